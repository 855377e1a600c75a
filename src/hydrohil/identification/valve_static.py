"""Pseudo-section parameters k1..k5, k1t..k5t (eq 3) from datasheet characteristics (paper §3.1.2).

How the system eq 4-17 is solved, and which choice it leaves open
-----------------------------------------------------------------
Write s0 = As1(0) = As2(0), t0 = A1t(0) = A2t(0) and s0' = dAs2/dx̄s(0), t0' = dA1t/dx̄s(0) (eq 3 makes
As1(x) = As2(−x), A2t(x) = A1t(−x)). With closed ports, α = sqrt(Ps/2 − ΔPm), β = sqrt(Ps/2 + ΔPm):
  eq 4    ΔPm = Ps/2·(s0² − t0²)/(s0² + t0²)         → r = t0/s0 = α/β
  eq 5-6  K̄p0 = −4·s0·t0·(s0'·t0 + s0·t0')/(s0² + t0²)²
  eq 8    K̄q0 = −(s0'·α + t0'·β) = −(β/s0)·(s0'·t0 + s0·t0')       (eq 9 is eq 8 again)
So K̄p0/K̄q0 fixes s0 (hence t0 and the centre leakage q_l0 of eq 12: it is *implied* by ΔPm, K̄p0
and K̄q0, not free; for the paper's datasheet q_l0 = 1.466 l/min, while the datasheet says 1.36, which
this model form cannot match together with K̄p0 and K̄q0), and the combination s0'·t0 + s0·t0'. How that
centre slope splits between the supply-side and the tank-side edges is the one free choice: the paper's
ten equations are only nine independent ones. Our rule: As2'(0)/A1t'(0) = ``slope_ratio`` (datasheet key,
default 1: both metering edges open at the same rate; the paper's published set has 1.048).
Each section S(x) = k1·x + k2 + sqrt(k3·x² + k4·x + k5) then has five conditions for its five k's:
S(0) and S'(0) (centre), S(1) = q_l1/sqrt(Ps) and S'(1) = 0 (eq 14-17: the closed side at full opening,
q_l1 = 0 by default) and S(−1) = Qn/sqrt(Pn) (eq 10-11). With u = sqrt(k5) and w = sqrt(k3 + k4 + k5)
three are linear in the k's, leaving two equations in (u, w), solved by Newton (scipy ``fsolve``) from
several starts; the root whose radicand stays positive on [−1, 1] is kept. Targets with no such root
fall back to a least-squares compromise over all conditions. Every characteristic is reported achieved
vs target (``achieved``, ``relative_error``).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.optimize import fsolve, least_squares

from hydrohil.errors import InputError
from hydrohil.identification.data import Column, keys_from_mapping, read_keys
from hydrohil.identification.result import Fit
from hydrohil.models import valve

FIELDS = (
    Column("qn_lpm", "l/min", 1e-3, 1e5),
    Column("pn_bar", "bar", 0.1, 1000.0, "nominal pressure drop in bar (35, not 3.5e6)"),
    Column("ps_bar", "bar", 0.1, 1000.0, "supply pressure in bar (70, not 7e6)"),
    Column("kq0_lpm", "l/min", 1e-3, 1e5),
    Column("kp0", "-", 1e-3, 1e5),
    Column("dpm_bar", "bar", -1000.0, 1000.0),
    Column("ql0_lpm", "l/min", 0.0, 1e4, default=np.nan),
    Column("ql1_lpm", "l/min", 0.0, 1e4, default=0.0),
    Column("slope_ratio", "-", 0.05, 20.0, default=1.0),
)


def read_datasheet(path: str | Path) -> dict[str, float]:
    return read_keys(path, FIELDS)


def _section_from_conditions(s0, ds0, s1, a_open) -> np.ndarray:
    """k1..k5 of one section with S(0)=s0, S'(0)=ds0, S(1)=s1, S'(1)=0, S(-1)=a_open."""

    def ks(uw):
        u, w = uw
        k2 = s0 - u
        k1 = s1 - k2 - w
        k4 = 2 * u * (ds0 - k1)
        k3 = -k1 * w - k4 / 2
        return np.array([k1, k2, k3, k4, u * u])

    def eqs(uw):
        u, w = uw
        k1, k2, k3, k4, k5 = ks(uw)
        return [k3 + k4 + k5 - w * w, (k3 - k4 + k5) - (a_open + k1 - k2) ** 2]

    best = None
    for u0 in (0.9 * s0, 0.5 * s0, 0.1 * s0, 2 * s0):
        for w0 in (0.5 * a_open, a_open, 0.1 * a_open, 2 * a_open):
            sol, info, ier, _ = fsolve(eqs, [u0, w0], full_output=True, xtol=1e-14)
            if ier != 1 or sol[0] <= 0 or sol[1] <= 0:
                continue
            k = ks(sol)
            x = np.linspace(-1, 1, 401)
            if np.min(k[2] * x * x + k[3] * x + k[4]) < -1e-12 or a_open + k[0] - k[1] < 0:
                continue
            err = np.abs(eqs(sol)).max()
            if best is None or err < best[0]:
                best = (err, k)
    return None if best is None else best[1]


def characteristics(k, kt, ps_bar: float, pn_bar: float | None = None) -> dict[str, float]:
    """Every characteristic of a k-set, in the datasheet's names and units (l/min, bar)."""
    sec1 = np.array(valve.pseudo_sections_np(1.0, k, kt), float)
    d = 1e-6
    sec1m = np.array(valve.pseudo_sections_np(1.0 - d, k, kt), float)
    out = {
        "dpm_bar": float(valve.delta_pm(ps_bar, k, kt)),
        "kp0": valve.pressure_gain(k, kt),
        "kq0_lpm": valve.flow_gain(ps_bar, k, kt),
        "kq0_lpm_eq9": float((valve.load_flow_2(1e-6, ps_bar, k, kt) - valve.load_flow_2(-1e-6, ps_bar, k, kt)) / 2e-6),
        "ql0_lpm": float(valve.leakage_flow(0.0, ps_bar, k, kt)),
        "ql1_lpm": float(np.sqrt(ps_bar) * sec1[1]),
        "as1_at_1": float(sec1[0]), "a2t_at_1": float(sec1[3]),
        "as2_at_1": float(sec1[1]), "a1t_at_1": float(sec1[2]),
        "d_as2_at_1": float((sec1[1] - sec1m[1]) / d), "d_a1t_at_1": float((sec1[2] - sec1m[2]) / d),
        "crossing_bar": float(ps_bar / 2 + valve.delta_pm(ps_bar, k, kt)),
    }
    if pn_bar is not None:
        out["qn_lpm_from_as1"] = float(sec1[0] * np.sqrt(pn_bar))
        out["qn_lpm_from_a2t"] = float(sec1[3] * np.sqrt(pn_bar))
    return out


def _targets(ds: dict[str, float]) -> dict[str, float]:
    return {"dpm_bar": ds["dpm_bar"], "kp0": ds["kp0"], "kq0_lpm": ds["kq0_lpm"], "ql0_lpm": ds["ql0_lpm"],
            "ql1_lpm": ds["ql1_lpm"], "qn_lpm_from_as1": ds["qn_lpm"], "qn_lpm_from_a2t": ds["qn_lpm"]}


def _least_squares_fallback(ds, x0):
    ps, a = ds["ps_bar"], ds["qn_lpm"] / np.sqrt(ds["pn_bar"])
    tg = _targets(ds)

    def res(theta):
        with np.errstate(invalid="ignore", divide="ignore"):   # 0/0 of a closed section: nan_to_num below
            c = characteristics(theta[:5], theta[5:], ps, ds["pn_bar"])
        r = [(c[key] - v) / max(abs(v), 1e-3 * a) for key, v in tg.items() if key not in ("ql1_lpm", "ql0_lpm")]
        r += [(c["ql1_lpm"] - ds["ql1_lpm"]) / ds["qn_lpm"], c["d_as2_at_1"] / a, c["d_a1t_at_1"] / a,
              c["a1t_at_1"] / a]
        return np.nan_to_num(np.array(r), nan=1e3)

    sol = least_squares(res, x0, xtol=1e-14, ftol=1e-14, max_nfev=5000)
    return sol.x[:5], sol.x[5:]


def identify_valve_static(datasheet: dict[str, float] | str | Path) -> Fit:
    """Solve eq 4-17 for the ten k's of eq 3; see the module docstring for how the solution is chosen."""
    t_start = time.perf_counter()
    if isinstance(datasheet, (str, Path)):
        src = str(datasheet)
        ds = read_datasheet(datasheet)
    else:
        src = "datasheet"
        ds = keys_from_mapping(datasheet, FIELDS, src)
    ps, pn = ds["ps_bar"], ds["pn_bar"]
    notes = []
    if abs(ds["dpm_bar"]) >= ps / 2:
        raise InputError(f"|dpm_bar| = {abs(ds['dpm_bar']):g} bar must be below ps_bar/2 = {ps / 2:g} bar",
                         source=src, key="dpm_bar")
    a_open = ds["qn_lpm"] / np.sqrt(pn)                    # eq 10-11
    alpha, beta = np.sqrt(ps / 2 - ds["dpm_bar"]), np.sqrt(ps / 2 + ds["dpm_bar"])
    r = alpha / beta                                       # eq 4: t0/s0
    s0 = 4 * r * ds["kq0_lpm"] / (beta * (1 + r * r) ** 2 * ds["kp0"])   # eq 6 / eq 8
    t0 = r * s0
    g = -ds["kq0_lpm"] * s0 / beta                         # s0'*t0 + s0*t0', eq 8
    dt0 = g / (ds["slope_ratio"] * t0 + s0)
    ds0 = ds["slope_ratio"] * dt0
    ql0_implied = 2 * s0 * t0 * np.sqrt(ps) / np.hypot(s0, t0)  # eq 12 at x = 0
    if np.isfinite(ds["ql0_lpm"]) and abs(ql0_implied / ds["ql0_lpm"] - 1) > 0.01:
        notes.append(f"ql0_lpm = {ds['ql0_lpm']:g} cannot be met together with dpm_bar, kp0 and kq0_lpm: "
                     f"those three imply ql0 = {ql0_implied:.4g} l/min with eq 3 (reported, not fitted)")
    s1 = ds["ql1_lpm"] / np.sqrt(ps)                       # eq 14-15
    k = _section_from_conditions(s0, ds0, s1, a_open)
    kt = _section_from_conditions(t0, dt0, s1, a_open)
    method = "exact (eq 4-17, slope_ratio rule)"
    if k is None or kt is None or ds0 >= 0 or dt0 >= 0:
        notes.append("no exact solution for these targets: least-squares compromise over all conditions")
        method = "least squares"
        x0 = np.array([-2.1, 0.016, 4.6, -0.08, 0.016, -2.1, 0.007, 4.6, -0.04, 0.011])
        x0[[1, 4, 6, 9]] *= a_open / 4.31
        k, kt = _least_squares_fallback(ds, x0)
    k, kt = [float(v) for v in k], [float(v) for v in kt]
    ach = characteristics(k, kt, ps, pn)
    targets = _targets(ds)
    rel = {key: (ach[key] - v) / v if v else ach[key] for key, v in targets.items() if np.isfinite(v)}
    cost = float(sum(x * x for key, x in rel.items() if key != "ql0_lpm" and targets[key]))
    targets = {key: (v if np.isfinite(v) else None) for key, v in targets.items()}
    fit = Fit("valve-static", {"k": k, "kt": kt, "method": method, "targets": targets,
                               "relative_error": rel}, cost=cost,
              updates={"valve.k": k, "valve.kt": kt}, achieved=ach, notes=notes,
              curves={"k": k, "kt": kt, "ps_bar": ps, "targets": targets})
    fit.wall_time_s = time.perf_counter() - t_start
    return fit
