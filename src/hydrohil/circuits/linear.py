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


def describe_modes(eigenvalues) -> list[dict]:
    """Each eigenvalue (a complex pair once): its time constant, or natural frequency and damping, or growth."""
    out = []
    for lam in eigenvalues:
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


def sorted_eigenvalues(A: np.ndarray) -> np.ndarray:
    ev = np.linalg.eigvals(A) if len(A) else np.zeros(0)
    return ev[np.lexsort((ev.imag, ev.real))]


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

    at: str = "at rest"                # where: "at rest" (where runs start) or "at t = ... s of <scenario>"
    closed: dict | None = None         # the scenario's loop closed around it (closed_loop)

    @property
    def eigenvalues(self) -> np.ndarray:
        return sorted_eigenvalues(self.A)

    def modes(self) -> list[dict]:
        """Each eigenvalue (a complex pair once): its time constant or natural frequency and damping."""
        return describe_modes(self.eigenvalues)

    def to_dict(self) -> dict:
        return {"states": self.states, "state_units": self.state_units, "inputs": self.inputs,
                "input_units": self.input_units, "A": self.A.tolist(), "B": self.B.tolist(), "x0": self.x0.tolist(),
                "u0": self.u0.tolist(), "rate": self.rate.tolist(), "moving": self.moving(), "modes": self.modes(),
                "at": self.at, "closed_loop": self.closed}

    def moving(self) -> list[str]:
        """The states not at rest where the model is linearised (a node's [initial] pressure, an unbalanced
        piston): there the model is a tangent, not an equilibrium's."""
        scale = {"Pa": 1e2, "m": 1e-9, "m/s": 1e-6, "rad/s": 1e-6}          # per second
        return [s for s, u, r in zip(self.states, self.state_units, self.rate) if abs(r) > scale.get(u, 1e-6)]


def linearise_circuit(c: Circuit, *, h: float = 5e-4, inputs: dict | None = None, loop=None,
                      state: tuple | None = None, at: str = "at rest", rest=True) -> CircuitLinear:
    """``c`` linearised where its runs start (at rest, SPEC §12.5; its [initial] pressures kept; with ``loop``
    the command that holds its piston) under its inputs at t = 0 (``inputs`` in place of its drive), or at
    ``state`` = (y, m, u) (:func:`run_state`); ``rate`` and :meth:`CircuitLinear.moving` say whether that is an
    equilibrium. With ``loop``: the loop closed around it too (:func:`closed_loop`). ``rest``: a scenario's
    start (:func:`hydrohil.circuits.run.start_state`: a Hold, a [start])."""
    cc = compile_circuit(c)
    lay, ffi, lib = cc.layout, cc.ffi, cc.lib
    y0, m0, u0 = state if state is not None else start_state(c, h=h, inputs=inputs, loop=loop, rest=rest)
    y0, m0, u0 = (np.ascontiguousarray(y0, float), np.ascontiguousarray(m0, np.int64),
                  np.ascontiguousarray(u0, float))
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
        prm = c.input_param(sig)
        d = max(1e-6 * max(abs(u0[j]), 1.0), 1e-9)
        if prm.unit == "Pa":
            d = max(d, 1.0)
        hi, lo = u0.copy(), u0.copy()
        hi[j] += d
        lo[j] -= d
        B[:, j] = (f(y0, hi) - f(y0, lo)) / (2 * d)
    lin = CircuitLinear(list(lay.states), list(lay.state_units), list(lay.inputs),
                        [input_unit(c, s) for s in lay.inputs], A, B, y0[:n].copy(), u0[:nu].copy(), f(y0, u0), at)
    if loop is not None:
        lin.closed = closed_loop(lin, loop, c, y0, m0, u0)
    return lin


def run_state(cs, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The state (y, modes, inputs) of the scenario's run at time ``t`` (its step's row): an operating point
    along the trajectory (a loop holding its reference, a motor at speed)."""
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.errors import InputError
    if not 0 <= t <= cs.duration:
        raise InputError(f"a time within the run, [0, {cs.duration:g}] s, got {t:g}", source=cs.source, key="--at")
    res = simulate_circuit(cs.circuit, max(t, cs.step), h=cs.step, method="rk3" if cs.method == "reference" else
                           cs.method, rest=cs.rest, loop=cs.loop, commands=cs.commands)
    lay = compile_circuit(cs.circuit).layout
    k = int(round(t / cs.step))
    y = np.array([res.columns[s][k] for s in lay.states] or [0.0])
    m = np.array([res.columns[md][k] for md in lay.modes] or [0], dtype=np.int64)
    u = np.array([res.columns[i][k] for i in lay.inputs] or [0.0])
    return y, m, u


def output_row(c: Circuit, lin: CircuitLinear, column: str, y0, m0, u0) -> tuple[np.ndarray, np.ndarray]:
    """A log column (a signal) linearised about (y0, m0, u0): its row C (per state) and D (per input) by central
    differences of the generated log row, y = C·x + D·u."""
    cc = compile_circuit(c)
    lay, ffi, lib = cc.layout, cc.ffi, cc.lib
    P = np.ascontiguousarray(lay.values())
    col = lay.log_columns.index(column)
    row = np.zeros(len(lay.log_columns))
    y0, u0 = np.asarray(y0, dtype=float), np.asarray(u0, dtype=float)

    def g(y, u):
        lib.hc_row(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", np.ascontiguousarray(y)),
                   ffi.from_buffer("int64_t[]", np.ascontiguousarray(m0, dtype=np.int64)),
                   ffi.from_buffer("double[]", np.ascontiguousarray(u)), 0.0, ffi.from_buffer("double[]", row))
        return row[col]
    n = len(lin.states)
    C, D = np.zeros(n), np.zeros(len(lin.inputs))
    for i in range(n):
        d = max(STEP_BY_UNIT.get(lin.state_units[i], 1e-9), 1e-6 * abs(y0[i]))
        hi, lo = y0.copy(), y0.copy()
        hi[i] += d
        lo[i] -= d
        C[i] = (g(hi, u0) - g(lo, u0)) / (2 * d)
    for j in range(len(lin.inputs)):
        du = max(1e-6 * max(abs(u0[j]), 1.0), 1e-9)
        hi, lo = u0.copy(), u0.copy()
        hi[j] += du
        lo[j] -= du
        D[j] = (g(y0, hi) - g(y0, lo)) / (2 * du)
    return C, D


def closed_loop(lin: CircuitLinear, loop, c: Circuit, y0, m0, u0) -> dict:
    """The scenario's loop closed around the linearised circuit, the law taken continuous (its sampling at the
    step, its one-step measurement delay, its sensor's resolution and a delayed command's input delay left out:
    ``left_out`` names the delay lines): with the measured signal
    y = C·x + D·u (C, D by central differences of the generated log row) and g = 1/(1 + kp·D), a P law gives
    A - g·kp·b·C; a PI law adds its integral xi' = ki·e: [[A - g·kp·b·C, g·b], [-ki·g·C, -ki·D·g]] (kp, ki
    times -1 for a reverse-acting loop). A PID law's derivative acts on the measured signal through its filter,
    tf·v' + v = y' (the sampled law's filter taken continuous): with D = 0, states [x, xi, v] and
    u = -kp·C·x + xi - kd·v. Its eigenvalues: the loop's poles. p_ff's feed-forward acts on the reference only
    (the poles are P's)."""
    lay = compile_circuit(c).layout
    cfg = loop.cfg
    if cfg.type not in ("p", "pi", "pid", "p_ff"):
        return {"law": cfg.type, "note": f"no closed-loop poles for a {cfg.type} law"}
    j = lay.inputs.index(loop.command)
    C, Dall = output_row(c, lin, loop.measure, y0, m0, u0)
    D = Dall[j]
    n = len(lin.states)
    kp = loop.sign * cfg.kp
    ki = loop.sign * getattr(cfg, "ki", 0.0) if cfg.type in ("pi", "pid") else 0.0
    b = lin.B[:, j]
    if cfg.type == "pid":
        if D != 0.0:
            return {"law": cfg.type, "note": "a PID law on a signal its command moves directly (D != 0): no "
                    "closed-loop poles in this version"}
        kd, tf = loop.sign * cfg.kd, cfg.tf
        Acl = lin.A - kp * np.outer(b, C)
        if tf > 0:                      # [x, xi, v]: v' = (C·x' - v)/tf
            top = np.hstack([Acl, b[:, None], -kd * b[:, None]])
            cx = C @ top
            A = np.vstack([top, np.hstack([-ki * C, [0.0, 0.0]]), (cx - np.eye(n + 2)[n + 1]) / tf])
        else:                           # v = C·x' exactly: u (1 + kd·C·b) = -(kp·C + kd·C·A)·x + xi
            gd = 1.0 / (1.0 + kd * (C @ b))
            K = gd * (kp * C + kd * (C @ lin.A))
            A = np.block([[lin.A - np.outer(b, K), gd * b[:, None]], [-ki * C[None, :], np.zeros((1, 1))]])
    else:
        gain = 1.0 / (1.0 + kp * D)
        A = lin.A - gain * kp * np.outer(b, C)
        if cfg.type == "pi":
            A = np.block([[A, gain * b[:, None]], [-ki * gain * C[None, :], np.array([[-ki * D * gain]])]])
    ev = sorted_eigenvalues(A)
    left_out = []
    for sig, par in lay.delay_params.items():
        comp, key = par.split(".")
        left_out.append(f"{sig}'s input delay, {c.components[comp].values[key] * 1e3:g} ms")
    return {"law": cfg.type, "measure": loop.measure, "command": loop.command, "C": C.tolist(), "D": float(D),
            "A": A.tolist(), "eigenvalues": [[float(e.real), float(e.imag)] for e in ev],
            "modes": describe_modes(ev), "left_out": left_out}
