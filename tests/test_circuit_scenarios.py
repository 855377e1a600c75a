"""Circuits (issue #27): the continuous reference generated from a circuit's description (against closed forms
computed here, and against the fixed-step run), scenarios that name their circuit, ``--set component.key=value``,
``hydrohil simulate``/``maxstep`` on a circuit scenario as a user types them."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from hydrohil.circuits.accuracy import LIMIT_POSITION, LIMIT_PRESSURE, LIMIT_SPEED, compare_to_reference
from hydrohil.circuits.circuit import CIRCUITS_DIR, circuit_from_dict
from hydrohil.circuits.run import simulate_circuit
from hydrohil.circuits.scenario import load_circuit_scenario
from hydrohil.errors import InputError

EXAMPLES = CIRCUITS_DIR.parent

FLUID = {"density": 860.0, "bulk_modulus": 1.4e9, "viscosity": 46e-6}
STOP_WN = 1e4          # rad/s: the reference's end stop (core/hc_end_stops.h HC_REF_STOP_WN)


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "hydrohil.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd)


def test_the_reference_of_a_cylinder_against_its_end_stop_and_relief_closed_forms():
    """A pump of constant flow into a 50/28 cylinder: the continuous reference (no modes) extends at Q/A1, then
    rests on its stiff stop past the stroke by F/(m*wn^2) (F the net force of the relief's pressure p_cr + Q/K
    on A1), the relief passing all of Q: closed forms computed here. The fixed-step hybrid model holds the
    piston at the stroke exactly."""
    q, bore, rod, stroke, m = 10e-3 / 60, 0.05, 0.028, 0.2, 50.0
    c = circuit_from_dict({"fluid": FLUID, "components": {
        "tank": {"type": "tank", "p": "t"},
        "pump": {"type": "pump", "inlet": "t", "outlet": "a", "displacement": q / 25.0, "speed": 25.0},
        "relief": {"type": "relief_valve", "p": "a", "t": "t", "cracking_pressure": "100 bar",
                   "rated_flow": "20 l/min", "rated_pressure": "110 bar"},
        "cyl": {"type": "cylinder", "a": "a", "b": "b", "bore": bore, "rod": rod, "stroke": stroke, "mass": m,
                "damping": 2000.0, "dead_volume_a": "0.2 l", "dead_volume_b": "0.2 l"},
        "out": {"type": "orifice", "a": "b", "b": "t", "area": "4 mm2"}}}, "test.toml")
    ref = simulate_circuit(c, 3.0, rest=False, method="reference")
    a1 = math.pi * bore ** 2 / 4
    t, x, v = ref.column("t"), ref.column("cyl.x"), ref.column("cyl.v")
    # (LSODA at rtol 1e-8: its figures depend on the BLAS kernels of the CPU's SciPy wheel picks; measured
    # 6e-14 (OpenBLAS's Haswell kernels, AMD EPYC) and 1.4e-10 (its SkylakeX kernels, an Intel Xeon))
    assert v[np.searchsorted(t, 1.0)] == pytest.approx(q / a1, rel=5e-10)
    p_end = 100e5 + q / ((20e-3 / 60) / 10e5)
    assert ref.column("a.p")[-1] == pytest.approx(p_end, rel=5e-14)               # (measured: 1.6e-14)
    assert ref.column("relief.q")[-1] == pytest.approx(q, rel=1e-14)              # (measured: 4e-15)
    penetration = p_end * a1 / (m * STOP_WN ** 2)                                  # 4.1 um
    assert x[-1] - stroke == pytest.approx(penetration, rel=2e-10)                # (measured: 6.5e-11, 7.8e-11)
    hybrid = simulate_circuit(c, 3.0, rest=False)
    assert hybrid.column("cyl.x")[-1] == stroke
    assert compare_to_reference(hybrid, ref).worst_position < 3 * penetration    # (measured: 4.9 um)


@pytest.mark.parametrize("name, position, pressure, speed, largest", [
    # measured at 0.5 ms: two_cylinders 1.0e-7 m, 2.1e-5, 1.3e-4; pump_relief_accumulator -, 4.7e-7, -;
    # motor_speed (closed loop) 3.9e-8 m (its spool), 1.0e-4, 5.7e-5; counterbalance_hose_burst 8.5e-6 m,
    # 2.7e-4, 6.6e-4 (3.2e-6 m without hc_node.h's coupled-node rule, which slows its hose nodes); largest stable steps 4.6, 16 (every step tried up to the search's 20 ms: its relief and
    # hose nodes, stiff beyond 7.7 ms, slowed as the core's chambers), 3.8, 1.5 ms
    ("two_cylinders", 3e-7, 6e-5, 4e-4, 4.5e-3),
    ("pump_relief_accumulator", 0.0, 1.5e-6, 0.0, 16e-3),
    ("motor_speed", 1.2e-7, 3e-4, 1.7e-4, 3.8e-3),
    ("counterbalance_hose_burst", 2.5e-5, 8e-4, 2e-3, 1.5e-3),
    # the paper's rig and its servo valve and LuGre cylinder on a pump supply (closed loops; their friction's
    # and stops' events located in the step, the valve's 0.76 ms input delay): 4.4e-6 m, 1.1e-3, 2.8e-3, 3.7 ms;
    # 3.4e-6 m, 7.0e-4, 8.4e-4, 3.7 ms
    ("ferreira2004", 1.4e-5, 3.3e-3, 8.5e-3, 3.7e-3),
    ("servo_supply", 1e-5, 2.1e-3, 2.6e-3, 3.7e-3),
    # two cylinders coupled to one deck (a load, rod_end) under a P loop, a payload ramped on (a linear drive):
    # 1.6e-6 m, 4.6e-5, 4.1e-4, 3.2 ms
    ("lift_platform", 5e-6, 1.4e-4, 1.2e-3, 3.2e-3),
])
def test_each_example_at_half_a_millisecond_against_its_reference_and_its_largest_step(name, position, pressure,
                                                                                       speed, largest):
    """The issue's "must hold": RK3 at 0.5 ms within 0.1 mm RMS in every position, 3 % of the highest pressure in
    every pressure, 2 % in every speed of the circuit's continuous reference; the largest stable step >= 1 ms.
    The limits here are about 3x what the code achieves."""
    from hydrohil.maxstep import circuit_max_stable_step
    cs = load_circuit_scenario(CIRCUITS_DIR / name / "scenario.toml")
    ms = circuit_max_stable_step(cs, "rk3")
    acc = ms["accuracy_at_step"]
    assert acc["holds"] and acc["worst_position_m"] <= LIMIT_POSITION
    assert acc["worst_pressure_relative"] <= LIMIT_PRESSURE and acc["worst_speed_relative"] <= LIMIT_SPEED
    assert acc["worst_position_m"] <= position and acc["worst_pressure_relative"] <= pressure
    assert acc["worst_speed_relative"] <= speed
    assert ms["max_stable_step"] >= max(1e-3, 0.8 * largest)       # the issue's 1 ms, and near what it was
    if ms["first_unstable_step"] is None:       # stable at every doubling up to the search's 20 ms ceiling
        assert largest == ms["max_stable_step"] and ms["trials"][-1]["step"] == largest
        return
    assert ms["first_unstable_step"] / ms["max_stable_step"] <= 1.05
    failed = [tr for tr in ms["trials"] if not tr["stable"]]
    assert failed and all(tr["step"] > ms["max_stable_step"] for tr in failed)


def test_a_scenario_names_its_circuit_and_sets_its_values(tmp_path):
    """[set] and --set with catalogue units on top of the circuit's values; a signal set is a constant drive;
    [inputs] replaces a drive; the circuit named by a path beside the scenario or by a built-in name."""
    f = tmp_path / "s.toml"
    f.write_text('circuit = "two_cylinders"\nduration = 1.0\n[solver]\nstep = 0.001\n'
                 '[set]\n"cyl1.mass" = "300 kg"\n"fluid.bulk_modulus" = "12000 bar"\n'
                 '[inputs]\n"valve2.command" = 0.25\n')
    cs = load_circuit_scenario(f, sets={"cyl2.mass": "0.25 t", "valve1.command": -0.5})
    c = cs.circuit
    assert c.components["cyl1"].values["mass"] == 300.0 and c.components["cyl2"].values["mass"] == 250.0
    assert c.fluid["bulk_modulus"] == 12000e5
    assert c.inputs["valve1.command"] == -0.5 and c.inputs["valve2.command"] == 0.25
    assert (cs.duration, cs.step, cs.method) == (1.0, 0.001, "rk3")
    for sets, key, message in [
        ({"cyl3.mass": 1.0}, "cyl3.mass", "no component 'cyl3'"),
        ({"cyl1.a": "x"}, "cyl1.a", "is its port"),
        ({"cyl1.mass": "3 bar"}, "components.cyl1.mass", "kg is wanted"),
        ({"cyl1.masss": 3.0}, "components.cyl1.masss", "not a parameter of a cylinder"),
        ({"mass": 3.0}, "mass", "expected component.key"),
    ]:
        with pytest.raises(InputError, match=message) as e:
            load_circuit_scenario(f, sets=sets)
        assert e.value.key == key
    f.write_text('circuit = "nowhere"\n')
    with pytest.raises(InputError, match="no circuit 'nowhere'.*built-in: .*two_cylinders"):
        load_circuit_scenario(f)
    f.write_text('circuit = "two_cylinders"\n[solver]\nmethod = "rk5"\n')
    with pytest.raises(InputError, match="one of euler, heun, rk3, rk4, reference") as e:
        load_circuit_scenario(f)
    assert e.value.key == "solver.method"
    loop = ('circuit = "motor_speed"\n[controller]\ntype = "pi"\nmeasure = "motor.w"\ncommand = "valve.command"\n'
            'kp = 0.008\nki = 0.08\n[reference]\nt = [0, 1]\nvalue = ["0 rpm", "500 rpm"]\n')
    f.write_text(loop)
    lp = load_circuit_scenario(f).loop
    assert lp.reference[1][1] == pytest.approx(500 * 2 * math.pi / 60, rel=1e-15)
    for old, new, key, message in [
        ('measure = "motor.w"', 'measure = "motor.speed"', "controller.measure", "not a signal of circuit"),
        ('command = "valve.command"', 'command = "pump.speed"', "controller.command", "not an input of circuit"),
        ('type = "pi"', 'type = "lqr"', "controller.type", "p, pi, pid, p_ff, state_feedback, python"),
        ('type = "pi"', 'type = "state_feedback"', "controller.load_pressure",
         "cylinders of circuit 'motor_speed': none"),
        ("ki = 0.08", "ki = -1", "controller.ki", "greater than 0"),
        ('"500 rpm"', '"500 bar"', "reference", "rad/s is wanted"),
        ("[reference]\nt = [0, 1]\nvalue = [\"0 rpm\", \"500 rpm\"]\n", "", "reference", r"both \[controller\]"),
    ]:
        f.write_text(loop.replace(old, new))
        with pytest.raises(InputError, match=message) as e:
            load_circuit_scenario(f)
        assert e.value.key == key, (old, e.value.key)
    f.write_text(loop)
    with pytest.raises(InputError, match="closed loop's command") as e:
        load_circuit_scenario(f, sets={"valve.command": 0.5})
    assert e.value.key == "valve.command"
    f.write_text(loop.replace("[controller]", "duration = 1e-5\n[controller]"))
    with pytest.raises(InputError, match="at least one step") as e:
        load_circuit_scenario(f)
    assert e.value.key == "duration"
    f.write_text(loop.replace('kp = 0.008', 'kp = 0.008\nu_min = -2.0'))
    with pytest.raises(InputError, match=r"valve.command's range \[-1, 1\]"):
        load_circuit_scenario(f)
    f.write_text(loop.replace('kp = 0.008', 'kp = 0.008\nsensor_resolution = "10 rpm"\nsensor_max = "700 rpm"\n'
                              'sensor_noise = "2 rpm"\nsensor_seed = 7'))
    lp = load_circuit_scenario(f).loop
    assert lp.sensor == pytest.approx((10 * 2 * math.pi / 60, -1e300, 700 * 2 * math.pi / 60, 2 * 2 * math.pi / 60),
                                      rel=1e-15) and lp.seed == 7
    f.write_text(loop.replace('kp = 0.008', 'kp = 0.008\nsensor_resolution = "1 bar"'))
    with pytest.raises(InputError, match="the sensor of motor.w") as e:
        load_circuit_scenario(f)
    assert e.value.key == "controller.sensor_*"
    f.write_text(loop.replace('kp = 0.008', 'kp = -0.008'))
    with pytest.raises(InputError, match='says action = "reverse"'):
        load_circuit_scenario(f)
    (tmp_path / "sub").mkdir()
    (tmp_path / "circuit.toml").write_text((CIRCUITS_DIR / "motor_speed" / "circuit.toml").read_text())
    sub = tmp_path / "sub" / "s.toml"
    sub.write_text('circuit = "circuit.toml"\n')              # not beside it: the folder above does not count
    with pytest.raises(InputError, match="no circuit 'circuit.toml'"):
        load_circuit_scenario(sub)
    f.write_text('circuit = "two_cylinders"\nparams = "ferreira2004"\n')
    with pytest.raises(InputError, match="unknown key") as e:
        load_circuit_scenario(f)
    assert e.value.key == "params"
    # a misspelt key named with the nearest one: the scenario's, the solver's, the loop's (not "kp missing")
    for text, key, near in (('circuit = "two_cylinders"\nduraton = 2\n', "duraton", "'duration'"),
                            ('circuit = "two_cylinders"\n[solver]\nsteps = 1e-3\n', "solver.steps", "'solver.step'"),
                            (loop.replace("kp = 0.008", "kpp = 0.008"), "controller.kpp", "'controller.kp'")):
        f.write_text(text)
        with pytest.raises(InputError, match=f"unknown key '{key}' \\(did you mean {near}\\?\\)") as e:
            load_circuit_scenario(f)
        assert e.value.key == key


def test_simulate_and_maxstep_on_a_circuit_scenario_as_a_user_types_them(tmp_path):
    """`hydrohil simulate` writes a column per signal named <component>.<variable> with its SI unit, the
    summary and the plot, for the fixed step and for the continuous reference (which agree); `--set` takes a
    value with its unit; a mistake exits 2 naming the key and writes nothing; `maxstep` prints JSON."""
    import csv
    scen = CIRCUITS_DIR / "two_cylinders" / "scenario.toml"
    runs = {}
    for solver in ("rk3", "reference"):
        out = tmp_path / solver
        r = cli("simulate", scen, "--out", out, "--solver", solver, "--set", "cyl1.mass=300 kg")
        assert r.returncode == 0, r.stderr
        said = "of the continuous reference (LSODA)" if solver == "reference" else "with rk3"
        assert f"{said} on circuit two_cylinders" in r.stdout
        with open(out / "log.csv") as fh:
            rows = list(csv.reader(fh))
        head = rows[0]
        assert head[:3] == ["t [s]", "tank.p [Pa]", "supply.p [Pa]"]
        assert "cyl1.x [m]" in head and "cyl2.v [m/s]" in head and "relief.mode [-]" in head
        assert rows[1][head.index("relief.mode [-]")] in ("closed", "open")
        runs[solver] = np.array([[float(v) for v in row[:head.index("relief.mode [-]")]] for row in rows[1:]])
        s = json.loads((out / "summary.json").read_text())
        assert s["sets"] == {"cyl1.mass": "300 kg"} and s["steps"] == 15000 and s["solver"] == solver
        assert (out / "plot.png").stat().st_size > 20000
    x = head.index("cyl1.x [m]")
    assert np.sqrt(np.mean((runs["rk3"][:, x] - runs["reference"][:, x]) ** 2)) < 3e-7
    bad = cli("simulate", scen, "--out", tmp_path / "bad", "--set", "cyl1.mass=3 bar")
    assert bad.returncode == 2 and "components.cyl1.mass" in bad.stderr and "kg is wanted" in bad.stderr
    assert not (tmp_path / "bad").exists()
    ms = cli("maxstep", scen, "--duration", "3")
    assert ms.returncode == 0, ms.stderr
    res = json.loads(ms.stdout)
    assert res["circuit"] == "two_cylinders" and res["max_stable_step"] >= 1e-3
    said = f"stable up to {res['max_stable_step'] * 1e3:.3g} ms"      # both answers in words, on stderr
    assert said in ms.stderr and said in res["verdict"] and "at the scenario's step 0.5 ms the accuracy limits" in \
        ms.stderr and res["verdict"].endswith(" hold") == res["accuracy_at_step"]["holds"]
    assert set(res["accuracy_at_step"]["rms_pressure_pa"]) == {"tank.p", "supply.p", "a1.p", "b1.p", "a2.p",
                                                                "b2.p"}


def test_pi_speed_control_of_a_motor_rejects_its_load():
    """examples/circuits/motor_speed: the core's PI law closes the loop on motor.w inside the generated loop;
    it reaches 1000 rpm within 2 % in 0.35 s without overshooting it by more than 3 % (measured: 0.12 s, 1 %),
    then holds 600 rpm under a 10 N.m load with no steady error (integral action); at the end the motor's
    pressure difference is the one its torque balance needs, (T + c*w)*2 pi/(eta*D), and its flow
    D*w/(2 pi) + Cl*dp: closed forms computed here."""
    cs = load_circuit_scenario(CIRCUITS_DIR / "motor_speed" / "scenario.toml")
    res = simulate_circuit(cs.circuit, cs.duration, loop=cs.loop)
    t, w = res.column("t"), res.column("motor.w")
    rpm = w * 60 / (2 * math.pi)
    assert np.array_equal(res.column("motor.w.reference")[t >= 1.5] * 60 / (2 * math.pi), np.full((t >= 1.5).sum(),
                                                                                                   600.0))
    up = (t > 0.2) & (t < 1.5)
    assert rpm[up].max() < 1030
    late = up & (np.abs(rpm - 1000) > 20)
    assert t[late].max() - 0.2 < 0.35
    assert abs(rpm[-1] - 600) < 0.01 and abs(rpm[t < 3.0][-1] - 600) < 0.02    # (measured: 0.0035, 0.0054)
    assert 400 < rpm[t > 3].min() < 590                          # the load's dip (measured: 503 rpm)
    u = res.column("valve.command")
    assert u.min() >= -1 and u.max() <= 1 and np.ptp(u[t > 4.0]) < 1e-3
    c = cs.circuit.components["motor"].values
    dp = res.column("a.p")[-1] - res.column("b.p")[-1]
    need = (10.0 + c["damping"] * w[-1]) * 2 * math.pi / (c["efficiency"] * c["displacement"])
    assert dp == pytest.approx(need, rel=1.5e-5)                  # (measured: 4.7e-6: still settling)
    q = c["displacement"] * w[-1] / (2 * math.pi) + c["leakage"] * dp
    assert res.column("motor.q")[-1] == pytest.approx(q, rel=1e-12)


def test_the_counterbalance_valve_holds_the_load_when_the_hose_bursts():
    """examples/circuits/counterbalance_hose_burst: lifting 1000 kg, the A hose bursts at 1.5 s; the line's
    pressure falls to the tank's, the check closes and the load stops within a few mm and stays (it does not
    creep down in 2.5 s); the cap side holds the load's pressure from the force balance, (W + p_rod*A2)/A1."""
    cs = load_circuit_scenario(CIRCUITS_DIR / "counterbalance_hose_burst" / "scenario.toml")
    res = simulate_circuit(cs.circuit, cs.duration, loop=cs.loop)
    t, x = res.column("t"), res.column("cyl.x")
    v = cs.circuit.components["cyl"].values
    assert x[0] == 0.1 and abs(res.column("cyl.net_force")[0]) < 1e-6        # held at rest by the force balance
    at_burst = x[np.searchsorted(t, 1.5)]
    assert at_burst > 0.14                                               # it was lifting (measured: 0.1505 m)
    assert abs(x[-1] - at_burst) < 3e-3                                 # stopped (measured: 0.8 mm)
    assert np.ptp(x[t > 3.0]) < 1e-7                                     # and held (measured: 2.5e-8 m)
    assert res.column("line_a.p")[-1] < 50.0                             # the burst line at the tank's (16 Pa)
    p_cap = (v["mass"] * 9.80665 + res.column("rod.p")[-1] * v["area_b"]) / v["area_a"]
    assert res.column("cap.p")[-1] == pytest.approx(p_cap, rel=1e-9)
    assert res.column("cb.mode")[-1] == 0                                # closed
    intact = simulate_circuit(cs.circuit, cs.duration, inputs={"burst.opening": 0.0})
    assert intact.column("cyl.x")[np.searchsorted(t, 2.5)] > x[-1] + 0.04   # without the burst it kept lifting


def test_a_loop_measures_under_the_command_it_applied_and_stays_in_the_commands_range(tmp_path):
    """A P loop on a signal its command moves directly (an orifice's flow on its opening): at each step the
    controller reads the flow under the opening it applied the step before (at step 0: the one the run starts
    with), so the logged command is kp*(reference - the logged flow of the step before); an opening asked
    beyond [0, 1] stays in the orifice's range (u_min/u_max default to the command parameter's)."""
    from hydrohil.circuits.circuit import circuit_from_dict
    from hydrohil.circuits.run import Loop, simulate_circuit
    from hydrohil.control import PControllerCfg
    c = circuit_from_dict({"fluid": FLUID, "components": {
        "s": {"type": "pressure_source", "p": "s", "pressure": "100 bar"}, "t": {"type": "tank", "p": "t"},
        "load": {"type": "orifice", "a": "s", "b": "t", "area": "2 mm2"}},
        "inputs": {"load.opening": 0.1}}, "test.toml")
    kp, ref = 1000.0, 2e-4                                   # per m3/s; 12 l/min
    loop = Loop(PControllerCfg(type="p", kp=kp), "load.q", "load.opening", (np.array([0.0]), np.array([ref])),
                limits=(0.0, 1.0))
    r = simulate_circuit(c, 0.01, loop=loop)
    q, u = r.column("load.q"), r.column("load.opening")
    assert u[0] == pytest.approx(kp * (ref - q0()), rel=1e-12)            # measured under the start's 0.1
    assert np.array_equal(u[1:-1], kp * (ref - q[:-2]))                     # under the opening applied before
    # (the last row: the state after the last step, under the last command applied)
    assert u[-1] == pytest.approx(kp * ref / (1 + kp * q0() / 0.1), rel=1e-9)   # the loop's fixed point
    big = Loop(PControllerCfg(type="p", kp=1e5), "load.q", "load.opening", (np.array([0.0]), np.array([1.0])),
               limits=(0.0, 1.0))
    assert simulate_circuit(c, 0.01, loop=big).column("load.opening").max() == 1.0
    neg = Loop(PControllerCfg(type="p", kp=1e5), "load.q", "load.opening", (np.array([0.0]), np.array([-1.0])),
               limits=(0.0, 1.0))
    assert simulate_circuit(c, 0.01, loop=neg).column("load.opening").min() == 0.0    # never below its range


def q0():
    """The orifice's flow at its start opening 0.1 (the textbook law, 100 bar)."""
    return 0.61 * 2e-6 * 0.1 * math.sqrt(2 * 100e5 / 860.0)


BLEED = '''
name = "bleed"
[components.tank]
type = "tank"
p = "tank"
[components.pump]
type = "pump"
inlet = "tank"
outlet = "supply"
displacement = "16 cm3/rev"
speed = "1500 rpm"
[components.relief]
type = "relief_valve"
p = "supply"
t = "tank"
cracking_pressure = "200 bar"
rated_flow = "40 l/min"
rated_pressure = "210 bar"
[components.block]
type = "volume"
p = "supply"
volume = "0.5 l"
[components.bleed]
type = "orifice"
a = "supply"
b = "tank"
area = "6 mm2"
[inputs]
"bleed.opening" = 1.0
'''


def _bleed_scenario(tmp_path, action: str):
    (tmp_path / "circuit.toml").write_text(BLEED)
    p = tmp_path / f"{action}.toml"
    p.write_text(f'circuit = "circuit.toml"\nduration = 1.5\n[controller]\ntype = "pi"\nmeasure = "supply.p"\n'
                 f'command = "bleed.opening"\naction = "{action}"\nkp = 1e-7\nki = 2e-6\n'
                 '[reference]\nt = [0, 0.5]\nvalue = ["100 bar", "150 bar"]\n')
    return p


def test_a_reverse_acting_loop_holds_a_pressure_by_bleeding(tmp_path):
    """A pump into a node bled to tank through an orifice: a larger opening lowers the pressure, so the PI loop
    is reverse-acting. It holds 150 bar with the opening the orifice law gives for the pump's flow,
    Q/(Cd·A·√(2Δp/ρ)), computed here; the same gains acting directly run away; the HIL run (lock-step) and
    the continuous reference apply the same law."""
    cs = load_circuit_scenario(_bleed_scenario(tmp_path, "reverse"))
    res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    q = 16e-6 * 25.0
    opening = q / (0.61 * 6e-6 * math.sqrt(2 * 150e5 / 860.0))
    assert res.columns["supply.p"][-1] == pytest.approx(150e5, rel=2e-8)
    assert res.columns["bleed.opening"][-1] == pytest.approx(opening, rel=2e-8)
    direct = load_circuit_scenario(_bleed_scenario(tmp_path, "direct"))
    d = simulate_circuit(direct.circuit, direct.duration, h=direct.step, loop=direct.loop)
    assert abs(d.columns["supply.p"][-1] - 150e5) > 10e5 and d.columns["bleed.opening"][-1] in (0.0, 1.0)
    ref = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop, method="reference")
    assert ref.columns["supply.p"][-1] == pytest.approx(150e5, rel=1e-6)
    from hydrohil.hil.run import run_hil
    r = run_hil(tmp_path / "reverse.toml", tmp_path / "hil", lockstep=True, plot=False, ready=lambda *a, **k: None)
    assert r.comparison["identical"]
    with pytest.raises(InputError, match="reverse") as e:
        load_circuit_scenario(_bleed_scenario(tmp_path, "sideways"))
    assert e.value.key == "controller.action"


def test_a_loops_sensor_noise_is_what_its_controller_reads(tmp_path):
    """sensor_noise: white noise of that standard deviation on the measured signal (one sample per reading,
    seeded), then the sensor's quantum and range. Over Fig 11 on the paper's circuit with 20 um noise and no
    quantum: the readings minus the true positions have the standard deviation given (0.23 % off, the test allows
    1 %) and mean 0 (0.3 standard errors; allowed 1);
    the P law's command at each step is clamp(kp·(ref − reading)), recomputed here from the logged readings; the
    same seed gives the same run, another seed another."""
    src = CIRCUITS_DIR / "ferreira2004"
    text = (src / "scenario.toml").read_text().replace('circuit = "circuit.toml"', f'circuit = "{src / "circuit.toml"}"')
    text = text.replace('sensor_resolution = "1 um"', 'sensor_noise = "20 um"\nsensor_seed = 3')
    f = tmp_path / "noisy.toml"
    f.write_text(text)
    cs = load_circuit_scenario(f)
    res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    x, seen = res.columns["cyl.x"], res.columns["cyl.x.sensed"]
    noise = (seen - x)[:-1]
    assert np.std(noise) == pytest.approx(20e-6, rel=0.01) and abs(np.mean(noise)) < 20e-6 / math.sqrt(len(noise))
    u = np.clip(50.0 * (res.columns["cyl.x.reference"] - seen), -1.0, 1.0)
    assert np.array_equal(res.columns["valve.command"][:-1], u[:-1])
    again = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    assert np.array_equal(again.columns["cyl.x"], x)
    f.write_text(text.replace("sensor_seed = 3", "sensor_seed = 4"))
    other = load_circuit_scenario(f)
    assert not np.array_equal(simulate_circuit(other.circuit, other.duration, h=other.step,
                                               loop=other.loop).columns["cyl.x.sensed"], seen)


def test_a_piston_reference_beyond_its_stroke_warns_saying_how_a_bare_number_is_read(tmp_path):
    """A loop on a piston whose reference leaves [0, stroke] warns (it cannot be reached: the end stop), saying
    that a number without its unit is in metres (50 meant as mm); the same in mm does not warn."""
    import warnings
    from hydrohil.errors import InputWarning
    f = tmp_path / "s.toml"
    body = ('circuit = "ferreira2004"\nduration = 1.0\n[controller]\ntype = "p"\nmeasure = "cyl.x"\n'
            'command = "valve.command"\nkp = 50.0\n[reference]\nt = [0.0, 0.5]\n')
    f.write_text(body + 'value = [0.03, 150]\n')
    with pytest.warns(InputWarning, match=r"reference value = 150 m \(at t = 0.5 s\) lies outside the stroke "
                                          r"\[0, 0.18\] m \(cyl.stroke\) \(a number without its unit is in m\)"):
        load_circuit_scenario(f)
    f.write_text(body + 'value = ["30 mm", "150 mm"]\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        load_circuit_scenario(f)


def test_maxsteps_verdict_names_the_signal_that_misses_the_accuracy_limits():
    """The verdict a user reads: a step stable to 2.38 ms whose own 0.5 ms step misses the 0.1 mm limit names
    the position and its RMS error (and not the pressure, within its 3 %)."""
    from hydrohil.circuits.accuracy import Accuracy
    from hydrohil.maxstep import circuit_verdict
    acc = Accuracy({"valve.x": 1.7e-6, "cyl.x": 1.52e-4}, {"a.p": 1.6e4, "supply.p": 4.3e4}, {"cyl.v": 2.6e-3}, 1.58e7)
    v = circuit_verdict(2.378e-3, 2.48e-3, 2e-3, 1e6, 5e-4, acc)
    assert v.startswith("stable up to 2.38 ms (within 2 mm and 10 bar RMS") and v.endswith(
        "do not hold: cyl.x 0.152 mm RMS")
    ok = Accuracy({"cyl.x": 5e-6}, {"a.p": 1e4}, {"cyl.v": 1e-3}, 1e7)
    assert circuit_verdict(3.67e-3, 3.8e-3, 2e-3, 1e6, 5e-4, ok).endswith("speed RMS) hold")
    # the search's ceiling reached, no step stable, a pressure missed, a state not finite: each said
    assert circuit_verdict(0.02, None, 2e-3, 1e6, 5e-4, ok).startswith("stable up to at least 20 ms")
    bad = Accuracy({"cyl.x": float("nan")}, {"a.p": 1e6, "b.p": 2e5}, {"cyl.v": 1e-3}, 1e7)
    v = circuit_verdict(None, 5e-4, 2e-3, 1e6, 5e-4, bad)
    assert v.startswith("no step is stable") and v.endswith(
        "do not hold: cyl.x not finite, a.p 10.00% of the highest pressure RMS")


def test_a_circuit_loops_summary_has_its_step_response_as_the_paper_scenarios(tmp_path):
    """summary.json of a circuit scenario's closed loop has the loop's moves (rise, overshoot, settling, the
    steady-state error; metrics.py), computed from the measured signal and its reference: the ferreira2004
    circuit's Fig 11 gives the core's fig11_p_control.toml's figures (the same times, positions to 1e-12 m)."""
    from hydrohil.cli import simulate
    paper = simulate(EXAMPLES / "fig11_p_control.toml", tmp_path / "p", plot=False, progress=False)["step_response"]
    circ = simulate(CIRCUITS_DIR / "ferreira2004" / "scenario.toml", tmp_path / "c", plot=False,
                    progress=False)["step_response"]
    assert circ["signal"] == "cyl.x" and circ["unit"] == "m" and len(circ["moves"]) == len(paper["moves"]) == 2
    for a, b in zip(paper["moves"], circ["moves"]):
        assert (a["rise_time"], a["settling_time"]) == (b["rise_time"], b["settling_time"])
        assert abs(a["overshoot"] - b["overshoot"]) < 1e-12 and abs(a["steady_state_error"] -
                                                                    b["steady_state_error"]) < 1e-12
    assert circ["rms_error"] == pytest.approx(paper["rms_error"], rel=1e-9)
