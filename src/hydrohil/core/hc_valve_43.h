/* hc_valve_43.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_VALVE_43_H
#define HC_VALVE_43_H
#include "core.h"
#include "hc_sqrt_law.h"

/* ---- 4/3 valve by geometry (SPEC §12.3): spool x [m] of a 2nd-order lag to u*x_max (wn, xi), clamped at
 * +-x_max; each edge open by s = max(0, +-x - lap) (lap < 0: underlap) plus a leakage opening; the flow of an
 * edge k*(s + s_leak)*sqrt-law with k = Cq*w*sqrt(2/rho), w the area gradient [m]. */
HH_INLINE double hc_edge_opening(double x, double lap, double leak) { return (x > lap ? x - lap : 0.0) + leak; }

HH_INLINE double hc_spool_accel(double x, double v, double x_ref, double wn, double xi)
{
    return wn * wn * (x_ref - x) - 2.0 * xi * wn * v;
}

/* the open-centre bypass P -> T of a 6/3 valve: fully open at x = 0, closed at |x| >= x_c */
HH_INLINE double hc_centre_opening(double x, double x_c) { return x_c > fabs(x) ? x_c - fabs(x) : 0.0; }

/* the rates of the openings [m/s] with the spool moving at dx (an edge's opening of +-x: sign +-1) */
HH_INLINE double hc_edge_opening_rate(int sign, double x, double lap, double dx) { return sign * x > lap ? sign * dx : 0.0; }
HH_INLINE double hc_centre_opening_rate(double x, double x_c, double dx)
{
    return x_c > fabs(x) ? (x > 0.0 ? -dx : x < 0.0 ? dx : 0.0) : 0.0;
}


/* the spool clamped at +-x_max after a step (plastic: v = 0 at the end) */
HH_INLINE void hc_spool_clamp(double *x, double *v, double x_max)
{
    if (*x > x_max) {
        *x = x_max;
        *v = *v > 0.0 ? 0.0 : *v;
    } else if (*x < -x_max) {
        *x = -x_max;
        *v = *v < 0.0 ? 0.0 : *v;
    }
}

/* The continuous reference's spool ends: past +-x_max a stiff unilateral spring-damper (20 wn, critically damped)
 * instead of the clamp. Returns an acceleration [m/s^2]. */
HH_INLINE double hc_spool_penalty(double x, double v, double x_max, double wn)
{
    const double ws = 20.0 * wn;
    double a;
    if (x > x_max) {
        a = ws * ws * (x - x_max) + 2.0 * ws * v;
        return a > 0.0 ? -a : 0.0;
    }
    if (x < -x_max) {
        a = ws * ws * (-x_max - x) - 2.0 * ws * v;
        return a > 0.0 ? a : 0.0;
    }
    return 0.0;
}

#endif
