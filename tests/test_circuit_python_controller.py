"""A user's Python controller on a circuit (issue #27 item 5: the paper's `fig11_python_pi` on the generated
code): ``[controller] type = "python"`` is called back by the generated loop each step with a
:class:`hydrohil.control.Measurement`; checked against the controller's rule computed here from the run's own
log, in the continuous reference, in lock-step HIL on both plants, and its failures named."""

import math

import numpy as np
import pytest

from conftest import EXAMPLES, Xoshiro
from hydrohil.circuits.run import simulate_circuit
from hydrohil.circuits.scenario import load_circuit_scenario
from hydrohil.errors import ControllerError, InputError

CIRCUIT = EXAMPLES / "circuits" / "ferreira2004" / "circuit.toml"
CONTROLLER = '''
import math

class PI:
    """a PI on the sensed position with a little load-pressure feedback; counts its calls"""
    def __init__(self, kp=40.0, ki=100.0, kpl=1e-8):
        self.kp, self.ki, self.kpl, self.i, self.t, self.times = kp, ki, kpl, 0.0, None, []

    def __call__(self, m):
        self.times.append(m.t)
        assert math.isnan(m.ps) and math.isnan(m.pt) and m.status == 0
        e = m.x_ref - m.x
        dt = 0.0 if self.t is None else m.t - self.t
        self.t = m.t
        self.i += self.ki * e * dt
        return self.kp * e + self.i - self.kpl * (m.p1 - 0.5 * m.p2)

def fails(m):
    if m.t >= 0.25:
        raise RuntimeError("sensor cable unplugged")
    return 0.0

def nan(m):
    return float("nan") if m.t >= 0.1 else 0.0
'''


def scenario(tmp_path, callable_="ctl.py:PI", duration=1.5, extra="", options="options = { kp = 40.0 }\n"):
    (tmp_path / "ctl.py").write_text(CONTROLLER)
    f = tmp_path / "scenario.toml"
    f.write_text(f'circuit = "{CIRCUIT}"\nduration = {duration}\n[set]\n"cyl.x0" = "30 mm"\n'
                 f'[controller]\ntype = "python"\ncallable = "{callable_}"\n{options}'
                 'measure = "cyl.x"\ncommand = "valve.command"\nsensor_resolution = "1 um"\n'
                 'load_pressure = "cyl"\npressure_range = "50 bar"\npressure_resolution = "0.5 bar"\n' + extra +
                 '[reference]\nt = [0.0, 0.2, 0.2, 1.5]\nvalue = ["30 mm", "30 mm", "100 mm", "100 mm"]\n'
                 'interpolation = "linear"\n')
    return f


def test_every_command_is_the_controllers_rule_on_what_it_read(tmp_path):
    """Each step's command is the user's PI computed here from the run's log: the encoder's reading, the
    reference, the chambers through 50 bar transducers of 0.5 bar (clamped to [0, 50 bar], then to whole
    quanta: both act in this run), t = k·h, the integral over the steps, clamped to the valve's range (to
    1e-12), the last row's too (called at every row's instant, as the core's log has it); a second run starts
    from a fresh instance (the same run)."""
    cs = load_circuit_scenario(scenario(tmp_path))
    runs = [simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop) for _ in range(2)]
    r = runs[0]
    e = r.column("cyl.x.reference") - r.column("cyl.x.sensed")
    p1, p2 = (np.floor(np.clip(r.column(c), 0.0, 5e6) / 5e4 + 0.5) * 5e4 for c in ("cap.p", "rod.p"))
    assert np.max(r.column("cap.p")) > 5.2e6 and np.max(np.abs(p1 - r.column("cap.p"))) > 1e4   # (both act)
    u, i = np.empty(len(e)), 0.0
    for k in range(len(u)):
        i += 100.0 * e[k] * (cs.step if k else 0.0)
        u[k] = min(max(40.0 * e[k] + i - 1e-8 * (p1[k] - 0.5 * p2[k]), -1.0), 1.0)
    assert np.max(np.abs(u - r.column("valve.command"))) < 1e-12
    assert np.max(np.abs(u)) == 1.0 and np.max(np.abs(1e-8 * p1)) > 0.01     # (its clamp and pressures act)
    assert np.array_equal(runs[0].column("cyl.x"), runs[1].column("cyl.x"))
    assert cs.loop.controller.times == [k * cs.step for k in range(len(u))]
    assert abs(r.column("cyl.x")[-1] - 0.1) < 2e-3            # (it tracks: 100 mm, measured 0.77 mm off)


READER = '''
class Reads:
    """a P law on the sensed position that keeps what it read of the pressures"""
    def __init__(self):
        self.read = []

    def __call__(self, m):
        self.read.append((m.p1, m.p2, m.ps, m.pt))
        return 40.0 * (m.x_ref - m.x)
'''


def transducers(columns, sigma, g, full_scale=5e6, quantum=5e4):
    """What four transducers read of ``columns`` (rows x 4) at each row: the value plus sigma times a normal sample,
    four drawn a row (two Box-Muller pairs of the xoshiro256** ``g``: the rig's p1, p2, ps, pt), clamped to
    [0, full scale], to whole quanta (sensors.c's model, computed here)."""
    out = np.empty_like(columns)
    for k, row in enumerate(columns):
        z = []
        for _ in range(2):
            r = math.sqrt(-2.0 * math.log(g.uniform()))
            a = 6.283185307179586 * g.uniform()
            z += [r * math.cos(a), r * math.sin(a)]
        v = np.clip(row + sigma * np.array(z), 0.0, full_scale)
        out[k] = np.floor(v / quantum + 0.5) * quantum
    return out


def test_it_reads_the_supply_and_the_tank_through_noisy_transducers(tmp_path):
    """supply_node and tank_node: a user's controller gets ps and pt (NaN without them), read through the loop's
    transducers as the chambers are; pressure_noise (0.3 bar) draws four normal samples a row (the rig's draw)
    from the stream of pressure_seed (11), or without one from a stream of the sensor's seed apart from the
    sensor's own noise (its stream 2^30; the sensor here noisy too): every reading the run gave is the model
    computed here on the run's own columns, noise from xoshiro256** and Box-Muller written apart from the core,
    the last row's included."""
    (tmp_path / "reads.py").write_text(READER)
    for seed, g in (("pressure_seed = 11\n", lambda: Xoshiro(11)),
                    ('sensor_noise = "2 um"\nsensor_seed = 5\n', lambda: Xoshiro.stream(5, 1 << 30))):
        cs = load_circuit_scenario(scenario(tmp_path, callable_="reads.py:Reads", duration=0.5, options="",
                                            extra='supply_node = "supply"\ntank_node = "tank"\n'
                                                  'pressure_noise = "0.3 bar"\n' + seed))
        r = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
        read = np.array(cs.loop.controller.read)
        truth = np.column_stack([r.column(c) for c in ("cap.p", "rod.p", "supply.p", "tank.p")])
        assert read.shape == truth.shape == (1001, 4)
        assert np.array_equal(read, transducers(truth, 3e4, g()))
    noiseless = transducers(truth, 0.0, g())
    assert np.count_nonzero(read[:, :2] != noiseless[:, :2]) > 200           # (the noise acts on the chambers)
    assert np.all(read[:, 2] == 5e6)                                       # (70 bar beyond a 50 bar full scale)
    assert 0 < np.count_nonzero(read[:, 3]) < 1001                         # (the tank's 0 Pa, noise clamped at 0)


def test_the_reference_solver_calls_it_at_the_same_instants(tmp_path):
    """The continuous reference runs the user's controller at each row's instant too (t = k·h, once each):
    its piston within 15 µm RMS of the fixed step's (measured 4.8 µm)."""
    cs = load_circuit_scenario(scenario(tmp_path, duration=1.0))
    fixed = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    ref = simulate_circuit(cs.circuit, cs.duration, h=cs.step, method="reference", loop=cs.loop)
    assert cs.loop.controller.times == [k * cs.step for k in range(cs.n_steps + 1)]
    rms = math.sqrt(np.mean((fixed.column("cyl.x") - ref.column("cyl.x")) ** 2))
    assert rms < 1.5e-5, rms


@pytest.mark.parametrize("name, message", [("fails", r"t = 0\.25 s .*RuntimeError: sensor cable unplugged"),
                                           ("nan", r"returned nan at t = 0\.1 s")])
def test_a_failing_controller_stops_the_run_naming_the_time(tmp_path, name, message):
    """A controller that raises or returns NaN stops the run: ControllerError with the time and its error."""
    cs = load_circuit_scenario(scenario(tmp_path, f"ctl.py:{name}", options=""))
    with pytest.raises(ControllerError, match=message):
        simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)


@pytest.mark.parametrize("callable_, extra, key", [("ctl.py:Nope", "", "controller.callable"),
                                                    ("missing.py:PI", "", "controller.callable"),
                                                    ("ctl.py:PI", 'action = "reverse"\n', "controller.action")])
def test_a_bad_user_controller_is_named_at_load(tmp_path, callable_, extra, key):
    """Its module or name not found, a reverse action: the key named when the scenario loads."""
    with pytest.raises(InputError) as e:
        load_circuit_scenario(scenario(tmp_path, callable_, extra=extra))
    assert e.value.key == key


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["python", "c"])
def test_lockstep_hil_with_a_user_controller_equals_offline(tmp_path, plant):
    """The controller process calls the user's controller on the plant's SIGNALS packets: lock-step, the run is
    the offline run bit for bit on either plant."""
    from hydrohil.hil.run import run_hil
    r = run_hil(scenario(tmp_path, duration=1.0), tmp_path / "out", lockstep=True, plot=False,
                ready=lambda *a, **k: None, plant=plant)
    assert r.comparison["identical"] and r.comparison["replay_max_abs_difference"] == 0.0


def test_a_copy_elsewhere_finds_its_module(tmp_path, monkeypatch):
    """The controller's module is looked up in the scenario's folder (or its ``path``, relative to it) wherever
    the run starts, and a copy written elsewhere (a run folder's, a panel session's, a study's) finds it too."""
    from hydrohil.circuits.scenario import write_circuit_scenario
    (tmp_path / "ctls").mkdir()
    src = scenario(tmp_path / "ctls", extra='path = "."\n')
    monkeypatch.chdir(tmp_path)                              # (not the scenario's folder)
    cs = load_circuit_scenario(src)
    assert cs.loop.cfg.path == str(tmp_path / "ctls")
    copy = write_circuit_scenario(src, tmp_path / "run" / "scenario.toml", sets={})
    r = simulate_circuit(*(lambda c: (c.circuit, 0.2))(load_circuit_scenario(copy)), h=5e-4,
                         loop=load_circuit_scenario(copy).loop)
    assert len(r.column("t")) == 401
