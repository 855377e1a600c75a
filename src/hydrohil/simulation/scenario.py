"""Scenario files (TOML): what to simulate, for how long, with which solver, input or controller.

See ``examples/*.toml`` and the README for the format. Relative ``params`` paths are resolved against
the scenario file's folder.
"""

from __future__ import annotations

import bisect
import math
import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from hydrohil.errors import InputError
from hydrohil.models.cylinder import warn_beyond_stroke
from hydrohil.parameters import Parameters, format_validation_error, load_parameters, read_toml
from hydrohil.parameters.schema import StrictModel
from hydrohil.control import ControllerCfg, anchor_controller
from hydrohil.simulation.faults import Fault
from hydrohil.core import METHODS, lib
from hydrohil.core.watchdog import WATCHDOG_TIMEOUT

SOLVERS = (*METHODS, "reference")
EXPERIMENTS_DIR = Path(__file__).resolve().parent.parent / "experiments"    # the paper's experiments, built in


def resolve_scenario(name_or_path: str | Path, base: Path | None = None) -> Path:
    """A scenario file: a path (relative to ``base``, the folder of the file naming it) or the name of a
    built-in experiment (``fig11_p_control``)."""
    p = Path(name_or_path)
    if not p.is_absolute() and base is not None and (base / p).exists():
        return base / p
    if p.exists():
        return p
    if p.suffix != ".toml" and (EXPERIMENTS_DIR / f"{p}.toml").exists():
        return EXPERIMENTS_DIR / f"{p}.toml"
    names = sorted(q.stem for q in EXPERIMENTS_DIR.glob("*.toml"))
    raise InputError(f"no scenario file {str(base / p) if base is not None and not p.is_absolute() else p}, and not "
                     f"a built-in experiment ({', '.join(names)})")


class SolverCfg(StrictModel):
    method: Literal["euler", "heun", "rk3", "rk4", "reference"] = "rk3"
    step: float = Field(5e-4, gt=1e-9, le=0.01, description="fixed step / control sample time [s]")
    output_every: int = Field(1, ge=1, le=10**6, description="log one row every N steps")
    rtol: float = Field(1e-7, gt=0, lt=1e-2, description="reference solver relative tolerance")


class Initial(StrictModel):
    xp: float = Field(description="piston position [m]")
    xs: float | None = Field(None, ge=-1, le=1, description="spool position [-] (default: the spool offset that "
                             "holds the piston at rest)")
    p1: float | None = Field(None, ge=-1e5, le=1e8, description="chamber 1 pressure [Pa] (default: at rest, the "
                             "chambers' flows balanced at the spool position)")
    p2: float | None = Field(None, ge=-1e5, le=1e8, description="chamber 2 pressure [Pa] (default: at rest)")


class TableInput(StrictModel):
    type: Literal["table"]
    t: list[float] = Field(min_length=1, description="times [s], non-decreasing")
    u: list[float] = Field(min_length=1, description="valve command [-], in [-1, 1]")

    @model_validator(mode="after")
    def _check(self):
        _check_table(self.t, self.u, "u", -1.0, 1.0)
        return self


class SineInput(StrictModel):
    type: Literal["sine"]
    amplitude: float = Field(ge=0, le=1, description="[-]")
    frequency: float = Field(gt=0, le=1000, description="[Hz]")
    offset: float = Field(0.0, ge=-1, le=1, description="[-]")
    phase: float = Field(0.0, description="[rad]")

    @model_validator(mode="after")
    def _check(self):
        if abs(self.offset) + self.amplitude > 1.0 + 1e-12:
            raise ValueError("|offset| + amplitude must be <= 1 (the command range)")
        return self


class TableReference(StrictModel):
    type: Literal["table"]
    t: list[float] = Field(min_length=1, description="times [s], non-decreasing")
    x: list[float] = Field(min_length=1, description="piston position reference [m]")
    repeat: float | None = Field(None, gt=0, le=1e6, description="period [s]: the table repeats, x_ref(t mod "
                                 "repeat) (the live panel's sessions repeat the scenario's reference)")

    @model_validator(mode="after")
    def _check(self):
        _check_table(self.t, self.x, "x", -1e3, 1e3)
        return self

    def sampler(self) -> "Table":
        return Table(self.t, self.x, period=self.repeat)

    def sample(self, t) -> tuple[np.ndarray, np.ndarray]:
        """x_ref(t) and its slope at the times t (:class:`Table`)."""
        return self.sampler()(t)


class Table:
    """A trajectory table sampled as the loop samples it: the value at t linear between the points (constant
    beyond them), and its slope [per s], the slope of the segment that starts at or before t (0 beyond the
    ends; at a step, a repeated time, the segment after it). Offline runs sample it at every step at once
    (``table(t)``), the HIL controller one packet at a time (``table.at(t)``): the same numbers."""

    def __init__(self, t, x, period: float | None = None):
        self.t, self.x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
        self.period = period                        # the table repeats: sampled at t mod period
        self._t_list = self.t.tolist()
        dt, dx = np.diff(self.t), np.diff(self.x)
        self.slopes = np.zeros(len(self.t) + 1)     # [i]: the slope after the i-th point (0: before the table)
        self.slopes[1:-1] = np.where(dt > 0, dx / np.where(dt > 0, dt, 1.0), 0.0)

    def __call__(self, t) -> tuple[np.ndarray, np.ndarray]:
        t = self._in_period(t)
        return np.interp(t, self.t, self.x), self.slopes[np.searchsorted(self.t, t, side="right")]

    def values(self, t) -> np.ndarray:
        """The value alone at the times t (``self(t)[0]``, its slopes not looked up)."""
        return np.interp(self._in_period(t), self.t, self.x)

    def _in_period(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.fmod(t, self.period) if self.period else t     # (exact, as math.fmod in at())

    def at(self, t: float) -> tuple[float, float]:
        if self.period:
            t = math.fmod(t, self.period)
        return float(np.interp(t, self.t, self.x)), float(self.slopes[bisect.bisect_right(self._t_list, t)])


class HilCfg(StrictModel):
    """``[hil]``: real-time settings and interface models of ``hydrohil hil`` (docs/protocol.md).

    The command transport delay acts in series with the spool delay, offline and in real time alike.
    """

    step: float | None = Field(None, gt=1e-6, le=0.01, description="plant step [s] (default: solver.step)")
    command_delay: float = Field(0.0, ge=0, le=0.1, description="valve command transport delay [s]")
    command_scale: float = Field(1.0, gt=0, le=1e3, description="command units per unit ū (e.g. 10 for ±10 V)")
    watchdog_timeout: float = Field(WATCHDOG_TIMEOUT, gt=0, le=10, description="no valid command for this long -> safe state [s]")
    safe_state: Literal["centre", "hold"] = Field("centre", description="valve to centre, or hold position")
    hold_kp: float = Field(50.0, gt=0, le=1e5, description="P gain of the 'hold' safe state [1/m]")
    controller_mode: Literal["packet", "clock"] = Field("packet", description="controller driven by sensor "
                                                        "packets or by its own clock")
    busy_poll: bool = Field(True, description="controller naps until 150 us before the next packet, then spins "
                            "on its socket (lower latency, ~1/3 of a core)")
    wait: Literal["sleep", "spin-controller", "spin"] = Field(
        "spin-controller", description="sleep: plant (SCHED_FIFO) sleeps until 150 us before each step, the "
        "controller naps until 150 us before the next packet; spin-controller: the plant sleeps, the controller "
        "busy-waits on its socket (one core); spin: both busy-wait (nice -20, two cores). Unless pinned by "
        "cpu_plant / cpu_controller, the spinning modes pin plant and controller to the last two CPUs")
    seed: int = Field(0, ge=0, le=2**53, description="seed of the pressure-sensor noise")
    connect_timeout: float = Field(30.0, gt=0, le=3600, description="the plant waits this long for the "
                                   "controller's first packet [s]")
    link_timeout: float = Field(5.0, gt=0, le=600, description="the controller waits this long for the "
                                "plant's first packet, and for any packet during the run [s]")
    # validity of a real-time run (hil/verdict.py): a run that breaks one of these is INVALID
    max_late_commands: float = Field(0.01, ge=0, le=1, description="fraction of steps stepped with a command "
                                     "that had not answered the previous sensor packet [-]")
    max_overruns: float = Field(0.01, ge=0, le=1, description="fraction of steps that started more than one "
                                "step late [-]")
    max_stall: float = Field(0.05, gt=0, le=60, description="longest lateness of a step's start [s]")
    max_watchdog_trips: int = Field(0, ge=0, le=10**9, description="watchdog trips not explained by an injected "
                                    "network or silence fault")
    cpu_plant: int | None = Field(None, ge=0, description="pin the plant process to this CPU")
    cpu_controller: int | None = Field(None, ge=0, description="pin the controller process to this CPU")

    def cpus(self) -> tuple[int | None, int | None]:
        """(plant CPU, controller CPU): the configured ones; else, when a process spins and at least two
        CPUs are allowed, the last two (so the spinning controller never shares the plant's CPU)."""
        plant, ctrl = self.cpu_plant, self.cpu_controller
        if self.wait != "sleep" and (plant is None or ctrl is None):
            try:
                allowed = sorted(os.sched_getaffinity(0))
            except (AttributeError, OSError):
                allowed = []
            free = [c for c in allowed if c not in (plant, ctrl)]
            if len(allowed) >= 2 and len(free) >= (plant is None) + (ctrl is None):
                if plant is None:
                    plant = free.pop()
                if ctrl is None:
                    ctrl = free.pop()
        return plant, ctrl


def _check_table(t, v, name, lo, hi):
    if len(t) != len(v):
        raise ValueError(f"t and {name} must have the same length ({len(t)} vs {len(v)})")
    if any(b < a for a, b in zip(t, t[1:])):
        raise ValueError("t must be non-decreasing")
    if any(not (lo <= x <= hi) for x in v):
        raise ValueError(f"{name} values must lie in [{lo}, {hi}]")


class Scenario(StrictModel):
    params: str = Field("ferreira2004", description="built-in parameter set name or TOML path")
    duration: float = Field(gt=0, le=3600, description="[s]")
    solver: SolverCfg = SolverCfg()
    overrides: dict[str, Any] = Field(default_factory=dict, description="dotted parameter name -> SI value")
    initial: Initial
    input: TableInput | SineInput | None = Field(None, discriminator="type")
    controller: ControllerCfg | None = Field(None, discriminator="type")
    reference: TableReference | None = None
    hil: HilCfg = HilCfg()
    faults: list[Fault] = Field(default_factory=list, max_length=lib.HH_MAX_FAULTS,
                                description="[[faults]] entries (faults.py)")

    @model_validator(mode="after")
    def _one_drive(self):
        closed = self.controller is not None or self.reference is not None
        if closed and self.input is not None:
            raise ValueError("give either [input] (open loop) or [controller] + [reference] (closed loop), not both")
        if closed and (self.controller is None or self.reference is None):
            raise ValueError("a closed loop needs both [controller] and [reference]")
        if not closed and self.input is None:
            raise ValueError("missing [input] (open loop) or [controller] + [reference] (closed loop)")
        if self.faults and self.solver.method == "reference":
            raise ValueError("[[faults]] need a fixed-step solver (the faults run in the virtual rig, step by step)")
        if self.python_controller and self.solver.method == "reference":
            raise ValueError("a Python controller needs a fixed-step solver (it runs in the virtual rig, step by step)")
        for i, f in enumerate(self.faults):
            if f.start >= self.duration:
                raise ValueError(f"faults[{i}] ({f.type}) starts at {f.start} s, after the end of the run "
                                 f"({self.duration} s)")
        return self

    @property
    def closed_loop(self) -> bool:
        return self.controller is not None

    @property
    def python_controller(self) -> bool:
        """The controller is the user's Python code (runs in a Python loop, not the compiled one)."""
        return self.controller is not None and self.controller.type == "python"

    def n_steps(self) -> int:
        return int(round(self.duration / self.solver.step))

    @property
    def plant_step(self) -> float:
        """The HIL plant's step: ``[hil] step``, else ``solver.step``."""
        return self.hil.step or self.solver.step

    def commands(self) -> np.ndarray:
        """Open-loop valve command at each sample t_k = k*h, k = 0..n_steps."""
        t = np.arange(self.n_steps() + 1) * self.solver.step
        inp = self.input
        if isinstance(inp, SineInput):
            return inp.offset + inp.amplitude * np.sin(2 * np.pi * inp.frequency * t + inp.phase)
        return np.interp(t, inp.t, inp.u)

    def drive(self) -> tuple[np.ndarray, np.ndarray | None]:
        """What drives the loop at each sample t_k, k = 0..n_steps: (commands, None) in open loop, (references,
        their slopes) in closed loop."""
        return self.references() if self.closed_loop else (self.commands(), None)

    def references(self) -> tuple[np.ndarray, np.ndarray]:
        """Closed-loop position reference [m] and its slope [m/s] at each sample t_k, k = 0..n_steps."""
        return self.reference.sample(np.arange(self.n_steps() + 1) * self.solver.step)


class LoadedScenario(BaseModel):
    model_config = ConfigDict(arbitrary_types_allowed=True, frozen=True)
    scenario: Scenario
    params: Parameters
    source: str

    def make_controller(self, h: float | None = None):
        """A fresh instance of the scenario's controller, sampled every ``h`` (default: solver.step);
        a Python controller's module is looked up beside the scenario file too."""
        from hydrohil.control import make_controller
        return make_controller(self.scenario.controller, self.params, h or self.scenario.solver.step,
                               base=Path(self.source).parent, source=self.source)


def scenario_data(path: str | Path, *, params: str | Path | None = None, sets: dict | None = None) -> dict:
    """The scenario file's table with the command line's parameter choice applied: ``params`` (a set's
    name or a TOML path, relative to the working directory) replaces the scenario's ``params``; ``sets``
    (dotted keys, as ``--set``) apply on top of its ``[overrides]``. A relative parameter path is made
    absolute, so the table can be written elsewhere (:func:`write_scenario`)."""
    path = Path(path)
    data = read_toml(path)
    if params is not None:
        p = Path(params)
        data["params"] = str(p.resolve()) if p.suffix == ".toml" or p.exists() else str(params)
    elif isinstance(data.get("params"), str):
        p = Path(data["params"])
        if p.suffix == ".toml" and not p.is_absolute():
            data["params"] = str((path.parent / p).resolve())
    if sets:
        data["overrides"] = {**(data.get("overrides") or {}), **sets}
    anchor_controller(data.get("controller"), path.parent)     # its module's folder, wherever the table goes
    return data


def write_scenario(path: str | Path, dest: str | Path, *, params: str | Path | None = None,
                   sets: dict | None = None, tables: dict | None = None) -> Path:
    """Write the scenario ``path`` with the command line's ``params`` / ``sets`` applied to ``dest`` (TOML):
    what a run folder records, and what its child processes read. ``tables``: {table: {key: value}} set on
    top (e.g. the live panel's repeating reference)."""
    import tomli_w
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    data = scenario_data(path, params=params, sets=sets)
    for table, values in (tables or {}).items():
        data.setdefault(table, {}).update(values)
    dest.write_text(f"# {Path(path).name} as run (hydrohil: --params / --set applied)\n" + tomli_w.dumps(data))
    return dest


def load_scenario(path: str | Path, *, solver: str | None = None, step: float | None = None,
                  duration: float | None = None, params: str | Path | None = None,
                  sets: dict | None = None) -> LoadedScenario:
    """Read, validate and resolve a scenario file (with optional CLI overrides of solver/step/duration, the
    parameter set ``params`` and dotted parameter values ``sets``: :func:`scenario_data`)."""
    path = Path(path)
    data = scenario_data(path, params=params, sets=sets)
    if solver is not None or step is not None:
        data.setdefault("solver", {})
        if solver is not None:
            data["solver"]["method"] = solver
        if step is not None:
            data["solver"]["step"] = step
    if duration is not None:
        data["duration"] = duration
    return _validated(data, path, solver=solver, step=step, duration=duration, params=params, sets=sets)


def scenario_from_data(data: dict, source: str | Path) -> LoadedScenario:
    """A scenario's table in memory (:func:`scenario_data`'s, e.g. with a study run's values applied) read as the
    file ``source`` would be: validated and resolved, errors naming ``source`` (nothing written or parsed)."""
    return _validated(data, Path(source))


def _validated(data: dict, path: Path, *, solver=None, step=None, duration=None, params=None,
               sets=None) -> LoadedScenario:
    """:func:`load_scenario`'s validation of the table ``data`` of the file ``path`` (the command line's options
    named in its errors)."""
    try:
        sc = Scenario.model_validate(data)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, Scenario)
        given = {"solver.method": ("--solver", solver), "solver.step": ("--step", step),   # (the command line's)
                 "duration": ("--duration", duration)}
        if key in given and given[key][1] is not None:
            raise InputError(msg, source=given[key][0]) from None
        raise InputError(msg, source=str(path), key=key) from None
    ppath = Path(sc.params)
    if ppath.suffix == ".toml" and not ppath.is_absolute():
        ppath = path.parent / ppath
    try:
        params = load_parameters(ppath if ppath.suffix == ".toml" else sc.params, sc.overrides)
    except InputError as exc:
        if exc.source != "overrides":        # the parameter set itself: name both files (or the option)
            if params is not None:
                raise InputError(str(exc), source="--params") from None
            raise InputError(str(exc), source=str(path), key="params") from None
        if sets and exc.key in sets:         # a --set value of the command line
            raise InputError(str(exc).split(": ", 2)[-1], source="--set", key=exc.key) from None
        raise InputError(str(exc).split(": ", 2)[-1], source=str(path), key=f"overrides.{exc.key}") from None
    if sc.hil.command_delay > 0:   # transport delay in series with the spool delay (same offline and HIL)
        from hydrohil.parameters import replace_values
        params = replace_values(params, {"spool.delay": params.spool.delay + sc.hil.command_delay}, str(path))
    L = params.cylinder.stroke
    if not 0.0 <= sc.initial.xp <= L:
        raise InputError(f"must lie in [0, {L}] m (cylinder.stroke)", source=str(path), key="initial.xp")
    if sc.reference is not None:
        warn_beyond_stroke(sc.reference.t, sc.reference.x, L, str(path), "reference.x", "cylinder.stroke")
    return LoadedScenario(scenario=sc, params=params, source=str(path))


# [hil] settings that mean something for the paper's rig only, and the values a circuit takes
RIG_ONLY = {"command_delay": 0.0, "command_scale": 1.0}


def circuit_hil(cs):
    """A circuit scenario's ``[hil]`` settings (:class:`HilCfg`), checked: a circuit's inputs are in their own SI
    units (no command scale), it has no transport delay of the paper's valve, its plant steps at the scenario's
    fixed step (its safe state: checked with its loop, circuits/scenario.py)."""
    try:
        hil = HilCfg.model_validate(cs.hil)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, HilCfg)
        raise InputError(msg, source=cs.source, key=f"hil.{key}" if key else "hil") from None
    for key, value in RIG_ONLY.items():
        if getattr(hil, key) != value:
            raise InputError(f"a setting of the paper's rig only; a circuit's inputs are in their SI units, a delay "
                             f"is a component (expected {value!r})",
                             source=cs.source, key=f"hil.{key}")
    if cs.method == "reference":
        raise InputError("a real-time plant steps the hybrid model: give a fixed-step method (rk3, ...), not the "
                         "continuous reference", source=cs.source, key="solver.method")
    if hil.step is not None and hil.step != cs.step:
        raise InputError(f"a circuit's plant steps at its [solver] step ({cs.step:g} s)", source=cs.source,
                         key="hil.step")
    return hil
