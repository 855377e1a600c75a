"""Accuracy table of the README: hybrid RK3 at 0.5 ms against the continuous LSODA reference.

    python benchmarks/accuracy.py [--markdown]

One row per accuracy scenario of ``examples/`` (the cases of ``tests/test_accuracy.py``): position RMS and
max error, chamber pressure RMS errors (raw and after a 20 ms moving average).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import load_scenario

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
CASES = ("sine_open_loop.toml", "fig11_p_control.toml", "fig12_steps_ramps.toml", "end_stops_p_control.toml",
         "maxstep_endstop.toml")


def _rms(e) -> float:
    return float(np.sqrt(np.mean(np.asarray(e) ** 2)))


def _ma(v, n=40):
    return np.convolve(v, np.ones(n) / n, mode="valid")


def accuracy(name: str) -> dict:
    hyb = run_scenario(load_scenario(EXAMPLES / name))
    ref = run_scenario(load_scenario(EXAMPLES / name, solver="reference"))
    ex = hyb.column("xp") - ref.column("xp")
    row = {"case": name, "xp_rms_mm": _rms(ex) * 1e3, "xp_max_mm": float(np.abs(ex).max()) * 1e3}
    for c in ("p1", "p2"):
        row[f"{c}_rms_bar"] = _rms(hyb.column(c) - ref.column(c)) / 1e5
        row[f"{c}_rms_20ms_bar"] = _rms(_ma(hyb.column(c)) - _ma(ref.column(c))) / 1e5
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", action="store_true")
    a = ap.parse_args()
    rows = [accuracy(c) for c in CASES]
    if a.markdown:
        print("| scenario | xp RMS [mm] | xp max [mm] | P1 RMS [bar] | P2 RMS [bar] | P1, P2 RMS 20 ms avg [bar] |")
        print("|---|---|---|---|---|---|")
        for r in rows:
            print(f"| {r['case']} | {r['xp_rms_mm']:.2g} | {r['xp_max_mm']:.2g} | {r['p1_rms_bar']:.2g} | "
                  f"{r['p2_rms_bar']:.2g} | {r['p1_rms_20ms_bar']:.2g}, {r['p2_rms_20ms_bar']:.2g} |")
    else:
        json.dump(rows, sys.stdout, indent=1)
        print()


if __name__ == "__main__":
    main()
