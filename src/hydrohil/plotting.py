"""Figures (matplotlib, Agg backend): kept apart from the models."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hydrohil.models.layout import FRICTION_NAMES, TRAVEL_NAMES  # noqa: E402


def plot_run(path: Path, t, xp, p1, p2, u, xs, travel, friction, *, xref=None, title: str = "",
             compare: dict | None = None) -> None:
    """Position (and reference), chamber pressures, command and spool, and the cylinder modes over time.

    ``compare`` optionally holds another run (keys t, xp, p1, p2, label) drawn dashed.
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
    ax[3].step(t, np.asarray(travel), where="post", label="travel")
    ax[3].step(t, np.asarray(friction) + 3, where="post", label="friction")
    ax[3].set_yticks(range(6), [*TRAVEL_NAMES, *FRICTION_NAMES], fontsize=7)
    ax[0].set_ylabel("position [mm]")
    ax[1].set_ylabel("pressure [bar]")
    ax[2].set_ylabel("valve [-]")
    ax[3].set_ylabel("mode")
    ax[3].set_xlabel("time [s]")
    for a in ax[:3]:
        a.grid(alpha=0.3)
        a.legend(loc="best", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
