"""Sweeps and Monte Carlo on Dask (hydrohil sweep): sampling checked against scipy's distributions, a real
`dask scheduler` with two `dask worker` processes on loopback where one worker is killed mid-study (exactly
one row per run, equal to a LocalCluster's), resume after an interrupted study, bad runs as rows, sequence
studies with verdicts, and --rerun reproducing a row."""

import json
import os
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from conftest import EXAMPLES, hh
from hydrohil.errors import InputError
from hydrohil.studies.engine import run_study
from hydrohil.studies.report import load_table
from hydrohil.studies.study import load_study

MC_EXAMPLE = EXAMPLES / "studies" / "fig11_monte_carlo.toml"


@pytest.fixture
def mc60(tmp_path):
    """The Monte Carlo example with 60 runs (the example itself has 1000: benchmarks/sweep.py)."""
    p = tmp_path / "mc60.toml"
    text = MC_EXAMPLE.read_text().replace("samples = 1000", "samples = 60")
    assert text != MC_EXAMPLE.read_text()
    p.write_text(text.replace('scenario = "../fig11_p_control.toml"', f'scenario = "{EXAMPLES / "fig11_p_control.toml"}"'))
    return p


def write_study(tmp_path, body, name="study.toml"):
    p = tmp_path / name
    p.write_text(f'scenario = "{EXAMPLES / "fig11_p_control.toml"}"\n' + body)
    return p


def test_sampling_against_scipy(tmp_path):
    p = write_study(tmp_path, 'samples = 4000\nseed = 7\n'
                    '[[vary]]\nname = "load.mass"\ndist = "uniform"\nrel = 0.2\n'
                    '[[vary]]\nname = "supply.ps"\ndist = "truncnormal"\nstd = 5e5\nlow = 6.5e6\nhigh = 8e6\n'
                    '[[vary]]\nname = "controller.kp"\ndist = "choice"\nvalues = [30.0, 50.0]\nweights = [1, 3]\n'
                    '[[vary]]\nname = "initial.xp"\ndist = "grid"\nstart = 0.03\nstop = 0.05\nnum = 2\n')
    st = load_study(p)
    runs = st.runs()
    assert len(runs) == 8000 and runs == load_study(p).runs()           # grid x samples, reproducible
    m = np.array([r["inputs"]["load.mass"] for r in runs])
    assert stats.kstest(m, stats.uniform(64.0, 32.0).cdf).pvalue > 1e-3    # 80 kg ± 20 %
    ps = np.array([r["inputs"]["supply.ps"] for r in runs])
    a, b = (6.5e6 - 7e6) / 5e5, (8e6 - 7e6) / 5e5
    assert stats.kstest(ps, stats.truncnorm(a, b, 7e6, 5e5).cdf).pvalue > 1e-3
    kp = np.array([r["inputs"]["controller.kp"] for r in runs])
    assert abs(np.mean(kp == 50.0) - 0.75) < 0.02
    assert sorted({r["inputs"]["initial.xp"] for r in runs}) == [0.03, 0.05]


DASK = Path(os.sys.executable).parent / "dask"      # the venv's dask command


def _scheduler(tmp_path):
    sf = tmp_path / "scheduler.json"
    sched = subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                              "--scheduler-file", sf], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return sched, sf


def _wait_file(path, proc, timeout=120):
    import time
    end = time.monotonic() + timeout
    while not (path.exists() and path.stat().st_size > 0):
        assert proc.poll() is None and time.monotonic() < end, "dask scheduler did not start"
        time.sleep(0.05)       # polling a file the scheduler writes once it listens (its handshake)
    return json.loads(path.read_text())["address"]


@pytest.mark.slow
def test_external_cluster_survives_a_killed_worker(tmp_path, mc60):
    from distributed import Client
    bin_dir = Path(os.sys.executable).parent
    env = {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}"}
    sched, sf = _scheduler(tmp_path)
    workers = []
    try:
        address = _wait_file(sf, sched)
        for name in ("w1", "w2"):
            workers.append(subprocess.Popen([DASK, "worker", address, "--nthreads", "1", "--no-nanny",
                                             "--no-dashboard", "--name", name], env=env,
                                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        client = Client(address, timeout="60s")
        client.wait_for_workers(2, timeout=120)
        killed = []

        def kill_w1(row):
            # kill w1 (SIGKILL: no goodbye) once 10 rows are in and w1 has run one: its runs in flight go to w2
            rows.append(row)
            if not killed and len(rows) >= 10 and any(r["worker"] == "w1" for r in rows):
                workers[0].send_signal(signal.SIGKILL)
                killed.append(len(rows))
        rows = []
        out = tmp_path / "ext"
        r = run_study(mc60, out, client=client, progress=False, on_row=kill_w1)
        client.close()
        assert killed and killed[0] < 60
        t = load_table(r.table)
        assert len(t["run_id"]) == 60 and len(set(t["run_id"])) == 60 and (t["status"] == "ok").all()
        assert set(t["worker"]) == {"w1", "w2"} and (t["worker"][-10:] == "w2").any()
        assert r.summary["runs"] == 60
    finally:
        for p in [*workers, sched]:
            p.kill()
            p.wait()
    local = run_study(mc60, tmp_path / "local", workers=2, progress=False)       # a LocalCluster: same runs, same numbers
    tl = load_table(local.table)
    for c in t:
        if c not in ("wall_s", "worker"):
            assert np.array_equal(t[c], tl[c]), c


@pytest.mark.slow
def test_resume_after_interruption(tmp_path):
    p = write_study(tmp_path, 'samples = 24\nseed = 3\n[[vary]]\nname = "load.mass"\ndist = "uniform"\nrel = 0.2\n')

    class Stop(Exception):
        pass
    seen = []

    def stop_after_8(row):
        seen.append(row["run_id"])
        if len(seen) == 8:
            raise Stop
    with pytest.raises(Stop):
        run_study(p, tmp_path / "out", workers=2, progress=False, on_row=stop_after_8)
    r = run_study(p, tmp_path / "out", workers=2, progress=False)
    assert r.skipped == 8 and r.ran == 16
    t = load_table(r.table)
    assert list(t["run_id"]) == [f"r{i:06d}" for i in range(24)]
    assert not list((tmp_path / "out" / "results").glob("*.parquet"))       # parts merged into one table
    changed = write_study(tmp_path, 'samples = 25\nseed = 3\n[[vary]]\nname = "load.mass"\ndist = "uniform"\nrel = 0.2\n')
    res = hh("sweep", changed, "--out", tmp_path / "out", "--no-progress")
    assert res.returncode == 2 and "another study" in res.stderr


@pytest.mark.slow
def test_bad_runs_are_rows_and_sequence_verdicts(tmp_path):
    p = write_study(tmp_path, 'samples = 6\nseed = 1\n[[vary]]\nname = "load.mass"\ndist = "normal"\nmean = 10\n'
                    'std = 40\n')
    r = run_study(p, tmp_path / "bad", workers=1, progress=False)
    t = load_table(r.table)
    neg = np.array([m <= 0 for m in t["in.load.mass"]])
    assert neg.any() and (~neg).any()            # this seed draws both (checked below, row by row)
    assert list(t["status"][neg]) == ["input_error"] * int(neg.sum()) and (t["status"][~neg] == "ok").all()
    assert all("load.mass" in e for e in t["error"][neg])
    seq = tmp_path / "seq.toml"
    seq.write_text(f'sequence = "{EXAMPLES / "sequences" / "p_hose_burst.toml"}"\n'
                   '[[vary]]\nname = "controller.kp"\ndist = "grid"\nvalues = [50.0, 400.0]\n')
    r = run_study(seq, tmp_path / "seq", workers=1, progress=False)
    t = load_table(r.table)
    assert list(t["in.controller.kp"]) == [50.0, 400.0] and list(t["verdict"]) == ["fail", "fail"]
    assert list(t["expect.0"]) == ["fail", "pass"]     # a stiffer P controller keeps the sag below 2 mm


@pytest.mark.slow
def test_cli_report_figures_and_rerun(tmp_path):
    p = write_study(tmp_path, 'samples = 12\nseed = 5\n[criterion]\nmetric = "max_hold_error"\nmax = 2.2e-4\n'
                    '[[vary]]\nname = "load.mass"\ndist = "uniform"\nrel = 0.2\n'
                    '[[vary]]\nname = "friction"\ndist = "uniform"\nlow = 0.7\nhigh = 1.3\n'
                    'scale = ["friction.positive.fc", "friction.negative.fc"]\n')
    out = tmp_path / "out"
    r = hh("sweep", p, "--out", out, "--workers", "2", "--no-progress")
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    t = load_table(out / "results.parquet")
    assert s["failed"] == int((t["max_hold_error"] > 2.2e-4).sum())
    for f in ("scatter.png", "pass_fail_map.png", "histograms.png"):
        assert (out / "figures" / f).stat().st_size > 10_000
    worst = s["worst"][0]["run_id"]
    assert hh("sweep", p, "--out", out, "--rerun", worst).returncode == 0
    # the rerun file, simulated by hand, gives the row's metric (an independent path: hydrohil simulate)
    assert hh("simulate", out / "rerun" / f"{worst}.toml", "--out", tmp_path / "sim", "--no-plot").returncode == 0
    from hydrohil.simulation.outputs import read_csv_columns
    from hydrohil.studies.runs import hold_error
    from hydrohil.simulation.scenario import load_scenario
    log = read_csv_columns(tmp_path / "sim" / "log.csv")
    ref = load_scenario(out / "rerun" / f"{worst}.toml").scenario.reference.sample(log["t"])[0]
    i = list(t["run_id"]).index(worst)
    assert hold_error(log["t"], log["xp"], ref) == pytest.approx(t["max_hold_error"][i], rel=1e-9)


def test_per_run_logs(tmp_path):
    p = write_study(tmp_path, 'samples = 2\nseed = 9\nlogs = true\n'
                    '[[vary]]\nname = "load.mass"\ndist = "uniform"\nrel = 0.2\n')
    r = run_study(p, tmp_path / "out", workers=1, progress=False)
    t = load_table(r.table)
    import pyarrow.parquet as pq
    from hydrohil.studies.runs import hold_error
    for i, run_id in enumerate(t["run_id"]):
        log = pq.read_table(tmp_path / "out" / "runs" / f"{run_id}.parquet").to_pydict()
        assert len(log["t"]) == 12001 and log["t"][-1] == pytest.approx(6.0)
        xp, ref = np.asarray(log["xp"]), np.asarray(log["x_ref"])
        assert hold_error(np.asarray(log["t"]), xp, ref) == t["max_hold_error"][i]


def test_report_with_a_metric_no_input_moves(tmp_path):
    """The pressure transducers' noise moves nothing in a position loop (the controller reads the encoder):
    every metric's histogram is one bin, the report is still written (matplotlib refused 40 bins over a
    3e-9 range)."""
    p = write_study(tmp_path, 'samples = 3\nseed = 5\n[[vary]]\nname = "sensors.pressure_noise"\n'
                    'dist = "uniform"\nlow = 0.0\nhigh = 5e3\n')
    r = run_study(p, tmp_path / "out", workers=1, progress=False)
    t = load_table(r.table)
    assert np.ptp(t["in.sensors.pressure_noise"]) > 100.0
    assert all(np.ptp(t[m]) == 0.0 for m in ("max_p1", "max_hold_error", "rms_error", "breakaways"))
    assert (tmp_path / "out" / "figures" / "histograms.png").stat().st_size > 10_000
    assert "Failed: **0 of 3**" in (tmp_path / "out" / "report.md").read_text()


def test_controllers_as_scenario_choice(tmp_path):
    """Whole controllers compared: the example controller files (full scenarios) as a grid over 'scenario'."""
    ctl = EXAMPLES / "controllers"
    p = write_study(tmp_path, f'[[vary]]\nname = "scenario"\ndist = "grid"\n'
                    f'values = ["{ctl / "fig11_pi.toml"}", "{EXAMPLES / "fig11_p_control.toml"}"]\n')
    r = run_study(p, tmp_path / "out", workers=1, progress=False)
    t = load_table(r.table)
    assert [Path(v).name for v in t["in.scenario"]] == ["fig11_pi.toml", "fig11_p_control.toml"]
    # the integral removes the P controller's settled error (README, Controllers): at least 5 times smaller
    assert t["max_hold_error"][0] * 5 < t["max_hold_error"][1]


@pytest.mark.slow
def test_criterion_checked_when_read_and_judged_again_when_changed(tmp_path):
    """Issue #25 §4: a misspelt metric is refused before any run (exit 2, the valid metrics named, nothing
    written); a finished study whose criterion alone changed judges its stored runs again (no run repeated)."""
    body = 'samples = 6\nseed = 5\n[[vary]]\nname = "load.mass"\ndist = "uniform"\nrel = 0.2\n'
    bad = write_study(tmp_path, body + '[criterion]\nmetric = "max_hold_eror"\nmax = 2e-4\n')
    r = hh("sweep", bad, "--out", tmp_path / "bad", "--no-progress")
    assert r.returncode == 2 and "criterion.metric" in r.stderr and "unknown metric 'max_hold_eror'" in r.stderr
    assert "max_hold_error [m]" in r.stderr and "breakaways" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "bad" / "results.parquet").exists()
    p = write_study(tmp_path, body + '[criterion]\nmetric = "max_hold_error"\nmax = 1.0\n')
    out = tmp_path / "out"
    assert hh("sweep", p, "--out", out, "--workers", "1", "--no-progress").returncode == 0
    assert json.loads((out / "summary.json").read_text())["failed"] == 0
    t = load_table(out / "results.parquet")
    p = write_study(tmp_path, body + '[criterion]\nmetric = "max_hold_error"\nmax = 0.0\n')   # every run fails now
    r = hh("sweep", p, "--out", out, "--no-progress")
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["failed"] == 6 and s["ran_this_time"] == 0 and s["criterion"] == {"metric": "max_hold_error", "max": 0.0}
    assert "Failed: **6 of 6**" in (out / "report.md").read_text()
    assert np.array_equal(load_table(out / "results.parquet")["max_hold_error"], t["max_hold_error"])


def test_study_figures_label_inputs_with_units(tmp_path):
    """Issue #25 §5: the scatter and pass/fail axes had bare names; each input now reads in its unit as
    people read it (Pa in bar, m in mm), a factor on several entries as '× nominal'."""
    from hydrohil.studies.report import input_axis
    from hydrohil.studies.study import load_study
    p = write_study(tmp_path, 'samples = 2\nseed = 1\n'
                    '[[vary]]\nname = "supply.ps"\ndist = "uniform"\nrel = 0.1\n'
                    '[[vary]]\nname = "friction"\ndist = "uniform"\nlow = 0.7\nhigh = 1.3\n'
                    'scale = ["friction.positive.fc"]\n'
                    '[[vary]]\nname = "initial.xp"\ndist = "uniform"\nlow = 0.02\nhigh = 0.04\n'
                    '[[vary]]\nname = "controller.kp"\ndist = "grid"\nvalues = [40.0, 60.0]\n')
    st = load_study(p)
    assert input_axis(st, "supply.ps") == (1e-5, "supply.ps [bar]")
    assert input_axis(st, "friction") == (1.0, "friction [× nominal]")
    assert input_axis(st, "initial.xp") == (1e3, "initial.xp [mm]")
    assert input_axis(st, "controller.kp") == (1.0, "controller.kp [1/m]")
    assert input_axis(st, "load.mass") == (1.0, "load.mass [kg]")


def test_a_circuit_study_varies_component_values_and_its_rows_are_the_runs(tmp_path):
    """examples/studies/servo_supply_monte_carlo.toml (8 runs) on a LocalCluster of 2 workers: inputs named
    component.key, each row's metrics those of the circuit run with its values, computed here directly
    (simulate_circuit with the row's --set values, the hold error over the reference's holds)."""
    from hydrohil.circuits.circuit import CIRCUITS_DIR
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.metrics import holds
    src = EXAMPLES / "studies" / "servo_supply_monte_carlo.toml"
    p = tmp_path / "mc8.toml"
    p.write_text(src.read_text().replace("samples = 200", "samples = 8").replace(
        'scenario = "../circuits/servo_supply/scenario.toml"',
        f'scenario = "{CIRCUITS_DIR / "servo_supply" / "scenario.toml"}"'))
    r = run_study(p, tmp_path / "out", workers=2, progress=False)
    rows = load_table(tmp_path / "out" / "results.parquet")
    assert sorted(rows["run_id"]) == [f"r{i:06d}" for i in range(8)] and set(rows["status"]) == {"ok"}
    names = ("accumulator.precharge", "accumulator.gas_volume", "pump.speed", "cyl.mass")
    for i in (0, 5):
        sets = {n: rows[f"in.{n}"][i] for n in names}
        cs = load_circuit_scenario(CIRCUITS_DIR / "servo_supply" / "scenario.toml", sets=sets)
        res = simulate_circuit(cs.circuit, cs.duration, loop=cs.loop)
        t, x, ref = res.column("t"), res.column("cyl.x"), res.column("cyl.x.reference")
        worst = max(float(np.max(np.abs(ref[a + (b - a) // 2:b + 1] - x[a + (b - a) // 2:b + 1])))
                    for a, b in holds(t, ref))
        assert rows["max_hold_error"][i] == worst
        peak = max(float(np.max(res.column(f"{n}.p"))) for n in cs.circuit.nodes)
        assert rows["max_p1"][i] == peak
    assert r.runs == 8 and r.summary["status"]["ok"] == 8 and r.summary["criterion"]["metric"] == "max_hold_error"
    bad = tmp_path / "bad.toml"
    bad.write_text(p.read_text().replace('name = "cyl.mass"', 'name = "cyl.masss"'))
    with pytest.raises(InputError, match="no such value .*'cyl.masss'") as e:
        load_study(bad)
    assert e.value.key == "vary[3]"


def test_a_paper_study_runs_on_the_generated_code_with_the_cores_rows(mc60, monkeypatch):
    """A study of a paper scenario runs each run on the code generated from its circuit (runs.ENGINE): its rows
    (every metric, the status) are the core's, run by run (12 runs of the Fig 11 Monte Carlo: mass, supply,
    friction and valve leakage drawn; executed in this process, as a worker does)."""
    import hydrohil.studies.runs as runs
    study = load_study(mc60)
    base = {"study": str(study.source.resolve()), "digest": study.digest(), "logs": None}
    assert runs.ENGINE == "generated"
    generated = [runs.execute({**r, **base}) for r in study.runs()[:12]]
    monkeypatch.setattr(runs, "ENGINE", "core")
    core = [runs.execute({**r, **base}) for r in study.runs()[:12]]
    skip = ("wall_s", "worker")
    assert all(g["status"] == "ok" for g in generated)
    assert [{k: v for k, v in g.items() if k not in skip} for g in generated] == \
        [{k: v for k, v in c.items() if k not in skip} for c in core]
    assert len({g["max_hold_error"] for g in generated}) == 12          # (12 different rigs)
    assert runs.keep_freed_memory() is True                             # (glibc: this machine's C library)


def test_a_paper_studys_run_read_in_memory_is_its_file_run(mc60, tmp_path):
    """A worker reads a paper run's table in memory (nothing written): each row's metrics are those of the run's
    table written to a TOML file, loaded and simulated as `hydrohil simulate` would (3 runs, bit for bit)."""
    import tomli_w

    import hydrohil.studies.runs as runs
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    study = load_study(mc60)
    base = {"study": str(study.source.resolve()), "digest": study.digest(), "logs": None}
    for r in study.runs()[:3]:
        row = runs.execute({**r, **base})
        data, kind, _ = runs.run_data(study, r["inputs"])
        assert kind == "scenario" and row["status"] == "ok"
        path = tmp_path / f"{r['run_id']}.toml"
        path.write_text(tomli_w.dumps(data))
        sc = load_scenario(path)
        res = run_scenario(sc)
        t = res.column("t")
        want = runs.metrics_of(t, res.column("xp"), sc.scenario.reference.sample(t)[0], res.column("p1"),
                               res.column("p2"), res.column("friction_mode"))
        assert {k: row[k] for k in want} == want


def test_runs_go_to_the_workers_in_small_batches():
    from hydrohil.studies.engine import BATCH_MAX, batch_size
    assert batch_size(1000, 2) == BATCH_MAX == 8             # (a big study: 8 runs a task)
    assert batch_size(60, 2) == 7                            # (every worker gets about four tasks)
    assert batch_size(3, 4) == 1 and batch_size(0, 1) == 1
