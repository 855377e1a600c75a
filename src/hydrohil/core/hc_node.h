/* hc_node.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_NODE_H
#define HC_NODE_H
#include "core.h"

/* ---- a node's pressure: dp/dt = sum(q_in) / C, C = V/beta + the accumulators' capacitances ------------- */
HH_INLINE double hc_node_rate(double q_in, double volume, double beta, double c_extra)
{
    return q_in / (volume / beta + c_extra);
}

#endif
