"""Reference position controller of the paper (§4): P control on the valve command, u = Kp*(x_ref - x).

Kp is in 1/m (u is the normalised command ū in [-1, 1]). The same law runs in the compiled offline
loop (:func:`p_control`), in the per-step Python loop and in the HIL controller process.
"""

from __future__ import annotations

from hydrohil._jit import jit


@jit(inline=True)
def p_control(kp, x_ref, x_meas):
    """Saturated P law: clamp(kp*(x_ref - x_meas), -1, 1)."""
    u = kp * (x_ref - x_meas)
    return min(max(u, -1.0), 1.0)


class PController:
    """Stateless P position controller; ``update(t, x_ref, x_meas) -> u``."""

    def __init__(self, kp: float):
        if not kp > 0:
            raise ValueError(f"controller kp must be > 0 (1/m), got {kp}")
        self.kp = float(kp)

    def update(self, t: float, x_ref: float, x_meas: float) -> float:
        return float(p_control(self.kp, x_ref, x_meas))
