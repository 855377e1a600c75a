"""A circuit scenario's faults switched on and off from the live panel (circuits.faults.live_switch, the plant
event ``fault``): each kind, applied to the Python plant's rig at a step boundary, against the rule computed
here (a leak's opening, a parameter with the value derived from it by its closed form, the loop's sensor
offset, a silence tripping the watchdog); what cannot be switched is refused naming the slot."""

import warnings

import numpy as np
import pytest

from conftest import EXAMPLES
from hydrohil.circuits.rig import CircuitRig
from hydrohil.circuits.scenario import load_circuit_scenario
from hydrohil.errors import InputError
from hydrohil.simulation.steering import apply_circuit_event, parse_event

MOTOR = EXAMPLES / "circuits" / "motor_speed"
FAULTS = """
[hil]
watchdog_timeout = 0.01
[[faults]]
type = "leak"
node = "a"
area = "2 mm2"
start = 1.0
end = 1.5
[[faults]]
type = "parameter"
target = "relief.cracking_pressure"
value = "120 bar"
start = 2.0
[[faults]]
type = "sensor_offset"
offset = 20.0
start = 3.5
end = 4.0
[[faults]]
type = "controller_silence"
start = 4.2
end = 4.3
"""


def motor_with_faults(tmp_path, extra: str = FAULTS):
    f = tmp_path / "motor.toml"
    f.write_text((MOTOR / "scenario.toml").read_text().replace('circuit = "circuit.toml"',
                                                                f'circuit = "{MOTOR / "circuit.toml"}"') + extra)
    return load_circuit_scenario(f)


def switch(rig, cs, slot: int, on: bool, k: int):
    ev = parse_event({"op": "fault", "slot": slot, "on": on}, "plant", circuit=cs)
    apply_circuit_event(rig, ev, k)
    return ev


def test_each_kind_of_fault_switched_live_acts_by_its_rule(tmp_path):
    """From step k on, whatever its schedule: the leak's orifice open (1) then closed (0); the relief's cracking
    pressure at the fault's 120 bar with its flow gain K = Q_r/(p_r - p_cr) following (and back to 150 bar with
    its own K); the loop's sensor reading the speed + 20 rad/s; a silent controller's command held, then the
    valve centred once the 10 ms watchdog trips (20 steps), the commands back when it is off."""
    cs = motor_with_faults(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rig = CircuitRig(cs)
    lay = cs.layout
    j = {name: lay.inputs.index(name) for name in lay.inputs}
    cmd = lay.inputs.index("valve.command")
    mask = 1 << cmd

    def step(k, value=0.3):
        values = [0.0] * len(lay.inputs)
        values[cmd] = value
        return rig.step(k, (mask, values)).copy()
    u = step(0)
    assert u[j["leak_a.opening"]] == 0.0 and u[cmd] == 0.3
    ev = switch(rig, cs, 0, True, 1)
    assert ev.inputs == {"leak_a.opening": 1.0} and ev.sensor == -1 and ev.network == -1
    assert step(1)[j["leak_a.opening"]] == 1.0
    switch(rig, cs, 0, False, 2)
    assert step(2)[j["leak_a.opening"]] == 0.0
    relief = cs.circuit.components["relief"].values
    q_r, p_r = 40e-3 / 60.0, 165e5                      # (the file's rated flow and pressure)
    switch(rig, cs, 1, True, 3)
    u = step(3)
    assert u[j["relief.cracking_pressure"]] == pytest.approx(120e5, rel=1e-15)
    assert u[j["relief.flow_gain"]] == pytest.approx(q_r / (p_r - 120e5), rel=1e-12)
    switch(rig, cs, 1, False, 4)
    u = step(4)
    assert u[j["relief.cracking_pressure"]] == pytest.approx(150e5, rel=1e-15)
    assert u[j["relief.flow_gain"]] == pytest.approx(q_r / (p_r - 150e5), rel=1e-12)
    assert u[j["relief.flow_gain"]] == relief["flow_gain"]
    w = lay.log_columns.index("motor.w") - lay.log_columns.index("t") - 1
    assert rig.read()[w] == rig.signal_row[w]
    switch(rig, cs, 2, True, 5)
    step(5)
    assert rig.read()[w] == rig.signal_row[w] + 20.0
    switch(rig, cs, 2, False, 6)
    step(6)
    assert rig.read()[w] == rig.signal_row[w]
    switch(rig, cs, 3, True, 7)
    applied = [step(k, 0.4)[cmd] for k in range(7, 40)]
    assert applied[:20] == [0.3] * 20 and applied[20:] == [0.0] * 13   # (held, then the trip: centred)
    switch(rig, cs, 3, False, 40)
    assert step(40, 0.4)[cmd] == 0.4


def test_faults_the_panel_cannot_switch_are_named(tmp_path):
    """A slot the scenario has not, a parameter two faults drive (neither switched), a pressure transducer's
    fault (the controller process reads it), off for a parameter fault that starts at 0 and never ends (it has
    no value outside it; a leak's off is closed)."""
    cs = motor_with_faults(tmp_path, FAULTS + '[[faults]]\ntype = "parameter"\ntarget = "relief.cracking_pressure"\n'
                                              'value = "100 bar"\nstart = 3.0\n[[faults]]\ntype = "parameter"\n'
                                              'target = "motor.damping"\nvalue = 0.01\nstart = 0.0\n')
    for body, message in (({"slot": 9, "on": True}, "0 to 5"),
                          ({"slot": 1, "on": True}, "faults[1] and faults[4] drive relief.cracking_pressure"),
                          ({"slot": 5, "on": False}, "no value outside it")):
        with pytest.raises(InputError, match=message.replace("[", r"\[").replace("]", r"\]")) as e:
            parse_event({"op": "fault", **body}, "plant", circuit=cs)
        assert e.value.key == "slot"
    assert parse_event({"op": "fault", "slot": 5, "on": True}, "plant", circuit=cs).inputs == {"motor.damping": 0.01}
    assert parse_event({"op": "fault", "slot": 0, "on": False}, "plant", circuit=cs).inputs == {"leak_a.opening": 0.0}
    for name in ("leak_a.opening", "motor.load_torque"):     # (a fault's inputs: not held, even a signal's)
        pumped = motor_with_faults(tmp_path, FAULTS + '[[faults]]\ntype = "parameter"\ntarget = "motor.load_torque"\n'
                                                      'value = 3.0\nstart = 0.5\n')
        with pytest.raises(InputError, match="switch the fault on or off instead") as e:
            parse_event({"op": "input", "name": name, "value": 1.0}, "plant", circuit=pumped)
        assert e.value.key == name
    fig12 = EXAMPLES / "circuits" / "ferreira2004"
    f = tmp_path / "sf.toml"
    f.write_text((fig12 / "scenario.toml").read_text().replace('circuit = "circuit.toml"',
                                                                f'circuit = "{fig12 / "circuit.toml"}"')
                 .replace('type = "p"', 'type = "state_feedback"\nkpl = 1e-9\ntpl = 0.05\nload_pressure = "cyl"')
                 + '[[faults]]\ntype = "sensor_offset"\nsignal = "cap.p"\noffset = "2 bar"\nstart = 0.5\n')
    sf = load_circuit_scenario(f)
    with pytest.raises(InputError, match="pressure transducer the controller process reads") as e:
        parse_event({"op": "fault", "slot": 0, "on": True}, "plant", circuit=sf)
    assert e.value.key == "slot"
    from hydrohil.panel.views import circuit_view
    view = circuit_view(sf)["faults"]
    assert view == [{"slot": 0, "type": "sensor_offset", "what": "cap.p", "switchable": False, "off": False,
                     "why": view[0]["why"]}] and "controller process" in view[0]["why"]


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["python", "c"])
def test_a_panel_session_switching_faults_replays_bit_for_bit(tmp_path, plant):
    """``hydrohil panel`` (lock-step) on the motor with its four faults, on either plant: each switched on and
    off from the panel at a step of its own (the C plant takes the inputs, the sensor row and the command path's
    place the panel derives); the page's state says which are on; the leak's opening as applied follows the
    switches; the recording's replay of the applied inputs and the events gives its states bit for bit; a slot
    the scenario has not is refused naming it."""
    import json
    import urllib.error

    from conftest import PanelProcess
    from hydrohil.hil.circuit import replay_circuit_session
    from hydrohil.simulation.outputs import read_csv_columns
    from test_panel import _record
    f = tmp_path / "motor.toml"                      # (the schedules moved past the session's steps: the
    late = FAULTS.replace("start = ", "start = 4").replace("end = ", "end = 4")   # switches alone act)
    f.write_text((MOTOR / "scenario.toml").read_text().replace('circuit = "circuit.toml"',
                                                                f'circuit = "{MOTOR / "circuit.toml"}"') + late)
    p = PanelProcess(tmp_path / "panel", f, "--lockstep", "--plant", plant)
    try:
        p.wait_steps(200)
        view = p.api("api/state")["view"]
        assert [(x["slot"], x["type"], x["switchable"]) for x in view["faults"]] == [
            (0, "leak", True), (1, "parameter", True), (2, "sensor_offset", True), (3, "controller_silence", True)]
        steer = [{"op": "fault", "slot": 0, "on": True}, {"op": "fault", "slot": 1, "on": True},
                 {"op": "fault", "slot": 2, "on": True}, {"op": "fault", "slot": 3, "on": True},
                 {"op": "fault", "slot": 3, "on": False}, {"op": "fault", "slot": 2, "on": False},
                 {"op": "fault", "slot": 0, "on": False}]
        rec, answers = _record(p, steer, steps_between=300)
        ctl = read_csv_columns(p.session / "controller_log.csv")
        assert p.api("api/state")["switched"] == {"0": False, "1": True, "2": False, "3": False}
        with pytest.raises(urllib.error.HTTPError) as exc:
            p.api("api/steer", {"op": "fault", "slot": 7, "on": True})
        assert exc.value.code == 400 and "0 to 3" in exc.value.read().decode()
        p.api("api/run/stop", {})
    finally:
        p.close()
    session = p.session
    cs = load_circuit_scenario(session / "scenario.toml")
    events = [json.loads(x) for x in (session / "events.jsonl").read_text().splitlines()]
    assert [(e["op"], e["slot"], e["on"]) for e in events] == [(b["op"], b["slot"], b["on"]) for b in steer]
    assert events[1]["inputs"]["relief.cracking_pressure"] == 120e5 and events[2]["sensor"] == 0
    assert events[3]["network"] == 0
    folder = session / "recordings" / rec["name"]
    cmp = json.loads((folder / "comparison.json").read_text())
    assert cmp["identical"] and max(cmp["replay_max_abs_difference"].values()) == 0.0
    log = read_csv_columns(folder / "plant_log.csv")
    ks = log["k"].astype(int)
    k_on, k_off = answers[0]["k"], answers[-1]["k"]
    opening = log["leak_a.opening.applied"]
    assert np.all(opening[(ks > k_on) & (ks <= k_off)] == 1.0) and np.all(opening[ks > k_off] == 0.0)
    rep = replay_circuit_session(cs, session, steps=rec["k1"])
    for i, s in enumerate(cs.layout.states):
        assert np.array_equal(rep[ks, i], log[s]), s
    # what the replay of the inputs does not see: the controller read the speed + 20 rad/s while the sensor's
    # offset was on, and the watchdog tripped 20 steps (10 ms) into the silence, until it was off
    (k2, k3, k4, k5) = (answers[i]["k"] for i in (2, 3, 4, 5))
    w = dict(zip(ks, log["motor.w"]))
    kc = np.rint(ctl["t"] / cs.step).astype(int)
    read = {k: m for k, m in zip(kc, ctl["measured"]) if k in w}
    on = [k for k in read if k2 < k < k5]
    off = [k for k in read if k < k2 - 1 or k > k5 + 1]
    assert len(on) > 500 and all(read[k] == w[k] + 20.0 for k in on)
    assert len(off) > 500 and all(read[k] == w[k] for k in off)
    dog = log["watchdog"]
    assert np.all(dog[(ks > k3 + 21) & (ks <= k4)] == 1) and np.all(dog[ks <= k3 + 19] == 0)
    assert np.all(dog[ks > k4 + 1] == 0)
