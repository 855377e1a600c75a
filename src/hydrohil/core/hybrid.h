/* hybrid.h: the hybrid valve + cylinder model (SPEC §6): continuous modes plus discrete transitions.
 *
 * Modes (m[HH_NM]): travel FREE (0 < xp < L) | AT_RETRACT (xp = 0, vp = 0) | AT_EXTEND (xp = L, vp = 0);
 * friction (meaningful in FREE) STICK (presliding spring: Ff = s0*z + (s1 + Kv)*vp, dz = vp) |
 * SLIP_POS / SLIP_NEG (steady-state curve eq 25 of that direction, z held); spool linear | acc_limited |
 * vel_limited | at_end (recorded; the saturations act in the flow).
 *
 * Guards g(y) >= 0 hold while a mode is valid; a sign change inside a step is an event:
 *
 *   guard               g                            reset when g crosses zero
 *   G_RETRACT (FREE)    xp                           xp := 0, vp := 0, AT_RETRACT, z := bristle state
 *   G_EXTEND (FREE)     L - xp                       xp := L, vp := 0, AT_EXTEND, z := bristle state
 *   G_BREAK_POS (STICK) Fs_pos - s0*z                SLIP_POS
 *   G_BREAK_NEG (STICK) Fs_neg + s0*z                SLIP_NEG
 *   G_REVERSE (SLIP_d)  d*vp                         vp := 0, STICK, z := d*Fs_d/s0 (Ff continuous)
 *   G_LEAVE (at a stop) -(F - s0*z) at retract,      FREE + STICK (F: hydraulic + gravity + load)
 *                       F - s0*z at extend
 *
 * Events are located by linear interpolation of g over the step (bounded, fixed work): the step is redone
 * to the event instant, the reset applied and the rest of the step integrated in the new mode, at most
 * HH_MAX_EVENTS times a step (worst case 2*HH_MAX_EVENTS + 1 RK substeps, a known bound).
 *
 * Stiff chambers (SPEC §3.2, §6.1 pitfall 2). A chamber's pressure relaxes towards its quasi-static value
 * Pq (where its net valve and leakage inflow balances the piston's displacement flow) at the rate
 * lambda = beta/V*g, g = dq_s/dp + dq_t/dp + g_lkc: unbounded as an orifice's pressure drop goes to zero.
 * At the start of each step, where lambda*h exceeds HH_LAMBDA_H_MAX (1.5: inside every tableau's
 * real-axis stability interval; RK3's step response stays monotone) only that relaxation is slowed, to
 * lambda*h = HH_LAMBDA_H_MAX (factor c < 1), while Pq moves as it physically does:
 *     dP/dt = c*beta/V*(F(P) -/+ A*vp) + (1 - c)*dPq/dt,  dPq/dt = (dF/dxs*dxs/dt -/+ A*dvp/dt)/g
 * (cylinder.c quasi_static_drift; g at the step start). Flows, equilibria, steady motion and the
 * hydraulic spring are exact; a deviation from Pq decays at c*lambda instead of lambda (README, "the model").
 */
#ifndef HH_HYBRID_H
#define HH_HYBRID_H
#include "cylinder.h"
#include "friction.h"
#include "rk.h"

HH_INLINE void hybrid_rhs(const double *y, double ud, const int64_t *m, const double *p, const double *sc,
                       double *dy);
HH_INLINE double friction_force(const double *y, const int64_t *m, const double *p);
static int hybrid_step(int method, double *y, int64_t *m, const double *p, double ud, double h);

#endif
