"""Fit-report figures: data vs identified model, one PNG per procedure (paper Figs 4, 5, 7-10)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter  # noqa: E402
import numpy as np  # noqa: E402

from hydrohil.identification.bulk_modulus import beta_eq21  # noqa: E402
from hydrohil.models.friction import steady_state_friction  # noqa: E402
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
    v, ni = fit.values, fit.not_identifiable
    limit = {k: (f"{sym} not identifiable (data need ≥ {ni[k]['needs_at_least']:.4g} {unit}; set to "
                 f"{v[k]:.4g} {unit}, never binding)" if k in ni else f"{sym} = {v[k]:.4g} {unit}")
             for k, sym, unit in (("lv", "Lv", "1/s"), ("la", "La", "1/s²"))}
    ax[0].set_title(f"spool: ωn = {v['wn']:.1f} rad/s, ξ = {v['xi']:.3f}, Δt = {v['delay'] * 1e3:.3f} ms\n"
                    f"{limit['lv']}\n{limit['la']}\n"
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
    ax.plot(vv, steady_state_friction(vv, **s), "-", label=f"symmetric (RMS {fit.achieved['rms_symmetric_n']:.1f} N)")
    ax.plot(vv, np.where(vv > 0, steady_state_friction(vv, **p), steady_state_friction(vv, **n)), "--",
            label=f"asymmetric (RMS {fit.achieved['rms_positive_n']:.1f} / {fit.achieved['rms_negative_n']:.1f} N)")
    ax.set_xlabel("velocity [m/s]")
    ax.set_ylabel("friction force [N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return [_save(fig, out / "fig9_friction_static.png")]


def _busiest_window(t, y, width: float, skip: float) -> tuple[float, float]:
    """(start, end) of the ``width``-second window, after the first ``skip`` seconds, where ``y`` varies
    most (largest standard deviation): the stick-slip ringing of the open-loop sine."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    starts = t[(t >= t[0] + skip) & (t <= t[-1] - width)]
    if len(starts) == 0:
        return float(t[0]), float(t[-1])
    best = max(starts, key=lambda a: float(np.std(y[(t >= a) & (t < a + width)])))
    return float(best), float(best + width)


def plot_friction_dynamic(fit: Fit, out: Path) -> list[Path]:
    """Fig 10-style fit of eq 27: measured vs fitted hydraulic force over the run, a zoom on the stick-slip
    ringing (where the samples can be told apart), the force residual, and the piston position."""
    c = fit.curves
    t, fh, fit_fh = np.asarray(c["t"], float), np.asarray(c["fh"], float), np.asarray(c["fh_fit"], float)
    rms = lambda e: float(np.sqrt(np.mean(np.square(e))))  # noqa: E731
    s0, s1 = fit.values["sigma0"], fit.values["sigma1"]
    fig = plt.figure(figsize=(10, 11))
    gs = fig.add_gridspec(4, 1, height_ratios=[2.2, 2.2, 1.6, 1.6])
    full = fig.add_subplot(gs[0])
    zoom = fig.add_subplot(gs[1])
    res = fig.add_subplot(gs[2], sharex=full)
    pos = fig.add_subplot(gs[3], sharex=full)
    full.plot(t, fh, lw=0.8, color="C0", label="measured Fh = P1·A1 − P2·A2")
    full.plot(t, fit_fh, lw=0.8, color="C1", alpha=0.8,
              label=f"model, identified σ0 = {s0:.3g} N/m, σ1 = {s1:.3g} N·s/m")
    w0, w1 = _busiest_window(t, fh, width=min(0.3, (t[-1] - t[0]) / 4), skip=0.2)
    full.axvspan(w0, w1, color="0.5", alpha=0.2, label="zoomed below")
    full.set_title("(a) hydraulic force over the run", fontsize=10, loc="left")
    m = (t >= w0) & (t <= w1)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    zoom.plot(t[m], fh[m], "o-", ms=3, lw=0.8, color="C0", label=f"measured ({dt * 1e3:.3g} ms samples)")
    zoom.plot(t[m], fit_fh[m], "s--", ms=3, lw=0.8, color="C1", label="model, identified σ0, σ1")
    zoom.set_title(f"(b) zoom {w0:.2f}–{w1:.2f} s: stick-slip ringing", fontsize=10, loc="left")
    zoom.set_xlabel("time [s]")
    res.plot(t, fh - fit_fh, lw=0.8, color="C3", label=f"measured − model (RMS {rms(fh - fit_fh):.1f} N)")
    if c.get("fh_start") is not None:
        res.plot([], [], " ", label=f"with the starting σ0, σ1: RMS {rms(fh - np.asarray(c['fh_start'])):.1f} N")
    res.axhline(0, color="k", lw=0.5)
    res.set_title("(c) force residual", fontsize=10, loc="left")
    pos.plot(t, np.asarray(c["xp"]) * 1e3, lw=1, color="C0", label="measured xp")
    pos.plot(t, np.asarray(c["xp_fit"]) * 1e3, "--", lw=1, color="C1", label="model xp")
    pos.set_title("(d) piston position", fontsize=10, loc="left")
    pos.set_xlabel("time [s]")
    for a, label, where in ((full, "force [N]", "upper right"), (zoom, "force [N]", "upper right"),
                            (res, "residual [N]", "upper right"), (pos, "position [mm]", "lower right")):
        a.set_ylabel(label)
        a.grid(alpha=0.3)
        a.legend(fontsize=8, loc=where)
    full.tick_params(labelbottom=False)
    res.tick_params(labelbottom=False)
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
