"""The result of a simulation run: the log (SI units, mode codes), how it was computed, and its summary."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hydrohil.errors import SimulationDiverged
from hydrohil.models.layout import MODE_COLUMNS, STATE_NAMES
from hydrohil.simulation.diagnostics import mode_names
from hydrohil.simulation.loop import LOG_COLUMNS


@dataclass
class SimulationResult:
    log: np.ndarray                 # rows x LOG_COLUMNS, SI units, mode codes
    solver: str
    step: float
    wall_time_s: float              # integration loop only
    diverged: SimulationDiverged | None = None
    extra: dict = field(default_factory=dict)
    columns: dict = field(default_factory=dict)   # extra per-row columns (rig runs: faults, x_meas, watchdog)

    def column(self, name: str) -> np.ndarray:
        if name in self.columns:
            return self.columns[name]
        return self.log[:, LOG_COLUMNS.index(name)]

    @property
    def steps(self) -> int:
        return int(round(self.log[-1, 0] / self.step)) if len(self.log) else 0

    def summary(self) -> dict:
        last = self.log[-1]
        sim_time = self.steps * self.step
        out = {
            "solver": self.solver, "step": self.step, "steps": self.steps, "simulated_time_s": sim_time,
            "wall_time_s": self.wall_time_s,
            "realtime_factor": sim_time / self.wall_time_s if self.wall_time_s > 0 else None,
            "final_state": {c: float(last[LOG_COLUMNS.index(c)]) for c in STATE_NAMES},
            "final_modes": mode_names([last[LOG_COLUMNS.index(c)] for c in MODE_COLUMNS]),
            "max_abs_p1": float(np.abs(self.column("p1")).max()),
            "max_abs_p2": float(np.abs(self.column("p2")).max()),
            "events": int(self.column("events").sum()),
            "diverged": str(self.diverged) if self.diverged else None,
        }
        out.update(self.extra)
        return out
