/* hc_end_stops.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_END_STOPS_H
#define HC_END_STOPS_H
#include "core.h"

/* ---- actuators' end stops (the paper's travel statechart, SPEC §7, for any linear actuator): in a stop mode
 * the piston rests at the end (x and v held) until the net force pulls it off; a step that crosses an end
 * puts it there with v = 0 (plastic stop). Modes: free, at the retract end (x = 0), at the extend end. */
enum { HC_FREE, HC_AT_RETRACT, HC_AT_EXTEND };

/* dv/dt of a mass m under the net force f (extending positive) in end-stop mode `mode` */
HH_INLINE double hc_stop_accel(int mode, double f, double m)
{
    if ((mode == HC_AT_RETRACT && f <= 0.0) || (mode == HC_AT_EXTEND && f >= 0.0))
        return 0.0;
    return f / m;
}

HH_INLINE double hc_stop_speed(int mode, double v) { return mode == HC_FREE ? v : 0.0; }

/* The end-stop mode after a step, clamping *x and *v at a crossed end; f: the net force now. */
HH_INLINE int hc_stop_mode(int mode, double *x, double *v, double stroke, double f)
{
    if (*x <= 0.0 && (mode != HC_FREE || *v <= 0.0) && !(mode == HC_AT_RETRACT && f > 0.0)) {
        *x = 0.0;
        *v = 0.0;
        return HC_AT_RETRACT;
    }
    if (*x >= stroke && (mode != HC_FREE || *v >= 0.0) && !(mode == HC_AT_EXTEND && f < 0.0)) {
        *x = stroke;
        *v = 0.0;
        return HC_AT_EXTEND;
    }
    return HC_FREE;
}

/* Its events as data (hc_lugre_cylinder.h's guards for the paper's cylinder): in the free mode the piston
 * reaching an end (x >= 0, stroke - x >= 0), at a stop the net force pulling it off (-f at the retract end,
 * f at the extend end); +inf where a guard does not apply. */
enum { HC_STOP_G_RETRACT, HC_STOP_G_EXTEND, HC_STOP_G_LEAVE };

HH_INLINE double hc_stop_guard(int g, int mode, double x, double f, double stroke)
{
    if (mode == HC_FREE)
        return g == HC_STOP_G_RETRACT ? x : g == HC_STOP_G_EXTEND ? stroke - x : INFINITY;
    if (g != HC_STOP_G_LEAVE)
        return INFINITY;
    return mode == HC_AT_RETRACT ? -f : f;
}

/* the transition of guard g: x, v in place; returns the new mode */
HH_INLINE int hc_stop_reset(int g, double *x, double *v, double stroke)
{
    if (g == HC_STOP_G_LEAVE)
        return HC_FREE;
    *x = g == HC_STOP_G_RETRACT ? 0.0 : stroke;
    *v = 0.0;
    return g == HC_STOP_G_RETRACT ? HC_AT_RETRACT : HC_AT_EXTEND;
}

/* The continuous reference's end stops (SPEC §6): no modes; past an end a unilateral spring-damper of
 * stiffness k and damping c on the penetration pushes the piston back (F = max(0, k*d + c*dd/dt): it pushes,
 * never pulls; the paper's cylinder: k = c = 1e10, the core's reference.c). Returns the force [N] along +x at
 * (x, v). */
HH_INLINE double hc_stop_force(double x, double v, double stroke, double k, double c)
{
    double f;
    if (x < 0.0) {
        f = k * (-x) - c * v;
        return f > 0.0 ? f : 0.0;
    }
    if (x > stroke) {
        f = k * (x - stroke) + c * v;
        return f > 0.0 ? -f : 0.0;
    }
    return 0.0;
}

/* ... of any linear actuator of moved mass m: natural frequency HC_REF_STOP_WN, critically damped */
#define HC_REF_STOP_WN 1e4          /* rad/s: 50 kN on 200 kg penetrates 2.5 um */
HH_INLINE double hc_stop_penalty(double x, double v, double stroke, double m)
{
    return hc_stop_force(x, v, stroke, m * HC_REF_STOP_WN * HC_REF_STOP_WN, 2.0 * m * HC_REF_STOP_WN);
}

#endif
