"""The plant at rest (SPEC §12.5, §7; core/rest.c): the chamber pressures at which both chambers' net
flows vanish at a spool position (valve flows with their laminar region, internal leakage), and the spool
offset at which those pressures hold the piston (force balance, friction zero). The default initial state
of every layer and the operating point of the linearisation are this state."""

from __future__ import annotations

import numpy as np

from hydrohil.core import dptr, ffi, lib
from hydrohil.errors import InputError
from hydrohil.models.layout import pack
from hydrohil.parameters import Parameters


def chamber_pressures(params: Parameters, xs: float, p: np.ndarray | None = None) -> tuple[float, float]:
    """(p1, p2) [Pa] at which both chambers' net inflows vanish with the spool at ``xs``."""
    p = pack(params) if p is None else p
    got = ffi.new("double[2]")          # the C function's results: p1, p2
    lib.hh_rest_pressures(dptr(p), float(xs), got, got + 1)
    return got[0], got[1]


def net_force(params: Parameters, p1: float, p2: float, p: np.ndarray | None = None) -> float:
    """Force on the piston along +x [N] from the pressures, gravity and the load force (friction zero): eq 28's
    external force, by the core (``external_force`` of core/cylinder.c)."""
    return lib.hh_external_force(float(p1), float(p2), dptr(pack(params) if p is None else p))


def unheld_load(params: Parameters) -> str:
    """What is wrong with a load that no spool position holds at rest."""
    w = net_force(params, 0.0, 0.0)
    return (f"no spool position holds the piston at rest: the net load (gravity and load.force, {w:+.0f} N along "
            f"+x) is more than the cylinder gives at a supply pressure of {params.supply.ps / 1e5:g} bar")


def rest_state(params: Parameters, p: np.ndarray | None = None) -> tuple[float, float, float]:
    """(xs, p1, p2) at rest: the spool offset that holds the piston and the chamber pressures there; an
    :class:`InputError` naming the load when no spool position holds it."""
    p = pack(params) if p is None else p
    got = ffi.new("double[3]")          # the C function's results: xs, p1, p2
    if lib.hh_rest_state(dptr(p), got, got + 1, got + 2) != 0:
        raise InputError(unheld_load(params), key="load")
    return got[0], got[1], got[2]
