"""HIL runtime benchmarks (issue #4): real-time plant + P controller as two processes over loopback.

  * 60 s real time at 0.5 ms (Fig 11 trajectory repeated): jitter percentiles, overruns, drift, RTT
  * 10 s at 0.1 ms: does it keep up? (overruns, late commands reported as they are)
  * lock-step throughput (steps/s) of the same exchange
  * identification times (the slow procedures) for the README

Run:  python benchmarks/bench_hil.py [--json FILE] [--seconds 60]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from bench_core import emit, machine

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"
KEYS = ("steps", "overruns", "jitter_us_p50", "jitter_us_p99", "jitter_us_p999", "jitter_us_max", "compute_us_p50",
        "compute_us_p99", "rtt_us_p50", "rtt_us_p99", "late_commands", "watchdog_trips", "packets_lost", "drift_ms",
        "os_rt_priority")


def scenario(tmp: Path, seconds: float, step: float) -> Path:
    t, x = [0.0], [0.03]
    period = 6.0
    k = 0
    while t[-1] < seconds:
        base = k * period
        t += [base + 0.5, base + 1.5, base + 3.0, base + 4.0, base + 6.0]
        x += [0.03, 0.15, 0.15, 0.03, 0.03]
        k += 1
    text = (f'params = "ferreira2004"\nduration = {seconds}\n[solver]\nstep = {step}\n[initial]\nxp = 0.03\n'
            f'[controller]\ntype = "p"\nkp = 50.0\n[reference]\ntype = "table"\nt = {t}\nx = {x}\n')
    path = tmp / f"bench_{seconds:g}s_{step:g}.toml"
    path.write_text(text)
    return path


def hil_run(path: Path, out: Path, lockstep=False) -> dict:
    from hydrohil.hil.run import run_hil
    t0 = time.perf_counter()
    r = run_hil(path, out, lockstep=lockstep, plot=False)
    res = {k: r.timing.get(k) for k in KEYS}
    res.update({"xp_rms_vs_offline_mm": r.comparison["xp_rms_mm"], "wall_s": time.perf_counter() - t0})
    if lockstep:
        res["steps_per_s"] = r.timing["steps_per_s"]
    return res


def identification_times() -> dict:
    from hydrohil.identification import identify_friction_dynamic, identify_spool
    from hydrohil.identification.friction_dynamic import synthetic_experiment
    from hydrohil.identification.spool import synthetic_bode
    from hydrohil.parameters import load_parameters, replace_values
    out = {}
    data = synthetic_bode(850.0, 0.62, 150.0, 6e4, 5e-4, noise_db=0.1, seed=1)
    identify_spool(data)                       # compile
    out["spool_s"] = identify_spool(data).wall_time_s
    base = load_parameters("ferreira2004", {"load.gravity_direction": 0})
    d = synthetic_experiment(replace_values(base, {"friction.sigma0": 1.2e7, "friction.sigma1": 5e3}), seed=7)
    out["friction_dynamic_s"] = identify_friction_dynamic(d, base).wall_time_s
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", type=Path)
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    res = {"machine": machine()}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        res["realtime_0.5ms"] = hil_run(scenario(tmp, args.seconds, 5e-4), tmp / "rt05")
        res["realtime_0.1ms"] = hil_run(scenario(tmp, 10.0, 1e-4), tmp / "rt01")
        res["lockstep_0.5ms"] = hil_run(scenario(tmp, 10.0, 5e-4), tmp / "ls", lockstep=True)
    res["identification"] = identification_times()
    emit(res, args.json)


if __name__ == "__main__":
    main()
