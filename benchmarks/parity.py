"""Parity of two builds of the model: record results with one, compare another against them.

    python benchmarks/parity.py record FILE.npz     # with build A (e.g. the numba model before the C core)
    python benchmarks/parity.py compare FILE.npz    # with build B: per case, the largest relative difference
    python benchmarks/parity.py compare FILE.npz --engine generated   # run_scenario's generated engine against
                                                    # a record of the core (its fixed-step runs without faults)

Cases (all through the public Python API, so any build of the package can run them):
* every accuracy scenario of ``examples/`` with each fixed-step solver (euler, heun, rk3, rk4) and the
  LSODA reference;
* 300 random scenarios drawn by hypothesis (derandomized; stored in the record, so a compare replays exactly
  the recorded ones): parameters, drive
  (open-loop sine or steps, closed-loop P on a random table), start position (at a stop too), solver, step;
* the per-step API (``HybridPlant.step``) on a sine;
* the explicit fixed-step continuous model of ``maxstep`` at a tiny step;
* steady-state spool Bode points (``simulate_bode``).

Relative difference of a column: max |a − b| / max |a| over the run (mode and event columns: the count of
samples that differ). A case passes at <= 1e-9.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from hydrohil.parameters import load_parameters
from hydrohil.simulation.scenario import LoadedScenario, Scenario, load_scenario

ROOT = Path(__file__).resolve().parent.parent
ACCURACY = ("sine_open_loop.toml", "fig11_p_control.toml", "fig12_steps_ramps.toml", "end_stops_p_control.toml",
            "maxstep_endstop.toml")
SOLVERS = ("euler", "heun", "rk3", "rk4")
N_RANDOM = 300
TOL = 1e-9


def _loaded(data: dict) -> LoadedScenario:
    sc = Scenario.model_validate(data)
    return LoadedScenario(scenario=sc, params=load_parameters(sc.params, sc.overrides), source="parity")


def random_scenarios(n: int = N_RANDOM) -> list[dict]:
    """n scenario dicts drawn by hypothesis, derandomized (the same list on every call)."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    out: list[dict] = []
    ranges = {"supply.ps": (3e6, 2e7), "load.mass": (5.0, 500.0), "load.force": (-3e3, 3e3),
              "spool.delay": (0.0, 2e-3), "friction.sigma0": (1e6, 1e8), "cylinder.v01": (5e-6, 2e-4)}

    @st.composite
    def scenario(draw):
        over = {k: draw(st.floats(lo, hi)) for k, (lo, hi) in ranges.items() if draw(st.booleans())}
        over["load.gravity_direction"] = draw(st.sampled_from([-1, 0, 1]))
        over["friction.asymmetric"] = draw(st.booleans())
        over["cylinder.bulk_modulus"] = draw(st.sampled_from(["pressure", "constant"]))
        duration = draw(st.sampled_from([0.2, 0.5, 1.0]))
        step = draw(st.sampled_from([2.5e-4, 5e-4, 1e-3]))
        d = {"duration": duration, "overrides": over,
             "solver": {"method": draw(st.sampled_from(SOLVERS)), "step": step},
             "initial": {"xp": draw(st.sampled_from([0.0, 0.18, draw(st.floats(0.001, 0.179))])),
                         "xs": draw(st.floats(-1.0, 1.0))}}
        drive = draw(st.sampled_from(["sine", "steps", "p"]))
        if drive == "sine":
            a = draw(st.floats(0.01, 1.0))
            d["input"] = {"type": "sine", "amplitude": a, "offset": draw(st.floats(-1.0 + a, 1.0 - a)),
                          "frequency": draw(st.floats(0.5, 80.0))}
        elif drive == "steps":
            t = sorted(draw(st.lists(st.floats(0.0, duration), min_size=2, max_size=6)))
            d["input"] = {"type": "table", "t": t, "u": [draw(st.floats(-1.0, 1.0)) for _ in t]}
        else:
            t = sorted(draw(st.lists(st.floats(0.0, duration), min_size=2, max_size=6)))
            d["controller"] = {"type": "p", "kp": draw(st.floats(5.0, 300.0))}
            d["reference"] = {"type": "table", "t": t, "x": [draw(st.floats(-0.01, 0.19)) for _ in t]}
        return d

    @settings(max_examples=n, derandomize=True, database=None, deadline=None,
              suppress_health_check=list(HealthCheck))
    @given(scenario())
    def collect(d):
        if len(out) < n:
            out.append(d)

    collect()
    return out


def cases(randoms: list[dict], engine: str = "core"):
    """(name, function returning a dict of arrays) for every case; ``randoms``: the random scenarios; ``engine``:
    run_scenario's."""
    from hydrohil.simulation.run import run_scenario

    def scenario_case(sc):
        def run():
            r = run_scenario(sc, engine=engine)
            return {"log": r.log, "diverged": np.array([r.diverged is not None])}
        return run

    for name in ACCURACY:
        for solver in (*SOLVERS, "reference"):
            yield f"{name}:{solver}", scenario_case(load_scenario(ROOT / "examples" / name, solver=solver))
    import warnings
    for i, d in enumerate(randoms):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield f"random{i:03d}:{d['solver']['method']}", scenario_case(_loaded(d))

    def per_step():
        from hydrohil.simulation.loop import HybridPlant
        plant = HybridPlant(load_parameters("ferreira2004"), xp=0.09)
        u = 0.6 * np.sin(2 * np.pi * 3.0 * np.arange(4000) * 5e-4)
        return {"out": np.array([plant.step(v).copy() for v in u])}
    yield "per_step_api", per_step

    def continuous():
        from hydrohil.maxstep import check_step
        sc = load_scenario(ROOT / "src/hydrohil/experiments/endstop_step_size.toml", duration=0.01)
        ref = run_scenario(load_scenario(ROOT / "src/hydrohil/experiments/endstop_step_size.toml", duration=0.01,
                                         solver="reference"), engine=engine).log
        r = check_step(sc, "continuous", "rk3", 4e-8, ref, engine=engine)
        return {"rms": np.array([r.get("rms_x", np.nan), r.get("rms_p", np.nan), float(r["stable"])])}
    yield "maxstep_continuous", continuous

    def bode():
        from hydrohil.identification.spool import simulate_bode
        a = np.repeat([0.05, 0.25, 0.5, 1.0], 5)
        f = np.tile([10.0, 50.0, 100.0, 200.0, 400.0], 4)
        b = simulate_bode(1007.01, 0.48, 125.56, 81184.24, 7.625e-4, a, f)
        return {"gain": b.gain_db, "phase": b.phase_deg, "half_periods": b.half_periods.astype(float)}
    yield "spool_bode", bode


def record(path: Path) -> None:
    randoms = random_scenarios()
    out = {"scenarios.json": np.array(json.dumps(randoms))}   # compare replays exactly these
    for i, (name, fn) in enumerate(cases(randoms)):
        for k, v in fn().items():
            out[f"{name}|{k}"] = np.asarray(v)
        if i % 20 == 0:
            print(f"{i} {name}", file=sys.stderr)
    np.savez_compressed(path, **out)
    print(f"recorded {len({k.split('|')[0] for k in out}) - 1} cases -> {path}")


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        return np.inf
    scale = np.max(np.abs(a)) if a.size else 0.0
    d = np.max(np.abs(a - b)) if a.size else 0.0
    return float(d / scale) if scale > 0 else float(d)


def compare(path: Path, worst: int = 40, engine: str = "core") -> int:
    from hydrohil.simulation.loop import LOG_COLUMNS
    ref = np.load(path)
    rows = []
    for name, fn in cases(json.loads(str(ref["scenarios.json"])), engine):
        got = fn()
        for k, v in got.items():
            a, b = ref[f"{name}|{k}"], np.asarray(v)
            if k == "log":
                if a.shape != b.shape:
                    rows.append((name, "rows", np.inf, f"{a.shape[0]} vs {b.shape[0]} rows"))
                    continue
                cont = [_rel(a[:, j], b[:, j]) for j in range(11)]
                j = int(np.argmax(cont))
                modes = int(np.sum(np.any(a[:, 11:] != b[:, 11:], axis=1)))
                rows.append((name, LOG_COLUMNS[j], cont[j], f"{modes} samples with other modes/events"))
            else:
                rows.append((name, k, _rel(a, b), ""))
    rows.sort(key=lambda r: -r[2])
    bad = [r for r in rows if not r[2] <= TOL]
    print(f"{len(rows)} results compared; {len(bad)} above {TOL:g} relative")
    edges = [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3, np.inf]
    counts = np.histogram([min(r[2], 1e300) for r in rows], bins=edges)[0]
    print("  relative difference:  " + ",  ".join(
        f"{'0' if lo == 0 else f'<= {hi:g}' if hi < np.inf else f'> {lo:g}'}: {c}" if lo == 0 else
        (f"({lo:g}, {hi:g}]: {c}" if hi < np.inf else f"> {lo:g}: {c}")
        for lo, hi, c in zip(edges[:-1], edges[1:], counts)))
    for r in rows[:worst]:
        print(f"  {r[0]:<42} {r[1]:<8} {r[2]:.3g}  {r[3]}")
    return 0 if not bad else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=("record", "compare"))
    ap.add_argument("file", type=Path)
    ap.add_argument("--engine", choices=("core", "generated"), default="core",
                    help="compare: run_scenario's engine (record: always the core's)")
    a = ap.parse_args()
    if a.action == "record":
        record(a.file)
        return 0
    return compare(a.file, engine=a.engine)


if __name__ == "__main__":
    raise SystemExit(main())
