"""``hydrohil panel``: the live instrument panel of a running rig, served on loopback.

One asyncio process (aiohttp); :class:`Panel` puts together, each in its module:

* the side channel (:mod:`hydrohil.panel.hub`): telemetry batches from the plant and the controller
  (:mod:`hydrohil.hil.sidechannel`) into :class:`~hydrohil.panel.traces.Traces`; steering messages out, each
  answered with the step index at which it was applied;
* the sessions (:mod:`hydrohil.panel.sessions`): with ``own=True`` (``hydrohil panel``) the plant and
  controller processes of each session, and the recordings made in it;
* the web side (:mod:`hydrohil.panel.web`): the page, a WebSocket per browser, the HTTP API, the security
  rules;

and keeps, here, what was steered (tunables, faults switched on, gains, reference, the applied changes) and
the state the page shows.
"""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path

from hydrohil.errors import HydrohilError, InputError
from hydrohil.panel.hub import SideHub
from hydrohil.panel.sessions import SessionSupervisor
from hydrohil.panel.web import PanelWeb

# a set's slots the standalone C plant takes in one message (rt_side.h: J_FIELDS 32, less the message's own)
C_PLANT_MAX_SLOTS = 24


class Panel:
    """The panel of one scenario. ``own``: start/stop the plant (and built-in controller) processes here
    (``hydrohil panel``); else attach to processes someone else started (``hydrohil hil --panel``). ``plant``:
    "python" (``hydrohil plant``) or "c" (the standalone C plant built for the scenario): the same side channel."""

    def __init__(self, scenario: Path, out: Path, *, own: bool = True, controller: str = "builtin",
                 lockstep: bool = False, params: str | None = None, sets: dict | None = None,
                 host: str = "127.0.0.1", port: int = 0, allow_remote: bool = False,
                 plant_port: int = 47000, plant: str = "python"):
        from hydrohil.circuits.scenario import NO_PARAMETER_SET, is_circuit_scenario
        from hydrohil.hil.run import PLANTS
        from hydrohil.panel.views import circuit_view, paper_view
        self.scenario_path, self.out = Path(scenario), Path(out)
        self.params_arg, self.sets = params, sets
        if controller not in ("builtin", "external"):
            raise InputError(f"--controller must be builtin or external, got {controller!r}", key="controller")
        if plant not in PLANTS:
            raise InputError(f"--plant must be one of {', '.join(PLANTS)}, got {plant!r}", key="plant")
        self.sc = self.cs = None
        if is_circuit_scenario(self.scenario_path):      # a circuit: its signals, inputs and parameters
            from hydrohil.circuits.scenario import load_circuit_scenario
            from hydrohil.simulation.scenario import circuit_hil
            if params is not None:
                raise InputError(NO_PARAMETER_SET, key="--params")
            cs = self.cs = load_circuit_scenario(self.scenario_path, sets=sets)
            self.hil, self.h, self.view = circuit_hil(cs), cs.step, circuit_view(cs)
            self.controller_type = cs.loop.cfg.type if cs.loop is not None else None
        else:
            from hydrohil.simulation.scenario import load_scenario
            self.sc = load_scenario(self.scenario_path, params=params, sets=sets)
            s = self.sc.scenario
            if controller == "builtin" and not s.closed_loop:
                raise InputError("the panel's built-in controller needs a closed-loop scenario ([controller] + "
                                 "[reference]); or use --controller external", source=str(scenario))
            self.hil, self.h, self.view = s.hil, s.plant_step, paper_view()
            self.controller_type = s.controller.type if s.controller else None
        # the columns a frame carries: every plotted one, the mode strips, the step jitter and the watchdog
        shown = [col for pl in self.view["plots"] for col, *_ in pl["series"]]
        shown += [col for col, *_ in (self.view["modes"] or {}).get("rows", [])]
        extra = [c for c in ("jitter_us", "watchdog", "faults") if c in self.view["plant_columns"]]
        self.shown = list(dict.fromkeys([*shown, *extra]))
        self.own, self.controller_kind, self.lockstep, self.plant = own, controller, lockstep, plant
        self.plant_port = plant_port
        self.hub = SideHub(self.h, self.view["plant_columns"], self.view["controller_columns"])
        self.supervisor = SessionSupervisor(self)
        self.web = PanelWeb(self, host=host, port=port, allow_remote=allow_remote)
        self.reset_steering()
        self.watcher = None

    # -- what was steered --------------------------------------------------------------------------
    def reset_steering(self) -> None:
        """The scenario's values again (a new session)."""
        self.tunables = {}
        if self.sc is not None:
            p = self.sc.params
            self.tunables = {"mass": p.load.mass, "force": p.load.force, "supply_pressure": p.supply.ps,
                             "friction_scale": 1.0}
        self.values: dict[str, float] = {}           # a circuit's parameters changed from the panel
        if self.cs is not None:                      # ... and its parameters with them (what the slots derive from)
            c = self.cs.circuit
            self.parameters = ({n: dict(comp.params) for n, comp in c.components.items()}, dict(c.fluid))
        self.held: dict[str, float] = {}             # a circuit's inputs held from the panel
        self.faults: dict[int, dict] = {}            # slot -> fault switched on from the panel
        self.switched: dict[int, bool] = {}          # a circuit's fault (its [[faults]] place) -> switched on
        self.gains = self._initial_gains()
        self.reference: float | None = None
        self.events: list[dict] = []                 # applied changes, newest last (shown on the page)

    def _initial_gains(self) -> dict:
        if self.cs is not None:
            c = self.cs.loop.cfg if self.cs.loop is not None else None
        else:
            c = self.sc.scenario.controller
        if c is None or self.controller_kind != "builtin" or c.type == "python":
            return {}
        from hydrohil.simulation.steering import GAINS
        return {g: getattr(c, g) for g in GAINS if g in type(c).model_fields}

    async def steer(self, body: dict) -> dict:
        """Validate a change here (clear errors before anything is sent), send it to the process it concerns,
        keep what the page shows in step with what was applied."""
        from hydrohil.simulation.steering import parse_event
        k_requested = self.hub.traces.k_max     # the newest step the plant had reported when the request came
        op = body.get("op")
        role = "controller" if op in ("gains", "reference") or body.get("target") == "controller" else "plant"
        body = {k: v for k, v in body.items() if k != "target"}
        ev = parse_event(body, role, source="request", circuit=self.cs)
        if role == "controller" and self.controller_kind != "builtin":
            raise InputError("the controller is your own: its gains and reference are not the panel's", source="request")
        changed = None
        if op == "set" and self.cs is not None:      # the slots it sets, derived values with them (both plants)
            from hydrohil.circuits.rig import parameter_change
            try:
                slots, *changed = parameter_change(self.cs.circuit, self.cs.layout, *self.parameters, ev.name,
                                                   ev.value)
            except ValueError as exc:
                raise InputError(str(exc), source="request") from None
            if self.plant == "c" and len(slots) > C_PLANT_MAX_SLOTS:
                raise InputError(f"{ev.name} changes {len(slots)} values of the parameter vector (itself and what "
                                 f"derives from it): more than the C plant takes in one message "
                                 f"({C_PLANT_MAX_SLOTS}); run the panel on the Python plant for it", source="request",
                                 key=ev.name)
            ev = ev.model_copy(update={"slots": {str(i): v for i, v in slots.items()}})
        body = ev.model_dump(exclude_none=True)
        if op == "fault" and self.plant == "c":      # (the C plant's messages take an input by its place)
            body["inputs"] = {str(self.cs.layout.inputs.index(n)): v for n, v in body["inputs"].items()}
        ans = await self.hub.send(role, body)
        if "error" in ans:
            raise InputError(ans["error"], source=role)
        d = ev.model_dump(exclude_none=True)
        if changed is not None:
            self.parameters = tuple(changed)
        if op == "set":
            (self.values if self.cs is not None else self.tunables)[d["name"]] = d["value"]
        elif op == "input":
            if d.get("value") is None:
                self.held.pop(d["name"], None)
            else:
                self.held[d["name"]] = d["value"]
        elif op == "fault_on":
            self.faults[ans["slot"]] = d["fault"]
        elif op == "fault_off":
            self.faults.pop(d["slot"], None)
        elif op == "fault":
            self.switched[d["slot"]] = d["on"]
        elif op == "gains":
            self.gains.update({k: v for k, v in d.items() if k != "op"})
        elif op == "reference":
            self.reference = d.get("value")
        self.events.append({"k": ans["k"], "k_requested": k_requested, "t": ans["k"] * self.h, "process": role, **d})
        return {"k": ans["k"], "k_requested": k_requested, **{k: v for k, v in ans.items() if k not in ("ack", "k")}}

    # -- state shown on the page -----------------------------------------------------------------
    def state(self) -> dict:
        from hydrohil.hil.verdict import judge
        from hydrohil.panel.schema import fault_schema, tunable_schema
        runs = self.supervisor
        c = self.hub.counters
        steps = c["steps"]
        timing = {"mode": "lockstep" if self.lockstep else "realtime", "steps": steps,
                  "late_commands": c["late_commands"], "overruns": c["overruns"],
                  "jitter_us_max": c["jitter_max_ns"] / 1e3, "watchdog_trips_unexplained": c["watchdog_trips_unexplained"]}
        return {"scenario": self.scenario_path.name, "plant": self.plant, "step_s": self.h, "running": runs.running,
                "controller": self.controller_kind, "controller_type": self.controller_type,
                "session": str(runs.folder) if runs.folder else None, "lockstep": self.lockstep,
                "view": self.view, "values": self.values, "held": self.held, "tunables": self.tunables,
                "tunable_schema": tunable_schema() if self.sc is not None else [],
                "fault_schema": fault_schema() if self.sc is not None else [],
                "faults": [{"slot": k, **v} for k, v in sorted(self.faults.items())], "gains": self.gains,
                "switched": {str(k): v for k, v in self.switched.items()},
                "reference": self.reference, "recording": runs.recording, "recordings": runs.recordings,
                "events": self.events[-30:], "counters": c,
                "verdict": judge(timing, self.hil) if steps else None, "ended": runs.ended,
                "plant_address": f"127.0.0.1:{self.plant_port}" if self.controller_kind == "external" else None,
                "own": self.own}

    # -- what hydrohil panel / hil --panel use -------------------------------------------------------
    @property
    def url(self) -> str | None:
        return self.web.url

    @property
    def side_address(self) -> str:
        return self.hub.address

    @property
    def sessions(self) -> list[Path]:
        """The session folders this panel made."""
        return self.supervisor.folders

    @property
    def ended(self) -> dict | None:
        """How the last session ended (its timing.json, with the processes' exit codes)."""
        return self.supervisor.ended

    def session_tables(self) -> dict:
        return self.supervisor.tables()

    async def start_session(self) -> None:
        await self.supervisor.start()

    # -- life cycle ---------------------------------------------------------------------------------
    async def open(self, side_port: int = 0) -> str:
        """Bind the side channel and the web server. Returns the URL."""
        await self.hub.open(side_port)
        url = await self.web.open()
        self.watcher = asyncio.ensure_future(self.supervisor.watch())
        return url

    async def close(self) -> None:
        runs = self.supervisor
        if self.own and runs.running:
            try:
                await runs.stop()
            except HydrohilError:
                pass
        runs.stop_children()
        await runs.finish_reports()
        if self.watcher is not None:
            self.watcher.cancel()
        await self.web.close()
        self.hub.close()


class PanelThread:
    """A panel attached to processes started elsewhere (``hydrohil hil --panel``), served from a thread of
    the supervising process. ``side_address`` is the side channel to give the plant and controller."""

    def __init__(self, scenario: Path, out: Path, **kw):
        self.loop = asyncio.new_event_loop()
        self.panel = Panel(scenario, out, own=False, **kw)
        self.panel.supervisor.folder = Path(out)      # the run folder: its recordings go there
        self.ready = threading.Event()
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, daemon=True, name="hydrohil-panel")
        self.thread.start()
        self.ready.wait(120)
        if self.panel.url is None:
            raise HydrohilError(f"the panel's server did not start: {self.error or 'no answer within 120 s'}")

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        try:
            self.loop.run_until_complete(self.panel.open())
        except (OSError, HydrohilError) as exc:      # e.g. the port is taken: said by the caller
            self.error = exc
            return
        finally:
            self.ready.set()
        self.panel.supervisor.running = True
        self.loop.run_forever()

    @property
    def url(self) -> str:
        return self.panel.url

    @property
    def side_address(self) -> str:
        return self.panel.side_address

    def close(self) -> None:
        fut = asyncio.run_coroutine_threadsafe(self.panel.close(), self.loop)
        try:
            fut.result(30)
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join(10)
