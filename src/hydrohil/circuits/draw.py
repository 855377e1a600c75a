"""``hydrohil circuit draw``: the circuit as a diagram an engineer reads as a circuit: each component by its
graphic symbol in the spirit of ISO 1219-1 (:mod:`hydrohil.circuits.symbols`: a valve's envelopes with its flow
paths, a pump's circle, a pressure valve's square, spring and pilot line, a cylinder with piston and rod, ...)
with its name and its key figures in catalogue units beside it; the hydraulic nodes as dots, each line meeting
the symbol at its own port; the power unit below and the actuators above (flow up the page, ISO practice); a rod
or shaft coupled to its load by a double line; the signals that drive a component as dashed arrows; a scenario's
faults in red. Graphviz lays it out; the symbols are drawn by matplotlib."""

from __future__ import annotations

import base64
import html
import shutil
import tempfile
from pathlib import Path

from hydrohil.circuits.circuit import Circuit
from hydrohil.errors import HydrohilError, InputError

LINE = "#3060a0"         # hydraulic lines
FAULT = "#c02020"
SIGNAL = "#a03030"       # signals: drives, a loop's measurement and command


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
    elif t in ("valve_43", "valve_63"):
        out.append(f"x_max {v['x_max'] * 1e3:g} mm")
    return out


SYMMETRIC = ("orifice", "hose")          # two ports, either way alike: drawn with the tank's side down


def _to_tank(c: Circuit, node: str) -> bool:
    """Whether ``node`` is a tank's (its pressure fixed by a tank)."""
    return node in c.fixed and c.components[c.fixed[node][0]].type.name == "tank"


def _port_row(ports: dict, side: str, width: int) -> str:
    """The row of a symbol's ports on one side: a cell of 4 pt per port where its stub leaves the symbol, named
    ``p_<port>``, the gaps between them empty (widths in points, as the image's)."""
    ports = sorted((f * width, port) for port, (s, f) in ports.items() if s == side)
    cells, x = [], 0
    for centre, port in ports:
        left = max(int(round(centre - 2)), x)
        if left > x:
            cells.append(f'<TD FIXEDSIZE="TRUE" WIDTH="{left - x}" HEIGHT="2"></TD>')
        cells.append(f'<TD PORT="p_{port}" FIXEDSIZE="TRUE" WIDTH="4" HEIGHT="2"></TD>')
        x = left + 4
    if width > x:
        cells.append(f'<TD FIXEDSIZE="TRUE" WIDTH="{width - x}" HEIGHT="2"></TD>')
    return f'<TABLE BORDER="0" CELLBORDER="0" CELLSPACING="0" CELLPADDING="0"><TR>{"".join(cells)}</TR></TABLE>'


def _label(title: str, lines: list[str], sym, image: Path, colour: str, ports: dict, left: bool) -> str:
    """A component's HTML label: its symbol's image between the rows of its ports (``ports``: port -> (side,
    x fraction)), its name and figures beside it: to the right, or (``left``) to the left of a rod or shaft
    coupled to its load, whose line leaves to the right."""
    w, h = int(round(sym.width * 72)), int(round(sym.height * 72))
    text = f'<FONT POINT-SIZE="11" COLOR="{colour}"><B>{html.escape(title)}</B></FONT>' + "".join(
        f'<BR/><FONT POINT-SIZE="9" COLOR="{colour}">{html.escape(t)}</FONT>' for t in lines)
    symbol = (f'<TD><TABLE BORDER="0" CELLBORDER="0" CELLSPACING="0" CELLPADDING="0">'
              f'<TR><TD>{_port_row(ports, "n", w)}</TD></TR>'
              f'<TR><TD PORT="img" FIXEDSIZE="TRUE" WIDTH="{w}" HEIGHT="{h}"><IMG SRC="{html.escape(str(image))}" '
              f'SCALE="TRUE"/></TD>'
              f'</TR><TR><TD>{_port_row(ports, "s", w)}</TD></TR></TABLE></TD>')
    words = f'<TD ALIGN="LEFT" BALIGN="LEFT" VALIGN="MIDDLE" CELLPADDING="4">{text}</TD>'
    return (f'<<TABLE BORDER="0" CELLBORDER="0" CELLSPACING="0" CELLPADDING="0"><TR>'
            f'{words + symbol if left else symbol + words}</TR></TABLE>>')


def _controller(g, loop, components) -> None:
    """A closed loop's controller as a block: its law and gains, the measured signal from its component (dashed,
    into the block), the command to the driven component's actuator (dashed arrow)."""
    cfg = loop.cfg
    gains = ", ".join(f"{k} = {getattr(cfg, k):g}" for k in ("kp", "ki", "kd", "kff", "kpl")
                      if isinstance(getattr(cfg, k, None), (int, float)))
    law = {"p_ff": "P + velocity feed-forward", "state_feedback": "P + load-pressure feedback",
           "python": f"Python {getattr(cfg, 'callable', '')}"}.get(cfg.type, cfg.type.upper())
    label = f"controller: {law}" + (f"\\n{gains}" if gains else "") + f"\\nreference → {loop.measure}"
    g.node("loop__controller", label=label, shape="box", style="rounded,dashed", color=SIGNAL, fontcolor=SIGNAL,
           fontsize="10")
    measured, commanded = loop.measure.split(".", 1)[0], loop.command.split(".", 1)[0]
    source = {"tailport": "img:w"} if measured in components else {}      # (a node's pressure: from its dot)
    g.edge(f"c__{measured}" if measured in components else f"n__{measured}", "loop__controller",
           label=loop.measure, style="dashed", color=SIGNAL, fontcolor=SIGNAL, arrowhead="normal", penwidth="1.0",
           constraint="false", **source)
    with g.subgraph() as same:
        same.attr(rank="same")
        same.node("loop__controller")
        same.node(f"c__{commanded}")
    g.edge("loop__controller", f"c__{commanded}", headport="img:w", label=loop.command, style="dashed", color=SIGNAL,
           fontcolor=SIGNAL, arrowhead="normal", penwidth="1.0")


def draw_circuit(c: Circuit, out: str | Path, faults: list | None = None, loop=None) -> Path:
    """Write the diagram of ``c`` to ``out`` (.png or .svg, self-contained); returns the path. ``faults``: its
    scenario's [[faults]] (hydrohil.circuits.faults), drawn in red: a leak's orifice, a parameter a fault
    drives. ``loop``: its scenario's closed loop (:class:`hydrohil.circuits.run.Loop`), drawn as the controller's
    block between the measured component and the commanded one (dashed: signals)."""
    out = Path(out)
    fmt = out.suffix.lstrip(".").lower()
    if fmt not in ("png", "svg"):
        raise InputError(f"the drawing is a .png or a .svg, got {out.name!r}", key="out")
    if shutil.which("dot") is None:
        raise InputError("circuit draw needs Graphviz's dot program (Debian: apt-get install graphviz)")
    import graphviz
    from hydrohil.circuits.symbols import SYMBOLS, render
    from hydrohil.circuits.units import to_si
    g = graphviz.Digraph(c.name, engine="dot", format=fmt,
                         graph_attr={"rankdir": "BT", "label": f"{c.name}", "labelloc": "t", "fontname": "Helvetica",
                                     "fontsize": "16", "splines": "true", "nodesep": "0.45", "ranksep": "0.45",
                                     **({"dpi": "110"} if fmt == "png" else {})},
                         node_attr={"fontname": "Helvetica", "fontsize": "11"},
                         edge_attr={"fontname": "Helvetica", "fontsize": "9", "color": LINE, "penwidth": "1.6",
                                    "arrowhead": "none", "fontcolor": "#555555"})
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
        fixed = f" (fixed by {c.fixed[node][0]})" if node in c.fixed and c.fixed[node][0] != node else ""
        g.node(f"n__{node}", label="", xlabel=node + fixed, shape="point", width="0.12", color=LINE,
               fontcolor=LINE, fontsize="10")
    with tempfile.TemporaryDirectory() as tmp:
        images: dict[tuple[str, str], Path] = {}
        for comp in c.components.values():
            t = comp.type.name
            colour = FAULT if comp.name in fault_parts else "black"
            if (t, colour) not in images:
                images[(t, colour)] = Path(tmp) / f"{t}_{len(images)}.png"
                render(t, images[(t, colour)], colour)
            sym, ports = SYMBOLS[t], dict(SYMBOLS[t].ports)
            if t in SYMMETRIC and _to_tank(c, comp.ports["b"]):     # its tank side down, as a drawing has it
                ports = {"a": ports["b"], "b": ports["a"]}
            lines = [t.replace("_", " "), *_figures(comp)]
            if comp.name in fault_parts:                    # a fault's part: red, its window said
                lines.append(fault_parts[comp.name])
            g.node(f"c__{comp.name}", shape="none", margin="0",
                   label=_label(comp.name, lines, sym, images[(t, colour)], colour, ports, bool(comp.coupled)))
            for port, node in comp.ports.items():     # the power unit below, the actuators above (rankdir BT)
                side = ports[port][0]
                label = port if port != node else ""   # (a port named as its node: one label)
                if side == "s":                       # the node below the symbol: the line into its bottom
                    g.edge(f"n__{node}", f"c__{comp.name}", headport=f"p_{port}:s", headlabel=label,
                           labeldistance="1.2", labelangle="30")
                else:
                    g.edge(f"c__{comp.name}", f"n__{node}", tailport=f"p_{port}:n", taillabel=label,
                           labeldistance="1.2", labelangle="-30")
        for comp in c.components.values():            # mechanical couplings: a rod driving its load (double line)
            if comp.coupled:                          # (the load above its actuator(s), as a lift's deck)
                g.edge(f"c__{comp.name}", f"c__{comp.coupled}", tailport="img:e", headport="img:s",
                       label=comp.type.coupling.part, color="#555555:#555555", penwidth="1.2")
        if loop is not None:                          # the controller: measured signal in, command out
            _controller(g, loop, c.components)
        for sig in c.inputs:
            comp = sig.split(".", 1)[0]
            if sig not in fault_signals and sig.split(".", 1)[1] not in c.components[comp].type.params:
                continue                                    # (a derived value following a fault's parameter)
            if loop is not None and sig == loop.command:
                continue                                    # (the controller's, drawn above)
            label = fault_signals.get(sig, sig)
            colour = FAULT if sig in fault_signals else SIGNAL
            g.node(f"s__{sig}", label=label, shape="plaintext", fontcolor=colour, fontsize="10")
            with g.subgraph() as same:
                same.attr(rank="same")
                same.node(f"s__{sig}")
                same.node(f"c__{comp}")
            g.edge(f"s__{sig}", f"c__{comp}", headport="img:w", style="dashed", color=colour, arrowhead="normal",
                   penwidth="1.0")
        out.parent.mkdir(parents=True, exist_ok=True)
        try:
            g.render(outfile=str(out), cleanup=True)
        except (graphviz.ExecutableNotFound, graphviz.CalledProcessError) as exc:
            raise HydrohilError(f"Graphviz's dot could not draw {c.name!r} ({c.source}): {exc}") from None
        if fmt == "svg":                                # the symbols inside the file, not beside it
            text = out.read_text()
            for path in images.values():
                data = base64.b64encode(path.read_bytes()).decode()
                for written in {str(path), html.escape(str(path))}:    # (as dot wrote the file's name)
                    text = text.replace(f'"{written}"', f'"data:image/png;base64,{data}"')
            out.write_text(text)
    return out
