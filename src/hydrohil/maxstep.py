"""Largest stable fixed step of the hybrid model and of the continuous (stiff end-stop) model.

A fixed step h is **stable** on a scenario when the explicit run over the whole scenario
1. stays finite and physical (no divergence: |p| < 1e9 Pa, |vp| < 100 m/s, xp within [-L, 2L]),
2. stays bounded: chamber pressures within [-1 bar, 1.5*Ps] and the spool within [-2, 2], and
3. stays close to the continuous reference solved by LSODA at tight tolerance (no growing or
   spurious oscillation): RMS position error <= ``tol_x`` (default 2 mm) and RMS pressure error
   <= ``tol_p`` (default 10 bar), on the reference's sample grid.
The input is zero-order held at the plant step (controller sampled at the plant step). The search
brackets a stable and an unstable step by halving/doubling from 0.5 ms, then bisects geometrically
until the bracket ratio is below ``1 + rel_tol``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from hydrohil.models.layout import pack
from hydrohil.simulation.loop import STATUS_OK, Sim, initial_state
from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import LoadedScenario
from hydrohil.simulation.reference import solve_reference


def continuous_run(sc: LoadedScenario, solver: str, h: float, engine: str = "generated"):
    """The continuous (stiff end-stop) model at the fixed explicit step h, driven like the scenario (its
    commands or references sampled by zero-order hold at each step); the core's loop with maxstep's bounds
    (|p| <= 1.5 Ps, |xs| <= 2), its steps the code generated from the scenario's circuit
    (:func:`hydrohil.simulation.generated_model.generated_continuous_model`) or, ``engine = "core"``, reference.c's.
    Returns (ok, log)."""
    s, params = sc.scenario, sc.params
    p = pack(params)
    h_out = s.solver.step
    y, m = initial_state(params, s.initial.xp, xs=s.initial.xs, p1=s.initial.p1, p2=s.initial.p2, p=p)
    if engine == "generated":
        from hydrohil.simulation.generated_model import generated_continuous_model
        sim = Sim(p, h, model="external", bounded=True)
        generated_continuous_model(params, sim, solver)
    else:
        sim = Sim(p, h, model="continuous", solver=solver, bounded=True)
    sim.set_state(y, m)
    t_in = np.arange(s.n_steps() + 1) * h_out
    every = max(1, int(round(h_out / h)))
    values, slopes = s.drive()
    status, _, log = sim.run(int(round(s.duration / h)), every, values, slopes=slopes, t_in=t_in, seed=s.hil.seed,
                             controller=sc.make_controller(h) if s.closed_loop else None)
    return status == STATUS_OK, log


def _errors(t, xp, p1, p2, ref_log):
    tr = ref_log[:, 0]
    ex = np.interp(tr, t, xp) - ref_log[:, 7]
    e1 = np.interp(tr, t, p1) - ref_log[:, 5]
    e2 = np.interp(tr, t, p2) - ref_log[:, 6]
    rms = lambda e: float(np.sqrt(np.mean(e ** 2)))  # noqa: E731
    return rms(ex), max(rms(e1), rms(e2))


def check_step(sc: LoadedScenario, model: str, solver: str, h: float, ref_log: np.ndarray,
               tol_x: float = 2e-3, tol_p: float = 10e5, engine: str = "generated") -> dict:
    """Run one candidate step (on ``engine``, run_scenario's); returns {stable, reason, rms_x, rms_p, wall_s}."""
    s, params = sc.scenario, sc.params
    h_out = s.solver.step
    t0 = time.perf_counter()
    if model == "hybrid":
        scn = sc.model_copy(update={"scenario": s.model_copy(update={
            "solver": s.solver.model_copy(update={"method": solver, "step": h,
                                                  "output_every": max(1, int(round(h_out / h)))})})})
        res = run_scenario(scn, engine=engine)
        if res.diverged:
            return {"stable": False, "reason": "diverged", "wall_s": time.perf_counter() - t0}
        t, xp, p1, p2 = (res.column(c) for c in ("t", "xp", "p1", "p2"))
        ok_bounds = p1.max() <= 1.5 * params.supply.ps and p2.max() <= 1.5 * params.supply.ps
        if not ok_bounds:
            return {"stable": False, "reason": "unbounded pressure", "wall_s": time.perf_counter() - t0}
    else:
        ok, log = continuous_run(sc, solver, h, engine)
        if not ok:
            return {"stable": False, "reason": "diverged or unbounded", "wall_s": time.perf_counter() - t0}
        t, xp, p1, p2 = log[:, 0], log[:, 7], log[:, 5], log[:, 6]
    ex, ep = _errors(t, xp, p1, p2, ref_log)
    stable = ex <= tol_x and ep <= tol_p
    return {"stable": stable, "reason": "ok" if stable else "far from reference", "rms_x": ex, "rms_p": ep,
            "wall_s": time.perf_counter() - t0}


def largest_stable(test, *, h0: float = 5e-4, rel_tol: float = 0.05, h_min: float = 1e-10,
                   h_max: float = 2e-2) -> tuple[float | None, float | None]:
    """(largest stable, smallest unstable) step by ``test(h) -> bool``: from h0 doubling (or quartering) to a
    bracket, then geometric bisection until the bracket's ratio is below 1 + rel_tol."""
    lo, hi = None, None
    h = h0
    if test(h):
        lo = h
        while hi is None:
            h *= 2
            if h > h_max:
                break
            if test(h):
                lo = h
            else:
                hi = h
    else:
        hi = h
        while lo is None:
            h /= 4
            if h < h_min:
                break
            if test(h):
                lo = h
            else:
                hi = h
    if lo is not None and hi is not None:
        while hi / lo > 1 + rel_tol:
            mid = float(np.sqrt(lo * hi))
            if test(mid):
                lo = mid
            else:
                hi = mid
    return lo, hi


def max_stable_step(sc: LoadedScenario, model: str = "hybrid", solver: str = "rk3", *, tol_x: float = 2e-3,
                    tol_p: float = 10e5, rel_tol: float = 0.05, h_min: float = 1e-10, h_max: float = 2e-2,
                    progress=None, engine: str = "generated") -> dict:
    """Bisect for the largest stable fixed step (definition in the module docstring). ``engine``: the runs, the
    continuous model's and the reference's right-hand side on the code generated from the scenario's circuit, or
    on the hand-written core ("core"): the same results."""
    if model not in ("hybrid", "continuous"):
        raise ValueError("model must be 'hybrid' or 'continuous'")
    s, params = sc.scenario, sc.params
    if s.python_controller:
        from hydrohil.errors import InputError
        raise InputError("maxstep compares against the stiff reference model, which runs built-in controllers "
                         "only (p, pi, pid, p_ff, state_feedback)", source=sc.source, key="controller.type")
    p = pack(params)
    y0, _ = initial_state(params, s.initial.xp, xs=s.initial.xs, p1=s.initial.p1, p2=s.initial.p2, p=p)
    stats: dict = {}
    values, slopes = s.drive()
    rhs = None
    if engine == "generated":
        from hydrohil.simulation.generated_model import generated_reference_rhs
        rhs = generated_reference_rhs(params)
    status, done, ref_log, y_end = solve_reference(p, y0, s.solver.step, s.n_steps(), values, slopes=slopes,
                                                   controller=sc.make_controller() if s.closed_loop else None,
                                                   seed=s.hil.seed, stats=stats, rhs=rhs)
    if status != STATUS_OK:      # no trustworthy reference: no step can be judged against it
        from hydrohil.simulation.diagnostics import divergence_error
        raise divergence_error(done * s.solver.step, y_end, np.zeros(3, dtype=np.int64),
                               "reference solution failed: " + stats.get("failure", "non-finite or unphysical state"))
    trials = []

    def test(h):
        r = check_step(sc, model, solver, h, ref_log, tol_x, tol_p, engine)
        r["step"] = h
        trials.append(r)
        if progress:
            progress(h, r)
        return r["stable"]

    lo, hi = largest_stable(test, rel_tol=rel_tol, h_min=h_min, h_max=h_max)
    return {"max_stable_step": lo, "first_unstable_step": hi, "model": model, "solver": solver,
            "scenario": sc.source, "duration": s.duration, "tol_x_m": tol_x, "tol_p_pa": tol_p,
            "criteria": "finite, |p| <= 1.5 Ps, RMS error vs LSODA reference <= tol_x and tol_p",
            "trials": [{k: v for k, v in t.items()} for t in trials]}


def circuit_verdict(h_max: float | None, h_bad: float | None, tol_x: float, tol_p: float, h: float, acc) -> str:
    """The two answers of a circuit's maxstep in words: how far the step may grow (stable, and within the
    search's coarse tolerances; ``h_bad`` None: no step up to the search's ceiling failed) and whether the
    scenario's own step meets the accuracy limits (SPEC §12: RMS against the continuous reference), naming the
    worst signal of each limit missed."""
    from hydrohil.circuits.accuracy import LIMIT_POSITION, LIMIT_PRESSURE, LIMIT_SPEED
    tols = f"within {tol_x * 1e3:g} mm and {tol_p / 1e5:g} bar RMS of the reference, --tol-x/--tol-p"
    if h_max is None:
        out = f"no step is stable ({tols}), down to 1/1000 of the scenario's step; "
    else:
        out = (f"stable up to {'at least ' if h_bad is None else ''}{h_max * 1e3:.3g} ms ({tols}); ")
    out += (f"at the scenario's step {h * 1e3:g} ms the accuracy limits ({LIMIT_POSITION * 1e3:g} mm, "
            f"{LIMIT_PRESSURE:.0%} of the highest pressure, {LIMIT_SPEED:.0%} in speed RMS) ")
    if acc.holds:
        return out + "hold"
    d = acc.as_dict()
    worst = []
    for values, limit, text in (
            (d["rms_position_m"], LIMIT_POSITION, lambda v: f"{v * 1e3:.3g} mm"),
            ({k: v / acc.p_highest if acc.p_highest > 0 else 0.0 for k, v in d["rms_pressure_pa"].items()},
             LIMIT_PRESSURE,
             lambda v: f"{v:.2%} of the highest pressure"),
            (d["rms_speed_relative"], LIMIT_SPEED, lambda v: f"{v:.2%}")):
        missed = {k: v for k, v in values.items() if not v <= limit}      # (NaN: missed, not finite)
        if missed:
            name = max(missed, key=lambda k: math.inf if missed[k] != missed[k] else missed[k])
            v = missed[name]
            worst.append(f"{name} {'not finite' if v != v else text(v)}")
    return out + f"do not hold: {', '.join(worst) or 'not finite'} RMS"


def circuit_max_stable_step(cs, solver: str = "rk3", *, tol_x: float = 2e-3, tol_p: float = 10e5,
                            rel_tol: float = 0.05, h_max: float = 2e-2, progress=None) -> dict:
    """The largest stable fixed step of a circuit scenario (``hydrohil.circuits.scenario``) with ``solver``: the
    run at h stays finite, its pressures below 1.5x the reference's highest, and its RMS errors against the
    circuit's continuous reference (at the scenario's step) within tol_x in every position and tol_p in every
    pressure. Also the accuracy at the scenario's step (the README's table)."""
    from hydrohil.circuits.accuracy import compare_to_reference
    from hydrohil.circuits.run import METHODS, simulate_circuit
    from hydrohil.errors import InputError, SimulationDiverged
    if solver not in METHODS:
        raise InputError(f"a fixed-step method to search the step of: one of {', '.join(METHODS)}, got {solver!r}",
                         key="--solver")
    c, h_out = cs.circuit, cs.step
    ref = simulate_circuit(c, cs.duration, h=h_out, method="reference", rest=cs.rest, loop=cs.loop,
                           commands=cs.commands)
    at_step = compare_to_reference(simulate_circuit(c, cs.duration, h=h_out, method=solver, rest=cs.rest,
                                                    loop=cs.loop, commands=cs.commands), ref)
    trials = []

    def test(h):
        import warnings
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():          # (a candidate's own rest may be off: judged by its run)
                warnings.simplefilter("ignore")
                run = simulate_circuit(c, cs.duration, h=h, method=solver, rest=cs.rest, loop=cs.loop,
                                       commands=cs.commands,
                                       every=max(1, int(round(h_out / h))))     # (a row per reference sample)
        except SimulationDiverged:
            r = {"stable": False, "reason": "diverged"}
        else:
            acc = compare_to_reference(run, ref)
            highest = max(float(np.max(run.columns[k])) for k in acc.pressures) if acc.pressures else 0.0
            rms_x, rms_p = acc.worst_position, max(acc.pressures.values(), default=0.0)
            if highest > 1.5 * acc.p_highest:
                r = {"stable": False, "reason": "unbounded pressure"}
            else:
                ok = rms_x <= tol_x and rms_p <= tol_p
                r = {"stable": ok, "reason": "ok" if ok else "far from reference", "rms_x": rms_x, "rms_p": rms_p}
        r.update(step=h, wall_s=time.perf_counter() - t0)
        trials.append(r)
        if progress:
            progress(h, r)
        return r["stable"]

    lo, hi = largest_stable(test, h0=h_out, rel_tol=rel_tol, h_min=h_out / 1000, h_max=h_max)
    return {"verdict": circuit_verdict(lo, hi, tol_x, tol_p, h_out, at_step),
            "max_stable_step": lo, "first_unstable_step": hi, "model": "hybrid", "solver": solver,
            "scenario": cs.source, "circuit": c.name, "duration": cs.duration, "tol_x_m": tol_x, "tol_p_pa": tol_p,
            "criteria": "finite, pressures <= 1.5x the reference's highest, RMS error vs the circuit's continuous "
                        "reference (LSODA) <= tol_x in every position and tol_p in every pressure (speeds: see "
                        "accuracy_at_step); searched down to 1/1000 of the scenario's step",
            "accuracy_at_step": {"step": h_out, **at_step.as_dict()}, "trials": trials}
