"""Fault injection: the ``[[faults]]`` entries of a scenario and the injector that applies them.

Each fault is active on the steps k with ``start <= k*h < end`` (``end`` omitted: to the end of the run).
The same :class:`FaultInjector` runs inside the virtual rig (:mod:`hydrohil.simulation.rig`) offline, in
lock-step and in real time, so a scenario's faults act identically in all three. Random faults (sensor
noise, packet loss, reordering) draw from their own generator seeded by ``[hil] seed`` and the fault's
index, so a run is reproducible.

=====================  ====================================================================================
type                   effect (parameters)
=====================  ====================================================================================
sensor_stuck           the sensor keeps reporting its value at ``start`` (``sensor``)
sensor_offset          reports value + ``offset`` + ``drift``·(t − start) (``sensor``, ``offset`` [m|Pa],
                       ``drift`` [m/s|Pa/s])
sensor_noise           reports value + Gaussian noise of ``std`` [m|Pa] (``sensor``)
sensor_dropout         reports 0 (broken wire) (``sensor``)
encoder_count_loss     the encoder misses ``fraction`` of its counts; the lost counts stay lost afterwards
spool_stuck            the spool freezes where it is (velocity set to 0, velocity limit 0)
valve_bandwidth        spool natural frequency ωn multiplied by ``factor`` (0 < factor <= 1)
valve_leakage          worn lands: ``section`` [(l/min)/√bar] added to each of the four pseudo-sections
command_inversion      the valve receives −ū (a swapped connector)
supply_pressure        supply pressure set to ``ps`` [Pa] (a drop; ``ps`` = tank pressure: loss of supply)
seal_wear              internal leakage conductance set to ``g_lkc`` [m³/(s·Pa)] (eq 22)
hose_burst             line ``line`` (1 or 2) drains to tank through ``section`` [(l/min)/√bar]
load_change            moved mass set to ``mass`` [kg] and/or external force to ``force`` [N]
packet_loss            each command is lost with ``probability`` (the plant holds the previous one)
network_delay          commands reach the valve ``delay`` [s] late (rounded to whole plant steps)
reordering             with ``probability`` a command arrives after its successor and is dropped as stale
controller_silence     no command reaches the plant (the watchdog trips after its timeout)
=====================  ====================================================================================
``sensor`` is one of ``position`` (the encoder), ``p1``, ``p2``, ``ps``, ``pt``.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import Field, model_validator

from hydrohil.models.layout import BURST1, BURST2, FLOAD, G_LKC, LV, MASS, PS, PT, VALVE_WEAR, VS, WN
from hydrohil.parameters.schema import StrictModel

SENSORS = ("position", "p1", "p2", "ps", "pt")
Sensor = Literal["position", "p1", "p2", "ps", "pt"]


class _Fault(StrictModel):
    start: float = Field(ge=0, le=3600, description="first instant the fault is active [s]")
    end: float | None = Field(None, gt=0, le=3600, description="instant it ends [s] (omit: to the end of the run)")

    @model_validator(mode="after")
    def _order(self):
        if self.end is not None and self.end <= self.start:
            raise ValueError(f"end ({self.end} s) must be after start ({self.start} s)")
        return self


class SensorStuck(_Fault):
    type: Literal["sensor_stuck"]
    sensor: Sensor


class SensorOffset(_Fault):
    type: Literal["sensor_offset"]
    sensor: Sensor
    offset: float = Field(0.0, ge=-1e8, le=1e8, description="[m] or [Pa]")
    drift: float = Field(0.0, ge=-1e8, le=1e8, description="[m/s] or [Pa/s]")


class SensorNoise(_Fault):
    type: Literal["sensor_noise"]
    sensor: Sensor
    std: float = Field(gt=0, le=1e8, description="standard deviation [m] or [Pa]")


class SensorDropout(_Fault):
    type: Literal["sensor_dropout"]
    sensor: Sensor


class EncoderCountLoss(_Fault):
    type: Literal["encoder_count_loss"]
    fraction: float = Field(gt=0, le=1, description="fraction of the counts missed [-]")


class SpoolStuck(_Fault):
    type: Literal["spool_stuck"]


class ValveBandwidth(_Fault):
    type: Literal["valve_bandwidth"]
    factor: float = Field(gt=0, le=1, description="multiplies the spool natural frequency [-]")


class ValveLeakage(_Fault):
    type: Literal["valve_leakage"]
    section: float = Field(gt=0, le=10, description="added to each pseudo-section [(l/min)/sqrt(bar)]")


class CommandInversion(_Fault):
    type: Literal["command_inversion"]


class SupplyPressure(_Fault):
    type: Literal["supply_pressure"]
    ps: float = Field(ge=0, le=1e8, description="supply pressure during the fault [Pa]")


class SealWear(_Fault):
    type: Literal["seal_wear"]
    g_lkc: float = Field(ge=0, le=1e-9, description="internal leakage conductance [m^3/(s.Pa)]")


class HoseBurst(_Fault):
    type: Literal["hose_burst"]
    line: Literal[1, 2]
    section: float = Field(4.31, gt=0, le=100, description="opening to tank [(l/min)/sqrt(bar)] "
                                                           "(default: a fully open valve port)")


class LoadChange(_Fault):
    type: Literal["load_change"]
    mass: float | None = Field(None, gt=0, le=1e5, description="moved mass [kg]")
    force: float | None = Field(None, ge=-1e7, le=1e7, description="external force, + opposes extension [N]")

    @model_validator(mode="after")
    def _some(self):
        if self.mass is None and self.force is None:
            raise ValueError("load_change needs mass and/or force")
        return self


class PacketLoss(_Fault):
    type: Literal["packet_loss"]
    probability: float = Field(gt=0, le=1, description="probability that a command is lost [-]")


class NetworkDelay(_Fault):
    type: Literal["network_delay"]
    delay: float = Field(gt=0, le=1, description="extra command latency [s]")


class Reordering(_Fault):
    type: Literal["reordering"]
    probability: float = Field(gt=0, le=1, description="probability that a command arrives after the next [-]")


class ControllerSilence(_Fault):
    type: Literal["controller_silence"]


_CLASSES = (SensorStuck, SensorOffset, SensorNoise, SensorDropout, EncoderCountLoss, SpoolStuck, ValveBandwidth,
            ValveLeakage, CommandInversion, SupplyPressure, SealWear, HoseBurst, LoadChange, PacketLoss, NetworkDelay,
            Reordering, ControllerSilence)
Fault = Annotated[Union[_CLASSES], Field(discriminator="type")]
FAULT_TYPES = tuple(c.model_fields["type"].annotation.__args__[0] for c in _CLASSES)
NETWORK = ("packet_loss", "network_delay", "reordering", "controller_silence")
PARAMETER = ("spool_stuck", "valve_bandwidth", "valve_leakage", "supply_pressure", "seal_wear", "hose_burst",
             "load_change")


class FaultInjector:
    """Applies a scenario's faults step by step (see the module docstring).

    Per step k: :meth:`begin_step` (parameter faults into the model's vector ``p``, state resets),
    :meth:`deliver` (network faults on the controller's command), :meth:`valve_command` (command
    faults), and after the step :meth:`sense_position` / :meth:`sense_pressure` (sensor faults).
    ``mask`` has bit i set while fault i is active (logged every step).
    """

    def __init__(self, faults: list, base_p: np.ndarray, h: float, seed: int = 0):
        self.faults = list(faults)
        if len(self.faults) > 62:
            raise ValueError("at most 62 faults per scenario")
        self.base = base_p.copy()
        self.h = h
        self.k_start = [int(math.ceil(f.start / h - 1e-9)) for f in self.faults]
        self.k_end = [int(math.ceil(f.end / h - 1e-9)) if f.end is not None else 1 << 62 for f in self.faults]
        self.seed = seed
        self.rng = [np.random.default_rng([seed, i]) for i in range(len(self.faults))]
        self.mask = 0
        self.stuck_value: dict[int, float] = {}
        self.lost_counts = 0.0
        self.last_counts: float | None = None
        self.delay_fifo: deque = deque()
        self.held_back: float | None = None
        self.k = 0

    def active(self, i: int) -> bool:
        return bool(self.mask >> i & 1)

    def _of_type(self, *types):
        return [(i, f) for i, f in enumerate(self.faults) if self.mask >> i & 1 and f.type in types]

    def begin_step(self, k: int, p: np.ndarray, y: np.ndarray) -> int:
        """Update the active set for step k; on a change rebuild ``p`` from the base values plus the active
        parameter faults (in file order). Returns the mask."""
        self.k = k
        mask = 0
        for i in range(len(self.faults)):
            if self.k_start[i] <= k < self.k_end[i]:
                mask |= 1 << i
        if mask != self.mask:
            started = mask & ~self.mask
            self.mask = mask
            self.rebuild(p, y, started)
        return mask

    def rebuild(self, p: np.ndarray, y: np.ndarray, started: int = 0) -> None:
        """``p`` = the base values plus the active parameter faults (in slot order); ``started``: the faults
        that begin now (a stuck spool stops where it is)."""
        mask = self.mask
        p[:] = self.base
        for i, f in self._of_type(*PARAMETER):
            if f.type == "spool_stuck":
                p[LV] = 0.0
                if started >> i & 1:
                    y[VS] = 0.0
            elif f.type == "valve_bandwidth":
                p[WN] = self.base[WN] * f.factor
            elif f.type == "valve_leakage":
                p[VALVE_WEAR] += f.section
            elif f.type == "supply_pressure":
                p[PS] = max(f.ps, self.base[PT])
            elif f.type == "seal_wear":
                p[G_LKC] = f.g_lkc
            elif f.type == "hose_burst":
                p[BURST1 if f.line == 1 else BURST2] += f.section
            elif f.type == "load_change":
                if f.mass is not None:
                    p[MASS] = f.mass
                if f.force is not None:
                    p[FLOAD] = f.force
        for i in range(len(self.faults)):
            if not (mask >> i & 1):
                self.stuck_value.pop(i, None)

    def add(self, fault, k: int) -> int:
        """Switch ``fault`` on from step k until :meth:`end` (the live panel): the first slot that is free
        (never used, or its fault ended by k) is reused; its random draws restart from the slot's seed."""
        for i, end in enumerate(self.k_end):
            if end <= k and not self.mask >> i & 1:
                break
        else:
            i = len(self.faults)
            if i >= 62:
                raise ValueError("at most 62 faults at a time")
            self.faults.append(None)
            self.k_start.append(0)
            self.k_end.append(0)
            self.rng.append(None)
        self.faults[i], self.k_start[i], self.k_end[i] = fault, k, 1 << 62
        self.rng[i] = np.random.default_rng([self.seed, i])
        return i

    def end(self, i: int, k: int) -> None:
        """Switch the fault in slot ``i`` off from step k on."""
        if not 0 <= i < len(self.faults) or self.k_end[i] <= k:
            raise ValueError(f"no active fault in slot {i}")
        self.k_end[i] = k

    def silence_active(self) -> bool:
        """True while an injected controller silence keeps every command from the plant (this step)."""
        return bool(self._of_type("controller_silence"))

    def deliver(self, u: float | None) -> float | None:
        """Network faults on the command sent for this step (None: nothing sent). Returns the command that
        reaches the plant this step, or None (the plant holds its last command)."""
        delay_steps = 0
        for i, f in self._of_type(*NETWORK):
            if f.type == "controller_silence":
                u = None
            elif f.type == "packet_loss" and u is not None and self.rng[i].random() < f.probability:
                u = None
            elif f.type == "network_delay":
                delay_steps = max(delay_steps, int(round(f.delay / self.h)))
            elif f.type == "reordering" and u is not None:
                if self.held_back is not None:       # the held-back command arrives after this one: stale
                    self.held_back = None
                elif self.rng[i].random() < f.probability:
                    self.held_back, u = u, None
        if delay_steps or self.delay_fifo:
            self.delay_fifo.append(u)
            if len(self.delay_fifo) <= delay_steps:
                return None
            while len(self.delay_fifo) > delay_steps + 1:      # the delay shrank or ended: newest wins
                self.delay_fifo.popleft()
            return self.delay_fifo.popleft()
        return u

    def valve_command(self, u: float) -> float:
        return -u if self._of_type("command_inversion") else u

    def _sense(self, sensor: str, value: float, t: float) -> float:
        for i, f in self._of_type("sensor_stuck", "sensor_offset", "sensor_noise", "sensor_dropout"):
            if f.sensor != sensor:
                continue
            if f.type == "sensor_stuck":
                value = self.stuck_value.setdefault(i, value)
            elif f.type == "sensor_offset":
                value += f.offset + f.drift * max(t - f.start, 0.0)
            elif f.type == "sensor_noise":
                value += f.std * self.rng[i].standard_normal()
            else:
                value = 0.0
        return value

    def sense_position(self, counts: float, resolution: float, t: float) -> float:
        """Encoder counts as reported: count loss, then the position sensor faults (in metres)."""
        if self.last_counts is not None:
            for _, f in self._of_type("encoder_count_loss"):
                self.lost_counts += math.copysign(f.fraction * abs(counts - self.last_counts),
                                                  counts - self.last_counts)
        self.last_counts = counts
        c = counts - round(self.lost_counts)
        if not self.mask:
            return c
        x = self._sense("position", c * resolution, t)
        return float(np.floor(x / resolution + 0.5))

    def sense_pressure(self, sensor: str, value: float, t: float) -> float:
        return self._sense(sensor, value, t) if self.mask else value
