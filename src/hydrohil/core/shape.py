"""The plant's shape, described once: its state, modes and their names, per-step outputs, log columns,
sensor channels, status bits, the HIL plant log, the side channel's columns and counters, timing.json's
keys and the verdict's criteria.

Every layer takes the shape from here: the build writes the C enums of ``hh_shape.h`` (included by ``hh.h``:
the core, the FMU and the standalone plant index with them), ``hydrohil export c`` writes the C plant's
column and mode-name tables into ``plant_config.h``, and the Python modules (models.layout, simulation,
hil, the FMU's variables) read the names and kinds below. Nothing else spells an index or a column list.

This module imports nothing of hydrohil (like :mod:`hydrohil.core.layout`): the build loads it by path
before the package exists.
"""

from __future__ import annotations

from typing import NamedTuple


class Quantity(NamedTuple):
    name: str           # as Python, the logs and the FMU name it
    c: str              # the C index (enum constant)
    unit: str
    description: str


class ModeValue(NamedTuple):
    c: str
    name: str           # as the logs write it
    description: str


class Mode(NamedTuple):
    name: str           # "travel"; its log column is "travel_mode"
    c: str              # index in m[HH_NM]
    values: tuple[ModeValue, ...]


class Column(NamedTuple):
    name: str
    kind: str           # "real" | "int" (written as an integer) | a mode's name (written as its value's name)
    description: str = ""


class StatusBit(NamedTuple):
    name: str
    bit: int
    description: str


# --- state vector y[HH_NY] (SPEC §3-§5) --------------------------------------------------------------
STATES = (
    Quantity("xs", "HH_XS", "-", "spool position (normalised)"),
    Quantity("vs", "HH_VS", "1/s", "spool velocity (normalised)"),
    Quantity("p1", "HH_P1", "Pa", "chamber 1 (cap side) pressure, gauge"),
    Quantity("p2", "HH_P2", "Pa", "chamber 2 (rod side) pressure, gauge"),
    Quantity("xp", "HH_XP", "m", "piston position"),
    Quantity("vp", "HH_VP", "m/s", "piston velocity"),
    Quantity("z", "HH_Z", "m", "LuGre bristle deflection"),
)

# every quantity of a step's output and of the logs by name: unit, description
QUANTITIES = {**{q.name: q for q in STATES},
              "t": Quantity("t", "HH_OUT_T", "s", "time"),
              "ff": Quantity("ff", "HH_OUT_FF", "N", "friction force"),
              "ud": Quantity("ud", "HH_OUT_UD", "-", "command reaching the spool after the input delay")}

# --- modes m[HH_NM] of the hybrid statechart (SPEC §7) -------------------------------------------------
MODES = (
    Mode("travel", "HH_M_TRAVEL", (
        ModeValue("HH_FREE", "free", "between the end stops"),
        ModeValue("HH_AT_RETRACT", "at_retract_stop", "at the retract end stop"),
        ModeValue("HH_AT_EXTEND", "at_extend_stop", "at the extend end stop"))),
    Mode("friction", "HH_M_FRICTION", (
        ModeValue("HH_STICK", "stick", "presliding (stick)"),
        ModeValue("HH_SLIP_POS", "slip_pos", "slipping in the positive direction"),
        ModeValue("HH_SLIP_NEG", "slip_neg", "slipping in the negative direction"))),
    Mode("spool", "HH_M_SPOOL", (
        ModeValue("HH_SPOOL_LINEAR", "linear", "linear second-order spool"),
        ModeValue("HH_SPOOL_ACC_LIMITED", "acc_limited", "acceleration-limited"),
        ModeValue("HH_SPOOL_VEL_LIMITED", "vel_limited", "velocity-limited"),
        ModeValue("HH_SPOOL_AT_END", "at_end", "at the end of its stroke"))),
)
MODE_NAMES = {m.name: tuple(v.name for v in m.values) for m in MODES}

# --- per-step output out[HH_NOUT] of the core's step (the state as one block) ---------------------------
OUTPUTS = ("t", "y", "ff", "travel", "friction", "spool", "events", "ud")     # "y": the state, HH_NY values
OUTPUT_NAMES = ("t", *(s.name for s in STATES), "ff", *(f"{m.name}_mode" for m in MODES), "events", "ud")

# --- the simulation log (hh_sim_run, `hydrohil simulate`'s log.csv) ------------------------------------
LOG = (Column("t", "real", "time [s]"), Column("u", "real", "valve command [-]"),
       Column("ud", "real", "command reaching the spool after the delay [-]"),
       *(Column(s.name, "real", f"{s.description} [{s.unit}]") for s in STATES),
       Column("ff", "real", "friction force [N]"),
       *(Column(f"{m.name}_mode", m.name) for m in MODES),
       Column("events", "int", "events of the step (hybrid transitions)"))
LOG_COLUMNS = tuple(c.name for c in LOG)

# --- the rig's sensor channels (encoder and pressure transducers) ---------------------------------------
SENSORS = ("position", "p1", "p2", "ps", "pt")
PRESSURES = SENSORS[1:]         # the pressure transducers, as a reading's p[HH_NPRESSURES] holds them

# --- status bits of a sensor packet (protocol v1, docs/protocol.md) and of the rig's reading -------------
STATUS = (
    StatusBit("watchdog", 0, "safe state active: no valid command for longer than the watchdog timeout"),
    StatusBit("lockstep", 1, "plant runs in lock-step (not wall-clock) mode"),
    StatusBit("at_retract", 2, "piston at the retract end stop"),
    StatusBit("at_extend", 3, "piston at the extend end stop"),
    StatusBit("stick", 4, "friction in stick (presliding)"),
    StatusBit("overrun", 5, "the step that produced this packet started after its successor's instant"),
    StatusBit("saturated", 6, "a pressure reading is clipped at the sensor range"),
    StatusBit("late_command", 7, "the command used was not the answer to the previous sensor packet"),
    StatusBit("fault", 8, "the plant stopped on a fault (simulation diverged); last packet"),
    StatusBit("final", 9, "last packet of the run"),
    StatusBit("fault_injected", 10, "a scenario fault ([[faults]]) is active at this step"),
)

# --- the HIL plant's log (plant_log.csv of both plants, one row per step) ----------------------------------
PLANT_LOG = (
    Column("k", "int", "step index"), Column("t", "real", "plant time [s]"),
    Column("wall", "real", "wall-clock time of the step's start [s since the epoch]"),
    Column("jitter_us", "real", "step start after its instant t0 + k h [us]"),
    Column("compute_us", "real", "time to compute the step [us]"),
    Column("u", "real", "command applied to the valve [-]"),
    Column("cmd_seq", "int", "sequence number of that command"),
    Column("cmd_age", "int", "steps since that command arrived"),
    Column("watchdog", "int", "1: the safe state holds the valve"),
    *(Column(s.name, "real", f"{s.description} [{s.unit}]") for s in STATES if s.name in ("xs", "p1", "p2", "xp",
                                                                                         "vp")),
    Column("ff", "real", "friction force [N]"),
    *(Column(f"{m.name}_mode", m.name) for m in MODES),
    Column("encoder", "int", "encoder reading [counts]"),
    Column("p1_meas", "real", "chamber 1 transducer [Pa]"), Column("p2_meas", "real", "chamber 2 transducer [Pa]"),
    Column("ps_meas", "real", "supply transducer [Pa]"),
    Column("faults", "int", "active injected faults (bit i: fault i)"),
    Column("status", "int", "status bits of the sensor packet (STATUS)"),
)
PLANT_LOG_COLUMNS = tuple(c.name for c in PLANT_LOG)

# --- what the rig's sensors reported in an offline run through the rig (beside the simulation log's rows) ---
RIG_LOG = (
    Column("faults", "int", "active injected faults (bit i: fault i)"),
    Column("x_meas", "real", "encoder reading [m]"),
    Column("p1_meas", "real", "chamber 1 transducer [Pa]"), Column("p2_meas", "real", "chamber 2 transducer [Pa]"),
    Column("ps_meas", "real", "supply transducer [Pa]"),
    Column("watchdog", "int", "1: the safe state holds the valve"),
)
RIG_LOG_COLUMNS = tuple(c.name for c in RIG_LOG)

# --- the side channel to the live panel (hil/sidechannel.py) ----------------------------------------------
SIDE_PLANT_COLUMNS = ("t", "xp", "vp", "xs", "u", "p1", "p2", "ps", "ff", "travel_mode", "friction_mode",
                      "spool_mode", "jitter_us", "compute_us", "watchdog", "faults", "x_meas")
SIDE_CONTROLLER_COLUMNS = ("x_ref", "x_meas_ctl", "u_cmd")
SIDE_PLANT_COUNTERS = ("overruns", "late_commands", "watchdog_trips", "watchdog_trips_unexplained",
                       "packets_lost", "telemetry_dropped", "jitter_max_ns", "steps")


class Tunable(NamedTuple):
    name: str
    unit: str
    lo: float
    hi: float
    description: str


# --- what the live panel may change in a running plant (steering "set"; rig.c hh_tuned_base applies them) ----
TUNABLES = (
    Tunable("mass", "kg", 0.1, 1e5, "moved mass"),
    Tunable("force", "N", -1e7, 1e7, "external force, + opposes extension"),
    Tunable("supply_pressure", "Pa", 0.0, 1e8, "supply pressure (at least the tank pressure)"),
    Tunable("friction_scale", "-", 0.0, 10.0, "multiplies every friction force (Coulomb, static, viscous)"),
)

# --- timing.json of a HIL run (both plants write these keys, in this order) ----------------------------------
TIMING_KEYS = (
    "mode", "step_s", "steps", "steps_planned", "overruns", "jitter_us_p50", "jitter_us_p99", "jitter_us_p999",
    "jitter_us_max", "compute_us_p50", "compute_us_p99", "compute_us_max", "rtt_us_p50", "rtt_us_p99",
    "rtt_seen_us_p50", "rtt_seen_us_p99", "rtt_source", "packets_rx", "packets_bad", "packets_foreign",
    "packets_lost", "packets_reordered", "late_commands", "packets_dropped_kernel", "watchdog_trips",
    "watchdog_trips_unexplained", "commands_delivered", "faults_injected", "simulated_s", "wall_s", "drift_ms",
    "fault", "link_error", "stopped_early", "stop_signal", "statistics", "os_cpu", "os_rt_priority",
    "os_timer_slack", "os_memory_locked", "plant", "log_rows_dropped", "steps_per_s", "verdict")
TIMING_ONLY_REALTIME = ("os_memory_locked",)      # not in a lock-step run's
TIMING_ONLY_LOCKSTEP = ("steps_per_s",)           # not in a real-time run's
# the verdict's criteria (hil/verdict.py): timing.json "verdict" -> "criteria" key -> [hil] setting
VERDICT_CRITERIA = (("max_late_commands", "max_late_commands"), ("max_overruns", "max_overruns"),
                    ("max_stall_s", "max_stall"), ("max_watchdog_trips", "max_watchdog_trips"))


TIMING_PANEL = ("telemetry_batches_sent", "telemetry_batches_dropped")   # after log_rows_dropped, with a panel
TIMING_RECORDING = ("recorded_steps", "rtt_scope")                         # then these, in a recording's


def timing_keys(mode: str, *, panel: bool = False, recording: bool = False) -> tuple[str, ...]:
    """The keys of a run's timing.json (``mode``: "realtime" or "lockstep"), in order: a plain run's, one with
    the live panel's side channel (``panel``), a recording's of the panel (``recording``)."""
    skip = TIMING_ONLY_LOCKSTEP if mode == "realtime" else TIMING_ONLY_REALTIME
    keys = [k for k in TIMING_KEYS if k not in skip]
    at = keys.index("log_rows_dropped") + 1
    keys[at:at] = (TIMING_PANEL if panel or recording else ()) + (TIMING_RECORDING if recording else ())
    return tuple(keys)


def _mode(name: str) -> Mode:
    return next(m for m in MODES if m.name == name)


def _enum(names, comment: str = "") -> str:
    body = ", ".join(names)
    lines, line = [], "enum {"
    for word in body.split(" "):
        if len(line) + len(word) + 1 > 110:
            lines.append(line)
            line = "      " + word
        else:
            line += " " + word
    lines.append(line + " };" + (f"   /* {comment} */" if comment else ""))
    return "\n".join(lines)


def c_header() -> str:
    """``hh_shape.h``: the enums of every index of the plant's shape (included by ``hh.h``)."""
    out = ["/* hh_shape.h: GENERATED from src/hydrohil/core/shape.py at build time: do not edit.",
           " * The plant's shape: state, modes, outputs, log columns, sensors, status bits, HIL plant log. */",
           "#ifndef HH_SHAPE_H", "#define HH_SHAPE_H", "",
           "/* state vector y[HH_NY]: " + ", ".join(f"{s.name} [{s.unit}]" for s in STATES) + " */",
           _enum([s.c for s in STATES] + ["HH_NY"]), "",
           "/* modes m[HH_NM] and their values */", _enum([m.c for m in MODES] + ["HH_NM"])]
    for m in MODES:
        out.append(_enum([v.c for v in m.values] + [f"HH_N_{m.name.upper()}"],
                         f"{m.name}: " + ", ".join(v.name for v in m.values)))
    out += ["", "/* out[HH_NOUT] of a step: t, the state (HH_NY values from HH_OUT_Y), ff, the modes, events, the",
            " * delayed input */",
            _enum(["HH_OUT_T", "HH_OUT_Y", "HH_OUT_FF = HH_OUT_Y + HH_NY", "HH_OUT_TRAVEL", "HH_OUT_FRICTION",
                   "HH_OUT_SPOOL", "HH_OUT_EVENTS", "HH_OUT_UD", "HH_NOUT"]), "",
            "/* columns of the simulation log (hh_sim_run) */",
            _enum([f"HH_LOG_{c.name.upper().replace('_MODE', '')}" for c in LOG] + ["HH_NLOG"]), "",
            "/* the rig's sensor channels; its pressure transducers as a reading holds them (p[HH_NPRESSURES]) */",
            _enum([f"HH_SENSOR_{s.upper()}" for s in SENSORS] + ["HH_NSENSORS"]),
            _enum([f"HH_PRESSURE_{s.upper()}" for s in PRESSURES] + ["HH_NPRESSURES"]),
            "", "/* status bits of a sensor packet and of the rig's reading */",
            _enum([f"HH_ST_{b.name.upper()} = 1 << {b.bit}" for b in STATUS]), "",
            "/* columns of the rig's log beside the simulation log in an offline run through the rig */",
            _enum([f"HH_RLOG_{c.name.upper()}" for c in RIG_LOG] + ["HH_NRLOG"]), "",
            "/* columns of the HIL plant log (plant_log.csv) */",
            _enum([f"HH_PLOG_{c.name.upper()}" for c in PLANT_LOG] + ["HH_NPLOG"]), "",
            "/* the side channel to the live panel: the plant's telemetry row, its counters */",
            _enum([f"HH_SIDE_{c.upper()}" for c in SIDE_PLANT_COLUMNS] + ["HH_NSIDE"]),
            _enum([f"HH_SIDEC_{c.upper()}" for c in SIDE_PLANT_COUNTERS] + ["HH_NSIDEC"]), "",
            "/* what the live panel may change in a running plant (hh_tuned_base) */",
            _enum([f"HH_TUNE_{t.name.upper()}" for t in TUNABLES] + ["HH_NTUNABLES"]), "", "#endif", ""]
    return "\n".join(out)


def c_plant_log_tables() -> str:
    """The C plant's plant_log.csv header, each column's kind and the modes' names (for ``plant_config.h``)."""
    kinds = {"real": "PLOG_REAL", "int": "PLOG_INT", **{m.name: f"PLOG_MODE_{m.name.upper()}" for m in MODES}}
    lines = ["/* plant_log.csv (core/shape.py PLANT_LOG): column names and how each is written */",
             _enum(["PLOG_REAL", "PLOG_INT", *(f"PLOG_MODE_{m.name.upper()}" for m in MODES)]),
             "#ifdef PLANT_CONFIG_TABLES",
             "const char *const PLANT_LOG_NAMES[HH_NPLOG] = {" + ", ".join(f'"{c.name}"' for c in PLANT_LOG) + "};",
             "const int PLANT_LOG_KINDS[HH_NPLOG] = {" + ", ".join(kinds[c.kind] for c in PLANT_LOG) + "};"]
    for m in MODES:
        lines.append(f"const char *const {m.name.upper()}_NAMES[HH_N_{m.name.upper()}] = {{"
                     + ", ".join(f'"{v.name}"' for v in m.values) + "};")
    lines += ["#else", "extern const char *const PLANT_LOG_NAMES[HH_NPLOG];", "extern const int PLANT_LOG_KINDS[HH_NPLOG];"]
    lines += [f"extern const char *const {m.name.upper()}_NAMES[HH_N_{m.name.upper()}];" for m in MODES]
    lines += ["#endif"]
    return "\n".join(lines)


def c_plant_side_tables() -> str:
    """The C plant's side-channel tables (for ``plant_config.h``): its telemetry columns' names, the tunables
    with unit and range."""
    return "\n".join([
        "/* the side channel (core/shape.py): telemetry columns; tunables with unit and admissible range */",
        "typedef struct {", "    const char *name, *unit;", "    double lo, hi;", "    const char *description;",
        "} tunable;",
        "#ifdef PLANT_CONFIG_TABLES",
        "const char *const SIDE_NAMES[HH_NSIDE] = {" + ", ".join(f'"{c}"' for c in SIDE_PLANT_COLUMNS) + "};",
        "const tunable TUNABLES[HH_NTUNABLES] = {",
        *(f'    {{"{t.name}", "{t.unit}", {t.lo!r}, {t.hi!r}, "{t.description}"}},' for t in TUNABLES),
        "};", "#else", "extern const char *const SIDE_NAMES[HH_NSIDE];", "extern const tunable TUNABLES[HH_NTUNABLES];",
        "#endif"])
