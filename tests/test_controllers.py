"""Controllers: the core's law against an independent transcription of its equations, the compiled loop
against the rig's Python loop and lock-step HIL, a user's Python controller, and what each controller
buys on the paper's experiments (step-response metrics checked against closed forms)."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import EXAMPLES, hh, lockstep_equals_offline
from hydrohil.control import (BuiltinController, ControllerError, Measurement, PControllerCfg, PFFControllerCfg,
                              PIControllerCfg, PIDControllerCfg, StateFeedbackControllerCfg, call_controller)
from hydrohil.errors import InputError
from hydrohil.metrics import step_metrics
from hydrohil.simulation.rig import run_rig
from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import Table, load_scenario

CONTROLLERS = EXAMPLES / "controllers"


def with_controller(sc, cfg):
    return sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"controller": cfg})})


# ---- the law, transcribed independently from control.h's equations ----------------------------------------

class Law:
    """control.h's equations in plain Python (the reference the C code is checked against)."""

    def __init__(self, c: dict, h: float, area_ratio: float):
        self.c, self.h, self.a = c, h, area_ratio
        self.i = self.v = self.xp = self.plp = self.plf = 0.0
        self.started = False

    def __call__(self, r, dr, x, p1, p2):
        c, h = self.c, self.h
        e, pl = r - x, p1 - self.a * p2
        if not self.started:
            self.xp, self.plp, self.started = x, pl, True
        self.v = (c["tf"] * self.v + (x - self.xp)) / (c["tf"] + h)
        self.plf = c["tpl"] / (c["tpl"] + h) * (self.plf + pl - self.plp) if c["tpl"] > 0 else pl
        self.xp, self.plp = x, pl
        us = (c["kp"] * e + self.i + c["kff"] * dr + c["u_bias"] - c["kd"] * self.v - c["kpl"] * self.plf
              + c["u_deadband"] * min(1.0, max(-1.0, e / c["e_deadband"])))
        u = min(max(us, c["u_min"]), c["u_max"])
        if c["ki"]:
            if c["antiwindup"] == "back_calculation":
                self.i += c["ki"] * h * e + h / max(c["tt"], h) * (u - us)
            elif u == us or not ((us > u and e > 0) or (us < u and e < 0)):
                self.i += c["ki"] * h * e
        return u


def full(cfg) -> dict:
    d = dict(kp=0.0, ki=0.0, kd=0.0, tf=2e-3, kff=0.0, u_bias=0.0, u_deadband=0.0, e_deadband=1e-4, kpl=0.0,
             tpl=0.0, antiwindup="clamp", tt=None, u_min=-1.0, u_max=1.0)
    d.update({k: v for k, v in cfg.model_dump().items() if k != "type"})
    if d["tt"] is None:
        d["tt"] = d["kp"] / d["ki"] if d["ki"] else 1.0
    return d


gains = st.floats(1.0, 300.0)
configs = st.one_of(
    st.builds(PControllerCfg, type=st.just("p"), kp=gains),
    st.builds(PIControllerCfg, type=st.just("pi"), kp=gains, ki=st.floats(10.0, 5000.0),
              antiwindup=st.sampled_from(["clamp", "back_calculation"]), u_max=st.floats(0.2, 1.0)),
    st.builds(PIDControllerCfg, type=st.just("pid"), kp=gains, ki=st.floats(10.0, 5000.0), kd=st.floats(0.0, 5.0),
              tf=st.floats(1e-4, 0.05), antiwindup=st.sampled_from(["clamp", "back_calculation"])),
    st.builds(PFFControllerCfg, type=st.just("p_ff"), kp=gains, kff=st.floats(0.0, 5.0),
              u_bias=st.floats(-0.05, 0.05), u_deadband=st.floats(0.0, 0.05), e_deadband=st.floats(1e-6, 1e-3)),
    st.builds(StateFeedbackControllerCfg, type=st.just("state_feedback"), kp=gains, kd=st.floats(0.0, 5.0),
              kpl=st.floats(0.0, 1e-6), tpl=st.sampled_from([0.0, 0.01, 0.3]), ki=st.sampled_from([0.0, 300.0])),
)


@settings(max_examples=150, deadline=None)
@given(cfg=configs, seed=st.integers(0, 2**32 - 1))
def test_core_law_equals_its_equations(paper, cfg, seed):
    rng = np.random.default_rng(seed)
    h = 5e-4
    ctl = BuiltinController(cfg, paper, h)
    law = Law(full(cfg), h, paper.cylinder.a2 / paper.cylinder.a1)
    x = 0.1 + np.cumsum(rng.normal(0, 2e-4, 300))       # a wandering measurement, saturating at times
    for k in range(300):
        r, dr = 0.1 + 0.05 * math.sin(k * h * 20), rng.normal(0, 0.1)
        p1, p2 = rng.uniform(0, 1e7, 2)
        assert ctl.update(r, dr, x[k], p1, p2) == pytest.approx(law(r, dr, x[k], p1, p2), rel=1e-10, abs=1e-12)


def test_integrator_clamped_at_the_limit_and_derivative_has_no_kick(paper):
    # a constant error of 1 mm into a limit of 0.1: the clamped integrator stops where it reached the limit
    ctl = BuiltinController(PIControllerCfg(type="pi", kp=50.0, ki=1000.0, u_max=0.1), paper, 1e-3)
    u = [ctl.update(0.001, 0.0, 0.0) for _ in range(1000)]
    assert u[-1] == 0.1 and ctl.state.integral == pytest.approx(0.05, abs=1e-3)   # 0.1 - kp*e, not 1 s * ki*e = 1
    # derivative on the measurement: a reference step moves only the P part
    pid = BuiltinController(PIDControllerCfg(type="pid", kp=50.0, ki=1.0, kd=2.0), paper, 5e-4)
    pid.update(0.0, 0.0, 0.0)
    assert pid.update(0.01, 0.0, 0.0) == pytest.approx(0.5, abs=1e-6)


# ---- one law in every loop ----------------------------------------------------------------------------

BUILTIN = [PIControllerCfg(type="pi", kp=50.0, ki=500.0, antiwindup="back_calculation"),
           PIDControllerCfg(type="pid", kp=50.0, ki=500.0, kd=0.2, tf=0.005),
           PFFControllerCfg(type="p_ff", kp=50.0, kff=2.5, u_bias=-0.009, u_deadband=0.002, e_deadband=5e-5),
           StateFeedbackControllerCfg(type="state_feedback", kp=100.0, kd=0.05, kpl=2e-8, tpl=0.05, ki=50.0)]


@pytest.mark.parametrize("cfg", BUILTIN, ids=lambda c: c.type)
def test_the_loop_of_the_plant_alone_equals_the_loop_through_the_rig_with_noisy_sensors(cfg):
    """hh_sim_run without a rig (hh_rig_read, the drive's noise) and through the rig step (hh_rig_sense, the
    rig's noise, its command path): the same law on the same readings, the same log, every column."""
    sc = load_scenario(EXAMPLES / "fig12_steps_ramps.toml", duration=2.0,
                       sets={"sensors.pressure_noise": 2e4, "sensors.pressure_resolution": 1e3})
    sc = with_controller(sc, cfg)
    compiled, rig = run_scenario(sc), run_rig(sc)
    assert np.array_equal(compiled.log, rig.log)
    assert rig.column("events").sum() > 0 and np.ptp(rig.column("p1_meas") - rig.column("p1")) > 1e4


def test_a_python_callable_sees_what_the_compiled_loop_sees():
    # the paper's P law written by a user: the same numbers as the built-in one, bit for bit
    sc = load_scenario(EXAMPLES / "fig11_p_control.toml", duration=2.0)
    seen = []

    def p_law(m: Measurement) -> float:
        seen.append(m)
        return min(1.0, max(-1.0, 50.0 * (m.x_ref - m.x)))

    mine, builtin = run_rig(sc, controller=p_law), run_scenario(sc)
    assert np.array_equal(mine.column("u"), builtin.column("u")) and np.array_equal(mine.column("xp"),
                                                                                     builtin.column("xp"))
    m = seen[1000]      # t = 0.5 s: the reference starts its ramp there (slope 0.12 m/s)
    assert m.t == 0.5 and m.x_ref == pytest.approx(0.03) and m.dx_ref == pytest.approx(0.12)
    assert m.x == pytest.approx(mine.column("xp")[1000], abs=0.5e-6) and 1e6 < m.p1 < 1e7


def test_python_controller_from_the_scenario_file(tmp_path):
    r = hh("simulate", CONTROLLERS / "fig11_python_pi.toml", "--out", tmp_path, "--no-plot")
    assert r.returncode == 0, r.stderr
    moves = json.loads((tmp_path / "summary.json").read_text())["step_response"]["moves"]
    assert len(moves) == 2 and max(abs(mv["steady_state_error"]) for mv in moves) < 1.5e-6   # measured 0.5 µm


@pytest.mark.parametrize("callable_, options, key, words", [
    ("no_such_module:f", "", "controller.callable", "cannot import 'no_such_module'"),
    ("pi.py:Nope", "", "controller.callable", "has no 'Nope'"),
    ("missing.py:PI", "", "controller.callable", "no such file"),
    ("pi.py:PI", "options = { kq = 1.0 }", "controller.options", "unexpected keyword argument 'kq'"),
    ("broken.py:PI", "", "controller.callable", "loading 'broken.py' failed: ZeroDivisionError"),
])
def test_bad_python_controller_is_named(tmp_path, callable_, options, key, words):
    (tmp_path / "pi.py").write_text((CONTROLLERS / "pi.py").read_text())
    (tmp_path / "broken.py").write_text("1 / 0\n")
    text = (CONTROLLERS / "fig11_python_pi.toml").read_text()
    text = text.replace('callable = "pi.py:PI"', f'callable = "{callable_}"')
    text = text.replace("options = { kp = 50.0, ki = 500.0 }", options)
    (tmp_path / "s.toml").write_text(text)
    r = hh("simulate", tmp_path / "s.toml", "--out", tmp_path / "out")
    assert r.returncode == 2 and key in r.stderr and words in r.stderr and "s.toml" in r.stderr, r.stderr


def test_a_failing_user_controller_stops_the_run_with_the_time():
    m = Measurement(0.25, 0.1, 0.0, 0.1, 1e6, 1e6, 7e6, 0.0, 0)
    with pytest.raises(ControllerError, match=r"t = 0.25 s .*ZeroDivisionError"):
        call_controller(lambda m: 1 / 0, m)
    with pytest.raises(ControllerError, match="returned nan"):
        call_controller(lambda m: float("nan"), m)


@pytest.mark.parametrize("change, key, words", [
    (("ki = 500.0 ", "ki = -1.0 "), "controller.ki", "must be > 0"),
    (("kp = 50.0 ", "kq = 50.0 "), None, "unknown key 'controller.kq'"),
    (('type = "pi"', 'type = "pdi"'), "controller.type", "pdi"),
    (("antiwindup = \"clamp\"", "antiwindup = \"clamp\"\nu_min = 0.5\nu_max = 0.2"), "controller", "u_min (0.5) must be < u_max (0.2)"),
])
def test_bad_gains_are_named_with_their_units(tmp_path, change, key, words):
    path = tmp_path / "s.toml"
    path.write_text((CONTROLLERS / "fig11_pi.toml").read_text().replace(*change))
    with pytest.raises(InputError) as exc:
        load_scenario(path)
    assert words in str(exc.value) and (key is None or exc.value.key.startswith(key)), str(exc.value)


# ---- what the controllers buy (README "Controllers") -------------------------------------------------------

def _hold_error(res, sc, t0):
    t, x = res.column("t"), res.column("xp")
    xr = sc.scenario.references()[0]
    return float(xr[np.searchsorted(t, t0)] - x[np.searchsorted(t, t0)])


def test_pi_removes_the_steady_state_error_p_leaves():
    p = load_scenario(EXAMPLES / "fig11_p_control.toml")
    pi = load_scenario(CONTROLLERS / "fig11_pi.toml")
    rp, rpi = run_scenario(p), run_scenario(pi)
    for t0 in (2.9, 5.9):                       # ends of the two holds
        assert abs(_hold_error(rp, p, t0)) > 100e-6       # measured 163 / 204 µm
        assert abs(_hold_error(rpi, pi, t0)) < 1.5e-6     # measured 0.5 µm (half an encoder count)


def test_pressure_feedback_damps_the_stick_slip_hunting():
    # the slow ramp of Fig 12 (5-6 s, 30 mm/s): under P the piston sticks and slips ~110 times
    def hunting(path):
        sc = load_scenario(path)
        r = run_scenario(sc)
        t, fm, v = r.column("t"), r.column("friction_mode"), r.column("vp")
        w = (t >= 5.1) & (t < 5.9)
        sliding = fm[w] != 0
        return int(np.count_nonzero(sliding[1:] & ~sliding[:-1])), float(np.std(v[w]))
    n_p, sd_p = hunting(EXAMPLES / "fig12_steps_ramps.toml")
    n_sf, sd_sf = hunting(CONTROLLERS / "fig12_pressure_feedback.toml")
    assert n_p > 30 and sd_p > 0.01                       # measured 56 breakaways, 24 mm/s
    assert n_sf <= 1 and sd_sf < 0.15e-3                  # measured 0 breakaways, 0.045 mm/s


# ---- metrics against closed forms ----------------------------------------------------------------------

def test_step_metrics_first_order_and_second_order_closed_forms():
    t = np.arange(0, 4.0, 1e-4)
    tau, t_step, a, x0 = 0.1, 1.0, 0.05, 0.02
    ref = np.where(t >= t_step, x0 + a, x0)
    x = np.where(t >= t_step, x0 + a * (1 - np.exp(-(t - t_step) / tau)), x0) - 30e-6 * (t >= t_step)
    m = step_metrics(t, x, ref)
    mv, = m["moves"]
    d = 30e-6 / a               # the offset shifts where the response crosses 10 % and 90 % of the move
    assert mv["rise_time"] == pytest.approx(tau * math.log((0.9 - d) / (0.1 - d)), abs=2e-4)
    assert mv["settling_time"] == pytest.approx(tau * math.log(a / (0.02 * a - 30e-6)), abs=2e-4)
    assert mv["steady_state_error"] == pytest.approx(30e-6, rel=1e-6) and mv["overshoot"] == 0.0
    # second order, zeta = 0.3: overshoot exp(-pi zeta / sqrt(1 - zeta^2))
    z, wn = 0.3, 20.0
    wd, s = wn * math.sqrt(1 - z * z), np.clip(t - t_step, 0, None)
    y = 1 - np.exp(-z * wn * s) * (np.cos(wd * s) + z / math.sqrt(1 - z * z) * np.sin(wd * s))
    m2, = step_metrics(t, x0 + a * y, ref)["moves"]
    assert m2["overshoot_pct"] == pytest.approx(100 * math.exp(-math.pi * z / math.sqrt(1 - z * z)), rel=1e-3)
    assert mv["via"] is None and m2["via"] is None          # (a plain step: no way beyond from..to)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from([0.0, -0.0, 0.01, 0.02, math.nan]), min_size=0, max_size=60),
       st.floats(0.0, 0.01))
def test_holds_are_the_runs_of_a_constant_reference(values, min_hold):
    """holds() (vectorised) against the sample-by-sample walk it replaced: each run of equal reference samples
    (a NaN a run of its own, -0.0 equal to 0.0) lasting at least min_hold."""
    from hydrohil.metrics import holds
    t = np.arange(len(values)) * 1e-3
    x_ref = np.array(values)
    walked, i = [], 0
    while i < len(t):
        j = i
        while j + 1 < len(t) and x_ref[j + 1] == x_ref[i]:
            j += 1
        if t[j] - t[i] >= min_hold:
            walked.append((i, j))
        i = j + 1
    assert holds(t, x_ref, min_hold) == walked


def test_a_move_that_goes_the_other_way_first_says_via_where():
    """Fig 12's second move: from the 100 mm hold the reference steps back to 60 mm, then ramps to the 140 mm
    hold; the move is 100 -> 140 mm via 60 mm, and its line says so."""
    from hydrohil.metrics import metrics_lines
    t = np.arange(0, 4.0, 1e-3)
    ref = np.interp(t, [0.0, 1.5, 1.5, 2.5, 4.0], [0.10, 0.10, 0.06, 0.14, 0.14])
    m = step_metrics(t, ref, ref)
    mv, = m["moves"]
    assert (mv["from"], mv["to"], mv["via"]) == (0.10, 0.14, pytest.approx(0.06, abs=1e-12))
    assert metrics_lines(m)[0].startswith("1: 100→140 mm (via 60)  rise ")


def test_reference_table_sampled_alike_one_at_a_time_and_at_once():
    tab = Table([0.0, 0.5, 0.5, 1.5, 1.5, 2.5, 3.5], [0.05, 0.05, 0.10, 0.10, 0.06, 0.14, 0.14])
    t = np.concatenate([np.arange(-0.1, 4.0, 5e-4), [0.5, 1.5, 2.5]])
    x, dx = tab(t)
    pairs = [tab.at(v) for v in t]
    assert np.array_equal(x, [p[0] for p in pairs]) and np.array_equal(dx, [p[1] for p in pairs])
    assert tab.at(0.5) == (0.10, 0.0) and tab.at(1.5) == pytest.approx((0.06, 0.08)) and tab.at(9.0) == (0.14, 0.0)


# ---- compare ---------------------------------------------------------------------------------------------

def test_compare_overlays_scenarios_and_run_folders(tmp_path):
    assert hh("simulate", CONTROLLERS / "fig11_pi.toml", "--out", tmp_path / "pi", "--no-plot").returncode == 0
    r = hh("compare", EXAMPLES / "fig11_p_control.toml", tmp_path / "pi", "--labels", "P,PI", "--out", tmp_path / "c")
    assert r.returncode == 0, r.stderr
    data = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert set(data) == {"P", "PI"} and (tmp_path / "c" / "compare.png").stat().st_size > 20_000
    assert data["PI"]["rms_error"] < 0.5 * data["P"]["rms_error"]          # measured 1.22 vs 3.72 mm
    bad = hh("compare", EXAMPLES / "fig11_p_control.toml", "--labels", "a,b", "--out", tmp_path / "d")
    assert bad.returncode == 2 and "--labels" in bad.stderr
    same = hh("compare", EXAMPLES / "fig11_p_control.toml", EXAMPLES / "fig11_p_control.toml", "--out", tmp_path / "e")
    assert same.returncode == 2 and "share a label" in same.stderr


# ---- lock-step HIL: the controller process runs the same law on the same readings ---------------------------

def _scenario_file(tmp_path, source, duration, extra=""):
    text = source.read_text().replace("duration = 6.0", f"duration = {duration}") + extra
    path = tmp_path / source.name
    path.write_text(text)
    if source.parent == CONTROLLERS and (CONTROLLERS / "pi.py").exists():
        (tmp_path / "pi.py").write_text((CONTROLLERS / "pi.py").read_text())
    return path


@pytest.mark.slow
@pytest.mark.parametrize("name, plant, noisy", [("fig11_pi.toml", "python", False),
                                                ("fig12_pressure_feedback.toml", "c", True),
                                                ("fig11_python_pi.toml", "python", False)])
def test_lockstep_hil_equals_offline_exactly(tmp_path, name, plant, noisy):
    extra = '\n"sensors.pressure_noise" = 2e4\n' if noisy else ""
    scen = _scenario_file(tmp_path, CONTROLLERS / name, 1.0)
    if noisy:      # noisy transducers: the controller sees the plant's noise draws, offline the same ones
        scen.write_text(scen.read_text().replace('[overrides]\n', '[overrides]' + extra))
    log, off = lockstep_equals_offline(scen, tmp_path / "out", "--plant", plant, steps=2000)
    assert np.array_equal(log["u"][1:], off.column("u")[:-1])     # the plant logs a command with the state it made
    cmp = json.loads((tmp_path / "out" / "comparison.json").read_text())
    assert cmp["step_response_hil"] == cmp["step_response_offline"]
    assert len(cmp["step_response_hil"]["moves"]) == (1 if name.startswith("fig12") else 0)   # holds within 1 s


@pytest.mark.slow
def test_python_controller_found_when_the_run_folder_holds_the_scenario(tmp_path):
    # with --set, hil writes the scenario into the run folder and both processes read it from there: the
    # controller's module must still be found (its folder is recorded as an absolute path)
    scen = _scenario_file(tmp_path, CONTROLLERS / "fig11_python_pi.toml", 0.2)
    r = hh("hil", scen, "--out", tmp_path / "out", "--lockstep", "--set", "load.mass=90", timeout=600)
    assert r.returncode == 0, r.stderr
    ran = (tmp_path / "out" / "scenario.toml").read_text()
    assert f'path = "{tmp_path.resolve()}"' in ran


@pytest.mark.parametrize("callable_", ["ctl.py:PI", "ctl:PI", "pkg.ctl:PI", "pkg:PI"])
def test_python_controller_as_file_module_or_package_with_its_own_imports(tmp_path, callable_):
    (tmp_path / "gains.py").write_text("KP = 50.0\n")
    body = "from gains import KP\n\n\nclass PI:\n    def __call__(self, m):\n        return max(-1.0, min(1.0, KP * (m.x_ref - m.x)))\n"
    (tmp_path / "ctl.py").write_text(body)
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "__init__.py").write_text("from .ctl import PI\n")
    (tmp_path / "pkg" / "ctl.py").write_text(body)
    text = (CONTROLLERS / "fig11_python_pi.toml").read_text().replace('callable = "pi.py:PI"', f'callable = "{callable_}"')
    (tmp_path / "s.toml").write_text(text.replace("options = { kp = 50.0, ki = 500.0 }", "").replace("duration = 6.0", "duration = 1.0"))
    mine = run_scenario(load_scenario(tmp_path / "s.toml"))
    p = run_scenario(load_scenario(EXAMPLES / "fig11_p_control.toml", duration=1.0))
    assert np.array_equal(mine.column("xp"), p.column("xp"))              # the P law, however it is named


def test_a_run_continued_and_a_controller_reused_give_the_same_numbers(paper):
    from hydrohil.models.layout import pack
    from hydrohil.simulation.loop import Sim, initial_state
    sc = with_controller(load_scenario(EXAMPLES / "fig11_p_control.toml", duration=1.0,
                                       sets={"sensors.pressure_noise": 2e4}), BUILTIN[3])
    ref, slope = sc.scenario.references()
    p = pack(sc.params)

    def sim():
        s = Sim(p, 5e-4)
        s.set_state(*initial_state(sc.params, 0.03, p=p))
        return s
    one = sim()
    _, _, whole = one.run(2000, 1, ref, slopes=slope, controller=sc.make_controller(), seed=3)
    two, ctl = sim(), sc.make_controller()
    _, _, first = two.run(1000, 1, ref[:1001], slopes=slope[:1001], controller=ctl, seed=3)
    _, _, second = two.run(1000, 1, ref[1000:], slopes=slope[1000:], controller=ctl, seed=3)
    assert np.array_equal(whole[1000:], second) and np.array_equal(whole[:1000], first[:1000])
    # a controller object handed to another run starts afresh
    a, b = run_rig(sc, controller=ctl), run_rig(sc, controller=ctl)
    assert np.array_equal(a.column("xp"), b.column("xp"))
