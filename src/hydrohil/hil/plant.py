"""The virtual rig: the hybrid model in its own process, locked to the wall clock, behind UDP.

Timeline of step k (h = plant step, t0 = start instant, docs/protocol.md):
  * until t0 + k·h the plant waits on its socket (``select``; coarse sleep) and spins the last
    ``spin_ns`` (150 µs, at most 30 % of h); every command that arrives is time-stamped on arrival;
  * at t0 + k·h it takes the latest valid command (or the watchdog's safe command), advances the model
    one step and sends the sensor packet of the state at (k+1)·h; its answer is due before t0 + (k+1)·h.
Jitter = start of step k − (t0 + k·h); an overrun is a step that starts after t0 + (k+1)·h.
``lockstep`` replaces the clock by the exchange itself: send sensor k, block until the command that
answers it, step — deterministic, as fast as the two processes go.
"""

from __future__ import annotations

import gc
import math
import os
import select
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hydrohil.control import p_control
from hydrohil.errors import HydrohilError, InputError
from hydrohil.hil import protocol as pr
from hydrohil.models.layout import AT_EXTEND, AT_RETRACT, FRICTION_NAMES, SPOOL_NAMES, STICK, TRAVEL_NAMES
from hydrohil.models.sensors import encoder_counts, pressure_reading
from hydrohil.parameters import Parameters
from hydrohil.simulation.loop import HybridPlant
from hydrohil.simulation.outputs import write_table
from hydrohil.simulation.scenario import HilCfg

SPIN_NS = 150_000            # busy-wait the last 150 us before a deadline ...
SPIN_FRACTION = 0.3          # ... but at most 30 % of a step: spinning ~all the time trips the kernel's RT throttling
CONNECT_TIMEOUT_S = 30.0     # wait this long for the controller's first packet
LOG_COLUMNS = ("k", "t", "wall", "jitter_us", "compute_us", "u", "cmd_seq", "cmd_age", "watchdog", "xs", "p1",
               "p2", "xp", "vp", "ff", "travel_mode", "friction_mode", "spool_mode", "encoder", "p1_meas",
               "p2_meas")


def parse_address(text: str, *, allow_remote: bool = False) -> tuple[str, int]:
    """'HOST:PORT' -> (host, port); a non-loopback host needs ``allow_remote``."""
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise InputError("expected HOST:PORT, e.g. 127.0.0.1:47000", source="address", key=text)
    host = host or "127.0.0.1"
    if not allow_remote and host not in ("127.0.0.1", "localhost", "::1"):
        raise InputError("binding a non-loopback address exposes the plant to the network; pass --allow-remote",
                         source="address", key=text)
    return host, int(port)


def realtime_setup(cpu: int | None) -> dict:
    """Best effort: pin to ``cpu``, SCHED_FIFO priority, 1-ns timer slack. Reports what was granted."""
    rep = {"cpu": None, "rt_priority": "not requested", "timer_slack": "default", "memory_locked": False}
    if cpu is not None:
        try:
            os.sched_setaffinity(0, {cpu})
            rep["cpu"] = cpu
        except (OSError, AttributeError) as exc:
            rep["cpu"] = f"not permitted ({exc.__class__.__name__})"
    try:
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
    watchdog_trips: int = 0
    rtt_ns: list = field(default_factory=list)


class PlantServer:
    """Serve the hybrid plant over UDP. ``run()`` returns the timing summary (``timing.json``)."""

    def __init__(self, params: Parameters, *, step: float = 5e-4, duration: float = 10.0,
                 bind: tuple[str, int] = ("127.0.0.1", 0), lockstep: bool = False, hil: HilCfg | None = None,
                 initial: dict | None = None, peer: tuple[str, int] | None = None, cpu: int | None = None):
        self.params, self.h, self.lockstep = params, float(step), lockstep
        self.hil = hil or HilCfg()
        self.n = int(round(duration / self.h))
        self.initial = dict(initial or {})
        self.plant = HybridPlant(params, h=self.h, **self.initial)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self.sock.bind(bind)
        self.address = self.sock.getsockname()
        self.peer = peer
        self.cpu = cpu
        self.spin_ns = min(SPIN_NS, int(SPIN_FRACTION * self.h * 1e9))
        self.c = Counters()
        self.rng = np.random.default_rng(self.hil.seed)
        self.log = np.empty((self.n + 1, len(LOG_COLUMNS)))
        self.log.fill(0.0)   # touch every page now: no page faults (or huge-page zeroing) inside the loop
        self.rows = 0
        self.stop_requested = False
        self.fault: str | None = None
        # latest command
        self.cmd_u = 0.0
        self.cmd_seq = -1
        self.cmd_echo = -1
        self.cmd_t_arrival = None
        self.watchdog = False
        self.hold_x = None
        self.sensor_t_send = {}

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) every kernel the loop calls, then restore the initial
        state: the first steps of a run must not pay for compilation."""
        self.plant.step(0.0)
        self.plant.reset(**self.initial)
        encoder_counts(0.0, 1e-6)
        p_control(1.0, 0.0, 0.0)

    # -- receiving --------------------------------------------------------------------------------
    def _receive(self, data: bytes, addr, t_arr: int) -> None:
        msg = pr.decode(data)
        if msg is None:
            self.c.packets_bad += 1
            return
        if self.peer is None:
            self.peer = addr
        elif addr != self.peer:
            self.c.packets_foreign += 1
            return
        self.c.packets_rx += 1
        if isinstance(msg, pr.Command):
            if msg.header.seq <= self.cmd_seq:
                self.c.packets_reordered += 1
                return
            if self.cmd_seq >= 0 and msg.header.seq > self.cmd_seq + 1:
                self.c.packets_lost += msg.header.seq - self.cmd_seq - 1
            self.cmd_seq, self.cmd_echo, self.cmd_t_arrival = msg.header.seq, msg.header.echo_seq, t_arr
            self.cmd_u = msg.u / self.hil.command_scale
            ts = self.sensor_t_send.pop(msg.header.echo_seq, None)
            if ts is not None:
                self.c.rtt_ns.append(t_arr - ts)
            if msg.flags & pr.CMD_STOP:
                self.stop_requested = True
        elif isinstance(msg, pr.Header) and msg.type == pr.T_BYE:
            self.stop_requested = True

    def _drain(self) -> None:
        while True:
            try:
                data, addr = self.sock.recvfrom(pr.MAX_DATAGRAM + 1)
            except BlockingIOError:
                return
            self._receive(data, addr, time.perf_counter_ns())

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
        recv = sock.recvfrom
        while time.perf_counter_ns() < deadline_ns:   # spin, still time-stamping arrivals
            try:
                data, addr = recv(pr.MAX_DATAGRAM + 1)
            except BlockingIOError:
                continue
            self._receive(data, addr, time.perf_counter_ns())

    # -- sending ----------------------------------------------------------------------------------
    def _send_sensor(self, k: int, out, status: int) -> tuple[int, float, float]:
        p = self.params
        s = p.sensors
        enc = int(encoder_counts(out[5], s.encoder_resolution)) if s.encoder_resolution > 0 else int(
            round(out[5] * 1e6))
        nz = self.rng.standard_normal(4) * s.pressure_noise if s.pressure_noise > 0 else (0.0, 0.0, 0.0, 0.0)
        p1, sat1 = pressure_reading(out[3], s.pressure_range, s.pressure_resolution, nz[0])
        p2, sat2 = pressure_reading(out[4], s.pressure_range, s.pressure_resolution, nz[1])
        ps, _ = pressure_reading(p.supply.ps, s.pressure_range, s.pressure_resolution, nz[2])
        pt, _ = pressure_reading(p.supply.pt, s.pressure_range, s.pressure_resolution, nz[3])
        travel, friction = int(out[9]), int(out[10])
        status |= (pr.ST_SATURATED if (sat1 or sat2) else 0) | (pr.ST_LOCKSTEP if self.lockstep else 0)
        status |= pr.ST_WATCHDOG if self.watchdog else 0
        status |= pr.ST_AT_RETRACT if travel == AT_RETRACT else pr.ST_AT_EXTEND if travel == AT_EXTEND else 0
        status |= pr.ST_STICK if friction == STICK else 0
        t_send = time.perf_counter_ns()
        pkt = pr.encode_sensor(k, t_send, self.cmd_t_arrival or 0, max(self.cmd_seq, 0), out[0], k, enc,
                               p1, p2, ps, pt, status, travel, friction, int(out[11]))
        self.sensor_t_send[k] = t_send
        if len(self.sensor_t_send) > 64:
            self.sensor_t_send.pop(next(iter(self.sensor_t_send)))
        if self.peer is not None:
            try:
                self.sock.sendto(pkt, self.peer)
            except OSError:
                pass
        return enc, p1, p2

    # -- one step ---------------------------------------------------------------------------------
    def _command_for_step(self, k: int, now_ns: int) -> float:
        """The valve command ū of step k: latest valid command, or the safe state after the timeout."""
        silent = self.cmd_t_arrival is None or (now_ns - self.cmd_t_arrival) > self.hil.watchdog_timeout * 1e9
        if silent and not self.watchdog:
            self.watchdog = True
            self.c.watchdog_trips += 1
            self.hold_x = float(self.plant.out[5])
        elif not silent and self.watchdog:
            self.watchdog = False
        if self.watchdog:
            if self.hil.safe_state == "hold":
                return float(p_control(self.hil.hold_kp, self.hold_x, float(self.plant.out[5])))
            return 0.0
        if self.cmd_echo < k:
            self.c.late_commands += 1
        return min(max(self.cmd_u, -1.0), 1.0)

    def run(self, progress=None) -> dict:
        """Serve until ``duration`` is simulated, the controller says BYE/stop, or a fault. Returns timing."""
        rt = realtime_setup(self.cpu) if not self.lockstep else {"cpu": None, "rt_priority": "lock-step",
                                                                  "timer_slack": "default"}
        h_ns = int(round(self.h * 1e9))
        # wait for the controller (first valid packet fixes the peer unless configured)
        self.sock.settimeout(CONNECT_TIMEOUT_S)
        t_connect = time.monotonic()
        while self.c.packets_rx == 0:
            try:
                data, addr = self.sock.recvfrom(pr.MAX_DATAGRAM + 1)
            except socket.timeout:
                raise HydrohilError(f"no controller packet within {CONNECT_TIMEOUT_S:g} s") from None
            self._receive(data, addr, time.perf_counter_ns())
            if time.monotonic() - t_connect > CONNECT_TIMEOUT_S:
                raise HydrohilError(f"no controller packet within {CONNECT_TIMEOUT_S:g} s")
        self.sock.setblocking(False)
        out = self.plant.out
        gc.collect()
        gc.freeze()
        gc.disable()
        jit_ns = np.full(self.n + 1, 0, dtype=np.int64)    # np.full writes: pages faulted in before the loop
        comp_ns = np.full(self.n + 1, 0, dtype=np.int64)
        status_extra = 0
        t0 = time.perf_counter_ns() + 2 * h_ns
        self.cmd_t_arrival = t0          # the watchdog counts from the start
        enc, m1, m2 = self._send_sensor(0, out, 0)
        self._log_row(0, out, 0.0, 0, 0, 0.0, enc, m1, m2)
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
                u = self._command_for_step(k, start)
                try:
                    self.plant.step(u)
                except HydrohilError as exc:
                    self.fault = str(exc)
                    self._send_sensor(k + 1, out, pr.ST_FAULT | pr.ST_FINAL)
                    break
                final = pr.ST_FINAL if (k + 1 == self.n or self.stop_requested) else 0
                enc, m1, m2 = self._send_sensor(k + 1, out, status_extra | final)
                end = time.perf_counter_ns()
                jit_ns[k], comp_ns[k] = late, end - start
                self._log_row(k + 1, out, (start - t0) / 1e9 if not self.lockstep else 0.0, late, end - start, u,
                              enc, m1, m2)
                k_done = k + 1
                if progress is not None and k % 200 == 0:
                    progress(k_done, self.n)
                if self.stop_requested:
                    break
        finally:
            gc.enable()
            gc.unfreeze()
            t_end = time.perf_counter_ns()
            for _ in range(3):   # tell the controller the run is over
                try:
                    if self.peer is not None:
                        self.sock.sendto(pr.encode_simple(pr.T_BYE, k_done + 1, t_end), self.peer)
                except OSError:
                    pass
        drift_ns = last_start - (t0 + max(k_done - 1, 0) * h_ns)
        return self._timing(jit_ns[:k_done], comp_ns[:k_done], k_done, h_ns, t0, t_end, rt, drift_ns)

    def _wait_lockstep(self, k: int) -> None:
        """Block until the command answering sensor packet k arrives (or the watchdog timeout passes)."""
        limit = time.perf_counter_ns() + int(self.hil.watchdog_timeout * 1e9)
        while self.cmd_echo < k and not self.stop_requested:
            left = limit - time.perf_counter_ns()
            if left <= 0:
                return
            r, _, _ = select.select([self.sock], [], [], left / 1e9)
            if r:
                self._drain()

    def _log_row(self, k, out, wall, jitter_ns, compute_ns, u, enc, m1, m2) -> None:
        row = self.log[k]
        row[0], row[1], row[2], row[3], row[4], row[5] = k, out[0], wall, jitter_ns / 1e3, compute_ns / 1e3, u
        row[6], row[7], row[8] = self.cmd_seq, k - 1 - self.cmd_echo if self.cmd_seq >= 0 else -1, self.watchdog
        row[9], row[10], row[11], row[12], row[13], row[14] = out[1], out[3], out[4], out[5], out[6], out[8]
        row[15], row[16], row[17] = out[9], out[10], out[11]
        row[18], row[19], row[20] = enc, m1, m2
        self.rows = k + 1

    def _timing(self, jit_ns, comp_ns, steps, h_ns, t0, t_end, rt, drift_ns) -> dict:
        def pct(a, q):
            return float(np.percentile(a, q)) / 1e3 if len(a) else float("nan")

        rtt = np.asarray(self.c.rtt_ns, dtype=float)
        sim_t = steps * self.h
        res = {
            "mode": "lockstep" if self.lockstep else "realtime",
            "step_s": self.h, "steps": int(steps), "steps_planned": self.n,
            "overruns": int(np.sum(jit_ns > h_ns)) if not self.lockstep else 0,
            "jitter_us_p50": pct(jit_ns, 50), "jitter_us_p99": pct(jit_ns, 99), "jitter_us_p999": pct(jit_ns, 99.9),
            "jitter_us_max": float(jit_ns.max()) / 1e3 if len(jit_ns) else float("nan"),
            "compute_us_p50": pct(comp_ns, 50), "compute_us_p99": pct(comp_ns, 99),
            "compute_us_max": float(comp_ns.max()) / 1e3 if len(comp_ns) else float("nan"),
            "rtt_us_p50": float(np.percentile(rtt, 50)) / 1e3 if rtt.size else float("nan"),
            "rtt_us_p99": float(np.percentile(rtt, 99)) / 1e3 if rtt.size else float("nan"),
            "packets_rx": self.c.packets_rx, "packets_bad": self.c.packets_bad,
            "packets_foreign": self.c.packets_foreign, "packets_lost": self.c.packets_lost,
            "packets_reordered": self.c.packets_reordered, "late_commands": self.c.late_commands,
            "watchdog_trips": self.c.watchdog_trips,
            "simulated_s": sim_t, "wall_s": (t_end - t0) / 1e9,
            # wall clock at the last step's start minus its scheduled instant t0 + (steps-1)*h
            "drift_ms": drift_ns / 1e6 if not self.lockstep else None,
            "fault": self.fault, "stopped_early": self.stop_requested,
            **{f"os_{k}": v for k, v in rt.items()},
        }
        if self.lockstep:
            res["steps_per_s"] = steps / max((t_end - t0) / 1e9, 1e-9)
        return res

    def write_log(self, path: Path) -> None:
        """Write the per-step log as CSV (modes as names)."""
        write_table(path, LOG_COLUMNS, self.log[: self.rows], names={15: TRAVEL_NAMES, 16: FRICTION_NAMES,
                                                                     17: SPOOL_NAMES}, ints={0, 6, 7, 8, 18})

    def close(self) -> None:
        self.sock.close()


def finite_or_none(d: dict) -> dict:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
