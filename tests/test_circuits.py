"""Circuits (issue #27, first part): the supply-side components against their closed forms, computed here
independently of the C (textbook formulas, root finding, quadrature), each through a generated and compiled
circuit; catalogue units; errors that name the file, the component and the key; the example circuit."""

import base64
import math
import re

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from conftest import EXAMPLES
from hydrohil.circuits.circuit import CIRCUITS_DIR, circuit_from_dict, load_circuit
from hydrohil.circuits.library import TYPES
from hydrohil.circuits.run import node_stiffness, simulate_circuit
from hydrohil.circuits.units import to_si
from hydrohil.errors import InputError, InputWarning

RHO, BETA, NU = 860.0, 1.4e9, 46e-6
FLUID = {"density": RHO, "bulk_modulus": BETA, "viscosity": NU}


def circuit(components, **extra):
    return circuit_from_dict({"name": "test", "fluid": FLUID, "components": components, **extra}, "test.toml")


def at_start(c, column):
    """An output at t = 0 (the initial state given): the component's law at known pressures."""
    return simulate_circuit(c, 0.0).column(column)[0]


def test_catalogue_units_convert_at_the_boundary():
    assert to_si("150 bar", "Pa") == 150e5
    assert to_si("40 l/min", "m3/s") == pytest.approx(40e-3 / 60, rel=1e-15)
    assert to_si("16 cm³/rev", "m3/rev") == pytest.approx(16e-6, rel=1e-15)
    assert to_si("1500 rpm", "rev/s") == 25.0
    assert to_si(0.25, "m") == 0.25
    with pytest.raises(ValueError, match="in Pa, m3/s is wanted"):
        to_si("3 bar", "m3/s")
    with pytest.raises(ValueError, match="unknown unit 'furlong'"):
        to_si("3 furlong", "m")


def test_orifice_flow_is_the_textbook_value_and_laminar_near_zero():
    """q = Cd*A*sqrt(2*dp/rho): 0.61 * 1 mm2 at 100 bar in oil of 860 kg/m3 = 5.58 l/min."""
    def make(p_node):
        return circuit({"src": {"type": "pressure_source", "p": "s", "pressure": "100 bar"},
                        "tank": {"type": "tank", "p": "t"},
                        "o": {"type": "orifice", "a": "s", "b": "n", "area": "1 mm2"},
                        "v": {"type": "volume", "p": "n", "volume": "1 l"},
                        "o2": {"type": "orifice", "a": "n", "b": "t", "area": "1 mm2"}},
                       initial={"n": p_node})
    q = at_start(make(0.0), "o.q")
    assert q * 60e3 == pytest.approx(0.61e-6 * math.sqrt(2 * 100e5 / RHO) * 60e3, rel=1e-12)
    assert 5.57 < q * 60e3 < 5.59
    # within the transition (dp < 1 bar) the flow is below the square-root law and goes to 0 linearly
    q_small = at_start(make(100e5 - 0.01e5), "o.q")
    assert 0 < q_small < 0.61e-6 * math.sqrt(2 * 0.01e5 / RHO)


def test_relief_valve_holds_its_pressure_at_a_given_flow():
    """A pump of constant flow Q (no leakage) into a relief valve: p = p_cr + Q/K, K = Q_r/(p_r - p_cr)."""
    c = circuit({"tank": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "n", "displacement": "10 cm3/rev",
                          "speed": "1200 rpm"},
                 "relief": {"type": "relief_valve", "p": "n", "t": "t", "cracking_pressure": "120 bar",
                            "rated_flow": "30 l/min", "rated_pressure": "140 bar"},
                 "v": {"type": "volume", "p": "n", "volume": "2 l"}})
    r = simulate_circuit(c, 3.0, rest=False)        # from the tank's pressure (at rest it would start open)
    q = 10e-6 * 20.0
    k = (30e-3 / 60) / 20e5
    assert r.column("n.p")[-1] == pytest.approx(120e5 + q / k, rel=1e-13)     # (measured: 2e-15)
    assert r.column("relief.q")[-1] == pytest.approx(q, rel=1e-13)
    modes = r.column("relief.mode")
    assert modes[0] == 0 and modes[-1] == 1 and np.all(np.diff(modes) >= 0)     # closed, then open for good
    # the cracking instant: the node fills at Q through its compressibility until p_cr (closed form)
    t_crack = 2e-3 / BETA * 120e5 / q
    t_open = r.column("t")[np.argmax(modes == 1)]
    assert 0 <= t_open - t_crack <= r.h           # the first step after the guard is crossed


def test_accumulator_charges_along_its_polytropic_curve():
    """A pump of constant flow into an accumulator (precharge 50 bar, n = 1.4) and a small volume: the oil
    pumped in equals the accumulator's oil volume plus the volume's compression at every instant;
    dV_oil/dp integrates to V_oil."""
    v0, p0, n = 0.5e-3, 50e5, 1.4
    c = circuit({"tank": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "n", "displacement": "20 cm3/rev",
                          "speed": "1500 rpm"},
                 "acc": {"type": "accumulator", "p": "n", "gas_volume": v0, "precharge": p0, "exponent": n},
                 "v": {"type": "volume", "p": "n", "volume": "0.05 l"}},
                initial={"n": p0 + 1.0})

    def v_oil(p):                       # the textbook polytropic law, absolute pressures
        return v0 - v0 * ((p0 + 1e5) / (p + 1e5)) ** (1 / n) if p > p0 else 0.0
    r = simulate_circuit(c, 0.5)
    q = 20e-6 * 25.0
    t, p = r.column("t"), r.column("n.p")
    pumped = q * t
    stored = np.array([v_oil(x) for x in p]) - v_oil(p0 + 1.0) + 0.05e-3 / BETA * (p - p0 - 1.0)
    assert np.max(np.abs(stored - pumped)) < 2e-13          # RK3 at 0.5 ms: 5.3e-14 m3 of 0.25 l (measured)
    assert r.column("acc.v_oil")[-1] == pytest.approx(v_oil(p[-1]), rel=1e-12)
    assert p[-1] > 100e5 and r.column("acc.mode")[-1] == 1                   # working, charged well past p0
    cap = quad(lambda x: v0 * (p0 + 1e5) ** (1 / n) / (n * (x + 1e5) ** (1 + 1 / n)), p0, 150e5)[0]
    assert cap == pytest.approx(v_oil(150e5), rel=1e-9)


def test_check_valve_cracks_and_feeds_an_orifice():
    """Source 50 bar -> check valve (cracks at 5 bar, 10 l/min at 15 bar) -> node -> orifice to tank: in steady
    state K*(50 bar - p - 5 bar) = Cd*A*sqrt(2p/rho) (the root found here by brentq)."""
    c = circuit({"src": {"type": "pressure_source", "p": "s", "pressure": "50 bar"},
                 "tank": {"type": "tank", "p": "t"},
                 "check": {"type": "check_valve", "a": "s", "b": "n", "cracking_pressure": "5 bar",
                           "rated_flow": "10 l/min", "rated_pressure": "15 bar"},
                 "v": {"type": "volume", "p": "n", "volume": "1 l"},
                 "o": {"type": "orifice", "a": "n", "b": "t", "area": "2 mm2"}})
    k = (10e-3 / 60) / 10e5
    p = brentq(lambda x: k * (50e5 - x - 5e5) - 0.61 * 2e-6 * math.sqrt(2 * x / RHO), 1e5, 45e5, xtol=1e-6)
    r = simulate_circuit(c, 4.0)
    assert r.column("n.p")[-1] == pytest.approx(p, rel=1e-13)             # (measured: 3e-14)
    assert r.column("check.mode")[-1] == 1
    # reversed (the node above the source): closed, no flow
    rev = circuit({"src": {"type": "pressure_source", "p": "s", "pressure": "50 bar"},
                   "check": {"type": "check_valve", "a": "s", "b": "n", "cracking_pressure": "5 bar",
                             "rated_flow": "10 l/min", "rated_pressure": "15 bar"},
                   "v": {"type": "volume", "p": "n", "volume": "1 l"}}, initial={"n": "80 bar"})
    r = simulate_circuit(rev, 0.5)
    assert np.all(r.column("check.q") == 0.0) and np.all(r.column("n.p") == 80e5)


def test_hose_laminar_and_turbulent_resistance():
    """10 mm x 2 m hose, 46 cSt: laminar dp = 128*mu*L*q/(pi*d^4) (0.54 bar at 10 l/min); at 5 bar (Re ~ 4000)
    the turbulent law (Blasius, the velocity solved here from the friction-factor form) gives the flow."""
    def flow(dp):
        c = circuit({"src": {"type": "pressure_source", "p": "s", "pressure": dp},
                     "tank": {"type": "tank", "p": "t"},
                     "h": {"type": "hose", "a": "s", "b": "n", "diameter": "10 mm", "length": "2 m"},
                     "o": {"type": "orifice", "a": "n", "b": "t", "area": "1 mm2"}},
                    initial={"n": 0.0})
        return at_start(c, "h.q")
    mu = RHO * NU
    r_lam = 128 * mu * 2.0 / (math.pi * 0.01 ** 4)
    q = 10e-3 / 60
    assert flow(r_lam * q) == pytest.approx(q, rel=1e-12)
    assert 0.53e5 < r_lam * q < 0.55e5
    dp = 5e5                              # well turbulent: Re ~ 4000
    area = math.pi * 0.01 ** 2 / 4
    v = brentq(lambda v: 0.3164 * (v * 0.01 / NU) ** -0.25 * (2.0 / 0.01) * RHO * v * v / 2 - dp, 0.01, 100)
    assert v * 0.01 / NU > 2300
    assert flow(dp) == pytest.approx(v * area, rel=1e-9)


def test_pump_catalogue_form():
    """eta_v = 0.92 at 1500 rpm and 250 bar: at that pressure the pump gives 92 % of D*n."""
    c = circuit({"tank": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "n", "displacement": "28 cm3/rev",
                          "speed": "1500 rpm", "volumetric_efficiency": 0.92, "rated_speed": "1500 rpm",
                          "rated_pressure": "250 bar"},
                 "v": {"type": "volume", "p": "n", "volume": "1 l"}}, initial={"n": "250 bar"})
    assert at_start(c, "pump.q") == pytest.approx(0.92 * 28e-6 * 25.0, rel=1e-12)


@pytest.mark.parametrize("change, where, message", [
    ({"relief": {"cracking_pressure": "160 psu"}}, "components.relief.cracking_pressure", "unknown unit 'psu'"),
    ({"relief": {"cracking_pressure": "16 l/min"}}, "components.relief.cracking_pressure", "is in m3/s, Pa is wanted"),
    ({"relief": {"cracking_pressure": "160 PSI"}}, "components.relief.cracking_pressure",
     "unknown unit 'PSI' in '160 PSI' (did you mean 'psi'?)"),
    ({"relief": {"rated_pressure": "150 bar"}}, "components.relief", "must be above cracking_pressure"),
    ({"accumulator": {"exponent": 1.6}}, "components.accumulator.exponent", "must be >= 1 and <= 1.4"),
    ({"accumulator": {"colour": "red"}}, "components.accumulator.colour", "not a parameter of a accumulator"),
    ({"load": {"type": "nozzle"}}, "components.load.type", "unknown component type 'nozzle'"),
    ({"line": {"b": None}}, "components.line.b", "port b of a hose needs a node name"),
    # a misspelt key named with the nearest (before the key it was meant for is found missing), a port's too
    ({"relief": {"cracking_pressure": None, "cracking_presure": "150 bar"}}, "components.relief.cracking_presure",
     "unknown key 'cracking_presure' (did you mean 'cracking_pressure'?): not a parameter of a relief_valve"),
    ({"line": {"b": None, "B": "load_port"}}, "components.line.B", "(did you mean 'b'?)"),
    ({"load": {"type": "orifise"}}, "components.load.type", "(did you mean 'orifice'?)"),
    # a misspelt node: a port connected to nothing else, the nearest node named
    ({"relief": {"t": "tnk"}}, "components.relief.t", "node 'tnk' connects to nothing else: only relief.t is at it "
                                                      "(did you mean 'tank'?)"),
])
def test_a_circuit_error_names_the_file_the_component_and_the_key(change, where, message):
    import copy
    import tomllib
    data = tomllib.loads((CIRCUITS_DIR / "pump_relief_accumulator" / "circuit.toml").read_text())
    data = copy.deepcopy(data)
    for comp, kv in change.items():
        for k, v in kv.items():
            if v is None:
                data["components"][comp].pop(k)
            else:
                data["components"][comp][k] = v
    with pytest.raises(InputError) as e:
        circuit_from_dict(data, "my_rig.toml")
    assert str(e.value).startswith(f"my_rig.toml: {where}: ") and message in str(e.value)


def test_a_node_without_volume_and_a_circuit_without_return_are_refused():
    with pytest.raises(InputError, match="nodes.n: this node has no volume"):
        circuit({"tank": {"type": "tank", "p": "t"}, "o": {"type": "orifice", "a": "t", "b": "n", "area": "1 mm2"},
                 "o2": {"type": "orifice", "a": "n", "b": "t", "area": "1 mm2"}})
    with pytest.raises(InputError, match="no tank or pressure source"):
        circuit({"v": {"type": "volume", "p": "n", "volume": "1 l"}})


def test_the_supply_sags_while_the_load_draws_and_recovers():
    """examples/circuits/pump_relief_accumulator: the load orifice opens at 2 s and draws more than the pump
    gives: the supply falls below the relief setting, the accumulator gives oil; closed again at 4 s, the
    supply comes back to the relief valve's pressure at the pump's flow (p_cr + Q/K)."""
    c = load_circuit("pump_relief_accumulator")
    r = simulate_circuit(c, 8.0)
    t, ps, v_oil, relief = r.column("t"), r.column("supply.p"), r.column("accumulator.v_oil"), r.column("relief.mode")
    pump_q = r.column("pump.q")[np.searchsorted(t, 1.99)]
    k = (40e-3 / 60) / 15e5
    held = 160e5 + (pump_q - r.column("load.q")[np.searchsorted(t, 1.99)]) / k
    assert ps[np.searchsorted(t, 1.99)] == pytest.approx(held, rel=5e-10)     # (measured: 1.5e-10, settling)
    during = (t > 2.2) & (t < 4.0)
    assert np.all(ps[during] < 160e5) and np.all(relief[during] == 0)
    assert v_oil[np.searchsorted(t, 3.99)] < v_oil[np.searchsorted(t, 1.99)] - 40e-6   # the accumulator gave oil
    assert ps[-1] == pytest.approx(held, rel=3e-12) and relief[-1] == 1                # recovered (8e-13)
    for s in node_stiffness(c, r):
        assert s.stable, s.treatment("rk3", r.h)


def test_rk3_at_half_a_millisecond_against_a_fine_reference():
    """The example at the real-time step against RK4 at 1/16 of it: node pressures agree within 1500 Pa
    (measured: 420 Pa on the load port, 19 Pa on the supply)."""
    c = load_circuit("pump_relief_accumulator")
    coarse = simulate_circuit(c, 6.0)
    fine = simulate_circuit(c, 6.0, h=5e-4 / 16, method="rk4", every=16)
    for node in ("supply.p", "load_port.p"):
        err = np.max(np.abs(coarse.column(node) - fine.column(node)))
        assert err < 1500, (node, err)


def test_circuit_show_and_run_as_a_user_types_them(tmp_path):
    """hydrohil circuit show (text and --json: signals with SI units, every node's treatment) and circuit run
    (log.csv with units in the header, modes by name; plot.png); a bad file: exit 2, the key named, nothing
    written."""
    import csv
    import json
    from conftest import hh
    r = hh("circuit", "show", "pump_relief_accumulator")
    assert r.returncode == 0, r.stderr
    assert "supply         pressure state" in r.stdout and "explicit rk3: lambda*h" in r.stdout
    assert "cracking_pressure             1.6e+07 Pa" in r.stdout and "(file: 160 bar)" in r.stdout
    d = json.loads(hh("circuit", "show", "pump_relief_accumulator", "--json").stdout)
    units = {s["name"]: s["unit"] for s in d["signals"]}
    assert units["supply.p"] == "Pa" and units["relief.q"] == "m3/s" and units["accumulator.v_oil"] == "m3"
    assert [n["name"] for n in d["nodes"]] == ["tank", "supply", "load_port"]
    assert all(n["lambda_h"] < n["stability_limit"] for n in d["nodes"] if "lambda_h" in n)
    # a closed loop's circuit: alone, its open-loop drive moves the piston off rest, which show (a description,
    # not the user's run) does not warn of; with its scenario, the loop holds it from the start
    r = hh("circuit", "show", "ferreira2004")
    assert r.returncode == 0 and "is not held at rest" not in r.stderr
    assert ("events located inside the step (guards): cyl.retract, cyl.extend, cyl.breakaway_pos, "
            "cyl.breakaway_neg, cyl.reverse, cyl.leave") in r.stdout
    assert "inputs seen late (delay lines): valve.command" in r.stdout
    assert ("cyl.x [m] in [-0.18, 0.36], cyl.v [m/s] in [-100, 100], cyl.z [m]" in r.stdout      # (the ranges
            and "valve.x [-] in [-10, 10], valve.v [1/s]," in r.stdout)              # a run stops outside)
    ranges = {s["name"]: s["range"] for s in json.loads(hh("circuit", "show", "motor_speed", "--json").stdout)["states"]}
    assert ranges["supply.p"] == [-1e9, 1e9] and ranges["motor.w"] == [-1e5, 1e5] and ranges["valve.v"] is None
    r = hh("circuit", "show", "--scenario", CIRCUITS_DIR / "ferreira2004" / "scenario.toml")
    assert r.returncode == 0 and "is not held" not in r.stderr and "over a run of the scenario" in r.stdout
    out = tmp_path / "run"
    r = hh("circuit", "run", "pump_relief_accumulator", "--out", out)         # default: the drive's end + 2 s
    assert r.returncode == 0, r.stderr
    rows = list(csv.reader(open(out / "log.csv")))
    assert rows[0][:3] == ["t [s]", "tank.p [Pa]", "supply.p [Pa]"] and len(rows) == 1 + 12001
    relief = [row[rows[0].index("relief.mode [-]")] for row in rows[1:]]
    assert relief[6000] == "closed" and relief[-1] == "open"                 # the load open at 3 s, closed at 6 s
    assert (out / "plot.png").stat().st_size > 20_000
    bad = tmp_path / "bad.toml"
    bad.write_text(open(load_circuit("pump_relief_accumulator").source).read().replace('"40 l/min"', '"40 bar"'))
    r = hh("circuit", "run", bad, "--out", tmp_path / "nothing")
    assert r.returncode == 2 and "components.relief.rated_flow" in r.stderr and "m3/s is wanted" in r.stderr
    assert not (tmp_path / "nothing").exists()


def test_motor_speed_is_flow_over_displacement_and_torque_balances_friction():
    """A 10 cm3/rev motor between 100 bar and tank, viscous friction 0.05 N.m.s/rad, efficiency 0.9: steady
    speed w = eta*D*dp/(2 pi c) and flow D*w/(2 pi) + Cl*dp (closed forms)."""
    d, dp, c_visc, eta, cl = 10e-6, 100e5, 0.05, 0.9, 1e-12
    c = circuit({"src": {"type": "pressure_source", "p": "s", "pressure": dp},
                 "tank": {"type": "tank", "p": "t"},
                 "motor": {"type": "motor", "a": "s", "b": "t", "displacement": d, "leakage": cl, "efficiency": eta,
                           "inertia": 0.01, "damping": c_visc}})          # (no pressure node: the motor's state only)
    r = simulate_circuit(c, 5.0)                      # (time constant J/c = 0.2 s: 25 of them, e^-25)
    w = eta * d * dp / (2 * math.pi * c_visc)
    assert r.column("motor.w")[-1] == pytest.approx(w, rel=1e-9)
    assert r.column("motor.q")[-1] == pytest.approx(d * w / (2 * math.pi) + cl * dp, rel=1e-9)
    assert 2735 < r.column("motor.w")[-1] * 60 / (2 * math.pi) < 2736                     # rpm, by hand


def test_cylinder_extends_at_pump_flow_over_area_then_stops_at_the_end():
    """A pump of constant flow into the cap side of a 50/28 mm cylinder, the rod side to tank through a large
    orifice: it extends at v = Q/A1 (closed form), stops at the end of its 0.2 m stroke (mode at_extend, v = 0)
    and the pressure rises to the relief valve's p_cr + Q/K."""
    q, bore, rod, stroke = 10e-3 / 60, 0.05, 0.028, 0.2
    c = circuit({"tank": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "a", "displacement": q / 25.0, "speed": 25.0},
                 "relief": {"type": "relief_valve", "p": "a", "t": "t", "cracking_pressure": "100 bar",
                            "rated_flow": "20 l/min", "rated_pressure": "110 bar"},
                 "cyl": {"type": "cylinder", "a": "a", "b": "b", "bore": bore, "rod": rod, "stroke": stroke,
                         "mass": 50.0, "damping": 2000.0, "dead_volume_a": "0.2 l", "dead_volume_b": "0.2 l"},
                 "out": {"type": "orifice", "a": "b", "b": "t", "area": "4 mm2"}})
    r = simulate_circuit(c, 3.0, rest=False)        # from empty chambers
    assert all(s.stable for s in node_stiffness(c, r))         # (a smaller rod-side volume or a larger outlet
                                                               # is too stiff for 0.5 ms: circuit show says so)
    a1 = math.pi * bore ** 2 / 4
    t, x, v = r.column("t"), r.column("cyl.x"), r.column("cyl.v")
    assert v[np.searchsorted(t, 1.0)] == pytest.approx(q / a1, rel=1e-12)        # (measured: 3e-16)
    t_end = t[np.argmax(r.column("cyl.mode") == 2)]
    assert t_end == pytest.approx(stroke / (q / a1), abs=3e-3)      # the start-up: compressing the chamber (0.8 ms)
    assert x[-1] == stroke and v[-1] == 0.0
    k = (20e-3 / 60) / 10e5
    assert r.column("a.p")[-1] == pytest.approx(100e5 + q / k, rel=1e-12)       # (measured: 6e-16)
    assert r.column("relief.mode")[-1] == 1


def test_valve_controlled_cylinder_moves_at_the_orifice_equation_speed():
    """100 bar into a 4/3 valve (critical centre, command 0.5) to a 50/28 cylinder without load or friction:
    both metering edges turbulent, the steady speed is v = k*x*sqrt(A1*ps / (A1^3 + A2^3)) (derived from
    q_PA = A1 v, q_BT = A2 v and p1 A1 = p2 A2), k = Cq*w*sqrt(2/rho); the valve's flow at t = 0 with the spool
    at 0.5 x_max against 100 bar into an empty chamber is k*x*sqrt(ps)."""
    ps, bore, rod = 100e5, 0.05, 0.028
    cq, w, xmax = 0.67, 2e-3, 1e-3
    body = {"src": {"type": "pressure_source", "p": "s", "pressure": ps},
            "tank": {"type": "tank", "p": "t"},
            "valve": {"type": "valve_43", "P": "s", "T": "t", "A": "a", "B": "b", "command": 0.5, "x_max": xmax,
                      "area_gradient": w, "discharge_coefficient": cq, "leakage_opening": 0.0, "wn": 600.0},
            "cyl": {"type": "cylinder", "a": "a", "b": "b", "bore": bore, "rod": rod, "stroke": 1.0, "mass": 20.0,
                    "x0": 0.1}}
    k = cq * w * math.sqrt(2 / RHO)
    x = 0.5 * xmax
    assert at_start(circuit(body, initial={"a": 0.0, "b": 0.0}), "valve.q_pa") == pytest.approx(k * x * math.sqrt(ps),
                                                                                               rel=1e-12)
    with pytest.warns(InputWarning, match="cyl is not held at rest"):       # (the valve is open: it moves)
        r = simulate_circuit(circuit(body), 1.0)
    a1, a2 = math.pi * bore ** 2 / 4, math.pi * (bore ** 2 - rod ** 2) / 4
    v = k * x * math.sqrt(a1 * ps / (a1 ** 3 + a2 ** 3))
    assert r.column("cyl.v")[-1] == pytest.approx(v, rel=6e-7)          # (measured: 2e-7, still settling at 1 s)
    assert r.column("a.p")[-1] * a1 == pytest.approx(r.column("b.p")[-1] * a2, rel=1.5e-8)      # (5e-9)
    assert r.column("valve.x")[-1] == pytest.approx(x, rel=1e-12)


def test_a_node_too_stiff_for_the_step_is_reported_and_slowed():
    """The cylinder's rod side with 0.05 l of dead volume draining through 20 mm²: near the orifice's laminar
    transition lambda ~ 1e4 1/s, beyond RK3's stability interval at 0.5 ms (alone, RK3 would alternate from step
    to step); the stiffness check says so, and the stiff-node form (hc_node.h) slows its relaxation to
    lambda*h = 1.5 there: no alternation, the steady state exact (the same as at 1/16 of the step within 7e-7,
    the fine run still settling) and the start-up within 2 % (measured 0.6 %) of the highest
    pressure; at 1/16 of the step it is explicitly stable and says that too."""
    c = circuit({"tank": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "a", "displacement": "6.67 cm3/rev", "speed": 25.0},
                 "cyl": {"type": "cylinder", "a": "a", "b": "b", "bore": 0.05, "rod": 0.028, "stroke": 0.2,
                         "mass": 50.0, "damping": 2000.0},
                 "out": {"type": "orifice", "a": "b", "b": "t", "area": "20 mm2"}})
    run = simulate_circuit(c, 0.5, rest=False)
    coarse = {s.node: s for s in node_stiffness(c, run)}
    assert not coarse["b"].stable and coarse["b"].lam_h > 2.51 and coarse["a"].stable
    assert "stiff for rk3 at 0.5 ms" in coarse["b"].treatment("rk3", 5e-4)
    assert "slowed to lambda*h = 1.5" in coarse["b"].treatment("rk3", 5e-4)
    fine_run = simulate_circuit(c, 0.5, h=5e-4 / 16, rest=False, every=16)
    fine = {s.node: s for s in node_stiffness(c, fine_run)}
    assert fine["b"].stable and fine["b"].treatment("rk3", 5e-4 / 16).startswith("explicit")
    b, b_fine = run.column("b.p"), fine_run.column("b.p")
    assert np.all(np.abs(np.diff(b[-100:])) < 3e-4)                  # settled, no alternation (measured 1e-4 Pa)
    for k, rel in (("a.p", 2e-6), ("b.p", 1e-7), ("cyl.v", 1e-7)):     # (measured: 6.7e-7, 3.1e-8, 3.1e-8)
        assert run.column(k)[-1] == pytest.approx(fine_run.column(k)[-1], rel=rel)
    after = run.column("t") > 0.05                                    # (the first 50 ms: chambers filling)
    assert np.max(np.abs(b - b_fine)[after]) < 0.02 * b_fine.max()



def test_two_cylinders_on_one_pump():
    """examples/circuits/two_cylinders: each cylinder extends when its valve opens; with both moving they want
    more than the pump gives: the supply leaves the relief's pressure and the accumulator gives oil; RK3 at
    0.5 ms against RK4 at 1/16 of the step: positions within 1.5 µm (measured 0.6 µm), chamber pressures
    within 0.15 bar (measured 0.047 bar: the ringing after each valve step), every node explicit-stable."""
    c = load_circuit("two_cylinders")
    r = simulate_circuit(c, 7.5)
    t = r.column("t")
    at = lambda s: np.searchsorted(t, s)      # noqa: E731
    x1, x2 = r.column("cyl1.x"), r.column("cyl2.x")
    assert x1[at(0.5)] == pytest.approx(0.05, abs=1e-5) and x1[at(3.0)] > 0.25           # the first extends
    assert x2[at(1.5)] == pytest.approx(0.05, abs=1e-5) and x2[at(3.5)] > 0.25           # then the second
    assert x1[-1] < x1[at(3.0)] - 0.1 and x2[-1] < x2[at(3.5)] - 0.1                    # both retract
    ps = r.column("supply.p")
    both = (t > 1.7) & (t < 3.0)
    assert np.all(ps[both] < 180e5) and np.all(r.column("relief.mode")[both] == 0)
    v_oil = r.column("accumulator.v_oil")
    assert v_oil[at(3.0)] < v_oil[at(1.5)] - 150e-6                                    # 0.23 l given
    fine = simulate_circuit(c, 7.5, h=5e-4 / 16, method="rk4", every=16)
    for n in ("cyl1.x", "cyl2.x"):
        assert np.max(np.abs(r.column(n) - fine.column(n))) < 1.5e-6, n
    for n in ("supply.p", "a1.p", "b1.p", "a2.p", "b2.p"):
        assert np.max(np.abs(r.column(n) - fine.column(n))) < 0.15e5, n
    assert all(s.stable for s in node_stiffness(c, r))


def test_circuits_start_at_rest_unless_initial_pressures_are_given():
    """SPEC §12.5: without [initial] the node pressures start at rest: the closed-centre valves' symmetric
    leakage holds each chamber at half the supply (closed form), the relief valve takes what the pump gives
    beyond the leakage (the supply node's flow balance), and the supply circuit starts where its dynamic run
    from 100 bar ends; a pump with nowhere to go has no rest and says where."""
    c = load_circuit("two_cylinders")
    c.initial = {}
    with pytest.warns(InputWarning) as rec:
        r = simulate_circuit(c, 0.0)           # (ps/2 on both sides of a differential piston: it extends)
    said = " ".join(str(w.message) for w in rec)
    for cyl in ("cyl1", "cyl2"):
        assert f"{cyl} is not held at rest: the net force on it at the start is 9706 N" in said
    ps = r.column("supply.p")[0]
    for n in ("a1", "b1", "a2", "b2"):
        assert r.column(f"{n}.p")[0] == pytest.approx(ps / 2, rel=1e-12)
    leaks = sum(r.column(f"valve{i}.q_{e}")[0] for i in (1, 2) for e in ("pa", "pb"))
    assert r.column("relief.q")[0] + leaks == pytest.approx(r.column("pump.q")[0], rel=1e-9)
    assert r.column("relief.mode")[0] == 1 and 180e5 < ps < 195e5
    given = load_circuit("pump_relief_accumulator")
    dynamic = simulate_circuit(given, 1.99)                          # from the file's 100 bar to rest
    given.initial = {}
    rest = simulate_circuit(given, 0.0)
    for n in ("supply.p", "load_port.p"):
        assert rest.column(n)[0] == pytest.approx(dynamic.column(n)[-1], rel=1e-9)
    assert dynamic.column("supply.p")[0] == 100e5                    # [initial] is kept when given
    dead = circuit({"tank": {"type": "tank", "p": "t"},
                    "pump": {"type": "pump", "inlet": "t", "outlet": "n", "displacement": "10 cm3/rev",
                             "speed": "1500 rpm"},
                    "v": {"type": "volume", "p": "n", "volume": "1 l"}})
    with pytest.raises(InputError, match="test.toml: initial: no state at rest: the pressures at n do not settle"):
        simulate_circuit(dead, 1.0)
    assert simulate_circuit(dead, 0.1, rest=False).column("n.p")[-1] > 0         # without: it just fills


def test_double_rod_cylinder_and_a_load_with_spring_and_weight():
    """A double-rod cylinder pushes out at each end what the pump pushes in (equal areas: Q = A*v both sides);
    a cylinder at a fixed pressure against a spring and its load's weight (rod 60° up) comes to rest at
    x = x_s + (p*A1 - M*g*sin 60°)/k (closed forms)."""
    bore, rod = 0.05, 0.025
    area = math.pi * (bore ** 2 - rod ** 2) / 4
    q = 6e-3 / 60
    c = circuit({"tank": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "a", "displacement": q, "speed": 1.0},
                 "cyl": {"type": "double_rod_cylinder", "a": "a", "b": "b", "bore": bore, "rod": rod, "stroke": 0.5,
                         "mass": 20.0, "damping": 1000.0, "dead_volume_a": "0.2 l", "dead_volume_b": "0.2 l"},
                 "out": {"type": "orifice", "a": "b", "b": "t", "area": "4 mm2"}})
    r = simulate_circuit(c, 1.5, rest=False)
    assert r.column("cyl.v")[-1] == pytest.approx(q / area, rel=1e-9)
    assert r.column("out.q")[-1] == pytest.approx(q, rel=1e-9)
    p, k, m, x_s = 20e5, 2e6, 100.0, 0.02
    c = circuit({"src": {"type": "pressure_source", "p": "s", "pressure": p},
                 "tank": {"type": "tank", "p": "t"},
                 "cyl": {"type": "cylinder", "a": "s", "b": "t", "bore": bore, "rod": rod, "stroke": 0.5, "mass": m,
                         "damping": 2e4, "spring": k, "spring_x0": x_s, "incline": "60 deg"}})
    with pytest.warns(InputWarning, match="cyl is not held at rest"):        # (the spring and weight move it)
        r = simulate_circuit(c, 2.0)
    x_eq = x_s + (p * math.pi * bore ** 2 / 4 - m * 9.80665 * math.sin(math.radians(60))) / k
    assert r.column("cyl.x")[-1] == pytest.approx(x_eq, rel=1e-9)


def test_counterbalance_valve_holds_the_load_and_lowers_it_under_pilot():
    """A 500 kg load on a vertical cylinder held on its cap side by a counterbalance valve (its valve port
    returning to tank) set at 1.3 x the load pressure: without pilot pressure it does not move; with 5 bar on the
    pilot (ratio 3) the main stage opens by s = (p_load + r*p_x - p_set)/dp_open and the load lowers at the speed
    where A1*|v| = s*K*sqrt(p_load) (K = Q_r/sqrt(dp_r)), p_load from the force balance with its friction,
    p_load = (W + c*v)/A1: solved here by root finding."""
    bore, rod, m, c_visc = 0.05, 0.028, 500.0, 2e4
    a1 = math.pi * bore ** 2 / 4
    w = m * 9.80665
    p_load = w / a1
    p_set = 1.3 * p_load
    k_o, dp_open = (10e-3 / 60) / math.sqrt(10e5), 20e5

    def rig(pilot):
        return circuit({"tank": {"type": "tank", "p": "t"},
                        "pilot": {"type": "pressure_source", "p": "x", "pressure": pilot},
                        "cb": {"type": "counterbalance_valve", "valve": "t", "load": "a", "pilot": "x",
                               "set_pressure": p_set, "pilot_ratio": 3.0, "rated_flow": "10 l/min",
                               "rated_drop": "10 bar", "rated_excess": "20 bar", "check_rated_flow": "20 l/min",
                               "check_rated_pressure": "5 bar"},
                        "cyl": {"type": "cylinder", "a": "a", "b": "t", "bore": bore, "rod": rod, "stroke": 0.6,
                                "mass": m, "damping": c_visc, "incline": "90 deg", "x0": 0.4,
                                "dead_volume_a": "0.2 l"}},
                       initial={"a": p_load})
    held = simulate_circuit(rig(0.0), 2.0)
    assert np.max(np.abs(held.column("cyl.x") - 0.4)) < 1e-9 and np.all(held.column("cb.mode") == 0)
    p_x = 5e5
    low = simulate_circuit(rig(p_x), 1.0)

    def balance(v):
        pl = (w + c_visc * v) / a1
        s = min(max((pl + 3.0 * p_x - p_set) / dp_open, 0.0), 1.0)
        return -a1 * v - s * k_o * math.sqrt(pl)
    v = brentq(balance, -0.2, -1e-9, xtol=1e-15, rtol=1e-15)      # (p_load > 0 down to -0.24 m/s)
    assert 0.1 < low.column("cb.opening")[-1] < 0.5                 # the main stage part open (0.23)
    assert low.column("cyl.v")[-1] == pytest.approx(v, rel=1e-13) and low.column("cb.mode")[-1] == 2  # (4e-15)
    # the relief path never carries oil into a load whose valve port is higher (100 bar against 99.5)
    up = circuit({"src": {"type": "pressure_source", "p": "v", "pressure": 100e5},
                  "pilot": {"type": "pressure_source", "p": "x", "pressure": p_x},
                  "cb": {"type": "counterbalance_valve", "valve": "v", "load": "a", "pilot": "x", "set_pressure": p_set,
                         "rated_flow": "10 l/min", "rated_drop": "10 bar", "rated_excess": "20 bar",
                         "check_rated_flow": "20 l/min",
                         "check_rated_pressure": "5 bar"},
                  "vol": {"type": "volume", "p": "a", "volume": "1 l"}}, initial={"a": 99.5e5})
    r = simulate_circuit(up, 0.5)
    assert r.column("cb.q")[0] >= 0.0 and np.all(np.diff(r.column("a.p")) >= -1e-6)


def test_open_centre_valve_passes_the_pump_to_tank_at_centre():
    """A 6/3 valve at x = 0: its centre path passes k*x_c*sqrt(ps) from P to T (closed form); at full stroke the
    centre is shut and P feeds A."""
    cq, w, xc = 0.67, 3e-3, 0.3e-3
    body = {"src": {"type": "pressure_source", "p": "s", "pressure": 50e5}, "tank": {"type": "tank", "p": "t"},
            "valve": {"type": "valve_63", "P": "s", "T": "t", "A": "a", "B": "b", "x_max": "1 mm",
                      "area_gradient": w, "discharge_coefficient": cq, "centre_travel": xc, "wn": 500.0,
                      "leakage_opening": 0.0, "command": 0.0},
            "va": {"type": "volume", "p": "a", "volume": "0.1 l"}, "vb": {"type": "volume", "p": "b", "volume": "0.1 l"}}
    k = cq * w * math.sqrt(2 / RHO)
    assert at_start(circuit(body, initial={"a": 0.0, "b": 0.0}), "valve.q_pt") == pytest.approx(k * xc * math.sqrt(50e5),
                                                                                               rel=1e-12)
    body["valve"]["command"] = 1.0
    r = simulate_circuit(circuit(body, initial={"a": 0.0, "b": 0.0}), 0.0)
    assert r.column("valve.q_pt")[0] == 0.0 and r.column("valve.q_pa")[0] > 0


def test_circuit_draw_labels_every_component_node_and_signal(tmp_path):
    """hydrohil circuit draw: an SVG whose text names every component (with its key figures in catalogue units),
    every node and every signal; a PNG; a wrong suffix refused (exit 2)."""
    import xml.etree.ElementTree as ET
    from conftest import hh
    r = hh("circuit", "draw", "two_cylinders", "--out", tmp_path / "two.svg")
    assert r.returncode == 0, r.stderr
    texts = " ".join(t.text or "" for t in ET.parse(tmp_path / "two.svg").iter() if t.tag.endswith("text"))
    c = load_circuit("two_cylinders")
    for name in [*c.components, *c.nodes, *c.inputs]:
        assert name in texts, name
    assert "63/36 × 400 mm, 200 kg" in texts and "180 bar, 40 l/min at 195" in texts and "20 cm³/rev" in texts
    svg = (tmp_path / "two.svg").read_text()                  # each component its symbol, inside the file
    images = [e for e in ET.parse(tmp_path / "two.svg").iter() if e.tag.endswith("image")]
    assert len(images) == len(c.components) and all(
        next(v for k, v in e.attrib.items() if k.endswith("href")).startswith("data:image/png;base64,") for e in images)
    assert str(tmp_path) not in svg and "/tmp" not in svg
    assert hh("circuit", "draw", "two_cylinders", "--out", tmp_path / "two.png").returncode == 0
    assert (tmp_path / "two.png").read_bytes()[:4] == b"\x89PNG"
    r = hh("circuit", "draw", "two_cylinders", "--out", tmp_path / "two.jpg")
    assert r.returncode == 2 and ".png or a .svg" in r.stderr and not (tmp_path / "two.jpg").exists()
    # a scenario's circuit as it runs it: its faults in red, their windows said
    r = hh("circuit", "draw", "--scenario", CIRCUITS_DIR / "counterbalance_hose_burst" / "scenario.toml", "--out",
           tmp_path / "cb.svg")
    assert r.returncode == 0, r.stderr
    texts = " ".join(t.text or "" for t in ET.parse(tmp_path / "cb.svg").iter() if t.tag.endswith("text"))
    assert "fault: a leak, from 1.5 s" in texts and "fault: burst opens, from 1.5 s" in texts
    red = 0                                                   # the burst's symbol drawn in red, the others black
    for e in ET.parse(tmp_path / "cb.svg").iter():
        if e.tag.endswith("image"):
            href = next(v for k, v in e.attrib.items() if k.endswith("href"))
            rgba = _png_pixels(base64.b64decode(href.split(",", 1)[1]))
            ink = rgba[rgba[..., 3] > 0.5]
            red += bool(((ink[:, 0] > 0.6) & (ink[:, 1] < 0.3)).mean() > 0.9)
    assert red == 1
    # a scenario's closed loop: the controller's block, its law and gains, the measured signal in, the command out
    r = hh("circuit", "draw", "--scenario", CIRCUITS_DIR / "ferreira2004" / "scenario.toml", "--out",
           tmp_path / "loop.svg")
    texts = " ".join(t.text or "" for t in ET.parse(tmp_path / "loop.svg").iter() if t.tag.endswith("text"))
    assert r.returncode == 0 and all(w in texts for w in ("controller: P", "kp = 50", "reference → cyl.x", "cyl.x",
                                                            "valve.command")), texts
    r = hh("circuit", "draw", "lift_platform", "--out", tmp_path / "lp.svg")
    texts = " ".join(t.text or "" for t in ET.parse(tmp_path / "lp.svg").iter() if t.tag.endswith("text"))
    assert r.returncode == 0 and "800 kg, 90°" in texts and texts.count("rod") >= 2      # the rods to the deck


def _png_pixels(data: bytes):
    import io
    import matplotlib.image as mpimg
    return mpimg.imread(io.BytesIO(data), format="png")


@pytest.mark.parametrize("type_name", sorted(TYPES))
def test_every_component_type_has_a_symbol_whose_port_stubs_are_where_its_ports_are(type_name, tmp_path):
    """circuit draw's ISO 1219 symbols (hydrohil.circuits.symbols): every type of the library has one, naming
    exactly its ports, each on the top or bottom edge; in the drawn PNG a stub leaves that edge at the port's
    place (ink within 2 px of it in the edge's rows, none just beside it), where the diagram's line is attached;
    the symbol is ink on a transparent ground."""
    from hydrohil.circuits.symbols import SYMBOLS, render
    sym = render(type_name, tmp_path / "s.png")
    assert set(sym.ports) == set(TYPES[type_name].ports)
    rgba = _png_pixels((tmp_path / "s.png").read_bytes())
    h, w = rgba.shape[:2]
    assert rgba[0, 0, 3] == 0 and 0.02 < (rgba[..., 3] > 0.5).mean() < 0.5
    for port, (side, f) in sym.ports.items():
        rows = rgba[:3] if side == "n" else rgba[-3:]
        x = int(round(f * w))
        assert (rows[:, max(x - 2, 0):x + 3, 3] > 0.5).any(), (port, side, f)
        elsewhere = rows[:, max(x - 12, 0):max(x - 6, 0), 3]      # (a stub, not an edge drawn all along)
        assert not (elsewhere > 0.5).all(), port
    assert SYMBOLS[type_name] is sym


def test_names_inputs_and_tables_are_checked_and_a_circuit_without_states_runs():
    """Component and node names are C identifiers (they name C); an input that is no signal, a signal given
    twice, a bad time or node table: each an error naming the key. A circuit with no pressure node and no state
    (two fixed pressures and an orifice) runs and logs its flow."""
    base = {"src": {"type": "pressure_source", "p": "s", "pressure": "10 bar"}, "tank": {"type": "tank", "p": "t"},
            "o": {"type": "orifice", "a": "s", "b": "t", "area": "1 mm2"}}
    for bad, where, message in (
            ({"my-valve": {"type": "volume", "p": "s", "volume": 1e-3}}, "components.my-valve", "letters, digits"),
            ({"v": {"type": "volume", "p": "node*/x", "volume": 1e-3}}, "components.v.p", "letters, digits")):
        with pytest.raises(InputError, match=f"test.toml: {where}: .*{message}"):
            circuit({**base, **bad})
    for inputs, where, message in (({"o.area": 1e-6}, "inputs.o.area", "not a signal of"),
                                   ({"o": 1.0}, "inputs.o", "not a signal of o"),
                                   ({"o.opening": {"t": [0, "1 bar"], "value": [1, 1]}}, "inputs.o.opening.t",
                                    "s is wanted")):
        with pytest.raises(InputError, match=f"test.toml: {where}: .*{message}"):
            circuit(base, inputs=inputs)
    with pytest.raises(InputError, match="components.o.opening: given here and driven in"):
        circuit({**base, "o": {**base["o"], "opening": 0.5}}, inputs={"o.opening": 1.0})
    with pytest.raises(InputError, match="nodes.s: a node's table has one key"):
        circuit({**base, "v": {"type": "volume", "p": "n", "volume": 1e-3},
                 "o2": {"type": "orifice", "a": "n", "b": "t", "area": "1 mm2"}}, nodes={"s": {"volum": "5 l"}})
    r = simulate_circuit(circuit(base), 0.01)
    assert np.all(r.column("o.q") == pytest.approx(0.61e-6 * math.sqrt(2 * 10e5 / RHO), rel=1e-12))


def test_a_node_without_an_open_path_at_rest_is_reported():
    """Closed-centre valve without leakage: its chambers have no path at rest; their pressure is the initial
    guess, and the run says so."""
    body = {"src": {"type": "pressure_source", "p": "s", "pressure": "100 bar"}, "tank": {"type": "tank", "p": "t"},
            "valve": {"type": "valve_43", "P": "s", "T": "t", "A": "a", "B": "b", "x_max": "1 mm",
                      "area_gradient": "2 mm", "leakage_opening": 0.0, "wn": 600.0},
            "va": {"type": "volume", "p": "a", "volume": "0.1 l"}, "vb": {"type": "volume", "p": "b", "volume": "0.1 l"}}
    with pytest.warns(InputWarning) as rec:
        simulate_circuit(circuit(body), 0.0)
    said = " ".join(str(w.message) for w in rec)
    assert "node a has no open path at rest" in said and "node b has no open path at rest" in said


def test_two_stiff_nodes_coupled_stay_stable_and_are_reported():
    """A pump into a 1 cm3 node, a 20 mm2 orifice to a 0.1 l node with a 1 l accumulator (empty below its 20 bar
    precharge): both nodes are stiff at 0.5 ms and coupled through the orifice. Each slowed to lambda*h = 1.5
    alone, their coupled mode would reach 3 (RK3 alternated between the pressure floor and 112 bar); the
    stiff-node form's Gershgorin rule (hc_node.h) cuts the rows reaching beyond 1.9: no alternation, no floor,
    the end state that of a 64x finer step within 3 % (measured 0.4 %, n1 still stiff at the fine step); and
    circuit show says the pair's common filling is slowed (it is: the fill transient lags the fine run's)."""
    c = circuit({"t": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "n1", "displacement": "10 cm3/rev", "speed": 20.0},
                 "ori": {"type": "orifice", "a": "n1", "b": "n2", "area": "20 mm2"},
                 "acc": {"type": "accumulator", "p": "n2", "gas_volume": "1 l", "precharge": "20 bar"}},
                nodes={"n1": {"volume": "1 cm3"}, "n2": {"volume": "0.1 l"}})
    run = simulate_circuit(c, 1.0, rest=False)
    fine = simulate_circuit(c, 1.0, h=5e-4 / 64, rest=False, every=64)
    n1 = run.column("n1.p")
    assert n1.min() >= 0.0                                             # (before: the floor, -0.99 bar)
    assert np.all(np.diff(n1) > 0)                                    # filling, no alternation
    assert run.column("n2.p")[-1] == pytest.approx(fine.column("n2.p")[-1], rel=0.03)
    s = {x.node: x for x in node_stiffness(c, run)}
    assert s["n1"].coupled_slowed == ("n2",)
    assert "common filling is slowed" in s["n1"].treatment("rk3", 5e-4)


def _platform(**load):
    """A pump of 20 l/min (relief at 150 bar) into the cap sides of a 50/28 x 300 mm and a 40/22 x 250 mm
    cylinder whose rods lift one platform (rod_end), their rod sides to tank through one orifice."""
    q = 20e-3 / 60
    return q, circuit({
        "tank": {"type": "tank", "p": "t"},
        "pump": {"type": "pump", "inlet": "t", "outlet": "a", "displacement": q / 25.0, "speed": 25.0},
        "relief": {"type": "relief_valve", "p": "a", "t": "t", "cracking_pressure": "150 bar",
                   "rated_flow": "30 l/min", "rated_pressure": "160 bar"},
        "c1": {"type": "cylinder", "a": "a", "b": "b", "bore": 0.05, "rod": 0.028, "stroke": 0.3, "rod_end": "deck",
               "dead_volume_a": "0.1 l", "dead_volume_b": "0.1 l"},
        "c2": {"type": "cylinder", "a": "a", "b": "b", "bore": 0.04, "rod": 0.022, "stroke": 0.25,
               "rod_end": "deck", "dead_volume_a": "0.1 l", "dead_volume_b": "0.1 l"},
        "out": {"type": "orifice", "a": "b", "b": "t", "area": "10 mm2"},
        "deck": {"type": "load", "mass": 400.0, "damping": 3000.0, "incline": "90 deg", "x0": 0.02, **load}})


def test_two_cylinders_coupled_to_one_load_move_as_one_body():
    """Mechanical coupling (SPEC §12.3): two cylinders of different bores whose rods drive one platform move it
    at the pump's flow over the sum of their cap areas (closed form), their cap pressure the force balance
    p_a = (c*v + M*g + p_b*(A2 + A2')) / (A1 + A1') with p_b from the orifice law at the rod sides' flow; the
    platform stops at the shorter stroke (0.25 m) and the relief takes the pump's flow."""
    q, c = _platform()
    assert not c.components["c1"].states and c.components["deck"].actuators == ["c1", "c2"]
    with pytest.warns(InputWarning, match="deck is not held at rest"):   # (the pump's flow into held pistons)
        r = simulate_circuit(c, 2.5)
    a1 = math.pi * (0.05 ** 2 + 0.04 ** 2) / 4
    a2 = math.pi * (0.05 ** 2 - 0.028 ** 2 + 0.04 ** 2 - 0.022 ** 2) / 4
    t, v = r.column("t"), r.column("deck.v")
    k = np.searchsorted(t, 1.0)
    assert v[k] == pytest.approx(q / a1, rel=1.5e-11)                      # (measured: 2.8e-12)
    assert np.array_equal(r.column("c1.x"), r.column("deck.x")) and np.array_equal(r.column("c2.v"), v)
    p_b = RHO / 2 * (a2 * v[k] / (0.61 * 10e-6)) ** 2
    p_a = (3000.0 * v[k] + 400.0 * 9.80665 + p_b * a2) / a1
    assert r.column("b.p")[k] == pytest.approx(p_b, rel=1.5e-11)           # (measured: 4.1e-12)
    assert r.column("a.p")[k] == pytest.approx(p_a, rel=1.5e-11)           # (measured: 4.6e-12)
    end = r.column("deck.mode") == 2
    assert end.any() and r.column("deck.x")[-1] == 0.25 and v[-1] == 0.0   # the shorter stroke
    x = r.column("deck.x")
    assert t[np.argmax(end)] == pytest.approx(1.0 + (0.25 - x[k]) / (q / a1), abs=1.2e-3)   # (measured: 0.38 ms)
    assert r.column("relief.mode")[-1] == 1


def test_a_coupled_load_is_checked_where_it_is_written():
    """A coupled cylinder's load keys are its load's; rod_end names a load; a load is driven; its start lies
    within the shortest stroke: each an error naming the file, the component and the key."""
    base = {"tank": {"type": "tank", "p": "t"}}
    cyl = {"type": "cylinder", "a": "a", "b": "t", "bore": 0.05, "rod": 0.028, "stroke": 0.3,
           "dead_volume_a": "0.1 l"}
    src = {"type": "pressure_source", "p": "a", "pressure": "10 bar"}
    for comps, where, message in (
            ({"c": {**cyl, "rod_end": "deck", "mass": 10.0}, "deck": {"type": "load", "mass": 100.0}},
             "components.c.mass", "c's rod drives the load 'deck' (rod_end): its mass is the load's"),
            ({"c": {**cyl, "rod_end": "pump"}, "pump": src}, "components.c.rod_end",
             "'pump' is not a load of this circuit (loads: none"),
            ({"c": {**cyl, "mass": 10.0}, "deck": {"type": "load", "mass": 100.0}}, "components.deck",
             "nothing drives this load: give a cylinder's rod_end = \"deck\""),
            ({"c": {**cyl, "rod_end": "deck"}, "deck": {"type": "load", "mass": 100.0, "x0": "0.4 m"}},
             "components.deck.x0", "within the travel of its cylinders (the shortest stroke, 0.3 m)"),
            ({"c": {**cyl, "rod_end": "deck", "rod_ende": 1}, "deck": {"type": "load", "mass": 100.0}},
             "components.c.rod_ende", "coupling: rod_end"),
            ({"c": {**cyl, "mass": 10.0}, "m": {"type": "motor", "a": "a", "b": "t", "displacement": 1e-5,
                                                "shaft": "c"}}, "components.m.shaft",
             "'c' is not a rotary_load of this circuit (rotary_loads: none"),
            ({"c": {**cyl, "mass": 10.0}, "m": {"type": "motor", "a": "a", "b": "t", "displacement": 1e-5,
                                                "shaft": "drum", "inertia": 0.1}, "drum": {"type": "rotary_load",
                                                                                          "inertia": 1.0}},
             "components.m.inertia", "m's shaft drives the load 'drum' (shaft): its inertia is the load's")):
        comps = {**base, **comps}
        comps.setdefault("pump", src)
        with pytest.raises(InputError, match=f"test.toml: {re.escape(where)}: .*{re.escape(message)}"):
            circuit(comps)
    with pytest.raises(InputError, match="inputs.c1.force: c1's rod drives the load 'deck'"):
        circuit({"tank": {"type": "tank", "p": "t"}, "src": src,
                 "c1": {**cyl, "rod_end": "deck"}, "deck": {"type": "load", "mass": 400.0}},
                inputs={"c1.force": 100.0})


def test_a_load_force_driven_linearly_over_time_and_a_held_drive():
    """A drive with interpolation = "linear" is sampled at each step's start (held over the step, as every
    input): the values at the step times are the straight lines between the points, held after the last; a
    load pushed by a cylinder at a fixed pressure against a force ramped 0 -> F over 1 s follows the quasi-static
    balance x = (p*A1 - F(t))/k of its spring, lagging by the damper's c/k times the ramp's rate (closed
    forms)."""
    from hydrohil.circuits.run import input_table
    p, k, bore, F = 50e5, 1e6, 0.05, 5000.0
    a1 = math.pi * bore ** 2 / 4
    comps = {"tank": {"type": "tank", "p": "t"}, "src": {"type": "pressure_source", "p": "s", "pressure": p},
             "c1": {"type": "cylinder", "a": "s", "b": "t", "bore": bore, "rod": 0.028, "stroke": 0.5,
                    "rod_end": "deck"},
             "deck": {"type": "load", "mass": 50.0, "damping": 2e4, "spring": k, "x0": p * a1 / k}}
    drive = {"t": [0, "0.5 s", 1.5], "value": [0, 0, "5 kN"], "interpolation": "linear"}
    c = circuit(comps, inputs={"deck.force": drive})
    u = input_table(c, 4000, 5e-4)[:, 0]
    t = np.arange(4000) * 5e-4
    expect = np.where(t < 0.5, 0.0, np.where(t < 1.5, F * (t - 0.5), F))         # by hand
    assert np.max(np.abs(u - expect)) < 1e-9
    r = simulate_circuit(c, 2.0)
    tt, x = r.column("t"), r.column("deck.x")
    balance = (p * a1 - np.interp(tt, [0, 0.5, 1.5], [0, 0, F])) / k
    lag = 2e4 / k              # c/k [s]: a ramp's steady lag behind the balance (the held input adds h/2)
    assert np.max(np.abs(x - balance)) == pytest.approx(lag * F / k, rel=0.04)   # (measured: +1.25 %)
    assert x[-1] == pytest.approx((p * a1 - F) / k, rel=3e-14)            # (measured: 7e-15)
    with pytest.raises(InputError, match="inputs.deck.force.interpolation: \"hold\" .* or \"linear\""):
        circuit(comps, inputs={"deck.force": {**drive, "interpolation": "cubic"}})


def test_two_motors_on_one_shaft_turn_as_one_inertia():
    """Rotary coupling (SPEC §12.3): a 10 and a 16 cm3/rev motor whose shafts drive one drum (rotary_load),
    fed in parallel by a pump of constant flow Q, turn at w = 2*pi*Q/(D1 + D2) (closed form); their common
    pressure drop holds the drum's viscous friction and load torque, dp = 2*pi*(c*w + T)/(eta1*D1 + eta2*D2)."""
    q, d1, d2, c_w, torque = 10e-3 / 60, 10e-6, 16e-6, 1.0, 10.0
    c = circuit({"tank": {"type": "tank", "p": "t"},
                 "pump": {"type": "pump", "inlet": "t", "outlet": "a", "displacement": q / 25.0, "speed": 25.0},
                 "relief": {"type": "relief_valve", "p": "a", "t": "t", "cracking_pressure": "200 bar",
                            "rated_flow": "30 l/min", "rated_pressure": "210 bar"},
                 "m1": {"type": "motor", "a": "a", "b": "t", "displacement": d1, "efficiency": 0.9, "shaft": "drum"},
                 "m2": {"type": "motor", "a": "a", "b": "t", "displacement": d2, "shaft": "drum"},
                 "drum": {"type": "rotary_load", "inertia": 0.2, "damping": c_w, "load_torque": torque},
                 "v": {"type": "volume", "p": "a", "volume": "0.5 l"}})
    assert not c.components["m1"].states and c.components["drum"].actuators == ["m1", "m2"]
    r = simulate_circuit(c, 15.0)                 # (its hydraulic spring rings at 15 rad/s, damped in 0.4 s)
    w = 2 * math.pi * q / (d1 + d2)
    assert r.column("drum.w")[-1] == pytest.approx(w, rel=3e-14)              # (measured: 7e-15)
    assert np.array_equal(r.column("m1.w"), r.column("drum.w"))
    dp = 2 * math.pi * (c_w * w + torque) / (0.9 * d1 + d2)
    assert r.column("a.p")[-1] == pytest.approx(dp, rel=2e-13)                # (measured: 7e-14)
    assert r.column("m1.q")[-1] == pytest.approx(d1 * w / (2 * math.pi), rel=3e-14)
    assert abs(r.column("drum.net_torque")[-1]) < 1e-11                       # N.m (measured: 3e-12)


def test_a_43_valve_from_its_catalogue_flow_at_its_rated_drop():
    """The textbook 4/3 valve given as catalogues give it: rated_flow through one edge fully open at rated_drop
    (40 l/min at 35 bar per edge): fully open against a fixed 35 bar across P->A it passes 40 l/min (closed
    form), and it is the valve of the equivalent area gradient Q/(x_max*Cq*sqrt(2*dp/rho)); one form only."""
    def valve(**form):
        return circuit({"src": {"type": "pressure_source", "p": "s", "pressure": "35 bar"},
                        "tank": {"type": "tank", "p": "t"},
                        "v": {"type": "valve_43", "P": "s", "T": "t", "A": "t", "B": "t", "x_max": "1 mm",
                              "wn": 400.0, "command": 1.0, "leakage_opening": 0.0, **form}})
    q = at_start(valve(rated_flow="40 l/min", rated_drop="35 bar"), "v.q_pa")
    assert q == pytest.approx(40e-3 / 60, rel=1e-15)                        # (measured: 2.2e-16)
    gradient = (40e-3 / 60) / (1e-3 * 0.67 * math.sqrt(2 * 35e5 / RHO))
    assert at_start(valve(area_gradient=gradient), "v.q_pa") == pytest.approx(q, rel=1e-15)
    for form in ({}, {"area_gradient": gradient, "rated_flow": "40 l/min", "rated_drop": "35 bar"},
                 {"rated_flow": "40 l/min"}):
        with pytest.raises(InputError, match="components.v: give area_gradient, or the catalogue's rated_flow"):
            valve(**form)


def test_a_load_against_its_force_table_rests_where_the_table_meets_the_piston_force():
    """A load's force_table over the position (a workpiece met at 50 mm, rising to 20 kN at 60 mm, held beyond):
    a cylinder at a fixed 50 bar pushes it there and rests where p*A1 = f(x), x = 50 mm + 10 mm * p*A1/20 kN
    (closed form); the continuous reference rests there too; circuit show lists the table in its units; a table
    of positions not increasing is refused by key."""
    p, bore = 50e5, 0.05
    comps = {"tank": {"type": "tank", "p": "t"}, "src": {"type": "pressure_source", "p": "s", "pressure": p},
             "c1": {"type": "cylinder", "a": "s", "b": "t", "bore": bore, "rod": 0.028, "stroke": 0.3,
                    "rod_end": "press"},
             "press": {"type": "load", "mass": 50.0, "damping": 2e5, "x0": "10 mm",
                       "force_table": {"x": ["0 mm", "50 mm", "60 mm"], "f": [0.0, 0.0, "20 kN"]}}}
    c = circuit(comps)
    assert c.components["press"].tables["force_table"][1][2] == 20e3
    with pytest.warns(InputWarning, match="press is not held at rest"):
        r = simulate_circuit(c, 4.0)                       # (the damper against the table's slope: 0.1 s)
    x_eq = 0.05 + 0.01 * p * math.pi * bore ** 2 / 4 / 20e3
    assert r.column("press.x")[-1] == pytest.approx(x_eq, rel=1e-13)      # (measured: 2.9e-14)
    ref = simulate_circuit(c, 4.0, method="reference")
    assert ref.column("press.x")[-1] == pytest.approx(x_eq, rel=1.5e-10)   # (measured: 4.6e-11, LSODA's)
    from hydrohil.circuits.show import describe, text
    out = text(describe(c, h=5e-4))
    assert "force_table              table: (0 m, 0 N), (0.05 m, 0 N), (0.06 m, 20000 N)" in out
    comps["press"]["force_table"] = {"x": [0.0, 0.06, 0.05], "f": [0.0, 0.0, 1.0]}
    with pytest.raises(InputError, match="components.press.force_table.x: positions increasing"):
        circuit(comps)
    comps["press"]["force_table"] = {"x": [0.0, "3 bar"], "f": [0.0, 1.0]}
    with pytest.raises(InputError, match="components.press.force_table.x: '3 bar' is in Pa, m is wanted"):
        circuit(comps)


def test_a_valves_bare_number_probably_in_another_unit_warns():
    """A spool's wn given as a bare 80 (rad/s: 12.7 Hz, below any valve's) warns as the paper's parameter files
    do; "80 Hz" or a plausible bare number does not."""
    import copy
    import tomllib
    import warnings
    data = tomllib.loads((CIRCUITS_DIR / "two_cylinders" / "circuit.toml").read_text())
    for value, warns in ((80, True), ("80 Hz", False), (600.0, False)):
        d = copy.deepcopy(data)
        d["components"]["valve1"]["wn"] = value
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            circuit_from_dict(d, "my_rig.toml")
        text = [str(w.message) for w in said if issubclass(w.category, InputWarning)]
        assert any("my_rig.toml: components.valve1.wn: 80 rad/s is 12.7 Hz" in t for t in text) == warns, text


def test_a_port_plugged_on_purpose_is_a_node_declared_with_its_volume():
    """A port only one component is at loads when the file declares its node ([nodes.NAME] volume: the plug's
    dead volume), as it did before misspelt nodes were refused; undeclared, it is refused naming the port."""
    import copy
    import tomllib
    data = tomllib.loads((CIRCUITS_DIR / "two_cylinders" / "circuit.toml").read_text())
    plugged = copy.deepcopy(data)
    plugged["components"]["valve2"]["B"] = "plug"          # (its B plugged: a 4/3 valve used as a 3/3)
    with pytest.raises(InputError, match=r"components.valve2.B: node 'plug' connects to nothing else: only valve2.B is "
                                         r"at it; a port plugged on purpose: give its dead volume, \[nodes.plug\]"):
        circuit_from_dict(plugged, "my_rig.toml")
    plugged.setdefault("nodes", {})["plug"] = {"volume": "0.05 l"}
    c = circuit_from_dict(plugged, "my_rig.toml")
    assert c.node_volume("plug") >= 0.05e-3 and "plug" in c.state_nodes


def test_a_run_computes_only_the_columns_asked_for_and_they_are_the_full_runs():
    """``simulate_circuit(..., columns=[...])``: the log holds t, the columns asked for and what the run reads
    itself (the loop's measured signal, its transducers' pressures), each the full run's bit for bit, the others
    not computed (the valve's flows absent, what the sensor read too, the valve's delayed command unless named);
    a column the circuit does not log is named."""
    from hydrohil.circuits.scenario import load_circuit_scenario
    from hydrohil.errors import InputError
    cs = load_circuit_scenario(EXAMPLES / "circuits" / "servo_supply" / "scenario.toml")

    def run(columns=None):
        return simulate_circuit(cs.circuit, 0.3, h=cs.step, method=cs.method, every=3, rest=cs.rest, loop=cs.loop,
                                commands=cs.commands, compiled=cs.compiled, columns=columns)
    full, some = run(), run(["valve.v", "cyl.mode"])
    logged = {"t", "valve.v", "cyl.mode", cs.loop.measure}
    assert logged <= set(some.columns) and not any(k.startswith("valve.q_") for k in some.columns)
    assert "valve.command.seen" in full.columns and "valve.command.seen" not in some.columns   # (named: computed)
    mixed = run(["cyl.friction", "accumulator.mode", "tank.p", "valve.x", "supply.p", "valve.command.seen", "cyl.x"])
    assert {"cyl.friction", "accumulator.mode", "tank.p", "valve.command.seen", "events"} <= set(mixed.columns)
    for name, column in mixed.columns.items():    # (states copied, modes converted, the rest computed: in order)
        assert np.array_equal(column, full.columns[name]), name
    assert set(full.columns) - set(some.columns) - {"t"}                     # (some columns left out)
    assert not any(k.endswith(".sensed") for k in some.columns)
    rig = load_circuit_scenario(EXAMPLES / "circuits" / "ferreira2004" / "scenario.toml")   # (an encoder read)
    read = [simulate_circuit(rig.circuit, 0.05, h=rig.step, loop=rig.loop, rest=rig.rest, compiled=rig.compiled,
                             columns=columns) for columns in (None, ["cyl.x"])]
    assert "cyl.x.sensed" in read[0].columns and "cyl.x.sensed" not in read[1].columns
    assert np.array_equal(read[0].columns["cyl.x"], read[1].columns["cyl.x"])
    for name, column in some.columns.items():
        assert np.array_equal(column, full.columns[name]), name
    with pytest.raises(InputError, match="no column 'valve.flow'"):
        run(["valve.flow"])


def _shuffled_values(c, rng):
    """A copy of circuit ``c`` with every given value (parameters, derived values, tables' points, nodes' own
    volumes, the fluid's) replaced at random, signs and zeros among them; what is not given stays NaN."""
    import copy
    d = copy.deepcopy(c)

    def draw(v):
        if v is None or v != v:
            return v
        return float(rng.choice([0.0, -1.0, 1.0]) * rng.uniform(0.1, 10.0) * (abs(v) or 1.0))
    d.fluid = {k: draw(v) for k, v in d.fluid.items()}
    d.node_volumes = {k: draw(v) for k, v in d.node_volumes.items()}
    for comp in d.components.values():
        comp.values = {k: draw(v) for k, v in comp.values.items()}
        comp.tables = {k: (rng.uniform(-1, 1, len(xs)), rng.uniform(-1, 1, len(fs)))
                       for k, (xs, fs) in comp.tables.items()}
    return d


@pytest.mark.parametrize("name", sorted(p.name for p in CIRCUITS_DIR.iterdir() if (p / "circuit.toml").exists()))
def test_the_generated_text_depends_on_the_structure_only(name):
    """generate()'s text reads no value but what structure() keys on: each example circuit with its values drawn
    anew (of any sign, zeros too; the fixed pressures' order and the [initial] kept, as structure() keys them)
    is the same C text, so one text per structure is made (generated) and compiled; its layout carries each
    circuit's own values."""
    from hydrohil.circuits.generate import Layout, generate, generated, structure
    c = load_circuit(CIRCUITS_DIR / name / "circuit.toml")
    text, lay = generate(c)
    rng = np.random.default_rng(7)
    tried = 0
    for _ in range(40):
        d = _shuffled_values(c, rng)
        if structure(d) != structure(c):         # (the lowest fixed pressure moved to another node)
            continue
        tried += 1
        assert generate(d)[0] == text
        source, dlay = generated(d)
        assert source == text and dlay.circuit is d
        np.testing.assert_array_equal(dlay.values(), Layout(d).values())
        assert dlay.log_columns == lay.log_columns and dlay.outputs == lay.outputs
    assert tried >= 10


def test_a_structure_changes_with_what_the_text_reads():
    """What the text reads of the values is in the key: a bulk modulus given by eq 21 or as a constant, an
    [initial] pressure, which fixed pressure is lowest."""
    from hydrohil.circuits.generate import generate, structure
    c = load_circuit(CIRCUITS_DIR / "ferreira2004" / "circuit.toml")
    import copy
    d = copy.deepcopy(c)
    cyl = d.components["cyl"]
    assert cyl.values["bulk_b"] == cyl.values["bulk_b"]
    cyl.values["bulk_b"] = math.nan
    cyl.values["beta_a"] = cyl.values["beta_b"] = 1.4e9
    assert structure(d) != structure(c) and generate(d)[0] != generate(c)[0]
    e = copy.deepcopy(c)
    e.initial = {**e.initial, "cap": 3e6}
    assert structure(e) != structure(c) and generate(e)[0] != generate(c)[0]
    f = copy.deepcopy(c)
    supply, tank = (f.components[comp] for comp, _ in (f.fixed["supply"], f.fixed["tank"]))
    supply.values["pressure"], tank.values["pressure"] = -1e5, 0.0
    assert structure(f) != structure(c) and generate(f)[0] != generate(c)[0]


def test_a_settled_circuits_states_are_zero_not_subnormal():
    """issue #29: two_cylinders' spools settle under their commands' return to zero and decay through the
    subnormal numbers, where a step cost 5-6x more on Intel CPUs (1829 -> 454 ns a step over 60 s, measured):
    the generated step makes a component's state zero where it would be subnormal, so every state of the run
    is zero or a normal number, and the spools end at exactly 0 after reaching the smallest normal numbers."""
    import sys

    from hydrohil.circuits.run import simulate_circuit
    from hydrohil.circuits.scenario import load_circuit_scenario
    cs = load_circuit_scenario(CIRCUITS_DIR / "two_cylinders" / "scenario.toml", solver="rk3", step=5e-4)
    r = simulate_circuit(cs.circuit, 10.0, h=cs.step, every=1, loop=cs.loop)
    states = [k for k in cs.compiled.layout.states if k in r.columns]
    assert len(states) == 13
    for k in states:
        mag = np.abs(r.columns[k])
        assert not ((mag > 0) & (mag < sys.float_info.min)).any(), k
    for k in ("valve1.x", "valve1.v", "valve2.x", "valve2.v"):
        mag = np.abs(r.columns[k])
        assert mag[-1] == 0.0 and mag[mag > 0].min() < 1e-300, k         # (measured: down to 2.3e-308)
