/* hc_node.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_NODE_H
#define HC_NODE_H
#include "core.h"

/* ---- a node's pressure: dp/dt = sum(q_in) / C, C = V/beta + the accumulators' capacitances ------------- */
HH_INLINE double hc_node_rate(double q_in, double volume, double beta, double c_extra)
{
    return q_in / (volume / beta + c_extra);
}

/* the same for a node of oil alone (no accumulator), its rate scaled by c (the stiff-node form's, below; 1:
 * the plain rate): dp/dt = c*beta/V * sum(q_in), one division fewer, in the order of the core's chamber
 * (cylinder.c), so that the paper's circuit steps as the core does, bit for bit from the same state */
HH_INLINE double hc_node_rate_oil(double c, double q_in, double volume, double beta)
{
    return c * beta / volume * q_in;
}

/* ---- a stiff node (the core's stiff chambers, hybrid.h, for any node): its pressure relaxes towards its
 * quasi-static value Pq (where its flows balance) at lambda = g/C, g = -d(q_in)/dp the conductance of the
 * flows at it. Where lambda*h exceeds HC_LAMBDA_H_MAX at a step's start (1.5, the core's default: inside
 * every tableau's real-axis stability interval), only that relaxation is slowed to lambda*h = HC_LAMBDA_H_MAX
 * (factor c < 1) while Pq moves as it physically does: dp/dt = c*q_in/C + (1 - c)/g * dq_in/dt|p held (the
 * flows' rate with the pressures held: spools and pistons moving). sc[0] = c, sc[1] = (1 - c)/g (0: not
 * stiff).
 * Nodes coupled to each other: the slowed Jacobian -diag(c/C)*G (G the conductances, symmetric) has the
 * eigenvalues of the symmetric diag(sqrt(c/C))*G*diag(sqrt(c/C)), whose Gershgorin row i reaches
 * r_i = c_i*l_i + sum_j sqrt(c_i*c_j/(C_i*C_j))*g_ij*h. Where r_i > HC_LAMBDA_H_ROW, c_i is cut by
 * HC_LAMBDA_H_ROW/r_i (the row's own part to the bound, its coupling part by the root of it: a row may stay
 * above the bound by that difference when its neighbours are cut too, which Gershgorin's own margin covers
 * in the cases tested); every coupled mode within every tableau's real-axis interval (Euler's 2 the
 * smallest). A node coupled to a large or slow one, or by leakage (the paper's chambers), keeps the first
 * rule's c. In three passes: hc_stiff_first (c_i, C_i), hc_stiff_pair
 * per flow between two pressure nodes, hc_stiff_last. */
#define HC_LAMBDA_H_MAX 1.5
#define HC_LAMBDA_H_ROW 1.9
HH_INLINE void hc_stiff_first(double g, double volume, double beta, double c_extra, double h, double *sc)
{
    double cap = volume / beta + c_extra;
    double l = c_extra == 0.0 ? beta / volume * g * h : g / cap * h;   /* (oil alone: the core's chamber's order) */
    sc[0] = l > HC_LAMBDA_H_MAX ? HC_LAMBDA_H_MAX / l : 1.0;   /* c */
    sc[1] = cap;                                              /* (C, until hc_stiff_last) */
    sc[2] = sc[0] * l;                                        /* the row's reach r */
}

HH_INLINE void hc_stiff_pair(double g_ij, double h, double *sc_i, double *sc_j)
{
    double w = sqrt(sc_i[0] * sc_j[0] / (sc_i[1] * sc_j[1])) * g_ij * h;
    sc_i[2] += w;
    sc_j[2] += w;
}

HH_INLINE void hc_stiff_last(double g, double *sc)
{
    double c = sc[0], r = sc[2];
    if (r > HC_LAMBDA_H_ROW)
        c *= HC_LAMBDA_H_ROW / r;
    sc[0] = c;
    sc[1] = c < 1.0 ? (1.0 - c) / g : 0.0;
    sc[2] = r;
}




#endif
