"""Readable names for modes and the divergence error."""

from __future__ import annotations

import numpy as np

from hydrohil.errors import SimulationDiverged
from hydrohil.models.layout import FRICTION_NAMES, SPOOL_NAMES, STATE_NAMES, TRAVEL_NAMES


def mode_names(m) -> dict[str, str]:
    return {"travel": TRAVEL_NAMES[int(m[0])], "friction": FRICTION_NAMES[int(m[1])],
            "spool": SPOOL_NAMES[int(m[2])]}


def divergence_error(t: float, y: np.ndarray, m, reason: str = "non-finite or unphysical state") -> SimulationDiverged:
    return SimulationDiverged(float(t), mode_names(m), {n: float(v) for n, v in zip(STATE_NAMES, y)}, reason)
