"""Cylinder leakage conductance from a drift test (paper §3.2.2, eq 22-23).

Port 2 trapped, port 1 open to tank, a heavy load: the piston drifts at the steady velocity v_ps fed
by the internal leakage only, so g_lkc = v_ps·A2/P2 (eq 23). Input either the summary numbers
(TOML keys ``displacement_m``, ``duration_s``, ``p2_pa``, ``a2_m2``) or a CSV time series with columns
``t`` [s], ``xp`` [m], ``p2`` [Pa] (v_ps is the slope of a straight-line fit, P2 the mean; A2 then comes
from ``a2_m2`` or the parameter set).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from hydrohil.errors import InputError
from hydrohil.identification.data import Column, keys_from_mapping, read_table
from hydrohil.identification.result import Fit
from hydrohil.parameters import read_toml

FIELDS = (
    Column("displacement_m", "m", 1e-9, 10.0, "displacement in m (1504 um = 1.504e-3 m)"),
    Column("duration_s", "s", 1e-3, 1e6),
    Column("p2_pa", "Pa", 1e3, 1e9, "chamber pressure in Pa (5.28 bar = 5.28e5 Pa)"),
    Column("a2_m2", "m^2", 1e-7, 1.0),
)
SERIES = (
    Column("t", "s", 0.0, 1e6),
    Column("xp", "m", -10.0, 10.0, "piston position in m"),
    Column("p2", "Pa", 1e3, 1e9, "chamber pressure in Pa (5.28 bar = 5.28e5 Pa)"),
)


def identify_leakage(data: dict | str | Path, *, a2_m2: float | None = None) -> Fit:
    """g_lkc [m^3/(s·Pa)] by eq 23 from drift-test numbers (dict/TOML) or a CSV time series."""
    t0 = time.perf_counter()
    curves = {}
    if isinstance(data, (str, Path)) and Path(data).suffix.lower() == ".csv":
        s = read_table(data, SERIES, min_rows=3)
        if np.any(np.diff(s["t"]) <= 0):
            raise InputError("time must increase strictly", source=str(data), key="t")
        slope, icpt = np.polyfit(s["t"], s["xp"], 1)
        v, p2, dur = abs(float(slope)), float(np.mean(s["p2"])), float(s["t"][-1] - s["t"][0])
        disp = v * dur
        if a2_m2 is None:
            raise InputError("a CSV drift test needs the rod-side area (a2_m2 / --params)", source=str(data))
        a2 = float(a2_m2)
        curves = {"t": s["t"], "xp": s["xp"], "fit": slope * s["t"] + icpt}
        src = str(data)
    else:
        src = str(data) if isinstance(data, (str, Path)) else "drift test"
        raw = dict(read_toml(data)) if isinstance(data, (str, Path)) else dict(data)
        if "a2_m2" not in raw and a2_m2 is not None:
            raw["a2_m2"] = a2_m2
        k = keys_from_mapping(raw, FIELDS, src)
        disp, dur, p2, a2 = k["displacement_m"], k["duration_s"], k["p2_pa"], k["a2_m2"]
        v = disp / dur
    g = v * a2 / p2   # eq 23
    fit = Fit("leakage", {"g_lkc": g, "v_ps": v, "p2": p2, "a2": a2, "displacement_m": disp, "duration_s": dur},
              cost=0.0, updates={"cylinder.g_lkc": g}, curves=curves)
    fit.wall_time_s = time.perf_counter() - t0
    if src:
        fit.values["source"] = src
    return fit
