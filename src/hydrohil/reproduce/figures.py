"""Figures of the reproduce report that the identification report does not already draw."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hydrohil.reproduce.paper import PAPER  # noqa: E402


def _rms(a) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def plot_fig10(path: Path, rig, model, cylinder) -> dict:
    """Fig 10: open-loop sine, "rig" (continuous reference model) vs hybrid model with the identified
    σ0, σ1: hydraulic force, chamber pressures, spool, piston position and velocity. Returns the RMS
    differences (SI) and the path."""
    n = min(len(rig.log), len(model.log))
    t = rig.column("t")[:n]
    col = {name: (rig.column(name)[:n], model.column(name)[:n]) for name in ("p1", "p2", "xs", "xp", "vp")}
    fh = tuple(c[0] * cylinder.a1 - c[1] * cylinder.a2 for c in zip(col["p1"], col["p2"]))
    fig, ax = plt.subplots(5, 1, figsize=(10, 13), sharex=True)
    ax[0].plot(t, fh[0], lw=1, label="rig (continuous reference model)")
    ax[0].plot(t, fh[1], "--", lw=1, label="hybrid model, identified σ0, σ1")
    for name, lab in (("p1", "P1"), ("p2", "P2")):
        ax[1].plot(t, col[name][0] / 1e5, lw=1, label=f"{lab} rig")
        ax[1].plot(t, col[name][1] / 1e5, "--", lw=1, label=f"{lab} model")
    for a, name, scale in ((ax[2], "xs", 100.0), (ax[3], "xp", 1e3), (ax[4], "vp", 1e3)):
        a.plot(t, col[name][0] * scale, lw=1, label="rig")
        a.plot(t, col[name][1] * scale, "--", lw=1, label="model")
    labels = ("hydraulic force Fh [N]", "pressure [bar]", "spool x̄s [%]", "piston xp [mm]", "velocity vp [mm/s]")
    for a, lab in zip(ax, labels):
        a.set_ylabel(lab)
        a.grid(alpha=0.3)
        a.legend(fontsize=8, loc="best")
    ax[-1].set_xlabel("time [s]")
    fig.suptitle("Fig 10: open-loop sine, horizontal — synthetic rig (reference model) vs hybrid model")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return {"path": path, "fh_rms_n": _rms(fh[0] - fh[1]), "fh_amplitude_n": float(np.ptp(fh[0]) / 2),
            "p1_rms_bar": _rms(np.subtract(*col["p1"])) / 1e5, "p2_rms_bar": _rms(np.subtract(*col["p2"])) / 1e5,
            "xp_rms_mm": _rms(np.subtract(*col["xp"])) * 1e3, "vp_rms_mm_s": _rms(np.subtract(*col["vp"])) * 1e3}


def plot_step_sizes(path: Path, hybrid: dict, continuous: dict) -> Path:
    """Step-size comparison: RMS position error vs the LSODA reference for each trial step of the
    bisection, stable and unstable trials marked, with the paper's 0.5 ms and 2 µs."""
    fig, ax = plt.subplots(figsize=(9, 6))
    for i, (res, label) in enumerate(((hybrid, "hybrid model"), (continuous, "stiff end stops + continuous LuGre"))):
        c = f"C{i}"
        for tr in res["trials"]:
            err = tr.get("rms_x")
            y = err * 1e3 if err is not None and np.isfinite(err) else 1e2
            ax.plot(tr["step"], y, "o" if tr["stable"] else "x", color=c, ms=6)
        ax.axvline(res["max_stable_step"], color=c, lw=1.5,
                   label=f"{label}: largest stable step {res['max_stable_step']:.3g} s")
    ax.axvline(PAPER["step.hybrid"][0], color="k", ls=":", lw=1, label="paper: hybrid 0.5 ms")
    ax.axvline(PAPER["step.stiff"][0], color="k", ls="--", lw=1, label="paper: stiff model 2 µs")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("fixed step h [s] (RK3)")
    ax.set_ylabel("RMS position error vs LSODA [mm]\n(o: stable, x: unstable, at 100: diverged)")
    ax.set_title("Largest stable explicit step, end-stop impact scenario")
    ax.grid(alpha=0.3, which="both")
    # below the axes: inside, any corner covers a trial point (the hybrid 0.5 ms point sits bottom right)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
