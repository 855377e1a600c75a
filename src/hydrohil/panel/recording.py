"""A recording of the live panel made complete: the files ``hydrohil hil`` writes, checked by a replay.

The plant writes ``plant_log.csv`` and ``timing.json`` of the recorded steps k0+1 .. k1 (its step loop);
here the panel adds ``scenario.toml``, the session's events up to k1 (a recording replays from the start
of its session), ``comparison.json`` (the replay of the session's applied commands and plant events, which
must give the recorded states bit for bit) and ``report.png``.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np


def _events_until(src: Path, dst: Path, k1: int) -> list[dict]:
    out = []
    if src.is_file():
        lines = [ln for ln in src.read_text().splitlines() if ln.strip() and json.loads(ln)["k"] <= k1]
        dst.write_text("".join(ln + "\n" for ln in lines))
        out = [json.loads(ln) for ln in lines]
    return out


SHOWN_UNITS = {"supply_pressure": (1e5, "bar"), "mass": (1, "kg"), "force": (1, "N"), "friction_scale": (1, "×")}


def _label(ev: dict, slots: dict) -> str:
    """A short text for an applied event (``slots``: slot -> fault type, as switched on so far)."""
    op = ev.get("op")
    if op == "set":
        scale, unit = SHOWN_UNITS.get(ev["name"], (1, ""))
        return f"{ev['name'].replace('_', ' ')} {ev['value'] / scale:g} {unit}"
    if op == "fault_on":
        slots[ev.get("result", {}).get("slot")] = ev["fault"]["type"]
        return f"{ev['fault']['type']} on"
    if op == "fault_off":
        return f"{slots.get(ev['slot'], 'fault')} off"
    if op == "gains":
        return ", ".join(f"{k}={v:g}" for k, v in ev.items() if k not in ("op", "k"))
    if op == "reference":
        return "reference " + ("scenario" if ev.get("value") is None else f"{ev['value'] * 1e3:g} mm")
    return str(op)


def finish_recording(sc, session: Path, folder: Path, k0: int, k1: int) -> dict:
    from hydrohil.simulation.outputs import read_csv_columns
    from hydrohil.hil.session import replay_session
    from hydrohil.hil.verdict import judge
    from hydrohil.models.sensors import count_size
    from hydrohil.plotting import plot_recording
    session, folder = Path(session), Path(folder)
    if (session / "scenario.toml").is_file():
        shutil.copyfile(session / "scenario.toml", folder / "scenario.toml")
    plant_ev = _events_until(session / "events.jsonl", folder / "events.jsonl", k1)
    ctl_ev = _events_until(session / "controller_events.jsonl", folder / "controller_events.jsonl", k1)
    log = read_csv_columns(folder / "plant_log.csv")
    ks = log["k"].astype(np.int64)
    k_first = int(ks[0]) if len(ks) else 0
    rep = replay_session(sc, session, steps=int(ks[-1]) if len(ks) else 0, keep_from=k_first)
    cmp = {"recorded_steps": [int(ks[0]), int(ks[-1])] if len(ks) else [], "replayed_from_step": 0}
    for c in ("xp", "p1", "p2", "xs", "vp"):
        cmp[f"replay_{c}_max_abs"] = float(np.max(np.abs(rep[c][ks - k_first] - log[c]))) if len(ks) else None
    (folder / "comparison.json").write_text(json.dumps(cmp, indent=2) + "\n")
    timing = json.loads((folder / "timing.json").read_text())
    h = sc.scenario.plant_step
    log.update(h=h, count_m=count_size(sc.params.sensors.encoder_resolution))
    slots: dict = {}
    events = [{"t": e["k"] * h, "label": _label(e, slots)} for e in plant_ev + ctl_ev]
    plot_recording(folder / "report.png", log, events=events, verdict=timing.get("verdict") or judge(timing, sc.scenario.hil),
                   title=f"{folder.name}: steps {cmp['recorded_steps']} of {session.name}")
    return {"comparison": cmp}


def finish_circuit_recording(cs, session: Path, folder: Path, k0: int, k1: int) -> dict:
    """A recording of a circuit plant's session made complete: ``scenario.toml``, the events up to k1, the
    replay of the session's applied inputs and plant events (:func:`hydrohil.hil.circuit.replay_circuit_session`,
    which must give the recorded states bit for bit: ``comparison.json``), ``report.png`` (recorded vs replayed,
    the inputs as applied, the jitter, the watchdog)."""
    from hydrohil.circuits.run import CircuitResult, input_unit, signal_units
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.hil.circuit import replay_circuit_session
    from hydrohil.hil.verdict import judge
    from hydrohil.plotting import plot_circuit_hil
    from hydrohil.simulation.outputs import read_csv_columns
    from hydrohil.simulation.scenario import circuit_hil
    session, folder = Path(session), Path(folder)
    if (session / "scenario.toml").is_file():
        shutil.copyfile(session / "scenario.toml", folder / "scenario.toml")
        cs = load_circuit_scenario(folder / "scenario.toml")          # (as the session ran: repeating)
    _events_until(session / "events.jsonl", folder / "events.jsonl", k1)
    _events_until(session / "controller_events.jsonl", folder / "controller_events.jsonl", k1)
    log = read_csv_columns(folder / "plant_log.csv")
    ks = log["k"].astype(np.int64)
    k_first = int(ks[0]) if len(ks) else 0
    lay = cs.layout
    rep = replay_circuit_session(cs, session, steps=int(ks[-1]) if len(ks) else 0, keep_from=k_first)
    diff = {s: float(np.max(np.abs(rep[ks - k_first, i] - log[s]))) if len(ks) else None
            for i, s in enumerate(lay.states)}
    cmp = {"recorded_steps": [int(ks[0]), int(ks[-1])] if len(ks) else [], "replayed_from_step": 0,
           "replay_max_abs_difference": diff,
           "identical": bool(len(ks)) and all(v == 0.0 for v in diff.values())}
    (folder / "comparison.json").write_text(json.dumps(cmp, indent=2) + "\n")
    timing = json.loads((folder / "timing.json").read_text())
    units = {s: u for s, u in signal_units(cs.circuit, lay).items() if s in lay.states}    # (what a replay has)
    units.update({name: input_unit(cs.circuit, name) for name in lay.inputs})              # (the inputs' strip)
    replayed = CircuitResult({"t": ks * cs.step, **{s: rep[ks - k_first, i] for i, s in enumerate(lay.states)}},
                             units, lay.mode_names, cs.step, cs.method)
    measure = cs.loop.measure if cs.loop is not None and cs.loop.measure in units else None
    plot_circuit_hil(folder / "report.png", log, replayed, measure,
                     title=f"{folder.name}: steps {cmp['recorded_steps']} of {session.name} ({cs.circuit.name})",
                     verdict=timing.get("verdict") or judge(timing, circuit_hil(cs)), inputs=lay.inputs,
                     commanded=cs.loop is not None or cs.commands is not None, other="replay")
    return {"comparison": cmp}
