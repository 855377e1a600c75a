"""The panel's web side (aiohttp): the page (``static/``, the project's own code: no CDN, no Node.js), a
WebSocket per browser with a frame of min/max envelopes every 40 ms (25 frames/s; a browser that does not
read its frames gets none until it does: frames are skipped, nothing queues), and the HTTP API the page,
scripts and tests use: ``/api/state``, ``/api/steer``, ``/api/run/{start,stop}``, ``/api/record/{start,stop}``,
``/api/recordings``, ``/recordings/NAME.zip``.

Security: bound to 127.0.0.1 and requests for another Host refused (DNS rebinding), unless
``allow_remote``: then every HTTP and WebSocket request must carry the token (``?token=``, header
``X-Hydrohil-Token`` or the cookie the page sets) and a WebSocket's Origin must be the panel's own; a POST
from another site's page is refused.
"""

from __future__ import annotations

import asyncio
import hmac
import json
import math
import secrets
import socket
import struct
import sys
import time
import zipfile
from pathlib import Path

from aiohttp import WSMsgType, web

from hydrohil.errors import HydrohilError, InputError
from hydrohil.panel.traces import JITTER_BINS

STATIC = Path(__file__).parent / "static"
FRAME_S = 0.04                   # 25 frames/s
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


def went_away(request: web.Request, why) -> None:
    """One line on stderr for a browser that disconnected mid-request (no traceback: nothing is wrong here)."""
    print(f"panel: the browser at {request.remote} went away during {request.method} {request.path} ({why})",
          file=sys.stderr, flush=True)


class PanelWeb:
    """The web server of a :class:`~hydrohil.panel.server.Panel` (``panel``): it shows the panel's state
    and traces and passes the page's requests to the panel (steering) and its sessions."""

    def __init__(self, panel, *, host: str = "127.0.0.1", port: int = 0, allow_remote: bool = False):
        self.panel = panel
        self.host, self.port, self.allow_remote = host, port, allow_remote
        self.token = secrets.token_urlsafe(18) if allow_remote else None
        self.frames_sent = 0
        self.sockets: set = set()
        self.url: str | None = None
        self.runner = None
        self.cpu0 = time.process_time()

    # -- frames ------------------------------------------------------------------------------------
    def frame(self, view: dict) -> bytes:
        hub, runs = self.panel.hub, self.panel.supervisor
        window = float(min(max(view.get("window", 10.0), 0.5), 60.0))
        end = view.get("end_k")
        shown = self.panel.shown          # (the view's columns: hydrohil.panel.views)
        f = hub.traces.frame(window, end, shown, int(min(max(view.get("points", 1000), 100), 2000)))
        total = int(hub.traces.jitter_counts.sum())
        head = {"seq": self.frames_sent, "h": self.panel.h, "k_max": hub.traces.k_max, "level": f["level"],
                "block": f["block"], "b0": f["b0"], "n": f["n"], "columns": shown, "window": window,
                "counters": hub.counters, "running": runs.running, "recording": runs.recording,
                "jitter_hist": {"edges_us": JITTER_EDGES_US, "counts": hub.traces.jitter_counts.tolist(),
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
        return web.json_response(self.panel.state())

    async def _body(self, request) -> dict:
        try:
            body = await request.json()
        except ValueError:
            raise InputError("expected a JSON object", source="request") from None
        if not isinstance(body, dict):
            raise InputError("expected a JSON object", source="request")
        return body

    async def api_steer(self, request):
        return web.json_response(await self.panel.steer(await self._body(request)))

    async def api_run(self, request):
        action, pn = request.match_info["action"], self.panel
        if action == "start":
            if not pn.own:
                raise InputError("this panel watches a scripted run: it cannot start another", source="panel")
            await pn.supervisor.start()
            return web.json_response({"session": str(pn.supervisor.folder)})
        if action == "stop":
            if not pn.own:
                ans = await pn.hub.send("plant", {"op": "stop"})
                return web.json_response(ans)
            return web.json_response(await pn.supervisor.stop())
        raise web.HTTPNotFound()

    async def api_record(self, request):
        action = request.match_info["action"]
        if action == "start":
            return web.json_response(await self.panel.supervisor.record_start())
        if action == "stop":
            return web.json_response(await self.panel.supervisor.record_stop())
        raise web.HTTPNotFound()

    async def api_recordings(self, request):
        return web.json_response(self.panel.supervisor.recordings)

    async def download(self, request):
        """A recording as a zip, made in a worker thread into the session's downloads/ (the event loop keeps
        serving the side channel meanwhile) and streamed from the file."""
        name = request.match_info["name"]
        runs = self.panel.supervisor
        rec = next((r for r in runs.recordings if r["name"] == name), None)
        if rec is None:
            raise web.HTTPNotFound(text=f"no recording {name}")
        folder = Path(rec["dir"])
        target = runs.folder / "downloads" / f"{name}.zip"
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
    async def open(self) -> str:
        """Serve the page and the API; returns the URL (with the token when remote access is allowed)."""
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
        return self.url

    async def close(self) -> None:
        for sock in list(self.sockets):       # open pages: closed, else the server's shutdown waits for them
            await sock.close()
        if self.runner is not None:
            await self.runner.cleanup()
