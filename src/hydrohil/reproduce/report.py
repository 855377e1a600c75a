"""``report.md`` of ``hydrohil reproduce``: paper vs hydrohil, round trips, figures, HIL timing."""

from __future__ import annotations

import platform

from hydrohil.identification.bulk_modulus import beta_eq21
from hydrohil.reproduce.paper import BULK_FRICTION, PAPER, SPEC_SANITY
from hydrohil.reproduce.state import Reproduction

FIGURES = (   # (result key, figure path in the report folder, heading): one heading per figure, each naming it
    ("spool", "figures/fig4_spool_bode.png", "Fig 4 — spool Bode gain and phase at 5/25/50 %"),
    ("valve-static", "figures/fig5_valve_static.png",
     "Fig 5a–c — closed-port pressures, load flow near centre and over the stroke"),
    ("bulk-modulus", "figures/fig7_acceleration.png",
     "Fig 7 — acceleration amplitude vs frequency per supply pressure (linear-model fit)"),
    ("bulk-modulus", "figures/fig8_bulk_modulus.png", "Fig 8 — effective bulk modulus βe vs pressure (eq 21)"),
    ("leakage", "figures/leakage_drift.png", "Drift test (eq 23) — piston drift and internal leakage g_lkc"),
    ("friction-static", "figures/fig9_friction_static.png", "Fig 9 — static friction, symmetric vs asymmetric"),
    ("friction-dynamic", "figures/fig10_friction_dynamic.png",
     "Fig 10, σ0/σ1 fit (eq 27) — measured vs fitted force, zoom on the ringing, residual, position"),
    ("friction-dynamic", "figures/fig10_open_loop.png",
     "Fig 10, open-loop sine — rig vs hybrid model: force, pressures, spool, position, velocity"),
    ("fig11", "fig11/report.png", "Fig 11 — HIL, Kp = 50, 80 kg, point-to-point"),
    ("fig12", "fig12/report.png", "Fig 12 — HIL, Ps = 120 bar, Kp = 100, steps and ramps"),
    ("step-size", "figures/step_size.png", "Step size — hybrid vs stiff end stops"),
)


def figure_sections(figures: dict[str, list[str]]) -> list[tuple[str, str]]:
    """(heading, path) for every figure written (``figures``: step -> paths), in :data:`FIGURES` order; a
    figure not listed there comes last with its step and path as heading, so no two headings are the same."""
    titles = {path: title for _, path, title in FIGURES}
    known = [(title, path) for key, path, title in FIGURES if path in figures.get(key, [])]
    rest = [(f"{key}: {path}", path) for key, paths in figures.items() for path in paths if path not in titles]
    return known + rest


def _g(v) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _row(name: str, paper_key: str | None, ours, how: str, table=PAPER) -> str:
    if paper_key is None:
        return f"| {name} | — | — | {_g(ours)} | — | {how} |"
    val, unit, where = table[paper_key]
    diff = f"{(ours - val) / abs(val) * 100:+.2f} %" if ours is not None and val else "—"
    return f"| {name} [{unit}] | {_g(val)} | {where} | {_g(ours)} | {diff} | {how} |"


def paper_rows(r: Reproduction) -> list[str]:
    res, fits = r.results, r.fits
    ch = res["characteristics"]
    sp = fits["spool"].values
    vs = fits["valve-static"]
    ach = vs.achieved
    bulk = fits["bulk-modulus"].values
    at70 = min(bulk["per_pressure"], key=lambda p: abs(p["ps"] - 7e6))
    fs = fits["friction-static"].values
    fd = fits["friction-dynamic"].values
    st = res["step-size"]
    cyl = r.truth.cylinder
    head = ["| quantity | paper | where | hydrohil | difference | hydrohil from |", "|---|---|---|---|---|---|"]
    rows = [_row(f"spool {k}", f"spool.{k}", sp[k], "fit to synthetic Bode data (Fig 4)")
            for k in ("wn", "xi", "lv", "la", "delay")]
    for key, ck in (("valve.dpm_bar", "dpm_bar"), ("valve.crossing_bar", "crossing_bar"), ("valve.kp0", "kp0"),
                    ("valve.kq0_lpm", "kq0_lpm"), ("valve.ql0_lpm", "ql0_lpm")):
        rows.append(_row(ck, key, ch[ck], "paper's k-set through eq 3-12"))
        rows.append(_row(ck, key, ach[ck], "k-set identified from the paper's datasheet"))
    rows.append(_row("Qn at Pn from As1(1)", "valve.qn_lpm", ach["qn_lpm_from_as1"], "identified k-set"))
    for i, n in enumerate(("k1", "k2", "k3", "k4", "k5")):
        rows.append(_row(n, f"valve.{n}", vs.values["k"][i], "identified from the datasheet (slope_ratio 1)"))
        rows.append(_row(f"{n}t", f"valve.{n}t", vs.values["kt"][i], "identified from the datasheet"))
    rows += [_row("B", "cylinder.b", bulk["b"], "eq 21 fit to βe identified at 4 supply pressures"),
             _row("C", "cylinder.c", bulk["c"], "eq 21 fit"),
             _row("βe1 at Ps = 70 bar", "beta1_70bar", at70["beta1"], "linear-model fit to synthetic Fig 7 data"),
             _row("βe2 at Ps = 70 bar", "beta2_70bar", at70["beta2"], "linear-model fit"),
             _row("f at Ps = 70 bar", "f_70bar", at70["f"], "linear-model fit"),
             _row("βe1 at P10 from eq 21", "beta1_70bar", beta_eq21(at70["p10"], cyl.b, cyl.c),
                  "the paper's own B, C in eq 21"),
             _row("βe2 at P20 from eq 21", "beta2_70bar", beta_eq21(at70["p20"], cyl.b, cyl.c),
                  "the paper's own B, C in eq 21"),
             _row("g_lkc", "cylinder.g_lkc", res["leakage"]["g_lkc_from_paper_numbers"], "eq 23, paper's numbers"),
             _row("g_lkc", "cylinder.g_lkc", fits["leakage"].values["g_lkc"], "eq 23, synthetic drift series")]
    for side in ("symmetric", "negative", "positive"):
        v = fs[side]
        rows += [_row(f"{side} Fc", f"{side}.fc", v["fc"], "fit to synthetic (v, Ff) points (Fig 9)"),
                 _row(f"{side} Fs − Fc", f"{side}.fs_minus_fc", v["fs"] - v["fc"], "same fit"),
                 _row(f"{side} vs", f"{side}.vs", v["vs"], "same fit"),
                 _row(f"{side} Kv", f"{side}.kv", v["kv"], "same fit")]
    rows += [_row("σ0", "friction.sigma0", fd["sigma0"], "eq 27 on the reference-model 'rig' (Fig 10)"),
             _row("σ1", "friction.sigma1", fd["sigma1"], "eq 27 on the reference-model 'rig'"),
             _row("P10", "p10_bar", ch["p10_bar"], "eq 18", SPEC_SANITY),
             _row("P20", "p20_bar", ch["p20_bar"], "eq 18", SPEC_SANITY),
             _row("As1(1)", "as1_at_1", ch["as1_at_1"], "eq 3, paper's k-set", SPEC_SANITY),
             _row("largest stable step, hybrid", "step.hybrid", st["hybrid_s"], "bisection, RK3 (hydrohil maxstep)"),
             _row("largest stable step, stiff end stops", "step.stiff", st["continuous_s"],
                  "bisection, RK3, continuous model")]
    return head + rows


def round_trip_rows(r: Reproduction) -> list[str]:
    """Parameters used to make the synthetic data vs parameters recovered."""
    t, fits = r.truth, r.fits
    out = ["| procedure | parameter | used to make the data | recovered | error |", "|---|---|---|---|---|"]

    def add(proc, name, true, got):
        out.append(f"| {proc} | {name} | {_g(true)} | {_g(got)} | {(got - true) / abs(true) * 100:+.2f} % |")

    for k in ("wn", "xi", "lv", "la", "delay"):
        add("spool", k, getattr(t.spool, k), fits["spool"].values[k])
    for row, f_true in zip(fits["bulk-modulus"].values["per_pressure"], BULK_FRICTION):
        ps = f"Ps = {row['ps'] / 1e5:g} bar"
        add("bulk modulus", f"βe1 ({ps})", beta_eq21(row["p10"], t.cylinder.b, t.cylinder.c), row["beta1"])
        add("bulk modulus", f"βe2 ({ps})", beta_eq21(row["p20"], t.cylinder.b, t.cylinder.c), row["beta2"])
        add("bulk modulus", f"f ({ps})", f_true, row["f"])
    add("bulk modulus", "B", t.cylinder.b, fits["bulk-modulus"].values["b"])
    add("bulk modulus", "C", t.cylinder.c, fits["bulk-modulus"].values["c"])
    add("leakage", "g_lkc", t.cylinder.g_lkc, fits["leakage"].values["g_lkc"])
    for side in ("positive", "negative"):
        true = getattr(t.friction, side)
        for k in ("fc", "fs", "vs", "kv"):
            add("static friction", f"{side} {k}", getattr(true, k), fits["friction-static"].values[side][k])
    add("dynamic friction", "σ0", t.friction.sigma0, fits["friction-dynamic"].values["sigma0"])
    add("dynamic friction", "σ1", t.friction.sigma1, fits["friction-dynamic"].values["sigma1"])
    return out


def write_markdown(r: Reproduction) -> None:
    res = r.results
    wall = res["wall_time_s"]
    f10 = res["friction-dynamic"]["fig10"]
    st = res["step-size"]
    lines = [
        "# hydrohil reproduce: Ferreira et al., Hybrid models for HIL simulation of hydraulic systems, Part 2", "",
        f"Every number in this report was computed in this run ({wall['total']:.0f} s on {platform.machine()}, "
        f"{platform.processor() or platform.platform()}, Python {platform.python_version()}), except the "
        "paper's values, quoted with their section. HIL runs: " + res["mode"]["hil"] + ".", "",
        "**Synthetic measurements.** We have no rig: the measured data of the paper are replaced by synthetic "
        "data in `data/` (spool Bode curves from the spool model at its periodic steady state, acceleration "
        "amplitudes from the linear model's frequency response, "
        "constant-velocity friction points from eq 25, a drift series, and the open-loop sine of Fig 10 run on "
        "the continuous reference model — LSODA, continuous LuGre, stiff end stops — with 1 µm encoder "
        "quantisation and 0.02 bar pressure noise), made with the paper's parameter set `ferreira2004`. "
        "The identification procedures then run as a chain on those files; `identified.toml` is the result.", "",
        "## Paper vs hydrohil", "", *paper_rows(r), "",
        "Valve: the datasheet's ΔPm, K̄p0 and K̄q0 fix the centre pseudo-sections, so the centre leakage is "
        "implied by them (not fitted) and the slope split is the one free choice of eq 4–17 (`slope_ratio`, "
        "default 1); the k's therefore differ from the paper's while every characteristic is met. Friction "
        "(symmetric): the paper fitted real data; ours fits points made with the paper's per-direction values.",
        "", f"Step size: the stiff model's damper alone has a rate c/M = {st['damper_rate_per_s']:.3g} 1/s, so an "
        f"explicit RK3 step must stay below ≈ 2.5·M/c = {2.5 / st['damper_rate_per_s']:.2g} s; the paper's 2 µs "
        "for the commercial library suggests its damper acted differently. Either way the hybrid step is "
        f"{st['ratio']:.3g}× larger.", "",
        "Bulk modulus: the paper's B, C put into eq 21 give βe1, βe2 at the 70 bar equilibrium 6–13 % below the "
        "paper's own linear-model values (rows above), so the paper's numbers are not mutually consistent; our "
        "synthetic Fig 7 data follow eq 21, which is why the identified βe at 70 bar sit there.", "",
        "## Identification round trips", "", *round_trip_rows(r), "",
        "Dynamic friction: the data come from a different model (the continuous reference) than the one "
        "fitted (the hybrid model), as with a real rig. Eq 27 is then ill-posed in σ1: force RMS at the "
        "optimum and with σ1 or σ0 scaled — " + ", ".join(
            f"{k}: {_g(v)} N" for k, v in res["friction-dynamic"]["sensitivity_force_rms_n"].items()) +
        ". The open-loop sine excites a self-sustained stick-slip ringing at tens of Hz in both models "
        "(Fig 10) whose phase, not σ1, dominates the 10 ms force samples; σ0 is found within the percentage "
        "shown, σ1 is not identifiable from this experiment (with data from the hybrid model itself the "
        "round trip recovers both within 1 %: tests/test_identification.py).", "",
        f"Fig 10 (rig = reference model, model = hybrid with identified σ0, σ1, the rest as identified): "
        f"hydraulic force RMS difference {f10['fh_rms_n']:.1f} N (force amplitude {f10['fh_amplitude_n']:.0f} N), "
        f"P1 {f10['p1_rms_bar']:.2f} bar, P2 {f10['p2_rms_bar']:.2f} bar, xp {f10['xp_rms_mm']:.3f} mm, "
        f"vp {f10['vp_rms_mm_s']:.2f} mm/s RMS.", "",
        "## HIL experiments (Figs 11, 12)", "",
        "| | fig11 | fig12 |", "|---|---|---|"]
    for group in ("timing", "comparison"):
        for k in res["fig11"][group]:
            lines.append(f"| {k} | {_g(res['fig11'][group][k])} | {_g(res['fig12'][group].get(k))} |")
    lines += ["", "The paper gives these two experiments as plots only (real rig vs HIL); here the comparison is "
              "HIL vs the offline simulation of the same scenario file, and both vs the reference trajectory.", "",
              "## Figures", ""]
    for title, path in figure_sections(r.figures):
        lines += [f"### {title}", "", f"![{title}]({path})", ""]
    lines += ["## Wall time per step", "", "| step | s |", "|---|---|"]
    lines += [f"| {k} | {v:.1f} |" for k, v in wall.items()]
    (r.out / "report.md").write_text("\n".join(lines) + "\n")
