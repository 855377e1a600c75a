"""Validated parameter schema (SPEC §3-§8). All values SI unless the field says otherwise.

Each field carries its unit and admissible range; loading a file that breaks one of them raises
:class:`hydrohil.errors.InputError` naming the file, the dotted key and what was expected.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

try:
    from hydrohil.parameters.characteristics import derived_linear
except ImportError:     # core/build.py loads this file alone to lay out the C parameter vector: no files read
    derived_linear = None


class StrictModel(BaseModel):
    """Base of every user-facing file schema (parameters, scenarios, faults): unknown keys, NaN and Inf
    are errors; validated objects are immutable."""
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _f(lo: float | None = None, hi: float | None = None, *, gt: float | None = None,
       lt: float | None = None, unit: str = "-", doc: str = ""):
    """A float field with unit text and bounds (ge=lo, le=hi, or strict gt/lt)."""
    return Field(ge=lo, le=hi, gt=gt, lt=lt, description=f"{doc} [{unit}]",
                 json_schema_extra={"unit": unit})


class Spool(StrictModel):
    wn: float = _f(gt=0, hi=1e5, unit="rad/s", doc="natural frequency")
    xi: float = _f(gt=0, hi=10, unit="-", doc="damping ratio")
    lv: float = _f(gt=0, hi=1e6, unit="1/s", doc="spool velocity limit")
    la: float = _f(gt=0, hi=1e9, unit="1/s^2", doc="spool acceleration limit")
    delay: float = _f(0, 0.1, unit="s", doc="pure delay")


# a coefficient of eq 3's pseudo-sections: the component library's servo valve takes the same range
_K = Annotated[float, Field(ge=-1e3, le=1e3)]


class Valve(StrictModel):
    k: tuple[_K, _K, _K, _K, _K] = Field(description="k1..k5 of eq 3 (l/min, bar)")
    kt: tuple[_K, _K, _K, _K, _K] = Field(description="k1t..k5t of eq 3 (l/min, bar)")
    dp_laminar: float = _f(gt=0, hi=5e6, unit="Pa", doc="laminar transition pressure drop")


class Supply(StrictModel):
    ps: float = _f(gt=1e5, hi=1e8, unit="Pa", doc="supply pressure (gauge)")
    pt: float = _f(-1e5, 5e6, unit="Pa", doc="tank pressure (gauge)")

    @model_validator(mode="after")
    def _ps_above_pt(self):
        if self.ps <= self.pt:
            raise ValueError(f"ps ({self.ps} Pa) must exceed pt ({self.pt} Pa)")
        return self


class Cylinder(StrictModel):
    a1: float = _f(gt=0, hi=1.0, unit="m^2", doc="cap-side area A1")
    a2: float = _f(gt=0, hi=1.0, unit="m^2", doc="rod-side area A2")
    v01: float = _f(gt=0, hi=1.0, unit="m^3", doc="dead volume chamber 1")
    v02: float = _f(gt=0, hi=1.0, unit="m^3", doc="dead volume chamber 2")
    stroke: float = _f(gt=0, hi=10.0, unit="m", doc="maximum stroke L")
    g_lkc: float = _f(0, 1e-9, unit="m^3/(s.Pa)", doc="internal leakage conductance")
    bulk_modulus: Literal["pressure", "constant"] = Field(description="eq 21 or constant per chamber")
    b: float = _f(0, 1e-6, unit="1/Pa", doc="eq 21 coefficient B")
    c: float = _f(gt=0, hi=1.0, unit="-", doc="eq 21 coefficient C")
    beta1: float = _f(gt=1e6, hi=1e11, unit="Pa", doc="constant bulk modulus, chamber 1")
    beta2: float = _f(gt=1e6, hi=1e11, unit="Pa", doc="constant bulk modulus, chamber 2")

    @field_validator("a2")
    @classmethod
    def _annulus(cls, a2, info):          # (a differential cylinder: the rod takes part of the bore; core/params.c)
        a1 = info.data.get("a1")
        if a1 is not None and not a2 < a1:
            raise ValueError(f"the rod-side annulus must be smaller than a1 ({a1} m^2)")
        return a2


class StaticFriction(StrictModel):
    fc: float = _f(0, 1e6, unit="N", doc="Coulomb force")
    fs: float = _f(gt=0, hi=1e6, unit="N", doc="breakaway (static) force Fs: the Stribeck curve at v = 0")
    vs: float = _f(gt=0, hi=10, unit="m/s", doc="Stribeck velocity")
    kv: float = _f(0, 1e7, unit="N.s/m", doc="viscous coefficient")

    @model_validator(mode="after")
    def _breakaway(self):
        if self.fs < self.fc:
            raise ValueError(f"fs (breakaway, {self.fs} N) must be >= fc ({self.fc} N)")
        return self


class Friction(StrictModel):
    sigma0: float = _f(gt=0, hi=1e12, unit="N/m", doc="bristle stiffness")
    sigma1: float = _f(0, 1e8, unit="N.s/m", doc="bristle damping")
    asymmetric: bool = Field(description="use positive/negative sets instead of symmetric")
    symmetric: StaticFriction
    positive: StaticFriction
    negative: StaticFriction


class Load(StrictModel):
    mass: float = _f(gt=0, hi=1e6, unit="kg", doc="moved mass")
    gravity_direction: Literal[-1, 0, 1] = Field(description="+1 gravity aids extension")
    gravity: float = _f(0, 30, unit="m/s^2", doc="gravity acceleration")
    force: float = _f(-1e7, 1e7, unit="N", doc="external force, positive opposes extension")


class Linear(StrictModel):
    """The paper's linearised model (eq 18-20, SPEC §7) and the default piston position; derived from the
    other groups when a file has no [linear] (:func:`hydrohil.parameters.characteristics.derived_linear`)."""
    xp0: float = _f(0, 10, unit="m", doc="linearisation position, and the default initial piston position")
    xs0: float = _f(-1, 1, unit="-", doc="spool position of the paper's linearised model (eq 19-20)")
    friction_factor: float = _f(0, 1e8, unit="N.s/m", doc="friction factor f of eq 20")
    kq: float = _f(gt=0, hi=1.0, unit="m^3/s", doc="flow gain per unit spool at pn on each edge (eq 19)")
    kp1: float = _f(-1e4, 1e4, unit="-", doc="pressure gain dP1/dxs per Ps, ports closed (eq 19)")
    kp2: float = _f(-1e4, 1e4, unit="-", doc="pressure gain dP2/dxs per Ps, ports closed (eq 19)")
    pn: float = _f(gt=0, hi=1e8, unit="Pa", doc="nominal pressure drop of kq")


class Sensors(StrictModel):
    encoder_resolution: float = _f(0, 1e-2, unit="m", doc="encoder count size (0 = ideal)")
    pressure_range: float = _f(gt=0, hi=1e9, unit="Pa", doc="transducer full scale")
    pressure_resolution: float = _f(0, 1e6, unit="Pa", doc="ADC quantum (0 = ideal)")
    pressure_noise: float = _f(0, 1e6, unit="Pa", doc="RMS noise (0 = none)")


class Parameters(StrictModel):
    """A complete, validated parameter set."""

    spool: Spool
    valve: Valve
    supply: Supply
    cylinder: Cylinder
    friction: Friction
    load: Load
    linear: Linear
    sensors: Sensors

    _derived: frozenset = PrivateAttr(default=frozenset())     # groups derived rather than given

    @model_validator(mode="wrap")
    @classmethod
    def _derive_linear(cls, data, handler):
        """A file without [linear] gets it derived from its other groups (they are checked after this: what
        cannot be derived from is left to their own errors); the set remembers it (:attr:`derived_groups`), so
        a changed value re-derives it (:func:`hydrohil.parameters.replace_values`)."""
        derived = isinstance(data, dict) and "linear" not in data and derived_linear is not None
        params = handler(with_derived_linear(data))
        if derived:
            params._derived = frozenset({"linear"})
        return params

    @property
    def derived_groups(self) -> frozenset:
        """The groups derived from the others because the set's file did not give them."""
        return self._derived

    @model_validator(mode="after")
    def _geometry(self):
        if self.linear.xp0 > self.cylinder.stroke:
            raise ValueError(f"linear.xp0 ({self.linear.xp0} m) lies beyond cylinder.stroke "
                             f"({self.cylinder.stroke} m)")
        return self

    def friction_sets(self) -> tuple[StaticFriction, StaticFriction]:
        """(positive, negative) static friction sets actually used by the models."""
        f = self.friction
        return (f.positive, f.negative) if f.asymmetric else (f.symmetric, f.symmetric)


def with_derived_linear(data):
    """``data`` (a parameter file's tables) with a derived ``linear`` group when it has none; unchanged when
    it has one or when its other groups are not complete enough to derive it from."""
    if not isinstance(data, dict) or "linear" in data or derived_linear is None:
        return data
    try:
        return {**data, "linear": derived_linear(data)}
    except (KeyError, TypeError, ValueError, IndexError):
        return data


# Values that load but are probably in another unit than the schema's: (dotted key, test, what to say)
PLAUSIBLE = (
    ("spool.wn", lambda v: v < 2 * math.pi * 15,
     lambda v: f"{v:g} rad/s is {v / (2 * math.pi):.3g} Hz: spools of servo and proportional valves have "
               f"20-300 Hz; if {v:g} is in Hz, give {2 * math.pi * v:.6g} rad/s"),
    ("spool.delay", lambda v: v > 0.01,
     lambda v: f"{v:g} s is {v * 1e3:g} ms: valve delays are 0.1-5 ms; if {v:g} is in ms, give {v * 1e-3:g} s"),
)


def implausible(params: "Parameters") -> list[tuple[str, str]]:
    """(dotted key, message) for each value that is valid but probably a unit mistake."""
    out = []
    for key, bad, say in PLAUSIBLE:
        group, name = key.split(".")
        v = getattr(getattr(params, group), name)
        if bad(v):
            out.append((key, say(v)))
    return out
