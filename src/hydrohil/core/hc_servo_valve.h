/* hc_servo_valve.h: one component's law of the library (components.h, SPEC §12.3): the paper's servo-solenoid
 * 4-way valve (SPEC §3), the one source of its equations for the core (valve.c) and for circuits. */
#ifndef HC_SERVO_VALVE_H
#define HC_SERVO_VALVE_H
#include "core.h"
#include "hc_sqrt_law.h"

/* ---- pseudo-sections (eq 3): k1*x + k2 + sqrt(k3*x^2 + k4*x + k5), floored at zero [(l/min)/sqrt(bar)];
 * x the normalised spool position in [-1, 1]: As2 = section(x) (P->B) and A1t = section(x, kt) (A->T),
 * As1 = section(-x) (P->A) and A2t = section(-x, kt) (B->T); with the paper's k1 < 0 a section grows as its
 * argument falls, so +x opens P->A and B->T (the piston extends) and -x opens P->B and A->T. */
HH_INLINE double hc_section(double x, double k1, double k2, double k3, double k4, double k5)
{
    return hh_max(k1 * x + k2 + sqrt(hh_max(k3 * x * x + k4 * x + k5, 0.0)), 0.0);
}

/* hc_section(-x, ...), bit for bit (a sign change is exact: k1*(-x) = -(k1*x), k3*(-x)*(-x) = k3*x*x, a + (-b) =
 * a - b), from the products of x that hc_section(x, ...) of the same coefficients forms: an edge pair's two
 * sections (P->A and P->B, A->T and B->T) share them (the compiler computes each product once) */
HH_INLINE double hc_section_neg(double x, double k1, double k2, double k3, double k4, double k5)
{
    return hh_max(-(k1 * x) + k2 + sqrt(hh_max(k3 * x * x - k4 * x + k5, 0.0)), 0.0);
}

/* d(hc_section)/dx (0 where the section is floored at zero) */
HH_INLINE double hc_section_slope(double x, double k1, double k2, double k3, double k4, double k5)
{
    double q = k3 * x * x + k4 * x + k5;
    double r = q > 0.0 ? sqrt(q) : 0.0;
    if (k1 * x + k2 + r <= 0.0)
        return 0.0;
    return r > 0.0 ? k1 + (2.0 * k3 * x + k4) / (2.0 * r) : k1;
}

/* d(q)/dx of an edge's flow (eq 3 with the laminar transition) with the pressures held, the spool at x
 * (clamped to [-1, 1]: no change beyond); sign +1: s(x), -1: s(-x) (wear is constant). Times the spool's speed,
 * the flow's rate with the pressures held (a node sums its edges' before multiplying, as the core's chamber,
 * cylinder.c: quasi_static_drift) */
HH_INLINE double hc_servo_edge_slope(int sign, double x, double k1, double k2, double k3, double k4, double k5,
                                     double dp, double dp_t)
{
    double ds;
    if (x >= 1.0 || x <= -1.0)
        return 0.0;
    ds = sign * hc_section_slope(sign * x, k1, k2, k3, k4, k5);
    return hc_sqrt_law(ds * HH_LPM_PER_SQRT_BAR, dp, dp_t);
}


/* ---- the spool (SPEC §3.1, eq 1, Fig 3): a 2nd-order lag (wn, xi) of the normalised command ud with its
 * acceleration clamp +-la and its velocity limit +-lv (a limited integrator: no wind-up beyond it); (dxs,
 * dvs) and the limits acting (HH_SPOOL_ACTS_* bits: the acceleration clamp, the velocity limit, an end). */
HH_INLINE int hc_spool_limits(double xs, double vs, double ud, double wn, double xi, double la, double lv,
                              double *dxs, double *dvs)
{
    double a = wn * wn * (ud - xs) - 2.0 * xi * wn * vs;
    int acts = 0;
    if (a > la) {
        a = la;
        acts = HH_SPOOL_ACTS_ACC;
    } else if (a < -la) {
        a = -la;
        acts = HH_SPOOL_ACTS_ACC;
    }
    if ((vs >= lv && a > 0.0) || (vs <= -lv && a < 0.0)) {   /* limited integrator: no wind-up beyond +-Lv */
        a = 0.0;
        acts |= HH_SPOOL_ACTS_VEL;
    }
    if (xs >= 1.0 || xs <= -1.0)
        acts |= HH_SPOOL_ACTS_END;
    *dxs = vs;
    *dvs = a;
    return acts;
}

/* The spool's mechanical end in the hybrid model (x in [-1, 1]): at an end, motion and acceleration into it
 * are stopped (the step's projection then holds x = +-1, v = 0). */
HH_INLINE void hc_spool_end_block(double xs, double vs, double *dxs, double *dvs)
{
    if (xs >= 1.0 && vs >= 0.0) {
        *dxs = 0.0;
        *dvs = hh_min(*dvs, 0.0);
    } else if (xs <= -1.0 && vs <= 0.0) {
        *dxs = 0.0;
        *dvs = hh_max(*dvs, 0.0);
    }
}

/* After a (sub)step: the velocity held in +-lv and the mechanical ends plastic (x clamped to +-1, velocity
 * into the end stopped). */
HH_INLINE void hc_spool_project(double *xs, double *vs, double lv)
{
    if (*vs > lv)
        *vs = lv;
    else if (*vs < -lv)
        *vs = -lv;
    if (*xs >= 1.0) {
        *xs = 1.0;
        if (*vs > 0.0)
            *vs = 0.0;
    } else if (*xs <= -1.0) {
        *xs = -1.0;
        if (*vs < 0.0)
            *vs = 0.0;
    }
}

/* The spool's region (the logs' HH_SPOOL_*: an end, the velocity limit, the acceleration limit, linear). */
HH_INLINE int hc_spool_region(double xs, double vs, double ud, double wn, double xi, double la, double lv)
{
    double a;
    if (xs >= 1.0 || xs <= -1.0)
        return HH_SPOOL_AT_END;
    if (fabs(vs) >= lv * (1.0 - 1e-9))
        return HH_SPOOL_VEL_LIMITED;
    a = wn * wn * (ud - xs) - 2.0 * xi * wn * vs;
    return fabs(a) > la ? HH_SPOOL_ACC_LIMITED : HH_SPOOL_LINEAR;
}

/* The spool of a circuit's servo valve as expressions: its speed and acceleration with the limits and the end
 * block (the hybrid model), and its acceleration with the limits only (a continuous reference, whose ends are
 * stiff springs: hc_spool_stop at 1e5 rad/s, critically damped, as the core's reference). */
HH_INLINE double hc_servo_spool_speed(double xs, double vs)
{
    return (xs >= 1.0 && vs >= 0.0) || (xs <= -1.0 && vs <= 0.0) ? 0.0 : vs;
}

HH_INLINE double hc_servo_spool_accel(double xs, double vs, double ud, double wn, double xi, double la, double lv)
{
    double dx, dv;
    hc_spool_limits(xs, vs, ud, wn, xi, la, lv, &dx, &dv);
    hc_spool_end_block(xs, vs, &dx, &dv);
    return dv;
}

HH_INLINE double hc_spool_stop(double xs, double vs, double k, double c);

HH_INLINE double hc_servo_spool_accel_free(double xs, double vs, double ud, double wn, double xi, double la,
                                           double lv)
{
    double dx, dv;
    hc_spool_limits(xs, vs, ud, wn, xi, la, lv, &dx, &dv);
    return dv + hc_spool_stop(xs, vs, 1e10, 2e5);
}

/* the spool's end in a continuous reference: a stiff unilateral spring-damper beyond |x| = 1 [1/s^2] */
HH_INLINE double hc_spool_stop(double xs, double vs, double k, double c)
{
    if (xs > 1.0)
        return -hh_max(0.0, k * (xs - 1.0) + c * vs);
    if (xs < -1.0)
        return hh_max(0.0, k * (-1.0 - xs) - c * vs);
    return 0.0;
}

#endif
