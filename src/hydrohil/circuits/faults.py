"""Faults of a circuit scenario (``[[faults]]``): compiled into the circuit itself, so that every layer that
steps it (simulate, the continuous reference, HIL on both plants, test sequences) injects them alike, step for
step, with no fault code of its own (an FMU exported from the scenario has a leak's opening and a faulted
parameter as inputs, for its importer to drive).

::

    [[faults]]
    type = "leak"                 # a burst hose, a broken fitting: an orifice from a node to tank opens
    orifice = "burst"             # the orifice's name in the logs (burst.q, burst.opening); default leak_<node>
    node = "line_a"
    area = "30 mm2"               # (discharge_coefficient = 0.61, transition_pressure = 1 bar: the orifice's;
                                  # to = "tank": default the node a tank fixes)
    start = 1.5                   # [s]: active on the steps k with start <= k*h < end
    end = 3.0                     # [s] (omit: to the end of the run)

    [[faults]]
    type = "parameter"            # any parameter of a component changed for a while: a seal wearing
    target = "cyl.damping"        # (leakage), a pump losing speed, a load changing, a relief setting drifting
    value = "40000 N.s/m"
    start = 2.0

    [[faults]]
    type = "sensor_offset"        # the closed loop's measurement fails (sensor_stuck, sensor_offset with
    offset = "2 bar"              # offset and drift, sensor_noise with std, sensor_dropout: it reads 0,
    drift = 0.0                   # encoder_count_loss with fraction), in its signal's unit
    start = 3.0                   # (signal = "<node>.p": a pressure transducer the loop reads fails instead)

    [[faults]]
    type = "packet_loss"          # the network between the controller and the plant (packet_loss and
    probability = 0.3             # reordering with probability, network_delay with delay [s],
    start = 1.0                   # controller_silence; command_inversion): on the loop's commands, as the
    end = 2.0                     # paper's rig's (circuits/network.py)

A leak is an orifice component added to the circuit, its opening a signal driven 0 -> 1 -> 0. A parameter
fault makes its parameter an input signal of the circuit, held at its value outside the fault and at
``value`` inside it; the values derived from it follow as signals of their own (a load's weight from its
mass, a relief valve's flow gain from its cracking pressure), computed here at each of the drive's values.
A fault on a signal replaces its drive during the fault. The log shows each as applied (``cyl.damping``).
A sensor fault acts where the loop reads its signal (the generated C's hc_sensed, the loop's transducer: an
ideal one when the scenario gives none), in every layer that reads it; the log's ``<measure>.sensed`` shows it.
``signal = "<node>.p"`` puts it on one of the loop's pressure transducers instead (a state feedback's load
cylinder's chambers, its supply_node, its tank_node: hc_pressures_read, the fault on the pressure before the
transducer's model, as the paper's rig's), in Pa.
A fault's random draws come from its own stream, seeded by ``[hil] seed`` and its place in ``[[faults]]`` (the
paper's rig's rule; ``stream = N`` draws from place N's instead: what ``hydrohil circuit convert`` writes where
the rig's table had another order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hydrohil.circuits.network import NETWORK_FAULTS
from hydrohil.errors import InputError, unknown_name

SENSOR_FAULTS = ("sensor_stuck", "sensor_offset", "sensor_noise", "sensor_dropout",
                 "encoder_count_loss")   # (hc_sensed's order)
TYPES = ("leak", "parameter", *SENSOR_FAULTS, *NETWORK_FAULTS)
KEYS = {"leak": {"type", "orifice", "node", "area", "to", "discharge_coefficient", "transition_pressure", "start",
                 "end"},
        "parameter": {"type", "target", "value", "start", "end"},
        "sensor_stuck": {"type", "start", "end"}, "sensor_offset": {"type", "offset", "drift", "start", "end"},
        "sensor_noise": {"type", "std", "start", "end"}, "sensor_dropout": {"type", "start", "end"},
        "encoder_count_loss": {"type", "fraction", "start", "end"},
        "packet_loss": {"type", "probability", "start", "end"}, "network_delay": {"type", "delay", "start", "end"},
        "reordering": {"type", "probability", "start", "end"}, "controller_silence": {"type", "start", "end"},
        "command_inversion": {"type", "start", "end"}}
for _kind in (*SENSOR_FAULTS, *NETWORK_FAULTS):      # (a loop's fault may name the random stream it draws from)
    KEYS[_kind] = KEYS[_kind] | {"stream"}
for _kind in SENSOR_FAULTS:                          # (and the signal whose sensor fails: the measured one, or a
    KEYS[_kind] = KEYS[_kind] | {"signal"}           # pressure the loop reads through its transducers)
MAX_LOOP_FAULTS = 53                                 # (the command path's fault mask: core HH_MAX_FAULTS)
# each network fault's value: key, unit, range (the paper's rig's, simulation/faults.py; a delay line up to 1 s)
NETWORK_VALUE = {"packet_loss": ("probability", "-", 0.0, 1.0), "network_delay": ("delay", "s", 0.0, 1.0),
                 "reordering": ("probability", "-", 0.0, 1.0)}


def _number(v, key: str, where: str, source: str, unit: str = "s") -> float:
    from hydrohil.circuits.units import to_si
    try:
        x = to_si(v, unit)
    except (ValueError, TypeError) as exc:
        raise InputError(f"{exc}", source=source, key=f"{where}.{key}") from None
    if not (isinstance(x, float) or isinstance(x, int)) or not math.isfinite(x):
        raise InputError(f"a number [{unit}], got {v!r}", source=source, key=f"{where}.{key}")
    return float(x)


def _window(f: dict, where: str, source: str) -> tuple[float, float | None]:
    start = _number(f.get("start"), "start", where, source) if "start" in f else None
    if start is None or not 0.0 <= start <= 1e5:
        raise InputError(f"the fault's first instant [s] in [0, 1e5], got {f.get('start')!r}", source=source,
                         key=f"{where}.start")
    end = _number(f["end"], "end", where, source) if "end" in f else None
    if end is not None and not end > start:
        raise InputError(f"end ({end:g} s) must be after start ({start:g} s)", source=source, key=f"{where}.end")
    return start, end


def active_faults(faults: list, h: float, rows: int, every: int = 1, source: str = "scenario"):
    """Per log row (every ``every`` steps) the scenario's faults active at its step, bit i for its fault i (the
    paper's rig's log column ``faults``): a fault's steps start <= k*h < end (network.fault_steps, the rig's
    rule)."""
    import numpy as np
    from hydrohil.circuits.network import fault_steps
    k = np.arange(rows, dtype=np.int64) * every
    mask = np.zeros(rows, dtype=np.int64)
    for i, f in enumerate(faults):
        k0, k1 = fault_steps(*_window(f, f"faults[{i}]", source), h)
        mask |= ((k >= k0) & (k < k1)).astype(np.int64) << i
    return mask.astype(float)


def windowed_drive(base, value, start: float, end: float | None) -> dict:
    """A held drive: ``base`` (a number, "<number> <unit>", or a held table {t, value}) with ``value`` over
    [start, end). ValueError for a table interpolated linearly (a value held over a window is no straight line)."""
    from hydrohil.circuits.units import to_si
    if isinstance(base, dict) and base.get("interpolation", "hold") != "hold":
        raise ValueError("its drive is interpolated linearly: a value held for a while replaces a held drive only "
                         "(give the drive held from each t, or a constant)")
    ts = [to_si(x, "s") for x in base["t"]] if isinstance(base, dict) else [0.0]
    vs = list(base["value"]) if isinstance(base, dict) else [base]

    def at(t):                                      # the base's value held at t
        return vs[max(i for i, ti in enumerate(ts) if ti <= t + 1e-12)]
    t_out = [t for t in ts if t < start]
    v_out = [v for t, v in zip(ts, vs) if t < start]
    t_out.append(start)
    v_out.append(value)
    if end is not None:
        t_out.append(end)
        v_out.append(at(end))
        t_out += [t for t in ts if t > end]
        v_out += [v for t, v in zip(ts, vs) if t > end]
    return {"t": t_out, "value": v_out}


def apply_faults(raw: dict, faults, source: str) -> frozenset:
    """The scenario's ``faults`` (a list of tables) written into the circuit's raw tables ``raw`` (in place):
    a leak's orifice and its drive, a parameter fault's drive. Returns the parameters driven by faults that are
    not signals of their type (for :func:`hydrohil.circuits.circuit.circuit_from_dict`)."""
    from hydrohil.circuits.circuit import _value          # (the circuit file's value check: unit, range, key)
    from hydrohil.circuits.library import TYPES as COMPONENTS
    if not isinstance(faults, list) or not all(isinstance(f, dict) for f in faults):
        raise InputError("[[faults]] tables (type = \"leak\" or \"parameter\")", source=source, key="faults")
    comps, inputs = raw.setdefault("components", {}), raw.setdefault("inputs", {})
    nodes = {n for body in comps.values() if isinstance(body, dict) for k, n in body.items()
             if isinstance(n, str) and k in COMPONENTS.get(body.get("type", ""), COMPONENTS["tank"]).ports}
    tanks = sorted({body["p"] for body in comps.values() if isinstance(body, dict) and body.get("type") == "tank"})
    driven = set()
    for i, f in enumerate(faults):
        where = f"faults[{i}]"
        kind = f.get("type")
        if kind not in TYPES:
            raise InputError(f"a circuit's faults are {', '.join(TYPES)} (a leak at a node, a parameter changed, "
                             f"the loop's sensor failing, the network losing, delaying or reordering its commands, "
                             f"the controller falling silent, the commands inverted; the rig's other fault types "
                             f"are a leak or a parameter here: hydrohil circuit convert writes them), got {kind!r}",
                             source=source, key=f"{where}.type")
        unknown = set(f) - KEYS[kind]
        if unknown:
            raise InputError(unknown_name(sorted(unknown)[0], sorted(KEYS[kind])) + f" (a {kind} fault's keys)",
                             source=source, key=f"{where}.{sorted(unknown)[0]}")
        start, end = _window(f, where, source)
        if kind in SENSOR_FAULTS or kind in NETWORK_FAULTS:   # (the loop's: sensor_faults, network_faults)
            continue
        if kind == "leak":
            node = f.get("node")
            if node not in nodes:
                raise InputError(f"the node that leaks, one of the circuit's ({', '.join(sorted(nodes))}), got "
                                 f"{node!r}", source=source, key=f"{where}.node")
            to = f.get("to", tanks[0] if len(tanks) == 1 else None)
            if to not in nodes or to == node:
                raise InputError(f"the node it leaks into (default: the tank's, when one tank fixes a node), one of "
                                 f"{', '.join(sorted(nodes - {node}))}, got {to!r}", source=source, key=f"{where}.to")
            name = f.get("orifice", f"leak_{node}")
            if not isinstance(name, str) or name in comps:
                raise InputError(f"a name for the leak's orifice that no component has, got {name!r}", source=source,
                                 key=f"{where}.orifice")
            if "area" not in f:
                raise InputError("required: the leak's area [m2] (e.g. \"30 mm2\")", source=source,
                                 key=f"{where}.area")
            for k in ("area", "discharge_coefficient", "transition_pressure"):
                if k in f:
                    _value(f, k, COMPONENTS["orifice"].params[k], source, where)
            comps[name] = {"type": "orifice", "a": node, "b": to, "area": f["area"],
                           **{k: f[k] for k in ("discharge_coefficient", "transition_pressure") if k in f}}
            inputs[f"{name}.opening"] = windowed_drive(0.0, 1.0, start, end)
            continue
        target = f.get("target")
        comp, _, key = target.partition(".") if isinstance(target, str) else ("", "", "")
        body = comps.get(comp)
        ctype = COMPONENTS.get(body.get("type", "")) if isinstance(body, dict) else None
        if ctype is None or key not in ctype.params:
            choices = ", ".join(f"{n}.<key>" for n in comps) or "none"
            raise InputError(f"a component's parameter, component.key ({choices}), got {target!r}", source=source,
                             key=f"{where}.target")
        coupling = ctype.coupling
        if coupling is not None and coupling.key in body and key in coupling.load_keys:
            raise InputError(f"{comp}'s {coupling.part} drives the load {body[coupling.key]!r}: its {key} is the "
                             f"load's (target = \"{body[coupling.key]}.{key}\")", source=source,
                             key=f"{where}.target")
        if key in ctype.ports or key in ("x0", "speed0", "delay"):
            raise InputError(f"{target} is fixed when the run starts (an initial state, a delay line's length): a "
                             "fault cannot change it", source=source, key=f"{where}.target")
        if "value" not in f:
            raise InputError(f"required: {target}'s value during the fault [{ctype.params[key].unit}]", source=source,
                             key=f"{where}.value")
        _value(f, "value", ctype.params[key], source, where)
        if target in inputs:
            base = inputs[target]
        else:
            prm = ctype.params[key]
            base = body.get(key, prm.default)
            if base is None or (isinstance(base, float) and math.isnan(base)):
                raise InputError(f"{target} has no value of its own to return to after the fault (give it in the "
                                 "circuit)", source=source, key=f"{where}.target")
            if key in ctype.inputs:
                body.pop(key, None)                   # a signal of its type: driven from now on
            else:
                driven.add(target)                    # its value as given kept: checked, shown, derived from
        try:
            inputs[target] = windowed_drive(base, f["value"], start, end)
        except ValueError as exc:
            raise InputError(f"{target}: {exc}", source=source, key=f"{where}.target") from None
    return frozenset(driven)


def driven_by_fault(c, name: str) -> bool:
    """An input a parameter fault made (a parameter that is no signal of its type, or a value derived from
    one): its drive is the fault's schedule."""
    comp, _, key = name.partition(".")
    return comp in c.components and key not in c.components[comp].type.inputs


def leak_openings(faults: list) -> set[str]:
    """The inputs a scenario's leaks open (``<orifice>.opening``)."""
    return {f"{f.get('orifice', 'leak_' + str(f.get('node')))}.opening" for f in faults if f.get("type") == "leak"}


def fault_inputs(faults: list) -> set[str]:
    """The inputs a scenario's faults drive: its leaks' openings and its parameter faults' targets (their
    schedules', or the live panel's fault switches'), not held as inputs."""
    return leak_openings(faults) | {f.get("target") for f in faults if f.get("type") == "parameter"}


def follows_fault(c, comp: str) -> bool:
    """A component whose derived values follow a fault's drive (they are inputs): a parameter of it changed
    live would leave them behind."""
    cp = c.components.get(comp)
    return cp is not None and any(f"{comp}.{dk}" in c.inputs for dk, _ in cp.type.derived)


def _loop_faults(faults: list, kinds: tuple, loop, what: str, source: str):
    """(stream, table, type, its key, start, end) of each of ``faults`` of the ``kinds`` acting on the loop's
    ``what`` (stream: its ``stream`` key, else its place in ``faults``: the random stream it draws from, seeded
    with ``[hil] seed``, as the paper's rig's); an error naming the fault when the scenario has no loop, or
    when there are more than MAX_LOOP_FAULTS of them."""
    n = 0
    for i, f in enumerate(faults):
        kind = f.get("type")
        if kind not in kinds:
            continue
        where = f"faults[{i}]"
        if loop is None:
            raise InputError(f"a {kind} acts on the closed loop's {what}: this scenario has no [controller]" + (
                " (in open loop: name the inputs the controller process sends, commands = [\"<input>\"])"
                if what == "commands" else ""), source=source, key=f"{where}.type")
        n += 1
        if n > MAX_LOOP_FAULTS:
            raise InputError(f"at most {MAX_LOOP_FAULTS} faults on the loop's {what}", source=source,
                             key=f"{where}.type")
        stream = f.get("stream", i)
        if not (isinstance(stream, int) and not isinstance(stream, bool) and 0 <= stream < 2 ** 31):
            raise InputError(f"a whole number in [0, 2^31) (the place whose random stream it draws from; default its "
                             f"own, {i}), got {stream!r}", source=source, key=f"{where}.stream")
        yield (stream, f, kind, where, *_window(f, where, source))


def sensor_faults(faults: list, loop, units: dict, source: str) -> tuple[list, list]:
    """The sensor faults among a scenario's ``faults`` (checked by :func:`apply_faults`), as the loop's sensors
    take them: (the measured signal's sensor's, its pressure transducers'). A fault's ``signal`` names the
    signal whose sensor fails: the loop's measured one (the default), or a pressure it reads through its
    transducers (a state feedback's load cylinder's chambers, its supply_node's and tank_node's). Each
    (type, start, end or None, a, b, slot), a transducer's with its slot (0, 1: the chambers, 2: the supply, 3:
    the tank) appended: an offset [unit] and drift [unit/s], a noise's standard deviation [unit], in SI (the
    signal's unit, ``units``), or the fraction of an encoder's counts missed."""
    out, press = [], []
    for stream, f, kind, where, start, end in _loop_faults(faults, SENSOR_FAULTS, loop, "sensors", source):
        signal = f.get("signal", loop.measure)
        reads = {} if loop.pressures is None else {**{col: i for i, col in enumerate(loop.pressures)},
                                                   **{col: i for i, col in loop.supply_tank}}
        if signal != loop.measure and signal not in reads:
            choices = ", ".join([loop.measure, *reads])
            raise InputError(f"a signal the loop reads through a sensor: its measured one or a pressure it reads "
                             f"through its transducers ({choices}), got {signal!r}", source=source,
                             key=f"{where}.signal")
        unit = units.get(signal, "-")
        a = b = 0.0
        if kind == "sensor_offset":
            a = _number(f.get("offset", 0.0), "offset", where, source, unit)
            b = _number(f.get("drift", 0.0), "drift", where, source, f"{unit}/s")
        elif kind == "sensor_noise":
            if "std" not in f:
                raise InputError(f"required: the noise's standard deviation [{unit}]", source=source,
                                 key=f"{where}.std")
            a = _number(f["std"], "std", where, source, unit)
            if not a > 0:
                raise InputError(f"a standard deviation > 0 [{unit}], got {f['std']!r}", source=source,
                                 key=f"{where}.std")
        elif kind == "encoder_count_loss":
            a = _number(f.get("fraction"), "fraction", where, source, "-") if "fraction" in f else math.nan
            if not 0 < a <= 1:
                raise InputError(f"the fraction of the counts missed, in (0, 1], got {f.get('fraction')!r}",
                                 source=source, key=f"{where}.fraction")
            if not loop.encoder or signal != loop.measure:
                raise InputError("an encoder's counts: the loop measuring a position (m or rad) with its "
                                 "sensor_resolution (its count size)", source=source, key=f"{where}.type")
        if signal == loop.measure:
            out.append((kind, start, end, a, b, stream))
        else:
            press.append((kind, start, end, a, b, stream, reads[signal]))
    return out, press


def follow_derived(c, source: str) -> None:
    """The values derived from a parameter that a fault drives (not a signal of its type: a load's weight from
    its mass) added to the circuit's inputs (in place) as drives of their own, the derivation (ComponentType.derive,
    the file's own check) applied at each of the drive's values."""
    from hydrohil.circuits.circuit import Drive, component_values
    for comp in c.components.values():
        faulted = [k for k in comp.type.params if f"{comp.name}.{k}" in c.inputs and k not in comp.type.inputs]
        if not faulted or not comp.type.derived:
            continue
        times = sorted({float(t) for k in faulted for t in c.inputs[f"{comp.name}.{k}"][0]})
        rows = []
        for t in times:
            params = dict(comp.params)
            for k in faulted:
                params[k] = float(c.inputs[f"{comp.name}.{k}"].at([t], 1.0)[0])
            try:
                rows.append(component_values(comp.type, params, c.fluid))
            except ValueError as exc:
                raise InputError(f"{comp.name} at {t:g} s, during a fault: {exc}", source=source, key="faults") from None
        for dk, _ in comp.type.derived:
            vals = np.array([r[dk] for r in rows], dtype=float)
            if not np.array_equal(vals, np.full_like(vals, comp.values[dk]), equal_nan=True):
                c.inputs[f"{comp.name}.{dk}"] = Drive(np.array(times), vals)


def network_faults(faults: list, loop, source: str) -> list:
    """The network faults among a scenario's ``faults`` (checked by :func:`apply_faults`) on the commands of
    ``loop`` (a closed loop, or an open loop's :class:`~hydrohil.circuits.run.Commands`), as the command path
    takes them (:class:`hydrohil.circuits.network.CommandPath`): (type, start, end or None, value, slot) with a
    probability, or a delay [s]; 0 for a controller_silence; slot: its place in ``faults`` (its random stream's)."""
    out = []
    for stream, f, kind, where, start, end in _loop_faults(faults, NETWORK_FAULTS, loop, "commands", source):
        a = 0.0
        if kind in NETWORK_VALUE:
            key, unit, lo, hi = NETWORK_VALUE[kind]
            if key not in f:
                raise InputError(f"required: the {key} [{unit}] in ({lo:g}, {hi:g}]", source=source,
                                 key=f"{where}.{key}")
            a = _number(f[key], key, where, source, unit)
            if not lo < a <= hi:
                raise InputError(f"a {key} [{unit}] in ({lo:g}, {hi:g}], got {f[key]!r}", source=source,
                                 key=f"{where}.{key}")
        out.append((kind, start, end, a, stream))
    return out


@dataclass(frozen=True)
class LiveSwitch:
    """What switching fault ``slot`` of a scenario's ``[[faults]]`` on or off from the live panel changes in
    either plant, at the step boundary k it is applied at, from then on (its schedule no longer applies): a
    leak's opening or a parameter fault's inputs held at their values inside the fault (on) or outside it (off),
    each value derived from the parameter with it; a sensor fault's row of the loop's sensor (``sensor``: its
    place in :attr:`hydrohil.circuits.run.Loop.sensor_faults`) or a network fault's place in the command path
    (``network``) active on [k, never) (on) or on no step (off), a stuck sensor's memory fresh."""
    slot: int
    on: dict                     # input -> value while on
    off: dict | None             # input -> value while off (None: it has none, it starts at 0 and never ends)
    sensor: int = -1
    network: int = -1


def live_switch(cs, slot: int, source: str = "event") -> LiveSwitch:
    """Fault ``slot`` of the circuit scenario ``cs`` as the live panel switches it (:class:`LiveSwitch`);
    InputError (key ``slot``) for one no plant switches: a fault on a pressure transducer (the controller
    process reads those), a parameter another fault drives too."""
    faults = cs.faults
    if not (isinstance(slot, int) and 0 <= slot < len(faults)):
        raise InputError(f"a place in the scenario's [[faults]] (0 to {len(faults) - 1})" if faults else
                         "the scenario has no [[faults]] to switch", source=source, key="slot")
    f = faults[slot]
    kind = f["type"]
    if kind in SENSOR_FAULTS:
        if f.get("signal", cs.loop.measure if cs.loop is not None else None) != cs.loop.measure:
            raise InputError(f"faults[{slot}] fails a pressure transducer the controller process reads: not "
                             "switched from the panel (its schedule acts)", source=source, key="slot")
        row = sum(1 for g in faults[:slot] if g["type"] in SENSOR_FAULTS
                  and g.get("signal", cs.loop.measure) == cs.loop.measure)
        return LiveSwitch(slot, {}, {}, sensor=row)
    if kind in NETWORK_FAULTS:
        return LiveSwitch(slot, {}, {}, network=sum(1 for g in faults[:slot] if g["type"] in NETWORK_FAULTS))
    c, h = cs.circuit, cs.step
    if kind == "leak":
        (name,) = leak_openings([f])
        return LiveSwitch(slot, {name: 1.0}, {name: 0.0})
    target = f["target"]
    others = [j for j, g in enumerate(faults)
              if j != slot and g.get("type") == "parameter" and g.get("target") == target]
    if others:
        raise InputError(f"faults[{slot}] and faults[{others[0]}] drive {target}: neither is switched from the "
                         "panel (their schedules act)", source=source, key="slot")
    comp = c.components[target.partition(".")[0]]
    names = [target, *(f"{comp.name}.{dk}" for dk, _ in comp.type.derived if f"{comp.name}.{dk}" in c.inputs)]
    start, end = _window(f, f"faults[{slot}]", source)
    at = lambda name, t: float(c.inputs[name].at(np.array([t]), h)[0])       # noqa: E731 (its drive at t)
    outside = max(start - h, 0.0) if start > 0 else end      # (the step before it, else after it)
    return LiveSwitch(slot, {n: at(n, start) for n in names},
                      {n: at(n, outside) for n in names} if outside is not None else None)
