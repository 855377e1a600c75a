/* hc_counterbalance.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_COUNTERBALANCE_H
#define HC_COUNTERBALANCE_H
#include "core.h"

/* ---- counterbalance valve (load holding): free flow into the load through its check (cracking dp_cr, flow
 * k_c*(p_valve - p_load - dp_cr)); out of the load a relief path whose spring chamber is vented to the valve
 * port: it opens when p_load - p_valve + r*p_pilot >= p_set (r the pilot ratio) and passes k_r times that
 * excess from the load to the valve port, only while p_load > p_valve (the flow goes to 0 across the last
 * dp_t, as an orifice's laminar end: continuous). The two paths are in parallel, each flowing while its guard
 * holds; the mode says which: closed, check open, relief open, both. Flow valve -> load. */
enum { HC_CB_CLOSED, HC_CB_CHECK, HC_CB_RELIEF, HC_CB_BOTH };

HH_INLINE double hc_cb_flow(int mode, double k_c, double dp_cr, double k_r, double p_set, double r, double dp_t,
                            double p_valve, double p_load, double p_pilot)
{
    double q = 0.0, dp = p_load - p_valve;
    if (mode == HC_CB_CHECK || mode == HC_CB_BOTH)
        q += k_c * (p_valve - p_load - dp_cr);
    if ((mode == HC_CB_RELIEF || mode == HC_CB_BOTH) && dp > 0.0)
        q -= k_r * (dp + r * p_pilot - p_set) * (dp < dp_t ? dp / dp_t : 1.0);
    return q;
}

HH_INLINE int hc_cb_mode(double dp_cr, double p_set, double r, double p_valve, double p_load, double p_pilot)
{
    int check = p_valve - p_load > dp_cr, relief = p_load - p_valve + r * p_pilot > p_set;
    return check ? (relief ? HC_CB_BOTH : HC_CB_CHECK) : (relief ? HC_CB_RELIEF : HC_CB_CLOSED);
}

#endif
