"""Reference position controller of the paper (§4): P control on the valve command, u = Kp*(x_ref - x).

Kp is in 1/m (u is the normalised command ū in [-1, 1]). The law is the core's (``core/control.c``): the
same code runs in the sampled loop of offline runs, in the per-step Python loop and in the HIL controller.
"""

from __future__ import annotations

from hydrohil.core import lib


def p_control(kp: float, x_ref: float, x_meas: float) -> float:
    """Saturated P law: clamp(kp*(x_ref - x_meas), -1, 1)."""
    return lib.hh_p_control(kp, x_ref, x_meas)


class PController:
    """Stateless P position controller; ``update(t, x_ref, x_meas) -> u``."""

    def __init__(self, kp: float):
        if not kp > 0:
            raise ValueError(f"controller kp must be > 0 (1/m), got {kp}")
        self.kp = float(kp)

    def update(self, t: float, x_ref: float, x_meas: float) -> float:
        return lib.hh_p_control(self.kp, x_ref, x_meas)
