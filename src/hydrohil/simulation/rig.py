"""The virtual rig: the hybrid plant as a controller sees it, one step at a time.

Hybrid model (:class:`~hydrohil.simulation.loop.HybridPlant`) + the C core's rig step (``core/rig.c``:
interface models of the encoder and the pressure sensors, command saturation, the watchdog, the fault table).
The Python HIL plant server calls it once per step with whatever command arrived, the standalone C plant
calls the same C; offline runs of scenarios with ``[[faults]]`` drive the very same object from the
controller in a Python loop (:func:`run_rig`), so faults, watchdog and sensors act identically offline, in
lock-step and in real time, in either plant.

Watchdog: silence is counted in plant steps since the last command that reached the plant (network
faults included): longer than ``[hil] watchdog_timeout`` -> safe state (``centre``: ū = 0; ``hold``: P
control on the position held at the trip), left on the next command that arrives. A trip with no
injected network or silence fault active during the silence is *unexplained* (the controller itself went
quiet): it counts against the run's validity (:mod:`hydrohil.hil.verdict`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from hydrohil.control import Measurement, call_controller, make_controller
from hydrohil.core import dptr, ffi, lib, shape, view
from hydrohil.core.watchdog import WatchdogCounters
from hydrohil.models.sensors import count_size
from hydrohil.parameters import Parameters
from hydrohil.simulation.diagnostics import divergence_error
from hydrohil.simulation.faults import fault_struct
from hydrohil.simulation.loop import HybridPlant, initial_state
from hydrohil.simulation.result import SimulationResult
from hydrohil.simulation.scenario import HilCfg



@dataclass
class Reading:
    """What the rig's sensors report for the current state."""
    t: float
    encoder: int           # counts
    p1: float              # Pa, as the transducer reports
    p2: float
    ps: float
    pt: float
    status: int
    travel: int
    friction: int
    spool: int
    faults: int            # bit i: fault i of the scenario active


class VirtualRig(WatchdogCounters):
    """The hybrid plant behind the rig step of the C core (``hh_rig``, core/rig.c: command path, watchdog,
    the fault table, sensing): the same step the standalone C plant takes. ``engine``: its hybrid model the code
    generated from the parameter set's circuit ("generated", :func:`~hydrohil.simulation.generated_model.
    generated_hybrid_model`: the core's runs bit for bit, tests) or the hand-written core's ("core")."""

    def __init__(self, params: Parameters, h: float, hil: HilCfg | None = None, faults: list | None = None,
                 initial: dict | None = None, engine: str = "generated"):
        self.params, self.h = params, float(h)
        self.hil = hil or HilCfg()
        self.initial = dict(initial or {})
        self.plant = HybridPlant(params, h=self.h, engine=engine, **self.initial)
        self.res = count_size(params.sensors.encoder_resolution)   # m per encoder count
        self.c = ffi.new("hh_rig *")
        self._fifo = None                                   # network_delay's commands in flight (on demand)
        lib.hh_rig_init(self.c, self.plant.sim._sim, self.res, int(self.hil.seed), self.hil.watchdog_timeout,
                        self.hil.safe_state == "hold", self.hil.hold_kp, ffi.NULL, 0)
        self.fault_models: list = []                        # slot -> the fault (None: a free slot never used)
        for f in faults or []:
            self._need_fifo(f)
            if lib.hh_rig_add(self.c, fault_struct(f, self.h)) < 0:
                raise ValueError(f"at most {lib.HH_MAX_FAULTS} faults per scenario")
            self.fault_models.append(f)
        lib.hh_rig_begin(self.c, 0)
        self._u = ffi.new("double *")
        self._r = ffi.new("hh_rig_reading *")
        self._base = view(self.c.base, np.float64, lib.HH_NP)           # the rig's fault-free parameters (a view)
        self.base0 = self._base.copy()                       # the scenario's parameters (tunables act on it)
        self.tunables: dict[str, float] = {}

    def _need_fifo(self, fault) -> None:
        """A network delay needs its delay line: up to 1 s of commands (the schema's bound), made once."""
        if fault.type == "network_delay" and self._fifo is None:
            cap = int(np.ceil(1.0 / self.h)) + 2
            self._fifo = np.zeros(2 * cap)                  # (slots of 2: hh_wire, link.c)
            self.c.wire.fifo, self.c.wire.cap = dptr(self._fifo), cap

    # -- steering (hydrohil.simulation.steering: the live panel, and its offline replay) ---------------------
    def tune(self, name: str, value: float) -> None:
        """Set a tunable (:data:`hydrohil.simulation.steering.TUNABLES`) from the next step on."""
        from hydrohil.simulation.steering import tuned_base
        self.tunables[name] = float(value)
        lib.hh_rig_set_base(self.c, dptr(np.ascontiguousarray(tuned_base(self.base0, self.tunables))))

    def fault_on(self, fault, k: int) -> int:
        """Switch a fault on from step k on; returns its slot (bit of the ``faults`` column)."""
        self._need_fifo(fault)
        slot = lib.hh_rig_add_live(self.c, fault_struct(fault, self.h), k)
        if slot < 0:
            raise ValueError(f"at most {lib.HH_MAX_FAULTS} faults at a time")
        self.fault_models[slot:slot + 1] = [fault]
        return slot

    def fault_off(self, slot: int, k: int) -> None:
        if lib.hh_rig_end(self.c, int(slot), k) != 0:
            raise ValueError(f"no active fault in slot {slot}")

    def reset(self) -> None:
        """The model back to the scenario's initial state (plant time 0) of the fault-free parameters (the
        rig's base, tunables applied: a fault active then hits a rig at rest); tunables and faults stay."""
        kw = dict(self.initial)
        y, m = initial_state(self.params, kw.pop("xp", self.params.linear.xp0), p=self._base, **kw)
        self.plant.sim.set_state(y, m)

    @property
    def mask(self) -> int:
        """Bit i: fault i active at the current step."""
        return int(self.c.mask)

    @property
    def link(self):
        """The command path's watchdog (``hh_watchdog``: active, trips, delivered, ...)."""
        return self.c.link

    def warm_up(self) -> None:
        """Run one step and restore the initial state: pages in the code and data a step touches, so the
        first step of a real-time run does not pay for it."""
        self.plant.step(0.0)
        self.reset()

    @property
    def out(self) -> np.ndarray:
        return self.plant.out

    def _diverged(self):
        return divergence_error(self.plant.out[lib.HH_OUT_T], self.plant.y, self.plant.m)

    def step(self, k: int, command: float | None) -> float:
        """Advance step k -> k+1 with the command the controller sent for it (ū; None: none arrived).
        Returns the command that drove the valve."""
        if lib.hh_rig_step(self.c, k, command is not None, 0.0 if command is None else command, self._u) != 0:
            raise self._diverged()
        return self._u[0]

    def step_applied(self, k: int, u: float) -> None:
        """Advance step k -> k+1 with the command that drove the valve (a log's ``u``): the replay of a run."""
        if lib.hh_rig_step_applied(self.c, k, u) != 0:
            raise self._diverged()

    def read(self) -> Reading:
        """Sensor readings of the current state (interface models and sensor faults, core/rig.c) and the
        status bits of the wire protocol the rig knows (the server adds lock-step, overrun and final)."""
        r, out = self._r, self.plant.out
        lib.hh_rig_sense(self.c, r)
        return Reading(float(out[lib.HH_OUT_T]), int(r.encoder), r.p[lib.HH_PRESSURE_P1], r.p[lib.HH_PRESSURE_P2],
                       r.p[lib.HH_PRESSURE_PS], r.p[lib.HH_PRESSURE_PT], int(r.status),
                       int(out[lib.HH_OUT_TRAVEL]), int(out[lib.HH_OUT_FRICTION]), int(out[lib.HH_OUT_SPOOL]),
                       int(r.faults))


RIG_COLUMNS = shape.RIG_LOG_COLUMNS      # beside the log's: what the sensors reported, faults, watchdog


def run_rig(sc, *, controller=None, progress=None, events=None, controller_events=None, steps: int | None = None,
            engine: str = "generated"):
    """Offline run of a scenario through the virtual rig (the path of scenarios with ``[[faults]]`` or a
    Python controller): closed loop = the scenario's controller (or ``controller``, a callable taking a
    :class:`~hydrohil.control.Measurement`) on what the rig's sensors report, exactly as the HIL controller
    process. ``events`` / ``controller_events`` ({k: [event]}, :func:`hydrohil.simulation.steering.read_events`)
    replay a steered session (the live panel) at the steps they were applied; ``steps`` replaces the
    scenario's step count. The loop is the core's (``hh_sim_run`` through the rig step): a built-in controller
    runs in C, a Python one (or a steered one) is called back each step. Returns a
    :class:`~hydrohil.simulation.result.SimulationResult` with the extra columns :data:`RIG_COLUMNS` (what the
    sensors reported, active faults, watchdog)."""
    from hydrohil.control import BuiltinController
    from hydrohil.simulation.steering import SteerableController, apply_plant_event
    s = sc.scenario
    h, n = s.solver.step, s.n_steps() if steps is None else int(steps)
    rig = VirtualRig(sc.params, h, s.hil, s.faults, s.initial.model_dump(), engine=engine)
    closed = s.closed_loop
    events, controller_events = events or {}, controller_events or {}
    builtin = command = None
    if closed:
        ctl = sc.make_controller() if controller is None else make_controller(controller, sc.params, h)
    if closed and (events or controller_events or steps is not None):   # the reference at the plant's time
        steered = SteerableController(ctl, s.reference.sampler().at)          # (a reset restarts it)
        values = slopes = None

        def command(k, t, v, dv, r):
            for ev in controller_events.get(k, ()):
                steered.apply(ev)
            t_r = rig.plant.out[lib.HH_OUT_T]
            xr, dxr = steered.ref(t_r)
            return call_controller(ctl, _measurement(t_r, xr, dxr, r, rig.res))
    else:
        values, slopes = s.drive()
        if closed and isinstance(ctl, BuiltinController):
            builtin = ctl                                                     # the law in C, on the rig's reading
        elif closed:
            def command(k, t, v, dv, r):
                return call_controller(ctl, _measurement(rig.plant.out[lib.HH_OUT_T], v, dv, r, rig.res))
    if values is None:                                        # a steered run's reference is the controller's
        values = np.zeros(n + 1)

    def on_event(k):
        for ev in events.get(k, ()):
            apply_plant_event(rig, ev, k)

    sim = rig.plant.sim
    t0 = time.perf_counter()
    status, _, log, extra = sim.run(n, s.solver.output_every, values, controller=builtin, slopes=slopes,
                                    seed=s.hil.seed, rig=rig.c, command=command, on_event=on_event,
                                    event_steps=[k for k in events if 0 <= k < n],
                                    progress=(lambda k: progress(k) if k % 2000 == 0 else None) if progress else None)
    wall = time.perf_counter() - t0
    diverged = rig._diverged() if status == lib.HH_DIVERGED else None
    return SimulationResult(log, s.solver.method, h, wall, diverged,
                            columns={c: extra[:, i] for i, c in enumerate(RIG_COLUMNS)})


def _measurement(t: float, x_ref: float, dx_ref: float, r, res: float) -> Measurement:
    """A controller's measurement from the rig's reading (``hh_rig_reading``) at plant time t."""
    p = r.p
    return Measurement(float(t), float(x_ref), float(dx_ref), r.encoder * res, p[lib.HH_PRESSURE_P1],
                       p[lib.HH_PRESSURE_P2], p[lib.HH_PRESSURE_PS], p[lib.HH_PRESSURE_PT], int(r.status))
