"""The command path's watchdog as Python reads it: one set of properties over an ``hh_watchdog`` (core/watchdog.c)
for every rig that has one (the paper's VirtualRig, a circuit's CircuitRig)."""

from __future__ import annotations

WATCHDOG_TIMEOUT = 0.05      # [s]: no command for this long -> the safe state ([hil] watchdog_timeout's default)


class WatchdogCounters:
    """``watchdog`` and its counters, read from ``self.link`` (the rig's ``hh_watchdog``)."""

    link: object

    @property
    def watchdog(self) -> bool:
        """The safe state is on."""
        return bool(self.link.active)

    @property
    def watchdog_trips(self) -> int:
        return int(self.link.trips)

    @property
    def watchdog_trips_unexplained(self) -> int:
        """Trips with no injected fault to explain the silence (they count against a run)."""
        return int(self.link.trips_unexplained)

    @property
    def commands_delivered(self) -> int:
        return int(self.link.delivered)
