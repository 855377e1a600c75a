"""Parts of the hybrid model that the scenario tests do not reach on their own: the fractional delay, the
orifice's laminar region, the event budget, the cavitation floor, the spool's limited modes and ends,
and the reference solver's Radau fallback."""

import numpy as np
import pytest

from hydrohil.models.cylinder import P_MIN
from hydrohil.models.layout import (MAX_EVENTS, AT_RETRACT, FREE, SPOOL_ACC_LIMITED,
                                    SPOOL_AT_END, SPOOL_LINEAR, SPOOL_VEL_LIMITED, VP, VS, XP, XS)
from hydrohil.models.valve import orifice_flow, orifice_slope
from hydrohil.parameters import load_parameters
from hydrohil.simulation.loop import HybridPlant
from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import LoadedScenario, Scenario

LPM_PER_SQRT_BAR = 1.0 / 60000.0 / np.sqrt(1e5)   # 1 (l/min)/sqrt(bar) in (m^3/s)/sqrt(Pa), computed here


# ---- fractional delay (SPEC §3.1: interpolated, not rounded) ---------------------------------------

def _exact_delayed_average(u, h, delay, k, samples=20000):
    """Mean over [k*h, (k+1)*h) of the zero-order-held sequence u delayed by ``delay``, by brute force."""
    tau = k * h + (np.arange(samples) + 0.5) / samples * h - delay
    j = np.floor(tau / h + 1e-12).astype(int)
    return np.where(j < 0, u[0], u[np.clip(j, 0, len(u) - 1)]).mean()


@pytest.mark.parametrize("delay", [7.625e-4, 1.0e-3, 2.2e-4])
def test_fractional_delay_is_the_exact_shift_averaged_over_the_step(delay):
    h = 5e-4
    prm = load_parameters("ferreira2004", {"spool.delay": delay})
    plant = HybridPlant(prm, h=h, xp=0.09)
    u = np.random.default_rng(1).uniform(-0.2, 0.2, 60)
    ud = np.array([plant.step(v)[13] for v in u])
    exact = np.array([_exact_delayed_average(u, h, delay, k) for k in range(len(u))])
    # the first steps average with the command held before t = 0 (the initial spool position, 0 here)
    n0 = int(np.ceil(delay / h))
    assert np.max(np.abs(ud[n0:] - exact[n0:])) < 2e-5        # brute-force quadrature error, 1/20000 of a jump


# ---- orifice law (SPEC §3.2): turbulent exactly, C1 cubic inside the laminar region ---------------

def test_orifice_laminar_region_value_and_slope():
    area, dpt = 4.31, 1e5
    k = area * LPM_PER_SQRT_BAR
    for dp in (1e5, 3e5, 2e7, -1e5, -4e6):                     # at and beyond the transition: exactly turbulent
        assert orifice_flow(area, dp, dpt) == np.sign(dp) * k * np.sqrt(abs(dp))
    eps = 1e-3
    for side in (1.0, -1.0):                                    # value and slope continuous at +-dp_t
        lo, hi = orifice_flow(area, side * (dpt - eps), dpt), orifice_flow(area, side * (dpt + eps), dpt)
        slope = orifice_slope(area, side * dpt, dpt)           # a jump would make this quotient huge
        assert side * (hi - lo) / (2 * eps) == pytest.approx(slope, rel=1e-6)
        assert orifice_slope(area, side * (dpt - eps), dpt) == pytest.approx(
            orifice_slope(area, side * (dpt + eps), dpt), rel=1e-7)
    assert orifice_flow(area, 0.0, dpt) == 0.0
    assert orifice_slope(area, 0.0, dpt) == pytest.approx(1.25 * k / np.sqrt(dpt), rel=1e-12)   # finite at 0
    for dp in np.linspace(-3e5, 3e5, 61):                        # slope = derivative of the flow everywhere
        d = 1e-2
        num = (orifice_flow(area, dp + d, dpt) - orifice_flow(area, dp - d, dpt)) / (2 * d)
        assert orifice_slope(area, dp, dpt) == pytest.approx(num, rel=1e-6)
    r = 0.5                                                     # inside: odd and below the square root
    assert orifice_flow(area, -r * dpt, dpt) == -orifice_flow(area, r * dpt, dpt)
    assert 0 < orifice_flow(area, r * dpt, dpt) < k * np.sqrt(r * dpt)


# ---- event budget: more than MAX_EVENTS guard crossings in one step --------------------------------

def test_event_budget_exhaustion_keeps_a_valid_state():
    # a 0.5 kg piston driven at 20 Hz near the retract stop with a 2 ms step: stop impacts, stick-slip and
    # leaving the stop crowd into single steps (found by search); the step must spend its budget, take the
    # rest of the step in the mode it reached, and leave a state that is valid for that mode
    prm = load_parameters("ferreira2004", {"load.mass": 0.5, "load.gravity_direction": 0})
    h = 2e-3
    plant = HybridPlant(prm, h=h, xp=0.002)
    exhausted = 0
    for k in range(8):          # (a 0.5 kg load at 2 ms is far outside the stable step: only the first steps)
        out = plant.step(0.05 * np.sin(2 * np.pi * 20 * k * h))
        exhausted += out[12] == MAX_EVENTS + 1
        assert np.all(np.isfinite(plant.y))
        travel = plant.m[0]
        if travel == FREE:
            assert 0.0 <= plant.y[XP] <= prm.cylinder.stroke
        else:
            assert plant.y[XP] == (0.0 if travel == AT_RETRACT else prm.cylinder.stroke) and plant.y[VP] == 0.0
    assert exhausted >= 1


# ---- a state at rest is zero, not subnormal (issue #29) ------------------------------------------------

def test_a_spool_decaying_to_rest_reaches_zero_without_subnormal_states():
    """The spool released at 30 % under a zero command decays as a damped second-order lag; its position and
    speed pass through the subnormal numbers (below 2.2e-308, ~100 cycles an operation on Intel CPUs), where
    without the step's rule they stayed for good (10 116 subnormal values in these 4 s before it): each engine's
    states are exactly 0 from the first step that would have made them subnormal, and the two engines agree bit
    for bit (the core's project and the generated substep apply the same rule)."""
    import sys
    prm = load_parameters("ferreira2004", {"load.gravity_direction": 0})
    logs = {}
    for engine in ("core", "generated"):
        plant = HybridPlant(prm, engine=engine, xp=0.09, xs=0.3)
        logs[engine] = np.array([plant.step(0.0).copy() for _ in range(8000)])       # 4 s
    rows = logs["core"]
    assert np.array_equal(rows, logs["generated"])
    mag = np.abs(rows)
    assert not ((mag > 0) & (mag < sys.float_info.min)).any()
    xs, vs = rows[:, 1 + XS], rows[:, 1 + VS]                  # (the row: t, then the state)
    zero = int(np.argmax((xs == 0.0) & (vs == 0.0)))
    assert 1000 < zero < 4000 and (xs[zero:] == 0.0).all() and (vs[zero:] == 0.0).all()   # (measured: step 2922)
    before = np.abs(np.concatenate([xs[:zero], vs[:zero]]))
    assert sys.float_info.min <= before[before > 0].min() < 1e-300  # (it went down to the smallest normal numbers)


# ---- cavitation floor (SPEC §4) ---------------------------------------------------------------------

def test_pressure_floor_under_cavitation():
    # valve centred with its lands sealed, a 20 kN force pulling the rod out: chamber 1 expands with no
    # inflow and its pressure falls to the floor, never below
    prm = load_parameters("ferreira2004", {"valve.k": [0, 0, 0, 0, 0], "valve.kt": [0, 0, 0, 0, 0],
                                           "load.force": -2e4, "load.gravity_direction": 0, "cylinder.g_lkc": 0.0})
    plant = HybridPlant(prm, xp=0.02, p1=5e5, p2=5e5)
    p1 = np.array([plant.step(0.0)[3] for _ in range(60)])
    assert (p1 >= P_MIN).all() and p1.min() == P_MIN
    assert np.sum(p1 == P_MIN) >= 3                              # it stays on the floor while chamber 1 grows


def test_reference_model_cavitates_at_the_same_floor():
    # an overrunning load (132 kg pulled out by gravity and 1.5 kN) at 50 bar: chamber 1 cavitates while the
    # piston runs out. The reference model once let its pressure fall to -1.5 bar (below vacuum) and then
    # differed from the hybrid model by 0.51 mm RMS; with the same floor: 0.021 mm (hypothesis found it)
    over = {"load.mass": 132.0, "supply.ps": 5e6, "load.gravity_direction": 1, "load.force": -1500.0}
    d = {"params": "ferreira2004", "duration": 3.0, "overrides": over, "initial": {"xp": 0.0},
         "input": {"type": "table", "t": [0.0, 1.0, 1.0, 3.0], "u": [0.0, 0.0, 0.3, 0.3]}}
    runs = {}
    for method in ("rk3", "reference"):
        d["solver"] = {"method": method, "step": 5e-4}
        runs[method] = run_scenario(LoadedScenario(scenario=Scenario.model_validate(d),
                                                   params=load_parameters("ferreira2004", over), source="test"))
    ref = runs["reference"]
    # it does cavitate, and stays within what LSODA oversteps the floor by (5 Pa measured)
    assert P_MIN - 20.0 <= ref.column("p1").min() < P_MIN + 1e3
    ex = runs["rk3"].column("xp") - ref.column("xp")
    assert np.sqrt(np.mean(ex ** 2)) < 0.07e-3


# ---- spool: linear, acceleration- and velocity-limited, at its ends (SPEC §3.1) ---------------------

def test_spool_modes_and_mechanical_end(paper):
    plant = HybridPlant(paper, xp=0.09)
    small = [int(plant.step(0.02)[11]) for _ in range(40)]
    assert set(small) == {SPOOL_LINEAR}                          # 2 %: far from every limit
    plant = HybridPlant(paper, xp=0.09)
    modes, xs, vs = [], [], []
    for _ in range(40):
        out = plant.step(1.0)
        modes.append(int(out[11]))
        xs.append(plant.y[XS])
        vs.append(plant.y[VS])
    modes, xs, vs = np.array(modes), np.array(xs), np.array(vs)
    i_acc, i_vel, i_end = (np.argmax(modes == m) for m in (SPOOL_ACC_LIMITED, SPOOL_VEL_LIMITED, SPOOL_AT_END))
    assert modes[i_acc] == SPOOL_ACC_LIMITED and modes[i_vel] == SPOOL_VEL_LIMITED and modes[i_end] == SPOOL_AT_END
    assert i_acc < i_vel < i_end                                  # a full step: accelerate, slew, reach the end
    assert np.max(np.abs(vs)) <= paper.spool.lv                   # velocity limit, no wind-up
    assert xs.max() == 1.0 and np.all(vs[xs == 1.0] == 0.0)      # held at the end, not through it
    assert np.all(modes[i_end:][xs[i_end:] == 1.0] == SPOOL_AT_END)


def test_reference_spool_end_is_a_stiff_stop(paper):
    from hydrohil.simulation.reference import solve_reference
    from hydrohil.models.layout import pack
    from hydrohil.simulation.loop import initial_state
    p = pack(paper)
    y0, _ = initial_state(paper, 0.09, p=p)
    status, _, log, _ = solve_reference(p, y0, 5e-4, 80, np.full(81, 1.0))
    xs = log[:, 3]
    assert status == 0 and 0.999 < xs.max() <= 1.002           # penetration ~ Lv/omega = 1.3e-3 at most
    assert abs(xs[-1] - 1.0) < 1e-4                             # resting on the stop


# ---- the reference solver's Radau fallback -----------------------------------------------------------

def test_reference_radau_fallback_and_failure(monkeypatch):
    from conftest import EXAMPLES
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    from hydrohil.core import stiff as reference
    sc = load_scenario(EXAMPLES / "fig11_p_control.toml", duration=0.05, solver="reference")
    normal = run_scenario(sc)
    assert normal.extra["reference_radau_fallbacks"] == 0
    monkeypatch.setattr(reference, "LSODA_MXSTEP", 3)              # LSODA gives up on almost every interval
    fallback = run_scenario(sc)
    assert fallback.diverged is None
    assert fallback.extra["reference_radau_fallbacks"] > 50
    assert np.max(np.abs(fallback.column("xp") - normal.column("xp"))) < 1e-8   # same tolerances, same answer

    class Failed:
        success, message = False, "step size too small (forced by the test)"
    monkeypatch.setattr(reference, "solve_ivp", lambda *a, **k: Failed())
    failed = run_scenario(sc)
    assert failed.diverged is not None and "Radau (step size too small" in str(failed.diverged)


def test_sim_run_refuses_a_zero_log_interval(paper):
    """Issue #25 §7: hh_sim_run with every = 0 divided by zero (SIGFPE in the C core); now the core answers
    HH_BAD_ARGUMENT having done nothing, and the Python loop says which argument."""
    from hydrohil.core import dptr, ffi, lib
    from hydrohil.models.layout import pack
    from hydrohil.simulation.loop import Sim
    sim = Sim(pack(paper), 5e-4)
    values = np.zeros(11)
    drive = ffi.new("hh_drive *")
    drive.kind, drive.v_in, drive.t_in, drive.n_in = lib.HH_DRIVE_OPEN, dptr(values), ffi.NULL, 11
    log, done, rows = np.zeros((11, lib.HH_NLOG)), ffi.new("int64_t *"), ffi.new("int64_t *")
    assert lib.hh_sim_run(sim._sim, drive, 10, 0, dptr(log), done, rows) == lib.HH_BAD_ARGUMENT
    assert done[0] == 0 and rows[0] == 0 and sim._sim.k == 0
    assert lib.hh_sim_run(sim._sim, drive, 10, 1, dptr(log), done, rows) == lib.HH_OK and rows[0] == 11
    with pytest.raises(ValueError, match="every >= 1"):
        sim.run(10, 0, values)


def test_a_progress_callback_changes_nothing_and_can_stop_the_run():
    """A progress callback (the terminal's progress bar) sees the steps and changes nothing: the reference run
    with one equals the run without (the callback used to take the place of the reference's step: a run in a
    terminal froze its state), and so does a run through the rig; what it raises (Ctrl-C) stops the run and
    is raised."""
    from conftest import EXAMPLES
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    cases = (load_scenario(EXAMPLES / "fig11_p_control.toml", solver="reference", duration=0.6),
             load_scenario(EXAMPLES / "faults" / "hose_burst.toml", duration=2.5))
    for sc in cases:
        seen = []
        with_bar, without = run_scenario(sc, progress=seen.append), run_scenario(sc)
        assert np.array_equal(with_bar.log, without.log) and np.ptp(with_bar.column("xp")) > 1e-3
        assert seen and seen == sorted(seen) and max(seen) < sc.scenario.n_steps()

    def ctrl_c(k):
        if k > 0:
            raise KeyboardInterrupt
    for sc in cases:
        with pytest.raises(KeyboardInterrupt):
            run_scenario(sc, progress=ctrl_c)


CTRL_C_CHILD = """
import sys, warnings
warnings.simplefilter("ignore")
from hydrohil.terminal import interruptible
interruptible()           # (as the CLI: SIGINT raises, also when started with it ignored, a background job)
from hydrohil.simulation.scenario import load_scenario
from hydrohil.simulation.run import run_scenario
ls = load_scenario(sys.argv[1])
def go(k):
    if k == 0:
        print("GO", flush=True)
try:
    res = run_scenario(ls, progress=go)
    print("COMPLETED", res.extra, flush=True)
except KeyboardInterrupt:
    print("INTERRUPTED", flush=True)
"""


def test_a_ctrl_c_stops_a_long_generated_run(tmp_path):
    """A Ctrl-C (SIGINT) while the generated code runs a long paper scenario (7.2 million steps) stops it with
    KeyboardInterrupt, whether it arrives in the progress callback or on the way into it (cffi's onerror:
    build.callback_raised). The child says GO from the run's first progress call; the parent interrupts it then."""
    import signal
    import subprocess
    import sys
    from conftest import EXAMPLES
    text = (EXAMPLES / "fig11_p_control.toml").read_text().replace("duration = 6.0", "duration = 3600.0")
    f = tmp_path / "long.toml"
    f.write_text(text.replace("[solver]\n", "[solver]\noutput_every = 1000\n"))
    child = tmp_path / "child.py"
    child.write_text(CTRL_C_CHILD)
    p = subprocess.Popen([sys.executable, str(child), str(f)], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "GO"
        p.send_signal(signal.SIGINT)
        out, _ = p.communicate(timeout=120)
    finally:
        p.kill()
    assert out.strip() == "INTERRUPTED" and p.returncode == 0
