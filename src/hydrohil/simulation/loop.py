"""Compiled simulation loops of the hybrid model and the per-step plant API (``HybridPlant.step``).

The plant input is a zero-order-held command u_k, either given (open loop) or computed at t_k by the
P controller from the encoder reading (closed loop, :mod:`hydrohil.control`), exactly as a sampled
controller would. One log row per output interval; columns :data:`LOG_COLUMNS`.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
from hydrohil._jit import jit, specialize

from hydrohil.control import p_control
from hydrohil.models.cylinder import external_force
from hydrohil.models.delay import delay_push_read, make_buffer, split_delay
from hydrohil.models.hybrid import friction_force, make_hybrid_step
from hydrohil.models.layout import (AT_EXTEND, AT_RETRACT, ENC_RES, FREE, FS_NEG, FS_POS, M_FRICTION,
                                    M_SPOOL, M_TRAVEL, NM, NY, P1, P2, SIGMA0, SPOOL_LINEAR, STICK, STROKE, VP,
                                    VS, XP, XS, Z, pack)
from hydrohil.models.sensors import encoder_position
from hydrohil.models.valve import closed_port_pressures
from hydrohil.parameters import Parameters
from hydrohil.solvers.tableaus import MAX_STAGES, get_tableau

LOG_COLUMNS = ("t", "u", "ud", "xs", "vs", "p1", "p2", "xp", "vp", "z", "ff", "travel_mode", "friction_mode",
               "spool_mode", "events")
NLOG = len(LOG_COLUMNS)
STATUS_OK, STATUS_DIVERGED = 0, 1


@jit(inline=True)
def diverged(y, p):
    """True when the state is non-finite or far outside any physical range."""
    for i in range(y.shape[0]):
        if not np.isfinite(y[i]):
            return True
    return (abs(y[P1]) > 1e9 or abs(y[P2]) > 1e9 or abs(y[VP]) > 100.0 or abs(y[XS]) > 10.0
            or y[XP] < -p[STROKE] or y[XP] > 2.0 * p[STROKE])


@jit(inline=True)
def write_row(log, row, t, u, ud, y, m, p, events):
    log[row, 0] = t
    log[row, 1] = u
    log[row, 2] = ud
    log[row, 3] = y[XS]
    log[row, 4] = y[VS]
    log[row, 5] = y[P1]
    log[row, 6] = y[P2]
    log[row, 7] = y[XP]
    log[row, 8] = y[VP]
    log[row, 9] = y[Z]
    log[row, 10] = friction_force(y, m, p)
    log[row, 11] = m[M_TRAVEL]
    log[row, 12] = m[M_FRICTION]
    log[row, 13] = m[M_SPOOL]
    log[row, 14] = events


HYBRID_STEP = None  # bound per solver by _make_kernels


def _run_loop(y, m, p, h, n_steps, every, u_open, closed, kp, xref, buf, pos, dl_n, dl_alpha, log, work):
    """Integrate n_steps fixed steps; returns (status, steps done, rows written); y, m in place.
    ``work``: scratch of :func:`work_array` (the kernel allocates nothing)."""
    row = 0
    events = 0
    for k in range(n_steps + 1):
        t = k * h
        if closed:
            u = p_control(kp, xref[k], encoder_position(y[XP], p[ENC_RES]))
        else:
            u = u_open[k]
        ud = delay_push_read(buf, pos, u, dl_n, dl_alpha)
        if k % every == 0:
            write_row(log, row, t, u, ud, y, m, p, events)
            row += 1
            events = 0
        if k == n_steps:
            break
        events += HYBRID_STEP(y, m, p, ud, h, work)
        if diverged(y, p):
            return STATUS_DIVERGED, k + 1, row
    return STATUS_OK, n_steps, row

def _plant_step(y, m, p, buf, pos, dl_n, dl_alpha, u, h, work, out):
    """One step of the per-step API: delay the command, advance, fill ``out`` (see HybridPlant)."""
    ud = delay_push_read(buf, pos, u, dl_n, dl_alpha)
    ev = HYBRID_STEP(y, m, p, ud, h, work)
    out[0] = (np.floor(out[0] / h + 0.5) + 1.0) * h   # t = k*h exactly as the offline loop (no sum drift)
    for i in range(NY):
        out[1 + i] = y[i]
    out[8] = friction_force(y, m, p)
    out[9] = m[M_TRAVEL]
    out[10] = m[M_FRICTION]
    out[11] = m[M_SPOOL]
    out[12] = ev
    out[13] = ud
    return diverged(y, p)


def _make_kernels(solver: str):
    """Compile the loop and the per-step function of the hybrid model for one fixed-step solver."""
    hybrid_step = make_hybrid_step(get_tableau(solver))
    return Kernels(hybrid_step,
                   specialize(_run_loop, f"run_loop_{solver}", nrt=False, HYBRID_STEP=hybrid_step),
                   specialize(_plant_step, f"plant_step_{solver}", nrt=False, HYBRID_STEP=hybrid_step))


def work_array() -> np.ndarray:
    """Scratch memory of one hybrid step (RK stages, stage state, step result)."""
    return np.empty((MAX_STAGES + 3, NY))


class Kernels(NamedTuple):
    hybrid_step: object
    run_loop: object
    plant_step: object


@functools.cache
def kernels(solver: str = "rk3") -> Kernels:
    """The compiled kernels of a fixed-step solver (built on first use, cached on disk by numba)."""
    return _make_kernels(solver)


def initial_state(params: Parameters, xp: float, xs: float = 0.0, vs: float = 0.0,
                  p1: float | None = None, p2: float | None = None, vp: float = 0.0,
                  p: np.ndarray | None = None):
    """(y, m) at rest: pressures default to the closed-port equilibrium at ``xs`` (SPEC §3.2); the
    friction state balances the net force up to breakaway (a quiet start)."""
    p = pack(params) if p is None else p
    ps, pt = params.supply.ps, params.supply.pt
    r1, r2 = closed_port_pressures(xs, params.valve.k, params.valve.kt)
    p1 = pt + (ps - pt) * float(r1) if p1 is None else float(p1)
    p2 = pt + (ps - pt) * float(r2) if p2 is None else float(p2)
    y = np.array([xs, vs, p1, p2, xp, vp, 0.0])
    m = np.zeros(NM, dtype=np.int64)
    m[M_SPOOL] = SPOOL_LINEAR
    L = params.cylinder.stroke
    f = external_force(p1, p2, p)
    if xp <= 0.0 and f <= 0.0:
        y[XP], y[VP], m[M_TRAVEL] = 0.0, 0.0, AT_RETRACT
    elif xp >= L and f >= 0.0:
        y[XP], y[VP], m[M_TRAVEL] = L, 0.0, AT_EXTEND
    else:
        y[XP] = min(max(xp, 0.0), L)
        m[M_TRAVEL] = FREE
        y[Z] = min(max(f, -p[FS_NEG]), p[FS_POS]) / p[SIGMA0]
    m[M_FRICTION] = STICK
    return y, m


class HybridPlant:
    """Per-step API of the hybrid model: ``plant.step(u)`` advances one fixed step h with command u.

    ``step`` returns a reused float64 array ``out``: [t, xs, vs, p1, p2, xp, vp, z, ff, travel, friction,
    spool, events, ud] (SI; mode codes of :mod:`hydrohil.models.layout`). Copy it to keep it.
    """

    OUT_COLUMNS = ("t", "xs", "vs", "p1", "p2", "xp", "vp", "z", "ff", "travel_mode", "friction_mode",
                   "spool_mode", "events", "ud")

    def __init__(self, params: Parameters, h: float = 5e-4, solver: str = "rk3", **initial):
        if not h > 0:
            raise ValueError(f"step h must be > 0 s, got {h}")
        self.params, self.h = params, float(h)
        self.p = pack(params)
        self.kernel = kernels(solver).plant_step
        self.dl_n, self.dl_alpha = split_delay(params.spool.delay, self.h)
        self.work = work_array()
        self.out = np.zeros(len(self.OUT_COLUMNS))
        self.reset(**initial)

    def reset(self, xp: float | None = None, **kw) -> np.ndarray:
        xp = self.params.linear.xp0 if xp is None else xp
        self.y, self.m = initial_state(self.params, xp, p=self.p, **kw)
        self.buf = make_buffer(self.dl_n, self.y[XS])
        self.pos = np.zeros(1, dtype=np.int64)
        self.out[:] = 0.0
        self.out[1:8] = self.y
        self.out[8:12] = (0.0, *self.m)
        return self.out

    def step(self, u: float) -> np.ndarray:
        bad = self.kernel(self.y, self.m, self.p, self.buf, self.pos, self.dl_n, self.dl_alpha, float(u),
                         self.h, self.work, self.out)
        if bad:
            from hydrohil.simulation.diagnostics import divergence_error
            raise divergence_error(self.out[0], self.y, self.m)
        return self.out

    @property
    def t(self) -> float:
        return float(self.out[0])
