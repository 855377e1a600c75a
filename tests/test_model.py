"""Physical sanity and mode transitions of the hybrid model."""

import numpy as np
import pytest

from hydrohil.models.layout import (AT_EXTEND, AT_RETRACT, FREE, P1, P2, SLIP_NEG, SLIP_POS, STICK, XP, VP)
from hydrohil.models.linear import linear_model
from hydrohil.models.valve import closed_port_pressures
from hydrohil.parameters import load_parameters
from hydrohil.simulation.loop import HybridPlant


def run(plant, u, n):
    travel, fric = [], []
    for _ in range(n):
        out = plant.step(u)
        travel.append(int(out[9]))
        fric.append(int(out[10]))
    return np.array(travel), np.array(fric)


def test_positive_spool_extends_negative_retracts(paper):
    plant = HybridPlant(paper, xp=0.09)
    run(plant, 0.3, 100)
    assert plant.y[VP] > 0.01
    plant = HybridPlant(paper, xp=0.09)
    run(plant, -0.3, 100)
    assert plant.y[VP] < -0.01


def test_closed_ports_reach_eq5_equilibrium():
    # a 50 kN load (> Ps*A1 = 8.8 kN) pins the piston at the retract stop: both chambers are closed volumes
    # and must settle at the closed-port pressures of eq 5 for any spool position
    prm = load_parameters("ferreira2004", {"load.gravity_direction": 0, "cylinder.g_lkc": 0.0, "load.force": 5e4})
    plant = HybridPlant(prm, xp=0.0, p1=0.0, p2=0.0)
    for xs in (0.0, 0.02, -0.03):
        plant.reset(xp=0.0, xs=xs, p1=1e6, p2=3e6)
        travel, _ = run(plant, xs, 4000)
        assert (travel == AT_RETRACT).all()
        r1, r2 = closed_port_pressures(xs, prm.valve.k, prm.valve.kt)
        assert plant.y[P1] == pytest.approx(r1 * prm.supply.ps, rel=1e-11)     # measured: < 5e-13
        assert plant.y[P2] == pytest.approx(r2 * prm.supply.ps, rel=1e-11)


def test_mass_conservation_in_closed_chamber():
    """Valve sealed (all pseudo-sections zero), no leakage, constant bulk modulus: an external force
    compresses chamber 1; beta*ln(V0/V) must equal the pressure rise (dP = -beta dV/V)."""
    prm = load_parameters("ferreira2004", {
        "valve.k": [0, 0, 0, 0, 0], "valve.kt": [0, 0, 0, 0, 0], "cylinder.g_lkc": 0.0,
        "cylinder.bulk_modulus": "constant", "load.gravity_direction": 0, "load.force": 2000.0})
    plant = HybridPlant(prm, h=5e-4, xp=0.09, p1=1e6, p2=1e6)
    v0 = prm.cylinder.v01 + prm.cylinder.a1 * 0.09
    run(plant, 0.0, 2000)
    v = prm.cylinder.v01 + prm.cylinder.a1 * plant.y[XP]
    assert plant.y[XP] < 0.09
    assert plant.y[P1] - 1e6 == pytest.approx(prm.cylinder.beta1 * np.log(v0 / v), rel=1e-4)


def test_hits_stop_then_leaves_it(paper):
    plant = HybridPlant(paper, xp=0.17)
    travel, _ = run(plant, 0.5, 400)
    assert AT_EXTEND in travel and plant.y[XP] == paper.cylinder.stroke and plant.y[VP] == 0.0
    travel, _ = run(plant, -0.5, 400)
    assert travel[-1] == FREE and plant.y[XP] < paper.cylinder.stroke - 1e-3


def test_stick_then_breakaway_and_reverse():
    # with the valve centred, the closed-port pressures push the rod in (the paper's reason for
    # x̄s0 = 0.009); a load force cancels that net force so the piston can rest
    base = load_parameters("ferreira2004", {"load.gravity_direction": 0})
    r1, r2 = closed_port_pressures(0.0, base.valve.k, base.valve.kt)
    f0 = base.supply.ps * (r1 * base.cylinder.a1 - r2 * base.cylinder.a2)
    prm = load_parameters("ferreira2004", {"load.gravity_direction": 0, "load.force": float(f0)})
    plant = HybridPlant(prm, xp=0.09)
    _, fric = run(plant, 0.0, 200)
    assert (fric == STICK).all() and abs(plant.y[VP]) < 1e-4   # at rest: stuck
    _, fric = run(plant, 0.2, 400)
    assert SLIP_POS in fric                                       # breaks away forwards
    _, fric = run(plant, -0.2, 600)
    i_neg = np.argmax(fric == SLIP_NEG)
    assert i_neg > 0 and STICK in fric[:i_neg]                    # reversal passes through stick


def test_per_step_api_matches_compiled_loop():
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    from conftest import EXAMPLES
    sc = load_scenario(EXAMPLES / "sine_open_loop.toml", duration=1.0)
    res = run_scenario(sc)
    plant = HybridPlant(sc.params, h=sc.scenario.solver.step, xp=sc.scenario.initial.xp)
    xs = [plant.step(u)[5] for u in sc.scenario.commands()[:-1]]
    np.testing.assert_array_equal(np.array(xs), res.column("xp")[1:])


def test_linear_model_eq20(paper):
    lm = linear_model(paper)
    ev = lm.eigenvalues
    assert np.sum(np.abs(ev) < 1e-9) == 1                 # the position integrator
    assert all(e.real < 0 for e in ev if abs(e) > 1e-9)   # the rest is stable
    assert 20 < lm.natural_frequency / (2 * np.pi) < 130   # hydraulic resonance inside Fig 7's 1-130 Hz
    assert 0 < lm.damping < 1
    a = lm.acceleration_amplitude([5, lm.natural_frequency / (2 * np.pi), 300])
    assert a[1] > a[0] and a[1] > a[2]


def test_divergence_reports_time_mode_state():
    from hydrohil.errors import SimulationDiverged
    prm = load_parameters("ferreira2004", {"load.mass": 1.0})
    plant = HybridPlant(prm, h=5e-3, solver="euler", xp=0.09)   # a 1 kg load: far outside Euler's stable region
    with pytest.raises(SimulationDiverged) as ei:
        for k in range(500):
            plant.step(0.3 * np.sin(2 * np.pi * 0.5 * k * 5e-3))
    msg = str(ei.value)
    assert "diverged at t =" in msg and "travel=" in msg and "xp=" in msg
