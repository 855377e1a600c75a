"""The paper's linearised valve + cylinder model around X_p0 (eq 18-20, SPEC §7): constant bulk moduli and the
datasheet's gains, as the paper uses it for the bulk-modulus identification (§9.3) and Fig 7. The plant
linearised anywhere, by exact derivatives of the model itself, is :mod:`hydrohil.linear`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hydrohil.parameters import Parameters


def equilibrium_pressures(params: Parameters) -> tuple[float, float]:
    """(P10, P20) [Pa] for vp = ap = 0 with P1 + P2 = Ps, eq 18 (general gravity direction and load):
    A1*P10 + gdir*M*g - F_L - A2*P20 = 0."""
    c, ld, ps = params.cylinder, params.load, params.supply.ps
    w = ld.gravity_direction * ld.mass * ld.gravity - ld.force
    return (c.a2 * ps - w) / (c.a1 + c.a2), (c.a1 * ps + w) / (c.a1 + c.a2)


@dataclass(frozen=True)
class LinearModel:
    """State [dp1, dp2, dvp, dxp]; inputs [dxs, g]; outputs [dvp, dxp] (eq 20)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    p10: float
    p20: float

    @property
    def eigenvalues(self) -> np.ndarray:
        return np.linalg.eigvals(self.A)

    @property
    def natural_frequency(self) -> float:
        """Undamped natural frequency [rad/s] of the oscillatory pair (largest |lambda| complex pair)."""
        ev = self.eigenvalues
        cx = ev[np.abs(ev.imag) > 1e-9]
        return float(np.abs(cx).max()) if cx.size else float("nan")

    @property
    def damping(self) -> float:
        ev = self.eigenvalues
        cx = ev[np.abs(ev.imag) > 1e-9]
        if not cx.size:
            return float("nan")
        lam = cx[np.argmax(np.abs(cx))]
        return float(-lam.real / abs(lam))

    def acceleration_amplitude(self, freq_hz) -> np.ndarray:
        """|a_p / x̄s| [m/s^2 per unit spool] of the frequency response (Fig 7)."""
        w = 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, dtype=float))
        out = np.empty_like(w)
        for i, wi in enumerate(w):
            x = np.linalg.solve(1j * wi * np.eye(4) - self.A, self.B[:, 0])
            out[i] = abs(1j * wi * x[2])
        return out


def linear_model(params: Parameters, *, beta1: float | None = None, beta2: float | None = None,
                 friction_factor: float | None = None) -> LinearModel:
    """Matrices of eq 20 from the parameter set (constant bulk moduli; overrides for identification)."""
    c, lin, ld, ps = params.cylinder, params.linear, params.load, params.supply.ps
    b1 = c.beta1 if beta1 is None else beta1
    b2 = c.beta2 if beta2 is None else beta2
    f = lin.friction_factor if friction_factor is None else friction_factor
    kq = lin.kq * np.sqrt(ps / (2 * lin.pn))          # m^3/s, kq1 = kq2
    kp1, kp2 = lin.kp1 * ps, lin.kp2 * ps             # Pa
    kc1, kc2 = kq / kp1, -kq / kp2                    # eq 19
    v1 = c.v01 + c.a1 * lin.xp0
    v2 = c.v02 + c.a2 * (c.stroke - lin.xp0)
    e1, e2, M = b1 / v1, b2 / v2, ld.mass
    A = np.array([[-e1 * kc1, 0, -e1 * c.a1, 0],
                  [0, -e2 * kc2, e2 * c.a2, 0],
                  [c.a1 / M, -c.a2 / M, -f / M, 0],
                  [0, 0, 1, 0]])
    B = np.array([[e1 * kq, 0], [-e2 * kq, 0], [0, 1], [0, 0]])
    C = np.array([[0, 0, 1, 0], [0, 0, 0, 1.0]])
    p10, p20 = equilibrium_pressures(params)
    return LinearModel(A, B, C, np.zeros((2, 2)), p10, p20)
