"""Catalogue units at the boundary of a circuit file (SPEC §12.3): a value is a number in SI units, or a string
``"<number> <unit>"`` in one of :data:`UNITS` (bar, l/min, cm³/rev, rpm, mm, ...), converted here once; every
value inside hydrohil is SI."""

from __future__ import annotations

import math
import re

from hydrohil.errors import closest_name

# unit -> (factor to SI, SI unit)
UNITS: dict[str, tuple[float, str]] = {
    "Pa": (1.0, "Pa"), "kPa": (1e3, "Pa"), "bar": (1e5, "Pa"), "MPa": (1e6, "Pa"), "psi": (6894.757293168, "Pa"),
    "m3/s": (1.0, "m3/s"), "l/min": (1e-3 / 60.0, "m3/s"), "l/s": (1e-3, "m3/s"), "cm3/s": (1e-6, "m3/s"),
    "m3": (1.0, "m3"), "l": (1e-3, "m3"), "cm3": (1e-6, "m3"), "mm3": (1e-9, "m3"),
    "m3/rev": (1.0, "m3/rev"), "cm3/rev": (1e-6, "m3/rev"), "cc/rev": (1e-6, "m3/rev"),
    "rev/s": (1.0, "rev/s"), "rpm": (1.0 / 60.0, "rev/s"),
    "m": (1.0, "m"), "mm": (1e-3, "m"), "cm": (1e-2, "m"), "um": (1e-6, "m"), "µm": (1e-6, "m"),
    "m2": (1.0, "m2"), "mm2": (1e-6, "m2"), "cm2": (1e-4, "m2"),
    "kg/m3": (1.0, "kg/m3"), "m2/s": (1.0, "m2/s"), "cSt": (1e-6, "m2/s"), "mm2/s": (1e-6, "m2/s"),
    "m3/(s.Pa)": (1.0, "m3/(s.Pa)"), "(l/min)/bar": (1e-3 / 60.0 / 1e5, "m3/(s.Pa)"),
    "s": (1.0, "s"), "ms": (1e-3, "s"), "-": (1.0, "-"), "%": (0.01, "-"),
    "kg": (1.0, "kg"), "t": (1e3, "kg"), "N": (1.0, "N"), "kN": (1e3, "N"), "N.s/m": (1.0, "N.s/m"),
    "kg.m2": (1.0, "kg.m2"), "N.m": (1.0, "N.m"), "N.m.s/rad": (1.0, "N.m.s/rad"), "rad/s": (1.0, "rad/s"),
    "Hz": (1.0, "Hz"), "N/m": (1.0, "N/m"), "N/mm": (1e3, "N/m"), "deg": (1.0, "deg"),
}
# the same word for another SI unit: rpm is rev/s for a pump's speed, rad/s for a motor's; Hz as rad/s
ALIASES: dict[tuple[str, str], float] = {("rpm", "rad/s"): 2.0 * math.pi / 60.0, ("rev/s", "rad/s"): 2.0 * math.pi,
                                         ("Hz", "rad/s"): 2.0 * math.pi}
_VALUE = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S.*?)?\s*$")


def to_si(value, si_unit: str) -> float:
    """``value`` (a number in ``si_unit``, or "number unit") in ``si_unit``; ValueError naming what is accepted."""
    if isinstance(value, bool):
        raise ValueError(f"expected a number in {si_unit}, got {value!r}")
    if isinstance(value, (int, float)):
        v = float(value)
    elif isinstance(value, str):
        m = _VALUE.match(value)
        if not m:
            raise ValueError(f"expected a number or \"<number> <unit>\", got {value!r}")
        unit = m.group(2) or si_unit
        unit = unit.replace("³", "3").replace("²", "2").replace("·", ".")
        if (unit, si_unit) in ALIASES:
            return _finite(float(m.group(1)) * ALIASES[unit, si_unit], value)
        if unit not in UNITS:
            valid = [u for u, (_, s) in UNITS.items() if s == si_unit]
            near = closest_name(unit, valid)
            raise ValueError(f"unknown unit {unit!r} in {value!r}" + (f" (did you mean {near!r}?)" if near else "")
                             + f" ({si_unit} wanted; units: {', '.join(valid)})")
        factor, si = UNITS[unit]
        if si != si_unit:
            raise ValueError(f"{value!r} is in {si}, {si_unit} is wanted (units: "
                             f"{', '.join(u for u, (_, s) in UNITS.items() if s == si_unit)})")
        v = float(m.group(1)) * factor
    else:
        raise ValueError(f"expected a number in {si_unit} or \"<number> <unit>\", got {value!r}")
    return _finite(v, value)


def _finite(v: float, value) -> float:
    if not math.isfinite(v):
        raise ValueError(f"not a finite number: {value!r}")
    return v


# how a signal in an SI unit is shown to a person (figures, reports): (factor from SI, display unit)
DISPLAY: dict[str, tuple[float, str]] = {"Pa": (1e-5, "bar"), "m": (1e3, "mm"), "m/s": (1e3, "mm/s"),
                                         "rad/s": (60.0 / (2.0 * math.pi), "rpm"), "m3/s": (6e4, "l/min"),
                                         "m3": (1e3, "l")}


def display(unit: str) -> tuple[float, str]:
    """(factor, unit) to show a value in ``unit`` (SI) as an engineer reads it; the unit itself when unlisted."""
    return DISPLAY.get(unit, (1.0, unit))


# ---- an SI unit's dimensions (an FMU's UnitDefinitions: its base units' exponents and factor) ---------------
# symbol -> (the base units' exponents, factor to them): kg, m, s, A, K, mol, cd and rad, as FMI counts them
_BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
_SYMBOLS: dict[str, tuple[dict, float]] = {
    **{b: ({b: 1}, 1.0) for b in _BASE}, "Pa": ({"kg": 1, "m": -1, "s": -2}, 1.0), "N": ({"kg": 1, "m": 1, "s": -2}, 1.0),
    "J": ({"kg": 1, "m": 2, "s": -2}, 1.0), "W": ({"kg": 1, "m": 2, "s": -3}, 1.0), "Hz": ({"s": -1}, 1.0),
    "rev": ({"rad": 1}, 2.0 * math.pi), "deg": ({"rad": 1}, math.pi / 180.0), "1": ({}, 1.0), "-": ({}, 1.0)}
_TERM = re.compile(r"^([A-Za-z]+|1|-)\^?(-?\d+)?$")


def dimensions(unit: str) -> tuple[dict, float] | None:
    """The base units' exponents (kg, m, s, A, K, mol, cd, rad: nonzero ones) and the factor of an SI unit as
    hydrohil writes them ("m^3/(s.Pa)", "N.m.s/rad", "kg.m2", "1/s^2", "-": {}, 1), or None where the exponents are
    not whole (a valve's (l/min)/sqrt(bar))."""
    def product(text: str, sign: int, out: dict) -> float:
        factor = 1.0
        for part in text.split("."):
            m = _TERM.match(part)
            if not m or m.group(1) not in _SYMBOLS:
                raise KeyError(part)
            exps, f = _SYMBOLS[m.group(1)]
            power = int(m.group(2) or 1) * sign
            for base, e in exps.items():
                out[base] = out.get(base, 0) + e * power
            factor *= f ** power
        return factor
    num, _, den = unit.partition("/")
    out: dict = {}
    try:
        factor = product(num, 1, out)
        if den:
            factor *= product(den.strip("()"), -1, out)
    except KeyError:
        return None
    return {b: out[b] for b in _BASE if out.get(b)}, factor
