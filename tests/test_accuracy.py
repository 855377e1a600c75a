"""Hybrid model (RK3, 0.5 ms) against the continuous stiff reference (LSODA).

Each paper scenario has its own limits, about 3x what the model achieves (measured 2026-11-22 with
benchmarks/accuracy.py, README table): a regression of the model shows up here. Fig 12's final ramp is a
stick-slip hunting limit cycle where two correct models differ in phase (SPEC §6.1 pitfall 3): judged by
its statistics (frequency, amplitude, mean), sample by sample before it.
"""

import numpy as np
import pytest

from conftest import EXAMPLES, rms
from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import load_scenario

# case: (xp RMS [m], xp max [m], P1 RMS [Pa], P2 RMS [Pa]); measured (every run starting at rest, 2026-11-23):
# sine 2.9 um, 23 um, 0.16, 0.16 bar; Fig 11 0.99 um, 14 um, 0.066, 0.075 bar; both stops 2.0 um, 19 um, 0.20,
# 0.17 bar; slammed stop 0.34 um, 1.6 um, 0.017, 0.039 bar (from the closed-port start: sine 2.6 um, 21 um,
# 0.13, 0.14; Fig 11 2.7 um, 14 um, 0.19, 0.14; both stops 4.5 um, 59 um, 0.31, 0.25; slammed 0.48 um, 2.1 um)
LIMITS = {"sine_open_loop.toml": (8e-6, 60e-6, 0.45e5, 0.45e5),
          "fig11_p_control.toml": (3e-6, 42e-6, 0.2e5, 0.23e5),
          "end_stops_p_control.toml": (6e-6, 57e-6, 0.6e5, 0.5e5),
          "maxstep_endstop.toml": (1.0e-6, 5e-6, 0.05e5, 0.12e5)}


def hybrid_and_reference(scenario):
    hyb = run_scenario(scenario)
    ref = run_scenario(scenario.model_copy(update={"scenario": scenario.scenario.model_copy(
        update={"solver": scenario.scenario.solver.model_copy(update={"method": "reference"})})}))
    assert hyb.diverged is None and ref.diverged is None
    return hyb, ref


@pytest.mark.parametrize("name", LIMITS)
def test_hybrid_rk3_matches_reference(name):
    hyb, ref = hybrid_and_reference(load_scenario(EXAMPLES / name))
    x_rms, x_max, p1_rms, p2_rms = LIMITS[name]
    ex = hyb.column("xp") - ref.column("xp")
    assert rms(ex) <= x_rms and abs(ex).max() <= x_max, (rms(ex), abs(ex).max())
    assert rms(hyb.column("p1") - ref.column("p1")) <= p1_rms
    assert rms(hyb.column("p2") - ref.column("p2")) <= p2_rms


def _oscillation(v, window, n=40):
    """The part of v faster than a 20 ms moving average (the limit cycle) in ``window`` and its dominant
    frequency [Hz]."""
    osc = (v - np.convolve(v, np.ones(n) / n, mode="same"))[window]
    f = np.fft.rfftfreq(osc.size, 5e-4)
    spec = np.abs(np.fft.rfft(osc))
    spec[f < 5.0] = 0.0
    return osc, f[np.argmax(spec)]


def test_fig12_steps_ramps_and_stick_slip_hunting():
    hyb, ref = hybrid_and_reference(load_scenario(EXAMPLES / "fig12_steps_ramps.toml"))
    t = hyb.column("t")
    # steps and ramps (t < 5 s), sample by sample; measured 30 um RMS, 0.17 mm max (the 50 mm step at
    # 0.5 s: both saturated, 0.3 ms apart), 0.53 / 0.40 bar RMS
    pre = t < 5.0
    ex = (hyb.column("xp") - ref.column("xp"))[pre]
    assert rms(ex) <= 90e-6 and abs(ex).max() <= 0.5e-3
    assert rms((hyb.column("p1") - ref.column("p1"))[pre]) <= 1.6e5
    assert rms((hyb.column("p2") - ref.column("p2"))[pre]) <= 1.2e5
    # the slow final ramp hunts in a 70 Hz stick-slip limit cycle in both models (measured: same frequency
    # bin, amplitudes 7 % apart, means 0.6 um and 0.06 bar apart)
    w = (t >= 5.2) & (t < 5.98)
    for col, mean_tol in (("xp", 3e-6), ("p1", 0.2e5), ("p2", 0.2e5)):
        (oh, fh), (orf, fr) = (_oscillation(r.column(col), w) for r in (hyb, ref))
        assert abs(fh - fr) <= 1.5 and fr > 20.0, (col, fh, fr)               # one FFT bin: 1.3 Hz
        assert abs(oh.std() / orf.std() - 1) <= 0.2, (col, oh.std(), orf.std())
        assert abs(hyb.column(col)[w].mean() - ref.column(col)[w].mean()) <= mean_tol, col


def test_kp50_at_120_bar_and_kp100_at_70_bar():
    # measured: 1.3 / 1.2 um RMS, 10 / 9 um max, P1 0.15 / 0.17 bar RMS
    import tomllib
    from hydrohil.parameters import load_parameters
    from hydrohil.simulation.scenario import LoadedScenario, Scenario
    for over, kp in (({"supply.ps": 1.2e7}, 50.0), ({"supply.ps": 7e6}, 100.0)):
        data = tomllib.loads((EXAMPLES / "fig11_p_control.toml").read_text())
        data["overrides"] = over
        data["controller"]["kp"] = kp
        sc = Scenario.model_validate(data)
        hyb, ref = hybrid_and_reference(LoadedScenario(scenario=sc, params=load_parameters("ferreira2004", over),
                                                       source="t"))
        ex = hyb.column("xp") - ref.column("xp")
        assert rms(ex) <= 4e-6 and abs(ex).max() <= 30e-6
        assert rms(hyb.column("p1") - ref.column("p1")) <= 0.5e5


@pytest.mark.parametrize("solver", ["euler", "heun", "rk3", "rk4"])
def test_every_solver_stable_at_half_millisecond(solver):
    res = run_scenario(load_scenario(EXAMPLES / "end_stops_p_control.toml", solver=solver))
    assert res.diverged is None
    assert abs(res.column("xp")[-1] - 0.09) < 2e-3


# ---- random physically sensible scenarios (hypothesis) -------------------------------------------

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@st.composite
def sensible_scenarios(draw, mass=(5.0, 500.0), ps=(20e5, 250e5), kp=(10.0, 150.0), duration=3.0):
    """A scenario of the paper's rig with load, supply, gravity, load force and input drawn at random:
    the P loop on random set-points (end stops included) or open-loop command steps or sines."""
    from hydrohil.parameters import load_parameters
    from hydrohil.simulation.scenario import LoadedScenario, Scenario
    over = {"load.mass": draw(st.floats(*mass)), "supply.ps": draw(st.floats(*ps)),
            "load.gravity_direction": draw(st.sampled_from([-1, 0, 1])),
            "load.force": draw(st.sampled_from([0.0, 0.0, -1500.0, 1500.0]))}
    d = {"params": "ferreira2004", "duration": duration, "solver": {"method": "rk3", "step": 5e-4},
         "overrides": over, "initial": {"xp": draw(st.floats(0.0, 0.18))}}
    times = sorted(draw(st.lists(st.floats(0.05, duration - 0.05), min_size=3, max_size=5)))
    t = [0.0] + [v for x in times for v in (x, x)] + [duration]
    kind = draw(st.sampled_from(["p", "p", "steps", "sine"]))
    if kind == "p":
        x = [v for v in draw(st.lists(st.floats(-0.02, 0.2), min_size=len(times) + 1, max_size=len(times) + 1))
             for _ in (0, 1)]
        d["controller"] = {"type": "p", "kp": draw(st.floats(*kp))}
        d["reference"] = {"type": "table", "t": t, "x": x}
    elif kind == "steps":
        scale = draw(st.sampled_from([0.05, 0.3, 1.0]))
        u = [scale * v for v in draw(st.lists(st.floats(-1, 1), min_size=len(times) + 1, max_size=len(times) + 1))
             for _ in (0, 1)]
        d["input"] = {"type": "table", "t": t, "u": u}
    else:
        d["input"] = {"type": "sine", "amplitude": draw(st.floats(0.01, 0.6)), "frequency": draw(st.floats(0.2, 20))}
    return LoadedScenario(scenario=Scenario.model_validate(d), params=load_parameters("ferreira2004", over),
                          source="hypothesis")


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sc=sensible_scenarios())
def test_hybrid_never_diverges_at_half_millisecond(sc):
    # loads 5-500 kg, supply 20-250 bar, gains up to 150 1/m, stops, stick-slip: RK3 at 0.5 ms stays finite,
    # physical and inside the stroke (2000 such runs were checked by hand, none diverged). Pressures may
    # exceed Ps (a heavy load braked at low supply pressure: 50 bar at Ps = 20 bar), not 1000 bar.
    res = run_scenario(sc)
    assert res.diverged is None, res.diverged
    assert max(res.column("p1").max(), res.column("p2").max()) < 1e8
    assert -1e-9 <= res.column("xp").min() and res.column("xp").max() <= sc.params.cylinder.stroke + 1e-9


def _moving_average(v, n=40):
    return np.convolve(v, np.ones(n) / n, mode="valid")


@pytest.mark.slow
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sc=sensible_scenarios(mass=(20.0, 200.0), ps=(50e5, 200e5), kp=(20.0, 100.0)))
def test_random_scenarios_match_reference(sc):
    # inside the envelope of the limits (loads 20-200 kg, 50-200 bar, Kp 20-100): position within
    # 0.5 mm RMS / 2 mm max; pressures within 3 bar RMS after a 20 ms moving average, since stick-slip
    # and hunting limit cycles make two correct models differ in phase (SPEC §6.1 pitfall 3; raw RMS
    # exceeded 3 bar in 5 of 120 hand-checked runs, all such limit cycles). A loop that hunts to the end
    # (its set-point held over the last second, the reference's position oscillating there by more than 0.1 mm
    # RMS above 5 Hz, at more than 20 Hz) drifts in phase
    # against the other model however close they are (seen: 177 kg at 192 bar, Kp 81, both hunting at 46 Hz,
    # 0.84 / 0.83 mm, means 3 um apart, pointwise 0.51 mm RMS): compared sample by sample until it starts
    # hunting, then as fig 12's hunting is, by its frequency, size and mean.
    hyb, ref = hybrid_and_reference(sc)
    t = hyb.column("t")
    last = t >= t[-1] - 1.0
    upto = np.ones(t.size, dtype=bool)
    osc, f_osc = _above_5hz(ref.column("xp")[last], spectrum=True)
    r = sc.scenario.reference
    changes = [tk for tk, a, b in zip(r.t[1:], r.x, r.x[1:]) if a != b] if r is not None else [t[-1]]
    held = sc.scenario.controller is not None and max(changes, default=0.0) <= t[-1] - 1.0
    if held and osc.std() > 1e-4 and f_osc > 20.0:        # the P loop hunting at its set-point to the end
        upto = t < _hunting_onset(ref.column("xp"), t)
        for col, mean_tol in (("xp", 1e-4), ("p1", 1e5), ("p2", 1e5)):
            (oh, fh), (orf, fr) = (_above_5hz(r.column(col)[last], spectrum=True) for r in (hyb, ref))
            assert abs(fh - fr) <= 2.0, (col, fh, fr)                         # (one FFT bin: 1 Hz)
            assert abs(oh.std() / orf.std() - 1) <= 0.2, (col, oh.std(), orf.std())
            assert abs(hyb.column(col)[last].mean() - ref.column(col)[last].mean()) <= mean_tol, col
    ex = (hyb.column("xp") - ref.column("xp"))[upto]
    assert rms(ex) <= 0.5e-3 and abs(ex).max() <= 2e-3
    for c in ("p1", "p2"):
        assert rms((_moving_average(hyb.column(c)) - _moving_average(ref.column(c)))[upto[39:]]) <= 3e5  # (valid)


def _above_5hz(v, spectrum=False):
    """The part of v above 5 Hz (its FFT's) and, with ``spectrum``, its dominant frequency [Hz]."""
    f = np.fft.rfftfreq(v.size, 5e-4)
    spec = np.fft.rfft(v - v.mean())
    spec[f < 5.0] = 0.0
    osc = np.fft.irfft(spec, v.size)
    return (osc, f[np.argmax(np.abs(spec))]) if spectrum else osc


def _hunting_onset(x, t, window=200):
    """When a loop starts hunting to the end: the first time after which the position's part faster than a
    20 ms moving average keeps a 0.1 s RMS above 25 um (x's limit cycle)."""
    hf = x - np.convolve(x, np.ones(40) / 40, mode="same")
    rolling = np.sqrt(np.convolve(hf ** 2, np.ones(window) / window, mode="same"))
    quiet = np.nonzero(rolling[: -window // 2] < 25e-6)[0]
    return t[quiet[-1]] if quiet.size else 0.0


@pytest.mark.slow
def test_a_loop_hunting_to_the_end_is_judged_by_its_cycle():
    """The case hypothesis found (177 kg at 192 bar, Kp 81, a 62.5 mm step at 1 s): both models hunt at 46 Hz
    after the step, 0.84 / 0.83 mm RMS, their means 3 um apart; sample by sample they drift apart in phase
    (0.51 mm RMS over the run: beyond 0.5 mm) — the random test judges it by its cycle, and it passes."""
    from hydrohil.parameters import load_parameters
    from hydrohil.simulation.scenario import LoadedScenario, Scenario
    over = {"load.mass": 177.0, "supply.ps": 19164004.0, "load.gravity_direction": 1, "load.force": 0.0}
    d = {"params": "ferreira2004", "duration": 3.0, "solver": {"method": "rk3", "step": 5e-4}, "overrides": over,
         "initial": {"xp": 0.0}, "controller": {"type": "p", "kp": 81.0},
         "reference": {"type": "table", "t": [0.0, 1.0, 1.0, 3.0], "x": [0.0, 0.0, 0.0625, 0.0625]}}
    sc = LoadedScenario(scenario=Scenario.model_validate(d), params=load_parameters("ferreira2004", over),
                        source="hypothesis's case")
    hyb, ref = hybrid_and_reference(sc)
    t = hyb.column("t")
    osc, f = _above_5hz(ref.column("xp")[t >= 2.0], spectrum=True)
    assert osc.std() > 5e-4 and 40.0 < f < 50.0                               # it hunts (measured: 46 Hz)
    assert rms(hyb.column("xp") - ref.column("xp")) > 0.5e-3                  # pointwise: the phase drift
    test_random_scenarios_match_reference.hypothesis.inner_test(sc)
