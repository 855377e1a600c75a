"""Offline runs through the rig: wall time of scenarios with faults or a Python controller.

    python benchmarks/offline_rig.py [--baseline PYTHON] [--repeats 7]

Cases: the Python PI example (examples/controllers/fig11_python_pi.toml: the user's class called each step),
and three fault examples with the built-in P controller (hose_burst, sensor_noise, network_delay). Each
case runs ``run_scenario`` in a fresh process (the figure is the loop's wall time, ``wall_time_s``);
with ``--baseline`` (the interpreter of another build, e.g. a venv of an older commit) the two builds run
interleaved, case by case, and the table gives both medians and their ratio.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = ("controllers/fig11_python_pi.toml", "faults/hose_burst.toml", "faults/sensor_noise.toml",
         "faults/network_delay.toml")
ONE_RUN = ("import json, sys, warnings; warnings.simplefilter('ignore');"
           "from hydrohil.simulation.run import run_scenario; from hydrohil.simulation.scenario import load_scenario;"
           "r = run_scenario(load_scenario(sys.argv[1])); print(json.dumps([r.wall_time_s, r.steps * r.step]))")


def wall(python: str, case: str) -> tuple[float, float]:
    out = subprocess.run([python, "-c", ONE_RUN, str(ROOT / "examples" / case)], capture_output=True, text=True,
                         check=True).stdout
    return tuple(json.loads(out.splitlines()[-1]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", help="the Python of the build to compare with")
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    builds = {"this": sys.executable, **({"baseline": args.baseline} if args.baseline else {})}
    print(f"| case | simulated [s] | {' | '.join(f'{b} wall [s] (x real time)' for b in builds)} |"
          + (" baseline / this |" if args.baseline else ""))
    print("|---|---|" + "---|" * len(builds) + ("---|" if args.baseline else ""))
    for case in CASES:
        walls = {b: [] for b in builds}
        sim_t = 0.0
        for _ in range(args.repeats):
            for b, py in builds.items():          # interleaved: the same load on both
                w, sim_t = wall(py, case)
                walls[b].append(w)
        med = {b: statistics.median(v) for b, v in walls.items()}
        cells = " | ".join(f"{med[b]:.3f} ({sim_t / med[b]:.0f}x)" for b in builds)
        ratio = f" {med['baseline'] / med['this']:.1f} |" if args.baseline else ""
        print(f"| {case} | {sim_t:g} | {cells} |{ratio}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
