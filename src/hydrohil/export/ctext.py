"""C text of Python values for the headers the exports write (``plant_config.h``, ``config.h``,
``circuit_plant.h``, ``paper_tables.h``): numbers exactly as Python holds them, strings escaped, constant arrays."""

from __future__ import annotations

import math


def c_double(v: float) -> str:
    """A double's C literal: repr (read back exactly), NAN, INFINITY, -INFINITY (math.h)."""
    v = float(v)
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    return repr(v)


def c_string(s: str) -> str:
    """A C string literal of ``s`` (backslashes and quotes escaped)."""
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def c_array(ctype: str, name: str, values, fmt=c_double, empty: str = "0") -> list[str]:
    """``static const ctype name[n] = {...};`` as lines, an item a line (C has no empty arrays: ``empty``)."""
    items = [fmt(v) for v in values] or [empty]
    return [f"static const {ctype} {name}[{len(items)}] = {{", *[f"    {x}," for x in items], "};"]
