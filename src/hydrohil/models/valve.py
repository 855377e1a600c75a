"""Servo-solenoid 4-way valve: spool dynamics (eq 1-2, SPEC §3.1) and pseudo-section static model (eq 3).

Pseudo-sections are in the paper's units, (l/min)/sqrt(bar); flows are converted to SI at the orifice.
The scalar functions are compiled with numba for the hot loop; the ``*_np`` helpers evaluate the same
formulas on arrays for identification and plots (SPEC §3.2, eq 4-17).
"""

from __future__ import annotations

import numpy as np
from hydrohil._jit import jit

from hydrohil.models.layout import (K1, K1T, LA, LPM_PER_SQRT_BAR, LV, SPOOL_ACC_LIMITED, SPOOL_AT_END,
                                    SPOOL_LINEAR, SPOOL_STOP_C, SPOOL_STOP_K, SPOOL_VEL_LIMITED, VALVE_WEAR, WN,
                                    XI)


def _section(x, k1, k2, k3, k4, k5):
    """One pseudo-section of eq 3: k1*x + k2 + sqrt(k3*x^2 + k4*x + k5), floored at zero."""
    return np.maximum(k1 * x + k2 + np.sqrt(np.maximum(k3 * x * x + k4 * x + k5, 0.0)), 0.0)


section = jit(inline=True)(_section)


@jit(inline=True)
def pseudo_sections(x, p):
    """(As1, As2, A1t, A2t) at spool position x (clamped to [-1, 1]) in (l/min)/sqrt(bar); eq 3,
    plus the worn-lands leakage section p[VALVE_WEAR] on each (0 unless a valve-leakage fault is active)."""
    x = min(max(x, -1.0), 1.0)
    w = p[VALVE_WEAR]
    as2 = section(x, p[K1], p[K1 + 1], p[K1 + 2], p[K1 + 3], p[K1 + 4]) + w
    as1 = section(-x, p[K1], p[K1 + 1], p[K1 + 2], p[K1 + 3], p[K1 + 4]) + w
    a1t = section(x, p[K1T], p[K1T + 1], p[K1T + 2], p[K1T + 3], p[K1T + 4]) + w
    a2t = section(-x, p[K1T], p[K1T + 1], p[K1T + 2], p[K1T + 3], p[K1T + 4]) + w
    return as1, as2, a1t, a2t


@jit(inline=True)
def section_slope(x, k1, k2, k3, k4, k5):
    """d/dx of :func:`section` (0 where the section is floored at zero)."""
    q = k3 * x * x + k4 * x + k5
    r = np.sqrt(q) if q > 0.0 else 0.0
    if k1 * x + k2 + r <= 0.0:
        return 0.0
    return k1 + (2.0 * k3 * x + k4) / (2.0 * r) if r > 0.0 else k1


@jit(inline=True)
def pseudo_section_slopes(x, p):
    """(dAs1/dx, dAs2/dx, dA1t/dx, dA2t/dx) of eq 3 [(l/min)/sqrt(bar) per unit x̄s]; 0 beyond the clamp
    at |x| = 1 (the worn-lands section is constant)."""
    if x >= 1.0 or x <= -1.0:
        return 0.0, 0.0, 0.0, 0.0
    das2 = section_slope(x, p[K1], p[K1 + 1], p[K1 + 2], p[K1 + 3], p[K1 + 4])
    das1 = -section_slope(-x, p[K1], p[K1 + 1], p[K1 + 2], p[K1 + 3], p[K1 + 4])
    da1t = section_slope(x, p[K1T], p[K1T + 1], p[K1T + 2], p[K1T + 3], p[K1T + 4])
    da2t = -section_slope(-x, p[K1T], p[K1T + 1], p[K1T + 2], p[K1T + 3], p[K1T + 4])
    return das1, das2, da1t, da2t


@jit(inline=True)
def orifice_flow(area, dp, dp_t):
    """Flow [m^3/s] through a pseudo-section ``area`` [(l/min)/sqrt(bar)] under ``dp`` [Pa].

    Turbulent q = K*sign(dp)*sqrt(|dp|) (K = area in SI) for |dp| >= dp_t, exactly; below, the odd
    cubic q = K*sqrt(dp_t)*r*(5 - r^2)/4, r = dp/dp_t, which meets it with the same value and slope
    (C1) and has the finite slope 1.25*K/sqrt(dp_t) at dp = 0 (SPEC §3.2).
    """
    k = area * LPM_PER_SQRT_BAR
    if dp >= dp_t:
        return k * np.sqrt(dp)
    if dp <= -dp_t:
        return -k * np.sqrt(-dp)
    r = dp / dp_t
    return k * np.sqrt(dp_t) * r * (1.25 - 0.25 * r * r)


@jit(inline=True)
def orifice_slope(area, dp, dp_t):
    """d(orifice_flow)/d(dp) [m^3/s/Pa] (>= 0)."""
    k = area * LPM_PER_SQRT_BAR
    a = abs(dp)
    if a >= dp_t:
        return 0.5 * k / np.sqrt(a)
    r = dp / dp_t
    return k / np.sqrt(dp_t) * (1.25 - 0.75 * r * r)


@jit(inline=True)
def spool_derivatives(xs, vs, ud, p):
    """(dxs/dt, dvs/dt, spool mode) of the limited second-order spool model (SPEC §3.1, Fig 3)."""
    wn = p[WN]
    a = wn * wn * (ud - xs) - 2.0 * p[XI] * wn * vs
    mode = SPOOL_LINEAR
    if a > p[LA]:
        a = p[LA]
        mode = SPOOL_ACC_LIMITED
    elif a < -p[LA]:
        a = -p[LA]
        mode = SPOOL_ACC_LIMITED
    # limited integrator: no wind-up beyond +-Lv
    if (vs >= p[LV] and a > 0.0) or (vs <= -p[LV] and a < 0.0):
        a = 0.0
        mode = SPOOL_VEL_LIMITED
    if xs >= 1.0 or xs <= -1.0:
        mode = SPOOL_AT_END
    return vs, a, mode


@jit(inline=True)
def spool_end_block(xs, vs, dxs, dvs):
    """The spool's mechanical end (SPEC §3.1: x̄s clamped to [-1, 1]) in the hybrid model: at an end, motion
    and acceleration into it are stopped (the step's projection then holds x̄s = ±1, v̄s = 0)."""
    if xs >= 1.0 and vs >= 0.0:
        return 0.0, min(dvs, 0.0)
    if xs <= -1.0 and vs <= 0.0:
        return 0.0, max(dvs, 0.0)
    return dxs, dvs


@jit(inline=True)
def spool_stop_acceleration(xs, vs):
    """The spool's mechanical end in the continuous reference model: a stiff unilateral spring-damper
    (k = SPOOL_STOP_K, c = SPOOL_STOP_C, acting only on penetration beyond |x̄s| = 1) [1/s^2]."""
    if xs > 1.0:
        return -max(0.0, SPOOL_STOP_K * (xs - 1.0) + SPOOL_STOP_C * vs)
    if xs < -1.0:
        return max(0.0, SPOOL_STOP_K * (-1.0 - xs) - SPOOL_STOP_C * vs)
    return 0.0


# ---- array versions for identification and plots (eq 3-17) -----------------------------------

def pseudo_sections_np(x, k, kt):
    """(As1, As2, A1t, A2t) for an array of spool positions, k and kt the five-number sets of eq 3."""
    x = np.clip(np.asarray(x, dtype=float), -1.0, 1.0)
    return (_section(-x, *k), _section(x, *k), _section(x, *kt), _section(-x, *kt))


def closed_port_pressures(x, k, kt):
    """Relative chamber pressures (P1/Ps, P2/Ps) with both ports closed (Q1 = Q2 = 0), SPEC §3.2."""
    as1, as2, a1t, a2t = pseudo_sections_np(x, k, kt)
    with np.errstate(invalid="ignore", divide="ignore"):
        return as1**2 / (as1**2 + a1t**2), as2**2 / (as2**2 + a2t**2)


def delta_pm(ps_bar, k, kt):
    """Pressure difference to the middle point, eq 4, in the unit of ``ps_bar``."""
    _, as2, _, a2t = pseudo_sections_np(0.0, k, kt)
    return ps_bar / 2 * (as2**2 - a2t**2) / (as2**2 + a2t**2)


def relative_load_pressure(x, k, kt):
    """P_L/Ps with closed ports, eq 5."""
    p1, p2 = closed_port_pressures(x, k, kt)
    return p1 - p2


def pressure_gain(k, kt, dx=1e-6):
    """Relative pressure gain K̄p0 = dP̄L/dx̄s at x̄s = 0, eq 6 (central difference)."""
    return float((relative_load_pressure(dx, k, kt) - relative_load_pressure(-dx, k, kt)) / (2 * dx))


def load_flow(x, ps_bar, k, kt):
    """Load flow Q_L = Q1 [l/min] with ports 1 and 2 joined by a null resistance, eq 7."""
    dpm = delta_pm(ps_bar, k, kt)
    as1, _, a1t, _ = pseudo_sections_np(x, k, kt)
    return as1 * np.sqrt(ps_bar / 2 - dpm) - a1t * np.sqrt(ps_bar / 2 + dpm)


def load_flow_2(x, ps_bar, k, kt):
    """Load flow Q_L = -Q2 [l/min] seen from port 2, eq 9 (equals eq 7 for a consistent k-set)."""
    dpm = delta_pm(ps_bar, k, kt)
    _, as2, _, a2t = pseudo_sections_np(x, k, kt)
    return a2t * np.sqrt(ps_bar / 2 + dpm) - as2 * np.sqrt(ps_bar / 2 - dpm)


def flow_gain(ps_bar, k, kt, dx=1e-6):
    """Flow gain K̄q0 = dQ_L/dx̄s at x̄s = 0 [l/min], eq 8."""
    return float((load_flow(dx, ps_bar, k, kt) - load_flow(-dx, ps_bar, k, kt)) / (2 * dx))


def leakage_flow(x, ps_bar, k, kt):
    """Internal valve leakage [l/min] with closed ports, eq 12 (supply side flow)."""
    as1, as2, a1t, a2t = pseudo_sections_np(x, k, kt)
    p1, p2 = closed_port_pressures(x, k, kt)
    return as1 * np.sqrt(ps_bar * (1 - p1)) + as2 * np.sqrt(ps_bar * (1 - p2))
