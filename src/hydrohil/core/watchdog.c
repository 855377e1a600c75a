/* watchdog.c: the command path's saturation and watchdog with its safe state (SPEC §10; docs/protocol.md):
 * the paper's rig (rig.c) and every circuit's plant (the generated C includes it) trip and recover by the same
 * rule. Needs control.c (p_control) before it in the translation unit. */

#ifndef HH_CORE_LINKED   /* (hh.h's functions of this part; a translation unit linked with hh_core.c, which defines
                           them, leaves them out: core.h) */
void hh_watchdog_init(hh_watchdog *w)
{
    w->u_held = 0.0;
    w->k_delivered = 0;                 /* the watchdog counts from the start of the run */
    w->k_interfered = -((int64_t)1 << 62);
    w->delivered = 0;
    w->active = 0;
    w->trips = 0;
    w->trips_unexplained = 0;
    w->hold_x = 0.0;
}

/* The valve command of step k. `arrived`: a command u (ū) reached the plant for this step; it is saturated
 * to [-1, 1] and held. Silence longer than `timeout` [s] (counted in steps of h since the last arrival)
 * trips the safe state: ū = 0, or with `hold` a P loop (gain hold_kp [1/m]) on the position xp [m] at the
 * trip; the next arrival leaves it. A trip is *unexplained* when no injected fault held a command back since
 * the last arrival (k_interfered, set by hh_rig_step when a network or silence fault held one back). */
double hh_command_clamp(double u) { return hh_clamp(u, -1.0, 1.0); }

double hh_watchdog_command(hh_watchdog *w, int64_t k, int arrived, double u, double h, double timeout, int hold,
                           double hold_kp, double xp)
{
    int silent;
    if (arrived) {
        w->u_held = hh_command_clamp(u);
        w->k_delivered = k;
        w->delivered++;
    }
    silent = (double)(k - w->k_delivered) * h > timeout + 1e-12;
    if (silent && !w->active) {
        w->active = 1;
        w->trips++;
        if (w->k_interfered <= w->k_delivered)
            w->trips_unexplained++;
        w->hold_x = xp;
    } else if (!silent && w->active) {
        w->active = 0;
    }
    if (w->active)
        return hold ? p_control(hold_kp, w->hold_x, xp) : 0.0;
    return w->u_held;
}
#endif
