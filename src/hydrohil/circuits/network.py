"""The network between a circuit's controller and its plant: a scenario's network faults on the command packets
(``packet_loss``, ``network_delay``, ``reordering``, ``controller_silence``: the paper's rig's, docs/faults in
the README), then the watchdog, and a ``command_inversion`` (the commands negated at the plant, a swapped
connector): the core's command path (core/link.c, ``hh_path``) that the offline loop (the
generated ``hc_run``), the continuous reference's loop, the Python plant (:class:`~hydrohil.circuits.rig.CircuitRig`)
and the standalone C plant (rt_circuit.c) all step, so a lock-step HIL run is the offline run bit for bit.

The faults act where the plant receives the controller's packets (simulated there, as the paper's rig does):
a lost or stale packet leaves the plant on the last command that arrived, a delayed one arrives whole steps
late, a silent controller trips the watchdog after ``[hil] watchdog_timeout`` (its safe state: the commanded
inputs at 0, the end of their range nearest to it; with ``safe_state = "hold"`` the loop's command a P law of
gain ``hold_kp`` holding its measured signal at its value at the trip, the paper's rig's hold). Their random
draws come from streams seeded by ``[hil] seed`` and the fault's place in the table; a trip while a fault held
packets back is explained (it does not make a real-time run INVALID).
"""

from __future__ import annotations

import math

from hydrohil.core import ffi as core_ffi
from hydrohil.core import lib as core
from hydrohil.core.watchdog import WatchdogCounters

NETWORK_FAULTS = ("packet_loss", "network_delay", "reordering", "controller_silence", "command_inversion")
NEVER = 2 ** 62                          # (HH_NEVER: a fault without an end)


def fault_steps(start: float, end: float | None, h: float) -> tuple[int, int]:
    """The steps k of a fault active on start <= k*h < end (the paper's rig's rule, simulation/faults.py)."""
    return math.ceil(start / h - 1e-9), (math.ceil(end / h - 1e-9) if end is not None else NEVER)


def delay_slots(network: list, h: float) -> int:
    """The delay line's slots for the longest network_delay of ``network`` (0: none)."""
    delays = [a for kind, _, _, a, _ in network if kind == "network_delay"]
    return int(math.ceil(max(delays) / h)) + 2 if delays else 0


class CommandPath(WatchdogCounters):
    """``hh_path`` over the network faults ``network`` ((type, start, end or None, a, slot) from
    :func:`hydrohil.circuits.faults.network_faults`; slot: its place in the scenario's [[faults]], which with
    ``seed`` seeds its stream, as the paper's rig's) for packets of ``stride`` values at step ``h``."""

    def __init__(self, network: list, h: float, *, seed: int, timeout: float, stride: int, hold_kp: float = 0.0):
        n = len(network)
        self._faults = core_ffi.new(f"hh_fault[{max(n, 1)}]")
        for i, (kind, start, end, a, slot) in enumerate(network):
            f = self._faults + i
            f.type = getattr(core, f"HH_FAULT_{kind.upper()}")
            f.sensor, f.a, f.b, f.stuck = -1, float(a), 0.0, math.nan
            f.k_start, f.k_end = fault_steps(start, end, h)
            core.hh_fault_seed(f, int(seed), int(slot))
        cap = delay_slots(network, h)
        self._fifo = core_ffi.new(f"double[{cap * (stride + 1)}]") if cap else core_ffi.NULL
        self.c = core_ffi.new("hh_path *")
        core.hh_path_init(self.c, self._faults, n, float(h), float(timeout), int(stride), self._fifo, cap)
        self.c.hold_kp = float(hold_kp)                  # (> 0: the safe state "hold", its gain)
        self.packet = core_ffi.new(f"double[{stride}]")

    @property
    def link(self):
        """The watchdog (``hh_watchdog``: its safe state and counters)."""
        return self.c.link

    @property
    def inverted(self) -> bool:
        """A command_inversion is active at the last step: the plant applies each command negated."""
        return bool(self.c.inverted)

    def apply(self, held: float, lo: float, hi: float, x: float | None = None) -> float:
        """What a commanded input gets after :meth:`step` (hh_path_apply: the last command, 0 in the safe state,
        negated under a command_inversion, saturated to [lo, hi]); ``x``: the held signal's value now, for the
        input that holds it (hh_path_apply_held: the safe state "hold"'s P law in place of 0)."""
        if x is not None:
            return float(core.hh_path_apply_held(self.c, float(held), float(lo), float(hi), float(x), core_ffi.NULL))
        return float(core.hh_path_apply(self.c, float(held), float(lo), float(hi), core_ffi.NULL))

    def step(self, k: int, sent: bool, x: float = 0.0) -> bool:
        """Step k's packet (in :attr:`packet`; ``sent`` False: none) through the faults and the watchdog: True
        when a packet reached the plant (then in :attr:`packet`); ``x``: the held signal's value at step k (the
        safe state "hold" keeps the value of its trip)."""
        return bool(core.hh_path_step(self.c, k, int(sent), self.packet, float(x)))
