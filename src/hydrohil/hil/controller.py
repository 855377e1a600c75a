"""Controller side of the HIL link: a client class for your own controller, and the loop that runs a
scenario's controller (built-in or Python, :mod:`hydrohil.control`) against a plant.

Write a controller in a few lines::

    from hydrohil.hil.controller import PlantClient
    with PlantClient(("127.0.0.1", 47000)) as plant:
        for s in plant.sensors():                 # one sensor packet per plant step
            x = s.encoder_counts * 1e-6           # m (1 um encoder)
            plant.send(50.0 * (0.10 - x), answer=s)   # ū = Kp·(x_ref − x)

or run one developed offline: ``plant.send(ctl(measurement(s, x_ref)), answer=s)``.
"""

from __future__ import annotations

import select
import socket
import time
from pathlib import Path
from typing import Callable, Iterator

from hydrohil.control import BuiltinController, Measurement, call_controller, p_control
from hydrohil.errors import InputError, LinkError
from hydrohil.hil import protocol as pr
from hydrohil.hil.protocol import parse_address
from hydrohil.hil.sampling import sample_loop
from hydrohil.circuits.scenario import is_circuit_scenario
from hydrohil.models.sensors import count_size
from hydrohil.simulation.outputs import CsvStream


SPIN_S = 150e-6


HELLO_EVERY_S = 0.2    # HELLO repeated while no plant has answered (it may start after the controller)


class PlantClient:
    """UDP client of a plant server: ``sensors()`` yields sensor packets, ``send(u)`` sends a command.

    ``sensors()`` raises :class:`~hydrohil.errors.LinkError` when no plant answers within ``connect_timeout``
    or the plant goes silent for ``timeout`` seconds before it ended the run: a controller never waits
    forever, and never ends quietly with nothing done. ``bind`` fixes the local address (a plant started
    with ``--peer`` accepts only that one); ``on_connect(sensor)`` is called at the first sensor packet.
    """

    def __init__(self, address: tuple[str, int], *, timeout: float = 5.0, connect_timeout: float | None = None,
                 command_scale: float = 1.0, busy_poll: bool = False, period: float = 5e-4, nap: bool = True,
                 bind: tuple[str, int] | None = None, on_connect: Callable[[pr.Sensor], None] | None = None,
                 should_stop: Callable[[], bool] | None = None):
        self.address = address
        self.should_stop = should_stop        # polled while waiting (a signal handler sets it): stop waiting
        self.connect_timeout = timeout if connect_timeout is None else connect_timeout
        self.on_connect = on_connect
        # busy_poll: sleep until SPIN_S before the next expected packet (one plant period after the last),
        # then spin on the socket: lower latency than waking up from select, ~1/3 of a core;
        # nap=False: never sleep (spin all the time, a whole core)
        self.busy_poll = busy_poll
        self.nap = nap
        self.period = period
        self.last_arrival = None
        self.timeout = timeout
        self.scale = command_scale
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        if bind is not None:
            self.sock.bind(bind)
        self.sock.connect(address)
        self.seq = 0
        self.bad = 0
        self.received = 0
        self.last_seq = -1
        self.lost = 0
        self.finished = False
        self.status = 0
        self.t_hello = 0.0
        self._hello()

    def _hello(self) -> None:
        self.t_hello = time.monotonic()
        try:
            self.sock.send(pr.encode_simple(pr.T_HELLO, 0, time.perf_counter_ns()))
        except OSError:
            pass      # no plant listening yet (ICMP port unreachable): the next HELLO may reach it

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        try:
            self.sock.send(pr.encode_simple(pr.T_BYE, self.seq + 1, time.perf_counter_ns()))
        except OSError:
            pass
        self.sock.close()

    def receive(self, timeout: float | None = None) -> pr.Sensor | None:
        """Next valid sensor packet, or None when none came within ``timeout`` seconds (0: only what has
        arrived already) or the plant said BYE."""
        end = time.monotonic() + (self.timeout if timeout is None else timeout)
        tried = False
        while not self.finished and not (self.should_stop is not None and self.should_stop()):
            now = time.monotonic()
            left = end - now
            if left <= 0 and tried:
                return None
            tried = True
            left = max(left, 0.0)
            if self.received == 0 and now - self.t_hello > HELLO_EVERY_S:
                self._hello()
            try:
                if self.busy_poll and self.received:      # spin only once the plant streams (not while it starts)
                    if self.nap and self.last_arrival is not None:
                        nap = self.last_arrival + self.period - SPIN_S - time.perf_counter()
                        if nap > 0:
                            select.select([self.sock], [], [], min(nap, left))
                    data = self.sock.recv(pr.MAX_DATAGRAM + 1, socket.MSG_DONTWAIT)
                else:
                    wait = min(left, HELLO_EVERY_S) if self.received == 0 else left
                    r, _, _ = select.select([self.sock], [], [], wait)
                    if not r:
                        continue
                    data = self.sock.recv(pr.MAX_DATAGRAM + 1)
            except BlockingIOError:
                continue
            except (ConnectionRefusedError, OSError):
                select.select([], [], [], min(0.01, left))   # plant not up yet / gone (ICMP port unreachable)
                continue
            msg = pr.decode(data)
            if msg is None:
                self.bad += 1
                continue
            if isinstance(msg, (pr.Sensor, pr.Signals)):
                self.last_arrival = time.perf_counter()
                self.received += 1
                if self.received == 1:
                    if msg.status & pr.ST_LOCKSTEP:
                        self.busy_poll = False      # no clock to keep: spinning would only starve the plant
                    if self.on_connect is not None:
                        self.on_connect(msg)
                if self.last_seq >= 0 and msg.header.seq > self.last_seq + 1:
                    self.lost += msg.header.seq - self.last_seq - 1
                self.last_seq = max(self.last_seq, msg.header.seq)
                self.status = msg.status
                if msg.status & pr.ST_FINAL:
                    self.finished = True
                return msg
            if msg.type == pr.T_BYE:
                self.finished = True
        return None

    def sensors(self, timeout: float | None = None) -> Iterator[pr.Sensor]:
        """Sensor packets until the plant ends the run. Raises LinkError when no plant answers within
        ``connect_timeout`` or the plant goes silent for ``timeout`` seconds (default: the client's)."""
        while True:
            first = self.received == 0
            wait = self.connect_timeout if first and timeout is None else timeout
            s = self.receive(wait)
            if s is None:
                if self.finished or (self.should_stop is not None and self.should_stop()):
                    return
                host, port = self.address
                if first:
                    raise LinkError(f"no answer from a plant at {host}:{port} within "
                                    f"{self.connect_timeout if wait is None else wait:g} s (is it running?)")
                raise LinkError(f"the plant at {host}:{port} went silent for "
                                f"{self.timeout if timeout is None else timeout:g} s after step {self.last_seq}")
            yield s
            if self.finished:
                return

    def send(self, u: float, answer: pr.Sensor | None = None, stop: bool = False) -> None:
        """Send valve command ū (scaled by ``command_scale``), answering sensor packet ``answer``."""
        self.seq += 1
        hdr = answer.header if answer is not None else None
        pkt = pr.encode_command(self.seq, time.perf_counter_ns(), hdr.t_send_ns if hdr else 0,
                                hdr.seq if hdr else 0, float(u) * self.scale, pr.CMD_STOP if stop else 0)
        try:
            self.sock.send(pkt)
        except OSError:
            pass


    def send_inputs(self, layout: int, mask: int, values, answer: pr.Signals | None = None,
                    stop: bool = False) -> None:
        """Send a circuit's input values (SI; input i set when bit i of ``mask`` is), answering SIGNALS packet
        ``answer``."""
        self.seq += 1
        hdr = answer.header if answer is not None else None
        pkt = pr.encode_inputs(self.seq, time.perf_counter_ns(), hdr.t_send_ns if hdr else 0, hdr.seq if hdr else 0,
                               layout, mask, [float(v) for v in values], pr.CMD_STOP if stop else 0)
        try:
            self.sock.send(pkt)
        except OSError:
            pass


CONTROLLER_LOG_COLUMNS = ("seq", "t", "wall", "x_meas", "x_ref", "u", "status")


def warm_up() -> None:
    """Call into the core once before saying HELLO (a first packet must not wait for its first call)."""
    p_control(1.0, 0.0, 0.0)


def run_position_controller(client: PlantClient, controller: Callable[[Measurement], float],
                            reference: Callable[[float], tuple[float, float]], *, encoder_resolution: float = 1e-6,
                            mode: str = "packet", sample_time: float = 5e-4, log_path: Path | None = None,
                            should_stop: Callable[[], bool] = lambda: False, side=None,
                            events_path: Path | None = None) -> dict:
    """A position controller over the link: ū = controller(measurement) with the reference (x_ref, slope) =
    ``reference(t)`` at the plant time of the sensor packet (:mod:`hydrohil.control`; the paper's P law is
    ``type = "p"``).

    ``mode = "packet"``: one command per sensor packet (answers it). ``mode = "clock"``: on its own
    periodic clock of ``sample_time``, using the latest sensor packet. The log is streamed to ``log_path``
    (CSV) while running. ``should_stop`` is polled every cycle (signal handlers set it). ``side``: the live
    panel's side channel (:mod:`hydrohil.hil.sidechannel`): telemetry (reference, measurement, command) out,
    steering events (:mod:`hydrohil.simulation.steering`) in, applied before the command answering the next sensor
    packet k and logged with that k in ``events_path``. Returns a summary.
    """
    from hydrohil.simulation.steering import EventLog, SteerableController, apply_controller_messages
    ctl = controller
    builtin = controller.update if isinstance(controller, BuiltinController) else None   # the core's law: no
    res = count_size(encoder_resolution)                                                # Measurement needed
    log = CsvStream(log_path, CONTROLLER_LOG_COLUMNS, ints={0, 6}) if log_path is not None else None
    t_start = time.perf_counter()
    steer = SteerableController(controller, reference)
    reference = steer.ref
    events = EventLog(events_path) if side is not None else None
    pending: list[dict] = []

    def act(s: pr.Sensor) -> None:
        if not isinstance(s, pr.Sensor):
            raise LinkError(f"the plant at {client.address[0]}:{client.address[1]} serves a circuit (SIGNALS "
                            "packets), not the paper's rig: run the controller with that circuit's scenario")
        if pending:
            apply_controller_messages(pending, s.step, steer, side, events)
        x = s.encoder_counts * res
        xr, dxr = reference(s.t_sim)
        if builtin is not None:
            u = builtin(xr, dxr, x, s.p1, s.p2)
        else:
            u = call_controller(ctl, Measurement(s.t_sim, xr, dxr, x, s.p1, s.p2, s.ps, s.pt, s.status))
        client.send(u, answer=s)
        if log is not None:
            log.write((s.header.seq, s.t_sim, time.perf_counter() - t_start, x, xr, u, s.status))
        if side is not None and side.row(s.step, xr, x, u):
            side.flush()
            pending.extend(side.poll())

    try:
        sample_loop(client, act, mode=mode, sample_time=sample_time, should_stop=should_stop)
    finally:
        if log is not None:
            log.close()
        if events is not None:
            events.close()
    return {"commands_sent": client.seq, "sensor_packets": client.received, "sensor_packets_bad": client.bad,
            "sensor_packets_lost": client.lost, "stopped_by_signal": bool(should_stop())}


def reference_table(text: str):
    """'t0:x0,t1:x1,...' [s:m] -> t -> (x_ref, slope), linear between the points."""
    from hydrohil.simulation.scenario import Table
    try:
        pts = [tuple(float(v) for v in item.split(":")) for item in text.split(",") if item.strip()]
        t, x = zip(*pts)
    except ValueError:
        raise InputError("expected t:x pairs in s:m, e.g. 0:0.03,0.5:0.03,1.5:0.15", source="--reference",
                         key=text) from None
    if any(b < a for a, b in zip(t, t[1:])):
        raise InputError("times must be non-decreasing", source="--reference", key=text)
    return Table(t, x).at


def _placement(hil, busy_poll: bool | None) -> tuple[bool, bool | None]:
    """The controller process on its [hil] CPU (when one is set or chosen); whether it spins (never on a single
    CPU) and busy-polls its socket."""
    import os
    cpu = hil.cpus()[1]
    spin = hil.wait != "sleep" and (os.cpu_count() or 1) > 1
    if cpu is not None:
        try:
            os.sched_setaffinity(0, {cpu})
        except OSError:
            pass
    return spin, (hil.busy_poll or spin) if busy_poll is None else busy_poll


def run_controller(connect: str, scenario: Path | None = None, kp: float = 50.0,
                   reference: str = "0:0.03,0.5:0.03,1.5:0.15,3:0.15,4:0.03,6:0.03", log: Path | None = None,
                   mode: str = "packet", allow_remote: bool = False, busy_poll: bool | None = None,
                   local: str | None = None, link_timeout: float | None = None, ready=print,
                   panel: str | None = None) -> dict:
    """The controller process (``hydrohil controller``, ``python -m hydrohil.hil controller``): the scenario's
    controller (or the paper's P position controller) as a separate process talking to a plant server.

    ``local``: bind the controller's socket to HOST:PORT (the address a plant started with ``--peer``
    expects). ``ready`` prints ``CONNECTED host:port`` at the plant's first sensor packet (a handshake for
    scripts). Raises LinkError when no plant answers within ``link_timeout`` (default ``[hil]
    link_timeout``, 5 s) or it goes silent; ``controller.json`` is written in every case (``error``)."""
    import signal
    stop: list[int] = []
    for sig in (signal.SIGINT, signal.SIGTERM):      # first thing: finish the log and controller.json, then exit
        signal.signal(sig, lambda signum, frame: stop.append(signum))
    import os

    from hydrohil.simulation.outputs import write_json
    from hydrohil.simulation.scenario import HilCfg

    addr = parse_address(connect, allow_remote=allow_remote)
    local_addr = parse_address(local, allow_remote=allow_remote) if local else None
    enc, scale, sample, spin, hil = 1e-6, 1.0, 5e-4, False, HilCfg()
    circuit = None
    if scenario is not None and is_circuit_scenario(scenario):      # a circuit's loop and drives (hil/circuit.py)
        from hydrohil.circuits.scenario import load_circuit_scenario
        from hydrohil.hil.circuit import Drives
        from hydrohil.simulation.scenario import circuit_hil
        circuit = load_circuit_scenario(scenario)
        hil = circuit_hil(circuit)
        drives = Drives(circuit)          # (compiled, its tables made: before the first packet)
        mode = (hil.controller_mode if circuit.loop is not None or circuit.commands is not None
                else "packet")                  # (an open loop without commands only answers each packet)
        sample = circuit.step
        spin, busy_poll = _placement(hil, busy_poll)
    elif scenario is not None:
        from hydrohil.simulation.scenario import load_scenario
        sc = load_scenario(scenario)
        s = sc.scenario
        hil = s.hil
        mode, scale = s.hil.controller_mode, s.hil.command_scale
        sample = s.plant_step
        if s.controller is None:
            raise InputError("an open-loop scenario has no controller to run", source=str(scenario), key="controller")
        ctl = sc.make_controller(sample)
        enc = sc.params.sensors.encoder_resolution
        ref = s.reference.sampler().at
        spin, busy_poll = _placement(hil, busy_poll)
    else:
        from hydrohil.control import PControllerCfg, make_controller
        from hydrohil.parameters import load_parameters
        ref = reference_table(reference)
        if not 0 < kp <= 1e5:
            raise InputError(f"must be > 0 and <= 1e5 [ū/m], got {kp}", source="--kp")
        ctl = make_controller(PControllerCfg(type="p", kp=kp), load_parameters("ferreira2004"), sample)
    timeout = hil.link_timeout if link_timeout is None else link_timeout
    busy_poll = bool(busy_poll)
    if log is not None:
        log.mkdir(parents=True, exist_ok=True)
    warm_up()
    try:
        if spin:
            os.setpriority(os.PRIO_PROCESS, 0, -20)
        elif scenario is not None:     # a controller that sleeps between packets: woken first (below the plant's
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(49))     # 50), whatever else the machine runs
    except (OSError, AttributeError):
        pass
    summary: dict = {"error": None}
    side = None
    if panel:
        from hydrohil.circuits.link import CONTROLLER_SIDE_COLUMNS
        from hydrohil.hil.sidechannel import CONTROLLER_COLUMNS, ROLE_CONTROLLER, SideChannel
        side = SideChannel(parse_address(panel), ROLE_CONTROLLER,
                           CONTROLLER_SIDE_COLUMNS if circuit is not None else CONTROLLER_COLUMNS)
    try:
        with PlantClient(addr, timeout=timeout, command_scale=scale, busy_poll=busy_poll, period=sample,
                         nap=not spin, bind=local_addr, should_stop=lambda: bool(stop),
                         on_connect=lambda s: ready(f"CONNECTED {addr[0]}:{addr[1]}", flush=True)) as client:
            try:
                if circuit is not None:
                    from hydrohil.hil.circuit import run_circuit_controller
                    summary.update(run_circuit_controller(
                        client, drives, mode=mode, should_stop=lambda: bool(stop), side=side,
                        log_path=(log / "controller_log.csv") if log else None,
                        events_path=(log / "controller_events.jsonl") if log else None))
                else:
                    summary.update(run_position_controller(
                        client, ctl, ref, encoder_resolution=enc, mode=mode, sample_time=sample,
                        log_path=(log / "controller_log.csv") if log else None, should_stop=lambda: bool(stop),
                        side=side, events_path=(log / "controller_events.jsonl") if log else None))
            except LinkError as exc:
                summary.update(error=str(exc), commands_sent=client.seq, sensor_packets=client.received)
                raise
    except OSError as exc:                        # e.g. the --local address taken by another process meanwhile
        summary["error"] = f"cannot use the local address {local or 'any'}: {exc}"
        raise LinkError(summary["error"]) from None
    finally:
        summary["stop_signal"] = stop[0] if stop else None
        if side is not None:
            side.close()
        if log is not None:
            write_json(log / "controller.json", summary)
    return summary
