"""A scenario of the paper's rig (``params = "ferreira2004"`` or a parameter file of its shape) as a circuit
scenario: its rig the circuit of its parameters (:func:`hydrohil.circuits.parameter_set.paper_tables`, the
``ferreira2004`` circuit for the built-in set), its drive, loop, encoder, faults and [hil] settings written in
a circuit scenario's terms, so that the generated code runs it (``hydrohil circuit convert``; then simulate,
hil, test, export as any circuit scenario). Its runs are the core's to rounding (README: the table per example);
what a circuit cannot express is refused, naming the key and why.

The translation, key by key:

=========================  ==========================================================================================
paper scenario             circuit scenario
=========================  ==========================================================================================
params, [overrides]        the circuit of the parameters (circuit.toml beside the scenario; ``initial.xp`` its x0)
[input] table / sine       ``[inputs] "valve.command"``: a table (linear) as written; a sine held per step; sent by
                           the controller process (``commands = ["valve.command"]``: the rig's open loop)
[controller] p/pi/pid/     the same law on ``cyl.x`` -> ``valve.command``, reading the encoder's counts
p_ff/state_feedback/       (``sensor_resolution`` = the count size); the reference table linear, as written, its
python, [reference]        ``repeat`` period too; a state feedback's load pressure of ``cyl`` through the rig's four
                           transducers (the chambers, ``supply_node``, ``tank_node``; sensors.pressure_range,
                           _resolution, _noise, its stream the rig's: ``pressure_seed`` = [hil] seed); a Python
                           controller the same callable,
                           called each step with the rig's measurement (``path``: its module's folder); in a file,
                           status 0 (said in a note; run_generated gives it the rig's bits, rig_status)
initial.xs                 omitted: in open loop ``rest = {hold = "cyl.x", by = "valve.command"}`` (the rig's
                           start: the piston held by the spool offset at rest), a closed loop's own start (the
                           same); given: ``[start] "valve.command"`` (the circuit at rest under it, the spool there,
                           its delay line holding it: the core's)
initial.p1, p2             ``[start] cap``, ``rod``: set on the state at rest, the other chamber keeping its rest
                           value (the core's rule)
[hil]                      as given; ``command_delay`` added to the valve's delay (the core's series delay);
                           ``safe_state = "hold"``: the loop's (``cyl.x`` held by ``valve.command``, ``hold_kp``
                           written; in open loop "centre", dropped with a note where no network fault can
                           trip it offline); ``controller_mode = "clock"``: the circuit's controller (an open
                           loop's, sending the commands) on its own clock
faults: network            the same faults on the loop's commands, or an open loop's (packet_loss, network_delay,
                           reordering, controller_silence; the same streams: seed and the rig's place, ``stream``)
faults: sensor (position)  the loop's sensor faults (stuck, offset, noise, dropout; in m; encoder_count_loss)
faults: sensor (pressure)  the same fault on the loop's transducer of it (``signal``: cap.p, rod.p, supply.p,
                           tank.p) where the loop reads it (a state feedback's chambers, a Python controller's
                           four); elsewhere not carried, with a note (the run is the same); in open loop a
                           position sensor's too (no loop reads it)
command_inversion          the same fault on the loop's commands
spool_stuck                ``parameter`` on valve.lv = 0 (the spool's clamp at the step's start: stopped at once)
valve_leakage              ``parameter`` on valve.wear (the worn lands' section on each edge; overlapping ones summed)
hose_burst                 ``parameter`` on valve.burst_a or burst_b (the line's section to tank, added to the edge's;
                           overlapping ones summed)
supply_pressure            ``parameter`` on supply.pressure (at least the tank's)
seal_wear                  ``parameter`` on cyl.leakage
valve_bandwidth            ``parameter`` on valve.wn (its value times the factor)
load_change                ``parameter`` on cyl.mass and/or cyl.force
=========================  ==========================================================================================

Refused (InputError naming the key): ``safe_state = "hold"`` in open loop with a network fault (a circuit holds a
closed loop's measured signal; an open loop's commands take "centre").
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from hydrohil.circuits.faults import NETWORK_FAULTS, SENSOR_FAULTS
from hydrohil.control import anchor_controller
from hydrohil.errors import InputError

LOOP_TYPES = ("p", "pi", "pid", "p_ff", "state_feedback", "python")
# the rig's fault types a circuit writes as a parameter changed: type -> [(key of the rig's fault, circuit target,
# its value from the rig's fault's value and the parameters)]
PARAMETER = {
    "supply_pressure": [("ps", "supply.pressure", lambda v, p: max(v, p.supply.pt))],
    "seal_wear": [("g_lkc", "cyl.leakage", lambda v, p: v)],
    "valve_bandwidth": [("factor", "valve.wn", lambda v, p: p.spool.wn * v)],
    "load_change": [("mass", "cyl.mass", lambda v, p: v), ("force", "cyl.force", lambda v, p: v)],
    "spool_stuck": [(None, "valve.lv", lambda v, p: 0.0)],       # (its clamp at the step's start: velocity 0)
}
# sensor faults with a memory (the value stuck at, the count last read): rig_columns reads the sensors again from
# the logged rows, exact when every step is logged only; a run logged every few steps with one runs on the core
STATEFUL_SENSOR_FAULTS = ("sensor_stuck", "encoder_count_loss")
# the rig's pressure sensors as the paper circuit's nodes (the loop's transducers of a state feedback, a Python law)
TRANSDUCERS = {"p1": "cap.p", "p2": "rod.p", "ps": "supply.p", "pt": "tank.p"}
HIL_DROPPED = ("command_scale",)          # the wire's unit of the paper's rig: a circuit's inputs are SI


def circuit_tables(ls) -> tuple[dict, dict, list[str]]:
    """The paper scenario ``ls`` (:class:`~hydrohil.simulation.scenario.LoadedScenario`) as (the circuit file's
    tables, the circuit scenario's tables, notes on what changed form). InputError for what a circuit cannot
    run, naming the scenario's key."""
    from hydrohil.circuits.parameter_set import paper_tables
    from hydrohil.models.sensors import count_size
    s, p, src = ls.scenario, ls.params, ls.source
    notes: list[str] = []
    ini = s.initial
    circuit = paper_tables(p, ini.xp)
    circuit["name"] = Path(src).stem
    circuit["description"] = f"the paper's rig of {Path(src).name} (params = {s.params!r}, its overrides applied)"
    hil = s.hil.model_dump(exclude_defaults=True)
    if s.hil.command_delay > 0:             # in series with the spool's delay (load_scenario: offline and HIL)
        hil.pop("command_delay")
        notes.append(f"hil.command_delay {s.hil.command_delay:g} s: in the valve's delay "
                     f"({circuit['components']['valve']['delay']:g} s)")
    for key in HIL_DROPPED:
        if key in hil:
            notes.append(f"hil.{key}: dropped (a circuit's inputs travel in SI units)")
            hil.pop(key)
    if s.hil.safe_state == "hold":          # (the loop's measure held by its command: the rig's piston, its valve)
        if s.controller is None:            # (a circuit holds a closed loop's measured signal only)
            network = [i for i, f in enumerate(s.faults) if f.type in NETWORK_FAULTS]
            if network:
                raise InputError("a circuit's safe state \"hold\" holds a closed loop's measured signal; an open "
                                 f"loop's commands take \"centre\", and faults[{network[0]}] may trip the watchdog "
                                 "(the runs would differ)", source=src, key="hil.safe_state")
            hil.pop("safe_state")
            hil.pop("hold_kp", None)
            notes.append("hil.safe_state = \"hold\": dropped (a circuit holds a closed loop's measured signal; an "
                         "open loop's commands take \"centre\": no fault trips the watchdog offline, a real-time "
                         "run's silence would centre the valve)")
        else:
            hil["hold_kp"] = s.hil.hold_kp
    scen: dict = {"circuit": "circuit.toml", "description": f"{Path(src).name} on the generated code",
                  "duration": s.duration, "solver": {"method": s.solver.method, "step": s.solver.step,
                                                    "output_every": s.solver.output_every}}
    t = np.arange(s.n_steps() + 1) * s.solver.step
    if s.controller is None:                # (the rig's open loop: its controller sends the command table)
        _open_loop(s, t, scen, src)
        scen["commands"] = ["valve.command"]
        if ini.xs is None:                  # the rig's default: the piston held by the spool offset at rest
            scen["rest"] = {"hold": "cyl.x", "by": "valve.command"}
    else:
        _loop(s, p, scen, src, count_size(p.sensors.encoder_resolution), notes)
    start = {"valve.command": ini.xs} if ini.xs is not None else {}   # (the spool at rest there, its delay line
    start.update({node: v for node, v in (("cap", ini.p1), ("rod", ini.p2)) if v is not None})   # too: the core's)
    if start:                               # the chambers' pressures set on the state at rest: the core's rule
        scen["start"] = start
    faults = _faults(s, p, src, notes)
    if faults:
        scen["faults"] = faults
    if hil:
        scen["hil"] = hil
    return circuit, scen, notes


def _open_loop(s, t: np.ndarray, scen: dict, src: str) -> None:
    """The valve's command as the circuit's input (a table as written, a sine per step)."""
    from hydrohil.simulation.scenario import SineInput
    inp = s.input
    if isinstance(inp, SineInput):          # held over each step, as the core samples it (t_n: the last row's)
        scen["inputs"] = {"valve.command": {"t": t, "value": s.commands()}}   # (arrays: lists in a file)
        return
    t, u = _linear_table(inp.t, inp.u, src, "input.t")
    scen["inputs"] = {"valve.command": {"t": t, "value": u, "interpolation": "linear"}}


def _linear_table(t, v, src: str, key: str) -> tuple[list, list]:
    """A paper table (times non-decreasing, from any time, a time given any number of times; np.interp's
    values between them, its first value before them) as a circuit's linear table (from 0, a time at most
    twice) of the same values and slopes at every time: the first point at 0 too, of a time given more than
    twice its first and last points (np.interp takes the last there). A table from before 0: InputError (its
    slope at 0 would be another line's)."""
    t, v = [float(x) for x in t], [float(x) for x in v]
    if t[0] < 0.0:
        raise InputError("a circuit's table starts at 0 s: this one starts before it", source=src, key=key)
    if t[0] > 0.0:
        t, v = [0.0, *t], [v[0], *v]
    keep = [i for i in range(len(t)) if not (0 < i < len(t) - 1 and t[i - 1] == t[i] == t[i + 1])]
    return [t[i] for i in keep], [v[i] for i in keep]


def _loop(s, p, scen: dict, src: str, count: float, notes: list[str]) -> None:
    ctl = s.controller
    table = ctl.model_dump(exclude_defaults=True)
    table["type"] = ctl.type
    if ctl.type == "python":                # its module where the rig's finds it (the scenario's folder)
        anchor_controller(table, Path(src).parent)
        notes.append(f"controller {ctl.callable}: called each step with the rig's t, x_ref, dx_ref, x (the "
                     "encoder's reading), p1, p2, ps and pt (the chambers, the supply's and the tank's nodes through "
                     "the rig's transducers); not the rig's: status 0 (no rig's status bits; simulate's own conversion "
                     "gives them)")
    scen["controller"] = {**table, "measure": "cyl.x", "command": "valve.command", "sensor_resolution": count}
    if ctl.type in ("state_feedback", "python"):   # the rig's four transducers, their noise the rig's stream
        scen["controller"].update(load_pressure="cyl", supply_node="supply", tank_node="tank",
                                  pressure_range=p.sensors.pressure_range,
                                  pressure_resolution=p.sensors.pressure_resolution)
        if p.sensors.pressure_noise > 0:
            scen["controller"].update(pressure_noise=p.sensors.pressure_noise, pressure_seed=s.hil.seed)
    t, x = _linear_table(s.reference.t, s.reference.x, src, "reference.t")
    scen["reference"] = {"t": t, "value": x, "interpolation": "linear",
                         **({"repeat": s.reference.repeat} if s.reference.repeat else {})}


def _faults(s, p, src: str, notes: list[str], reads: tuple | None = None) -> list[dict]:
    """The faults in a circuit scenario's terms; a loop's fault keeps its random stream, the rig's (``stream``:
    its place in the rig's table, where the circuit's has another). ``reads``: the sensors a loop reads (the
    rig's names: position, p1, p2, ps, pt), their faults carried; None: the scenario's controller's."""
    if reads is None:
        reads = (("position",) if s.controller is not None else ()) + {
            "state_feedback": ("p1", "p2"), "python": ("p1", "p2", "ps", "pt")}.get(
            s.controller.type if s.controller is not None else None, ())
    out, added = [], {}                 # (added: the faults that add to a parameter, by target)
    for i, f in enumerate(s.faults):
        where = f"faults[{i}]"
        window = {"start": f.start, **({"end": f.end} if f.end is not None else {})}
        stream = {"stream": i} if len(out) != i else {}
        if f.type in NETWORK_FAULTS:          # (a loop's command, an open loop's: the valve's command sent)
            out.append({**f.model_dump(exclude_none=True), **stream})
        elif f.type in SENSOR_FAULTS:
            sensor = getattr(f, "sensor", "position")
            body = {k: v for k, v in f.model_dump(exclude_none=True).items() if k != "sensor"}
            if sensor in reads and sensor != "position":   # (what the rig's controller reads: its transducer)
                out.append({**body, "signal": TRANSDUCERS[sensor], **stream})
                continue
            if sensor not in reads:           # (only what the rig's log reports of it)
                notes.append(f"{where} ({f.type} on the {sensor} sensor): not carried: "
                             f"{'no loop reads it' if s.controller is None else 'the loop does not read it'}, so "
                             "it changes nothing in the run (the rig's log shows it in its reading)")
                continue
            out.append({**body, **stream})
        elif f.type == "hose_burst":          # the rig's burst: its section added to its line's edge to tank
            target = f"valve.burst_{'ab'[f.line - 1]}"             # (cylinder.c: the core's sum, bit for bit)
            added.setdefault(target, []).append((f.start, f.end, f.section))
            notes.append(f"{where} (hose_burst): a parameter fault on {target} (its section to tank beside the "
                         f"valve's edge, as the rig's)")
        elif f.type == "valve_leakage":       # (the rig adds each worn section to the lands': valve.wear)
            added.setdefault("valve.wear", []).append((f.start, f.end, f.section))
            notes.append(f"{where} (valve_leakage): a parameter fault on valve.wear")
        else:
            given = [(k, t, v) for k, t, v in PARAMETER[f.type] if k is None or getattr(f, k) is not None]
            for key, target, value in given:
                out.append({"type": "parameter", "target": target,
                            "value": value(getattr(f, key) if key else None, p), **window})
            notes.append(f"{where} ({f.type}): a parameter fault on {', '.join(t for _, t, _ in given)}")
    for target, windows in added.items():
        out += _summed(target, windows)
    return out


def _summed(target: str, windows: list) -> list[dict]:
    """Faults that add to a parameter (the rig's ``+=``: sections of worn lands, of burst hoses; from 0) as
    parameter faults on ``target``, which set it: one per stretch between the windows' starts and ends where any
    acts, its value their sum (in the scenario's order, as the rig adds them), so overlapping windows add up."""
    inf = math.inf
    cuts = sorted({t for start, end, _ in windows for t in (start, inf if end is None else end)})
    out = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        acting = [v for start, end, v in windows if start <= a and (end is None or end >= b)]
        if acting:                          # (summed left to right from 0: the rig's order)
            out.append({"type": "parameter", "target": target, "value": float(sum(acting)), "start": a,
                        **({"end": b} if b != inf else {})})
    return out


def convert(ls, out: str | Path) -> tuple[Path, Path, list[str]]:
    """:func:`circuit_tables` written into the folder ``out`` (circuit.toml, scenario.toml): the paths and the
    notes."""
    import tomli_w
    circuit, scen, notes = circuit_tables(ls)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    head = f"# {Path(ls.source).name} as a circuit scenario (hydrohil circuit convert): the generated code runs it\n"
    cpath, spath = out / "circuit.toml", out / "scenario.toml"
    cpath.write_text(head + tomli_w.dumps(circuit))
    spath.write_text(head + "".join(f"# {n}\n" for n in notes) + tomli_w.dumps(_listed(scen)))
    return cpath, spath, notes


# the paper circuit's log columns a paper scenario's run reads: the core's log (circuits.paper.paper_log) and the
# rig's sensors (rig_columns: the piston, the four nodes' pressures); the others (the valve's four flows, the
# cylinder's force) not computed
PAPER_COLUMNS = ["cyl.mode", "valve.mode", "valve.x", "valve.v", "cyl.x", "cyl.v", "cyl.z", "cyl.friction", "cap.p",
                 "rod.p", "supply.p", "tank.p", "valve.command.seen"]


def _listed(table):
    """A table with its arrays as lists (what a TOML file holds)."""
    if isinstance(table, dict):
        return {k: _listed(v) for k, v in table.items()}
    if isinstance(table, list):
        return [_listed(v) for v in table]
    return table.tolist() if isinstance(table, np.ndarray) else table


def circuit_scenario_of(ls, tables: tuple | None = None):
    """The paper scenario ``ls`` as a circuit scenario in memory (:func:`circuit_tables`, or its ``tables`` when
    the caller has them; no file written)."""
    from hydrohil.circuits.scenario import scenario_from_dict
    circuit, scen, _ = circuit_tables(ls) if tables is None else tables
    return scenario_from_dict(scen, Path(ls.source).parent, f"{ls.source} (as a circuit, in memory)",
                              circuit=circuit)


def rig_instruments(ls, tables: tuple | None = None):
    """The paper's rig's sensors as a circuit's loop (:class:`~hydrohil.circuits.run.Loop`) that reads them all,
    whatever the scenario's loop reads: the encoder on ``cyl.x`` (its count), the four transducers (the chambers,
    the supply's and the tank's nodes: sensors.pressure_*, the noise the rig's stream, [hil] seed) and every
    sensor fault of the scenario on its sensor (its stream the rig's). What the rig's log reports through them
    (:func:`rig_columns`); the loop's law is not run. ``tables``: :func:`circuit_tables`'s, when the caller has
    them."""
    from hydrohil.circuits.scenario import scenario_from_dict
    from hydrohil.models.sensors import count_size
    s, p, src = ls.scenario, ls.params, ls.source
    circuit, scen, _ = circuit_tables(ls) if tables is None else tables
    table = {"type": "state_feedback", "kp": 1.0, "measure": "cyl.x", "command": "valve.command",
             "sensor_resolution": count_size(p.sensors.encoder_resolution), "load_pressure": "cyl",
             "supply_node": "supply", "tank_node": "tank", "pressure_range": p.sensors.pressure_range,
             "pressure_resolution": p.sensors.pressure_resolution}
    if p.sensors.pressure_noise > 0:
        table.update(pressure_noise=p.sensors.pressure_noise, pressure_seed=s.hil.seed)
    keep = {k: scen[k] for k in ("circuit", "duration", "solver", "hil") if k in scen}
    keep.update(controller=table, reference={"t": [0.0], "value": [0.0]})
    faults = _faults(s, p, src, [], reads=("position", *TRANSDUCERS))
    if faults:
        keep["faults"] = faults
    return scenario_from_dict(keep, Path(src).parent, f"{src} (the rig's sensors)", circuit=circuit).loop


def rig_columns(ls, res, compiled, tables: tuple | None = None) -> dict[str, np.ndarray]:
    """The rig's extra log columns (:data:`hydrohil.simulation.rig.RIG_COLUMNS`) of the generated run ``res`` of
    the paper scenario ``ls`` (``compiled``: its circuit's code): what the rig's sensors reported
    (:func:`rig_instruments`, their noise drawn again from the seeds), the faults active (bit i: the scenario's
    fault i, the rig's rule start <= k*h < end) and the watchdog (1: its safe state held: as the rig's sensor
    packet reports it at step k, held over step k - 1). ``tables``: :func:`circuit_tables`'s, when the caller has
    them."""
    from hydrohil.circuits.faults import active_faults
    from hydrohil.circuits.run import pressures_sensed, sensed_column
    s = ls.scenario
    every, rows = s.solver.output_every, len(res.columns["t"])
    sensors = rig_instruments(ls, tables)
    pressures = pressures_sensed(compiled, sensors, res, every)
    cols = {"faults": active_faults([f.model_dump(exclude_none=True) for f in s.faults], s.solver.step, rows, every,
                                    str(ls.source)),
            "x_meas": sensed_column(compiled, sensors, res.columns["cyl.x"], every),
            **{f"{rig}_meas": pressures[f"{TRANSDUCERS[rig]}.sensed"] for rig in ("p1", "p2", "ps")},
            "watchdog": np.zeros(rows)}
    if res.watchdog is not None:             # (the packet of step k reports the safe state of step k - 1)
        k = np.arange(rows) * every
        cols["watchdog"] = np.where(k > 0, res.watchdog[np.clip(k - 1, 0, len(res.watchdog) - 1)], 0.0)
    return cols


def rig_status(ls, compiled):
    """The rig's status bits as its controller reads them at each step (rig.c: the sensor packet's; core/shape.py
    STATUS), for a Python controller of the paper scenario ``ls`` on the generated code of its circuit
    (``compiled``): a function (k, the log row of step k, 1 when a transducer's reading was clipped, the command
    path or None) -> the bits at_retract, at_extend and stick of the cylinder's mode in the row (at a stop the
    core's friction is stick: circuits.paper.CYL_MODE), saturated, watchdog (the path's safe state held), and
    fault_injected (a fault of the scenario active at step k, the rig's rule start <= k*h < end)."""
    from hydrohil.circuits.faults import active_faults
    from hydrohil.circuits.paper import CYL_MODE
    from hydrohil.core.shape import STATUS
    bit = {b.name: 1 << b.bit for b in STATUS}
    lay, h = compiled.layout, ls.scenario.solver.step
    col = lay.log_columns.index("cyl.mode")
    of_mode = [(bit["at_retract"] if travel == "at_retract_stop" else bit["at_extend"] if travel == "at_extend_stop"
                else 0) | (bit["stick"] if friction == "stick" else 0)
               for travel, friction in (CYL_MODE[name] for name in lay.mode_names["cyl.mode"])]
    s = ls.scenario
    injected = active_faults([f.model_dump(exclude_none=True) for f in s.faults], h, s.n_steps() + 1, 1,
                             str(ls.source)) != 0

    def status(k, row, saturated, path):
        st = of_mode[int(row[col])] | (bit["saturated"] if saturated else 0)
        if path is not None and path.link.active:
            st |= bit["watchdog"]
        if injected[k]:
            st |= bit["fault_injected"]
        return st
    return status


def run_generated(ls, *, progress=None, rig: bool = False):
    """``run_scenario``'s fixed-step run of the paper scenario ``ls`` (a drive, a built-in law or a Python
    controller reading the rig's status bits, :func:`rig_status`; its faults) on the code generated from its circuit (:func:`circuit_scenario_of`), from the core's state at rest
    (``hh_initial_state``, SPEC §12.5: circuits.paper.paper_start), as the core's log (circuits.paper.paper_log;
    ``extra["engine"]`` "generated"; with faults, a Python controller or ``rig`` the rig's columns too, :func:`rig_columns`): the
    core's run bit for bit (tests: every example, the 17 fault examples but for one value of the stuck spool's,
    its speed in the jam's first row, 2.3e-13 1/s where the core logs 0: the circuit clamps it at the step's
    start, after the row; benchmarks/parity.py --engine generated: all 320 fixed-step runs of its record); with
    faults or a Python controller and another solver than RK3, the solver's run, where the core's rig stepped RK3
    whatever the scenario said. A run that diverges (a state non-finite, or outside the physical range the
    paper's components declare, the core's hh_diverged) gives its log up to the step and the core's message
    (:func:`paper_divergence`: the same time, modes and state; the state that left its range named). None when
    the scenario has what a circuit does not take, or a sensor fault with a memory in a run not logged every
    step (rig_columns): run_scenario then runs the core."""
    from hydrohil.circuits.paper import paper_log
    from hydrohil.simulation.result import SimulationResult
    run = _generated_run(ls, PAPER_COLUMNS, progress)
    if run is None:
        return None
    res, diverged, cs, tables = run
    s = ls.scenario
    columns = rig_columns(ls, res, cs.compiled, tables) if s.faults or s.python_controller or rig else {}   # (run_rig's
    #                                                          columns: ``rig``, or a run the core gives the rig)
    return SimulationResult(paper_log(res), s.solver.method, s.solver.step, res.wall, diverged,
                            extra={"engine": "generated"}, columns=columns)


def generated_columns(ls, names: list[str], *, reference: bool = False):
    """The core's log columns ``names`` (core/shape.LOG_COLUMNS': t, xp, p1, friction_mode, ...) of
    :func:`run_generated`'s run of the paper scenario ``ls``, the generated code logging only their circuit
    columns (circuits.paper.paper_columns; a study's metrics read five of the core's fifteen): ({name: column},
    the divergence or None), the same values as :func:`run_generated`'s log and ``diverged``; with ``reference``
    (a closed loop's) its column ``x_ref`` too: the reference the controller read at each row (the loop's table,
    what ``ls.scenario.reference.sample`` gives at the row's t: the circuit's table has the same values at every
    time, :func:`_linear_table`); None where
    :func:`run_generated` is None (run_scenario then runs the core) or the scenario's solver is the continuous
    reference (run_scenario's: the core's sampled loop). KeyError naming a column not in the core's log."""
    from hydrohil.circuits.paper import circuit_columns, paper_columns
    wanted = circuit_columns(names)
    if ls.scenario.solver.method == "reference":
        return None
    run = _generated_run(ls, [c for c in PAPER_COLUMNS if c in wanted], None)   # (the log's: not t, the inputs)
    if run is None:
        return None
    res, diverged, _, _ = run
    cols = paper_columns(res, names)
    if reference:
        cols["x_ref"] = res.columns["cyl.x.reference"]
    return cols, diverged


def _generated_run(ls, columns: list[str], progress):
    """The generated code's run of ``ls`` for :func:`run_generated` and :func:`generated_columns` (``columns``
    the circuit's log columns it computes): (its CircuitResult, its divergence (the core's SimulationDiverged,
    :func:`paper_divergence`) or None, its circuit scenario, :func:`circuit_tables`'s tables), or None (what a
    circuit does not take)."""
    import warnings

    from hydrohil.circuits.paper import paper_start
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.core.shape import LOG_COLUMNS
    from hydrohil.errors import SimulationDiverged
    from hydrohil.models.layout import MODE_COLUMNS, STATE_NAMES
    from hydrohil.simulation.loop import initial_state
    s = ls.scenario
    if s.solver.output_every > 1 and any(f.type in STATEFUL_SENSOR_FAULTS for f in s.faults):
        return None                              # (rig_columns' readings between rows would not be the rig's)
    ini = s.initial
    y, m = initial_state(ls.params, ini.xp, xs=ini.xs, p1=ini.p1, p2=ini.p2)   # (its warnings: the user's)
    row = np.zeros(len(LOG_COLUMNS))
    for i, name in enumerate(STATE_NAMES):
        row[LOG_COLUMNS.index(name)] = y[i]
    for i, name in enumerate(MODE_COLUMNS):
        row[LOG_COLUMNS.index(name)] = m[i]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # (the conversion's own: said by the core's start above)
        try:
            tables = circuit_tables(ls)          # (once: the run's circuit scenario, the rig's sensors)
            cs = circuit_scenario_of(ls, tables)
        except InputError:                       # (what a circuit does not take: a table from before 0)
            return None
    if s.python_controller:                      # (it reads the rig's status bits)
        cs.loop.status = rig_status(ls, cs.compiled)
    diverged = None
    try:
        res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, method=cs.method, every=cs.every, loop=cs.loop,
                               commands=cs.commands, start=paper_start(cs.circuit, row, cs.step, compiled=cs.compiled),
                               progress=progress, compiled=cs.compiled, columns=columns)
    except SimulationDiverged as exc:            # (non-finite, or outside the core's physical range: the paper's
        res, diverged = exc.partial, paper_divergence(exc)   # components declare hh_diverged's bounds: the core's
    return res, diverged, cs, tables


def paper_divergence(exc):
    """The divergence ``exc`` of a paper circuit's run (its circuit's states and modes) in the paper's names, as
    the core says it (models.layout.STATE_NAMES, the travel, friction and spool modes; its reason's state named
    the paper's way: "vp = 161.828 outside its physical range [-100, 100]")."""
    from hydrohil.circuits.paper import CYL_MODE, PAPER_VIEW
    from hydrohil.core.shape import MODE_NAMES
    from hydrohil.models.layout import STATE_NAMES
    from hydrohil.simulation.diagnostics import divergence_error
    y = [exc.state[PAPER_VIEW[name]] for name in STATE_NAMES]
    travel, friction = CYL_MODE[exc.modes["cyl.mode"]]
    m = [MODE_NAMES["travel"].index(travel), MODE_NAMES["friction"].index(friction),
         MODE_NAMES["spool"].index(exc.modes["valve.mode"])]
    reason = exc.reason
    for name in STATE_NAMES:
        if reason.startswith(PAPER_VIEW[name] + " = "):
            reason = name + reason[len(PAPER_VIEW[name]):]
    return divergence_error(exc.t, y, m, reason)
