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

#endif
