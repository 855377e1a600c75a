"""A parameter set as a person reads it (``hydrohil params show``): every key with its value, unit and
description, and which groups were derived rather than given. The TOML form loads back unchanged."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import tomli_w
from pydantic import BaseModel

from hydrohil.parameters import load_parameters
from hydrohil.parameters.schema import Parameters

DERIVED_NOTE = {"linear": "derived: the file has no [linear] (mid-stroke, the valve's centre; see "
                          "hydrohil.parameters.characteristics.derived_linear)"}


def _text(field) -> tuple[str, str]:
    """(unit, description without its bracketed unit) of a schema field."""
    extra = field.json_schema_extra if isinstance(field.json_schema_extra, dict) else {}
    desc = field.description or ""
    return extra.get("unit", "-"), re.sub(r"\s*\[[^\]]*\]$", "", desc)


def _toml(v) -> str:
    return tomli_w.dumps({"v": v}).split("=", 1)[1].strip()


def fields(params: Parameters, derived: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """One row per key (dotted, in schema order): value, unit, description, derived."""
    rows: list[dict[str, Any]] = []

    def walk(model: BaseModel, prefix: str, group_derived: bool) -> None:
        for name, field in type(model).model_fields.items():
            value = getattr(model, name)
            key = prefix + name
            if isinstance(value, BaseModel):
                walk(value, key + ".", group_derived or key in derived)
                continue
            unit, desc = _text(field)
            rows.append({"key": key, "value": list(value) if isinstance(value, tuple) else value, "unit": unit,
                         "description": desc, "derived": group_derived})
    walk(params, "", False)
    return rows


def annotated_toml(params: Parameters, derived: tuple[str, ...] = ()) -> str:
    """The set as TOML with each key's unit and description as a comment (loads back unchanged)."""
    rows = fields(params, derived)
    lines: list[str] = []
    table = None
    for r in rows:
        group, _, name = r["key"].rpartition(".")
        if group != table:
            table = group
            note = next((DERIVED_NOTE.get(g, "derived") for g in derived if group == g or group.startswith(g + ".")),
                        None)
            lines += ["", f"[{group}]" + (f"                      # {note}" if note else "")]
        v = r["value"]
        value = f"{name} = " + (f"[{', '.join(_toml(x) for x in v)}]" if isinstance(v, list) else _toml(v))
        unit = "" if r["unit"] in ("-", "") else f"[{r['unit']}] "
        lines.append(f"{value:<44} # {unit}{r['description']}")
    return "\n".join(lines).lstrip("\n") + "\n"


def load_shown(name_or_path: str | Path) -> tuple[Parameters, tuple[str, ...]]:
    """(the validated set, the groups derived because its file lacks them)."""
    params = load_parameters(name_or_path)
    return params, tuple(sorted(params.derived_groups))
