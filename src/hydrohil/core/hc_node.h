/* hc_node.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_NODE_H
#define HC_NODE_H
#include "core.h"

/* ---- a node's pressure: dp/dt = sum(q_in) / C, C = V/beta + the accumulators' capacitances ------------- */
HH_INLINE double hc_node_rate(double q_in, double volume, double beta, double c_extra)
{
    return q_in / (volume / beta + c_extra);
}

/* ---- a stiff node (the core's stiff chambers, hybrid.h, for any node): its pressure relaxes towards its
 * quasi-static value Pq (where its flows balance) at lambda = g/C, g = -d(q_in)/dp the conductance of the
 * flows at it. Where lambda*h exceeds HC_LAMBDA_H_MAX at a step's start (1.5, the core's default: inside
 * every tableau's real-axis stability interval), only that relaxation is slowed to lambda*h = HC_LAMBDA_H_MAX
 * (factor c < 1) while Pq moves as it physically does: dp/dt = c*q_in/C + (1 - c)/g * dq_in/dt|p held (the
 * flows' rate with the pressures held: spools and pistons moving). sc[0] = c, sc[1] = (1 - c)/g (0: not
 * stiff). Nodes coupled to each other (g_n: the conductance of the flows between this node and other
 * pressure nodes) are slowed further where needed so that c*(g + g_n)/C*h <= HC_LAMBDA_H_ROW: every
 * Gershgorin disc of the slowed nodes' Jacobian, hence every coupled mode, inside every tableau's real-axis
 * interval (Euler's 2 the smallest); a node coupled by leakage alone (the paper's chambers) keeps the first
 * rule's c. */
#define HC_LAMBDA_H_MAX 1.5
#define HC_LAMBDA_H_ROW 1.9
HH_INLINE void hc_stiff_node(double g, double g_n, double volume, double beta, double c_extra, double h, double *sc)
{
    double cap = volume / beta + c_extra, l = g / cap * h, l_row = (g + g_n) / cap * h;
    double c = l > HC_LAMBDA_H_MAX ? HC_LAMBDA_H_MAX / l : 1.0;
    if (c * l_row > HC_LAMBDA_H_ROW)
        c = HC_LAMBDA_H_ROW / l_row;
    sc[0] = c;
    sc[1] = c < 1.0 ? (1.0 - c) / g : 0.0;
}



#endif
