"""Run test sequences offline, in lock-step or in real time, and judge their expectations.

``offline``: the compiled scenario through the virtual rig in this process (:func:`~hydrohil.simulation.rig.run_rig`,
the same sensors, faults and watchdog as the HIL plant), with the scenario's controller or a Python
callable. ``lockstep`` / ``realtime``: ``hydrohil hil`` with the plant and the controller as two processes
(the scenario's controller, or an external program that speaks the protocol); a lock-step run steps the
model exactly as the offline run. A real-time run whose timing is INVALID is an *error*: its signals do not
show what the controller would do on the rig, so nothing passes.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from hydrohil.errors import HydrohilError, InputError
from hydrohil.sequences.expectations import (Outcome, Predicate, Signals, evaluate, loop_units,
                                             signals_from_columns)
from hydrohil.sequences.sequence import LoadedSequence, load_sequence, slug

MODES = ("offline", "lockstep", "realtime")


@dataclass
class SequenceResult:
    """A sequence's run: ``status`` pass (every expectation met), fail (one or more not met) or error (the run
    could not be judged: diverged, a process failed, an INVALID real-time run), its outcomes and signals."""
    name: str
    mode: str
    status: str
    outcomes: list[Outcome]
    out: Path
    source: str = ""
    error: str | None = None
    wall_s: float = 0.0
    signals: Signals | None = field(default=None, repr=False)
    verdict: dict | None = None

    @property
    def passed(self) -> bool:
        return self.status == "pass"

    def counts(self) -> dict[str, int]:
        return {k: sum(o.status == k for o in self.outcomes) for k in ("pass", "fail", "error")}

    def summary(self) -> dict:
        return {"name": self.name, "mode": self.mode, "status": self.status, "error": self.error,
                "source": self.source, "wall_s": self.wall_s, "verdict": self.verdict,
                "expectations": [{"name": o.name, "type": o.type, "status": o.status, "message": o.message,
                                  "measured": o.measured, "limit": o.limit} for o in self.outcomes]}


def _predicates(seq: LoadedSequence, given: dict[int, Callable] | None) -> dict[int, Callable]:
    from hydrohil.control import load_callable
    out = dict(given or {})
    for i, e in enumerate(seq.expectations):
        if isinstance(e, Predicate) and i not in out:
            out[i] = load_callable(e.function, seq.source.parent, str(seq.source), key=f"expect[{i}].function")
    return out


def run_sequence(sequence: str | Path | LoadedSequence, out: str | Path, *, mode: str = "offline",
                 controller: str | Callable | None = None, predicates: dict[int, Callable] | None = None,
                 progress: Callable | None = None) -> SequenceResult:
    """Run one sequence into the folder ``out`` (compiled ``scenario.toml``, the run's logs, ``result.json``)
    and judge it. ``controller``: None (the scenario's), a Python callable (offline only) or the command line
    of an external program (``{host} {port} {scenario} {duration} {out}`` filled in; lock-step / real time,
    :func:`hydrohil.hil.run.run_hil`). ``predicates``: {expectation index: callable} for ``predicate``
    expectations given in Python. InputError for bad input; every other problem is the result's error."""
    import time
    seq = sequence if isinstance(sequence, LoadedSequence) else load_sequence(sequence)
    if mode not in MODES:
        raise InputError(f"must be one of {', '.join(MODES)}, got {mode!r}", key="mode")
    external = isinstance(controller, str)
    if external and mode == "offline":
        raise InputError("an external controller program runs against the plant process: use --mode lockstep "
                         "or realtime", key="controller")
    if callable(controller) and mode != "offline":
        raise InputError("a Python callable controller runs offline; in lock-step or real time give a "
                         "[controller] table (type = \"python\") or a program", key="controller")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if seq.circuit is not None:
        return _run_circuit_sequence(seq, out, mode, controller, predicates)
    scen = seq.compile(out / "scenario.toml")
    preds = _predicates(seq, predicates)
    from hydrohil.simulation.scenario import load_scenario
    sc = load_scenario(scen)
    s = sc.scenario
    if not s.closed_loop:
        raise InputError("a test sequence needs a closed-loop scenario ([controller] + [reference])",
                         source=str(seq.source), key="scenario")
    t0 = time.perf_counter()
    kw = {"safe_state": s.hil.safe_state, "mode": mode}
    error = verdict = None
    cols = None
    try:
        if mode == "offline":              # (the generated code; a callable passed in: the rig's)
            from hydrohil.simulation.as_circuit import run_generated
            from hydrohil.simulation.rig import run_rig
            res = None
            if controller is None and s.solver.method != "reference":
                res = run_generated(sc, progress=progress, rig=True)
            if res is None:                 # (not for the generated code: the rig's run)
                res = run_rig(sc, controller=controller, progress=progress)
            from hydrohil.simulation.outputs import write_log_csv
            write_log_csv(out / "log.csv", res.log, res.columns)
            cols = {c: res.column(c) for c in ("t", "u", "xs", "p1", "p2", "xp", "vp", "ff", "watchdog", "faults",
                                               "x_meas", "p1_meas", "p2_meas", "ps_meas")}
            cols["u"] = _as_applied(cols["u"])
            if res.diverged is not None:
                error = str(res.diverged)
        else:
            from hydrohil.hil.run import run_hil
            from hydrohil.simulation.outputs import read_csv_columns
            hil = run_hil(scen, out, lockstep=mode == "lockstep", plot=False,
                          controller=controller if external else None)
            log = read_csv_columns(out / "plant_log.csv")
            cols = dict(log)
            if len(log["u"]) > 1:       # the plant logs at row k the command it applied over step k-1 -> k
                cols["u"] = np.append(log["u"][1:], log["u"][-1])
            from hydrohil.models.sensors import count_size
            cols["x_meas"] = log["encoder"] * count_size(sc.params.sensors.encoder_resolution)
            verdict, error = _verdict(hil, mode)
    except InputError:
        raise
    except HydrohilError as exc:
        error = f"{type(exc).__name__}: {exc}"
    wall = time.perf_counter() - t0
    outcomes: list[Outcome] = []
    signals = None
    if cols is not None and len(cols["t"]):
        signals = signals_from_columns(cols, s.reference.sample(np.asarray(cols["t"], float))[0],
                                       seq.event_times(), **kw)
        outcomes = evaluate(seq.expectations, signals, preds)
    return _judged(seq, out, mode, outcomes, error, wall, signals, verdict)


def _verdict(hil, mode: str) -> tuple[dict | None, str | None]:
    """A HIL run's verdict (real time only: lock-step has no clock to keep) and the error an INVALID one is."""
    if mode != "realtime":
        return None, None
    v = hil.verdict
    return v, None if v["valid"] else f"real-time run INVALID: {'; '.join(v['reasons'])}"


def _judged(seq: LoadedSequence, out: Path, mode: str, outcomes: list[Outcome], error: str | None, wall: float,
            signals, verdict: dict | None) -> SequenceResult:
    """The sequence's result (``result.json`` written): a run that cannot be judged (``error``) judges none of
    its expectations; else pass when every expectation passed."""
    if error is not None:
        outcomes = [dataclasses.replace(o, status="error", message=f"not judged ({error}); measured: {o.message}")
                    for o in outcomes]
        status = "error"
    elif any(o.status == "error" for o in outcomes):
        status = "error"
    else:
        status = "pass" if all(o.passed for o in outcomes) else "fail"
    result = SequenceResult(seq.name, mode, status, outcomes, out, str(seq.source), error, wall, signals, verdict)
    (out / "result.json").write_text(json.dumps(result.summary(), indent=2, default=float) + "\n")
    return result


def _run_circuit_sequence(seq: LoadedSequence, out: Path, mode: str, controller, predicates) -> SequenceResult:
    """A circuit's sequence: its compiled circuit scenario run with its loop offline (the generated C) or as HIL
    (:func:`hydrohil.hil.run.run_hil`, lock-step or real time; ``controller``: an external program's command
    line), its signals every log column (``component.variable``) and every input as it drove each step, with,
    in closed loop, the loop's ``x_ref`` (its reference), ``xp`` (its measured signal) and ``error``, in their
    SI units."""
    import time
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.sequences.expectations import Bounds, Reaction
    if callable(controller):
        raise InputError("a circuit's sequence runs its scenario's controller, or an external program in lock-step "
                         "or real time", source=str(seq.source), key="controller")
    scen = seq.compile(out / "scenario.toml")
    cs = load_circuit_scenario(scen)
    preds = _predicates(seq, predicates)
    t0 = time.perf_counter()
    error, signals, outcomes, verdict = None, None, [], None
    cols = units = None
    try:
        if mode == "offline":
            cols, units = _circuit_offline(cs, out)
        else:
            from hydrohil.hil.run import run_hil
            hil = run_hil(scen, out, lockstep=mode == "lockstep", plot=False, controller=controller,
                          ready=lambda *a, **k: None)
            cols, units = _circuit_hil_columns(cs, out)
            verdict, error = _verdict(hil, mode)
    except InputError:
        raise
    except HydrohilError as exc:         # (a diverged run, a failed process)
        error = f"{type(exc).__name__}: {exc}"
    if cols is not None and len(cols["t"]):
        lp = cs.loop
        if lp is not None:                 # the loop's reference, measure, error and command under the rig's names
            cols["x_ref"], cols["xp"] = cols[f"{lp.measure}.reference"], cols[lp.measure]
            cols["error"] = cols["x_ref"] - cols["xp"]
            cols["u"] = cols[lp.command]
            units.update(loop_units(units, lp))
        for i, e in enumerate(seq.expectations):
            sig = getattr(e, "signal", None) if isinstance(e, (Bounds, Reaction)) else None
            if sig is not None and sig not in cols:
                from hydrohil.errors import unknown_name
                raise InputError(unknown_name(sig, [c for c in cols if c != "t"], what="signal of this circuit"),
                                 source=str(seq.source), key=f"expect[{i}].signal")
        signals = Signals(cols, seq.event_times(), mode=mode, units=units,
                          safe_state=cs.hil.get("safe_state", "centre"))
        outcomes = evaluate(seq.expectations, signals, preds)
    return _judged(seq, out, mode, outcomes, error, time.perf_counter() - t0, signals, verdict)


def _circuit_offline(cs, out: Path) -> tuple[dict, dict]:
    """A circuit scenario run offline (log.csv written): its columns and units; each input's last row what drove
    the last step (the log's: the drive or the law at t_n, never applied), as the HIL plant's log gives it."""
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.show import write_log
    res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, method=cs.method, every=cs.every, rest=cs.rest,
                           loop=cs.loop, commands=cs.commands)
    write_log(res, out / "log.csv")
    cols = {k: np.asarray(v, float) for k, v in res.columns.items()}
    for name in cs.circuit.inputs:
        cols[name] = _as_applied(cols[name])
    return cols, dict(res.units)


def _as_applied(u: np.ndarray) -> np.ndarray:
    """An offline log's input column as the HIL plant's log has it: its last row (the drive's or the controller's
    answer to the final state, never applied) replaced by the row before, what drove the last step."""
    return np.append(u[:-1], u[-2]) if len(u) > 1 else u


def _circuit_hil_columns(cs, out: Path) -> tuple[dict, dict]:
    """A circuit's HIL plant log as the offline run's columns: every signal; each input as it drove the step
    from each row (the plant logs at row k what drove step k-1 -> k); the loop's reference and what its sensor
    read."""
    from hydrohil.circuits.build import compile_circuit
    from hydrohil.circuits.link import circuit_link
    from hydrohil.simulation.outputs import read_csv_columns
    log = read_csv_columns(out / "plant_log.csv")
    cc = compile_circuit(cs.circuit)
    signals, inputs, _ = circuit_link(cs.circuit)
    cols = {"t": np.asarray(log["t"], float), **{n: np.asarray(log[n], float) for n, _ in signals},
            "watchdog": np.asarray(log["watchdog"], float)}
    units = {"t": "s", **dict(signals), **dict(inputs), "watchdog": "-"}
    for name, _ in inputs:
        applied = np.asarray(log[f"{name}.applied"], float)
        cols[name] = np.append(applied[1:], applied[-1]) if len(applied) > 1 else applied
    lp = cs.loop
    if lp is not None:
        cols[f"{lp.measure}.reference"] = lp.at(cols["t"], cs.step)
        units[f"{lp.measure}.reference"] = units[lp.measure]
        if lp.sensor is not None:
            from hydrohil.circuits.run import sensed_column
            cols[f"{lp.measure}.sensed"] = sensed_column(cc, lp, cols[lp.measure])
            units[f"{lp.measure}.sensed"] = units[lp.measure]
    return cols, units


def run_suite(paths: list[str | Path], out: str | Path, *, mode: str = "offline", controller=None,
              junit: str | Path | None = None, report: bool = True, echo: Callable | None = None) -> list[SequenceResult]:
    """Run several sequence files, each into ``out/<name>/``; write ``out/report.md`` (a figure per failed
    expectation) and, with ``junit``, a JUnit XML file. All files (and the mode) are validated before the first
    run."""
    if mode not in MODES:
        raise InputError(f"must be one of {', '.join(MODES)}, got {mode!r}", source="--mode")
    seqs = [load_sequence(p) for p in paths]
    names = [slug(s.name) for s in seqs]
    dirs = [Path(out) / (n if names.count(n) == 1 else f"{n}_{i}") for i, n in enumerate(names)]
    results = []
    for seq, d in zip(seqs, dirs):
        if echo:
            echo(f"{seq.name} ({mode}) ...")
        r = run_sequence(seq, d, mode=mode, controller=controller)
        results.append(r)
        if echo:
            echo(line(r))
    if report:
        from hydrohil.sequences.report import write_report
        write_report(results, Path(out) / "report.md")
    if junit is not None:
        from hydrohil.sequences.report import write_junit
        write_junit(results, Path(junit))
    return results


SHOWN = 5                                  # the failed or errored expectations a console line lists


def line(r: SequenceResult) -> str:
    """A sequence's result for the console: its counts, then each expectation that failed or could not be
    judged with why (the first SHOWN; report.md has them all)."""
    c = r.counts()
    head = {"pass": "PASS", "fail": "FAIL", "error": "ERROR"}[r.status]
    tail = f" — {r.error}" if r.error else ""
    out = [f"{head}  {r.name}: {c['pass']} passed, {c['fail']} failed, {c['error']} errors{tail}"]
    bad = [o for o in r.outcomes if not o.passed]
    out += [f"      {o.status}: {o.name}: {o.message}" for o in bad[:SHOWN]]
    if len(bad) > SHOWN:
        out.append(f"      … {len(bad) - SHOWN} more in report.md")
    return "\n".join(out)


def exit_code(results: list[SequenceResult]) -> int:
    """0: every sequence passed; 1: an expectation failed; 3: a run could not be judged (error)."""
    if any(r.status == "error" for r in results):
        return 3
    return 0 if all(r.passed for r in results) else 1
