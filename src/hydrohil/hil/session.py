"""A live-panel session of the real-time plant: its folder, the applied events and commands, recordings.

Session folder (``hydrohil panel --out DIR``: ``DIR/session-N``)::

    events.jsonl            every applied steering event with its step index k (hydrohil.simulation.steering)
    commands.f64            the valve command applied at each step (float64, little-endian, k = 0, 1, ...);
                            a circuit's plant: every input as applied, one row of them per step
    timing.json             the whole session's timing and verdict (at its end)
    recordings/NAME/        plant_log.csv + timing.json of the recorded steps (+ the panel's report)

From ``events.jsonl`` and ``commands.f64`` the session replays exactly (:func:`replay_session`, a circuit's:
:func:`hydrohil.hil.circuit.replay_circuit_session`), whatever the machine did to the timing: the state of every
step, bit for bit.
"""

from __future__ import annotations

import time
from array import array
from pathlib import Path

import numpy as np

from hydrohil.core import shape
from hydrohil.hil.stats import LatencyHistogram
from hydrohil.simulation.steering import EventLog

COMMANDS_FILE = "commands.f64"
FLUSH_EVERY = 2000        # commands buffered in memory between two writes (1 s at 0.5 ms: 16 kB)


class Recording:
    """Rows k0+1 .. of the plant log into ``folder/plant_log.csv``, with the window's own histograms."""

    def __init__(self, server, folder: Path, k0: int):
        self.folder, self.k0 = folder, k0
        folder.mkdir(parents=True, exist_ok=True)
        self.log = server.open_log(folder / "plant_log.csv")
        self.jitter, self.compute = LatencyHistogram(), LatencyHistogram()
        self.counters0 = server.counter_values()
        self.t0_ns = time.perf_counter_ns()

    def write(self, row, jitter_ns: int, compute_ns: int) -> None:
        self.log.write(row)
        self.jitter.add(jitter_ns)
        self.compute.add(compute_ns)


class PanelSession:
    def __init__(self, server, folder: Path):
        self.server, self.folder = server, folder
        folder.mkdir(parents=True, exist_ok=True)
        self.events = EventLog(folder / "events.jsonl")
        self.cmd_file = open(folder / COMMANDS_FILE, "wb")
        self.cmds = array("d")
        self.recording: Recording | None = None

    def command(self, *u: float) -> None:
        """The command(s) applied at a step: the valve's (the paper's rig), or every input of a circuit."""
        self.cmds.extend(u)
        if len(self.cmds) >= FLUSH_EVERY:
            self.flush()

    def record_start(self, folder: Path, k: int) -> dict:
        if self.recording is not None:
            raise ValueError(f"already recording into {self.recording.folder}")
        self.recording = Recording(self.server, folder, k)
        return {"dir": str(folder)}

    def record_stop(self, k: int) -> dict:
        rec = self.recording
        if rec is None:
            raise ValueError("not recording")
        self.recording = None
        rec.log.close()
        self.flush()
        from hydrohil.simulation.outputs import finite_or_none, write_json
        s = self.server
        timing = finite_or_none(s._timing(k - rec.k0, rec.t0_ns, time.perf_counter_ns(), s.rt, 0, window=rec))
        write_json(rec.folder / "timing.json", timing)
        return {"dir": str(rec.folder), "steps": k - rec.k0, "verdict": timing["verdict"]["verdict"]}

    def flush(self) -> None:
        self.cmds.tofile(self.cmd_file)
        self.cmd_file.flush()
        del self.cmds[:]

    def close(self, k: int) -> None:
        if self.recording is not None:
            try:
                self.record_stop(k)
            except OSError:
                pass
        self.flush()
        self.cmd_file.close()
        self.events.close()


def read_commands(folder: Path) -> np.ndarray:
    """The applied valve commands of a session (``commands.f64``), one per step from k = 0."""
    return np.fromfile(Path(folder) / COMMANDS_FILE, dtype="<f8")


def replay_session(sc, folder: Path, steps: int | None = None, keep_from: int = 0) -> dict[str, np.ndarray]:
    """A session's applied commands and plant events (:func:`replay_applied`) up to step ``steps``; the
    columns of steps ``keep_from`` .. ``steps`` kept (index k − keep_from)."""
    from hydrohil.simulation.steering import read_events
    u = read_commands(folder)
    n = len(u) if steps is None else min(int(steps), len(u))
    return replay_applied(sc, u[:n], read_events(Path(folder) / "events.jsonl", "plant"), keep_from=keep_from)


# the model's columns a replay keeps (name -> column of the simulation log, core/shape.py)
REPLAY_COLUMNS = {c: shape.LOG_COLUMNS.index(c) for c in ("xs", "vs", "p1", "p2", "xp", "vp", "z", "travel_mode",
                                                          "friction_mode", "spool_mode")}


def replay_applied(sc, u, events: dict | None = None, keep_from: int = 0) -> dict[str, np.ndarray]:
    """The valve commands that drove a run (``u[k]`` applied at step k: a plant log's column ``u`` from its
    second row, or a session's ``commands.f64``) and its plant events replayed through a fresh rig of
    scenario ``sc`` (its faults act as they did) by the core's sampled loop (``hh_sim_run``, the rig's step
    with the applied commands): per step k = 0..len(u) the model's state and modes at step k
    (:data:`REPLAY_COLUMNS`) and ``faults``. The states equal the run's bit for bit
    when it stepped the model right, however late its commands came. ``keep_from``: only steps from there on
    are kept (index k − keep_from), so a long session's recording needs memory for its own steps only."""
    from hydrohil.core import lib
    from hydrohil.simulation.steering import apply_plant_event
    from hydrohil.simulation.rig import VirtualRig
    s = sc.scenario
    events = events or {}
    u = np.asarray(u, dtype=np.float64)
    n = len(u)
    rig = VirtualRig(sc.params, s.plant_step, s.hil, s.faults, s.initial.model_dump())
    k0 = min(max(int(keep_from), 0), n)

    def on_event(k):
        for ev in events[k]:
            apply_plant_event(rig, ev, k)

    status, _, log, rig_log = rig.plant.sim.run(n, 1, np.append(u, 0.0), rig=rig.c, applied=True, on_event=on_event,
                                                event_steps=[k for k in events if 0 <= k < n], log_from=k0)
    if status != lib.HH_OK:
        raise rig._diverged()
    cols = {c: log[:, i].copy() for c, i in REPLAY_COLUMNS.items()}
    cols["faults"] = rig_log[:, lib.HH_RLOG_FAULTS].copy()
    return cols
