"""Sensor interface models shared by offline simulation and the HIL plant (SPEC §8 'sensors', §10).

The models are the core's (``core/sensors.c``, ``core/rig.c``), shared by the sampled loop, the Python rig
(:mod:`hydrohil.simulation.rig`) and the standalone C plant.
"""

from __future__ import annotations

from hydrohil.core import lib

IDEAL_COUNT = lib.HH_IDEAL_COUNT   # m: the count of an ideal encoder (resolution 0) where counts must be integers


def count_size(resolution: float) -> float:
    """Size [m] of one encoder count as the rig reports it: ``resolution``, or 1 nm for an ideal encoder
    (``sensors.encoder_resolution = 0``), whose reading is then exact to 0.5 nm (docs/protocol.md)."""
    return lib.hh_count_size(resolution)


def encoder_counts(xp: float, resolution: float) -> float:
    """Encoder reading [counts] of position xp [m] for a count size ``resolution`` [m] (nearest count)."""
    return lib.hh_encoder_counts(xp, resolution)

