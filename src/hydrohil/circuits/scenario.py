"""A scenario that names its circuit (SPEC §12.1): which circuit, how long, which solver and step, parameter
values on top of the circuit's, and drives of its signals in place of the circuit's defaults.

::

    circuit = "circuit.toml"          # a path (relative to this file) or a built-in circuit's name
    duration = 7.5                    # [s] (default: the drive's last change + 2 s)
    repeat = false                    # true: the drives and the reference start again every duration (what
                                      # a live panel session, running until stopped, writes)
    rest = true                       # start at rest (SPEC §12.5); false: as the file gives it; in open loop
                                      # {hold = "cyl.x", by = "valve.command"}: the piston held at the start by
                                      # that input's value that holds it, the drives from t = 0 (the paper's
                                      # rig's open-loop start)
    [start]                           # optional: the start in place of the rest's alone
    "valve.command" = 0.3             # an input's value before t = 0: at rest under it (a spool there, the
                                      # nodes settled to its flows; a delayed input sees it until its delay
                                      # has passed), the drives from t = 0 (a loop's command: held until the
                                      # controller's first, in place of the one that holds the piston)
    cap = "50 bar"                    # a node's pressure, set on the state at rest (the other nodes keep
                                      # their rest values; the seals take the new net force)
    [solver]
    method = "rk3"                    # euler, heun, rk3, rk4 or reference (the continuous model, LSODA)
    step = 0.0005                     # [s]
    output_every = 1                  # a log row every n steps
    [set]                             # parameters, as in the circuit file ("<number> <unit>" or SI)
    "cyl1.mass" = "300 kg"
    "fluid.bulk_modulus" = "12000 bar"
    [inputs]                          # drives of the circuit's signals, as in its [inputs] (held from each
    "valve1.command" = { t = [0, 0.5], value = [0, 0.6] }  # t, or interpolation = "linear")
    [controller]                      # optional closed loop: the core's law (control.h) on any signal
    type = "pi"                       # p, pi, pid, p_ff or state_feedback (load_pressure = "<cylinder>": its
                                      # chambers read too, through pressure_range/_resolution/_noise
                                      # transducers, pressure_seed; supply_node, tank_node read too),
                                      # or python (callable = "file.py:Name", options: a user's controller,
                                      # called each step with a hydrohil.control.Measurement)
    measure = "motor.w"               # the signal it reads (a log column)
    command = "valve.command"         # the input it drives (one of the circuit's [inputs])
    kp = 0.002                        # gains in the command's unit per the measured signal's SI unit
    ki = 0.02                         # (u_min, u_max: the command's limits, default its parameter's range;
                                      # sensor_resolution, sensor_min, sensor_max, sensor_noise (its standard
                                      # deviation; sensor_seed): what the controller reads;
                                      # action = "reverse": a larger command lowers the signal)
    [reference]                       # the measured signal's reference, held from each t, with units
    t = [0, 0.5, 3]
    value = ["0 rpm", "600 rpm", "300 rpm"]
    interpolation = "hold"            # or "linear" between the points (its slope goes to p_ff's kff)
    repeat = "4 s"                    # optional: the table again every period (its value at t mod period)
    commands = ["valve.command"]      # optional, open loop: the inputs whose drives the controller process
                                      # sends (a value per step, the paper rig's open loop): the network
                                      # faults and the watchdog act on them
    [hil]                             # optional: real-time settings of `hydrohil hil` (as a paper scenario's)
    watchdog_timeout = 0.05
    safe_state = "hold"               # on a trip: the loop's command holds its measured signal at its value
    hold_kp = 0.002                   # then (P gain, the command's unit per the signal's SI unit); default
                                      # "centre": the commanded inputs at 0
    [[faults]]                        # optional: a leak at a node, a parameter changed (circuits/faults.py)
    type = "leak"
    node = "line_a"
    area = "30 mm2"
    start = 1.5

``--set component.key=value`` on the command line applies on top of ``[set]``; setting a signal replaces its
drive by that constant.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from hydrohil.circuits.circuit import (PRESSURE, TABLE_TIMES, Circuit, circuit_from_dict, circuit_path,
                                      valid_table_times)
from hydrohil.circuits.faults import apply_faults, follow_derived
from hydrohil.circuits.run import SOLVERS, Commands, Hold, Loop, Start
from hydrohil.core.watchdog import WATCHDOG_TIMEOUT
from hydrohil.errors import InputError, unknown_name
from hydrohil.parameters import copy_tables

# a --params given for a circuit scenario (simulate, hil, panel say it)
NO_PARAMETER_SET = "a circuit scenario has no parameter set: give its values with --set component.key=value"
KEYS = {"circuit", "description", "duration", "solver", "set", "inputs", "rest", "start", "controller", "reference",
        "hil", "repeat", "faults", "commands"}
LOOP_TYPES = ("p", "pi", "pid", "p_ff", "state_feedback", "python")
SOLVER_KEYS = {"method", "step", "output_every"}


@dataclass
class CircuitScenario:
    source: str
    circuit: Circuit
    duration: float
    method: str = "rk3"
    step: float = 5e-4
    every: int = 1
    rest: bool | Hold | Start = True               # (a Hold: an open loop starting with a piston held; a Start:
                                                   # with a [start] table)
    description: str = ""
    sets: dict = field(default_factory=dict)       # "component.key" -> value as given (scenario [set] + --set)
    loop: Loop | None = None                       # closed loop ([controller] + [reference])
    hil: dict = field(default_factory=dict)        # [hil] as given (checked by hydrohil.hil.circuit)
    faults: list = field(default_factory=list)     # [[faults]] as given (compiled into the circuit: faults.py)
    repeat: bool = False                           # drives and reference again every duration (a panel session)
    link: tuple = (0, WATCHDOG_TIMEOUT, 0.0)       # ([hil] seed, watchdog_timeout, hold_kp): the command path's
    commands: Commands | None = None               # an open loop's inputs sent by the controller process

    @cached_property
    def compiled(self):
        """Its circuit's :class:`~hydrohil.circuits.build.CompiledCircuit` (compiled or loaded once)."""
        from hydrohil.circuits.build import compile_circuit
        return compile_circuit(self.circuit)

    @property
    def layout(self):
        """Its circuit's :class:`~hydrohil.circuits.generate.Layout`."""
        return self.compiled.layout

    @property
    def n_steps(self) -> int:
        return int(round(self.duration / self.step))


def is_circuit_scenario(path: str | Path) -> bool:
    """True when the TOML file at ``path`` names a circuit (``circuit = ...``)."""
    try:
        return "circuit" in tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError):
        return False


def circuit_file(name: str, base: Path, source: str = "") -> Path:
    """The file of a circuit named in a scenario: a path relative to the scenario's folder, or a built-in
    (:func:`hydrohil.circuits.circuit.circuit_path`)."""
    return circuit_path(name, base, source or str(base), key="circuit")


def load_circuit_scenario(path: str | Path, *, solver: str | None = None, step: float | None = None,
                          duration: float | None = None, sets: dict | None = None) -> CircuitScenario:
    """The scenario at ``path`` with its circuit, ``sets`` ("component.key" -> value) on top of its [set]."""
    path = Path(path)
    source = str(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError("no such scenario file", source=source) from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not valid TOML: {exc}", source=source) from None
    return scenario_from_dict(data, path.parent, source, solver=solver, step=step, duration=duration, sets=sets)


def scenario_from_dict(data: dict, base: Path, source: str, *, solver: str | None = None, step: float | None = None,
                       duration: float | None = None, sets: dict | None = None,
                       circuit: dict | None = None) -> CircuitScenario:
    """A circuit scenario from its tables (``base``: the folder its circuit path is relative to; ``circuit``: the
    circuit file's tables in place of reading the file it names, e.g. a paper scenario's, converted in memory)."""
    unknown = set(data) - KEYS
    if unknown:
        raise InputError(unknown_name(sorted(unknown)[0], sorted(KEYS)) + " (a circuit scenario's keys)",
                         source=source, key=sorted(unknown)[0])
    if not isinstance(data.get("circuit"), str):
        raise InputError("the circuit's file or built-in name", source=source, key="circuit")
    cfile = circuit_file(data["circuit"], base, source) if circuit is None else base / data["circuit"]
    try:
        raw = tomllib.loads(cfile.read_text()) if circuit is None else circuit
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not valid TOML: {exc}", source=str(cfile)) from None
    solver_t = data.get("solver", {})
    if not isinstance(solver_t, dict) or set(solver_t) - SOLVER_KEYS:
        bad = sorted(set(solver_t) - SOLVER_KEYS)[0] if isinstance(solver_t, dict) else "solver"
        raise InputError(unknown_name(bad, sorted(SOLVER_KEYS), prefix="solver."), source=source, key=f"solver.{bad}")
    method = solver or solver_t.get("method", "rk3")
    if method not in SOLVERS:                   # (a command line's value named as its option)
        raise InputError(f"one of {', '.join(SOLVERS)}, got {method!r}", **(
            {"source": "--solver"} if solver else {"source": source, "key": "solver.method"}))
    h = step if step is not None else solver_t.get("step", 5e-4)
    every = solver_t.get("output_every", 1)
    if not (isinstance(h, (int, float)) and 1e-7 <= h <= 0.1):
        raise InputError(f"a fixed step in [1e-7, 0.1] s, got {h!r}", **(
            {"source": "--step"} if step is not None else {"source": source, "key": "solver.step"}))
    if not (isinstance(every, int) and every >= 1):
        raise InputError(f"an integer >= 1, got {every!r}", source=source, key="solver.output_every")
    for key in ("set", "inputs", "hil"):
        if not isinstance(data.get(key, {}), dict):
            raise InputError("a table of \"component.key\" = value", source=source, key=key)
    raw = copy_tables(raw)                      # (its tables set below, never a value changed in place)
    raw.setdefault("inputs", {}).update(data.get("inputs", {}))
    given = {**data.get("set", {}), **(sets or {})}
    for key, value in given.items():
        _apply(raw, key, value, source if key in data.get("set", {}) and key not in (sets or {}) else "--set")
    origin = str(cfile) if not (given or data.get("inputs") or data.get("faults")) else \
        f"{cfile} (with {source}'s [set], [inputs], [[faults]] and --set)"
    faulted = apply_faults(raw, data["faults"], source) if "faults" in data else frozenset()
    c = circuit_from_dict(raw, origin, fault_signals=faulted)
    follow_derived(c, source)
    if c.name == "circuit" or not raw.get("name"):
        c.name = cfile.parent.name
    from hydrohil.circuits.show import default_duration
    dur = duration if duration is not None else data.get("duration", default_duration(c))
    if not (isinstance(dur, (int, float)) and 0 < dur <= 1e5):
        raise InputError(f"a duration in (0, 1e5] s, got {dur!r}", source=source, key="duration")
    if dur < h:
        raise InputError(f"a run of at least one step: duration {dur:g} s < step {h:g} s", source=source,
                         key="duration")
    rest, repeat = data.get("rest", True), data.get("repeat", False)
    for key, v in (("rest", rest), ("repeat", repeat)):
        if not isinstance(v, bool) and not (key == "rest" and isinstance(v, dict)):
            raise InputError(f"true or false{' (or {hold, by})' if key == 'rest' else ''}, got {v!r}", source=source,
                             key=key)
    built: list = []                              # (its circuit compiled once, when a check needs its layout)

    def layout():
        if not built:
            from hydrohil.circuits.build import compile_circuit
            built.append(compile_circuit(c))
        return built[0].layout
    loop = _loop(data, c, source, base, layout)
    link = _link(data.get("hil", {}), source, loop)   # the faults' streams, the watchdog: the scenario's [hil]
    if loop is not None:
        loop.link = link
    commands = _commands(data["commands"], c, loop, link, source) if "commands" in data else None
    if isinstance(rest, dict):
        rest = _hold(rest, c, loop, source, layout)
    if "start" in data:
        rest = _start(data["start"], c, loop, rest, source)
    if loop is not None:
        loop.h = float(h)                         # (sampled at the scenario's step)
    if data.get("faults"):                        # the loop's sensor failing (an ideal one to fail if none given)
        from hydrohil.circuits.faults import network_faults, sensor_faults
        from hydrohil.circuits.run import signal_units
        units = signal_units(c, layout())
        found, press = sensor_faults(data["faults"], loop, units, source)
        if found:
            loop.sensor_faults = found
            if loop.sensor is None:
                loop.sensor = (0.0, -1e300, 1e300, 0.0)
        if press:                                 # (its pressure transducers failing: hc_pressures_read)
            loop.pressure_faults = press
        network = network_faults(data["faults"], loop or commands, source)
        if network:                               # the loop's commands through the network (circuits/network.py)
            (loop or commands).network = network
    if loop is not None and loop.command in given:
        raise InputError(f"{loop.command} is the closed loop's command (its controller drives it): a value set "
                         "for it would be overridden", source=source if loop.command in data.get("set", {}) else
                         "--set", key=loop.command)
    for name in commands.inputs if commands is not None else ():
        if name in given:
            raise InputError(f"{name} is one of the open loop's commands (the controller process sends its drive): "
                             "give its drive in [inputs], not a value", source=source if name in data.get("set", {})
                             else "--set", key=name)
    cs = CircuitScenario(source, c, float(dur), method, float(h), every, rest, str(data.get("description", "")),
                         given, loop, dict(data.get("hil", {})), list(data.get("faults", [])), repeat, link, commands)
    if built:
        cs.__dict__["compiled"] = built[0]        # (its cached_property: the circuit is not changed after)
    return cs


def _commands(names, c: Circuit, loop, link: tuple, source: str) -> Commands:
    """``commands = ["<input>", ...]``: an open loop's inputs whose drives the controller process sends
    (run.Commands)."""
    if loop is not None:
        raise InputError("a closed loop's controller sends its command already; commands names an open loop's "
                         "inputs sent over the link", source=source, key="commands")
    if not (isinstance(names, list) and names and all(isinstance(n, str) for n in names)):
        raise InputError(f"a list of the circuit's inputs, e.g. [\"{next(iter(c.inputs), 'valve.command')}\"], got "
                         f"{names!r}", source=source, key="commands")
    for name in names:
        if name not in c.inputs:
            raise InputError(unknown_name(name, list(c.inputs), what="input") + " (the circuit's inputs)",
                             source=source, key="commands")
    if len(set(names)) != len(names):
        raise InputError(f"an input named twice: {names!r}", source=source, key="commands")
    return Commands(tuple(n for n in c.inputs if n in names), link=link)


def _link(hil: dict, source: str, loop) -> tuple[int, float, float]:
    """([hil] seed, watchdog_timeout, the safe state's hold gain: 0 for "centre") of the command path (the full
    [hil] check is the HIL run's: hydrohil.simulation.scenario.circuit_hil; these act offline too). The safe
    state "hold" holds the loop's measured signal at its value at the trip with the loop's command, a P law of
    gain ``hold_kp`` [the command's unit per the signal's SI unit], given (no default fits every signal)."""
    seed, timeout = hil.get("seed", 0), hil.get("watchdog_timeout", WATCHDOG_TIMEOUT)
    if not (isinstance(seed, int) and not isinstance(seed, bool) and 0 <= seed <= 2 ** 53):
        raise InputError(f"a whole number in [0, 2^53] (the network faults' random streams), got {seed!r}",
                         source=source, key="hil.seed")
    if not (isinstance(timeout, (int, float)) and not isinstance(timeout, bool) and 0 < timeout <= 10):
        raise InputError(f"a time [s] in (0, 10], got {timeout!r}", source=source, key="hil.watchdog_timeout")
    safe = hil.get("safe_state", "centre")
    if safe not in ("centre", "hold"):
        raise InputError(f"centre (the commanded inputs to 0) or hold (the loop's measured signal held by its "
                         f"command), got {safe!r}", source=source, key="hil.safe_state")
    if safe == "centre":
        return seed, float(timeout), 0.0
    if loop is None:
        raise InputError("the safe state \"hold\" holds the closed loop's measured signal with its command: this "
                         "scenario has no [controller] (its safe state: \"centre\")", source=source,
                         key="hil.safe_state")
    if loop.sign < 0:
        raise InputError("the safe state \"hold\" holds a directly acting loop's signal (a larger command raises "
                         "it): not with action = \"reverse\"", source=source, key="hil.safe_state")
    kp = hil.get("hold_kp")
    if not (isinstance(kp, (int, float)) and not isinstance(kp, bool) and 0 < kp <= 1e5):
        raise InputError(f"the P gain in (0, 1e5] holding {loop.measure} with {loop.command} [the command's unit per "
                         f"the signal's SI unit], required with safe_state = \"hold\", got {kp!r}", source=source,
                         key="hil.hold_kp")
    return seed, float(timeout), float(kp)


def anchored(data: dict, path: Path) -> dict:
    """The tables ``data`` of the circuit scenario at ``path`` as a copy elsewhere reads them (a run folder's, a
    test sequence's, a study's): its circuit's file and a user's controller's folder (its ``path``, default
    the scenario's folder) by absolute path. ``data`` changed in place and returned."""
    from hydrohil.control import anchor_controller
    data["circuit"] = str(circuit_file(data["circuit"], path.parent, str(path)).resolve())
    anchor_controller(data.get("controller"), path.parent)
    return data


def write_circuit_scenario(path: str | Path, dest: str | Path, *, sets: dict, repeat: bool | None = None,
                           hil: dict | None = None) -> Path:
    """The scenario ``path`` with ``sets`` added to its [set], written to ``dest`` with its circuit's file named
    absolutely: what a run folder records, and what its processes read. ``repeat``: its ``repeat`` key set so,
    ``hil``: keys of its [hil] (a live panel session)."""
    import tomli_w
    path, dest = Path(path), Path(dest)
    data = anchored(tomllib.loads(path.read_text()), path)
    data.setdefault("set", {}).update(sets)
    if repeat is not None:
        data["repeat"] = repeat
    if hil:
        data.setdefault("hil", {}).update(hil)
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_text(f"# {path.name} as run (hydrohil: --set applied)\n" + tomli_w.dumps(data))
    return dest


# a circuit loop's [controller] keys beside its law's (hydrohil.control): the signals it closes on, the command's
# range, the sensor, a state feedback's load pressure
LIMIT_KEYS = ("u_min", "u_max")
SENSOR_KEYS = ("sensor_resolution", "sensor_min", "sensor_max", "sensor_noise")
FEEDBACK_KEYS = ("load_pressure", "pressure_range", "pressure_resolution", "pressure_noise", "pressure_seed",
                 "supply_node", "tank_node")
LOOP_KEYS = ("measure", "command", *LIMIT_KEYS, *SENSOR_KEYS, "sensor_seed", "action", *FEEDBACK_KEYS)


def _loop(data: dict, c: Circuit, source: str, base: Path, layout) -> Loop | None:
    """The closed loop of [controller] + [reference]: the core's built-in law (hydrohil.control) with its gains
    checked as a paper scenario's are, the measured signal and the driven input named, the reference in the
    measured signal's unit (``layout()``: the circuit's layout, compiled once per scenario)."""
    import numpy as np
    from pydantic import ValidationError
    from hydrohil.circuits.units import to_si
    from hydrohil.control import (PControllerCfg, PFFControllerCfg, PIControllerCfg, PIDControllerCfg,
                                  PythonControllerCfg, StateFeedbackControllerCfg, anchor_controller)
    LOOP_CFG = {"p": PControllerCfg, "pi": PIControllerCfg, "pid": PIDControllerCfg, "p_ff": PFFControllerCfg,
                "state_feedback": StateFeedbackControllerCfg, "python": PythonControllerCfg}
    if "controller" not in data and "reference" not in data:
        return None
    if not isinstance(data.get("controller"), dict) or not isinstance(data.get("reference"), dict):
        raise InputError("a closed loop needs both [controller] (type, measure, command, gains) and [reference] "
                         "(t, value)", source=source, key="controller" if "controller" not in data else "reference")
    table = dict(data["controller"])
    for key in ("measure", "command"):
        if not isinstance(table.get(key), str):
            raise InputError("the signal's name, component.variable", source=source, key=f"controller.{key}")
    measure, command = table.pop("measure"), table.pop("command")
    limits = {k: table.pop(k) for k in LIMIT_KEYS if k in table}     # (the command's unit, not ū)
    sensor_keys = {k: table.pop(k) for k in SENSOR_KEYS if k in table}
    feedback = {k: table.pop(k) for k in FEEDBACK_KEYS if k in table}
    seed = table.pop("sensor_seed", 0)
    if not (isinstance(seed, int) and not isinstance(seed, bool) and 0 <= seed < 2 ** 63):
        raise InputError(f"a whole number >= 0, got {seed!r}", source=source, key="controller.sensor_seed")
    action = table.pop("action", "direct")
    if action not in ("direct", "reverse"):
        raise InputError(f"\"direct\" (a larger command raises the measured signal) or \"reverse\" (lowers it), "
                         f"got {action!r}", source=source, key="controller.action")
    anchor_controller(table, base)              # (a user's controller's folder: relative to the scenario's)
    if table.get("type") not in LOOP_TYPES:
        raise InputError(f"a circuit's loop runs the core's laws or a user's controller: type one of "
                         f"{', '.join(LOOP_TYPES)}, got {table.get('type')!r}", source=source, key="controller.type")
    try:
        cfg = LOOP_CFG[table["type"]].model_validate(table)
    except ValidationError as exc:
        errors = exc.errors()
        extra = [e for e in errors if e["type"] == "extra_forbidden"]
        if extra:                                   # a misspelt key: named with the nearest (not "kp missing")
            key = str(extra[0]["loc"][-1])
            valid = [*LOOP_CFG[table["type"]].model_fields, *LOOP_KEYS]
            raise InputError(unknown_name(key, valid, prefix="controller."), source=source,
                             key=f"controller.{key}") from None
        e = errors[0]
        loc = ".".join(str(x) for x in e["loc"]) or "type"
        hint = (" (gains are positive; a loop where a larger command lowers the measured signal says action = "
                "\"reverse\")" if loc in ("kp", "ki") and "greater than" in e["msg"] else "")
        raise InputError(e["msg"] + hint, source=source, key=f"controller.{loc}") from None
    lay = layout()
    units = {"t": "s", **{f"{n}.p": "Pa" for n in c.nodes}, **dict(lay.outputs)}
    if measure not in units or measure == "t":
        raise InputError(f"not a signal of circuit {c.name!r} (signals: {', '.join(x for x in units if x != 't')})",
                         source=source, key="controller.measure")
    if command not in c.inputs:
        raise InputError(f"not an input of circuit {c.name!r} (inputs: {', '.join(c.inputs) or 'none'}; a "
                         "circuit's [inputs] names the signals it lets be driven)", source=source,
                         key="controller.command")
    prm = c.input_param(command)
    try:
        lo = to_si(limits.get("u_min", prm.lo), prm.unit)
        hi = to_si(limits.get("u_max", prm.hi), prm.unit)
    except ValueError as exc:
        raise InputError(str(exc), source=source, key="controller.u_min/u_max") from None
    if not prm.lo <= lo < hi <= prm.hi:
        raise InputError(f"the command's limits must lie in {command}'s range [{prm.lo:g}, {prm.hi:g}] {prm.unit} "
                         f"with u_min < u_max, got [{lo:g}, {hi:g}]", source=source, key="controller.u_min")
    sensor = None
    if sensor_keys:                        # the measurement as the rig's sensor gives it (SPEC §10)
        unit = units[measure]
        try:
            sensor = tuple(to_si(sensor_keys.get(k, d), unit) for k, d in (
                ("sensor_resolution", 0.0), ("sensor_min", -1e300), ("sensor_max", 1e300), ("sensor_noise", 0.0)))
        except ValueError as exc:
            raise InputError(f"{exc} (the sensor of {measure} [{unit}])", source=source,
                             key="controller.sensor_*") from None
        if not (sensor[0] >= 0 and sensor[1] < sensor[2] and sensor[3] >= 0):
            raise InputError(f"a resolution >= 0, sensor_min < sensor_max and a noise >= 0 (its standard deviation), "
                             f"got {sensor}", source=source, key="controller.sensor_resolution")
    ref = data["reference"]
    t, v = ref.get("t"), ref.get("value")
    if set(ref) - {"t", "value", "interpolation", "repeat"} or not isinstance(t, list) or not isinstance(v, list) \
            or len(t) != len(v) or not t:
        raise InputError("t = [...] and value = [...] of one length (and interpolation = \"hold\" or \"linear\", "
                         "repeat = its period)", source=source, key="reference")
    period = None
    if "repeat" in ref:                           # the table again every period: its value at t mod period
        try:
            period = to_si(ref["repeat"], "s")
        except ValueError as exc:
            raise InputError(f"{exc} (the reference's period)", source=source, key="reference.repeat") from None
        if not (isinstance(period, (int, float)) and not isinstance(period, bool) and 0 < period <= 1e6):
            raise InputError(f"the reference's period [s] in (0, 1e6], got {ref['repeat']!r}", source=source,
                             key="reference.repeat")
    if ref.get("interpolation", "hold") not in ("hold", "linear"):
        raise InputError(f"\"hold\" (from each t) or \"linear\", got {ref['interpolation']!r}", source=source,
                         key="reference.interpolation")
    try:
        ts = np.array([to_si(x, "s") for x in t])
        vs = np.array([to_si(x, units[measure]) for x in v])
    except ValueError as exc:
        raise InputError(f"{exc} (the reference of {measure} [{units[measure]}])", source=source,
                         key="reference") from None
    if not valid_table_times(ts, ref.get("interpolation") == "linear"):
        raise InputError(TABLE_TIMES, source=source, key="reference.t")
    comp, _, var = measure.partition(".")
    if comp in c.components and var == "x" and "stroke" in c.components[comp].values:
        from hydrohil.models.cylinder import warn_beyond_stroke
        warn_beyond_stroke(ts, vs, c.components[comp].values["stroke"], source, "reference value", f"{comp}.stroke",
                           given=v)
    encoder = sensor is not None and sensor[0] > 0 and units[measure] in ("m", "rad")   # (counts: a position)
    loop = Loop(cfg, measure, command, (ts, vs), linear=ref.get("interpolation") == "linear", period=period,
                limits=(lo, hi),
                sensor=sensor, sign=-1.0 if action == "reverse" else 1.0, seed=seed, encoder=encoder,
                base=base, source=source)
    if loop.python:
        if loop.sign < 0:
            raise InputError("a user's controller computes its own command's sign: no action = \"reverse\"",
                             source=source, key="controller.action")
        loop.user_callable()                    # (its module and name checked now; instantiated for each run)
    _load_pressure(loop, feedback, c, source)
    return loop


def _load_pressure(loop: Loop, feedback: dict, c: Circuit, source: str) -> None:
    """A state feedback's load pressure (``load_pressure = "<cylinder>"``: pL = p_a - (A_b/A_a)·p_b of its two
    chambers' nodes; ``pressure_range``, ``pressure_resolution``, ``pressure_noise`` (a standard deviation;
    ``pressure_seed`` its stream's): their transducers, the rig's, SPEC §10; none: the pressures themselves;
    ``supply_node``, ``tank_node``: nodes read through the same transducers too, a user's controller's ps and
    pt) into ``loop``."""
    from hydrohil.circuits.units import to_si
    reads = loop.cfg.type in ("state_feedback", "python")
    if not reads or (loop.python and not feedback):     # (a user's controller reads them when it names them)
        if feedback:
            raise InputError(f"only a state feedback or a user's controller reads a load pressure, not a "
                             f"{loop.cfg.type!r} loop", source=source, key=f"controller.{next(iter(feedback))}")
        return
    name = feedback.get("load_pressure")
    comp = c.components.get(name) if isinstance(name, str) else None
    cylinders = [n for n, x in c.components.items() if {"a", "b"} <= set(x.ports) and "area_a" in x.values
                 and "area_b" in x.values]
    if comp is None or name not in cylinders:
        raise InputError(f"a state feedback reads the load pressure of a cylinder: load_pressure = \"<its name>\" "
                         f"(cylinders of circuit {c.name!r}: {', '.join(cylinders) or 'none'}), got {name!r}",
                         source=source, key="controller.load_pressure")
    if loop.sign < 0:          # (a user's controller: refused above)
        raise InputError("a state feedback acts directly (its load pressure's sign is its cylinder's): no "
                         "action = \"reverse\"", source=source, key="controller.action")
    try:
        sensor = tuple(to_si(feedback.get(k, 0.0), "Pa") for k in ("pressure_range", "pressure_resolution",
                                                                   "pressure_noise"))
    except ValueError as exc:
        raise InputError(f"{exc} (the chambers' pressure transducers)", source=source,
                         key="controller.pressure_range") from None
    if not (sensor[0] >= 0 and sensor[1] >= 0) or (sensor[1] > 0 and sensor[0] == 0):
        raise InputError(f"a full scale >= 0 (0: no transducer, the pressures themselves) and a resolution >= 0 "
                         f"(with a full scale), got {sensor[:2]} Pa", source=source, key="controller.pressure_range")
    if not sensor[2] >= 0 or (sensor[2] > 0 and sensor[0] == 0):
        raise InputError(f"a noise >= 0 Pa (its standard deviation), of a transducer (with a pressure_range), got "
                         f"{sensor[2]:g} Pa", source=source, key="controller.pressure_noise")
    seed = feedback.get("pressure_seed")
    if seed is not None and not (isinstance(seed, int) and not isinstance(seed, bool) and 0 <= seed < 2 ** 63):
        raise InputError(f"a whole number >= 0, got {seed!r}", source=source, key="controller.pressure_seed")
    if seed is not None and seed == loop.seed and sensor[2] > 0 and loop.sensor is not None and loop.sensor[3] > 0:
        raise InputError(f"the pressure transducers' noise and the sensor's would be the same numbers: another seed "
                         f"than sensor_seed ({seed}), or none (a stream of its own)", source=source,
                         key="controller.pressure_seed")
    reads = []
    for slot, key in ((2, "supply_node"), (3, "tank_node")):
        if key in feedback:
            node = feedback[key]
            if node not in c.nodes:
                raise InputError(unknown_name(str(node), list(c.nodes), what="node"),
                                 source=source, key=f"controller.{key}")
            reads.append((slot, f"{node}.p"))
    loop.pressures = (f"{comp.ports['a']}.p", f"{comp.ports['b']}.p")
    if loop.sensor is not None and loop.measure in (*loop.pressures, *(col for _, col in reads)):
        raise InputError(f"{loop.measure} is measured through the loop's sensor: it is not read through a pressure "
                         "transducer too (the plant sends its sensor's reading)", source=source,
                         key="controller.measure")
    loop.area_ratio = comp.values["area_b"] / comp.values["area_a"]
    loop.pressure_sensor, loop.pressure_seed, loop.supply_tank = sensor, seed, tuple(reads)


def _hold(table: dict, c: Circuit, loop, source: str, layout) -> Hold:
    """``rest = {hold = "<piston>.x", by = "<input>"}``: an open loop starting with the piston held by the input's
    value that holds it (run.Hold)."""
    if set(table) != {"hold", "by"}:
        raise InputError("rest = {hold = \"<component>.x\", by = \"<input>\"}: the piston held at the start and the "
                         "input that holds it", source=source, key="rest")
    if loop is not None:
        raise InputError("a closed loop starts with its piston held by its own command already: rest = true",
                         source=source, key="rest")
    from hydrohil.circuits.run import MOVING
    lay = layout()
    comp = c.components.get(str(table["hold"]).rsplit(".", 1)[0])
    if comp is not None and comp.coupled:                 # (a coupled rod's position is its load's)
        comp = c.components[comp.coupled]
    if not (isinstance(table["hold"], str) and table["hold"].endswith(".x") and table["hold"] in lay.log_columns
            and comp is not None and comp.type.name in MOVING):
        xs = [x for x in lay.log_columns if x.endswith(".x") and c.components[x.rsplit(".", 1)[0]].type.name in MOVING]
        raise InputError(f"a position signal to hold, one of {', '.join(xs) or 'none'}, got {table['hold']!r}",
                         source=source, key="rest.hold")
    if table["by"] not in c.inputs:
        raise InputError(f"an input of circuit {c.name!r} (inputs: {', '.join(c.inputs) or 'none'}), got "
                         f"{table['by']!r}", source=source, key="rest.by")
    return Hold(table["hold"], table["by"])


def _start(table, c: Circuit, loop, rest: bool | Hold, source: str) -> Start:
    """``[start]``: inputs' values before t = 0 and node pressures set on the state at rest (run.Start)."""
    from hydrohil.circuits.circuit import _value          # (the circuit file's value check: unit, range, key)
    if not isinstance(table, dict) or not table:
        raise InputError("a table of \"<input>\" = value (its value before t = 0) and \"<node>\" = pressure (set "
                         "on the state at rest)", source=source, key="start")
    nodes = list(c.state_nodes)
    inputs, pressures = {}, {}
    for key, value in table.items():
        where = f"start.{key}"
        if key in c.inputs:
            prm = c.input_param(key)
            if isinstance(rest, Hold) and key == rest.command:
                raise InputError(f"{key} holds the piston at the start (rest = {{hold, by}}): give it a value or "
                                 "the hold, not both", source=source, key=where)
        elif key in nodes:
            prm = PRESSURE
        else:
            raise InputError(unknown_name(key, [*c.inputs, *nodes]) + " (an input of the circuit, or a node with a "
                             "pressure of its own)", source=source, key=where)
        (inputs if key in c.inputs else pressures)[key] = _value(table, key, prm, source, "start")   # (unit, range)
    return Start(rest, inputs, pressures)


def _apply(raw: dict, key: str, value, source: str) -> None:
    """``component.key = value`` (or ``fluid.key``) into the circuit's raw tables; a signal's drive replaced."""
    comp, dot, name = key.partition(".")
    comps = raw.get("components", {})
    if not dot or not name:
        raise InputError("expected component.key (or fluid.key), e.g. cyl1.mass", source=source, key=key)
    if comp == "fluid":
        raw.setdefault("fluid", {})[name] = value
        return
    if comp not in comps:
        raise InputError(f"no component {comp!r} (components: {', '.join(comps)}; or fluid)", source=source, key=key)
    if key in raw.get("inputs", {}):
        raw["inputs"][key] = value              # a signal: its drive is now this constant
        return
    if name in ("type",) or name in _ports(comps[comp]):
        raise InputError(f"{name} of {comp} is its {'type' if name == 'type' else 'port'}: not a parameter",
                         source=source, key=key)
    comps[comp][name] = value


def _ports(body: dict) -> set[str]:
    from hydrohil.circuits.library import TYPES
    t = TYPES.get(body.get("type", ""))
    return set(t.ports) if t else set()


def run_circuit_scenario(cs: CircuitScenario, progress=None):
    """The scenario's run (:func:`hydrohil.circuits.run.simulate_circuit`) and its summary: steps, step, solver,
    wall time of the run (not the compile, not the rest march) and real-time factor, the final value of every
    column, the reference's solver statistics; with faults, the log's ``faults``: bit i where its fault i acts."""
    from hydrohil.circuits.run import simulate_circuit
    res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, method=cs.method, every=cs.every, rest=cs.rest,
                           progress=progress, loop=cs.loop, commands=cs.commands, compiled=cs.compiled)
    if cs.faults:                            # which of its faults act at each row (the paper's rig's column)
        from hydrohil.circuits.faults import active_faults
        res.columns["faults"] = active_faults(cs.faults, cs.step, len(res.columns["t"]), cs.every, cs.source)
        res.units["faults"] = "-"
    wall = res.wall
    final = {k: (res.mode_names[k][int(v[-1])] if k in res.mode_names else float(v[-1]))
             for k, v in res.columns.items() if k != "t"}
    summary = {"scenario": cs.source, "circuit": cs.circuit.name, "circuit_source": cs.circuit.source,
               "solver": cs.method, "step": cs.step, "steps": cs.n_steps, "duration": cs.duration,
               "wall_time_s": wall, "realtime_factor": cs.duration / wall if wall > 0 else float("inf"),
               "sets": cs.sets, "units": res.units, "final_state": final, **res.stats}
    if cs.loop is not None:                  # the loop's moves as a control engineer reads them (metrics.py)
        from hydrohil.metrics import step_metrics
        lp = cs.loop
        summary["step_response"] = {"signal": lp.measure, "unit": res.units.get(lp.measure, "-"),
                                    **step_metrics(res.columns["t"], res.columns[lp.measure],
                                                   res.columns[f"{lp.measure}.reference"])}
    return res, summary


def circuit_scenario(*, circuit: str | None = None, scenario: str | Path | None = None, sets: dict | None = None,
                     step: float | None = None) -> CircuitScenario:
    """A circuit scenario from a scenario file naming its circuit, or a circuit (built-in name or file) alone
    with its default drive; ``sets`` and ``step`` on top. One of the two, not both."""
    if (circuit is None) == (scenario is None):
        raise InputError("give a circuit (--circuit NAME|PATH) or a scenario naming one (--scenario FILE)",
                         key="--circuit/--scenario")
    if scenario is not None:
        if not is_circuit_scenario(scenario):
            raise InputError("this scenario names no circuit (circuit = \"NAME|PATH\")", source=str(scenario),
                             key="circuit")
        return load_circuit_scenario(scenario, step=step, sets=sets)
    cs = scenario_from_dict({"circuit": str(circuit)}, Path.cwd(), "--circuit", step=step, sets=sets)
    cs.source = str(circuit)
    return cs
