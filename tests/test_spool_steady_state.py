"""Spool identification fits the periodic steady state (issue #12 §1, SPEC §9.1, paper eq 1-2).

The Bode "datasheets" here are made by an independent program written in this file: a NumPy simulation,
vectorised over points, of the limited spool model of SPEC §3.1 (its own RK4, its own limits), switched on
at rest and run period by period until two successive periods agree; the gain is half the peak-to-peak
output of the last period, the phase that of its fundamental (DFT), the delay the exact shift −360·f·Δt.
It does not use hydrohil's sine response. The parameter sets are unlike the paper's (ωn 1007 rad/s,
ξ 0.48, Lv 125.6 1/s, La 81184 1/s², Δt 0.76 ms).
"""

import numpy as np
import pytest

from hydrohil.core import lib
from hydrohil.errors import InputError
from hydrohil.identification.spool import (STEADY_TOL, identify_spool, simulate_bode, spool_vector,
                                           steady_sine_response)
from hydrohil.models.valve import spool_derivatives
from hydrohil.parameters import load_parameters, replace_values
from hydrohil.simulation.loop import HybridPlant

AMPLITUDES = (0.05, 0.25, 0.5)
FREQS = np.arange(10.0, 301.0, 10.0)
SETS = {   # unlike the paper's: a slow, well-damped, strongly limited spool and a fast, lightly damped one
    "slow": dict(wn=650.0, xi=0.75, lv=90.0, la=3.5e4, delay=1.1e-3),
    "fast": dict(wn=1400.0, xi=0.35, lv=230.0, la=1.6e5, delay=3.5e-4),
}
ISSUE = dict(wn=850.0, xi=0.62, lv=160.0, la=6.0e4, delay=0.0)   # the issue's measurement (50 %: 100, 200 Hz)
NOISE_DB, NOISE_DEG = 0.1, 1.0                                    # datasheet-like reading noise


def reference_bode(wn, xi, lv, la, delay, amplitude, freq, steps_per_period=256, rtol=1e-7, max_periods=1000):
    """Independent steady-state Bode points (gain [dB], phase [deg, wrapped], periods simulated); every
    argument an array over the points. RK4 with a fixed number of steps per period (the same input
    phases at every point), the spool acceleration a* = ωn²(u − x) − 2ξωn·v clamped to ±La, no
    acceleration beyond ±Lv (limited integrator), v clipped to ±Lv after each step; the spool's ends at
    x = ±1 plastic (no motion or acceleration into an end, x clipped there and the velocity into it zeroed)."""
    wn, xi, lv, la, delay, amplitude, freq = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (wn, xi, lv, la, delay, amplitude, freq)))
    n_pts = amplitude.size
    s_half = np.sin(np.pi * np.arange(2 * steps_per_period + 1) / steps_per_period)   # sin ωt at half steps
    c_step = np.cos(2 * np.pi * np.arange(steps_per_period) / steps_per_period)
    x_all, v_all = np.zeros(n_pts), np.zeros(n_pts)
    amp_prev = np.full(n_pts, np.inf)
    agreed = np.zeros(n_pts, bool)
    gain, phase, periods = np.full(n_pts, np.nan), np.full(n_pts, np.nan), np.zeros(n_pts, int)
    active = np.arange(n_pts)
    for period in range(1, max_periods + 1):
        a, h, w = amplitude[active], 1.0 / (freq[active] * steps_per_period), 2 * np.pi * freq[active]
        k_lin, k_damp = wn[active] ** 2, 2 * xi[active] * wn[active]
        lim_v, lim_a = lv[active], la[active]

        def rates(xx, vv, u):
            acc = np.minimum(np.maximum(k_lin * (u - xx) - k_damp * vv, -lim_a), lim_a)
            acc = np.where(((vv >= lim_v) & (acc > 0)) | ((vv <= -lim_v) & (acc < 0)), 0.0, acc)
            top, bottom = (xx >= 1) & (vv >= 0), (xx <= -1) & (vv <= 0)
            return (np.where(top | bottom, 0.0, vv),
                    np.where(top, np.minimum(acc, 0.0), np.where(bottom, np.maximum(acc, 0.0), acc)))

        x, v = x_all[active], v_all[active]
        x0, v0 = x, v
        hi, lo = x.copy(), x.copy()
        s_sum, c_sum = np.zeros(active.size), np.zeros(active.size)
        for j in range(steps_per_period):
            s_sum += x * s_half[2 * j]
            c_sum += x * c_step[j]
            np.maximum(hi, x, out=hi)
            np.minimum(lo, x, out=lo)
            u0, um, u1 = a * s_half[2 * j], a * s_half[2 * j + 1], a * s_half[2 * j + 2]
            d1, a1 = rates(x, v, u0)
            d2, a2 = rates(x + 0.5 * h * d1, v + 0.5 * h * a1, um)
            d3, a3 = rates(x + 0.5 * h * d2, v + 0.5 * h * a2, um)
            d4, a4 = rates(x + h * d3, v + h * a3, u1)
            x = x + h / 6 * (d1 + 2 * d2 + 2 * d3 + d4)
            v = np.minimum(np.maximum(v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4), -lim_v), lim_v)
            v = np.where((x >= 1) & (v > 0) | (x <= -1) & (v < 0), 0.0, v)
            x = np.clip(x, -1.0, 1.0)
        x_all[active], v_all[active] = x, v
        amp = 0.5 * (hi - lo)
        same = ((np.abs(x - x0) <= rtol * amp) & (np.abs(v - v0) <= rtol * amp * w)
                & (np.abs(amp - amp_prev[active]) <= rtol * amp))
        done = same & agreed[active]               # successive periods agreed twice in a row
        agreed[active], amp_prev[active] = same, amp
        idx = active[done]
        gain[idx] = 20 * np.log10(amp[done] / a[done])
        phase[idx] = np.degrees(np.arctan2(c_sum[done], s_sum[done]))
        periods[idx] = period
        active = active[~done]
        if not active.size:
            break
    assert not active.size, f"{active.size} points not periodic after {max_periods} periods"
    return gain, (phase - 360.0 * freq * delay + 180.0) % 360.0 - 180.0, periods


def unwrap_per_curve(amplitude, phase):
    """Unwrap along frequency within each amplitude curve (points ordered by frequency), from near 0°."""
    out = np.array(phase, float)
    for a in np.unique(amplitude):
        m = amplitude == a
        out[m] = np.degrees(np.unwrap(np.radians(out[m])))
    return out


@pytest.fixture(scope="module")
def datasheets():
    """Steady-state Bode data of both sets at 5/25/50 %, 10-300 Hz, plus the issue's two 50 % points,
    all in one vectorised run of the independent generator."""
    a = np.repeat(AMPLITUDES, FREQS.size)
    f = np.tile(FREQS, len(AMPLITUDES))
    cols = {k: [] for k in ("wn", "xi", "lv", "la", "delay", "amplitude", "freq")}
    for s in SETS.values():
        for k in ("wn", "xi", "lv", "la", "delay"):
            cols[k].append(np.full(a.size, s[k]))
        cols["amplitude"].append(a)
        cols["freq"].append(f)
    for k in ("wn", "xi", "lv", "la", "delay"):
        cols[k].append(np.full(2, ISSUE[k]))
    cols["amplitude"].append(np.array([0.5, 0.5]))
    cols["freq"].append(np.array([100.0, 200.0]))
    gain, phase, periods = reference_bode(**{k: np.concatenate(v) for k, v in cols.items()})
    rng = np.random.default_rng(2024)
    out = {}
    for i, name in enumerate(SETS):
        sl = slice(i * a.size, (i + 1) * a.size)
        out[name] = {"amplitude": a, "frequency_hz": f, "gain_db": gain[sl], "phase_deg": unwrap_per_curve(a, phase[sl]),
                     "periods": periods[sl]}
    out["issue"] = {"gain_db": gain[-2:], "phase_deg": phase[-2:], "periods": periods[-2:]}
    out["noisy"] = {name: {**d, "gain_db": d["gain_db"] + NOISE_DB * rng.standard_normal(a.size),
                           "phase_deg": d["phase_deg"] + NOISE_DEG * rng.standard_normal(a.size)}
                    for name, d in ((n, out[n]) for n in SETS)}
    return out


# measured (seed 2024, gain and phase fitted together): slow ωn −0.28 %, ξ −0.53 %, Lv −0.28 %, La +0.28 %,
# Δt +0.02 %; fast ωn +0.14 %, ξ +0.45 %, Lv +0.02 %, La −0.17 %, Δt +0.59 %; gain RMS 0.086 / 0.093 dB
# (gain first, then Δt: slow −0.36/−0.74/−0.55/+0.18/−0.07 %, fast +0.29/+1.05/−0.40/+0.24/+1.37 %)
LIMITS = {"wn": 0.009, "xi": 0.016, "lv": 0.009, "la": 0.009, "delay": 0.018}   # ~3x the worst of the two sets


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SETS))
def test_fit_recovers_parameters_from_independent_steady_state_data(datasheets, name):
    true = SETS[name]
    fit = identify_spool(datasheets["noisy"][name])
    errors = {k: fit.values[k] / true[k] - 1 for k in LIMITS}
    for k, lim in LIMITS.items():
        assert abs(errors[k]) < lim, (name, errors)
    assert fit.achieved["gain_rms_db"] < 0.12          # the 0.1 dB noise; a transient-biased model shows ~1.5 dB
    assert fit.achieved["phase_rms_deg"] < 1.3         # the 1° noise
    assert fit.achieved["points_at_cap"] == 0 and not fit.notes


def test_model_matches_independent_generator_point_by_point(datasheets):
    """hydrohil's steady state (Anderson-accelerated half periods, refined steps) against the plain long
    run of the independent generator: measured 7.0e-4 dB and 0.024° at most over the 180 points (the
    generator's own step error: at 1024 steps per period it moves by the same amount)."""
    for name, s in SETS.items():
        d = datasheets[name]
        m = simulate_bode(s["wn"], s["xi"], s["lv"], s["la"], s["delay"], d["amplitude"], d["frequency_hz"])
        assert not m.at_cap.any()
        assert np.max(np.abs(m.gain_db - d["gain_db"])) < 2e-3, name
        assert np.max(np.abs(m.phase_deg - d["phase_deg"])) < 0.07, name


def test_issue_points_short_warm_up_trap(datasheets):
    """The issue's measurement (ωn 850, ξ 0.62, Lv 160, La 6e4, 50 % input): at 200 Hz the gain was
    −13.5 dB after 4 warm-up periods, −20.6 dB at the steady state; at 100 Hz −7.76 vs −8.54 dB. The
    independent generator needs 43 and 72 periods there; hydrohil agrees with it (measured 5.4e-4 dB,
    4.6e-3°)."""
    ref = datasheets["issue"]
    assert ref["gain_db"] == pytest.approx([-8.537, -20.588], abs=0.01)
    assert ref["periods"].min() > 20                     # what a few warm-up periods miss
    m = simulate_bode(ISSUE["wn"], ISSUE["xi"], ISSUE["lv"], ISSUE["la"], 0.0, [0.5, 0.5], [100.0, 200.0])
    assert np.max(np.abs(m.gain_db - ref["gain_db"])) < 1.5e-3
    assert np.max(np.abs(m.phase_deg - ref["phase_deg"])) < 0.015


def test_spool_model_is_odd():
    """The half-period map rests on spool_derivatives(−x, −v, −u) = −spool_derivatives(x, v, u) (symmetric
    limits, SPEC §3.1), at and beyond every limit, including the end of travel."""
    rng = np.random.default_rng(1)
    p = spool_vector(850.0, 0.62, 160.0, 6.0e4)
    xs = np.concatenate([rng.uniform(-1.2, 1.2, 400), [1.0, -1.0, 0.0]])
    vs = np.concatenate([rng.uniform(-200.0, 200.0, 400), [160.0, -160.0, 160.0]])
    us = np.concatenate([rng.uniform(-1.0, 1.0, 400), [1.0, -1.0, 1.0]])
    for x, v, u in zip(xs, vs, us):
        dx, dv, mode = spool_derivatives(x, v, u, p)
        ndx, ndv, nmode = spool_derivatives(-x, -v, -u, p)
        assert (ndx, ndv, nmode) == (-dx, -dv, mode)


def test_cap_is_bounded_and_reported(datasheets):
    f = 200.0
    a_out, _, used, resid = steady_sine_response(spool_vector(850.0, 0.62, 160.0, 6.0e4), 0.5, f, 4)
    assert used == 4 and resid > STEADY_TOL and a_out > 0
    d = datasheets["noisy"]["fast"]
    few = (d["amplitude"] == 0.5) & (d["frequency_hz"] >= 250.0)       # saturated: far from periodic in 2
    fit = identify_spool({k: d[k][few] for k in ("amplitude", "frequency_hz", "gain_db", "phase_deg")},
                         max_periods=2)
    assert fit.achieved["points_at_cap"] > 0 and fit.achieved["search_points_at_cap"] > 0
    assert any("not periodic after 2 periods" in n for n in fit.notes)


def test_bad_model_inputs():
    with pytest.raises(InputError, match="0.05"):
        simulate_bode(850.0, 0.62, 160.0, 6e4, 0.0, [5.0], [100.0])          # 5 %, not 0.05
    with pytest.raises(InputError, match="frequency_hz"):
        simulate_bode(850.0, 0.62, 160.0, 6e4, 0.0, [0.5], [0.0])
    with pytest.raises(InputError, match="xi"):
        simulate_bode(850.0, -0.1, 160.0, 6e4, 0.0, [0.5], [100.0])
    with pytest.raises(InputError, match="max_periods"):
        simulate_bode(850.0, 0.62, 160.0, 6e4, 0.0, [0.5], [100.0], max_periods=1)


def test_identification_spool_is_the_plants_spool_with_its_ends():
    """Issue #25 §1: at full input the linear spool would overshoot its travel (the paper's set: gain
    1.0021 at 10 Hz), but the plant clamps x̄s at ±1. The sine response behind identification stops there
    too (it had no end: 1.0021), as the independent generator with plastic ends and the plant itself do."""
    paper = dict(wn=1007.01, xi=0.48, lv=125.56, la=81184.24)
    freqs = np.array([5.0, 10.0, 20.0])
    w = 2 * np.pi * freqs
    linear_gain = np.abs(paper["wn"] ** 2 / (paper["wn"] ** 2 - w ** 2 + 2j * paper["xi"] * paper["wn"] * w))
    assert np.all(linear_gain > 1.0003)                               # an end-less spool would pass x̄s = 1
    m = simulate_bode(**paper, delay=0.0, amplitude=np.ones(3), freq=freqs)
    assert np.all(m.acting(lib.HH_SPOOL_ACTS_END)) and np.all(m.gain_db <= 0.0)
    ref_gain, ref_phase, _ = reference_bode(**paper, delay=0.0, amplitude=np.ones(3), freq=freqs)
    assert np.all(ref_gain == 0.0)                                    # the independent spool stops at 1 too
    assert np.max(np.abs(m.phase_deg - ref_phase)) < 1e-4             # measured 2.8e-5 deg
    # the plant's spool (hybrid step, RK4 at 20 µs, no delay) on the same sine: the same peak, the end
    params = replace_values(load_parameters("ferreira2004"), {"spool.delay": 0.0})
    plant = HybridPlant(params, h=2e-5, solver="rk4")
    xs = np.array([plant.step(np.sin(2 * np.pi * 10.0 * plant.t))[1] for _ in range(3 * 5000)])
    assert xs[-5000:].max() == 1.0 and xs[-5000:].min() == -1.0
    a_out, *_ = steady_sine_response(spool_vector(**paper), 1.0, 10.0, 400)
    assert a_out == 1.0
