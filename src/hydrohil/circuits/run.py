"""Running a circuit offline: the compiled model (:mod:`hydrohil.circuits.build`) at a fixed step with one of
the core's explicit methods, its inputs from the circuit's default drive or given here."""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from hydrohil.circuits.build import callback_raised, compile_circuit
from hydrohil.circuits.circuit import Circuit, Drive
from hydrohil.circuits.generate import PRESSURE_FLOOR
from hydrohil.control import BuiltinController, Measurement, call_controller, load_callable, user_controller
from hydrohil.core.watchdog import WATCHDOG_TIMEOUT
from hydrohil.errors import HydrohilError, InputError, SimulationDiverged

METHODS = ("euler", "heun", "rk3", "rk4")       # the core's tableaus, in its order (HH_EULER ..)
SOLVERS = (*METHODS, "reference")               # "reference": the continuous model, LSODA/Radau
CYLINDERS = ("cylinder", "double_rod_cylinder", "lugre_cylinder")   # (mode 0: free, or free and sticking)
MOVING = (*CYLINDERS, "load")          # bodies moving on a rod (x, v, stop modes), unless coupled to a load


def net_force_column(comp) -> str:
    """A moving body's log column of the force that moves it (a LuGre cylinder's: before its seals' friction)."""
    return f"{comp.name}.{'applied_force' if comp.type.name == 'lugre_cylinder' else 'net_force'}"


@dataclass
class CircuitResult:
    columns: dict[str, np.ndarray]      # "t", "<node>.p", "<component>.<output>", "<component>.mode" (index)
    units: dict[str, str]
    mode_names: dict[str, tuple[str, ...]]
    h: float
    method: str
    wall: float = 0.0                   # [s] of the run itself (not the compile, not the rest march)
    stats: dict = field(default_factory=dict)   # the reference's: intervals, radau_fallbacks
    states: list = field(default_factory=list)  # the components' state columns ("cyl.x", "cyl.v", "motor.w")
    watchdog: np.ndarray | None = None  # per step (not per row): 1 where a command path's watchdog held its safe state

    def column(self, name: str) -> np.ndarray:
        try:
            return self.columns[name]
        except KeyError:
            raise InputError(f"no column {name!r} (columns: {', '.join(self.columns)})") from None


def input_table(c: Circuit, n: int, h: float, inputs: dict | None = None) -> np.ndarray:
    """The inputs of steps 0..n-1 (n x NU): each signal's drive (a value, or (t, values) held from each t),
    ``inputs`` replacing the circuit's defaults."""
    drives = {**c.inputs, **(inputs or {})}
    unknown = set(drives) - set(c.inputs)
    if unknown:
        raise InputError(f"not an input of circuit {c.name!r}: {sorted(unknown)[0]} (inputs: "
                         f"{', '.join(c.inputs) or 'none'})", key="inputs")
    u = np.zeros((max(n, 1), max(len(c.inputs), 1)))
    t = np.arange(max(n, 1)) * h
    for j, name in enumerate(c.inputs):
        d = drives[name]
        if isinstance(d, tuple):           # a table (t, values), held or linear (Drive.at)
            u[:, j] = (d if isinstance(d, Drive) else Drive(*d)).at(t, h)
        else:
            u[:, j] = float(d)
    return u


PRESSURE_STREAM = 1 << 30  # a loop's pressure noise without a seed of its own: this stream of its sensor's seed
REST_MARCH_S = 20.0         # simulated seconds of the rest march (the fast parts: a relief, an accumulator)
REST_TOL = 1e-13            # a pressure at rest moves less than this * (1 bar + |p|) in a step


def settle(c: Circuit, cc, P, u, y, m, h: float, method: str) -> None:
    """The node pressures at rest (SPEC §12.5) in place of their initial guesses: the components' states held,
    the pressures marched until the fast parts settle (a relief valve, an accumulator), then the flow balance of
    every node solved (nodes fed by leakage alone take minutes to settle), the modes following their guards, then
    the components' states at rest (a LuGre seal's bristles carry the net force, up to the breakaway: the core's
    rest); a node given in ``[initial]`` keeps its value. Pressures that do not settle (a pump with nowhere to go) are
    an error naming the nodes."""
    from scipy.optimize import root
    ffi, lib = cc.ffi, cc.lib
    nn = len(c.state_nodes)
    held = np.array([n in c.initial for n in c.state_nodes] or [0], dtype=np.int64)
    free = [i for i in range(nn) if not held[i]]
    y0 = y.copy()
    buf = {name: ffi.from_buffer(t, a) for name, t, a in (("P", "double[]", P), ("u", "double[]", u),
                                                         ("y", "double[]", y), ("m", "int64_t[]", m),
                                                         ("held", "int64_t[]", held))}

    def march(seconds):
        return lib.hc_rest(buf["P"], buf["u"], buf["y"], buf["m"], buf["held"], METHODS.index(method), float(h),
                           max(int(seconds / h), 1), REST_TOL)
    settled = march(REST_MARCH_S) > 0
    dy = np.zeros(max(len(y), 1))
    for _ in range(5):                    # a few rounds: the modes at the solution may differ from the march's
        if settled or not free:
            break

        def balance(p):
            yy = y.copy()
            yy[free] = p
            lib.hc_rhs(buf["P"], ffi.from_buffer("double[]", yy), buf["m"], buf["u"], ffi.from_buffer("double[]", dy))
            return dy[free]
        sol = root(balance, y[free], method="hybr", options={"xtol": 1e-15})
        if np.all(np.isfinite(sol.x)):
            y[free] = sol.x
        settled = march(10 * h) > 0       # the modes follow; settled when no pressure moves any more
    if settled:
        open_nodes = _indeterminate(cc, buf, y, free)
        open_nodes = _force_balance(c, cc, buf, y, open_nodes)
        _warn_indeterminate(c, y, open_nodes)
        lib.hc_hold(buf["P"], buf["u"], buf["y"], buf["m"])   # the bristles taking the load
    if not settled:
        moving = [c.state_nodes[i] for i in free]
        raise InputError(f"no state at rest: the pressures at {', '.join(moving)} do not settle (from "
                         f"{', '.join(f'{x / 1e5:.4g}' for x in y0[:nn])} bar); does a pump have nowhere to go? "
                         "Give [initial] pressures to start from a state of your own", source=c.source, key="initial")


def _indeterminate(cc, buf, y, free) -> list[int]:
    """The free nodes whose flow balance does not depend on their pressure (no path but closed ones): they have
    no pressure at rest from the flows."""
    ffi, lib = cc.ffi, cc.lib
    hi, lo = np.zeros(max(len(y), 1)), np.zeros(max(len(y), 1))
    out = []
    for i in free:
        d = max(1e3, 1e-6 * abs(y[i]))
        for sign, res in ((1, hi), (-1, lo)):
            yy = y.copy()
            yy[i] += sign * d
            lib.hc_rhs(buf["P"], ffi.from_buffer("double[]", yy), buf["m"], buf["u"], ffi.from_buffer("double[]", res))
        if abs(hi[i] - lo[i]) / (2 * d) < 1e-9:
            out.append(i)
    return out


def _force_balance(c: Circuit, cc, buf, y, nodes: list[int]) -> list[int]:
    """A piston chamber closed off at rest (a counterbalance or check valve holding a load) takes the pressure
    that holds the piston still (SPEC §12.5: the force balance), when the other chamber's is known; the
    nodes still without a pressure are returned."""
    ffi, lib = cc.ffi, cc.lib
    lay = cc.layout
    dy = np.zeros(max(len(y), 1))
    left = list(nodes)
    for comp in c.components.values():
        if comp.type.name not in CYLINDERS:
            continue
        idx = [c.state_nodes.index(comp.ports[p]) if comp.ports[p] in c.state_nodes else None for p in ("a", "b")]
        chambers = [i for i in idx if i is not None and i in left]
        if len(chambers) != 1:
            continue
        i, j = chambers[0], lay.states.index(f"{comp.coupled or comp.name}.v")   # (a coupled rod: its load's)

        def accel(p):
            yy = y.copy()
            yy[i] = p
            lib.hc_rhs(buf["P"], ffi.from_buffer("double[]", yy), buf["m"], buf["u"], ffi.from_buffer("double[]", dy))
            return dy[j]
        a0, a1 = accel(y[i]), accel(y[i] + 1e5)
        if a1 != a0:                                   # (at an end stop pushed into it: held by the stop)
            y[i] = max(y[i] - a0 * 1e5 / (a1 - a0), PRESSURE_FLOOR)
            left.remove(i)
    return left


def _warn_indeterminate(c: Circuit, y, nodes: list[int]) -> None:
    """A node without a pressure at rest keeps its initial guess, which the user should know (and may give in
    [initial])."""
    import warnings
    from hydrohil.errors import InputWarning
    for i in nodes:
        warnings.warn(f"{c.source}: node {c.state_nodes[i]} has no open path at rest: its pressure is no rest "
                      f"value but its initial guess, {y[i] / 1e5:.4g} bar (give it in [initial])", InputWarning,
                      stacklevel=4)


def _logged(c: Circuit, lay, columns: list[str] | None, loop, warn: bool = False) -> list[str]:
    """The log columns a fixed-step run computes: every one (``columns`` None), else t, ``columns`` and what the
    run reads itself (a loop's measured signal, its transducers' pressures; ``warn``: what _warn_unbalanced reads
    of the first row), in the layout's order. InputError naming a column the circuit does not log."""
    if columns is None:
        return list(lay.log_columns)
    unknown = [name for name in columns if name not in lay.log_columns]
    if unknown:
        raise InputError(f"no column {unknown[0]!r} (columns: {', '.join(lay.log_columns)})", key="columns")
    want = {"t", *columns}
    if loop is not None:
        want |= {loop.measure, *(loop.pressures or ()), *(col for _, col in loop.supply_tank)}
    if warn:
        for comp in c.components.values():
            if comp.type.name in MOVING and not comp.coupled:
                rods = [c.components[a] for a in comp.actuators] or [comp]
                want |= {f"{comp.name}.mode", net_force_column(comp), *(f"{r.ports['a']}.p" for r in rods)}
    return [name for name in lay.log_columns if name in want]


def _warn_unbalanced(c: Circuit, res) -> None:
    """A piston started at rest whose chambers' pressures do not balance its load moves at once (SPEC §12.5: a
    closed loop holds it with its spool offset; [initial] pressures can too)."""
    import warnings
    from hydrohil.errors import InputWarning
    for comp in c.components.values():
        if comp.type.name in MOVING and not comp.coupled and res.columns[f"{comp.name}.mode"][0] == 0:
            f = res.columns[net_force_column(comp)][0]
            if comp.type.name == "lugre_cylinder" and -comp.values["fs_neg"] <= f <= comp.values["fs_pos"]:
                continue                       # its seals hold it (the bristles take the force at once)
            rods = [c.components[a] for a in comp.actuators] or [comp]
            scale = sum(abs(res.columns[f"{r.ports['a']}.p"][0]) * r.values["area_a"] for r in rods) + 1.0
            if abs(f) > 1e-6 * scale:
                warnings.warn(f"{c.source}: {comp.name} is not held at rest: the net force on it at the start is "
                              f"{f:.4g} N (its chambers' pressures at rest do not balance its load); it moves at "
                              "once (a scenario's closed loop on it, or rest = {hold = ..., by = ...}, starts it held)",
                              InputWarning, stacklevel=3)


@dataclass
class Loop:
    """A closed loop on a circuit: the core's law (``cfg``, a built-in [controller] table; run by
    :class:`hydrohil.control.BuiltinController` sampled at the run's step) reads the signal ``measure`` (a log
    column) at each step and sets the input ``command`` for the reference (SI units of the measured signal)."""
    cfg: object
    measure: str
    command: str
    reference: tuple                    # (times, values): held from each time, or linear between them
    controller: object = None           # the law at the run's step (set by simulate_circuit)
    linear: bool = False                # the reference interpolated linearly (else held)
    period: float | None = None         # the reference repeats: its value at t mod period [s] (None: it does not)
    limits: tuple = (-1.0, 1.0)         # the command's range: [u_min, u_max] within its parameter's range
    sensor: tuple | None = None         # (quantum, lo, hi, noise) of what the controller reads; None: the signal
    sign: float = 1.0                   # -1: reverse-acting (a larger command lowers the signal)
    seed: int = 0                       # of the sensor's noise (one normal sample per reading)
    sensor_faults: list = field(default_factory=list)   # (type, start, end, a, b, slot): circuits/faults.py
    encoder: bool = False               # its sensor counts (a position with a resolution: hc_sensed's encoder)
    h: float | None = None              # the step it is sampled at (its scenario's; start(h) sets it)
    network: list = field(default_factory=list)   # (type, start, end, value, slot): circuits/network.py
    link: tuple = (0, WATCHDOG_TIMEOUT, 0.0)   # ([hil] seed, watchdog_timeout [s], hold_kp: > 0 the safe state
    #                                            "hold"'s gain): its faults' streams, the watchdog
    sent: np.ndarray | None = None      # the last run's commands as the controller sent them (network faults)
    watchdog: np.ndarray | None = None  # ... and per step 1 where its command path's watchdog held the safe state
    # a state feedback's load pressure pL = p1 - area_ratio * p2 (the law's kpl, tpl): the log columns of its
    # cylinder's two chambers, A_b/A_a, and their transducers (full scale, resolution, noise [Pa]; full scale 0:
    # none); the supply's and the tank's pressures it reads too ((slot 2 or 3, log column)); the seed of the
    # transducers' noise (the rig's stream for the seed, [hil] seed in a converted paper scenario; None: a stream
    # of the sensor's seed apart from the sensor's own, PRESSURE_STREAM)
    pressures: tuple | None = None
    area_ratio: float = 0.0
    pressure_sensor: tuple = (0.0, 0.0, 0.0)
    supply_tank: tuple = ()
    pressure_seed: int | None = None
    pressure_faults: list = field(default_factory=list)   # (type, start, end, a, b, slot, transducer slot): faults.py
    base: object = None                 # a user's controller (cfg.type "python"): the folder its module is in
    # the status bits a user's controller reads (Measurement.status): a function (k, the log row of step k, 1 when
    # a transducer's reading was clipped, the command path or None) -> int; None: 0 (a paper scenario's: the
    # rig's bits, simulation/as_circuit.py)
    status: object = None
    source: str | None = None           # (the scenario, named by its errors)

    @property
    def python(self) -> bool:
        """A user's controller (``type = "python"``), called back each step, not the core's law."""
        return self.cfg.type == "python"

    def __post_init__(self):
        if self.sensor is not None and len(self.sensor) == 3:     # (quantum, lo, hi): a noiseless sensor
            self.sensor = (*self.sensor, 0.0)

    def update(self, ref: float, dref: float, sensed: float, p1: float = 0.0, p2: float = 0.0,
               t: float = 0.0, ps: float = math.nan, pt: float = math.nan, status: int = 0) -> float:
        """The law's command for the reference (and slope) and the signal as sensed, as the generated loop
        computes it (hc_run: the law on sign·ref, sign·dref, sign·signal; a state feedback's chamber pressures
        p1, p2 as read, :meth:`read_pressures`). A user's controller is called with a
        :class:`hydrohil.control.Measurement` at the plant's time ``t`` (x: the signal as sensed; p1, p2: the
        chambers of ``load_pressure`` as read, else 0; ps, pt: the supply's and the tank's nodes as read where
        the loop names them, else NaN; status: its bits, :attr:`status`), its command kept in the loop's limits;
        one that raises or returns no finite number stops the run (ControllerError naming the time)."""
        if self.python:
            u = call_controller(self.controller, Measurement(float(t), float(ref), float(dref), float(sensed),
                                                             float(p1), float(p2), float(ps), float(pt), int(status)))
            return min(max(u, self.limits[0]), self.limits[1])
        s = self.sign
        return self.controller.update(s * ref, s * dref, s * sensed, p1, p2)

    def command_callback(self, cc, ref, dref, h: float, path=None):
        """hc_run's ``command`` and ``command_ctx`` for a user's controller (NULLs for the core's law): the
        module's compiled callback (build.py: hc_py_command) and the handle of the function that gives step k's
        command from the signal as sensed and the chambers as read (:meth:`update`; its status bits
        :attr:`status`'s, of the step's row and the command ``path``); what it raises is kept in ``self.error``
        and NaN returned (hc_run stops, 3). Keep the pair alive while hc_run runs."""
        if not self.python:
            return cc.ffi.NULL, cc.ffi.NULL
        self.error = None

        def command(k, row, sensed, p1, p2, ps, pt, saturated):
            try:
                st = self.status(k, row, saturated, path) if self.status is not None else 0
                return self.update(ref[k], dref[k], sensed, p1, p2, t=k * h, ps=ps, pt=pt, status=st)
            except BaseException as exc:     # noqa: BLE001 - raised again once hc_run has stopped
                self.error = exc
                return math.nan
        return cc.lib.hc_py_command, cc.ffi.new_handle(command)

    def user_callable(self):
        """A user's controller's callable (its class or function), its module loaded once for the loop (the
        runs of a study or a frequency response each instantiate it, :meth:`start`)."""
        if getattr(self, "_callable", None) is None:
            cfg = self.cfg
            self._callable = load_callable(cfg.callable, Path(cfg.path) if cfg.path else self.base, self.source)
        return self._callable

    @property
    def pressure_noise(self) -> bool:
        """Its pressure transducers draw noise (from a stream of their own, :meth:`streams`)."""
        return self.pressures is not None and self.pressure_sensor[2] > 0

    def pressure_args(self, cc, h: float | None = None):
        """hc_run's ``press`` (NULL: no pressure read): the generated C's hc_pressures_read table [n, full scale,
        resolution, noise, the place of its stream in :meth:`streams`, the step h, the number of faults, then
        (slot, log column) of each transducer, then each fault's row (type, its steps, a, b, start, slot, the place
        of its stream, a fresh memory)], made anew for each run (a stuck transducer not yet stuck); its faults'
        steps at step ``h`` (default: the step of :meth:`start`)."""
        if self.pressures is None:
            return cc.ffi.NULL
        from hydrohil.circuits.faults import SENSOR_FAULTS
        from hydrohil.circuits.network import fault_steps
        h = self.h if h is None else h
        reads = ((0, self.pressures[0]), (1, self.pressures[1]), *self.supply_tank)
        cols, nf = cc.layout.log_columns, len(self.sensor_faults)
        table = [float(len(reads)), *map(float, self.pressure_sensor), float(1 + nf), float(h or 0.0),
                 float(len(self.pressure_faults))]
        for slot, col in reads:
            table += [float(slot), float(cols.index(col))]
        for i, (kind, start, end, a, b, _, slot) in enumerate(self.pressure_faults):
            if h is None:
                raise ValueError("the loop's pressure faults need the step they act at (Loop.start(h), or h)")
            k0, k1 = fault_steps(start, end, h)
            table += [float(SENSOR_FAULTS.index(kind) + 1), float(k0), float(k1), float(a), float(b), float(start),
                      float(slot), float(2 + nf + i), math.nan]
        return cc.ffi.new(f"double[{len(table)}]", table)

    def read_pressures(self, cc, row: np.ndarray, rng=None, k: int = 0, press=None) -> tuple[float, float, float,
                                                                                              float]:
        """(p1, p2, ps, pt) as the loop reads them from the log row ``row`` of step ``k`` (the generated C's
        hc_pressures_read, hc_run's rule; its noise from ``rng``, :meth:`sensor_args`' generators; ``press``: the
        run's :meth:`pressure_args`, whose memory its faults keep from step to step, default a fresh one): (0, 0,
        NaN, NaN) when it reads no pressure, NaN for the supply or the tank it does not read; ``self.saturated``: 1
        when a reading was clipped to its range."""
        self.saturated = 0
        if self.pressures is None:
            return 0.0, 0.0, math.nan, math.nan
        out = cc.ffi.new("double[4]")
        self.saturated = cc.lib.hc_pressures_read(cc.ffi.from_buffer("double[]", np.ascontiguousarray(row, dtype=float)),
                                                  self.pressure_args(cc) if press is None else press,
                                                  cc.ffi.NULL if rng is None else rng, int(k), out)
        return tuple(out)

    def start(self, h: float) -> None:
        """A fresh controller sampled at h (no integrator or filter state from another run) and its sensor's
        noise generator from its seed."""
        if self.python:                                 # (a class instantiated afresh: no state from another run)
            self.controller = user_controller(self.user_callable(), self.cfg, self.source)
        else:
            self.controller = BuiltinController(self.cfg, None, h, limits=self.limits,   # (the law's clamp: its range)
                                                area_ratio=self.area_ratio)
        self.rng = self.streams()
        self.h = h

    def streams(self):
        """Its noise generators (hc_sensed's and hc_pressures_read's rng): [0] its sensor's, seeded by its seed;
        [1 + i] its sensor's i-th fault's, seeded by [hil] seed and the fault's place in the scenario's
        [[faults]] (the paper's rig's streams, core/link.c); then its pressure transducers', seeded by their
        seed (the rig's noise stream, rig.c, for the same seed), else the sensor's seed's stream PRESSURE_STREAM
        (not the sensor's own draws); then its transducers' faults', as its sensor's."""
        from hydrohil.core import ffi as core_ffi, lib as core
        nf = len(self.sensor_faults)
        rng = core_ffi.new(f"hh_rng[{2 + nf + len(self.pressure_faults)}]")
        core.hh_rng_seed(rng, int(self.seed))
        for i, (*_, slot) in enumerate(self.sensor_faults):
            core.hh_rng_stream(rng + 1 + i, int(self.link[0]), int(slot))
        if self.pressure_seed is None:
            core.hh_rng_stream(rng + 1 + nf, int(self.seed), PRESSURE_STREAM)
        else:
            core.hh_rng_seed(rng + 1 + nf, int(self.pressure_seed))
        for i, (*_, slot, _) in enumerate(self.pressure_faults):
            core.hh_rng_stream(rng + 2 + nf + i, int(self.link[0]), int(slot))
        return rng

    def sensor_vector(self, h: float) -> list[float]:
        """The sensor as the generated C's hc_sensed reads it: its transducer (quantum, range, noise), an encoder
        or not, then its faults with their steps at step h (a fresh memory: a stuck sensor not yet stuck)."""
        from hydrohil.circuits.faults import SENSOR_FAULTS
        from hydrohil.circuits.network import fault_steps
        out = [*self.sensor, float(len(self.sensor_faults)), float(h), float(self.encoder)]
        for kind, start, end, a, b, _ in self.sensor_faults:
            k0, k1 = fault_steps(start, end, h)
            out += [float(SENSOR_FAULTS.index(kind) + 1), float(k0), float(k1), float(a), float(b),
                    math.nan if kind in ("sensor_stuck", "encoder_count_loss") else float(start)]
        return out

    def sensor_args(self, cc, rng=None, h: float | None = None):
        """(sensor, rng) as the generated C's hc_sensed / hc_run take them (NULL: an ideal reading), a fresh
        sensor (its faults' memory new, their steps at step ``h``, default the step of :meth:`start`); ``rng``:
        generators of :meth:`streams` in place of this loop's own."""
        ffi = cc.ffi
        from hydrohil.core import ffi as core_ffi
        if self.sensor is None and not self.pressure_noise and not self.pressure_faults:
            return ffi.NULL, ffi.NULL
        streams = ffi.cast("void *", int(core_ffi.cast("uintptr_t", self.rng if rng is None else rng)))
        if self.sensor is None:            # (the generators still, for noisy pressure transducers or their faults)
            return ffi.NULL, streams
        if h is None and self.h is None:
            raise ValueError("the loop's sensor needs the step it is read at (Loop.start(h), or h)")
        vec = self.sensor_vector(self.h if h is None else h)
        buf = ffi.new(f"double[{len(vec)}]", vec)
        self._sensor_buf = buf                           # (alive while the C reads it)
        return buf, streams

    def command_path(self, h: float, stride: int = 1):
        """The command path of its network faults at step h for packets of ``stride`` values (None: none, the
        commands reach the plant as sent; its watchdog's safe state the [hil]'s: "hold" with hold_kp > 0)."""
        from hydrohil.circuits.network import CommandPath
        if not self.network:
            return None
        seed, timeout, hold_kp = self.link
        return CommandPath(self.network, h, seed=seed, timeout=timeout, stride=stride, hold_kp=hold_kp)

    def at(self, t: np.ndarray, h: float) -> np.ndarray:
        """The reference at the step times ``t`` of step ``h`` (the circuit's drive rule, Drive.at; a repeating
        one at t mod its period, the paper rig's rule)."""
        return self._drive_at(self._in_period(t), h)

    def _in_period(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.fmod(t, self.period) if self.period else t

    def _drive_at(self, t: np.ndarray, h: float) -> np.ndarray:
        return Drive(*self.reference, self.linear).at(t, h)

    def table(self, n: int, h: float) -> tuple[np.ndarray, np.ndarray]:
        """The reference and its slope at each step (a held reference has none): :meth:`reference_at` of the
        n + 1 step times; a run of up to TABLE_CACHED steps made once per reference and grid in a process (a
        study's runs share them; copies), a longer one (a long HIL session) each time."""
        if n > TABLE_CACHED:
            return self.reference_at(np.arange(n + 1) * h, h)
        ts, vs = (np.asarray(a) for a in self.reference)
        r, dr = _reference_table(ts.tobytes(), str(ts.dtype), vs.tobytes(), str(vs.dtype), self.linear,
                                 self.period, n, h)
        return r.copy(), dr.copy()

    def reference_at(self, t: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """The reference and its slope at the step times ``t`` of step ``h`` (a held reference has none)."""
        t = self._in_period(t)
        r = np.ascontiguousarray(self._drive_at(t, h), dtype=float)
        if not self.linear:
            return r, np.zeros_like(r)
        ts, vs = self.reference
        seg = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, max(len(ts) - 2, 0))
        dt = np.diff(ts)
        slope = np.where(dt > 0, np.diff(vs) / np.where(dt > 0, dt, 1.0), 0.0) if len(ts) > 1 else np.zeros(1)
        dr = np.where(t < ts[-1], slope[seg], 0.0) if len(ts) > 1 else np.zeros_like(t)
        return r, np.ascontiguousarray(dr, dtype=float)


TABLE_CACHED = 400_000       # steps: Loop.table's tables kept up to this (8 at most: 51 MB), a 200 s run at 0.5 ms


@functools.lru_cache(maxsize=8)
def _reference_table(ts: bytes, ts_type: str, vs: bytes, vs_type: str, linear: bool, period: float | None, n: int,
                     h: float) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Loop.table` of the reference (the times ``ts``, the values ``vs``: their arrays' bytes and dtypes)."""
    ref = (np.frombuffer(ts, dtype=ts_type), np.frombuffer(vs, dtype=vs_type))
    return Loop(None, "", "", ref, linear=linear, period=period).reference_at(np.arange(n + 1) * h, h)


@dataclass
class Commands:
    """An open loop's commanded inputs (a scenario's ``commands``): the controller process sends their drives,
    a value per step, as a loop's controller sends its command (the paper's rig's open loop: its command table
    over the link), so the scenario's network faults and the watchdog act on them on the way (the command path,
    :mod:`hydrohil.circuits.network`): a lost packet leaves an input on the last value that arrived, a silence
    beyond ``watchdog_timeout`` puts them at 0 (the end of their range nearest to it), a command_inversion
    negates them. Before the first packet an input has its value at the start."""
    inputs: tuple                       # their names, in the circuit's input order
    network: list = field(default_factory=list)   # (type, start, end, value, slot): circuits/network.py
    link: tuple = (0, WATCHDOG_TIMEOUT, 0.0)      # ([hil] seed, watchdog_timeout, 0: the safe state "centre")

    def mask(self, c: Circuit) -> int:
        """Their bits in an INPUTS packet's mask."""
        return sum(1 << list(c.inputs).index(name) for name in self.inputs)

    def apply(self, c: Circuit, u: np.ndarray, h: float, start: np.ndarray) -> np.ndarray:
        """The table ``u`` (a row per step, the drives as sent) with these inputs as the plant applies them
        through the command path at step ``h`` (their values before the first packet: ``start``'s), in place, for
        the steps before the last row (the last row's: its drive, as a loop's last row has the law's command);
        returns what was sent (their columns of ``u`` before) and per step 1 where the watchdog held the safe
        state."""
        from hydrohil.circuits.network import CommandPath
        idx = [list(c.inputs).index(name) for name in self.inputs]
        sent = u[:, idx].copy()
        dog = np.zeros(len(u))
        if not self.network:                 # (nothing on the way: every packet arrives, the watchdog silent)
            return sent, dog
        seed, timeout, _ = self.link
        path = CommandPath(self.network, h, seed=seed, timeout=timeout, stride=1 + len(c.inputs))
        ranges = [c.input_param(name) for name in self.inputs]
        held = [float(start[j]) for j in idx]
        mask, packet = float(self.mask(c)), path.packet
        for k in range(len(u) - 1):
            packet[0] = mask
            for i, j in enumerate(idx):
                packet[1 + j] = sent[k, i]
            if path.step(k, True):
                held = [packet[1 + j] for j in idx]
            dog[k] = float(path.link.active)
            for i, j in enumerate(idx):
                u[k, j] = path.apply(held[i], ranges[i].lo, ranges[i].hi)
        dog[-1] = dog[-2] if len(dog) > 1 else 0.0       # (the last row: no step; the step before's)
        return sent, dog


def simulate_circuit(c: Circuit, duration: float, *, h: float = 5e-4, method: str = "rk3", every: int = 1,
                     inputs: dict | None = None, rest: bool | Hold | Start = True, progress=None,
                     loop: Loop | None = None, warn_unheld: bool = True, start: tuple | None = None,
                     commands: Commands | None = None, compiled=None,
                     columns: list[str] | None = None) -> CircuitResult:
    """Run ``c`` for ``duration`` seconds at step ``h``; a log row every ``every`` steps. It starts at rest
    (``rest``, :func:`settle`: the node pressures settled with the components' states held; a node given in the
    circuit's ``[initial]`` keeps its value; a :class:`Hold`: with a piston held by an input's value; a
    :class:`Start`: from an input's value before t = 0 and node pressures of a scenario's [start]). ``method``
    "reference": the continuous reference generated from
    the same description (:mod:`hydrohil.circuits.reference`), from the same state at rest (settled by RK3 at
    ``h``), its log on the same grid. ``progress(step)`` is called now and then (a fixed-step run: before every
    4096th step); what it raises (a Ctrl-C) stops the run and is raised. Raises SimulationDiverged with
    the time, the modes and the state when a state leaves its physical range or the finite (the fixed-step
    solvers: checked after every step, hc_unphysical, the rows logged before the stop its ``partial`` result;
    the reference: where it leaves the finite or its solvers fail).
    ``loop``: closed loop (:class:`Loop`); the log gets the controller's reference as a column. ``warn_unheld``:
    warn when a piston started at rest is not held there (InputWarning: it moves at once). ``start``: (y, m, u0)
    in place of the start at rest: the state (hc_state_size values: the layout's states, then the delay lines'
    memory), the modes and the inputs of step 0 (a loop's command: the one held until the controller's first
    arrives), e.g. :func:`hydrohil.circuits.paper.paper_start`. ``commands``: an open loop's inputs sent over
    the link (:class:`Commands`: the scenario's network faults act on them; their sent values as columns
    ``<input>.sent``). ``compiled``: ``compile_circuit(c)`` when the caller has it (a scenario's ``compiled``).
    ``columns``: the log columns a caller reads (a fixed-step run computes only those, with t, a loop's measured
    signal and the pressures its transducers read; ``events``, the inputs and the loop's reference besides; the
    delayed inputs as the components see them, ``<input>.seen``, when one is named; not what its sensor and
    transducers read, ``.sensed``; None: every column; the reference computes every column)."""
    if method not in SOLVERS:
        raise InputError(f"one of {', '.join(SOLVERS)}, got {method!r}", key="method")
    if not (h > 0 and duration >= 0 and every >= 1):
        raise InputError(f"need h > 0, duration >= 0, every >= 1 (got {h}, {duration}, {every})")
    cc = compile_circuit(c) if compiled is None else compiled
    lay = cc.layout
    n = int(round(duration / h))
    u = np.ascontiguousarray(input_table(c, n + 1, h, inputs))    # (the last: the last row's, at t_n)
    P = np.ascontiguousarray(lay.values())
    ffi, lib = cc.ffi, cc.lib
    if loop is not None:
        _check_loop(c, lay, loop)
        loop.start(h)
    if start is None:
        y, m, u0 = _start(c, cc, P, u, h, "rk3" if method == "reference" else method, rest, loop)
    else:
        y, m, u0 = (np.array(start[0], dtype=float), np.array(start[1], dtype=np.int64),
                    np.array(start[2], dtype=float))
        sizes = (lib.hc_state_size(ffi.from_buffer("double[]", P), float(h)), max(len(lay.modes), 1),
                 max(len(lay.inputs), 1))
        if (len(y), len(m), len(u0)) != sizes:
            raise InputError(f"a start state of circuit {c.name!r} at step {h} is (y, m, u0) of {sizes[0]}, "
                             f"{sizes[1]} and {sizes[2]} values", key="start")
    if loop is not None:                  # what the valve was held at: the command the controller's first
        u[0, lay.inputs.index(loop.command)] = u0[lay.inputs.index(loop.command)]   # measurement is made with
    sent, dog = (commands.apply(c, u, h, u0) if commands is not None and loop is None and commands.network
                 else (None, None))
    warn = bool(rest and warn_unheld and start is None and not (isinstance(rest, Start) and (
        rest.pressures or rest.inputs)))           # (a start of the user's own: not the rest's to balance)
    seen_cols = [f"{name}.seen" for name in lay.delayed]   # (the step's: asked for by name, or every one)
    with_seen = columns is None or bool(set(columns) & set(seen_cols))
    names = _logged(c, lay, None if columns is None else [x for x in columns if x not in seen_cols], loop, warn)
    if method == "reference":
        res = _reference_run(c, cc, P, y, m, u, h, n, every, progress, loop)
        return _with_drives(c, cc, res, u, every, loop, commands, sent, dog)
    cols = np.array([lay.log_columns.index(name) for name in names], dtype=np.int64)
    log = np.empty((n // every + 1, len(names)))    # (hc_run writes every column of each row it reports: no
    seen = np.zeros((len(log), max(len(lay.delayed), 1))) if with_seen else None   # zeroing, a few per cent of a
    events = np.empty(len(log))                      # study's run)
    rows, steps = ffi.new("int64_t *"), ffi.new("int64_t *")
    ctl = (_loop_args(cc, lay, loop, n, h, input_range(c, loop.command)) if loop is not None else
           (ffi.NULL, ffi.NULL, ffi.NULL, ffi.NULL, 0, 0, ffi.NULL, ffi.NULL, 1.0, ffi.NULL, 0.0, 0.0, ffi.NULL,
            ffi.NULL, ffi.NULL, ffi.NULL))
    stop: list = []                       # (what the progress callback raised: a Ctrl-C, raised once stopped)

    def tick(k):
        try:
            progress(k)
            return 0
        except BaseException as exc:      # noqa: BLE001 - raised again once hc_run has stopped
            stop.append(exc)
            return 1
    reference = loop._keep[0] if loop is not None else None     # (the reference at each step, as hc_run read it)
    handle = ffi.new_handle(tick) if progress is not None else None
    callback_raised()                     # (nothing kept from another run)
    t0 = time.perf_counter()
    status = lib.hc_run(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", y),
                        ffi.from_buffer("int64_t[]", m), METHODS.index(method), float(h), n, int(every),
                        ffi.from_buffer("double[]", u), ffi.from_buffer("double[]", log), rows, *ctl,
                        ffi.from_buffer("double[]", seen) if seen is not None else ffi.NULL,
                        ffi.from_buffer("double[]", events),
                        ffi.from_buffer("double[]", loop.watchdog) if loop is not None and loop.watchdog is not None
                        else ffi.NULL, steps, lib.hc_py_progress if handle is not None else ffi.NULL,
                        handle if handle is not None else ffi.NULL,
                        ffi.from_buffer("int64_t[]", cols) if columns is not None else ffi.NULL, len(cols))
    wall = time.perf_counter() - t0
    log = log[:rows[0]]
    res = CircuitResult({name: log[:, i] for i, name in enumerate(names)}, {}, lay.mode_names, h, method,
                        wall, states=lay.states[len(c.state_nodes):])
    around = callback_raised()            # (raised outside a callback's callable: a Ctrl-C on the way in)
    if status == 3:                       # (a user's controller failed: its error, with the time)
        raise loop.error or around or HydrohilError("a user's controller gave no command")
    if status == 5:                       # (stopped by the progress callback: what it raised)
        raise (stop or [around])[0] or HydrohilError("the run was stopped")
    if status == 2:                       # (a state sized for another step: not from simulate_circuit)
        raise HydrohilError(f"circuit {c.name!r}: the step {h} s is not the one its state's delay lines were sized "
                            "for (hc_init)")
    res.units = signal_units(c, lay)
    _step_columns(c, res, lay, seen[:rows[0]] if seen is not None else None, events[:rows[0]])
    if status != 0:                       # (the end of the failed step; the rows logged before it: ``partial``)
        modes = {name: lay.mode_names[name][int(m[i])] for i, name in enumerate(lay.modes)}
        raise SimulationDiverged(int(steps[0]) * h, modes, {s: float(y[i]) for i, s in enumerate(lay.states)},
                                 divergence_reason(cc, P, y, status),
                                 partial=_with_drives(c, cc, res, u, every, loop, commands, sent, dog,
                                                      sensed=columns is None, reference=reference))
    if warn and len(log):
        _warn_unbalanced(c, res)
    return _with_drives(c, cc, res, u, every, loop, commands, sent, dog, sensed=columns is None,
                        reference=reference)


class Hold(NamedTuple):
    """An open loop's start with a piston held (a scenario's ``rest = {hold, by}``): the piston ``measure``
    (``<component>.x``) held at rest by the value of input ``command`` that holds it, found as a closed loop's
    start is (:func:`_held_by_loop`); the drives take over from step 0, a delayed input seeing the holding value
    until its delay has passed (the paper's rig's open-loop start, SPEC §12.5)."""
    measure: str
    command: str


class Start(NamedTuple):
    """A scenario's ``[start]``: the state a run starts from in place of the rest's alone (the paper's rig's
    ``initial.xs``, ``initial.p1``/``p2``). ``inputs``: an input's value before t = 0 (input -> value in its SI
    unit): the circuit comes to rest under it (a spool at that position, the nodes settled to its flows), a
    delayed input sees it until its delay has passed, the drives act from step 0 (a closed loop's command: the
    value it holds until the controller's first command, in place of the one that holds its piston, and the
    circuit at rest under it). ``pressures`` (node -> Pa):
    set on the state at rest, the other nodes keeping their rest values, the components' states at rest then
    taking the new pressures (a LuGre seal's bristles the new net force). ``rest``: the rest it starts from
    (True, False: the file's state, the pressures set on it and nothing else, or a :class:`Hold`)."""
    rest: bool | Hold
    inputs: dict
    pressures: dict

    def __bool__(self) -> bool:
        return bool(self.rest)


def start_state(c: Circuit, *, h: float = 5e-4, method: str = "rk3", inputs: dict | None = None,
                rest: bool | Hold | Start = True,
                loop: Loop | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The state a run of ``c`` starts from (states y, modes m) and the inputs of its step 0 (a closed loop's
    command, or a Hold's: the one that holds its piston): what :func:`simulate_circuit` starts from, and an
    exported plant's initial state."""
    cc = compile_circuit(c)
    u = np.ascontiguousarray(input_table(c, 1, h, inputs))
    if loop is not None:
        _check_loop(c, cc.layout, loop)
    return _start(c, cc, np.ascontiguousarray(cc.layout.values()), u, h, method, rest, loop)


def new_state(cc, P, h: float) -> np.ndarray:
    """A zero state for steps of h: the circuit's states (one at least) and its delay lines' memory after them
    (hc_state_size; hc_init sizes and fills the lines for the same h)."""
    return np.zeros(max(int(cc.lib.hc_state_size(cc.ffi.from_buffer("double[]", P), float(h))), 1))


def _start(c: Circuit, cc, P, u, h: float, method: str, rest: bool | Hold | Start, loop: Loop | None):
    ffi, lib, lay = cc.ffi, cc.lib, cc.layout
    if isinstance(rest, Start):
        uu = u.copy()
        for name, value in rest.inputs.items():
            uu[0, lay.inputs.index(name)] = value
        held = loop is not None and loop.command in rest.inputs     # (the loop's command given: not the hold's)
        y, m, u0 = _start(c, cc, P, uu, h, method, rest.rest, None if held else loop)
        for node, value in rest.pressures.items():
            y[c.state_nodes.index(node)] = value
        if rest.pressures and rest.rest:          # (the components' states at rest take them; rest = false: as is)
            lib.hc_hold(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", u0), ffi.from_buffer("double[]", y),
                        ffi.from_buffer("int64_t[]", m))
        return y, m, u0
    if rest and loop is not None:
        return _held_by_loop(c, cc, P, u, h, method, loop.measure, loop.command)
    if isinstance(rest, Hold):
        return _held_by_loop(c, cc, P, u, h, method, rest.measure, rest.command)
    y = new_state(cc, P, h)
    m = np.zeros(max(len(lay.modes), 1), dtype=np.int64)
    lib.hc_init(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", u), float(h),
                ffi.from_buffer("double[]", y), ffi.from_buffer("int64_t[]", m))
    if rest:
        settle(c, cc, P, u, y, m, h, method)
    return y, m, u[0].copy()


def _held_by_loop(c: Circuit, cc, P, u, h: float, method: str, measure: str, command: str):
    """The state at rest of a closed loop (SPEC §12.5): the command that holds the piston the loop measures
    (the net force on it zero, its chambers at their rest pressures; what `hydrohil linear` computes for the
    paper's rig), found by root finding over the command's range, its valve there and the nodes settled; the
    controller then starts from its own first command. Without a piston measured, or no command in range
    holding it: the state at rest under the step-0 command (settle), as in open loop."""
    import warnings
    from scipy.optimize import brentq
    ffi, lib, lay = cc.ffi, cc.lib, cc.layout
    comp = c.components.get(measure.rsplit(".", 1)[0])
    j = lay.inputs.index(command)

    def state(u0):
        uu = u.copy()
        uu[0, j] = u0
        y = new_state(cc, P, h)
        m = np.zeros(max(len(lay.modes), 1), dtype=np.int64)
        lib.hc_init(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", uu), float(h),
                    ffi.from_buffer("double[]", y), ffi.from_buffer("int64_t[]", m))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            settle(c, cc, P, uu, y, m, h, method)
        return y, m, uu

    def force(u0):
        y, m, uu = state(u0)
        row = np.zeros(len(lay.log_columns))
        lib.hc_reference_row(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", y),
                             ffi.from_buffer("double[]", uu[0]), 0.0, ffi.from_buffer("double[]", row))
        return row[lay.log_columns.index(net_force_column(comp))]
    if comp is not None and comp.coupled:                   # a coupled rod's position is its load's
        comp = c.components[comp.coupled]
    if comp is not None and comp.type.name in MOVING and measure.endswith(".x"):
        prm = c.input_param(command)
        lo, hi = max(prm.lo, -1.0), min(prm.hi, 1.0)
        try:
            f_lo, f_hi = force(lo), force(hi)
            if f_lo * f_hi < 0:
                u0 = brentq(force, lo, hi, xtol=1e-12, rtol=1e-12, maxiter=100)
                y, m, uu = state(u0)
                return y, m, uu[0].copy()
        except InputError:
            pass
    return _start(c, cc, P, u, h, method, True, None)


def _check_loop(c: Circuit, lay, loop: Loop) -> None:
    if loop.measure not in lay.log_columns or loop.measure == "t":
        raise InputError(f"not a signal of circuit {c.name!r}: {loop.measure!r} (signals: "
                         f"{', '.join(x for x in lay.log_columns if x != 't')})", key="controller.measure")
    if loop.command not in c.inputs:
        raise InputError(f"not an input of circuit {c.name!r}: {loop.command!r} (inputs: "
                         f"{', '.join(c.inputs) or 'none: give a signal in the circuit [inputs]'})",
                         key="controller.command")


def _loop_args(cc, lay, loop: Loop, n: int, h: float, limits: tuple[float, float]):
    """hc_run's closed-loop arguments: the core's controller and its state (the core module's structs, passed
    by address: the same header, the same compiler), the reference and its slope per step, the indices, the
    command path of its network faults (the command saturated to ``limits``, its input's range)."""
    from hydrohil.core import ffi as core_ffi
    ffi = cc.ffi
    ref, dref = loop.table(n, h)
    addr = lambda p: ffi.cast("void *", int(core_ffi.cast("uintptr_t", p)))  # noqa: E731
    sensor, rng = loop.sensor_args(cc)
    path = loop.command_path(h)                                  # (its network faults: circuits/network.py)
    loop.sent = np.zeros(n + 1) if path is not None else None    # what the controller sent (the path's input)
    loop.watchdog = np.zeros(n + 1) if path is not None else None
    press = loop.pressure_args(cc, h)                           # (a state feedback's load pressure)
    command = loop.command_callback(cc, ref, dref, h, path)      # (a user's controller, called back)
    loop._keep = (ref, dref, sensor, path, press, command)       # alive while hc_run reads them
    law = (ffi.NULL, ffi.NULL) if loop.python else (addr(loop.controller.c), addr(loop.controller.state))
    return (*law, ffi.from_buffer("double[]", ref),
            ffi.from_buffer("double[]", dref), lay.log_columns.index(loop.measure), cc.layout.inputs.index(loop.command),
            sensor, rng, float(loop.sign), addr(path.c) if path is not None else ffi.NULL, *limits,
            ffi.from_buffer("double[]", loop.sent) if path is not None else ffi.NULL, press, *command)


def _with_drives(c: Circuit, cc, res: CircuitResult, u: np.ndarray, every: int, loop: Loop | None,
                 commands: Commands | None = None, sent: np.ndarray | None = None,
                 dog: np.ndarray | None = None, sensed: bool = True,
                 reference: np.ndarray | None = None) -> CircuitResult:
    """The run's inputs as columns (``valve.command``: what drove each step; closed loop: what the controller
    sent; an open loop's commands through network faults: what was sent, ``<input>.sent``) and the loop's
    reference (``<measure>.reference``: ``reference``, the loop's at each step of a fixed-step run (Loop.table,
    what hc_run read), at the logged steps; else Loop.at of the log's times, the same values: the log's t is
    step * h); ``sensed``: what its sensor and transducers read too (``.sensed``)."""
    rows = len(res.columns["t"])

    def at_rows(a: np.ndarray) -> np.ndarray:     # (a per-step array at each row's step, its last beyond its end;
        if every == 1 and rows <= len(a):          # a copy: a slice of it when every step is a row)
            return a[:rows].copy()
        return a[np.minimum(np.arange(rows) * every, len(a) - 1)]
    for j, sig in enumerate(c.inputs):
        res.columns[sig] = at_rows(u[:, j])
        res.units[sig] = input_unit(c, sig)
    for i, sig in enumerate(commands.inputs if sent is not None else ()):
        res.columns[f"{sig}.sent"] = at_rows(sent[:, i])
        res.units[f"{sig}.sent"] = input_unit(c, sig)
    if loop is not None and loop.sent is not None and len(loop.sent):   # (network faults: what was sent)
        res.columns[f"{loop.command}.sent"] = at_rows(loop.sent)
        res.units[f"{loop.command}.sent"] = input_unit(c, loop.command)
        dog = loop.watchdog
    if dog is not None and len(dog):      # (a command path: 1 where its watchdog held the safe state)
        res.columns["watchdog"], res.units["watchdog"] = at_rows(dog), "-"
        res.watchdog = dog
    if loop is not None:
        res.columns[f"{loop.measure}.reference"] = (loop.at(res.columns["t"], res.h) if reference is None else
                                                    at_rows(reference))
        res.units[f"{loop.measure}.reference"] = res.units.get(loop.measure, "-")
        if loop.sensor is not None and sensed:   # what the controller read (through the sensor: the C's hc_sensed)
            res.columns[f"{loop.measure}.sensed"] = sensed_column(cc, loop, res.columns[loop.measure], every)
            res.units[f"{loop.measure}.sensed"] = res.units.get(loop.measure, "-")
        for name, column in pressures_sensed(cc, loop, res, every).items() if sensed else ():   # (its transducers')
            res.columns[name], res.units[name] = column, "Pa"
    return res


def sensed_column(cc, loop: Loop, x: np.ndarray, every: int = 1) -> np.ndarray:
    """What the loop's sensor read of the signal ``x`` logged every ``every`` steps: the readings the controller
    got, its noise drawn again from the seed, one sample per step in order (the samples of the steps between
    rows drawn and left)."""
    generator = loop.streams()
    sensor, rng = loop.sensor_args(cc, generator)
    x = np.ascontiguousarray(x, dtype=float)
    out = np.empty(len(x))
    cc.lib.hc_sensed_rows(cc.ffi.from_buffer("double[]", x), len(x), every, sensor, rng,
                          cc.ffi.from_buffer("double[]", out))
    return out


def divergence_reason(cc, P: np.ndarray, y: np.ndarray, status: int) -> str:
    """Why a run of ``cc`` stopped at state ``y`` with hc_run's or hc_step's ``status``: 4, the state outside its
    physical range (hc_unphysical, the components' declared bounds: "cyl.x = 0.5 outside its physical range
    [-0.18, 0.36]"); another, a state not finite."""
    if status != 4:
        return "a state is not finite"
    ffi = cc.ffi
    P = np.ascontiguousarray(P, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    bad = int(cc.lib.hc_unphysical(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", y)))
    if bad <= 0:
        return "a state is not finite"
    lo, hi = state_bounds(cc, P)
    i = bad - 1
    return f"{cc.layout.states[i]} = {y[i]:.6g} outside its physical range [{lo[i]:.6g}, {hi[i]:.6g}]"


def state_bounds(cc, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): each state's physical range under parameters ``P`` (hc_state_bounds, the components' declared
    bounds; ±inf: none), in the layout's state order."""
    ffi, n = cc.ffi, len(cc.layout.states)
    P = np.ascontiguousarray(P, dtype=float)
    lo, hi = np.empty(n), np.empty(n)
    cc.lib.hc_state_bounds(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", lo),
                           ffi.from_buffer("double[]", hi))
    return lo, hi


def pressures_sensed(cc, loop: Loop, res: CircuitResult, every: int = 1) -> dict[str, np.ndarray]:
    """What the loop's pressure transducers read of the run ``res`` logged every ``every`` steps (a state
    feedback's chambers, a user's controller's supply and tank: hc_pressures_read, its noise drawn again from
    the seed, its faults acting): ``<node>.p.sensed`` per node read; none when the loop reads no pressure."""
    if loop.pressures is None:
        return {}
    lay = cc.layout
    reads = [*loop.pressures, *(col for _, col in loop.supply_tank)]
    rows = np.zeros((len(res.columns["t"]), len(lay.log_columns)))   # (the rows as hc_pressures_read reads them:
    for col in reads:                                                 # the columns it reads filled in)
        rows[:, lay.log_columns.index(col)] = res.columns[col]
    out = np.empty((len(rows), 4))
    generator = loop.streams()                     # (alive while the C draws from it)
    _, rng = loop.sensor_args(cc, generator)
    ffi = cc.ffi
    cc.lib.hc_pressures_rows(ffi.from_buffer("double[]", rows), len(rows), every, loop.pressure_args(cc), rng,
                             ffi.from_buffer("double[]", out))
    slots = [0, 1, *(slot for slot, _ in loop.supply_tank)]
    return {f"{col}.sensed": out[:, slot].copy() for slot, col in zip(slots, reads)}


def input_range(c: Circuit, sig: str) -> tuple[float, float]:
    """An input's range [lo, hi] (its parameter's): what a command to it is saturated to; in the watchdog's safe
    state 0 in it, or the end nearest to 0 (a valve centred, an orifice closed, a pump stopped)."""
    p = c.input_param(sig)
    return float(p.lo), float(p.hi)


def input_unit(c: Circuit, sig: str) -> str:
    """The SI unit of an input signal (a parameter a circuit drives)."""
    return c.input_param(sig).unit


def signal_units(c: Circuit, lay) -> dict[str, str]:
    """The SI unit of every log column of a circuit (its signals)."""
    return {"t": "s", **{f"{nd}.p": "Pa" for nd in c.nodes}, **dict(lay.outputs), **{md: "-" for md in lay.modes}}


def _reference_run(c: Circuit, cc, P, y, m, u, h: float, n: int, every: int, progress,
                   loop: Loop | None) -> CircuitResult:
    from hydrohil.circuits.reference import solve_circuit_reference
    from hydrohil.core.stiff import ReferenceSolverFailed
    lay = cc.layout
    stats: dict = {}
    control = None
    seen = _delay_line(cc, P, y, h)            # the inputs as the components see them (delayed ones late)
    u_seen = u if seen is None else u.copy()
    if loop is None and seen is not None:
        for k in range(len(u)):                # (the last row's: what its line would give it, as hc_run's)
            u_seen[k] = seen(u[k])
    elif loop is not None:                     # the same sampled law at each step, on the reference's state
        ref, dref = loop.table(n, h)
        meas, cmd = lay.log_columns.index(loop.measure), lay.inputs.index(loop.command)

        sensor, rng = loop.sensor_args(cc)
        press = loop.pressure_args(cc, h)      # (its transducers, their faults' memory: this run's)
        path = loop.command_path(h)            # (its network faults: hc_run's rule, the same C)
        loop.sent = np.zeros(n + 1) if path is not None else None
        loop.watchdog = np.zeros(n + 1) if path is not None else None
        (lo, hi), held = input_range(c, loop.command), [u[0, cmd]]

        def control(k, row):                   # (k = n: the last row's command, the law's, not sent)
            sensed = cc.lib.hc_sensed(row[meas], sensor, rng, k)
            p1, p2, ps, pt = loop.read_pressures(cc, row, rng, k, press)
            st = loop.status(k, row, loop.saturated, path) if loop.status is not None else 0
            u[k, cmd] = loop.update(ref[k], dref[k], sensed, p1, p2, t=k * h, ps=ps, pt=pt, status=st)
            if path is not None:
                loop.sent[k] = u[k, cmd]
            if path is not None and k < n:
                path.packet[0] = u[k, cmd]
                if path.step(k, True, row[meas]):
                    held[0] = path.packet[0]
                u[k, cmd] = path.apply(held[0], lo, hi, row[meas])
            if path is not None:
                loop.watchdog[k] = float(path.link.active) if k < n else loop.watchdog[k - 1]
            if seen is not None:
                u_seen[k] = seen(u[k])

        def applied(k):                        # the row the controller reads: under the command last applied
            if k > 0:
                u[k, cmd] = u[k - 1, cmd]
    t0 = time.perf_counter()
    try:
        log = solve_circuit_reference(cc, P, y[:len(lay.states)], u, h, n, every, progress=progress, stats=stats,
                                      control=control, applied=applied if loop is not None else None, seen=u_seen)
    except ReferenceSolverFailed as exc:
        modes = {name: lay.mode_names[name][int(m[i])] for i, name in enumerate(lay.modes)}
        state = exc.y if exc.y is not None else y
        raise SimulationDiverged(exc.t, modes, {s: float(state[i]) for i, s in enumerate(lay.states)},
                                 str(exc)) from None
    res = CircuitResult({name: log[:, i] for i, name in enumerate(lay.log_columns)}, signal_units(c, lay),
                        lay.mode_names, h, "reference", time.perf_counter() - t0, stats,
                        lay.states[len(c.state_nodes):])
    idx = np.minimum(np.arange(len(log)) * every, len(u_seen) - 1)
    _step_columns(c, res, lay, u_seen[idx][:, [lay.inputs.index(d) for d in lay.delayed]], np.zeros(len(log)))
    return res


def _step_columns(c: Circuit, res: CircuitResult, lay, seen: np.ndarray | None, events: np.ndarray) -> None:
    """What each row's step did beside its state (the core's log columns ud and events): ``<input>.seen``, each
    delayed input as the components see it in the row's step (after its delay; ``seen`` None: not asked for),
    and ``events``, the events located in the steps since the row before (the reference: none, its modes are
    functions of its state)."""
    for j, name in enumerate(lay.delayed if seen is not None else ()):
        res.columns[f"{name}.seen"] = seen[:, j].copy()
        res.units[f"{name}.seen"] = input_unit(c, name)
    res.columns["events"] = events.copy()
    res.units["events"] = "-"


def _delay_line(cc, P, y, h: float):
    """f(u_k) -> the inputs of step k as the components see them, each delayed input through the generated
    delay line (hc_delayed_inputs on a copy of y's memory: the hybrid step's own), pushed at each call; None
    when no input is delayed (the inputs as set)."""
    lay, ffi = cc.layout, cc.ffi
    if not lay.delayed:
        return None
    mem, Pb = y.copy(), ffi.from_buffer("double[]", P)
    memb = ffi.from_buffer("double[]", mem)
    out = np.zeros(max(len(lay.inputs), 1))
    outb = ffi.from_buffer("double[]", out)

    def seen(uk):
        cc.lib.hc_delayed_inputs(Pb, float(h), memb, ffi.from_buffer("double[]", np.ascontiguousarray(uk)), outb)
        return out.copy()
    return seen


@dataclass
class NodeStiffness:
    node: str
    volume: float           # [m3]
    lam: float              # largest -d(dp/dt)/dp over the states sampled [1/s]
    lam_h: float
    limit: float            # the method's stability interval |lambda*h|
    slowed_above: float     # the stiff-node form's lambda*h (hc_node.h): a stiffer relaxation is slowed to it
    coupled_slowed: tuple = ()  # the nodes it is coupled to, where their coupled mode slowed it further (hc_node.h)

    @property
    def stable(self) -> bool:
        """explicitly stable at its stiffest without the stiff-node form"""
        return self.lam_h < self.limit

    def treatment(self, method: str, h: float) -> str:
        if self.lam_h <= self.slowed_above and not self.coupled_slowed:
            return f"explicit {method}: lambda*h = {self.lam_h:.3g} < {self.limit:g}"
        why = ("beyond the stability interval" if not self.stable else "inside the stability interval, "
               "though it would ring")
        text = (f"stiff for {method} at {h * 1e3:g} ms: lambda*h up to {self.lam_h:.3g} ({why}, {self.limit:g}), "
                f"its relaxation slowed to lambda*h = {self.slowed_above:g} where stiffer (the stiff-node form, "
                f"hc_node.h): flows, equilibria and steady motion exact, a deviation from its quasi-static "
                f"pressure decaying at {self.slowed_above / h:.4g} 1/s instead of up to {self.lam:.4g} 1/s")
        if self.coupled_slowed:
            text += (f"; coupled to {', '.join(self.coupled_slowed)}, slowed further where their coupled mode "
                     f"needed it (hc_node.h's Gershgorin bound): their common filling is slowed too (a pressure "
                     f"rising together too slowly): give them more volume, make them one node or take a smaller "
                     f"step")
        return text




def node_stiffness(c: Circuit, res: CircuitResult, *, samples: int = 50) -> list[NodeStiffness]:
    """Each pressure node's stiffness (SPEC §12.4): lambda = -d(dp/dt)/dp by central differences of the
    compiled right-hand side (without the stiff-node form), the largest over ``samples`` states of the run
    ``res``, against the stability interval of its method at its step and the stiff-node form's lambda*h."""
    from hydrohil.core import lib as core
    cc = compile_circuit(c)
    lay, ffi = cc.layout, cc.ffi
    P = np.ascontiguousarray(lay.values())
    n = len(res.columns["t"])
    dt_row = res.columns["t"][1] - res.columns["t"][0] if n > 1 else res.h
    u_all = input_table(c, max(n, 1), dt_row)          # the inputs at the rows' times
    limit = core.hh_real_axis_limit(METHODS.index(res.method))
    nn = len(c.state_nodes)
    lam, cut = np.zeros(nn), np.zeros(nn, dtype=bool)  # cut: slowed further for a coupled mode (hc_node.h)
    sc = np.zeros(3 * nn + 3)
    row_limit = float(cc.lib.hc_lambda_h_row())
    dy_hi, dy_lo = np.zeros(max(len(lay.states), 1)), np.zeros(max(len(lay.states), 1))
    for row in np.unique(np.linspace(0, n - 1, min(samples, n)).astype(int)):
        y = np.array([res.columns[s][row] for s in lay.states])
        m = np.array([res.columns[md][row] for md in lay.modes] or [0], dtype=np.int64)
        u = np.ascontiguousarray(u_all[min(row, len(u_all) - 1)])
        cc.lib.hc_stiff_constants(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", y),
                                  ffi.from_buffer("int64_t[]", m), ffi.from_buffer("double[]", u), float(res.h),
                                  ffi.from_buffer("double[]", sc))
        cut |= sc[2:3 * nn:3] > row_limit                  # (each node's Gershgorin reach before the cut)
        for i in range(len(c.state_nodes)):       # the node pressures (the fast parts, SPEC §12.4)
            d = max(1e3, 1e-6 * abs(y[i]))
            for sign, out in ((1, dy_hi), (-1, dy_lo)):
                yy = y.copy()
                yy[i] += sign * d
                cc.lib.hc_rhs(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", yy),
                              ffi.from_buffer("int64_t[]", m), ffi.from_buffer("double[]", u),
                              ffi.from_buffer("double[]", out))
            lam[i] = max(lam[i], -(dy_hi[i] - dy_lo[i]) / (2 * d))
    slowed = float(cc.lib.hc_lambda_h_max())
    return [NodeStiffness(node, c.node_volume(node), float(lam[i]), float(lam[i] * res.h), float(limit), slowed,
                          tuple(sorted({b if a == node else a for a, b in lay.coupled if node in (a, b)}))
                          if cut[i] else ())
            for i, node in enumerate(c.state_nodes)]
