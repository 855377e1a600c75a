"""Run a scenario with the hybrid model (any fixed-step solver) or the continuous reference model."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from hydrohil.errors import SimulationDiverged
from hydrohil.models.layout import pack
from hydrohil.parameters import Parameters
from hydrohil.simulation.diagnostics import divergence_error
from hydrohil.simulation.loop import LOG_COLUMNS, STATUS_OK, initial_state, run_loop
from hydrohil.simulation.scenario import LoadedScenario
from hydrohil.solvers.reference import solve_reference


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
        from hydrohil.simulation.diagnostics import mode_names
        last = self.log[-1]
        sim_time = self.steps * self.step
        out = {
            "solver": self.solver, "step": self.step, "steps": self.steps, "simulated_time_s": sim_time,
            "wall_time_s": self.wall_time_s,
            "realtime_factor": sim_time / self.wall_time_s if self.wall_time_s > 0 else None,
            "final_state": {c: float(last[LOG_COLUMNS.index(c)]) for c in ("xs", "vs", "p1", "p2", "xp", "vp", "z")},
            "final_modes": mode_names(last[11:14]),
            "max_abs_p1": float(np.abs(self.column("p1")).max()),
            "max_abs_p2": float(np.abs(self.column("p2")).max()),
            "events": int(self.column("events").sum()),
            "diverged": str(self.diverged) if self.diverged else None,
        }
        out.update(self.extra)
        return out


def run_scenario(sc: LoadedScenario, *, progress=None) -> SimulationResult:
    """Simulate a loaded scenario; returns the log (also when the run diverged: see ``.diverged``)."""
    s, params = sc.scenario, sc.params
    if s.faults or s.python_controller:          # a Python loop: the virtual rig's
        from hydrohil.simulation.rig import run_rig
        return run_rig(sc, progress=progress)
    h, n = s.solver.step, s.n_steps()
    p = pack(params)
    y, m = initial_state(params, s.initial.xp, xs=s.initial.xs, p1=s.initial.p1, p2=s.initial.p2, p=p)
    closed = s.closed_loop
    drive, slopes = s.drive()
    ctl = sc.make_controller() if closed else None
    every = s.solver.output_every
    if s.solver.method == "reference":
        t0 = time.perf_counter()
        stats: dict = {}
        status, done, log, yend = solve_reference(p, y, h, n, drive, controller=ctl, slopes=slopes, seed=s.hil.seed,
                                                  every=every, rtol=s.solver.rtol, progress=progress, stats=stats)
        wall = time.perf_counter() - t0
        div = None
        if status != STATUS_OK:
            reason = stats.pop("failure", None) or "non-finite or unphysical state"
            div = divergence_error(done * h, yend, np.zeros(3, dtype=np.int64), reason)
        extra = {"reference_intervals": stats["intervals"], "reference_radau_fallbacks": stats["radau_fallbacks"]}
        return SimulationResult(log, "reference", h, wall, div, extra=extra)
    status, done, log, wall = run_hybrid(params, p, y, m, h, n, every, drive, controller=ctl, slopes=slopes,
                                         seed=s.hil.seed, solver=s.solver.method)
    div = None if status == STATUS_OK else divergence_error(done * h, y, m)
    return SimulationResult(log, s.solver.method, h, wall, div)


def run_hybrid(params: Parameters, p: np.ndarray, y: np.ndarray, m: np.ndarray, h: float, n: int, every: int,
               values: np.ndarray, *, controller=None, slopes: np.ndarray | None = None, seed: int = 0,
               solver: str = "rk3"):
    """Run the core's loop with the hybrid model for n steps from (y, m), both updated in place.

    Open loop: ``values[k]`` is the command held over step k (n + 1 values). Closed loop: the built-in
    ``controller`` on the references ``values`` (slopes ``slopes``). Returns (status, steps done, log rows,
    wall time of the loop [s])."""
    t0 = time.perf_counter()
    status, done, log = run_loop(params, p, y, m, h, n, every, values, controller=controller, slopes=slopes,
                                 seed=seed, solver=solver)
    return status, done, log, time.perf_counter() - t0
