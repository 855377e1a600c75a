"""The one explicit Runge-Kutta stepper shared by every tableau and every model right-hand side.

``make_rk_step(rhs, tableau)`` compiles the generic stepper for a model right-hand side
``rhs(y, ud, m, p, sc, dy)`` (sc: an array of per-step model constants) with the tableau as a compile-time
constant (the stage loops unroll; reading the tableau at run time, or dispatching on it, cost 1.7x per
step on this machine).
"""

from __future__ import annotations

from hydrohil._jit import specialize
from hydrohil.solvers.tableaus import Tableau

# bound per specialisation by make_rk_step
RHS = A = B = NS = None


def _rk_step(y0, h, ud, m, p, sc, k, ytmp, yout):
    """One explicit RK step of size h -> yout; k (>= stages x ny) and ytmp are caller-owned work arrays."""
    ny = y0.shape[0]
    for s in range(NS):
        for i in range(ny):
            acc = y0[i]
            for j in range(s):
                acc += h * A[s, j] * k[j, i]
            ytmp[i] = acc
        RHS(ytmp, ud, m, p, sc, k[s])
    for i in range(ny):
        acc = y0[i]
        for s in range(NS):
            acc += h * B[s] * k[s, i]
        yout[i] = acc


def make_rk_step(rhs, tab: Tableau):
    """Return ``rk_step(y0, h, ud, m, p, sc, k, ytmp, yout)`` for ``rhs`` and tableau ``tab``."""
    return specialize(_rk_step, f"rk_step_{rhs.__name__}_{tab.name}", inline=True,
                      RHS=rhs, A=tab.a, B=tab.b, NS=tab.stages)
