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
