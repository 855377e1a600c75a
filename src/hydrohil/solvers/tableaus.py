"""Butcher tableaus of the fixed-step explicit Runge-Kutta methods (one stepper, each method a tableau)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Tableau:
    name: str
    order: int
    a: np.ndarray  # (s, s) strictly lower triangular
    b: np.ndarray  # (s,)
    c: np.ndarray  # (s,)
    real_axis_limit: float  # stability interval on the negative real axis, |lambda*h|

    @property
    def stages(self) -> int:
        return len(self.b)


def _t(name, order, a, b, limit):
    a = np.array(a, dtype=float)
    return Tableau(name, order, a, np.array(b, dtype=float), a.sum(axis=1), limit)


EULER = _t("euler", 1, [[0.0]], [1.0], 2.0)
HEUN = _t("heun", 2, [[0, 0], [1, 0]], [0.5, 0.5], 2.0)
# Bogacki-Shampine 3(2), the "ode3" of Simulink; as a fixed-step method only the 3rd-order stages are used.
RK3 = _t("rk3", 3, [[0, 0, 0], [0.5, 0, 0], [0, 0.75, 0]], [2 / 9, 1 / 3, 4 / 9], 2.51)
RK4 = _t("rk4", 4, [[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]], [1 / 6, 1 / 3, 1 / 3, 1 / 6], 2.79)

TABLEAUS = {t.name: t for t in (EULER, HEUN, RK3, RK4)}
FIXED_STEP_SOLVERS = tuple(TABLEAUS)
MAX_STAGES = max(t.stages for t in TABLEAUS.values())


def get_tableau(name: str) -> Tableau:
    try:
        return TABLEAUS[name]
    except KeyError:
        raise ValueError(f"unknown fixed-step solver '{name}' (expected one of {', '.join(TABLEAUS)})") from None
