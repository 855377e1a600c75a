"""Differential cylinder: chamber volumes, effective bulk modulus (eq 21) and continuity (SPEC §4)."""

from __future__ import annotations

from hydrohil._jit import jit

from hydrohil.models.layout import (A1, A2, BB, BC, BETA1, BETA2, BULK_CONST, BURST1, BURST2, FLOAD, G_LKC, GDIR,
                                    GRAV, MASS, PS, PT, STROKE, V01, V02)
from hydrohil.models.valve import orifice_flow, pseudo_section_slopes, pseudo_sections

P_MIN = -0.99e5  # Pa gauge: just above absolute zero; pressures are floored here (cavitation)
P_ATM = 1e5      # Pa, the atmospheric pressure of eq 21


@jit(inline=True)
def bulk_modulus(pressure, chamber, p):
    """Effective bulk modulus [Pa] at gauge ``pressure`` [Pa]: eq 21 (1e5 + P)/(B*P + C), or the
    constant per-chamber value (chamber 1 or 2) when ``cylinder.bulk_modulus = "constant"``."""
    if p[BULK_CONST] > 0.5:
        return p[BETA1] if chamber == 1 else p[BETA2]
    pr = max(pressure, P_MIN)
    return (P_ATM + pr) / (p[BB] * pr + p[BC])


@jit(inline=True)
def volumes(xp, p):
    """Chamber volumes [m^3]: V1 = V01 + A1*xp, V2 = V02 + A2*(L - xp); xp limited to the stroke."""
    x = min(max(xp, 0.0), p[STROKE])
    return p[V01] + p[A1] * x, p[V02] + p[A2] * (p[STROKE] - x)


@jit(inline=True)
def chamber_pressure_rates(xs, p1, p2, xp, vp, p, dp_t, c1, c2):
    """(dP1/dt, dP2/dt) [Pa/s] by continuity (SPEC §4) with the valve flows of SPEC §3.2.

    Q1 = q_s1 - q_1t, Q2 = q_s2 - q_2t; q_lkc = g_lkc*(P1 - P2) (eq 22);
    dP1/dt = c1*beta(P1)/V1*(Q1 - A1*vp - q_lkc), dP2/dt = c2*beta(P2)/V2*(Q2 + A2*vp + q_lkc).
    ``dp_t``: laminar transition pressure of the orifices; ``c1``/``c2``: capacitance scales of the
    chambers (1 = physical; the hybrid model's stiff-chamber slowing, see hybrid.py). A burst
    hose (fault) drains chamber i to tank through the section p[BURSTi] (0 normally).
    """
    as1, as2, a1t, a2t = pseudo_sections(xs, p)
    ps, pt = p[PS], p[PT]
    q1 = orifice_flow(as1, ps - p1, dp_t) - orifice_flow(a1t + p[BURST1], p1 - pt, dp_t)
    q2 = orifice_flow(as2, ps - p2, dp_t) - orifice_flow(a2t + p[BURST2], p2 - pt, dp_t)
    q_lk = p[G_LKC] * (p1 - p2)
    v1, v2 = volumes(xp, p)
    dp1 = c1 * bulk_modulus(p1, 1, p) / v1 * (q1 - p[A1] * vp - q_lk)
    dp2 = c2 * bulk_modulus(p2, 2, p) / v2 * (q2 + p[A2] * vp + q_lk)
    return dp1, dp2


@jit(inline=True)
def quasi_static_drift(xs, dxs, p1, p2, dvp, p, dp_t):
    """Drive terms of the quasi-static chamber pressures (the hybrid model's stiff chambers, hybrid.py).

    P_i* is the pressure at which chamber i's net inflow F_i (valve flow and leakage, SPEC §4) balances the
    piston's displacement flow: F1(P1*) = A1*vp, F2(P2*) = -A2*vp. Differentiating, with g_i = -dF_i/dP_i:
    dP1*/dt = (dF1/dxs*dxs/dt - A1*dvp/dt)/g1 and dP2*/dt = (dF2/dxs*dxs/dt + A2*dvp/dt)/g2. Returns the two
    numerators [m^3/s^2]; flows are linear in the pseudo-sections, so dF/dxs is the orifice flow through the
    section slopes (valve.pseudo_section_slopes).
    """
    das1, das2, da1t, da2t = pseudo_section_slopes(xs, p)
    ps, pt = p[PS], p[PT]
    dq1 = orifice_flow(das1, ps - p1, dp_t) - orifice_flow(da1t, p1 - pt, dp_t)
    dq2 = orifice_flow(das2, ps - p2, dp_t) - orifice_flow(da2t, p2 - pt, dp_t)
    return dq1 * dxs - p[A1] * dvp, dq2 * dxs + p[A2] * dvp


@jit(inline=True)
def external_force(p1, p2, p):
    """Hydraulic + gravity + load force on the piston along +x [N] (eq 28 without friction)."""
    return p1 * p[A1] - p2 * p[A2] - p[FLOAD] + p[GDIR] * p[MASS] * p[GRAV]
