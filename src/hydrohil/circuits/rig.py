"""A circuit as a controller sees it, one step at a time: the plant side of a circuit's HIL run.

The generated C's per-step interface (``hc_step``, ``hc_row``, ``hc_sensed``) under the inputs a controller
sends: each step takes the scenario's drives (its ``[inputs]``, the circuit's defaults) and replaces those
the controller has set (the latest value of each input it named); a loop's command starts at the command
that holds its piston (:func:`hydrohil.circuits.run.start_state`), so a controller that answers every
sensor packet gets exactly :func:`~hydrohil.circuits.run.simulate_circuit`'s run. What a controller reads:
every log column of the state after the step, the loop's measured signal through its sensor.

Inputs are saturated to their parameter's range. The controller's packets reach the inputs through the
command path (:mod:`hydrohil.circuits.network`: the scenario's network faults, then the core's watchdog, the
same rule as the paper's rig): no command for longer than ``watchdog_timeout`` -> the safe state until the next
command: every input the controller drives (a loop's command from the start) at 0, or the end of its range
nearest to 0 (a valve centred, an orifice closed, a pump stopped: the rig's "centre"), the others on their
drives from the scenario; with ``safe_state = "hold"`` the loop's command instead a P law (``hold_kp``) holding
its measured signal at its value at the trip (the rig's "hold"). A trip counts against the run
(:mod:`hydrohil.hil.verdict`) unless a network fault held packets back meanwhile.
"""

from __future__ import annotations

import numpy as np

from hydrohil.circuits.build import compile_circuit
from hydrohil.circuits.link import wire_lists
from hydrohil.circuits.network import CommandPath
from hydrohil.circuits.run import METHODS, divergence_reason, input_table, start_state
from hydrohil.core import ffi as core_ffi
from hydrohil.core import lib as core
from hydrohil.core.watchdog import WatchdogCounters
from hydrohil.errors import InputError, SimulationDiverged


class CircuitRig(WatchdogCounters):
    """The circuit of a scenario (:class:`~hydrohil.circuits.scenario.CircuitScenario`) behind its inputs.
    ``signals`` / ``inputs``: (name, SI unit) of what it reports and what it takes, in wire order. The command
    path's watchdog timeout (``watchdog_timeout`` in its place: a test's) and the seed of its faults' streams: the
    scenario's [hil], as its offline run's."""

    def __init__(self, cs, *, watchdog_timeout: float | None = None, network: bool = True):
        if cs.method == "reference":
            raise InputError("a real-time plant steps the hybrid model: give a fixed-step method (rk3, ...), not "
                             "the continuous reference", source=cs.source, key="solver.method")
        c = self.circuit = cs.circuit
        self.cs, self.h, self.n = cs, cs.step, cs.n_steps
        cc = self.cc = compile_circuit(c)
        lay = self.layout = cc.layout
        self.signals, self.inputs = wire_lists(c, lay)
        self.drives = input_table(c, self.n, self.h)              # the scenario's drive of each input per step
        ranges = [c.input_param(s) for s in lay.inputs]
        self.lo, self.hi = [float(p.lo) for p in ranges], [float(p.hi) for p in ranges]     # (saturation)
        self.P = np.ascontiguousarray(lay.values())
        self.method = METHODS.index(cs.method)
        self.seed, timeout, self.hold_kp = cs.link                # (the scenario's [hil], as offline)
        self.watchdog_timeout = float(timeout if watchdog_timeout is None else watchdog_timeout)
        # the network faults on the loop's command or an open loop's commands (network False: none, a replay of
        # the inputs as applied after them)
        sender = cs.loop if cs.loop is not None else cs.commands
        self.network = sender.network if network and sender is not None else []
        self.loop = cs.loop
        self._cmd = -1
        # the inputs the controller drives from the start (until it speaks: their values at the start)
        self.commanded = {lay.inputs.index(name) for name in cs.commands.inputs} if cs.commands is not None else set()
        if self.loop is not None:
            self._meas = lay.log_columns.index(self.loop.measure)
            self._cmd = lay.inputs.index(self.loop.command)
            self.commanded = {self._cmd}
        self.y0, self.m0, self.u0 = start_state(c, h=self.h, method=cs.method, rest=cs.rest, loop=self.loop)
        self.row = np.zeros(len(lay.log_columns))
        self._t = lay.log_columns.index("t")
        self.fault_models: list = []                      # (none: the plant server's summary lists them)
        self.repeat = cs.repeat                           # the drives again every scenario's duration (the panel)
        self.held: dict[int, float] = {}                  # input -> value held by the live panel (steering)
        self.fluid = dict(c.fluid)                        # the parameters before derivation, as steered
        self.params = {n: dict(comp.params) for n, comp in c.components.items()}
        self.reset()

    def reset(self) -> None:
        """Back to the state at rest, no command received, no watchdog trip counted."""
        ffi = self.cc.ffi
        self.y, self.m = self.y0.copy(), self.m0.copy()
        if self.loop is not None:                       # its sensor's noise from its seed again
            self._rng = self.loop.streams()
            self._sensor = self.loop.sensor_args(self.cc, self._rng, self.h)
        self.u = self.u0.copy()                         # the inputs of the last step (applied)
        self._c = [ffi.from_buffer("double[]", self.P), ffi.from_buffer("double[]", self.y),
                   ffi.from_buffer("int64_t[]", self.m), ffi.from_buffer("double[]", self.u),
                   ffi.from_buffer("double[]", self.row)]          # (the C's views of them, made once)
        self.cmd = self.u0.tolist()                     # the latest value of each input the controller set
        self.held.clear()                               # (no input held, no fault switched: as the C plant's)
        self.set_inputs = set(self.commanded)           # the inputs set by the controller so far (the loop's
        #                                                 command, the one holding the piston until it speaks)
        self.path = CommandPath(self.network, self.h, seed=self.seed, timeout=self.watchdog_timeout,
                                stride=1 + len(self.inputs), hold_kp=self.hold_kp)   # (mask, values)
        self.link = self.path.link                      # its watchdog (counts from step 0)
        self._sat = core_ffi.new("int *")
        self.saturated = False
        self.k = 0
        self._row(0.0)

    def warm_up(self) -> None:
        """One step, then back to rest: the first step of a real-time run pays no page faults."""
        self.step(0, None)
        self.reset()

    def _row(self, t: float) -> None:
        P, y, m, u, row = self._c
        self.cc.lib.hc_row(P, y, m, u, t, row)

    def step(self, k: int, command: tuple[int, tuple] | None) -> np.ndarray:
        """Advance step k -> k+1 with the inputs the controller sent for it ((mask, values); None: nothing new).
        Returns the inputs that drove the step (SI)."""
        packet = self.path.packet
        if command is not None:
            packet[0] = command[0]
            for j, v in enumerate(command[1]):
                packet[1 + j] = v
        x = float(self.row[self._meas]) if self.loop is not None else 0.0     # (what the safe state "hold" holds)
        if self.path.step(k, command is not None, x):  # (the network's faults, the watchdog: circuits/network.py)
            mask = int(packet[0])
            for j in range(len(self.inputs)):
                if mask >> j & 1:
                    self.cmd[j] = packet[1 + j]
                    self.set_inputs.add(j)
        u = self.u
        nd = len(self.drives)
        u[:] = self.drives[k % nd if self.repeat else min(k, nd - 1)]
        for j, v in self.held.items():
            u[j] = v
        self.saturated = False
        for j in self.set_inputs:           # (the safe state, a command_inversion, the range: hh_path_apply)
            if j == self._cmd:              # (the loop's command: in the safe state "hold", its P law on x)
                u[j] = core.hh_path_apply_held(self.path.c, self.cmd[j], self.lo[j], self.hi[j], x, self._sat)
            else:
                u[j] = core.hh_path_apply(self.path.c, self.cmd[j], self.lo[j], self.hi[j], self._sat)
            self.saturated |= bool(self._sat[0])
        P, y, m, uc, _ = self._c
        status = self.cc.lib.hc_step(P, y, m, uc, self.method, self.h)
        self.k = k + 1
        if status != 0:
            lay = self.layout
            modes = {name: lay.mode_names[name][int(self.m[i])] for i, name in enumerate(lay.modes)}
            raise SimulationDiverged(self.k * self.h, modes, {s: float(self.y[i]) for i, s in enumerate(lay.states)},
                                     divergence_reason(self.cc, self.P, self.y, status))
        self._row(self.k * self.h)
        return u

    # -- steering (the live panel; events of hydrohil.simulation.steering, applied at a step boundary) ----------
    def hold(self, name: str, value: float | None) -> None:
        """Input ``name`` held at ``value`` (SI, within its range) from the next step on; None: back to its
        drive. (An input the controller drives is not held: the event parser refuses it.)"""
        j = self.layout.inputs.index(name)
        if value is None:
            self.held.pop(j, None)
        else:
            self.held[j] = float(value)

    def switch_fault(self, on: bool, inputs: dict, sensor: int, network: int, k: int) -> None:
        """A scenario's fault switched on or off at the boundary of step k, from then on
        (:class:`hydrohil.circuits.faults.LiveSwitch`, the panel's ``fault`` event): ``inputs`` held at their
        values; the loop's sensor's fault row ``sensor`` or the command path's fault ``network`` active on [k,
        never) or on no step (a stuck sensor's memory fresh, an offset's drift from k)."""
        from hydrohil.circuits.network import NEVER
        for name, value in inputs.items():
            self.hold(name, value)
        if sensor >= 0 and self.loop is not None:
            sensor_fault_window(self._sensor[0], sensor, on, k, self.h)
        if network >= 0 and self.network:
            f = self.path._faults + network
            f.k_start, f.k_end = (k, NEVER) if on else (k, k)

    def set_value(self, key: str, value: float) -> None:
        """Parameter ``key`` (``component.key`` or ``fluid.key``, SI, in its range: the event parser checks)
        changed from the next step on; the values derived from it follow (:func:`parameter_change`). ValueError
        (nothing changed) when the component's parameters no longer fit together."""
        slots, self.params, self.fluid = parameter_change(self.circuit, self.layout, self.params, self.fluid, key,
                                                          value)
        for i, v in slots.items():
            self.P[i] = v

    def restart(self) -> None:
        """The model's states and modes back to rest (the scenario's); the step count, the drives and the
        reference go on, held inputs, changed parameters and the command path stay."""
        self.y[:], self.m[:] = self.y0, self.m0
        self._row(0.0)

    @property
    def t(self) -> float:
        """The plant time of the current state (its log row's time column)."""
        return float(self.row[self._t])

    @property
    def signal_row(self) -> np.ndarray:
        """The signals of the current state (its log row after the time), in the order of ``signals``."""
        return self.row[self._t + 1:]

    def read(self) -> list[float]:
        """The signals of the current state as the controller reads them (the loop's measured one through its
        sensor), in the order of ``signals``."""
        values = self.signal_row.tolist()
        if self.loop is not None:
            values[self._meas - self._t - 1] = self.cc.lib.hc_sensed(float(self.row[self._meas]), *self._sensor,
                                                                     self.k)
        return values


def sensor_fault_window(vec, row: int, on: bool, k: int, h: float) -> None:
    """Row ``row`` of a loop's sensor vector (:meth:`hydrohil.circuits.run.Loop.sensor_vector`: 7 values, then 6
    per fault: type, first step, end step, a, b, memory) active on [k, never) or on no step; switched on, its
    memory fresh (a stuck reading's NaN, an offset's drift from step k's time). rt_circuit.c's steer_fault
    does the same to its copy."""
    from hydrohil.circuits.faults import SENSOR_FAULTS
    from hydrohil.circuits.network import NEVER
    base = 7 + 6 * row
    vec[base + 1], vec[base + 2] = (float(k), float(NEVER)) if on else (float(k), float(k))
    if on:
        kind = SENSOR_FAULTS[int(vec[base]) - 1]
        vec[base + 5] = float("nan") if kind in ("sensor_stuck", "encoder_count_loss") else k * h


def parameter_change(c, layout, params: dict, fluid: dict, key: str, value: float) -> tuple[dict, dict, dict]:
    """A parameter ``key`` (``component.key`` or ``fluid.key``) changed to ``value`` on a circuit whose current
    parameters are ``params`` (component -> its parameters, SI) and ``fluid``: the slots of the parameter vector
    it changes ({slot: value}: its own, and the values derived from it, by the circuit file's rule,
    ``component_values``, for every component it concerns) and the new parameters and fluid. What the Python
    plant applies, and what the panel hands the standalone C plant (which has no derivations of its own); a
    derived value the change leaves as it was is not in it.
    ValueError (nothing changed) when a component's parameters no longer fit together."""
    from hydrohil.circuits.circuit import component_values
    slot = layout.slot
    name, _, k = key.partition(".")
    before = {n: component_values(cp.type, params[n], fluid) for n, cp in c.components.items()
              if (name == "fluid" or n == name) and cp.type.derived}
    fluid, params = dict(fluid), {n: dict(v) for n, v in params.items()}
    (fluid if name == "fluid" else params[name])[k] = float(value)
    slots = {slot[key]: float(value)}
    for n in before:                                     # the derived values that change with it
        comp = c.components[n]
        try:
            values = component_values(comp.type, params[n], fluid)
        except ValueError as exc:
            raise ValueError(f"{key}: {n}: {exc}") from None
        for dk, _ in comp.type.derived:
            if not (values[dk] == before[n][dk] or (values[dk] != values[dk] and before[n][dk] != before[n][dk])):
                slots[slot[f"{n}.{dk}"]] = float(values[dk])
    return slots, params, fluid

