"""A circuit file (TOML): components of the library, the nodes their ports connect to, the fluid, the signals
that drive it, initial node pressures. Values in SI or as "<number> <unit>" (:mod:`hydrohil.circuits.units`),
converted at the boundary; a mistake names the file, the component, the key and the expected unit or range.

::

    name = "pump_relief_accumulator"
    [fluid]                                   # optional: density, bulk_modulus, viscosity
    bulk_modulus = "14000 bar"
    [nodes.supply]                            # optional: a node's own volume (pipes, block)
    volume = "0.2 l"
    [components.pump]
    type = "pump"
    inlet = "tank"                            # port = node
    outlet = "supply"
    displacement = "16 cm3/rev"
    speed = "1500 rpm"
    [components.lift]
    type = "cylinder"
    a = "supply"
    b = "tank"
    bore = "50 mm"
    rod = "28 mm"
    stroke = "300 mm"
    rod_end = "deck"                          # a mechanical coupling: its rod drives the load "deck"
    [components.deck]
    type = "load"                             # mass, damping, spring, incline, force (or its signal), x0
    mass = "500 kg"
    [inputs]                                  # parameters driven as signals, with their default drive:
    "load.opening" = { t = [0, 1], value = [0.2, 1.0] }     # held from each t (zero-order hold), or a number
    "deck.force" = { t = [0, 2], value = [0, "3 kN"], interpolation = "linear" }   # or a straight line
    [initial]
    supply = "100 bar"                        # node pressures (default: at rest, hydrohil.circuits.run.settle)
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hydrohil.circuits.library import FLUID, TYPES, ComponentType, Param
from hydrohil.circuits.units import to_si
from hydrohil.errors import InputError, closest_name, unknown_name

CIRCUITS_DIR = Path(__file__).resolve().parents[3] / "examples" / "circuits"


@dataclass
class Component:
    name: str
    type: ComponentType
    ports: dict[str, str]                # port -> node
    values: dict[str, float]             # parameters (SI) and derived values
    given: dict[str, str]                # parameter -> as the file wrote it (shown by `circuit show`)
    params: dict[str, float] = field(default_factory=dict)   # its parameters (SI) before derivation
    coupled: str | None = None           # the load its rod or shaft drives (rod_end, shaft): its motion is the load's
    actuators: list[str] = field(default_factory=list)        # a load: the actuators coupled to it
    tables: dict = field(default_factory=dict)                # name -> (x's, values), SI (a load's force_table)

    @property
    def load_keys(self) -> tuple[str, ...]:
        """Its keys that are its load's (a coupled actuator: its load's mass, its shaft load's inertia, ...)."""
        return self.type.coupling.load_keys if self.coupled else ()

    @property
    def states(self) -> tuple[tuple[str, str], ...]:
        """(name, SI unit) of its own states (a coupled cylinder has none: they are its load's)."""
        return () if self.coupled else self.type.states

    @property
    def modes(self) -> tuple[str, ...]:
        """Its modes (a coupled cylinder has none: its end stops are its load's)."""
        return () if self.coupled else self.type.modes


@dataclass
class Circuit:
    name: str
    source: str
    fluid: dict[str, float]
    components: dict[str, Component]
    node_volumes: dict[str, float]       # a node's own volume [m3] (0: none given)
    inputs: dict[str, object]            # "component.parameter" -> float or (t, values) arrays
    initial: dict[str, float]            # node -> pressure [Pa]
    nodes: list[str] = field(default_factory=list)          # every node, in order of first mention
    fixed: dict[str, tuple[str, str]] = field(default_factory=dict)   # node -> (component, its pressure key)

    @property
    def state_nodes(self) -> list[str]:
        return [n for n in self.nodes if n not in self.fixed]

    def input_param(self, sig: str) -> Param:
        """The parameter an input signal drives (its SI unit, range, description): a parameter of its component,
        or a value derived from one that a fault changes (hydrohil.circuits.faults: unbounded)."""
        comp, _, key = sig.partition(".")
        ctype = self.components[comp].type
        if key in ctype.params:
            return ctype.params[key]
        return Param(dict(ctype.derived)[key], -math.inf, math.inf, f"derived {key}, following a fault's change")

    def node_volume(self, node: str) -> float:
        """A node's volume [m3] at the initial state: its own and what the components attached bring (hoses'
        halves, volumes, a cylinder's chamber)."""
        v = self.node_volumes.get(node, 0.0)
        for c in self.components.values():
            for port, n in c.ports.items():
                if n == node:
                    v += c.type.port_volume(c.values, port)
        return v


NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")      # component and node names: C identifiers (they name C)


def _err(source: str, where: str, message: str) -> InputError:
    return InputError(message, source=source, key=where)


def builtin_circuits() -> list[str]:
    """The circuits known by name: the example circuits (``examples/circuits/<name>/``, a checkout's) and the
    parameter sets (``ferreira2004``: the paper's rig as a circuit, in any install)."""
    from hydrohil.parameters import builtin_names
    examples = [d.name for d in CIRCUITS_DIR.iterdir() if (d / "circuit.toml").is_file()] \
        if CIRCUITS_DIR.is_dir() else []
    return sorted({*examples, *builtin_names()})


def circuit_path(name: str | Path, base: Path | None = None, source: str = "", key: str | None = None) -> Path:
    """The circuit file a name stands for: a file or a folder holding circuit.toml (relative to ``base``, default
    the working folder), an example circuit by name, or a parameter set — a built-in name or a parameter file of
    the paper's shape — as its rig's circuit (:func:`hydrohil.circuits.parameter_set.paper_circuit_file`).
    InputError naming ``source`` and ``key`` otherwise."""
    from hydrohil.circuits.parameter_set import paper_circuit_file
    from hydrohil.parameters import builtin_names
    p = (base or Path.cwd()) / name
    if p.is_dir() and (p / "circuit.toml").is_file():
        p = p / "circuit.toml"
    if p.is_file():
        try:
            data = tomllib.loads(p.read_text())
        except (tomllib.TOMLDecodeError, UnicodeDecodeError):
            return p.resolve()                       # (its loader says what is wrong)
        if "components" not in data and {"spool", "valve", "cylinder"} & set(data):
            return paper_circuit_file(p.resolve())   # a parameter file: its rig
        return p.resolve()
    example = CIRCUITS_DIR / str(name) / "circuit.toml"
    if example.is_file():
        return example
    if str(name) in builtin_names():
        return paper_circuit_file(str(name))
    raise InputError(f"no circuit {str(name)!r}: not a file{f' (relative to {base})' if base else ''} nor a built-in "
                     f"circuit (built-in: {', '.join(builtin_circuits())}; a parameter file stands for its rig)",
                     source=source or str(p), key=key)


def load_circuit(path: str | Path) -> Circuit:
    """A circuit from a file, or a built-in one by name (:func:`circuit_path`)."""
    p = circuit_path(path)
    source = str(p)
    try:
        data = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not valid TOML: {exc}", source=source) from None
    return circuit_from_dict(data, source)


def circuit_from_dict(data: dict, source: str = "circuit", *, fault_signals: frozenset = frozenset()) -> Circuit:
    """A circuit from its tables. ``fault_signals``: parameters ("component.key") a scenario's faults drive
    (hydrohil.circuits.faults): driven although not signals of their type, their values as given kept (the
    value outside the fault)."""
    top = ("name", "description", "fluid", "nodes", "components", "inputs", "initial")
    unknown = set(data) - set(top)
    if unknown:
        raise _err(source, sorted(unknown)[0], unknown_name(sorted(unknown)[0], top))
    fluid = {}
    for key, prm in FLUID.items():
        fluid[key] = _value(data.get("fluid", {}), key, prm, source, "fluid")
    for key in set(data.get("fluid", {})) - set(FLUID):
        raise _err(source, f"fluid.{key}", unknown_name(key, FLUID))
    comps_data = data.get("components")
    if not isinstance(comps_data, dict) or not comps_data:
        raise _err(source, "components", "a circuit needs [components.NAME] tables")
    inputs_data = data.get("inputs", {})
    driven = set(inputs_data)
    components: dict[str, Component] = {}
    nodes: list[str] = []
    fixed: dict[str, tuple[str, str]] = {}
    for name, body in comps_data.items():
        where = f"components.{name}"
        if not NAME.match(name):
            raise _err(source, where, "a component's name is letters, digits and _ (not starting with a digit)")
        if not isinstance(body, dict) or "type" not in body:
            raise _err(source, where, f"needs type = one of {', '.join(TYPES)}")
        ctype = TYPES.get(body["type"])
        if ctype is None:
            raise _err(source, f"{where}.type", unknown_name(body["type"], TYPES, what="component type"))
        cp = ctype.coupling
        other = ({cp.key} if cp else set()) | set(ctype.tables)       # a coupling's key, the tables
        for key in sorted(set(body) - set(ctype.params) - set(ctype.ports) - other - {"type"}):
            more = (f"; coupling: {cp.key}" if cp else "") + (f"; tables: {', '.join(ctype.tables)}"
                                                                if ctype.tables else "")
            near = closest_name(key, [*ctype.params, *ctype.ports, *sorted(other)])
            hint = f"unknown key '{key}'" + (f" (did you mean '{near}'?)" if near else "")
            raise _err(source, f"{where}.{key}", f"{hint}: not a parameter of a {ctype.name} (parameters: "
                                                 f"{', '.join(ctype.params)}; ports: {', '.join(ctype.ports)}"
                                                 f"{more})")
        ports = {}
        for port in ctype.ports:
            node = body.get(port)
            if not isinstance(node, str) or not NAME.match(node):
                raise _err(source, f"{where}.{port}", f"port {port} of a {ctype.name} needs a node name of letters, "
                                                      f"digits and _ (ports: {', '.join(ctype.ports)})")
            ports[port] = node
            if node not in nodes:
                nodes.append(node)
        coupled = None
        if cp is not None and cp.key in body:
            coupled = body[cp.key]
            if not isinstance(coupled, str) or not NAME.match(coupled):
                raise _err(source, f"{where}.{cp.key}", f"the name of the load its {cp.part} drives (a component of "
                                                        f"type {cp.load_type}), got {coupled!r}")
        values, given = {}, {}
        for key, prm in ctype.params.items():
            if coupled and key in cp.load_keys:          # the load's (checked by _couple), not the actuator's
                if key in body or f"{name}.{key}" in driven:
                    raise _err(source, f"{where}.{key}" if key in body else f"inputs.{name}.{key}",
                               f"{name}'s {cp.part} drives the load {coupled!r} ({cp.key}): its {key} is the load's "
                               f"(give it there; a coupled {ctype.name}'s keys: "
                               f"{', '.join(k for k in ctype.params if k not in cp.load_keys)})")
                values[key] = 0.0
                continue
            if f"{name}.{key}" in fault_signals:
                values[key] = _value(body, key, prm, source, where)
                if key in body:
                    given[key] = str(body[key])
                continue
            if f"{name}.{key}" in driven:
                if key not in ctype.inputs:
                    raise _err(source, f"inputs.{name}.{key}", f"not a signal of a {ctype.name} (signals: "
                                                                f"{', '.join(ctype.inputs) or 'none'})")
                if key in body:
                    raise _err(source, f"{where}.{key}", f"given here and driven in [inputs] \"{name}.{key}\": "
                                                         "one or the other")
                values[key] = math.nan
                continue
            values[key] = _value(body, key, prm, source, where)
            if key in body:
                given[key] = str(body[key])
        tables = {k: _table(body[k], ctype.tables[k], source, f"{where}.{k}") for k in ctype.tables if k in body}
        params = dict(values)
        try:
            values = component_values(ctype, params, fluid)
        except ValueError as exc:
            raise _err(source, where, str(exc)) from None
        if ctype.fixes:
            node = ports[ctype.ports[0]]
            if node in fixed:
                raise _err(source, where, f"node {node!r} is already fixed by {fixed[node][0]} (one tank or pressure "
                                          "source per node)")
            fixed[node] = (name, ctype.fixes)
        _warn_implausible(ctype, body, values, source, where)
        components[name] = Component(name, ctype, ports, values, given, params, coupled, tables=tables)
    _couple(components, source)
    node_volumes = {}
    for node, body in data.get("nodes", {}).items():
        if node not in nodes:
            raise _err(source, f"nodes.{node}", f"no component's port is at this node: "
                                                f"{unknown_name(node, nodes, what='node')}")
        if not isinstance(body, dict) or set(body) - {"volume"}:
            raise _err(source, f"nodes.{node}", "a node's table has one key: volume = \"<number> <unit>\"")
        node_volumes[node] = _value(body, "volume", _NODE_VOLUME, source, f"nodes.{node}")
    inputs = {}
    for sig, drive in inputs_data.items():
        comp, _, key = sig.partition(".")
        if comp not in components:
            raise _err(source, f"inputs.{sig}", unknown_name(comp, components, what="component"))
        if key not in components[comp].type.inputs and sig not in fault_signals:
            raise _err(source, f"inputs.{sig}", f"not a signal of {comp} (signals of a {components[comp].type.name}: "
                                                f"{', '.join(components[comp].type.inputs) or 'none'})")
        prm = components[comp].type.params[key]
        inputs[sig] = _drive(drive, prm, source, f"inputs.{sig}")
    initial = {}
    for node, v in data.get("initial", {}).items():
        if node not in nodes or node in fixed:
            raise _err(source, f"initial.{node}", f"not a pressure node of the circuit (nodes: "
                                                  f"{', '.join(n for n in nodes if n not in fixed)})")
        initial[node] = _value({node: v}, node, PRESSURE, source, "initial")
    c = Circuit(str(data.get("name", Path(source).parent.name)), source, fluid, components, node_volumes, inputs,
                initial, nodes, fixed)
    if not fixed:
        raise _err(source, "components", "no tank or pressure source: every circuit needs one (its return line)")
    _single_port_nodes(components, nodes, source, set(node_volumes) | set(initial))
    for node in c.state_nodes:
        if c.node_volume(node) <= 0.0:
            raise _err(source, f"nodes.{node}", "this node has no volume: give [nodes.NAME] volume = ... or attach a "
                                                "hose or a volume")
    return c


def _warn_implausible(ctype: ComponentType, body: dict, values: dict, source: str, where: str) -> None:
    """A valve's value given as a bare number that is valid but probably in another unit (a spool's wn in Hz,
    its delay in ms): warned with the paper's parameter files' rules (parameters.schema.PLAUSIBLE); a value
    written with its unit is taken as meant."""
    import warnings
    from hydrohil.errors import InputWarning
    from hydrohil.parameters.schema import PLAUSIBLE
    for key, bad, say in PLAUSIBLE:
        name = key.split(".")[1]
        v = body.get(name)
        if name in ctype.params and isinstance(v, (int, float)) and not isinstance(v, bool) and bad(values[name]):
            warnings.warn(f"{source}: {where}.{name}: {say(values[name])} (or write it with its unit)", InputWarning,
                          stacklevel=3)


def _single_port_nodes(components: dict, nodes: list[str], source: str, declared: set) -> None:
    """A node only one port is at and the file says nothing else of (``declared``: the nodes of [nodes] and
    [initial]): a port connected to nothing, most often a node's name misspelt (the nearest other node named); a
    port plugged on purpose is declared: its dead volume in [nodes.NAME]."""
    at: dict[str, list[str]] = {n: [] for n in nodes}
    for comp in components.values():
        for port, node in comp.ports.items():
            at[node].append(f"{comp.name}.{port}")
    for node in nodes:
        if len(at[node]) == 1 and node not in declared:
            close = closest_name(node, [n for n in nodes if n != node], cutoff=0.5)
            hint = f" (did you mean '{close}'?)" if close else ""
            raise _err(source, f"components.{at[node][0]}",
                       f"node '{node}' connects to nothing else: only {at[node][0]} is at it{hint}; a port "
                       f"plugged on purpose: give its dead volume, [nodes.{node}] volume = \"...\"")


def _table(t, spec: tuple, source: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    """A component's table {x = [...], f = [...]} in SI (``spec``: x's unit, the values' unit): at least two
    points, x increasing."""
    x_unit, f_unit, _ = spec
    if not isinstance(t, dict) or set(t) != {"x", "f"} or not isinstance(t["x"], list) or \
            not isinstance(t["f"], list) or len(t["x"]) != len(t["f"]) or len(t["x"]) < 2:
        raise _err(source, where, f"a table {{x = [...] ({x_unit}), f = [...] ({f_unit})}} of at least two points, "
                                  "one length")
    try:
        xs = np.array([to_si(v, x_unit) for v in t["x"]])
    except ValueError as exc:
        raise _err(source, f"{where}.x", str(exc)) from None
    try:
        fs = np.array([to_si(v, f_unit) for v in t["f"]])
    except ValueError as exc:
        raise _err(source, f"{where}.f", str(exc)) from None
    if np.any(np.diff(xs) <= 0):
        raise _err(source, f"{where}.x", "positions increasing")
    return xs, fs


def _couple(components: dict[str, Component], source: str) -> None:
    """The mechanical couplings (SPEC §12.1, §12.3): each cylinder's rod_end names a load, each motor's shaft a
    rotary load; a load is driven by at least one actuator; coupled pistons start where their load does, within
    the shortest stroke (their chambers' volumes at the start)."""
    for comp in components.values():
        if comp.coupled is None:
            continue
        cp = comp.type.coupling
        load = components.get(comp.coupled)
        if load is None or load.type.name != cp.load_type:
            loads = ", ".join(n for n, c in components.items() if c.type.name == cp.load_type) or \
                f"none: add a [components.NAME] of type = \"{cp.load_type}\""
            raise _err(source, f"components.{comp.name}.{cp.key}",
                       f"{comp.coupled!r} is not a {cp.load_type} of this circuit ({cp.load_type}s: {loads})")
        load.actuators.append(comp.name)
    for load in components.values():
        if load.type.name not in ("load", "rotary_load"):
            continue
        if not load.actuators:
            what = "cylinder's rod_end" if load.type.name == "load" else "motor's shaft"
            raise _err(source, f"components.{load.name}", f"nothing drives this {load.type.name}: give a {what} = "
                                                          f"\"{load.name}\"")
        if load.type.name == "rotary_load":           # (a coupled motor's own speed is never read)
            continue
        stroke = min(components[a].values["stroke"] for a in load.actuators)
        if not load.values["x0"] <= stroke:
            raise _err(source, f"components.{load.name}.x0",
                       f"must be within the travel of its cylinders (the shortest stroke, {stroke:g} m), got "
                       f"{load.values['x0']:g} m")
        for a in load.actuators:
            components[a].values["x0"] = components[a].params["x0"] = load.values["x0"]


_NODE_VOLUME = Param("m3", 0.0, 10.0, "the node's own volume", 0.0)
PRESSURE = Param("Pa", -1e5, 1e9, "pressure (gauge)")


def _value(body: dict, key: str, prm, source: str, where: str) -> float:
    if key not in body:
        if prm.default is None:
            raise _err(source, f"{where}.{key}", f"required: {prm.text(where.rpartition('.')[2])} [{prm.unit}]")
        return prm.default
    try:
        v = to_si(body[key], prm.unit)
    except ValueError as exc:
        raise _err(source, f"{where}.{key}", str(exc)) from None
    problem = prm.check(v)
    if problem:
        raise _err(source, f"{where}.{key}", f"{problem}, got {body[key]!r}")
    return v


class Drive(tuple):
    """A signal's drive as a table: (times [s], values [SI]), held from each time (zero-order hold) or, with
    ``linear``, interpolated linearly between them (a ramp, a load force over time); held after the last."""

    def __new__(cls, t, v, linear: bool = False):
        obj = super().__new__(cls, (t, v))
        obj.linear = bool(linear)
        return obj

    def __getnewargs__(self):
        return (self[0], self[1], self.linear)

    def at(self, t, h: float):
        """Its values at the step times ``t`` of step ``h`` (held over each step: a step starting within
        1e-12 h of a table's time counts as at it)."""
        ts, vs = self
        if self.linear:
            return np.interp(np.asarray(t, dtype=float), ts, vs)
        return vs[np.searchsorted(ts, np.asarray(t) + 1e-12 * h, side="right") - 1]


def _drive(drive, prm, source: str, where: str):
    """A signal's default drive: a value, or a table {t, value[, interpolation]} held from each t or linear."""
    if not isinstance(drive, dict):
        return _value({"value": drive}, "value", prm, source, where)
    t, v = drive.get("t"), drive.get("value")
    extra = set(drive) - {"t", "value", "interpolation"}
    if extra:
        raise _err(source, f"{where}.{sorted(extra)[0]}", unknown_name(sorted(extra)[0], ("t", "value", "interpolation")))
    interp = drive.get("interpolation", "hold")
    if interp not in ("hold", "linear"):
        raise _err(source, f"{where}.interpolation", f"\"hold\" (from each t) or \"linear\" (between the points), "
                                                     f"got {interp!r}")
    if not isinstance(t, (list, np.ndarray)) or not isinstance(v, (list, np.ndarray)) or len(t) != len(v) or not len(t):
        raise _err(source, where, "a table needs t = [...] and value = [...] of one length")
    ts = _plain(t)                     # (plain numbers, all finite: at once; else each, its error named)
    if ts is None:
        try:
            ts = np.array([to_si(x, "s") for x in t])
        except ValueError as exc:
            raise _err(source, f"{where}.t", str(exc)) from None
    if not valid_table_times(ts, interp == "linear"):
        raise _err(source, f"{where}.t", TABLE_TIMES)
    vs = _plain(v)
    if vs is None or prm.check(float(vs.min())) or prm.check(float(vs.max())):   # (a range: its ends tell)
        vs = np.array([_value({"value": x}, "value", prm, source, where) for x in v])
    return Drive(ts, vs, interp == "linear")


def _plain(values) -> np.ndarray | None:
    """A table's column as SI values at once when it is an array of finite numbers (a table made in memory: a
    paper scenario's sine per step, as_circuit), else None (a file's list: each entry read by to_si, the first
    bad one named)."""
    if not (isinstance(values, np.ndarray) and values.ndim == 1 and values.dtype.kind in "fi"):
        return None
    a = values.astype(float)
    return a if np.all(np.isfinite(a)) else None


TABLE_TIMES = ("times start at 0 and increase (a linear table may give a time twice: a jump there, the value "
               "after it from that instant)")


def valid_table_times(ts: np.ndarray, linear: bool) -> bool:
    """A table's times as a drive or a reference takes them: from 0, increasing; a linear one may repeat a time
    once (a jump: np.interp takes the later value from that instant)."""
    dt = np.diff(ts)
    return bool(ts[0] == 0.0 and np.all(dt >= 0 if linear else dt > 0)
                and not np.any((dt[:-1] == 0) & (dt[1:] == 0)))


def component_values(ctype: ComponentType, params: dict, fluid: dict) -> dict:
    """A component's parameters (SI) with the values derived from them (and the fluid's), checked together
    (:func:`cross_check`): what a circuit file gives, and what a parameter changed while running gives.
    ValueError saying what does not fit. (A parameter not given is NaN; the check may set it None.)"""
    params = {k: math.nan if v is None else v for k, v in params.items()}
    problem = cross_check(ctype, params)
    if problem:
        raise ValueError(problem)
    try:
        return {**params, **ctype.derive({**params, **fluid})}
    except (TypeError, ArithmeticError) as exc:         # (a catalogue partner not given: None)
        missing = [k for k, v in params.items() if v is None]
        raise ValueError(f"its derived values need {', '.join(missing) or 'other parameters'} given too "
                         f"({exc})") from None


def cross_check(ctype: ComponentType, v: dict) -> str | None:
    if ctype.name == "lugre_motor" and (v["fs_pos"] < v["fc_pos"] or v["fs_neg"] < v["fc_neg"]):
        return "a breakaway torque fs_* is at least its Coulomb torque fc_*"
    if ctype.name == "lugre_cylinder":
        areas, sizes = [v[k] == v[k] for k in ("area_a", "area_b")], [v[k] == v[k] for k in ("bore", "rod")]
        if not (all(areas) and not any(sizes)) and not (all(sizes) and not any(areas)):
            return "give bore and rod, or area_a and area_b (one pair)"
        if (v["bulk_b"] == v["bulk_b"]) != (v["bulk_c"] == v["bulk_c"]):
            return "eq 21 needs both bulk_b and bulk_c"
        if (v["beta_a"] == v["beta_a"]) != (v["beta_b"] == v["beta_b"]):
            return "constant chamber bulk moduli need both beta_a and beta_b"
        if v["bulk_b"] == v["bulk_b"] and v["beta_a"] == v["beta_a"]:
            return "give eq 21 (bulk_b, bulk_c) or constant beta_a, beta_b, not both"
        if v["fs_pos"] < v["fc_pos"] or v["fs_neg"] < v["fc_neg"]:
            return "a breakaway force fs_* is at least its Coulomb force fc_*"
        if all(sizes) and not v["rod"] < v["bore"]:
            return f"rod ({v['rod'] * 1e3:g} mm) must be thinner than bore ({v['bore'] * 1e3:g} mm)"
        if all(areas) and not v["area_b"] < v["area_a"]:
            return "area_b (the annulus) must be smaller than area_a"
        if not v["x0"] <= v["stroke"]:
            return f"x0 ({v['x0']:g} m) must be within the stroke ({v['stroke']:g} m)"
    if ctype.name in ("valve_43", "valve_63"):
        gradient, catalogue = v["area_gradient"] == v["area_gradient"], [v[k] == v[k] for k in ("rated_flow",
                                                                                                  "rated_drop")]
        if gradient == any(catalogue) or (any(catalogue) and not all(catalogue)):
            return "give area_gradient, or the catalogue's rated_flow at rated_drop (one of the two)"
    if ctype.name == "counterbalance_valve" and not v["check_rated_pressure"] > v["check_cracking"]:
        return "check_rated_pressure must be above check_cracking"
    if ctype.name in ("relief_valve", "check_valve") and not v["rated_pressure"] > v["cracking_pressure"]:
        return (f"rated_pressure ({v['rated_pressure'] / 1e5:g} bar) must be above cracking_pressure "
                f"({v['cracking_pressure'] / 1e5:g} bar)")
    if ctype.name in ("cylinder", "double_rod_cylinder"):
        if not v["rod"] < v["bore"]:
            return f"rod ({v['rod'] * 1e3:g} mm) must be thinner than bore ({v['bore'] * 1e3:g} mm)"
        if not v["x0"] <= v["stroke"]:
            return f"x0 ({v['x0']:g} m) must be within the stroke ({v['stroke']:g} m)"
    if ctype.name == "pump":
        cat = [v["volumetric_efficiency"], v["rated_speed"], v["rated_pressure"]]
        if any(not math.isnan(x) for x in cat) and any(math.isnan(x) for x in cat):
            return "the catalogue form needs volumetric_efficiency, rated_speed and rated_pressure together"
        if not math.isnan(v["volumetric_efficiency"]) and v["leakage"] != 0.0:
            return "give leakage or the catalogue's volumetric_efficiency, not both"
        if all(math.isnan(x) for x in cat):
            v["volumetric_efficiency"] = v["rated_speed"] = v["rated_pressure"] = None
    return None
