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
    assert v[np.searchsorted(t, 1.0)] == pytest.approx(q / a1, rel=2e-12)         # (measured: 4e-13)
    p_end = 100e5 + q / ((20e-3 / 60) / 10e5)
    assert ref.column("a.p")[-1] == pytest.approx(p_end, rel=1e-14)               # (measured: 2e-16)
    assert ref.column("relief.q")[-1] == pytest.approx(q, rel=1e-14)              # (measured: 4e-15)
    penetration = p_end * a1 / (m * STOP_WN ** 2)                                  # 4.1 um
    assert x[-1] - stroke == pytest.approx(penetration, rel=2e-11)                # (measured: 4e-12)
    hybrid = simulate_circuit(c, 3.0, rest=False)
    assert hybrid.column("cyl.x")[-1] == stroke
    assert compare_to_reference(hybrid, ref).worst_position < 3 * penetration    # (measured: 4.9 um)


@pytest.mark.parametrize("name, position, pressure, speed", [
    # measured at 0.5 ms: two_cylinders 1.0e-7 m, 2.1e-5, 1.3e-4; pump_relief_accumulator -, 4.7e-7, -
    ("two_cylinders", 3e-7, 6e-5, 4e-4),
    ("pump_relief_accumulator", 0.0, 1.5e-6, 0.0),
])
def test_each_example_at_half_a_millisecond_against_its_reference_and_its_largest_step(name, position, pressure,
                                                                                       speed):
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
    assert ms["max_stable_step"] >= 1e-3                      # (measured: 4.6 ms and 7.7 ms)
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
    f.write_text('circuit = "two_cylinders"\nparams = "ferreira2004"\n')
    with pytest.raises(InputError, match="unknown key") as e:
        load_circuit_scenario(f)
    assert e.value.key == "params"


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
        assert f"with {solver} on circuit two_cylinders" in r.stdout
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
    assert set(res["accuracy_at_step"]["rms_pressure_pa"]) == {"tank.p", "supply.p", "a1.p", "b1.p", "a2.p",
                                                                "b2.p"}
