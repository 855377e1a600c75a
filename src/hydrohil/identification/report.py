"""Fit-report figures: data vs identified model, one PNG per procedure (paper Figs 4, 5, 7-10)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter  # noqa: E402
import numpy as np  # noqa: E402

from hydrohil.identification.bulk_modulus import beta_eq21  # noqa: E402
from hydrohil.identification.friction_static import stribeck_curve  # noqa: E402
from hydrohil.identification.result import Fit  # noqa: E402
from hydrohil.models import valve  # noqa: E402


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_spool(fit: Fit, out: Path) -> list[Path]:
    """Fig 4: Bode gain and phase per input amplitude on a log frequency axis: the datasheet points as
    markers, the fitted model (periodic steady state, delay included) as curves on a dense log grid."""
    c = fit.curves
    fig, ax = plt.subplots(2, 1, figsize=(8, 8), sharex=True)
    for i, a in enumerate(np.unique(c["amplitude"])):
        col = f"C{i}"
        m = c["amplitude"] == a
        ax[0].plot(c["frequency_hz"][m], c["gain_db"][m], "o", color=col, ms=4, mfc="none", label=f"data {a:.0%}")
        ax[1].plot(c["frequency_hz"][m], c["phase_deg"][m], "o", color=col, ms=4, mfc="none")
        md = c["model_amplitude"] == a
        o = np.argsort(c["model_frequency_hz"][md])
        fd = c["model_frequency_hz"][md][o]
        ax[0].plot(fd, c["model_gain_db"][md][o], "-", color=col, lw=1.2, label=f"model {a:.0%}")
        ax[1].plot(fd, c["model_phase_deg"][md][o], "-", color=col, lw=1.2)
    v = fit.values
    ax[0].set_title(f"spool: ωn = {v['wn']:.1f} rad/s, ξ = {v['xi']:.3f}, Lv = {v['lv']:.1f} 1/s, "
                    f"La = {v['la']:.4g} 1/s², Δt = {v['delay'] * 1e3:.3f} ms\n"
                    f"gain RMS {fit.achieved['gain_rms_db']:.2f} dB, phase RMS {fit.achieved['phase_rms_deg']:.1f}°; "
                    "model at its periodic steady state", fontsize=9)
    ax[0].set_ylabel("gain [dB]")
    ax[1].set_ylabel("phase [deg]")
    ax[1].set_xlabel("frequency [Hz]")
    ax[1].set_xscale("log")
    ax[1].xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0)))
    ax[1].xaxis.set_major_formatter(ScalarFormatter())
    ax[1].xaxis.set_minor_formatter(NullFormatter())
    for a in ax:
        a.grid(alpha=0.3, which="both")
    ax[0].legend(fontsize=8, ncol=2)
    return [_save(fig, out / "fig4_spool_bode.png")]


def plot_valve_static(fit: Fit, out: Path) -> list[Path]:
    """Fig 5a-c: closed-port relative pressures and load flow near centre; load flow over the stroke."""
    k, kt, ps = fit.curves["k"], fit.curves["kt"], fit.curves["ps_bar"]
    tg = fit.curves["targets"]
    x = np.linspace(-0.06, 0.06, 601)
    p1, p2 = valve.closed_port_pressures(x, k, kt)
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    ax[0].plot(x * 100, p1 * ps, label="P1")
    ax[0].plot(x * 100, p2 * ps, label="P2")
    cross = ps / 2 + tg["dpm_bar"]
    ax[0].axhline(cross, color="k", ls=":", lw=1, label=f"target crossing {cross:.1f} bar")
    ax[0].set_xlabel("spool x̄s [%]")
    ax[0].set_ylabel("pressure [bar]")
    ax[0].set_title("(a) closed-port pressures")
    ql = valve.load_flow(x, ps, k, kt)
    ax[1].plot(x * 100, ql, label="model Q_L (eq 7)")
    ax[1].plot(x * 100, tg["kq0_lpm"] * x, "k:", label=f"target K̄q0 = {tg['kq0_lpm']:g} l/min")
    ax[1].set_xlabel("spool x̄s [%]")
    ax[1].set_ylabel("load flow [l/min]")
    ax[1].set_title("(b) load flow near centre")
    xf = np.linspace(-1, 1, 401)
    ax[2].plot(xf, valve.load_flow(xf, ps, k, kt), label="model Q_L")
    ax[2].plot([-1.0, 1.0], valve.load_flow(np.array([-1.0, 1.0]), ps, k, kt), "o", label="full opening")
    ax[2].set_xlabel("spool x̄s [-]")
    ax[2].set_ylabel("load flow [l/min]")
    ax[2].set_title(f"(c) load flow, Ps = {ps:g} bar")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    return [_save(fig, out / "fig5_valve_static.png")]


def plot_bulk_modulus(fit: Fit, out: Path) -> list[Path]:
    """Fig 7 (acceleration vs frequency per supply pressure) and Fig 8 (βe vs pressure, eq 21)."""
    paths = []
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, (ps, c) in enumerate((k, v) for k, v in fit.curves.items() if k != "eq21"):
        ax.plot(c["frequency_hz"], c["accel"], "o", ms=3, color=f"C{i}", label=f"data Ps = {ps / 1e5:g} bar")
        ax.plot(c["fit_f"], c["fit_a"], "-", color=f"C{i}",
                label=f"linear model (fn = {c['natural_frequency_hz']:.1f} Hz)")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("acceleration amplitude [m/s² per unit x̄s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    paths.append(_save(fig, out / "fig7_acceleration.png"))
    if "eq21" in fit.curves:
        e = fit.curves["eq21"]
        fig, ax = plt.subplots(figsize=(7, 5))
        ax.plot(e["p"] / 1e5, e["beta"] / 1e6, "o", label="identified βe (per chamber and Ps)")
        pp = np.linspace(0, max(e["p"]) * 1.1, 200)
        ax.plot(pp / 1e5, beta_eq21(pp, e["b"], e["c"]) / 1e6, "-", label=f"eq 21: B = {e['b']:.3g}, C = {e['c']:.3g}")
        ax.set_xlabel("chamber pressure [bar]")
        ax.set_ylabel("βe [MPa]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        paths.append(_save(fig, out / "fig8_bulk_modulus.png"))
    return paths


def plot_friction_static(fit: Fit, out: Path) -> list[Path]:
    """Fig 9: measured steady-state friction vs symmetric and asymmetric eq-25 curves."""
    v, ff = fit.curves["v"], fit.curves["ff"]
    vv = np.linspace(v.min(), v.max(), 801)
    vv = vv[vv != 0]
    s, p, n = fit.values["symmetric"], fit.values["positive"], fit.values["negative"]
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(v, ff, "o", ms=4, label="data")
    ax.plot(vv, stribeck_curve(vv, **s), "-", label=f"symmetric (RMS {fit.achieved['rms_symmetric_n']:.1f} N)")
    ax.plot(vv, np.where(vv > 0, stribeck_curve(vv, **p), stribeck_curve(vv, **n)), "--",
            label=f"asymmetric (RMS {fit.achieved['rms_positive_n']:.1f} / {fit.achieved['rms_negative_n']:.1f} N)")
    ax.set_xlabel("velocity [m/s]")
    ax.set_ylabel("friction force [N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return [_save(fig, out / "fig9_friction_static.png")]


def plot_friction_dynamic(fit: Fit, out: Path) -> list[Path]:
    """Fig 10-style: measured vs simulated hydraulic force and position of the open-loop experiment."""
    c = fit.curves
    fig, ax = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    ax[0].plot(c["t"], c["fh"], lw=1, label="measured Fh = P1·A1 − P2·A2")
    ax[0].plot(c["t"], c["fh_fit"], lw=1,
               label=f"model, σ0 = {fit.values['sigma0']:.3g}, σ1 = {fit.values['sigma1']:.3g}")
    if c.get("fh_start") is not None:
        ax[0].plot(c["t"], c["fh_start"], ":", lw=1, label="model with the starting σ0, σ1")
    ax[1].plot(c["t"], np.asarray(c["xp"]) * 1e3, lw=1, label="measured xp")
    ax[1].plot(c["t"], np.asarray(c["xp_fit"]) * 1e3, lw=1, label="model xp")
    ax[0].set_ylabel("hydraulic force [N]")
    ax[1].set_ylabel("position [mm]")
    ax[1].set_xlabel("time [s]")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    return [_save(fig, out / "fig10_friction_dynamic.png")]


def plot_leakage(fit: Fit, out: Path) -> list[Path]:
    c = fit.curves
    if not c:
        return []
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(c["t"], np.asarray(c["xp"]) * 1e6, ".", ms=3, label="measured xp")
    ax.plot(c["t"], np.asarray(c["fit"]) * 1e6, "-", label=f"line: v = {fit.values['v_ps'] * 1e6:.3f} µm/s")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position [µm]")
    ax.set_title(f"drift test: g_lkc = {fit.values['g_lkc']:.4g} m³/(s·Pa)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return [_save(fig, out / "leakage_drift.png")]


PLOTS = {"spool": plot_spool, "valve-static": plot_valve_static, "bulk-modulus": plot_bulk_modulus,
         "leakage": plot_leakage, "friction-static": plot_friction_static, "friction-dynamic": plot_friction_dynamic}


def write_report(fit: Fit, out: str | Path) -> list[Path]:
    """Write the figures of ``fit`` into folder ``out`` (created); returns the files written."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    return PLOTS[fit.procedure](fit, out)
