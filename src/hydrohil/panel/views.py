"""What the panel's page draws and steers for a rig (one place: the page builds its plots and forms from it).

A view is a dict sent with ``/api/state`` (``view``): its plots (``plots``: id, title, height, series of [column,
colour, display factor, dash]), its mode strips (``modes``: title, rows of [column, label, colours, mode names]),
the telemetry columns of the plant and of the controller (what the side hub accepts), and the steering forms
the page shows. The paper's rig shows what it always did; a circuit (a scenario naming its circuit) shows its
signals grouped by unit (the loop's measured signal with its reference first, then pressures, positions,
speeds, flows, ...), its mode strips, its inputs (held from the page) and its parameters (changed from the page).
"""

from __future__ import annotations

import math

from hydrohil.core import shape

PALETTE = ("#1565c0", "#ef6c00", "#2e7d32", "#6a1b9a", "#c62828", "#00838f", "#795548", "#455a64", "#ad1457",
           "#9e9d24")
MODE_PALETTE = ("#c8e6c9", "#e53935", "#1e88e5", "#ffb74d", "#b3e5fc", "#fff59d", "#ce93d8", "#90a4ae")
# the order a circuit's signals are shown in, by SI unit (others after, in the order met)
UNIT_ORDER = ("Pa", "m", "m/s", "rad", "rad/s", "m3/s", "m3", "N", "N.m", "-")
UNIT_TITLE = {"Pa": "pressure", "m": "position", "m/s": "velocity", "rad": "angle", "rad/s": "speed",
              "m3/s": "flow", "m3": "volume", "N": "force", "N.m": "torque", "-": "opening / command"}


def _num(v) -> float | None:
    """A number as JSON carries it: None for one not given (NaN, None) or unbounded (inf)."""
    return float(v) if v is not None and math.isfinite(v) else None


def paper_view() -> dict:
    """The paper's rig (core/shape.py's telemetry columns)."""
    pos = [["x_ref", "#444", 1e3, [4, 3]], ["xp", "#1565c0", 1e3]]
    return {
        "kind": "paper",
        "plant_columns": list(shape.SIDE_PLANT_COLUMNS),
        "controller_columns": list(shape.SIDE_CONTROLLER_COLUMNS),
        "plots": [
            {"id": "c-position", "title": "position [mm]", "height": 150, "series": pos},
            {"id": "c-error", "title": "error x_ref − xp [mm]", "height": 90, "series": [["error", "#c62828", 1e3]]},
            {"id": "c-pressure", "title": "pressure [bar]", "height": 130,
             "series": [["p1", "#1565c0", 1e-5], ["p2", "#ef6c00", 1e-5], ["ps", "#444", 1e-5, [4, 3]]]},
            {"id": "c-valve", "title": "command ū and spool xs [-]", "height": 100,
             "series": [["u", "#6a1b9a", 1], ["xs", "#2e7d32", 1]]},
            {"id": "c-friction", "title": "friction force [N]", "height": 90, "series": [["ff", "#795548", 1]]}],
        "modes": {"title": "modes: travel · friction · spool", "rows": [
            [f"{m}_mode", m, colours, list(shape.MODE_NAMES[m])] for m, colours in (
                ("travel", ["#c8e6c9", "#e53935", "#1e88e5"]), ("friction", ["#ffb74d", "#b3e5fc", "#b3e5fc"]),
                ("spool", ["#e0e0e0", "#fff59d", "#ffcc80", "#e57373"]))]},
    }


def circuit_view(cs) -> dict:
    """A circuit scenario (:class:`hydrohil.circuits.scenario.CircuitScenario`): its signals by unit, its
    modes, its inputs and parameters with their units and ranges."""
    from hydrohil.circuits.faults import SENSOR_FAULTS, driven_by_fault, fault_inputs, follows_fault, live_switch
    from hydrohil.circuits.link import CONTROLLER_SIDE_COLUMNS, side_columns, wire_lists
    from hydrohil.errors import InputError
    from hydrohil.circuits.units import display
    c, lay, loop = cs.circuit, cs.layout, cs.loop
    signals, inputs = wire_lists(c, lay)
    plots: list[dict] = []

    def plot(pid: str, title: str, unit: str, series: list, height: int = 110) -> None:
        k, du = display(unit)
        plots.append({"id": pid, "title": f"{title} [{du}]", "height": height,
                      "series": [[col, PALETTE[i % len(PALETTE)], k, *extra] for i, (col, *extra) in enumerate(series)]})

    units = dict(signals)
    if loop is not None:
        m = loop.measure
        plot("c-loop", f"{m} and its reference", units[m], [("reference", [4, 3]), (m,)], 150)
        plot("c-error", "error reference − measured", units[m], [("error",)], 90)
    if inputs:
        by_unit: dict[str, list] = {}
        for name, unit in inputs:
            by_unit.setdefault(unit, []).append((f"{name}.applied",))
        for unit, series in by_unit.items():
            plot(f"c-inputs-{len(plots)}", "inputs as applied", unit, series, 90)
    groups: dict[tuple, list] = {}
    for name, unit in signals:
        comp = c.components.get(name.split(".")[0])
        if name in lay.modes or (loop is not None and name == loop.measure):
            continue
        spool = comp is not None and {"P", "T", "A", "B"} <= set(comp.type.ports)
        if spool and name.endswith(".v"):         # a spool's speed: not what an engineer watches
            continue
        groups.setdefault((unit, spool), []).append((name,))
    order = {u: i for i, u in enumerate(UNIT_ORDER)}
    for (unit, spool), series in sorted(groups.items(), key=lambda g: (order.get(g[0][0], len(order)), g[0][1])):
        title = ("valve " if spool else "") + UNIT_TITLE.get(unit, unit)
        plot(f"c-{'valve-' if spool else ''}{unit.replace('/', '_').replace('.', '_')}", title, unit, series)
    rows = [[name, name.rsplit(".", 1)[0], list(MODE_PALETTE), list(lay.mode_names[name])] for name in lay.modes]
    params = []
    for comp in c.components.values():
        follows = follows_fault(c, comp.name)          # (its derived values follow a fault's drive)
        for key, prm in comp.type.params.items():
            name = f"{comp.name}.{key}"
            if name in c.inputs or name in lay.delay_params.values() or key in comp.load_keys or follows:
                continue
            k, du = display(prm.unit)
            params.append({"name": name, "unit": prm.unit, "shown": [k, du], "lo": _num(prm.lo), "hi": _num(prm.hi),
                           "value": _num(comp.values[key]), "description": prm.text(comp.name)})
    ins = []
    scheduled = fault_inputs(cs.faults)
    for name, unit in inputs:
        if driven_by_fault(c, name) or name in scheduled:
            continue                                  # (a fault's schedule: not held from the page)
        prm = c.input_param(name)
        ins.append({"name": name, "unit": unit, "shown": list(display(unit)), "lo": _num(prm.lo), "hi": _num(prm.hi),
                    "controller": (loop is not None and name == loop.command) or (
                        cs.commands is not None and name in cs.commands.inputs),
                    "description": prm.text(name.split(".")[0])})
    faults = []                                       # the scenario's faults, switched on and off from the page
    for i, f in enumerate(cs.faults):
        what = f.get("node") or f.get("target") or f.get("signal") or (loop.measure if loop is not None and
                                                                         f["type"] in SENSOR_FAULTS else "commands")
        try:
            sw = live_switch(cs, i, "panel")
            why = None if sw.off is not None else "on only: it starts at 0 and never ends"
        except InputError as exc:
            sw, why = None, exc.message
        faults.append({"slot": i, "type": f["type"], "what": str(what), "switchable": sw is not None,
                       "off": sw is not None and sw.off is not None, "why": why})
    return {"kind": "circuit", "circuit": c.name, "faults": faults,
            "plant_columns": list(side_columns(signals, inputs)),
            "controller_columns": list(CONTROLLER_SIDE_COLUMNS) if loop is not None else [],
            "plots": plots, "modes": {"title": "modes", "rows": rows} if rows else None,
            "inputs": ins, "params": params,
            "reference": {"signal": loop.measure, "unit": units[loop.measure],
                          "shown": list(display(units[loop.measure]))} if loop is not None else None}
