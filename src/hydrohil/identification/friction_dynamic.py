"""Dynamic friction parameters σ0, σ1 from an open-loop experiment (paper §3.2.3 b, eq 27-28).

The hybrid model (all other parameters from a given parameter set) is driven by the measured valve
command from the measured initial state; σ0 and σ1 minimise eq 27, the sum over the samples of the
squared difference between the measured hydraulic force Fh = P1·A1 − P2·A2 and the simulated one.
The excitation must take the piston in and out of stiction (paper).

Eq 27 on raw 10 ms samples is a very rugged function of (σ0, σ1): the stick phase rings at tens of Hz
(mass on the bristle spring and the oil columns) and a 10 % change of σ0 shifts that ringing enough to
raise the RMS force error from a few N to ~150 N, so a local search from a poor start stalls. The search
therefore runs by continuation in log space: eq 27 on forces low-passed by a moving average of
0.2 s (smooth, wide basin; a grid of compiled simulations, a few ms each, picks the start), then 0.05 s,
then the raw eq 27, each stage a Nelder–Mead simplex started from the previous optimum.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.optimize import minimize

from hydrohil.errors import InputError
from hydrohil.identification.data import Column, read_table
from hydrohil.identification.result import Fit
from hydrohil.models.layout import P1, P2, SIGMA0, SIGMA1, XP, pack
from hydrohil.parameters import Parameters, load_parameters
from hydrohil.simulation.loop import LOG_COLUMNS, STATUS_OK, initial_state
from hydrohil.simulation.run import run_hybrid

COLUMNS = (
    Column("t", "s", 0.0, 1e5),
    Column("u", "-", -1.0, 1.0, "valve command normalised to [-1, 1]"),
    Column("p1", "Pa", -1e5, 1e9, "pressures in Pa (bar x 1e5)"),
    Column("p2", "Pa", -1e5, 1e9, "pressures in Pa (bar x 1e5)"),
    Column("xp", "m", -0.01, 10.0, "piston position in m"),
)
H_MAX = 5e-4
GRID_SIGMA0 = np.geomspace(1e6, 1e9, 13)
GRID_SIGMA1 = np.geomspace(1e1, 1e5, 9)
SMOOTHING_S = (0.2, 0.05, 0.0)   # continuation stages: moving-average window [s]; 0 = eq 27 itself


def read_experiment(path: str | Path) -> dict[str, np.ndarray]:
    d = read_table(path, COLUMNS, min_rows=20)
    check_experiment(d, str(path))
    return d


def check_experiment(d, src: str) -> None:
    dt = np.diff(d["t"])
    if np.any(dt <= 0):
        raise InputError("time must increase strictly", source=src, key="t")
    if np.ptp(dt) > 1e-6 * np.mean(dt) + 1e-9:
        raise InputError(f"samples must be evenly spaced (dt from {dt.min():g} to {dt.max():g} s)", source=src,
                         key="t")
    if max(np.max(np.abs(d["p1"])), np.max(np.abs(d["p2"]))) < 1e3:
        raise InputError("pressures look like bar, expected Pa", source=src, key="p1")


class ForceSimulator:
    """Hydraulic force Fh(t_k) of the hybrid model for the experiment's command and initial state."""

    def __init__(self, params: Parameters, d: dict[str, np.ndarray], solver: str = "rk3"):
        self.params = params
        t = d["t"] - d["t"][0]
        dt = float(np.mean(np.diff(t)))
        self.every = max(1, int(np.ceil(dt / H_MAX - 1e-9)))
        self.h = dt / self.every
        self.n = (len(t) - 1) * self.every
        self.u = np.interp(np.arange(self.n + 1) * self.h, t, d["u"])
        self.p = pack(params)
        self.y0, self.m0 = initial_state(params, float(d["xp"][0]), xs=float(d["u"][0]), p1=float(d["p1"][0]),
                                         p2=float(d["p2"][0]), p=self.p)
        self.solver = solver
        self.n_samples = len(t)
        self.evaluations = 0

    def log(self, sigma0: float, sigma1: float) -> np.ndarray:
        p = self.p.copy()
        p[SIGMA0], p[SIGMA1] = sigma0, sigma1
        y, m = self.y0.copy(), self.m0.copy()
        status, done, log, _ = run_hybrid(self.params, p, y, m, self.h, self.n, self.every, self.u,
                                          solver=self.solver)
        self.evaluations += 1
        if status != STATUS_OK or log.shape[0] < self.n_samples:
            return None
        return log

    def force(self, sigma0: float, sigma1: float) -> np.ndarray | None:
        return self.force_of(self.log(sigma0, sigma1))

    def force_of(self, log: np.ndarray | None) -> np.ndarray | None:
        """Hydraulic force Fh = P1·A1 − P2·A2 [N] at the samples of a simulation log (eq 28)."""
        if log is None:
            return None
        c = self.params.cylinder
        i1, i2 = LOG_COLUMNS.index("p1"), LOG_COLUMNS.index("p2")
        return log[: self.n_samples, i1] * c.a1 - log[: self.n_samples, i2] * c.a2


def identify_friction_dynamic(data: dict[str, np.ndarray] | str | Path, params: Parameters | str = "ferreira2004",
                              *, progress=None) -> Fit:
    """σ0 [N/m], σ1 [N·s/m] minimising eq 27 with the rest of the model from ``params``."""
    t_start = time.perf_counter()
    src = str(data) if isinstance(data, (str, Path)) else "data"
    if isinstance(data, (str, Path)):
        d = read_experiment(data)
    else:
        d = data
        check_experiment(d, src)
    params = load_parameters(params) if isinstance(params, (str, Path)) else params
    sim = ForceSimulator(params, d)
    c = params.cylinder
    fh = d["p1"] * c.a1 - d["p2"] * c.a2

    dt = float(np.mean(np.diff(d["t"])))

    def cost_fn(window_s):
        w = int(round(window_s / dt))
        target = uniform_filter1d(fh, w) if w > 1 else fh

        def cost(theta):                 # eq 27 (on low-passed forces when w > 1)
            f = sim.force(*np.exp(theta))
            if f is None:
                return 1e30
            return float(np.sum((target - (uniform_filter1d(f, w) if w > 1 else f)) ** 2))
        return cost

    grid = [(s0, s1) for s0 in GRID_SIGMA0 for s1 in GRID_SIGMA1]
    total = len(grid) + len(SMOOTHING_S)
    first = cost_fn(SMOOTHING_S[0])
    costs = []
    for i, (s0, s1) in enumerate(grid):
        costs.append(first(np.log([s0, s1])))
        if progress:
            progress(i + 1, total)
    x = np.log(grid[int(np.argmin(costs))])
    step = np.log(GRID_SIGMA0[1] / GRID_SIGMA0[0])
    for j, window in enumerate(SMOOTHING_S):
        nm = minimize(cost_fn(window), x, method="Nelder-Mead",
                      options={"xatol": 1e-4, "fatol": 1e-9, "maxfev": 300,
                               "initial_simplex": x + np.array([[0, 0], [step, 0], [0, step]])})
        x, step = nm.x, step / 3
        if progress:
            progress(len(grid) + j + 1, total)
    s0, s1 = (float(v) for v in np.exp(nm.x))
    log_fit = sim.log(s0, s1)
    f_fit = sim.force_of(log_fit)
    f_start = sim.force(params.friction.sigma0, params.friction.sigma1)
    rms = float(np.sqrt(np.mean((fh - f_fit) ** 2)))
    fit = Fit("friction-dynamic", {"sigma0": s0, "sigma1": s1}, cost=float(nm.fun),
              updates={"friction.sigma0": s0, "friction.sigma1": s1},
              achieved={"force_rms_n": rms, "force_rms_with_start_values_n":
                        float(np.sqrt(np.mean((fh - f_start) ** 2))) if f_start is not None else None,
                        "simulations": sim.evaluations, "samples": sim.n_samples},
              curves={"t": d["t"], "fh": fh, "fh_fit": f_fit, "fh_start": f_start, "xp": d["xp"],
                      "xp_fit": log_fit[: sim.n_samples, LOG_COLUMNS.index("xp")]})
    fit.wall_time_s = time.perf_counter() - t_start
    return fit


def synthetic_experiment(params: Parameters, duration=6.0, amplitude=0.03, frequency=0.5, offset=0.0,
                         dt=0.01, xp0=0.09, noise_pa=0.0, noise_m=0.0, seed=0) -> dict[str, np.ndarray]:
    """Open-loop sine experiment sampled every ``dt`` from the hybrid model (+ sensor noise)."""
    t = np.arange(0.0, duration + 1e-12, dt)
    u = offset + amplitude * np.sin(2 * np.pi * frequency * t)
    p = pack(params)
    y, m = initial_state(params, xp0, xs=float(u[0]), p=p)
    d0 = {"t": t, "u": u, "xp": np.full_like(t, xp0), "p1": np.full_like(t, y[P1]), "p2": np.full_like(t, y[P2])}
    sim = ForceSimulator(params, d0)
    log = sim.log(params.friction.sigma0, params.friction.sigma1)
    rng = np.random.default_rng(seed)
    out = {"t": t, "u": u}
    for name in ("p1", "p2", "xp"):
        col = log[: t.size, LOG_COLUMNS.index(name)]
        out[name] = col + (noise_m if name == "xp" else noise_pa) * rng.standard_normal(t.size)
    out["xp"][0], out["p1"][0], out["p2"][0] = y[XP], y[P1], y[P2]
    return out
