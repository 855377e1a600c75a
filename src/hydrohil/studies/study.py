"""Study files (TOML): sweeps and Monte Carlo over parameters, scenarios, controllers and test sequences.

::

    name = "fig11_monte_carlo"
    scenario = "../fig11_p_control.toml"     # or: sequence = "../sequences/x.toml" (its verdicts per run)
    samples = 1000                           # random draws (per grid point when grids are given too)
    seed = 1
    [criterion]                              # optional: a run passes when metric <= max
    metric = "max_hold_error"
    max = 1e-3

    [[vary]]                                 # a dotted parameter, a relative spread of its nominal value
    name = "load.mass"
    dist = "uniform"                         # uniform | normal | truncnormal | choice | grid
    rel = 0.2                                # ±20 % (uniform), or: low / high (absolute)
    [[vary]]                                 # one factor on several entries: "name[i]" picks a list entry,
    name = "friction"                        # "^2" scales it by the factor squared
    scale = ["friction.positive.fc", "friction.positive.fs", "friction.negative.fc", "friction.negative.fs"]
    dist = "uniform"
    low = 0.7
    high = 1.3
    [[vary]]
    name = "controller.kp"                   # a key of the scenario's [controller] (also initial.*, duration)
    dist = "grid"
    values = [30.0, 50.0, 70.0]              # or start / stop / num

Runs are the grid's points (their Cartesian product) times ``samples`` random draws each (one draw of the
random entries per run; no grid: ``samples`` runs; no random entry: one run per grid point). Every run has an
id (``r000042``), its inputs and its own generator state derived from ``seed`` and its index, so any run
can be made again alone (``hydrohil sweep STUDY --rerun r000042``) and a resumed study draws the same runs.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
import math
import re
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, ValidationError, field_validator, model_validator

from hydrohil.errors import InputError
from hydrohil.parameters import format_validation_error, read_toml
from hydrohil.parameters.schema import StrictModel

DISTS = ("uniform", "normal", "truncnormal", "choice", "grid")
# the metrics of a run's row (studies/runs.py computes them) and their SI units: what a [criterion] may name
METRICS = ("rms_error", "max_abs_error", "max_hold_error", "max_p1", "max_p2", "max_overshoot_pct",
           "max_settling_time", "max_abs_ss_error", "breakaways")
METRIC_UNITS = {"rms_error": "m", "max_abs_error": "m", "max_hold_error": "m", "max_p1": "Pa", "max_p2": "Pa",
                "max_overshoot_pct": "%", "max_settling_time": "s", "max_abs_ss_error": "m", "breakaways": "-"}
SPECIAL = ("scenario", "sequence", "duration")        # names that are not parameters
_ENTRY = re.compile(r"^([A-Za-z_][A-Za-z0-9_.]*)(?:\[(\d+)\])?(?:\^(\d+(?:\.\d+)?))?$")


class Vary(StrictModel):
    name: str = Field(min_length=1, max_length=200, description="dotted parameter, controller.KEY, initial.KEY, "
                      "duration, scenario, sequence; with 'scale': a label")
    dist: Literal["uniform", "normal", "truncnormal", "choice", "grid"]
    scale: list[str] | None = Field(None, min_length=1, description="parameters multiplied by the drawn factor "
                                    "(name[i]: a list's entry, ^p: by the factor to the power p)")
    low: float | None = None
    high: float | None = None
    rel: float | None = Field(None, gt=0, le=10, description="uniform: ±rel of the nominal value; normal: the "
                              "standard deviation relative to it [-]")
    mean: float | None = None
    std: float | None = Field(None, gt=0)
    values: list[Any] | None = Field(None, min_length=1, max_length=10**6)
    weights: list[float] | None = None
    start: float | None = None
    stop: float | None = None
    num: int | None = Field(None, ge=1, le=10**6)

    @model_validator(mode="after")
    def _check(self):
        d = self.dist
        if d == "uniform" and self.rel is None and (self.low is None or self.high is None):
            raise ValueError("uniform needs rel, or low and high")
        if d in ("normal", "truncnormal") and self.std is None and self.rel is None:
            raise ValueError(f"{d} needs std (with mean; default the nominal value) or rel")
        if d == "truncnormal" and (self.low is None or self.high is None):
            raise ValueError("truncnormal needs low and high (the truncation)")
        if self.low is not None and self.high is not None and self.low >= self.high:
            raise ValueError(f"low ({self.low:g}) must be below high ({self.high:g})")
        if d == "choice" and not self.values:
            raise ValueError("choice needs values")
        if d == "grid" and not self.values and (self.start is None or self.stop is None or self.num is None):
            raise ValueError("grid needs values, or start, stop and num")
        if self.weights is not None and (not self.values or len(self.weights) != len(self.values)):
            raise ValueError("weights needs one weight per value")
        for s in self.scale or ():
            if not _ENTRY.match(s):
                raise ValueError(f"scale entry {s!r}: expected a dotted name, optionally [index] and ^power")
        return self

    @property
    def random(self) -> bool:
        return self.dist != "grid"

    def grid(self) -> list:
        return list(self.values) if self.values else np.linspace(self.start, self.stop, self.num).tolist()


class Criterion(StrictModel):
    metric: str = Field(description="one of the run metrics (METRICS)")
    max: float = Field(description="a run passes when its metric is at most this (the metric's SI unit)")

    @field_validator("metric")
    @classmethod
    def _known(cls, v: str) -> str:
        if v not in METRICS:
            raise ValueError(f"unknown metric {v!r}: one of " + ", ".join(f"{m} [{METRIC_UNITS[m]}]" for m in METRICS))
        return v


class Study(StrictModel):
    name: str | None = Field(None, min_length=1, max_length=200)
    scenario: str | None = Field(None, description="scenario TOML (relative to the study) or built-in experiment")
    sequence: str | None = Field(None, description="test sequence TOML: each run judged by its expectations")
    samples: int = Field(0, ge=0, le=10**7, description="random draws (per grid point)")
    seed: int = Field(0, ge=0, le=2**63 - 1)
    vary: list[Vary] = Field(default_factory=list, max_length=100)
    criterion: Criterion | None = None
    logs: bool = Field(False, description="keep each run's log (runs/ID.parquet)")

    @model_validator(mode="after")
    def _check(self):
        if (self.scenario is None) == (self.sequence is None):
            raise ValueError("give scenario or sequence (one of them)")
        if any(v.random for v in self.vary) and self.samples == 0:
            raise ValueError("random entries (uniform, normal, truncnormal, choice) need samples > 0")
        names = [v.name for v in self.vary]
        dup = next((n for n in names if names.count(n) > 1), None)
        if dup:
            raise ValueError(f"vary name {dup!r} given twice")
        return self


class LoadedStudy:
    """A validated study: its runs (:meth:`runs`), the nominal values the relative spreads refer to."""

    def __init__(self, study: Study, source: Path):
        self.study, self.source = study, Path(source)
        self.name = study.name or self.source.stem
        self.base = self._base_file()
        self.nominal = self._nominal()

    @functools.cached_property
    def circuit(self) -> bool:
        """The base scenario names a circuit: its runs are the circuit's (values "component.key"). (Read once:
        a worker asks it for every run of the study it keeps.)"""
        from hydrohil.circuits.scenario import is_circuit_scenario
        return is_circuit_scenario(self.base_scenario())

    def _base_file(self) -> Path:
        from hydrohil.simulation.scenario import resolve_scenario
        s = self.study
        base = self.source.parent / (s.scenario or s.sequence)
        if base.is_file():
            return base.resolve()
        try:
            return resolve_scenario(s.scenario or s.sequence, self.source.parent).resolve()
        except InputError as exc:
            raise InputError(str(exc), source=str(self.source), key="scenario" if s.scenario else "sequence") from None

    def base_scenario(self, base: Path | None = None) -> Path:
        base = base or self.base
        if self.study.sequence is None:
            return base
        from hydrohil.sequences.sequence import load_sequence
        return load_sequence(base).scenario_path()

    def _nominal(self) -> dict[str, Any]:
        """Nominal value of every varied entry: the base scenario's parameters, controller and initial state;
        a circuit's: its components' values (SI, "component.key"), its fluid's ("fluid.key"), its loop's gains
        ("controller.key")."""
        if self.circuit:
            from hydrohil.circuits.scenario import load_circuit_scenario
            cs = load_circuit_scenario(self.base_scenario())
            values = {f"{c.name}.{k}": v for c in cs.circuit.components.values() for k, v in c.values.items()
                      if k in c.type.params}
            values.update({f"fluid.{k}": v for k, v in cs.circuit.fluid.items()})
            if cs.loop is not None:
                values.update({f"controller.{k}": v for k, v in cs.loop.cfg.model_dump().items()})
            self.param_values = {}

            def lookup(name, idx):
                if idx is not None:
                    raise KeyError(name)
                return values[name]
            what = "value (component.key, fluid.key, controller.key) of the circuit scenario"
        else:
            from hydrohil.simulation.scenario import load_scenario
            sc = load_scenario(self.base_scenario())
            params = self.param_values = sc.params.model_dump(mode="python")
            data = sc.scenario.model_dump(mode="python")

            def lookup(name, idx):
                return _lookup(data if name.split(".")[0] in ("controller", "initial") else params, name, idx)
            what = "parameter or key in"
        out = {}
        for i, v in enumerate(self.study.vary):
            for entry in (v.scale or [v.name]):
                name, idx, _ = _parse_entry(entry)
                if name in SPECIAL:
                    continue
                try:
                    node = lookup(name, idx)
                except (KeyError, IndexError, TypeError):
                    if v.scale is None and v.dist in ("choice", "grid") and name.split(".")[0] == "controller":
                        continue            # a controller key the base controller does not have (e.g. ki)
                    raise InputError(f"no such {what} {entry!r} in {self.base_scenario()}",
                                     source=str(self.source), key=f"vary[{i}]") from None
                if isinstance(node, (int, float)) and not isinstance(node, bool) and node == node:
                    out[entry] = float(node)
        return out

    def runs(self) -> list[dict]:
        """Every run: ``{"run_id", "index", "inputs": {name: value}}``, the same on every call."""
        s = self.study
        grids = [v for v in s.vary if not v.random]
        rand = [v for v in s.vary if v.random]
        points = list(itertools.product(*[v.grid() for v in grids])) or [()]
        per_point = s.samples if rand else 1
        runs = []
        for p_i, point in enumerate(points):
            for j in range(per_point):
                index = p_i * per_point + j
                rng = np.random.default_rng([s.seed, index])
                inputs = {v.name: (x.item() if hasattr(x, "item") else x) for v, x in zip(grids, point)}
                for v in rand:
                    inputs[v.name] = self._draw(v, rng)
                runs.append({"run_id": f"r{index:06d}", "index": index, "inputs": inputs})
        return runs

    def _draw(self, v: Vary, rng):
        if v.dist == "choice":
            p = None if v.weights is None else np.asarray(v.weights, float) / np.sum(v.weights)
            return v.values[int(rng.choice(len(v.values), p=p))]
        nominal = 1.0 if v.scale else self.nominal.get(v.name)
        if v.dist == "uniform":
            if v.low is not None:
                return float(rng.uniform(v.low, v.high))
            return float(nominal * (1 + rng.uniform(-v.rel, v.rel)))
        mean = v.mean if v.mean is not None else nominal
        std = v.std if v.std is not None else abs(nominal) * v.rel
        if v.dist == "normal":
            return float(rng.normal(mean, std))
        for _ in range(10_000):           # truncnormal: rejection (the truncation holds most of the mass)
            x = rng.normal(mean, std)
            if v.low <= x <= v.high:
                return float(x)
        from scipy.stats import truncnorm
        return float(truncnorm.rvs((v.low - mean) / std, (v.high - mean) / std, mean, std, random_state=rng))

    def settings(self, inputs: dict) -> dict:
        """A run's inputs as what they set: ``{"sets": {dotted: value}, "controller": {...}, "initial": {...},
        "duration", "base": file}``."""
        s = self.study
        out: dict = {"sets": {}, "controller": {}, "initial": {}, "duration": None, "base": self.base}
        for v in s.vary:
            x = inputs[v.name]
            if v.scale:
                for entry in v.scale:
                    name, idx, power = _parse_entry(entry)
                    val = self.nominal[entry] * float(x) ** power
                    _set(out, name, idx, val, self)
            elif v.name in ("scenario", "sequence"):
                from hydrohil.simulation.scenario import resolve_scenario
                out["base"] = resolve_scenario(str(x), self.source.parent).resolve()
            elif v.name == "duration":
                out["duration"] = float(x)
            else:
                _set(out, v.name, None, x, self)
        return out

    def digest(self) -> str:
        """A fingerprint of what the runs are (the study's table and its base files): a resumed study must match.
        The criterion judges the runs, it does not make them: a study whose criterion alone changed judges its
        stored runs again."""
        h = hashlib.sha256(json.dumps(self.study.model_dump(mode="json", exclude={"criterion"}),
                                      sort_keys=True).encode())
        h.update(self.base.read_bytes())
        return h.hexdigest()[:16]


def _lookup(tree: dict, name: str, idx: int | None = None):
    """The value at the dotted ``name`` (and list entry ``idx``) of a nested table."""
    for part in name.split("."):
        tree = tree[part]
    return tree if idx is None else tree[idx]


def _parse_entry(entry: str) -> tuple[str, int | None, float]:
    m = _ENTRY.match(entry)
    return m.group(1), (int(m.group(2)) if m.group(2) is not None else None), float(m.group(3) or 1.0)


def _set(out: dict, name: str, idx: int | None, value, study: LoadedStudy) -> None:
    head, _, rest = name.partition(".")
    if head in ("controller", "initial") and rest:
        out[head][rest] = value
        return
    if idx is None:
        out["sets"][name] = value
        return
    if name not in out["sets"]:             # a list parameter: the nominal list with this entry replaced
        out["sets"][name] = list(_lookup(study.param_values, name))
    out["sets"][name][idx] = value


def load_study(path: str | Path) -> LoadedStudy:
    path = Path(path)
    data = read_toml(path)
    try:
        study = Study.model_validate(data)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, Study)
        raise InputError(msg, source=str(path), key=key) from None
    return LoadedStudy(study, path)


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a probability estimated as k/n."""
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    w = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (max(0.0, c - w), min(1.0, c + w))
