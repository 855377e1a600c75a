"""One run of a study, as a Dask worker executes it: the run's scenario (or sequence) made from the study's
base file and the run's inputs, simulated offline, reduced to one row (inputs, metrics, verdicts, status).

A run that diverges or has bad input (a drawn mass below zero, say) is a row with its status and error,
never an exception that would stop the study. Workers read the study's files at the paths the client gave:
on a cluster of several machines they need a shared file system (as SLURM clusters have).
"""

from __future__ import annotations

import functools
import os
import socket
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

from hydrohil.errors import InputError
from hydrohil.studies.study import load_study



@functools.lru_cache(maxsize=8)
def _study(path: str, digest: str):
    return load_study(path)


ENGINE = "generated"    # a paper scenario's runs: the code generated from its circuit (run_scenario's; "core" the same rows)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3     # glibc's mallopt parameters (malloc.h)


@functools.cache
def keep_freed_memory() -> bool:
    """Let this process keep the memory a run frees for the next run (glibc: blocks up to 32 MB from the heap,
    the heap not trimmed below 256 MB of free space), instead of returning it to the system and taking every
    page again, zeroed, on the next run: a run's logs are a few MB, allocated and freed per run, so a worker
    spent about a third of a 12 000-step run in page faults (benchmarks/sweep.py). False where the C library
    is not glibc (nothing changed)."""
    import ctypes
    try:
        libc = ctypes.CDLL("libc.so.6")
        mmap = libc.mallopt(M_MMAP_THRESHOLD, 32 << 20)         # (glibc's largest: 32 MB on 64-bit)
        trim = libc.mallopt(M_TRIM_THRESHOLD, 256 << 20)
        return bool(mmap and trim)
    except (OSError, AttributeError):
        return False


def run_data(study, inputs: dict) -> tuple[dict, str, Path]:
    """(the run's table, "scenario" | "circuit" | "sequence", the base file): the base file's table with the run's
    inputs applied."""
    from hydrohil.parameters import read_toml
    from hydrohil.simulation.scenario import scenario_data
    st = study.settings(inputs)
    base = Path(st["base"])
    kind = "sequence" if study.study.sequence is not None else "scenario"
    if kind == "scenario" and study.circuit:
        return _circuit_data(base, st), "circuit", base
    if kind == "scenario":
        data = scenario_data(base, sets=st["sets"] or None)
    else:
        data = read_toml(base)
        from hydrohil.simulation.scenario import resolve_scenario
        data["scenario"] = str(resolve_scenario(data["scenario"], base.parent).resolve())
        pred = [e for e in data.get("expect", []) if e.get("type") == "predicate" and ":" in str(e.get("function"))]
        for e in pred:                      # predicate files stay where the sequence is
            f, _, name = e["function"].rpartition(":")
            if f.endswith(".py") and not Path(f).is_absolute():
                e["function"] = f"{(base.parent / f).resolve()}:{name}"
        if st["sets"]:
            data["set"] = {**data.get("set", {}), **st["sets"]}
    if st["controller"]:
        if kind == "scenario":
            data["controller"] = {**data.get("controller", {}), **st["controller"]}
        else:
            from hydrohil.simulation.scenario import load_scenario
            ctl = data.get("controller") or load_scenario(data["scenario"]).scenario.controller.model_dump(
                mode="json", exclude_none=True)
            data["controller"] = {**ctl, **st["controller"]}
    if st["initial"]:
        data["initial"] = {**data.get("initial", {}), **st["initial"]}
    if st["duration"] is not None:
        data["duration"] = st["duration"]
    return data, kind, base


def _circuit_data(base: Path, st: dict) -> dict:
    """A circuit scenario's table with a run's values: "component.key" in its [set], its loop's gains in its
    [controller], its circuit (and a user's controller's folder) by absolute path (the run's file lives
    elsewhere)."""
    from hydrohil.circuits.scenario import anchored
    from hydrohil.parameters import read_toml
    data = anchored(read_toml(base), base)
    if st["sets"]:
        data["set"] = {**data.get("set", {}), **st["sets"]}
    if st["controller"]:
        data["controller"] = {**data.get("controller", {}), **st["controller"]}
    if st["initial"]:
        raise InputError("a circuit scenario's initial state is its [set] (component.x0) and its circuit's "
                         "[initial]: vary those", source=str(base), key="vary")
    if st["duration"] is not None:
        data["duration"] = st["duration"]
    return data


def hold_error(t, x, x_ref, spans: list[tuple[int, int]] | None = None) -> float:
    """Largest |x_ref − xp| over the second half of every hold of the reference (the settled position error;
    ``spans``: metrics.holds(t, x_ref), when the caller has them)."""
    from hydrohil.metrics import holds
    worst = 0.0
    for first, last in holds(t, x_ref) if spans is None else spans:
        mid = first + (last - first) // 2
        worst = max(worst, float(np.max(np.abs(x_ref[mid:last + 1] - x[mid:last + 1]))))
    return worst


def metrics_of(t, xp, x_ref, p1, p2, sliding=None) -> dict:
    from hydrohil.metrics import holds, step_metrics
    spans = holds(t, x_ref)
    m = step_metrics(t, xp, x_ref, p1, p2, sliding=sliding, spans=spans)
    moves = m["moves"]

    def worst(key, f=lambda v: v):
        vals = [f(mv[key]) for mv in moves if mv[key] is not None]
        return float(max(vals)) if vals else None
    return {"rms_error": m["rms_error"], "max_abs_error": m["max_abs_error"], "max_hold_error": hold_error(t, xp, x_ref, spans),
            "max_p1": m["max_p1"], "max_p2": m["max_p2"], "max_overshoot_pct": worst("overshoot_pct"),
            "max_settling_time": worst("settling_time"), "max_abs_ss_error": worst("steady_state_error", abs),
            "breakaways": float(m.get("breakaways", 0)) if sliding is not None else None}


def execute(task: dict) -> dict:
    """Run one task (``run_id``, ``index``, ``inputs``, ``study``, ``digest``, ``logs``) -> its row."""
    import tomli_w
    keep_freed_memory()
    t0 = time.perf_counter()
    row = {"run_id": task["run_id"], "index": task["index"], "status": "ok", "error": None}
    row.update({f"in.{k}": v for k, v in task["inputs"].items()})
    try:
        from distributed import get_worker
        row["worker"] = get_worker().name if isinstance(get_worker().name, str) else get_worker().address
    except (ImportError, ValueError):
        row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    try:
        study = _study(task["study"], task["digest"])
        data, kind, base = run_data(study, task["inputs"])
        if kind == "scenario":           # (read in memory, as its base file would be: nothing written)
            cols, diverged = _run_scenario(data, base)
        else:
            with tempfile.TemporaryDirectory(prefix="hydrohil-run-") as d:
                path = Path(d) / f"{task['run_id']}.toml"
                path.write_text(tomli_w.dumps(data))
                if kind == "circuit":
                    cols, diverged = _run_circuit(path)
                else:
                    cols, diverged, verdicts = _run_sequence(path, Path(d))
                    row.update(verdicts)
        row.update(metrics_of(cols["t"], cols["xp"], cols["x_ref"], cols["p1"], cols["p2"], cols.get("friction_mode")))
        if diverged is not None:
            row["status"], row["error"] = "diverged", diverged
        if task.get("logs"):
            _write_log(Path(task["logs"]) / f"{task['run_id']}.parquet", cols)
    except InputError as exc:
        row["status"], row["error"] = "input_error", str(exc)
    except Exception as exc:             # a study must survive any single run: the row says what happened
        row["status"] = "error"
        row["error"] = f"{type(exc).__name__}: {exc} | {traceback.format_exc(limit=3)[-600:]}"
    row["wall_s"] = time.perf_counter() - t0
    return row


def execute_batch(tasks: list[dict]) -> list[dict]:
    """Run the tasks of one batch (:func:`execute` each, in order) -> their rows."""
    return [execute(task) for task in tasks]


STUDY_COLUMNS = ["t", "xp", "p1", "p2", "u", "xs", "friction_mode"]    # (the core's log: what a row and a run's log read)


def _run_scenario(data: dict, base: str | Path):
    """A paper scenario's run from its table ``data`` (the base file ``base``'s with the run's values): on the
    generated code, only the columns of :data:`STUDY_COLUMNS` logged (as_circuit.generated_columns: the values
    of run_scenario's log), else (what a circuit does not take, or ENGINE "core") run_scenario's run."""
    from hydrohil.simulation.as_circuit import generated_columns
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import scenario_from_data
    sc = scenario_from_data(data, base)
    if not sc.scenario.closed_loop:
        raise InputError("a study's scenario must be closed loop ([controller] + [reference])", source=str(base))
    run = generated_columns(sc, STUDY_COLUMNS, reference=True) if ENGINE == "generated" else None
    if run is None:
        res = run_scenario(sc, engine=ENGINE)
        run = {c: res.column(c) for c in STUDY_COLUMNS}, res.diverged
    cols, diverged = run
    if "x_ref" not in cols:              # (the generated run's: the loop's reference, the same values)
        cols["x_ref"] = sc.scenario.reference.sampler().values(cols["t"])
    return cols, (str(diverged) if diverged else None)


def _run_circuit(path: Path):
    """A circuit scenario's run, as the rig's columns: ``xp`` and ``x_ref`` the loop's measured signal and
    reference, ``p1`` and ``p2`` the highest node pressure at each step (so max_p1 = max_p2: the circuit's
    peak pressure), ``u`` the loop's command; every signal of the circuit besides (the per-run log)."""
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.errors import SimulationDiverged
    cs = load_circuit_scenario(path)
    if cs.loop is None:
        raise InputError("a study's circuit scenario must be a closed loop ([controller] + [reference])",
                         source=str(path))
    try:
        res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, method=cs.method, every=cs.every, rest=cs.rest,
                               loop=cs.loop, commands=cs.commands, compiled=cs.compiled)
    except SimulationDiverged as exc:
        return {k: np.zeros(1) for k in ("t", "xp", "x_ref", "p1", "p2", "u")}, str(exc)
    cols = {k: v for k, v in res.columns.items()}
    nodes = [f"{n}.p" for n in cs.circuit.nodes]
    peak = np.max(np.vstack([cols[n] for n in nodes]), axis=0)
    cols.update({"xp": cols[cs.loop.measure], "x_ref": cols[f"{cs.loop.measure}.reference"], "p1": peak,
                 "p2": peak, "u": cols[cs.loop.command]})
    return cols, None


def _run_sequence(path: Path, folder: Path):
    from hydrohil.sequences.runner import run_sequence
    r = run_sequence(path, folder / "run")
    if r.signals is None:
        raise RuntimeError(r.error or "the sequence's run produced no signals")
    s = r.signals
    if "p1" in s:
        cols = {c: s[c] for c in ("t", "xp", "p1", "p2", "u", "xs", "x_ref")}
    else:                                  # a circuit's sequence: its signals, the peak node pressure as p1, p2
        if "xp" not in s:
            raise InputError("a study's circuit sequence must be a closed loop ([controller] + [reference])",
                             source=str(path))
        peak = np.max(np.vstack([v for k, v in s.items() if s.units.get(k) == "Pa" and k.endswith(".p")]), axis=0)
        cols = {**s, "p1": peak, "p2": peak}
    verdicts = {f"expect.{i}": o.status for i, o in enumerate(r.outcomes)}
    verdicts["verdict"] = r.status
    return cols, r.error if r.status == "error" else None, verdicts


def _write_log(path: Path, cols: dict) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".part")
    pq.write_table(pa.table({k: np.asarray(v, float) for k, v in cols.items()}), tmp)
    tmp.replace(path)
