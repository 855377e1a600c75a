"""HIL of any circuit (a scenario naming its circuit, :mod:`hydrohil.circuits.scenario`): the plant server
over the circuit's rig (:class:`hydrohil.circuits.rig.CircuitRig`), the controller loop, the offline check.

The link is protocol v1's circuit packets (docs/protocol.md): the plant sends SIGNALS (every signal of the
circuit, the loop's measured one through its sensor), the controller answers with INPUTS (a value per input it
sets). Both carry the circuit's ``layout`` (:func:`hydrohil.hil.protocol.layout_id`), so a controller built for
another circuit is told at once. The scenario's controller process runs its loop (the core's law, the same C
as offline) and sets the loop's command; the plant applies the scenario's drives of the other inputs itself (an
open-loop scenario's controller only answers). Lock-step, that is
:func:`hydrohil.circuits.run.simulate_circuit`'s run bit for bit.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from hydrohil.circuits.link import PLANT_LOG_INTS, check_link_size, plant_log_columns, side_columns
from hydrohil.errors import LinkError
from hydrohil.hil import protocol as pr
from hydrohil.hil.plant import PlantServer, early_stop, serve
from hydrohil.hil.sampling import sample_loop
from hydrohil.hil.protocol import parse_address
from hydrohil.simulation.outputs import CsvStream
from hydrohil.simulation.scenario import circuit_hil

CONTROLLER_LOG_HEAD = ("seq", "t", "wall", "measured", "reference", "command", "status")


class CircuitPlantServer(PlantServer):
    """:class:`~hydrohil.hil.plant.PlantServer` (clock, lock-step, watchdog, counters, verdict) serving a
    circuit: SIGNALS out, INPUTS in, its own ``plant_log.csv`` columns."""

    def __init__(self, cs, *, hil, duration: float, log: Path | None = None, **kw):
        self.cs = cs
        from hydrohil.circuits.rig import CircuitRig
        rig = CircuitRig(cs)                # (its watchdog, its faults' seed: the scenario's [hil], as offline)
        check_link_size(rig.signals, rig.inputs, cs.source)
        self.layout = pr.layout_id(rig.signals, rig.inputs)
        self.columns = plant_log_columns(rig.signals, rig.inputs)
        super().__init__(None, step=cs.step, duration=duration, hil=hil, log=log, rig=rig, **kw)
        self.side_row = [0.0] * len(self.telemetry_columns())

    def telemetry_columns(self) -> tuple[str, ...]:
        return side_columns(self.rig.signals, self.rig.inputs)

    def apply_event(self, msg: dict, k: int) -> tuple:
        from hydrohil.simulation.steering import apply_circuit_event, parse_event
        ev = parse_event(msg, "plant", source="panel", circuit=self.cs)
        return ev, apply_circuit_event(self.rig, ev, k)

    def _telemetry(self, k: int, status: int, late_ns: int, compute_ns: int, u) -> None:
        """Row k to the panel (:func:`hydrohil.circuits.link.side_columns`); every batch: send it, then apply
        what the panel asked for at this boundary."""
        rig, side, row = self.rig, self.side, self.side_row
        ni = len(rig.inputs)
        if self.session is not None:
            self.session.command(*u[:ni])
        row[:] = (rig.t, *rig.signal_row.tolist(), *u[:ni].tolist(), late_ns / 1e3, compute_ns / 1e3, rig.watchdog)
        if side.row(k, *row):
            side.flush(self._counters(k))
            for msg in side.poll():
                self._steer(msg, k)

    def accepts(self, msg) -> bool:
        if isinstance(msg, pr.Inputs):
            return msg.layout == self.layout and len(msg.values) == len(self.rig.inputs)
        return not isinstance(msg, (pr.Sensor, pr.Command, pr.Signals))

    def command_value(self, msg):
        return msg.mask, msg.values

    def _send_sensor(self, k: int, status: int):
        rig = self.rig
        status |= ((pr.ST_LOCKSTEP if self.lockstep else 0) | (pr.ST_WATCHDOG if rig.watchdog else 0)
                   | (pr.ST_SATURATED if rig.saturated else 0))
        values = rig.read()
        t_send, t_send_wall = time.perf_counter_ns(), time.time_ns()
        self._transmit(k, pr.encode_signals(k, t_send, self.cmd_t_arrival or 0, max(self.cmd_seq, 0), rig.t, k,
                                            status, self.layout, values), t_send, t_send_wall)
        return status

    def _log_row(self, k, status, wall, jitter_ns, compute_ns, u) -> None:
        rec = self.session.recording if self.session is not None else None
        if self.log is None and rec is None:
            return
        rig = self.rig
        age = k - 1 - self.cmd_echo if self.cmd_seq >= 0 else -1
        row = (k, rig.t, wall, jitter_ns / 1e3, compute_ns / 1e3, self.cmd_seq, age, rig.watchdog, status,
               *rig.signal_row, *rig.u[:len(rig.inputs)])
        if self.log is not None:
            self.log.write(row)
        if rec is not None:
            rec.write(row, jitter_ns, compute_ns)

    def open_log(self, path: Path) -> CsvStream:
        return CsvStream(path, self.columns, ints={self.columns.index(c) for c in PLANT_LOG_INTS})

    def _timing(self, *args, **kw) -> dict:
        res = super()._timing(*args, **kw)
        res.update(circuit=self.cs.circuit.name, layout=self.layout, signals=len(self.rig.signals),
                   inputs=len(self.rig.inputs))
        return res


def serve_circuit_plant(scenario: Path, bind: str = "127.0.0.1:47000", duration: float | None = None,
                        log: Path | None = None, lockstep: bool = False, allow_remote: bool = False,
                        cpu: int | None = None, peer: str | None = None, connect_timeout: float | None = None,
                        ready=print, panel: str | None = None, rows: bool = True) -> dict:
    """The plant process of a circuit scenario (``hydrohil plant --scenario`` on one naming its circuit): as
    :func:`hydrohil.hil.plant.serve_plant`, the circuit behind the link. Returns the timing summary."""
    from hydrohil.circuits.scenario import load_circuit_scenario
    stop = early_stop()
    host_port = parse_address(bind, allow_remote=allow_remote)
    peer_addr = parse_address(peer, allow_remote=allow_remote) if peer else None
    cs = load_circuit_scenario(scenario)
    hil = circuit_hil(cs)
    if connect_timeout is not None:
        hil = hil.model_copy(update={"connect_timeout": connect_timeout})
    if log is not None:
        log.mkdir(parents=True, exist_ok=True)
    server = CircuitPlantServer(cs, hil=hil, duration=cs.duration if duration is None else duration, bind=host_port,
                                lockstep=lockstep, peer=peer_addr, cpu=hil.cpus()[0] if cpu is None else cpu,
                                log=(log / "plant_log.csv") if log is not None and rows else None,
                                panel=parse_address(panel) if panel else None, session=log)
    return serve(server, log, ready, stop)


class Drives:
    """What the scenario's controller process sends for each sensor packet: the loop's command from the core's
    law on the measured signal (the same C as offline), its bit alone in the mask (the plant applies the other
    inputs' drives itself, on time); an open loop sends its ``commands``' drives at the packet's step, and answers
    each packet with nothing set without them. ``steer``: the live
    panel's changes to the loop (gains, a held reference, the law's state cleared;
    :class:`hydrohil.simulation.steering.SteerableController`)."""

    def __init__(self, cs):
        from hydrohil.circuits.link import circuit_link
        from hydrohil.simulation.steering import SteerableController
        self.cs = cs
        lay = cs.layout
        signals, inputs, self.layout = circuit_link(cs.circuit, lay)
        self.n, self.loop, self.repeat = cs.n_steps, cs.loop, cs.repeat
        self.values = [0.0] * len(inputs)
        self.mask = 0
        self.steer = None
        self.commands = []                          # an open loop's commands: (input, its drive per step)
        if cs.commands is not None:
            from hydrohil.circuits.run import input_table
            table = input_table(cs.circuit, self.n + 1, cs.step)
            self.commands = [(j, table[:, j].copy()) for j, name in enumerate(lay.inputs) if name in cs.commands.inputs]
            self.mask = cs.commands.mask(cs.circuit)
        if self.loop is not None:
            self.loop.start(cs.step)
            self.ref, self.dref = self.loop.table(self.n, cs.step)
            at = lambda col: lay.log_columns.index(col) - lay.log_columns.index("t") - 1       # noqa: E731 (in SIGNALS)
            self.meas = at(self.loop.measure)
            self.cc = cs.compiled                   # (a loop reading pressures: its transducers, the generated C's)
            self._rng = self.loop.rng                           # (kept alive here: the C reads it by address)
            self.streams = self.loop.sensor_args(self.cc, self._rng)[1]
            self.press = self.loop.pressure_args(self.cc)      # (its transducers' faults' memory: this run's)
            self.cmd = lay.inputs.index(self.loop.command)
            self.mask = 1 << self.cmd
            self.steer = SteerableController(self.loop.controller, None)
        self.measured = self.reference = float("nan")
        self._read = None                           # (the step and the pressures as read of the last packet)

    def answer(self, s: pr.Signals) -> list[float]:
        for j, drive in self.commands:              # (an open loop's: the drive at the packet's step)
            self.values[j] = float(drive[int(s.step) % self.n if self.repeat else min(int(s.step), self.n)])
        if self.loop is not None:
            k = int(s.step) % self.n if self.repeat else min(int(s.step), self.n)
            held = self.steer.held
            if held is not None:
                ref, dref = held, 0.0
            elif self.repeat and self.loop.period:     # (a panel session: the reference's own period goes on)
                r, d = self.loop.reference_at(np.array([int(s.step) * self.cs.step]), self.cs.step)
                ref, dref = float(r[0]), float(d[0])
            else:
                ref, dref = float(self.ref[k]), float(self.dref[k])
            self.measured, self.reference = s.values[self.meas], ref
            if self.loop.pressures is None:
                p1, p2, ps, pt = 0.0, 0.0, math.nan, math.nan
            elif self._read is not None and self._read[0] == s.step:   # (a clock's second look at a packet: the
                p1, p2, ps, pt = self._read[1]                          # transducers read it once, as the rig's)
            else:
                p1, p2, ps, pt = self.loop.read_pressures(self.cc, [s.t_sim, *s.values], self.streams, int(s.step),
                                                          self.press)
                self._read = (s.step, (p1, p2, ps, pt))
            self.values[self.cmd] = self.loop.update(ref, dref, self.measured, p1, p2, t=s.t_sim, ps=ps, pt=pt)
        return self.values


def run_circuit_controller(client, drives: Drives, *, mode: str = "packet", log_path: Path | None = None,
                           should_stop=lambda: False, side=None, events_path: Path | None = None) -> dict:
    """The scenario's controller over the link: one INPUTS packet answering each SIGNALS packet
    (:class:`Drives`, made before the link opens), or with ``mode = "clock"`` one on its own clock of the
    scenario's step on the newest packet (:func:`~hydrohil.hil.sampling.sample_loop`, the paper rig's
    controller's). Raises LinkError when the plant serves another circuit (its layout differs). ``side``: the
    live panel's side channel (columns :data:`hydrohil.circuits.link.CONTROLLER_SIDE_COLUMNS`); its steering
    events are applied before the command answering the next packet k and logged with that k in
    ``events_path``."""
    from hydrohil.simulation.steering import EventLog, apply_controller_messages
    cs = drives.cs
    log = CsvStream(log_path, CONTROLLER_LOG_HEAD, ints={0, 6}) if log_path is not None else None
    events = EventLog(events_path) if side is not None else None
    pending: list[dict] = []
    t_start = time.perf_counter()
    cmd = drives.cmd if drives.loop is not None else None

    def act(s) -> None:
        if not isinstance(s, pr.Signals) or s.layout != drives.layout:
            raise LinkError(f"the plant at {client.address[0]}:{client.address[1]} serves another circuit "
                            f"(layout {getattr(s, 'layout', 'of the paper rig')}, expected {drives.layout} of "
                            f"{cs.circuit.name!r})")
        if pending:
            apply_controller_messages(pending, s.step, drives.steer, side, events, circuit=cs)
        values = drives.answer(s)
        client.send_inputs(drives.layout, drives.mask, values, answer=s)
        command = values[cmd] if cmd is not None else float("nan")
        if log is not None:
            log.write((s.header.seq, s.t_sim, time.perf_counter() - t_start, drives.measured, drives.reference,
                       command, s.status))
        if side is not None and side.row(s.step, drives.reference, drives.measured, command):
            side.flush()
            pending.extend(side.poll())

    try:
        sample_loop(client, act, mode=mode, sample_time=cs.step, should_stop=should_stop)
    finally:
        if log is not None:
            log.close()
        if events is not None:
            events.close()
    return {"circuit": cs.circuit.name, "layout": drives.layout, "commands_sent": client.seq,
            "sensor_packets": client.received, "sensor_packets_bad": client.bad, "sensor_packets_lost": client.lost,
            "stopped_by_signal": bool(should_stop())}


def replay_applied_inputs(cs, applied: np.ndarray, events: dict | None = None, keep_from: int = 0) -> np.ndarray:
    """The inputs that drove a run (``applied[k]``: every input as applied at step k, SI) and the plant's steering
    events ({k: [events]}, :func:`hydrohil.simulation.steering.apply_circuit_event` before step k) replayed through
    the circuit from its state at rest: its state columns at steps ``keep_from`` .. len(applied) (row k −
    keep_from), equal to the run's bit for bit when the plant stepped the model right, however late its
    commands came."""
    from hydrohil.circuits.rig import CircuitRig
    from hydrohil.simulation.steering import apply_circuit_event
    rig = CircuitRig(cs, network=False)            # (the inputs as applied: after the network's faults)
    idx = [rig.layout.log_columns.index(s) for s in rig.layout.states]
    events = events or {}
    n = len(applied)
    k0 = min(max(int(keep_from), 0), n)
    states = np.zeros((n + 1 - k0, len(idx)))
    if k0 == 0:
        states[k0] = rig.row[idx]
    every = (1 << len(rig.inputs)) - 1
    for k in range(n):
        for ev in events.get(k, ()):
            apply_circuit_event(rig, ev, k)
        rig.step(k, (every, applied[k].tolist()))
        if k + 1 >= k0:
            states[k + 1 - k0] = rig.row[idx]
    return states


def replay_inputs(cs, hil: dict, events: dict | None = None) -> np.ndarray:
    """The plant log's applied inputs (``<input>.applied``; row k + 1: step k's) and its steering ``events``
    replayed through the circuit from its state at rest (:func:`replay_applied_inputs`): the state columns they
    give, row by row."""
    n = len(hil["t"]) - 1
    names = [f"{name}.applied" for name in cs.circuit.inputs]
    applied = np.column_stack([hil[c][1:] for c in names]) if names else np.zeros((n, 0))
    return replay_applied_inputs(cs, applied, events)


def replay_circuit_session(cs, folder: Path, steps: int | None = None, keep_from: int = 0) -> np.ndarray:
    """A live-panel session of a circuit plant (its ``commands.f64``: every input as applied, a row per step;
    its ``events.jsonl``) replayed up to step ``steps`` (:func:`replay_applied_inputs`; rows from ``keep_from``)."""
    from hydrohil.hil.session import read_commands
    from hydrohil.simulation.steering import read_events
    ni = len(cs.circuit.inputs)
    u = read_commands(folder)
    applied = u[:len(u) // ni * ni].reshape(-1, ni) if ni else np.zeros((int(steps or 0), 0))
    n = len(applied) if steps is None else min(int(steps), len(applied))
    return replay_applied_inputs(cs, applied[:n], read_events(Path(folder) / "events.jsonl", "plant", circuit=cs),
                                 keep_from)


def compare_circuit_offline(cs, out: Path, *, plot: bool = True, verdict: dict | None = None,
                            plant: str | None = None) -> dict:
    """The scenario run offline (:func:`hydrohil.circuits.run.simulate_circuit`, every step) against the plant
    log: per state and mode the largest difference, the loop's measured signal (RMS against offline and against
    its reference); the replay of the applied inputs."""
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.units import display
    from hydrohil.simulation.outputs import read_csv_columns
    hil = read_csv_columns(out / "plant_log.csv")
    res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, method=cs.method, rest=cs.rest, loop=cs.loop,
                           commands=cs.commands)
    n = min(len(hil["t"]), len(res.columns["t"]))
    # the states (an output of an input, e.g. a burst's flow, is logged under the step's new input offline and
    # under the input applied before it by the plant: at a change of input they differ by design)
    from hydrohil.circuits.build import compile_circuit
    lay = compile_circuit(cs.circuit).layout
    states = [*lay.states, *lay.modes]
    diff = {s: float(np.max(np.abs(hil[s][:n] - res.columns[s][:n]))) if n else 0.0 for s in states}
    cmp = {"steps_compared": int(n), "max_abs_difference": diff,
           "identical": bool(n and all(v == 0.0 for v in diff.values()))}
    rms = lambda e: float(np.sqrt(np.mean(np.square(e)))) if len(e) else float("nan")    # noqa: E731
    if cs.loop is not None:
        m = cs.loop.measure
        ref = res.columns[f"{m}.reference"][:n]
        cmp.update(measure=m, unit=res.units.get(m, "-"), hil_vs_offline_rms=rms(hil[m][:n] - res.columns[m][:n]),
                   hil_tracking_rms=rms(hil[m][:n] - ref), offline_tracking_rms=rms(res.columns[m][:n] - ref))
        k, du = display(cmp["unit"])
        cmp["text"] = ("HIL = offline bit for bit in every state and mode" if cmp["identical"] else
                       f"HIL vs offline {m} RMS {cmp['hil_vs_offline_rms'] * k:.4g} {du}") + \
            f"; tracking RMS {cmp['hil_tracking_rms'] * k:.4g} {du}"
    else:
        worst = max(diff, key=lambda s: diff[s] * display(res.units.get(s, "-"))[0]) if diff else None
        cmp["text"] = "HIL = offline bit for bit in every state and mode" if cmp["identical"] or worst is None else \
            f"HIL vs offline: largest difference {worst} {diff[worst] * display(res.units[worst])[0]:.4g} " \
            f"{display(res.units[worst])[1]}"
    from hydrohil.simulation.steering import read_events
    steered = read_events(out / "events.jsonl", "plant", circuit=cs)
    n_ctl = sum(map(len, read_events(out / "controller_events.jsonl", "controller", circuit=cs).values())) \
        if cs.loop is not None else 0
    if steered or n_ctl:         # changed from the live panel: the offline run is the scenario's, unsteered
        cmp["steered_events"] = {"plant": sum(map(len, steered.values())), "controller": n_ctl}
        cmp["text"] += " (the run was steered from the live panel; the offline run was not)"
    if n > 1:
        rep = replay_inputs(cs, hil, steered)
        logged = np.column_stack([hil[s] for s in lay.states])
        cmp["replay_max_abs_difference"] = float(np.max(np.abs(rep - logged)))
    (out / "comparison.json").write_text(json.dumps(cmp, indent=2) + "\n")
    if plot:
        from hydrohil.plotting import plot_circuit_hil
        which = {"c": " (standalone C plant)", "python": " (Python plant)"}.get(plant or "", "")
        plot_circuit_hil(out / "report.png", hil, res, cs.loop.measure if cs.loop is not None else None,
                         title=f"{Path(cs.source).name} ({cs.circuit.name}): HIL{which} vs offline", verdict=verdict,
                         inputs=lay.inputs, commanded=cs.loop is not None or cs.commands is not None)
    return cmp
