"""Servo-solenoid 4-way valve (SPEC §3).

The valve of the plant is in the C core (``core/valve.c``: spool dynamics eq 1-2, pseudo-sections eq 3,
orifice law); :func:`orifice_flow`, :func:`orifice_slope` and :func:`spool_derivatives` call it. The static
characteristics on arrays (eq 3-17 with closed ports: what a datasheet quotes, for identification and plots)
are :mod:`hydrohil.parameters.characteristics`, re-exported here.
"""

from __future__ import annotations

import numpy as np

from hydrohil.core import dptr, ffi, lib
from hydrohil.parameters.characteristics import (closed_port_pressures, delta_pm, flow_gain,  # noqa: F401
                                                 leakage_flow, load_flow, load_flow_2, pressure_gain,
                                                 pseudo_sections_np, relative_load_pressure)


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
