"""The parameter vector of the C core, generated from the pydantic schema (the one place it is defined).

Every value of :class:`hydrohil.parameters.Parameters` gets one float64 slot, in schema order (a 5-tuple
gets five: ``valve.k[1]`` … ``valve.k[5]``; a Literal its value, or its index when the values are words;
a bool 0/1). After them come the model's own slots (:data:`MODEL_SLOTS`): the friction set of each
direction (derived by the core from ``friction.asymmetric``), the continuous reference model's constants,
the hybrid model's stiff-chamber limit, and the values fault injection sets (0 in every parameter set).

This module imports nothing of hydrohil: the build (``src/hydrohil/core/build.py``) loads it and the schema
file by path to write ``hh_params.h`` before the package exists, and :mod:`hydrohil.models.layout` calls
the same :func:`slots` at run time, so C and Python cannot disagree.
"""

from __future__ import annotations

import typing
from dataclasses import dataclass


@dataclass(frozen=True)
class Slot:
    key: str            # dotted name as in the TOML file: "spool.wn", "valve.k[2]"; model slots: "model.fc_pos"
    c_name: str         # macro of the C index: "HH_SPOOL_WN"
    kind: str           # "real" | "integer" | "boolean" | "enum"
    unit: str
    description: str
    lo: float | None    # admissible range (inclusive unless strict)
    hi: float | None
    lo_strict: bool = False
    hi_strict: bool = False
    options: tuple = ()  # enum: the words, value = index
    schema: bool = True  # False: a model slot (not a user parameter)


# (name, unit, description, default) of the slots the model adds after the schema's; defaults are what
# hydrohil.models.layout.pack writes (None: derived by hh_params_derive from the schema slots).
MODEL_SLOTS = (
    ("fc_pos", "N", "Coulomb force of the positive direction (symmetric or positive set)", None),
    ("fs_pos", "N", "breakaway force, positive direction", None),
    ("vs_pos", "m/s", "Stribeck velocity, positive direction", None),
    ("kv_pos", "N.s/m", "viscous coefficient, positive direction", None),
    ("fc_neg", "N", "Coulomb force of the negative direction (symmetric or negative set)", None),
    ("fs_neg", "N", "breakaway force, negative direction", None),
    ("vs_neg", "m/s", "Stribeck velocity, negative direction", None),
    ("kv_neg", "N.s/m", "viscous coefficient, negative direction", None),
    ("stop_k", "N/m", "reference model: end-stop stiffness (SPEC §6)", 1e10),
    ("stop_c", "N.s/m", "reference model: end-stop damping (SPEC §6)", 1e10),
    ("dp_lam_ref", "Pa", "reference model: laminar region of the orifices (keeps its Jacobian finite)", 1e3),
    ("spool_stop_k", "1/s^2", "reference model: spool end-stop stiffness per unit spool travel", 1e10),
    ("spool_stop_c", "1/s", "reference model: spool end-stop damping (critical at 1e5 rad/s)", 2e5),
    ("lambda_h_max", "-", "hybrid model: largest lambda*h of a chamber's pressure relaxation", 1.5),
    ("valve_wear", "(l/min)/sqrt(bar)", "fault: worn-lands section added to each pseudo-section", 0.0),
    ("burst1", "(l/min)/sqrt(bar)", "fault: burst hose from chamber 1 to tank", 0.0),
    ("burst2", "(l/min)/sqrt(bar)", "fault: burst hose from chamber 2 to tank", 0.0),
)


def _unit_and_text(field) -> tuple[str, str]:
    extra = field.json_schema_extra or {}
    desc = field.description or ""
    unit = extra.get("unit") if isinstance(extra, dict) else None
    if unit is None:
        unit = "-"
    text = desc.rsplit(" [", 1)[0] if desc.endswith("]") else desc
    return unit, text


def _bounds(field):
    lo = hi = None
    lo_s = hi_s = False
    for m in field.metadata:
        for attr, strict, upper in (("ge", False, False), ("gt", True, False), ("le", False, True),
                                    ("lt", True, True)):
            v = getattr(m, attr, None)
            if v is not None:
                if upper:
                    hi, hi_s = float(v), strict
                else:
                    lo, lo_s = float(v), strict
    return lo, hi, lo_s, hi_s


@dataclass(frozen=True)
class _Item:
    """A tuple item's constraints (``Annotated[float, Field(...)]``'s metadata) as a field's, for :func:`_bounds`."""
    extra: tuple

    @property
    def metadata(self):
        return [m for f in self.extra for m in getattr(f, "metadata", [f])]


def _c_name(key: str) -> str:
    return "HH_" + key.replace("[", "").replace("]", "").replace(".", "_").upper()


def _walk(model, prefix: str) -> list[Slot]:
    out: list[Slot] = []
    for name, field in model.model_fields.items():
        key = f"{prefix}{name}"
        ann = field.annotation
        origin = typing.get_origin(ann)
        if isinstance(ann, type) and hasattr(ann, "model_fields"):
            out += _walk(ann, key + ".")
            continue
        unit, text = _unit_and_text(field)
        if origin is tuple:
            args = typing.get_args(ann)
            for i, arg in enumerate(args):
                k = f"{key}[{i + 1}]"
                lo, hi, lo_s, hi_s = _bounds(_Item(typing.get_args(arg)[1:]))   # (an Annotated item's range)
                out.append(Slot(k, _c_name(k), "real", unit, f"{text} ({name}{i + 1})", lo, hi, lo_s, hi_s))
        elif origin is typing.Literal:
            opts = typing.get_args(ann)
            if all(isinstance(o, str) for o in opts):
                out.append(Slot(key, _c_name(key), "enum", "-", text, 0.0, float(len(opts) - 1), options=opts))
            else:
                out.append(Slot(key, _c_name(key), "integer", unit, text, float(min(opts)), float(max(opts)),
                                options=opts))
        elif ann is bool:
            out.append(Slot(key, _c_name(key), "boolean", "-", text, 0.0, 1.0))
        elif ann is float:
            lo, hi, lo_s, hi_s = _bounds(field)
            out.append(Slot(key, _c_name(key), "real", unit, text, lo, hi, lo_s, hi_s))
        else:
            raise TypeError(f"parameter {key}: no slot layout for the type {ann!r}")
    return out


def slots(parameters_model) -> list[Slot]:
    """Every slot of the parameter vector, in order: the schema's, then :data:`MODEL_SLOTS`."""
    out = _walk(parameters_model, "")
    for name, unit, text, _ in MODEL_SLOTS:
        out.append(Slot(f"model.{name}", f"HH_{name.upper()}", "real", unit, text, None, None, schema=False))
    return out


def _c_double(v: float | None, inf: str) -> str:
    return inf if v is None else repr(float(v))


def c_header(parameters_model) -> str:
    """``hh_params.h``: an index macro per slot, ``HH_NP``, and the table the core checks values against
    (key, unit, kind, range; model slots: their default)."""
    lines = ["/* hh_params.h: index of each parameter in the core's parameter vector p[HH_NP].",
             " * GENERATED at build time from the pydantic schema (src/hydrohil/parameters/schema.py) by",
             " * src/hydrohil/core/layout.py: do not edit. */",
             "#ifndef HH_PARAMS_H", "#define HH_PARAMS_H", ""]
    all_slots = slots(parameters_model)
    n_schema = sum(s.schema for s in all_slots)
    for i, s in enumerate(all_slots):
        lines.append(f"#define {s.c_name:<32} {i:3d}  /* {s.key} [{s.unit}] {s.description} */")
    lines += ["", f"#define HH_NP {len(all_slots)}", f"#define HH_NP_SCHEMA {n_schema}", "",
              "enum { HH_KIND_REAL, HH_KIND_INTEGER, HH_KIND_BOOLEAN, HH_KIND_ENUM };",
              "typedef struct {",
              "    const char *key, *unit;",
              "    int kind;",
              "    double lo, hi;           /* schema slots: admissible range; model slots: lo = the default */",
              "    int lo_strict, hi_strict;",
              "} hh_param_info;", "", "#endif", "",
              "/* the table: in the one file that defines HH_PARAMS_TABLE before including this (params.c) */",
              "#if defined(HH_PARAMS_TABLE) && !defined(HH_PARAMS_TABLE_DEFINED)",
              "#define HH_PARAMS_TABLE_DEFINED",
              "static const hh_param_info HH_PARAM_INFO[HH_NP] = {"]
    kinds = {"real": "HH_KIND_REAL", "integer": "HH_KIND_INTEGER", "boolean": "HH_KIND_BOOLEAN",
             "enum": "HH_KIND_ENUM"}
    defaults = {f"model.{n}": d for n, _, _, d in MODEL_SLOTS}
    for s in all_slots:
        if s.schema:
            lo, hi = _c_double(s.lo, "-HUGE_VAL"), _c_double(s.hi, "HUGE_VAL")
        else:
            d = defaults[s.key]
            lo, hi = _c_double(d, "NAN"), "NAN"
        lines.append(f'    {{"{s.key}", "{s.unit}", {kinds[s.kind]}, {lo}, {hi}, {int(s.lo_strict)}, '
                     f'{int(s.hi_strict)}}},')
    lines += ["};", "#endif", ""]
    return "\n".join(lines)
