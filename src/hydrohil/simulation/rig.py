"""The virtual rig: the hybrid plant as a controller sees it, one step at a time.

Hybrid model (:class:`~hydrohil.simulation.loop.HybridPlant`) + interface models (encoder, pressure
sensors, command saturation) + fault injection + the watchdog. The HIL plant server calls it once per
step with whatever command arrived; offline runs of scenarios with ``[[faults]]`` drive the very same
object from the P controller in a Python loop (:func:`run_rig`), so faults, watchdog and sensors act
identically offline, in lock-step and in real time.

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
from hydrohil.core import ffi, lib
from hydrohil.errors import HydrohilError
from hydrohil.hil.protocol import (ST_AT_EXTEND, ST_AT_RETRACT, ST_FAULT_INJECTED, ST_SATURATED, ST_STICK,
                                   ST_WATCHDOG)
from hydrohil.models.layout import AT_EXTEND, AT_RETRACT, PS, PT, STICK
from hydrohil.models.sensors import count_size, encoder_counts
from hydrohil.parameters import Parameters
from hydrohil.simulation.faults import FaultInjector
from hydrohil.simulation.loop import NLOG, HybridPlant
from hydrohil.simulation.run import SimulationResult
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


class VirtualRig:
    def __init__(self, params: Parameters, h: float, hil: HilCfg | None = None, faults: list | None = None,
                 initial: dict | None = None):
        self.params, self.h = params, float(h)
        self.hil = hil or HilCfg()
        self.initial = dict(initial or {})
        self.plant = HybridPlant(params, h=self.h, **self.initial)
        self.faults = FaultInjector(faults or [], self.plant.p, self.h, seed=self.hil.seed)
        self.faults.begin_step(0, self.plant.p, self.plant.y)
        self.noise = ffi.new("hh_rng *")                    # the core's generator: the C plant draws the same
        lib.hh_rng_seed(self.noise, self.hil.seed)
        self._nz = ffi.new("double[4]")
        self._sat = ffi.new("int *")
        self._reading = ffi.new("hh_reading *")
        self._sim = self.plant.sim._sim
        self._faulty = bool(self.faults.faults)     # without faults: one C call per step for the sensors
        self.res = count_size(params.sensors.encoder_resolution)   # m per encoder count
        self.link = ffi.new("hh_watchdog *")                # command path: saturation, watchdog, safe state
        lib.hh_watchdog_init(self.link)
        self._hold = self.hil.safe_state == "hold"
        self.base0 = self.faults.base.copy()              # the scenario's parameter vector (tunables apply on it)
        self.tunables: dict[str, float] = {}

    # -- steering (hydrohil.hil.steering: the live panel, and its offline replay) ---------------------
    def tune(self, name: str, value: float) -> None:
        """Set a tunable (:data:`hydrohil.hil.steering.TUNABLES`) from the next step on."""
        from hydrohil.hil.steering import tuned_base
        self.tunables[name] = float(value)
        self.faults.base[:] = tuned_base(self.base0, self.tunables)
        self.faults.rebuild(self.plant.p, self.plant.y)

    def fault_on(self, fault, k: int) -> int:
        """Switch a fault on from step k on; returns its slot (bit of the ``faults`` column)."""
        slot = self.faults.add(fault, k)
        self._faulty = True
        self.faults.begin_step(k, self.plant.p, self.plant.y)
        return slot

    def fault_off(self, slot: int, k: int) -> None:
        self.faults.end(slot, k)
        self.faults.begin_step(k, self.plant.p, self.plant.y)

    def reset(self) -> None:
        """The model back to the scenario's initial state (plant time 0); tunables and faults stay."""
        self.plant.reset(**self.initial)

    @property
    def watchdog(self) -> bool:
        return bool(self.link.active)

    @property
    def watchdog_trips(self) -> int:
        return int(self.link.trips)

    @property
    def watchdog_trips_unexplained(self) -> int:
        return int(self.link.trips_unexplained)

    @property
    def commands_delivered(self) -> int:
        return int(self.link.delivered)

    def warm_up(self) -> None:
        """Run one step and restore the initial state: pages in the code and data a step touches, so the
        first step of a real-time run does not pay for it."""
        self.plant.step(0.0)
        self.plant.reset(**self.initial)

    @property
    def out(self) -> np.ndarray:
        return self.plant.out

    def step(self, k: int, command: float | None) -> float:
        """Advance step k -> k+1 with the command the controller sent for it (ū; None: none arrived).
        Returns the command that drove the valve."""
        plant, faults = self.plant, self.faults if self._faulty else None   # no faults: skip the injector
        u = command
        if faults is not None:
            faults.begin_step(k, plant.p, plant.y)
            u = faults.deliver(command)
            if (command is not None and u is None) or faults.silence_active():
                self.link.k_interfered = k     # an injected fault held the controller's command back this step
        u = lib.hh_watchdog_command(self.link, k, u is not None, 0.0 if u is None else u, self.h,
                                    self.hil.watchdog_timeout, self._hold, self.hil.hold_kp, float(plant.out[5]))
        if faults is not None:
            u = faults.valve_command(u)
        plant.step(u)
        if faults is not None:
            faults.begin_step(k + 1, plant.p, plant.y)     # faults of t_(k+1): its sensor reading and step
        return u

    def step_applied(self, k: int, u: float) -> None:
        """Advance step k -> k+1 with the command that drove the valve (a log's ``u``): the replay of a run."""
        if self._faulty:
            self.faults.begin_step(k, self.plant.p, self.plant.y)
        self.plant.step(u)
        if self._faulty:
            self.faults.begin_step(k + 1, self.plant.p, self.plant.y)

    def read(self) -> Reading:
        """Sensor readings of the current state (interface models, then sensor faults) and the status bits of
    the wire protocol the rig knows (the server adds lock-step, overrun and final)."""
        out, s, p, f = self.plant.out, self.params.sensors, self.plant.p, self.faults
        if not self._faulty:               # the core's sensor models in one call (the C plant's too)
            r = self._reading
            lib.hh_rig_read(self._sim, self.res, self.noise, r)
            vals, sat, enc, mask = (r.p[0], r.p[1], r.p[2], r.p[3]), r.saturated, r.encoder, 0
        else:
            t = float(out[0])
            enc = lib.hh_count_to_int(f.sense_position(float(encoder_counts(out[5], self.res)), self.res, t))
            nz = self._nz
            if s.pressure_noise > 0:
                lib.hh_rng_normals(self.noise, 4, nz)
            noise = [nz[i] * s.pressure_noise for i in range(4)] if s.pressure_noise > 0 else (0.0, 0.0, 0.0, 0.0)
            true = (out[3], out[4], p[PS], p[PT])
            vals, sat = [], False
            for name, v, n in zip(("p1", "p2", "ps", "pt"), true, noise):
                vals.append(lib.hh_pressure_reading(f.sense_pressure(name, float(v), t), s.pressure_range,
                                                    s.pressure_resolution, n, self._sat))
                sat |= bool(self._sat[0])
            mask = f.mask
        travel, friction = int(out[9]), int(out[10])
        status = (ST_SATURATED if sat else 0) | (ST_WATCHDOG if self.link.active else 0)
        status |= ST_AT_RETRACT if travel == AT_RETRACT else ST_AT_EXTEND if travel == AT_EXTEND else 0
        status |= (ST_STICK if friction == STICK else 0) | (ST_FAULT_INJECTED if mask else 0)
        return Reading(float(out[0]), enc, *vals, status, travel, friction, int(out[11]), mask)


RIG_COLUMNS = ("faults", "x_meas", "p1_meas", "p2_meas", "ps_meas", "watchdog")


def run_rig(sc, *, controller=None, progress=None, events=None, controller_events=None, steps: int | None = None):
    """Offline run of a scenario through the virtual rig (the path of scenarios with ``[[faults]]`` or a
    Python controller): closed loop = the scenario's controller (or ``controller``, a callable taking a
    :class:`~hydrohil.control.Measurement`) on what the rig's sensors report, exactly as the HIL controller
    process. ``events`` / ``controller_events`` ({k: [event]}, :func:`hydrohil.hil.steering.read_events`)
    replay a steered session (the live panel) at the steps they were applied; ``steps`` replaces the
    scenario's step count. Returns a :class:`~hydrohil.simulation.run.SimulationResult` with the extra
    columns :data:`RIG_COLUMNS` (what the sensors reported, active faults, watchdog)."""
    from hydrohil.hil.steering import SteerableController, apply_plant_event
    s = sc.scenario
    h, n = s.solver.step, s.n_steps() if steps is None else int(steps)
    rig = VirtualRig(sc.params, h, s.hil, s.faults, s.initial.model_dump())
    closed = s.closed_loop
    events, controller_events = events or {}, controller_events or {}
    steered = None
    if closed:
        ctl = sc.make_controller() if controller is None else make_controller(controller, sc.params, h)
    if closed and (events or controller_events or steps is not None):   # the reference at the plant's time
        steered = SteerableController(ctl, s.reference.sampler().at)          # (a reset restarts it)
        drive = slopes = None
    else:
        drive, slopes = s.drive()
    every = s.solver.output_every
    log = np.zeros((n // every + 1, NLOG))
    extra = np.zeros((n // every + 1, len(RIG_COLUMNS)))
    plant = rig.plant
    y_prev, m_prev = plant.y.copy(), plant.m.copy()
    t0 = time.perf_counter()
    diverged = None
    rows = 0
    for k in range(n + 1):
        r = rig.read()
        x = r.encoder * rig.res
        if steered is not None:
            for ev in controller_events.get(k, ()):
                steered.apply(ev)
            xr, dxr = steered.ref(r.t)
        elif closed:
            xr, dxr = drive[k], slopes[k]
        if closed:
            u = call_controller(ctl, Measurement(r.t, xr, dxr, x, r.p1, r.p2, r.ps, r.pt, r.status))
        else:
            u = float(drive[k])
        y_prev[:], m_prev[:] = plant.y, plant.m
        record = k % every == 0
        if k < n:
            for ev in events.get(k, ()):
                apply_plant_event(rig, ev, k)
            try:
                u_valve = rig.step(k, u)
            except HydrohilError as exc:
                diverged = exc
                break
            ud = float(plant.out[13])
        else:
            u_valve, ud = u, float(plant.out[13])
        if record:
            plant.sim.log_row(k * h, u_valve, ud, y_prev, m_prev, plant.out[12], log[rows])
            extra[rows] = (r.faults, x, r.p1, r.p2, r.ps, r.status & ST_WATCHDOG)
            rows += 1
        if progress is not None and k % 2000 == 0:
            progress(k)
    wall = time.perf_counter() - t0
    return SimulationResult(log[:rows], s.solver.method, h, wall, diverged,
                            columns={c: extra[:rows, i] for i, c in enumerate(RIG_COLUMNS)})
