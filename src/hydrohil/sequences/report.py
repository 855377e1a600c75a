"""What a sequence run leaves for people and CI systems: ``report.md`` with a figure per failed expectation,
and JUnit XML (the Jenkins / Surefire schema every CI system reads: one ``testsuite`` per sequence, one
``testcase`` per expectation; a failed expectation is a ``failure``, a run that could not be judged an
``error``)."""

from __future__ import annotations

import os
import socket
import time
import xml.etree.ElementTree as ET
from pathlib import Path

from hydrohil.sequences.expectations import DISPLAY, Outcome, unit_of
from hydrohil.sequences.sequence import slug


def write_junit(results, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    root = ET.Element("testsuites", name="hydrohil test")
    totals = {"tests": 0, "failures": 0, "errors": 0, "time": 0.0}
    stamp = time.strftime("%Y-%m-%dT%H:%M:%S")
    for r in results:
        cases = r.outcomes or [Outcome("run", "run", "error", r.error or "no signals")]
        fails = sum(o.status == "fail" for o in cases) if r.status != "error" else 0
        errors = len(cases) if r.status == "error" else sum(o.status == "error" for o in cases)
        suite = ET.SubElement(root, "testsuite", name=r.name, tests=str(len(cases)), failures=str(fails),
                              errors=str(errors), skipped="0", time=f"{r.wall_s:.3f}", timestamp=stamp,
                              hostname=socket.gethostname(), file=r.source)
        props = ET.SubElement(suite, "properties")
        ET.SubElement(props, "property", name="mode", value=r.mode)
        if r.verdict is not None:
            ET.SubElement(props, "property", name="timing", value=r.verdict.get("verdict", ""))
        for o in cases:
            case = ET.SubElement(suite, "testcase", name=o.name, classname=f"hydrohil.{r.name}", time="0.000")
            if r.status == "error":            # the run cannot be judged: every expectation is an error
                reason = r.error or o.message
                ET.SubElement(case, "error", type="run", message=reason).text = f"{reason}\n(measured: {o.message})"
            elif o.status == "fail":
                ET.SubElement(case, "failure", type=o.type, message=o.message).text = o.message
            elif o.status == "error":
                ET.SubElement(case, "error", type=o.type, message=o.message).text = o.message
            else:
                ET.SubElement(case, "system-out").text = o.message
        totals["tests"] += len(cases)
        totals["failures"] += fails
        totals["errors"] += errors
        totals["time"] += r.wall_s
    for k, v in totals.items():
        root.set(k, f"{v:.3f}" if k == "time" else str(v))
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def failure_figure(result, index: int, outcome: Outcome, path: Path) -> Path:
    """The signal of a failed expectation over its window: the bounds dashed, the violation marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    s, p = result.signals, outcome.plot
    name = p.get("signal", "xp")
    si = unit_of(name, s.units)
    k, unit = DISPLAY.get(si, (1.0, si))
    t = s.t
    t0, t1 = p.get("window", (0.0, float(t[-1])))
    pad = max(0.05 * (t1 - t0), 0.02)
    m = s.mask(*p.get("view", (t0 - pad, t1 + pad)))
    fig, ax = plt.subplots(figsize=(8, 3.6), constrained_layout=True)
    ax.plot(t[m], s[name][m] * k, color="C0", lw=1.2, label=name)
    if p.get("ref") or name == "xp":
        ax.plot(t[m], s["x_ref"][m] * k, color="0.4", lw=1, ls="--", label="x_ref")
    for key, lab in (("lo", "lower bound"), ("hi", "upper bound")):
        if p.get(key) is not None:
            ax.axhline(p[key] * k, color="C3", ls="--", lw=1, label=lab)
    if p.get("level") is not None:
        ax.axhline(p["level"] * k, color="C3", ls=":", lw=1.5, label="level to reach")
    if p.get("band"):
        lo, hi = p["band"]
        ax.axhspan(lo * k, hi * k, color="C2", alpha=0.15, label="settling band")
    ax.axvspan(t0, t1, color="0.9", zorder=0, label="judged window")
    if p.get("deadline") is not None:
        ax.axvline(p["deadline"], color="C3", lw=1.2, label=p.get("deadline_label", "deadline"))
    if p.get("also") and p["also"] in s:
        ax2 = ax.twinx()
        ax2.plot(t[m], s[p["also"]][m], color="C1", lw=0.8, alpha=0.8)
        ax2.set_ylabel(f"{p['also']} [-]", color="C1")
    v = p.get("violation")
    if v is not None:
        if v[1] is None:         # an instant (a reaction, a settling): not a second deadline
            ax.axvline(v[0], color="C4", ls="-.", lw=1.5, label=p.get("violation_label", "first violation"))
        else:
            ax.plot([v[0]], [v[1] * k], "x", color="C3", ms=12, mew=2.5,
                    label=p.get("violation_label", "first violation"))
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"{name} [{unit}]")
    import textwrap
    ax.set_title(textwrap.fill(f"{result.name}: {outcome.name}", 95), fontsize=10)
    ax.legend(fontsize=7, loc="best")
    ax.grid(alpha=0.3)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_report(results, path: Path) -> Path:
    """``report.md``: a table per sequence (every expectation with its verdict and what was measured) and a
    figure for each failed one (``figures/``)."""
    path = Path(path)
    figs = path.parent / "figures"
    for old in figs.glob("*.png"):            # a report folder used again: this run's figures only
        old.unlink()
    total = {k: sum(r.status == k for r in results) for k in ("pass", "fail", "error")}
    lines = ["# hydrohil test report", "",
             f"{len(results)} sequence(s): {total['pass']} passed, {total['fail']} failed, {total['error']} errors.", ""]
    for r in results:
        head = {"pass": "PASS", "fail": "FAIL", "error": "ERROR"}[r.status]
        lines += [f"## {head} — {r.name}", "",
                  f"Mode {r.mode}, source `{r.source}`, run folder `{os.path.relpath(r.out, path.parent)}`, "
                  f"{r.wall_s:.1f} s." + (f" Timing: **{r.verdict['verdict']}**." if r.verdict else ""), ""]
        if r.error:
            lines += [f"**Error:** {r.error}", ""]
        if r.outcomes:
            lines += ["| expectation | type | verdict | what was measured |", "|---|---|---|---|"]
            for o in r.outcomes:
                lines.append(f"| {o.name} | {o.type} | {o.status.upper()} | {o.message.replace('|', chr(92) + '|')} |")
            lines.append("")
        for i, o in enumerate(r.outcomes):
            if o.status == "fail" and o.plot and r.signals is not None:
                f = failure_figure(r, i, o, figs / f"{slug(r.name)}_{i}_{slug(o.type)}.png")
                lines += [f"![{o.name}]({os.path.relpath(f, path.parent)})", "", f"*{o.name}*: {o.message}", ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path

