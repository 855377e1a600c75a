"""``hydrohil demo``: the paper's Fig 11 and Fig 12 experiments as real-time HIL runs, with a report.

Each experiment runs with the plant and the P controller as two processes over UDP loopback, locked to
the wall clock, then offline with the same scenario file; ``report.md`` holds the timing table and the
HIL-vs-offline comparison, each experiment's folder its logs and ``report.png``.
"""

from __future__ import annotations

import json
import platform
from pathlib import Path
from typing import Callable

from hydrohil.hil.run import run_hil
from hydrohil.hil.verdict import BUSY_ADVICE
from hydrohil.simulation.scenario import EXPERIMENTS_DIR

EXPERIMENTS = (
    ("fig11", "fig11_p_control.toml", "Fig 11: P control, Kp = 50 1/m, 80 kg, 70 bar, point-to-point"),
    ("fig12", "fig12_steps_ramps.toml", "Fig 12: P control, Kp = 100 1/m, 120 bar, steps and ramps"),
)
TIMING_ROWS = ("steps", "overruns", "jitter_us_p50", "jitter_us_p99", "jitter_us_p999", "jitter_us_max",
               "compute_us_p50", "compute_us_p99", "rtt_us_p50", "rtt_us_p99", "packets_rx", "packets_bad",
               "packets_lost", "late_commands", "watchdog_trips", "watchdog_trips_unexplained", "drift_ms",
               "os_rt_priority")
COMPARISON_ROWS = ("xp_rms_mm", "xp_max_mm", "p1_rms_bar", "hil_tracking_rms_mm", "offline_tracking_rms_mm")


def _fmt(v) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def run_demo(out: str | Path = "hydrohil-demo", *, lockstep: bool = False,
             on_experiment: Callable[[str, str], None] | None = None,
             progress: Callable[[float, float], None] | None = None,
             experiments=EXPERIMENTS) -> dict:
    """Run the experiments (default the paper's two; else (name, scenario file, title) triples, a file name
    without a folder being one of the package's experiments); returns {name: {"timing", "comparison",
    "controller"}} and writes the report."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    for name, fname, title in experiments:
        if on_experiment:
            on_experiment(name, title)
        scenario = Path(fname) if Path(fname).parent != Path(".") else EXPERIMENTS_DIR / fname
        r = run_hil(scenario, out / name, lockstep=lockstep, progress=progress)
        results[name] = {"title": title, "timing": r.timing, "comparison": r.comparison, "controller": r.controller}
    (out / "results.json").write_text(json.dumps(results, indent=2) + "\n")
    _write_markdown(out, results, lockstep)
    return results


def _banner(results: dict) -> list[str]:
    """The verdict at the top of the report: every run VALID, or which are INVALID, why, and what to do."""
    bad = {n: r["timing"]["verdict"] for n, r in results.items() if not r["timing"]["verdict"]["valid"]}
    if not bad:
        return [f"> **VALID** — every run met the real-time criteria ({', '.join(results)}); the figures below "
                "are what the controller would see on the rig.", ""]
    lines = ["> **INVALID** — " + ", ".join(bad) + " did not meet the real-time criteria, so their HIL results "
             "do not show what the controller would do on the rig:"]
    lines += [f"> - {n}: " + "; ".join(v["reasons"]) for n, v in bad.items()]
    lines += [">", f"> What to do: {BUSY_ADVICE}.", ""]
    return lines


def _write_markdown(out: Path, results: dict, lockstep: bool) -> None:
    names = list(results)
    lines = ["# hydrohil demo: the paper's closed-loop experiments as hardware-in-the-loop runs", "",
             *_banner(results),
             f"Mode: {'lock-step' if lockstep else 'real time (plant locked to the wall clock)'}; machine: "
             f"{platform.machine()}, {platform.processor() or platform.platform()}, Python "
             f"{platform.python_version()}. Plant and controller are separate processes talking UDP over "
             "loopback (docs/protocol.md). Every number below was measured in this run.", ""]
    for n in names:
        lines += [f"- **{n}**: {results[n]['title']} — `{n}/report.png`, logs in `{n}/`"]
    lines += ["", "## Timing", "", "| | " + " | ".join(names) + " |", "|---|" + "---|" * len(names),
              "| verdict | " + " | ".join(results[n]["timing"]["verdict"]["verdict"] for n in names) + " |"]
    for key in TIMING_ROWS:
        lines.append(f"| {key} | " + " | ".join(_fmt(results[n]["timing"].get(key)) for n in names) + " |")
    lines += ["", "Jitter: lateness of each step's start against t0 + k·h. Overrun: a step starting after its "
              "successor's instant. RTT: plant's sensor packet out to the answering command in. "
              "Late command: the plant stepped with a command that did not answer its previous packet. "
              "n/a: not measured (lock-step runs have no clock).",
              "", "## HIL vs offline simulation of the same scenario file", "",
              "| | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for key in COMPARISON_ROWS:
        lines.append(f"| {key} | " + " | ".join(_fmt(results[n]["comparison"].get(key)) for n in names) + " |")
    lines += ["", "Figures: " + ", ".join(f"![{n}]({n}/report.png)" for n in names), ""]
    (out / "report.md").write_text("\n".join(lines))
