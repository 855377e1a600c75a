"""``hydrohil circuit draw``: the circuit as a labelled diagram (Graphviz): hydraulic nodes as dots, each
component as a shape in the spirit of its ISO 1219 symbol (a valve's three envelopes, a pump's circle, an
accumulator's capsule, a tank's open box) with its key figures in catalogue units, its ports' lines to the
nodes, the signals that drive it as dashed arrows, a rod or shaft coupled to its load as a double line."""

from __future__ import annotations

import shutil
from pathlib import Path

from hydrohil.circuits.circuit import Circuit
from hydrohil.errors import InputError

# component type -> (graphviz shape, a glyph for the symbol, extra attributes)
STYLE = {
    "tank": ("invhouse", "tank", {}),
    "pressure_source": ("circle", "P", {"style": "filled", "fillcolor": "#fde2e2"}),
    "pump": ("circle", "▲ pump", {"style": "filled", "fillcolor": "#e2f0fd"}),
    "relief_valve": ("diamond", "relief", {"style": "filled", "fillcolor": "#fff3d6"}),
    "check_valve": ("diamond", "check ▶", {"style": "filled", "fillcolor": "#fff3d6"}),
    "counterbalance_valve": ("diamond", "counterbalance", {"style": "filled", "fillcolor": "#fff3d6"}),
    "orifice": ("rarrow", "orifice", {}),
    "accumulator": ("ellipse", "accumulator", {"style": "filled", "fillcolor": "#e9e2fd"}),
    "hose": ("box", "hose", {"style": "rounded,dashed"}),
    "volume": ("cylinder", "volume", {}),
    "motor": ("circle", "▽ motor", {"style": "filled", "fillcolor": "#e2fde8"}),
    "cylinder": ("box3d", "cylinder", {"style": "filled", "fillcolor": "#e2fde8"}),
    "double_rod_cylinder": ("box3d", "double-rod cylinder", {"style": "filled", "fillcolor": "#e2fde8"}),
    "lugre_cylinder": ("box3d", "cylinder, LuGre seals", {"style": "filled", "fillcolor": "#e2fde8"}),
    "lugre_motor": ("circle", "▽ motor, LuGre", {"style": "filled", "fillcolor": "#e2fde8"}),
    "load": ("box", "load", {"style": "filled,bold", "fillcolor": "#eeeeee"}),
    "rotary_load": ("circle", "rotary load", {"style": "filled,bold", "fillcolor": "#eeeeee"}),
}
VALVES = {"valve_43": ("⇉", "⊥ ⊤", "⇆"), "valve_63": ("⇉", "⇢ P→T", "⇆"), "servo_valve": ("⇉", "⊥ ⊤", "⇆")}
INTO = {"inlet", "a", "P", "p", "pilot", "valve"}        # ports the flow usually enters a component by


def _figures(comp) -> list[str]:
    """A component's key figures in catalogue units."""
    v, t = comp.values, comp.type.name
    out = []
    if t in ("tank", "pressure_source") and v.get("pressure") is not None and v["pressure"] == v["pressure"]:
        out.append(f"{v['pressure'] / 1e5:g} bar")
    if t == "pump":
        out.append(f"{v['displacement'] * 1e6:g} cm³/rev")
        if v["speed"] == v["speed"]:
            out.append(f"{v['speed'] * 60:g} rpm")
    if t in ("relief_valve", "check_valve"):
        out.append(f"{v['cracking_pressure'] / 1e5:g} bar, {v['rated_flow'] * 6e4:g} l/min at {v['rated_pressure'] / 1e5:g} bar")
    if t == "counterbalance_valve":
        out.append(f"set {v['set_pressure'] / 1e5:.4g} bar, pilot {v['pilot_ratio']:g}:1, "
                   f"{v['rated_flow'] * 6e4:g} l/min at {v['rated_drop'] / 1e5:g} bar")
    if t == "orifice":
        out.append(f"{v['area'] * 1e6:g} mm²")
    if t == "accumulator":
        out.append(f"{v['gas_volume'] * 1e3:g} l at {v['precharge'] / 1e5:g} bar")
    if t == "hose":
        out.append(f"{v['diameter'] * 1e3:g} mm × {v['length']:g} m")
    if t == "volume":
        out.append(f"{v['volume'] * 1e3:g} l")
    if t in ("motor", "lugre_motor"):
        out.append(f"{v['displacement'] * 1e6:g} cm³/rev")
    if t == "rotary_load":
        out.append(f"{v['inertia']:g} kg·m²")
    if t in ("cylinder", "double_rod_cylinder"):
        load = "" if comp.coupled else f", {v['mass']:g} kg"
        out.append(f"{v['bore'] * 1e3:g}/{v['rod'] * 1e3:g} × {v['stroke'] * 1e3:g} mm{load}")
    if t == "load":
        out.append(f"{v['mass']:g} kg" + (f", {v['incline']:g}°" if v["incline"] else "")
                   + (f", spring {v['spring'] / 1e3:g} N/mm" if v["spring"] else ""))
    if t == "lugre_cylinder":
        out.append(f"A1 {v['area_a'] * 1e4:.4g} cm², A2 {v['area_b'] * 1e4:.4g} cm², {v['stroke'] * 1e3:g} mm, "
                   f"{v['mass']:g} kg")
    if t == "servo_valve":
        out.append(f"servo, ωn {v['wn']:.4g} rad/s")
    elif t in VALVES:
        out.append(f"x_max {v['x_max'] * 1e3:g} mm")
    return out


def draw_circuit(c: Circuit, out: str | Path, faults: list | None = None) -> Path:
    """Write the diagram of ``c`` to ``out`` (.png or .svg); returns the path. ``faults``: its scenario's
    [[faults]] (hydrohil.circuits.faults), drawn in red: a leak's orifice, a parameter a fault drives."""
    out = Path(out)
    fmt = out.suffix.lstrip(".").lower()
    if fmt not in ("png", "svg"):
        raise InputError(f"the drawing is a .png or a .svg, got {out.name!r}", key="out")
    if shutil.which("dot") is None:
        raise InputError("circuit draw needs Graphviz's dot program (Debian: apt-get install graphviz)")
    import graphviz
    g = graphviz.Digraph(c.name, engine="dot", format=fmt,
                       graph_attr={"rankdir": "TB", "label": f"{c.name}", "labelloc": "t", "fontname": "Helvetica",
                                   "fontsize": "16", "splines": "true", "nodesep": "0.4", "ranksep": "0.7"},
                       node_attr={"fontname": "Helvetica", "fontsize": "11"},
                       edge_attr={"fontname": "Helvetica", "fontsize": "9", "color": "#3060a0", "penwidth": "1.6",
                                  "arrowhead": "none"})
    from hydrohil.circuits.units import to_si
    fault_parts, fault_signals = {}, {}
    for f in faults or []:                          # (checked by the scenario's loader: numbers or "<n> s")
        window = f"from {to_si(f.get('start', 0), 's'):g} s" + \
            (f" to {to_si(f['end'], 's'):g} s" if "end" in f else "")
        if f.get("type") == "leak":
            name = f.get("orifice", f"leak_{f.get('node')}")
            fault_parts[name] = f"fault: a leak, {window}"
            fault_signals[f"{name}.opening"] = f"fault: {name} opens, {window}"
        elif f.get("type") == "parameter":               # (a sensor's faults act on the loop: not drawn)
            fault_signals[f.get("target")] = f"fault: {f.get('target')} = {f.get('value')}, {window}"
    for node in c.nodes:
        fixed = f" (fixed by {c.fixed[node][0]})" if node in c.fixed else ""
        g.node(f"n__{node}", label="", xlabel=node + fixed, shape="point", width="0.14", color="#3060a0")
    for comp in c.components.values():
        t = comp.type.name
        figures = "\\n".join(_figures(comp))
        if t in VALVES:                                     # the ISO symbol's three envelopes, side by side
            a, centre, b = VALVES[t]
            g.node(f"c__{comp.name}", shape="record", style="filled", fillcolor="#fff3d6",
                   label=f"{{{comp.name} ({t.replace('_', ' ')})|{{ {a} | {centre} | {b} }}|{figures}}}")
        else:
            shape, glyph, extra = STYLE.get(t, ("box", t, {}))
            name = comp.name if glyph in (comp.name, t) and comp.name == glyph else f"{comp.name}\\n{glyph}"
            if comp.name in fault_parts:                    # a fault's part: red, dashed, its window said
                shape, extra = "box", {"color": "#c02020", "fontcolor": "#c02020", "style": "dashed,bold"}
                figures = f"{figures}\\n{fault_parts[comp.name]}"
            g.node(f"c__{comp.name}", label=name + (f"\\n{figures}" if figures else ""), shape=shape, **extra)
        for port, node in comp.ports.items():     # drawn along the flow: supply at the top, tank at the bottom
            into = port in INTO and t != "pressure_source"
            g.edge(*((f"n__{node}", f"c__{comp.name}") if into else (f"c__{comp.name}", f"n__{node}")), label=port)
    for comp in c.components.values():            # mechanical couplings: a rod driving its load (double line)
        if comp.coupled:
            g.edge(f"c__{comp.name}", f"c__{comp.coupled}", label=comp.type.coupling.part, color="#555555:#555555",
                   penwidth="1.2")
    for sig in c.inputs:
        comp = sig.split(".", 1)[0]
        if sig not in fault_signals and sig.split(".", 1)[1] not in c.components[comp].type.params:
            continue                                        # (a derived value following a fault's parameter)
        label = fault_signals.get(sig, sig)
        colour = "#c02020" if sig in fault_signals else "#a03030"
        g.node(f"s__{sig}", label=label, shape="plaintext", fontcolor=colour)
        g.edge(f"s__{sig}", f"c__{comp}", style="dashed", color=colour, arrowhead="normal", penwidth="1.0")
    out.parent.mkdir(parents=True, exist_ok=True)
    g.render(outfile=str(out), cleanup=True)
    return out
