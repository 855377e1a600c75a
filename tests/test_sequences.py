"""Test sequences (hydrohil test): every expectation type passes and fails where it should (on signals
whose answer is known by construction), the examples pass / fail as documented, JUnit validates against
the Jenkins/Surefire schema, a lock-step run equals its offline run, an external C controller is tested the
same way, an INVALID real-time run is an error, bad input names the file and key, and the pytest fixture."""

import json
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest
from pydantic import TypeAdapter

from conftest import EXAMPLES, hh
from hydrohil.errors import InputError
from hydrohil.sequences.expectations import Expectation, Signals

SEQ = EXAMPLES / "sequences"


def signals(**cols):
    """Signals on t = 0..1 s at 1 ms: x_ref steps 0 -> 0.1 m at 0.2 s, xp follows a first-order lag (tau 50 ms)."""
    t = np.arange(1001) * 1e-3
    x_ref = np.where(t >= 0.2, 0.1, 0.0)
    xp = np.where(t >= 0.2, 0.1 * (1 - np.exp(-(t - 0.2) / 0.05)), 0.0)
    base = {"t": t, "x_ref": x_ref, "xp": xp, "error": x_ref - xp, "u": 50 * (x_ref - xp), "p1": np.full_like(t, 3e6),
            "p2": np.full_like(t, 2e6), "watchdog": np.zeros_like(t)}
    base.update(cols)
    base["p_max"] = np.maximum(base["p1"], base["p2"])
    return Signals(base, {"step": 0.2, "cut": 0.5})


def judge(table, s=None):
    return TypeAdapter(Expectation).validate_python(table).evaluate(s if s is not None else signals())


def test_bounds():
    assert judge({"type": "bounds", "signal": "xp", "min": 0.0, "max": 0.1}).passed
    o = judge({"type": "bounds", "signal": "p_max", "max": 2.9e6})      # p1 = 30 bar everywhere
    assert o.status == "fail" and o.plot["violation"][0] == 0.0 and "30 bar" in o.message
    o = judge({"type": "bounds", "signal": "xp", "min": 0.05, "after": "step", "until": 0.3})
    assert o.status == "fail" and o.plot["violation"][0] == pytest.approx(0.2)   # x = 0 at the step


def test_tracking():
    # |e| = 0.1 exp(-(t-0.2)/0.05) <= 1 mm from t = 0.2 + 0.05 ln(100) = 0.4303 s
    assert judge({"type": "tracking", "after": "step", "within": 0.231, "tol": 1e-3}).passed
    o = judge({"type": "tracking", "after": "step", "within": 0.229, "tol": 1e-3})
    assert o.status == "fail" and o.plot["violation"][0] == pytest.approx(0.429)


def test_step_response():
    # first-order lag: rise 10-90 % = tau ln 9 = 0.1099 s, no overshoot, 2 % settling = tau ln 50 = 0.1956 s
    # (the move starts at the last sample of the hold before it, 1 ms before the step)
    ok = judge({"type": "step_response", "after": "step", "max_rise_time": 0.111, "max_overshoot_pct": 0.1,
                "max_settling_time": 0.199})
    assert ok.passed, ok.message
    o = judge({"type": "step_response", "after": "step", "max_settling_time": 0.19})
    assert o.status == "fail" and o.measured == pytest.approx(0.1956 + 0.001, abs=1.5e-3), o.message
    xp = signals()["xp"] * np.where(np.arange(1001) >= 300, 1.05, 1.0)      # 5 % overshoot from 0.3 s on
    o = judge({"type": "step_response", "after": 0.2, "max_overshoot_pct": 4.0}, signals(xp=xp))
    assert o.status == "fail" and "overshoot 5" in o.message


def test_watchdog():
    assert judge({"type": "watchdog"}).passed
    w = np.where((np.arange(1001) >= 520) & (np.arange(1001) < 600), 1.0, 0.0)     # trips 20 ms after the cut
    u = np.where(w > 0, 0.0, 0.3)
    s = signals(watchdog=w, u=u)
    o = judge({"type": "watchdog"}, s)
    assert o.status == "fail" and o.measured == 1 and o.plot["violation"][0] == pytest.approx(0.52)
    assert judge({"type": "watchdog", "until": "cut"}, s).passed
    assert judge({"type": "watchdog", "after": "cut", "safe_within": 0.021}, s).passed
    o = judge({"type": "watchdog", "after": "cut", "safe_within": 0.019}, s)
    assert o.status == "fail" and "20.0 ms" in o.message
    s_hold = signals(watchdog=w, u=np.full(1001, 0.3))       # watchdog on but the valve not centred
    assert judge({"type": "watchdog", "after": "cut", "safe_within": 0.05}, s_hold).status == "fail"


def test_reaction():
    u = np.where(np.arange(1001) >= 215, -0.4, 0.3)        # reverses 15 ms after the step
    s = signals(u=u)
    assert judge({"type": "reaction", "after": "step", "within": 0.016, "reverses": True}, s).passed
    o = judge({"type": "reaction", "after": "step", "within": 0.014, "reverses": True}, s)
    assert o.status == "fail" and "15.0 ms" in o.message
    # the figure's two instants: the deadline (0.214 s) and the late reaction (0.215 s), named apart
    assert o.plot["deadline"] == pytest.approx(0.214) and o.plot["violation"][0] == pytest.approx(0.215)
    assert o.plot["violation_label"] == "u reacted (too late)" and "deadline_label" not in o.plot
    never = judge({"type": "reaction", "after": "step", "within": 0.014, "below": -0.9}, s)
    assert "violation" not in never.plot and never.plot["deadline_label"] == "deadline (u reacted: never)"
    p1 = np.where(np.arange(1001) >= 530, 1e6, 3e6)        # relieved 30 ms after the cut
    assert judge({"type": "reaction", "after": "cut", "within": 0.031, "signal": "p1", "below": 2e6}, signals(p1=p1)).passed
    assert not judge({"type": "reaction", "after": "cut", "within": 0.029, "signal": "p1", "below": 2e6},
                     signals(p1=p1)).passed


def test_predicate(tmp_path):
    from hydrohil.sequences.expectations import evaluate
    e = [TypeAdapter(Expectation).validate_python({"type": "predicate", "function": "x.py:f"})] * 3
    s = signals()
    out = evaluate(e, s, {0: lambda s: bool(s["xp"].max() <= 0.1), 1: lambda s: (False, "too slow"),
                          2: lambda s: 1 / 0})
    assert [o.status for o in out] == ["pass", "fail", "error"] and out[1].message == "too slow"
    assert "ZeroDivisionError" in out[2].message


def junit_schema(tmp_path_factory):
    """The Jenkins/Surefire JUnit schema (junit-10.xsd) as pytest's own tests use it, from pytest's sdist."""
    import xmlschema
    cache = Path.home() / ".cache" / "hydrohil" / "junit-10.xsd"
    if not cache.exists():
        d = tmp_path_factory.mktemp("xsd")
        r = subprocess.run([sys.executable, "-m", "pip", "download", f"pytest=={pytest.__version__}", "--no-deps",
                            "--no-binary", ":all:", "-d", d, "-q"], capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        with tarfile.open(next(Path(d).glob("pytest-*.tar.gz"))) as tf:
            m = next(m for m in tf.getmembers() if m.name.endswith("testing/example_scripts/junit-10.xsd"))
            cache.parent.mkdir(parents=True, exist_ok=True)
            cache.write_bytes(tf.extractfile(m).read())
    return xmlschema.XMLSchema(str(cache))


def test_examples_cli_report_and_junit(tmp_path, tmp_path_factory):
    out = tmp_path / "out"
    r = hh("test", SEQ / "fig11_p_passes.toml", SEQ / "p_hose_burst.toml", "--out", out, "--junit", out / "j.xml")
    assert r.returncode == 1, r.stdout + r.stderr                    # the hose burst exposes the P controller
    assert "PASS  Fig 11" in r.stdout and "FAIL  P control vs a rod-side hose burst: 1 passed, 3 failed" in r.stdout
    below = r.stdout.split("FAIL  P control vs a rod-side hose burst")[1].splitlines()[1:4]   # each failure: why
    assert len(below) == 3 and all(x.startswith("      fail: ") and len(x) > 40 for x in below), below
    junit_schema(tmp_path_factory).validate(str(out / "j.xml"))
    import xml.etree.ElementTree as ET
    root = ET.parse(out / "j.xml").getroot()
    assert (root.get("tests"), root.get("failures"), root.get("errors")) == ("9", "3", "0")
    report = (out / "report.md").read_text()
    figs = [line.split("](")[1].rstrip(")") for line in report.splitlines() if line.startswith("![")]
    assert len(figs) == 3 and all((out / f).stat().st_size > 10_000 for f in figs)
    assert "p1 = -0.99 bar" in report          # the cap side cavitates: the figure and the text say where
    assert hh("test", SEQ / "fig11_p_passes.toml", "--out", tmp_path / "ok").returncode == 0


def test_lockstep_equals_offline(tmp_path):
    from hydrohil.simulation.outputs import read_csv_columns
    from hydrohil.sequences.runner import run_sequence
    off = run_sequence(SEQ / "p_hose_burst.toml", tmp_path / "off")
    ls = run_sequence(SEQ / "p_hose_burst.toml", tmp_path / "ls", mode="lockstep")
    for c in ("t", "xp", "p1", "p2", "u", "watchdog", "faults", "x_meas", "p1_meas"):
        assert np.array_equal(off.signals[c], ls.signals[c]), c
    assert [(o.status, o.message) for o in off.outcomes] == [(o.status, o.message) for o in ls.outcomes]
    log = read_csv_columns(tmp_path / "ls" / "plant_log.csv")
    assert len(log["t"]) == 8001 and off.status == ls.status == "fail"


@pytest.mark.slow
def test_external_c_controller(tmp_path):
    """The protocol's C example controller (holds a constant reference) tested as any program would be."""
    exe = tmp_path / "p_controller"
    subprocess.run(["cc", "-O2", "-o", exe, EXAMPLES / "c_controller" / "p_controller.c", "-lz"], check=True)
    seq = tmp_path / "hold.toml"
    seq.write_text(f'scenario = "{EXAMPLES / "faults" / "hose_burst.toml"}"\nduration = 3.0\n'
                   '[[expect]]\ntype = "tracking"\nafter = 0.5\nuntil = 2.0\ntol = 1e-3\n'
                   '[[expect]]\ntype = "tracking"\nafter = 2.0\ntol = 1e-3\n')
    import tomllib
    x0 = tomllib.loads((EXAMPLES / "faults" / "hose_burst.toml").read_text())["initial"]["xp"]
    r = hh("test", seq, "--out", tmp_path / "out", "--controller", f"{exe} {{host}} {{port}} 50 {x0}")
    assert r.returncode == 1, r.stdout + r.stderr
    res = json.loads(next((tmp_path / "out").glob("*/result.json")).read_text())
    assert res["mode"] == "lockstep" and [e["status"] for e in res["expectations"]] == ["pass", "fail"]


def test_invalid_realtime_run_is_an_error(tmp_path, tmp_path_factory):
    seq = tmp_path / "rt.toml"      # a stall limit of 1 ns: no machine starts every step that exactly on time
    seq.write_text('scenario = "fig11_p_control"\nduration = 0.5\n[hil]\nmax_stall = 1e-9\n'
                   '[[expect]]\ntype = "bounds"\nsignal = "xp"\nmin = 0.0\n')
    seq.write_text(seq.read_text() + '[[expect]]\ntype = "bounds"\nsignal = "p1"\nmax = 2e7\n')
    r = hh("test", seq, "--mode", "realtime", "--out", tmp_path / "out", "--junit", tmp_path / "j.xml")
    assert r.returncode == 3, r.stdout + r.stderr
    # the terminal, report.md, result.json and the JUnit file say the same: 2 expectations not judged
    assert "ERROR" in r.stdout and "INVALID" in r.stdout and "0 passed, 0 failed, 2 errors" in r.stdout
    junit_schema(tmp_path_factory).validate(str(tmp_path / "j.xml"))
    junit = (tmp_path / "j.xml").read_text()
    assert '<error type="run" message="real-time run INVALID' in junit and 'errors="2"' in junit
    assert 'failures="0"' in junit
    report = (tmp_path / "out" / "report.md").read_text()
    assert "0 passed, 0 failed, 1 errors" in report and "| PASS |" not in report and report.count("| ERROR |") == 2
    res = json.loads(next((tmp_path / "out").glob("*/result.json")).read_text())
    assert res["status"] == "error" and [e["status"] for e in res["expectations"]] == ["error", "error"]


@pytest.mark.parametrize("text, key", [
    ('scenario = "fig11_p_control"\n[[actions]]\nat = 1\ntype = "hose_brust"\n[[expect]]\ntype = "watchdog"\n',
     "actions[0]"),
    ('scenario = "fig11_p_control"\n[[actions]]\nat = 1\ntype = "hose_burst"\nline = 3\nsection = 1\n'
     '[[expect]]\ntype = "watchdog"\n', "actions[0].line"),
    ('scenario = "fig11_p_control"\n[[expect]]\ntype = "tracking"\nafter = "burst"\ntol = 1e-3\n', "expect[0].after"),
    ('scenario = "fig11_p_control"\n[[expect]]\ntype = "bounds"\nsignal = "pp1"\nmax = 1\n', "expect.0"),
    ('scenario = "nope"\n[[expect]]\ntype = "watchdog"\n', "scenario"),
    ('scenario = "fig11_p_control"\n[[actions]]\nat = 9\ntype = "step"\nx = 0.1\n[[expect]]\ntype = "watchdog"\n',
     "actions[0].at"),
    ('scenario = "fig11_p_control"\n', "expect"),
])
def test_bad_input_names_file_and_key(tmp_path, text, key):
    from hydrohil.sequences.runner import run_sequence
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(InputError) as ei:
        run_sequence(p, tmp_path / "out")
    assert str(p) in str(ei.value) and key in str(ei.value), str(ei.value)
    r = hh("test", p, "--out", tmp_path / "o2")
    assert r.returncode == 2 and str(p) in r.stderr


def test_pytest_plugin(pytester):
    pytester.makepyfile('''
        def test_supply_drop(rig):
            run = rig.run("fig11_p_control", duration=3.0,
                          actions=[{"name": "drop", "at": 2.0, "until": 2.5, "type": "supply_pressure", "ps": 4e6}],
                          expect=[{"type": "bounds", "signal": "p_max", "max": 7e6}])
            run.assert_passed()
            run.check({"type": "tracking", "after": 1.5, "within": 0.2, "until": 2.0, "tol": 1e-3})
            assert run.metrics()["moves"][0]["overshoot_pct"] < 1.0

        def test_a_failing_expectation(rig):
            run = rig.run("fig11_p_control", duration=2.0)
            run.check({"type": "tracking", "tol": 1e-4})
    ''')
    res = pytester.runpytest("-q", "-p", "no:cacheprovider")
    res.assert_outcomes(passed=1, failed=1)
    res.stdout.fnmatch_lines(["*AssertionError: *|x_ref − xp| ≤ 0.1 mm*|error| = * mm at t = *"])
