"""Fault injection (issue #6): one test per fault type on its example scenario, the network faults on the
injector itself, flags in sensor readings, and HIL (lock-step and real time) == offline with faults."""

import json
from pathlib import Path

import numpy as np
import pytest

from conftest import EXAMPLES
from hydrohil.errors import InputError
from hydrohil.hil.protocol import ST_FAULT_INJECTED, ST_WATCHDOG
from hydrohil.simulation.outputs import read_csv_columns
from hydrohil.simulation.faults import FAULT_TYPES, NetworkDelay, PacketLoss, Reordering
from hydrohil.simulation.rig import VirtualRig
from hydrohil.simulation.run import run_scenario
from hydrohil.simulation.scenario import load_scenario

from conftest import hh, lockstep_equals_offline

FAULTS = Path(__file__).resolve().parent.parent / "examples" / "faults"
H = 5e-4


def run(name, faults=True):
    sc = load_scenario(FAULTS / f"{name}.toml")
    if not faults:
        sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"faults": []})})
    return sc, run_scenario(sc)


def window(r, t0, t1):
    t = r.column("t")
    return (t >= t0 - 1e-9) & (t < t1 - 1e-9)


def test_one_example_per_fault_type_and_flags_exactly_on_the_window():
    assert sorted(p.stem for p in FAULTS.glob("*.toml")) == sorted(FAULT_TYPES)
    sc, r = run("sensor_dropout")
    f = sc.scenario.faults[0]
    assert np.array_equal(r.column("faults") != 0, window(r, f.start, f.end))


def test_sensor_stuck():
    _, r = run("sensor_stuck")
    w = window(r, 1.0, 1.5)
    assert np.ptp(r.column("x_meas")[w]) == 0.0 and np.ptp(r.column("xp")[w]) > 0.01


def test_sensor_offset_and_drift():
    _, r = run("sensor_offset")
    w = window(r, 2.5, 4.0)
    err = r.column("x_meas")[w] - r.column("xp")[w]
    expected = 0.005 + 0.002 * (r.column("t")[w] - 2.5)
    assert np.max(np.abs(err - expected)) < 1.5e-6          # within one encoder count + rounding


def test_sensor_noise_burst():
    _, r = run("sensor_noise")
    w = window(r, 2.2, 2.8)
    e = r.column("x_meas") - r.column("xp")
    assert np.std(e[w]) == pytest.approx(5e-4, rel=0.15)
    assert np.max(np.abs(e[~w])) <= 0.51e-6


def test_sensor_dropout_pressure():
    _, r = run("sensor_dropout")
    w = window(r, 1.0, 2.0)
    assert np.all(r.column("p1_meas")[w] == 0.0) and np.all(r.column("p1_meas")[~w] > 1e5)
    assert np.all(r.column("p2_meas")[w] > 1e5)


def test_encoder_count_loss_is_permanent():
    _, r = run("encoder_count_loss")
    xp, xm, t = r.column("xp"), r.column("x_meas"), r.column("t")
    i0, i1 = np.searchsorted(t, 0.5), np.searchsorted(t, 2.0)
    # counts moved into each reading taken while the fault is active (readings i0 .. i1 - 1)
    travelled = np.sum(np.abs(np.diff(np.round(xp[i0 - 1:i1] / 1e-6))))
    lost = np.round((xp[i1 + 100] - xm[i1 + 100]) / 1e-6)
    assert lost == pytest.approx(0.2 * travelled, abs=2)
    assert (xp[-1] - xm[-1]) / 1e-6 == pytest.approx(lost, abs=1)       # still lost at the end


def test_spool_stuck():
    _, r = run("spool_stuck")
    _, b = run("spool_stuck", faults=False)
    w = window(r, 1.0, 2.5)
    assert np.ptp(r.column("xs")[w]) == 0.0 and np.ptp(b.column("xs")[w]) > 0.1
    assert r.column("xp")[w].max() > b.column("xp")[w].max() + 0.01


def test_valve_bandwidth():
    _, r = run("valve_bandwidth")
    _, b = run("valve_bandwidth", faults=False)
    lag = lambda res: np.sqrt(np.mean((res.column("xs") - res.column("ud")) ** 2))  # noqa: E731
    assert lag(r) > 3 * lag(b)


@pytest.mark.parametrize("name", ["valve_leakage", "seal_wear"])
def test_leakage_faults_let_the_load_sink(name):
    _, r = run(name)
    _, b = run(name, faults=False)
    w = window(r, 2.5, 4.0)
    v_fault, v_base = np.mean(r.column("vp")[w]), np.mean(b.column("vp")[w])
    assert v_fault > 3 * v_base > 0


def test_command_inversion():
    sc, r = run("command_inversion")
    kp = sc.scenario.controller.kp
    w = window(r, 2.5, 2.8)
    law = np.clip(kp * (sc.scenario.references()[0][: len(r.log)] - r.column("x_meas")), -1, 1)
    assert np.array_equal(r.column("u")[w], -law[w]) and np.array_equal(r.column("u")[~w][:-1], law[~w][:-1])


def test_supply_pressure_drop_and_loss():
    _, r = run("supply_pressure")
    assert np.all(r.column("ps_meas")[window(r, 1.0, 4.0)] == 3e6)
    assert np.all(r.column("ps_meas")[window(r, 4.0, 6.0)] == 0.0)
    settled = window(r, 1.3, 4.0)
    assert max(r.column("p1")[settled].max(), r.column("p2")[settled].max()) < 3e6 + 1e4


def test_hose_burst_drops_the_line_pressure_and_the_load_sinks():
    _, r = run("hose_burst")
    _, b = run("hose_burst", faults=False)
    w = window(r, 2.05, 2.3)
    assert r.column("p2")[w].max() < 10e5 < b.column("p2")[w].min()
    assert r.column("xp")[w].max() > b.column("xp")[w].max() + 2e-3      # gravity aids extension


def test_load_change_shifts_the_hydraulic_force():
    sc, r = run("load_change")
    a1, a2 = sc.params.cylinder.a1, sc.params.cylinder.a2
    fh = r.column("p1") * a1 - r.column("p2") * a2
    before, after = np.mean(fh[window(r, 1.7, 2.0)]), np.mean(fh[window(r, 2.5, 3.0)])
    expected = 4000.0 - (300.0 - 80.0) * 9.81           # F_L up, gravity aid m*g up (eq 28 statics)
    assert after - before == pytest.approx(expected, abs=400.0)    # static friction band +-260 N


def test_controller_silence_trips_the_watchdog_after_its_timeout():
    sc, r = run("controller_silence")
    wd = r.column("watchdog") != 0
    t = r.column("t")[wd]
    assert t[0] == pytest.approx(1.0 + sc.scenario.hil.watchdog_timeout, abs=1.5 * H) and t[-1] <= 1.5 + 1e-9
    # safe state: valve centred (the flag of a row is the reading's; the command of the row at 1.5 s is
    # the first one after the silence)
    assert np.all(r.column("u")[wd][:-1] == 0.0) and r.column("u")[wd][-1] != 0.0


def _delivered(fault, n, seed=0):
    """The commands u_k = k·1e-4 sent through the rig's network faults (core/rig.c) for n steps: per step the
    command that reached the plant (None: none did), from the watchdog's count and held command."""
    sc = load_scenario(FAULTS / "packet_loss.toml")
    s = sc.scenario
    rig = VirtualRig(sc.params, H, s.hil.model_copy(update={"seed": seed, "watchdog_timeout": 10.0}), [fault],
                     {"xp": 0.09})
    out = []
    for k in range(n):
        before = rig.link.delivered
        rig.step(k, k * 1e-4)
        out.append(rig.link.u_held if rig.link.delivered > before else None)
    return out


def test_network_faults_in_the_rig_step():
    got = _delivered(PacketLoss(type="packet_loss", probability=0.4, start=0.0), 8000, seed=3)
    assert sum(g is not None for g in got) / len(got) == pytest.approx(0.6, abs=0.02)
    out = _delivered(NetworkDelay(type="network_delay", delay=0.01, start=0.0, end=0.1), 400)
    assert out[:20] == [None] * 20 and out[20:199] == [(k - 20) * 1e-4 for k in range(20, 199)]
    assert out[250:] == [k * 1e-4 for k in range(250, 400)]                  # delay over: newest again
    vals = [v for v in _delivered(Reordering(type="reordering", probability=0.3, start=0.0), 8000, seed=1)
            if v is not None]
    assert all(b > a for a, b in zip(vals, vals[1:]))                     # stale commands never applied
    assert 0.7 < len(vals) / 8000 < 0.85


def test_rig_flags_faults_in_sensor_status():
    sc = load_scenario(FAULTS / "sensor_dropout.toml")
    s = sc.scenario
    rig = VirtualRig(sc.params, H, s.hil, s.faults, {"xp": s.initial.xp})
    flags = []
    for k in range(int(2.5 / H)):
        rig.step(k, 0.0)
        flags.append(bool(rig.read().status & ST_FAULT_INJECTED))
    t = (np.arange(len(flags)) + 1) * H
    assert np.array_equal(np.array(flags), (t >= 1.0 - 1e-9) & (t < 2.0 - 1e-9))


ALL_FAULTS = """params = "ferreira2004"
duration = 4.0
[initial]
xp = 0.03
[controller]
type = "p"
kp = 50.0
[reference]
type = "table"
t = [0.0, 0.5, 1.5, 3.0, 4.0]
x = [0.03, 0.03, 0.15, 0.15, 0.05]
[[faults]]
type = "sensor_noise"
sensor = "position"
std = 2e-4
start = 0.6
end = 0.8
[[faults]]
type = "packet_loss"
probability = 0.3
start = 0.9
end = 1.1
[[faults]]
type = "network_delay"
delay = 0.01
start = 1.2
end = 1.4
[[faults]]
type = "reordering"
probability = 0.2
start = 1.5
end = 1.7
[[faults]]
type = "controller_silence"
start = 1.8
end = 2.0
[[faults]]
type = "load_change"
mass = 200.0
force = 500.0
start = 2.1
[[faults]]
type = "supply_pressure"
ps = 3e6
start = 2.6
end = 3.0
[[faults]]
type = "hose_burst"
line = 1
section = 1.0
start = 3.1
end = 3.2
[[faults]]
type = "encoder_count_loss"
fraction = 0.1
start = 3.3
end = 3.5
"""


def test_lockstep_hil_with_faults_matches_offline_exactly(tmp_path):
    scen = tmp_path / "all_faults.toml"
    scen.write_text(ALL_FAULTS)
    hil, off = lockstep_equals_offline(scen, tmp_path / "hil", steps=8000)
    assert np.array_equal(hil["faults"], off.column("faults"))
    assert np.array_equal(hil["watchdog"], off.column("watchdog"))
    flagged = (hil["status"].astype(int) & ST_FAULT_INJECTED) != 0
    assert np.array_equal(flagged, hil["faults"] != 0)
    timing = json.loads((tmp_path / "hil" / "timing.json").read_text())
    assert timing["watchdog_trips"] == 1 and len(timing["faults_injected"]) == 9


@pytest.mark.slow
def test_real_time_hil_with_controller_silence(tmp_path):
    text = (FAULTS / "controller_silence.toml").read_text().replace("duration = 6.0", "duration = 2.0")
    scen = tmp_path / "silence.toml"
    scen.write_text(text)
    r = hh("hil", scen, "--out", tmp_path / "rt")
    timing = json.loads((tmp_path / "rt" / "timing.json").read_text())
    assert r.returncode == (0 if timing["verdict"]["valid"] else 3), r.stderr   # 3: too busy to keep time
    log = read_csv_columns(tmp_path / "rt" / "plant_log.csv")
    wd = (log["status"].astype(int) & ST_WATCHDOG) != 0
    assert wd[(log["t"] >= 1.06) & (log["t"] < 1.5)].all()         # on 50 ms into the silence, through it
    assert not wd[log["t"] > 1.5].all()                            # and off again once the controller speaks
    assert timing["watchdog_trips"] - timing["watchdog_trips_unexplained"] >= 1   # the fault's trip
    cmp = json.loads((tmp_path / "rt" / "comparison.json").read_text())
    assert cmp["replay_xp_max_abs_m"] == 0.0                       # the plant stepped the model exactly


@pytest.mark.parametrize("fault, message", [
    ('type = "hose_burst"\nline = 3\nstart = 1.0', "faults.0.line"),
    ('type = "sensor_stuck"\nsensor = "p9"\nstart = 1.0', "faults.0.sensor"),
    ('type = "packet_loss"\nprobability = 1.5\nstart = 1.0', "faults.0.probability: must be <= 1, got 1.5"),
    ('type = "seal_wear"\ng_lkc = 1e-12\nstart = 2.0\nend = 1.0', "end"),
    ('type = "meteor"\nstart = 1.0', "faults.0.type: unknown type 'meteor'"),
    ('type = "load_change"\nstart = 1.0', "mass and/or force"),
    ('type = "spool_stuck"\nstart = 10.0', "after the end of the run"),
])
def test_bad_fault_entries_are_clear_errors(tmp_path, fault, message):
    text = (FAULTS / "spool_stuck.toml").read_text().split("[[faults]]")[0] + "[[faults]]\n" + fault + "\n"
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError) as exc:
        load_scenario(path)
    assert str(path) in str(exc.value) and message in str(exc.value)


def test_the_offline_loop_through_the_rig_stops_on_a_failed_callback():
    """The core's loop through the rig calls Python back for steering events and Python controllers: what
    they raise stops the run at that step and is raised as it was (the log up to there is not returned)."""
    from hydrohil.simulation.rig import run_rig
    from hydrohil.simulation.scenario import load_scenario
    from hydrohil.simulation.steering import parse_event
    sc = load_scenario(EXAMPLES / "fig11_p_control.toml", duration=0.5)
    off = parse_event({"op": "fault_off", "slot": 3}, "plant")
    with pytest.raises(ValueError, match="no active fault in slot 3"):
        run_rig(sc, events={100: [off]}, steps=400)
    seen = []

    def fails_at_step_250(m):
        seen.append(m.t)
        if len(seen) == 251:
            raise RuntimeError("lost the sensor")
        return 50.0 * (m.x_ref - m.x)
    from hydrohil.control import ControllerError
    with pytest.raises(ControllerError, match=r"t = 0.125 s .*RuntimeError: lost the sensor"):
        run_rig(sc, controller=fails_at_step_250)
    assert seen[-1] == 0.125 and len(seen) == 251


def test_a_command_that_is_not_a_number_is_no_command():
    """The rig step takes a non-finite command as none arrived (the wire refuses one; an offline caller may
    send one): the valve holds the last command, the watchdog trips after its timeout, with a fault table
    or without; never a full-scale command (the saturation of NaN)."""
    from hydrohil.parameters import load_parameters
    from hydrohil.simulation.steering import fault_model
    prm = load_parameters("ferreira2004")
    for faults in ([], [fault_model({"type": "sensor_offset", "sensor": "p1", "offset": 1e4, "start": 0.0})]):
        rig = VirtualRig(prm, 5e-4, faults=faults)
        for k in range(40):
            rig.step(k, 0.3)
        sent = [rig.step(k, float("nan")) for k in range(40, 200)]
        assert sent[0] == 0.3 and rig.watchdog and rig.watchdog_trips == 1 == rig.watchdog_trips_unexplained
        assert sent[-1] == 0.0 and all(u in (0.3, 0.0) for u in sent)      # held, then the safe state centres


def test_at_most_53_faults_a_scenario(tmp_path):
    """The active-fault mask is logged as a float64 in both plants' logs: exact for 53 bits, so 53 faults."""
    from hydrohil.simulation.scenario import load_scenario
    base = (EXAMPLES / "fig11_p_control.toml").read_text()
    entry = '\n[[faults]]\ntype = "spool_stuck"\nstart = 1.0\n'
    ok, bad = tmp_path / "ok.toml", tmp_path / "bad.toml"
    ok.write_text(base + entry * 53)
    bad.write_text(base + entry * 54)
    assert len(load_scenario(ok).scenario.faults) == 53
    with pytest.raises(InputError, match="at most 53"):
        load_scenario(bad)


def test_a_replay_through_the_c_loop_equals_a_step_by_step_replay_with_events():
    """replay_applied (the core's sampled loop with the applied commands) against a loop written here over the
    rig's per-step call (an independent path): a run with scheduled faults (network faults that held commands
    back, which a replay of the applied commands must not apply again) and steering events (a tunable, a fault
    switched on and off, a reset) gives the same states, modes and fault masks bit for bit; keep_from keeps
    the end of the same replay."""
    from hydrohil.hil.session import REPLAY_COLUMNS, replay_applied
    from hydrohil.simulation.steering import apply_plant_event, parse_event
    sc = load_scenario(FAULTS / "packet_loss.toml")
    s = sc.scenario
    u = run_scenario(sc).column("u")[:6000]
    events = {1000: [parse_event({"op": "set", "name": "mass", "value": 150.0}, "plant")],
              2000: [parse_event({"op": "fault_on", "fault": {"type": "hose_burst", "line": 2, "section": 0.5}},
                                 "plant")],
              2600: [parse_event({"op": "fault_off", "slot": 1}, "plant"),
                     parse_event({"op": "set", "name": "friction_scale", "value": 3.0}, "plant")],
              4000: [parse_event({"op": "reset"}, "plant")]}
    rep = replay_applied(sc, u, events)
    rig = VirtualRig(sc.params, s.plant_step, s.hil, s.faults, s.initial.model_dump())
    names = [c for c in REPLAY_COLUMNS]
    from hydrohil.core import shape
    at = [shape.OUTPUT_NAMES.index(c) for c in names]
    ref = {c: [] for c in (*names, "faults")}

    def put():
        for c, i in zip(names, at):
            ref[c].append(rig.out[i])
        ref["faults"].append(rig.mask)
    put()
    for k, uk in enumerate(u):
        for ev in events.get(k, ()):
            apply_plant_event(rig, ev, k)
        rig.step_applied(k, float(uk))
        put()
    for c in ref:
        assert np.array_equal(rep[c], np.array(ref[c], dtype=float)), c
    mask = rep["faults"].astype(int)
    assert np.any(mask & 1) and np.all(mask[2001:2601] & 2) and not np.any(mask[2602:] & 2)   # both kinds acted
    tail = replay_applied(sc, u, events, keep_from=2500)
    for c in ref:
        assert np.array_equal(tail[c], rep[c][2500:]), c


def test_applied_commands_need_a_rig_and_an_open_loop():
    sc = load_scenario(FAULTS / "packet_loss.toml")
    rig = VirtualRig(sc.params, H, sc.scenario.hil)
    with pytest.raises(ValueError, match="through a rig"):
        rig.plant.sim.run(10, 1, np.zeros(11), applied=True)
    with pytest.raises(ValueError, match="log_from"):
        rig.plant.sim.run(10, 1, np.zeros(11), rig=rig.c, applied=True, log_from=11)
