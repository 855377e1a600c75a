"""Core benchmarks (issue #2): compiled step cost, per-step API cost, max stable step hybrid vs
continuous, start-up of a short `hydrohil simulate` cold (empty JIT cache) and warm.

Run:  python benchmarks/bench_core.py [--json FILE]
Medians over repeats, measured in one run on this machine.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
EX = ROOT / "examples"


def compiled_step_ns(repeats=7):
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    out = {}
    for name in ("sine_open_loop.toml", "fig11_p_control.toml"):
        sc = load_scenario(EX / name, duration=60.0)
        sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={
            "solver": sc.scenario.solver.model_copy(update={"output_every": 1000})})})
        walls = [run_scenario(sc).wall_time_s for _ in range(repeats)]
        n = sc.scenario.n_steps()
        out[name] = {"ns_per_step_median": statistics.median(walls) / n * 1e9,
                     "realtime_factor_median": sc.scenario.duration / statistics.median(walls)}
    return out


def per_step_api_us(n=20000, repeats=5):
    from hydrohil.parameters import load_parameters
    from hydrohil.simulation.loop import HybridPlant
    plant = HybridPlant(load_parameters("ferreira2004", {"load.gravity_direction": 0}), xp=0.09)
    u = 0.3 * np.sin(2 * np.pi * 0.5 * np.arange(n) * 5e-4)
    res = []
    for _ in range(repeats):
        plant.reset(xp=0.09)
        step = plant.step
        t0 = time.perf_counter()
        for uk in u:
            step(uk)
        res.append((time.perf_counter() - t0) / n * 1e6)
    return {"us_per_call_median": statistics.median(res)}


def max_steps():
    from hydrohil.maxstep import max_stable_step
    from hydrohil.simulation.scenario import load_scenario
    sc = load_scenario(EX / "maxstep_endstop.toml")
    t0 = time.perf_counter()
    hyb = max_stable_step(sc, "hybrid", "rk3")
    cont = max_stable_step(sc, "continuous", "rk3")
    return {"hybrid_s": hyb["max_stable_step"], "continuous_s": cont["max_stable_step"],
            "ratio": hyb["max_stable_step"] / cont["max_stable_step"], "search_wall_s": time.perf_counter() - t0}


def startup(repeats=3):
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        cmd = [sys.executable, "-m", "hydrohil.cli", "simulate", str(EX / "maxstep_endstop.toml"), "--out", out,
               "--no-plot"]
        t0 = time.perf_counter()
        subprocess.run(cmd, env=env, check=True, capture_output=True)
        cold = time.perf_counter() - t0
        warm = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            subprocess.run(cmd, env=env, check=True, capture_output=True)
            warm.append(time.perf_counter() - t0)
    return {"cold_s": cold, "warm_s_median": statistics.median(warm)}


def machine():
    return {"python": sys.version.split()[0], "platform": platform.platform(), "processor": platform.processor(),
            "cpus": os.cpu_count()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    res = {"machine": machine()}
    for name, fn in (("startup", startup), ("compiled_loop", compiled_step_ns), ("per_step_api", per_step_api_us),
                     ("max_stable_step", max_steps)):
        print(f"[bench] {name} ...", file=sys.stderr, flush=True)
        res[name] = fn()
    emit(res, args.json)


def emit(res: dict, path: Path | None) -> None:
    """Print the results as JSON (and write them to ``path`` when given)."""
    text = json.dumps(res, indent=2)
    print(text)
    if path:
        path.write_text(text + "\n")


if __name__ == "__main__":
    main()
