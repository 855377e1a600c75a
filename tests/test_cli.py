"""The CLI as a user runs it: real processes, real files, exit codes."""

import csv
import json


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
