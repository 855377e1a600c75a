"""Differential cylinder (SPEC §4): its equations are in the C core (``core/cylinder.c``); these are its
constants as the Python side needs them."""

from __future__ import annotations

from hydrohil.core import lib

P_MIN = lib.HH_P_MIN  # Pa gauge: just above absolute zero; pressures are floored here (cavitation)
P_ATM = lib.HH_P_ATM  # Pa, the atmospheric pressure of eq 21

