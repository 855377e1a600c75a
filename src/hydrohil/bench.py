"""``hydrohil bench``: one benchmark suite, measured in one run on the current machine.

Sections (each a function returning a dict; medians over repeats, ratios computed from the same run):
  machine           CPU model, cores, Python/numpy/cffi versions, C compiler, real-time permissions
  startup           `hydrohil simulate` as a new process (first and following runs), `import hydrohil`
  compiled_loop     ns per hybrid RK3 step in the C core's loop (open and closed loop), real-time factor
  instructions      machine instructions per RK3 step of the C core (valgrind/callgrind)
  per_step_api      µs per ``HybridPlant.step(u)`` call from Python
  reference_solver  wall time of the LSODA reference per simulated second, ratio to the hybrid loop
  max_stable_step   largest stable RK3 step, hybrid vs continuous stiff-stop model, ratio
  circuits          each example circuit: ns per RK3 step, real-time factor, largest stable step, accuracy
  paper_circuit     the paper's rig as a generated circuit beside the core: ns and instructions per step
  floor             the floor program (rk3_floor.c, the same RHS in plain C): ns and instructions per step
  realtime_0.5ms    plant + controller processes over loopback, wall-clock locked: jitter, overruns, RTT
  realtime_0.1ms    the same at 0.1 ms: does it keep up?
  udp_ping_pong     bare Python UDP round trip on loopback (the floor under the HIL RTT)
  lockstep          lock-step HIL throughput (steps/s)
  identification    wall time of the spool and dynamic-friction fits
``markdown(results)`` renders the README's performance table from the JSON.
"""

from __future__ import annotations

import os
import platform
import socket
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable

import numpy as np

from hydrohil.simulation.scenario import EXPERIMENTS_DIR

HIL_KEYS = ("steps", "overruns", "overrun_fraction", "jitter_us_p50", "jitter_us_p99", "jitter_us_p999",
            "jitter_us_max", "compute_us_p50", "compute_us_p99", "rtt_us_p50", "rtt_us_p99", "rtt_seen_us_p50",
            "rtt_seen_us_p99", "rtt_source", "late_commands",
            "watchdog_trips", "packets_lost", "drift_ms", "os_rt_priority")


def machine() -> dict:
    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import cffi
    from hydrohil.core.build import c_compiler
    cc = c_compiler()
    try:
        import subprocess
        cc_version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    except (OSError, IndexError):
        cc_version = cc
    return {"cpu": cpu, "cpus": os.cpu_count(), "platform": platform.platform(),
            "python": sys.version.split()[0], "numpy": np.__version__, "cffi": cffi.__version__,
            "compiler": cc_version, "date_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime())}


def _scenario(name: str, duration: float, every: int = 1000, solver: str | None = None):
    from hydrohil.simulation.scenario import load_scenario
    sc = load_scenario(EXPERIMENTS_DIR / name, duration=duration, solver=solver)
    return sc.model_copy(update={"scenario": sc.scenario.model_copy(update={
        "solver": sc.scenario.solver.model_copy(update={"output_every": every})})})


def compiled_loop(duration: float = 60.0, repeats: int = 7) -> dict:
    from hydrohil.simulation.run import run_scenario
    out = {}
    for label, name in (("open_loop", "fig10_open_loop_sine.toml"), ("closed_loop", "fig11_p_control.toml")):
        sc = _scenario(name, duration)
        walls = [run_scenario(sc, engine="core").wall_time_s for _ in range(repeats)]   # (the C core's loop)
        med = statistics.median(walls)
        out[label] = {"ns_per_step": med / sc.scenario.n_steps() * 1e9, "realtime_factor": duration / med}
    return out


def per_step_api(n: int = 20000, repeats: int = 5) -> dict:
    from hydrohil.parameters import load_parameters
    from hydrohil.simulation.loop import HybridPlant
    plant = HybridPlant(load_parameters("ferreira2004", {"load.gravity_direction": 0}), xp=0.09)
    u = (0.3 * np.sin(2 * np.pi * 0.5 * np.arange(n) * 5e-4)).tolist()    # Python floats, as a controller sends
    res = []
    for _ in range(repeats):
        plant.reset(xp=0.09)
        step = plant.step
        t0 = time.perf_counter()
        for uk in u:
            step(uk)
        res.append((time.perf_counter() - t0) / n * 1e6)
    return {"us_per_call": statistics.median(res)}


def instructions(steps: int = 4000) -> dict:
    """Machine instructions per hybrid RK3 step of the C core's loop, counted by valgrind/callgrind inside
    ``hh_sim_run`` (Fig 10's open-loop sine, the first ``steps`` steps): independent of machine load. The
    driver (``core/tools/step_count.c``) is compiled with the extension's flags; None without valgrind/cc."""
    import shutil
    import subprocess
    from hydrohil.core import build as core_build
    from hydrohil.models.layout import pack
    cc = core_build.c_compiler()
    if shutil.which("valgrind") is None or shutil.which(cc) is None:
        return {"per_step": None, "reason": "valgrind or a C compiler not found"}
    core = Path(core_build.__file__).resolve().parent
    sc = _scenario("fig10_open_loop_sine.toml", steps * 5e-4)
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        pack(sc.params).tofile(t / "p.bin")
        np.ascontiguousarray(sc.scenario.commands()[:steps + 1], float).tofile(t / "u.bin")
        subprocess.run([cc, *core_build.CFLAGS, "-I", str(core), str(core / "tools" / "step_count.c"),
                        str(core / "hh_core.c"), "-lm", "-o", str(t / "step_count")], check=True, capture_output=True)
        subprocess.run(["valgrind", "--tool=callgrind", "--toggle-collect=hh_sim_run",
                        f"--callgrind-out-file={t / 'cg.out'}", str(t / "step_count"), str(t / "p.bin"),
                        str(t / "u.bin"), str(steps), "2", "5e-4", str(sc.scenario.initial.xp)],
                       check=True, capture_output=True)
        total = 0
        for line in (t / "cg.out").read_text().splitlines():
            if line.startswith("totals:") or line.startswith("summary:"):
                total = int(line.split()[1])
    return {"per_step": total / steps, "steps": steps, "tool": "valgrind --tool=callgrind"}


FLOOR_ENV = "HYDROHIL_RK3_FLOOR"     # the floor program's C file (default: the workspace's shared/bench/rk3_floor.c)


def floor_program(path: str | Path | None = None) -> Path | None:
    """The floor program's C file (a plain-C RK3 of the same right-hand side without the statechart, events or
    stiff-chamber constants: what the arithmetic alone costs): ``path`` (FileNotFoundError when it is not a file),
    else $HYDROHIL_RK3_FLOOR, else ``shared/bench/rk3_floor.c`` beside the repository; None when there is none."""
    if path is not None:
        if not Path(path).is_file():
            raise FileNotFoundError(f"{path}: no such file (the floor program)")
        return Path(path)
    for p in (os.environ.get(FLOOR_ENV), Path(__file__).resolve().parents[3] / "shared" / "bench" / "rk3_floor.c"):
        if p and Path(p).is_file():
            return Path(p)
    return None


def build_floor(src: Path, exe: Path, text: str | None = None) -> Path:
    """The floor program ``src`` (or its ``text``, e.g. a shortened copy) compiled to ``exe`` with the package's
    compiler and flags (its folder on the include path); RuntimeError with the compiler's message."""
    import subprocess
    from hydrohil.core import build as core_build
    c = exe.with_suffix(".c")
    c.write_text(src.read_text() if text is None else text)
    r = subprocess.run([*core_build.c_compiler().split(), *core_build.CFLAGS, f"-I{src.resolve().parent}", str(c),
                        "-lm", "-o", str(exe)], capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError(f"{src}: does not build: {r.stderr.strip()[-400:]}")
    return exe


def floor_ns(exe: Path) -> float:
    """One run of the built floor program: the ns per step it prints first ("<ns> ns per RK3 step ...")."""
    import subprocess
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    try:
        return float(out.split()[0])
    except (IndexError, ValueError):
        raise RuntimeError(f"{exe}: printed {out[:80]!r}, not its ns per step first") from None


def floor_instructions(src: Path, steps: int = 4000) -> tuple[float | None, str | None]:
    """(machine instructions per step of the floor program's loop, None) counted by callgrind inside ``main`` on
    a copy of ``steps`` steps (its ``const int N = ...;`` replaced; its ``sin`` of the command included), or
    (None, why not)."""
    import re
    import shutil
    import subprocess
    if shutil.which("valgrind") is None:
        return None, "valgrind not found"
    short, n = re.subn(r"const int N = \d+;", f"const int N = {steps};", src.read_text())
    if n != 1:
        return None, f"{src}: no single 'const int N = <steps>;' to shorten"
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_floor(src, Path(tmp) / "floor_short", short)
        cg = Path(tmp) / "cg.out"
        subprocess.run(["valgrind", "--tool=callgrind", "--toggle-collect=main", f"--callgrind-out-file={cg}",
                        str(exe)], check=True, capture_output=True)
        total = next(int(line.split()[1]) for line in cg.read_text().splitlines()
                     if line.startswith(("summary:", "totals:")))
    return total / steps, None


def floor_step(path: str | Path | None = None, repeats: int = 5, steps: int | None = 4000) -> dict:
    """The floor program (:func:`floor_program`) built with the package's compiler and flags: the median of its
    own ns per step over ``repeats`` runs (2e6 steps a run) and, with valgrind, its instructions per step
    (:func:`floor_instructions`; ``steps`` None: not counted); {"ns_per_step": None, "reason": ...} when there
    is no floor program or it does not build or run (the rest of the benchmark goes on)."""
    import shutil
    import subprocess
    from hydrohil.core import build as core_build
    src = floor_program(path)
    none = {"ns_per_step": None, "instructions_per_step": None}
    if src is None:
        return {**none, "reason": f"no floor program (give --floor or ${FLOOR_ENV})"}
    if shutil.which(core_build.c_compiler().split()[0]) is None:
        return {**none, "reason": "no C compiler"}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            exe = build_floor(src, Path(tmp) / "rk3_floor")
            ns = [floor_ns(exe) for _ in range(repeats)]
        count, why = floor_instructions(src, steps) if steps else (None, "not counted")
    except (RuntimeError, subprocess.CalledProcessError, StopIteration) as exc:
        return {**none, "reason": str(exc)[-400:]}
    res = {"ns_per_step": statistics.median(ns), "runs": ns, "source": str(src), "instructions_per_step": count}
    if why:
        res["instructions_reason"] = why
    return res


def reference_solver(duration: float = 6.0, repeats: int = 3) -> dict:
    from hydrohil.simulation.run import run_scenario
    ref = _scenario("fig10_open_loop_sine.toml", duration, every=1, solver="reference")
    hyb = _scenario("fig10_open_loop_sine.toml", duration, every=1)
    w_ref = statistics.median(run_scenario(ref).wall_time_s for _ in range(repeats))
    w_hyb = statistics.median(run_scenario(hyb, engine="core").wall_time_s for _ in range(repeats))
    return {"lsoda_s_per_simulated_s": w_ref / duration, "hybrid_s_per_simulated_s": w_hyb / duration,
            "ratio": w_ref / w_hyb}


def circuits(duration: float = 60.0, repeats: int = 7) -> dict:
    """Each example circuit (``examples/circuits/*/scenario.toml``): its RK3 step at 0.5 ms (median ns per step
    of the generated loop over ``duration`` simulated seconds, a log row every 1000 steps; real-time factor),
    its largest stable RK3 step and its accuracy at 0.5 ms against its continuous reference (maxstep)."""
    from hydrohil.circuits.circuit import CIRCUITS_DIR
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.maxstep import circuit_max_stable_step
    out = {}
    for f in sorted(CIRCUITS_DIR.glob("*/scenario.toml")):
        cs = load_circuit_scenario(f, solver="rk3", step=5e-4)
        walls = [simulate_circuit(cs.circuit, duration, h=cs.step, every=1000, loop=cs.loop).wall
                 for _ in range(repeats)]
        med = statistics.median(walls)
        ms = circuit_max_stable_step(cs, "rk3")
        acc = ms["accuracy_at_step"]
        out[f.parent.name] = {"ns_per_step": med / int(round(duration / cs.step)) * 1e9,
                              "realtime_factor": duration / med, "pressure_nodes": len(cs.circuit.state_nodes),
                              "max_stable_step_s": ms["max_stable_step"],
                              "first_unstable_step_s": ms["first_unstable_step"],
                              "worst_position_m": acc["worst_position_m"],
                              "worst_pressure_relative": acc["worst_pressure_relative"],
                              "worst_speed_relative": acc["worst_speed_relative"], "holds": acc["holds"],
                              "positions": len(acc["rms_position_m"]), "speeds": len(acc["rms_speed_relative"])}
    return out


def _paper_runs(duration: float):
    """Fig 10's open-loop sine on the core's loop and on the paper's rig as a circuit (hydrohil.circuits.paper;
    both delaying the valve's command): (steps, run core, run circuit); each run returns its wall time [s]."""
    import warnings
    from hydrohil.circuits.paper import paper_circuit
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.simulation.run import run_scenario
    sc = _scenario("fig10_open_loop_sine.toml", duration)
    s = sc.scenario
    h, n = s.solver.step, s.n_steps()
    drive = {"valve.command": (np.arange(n + 1) * h, s.commands())}
    c = paper_circuit(sc.params, s.initial.xp)

    def circuit():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")            # (open loop: the piston is not held at rest)
            return simulate_circuit(c, duration, h=h, every=1000, inputs=drive).wall
    return n, lambda: run_scenario(sc, engine="core").wall_time_s, circuit


def paper_circuit(duration: float = 60.0, repeats: int = 7, steps: int | None = 4000) -> dict:
    """The paper's rig as a generated circuit beside the hand-written core, in one run: median ns per RK3 step
    of each loop (Fig 10 open loop) and, with valgrind, machine instructions per step inside ``hh_sim_run`` and
    ``hc_run`` (the first ``steps`` steps). The same work: both locate their events inside the step, slow
    their stiff chambers (nodes) and delay the valve's command. ``steps`` None: no instruction count. Through
    Python the core's run costs some 230 instructions a step more than in a plain C loop (not located):
    benchmarks/paper_circuit_c.py compares the two like for like (the README's figures)."""
    import shutil
    import subprocess
    n, core, circuit = _paper_runs(duration)
    walls = [(core(), circuit()) for _ in range(repeats)]
    out = {"core_ns_per_step": statistics.median(w[0] for w in walls) / n * 1e9,
           "circuit_ns_per_step": statistics.median(w[1] for w in walls) / n * 1e9}
    out["ratio"] = out["circuit_ns_per_step"] / out["core_ns_per_step"]
    if shutil.which("valgrind") is None or steps is None:
        return {**out, "core_instructions": None, "circuit_instructions": None}
    with tempfile.TemporaryDirectory() as tmp:
        for name, fn, idx in (("core", "hh_sim_run", 1), ("circuit", "hc_run", 2)):
            prog = ("from hydrohil.bench import "
                    f"_paper_runs; r = _paper_runs({steps * 5e-4!r}); r[{idx}]()")
            cg = Path(tmp) / f"{name}.out"
            subprocess.run(["valgrind", "--tool=callgrind", f"--toggle-collect={fn}", f"--callgrind-out-file={cg}",
                            sys.executable, "-c", prog], check=True, capture_output=True)
            total = next(int(line.split()[1]) for line in cg.read_text().splitlines()
                         if line.startswith(("summary:", "totals:")))
            out[f"{name}_instructions"] = total / steps
    return out


def max_stable_step() -> dict:
    from hydrohil.maxstep import max_stable_step as search
    from hydrohil.simulation.scenario import load_scenario
    sc = load_scenario(EXPERIMENTS_DIR / "endstop_step_size.toml")
    t0 = time.perf_counter()
    hyb, cont = search(sc, "hybrid", "rk3"), search(sc, "continuous", "rk3")
    return {"hybrid_s": hyb["max_stable_step"], "continuous_s": cont["max_stable_step"],
            "ratio": hyb["max_stable_step"] / cont["max_stable_step"], "search_wall_s": time.perf_counter() - t0}


def startup(repeats: int = 5) -> dict:
    """`hydrohil simulate` of a short scenario as a fresh process (the first run after this process started,
    then the median of the next ones; nothing is compiled at run time), and `import hydrohil` in a fresh
    process less an empty interpreter's start."""
    import subprocess

    def wall(cmd):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        return time.perf_counter() - t0

    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "hydrohil.cli", "simulate", str(EXPERIMENTS_DIR / "endstop_step_size.toml"),
               "--out", out, "--no-plot"]
        walls = [wall(cmd) for _ in range(repeats + 1)]
    bare = statistics.median(wall([sys.executable, "-c", "pass"]) for _ in range(repeats))
    imp = statistics.median(wall([sys.executable, "-c", "import hydrohil"]) for _ in range(repeats))
    sim = statistics.median(wall([sys.executable, "-c", "import hydrohil.simulation.run"]) for _ in range(repeats))
    return {"cold_s": walls[0], "warm_s": statistics.median(walls[1:]), "import_s": imp - bare,
            "import_simulation_s": sim - bare}


def hil_scenario(tmp: Path, seconds: float, step: float) -> Path:
    """Fig 11's point-to-point move repeated for ``seconds`` at plant step ``step``."""
    t, x = [0.0], [0.03]
    k = 0
    while t[-1] < seconds:
        base = 6.0 * k
        t += [base + 0.5, base + 1.5, base + 3.0, base + 4.0, base + 6.0]
        x += [0.03, 0.15, 0.15, 0.03, 0.03]
        k += 1
    path = tmp / f"bench_{seconds:g}s_{step:g}.toml"
    path.write_text(f'params = "ferreira2004"\nduration = {seconds}\n[solver]\nstep = {step}\n[initial]\nxp = 0.03\n'
                    f'[controller]\ntype = "p"\nkp = 50.0\n[reference]\ntype = "table"\nt = {t}\nx = {x}\n')
    return path


def hil(seconds: float, step: float, lockstep: bool = False, plant: str = "python") -> dict:
    """A HIL run of :func:`hil_scenario` with the Python plant server or the standalone C plant."""
    from hydrohil.hil.run import run_hil
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        scenario = hil_scenario(tmp, seconds, step)
        if plant == "c":          # build (or find in the cache) before the clock starts
            from hydrohil.hil.run import c_plant_executable
            from hydrohil.simulation.scenario import load_scenario
            c_plant_executable(load_scenario(scenario), scenario)
        t0 = time.perf_counter()
        r = run_hil(scenario, tmp / "out", lockstep=lockstep, plot=False, plant=plant)
        res = {k: r.timing.get(k) for k in HIL_KEYS}
        res["verdict"] = r.verdict["verdict"]
        res["verdict_reasons"] = r.verdict["reasons"]
        if res["steps"]:
            res["overrun_fraction"] = (res["overruns"] or 0) / res["steps"]
        res.update({"step_s": step, "seconds": seconds, "xp_rms_vs_offline_mm": r.comparison["xp_rms_mm"],
                    "wall_s": time.perf_counter() - t0})
        if lockstep:
            res["steps_per_s"] = r.timing.get("steps_per_s")
    return res


def hiccup(seconds: float) -> dict:
    """The platform's wake-up floor: ``core/tools/hiccup.c`` (the plant's duty cycle, nothing else) on the
    plant's CPU for ``seconds``."""
    import json
    import subprocess
    from hydrohil.core.build import HERE as core, c_compiler
    from hydrohil.simulation.scenario import HilCfg
    cpu = HilCfg().cpus()[0]
    with tempfile.TemporaryDirectory() as tmp:
        exe = Path(tmp) / "hiccup"
        subprocess.run([c_compiler(), "-O2", "-o", str(exe), str(core / "tools" / "hiccup.c")], check=True,
                       capture_output=True)
        r = subprocess.run([str(exe), str(seconds), *([str(cpu)] if cpu is not None else [])], capture_output=True,
                           text=True, check=True)
    return {"seconds": seconds, **json.loads(r.stdout.strip().splitlines()[-1])}


def udp_ping_pong(n: int = 20000) -> dict:
    """Round trip of a 52-byte datagram between two sockets on loopback, echo in a thread."""
    a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    a.bind(("127.0.0.1", 0))
    b.bind(("127.0.0.1", 0))
    a.connect(b.getsockname())
    b.connect(a.getsockname())
    stop = threading.Event()

    def echo():
        b.settimeout(0.5)
        while not stop.is_set():
            try:
                b.send(b.recv(2048))
            except socket.timeout:
                pass

    th = threading.Thread(target=echo, daemon=True)
    th.start()
    msg = bytes(52)
    rtt = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter_ns()
        a.send(msg)
        a.recv(2048)
        rtt[i] = (time.perf_counter_ns() - t0) / 1e3
    stop.set()
    th.join()
    a.close()
    b.close()
    return {"rtt_us_p50": float(np.percentile(rtt, 50)), "rtt_us_p99": float(np.percentile(rtt, 99))}


def identification() -> dict:
    from hydrohil.identification import identify_friction_dynamic, identify_spool
    from hydrohil.identification.friction_dynamic import synthetic_experiment
    from hydrohil.identification.spool import synthetic_bode
    from hydrohil.parameters import load_parameters, replace_values
    data = synthetic_bode(850.0, 0.62, 150.0, 6e4, 5e-4, noise_db=0.1, seed=1)
    identify_spool(data)                       # compile
    base = load_parameters("ferreira2004", {"load.gravity_direction": 0})
    d = synthetic_experiment(replace_values(base, {"friction.sigma0": 1.2e7, "friction.sigma1": 5e3}), seed=7)
    return {"spool_s": identify_spool(data).wall_time_s,
            "friction_dynamic_s": identify_friction_dynamic(d, base).wall_time_s}


def run_bench(*, seconds: float = 60.0, quick: bool = False,
              on_section: Callable[[str, int, int], None] | None = None, floor: str | Path | None = None) -> dict:
    """Run every section; ``quick`` shortens every run (a smoke test, not figures to report); ``floor``: the
    floor program's C file (:func:`floor_program`)."""
    rt = 2.0 if quick else seconds
    sections: list[tuple[str, Callable[[], dict]]] = [
        ("startup", lambda: startup(1 if quick else 3)),
        ("compiled_loop", lambda: compiled_loop(6.0 if quick else 60.0, 2 if quick else 7)),
        ("instructions", lambda: instructions(1000 if quick else 4000)),
        ("per_step_api", lambda: per_step_api(2000 if quick else 20000, 2 if quick else 5)),
        ("reference_solver", lambda: reference_solver(1.0 if quick else 6.0, 1 if quick else 3)),
        ("max_stable_step", max_stable_step),
        ("circuits", lambda: circuits(6.0 if quick else 60.0, 2 if quick else 7)),
        ("paper_circuit", lambda: paper_circuit(6.0 if quick else 60.0, 2 if quick else 7, None if quick else 4000)),
        ("floor", lambda: floor_step(floor, 2 if quick else 7, None if quick else 4000)),
        ("realtime_0.5ms", lambda: hil(rt, 5e-4)),
        ("realtime_0.5ms_c", lambda: hil(rt, 5e-4, plant="c")),
        ("hiccup", lambda: hiccup(rt)),
        ("realtime_0.1ms", lambda: hil(min(rt, 10.0), 1e-4)),
        ("udp_ping_pong", lambda: udp_ping_pong(2000 if quick else 20000)),
        ("lockstep", lambda: hil(2.0 if quick else 10.0, 5e-4, lockstep=True)),
        ("identification", identification),
    ]
    res = {"machine": machine(), "quick": quick}
    for i, (name, fn) in enumerate(sections):
        if on_section:
            on_section(name, i, len(sections))
        res[name] = fn()
    res["ratios"] = {
        "hybrid_vs_continuous_step": res["max_stable_step"]["ratio"],
        "lsoda_vs_hybrid_wall": res["reference_solver"]["ratio"],
        "hil_rtt_p50_vs_bare_udp": res["realtime_0.5ms"]["rtt_us_p50"] / res["udp_ping_pong"]["rtt_us_p50"],
        "per_step_api_vs_compiled_step": res["per_step_api"]["us_per_call"] * 1e3
        / res["compiled_loop"]["open_loop"]["ns_per_step"]}
    return res


def emit(res: dict, path: Path | None = None) -> None:
    """Print results as JSON (and write them to ``path``): the output of the benchmark scripts."""
    import json
    text = json.dumps(res, indent=2)
    print(text)
    if path:
        path.write_text(text + "\n")


def _f(v, fmt="{:.3g}") -> str:
    return "—" if v is None else fmt.format(v)


def markdown(res: dict) -> str:
    """The README's performance table from a ``run_bench`` result."""
    c, rt5, rt1 = res["compiled_loop"], res["realtime_0.5ms"], res["realtime_0.1ms"]
    pc, fl = res.get("paper_circuit") or {}, res.get("floor") or {}
    m = res["machine"]
    rows = [
        ("hybrid RK3 step, the paper's rig on its generated code (what `simulate` runs) / on the C core, Fig 10",
         f"{_f(pc.get('circuit_ns_per_step'), '{:.0f}')} / {_f(pc.get('core_ns_per_step'), '{:.0f}')} ns", "≤ 100 ns"),
        ("… the floor program in the same run (`rk3_floor.c`: plain-C RK3 of the same right-hand side, no "
         "statechart; the package's flags): ns, the generated step / the floor",
         f"{_f(fl.get('ns_per_step'), '{:.0f}')} ns, "
         + (f"{pc['circuit_ns_per_step'] / fl['ns_per_step']:.2f}" if fl.get("ns_per_step") and pc else "—"),
         "—"),
        ("… machine instructions per RK3 step (callgrind, independent of load): generated (hc_run) / core (its plain-C "
         "driver, core/tools/step_count.c) / floor",
         f"{_f(pc.get('circuit_instructions'), '{:.0f}')} / {_f(res.get('instructions', {}).get('per_step'), '{:.0f}')}"
         f" / {_f(fl.get('instructions_per_step'), '{:.0f}')}", "≤ 1 100"),
        ("hybrid RK3 step, C core loop (open / closed loop)",
         f"{c['open_loop']['ns_per_step']:.0f} / {c['closed_loop']['ns_per_step']:.0f} ns "
         f"(real-time factor {c['open_loop']['realtime_factor']:.0f} / {c['closed_loop']['realtime_factor']:.0f})",
         "—"),
        ("`hydrohil simulate` as a new process: first / following runs",
         f"{res['startup']['cold_s']:.2f} s / {res['startup']['warm_s']:.2f} s", "≤ 1.5 s"),
        ("`import hydrohil` / `import hydrohil.simulation.run` (fresh process, less the interpreter's start)",
         f"{res['startup'].get('import_s', float('nan')):.3f} s / "
         f"{res['startup'].get('import_simulation_s', float('nan')):.2f} s", "≤ 0.3 s"),
        ("per-step API `plant.step(u)` from Python", f"{res['per_step_api']['us_per_call']:.2f} µs", "≤ 0.5 µs"),
        ("LSODA reference, wall per simulated second",
         f"{res['reference_solver']['lsoda_s_per_simulated_s']:.3g} s ({res['reference_solver']['ratio']:.0f}× "
         "the hybrid loop)", "—"),
        ("largest stable RK3 step: hybrid / stiff end stops",
         f"{_f(res['max_stable_step']['hybrid_s'])} s / {_f(res['max_stable_step']['continuous_s'])} s "
         f"(ratio {res['max_stable_step']['ratio']:.3g})", "ratio ≥ 100"),
        (f"real time 0.5 ms, {rt5['seconds']:g} s: jitter p50 / p99 / p99.9 / max",
         f"{_f(rt5['jitter_us_p50'])} / {_f(rt5['jitter_us_p99'])} / {_f(rt5['jitter_us_p999'])} / "
         f"{_f(rt5['jitter_us_max'])} µs", "p99 ≤ 50 µs"),
        ("real time 0.5 ms: overruns", f"{rt5['overruns']} of {rt5['steps']} ({rt5['overrun_fraction']:.3%})",
         "≤ 0.1 %"),
        ("real time 0.5 ms: verdict (hil/verdict.py)",
         rt5["verdict"] + (f" ({'; '.join(rt5['verdict_reasons'])})" if rt5["verdict_reasons"] else ""), "VALID"),
        ("real time 0.5 ms: plant server compute per step p50 / p99",
         f"{_f(rt5.get('compute_us_p50'))} / {_f(rt5.get('compute_us_p99'))} µs", "—"),
        ("real time 0.5 ms: drift (final wall − simulated time)", f"{_f(rt5['drift_ms'])} ms", "≤ 1 ms"),
        ("loopback RTT p50 / p99 (plant packet out → answering command in, kernel receive stamp)",
         f"{_f(rt5['rtt_us_p50'])} / {_f(rt5['rtt_us_p99'])} µs", "p99 ≤ 100 µs"),
        ("… the same until the plant process read the command (its own wake-up included)",
         f"{_f(rt5['rtt_seen_us_p50'])} / {_f(rt5['rtt_seen_us_p99'])} µs", "—"),
        ("bare Python UDP ping-pong p50 / p99 (floor)",
         f"{_f(res['udp_ping_pong']['rtt_us_p50'])} / {_f(res['udp_ping_pong']['rtt_us_p99'])} µs", "—"),
        ("HIL vs offline position (0.5 ms run)", f"{_f(rt5['xp_rms_vs_offline_mm'])} mm RMS", "≤ 0.5 mm"),
        (f"real time 0.1 ms, {rt1['seconds']:g} s: overruns, jitter p99, late commands",
         f"{rt1['overrun_fraction']:.2%}, {_f(rt1['jitter_us_p99'])} µs, {rt1['late_commands']}", "reported"),
        ("lock-step HIL throughput", f"{res['lockstep']['steps_per_s']:.0f} steps/s "
         f"(vs offline {_f(res['lockstep']['xp_rms_vs_offline_mm'])} mm)", "—"),
        ("identification: spool / dynamic friction", f"{res['identification']['spool_s']:.1f} s / "
         f"{res['identification']['friction_dynamic_s']:.1f} s", "—"),
    ]
    head = [f"Measured by `hydrohil bench` on {m['cpu']} ({m['cpus']} CPUs), Python {m['python']}, "
            f"C core: {m.get('compiler', '?')} via cffi {m.get('cffi', '?')}, {m['date_utc']} UTC; "
            f"real-time priority: {rt5['os_rt_priority']}.", "",
            "| figure | measured | target |", "|---|---|---|"]
    return ("\n".join(head + [f"| {a} | {b} | {c} |" for a, b, c in rows]) + "\n" + plants_table(res)
            + circuits_table(res))


def circuits_table(res: dict) -> str:
    """The example circuits' table: step cost, real-time factor, largest stable step, accuracy at 0.5 ms."""
    if not res.get("circuits"):
        return ""
    lines = ["", "Example circuits (`examples/circuits/*/scenario.toml`), RK3 at 0.5 ms against each circuit's "
             "continuous reference (LSODA, generated from the same description):", "",
             "| circuit | step | real-time factor | largest stable step | position RMS | pressure RMS "
             "(of highest) | speed RMS (of largest) |", "|---|---|---|---|---|---|---|"]
    for name, r in res["circuits"].items():
        lines.append(f"| `{name}` | {r['ns_per_step']:.0f} ns | {r['realtime_factor']:.0f} | "
                     f"{'' if r.get('first_unstable_step_s', 0) else '≥ '}"
                     f"{_f(r['max_stable_step_s'] and r['max_stable_step_s'] * 1e3)} ms | "
                     f"{_f(r['worst_position_m'] * 1e6 if r.get('positions') else None, '{:.2g} µm')} | "
                     f"{r['worst_pressure_relative'] * 100:.2g} % | "
                     f"{_f(r['worst_speed_relative'] * 100 if r.get('speeds') else None, '{:.2g} %')} |")
    lines.append("")
    lines.append("Limits (every example): position ≤ 0.1 mm, pressure ≤ 3 %, speed ≤ 2 % RMS; largest stable step "
                 "≥ 1 ms.")
    pc = res.get("paper_circuit")
    if pc:
        counted = pc.get("circuit_instructions") is not None       # (valgrind: not in a quick run, or absent)
        lines += ["", f"The paper's rig generated as a circuit beside the hand-written core (Fig 10, the same work, "
                  f"same run): {pc['circuit_ns_per_step']:.0f} vs {pc['core_ns_per_step']:.0f} ns per RK3 step "
                  f"(ratio {pc['ratio']:.2f})" + (f", {pc['circuit_instructions']:.0f} vs "
                                                  f"{pc['core_instructions']:.0f} instructions per step (callgrind)."
                                                  if counted else "; instructions not counted (no valgrind run).")]
    return "\n".join(lines) + "\n"


def plants_table(res: dict) -> str:
    """The Python plant server and the standalone C plant side by side (same scenario, back to back), and
    the platform's floor (hiccup.c)."""
    py, c, hc = res.get("realtime_0.5ms"), res.get("realtime_0.5ms_c"), res.get("hiccup")
    if not (py and c):
        return ""

    def col(r, key, fmt="{:.3g}"):
        return _f(r.get(key), fmt)

    rows = [("jitter p50 / p99 / max [µs]", *(f"{col(r, 'jitter_us_p50')} / {col(r, 'jitter_us_p99')} / "
                                                f"{col(r, 'jitter_us_max', '{:.0f}')}" for r in (py, c))),
            ("overruns (steps started > 0.5 ms late)", *(f"{r['overruns']} of {r['steps']} "
                                                         f"({r['overrun_fraction']:.3%})" for r in (py, c))),
            ("late commands", *(str(r["late_commands"]) for r in (py, c))),
            ("RTT p50 / p99, kernel stamp [µs]", *(f"{col(r, 'rtt_us_p50')} / {col(r, 'rtt_us_p99')}" for r in (py, c))),
            ("compute per step p50 / p99 [µs]", *(f"{col(r, 'compute_us_p50')} / {col(r, 'compute_us_p99')}"
                                                  for r in (py, c))),
            ("HIL vs offline position [mm RMS]", *(col(r, "xp_rms_vs_offline_mm") for r in (py, c))),
            ("verdict", *(r["verdict"] for r in (py, c)))]
    floor = (f"{hc['wakeups_late_0.5ms']} of {hc['periods']} wake-ups > 0.5 ms late ({hc['late_fraction']:.3%}), "
             f"worst {hc['worst_ms']:.1f} ms" if hc else "—")
    lines = ["", f"Plant servers side by side (0.5 ms, {py['seconds']:g} s each, back to back; the P controller "
             "process is the same):", "",
             "| figure | Python plant (`hydrohil plant`) | C plant (`hydrohil export c`) |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {cc} |" for a, b, cc in rows]
    lines += ["", f"Platform floor (`core/tools/hiccup.c`, the plant's duty cycle and nothing else, {_f(hc and hc['seconds'])}"
              f" s): {floor}."]
    return "\n".join(lines) + "\n"
