"""Test sequences on circuits (issue #27): a sequence whose scenario names a circuit runs it offline with its
loop; its actions move the loop's reference (step, ramp) and set input signals (set, with until); its
expectations judge any signal of the circuit in its SI unit. Every example circuit has one, and each passes."""

import tomllib

import numpy as np
import pytest

from hydrohil.circuits.circuit import CIRCUITS_DIR
from hydrohil.errors import InputError
from hydrohil.sequences.runner import exit_code, run_sequence, run_suite
from hydrohil.sequences.sequence import load_sequence


def test_every_example_circuit_has_a_sequence_and_it_passes(tmp_path):
    examples = sorted(p.parent.name for p in CIRCUITS_DIR.glob("*/circuit.toml"))
    files = sorted(CIRCUITS_DIR.glob("*/sequence.toml"))
    assert [f.parent.name for f in files] == examples
    results = run_suite(files, tmp_path, report=True, junit=tmp_path / "junit.xml")
    assert exit_code(results) == 0, [(r.name, [o.message for o in r.outcomes if not o.passed]) for r in results]
    assert all(len(r.outcomes) >= 3 for r in results)
    assert f"{len(files)} sequence(s): {len(files)} passed" in (tmp_path / "report.md").read_text()


def _write(tmp_path, text: str):
    scen = CIRCUITS_DIR / "motor_speed" / "scenario.toml"
    p = tmp_path / "seq.toml"
    p.write_text(f'scenario = "{scen}"\nduration = 2.0\n' + text)
    return p


def test_actions_compile_into_the_circuit_scenario_and_a_failure_is_shown_in_the_signals_unit(tmp_path):
    """A step of the reference with a unit, a load torque set for 0.5 s: the compiled scenario holds the
    reference table and the input's drive (back to its value at 'until'); a bound broken on a circuit signal is
    a fail with the value in its unit and a figure in the report."""
    p = _write(tmp_path, '''
[[actions]]
name = "up"
at = 0.2
type = "step"
value = "800 rpm"
[[actions]]
name = "load"
at = 1.0
until = 1.5
type = "set"
signal = "motor.load_torque"
value = "15 N.m"
[[expect]]
name = "speed at 800 rpm within 0.5 s, until the load"
type = "tracking"
after = "up"
within = 0.5
until = "load"
tol = 1.0                  # rad/s (measured: 0.42, the integral still closing in)
[[expect]]
name = "too tight on purpose"
type = "bounds"
signal = "a.p"
max = 9.0e6
''')
    r = run_sequence(p, tmp_path / "out")
    compiled = tomllib.loads((tmp_path / "out" / "scenario.toml").read_text())
    assert compiled["reference"]["t"] == [0.0, 0.2] and compiled["reference"]["value"][1] == "800 rpm"
    assert compiled["inputs"]["motor.load_torque"] == {"t": [0.0, 1.0, 1.5, 3.0],   # (3 s: the circuit's own step)
                                                       "value": [0.0, "15 N.m", 0.0, 10.0]}
    by = {o.name: o for o in r.outcomes}
    assert by["speed at 800 rpm within 0.5 s, until the load"].passed
    bad = by["too tight on purpose"]
    assert bad.status == "fail" and "a.p = " in bad.message and " bar at t = " in bad.message
    assert r.status == "fail" and exit_code([r]) == 1
    s = r.signals
    torque = s["motor.load_torque"]
    assert torque[np.searchsorted(s.t, 1.2)] == 15.0 and torque[-1] == 0.0
    assert np.allclose(s["error"], s["x_ref"] - s["motor.w"])
    run_suite([p], tmp_path / "suite")
    figures = list((tmp_path / "suite").rglob("*.png"))
    assert figures and figures[0].stat().st_size > 10000


@pytest.mark.parametrize("text, key, message", [
    ('[[actions]]\nat = 0.5\ntype = "hose_burst"\n[[expect]]\ntype = "bounds"\nsignal = "a.p"\nmax = 1e9\n',
     "actions[0].type", "actions step, ramp, set"),
    ('[[actions]]\nat = 0.5\ntype = "set"\nsignal = "pump.speed"\nvalue = 1.0\n[[expect]]\ntype = "bounds"\n'
     'signal = "a.p"\nmax = 1e9\n', "actions", "not one of the circuit's inputs .*a pump's speed may be one: name "
                                                 "it in the scenario's \\[inputs\\]"),
    ('[[actions]]\nat = 0.5\ntype = "set"\nsignal = "relief.cracking_pressure"\nvalue = 1.0\n[[expect]]\n'
     'type = "bounds"\nsignal = "a.p"\nmax = 1e9\n', "actions", "is a parameter, not a signal: a parameter action"),
    ('[[expect]]\ntype = "bounds"\nsignal = "motor.speed"\nmax = 1.0\n', "expect[0].signal", "motor.speed"),
    ('[[actions]]\nat = 5.0\ntype = "step"\nvalue = 1.0\n[[expect]]\ntype = "bounds"\nsignal = "a.p"\nmax = 1e9\n',
     "actions[0].at", "not before the end of the run"),
    ('[[actions]]\nat = 0.5\ntype = "step"\nvalue = "3 bar"\n[[expect]]\ntype = "bounds"\nsignal = "a.p"\n'
     'max = 1e9\n', None, "rad/s is wanted"),
])
def test_a_bad_circuit_sequence_names_its_key(tmp_path, text, key, message):
    p = _write(tmp_path, text)
    with pytest.raises(InputError, match=message) as e:
        run_sequence(p, tmp_path / "out")
    if key:
        assert e.value.key == key


def test_what_a_circuit_run_cannot_judge_is_an_error_not_a_pass(tmp_path):
    """A watchdog expectation (no watchdog offline), tracking on an open loop: errors; a Python callable as a
    circuit's controller: refused."""
    p = _write(tmp_path, '[[expect]]\ntype = "watchdog"\n')
    r = run_sequence(p, tmp_path / "w")
    assert r.status == "error" and "no watchdog" in r.outcomes[0].message
    open_loop = tmp_path / "open.toml"
    open_loop.write_text(f'scenario = "{CIRCUITS_DIR / "two_cylinders" / "scenario.toml"}"\n'
                         '[[expect]]\ntype = "tracking"\ntol = 0.001\n')
    r = run_sequence(open_loop, tmp_path / "o")
    assert r.status == "error" and "open loop" in r.outcomes[0].message
    with pytest.raises(InputError, match="external program") as e:
        run_sequence(load_sequence(open_loop), tmp_path / "l", controller=lambda m: 0.0)
    assert e.value.key == "controller"


LOCKSTEP_SEQUENCE = '''
[[actions]]
name = "up"
at = 0.2
type = "step"
value = "800 rpm"

[[expect]]
type = "step_response"
after = "up"
max_settling_time = 0.4
max_overshoot_pct = 3.0

[[expect]]
type = "bounds"
signal = "a.p"
max = 1.65e7

[[expect]]
type = "watchdog"
'''


def test_lockstep_sequence_judges_as_offline_and_judges_its_watchdog(tmp_path):
    """Lock-step, the plant process and the controller process: every expectation measures what offline
    measures (the same run bit for bit), and a watchdog expectation can be judged (no trip)."""
    p = _write(tmp_path, LOCKSTEP_SEQUENCE)
    off = run_sequence(p, tmp_path / "off")
    lock = run_sequence(p, tmp_path / "lock", mode="lockstep")
    assert [o.status for o in lock.outcomes[:2]] == [o.status for o in off.outcomes[:2]]
    assert [o.message for o in lock.outcomes[:2]] == [o.message for o in off.outcomes[:2]]
    assert [o.measured for o in lock.outcomes[:2]] == [o.measured for o in off.outcomes[:2]]
    assert off.outcomes[2].status == "error" and lock.outcomes[2].status == "pass"
    assert lock.status == "pass" and "settling time 0.303 s" in lock.outcomes[0].message


def test_real_time_circuit_sequence_is_judged_or_says_why_not(tmp_path):
    """Real time: the same expectations on the plant's log, or, on a machine too busy to keep the clock, an
    error naming the INVALID run (never a pass of an invalid run)."""
    r = run_sequence(_write(tmp_path, LOCKSTEP_SEQUENCE), tmp_path / "rt", mode="realtime")
    assert r.verdict is not None
    if r.verdict["valid"]:
        assert r.status == "pass" and r.outcomes[2].message == "0 watchdog trip(s)"
    else:
        assert r.status == "error" and "INVALID" in r.error
    assert (tmp_path / "rt" / "plant_log.csv").is_file() and (tmp_path / "rt" / "result.json").is_file()


def test_a_failed_watchdog_expectation_on_an_open_circuit_has_its_figure(tmp_path):
    """A circuit without a loop has no command "u": a watchdog trip fails the expectation and its figure shows
    the watchdog alone (no crash); with a loop, the safe state is its command at 0."""
    from types import SimpleNamespace

    from hydrohil.sequences.expectations import Signals, Watchdog
    from hydrohil.sequences.report import failure_figure
    t = np.arange(0, 1.0, 5e-4)
    wd = ((t > 0.4) & (t < 0.6)).astype(float)
    s = Signals({"t": t, "watchdog": wd, "supply.p": 1e7 + 0 * t}, {}, mode="realtime", units={"t": "s"})
    o = Watchdog(type="watchdog").evaluate(s)
    assert o.status == "fail" and "1 watchdog trip" in o.message
    png = failure_figure(SimpleNamespace(signals=s, name="open"), 0, o, tmp_path / "f.png")
    assert png.stat().st_size > 10_000
    u = np.where(wd > 0, 0.0, 0.3)
    late = np.where((t > 0.4) & (t < 0.45), 0.3, u)           # centred 50 ms after the trip
    for cmd, verdict in ((u, "pass"), (late, "fail")):
        s = Signals({"t": t, "watchdog": wd, "u": cmd}, {}, mode="realtime", units={"t": "s", "u": "-"})
        o = Watchdog(type="watchdog", after=0.4, safe_within=0.02).evaluate(s)
        assert o.status == verdict, o.message


def test_an_expectations_level_may_carry_its_unit(tmp_path):
    """A bound given with its unit ("170 bar") is the signal's SI value (a.p: Pa), a loop's tolerance in the
    measured signal's (motor.w: rad/s, "100 rpm"); the same sequence with the SI numbers loads the same; a unit
    of another quantity names the key and the unit wanted, before anything runs."""
    from hydrohil.sequences.sequence import load_sequence
    with_units = _write(tmp_path, '[[expect]]\ntype = "bounds"\nsignal = "a.p"\nmin = "-1 bar"\nmax = "170 bar"\n'
                                  '[[expect]]\ntype = "tracking"\ntol = "100 rpm"\nafter = 1.0\n')
    e = load_sequence(with_units).expectations
    assert (e[0].min, e[0].max) == (-1e5, 170e5) and e[1].tol == pytest.approx(100 * 2 * 3.141592653589793 / 60,
                                                                             rel=1e-15)
    bad = _write(tmp_path, '[[expect]]\ntype = "bounds"\nsignal = "a.p"\nmax = "170 mm"\n')
    with pytest.raises(InputError, match=r"expect\[0\]\.max: .*Pa.*\(a\.p is in Pa\)") as exc:
        load_sequence(bad)
    assert exc.value.key == "expect[0].max"
