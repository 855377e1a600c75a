"""A circuit's continuous reference (SPEC §6, §12.4), generated from the same description as its hybrid model
(:mod:`hydrohil.circuits.generate`: ``hc_reference_rhs``): the same laws, modes that are functions of the state
evaluated at every call, end stops and spool ends as stiff spring-dampers, solved by LSODA at tight tolerance
(Radau where LSODA gives up, :mod:`hydrohil.core.stiff`), restarted wherever an input changes (inputs are
held over each step of the sample grid, as the fixed-step run's)."""

from __future__ import annotations

import numpy as np

from hydrohil.core import stiff

RTOL = 1e-8
ATOL_BY_UNIT = {"Pa": 1.0, "m": 1e-10, "m/s": 1e-9, "rad/s": 1e-7}    # else 1e-10 of the unit


def reference_atol(units: list[str]) -> np.ndarray:
    """Absolute tolerances of the states from their units: 1 Pa, 0.1 nm, 1 nm/s, 1e-7 rad/s."""
    return np.array([ATOL_BY_UNIT.get(u, 1e-10) for u in units] or [1e-10])


def solve_circuit_reference(cc, P: np.ndarray, y0: np.ndarray, u: np.ndarray, h: float, n: int, every: int, *,
                            rtol: float = RTOL, progress=None, stats: dict | None = None,
                            control=None, applied=None, seen: np.ndarray | None = None) -> np.ndarray:
    """The reference's log rows (NLOG columns, the hybrid run's) at steps 0, every, 2*every, .. n from ``y0``
    under the inputs ``u`` (a row per step, held over it). ``control(k, row)``: a sampled controller that sets
    u[k] from the log row of the state at step k (each step is then an interval of its own; ``applied(k)``
    first puts the command last applied into u[k], the one that row is computed with). ``seen``: the inputs
    as the components see them (a delayed input late, row k over step k; ``control`` keeps it up to date),
    default u; the log rows take u. Raises stiff.ReferenceSolverFailed."""
    ffi, lib, lay = cc.ffi, cc.lib, cc.layout
    stats = {} if stats is None else stats
    stats.update(intervals=0, radau_fallbacks=0)
    Pb = ffi.from_buffer("double[]", P)
    dy = np.zeros(len(y0))
    dyb = ffi.from_buffer("double[]", dy)
    ub = {}

    def f(yv, t, k):
        if not yv.flags.c_contiguous:      # Radau's finite-difference Jacobian passes column views
            yv = np.ascontiguousarray(yv)
        lib.hc_reference_rhs(Pb, ffi.from_buffer("double[]", yv), ub[k], dyb)
        return dy

    atol = reference_atol(lay.state_units)[:len(y0)]
    rows = np.arange(0, n + 1, every)
    log = np.zeros((len(rows), len(lay.log_columns)))
    # segments of constant input: [k0, k1) steps
    su = u if seen is None else seen
    if control is not None:
        return _closed_loop(cc, Pb, f, ub, y0, u, su, h, n, every, rtol, atol, stats, control, applied, log,
                            progress)
    change = [0] + [k for k in range(1, n) if np.any(su[k] != su[k - 1])] + [n]
    y = np.array(y0, dtype=float)
    r = 0
    for k0, k1 in zip(change[:-1], change[1:]):
        uk = np.ascontiguousarray(su[min(k0, len(su) - 1)])
        ub[k0] = ffi.from_buffer("double[]", uk)
        inside = rows[(rows > k0) & (rows <= k1)]
        times = np.concatenate(([k0], inside, [k1] if not len(inside) or inside[-1] != k1 else [])) * h
        if k1 > k0:
            ys = stiff.advance(f, y, times, k0, rtol, atol, stats)
        else:
            ys = y[None, :]
        if r < len(rows) and rows[r] == k0:                   # the segment's first row (step 0)
            lib.hc_reference_row(Pb, ffi.from_buffer("double[]", np.ascontiguousarray(y)),
                                 ffi.from_buffer("double[]", np.ascontiguousarray(u[min(k0, len(u) - 1)])), k0 * h,
                                 ffi.from_buffer("double[]", log[r]))
            r += 1
        for j, k in enumerate(inside):
            yk = np.ascontiguousarray(ys[1 + j])
            uk_row = u[min(k, len(u) - 1)]
            lib.hc_reference_row(Pb, ffi.from_buffer("double[]", yk), ffi.from_buffer("double[]",
                                 np.ascontiguousarray(uk_row)), k * h, ffi.from_buffer("double[]", log[r]))
            r += 1
        y = np.array(ys[-1])
        if progress:
            progress(k1)
    return log


def _closed_loop(cc, Pb, f, ub, y0, u, su, h, n, every, rtol, atol, stats, control, applied, log, progress):
    """Step by step: the row of the state at t_k, the controller's command, the interval [t_k, t_k+1]."""
    ffi, lib = cc.ffi, cc.lib
    nlog = log.shape[1]
    row = np.zeros(nlog)
    y = np.array(y0, dtype=float)
    for k in range(n + 1):
        uk = u[min(k, len(u) - 1)]
        if applied is not None:
            applied(k)
        lib.hc_reference_row(Pb, ffi.from_buffer("double[]", np.ascontiguousarray(y)),
                             ffi.from_buffer("double[]", uk), k * h, ffi.from_buffer("double[]", row))
        if k < len(u):                     # (k = n: the last row's command, with u's row n)
            control(k, row)
            lib.hc_reference_row(Pb, ffi.from_buffer("double[]", np.ascontiguousarray(y)),
                                 ffi.from_buffer("double[]", uk), k * h, ffi.from_buffer("double[]", row))
        if k % every == 0:
            log[k // every] = row
        if k == n:
            break
        ub[k] = ffi.from_buffer("double[]", np.ascontiguousarray(su[min(k, len(su) - 1)]))
        y = np.array(stiff.advance(f, y, [k * h, (k + 1) * h], k, rtol, atol, stats)[-1])
        del ub[k]
        if progress and k % 1000 == 0:
            progress(k)
    return log
