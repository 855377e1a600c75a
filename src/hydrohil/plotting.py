"""Figures (matplotlib, Agg backend): kept apart from the models."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hydrohil.models.layout import FRICTION_NAMES, SPOOL_NAMES, TRAVEL_NAMES  # noqa: E402

# The three state machines of the hybrid model, one strip each: (label, state names as the logs write them,
# as a person reads them, colour per state)
MODE_STRIPS = (("travel", TRAVEL_NAMES, ("free", "at the retract stop", "at the extend stop"),
                ("0.85", "tab:blue", "tab:red")),
               ("friction", FRICTION_NAMES, ("stick", "slip, extending", "slip, retracting"),
                ("0.35", "tab:green", "tab:purple")),
               ("spool", SPOOL_NAMES, ("linear", "acceleration-limited", "velocity-limited", "at its end"),
                ("0.85", "tab:orange", "tab:red", "k")))
ERROR_LABEL = "error x_ref − xp [mm]"     # one sign of the tracking error everywhere (figures and the panel)


def _stack(heights, figsize, banner: float = 0.0):
    """A figure of axes stacked vertically with a shared time axis (tick labels on the last only), and
    optionally a banner axis of relative height ``banner`` above them. Returns (fig, axes, banner_ax)."""
    fig = plt.figure(figsize=figsize)
    gs = fig.add_gridspec(len(heights) + bool(banner), 1, height_ratios=([banner] if banner else []) + list(heights))
    top = fig.add_subplot(gs[0]) if banner else None
    first = fig.add_subplot(gs[bool(banner)])
    ax = [first] + [fig.add_subplot(gs[i + bool(banner)], sharex=first) for i in range(1, len(heights))]
    for a in ax[:-1]:
        a.tick_params(labelbottom=False)
    return fig, ax, top


def plot_run(path: Path, t, xp, p1, p2, u, xs, travel, friction, spool=None, *, xref=None, title: str = "",
             compare: dict | None = None, faults=None, metrics: dict | None = None) -> None:
    """Position (and reference), chamber pressures, command and spool, and the travel, friction and spool
    modes over time (one strip each; ``spool`` may be omitted).

    ``compare`` optionally holds another run (keys t, xp, p1, p2, label) drawn dotted; ``faults`` (the
    per-row fault mask) shades the intervals with an injected fault; ``metrics`` (:func:`hydrohil.metrics.
    step_metrics`) marks each move's settling instant and lists the moves' figures.
    """
    modes = [m for m in (travel, friction, spool) if m is not None]
    fig, ax, _ = _stack([3, 3, 2] + [0.45] * len(modes), (10, 10 + 0.4 * len(modes)))
    ax[0].plot(t, np.asarray(xp) * 1e3, label="piston xp")
    if xref is not None:
        ax[0].plot(t, np.asarray(xref) * 1e3, "k--", lw=1, label="reference")
    ax[1].plot(t, np.asarray(p1) / 1e5, color="C0", label="P1")
    ax[1].plot(t, np.asarray(p2) / 1e5, color="C1", label="P2")
    if compare:
        lab = compare.get("label", "other")
        ax[0].plot(compare["t"], np.asarray(compare["xp"]) * 1e3, ":", lw=1.5, label=f"xp ({lab})")
        ax[1].plot(compare["t"], np.asarray(compare["p1"]) / 1e5, ":", color="C0", lw=1.5, label=f"P1 ({lab})")
        ax[1].plot(compare["t"], np.asarray(compare["p2"]) / 1e5, ":", color="C1", lw=1.5, label=f"P2 ({lab})")
    ax[2].plot(t, u, lw=1, label="command ū")
    ax[2].plot(t, xs, lw=1, label="spool x̄s")
    if metrics:
        _metrics_marks(ax[0], metrics)
    _mode_strips(ax[3:], t, travel, friction, spool)
    _fault_spans(ax, t, faults)
    _finish(fig, path, ax[:3], ("position [mm]", "pressure [bar]", "valve [-]"), title)


def _metrics_marks(ax, metrics: dict) -> None:
    """A triangle at each move's settling instant, and the moves' figures (step-response metrics) above the
    axis, where they cover no curve."""
    from hydrohil.metrics import metrics_lines
    for i, mv in enumerate(metrics["moves"]):
        if mv["settling_time"] is not None:
            ax.plot(mv["start"] + mv["settling_time"], mv["to"] * 1e3, "v", color="k", ms=5,
                    label="settled (band)" if i == 0 else None)
    _text_above(ax, metrics_lines(metrics))


def _text_above(ax, lines: list[str]) -> None:
    """Lines of figures (monospace, 8 pt) as the axis' left title: above the data, never over it."""
    if lines:
        ax.set_title("\n".join(lines), loc="left", fontsize=8, family="monospace")


def _fault_spans(ax, t, faults) -> None:
    """Shade the time intervals where the fault mask is non-zero (injected faults) on every axis."""
    if faults is None:
        return
    t, on = np.asarray(t), np.asarray(faults) != 0
    for a in ax:
        for i, (t0, t1) in enumerate(_runs(t, on)):
            a.axvspan(t0, t1, color="red", alpha=0.08, label="fault injected" if (i == 0 and a is ax[0]) else None)


def _runs(t, on) -> list[tuple[float, float]]:
    """(start, end) times of the runs of consecutive True in ``on`` (a run ends at the next sample)."""
    t, on = np.asarray(t, float), np.asarray(on, bool)
    if not on.any():
        return []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
    return [(t[k0], t[min(k1, len(t) - 1)]) for k0, k1 in zip(edges[::2], edges[1::2])]


def _codes(values, names) -> np.ndarray:
    """Mode codes from a log column: integer codes as they are, state names (the HIL plant log) looked up."""
    v = np.asarray(values)
    if v.dtype.kind in "US":
        return np.array([names.index(x) for x in v])
    return v.astype(int)


def _mode_strips(ax, t, *columns) -> None:
    """Cylinder state diagram (Fig 11b style): one strip per state machine (travel, friction, spool), each
    state a colour, named in the strip's legend; ``None`` columns are skipped."""
    t = np.asarray(t, float)
    strips = [(m, c) for m, c in zip(MODE_STRIPS, columns) if c is not None]
    for a, ((label, names, shown, colours), col) in zip(ax, strips):
        code = _codes(col, names)
        for i, (name, colour) in enumerate(zip(shown, colours)):
            spans = [(t0, t1 - t0) for t0, t1 in _runs(t, code == i)]
            a.broken_barh(spans, (0, 1), facecolors=colour, label=name if spans else f"{name} (never)")
        a.set_ylim(0, 1)
        a.set_yticks([])
        a.set_ylabel(label, rotation=0, ha="right", va="center")
        a.legend(loc="center left", bbox_to_anchor=(1.005, 0.5), fontsize=7, frameon=False, handlelength=1)


def _finish(fig, path: Path, legend_axes, ylabels, title: str, banner=None) -> None:
    """Axis labels, grid and legend (right of the axis) on ``legend_axes``, time label on the last axis,
    title, ``banner`` axis widened to the full figure width; save and close."""
    for a, label in zip(legend_axes, ylabels):
        a.set_ylabel(label)
        a.grid(alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="center left", bbox_to_anchor=(1.005, 0.5), fontsize=8, frameon=False)
    fig.axes[-1].set_xlabel("time [s]")
    if title and banner is not None:
        banner.set_title(title)      # above the banner (a figure suptitle would overlap it)
    elif title:
        fig.suptitle(title)
    # keep 0.4 in free at the top for the suptitle (tight_layout alone let it overlap the first axis)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.4 / fig.get_figheight() if title and banner is None else 1))
    if banner is not None:
        box = banner.get_position()
        banner.set_position([0.01, box.y0, 0.98, box.height])
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _verdict_banner(ax, verdict: dict, mode: str = "real-time") -> None:
    """A full-width green "VALID real-time run" (or lock-step run) or red "INVALID: <reasons>" banner."""
    import textwrap
    ok = bool(verdict.get("valid"))
    text = f"VALID {mode} run" if ok else "INVALID: " + "; ".join(verdict.get("reasons") or ["(no reason given)"])
    ax.set_facecolor("#1a7f37" if ok else "#c62828")
    ax.set_xticks([])
    ax.set_yticks([])
    for side in ax.spines.values():
        side.set_visible(False)
    ax.text(0.5, 0.5, textwrap.fill(text, 95), ha="center", va="center", color="white", fontsize=12,
            fontweight="bold", transform=ax.transAxes)


def _jitter_panel(ax, t, jitter_us) -> None:
    """Step-start lateness on a log axis (so p99 and the rare spikes are both visible), with p50/p99/max."""
    t, j = np.asarray(t, float), np.asarray(jitter_us, float)
    h_us = float(np.median(np.diff(t))) * 1e6 if len(t) > 1 else None
    if not np.any(j > 0):
        ax.text(0.5, 0.5, "no wall-clock timing (lock-step run): jitter 0", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_yticks([])
        return
    floor = 0.1
    ax.plot(t, np.maximum(j, floor), ".", ms=1.5, color="0.3", label="step start lateness")
    p50, p99, top = np.percentile(j, 50), np.percentile(j, 99), float(np.max(j))
    for v, style, name in ((p50, ":", "p50"), (p99, "--", "p99"), (top, "-", "max")):
        ax.axhline(max(v, floor), color="tab:blue", ls=style, lw=1, label=f"{name} = {v:.3g} µs")
    if h_us:
        ax.axhline(h_us, color="tab:red", lw=1, label=f"one step = {h_us:g} µs")
    ax.set_yscale("log")
    ax.set_ylim(floor / 2, max(top, h_us or 0) * 2)


def _watchdog_strip(ax, t, watchdog) -> None:
    """Where the watchdog held the safe state, as red bars (or "never active")."""
    wd = np.asarray(watchdog) != 0
    if wd.any():
        ax.broken_barh([(t0, t1 - t0) for t0, t1 in _runs(t, wd)], (0, 1), facecolors="tab:red",
                       label="active (safe state)")
        ax.legend(loc="center left", bbox_to_anchor=(1.005, 0.5), fontsize=7, frameon=False, handlelength=1)
    else:
        ax.text(0.5, 0.5, "never active", ha="center", va="center", fontsize=8, transform=ax.transAxes)
    ax.set_ylim(0, 1)
    ax.set_yticks([])
    ax.set_ylabel("watchdog", rotation=0, ha="right", va="center")


def plot_hil(path: Path, hil: dict, offline, xref, *, title: str = "", verdict: dict | None = None,
             metrics: dict | None = None) -> None:
    """HIL report: reference vs HIL vs offline position, tracking error, HIL − offline, pressures, plant
    modes, step jitter (log scale) and the watchdog. ``verdict`` (keys ``valid``: bool, ``reasons``: list of
    str) adds a banner at the top: "VALID real-time run" in green or "INVALID: <reasons>" in red;
    ``metrics`` (the HIL run's step-response metrics) are marked on the position axis."""
    t = np.asarray(hil["t"])
    n = min(len(t), len(offline.log))
    to = offline.column("t")[:n]
    xp, xo, xr = np.asarray(hil["xp"])[:n], offline.column("xp")[:n], np.asarray(xref)[:n]
    rms = lambda e: float(np.sqrt(np.mean(np.square(e)))) if len(e) else float("nan")  # noqa: E731
    heights = [3, 1.6, 1.6, 3, 0.45, 0.45, 0.45, 2, 0.45]
    fig, ax, top = _stack(heights, (10, 17), banner=0.5 if verdict is not None else 0.0)
    lockstep = "jitter_us" in hil and not np.any(np.asarray(hil["jitter_us"], float) > 0)
    if top is not None:
        _verdict_banner(top, verdict, "lock-step" if lockstep else "real-time")
    ax[0].plot(t[:n], xr * 1e3, "k--", lw=1, label="reference")
    ax[0].plot(t, np.asarray(hil["xp"]) * 1e3, lw=1.5, label="HIL (lock-step plant)" if lockstep else
               "HIL (real-time plant)")
    ax[0].plot(to, xo * 1e3, ":", lw=1.5, label="offline simulation")
    if metrics:
        _metrics_marks(ax[0], metrics)
    ax[1].plot(t[:n], (xr - xp) * 1e3, lw=1, label=f"x_ref − xp (HIL)\n(RMS {rms(xr - xp) * 1e3:.2f} mm)")
    ax[2].plot(t[:n], (xp - xo) * 1e3, lw=1, color="tab:red",
               label=f"HIL − offline\n(RMS {rms(xp - xo) * 1e3:.3g} mm)")
    for name, hil_c, off_c in (("p1", "C0", "navy"), ("p2", "C1", "saddlebrown")):   # offline under HIL
        ax[3].plot(to, offline.column(name)[:n] / 1e5, ":", lw=1.5, color=off_c, label=f"{name.upper()} (offline)")
        ax[3].plot(t, np.asarray(hil[name]) / 1e5, lw=1, color=hil_c, label=f"{name.upper()} (HIL)")
    _mode_strips(ax[4:7], t, hil["travel_mode"], hil["friction_mode"], hil.get("spool_mode"))
    _jitter_panel(ax[7], t, hil["jitter_us"])
    _watchdog_strip(ax[8], t, hil["watchdog"])
    _fault_spans(ax, t, hil.get("faults"))
    _finish(fig, path, [ax[i] for i in (0, 1, 2, 3, 7)],
            ("position [mm]", ERROR_LABEL.replace("error ", "error\n"), "HIL − offline\n[mm]", "pressure [bar]",
             "jitter [µs]"), title,
            banner=top)


def plot_circuit_hil(path: Path, hil: dict, offline, measure: str | None, *, title: str = "",
                     verdict: dict | None = None, inputs: list[str] = (), commanded: bool = True,
                     other: str = "offline") -> None:
    """HIL report of a circuit: the loop's measured signal (open loop: the circuit's position or speed that moves
    most, else its pressure that does) with its reference, HIL and offline; HIL − offline; every pressure that
    moves (HIL solid, offline dotted); the inputs as the plant applied them, late commands marked; in real time
    the step jitter; the watchdog. ``offline``: a :class:`hydrohil.circuits.run.CircuitResult`; ``commanded``:
    the controller sets an input (late commands matter; an open loop's controller only answers); ``other``: what
    ``offline`` is ("offline": the simulation; "replay": a recording's replay of its applied inputs)."""
    from hydrohil.circuits.units import display
    t = np.asarray(hil["t"])
    cols, units = offline.columns, offline.units
    n = min(len(t), len(cols["t"]))
    if measure is None:        # open loop: the signal that moves most, a position or speed before a pressure
        moving = [[s for s in units if units[s] in kinds and s in hil and np.ptp(cols[s][:n]) > 0]
                  for kinds in (("m", "rad/s"), ("Pa",))]
        pick = moving[0] or moving[1]
        measure = max(pick, key=lambda s: np.ptp(cols[s][:n]) * display(units[s])[0]) if pick else None
    lockstep = not np.any(np.asarray(hil["jitter_us"], float) > 0)
    by_unit: dict[str, list] = {}             # the inputs, an axis per unit (a command in [-] beside a torque)
    for name in inputs:
        by_unit.setdefault(units.get(name, "-"), []).append(name)
    groups = list(by_unit.items()) or [("-", [])]
    heights = [3, 1.4, 3] + [2 if len(groups) == 1 else 1.6] * len(groups) + ([] if lockstep else [2]) + [0.45]
    fig, ax, top = _stack(heights, (10, 3 + 1.15 * sum(heights)), banner=0.5 if verdict is not None else 0.0)
    if top is not None:
        _verdict_banner(top, verdict, "lock-step" if lockstep else "real-time")
    labels = []
    if measure is not None:
        k, du = display(units.get(measure, "-"))
        if f"{measure}.reference" in cols:
            ax[0].plot(cols["t"][:n], cols[f"{measure}.reference"][:n] * k, "k--", lw=1, label="reference")
        ax[0].plot(t, np.asarray(hil[measure]) * k, lw=1.5, label="HIL (lock-step plant)" if lockstep else
                   "HIL (real-time plant)")
        ax[0].plot(cols["t"][:n], cols[measure][:n] * k, ":", lw=1.5,
                   label="offline simulation" if other == "offline" else other)
        d = (np.asarray(hil[measure])[:n] - cols[measure][:n]) * k
        rms = float(np.sqrt(np.mean(d ** 2))) if n else float("nan")
        ax[1].plot(t[:n], d, lw=1, color="tab:red", label=f"HIL − {other}\n" + (
            "(0 at every step:\nbit for bit)" if n and not np.any(d) else f"(RMS {rms:.3g} {du})"))
        labels += [f"{measure} [{du}]", f"HIL − {other}\n[{du}]"]
    else:
        labels += ["", ""]
    for i, s in enumerate(x for x in units if units[x] == "Pa" and x in hil and np.ptp(cols[x]) > 0):
        ax[2].plot(cols["t"][:n], cols[s][:n] / 1e5, ":", lw=1.5, color=f"C{i % 10}")
        ax[2].plot(t, np.asarray(hil[s]) / 1e5, lw=1, color=f"C{i % 10}", label=s)
    labels.append(f"pressure [bar]\n(HIL solid,\n{other} dotted)")
    i = 0
    for g, (unit, names) in enumerate(groups):      # what drove each step (row k: the step into it)
        k, du = display(unit)
        for name in names:
            ax[3 + g].step(t, np.asarray(hil[f"{name}.applied"], float) * k, where="pre", lw=1, color=f"C{i % 10}",
                           label=name)
            i += 1
        labels.append(f"inputs as\napplied [{du}]")
    late = (np.asarray(hil.get("cmd_age", np.zeros(len(t))), float) > 0) & commanded
    if late.any():
        ax[3].plot(t[late], np.zeros(int(late.sum())), "|", color="tab:red", ms=10,
                   label=f"late command ({int(late.sum())} steps: the one before repeated)")
    if not lockstep:
        _jitter_panel(ax[3 + len(groups)], t, hil["jitter_us"])
        labels.append("jitter [µs]")
    _watchdog_strip(ax[-1], t, hil["watchdog"])
    _finish(fig, path, ax[:len(labels)], tuple(labels), title, banner=top)


def plot_compare(path: Path, runs, *, title: str = "") -> None:
    """Runs overlaid (``runs``: :class:`hydrohil.compare.Run`): position and reference, position error,
    piston velocity, valve command, chamber pressures (P1 solid, P2 dashed); per run its metrics in the
    first axis."""
    fig, ax, _ = _stack([3, 2, 2, 2, 2.5], (10, 12))
    ref = runs[0].data
    ax[0].plot(ref["t"], ref["x_ref"] * 1e3, "k--", lw=1, label="reference")
    lines = []
    for i, r in enumerate(runs):
        d, c = r.data, f"C{i}"
        ax[0].plot(d["t"], d["xp"] * 1e3, color=c, lw=1.2, label=r.label)
        ax[1].plot(d["t"], (d["x_ref"] - d["xp"]) * 1e3, color=c, lw=1, label=r.label)
        ax[2].plot(d["t"], d["vp"] * 1e3, color=c, lw=1, label=r.label)
        ax[3].plot(d["t"], d["u"], color=c, lw=1, label=r.label)
        ax[4].plot(d["t"], d["p1"] / 1e5, color=c, lw=1, label=f"P1 {r.label}")
        ax[4].plot(d["t"], d["p2"] / 1e5, color=c, lw=1, ls="--", label=f"P2 {r.label}")
        m = r.metrics
        ess = max((abs(mv["steady_state_error"]) for mv in m["moves"]), default=float("nan"))
        os_ = max((mv["overshoot_pct"] for mv in m["moves"]), default=float("nan"))
        lines.append(f"{r.label}: RMS e {m['rms_error'] * 1e3:.2f} mm, |e_ss| ≤ {ess * 1e6:.1f} µm, OS ≤ {os_:.1f} %"
                     + (f", {m['breakaways']} breakaways" if "breakaways" in m else ""))
    ax[1].axhline(0, color="k", lw=0.5)
    _text_above(ax[0], lines)
    _finish(fig, path, ax, ("position [mm]", ERROR_LABEL, "velocity [mm/s]", "command ū [-]", "pressure [bar]"),
            title)


def plot_bode(path: Path, by_loop: dict, *, title: str = "", names: dict | None = None) -> None:
    """Bode plots, one column per loop (``by_loop``: loop -> {"freq", "gain_db", "phase_deg", "converged"}
    of the stepped sines of :mod:`hydrohil.freqresp`, and "linear": (frequencies, gain [dB], phase [deg]) of
    the linear prediction, or None; ``names``: loop -> its panel's title): the nonlinear model's stepped sines as markers (points without a periodic
    steady state, e.g. at an end stop, are left out and counted in the legend), the linear model as a line."""
    loops = list(by_loop)
    fig, ax = plt.subplots(2, len(loops), figsize=(6 * len(loops), 7), sharex="col", squeeze=False)
    names = names or {"closed": "closed loop x / x_ref", "open": "open loop x / ū [m per unit ū]"}
    for j, loop in enumerate(loops):
        d = by_loop[loop]
        f, db, ph, ok = d["freq"], d["gain_db"], d["phase_deg"], d["converged"]
        if d["linear"] is not None:
            f_lin, lin_db, lin_ph = d["linear"]
            ax[0, j].semilogx(f_lin, lin_db, "-", color="k", lw=1.2, label="linear model")
            ax[1, j].semilogx(f_lin, lin_ph, "-", color="k", lw=1.2, label="linear model")
        missing = f" ({int((~ok).sum())} points without steady state left out)" if (~ok).any() else ""
        for a, v in ((ax[0, j], db), (ax[1, j], ph)):
            a.semilogx(f[ok], v[ok], "o", color="C0", ms=5, label="nonlinear model (stepped sines)" + missing)
            a.grid(alpha=0.3, which="both")
        if loop == "closed":
            ax[0, j].axhline(-3, color="0.5", ls=":", lw=1, label="−3 dB")
        ax[0, j].set_title(names.get(loop, loop))
        ax[0, j].set_ylabel("gain [dB]")
        ax[1, j].set_ylabel("phase [deg]")
        ax[1, j].set_xlabel("frequency [Hz]")
        ax[0, j].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_recording(path: Path, log: dict, *, events=(), title: str = "", verdict: dict | None = None) -> None:
    """A recording of the live panel (``plant_log.csv`` of the recorded steps, against session time k·h):
    position (encoder and model), valve command and spool, chamber pressures with the supply transducer,
    friction force, mode strips, step jitter, the watchdog; each applied change (``events``: dicts with
    ``t`` and a ``label``) a vertical line with its label; injected faults shaded."""
    t = np.asarray(log["k"], float) * float(log["h"])
    heights = [2.4, 1.6, 2.4, 1.4, 0.45, 0.45, 0.45, 1.8, 0.45]
    fig, ax, top = _stack(heights, (10, 15), banner=0.5 if verdict is not None else 0.0)
    if top is not None:
        _verdict_banner(top, verdict, "real-time" if np.any(np.asarray(log["jitter_us"], float) > 0) else "lock-step")
    ax[0].plot(t, np.asarray(log["xp"]) * 1e3, lw=1.2, label="piston xp (model)")
    ax[0].plot(t, np.asarray(log["encoder"], float) * float(log["count_m"]) * 1e3, lw=0.8, ls="--",
               label="encoder")
    ax[1].plot(t, log["u"], lw=1, label="command ū (applied)")
    ax[1].plot(t, log["xs"], lw=1, label="spool xs")
    for name, c in (("p1", "C0"), ("p2", "C1")):
        ax[2].plot(t, np.asarray(log[name]) / 1e5, lw=1, color=c, label=name.upper())
    ax[2].plot(t, np.asarray(log["ps_meas"]) / 1e5, lw=1, color="k", ls="--", label="supply (transducer)")
    ax[3].plot(t, log["ff"], lw=1, color="tab:brown", label="friction force")
    _mode_strips(ax[4:7], t, log["travel_mode"], log["friction_mode"], log.get("spool_mode"))
    _jitter_panel(ax[7], t, log["jitter_us"])
    _watchdog_strip(ax[8], t, log["watchdog"])
    _fault_spans(ax, t, log.get("faults"))
    for ev in events:
        if t[0] <= ev["t"] <= t[-1]:
            for a in ax[:4]:
                a.axvline(ev["t"], color="tab:purple", lw=0.8, ls=":")
            ax[0].annotate(ev["label"], (ev["t"], 1.0), xycoords=("data", "axes fraction"), rotation=90, fontsize=7,
                           va="top", ha="right", color="tab:purple")
    _finish(fig, path, [ax[i] for i in (0, 1, 2, 3, 7)],
            ("position [mm]", "ū, xs [-]", "pressure [bar]", "friction [N]", "jitter [µs]"), title, banner=top)
