"""Spool dynamics from datasheet Bode curves (paper §3.1.1, eq 2; SPEC §9.1).

The model is the limited second-order spool of SPEC §3.1 (the same ``spool_derivatives`` the plant
uses). For each (amplitude, frequency) of the data it is driven by a sine until its response is periodic,
because a datasheet curve is a periodic steady state (SPEC §9.1): under velocity saturation the start-up
transient decays over tens of periods, and a few warm-up periods leave the gain several dB off (at 50 %,
200 Hz, ωn 850 rad/s, ξ 0.62, Lv 160 1/s, La 6e4 1/s²: −13.5 dB after 4 periods, −20.59 dB periodic).
:func:`steady_sine_response` says how, :func:`simulate_bode` is the one evaluation that the fit, the
report curves and every synthetic data generator use. The gain is G = 20·log10(A_out/A_in) with A_out
the half peak-to-peak periodic output (what a datasheet plots), the phase that of the output's
fundamental. (ωn, ξ, Lv, La) minimise eq 2: F = Σ_curves w·Σ_n (G_sim − G_data)²/2 with w = 4 on the
smallest amplitude and 1 on the others, by least squares in log-parameters within SEARCH_BOUNDS. The pure
delay Δt only shifts the phase by −360·f·Δt degrees, so once the gain fit is done, Δt follows from the
same weighted least squares on the phase in closed form.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import prange
from scipy.optimize import least_squares

from hydrohil._jit import jit
from hydrohil.errors import InputError
from hydrohil.identification.data import Column, read_table
from hydrohil.identification.result import Fit
from hydrohil.models.layout import LA, LV, NP, SPOOL_AT_END, SPOOL_LINEAR, SPOOL_VEL_LIMITED, WN, XI
from hydrohil.models.valve import spool_derivatives

COLUMNS = (
    Column("amplitude", "fraction of full input", 1e-4, 1.0, "5 % of full input is 0.05, not 5"),
    Column("frequency_hz", "Hz", 0.1, 1e4),
    Column("gain_db", "dB", -80.0, 20.0),
    Column("phase_deg", "deg", -1080.0, 180.0),
)
SMALL_AMPLITUDE_WEIGHT = 4.0   # eq 2
H_MAX = 2e-5                   # s, largest internal step of the sine-response simulation
STEPS_PER_PERIOD_MIN = 200     # (made even: the steady state is computed half a period at a time)
STEADY_TOL = 1e-9              # periodic when a half period ends where it began (sign flipped) within this,
                               # relative to the output amplitude, in (x̄s, v̄s/ω)
REFINE_DEPTH = 10              # a step holding a discontinuity of the model is cut down to h/2^10
MAX_PERIODS = 200              # bounded worst case per point (default); a point that hits it is reported
ACCEL_HALF_PERIODS = 100       # of which at most these for the accelerated half-period search (steady_sine_response)
PLAIN_HALF_PERIODS = 6         # simulated as they come before the slow tail may be accelerated
SLOW_CONTRACTION = 0.2         # tail accelerated when a half period shrinks the residual by less than 5x
DENSE_POINTS = 80              # log-spaced model frequencies per amplitude drawn in the report (Fig 4)
# Box of the search for (ωn [rad/s], ξ, Lv [1/s], La [1/s²]). ξ between 0.05 (no steady state without
# damping) and 5; ωn up to 1.2e4 rad/s (1.9 kHz) keeps the RK4 step H_MAX stable (2ξωn·H_MAX <= 2.4 < 2.78).
SEARCH_BOUNDS = (np.array([1.0, 0.05, 1e-3, 1e-3]), np.array([1.2e4, 5.0, 1e6, 1e9]))


@jit(inline=True)
def _jumps(mode):
    """Whether the right-hand side is discontinuous across entering/leaving ``mode``: the limited
    integrator at ±Lv (the acceleration clamp at ±La is continuous) and the end of the spool travel."""
    return mode == SPOOL_VEL_LIMITED or mode == SPOOL_AT_END


@jit(inline=True)
def _rk4_step(p, xs, vs, u0, um, u1, h, lv):
    """One classic RK4 step of the spool model (SPEC §3.1) with the input at t, t + h/2, t + h; velocity held
    in ±Lv after the step (the limited integrator). Also says whether the step holds a discontinuity of
    the model (its four stages not all on the same side of one, or the velocity clamped at the end) and
    whether any limit acted in it (else the step was linear)."""
    d1x, d1v, m1 = spool_derivatives(xs, vs, u0, p)
    d2x, d2v, m2 = spool_derivatives(xs + 0.5 * h * d1x, vs + 0.5 * h * d1v, um, p)
    d3x, d3v, m3 = spool_derivatives(xs + 0.5 * h * d2x, vs + 0.5 * h * d2v, um, p)
    d4x, d4v, m4 = spool_derivatives(xs + h * d3x, vs + h * d3v, u1, p)
    xn = xs + h / 6.0 * (d1x + 2.0 * d2x + 2.0 * d3x + d4x)
    vn = vs + h / 6.0 * (d1v + 2.0 * d2v + 2.0 * d3v + d4v)
    clipped = vn > lv or vn < -lv
    j1 = _jumps(m1)
    switched = _jumps(m2) != j1 or _jumps(m3) != j1 or _jumps(m4) != j1 or clipped
    limited = (m1 != SPOOL_LINEAR or m2 != SPOOL_LINEAR or m3 != SPOOL_LINEAR or m4 != SPOOL_LINEAR
               or clipped)
    return xn, min(max(vn, -lv), lv), switched, limited


@jit(inline=True)
def _refined_step(p, amplitude, w, t0, h, xs, vs, lv):
    """The step [t0, t0 + h] that holds a discontinuity, as dyadic sub-steps: a sub-step that still holds one
    is halved, down to h/2^REFINE_DEPTH. A fixed-step RK4 across the discontinuous right-hand side of the
    velocity limit makes the state after the step jump by ~h²·La as the switching crosses a stage; this
    leaves jumps ~4^−REFINE_DEPTH times smaller, so the steady state and the fit's cost are smooth."""
    full = 1 << REFINE_DEPTH
    pos = 0
    level = 1
    while pos < full:
        size = full >> level
        hs = h * size / full
        ts = t0 + h * pos / full
        u0 = amplitude * math.sin(w * ts)
        um = amplitude * math.sin(w * (ts + 0.5 * hs))
        u1 = amplitude * math.sin(w * (ts + hs))
        xn, vn, switched, _ = _rk4_step(p, xs, vs, u0, um, u1, hs, lv)
        if switched and level < REFINE_DEPTH:
            level += 1
            continue
        xs, vs = xn, vn
        pos += size
        while level > 1 and pos % (2 * size) == 0:     # back to the coarser sub-step once aligned with it
            level -= 1
            size *= 2
    return xs, vs


@jit
def _half_period(p, amplitude, sin_tab, w, h, xs, vs, xbuf):
    """RK4 over half a period of u = amplitude·sin(ωt) from (xs, vs) at t = 0 (steps holding a discontinuity
    of the model refined, :func:`_refined_step`); ``sin_tab[i]`` is sin(ωt) at t = i·h/2, ``xbuf[j]`` receives
    x̄s at t = j·h (j = 0..n). Returns the end state, the largest |x̄s| sampled and whether any limit
    acted (if none, the model was linear throughout)."""
    lv = p[LV]
    n = xbuf.shape[0] - 1
    xbuf[0] = xs
    peak = abs(xs)
    nonlinear = False
    for j in range(n):
        xn, vn, switched, limited = _rk4_step(p, xs, vs, amplitude * sin_tab[2 * j], amplitude * sin_tab[2 * j + 1],
                                              amplitude * sin_tab[2 * j + 2], h, lv)
        if switched:
            xn, vn = _refined_step(p, amplitude, w, j * h, h, xs, vs, lv)
        nonlinear = nonlinear or limited
        xs, vs = xn, vn
        xbuf[j + 1] = xs
        peak = max(peak, abs(xs))
    return xs, vs, peak, nonlinear


@jit(inline=True)
def _period_sample(xa, xb, k):
    """Sample k (cyclic) of one period made of the half period ``xa`` then the negation of ``xb``."""
    n = xa.shape[0] - 1
    k = k % (2 * n)
    return xa[k] if k < n else -xb[k - n]


@jit(inline=True)
def _parabola_peak(ym, y0, yp):
    """Extreme of the parabola through three equally spaced samples (y0 if they are collinear)."""
    curv = ym - 2.0 * y0 + yp
    if curv == 0.0:
        return y0
    return y0 - 0.125 * (ym - yp) * (ym - yp) / curv


@jit
def _amplitude_and_phase(xa, xb, sin_tab, cos_tab):
    """(half peak-to-peak, phase of the fundamental [rad]) of x̄s over one period: the half period ``xa``
    (samples at t = j·h, j = 0..n, in the frame of the input u = A·sin ωt) followed by the half period
    ``xb`` simulated in the negated frame (its input was −u); for a half-wave symmetric response
    ``xb`` is ``xa``. Maximum and minimum are refined by a parabola through the three samples around them."""
    n = xa.shape[0] - 1
    kmax = 0
    kmin = 0
    for k in range(1, 2 * n):
        y = _period_sample(xa, xb, k)
        if y > _period_sample(xa, xb, kmax):
            kmax = k
        if y < _period_sample(xa, xb, kmin):
            kmin = k
    hi = _parabola_peak(_period_sample(xa, xb, kmax - 1), _period_sample(xa, xb, kmax),
                        _period_sample(xa, xb, kmax + 1))
    lo = _parabola_peak(_period_sample(xa, xb, kmin - 1), _period_sample(xa, xb, kmin),
                        _period_sample(xa, xb, kmin + 1))
    c_sin = 0.0
    c_cos = 0.0
    for j in range(n):          # second half: (−xb)·(−sin), (−xb)·(−cos)
        c_sin += (xa[j] + xb[j]) * sin_tab[2 * j]
        c_cos += (xa[j] + xb[j]) * cos_tab[2 * j]
    return 0.5 * (hi - lo), math.atan2(c_cos, c_sin)


@jit
def steady_sine_response(p, amplitude, freq, spp, tol, max_half_periods):
    """Periodic steady state of the spool model (SPEC §3.1) driven by u = amplitude·sin(2πft), as a
    datasheet Bode point shows it (SPEC §9.1): (half peak-to-peak output, phase of the fundamental [rad],
    half periods simulated, residual: the estimated distance to the periodic state, relative to the output
    amplitude; > tol when ``max_half_periods`` was hit).

    The model is odd (``spool_derivatives(−x, −v, −u) = −spool_derivatives(x, v, u)``: symmetric limits) and
    u(t + T/2) = −u(t), so one period is two applications of the half-period map H(s) = −Φ_{T/2}(s) of the
    state s = (x̄s, v̄s), and a half-wave symmetric periodic response is a fixed point of H.

    1. From rest, half periods are simulated until one ends where it began (sign flipped):
       |H(s) − s| <= tol·A_out in (x̄s, v̄s/ω). The first PLAIN_HALF_PERIODS run as they come (the sine
       switched on at rest). Under velocity saturation the rest of the transient decays over tens to
       hundreds of periods (the offset is only corrected while the spool is not saturated): once a half
       period shrinks the residual by less than 1/SLOW_CONTRACTION, each next start is extrapolated by a
       secant step through the last two iterates (Anderson mixing, memory 1). A fixed point reached by
       plain simulation attracts; one reached by extrapolation is accepted only if it does (spectral
       radius of the Jacobian of H, by finite differences, < 1): a measurement never shows an unstable
       periodic response. Measured against a plain simulation from rest for 1500 periods (200 random
       points, ωn 500–2000 rad/s, ξ 0.3–1, Lv 50–400 1/s, La 2e4–3e5 1/s², 3–60 %, 10–300 Hz): the same
       gain within 5e-9 dB and phase within 7e-8°, after a median 7 and at most 26 half periods.
    2. Otherwise (no such fixed point within ACCEL_HALF_PERIODS, or a repelling one: lightly damped,
       strongly acceleration-limited spools can have several periodic responses, or a subharmonic one),
       the sine is simulated from rest period by period until two successive periods agree: the
       difference d_k of the states at successive period starts, with the contraction λ = d_k/d_{k−1},
       bounds the distance to the periodic state by d_k·max(1, λ/(1 − λ)) <= tol.
    The amplitude and phase are those of the last simulated (half) period."""
    n = spp // 2
    h = 1.0 / (freq * spp)
    w = 2.0 * math.pi * freq
    sin_tab = np.empty(spp + 1)
    cos_tab = np.empty(spp + 1)
    for i in range(spp + 1):
        sin_tab[i] = math.sin(math.pi * i / spp)
        cos_tab[i] = math.cos(math.pi * i / spp)
    xa = np.empty(n + 1)
    xb = np.empty(n + 1)
    lv = p[LV]
    # 1. the sine from rest, half period by half period; the slow tail secant-accelerated
    x = 0.0
    v = 0.0
    px = pv = pfx = pfv = 0.0
    r_prev = math.inf
    accel = False
    used = 0
    for it in range(1, min(ACCEL_HALF_PERIODS, max_half_periods - 2) + 1):
        ex, ev, peak, nonlinear = _half_period(p, amplitude, sin_tab, w, h, x, v, xa)
        used += 1
        gx, gv = -ex, -ev
        fx = gx - x
        fv = (gv - v) / w
        resid = math.sqrt(fx * fx + fv * fv) / max(peak, 1e-300)
        if resid <= tol:
            a_out, ph = _amplitude_and_phase(xa, xa, sin_tab, cos_tab)
            if not (accel and nonlinear):          # reached by simulation, or the model was linear
                return a_out, ph, used, resid
            d = 1e-6 * peak                        # Jacobian of H in (x, v/ω), forward differences
            e1x, e1v, _, _ = _half_period(p, amplitude, sin_tab, w, h, x + d, v, xb)
            e2x, e2v, _, _ = _half_period(p, amplitude, sin_tab, w, h, x, v + d * w, xb)
            used += 2
            j11 = (-e1x - gx) / d
            j21 = (-e1v - gv) / (w * d)
            j12 = (-e2x - gx) / d
            j22 = (-e2v - gv) / (w * d)
            tr = j11 + j22
            det = j11 * j22 - j12 * j21
            disc = tr * tr - 4.0 * det
            rho = 0.5 * (abs(tr) + math.sqrt(disc)) if disc >= 0.0 else math.sqrt(abs(det))
            if rho < 1.0:
                return a_out, ph, used, resid
            break
        if it >= PLAIN_HALF_PERIODS and resid > SLOW_CONTRACTION * r_prev:
            accel = True
        nx, nv = gx, gv
        if accel:                       # secant (Anderson-1) step on f(s) = H(s) − s, scaled (x, v/ω)
            dfx = fx - pfx
            dfv = fv - pfv
            den = dfx * dfx + dfv * dfv
            if den > 0.0:
                gam = (fx * dfx + fv * dfv) / den
                nx = gx - gam * ((x - px) + dfx)
                nv = gv - gam * ((v - pv) + dfv * w)
        px, pv, pfx, pfv = x, v, fx, fv
        r_prev = resid
        x = nx
        v = min(max(nv, -lv), lv)
    # 2. plain simulation from rest, period by period, until two successive periods agree
    x = 0.0
    v = 0.0
    d_prev = math.inf
    a_out = 0.0
    ph = 0.0
    err = math.inf
    while used + 2 <= max_half_periods:
        mx, mv, _, _ = _half_period(p, amplitude, sin_tab, w, h, x, v, xa)
        ex, ev, _, _ = _half_period(p, amplitude, sin_tab, w, h, -mx, -mv, xb)   # = H(H(s)) negated
        ex, ev = -ex, -ev
        used += 2
        a_out, ph = _amplitude_and_phase(xa, xb, sin_tab, cos_tab)
        dx = ex - x
        dv = (ev - v) / w
        d = math.sqrt(dx * dx + dv * dv) / max(a_out, 1e-300)
        lam = d / d_prev
        err = math.inf if lam >= 1.0 else d * max(1.0, lam / (1.0 - lam))
        if err <= tol:
            break
        d_prev = d
        x, v = ex, ev
    return a_out, ph, used, err


@jit(inline=True)
def steps_per_period(freq):
    """RK4 steps per period at ``freq`` [Hz]: h <= H_MAX, at least STEPS_PER_PERIOD_MIN, even."""
    spp = max(STEPS_PER_PERIOD_MIN, int(math.ceil(1.0 / (freq * H_MAX))))
    return spp + (spp & 1)


@jit(parallel=True)
def bode_points(p, amplitude, freq, max_periods, out_gain, out_phase, out_half_periods, out_resid):
    """Steady-state gain [dB] and phase [deg, wrapped] of the undelayed spool model at each
    (amplitude, freq), with the half periods simulated and the periodicity residual of each point."""
    for i in prange(amplitude.shape[0]):
        f = freq[i]
        spp = steps_per_period(f)
        a_out, ph, n_half, resid = steady_sine_response(p, amplitude[i], f, spp, STEADY_TOL, 2 * max_periods)
        out_gain[i] = 20.0 * math.log10(max(a_out, 1e-12) / amplitude[i])
        out_phase[i] = ph * 180.0 / math.pi
        out_half_periods[i] = n_half
        out_resid[i] = resid


def spool_vector(wn: float, xi: float, lv: float, la: float) -> np.ndarray:
    p = np.zeros(NP)
    p[WN], p[XI], p[LV], p[LA] = wn, xi, lv, la
    return p


@dataclass(frozen=True)
class SteadyBode:
    """Steady-state Bode points of the spool model (incl. delay): gain [dB], phase [deg, unwrapped along
    each amplitude curve], half periods simulated per point and the periodicity residual of the accepted
    half period (> STEADY_TOL: the point hit the cap on periods)."""

    gain_db: np.ndarray
    phase_deg: np.ndarray
    half_periods: np.ndarray
    residual: np.ndarray

    @property
    def at_cap(self) -> np.ndarray:
        return ~(self.residual <= STEADY_TOL)


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
    g = np.empty(amplitude.size)
    ph = np.empty(amplitude.size)
    n_half = np.empty(amplitude.size, np.int64)
    resid = np.empty(amplitude.size)
    bode_points(spool_vector(wn, xi, lv, la), amplitude, freq, int(max_periods), g, ph, n_half, resid)
    return SteadyBode(g, unwrap_curves(amplitude, freq, ph - 360.0 * freq * delay), n_half, resid)


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


def _initial_guesses(a, f, g) -> list[np.ndarray]:
    """Starting points from the data: ωn from the −3 dB point of the smallest-amplitude curve, Lv and
    La from the largest sine velocity/acceleration the data show."""
    small = a == a.min()
    fs, gs = f[small], g[small]
    order = np.argsort(fs)
    below = np.flatnonzero(gs[order] < -3.0)
    f3 = fs[order][below[0]] if below.size else 2 * fs.max()
    wn0 = 2 * np.pi * f3
    a_out = a * 10 ** (g / 20)
    lv0 = max(2 * np.pi * np.max(f * a_out), 1e-3)
    la0 = max(np.max((2 * np.pi * f) ** 2 * a_out), 1e-3)
    starts = []
    for xi0 in (0.5, 0.8, 0.3):
        for s in (1.0, 0.6):
            starts.append(np.log([wn0, xi0, lv0 * s, la0 * s]))
    return starts


def identify_spool(data: dict[str, np.ndarray] | str | Path, *, progress=None,
                   max_periods: int = MAX_PERIODS) -> Fit:
    """Fit (ωn, ξ, Lv, La) to the gain curves by eq 2, then Δt to the phase curves. ``data`` holds the
    columns of :data:`COLUMNS` or is the path of such a CSV file. Every model point is a periodic
    steady state (:func:`steady_sine_response`, at most ``max_periods`` periods); ``achieved`` counts
    the points that hit that cap, in the fitted model and during the search."""
    t0 = time.perf_counter()
    if int(max_periods) < 2:
        raise InputError(f"must be >= 2, got {max_periods!r}", key="max_periods")
    max_periods = int(max_periods)
    d = read_bode(data) if isinstance(data, (str, Path)) else data
    a, f = np.asarray(d["amplitude"], float), np.asarray(d["frequency_hz"], float)
    g_data = np.asarray(d["gain_db"], float)
    ph_data = unwrap_curves(a, f, np.asarray(d["phase_deg"], float))
    sw = np.sqrt(_weights(a))
    g = np.empty(a.size)
    ph = np.empty(a.size)
    n_half = np.empty(a.size, np.int64)
    resid = np.empty(a.size)
    search = {"evaluations": 0, "points_at_cap": 0}

    def residuals(theta):
        wn, xi, lv, la = np.exp(theta)
        bode_points(spool_vector(wn, xi, lv, la), a, f, max_periods, g, ph, n_half, resid)
        search["evaluations"] += 1
        search["points_at_cap"] += int(np.count_nonzero(~(resid <= STEADY_TOL)))
        return sw * (g - g_data)   # 0.5*sum(r^2) = F of eq 2

    best = None
    starts = _initial_guesses(a, f, g_data)
    lo, hi = np.log(SEARCH_BOUNDS[0]), np.log(SEARCH_BOUNDS[1])
    for i, x0 in enumerate(starts):
        sol = least_squares(residuals, np.clip(x0, lo + 1e-9, hi - 1e-9), method="trf", bounds=(lo, hi),
                            x_scale=1.0, diff_step=1e-4, xtol=1e-10, ftol=1e-12, max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
        if progress:
            progress(i + 1, len(starts))
    wn, xi, lv, la = (float(v) for v in np.exp(best.x))
    # delay: weighted linear least squares on phase (same weights as eq 2)
    m0 = simulate_bode(wn, xi, lv, la, 0.0, a, f, max_periods)
    w = _weights(a)
    delay = float(np.sum(w * f * (m0.phase_deg - ph_data)) / (360.0 * np.sum(w * f * f)))
    delay = max(delay, 0.0)
    ph_fit = unwrap_curves(a, f, m0.phase_deg - 360.0 * f * delay)
    phase_cost = float(0.5 * np.sum(w * (ph_fit - ph_data) ** 2))
    res_g = m0.gain_db - g_data
    # the model on a dense log grid (Fig 4 draws it as curves, the data as markers)
    fd = np.geomspace(f.min(), f.max(), DENSE_POINTS)
    ad = np.repeat(np.unique(a), fd.size)
    fd = np.tile(fd, np.unique(a).size)
    dense = simulate_bode(wn, xi, lv, la, delay, ad, fd, max_periods)
    at_cap = int(np.count_nonzero(m0.at_cap))
    values = {"wn": wn, "xi": xi, "lv": lv, "la": la, "delay": delay}
    notes = [f"{name} = {v:.4g} at the bound of the search [{b_lo:g}, {b_hi:g}]"
             for name, v, b_lo, b_hi in zip(("wn", "xi", "lv", "la"), (wn, xi, lv, la), *SEARCH_BOUNDS)
             if not b_lo * (1 + 1e-6) < v < b_hi * (1 - 1e-6)]
    if at_cap:
        notes.append(f"{at_cap} of {a.size} points of the fitted model not periodic after {max_periods} periods "
                     f"(residual up to {np.max(m0.residual):.2g}): their gain is that of the last simulated period")
    if search["points_at_cap"]:
        notes.append(f"{search['points_at_cap']} point evaluations hit the {max_periods}-period cap during the "
                     "search")
    fit = Fit("spool", values, cost=float(best.cost), notes=notes,
              updates={"spool.wn": wn, "spool.xi": xi, "spool.lv": lv, "spool.la": la, "spool.delay": delay},
              achieved={"gain_rms_db": float(np.sqrt(np.mean(res_g ** 2))),
                        "gain_max_abs_db": float(np.max(np.abs(res_g))),
                        "phase_rms_deg": float(np.sqrt(np.mean((ph_fit - ph_data) ** 2))),
                        "phase_cost": phase_cost,
                        "points_at_cap": at_cap,
                        "periods_max": float(np.max(m0.half_periods)) / 2,
                        "search_evaluations": search["evaluations"],
                        "search_points_at_cap": search["points_at_cap"]},
              curves={"amplitude": a, "frequency_hz": f, "gain_db": g_data, "phase_deg": ph_data,
                      "gain_fit": m0.gain_db, "phase_fit": ph_fit,
                      "model_amplitude": ad, "model_frequency_hz": fd, "model_gain_db": dense.gain_db,
                      "model_phase_deg": dense.phase_deg})
    fit.wall_time_s = time.perf_counter() - t0
    return fit


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
