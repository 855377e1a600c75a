"""`hydrohil circuit linear`: a circuit linearised where its runs start, against closed forms computed here: a
node between two orifices (its time constant from the orifice law's slopes), a closed-in cylinder's hydraulic
resonance sqrt((beta*A1^2/V1 + beta*A2^2/V2)/M), the paper's spool (wn, xi as identified)."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import hh
from hydrohil.circuits.circuit import circuit_from_dict, load_circuit
from hydrohil.circuits.linear import linearise_circuit
from hydrohil.circuits.run import simulate_circuit

FLUID = {"density": 860.0, "bulk_modulus": 1.4e9, "viscosity": 46e-6}


def test_a_node_between_two_orifices_relaxes_at_the_orifice_laws_slope():
    c = circuit_from_dict({"fluid": FLUID, "components": {
        "s": {"type": "pressure_source", "p": "s", "pressure": "100 bar"}, "t": {"type": "tank", "p": "t"},
        "o1": {"type": "orifice", "a": "s", "b": "n", "area": "1 mm2"},
        "o2": {"type": "orifice", "a": "n", "b": "t", "area": "2 mm2"},
        "v": {"type": "volume", "p": "n", "volume": "1 l"}}}, "test.toml")
    lin = linearise_circuit(c)
    p = lin.x0[0]
    assert p == pytest.approx(100e5 / 5, rel=1e-9)                 # the series orifices' divider: 1/(1 + 2^2)
    k1 = 0.61 * 1e-6 * math.sqrt(2 / 860.0)
    lam = -1.4e9 / 1e-3 * (k1 / (2 * math.sqrt(100e5 - p)) + 2 * k1 / (2 * math.sqrt(p)))
    assert lin.eigenvalues[0] == pytest.approx(lam, rel=1e-9)      # (measured: 2e-10)
    assert lin.moving() == [] and lin.modes()[0]["time_constant_s"] == pytest.approx(-1 / lam, rel=1e-9)


def test_a_closed_in_cylinder_resonates_at_the_hydraulic_natural_frequency():
    """A 63/36 cylinder with 200 kg held by a closed-centre valve with leakage (its chambers at rest): the
    complex pair at sqrt((beta*A1^2/V1 + beta*A2^2/V2)/M) with V the chambers' volumes at x0 (measured: 1e-6
    relative, the valve's leakage), damped by the viscous friction c/(2*M*w) (measured: 5e-4 more, the leakage)."""
    bore, rod, x0, m, c_v = 0.063, 0.036, 0.05, 200.0, 5000.0
    c = circuit_from_dict({"fluid": FLUID, "components": {
        "s": {"type": "pressure_source", "p": "s", "pressure": "150 bar"}, "t": {"type": "tank", "p": "t"},
        "v": {"type": "valve_43", "P": "s", "T": "t", "A": "a", "B": "b", "x_max": "1 mm", "area_gradient": "4 mm",
              "wn": 500.0},
        "cyl": {"type": "cylinder", "a": "a", "b": "b", "bore": bore, "rod": rod, "stroke": 0.4, "mass": m,
                "damping": c_v, "x0": x0, "dead_volume_a": "0.3 l", "dead_volume_b": "0.3 l"}}},
        "test.toml")
    c.initial = {"a": 50e5, "b": 50e5 * (bore ** 2) / (bore ** 2 - rod ** 2)}       # the piston balanced
    lin = linearise_circuit(c)
    a1, a2 = math.pi * bore ** 2 / 4, math.pi * (bore ** 2 - rod ** 2) / 4
    v1, v2 = 0.3e-3 + a1 * x0, 0.3e-3 + a2 * (0.4 - x0)
    w = math.sqrt((1.4e9 * a1 ** 2 / v1 + 1.4e9 * a2 ** 2 / v2) / m)
    pairs = sorted((md for md in lin.modes() if "damping" in md), key=lambda md: md["natural_frequency_rad_s"])
    assert pairs[0]["natural_frequency_rad_s"] == pytest.approx(w, rel=3e-6)             # 423 rad/s
    assert pairs[0]["damping"] == pytest.approx(c_v / (2 * m * w), rel=2e-3)              # + the leakage's share
    assert pairs[1]["natural_frequency_rad_s"] == pytest.approx(500.0, rel=1e-9) and pairs[1]["damping"] == \
        pytest.approx(0.7, rel=1e-9)                                                       # the spool: wn, xi


def test_circuit_linear_as_a_user_types_it(tmp_path):
    """The paper's rig as a circuit: the spool's pair at its identified 1007 rad/s, 0.48 and the hydraulic
    resonance (stick mode: the seals' bristles add stiffness); --json and --out .json/.npz; a bad --out exits 2."""
    run = lambda *a: subprocess.run([sys.executable, "-m", "hydrohil.cli", "circuit", "linear", *map(str, a)],  # noqa: E731
                                    capture_output=True, text=True)
    r = run("ferreira2004", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    pairs = sorted((m["natural_frequency_rad_s"], m["damping"]) for m in d["modes"] if "damping" in m)
    assert pairs[-1] == pytest.approx((1007.01, 0.48), rel=1e-7)
    assert pairs[0] == pytest.approx((663.41, 0.04454), rel=2e-3)      # (measured: 663.406 rad/s, damping 0.04454)
    assert d["states"] == ["cap.p", "rod.p", "valve.x", "valve.v", "cyl.x", "cyl.v", "cyl.z"]
    assert run("ferreira2004", "--out", tmp_path / "l.npz").returncode == 0
    z = np.load(tmp_path / "l.npz")
    assert z["A"].shape == (7, 7) and list(z["inputs"]) == ["valve.command"]
    bad = run("ferreira2004", "--out", tmp_path / "l.txt")
    assert bad.returncode == 2 and "a .json or .npz file" in bad.stderr
    assert "oscillation" in run("two_cylinders").stdout
    assert load_circuit("two_cylinders").initial          # (its [initial] holds the supply off its rest: said)
    assert "not an equilibrium: supply.p" in run("two_cylinders").stdout
    from conftest import EXAMPLES                          # the loop's poles leave the valve's delay out: said
    r = run("--scenario", EXAMPLES / "circuits" / "ferreira2004" / "scenario.toml", "--json")
    assert json.loads(r.stdout)["closed_loop"]["left_out"] == ["valve.command's input delay, 0.7625 ms"]


def test_a_loops_closed_poles_predict_its_step_response(tmp_path):
    """A pump into a node bled through an orifice under a reverse-acting P loop on the pressure: linearised at
    t = 1 s of its run (the loop holding the node at 148 bar, its P offset above the 50 bar reference), the
    closed loop's pole (-152 1/s) predicts the decay of the simulated response to a 0.5 bar step of the
    reference, measured here from the run itself (its log slope: -156.5 1/s; the law is sampled at 0.5 ms,
    the model takes it continuous)."""
    from test_circuit_scenarios import BLEED
    (tmp_path / "circuit.toml").write_text(BLEED)
    scen = tmp_path / "p.toml"
    scen.write_text('circuit = "circuit.toml"\nduration = 1.2\n[controller]\ntype = "p"\nmeasure = "supply.p"\n'
                    'command = "bleed.opening"\naction = "reverse"\nkp = 6e-8\n'
                    '[reference]\nt = [0, 1.0]\nvalue = ["50 bar", "50.5 bar"]\n')
    from hydrohil.circuits.linear import linearise_circuit, run_state
    from hydrohil.circuits.scenario import load_circuit_scenario
    cs = load_circuit_scenario(scen)
    lin = linearise_circuit(cs.circuit, h=cs.step, loop=cs.loop, state=run_state(cs, 0.999), at="t = 0.999 s")
    assert not lin.moving()                                     # the loop holds: an equilibrium
    (pole,) = [complex(*e) for e in lin.closed["eigenvalues"]]
    assert pole.imag == 0 and pole.real < 0
    open_pole = lin.eigenvalues[0].real
    assert pole.real < 3 * open_pole                            # the loop makes it faster than the bleed alone
    res = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    t, p = res.columns["t"], res.columns["supply.p"]
    final = p[-1]
    after = (t > 1.0 + 2e-3) & (t < 1.0 + 4 / -pole.real)      # the exponential's first four time constants
    slope = np.polyfit(t[after], np.log(np.abs(final - p[after])), 1)[0]
    assert slope == pytest.approx(pole.real, rel=0.09)
    r = hh("circuit", "linear", "--scenario", scen, "--at", "0.999")
    assert r.returncode == 0 and "closed loop (p on supply.p -> bleed.opening" in r.stdout


def test_a_pid_loops_poles_are_the_pi_loops_and_its_filters_when_kd_vanishes(tmp_path):
    """The PID law's closed-loop matrix (states x, the integral, the filtered derivative) against the PI
    law's: with kd -> 0 its poles are the PI loop's and the derivative filter's -1/tf; with kd > 0 one more pole
    moves, none at the filter's."""
    from test_circuit_scenarios import BLEED
    from hydrohil.circuits.linear import run_state
    from hydrohil.circuits.scenario import load_circuit_scenario
    (tmp_path / "circuit.toml").write_text(BLEED)

    def poles(kind, extra):
        scen = tmp_path / f"{kind}.toml"
        scen.write_text('circuit = "circuit.toml"\nduration = 1.0\n[controller]\n'
                        f'type = "{kind}"\nmeasure = "supply.p"\ncommand = "bleed.opening"\naction = "reverse"\n'
                        f'kp = 6e-8\nki = 1e-6\n{extra}[reference]\nt = [0]\nvalue = ["50 bar"]\n')
        cs = load_circuit_scenario(scen)
        lin = linearise_circuit(cs.circuit, h=cs.step, loop=cs.loop, state=run_state(cs, 0.9))
        return np.array([complex(*e) for e in lin.closed["eigenvalues"]])
    pi = poles("pi", "")
    vanishing = poles("pid", "kd = 1e-30\ntf = 0.002\n")
    assert np.allclose(np.sort_complex(vanishing), np.sort_complex(np.append(pi, -1 / 0.002)), rtol=1e-9)
    with_d = poles("pid", "kd = 1e-9\ntf = 0.002\n")
    assert len(with_d) == 3 and np.all(with_d.real < 0) and np.min(np.abs(with_d + 500.0)) > 1.0
