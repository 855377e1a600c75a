"""Run a scenario with the hybrid model (any fixed-step solver) or the continuous reference model."""

from __future__ import annotations

import time

import numpy as np

from hydrohil.models.layout import pack
from hydrohil.parameters import Parameters
from hydrohil.simulation.diagnostics import divergence_error
from hydrohil.simulation.loop import STATUS_OK, initial_state, run_loop
from hydrohil.simulation.reference import solve_reference
from hydrohil.simulation.result import SimulationResult
from hydrohil.simulation.scenario import LoadedScenario


ENGINES = ("generated", "core")


def run_scenario(sc: LoadedScenario, *, progress=None, engine: str = "generated") -> SimulationResult:
    """Simulate a loaded scenario; returns the log (also when the run diverged: see ``.diverged``).

    ``engine = "generated"`` (the default): a fixed-step run (a drive, a built-in law or a Python controller, its
    faults) runs
    on the code generated from the scenario's circuit (:func:`hydrohil.simulation.as_circuit.run_generated`: the
    core's log and the rig's columns bit for bit, but for a stuck spool's speed in its first row, said there);
    ``"core"`` on the hand-written core (with faults or a Python controller, the virtual rig's). The continuous
    reference runs the core's sampled loop either way, on the right-hand side generated from the circuit
    (:func:`hydrohil.simulation.generated_model.generated_reference_rhs`: the core's reference.c's bit for bit) or,
    ``"core"``, reference.c's."""
    if engine not in ENGINES:
        raise ValueError(f"engine: one of {', '.join(ENGINES)}, got {engine!r}")
    s, params = sc.scenario, sc.params
    fixed = s.solver.method != "reference"
    if engine == "generated" and fixed:
        from hydrohil.simulation.as_circuit import run_generated
        res = run_generated(sc, progress=progress)
        if res is not None:
            return res                           # (None: what a circuit does not take; the core's run, below)
    if s.faults or s.python_controller:          # the virtual rig's loop (its faults, a controller in Python)
        from hydrohil.simulation.rig import run_rig
        return run_rig(sc, progress=progress, engine=engine)
    h, n = s.solver.step, s.n_steps()
    p = pack(params)
    y, m = initial_state(params, s.initial.xp, xs=s.initial.xs, p1=s.initial.p1, p2=s.initial.p2, p=p)
    closed = s.closed_loop
    drive, slopes = s.drive()
    ctl = sc.make_controller() if closed else None
    every = s.solver.output_every
    if s.solver.method == "reference":
        rhs = None
        if engine == "generated":                # the circuit's equations in the core's sampled loop
            from hydrohil.simulation.generated_model import generated_reference_rhs
            rhs = generated_reference_rhs(params)
        t0 = time.perf_counter()
        stats: dict = {}
        status, done, log, yend = solve_reference(p, y, h, n, drive, controller=ctl, slopes=slopes, seed=s.hil.seed,
                                                  every=every, rtol=s.solver.rtol, progress=progress, stats=stats,
                                                  rhs=rhs)
        wall = time.perf_counter() - t0
        div = None
        if status != STATUS_OK:
            reason = stats.pop("failure", None) or "non-finite or unphysical state"
            div = divergence_error(done * h, yend, np.zeros(3, dtype=np.int64), reason)
        extra = {"reference_intervals": stats["intervals"], "reference_radau_fallbacks": stats["radau_fallbacks"]}
        return SimulationResult(log, "reference", h, wall, div, extra=extra)
    status, done, log, wall = run_hybrid(params, p, y, m, h, n, every, drive, controller=ctl, slopes=slopes,
                                         seed=s.hil.seed, solver=s.solver.method, engine=engine)
    div = None if status == STATUS_OK else divergence_error(done * h, y, m)
    return SimulationResult(log, s.solver.method, h, wall, div)


def run_hybrid(params: Parameters, p: np.ndarray, y: np.ndarray, m: np.ndarray, h: float, n: int, every: int,
               values: np.ndarray, *, controller=None, slopes: np.ndarray | None = None, seed: int = 0,
               solver: str = "rk3", engine: str = "generated"):
    """Run the core's loop with the hybrid model (``engine``: generated from the circuit of ``params``, or the
    core's) for n steps from (y, m), both updated in place.

    Open loop: ``values[k]`` is the command held over step k (n + 1 values). Closed loop: the built-in
    ``controller`` on the references ``values`` (slopes ``slopes``). Returns (status, steps done, log rows,
    wall time of the loop [s])."""
    t0 = time.perf_counter()
    status, done, log = run_loop(params, p, y, m, h, n, every, values, controller=controller, slopes=slopes,
                                 seed=seed, solver=solver, engine=engine)
    return status, done, log, time.perf_counter() - t0
