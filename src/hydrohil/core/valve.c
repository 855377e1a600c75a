/* valve.c: servo-solenoid valve, SPEC §3 (see valve.h). */
#include "valve.h"

/* One pseudo-section of eq 3 (hc_servo_valve.h) of the coefficients k[0..4]. */
HH_INLINE double section(double x, const double *k) { return hc_section(x, k[0], k[1], k[2], k[3], k[4]); }

/* (As1, As2, A1t, A2t) at spool position x (clamped to [-1, 1]), eq 3, plus the worn-lands leakage
 * section p[HH_VALVE_WEAR] on each (0 unless a valve-leakage fault is active). */
HH_INLINE hh_sections pseudo_sections(double x, const double *p)
{
    const double *k = p + HH_VALVE_K1, *kt = p + HH_VALVE_KT1;
    double w = p[HH_VALVE_WEAR];
    hh_sections s;
    x = hh_clamp(x, -1.0, 1.0);
    s.as2 = section(x, k) + w;
    s.as1 = section(-x, k) + w;
    s.a1t = section(x, kt) + w;
    s.a2t = section(-x, kt) + w;
    return s;
}

/* d/dx of one section (0 where it is floored at zero; hc_servo_valve.h). */
HH_INLINE double section_slope(double x, const double *k) { return hc_section_slope(x, k[0], k[1], k[2], k[3], k[4]); }

/* (dAs1/dx, dAs2/dx, dA1t/dx, dA2t/dx) of eq 3; 0 beyond the clamp at |x| = 1 (wear is constant). */
HH_INLINE hh_sections pseudo_section_slopes(double x, const double *p)
{
    const double *k = p + HH_VALVE_K1, *kt = p + HH_VALVE_KT1;
    hh_sections s = {0.0, 0.0, 0.0, 0.0};
    if (x >= 1.0 || x <= -1.0)
        return s;
    s.as2 = section_slope(x, k);
    s.as1 = -section_slope(-x, k);
    s.a1t = section_slope(x, kt);
    s.a2t = -section_slope(-x, kt);
    return s;
}

/* Flow [m^3/s] through a pseudo-section `area` [(l/min)/sqrt(bar)] under dp [Pa] (SPEC §3.2): turbulent
 * q = K*sign(dp)*sqrt(|dp|) for |dp| >= dp_t exactly; below, the odd cubic K*sqrt(dp_t)*r*(5 - r^2)/4,
 * r = dp/dp_t, which meets it with the same value and slope (C1), slope 1.25*K/sqrt(dp_t) at 0. */
HH_INLINE double orifice_flow(double area, double dp, double dp_t)
{
    return hc_sqrt_law(area * HH_LPM_PER_SQRT_BAR, dp, dp_t);     /* the library's law (components.h) */
}

/* d(orifice_flow)/d(dp) [m^3/s/Pa] (>= 0). */
HH_INLINE double orifice_slope(double area, double dp, double dp_t)
{
    return hc_sqrt_law_slope(area * HH_LPM_PER_SQRT_BAR, dp, dp_t);     /* the library's (components.h) */
}

/* (dxs/dt, dvs/dt) of the limited second-order spool (SPEC §3.1, eq 1, Fig 3); returns the limits acting
 * (HH_SPOOL_ACTS_* bits): the acceleration clamp, the limited integrator at ±Lv, the spool at an end. */
HH_INLINE int spool_limits(double xs, double vs, double ud, const double *p, double *dxs, double *dvs)
{
    return hc_spool_limits(xs, vs, ud, p[HH_SPOOL_WN], p[HH_SPOOL_XI], p[HH_SPOOL_LA], p[HH_SPOOL_LV], dxs, dvs);
}

/* spool_limits as one spool mode (the logs' HH_SPOOL_*: an end before the velocity limit before the
 * acceleration limit). */
HH_INLINE int spool_derivatives(double xs, double vs, double ud, const double *p, double *dxs, double *dvs)
{
    int acts = spool_limits(xs, vs, ud, p, dxs, dvs);
    if (acts & HH_SPOOL_ACTS_END)
        return HH_SPOOL_AT_END;
    if (acts & HH_SPOOL_ACTS_VEL)
        return HH_SPOOL_VEL_LIMITED;
    return acts ? HH_SPOOL_ACC_LIMITED : HH_SPOOL_LINEAR;
}

/* The spool's mechanical end in the hybrid model (SPEC §3.1: x̄s in [-1, 1]): at an end, motion and
 * acceleration into it are stopped (the step's projection then holds x̄s = ±1, v̄s = 0). */
HH_INLINE void spool_end_block(double xs, double vs, double *dxs, double *dvs) { hc_spool_end_block(xs, vs, dxs, dvs); }

/* The spool of the hybrid model (SPEC §3.1): eq 1 with its limits and its mechanical ends, the one
 * right-hand side of the plant's spool and of identification's sine responses; returns spool_limits' bits. */
HH_INLINE int spool_rhs(double xs, double vs, double ud, const double *p, double *dxs, double *dvs)
{
    int acts = spool_limits(xs, vs, ud, p, dxs, dvs);
    spool_end_block(xs, vs, dxs, dvs);
    return acts;
}

/* After a (sub)step of the hybrid spool: the velocity held in ±Lv (the limited integrator) and the
 * mechanical ends plastic (x̄s clamped to ±1, velocity into the end stopped). */
HH_INLINE void spool_project(double *xs, double *vs, double lv) { hc_spool_project(xs, vs, lv); }

/* The spool's end in the continuous reference model: a stiff unilateral spring-damper on penetration
 * beyond |x̄s| = 1 (HH_SPOOL_STOP_K, HH_SPOOL_STOP_C) [1/s^2]. */
HH_INLINE double spool_stop_acceleration(double xs, double vs, const double *p)
{
    return hc_spool_stop(xs, vs, p[HH_SPOOL_STOP_K], p[HH_SPOOL_STOP_C]);
}
