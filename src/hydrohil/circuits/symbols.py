"""The components' graphic symbols in the spirit of ISO 1219-1 (fluid power: graphic symbols), drawn with
matplotlib for ``hydrohil circuit draw``: a directional valve's envelopes side by side with its flow paths, its
spring and its proportional solenoid, a pump's and a motor's circle with the triangle pointing out or in, a
pressure valve's square with the arrow off the flow line, its spring and its dashed pilot line, a check valve's
ball on its seat, an accumulator's capsule, a restrictor, a flexible line, a tank's open box, a cylinder with its
piston and rod. Each symbol is a :class:`Symbol`: its size and where its ports leave it (its top or bottom edge,
at a fraction of its width), so that the diagram's lines meet the symbol's own port stubs; a power unit below, the
actuators above (ISO practice: flow upward through the page)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

LW = 1.3            # line width [pt]
DASH = (0, (4, 2.5))


@dataclass(frozen=True)
class Symbol:
    """A symbol's size [in] and its ports: port -> (side "n" or "s", x as a fraction of the width); an
    actuator's rod or shaft leaves at its right edge (its coupling to a load is drawn from there)."""
    draw: Callable
    width: float
    height: float
    ports: dict[str, tuple[str, float]]


def _line(ax, pts, colour, **kw):
    a = np.asarray(pts, float)
    ax.plot(a[:, 0], a[:, 1], color=colour, lw=kw.pop("lw", LW), solid_capstyle="butt", **kw)


def _arrow(ax, start, end, colour, head=0.09):
    """A flow arrow from start to end, its filled head at end."""
    (x0, y0), (x1, y1) = start, end
    d = np.hypot(x1 - x0, y1 - y0)
    ux, uy = (x1 - x0) / d, (y1 - y0) / d
    bx, by = x1 - head * ux, y1 - head * uy
    _line(ax, [start, (bx, by)], colour)
    px, py = -uy * head * 0.4, ux * head * 0.4
    ax.fill([x1, bx + px, bx - px], [y1, by + py, by - py], color=colour, lw=0)


def _blocked(ax, x, y, colour, down=True, w=0.06, stub=0.09):
    """A closed port inside an envelope: its stub ending in a crossbar (ISO's T)."""
    y1 = y + (stub if down else -stub)
    _line(ax, [(x, y), (x, y1)], colour)
    _line(ax, [(x - w, y1), (x + w, y1)], colour)


def _spring(ax, x0, x1, y, colour, amp=0.07, n=4, vertical=False):
    """A zigzag spring from x0 to x1 at height y (or, vertical, from y0=x0 to y1=x1 at abscissa y)."""
    t = np.linspace(0, 1, 2 * n + 1)
    along = x0 + (x1 - x0) * t
    across = y + amp * np.array([0 if i in (0, 2 * n) else (1 if i % 2 else -1) for i in range(2 * n + 1)])
    _line(ax, np.c_[across, along] if vertical else np.c_[along, across], colour, lw=1.0)


def _triangle(ax, cx, cy, size, up, colour):
    s = size if up else -size
    ax.fill([cx - size * 0.6, cx + size * 0.6, cx], [cy, cy, cy + s], color=colour, lw=0)


def _box(ax, x0, y0, x1, y1, colour, **kw):
    _line(ax, [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)], colour, **kw)


def _stubs(ax, sym: Symbol, y_in: dict, colour):
    """Each port's line from the symbol's edge to where it enters the drawing (y_in: port -> y)."""
    for port, (side, f) in sym.ports.items():
        x = f * sym.width
        _line(ax, [(x, sym.height if side == "n" else 0.0), (x, y_in[port])], colour)


# ---- the symbols: each draws on axes in inches, (0, 0) the lower left, given the symbol and a colour ----

def _tank(ax, sym, c):
    w = sym.width
    _line(ax, [(0.1 * w, 0.3), (0.1 * w, 0.05), (0.9 * w, 0.05), (0.9 * w, 0.3)], c)
    _stubs(ax, sym, {"p": 0.12}, c)


def _source(ax, sym, c):
    r, cx, cy = 0.2, sym.width / 2, 0.26
    ax.add_patch(_circle(cx, cy, r, c))
    _triangle(ax, cx, cy + r - 0.13, 0.12, True, c)
    ax.text(cx, cy - 0.08, "p", ha="center", va="center", fontsize=7, color=c, style="italic")
    _stubs(ax, sym, {"p": cy + r}, c)


def _circle(cx, cy, r, c):
    from matplotlib.patches import Circle
    return Circle((cx, cy), r, fill=False, edgecolor=c, lw=LW)


def _rotating(ax, cx, cy, r, c, pump: bool):
    """A pump's or motor's circle, its triangle(s) at the top (out: a pump, in: a motor), its drive shaft and
    the rotation's arc to the right."""
    ax.add_patch(_circle(cx, cy, r, c))
    if pump:
        _triangle(ax, cx, cy + r - 0.13, 0.12, True, c)
    else:
        _triangle(ax, cx, cy + r - 0.01, 0.12, False, c)
        _triangle(ax, cx, cy - r + 0.01, 0.12, True, c)
    _line(ax, [(cx + r, cy + 0.02), (cx + r + 0.22, cy + 0.02)], c, lw=1.0)
    _line(ax, [(cx + r, cy - 0.02), (cx + r + 0.22, cy - 0.02)], c, lw=1.0)
    from matplotlib.patches import Arc
    ax.add_patch(Arc((cx + r + 0.11, cy), 0.16, 0.2, theta1=120, theta2=240, color=c, lw=1.0))


def _pump(ax, sym, c):
    cx, cy, r = 0.3, sym.height / 2, 0.22
    _rotating(ax, cx, cy, r, c, True)
    _stubs(ax, sym, {"inlet": cy - r, "outlet": cy + r}, c)


def _motor(ax, sym, c):
    cx, cy, r = 0.3, sym.height / 2 + 0.05, 0.22
    _rotating(ax, cx, cy, r, c, False)
    x_a, x_b = (f * sym.width for _, f in (sym.ports["a"], sym.ports["b"]))
    for x in (x_a, x_b):                     # both ports from below, into the circle's lower half
        dx = x - cx
        _line(ax, [(x, 0.0), (x, cy - np.sqrt(max(r * r - dx * dx, 0.0)))], c)


def _relief(ax, sym, c):
    """A pressure valve, normally closed: its square, the arrow off the flow line, the spring on the right, the
    dashed pilot line from the inlet (top) to the left side."""
    x0, x1, y0, y1 = 0.22, 0.22 + 0.44, 0.2, 0.64
    xm = sym.ports["p"][1] * sym.width
    _box(ax, x0, y0, x1, y1, c)
    _arrow(ax, (xm + 0.08, y1 - 0.05), (xm + 0.08, y0 + 0.05), c)
    _spring(ax, x1, x1 + 0.22, (y0 + y1) / 2, c)
    _line(ax, [(x1 + 0.2, (y0 + y1) / 2 - 0.1), (x1 + 0.26, (y0 + y1) / 2 + 0.1)], c, lw=0.8)   # adjustable
    _line(ax, [(xm, y1 + 0.1), (0.08, y1 + 0.1), (0.08, (y0 + y1) / 2), (x0, (y0 + y1) / 2)], c, lw=1.0,
          linestyle=DASH)
    _stubs(ax, sym, {"p": y1, "t": y0}, c)


def _seat(ax, cx, cy, c, spring: bool):
    """A check valve's ball on its V seat: free flow upward (from the seat's point), closed downward."""
    ax.add_patch(_circle(cx, cy + 0.02, 0.07, c))
    _line(ax, [(cx - 0.1, cy + 0.04), (cx, cy - 0.09), (cx + 0.1, cy + 0.04)], c)
    if spring:
        _spring(ax, cy + 0.09, cy + 0.26, cx, c, amp=0.05, n=3, vertical=True)


def _check(ax, sym, c):
    cx = sym.ports["a"][1] * sym.width
    _seat(ax, cx, 0.3, c, True)
    _stubs(ax, sym, {"a": 0.21, "b": 0.56}, c)


def _orifice(ax, sym, c):
    from matplotlib.patches import Arc
    cx, cy = sym.width / 2, sym.height / 2
    _stubs(ax, sym, {"a": cy, "b": cy}, c)
    for side in (-1, 1):                       # the two arcs bulging into the line: a fixed restrictor
        ax.add_patch(Arc((cx + side * 0.16, cy), 0.24, 0.3, theta1=(150 if side > 0 else -30),
                         theta2=(210 if side > 0 else 30), color=c, lw=LW))


def _accumulator(ax, sym, c):
    from matplotlib.patches import FancyBboxPatch
    cx, w = sym.width / 2, 0.3
    ax.add_patch(FancyBboxPatch((cx - w / 2, 0.16), w, 0.52, boxstyle="round,pad=0,rounding_size=0.15",
                                fill=False, edgecolor=c, lw=LW))
    _line(ax, [(cx - w / 2, 0.42), (cx + w / 2, 0.42)], c)                   # the separating element
    _triangle(ax, cx, 0.5, 0.09, True, c)                                      # its gas side
    _stubs(ax, sym, {"p": 0.16}, c)


def _hose(ax, sym, c):
    from matplotlib.patches import Arc
    cx, h = sym.width / 2, sym.height
    _line(ax, [(cx, 0.0), (cx, 0.14)], c)
    _line(ax, [(cx, h - 0.14), (cx, h)], c)
    ax.add_patch(Arc((cx, h / 2), 0.3, h - 0.28, theta1=90, theta2=270, color=c, lw=LW))  # a flexible line


def _volume(ax, sym, c):
    from matplotlib.patches import FancyBboxPatch
    ax.add_patch(FancyBboxPatch((0.12, 0.18), sym.width - 0.24, 0.34, boxstyle="round,pad=0,rounding_size=0.06",
                                fill=False, edgecolor=c, lw=LW))
    ax.text(sym.width / 2, 0.35, "V", ha="center", va="center", fontsize=8, color=c)
    _stubs(ax, sym, {"p": 0.18}, c)


def _cylinder_body(ax, sym, c, x0, x1, piston, rods, mass=False):
    y0, y1 = 0.22, 0.58
    _box(ax, x0, y0, x1, y1, c)
    _line(ax, [(piston, y0), (piston, y1)], c, lw=2.6)
    ym = (y0 + y1) / 2
    for a, b in rods:
        _line(ax, [(a, ym - 0.03), (b, ym - 0.03)], c, lw=1.0)
        _line(ax, [(a, ym + 0.03), (b, ym + 0.03)], c, lw=1.0)
    if mass:                                  # its load at the rod's end (a mass block)
        _box(ax, sym.width - 0.3, ym - 0.16, sym.width - 0.02, ym + 0.16, c)
        ax.text(sym.width - 0.16, ym, "m", ha="center", va="center", fontsize=8, color=c, style="italic")
    _stubs(ax, sym, {p: y0 for p in sym.ports}, c)


def _cylinder(ax, sym, c):
    w = sym.width
    _cylinder_body(ax, sym, c, 0.05, 0.72 * w, 0.3 * w, [(0.3 * w, w)])


def _double_rod(ax, sym, c):
    w = sym.width
    _cylinder_body(ax, sym, c, 0.16 * w, 0.84 * w, 0.5 * w, [(0.0, 0.5 * w), (0.5 * w, w)])


def _lugre_cylinder(ax, sym, c):
    w = sym.width
    _cylinder_body(ax, sym, c, 0.05, 0.6 * w, 0.25 * w, [(0.25 * w, w - 0.3)], mass=True)


def _load(ax, sym, c):
    w, h = sym.width, sym.height
    _box(ax, 0.15, 0.2, w - 0.1, h - 0.12, c)
    ax.text((w + 0.05) / 2, (h + 0.08) / 2, "m", ha="center", va="center", fontsize=9, color=c, style="italic")
    _arrow(ax, (0.06, h - 0.2), (0.06, 0.2), c, head=0.07)                    # gravity
    ax.text(0.06, 0.1, "g", ha="center", va="center", fontsize=7, color=c, style="italic")


def _rotary_load(ax, sym, c):
    from matplotlib.patches import Ellipse
    cx, cy = sym.width / 2 + 0.05, sym.height / 2
    _line(ax, [(0.0, cy + 0.02), (cx, cy + 0.02)], c, lw=1.0)
    _line(ax, [(0.0, cy - 0.02), (cx, cy - 0.02)], c, lw=1.0)
    ax.add_patch(Ellipse((cx, cy), 0.14, 0.5, fill=True, facecolor="white", edgecolor=c, lw=LW))   # a flywheel
    ax.text(cx + 0.16, cy, "J", ha="center", va="center", fontsize=8, color=c, style="italic")


def _envelopes(ax, sym, c, centre: str, left_actuator: str, right_actuator: str):
    """A directional valve's three envelopes (squares of side e): left: P->A, B->T straight; centre: the neutral
    position (closed, or open centre P->T); right: P->B, A->T crossed; a centring spring and an actuator (None:
    none) at each end; the two lines above and below of a continuously positioned (proportional) valve."""
    e, x0, y0 = 0.46, 0.45, 0.16
    y1 = y0 + e
    for i in range(3):
        _box(ax, x0 + i * e, y0, x0 + (i + 1) * e, y1, c)
    for y in (y0 - 0.05, y1 + 0.05):                       # continuously positioned
        _line(ax, [(x0, y), (x0 + 3 * e, y)], c, lw=0.8)
    a, b = 0.25 * e, 0.75 * e
    L = x0                                                  # left envelope: parallel
    _arrow(ax, (L + a, y0), (L + a, y1), c)
    _arrow(ax, (L + b, y1), (L + b, y0), c)
    R = x0 + 2 * e                                          # right envelope: crossed
    _arrow(ax, (R + a, y0), (R + b, y1), c)
    _arrow(ax, (R + a, y1), (R + b, y0), c)
    C = x0 + e
    if centre == "open":                                     # open centre: P to T, A and B closed
        _line(ax, [(C + a, y0), (C + a, y0 + 0.14), (C + b, y0 + 0.14), (C + b, y0)], c)
        _blocked(ax, C + a, y1, c, down=False)
        _blocked(ax, C + b, y1, c, down=False)
    else:                                                   # closed centre: every port blocked
        for x in (C + a, C + b):
            _blocked(ax, x, y0, c, down=True)
            _blocked(ax, x, y1, c, down=False)
    ym = (y0 + y1) / 2
    for side, kind in ((-1, left_actuator), (1, right_actuator)):   # spring-centred: a spring at each end,
        edge = x0 if side < 0 else x0 + 3 * e                       # then its actuator
        _spring(ax, edge, edge + side * 0.16, ym, c, amp=0.06, n=3)
        if kind is None:
            continue
        bx = edge + side * 0.16 if side > 0 else edge - 0.16 - 0.14    # a proportional solenoid (slanted arrow)
        _box(ax, bx, ym - 0.12, bx + 0.14, ym + 0.12, c)
        _line(ax, [(bx + 0.02, ym - 0.1), (bx + 0.12, ym + 0.1)], c, lw=0.8)
        if kind == "servo":                                 # a torque motor's pilot stage: a second box
            bx2 = bx + side * 0.14
            _box(ax, bx2, ym - 0.12, bx2 + 0.14, ym + 0.12, c)
            _line(ax, [(bx2 + 0.02, ym), (bx2 + 0.12, ym)], c, lw=0.8)
    _stubs(ax, sym, {"A": y1, "B": y1, "P": y0, "T": y0}, c)


def _valve43(ax, sym, c):
    _envelopes(ax, sym, c, "closed", "solenoid", "solenoid")


def _valve63(ax, sym, c):
    _envelopes(ax, sym, c, "open", "solenoid", "solenoid")


def _servo(ax, sym, c):
    _envelopes(ax, sym, c, "closed", "servo", None)


def _counterbalance(ax, sym, c):
    """A counterbalance valve: a pressure valve from the load down to the directional valve (piloted by its own
    inlet and by the pilot line, dashed) and a check valve beside it for free flow up to the load."""
    w = sym.width
    x_in, x_pilot = sym.ports["valve"][1] * w, sym.ports["pilot"][1] * w
    x0, x1, y0, y1 = x_in - 0.2, x_in + 0.2, 0.26, 0.66
    _box(ax, x0, y0, x1, y1, c)
    _arrow(ax, (x_in - 0.07, y1 - 0.05), (x_in - 0.07, y0 + 0.05), c)
    _spring(ax, x0, x0 - 0.18, (y0 + y1) / 2, c, amp=0.05, n=3)
    _line(ax, [(x_pilot, 0.0), (x_pilot, 0.12), (x1 + 0.1, 0.12), (x1 + 0.1, (y0 + y1) / 2), (x1, (y0 + y1) / 2)],
          c, lw=1.0, linestyle=DASH)
    xc = x1 + 0.3                                            # the check valve's branch, in parallel
    _line(ax, [(x_in, 0.0), (x_in, y0)], c)
    _line(ax, [(x_in, y1), (x_in, sym.height)], c)
    _line(ax, [(x_in, 0.08), (xc, 0.08), (xc, 0.32)], c)
    _seat(ax, xc, 0.42, c, False)
    _line(ax, [(xc, 0.5), (xc, sym.height - 0.08), (x_in, sym.height - 0.08)], c)


SYMBOLS: dict[str, Symbol] = {
    "tank": Symbol(_tank, 0.5, 0.4, {"p": ("n", 0.5)}),
    "pressure_source": Symbol(_source, 0.5, 0.6, {"p": ("n", 0.5)}),
    "pump": Symbol(_pump, 0.85, 0.6, {"inlet": ("s", 0.3 / 0.85), "outlet": ("n", 0.3 / 0.85)}),
    "relief_valve": Symbol(_relief, 0.95, 0.84, {"p": ("n", 0.44 / 0.95), "t": ("s", 0.44 / 0.95)}),
    "check_valve": Symbol(_check, 0.4, 0.72, {"a": ("s", 0.5), "b": ("n", 0.5)}),
    "orifice": Symbol(_orifice, 0.4, 0.5, {"a": ("s", 0.5), "b": ("n", 0.5)}),
    "accumulator": Symbol(_accumulator, 0.45, 0.75, {"p": ("s", 0.5)}),
    "hose": Symbol(_hose, 0.4, 0.6, {"a": ("s", 0.5), "b": ("n", 0.5)}),
    "volume": Symbol(_volume, 0.55, 0.6, {"p": ("s", 0.5)}),
    "motor": Symbol(_motor, 0.85, 0.62, {"a": ("s", 0.2 / 0.85), "b": ("s", 0.4 / 0.85)}),
    "lugre_motor": Symbol(_motor, 0.85, 0.62, {"a": ("s", 0.2 / 0.85), "b": ("s", 0.4 / 0.85)}),
    "rotary_load": Symbol(_rotary_load, 0.6, 0.62, {}),
    "cylinder": Symbol(_cylinder, 1.5, 0.66, {"a": ("s", 0.1), "b": ("s", 0.62)}),
    "double_rod_cylinder": Symbol(_double_rod, 1.5, 0.66, {"a": ("s", 0.24), "b": ("s", 0.76)}),
    "lugre_cylinder": Symbol(_lugre_cylinder, 1.7, 0.66, {"a": ("s", 0.09), "b": ("s", 0.52)}),
    "load": Symbol(_load, 0.7, 0.66, {}),
    "valve_43": Symbol(_valve43, 2.28, 0.78, {"A": ("n", (0.45 + 0.46 + 0.115) / 2.28),
                                                "B": ("n", (0.45 + 0.46 + 0.345) / 2.28),
                                                "P": ("s", (0.45 + 0.46 + 0.115) / 2.28),
                                                "T": ("s", (0.45 + 0.46 + 0.345) / 2.28)}),
    "counterbalance_valve": Symbol(_counterbalance, 1.1, 0.9, {"valve": ("s", 0.45), "load": ("n", 0.45),
                                                               "pilot": ("s", 0.08)}),
}
SYMBOLS["valve_63"] = Symbol(_valve63, **{k: getattr(SYMBOLS["valve_43"], k) for k in ("width", "height", "ports")})
SYMBOLS["servo_valve"] = Symbol(_servo, 2.14, 0.78, {p: (s, f * 2.28 / 2.14)
                                                     for p, (s, f) in SYMBOLS["valve_43"].ports.items()})


def render(type_name: str, path: Path, colour: str = "black", dpi: int = 200) -> Symbol:
    """Draw the symbol of component type ``type_name`` into the PNG ``path`` (transparent); returns it. (A
    Figure of its own, no pyplot: the process's backend is left as it is.)"""
    from matplotlib.figure import Figure
    sym = SYMBOLS[type_name]
    fig = Figure(figsize=(sym.width, sym.height), dpi=dpi)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, sym.width)
    ax.set_ylim(0, sym.height)
    ax.set_aspect("equal")
    ax.axis("off")
    sym.draw(ax, sym, colour)
    fig.savefig(path, transparent=True, dpi=dpi)
    return sym
