"""Steering a running rig: changes applied at a step boundary, logged with their step index, replayable.

A change is a small JSON object (an *event*) sent by the live panel (:mod:`hydrohil.panel`) through the
side channel (:mod:`hydrohil.hil.sidechannel`) to the process it concerns. That process applies it at the
boundary of the step it is about to take (the plant: before step k; the controller: before the command
answering sensor packet k) and appends it to its event log with that ``k``:

==================  ============  ===================================================================
op                  process       fields
==================  ============  ===================================================================
``set``             plant         ``name`` (one of :data:`TUNABLES`), ``value`` (SI unit of the table)
``fault_on``        plant         ``fault``: an entry of ``[[faults]]`` without start/end -> ``slot``
``fault_off``       plant         ``slot`` (as returned by its ``fault_on``)
``reset``           plant         the model back to the scenario's initial state (plant time 0)
``gains``           controller    any of ``kp ki kd kff kpl`` of the built-in law (units of [controller])
``reference``       controller    ``value`` [m] held from now on, or null: the scenario's reference again
``reset``           controller    the law's state (integral, filters) cleared
==================  ============  ===================================================================

A circuit's plant (a scenario naming its circuit, :mod:`hydrohil.hil.circuit`) takes its own events:

==================  ============  ===================================================================
``input``           plant         ``name`` (one of its inputs not driven by the controller), ``value``
                                  (SI, in its parameter's range) held from now on, or null: its drive again
``set``             plant         ``name`` (``component.key`` or ``fluid.key``: any parameter but an input
                                  or a delay), ``value`` (SI, in its range); the values derived from it follow
``fault``           plant         ``slot`` (a place in the scenario's ``[[faults]]``), ``on`` (true: active
                                  from now on; false: inactive): its schedule no longer applies (a leak's
                                  opening, a parameter's value with what derives from it held; a sensor's
                                  or a network fault's window from now; circuits.faults.live_switch)
``reset``           plant         its states and modes back to rest (the drives and time go on)
``gains``           controller    as above, the loop's law
``reference``       controller    ``value`` (SI of the measured signal) held from now on, or null
``reset``           controller    as above
==================  ============  ===================================================================

The same functions apply an event in the real-time plant, in the controller process and in the offline
replay (:func:`hydrohil.simulation.rig.run_rig` with ``events``), so a panel session replays bit for bit.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from typing import Annotated, Literal, Union

from pydantic import Field, TypeAdapter, ValidationError

from hydrohil.errors import HydrohilError, InputError
from hydrohil.core import dptr, lib, shape
from hydrohil.parameters.schema import StrictModel

# name -> (unit, lower, upper, what it is) of what "set" changes (core/shape.py TUNABLES, applied by C's hh_tuned_base)
TUNABLES = {t.name: (t.unit, t.lo, t.hi, t.description) for t in shape.TUNABLES}
GAINS = ("kp", "ki", "kd", "kff", "kpl")


class SetTunable(StrictModel):
    op: Literal["set"]
    name: Literal[tuple(t.name for t in shape.TUNABLES)]
    value: float


class FaultOn(StrictModel):
    op: Literal["fault_on"]
    fault: dict


class FaultOff(StrictModel):
    op: Literal["fault_off"]
    slot: int = Field(ge=0, lt=lib.HH_MAX_FAULTS)


class Reset(StrictModel):
    op: Literal["reset"]


class Gains(StrictModel):
    op: Literal["gains"]
    kp: float | None = None
    ki: float | None = None
    kd: float | None = None
    kff: float | None = None
    kpl: float | None = None


class Reference(StrictModel):
    op: Literal["reference"]
    value: float | None = Field(None, ge=-10, le=10, description="held reference [m]; null: the scenario's")


class HoldInput(StrictModel):
    op: Literal["input"]
    name: str
    value: float | None = Field(None, allow_inf_nan=False, description="held value (SI); null: its drive again")


class SetValue(StrictModel):
    op: Literal["set"]
    name: str
    value: float = Field(allow_inf_nan=False)
    slots: dict[str, float] | None = Field(None, description="the parameter vector's slots the change sets, its "
                                           "derived values with it ({slot: value}, circuits.rig.parameter_change): "
                                           "what the panel hands the standalone C plant")


class CircuitFault(StrictModel):
    op: Literal["fault"]
    slot: int = Field(ge=0, description="the fault's place in the scenario's [[faults]]")
    on: bool = Field(description="true: active from now on; false: inactive from now on (its schedule no longer "
                     "applies)")
    inputs: dict[str, float] | None = Field(None, description="the inputs it holds and their values (filled in "
                                            "from the scenario: circuits.faults.live_switch)")
    sensor: int = Field(-1, description="its row of the loop's sensor (filled in), -1: none")
    network: int = Field(-1, description="its place in the command path (filled in), -1: none")


class CircuitReference(Reference):
    value: float | None = Field(None, allow_inf_nan=False, description="held reference (SI of the measured "
                                                                      "signal); null: the scenario's")


PlantEvent = Annotated[Union[SetTunable, FaultOn, FaultOff, Reset], Field(discriminator="op")]
ControllerEvent = Annotated[Union[Gains, Reference, Reset], Field(discriminator="op")]
CircuitEvent = Annotated[Union[HoldInput, SetValue, CircuitFault, Reset], Field(discriminator="op")]
CircuitControllerEvent = Annotated[Union[Gains, CircuitReference, Reset], Field(discriminator="op")]
_PLANT, _CONTROLLER = TypeAdapter(PlantEvent), TypeAdapter(ControllerEvent)
_CIRCUIT, _CIRCUIT_CONTROLLER = TypeAdapter(CircuitEvent), TypeAdapter(CircuitControllerEvent)


def _errors(exc: ValidationError) -> str:
    return "; ".join(f"{'.'.join(map(str, e['loc'])) or 'event'}: {e['msg']}" for e in exc.errors())


def _validate(adapter, data: dict, source: str):
    body = {k: v for k, v in data.items() if k not in ("k", "id", "result")}
    try:
        return adapter.validate_python(body)
    except ValidationError as exc:
        raise InputError(_errors(exc), source=source) from None


def parse_event(data: dict, process: str, source: str = "event", circuit=None):
    """Validate one event for ``process`` ("plant" | "controller"); InputError naming the field otherwise.
    ``circuit``: the :class:`~hydrohil.circuits.scenario.CircuitScenario` whose plant or loop it steers (its
    events, :func:`parse_circuit_event`)."""
    if circuit is not None:
        return parse_circuit_event(data, process, circuit, source)
    ev = _validate(_PLANT if process == "plant" else _CONTROLLER, data, source)
    if isinstance(ev, SetTunable):
        unit, lo, hi, what = TUNABLES[ev.name]
        if not lo <= ev.value <= hi:
            raise InputError(f"{what} must be in [{lo:g}, {hi:g}] {unit}, got {ev.value:g}", source=source,
                             key=ev.name)
    if isinstance(ev, FaultOn):
        ev = FaultOn(op="fault_on", fault=fault_model(ev.fault, source).model_dump())
    return ev


def parse_circuit_event(data: dict, process: str, cs, source: str = "event"):
    """An event of a circuit scenario ``cs``'s plant or loop, checked against its circuit: an input it has and
    the controller does not drive, a parameter it has (not an input, not a delay: its memory is sized at the
    start), a value in the parameter's range (SI unit named)."""
    if process != "plant":
        if cs.loop is None:
            raise InputError("this circuit scenario has no closed loop: its controller takes no steering",
                             source=source)
        return _validate(_CIRCUIT_CONTROLLER, data, source)
    ev = _validate(_CIRCUIT, data, source)
    c = cs.circuit
    if isinstance(ev, CircuitFault):                # (what it changes: from the scenario, whatever was given)
        from hydrohil.circuits.faults import live_switch
        sw = live_switch(cs, ev.slot, source)
        if not ev.on and sw.off is None:
            raise InputError(f"faults[{ev.slot}] starts at 0 and never ends: it has no value outside it to switch "
                             "off to", source=source, key="slot")
        return ev.model_copy(update={"inputs": sw.on if ev.on else sw.off, "sensor": sw.sensor,
                                     "network": sw.network})
    if isinstance(ev, HoldInput):
        if ev.name not in c.inputs:
            raise InputError(f"not an input of circuit {c.name!r} (inputs: {', '.join(c.inputs) or 'none'})",
                             source=source, key=ev.name)
        if cs.loop is not None and ev.name == cs.loop.command:
            raise InputError("the closed loop's command: its controller drives it (steer its reference or gains)",
                             source=source, key=ev.name)
        if cs.commands is not None and ev.name in cs.commands.inputs:
            raise InputError("one of the open loop's commands: the controller process sends its drive",
                             source=source, key=ev.name)
    if isinstance(ev, (HoldInput, SetValue)):
        from hydrohil.circuits.faults import driven_by_fault, fault_inputs, follows_fault
        if isinstance(ev, HoldInput) and ev.name in c.inputs and driven_by_fault(c, ev.name):
            raise InputError("driven by the scenario's parameter fault (its schedule): not held from the panel",
                             source=source, key=ev.name)
        if isinstance(ev, HoldInput) and ev.name in fault_inputs(cs.faults):
            raise InputError("driven by the scenario's fault (a leak's opening, a parameter fault's target: its "
                             "schedule): switch the fault on or off instead (op \"fault\")", source=source,
                             key=ev.name)
        if isinstance(ev, SetValue) and follows_fault(c, ev.name.partition(".")[0]):
            raise InputError(f"{ev.name.partition('.')[0]}'s derived values follow the scenario's parameter fault: "
                             "its parameters are not changed live", source=source, key=ev.name)
        prm = _circuit_param(c, ev.name, source)
        if isinstance(ev, SetValue) and ev.name in c.inputs:
            raise InputError("an input of the circuit: hold it with op \"input\"", source=source, key=ev.name)
        if isinstance(ev, SetValue) and ev.name in cs.layout.delay_params.values():
            raise InputError("a delay's memory is sized when the run starts: not changed while it runs",
                             source=source, key=ev.name)
        problem = prm.check(ev.value) if ev.value is not None else None
        if problem:
            raise InputError(f"{problem}, got {ev.value:g}", source=source, key=ev.name)
    return ev


def _circuit_param(c, key: str, source: str):
    from hydrohil.circuits.library import FLUID
    comp, _, name = key.partition(".")
    if comp == "fluid":
        if name not in FLUID:
            raise InputError(f"not a fluid parameter (fluid: {', '.join(FLUID)})", source=source, key=key)
        return FLUID[name]
    if comp not in c.components:
        raise InputError(f"no component {comp!r} (components: {', '.join(c.components)}; or fluid)", source=source,
                         key=key)
    params = c.components[comp].type.params
    if name not in params:
        raise InputError(f"not a parameter of {comp} ({c.components[comp].type.name}: {', '.join(params)})",
                         source=source, key=key)
    if name in c.components[comp].load_keys:
        coupled = c.components[comp].coupled
        raise InputError(f"{comp} drives the load {coupled!r}: its {name} is the load's ({coupled}.{name})",
                         source=source, key=key)
    return params[name]


def apply_circuit_event(rig, ev, k: int) -> dict:
    """Apply a validated circuit plant event to a :class:`~hydrohil.circuits.rig.CircuitRig` at the boundary of
    step k (before it is taken)."""
    if isinstance(ev, HoldInput):
        rig.hold(ev.name, ev.value)
    elif isinstance(ev, SetValue):
        rig.set_value(ev.name, ev.value)
    elif isinstance(ev, CircuitFault):
        rig.switch_fault(ev.on, ev.inputs or {}, ev.sensor, ev.network, k)
    elif isinstance(ev, Reset):
        rig.restart()
    else:
        raise TypeError(f"not a circuit event: {ev!r}")
    return {}


_FAULT = None


def fault_model(fault: dict, source: str = "event"):
    """A fault of :mod:`hydrohil.simulation.faults` switched on now (start 0, no end: it lasts until off).
    (The validator is built once: building it takes milliseconds, validating microseconds.)"""
    global _FAULT
    if _FAULT is None:
        from hydrohil.simulation.faults import Fault
        _FAULT = TypeAdapter(Fault)
    body = {k: v for k, v in fault.items() if k not in ("start", "end")}
    try:
        return _FAULT.validate_python({**body, "start": 0.0})
    except ValidationError as exc:
        raise InputError(_errors(exc), source=source, key="fault") from None


def tuned_base(base0, tunables: dict):
    """The parameter vector of the scenario (``base0``) with the tunables applied (C's ``hh_tuned_base``, which
    the standalone plant calls too)."""
    t = np.array([tunables.get(x.name, np.nan) for x in shape.TUNABLES], dtype=np.float64)
    b = np.ascontiguousarray(base0, dtype=np.float64)
    p = np.empty_like(b)
    lib.hh_tuned_base(dptr(b), dptr(t), dptr(p))
    return p


def apply_plant_event(rig, ev, k: int) -> dict:
    """Apply a validated plant event to a :class:`~hydrohil.simulation.rig.VirtualRig` at the boundary of
    step k (before it is taken). Returns what the acknowledgement adds (e.g. the fault's slot)."""
    if isinstance(ev, SetTunable):
        rig.tune(ev.name, ev.value)
        return {}
    if isinstance(ev, FaultOn):
        return {"slot": rig.fault_on(fault_model(ev.fault), k)}
    if isinstance(ev, FaultOff):
        rig.fault_off(ev.slot, k)
        return {}
    if isinstance(ev, Reset):
        rig.reset()
        return {}
    raise TypeError(f"not a plant event: {ev!r}")


class SteerableController:
    """The built-in law of a scenario with its reference, as the controller process and the offline replay
    run it: events change the gains, hold a reference or clear the law's state (:func:`apply`)."""

    def __init__(self, controller, reference):
        self.controller, self.reference = controller, reference
        self.held: float | None = None

    def ref(self, t: float) -> tuple[float, float]:
        return (self.held, 0.0) if self.held is not None else self.reference(t)

    def apply(self, ev) -> dict:
        from hydrohil.control import BuiltinController
        if isinstance(ev, Reference):
            self.held = ev.value
        elif isinstance(ev, Reset):
            if hasattr(self.controller, "reset"):
                self.controller.reset()
        elif isinstance(ev, Gains):
            if not isinstance(self.controller, BuiltinController):
                raise InputError("gains apply to a built-in controller only", source="event", key="gains")
            self.controller.retune(**{g: getattr(ev, g) for g in GAINS if getattr(ev, g) is not None})
        else:
            raise TypeError(f"not a controller event: {ev!r}")
        return {}


def apply_controller_messages(messages: list[dict], k: int, steer: SteerableController, side, events, *,
                               circuit=None) -> None:
    """The panel's messages to a controller process (``side``: its side channel), applied before the command
    answering sensor packet k: each validated (``circuit``: a circuit scenario's loop), applied to ``steer``,
    logged with k in ``events`` and answered; a refused one answered with its error. ``messages`` is emptied."""
    for msg in messages:
        try:
            ev = parse_event(msg, "controller", source="panel", circuit=circuit)
            steer.apply(ev)
        except (HydrohilError, ValueError, TypeError) as exc:
            side.answer(msg, error=str(exc))
            continue
        events.write(k, ev.model_dump(exclude_none=True))
        side.answer(msg, k=k)
    messages.clear()


class EventLog:
    """Append-only JSON-lines log of applied events (``events.jsonl`` / ``controller_events.jsonl``):
    one line per event with its step index ``k``; flushed at once (a crash keeps what was applied)."""

    def __init__(self, path: Path | None):
        self.path = path
        self.fh = open(path, "a", buffering=1) if path is not None else None

    def write(self, k: int, event: dict, **result) -> None:
        """One applied event; ``result``: what applying it gave (a fault's slot), kept apart from the event."""
        if self.fh is not None:
            self.fh.write(json.dumps({"k": int(k), **event, **({"result": result} if result else {})}) + "\n")

    def close(self) -> None:
        if self.fh is not None:
            self.fh.close()
            self.fh = None


def read_events(path: Path, process: str, circuit=None) -> dict[int, list]:
    """An event log -> {k: [validated events in the order applied]} (a missing file: no events). Only
    applied events are in it (a refused one is answered with an error and never logged)."""
    path = Path(path)
    out: dict[int, list] = {}
    if not path.is_file():
        return out
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            data = json.loads(line)
            k = int(data["k"])
        except (ValueError, KeyError, TypeError):
            raise InputError("expected a JSON object with an integer step index k", source=f"{path}:{n}") from None
        out.setdefault(k, []).append(parse_event(data, process, source=f"{path}:{n}", circuit=circuit))
    return out
