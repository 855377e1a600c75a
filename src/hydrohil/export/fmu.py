"""``hydrohil export fmu``: the plant as an FMU (FMI 2.0 or 3.0, Co-Simulation and Model Exchange), built on the spot.

The FMU holds its C sources (the core, ``hh_params.h``, a generated ``config.h`` with the value references
and start values, the instance layer ``plant_fmu.c`` and the FMI wrapper of its version) and a shared
library for this platform (``binaries/linux64`` for FMI 2, ``binaries/x86_64-linux`` for FMI 3) compiled
with the core's flags. Variables: every parameter of the schema (tunable at initialisation, with unit,
description, start, min/max), the internal step and the initial state (xp0; at rest by default, at_rest = 0:
the spool at xs0), the calculated parameter ``xs_rest`` (the spool offset that holds the piston); inputs ``u``
(ū, saturated to [-1, 1]), ``F_load`` [N], ``ps`` [Pa]; outputs ``xp``, ``vp``, ``p1``, ``p2``, ``xs``, ``ff`` and the Integer
outputs ``travel_mode``, ``friction_mode``, ``spool_mode``, ``encoder`` [counts]. The standard's headers
come from FMPy's installed package (``fmpy/c-code``).
"""

from __future__ import annotations

import hashlib
import json
import math
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

from hydrohil import __version__
from hydrohil.core import shape
from hydrohil.errors import InputError
from hydrohil.export.ctext import c_array, c_double
from hydrohil.export.paper_model import STRUCTURE_KEYS
from hydrohil.models.layout import SLOTS, pack
from hydrohil.parameters import Parameters

MODEL_IDENTIFIER = "hydrohil_plant"
HERE = Path(__file__).resolve().parent
CORE = HERE.parent / "core"
# the platforms an FMU carries a binary for: (FMI 2's folder, FMI 3's folder, the library's suffix, the compiler
# that builds it on a machine of another kind and its Debian package: .ci/run installs them). FMI 2 names no
# folder for aarch64: its binary is in FMI 3's, which an FMI 2 importer on such a machine must be pointed to.
TARGETS = {"x86_64-linux": ("linux64", "x86_64-linux", ".so", "x86_64-linux-gnu-gcc", "gcc-x86-64-linux-gnu"),
           "aarch64-linux": ("aarch64-linux", "aarch64-linux", ".so", "aarch64-linux-gnu-gcc", "gcc-aarch64-linux-gnu"),
           "x86_64-windows": ("win64", "x86_64-windows", ".dll", "x86_64-w64-mingw32-gcc", "gcc-mingw-w64-x86-64")}
FMI_HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
               3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
METHOD_RK3 = 2
# the C files of the paper's rig's FMU (the shared FMI layer's besides): the core, the model generated from its
# circuit and what attaches it to the core's loop (export/paper_model.py), the instance
RIG_UNITS = ("hh_core.c", "paper_circuit.c", "paper_model.c", "plant_fmu.c")
CIRCUIT_UNITS = ("circuit.c", "plant_fmu.c")     # a circuit's: its generated C (with the core's parts it uses)

# value references beyond the schema's parameters (those are 0 .. n-1, in schema order): name, config.h's macro
# of it (VR_...), unit, description, min, max, type (start values: _extra_starts)
EXTRA_PARAMETERS = (
    ("step", "STEP", "s", "internal fixed step of the hybrid model (RK3); a communication step of any size takes the "
     "internal steps that end by its communication point", 1e-7, 0.01, "real"),
    ("initial.xp", "XP0", "m", "the piston's initial position (linear.xp0 is its default, and the linearisation's "
     "point)", 0.0, None, "real"),
    ("initial.xs", "XS0", "1", "the spool's initial position (normalised) when initial.at_rest is false; the chamber "
     "pressures then balance the chambers' flows at it", -1.0, 1.0, "real"),
    ("initial.at_rest", "AT_REST", "", "true: start at rest (SPEC 12.5): the spool at the offset that holds the "
     "piston (xs_rest), the chamber pressures balancing the flows and the load; false: with the spool at "
     "initial.xs", None, None, "bool"),
)
CALCULATED = (("xs_rest", "1", "the spool offset that holds the piston at rest: an open-loop u held here keeps it "
               "there", 250),)
INPUTS = (("u", "1", "normalised valve command; saturated to [-1, 1] as the rig's command path does", 200, None,
           None),
          ("F_load", "N", "external load force on the piston, positive opposes extension (replaces load.force)",
           201, None, None),
          ("ps", "Pa", "supply pressure, gauge (replaces supply.ps)", 202, None, 1e8))
# outputs: the plant's quantities and modes as core/shape.py describes them, with the FMU's value references
REAL_OUTPUTS = tuple((name, "1" if shape.QUANTITIES[name].unit == "-" else shape.QUANTITIES[name].unit,
                      shape.QUANTITIES[name].description, vr)
                     for name, vr in (("xp", 300), ("vp", 301), ("p1", 302), ("p2", 303), ("xs", 304), ("ff", 305)))
# the modes as Enumerations of their names (their type: <Mode>Mode, its items the core's values in order)
MODE_OUTPUTS = tuple((f"{m.name}_mode", f"{m.name.capitalize()}Mode", vr) for m, vr in zip(shape.MODES, (310, 311, 312)))
MODE_TYPES = {f"{m.name.capitalize()}Mode": [(v.name, v.description) for v in m.values] for m in shape.MODES}
INT_OUTPUTS = (("encoder", "encoder reading [counts] (sensors.encoder_resolution; 0: ideal, 1 nm counts)", 313),)
# Model Exchange: the continuous states are the core's (core/shape.py's STATES, in its order): the outputs above
# and two locals (the spool's speed, the bristles); their derivatives der(x) from VR_DER0, the statechart's guards
# (event indicators) from VR_EVENT0; nominal: a state's typical size (the importer's absolute tolerance: its
# relative one times it)
STATE_LOCALS = (("vs", 306), ("z", 307))
STATE_NOMINALS = {"xs": 1.0, "vs": 100.0, "p1": 1e6, "p2": 1e6, "xp": 1e-2, "vp": 1e-2, "z": 1e-5}
VR_DER0, VR_EVENT0 = 400, 450
# eq 3's coefficients: k1, k2 of a pseudo-section in (l/min)/sqrt(bar), k3..k5 under its square root
K_UNITS = ("(l/min)/sqrt(bar)", "(l/min)/sqrt(bar)", "(l/min)^2/bar", "(l/min)^2/bar", "(l/min)^2/bar")
# C's kinds of a parameter (config.h's PLANT_KIND): what its getters and setters are
KIND_CODES = {"real": 0, "int": 1, "bool": 2, "enum": 3}


def _paper_guards(params: Parameters, step: float) -> list[str]:
    """The guards of the parameter set's circuit's statechart (its event indicators), by name."""
    from hydrohil.simulation.generated_model import core_tables
    return list(core_tables(params, step).compiled.layout.guards)


def _slot_type(s) -> str:
    """An FMU variable's type of schema slot ``s``: real, int (a whole number of a set: load.gravity_direction),
    bool, or enum (words: an Enumeration named after its key)."""
    return {"enum": "enum", "integer": "int", "boolean": "bool"}.get(s.kind, "real")


def _enum_type(key: str) -> str:
    """The Enumeration type of an option parameter: "cylinder.bulk_modulus" -> "BulkModulus"."""
    return "".join(w.capitalize() for w in key.rsplit(".", 1)[-1].split("_"))


def _slot_unit(s) -> str:
    if s.key.startswith(("valve.k[", "valve.kt[")):
        return K_UNITS[int(s.key.split("[")[1].rstrip("]")) - 1]
    return "1" if s.unit in ("-", "") else s.unit


def _extra_starts(params: Parameters, step: float) -> dict[str, float]:
    """Start values of EXTRA_PARAMETERS for this export."""
    return {"step": step, "initial.xp": params.linear.xp0, "initial.xs": 0.0, "initial.at_rest": 1.0}


def _schema_slots():
    return [s for s in SLOTS if s.schema]


def _fmt(v: float) -> str:
    return repr(float(v))


def config_h(params: Parameters, step: float, token: str) -> str:
    """``config.h``: value references, names and start values of this export."""
    slots = _schema_slots()
    p = pack(params)
    starts = [p[i] for i in range(len(slots))]
    extras = _extra_starts(params, step)
    starts += [extras[name] for name, *_ in EXTRA_PARAMETERS]
    names = [s.key for s in slots] + [name for name, *_ in EXTRA_PARAMETERS]
    kinds = [_slot_type(s) for s in slots] + [e[6] for e in EXTRA_PARAMETERS]
    n = len(slots)
    lines = ["/* config.h: GENERATED by `hydrohil export fmu` (hydrohil " + __version__ + "): do not edit. */",
             "#ifndef PLANT_CONFIG_H", "#define PLANT_CONFIG_H", "",
             f'#define PLANT_TOKEN "{token}"', f"#define PLANT_METHOD {METHOD_RK3}   /* HH_RK3 */",
             f"#define PLANT_NPAR {len(names)}"]
    lines += [f"#define VR_{macro} {n + k}" for k, (_, macro, *_) in enumerate(EXTRA_PARAMETERS)]
    lines += [f"#define VR_{name.upper()} {vr}" for name, _, _, vr in CALCULATED]
    lines += [f"#define VR_{name.upper()} {vr}" for name, _, _, vr, *_ in INPUTS]
    lines += [f"#define VR_{name.upper()} {vr}" for name, _, _, vr in REAL_OUTPUTS]
    lines += [f"#define VR_{name.upper().replace('_MODE', '')} {vr}" for name, _, vr in MODE_OUTPUTS + INT_OUTPUTS]
    lines += [f"#define VR_{name.upper()} {vr}" for name, vr in STATE_LOCALS]
    lines += [f"#define VR_DER0 {VR_DER0}   /* Model Exchange: der(x) of the core's states, in their order */",
              f"#define VR_EVENT0 {VR_EVENT0}   /* Model Exchange: the event indicators */",
              f"#define PLANT_NX {len(shape.STATES)}", f"#define PLANT_NZ {len(_paper_guards(params, step))}"]
    lines += ["/* a parameter's kind: its getters and setters (Real, Integer, Boolean, Enumeration) */",
              "enum { " + ", ".join(f"PLANT_KIND_{k.upper()} = {v}" for k, v in KIND_CODES.items()) + " };",
              "", "static const double PLANT_START[PLANT_NPAR] = {"]
    lines += [f"    {_fmt(v)},   /* {k} */" for k, v in zip(names, starts)]
    lines += ["};", "static const char *const PLANT_NAMES[PLANT_NPAR] = {"]
    lines += [f'    "{k}",' for k in names]
    lines += ["};", "static const double PLANT_NOMINAL[PLANT_NX] = {" +
              ", ".join(_fmt(STATE_NOMINALS[s.name]) for s in shape.STATES) + "};"]
    lines += ["static const int PLANT_KIND[PLANT_NPAR] = {"]
    lines += [f"    PLANT_KIND_{k.upper()},   /* {name} */" for name, k in zip(names, kinds)]
    lines += ["};", "", "#endif", ""]
    return "\n".join(lines)


def _bound(v: float | None) -> float | None:
    return None if v is None else float(v)


def fmu_sources(units, fmi: int) -> list[str]:
    """The C files an FMU's binary is built from, in sources/: its model's ``units`` and the shared FMI layer. Each
    compiles on its own with no flag or file beyond sources/ (core/hh_compat.h: the same numbers from any build)."""
    return [*units, "fmu_instance.c", f"fmi{fmi}Functions.c"]


def build_description_xml(sources: list[str]) -> str:
    """FMI 3's sources/buildDescription.xml: one build configuration of the C99 ``sources``, no definitions."""
    files = "\n".join(f"      <SourceFile name={quoteattr(name)}/>" for name in sources)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{MODEL_IDENTIFIER}">\n    <SourceFileSet language="C99">\n'
            f"{files}\n    </SourceFileSet>\n  </BuildConfiguration>\n</fmiBuildDescription>\n")


def host_target(cc: str) -> str:
    """The platform (a key of :data:`TARGETS`) compiler ``cc`` builds for (its -dumpmachine)."""
    machine = subprocess.run([cc, "-dumpmachine"], capture_output=True, text=True).stdout.strip()
    arch, _, rest = machine.partition("-")
    system = "windows" if "mingw" in rest or "windows" in rest else "linux" if "linux" in rest else rest
    target = f"{arch}-{system}"
    if target not in TARGETS:
        raise InputError(f"the C compiler '{cc}' builds for {machine}: an FMU's binaries are for "
                         f"{', '.join(TARGETS)}", key="CC")
    return target


def fmu_compilers(cc: str | None = None, platforms=None) -> dict[str, str]:
    """Target -> compiler of an FMU's binaries: this machine's (``cc``, default this Python's), and each other
    platform of :data:`TARGETS` whose cross compiler is on the PATH; ``platforms`` (names of TARGETS, or "host":
    this machine's) asks for those (a missing compiler named)."""
    from hydrohil.core.build import c_compiler
    cc = cc or c_compiler()
    if shutil.which(cc) is None:
        raise InputError(f"no C compiler '{cc}' found: the FMU's binary is built on the spot")
    host = host_target(cc)
    found = {host: cc, **{t: spec[3] for t, spec in TARGETS.items() if t != host and shutil.which(spec[3])}}
    if platforms is None:
        return found
    platforms = [host if p == "host" else p for p in platforms]
    unknown = [p for p in platforms if p not in TARGETS]
    if unknown:
        raise InputError(f"no platform {unknown[0]!r}: one of {', '.join(TARGETS)}", key="platforms")
    missing = [p for p in platforms if p not in found]
    if missing:
        raise InputError(f"no compiler for {missing[0]}: {TARGETS[missing[0]][3]} (Debian: apt-get install "
                         f"{TARGETS[missing[0]][4]})", key="platforms")
    return {p: found[p] for p in platforms}


def model_description(params: Parameters, fmi: int, step: float, token: str) -> str:
    """modelDescription.xml of FMI ``fmi`` (2 or 3)."""
    slots = _schema_slots()
    p = pack(params)
    vars_: list[dict] = []
    enums: dict[str, list] = dict(MODE_TYPES)
    for i, s in enumerate(slots):
        kind = _slot_type(s)
        lo, hi = (p[i], p[i]) if s.key in STRUCTURE_KEYS else (s.lo, s.hi)   # (the export's structure: fixed)
        desc = s.description + (" (fixed by this export: its generated model's structure)"
                                if s.key in STRUCTURE_KEYS else "")
        var = dict(name=s.key, vr=i, causality="parameter", variability="fixed", initial="exact", desc=desc,
                   unit=_slot_unit(s), start=p[i], lo=lo, hi=hi, kind=kind,
                   display="Hz" if s.key.endswith(".wn") else None)        # (a natural frequency in Hz)
        if kind == "enum":
            var["type"] = _enum_type(s.key)
            enums[var["type"]] = [(o, "") for o in s.options]
        vars_.append(var)
    n = len(slots)
    extras = _extra_starts(params, step)
    for k, (name, _, unit, desc, lo, hi, kind) in enumerate(EXTRA_PARAMETERS):
        hi = params.cylinder.stroke if name == "initial.xp" else hi
        vars_.append(dict(name=name, vr=n + k, causality="parameter", variability="fixed", initial="exact",
                          desc=desc, unit=unit, start=extras[name], lo=lo, hi=hi, kind=kind))
    for name, unit, desc, vr in CALCULATED:
        vars_.append(dict(name=name, vr=vr, causality="calculatedParameter", variability="fixed",
                          initial="calculated", desc=desc, unit=unit, start=None, lo=None, hi=None, kind="real"))
    calculated = [i for i, v in enumerate(vars_) if v["causality"] == "calculatedParameter"]
    starts = {"u": 0.0, "F_load": params.load.force, "ps": params.supply.ps}
    for name, unit, desc, vr, lo, hi in INPUTS:
        vars_.append(dict(name=name, vr=vr, causality="input", variability="continuous", initial=None, desc=desc,
                          unit=unit, start=starts[name], lo=lo, hi=hi, kind="real"))
    outputs = []
    for name, unit, desc, vr in REAL_OUTPUTS:
        outputs.append(len(vars_))
        vars_.append(dict(name=name, vr=vr, causality="output", variability="continuous", initial=None,
                          desc=desc, unit=unit, start=None, lo=None, hi=None, kind="real"))
    for (name, enum, vr), mode in zip(MODE_OUTPUTS, shape.MODES):
        outputs.append(len(vars_))
        vars_.append(dict(name=name, vr=vr, causality="output", variability="discrete", initial=None,
                          desc=f"the {mode.name} mode", unit="", start=None, lo=None, hi=None, kind="enum",
                          type=enum))
    for name, desc, vr in INT_OUTPUTS:
        outputs.append(len(vars_))
        vars_.append(dict(name=name, vr=vr, causality="output", variability="discrete", initial=None,
                          desc=desc, unit="", start=None, lo=None, hi=None, kind="int"))
    locals_ = dict(STATE_LOCALS)
    for s in shape.STATES:                       # (Model Exchange's states: an output, or a local of its own)
        if s.name in locals_:
            vars_.append(dict(name=s.name, vr=locals_[s.name], causality="local", variability="continuous",
                              initial=None, desc=shape.QUANTITIES[s.name].description,
                              unit=_real_unit(shape.QUANTITIES[s.name].unit), start=None, lo=None, hi=None,
                              kind="real"))
    index = {v["name"]: i for i, v in enumerate(vars_)}
    me = {"states": [index[s.name] for s in shape.STATES], "derivatives": [], "indicators": []}
    for k, s in enumerate(shape.STATES):
        vars_[index[s.name]]["nominal"] = STATE_NOMINALS[s.name]
        me["derivatives"].append(len(vars_))
        unit = _real_unit(shape.QUANTITIES[s.name].unit)
        vars_.append(dict(name=f"der({s.name})", vr=VR_DER0 + k, causality="local", variability="continuous",
                          initial=None, desc=f"d/dt of {s.name}", unit=_per_second(unit),
                          start=None, lo=None, hi=None, kind="real", derivative=index[s.name]))
    for g, name in enumerate(_paper_guards(params, step)):
        me["indicators"].append(len(vars_))
        vars_.append(dict(name=f"guard.{name}", vr=VR_EVENT0 + g, causality="local", variability="continuous",
                          initial=None, desc=f"the statechart's guard {name}: >= 0 while its mode holds (1 in "
                          "the other modes); its zero crossing an event", unit="1", start=None, lo=None, hi=None,
                          kind="real"))
    return _description_xml(vars_, outputs, calculated, fmi, step, token, enums,
                            "hydrohil: servo-solenoid valve + differential cylinder, hybrid model (Ferreira et al., "
                            "Part 2), parameter set exported with its values", fmu_sources(RIG_UNITS, fmi), me=me)


def _per_second(unit: str) -> str:
    """A rate's unit: "Pa" -> "Pa/s", "m/s" -> "m/s^2", "1" -> "1/s"."""
    return f"{unit}^2" if unit.endswith("/s") else f"{unit}/s"


def _real_unit(unit: str) -> str:
    """A Real's unit in the FMU: hydrohil's SI name, "1" for a dimensionless one ("-")."""
    return "1" if unit in ("-", "") else unit


def _unit_definitions(units) -> list[str]:
    """<UnitDefinitions>' lines of the ``units`` (their SI names as hydrohil writes them): each with its base units'
    exponents (none where they are not whole, a valve's (l/min)/sqrt(bar)) and the display units an engineer
    reads (circuits.units' catalogue units of that SI unit: bar, l/min, mm, rpm, ...)."""
    from hydrohil.circuits.units import ALIASES, DISPLAY, UNITS, dimensions
    out = ["  <UnitDefinitions>"]
    for u in sorted(set(units)):
        dims = dimensions(u)
        si = u.replace("^", "")
        inverse = lambda f: float(f"{1.0 / f:.15g}")                      # noqa: E731  (1/1e-9: 1e9)
        shown = [(name, inverse(f)) for name, (f, s) in UNITS.items() if s == si and name != si and name.isascii()
                 and name not in ("-",)]
        shown += [(name, inverse(f)) for (name, s), f in ALIASES.items() if s == si]
        factor, name = DISPLAY.get(si, (1.0, si))
        if name != si and name not in dict(shown):          # (the displayUnit a variable names)
            shown.append((name, factor))
        if u in ("1", "-"):
            shown = [("%", 100.0)]
        rows = []
        if dims is not None:
            exps, factor = dims
            base = {**exps, **({"factor": _fmt(factor)} if factor != 1.0 else {})}
            rows.append("      <BaseUnit" + "".join(f' {k}="{v}"' for k, v in base.items()) + "/>")
        rows += [f"      <DisplayUnit name={quoteattr(name)} factor=\"{_fmt(f)}\"/>" for name, f in shown]
        out += ([f"    <Unit name={quoteattr(u)}>", *rows, "    </Unit>"] if rows else [f"    <Unit name={quoteattr(u)}/>"])
    out.append("  </UnitDefinitions>")
    return out


def _type_definitions(enums: dict, fmi: int) -> list[str]:
    """<TypeDefinitions>' lines: an Enumeration type per name of ``enums`` (name -> [(item, description)]), its
    items valued 0, 1, ... (the C core's codes)."""
    if not enums:
        return []
    out = ["  <TypeDefinitions>"]
    for name, items in enums.items():
        rows = [f"      <Item name={quoteattr(item)} value=\"{k}\"" + (f" description={quoteattr(d)}" if d else "")
                + "/>" for k, (item, d) in enumerate(items)]
        if fmi == 2:
            out += [f"    <SimpleType name={quoteattr(name)}>", "      <Enumeration>",
                    *("  " + r for r in rows), "      </Enumeration>", "    </SimpleType>"]
        else:
            out += [f"    <EnumerationType name={quoteattr(name)}>", *rows, "    </EnumerationType>"]
    out.append("  </TypeDefinitions>")
    return out


# the unit a person reads a value of an SI unit in (a Real's displayUnit: circuits.units.DISPLAY's)
def _display_unit(unit: str) -> str | None:
    from hydrohil.circuits.units import display
    return display(unit.replace("^", ""))[1] if display(unit.replace("^", ""))[1] != unit.replace("^", "") else None


def _description_xml(vars_: list[dict], outputs: list[int], calculated: list[int], fmi: int, step: float, token: str,
                     enums: dict, description: str, sources: list[str], feedthrough: bool = False,
                     me: dict | None = None) -> str:
    """modelDescription.xml of FMI ``fmi`` from the variables (dicts: name, vr, causality, variability, initial,
    desc, unit, start, lo, hi, kind "real"/"int"/"bool"/"enum" (with its "type", one of ``enums``: name ->
    [(item, description)]); a state's "nominal", a derivative's "derivative": its state's index in ``vars_``),
    the indices of the outputs and calculated parameters, the C files the binary is built from (``sources``: FMI
    2's <SourceFiles>; FMI 3 declares them in sources/buildDescription.xml, :func:`build_description_xml`);
    ``feedthrough``: the outputs may depend on the inputs directly (their dependencies not declared). ``me``: the
    Model Exchange interface beside Co-Simulation's, {"states", "derivatives", "indicators": indices in
    ``vars_``}. Every Real has a unit (its UnitDefinition: base units, display units; "1": dimensionless) and,
    where an engineer reads another, a displayUnit (bar, mm, l/min, rpm)."""
    deps = "" if feedthrough else ' dependencies=""'
    def attrs(d: dict) -> str:
        return " ".join(f'{k}={quoteattr(str(v))}' for k, v in d.items() if v is not None)
    me = me or {"states": [], "derivatives": [], "indicators": []}
    files = ["    <SourceFiles>", *[f"      <File name={quoteattr(name)}/>" for name in sources], "    </SourceFiles>"]
    out = ['<?xml version="1.0" encoding="UTF-8"?>']
    head = dict(modelName=MODEL_IDENTIFIER, description=description, generationTool=f"hydrohil {__version__}",
                variableNamingConvention="structured")
    if fmi == 2:
        out.append(f'<fmiModelDescription fmiVersion="2.0" guid="{token}" '
                   f'numberOfEventIndicators="{len(me["indicators"])}" {attrs(head)}>')
        if me["states"]:
            out.append(f'  <ModelExchange modelIdentifier="{MODEL_IDENTIFIER}" completedIntegratorStepNotNeeded="false" '
                       'canGetAndSetFMUstate="true" canSerializeFMUstate="true" canNotUseMemoryManagementFunctions="true">')
            out += [*files, "  </ModelExchange>"]
        out.append(f'  <CoSimulation modelIdentifier="{MODEL_IDENTIFIER}" canHandleVariableCommunicationStepSize="true" '
                   'canGetAndSetFMUstate="true" canSerializeFMUstate="true" canNotUseMemoryManagementFunctions="true">')
        out += [*files, "  </CoSimulation>"]
    else:
        out.append(f'<fmiModelDescription fmiVersion="3.0" instantiationToken="{token}" {attrs(head)}>')
        if me["states"]:
            out.append(f'  <ModelExchange modelIdentifier="{MODEL_IDENTIFIER}" needsCompletedIntegratorStep="true" '
                       'canGetAndSetFMUState="true" canSerializeFMUState="true"/>')
        out.append(f'  <CoSimulation modelIdentifier="{MODEL_IDENTIFIER}" canHandleVariableCommunicationStepSize="true" '
                   f'canGetAndSetFMUState="true" canSerializeFMUState="true" fixedInternalStepSize="{_fmt(step)}"/>')
    out += _unit_definitions([_real_unit(v["unit"]) for v in vars_ if v["kind"] == "real"] + ["s"])   # (s: time's)
    out += _type_definitions(enums, fmi)
    out.append(f'  <DefaultExperiment startTime="0" stepSize="{_fmt(step)}"/>')
    out.append("  <ModelVariables>")
    for v in vars_:
        common = dict(name=v["name"], valueReference=v["vr"], description=v["desc"], causality=v["causality"],
                      variability=v["variability"], initial=v["initial"])
        kind = v["kind"]
        start = (None if v["start"] is None else _fmt(v["start"]) if kind == "real"
                 else ("true" if v["start"] else "false") if kind == "bool" else int(v["start"]))
        if kind == "real":
            unit = _real_unit(v["unit"])
            der = v.get("derivative")               # (FMI 2: its state's index, from 1; FMI 3: its state's vr)
            typed = dict(unit=unit, displayUnit=v.get("display") or _display_unit(unit),
                         derivative=None if der is None else der + 1 if fmi == 2 else vars_[der]["vr"],
                         nominal=None if v.get("nominal") is None else _fmt(v["nominal"]), min=_bound(v["lo"]),
                         max=_bound(v["hi"]), start=start)
        elif kind == "bool":
            typed = dict(start=start)
        else:                                     # (an Integer's, an Enumeration's bounds: whole numbers)
            typed = dict(declaredType=v.get("type"), min=None if v["lo"] is None else int(v["lo"]),
                         max=None if v["hi"] is None else int(v["hi"]), start=start)
        if fmi == 2:
            tag = {"real": "Real", "int": "Integer", "bool": "Boolean", "enum": "Enumeration"}[kind]
            out.append(f"    <ScalarVariable {attrs(common)}>")
            out.append(f"      <{tag} {attrs(typed)}/>".replace(" />", "/>"))
            out.append("    </ScalarVariable>")
        else:
            tag = {"real": "Float64", "int": "Int32", "bool": "Boolean", "enum": "Enumeration"}[kind]
            out.append(f"    <{tag} {attrs(common)} {attrs(typed)}/>")
    if fmi == 3:
        out.append('    <Float64 name="time" valueReference="999" causality="independent" variability="continuous" '
                   'description="simulation time" unit="s"/>')
    out.append("  </ModelVariables>")
    out.append("  <ModelStructure>")
    initial = sorted(set(outputs + calculated + me["states"] + me["derivatives"]))
    if fmi == 2:
        out.append("    <Outputs>")
        out += [f'      <Unknown index="{i + 1}"{deps}/>' for i in outputs]
        out.append("    </Outputs>")
        if me["derivatives"]:
            out.append("    <Derivatives>")
            out += [f'      <Unknown index="{i + 1}"/>' for i in me["derivatives"]]
            out.append("    </Derivatives>")
        out.append("    <InitialUnknowns>")
        out += [f'      <Unknown index="{i + 1}"/>' for i in initial]
        out.append("    </InitialUnknowns>")
    else:
        out += [f'    <Output valueReference="{vars_[i]["vr"]}"{deps}/>' for i in outputs]
        out += [f'    <ContinuousStateDerivative valueReference="{vars_[i]["vr"]}"/>' for i in me["derivatives"]]
        out += [f'    <InitialUnknown valueReference="{vars_[i]["vr"]}"/>' for i in initial]
        out += [f'    <EventIndicator valueReference="{vars_[i]["vr"]}"/>' for i in me["indicators"]]
    out.append("  </ModelStructure>")
    out.append("</fmiModelDescription>")
    return "\n".join(out) + "\n"


def _fmi_headers(fmi: int) -> list[Path]:
    try:
        import fmpy
    except ImportError:
        raise InputError("exporting an FMU needs FMPy's copy of the FMI headers: pip install fmpy") from None
    base = Path(fmpy.__file__).resolve().parent / "c-code"
    paths = [base / name for name in FMI_HEADERS[fmi]]
    missing = [p.name for p in paths if not p.exists()]
    if missing:
        raise InputError(f"FMPy at {base} lacks {', '.join(missing)}")
    return paths


def _checked(out, fmi: int, step: float) -> Path:
    """The output path of an export, its FMI version and step checked."""
    if fmi not in (2, 3):
        raise InputError(f"--fmi must be 2 or 3, got {fmi}", key="fmi")
    if not 1e-7 <= step <= 0.01:
        raise InputError(f"must be in [1e-7, 0.01] s, got {step}", key="step")
    out = Path(out)
    if out.suffix != ".fmu":
        raise InputError(f"the output file must end in .fmu, got {out.name}", key="out")
    return out


def export_fmu(params: Parameters, out: Path, *, fmi: int = 2, step: float = 5e-4, cc: str | None = None,
               platforms=None) -> Path:
    """Write the FMU ``out`` (FMI ``fmi`` = 2 or 3, internal step ``step`` [s]) with a binary for this machine and
    each platform a cross compiler is present for (``platforms``: those; :func:`fmu_compilers`); returns its
    path."""
    from hydrohil.export.paper_model import paper_model_files
    out = _checked(out, fmi, step)
    token = "{" + str(uuid.UUID(hashlib.md5(f"{params.model_dump_json()}|{fmi}|{step}".encode()).hexdigest())) + "}"
    return package_fmu(out, fmi, {"plant_fmu.h": HERE / "c" / "fmu" / "plant_fmu.h",
                                  "plant_fmu.c": HERE / "c" / "fmu" / "plant_fmu.c",
                                  "config.h": config_h(params, step, token),
                                  **paper_model_files(params, step)},     # (its model: the circuit's generated C)
                       fmu_sources(RIG_UNITS, fmi), model_description(params, fmi, step, token),
                       fmu_compilers(cc, platforms))


def package_fmu(out: Path, fmi: int, files: dict, sources: list[str], description: str,
                compilers: dict[str, str]) -> Path:
    """Build and zip an FMU: the core's sources, the shared FMI layer (fmu_instance.[ch], fmi<N>Functions.c),
    the FMI headers and the model's ``files`` (name -> a Path to copy or the text to write) into sources/ (FMI 3:
    with its buildDescription.xml), a binary of ``sources`` for each platform of ``compilers`` (target ->
    compiler: :func:`fmu_compilers`) with the core's flags, ``description`` as modelDescription.xml; written to
    ``out`` (whole or not at all)."""
    from hydrohil.core.build import CFLAGS, core_sources, write_headers
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        src.mkdir(parents=True)
        write_headers(CORE)
        for path in core_sources():
            shutil.copy2(path, src / path.name)
        for name in ("fmu_instance.h", "fmu_instance.c", f"fmi{fmi}Functions.c"):
            shutil.copy2(HERE / "c" / "fmu" / name, src / name)
        for h in _fmi_headers(fmi):
            shutil.copy2(h, src / h.name)
        for name, body in files.items():
            if isinstance(body, Path):
                shutil.copy2(body, src / name)
            else:
                (src / name).write_text(body)
        if fmi == 3:
            (src / "buildDescription.xml").write_text(build_description_xml(sources))
        (root / "modelDescription.xml").write_text(description)
        builds = []                                      # (the platforms' compilers run side by side)
        for target, cc in compilers.items():
            folder, folder3, suffix = TARGETS[target][:3]
            binary = root / "binaries" / (folder if fmi == 2 else folder3) / f"{MODEL_IDENTIFIER}{suffix}"
            binary.parent.mkdir(parents=True)
            elf = suffix == ".so"                        # (a Windows DLL exports what FMIN_Export marks)
            cmd = [cc, *CFLAGS, "-DHH_GLIBC_COMPAT", "-shared", *(("-fPIC", "-fvisibility=hidden") if elf else ()),
                   "-I", str(src), *[str(src / u) for u in sources], "-lm", "-o", str(binary)]
            builds.append((target, cmd, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                                          text=True)))
        done = [(target, cmd, *proc.communicate()[:1], proc.returncode) for target, cmd, proc in builds]
        failed = [d for d in done if d[3] != 0]
        if failed:
            target, cmd, output, _ = failed[0]
            raise RuntimeError(f"building the FMU's {target} binary failed:\n{' '.join(cmd)}\n{output}")
        out.parent.mkdir(parents=True, exist_ok=True)
        part = out.with_suffix(".fmu.part")
        with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(root.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(root).as_posix())
        part.replace(out)
    return out


# ---- a circuit as an FMU (issue #27): the circuit's generated C behind the same FMI layer ------------------

VR_INPUT0, VR_OUTPUT0, VR_MODE0 = 1000, 2000, 3000
# Model Exchange: der(x) of each state, the guards (event indicators), the states that are no output signal
CIRCUIT_VR_DER0, CIRCUIT_VR_EVENT0, CIRCUIT_VR_LOCAL0 = 4000, 5000, 6000


def circuit_me_sizes(compiled) -> dict:
    """A compiled circuit's Model Exchange sizes: states, modes, event indicators (its guards), delayed inputs."""
    ffi = compiled.ffi
    out = [ffi.new("int64_t *") for _ in range(4)]
    compiled.lib.hc_me_sizes(*out)
    return dict(zip(("ny", "nm", "nz", "nd"), (int(v[0]) for v in out)))


def _state_nominal(name: str, unit: str, y0: float) -> float:
    """A circuit state's typical size (Model Exchange's nominal: the importer's absolute tolerance is its relative one
    times it): its start's size, at least its unit's (a pressure 1 bar, a length 1 mm, a speed 1 mm/s, a LuGre
    seal's bristles 10 um)."""
    if name.endswith(".z"):
        return 1e-5
    floor = {"Pa": 1e5, "m": 1e-3, "m/s": 1e-3, "rad/s": 1.0, "1/s": 1.0, "-": 1e-2}.get(unit, 1.0)
    return max(abs(float(y0)), floor)


def circuit_config_h(c, lay, y0, m0, u0, step: float, token: str, me: dict) -> str:
    """``config.h`` of a circuit's FMU: sizes, value references, the exported parameters and initial state, Model
    Exchange's sizes (``me``: :func:`circuit_me_sizes`) and its states' nominals."""
    outputs = [i for i, col in enumerate(lay.log_columns) if col != "t" and col not in lay.modes]
    q = json.dumps                                      # a C string literal of a name (ASCII, escaped)
    held = [1 if n in c.initial else 0 for n in c.state_nodes] + [0] * (len(lay.states) - len(c.state_nodes))
    lines = ["/* config.h: GENERATED by `hydrohil export fmu --circuit` (hydrohil " + __version__ + "): do not edit. */",
             "#ifndef PLANT_CONFIG_H", "#define PLANT_CONFIG_H", "#include <math.h>", "#include <stdint.h>", "",
             f'#define PLANT_TOKEN "{token}"', f"#define CIRCUIT_NAME {q(c.name)}",
             f"#define CIRCUIT_METHOD {METHOD_RK3}   /* HH_RK3 */", f"#define CIRCUIT_STEP {_fmt(step)}",
             f"#define CIRCUIT_NP {len(lay.params)}", f"#define CIRCUIT_NU {max(len(lay.inputs), 1)}",
             f"#define CIRCUIT_NY {len(y0)}", f"#define CIRCUIT_NM {max(len(lay.modes), 1)}",
             f"#define CIRCUIT_NLOG {len(lay.log_columns)}", f"#define CIRCUIT_NINPUTS {len(lay.inputs)}",
             f"#define CIRCUIT_NOUTPUTS {len(outputs)}", f"#define CIRCUIT_NMODES {len(lay.modes)}",
             f"#define CIRCUIT_NSTATES {len(lay.states)}",
             f"#define VR_INPUT0 {VR_INPUT0}", f"#define VR_OUTPUT0 {VR_OUTPUT0}", f"#define VR_MODE0 {VR_MODE0}",
             "/* Model Exchange: its states (the first CIRCUIT_NSTATES of y), der(x), the event indicators, the states "
             "no output shows */",
             f"#define PLANT_NX {len(lay.states)}", f"#define PLANT_NZ {me['nz']}",
             f"#define CIRCUIT_NDELAY {max(me['nd'], 1)}   /* the delayed inputs (at least 1: C has no empty arrays) */",
             f"#define VR_DER0 {CIRCUIT_VR_DER0}", f"#define VR_EVENT0 {CIRCUIT_VR_EVENT0}",
             f"#define VR_LOCAL0 {CIRCUIT_VR_LOCAL0}", ""]
    lines += c_array("double", "CIRCUIT_P", lay.values(), c_double)
    lines += c_array("double", "CIRCUIT_U0", u0[:max(len(lay.inputs), 1)], c_double)
    lines += c_array("double", "CIRCUIT_Y0", y0, c_double)
    lines += c_array("int64_t", "CIRCUIT_M0", m0, lambda v: str(int(v)))
    lines += c_array("int", "CIRCUIT_OUTPUT_COLUMN", outputs, str)
    lines += c_array("char *const", "CIRCUIT_INPUT_NAMES", lay.inputs, q, empty='""')
    lines += c_array("char *const", "CIRCUIT_STATE_NAMES", lay.states, q, empty='""')
    lines += c_array("int64_t", "CIRCUIT_HELD", held or [0], str)          # nodes given in [initial]
    lines += c_array("double", "CIRCUIT_NOMINAL", [_state_nominal(n, u, y0[i]) for i, (n, u) in
                                                   enumerate(zip(lay.states, lay.state_units))], c_double)
    lines += ["", "#endif", ""]
    return "\n".join(lines)


def _finite(v: float) -> float | None:
    """A range bound for the modelDescription (None: not bounded)."""
    return v if math.isfinite(v) else None


def circuit_model_description(c, lay, u0, fmi: int, step: float, token: str, y0=None) -> str:
    """modelDescription.xml of a circuit's FMU: its input signals (start: the exported drive at t = 0), every
    signal as an output with its SI unit, the modes as Enumeration outputs of their names."""
    from hydrohil.circuits.run import input_unit
    vars_: list[dict] = []
    for j, sig in enumerate(lay.inputs):
        prm = c.input_param(sig)
        vars_.append(dict(name=sig, vr=VR_INPUT0 + j, causality="input", variability="continuous", initial=None,
                          desc=prm.text(sig.split(".")[0]), unit=input_unit(c, sig), start=float(u0[j]), lo=_finite(prm.lo), hi=_finite(prm.hi),
                          kind="real"))
    units = dict(lay.outputs)
    outputs = []
    k = 0
    for i, col in enumerate(lay.log_columns):
        if col == "t" or col in lay.modes:
            continue
        outputs.append(len(vars_))
        unit = "Pa" if col.endswith(".p") and col[:-2] in c.nodes else units.get(col, "")
        desc = f"pressure of node {col[:-2]}" if unit == "Pa" and col[:-2] in c.nodes else f"{col} [{unit}]"
        vars_.append(dict(name=col, vr=VR_OUTPUT0 + k, causality="output", variability="continuous", initial=None,
                          desc=desc, unit=unit, start=None, lo=None, hi=None, kind="real"))
        k += 1
    enums = {}
    for j, md in enumerate(lay.modes):             # (an Enumeration of its names each: cyl.mode -> CylMode)
        outputs.append(len(vars_))
        component = md.removesuffix(".mode")
        enum = "".join(w.capitalize() for w in component.split("_")) + "Mode"
        enums[enum] = [(n, "") for n in lay.mode_names[md]]
        vars_.append(dict(name=md, vr=VR_MODE0 + j, causality="output", variability="discrete", initial=None,
                          desc=f"the mode of {component}", unit="", start=None, lo=None, hi=None, kind="enum",
                          type=enum))
    index = {v["name"]: i for i, v in enumerate(vars_)}
    me = {"states": [], "derivatives": [], "indicators": []}
    for i, (name, unit) in enumerate(zip(lay.states, lay.state_units)):   # (Model Exchange's states)
        if name not in index:                          # (a state no output shows: a local of its own)
            index[name] = len(vars_)
            vars_.append(dict(name=name, vr=CIRCUIT_VR_LOCAL0 + i, causality="local", variability="continuous",
                              initial=None, desc=f"state {name}", unit=unit, start=None, lo=None, hi=None,
                              kind="real"))
        vars_[index[name]]["nominal"] = _state_nominal(name, unit, 0.0 if y0 is None else y0[i])
        me["states"].append(index[name])
    for i, (name, unit) in enumerate(zip(lay.states, lay.state_units)):
        me["derivatives"].append(len(vars_))
        vars_.append(dict(name=f"der({name})", vr=CIRCUIT_VR_DER0 + i, causality="local", variability="continuous",
                          initial=None, desc=f"d/dt of {name}", unit=_per_second(_real_unit(unit)), start=None,
                          lo=None, hi=None, kind="real", derivative=index[name]))
    for g, name in enumerate(lay.guards):
        me["indicators"].append(len(vars_))
        vars_.append(dict(name=f"guard.{name}", vr=CIRCUIT_VR_EVENT0 + g, causality="local", variability="continuous",
                          initial=None, desc=f"the guard {name}: >= 0 while its mode holds (1 in the other modes); its "
                          "zero crossing an event", unit="1", start=None, lo=None, hi=None, kind="real"))
    return _description_xml(vars_, outputs, [], fmi, step, token, enums,
                             f"hydrohil circuit {c.name!r} ({c.source}): generated from its description, RK3 at a "
                             f"fixed {step * 1e3:g} ms step, parameters as exported",
                             fmu_sources(CIRCUIT_UNITS, fmi), feedthrough=True, me=me)


def export_circuit_fmu(c, out: Path, *, fmi: int = 2, step: float = 5e-4, loop=None, rest=True,
                       cc: str | None = None, platforms=None) -> Path:
    """Write circuit ``c`` as an FMU (FMI ``fmi`` = 2 or 3) to ``out``: its generated C (the same file
    ``simulate`` compiles) behind the shared FMI layer, starting at rest as a run of the circuit does (``loop``:
    a closed loop's start, the command that holds its piston as the command input's start value; ``rest``: a
    scenario's, its Hold an open loop's held start)."""
    from hydrohil.circuits.build import compile_circuit
    from hydrohil.circuits.run import start_state
    out = _checked(out, fmi, step)
    compiled = compile_circuit(c)
    source, lay = compiled.source, compiled.layout
    y0, m0, u0 = start_state(c, h=step, loop=loop, rest=rest)
    token = "{" + str(uuid.UUID(hashlib.md5(f"{source}|{lay.values().tobytes().hex()}|{y0.tobytes().hex()}|"
                                            f"{u0.tobytes().hex()}|{fmi}|{step}".encode()).hexdigest())) + "}"
    model = HERE / "c" / "circuit_fmu"
    return package_fmu(out, fmi, {"plant_fmu.h": model / "plant_fmu.h", "plant_fmu.c": model / "plant_fmu.c",
                                  "circuit.c": source,
                                  "config.h": circuit_config_h(c, lay, y0, m0, u0, step, token, circuit_me_sizes(compiled))},
                       fmu_sources(CIRCUIT_UNITS, fmi), circuit_model_description(c, lay, u0, fmi, step, token, y0),
                       fmu_compilers(cc, platforms))
