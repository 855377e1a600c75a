"""Network faults on a circuit's loop (circuits/network.py, core/link.c): packet loss, delay, reordering and a
silent controller act on the commands as the paper's rig's do. Checked against rules computed here (the
random streams by conftest's xoshiro256**), against the core's hand-written rig on the
paper's Fig 11, and lock-step HIL on both plants = offline bit for bit."""

import re

import numpy as np
import pytest

from conftest import EXAMPLES, Xoshiro, sequence_scenario
from hydrohil.circuits.run import simulate_circuit
from hydrohil.circuits.scenario import load_circuit_scenario
from hydrohil.errors import InputError

PAPER = EXAMPLES / "circuits" / "ferreira2004"
H, TIMEOUT, SEED = 5e-4, 0.05, 7
FAULTS = """
[hil]
seed = 7
[[faults]]
type = "packet_loss"
probability = 0.4
start = 0.6
end = 1.2
[[faults]]
type = "network_delay"
delay = "10 ms"
start = 1.3
end = 1.8
[[faults]]
type = "reordering"
probability = 0.3
start = 2.0
end = 2.6
[[faults]]
type = "controller_silence"
start = 3.1
end = 3.3
"""


def paper_scenario(tmp_path, faults: str = FAULTS, duration: float = 3.5, name: str = "net.toml"):
    """The ferreira2004 example (Fig 11's P loop) cut to ``duration`` with ``faults``."""
    text = (PAPER / "scenario.toml").read_text().replace('circuit = "circuit.toml"',
                                                          f'circuit = "{PAPER / "circuit.toml"}"')
    f = tmp_path / name
    f.write_text(text.replace("duration = 6.0", f"duration = {duration}") + faults)
    return f


def expected_applied(sent: np.ndarray, u0: float) -> tuple[np.ndarray, np.ndarray]:
    """What reaches the valve at each step under FAULTS, from what the controller sent, by the documented rules:
    a lost packet (a draw below the probability) or one held back by reordering (then the next one arrives,
    the held one is stale) leaves the last command; a 10 ms delay delivers the packet of 20 steps before (none in
    its first 20 steps; the newest when it ends); silence delivers nothing; no packet for longer than the
    watchdog's timeout -> 0 until the next one. Returns the commands and the watchdog per step."""
    k_of = lambda t: int(np.ceil(t / H - 1e-9))                      # noqa: E731
    loss, delay, reorder, silence = (k_of(0.6), k_of(1.2)), (k_of(1.3), k_of(1.8)), (k_of(2.0), k_of(2.6)), \
        (k_of(3.1), k_of(3.3))
    rng_loss, rng_reorder = Xoshiro.stream(SEED, 0), Xoshiro.stream(SEED, 2)
    held, k_delivered, held_back = u0, 0, False
    out, dog = np.empty(len(sent)), np.zeros(len(sent), bool)
    for k, s in enumerate(sent):
        got = None
        if loss[0] <= k < loss[1]:
            got = None if rng_loss.uniform() - 2.0 ** -53 < 0.4 else s
        elif delay[0] <= k < delay[1]:
            got = sent[k - 20] if k - delay[0] >= 20 else None
        elif reorder[0] <= k < reorder[1]:
            if held_back:
                held_back, got = False, s
            elif rng_reorder.uniform() - 2.0 ** -53 < 0.3:
                held_back = True
            else:
                got = s
        elif not silence[0] <= k < silence[1]:
            got = s
        if got is not None:
            held, k_delivered = got, k
        dog[k] = (k - k_delivered) * H > TIMEOUT + 1e-12
        out[k] = 0.0 if dog[k] else held
    return out, dog


def test_network_faults_deliver_the_commands_by_their_rules(tmp_path):
    """Offline, the valve gets exactly what the rules computed here give from the controller's commands: losses
    and reorderings at the draws of an independent xoshiro256**, the 20-step delay, the watchdog's trip 50 ms
    into the silence and its recovery. (The faults acted: 28 % of the loss window's commands differ from what was
    sent — a lost one often equals the last, the loop's commands being quantised —, 20 steps of delay, the safe
    state for 0.15 s.)"""
    cs = load_circuit_scenario(paper_scenario(tmp_path))
    r = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    sent, applied = r.column("valve.command.sent"), r.column("valve.command")
    want, dog = expected_applied(sent[:-1], applied[0])
    assert np.array_equal(applied[:-1], want)
    t = r.column("t")[:-1]
    assert t[dog][0] == pytest.approx(3.1 + TIMEOUT, abs=1e-9) and t[dog][-1] == pytest.approx(3.3 - H, abs=1e-9)
    assert np.array_equal(r.column("watchdog")[:-1] > 0, dog) and r.units["watchdog"] == "-"   # (logged: these)
    window = (t >= 0.6) & (t < 1.2)
    assert 0.25 < np.mean(applied[:-1][window] != sent[:-1][window]) < 0.45   # (many commands repeat: quantised)
    assert r.units["valve.command.sent"] == "-"


def test_the_circuit_loses_delays_and_reorders_as_the_cores_rig(tmp_path):
    """The paper's Fig 11 with the same four network faults run by the core's hand-written rig (rig.c, its own
    loop, sensing and model) and by the ferreira2004 circuit (the generated loop): the same command reaches the
    valve at every step, the piston within 4e-15 m RMS (measured 1.3e-15), the watchdog trips at the same
    steps. (Both deliver through core/link.c: this checks the two plumbings around it and the models; the
    delivery rule itself is checked apart above.)"""
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    core_toml = (EXAMPLES / "fig11_p_control.toml").read_text().replace("duration = 6.0", "duration = 3.5")
    (tmp_path / "core.toml").write_text(core_toml + FAULTS.replace('"10 ms"', "0.01"))
    core = run_scenario(load_scenario(tmp_path / "core.toml"), engine="core")
    cs = load_circuit_scenario(paper_scenario(tmp_path))
    r = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    assert np.array_equal(core.column("u")[:-1], r.column("valve.command")[:-1])   # (the last row: no step)
    assert float(np.sqrt(np.mean((core.column("xp") - r.column("cyl.x")) ** 2))) < 4e-15
    _, dog = expected_applied(r.column("valve.command.sent")[:-1], r.column("valve.command")[0])
    assert dog.any() and np.array_equal(core.column("watchdog")[1:] > 0, dog)     # (its row k+1: after step k)
    assert np.array_equal(core.column("watchdog")[1:] > 0, r.column("watchdog")[:-1] > 0)   # (the circuit's: k)


def test_a_scenarios_log_says_which_faults_act_as_the_rigs_does(tmp_path):
    """A circuit scenario's run (run_circuit_scenario) logs ``faults``: bit i at the rows its fault i acts on,
    start <= k*h < end — here computed from the four windows — and the core's rig logs the same column for the
    same scenario (Fig 11 with the four network faults), row for row."""
    from hydrohil.circuits.scenario import run_circuit_scenario
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    r, _ = run_circuit_scenario(load_circuit_scenario(paper_scenario(tmp_path)))
    k = np.arange(len(r.column("t")))
    windows = [(0.6, 1.2), (1.3, 1.8), (2.0, 2.6), (3.1, 3.3)]
    want = sum(((k >= np.ceil(a / H - 1e-9)) & (k < np.ceil(b / H - 1e-9))).astype(int) << i
               for i, (a, b) in enumerate(windows))
    assert np.array_equal(r.column("faults"), want) and r.units["faults"] == "-" and set(want) == {0, 1, 2, 4, 8}
    core_toml = (EXAMPLES / "fig11_p_control.toml").read_text().replace("duration = 6.0", "duration = 3.5")
    (tmp_path / "core.toml").write_text(core_toml + FAULTS.replace('"10 ms"', "0.01"))
    core = run_scenario(load_scenario(tmp_path / "core.toml"), engine="core")
    assert np.array_equal(core.column("faults"), r.column("faults"))


def test_the_reference_takes_the_same_commands(tmp_path):
    """The continuous reference's loop sends its commands through the same path: under the same faults its
    piston stays within 2 µm RMS of RK3's (measured 0.64 µm), and what reached its valve follows the rules
    computed here from what its controller sent."""
    cs = load_circuit_scenario(paper_scenario(tmp_path, duration=1.4))
    r = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop, method="reference")
    rk = simulate_circuit(cs.circuit, cs.duration, h=cs.step, loop=cs.loop)
    sent, applied = r.column("valve.command.sent"), r.column("valve.command")
    want, dog = expected_applied(sent[:-1], applied[0])
    assert np.array_equal(applied[:-1], want)
    assert np.array_equal(r.column("watchdog")[:-1] > 0, dog)
    assert float(np.sqrt(np.mean((r.column("cyl.x") - rk.column("cyl.x")) ** 2))) < 2e-6


@pytest.mark.parametrize("plant", ["python", "c"])
def test_lockstep_hil_with_network_faults_equals_offline_and_is_valid(tmp_path, plant):
    """Both plants take the controller's packets through the scenario's network faults (the same streams, the
    same delay line): lock-step, the run is the offline run bit for bit, the replay of the applied inputs too; the
    watchdog trip of the silence is explained by it, so the run is VALID."""
    from hydrohil.hil.run import run_hil
    r = run_hil(paper_scenario(tmp_path), tmp_path / "out", lockstep=True, plot=False, ready=lambda *a, **k: None,
                plant=plant)
    assert r.comparison["identical"] and r.comparison["replay_max_abs_difference"] == 0.0
    assert r.timing["watchdog_trips"] == 1 and r.timing["watchdog_trips_unexplained"] == 0
    assert r.timing["verdict"]["verdict"] == "VALID"


def test_a_sequence_silences_the_controller_of_a_circuit(tmp_path):
    """A circuit sequence's controller_silence action (at/until -> the compiled scenario's fault): the valve
    centred by the watchdog 50 ms into it, the piston stopped short of 150 mm while the reference moves on,
    there once the controller speaks again."""
    from hydrohil.sequences.runner import run_sequence
    scen = paper_scenario(tmp_path, faults="", duration=3.0, name="s.toml")
    seq = tmp_path / "seq.toml"
    seq.write_text(f'scenario = "{scen}"\n'
                   '[[actions]]\nname = "silent"\ntype = "controller_silence"\nat = 0.8\nuntil = 1.2\n'
                   '[[expect]]\nname = "centred by the watchdog"\ntype = "bounds"\nsignal = "valve.command"\n'
                   'after = 0.852\nuntil = 1.19\nmin = 0.0\nmax = 0.0\n'
                   '[[expect]]\nname = "at 150 mm after"\ntype = "tracking"\nafter = 2.0\nwithin = 0.5\n'
                   'until = 3.0\ntol = 5e-4\n')
    res = run_sequence(seq, tmp_path / "out")
    assert res.passed, [o.message for o in res.outcomes]
    compiled = sequence_scenario(tmp_path / "out")
    assert [(f["type"], f["start"], f["end"]) for f in compiled["faults"]] == [("controller_silence", 0.8, 1.2)]


@pytest.mark.parametrize("text, key, message", [
    ('[[faults]]\ntype = "packet_loss"\nstart = 1', "faults[0].probability", "required: the probability"),
    ('[[faults]]\ntype = "packet_loss"\nprobability = 1.5\nstart = 1', "faults[0].probability", "in (0, 1]"),
    ('[[faults]]\ntype = "network_delay"\ndelay = "2 s"\nstart = 1', "faults[0].delay", "in (0, 1]"),
    ('[[faults]]\ntype = "network_delay"\ndelay = "2 bar"\nstart = 1', "faults[0].delay", "s is wanted"),
    ('[[faults]]\ntype = "reordering"\nprobability = 0.1\nchance = 1\nstart = 1', "faults[0].chance", "unknown key"),
    ('[[faults]]\ntype = "controller_silence"\nstart = 2\nend = 1', "faults[0].end", "must be after start"),
    ('[hil]\nsafe_state = "hold"', "hil.hold_kp", "required with safe_state = \"hold\", got None"),
    ('[hil]\nsafe_state = "hold"\nhold_kp = -3', "hil.hold_kp", "the P gain in (0, 1e5] holding cyl.x with valve.command"),
    ('[hil]\nsafe_state = "brake"', "hil.safe_state", "centre (the commanded inputs to 0) or hold"),
])
def test_a_network_fault_or_safe_state_error_names_the_key(tmp_path, text, key, message):
    with pytest.raises(InputError, match=re.escape(message)) as e:
        load_circuit_scenario(paper_scenario(tmp_path, faults=f"{text}\n"))
    assert e.value.key == key, str(e.value)


def test_a_network_fault_needs_a_loop(tmp_path):
    """An open-loop scenario has no controller's commands to lose: refused, naming the fault."""
    text = (PAPER / "circuit.toml").read_text()
    (tmp_path / "circuit.toml").write_text(text)
    f = tmp_path / "open.toml"
    f.write_text('circuit = "circuit.toml"\nduration = 1.0\n[[faults]]\ntype = "packet_loss"\nprobability = 0.1\n'
                 'start = 0.1\n')
    with pytest.raises(InputError, match="acts on the closed loop's commands") as e:
        load_circuit_scenario(f)
    assert e.value.key == "faults[0].type"


HOLD = '[hil]\nseed = 7\nsafe_state = "hold"\nhold_kp = 40.0\n[[faults]]\ntype = "controller_silence"\nstart = 0.6\n' \
       'end = 0.9\n'


@pytest.mark.parametrize("plant", ["python", "c"])
def test_lockstep_hil_with_the_safe_state_hold_equals_offline(tmp_path, plant):
    """safe_state = "hold" on a circuit: a silent controller trips the watchdog, both plants hold the loop's
    measured signal with its command (the P law on its truth, hh_path_apply_held) as the offline loop does, so the
    lock-step run is the offline run bit for bit; the trip is explained by the silence (VALID)."""
    from hydrohil.hil.run import run_hil
    r = run_hil(paper_scenario(tmp_path, faults=HOLD, duration=1.2), tmp_path / "out", lockstep=True, plot=False,
                ready=lambda *a, **k: None, plant=plant)
    assert r.comparison["identical"] and r.comparison["replay_max_abs_difference"] == 0.0
    assert r.timing["watchdog_trips"] == 1 and r.timing["watchdog_trips_unexplained"] == 0


def test_the_safe_state_hold_needs_a_loop(tmp_path):
    """An open loop has no measured signal to hold: refused, naming the key."""
    (tmp_path / "circuit.toml").write_text((PAPER / "circuit.toml").read_text())
    f = tmp_path / "open.toml"
    f.write_text('circuit = "circuit.toml"\nduration = 1.0\n[hil]\nsafe_state = "hold"\nhold_kp = 40.0\n')
    with pytest.raises(InputError, match="this scenario has no \\[controller\\]") as e:
        load_circuit_scenario(f)
    assert e.value.key == "hil.safe_state"


def test_the_safe_state_hold_needs_a_directly_acting_loop(tmp_path):
    """A reverse-acting loop (a larger command lowers its signal) would be pushed away by the hold's P law: refused."""
    f = paper_scenario(tmp_path, faults='[hil]\nsafe_state = "hold"\nhold_kp = 40.0\n')
    f.write_text(f.read_text().replace('command = "valve.command"', 'command = "valve.command"\naction = "reverse"'))
    with pytest.raises(InputError, match="not with action = \"reverse\"") as e:
        load_circuit_scenario(f)
    assert e.value.key == "hil.safe_state"


@pytest.mark.slow
def test_a_clock_driven_controller_runs_a_circuits_loop(tmp_path):
    """[hil] controller_mode = "clock" on a circuit: the controller process acts on its own clock of the step on
    the newest SIGNALS packet (the paper rig's sampling loop): it ran (well over 1000 commands, on packets in
    order), the plant's applied inputs replay to its log bit for bit, and a run that kept time tracked Fig 11's
    reference to 150 mm."""
    import json
    from hydrohil.hil.run import run_hil
    from hydrohil.simulation.outputs import read_csv_columns
    scen = paper_scenario(tmp_path, faults='[hil]\ncontroller_mode = "clock"\n', duration=2.0)
    r = run_hil(scen, tmp_path / "out", lockstep=False, plot=False, ready=lambda *a, **k: None, plant="python")
    t = json.loads((tmp_path / "out" / "timing.json").read_text())
    ctl = read_csv_columns(tmp_path / "out" / "controller_log.csv")
    assert t["steps"] == 4000 and len(ctl["seq"]) > 1000
    assert np.all(np.diff(ctl["seq"]) >= 0)
    assert r.comparison["replay_max_abs_difference"] == 0.0
    if t["verdict"]["valid"]:
        x = read_csv_columns(tmp_path / "out" / "plant_log.csv")["cyl.x"]
        assert abs(x[-1] - 0.15) < 2e-3 and np.max(x) < 0.16
