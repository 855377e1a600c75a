"""The plant linearised at any operating point at rest (the paper's eq 18-20 generalised; README "Linear
analysis").

The operating point is a piston position ``xp`` at rest under the parameter set's supply pressure and load:
the equilibrium spool offset ``xs`` and chamber pressures (p1, p2) at which both chambers' net flows vanish
(the valve's null leakage and the internal leakage balance) and the pressures hold the load (friction
zero). The matrices are the exact derivatives of the hybrid model's equations there (``core/linear.c``):
state [xs, vs, p1, p2, vp, xp], inputs [ū, F_L], outputs [xp, vp, p1, p2]; the valve's pure delay
(``spool.delay``) is kept apart (:attr:`LinearPlant.delay`), exact in :meth:`LinearPlant.frequency_response`,
a Padé approximation in :func:`state_space`.

``paper``'s eq 20 with the datasheet's constant gains stays in :mod:`hydrohil.models.linear` (the bulk
modulus identification of §9.3 uses it as the paper does).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hydrohil.core import dptr, lib
from hydrohil.errors import InputError
from hydrohil.models.layout import pack
from hydrohil.models.rest import chamber_pressures, net_force, rest_state
from hydrohil.parameters import Parameters, replace_values

STATES = ("xs", "vs", "p1", "p2", "vp", "xp")
STATE_UNITS = ("-", "1/s", "Pa", "Pa", "m/s", "m")
INPUTS = ("u", "F_L")
INPUT_UNITS = ("-", "N")
OUTPUTS = ("xp", "vp", "p1", "p2")
_C = np.zeros((4, 6))
_C[0, 5] = _C[1, 4] = _C[2, 2] = _C[3, 3] = 1.0


@dataclass(frozen=True)
class OperatingPoint:
    xp: float        # piston position [m]
    xs: float        # equilibrium spool offset [-] (the command that holds the piston there)
    p1: float        # chamber pressures [Pa gauge]
    p2: float
    ps: float        # supply pressure [Pa]
    load: float      # external load force F_L [N] (against +x)
    net_force: float = 0.0   # force on the piston there [N] (0 at the equilibrium; not with a forced xs)


@dataclass(frozen=True)
class LinearPlant:
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    point: OperatingPoint
    delay: float                 # the valve's pure delay on ū [s]
    friction_slope: float        # dFf/dvp used [N.s/m]
    coefficients: dict = field(default_factory=dict)   # beta1, beta2 [Pa], V1, V2 [m^3], Kq1, Kq2, Kc1, Kc2
    mass: float = 0.0
    areas: tuple = (0.0, 0.0)

    @property
    def eigenvalues(self) -> np.ndarray:
        return np.linalg.eigvals(self.A)

    def _hydraulic_pair(self) -> complex | None:
        ev = np.linalg.eigvals(self.A[2:, 2:])          # the cylinder's states p1, p2, vp, xp
        cx = ev[ev.imag > 1e-9]
        return complex(cx[np.argmax(np.abs(cx))]) if cx.size else None

    @property
    def natural_frequency(self) -> float:
        """Hydraulic natural frequency [rad/s]: |λ| of the cylinder's oscillatory eigenvalue pair."""
        lam = self._hydraulic_pair()
        return abs(lam) if lam is not None else float("nan")

    @property
    def damping(self) -> float:
        lam = self._hydraulic_pair()
        return -lam.real / abs(lam) if lam is not None else float("nan")

    @property
    def closed_form_frequency(self) -> float:
        """ωh = √((β1·A1²/V1 + β2·A2²/V2)/M) [rad/s]: the classic formula (no friction, no flow-pressure
        coefficients), with each chamber's bulk modulus at its pressure."""
        c, (a1, a2) = self.coefficients, self.areas
        return math.sqrt((c["beta1"] * a1 ** 2 / c["V1"] + c["beta2"] * a2 ** 2 / c["V2"]) / self.mass)

    def frequency_response(self, freq_hz, output: str = "xp", input: str = "u") -> np.ndarray:
        """Complex gain output/input at the frequencies [Hz], the valve's delay included exactly."""
        w = 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, dtype=float))
        i, o = INPUTS.index(input), OUTPUTS.index(output)
        out = np.empty(w.shape, dtype=complex)
        eye = np.eye(6)
        for k, wk in enumerate(w):
            x = np.linalg.solve(1j * wk * eye - self.A, self.B[:, i])
            out[k] = self.C[o] @ x * (np.exp(-1j * wk * self.delay) if input == "u" else 1.0)
        return out

    def outputs_per_command(self, freq_hz) -> np.ndarray:
        """[n, 4] complex gains of (xp, vp, p1, p2) per unit ū, delay included (closed-loop prediction)."""
        return np.stack([self.frequency_response(freq_hz, o, "u") for o in OUTPUTS], axis=1)

    def to_dict(self) -> dict:
        ev = self.eigenvalues
        return {
            "operating_point": vars(self.point), "delay_s": self.delay, "friction_slope_Ns_per_m": self.friction_slope,
            "states": list(STATES), "state_units": list(STATE_UNITS), "inputs": list(INPUTS),
            "input_units": list(INPUT_UNITS), "outputs": list(OUTPUTS),
            "A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(), "D": self.D.tolist(),
            "eigenvalues": [[float(e.real), float(e.imag)] for e in ev],
            "natural_frequency_rad_s": self.natural_frequency, "natural_frequency_hz": self.natural_frequency / (2 * math.pi),
            "damping": self.damping, "closed_form_frequency_rad_s": self.closed_form_frequency,
            "coefficients": self.coefficients,
        }


def _friction_slope(p: np.ndarray) -> float:
    """The local viscous slope of the steady-state friction at rest: the mean of the two directions' kv."""
    return 0.5 * (float(p[lib.HH_KV_POS]) + float(p[lib.HH_KV_NEG]))


def equilibrium(params: Parameters, xp: float, xs: float | None = None) -> OperatingPoint:
    """The operating point at rest at ``xp`` (module docstring): the spool offset from the force balance over
    the pressures at rest (:mod:`hydrohil.models.rest`). ``xs`` forces the spool
    offset instead: the flows still balance, the force need not (``net_force``)."""
    L = params.cylinder.stroke
    if not 0.0 <= xp <= L:
        raise InputError(f"must lie in [0, {L}] m (cylinder.stroke), got {xp}", key="xp")
    p = pack(params)
    if xs is None:
        xs, p1, p2 = rest_state(params, p)
    elif not -1.0 <= xs <= 1.0:
        raise InputError(f"must lie in [-1, 1], got {xs}", key="xs")
    else:
        p1, p2 = chamber_pressures(params, xs, p)
    return OperatingPoint(float(xp), float(xs), float(p1), float(p2), float(params.supply.ps),
                          float(params.load.force), float(net_force(params, p1, p2, p)))


def with_point(params: Parameters, *, ps: float | None = None, load: float | None = None) -> Parameters:
    """``params`` with the supply pressure and the external load force replaced (None: kept)."""
    values = {}
    if ps is not None:
        values["supply.ps"] = ps
    if load is not None:
        values["load.force"] = load
    return replace_values(params, values, "linear") if values else params


def linearise(params: Parameters, xp: float | None = None, *, xs: float | None = None, ps: float | None = None,
              load: float | None = None, friction: bool = True) -> LinearPlant:
    """The plant linearised at rest at ``xp`` (default ``linear.xp0``) with supply ``ps`` and load force
    ``load`` (default: the set's). ``xs`` forces the spool offset (the pressures are those that balance the
    flows there; the load need not be held: ``point.net_force``); ``friction=False`` drops the viscous
    slope."""
    params = with_point(params, ps=ps, load=load)
    xp = params.linear.xp0 if xp is None else float(xp)
    point = equilibrium(params, xp, xs)
    p = pack(params)
    A, B, coef = np.zeros(36), np.zeros(12), np.zeros(8)
    slope = _friction_slope(p) if friction else 0.0
    lib.hh_linearise(dptr(p), point.xs, point.p1, point.p2, point.xp, slope, dptr(A), dptr(B), dptr(coef))
    names = ("beta1", "beta2", "V1", "V2", "Kq1", "Kq2", "Kc1", "Kc2")
    return LinearPlant(A.reshape(6, 6), B.reshape(6, 2), _C.copy(), np.zeros((4, 2)), point,
                       params.spool.delay, slope, dict(zip(names, map(float, coef))), params.load.mass,
                       (params.cylinder.a1, params.cylinder.a2))


def state_space(params: Parameters | None = None, xp: float | None = None, *, pade: int = 3, **kw):
    """The linear plant as a python-control ``StateSpace`` (inputs u, F_L; outputs xp, vp, p1, p2), the
    valve's delay as a Padé approximation of order ``pade`` on ū (0: left out). Needs the optional
    package: ``pip install "hydrohil[control]"``."""
    try:
        import control
    except ImportError:
        raise ImportError('hydrohil.linear.state_space needs python-control: pip install "hydrohil[control]"') from None
    if params is None:
        from hydrohil.parameters import load_parameters
        params = load_parameters("ferreira2004")
    lp = linearise(params, xp, **kw)
    sys = control.ss(lp.A, lp.B, lp.C, lp.D, inputs=list(INPUTS), outputs=list(OUTPUTS), states=list(STATES),
                     name="hydrohil_plant")
    if pade and lp.delay > 0:
        num, den = control.pade(lp.delay, pade)
        d = control.tf2ss(control.tf(num, den))
        delay = control.ss(d.A, d.B, d.C, d.D, inputs=["u_cmd"], outputs=["u"], name="valve_delay")
        sys = control.interconnect([delay, sys], inputs=["u_cmd", "F_L"], outputs=list(OUTPUTS),
                                   name="hydrohil_plant")
    return sys


def save(models: list[LinearPlant], path: Path) -> Path:
    """Write the models (one per operating point) to ``.json``, ``.npz`` or ``.mat`` (arrays stacked along
    the first axis: A [n, 6, 6] ...)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".json":
        path.write_text(json.dumps({"models": [m.to_dict() for m in models]}, indent=2) + "\n")
        return path
    arrays = {k: np.stack([getattr(m, k) for m in models]) for k in ("A", "B", "C", "D")}
    for k in ("xp", "xs", "p1", "p2", "ps", "load"):
        arrays[k] = np.array([getattr(m.point, k) for m in models])
    arrays["delay"] = np.array([m.delay for m in models])
    arrays["natural_frequency"] = np.array([m.natural_frequency for m in models])
    arrays["damping"] = np.array([m.damping for m in models])
    arrays["states"], arrays["inputs"], arrays["outputs"] = np.array(STATES), np.array(INPUTS), np.array(OUTPUTS)
    if path.suffix == ".npz":
        np.savez(path, **arrays)
    elif path.suffix == ".mat":
        from scipy.io import savemat
        savemat(path, arrays)
    else:
        raise InputError("expected a .json, .npz or .mat file", source="--out", key=str(path))
    return path
