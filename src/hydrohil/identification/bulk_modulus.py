"""Effective bulk modulus and friction factor from acceleration–frequency data (paper §3.2.1, Figs 6-8).

Per supply pressure Ps, (βe1, βe2, f) of the linearised model (eq 18-20, constant bulk moduli) minimise
the distance between measured and simulated piston-acceleration amplitude in the acceleration–frequency
plane, taken as the log ratio Σ ln(a_model/a_data)² (a 10 % miss weighs the same at the resonance peak and
at 1 Hz). With two or more supply pressures, the points (P10, βe1), (P20, βe2) at the equilibrium
pressures of eq 18 give B and C of eq 21 by linear least squares: (1e5 + P)/βe = B·P + C.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from hydrohil.errors import InputError
from hydrohil.identification.data import Column, read_table
from hydrohil.identification.result import Fit
from hydrohil.models.cylinder import P_ATM
from hydrohil.models.linear import equilibrium_pressures, linear_model
from hydrohil.parameters import Parameters, load_parameters, replace_values

COLUMNS = (
    Column("ps", "Pa", 1e5, 1e8, "supply pressure in Pa (70 bar = 7e6 Pa)"),
    Column("frequency_hz", "Hz", 0.01, 1e4),
    Column("accel", "m/s^2", 0.0, 1e7),
    Column("xs_amplitude", "fraction of full spool stroke", 1e-6, 1.0, default=1.0),
)
MIN_POINTS_PER_PRESSURE = 5


def read_accel(path: str | Path) -> dict[str, np.ndarray]:
    d = read_table(path, COLUMNS, min_rows=MIN_POINTS_PER_PRESSURE)
    if np.any(d["accel"] <= 0):
        raise InputError("acceleration amplitudes must be > 0 m/s^2", source=str(path), key="accel")
    return d


def beta_eq21(p, b, c):
    """Effective bulk modulus [Pa] at gauge pressure p [Pa], eq 21."""
    return (P_ATM + p) / (b * p + c)


def _fit_one(params: Parameters, f_hz, a_meas):
    """(beta1, beta2, f, cost) for one supply pressure."""
    v1 = params.cylinder.v01 + params.cylinder.a1 * params.linear.xp0
    v2 = params.cylinder.v02 + params.cylinder.a2 * (params.cylinder.stroke - params.linear.xp0)
    c, M = params.cylinder, params.load.mass
    wpk = 2 * np.pi * f_hz[np.argmax(a_meas)]
    beta0 = wpk ** 2 * M / (c.a1 ** 2 / v1 + c.a2 ** 2 / v2)   # undamped resonance at the peak
    la = np.log(a_meas)

    def res(theta):
        b1, b2, ff = np.exp(theta)
        lm = linear_model(params, beta1=b1, beta2=b2, friction_factor=ff)
        return np.log(lm.acceleration_amplitude(f_hz)) - la

    best = None
    for f0 in (1e3, 1e4, 1e5):
        for r in (1.0, 0.7, 1.4):
            sol = least_squares(res, np.log([beta0 * r, beta0 / r, f0]), xtol=1e-12, ftol=1e-12, max_nfev=500)
            if best is None or sol.cost < best.cost:
                best = sol
    b1, b2, ff = np.exp(best.x)
    return float(b1), float(b2), float(ff), float(2 * best.cost)


def fit_eq21(pressures, betas) -> tuple[float, float, float]:
    """(B, C, rms relative error) of eq 21 through (P, βe) points, B >= 0, C > 0."""
    P, beta = np.asarray(pressures, float), np.asarray(betas, float)
    A = np.column_stack([P, np.ones_like(P)]) * (beta / (P_ATM + P))[:, None]  # rows: (B*P + C)*beta/(1e5 + P)
    sol = lsq_linear(A, np.ones_like(P), bounds=([0.0, 1e-12], [np.inf, np.inf]))
    B, C = (float(x) for x in sol.x)
    err = beta_eq21(P, B, C) / beta - 1
    return B, C, float(np.sqrt(np.mean(err ** 2)))


def identify_bulk_modulus(data: dict[str, np.ndarray] | str | Path, params: Parameters | str = "ferreira2004",
                          *, progress=None) -> Fit:
    """βe1, βe2, f per supply pressure (eq 20) and B, C of eq 21 when several pressures are given.
    ``params`` supplies the rest of the linear model (areas, volumes, mass, X_p0, valve gains)."""
    t_start = time.perf_counter()
    src = str(data) if isinstance(data, (str, Path)) else "data"
    d = read_accel(data) if isinstance(data, (str, Path)) else data
    params = load_parameters(params) if isinstance(params, (str, Path)) else params
    per, curves = [], {}
    groups = np.unique(d["ps"])
    for i, ps in enumerate(groups):
        m = d["ps"] == ps
        f_hz, acc = d["frequency_hz"][m], d["accel"][m] / d["xs_amplitude"][m]
        if f_hz.size < MIN_POINTS_PER_PRESSURE:
            raise InputError(f"only {f_hz.size} points at ps = {ps:g} Pa (need {MIN_POINTS_PER_PRESSURE})",
                             source=src, key="ps")
        order = np.argsort(f_hz)
        f_hz, acc = f_hz[order], acc[order]
        pp = replace_values(params, {"supply.ps": float(ps)}, source=src)
        b1, b2, ff, cost = _fit_one(pp, f_hz, acc)
        p10, p20 = equilibrium_pressures(pp)
        per.append({"ps": float(ps), "beta1": b1, "beta2": b2, "f": ff, "p10": float(p10), "p20": float(p20),
                    "cost": cost})
        lm = linear_model(pp, beta1=b1, beta2=b2, friction_factor=ff)
        fine = np.linspace(f_hz.min(), f_hz.max(), 400)
        curves[float(ps)] = {"frequency_hz": f_hz, "accel": acc, "fit_f": fine,
                             "fit_a": lm.acceleration_amplitude(fine),
                             "natural_frequency_hz": lm.natural_frequency / (2 * np.pi), "damping": lm.damping}
        if progress:
            progress(i + 1, len(groups))
    values: dict = {"b": None, "c": None, "per_pressure": per}
    updates = {"cylinder.beta1": per[0]["beta1"], "cylinder.beta2": per[0]["beta2"],
               "linear.friction_factor": per[0]["f"]}
    notes = []
    if len(per) > 1:
        # nominal constant moduli / friction factor: those at the pressure closest to the parameter set's Ps
        near = min(per, key=lambda r: abs(r["ps"] - params.supply.ps))
        updates = {"cylinder.beta1": near["beta1"], "cylinder.beta2": near["beta2"],
                   "linear.friction_factor": near["f"]}
        P = [r["p10"] for r in per] + [r["p20"] for r in per]
        beta = [r["beta1"] for r in per] + [r["beta2"] for r in per]
        B, C, rms = fit_eq21(P, beta)
        values.update(b=B, c=C, eq21_rms_relative=rms)
        updates.update({"cylinder.b": B, "cylinder.c": C})
        curves["eq21"] = {"p": np.array(P), "beta": np.array(beta), "b": B, "c": C}
    else:
        notes.append("one supply pressure: B and C of eq 21 need two or more (left unchanged)")
    fit = Fit("bulk-modulus", values, cost=float(sum(r["cost"] for r in per)), updates=updates, notes=notes,
              curves=curves)
    fit.wall_time_s = time.perf_counter() - t_start
    return fit


def synthetic_accel(params: Parameters, pressures, b, c, friction_factors, freqs=np.arange(1.0, 131.0, 2.0),
                    noise=0.0, seed=0) -> dict[str, np.ndarray]:
    """Acceleration-amplitude data of the linear model with βe from eq 21 (B, C) at each supply pressure."""
    rng = np.random.default_rng(seed)
    cols = {"ps": [], "frequency_hz": [], "accel": [], "xs_amplitude": []}
    for ps, ff in zip(pressures, friction_factors):
        pp = replace_values(params, {"supply.ps": float(ps)})
        p10, p20 = equilibrium_pressures(pp)
        lm = linear_model(pp, beta1=beta_eq21(p10, b, c), beta2=beta_eq21(p20, b, c), friction_factor=ff)
        a = lm.acceleration_amplitude(freqs) * np.exp(noise * rng.standard_normal(freqs.size))
        cols["ps"] += [ps] * freqs.size
        cols["frequency_hz"] += list(freqs)
        cols["accel"] += list(a)
        cols["xs_amplitude"] += [1.0] * freqs.size
    return {k: np.asarray(v, float) for k, v in cols.items()}
