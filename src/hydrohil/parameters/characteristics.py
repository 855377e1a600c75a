"""The valve's static characteristics of a parameter set (SPEC §3.2, eq 3-17): eq 3's pseudo-sections on
arrays and the closed-port relations a datasheet quotes (ΔPm, K̄p0, K̄q0, leakage), in the paper's units
(l/min, bar); and the constants of the paper's linearised model (``[linear]``, eq 18-20, SPEC §7) derived
from them when a parameter file has no ``[linear]`` group. No simulation: numpy on the set's numbers (the
plant's valve is the C core, core/valve.c; identification and plots use these)."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

LINEAR_PN = 35e5        # Pa: the nominal pressure drop of derived linear constants (the datasheets' 35 bar)


def _section(x, k1, k2, k3, k4, k5):
    """One pseudo-section of eq 3 on arrays: k1*x + k2 + sqrt(k3*x^2 + k4*x + k5), floored at zero."""
    return np.maximum(k1 * x + k2 + np.sqrt(np.maximum(k3 * x * x + k4 * x + k5, 0.0)), 0.0)


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


def derived_linear(data: Mapping[str, Any]) -> dict[str, float]:
    """The ``[linear]`` group (eq 18-20) of a parameter set whose file has none, from its other groups (raw
    TOML tables): at mid-stroke (xp0 = stroke/2) and the valve's centre (xs0 = 0: the paper's model is about a
    spool offset near 0; the plant linearised at its own load-dependent rest offset is ``hydrohil linear``,
    :mod:`hydrohil.linear`); the flow gain kq per unit
    spool with Pn = 35 bar on each edge, kq = (dAs1/dx − dA1t/dx)·sqrt(Pn [bar]) [l/min -> m³/s] (the paper's
    kq1 = kq·sqrt(Ps/(2Pn))); the closed-port pressure gains kp1, kp2 = d(P1/Ps)/dx, d(P2/Ps)/dx; the friction
    factor f = the steady-state friction's viscous slope (mean of the directions' kv). On the paper's k-set
    this gives kq 4.74e-4 m³/s, kp1 18.2, kp2 −18.2 (the paper: 4.76e-4, 19, −15.6 at x̄s0 = 0.009)."""
    k, kt = data["valve"]["k"], data["valve"]["kt"]
    d = 1e-6

    def slope(f):
        return (np.asarray(f(d), float) - np.asarray(f(-d), float)) / (2 * d)
    as1, _, a1t, _ = slope(lambda x: np.array(pseudo_sections_np(x, k, kt)))
    kp1, kp2 = slope(lambda x: np.array(closed_port_pressures(x, k, kt)))
    fr = data["friction"]
    sets = (fr["positive"], fr["negative"]) if fr.get("asymmetric") else (fr["symmetric"], fr["symmetric"])
    return {"xp0": 0.5 * float(data["cylinder"]["stroke"]), "xs0": 0.0,
            "friction_factor": 0.5 * (float(sets[0]["kv"]) + float(sets[1]["kv"])),
            "kq": float((as1 - a1t) * np.sqrt(LINEAR_PN / 1e5) / 60000.0),
            "kp1": float(kp1), "kp2": float(kp2), "pn": LINEAR_PN}
