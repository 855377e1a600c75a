"""Static friction curve from constant-velocity points (paper §3.2.3 a, eq 24-26).

Ff_ss(v) = [Fc + (Fs − Fc)·exp(−(v/vs)²)]·sgn(v) + Kv·v (eq 25) is fitted by the least squares of
eq 26, symmetric (all points) and per direction (v > 0 and v < 0 separately, on |Ff|), with the
Nelder–Mead simplex the paper used, started from the data (Fc, Kv by a line through the fast points,
Fs from the slowest points) and polished by a trust-region least-squares step. Here ``fs`` is the
breakaway force Fc + (Fs − Fc), as in the parameter files.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares, minimize

from hydrohil.errors import InputError
from hydrohil.identification.data import Column, read_table
from hydrohil.identification.result import Fit
from hydrohil.models.friction import steady_state_friction

COLUMNS = (
    Column("v", "m/s", -10.0, 10.0, "velocity in m/s"),
    Column("ff", "N", -1e6, 1e6),
)
MIN_POINTS_PER_SIDE = 6


def _fit_side(v, ff) -> tuple[dict[str, float], float, float]:
    """Fit |Ff| = Fc + (Fs − Fc)·exp(−(|v|/vs)²) + Kv·|v| to one direction; (params, cost, rms)."""
    av, af = np.abs(v), np.abs(ff)
    fast = av >= np.quantile(av, 0.5)
    kv0, fc0 = np.polyfit(av[fast], af[fast], 1)
    kv0, fc0 = max(kv0, 0.0), max(fc0, 1e-3)
    slow = av <= np.quantile(av, 0.2)
    fs0 = max(float(np.max(af[slow])), fc0 * 1.01)
    vs0 = max(float(np.quantile(av, 0.25)), 1e-5)
    scale = np.array([fc0, fs0, vs0, max(kv0, 1.0)])

    def model(x):
        fc, dfs, vs, kv = x * scale
        return fc + dfs * np.exp(-(av / vs) ** 2) + kv * av

    def cost(x):                       # eq 26
        if x[2] <= 0:
            return 1e30
        return float(np.sum((af - model(x)) ** 2))

    x0 = np.array([1.0, (fs0 - fc0) / fs0, 1.0, 1.0])
    nm = minimize(cost, x0, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000,
                                                            "maxfev": 40000})
    ls = least_squares(lambda x: af - model(x), nm.x, bounds=([0, 0, 1e-9, 0], np.inf), xtol=1e-14, ftol=1e-14)
    x = ls.x if 2 * ls.cost <= nm.fun else nm.x
    fc, dfs, vs, kv = x * scale
    c = cost(x)
    return {"fc": float(fc), "fs": float(fc + dfs), "vs": float(vs), "kv": float(kv)}, c, float(np.sqrt(c / av.size))


def identify_friction_static(data: dict[str, np.ndarray] | str | Path) -> Fit:
    """Symmetric and per-direction eq 25 parameters from (v, Ff) points; residuals in ``achieved``."""
    t0 = time.perf_counter()
    src = str(data) if isinstance(data, (str, Path)) else "data"
    d = read_table(data, COLUMNS, min_rows=2 * MIN_POINTS_PER_SIDE) if isinstance(data, (str, Path)) else data
    v, ff = np.asarray(d["v"], float), np.asarray(d["ff"], float)
    keep = v != 0
    v, ff = v[keep], ff[keep]
    pos, neg = v > 0, v < 0
    for name, m in (("v > 0", pos), ("v < 0", neg)):
        if m.sum() < MIN_POINTS_PER_SIDE:
            raise InputError(f"only {int(m.sum())} points with {name} (need {MIN_POINTS_PER_SIDE} per direction)",
                             source=src, key="v")
    wrong = np.sign(ff) != np.sign(v)
    if wrong.mean() > 0.2:
        raise InputError(f"{wrong.mean():.0%} of the friction forces oppose the sign convention (Ff has the sign "
                         "of v: Ff = P1*A1 - P2*A2 at constant velocity, eq 24)", source=src, key="ff")
    if np.max(np.abs(v)) > 5.0:
        raise InputError(f"|v| up to {np.max(np.abs(v)):g}: velocities must be in m/s", source=src, key="v")
    sym, c_sym, rms_sym = _fit_side(v, ff)
    p, c_p, rms_p = _fit_side(v[pos], ff[pos])
    n, c_n, rms_n = _fit_side(v[neg], ff[neg])
    values = {"symmetric": sym, "positive": p, "negative": n}
    updates = {f"friction.{side}.{k}": val for side, s in values.items() for k, val in s.items()}
    updates["friction.asymmetric"] = True
    fit = Fit("friction-static", values, cost=c_p + c_n,
              updates=updates,
              achieved={"cost_symmetric": c_sym, "cost_asymmetric": c_p + c_n, "rms_symmetric_n": rms_sym,
                        "rms_positive_n": rms_p, "rms_negative_n": rms_n},
              curves={"v": v, "ff": ff})
    fit.wall_time_s = time.perf_counter() - t0
    return fit


def synthetic_friction(pos: dict, neg: dict, v=None, noise=0.0, seed=0) -> dict[str, np.ndarray]:
    """(v, Ff) points of eq 25 with different parameters per direction, + Gaussian noise [N]."""
    if v is None:
        half = np.concatenate([np.linspace(0.002, 0.02, 10), np.linspace(0.025, 0.2, 15)])
        v = np.concatenate([-half[::-1], half])
    v = np.asarray(v, float)
    ff = np.where(v > 0, steady_state_friction(v, **pos), steady_state_friction(v, **neg))
    rng = np.random.default_rng(seed)
    return {"v": v, "ff": ff + noise * rng.standard_normal(v.size)}
