"""Stepped-sine frequency responses of the nonlinear model against the linear model's prediction."""

import json

import numpy as np
import pytest

from conftest import EXAMPLES, hh
from hydrohil.freqresp import freqresp
from hydrohil.simulation.scenario import load_scenario


def test_small_amplitude_closed_loop_agrees_with_the_linear_model(tmp_path):
    sc = load_scenario(EXAMPLES / "fig11_p_control.toml")
    s = freqresp(sc, tmp_path, fmin=0.5, fmax=8.0, points=7, loops=("closed",))["loops"]["closed"]
    assert s["unconverged"] == 0 and 2.5 < s["bandwidth_hz"] < 4.0            # measured 3.2 Hz
    assert s["max_gain_gap_db_below_bandwidth"] < 0.4                          # measured 0.12 dB
    assert s["max_phase_gap_deg_below_bandwidth"] < 5.0                        # measured 1.7°


def test_large_amplitude_shows_where_the_linear_model_fails(tmp_path):
    sc = load_scenario(EXAMPLES / "fig11_p_control.toml")
    freqresp(sc, tmp_path, fmin=1.0, fmax=30.0, points=3, amplitude=0.02, loops=("closed",), workers=1)
    rows = [r.split(",") for r in (tmp_path / "freqresp.csv").read_text().splitlines()[1:]]
    gap = {float(r[1]): abs(float(r[2]) - float(r[4])) for r in rows}
    assert gap[1.0] < 0.5 and max(gap.values()) > 2.0        # measured 0.3 dB at 1 Hz, 4.5 dB near 30 Hz


def test_points_are_deterministic_whatever_the_threads(tmp_path):
    sc = load_scenario(EXAMPLES / "fig12_steps_ramps.toml")
    a = freqresp(sc, tmp_path / "a", fmin=1.0, fmax=10.0, points=3, workers=1)
    b = freqresp(sc, tmp_path / "b", fmin=1.0, fmax=10.0, points=3, workers=4)
    assert a["loops"] == b["loops"]
    assert (tmp_path / "a" / "freqresp.csv").read_text() == (tmp_path / "b" / "freqresp.csv").read_text()


def test_freqresp_cli(tmp_path):
    r = hh("freqresp", EXAMPLES / "controllers" / "fig11_pi.toml", "--out", tmp_path, "--points", "4", "--fmax", "10")
    assert r.returncode == 0, r.stderr
    assert "closed loop: 4 points" in r.stdout and (tmp_path / "bode.png").stat().st_size > 20_000
    data = json.loads((tmp_path / "freqresp.json").read_text())
    assert set(data["loops"]) == {"closed", "open"}
    lines = (tmp_path / "freqresp.csv").read_text().splitlines()
    assert len(lines) == 9 and lines[0].startswith("loop,freq_hz,gain_db,phase_deg,linear_gain_db")
    bad = hh("freqresp", EXAMPLES / "fig11_p_control.toml", "--out", tmp_path / "x", "--fmax", "600")
    assert bad.returncode == 2 and "quarter of the sample rate" in bad.stderr
    bad = hh("freqresp", EXAMPLES / "controllers" / "fig11_python_pi.toml", "--out", tmp_path / "y")
    assert bad.returncode == 2 and "controller.type" in bad.stderr
    assert np.isfinite(float(lines[1].split(",")[2]))


@pytest.mark.parametrize("name", ["fig11_pi.toml", "fig12_pressure_feedback.toml"])
def test_the_prediction_holds_for_integral_and_pressure_feedback(tmp_path, name):
    sc = load_scenario(EXAMPLES / "controllers" / name)
    s = freqresp(sc, tmp_path, fmin=0.5, fmax=5.0, points=4, loops=("closed",))["loops"]["closed"]
    assert s["max_gain_gap_db_below_bandwidth"] < 0.75 and s["max_phase_gap_deg_below_bandwidth"] < 7.5  # ~0.25 dB, 2.6°


def test_points_at_an_end_stop_are_left_out_not_fatal(tmp_path):
    sc = load_scenario(EXAMPLES / "fig11_p_control.toml")
    s = freqresp(sc, tmp_path, fmin=0.5, fmax=3.0, points=3, u_amplitude=0.3, loops=("open",))["loops"]["open"]
    assert 1 <= s["unconverged"] < 3 and np.isfinite(s["max_gain_gap_db"])       # 0.5 Hz at ±0.3 ū hits a stop
    json.loads((tmp_path / "freqresp.json").read_text())                          # valid JSON (no NaN)
    assert "reached an end stop" in (tmp_path / "freqresp.csv").read_text()


def test_bad_amplitude_and_gain_are_named(tmp_path):
    r = hh("freqresp", EXAMPLES / "fig11_p_control.toml", "--out", tmp_path, "--amplitude", "0")
    assert r.returncode == 2 and "--amplitude" in r.stderr
    r = hh("controller", "--kp", "-5", "--link-timeout", "1")
    assert r.returncode == 2 and "--kp" in r.stderr and "Traceback" not in r.stderr
