/* hc_relief_valve.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_RELIEF_VALVE_H
#define HC_RELIEF_VALVE_H
#include "core.h"

/* ---- direct-operated relief valve, cracking at p_cr, Q_r at p_r > p_cr: K = Q_r/(p_r - p_cr) -------------
 * Modes: closed (q = 0) while dp <= p_cr; open: q = K*(dp - p_cr). The guard dp = p_cr switches both ways.
 * The check valve is the same law (cracking dp_cr, one direction only). */
enum { HC_CLOSED, HC_OPEN };
HH_INLINE double hc_relief_flow(int mode, double k, double p_cr, double dp) { return mode == HC_OPEN ? k * (dp - p_cr) : 0.0; }

HH_INLINE int hc_relief_mode(int mode, double p_cr, double dp)
{
    (void)mode;
    return dp > p_cr ? HC_OPEN : HC_CLOSED;
}

#endif
