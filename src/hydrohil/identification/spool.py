"""Spool dynamics from datasheet Bode curves (paper §3.1.1, eq 2; SPEC §9.1).

The model is the plant's spool (SPEC §3.1: eq 1 with its acceleration and velocity limits and its
mechanical ends, ``spool_rhs``/``spool_project`` of core/valve.c). For each (amplitude, frequency) of the
data it is driven by a sine until its response is periodic, because a datasheet curve is a periodic
steady state (SPEC §9.1): under velocity saturation the start-up transient decays over tens of periods,
and a few warm-up periods leave the gain several dB off (at 50 %, 200 Hz, ωn 850 rad/s, ξ 0.62, Lv 160 1/s,
La 6e4 1/s²: −13.5 dB after 4 periods, −20.59 dB periodic). :func:`steady_sine_response` says how,
:func:`simulate_bode` is the one evaluation that the fit, the report curves and every synthetic data
generator use. The gain is G = 20·log10(A_out/A_in) with A_out the half peak-to-peak periodic output
(what a datasheet plots), the phase that of the output's fundamental.

The fit. Eq 2 weighs the gain curves (w = 4 on the smallest amplitude, 1 on the others); fitting the gain
alone and then the delay Δt to the phase leaves (ωn, ξ) free to trade against limits that bend the gain
(exact points of a linear spool at one amplitude gave ωn 9 % high, a 2.9° phase RMS and binding limits).
So gain and phase are fitted together, each point's error the complex log ratio ln(G_model/G_data): the
gain error in nepers (dB·ln10/20) and the phase error in radians, with eq 2's weights:
1. the linear spool (eq 1 without limits, analytic) for (ωn, ξ, Δt): the answer when the data show no limit;
2. the full model for (ωn, ξ, Lv, La, Δt) from that answer and from starts with limits at what the data
   need; the limited model is kept only if it explains the data significantly better than the linear one
   (F-test at 1 %, two more parameters) and a limit acts at some data point.
A limit that acts at no data point of the chosen model is not identifiable from these data: it is reported
(the terminal, the JSON, the figure) with the least value the data need and set to a value at which it
never binds for commands in [−1, 1] (:func:`non_binding_limits`). A second curve at a larger amplitude that
reaches the limit identifies it.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import signal
from scipy.integrate import trapezoid
from scipy.optimize import least_squares
from scipy.stats import f as f_distribution

from hydrohil.core import dptr, ffi, iptr, lib
from hydrohil.errors import InputError
from hydrohil.identification.data import Column, read_table
from hydrohil.identification.result import Fit
from hydrohil.models.layout import LA, LV, WN, XI, pack_defaults

COLUMNS = (
    Column("amplitude", "fraction of full input", 1e-4, 1.0, "5 % of full input is 0.05, not 5"),
    Column("frequency_hz", "Hz", 0.1, 1e4),
    Column("gain_db", "dB", -80.0, 20.0),
    Column("phase_deg", "deg", -1080.0, 180.0),
)
SMALL_AMPLITUDE_WEIGHT = 4.0   # eq 2
STEADY_TOL = lib.hh_spool_steady_tol   # periodic when a half period ends where it began (sign flipped) within
                               # this, relative to the output amplitude, in (x̄s, v̄s/ω) (core/spool_bode.c)
MAX_PERIODS = 200              # bounded worst case per point (default); a point that hits it is reported
DENSE_POINTS = 80              # log-spaced model frequencies per amplitude drawn in the report (Fig 4)
# Box of the search for (ωn [rad/s], ξ, Lv [1/s], La [1/s²], Δt [s]). ξ between 0.05 (no steady state without
# damping) and 5; ωn up to 1.2e4 rad/s (1.9 kHz) keeps the RK4 step of the sine response (20 µs) stable
# (2ξωn·h <= 2.4 < 2.78).
SEARCH_BOUNDS = (np.array([1.0, 0.05, 1e-3, 1e-3, 0.0]), np.array([1.2e4, 5.0, 1e6, 1e9, 0.05]))
THREADS = max(1, min(8, os.cpu_count() or 1))   # Bode points are independent: one C call each, GIL released
NEPER_PER_DB = np.log(10.0) / 20.0   # a gain error in dB as the real part of ln(G_model/G_data)
LIMIT_MARGIN = 1.5             # a limit that is not identifiable is set this far above any value it can reach
SIGNIFICANCE = 0.01            # the limited model must beat the linear one at this level (F-test)
NUMERIC_RESIDUAL = 1e-6        # nepers/radians: below this a point's error is the sine response's numerics
LIMITS = {"lv": (lib.HH_SPOOL_ACTS_VEL, "1/s", "velocity limit", 0),
          "la": (lib.HH_SPOOL_ACTS_ACC, "1/s²", "acceleration limit", 1)}   # bit, unit, name, column of peaks


def steady_sine_response(p: np.ndarray, amplitude: float, freq: float, max_half_periods: int):
    """Periodic steady state of the spool model (SPEC §3.1) driven by u = amplitude·sin(2πft), as a datasheet
    Bode point shows it (SPEC §9.1), by the core (``core/spool_bode.c``): (half peak-to-peak output, phase of
    the fundamental [rad], half periods simulated, residual: the estimated distance to the periodic state,
    relative to the output amplitude; > STEADY_TOL when ``max_half_periods`` was hit).

    The model is odd and u(t + T/2) = −u(t), so a half-wave symmetric periodic response is a fixed point of
    the half-period map H(s) = −Φ_{T/2}(s) of s = (x̄s, v̄s). From rest, half periods are simulated (RK4,
    h <= 20 µs, steps holding the velocity limit's or an end's discontinuity refined to h/1024) until one ends
    where it began within STEADY_TOL; the slow tail under velocity saturation is secant-extrapolated
    (Anderson-1), a fixed point so reached accepted only if it attracts. Otherwise (several periodic
    responses, or a subharmonic one) the sine is simulated period by period until two successive periods
    agree within a contraction-corrected bound. Measured against a plain simulation from rest for 1500
    periods (200 random points, ωn 500–2000 rad/s, ξ 0.3–1, Lv 50–400 1/s, La 2e4–3e5 1/s², 3–60 %,
    10–300 Hz): the same gain within 5e-9 dB and phase within 7e-8°, after a median 7 and at most 26 half
    periods."""
    work = np.empty(lib.hh_spool_bode_work(freq))
    got = ffi.new("double[5]")          # the C function's results (gain, phase, ..., cap)
    used = ffi.new("int64_t[2]")
    lib.hh_steady_sine_response(dptr(p), amplitude, freq, int(max_half_periods), dptr(work), got, got + 1, used,
                                got + 2, used + 1, got + 3)
    return got[0], got[1], int(used[0]), got[2]


@dataclass(frozen=True)
class SteadyBode:
    """Steady-state Bode points of the spool model (incl. delay): gain [dB], phase [deg, unwrapped along
    each amplitude curve], half periods simulated per point, the periodicity residual of the accepted
    half period (> STEADY_TOL: the point hit the cap on periods), the limits that acted in the periodic
    state (``lib.HH_SPOOL_ACTS_*`` bits) and its peaks: largest |v̄s| [1/s] and demanded |a*| [1/s²]."""

    gain_db: np.ndarray
    phase_deg: np.ndarray
    half_periods: np.ndarray
    residual: np.ndarray
    limits: np.ndarray
    peaks: np.ndarray

    @property
    def at_cap(self) -> np.ndarray:
        return ~(self.residual <= STEADY_TOL)

    def acting(self, bit: int) -> np.ndarray:
        """Points where the limit ``bit`` (``lib.HH_SPOOL_ACTS_*``) acted."""
        return (self.limits & bit) != 0


def bode_points(p, amplitude, freq, max_periods) -> SteadyBode:
    """Steady-state Bode points of the undelayed spool model at each (amplitude, freq): gain [dB], phase [deg,
    wrapped] and the rest of :class:`SteadyBode`; the points are shared out to THREADS threads (the C calls
    release the GIL)."""
    n = amplitude.shape[0]
    g, ph, resid, used = np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64)
    acts, peaks = np.empty(n, np.int64), np.empty((n, 2))
    threads = min(THREADS, n)

    def run(i):                      # every threads-th point from i: costs vary with the frequency
        idx = np.arange(i, n, threads)
        a, f = np.ascontiguousarray(amplitude[idx], float), np.ascontiguousarray(freq[idx], float)
        gi, phi, ri, pki = np.empty(len(idx)), np.empty(len(idx)), np.empty(len(idx)), np.empty((len(idx), 2))
        ui, ai = np.empty(len(idx), np.int64), np.empty(len(idx), np.int64)
        work = np.empty(max(lib.hh_spool_bode_work(float(v)) for v in f))
        lib.hh_spool_bode(dptr(p), len(idx), dptr(a), dptr(f), int(max_periods), dptr(work), dptr(gi), dptr(phi),
                          iptr(ui), dptr(ri), iptr(ai), dptr(pki))
        g[idx], ph[idx], used[idx], resid[idx], acts[idx], peaks[idx] = gi, phi, ui, ri, ai, pki

    if threads <= 1:
        run(0)
    else:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(run, range(threads)))
    return SteadyBode(g, ph, used, resid, acts, peaks)


def spool_vector(wn: float, xi: float, lv: float, la: float) -> np.ndarray:
    p = pack_defaults()
    p[WN], p[XI], p[LV], p[LA] = wn, xi, lv, la
    return p


def _check_model(wn, xi, lv, la, delay, amplitude, freq) -> None:
    for name, v in (("wn", wn), ("xi", xi), ("lv", lv), ("la", la)):
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"must be a finite number > 0, got {v!r}", key=name)
    if not (np.isfinite(delay) and delay >= 0):
        raise InputError(f"must be a finite number >= 0 s, got {delay!r}", key="delay")
    if amplitude.shape != freq.shape:
        raise InputError(f"amplitude and frequency differ in shape: {amplitude.shape} vs {freq.shape}")
    if not np.all((amplitude > 0) & (amplitude <= 1)):
        raise InputError("amplitudes must be in (0, 1] (fraction of full input: 5 % is 0.05)", key="amplitude")
    if not np.all(np.isfinite(freq) & (freq > 0)):
        raise InputError("frequencies must be finite and > 0 Hz", key="frequency_hz")


def simulate_bode(wn, xi, lv, la, delay, amplitude, freq, max_periods: int = MAX_PERIODS) -> SteadyBode:
    """Periodic steady state of the spool model (SPEC §3.1, §9.1) at each (amplitude, freq), the delay Δt
    adding −360·f·Δt degrees; the one sine-response evaluation used by the fit, the report curves and
    every synthetic data generator. At most ``max_periods`` periods per point."""
    amplitude = np.atleast_1d(np.asarray(amplitude, float))
    freq = np.atleast_1d(np.asarray(freq, float))
    _check_model(wn, xi, lv, la, delay, amplitude, freq)
    if int(max_periods) < 2:
        raise InputError(f"must be >= 2, got {max_periods!r}", key="max_periods")
    m = bode_points(spool_vector(wn, xi, lv, la), amplitude, freq, int(max_periods))
    return SteadyBode(m.gain_db, unwrap_curves(amplitude, freq, m.phase_deg - 360.0 * freq * delay),
                      m.half_periods, m.residual, m.limits, m.peaks)


def linear_response(wn, xi, delay, freq) -> np.ndarray:
    """Frequency response of the linear spool, eq 1 without limits, with the delay:
    ωn²/(ωn² − ω² + 2jξωnω)·exp(−jωΔt) at ω = 2πf."""
    w = 2.0 * np.pi * np.asarray(freq, float)
    return wn * wn / (wn * wn - w * w + 2j * xi * wn * w) * np.exp(-1j * w * delay)


def non_binding_limits(wn: float, xi: float) -> tuple[float, float]:
    """(Lv, La) at which the limits never act for commands in [−1, 1]: LIMIT_MARGIN × the largest |v̄s| and
    demanded |a*| the linear spool can reach, the L1 norms of its velocity and acceleration impulse responses
    (the peak gain over all inputs bounded by 1). v = sωn²/D(s)·u; a* = s²ωn²/D(s)·u = ωn²·u − ωn²(2ξωns +
    ωn²)/D(s)·u, D(s) = s² + 2ξωns + ωn²."""
    den = [1.0, 2.0 * xi * wn, wn * wn]
    slowest = xi * wn if xi < 1.0 else wn * (xi - np.sqrt(xi * xi - 1.0))
    t = np.linspace(0.0, 40.0 / slowest, 40001 if xi < 1.0 else 20001)
    t = np.linspace(0.0, t[-1], max(t.size, int(t[-1] * wn * 200) + 1))
    _, hv = signal.impulse(([wn * wn, 0.0], den), T=t)
    _, hr = signal.impulse(([2.0 * xi * wn ** 3, wn ** 4], den), T=t)
    v_max = trapezoid(np.abs(hv), t)
    a_max = wn * wn + trapezoid(np.abs(hr), t)
    return LIMIT_MARGIN * float(v_max), LIMIT_MARGIN * float(a_max)


def unwrap_curves(amplitude, freq, phase_deg) -> np.ndarray:
    """Unwrap phases along increasing frequency within each amplitude curve, starting near 0 deg."""
    out = np.array(phase_deg, float)
    for a in np.unique(amplitude):
        idx = np.flatnonzero(amplitude == a)
        idx = idx[np.argsort(freq[idx])]
        un = np.unwrap(np.radians(out[idx]))
        un -= 2 * np.pi * np.round(un[0] / (2 * np.pi))
        out[idx] = np.degrees(un)
    return out


def read_bode(path: str | Path) -> dict[str, np.ndarray]:
    d = read_table(path, COLUMNS, min_rows=6)
    if np.unique(d["frequency_hz"]).size < 3:
        raise InputError("need at least 3 distinct frequencies", source=str(path), key="frequency_hz")
    return d


def _weights(amplitude: np.ndarray) -> np.ndarray:
    return np.where(amplitude == amplitude.min(), SMALL_AMPLITUDE_WEIGHT, 1.0)


def _wrap_rad(d_deg: np.ndarray) -> np.ndarray:
    """A phase difference [deg] as radians in [−π, π)."""
    return np.radians((np.asarray(d_deg) + 180.0) % 360.0 - 180.0)


def _wn_3db(a, f, g_data) -> float:
    """A first ωn [rad/s]: the −3 dB point of the smallest-amplitude curve (twice its last frequency if the
    curve never falls that far)."""
    small = a == a.min()
    fs, gs = f[small], g_data[small]
    order = np.argsort(fs)
    below = np.flatnonzero(gs[order] < -3.0)
    return 2 * np.pi * (fs[order][below[0]] if below.size else 2 * fs.max())


def _fit_linear(a, f, g_data, ph_data, sw) -> tuple[float, float, float]:
    """(ωn, ξ, Δt) of the linear spool (:func:`linear_response`) minimising the weighted complex log error
    over every point, from starts around the −3 dB point of the smallest-amplitude curve."""
    wn3 = _wn_3db(a, f, g_data)
    lo, hi = np.log(SEARCH_BOUNDS[0][[0, 1]]), np.log(SEARCH_BOUNDS[1][[0, 1]])

    def residuals(theta):
        wn, xi = np.exp(theta[:2])
        G = linear_response(wn, xi, theta[2] * 1e-3, f)
        return np.concatenate([sw * (np.log(np.abs(G)) - g_data * NEPER_PER_DB),
                               sw * _wrap_rad(np.degrees(np.angle(G)) - ph_data)])

    best = None
    for wn0 in (wn3, 0.5 * wn3, 2.0 * wn3):
        for xi0 in (0.3, 0.7, 1.5):
            x0 = np.clip(np.array([np.log(wn0), np.log(xi0), 0.0]), np.r_[lo, 0.0] + 1e-9,
                         np.r_[hi, SEARCH_BOUNDS[1][4] * 1e3] - 1e-9)
            sol = least_squares(residuals, x0, bounds=(np.r_[lo, 0.0], np.r_[hi, SEARCH_BOUNDS[1][4] * 1e3]),
                                x_scale=1.0, xtol=1e-12, ftol=1e-14, gtol=1e-14, max_nfev=2000)
            if best is None or sol.cost < best.cost:
                best = sol
    wn, xi = np.exp(best.x[:2])
    return float(wn), float(xi), float(best.x[2] * 1e-3)


def identify_spool(data: dict[str, np.ndarray] | str | Path, *, progress=None,
                   max_periods: int = MAX_PERIODS) -> Fit:
    """Fit (ωn, ξ, Lv, La, Δt) to the gain and phase curves (module docstring: eq 2's weights, the linear
    model first, the limits only where the data show them). ``data`` holds the columns of :data:`COLUMNS` or
    is the path of such a CSV file. Every model point is a periodic steady state (:func:`steady_sine_response`,
    at most ``max_periods`` periods); ``achieved`` counts the points that hit that cap, in the fitted model
    and during the search. Limits the data cannot determine are in ``not_identifiable``."""
    t0 = time.perf_counter()
    if int(max_periods) < 2:
        raise InputError(f"must be >= 2, got {max_periods!r}", key="max_periods")
    max_periods = int(max_periods)
    d = read_bode(data) if isinstance(data, (str, Path)) else data
    a, f = np.asarray(d["amplitude"], float), np.asarray(d["frequency_hz"], float)
    g_data = np.asarray(d["gain_db"], float)
    ph_data = unwrap_curves(a, f, np.asarray(d["phase_deg"], float))
    sw = np.sqrt(_weights(a))
    search = {"evaluations": 0, "points_at_cap": 0}

    def residuals(wn, xi, lv, la, delay):
        m = bode_points(spool_vector(wn, xi, lv, la), a, f, max_periods)
        search["evaluations"] += 1
        search["points_at_cap"] += int(np.count_nonzero(m.at_cap))
        return np.concatenate([sw * (m.gain_db - g_data) * NEPER_PER_DB,
                               sw * _wrap_rad(m.phase_deg - 360.0 * f * delay - ph_data)])

    lo, hi = np.log(SEARCH_BOUNDS[0][:4]), np.log(SEARCH_BOUNDS[1][:4])
    dt_hi = SEARCH_BOUNDS[1][4] * 1e3   # the delay in ms in the search vector

    def fit(x0, free):
        """Least squares over the entries ``free`` of (ln ωn, ln ξ, ln Lv, ln La, Δt [ms]), the rest held."""
        full_lo, full_hi = np.r_[lo, 0.0], np.r_[hi, dt_hi]
        x0 = np.clip(np.asarray(x0, float), full_lo + 1e-9, full_hi - 1e-9)

        def r(theta):
            x = x0.copy()
            x[free] = theta
            return residuals(*np.exp(x[:4]), x[4] * 1e-3)

        sol = least_squares(r, x0[free], method="trf", bounds=(full_lo[free], full_hi[free]), x_scale=1.0,
                            diff_step=1e-4, xtol=1e-10, ftol=1e-12, max_nfev=400)
        x = x0.copy()
        x[free] = sol.x
        return x, float(sol.cost)

    # 1. the linear spool, analytic; its limits held where they never bind
    wn_l, xi_l, dt_l = _fit_linear(a, f, g_data, ph_data, sw)
    lv_nb, la_nb = non_binding_limits(wn_l, xi_l)
    x_lin, cost_lin = fit(np.r_[np.log([wn_l, xi_l, lv_nb, la_nb]), dt_l * 1e3], [0, 1, 4])
    # 2. the limited model from starts whose limits act: what the data's output needs, and fractions of it
    a_out = a * 10 ** (g_data / 20)
    lv0 = max(2 * np.pi * np.max(f * a_out), 1e-3)
    la0 = max(np.max((2 * np.pi * f) ** 2 * a_out), 1e-3)
    starts = [np.r_[x_lin[:2], np.log([lv0 * s, la0 * s]), x_lin[4]] for s in (1.0, 0.6)]
    wn3 = _wn_3db(a, f, g_data)
    starts += [np.r_[np.log([wn3, xi0, lv0 * s, la0 * s]), x_lin[4]] for xi0 in (0.5, 0.8) for s in (1.0, 0.6)]
    x_lim, cost_lim = None, np.inf
    for i, x0 in enumerate(starts):
        x, c = fit(x0, [0, 1, 2, 3, 4])
        if c < cost_lim:
            x_lim, cost_lim = x, c
        if progress:
            progress(i + 1, len(starts))
    n_res, floor = 2 * a.size, 0.5 * 2 * a.size * NUMERIC_RESIDUAL ** 2
    dof = n_res - 5
    m_lim = simulate_bode(*np.exp(x_lim[:4]), x_lim[4] * 1e-3, a, f, max_periods)
    limited_acts = bool(np.any(m_lim.limits & (lib.HH_SPOOL_ACTS_VEL | lib.HH_SPOOL_ACTS_ACC)))
    f_stat = ((cost_lin - cost_lim) / 2.0) / (max(cost_lim, floor) / dof) if dof > 0 else 0.0
    p_value = float(f_distribution.sf(f_stat, 2, dof)) if dof > 0 and f_stat > 0 else 1.0
    limited = limited_acts and cost_lim < cost_lin and p_value < SIGNIFICANCE
    x, cost = (x_lim, cost_lim) if limited else (x_lin, cost_lin)
    wn, xi, lv, la = (float(v) for v in np.exp(x[:4]))
    delay = float(x[4] * 1e-3)
    m0 = m_lim if limited else simulate_bode(wn, xi, lv, la, delay, a, f, max_periods)
    # limits that act at no data point: not identifiable; set where they never bind
    not_identifiable = {}
    never = dict(zip(("lv", "la"), non_binding_limits(wn, xi)))
    values = {"wn": wn, "xi": xi, "lv": lv, "la": la, "delay": delay}
    for key, (bit, unit, name, col) in LIMITS.items():
        if not np.any(m0.acting(bit)):
            need = float(np.max(m0.peaks[:, col]))
            values[key] = max(never[key], values[key] if limited else 0.0)
            not_identifiable[key] = {
                "needs_at_least": need, "set_to": values[key], "unit": unit,
                "why": f"the {name} acts at no data point: the data only show it is >= {need:.4g} {unit}; set to "
                       f"{values[key]:.4g} {unit}, where it never binds for commands in [-1, 1] (a curve at a "
                       "larger amplitude that reaches it identifies it)"}
    if not_identifiable:
        m0 = simulate_bode(*(values[k] for k in ("wn", "xi", "lv", "la", "delay")), a, f, max_periods)
    ph_fit = unwrap_curves(a, f, m0.phase_deg)
    res_g = m0.gain_db - g_data
    res_ph = np.degrees(_wrap_rad(ph_fit - ph_data))
    # the model on a dense log grid (Fig 4 draws it as curves, the data as markers)
    fd = np.geomspace(f.min(), f.max(), DENSE_POINTS)
    ad = np.repeat(np.unique(a), fd.size)
    fd = np.tile(fd, np.unique(a).size)
    dense = simulate_bode(*(values[k] for k in ("wn", "xi", "lv", "la", "delay")), ad, fd, max_periods)
    at_cap = int(np.count_nonzero(m0.at_cap))
    names = ("wn", "xi", "lv", "la", "delay")
    bounded = [i for i in ((0, 1, 2, 3, 4) if limited else (0, 1, 4))
               if names[i] not in not_identifiable]
    notes = [f"{names[i]} = {values[names[i]]:.4g} at the bound of the search "
             f"[{SEARCH_BOUNDS[0][i]:g}, {SEARCH_BOUNDS[1][i]:g}]" for i in bounded
             if not (SEARCH_BOUNDS[0][i] * (1 + 1e-6) + (1e-9 if i == 4 else 0.0) < values[names[i]]
                     < SEARCH_BOUNDS[1][i] * (1 - 1e-6))]
    n_end = int(np.count_nonzero(m0.acting(lib.HH_SPOOL_ACTS_END)))
    if n_end:
        notes.append(f"the spool reaches its end (|x̄s| = 1) at {n_end} of {a.size} points")
    if at_cap:
        notes.append(f"{at_cap} of {a.size} points of the fitted model not periodic after {max_periods} periods "
                     f"(residual up to {np.max(m0.residual):.2g}): their gain is that of the last simulated period")
    if search["points_at_cap"]:
        notes.append(f"{search['points_at_cap']} point evaluations hit the {max_periods}-period cap during the "
                     "search")
    result = Fit("spool", values, cost=float(cost), notes=notes, not_identifiable=not_identifiable,
                 updates={f"spool.{k}": values[k] for k in names},
                 achieved={"gain_rms_db": float(np.sqrt(np.mean(res_g ** 2))),
                           "gain_max_abs_db": float(np.max(np.abs(res_g))),
                           "phase_rms_deg": float(np.sqrt(np.mean(res_ph ** 2))),
                           "phase_max_abs_deg": float(np.max(np.abs(res_ph))),
                           "model": "limited" if limited else "linear",
                           "limited_vs_linear_p_value": p_value,
                           "points_velocity_limited": int(np.count_nonzero(m0.acting(lib.HH_SPOOL_ACTS_VEL))),
                           "points_acceleration_limited": int(np.count_nonzero(m0.acting(lib.HH_SPOOL_ACTS_ACC))),
                           "points_at_end": n_end,
                           "points_at_cap": at_cap,
                           "periods_max": float(np.max(m0.half_periods)) / 2,
                           "search_evaluations": search["evaluations"],
                           "search_points_at_cap": search["points_at_cap"]},
                 curves={"amplitude": a, "frequency_hz": f, "gain_db": g_data, "phase_deg": ph_data,
                         "gain_fit": m0.gain_db, "phase_fit": ph_fit,
                         "model_amplitude": ad, "model_frequency_hz": fd, "model_gain_db": dense.gain_db,
                         "model_phase_deg": dense.phase_deg})
    result.wall_time_s = time.perf_counter() - t0
    return result


def synthetic_bode(wn, xi, lv, la, delay, amplitudes=(0.05, 0.25, 0.5), freqs=np.arange(10.0, 301.0, 10.0),
                   noise_db=0.0, noise_deg=0.0, seed=0) -> dict[str, np.ndarray]:
    """Bode 'datasheet' curves of the spool model with known parameters at its periodic steady state
    (:func:`simulate_bode`, as a datasheet shows them) + optional Gaussian noise."""
    a = np.repeat(np.asarray(amplitudes, float), len(freqs))
    f = np.tile(np.asarray(freqs, float), len(amplitudes))
    m = simulate_bode(wn, xi, lv, la, delay, a, f)
    if np.any(m.at_cap):
        raise RuntimeError(f"{np.count_nonzero(m.at_cap)} synthetic Bode points not periodic after "
                           f"{MAX_PERIODS} periods")
    rng = np.random.default_rng(seed)
    return {"amplitude": a, "frequency_hz": f, "gain_db": m.gain_db + noise_db * rng.standard_normal(a.size),
            "phase_deg": m.phase_deg + noise_deg * rng.standard_normal(a.size)}
