"""``hydrohil compare``: overlay closed-loop runs (e.g. one scenario under several controllers) and tabulate
their step-response metrics (:mod:`hydrohil.metrics`).

A run is a scenario file (simulated here, with ``--params`` / ``--set`` if given) or the folder of a run
that ``hydrohil simulate`` wrote (its ``log.csv``).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hydrohil.errors import InputError
from hydrohil.metrics import step_metrics

COLUMNS = ("t", "xp", "vp", "x_ref", "u", "p1", "p2", "friction_mode")


@dataclass
class Run:
    label: str
    data: dict[str, np.ndarray]
    metrics: dict


def _read_log(folder: Path) -> dict[str, np.ndarray]:
    path = folder / "log.csv"
    if not path.is_file():
        raise InputError("no log.csv here (a run folder of `hydrohil simulate`, or a scenario .toml)",
                         source=str(folder))
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    head, body = rows[0], rows[1:]
    if "x_ref" not in head:
        raise InputError("an open-loop run (no x_ref column): nothing to compare against a reference", source=str(path))
    out = {}
    for c in COLUMNS:
        i = head.index(c)
        if c == "friction_mode":
            out[c] = np.array([r[i] != "stick" for r in body], dtype=float)     # 1 while sliding (0: stick)
        else:
            out[c] = np.array([float(r[i]) for r in body])
    return out


def _simulate(path: Path, params, sets) -> dict[str, np.ndarray]:
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    sc = load_scenario(path, params=params, sets=sets)
    if not sc.scenario.closed_loop:
        raise InputError("an open-loop scenario: nothing to compare against a reference", source=str(path))
    res = run_scenario(sc)
    if res.diverged:
        raise res.diverged
    s = sc.scenario
    out = {c: res.column(c) for c in ("t", "xp", "vp", "u", "p1", "p2")}
    out["x_ref"] = s.references()[0][::s.solver.output_every][:len(res.log)]
    out["friction_mode"] = (res.column("friction_mode") != 0).astype(float)
    return out


def load_run(source: str | Path, label: str | None = None, *, params=None, sets=None) -> Run:
    """A run from a scenario file (simulated) or a run folder, with its metrics."""
    source = Path(source)
    if source.is_dir():
        data = _read_log(source)
    elif source.suffix == ".toml":
        data = _simulate(source, params, sets)
    else:
        raise InputError("expected a scenario .toml or a run folder", source=str(source))
    m = step_metrics(data["t"], data["xp"], data["x_ref"], data["p1"], data["p2"], sliding=data["friction_mode"])
    return Run(label or (source.stem if source.suffix == ".toml" else source.name), data, m)


def compare(sources, out: Path, *, labels: list[str] | None = None, params=None, sets=None,
            title: str = "") -> list[Run]:
    """Overlay the runs in ``out/compare.png`` and write their metrics to ``out/compare.json``."""
    from hydrohil.plotting import plot_compare
    from hydrohil.simulation.outputs import write_json
    sources = list(sources)
    if labels is not None and len(labels) != len(sources):
        raise InputError(f"{len(labels)} labels for {len(sources)} runs", source="--labels")
    runs = [load_run(s, labels[i] if labels else None, params=params, sets=sets) for i, s in enumerate(sources)]
    names = [r.label for r in runs]
    if len(set(names)) < len(names):
        raise InputError(f"two runs share a label ({', '.join(names)}): give --labels", source="--labels")
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "compare.json", {r.label: {"source": str(s), **r.metrics} for r, s in zip(runs, sources)})
    plot_compare(out / "compare.png", runs, title=title)
    return runs
