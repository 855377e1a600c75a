"""Frequency responses of any circuit (issue #27: freqresp where it applies): stepped sines on the generated
loop beside the linearised circuit, checked against a closed form computed here and against each other."""

import json
import math

import numpy as np
import pytest

from conftest import EXAMPLES, hh
from hydrohil.circuits.scenario import load_circuit_scenario
from hydrohil.freqresp import circuit_freqresp

RHO, BETA = 860.0, 1.4e9
CIRCUIT = """
name = "lag"
[fluid]
density = 860.0
bulk_modulus = 1.4e9
[components.src]
type = "pressure_source"
p = "s"
pressure = "100 bar"
[components.tank]
type = "tank"
p = "t"
[components.inlet]
type = "orifice"
a = "s"
b = "n"
area = "1 mm2"
[components.outlet]
type = "orifice"
a = "n"
b = "t"
area = "1 mm2"
[nodes.n]
volume = "0.5 l"
[inputs]
"inlet.opening" = 0.5
"""


def test_a_node_between_two_orifices_is_the_first_order_lag_of_its_closed_form(tmp_path):
    """The node between an orifice opened 0.5 +- 0.005 and a fixed one: at rest k*u*sqrt(ps - p) = k*sqrt(p),
    p0 = ps*u^2/(1 + u^2); small signals dp/du = (dq1/du)/(C*jw + g1 + g2) with C = V/beta, g = dq/d(dp), held
    over each step (zero-order hold). The stepped sines of the nonlinear model and the linearised circuit both
    follow it."""
    (tmp_path / "circuit.toml").write_text(CIRCUIT)
    (tmp_path / "s.toml").write_text('circuit = "circuit.toml"\nduration = 1.0\n')
    cs = load_circuit_scenario(tmp_path / "s.toml")
    s = circuit_freqresp(cs, tmp_path / "out", fmin=1.0, fmax=50.0, points=4, loops=("open",), signal="n.p",
                         input_="inlet.opening", u_amplitude=0.005)
    ps, u, k = 100e5, 0.5, 0.61 * 1e-6 * math.sqrt(2 / RHO)
    p0 = ps * u ** 2 / (1 + u ** 2)
    dq_du = k * math.sqrt(ps - p0)
    g1, g2 = k * u / (2 * math.sqrt(ps - p0)), k / (2 * math.sqrt(p0))
    c = 0.5e-3 / BETA
    rows = [r.split(",") for r in (tmp_path / "out" / "freqresp.csv").read_text().splitlines()[1:]]
    h = cs.step
    for r in rows:
        f = float(r[1])
        w = 2 * math.pi * f
        g = dq_du / (c * 1j * w + g1 + g2) * (1 - np.exp(-1j * w * h)) / (1j * w * h)
        assert float(r[4]) == pytest.approx(20 * math.log10(abs(g)), abs=5e-9), f     # linearised (measured: 1.2e-9)
        assert float(r[5]) == pytest.approx(math.degrees(np.angle(g)), abs=2e-8)      # (measured: 4.5e-9 deg)
        # the nonlinear model at RK3's fixed 0.5 ms (its discretisation: 0.02 dB and 0.014 deg at 50 Hz)
        assert float(r[2]) == pytest.approx(20 * math.log10(abs(g)), abs=0.06), f
        assert float(r[3]) == pytest.approx(math.degrees(np.angle(g)), abs=0.05)
    assert s["loops"]["open"]["unconverged"] == 0


@pytest.mark.slow
def test_the_motor_speed_loop_measured_and_linear_agree_from_the_command_line(tmp_path):
    """`hydrohil freqresp` on examples/circuits/motor_speed: the PI speed loop around its 600 rpm (the reference's
    last value, reached first) and the valve-to-speed open loop at rest; the stepped sines of the nonlinear model
    agree with the linearised circuit and its sampled law (closed below the bandwidth, open over the band)."""
    r = hh("freqresp", EXAMPLES / "circuits" / "motor_speed" / "scenario.toml", "--out", tmp_path, "--points", "6")
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "freqresp.json").read_text())
    closed, opened = s["loops"]["closed"], s["loops"]["open"]
    assert closed["unconverged"] == 0 and opened["unconverged"] == 0
    assert 9.0 < closed["bandwidth_hz"] < 13.0                              # (measured: 11.1 Hz)
    assert closed["max_gain_gap_db_below_bandwidth"] < 0.06                 # (measured: 0.02 dB, 0.3 deg)
    assert closed["max_phase_gap_deg_below_bandwidth"] < 1.0
    assert opened["max_gain_gap_db"] < 0.4 and opened["max_phase_gap_deg"] < 8.0   # (measured: 0.13 dB, 2.7 deg)
    assert s["closed"]["around"] == pytest.approx(600 * 2 * math.pi / 60) and s["open"]["input"] == "valve.command"
    assert (tmp_path / "bode.png").read_bytes()[:4] == b"\x89PNG"
    bad = hh("freqresp", EXAMPLES / "circuits" / "motor_speed" / "scenario.toml", "--out", tmp_path / "b",
             "--loop", "open", "--input", "motor.nope")
    assert bad.returncode == 2 and "--input" in bad.stderr and "valve.command" in bad.stderr
    bad = hh("freqresp", EXAMPLES / "fig11_p_control.toml", "--out", tmp_path / "c", "--signal", "motor.w")
    assert bad.returncode == 2 and "names no circuit" in bad.stderr
