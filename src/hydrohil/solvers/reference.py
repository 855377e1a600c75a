"""Stiff variable-step solution of the continuous reference model (SPEC §6).

LSODA (scipy ``odeint``) at tight tolerance, restarted at every discontinuity of the plant input: the
zero-order-held command changes at each sample t_k and reaches the spool delayed by dt = (n + alpha)*h,
so each step is split at t_k + alpha*h. In closed loop the same sampled P controller as the hybrid
model's acts at t_k on the encoder reading (like-for-like comparison, SPEC §6).

LSODA can give up on an interval: with a light load pressed on a stiff stop it may chatter at sub-ns
steps on the stop's and the friction's switching until its step budget is spent, and then returns a
state from *before* the interval's end. Such an interval is redone with Radau (implicit, L-stable) at
the same tolerances; if Radau fails too the run stops with the solver's message. ``stats`` counts both.
"""

from __future__ import annotations

import numpy as np
import warnings

from scipy.integrate import ODEintWarning, odeint, solve_ivp

from hydrohil.control import p_control
from hydrohil.models.delay import delay_push, make_buffer, split_delay
from hydrohil.models.layout import (DELAY, ENC_RES, NY, SLIP_NEG, SLIP_POS, STICK, STROKE, VP,
                                    XP, XS, Z, AT_EXTEND, AT_RETRACT, FREE)
from hydrohil.models.reference import reference_rhs
from hydrohil.models.friction import lugre
from hydrohil.models.sensors import encoder_position
from hydrohil.simulation.loop import NLOG, diverged

DEFAULT_RTOL = 1e-7
# absolute tolerances per state: xs, vs, p1, p2 [Pa], xp [m], vp [m/s], z [m]
DEFAULT_ATOL = np.array([1e-8, 1e-6, 1.0, 1.0, 1e-9, 1e-8, 1e-11])
LSODA_MXSTEP = 20000   # internal steps per interval before LSODA gives up (then Radau redoes it)


class ReferenceSolverFailed(RuntimeError):
    """Neither LSODA nor Radau could integrate an interval of the reference model."""


def advance(f, y, t0: float, t1: float, ud: float, rtol: float, atol, stats: dict) -> np.ndarray:
    """State at t1 from ``y`` at t0 under spool input ``ud``: LSODA, Radau where LSODA gives up."""
    out, info = odeint(f, y, [t0, t1], args=(ud,), rtol=rtol, atol=atol, mxstep=LSODA_MXSTEP, full_output=True)
    stats["intervals"] += 1
    if info["message"] == "Integration successful.":
        return out[-1]
    stats["radau_fallbacks"] += 1
    r = solve_ivp(lambda t, yv: f(yv, t, ud).copy(), (t0, t1), y, method="Radau", rtol=rtol, atol=atol)
    if not r.success:
        raise ReferenceSolverFailed(f"LSODA ({info['message'].strip()}) and Radau ({r.message}) failed on "
                                    f"[{t0:.6g}, {t1:.6g}] s")
    return r.y[:, -1]


def _derived_modes(y, p):
    """Modes read off the continuous state, for plots only: penetration -> stop; |vp| < 1 mm/s -> stick."""
    travel = AT_RETRACT if y[XP] < 0 else AT_EXTEND if y[XP] > p[STROKE] else FREE
    fric = STICK if abs(y[VP]) < 1e-3 else SLIP_POS if y[VP] > 0 else SLIP_NEG
    return travel, fric


def solve_reference(p: np.ndarray, y0: np.ndarray, h: float, n_steps: int, *, u_open=None, kp: float = 0.0,
                    xref=None, every: int = 1, rtol: float = DEFAULT_RTOL, atol=DEFAULT_ATOL,
                    progress=None, stats: dict | None = None):
    """Integrate the reference model over n_steps samples of h; returns (status, steps done, log, final y).

    ``u_open`` (n_steps + 1 commands) for open loop, or ``kp`` and ``xref`` (n_steps + 1 positions) for the
    sampled P loop. ``progress(k)`` is called now and then. Log columns as the hybrid loop's. ``stats``
    (optional dict) receives ``intervals``, ``radau_fallbacks`` and, on a solver failure, ``failure``
    (the run then ends with the divergence status).
    """
    closed = u_open is None
    dl_n, alpha = split_delay(p[DELAY], h)
    buf = make_buffer(dl_n, y0[XS])
    pos = np.zeros(1, dtype=np.int64)
    y = np.array(y0, dtype=float)
    dy = np.empty(NY)
    m_dummy = np.zeros(3, dtype=np.int64)
    sc_dummy = np.array([1.0, 1.0, 0.0, 0.0])
    log = np.zeros(((n_steps // every) + 1, NLOG))
    stats = {} if stats is None else stats
    stats.update(intervals=0, radau_fallbacks=0)

    def f(yv, t, ud):
        reference_rhs(yv, ud, m_dummy, p, sc_dummy, dy)
        return dy

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ODEintWarning)   # LSODA giving up is handled in advance()
        return _integrate(f, y, p, h, n_steps, closed, u_open, kp, xref, buf, pos, dl_n, alpha, every, log,
                          rtol, atol, progress, stats)


def _integrate(f, y, p, h, n_steps, closed, u_open, kp, xref, buf, pos, dl_n, alpha, every, log, rtol, atol,
               progress, stats):
    from hydrohil.simulation.loop import STATUS_DIVERGED, STATUS_OK

    row = 0
    for k in range(n_steps + 1):
        t = k * h
        if closed:
            u = p_control(kp, xref[k], encoder_position(y[XP], p[ENC_RES]))
        else:
            u = float(u_open[k])
        u_new, u_old = delay_push(buf, pos, u, dl_n)
        if k % every == 0:
            travel, fric = _derived_modes(y, p)
            _, ff = lugre(y[VP], y[Z], p)
            log[row, :11] = (t, u, (1 - alpha) * u_new + alpha * u_old, *y, ff)
            log[row, 11:] = (travel, fric, 0, 0)
            row += 1
        if k == n_steps:
            break
        t_switch = t + alpha * h
        try:
            if alpha > 1e-12:
                y = advance(f, y, t, t_switch, u_old, rtol, atol, stats)
            y = advance(f, y, t_switch, t + h, u_new, rtol, atol, stats)
        except ReferenceSolverFailed as e:
            stats["failure"] = str(e)
            return STATUS_DIVERGED, k + 1, log[:row], y
        if diverged(y, p):
            return STATUS_DIVERGED, k + 1, log[:row], y
        if progress is not None and k % 500 == 0:
            progress(k)
    return STATUS_OK, n_steps, log[:row], y
