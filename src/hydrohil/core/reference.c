/* reference.c: the continuous reference model, SPEC §6 (see reference.h). */
#include "reference.h"

/* Unilateral spring-damper end-stop force along +x [N]. */
HH_INLINE double end_stop_force(double xp, double vp, const double *p)
{
    double over;
    if (xp < 0.0)
        return hh_max(0.0, p[HH_STOP_K] * (-xp) + p[HH_STOP_C] * (-vp));
    over = xp - p[HH_CYLINDER_STROKE];
    if (over > 0.0)
        return -hh_max(0.0, p[HH_STOP_K] * over + p[HH_STOP_C] * vp);
    return 0.0;
}

/* dy/dt of the continuous reference model; state layout as the hybrid model (m and sc unused). */
HH_INLINE void reference_rhs(const double *y, double ud, const int64_t *m, const double *p, const double *sc,
                          double *dy)
{
    double vp = y[HH_VP], dz, ff;
    (void)m;
    (void)sc;
    spool_derivatives(y[HH_XS], y[HH_VS], ud, p, &dy[HH_XS], &dy[HH_VS]);
    dy[HH_VS] += spool_stop_acceleration(y[HH_XS], y[HH_VS], p);
    chamber_pressure_rates(y[HH_XS], y[HH_P1], y[HH_P2], y[HH_XP], vp, p, p[HH_DP_LAM_REF], 1.0, 1.0,
                           &dy[HH_P1], &dy[HH_P2]);
    /* cavitation (SPEC §4): a chamber does not fall below HH_P_MIN (the hybrid model projects onto it) */
    if (y[HH_P1] <= HH_P_MIN && dy[HH_P1] < 0.0)
        dy[HH_P1] = 0.0;
    if (y[HH_P2] <= HH_P_MIN && dy[HH_P2] < 0.0)
        dy[HH_P2] = 0.0;
    ff = lugre(vp, y[HH_Z], p, &dz);
    dy[HH_Z] = dz;
    dy[HH_XP] = vp;
    dy[HH_VP] = (external_force(y[HH_P1], y[HH_P2], p) - ff + end_stop_force(y[HH_XP], vp, p)) / p[HH_LOAD_MASS];
}

/* One fixed step of the continuous model (the explicit runs of maxstep). */
static void continuous_step(int method, double *y, const double *p, double ud, double h)
{
    static const int64_t m0[HH_NM] = {0, 0, 0};
    static const double sc1[4] = {1.0, 1.0, 0.0, 0.0};
    double y1[HH_NY];
    int i;
    switch (method) {
    case HH_EULER: rk_step(&HH_TABLEAUS[HH_EULER], reference_rhs, y, h, ud, m0, p, sc1, y1); break;
    case HH_HEUN: rk_step(&HH_TABLEAUS[HH_HEUN], reference_rhs, y, h, ud, m0, p, sc1, y1); break;
    case HH_RK4: rk_step(&HH_TABLEAUS[HH_RK4], reference_rhs, y, h, ud, m0, p, sc1, y1); break;
    default: rk_step(&HH_TABLEAUS[HH_RK3], reference_rhs, y, h, ud, m0, p, sc1, y1); break;
    }
    for (i = 0; i < HH_NY; i++)
        y[i] = y1[i];
}
