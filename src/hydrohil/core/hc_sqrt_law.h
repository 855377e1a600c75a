/* hc_sqrt_law.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_SQRT_LAW_H
#define HC_SQRT_LAW_H
#include "core.h"

/* ---- square-root law with the laminar transition of §3.2: q = k*sign(dp)*sqrt|dp| for |dp| >= dp_t; below,
 * the odd cubic k*sqrt(dp_t)*r*(5 - r^2)/4, r = dp/dp_t (same value and slope at dp_t). k [m^3/s/sqrt(Pa)]. */
HH_INLINE double hc_sqrt_law(double k, double dp, double dp_t)
{
    double r;
    if (dp >= dp_t)
        return k * sqrt(dp);
    if (dp <= -dp_t)
        return -k * sqrt(-dp);
    r = dp / dp_t;
    return k * sqrt(dp_t) * r * (1.25 - 0.25 * r * r);
}

/* d(hc_sqrt_law)/d(dp) [m^3/s/Pa] (>= 0): the conductance of the law at dp */
HH_INLINE double hc_sqrt_law_slope(double k, double dp, double dp_t)
{
    double a = fabs(dp), r;
    if (a >= dp_t)
        return 0.5 * k / sqrt(a);
    r = dp / dp_t;
    return k / sqrt(dp_t) * (1.25 - 0.75 * r * r);
}


#endif
