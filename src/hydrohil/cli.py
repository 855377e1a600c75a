"""Command-line interface: a thin layer over the library; every command is an importable function.

Exit codes: 0 success, 1 simulation diverged / runtime failure, 2 bad input (file, key, range).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import typer

from hydrohil.errors import HydrohilError, InputError
from hydrohil.hil.commands import controller_cmd, plant_cmd
from hydrohil.terminal import fail, interruptible, show_warnings_as_lines


def out_folder(value: Path | None) -> Path | None:
    """--out of a folder: refused at once (exit 2, before any run) when it names an existing file, or a path
    through one."""
    if value is not None:
        _through_a_file(value)
        if value.exists() and not value.is_dir():
            raise typer.BadParameter(f"{value} exists and is not a folder")
    return value


def out_file(value: Path | None) -> Path | None:
    """--out of a file: refused at once (exit 2) when it names a folder or its folder's path goes through a
    file."""
    if value is not None:
        _through_a_file(value)
        if value.is_dir():
            raise typer.BadParameter(f"{value} is a folder: give a file's name")
    return value


def _through_a_file(value: Path) -> None:
    for parent in value.parents:
        if parent.exists():
            if not parent.is_dir():
                raise typer.BadParameter(f"{parent} is a file, not a folder: {value} cannot be written")
            return

# rich_markup_mode=None: help texts are plain text, so bracketed units such as "[s]", "[s:m]" and "[hil]"
# are printed as written (rich markup would swallow them as style tags)
app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,
                  help="hydrohil: hybrid valve-cylinder models, identification and real-time HIL simulation.")
params_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None, help="Inspect parameter sets.")
app.add_typer(params_app, name="params")


def package_version() -> str:
    """The installed distribution's version (what pip reports), else the package's ``__version__``."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("hydrohil")
    except PackageNotFoundError:
        from hydrohil import __version__
        return __version__


def _print_version(value: bool):
    if value:
        typer.echo(f"hydrohil {package_version()}")
        raise typer.Exit()


@app.callback()
def _main(version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                       help="print the version and exit")):
    pass    # the app's help text is the one given to typer.Typer above


def simulate(scenario: Path, out: Path, solver: Optional[str] = None, step: Optional[float] = None,
             plot: bool = True, progress: bool = True, params: Optional[str] = None,
             sets: Optional[dict] = None, engine: str = "generated") -> dict:
    """Run one scenario and write ``out/log.csv``, ``out/summary.json`` and ``out/simulation.png``.
    ``params`` replaces the scenario's parameter set, ``sets`` (dotted keys) apply on top of its overrides;
    ``engine``: a paper scenario's run on the hand-written core or the generated code
    (:func:`hydrohil.simulation.run.run_scenario`)."""
    from hydrohil.circuits.scenario import NO_PARAMETER_SET, is_circuit_scenario
    from hydrohil.simulation.outputs import write_json, write_log_csv
    from hydrohil.simulation.run import ENGINES, run_scenario
    from hydrohil.simulation.scenario import load_scenario

    if engine not in ENGINES:
        raise InputError(f"one of {', '.join(ENGINES)}, got {engine!r}", source="--engine")
    if is_circuit_scenario(scenario):
        if params is not None:
            raise InputError(NO_PARAMETER_SET, source="--params", key=params)
        if engine != "generated":
            raise InputError("a circuit scenario runs on its generated code (no hand-written core): --engine core "
                             "is a paper scenario's", source="--engine")
        return simulate_circuit_scenario(scenario, out, solver, step, plot, progress, sets)
    sc = load_scenario(scenario, solver=solver, step=step, params=params, sets=sets)
    prog = None
    if progress and sc.scenario.solver.method == "reference" and sys.stderr.isatty():
        from rich.progress import Progress
        bar = Progress(transient=True)
        bar.start()
        task = bar.add_task("reference (LSODA)", total=sc.scenario.n_steps())
        prog = lambda k: bar.update(task, completed=k)  # noqa: E731
    try:
        res = run_scenario(sc, progress=prog, engine=engine)
    finally:
        if prog:
            bar.stop()
    out.mkdir(parents=True, exist_ok=True)
    extra = dict(res.columns)
    if sc.scenario.closed_loop:
        s = sc.scenario
        extra["x_ref"] = s.references()[0][::s.solver.output_every][:len(res.log)]
    write_log_csv(out / "log.csv", res.log, extra)
    summary = res.summary()
    summary.update({"scenario": str(scenario), "params": sc.scenario.params, "overrides": sc.scenario.overrides})
    if sc.scenario.closed_loop:
        from hydrohil.metrics import step_metrics
        summary["step_response"] = step_metrics(res.column("t"), res.column("xp"), extra["x_ref"], res.column("p1"),
                                                res.column("p2"), sliding=res.column("friction_mode"))
    write_json(out / "summary.json", summary)
    if plot:
        from hydrohil.plotting import plot_run
        plot_run(out / "simulation.png", res.column("t"), res.column("xp"), res.column("p1"), res.column("p2"),
                 res.column("u"), res.column("xs"), res.column("travel_mode"), res.column("friction_mode"),
                 res.column("spool_mode"), xref=extra.get("x_ref"), metrics=summary.get("step_response"),
                 title=f"{scenario.name} — {res.solver}, h = {res.step:g} s", faults=res.columns.get("faults"))
    if res.diverged:
        raise res.diverged
    return summary


def simulate_circuit_scenario(scenario: Path, out: Path, solver: Optional[str] = None, step: Optional[float] = None,
                              plot: bool = True, progress: bool = True, sets: Optional[dict] = None) -> dict:
    """Run a scenario that names its circuit (``circuit = ...``): ``out/log.csv`` (a column per signal,
    ``<component>.<variable> [SI unit]``), ``out/summary.json`` and ``out/plot.png``."""
    from hydrohil.circuits.scenario import load_circuit_scenario, run_circuit_scenario
    from hydrohil.circuits.show import plot_run, write_log
    from hydrohil.simulation.outputs import write_json
    cs = load_circuit_scenario(scenario, solver=solver, step=step, sets=sets)
    prog, bar = None, None
    if progress and cs.method == "reference" and sys.stderr.isatty():
        from rich.progress import Progress
        bar = Progress(transient=True)
        bar.start()
        task = bar.add_task("reference (LSODA)", total=cs.n_steps)
        prog = lambda k: bar.update(task, completed=k)  # noqa: E731
    try:
        res, summary = run_circuit_scenario(cs, progress=prog)
    finally:
        if bar:
            bar.stop()
    out.mkdir(parents=True, exist_ok=True)
    write_log(res, out / "log.csv")
    write_json(out / "summary.json", summary)
    if plot:
        plot_run(res, out / "plot.png", f"{scenario.name} ({cs.circuit.name}): {cs.method} at {cs.step * 1e3:g} ms")
    return summary


@app.command("simulate")
def simulate_cmd(scenario: Path = typer.Argument(..., help="scenario TOML"),
                 out: Path = typer.Option(Path("hydrohil-out"), "--out", callback=out_folder, help="output folder"),
                 solver: Optional[str] = typer.Option(None, help="euler|heun|rk3|rk4|reference"),
                 step: Optional[float] = typer.Option(None, help="fixed step / sample time [s]"),
                 plot: bool = typer.Option(True, help="write simulation.png (a circuit scenario: plot.png)"),
                 params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML path) in place of "
                                                   "the scenario's"),
                 sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable), on top of "
                                                "the scenario's [overrides], e.g. --set load.mass=120"),
                 engine: str = typer.Option("generated", help="a paper scenario's run (fixed step, its faults, "
                                            "a Python controller too; the continuous reference): generated (the "
                                            "code generated from its circuit, the core's log bit for bit) or core "
                                            "(the hand-written model)")):
    """Simulate a scenario with the hybrid model (or the continuous reference)."""
    try:
        s = simulate(scenario, out, solver, step, plot, params=params, sets=_parse_sets(sets), engine=engine)
    except HydrohilError as exc:
        fail(exc)
    if "circuit" in s:
        how = (f"samples every {s['step']:g} s of the continuous reference (LSODA)" if s["solver"] == "reference"
               else f"steps of {s['step']:g} s with {s['solver']}")
        typer.echo(f"{s['steps']} {how} on circuit {s['circuit']}: wall "
                   f"{s['wall_time_s']:.3f} s, real-time factor {s['realtime_factor']:.0f}; wrote {out}/log.csv, "
                   f"summary.json" + (", plot.png" if plot else ""))
        return
    written = ", ".join(["log.csv", "summary.json"] + (["simulation.png"] if plot else []))
    on = " on the generated code" if s.get("engine") == "generated" else ""
    typer.echo(f"{s['steps']} steps of {s['step']:g} s with {s['solver']}{on}: wall {s['wall_time_s']:.3f} s, "
               f"real-time factor {s['realtime_factor']:.0f}; final xp = {s['final_state']['xp'] * 1e3:.3f} mm; "
               f"wrote {out}/{written}")


@app.command("compare")
def compare_cmd(runs: list[Path] = typer.Argument(..., help="scenario TOMLs (simulated) or run folders of "
                                                 "`hydrohil simulate`"),
                out: Path = typer.Option(Path("hydrohil-compare"), "--out", callback=out_folder, help="output folder"),
                labels: Optional[str] = typer.Option(None, help="comma-separated labels, one per run"),
                title: str = typer.Option("", help="figure title"),
                params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML path) for "
                                                     "the scenarios"),
                sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable)")):
    """Overlay closed-loop runs (e.g. one scenario under several controllers): compare.png, and each run's
    step-response metrics in compare.json and on the terminal."""
    from hydrohil.compare import compare
    from hydrohil.metrics import metrics_lines
    try:
        result = compare(runs, out, labels=labels.split(",") if labels else None, params=params,
                         sets=_parse_sets(sets), title=title)
    except HydrohilError as exc:
        fail(exc)
    for r in result:
        typer.echo(f"{r.label}: RMS error {r.metrics['rms_error'] * 1e3:.3f} mm, max |error| "
                   f"{r.metrics['max_abs_error'] * 1e3:.3f} mm, {r.metrics['breakaways']} breakaways")
        for line in metrics_lines(r.metrics):
            typer.echo("  " + line)
    typer.echo(f"wrote {out}/compare.png, compare.json")


@app.command("freqresp")
def freqresp_cmd(scenario: Path = typer.Argument(..., help="scenario TOML (its parameters, step and controller), or a "
                                                 "scenario naming its circuit"),
                 out: Path = typer.Option(Path("hydrohil-freqresp"), "--out", callback=out_folder, help="output folder"),
                 amplitude: Optional[float] = typer.Option(None, help="closed loop: reference amplitude [m] (default "
                                                           "1 mm; a circuit's: in its measured signal's SI unit, "
                                                           "default by unit: 1 mm, 2 rad/s, 1 bar, ...)"),
                 u_amplitude: Optional[float] = typer.Option(None, help="open loop: command amplitude [ū] (default "
                                                             "0.02; a circuit's: in its input's SI unit, default 1 % "
                                                             "of its range)"),
                 input_: Optional[str] = typer.Option(None, "--input", help="a circuit's open loop: the input it "
                                                      "drives (default: its loop's command)"),
                 signal: Optional[str] = typer.Option(None, "--signal", help="a circuit's open loop: the signal "
                                                      "measured (default: its loop's measured signal)"),
                 around: Optional[float] = typer.Option(None, "--around", help="a circuit's closed loop: the "
                                                        "operating point, SI (default: the reference's last value)"),
                 fmin: float = typer.Option(0.5, help="lowest frequency [Hz]"),
                 fmax: float = typer.Option(50.0, help="highest frequency [Hz]"),
                 points: int = typer.Option(15, min=2, max=500, help="frequencies, log-spaced"),
                 loop: str = typer.Option("both", help="closed | open | both"),
                 workers: Optional[int] = typer.Option(None, min=1, help="parallel points (default: every core)"),
                 params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML path)"),
                 sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable)")):
    """Frequency responses of the nonlinear model by stepped sines at periodic steady state (closed loop
    x/x_ref, open loop x/ū; a circuit's: its loop's measured signal per its reference, a signal per an input),
    beside the linear model's: freqresp.csv, bode.png, freqresp.json."""
    from hydrohil.circuits.scenario import NO_PARAMETER_SET, is_circuit_scenario, load_circuit_scenario
    from hydrohil.errors import InputError
    from hydrohil.freqresp import circuit_freqresp, freqresp
    from hydrohil.simulation.scenario import load_scenario
    loops = {"both": ("closed", "open"), "closed": ("closed",), "open": ("open",)}
    try:
        if loop not in loops:
            raise InputError("expected closed, open or both", source="--loop", key=loop)
        circuit = is_circuit_scenario(scenario)
        if circuit:
            if params is not None:
                raise InputError(NO_PARAMETER_SET, source="--params")
            cs = load_circuit_scenario(scenario, sets=_parse_sets(sets))
            chosen = loops[loop] if loop != "both" or cs.loop is not None else ("open",)
        elif input_ is not None or signal is not None or around is not None:
            raise InputError("--input, --signal and --around choose a circuit's responses: this scenario names no "
                             "circuit", source="--input/--signal/--around")
        else:
            sc = load_scenario(scenario, params=params, sets=_parse_sets(sets))
            chosen = loops[loop]
        from rich.progress import Progress
        with Progress(transient=True, disable=not sys.stderr.isatty()) as bar:
            task = bar.add_task("stepped sines", total=points * len(chosen))
            tick = lambda k, n: bar.update(task, completed=k)   # noqa: E731
            if circuit:
                s = circuit_freqresp(cs, out, fmin=fmin, fmax=fmax, points=points, amplitude=amplitude,
                                     u_amplitude=u_amplitude, loops=chosen, input_=input_, signal=signal,
                                     around=around, workers=workers, progress=tick)
            else:
                s = freqresp(sc, out, fmin=fmin, fmax=fmax, points=points,
                             amplitude=1e-3 if amplitude is None else amplitude,
                             u_amplitude=0.02 if u_amplitude is None else u_amplitude, loops=chosen, workers=workers,
                             progress=tick)
    except HydrohilError as exc:
        fail(exc)
    for name, info in s["loops"].items():
        line = f"{name} loop: {info['points']} points, {info['unconverged']} not converged"
        if "bandwidth_hz" in info:
            line += f", bandwidth (−3 dB) {info['bandwidth_hz']:.3g} Hz" if info["bandwidth_hz"] else ", bandwidth above fmax"
        if "max_gain_gap_db_below_bandwidth" in info:
            line += (f"; vs linear below it: {info['max_gain_gap_db_below_bandwidth']:.2f} dB, "
                     f"{info['max_phase_gap_deg_below_bandwidth']:.1f}°")
        if "max_gain_gap_db" in info:
            line += f"; vs linear: {info['max_gain_gap_db']:.2f} dB, {info['max_phase_gap_deg']:.1f}°"
        typer.echo(line)
    typer.echo(f"wrote {out}/freqresp.csv, bode.png, freqresp.json")


@app.command("maxstep")
def maxstep_cmd(scenario: Path = typer.Argument(..., help="scenario TOML"),
                model: str = typer.Option("hybrid", help="hybrid|continuous"),
                solver: str = typer.Option("rk3", help="euler|heun|rk3|rk4"),
                duration: Optional[float] = typer.Option(None, help="override the scenario duration [s]"),
                tol_x: float = typer.Option(2e-3, help="max RMS position error vs reference [m]"),
                tol_p: float = typer.Option(10e5, help="max RMS pressure error vs reference [Pa]"),
                params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML path) in place of "
                                                  "the scenario's"),
                sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable), on top of "
                                               "the scenario's [overrides], e.g. --set load.mass=120")):
    """Find the largest stable fixed step by bisection; prints JSON. A circuit scenario: the hybrid model
    against the circuit's continuous reference, with the accuracy at the scenario's step."""
    from hydrohil.circuits.scenario import is_circuit_scenario, load_circuit_scenario
    from hydrohil.maxstep import circuit_max_stable_step, max_stable_step
    from hydrohil.simulation.scenario import load_scenario
    say = lambda h, r: typer.echo(f"  h = {h:.3e} s: {r['reason']}", err=True)  # noqa: E731
    try:
        if is_circuit_scenario(scenario):
            if model != "hybrid" or params is not None:
                raise InputError("a circuit scenario: the hybrid model (against its continuous reference), its "
                                 "values by --set", source=str(scenario), key="--model/--params")
            cs = load_circuit_scenario(scenario, duration=duration, sets=_parse_sets(sets))
            res = circuit_max_stable_step(cs, solver, tol_x=tol_x, tol_p=tol_p, progress=say)
            typer.echo(res["verdict"], err=True)                # (stdout: the JSON alone)
            typer.echo(json.dumps(res, indent=2))
            return
        sc = load_scenario(scenario, duration=duration, params=params, sets=_parse_sets(sets))
        res = max_stable_step(sc, model, solver, tol_x=tol_x, tol_p=tol_p, progress=say)
    except HydrohilError as exc:
        fail(exc)
    except ValueError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2)
    typer.echo(json.dumps(res, indent=2))


@params_app.command("show")
def params_show(name: str = typer.Argument("ferreira2004", help="built-in name or TOML path"),
                as_json: bool = typer.Option(False, "--json", help="print JSON instead of TOML")):
    """Print a resolved, validated parameter set: TOML (it loads back unchanged) with each key's unit and
    description; groups the file lacks are derived and marked so. --json: {"parameters": the values,
    "fields": [{key, value, unit, description, derived}], "derived": [groups]}."""
    from hydrohil.parameters.show import annotated_toml, fields, load_shown
    try:
        prm, derived = load_shown(name)
    except HydrohilError as exc:
        fail(exc)
    if as_json:
        typer.echo(json.dumps({"parameters": prm.model_dump(mode="json"), "fields": fields(prm, derived),
                               "derived": list(derived)}, indent=2))
    else:
        typer.echo(annotated_toml(prm, derived), nl=False)


@params_app.command("list")
def params_list():
    """List the built-in parameter sets."""
    from hydrohil.parameters import builtin_names
    for n in builtin_names():
        typer.echo(n)


def linear(params: Optional[str] = None, sets: Optional[dict] = None, scenario: Optional[Path] = None,
           xp: Optional[float] = None, xs: Optional[float] = None, ps: Optional[float] = None,
           load: Optional[float] = None, friction: bool = True, out: Optional[Path] = None) -> list:
    """The plant linearised at rest (``hydrohil.linear``): at ``xp`` (default ``linear.xp0``), or at each hold
    of ``scenario``'s reference (its parameters, with ``params``/``sets`` applied). Writes ``out`` when given."""
    import numpy as np
    from hydrohil.linear import linearise, save
    from hydrohil.parameters import load_parameters
    if scenario is not None:
        from hydrohil.metrics import holds
        from hydrohil.simulation.scenario import load_scenario
        sc = load_scenario(scenario, params=params, sets=sets)
        s, pset = sc.scenario, sc.params
        if xp is not None:
            points = [xp]
        elif s.closed_loop:
            t = np.arange(s.n_steps() + 1) * s.solver.step
            x_ref = s.references()[0]
            points = list(dict.fromkeys(float(x_ref[i]) for i, _ in holds(t, x_ref)))
        else:
            points = [s.initial.xp]
    else:
        pset = load_parameters(params or "ferreira2004", sets)
        points = [xp]
    models = [linearise(pset, x, xs=xs, ps=ps, load=load, friction=friction) for x in points]
    if out is not None:
        save(models, out)
    return models


@app.command("linear")
def linear_cmd(params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML path); "
                                                    "default the paper's, or the scenario's"),
               sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable)"),
               scenario: Optional[Path] = typer.Option(None, "--scenario", help="operating points at the holds of "
                                                       "this scenario's reference, with its parameters"),
               xp: Optional[float] = typer.Option(None, "--xp", help="piston position [m] (default linear.xp0)"),
               xs: Optional[float] = typer.Option(None, "--xs", help="force the spool offset [-] (default: the "
                                                  "equilibrium's)"),
               ps: Optional[float] = typer.Option(None, "--ps", help="supply pressure [Pa]"),
               load: Optional[float] = typer.Option(None, "--load", help="external load force F_L [N] "
                                                    "(against +x)"),
               friction: bool = typer.Option(True, help="friction's local viscous slope in the model"),
               as_json: bool = typer.Option(False, "--json", help="print JSON (every matrix)"),
               out: Optional[Path] = typer.Option(None, "--out", callback=out_file, help="write the model(s): .npz, .mat or .json")):
    """The plant linearised at rest: equilibrium spool offset and pressures, A/B/C/D, eigenvalues,
    hydraulic natural frequency and damping, checked against the closed form."""
    try:
        models = linear(params, _parse_sets(sets), scenario, xp, xs, ps, load, friction, out)
    except HydrohilError as exc:
        fail(exc)
    if as_json:
        typer.echo(json.dumps([m.to_dict() for m in models] if len(models) > 1 else models[0].to_dict(), indent=2))
        return
    for m in models:
        pt, c = m.point, m.coefficients
        typer.echo(f"xp = {pt.xp * 1e3:.1f} mm, Ps = {pt.ps / 1e5:.0f} bar, F_L = {pt.load:g} N: spool offset "
                   f"xs0 = {pt.xs:+.5f}, P1 = {pt.p1 / 1e5:.2f} bar, P2 = {pt.p2 / 1e5:.2f} bar"
                   + (f", net force {pt.net_force:+.0f} N (forced --xs: not at rest)" if xs is not None else ""))
        typer.echo(f"  beta1 = {c['beta1'] / 1e6:.0f} MPa, beta2 = {c['beta2'] / 1e6:.0f} MPa, V1 = {c['V1'] * 1e6:.1f} "
                   f"cm³, V2 = {c['V2'] * 1e6:.1f} cm³, Kq1 = {c['Kq1']:.3g}, Kq2 = {c['Kq2']:.3g} m³/s, "
                   f"Kc1 = {c['Kc1']:.3g}, Kc2 = {c['Kc2']:.3g} m³/(s·Pa)")
        typer.echo(f"  hydraulic natural frequency {m.natural_frequency:.1f} rad/s ({m.natural_frequency / 2 / 3.141592653589793:.1f} "
                   f"Hz), damping {m.damping:.4f} (friction slope {m.friction_slope:g} N·s/m); closed form "
                   f"√((β1A1²/V1 + β2A2²/V2)/M) = {m.closed_form_frequency:.1f} rad/s; valve delay "
                   f"{m.delay * 1e3:.3g} ms")
        typer.echo("  eigenvalues: " + ", ".join(f"{e.real:.4g}{e.imag:+.4g}j" for e in m.eigenvalues))
    if out is not None:
        typer.echo(f"wrote {out}")


circuit_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                          help="Hydraulic circuits from the component library (README: Circuits).")
app.add_typer(circuit_app, name="circuit")


@circuit_app.command("show")
def circuit_show(circuit: Optional[str] = typer.Argument(None, help="built-in name (an example circuit or a "
                                                         "parameter set), circuit TOML or parameter file (or "
                                                         "--scenario)"),
                 scenario: Optional[Path] = typer.Option(None, "--scenario", help="a scenario naming its circuit: "
                                                         "its [set], drives and loop (the stiffness over its run)"),
                 as_json: bool = typer.Option(False, "--json", help="print JSON"),
                 step: float = typer.Option(5e-4, "--step", help="fixed step [s] the stiffness is judged at"),
                 method: str = typer.Option("rk3", "--method", help="euler, heun, rk3 or rk4")):
    """Components with their parameters (SI, as written, derived), nodes (fixed, or a pressure state with its
    volume, initial pressure, stiffness at the step and the method's treatment), states, modes, inputs and
    signals with units. --json: the same as data (signals as {name, unit}). With --scenario: the circuit as the
    scenario sets it, the stiffness over the scenario's run (a closed loop's piston starts held)."""
    from hydrohil.circuits.scenario import circuit_scenario
    from hydrohil.circuits.show import describe, text
    try:
        if circuit is None and scenario is None:
            raise InputError("give a circuit (a built-in name or a circuit TOML) or --scenario FILE", key="circuit")
        cs = circuit_scenario(circuit=circuit, scenario=scenario)
        d = describe(cs.circuit, h=step, method=method, scenario=cs if scenario is not None else None)
    except HydrohilError as exc:
        fail(exc)
    typer.echo(json.dumps(d, indent=2) if as_json else text(d), nl=as_json)


@circuit_app.command("draw")
def circuit_draw(circuit: str | None = typer.Argument(None, help="built-in name (an example circuit or a parameter "
                                                                  "set) or circuit TOML"),
                 out: Path = typer.Option(..., "--out", callback=out_file, help="F.png or F.svg"),
                 scenario: Path | None = typer.Option(None, "--scenario", help="a scenario naming its circuit: "
                                                      "drawn as it runs it, its faults marked")):
    """The circuit drawn with ISO 1219 symbols (laid out by Graphviz): each component's symbol with its key
    figures, the lines to its ports, the nodes, the signals; with --scenario, the scenario's faults (a leak's
    orifice, a parameter changed) in red."""
    from hydrohil.circuits.draw import draw_circuit
    from hydrohil.circuits.scenario import circuit_scenario
    try:
        cs = circuit_scenario(circuit=circuit, scenario=scenario)
        typer.echo(f"wrote {draw_circuit(cs.circuit, out, faults=cs.faults, loop=cs.loop)}")
    except HydrohilError as exc:
        fail(exc)


def circuit_convert(scenario: Path, out: Path, params: Optional[str] = None, sets: Optional[dict] = None,
                    check: bool = False) -> dict:
    """A scenario of the paper's rig (``params``, ``sets`` applied as ``simulate`` does) written as a circuit
    scenario into the folder ``out`` (circuit.toml, scenario.toml; :mod:`hydrohil.simulation.as_circuit`): what
    it wrote and the notes on what changed form. ``check``: both run, the core's log against the generated
    code's column by column (:func:`hydrohil.simulation.convert_check.check`, also written to ``out/check.json``)."""
    from hydrohil.circuits.scenario import is_circuit_scenario
    from hydrohil.simulation.as_circuit import convert
    from hydrohil.simulation.convert_check import check as check_runs
    from hydrohil.simulation.scenario import load_scenario
    if is_circuit_scenario(scenario):
        raise InputError("a circuit scenario already (it names its circuit): nothing to convert", source=str(scenario),
                         key="circuit")
    ls = load_scenario(scenario, params=params, sets=sets)
    cpath, spath, notes = convert(ls, out)
    r = {"circuit": str(cpath), "scenario": str(spath), "notes": notes}
    if check:
        r["check"] = check_runs(ls, spath)
        (Path(out) / "check.json").write_text(json.dumps(r["check"], indent=2))
    return r


@circuit_app.command("convert")
def circuit_convert_cmd(scenario: Path = typer.Argument(..., help="a scenario of the paper's rig (params = ...)"),
                        out: Path = typer.Option(..., "--out", callback=out_folder, help="folder for circuit.toml and scenario.toml"),
                        params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML "
                                                             "path) in place of the scenario's"),
                        sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable), on "
                                                       "top of the scenario's [overrides]"),
                        check: bool = typer.Option(False, "--check", help="run both, the core and the generated code, "
                                                   "and compare every column of the core's log (check.json)")):
    """A paper scenario as a circuit scenario: its rig the circuit of its parameters, its drive, loop, encoder,
    faults and [hil] in a circuit scenario's terms, for the generated code to run (simulate, hil, test, export);
    its runs are the core's to rounding (--check shows it on this scenario). What a circuit cannot express is
    refused, naming the key."""
    try:
        r = circuit_convert(scenario, out, params, _parse_sets(sets), check)
    except HydrohilError as exc:
        fail(exc)
    for note in r["notes"]:
        typer.echo(f"note: {note}")
    typer.echo(f"wrote {r['circuit']}, {r['scenario']}")
    if check:
        _print_check(r["check"], Path(out) / "check.json")


def _print_check(c: dict, path: Path) -> None:
    """The core's run against the generated code's, column by column (circuit convert --check)."""
    from hydrohil.core.shape import QUANTITIES
    typer.echo(f"check: the core's run against the generated code's, {c['rows']} rows (paper_log: the core's "
               "columns from the circuit's)")
    typer.echo(f"  {'column':<14} {'largest difference':>20} {'of its peak':>12}")
    for name, v in c["columns"].items():
        if "relative" in v and name != "t":
            unit = QUANTITIES[name].unit if name in QUANTITIES else "-"
            typer.echo(f"  {name:<14} {v['max_abs_difference']:>16.2g} {unit:<3} {v['relative']:>12.2g}")
    discrete = [n for n, v in c["columns"].items() if "rows_differing" in v]
    differ = [f"{n} ({c['columns'][n]['rows_differing']} rows)" for n in discrete
              if c["columns"][n]["rows_differing"]]
    typer.echo(f"  {', '.join(discrete)}: " + (f"differ: {', '.join(differ)}" if differ else "the same at every row"))
    typer.echo(f"  largest: {c['worst']} ({c['columns'][c['worst']]['relative']:.2g} of its peak); wrote {path}")


@circuit_app.command("run")
def circuit_run(circuit: str = typer.Argument(..., help="built-in name (an example circuit or a parameter set), "
                                                      "circuit TOML or parameter file"),
                out: Path = typer.Option(..., "--out", callback=out_folder, help="folder for log.csv and plot.png"),
                duration: Optional[float] = typer.Option(None, "--duration", help="[s] (default: the inputs' "
                                                         "last change + 2 s)"),
                step: float = typer.Option(5e-4, "--step", help="fixed step [s]"),
                method: str = typer.Option("rk3", "--method", help="euler, heun, rk3 or rk4")):
    """Simulate a circuit offline with its default inputs: log.csv (every signal, SI) and plot.png."""
    from hydrohil.circuits.circuit import load_circuit
    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.show import default_duration, write_run
    try:
        c = load_circuit(circuit)
        res = simulate_circuit(c, default_duration(c) if duration is None else duration, h=step, method=method)
        files = write_run(res, out, f"{c.name}: {method} at {step * 1e3:g} ms")
    except HydrohilError as exc:
        fail(exc)
    typer.echo(f"wrote {', '.join(str(f) for f in files)}")


def circuit_linear(circuit: Optional[str] = None, sets: Optional[dict] = None, out: Optional[Path] = None,
                   scenario: Optional[Path] = None, at: Optional[float] = None):
    """A circuit (built-in name or file, ``sets`` on top) linearised at its state at rest
    (:func:`hydrohil.circuits.linear.linearise_circuit`); with ``scenario`` its inputs and loop (closed around
    it), with ``at`` at the state of the scenario's run at that time; written to ``out`` (.json or .npz)."""
    from hydrohil.circuits.linear import linearise_circuit, run_state
    from hydrohil.circuits.scenario import circuit_scenario
    if out is not None and Path(out).suffix not in (".json", ".npz"):
        raise InputError(f"a .json or .npz file, got {Path(out).name}", source="--out", key=str(out))
    cs = circuit_scenario(circuit=circuit, scenario=scenario, sets=sets)
    where = "at rest" if at is None else f"at t = {at:g} s of {Path(cs.source).name}"
    state = run_state(cs, at) if at is not None else None
    lin = linearise_circuit(cs.circuit, h=cs.step, loop=cs.loop, state=state, at=where, rest=cs.rest)
    if out is not None:
        out = Path(out)
        if out.suffix == ".npz":
            import numpy as np
            np.savez(out, A=lin.A, B=lin.B, x0=lin.x0, u0=lin.u0, states=lin.states, inputs=lin.inputs,
                     **({"A_closed": np.array(lin.closed["A"])} if lin.closed and "A" in lin.closed else {}))
        else:
            out.write_text(json.dumps(lin.to_dict(), indent=2))
    return lin


def _echo_modes(modes: list[dict], eigenvalues) -> None:
    for m in modes:
        if "damping" in m:
            typer.echo(f"  oscillation {m['natural_frequency_rad_s']:.1f} rad/s ({m['frequency_hz']:.1f} Hz), "
                       f"damping {m['damping']:.3f}")
        elif "time_constant_s" in m:
            typer.echo(f"  time constant {m['time_constant_s']:.4g} s (eigenvalue {m['eigenvalue'][0]:.4g} 1/s)")
        elif abs(m["eigenvalue"][0]) < 1e-9 * max(abs(e) for e in eigenvalues):
            typer.echo("  an integrator (eigenvalue 0): a position the circuit does not pull back")
        else:
            typer.echo(f"  growing: eigenvalue {m['eigenvalue'][0]:.4g} 1/s (e-fold in {m['growth_time_s']:.4g} s)")


@circuit_app.command("linear")
def circuit_linear_cmd(circuit: Optional[str] = typer.Argument(None, help="built-in name (examples/circuits/NAME) or "
                                                               "circuit TOML (or --scenario)"),
                       scenario: Optional[Path] = typer.Option(None, "--scenario", help="a scenario naming its "
                                                               "circuit: its inputs, [set] and loop (closed around "
                                                               "the model)"),
                       at: Optional[float] = typer.Option(None, "--at", help="linearise at the state of the "
                                                          "scenario's run at this time [s] (default: at rest)"),
                       sets: list[str] = typer.Option([], "--set", help="component.key=value (repeatable)"),
                       as_json: bool = typer.Option(False, "--json", help="print JSON (A, B, the modes)"),
                       out: Optional[Path] = typer.Option(None, "--out", callback=out_file, help="write the model: .json or .npz")):
    """The circuit linearised at its state at rest (or at --at of a scenario's run): A, B by central differences
    of its generated right-hand side, its eigenvalues as time constants and as natural frequencies with their
    damping; with a scenario's loop, the closed loop's poles (P and PI, the law taken continuous)."""
    import numpy as np
    try:
        if at is not None and scenario is None:
            raise InputError("--at is a time of a scenario's run: give --scenario", key="--at")
        lin = circuit_linear(circuit, _parse_sets(sets), out, scenario, at)
    except HydrohilError as exc:
        fail(exc)
    if as_json:
        typer.echo(json.dumps(lin.to_dict(), indent=2))
        return
    typer.echo(f"{circuit or scenario}: {len(lin.states)} states ({', '.join(lin.states)}), inputs "
               f"{', '.join(lin.inputs) or 'none'}; linearised {lin.at}")
    if lin.moving():
        rates = {st: (r, u) for st, u, r in zip(lin.states, lin.state_units, lin.rate)}
        moving = ", ".join(f"{st} {rates[st][0]:.3g} {rates[st][1]}/s" for st in lin.moving())
        typer.echo(f"  not an equilibrium: {moving} (an [initial] pressure, an unbalanced load, a run on its way, a "
                   "sampled loop's dither): the model is the tangent there")
    _echo_modes(lin.modes(), lin.eigenvalues)
    cl = lin.closed
    if cl is not None and "modes" in cl:
        left = "".join(f"; without {x}" for x in cl.get("left_out", []))
        typer.echo(f"closed loop ({cl['law']} on {cl['measure']} -> {cl['command']}, the law taken continuous{left}):")
        _echo_modes(cl["modes"], np.array([complex(*e) for e in cl["eigenvalues"]]))
    elif cl is not None:
        typer.echo(f"closed loop: {cl['note']}")
    if out is not None:
        typer.echo(f"wrote {out}")


export_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None,
                         help="Generate real-time code of the plant from the C core.")
app.add_typer(export_app, name="export")


def export_fmu(out: Path, params: str = "ferreira2004", fmi: int = 2, step: Optional[float] = None,
               circuit: Optional[str] = None, scenario: Optional[Path] = None, sets: Optional[dict] = None,
               platforms: Optional[list[str]] = None) -> Path:
    """Write an FMU (FMI 2.0 or 3.0; Co-Simulation and Model Exchange) of the plant with the parameter set
    ``params``; or of a circuit (``circuit``: a built-in name or a circuit file; ``scenario``: a scenario naming its circuit, whose [set] and
    closed loop's start it takes), ``sets`` on top (a circuit's "component.key", the paper's rig's "group.key" ->
    value). Its binaries: this machine's and every platform whose cross compiler is here, or ``platforms``."""
    from hydrohil.export.fmu import export_circuit_fmu, export_fmu as build
    if circuit is not None or scenario is not None:
        from hydrohil.circuits.scenario import circuit_scenario
        cs = circuit_scenario(circuit=circuit, scenario=scenario, sets=sets, step=step)
        return export_circuit_fmu(cs.circuit, out, fmi=fmi, step=cs.step, loop=cs.loop, rest=cs.rest,
                                  platforms=platforms)
    return build(_set_values(params, sets), out, fmi=fmi, step=5e-4 if step is None else step, platforms=platforms)


def _set_values(params: str, sets: Optional[dict]):
    """The parameter set ``params`` with ``--set`` values (group.key=value, as a scenario's [overrides]) on top,
    the error naming --set."""
    from hydrohil.parameters import load_parameters
    if not sets:
        return load_parameters(params)
    try:
        return load_parameters(params, sets)
    except InputError as exc:
        raise InputError(exc.message, source="--set", key=exc.key) from None


@export_app.command("fmu")
def export_fmu_cmd(out: Path = typer.Option(..., "--out", callback=out_file, help="FMU file to write (.fmu)"),
                   params: str = typer.Option("ferreira2004", "--params", help="parameter set (name or path)"),
                   fmi: int = typer.Option(2, "--fmi", help="FMI version: 2 or 3"),
                   step: Optional[float] = typer.Option(None, "--step", help="internal fixed step [s] (default: "
                                                        "0.5 ms, or the scenario's)"),
                   circuit: Optional[str] = typer.Option(None, "--circuit", help="a circuit (built-in name or "
                                                         "circuit TOML) in place of the paper's rig"),
                   scenario: Optional[Path] = typer.Option(None, "--scenario", help="a scenario naming its circuit: "
                                                           "its circuit, [set], step and closed loop's start"),
                   sets: list[str] = typer.Option([], "--set", help="a parameter on top (repeatable): the paper's "
                                                  "rig's group.key=value (--set cylinder.bulk_modulus=constant), "
                                                  "a circuit's component.key=value (--set 'cyl1.mass=300 kg')"),
                   platforms: list[str] = typer.Option([], "--platform", help="a platform to build a binary for "
                                                       "(repeatable): host, x86_64-linux, aarch64-linux, "
                                                       "x86_64-windows (default: this machine's and every one whose "
                                                       "cross compiler is installed)")):
    """FMU of the plant, or of a circuit (Co-Simulation and Model Exchange): its C sources (declared: any importer
    may rebuild it for its target) and binaries built here; see the README."""
    try:
        path = export_fmu(out, params, fmi, step, circuit, scenario, _parse_sets(sets), platforms or None)
    except HydrohilError as exc:
        fail(exc)
    from fmpy import read_model_description
    md = read_model_description(str(path))
    what = (f"circuit {md.description.split(chr(39))[1]}" if circuit or scenario else f"parameter set {params}")
    import zipfile
    with zipfile.ZipFile(path) as z:
        bins = sorted({n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2})
    kinds = " and ".join(k for k, on in (("Model Exchange", md.modelExchange), ("Co-Simulation", md.coSimulation))
                         if on)
    typer.echo(f"wrote {path} (FMI {fmi}.0 {kinds} of {what}, internal step "
               f"{md.defaultExperiment.stepSize} s; binaries: {', '.join(bins)}; sources)")


def export_c(out: Path, params: str = "ferreira2004", step: float = 5e-4, duration: float = 10.0,
             scenario: Optional[Path] = None, make: bool = True, circuit: Optional[str] = None,
             sets: Optional[dict] = None) -> Path:
    """Write the standalone real-time C plant (sources + Makefile) into the folder ``out`` and, with
    ``make``, build it there; returns the folder. ``scenario``: take the parameters, step, duration,
    initial state and [hil] settings from it; a scenario naming its circuit, or ``circuit`` (a built-in name
    or file, its default drive): that circuit's plant. ``sets`` on top: a circuit's component.key=value, the paper's
    rig's group.key=value (as a scenario's [overrides])."""
    from hydrohil.export.cplant import build, export_c as write, export_circuit_c, scenario_options
    from hydrohil.parameters import load_parameters
    from hydrohil.circuits.scenario import circuit_scenario, is_circuit_scenario
    if circuit is not None or (scenario is not None and is_circuit_scenario(scenario)):
        cs = circuit_scenario(circuit=circuit, scenario=scenario, sets=sets)
        folder = export_circuit_c(cs, out)
    elif scenario is not None:
        from hydrohil.simulation.scenario import load_scenario
        sc = load_scenario(scenario, sets=sets)
        folder = write(sc.params, out, **scenario_options(sc.scenario), label=scenario.name)
    else:
        folder = write(_set_values(params, sets), out, step=step, duration=duration, label=str(params))
    if make:
        build(folder)
    return folder


@export_app.command("c")
def export_c_cmd(out: Path = typer.Option(..., "--out", help="folder to write the sources and Makefile into"),
                 params: str = typer.Option("ferreira2004", "--params", help="parameter set (name or path)"),
                 step: float = typer.Option(5e-4, "--step", help="default plant step [s]"),
                 duration: float = typer.Option(10.0, "--duration", help="default simulated time to serve [s]"),
                 scenario: Optional[Path] = typer.Option(None, "--scenario", help="take parameters, step, duration, "
                                                         "initial state and [hil] settings from a scenario"),
                 make: bool = typer.Option(True, "--make/--no-make", help="build it here with make (CC honoured)"),
                 circuit: Optional[str] = typer.Option(None, "--circuit", help="a circuit (built-in name or TOML): "
                                                       "its plant, with its default drive"),
                 sets: list[str] = typer.Option([], "--set", help="a parameter on top (repeatable): the paper's "
                                                "rig's group.key=value, a circuit's component.key=value")):
    """Standalone real-time C plant (no Python on the target): sources + Makefile; see the README. A circuit
    (--circuit, or a scenario naming one): its generated C behind the same plant (protocol: SIGNALS/INPUTS)."""
    try:
        folder = export_c(out, params, step, duration, scenario, make, circuit, _parse_sets(sets))
    except HydrohilError as exc:
        fail(exc)
    typer.echo(f"wrote {folder} (C sources, Makefile" + (f"; built {folder / 'hydrohil_plant'})" if make else
               "; build with: make -C " + str(folder) + ")"))


def _parse_sets(items: list[str]) -> dict:
    """``key=value`` pairs from repeated ``--set`` options; values are TOML literals (``0`` is an
    integer, ``7e6`` a float, ``true`` a boolean), exactly as in a scenario's ``[overrides]``, a word (``constant``:
    an option, as the TOML string "constant") or a number with its unit (``300 kg``: a circuit's parameter)."""
    import re
    import tomllib
    from hydrohil.errors import InputError
    out = {}
    for it in items:
        key, sep, val = it.partition("=")
        if not sep:
            raise InputError("expected key=value, e.g. load.gravity_direction=0", source="--set", key=it)
        try:
            out[key.strip()] = tomllib.loads(f"v = {val.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            if re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", val.strip()):   # a word: an option (bulk_modulus=constant)
                out[key.strip()] = val.strip()
                continue
            if not re.match(r"^[-+]?[0-9.]+([eE][-+]?[0-9]+)?\s*[A-Za-z%°(][\w/.^%°()³²]*$", val.strip()):
                raise InputError(f"not a TOML value nor a number with its unit: {val!r}", source="--set",
                                 key=key) from None
            out[key.strip()] = val.strip()        # "300 kg", "150bar": a value with its unit (circuits)
    return out


def identify(procedure: str, data: Path, out: Optional[Path] = None, params: str = "ferreira2004",
             report: Optional[Path] = None, conditions: Optional[dict] = None, progress: bool = True) -> dict:
    """Run one identification procedure (or ``all`` with a chain config) and write the parameter file
    ``out`` (the ``params`` set with the identified values) and the report figures into ``report``.
    Returns the JSON document the CLI prints with ``--json``."""
    from hydrohil.identification import PROCEDURES
    from hydrohil.identification import identify as run_one
    from hydrohil.identification.chain import identify_all
    from hydrohil.identification.report import write_report
    from hydrohil.parameters import load_parameters, save_parameters

    if procedure != "all" and procedure not in PROCEDURES:
        from hydrohil.errors import InputError
        raise InputError(f"unknown procedure (one of: {', '.join(PROCEDURES)}, all)", source="identify",
                         key=procedure)
    bar = None
    cb = None
    if progress and sys.stderr.isatty():
        from rich.progress import Progress
        bar = Progress(transient=True)
        bar.start()
        task = bar.add_task(procedure, total=1)
        cb = lambda k, n: bar.update(task, completed=k, total=n)  # noqa: E731
    try:
        if procedure == "all":
            start = (lambda name: bar.update(task, description=name, completed=0)) if bar else None
            result, fits = identify_all(data, on_start=start, progress=cb)
            doc = {"procedures": [f.to_json() for f in fits]}
        else:
            base = load_parameters(params)
            fit = run_one(procedure, data, base, conditions, progress=cb)
            result, fits = fit.apply(base), [fit]
            doc = fit.to_json()
    finally:
        if bar:
            bar.stop()
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        header = (f"written by `hydrohil identify {procedure} {data}`\n"
                  + "\n".join(f"{f.procedure}: " + ", ".join(f"{k} = {v}" for k, v in f.updates.items()) for f in fits)
                  + "".join(f"\n{f.procedure}: {k} not identifiable: {v['why']}" for f in fits
                            for k, v in f.not_identifiable.items()))
        save_parameters(result, out, header=header)
        doc["params_file"] = str(out)
    if report is not None:
        doc["report"] = [str(p) for f in fits for p in write_report(f, report)]
    return doc


@app.command("identify")
def identify_cmd(procedure: str = typer.Argument(..., help="spool|valve-static|bulk-modulus|leakage|"
                                                 "friction-static|friction-dynamic|all"),
                 data: Path = typer.Argument(..., help="input file (CSV/TOML; for `all` the chain config)"),
                 out: Optional[Path] = typer.Option(None, "--out", callback=out_file, help="parameter file to write (TOML)"),
                 params: str = typer.Option("ferreira2004", help="starting parameter set (name or path)"),
                 report: Optional[Path] = typer.Option(None, "--report", help="folder for the fit figures"),
                 as_json: bool = typer.Option(False, "--json", help="print the fitted values as one JSON object"),
                 sets: list[str] = typer.Option([], "--set", help="experiment condition key=value (repeatable), "
                                                "e.g. load.gravity_direction=0; used for the fit only")):
    """Identify model parameters from a datasheet or a measurement (paper §3)."""
    try:
        doc = identify(procedure, data, out, params, report, _parse_sets(sets))
    except HydrohilError as exc:
        fail(exc)
    if as_json:
        typer.echo(json.dumps(doc, indent=2, default=float))
    else:
        for f in doc.get("procedures", [doc]):
            vals = {k: v for k, v in f.items() if k not in ("procedure", "achieved", "curves", "targets",
                                                          "relative_error", "notes", "per_pressure",
                                                          "not_identifiable")}
            typer.echo(f"{f['procedure']}: " + json.dumps(vals, default=float))
            for k, v in f.get("not_identifiable", {}).items():
                typer.echo(f"  not identifiable: {k}: {v['why']}")
            for n in f.get("notes", []):
                typer.echo(f"  note: {n}")
        if out:
            typer.echo(f"wrote {out}")
        if report:
            typer.echo(f"wrote {len(doc['report'])} figure(s) to {report}")


# the HIL processes: their command lines are defined beside them (python -m hydrohil.hil runs the same)
app.command("plant")(plant_cmd)
app.command("controller")(controller_cmd)


def hil(scenario: Path, out: Path, lockstep: bool = False, progress: bool = True, plant: str = "python",
        params: Optional[str] = None, sets: Optional[dict] = None, panel: bool = False, panel_port: int = 8050,
        ready=print):
    """Run a closed-loop scenario as HIL: plant and controller processes; returns ``HilResult``."""
    from hydrohil.hil.run import run_hil
    bar = None
    cb = None
    if progress and sys.stderr.isatty():
        from rich.progress import Progress
        bar = Progress(transient=True)
        bar.start()
        task = bar.add_task(f"HIL {scenario.name}" + (" (lock-step)" if lockstep else " (real time)"), total=1)
        cb = lambda t, n: bar.update(task, completed=t, total=n)  # noqa: E731
    live = None
    if panel:
        from functools import partial

        from hydrohil.panel.server import PanelThread
        live = partial(PanelThread, lockstep=lockstep, port=panel_port)
    try:
        return run_hil(scenario, out, lockstep=lockstep, progress=cb, plant=plant, params=params, sets=sets,
                       live=live, ready=ready)
    finally:
        if bar:
            bar.stop()


@app.command("hil")
def hil_cmd(scenario: Path = typer.Argument(..., help="closed-loop scenario TOML (optional [hil] table), or a "
                                            "circuit scenario (open or closed loop)"),
            out: Path = typer.Option(Path("hydrohil-hil"), "--out", callback=out_folder, help="output folder"),
            lockstep: bool = typer.Option(False, help="deterministic lock-step exchange, as fast as possible"),
            plant: str = typer.Option("python", "--plant", help="python: `hydrohil plant`; c: the standalone C "
                                      "plant of `hydrohil export c`, built on first use (cached)"),
            params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML path) in place of "
                                              "the scenario's"),
            sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable), on top of "
                                           "the scenario's [overrides], e.g. --set load.mass=120"),
            panel: bool = typer.Option(False, "--panel", help="serve the live panel while it runs (URL printed)"),
            panel_port: int = typer.Option(8050, "--panel-port", help="HTTP port of the panel (0: any free)")):
    """Real-time HIL run: plant and controller as separate processes over UDP, then the report. A scenario
    naming its circuit runs that circuit (its signals and inputs over the link, README: Circuits).

    Ends with the verdict: VALID, or INVALID with the reasons (exit 3; [hil] max_late_commands,
    max_overruns, max_stall, max_watchdog_trips). Exit 4 when a process got no answer, 130 on Ctrl-C.
    """
    from hydrohil.errors import RunInvalid
    from hydrohil.hil.verdict import BUSY_ADVICE, summary_line
    interruptible()
    try:
        r = hil(scenario, out, lockstep, plant=plant, params=params, sets=_parse_sets(sets), panel=panel,
                panel_port=panel_port)
        t, c = r.timing, r.comparison
        vs = c["text"] if "text" in c else f"HIL vs offline xp RMS {c['xp_rms_mm']:.4f} mm"    # (a circuit: its own)
        typer.echo(f"{t['steps']} steps ({t['mode']}): jitter p99 {_us(t['jitter_us_p99'])}, overruns "
                   f"{_n(t['overruns'])}, rtt p99 {_us(t['rtt_us_p99'])}, late commands {t['late_commands']}, "
                   f"watchdog trips {t['watchdog_trips']}; {vs}; "
                   f"wrote {out}/plant_log.csv, controller_log.csv, timing.json, report.png")
        typer.echo(summary_line(t))
        if not r.verdict["valid"]:
            raise RunInvalid(f"the run is INVALID ({'; '.join(r.verdict['reasons'])}); {BUSY_ADVICE}",
                             r.verdict["reasons"])
    except HydrohilError as exc:
        fail(exc)


def panel(scenario: Optional[Path] = None, out: Path = Path("hydrohil-panel"), controller: str = "builtin",
          port: int = 8050, open_browser: bool = False, lockstep: bool = False, allow_remote: bool = False,
          host: str = "0.0.0.0", params: Optional[str] = None, sets: Optional[dict] = None, ready=print,
          plant: str = "python") -> int:
    """Serve the live panel and run a session of the scenario (default: the paper's Fig 11 experiment) until
    SIGINT/SIGTERM; prints ``PANEL <url>`` once the page is served and ``SESSION <folder> plant <address>``
    once the plant is up (handshakes for scripts), and at the end how it ended and where the sessions and
    recordings are. ``plant``: "python" or "c" (the standalone C plant). Returns the exit code: 130 stopped by
    SIGINT (Ctrl-C), 143 by SIGTERM."""
    import asyncio
    import signal
    from hydrohil.panel.server import Panel
    from hydrohil.simulation.scenario import EXPERIMENTS_DIR
    if scenario is None:
        scenario = EXPERIMENTS_DIR / "fig11_p_control.toml"
    pn = Panel(scenario, out, controller=controller, lockstep=lockstep, params=params, sets=sets, host=host,
               port=port, allow_remote=allow_remote, plant=plant)

    stopped_by = []

    async def main():
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, lambda sig=sig: (stopped_by.append(sig), stop.set()))
        url = await pn.open()
        ready(f"PANEL {url}", flush=True)
        if allow_remote:
            ready("the token above is required on every request; it is shown once", flush=True)
        if open_browser:
            import webbrowser
            webbrowser.open(url)
        try:
            await pn.start_session()
            await stop.wait()
        finally:
            await pn.close()
    asyncio.run(main())
    sig = stopped_by[0] if stopped_by else signal.SIGINT
    how = "SIGINT (Ctrl-C)" if sig == signal.SIGINT else "SIGTERM"
    sessions = pn.sessions                         # this panel's, not older ones in the same folder
    recordings = [r for s in sessions for r in sorted((s / "recordings").glob("rec-*"))]
    v = (pn.ended or {}).get("verdict")
    timing = (f", the last one's timing {v['verdict']}" + (f" ({'; '.join(v['reasons'])})" if v.get("reasons") else "")
              if isinstance(v, dict) else "")
    ready(f"panel stopped by {how}: {len(sessions)} session(s) in {out}{timing}", flush=True)
    ready(f"recordings: {len(recordings)}" + "".join(f"\n  {r}" for r in recordings), flush=True)
    return 128 + int(sig)


@app.command("panel")
def panel_cmd(scenario: Optional[Path] = typer.Argument(None, help="closed-loop scenario TOML (default: the paper's "
                                                       "Fig 11 experiment), or a scenario naming its circuit"),
              out: Path = typer.Option(Path("hydrohil-panel"), "--out", callback=out_folder, help="folder of the sessions and recordings"),
              controller: str = typer.Option("builtin", "--controller", help="builtin: the scenario's controller "
                                             "process; external: wait for yours on 127.0.0.1:47000"),
              port: int = typer.Option(8050, "--port", help="HTTP port of the page (0: any free port)"),
              open_browser: bool = typer.Option(False, "--open", help="open the page in the default browser"),
              lockstep: bool = typer.Option(False, help="lock-step plant (deterministic, as fast as possible)"),
              allow_remote: bool = typer.Option(False, help="serve on --host for other machines: every request "
                                                "then needs the token printed at the start"),
              host: str = typer.Option("0.0.0.0", help="address to serve on with --allow-remote"),
              params: Optional[str] = typer.Option(None, "--params", help="parameter set (name or TOML path)"),
              sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable)"),
              plant: str = typer.Option("python", "--plant", help="python: `hydrohil plant`; c: the standalone C "
                                        "plant of `hydrohil export c`, built on first use (cached)")):
    """Live instrument panel: the real-time plant (and controller) with a web page on loopback.

    Watch position, pressures, spool, friction, modes and timing live; change the load, supply pressure,
    friction and gains; switch faults on and off; record run folders. Ctrl-C stops the session cleanly.
    A circuit scenario: its signals by unit and its modes; hold any input the controller does not drive, the
    loop's gains and reference; change any parameter (--set keys) on the Python plant.
    """
    from hydrohil.hil.plant import parse_address
    try:
        if allow_remote:
            parse_address(f"{host}:{port}", allow_remote=True)
        code = panel(scenario, out, controller, port, open_browser, lockstep, allow_remote, host, params,
                     _parse_sets(sets), plant=plant)
    except HydrohilError as exc:
        fail(exc)
    raise typer.Exit(code)


def run_sequences(sequences: list[Path], out: Path = Path("hydrohil-test"), mode: Optional[str] = None,
                  controller: Optional[str] = None, junit: Optional[Path] = None, echo=print) -> int:
    """Run test sequences (:mod:`hydrohil.sequences`): ``out/report.md``, each run in ``out/<name>/``, JUnit
    XML with ``junit``. ``mode``: offline, lockstep or realtime (default: offline, lockstep with an external
    ``controller`` program). Returns the exit code: 0 all passed, 1 an expectation failed, 3 a run could not
    be judged (diverged, a process failed, a real-time run INVALID)."""
    from hydrohil.sequences.runner import exit_code, run_suite
    mode = mode or ("lockstep" if controller else "offline")
    results = run_suite(sequences, out, mode=mode, controller=controller, junit=junit, echo=echo)
    echo(f"report: {out / 'report.md'}" + (f", JUnit: {junit}" if junit else ""))
    return exit_code(results)


@app.command("test")
def test_cmd(sequences: list[Path] = typer.Argument(..., help="test sequence TOMLs (examples/sequences/)"),
             out: Path = typer.Option(Path("hydrohil-test"), "--out", callback=out_folder, help="report folder (report.md, one folder per "
                                      "sequence)"),
             mode: Optional[str] = typer.Option(None, "--mode", help="offline | lockstep | realtime (default: offline; "
                                                "lockstep with --controller)"),
             controller: Optional[str] = typer.Option(None, "--controller", help="an external controller program that "
                                                      "speaks the protocol, e.g. \"./my_ctrl {host} {port}\" ({host} "
                                                      "{port} {scenario} {duration} {out} are filled in)"),
             junit: Optional[Path] = typer.Option(None, "--junit", help="write JUnit XML here (for CI systems)")):
    """Run HIL test sequences: a timeline of actions and faults, expectations with verdicts.

    Exit code 0 when every expectation passed, 1 when one failed, 3 when a run could not be judged
    (diverged, a process failed, a real-time run INVALID), 2 for bad input.
    """
    try:
        code = run_sequences(sequences, out, mode, controller, junit, echo=typer.echo)
    except HydrohilError as exc:
        fail(exc)
    raise typer.Exit(code)


def sweep(study: Path, out: Path = Path("hydrohil-sweep"), scheduler: Optional[str] = None,
          workers: Optional[int] = None, progress: bool = True, rerun_id: Optional[str] = None, echo=print):
    """Run a study (:mod:`hydrohil.studies`) on Dask into ``out`` (``results.parquet``, ``summary.json``,
    ``report.md``, figures), resuming an earlier run there; with ``rerun_id``: write that run's scenario file
    ``out/rerun/ID.toml`` instead. Returns the :class:`~hydrohil.studies.engine.StudyResult` (or the path)."""
    from hydrohil.studies.engine import rerun, run_study
    if rerun_id:
        dest = rerun(study, rerun_id, out / "rerun" / f"{rerun_id}.toml")
        echo(f"wrote {dest}")
        return dest
    r = run_study(study, out, scheduler=scheduler, workers=workers, progress=progress)
    s = r.summary
    lo, hi = s["p_fail_95ci"]
    echo(f"{r.runs} runs ({r.ran} run now, {r.skipped} already done) in {r.wall_s:.1f} s on {r.workers} worker(s); "
         f"failed {s['failed']} ({100 * (s['p_fail'] or 0):.2f} %, 95 % interval {100 * lo:.2f}-{100 * hi:.2f} %); "
         f"status {s['status']}")
    echo(f"results: {r.table}, report: {out / 'report.md'}")
    return r


@app.command("sweep")
def sweep_cmd(study: Path = typer.Argument(..., help="study TOML (examples/studies/)"),
              out: Path = typer.Option(Path("hydrohil-sweep"), "--out", callback=out_folder, help="results folder (a rerun resumes)"),
              scheduler: Optional[str] = typer.Option(None, "--scheduler", help="address of a Dask scheduler, e.g. "
                                                      "tcp://10.0.0.5:8786 (default: a local cluster)"),
              workers: Optional[int] = typer.Option(None, "--workers", min=1, help="local cluster: worker processes "
                                                    "(default: every core)"),
              progress: bool = typer.Option(True, help="progress bar"),
              rerun_id: Optional[str] = typer.Option(None, "--rerun", help="write this run's scenario file "
                                                     "(OUT/rerun/ID.toml) instead of running the study")):
    """Sweeps and Monte Carlo studies on Dask: Parquet results, resume, figures and the worst runs."""
    try:
        sweep(study, out, scheduler, workers, progress, rerun_id, echo=typer.echo)
    except HydrohilError as exc:
        fail(exc)


def _us(v) -> str:
    return "n/a" if v is None else f"{v:.1f} us"


def _n(v) -> str:
    return "n/a" if v is None else str(v)


def demo(out: Path = Path("hydrohil-demo"), lockstep: bool = False, progress: bool = True) -> dict:
    """The main job: Fig 11 and Fig 12 as real-time HIL runs plus the report folder ``out``."""
    from hydrohil.hil.demo import run_demo
    bar = task = None
    if progress and sys.stderr.isatty():
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
        bar = Progress(TextColumn("{task.description}"), BarColumn(),
                       TextColumn("{task.completed:.1f}/{task.total:.0f} s"), TimeElapsedColumn())
        bar.start()

    def on_exp(name, title):
        nonlocal task
        if bar:
            task = bar.add_task(f"{name} (HIL)", total=1)
        else:
            typer.echo(f"running {title} ...", err=True)
    try:
        return run_demo(out, lockstep=lockstep, on_experiment=on_exp,
                        progress=(lambda t, n: bar.update(task, completed=t, total=n)) if bar else None)
    finally:
        if bar:
            bar.stop()


@app.command("demo")
def demo_cmd(out: Path = typer.Option(Path("hydrohil-demo"), "--out", callback=out_folder, help="report folder"),
             lockstep: bool = typer.Option(False, help="lock-step instead of real time")):
    """The paper's Fig 11 and Fig 12 experiments as real-time HIL runs, with report and timing.

    Each run gets a verdict (VALID / INVALID); exit 3 when one is INVALID (the report says why and what to do).
    """
    from hydrohil.errors import RunInvalid
    from hydrohil.hil.verdict import BUSY_ADVICE, summary_line
    interruptible()
    try:
        res = demo(out, lockstep)
        for name, r in res.items():
            t, c = r["timing"], r["comparison"]
            typer.echo(f"{name}: {t['steps']} steps, jitter p99 {_us(t['jitter_us_p99'])}, overruns "
                       f"{_n(t['overruns'])}, rtt p99 {_us(t['rtt_us_p99'])}, HIL vs offline xp RMS "
                       f"{c['xp_rms_mm']:.4f} mm, tracking RMS {c['hil_tracking_rms_mm']:.2f} mm: {summary_line(t)}")
        typer.echo(f"report: {out}/report.md (figures {out}/fig11/report.png, {out}/fig12/report.png)")
        bad = [n for n, r in res.items() if not r["timing"]["verdict"]["valid"]]
        if bad:
            raise RunInvalid(f"{', '.join(bad)} INVALID: {BUSY_ADVICE}", bad)
    except HydrohilError as exc:
        fail(exc)


class _Stages:
    """Progress over named stages: a rich bar on a terminal, one line per stage otherwise."""

    def __init__(self, title: str, enabled: bool = True):
        self.title, self.bar, self.task, self.t0 = title, None, None, None
        if enabled and sys.stderr.isatty():
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
            self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                                TimeElapsedColumn())
        self.enabled = enabled

    def __enter__(self):
        if self.bar:
            self.bar.start()
        return self

    def __call__(self, name: str, i: int, n: int) -> None:
        if self.bar:
            if self.task is None:
                self.task = self.bar.add_task(self.title, total=n)
            self.bar.update(self.task, completed=i, description=f"{self.title}: {name}")
        elif self.enabled:
            typer.echo(f"[{i + 1}/{n}] {name} ...", err=True)

    def __exit__(self, *exc):
        if self.bar:
            self.bar.stop()


def reproduce(out: Path = Path("hydrohil-reproduce"), quick: bool = False, lockstep: Optional[bool] = None,
              progress: bool = True, params: Optional[str] = None, sets: Optional[dict] = None) -> dict:
    """Every figure and number of the paper a model can produce; writes ``out/report.md`` and the rest.
    ``params`` / ``sets``: reproduce another rig (default: the paper's set)."""
    from hydrohil.reproduce import run_reproduce
    with _Stages("reproduce", progress) as stages:
        return run_reproduce(out, quick=quick, lockstep=lockstep, on_step=stages, params=params, sets=sets)


@app.command("reproduce")
def reproduce_cmd(out: Path = typer.Option(Path("hydrohil-reproduce"), "--out", callback=out_folder, help="report folder"),
                  quick: bool = typer.Option(False, help="lock-step HIL and a coarse step-size search (minutes "
                                                         "-> about 30 s)"),
                  lockstep: Optional[bool] = typer.Option(None, "--lockstep/--realtime",
                                                          help="HIL mode for Figs 11-12 (default: real time)"),
                  params: Optional[str] = typer.Option(None, "--params", help="the rig to reproduce: a parameter "
                                                       "set (name or TOML path; default: the paper's)"),
                  sets: list[str] = typer.Option([], "--set", help="parameter value key=value (repeatable)")):
    """Reproduce the paper: Figs 4, 5, 7-12, step sizes, paper-vs-hydrohil table, identification round trips."""
    try:
        res = reproduce(out, quick, lockstep, params=params, sets=_parse_sets(sets))
    except HydrohilError as exc:
        fail(exc)
    st = res["step-size"]
    typer.echo(f"hybrid step {st['hybrid_s']:.3g} s vs stiff model {st['continuous_s']:.3g} s; "
               f"{sum(len(v) for v in res['figures'].values())} figures; {res['wall_time_s']['total']:.0f} s; "
               f"report: {out}/report.md")


def bench(json_path: Optional[Path] = None, markdown_path: Optional[Path] = None, seconds: float = 60.0,
          quick: bool = False, progress: bool = True, floor: Optional[Path] = None) -> dict:
    """Run the benchmark suite; optionally write the JSON and the README table (markdown). ``floor``: the floor
    program's C file (hydrohil.bench.floor_program)."""
    from hydrohil.bench import floor_program, markdown, run_bench
    from hydrohil.simulation.outputs import write_json
    try:
        floor_program(floor)                     # (before the long run: an explicit one must be a file)
    except FileNotFoundError:
        raise InputError("no such file (the floor program: a plain-C RK3 loop that prints its ns per step)",
                         source=str(floor), key="--floor") from None
    with _Stages("bench", progress) as stages:
        res = run_bench(seconds=seconds, quick=quick, on_section=stages, floor=floor)
    if json_path:
        write_json(json_path, res)
    if markdown_path:
        markdown_path.write_text(markdown(res))
    return res


@app.command("bench")
def bench_cmd(json_path: Optional[Path] = typer.Option(None, "--json", help="write all results as JSON"),
              markdown_path: Optional[Path] = typer.Option(None, "--markdown", help="write the README table"),
              seconds: float = typer.Option(60.0, help="length of the 0.5 ms real-time run [s]"),
              quick: bool = typer.Option(False, help="short runs: a smoke test, not figures to report"),
              floor: Optional[Path] = typer.Option(None, "--floor", help="the floor program's C file (default: "
                                                   "$HYDROHIL_RK3_FLOOR, else shared/bench/rk3_floor.c beside "
                                                   "the repository)")):
    """Benchmark suite: step cost, solvers, step sizes, real-time jitter/overruns/RTT, lock-step, identification."""
    from hydrohil.bench import markdown
    try:
        res = bench(json_path, markdown_path, seconds, quick, floor=floor)
    except HydrohilError as exc:
        fail(exc)
    typer.echo(markdown(res))



def main():
    show_warnings_as_lines()
    app()


if __name__ == "__main__":
    main()
