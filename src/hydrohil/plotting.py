"""Figures (matplotlib, Agg backend): kept apart from the models."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hydrohil.models.layout import FRICTION_NAMES, TRAVEL_NAMES  # noqa: E402


def plot_run(path: Path, t, xp, p1, p2, u, xs, travel, friction, *, xref=None, title: str = "",
             compare: dict | None = None, faults=None) -> None:
    """Position (and reference), chamber pressures, command and spool, and the cylinder modes over time.

    ``compare`` optionally holds another run (keys t, xp, p1, p2, label) drawn dashed; ``faults`` (the
    per-row fault mask) shades the intervals with an injected fault.
    """
    fig, ax = plt.subplots(4, 1, figsize=(10, 10), sharex=True,
                           gridspec_kw={"height_ratios": [3, 3, 2, 1.5]})
    ax[0].plot(t, np.asarray(xp) * 1e3, label="piston xp")
    if xref is not None:
        ax[0].plot(t, np.asarray(xref) * 1e3, "k--", lw=1, label="reference")
    ax[1].plot(t, np.asarray(p1) / 1e5, label="P1")
    ax[1].plot(t, np.asarray(p2) / 1e5, label="P2")
    if compare:
        lab = compare.get("label", "other")
        ax[0].plot(compare["t"], np.asarray(compare["xp"]) * 1e3, ":", lw=1.5, label=f"xp ({lab})")
        ax[1].plot(compare["t"], np.asarray(compare["p1"]) / 1e5, ":", lw=1.5, label=f"P1 ({lab})")
        ax[1].plot(compare["t"], np.asarray(compare["p2"]) / 1e5, ":", lw=1.5, label=f"P2 ({lab})")
    ax[2].plot(t, u, lw=1, label="command ū")
    ax[2].plot(t, xs, lw=1, label="spool x̄s")
    _mode_strip(ax[3], t, travel, friction)
    _fault_spans(ax, t, faults)
    _finish(fig, path, ax, ("position [mm]", "pressure [bar]", "valve [-]", "mode"), ax[:3], title)


def _fault_spans(ax, t, faults) -> None:
    """Shade the time intervals where the fault mask is non-zero (injected faults) on every axis."""
    if faults is None:
        return
    t, on = np.asarray(t), np.asarray(faults) != 0
    if not on.any():
        return
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
    for a in ax:
        for i, (k0, k1) in enumerate(zip(edges[::2], edges[1::2])):
            a.axvspan(t[k0], t[min(k1, len(t) - 1)], color="red", alpha=0.08,
                      label="fault injected" if (i == 0 and a is ax[0]) else None)


def _mode_strip(ax, t, travel, friction) -> None:
    """Cylinder state diagram (Fig 11b style): travel and friction mode codes over time."""
    ax.step(t, np.asarray(travel), where="post", label="travel")
    ax.step(t, np.asarray(friction) + 3, where="post", label="friction")
    ax.set_yticks(range(6), [*TRAVEL_NAMES, *FRICTION_NAMES], fontsize=7)


def _finish(fig, path: Path, ax, ylabels, legend_axes, title: str) -> None:
    """Axis labels (time on the last axis), grid and legend on ``legend_axes``, title; save and close."""
    for a, label in zip(ax, ylabels):
        a.set_ylabel(label)
    ax[-1].set_xlabel("time [s]")
    for a in legend_axes:
        a.grid(alpha=0.3)
        a.legend(loc="best", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_hil(path: Path, hil: dict, offline, xref, *, title: str = "") -> None:
    """HIL report: reference vs HIL vs offline position, error, pressures, plant modes, step jitter."""
    t = np.asarray(hil["t"])
    n = min(len(t), len(offline.log))
    fig, ax = plt.subplots(5, 1, figsize=(10, 13), sharex=True,
                           gridspec_kw={"height_ratios": [3, 2, 3, 1.5, 1.5]})
    ax[0].plot(t[:n], np.asarray(xref[:n]) * 1e3, "k--", lw=1, label="reference")
    ax[0].plot(t, np.asarray(hil["xp"]) * 1e3, lw=1.5, label="HIL (real-time plant)")
    ax[0].plot(offline.column("t")[:n], offline.column("xp")[:n] * 1e3, ":", lw=1.5, label="offline simulation")
    ax[1].plot(t[:n], (np.asarray(hil["xp"][:n]) - np.asarray(xref[:n])) * 1e3, lw=1, label="HIL − reference")
    ax[1].plot(t[:n], (np.asarray(hil["xp"][:n]) - offline.column("xp")[:n]) * 1e3, lw=1, label="HIL − offline")
    ax[2].plot(t, np.asarray(hil["p1"]) / 1e5, lw=1, label="P1 (HIL)")
    ax[2].plot(t, np.asarray(hil["p2"]) / 1e5, lw=1, label="P2 (HIL)")
    ax[2].plot(offline.column("t")[:n], offline.column("p1")[:n] / 1e5, ":", lw=1, label="P1 (offline)")
    ax[2].plot(offline.column("t")[:n], offline.column("p2")[:n] / 1e5, ":", lw=1, label="P2 (offline)")
    _mode_strip(ax[3], t, [TRAVEL_NAMES.index(v) for v in hil["travel_mode"]],
                [FRICTION_NAMES.index(v) for v in hil["friction_mode"]])
    ax[4].plot(t, np.asarray(hil["jitter_us"]), ".", ms=1, label="step start lateness (jitter)")
    ax[4].plot(t, np.asarray(hil["watchdog"]) * max(1.0, float(np.max(hil["jitter_us"]))), lw=1,
               label="watchdog active")
    _fault_spans(ax, t, hil.get("faults"))
    _finish(fig, path, ax, ("position [mm]", "error [mm]", "pressure [bar]", "mode", "jitter [µs]"),
            (ax[0], ax[1], ax[2], ax[4]), title)
