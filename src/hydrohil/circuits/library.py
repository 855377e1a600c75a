"""The component library (SPEC §12.3): each type declares its ports, parameters (SI unit, range, description,
default), modes and the signals a circuit may drive; its law is C (``core/components.h``), which
:meth:`ComponentType.emit` calls with the instance's parameter slots and port pressures. A circuit
(:mod:`hydrohil.circuits.circuit`) is a netlist of instances; :mod:`hydrohil.circuits.generate` writes its C.

The library: tank, pressure source, fixed-displacement pump, relief and check valves, orifice, gas-charged
accumulator, hose, a plain volume; the 4/3 and open-centre 6/3 valves by geometry, the paper's servo valve;
differential and double-rod cylinders (with their own load, or their rods coupled to a ``load``: a
mechanical coupling, ``rod_end``), the paper's LuGre cylinder; motors (their shafts coupled to a
``rotary_load`` or not; with LuGre friction too); the counterbalance valve. The paper's rig is the circuit its servo valve and LuGre cylinder make.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Param:
    unit: str                    # SI unit (hydrohil.circuits.units)
    lo: float
    hi: float
    description: str
    default: float | None = None  # None: required
    lo_strict: bool = False

    def text(self, component: str) -> str:
        """Its description for a component named ``component`` (NAME in it: the component's name)."""
        return self.description.replace("NAME", component)

    def check(self, v: float) -> str | None:
        """None, or what is wrong with ``v``."""
        if (v <= self.lo if self.lo_strict else v < self.lo) or v > self.hi:
            return f"must be {'>' if self.lo_strict else '>='} {self.lo:g} and <= {self.hi:g} {self.unit}"
        return None


@dataclass
class Emit:
    """What one instance adds to the generated right-hand side: its local values first (``pre``: (name, C
    expression), named ``c.v(name)``), flows (from port, to port, C expression[, conductance, rate]; a port
    None: the flow leaves or enters the circuit's nodes there, e.g. a piston's displacement; the conductance
    d(q)/d(p_from - p_to) >= 0 and the rate d(q)/dt with the pressures held, its states moving at ``c.dx(state)``:
    C expressions, None where they are 0, for the stiff-node treatment of hc_node.h; a rate (factor, speed):
    factor * speed, a node summing the factors of one speed first), capacitance [m³/Pa] and
    volume [m³] (C expressions) at a port's node, its states' derivatives (state -> C) and initial values
    (state -> C, may use the inputs u), the update of its mode after a step (C statements, may clamp its
    states), its states once the nodes settled at rest (``at_rest``: the bristles taking the load, SPEC §12.5),
    its outputs (name -> (C expression, SI unit)).


    The continuous reference generated from the same description (SPEC §6, §12.4) has no memory of modes: a
    mode that is a function of the state (``mode_of_state``, a C expression; the hybrid model's update is then
    that assignment after each step) is evaluated at every call of the right-hand side; a mode that clamps
    states (end stops, spool ends) is replaced by ``reference`` derivatives (state -> C) with stiff
    spring-dampers, its mode staying 0. A component may set its ports' nodes' bulk modulus (``bulk_modulus``:
    the paper's cylinder chambers follow eq 21); other nodes take the fluid's.

    A component whose modes switch at events declares them as data (``guards``: (name, C value >= 0 while its
    mode holds, +INFINITY where the guard does not apply, C statements of its transition)): the generated
    step locates the earliest crossing of all the circuit's guards inside the step and applies its transition
    there (SPEC §6, as the core's hybrid.c); its ``mode_update`` sets its mode at the start and in the rest
    march. ``mode_at_rest``: its mode once the nodes settled at rest (C expression; a piston against its stop
    pushed into it rests there, as the core's). ``bounds``: a state's physical range (state -> (lo, hi), C
    expressions of constants and the parameters' nominal values, ``c.nominal``; None: no bound on that side), far
    outside what any rig reaches: a state beyond it means the run has
    diverged, and it stops there with the time, the modes and the state, naming the state (generate.py:
    hc_unphysical; the paper's rig: the core's hh_diverged, whose bounds the paper's components declare)."""
    pre: list = field(default_factory=list)
    flows: list = field(default_factory=list)
    capacitance: list = field(default_factory=list)
    volume: list = field(default_factory=list)
    derivatives: dict = field(default_factory=dict)
    initial: dict = field(default_factory=dict)
    mode_update: str | None = None
    outputs: dict = field(default_factory=dict)
    mode_of_state: str | None = None
    reference: dict = field(default_factory=dict)
    bulk_modulus: list = field(default_factory=list)     # (port, C expression of its node's bulk modulus [Pa])
    guards: list = field(default_factory=list)           # (name, C value, C transition)
    at_rest: dict = field(default_factory=dict)          # state -> C: its value once the nodes settled at rest
    delays: list = field(default_factory=list)           # (input key, delay's parameter key): seen that late
    mode_at_rest: str | None = None
    bounds: dict = field(default_factory=dict)           # state -> (lo, hi) C (None: unbounded): its physical range
    # the parameters its mode_update's clamps read: one a fault drives (an input of the circuit) is applied at the
    # step's start too, so a clamp tightened between steps holds from then (a spool's speed limit set to 0: stuck
    # at once; a live panel's `set` changes the parameter itself: its clamp acts from the step's end)
    clamps: tuple = ()
    # its flows in the continuous reference where they differ (the same flows, in order, as (from, to, C flow)):
    # the paper's valve's narrow laminar region there (SPEC §6); None: ``flows``; and the outputs that log them
    # there (name -> C expression)
    reference_flows: list | None = None
    reference_outputs: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Coupling:
    """A mechanical coupling an actuator may have (SPEC §12.1): the key naming the load it drives, that load's
    type, the actuator's keys that are then its load's, and what couples (a rod, a shaft)."""
    key: str
    load_type: str
    load_keys: tuple[str, ...]
    part: str


@dataclass(frozen=True)
class ComponentType:
    name: str
    description: str
    ports: tuple[str, ...]
    params: dict[str, Param]
    modes: tuple[str, ...] = ()
    inputs: tuple[str, ...] = ()       # parameters a circuit may drive as signals instead
    fixes: str | None = None           # the parameter that fixes its port's pressure (tank, source)
    states: tuple[tuple[str, str], ...] = ()    # (name, SI unit) of its own states
    derived: tuple[tuple[str, str], ...] = ()   # (key, SI unit) of values derived from the parameters
    coupling: "Coupling | None" = None   # an optional mechanical coupling: its rod or shaft driving a load
    tables: dict = field(default_factory=dict)   # optional tables: name -> (x's SI unit, value's SI unit, what)

    def derive(self, v: dict[str, float]) -> dict[str, float]:
        return _DERIVE.get(self.name, lambda v: {})(v)

    def emit(self, c) -> Emit:
        """``c``: the generator's view of the instance: ``c.par(key)`` (a parameter or derived value's C, or the
        driving signal's), ``c.p(port)`` (the port's pressure), ``c.x(state)`` (its state's C lvalue),
        ``c.v(name)`` (its local value), ``c.mode`` (its mode's C lvalue), ``c.fluid(key)``."""
        return _EMIT[self.name](c)

    def port_volume(self, values: dict, port: str) -> float:
        """The volume [m³] it adds at a port's node at its initial state (validation, ``circuit show``)."""
        return _PORT_VOLUME.get(self.name, lambda v, port: 0.0)(values, port)


G = 9.80665          # m/s2


def _weight(v):
    """The load's weight along the rod [N], opposing extension when the rod points up (incline > 0)."""
    return v["mass"] * G * math.sin(math.radians(v["incline"]))


def _pump_derive(v):
    if v.get("volumetric_efficiency") is not None:
        leak = (1.0 - v["volumetric_efficiency"]) * v["displacement"] * v["rated_speed"] / v["rated_pressure"]
    else:
        leak = v.get("leakage") or 0.0
    return {"leakage_conductance": leak}


def _valve_k(v):
    return {"flow_gain": v["rated_flow"] / (v["rated_pressure"] - v["cracking_pressure"])}


def _orifice_derive(v):
    return {"flow_coefficient": v["discharge_coefficient"] * v["area"] * math.sqrt(2.0 / v["density"])}


_DERIVE = {"pump": _pump_derive, "relief_valve": _valve_k, "check_valve": _valve_k, "orifice": _orifice_derive,
           "accumulator": lambda v: {"min_gas_volume": v["gas_volume"] * v["min_gas_fraction"]},
           "hose": lambda v: {"volume": math.pi * v["diameter"] ** 2 * v["length"] / 4.0},
           "cylinder": lambda v: {"area_a": math.pi * v["bore"] ** 2 / 4.0,
                                  "area_b": math.pi * (v["bore"] ** 2 - v["rod"] ** 2) / 4.0,
                                  "weight": _weight(v)},
           "double_rod_cylinder": lambda v: {"area_a": math.pi * (v["bore"] ** 2 - v["rod"] ** 2) / 4.0,
                                             "area_b": math.pi * (v["bore"] ** 2 - v["rod"] ** 2) / 4.0,
                                             "weight": _weight(v)},
           "load": lambda v: {"weight": _weight(v)},
           "valve_43": lambda v: {"flow_gain": v["discharge_coefficient"] * v["area_gradient"]
                                  * math.sqrt(2.0 / v["density"]) if v["area_gradient"] == v["area_gradient"]
                                  else v["rated_flow"] / (v["x_max"] * math.sqrt(v["rated_drop"]))},
           "counterbalance_valve": lambda v: {"check_gain": v["check_rated_flow"] / (v["check_rated_pressure"]
                                                                                     - v["check_cracking"]),
                                              "relief_coefficient": v["rated_flow"] / math.sqrt(v["rated_drop"])}}
_DERIVE["valve_63"] = _DERIVE["valve_43"]


def _lugre_cylinder_derive(v):
    given = v["area_a"] == v["area_a"]                  # areas given (not NaN), else from bore and rod
    a1 = v["area_a"] if given else math.pi * v["bore"] ** 2 / 4.0
    a2 = v["area_b"] if given else math.pi * (v["bore"] ** 2 - v["rod"] ** 2) / 4.0
    return {"area_a": a1, "area_b": a2,
            "weight": v["mass"] * v["gravity"] * math.sin(math.radians(v["incline"]))}


_DERIVE["lugre_cylinder"] = _lugre_cylinder_derive


def _emit_tank(c):
    return Emit()                 # (its pressure is its node's column)


def _emit_pump(c):
    q = f"hc_pump_flow({c.par('displacement')}, {c.par('speed')}, {c.par('leakage_conductance')}, " \
        f"{c.p('inlet')}, {c.p('outlet')})"
    return Emit(flows=[("inlet", "outlet", q, c.par("leakage_conductance"))], outputs={"q": (q, "m3/s")})


def _emit_valve(c, a, b):
    dp = f"({c.p(a)} - {c.p(b)})"
    q = f"hc_relief_flow((int){c.mode}, {c.par('flow_gain')}, {c.par('cracking_pressure')}, {dp})"
    return Emit(flows=[(a, b, q, f"({c.mode} == HC_OPEN ? {c.par('flow_gain')} : 0.0)")], outputs={"q": (q, "m3/s")},
                mode_of_state=f"hc_relief_mode((int){c.mode}, {c.par('cracking_pressure')}, {dp})")


def _emit_orifice(c):
    args = f"{c.par('flow_coefficient')} * {c.par('opening')}, {c.p('a')} - {c.p('b')}, {c.par('transition_pressure')}"
    q = f"hc_sqrt_law({args})"
    return Emit(flows=[("a", "b", q, f"hc_sqrt_law_slope({args})")], outputs={"q": (q, "m3/s")})


def _emit_accumulator(c):
    args = f"{c.par('gas_volume')}, {c.par('precharge')}, {c.par('exponent')}"
    return Emit(capacitance=[("p", f"hc_acc_capacitance((int){c.mode}, {args}, {c.p('p')})")],
                mode_of_state=f"hc_acc_mode({args}, {c.par('min_gas_volume')}, {c.p('p')})",
                outputs={"v_oil": (f"hc_acc_oil_volume({args}, {c.p('p')})", "m3")})


def _emit_hose(c):
    args = f"{c.par('diameter')}, {c.par('length')}, {c.fluid('density')}, {c.fluid('viscosity')}, " \
           f"{c.p('a')} - {c.p('b')}"
    q = f"hc_hose_flow({args})"
    half = f"0.5 * {c.par('volume')}"
    return Emit(flows=[("a", "b", q, f"hc_hose_slope({args})")], volume=[("a", half), ("b", half)],
                outputs={"q": (q, "m3/s")})


def _emit_volume(c):
    return Emit(volume=[("p", c.par("volume"))])


def _motor_torque(c) -> str:
    """A motor's torque on its shaft [N.m]: eta*D*dp/(2 pi) (SPEC §12.3)."""
    return f"hc_motor_torque({c.par('displacement')}, {c.par('efficiency')}, ({c.p('a')} - {c.p('b')}))"


def _net_torque(c, drive: str) -> str:
    """The net torque on a shaft [N.m]: its ``drive`` (the motors' torque) less viscous friction and the load
    torque (J w' = it: a motor with its own inertia, or a rotary load)."""
    return f"({drive} - {c.par('damping')} * {c.x('w')} - {c.par('load_torque')})"


def _emit_motor(c):
    dp = f"({c.p('a')} - {c.p('b')})"
    q = f"hc_motor_flow({c.par('displacement')}, {c.x('w')}, {c.par('leakage')}, {dp})"
    torque = _motor_torque(c)
    e = Emit(pre=[("torque", torque)],
             flows=[("a", "b", q, c.par("leakage"), f"hc_motor_flow({c.par('displacement')}, {c.dx('w')}, 0.0, 0.0)")],
             outputs={"w": (c.x("w"), "rad/s"), "q": (q, "m3/s"), "torque": (torque, "N.m")})
    if not c.comp.coupled:       # its own inertia (coupled: its shaft's load turns it, shaft)
        e.derivatives = {"w": f"{_net_torque(c, c.v('torque'))} / {c.par('inertia')}"}
        e.initial = {"w": c.par("speed0")}
        e.bounds = _SHAFT
    return e


def _emit_rotary_load(c):
    """A rotary load driven by the motors coupled to it (their shaft): one inertia, their torques summed."""
    net = _net_torque(c, " + ".join(f"({_motor_torque(a)})" for a in c.coupled_views()))
    return Emit(pre=[("t", net)], derivatives={"w": f"{c.v('t')} / {c.par('inertia')}"},
                initial={"w": c.par("speed0")}, bounds=_SHAFT,
                outputs={"w": (c.x("w"), "rad/s"), "net_torque": (net, "N.m")})


def _piston_force(c) -> str:
    """The chambers' force on a cylinder's piston [N], + extending (SPEC §12.3)."""
    return f"{c.p('a')} * {c.par('area_a')} - {c.p('b')} * {c.par('area_b')}"


SPEED_BOUND = 100.0          # [m/s] a piston's or a load's: far beyond any hydraulic drive (the core's hh_diverged)
SPOOL_BOUND = 10.0           # a spool's position in its own travels (normalised ±1, or x_max): the core's
SHAFT_BOUND = 1e5            # [rad/s] a shaft's speed (955 000 rpm; a shaft may start at up to 1e4)
_SHAFT = {"w": (f"-{SHAFT_BOUND!r}", f"{SHAFT_BOUND!r}")}


def _travel_bounds(stroke: str) -> dict:
    """A piston's physical range (the core's hh_diverged): within a stroke (``stroke``: its nominal value's C,
    _View.nominal) beyond either end, and slower than SPEED_BOUND."""
    return {"x": (f"-({stroke})", f"2.0 * ({stroke})"), "v": (f"-{SPEED_BOUND!r}", f"{SPEED_BOUND!r}")}


def _motion(c, force: str, stroke: str, nominal_stroke: str) -> Emit:
    """A rigid body moving along a rod between end stops (a cylinder with its own load, or a load driven by the
    cylinders coupled to it): x' = v, M v' = F (net ``force``), plastic end stops at 0 and ``stroke`` as modes
    with their guards (hc_stop_*), the reference's stops stiff spring-dampers."""
    x, v = c.x("x"), c.x("v")
    guards = [(name, f"hc_stop_guard({g}, (int){c.mode}, {x}, {force}, {stroke})",
               f"{c.mode} = hc_stop_reset({g}, &{x}, &{v}, {stroke});")
              for name, g in (("retract", "HC_STOP_G_RETRACT"), ("extend", "HC_STOP_G_EXTEND"),
                              ("leave", "HC_STOP_G_LEAVE"))]
    return Emit(pre=[("f", force)], guards=guards,
                derivatives={"x": f"hc_stop_speed((int){c.mode}, {v})",
                             "v": f"hc_stop_accel((int){c.mode}, {c.v('f')}, {c.par('mass')})"},
                initial={"x": c.par("x0"), "v": "0.0"},
                mode_update=f"{c.mode} = hc_stop_mode((int){c.mode}, &{x}, &{v}, {stroke}, {force});",
                outputs={"x": (x, "m"), "v": (v, "m/s"), "net_force": (force, "N")},
                bounds=_travel_bounds(nominal_stroke),
                reference={"x": v, "v": f"({c.v('f')} + hc_stop_penalty({x}, {v}, {stroke}, "
                                        f"{c.par('mass')})) / {c.par('mass')}"})


def _load_forces(c) -> str:
    """The forces of a load on the rod [N], + opposing extension: viscous friction, the external force, the
    spring, the weight and its force table over the position (a load's ``force_table``)."""
    x, v = c.x("x"), c.x("v")
    table = c.table("force_table")
    return (f"{c.par('damping')} * {v} + {c.par('force')} + {c.par('spring')} * ({x} - {c.par('spring_x0')}) + "
            f"{c.par('weight')}" + (f" + hc_table({x}, {table})" if table else ""))


def _chambers(c) -> Emit:
    """A cylinder's chambers: the piston's displacement flows and the chambers' volumes at its position."""
    x, v = c.x("x"), c.x("v")
    return Emit(flows=[("a", None, f"{c.par('area_a')} * {v}", None, f"{c.par('area_a')} * {c.dx('v')}"),
                       (None, "b", f"{c.par('area_b')} * {v}", None, f"{c.par('area_b')} * {c.dx('v')}")],
                volume=[("a", f"({c.par('dead_volume_a')} + {c.par('area_a')} * {x})"),
                        ("b", f"({c.par('dead_volume_b')} + {c.par('area_b')} * ({c.par('stroke')} - {x}))")])


def _emit_cylinder(c):
    e = _chambers(c)
    if c.comp.coupled:           # its rod drives a load (rod_end): the load's motion is its piston's
        e.outputs = {"x": (c.x("x"), "m"), "v": (c.x("v"), "m/s"), "piston_force": (_piston_force(c), "N")}
        return e
    m = _motion(c, f"{_piston_force(c)} - ({_load_forces(c)})", c.par("stroke"), c.nominal("stroke"))
    m.flows, m.volume = e.flows, e.volume
    return m


def _emit_load(c):
    """A load driven by the cylinders coupled to it (their rod_end): one rigid body, their pistons' forces
    summed, its travel the shortest of their strokes (SPEC §12.3: a mechanical coupling)."""
    actuators = c.coupled_views()
    drive = " + ".join(f"({_piston_force(a)})" for a in actuators)
    stroke, nominal = actuators[0].par("stroke"), actuators[0].nominal("stroke")
    for a in actuators[1:]:
        stroke, nominal = f"fmin({stroke}, {a.par('stroke')})", f"fmin({nominal}, {a.nominal('stroke')})"
    return _motion(c, f"{drive} - ({_load_forces(c)})", stroke, nominal)


def _emit_counterbalance(c):
    pv, pl, px = c.p("valve"), c.p("load"), c.p("pilot")
    args = f"{c.par('check_cracking')}, {c.par('set_pressure')}, {c.par('pilot_ratio')}"
    q = (f"hc_cb_flow((int){c.mode}, {c.par('check_gain')}, {c.par('check_cracking')}, "
         f"{c.par('relief_coefficient')}, {c.par('set_pressure')}, {c.par('pilot_ratio')}, {c.par('rated_excess')}, "
         f"{c.par('transition_pressure')}, {pv}, {pl}, {px})")
    opening = f"hc_cb_opening({c.par('set_pressure')}, {c.par('pilot_ratio')}, {c.par('rated_excess')}, {pv}, {pl}, {px})"
    slope = (f"hc_cb_slope((int){c.mode}, {c.par('check_gain')}, {c.par('relief_coefficient')}, "
             f"{c.par('set_pressure')}, {c.par('pilot_ratio')}, {c.par('rated_excess')}, "
             f"{c.par('transition_pressure')}, {pv}, {pl}, {px})")
    return Emit(flows=[("valve", "load", q, slope)], outputs={"q": (q, "m3/s"), "opening": (opening, "-")},
                mode_of_state=f"hc_cb_mode({args}, {pv}, {pl}, {px})")


def _emit_valve43(c):
    x, v = c.x("x"), c.x("v")
    k = f"{c.par('flow_gain')}"
    leak, dpt = c.par("leakage_opening"), c.par("transition_pressure")
    P, T, A, B = (c.p(n) for n in ("P", "T", "A", "B"))

    def edge(sign, lap, a, b):
        return f"hc_sqrt_law({k} * hc_edge_opening({sign}{x}, {c.par(lap)}, {leak}), {a} - {b}, {dpt})"

    def edge_flow(sign, lap, a, b):               # (its ports, flow, conductance, rate with the pressures held)
        opening = f"hc_edge_opening({sign}{x}, {c.par(lap)}, {leak})"
        rate = f"hc_edge_opening_rate({sign}1, {x}, {c.par(lap)}, {c.dx('x')})"
        return (a, b, edge(sign, lap, c.p(a), c.p(b)), f"hc_sqrt_law_slope({k} * {opening}, {c.p(a)} - {c.p(b)}, {dpt})",
                f"hc_sqrt_law({k} * {rate}, {c.p(a)} - {c.p(b)}, {dpt})")
    qs = {"PA": edge("", "lap_pa", P, A), "AT": edge("-", "lap_at", A, T), "PB": edge("-", "lap_pb", P, B),
          "BT": edge("", "lap_bt", B, T)}
    flows = [edge_flow("", "lap_pa", "P", "A"), edge_flow("-", "lap_at", "A", "T"), edge_flow("-", "lap_pb", "P", "B"),
             edge_flow("", "lap_bt", "B", "T")]
    if "centre_travel" in c.comp.type.params:      # the open centre of a 6/3 valve: P -> T around x = 0
        xc = c.par("centre_travel")
        qs["PT"] = f"hc_sqrt_law({k} * hc_centre_opening({x}, {xc}), {P} - {T}, {dpt})"
        flows.append(("P", "T", qs["PT"], f"hc_sqrt_law_slope({k} * hc_centre_opening({x}, {xc}), {P} - {T}, {dpt})",
                      f"hc_sqrt_law({k} * hc_centre_opening_rate({x}, {xc}, {c.dx('x')}), {P} - {T}, {dpt})"))
    return Emit(flows=flows,
                derivatives={"x": v, "v": f"hc_spool_accel({x}, {v}, {c.par('command')} * {c.par('x_max')}, "
                                          f"{c.par('wn')}, {c.par('xi')})"},
                initial={"x": f"{c.par('command')} * {c.par('x_max')}", "v": "0.0"},
                mode_update=f"hc_spool_clamp(&{x}, &{v}, {c.par('x_max')});",
                reference={"v": f"hc_spool_accel({x}, {v}, {c.par('command')} * {c.par('x_max')}, {c.par('wn')}, "
                                f"{c.par('xi')}) + hc_spool_penalty({x}, {v}, {c.par('x_max')}, {c.par('wn')})"},
                outputs={"x": (x, "m"), **{f"q_{e.lower()}": (q, "m3/s") for e, q in qs.items()}},
                bounds={"x": (f"-{SPOOL_BOUND!r} * {c.nominal('x_max')}", f"{SPOOL_BOUND!r} * {c.nominal('x_max')}")})


def _emit_servo_valve(c):
    """The paper's servo-solenoid valve (SPEC §3): pseudo-sections of eq 3 per edge, the limited spool."""
    x, v = c.x("x"), c.x("v")
    k = ", ".join(c.par(f"k{i}") for i in range(1, 6))
    kt = ", ".join(c.par(f"kt{i}") for i in range(1, 6))
    dpt, dpr = c.par("dp_laminar"), c.par("reference_dp_laminar")
    xc = f"hh_clamp({x}, -1.0, 1.0)"
    spool = f"{c.par('wn')}, {c.par('xi')}, {c.par('la')}, {c.par('lv')}"
    wear = c.par("wear")

    def section(sign, coeffs, burst=None):        # (eq 3's section, plus the worn lands' leakage section; an edge
        s = f"(hc_section{'_neg' if sign else ''}({xc}, {coeffs}) + {wear})"      # to tank, plus its line's burst hose: the core's)
        return f"({s} + {c.par(burst)})" if burst else s

    def edge(sign, coeffs, a, b, s=None, burst=None, laminar=dpt):
        return f"hc_sqrt_law({s or section(sign, coeffs, burst)} * HH_LPM_PER_SQRT_BAR, {a} - {b}, {laminar})"

    def edge_flow(name, sign, coeffs, a, b):      # (its ports, flow, conductance, rate with the pressures held)
        dp, s = f"{c.p(a)} - {c.p(b)}", c.v(name)     # (its section once per right-hand side: flow and conductance)
        return (a, b, edge(sign, coeffs, c.p(a), c.p(b), s), f"hc_sqrt_law_slope({s} * HH_LPM_PER_SQRT_BAR, {dp}, {dpt})",
                (f"hc_servo_edge_slope({sign}1, {x}, {coeffs}, {dp}, {dpt})", c.dx("x")))
    u = c.par("command")
    # its four edges: (section's local, the section's sign, coefficients, from port, to port, a burst line's key)
    edges = (("s_pa", "-", k, "P", "A", None), ("s_at", "", kt, "A", "T", "burst_a"), ("s_pb", "", k, "P", "B", None),
             ("s_bt", "-", kt, "B", "T", "burst_b"))
    qs = {a + b: edge(sign, co, c.p(a), c.p(b), burst=burst) for _, sign, co, a, b, burst in edges}
    return Emit(pre=[(name, section(sign, co, burst)) for name, sign, co, _, _, burst in edges],
                flows=[edge_flow(*e[:5]) for e in edges],
                reference_flows=[(a, b, edge(sign, co, c.p(a), c.p(b), c.v(name), laminar=dpr))
                                 for name, sign, co, a, b, _ in edges],
                reference_outputs={f"q_{(a + b).lower()}": edge(sign, co, c.p(a), c.p(b), burst=burst, laminar=dpr)
                                   for _, sign, co, a, b, burst in edges},
                delays=[("command", "delay")],
                derivatives={"x": f"hc_servo_spool_speed({x}, {v})",
                             "v": f"hc_servo_spool_accel({x}, {v}, {u}, {spool})"},
                initial={"x": f"hh_clamp({u}, -1.0, 1.0)", "v": "0.0"},
                mode_update=f"hc_spool_project(&{x}, &{v}, {c.par('lv')}); "
                            f"{c.mode} = hc_spool_region({x}, {v}, {u}, {spool});", clamps=("lv",),
                reference={"x": v, "v": f"hc_servo_spool_accel_free({x}, {v}, {u}, {spool})"},
                outputs={"x": (x, "-"), **{f"q_{e.lower()}": (q, "m3/s") for e, q in qs.items()}},
                bounds={"x": (f"-{SPOOL_BOUND!r}", f"{SPOOL_BOUND!r}")})


def _emit_lugre_cylinder(c):
    """The paper's differential cylinder (SPEC §4-§6): eq 21 chambers, leakage, LuGre friction, end stops."""
    x, v, z = c.x("x"), c.x("v"), c.x("z")
    fr = ", ".join(c.par(k) for k in ("sigma0", "sigma1", "fc_pos", "fs_pos", "vs_pos", "kv_pos", "fc_neg",
                                      "fs_neg", "vs_neg", "kv_neg"))
    static = ", ".join(c.par(k) for k in ("fc_pos", "fs_pos", "vs_pos", "fc_neg", "fs_neg", "vs_neg"))
    a1, a2, stroke = c.par("area_a"), c.par("area_b"), c.par("stroke")
    free = f"({c.mode} < HC_LC_AT_RETRACT)"
    f_ext = f"{c.p('a')} * {a1} - {c.p('b')} * {a2} - {c.par('force')} - {c.par('weight')}"
    vp = f"({free} ? {v} : 0.0)"
    ff = f"hc_lc_friction((int){c.mode}, {v}, {z}, {fr})"
    xin = f"hc_in_stroke({x}, {stroke})"
    kv = f"({v} >= 0.0 ? {c.par('kv_pos')} : {c.par('kv_neg')})"
    g = f"hc_stribeck({v}, {static})"
    fs = f"{c.par('fs_pos')}, {c.par('fs_neg')}"
    guards = [(name, f"hc_lc_guard({gid}, (int){c.mode}, {x}, {v}, {z}, {f_ext}, {stroke}, {c.par('sigma0')}, {fs})",
               f"{c.mode} = hc_lc_reset({gid}, (int){c.mode}, &{x}, &{v}, &{z}, {stroke}, {c.par('sigma0')}, "
               f"{static});") for name, gid in _LUGRE_GUARDS]
    e = Emit(pre=[("f", f_ext), ("vp", vp)], guards=guards,
             at_rest={"z": f"hc_lc_held_z((int){c.mode}, {f_ext}, {z}, {c.par('sigma0')}, {fs})"},
             mode_at_rest=f"hc_lc_rest_mode((int){c.mode}, &{x}, &{v}, {f_ext}, {stroke})",
             flows=[("a", None, f"{a1} * {c.v('vp')}", None, f"{a1} * {c.dx('v')}"),
                    (None, "b", f"{a2} * {c.v('vp')}", None, f"{a2} * {c.dx('v')}"),
                    ("a", "b", f"{c.par('leakage')} * ({c.p('a')} - {c.p('b')})", c.par("leakage"))],
             volume=[("a", f"({c.par('dead_volume_a')} + {a1} * {xin})"),
                     ("b", f"({c.par('dead_volume_b')} + {a2} * ({stroke} - {xin}))")],
             derivatives={"x": c.v("vp"),
                          "v": f"({free} ? ({c.v('f')} - {ff}) / {c.par('mass')} : 0.0)",
                          "z": f"({c.mode} == HC_LC_STICK ? {v} : 0.0)"},
             initial={"x": c.par("x0"), "v": "0.0", "z": "0.0"},
             mode_update=f"{c.mode} = hc_lc_mode((int){c.mode}, &{x}, &{v}, &{z}, {f_ext}, {stroke}, "
                         f"{c.par('sigma0')}, {static});",
             reference={"x": v, "z": f"{v} - {c.par('sigma0')} * fabs({v}) * {z} / {g}",
                        "v": f"({c.v('f')} - ({c.par('sigma0')} * {z} + {c.par('sigma1')} * ({v} - "
                             f"{c.par('sigma0')} * fabs({v}) * {z} / {g}) + {kv} * {v}) + "
                             f"hc_stop_force({x}, {v}, {stroke}, {c.par('stop_stiffness')}, "
                             f"{c.par('stop_damping')})) / {c.par('mass')}"},
             outputs={"x": (x, "m"), "v": (v, "m/s"), "applied_force": (f_ext, "N"), "friction": (ff, "N")},
             bounds=_travel_bounds(c.nominal("stroke")))
    val = c.comp.values
    if val["bulk_b"] == val["bulk_b"]:                                     # eq 21 given (not NaN)
        e.bulk_modulus = [(port, f"hc_bulk_modulus({c.p(port)}, {c.par('bulk_b')}, {c.par('bulk_c')})")
                          for port in ("a", "b")]
    elif val["beta_a"] == val["beta_a"]:                                  # a constant per chamber
        e.bulk_modulus = [("a", c.par("beta_a")), ("b", c.par("beta_b"))]
    return e


_FRICTION_GUARDS = (("breakaway_pos", "HC_LC_G_BREAK_POS"), ("breakaway_neg", "HC_LC_G_BREAK_NEG"),
                    ("reverse", "HC_LC_G_REVERSE"))                # (a rotary motion's too: lugre_motor)
_LUGRE_GUARDS = (("retract", "HC_LC_G_RETRACT"), ("extend", "HC_LC_G_EXTEND"), *_FRICTION_GUARDS,
                 ("leave", "HC_LC_G_LEAVE"))


def _emit_lugre_motor(c):
    """A hydraulic motor with LuGre friction (SPEC §12.3: the Stribeck form of eq 25 with stick and slip)."""
    w, z = c.x("w"), c.x("z")
    dp = f"({c.p('a')} - {c.p('b')})"
    fr = ", ".join(c.par(k) for k in ("sigma0", "sigma1", "fc_pos", "fs_pos", "vs_pos", "kv_pos", "fc_neg",
                                      "fs_neg", "vs_neg", "kv_neg"))
    static = ", ".join(c.par(k) for k in ("fc_pos", "fs_pos", "vs_pos", "fc_neg", "fs_neg", "vs_neg"))
    torque = f"hc_motor_torque({c.par('displacement')}, {c.par('efficiency')}, {dp})"
    drive = _net_torque(c, torque)                                    # the net torque but the seals' friction
    ff = f"hc_lc_friction((int){c.mode}, {w}, {z}, {fr})"
    q = f"hc_motor_flow({c.par('displacement')}, {w}, {c.par('leakage')}, {dp})"
    g = f"hc_stribeck({w}, {static})"
    kv = f"({w} >= 0.0 ? {c.par('kv_pos')} : {c.par('kv_neg')})"
    dz = f"({w} - {c.par('sigma0')} * fabs({w}) * {z} / {g})"
    fs = f"{c.par('fs_pos')}, {c.par('fs_neg')}"
    guards = [(name, f"hc_lc_guard({gid}, (int){c.mode}, 0.0, {w}, {z}, 0.0, INFINITY, {c.par('sigma0')}, {fs})",
               f"{c.mode} = hc_lc_friction_reset({gid}, (int){c.mode}, &{w}, &{z}, {c.par('sigma0')}, {fs});")
              for name, gid in _FRICTION_GUARDS]
    return Emit(pre=[("drive", drive)], guards=guards,
                flows=[("a", "b", q, c.par("leakage"), f"hc_motor_flow({c.par('displacement')}, {c.dx('w')}, 0.0, 0.0)")],
                at_rest={"z": f"({w} == 0.0 ? hc_lc_held_z((int){c.mode}, {drive}, {z}, {c.par('sigma0')}, {fs}) "
                              f": {z})"},
                derivatives={"w": f"({c.v('drive')} - {ff}) / {c.par('inertia')}",
                             "z": f"({c.mode} == HC_LC_STICK ? {w} : 0.0)"},
                initial={"w": c.par("speed0"), "z": "0.0"},
                mode_update=f"{c.mode} = hc_lc_friction_mode((int){c.mode}, &{w}, &{z}, {c.par('sigma0')}, {fs});",
                reference={"z": dz, "w": f"({c.v('drive')} - ({c.par('sigma0')} * {z} + {c.par('sigma1')} * {dz} + "
                                         f"{kv} * {w})) / {c.par('inertia')}"},
                outputs={"w": (w, "rad/s"), "q": (q, "m3/s"), "torque": (torque, "N.m"), "friction": (ff, "N.m")},
                bounds=_SHAFT)


_EMIT = {"tank": _emit_tank, "pressure_source": _emit_tank, "pump": _emit_pump,
         "relief_valve": lambda c: _emit_valve(c, "p", "t"), "check_valve": lambda c: _emit_valve(c, "a", "b"),
         "orifice": _emit_orifice, "accumulator": _emit_accumulator, "hose": _emit_hose, "volume": _emit_volume,
         "motor": _emit_motor, "cylinder": _emit_cylinder, "double_rod_cylinder": _emit_cylinder, "load": _emit_load,
         "rotary_load": _emit_rotary_load,
         "valve_43": _emit_valve43, "valve_63": _emit_valve43, "counterbalance_valve": _emit_counterbalance,
         "servo_valve": _emit_servo_valve, "lugre_cylinder": _emit_lugre_cylinder, "lugre_motor": _emit_lugre_motor}
_PORT_VOLUME = {"hose": lambda v, port: 0.5 * v["volume"], "volume": lambda v, port: v["volume"],
                "cylinder": lambda v, port: (v["dead_volume_a"] + v["area_a"] * v["x0"] if port == "a" else
                                             v["dead_volume_b"] + v["area_b"] * (v["stroke"] - v["x0"]))}
_PORT_VOLUME["double_rod_cylinder"] = _PORT_VOLUME["cylinder"]
_PORT_VOLUME["lugre_cylinder"] = _PORT_VOLUME["cylinder"]

def _cylinder_params(rod: str) -> dict[str, Param]:
    """A linear actuator's parameters with its load (both cylinder types; ``rod``: the rod's description)."""
    return {"bore": Param("m", 0.0, 2.0, "piston diameter", lo_strict=True),
            "rod": Param("m", 0.0, 2.0, rod, lo_strict=True),
            "stroke": Param("m", 0.0, 20.0, "stroke", lo_strict=True),
            "dead_volume_a": Param("m3", 0.0, 1.0, "cap-side volume at x = 0 (ports, hose)", 5e-5,
                                   lo_strict=True),
            "dead_volume_b": Param("m3", 0.0, 1.0, "rod-side volume at full stroke", 5e-5, lo_strict=True),
            "mass": Param("kg", 0.0, 1e6, "moved mass", lo_strict=True),
            "damping": Param("N.s/m", 0.0, 1e8, "viscous friction", 0.0),
            "force": Param("N", -1e8, 1e8, "external force, + opposes extension (or the signal)", 0.0),
            "spring": Param("N/m", 0.0, 1e10, "spring on the rod, k*(x - spring_x0) opposes extension", 0.0),
            "spring_x0": Param("m", -20.0, 20.0, "position where the spring is relaxed", 0.0),
            "incline": Param("deg", -90.0, 90.0, "rod's angle above the horizontal (90: up, the weight "
                             "opposes extension)", 0.0),
            "x0": Param("m", 0.0, 20.0, "initial position", 0.0)}


def _valve_params(extra: dict | None = None) -> dict[str, Param]:
    """A proportional valve's parameters by geometry (the 4/3 valve; ``extra``: an open centre's, before the
    spool's dynamics)."""
    return {"command": Param("-", -1.0, 1.0, "spool command u (or the signal NAME.command)", 0.0),
            "x_max": Param("m", 0.0, 0.05, "spool stroke", lo_strict=True),
            "area_gradient": Param("m", 0.0, 1.0, "opening per spool travel, w = pi*d*fraction (or the catalogue's "
                                   "rated_flow at rated_drop)", math.nan, lo_strict=True),
            "rated_flow": Param("m3/s", 0.0, 1.0, "catalogue: flow through one edge fully open (x_max) at rated_drop "
                                "(in place of area_gradient)", math.nan, lo_strict=True),
            "rated_drop": Param("Pa", 0.0, 1e9, "catalogue: the pressure drop per edge of rated_flow (often 5, 10 or "
                                "35 bar)", math.nan, lo_strict=True),
            "discharge_coefficient": Param("-", 0.0, 1.0, "Cq", 0.67, lo_strict=True),
            "lap_pa": Param("m", -0.01, 0.01, "overlap of P->A (< 0: underlap)", 0.0),
            "lap_at": Param("m", -0.01, 0.01, "overlap of A->T", 0.0),
            "lap_pb": Param("m", -0.01, 0.01, "overlap of P->B", 0.0),
            "lap_bt": Param("m", -0.01, 0.01, "overlap of B->T", 0.0),
            "leakage_opening": Param("m", 0.0, 0.001, "opening of a closed edge (its leakage)", 1e-7),
            "transition_pressure": Param("Pa", 0.0, 1e7, "laminar transition", 1e5, lo_strict=True),
            **(extra or {}),
            "wn": Param("rad/s", 0.0, 1e5, "spool natural frequency", lo_strict=True),
            "xi": Param("-", 0.0, 10.0, "spool damping ratio", 0.7, lo_strict=True)}


_STOPS = ("free", "at_retract", "at_extend")
# a cylinder's keys that belong to its load: given on the load when its rod is coupled to one (rod_end); a
# motor's that belong to its shaft's load (shaft)
ROD = Coupling("rod_end", "load", ("mass", "damping", "force", "spring", "spring_x0", "incline", "x0"), "rod")
SHAFT = Coupling("shaft", "rotary_load", ("inertia", "damping", "load_torque", "speed0"), "shaft")
_PISTON = (("x", "m"), ("v", "m/s"))
_CYLINDER_DERIVED = (("area_a", "m2"), ("area_b", "m2"), ("weight", "N"))

_P = 1e9      # Pa: the ranges' upper bound for pressures (10 000 bar)
TYPES: dict[str, ComponentType] = {t.name: t for t in (
    ComponentType("tank", "reservoir at a fixed pressure", ("p",),
                  {"pressure": Param("Pa", -1e5, _P, "tank pressure (gauge)", 0.0)}, fixes="pressure"),
    ComponentType("pressure_source", "ideal pressure source (an ideal supply, a pilot line)", ("p",),
                  {"pressure": Param("Pa", -1e5, _P, "pressure (gauge), or the signal NAME.pressure")},
                  fixes="pressure", inputs=("pressure",)),
    ComponentType("pump", "fixed-displacement pump: q = D*n - Cl*(p_out - p_in)", ("inlet", "outlet"),
                  {"displacement": Param("m3/rev", 0.0, 1e-2, "displacement per revolution", lo_strict=True),
                   "speed": Param("rev/s", 0.0, 1e3, "shaft speed (or the signal pump.speed)"),
                   "leakage": Param("m3/(s.Pa)", 0.0, 1e-6, "leakage conductance Cl", 0.0),
                   "volumetric_efficiency": Param("-", 0.0, 1.0, "catalogue: eta_v at rated speed and pressure "
                                                  "(gives Cl)", math.nan, lo_strict=True),
                   "rated_speed": Param("rev/s", 0.0, 1e3, "catalogue: rated speed", math.nan, lo_strict=True),
                   "rated_pressure": Param("Pa", 0.0, _P, "catalogue: rated pressure", math.nan, lo_strict=True)},
                  inputs=("speed",), derived=(("leakage_conductance", "m3/(s.Pa)"),)),
    ComponentType("relief_valve", "direct-operated relief valve: closed below p_cr, q = K*(dp - p_cr) above",
                  ("p", "t"),
                  {"cracking_pressure": Param("Pa", 0.0, _P, "cracking pressure p_cr", lo_strict=True),
                   "rated_flow": Param("m3/s", 0.0, 1.0, "rated flow Q_r", lo_strict=True),
                   "rated_pressure": Param("Pa", 0.0, _P, "pressure at the rated flow (> p_cr)", lo_strict=True)},
                  modes=("closed", "open"), derived=(("flow_gain", "m3/(s.Pa)"),)),
    ComponentType("check_valve", "check valve: flow a -> b once dp > the cracking pressure", ("a", "b"),
                  {"cracking_pressure": Param("Pa", 0.0, _P, "cracking pressure difference", lo_strict=True),
                   "rated_flow": Param("m3/s", 0.0, 1.0, "rated flow", lo_strict=True),
                   "rated_pressure": Param("Pa", 0.0, _P, "pressure difference at the rated flow",
                                           lo_strict=True)},
                  modes=("closed", "open"), derived=(("flow_gain", "m3/(s.Pa)"),)),
    ComponentType("orifice", "sharp-edged orifice: q = Cd*A*sqrt(2|dp|/rho), laminar near dp = 0", ("a", "b"),
                  {"area": Param("m2", 0.0, 1.0, "area", lo_strict=True),
                   "discharge_coefficient": Param("-", 0.0, 1.0, "Cd", 0.61, lo_strict=True),
                   "transition_pressure": Param("Pa", 0.0, 1e7, "pressure difference of the laminar transition",
                                                1e5, lo_strict=True),
                   "opening": Param("-", 0.0, 1.0, "fraction of the area open (or the signal NAME.opening)", 1.0)},
                  inputs=("opening",), derived=(("flow_coefficient", "m3/s/sqrt(Pa)"),)),
    ComponentType("accumulator", "gas-charged accumulator, polytropic gas", ("p",),
                  {"gas_volume": Param("m3", 0.0, 10.0, "nominal gas volume V0", lo_strict=True),
                   "precharge": Param("Pa", 0.0, _P, "precharge pressure p0 (gauge)", lo_strict=True),
                   "exponent": Param("-", 1.0, 1.4, "polytropic exponent n", 1.4),
                   "min_gas_fraction": Param("-", 0.0, 1.0, "gas left when full, of V0", 0.05, lo_strict=True)},
                  modes=("empty", "working", "full"), derived=(("min_gas_volume", "m3"),)),
    ComponentType("hose", "hose / line: laminar or turbulent resistance, its volume at its ends", ("a", "b"),
                  {"diameter": Param("m", 0.0, 1.0, "inner diameter", lo_strict=True),
                   "length": Param("m", 0.0, 1e3, "length", lo_strict=True)}, derived=(("volume", "m3"),)),
    ComponentType("volume", "a volume of oil at a node (a block's bores, a manifold)", ("p",),
                  {"volume": Param("m3", 0.0, 10.0, "volume", lo_strict=True)}),
    ComponentType("motor", "hydraulic motor with its inertia: q = D*w/(2 pi) + Cl*dp, torque eta*D*dp/(2 pi); or "
                  "its shaft coupled to a rotary load (shaft)",
                  ("a", "b"),
                  {"displacement": Param("m3/rev", 0.0, 1e-2, "displacement per revolution", lo_strict=True),
                   "leakage": Param("m3/(s.Pa)", 0.0, 1e-6, "leakage conductance Cl", 0.0),
                   "efficiency": Param("-", 0.0, 1.0, "hydro-mechanical efficiency", 1.0, lo_strict=True),
                   "inertia": Param("kg.m2", 0.0, 1e4, "inertia of the motor and its load", lo_strict=True),
                   "damping": Param("N.m.s/rad", 0.0, 1e5, "viscous friction", 0.0),
                   "load_torque": Param("N.m", -1e6, 1e6, "load torque (or the signal NAME.load_torque)", 0.0),
                   "speed0": Param("rad/s", -1e4, 1e4, "initial speed", 0.0)},
                  inputs=("load_torque",), states=(("w", "rad/s"),), coupling=SHAFT),
    ComponentType("rotary_load", "a rotary load turned by the motors whose shaft names it (one inertia: the "
                  "motors' and the load's, viscous friction, a load torque or its signal)", (),
                  {"inertia": Param("kg.m2", 0.0, 1e4, "inertia of the load and the motors on it", lo_strict=True),
                   "damping": Param("N.m.s/rad", 0.0, 1e5, "viscous friction", 0.0),
                   "load_torque": Param("N.m", -1e6, 1e6, "load torque (or the signal NAME.load_torque)", 0.0),
                   "speed0": Param("rad/s", -1e4, 1e4, "initial speed", 0.0)},
                  inputs=("load_torque",), states=(("w", "rad/s"),)),
    ComponentType("cylinder", "differential cylinder with its load (mass, viscous friction, force) and end stops, "
                  "or its rod coupled to a load (rod_end)",
                  ("a", "b"), _cylinder_params("rod diameter"), modes=_STOPS, inputs=("force",), states=_PISTON,
                  derived=_CYLINDER_DERIVED, coupling=ROD),
    ComponentType("double_rod_cylinder", "double-rod cylinder (equal areas) with its load and end stops, or its "
                  "rod coupled to a load (rod_end)",
                  ("a", "b"), _cylinder_params("rod diameter (both sides)"), modes=_STOPS, inputs=("force",),
                  states=_PISTON, derived=_CYLINDER_DERIVED, coupling=ROD),
    ComponentType("load", "a load moved by the cylinders whose rod_end names it (one rigid body: mass, viscous "
                  "friction, spring, weight, a force or force signal); its travel the shortest of their strokes, "
                  "end stops as modes", (),
                  {k: v for k, v in _cylinder_params("").items() if k in ROD.load_keys},
                  modes=_STOPS, inputs=("force",), states=_PISTON,
                  derived=(("weight", "N"),),
                  tables={"force_table": ("m", "N", "force opposing extension over the position: {x = [...], "
                                                   "f = [...]}, linear between the points, held beyond them (a "
                                                   "workpiece, a spring's curve)")}),
    ComponentType("valve_43", "4/3 proportional valve by geometry: spool lag (wn, xi), an opening per edge",
                  ("P", "T", "A", "B"), _valve_params(), inputs=("command",), states=(("x", "m"), ("v", "m/s")),
                  derived=(("flow_gain", "m2/s/sqrt(Pa)"),)),
    ComponentType("valve_63", "open-centre 6/3 valve (mobile hydraulics): the 4/3 valve plus a P -> T centre path "
                  "open at x = 0, closed at |x| >= centre_travel",
                  ("P", "T", "A", "B"),
                  _valve_params({"centre_travel": Param("m", 0.0, 0.05, "spool travel that closes the centre path",
                                                        lo_strict=True)}),
                  inputs=("command",), states=(("x", "m"), ("v", "m/s")), derived=(("flow_gain", "m2/s/sqrt(Pa)"),)),
    ComponentType("counterbalance_valve", "counterbalance valve: free flow into the load through a check; out of "
                  "it a main stage (an orifice) opened by p_load - p_valve + r*p_pilot beyond p_set",
                  ("valve", "load", "pilot"),
                  {"set_pressure": Param("Pa", 0.0, 1e9, "setting p_set (typically 1.3 x the load's pressure)",
                                         lo_strict=True),
                   "pilot_ratio": Param("-", 0.0, 100.0, "pilot ratio r", 3.0),
                   "rated_flow": Param("m3/s", 0.0, 1.0, "flow of the main stage fully open at its rated drop",
                                       lo_strict=True),
                   "rated_drop": Param("Pa", 0.0, 1e9, "pressure drop load -> valve port at the rated flow, fully "
                                       "open (the catalogue's flow curve)", lo_strict=True),
                   "rated_excess": Param("Pa", 0.0, 1e9, "excess of p_load - p_valve + r*p_pilot over p_set that "
                                         "opens the main stage fully", lo_strict=True),
                   "check_cracking": Param("Pa", 0.0, 1e8, "check's cracking pressure difference", 2e5,
                                           lo_strict=True),
                   "check_rated_flow": Param("m3/s", 0.0, 1.0, "check's flow at its rated difference",
                                             lo_strict=True),
                   "check_rated_pressure": Param("Pa", 0.0, 1e8, "check's pressure difference at that flow",
                                                 lo_strict=True),
                   "transition_pressure": Param("Pa", 0.0, 1e7, "laminar transition of the main stage's orifice",
                                                1e5, lo_strict=True)},
                  modes=("closed", "check_open", "relief_open", "both_open"),
                  derived=(("check_gain", "m3/(s.Pa)"), ("relief_coefficient", "m3/s/sqrt(Pa)"))),
)}

# the paper's rig (SPEC §8, parameters/ferreira2004.toml): the defaults of its servo valve and its seal friction
_FERREIRA_K = (-2.136, 1.602e-2, 4.561, -8.084e-2, 1.563e-2)
_FERREIRA_KT = (-2.145, 7.276e-3, 4.602, -4.208e-2, 1.092e-2)
_SECTION = "(l/min)/sqrt(bar)"
TYPES["servo_valve"] = ComponentType(
    "servo_valve", "the paper's servo-solenoid 4/3 valve (SPEC §3): a limited 2nd-order spool and eq 3's "
    "pseudo-sections per edge (defaults: the paper's valve)", ("P", "T", "A", "B"),
    {"command": Param("-", -1.0, 1.0, "normalised spool command u (or the signal NAME.command)", 0.0),
     **{f"k{i}": Param("-", -1e3, 1e3, f"eq 3 coefficient k{i} of P->A, P->B [{_SECTION}]", k)
        for i, k in enumerate(_FERREIRA_K, 1)},
     **{f"kt{i}": Param("-", -1e3, 1e3, f"eq 3 coefficient k{i}t of A->T, B->T [{_SECTION}]", k)
        for i, k in enumerate(_FERREIRA_KT, 1)},
     "dp_laminar": Param("Pa", 0.0, 1e7, "laminar transition of the orifice law", 1e5, lo_strict=True),
     "reference_dp_laminar": Param("Pa", 0.0, 1e7, "the continuous reference's laminar transition (SPEC §6: "
                                   "narrow, the Jacobian finite; the core's dp_lam_ref)", 1e3, lo_strict=True),
     "wn": Param("rad/s", 0.0, 1e5, "spool natural frequency", 1007.01, lo_strict=True),
     "xi": Param("-", 0.0, 10.0, "spool damping ratio", 0.48, lo_strict=True),
     "la": Param("1/s2", 0.0, 1e9, "spool acceleration limit (normalised stroke)", 81184.24, lo_strict=True),
     "lv": Param("1/s", 0.0, 1e6, "spool velocity limit (normalised stroke; 0: a spool that cannot move, stuck)",
                 125.56),
     "wear": Param("-", 0.0, 10.0, f"worn lands: a leakage section added to each edge's [{_SECTION}]", 0.0),
     **{f"burst_{port.lower()}": Param("-", 0.0, 100.0, f"a burst hose on the {port} line (a fault): its section to "
                                        f"tank, added to the {port}->T edge's (its flow in q_{port.lower()}t) "
                                        f"[{_SECTION}]", 0.0) for port in ("A", "B")},
     "delay": Param("s", 0.0, 0.1, "pure delay of a driven command (the core's delay line, SPEC §3.1)", 7.625e-4)},
    modes=("linear", "acc_limited", "vel_limited", "at_end"), inputs=("command",), states=(("x", "-"), ("v", "1/s")))

TYPES["lugre_cylinder"] = ComponentType(
    "lugre_cylinder", "the paper's differential cylinder (SPEC §4-§6): LuGre seal friction with stick and slip "
    "modes, end stops, eq 21 chambers, internal leakage (defaults: the paper's seals)", ("a", "b"),
    {"bore": Param("m", 0.0, 2.0, "piston diameter (or area_a, area_b)", math.nan, lo_strict=True),
     "rod": Param("m", 0.0, 2.0, "rod diameter (or area_a, area_b)", math.nan, lo_strict=True),
     "area_a": Param("m2", 0.0, 4.0, "cap-side area A1 (or bore, rod)", math.nan, lo_strict=True),
     "area_b": Param("m2", 0.0, 4.0, "rod-side annulus A2 (or bore, rod)", math.nan, lo_strict=True),
     "stroke": Param("m", 0.0, 20.0, "stroke", lo_strict=True),
     "dead_volume_a": Param("m3", 0.0, 1.0, "cap-side volume at x = 0 (ports, line)", 5e-5, lo_strict=True),
     "dead_volume_b": Param("m3", 0.0, 1.0, "rod-side volume at full stroke", 5e-5, lo_strict=True),
     "leakage": Param("m3/(s.Pa)", 0.0, 1e-6, "internal leakage conductance a -> b (eq 22)", 0.0),
     "bulk_b": Param("1/Pa", 0.0, 1e-6, "eq 21 coefficient B (with bulk_c; else the fluid's bulk modulus)",
                     math.nan),
     "bulk_c": Param("-", 0.0, 1.0, "eq 21 coefficient C", math.nan, lo_strict=True),
     "beta_a": Param("Pa", 1e6, 1e11, "a constant bulk modulus of the cap-side chamber (else eq 21 or the "
                     "fluid's)", math.nan),
     "beta_b": Param("Pa", 1e6, 1e11, "a constant bulk modulus of the rod-side chamber", math.nan),
     "mass": Param("kg", 0.0, 1e6, "moved mass", lo_strict=True),
     "gravity": Param("m/s2", 0.0, 100.0, "gravitational acceleration", G),
     "incline": Param("deg", -90.0, 90.0, "rod's angle above the horizontal (90: up, the weight opposes "
                      "extension; -90: down, it aids)", 0.0),
     "force": Param("N", -1e8, 1e8, "external force, + opposes extension (or the signal)", 0.0),
     "sigma0": Param("N/m", 0.0, 1e12, "bristle stiffness", 2.114e7, lo_strict=True),
     "sigma1": Param("N.s/m", 0.0, 1e9, "bristle damping", 2.914e3),
     "fc_pos": Param("N", 0.0, 1e7, "Coulomb friction, extending", 110.2),
     "fs_pos": Param("N", 0.0, 1e7, "breakaway force, extending", 261.0, lo_strict=True),
     "vs_pos": Param("m/s", 0.0, 10.0, "Stribeck velocity, extending", 0.0152, lo_strict=True),
     "kv_pos": Param("N.s/m", 0.0, 1e8, "viscous friction, extending", 818.4),
     "fc_neg": Param("N", 0.0, 1e7, "Coulomb friction, retracting (magnitude)", 89.26),
     "fs_neg": Param("N", 0.0, 1e7, "breakaway force, retracting (magnitude)", 249.56, lo_strict=True),
     "vs_neg": Param("m/s", 0.0, 10.0, "Stribeck velocity, retracting", 0.0251, lo_strict=True),
     "kv_neg": Param("N.s/m", 0.0, 1e8, "viscous friction, retracting", 1387.0),
     "x0": Param("m", 0.0, 20.0, "initial position", 0.0),
     "stop_stiffness": Param("N/m", 0.0, 1e14, "the continuous reference's end stops (SPEC §6): a unilateral "
                             "spring-damper past an end, its stiffness", 1e10, lo_strict=True),
     "stop_damping": Param("N.s/m", 0.0, 1e14, "... and its damping (it pushes, never pulls)", 1e10)},
    modes=("stick", "slip_pos", "slip_neg", "at_retract", "at_extend"), inputs=("force",),
    states=(("x", "m"), ("v", "m/s"), ("z", "m")), derived=(*_CYLINDER_DERIVED,))

TYPES["lugre_motor"] = ComponentType(
    "lugre_motor", "hydraulic motor with its inertia and LuGre friction (SPEC §12.3: the Stribeck form of eq 25 "
    "with stick and slip modes): q = D*w/(2 pi) + Cl*dp, torque eta*D*dp/(2 pi)", ("a", "b"),
    {**{k: TYPES["motor"].params[k] for k in ("displacement", "leakage", "efficiency", "inertia", "damping",
                                               "load_torque", "speed0")},
     "sigma0": Param("N.m/rad", 0.0, 1e12, "bristle stiffness", lo_strict=True),
     "sigma1": Param("N.m.s/rad", 0.0, 1e9, "bristle damping", 0.0),
     "fc_pos": Param("N.m", 0.0, 1e7, "Coulomb torque, turning forward"),
     "fs_pos": Param("N.m", 0.0, 1e7, "breakaway torque, turning forward", lo_strict=True),
     "vs_pos": Param("rad/s", 0.0, 1e4, "Stribeck speed, forward", lo_strict=True),
     "kv_pos": Param("N.m.s/rad", 0.0, 1e8, "viscous friction of the seals, forward", 0.0),
     "fc_neg": Param("N.m", 0.0, 1e7, "Coulomb torque, backward (magnitude)"),
     "fs_neg": Param("N.m", 0.0, 1e7, "breakaway torque, backward (magnitude)", lo_strict=True),
     "vs_neg": Param("rad/s", 0.0, 1e4, "Stribeck speed, backward", lo_strict=True),
     "kv_neg": Param("N.m.s/rad", 0.0, 1e8, "viscous friction of the seals, backward", 0.0)},
    modes=("stick", "slip_pos", "slip_neg"), inputs=("load_torque",), states=(("w", "rad/s"), ("z", "rad")))

FLUID = {"density": Param("kg/m3", 500.0, 2000.0, "density", 860.0),
         "bulk_modulus": Param("Pa", 1e7, 1e11, "effective bulk modulus (constant)", 1.4e9),
         "viscosity": Param("m2/s", 1e-7, 1e-2, "kinematic viscosity", 46e-6)}
