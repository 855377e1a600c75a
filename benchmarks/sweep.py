"""Sweep benchmark: runs/s of a study on 1 Dask worker vs every core (scaling efficiency), the 1000-run Monte
Carlo example's wall time and its probability, and peak memory (client and workers, resident set).

    python benchmarks/sweep.py [--runs 200] [--out /tmp/hydrohil-sweep-bench]

Medians of one run per case on a shared machine: compare the ratio, not the absolute figures.
"""

import argparse
import json
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

import psutil

from hydrohil.studies.engine import run_study

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "studies" / "fig11_monte_carlo.toml"


class PeakRSS:
    """Peak resident memory of this process and its children (the LocalCluster's workers), sampled."""

    def __init__(self):
        self.peak, self._stop = 0, threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        me = psutil.Process()
        while not self._stop.is_set():
            try:
                procs = [me, *me.children(recursive=True)]
                self.peak = max(self.peak, sum(p.memory_info().rss for p in procs if p.is_running()))
            except psutil.Error:
                pass
            time.sleep(0.1)

    def __enter__(self):
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()


def study_file(folder: Path, runs: int) -> Path:
    p = folder / f"mc{runs}.toml"
    text = EXAMPLE.read_text().replace("samples = 1000", f"samples = {runs}")
    p.write_text(text.replace('"../fig11_p_control.toml"', f'"{EXAMPLE.parent.parent / "fig11_p_control.toml"}"'))
    return p


def timed(study: Path, out: Path, workers: int):
    """(result, peak RSS, runs/s between the first and the last row: the cluster's start-up excluded)."""
    shutil.rmtree(out, ignore_errors=True)
    stamps = []
    with PeakRSS() as mem:
        r = run_study(study, out, workers=workers, progress=False, on_row=lambda row: stamps.append(time.perf_counter()))
    return r, mem.peak, (len(stamps) - 1) / (stamps[-1] - stamps[0])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "hydrohil-sweep-bench")
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    cores = len(os.sched_getaffinity(0))
    small = study_file(a.out, a.runs)
    one, _, rate1 = timed(small, a.out / "w1", 1)
    allc, _, rate_n = timed(small, a.out / f"w{cores}", cores)
    mc, peak, mc_rate = timed(EXAMPLE, a.out / "mc1000", cores)
    res = {"cores": cores, "runs": a.runs, "runs_per_s_1_worker": rate1, f"runs_per_s_{cores}_workers": rate_n,
           "speedup": rate_n / rate1, "efficiency_per_core": rate_n / rate1 / cores,
           "mc1000_wall_s": mc.wall_s, "mc1000_runs_per_s": mc_rate, "wall_s_1_worker": one.wall_s,
           f"wall_s_{cores}_workers": allc.wall_s, "mc1000_peak_rss_MB": peak / 1e6,
           "mc1000_failed": mc.summary["failed"], "mc1000_p_fail_95ci": mc.summary["p_fail_95ci"],
           "mc1000_max_hold_error_mm": {k: v * 1e3 for k, v in mc.summary["metrics"]["max_hold_error"].items()},
           "mc1000_max_abs_error_mm": {k: v * 1e3 for k, v in mc.summary["metrics"]["max_abs_error"].items()}}
    print(json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
