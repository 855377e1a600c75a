"""``hydrohil hil``: plant and controller as two OS processes over UDP loopback, then the report.

The plant process (``hydrohil plant --scenario ... --peer 127.0.0.1:C``) prints ``READY host:port`` once
bound; the controller process (``hydrohil controller --scenario ... --connect host:port --local
127.0.0.1:C``) then runs the scenario's P controller from the one address the plant accepts. Each process
ends by itself: the plant after the scenario's duration, the controller at the plant's final packet (or
with an error when the plant goes silent for ``[hil] link_timeout``). Ctrl-C stops both with SIGINT (they
finish their logs). Afterwards the same scenario runs offline (``hydrohil simulate``'s code path) for the
comparison, and the plant's applied commands are replayed through the model (an exact check on any
machine); the plant's verdict (:mod:`hydrohil.hil.verdict`) says whether the run is VALID.
"""

from __future__ import annotations

import json
import signal
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Protocol

import numpy as np

from hydrohil.errors import HydrohilError, InputError, Interrupted, LinkError
from hydrohil.circuits.scenario import is_circuit_scenario
from hydrohil.hil.circuit import compare_circuit_offline
from hydrohil.simulation.scenario import circuit_hil
from hydrohil.hil.processes import Child, free_udp_port, process_command
from hydrohil.simulation.outputs import read_csv_columns
from hydrohil.simulation.scenario import load_scenario

READY_TIMEOUT_S = 120.0    # a child that has not bound its socket by then is stuck (a loaded machine: seconds)
EXIT_GRACE_S = 30.0        # after one process ended, the other gets its own timeout plus this to end


@dataclass
class HilResult:
    out: Path
    timing: dict
    controller: dict
    comparison: dict

    @property
    def verdict(self) -> dict:
        return self.timing["verdict"]


PLANTS = ("python", "c")


class LiveView(Protocol):
    """What ``run_hil(live=...)`` attaches to a run (the live panel, :class:`hydrohil.panel.server.PanelThread`):
    a side channel for both processes, a URL to print, and a close at the end."""
    url: str
    side_address: str

    def close(self) -> None: ...


def c_plant_executable(sc, scenario: Path) -> Path:
    """The standalone C plant built for a loaded scenario (:func:`hydrohil.export.cplant.cached_plant`)."""
    from hydrohil.export.cplant import cached_plant, scenario_options
    return cached_plant(sc.params, **scenario_options(sc.scenario), label=Path(scenario).name)


def plant_command(sc, scenario: Path, out: Path, peer: str | None, *, lockstep: bool = False,
                  plant: str = "python", bind: str = "127.0.0.1:0", extra: tuple = ()) -> list:
    """The command line of the plant process: ``hydrohil plant`` (``plant="python"``) or the standalone C
    plant of :mod:`hydrohil.export.cplant` built for this scenario (cached), with the same options. ``peer``:
    the only controller address it accepts (None: the first that speaks); ``extra``: options both plants take
    (``--panel``, ``--no-rows``, ``--duration``, ``--connect-timeout``)."""
    tail = ["--bind", bind, "--log", out, *(["--peer", peer] if peer else []),
            *(["--lockstep"] if lockstep else []), *extra]
    if plant == "python":
        return process_command("plant", "--scenario", scenario, *tail)
    if plant != "c":
        raise InputError(f"--plant must be one of {', '.join(PLANTS)}, got {plant!r}", key="plant")
    if hasattr(sc, "circuit"):        # a circuit scenario: its own standalone plant (rt_circuit.c)
        from hydrohil.export.cplant import cached_circuit_plant
        cpu = circuit_hil(sc).cpus()[0]
        return [cached_circuit_plant(sc), *tail, *(["--cpu", cpu] if cpu is not None else [])]
    from hydrohil.export.cplant import fault_options
    s = sc.scenario
    exe = c_plant_executable(sc, scenario)
    cpu = s.hil.cpus()[0]
    return [exe, *tail, *(["--cpu", cpu] if cpu is not None else []), *fault_options(s.faults)]


def run_hil(scenario: str | Path, out: str | Path, *, lockstep: bool = False,
            progress: Callable[[float, float], None] | None = None, plot: bool = True,
            plant: str = "python", params: str | Path | None = None, sets: dict | None = None,
            live: Callable[[Path, Path], LiveView] | None = None, ready=print,
            controller: str | None = None) -> HilResult:
    """Run a scenario as a HIL experiment; writes plant_log.csv, controller_log.csv, timing.json (with the
    verdict), comparison.json and report.png into ``out``. ``plant``: "python" (``hydrohil plant``) or "c"
    (the standalone C plant, built and cached on first use). ``params`` / ``sets`` replace the scenario's
    parameter set / apply on top of its overrides (the scenario as run is written to ``out/scenario.toml``).
    ``live``: a live view to attach while it runs, made as ``live(scenario as run, out)`` (the panel:
    ``functools.partial(hydrohil.panel.server.PanelThread, port=..., lockstep=...)``; ``ready`` prints
    ``PANEL <url>``): both processes send it telemetry and take steering from it through its side channel
    (applied changes in ``events.jsonl`` / ``controller_events.jsonl``, replayed by the offline
    comparison). ``controller``: the command
    line of an external controller program that speaks the protocol (docs/protocol.md) instead of the
    scenario's controller process: ``{host}``, ``{port}`` (the plant's address), ``{scenario}`` (the scenario
    file as run), ``{duration}`` [s] and ``{out}`` are filled in, e.g. ``"./p_controller {host} {port} 50 0.1"``.
    Raises LinkError / HydrohilError when a process failed, Interrupted on Ctrl-C (after both processes
    finished their logs)."""
    scenario, out = Path(scenario), Path(out)
    circuit = None
    if is_circuit_scenario(scenario):      # any circuit: its signals and inputs over the link (hil/circuit.py)
        circuit, scenario, hil_cfg = _circuit_run(scenario, out, params=params, sets=sets)
        duration = circuit.duration
    else:
        sc = load_scenario(scenario, params=params, sets=sets)     # validate before starting anything
        if params is not None or sets:         # the run folder records what ran; both processes read it
            from hydrohil.simulation.scenario import write_scenario
            scenario = write_scenario(scenario, out / "scenario.toml", params=params, sets=sets)
        if not sc.scenario.closed_loop:
            raise InputError("hydrohil hil needs a closed-loop scenario ([controller] + [reference])",
                             source=str(scenario))
        hil_cfg, duration = sc.scenario.hil, sc.scenario.duration
    ctl_address = f"127.0.0.1:{free_udp_port()}" if controller is None else None
    command = plant_command(circuit or sc, scenario, out, ctl_address, lockstep=lockstep, plant=plant)
    out.mkdir(parents=True, exist_ok=True)
    view = side = None
    if live is not None:
        for name in ("events.jsonl", "controller_events.jsonl"):    # a run folder used again: this run's only
            (out / name).unlink(missing_ok=True)
        view = live(scenario, out)
        side = ["--panel", view.side_address]
        command += side
        ready(f"PANEL {view.url}", flush=True)
    plant = Child(command, "plant")
    ctl = None
    try:
        address = plant.wait_line("READY ", READY_TIMEOUT_S)
        ctl = Child(controller_args(controller, address, scenario, duration, out)
                    if controller is not None else
                    process_command("controller", "--scenario", scenario, "--connect", address, "--log", out, "--local",
                        ctl_address, *(side or [])), "controller")
        _supervise(plant, ctl, duration, hil_cfg, progress)
    except KeyboardInterrupt as exc:         # Ctrl-C (or SIGTERM, see terminal.interruptible)
        for p in (ctl, plant):
            if p is not None:
                p.stop()
        raise Interrupted(getattr(exc, "signum", signal.SIGINT), f"HIL run interrupted; logs so far in {out}") from None
    finally:
        for p in (ctl, plant):
            if p is not None and p.poll() is None:
                p.stop()
        if view is not None:
            view.close()
    # a plant that crashed explains a controller that then found it silent: report the plant first
    order = (plant, ctl) if plant.returncode not in (0, 3, 4, 130, 143) else (ctl, plant)
    for p in order:
        if p.returncode not in ((0, 3) if p is plant else (0,)):   # plant 3: INVALID, logs and verdict complete
            raise (LinkError if p.returncode == 4 else HydrohilError)(
                f"{p.name} process failed (exit {p.returncode}): {p.stderr()[-2000:]}")
    timing = json.loads((out / "timing.json").read_text())
    ctl_summary = json.loads((out / "controller.json").read_text()) if controller is None else {"command": controller}
    if circuit is not None:
        comparison = compare_circuit_offline(circuit, out, plot=plot, verdict=timing.get("verdict"),
                                             plant=timing.get("plant"))
    else:
        comparison = compare_offline(scenario, out, plot=plot, verdict=timing.get("verdict"),
                                     plant=timing.get("plant"))
    return HilResult(out, timing, ctl_summary, comparison)


def _circuit_run(scenario: Path, out: Path, *, params, sets):
    """A circuit scenario checked for a HIL run (before anything starts or is written), the file both processes
    read (the scenario itself, or with ``sets`` applied ``out/scenario.toml``) and its [hil] settings."""
    from hydrohil.circuits.scenario import NO_PARAMETER_SET, load_circuit_scenario, write_circuit_scenario
    if params is not None:
        raise InputError(NO_PARAMETER_SET, key="--params")
    cs = load_circuit_scenario(scenario, sets=sets)
    hil = circuit_hil(cs)
    if sets:
        scenario = write_circuit_scenario(scenario, out / "scenario.toml", sets=sets)
    return cs, scenario, hil


def controller_args(template: str, address: str, scenario: Path, duration: float, out: Path) -> list[str]:
    """An external controller's command line (``run_hil(controller=...)``) with its fields filled in."""
    import shlex
    host, _, port = address.rpartition(":")
    try:
        text = template.format(host=host, port=port, scenario=shlex.quote(str(scenario)), duration=duration,
                               out=shlex.quote(str(out)))
    except (KeyError, IndexError, ValueError) as exc:
        raise InputError(f"unknown field {exc} in {template!r} (fields: {{host}} {{port}} {{scenario}} "
                         "{duration} {out})", key="controller") from None
    args = shlex.split(text)
    if not args:
        raise InputError("empty controller command", key="controller")
    import shutil
    if shutil.which(args[0]) is None:
        raise InputError(f"no executable program {args[0]!r} (a path, or a program on PATH)", key="controller")
    return args


def _supervise(plant: Child, ctl: Child, duration: float, hil_cfg, progress) -> None:
    """Wait until both processes have ended by themselves. One that ends with an error stops the other;
    once one has ended, the other gets its own timeout plus a grace period before it is stopped."""
    t0 = time.monotonic()
    t_first_end = None
    while plant.poll() is None or ctl.poll() is None:
        if progress:
            progress(min(time.monotonic() - t0, duration), duration)
        if ctl.poll() not in (None, 0):            # the controller failed: no point in serving the plant on
            plant.stop()
            break
        if (plant.poll() is None) != (ctl.poll() is None):
            t_first_end = t_first_end or time.monotonic()
            limit = (hil_cfg.link_timeout if plant.poll() is not None else hil_cfg.watchdog_timeout) + EXIT_GRACE_S
            if time.monotonic() - t_first_end > limit:
                (ctl if ctl.poll() is None else plant).stop()
        time.sleep(0.05)
    if progress:
        progress(duration, duration)


def replay_commands(sc, hil: dict, events: dict | None = None) -> np.ndarray:
    """The plant log's applied valve commands (column ``u``) and the run's plant events replayed through the
    model (:func:`hydrohil.hil.session.replay_applied`): the piston positions they give. Equal to the log's
    ``xp`` bit for bit when the plant stepped the model correctly, however late its commands came."""
    from hydrohil.hil.session import replay_applied
    return replay_applied(sc, np.asarray(hil["u"][1:], float), events)["xp"]


def compare_offline(scenario: Path, out: Path, *, plot: bool = True, verdict: dict | None = None,
                    plant: str | None = None) -> dict:
    """Offline run of the same scenario; position RMS/max difference to the HIL plant log; the replay of
    the plant's applied commands (:func:`replay_commands`)."""
    from hydrohil.simulation.steering import read_events
    from hydrohil.simulation.run import run_scenario
    sc = load_scenario(scenario)
    hil = read_csv_columns(out / "plant_log.csv")
    events = read_events(out / "events.jsonl", "plant")
    ctl_events = read_events(out / "controller_events.jsonl", "controller")
    if events or ctl_events:        # a steered run (the live panel): the offline run replays the changes
        from hydrohil.simulation.rig import run_rig
        res = run_rig(sc, events=events, controller_events=ctl_events, steps=max(len(hil["t"]) - 1, 0))
    else:
        res = run_scenario(sc)
    n = min(len(hil["t"]), len(res.log))
    d = hil["xp"][:n] - res.column("xp")[:n]
    ref = sc.scenario.references()[0][:n]
    cmp = {"steps_compared": int(n), "xp_rms_mm": float(np.sqrt(np.mean(d ** 2)) * 1e3),
           "xp_max_mm": float(np.max(np.abs(d)) * 1e3),
           "p1_rms_bar": float(np.sqrt(np.mean((hil["p1"][:n] - res.column("p1")[:n]) ** 2)) / 1e5),
           "hil_tracking_rms_mm": float(np.sqrt(np.mean((hil["xp"][:n] - ref) ** 2)) * 1e3),
           "offline_tracking_rms_mm": float(np.sqrt(np.mean((res.column("xp")[:n] - ref) ** 2)) * 1e3)}
    from hydrohil.metrics import step_metrics
    t = hil["t"][:n]
    cmp["step_response_hil"] = step_metrics(t, hil["xp"][:n], ref, hil["p1"][:n], hil["p2"][:n])
    cmp["step_response_offline"] = step_metrics(t, res.column("xp")[:n], ref, res.column("p1")[:n],
                                                res.column("p2")[:n])
    if len(hil["u"]):
        cmp["replay_xp_max_abs_m"] = float(np.max(np.abs(replay_commands(sc, hil, events) - hil["xp"])))
    (out / "comparison.json").write_text(json.dumps(cmp, indent=2) + "\n")
    if plot:
        from hydrohil.plotting import plot_hil
        which = {"c": " (standalone C plant)", "python": " (Python plant)"}.get(plant or "", "")
        plot_hil(out / "report.png", hil, res, ref, title=f"{scenario.name}: HIL{which} vs offline", verdict=verdict,
                 metrics=cmp["step_response_hil"])
    return cmp
