"""Fault injection: the ``[[faults]]`` entries of a scenario, as the C core's rig step injects them.

Each fault is active on the steps k with ``start <= k*h < end`` (``end`` omitted: to the end of the run).
The rig step (``core/rig.c``: a fault table apart from the model's parameters) runs inside every plant —
the virtual rig offline (:mod:`hydrohil.simulation.rig`), the Python HIL plant and the standalone C plant —
so a scenario's faults act identically offline, in lock-step and in real time, bit for bit. Random faults
(sensor noise, packet loss, reordering) draw from their own stream (xoshiro256**) seeded by ``[hil] seed``
and the fault's slot, so a run is reproducible.

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
from typing import Annotated, Literal, Union

from pydantic import Field, model_validator

from hydrohil.core import ffi, lib
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


# the fields of a fault that are its parameters (the C table's a, b, in declaration order), per type
PARAMS = {t: tuple(n for n in c.model_fields if n not in ("type", "start", "end", "sensor"))
          for t, c in zip(FAULT_TYPES, _CLASSES)}


_C_NAMES = tuple(ffi.string(lib.hh_fault_type_name(i)).decode() for i in range(lib.HH_NFAULT_TYPES))
if _C_NAMES != FAULT_TYPES or lib.HH_NSENSORS != len(SENSORS) or max(map(len, PARAMS.values())) > 2:
    raise ImportError(f"hydrohil's C core knows the faults {_C_NAMES}, this package {FAULT_TYPES}: rebuild it "
                      "(pip install -e .)")


def k_range(fault, h: float) -> tuple[int, int]:
    """(first step, step after the last) a scheduled fault is active: start <= k·h < end."""
    never = 1 << 62
    return (int(math.ceil(fault.start / h - 1e-9)),
            int(math.ceil(fault.end / h - 1e-9)) if fault.end is not None else never)


def fault_struct(fault, h: float):
    """The C core's ``hh_fault`` of a validated fault (its step range from start/end at step h)."""
    f = ffi.new("hh_fault *")
    f.type = FAULT_TYPES.index(fault.type)
    f.sensor = SENSORS.index(fault.sensor) if hasattr(fault, "sensor") else lib.HH_SENSOR_POSITION
    values = [getattr(fault, n) for n in PARAMS[fault.type]]
    values = [math.nan if v is None else float(v) for v in values] + [0.0] * (2 - len(values))
    f.a, f.b = values
    f.start = fault.start
    f.k_start, f.k_end = k_range(fault, h)
    return f
