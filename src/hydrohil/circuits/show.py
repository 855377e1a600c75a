"""What ``hydrohil circuit show`` prints: a circuit's components with their parameters (SI, as the file wrote
them, derived values), its nodes (fixed or a pressure state, volume, initial pressure, stiffness at the step
and the method's treatment), states, modes, inputs and signals with units; and ``circuit run``'s files."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from hydrohil.circuits.circuit import Circuit
from hydrohil.circuits.build import compile_circuit
from hydrohil.circuits.run import CircuitResult, input_unit, node_stiffness, simulate_circuit, state_bounds


def _bound(v: float) -> float | None:
    """A physical range's side for --json: None where it is open."""
    return float(v) if math.isfinite(v) else None


def _range_text(r: list | None) -> str:
    """A state's physical range as text (" in [lo, hi]"; an open side: -inf or inf; none: "")."""
    if r is None:
        return ""
    lo, hi = r
    return f" in [{'-inf' if lo is None else f'{lo:.4g}'}, {'inf' if hi is None else f'{hi:.4g}'}]"


def default_duration(c: Circuit) -> float:
    """Long enough to see the default drive: its last change + 2 s (at least 2 s)."""
    last = max((float(d[0][-1]) for d in c.inputs.values() if isinstance(d, tuple)), default=0.0)
    return max(2.0, last + 2.0)


def describe(c: Circuit, *, h: float = 5e-4, method: str = "rk3", scenario=None) -> dict:
    """The circuit as data (``circuit show --json``); the nodes' stiffness from a run of its default drive, or of
    ``scenario`` (a :class:`hydrohil.circuits.scenario.CircuitScenario` of ``c``: its drives, duration and loop,
    a held piston starting held)."""
    if scenario is not None:
        res = simulate_circuit(c, scenario.duration, h=h, method=method, every=20, rest=scenario.rest,
                               loop=scenario.loop, commands=scenario.commands)
    else:                 # (a run for the nodes' stiffness: a piston its default drive leaves unheld is no news here)
        res = simulate_circuit(c, default_duration(c), h=h, method=method, every=20, warn_unheld=False)
    stiff = {s.node: s for s in node_stiffness(c, res)}
    cc = compile_circuit(c)
    lay = cc.layout
    lo, hi = state_bounds(cc, lay.values())
    comps = []
    for comp in c.components.values():
        prm = [{"key": k, "value": _num(comp.values[k]), "unit": p.unit, "description": p.text(comp.name),
                "given": comp.given.get(k), "signal": f"{comp.name}.{k}" in c.inputs}
               for k, p in comp.type.params.items() if comp.values.get(k) is not None
               and k not in comp.load_keys]                           # (a coupled actuator's: its load's)
        couplings = {comp.type.coupling.key: comp.coupled} if comp.coupled else \
            {"driven_by": comp.actuators} if comp.actuators else {}
        tables = {name: {"x": xs.tolist(), "f": fs.tolist(), "x_unit": comp.type.tables[name][0],
                         "f_unit": comp.type.tables[name][1]} for name, (xs, fs) in comp.tables.items()}
        comps.append({"name": comp.name, "type": comp.type.name, "description": comp.type.description,
                      "ports": comp.ports, "couplings": couplings, "parameters": prm, "tables": tables,
                      "derived": [{"key": k, "value": comp.values[k], "unit": u} for k, u in comp.type.derived
                                  if not (comp.coupled and k == "weight")],         # (its load's)
                      "modes": list(comp.modes)})
    nodes = []
    for node in c.nodes:
        d = {"name": node, "volume_m3": c.node_volume(node)}
        if node in c.fixed:
            comp, key = c.fixed[node]
            d.update(fixed_by=comp, pressure_pa=c.components[comp].values[key])
        else:
            s = stiff[node]
            d.update(initial_pa=float(res.column(f"{node}.p")[0]), stiffness_per_s=s.lam, lambda_h=s.lam_h,
                     stability_limit=s.limit, treatment=s.treatment(method, h))
        nodes.append(d)
    signals = [{"name": n, "unit": res.units[n]} for n in res.columns]
    return {"name": c.name, "source": c.source, "step_s": h, "method": method,
            "stiffness_run": "the default drive" if scenario is None else f"the scenario {scenario.source}",
            "fluid": [{"key": k, "value": v} for k, v in c.fluid.items()], "components": comps, "nodes": nodes,
            "states": [{"name": s, "unit": u, "range": [_bound(a), _bound(b)]
                        if math.isfinite(a) or math.isfinite(b) else None}          # (None: an open side)
                       for s, u, a, b in zip(lay.states, lay.state_units, lo, hi)],
            "modes": [{"name": m, "values": list(lay.mode_names[m])} for m in lay.modes],
            "guards": list(lay.guards), "delayed_inputs": list(lay.delayed),
            "inputs": [{"name": n, "unit": input_unit(c, n), "drive": _drive_text(d)} for n, d in c.inputs.items()],
            "signals": signals, "link": _link(c)}


def _link(c: Circuit) -> dict:
    """The circuit over the HIL link (docs/protocol.md): SIGNALS' values and INPUTS' values in order, layout."""
    from hydrohil.circuits.link import circuit_link
    signals, inputs, layout = circuit_link(c)
    return {"layout": layout, "signals": [{"name": n, "unit": u} for n, u in signals],
            "inputs": [{"name": n, "unit": u} for n, u in inputs]}


def _num(v):
    return None if v is None or (isinstance(v, float) and math.isnan(v)) else v



def _drive_text(d) -> str:
    if isinstance(d, tuple):
        if getattr(d, "linear", False):
            return "linear through " + ", ".join(f"{v:g} at {t:g} s" for t, v in zip(*d))
        return ", ".join(f"{v:g} from {t:g} s" for t, v in zip(*d))
    return f"{d:g}"


def text(d: dict) -> str:
    """The data of :func:`describe` for a person."""
    out = [f"circuit {d['name']}  ({d['source']})", "fluid: " + ", ".join(f"{f['key']} {f['value']:g}" for f in d["fluid"])
           + "  [kg/m3, Pa, m2/s]", "", "components:"]
    for comp in d["components"]:
        ports = ", ".join([f"{p} = {n}" for p, n in comp["ports"].items()] +
                          [f"{k} = {v if isinstance(v, str) else ', '.join(v)}" for k, v in comp["couplings"].items()])
        out.append(f"  {comp['name']}  ({comp['type']}: {comp['description']})  ports: {ports}")
        for p in comp["parameters"]:
            given = f"  (file: {p['given']})" if p["given"] and p["given"] != repr(p["value"]) else ""
            sig = "  signal" if p["signal"] else ""
            value = "driven" if p["signal"] else "—" if p["value"] is None else f"{p['value']:g}"
            out.append(f"    {p['key']:<24} {value:>12} {p['unit']:<10} {p['description']}{given}{sig}")
        for x in comp["derived"]:
            out.append(f"    {x['key']:<24} {x['value']:>12.6g} {x['unit']:<10} derived")
        for name, tb in comp["tables"].items():
            points = ", ".join(f"({x:g} {tb['x_unit']}, {f:g} {tb['f_unit']})" for x, f in zip(tb["x"], tb["f"]))
            out.append(f"    {name:<24} table: {points}")
    out += ["", f"nodes (stiffness over a run of {d['stiffness_run']}, {d['method']} at {d['step_s'] * 1e3:g} ms):"]
    for n in d["nodes"]:
        if "fixed_by" in n:
            out.append(f"  {n['name']:<14} fixed at {n['pressure_pa'] / 1e5:g} bar by {n['fixed_by']}")
        else:
            out.append(f"  {n['name']:<14} pressure state, volume {n['volume_m3'] * 1e3:.4g} l, initially "
                       f"{n['initial_pa'] / 1e5:g} bar; stiffness {n['stiffness_per_s']:.4g} 1/s: {n['treatment']}")
    out += ["", "states (a fixed-step run stops outside a physical range): " + ", ".join(
                f"{s['name']} [{s['unit']}]{_range_text(s['range'])}" for s in d["states"]),
            "modes: " + (", ".join(f"{m['name']} ({'|'.join(m['values'])})" for m in d["modes"]) or "none"),
            "events located inside the step (guards): " + (", ".join(d["guards"]) or "none"),
            "inputs seen late (delay lines): " + (", ".join(d["delayed_inputs"]) or "none"),
            "inputs: " + (", ".join(f"{i['name']} [{i['unit']}] = {i['drive']}" for i in d["inputs"]) or "none"),
            "signals: " + ", ".join(f"{s['name']} [{s['unit']}]" for s in d["signals"]),
            f"HIL link (docs/protocol.md): layout {d['link']['layout']}, SIGNALS carry "
            f"{len(d['link']['signals'])} values (the signals above from {d['link']['signals'][0]['name']} to "
            f"{d['link']['signals'][-1]['name']}), INPUTS {len(d['link']['inputs'])} "
            f"({', '.join(i['name'] for i in d['link']['inputs']) or 'none'})"]
    return "\n".join(out) + "\n"


def write_run(res: CircuitResult, out: Path, title: str) -> list[Path]:
    """``log.csv`` (a column per signal, SI; modes by name) and ``plot.png`` (pressures in bar, flows in l/min,
    modes) into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    write_log(res, out / "log.csv")
    return [out / "log.csv", plot_run(res, out / "plot.png", title)]


def write_log(res: CircuitResult, path: Path) -> Path:
    """The run as CSV: a column per signal, ``<component>.<variable> [SI unit]``; modes by name."""
    names = list(res.columns)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([f"{n} [{res.units[n]}]" for n in names])
        cols = [res.columns[n] for n in names]
        for i in range(len(cols[0])):
            w.writerow([res.mode_names[n][int(c[i])] if n in res.mode_names else repr(float(c[i]))
                        for n, c in zip(names, cols)])
    return path


def plot_run(res: CircuitResult, path: Path, title: str) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = res.columns["t"]
    pres = [n for n, u in res.units.items() if u == "Pa" and np.ptp(res.columns[n]) > 0]
    # positions of actuators (strokes of more than 5 mm; a valve's spool is not one), their speeds
    pos = [n for n, u in res.units.items() if u == "m" and np.max(np.abs(res.columns[n])) > 5e-3]
    speed = [n for n, u in res.units.items() if u == "rad/s"]
    flows = [n for n, u in res.units.items() if u == "m3/s" and ".q_" not in n]     # (a valve's edges: in log.csv)
    modes = list(res.mode_names)
    panels = [("pressure [bar]", pres, 1e-5)] + ([("position [mm]", pos, 1e3)] if pos else []) + \
        ([("speed [rpm]", speed, 60 / (2 * np.pi))] if speed else []) + [("flow [l/min]", flows, 60e3)]
    ratios = [3] * len(panels) + ([0.5 + 0.5 * len(modes)] if modes else [])
    fig, axes = plt.subplots(len(ratios), 1, figsize=(10, 2.2 * sum(ratios) / 3 + 2.5), sharex=True,
                             gridspec_kw={"height_ratios": ratios})
    for ax, (label, names, scale) in zip(axes, panels):
        for n in names:
            ax.plot(t, res.columns[n] * scale, label=n)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if names:
            ax.legend(loc="best", fontsize=8, ncol=2)
    if modes:                       # a strip per component with modes, a colour per mode value
        ax, colour = axes[-1], 0
        for i, n in enumerate(modes):
            m = res.columns[n].astype(int)
            for j, name in enumerate(res.mode_names[n]):
                if np.any(m == j):
                    ax.fill_between(t, i - 0.4, i + 0.4, where=m == j, step="post", color=f"C{colour % 10}",
                                    alpha=0.6, label=f"{n.rsplit('.', 1)[0]}: {name}")
                colour += 1
        ax.set_yticks(range(len(modes)), [n.rsplit(".", 1)[0] for n in modes])
        ax.set_ylim(-0.6, len(modes) - 0.4)
        ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8)
        ax.set_title("modes", fontsize=9, loc="left")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
