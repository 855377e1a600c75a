"""A study's summary (``summary.json``), figures and ``report.md``: pass/fail by the study's criterion (or the
sequence's verdicts), the probability of failing with its 95 % interval, metric vs input scatter plots, a
pass/fail map over two inputs, metric histograms, and the worst runs with the command that makes one again."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from hydrohil.sequences.expectations import DISPLAY
from hydrohil.studies.study import METRIC_UNITS, METRICS
from hydrohil.studies.study import wilson


def _shown(metric: str) -> tuple[float, str]:
    """(factor, unit) a metric is shown in (mm, bar, ...; its SI unit when there is no display unit)."""
    unit = METRIC_UNITS.get(metric, "-")
    return DISPLAY.get(unit, (1.0, unit))


def _label(metric: str) -> str:
    return f"{metric} [{_shown(metric)[1]}]"


def _scale(metric: str) -> float:
    return _shown(metric)[0]


# units of the study inputs that are not parameters of the schema (those take theirs from it)
OTHER_INPUT_UNITS = {"duration": "s", "initial.xp": "m", "initial.xs": "-", "initial.p1": "Pa", "initial.p2": "Pa",
                     "controller.kp": "1/m", "controller.ki": "1/(m·s)", "controller.kd": "s/m",
                     "controller.kff": "s/m", "controller.kpl": "1/Pa"}


def input_axis(study, name: str) -> tuple[float, str]:
    """(scale, axis label) of the study input ``name`` as people read it: a factor on several entries as
    '× nominal', a parameter in its unit (Pa shown in bar, m in mm)."""
    from hydrohil.models.layout import SLOTS
    vary = next((v for v in study.study.vary if v.name == name), None)
    if vary is not None and vary.scale:
        return 1.0, f"{name} [× nominal]"
    unit = {s.key: s.unit for s in SLOTS}.get(name) or OTHER_INPUT_UNITS.get(name)
    if unit is None:
        return 1.0, name
    k, shown = DISPLAY.get(unit, (1.0, unit))
    return k, f"{name} [{shown}]"


def load_table(path: Path) -> dict[str, np.ndarray]:
    import pyarrow.parquet as pq
    t = pq.read_table(path)
    out = {}
    for name in t.column_names:
        col = t.column(name)
        out[name] = (np.asarray(col.to_numpy(zero_copy_only=False), dtype=float)
                     if str(col.type) in ("double", "int64") else np.asarray(col.to_pylist(), dtype=object))
    return out


def write_study_report(study, table_path: Path, out: Path, *, wall_s: float, ran: int, workers: int) -> dict:
    cols = load_table(table_path)
    n = len(cols["run_id"])
    ok = cols["status"] == "ok"
    crit = study.study.criterion
    metric = crit.metric if crit else ("max_hold_error" if study.study.sequence is None else None)
    if crit is not None:
        v = cols[crit.metric]
        passed = ok & (v <= crit.max)
    elif "verdict" in cols:
        passed = cols["verdict"] == "pass"
    else:
        passed = ok
    failed = ~passed
    inputs = [c for c in cols if c.startswith("in.")]
    numeric = [c for c in inputs if cols[c].dtype == float]
    k = int(failed.sum())
    lo, hi = wilson(k, n)
    summary = {"name": study.name, "runs": n, "ran_this_time": ran, "wall_s": wall_s, "workers": workers,
               "status": {s: int((cols["status"] == s).sum()) for s in ("ok", "diverged", "input_error", "error")},
               "criterion": crit.model_dump() if crit else ("sequence verdict" if "verdict" in cols else "status ok"),
               "failed": k, "p_fail": k / n if n else None, "p_fail_95ci": [lo, hi],
               "metrics": {m: _quantiles(cols[m][ok]) for m in METRICS if m in cols}}
    order_metric = metric if metric in cols else None
    if order_metric:
        worst = np.argsort(np.where(np.isnan(cols[order_metric]), -np.inf, cols[order_metric]))[::-1][:10]
    else:
        worst = np.nonzero(failed)[0][:10]
    summary["worst"] = [{"run_id": cols["run_id"][i], "status": cols["status"][i],
                         **({order_metric: float(cols[order_metric][i])} if order_metric else {}),
                         **{c[3:]: (cols[c][i].item() if hasattr(cols[c][i], "item") else cols[c][i]) for c in inputs}}
                        for i in worst]
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
    figs = _figures(study, cols, ok, passed, numeric, order_metric, out / "figures")
    _markdown(study, summary, figs, out)
    return summary


def _quantiles(v) -> dict:
    v = v[np.isfinite(v)] if v.dtype == float else v
    if not len(v):
        return {}
    q = np.percentile(v, [0, 5, 50, 95, 100])
    return dict(zip(("min", "p5", "median", "p95", "max"), map(float, q)))


def _figures(study, cols, ok, passed, numeric, metric, folder: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator
    name = study.name
    axis = {c: input_axis(study, c[3:]) for c in numeric}
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("*.png"):
        old.unlink()
    figs = []
    colors = np.where(passed, "C0", "C3")
    if metric and numeric:
        k = _scale(metric)
        fig, axes = plt.subplots(1, len(numeric), figsize=(3.6 * len(numeric), 3.3), squeeze=False,
                                 constrained_layout=True)
        for ax, c in zip(axes[0], numeric):
            ax.scatter(cols[c][ok] * axis[c][0], cols[metric][ok] * k, s=6, c=colors[ok], alpha=0.7, lw=0)
            ax.set_xlabel(axis[c][1])
            ax.xaxis.set_major_locator(MaxNLocator(5))
            ax.grid(alpha=0.3)
        axes[0][0].set_ylabel(_label(metric))
        fig.suptitle(f"{name}: {metric} against each input (red: fails)", fontsize=10)
        figs.append(folder / "scatter.png")
        fig.savefig(figs[-1], dpi=110)
        plt.close(fig)
    if len(numeric) >= 2:
        a, b = numeric[:2]
        fig, ax = plt.subplots(figsize=(5.2, 4.2), constrained_layout=True)
        (ka, la), (kb, lb) = axis[a], axis[b]
        ax.scatter(cols[a][passed] * ka, cols[b][passed] * kb, s=10, c="C0", label=f"pass ({int(passed.sum())})", lw=0)
        ax.scatter(cols[a][~passed] * ka, cols[b][~passed] * kb, s=14, c="C3", marker="x",
                   label=f"fail ({int((~passed).sum())})")
        ax.set_xlabel(la)
        ax.set_ylabel(lb)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        ax.set_title(f"pass/fail over {a[3:]} and {b[3:]}", fontsize=10)
        figs.append(folder / "pass_fail_map.png")
        fig.savefig(figs[-1], dpi=110)
        plt.close(fig)
    shown = [m for m in ("max_hold_error", "max_abs_error", "rms_error", "max_overshoot_pct", "max_settling_time",
                         "max_p1") if m in cols and np.isfinite(cols[m][ok].astype(float)).any()]
    if shown and ok.sum() > 1:
        fig, axes = plt.subplots(2, 3, figsize=(11, 6), constrained_layout=True)
        for ax, m in zip(axes.flat, shown):
            v = cols[m][ok] * _scale(m)
            v = v[np.isfinite(v)]
            spread = np.ptp(v) > 1e-9 * np.abs(v).max() if v.size else False    # (a metric no input moved: 1 bin)
            ax.hist(v, bins=40 if spread else 1, color="C0", alpha=0.8)
            ax.set_xlabel(_label(m))
            ax.xaxis.set_major_locator(MaxNLocator(5))      # tick labels that never run into each other
            ax.yaxis.set_major_locator(MaxNLocator(5, integer=True))
            ax.grid(alpha=0.3)
        for ax in axes[:, 0]:
            ax.set_ylabel("runs")
        for ax in list(axes.flat)[len(shown):]:
            ax.axis("off")
        fig.suptitle(f"{name}: metrics over {int(ok.sum())} runs", fontsize=10)
        figs.append(folder / "histograms.png")
        fig.savefig(figs[-1], dpi=110)
        plt.close(fig)
    return figs


def _markdown(study, s: dict, figs: list[Path], out: Path) -> None:
    crit = s["criterion"]
    if isinstance(crit, dict):                  # (in the unit the table shows: mm, bar, ...)
        k, unit = _shown(crit["metric"])
        what = f"{crit['metric']} ≤ {crit['max'] * k:g}" + (f" {unit}" if unit != "-" else "")
    else:
        what = crit
    lo, hi = s["p_fail_95ci"]
    lines = [f"# Study: {study.name}", "",
             f"{s['runs']} runs ({s['ran_this_time']} run now on {s['workers']} Dask worker(s), {s['wall_s']:.1f} s); "
             f"status: " + ", ".join(f"{k} {v}" for k, v in s["status"].items()) + ".", "",
             f"Pass criterion: **{what}**. Failed: **{s['failed']} of {s['runs']}**, probability "
             f"**{100 * (s['p_fail'] or 0):.2f} %** (95 % interval {100 * lo:.2f} – {100 * hi:.2f} %).", "",
             "| metric | min | 5 % | median | 95 % | max |", "|---|---|---|---|---|---|"]
    for m, q in s["metrics"].items():
        if q:
            k = _scale(m)
            lines.append(f"| {_label(m)} | " + " | ".join(f"{q[x] * k:.4g}" for x in ("min", "p5", "median", "p95", "max"))
                         + " |")
    lines += ["", *[f"![{f.stem}](figures/{f.name})" for f in figs], "", "## Worst runs", "",
              "Make one again by hand: `hydrohil sweep STUDY --rerun ID --out DIR` writes its scenario file.", ""]
    if s["worst"]:
        keys = list(s["worst"][0])
        lines += ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
        for w in s["worst"]:
            lines.append("| " + " | ".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in w.values()) + " |")
    lines += ["", f"`hydrohil sweep {study.source} --rerun {s['worst'][0]['run_id'] if s['worst'] else 'r000000'} "
              f"--out {out}`", ""]
    (out / "report.md").write_text("\n".join(lines))
