/* hc_counterbalance.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_COUNTERBALANCE_H
#define HC_COUNTERBALANCE_H
#include "core.h"
#include "hc_sqrt_law.h"

/* ---- counterbalance valve (load holding): free flow into the load through its check (cracking dp_cr, flow
 * k_c*(p_valve - p_load - dp_cr)); out of the load a main stage whose spring chamber is vented to the valve
 * port, opened by p_load - p_valve + r*p_pilot beyond p_set (r the pilot ratio): its opening
 * s = clamp((p_load - p_valve + r*p_pilot - p_set)/dp_open, 0, 1) (fully open dp_open beyond the setting) makes
 * an orifice s*k_o*sqrt(p_load - p_valve) (k_o = Q_r/sqrt(dp_r): the rated flow at the rated drop fully
 * open; the laminar transition dp_t near 0), flowing out of the load only (the seat is one-way). The two
 * paths are in parallel, each flowing while its guard holds; the mode says which: closed, check open, main
 * stage open, both. Flow valve -> load. */
enum { HC_CB_CLOSED, HC_CB_CHECK, HC_CB_RELIEF, HC_CB_BOTH };

/* the main stage's opening [0, 1] */
HH_INLINE double hc_cb_opening(double p_set, double r, double dp_open, double p_valve, double p_load, double p_pilot)
{
    double s = (p_load - p_valve + r * p_pilot - p_set) / dp_open;
    return s <= 0.0 ? 0.0 : s >= 1.0 ? 1.0 : s;
}

HH_INLINE double hc_cb_flow(int mode, double k_c, double dp_cr, double k_o, double p_set, double r, double dp_open,
                            double dp_t, double p_valve, double p_load, double p_pilot)
{
    double q = 0.0, dp = p_load - p_valve;
    if (mode == HC_CB_CHECK || mode == HC_CB_BOTH)
        q += k_c * (p_valve - p_load - dp_cr);
    if ((mode == HC_CB_RELIEF || mode == HC_CB_BOTH) && dp > 0.0)
        q -= hc_sqrt_law(k_o * hc_cb_opening(p_set, r, dp_open, p_valve, p_load, p_pilot), dp, dp_t);
    return q;
}

/* d(hc_cb_flow)/d(p_valve - p_load): the check's gain, the main stage's orifice and its opening's growth */
HH_INLINE double hc_cb_slope(int mode, double k_c, double k_o, double p_set, double r, double dp_open, double dp_t,
                             double p_valve, double p_load, double p_pilot)
{
    double g = 0.0, dp = p_load - p_valve, s;
    if (mode == HC_CB_CHECK || mode == HC_CB_BOTH)
        g += k_c;
    if ((mode == HC_CB_RELIEF || mode == HC_CB_BOTH) && dp > 0.0) {
        s = hc_cb_opening(p_set, r, dp_open, p_valve, p_load, p_pilot);
        g += hc_sqrt_law_slope(k_o * s, dp, dp_t);
        if (s > 0.0 && s < 1.0)
            g += k_o / dp_open * hc_sqrt_law(1.0, dp, dp_t);
    }
    return g;
}

HH_INLINE int hc_cb_mode(
double dp_cr, double p_set, double r, double p_valve, double p_load, double p_pilot)
{
    int check = p_valve - p_load > dp_cr, relief = p_load - p_valve + r * p_pilot > p_set;
    return check ? (relief ? HC_CB_BOTH : HC_CB_CHECK) : (relief ? HC_CB_RELIEF : HC_CB_CLOSED);
}

#endif
