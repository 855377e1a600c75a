"""``hydrohil hil``: plant and controller as two OS processes over UDP loopback, then the report.

The plant process (``hydrohil plant --scenario ...``) prints ``READY host:port`` once bound; the
controller process (``hydrohil controller --scenario ... --connect host:port``) then runs the
scenario's P controller. Both are stopped with SIGINT on Ctrl-C (they finish their logs). Afterwards
the same scenario runs offline (``hydrohil simulate``'s code path) for the comparison.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from hydrohil.errors import HydrohilError, InputError
from hydrohil.simulation.scenario import load_scenario

READY_TIMEOUT_S = 120.0    # first start compiles the model (numba cache) before binding


@dataclass
class HilResult:
    out: Path
    timing: dict
    controller: dict
    comparison: dict


def _cli(*args) -> list[str]:
    return [sys.executable, "-m", "hydrohil.cli", *map(str, args)]


def _stop(proc: subprocess.Popen, grace: float = 10.0) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(grace)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def run_hil(scenario: str | Path, out: str | Path, *, lockstep: bool = False,
            progress: Callable[[float, float], None] | None = None, plot: bool = True) -> HilResult:
    """Run a scenario as a HIL experiment; writes plant_log.csv, controller_log.csv, timing.json,
    comparison.json and report.png into ``out``."""
    scenario, out = Path(scenario), Path(out)
    sc = load_scenario(scenario)           # validate before starting anything
    if not sc.scenario.closed_loop:
        raise InputError("hydrohil hil needs a closed-loop scenario ([controller] + [reference])",
                         source=str(scenario))
    out.mkdir(parents=True, exist_ok=True)
    plant_cmd = _cli("plant", "--scenario", scenario, "--bind", "127.0.0.1:0", "--log", out,
                     *(["--lockstep"] if lockstep else []))
    plant = subprocess.Popen(plant_cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ctl = None
    try:
        address = _wait_ready(plant)
        ctl = subprocess.Popen(_cli("controller", "--scenario", scenario, "--connect", address, "--log", out),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        duration = sc.scenario.duration
        t0 = time.monotonic()
        while plant.poll() is None or ctl.poll() is None:
            if progress:
                progress(min(time.monotonic() - t0, duration), duration)
            time.sleep(0.1)
            if plant.poll() is not None and ctl.poll() is None and time.monotonic() - t0 > duration + 30:
                _stop(ctl)
        if progress:
            progress(duration, duration)
    except KeyboardInterrupt:
        for p in (ctl, plant):
            if p is not None:
                _stop(p)
        raise
    finally:
        for p in (ctl, plant):
            if p is not None and p.poll() is None:
                _stop(p)
    p_err = plant.stderr.read() if plant.stderr else ""
    if plant.returncode != 0:
        raise HydrohilError(f"plant process failed (exit {plant.returncode}): {p_err.strip()[-2000:]}")
    c_err = ctl.stderr.read() if ctl and ctl.stderr else ""
    if ctl is not None and ctl.returncode != 0:
        raise HydrohilError(f"controller process failed (exit {ctl.returncode}): {c_err.strip()[-2000:]}")
    timing = json.loads((out / "timing.json").read_text())
    controller = json.loads((out / "controller.json").read_text())
    comparison = compare_offline(scenario, out, plot=plot)
    return HilResult(out, timing, controller, comparison)


def _wait_ready(plant: subprocess.Popen) -> str:
    t0 = time.monotonic()
    while time.monotonic() - t0 < READY_TIMEOUT_S:
        line = plant.stdout.readline()
        if line.startswith("READY "):
            return line.split()[1]
        if not line and plant.poll() is not None:
            err = plant.stderr.read()
            raise HydrohilError(f"plant process exited before binding (exit {plant.returncode}): {err.strip()}")
    raise HydrohilError(f"plant did not report READY within {READY_TIMEOUT_S:g} s")


def read_csv_columns(path: Path) -> dict[str, np.ndarray]:
    import csv
    with open(path, newline="") as fh:
        r = csv.reader(fh)
        header = next(r)
        rows = list(r)
    out = {}
    for j, name in enumerate(header):
        col = [row[j] for row in rows]
        try:
            out[name] = np.array(col, dtype=float)
        except ValueError:
            out[name] = np.array(col)
    return out


def compare_offline(scenario: Path, out: Path, *, plot: bool = True) -> dict:
    """Offline run of the same scenario; position RMS/max difference to the HIL plant log."""
    from hydrohil.simulation.run import run_scenario
    sc = load_scenario(scenario)
    res = run_scenario(sc)
    hil = read_csv_columns(out / "plant_log.csv")
    n = min(len(hil["t"]), len(res.log))
    d = hil["xp"][:n] - res.column("xp")[:n]
    ref = sc.scenario.references()[:n]
    cmp = {"steps_compared": int(n), "xp_rms_mm": float(np.sqrt(np.mean(d ** 2)) * 1e3),
           "xp_max_mm": float(np.max(np.abs(d)) * 1e3),
           "p1_rms_bar": float(np.sqrt(np.mean((hil["p1"][:n] - res.column("p1")[:n]) ** 2)) / 1e5),
           "hil_tracking_rms_mm": float(np.sqrt(np.mean((hil["xp"][:n] - ref) ** 2)) * 1e3),
           "offline_tracking_rms_mm": float(np.sqrt(np.mean((res.column("xp")[:n] - ref) ** 2)) * 1e3)}
    (out / "comparison.json").write_text(json.dumps(cmp, indent=2) + "\n")
    if plot:
        from hydrohil.plotting import plot_hil
        plot_hil(out / "report.png", hil, res, ref, title=f"{scenario.name}: HIL vs offline")
    return cmp
