"""The verdict on a HIL run: VALID when its timing let the controller close the loop as it would on the rig.

A real-time run is INVALID when, over the steps it ran (``[hil]`` settings, defaults in brackets):
  * commands came late on more than ``max_late_commands`` of the steps (1 %): the plant stepped with a
    command that had not answered its previous sensor packet, so the loop ran with an extra step of delay;
  * more than ``max_overruns`` of the steps (1 %) started more than one step late;
  * a step started more than ``max_stall`` late (50 ms): the plant stood still that long;
  * the watchdog tripped more than ``max_watchdog_trips`` times (0) without an injected network or silence
    fault to explain it (a controller that went silent on its own).
A run that never heard its peer (``link_error``) or whose model diverged (``fault``) is INVALID too.
Lock-step runs have no clock: only the last two and the watchdog criterion apply.
"""

from __future__ import annotations

from hydrohil.errors import HydrohilError, Interrupted, LinkError, RunInvalid
from hydrohil.simulation.scenario import HilCfg


def judge(timing: dict, hil: HilCfg) -> dict:
    """``{"valid", "verdict", "reasons", "criteria"}`` for a plant's timing summary (``timing.json``)."""
    reasons = []
    steps = timing.get("steps") or 0
    if timing.get("link_error"):
        reasons.append(timing["link_error"])
    if timing.get("fault"):
        reasons.append(f"the model failed: {timing['fault']}")
    if timing.get("mode") == "realtime" and steps:
        late, over = timing.get("late_commands") or 0, timing.get("overruns") or 0
        if late > hil.max_late_commands * steps:
            reasons.append(f"{late} of {steps} commands late ({late / steps:.1%} > {hil.max_late_commands:.1%})")
        if over > hil.max_overruns * steps:
            reasons.append(f"{over} of {steps} steps overran ({over / steps:.1%} > {hil.max_overruns:.1%})")
        stall_us = timing.get("jitter_us_max")
        if stall_us is not None and stall_us > hil.max_stall * 1e6:
            reasons.append(f"the plant stalled {stall_us / 1e3:.1f} ms (> {hil.max_stall * 1e3:g} ms)")
    trips = timing.get("watchdog_trips_unexplained") or 0
    if trips > hil.max_watchdog_trips:
        reasons.append(f"{trips} watchdog trip(s) without an injected fault (no command reached the plant for "
                       f"{hil.watchdog_timeout * 1e3:g} ms; allowed {hil.max_watchdog_trips})")
    return {"valid": not reasons, "verdict": "INVALID" if reasons else "VALID", "reasons": reasons,
            "criteria": {"max_late_commands": hil.max_late_commands, "max_overruns": hil.max_overruns,
                         "max_stall_s": hil.max_stall, "max_watchdog_trips": hil.max_watchdog_trips}}


def summary_line(timing: dict) -> str:
    """``VALID`` or ``INVALID: reason; reason`` for the end of a run."""
    v = timing.get("verdict") or {}
    if v.get("valid"):
        return "VALID"
    return "INVALID: " + "; ".join(v.get("reasons") or ["no verdict"])


BUSY_ADVICE = ("the machine was too busy to keep the plant on time: close other programs (or stop background "
               "jobs) and run again; `--lockstep` gives a deterministic run without a clock; on a dedicated HIL "
               "machine, isolate two CPUs for the plant and the controller")


def raise_for_outcome(timing: dict, what: str = "run") -> None:
    """Raise what the end of a run means for the exit code (errors.py): no peer (4), a model failure (1),
    a stop by signal (130 / 143), INVALID timing (3); return quietly when the run is VALID."""
    if timing.get("link_error"):
        raise LinkError(timing["link_error"])
    if timing.get("fault"):
        raise HydrohilError(timing["fault"])
    if timing.get("stop_signal"):
        raise Interrupted(timing["stop_signal"], f"{what} stopped by signal after {timing.get('steps')} steps; "
                          f"{summary_line(timing)}")
    v = timing.get("verdict") or {}
    if not v.get("valid", True):
        raise RunInvalid(f"{what} INVALID: " + "; ".join(v["reasons"]), v["reasons"])
