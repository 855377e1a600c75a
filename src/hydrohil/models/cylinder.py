"""Differential cylinder (SPEC §4): its equations are in the C core (``core/cylinder.c``); these are its
constants as the Python side needs them."""

from __future__ import annotations

from hydrohil.core import dptr, lib

P_MIN = lib.HH_P_MIN  # Pa gauge: just above absolute zero; pressures are floored here (cavitation)
P_ATM = lib.HH_P_ATM  # Pa, the atmospheric pressure of eq 21


def external_force(p1: float, p2: float, p) -> float:
    """Hydraulic + gravity + load force on the piston along +x [N] (eq 28 without friction; core)."""
    return lib.hh_external_force(p1, p2, dptr(p))
