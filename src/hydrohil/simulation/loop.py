"""The core's sampled loop from Python: :class:`Sim` (one ``hh_sim`` of ``core/hh.h``), the offline run
:func:`run_loop` and the per-step API :class:`HybridPlant`.

The plant input is a zero-order-held command u_k, given (open loop) or computed at t_k by a built-in
controller from the sensor readings (closed loop), exactly as a sampled controller would; it reaches the spool through
the fractional input delay. One log row per output interval; columns :data:`LOG_COLUMNS`. The loop itself
(controller -> delay -> step -> log) is C (``core/loop.c``): simulate, maxstep, the stiff reference and the
rig all run it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from hydrohil.core import dptr, ffi, iptr, lib, method_code, shape, view
from hydrohil.errors import HydrohilError, InputWarning
from hydrohil.models.layout import FREE, M_TRAVEL, NM, NY, pack
from hydrohil.models.rest import unheld_load
from hydrohil.parameters import Parameters

LOG_COLUMNS = shape.LOG_COLUMNS          # the log's columns (core/shape.py; hh_shape.h's HH_LOG_* from the same)
NLOG = lib.HH_NLOG
STATUS_OK, STATUS_DIVERGED = lib.HH_OK, lib.HH_DIVERGED
MODELS = {"hybrid": lib.HH_MODEL_HYBRID, "continuous": lib.HH_MODEL_CONTINUOUS, "external": lib.HH_MODEL_EXTERNAL,
          "generated": lib.HH_MODEL_GENERATED}


def split_delay(delay: float, h: float) -> tuple[int, float]:
    """(whole steps n, fraction alpha) with delay = (n + alpha)*h (core/delay.c)."""
    alpha = ffi.new("double *")
    n = lib.hh_delay_steps(delay, h, alpha)
    return n, alpha[0]


def initial_state(params: Parameters, xp: float, xs: float | None = None, vs: float = 0.0,
                  p1: float | None = None, p2: float | None = None, vp: float = 0.0,
                  p: np.ndarray | None = None):
    """(y, m) by the core (``hh_initial_state``): at rest by default (SPEC §12.5): ``xs`` None -> the spool
    offset that holds the piston, pressures None -> those at which the chambers' flows balance at the spool
    position (:mod:`hydrohil.models.rest`); on a stop when pressed onto it, else free with the friction state
    balancing the net force up to breakaway. When no spool position holds the load (and the piston is free
    with the default pressures) an :class:`InputWarning` says so and the spool starts centred: the load
    moves the piston, as it would on the rig."""
    p = pack(params) if p is None else p
    y = np.zeros(NY)
    m = np.zeros(NM, dtype=np.int64)
    nan = math.nan
    status = lib.hh_initial_state(dptr(p), float(xp), nan if xs is None else float(xs), float(vs),
                                  nan if p1 is None else float(p1), nan if p2 is None else float(p2), float(vp),
                                  dptr(y), iptr(m))
    if status != 0 and m[M_TRAVEL] == FREE and (p1 is None or p2 is None):
        warnings.warn(InputWarning(f"initial.xs: {unheld_load(params)}; the spool starts centred and the load "
                                   "moves the piston"), stacklevel=2)
    return y, m


class Sim:
    """One instance of the core's loop state (``hh_sim``): parameters ``p``, state ``y``, modes ``m`` and the
    last step's outputs ``out`` are NumPy views of the C struct (edit ``p`` in place, e.g. fault injection).

    ``model``: "hybrid" (fixed-step hybrid model), "continuous" (the reference model at a fixed explicit
    step, maxstep), "external" (a Python step behind a callback, the SciPy reference) or "generated" (the hybrid
    model generated from the circuit of ``params``, the parameter set ``p`` was packed from:
    :func:`hydrohil.simulation.generated_model.generated_hybrid_model`)."""

    def __init__(self, p: np.ndarray, h: float, *, model: str = "hybrid", solver: str = "rk3",
                 bounded: bool = False, params: Parameters | None = None):
        if not h > 0:
            raise ValueError(f"step h must be > 0 s, got {h}")
        self.h = float(h)
        self._sim = ffi.new("hh_sim *")
        self.dl_n, self.dl_alpha = split_delay(float(p[lib.HH_SPOOL_DELAY]), self.h)
        self._buf = np.zeros(self.dl_n + 2)
        lib.hh_sim_init(self._sim, dptr(np.ascontiguousarray(p, dtype=float)), MODELS[model],
                        method_code(solver) if model != "external" else lib.HH_RK3, self.h, dptr(self._buf),
                        self.dl_n, self.dl_alpha)
        self._sim.bounded = int(bounded)
        self._model = None
        if model == "generated":             # the paper's circuit's generated hybrid model behind this loop
            from hydrohil.simulation.generated_model import generated_hybrid_model
            self._model = generated_hybrid_model(params, self, solver)
        self._rng = ffi.new("hh_rng *")           # the sensors' noise of closed-loop runs (Sim.run)
        self.p = view(self._sim.p, np.float64, lib.HH_NP)
        self.y = view(self._sim.y, np.float64, NY)
        self.m = view(self._sim.m, np.int64, NM)
        self.out = view(self._sim.out, np.float64, lib.HH_NOUT)

    def set_state(self, y: np.ndarray, m: np.ndarray | None = None) -> None:
        """Start from (y, m): k = 0, delay line filled with the command y[XS] held before t = 0."""
        self.y[:] = y
        if m is not None:
            self.m[:] = m
        lib.hh_sim_reset(self._sim)

    def step(self, u: float) -> int:
        return lib.hh_sim_step(self._sim, u)

    def run(self, n_steps: int, every: int, values: np.ndarray, *, controller=None, slopes: np.ndarray | None = None,
            seed: int = 0, t_in: np.ndarray | None = None, progress=None, rig=None, command=None,
            on_event=None, event_steps=(), applied: bool = False, log_from: int = 0):
        """Run n_steps from the current state; returns (status, steps done, log rows) and, with ``rig``, the
        rig's columns of those rows (``(status, done, log, rig_log)``).

        ``values``: commands u (open loop) or, with ``controller`` (a
        :class:`~hydrohil.control.BuiltinController`, sampled every step on the rig's sensor readings, the
        pressure noise seeded by ``seed`` at k = 0; a run continued from where the last one stopped goes on
        with the same controller state and noise draws), positions x_ref with their ``slopes``; value k holds over step k
        (n_steps + 1 values), or with ``t_in`` a table sampled by zero-order hold.

        ``rig``: the ``hh_rig`` this sim is the plant of (:class:`~hydrohil.simulation.rig.VirtualRig`): the run
        goes through its sensing and its step (faults, command path, watchdog). ``command(k, t, v, dv, reading)``:
        a controller in Python, called each step with the rig's reading (``hh_rig_reading``); ``on_event(k)``:
        called before each step of ``event_steps``. What either raises stops the run and is raised here.
        ``applied`` (with ``rig``): the values are the commands that drove the valve (a run replayed: the rig's
        command path skipped); ``log_from``: rows of the steps before it are not kept (with ``rig``)."""
        if int(every) < 1 or int(n_steps) < 0:
            raise ValueError(f"need every >= 1 and n_steps >= 0, got every = {every}, n_steps = {n_steps}")
        values = np.ascontiguousarray(values, dtype=float)
        drive = ffi.new("hh_drive *")
        drive.kind = lib.HH_DRIVE_OPEN if controller is None and command is None else lib.HH_DRIVE_CLOSED
        if applied or log_from:
            if rig is None or controller is not None or command is not None or not 0 <= int(log_from) <= n_steps:
                raise ValueError("applied commands and log_from are for a run through a rig, open loop, "
                                 "0 <= log_from <= n_steps")
            drive.kind = lib.HH_DRIVE_APPLIED if applied else drive.kind
            drive.log_from = int(log_from)
        first = -(-int(log_from) // int(every)) * int(every)      # the first step logged
        n_rows = (int(n_steps) - first) // int(every) + 1
        if controller is not None:
            if self._sim.k == 0:               # a fresh start; a continued run keeps drawing where it stopped
                lib.hh_rng_seed(self._rng, int(seed))
            drive.controller, drive.state, drive.rng = controller.c, controller.state, self._rng
        rig_log = steps_arr = None
        calls = _Callbacks(command, on_event, progress)
        if rig is not None:
            drive.rig = rig
            rig_log = np.zeros((n_rows, lib.HH_NRLOG))
            drive.rig_log = dptr(rig_log)
            drive.ctx = calls.handle
            if command is not None:
                drive.command = lib.hh_py_command
            if len(event_steps):
                steps_arr = np.ascontiguousarray(sorted(event_steps), dtype=np.int64)
                drive.event_steps, drive.n_event_steps = iptr(steps_arr), len(steps_arr)
                drive.on_event = lib.hh_py_event
        if slopes is not None:
            slopes = np.ascontiguousarray(slopes, dtype=float)
            if len(slopes) != len(values):
                raise ValueError(f"{len(values)} slopes needed, got {len(slopes)}")
            drive.dv_in = dptr(slopes)
        drive.v_in = dptr(values)
        if t_in is None:
            if len(values) < n_steps + 1:
                raise ValueError(f"{n_steps + 1} drive values needed, got {len(values)}")
            drive.t_in = ffi.NULL
        else:
            t_in = np.ascontiguousarray(t_in, dtype=float)
            if len(t_in) != len(values) or len(t_in) == 0:
                raise ValueError("t_in and values differ in length (or are empty)")
            drive.t_in = dptr(t_in)
        drive.n_in = len(values)
        log = np.zeros((n_rows, NLOG))
        done = ffi.new("int64_t *")
        rows = ffi.new("int64_t *")
        if progress is not None:
            self._sim.progress_ctx = calls.handle
            self._sim.progress = lib.hh_py_progress
        try:
            status = lib.hh_sim_run(self._sim, drive, int(n_steps), int(every), dptr(log), done, rows)
        finally:
            if progress is not None:
                self._sim.progress, self._sim.progress_ctx = ffi.NULL, ffi.NULL
        if status == lib.HH_BAD_ARGUMENT:
            raise ValueError("a run through a rig starts at the rig's step 0 with the rig's own plant")
        if status == lib.HH_STOPPED:      # a callback raised (the controller, an event, progress: Ctrl-C)
            raise calls.error if calls.error is not None else HydrohilError(
                f"the controller gave no command at step {int(done[0])} (t = {int(done[0]) * self.h:.6g} s)")
        if rig is None:
            return status, int(done[0]), log[:rows[0]]
        return status, int(done[0]), log[:rows[0]], rig_log[:rows[0]]


class _Callbacks:
    """A run's Python callbacks behind one handle; what they raise is kept for :meth:`Sim.run` to raise (the C
    loop stops on HH_STOPPED)."""

    def __init__(self, command, on_event, progress):
        self.command, self.on_event, self.progress = command, on_event, progress
        self.error: BaseException | None = None
        self.handle = ffi.new_handle(self)


@ffi.def_extern()
def hh_py_command(ctx, k, t, v, dv, reading):
    calls = ffi.from_handle(ctx)
    try:
        return calls.command(int(k), t, v, dv, reading)
    except BaseException as exc:      # noqa: BLE001 - raised again by Sim.run once the loop has stopped
        calls.error = exc
        return math.nan


@ffi.def_extern()
def hh_py_progress(ctx, k):
    calls = ffi.from_handle(ctx)
    try:
        calls.progress(int(k))
        return 0
    except BaseException as exc:      # noqa: BLE001 - e.g. Ctrl-C: the loop stops, Sim.run raises it
        calls.error = exc
        return 1


@ffi.def_extern()
def hh_py_event(ctx, k):
    calls = ffi.from_handle(ctx)
    try:
        calls.on_event(int(k))
        return 0
    except BaseException as exc:      # noqa: BLE001 - raised again by Sim.run once the loop has stopped
        calls.error = exc
        return 1


def _engine_model(engine: str, params: Parameters) -> dict:
    """Sim's model of an ``engine``: "generated" (from the circuit of ``params``) or "core" (hybrid.c)."""
    if engine not in ("generated", "core"):
        raise ValueError(f"engine: generated or core, got {engine!r}")
    return {"model": "generated", "params": params} if engine == "generated" else {"model": "hybrid"}


def run_loop(params: Parameters, p: np.ndarray, y: np.ndarray, m: np.ndarray, h: float, n: int, every: int,
             values: np.ndarray, *, controller=None, slopes: np.ndarray | None = None, seed: int = 0,
             solver: str = "rk3", engine: str = "generated"):
    """Run the hybrid model n steps from (y, m), both updated in place; open loop with commands ``values``
    (n + 1), or the built-in ``controller`` on the positions ``values`` (slopes ``slopes``; pressure noise
    seeded by ``seed``). ``engine``: the model generated from the circuit of ``params`` (the parameter set ``p``
    was packed from) or the hand-written core's ("core"). Returns (status, steps done, log)."""
    sim = Sim(p, h, solver=solver, **_engine_model(engine, params))
    sim.set_state(y, m)
    status, done, log = sim.run(n, every, values, controller=controller, slopes=slopes, seed=seed)
    y[:] = sim.y
    m[:] = sim.m
    return status, done, log


class HybridPlant:
    """Per-step API of the hybrid model: ``plant.step(u)`` advances one fixed step h with command u.

    ``step`` returns a reused float64 array ``out``: [t, xs, vs, p1, p2, xp, vp, z, ff, travel, friction,
    spool, events, ud] (SI; mode codes of :mod:`hydrohil.models.layout`). Copy it to keep it. ``engine``: the
    hybrid model generated from the parameter set's circuit ("generated", in the core's loop) or the
    hand-written core's ("core"): the same bits.
    """

    OUT_COLUMNS = shape.OUTPUT_NAMES

    def __init__(self, params: Parameters, h: float = 5e-4, solver: str = "rk3", engine: str = "generated",
                 **initial):
        self.sim = Sim(pack(params), h, solver=solver, **_engine_model(engine, params))   # checks h > 0
        self.params, self.h = params, self.sim.h
        self.p, self.y, self.m, self.out = self.sim.p, self.sim.y, self.sim.m, self.sim.out
        self._step = lib.hh_sim_step
        self._c = self.sim._sim
        self.reset(**initial)

    def reset(self, xp: float | None = None, **kw) -> np.ndarray:
        xp = self.params.linear.xp0 if xp is None else xp
        y, m = initial_state(self.params, xp, p=self.p, **kw)
        self.sim.set_state(y, m)
        return self.out

    def step(self, u: float) -> np.ndarray:
        if self._step(self._c, u):
            from hydrohil.simulation.diagnostics import divergence_error
            raise divergence_error(self.out[lib.HH_OUT_T], self.y, self.m)
        return self.out

    @property
    def t(self) -> float:
        return float(self.out[lib.HH_OUT_T])
