"""The virtual rig: the hybrid model in its own process, locked to the wall clock, behind UDP.

Timeline of step k (h = plant step, t0 = start instant, docs/protocol.md):
  * until t0 + k·h the plant waits on its socket (``select``; coarse sleep) and spins the last
    ``spin_ns`` (150 µs, at most 30 % of h); every command is time-stamped by the kernel as it arrives
    (:mod:`hydrohil.hil.netstamp`) and by the plant as it reads it: the round trip is reported both ways;
  * at t0 + k·h it takes the latest valid command (or the watchdog's safe command), advances the model
    one step and sends the sensor packet of the state at (k+1)·h; its answer is due before t0 + (k+1)·h.
Jitter = start of step k − (t0 + k·h); an overrun is a step that starts after t0 + (k+1)·h.
``lockstep`` replaces the clock by the exchange itself: send sensor k, block until the command that
answers it, step — deterministic, as fast as the two processes go.
"""

from __future__ import annotations

import gc
import os
import select
import signal
import socket
import time
from dataclasses import dataclass
from pathlib import Path

from hydrohil.errors import HydrohilError, InputError
from hydrohil.hil import protocol as pr
from hydrohil.hil.protocol import parse_address
from hydrohil.hil.netstamp import enable_kernel_timestamps, recv_stamped
from hydrohil.hil.session import PanelSession
from hydrohil.hil.stats import LatencyHistogram
from hydrohil.core import lib, shape
from hydrohil.models.layout import PS
from hydrohil.parameters import Parameters, load_parameters
from hydrohil.simulation.outputs import CsvStream, column_formats, finite_or_none, write_json
from hydrohil.simulation.rig import Reading, VirtualRig
from hydrohil.simulation.scenario import HilCfg, load_scenario

SPIN_NS = 150_000            # busy-wait the last 150 us before a deadline ...
SPIN_FRACTION = 0.3          # ... but at most 30 % of a step: spinning ~all the time trips the kernel's RT throttling
LOG_COLUMNS = shape.PLANT_LOG_COLUMNS         # plant_log.csv (core/shape.py: the C plant writes the same)
# (plant_log.csv column, out[] index) of the columns that are the step's outputs (t, state, ff, modes), by name
_OUT = {name: i for i, name in enumerate(shape.OUTPUT_NAMES)}
FROM_OUT = tuple((i, _OUT[c.name]) for i, c in enumerate(shape.PLANT_LOG) if c.name != "k" and c.name in _OUT)
# the same for the panel's telemetry row (shape.SIDE_PLANT_COLUMNS), and the places of its other columns
SIDE_FROM_OUT = tuple((i, _OUT[c]) for i, c in enumerate(shape.SIDE_PLANT_COLUMNS) if c in _OUT)
S_U, S_PS, S_JITTER, S_COMPUTE, S_WATCHDOG, S_FAULTS, S_X_MEAS = (
    shape.SIDE_PLANT_COLUMNS.index(c) for c in ("u", "ps", "jitter_us", "compute_us", "watchdog", "faults", "x_meas"))


def _pin(cpu: int | None):
    """Pin this process to ``cpu`` (None: leave it); returns what was granted, for ``timing.json``."""
    if cpu is None:
        return None
    try:
        os.sched_setaffinity(0, {cpu})
        return cpu
    except (OSError, AttributeError) as exc:
        return f"not permitted ({exc.__class__.__name__})"


def realtime_setup(cpu: int | None, *, spin: bool = False) -> dict:
    """Best effort: pin to ``cpu``, SCHED_FIFO priority (``spin``: normal policy at nice -20 instead: a FIFO
    task that never sleeps is stopped by the kernel's RT throttling), 1-ns timer slack, memory locked.
    Reports what was granted."""
    rep = {"cpu": _pin(cpu), "rt_priority": "not requested", "timer_slack": "default", "memory_locked": False}
    try:
        if spin:
            os.setpriority(os.PRIO_PROCESS, 0, -20)
            rep["rt_priority"] = "normal policy, nice -20 (spin)"
        else:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(50))
            rep["rt_priority"] = "SCHED_FIFO 50"
    except (OSError, AttributeError) as exc:
        rep["rt_priority"] = f"not permitted ({exc.__class__.__name__}); normal priority"
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(29, 1, 0, 0, 0) == 0:   # PR_SET_TIMERSLACK = 29
            rep["timer_slack"] = "1 ns"
        rep["memory_locked"] = libc.mlockall(3) == 0   # MCL_CURRENT | MCL_FUTURE: no paging in the loop
    except (OSError, AttributeError):
        pass
    return rep


@dataclass
class Counters:
    packets_rx: int = 0
    packets_bad: int = 0
    packets_foreign: int = 0
    packets_lost: int = 0
    packets_reordered: int = 0
    late_commands: int = 0
    packets_dropped_kernel: int = 0     # discarded by the kernel: the socket's receive buffer was full


class PlantServer:
    """Serve the virtual rig (:class:`~hydrohil.simulation.rig.VirtualRig`) over UDP. ``run()`` returns the
    timing summary (``timing.json``); with ``log`` the per-step log is streamed to ``log`` (CSV) as it runs.
    Memory stays bounded however long the run (histograms, streamed log)."""

    def __init__(self, params: Parameters, *, step: float = 5e-4, duration: float = 10.0,
                 bind: tuple[str, int] = ("127.0.0.1", 0), lockstep: bool = False, hil: HilCfg | None = None,
                 initial: dict | None = None, peer: tuple[str, int] | None = None, cpu: int | None = None,
                 faults: list | None = None, log: Path | None = None, panel: tuple[str, int] | None = None,
                 session: Path | None = None, rig=None):
        self.params, self.h, self.lockstep = params, float(step), lockstep
        self.hil = hil or HilCfg()
        self.n = int(round(duration / self.h)) if duration > 0 else 1 << 62     # 0: until stopped
        # the model behind the link (a circuit's: hydrohil.hil.circuit gives its own rig and packets)
        self.rig = rig if rig is not None else VirtualRig(params, self.h, self.hil, faults, initial)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self.sock.bind(bind)
        self.kernel_stamps = enable_kernel_timestamps(self.sock)
        self.address = self.sock.getsockname()
        self.peer = peer                      # configured controller address, else the first valid sender
        self.cpu = cpu
        # wait = "spin": busy-wait the whole period, never sleep (a halted vCPU wakes late, README)
        self.spin = self.hil.wait == "spin"
        self.spin_ns = int(self.h * 2e9) if self.spin else min(SPIN_NS, int(SPIN_FRACTION * self.h * 1e9))
        self.c = Counters()
        self.jitter, self.compute, self.rtt = LatencyHistogram(), LatencyHistogram(), LatencyHistogram()
        self.rtt_seen = LatencyHistogram()    # until the plant process read the command (its wake-up included)
        self.overruns = 0
        self.log = self.open_log(log) if log is not None else None
        self.row = [0.0] * len(LOG_COLUMNS)
        self.side_row = [0.0] * len(shape.SIDE_PLANT_COLUMNS)
        self.stop_requested = False
        self.stop_signal: int | None = None    # the signal that stopped the run (set by the CLI's handler)
        self.fault: str | None = None
        self.link_error: str | None = None
        self.on_peer = None                    # called with the controller's address once it has spoken
        # latest command
        self.cmd_u = 0.0
        self.cmd_new = False
        self.cmd_seq = -1
        self.cmd_echo = -1
        self.cmd_t_arrival = None
        self.sensor_t_send = {}
        # the live panel (hydrohil.panel): telemetry out and steering in through a side channel; the
        # session folder gets the applied events and commands (a session replays from them)
        self.side = None
        self.queued: list[dict] = []
        self.session = PanelSession(self, Path(session)) if panel is not None and session is not None else None
        if panel is not None:
            from hydrohil.hil.sidechannel import ROLE_PLANT, SideChannel
            self.side = SideChannel(panel, ROLE_PLANT, self.telemetry_columns())

    def telemetry_columns(self) -> tuple[str, ...]:
        """The columns of its telemetry rows to the live panel (the paper's rig: core/shape.py's)."""
        return shape.SIDE_PLANT_COLUMNS

    def warm_up(self) -> None:
        """Touch every path a step takes once (the first steps of a run must not pay for page faults)."""
        self.rig.warm_up()

    # -- receiving --------------------------------------------------------------------------------
    def _receive(self, data: bytes, addr, t_arr: int, t_kernel: int | None, drops: int | None = None) -> None:
        if drops is not None:
            self.c.packets_dropped_kernel = drops
        msg = pr.decode(data)
        if msg is None or not self.accepts(msg):
            self.c.packets_bad += 1
            return
        if self.peer is None:
            self.peer = addr
        elif addr != self.peer:
            self.c.packets_foreign += 1
            return
        self.c.packets_rx += 1
        if isinstance(msg, (pr.Command, pr.Inputs)):
            if msg.header.seq <= self.cmd_seq:
                self.c.packets_reordered += 1
                return
            if self.cmd_seq >= 0 and msg.header.seq > self.cmd_seq + 1:
                self.c.packets_lost += msg.header.seq - self.cmd_seq - 1
            self.cmd_seq, self.cmd_echo, self.cmd_t_arrival = msg.header.seq, msg.header.echo_seq, t_arr
            self.cmd_u = self.command_value(msg)
            self.cmd_new = True
            ts = self.sensor_t_send.pop(msg.header.echo_seq, None)
            if ts is not None:
                self.rtt_seen.add(t_arr - ts[0])
                self.rtt.add(t_arr - ts[0] if t_kernel is None else t_kernel - ts[1])
            if msg.flags & pr.CMD_STOP:
                self.stop_requested = True
        elif isinstance(msg, pr.Header) and msg.type == pr.T_BYE:
            self.stop_requested = True

    def accepts(self, msg) -> bool:
        """A packet this plant takes (the rig's: no circuit packet)."""
        return not isinstance(msg, (pr.Signals, pr.Inputs))

    def command_value(self, msg):
        """What the rig's step takes of a command packet: ū."""
        return msg.u / self.hil.command_scale

    def _drain(self) -> None:
        while True:
            try:
                data, addr, t_kernel, drops = recv_stamped(self.sock, pr.MAX_DATAGRAM + 1)
            except BlockingIOError:
                return
            self._receive(data, addr, time.perf_counter_ns(), t_kernel, drops)

    def _wait_until(self, deadline_ns: int) -> None:
        """Sleep on the socket (handling arrivals) until ``spin_ns`` before the deadline, then spin."""
        sock = self.sock
        while True:
            now = time.perf_counter_ns()
            left = deadline_ns - now - self.spin_ns
            if left <= 0:
                break
            r, _, _ = select.select([sock], [], [], left / 1e9)
            if r:
                self._drain()
        while time.perf_counter_ns() < deadline_ns:   # spin, still time-stamping arrivals
            try:
                data, addr, t_kernel, drops = recv_stamped(sock, pr.MAX_DATAGRAM + 1)
            except BlockingIOError:
                continue
            self._receive(data, addr, time.perf_counter_ns(), t_kernel, drops)

    # -- sending ----------------------------------------------------------------------------------
    def _send_sensor(self, k: int, status: int) -> Reading:
        r = self.rig.read()
        status |= r.status | (pr.ST_LOCKSTEP if self.lockstep else 0)
        t_send, t_send_wall = time.perf_counter_ns(), time.time_ns()
        self._transmit(k, pr.encode_sensor(k, t_send, self.cmd_t_arrival or 0, max(self.cmd_seq, 0), r.t, k,
                                           r.encoder, r.p1, r.p2, r.ps, r.pt, status, r.travel, r.friction, r.spool),
                       t_send, t_send_wall)
        r.status = status
        return r

    def _transmit(self, k: int, pkt: bytes, t_send: int, t_send_wall: int) -> None:
        """Send sensor packet k to the controller, its send time kept for the round trip of the answer."""
        self.sensor_t_send[k] = (t_send, t_send_wall)
        if len(self.sensor_t_send) > 64:
            self.sensor_t_send.pop(next(iter(self.sensor_t_send)))
        if self.peer is not None:
            try:
                self.sock.sendto(pkt, self.peer)
            except OSError:
                pass

    # -- one step ---------------------------------------------------------------------------------
    def _take_command(self, k: int) -> float | None:
        """The command that arrived for step k (None: nothing new since the last step)."""
        if self.cmd_echo < k and not self.rig.watchdog:
            self.c.late_commands += 1
        if not self.cmd_new:
            return None
        self.cmd_new = False
        return self.cmd_u                      # the rig saturates it

    def run(self, progress=None) -> dict:
        """Serve until ``duration`` is simulated, the controller says BYE/stop, or a fault. Returns timing."""
        if self.lockstep:      # no clock, no priority; pinned apart from a spinning controller all the same
            rt = {"cpu": _pin(self.cpu), "rt_priority": "lock-step", "timer_slack": "default"}
        else:
            rt = realtime_setup(self.cpu, spin=self.spin)
        h_ns = int(round(self.h * 1e9))
        # wait for the controller (first valid packet fixes the peer unless configured)
        if not self._wait_for_controller():
            if not self.stop_requested:      # (stopped by a signal before anyone spoke: that is the outcome)
                self.link_error = (f"no controller packet within {self.hil.connect_timeout:g} s "
                                   f"({self.c.packets_bad} bad, {self.c.packets_foreign} foreign packets)")
            if self.log is not None:
                self.log.close()
            return self._timing(0, time.perf_counter_ns(), time.perf_counter_ns(), rt, 0)
        if self.on_peer is not None:
            self.on_peer(self.peer)
        self.sock.setblocking(False)
        self.cmd_new = False             # HELLO / early packets are not commands for step 0
        gc.collect()
        gc.freeze()
        gc.disable()
        status_extra = 0
        t0 = self.t0 = time.perf_counter_ns() + 2 * h_ns
        self.rt = rt
        self._log_row(0, self._send_sensor(0, 0), 0.0, 0, 0, 0.0)
        for msg in self.queued:            # steering that came while waiting for the controller: at boundary 0
            self._steer(msg, 0)
        self.queued.clear()
        k_done = 0
        last_start = t0
        try:
            for k in range(self.n):
                if self.lockstep:
                    self._wait_lockstep(k)
                    start = time.perf_counter_ns()
                    late = 0
                else:
                    deadline = t0 + k * h_ns
                    self._wait_until(deadline)
                    start = last_start = time.perf_counter_ns()
                    self._drain()
                    late = start - deadline
                    status_extra = pr.ST_OVERRUN if late > h_ns else 0
                    self.overruns += late > h_ns
                try:
                    u = self.rig.step(k, self._take_command(k))
                except HydrohilError as exc:
                    self.fault = str(exc)
                    self._send_sensor(k + 1, pr.ST_FAULT | pr.ST_FINAL)
                    break
                final = pr.ST_FINAL if (k + 1 == self.n or self.stop_requested) else 0
                reading = self._send_sensor(k + 1, status_extra | final)
                end = time.perf_counter_ns()
                self.jitter.add(late)          # 0 in lock-step: no clock to be late against
                self.compute.add(end - start)
                k_done = k + 1
                self._log_row(k + 1, reading, (start - t0) / 1e9 if not self.lockstep else 0.0, late, end - start,
                              u)
                if self.side is not None:
                    self._telemetry(k + 1, reading, late, end - start, u)
                if progress is not None and k % 200 == 0:
                    progress(k_done, self.n)
                if self.stop_requested:
                    break
        finally:
            gc.enable()
            gc.unfreeze()
            t_end = time.perf_counter_ns()
            try:
                self._drain()        # count what arrived up to the end (fuzzing, a controller's last words)
            except OSError:
                pass
            for _ in range(3):   # tell the controller the run is over
                try:
                    if self.peer is not None:
                        self.sock.sendto(pr.encode_simple(pr.T_BYE, k_done + 1, t_end), self.peer)
                except OSError:
                    pass
            if self.log is not None:
                self.log.close()
            if self.session is not None:
                self.session.close(k_done)
            if self.side is not None:
                self.side.flush(self._counters(k_done))
        drift_ns = last_start - (t0 + max(k_done - 1, 0) * h_ns)
        return self._timing(k_done, t0, t_end, rt, drift_ns)

    def _wait_for_controller(self) -> bool:
        """Block until a valid packet from the (configured or first) controller arrived, at most
        ``[hil] connect_timeout``; stopping the run (a signal) ends the wait too."""
        end = time.monotonic() + self.hil.connect_timeout
        while self.c.packets_rx == 0 and not self.stop_requested:
            left = end - time.monotonic()
            if left <= 0:
                return False
            if self.side is not None:      # the panel is served meanwhile: stop at once, the rest at step 0
                for msg in self.side.poll():
                    if msg.get("op") == "stop":
                        self._steer(msg, 0)
                    else:
                        self.queued.append(msg)
            r, _, _ = select.select([self.sock], [], [], min(left, 0.2))
            if r:
                data, addr, t_kernel, drops = recv_stamped(self.sock, pr.MAX_DATAGRAM + 1)
                self._receive(data, addr, time.perf_counter_ns(), t_kernel, drops)
        return self.c.packets_rx > 0

    def _wait_lockstep(self, k: int) -> None:
        """Block until the command answering sensor packet k arrives. Lock-step has no clock: a slow
        controller (a loaded machine) is waited for, up to ``[hil] link_timeout``; a controller silent that
        long is gone (crashed, killed): the run ends with a link error (exit 4), its logs written."""
        limit = time.perf_counter_ns() + int(self.hil.link_timeout * 1e9)
        while self.cmd_echo < k and not self.stop_requested:
            left = limit - time.perf_counter_ns()
            if left <= 0:
                bad = f"; {self.c.packets_bad} bad packets came" if self.c.packets_bad else ""
                self.link_error = f"controller silent for {self.hil.link_timeout:g} s at step {k} (lock-step{bad})"
                self.stop_requested = True
                return
            r, _, _ = select.select([self.sock], [], [], left / 1e9)
            if r:
                self._drain()

    # -- the live panel ---------------------------------------------------------------------------
    def _counters(self, steps: int) -> tuple:
        return (self.overruns, self.c.late_commands, self.rig.watchdog_trips, self.rig.watchdog_trips_unexplained,
                self.c.packets_lost, self.side.dropped, self.jitter.max_ns, steps)

    def _telemetry(self, k: int, r: Reading, late_ns: int, compute_ns: int, u: float) -> None:
        """Row k to the panel; every batch: send it, then apply what the panel asked for at this boundary."""
        out, side = self.rig.out, self.side
        if self.session is not None:
            self.session.command(u)
        row = self.side_row
        for i, j in SIDE_FROM_OUT:
            row[i] = out[j]
        row[S_U], row[S_PS], row[S_JITTER], row[S_COMPUTE] = u, self.rig.plant.p[PS], late_ns / 1e3, compute_ns / 1e3
        row[S_WATCHDOG], row[S_FAULTS], row[S_X_MEAS] = self.rig.link.active, r.faults, r.encoder * self.rig.res
        if side.row(k, *row):
            side.flush(self._counters(k))
            msgs = side.poll()
            for msg in msgs:
                self._steer(msg, k)

    def apply_event(self, msg: dict, k: int) -> tuple:
        """A steering event validated and applied at the boundary of step k: (the event, what its answer adds)."""
        from hydrohil.simulation.steering import apply_plant_event, parse_event
        ev = parse_event(msg, "plant", source="panel")
        return ev, apply_plant_event(self.rig, ev, k)

    def _steer(self, msg: dict, k: int) -> None:
        """Apply one steering message at the boundary of step k (before it is taken), log it, answer it."""
        op = msg.get("op")
        try:
            if op == "stop":
                self.stop_requested = True
                self.side.answer(msg, k=k)
                return
            if op in ("record_start", "record_stop"):
                if self.session is None:
                    raise InputError("recording needs a session folder (hydrohil panel)", source="panel")
                info = self.session.record_start(Path(msg["dir"]), k) if op == "record_start" else \
                    self.session.record_stop(k)
                self.side.answer(msg, k=k, **info)
                return
            ev, extra = self.apply_event(msg, k)
        except (HydrohilError, ValueError, KeyError, TypeError, OSError) as exc:
            self.side.answer(msg, error=str(exc))
            return
        if self.session is not None:
            self.session.events.write(k, ev.model_dump(), **extra)
        self.side.answer(msg, k=k, **extra)

    def _log_row(self, k, r: Reading, wall, jitter_ns, compute_ns, u) -> None:
        rec = self.session.recording if self.session is not None else None
        if self.log is None and rec is None:
            return
        out, row = self.rig.out, self.row
        for i, j in FROM_OUT:
            row[i] = out[j]
        row[lib.HH_PLOG_K], row[lib.HH_PLOG_WALL], row[lib.HH_PLOG_U] = k, wall, u
        row[lib.HH_PLOG_JITTER_US], row[lib.HH_PLOG_COMPUTE_US] = jitter_ns / 1e3, compute_ns / 1e3
        row[lib.HH_PLOG_CMD_SEQ] = self.cmd_seq
        row[lib.HH_PLOG_CMD_AGE] = k - 1 - self.cmd_echo if self.cmd_seq >= 0 else -1
        row[lib.HH_PLOG_WATCHDOG] = self.rig.watchdog
        row[lib.HH_PLOG_ENCODER], row[lib.HH_PLOG_FAULTS], row[lib.HH_PLOG_STATUS] = r.encoder, r.faults, r.status
        row[lib.HH_PLOG_P1_MEAS], row[lib.HH_PLOG_P2_MEAS], row[lib.HH_PLOG_PS_MEAS] = r.p1, r.p2, r.ps
        if self.log is not None:
            self.log.write(row)
        if rec is not None:
            rec.write(row, jitter_ns, compute_ns)

    def open_log(self, path: Path) -> CsvStream:
        """A plant log (``plant_log.csv``) with this server's columns."""
        names, ints = column_formats(shape.PLANT_LOG)
        return CsvStream(path, LOG_COLUMNS, names=names, ints=ints)

    def counter_values(self) -> dict:
        """The run's counters now (a recording subtracts those at its start)."""
        return {**{f: getattr(self.c, f) for f in self.c.__dataclass_fields__}, "overruns": self.overruns,
                "watchdog_trips": self.rig.watchdog_trips, "watchdog_trips_unexplained": self.rig.watchdog_trips_unexplained,
                "commands_delivered": self.rig.commands_delivered}

    def _timing(self, steps, t0, t_end, rt, drift_ns, window=None) -> dict:
        """The run's summary (``timing.json``) with its verdict (:mod:`hydrohil.hil.verdict`). Lock-step runs
        have no clock: their jitter, overrun, drift and round-trip figures are None (n/a). ``window`` (a
        recording of the live panel): its own jitter and compute histograms and counters since its start."""
        from hydrohil.hil.verdict import judge
        j, c, rtt = (self.jitter, self.compute, self.rtt) if window is None else (window.jitter, window.compute,
                                                                                  self.rtt)
        cnt = self.counter_values()
        if window is not None:
            cnt = {key: v - window.counters0[key] for key, v in cnt.items()}
        sim_t = steps * self.h
        res = {
            "mode": "lockstep" if self.lockstep else "realtime",
            "step_s": self.h, "steps": int(steps), "steps_planned": self.n if window is None else int(steps),
            "overruns": int(cnt["overruns"]),
            "jitter_us_p50": j.percentile(50), "jitter_us_p99": j.percentile(99), "jitter_us_p999": j.percentile(99.9),
            "jitter_us_max": j.max_ns / 1e3 if j.n else float("nan"),
            "compute_us_p50": c.percentile(50), "compute_us_p99": c.percentile(99),
            "compute_us_max": c.max_ns / 1e3 if c.n else float("nan"),
            "rtt_us_p50": rtt.percentile(50), "rtt_us_p99": rtt.percentile(99),
            "rtt_seen_us_p50": self.rtt_seen.percentile(50), "rtt_seen_us_p99": self.rtt_seen.percentile(99),
            "rtt_source": "kernel receive timestamp (SO_TIMESTAMPNS)" if self.kernel_stamps else "plant process",
            "packets_rx": cnt["packets_rx"], "packets_bad": cnt["packets_bad"],
            "packets_foreign": cnt["packets_foreign"], "packets_lost": cnt["packets_lost"],
            "packets_reordered": cnt["packets_reordered"], "late_commands": cnt["late_commands"],
            "packets_dropped_kernel": cnt["packets_dropped_kernel"],
            "watchdog_trips": cnt["watchdog_trips"],
            "watchdog_trips_unexplained": cnt["watchdog_trips_unexplained"],
            "commands_delivered": cnt["commands_delivered"],
            "faults_injected": [f.type for f in self.rig.fault_models if f is not None],
            "simulated_s": sim_t, "wall_s": (t_end - t0) / 1e9,
            # wall clock at the last step's start minus its scheduled instant t0 + (steps-1)*h
            "drift_ms": drift_ns / 1e6 if not self.lockstep else None,
            "fault": self.fault, "link_error": self.link_error,
            "stopped_early": self.stop_requested and (window is not None or steps < self.n),   # (not a late BYE)
            "stop_signal": self.stop_signal,
            "statistics": "histograms, 1.2 % bins (bounded memory); max exact",
            **{f"os_{k}": v for k, v in rt.items()},
            "plant": "python", "log_rows_dropped": 0,     # (the log is written in the loop: no row is dropped)
        }
        if self.side is not None:
            res["telemetry_batches_sent"], res["telemetry_batches_dropped"] = self.side.sent, self.side.dropped
        if window is not None:
            res.update(recorded_steps=[window.k0, window.k0 + int(steps)], rtt_scope="session so far",
                       wall_s=(t_end - window.t0_ns) / 1e9, drift_ms=None)
        if self.lockstep:
            res["steps_per_s"] = steps / max((t_end - t0) / 1e9, 1e-9)
            for k in ("overruns", "jitter_us_p50", "jitter_us_p99", "jitter_us_p999", "jitter_us_max", "rtt_us_p50",
                      "rtt_us_p99", "rtt_seen_us_p50", "rtt_seen_us_p99"):
                res[k] = None
        res["verdict"] = judge(res, self.hil)
        return res

    def close(self) -> None:
        if self.log is not None:
            self.log.close()
        self.sock.close()


def serve_plant(params: str = "ferreira2004", bind: str = "127.0.0.1:47000", step: float = 5e-4,
                duration: float | None = None, log: Path | None = None, lockstep: bool = False,
                scenario: Path | None = None, allow_remote: bool = False, cpu: int | None = None,
                peer: str | None = None, connect_timeout: float | None = None, ready=print,
                panel: str | None = None, rows: bool = True) -> dict:
    """The plant process (``hydrohil plant``, ``python -m hydrohil.hil plant``): run the plant server until the
    run ends; streams ``log/plant_log.csv`` and writes ``log/timing.json``
    with the run's verdict, whatever the end (also on SIGINT/SIGTERM, or when no controller spoke). With
    ``scenario`` the parameters, step, duration, initial state, [hil] settings and [[faults]] come from it.
    ``peer``: the only controller address accepted (default: first sender). ``ready`` prints
    ``READY host:port`` once bound and ``PEER host:port`` once the controller has spoken (handshakes for
    scripts). ``panel``: HOST:PORT of the live panel's side channel (telemetry out, steering in; the session's
    events and applied commands go to ``log``); ``rows=False``: no ``plant_log.csv`` of the whole run (a panel
    session: recordings only). Returns the timing summary; :func:`hydrohil.hil.verdict.raise_for_outcome` maps
    it to an exit."""
    stop = early_stop()
    host_port = parse_address(bind, allow_remote=allow_remote)
    peer_addr = parse_address(peer, allow_remote=allow_remote) if peer else None
    initial, hil, faults = {}, HilCfg(), []
    if scenario is not None:
        sc = load_scenario(scenario)
        s = sc.scenario
        prm, hil = sc.params, s.hil
        step, duration = s.plant_step, s.duration if duration is None else duration
        initial = s.initial.model_dump()
        cpu = hil.cpus()[0] if cpu is None else cpu
        faults = s.faults
    else:
        prm = load_parameters(params)
        duration = 10.0 if duration is None else duration
    if connect_timeout is not None:
        hil = hil.model_copy(update={"connect_timeout": connect_timeout})
    if log is not None:
        log.mkdir(parents=True, exist_ok=True)
    server = PlantServer(prm, step=step, duration=duration, bind=host_port, lockstep=lockstep, hil=hil,
                         initial=initial, cpu=cpu, faults=faults, peer=peer_addr,
                         log=(log / "plant_log.csv") if log is not None and rows else None,
                         panel=parse_address(panel) if panel else None, session=log)
    return serve(server, log, ready, stop)


def early_stop() -> list[int]:
    """The first thing a plant process does: SIGINT/SIGTERM noted from now on (a signal during start-up ends
    the run cleanly too: :func:`serve` stops at once). Returns the list the signals go to."""
    stop: list[int] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.append(signum))
    return stop


def serve(server: PlantServer, log: Path | None, ready, stop: list[int]) -> dict:
    """Run a plant server to its end: SIGINT/SIGTERM stop it (``stop``: those that came before), ``READY`` once
    bound and ``PEER`` once the controller spoke; ``log/timing.json`` written whatever the end."""
    server.on_peer = lambda addr: ready(f"PEER {addr[0]}:{addr[1]}", flush=True)

    def _stop(signum, frame):
        server.stop_requested = True
        server.stop_signal = signum
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _stop)
    if stop:
        _stop(stop[0], None)
    server.warm_up()
    host, port = server.address
    ready(f"READY {host}:{port}", flush=True)
    try:
        timing = finite_or_none(server.run())
    finally:
        server.close()
    if log is not None:
        write_json(log / "timing.json", timing)
    return timing
