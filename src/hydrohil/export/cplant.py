"""``hydrohil export c``: the plant as a standalone real-time C program for dedicated hardware.

The folder written holds the C core (the same sources the Python binding and the FMU compile), the
generated ``hh_params.h``, a generated ``plant_config.h`` (this export's parameter values, step, duration,
initial state and the ``[hil]`` settings with their ranges, taken from the pydantic schema), the plant
(``rt_plant.c``: clock, UDP protocol v1, watchdog, logs, verdict; ``protocol.c``, ``latency.c``) and a
``Makefile`` that honours ``CC`` (``make CC=aarch64-linux-gnu-gcc`` cross-compiles). The program needs
libc, libm and pthreads, no Python. It speaks protocol v1 exactly as ``hydrohil plant``
(docs/protocol.md) and writes the same ``plant_log.csv`` and ``timing.json``.

``hydrohil hil SCENARIO --plant c`` builds it (:func:`cached_plant`, cached by the hash of its sources)
and runs it in place of the Python plant.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import shutil
import subprocess
import typing
from pathlib import Path

from hydrohil import __version__
from hydrohil.core import shape
from hydrohil.errors import HydrohilError, InputError
from hydrohil.export.ctext import c_double as _c, c_string as _str
from hydrohil.export.paper_model import STRUCTURE_KEYS
from hydrohil.parameters import Parameters

HERE = Path(__file__).resolve().parent
RT = HERE / "c" / "rt"
RT_SOURCES = ("rt_plant.c", "rt_plant.h", "rt_options.c", "rt_log.c", "rt_report.c", "protocol.c", "protocol.h",
              "latency.c", "latency.h", "rt_side.c", "rt_side.h", "Makefile")
RIG_SOURCES = ("rt_rig.c",)                     # what the plant serves: the paper's rig ...
CIRCUIT_SOURCES = ("rt_circuit.c",)             # ... or a circuit (with its generated circuit.c)
RIG_MODEL_MK = "MODEL_CORE = hh_core.c\nMODEL_SOURCES = rt_rig.c rt_side.c paper_model.c\nMODEL_LINKED = paper_circuit.c\nMODEL_LINKED_INCLUDES = circuit.c\n"
EXECUTABLE = "hydrohil_plant"
# [hil] settings the plant reads (the others are the controller's, or the plant's own options: step, cpu)
PLANT_HIL_KEYS = ("command_scale", "watchdog_timeout", "safe_state", "hold_kp", "wait", "seed", "connect_timeout",
                  "link_timeout", "max_late_commands", "max_overruns", "max_stall", "max_watchdog_trips")


def _hil_table(hil) -> tuple[list[str], list[str]]:
    """C rows of the [hil] settings (key, kind, value, range, unit, options, description, from HilCfg) and the
    macros of their enum words."""
    from hydrohil.core.layout import _bounds
    fields = type(hil).model_fields
    rows, enums = [], []
    for key in PLANT_HIL_KEYS:
        f = fields[key]
        desc = f.description or ""
        m = re.search(r"\[([^\]]*)\]\s*$", desc)
        unit = m.group(1) if m else "-"
        text = desc[:m.start()].strip() if m else desc
        value = getattr(hil, key)
        if typing.get_origin(f.annotation) is typing.Literal:
            opts = typing.get_args(f.annotation)
            rows.append(f"    {{{_str(key)}, SET_ENUM, {opts.index(value)}, 0.0, {len(opts) - 1}.0, 0, 0, \"-\", "
                        f"{_str('|'.join(opts))}, {_str(text)}}},")
            enums += [f"#define HIL_{key.upper()}_{o.upper().replace('-', '_')} {i}" for i, o in enumerate(opts)]
        else:
            lo, hi, lo_s, hi_s = _bounds(f)
            kind = "SET_INT" if f.annotation is int else "SET_REAL"
            rows.append(f"    {{{_str(key)}, {kind}, {_c(value)}, {_c(-math.inf if lo is None else lo)}, "
                        f"{_c(math.inf if hi is None else hi)}, {int(lo_s)}, {int(hi_s)}, {_str(unit)}, NULL, "
                        f"{_str(text)}}},")
    return rows, enums


FAULT_SLOTS = ("FIELD_START", "FIELD_END", "FIELD_SENSOR", "FIELD_A", "FIELD_B")


def _fault_table() -> list[str]:
    """C rows of the fault types and their fields (simulation/faults.py, in the core's order): name, where the
    value goes (start, end, sensor, the parameters a, b), range, default (NaN: none), options, unit."""
    from hydrohil.core.layout import _bounds
    from hydrohil.parameters import _unit_of
    from hydrohil.simulation.faults import _CLASSES, FAULT_TYPES, PARAMS
    rows = []
    for name, cls in zip(FAULT_TYPES, _CLASSES):
        fields = []
        for key, f in cls.model_fields.items():
            if key == "type":
                continue
            slot = {"start": 0, "end": 1, "sensor": 2}.get(key, 3 + PARAMS[name].index(key) if key in PARAMS[name]
                                                            else None)
            unit = _unit_of(f) or "-"
            args = typing.get_args(f.annotation) if typing.get_origin(f.annotation) is typing.Literal else ()
            options = "|".join(str(a) for a in args)
            lo, hi, lo_s, hi_s = _bounds(f)
            dflt = math.nan if f.is_required() or f.default is None else f.default
            required = int(f.is_required())
            fields.append(f"{{{_str(key)}, {FAULT_SLOTS[slot]}, {_c(-math.inf if lo is None else lo)}, "
                          f"{_c(math.inf if hi is None else hi)}, {int(lo_s)}, {int(hi_s)}, {required}, "
                          f"{_c(dflt if isinstance(dflt, float) else math.nan)}, "
                          f"{_str(options) if options else 'NULL'}, {_str(unit)}}}")
        rows.append(f"    {{{_str(name)}, {len(fields)}, {{{', '.join(fields)}}}}},")
    return rows


def plant_config_h(params: Parameters, *, step: float = 5e-4, duration: float = 10.0, hil=None,
                   initial: dict | None = None, label: str = "custom") -> str:
    """``plant_config.h``: this export's parameter values, defaults of the plant's options, [hil] table."""
    from hydrohil.models.layout import SLOTS, pack
    from hydrohil.simulation.scenario import HilCfg
    hil = hil or HilCfg()
    initial = {"xp": params.linear.xp0, "xs": None, "p1": None, "p2": None, **(initial or {})}
    p = pack(params)
    schema = [s for s in SLOTS if s.schema]
    rows, enums = _hil_table(hil)
    lines = [f"/* plant_config.h: GENERATED by `hydrohil export c` (hydrohil {__version__}): do not edit; export again.",
             " * This export's parameter values (change them at run time with --set KEY=VALUE), the defaults of the",
             " * plant's options and its [hil] settings with their admissible ranges (from the pydantic schema).",
             " * The tables are compiled where PLANT_CONFIG_TABLES is defined (rt_options.c); the rest is shared. */",
             "#ifndef PLANT_CONFIG_H", "#define PLANT_CONFIG_H", "#include <math.h>", "#include \"hh.h\"", "",
             f"#define PLANT_DESCRIPTION {_str(f'hydrohil {__version__}, parameter set {label}')}",
             f"#define PLANT_STEP_DEFAULT {_c(step)}", f"#define PLANT_DURATION_DEFAULT {_c(duration)}", "",
             shape.c_plant_log_tables(), "", shape.c_plant_side_tables(), "",
             "enum { SET_REAL, SET_INT, SET_ENUM };",
             "typedef struct {", "    const char *key;", "    int kind;",
             "    double value, lo, hi;    /* default (enum: index) and admissible range */",
             "    int lo_strict, hi_strict;", "    const char *unit, *options, *description;", "} plant_setting;",
             "enum { " + ", ".join(f"HIL_{k.upper()}" for k in PLANT_HIL_KEYS) + ", HIL_N };", *enums, "",
             "/* the faults --fault accepts (simulation/faults.py): each field's place, range, default and options */",
             f"enum {{ {', '.join(FAULT_SLOTS)} }};",
             "typedef struct {", "    const char *key;", "    int slot;",
             "    double lo, hi;", "    int lo_strict, hi_strict, required;",
             "    double value;               /* default (NAN: none) */",
             "    const char *options, *unit;  /* options: the admissible values (sensor names or numbers) */",
             "} fault_field;",
             "typedef struct {", "    const char *type;", "    int nfields;", "    fault_field fields[6];",
             "} fault_kind;", "",
             "#ifdef PLANT_CONFIG_TABLES",
             "static const double PLANT_PARAMS[HH_NP_SCHEMA] = {"]
    lines += [f"    {_c(p[i])},   /* {s.key} [{s.unit}] */" for i, s in enumerate(schema)]
    lines += ["};", "/* enum parameters: their words (value = index); NULL for numbers */",
              "static const char *const PLANT_OPTIONS[HH_NP_SCHEMA] = {"]
    lines += [f"    {_str('|'.join(s.options)) if s.kind == 'enum' else 'NULL'},   /* {s.key} */" for s in schema]
    lines += ["};", "/* 1: fixed by this export (its generated model's structure: export/paper_model.py STRUCTURE_KEYS) */",
              "static const int PLANT_FIXED[HH_NP_SCHEMA] = {"]
    lines += [f"    {int(s.key in STRUCTURE_KEYS)},   /* {s.key} */" for s in schema]
    lines += ["};", "/* initial state: xp [m], xs [-], p1, p2 [Pa gauge] (NAN: at rest, SPEC §12.5) */",
              "static const double PLANT_INITIAL[4] = {" + ", ".join(
                  _c(math.nan if initial[k] is None else initial[k]) for k in ("xp", "xs", "p1", "p2")) + "};", "",
              "static const plant_setting HIL_SETTINGS[HIL_N] = {", *rows, "};", "",
              "static const fault_kind FAULT_KINDS[HH_NFAULT_TYPES] = {", *_fault_table(), "};",
              "#endif", "", "#endif", ""]
    return "\n".join(lines)


def fault_options(faults) -> list[str]:
    """The C plant's command-line options of a scenario's [[faults]]: ``--fault TYPE:key=value,...`` each
    (values as Python writes them, which the plant reads back exactly)."""
    out = []
    for f in faults:
        fields = [f"{k}={v if isinstance(v, str) else repr(float(v))}" for k, v in f.model_dump().items()
                  if k != "type" and v is not None]
        out += ["--fault", f"{f.type}:" + ",".join(fields)]
    return out


def scenario_options(s) -> dict:
    """The plant options a scenario (:class:`~hydrohil.simulation.scenario.Scenario`) fixes: step, duration,
    [hil] settings and initial state, as :func:`export_c` / :func:`cached_plant` take them."""
    return {"step": s.plant_step, "duration": s.duration, "hil": s.hil, "initial": s.initial.model_dump()}


def _prepare(out: str | Path, step: float, duration: float) -> Path:
    """The export folder with the core's sources and the plant's own (what every plant shares)."""
    from hydrohil.core.build import core_sources, write_headers
    if not 1e-6 < step <= 0.01:
        raise InputError(f"must be > 1e-06 and <= 0.01 s, got {step}", key="step")
    if not 0 < duration <= 1e6:
        raise InputError(f"must be > 0 and <= 1e6 s, got {duration}", key="duration")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("exists and is not a folder", source=str(out))
    out.mkdir(parents=True, exist_ok=True)
    write_headers()
    for src in core_sources():
        _copy(src, out / src.name)
    for name in RT_SOURCES:
        _copy(RT / name, out / name)
    return out


def export_c(params: Parameters, out: str | Path, *, step: float = 5e-4, duration: float = 10.0, hil=None,
             initial: dict | None = None, label: str = "custom") -> Path:
    """Write the standalone plant's sources and Makefile into the folder ``out``; returns it."""
    from hydrohil.export.paper_model import paper_model_files
    out = _prepare(out, step, duration)
    for name in RIG_SOURCES:
        _copy(RT / name, out / name)
    for name, text in paper_model_files(params, step).items():   # (its model: the circuit's generated C)
        _write(out / name, text)
    _write(out / "model.mk", RIG_MODEL_MK)
    _write(out / "plant_config.h", plant_config_h(params, step=step, duration=duration, hil=hil, initial=initial,
                                                           label=label))
    return out


def export_circuit_c(cs, out: str | Path) -> Path:
    """Write the standalone plant of a circuit scenario (:class:`hydrohil.circuits.scenario.CircuitScenario`) into
    ``out``: the circuit's generated C (``circuit.c``, the file ``simulate`` compiles), its export
    (``circuit_plant.h``: parameters, state at rest, drives, names, layout), ``rt_circuit.c`` behind the same
    plant loop as the paper's rig's; returns the folder."""
    from hydrohil.circuits.generate import generated
    from hydrohil.parameters import load_parameters
    from hydrohil.simulation.scenario import circuit_hil
    hil = circuit_hil(cs)
    out = _prepare(out, cs.step, cs.duration)
    for name in CIRCUIT_SOURCES:
        _copy(RT / name, out / name)
    _write(out / "model.mk", "MODEL_CORE = circuit.c\nMODEL_SOURCES = rt_circuit.c rt_side.c\n")
    source, _ = generated(cs.circuit)
    _write(out / "circuit.c", source)
    _write(out / "circuit_plant.h", circuit_plant_h(cs))
    config = plant_config_h(load_parameters("ferreira2004"), step=cs.step, duration=cs.duration, hil=hil,
                            label=f"circuit {cs.circuit.name}")
    config = config.replace(f"parameter set circuit {cs.circuit.name}", f"circuit {cs.circuit.name}")
    _write(out / "plant_config.h", config.replace("#define PLANT_CONFIG_H\n", "#define PLANT_CONFIG_H\n"
                                                  "#define PLANT_CIRCUIT 1   /* a circuit's plant: rt_circuit.c */\n", 1))
    return out


def circuit_plant_h(cs) -> str:
    """``circuit_plant.h``: a circuit scenario's export for rt_circuit.c: sizes, parameters, the state at rest and
    the inputs it starts with (a loop's: the command that holds its piston), each input's range and its drive
    as the steps where it changes, the loop's measured signal and sensor, the names, the wire layout and the
    plant_log.csv columns."""
    from hydrohil.circuits.build import compile_circuit
    from hydrohil.circuits.link import (PLANT_LOG_HEAD, PLANT_LOG_INTS, check_link_size, circuit_link,
                                        plant_log_columns, side_columns)
    from hydrohil.circuits.network import delay_slots, fault_steps
    from hydrohil.circuits.run import METHODS, input_table, start_state
    c, lay = cs.circuit, compile_circuit(cs.circuit).layout
    signals, inputs, layout = circuit_link(c, lay)
    check_link_size(signals, inputs, cs.source)          # (the plant's buffers are sized by the link's limits)
    y0, m0, u0 = start_state(c, h=cs.step, method=cs.method, rest=cs.rest, loop=cs.loop)
    drives = input_table(c, cs.n_steps, cs.step)
    changes = [(k, j, float(drives[k, j])) for k in range(1, len(drives)) for j in range(len(inputs))
               if drives[k, j] != drives[k - 1, j]]
    prm = [c.input_param(n) for n, _ in inputs]
    loop = cs.loop
    commanded = (1 << lay.inputs.index(loop.command) if loop is not None else
                 cs.commands.mask(c) if cs.commands is not None else 0)
    words, first = [], []
    for md in lay.modes:
        first.append(len(words))
        words += list(lay.mode_names[md])
    plog = plant_log_columns(signals, inputs)
    kinds = ["PLOG_INT" if name in PLANT_LOG_INTS else "PLOG_REAL" for name in plog]
    q = lambda text: _str(str(text))                                       # noqa: E731
    arr = lambda ctype, name, items, fmt=_c: [                             # noqa: E731
        f"static const {ctype} {name}[{max(len(items), 1)}] = {{" + ", ".join(fmt(v) for v in (items or [0])) + "};"]
    lines = [f"/* circuit_plant.h: GENERATED by `hydrohil export c` (hydrohil {__version__}) from {cs.source}: do not "
             "edit; export again. */", "#ifndef CIRCUIT_PLANT_H", "#define CIRCUIT_PLANT_H", "#include <stdint.h>", "",
             f"#define CIRCUIT_NAME {q(c.name)}", f"#define CIRCUIT_METHOD {METHODS.index(cs.method)}",
             f"#define CIRCUIT_STEP {_c(cs.step)}", f"#define CIRCUIT_LAYOUT {layout}U",
             f"enum {{ CIRCUIT_NP = {len(lay.params)}, CIRCUIT_NY = {len(y0)}, "
             f"CIRCUIT_NM = {max(len(lay.modes), 1)}, CIRCUIT_NU = {max(len(inputs), 1)}, "
             f"CIRCUIT_NLOG = {len(lay.log_columns)}, CIRCUIT_NSIGNALS = {len(signals)}, "
             f"CIRCUIT_NINPUTS = {len(inputs)}, CIRCUIT_NSTATES = {len(lay.states)}, CIRCUIT_NMODES = {len(lay.modes)}, "
             f"CIRCUIT_NDRIVES = {len(changes)}, LOG_HEAD = {len(PLANT_LOG_HEAD)} }};",
             "enum { " + ", ".join(f"CPLOG_{c.upper()}" for c in PLANT_LOG_HEAD) + " };   /* plant_log.csv's first columns */",
             f"#define CIRCUIT_LOOP_COMMAND {lay.inputs.index(loop.command) if loop is not None else -1}",
             f"#define CIRCUIT_COMMANDED {commanded}U   /* the inputs the controller drives from the start (mask) */",
             f"#define CIRCUIT_MEASURE {lay.log_columns.index(loop.measure) if loop is not None else -1}",
             f"#define CIRCUIT_HOLDS {int(cs.link[2] > 0)}   /* 1: the scenario's safe state: \"hold\" */",
             f"#define CIRCUIT_HAS_SENSOR {int(loop is not None and loop.sensor is not None)}",
             f"#define CIRCUIT_SENSOR_SEED {loop.seed if loop is not None else 0}ULL",
             f"#define CIRCUIT_LOG_T {lay.log_columns.index('t')}   /* the log row's time: first, the signals after it */",
             f"#define CIRCUIT_NSTEPS {max(cs.n_steps, 1)}LL   /* the scenario's steps (its drives' table) */",
             f"#define CIRCUIT_REPEAT {int(cs.repeat)}   /* 1: the drives start again every CIRCUIT_NSTEPS (a panel session) */",
             f"enum {{ CIRCUIT_NSIDE = {len(side_columns(signals, inputs))} }};   /* the live panel's telemetry columns */",
             ""]
    lines += arr("double", "CIRCUIT_P", list(lay.values()))
    lines += arr("double", "CIRCUIT_Y0", list(y0))       # (the states, then the delay lines' memory)
    lines += arr("int64_t", "CIRCUIT_M0", list(m0[:max(len(lay.modes), 1)]), lambda v: str(int(v)))
    lines += arr("double", "CIRCUIT_U0", list(u0[:max(len(inputs), 1)]))
    lines += arr("double", "CIRCUIT_DRIVE0", list(drives[0][:max(len(inputs), 1)]))
    lines += arr("int64_t", "CIRCUIT_DRIVE_STEP", [k for k, _, _ in changes], str)
    lines += arr("int", "CIRCUIT_DRIVE_INPUT", [j for _, j, _ in changes], str)
    lines += arr("double", "CIRCUIT_DRIVE_VALUE", [v for _, _, v in changes])
    lines += arr("double", "CIRCUIT_LO", [p.lo for p in prm])
    lines += arr("double", "CIRCUIT_HI", [p.hi for p in prm])
    sensor = loop.sensor_vector(cs.step) if loop is not None and loop.sensor else [0.0] * 7
    slots = [f[-1] for f in loop.sensor_faults] if loop is not None and loop.sensor else []
    lines += [f"enum {{ CIRCUIT_SENSOR_N = {len(sensor)}, CIRCUIT_SENSOR_NF = {len(slots)} }};   /* hc_sensed's "
              "sensor: its transducer, its faults */"]
    lines += arr("double", "CIRCUIT_SENSOR", sensor)
    lines += arr("int", "CIRCUIT_SENSOR_SLOT", slots, str)      # (each fault's place in [[faults]]: its stream)
    sender = loop if loop is not None else cs.commands   # the network faults on its commands (circuits/network.py)
    network = sender.network if sender is not None else []
    cap = delay_slots(network, cs.step)
    lines += [f"enum {{ CIRCUIT_NNET = {len(network)}, CIRCUIT_FIFO_CAP = {cap} }};   /* network faults; "
              "network_delay's line (slots) */"]
    lines += arr("int", "CIRCUIT_NET_TYPE", [f"HH_FAULT_{kind.upper()}" for kind, *_ in network], str)
    lines += arr("double", "CIRCUIT_NET_VALUE", [a for _, _, _, a, _ in network])
    lines += arr("int", "CIRCUIT_NET_SLOT", [slot for *_, slot in network], str)
    steps = [fault_steps(start, end, cs.step) for _, start, end, _, _ in network]
    lines += arr("int64_t", "CIRCUIT_NET_K0", [k0 for k0, _ in steps], lambda v: f"{v}LL")
    lines += arr("int64_t", "CIRCUIT_NET_K1", [k1 for _, k1 in steps], lambda v: f"{v}LL")
    lines += arr("char *const", "CIRCUIT_STATE_NAMES", list(lay.states), q)
    lines += arr("char *const", "CIRCUIT_MODE_NAMES", list(lay.modes), q)
    lines += arr("char *const", "CIRCUIT_MODE_WORDS", words, q)
    lines += arr("int", "CIRCUIT_MODE_FIRST", first, str)
    lines += arr("char *const", "CIRCUIT_PLOG_NAMES", plog, q)
    lines += arr("char *const", "CIRCUIT_INPUT_NAMES", [n for n, _ in inputs], q)
    lines += arr("char *const", "CIRCUIT_INPUT_UNITS", [u for _, u in inputs], q)
    lines += arr("char *const", "CIRCUIT_SIDE_NAMES", list(side_columns(signals, inputs)), q)
    lines += arr("int", "CIRCUIT_PLOG_KINDS", kinds, str)
    return "\n".join(lines + ["", "#endif", ""])


def _copy(src: Path, dst: Path) -> None:
    _write(dst, src.read_text())


def _write(path: Path, text: str) -> None:
    """Write unless unchanged (keeps make's timestamps meaningful)."""
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def build(folder: str | Path, *, cc: str | None = None, env: dict | None = None) -> Path:
    """``make`` in an exported folder (``CC`` = ``cc``, else the environment's, else this Python's compiler;
    the environment's CFLAGS etc. apply unless ``env`` replaces it); returns the executable."""
    import shlex
    from hydrohil.core.build import c_compiler
    folder = Path(folder)
    env = dict(os.environ if env is None else env)
    cc = cc or env.get("CC") or ("cc" if shutil.which("cc") else c_compiler())   # (make's own default first:
    # a plain `make` in the folder afterwards finds the same compiler and rebuilds nothing)
    if not shlex.split(cc) or shutil.which(shlex.split(cc)[0]) is None:
        raise InputError(f"no C compiler '{cc}' found: the standalone plant is built with make and a C compiler",
                         key="CC")
    make = shutil.which("make")
    if make is None:
        raise InputError("no 'make' found: install it (Debian: apt-get install make)")
    r = subprocess.run([make, "-s", "-C", str(folder), f"CC={cc}"], capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise HydrohilError(f"building the standalone plant failed in {folder} (CC={cc}):\n{r.stdout}{r.stderr}")
    return folder / EXECUTABLE


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hydrohil" / "c-plant"


def cached_plant(params: Parameters, *, step: float, duration: float, hil=None, initial: dict | None = None,
                 label: str = "custom") -> Path:
    """The executable of this configuration, exported and built once into the cache (keyed by the hash of
    all its sources: a changed core, plant or parameter set builds anew)."""
    return _cached(lambda tmp: export_c(params, tmp, step=step, duration=duration, hil=hil, initial=initial,
                                        label=label))


def cached_circuit_plant(cs) -> Path:
    """The standalone plant of a circuit scenario (:func:`export_circuit_c`), built once into the cache."""
    return _cached(lambda tmp: export_circuit_c(cs, tmp))


def _cached(export) -> Path:
    """``export(folder)`` into a temporary folder, keyed by the hash of every file it wrote and the compiler:
    built once into the cache, its executable returned."""
    import tempfile
    from hydrohil.core.build import c_compiler
    cc = c_compiler()                 # this machine's compiler, default flags: the cache never holds a cross build
    env = {k: v for k, v in os.environ.items() if k not in ("CC", "CFLAGS", "CPPFLAGS", "LDFLAGS", "LDLIBS")}
    target = subprocess.run([cc, "-dumpmachine"], capture_output=True, text=True).stdout.strip()
    with tempfile.TemporaryDirectory() as tmp:
        export(tmp)
        digest = hashlib.sha256(f"{cc}|{target}\0".encode())
        for f in sorted(Path(tmp).iterdir()):
            digest.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
        folder = cache_dir() / digest.hexdigest()[:16]
        exe = folder / EXECUTABLE
        if exe.exists():
            return exe
        part = folder.with_name(folder.name + f".part{os.getpid()}")
        shutil.rmtree(part, ignore_errors=True)
        shutil.copytree(tmp, part)
    build(part, cc=cc, env=env)
    try:
        part.rename(folder)
    except OSError:                # another process built the same configuration meanwhile
        shutil.rmtree(part, ignore_errors=True)
    return exe
