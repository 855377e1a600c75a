"""Test sequences (TOML): a scenario, a timeline of actions and the expectations a run must meet.

A sequence compiles into an ordinary scenario (:func:`compile_sequence`): reference actions become its
``[reference]`` table, every other action one of its ``[[faults]]`` (``at`` / ``until`` are the fault's
``start`` / ``end``), so the timeline acts identically offline, in lock-step and in real time (the virtual
rig runs it in all three). The compiled scenario is written into the run folder (``scenario.toml``): it is
what ran, and what ``hydrohil simulate`` / ``hydrohil hil`` run again by hand.

Format (``examples/sequences/``)::

    name = "P control holds the load through a hose burst"    # default: the file's stem
    scenario = "../faults/hose_burst.toml"    # path (relative to this file) or built-in experiment name; a
                                              # scenario naming a circuit: actions step/ramp (value), set and
                                              # its faults (leak, parameter, sensor_*: circuits/faults.py)
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

from hydrohil.circuits.faults import TYPES as CIRCUIT_FAULTS
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

# ---- a circuit's sequence (its scenario names a circuit): the loop's reference moves, its inputs are set ----

_Value = Union[float, str]


class CircuitStep(_Action):
    type: Literal["step"]
    value: _Value = Field(description="the loop's new reference: SI or \"<number> <unit>\" of the measured signal")


class CircuitRamp(_Action):
    type: Literal["ramp"]
    value: _Value = Field(description="the reference at the end of the ramp")
    over: float = Field(gt=0, le=3600, description="duration of the ramp [s]")


class SetAction(_Action):
    type: Literal["set"]
    signal: str = Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*\.[A-Za-z_][A-Za-z0-9_]*$",
                        description="one of the circuit's [inputs] (component.key)")
    value: _Value = Field(description="its value from 'at' (SI or \"<number> <unit>\")")
    until: float | None = Field(None, gt=0, le=3600, description="back to its drive at this time [s] (omit: never)")


class CircuitFaultAction(FaultAction):
    """A circuit's fault (hydrohil.circuits.faults: a leak, a parameter changed, the loop's sensor failing, the
    network losing, delaying or reordering its commands, the controller falling silent) from ``at`` until
    ``until``: the scenario's ``[[faults]]`` entry it becomes (FaultAction.fault_table), its keys those of its
    type."""
    type: Literal[CIRCUIT_FAULTS]

    @model_validator(mode="after")
    def _fault_type(self):                 # (in place of the rig's: a circuit's fault types and keys)
        from hydrohil.circuits.faults import KEYS
        unknown = set(self.model_extra or {}) - (KEYS[self.type] - {"type", "start", "end"})
        if unknown:
            raise ValueError(f"unknown key {sorted(unknown)[0]!r} (keys of a {self.type} action: name, at, until, "
                             f"{', '.join(sorted(KEYS[self.type] - {'type', 'start', 'end'}))})")
        return self


CircuitAction = Annotated[Union[CircuitStep, CircuitRamp, SetAction, CircuitFaultAction], Field(discriminator="type")]
CIRCUIT_ACTIONS = ("step", "ramp", "set", *CIRCUIT_FAULTS)


class Sequence(StrictModel):
    name: str | None = Field(None, min_length=1, max_length=200, description="default: the file's stem")
    scenario: str = Field(description="scenario TOML (relative to the sequence file) or built-in experiment name")
    duration: float | None = Field(None, gt=0, le=3600, description="replaces the scenario's duration [s]")
    set: dict[str, Any] = Field(default_factory=dict, description="dotted parameter name -> SI value")
    controller: dict[str, Any] | None = Field(None, description="replaces the scenario's [controller] table")
    hil: dict[str, Any] = Field(default_factory=dict, description="keys set on top of the scenario's [hil]")
    actions: list[dict[str, Any]] = Field(default_factory=list, max_length=53)   # (faults: core HH_MAX_FAULTS)
    expect: list[Expectation] = Field(default_factory=list, max_length=1000)


def _circuit_action(i: int, table: dict, source: str):
    kind = table.get("type")
    if kind not in CIRCUIT_ACTIONS:
        raise InputError(f"a circuit's sequence has actions {', '.join(CIRCUIT_ACTIONS)} (the loop's reference, an "
                         f"input signal), got {kind!r}", source=source, key=f"actions[{i}].type")
    try:
        return TypeAdapter(CircuitAction).validate_python(table)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, {"step": CircuitStep, "ramp": CircuitRamp, "set": SetAction}.get(
            kind, CircuitFaultAction))
        key = (key or "").removeprefix(f"{kind}.")
        raise InputError(msg, source=source, key=f"actions[{i}]" + (f".{key}" if key else "")) from None


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

    def __init__(self, seq: Sequence, source: Path, actions: list, circuit: Path | None = None):
        self.seq, self.source, self.actions = seq, source, actions
        self.name = seq.name or source.stem
        self.circuit = circuit           # a circuit scenario's path: the sequence runs that circuit

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
        if self.circuit is not None:
            return self._compile_circuit(Path(dest))

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


    def _compile_circuit(self, dest: Path) -> Path:
        """The circuit scenario this sequence runs: its circuit by absolute path, [set] and duration on top, the
        reference moved by the step and ramp actions, the inputs set by the set actions."""
        import tomli_w
        from hydrohil.circuits.faults import windowed_drive
        from hydrohil.circuits.scenario import anchored, load_circuit_scenario
        from hydrohil.parameters import read_toml
        seq, src, scen = self.seq, str(self.source), self.circuit
        data = anchored(read_toml(scen), scen)
        cfile = Path(data["circuit"])
        if seq.hil:
            raise InputError("a circuit's sequence runs offline: no [hil] table", source=src, key="hil")
        if seq.set:
            data["set"] = {**data.get("set", {}), **seq.set}
        if seq.duration is not None:
            data["duration"] = seq.duration
        if seq.controller is not None:
            data["controller"] = {**(data.get("controller") or {}), **seq.controller}
        duration = float(data.get("duration") or load_circuit_scenario(scen).duration)
        data["duration"] = duration
        for i, a in enumerate(self.actions):
            if a.at >= duration:
                raise InputError(f"at = {a.at:g} s is not before the end of the run ({duration:g} s)", source=src,
                                 key=f"actions[{i}].at")
        refs = sorted((a for a in self.actions if a.type in REFERENCE_ACTIONS), key=lambda a: a.at)
        if refs:
            if "reference" not in data:
                raise InputError("step and ramp actions move the loop's reference: the scenario has no [reference]",
                                 source=src, key="actions")
            if "repeat" in data["reference"]:
                raise InputError("step and ramp actions write the loop's reference for the whole run: the "
                                 "scenario's reference repeats (remove its repeat, or the reference actions)",
                                 source=src, key="actions")
            data["reference"] = _circuit_reference(data["reference"], refs, duration, src)
        circuit_inputs = read_toml(cfile).get("inputs", {})
        for a in sorted((a for a in self.actions if a.type == "set"), key=lambda a: a.at):
            base = data.get("inputs", {}).get(a.signal, circuit_inputs.get(a.signal))
            if base is None:
                raise InputError(_not_an_input(a.signal, read_toml(cfile), data.get("inputs", {})), source=src,
                                 key="actions")
            try:
                data.setdefault("inputs", {})[a.signal] = windowed_drive(base, a.value, a.at, a.until)
            except ValueError as exc:
                raise InputError(f"{a.signal}: {exc}", source=src, key="actions") from None
        for a in self.actions:                  # leaks and parameter changes: the scenario's faults
            if isinstance(a, CircuitFaultAction):
                data.setdefault("faults", []).append(a.fault_table())
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_text(f"# compiled from the test sequence {self.source.name} (hydrohil test)\n" + tomli_w.dumps(data))
        try:
            cs = load_circuit_scenario(dest)
        except InputError as exc:
            raise InputError(f"the scenario it compiles to: {exc}", source=src) from None
        del cs                           # (loaded to check it: an open loop's sequence judges its signals alone)
        return dest


def _not_an_input(signal: str, circuit: dict, scenario_inputs: dict) -> str:
    """Why a set action's ``signal`` has nothing to set, and how it would: a parameter its component lets be a
    signal is driven once the scenario's [inputs] names it."""
    from hydrohil.circuits.library import TYPES
    inputs = [*circuit.get("inputs", {}), *scenario_inputs]
    comp, _, key = signal.partition(".")
    ctype = TYPES.get(str(circuit.get("components", {}).get(comp, {}).get("type")))
    out = f"{signal} is not one of the circuit's inputs (inputs: {', '.join(inputs) or 'none'})"
    if ctype is not None and key in ctype.inputs:
        out += (f"; a {ctype.name}'s {key} may be one: name it in the scenario's [inputs] (\"{signal}\" = its value "
                "before the action, with its unit) and the action drives it")
    elif ctype is not None and key in ctype.params:
        out += f"; {signal} is a parameter, not a signal: a parameter action changes it"
    return out


def _circuit_reference(ref: dict, refs: list, duration: float, source: str) -> dict:
    """A circuit loop's [reference] moved by the step and ramp actions: held steps, or linear when a ramp is
    in it (a step then rises over 1 us: a table's times increase)."""
    linear = ref.get("interpolation") == "linear" or any(a.type == "ramp" for a in refs)
    t = [float(x) for x in ref["t"]]
    v = list(ref["value"])
    t_out, v_out = [x for x in t if x < refs[0].at], [y for x, y in zip(t, v) if x < refs[0].at]
    for a in refs:
        prev = v_out[-1] if v_out else v[0]
        if t_out and a.at < t_out[-1]:
            raise InputError(f"'{a.name or a.type}' at {a.at:g} s starts before the ramp before it ends "
                             f"({t_out[-1]:g} s)", source=source, key="actions")
        if linear and a.at > (t_out[-1] if t_out else -1.0):
            t_out.append(a.at)
            v_out.append(prev)
        end = a.at + (a.over if a.type == "ramp" else (1e-6 if linear else 0.0))
        if not linear and t_out and t_out[-1] == a.at:
            v_out[-1] = a.value
        else:
            t_out.append(end)
            v_out.append(a.value)
    if t_out[0] != 0.0:
        t_out.insert(0, 0.0)
        v_out.insert(0, v[0])
    return {"t": t_out, "value": v_out, "interpolation": "linear" if linear else "hold"}


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
    scenario = data.get("scenario")
    circuit = _circuit_scenario(scenario, path.parent) if isinstance(scenario, str) else None
    _expectation_units(data, path, circuit)
    try:
        seq = Sequence.model_validate(data)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, Sequence)
        raise InputError(msg, source=str(path), key=key) from None
    actions = [(_circuit_action if circuit else _action)(i, a, str(path)) for i, a in enumerate(seq.actions)]
    names = [a.name for a in actions if a.name]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup:
        raise InputError(f"action name '{dup}' is used twice", source=str(path), key="actions")
    loaded = LoadedSequence(seq, path, actions, circuit)
    events = loaded.event_times()
    for i, e in enumerate(seq.expect):
        for key in ("after", "until"):
            v = getattr(e, key, None)
            if isinstance(v, str) and v not in events:
                from hydrohil.errors import unknown_name
                raise InputError(unknown_name(v, events, what="action name"), source=str(path),
                                 key=f"expect[{i}].{key}")
    return loaded


# an expectation's values that are in its signal's unit (a number: SI; or "<number> <unit>"): type -> keys
VALUE_KEYS = {"bounds": ("min", "max"), "reaction": ("margin", "below", "above"), "tracking": ("tol",),
              "step_response": ("max_steady_state_error",)}


def _expectation_units(data: dict, path: Path, circuit: Path | None) -> None:
    """An expectation's level in a sequence file given with its unit ("170 bar", "2 mm") in its signal's SI
    unit, in place (a bound on a circuit's signal: the unit its run logs; a loop's tolerance: the measured
    signal's); a unit of another quantity names the key and the unit wanted. (Python's expectations, the pytest
    plugin's, take SI numbers.)"""
    from hydrohil.circuits.units import to_si
    from hydrohil.sequences.expectations import UNITS
    units = None
    for i, e in enumerate(data.get("expect") or []):
        kind = e.get("type") if isinstance(e, dict) else None
        if not isinstance(kind, str) or not isinstance(e.get("signal", ""), str) or not any(
                isinstance(e.get(k), str) for k in VALUE_KEYS.get(kind, ())):
            continue                          # (a malformed entry: the schema's validation names it)
        if units is None:
            units = dict(UNITS) if circuit is None else _circuit_units(circuit)
        loop_signal = "error" if kind in ("tracking", "step_response") else None
        signal = loop_signal or e.get("signal", "u" if kind == "reaction" else None)
        unit = units.get(signal)
        for k in VALUE_KEYS[kind]:
            if not isinstance(e.get(k), str):
                continue
            if not unit:
                raise InputError(f"no unit known for signal {signal!r}: give the value as a number in its SI unit",
                                 source=str(path), key=f"expect[{i}].{k}")
            try:
                e[k] = to_si(e[k], unit)
            except ValueError as exc:
                raise InputError(f"{exc} ({signal} is in {unit})", source=str(path), key=f"expect[{i}].{k}") from None


def _circuit_units(scenario: Path) -> dict:
    """The SI unit of every signal of a circuit scenario's run, its loop's under the rig's names too."""
    from hydrohil.circuits.run import input_unit, signal_units
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.sequences.expectations import loop_units
    cs = load_circuit_scenario(scenario)
    units = {**signal_units(cs.circuit, cs.layout), **{s: input_unit(cs.circuit, s) for s in cs.circuit.inputs}}
    if cs.loop is not None:
        units.update(loop_units(units, cs.loop))
    return units


def _circuit_scenario(name: str, base: Path) -> Path | None:
    """The scenario file when it names a circuit (a circuit's sequence), else None."""
    from hydrohil.circuits.scenario import is_circuit_scenario
    p = base / name
    return p if p.is_file() and is_circuit_scenario(p) else None


def slug(text: str) -> str:
    """A sequence's (or an expectation's) name as a file name: letters, digits, ``_.-``; at most 80 chars."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")[:80] or "sequence"
