/* hc_sqrt_law.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_SQRT_LAW_H
#define HC_SQRT_LAW_H
#include "core.h"

/* ---- square-root law with the laminar transition of §3.2: q = k*sign(dp)*sqrt|dp| for |dp| >= dp_t; below,
 * the odd cubic k*sqrt(dp_t)*r*(5 - r^2)/4, r = dp/dp_t (same value and slope at dp_t). k [m^3/s/sqrt(Pa)], dp_t > 0
 * (every law's transition is validated so). Returns the flow and puts its slope d(q)/d(dp) [m^3/s/Pa] (>= 0, the
 * law's conductance) in *g, from one square root: a step's first stage needs both (generate.py's rhs_start); a
 * caller that reads one of them inlines only its work (hc_sqrt_law, hc_sqrt_law_slope). */
HH_INLINE double hc_sqrt_law_g(double k, double dp, double dp_t, double *g)
{
    double r, s;
    if (dp >= dp_t) {
        s = sqrt(dp);
        *g = 0.5 * k / s;
        return k * s;
    }
    if (dp <= -dp_t) {
        s = sqrt(-dp);
        *g = 0.5 * k / s;
        return -k * s;
    }
    r = dp / dp_t;
    *g = k / sqrt(dp_t) * (1.25 - 0.75 * r * r);
    return k * sqrt(dp_t) * r * (1.25 - 0.25 * r * r);
}

/* the law's flow */
HH_INLINE double hc_sqrt_law(double k, double dp, double dp_t)
{
    double g;
    return hc_sqrt_law_g(k, dp, dp_t, &g);
}

/* the law's slope (its conductance) */
HH_INLINE double hc_sqrt_law_slope(double k, double dp, double dp_t)
{
    double g;
    hc_sqrt_law_g(k, dp, dp_t, &g);
    return g;
}

#endif
