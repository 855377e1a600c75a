"""Parameter sets: load from a built-in name or a TOML path, apply dotted overrides, validate, save.

Built-in sets live beside this file as ``NAME.toml`` (``ferreira2004`` is the paper's test bed).
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path
from typing import Any, Mapping

import tomli_w
from pydantic import ValidationError

from hydrohil.errors import InputError
from hydrohil.parameters.schema import Parameters

BUILTIN_DIR = Path(__file__).parent
__all__ = ["Parameters", "load_parameters", "builtin_names", "read_toml", "apply_overrides",
           "validate_parameters", "save_parameters", "format_validation_error", "replace_values"]


def builtin_names() -> list[str]:
    return sorted(p.stem for p in BUILTIN_DIR.glob("*.toml"))


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file, turning I/O and syntax errors into :class:`InputError` naming the file."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise InputError("file not found", source=str(path)) from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"invalid TOML: {exc}", source=str(path)) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror}", source=str(path)) from None


def _resolve_source(name_or_path: str | Path) -> Path:
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        return p
    if str(name_or_path) in builtin_names():
        return BUILTIN_DIR / f"{name_or_path}.toml"
    raise InputError(f"no such parameter file, and not a built-in set (built-in: {', '.join(builtin_names())})",
                     source=str(name_or_path))


def apply_overrides(data: dict[str, Any], overrides: Mapping[str, Any], source: str = "overrides") -> dict[str, Any]:
    """Return a copy of ``data`` with dotted keys (``supply.ps``) set; unknown paths are errors."""
    out = copy.deepcopy(data)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        node = out
        for i, part in enumerate(parts[:-1]):
            if not isinstance(node, dict) or part not in node:
                raise InputError(f"unknown parameter group '{'.'.join(parts[:i + 1])}'", source=source, key=dotted)
            node = node[part]
        if not isinstance(node, dict) or parts[-1] not in node:
            raise InputError("unknown parameter (see `hydrohil params show ferreira2004` for the keys)",
                             source=source, key=dotted)
        node[parts[-1]] = value
    return out


def format_validation_error(exc: ValidationError, schema: type | None = None) -> tuple[str, str]:
    """(dotted key, message with expected unit/range) of the first error of a pydantic exception."""
    err = exc.errors()[0]
    key = ".".join(str(x) for x in err["loc"]) or "(top level)"
    msg = err["msg"]
    if err["type"] == "extra_forbidden":
        msg = "unknown key"
    elif err["type"] == "missing":
        msg = "missing key"
    unit = _unit_of(schema, err["loc"]) if schema else None
    if unit:
        msg += f" (unit: {unit})"
    if "input" in err and err["type"] not in ("missing",) and not isinstance(err["input"], dict):
        msg += f"; got {err['input']!r}"
    return key, msg


def _unit_of(schema, loc) -> str | None:
    model = schema
    field = None
    for part in loc:
        fields = getattr(model, "model_fields", None)
        if not fields or part not in fields:
            return None
        field = fields[part]
        model = field.annotation
    extra = field.json_schema_extra if field is not None else None
    return extra.get("unit") if isinstance(extra, dict) else None


def validate_parameters(data: Mapping[str, Any], source: str) -> Parameters:
    try:
        return Parameters.model_validate(data)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, Parameters)
        raise InputError(msg, source=source, key=key) from None


def load_parameters(name_or_path: str | Path = "ferreira2004",
                    overrides: Mapping[str, Any] | None = None) -> Parameters:
    """Load and validate a parameter set by built-in name or TOML path, with optional dotted overrides."""
    path = _resolve_source(name_or_path)
    data = read_toml(path)
    if overrides:
        data = apply_overrides(data, overrides)
    try:
        return validate_parameters(data, str(path))
    except InputError as exc:
        if overrides and exc.key in overrides:  # the bad value came from an override, say so
            raise InputError(str(exc).split(f"{exc.key}: ", 1)[-1], source="overrides", key=exc.key) from None
        raise


def replace_values(params: Parameters, values: Mapping[str, Any], source: str = "overrides") -> Parameters:
    """A copy of ``params`` with dotted keys set (``{"supply.ps": 1.2e7}``), validated again."""
    return validate_parameters(apply_overrides(params.model_dump(mode="python"), values, source), source)


def save_parameters(params: Parameters, path: str | Path, header: str = "") -> None:
    """Write a parameter set as TOML that :func:`load_parameters` reads back unchanged."""
    text = tomli_w.dumps(params.model_dump(mode="python"))
    if header:
        text = "".join(f"# {line}\n" for line in header.splitlines()) + "\n" + text
    tmp = Path(str(path) + ".part")   # never leave a half-written parameter file
    tmp.write_text(text)
    tmp.replace(path)
