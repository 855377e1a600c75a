"""Stiff variable-step integration of a reference model over an interval of constant input (SPEC §6): LSODA
(scipy ``odeint``) at tight tolerance, and Radau (implicit, L-stable) where LSODA gives up. Used by the paper
rig's reference (:mod:`hydrohil.simulation.reference`) and a circuit's (:mod:`hydrohil.circuits.reference`).

LSODA can give up on an interval: with a light load pressed on a stiff stop it may chatter at sub-ns steps on
the stop's and the friction's switching until its step budget is spent, and then returns a state from *before*
the interval's end. Such an interval is redone with Radau at the same tolerances; if Radau fails too,
:class:`ReferenceSolverFailed` names the interval and both solvers' messages. ``stats`` counts both.
"""

from __future__ import annotations

import numpy as np

LSODA_MXSTEP = 20000   # internal steps per interval before LSODA gives up (then Radau redoes it)


class ReferenceSolverFailed(RuntimeError):
    """Neither LSODA nor Radau could integrate an interval of a reference model: ``t`` its start, ``y`` the
    state there."""

    def __init__(self, message: str, t: float = float("nan"), y=None):
        super().__init__(message)
        self.t, self.y = t, y


def odeint(*args, **kwargs):
    """scipy.integrate.odeint, imported on first use (SciPy's import costs 0.5 s of every start-up)."""
    from scipy.integrate import odeint as lsoda
    return lsoda(*args, **kwargs)


def solve_ivp(*args, **kwargs):
    """scipy.integrate.solve_ivp, imported on first use."""
    from scipy.integrate import solve_ivp as ivp
    return ivp(*args, **kwargs)


def advance(f, y, times, arg, rtol: float, atol, stats: dict) -> np.ndarray:
    """The states at ``times`` (increasing; times[0]: the time of ``y``) under the constant input ``arg`` of
    ``f(y, t, arg)``: LSODA, Radau where LSODA gives up. Rows: one per time (the first is ``y``)."""
    import warnings
    from scipy.integrate import ODEintWarning
    times = np.asarray(times, dtype=float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ODEintWarning)        # LSODA giving up is handled here
        out, info = odeint(f, y, times, args=(arg,), rtol=rtol, atol=atol, mxstep=LSODA_MXSTEP, full_output=True)
    stats["intervals"] = stats.get("intervals", 0) + 1
    if info["message"] == "Integration successful.":
        return out
    stats["radau_fallbacks"] = stats.get("radau_fallbacks", 0) + 1
    r = solve_ivp(lambda t, yv: f(yv, t, arg).copy(), (times[0], times[-1]), y, method="Radau", rtol=rtol,
                  atol=atol, t_eval=times)
    if not r.success:
        raise ReferenceSolverFailed(f"LSODA ({info['message'].strip()}) and Radau ({r.message}) failed on "
                                    f"[{times[0]:.6g}, {times[-1]:.6g}] s", t=float(times[0]), y=np.array(y))
    return r.y.T
