"""What the page's forms are built from: the fault types of :mod:`hydrohil.simulation.faults` and the
tunables of :mod:`hydrohil.simulation.steering`, read from their schemas (one source: a new fault type or bound
appears on the page by itself)."""

from __future__ import annotations

import typing
from functools import lru_cache


def _field(name: str, f) -> dict:
    ann = f.annotation
    out = {"name": name, "description": f.description or "", "default": None if f.is_required() else f.default}
    args = typing.get_args(ann)
    if typing.get_origin(ann) is typing.Literal or (args and typing.get_origin(args[0]) is typing.Literal):
        lit = ann if typing.get_origin(ann) is typing.Literal else args[0]
        out.update(kind="choice", choices=list(typing.get_args(lit)))
    else:
        out["kind"] = "number"
        for m in f.metadata:
            for key in ("ge", "gt", "le", "lt"):
                if getattr(m, key, None) is not None:
                    out[key] = getattr(m, key)
    return out


@lru_cache(maxsize=1)
def fault_schema() -> list[dict]:
    from hydrohil.simulation.faults import _CLASSES
    out = []
    for cls in _CLASSES:
        fields = [_field(n, f) for n, f in cls.model_fields.items() if n not in ("type", "start", "end")]
        out.append({"type": cls.model_fields["type"].annotation.__args__[0], "fields": fields,
                    "description": (cls.__doc__ or "").strip()})
    return out


def tunable_schema() -> list[dict]:
    from hydrohil.simulation.steering import TUNABLES
    return [{"name": n, "unit": u, "min": lo, "max": hi, "description": d} for n, (u, lo, hi, d) in TUNABLES.items()]
