"""A circuit linearised at its state at rest (SPEC §12.5; README "Circuits"): dx/dt = A x + B u about the rest,
by central differences of the generated right-hand side (``hc_rhs``) with the modes at rest held; the states
are the circuit's (node pressures, then the components' states), the inputs its signals. Its eigenvalues give
the circuit's time constants and, for each complex pair, a natural frequency and damping: the hydraulic
resonances the fixed step has to resolve."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hydrohil.circuits.build import compile_circuit
from hydrohil.circuits.circuit import Circuit
from hydrohil.circuits.run import input_unit, start_state

# a state's perturbation: this much of its unit, or 1e-6 of its value when larger
STEP_BY_UNIT = {"Pa": 1.0, "m": 1e-9, "m/s": 1e-9, "rad/s": 1e-7, "-": 1e-9, "1/s": 1e-6}


@dataclass
class CircuitLinear:
    states: list[str]
    state_units: list[str]
    inputs: list[str]
    input_units: list[str]
    A: np.ndarray
    B: np.ndarray
    x0: np.ndarray                     # the state at rest
    u0: np.ndarray                     # the inputs there
    rate: np.ndarray                   # dx/dt there (0 at an equilibrium; not when [initial] holds a node off)

    @property
    def eigenvalues(self) -> np.ndarray:
        ev = np.linalg.eigvals(self.A) if len(self.A) else np.zeros(0)
        return ev[np.lexsort((ev.imag, ev.real))]

    def modes(self) -> list[dict]:
        """Each eigenvalue (a complex pair once): its time constant or natural frequency and damping."""
        out = []
        for lam in self.eigenvalues:
            if lam.imag < 0:
                continue
            w = abs(lam)
            if lam.imag > 0:
                out.append({"eigenvalue": [lam.real, lam.imag], "natural_frequency_rad_s": w,
                            "frequency_hz": w / (2 * np.pi), "damping": -lam.real / w if w else 0.0})
            elif lam.real < 0:
                out.append({"eigenvalue": [lam.real, 0.0], "time_constant_s": -1.0 / lam.real})
            else:
                out.append({"eigenvalue": [lam.real, 0.0], "growth_time_s": 1.0 / lam.real if lam.real > 0 else
                            float("inf")})
        return out

    def to_dict(self) -> dict:
        return {"states": self.states, "state_units": self.state_units, "inputs": self.inputs,
                "input_units": self.input_units, "A": self.A.tolist(), "B": self.B.tolist(), "x0": self.x0.tolist(),
                "u0": self.u0.tolist(), "rate": self.rate.tolist(), "moving": self.moving(), "modes": self.modes()}

    def moving(self) -> list[str]:
        """The states not at rest where the model is linearised (a node's [initial] pressure, an unbalanced
        piston): there the model is a tangent, not an equilibrium's."""
        scale = {"Pa": 1e2, "m": 1e-9, "m/s": 1e-6, "rad/s": 1e-6}          # per second
        return [s for s, u, r in zip(self.states, self.state_units, self.rate) if abs(r) > scale.get(u, 1e-6)]


def linearise_circuit(c: Circuit, *, h: float = 5e-4, inputs: dict | None = None) -> CircuitLinear:
    """``c`` linearised where its runs start (at rest, SPEC §12.5; its [initial] pressures kept) under its inputs
    at t = 0 (``inputs`` in place of its drive); ``rate`` and :meth:`CircuitLinear.moving` say whether that is
    an equilibrium."""
    cc = compile_circuit(c)
    lay, ffi, lib = cc.layout, cc.ffi, cc.lib
    y0, m0, u0 = start_state(c, h=h, inputs=inputs)
    n, nu = len(lay.states), len(lay.inputs)
    P = np.ascontiguousarray(lay.values())
    dy = np.zeros(max(n, 1))

    def f(y, u):
        lib.hc_rhs(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", np.ascontiguousarray(y)),
                   ffi.from_buffer("int64_t[]", m0), ffi.from_buffer("double[]", np.ascontiguousarray(u)),
                   ffi.from_buffer("double[]", dy))
        return dy[:n].copy()
    A, B = np.zeros((n, n)), np.zeros((n, nu))
    for j in range(n):
        d = max(STEP_BY_UNIT.get(lay.state_units[j], 1e-9), 1e-6 * abs(y0[j]))
        hi, lo = y0.copy(), y0.copy()
        hi[j] += d
        lo[j] -= d
        A[:, j] = (f(hi, u0) - f(lo, u0)) / (2 * d)
    for j, sig in enumerate(lay.inputs):
        prm = c.components[sig.split(".")[0]].type.params[sig.split(".")[1]]
        d = max(1e-6 * max(abs(u0[j]), 1.0), 1e-9)
        if prm.unit == "Pa":
            d = max(d, 1.0)
        hi, lo = u0.copy(), u0.copy()
        hi[j] += d
        lo[j] -= d
        B[:, j] = (f(y0, hi) - f(y0, lo)) / (2 * d)
    return CircuitLinear(list(lay.states), list(lay.state_units), list(lay.inputs),
                         [input_unit(c, s) for s in lay.inputs], A, B, y0[:n].copy(), u0[:nu].copy(), f(y0, u0))
