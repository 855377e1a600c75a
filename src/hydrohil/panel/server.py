"""``hydrohil panel``: the live instrument panel of a running rig, served on loopback.

One asyncio process (aiohttp) owns:

* the side-channel socket: telemetry batches from the plant and the controller (:mod:`hydrohil.hil.sidechannel`)
  into :class:`~hydrohil.panel.traces.Traces`; steering messages out, each answered with the step index at
  which it was applied;
* the page (``static/``, the project's own code: no CDN, no Node.js) and a WebSocket per browser: a frame of
  min/max envelopes every 40 ms (25 frames/s); a browser that does not read its frames gets none until it
  does (its frames are skipped, nothing queues);
* the HTTP API the page (and scripts, and tests) use: ``/api/state``, ``/api/steer``, ``/api/run/{start,stop}``,
  ``/api/record/{start,stop}``, ``/api/recordings``, ``/recordings/NAME.zip``;
* with ``own=True`` (``hydrohil panel``) the plant and controller processes of each session.

Security: bound to 127.0.0.1 and requests for another Host refused (DNS rebinding), unless
``allow_remote``: then every HTTP and WebSocket request must carry the token (``?token=``, header
``X-Hydrohil-Token`` or the cookie the page sets) and a WebSocket's Origin must be the panel's own.
"""

from __future__ import annotations

import asyncio
import hmac
import json
import math
import os
import secrets
import socket
import struct
import sys
import threading
import time
import zipfile
from pathlib import Path

import numpy as np
from aiohttp import WSMsgType, web

from hydrohil.errors import HydrohilError, InputError
from hydrohil.hil.sidechannel import (CONTROLLER_COLUMNS, PLANT_COLUMNS, PLANT_COUNTERS, ROLE_CONTROLLER, ROLE_PLANT,
                                      parse_batch)
from hydrohil.panel.traces import JITTER_BINS, Traces

STATIC = Path(__file__).parent / "static"
FRAME_S = 0.04                   # 25 frames/s
ACK_TIMEOUT_S = 3.0
SHOWN = ("xp", "x_ref", "error", "p1", "p2", "ps", "xs", "u", "ff", "travel_mode", "friction_mode", "spool_mode",
         "jitter_us", "watchdog", "faults")
TOKEN_COOKIE = "hydrohil_token"
JITTER_EDGES_US = [float(e) for e in JITTER_BINS[1:-1]]     # (sent with every frame: made once)


def _view(text: str) -> dict:
    """The view a page asks for, checked (anything malformed is ignored, never an error in the frame loop)."""
    out = {}
    try:
        v = json.loads(text)
        if not isinstance(v, dict):
            return out
        w = float(v.get("window", 10.0))
        if math.isfinite(w):
            out["window"] = w
        if "end_k" in v:
            out["end_k"] = None if v["end_k"] is None else int(v["end_k"])
        if "points" in v:
            out["points"] = int(v["points"])
        if "paused" in v:
            out["paused"] = bool(v["paused"])
    except (ValueError, TypeError, OverflowError):
        pass
    return out


class SideProtocol(asyncio.DatagramProtocol):
    def __init__(self, panel: "Panel"):
        self.panel = panel

    def datagram_received(self, data: bytes, addr) -> None:
        self.panel.on_datagram(data, addr)


def went_away(request: web.Request, why) -> None:
    """One line on stderr for a browser that disconnected mid-request (no traceback: nothing is wrong here)."""
    print(f"panel: the browser at {request.remote} went away during {request.method} {request.path} ({why})",
          file=sys.stderr, flush=True)


class Panel:
    """The panel of one scenario. ``own``: start/stop the plant (and built-in controller) processes here
    (``hydrohil panel``); else attach to processes someone else started (``hydrohil hil --panel``)."""

    def __init__(self, scenario: Path, out: Path, *, own: bool = True, controller: str = "builtin",
                 lockstep: bool = False, params: str | None = None, sets: dict | None = None,
                 host: str = "127.0.0.1", port: int = 0, allow_remote: bool = False,
                 plant_port: int = 47000):
        from hydrohil.simulation.scenario import load_scenario
        self.scenario_path, self.out = Path(scenario), Path(out)
        self.sc = load_scenario(self.scenario_path, params=params, sets=sets)
        self.params_arg, self.sets = params, sets
        s = self.sc.scenario
        if controller not in ("builtin", "external"):
            raise InputError(f"--controller must be builtin or external, got {controller!r}", key="controller")
        if controller == "builtin" and not s.closed_loop:
            raise InputError("the panel's built-in controller needs a closed-loop scenario ([controller] + "
                             "[reference]); or use --controller external", source=str(scenario))
        self.own, self.controller_kind, self.lockstep = own, controller, lockstep
        self.h = s.plant_step
        self.host, self.port, self.allow_remote = host, port, allow_remote
        self.plant_port = plant_port
        self.token = secrets.token_urlsafe(18) if allow_remote else None
        self.traces = Traces(self.h)
        self.counters = {**dict.fromkeys(PLANT_COUNTERS, 0), "telemetry_lost_steps": 0}
        self.peers: dict[str, tuple] = {}            # role -> side-channel address of that process
        self.acks: dict[int, asyncio.Future] = {}
        self.next_id = 1
        self.session: Path | None = None
        self.session_n = 0
        self.sessions: list[Path] = []               # the session folders this panel made
        self.running = False
        self.stopping = False                        # a stop is under way (the watcher leaves the children alone)
        self.children: list = []
        self.ended: dict | None = None               # the last session's timing (when it ended)
        self.recording: dict | None = None          # the recording under way
        self.recordings: list[dict] = []
        self.reports: list = []                      # recordings' reports being made (awaited at a session's end)
        self.events: list[dict] = []                 # applied changes, newest last (shown on the page)
        self.tunables = self._initial_tunables()
        self.faults: dict[int, dict] = {}            # slot -> fault switched on from the panel
        self.gains = self._initial_gains()
        self.reference: float | None = None
        self.frames_sent = 0
        self.sockets: set = set()
        self.udp = None
        self.url = None
        self.cpu0 = time.process_time()

    # -- state shown on the page -----------------------------------------------------------------
    def _initial_tunables(self) -> dict:
        p = self.sc.params
        return {"mass": p.load.mass, "force": p.load.force, "supply_pressure": p.supply.ps, "friction_scale": 1.0}

    def _initial_gains(self) -> dict:
        c = self.sc.scenario.controller
        if c is None or self.controller_kind != "builtin" or c.type == "python":
            return {}
        from hydrohil.simulation.steering import GAINS
        return {g: getattr(c, g) for g in GAINS if g in type(c).model_fields}

    def state(self) -> dict:
        from hydrohil.panel.schema import fault_schema, tunable_schema
        from hydrohil.hil.verdict import judge
        s = self.sc.scenario
        c = self.counters
        steps = c["steps"]
        timing = {"mode": "lockstep" if self.lockstep else "realtime", "steps": steps,
                  "late_commands": c["late_commands"], "overruns": c["overruns"],
                  "jitter_us_max": c["jitter_max_ns"] / 1e3, "watchdog_trips_unexplained": c["watchdog_trips_unexplained"]}
        return {"scenario": self.scenario_path.name, "step_s": self.h, "running": self.running,
                "controller": self.controller_kind, "controller_type": s.controller.type if s.controller else None,
                "session": str(self.session) if self.session else None, "lockstep": self.lockstep,
                "tunables": self.tunables, "tunable_schema": tunable_schema(), "fault_schema": fault_schema(),
                "faults": [{"slot": k, **v} for k, v in sorted(self.faults.items())], "gains": self.gains,
                "reference": self.reference, "recording": self.recording, "recordings": self.recordings,
                "events": self.events[-30:], "counters": c,
                "verdict": judge(timing, s.hil) if steps else None, "ended": self.ended,
                "plant_address": f"127.0.0.1:{self.plant_port}" if self.controller_kind == "external" else None,
                "own": self.own}

    # -- side channel ------------------------------------------------------------------------------
    def on_datagram(self, data: bytes, addr) -> None:
        if data[:4] == b"HHTM":
            b = parse_batch(data)
            if b is None:
                return
            role, k0, counters, ncols, nrows, payload = b
            rows = np.frombuffer(payload, dtype="<f8").reshape(nrows, ncols)
            if role == ROLE_PLANT and ncols == len(PLANT_COLUMNS):
                self.peers.setdefault("plant", addr)
                self.traces.add_plant(k0, rows)
                self.counters = {**dict(zip(PLANT_COUNTERS, counters)), "telemetry_lost_steps": self.traces.lost}
            elif role == ROLE_CONTROLLER and ncols == len(CONTROLLER_COLUMNS):
                self.peers.setdefault("controller", addr)
                self.traces.add_controller(k0, rows)
            return
        try:
            msg = json.loads(data)
        except ValueError:
            return
        if "hello" in msg:
            self.peers[msg["hello"]] = addr
        elif "ack" in msg:
            fut = self.acks.pop(int(msg["ack"]), None)
            if fut is not None and not fut.done():
                fut.set_result(msg)

    async def send(self, role: str, msg: dict) -> dict:
        """Send a steering message to ``role``'s process, resent until answered (at most ACK_TIMEOUT_S);
        returns the answer ({"k": step applied, ...} or {"error": ...})."""
        addr = self.peers.get(role)
        if addr is None:
            raise InputError(f"no {role} process is connected to the panel", source="panel")
        mid = self.next_id
        self.next_id += 1
        msg = {**msg, "id": mid}
        fut = asyncio.get_running_loop().create_future()
        self.acks[mid] = fut
        data = json.dumps(msg).encode()
        end = time.monotonic() + ACK_TIMEOUT_S
        while time.monotonic() < end:
            self.udp.sendto(data, addr)
            try:
                return await asyncio.wait_for(asyncio.shield(fut), 0.5)
            except asyncio.TimeoutError:
                continue
        self.acks.pop(mid, None)
        raise HydrohilError(f"the {role} did not answer within {ACK_TIMEOUT_S:g} s")

    async def steer(self, body: dict) -> dict:
        """Validate a change here (clear errors before anything is sent), send it to the process it concerns,
        keep what the page shows in step with what was applied."""
        from hydrohil.simulation.steering import parse_event
        k_requested = self.traces.k_max     # the newest step the plant had reported when the request came
        op = body.get("op")
        role = "controller" if op in ("gains", "reference") or body.get("target") == "controller" else "plant"
        body = {k: v for k, v in body.items() if k != "target"}
        ev = parse_event(body, role, source="request")
        if role == "controller" and self.controller_kind != "builtin":
            raise InputError("the controller is your own: its gains and reference are not the panel's", source="request")
        ans = await self.send(role, ev.model_dump(exclude_none=True))
        if "error" in ans:
            raise InputError(ans["error"], source=role)
        d = ev.model_dump(exclude_none=True)
        if op == "set":
            self.tunables[d["name"]] = d["value"]
        elif op == "fault_on":
            self.faults[ans["slot"]] = d["fault"]
        elif op == "fault_off":
            self.faults.pop(d["slot"], None)
        elif op == "gains":
            self.gains.update({k: v for k, v in d.items() if k != "op"})
        elif op == "reference":
            self.reference = d.get("value")
        self.events.append({"k": ans["k"], "k_requested": k_requested, "t": ans["k"] * self.h, "process": role, **d})
        return {"k": ans["k"], "k_requested": k_requested, **{k: v for k, v in ans.items() if k not in ("ack", "k")}}

    # -- sessions (own=True) -----------------------------------------------------------------------
    def session_tables(self) -> dict:
        """What a session changes in its scenario: it runs until stopped, so the reference repeats
        (x_ref(t mod duration)); on fewer than 4 CPUs the browser needs one, so neither process busy-waits
        unless the scenario says so (``[hil] wait``: "sleep" here by default, "spin-controller" elsewhere)."""
        s, tables = self.sc.scenario, {}
        if s.closed_loop and s.reference.repeat is None:
            tables["reference"] = {"repeat": s.duration}
        if "wait" not in s.hil.model_fields_set and (os.cpu_count() or 1) < 4:
            tables["hil"] = {"wait": "sleep", "busy_poll": True}
        return tables

    async def start_session(self) -> None:
        from hydrohil.hil.processes import Child, free_udp_port, process_command
        from hydrohil.simulation.scenario import write_scenario
        if self.running:
            raise InputError("a session is running: stop it first", source="panel")
        self.session_n += 1
        while (self.out / f"session-{self.session_n:03d}").exists():
            self.session_n += 1
        folder = self.session = self.out / f"session-{self.session_n:03d}"
        folder.mkdir(parents=True)
        self.sessions.append(folder)
        scenario = write_scenario(self.scenario_path, folder / "scenario.toml", params=self.params_arg, sets=self.sets,
                                  tables=self.session_tables())
        self.traces = Traces(self.h)
        self.counters = {**dict.fromkeys(PLANT_COUNTERS, 0), "telemetry_lost_steps": 0}
        self.peers.clear()
        self.tunables, self.faults, self.gains = self._initial_tunables(), {}, self._initial_gains()
        self.reference, self.events, self.ended = None, [], None
        self.recording = None
        side = f"127.0.0.1:{self.udp.get_extra_info('sockname')[1]}"
        builtin = self.controller_kind == "builtin"
        ctl_addr = f"127.0.0.1:{free_udp_port()}" if builtin else None
        bind = "127.0.0.1:0" if builtin else f"127.0.0.1:{self.plant_port}"
        plant = Child(process_command("plant", "--scenario", scenario, "--bind", bind, "--log", folder, "--panel", side,
                          "--no-rows", "--duration", "0", *(["--peer", ctl_addr] if builtin else []),
                          *(["--lockstep"] if self.lockstep else []),
                          *([] if builtin else ["--connect-timeout", "3600"])), "plant")
        self.children = [plant]
        loop = asyncio.get_running_loop()
        address = await loop.run_in_executor(None, plant.wait_line, "READY ", 120.0)
        if builtin:
            self.children.append(Child(process_command("controller", "--scenario", scenario, "--connect", address, "--local",
                                           ctl_addr, "--panel", side, "--log", folder), "controller"))
        self.running = True
        print(f"SESSION {folder} plant {address}", flush=True)

    async def stop_session(self) -> dict:
        """Stop the plant at a step boundary (it ends the controller with its final packet); wait for both."""
        if not self.running or self.stopping:
            raise InputError("no session is running", source="panel")
        self.stopping = True
        try:
            return await self._stop_session()
        finally:
            self.stopping = False

    async def _stop_session(self) -> dict:
        if self.recording is not None:
            try:
                await self.record_stop()
            except HydrohilError:
                self._recording_ended()
        try:
            await self.send("plant", {"op": "stop"})
        except HydrohilError:
            pass
        loop = asyncio.get_running_loop()
        for ch in self.children:
            try:
                await loop.run_in_executor(None, ch.wait, 30)
            except Exception:     # noqa: BLE001 - a stuck child is stopped, whatever went wrong
                ch.stop()
        self.running = False
        await self.finish_reports()
        return self._ended("the plant wrote no timing.json")

    def _ended(self, error: str) -> dict:
        """The ended session's timing (``error`` when the plant wrote none) with the processes' exit codes."""
        t = self.session / "timing.json"
        self.ended = json.loads(t.read_text()) if t.is_file() else {"error": error}
        self.ended["exit_codes"] = {ch.name: ch.returncode for ch in self.children}
        return self.ended

    async def watch_children(self) -> None:
        """A session whose plant ended by itself (a model fault, the controller gone) is marked ended."""
        while True:
            await asyncio.sleep(0.2)
            if self.own and self.running and not self.stopping and self.children and self.children[0].poll() is not None:
                for ch in self.children[1:]:
                    if ch.poll() is None:
                        ch.stop()
                self.running = False
                self._recording_ended()
                self._ended(self.children[0].stderr()[-500:])

    # -- recordings --------------------------------------------------------------------------------
    async def record_start(self) -> dict:
        if self.recording is not None:
            raise InputError("already recording", source="panel")
        if self.session is None:
            raise InputError("no session", source="panel")
        n = len(self.recordings) + 1
        folder = self.session / "recordings" / f"rec-{n:03d}"
        while folder.exists():
            n += 1
            folder = self.session / "recordings" / f"rec-{n:03d}"
        ans = await self.send("plant", {"op": "record_start", "dir": str(folder.resolve())})
        if "error" in ans:
            raise InputError(ans["error"], source="plant")
        self.recording = {"name": folder.name, "dir": str(folder), "k0": ans["k"]}
        return self.recording

    async def record_stop(self) -> dict:
        if self.recording is None:
            raise InputError("not recording", source="panel")
        ans = await self.send("plant", {"op": "record_stop"})
        if "error" in ans:
            raise InputError(ans["error"], source="plant")
        rec = {**self.recording, "k1": ans["k"], "steps": ans["steps"], "verdict": ans["verdict"], "report": "pending"}
        self.recording = None
        self.recordings.append(rec)
        loop = asyncio.get_running_loop()
        self.reports.append(loop.run_in_executor(None, self._finish_recording, rec))
        return rec

    def _recording_ended(self) -> None:
        """The plant ended while recording (it closes the recording itself): list it and make its report."""
        rec, self.recording = self.recording, None
        if rec is None:
            return
        from hydrohil.simulation.outputs import read_csv_columns
        folder = Path(rec["dir"])
        try:
            k = read_csv_columns(folder / "plant_log.csv")["k"]
            timing = json.loads((folder / "timing.json").read_text())
        except (OSError, ValueError, KeyError):
            rec.update(report="failed: the plant ended before the recording was complete")
            self.recordings.append(rec)
            return
        k1 = int(k[-1]) if len(k) else rec["k0"]
        rec.update(k1=k1, steps=k1 - rec["k0"], verdict=timing["verdict"]["verdict"], report="pending")
        self.recordings.append(rec)
        self.reports.append(asyncio.get_running_loop().run_in_executor(None, self._finish_recording, rec))

    async def finish_reports(self) -> None:
        pending, self.reports = self.reports, []
        if pending:
            await asyncio.gather(*pending)

    def _finish_recording(self, rec: dict) -> None:
        """Complete a recording's folder: scenario, the events up to its end, the replay check, report.png."""
        from hydrohil.panel.recording import finish_recording
        try:
            rec.update(finish_recording(self.sc, self.session, Path(rec["dir"]), rec["k0"], rec["k1"]))
            rec["report"] = "done"
        except Exception as exc:       # noqa: BLE001 - shown on the page, the recording's logs stay
            rec["report"] = f"failed: {exc}"

    # -- frames ------------------------------------------------------------------------------------
    def frame(self, view: dict) -> bytes:
        window = float(min(max(view.get("window", 10.0), 0.5), 60.0))
        end = view.get("end_k")
        f = self.traces.frame(window, end, list(SHOWN), int(min(max(view.get("points", 1000), 100), 2000)))
        total = int(self.traces.jitter_counts.sum())
        head = {"seq": self.frames_sent, "h": self.h, "k_max": self.traces.k_max, "level": f["level"],
                "block": f["block"], "b0": f["b0"], "n": f["n"], "columns": list(SHOWN), "window": window,
                "counters": self.counters, "running": self.running, "recording": self.recording,
                "jitter_hist": {"edges_us": JITTER_EDGES_US, "counts": self.traces.jitter_counts.tolist(),
                                "total": total},
                "server_cpu_s": time.process_time() - self.cpu0}
        hb = json.dumps(head).encode()
        hb += b" " * (-(len(hb) + 4) % 4)
        return struct.pack("<I", len(hb)) + hb + f["lo"].tobytes() + f["hi"].tobytes()

    # -- HTTP ---------------------------------------------------------------------------------------
    def _authorised(self, request: web.Request) -> bool:
        if not self.allow_remote:
            host = request.host.rsplit(":", 1)[0].strip("[]")
            return host in ("127.0.0.1", "localhost", "::1")
        given = (request.query.get("token") or request.headers.get("X-Hydrohil-Token")
                 or request.cookies.get(TOKEN_COOKIE) or "")
        return hmac.compare_digest(given.encode(), self.token.encode())

    @web.middleware
    async def guard(self, request: web.Request, handler):
        if not self._authorised(request):
            return web.Response(status=403, text="forbidden: this panel needs its token (printed when it started)\n")
        if request.method == "POST":      # another site's page in the user's browser must not steer the rig
            origin = request.headers.get("Origin")
            if origin is not None and origin.rstrip("/") != f"{request.scheme}://{request.host}":
                return web.Response(status=403, text=f"forbidden: a request from a foreign origin {origin}\n")
            if request.headers.get("Sec-Fetch-Site", "same-origin") not in ("same-origin", "none"):
                return web.Response(status=403, text="forbidden: a cross-site request\n")
            if request.content_type != "application/json":
                return web.json_response({"error": "expected Content-Type: application/json"}, status=415)
        try:
            resp = await handler(request)
        except InputError as exc:
            return web.json_response({"error": str(exc)}, status=400)
        except HydrohilError as exc:
            return web.json_response({"error": str(exc)}, status=503)
        except ConnectionError as exc:          # the browser went away mid-request: one line, no traceback
            went_away(request, exc)
            return web.Response(status=400, text="the request was cut off\n")   # to nobody: aiohttp drops it
        if self.token and request.query.get("token"):
            resp.set_cookie(TOKEN_COOKIE, self.token, httponly=True, samesite="Strict")
        return resp

    async def page(self, request):
        return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-store"})

    async def api_state(self, request):
        return web.json_response(self.state())

    async def _body(self, request) -> dict:
        try:
            body = await request.json()
        except ValueError:
            raise InputError("expected a JSON object", source="request") from None
        if not isinstance(body, dict):
            raise InputError("expected a JSON object", source="request")
        return body

    async def api_steer(self, request):
        return web.json_response(await self.steer(await self._body(request)))

    async def api_run(self, request):
        action = request.match_info["action"]
        if action == "start":
            if not self.own:
                raise InputError("this panel watches a scripted run: it cannot start another", source="panel")
            await self.start_session()
            return web.json_response({"session": str(self.session)})
        if action == "stop":
            if not self.own:
                ans = await self.send("plant", {"op": "stop"})
                return web.json_response(ans)
            return web.json_response(await self.stop_session())
        raise web.HTTPNotFound()

    async def api_record(self, request):
        action = request.match_info["action"]
        if action == "start":
            return web.json_response(await self.record_start())
        if action == "stop":
            return web.json_response(await self.record_stop())
        raise web.HTTPNotFound()

    async def api_recordings(self, request):
        return web.json_response(self.recordings)

    async def download(self, request):
        """A recording as a zip, made in a worker thread into the session's downloads/ (the event loop keeps
        serving the side channel meanwhile) and streamed from the file."""
        name = request.match_info["name"]
        rec = next((r for r in self.recordings if r["name"] == name), None)
        if rec is None:
            raise web.HTTPNotFound(text=f"no recording {name}")
        folder = Path(rec["dir"])
        target = self.session / "downloads" / f"{name}.zip"
        target.parent.mkdir(exist_ok=True)

        def pack():
            with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as z:
                for f in sorted(folder.iterdir()):
                    if f.is_file():
                        z.write(f, f"{name}/{f.name}")
        await asyncio.get_running_loop().run_in_executor(None, pack)
        return web.FileResponse(target, headers={"Content-Disposition": f'attachment; filename="{name}.zip"',
                                                 "Content-Type": "application/zip"})

    async def ws(self, request):
        origin = request.headers.get("Origin")
        if origin is not None and origin.rstrip("/") != f"{request.scheme}://{request.host}":
            return web.Response(status=403, text=f"forbidden: WebSocket from a foreign origin {origin}\n")
        if origin is None and not self.allow_remote and request.headers.get("User-Agent", "").startswith("Mozilla"):
            return web.Response(status=403, text="forbidden: a browser's WebSocket without Origin\n")
        sock = web.WebSocketResponse(heartbeat=None, max_msg_size=1 << 16)
        await sock.prepare(request)
        view = {"window": 10.0, "end_k": None, "paused": False}
        self.sockets.add(sock)

        async def reader():
            async for msg in sock:
                if msg.type == WSMsgType.TEXT:
                    view.update(_view(msg.data))
        task = asyncio.ensure_future(reader())
        lost: BaseException | None = None
        try:
            while not sock.closed and not task.done():
                t0 = time.monotonic()
                if not view.get("paused") or view.get("end_k") is not None:
                    transport = request.transport
                    # a browser that does not read: its socket buffer is full -> skip (never queue) frames
                    if transport is None or transport.get_write_buffer_size() < 1 << 20:
                        await sock.send_bytes(self.frame(view))
                        self.frames_sent += 1
                await asyncio.sleep(max(FRAME_S - (time.monotonic() - t0), 0.005))
        except (ConnectionError, RuntimeError) as exc:
            lost = exc
        finally:
            task.cancel()
            done = await asyncio.gather(task, return_exceptions=True)   # its end retrieved: never a stray traceback
            self.sockets.discard(sock)
        if isinstance(done[0], Exception) and lost is None:
            lost = done[0]
        if lost is not None or sock.close_code not in (None, 1000, 1001):
            went_away(request, lost or f"WebSocket closed with code {sock.close_code}")
        return sock

    def app(self) -> web.Application:
        app = web.Application(middlewares=[self.guard])
        app.router.add_get("/", self.page)
        app.router.add_static("/static/", STATIC)
        app.router.add_get("/api/state", self.api_state)
        app.router.add_post("/api/steer", self.api_steer)
        app.router.add_post("/api/run/{action}", self.api_run)
        app.router.add_post("/api/record/{action}", self.api_record)
        app.router.add_get("/api/recordings", self.api_recordings)
        app.router.add_get("/recordings/{name}.zip", self.download)
        app.router.add_get("/ws", self.ws)
        return app

    # -- life cycle ---------------------------------------------------------------------------------
    async def open(self, side_port: int = 0) -> str:
        """Bind the side channel and the web server; start a session when ``own``. Returns the URL."""
        loop = asyncio.get_running_loop()
        self.udp, _ = await loop.create_datagram_endpoint(lambda: SideProtocol(self), local_addr=("127.0.0.1", side_port))
        s = self.udp.get_extra_info("socket")
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self.runner = web.AppRunner(self.app(), access_log=None)
        await self.runner.setup()
        host = self.host if self.allow_remote else "127.0.0.1"
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, self.port))
        self.port = sock.getsockname()[1]
        site = web.SockSite(self.runner, sock)
        await site.start()
        shown = "127.0.0.1" if host in ("127.0.0.1", "0.0.0.0") else host
        self.url = f"http://{shown}:{self.port}/" + (f"?token={self.token}" if self.token else "")
        self.watcher = asyncio.ensure_future(self.watch_children())
        return self.url

    @property
    def side_address(self) -> str:
        return f"127.0.0.1:{self.udp.get_extra_info('sockname')[1]}"

    async def close(self) -> None:
        if self.own and self.running:
            try:
                await self.stop_session()
            except HydrohilError:
                pass
        for ch in self.children:
            if ch.poll() is None:
                ch.stop()
        await self.finish_reports()
        self.watcher.cancel()
        for sock in list(self.sockets):       # open pages: closed, else the server's shutdown waits for them
            await sock.close()
        await self.runner.cleanup()
        self.udp.close()


class PanelThread:
    """A panel attached to processes started elsewhere (``hydrohil hil --panel``), served from a thread of
    the supervising process. ``address`` is the side channel to give the plant and controller."""

    def __init__(self, scenario: Path, out: Path, **kw):
        self.loop = asyncio.new_event_loop()
        self.panel = Panel(scenario, out, own=False, **kw)
        self.panel.session = Path(out)
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
        self.panel.running = True
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
