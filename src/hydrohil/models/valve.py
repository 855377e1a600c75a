"""Servo-solenoid 4-way valve (SPEC §3): array forms of the static model for identification and plots.

The valve of the plant is in the C core (``core/valve.c``: spool dynamics eq 1-2, pseudo-sections eq 3,
orifice law); :func:`orifice_flow`, :func:`orifice_slope` and :func:`spool_derivatives` call it. The ``*_np``
helpers and the closed-port relations (SPEC §3.2, eq 4-17) evaluate eq 3 on arrays for the identification
procedures of the valve's static characteristics, where the data are datasheet curves, not a simulation.
"""

from __future__ import annotations

import numpy as np

from hydrohil.core import dptr, ffi, lib


def orifice_flow(area: float, dp: float, dp_t: float) -> float:
    """Flow [m^3/s] through a pseudo-section ``area`` [(l/min)/sqrt(bar)] under ``dp`` [Pa] (core, SPEC §3.2)."""
    return lib.hh_orifice_flow(area, dp, dp_t)


def orifice_slope(area: float, dp: float, dp_t: float) -> float:
    """d(orifice_flow)/d(dp) [m^3/s/Pa] (core)."""
    return lib.hh_orifice_slope(area, dp, dp_t)


def spool_derivatives(xs: float, vs: float, ud: float, p: np.ndarray) -> tuple[float, float, int]:
    """(dxs/dt, dvs/dt, spool mode) of the limited spool model (core, SPEC §3.1)."""
    d = ffi.new("double[2]")
    mode = lib.hh_spool_derivatives(xs, vs, ud, dptr(p), d, d + 1)
    return d[0], d[1], mode


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
