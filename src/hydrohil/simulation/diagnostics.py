"""Readable names for modes and the divergence error."""

from __future__ import annotations

import numpy as np

from hydrohil.errors import SimulationDiverged
from hydrohil.core import shape
from hydrohil.models.layout import STATE_NAMES


def mode_names(m) -> dict[str, str]:
    """{mode: the name of its value} of a mode vector m (in m[] order: travel, friction, spool)."""
    return {mode.name: mode.values[int(v)].name for mode, v in zip(shape.MODES, m)}


def divergence_error(t: float, y: np.ndarray, m, reason: str = "non-finite or unphysical state") -> SimulationDiverged:
    return SimulationDiverged(float(t), mode_names(m), {n: float(v) for n, v in zip(STATE_NAMES, y)}, reason)
