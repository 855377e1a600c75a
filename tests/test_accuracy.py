"""Hybrid model (RK3, 0.5 ms) against the continuous stiff reference (LSODA), issue #2 limits."""

import pytest

from conftest import EXAMPLES, rms
from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import load_scenario

CASES = ["sine_open_loop.toml", "fig11_p_control.toml", "fig12_steps_ramps.toml", "end_stops_p_control.toml",
         "maxstep_endstop.toml"]


@pytest.mark.parametrize("name", CASES)
def test_hybrid_rk3_matches_reference(name):
    hyb = run_scenario(load_scenario(EXAMPLES / name))
    ref = run_scenario(load_scenario(EXAMPLES / name, solver="reference"))
    assert hyb.diverged is None and ref.diverged is None
    ex = hyb.column("xp") - ref.column("xp")
    assert rms(ex) <= 0.5e-3
    assert abs(ex).max() <= 2e-3
    assert rms(hyb.column("p1") - ref.column("p1")) <= 3e5
    assert rms(hyb.column("p2") - ref.column("p2")) <= 3e5


def test_kp50_at_120_bar_and_kp100_at_70_bar():
    for over, kp in (({"supply.ps": 1.2e7}, 50.0), ({"supply.ps": 7e6}, 100.0)):
        import tomllib
        data = tomllib.loads((EXAMPLES / "fig11_p_control.toml").read_text())
        data["overrides"] = over
        data["controller"]["kp"] = kp
        from hydrohil.simulation.scenario import LoadedScenario, Scenario
        from hydrohil.parameters import load_parameters
        sc = Scenario.model_validate(data)
        ls = LoadedScenario(scenario=sc, params=load_parameters("ferreira2004", over), source="t")
        hyb = run_scenario(ls)
        ref = run_scenario(ls.model_copy(update={"scenario": sc.model_copy(
            update={"solver": sc.solver.model_copy(update={"method": "reference"})})}))
        assert rms(hyb.column("xp") - ref.column("xp")) <= 0.5e-3
        assert rms(hyb.column("p1") - ref.column("p1")) <= 3e5


@pytest.mark.parametrize("solver", ["euler", "heun", "rk3", "rk4"])
def test_every_solver_stable_at_half_millisecond(solver):
    res = run_scenario(load_scenario(EXAMPLES / "end_stops_p_control.toml", solver=solver))
    assert res.diverged is None
    assert abs(res.column("xp")[-1] - 0.09) < 2e-3
