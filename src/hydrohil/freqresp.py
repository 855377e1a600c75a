"""``hydrohil freqresp``: frequency responses of the nonlinear model by stepped sines, beside the linear
model's prediction (README "Frequency responses").

Per frequency f one run of the compiled loop (the scenario's parameters, step and built-in controller):

- closed loop, x/x_ref: the reference x0 + A·sin(2πft) (slope included for feed-forward) around the
  scenario's initial position x0;
- open loop, x/ū: the command xs0 + a·sin(2πft) around the equilibrium spool offset xs0 (``linear``), the
  piston starting at mid-stroke; the position integrates the velocity and drifts with any asymmetry, so
  the gain is measured on the velocity, x/ū = (vp/ū)/(j2πf).

Gain and phase are the fundamental's (projection on sin/cos over whole periods) in the run's last period.
Periodic steady state is checked as the spool identification does: the last two periods' fundamentals
must agree within ``tol`` (relative, amplitude; the phase within tol rad); the run is doubled until they do
(or the point is reported unconverged). The points run in parallel threads (the core releases the GIL).

The linear prediction is :mod:`hydrohil.linear` at x0 with the controller's sampled law in z = e^{jωh},
the zero-order hold (1 − e^{−jωh})/(jωh) and the valve's delay.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hydrohil.errors import InputError
from hydrohil.models.layout import pack
from hydrohil.simulation.loop import STATUS_OK, Sim, initial_state

MAX_STEPS = 4_000_000        # per point: 2000 s of plant time at 0.5 ms


@dataclass
class Point:
    freq: float
    gain: complex                  # output per input (x/x_ref, or x/ū)
    periods: int
    residual: float
    converged: bool
    note: str = ""


def phase_deg(g) -> np.ndarray:
    """Phase [deg] of the complex gains, unwrapped along the finite ones (NaN stays NaN)."""
    g = np.asarray(g, dtype=complex)
    out = np.full(g.shape, np.nan)
    ok = np.isfinite(g)
    out[ok] = np.degrees(np.unwrap(np.angle(g[ok])))
    return out


def _fundamental(t, y, f):
    w = 2 * np.pi * f
    return 2 * np.mean(y * np.exp(-1j * w * t))


def _periods(log, f, h, col):
    t, y = log[:, 0], log[:, col]
    k = int(round(1 / (f * h)))          # samples per period (the grid is exact when 1/(f h) is whole)
    last = y[-k:] - y[-k:].mean(), y[-2 * k:-k] - y[-2 * k:-k].mean()
    return _fundamental(t[-k:], last[0], f), _fundamental(t[-2 * k:-k], last[1], f)


def point(sc, f: float, *, loop: str, amplitude: float, u0: float = 0.0, tol: float = 1e-3,
          min_periods: int = 6) -> Point:
    """One stepped-sine point (module docstring); ``u0``: the open loop's mean command."""
    s, params = sc.scenario, sc.params
    h = s.solver.step
    p = pack(params)
    f = 1.0 / (round(1.0 / (f * h)) * h)          # a whole number of steps per period
    w = 2 * np.pi * f
    periods = max(min_periods, int(math.ceil(0.5 * f)) * 2)       # at least ~1 s of settling
    x0 = s.initial.xp if loop == "closed" else 0.5 * params.cylinder.stroke
    while True:
        n = int(round(periods / (f * h)))
        if n > MAX_STEPS:
            return Point(f, complex("nan"), periods // 2, float("nan"), False, "did not converge")
        t = np.arange(n + 1) * h
        y, m = initial_state(params, x0, xs=0.0 if loop == "closed" else u0, p=p)
        sim = Sim(p, h, solver=s.solver.method, model="generated", params=params)   # (its circuit's model)
        sim.set_state(y, m)
        if loop == "closed":
            status, _, log = sim.run(n, 1, x0 + amplitude * np.sin(w * t), slopes=amplitude * w * np.cos(w * t),
                                     controller=sc.make_controller(), seed=s.hil.seed)
            a, b = _periods(log, f, h, 7)
            ref = -1j * amplitude          # the fundamental of A sin(wt) as _fundamental measures it
        else:
            status, _, log = sim.run(n, 1, u0 + amplitude * np.sin(w * t))
            a, b = _periods(log, f, h, 8)                    # velocity
            a, b = a / (1j * w), b / (1j * w)
            ref = -1j * amplitude
        if status != STATUS_OK:
            return Point(f, complex("nan"), periods, float("nan"), False, "diverged")
        travel = log[-int(round(2 / (f * h))):, 11]
        if np.any(travel != 0):
            return Point(f, complex("nan"), periods, float("nan"), False, "reached an end stop")
        res = abs(a - b) / max(abs(a), 1e-300)
        if res < tol:
            return Point(f, a / ref, periods, float(res), True)
        periods *= 2


def linear_prediction(sc, freqs, loop: str) -> np.ndarray | None:
    """The linear model's gain at ``freqs`` (module docstring); None for a Python controller."""
    from hydrohil.linear import OUTPUTS, linearise
    s, params = sc.scenario, sc.params
    h = s.solver.step
    x0 = s.initial.xp if loop == "closed" else 0.5 * params.cylinder.stroke
    lp = linearise(params, x0)
    f = np.asarray(freqs, dtype=float)
    w = 2 * np.pi * f
    zoh = (1 - np.exp(-1j * w * h)) / (1j * w * h)
    g = lp.outputs_per_command(f) * zoh[:, None]         # (xp, vp, p1, p2) per unit ū
    if loop == "open":
        return g[:, OUTPUTS.index("xp")]
    c = s.controller
    if c.type == "python":
        return None
    # p_ff's bias and deadband compensation are left out: a constant, and a gain u_db/e_db only for errors
    # below e_db (the small-signal loop of such a controller is stiffer than predicted here)
    zi = np.exp(-1j * w * h)                              # z^-1
    kp, ki, kd = c.kp, getattr(c, "ki", 0.0), getattr(c, "kd", 0.0)
    tf, kff, kpl, tpl = getattr(c, "tf", 2e-3), getattr(c, "kff", 0.0), getattr(c, "kpl", 0.0), getattr(c, "tpl", 0.0)
    integ = ki * h * zi / (1 - zi)                         # I_k = I_{k-1} + ki h e_{k-1}
    vel = (1 - zi) / ((tf + h) - tf * zi)
    a = tpl / (tpl + h) if tpl > 0 else None
    hp = a * (1 - zi) / (1 - a * zi) if a is not None else 1.0
    ratio = params.cylinder.a2 / params.cylinder.a1
    gx, gpl = g[:, 0], g[:, 2] - ratio * g[:, 3]
    u_per_r = (kp + integ + kff * 1j * w) / (1 + (kp + integ + kd * vel) * gx + kpl * hp * gpl)
    return gx * u_per_r


def freqresp(sc, out: Path, *, fmin: float = 0.5, fmax: float = 50.0, points: int = 15, amplitude: float = 1e-3,
             u_amplitude: float = 0.02, loops=("closed", "open"), workers: int | None = None, progress=None) -> dict:
    """Stepped-sine responses of the loaded scenario ``sc``: ``out/freqresp.csv``, ``bode.png``,
    ``freqresp.json``. Returns the summary."""
    s = sc.scenario
    if "closed" in loops and not s.closed_loop:
        raise InputError("the closed-loop response needs a [controller] + [reference] scenario", source=sc.source)
    if not (amplitude > 0 and u_amplitude > 0):
        raise InputError(f"amplitudes must be > 0, got {amplitude} m and {u_amplitude}", source="--amplitude")
    if "closed" in loops and s.python_controller:
        raise InputError("freqresp runs built-in controllers in the compiled loop (p, pi, pid, p_ff, "
                         "state_feedback)", source=sc.source, key="controller.type")
    if not 0 < fmin < fmax:
        raise InputError(f"need 0 < fmin < fmax, got {fmin}, {fmax}", source="--fmin/--fmax")
    if fmax > 0.25 / s.solver.step:
        raise InputError(f"fmax {fmax:g} Hz is above a quarter of the sample rate ({0.25 / s.solver.step:g} Hz)",
                         source="--fmax")
    freqs = np.geomspace(fmin, fmax, points)
    jobs = [(loop, f) for loop in loops for f in freqs]
    amp = {"closed": amplitude, "open": u_amplitude}
    u0 = 0.0
    if "open" in loops:                 # the open loop's mean command: the equilibrium spool offset at mid-stroke
        from hydrohil.linear import equilibrium
        u0 = equilibrium(sc.params, 0.5 * sc.params.cylinder.stroke).xs
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        futures = [pool.submit(point, sc, f, loop=loop, amplitude=amp[loop], u0=u0) for loop, f in jobs]
        results = []
        for fut in futures:
            results.append(fut.result())
            if progress is not None:
                progress(len(results), len(jobs))
    summary = {"scenario": sc.source, "amplitude_m": amplitude, "u_amplitude": u_amplitude}
    return _report(out, jobs, results, lambda fr, loop: linear_prediction(sc, fr, loop), fmin, fmax, summary,
                   f"{Path(sc.source).name}: stepped sines, closed-loop ±{amplitude * 1e3:g} mm, "
                   f"open-loop ±{u_amplitude:g} ū")


def _report(out: Path, jobs: list, results: list, linear, fmin: float, fmax: float, summary: dict, title: str,
            names: dict | None = None) -> dict:
    """The stepped sines' points (``jobs`` (loop, f) and their ``results``) beside ``linear(freqs, loop)`` (the
    linear prediction, or None): freqresp.csv, bode.png, freqresp.json in ``out``; the summary (``summary``
    with each loop's points, bandwidth and gaps to the linear model)."""
    out.mkdir(parents=True, exist_ok=True)
    rows, summary = [], {**summary, "loops": {}}
    by_loop = {}
    loops = list(dict.fromkeys(loop for loop, _ in jobs))
    for loop in loops:
        pts = [r for (lp_, _), r in zip(jobs, results) if lp_ == loop]
        fr = np.array([r.freq for r in pts])
        lin = linear(fr, loop)
        dense = np.geomspace(fmin, fmax, 200)
        lin_dense = linear(dense, loop)
        g = np.array([r.gain for r in pts])
        db = 20 * np.log10(np.abs(g))
        ph = phase_deg(g)
        by_loop[loop] = {"freq": fr, "gain_db": db, "phase_deg": ph,
                         "converged": np.array([r.converged for r in pts], dtype=bool),
                         "linear": None if lin_dense is None else
                         (dense, 20 * np.log10(np.abs(lin_dense)), phase_deg(lin_dense))}
        ldb = 20 * np.log10(np.abs(lin)) if lin is not None else np.full(len(pts), np.nan)
        lph = phase_deg(lin) if lin is not None else np.full(len(pts), np.nan)
        for r, a, b, c, d in zip(pts, db, ph, ldb, lph):
            rows.append((loop, r.freq, a, b, c, d, r.periods, r.residual, int(r.converged), r.note))
        info = {"points": len(pts), "unconverged": int(sum(not r.converged for r in pts))}
        ok = np.isfinite(db)                  # points that reached an end stop or did not converge: left out
        if loop == "closed":
            f_ok, db_ok = fr[ok], db[ok]
            below = np.nonzero(db_ok < -3.0)[0]
            bw = None                         # None: not crossed among the measured points
            if below.size and below[0] > 0:   # the -3 dB crossing, linear in dB over log frequency
                i = below[0]
                r = (db_ok[i - 1] + 3.0) / (db_ok[i - 1] - db_ok[i])
                bw = float(np.exp(np.log(f_ok[i - 1]) + r * (np.log(f_ok[i]) - np.log(f_ok[i - 1]))))
            info["bandwidth_hz"] = bw
            sel = ok & (fr <= bw if bw is not None else True)
            if lin is not None and sel.any():
                info["max_gain_gap_db_below_bandwidth"] = float(np.max(np.abs(db - ldb)[sel]))
                info["max_phase_gap_deg_below_bandwidth"] = float(np.max(np.abs(ph - lph)[sel]))
        elif lin is not None and ok.any():
            info["max_gain_gap_db"] = float(np.max(np.abs(db - ldb)[ok]))
            info["max_phase_gap_deg"] = float(np.max(np.abs(ph - lph)[ok]))
        summary["loops"][loop] = info
    with (out / "freqresp.csv").open("w") as fh:
        fh.write("loop,freq_hz,gain_db,phase_deg,linear_gain_db,linear_phase_deg,periods,residual,converged,note\n")
        for r in rows:
            fh.write(",".join(repr(float(v)) if isinstance(v, (float, np.floating)) else str(v) for v in r) + "\n")
    from hydrohil.plotting import plot_bode
    from hydrohil.simulation.outputs import write_json
    plot_bode(out / "bode.png", by_loop, title=title, names=names)
    write_json(out / "freqresp.json", summary)
    return summary


# ---- any circuit (issue #27): the same stepped sines on its generated loop, its linearisation beside them ----
# the closed loop's default reference amplitude, per unit of the measured signal
CIRCUIT_AMPLITUDE = {"m": 1e-3, "m/s": 1e-3, "rad/s": 2.0, "Pa": 1e5, "m3/s": 1e-5, "N": 100.0, "N.m": 1.0}


@dataclass
class CircuitSines:
    """What a circuit's stepped sines drive and read: the closed loop's reference (around its last value) or
    an input (around its value at rest, the loop opened), and the signal read (a position through its speed:
    a cylinder's position integrates, x/u = (v/u)/(jw))."""
    cs: object
    loop: str
    input: str | None             # the open loop's input
    signal: str                   # the signal whose response is measured
    read: str                     # the column read (the signal, or its speed)
    integrate: bool               # read / (jw)
    amplitude: float
    centre: float
    state: tuple                  # (y, m, u) of the operating point (the open loop's: the loop's holding command)


SETTLE_S = 2.0       # a closed loop's run holds its reference at the operating point this long before the sine


def _held_loop(cs, centre: float, t: np.ndarray, values: np.ndarray):
    """The scenario's loop with the reference ``centre`` for SETTLE_S, then ``values`` at the times ``t`` after."""
    import dataclasses
    ts = np.concatenate(([0.0], SETTLE_S + t))
    return dataclasses.replace(cs.loop, reference=(ts, np.concatenate(([centre], values))), linear=True,
                               period=None, controller=None, sensor_faults=[],
                               pressure_faults=[])    # (its faults, its repeat: not in a sine)


def _circuit_sines(cs, loop: str, amplitude: float | None, input_: str | None, signal: str | None,
                   around: float | None = None) -> CircuitSines:
    from hydrohil.circuits.run import signal_units, simulate_circuit, start_state
    lay = cs.layout
    c = cs.circuit
    if loop == "closed":
        if cs.loop is None:
            raise InputError("the closed-loop response needs a [controller] + [reference] scenario", source=cs.source)
        sig = signal or cs.loop.measure
        if sig != cs.loop.measure:
            raise InputError(f"a closed loop's response is its measured signal's ({cs.loop.measure})",
                             source="--signal")
        unit = signal_units(c, lay)[sig]
        amp = amplitude if amplitude is not None else CIRCUIT_AMPLITUDE.get(unit, 1e-3)
        centre = float(cs.loop.reference[1][-1]) if around is None else float(around)
        held = {name: float(v) for name, v in zip(lay.inputs, start_state(c, h=cs.step, loop=cs.loop,
                                                                           rest=cs.rest)[2])
                if name != cs.loop.command}
        res = simulate_circuit(c, SETTLE_S, h=cs.step, method=cs.method, rest=cs.rest, inputs=held,
                               loop=_held_loop(cs, centre, np.zeros(1), np.array([centre])))
        state = (np.array([res.columns[x][-1] for x in lay.states]),
                 np.array([res.columns[m][-1] for m in lay.modes] or [0], dtype=np.int64),
                 np.array([res.columns[i][-1] for i in lay.inputs]))
        return CircuitSines(cs, loop, None, sig, sig, False, amp, centre, state)
    name = input_ or (cs.loop.command if cs.loop is not None else (lay.inputs[0] if lay.inputs else None))
    if name not in lay.inputs:
        raise InputError(f"the input the open loop drives, one of the circuit's: {', '.join(lay.inputs) or 'none'}",
                         source="--input", key=str(name))
    sig = signal or (cs.loop.measure if cs.loop is not None else None)
    if sig is None or sig not in lay.log_columns or sig == "t":
        raise InputError(f"the signal whose response is measured (a log column of {c.name}: "
                         f"{', '.join(x for x in lay.log_columns if x != 't')})", source="--signal", key=str(sig))
    comp, _, var = sig.rpartition(".")
    integrate = var == "x" and f"{comp}.v" in lay.log_columns
    prm = c.input_param(name)
    span = (prm.hi - prm.lo) if np.isfinite(prm.hi - prm.lo) else 1.0
    amp = amplitude if amplitude is not None else 0.01 * span
    state = start_state(c, h=cs.step, loop=cs.loop, rest=cs.rest)
    u0 = float(state[2][lay.inputs.index(name)])
    return CircuitSines(cs, loop, name, sig, f"{comp}.v" if integrate else sig, integrate, amp, u0, state)


def circuit_point(sn: CircuitSines, f: float, *, tol: float = 1e-3, min_periods: int = 6) -> Point:
    """One stepped-sine point of a circuit (as :func:`point`): the generated loop run from the operating point's
    rest with the reference or the input a sine, the fundamental of the signal read in the last period."""
    from hydrohil.circuits.circuit import Drive
    from hydrohil.circuits.run import MOVING, simulate_circuit
    from hydrohil.errors import SimulationDiverged
    cs = sn.cs
    c, h = cs.circuit, cs.step
    f = 1.0 / (round(1.0 / (f * h)) * h)
    w = 2 * np.pi * f
    periods = max(min_periods, int(math.ceil(0.5 * f)) * 2)
    stops = {f"{comp.name}.mode": [comp.modes.index("at_retract"), comp.modes.index("at_extend")]
             for comp in c.components.values() if comp.type.name in MOVING and "at_retract" in comp.modes}
    lay = cs.layout
    held = {name: float(sn.state[2][j]) for j, name in enumerate(lay.inputs)      # the other inputs: as at rest
            if name != (sn.input if sn.loop == "open" else cs.loop.command)}
    while True:
        n = int(round(periods / (f * h)))
        if n > MAX_STEPS:
            return Point(f, complex("nan"), periods // 2, float("nan"), False, "did not converge")
        t = np.arange(n + 1) * h
        sine = sn.centre + sn.amplitude * np.sin(w * t)
        try:
            if sn.loop == "closed":                  # (the operating point reached first: SETTLE_S)
                res = simulate_circuit(c, SETTLE_S + n * h, h=h, method=cs.method, rest=cs.rest,
                                       loop=_held_loop(cs, sn.centre, t, sine), inputs=held)
            else:
                res = simulate_circuit(c, n * h, h=h, method=cs.method, rest=cs.rest,
                                       inputs={**held, sn.input: Drive(t, sine)})
        except SimulationDiverged:
            return Point(f, complex("nan"), periods, float("nan"), False, "diverged")
        k = int(round(1 / (f * h)))
        if any(np.any(np.isin(res.column(m)[-2 * k:], at)) for m, at in stops.items()):
            return Point(f, complex("nan"), periods, float("nan"), False, "reached an end stop")
        t0 = SETTLE_S if sn.loop == "closed" else 0.0        # (the sine's own time: its phase)
        log = np.column_stack([res.column("t") - t0, res.column(sn.read)])
        a, b = _periods(log, f, h, 1)
        if sn.integrate:
            a, b = a / (1j * w), b / (1j * w)
        res_ = abs(a - b) / max(abs(a), 1e-300)
        if res_ < tol:
            return Point(f, a / (-1j * sn.amplitude), periods, float(res_), True)
        periods *= 2


def circuit_linear_prediction(sn: CircuitSines, freqs) -> np.ndarray | None:
    """The circuit linearised at the operating point (:mod:`hydrohil.circuits.linear`): the signal per input
    C (jw - A)^-1 B + D, held over each step (the zero-order hold) and late by the input's delay line; in closed
    loop the sampled law around it as the paper's (:func:`linear_prediction`: P, PI, PID, p_ff's feed-forward;
    the measurement's one-step wait and a sensor's resolution left out). None for another law."""
    from hydrohil.circuits.linear import linearise_circuit, output_row
    cs = sn.cs
    c, h, lay = cs.circuit, cs.step, cs.layout
    y0, m0, u0 = sn.state
    lin = linearise_circuit(c, h=h, state=(y0, m0, u0))
    name = sn.input if sn.loop == "open" else cs.loop.command
    j = lay.inputs.index(name)
    C, D = output_row(c, lin, sn.signal, y0, m0, u0)
    f = np.asarray(freqs, dtype=float)
    w = 2 * np.pi * f
    n = len(lin.states)
    g = np.array([C @ np.linalg.solve(1j * wk * np.eye(n) - lin.A, lin.B[:, j]) + D[j] for wk in w])
    g = g * (1 - np.exp(-1j * w * h)) / (1j * w * h)
    if name in lay.delay_params:
        comp, key = lay.delay_params[name].split(".")
        g = g * np.exp(-1j * w * c.components[comp].values[key])
    if sn.loop == "open":
        return g
    cfg, s = cs.loop.cfg, cs.loop.sign
    if cfg.type not in ("p", "pi", "pid", "p_ff"):
        return None
    zi = np.exp(-1j * w * h)
    kp, ki, kd = s * cfg.kp, s * getattr(cfg, "ki", 0.0), s * getattr(cfg, "kd", 0.0)
    tf, kff = getattr(cfg, "tf", 2e-3), s * getattr(cfg, "kff", 0.0)
    integ = ki * h * zi / (1 - zi)
    vel = (1 - zi) / ((tf + h) - tf * zi)
    return g * (kp + integ + kff * 1j * w) / (1 + (kp + integ + kd * vel) * g)


def circuit_freqresp(cs, out: Path, *, fmin: float = 0.5, fmax: float = 50.0, points: int = 15,
                     amplitude: float | None = None, u_amplitude: float | None = None, loops=("closed", "open"),
                     input_: str | None = None, signal: str | None = None, around: float | None = None,
                     workers: int | None = None, progress=None) -> dict:
    """Stepped-sine responses of a circuit scenario ``cs`` (:class:`hydrohil.circuits.scenario.CircuitScenario`):
    the closed loop's measured signal per its reference around ``around`` (default: the reference's last value,
    reached in SETTLE_S first), the open loop's ``signal`` per ``input_`` (default: the loop's command and
    measured signal) around the state at rest, the other inputs held as at rest; beside the linearised
    circuit's; the same files as :func:`freqresp`."""
    if cs.method == "reference":
        raise InputError("stepped sines run the fixed-step model (solver.method rk3, ...): not the reference",
                         source=cs.source, key="solver.method")
    if not 0 < fmin < fmax:
        raise InputError(f"need 0 < fmin < fmax, got {fmin}, {fmax}", source="--fmin/--fmax")
    if fmax > 0.25 / cs.step:
        raise InputError(f"fmax {fmax:g} Hz is above a quarter of the sample rate ({0.25 / cs.step:g} Hz)",
                         source="--fmax")
    for a, what in ((amplitude, "--amplitude"), (u_amplitude, "--u-amplitude")):
        if a is not None and not a > 0:
            raise InputError(f"an amplitude > 0, got {a}", source=what)
    sines = {loop: _circuit_sines(cs, loop, amplitude if loop == "closed" else u_amplitude, input_, signal, around)
             for loop in loops}
    freqs = np.geomspace(fmin, fmax, points)
    jobs = [(loop, f) for loop in loops for f in freqs]
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        futures = [pool.submit(circuit_point, sines[loop], f) for loop, f in jobs]
        results = []
        for fut in futures:
            results.append(fut.result())
            if progress is not None:
                progress(len(results), len(jobs))
    from hydrohil.circuits.run import signal_units
    units = signal_units(cs.circuit, cs.layout)
    names, head = {}, {"scenario": cs.source, "circuit": cs.circuit.name}
    for loop, sn in sines.items():
        unit = units.get(sn.signal, "-")
        if loop == "closed":
            names[loop] = f"closed loop {sn.signal} / its reference"
            head["closed"] = {"signal": sn.signal, "amplitude": sn.amplitude, "unit": unit, "around": sn.centre}
        else:
            iu = cs.circuit.input_param(sn.input).unit
            names[loop] = f"open loop {sn.signal} / {sn.input} [{unit} per {iu}]"
            head["open"] = {"signal": sn.signal, "input": sn.input, "amplitude": sn.amplitude, "unit": iu,
                            "around": sn.centre, "through_speed": sn.integrate}
    title = f"{Path(cs.source).name} ({cs.circuit.name}): stepped sines, " + ", ".join(
        f"{loop} loop ±{sn.amplitude:g} {head[loop]['unit']}" for loop, sn in sines.items())
    return _report(out, jobs, results, lambda fr, loop: circuit_linear_prediction(sines[loop], fr), fmin, fmax,
                   head, title, names)
