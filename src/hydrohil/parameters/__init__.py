"""Parameter sets: load from a built-in name or a TOML path, apply dotted overrides, validate, save.

Built-in sets live beside this file as ``NAME.toml`` (``ferreira2004`` is the paper's test bed).
"""

from __future__ import annotations

import functools
import re
import tomllib
import types
import typing
import warnings
from pathlib import Path
from typing import Any, Mapping

import tomli_w
from pydantic import BaseModel, ValidationError

from hydrohil.errors import InputError, InputWarning, unknown_name
from hydrohil.parameters.schema import Parameters, implausible, with_derived_linear

BUILTIN_DIR = Path(__file__).parent
__all__ = ["Parameters", "load_parameters", "builtin_names", "read_toml", "copy_tables", "apply_overrides",
           "validate_parameters", "save_parameters", "format_validation_error", "replace_values"]


@functools.lru_cache(maxsize=32)
def _parsed(path: str, mtime_ns: int, size: int) -> dict[str, Any]:
    with open(path, "rb") as fh:
        return tomllib.load(fh)


def copy_tables(tree):
    """A copy of a tree of tables (a parsed TOML file's, or tables made like one): its tables (dicts) and arrays
    (lists) new, the values in them shared (str, numbers, bool, dates: immutable in a parsed file); for a tree
    whose tables are changed, never its values in place, what copy.deepcopy gives, in a fifth of its time."""
    if isinstance(tree, dict):                # (a value is not a call: most of a tree is values)
        return {k: copy_tables(v) if isinstance(v, (dict, list)) else v for k, v in tree.items()}
    if isinstance(tree, list):
        return [copy_tables(v) if isinstance(v, (dict, list)) else v for v in tree]
    return tree


def builtin_names() -> list[str]:
    return sorted(p.stem for p in BUILTIN_DIR.glob("*.toml"))


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file, turning I/O and syntax errors into :class:`InputError` naming the file. A file read
    before and not changed since (the same modification time to the nanosecond and size) is not parsed again:
    its tables are copied (a study reads its parameter file for every run)."""
    path = Path(path)
    try:
        st = path.stat()
        return copy_tables(_parsed(str(path), st.st_mtime_ns, st.st_size))
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
    name = str(name_or_path)
    if p.name == name and (BUILTIN_DIR / f"{name}.toml").is_file():     # (a name, not a path: builtin_names()'s,
        return BUILTIN_DIR / f"{name}.toml"                           # without listing the folder every run)
    raise InputError(f"no such parameter file, and not a built-in set (built-in: {', '.join(builtin_names())})",
                     source=str(name_or_path))


def apply_overrides(data: dict[str, Any], overrides: Mapping[str, Any], source: str = "overrides") -> dict[str, Any]:
    """Return a copy of ``data`` with dotted keys (``supply.ps``) set; unknown paths are errors."""
    return _set_overrides(copy_tables(data), overrides, source)   # (its tables new: the values set replace,
    #                                                               never change, a value)


def _set_overrides(out: dict[str, Any], overrides: Mapping[str, Any], source: str) -> dict[str, Any]:
    """:func:`apply_overrides` in the tables of ``out`` (a tree of its caller's own, copied already)."""
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        node = out
        for i, part in enumerate(parts):
            if not isinstance(node, dict):
                raise InputError(f"'{'.'.join(parts[:i])}' is a parameter, not a group", source=source, key=dotted)
            if part not in node:
                what = "parameter group" if i < len(parts) - 1 else "parameter"
                raise InputError(unknown_name(part, node, what, prefix="".join(p + "." for p in parts[:i]))
                                 + " (all keys: `hydrohil params show ferreira2004`)", source=source, key=dotted)
            if i < len(parts) - 1:
                node = node[part]
        node[parts[-1]] = value
    return out


_BOUNDS = {"greater_than": ("gt", ">"), "greater_than_equal": ("ge", ">="), "less_than": ("lt", "<"),
           "less_than_equal": ("le", "<=")}


def format_validation_error(exc: ValidationError, schema: type | None = None) -> tuple[str | None, str]:
    """(dotted key, message) for one error of a pydantic exception, as a user fixes it.

    An unknown key is reported before anything else (a misspelt ``duraton`` also makes ``duration``
    missing), named in full in the message: ``(None, "unknown key 'solver.methd' (did you mean
    'solver.method'?)")``. Range errors state the bound and the field's unit (the
    bracketed text of its description): ``("solver.step", "must be > 1e-09 [s], got -1")``."""
    errors = exc.errors()
    err = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
    loc = tuple(err["loc"])
    admitted, parts, field = _walk(schema, loc[:-1] if err["type"] == "extra_forbidden" else loc)
    key = ".".join(parts) or None
    if err["type"] == "extra_forbidden":
        valid = [name for m in _models(admitted) for name in m.model_fields]
        return None, unknown_name(loc[-1], dict.fromkeys(valid), prefix="".join(p + "." for p in parts))
    if err["type"] in ("union_tag_invalid", "union_tag_not_found") and "ctx" in err:
        tags = [t.strip().strip("'") for t in err["ctx"].get("expected_tags", "").split(",") if t.strip()]
        disc = err["ctx"].get("discriminator", "'type'").strip("'")
        key = ".".join((*parts, disc))
        if err["type"] == "union_tag_not_found":
            return key, f"missing key (one of: {', '.join(tags)})"
        return key, unknown_name(err["ctx"]["tag"], tags, what="type")
    if err["type"] == "missing":
        return key or "(top level)", "missing key"
    unit = _unit_of(field)
    if err["type"] in _BOUNDS and "ctx" in err:
        name, op = _BOUNDS[err["type"]]
        msg = f"must be {op} {err['ctx'][name]:g}" + (f" {unit}" if unit else "")
    else:
        msg = err["msg"].removeprefix("Value error, ") + (f" (unit: {unit})" if unit else "")
    if "input" in err and not isinstance(err["input"], dict):
        msg += f", got {err['input']!r}"
    return key or "(top level)", msg


def _flatten(annotation) -> list:
    """The types an annotation admits: Annotated and unions unwrapped (``A | B | None`` -> [A, B, None])."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _flatten(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return [t for a in typing.get_args(annotation) for t in _flatten(a)]
    return [annotation]


def _models(candidates) -> list:
    """The pydantic models among the types ``candidates`` admit."""
    return [t for c in candidates for t in _flatten(c) if isinstance(t, type) and issubclass(t, BaseModel)]


def _tag(model) -> object:
    """The value of a discriminated-union member's ``type`` Literal (``"sine"``, ``"hose_burst"``)."""
    f = model.model_fields.get("type")
    args = typing.get_args(f.annotation) if f is not None else ()
    return args[0] if len(args) == 1 else None


def _walk(schema, loc) -> tuple[list, list[str], object]:
    """Follow a pydantic error location through ``schema``: (types admitted there, the dotted key as the
    user wrote it (union tags such as ``sine`` dropped), the field's FieldInfo or None)."""
    candidates, parts, field = ([schema] if schema is not None else []), [], None
    for part in loc:
        flat = [t for c in candidates for t in _flatten(c)]
        models = _models(candidates)
        owner = next((m for m in models if isinstance(part, str) and part in m.model_fields), None)
        if owner is not None:
            field = owner.model_fields[part]
            candidates = [field.annotation]
        elif isinstance(part, int) and parts and any(typing.get_origin(t) is tuple for t in flat):
            parts[-1] += f"[{part + 1}]"              # (a tuple's item as its slot names it: valve.k[1])
            candidates = [typing.get_args(t)[part] for t in flat if typing.get_origin(t) is tuple]
            continue
        elif isinstance(part, int):
            candidates = [typing.get_args(t)[0] for t in flat if typing.get_origin(t) is list]
            field = None
        elif any(_tag(m) == part for m in models):
            candidates = [m for m in models if _tag(m) == part]
            continue
        else:
            candidates, field = [], None
        parts.append(str(part))
    return candidates, parts, field


def _unit_of(field) -> str | None:
    """The unit(s) a field's description gives in brackets, as written: "fixed step [s]" -> "[s]",
    "[m] or [Pa]" -> "[m] or [Pa]"; None when there is none or the quantity is dimensionless ("[-]")."""
    text = (field.description or "") if field is not None else ""
    units = [u for u in re.findall(r"(?<!\[)\[[^\[\]]+\](?!\])", text) if u != "[-]"]
    return " or ".join(units) if units else None


def validate_parameters(data: Mapping[str, Any], source: str, changed: set[str] | None = None) -> Parameters:
    """A validated parameter set (an :class:`InputError` naming ``source`` and the key otherwise); a value that
    is valid but probably in another unit is an :class:`InputWarning` (``warning: …`` on the terminal), said
    of the keys ``changed`` only when given (a set changed by overrides was judged when it was read)."""
    try:
        params = Parameters.model_validate(data)
    except ValidationError as exc:
        key, msg = format_validation_error(exc, Parameters)
        raise InputError(msg, source=source, key=key) from None
    for key, msg in implausible(params):
        if changed is None or key in changed:
            warnings.warn(InputWarning(f"{source}: {key}: {msg}"), stacklevel=3)
    return params


def load_parameters(name_or_path: str | Path = "ferreira2004",
                    overrides: Mapping[str, Any] | None = None) -> Parameters:
    """Load and validate a parameter set by built-in name or TOML path, with optional dotted overrides."""
    path = _resolve_source(name_or_path)
    data = read_toml(path)
    if overrides and any(k.startswith("linear.") for k in overrides):
        data = with_derived_linear(data)          # an override of a derived value needs the group to set it in
    if overrides:                                 # (data: read_toml's copy, or with_derived_linear's)
        data = _set_overrides(data, overrides, "overrides")
    try:
        return validate_parameters(data, str(path))
    except InputError as exc:
        if overrides and exc.key in overrides:  # the bad value came from an override, say so
            raise InputError(str(exc).split(f"{exc.key}: ", 1)[-1], source="overrides", key=exc.key) from None
        raise


def replace_values(params: Parameters, values: Mapping[str, Any], source: str = "overrides") -> Parameters:
    """A copy of ``params`` with dotted keys set (``{"supply.ps": 1.2e7}``), validated again. Groups the set
    derived (:attr:`Parameters.derived_groups`) are derived again from the new values, unless a key sets one
    of their values (the group is then given)."""
    data = params.model_dump(mode="python")
    for group in params.derived_groups:
        if not any(k.startswith(group + ".") for k in values):
            del data[group]
    return validate_parameters(apply_overrides(data, values, source), source, changed=set(values))


def save_parameters(params: Parameters, path: str | Path, header: str = "") -> None:
    """Write a parameter set as TOML that :func:`load_parameters` reads back unchanged (derived groups are
    left out: they are derived again when it is read)."""
    text = tomli_w.dumps(params.model_dump(mode="python", exclude=set(params.derived_groups)))
    if header:
        text = "".join(f"# {line}\n" for line in header.splitlines()) + "\n" + text
    tmp = Path(str(path) + ".part")   # never leave a half-written parameter file
    tmp.write_text(text)
    tmp.replace(path)
