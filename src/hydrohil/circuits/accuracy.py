"""A fixed-step run of a circuit against its continuous reference (SPEC §12.4, the issue's "must hold"): the RMS
error of every position, every node pressure and every speed, on the reference's sample grid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hydrohil.circuits.run import CircuitResult

# the limits every example holds at 0.5 ms with RK3 (README: Circuits)
LIMIT_POSITION = 1e-4          # m RMS, every position
LIMIT_PRESSURE = 0.03          # RMS, of the circuit's highest pressure, every node
LIMIT_SPEED = 0.02             # RMS, of the signal's largest magnitude, every speed


@dataclass
class Accuracy:
    positions: dict[str, float]     # column -> RMS error [m]
    pressures: dict[str, float]     # node column -> RMS error [Pa]
    speeds: dict[str, float]        # column -> RMS error relative to the reference's largest |speed|
    p_highest: float                # the reference's highest pressure [Pa]

    @property
    def worst_position(self) -> float:
        return max(self.positions.values(), default=0.0)

    @property
    def worst_pressure(self) -> float:
        """The largest pressure RMS error as a fraction of the circuit's highest pressure."""
        return max(self.pressures.values(), default=0.0) / self.p_highest if self.p_highest > 0 else 0.0

    @property
    def worst_speed(self) -> float:
        return max(self.speeds.values(), default=0.0)

    @property
    def holds(self) -> bool:
        return (self.worst_position <= LIMIT_POSITION and self.worst_pressure <= LIMIT_PRESSURE
                and self.worst_speed <= LIMIT_SPEED)

    def as_dict(self) -> dict:
        return {"rms_position_m": self.positions, "rms_pressure_pa": self.pressures,
                "rms_speed_relative": self.speeds, "highest_pressure_pa": self.p_highest,
                "worst_position_m": self.worst_position, "worst_pressure_relative": self.worst_pressure,
                "worst_speed_relative": self.worst_speed, "holds": self.holds,
                "limits": {"position_m": LIMIT_POSITION, "pressure_relative": LIMIT_PRESSURE,
                           "speed_relative": LIMIT_SPEED}}


def state_columns(res: CircuitResult, units: tuple[str, ...]) -> list[str]:
    """The components' state columns of the given units (positions: m; speeds: m/s, rad/s), not node pressures."""
    return [k for k in res.states if res.units[k] in units]


def compare_to_reference(run: CircuitResult, ref: CircuitResult) -> Accuracy:
    """RMS errors of ``run`` (interpolated onto the reference's times where the grids differ) against ``ref``."""
    t_ref, t = ref.columns["t"], run.columns["t"]
    same = len(t) == len(t_ref) and np.array_equal(t, t_ref)

    def err(col):
        a = run.columns[col] if same else np.interp(t_ref, t, run.columns[col])
        return float(np.sqrt(np.mean((a - ref.columns[col]) ** 2)))
    nodes = [k for k, u in ref.units.items() if u == "Pa" and k.endswith(".p")]
    p_highest = max((float(np.max(ref.columns[k])) for k in nodes), default=0.0)
    speeds = {}
    for k in state_columns(ref, ("m/s", "rad/s")):
        scale = float(np.max(np.abs(ref.columns[k])))
        speeds[k] = err(k) / scale if scale > 0 else err(k)
    return Accuracy({k: err(k) for k in state_columns(ref, ("m",))}, {k: err(k) for k in nodes}, speeds, p_highest)
