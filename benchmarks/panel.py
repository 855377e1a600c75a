"""Does the plant pay for the live panel? One run of each case, the same 20 s of plant time (README).

Cases (the scenario: the paper's Fig 11 as a panel session runs it, reference repeating):

* ``no panel``: ``hydrohil hil`` (plant and controller, no side channel);
* ``panel, no page``: ``hydrohil panel`` with nobody looking (telemetry and the side channel only);
* ``panel, Chromium``: the page open in headless Chromium (25 frames/s requested);
* ``panel, stalled page``: a WebSocket client that connects and never reads.

Per case: the plant's jitter p99, overruns, compute time per step (p50/p99) from its ``timing.json``; the
panel server's CPU time per second of plant time (/proc); the frames/s the page drew. Usage:
``python benchmarks/panel.py [--seconds 20] [--json F]``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))


def cpu_s(pid: int) -> float:
    f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def plant_figures(timing: dict) -> dict:
    return {k: timing.get(k) for k in ("steps", "jitter_us_p99", "overruns", "compute_us_p50", "compute_us_p99",
                                       "late_commands", "verdict")}


def browser(profile: Path):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = shutil.which("chromium")
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--window-size=1400,1300",
              f"--user-data-dir={profile}"):
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)


def stalled_client(url: str) -> socket.socket:
    """A WebSocket upgrade, then never a byte read: the server's frames pile up in the kernel buffers."""
    import base64
    host, port = url.split("//")[1].split("/")[0].split(":")
    s = socket.create_connection((host, int(port)))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
              f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\nOrigin: http://{host}:{port}\r\n\r\n".encode())
    return s


def panel_case(scenario: Path, work: Path, seconds: float, page: str) -> dict:
    from conftest import PanelProcess
    p = PanelProcess(work / f"panel-{page}", str(scenario))
    drv = sock = None
    try:
        s0 = p.wait_steps(200)["counters"]["steps"]
        if page == "chromium":
            drv = browser(work / "profile")
            drv.get(p.url)
        elif page == "stalled":
            sock = stalled_client(p.url)
        c0, w0 = cpu_s(p.child.proc.pid), time.monotonic()
        f0 = int(drv.find_element("id", "frames").text) if drv else 0
        s1 = p.wait_steps(s0 + int(seconds / 5e-4), timeout=10 * seconds + 60)["counters"]["steps"]
        c1, w1 = cpu_s(p.child.proc.pid), time.monotonic()
        fps = (int(drv.find_element("id", "frames").text) - f0) / (w1 - w0) if drv else None
        ended = p.api("api/run/stop", {})
        plant_s = (s1 - s0) * 5e-4
        return {**plant_figures(ended), "panel_cpu_ms_per_plant_s": 1e3 * (c1 - c0) / plant_s, "browser_fps": fps,
                "telemetry_lost_steps": p.api("api/state")["counters"]["telemetry_lost_steps"]}
    finally:
        if drv is not None:
            drv.quit()
        if sock is not None:
            sock.close()
        p.close()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    from conftest import EXAMPLES, hh
    from hydrohil.panel.server import Panel
    work = Path(tempfile.mkdtemp(prefix="hh-panel-bench-"))
    # the scenario exactly as a panel session runs it, for 20 s
    from hydrohil.simulation.scenario import write_scenario
    pn = Panel(EXAMPLES / "fig11_p_control.toml", work)
    tables = pn.session_tables()
    tables.setdefault("reference", {})
    scen = write_scenario(EXAMPLES / "fig11_p_control.toml", work / "bench.toml", tables=tables)
    text = scen.read_text().replace("duration = 6.0", f"duration = {args.seconds}")
    scen.write_text(text)
    rows = {}
    r = hh("hil", scen, "--out", work / "hil", timeout=600)
    t = json.loads((work / "hil" / "timing.json").read_text())
    rows["no panel"] = {**plant_figures(t), "panel_cpu_ms_per_plant_s": None, "browser_fps": None}
    print("no panel", json.dumps(rows["no panel"]), flush=True)
    for name, page in (("panel, no page", "none"), ("panel, Chromium", "chromium"), ("panel, stalled page", "stalled")):
        rows[name] = panel_case(scen, work, args.seconds, page)
        print(name, json.dumps(rows[name]), flush=True)
    shutil.rmtree(work, ignore_errors=True)
    print("\n| case | plant jitter p99 | overruns | late commands | compute p50 / p99 | panel CPU per s of plant time |"
          " page frames/s | verdict |")
    print("|---|---|---|---|---|---|---|---|")
    for name, r in rows.items():
        steps = r["steps"] or 1
        cpu = "–" if r["panel_cpu_ms_per_plant_s"] is None else f"{r['panel_cpu_ms_per_plant_s']:.0f} ms"
        fps = "–" if r["browser_fps"] is None else f"{r['browser_fps']:.1f}"
        print(f"| {name} | {r['jitter_us_p99']:.0f} µs | {r['overruns']} ({100 * r['overruns'] / steps:.2f} %) | "
              f"{r['late_commands']} | {r['compute_us_p50']:.0f} / {r['compute_us_p99']:.0f} µs | {cpu} | {fps} | "
              f"{r['verdict']['verdict']} |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
