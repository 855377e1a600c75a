"""Stiff variable-step solution of the continuous reference model (SPEC §6).

LSODA at tight tolerance, Radau where it gives up (:mod:`hydrohil.core.stiff`), restarted at every
discontinuity of the plant input: the zero-order-held command changes at each sample t_k and reaches the spool
delayed by dt = (n + alpha)*h, so each step is split at t_k + alpha*h. In closed loop the same sampled P
controller as the hybrid model's acts at t_k on the encoder reading (like-for-like comparison, SPEC §6).
"""

from __future__ import annotations

import numpy as np

from hydrohil.core import dptr, ffi, lib, stiff
from hydrohil.core.stiff import ReferenceSolverFailed
from hydrohil.models.layout import NY
from hydrohil.simulation.loop import Sim

DEFAULT_RTOL = 1e-7
# absolute tolerances per state: xs, vs, p1, p2 [Pa], xp [m], vp [m/s], z [m]
DEFAULT_ATOL = np.array([1e-8, 1e-6, 1.0, 1.0, 1e-9, 1e-8, 1e-11])


def advance(f, y, t0: float, t1: float, ud: float, rtol: float, atol, stats: dict) -> np.ndarray:
    """State at t1 from ``y`` at t0 under spool input ``ud`` (:func:`hydrohil.core.stiff.advance`)."""
    return stiff.advance(f, y, [t0, t1], ud, rtol, atol, stats)[-1]


def reference_rhs(p: np.ndarray):
    """``f(y, t, ud) -> dy/dt`` of the core's continuous reference model (core/reference.c) for SciPy; the
    returned array is reused between calls."""
    dy = np.empty(NY)
    pp, dyp = dptr(p), dptr(dy)
    rhs = lib.hh_reference_rhs

    def f(yv, t, ud):
        if not yv.flags.c_contiguous:       # Radau's finite-difference Jacobian passes column views
            yv = np.ascontiguousarray(yv)
        rhs(ffi.from_buffer("double[]", yv), ud, pp, dyp)
        return dy

    return f


class _Stepper:
    """The core loop's external step: y over [t, t + h], spool input u_old for alpha*h then u_new."""

    def __init__(self, f, rtol, atol, stats):
        self.f, self.rtol, self.atol, self.stats = f, rtol, atol, stats
        self.error: Exception | None = None

    def __call__(self, t, h, alpha, u_old, u_new, y) -> int:
        yv = np.frombuffer(ffi.buffer(y, NY * 8), dtype=np.float64)
        try:
            t_switch = t + alpha * h
            out = yv.copy()
            if alpha > 1e-12:
                out = advance(self.f, out, t, t_switch, u_old, self.rtol, self.atol, self.stats)
            out = advance(self.f, out, t_switch, t + h, u_new, self.rtol, self.atol, self.stats)
        except ReferenceSolverFailed as e:
            self.stats["failure"] = str(e)
            return 1
        except BaseException as e:     # noqa: BLE001 - re-raised after the C loop returns
            self.error = e
            return 1
        yv[:] = out
        return 0


@ffi.def_extern()
def hh_py_advance(ctx, t, h, alpha, u_old, u_new, y):
    return ffi.from_handle(ctx)(t, h, alpha, u_old, u_new, y)


def solve_reference(p: np.ndarray, y0: np.ndarray, h: float, n_steps: int, values: np.ndarray, *,
                    controller=None, slopes=None, seed: int = 0, every: int = 1, rtol: float = DEFAULT_RTOL, atol=DEFAULT_ATOL,
                    progress=None, stats: dict | None = None, rhs=None):
    """Integrate the reference model over n_steps samples of h; returns (status, steps done, log, final y).

    ``values``: n_steps + 1 commands (open loop), or positions for the sampled built-in ``controller``
    (with ``slopes``; pressure noise seeded by ``seed``). The sampled loop is the core's (controller, delay, log); each step is LSODA (Radau
    where LSODA gives up) on the core's right-hand side. ``progress(k)`` is called now and then. Log columns
    as the hybrid loop's (modes read off the state: penetration -> stop, |vp| < 1 mm/s -> stick). ``stats``
    (optional dict) receives ``intervals``, ``radau_fallbacks`` and, on a solver failure, ``failure``
    (the run then ends with the divergence status). ``rhs``: ``f(y, t, ud) -> dy/dt`` in the core's state order
    in place of the core's (:func:`reference_rhs`): the one generated from the scenario's circuit
    (:func:`hydrohil.simulation.generated_model.generated_reference_rhs`).
    """
    stats = {} if stats is None else stats
    stats.update(intervals=0, radau_fallbacks=0)
    sim = Sim(p, h, model="external")
    sim.set_state(np.asarray(y0, dtype=float))
    stepper = _Stepper(reference_rhs(sim.p) if rhs is None else rhs, rtol, atol, stats)
    handle = ffi.new_handle(stepper)
    sim._sim.advance = lib.hh_py_advance
    sim._sim.ctx = handle
    status, done, log = sim.run(n_steps, every, values, controller=controller, slopes=slopes, seed=seed,
                                progress=progress)
    if stepper.error is not None:
        raise stepper.error
    return status, done, log, sim.y.copy()
