"""Spool dynamics from datasheet Bode curves (paper §3.1.1, eq 2; SPEC §9.1).

The model is the limited second-order spool of SPEC §3.1 (the same ``spool_derivatives`` the plant
uses). For each (amplitude, frequency) of the data it is driven by a sine; the gain is
G = 20·log10(A_out/A_in) with A_out the half peak-to-peak output over the last periods (what a datasheet
plots), the phase that of the output's fundamental. (ωn, ξ, Lv, La) minimise eq 2:
F = Σ_curves w·Σ_n (G_sim − G_data)²/2 with w = 4 on the smallest amplitude and 1 on the others.
The pure delay Δt only shifts the phase by −360·f·Δt degrees, so once the gain fit is done, Δt follows
from the same weighted least squares on the phase in closed form.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from numba import prange
from scipy.optimize import least_squares

from hydrohil._jit import jit
from hydrohil.errors import InputError
from hydrohil.identification.data import Column, read_table
from hydrohil.identification.result import Fit
from hydrohil.models.layout import LA, LV, NP, WN, XI
from hydrohil.models.valve import spool_derivatives

COLUMNS = (
    Column("amplitude", "fraction of full input", 1e-4, 1.0, "5 % of full input is 0.05, not 5"),
    Column("frequency_hz", "Hz", 0.1, 1e4),
    Column("gain_db", "dB", -80.0, 20.0),
    Column("phase_deg", "deg", -1080.0, 180.0),
)
SMALL_AMPLITUDE_WEIGHT = 4.0   # eq 2
H_MAX = 2e-5                   # s, largest internal step of the sine-response simulation
STEPS_PER_PERIOD_MIN = 200
KEEP_PERIODS = 2               # periods evaluated after the transient


@jit
def sine_response(p, amplitude, freq, n_warm, n_keep, spp):
    """(half peak-to-peak output, phase of the fundamental [rad]) of the spool model driven by
    u = amplitude·sin(2πft) from rest; RK4 with ``spp`` steps per period, velocity clamped to ±Lv."""
    h = 1.0 / (freq * spp)
    w = 2.0 * math.pi * freq
    xs = 0.0
    vs = 0.0
    lv = p[LV]
    lo = 1e300
    hi = -1e300
    c_sin = 0.0
    c_cos = 0.0
    n_total = (n_warm + n_keep) * spp
    n_start = n_warm * spp
    for k in range(n_total):
        t = k * h
        u0 = amplitude * math.sin(w * t)
        um = amplitude * math.sin(w * (t + 0.5 * h))
        u1 = amplitude * math.sin(w * (t + h))
        d1x, d1v, _ = spool_derivatives(xs, vs, u0, p)
        d2x, d2v, _ = spool_derivatives(xs + 0.5 * h * d1x, vs + 0.5 * h * d1v, um, p)
        d3x, d3v, _ = spool_derivatives(xs + 0.5 * h * d2x, vs + 0.5 * h * d2v, um, p)
        d4x, d4v, _ = spool_derivatives(xs + h * d3x, vs + h * d3v, u1, p)
        xs += h / 6.0 * (d1x + 2.0 * d2x + 2.0 * d3x + d4x)
        vs += h / 6.0 * (d1v + 2.0 * d2v + 2.0 * d3v + d4v)
        vs = min(max(vs, -lv), lv)
        if k + 1 >= n_start:
            lo = min(lo, xs)
            hi = max(hi, xs)
            if k + 1 < n_total:
                c_sin += xs * math.sin(w * (t + h))
                c_cos += xs * math.cos(w * (t + h))
    return 0.5 * (hi - lo), math.atan2(c_cos, c_sin)


@jit(parallel=True)
def bode_points(p, amplitude, freq, out_gain, out_phase):
    """Gain [dB] and phase [deg, wrapped] of the undelayed spool model at each (amplitude, freq)."""
    for i in prange(amplitude.shape[0]):
        f = freq[i]
        spp = max(STEPS_PER_PERIOD_MIN, int(math.ceil(1.0 / (f * H_MAX))))
        n_warm = max(3, int(math.ceil(0.02 * f)))
        a_out, ph = sine_response(p, amplitude[i], f, n_warm, KEEP_PERIODS, spp)
        out_gain[i] = 20.0 * math.log10(max(a_out, 1e-12) / amplitude[i])
        out_phase[i] = ph * 180.0 / math.pi


def spool_vector(wn: float, xi: float, lv: float, la: float) -> np.ndarray:
    p = np.zeros(NP)
    p[WN], p[XI], p[LV], p[LA] = wn, xi, lv, la
    return p


def simulate_bode(wn, xi, lv, la, delay, amplitude, freq) -> tuple[np.ndarray, np.ndarray]:
    """(gain_db, phase_deg) of the spool model incl. delay; phases unwrapped along each amplitude curve."""
    amplitude = np.asarray(amplitude, float)
    freq = np.asarray(freq, float)
    g = np.empty(amplitude.size)
    ph = np.empty(amplitude.size)
    bode_points(spool_vector(wn, xi, lv, la), amplitude, freq, g, ph)
    return g, unwrap_curves(amplitude, freq, ph - 360.0 * freq * delay)


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


def identify_spool(data: dict[str, np.ndarray] | str | Path, *, progress=None) -> Fit:
    """Fit (ωn, ξ, Lv, La) to the gain curves by eq 2, then Δt to the phase curves. ``data`` holds the
    columns of :data:`COLUMNS` or is the path of such a CSV file."""
    t0 = time.perf_counter()
    d = read_bode(data) if isinstance(data, (str, Path)) else data
    a, f = np.asarray(d["amplitude"], float), np.asarray(d["frequency_hz"], float)
    g_data = np.asarray(d["gain_db"], float)
    ph_data = unwrap_curves(a, f, np.asarray(d["phase_deg"], float))
    sw = np.sqrt(_weights(a))
    g = np.empty(a.size)
    ph = np.empty(a.size)

    def residuals(theta):
        wn, xi, lv, la = np.exp(theta)
        bode_points(spool_vector(wn, xi, lv, la), a, f, g, ph)
        return sw * (g - g_data)   # 0.5*sum(r^2) = F of eq 2

    best = None
    starts = _initial_guesses(a, f, g_data)
    for i, x0 in enumerate(starts):
        sol = least_squares(residuals, x0, method="trf", x_scale=1.0, diff_step=1e-4, xtol=1e-10, ftol=1e-12,
                            max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
        if progress:
            progress(i + 1, len(starts))
    wn, xi, lv, la = (float(v) for v in np.exp(best.x))
    # delay: weighted linear least squares on phase (same weights as eq 2)
    g_fit, ph0 = simulate_bode(wn, xi, lv, la, 0.0, a, f)
    w = _weights(a)
    delay = float(np.sum(w * f * (ph0 - ph_data)) / (360.0 * np.sum(w * f * f)))
    delay = max(delay, 0.0)
    _, ph_fit = simulate_bode(wn, xi, lv, la, delay, a, f)
    phase_cost = float(0.5 * np.sum(w * (ph_fit - ph_data) ** 2))
    res_g = g_fit - g_data
    values = {"wn": wn, "xi": xi, "lv": lv, "la": la, "delay": delay}
    fit = Fit("spool", values, cost=float(best.cost),
              updates={"spool.wn": wn, "spool.xi": xi, "spool.lv": lv, "spool.la": la, "spool.delay": delay},
              achieved={"gain_rms_db": float(np.sqrt(np.mean(res_g ** 2))),
                        "gain_max_abs_db": float(np.max(np.abs(res_g))),
                        "phase_rms_deg": float(np.sqrt(np.mean((ph_fit - ph_data) ** 2))),
                        "phase_cost": phase_cost},
              curves={"amplitude": a, "frequency_hz": f, "gain_db": g_data, "phase_deg": ph_data,
                      "gain_fit": g_fit, "phase_fit": ph_fit})
    fit.wall_time_s = time.perf_counter() - t0
    return fit


def synthetic_bode(wn, xi, lv, la, delay, amplitudes=(0.05, 0.25, 0.5), freqs=np.arange(10.0, 301.0, 10.0),
                   noise_db=0.0, noise_deg=0.0, seed=0) -> dict[str, np.ndarray]:
    """Bode 'datasheet' curves of the spool model with known parameters (+ optional Gaussian noise)."""
    a = np.repeat(np.asarray(amplitudes, float), len(freqs))
    f = np.tile(np.asarray(freqs, float), len(amplitudes))
    g, ph = simulate_bode(wn, xi, lv, la, delay, a, f)
    rng = np.random.default_rng(seed)
    return {"amplitude": a, "frequency_hz": f, "gain_db": g + noise_db * rng.standard_normal(a.size),
            "phase_deg": ph + noise_deg * rng.standard_normal(a.size)}
