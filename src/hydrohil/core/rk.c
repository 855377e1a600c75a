/* rk.c: fixed-step explicit Runge-Kutta tableaus and the generic step (see rk.h). */
#include "rk.h"

static const hh_tableau HH_TABLEAUS[HH_NMETHODS] = {
    {"euler", 1, 1, {{0.0}}, {1.0}, 2.0},
    {"heun", 2, 2, {{0.0}, {1.0}}, {0.5, 0.5}, 2.0},
    /* Bogacki-Shampine 3(2), Simulink's "ode3"; as a fixed-step method only its 3rd-order stages */
    {"rk3", 3, 3, {{0.0}, {0.5}, {0.0, 0.75}}, {2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0}, 2.51},
    {"rk4", 4, 4, {{0.0}, {0.5}, {0.0, 0.5}, {0.0, 0.0, 1.0}}, {1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0}, 2.79},
};

/* One explicit RK step of size h from y0 -> yout. Always inlined with a constant tableau and right-hand
 * side, so the model is inlined into each stage. Whether the stage loops unroll and the zero tableau
 * coefficients drop out is the compiler's choice: gcc 12 at -O3 keeps work for them (a prototype with the
 * stages written out saved 73 instructions an RK3 step, issue #29). */
HH_INLINE void rk_step(const hh_tableau *tab, hh_rhs rhs, const double *y0, double h, double ud,
                       const int64_t *m, const double *p, const double *sc, double *yout)
{
    double k[HH_MAX_STAGES][HH_NY], ytmp[HH_NY];
    int s, j, i;
    for (s = 0; s < tab->stages; s++) {
        for (i = 0; i < HH_NY; i++) {
            double acc = y0[i];
            for (j = 0; j < s; j++)
                if (tab->a[s][j] != 0.0)
                    acc += h * tab->a[s][j] * k[j][i];
            ytmp[i] = acc;
        }
        rhs(ytmp, ud, m, p, sc, k[s]);
    }
    for (i = 0; i < HH_NY; i++) {
        double acc = y0[i];
        for (s = 0; s < tab->stages; s++)
            acc += h * tab->b[s] * k[s][i];
        yout[i] = acc;
    }
}
