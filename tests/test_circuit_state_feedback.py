"""A circuit's loop as a state feedback (issue #27 item 5: the paper's Fig 12 with load-pressure feedback on the
generated code): the law reads its cylinder's two chambers (``load_pressure``, through the rig's transducers),
checked against the law computed here from the run's own log, against the core's run, in lock-step HIL on both
plants, and its bad input named."""

import re
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import EXAMPLES
from hydrohil.circuits.run import simulate_circuit
from hydrohil.circuits.scenario import load_circuit_scenario
from hydrohil.errors import InputError
from hydrohil.parameters import load_parameters
from hydrohil.simulation.as_circuit import convert
from hydrohil.simulation.scenario import load_scenario

FIG12_SF = EXAMPLES / "controllers" / "fig12_pressure_feedback.toml"


@pytest.fixture(scope="module")
def converted():
    with tempfile.TemporaryDirectory() as tmp:
        _, spath, _ = convert(load_scenario(FIG12_SF), Path(tmp) / "sf")
        yield spath.read_text(), (Path(tmp) / "sf" / "circuit.toml").read_text()


def _write(tmp_path, converted, replace=()):
    scen, circ = converted
    for a, b in replace:
        assert a in scen, a
        scen = scen.replace(a, b)
    (tmp_path / "circuit.toml").write_text(circ)
    (tmp_path / "scenario.toml").write_text(scen)
    return tmp_path / "scenario.toml"


def _run(path, **updates):
    cs = load_circuit_scenario(path)
    if updates:
        cs.loop.cfg = cs.loop.cfg.model_copy(update=updates)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return cs, simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)


def test_the_law_reads_the_load_pressure_of_its_cylinder(tmp_path, converted):
    """Every command of the run is the state feedback's law computed here from the run's own log: the encoder's
    reading, the reference, pL = p_cap - (A2/A1)·p_rod of the paper's areas through transducers of 100 bar full
    scale and 0.2 bar quanta (clamped, then rounded: both act in this run), high-passed with tpl = 50 ms (to
    1e-12 of the command)."""
    cs, r = _run(_write(tmp_path, converted, [("duration = 6.0", "duration = 2.0"),
                                              ("pressure_range = 25000000.0\npressure_resolution = 0.0",
                                               'pressure_range = "100 bar"\npressure_resolution = "0.2 bar"')]))
    p = load_parameters("ferreira2004")
    ratio, h, kp, kpl, tpl = p.cylinder.a2 / p.cylinder.a1, cs.step, 100.0, 2e-8, 0.05
    read = lambda v: np.floor(np.clip(v, 0.0, 1e7) / 2e4 + 0.5) * 2e4                 # noqa: E731
    assert np.max(r.column("rod.p")) > 1.05e7 and np.max(np.abs(read(r.column("cap.p")) - r.column("cap.p"))) > 5e3
    pl = read(r.column("cap.p")) - ratio * read(r.column("rod.p"))
    e = r.column("cyl.x.reference") - r.column("cyl.x.sensed")
    u = np.empty(len(pl) - 1)
    plf = 0.0
    for k in range(len(u)):
        if k > 0:
            plf = tpl / (tpl + h) * (plf + pl[k] - pl[k - 1])
        u[k] = np.clip(kp * e[k] - kpl * plf, -1.0, 1.0)
    assert np.max(np.abs(u - r.column("valve.command")[:-1])) < 1e-12
    assert np.max(np.abs(kpl * np.array(pl))) > 0.05          # (the pressures' share is no rounding: > 5 % of ū)
    sensed = sorted(k for k in r.columns if k.endswith(".p.sensed"))
    assert sensed == ["cap.p.sensed", "rod.p.sensed", "supply.p.sensed", "tank.p.sensed"]   # (the rig's four)
    for name in sensed:                                       # the readings logged: the transducers' rule, here
        assert np.array_equal(r.column(name), read(r.column(name[:-len(".sensed")]))), name
        assert r.units[name] == "Pa"


def test_the_noisy_readings_logged_are_what_the_law_read(tmp_path, converted):
    """With 2 bar of transducer noise the log's cap.p.sensed and rod.p.sensed are what the law read: every
    command is the law computed here from them (to 1e-12), their noise about the truth is 2 bar (sample
    standard deviation within 5 %, 2001 draws each), and logged every 5th step they are the every-step run's
    at those rows (the draws between rows kept)."""
    path = _write(tmp_path, converted, [("duration = 6.0", "duration = 1.0"),
                                        ("pressure_range = 25000000.0", "pressure_range = 25000000.0\n"
                                                                        "pressure_noise = 2e5")])
    cs, r = _run(path)
    p = load_parameters("ferreira2004")
    ratio, h, kp, kpl, tpl = p.cylinder.a2 / p.cylinder.a1, cs.step, 100.0, 2e-8, 0.05
    pl = r.column("cap.p.sensed") - ratio * r.column("rod.p.sensed")
    e = r.column("cyl.x.reference") - r.column("cyl.x.sensed")
    u, plf = np.empty(len(pl) - 1), 0.0
    for k in range(len(u)):
        if k > 0:
            plf = tpl / (tpl + h) * (plf + pl[k] - pl[k - 1])
        u[k] = np.clip(kp * e[k] - kpl * plf, -1.0, 1.0)
    assert np.max(np.abs(u - r.column("valve.command")[:-1])) < 1e-12
    for node in ("cap", "rod"):
        noise = r.column(f"{node}.p.sensed") - r.column(f"{node}.p")
        assert abs(np.std(noise) / 2e5 - 1.0) < 0.05, np.std(noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sparse = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop, every=5)
    assert np.array_equal(sparse.column("cap.p.sensed"), r.column("cap.p.sensed")[::5])


def test_noisy_transducers_without_a_position_sensor(tmp_path, converted):
    """A loop whose piston is read as it is (no sensor) still draws its transducers' noise (2 bar: the commands
    move off the noiseless run's by more than 1e-3), the same numbers run after run."""
    noisy = [("duration = 6.0", "duration = 1.0"), ("sensor_resolution = 1e-06\n", ""),
             ("pressure_range = 25000000.0", "pressure_range = 25000000.0\npressure_noise = 2e5")]
    quiet = [("duration = 6.0", "duration = 1.0"), ("sensor_resolution = 1e-06\n", "")]
    cs, r = _run(_write(tmp_path, converted, noisy))
    assert cs.loop.sensor is None
    again = _run(tmp_path / "scenario.toml")[1]
    q = _run(_write(tmp_path, converted, quiet))[1]
    assert np.array_equal(r.column("valve.command"), again.column("valve.command"))
    assert np.max(np.abs(r.column("valve.command") - q.column("valve.command"))) > 1e-3


def test_the_load_pressure_feedback_keeps_the_slow_ramp_sliding(tmp_path, converted):
    """Fig 12's slow ramp (5-6 s): with the load-pressure feedback the piston does not stick again (0 times),
    with the same P gain alone it sticks 63 times (the example's point; the core's Fig 12 under P hunts)."""
    path = _write(tmp_path, converted)
    counts = []
    for kpl in (2e-8, 0.0):
        _, r = _run(path, kpl=kpl)
        t, m = r.column("t"), r.column("cyl.mode")
        w = (t >= 5.0) & (t < 6.0)
        counts.append(int(np.sum((np.diff(m[w]) != 0) & (m[w][1:] == 0))))     # (mode 0: stick)
    assert counts[0] == 0 and counts[1] > 30, counts


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["python", "c"])
def test_lockstep_hil_of_a_state_feedback_equals_offline(tmp_path, converted, plant):
    """The controller process reads the chambers from the plant's SIGNALS packets through the same transducers,
    their noise from the same stream: lock-step, the run is the offline run bit for bit on either plant."""
    from hydrohil.hil.run import run_hil
    _, path = _noisy(tmp_path, duration=1.5)            # (noisy transducers: the controller draws their noise)
    r = run_hil(path, tmp_path / "out", lockstep=True, plot=False, ready=lambda *a, **k: None, plant=plant)
    assert r.comparison["identical"] and r.comparison["replay_max_abs_difference"] == 0.0


@pytest.mark.parametrize("change, key, message", [
    (('load_pressure = "cyl"\n', ""), "controller.load_pressure",
     r"cylinders of circuit 'fig12_pressure_feedback': cyl\), got None"),
    (('load_pressure = "cyl"', 'load_pressure = "valve"'), "controller.load_pressure", "got 'valve'"),
    (('type = "state_feedback"', 'type = "p"'), "controller.load_pressure", "only a state feedback"),
    (('command = "valve.command"', 'command = "valve.command"\naction = "reverse"'), "controller.action",
     "acts directly"),
    (("pressure_range = 25000000.0\npressure_resolution = 0.0", "pressure_range = 0.0\npressure_resolution = 1000.0"),
     "controller.pressure_range", "with a full scale"),
    (("pressure_range = 25000000.0", 'pressure_range = "250 m"'), "controller.pressure_range", "transducers"),
    (("pressure_range = 25000000.0", 'pressure_range = 0.0\npressure_noise = "0.1 bar"'),
     "controller.pressure_noise", "of a transducer"),
    (('supply_node = "supply"', 'supply_node = "suply"'), "controller.supply_node", "did you mean 'supply'"),
    (('tank_node = "tank"', "tank_node = 3"), "controller.tank_node", "unknown node '3'"),
    (('load_pressure = "cyl"', 'load_pressure = "cyl"\npressure_seed = -1'), "controller.pressure_seed",
     "a whole number"),
    (('load_pressure = "cyl"', 'load_pressure = "cyl"\npressure_noise = 1000.0\npressure_seed = 0\n'
      'sensor_noise = 1e-6'), "controller.pressure_seed", "the same numbers"),
    (('measure = "cyl.x"', 'measure = "cap.p"'), "controller.measure", "not read through a pressure transducer"),
])
def test_a_bad_load_pressure_is_named(tmp_path, converted, change, key, message):
    """Its cylinder missing or not a cylinder, a load pressure on another law, a reverse action, a resolution
    without a full scale, a unit that is not a pressure: the key named."""
    scen, _ = converted
    if change[1] == 'type = "p"':          # (a P law has no kpl, tpl)
        scen = scen.replace("kpl = 2e-08\ntpl = 0.05\n", "")
    path = _write(tmp_path, (scen, converted[1]), [change])
    with pytest.raises(InputError, match=message) as e:
        load_circuit_scenario(path)
    assert e.value.key == key


def _noisy(tmp_path, duration: float = 6.0):
    """Fig 12's state feedback with transducers of 0.2 bar noise (seed 7), converted: (paper scenario, circuit's)."""
    noisy = tmp_path / "noisy.toml"
    noisy.write_text(FIG12_SF.read_text().replace('"supply.ps" = 1.2e7', '"supply.ps" = 1.2e7\n'
                                                  '"sensors.pressure_noise" = 2e4')
                     .replace("duration = 6.0", f"duration = {duration}") + "\n[hil]\nseed = 7\n")
    ls = load_scenario(noisy)
    return ls, convert(ls, tmp_path / "a")[1]


def test_noisy_transducers_convert_to_the_rigs_noise(tmp_path):
    """The rig's state feedback draws its four transducers' noise (p1, p2, ps, pt) from the stream of [hil] seed:
    converted, the loop reads the chambers, the supply's and the tank's nodes with the same noise
    (pressure_noise, pressure_seed = the seed), so the run is the core's to rounding, as without noise: the
    piston within 4e-15 m RMS (measured 1.1e-15), the command within 1e-13 (3.5e-14), the modes the same at
    every step; and the noise acts (the noiseless run's commands differ by 2.2e-3)."""
    from hydrohil.simulation.run import run_scenario
    ls, spath = _noisy(tmp_path)
    assert 'pressure_noise = 20000.0' in spath.read_text() and "pressure_seed = 7" in spath.read_text()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        core, (cs, r) = run_scenario(ls, engine="core"), _run(spath)
        quiet = run_scenario(load_scenario(FIG12_SF), engine="core")
    assert np.sqrt(np.mean((core.column("xp") - r.column("cyl.x")) ** 2)) < 4e-15
    assert np.max(np.abs(core.column("u") - r.column("valve.command"))) < 1e-13
    travel, friction = core.column("travel_mode"), core.column("friction_mode")
    assert np.array_equal(np.where(travel == 0, friction, travel + 2), r.column("cyl.mode"))
    assert np.max(np.abs(core.column("u") - quiet.column("u"))) > 1e-3


FAULTY = ('\n[[faults]]\ntype = "sensor_offset"\nsensor = "p1"\noffset = 2e5\ndrift = 1e5\nstart = 0.2\nend = 0.8\n'
          '[[faults]]\ntype = "sensor_noise"\nsensor = "p2"\nstd = 3e4\nstart = 0.1\n'
          '[[faults]]\ntype = "sensor_stuck"\nsensor = "p2"\nstart = 0.9\nend = 1.2\n')


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["python", "c"])
def test_lockstep_hil_with_faulty_transducers_equals_offline(tmp_path, plant):
    """The rig's faults on the chambers' sensors, converted to faults on the loop's transducers: the controller
    process applies them to the pressures of the plant's SIGNALS packets (each fault's memory and stream kept from
    packet to packet), so that lock-step the run is the offline run bit for bit on either plant."""
    from hydrohil.hil.run import run_hil
    faulty = tmp_path / "faulty.toml"
    faulty.write_text(FIG12_SF.read_text().replace("duration = 6.0", "duration = 1.5") + "\n[hil]\nseed = 5\n" +
                      FAULTY)
    _, path, _ = convert(load_scenario(faulty), tmp_path / "a")
    assert 'signal = "rod.p"' in path.read_text()
    r = run_hil(path, tmp_path / "out", lockstep=True, plot=False, ready=lambda *a, **k: None, plant=plant)
    assert r.comparison["identical"] and r.comparison["replay_max_abs_difference"] == 0.0


@pytest.mark.parametrize("fault, key, message", [
    ('type = "sensor_offset"\nsignal = "valve.x"\noffset = 1e5\nstart = 1.0', "faults[0].signal",
     "its measured one or a pressure it reads through its transducers (cyl.x, cap.p, rod.p, supply.p, tank.p), got "
     "'valve.x'"),
    ('type = "encoder_count_loss"\nsignal = "cap.p"\nfraction = 0.5\nstart = 1.0', "faults[0].type",
     "an encoder's counts"),
    ('type = "sensor_offset"\nsignal = "cap.p"\noffset = "2 mm"\nstart = 1.0', "faults[0].offset", "Pa is wanted"),
])
def test_a_bad_transducer_fault_is_named(tmp_path, converted, fault, key, message):
    """A fault on a signal the loop does not read through a sensor, an encoder's fault on a transducer, an offset
    in a unit that is not the pressure's: the key named."""
    path = _write(tmp_path, converted)
    path.write_text(path.read_text() + f"\n[[faults]]\n{fault}\n")
    with pytest.raises(InputError, match=re.escape(message)) as e:
        load_circuit_scenario(path)
    assert e.value.key == key


def test_a_noisy_transducer_fault_draws_without_a_sensor(tmp_path, converted):
    """A loop reading its piston ideally (no sensor of its own) still draws a transducer fault's noise: 0.2 bar
    on cap.p over [0.2, 0.7) s changes the commands there (at 84 % of the steps, measured; the transducer's
    resolution rounds some draws away) and nowhere before."""
    scen, circ = converted
    scen = re.sub(r"sensor_resolution = [0-9.e-]+\n", "", scen).replace("duration = 6.0", "duration = 1.0")
    runs = []
    for extra in ("", '\n[[faults]]\ntype = "sensor_noise"\nsignal = "cap.p"\nstd = "0.2 bar"\nstart = 0.2\n'
                      'end = 0.7\n'):
        path = _write(tmp_path, (scen + extra, circ))
        cs, r = _run(path)
        assert cs.loop.sensor is None
        runs.append(r)
    t, a, b = runs[0].column("t"), runs[0].column("valve.command"), runs[1].column("valve.command")
    w = (t >= 0.2 + 1e-9) & (t < 0.7)
    assert np.array_equal(a[t < 0.2], b[t < 0.2]) and np.mean(a[w] != b[w]) > 0.5   # (some draws quantise away)
