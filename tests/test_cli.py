"""The CLI as a user runs it: real processes, real files, exit codes."""

import csv
import json

import pytest

from conftest import EXAMPLES, hh


def test_simulate_writes_log_summary_plot(tmp_path):
    r = hh("simulate", EXAMPLES / "fig11_p_control.toml", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(tmp_path / "log.csv")))
    assert len(rows) == 12001
    for col in ("t", "u", "xs", "p1", "p2", "xp", "vp", "ff", "travel_mode", "friction_mode"):
        assert col in rows[0]
    assert {r["travel_mode"] for r in rows} <= {"free", "at_retract_stop", "at_extend_stop"}
    s = json.loads((tmp_path / "summary.json").read_text())
    for key in ("final_state", "max_abs_p1", "steps", "wall_time_s", "realtime_factor", "solver", "step"):
        assert key in s
    assert s["steps"] == 12000 and s["solver"] == "rk3" and s["realtime_factor"] > 50
    assert (tmp_path / "simulation.png").stat().st_size > 10000


def test_solver_and_step_override(tmp_path):
    r = hh("simulate", EXAMPLES / "sine_open_loop.toml", "--out", tmp_path, "--solver", "rk4", "--step", "2.5e-4")
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["solver"] == "rk4" and s["step"] == 2.5e-4 and s["steps"] == 16000


def test_bad_scenario_exit_2_names_key(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('duration = 1.0\n[initial]\nxp = 0.05\n[input]\ntype = "sine"\namplitude = 2.0\nfrequency = 1.0\n')
    r = hh("simulate", f, "--out", tmp_path / "o")
    assert r.returncode == 2
    assert str(f) in r.stderr and "input" in r.stderr
    assert not (tmp_path / "o" / "log.csv").exists()


def test_bad_override_exit_2(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('duration = 1.0\n[overrides]\n"supply.ps" = 70\n[initial]\nxp = 0.05\n'
                 '[input]\ntype = "sine"\namplitude = 0.1\nfrequency = 1.0\n')
    r = hh("simulate", f, "--out", tmp_path / "o")
    assert r.returncode == 2 and "overrides.supply.ps" in r.stderr and "Pa" in r.stderr


def test_divergence_exit_1_with_time_mode_state(tmp_path):
    # a 1 kg load with explicit Euler at 5 ms is far outside the stable region: it must stop cleanly
    f = tmp_path / "light.toml"
    f.write_text((EXAMPLES / "sine_open_loop.toml").read_text().replace(
        '"load.gravity_direction" = 0', '"load.gravity_direction" = 0\n"load.mass" = 1.0'))
    r = hh("simulate", f, "--out", tmp_path, "--solver", "euler", "--step", "0.005")
    assert r.returncode == 1
    assert "diverged at t =" in r.stderr and "travel=" in r.stderr and "p1=" in r.stderr


def test_two_processes_give_identical_logs(tmp_path):
    # the C core is compiled once at install with IEEE-strict arithmetic (no FMA contraction): every run
    # of a scenario gives the same bits
    for run in ("a", "b"):
        r = hh("simulate", EXAMPLES / "fig11_p_control.toml", "--out", tmp_path / run, "--no-plot")
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "a" / "log.csv").read_bytes() == (tmp_path / "b" / "log.csv").read_bytes()


def test_params_show_and_missing_file(tmp_path):
    r = hh("params", "show", "ferreira2004")
    assert r.returncode == 0 and "sigma0" in r.stdout
    r = hh("params", "show", tmp_path / "nope.toml")
    assert r.returncode == 2 and "file not found" in r.stderr


@pytest.mark.slow
def test_maxstep_hybrid_vs_continuous(tmp_path):
    src = (EXAMPLES / "maxstep_endstop.toml").read_text().replace("duration = 0.25", "duration = 0.2")
    f = tmp_path / "m.toml"
    f.write_text(src)
    hyb = json.loads(hh("maxstep", f, "--model", "hybrid").stdout)
    cont = json.loads(hh("maxstep", f, "--model", "continuous").stdout)
    assert hyb["max_stable_step"] >= 5e-4
    assert cont["max_stable_step"] < 1e-5
    assert hyb["max_stable_step"] / cont["max_stable_step"] >= 100


def test_help_keeps_bracketed_units():
    # rich markup used to swallow "[s]", "[hil]", "[s:m]", "[1/m]", "[m]" as style tags (issue #12)
    expected = {"plant": ("[s]", "[hil]"), "controller": ("[hil]", "[s:m]", "[1/m]"), "hil": ("[hil]",),
                "simulate": ("[s]",), "maxstep": ("[s]", "[m]", "[Pa]"), "bench": ("[s]",)}
    for cmd, texts in expected.items():
        r = hh(cmd, "--help")
        assert r.returncode == 0, r.stderr
        help_text = " ".join(r.stdout.split())          # undo the line wrapping
        for text in texts:
            assert text in help_text, f"`hydrohil {cmd} --help` lost {text}:\n{r.stdout}"


def test_version():
    from importlib.metadata import version
    r = hh("--version")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == f"hydrohil {version('hydrohil')}"


def test_simulate_no_plot_reports_only_files_written(tmp_path):
    r = hh("simulate", EXAMPLES / "sine_open_loop.toml", "--out", tmp_path, "--no-plot")
    assert r.returncode == 0, r.stderr
    assert not (tmp_path / "simulation.png").exists()
    assert "simulation.png" not in r.stdout
    assert "log.csv" in r.stdout and "summary.json" in r.stdout
    assert (tmp_path / "log.csv").exists() and (tmp_path / "summary.json").exists()


# ---- parameters on the command line (--params / --set) ----------------------------------------------

def _log(path):
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


@pytest.mark.slow
def test_set_and_params_on_simulate_equal_the_same_values_in_files(tmp_path):
    # three routes to a 200 kg load must give the same run, bit for bit: --set, --params FILE (a copy of
    # the paper's set with the mass changed), and the scenario's own [overrides] written by hand
    scen = EXAMPLES / "fig11_p_control.toml"
    r = hh("simulate", scen, "--out", tmp_path / "set", "--no-plot", "--set", "load.mass=200")
    assert r.returncode == 0, r.stderr
    text = hh("params", "show", "ferreira2004").stdout
    assert "mass = 80.0" in text
    (tmp_path / "heavy.toml").write_text(text.replace("mass = 80.0", "mass = 200.0"))
    r = hh("simulate", scen, "--out", tmp_path / "file", "--no-plot", "--params", "heavy.toml", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    body = scen.read_text()
    assert "[overrides]" not in body
    (tmp_path / "own.toml").write_text(body + '\n[overrides]\n"load.mass" = 200.0\n')
    r = hh("simulate", tmp_path / "own.toml", "--out", tmp_path / "own", "--no-plot")
    assert r.returncode == 0, r.stderr
    logs = [_log(tmp_path / d / "log.csv") for d in ("set", "file", "own")]
    assert logs[0] == logs[1] == logs[2]
    assert logs[0] != _log_default(tmp_path, scen)                       # and the mass did change the run
    assert json.loads((tmp_path / "set" / "summary.json").read_text())["overrides"] == {"load.mass": 200}


def _log_default(tmp_path, scen):
    r = hh("simulate", scen, "--out", tmp_path / "default", "--no-plot")
    assert r.returncode == 0, r.stderr
    return _log(tmp_path / "default" / "log.csv")


@pytest.mark.parametrize("args, message", [
    (["--set", "load.mas=3"], "--set: load.mas: unknown parameter 'load.mas' (did you mean 'load.mass'?)"),
    (["--set", "load.mass=-2"], "--set: load.mass: must be > 0 [kg], got -2"),
    (["--set", "load.mass"], "--set: load.mass: expected key=value"),
    (["--params", "nope.toml"], "--params: "),
])
def test_bad_command_line_parameters_exit_2(tmp_path, args, message):
    r = hh("simulate", EXAMPLES / "fig11_p_control.toml", "--out", tmp_path, *args)
    assert r.returncode == 2 and message in r.stderr, r.stderr
    assert not (tmp_path / "log.csv").exists()


@pytest.mark.slow
def test_hil_records_the_scenario_as_run_and_matches_offline_with_the_same_set(tmp_path):
    scen = tmp_path / "short.toml"
    scen.write_text((EXAMPLES / "fig11_p_control.toml").read_text().replace("duration = 6.0", "duration = 1.0"))
    r = hh("hil", scen, "--out", tmp_path / "hil", "--lockstep", "--set", "load.mass=200", "--set", "supply.ps=9e6")
    assert r.returncode == 0, r.stderr
    ran = (tmp_path / "hil" / "scenario.toml").read_text()
    assert '"load.mass" = 200' in ran and '"supply.ps" = 9000000.0' in ran
    assert json.loads((tmp_path / "hil" / "comparison.json").read_text())["xp_max_mm"] == 0.0
    off = hh("simulate", scen, "--out", tmp_path / "off", "--no-plot", "--set", "load.mass=200", "--set",
             "supply.ps=9e6")
    assert off.returncode == 0, off.stderr
    hil = {row[0]: row for row in _log(tmp_path / "hil" / "plant_log.csv")[1:]}
    rows = _log(tmp_path / "off" / "log.csv")
    ix = rows[0].index("xp")
    assert all(hil[str(k)][12] == row[ix] for k, row in enumerate(rows[1:]))   # plant_log column 12 is xp


def test_maxstep_and_linear_take_parameters(tmp_path):
    a = json.loads(hh("linear", "--json").stdout)["operating_point"]
    b = json.loads(hh("linear", "--json", "--set", "supply.ps=1.2e7").stdout)["operating_point"]
    assert b["p1"] > a["p1"] * 1.5 and b["ps"] == 1.2e7       # the equilibrium pressures scale with the supply
    r = hh("maxstep", EXAMPLES / "maxstep_endstop.toml", "--duration", "0.3", "--set", "load.mass=-1")
    assert r.returncode == 2 and "--set: load.mass: must be > 0" in r.stderr
