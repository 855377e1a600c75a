"""The hybrid valve + cylinder model (SPEC §6): continuous modes plus discrete transitions.

Modes (``m`` vector, codes in :mod:`hydrohil.models.layout`):

* travel: FREE (0 < xp < L) | AT_RETRACT (xp = 0, vp = 0) | AT_EXTEND (xp = L, vp = 0)
* friction (only meaningful in FREE): STICK (presliding spring: Ff = s0*z + (s1 + Kv)*vp, dz = vp)
  | SLIP_POS / SLIP_NEG (steady-state curve eq 25 of that direction, z held)
* spool: linear | acc_limited | vel_limited | at_end (recorded; the saturations are in the flow)

Guards g(y) >= 0 hold while a mode is valid; a sign change inside a step is an event:

====================  ==========================  ==============================================
guard                 g                           reset when g crosses zero
====================  ==========================  ==============================================
G_RETRACT (FREE)      xp                          xp := 0, vp := 0, AT_RETRACT, z := bristle state
G_EXTEND (FREE)       L - xp                      xp := L, vp := 0, AT_EXTEND, z := bristle state
G_BREAK_POS (STICK)   Fs_pos - s0*z               SLIP_POS
G_BREAK_NEG (STICK)   Fs_neg + s0*z               SLIP_NEG
G_REVERSE (SLIP_d)    d*vp                        vp := 0, STICK, z := d*Fs_d/s0 (Ff continuous)
G_LEAVE (at a stop)   -(F - s0*z) at retract,     FREE + STICK (F: hydraulic + gravity + load)
                      F - s0*z at extend
====================  ==========================  ==============================================

Events are located by linear interpolation of g over the step (bounded, fixed work): the step is
redone to the event instant, the reset applied, and the rest of the step integrated in the new mode,
at most ``MAX_EVENTS`` times a step (worst case 2*MAX_EVENTS + 1 RK substeps, a known bound).

Stiff chambers (SPEC §3.2, §6.1 pitfall 2). A chamber's pressure relaxes towards its quasi-static value
P* (where its net valve and leakage inflow balances the piston's displacement flow) at the rate
lambda = beta/V * g, g = dq_s/dp + dq_t/dp + g_lkc: unbounded as an orifice's pressure drop goes to zero,
large for a small chamber behind a wide-open valve. At the start of each step, where lambda*h exceeds
LAMBDA_H_MAX (1.5: inside every tableau's real-axis stability interval, and RK3's step response stays
monotone), only that relaxation is slowed, to lambda*h = LAMBDA_H_MAX (factor c < 1), while P* itself
moves as it physically does:

    dP/dt = c * beta/V * (F(P) -/+ A*vp) + (1 - c) * dP*/dt,   dP*/dt = (dF/dxs*dxs/dt -/+ A*dvp/dt)/g

(cylinder.quasi_static_drift; g taken at the step start). A deviation from P* decays at c*lambda instead of
lambda; the pressure's response to the piston and the spool (the hydraulic spring and the valve's
pressure gain) is physical, its lag behind a moving P* (-dP*/dt/lambda) exact, and flows, equilibria and
steady motion exact (the orifice law is untouched above its 1 bar laminar region). Two earlier versions:
widening the orifices' laminar region (distorted the flow itself up to ~10x the width: steady speeds up to
7 % slow at low supply pressure) and scaling the whole capacitance beta/V by c (slowed the hydraulic
spring A*vp term too) — README, "the model".
"""

from __future__ import annotations

import numpy as np
from hydrohil._jit import jit, specialize

from hydrohil.models.cylinder import (P_MIN, bulk_modulus, chamber_pressure_rates, external_force,
                                      quasi_static_drift, volumes)
from hydrohil.models.friction import slip_friction, stribeck, viscous
from hydrohil.models.layout import (AT_EXTEND, AT_RETRACT, BURST1, BURST2, DP_LAM, FREE, FS_NEG, FS_POS, G_LKC, LA,
                                    LAMBDA_H_MAX, LV, M_FRICTION, M_SPOOL, M_TRAVEL, MASS, P1, P2, PS, PT, SIGMA0,
                                    SIGMA1, SLIP_NEG, SLIP_POS, SPOOL_ACC_LIMITED, SPOOL_AT_END, SPOOL_LINEAR,
                                    SPOOL_VEL_LIMITED, STICK, STROKE, VP, VS, WN, XI, XP, XS, Z)
from hydrohil.models.valve import orifice_slope, pseudo_sections, spool_derivatives, spool_end_block
from hydrohil.solvers.fixed_step import make_rk_step
from hydrohil.solvers.tableaus import MAX_STAGES, Tableau

MAX_EVENTS = 3
G_NONE, G_RETRACT, G_EXTEND, G_BREAK_POS, G_BREAK_NEG, G_REVERSE, G_LEAVE = -1, 0, 1, 2, 3, 4, 5
GUARD_NAMES = ("retract_stop", "extend_stop", "breakaway_pos", "breakaway_neg", "reversal", "leave_stop")


@jit(inline=True)
def hybrid_rhs(y, ud, m, p, sc, dy):
    """dy/dt of the hybrid model in the modes ``m`` (SPEC §3-§6); ``sc``: the step's stiff-chamber constants
    (:func:`stiff_chamber_constants`)."""
    dxs, dvs, _ = spool_derivatives(y[XS], y[VS], ud, p)
    dy[XS], dy[VS] = spool_end_block(y[XS], y[VS], dxs, dvs)
    travel = m[M_TRAVEL]
    vp = y[VP] if travel == FREE else 0.0
    if travel != FREE:
        dy[XP] = 0.0
        dy[VP] = 0.0
        dy[Z] = 0.0
    else:
        fr = m[M_FRICTION]
        if fr == STICK:
            ff = p[SIGMA0] * y[Z] + (p[SIGMA1] + viscous(vp, p)) * vp
            dy[Z] = vp
        else:
            ff = slip_friction(vp, 1 if fr == SLIP_POS else -1, p)
            dy[Z] = 0.0
        dy[XP] = vp
        dy[VP] = (external_force(y[P1], y[P2], p) - ff) / p[MASS]
    dy[P1], dy[P2] = chamber_pressure_rates(y[XS], y[P1], y[P2], y[XP], vp, p, p[DP_LAM], sc[0], sc[1])
    if sc[2] != 0.0 or sc[3] != 0.0:      # a stiff chamber: its quasi-static pressure moves physically
        d1, d2 = quasi_static_drift(y[XS], dy[XS], y[P1], y[P2], dy[VP], p, p[DP_LAM])
        dy[P1] += sc[2] * d1
        dy[P2] += sc[3] * d2


@jit(inline=True)
def friction_force(y, m, p):
    """Friction force [N] of the current state and modes (for logs; at a stop: the seal force s0*z)."""
    if m[M_TRAVEL] != FREE or m[M_FRICTION] == STICK:
        v = y[VP] if m[M_TRAVEL] == FREE else 0.0
        return p[SIGMA0] * y[Z] + (p[SIGMA1] + viscous(v, p)) * v
    return slip_friction(y[VP], 1 if m[M_FRICTION] == SLIP_POS else -1, p)


@jit(inline=True)
def stiff_chamber_constants(y, p, h, sc):
    """Fill ``sc`` for the next step of size h (module doc): [c1, c2, (1 - c1)/g1, (1 - c2)/g2], c_i in (0, 1]
    the slowing of chamber i's relaxation, g_i = -dF_i/dP_i its conductance at the step start."""
    as1, as2, a1t, a2t = pseudo_sections(y[XS], p)
    v1, v2 = volumes(y[XP], p)
    ps, pt, dl = p[PS], p[PT], p[DP_LAM]
    g1 = orifice_slope(as1, ps - y[P1], dl) + orifice_slope(a1t + p[BURST1], y[P1] - pt, dl) + p[G_LKC]
    g2 = orifice_slope(as2, ps - y[P2], dl) + orifice_slope(a2t + p[BURST2], y[P2] - pt, dl) + p[G_LKC]
    l1 = bulk_modulus(y[P1], 1, p) / v1 * g1 * h
    l2 = bulk_modulus(y[P2], 2, p) / v2 * g2 * h
    lim = p[LAMBDA_H_MAX]
    c1 = min(1.0, lim / l1)
    c2 = min(1.0, lim / l2)
    sc[0] = c1
    sc[1] = c2
    sc[2] = (1.0 - c1) / g1 if c1 < 1.0 else 0.0
    sc[3] = (1.0 - c2) / g2 if c2 < 1.0 else 0.0


@jit(inline=True)
def guard_value(gid, y, m, p):
    """Value of guard ``gid`` (>= 0 while the current mode is valid); +inf when it does not apply."""
    travel = m[M_TRAVEL]
    if travel == FREE:
        if gid == G_RETRACT:
            return y[XP]
        if gid == G_EXTEND:
            return p[STROKE] - y[XP]
        fr = m[M_FRICTION]
        if gid == G_BREAK_POS and fr == STICK:
            return p[FS_POS] - p[SIGMA0] * y[Z]
        if gid == G_BREAK_NEG and fr == STICK:
            return p[FS_NEG] + p[SIGMA0] * y[Z]
        if gid == G_REVERSE and fr != STICK:
            return y[VP] if fr == SLIP_POS else -y[VP]
        return np.inf
    if gid == G_LEAVE:
        f = external_force(y[P1], y[P2], p) - p[SIGMA0] * y[Z]
        return -f if travel == AT_RETRACT else f
    return np.inf


@jit(inline=True)
def _crossing(g0, g1):
    """Fraction of the step at which a guard going from g0 to g1 < 0 crosses zero (linear)."""
    return 0.0 if g0 <= 0.0 else g0 / (g0 - g1)


@jit(inline=True)
def first_crossing(y0, y1, m, p):
    """(guard id, theta in [0, 1]) of the earliest guard crossing between y0 and y1, or (G_NONE, 1).

    Equivalent to scanning :func:`guard_value` over all guards, written out per mode for speed.
    """
    best, theta = G_NONE, 1.0
    if m[M_TRAVEL] != FREE:
        g1 = guard_value(G_LEAVE, y1, m, p)
        if g1 < 0.0:
            return G_LEAVE, _crossing(guard_value(G_LEAVE, y0, m, p), g1)
        return best, theta
    if y1[XP] < 0.0:
        best, theta = G_RETRACT, _crossing(y0[XP], y1[XP])
    elif y1[XP] > p[STROKE]:
        best, theta = G_EXTEND, _crossing(p[STROKE] - y0[XP], p[STROKE] - y1[XP])
    if m[M_FRICTION] == STICK:
        g_lo, g_hi = G_BREAK_POS, G_BREAK_NEG + 1
    else:
        g_lo, g_hi = G_REVERSE, G_REVERSE + 1
    for gid in range(g_lo, g_hi):
        g1 = guard_value(gid, y1, m, p)
        if g1 < 0.0:
            th = _crossing(guard_value(gid, y0, m, p), g1)
            if best == G_NONE or th < theta:
                best, theta = gid, th
    return best, theta


@jit(inline=True)
def apply_reset(gid, y, m, p):
    """Discrete transition of guard ``gid`` (table in the module docstring)."""
    s0 = p[SIGMA0]
    if gid == G_RETRACT or gid == G_EXTEND:
        fr = m[M_FRICTION]
        if fr != STICK:  # bristles at their sliding steady state just before impact
            d = 1.0 if fr == SLIP_POS else -1.0
            y[Z] = d * stribeck(y[VP], p) / s0
        y[XP] = 0.0 if gid == G_RETRACT else p[STROKE]
        y[VP] = 0.0
        m[M_TRAVEL] = AT_RETRACT if gid == G_RETRACT else AT_EXTEND
        m[M_FRICTION] = STICK
    elif gid == G_BREAK_POS:
        m[M_FRICTION] = SLIP_POS
    elif gid == G_BREAK_NEG:
        m[M_FRICTION] = SLIP_NEG
    elif gid == G_REVERSE:
        d = 1.0 if m[M_FRICTION] == SLIP_POS else -1.0
        y[VP] = 0.0
        y[Z] = d * (p[FS_POS] if d > 0 else p[FS_NEG]) / s0
        m[M_FRICTION] = STICK
    elif gid == G_LEAVE:
        m[M_TRAVEL] = FREE
        m[M_FRICTION] = STICK


@jit(inline=True)
def project(y, m, p):
    """Keep the state on its mode's manifold and inside physical bounds after a (sub)step."""
    lv = p[LV]
    if y[VS] > lv:
        y[VS] = lv
    elif y[VS] < -lv:
        y[VS] = -lv
    if y[XS] >= 1.0:              # the spool's mechanical ends (SPEC §3.1): plastic, velocity into it stopped
        y[XS] = 1.0
        if y[VS] > 0.0:
            y[VS] = 0.0
    elif y[XS] <= -1.0:
        y[XS] = -1.0
        if y[VS] < 0.0:
            y[VS] = 0.0
    if y[P1] < P_MIN:
        y[P1] = P_MIN
    if y[P2] < P_MIN:
        y[P2] = P_MIN
    if m[M_TRAVEL] == AT_RETRACT:
        y[XP] = 0.0
        y[VP] = 0.0
    elif m[M_TRAVEL] == AT_EXTEND:
        y[XP] = p[STROKE]
        y[VP] = 0.0


@jit(inline=True)
def spool_mode(y, ud, p):
    """Spool region of the state at the end of a step (recorded, Fig 11b-style)."""
    if y[XS] >= 1.0 or y[XS] <= -1.0:
        return SPOOL_AT_END
    if abs(y[VS]) >= p[LV] * (1.0 - 1e-9):
        return SPOOL_VEL_LIMITED
    a = p[WN] * p[WN] * (ud - y[XS]) - 2.0 * p[XI] * p[WN] * y[VS]
    if abs(a) > p[LA]:
        return SPOOL_ACC_LIMITED
    return SPOOL_LINEAR


@jit(inline=True)
def _copy(src, dst):
    for i in range(src.shape[0]):
        dst[i] = src[i]


RK_STEP = None  # bound per tableau by make_hybrid_step


def _hybrid_step(y, m, p, ud, h, work):
    """Advance the hybrid model one fixed step h with delayed input ``ud``; returns the event count.

    ``y`` (state) and ``m`` (modes) are updated in place. ``work``: a (MAX_STAGES + 3, ny) scratch array.
    """
    k = work[:MAX_STAGES]
    ytmp = work[MAX_STAGES]
    y1 = work[MAX_STAGES + 1]
    sc = work[MAX_STAGES + 2]
    stiff_chamber_constants(y, p, h, sc)
    t_left = h      # time still to integrate in this step
    hh = h          # size of the next RK (sub)step
    pending = G_NONE  # guard whose event instant the last substep was aimed at
    n_events = 0
    for _ in range(2 * MAX_EVENTS + 1):  # one call site: the stepper is inlined once
        RK_STEP(y, hh, ud, m, p, sc, k, ytmp, y1)
        project(y1, m, p)
        if pending != G_NONE:  # arrived at a located event: reset, go on in the new mode
            _copy(y1, y)
            apply_reset(pending, y, m, p)
            project(y, m, p)
            pending = G_NONE
            t_left -= hh
            hh = t_left
            if t_left <= 1e-12 * h:
                break
            continue
        gid, theta = first_crossing(y, y1, m, p)
        if gid == G_NONE:
            _copy(y1, y)
            break
        n_events += 1
        if n_events > MAX_EVENTS:  # event budget spent: take the step, reset at its end
            _copy(y1, y)
            apply_reset(gid, y, m, p)
            project(y, m, p)
            break
        if theta <= 0.0:  # guard already violated at the start: reset now, redo the substep
            apply_reset(gid, y, m, p)
            project(y, m, p)
            continue
        pending = gid
        hh = theta * t_left
    m[M_SPOOL] = spool_mode(y, ud, p)
    return n_events


def make_hybrid_step(tab: Tableau):
    """Compile ``hybrid_step(y, m, p, ud, h, work)`` for one fixed-step tableau (an inlined, allocation-free
    helper of the loops: see :func:`hydrohil._jit.jit`)."""
    return specialize(_hybrid_step, f"hybrid_step_{tab.name}", inline=True, RK_STEP=make_rk_step(hybrid_rhs, tab))
