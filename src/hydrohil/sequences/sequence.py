"""Test sequences (TOML): a scenario, a timeline of actions and the expectations a run must meet.

A sequence compiles into an ordinary scenario (:func:`compile_sequence`): reference actions become its
``[reference]`` table, every other action one of its ``[[faults]]`` (``at`` / ``until`` are the fault's
``start`` / ``end``), so the timeline acts identically offline, in lock-step and in real time (the virtual
rig runs it in all three). The compiled scenario is written into the run folder (``scenario.toml``): it is
what ran, and what ``hydrohil simulate`` / ``hydrohil hil`` run again by hand.

Format (``examples/sequences/``)::

    name = "P control holds the load through a hose burst"    # default: the file's stem
    scenario = "../faults/hose_burst.toml"    # path (relative to this file) or built-in experiment name
    duration = 6.0                            # optional: replaces the scenario's
    [set]                                     # optional: parameter values (dotted keys, SI units)
    "load.mass" = 120.0
    [controller]                              # optional: replaces the scenario's controller table
    [hil]                                     # optional: keys set on top of the scenario's [hil] table

    [[actions]]                               # reference: type "step" (x [m]) or "ramp" (x [m], over [s])
    name = "extend"                           # optional; expectations refer to actions by name
    at = 0.5
    type = "step"
    x = 0.15
    [[actions]]                               # any fault type of [[faults]] with its keys (faults.py);
    name = "burst"                            # load and parameter changes are faults too: load_change,
    at = 2.0                                  # supply_pressure, valve_leakage, seal_wear, ...
    until = 2.3                               # optional: cleared at this time (default: never)
    type = "hose_burst"
    line = 2
    section = 4.31

    [[expect]]                                # see expectations.py for every type and key
    type = "tracking"
    after = "extend"
    within = 0.8
    tol = 0.002
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Any, Literal, Union

from pydantic import Field, TypeAdapter, ValidationError, model_validator

from hydrohil.errors import InputError
from hydrohil.parameters import format_validation_error, read_toml
from hydrohil.parameters.schema import StrictModel
from hydrohil.sequences.expectations import Expectation
from hydrohil.simulation.faults import FAULT_TYPES, Fault

REFERENCE_ACTIONS = ("step", "ramp")


class _Action(StrictModel):
    name: str | None = Field(None, min_length=1, max_length=100, description="label the expectations refer to")
    at: float = Field(ge=0, le=3600, description="time of the action [s]")


class StepAction(_Action):
    type: Literal["step"]
    x: float = Field(ge=-1e3, le=1e3, description="new position reference [m]")


class RampAction(_Action):
    type: Literal["ramp"]
    x: float = Field(ge=-1e3, le=1e3, description="position reference at the end of the ramp [m]")
    over: float = Field(gt=0, le=3600, description="duration of the ramp [s]")


class FaultAction(StrictModel):
    """A fault (or load / parameter change) switched on at ``at`` and off at ``until``: validated as the
    scenario's ``[[faults]]`` entry it becomes."""
    model_config = {"extra": "allow"}
    name: str | None = Field(None, min_length=1, max_length=100)
    at: float = Field(ge=0, le=3600, description="time the fault starts [s]")
    until: float | None = Field(None, gt=0, le=3600, description="time it is cleared [s] (omit: never)")
    type: str

    @model_validator(mode="after")
    def _fault_type(self):
        if self.type not in FAULT_TYPES:
            from hydrohil.errors import unknown_name
            raise ValueError(unknown_name(self.type, (*REFERENCE_ACTIONS, *FAULT_TYPES), what="action type"))
        return self

    def fault_table(self) -> dict:
        extra = dict(self.model_extra or {})
        return {"type": self.type, "start": self.at, **({"end": self.until} if self.until is not None else {}),
                **extra}


Action = Annotated[Union[StepAction, RampAction], Field(discriminator="type")]


class Sequence(StrictModel):
    name: str | None = Field(None, min_length=1, max_length=200, description="default: the file's stem")
    scenario: str = Field(description="scenario TOML (relative to the sequence file) or built-in experiment name")
    duration: float | None = Field(None, gt=0, le=3600, description="replaces the scenario's duration [s]")
    set: dict[str, Any] = Field(default_factory=dict, description="dotted parameter name -> SI value")
    controller: dict[str, Any] | None = Field(None, description="replaces the scenario's [controller] table")
    hil: dict[str, Any] = Field(default_factory=dict, description="keys set on top of the scenario's [hil]")
    actions: list[dict[str, Any]] = Field(default_factory=list, max_length=53)   # (faults: core HH_MAX_FAULTS)
    expect: list[Expectation] = Field(default_factory=list, max_length=1000)


def _action(i: int, table: dict, source: str) -> StepAction | RampAction | FaultAction:
    kind = table.get("type")
    try:
        if kind in REFERENCE_ACTIONS:
            return TypeAdapter(Action).validate_python(table)
        act = FaultAction.model_validate(table)
        TypeAdapter(Fault).validate_python(act.fault_table())      # the fault's own keys and ranges
        return act
    except ValidationError as exc:
        if kind in REFERENCE_ACTIONS:
            key, msg = format_validation_error(exc, {"step": StepAction, "ramp": RampAction}[kind])
        elif kind in FAULT_TYPES:
            key, msg = format_validation_error(exc, None)
            key = (key or "").removeprefix(f"{kind}.")         # (the union's tag in pydantic's location)
            key = {"start": "at", "end": "until"}.get(key, key) or None
            msg = msg.replace("start (", "at (").replace("end (", "until (")
        else:
            key, msg = format_validation_error(exc, FaultAction)
        raise InputError(msg, source=source, key=f"actions[{i}]" + (f".{key}" if key else "")) from None


class LoadedSequence:
    """A validated sequence: its actions (times, names) and expectations; :meth:`compile` writes its scenario."""

    def __init__(self, seq: Sequence, source: Path, actions: list):
        self.seq, self.source, self.actions = seq, source, actions
        self.name = seq.name or source.stem

    @property
    def expectations(self) -> list:
        return self.seq.expect

    def event_times(self) -> dict[str, float]:
        """Action name -> its time [s] (the ``after`` of the expectations)."""
        return {a.name: a.at for a in self.actions if a.name}

    def scenario_path(self) -> Path:
        from hydrohil.simulation.scenario import resolve_scenario
        try:
            return resolve_scenario(self.seq.scenario, self.source.parent)
        except InputError as exc:
            raise InputError(str(exc), source=str(self.source), key="scenario") from None

    def compile(self, dest: Path) -> Path:
        """Write the scenario this sequence runs to ``dest`` (TOML) and check it loads; InputError names the
        sequence file for any problem of the compiled scenario."""
        import tomli_w

        from hydrohil.simulation.scenario import load_scenario, scenario_data
        seq, src = self.seq, str(self.source)
        scen = self.scenario_path()
        data = scenario_data(scen, sets=seq.set or None)
        if seq.duration is not None:
            data["duration"] = seq.duration
        if seq.controller is not None:
            data["controller"] = dict(seq.controller)
        if seq.hil:
            data["hil"] = {**(data.get("hil") or {}), **seq.hil}
        duration = float(data.get("duration", 0.0))
        refs = sorted((a for a in self.actions if a.type in REFERENCE_ACTIONS), key=lambda a: a.at)
        if refs:
            data["reference"] = _reference_table(data, refs, duration, src)
        faults = [a.fault_table() for a in self.actions if a.type not in REFERENCE_ACTIONS]
        if faults:
            data["faults"] = [*(data.get("faults") or []), *faults]
        for i, a in enumerate(self.actions):
            if a.at >= duration:
                raise InputError(f"at = {a.at:g} s is not before the end of the run ({duration:g} s)", source=src,
                                 key=f"actions[{i}].at")
        dest = Path(dest)
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_text(f"# compiled from the test sequence {self.source.name} (hydrohil test)\n" + tomli_w.dumps(data))
        try:
            load_scenario(dest)
        except InputError as exc:
            raise InputError(f"the scenario it compiles to: {exc}", source=src) from None
        return dest


def _reference_table(data: dict, refs: list, duration: float, source: str) -> dict:
    """The ``[reference]`` table of the reference actions: from the scenario's reference at t = 0 (else the
    initial position), a step or a ramp at each action's time, held to the end of the run."""
    from hydrohil.simulation.scenario import Table
    ref = data.get("reference") or {}
    x0 = Table(ref["t"], ref["x"]).at(0.0)[0] if ref.get("t") else float(data["initial"]["xp"])
    t, x = [0.0], [x0]
    for a in refs:
        if a.at < t[-1]:
            raise InputError(f"'{a.name or a.type}' at {a.at:g} s starts before the ramp before it ends "
                             f"({t[-1]:g} s)", source=source, key="actions")
        t.append(a.at)
        x.append(x[-1])
        t.append(a.at + (a.over if a.type == "ramp" else 0.0))
        x.append(a.x)
    if t[-1] < duration:
        t.append(duration)
        x.append(x[-1])
    return {"type": "table", "t": t, "x": x}


def load_sequence(path: str | Path, *, allow_empty: bool = False) -> LoadedSequence:
    """Read and validate a sequence file (InputError names the file and the key). A file without
    ``[[expect]]`` is refused unless ``allow_empty`` (the pytest fixture's runs judge in Python)."""
    path = Path(path)
    data = read_toml(path)
    if not allow_empty and not data.get("expect"):
        raise InputError("no [[expect]] entries: a test sequence states what the run must do", source=str(path),
                         key="expect")
    try:
        seq = Sequence.model_validate(data)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, Sequence)
        raise InputError(msg, source=str(path), key=key) from None
    actions = [_action(i, a, str(path)) for i, a in enumerate(seq.actions)]
    names = [a.name for a in actions if a.name]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup:
        raise InputError(f"action name '{dup}' is used twice", source=str(path), key="actions")
    loaded = LoadedSequence(seq, path, actions)
    events = loaded.event_times()
    for i, e in enumerate(seq.expect):
        for key in ("after", "until"):
            v = getattr(e, key, None)
            if isinstance(v, str) and v not in events:
                from hydrohil.errors import unknown_name
                raise InputError(unknown_name(v, events, what="action name"), source=str(path),
                                 key=f"expect[{i}].{key}")
    return loaded


def slug(text: str) -> str:
    """A sequence's (or an expectation's) name as a file name: letters, digits, ``_.-``; at most 80 chars."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")[:80] or "sequence"
