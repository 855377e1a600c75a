"""Real-time soak (issue #6): plant + P controller over loopback for N minutes at 0.5 ms.

Samples the plant process's resident memory every second, then reads the streamed plant log to check that
no step is missing and to give jitter/overrun figures per minute (flat = no degradation).

Run:  python benchmarks/soak.py [--minutes 10] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from hydrohil.bench import emit, hil_scenario, machine
from hydrohil.hil.processes import Child, cli, free_udp_port
from hydrohil.simulation.outputs import read_csv_columns


def rss_mb(pid: int) -> float | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        return None
    return None


def soak(minutes: float, step: float = 5e-4) -> dict:
    seconds = minutes * 60
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        scen = hil_scenario(tmp, seconds, step)
        ctl_address = f"127.0.0.1:{free_udp_port()}"
        plant = Child(cli("plant", "--scenario", scen, "--bind", "127.0.0.1:0", "--log", tmp / "out", "--peer",
                          ctl_address), "plant")
        addr = plant.wait_line("READY ", 120.0)
        ctl = Child(cli("controller", "--scenario", scen, "--connect", addr, "--log", tmp / "out", "--local",
                        ctl_address), "controller")
        plant.wait_line("PEER ", 120.0)
        mem = []
        t0 = time.monotonic()
        while plant.poll() is None:
            m = rss_mb(plant.proc.pid)
            if m is not None:
                mem.append((time.monotonic() - t0, m))
            print(f"\r{time.monotonic() - t0:6.0f} s / {seconds:.0f} s, plant RSS {m or 0:.1f} MB", end="",
                  file=sys.stderr, flush=True)
            time.sleep(1.0)
        print(file=sys.stderr)
        ctl.wait(60)
        timing = json.loads((tmp / "out" / "timing.json").read_text())
        log = read_csv_columns(tmp / "out" / "plant_log.csv")
        log_mb = (tmp / "out" / "plant_log.csv").stat().st_size / 1e6
    k = log["k"]
    jit = log["jitter_us"][1:]
    per_step = int(round(60 / step))
    minutes_tab = []
    for i in range(0, len(jit), per_step):
        j = jit[i:i + per_step]
        minutes_tab.append({"minute": i // per_step + 1, "jitter_us_p99": float(np.percentile(j, 99)),
                            "jitter_us_max": float(j.max()), "overruns": int(np.sum(j > step * 1e6))})
    m = np.array(mem)
    settled = m[m[:, 0] > 10, 1] if len(m) else np.array([])
    return {
        "minutes": minutes, "step_s": step, "steps": timing["steps"], "steps_planned": timing["steps_planned"],
        "log_rows": int(len(k)), "log_steps_missing": int(timing["steps"] + 1 - len(k)),
        "log_k_contiguous": bool(np.all(np.diff(k) == 1)), "log_mb": log_mb,
        "rss_mb_first": float(settled[0]) if settled.size else None,
        "rss_mb_last": float(settled[-1]) if settled.size else None,
        "rss_mb_max": float(settled.max()) if settled.size else None,
        **{key: timing.get(key) for key in ("overruns", "jitter_us_p50", "jitter_us_p99", "jitter_us_p999",
                                            "jitter_us_max", "rtt_us_p50", "rtt_us_p99", "late_commands",
                                            "watchdog_trips", "packets_lost", "drift_ms", "os_rt_priority")},
        "verdict": timing["verdict"]["verdict"], "verdict_reasons": timing["verdict"]["reasons"],
        "per_minute": minutes_tab,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    res = {"machine": machine(), "soak": soak(args.minutes)}
    emit(res, args.json)


if __name__ == "__main__":
    main()
