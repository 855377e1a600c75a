"""The C plant's compute per step with faults off: the rig step of issue #26 against the pieces it replaced.

    python benchmarks/rig_step_cost.py [--steps 20000]

Builds ``rig_step_cost.c`` against the core's sources with the core's flags and counts the instructions of
both modes under valgrind's callgrind (independent of the machine's load), per step over ``--steps`` steps
of a sine on the paper's rig; prints both and the ratio. Both modes must end in the same state (checked).
Needs valgrind.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from hydrohil.core.build import CFLAGS, c_compiler, write_headers
from hydrohil.models.layout import pack
from hydrohil.parameters import load_parameters

HERE = Path(__file__).resolve().parent
CORE = HERE.parent / "src" / "hydrohil" / "core"


def instructions(exe: Path, pbin: Path, mode: int, steps: int, tmp: Path) -> tuple[int, str]:
    out = tmp / f"cg.{mode}"
    r = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(exe), str(pbin),
                        str(mode), str(steps)], capture_output=True, text=True, check=True)
    total = re.search(r"Collected\s*:\s*(\d+)", r.stderr) or re.search(r"refs:\s*([\d,]+)", r.stderr)
    return int(total.group(1).replace(",", "")), r.stdout.strip()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=20000)
    args = ap.parse_args()
    if shutil.which("valgrind") is None:
        print("valgrind is needed (apt-get install valgrind)", file=sys.stderr)
        return 2
    write_headers(CORE)
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        exe = tmp / "rig_step_cost"
        subprocess.run([c_compiler(), *CFLAGS, "-I", str(CORE), str(HERE / "rig_step_cost.c"), str(CORE / "hh_core.c"),
                        "-o", str(exe), "-lm"], check=True)
        pbin = tmp / "p.bin"
        pack(load_parameters("ferreira2004")).astype("<f8").tofile(pbin)
        base = {}
        for steps in (0, args.steps):        # the difference of two runs: the steps alone, start-up taken out
            for mode in (0, 1):
                base[mode, steps] = instructions(exe, pbin, mode, steps, tmp)
    old = (base[0, args.steps][0] - base[0, 0][0]) / args.steps
    new = (base[1, args.steps][0] - base[1, 0][0]) / args.steps
    same = base[0, args.steps][1].split()[1] == base[1, args.steps][1].split()[1]
    print(f"instructions per step (callgrind, {args.steps} steps): before #26 {old:.0f}, the rig step {new:.0f}, "
          f"ratio {new / old:.3f}; same final state: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
