"""Faults on circuits (issue #27): a scenario's [[faults]] compiled into its circuit (hydrohil.circuits.faults):
a leak at a node (an orifice to tank opening for a while) and a parameter changed for a while, the values
derived from it following; checked against closed forms computed here, and as a test sequence's actions."""

import math
import re

import numpy as np
import pytest

from conftest import sequence_scenario
from hydrohil.circuits.circuit import CIRCUITS_DIR
from hydrohil.circuits.scenario import load_circuit_scenario
from hydrohil.circuits.run import simulate_circuit
from hydrohil.errors import InputError

RHO = 860.0
CIRCUIT = '''
name = "leaky"
[fluid]
density = 860.0
bulk_modulus = 1.4e9
[components.tank]
type = "tank"
p = "t"
[components.pump]
type = "pump"
inlet = "t"
outlet = "s"
displacement = "10 cm3/rev"
speed = "1200 rpm"
[components.relief]
type = "relief_valve"
p = "s"
t = "t"
cracking_pressure = "100 bar"
rated_flow = "30 l/min"
rated_pressure = "110 bar"
[components.load]
type = "orifice"
a = "s"
b = "t"
area = "0.5 mm2"
[nodes.s]
volume = "1 l"
'''


LIFT = '''
name = "lift"
[components.tank]
type = "tank"
p = "t"
[components.src]
type = "pressure_source"
p = "s"
pressure = "100 bar"
[components.cyl]
type = "cylinder"
a = "s"
b = "t"
bore = "40 mm"
rod = "20 mm"
stroke = "200 mm"
rod_end = "mass"
[components.mass]
type = "load"
mass = "300 kg"
damping = 1e5
spring = 2e6
incline = "90 deg"
x0 = 0.004812187807179585        # (p*A1 - M*g)/k: at rest
'''


def scenario(tmp_path, faults: str, duration: float = 3.0, circuit: str = CIRCUIT):
    (tmp_path / "circuit.toml").write_text(circuit)
    f = tmp_path / "scenario.toml"
    f.write_text(f'circuit = "circuit.toml"\nduration = {duration}\n' + faults)
    return load_circuit_scenario(f)


def run(cs):
    return simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)


def test_a_leak_drains_its_node_through_an_orifice_for_as_long_as_it_lasts(tmp_path):
    """A 12 l/min pump into a load orifice, held by its relief at p = p_cr + (Q - q_load)/K; a 1 mm2 leak to tank
    opens at 1 s and closes at 2 s (1 mm2: less than the relief's flow): while open it takes Cd*A*sqrt(2p/rho) and the relief the rest,
    p = p_cr + (Q - q_load - q_leak)/K (solved here); after it the relief takes Q - q_load again."""
    from scipy.optimize import brentq
    cs = scenario(tmp_path, '[[faults]]\ntype = "leak"\nnode = "s"\narea = "1 mm2"\nstart = 1.0\nend = 2.0\n',
                  duration=3.0)
    r = run(cs)
    t, p = r.column("t"), r.column("s.p")
    q = 10e-6 * 20.0
    k = (30e-3 / 60) / 10e5
    leak = lambda pp: 0.61 * 1e-6 * math.sqrt(2 * pp / RHO)              # noqa: E731
    load = lambda pp: 0.61 * 0.5e-6 * math.sqrt(2 * pp / RHO)            # noqa: E731
    p_leak = brentq(lambda pp: 100e5 + (q - leak(pp) - load(pp)) / k - pp, 90e5, 120e5, xtol=1e-9)
    p_intact = brentq(lambda pp: 100e5 + (q - load(pp)) / k - pp, 90e5, 120e5, xtol=1e-9)
    during, after = np.searchsorted(t, 1.9), np.searchsorted(t, 2.9)
    assert r.column("leak_s.q")[during] == pytest.approx(leak(p_leak), rel=1e-14)   # (measured: 2e-16)
    assert p[during] == pytest.approx(p_leak, rel=1e-14)                  # (measured: 9e-16)
    assert r.column("leak_s.opening")[np.searchsorted(t, 0.999)] == 0.0 and r.column("leak_s.q")[after] == 0.0
    assert p[after] == pytest.approx(p_intact, rel=1e-14)                 # the relief takes the rest again
    first = np.argmax(r.column("leak_s.opening") > 0)
    assert t[first] == 1.0 and t[np.argmax(t >= 2.0)] == 2.0 and r.column("leak_s.opening")[first + 1999] == 1.0
    assert r.column("leak_s.opening")[first + 2000] == 0.0               # start <= k*h < end: 2000 steps


def test_a_parameter_fault_changes_it_for_a_while_and_what_derives_from_it_follows(tmp_path):
    """The relief's cracking pressure lowered to 80 bar over [1, 2) s moves the supply to the balance with
    K = Q_r/(p_r - p_cr) following (its flow gain, derived), back after; the load's mass doubled from 1 s (its
    weight, derived, follows: the rod points up) moves the spring's equilibrium by dW/k (closed forms)."""
    from scipy.optimize import brentq
    cs = scenario(tmp_path, '[[faults]]\ntype = "parameter"\ntarget = "relief.cracking_pressure"\n'
                            'value = "80 bar"\nstart = 1.0\nend = 2.0\n', duration=3.0)
    assert set(cs.circuit.inputs) == {"relief.cracking_pressure", "relief.flow_gain"}
    r = run(cs)
    t, p = r.column("t"), r.column("s.p")
    q = 10e-6 * 20.0
    load = lambda pp: 0.61 * 0.5e-6 * math.sqrt(2 * pp / RHO)            # noqa: E731
    k80, k100 = (30e-3 / 60) / 30e5, (30e-3 / 60) / 10e5
    p80 = brentq(lambda pp: 80e5 + (q - load(pp)) / k80 - pp, 70e5, 120e5, xtol=1e-9)
    p100 = brentq(lambda pp: 100e5 + (q - load(pp)) / k100 - pp, 90e5, 120e5, xtol=1e-9)
    assert p[np.searchsorted(t, 1.9)] == pytest.approx(p80, rel=1e-14)   # (measured: 2e-15)
    assert p[np.searchsorted(t, 2.9)] == pytest.approx(p100, rel=1e-14)  # (measured: 9e-16)
    assert r.column("relief.flow_gain")[np.searchsorted(t, 1.5)] == pytest.approx(k80, rel=1e-15)
    assert r.column("relief.flow_gain")[np.searchsorted(t, 2.5)] == pytest.approx(k100, rel=1e-15)
    cs = scenario(tmp_path, '[[faults]]\ntype = "parameter"\ntarget = "mass.mass"\nvalue = "600 kg"\nstart = 1.0\n',
                  circuit=LIFT)
    assert set(cs.circuit.inputs) == {"mass.mass", "mass.weight"}
    r = run(cs)
    t, x = r.column("t"), r.column("mass.x")
    assert x[np.searchsorted(t, 0.99)] == pytest.approx(0.004812187807179585, rel=1e-14)   # at rest until then
    dx = x[np.searchsorted(t, 0.99)] - x[-1]
    assert dx == pytest.approx(300 * 9.80665 / 2e6, rel=1e-13)           # (measured: 3e-14)


def test_a_fault_on_a_signal_replaces_its_drive_and_the_pump_trips(tmp_path):
    """pump.speed (a signal of a pump, given as a constant) to 0 over [1, 2): no flow, the relief closes and the
    load orifice drains the node; after it the pump turns at its 1200 rpm again and the relief opens."""
    cs = scenario(tmp_path, '[[faults]]\ntype = "parameter"\ntarget = "pump.speed"\nvalue = 0.0\nstart = 1.0\n'
                            'end = 2.0\n')
    r = run(cs)
    t = r.column("t")
    assert r.column("pump.q")[np.searchsorted(t, 1.5)] == 0.0 and r.column("pump.speed")[np.searchsorted(t, 1.5)] == 0
    assert r.column("relief.mode")[np.searchsorted(t, 1.9)] == 0 and r.column("s.p")[np.searchsorted(t, 1.9)] < 1e5
    assert r.column("pump.speed")[-1] == 20.0 and r.column("relief.mode")[-1] == 1


@pytest.mark.parametrize("fault, key, message", [
    ('type = "hose_burst"\nline = 1\nstart = 1.0', "faults[0].type", "a circuit's faults are leak, parameter, sensor_stuck"),
    ('type = "sensor_stuck"\nstart = 1.0', "faults[0].type", "acts on the closed loop's sensors"),
    ('type = "leak"\nnode = "s"\narea = "1 mm2"\nstart = 1.0\nline = 2', "faults[0].line", "unknown key"),
    ('type = "leak"\nnode = "nowhere"\narea = "1 mm2"\nstart = 1.0', "faults[0].node", "one of the circuit's"),
    ('type = "leak"\nnode = "s"\nstart = 1.0', "faults[0].area", "required: the leak's area"),
    ('type = "leak"\nnode = "s"\narea = "1 mm2"\nstart = 1.0\norifice = "pump"', "faults[0].orifice",
     "no component has"),
    ('type = "leak"\nnode = "s"\narea = "3 bar"\nstart = 1.0', "faults[0].area", "m2 is wanted"),
    ('type = "parameter"\ntarget = "relief.crackin"\nvalue = 1\nstart = 1', "faults[0].target", "component.key"),
    ('type = "parameter"\ntarget = "mass.x0"\nvalue = 1\nstart = 1', "faults[0].target", "fixed when the run starts"),
    ('type = "parameter"\ntarget = "relief.cracking_pressure"\nvalue = "200 bar"\nstart = 1', "faults",
     "relief at 1 s, during a fault: rated_pressure (110 bar) must be above cracking_pressure (200 bar)"),
    ('type = "parameter"\ntarget = "mass.mass"\nvalue = "2 bar"\nstart = 1', "faults[0].value", "kg is wanted"),
    ('type = "parameter"\ntarget = "mass.mass"\nvalue = -5\nstart = 1', "faults[0].value", "must be > 0"),
    ('type = "parameter"\ntarget = "mass.mass"\nvalue = 600\nstart = 2\nend = 1', "faults[0].end",
     "must be after start"),
])
def test_a_circuit_fault_error_names_the_file_and_the_key(tmp_path, fault, key, message):
    with pytest.raises(InputError, match=re.escape(message)) as e:
        scenario(tmp_path, f"[[faults]]\n{fault}\n", circuit=LIFT if "mass." in fault else CIRCUIT)
    assert e.value.key == key, str(e.value)
    assert str(e.value).startswith(str(tmp_path))


def test_the_counterbalance_example_bursts_its_hose_by_a_fault(tmp_path):
    """examples/circuits/counterbalance_hose_burst: the burst is a leak fault of its scenario (the orifice
    "burst" added to the circuit, its opening 0 -> 1 at 1.5 s); the circuit alone has no burst."""
    from hydrohil.circuits.circuit import load_circuit
    assert "burst" not in load_circuit("counterbalance_hose_burst").components
    cs = load_circuit_scenario(CIRCUITS_DIR / "counterbalance_hose_burst" / "scenario.toml")
    assert cs.circuit.components["burst"].type.name == "orifice" and cs.faults[0]["type"] == "leak"
    r = run(cs)
    t = r.column("t")
    assert r.column("burst.q")[np.searchsorted(t, 1.4)] == 0.0 and r.column("burst.q")[np.searchsorted(t, 1.6)] > 1e-4


def test_a_sequence_injects_circuit_faults_as_actions(tmp_path):
    """A circuit sequence's fault actions (a leak, a parameter, the sensor's dropout) become the compiled
    scenario's [[faults]] (at/until -> start/end) and act in the run: the motor's line leaks at 2 s and its PI
    loop opens the valve further; its speed reading dropping out, it opens the valve fully."""
    from hydrohil.sequences.runner import run_sequence
    scen = CIRCUITS_DIR / "motor_speed" / "scenario.toml"
    p = tmp_path / "seq.toml"
    p.write_text(f'scenario = "{scen}"\nduration = 3.0\n'
                 '[[actions]]\nname = "leak"\nat = 2.0\ntype = "leak"\nnode = "a"\narea = "0.5 mm2"\n'
                 '[[actions]]\nname = "stiffer"\nat = 2.5\nuntil = 2.8\ntype = "parameter"\n'
                 'target = "motor.damping"\nvalue = 0.05\n'
                 '[[actions]]\nname = "blind"\nat = 2.9\nuntil = 2.95\ntype = "sensor_dropout"\n'
                 '[[expect]]\nname = "the valve opens further within 50 ms of the leak"\ntype = "reaction"\n'
                 'after = "leak"\nwithin = 0.05\nsignal = "valve.command"\nabove = 0.31\n'
                 '[[expect]]\nname = "the leak takes oil"\ntype = "bounds"\nafter = 2.1\nuntil = "blind"\n'
                 'signal = "leak_a.q"\nmin = 1e-5\n'
                 '[[expect]]\nname = "blind, the loop opens the valve fully"\ntype = "reaction"\nafter = "blind"\n'
                 'within = 0.04\nsignal = "valve.command"\nabove = 0.99\n')
    res = run_sequence(p, tmp_path / "out")
    assert res.passed, [o.message for o in res.outcomes]
    compiled = sequence_scenario(tmp_path / "out")
    assert [f["type"] for f in compiled["faults"]] == ["leak", "parameter", "sensor_dropout"]
    assert compiled["faults"][1]["start"] == 2.5 and compiled["faults"][1]["end"] == 2.8
    bad = tmp_path / "bad.toml"
    bad.write_text(f'scenario = "{scen}"\n[[actions]]\nat = 1.0\ntype = "leak"\nnode = "a"\narea = 1e-6\nline = 1\n'
                   '[[expect]]\ntype = "bounds"\nsignal = "a.p"\nmax = 1e8\n')
    from hydrohil.sequences.sequence import load_sequence
    with pytest.raises(InputError, match="unknown key 'line'") as e:
        load_sequence(bad)
    assert e.value.key.startswith("actions[0]")


MOTOR = CIRCUITS_DIR / "motor_speed" / "scenario.toml"


def motor(tmp_path, faults: str, name="m.toml"):
    f = tmp_path / name
    text = MOTOR.read_text().replace('circuit = "circuit.toml"', f'circuit = "{MOTOR.parent / "circuit.toml"}"')
    f.write_text(text + faults)
    return load_circuit_scenario(f)


def test_sensor_faults_act_where_the_loop_reads_its_signal(tmp_path):
    """The motor's PI speed loop (1000 rpm from 0.2 s, 600 rpm from 1.5 s): an offset of +20 rad/s on its speed
    reading from 0.6 s makes it hold the true speed 20 rad/s below the reference (a PI has no steady error on
    what it reads); a reading stuck over [2.0, 2.5) s keeps the value of its first step; a dropout reads 0; an
    added noise has the standard deviation it was given. The log's motor.w.sensed is what the loop read."""
    cs = motor(tmp_path, '[[faults]]\ntype = "sensor_offset"\noffset = 20.0\nstart = 0.6\nend = 2.0\n'
                         '[[faults]]\ntype = "sensor_stuck"\nstart = 2.0\nend = 2.5\n'
                         '[[faults]]\ntype = "sensor_dropout"\nstart = 3.5\nend = 3.51\n'
                         '[[faults]]\ntype = "sensor_noise"\nstd = 2.0\nstart = 4.0\n')
    assert [f[0] for f in cs.loop.sensor_faults] == ["sensor_offset", "sensor_stuck", "sensor_dropout",
                                                     "sensor_noise"]
    r = run(cs)
    t, w, seen = r.column("t"), r.column("motor.w"), r.column("motor.w.sensed")
    ref_1000 = 1000 * 2 * math.pi / 60
    k = np.searchsorted(t, 1.45)
    assert seen[k] - w[k] == 20.0 and w[k] == pytest.approx(ref_1000 - 20.0, abs=0.05)   # (measured: 0.018)
    k1, k2 = np.searchsorted(t, 2.0), np.searchsorted(t, 2.5)
    assert np.all(seen[k1:k2] == seen[k1]) and seen[k1] == w[k1] and np.ptp(w[k1:k2]) > 1.0
    assert seen[k2] == w[k2]
    drop = (t >= 3.5) & (t < 3.51)
    assert np.all(seen[drop] == 0.0) and np.all(seen[(t >= 3.51) & (t < 4.0)] == w[(t >= 3.51) & (t < 4.0)])
    noise = (seen - w)[t >= 4.0]
    assert np.std(noise) == pytest.approx(2.0, rel=0.1) and abs(np.mean(noise)) < 0.2   # (1001 samples: 2.016,
                                                                                     # 0.068; seeded)
    again = run(cs)                                      # the same draws: the seed's
    assert np.array_equal(again.column("motor.w.sensed"), seen)


@pytest.mark.parametrize("example, target, value, state, nominal", [
    ("ferreira2004", "cyl.stroke", "0.15", "cyl.x", (-0.18, 0.36)),
    ("lift_platform", "valve.x_max", '"1 mm"', "valve.x", (-0.015, 0.015)),
    ("lift_platform", "left.stroke", '"0.4 m"', "deck.x", (-0.5, 1.0))])
def test_a_fault_on_a_parameter_a_physical_range_is_of_keeps_the_files_range(tmp_path, example, target, value,
                                                                             state, nominal):
    """A parameter fault on a stroke or a spool's travel drives that parameter as a signal; the physical range
    (the run's stop, library Emit.bounds) stays the file's (its nominal value, P): the circuit compiles, runs
    through the fault and circuit show's range is the file's."""
    from hydrohil.circuits.run import state_bounds
    src = CIRCUITS_DIR / example
    f = tmp_path / "s.toml"
    f.write_text((src / "scenario.toml").read_text().replace('circuit = "circuit.toml"',
                                                              f'circuit = "{src / "circuit.toml"}"')
                 .replace("duration = ", "duration = 1.0\n# was ", 1)
                 + f'\n[[faults]]\ntype = "parameter"\ntarget = "{target}"\nvalue = {value}\nstart = 0.5\n')
    cs = load_circuit_scenario(f)
    assert target in cs.circuit.inputs
    r = run(cs)
    assert r.column("t")[-1] == pytest.approx(1.0)
    lo, hi = state_bounds(cs.compiled, cs.layout.values())
    i = cs.layout.states.index(state)
    assert (lo[i], hi[i]) == pytest.approx(nominal, rel=1e-15)


def test_a_parameter_faults_schedule_is_not_steered_and_errors_name_the_fault(tmp_path):
    """The live panel's view of a scenario with a parameter fault whose derived value follows it (a load's mass,
    its weight): built, the fault's inputs not offered to hold, the component's parameters not offered to set,
    and such events refused by name; a fault on a drive whose times carry units; a fault on a coupled
    cylinder's load key named as the load's."""
    from hydrohil.panel.views import circuit_view
    from hydrohil.simulation.steering import parse_event
    src = CIRCUITS_DIR / "lift_platform"
    f = tmp_path / "lp.toml"
    text = (src / "scenario.toml").read_text().replace('circuit = "circuit.toml"', f'circuit = "{src / "circuit.toml"}"')
    f.write_text(text + '[[faults]]\ntype = "parameter"\ntarget = "deck.mass"\nvalue = "1 t"\nstart = 1.0\n')
    cs = load_circuit_scenario(f)
    assert {"deck.mass", "deck.weight"} <= set(cs.circuit.inputs)
    view = circuit_view(cs)
    assert {i["name"] for i in view["inputs"]} == {"deck.force", "valve.command"}   # (the loop's: shown, not held)
    assert not any(p["name"].startswith("deck.") or p["name"] == "left.mass" for p in view["params"])
    for body, what in (({"op": "input", "name": "deck.mass", "value": 500.0}, "parameter fault"),
                       ({"op": "set", "name": "deck.incline", "value": 45.0}, "derived values follow")):
        with pytest.raises(InputError, match=what) as e:
            parse_event(body, "plant", circuit=cs)
        assert e.value.key == body["name"]
    f.write_text(text + '[inputs]\n"deck.force" = { t = [0, "1 s"], value = [0, "1 kN"] }\n'
                        '[[faults]]\ntype = "parameter"\ntarget = "deck.force"\nvalue = "2 kN"\nstart = "1.5 s"\n'
                        'end = 2.0\n')
    cs = load_circuit_scenario(f)
    assert list(cs.circuit.inputs["deck.force"][1]) == [0.0, 1000.0, 2000.0, 1000.0]
    f.write_text(text + '[[faults]]\ntype = "parameter"\ntarget = "left.mass"\nvalue = "1 t"\nstart = 1.0\n')
    with pytest.raises(InputError, match="left's rod drives the load 'deck': its mass is the load's "
                                         "\\(target = \"deck.mass\"\\)") as e:
        load_circuit_scenario(f)
    assert e.value.key == "faults[0].target"
