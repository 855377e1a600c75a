"""Continuous reference model (SPEC §6): the same physics as the hybrid model without discrete modes.

Continuous LuGre friction (SPEC §5) and end stops as unilateral spring-dampers (k = c = 1e10 on
penetration, F = max(0, k*d + c*dd/dt): it pushes, never pulls); orifices with a narrow laminar region
(0.01 bar) so the Jacobian stays finite. Stiff: solved by LSODA at tight tolerance
(:mod:`hydrohil.solvers.reference`), or by an explicit fixed step for the max-stable-step comparison.
The spool's mechanical ends are a stiff unilateral spring-damper too (the hybrid model clamps x̄s).
The signature matches :func:`hydrohil.models.hybrid.hybrid_rhs` (modes and step constants unused).
"""

from __future__ import annotations

from hydrohil._jit import jit

from hydrohil.models.cylinder import chamber_pressure_rates, external_force
from hydrohil.models.friction import lugre
from hydrohil.models.layout import DP_LAM_REF, MASS, P1, P2, STOP_C, STOP_K, STROKE, VP, VS, XP, XS, Z
from hydrohil.models.valve import spool_derivatives, spool_stop_acceleration


@jit(inline=True)
def end_stop_force(xp, vp, p):
    """Unilateral spring-damper end-stop force along +x [N]."""
    if xp < 0.0:
        return max(0.0, p[STOP_K] * (-xp) + p[STOP_C] * (-vp))
    over = xp - p[STROKE]
    if over > 0.0:
        return -max(0.0, p[STOP_K] * over + p[STOP_C] * vp)
    return 0.0


@jit(inline=True)
def reference_rhs(y, ud, m, p, sc, dy):
    """dy/dt of the continuous reference model; state layout as the hybrid model."""
    dy[XS], dy[VS], _ = spool_derivatives(y[XS], y[VS], ud, p)
    dy[VS] += spool_stop_acceleration(y[XS], y[VS])
    vp = y[VP]
    dy[P1], dy[P2] = chamber_pressure_rates(y[XS], y[P1], y[P2], y[XP], vp, p, p[DP_LAM_REF], 1.0, 1.0)
    dz, ff = lugre(vp, y[Z], p)
    dy[Z] = dz
    dy[XP] = vp
    dy[VP] = (external_force(y[P1], y[P2], p) - ff + end_stop_force(y[XP], vp, p)) / p[MASS]
