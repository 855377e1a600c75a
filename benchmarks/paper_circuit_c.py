"""The paper's rig as a generated circuit beside the hand-written core, like for like: each in a plain C loop
(benchmarks/paper_circuit_c.c), the same compiler and flags as the package, Fig 10's open loop from the same state
at rest (the core's initial state; the circuit's settled the same: the final positions agree to rounding), one
log row every 1000 steps, no Python in the loop. Prints the median ns per step of each (runs alternated, so both
see the same machine) and, with valgrind, the machine instructions per step inside ``hh_sim_run`` / ``hc_run``
over the first 4000 steps. (``hydrohil bench``'s ``paper_circuit`` times the same runs through Python: there the
core's run costs some 230 instructions a step more than here, not located; this is the issue's comparison.)

    python benchmarks/paper_circuit_c.py [--seconds 600] [--runs 41] [--floor rk3_floor.c]

With the floor program (``--floor``, default hydrohil.bench.floor_program's: a plain-C RK3 of the same right-hand
side without the statechart, which prints its own ns per step), it runs in the same rounds, built with the same
flags: the ratios of each loop to it, and its instructions per step.

(The defaults: a timed run of 600 simulated seconds is ~0.14 s of wall time; runs of 60 s, ~14 ms, scatter by
several per cent from one run to the next.)
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import statistics
import subprocess
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _c(values) -> str:
    return ", ".join("NAN" if math.isnan(float(v)) else repr(float(v)) for v in values)


def write_data(folder: Path, steps: int, runs: int) -> None:
    """bench_data.h and the commands' file of Fig 10 for ``steps`` steps, and the circuit's generated C."""
    from hydrohil.bench import _scenario
    from hydrohil.circuits.build import compile_circuit
    from hydrohil.circuits.generate import generate
    from hydrohil.circuits.paper import paper_circuit
    from hydrohil.circuits.run import _start, input_table
    from hydrohil.models.layout import pack
    sc = _scenario("fig10_open_loop_sine.toml", steps * 5e-4)
    s = sc.scenario
    h, n = s.solver.step, s.n_steps()
    cmds = s.commands()
    c = paper_circuit(sc.params, s.initial.xp)
    cc = compile_circuit(c)
    lay = cc.layout
    u = np.ascontiguousarray(input_table(c, n, h, {"valve.command": (np.arange(n + 1) * h, cmds)}))
    P = np.ascontiguousarray(lay.values())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                  # (open loop: the piston is not held at rest)
        y, m, _ = _start(c, cc, P, u, h, "rk3", True, None)
    (folder / "circuit.c").write_text(generate(c)[0])
    cmds.astype(np.float64).tofile(folder / "commands.bin")
    (folder / "bench_data.h").write_text(
        f"#define N {n}\n#define R {runs}\n#define STEP {h!r}\n#define COMMANDS \"{folder / 'commands.bin'}\"\n"
        f"#define NLOGC {len(lay.log_columns)}\n#define XP_INDEX {lay.states.index('cyl.x')}\n"
        f"#define XP0 {s.initial.xp!r}\n#define XS0 {s.initial.xs!r}\n"
        f"static double P0[] = {{{_c(P)}}};\nstatic double Y0[] = {{{_c(y)}}};\n"
        f"static int64_t M0[] = {{{', '.join(str(int(v)) for v in m)}}};\n"
        f"static double PC[] = {{{_c(pack(sc.params))}}};\n")


def build(folder: Path) -> tuple[Path, Path]:
    from hydrohil.core.build import CFLAGS, c_compiler
    core = Path(__file__).resolve().parent.parent / "src" / "hydrohil" / "core"
    cc = c_compiler().split()
    flags = [*CFLAGS, "-g", f"-I{core}", f"-I{folder}"]
    main = HERE / "paper_circuit_c.c"
    out_core, out_circuit = folder / "core_loop", folder / "circuit_loop"
    subprocess.run([*cc, *flags, str(main), str(core / "hh_core.c"), "-lm", "-o", str(out_core)], check=True)
    subprocess.run([*cc, *flags, "-DCIRCUIT", str(main), str(folder / "circuit.c"), "-lm", "-o", str(out_circuit)],
                   check=True)
    return out_core, out_circuit


def ns_per_step(exe: Path) -> tuple[list[float], float]:
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split("\n")
    return [float(x) for x in out[0].split()], float(out[1].split()[1])


def instructions(exe: Path, fn: str, steps: int) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        cg = Path(tmp) / "cg.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--toggle-collect={fn}", f"--callgrind-out-file={cg}",
                        str(exe)], check=True, capture_output=True)
        total = next(int(line.split()[1]) for line in cg.read_text().splitlines() if line.startswith("summary:"))
    return total / steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=600.0, help="simulated time of a timed run [s]")
    ap.add_argument("--runs", type=int, default=41, help="timed runs of each (alternated)")
    ap.add_argument("--floor", type=Path, default=None, help="the floor program's C file")
    a = ap.parse_args()
    from hydrohil.bench import build_floor, floor_instructions, floor_ns, floor_program
    out: dict = {}
    floor_src = floor_program(a.floor)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_data(folder, int(round(a.seconds / 5e-4)), 1)
        core, circuit = build(folder)
        floor = build_floor(floor_src, folder / "rk3_floor") if floor_src is not None else None
        times = {"core": [], "circuit": [], "floor": []}
        for _ in range(a.runs):
            for name, exe in (("core", core), ("circuit", circuit)):
                t, xp = ns_per_step(exe)
                times[name] += t
                out[f"{name}_final_xp_m"] = xp
            if floor is not None:
                times["floor"].append(floor_ns(floor))
        out["core_ns_per_step"] = statistics.median(times["core"])
        out["circuit_ns_per_step"] = statistics.median(times["circuit"])
        out["ratio"] = out["circuit_ns_per_step"] / out["core_ns_per_step"]
        if floor is not None:
            out["floor_ns_per_step"] = statistics.median(times["floor"])
            out["circuit_vs_floor"] = out["circuit_ns_per_step"] / out["floor_ns_per_step"]
            out["core_vs_floor"] = out["core_ns_per_step"] / out["floor_ns_per_step"]
        if shutil.which("valgrind"):
            write_data(folder, 4000, 1)
            core, circuit = build(folder)
            out["core_instructions"] = instructions(core, "hh_sim_run", 4000)
            out["circuit_instructions"] = instructions(circuit, "hc_run", 4000)
            if floor_src is not None:
                out["floor_instructions"] = floor_instructions(floor_src, 4000)[0]
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
