"""`hydrohil demo`, the main job: the paper's closed-loop experiments as HIL runs with a report."""

import json

import pytest

from conftest import EXAMPLES, hh
from hydrohil.hil.demo import run_demo


def test_demo_report_of_a_short_run(tmp_path):
    """The demo's report on a 1 s Fig 11 run in lock-step: the verdict banner, the timing and comparison
    tables filled from the run (lock-step HIL equals the offline simulation), its figure."""
    scen = tmp_path / "fig11_1s.toml"
    text = (EXAMPLES / "fig11_p_control.toml").read_text()
    assert "duration = 6.0" in text
    scen.write_text(text.replace("duration = 6.0", "duration = 1.0"))
    res = run_demo(tmp_path / "demo", lockstep=True, experiments=[("short", scen, "Fig 11 for 1 s")])
    assert list(res) == ["short"]
    t, c = res["short"]["timing"], res["short"]["comparison"]
    assert t["steps"] == 2000 and t["verdict"]["valid"]
    assert c["xp_rms_mm"] == 0.0 and c["steps_compared"] == 2001
    md = (tmp_path / "demo" / "report.md").read_text()
    assert "> **VALID** — every run met the real-time criteria (short)" in md
    assert "| verdict | VALID |" in md and "| steps | 2000 |" in md and "| xp_rms_mm | 0 |" in md
    assert "Mode: lock-step" in md and "![short](short/report.png)" in md
    assert (tmp_path / "demo" / "short" / "report.png").stat().st_size > 20_000
    assert json.loads((tmp_path / "demo" / "results.json").read_text())["short"]["timing"]["steps"] == 2000


@pytest.mark.slow
def test_demo_command_runs_both_experiments(tmp_path):
    """`hydrohil demo --lockstep` as a user runs it (lock-step: the same report on a loaded machine): Fig 11
    and Fig 12, each 12 000 steps equal to the offline simulation, exit 0 and one line per experiment."""
    r = hh("demo", "--out", tmp_path / "demo", "--lockstep", timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("12000 steps") == 2 and "fig11:" in r.stdout and "fig12:" in r.stdout
    res = json.loads((tmp_path / "demo" / "results.json").read_text())
    assert list(res) == ["fig11", "fig12"]
    for name in res:
        assert res[name]["timing"]["verdict"]["valid"] and res[name]["comparison"]["xp_rms_mm"] < 1e-9
        assert (tmp_path / "demo" / name / "report.png").stat().st_size > 20_000
