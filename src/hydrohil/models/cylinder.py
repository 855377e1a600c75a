"""Differential cylinder (SPEC §4): its equations are in the C core (``core/cylinder.c``); these are its
constants as the Python side needs them."""

from __future__ import annotations

from hydrohil.core import lib

P_MIN = lib.HH_P_MIN  # Pa gauge: just above absolute zero; pressures are floored here (cavitation)
P_ATM = lib.HH_P_ATM  # Pa, the atmospheric pressure of eq 21



def warn_beyond_stroke(times, values, stroke: float, source: str, what: str, whose: str, given=None) -> None:
    """A piston's position reference outside [0, stroke] cannot be reached: warn (the run is still valid) at
    its farthest point: ``{source}: {what} = {value} m (at t = ...) lies outside the stroke [0, L] m ({whose})``;
    ``given``: the values as written (a bare number said to be read in metres: "200 mm" meant as 200)."""
    import warnings
    import numpy as np
    from hydrohil.errors import InputWarning
    x = np.asarray(values, dtype=float)
    beyond = np.maximum(-x, x - stroke)
    i = int(np.argmax(beyond))
    if beyond[i] > 0:
        bare = " (a number without its unit is in m)" if given is not None and not isinstance(given[i], str) else ""
        warnings.warn(f"{source}: {what} = {x[i]:g} m (at t = {times[i]:g} s) lies outside the stroke "
                      f"[0, {stroke:g}] m ({whose}){bare}: the piston stops at the end stop there", InputWarning,
                      stacklevel=4)
