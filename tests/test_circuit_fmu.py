"""A circuit as an FMU (issue #27: `export fmu --circuit/--scenario`): it validates with FMPy (FMI 2 and 3),
and stepped from Python as an importer does (inputs set, outputs read, doStep) it gives `simulate`'s run of the
same circuit bit for bit (the same generated C, the same flags); a closed loop's plant starts where the loop's
run starts; its state round-trips; bad calls get a status and a message."""

import math
import subprocess
import sys

import numpy as np
import pytest

from fmpy import extract  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from test_fmu import Fmu  # noqa: E402   (FMPy's slave classes for FMI 2 and 3)

from hydrohil.circuits.build import compile_circuit  # noqa: E402
from hydrohil.circuits.circuit import CIRCUITS_DIR, load_circuit  # noqa: E402
from hydrohil.circuits.run import input_table, simulate_circuit  # noqa: E402
from hydrohil.circuits.scenario import load_circuit_scenario  # noqa: E402
from hydrohil.export.fmu import export_circuit_fmu  # noqa: E402


def outputs(f):
    return [n for n, vr in f.vr.items() if 2000 <= vr < 3000]


def modes(f):
    return [n for n, vr in f.vr.items() if 3000 <= vr < 4000 and n != "time"]   # (from 4000: Model Exchange's)


def drive(f, c, u, n, h, on_step=None):
    """Step the FMU n steps of h with the inputs u[k] set at each t_k; the outputs and modes read at each t_k."""
    outs, mds = outputs(f), modes(f)
    rows = np.zeros((n + 1, len(outs) + len(mds)))
    for k in range(n + 1):
        if c.inputs:
            f.set(**{s: u[min(k, n - 1), j] for j, s in enumerate(c.inputs)})
        if on_step:
            on_step(k, f)
        rows[k, :len(outs)] = f.real(*outs)
        if mds:
            rows[k, len(outs):] = f.integer(*mds)
        if k < n:
            f.step(k * h, h)
    return outs + mds, rows


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("name", ["two_cylinders", "pump_relief_accumulator", "lift_platform"])
def test_a_circuit_fmu_validates_and_gives_simulates_run_bit_for_bit(tmp_path, fmi, name):
    c = load_circuit(name)
    path = export_circuit_fmu(c, tmp_path / f"{name}.fmu", fmi=fmi, platforms=["host"])
    assert validate_fmu(str(path)) == []
    f = Fmu(str(path), extract(str(path), unzipdir=tmp_path / "u"))
    f.s.enterInitializationMode()
    f.s.exitInitializationMode()
    h, duration = 5e-4, 6.0
    n = int(round(duration / h))
    names, rows = drive(f, c, input_table(c, n, h), n, h)
    ref = simulate_circuit(c, duration)
    for j, col in enumerate(names):
        assert np.array_equal(rows[:, j], ref.columns[col]), col            # (measured: equal, every column)
    assert {"supply.p", "relief.q", "relief.mode"} <= set(names)


def test_a_closed_loop_plant_starts_where_the_loop_starts_and_its_state_round_trips(tmp_path):
    """The ferreira2004 scenario's plant as an FMU: its command input starts at the command that holds the
    piston (-0.00918); the scenario's P law closed around it from Python gives the run of `simulate` (the same
    law, from the core); an FMU state taken at 1 s and set back replays the same second."""
    from hydrohil.control import p_control
    cs = load_circuit_scenario(CIRCUITS_DIR / "ferreira2004" / "scenario.toml")
    path = export_circuit_fmu(cs.circuit, tmp_path / "fe.fmu", fmi=2, loop=cs.loop, platforms=["host"])
    f = Fmu(str(path), extract(str(path), unzipdir=tmp_path / "u"))
    f.s.enterInitializationMode()
    f.s.exitInitializationMode()
    assert f.real("valve.command")[0] == pytest.approx(-0.00917824406, abs=1e-10)
    ref = simulate_circuit(cs.circuit, cs.duration, loop=cs.loop)
    h, n = cs.step, cs.n_steps
    x_ref = ref.column("cyl.x.reference")
    saved = {}

    def control(k, fmu):                  # the scenario's P law on the 1 um encoder's counts, as its loop reads
        x = fmu.real("cyl.x")[0]
        fmu.set(**{"valve.command": p_control(50.0, x_ref[k], math.floor(x / 1e-6 + 0.5) * 1e-6)})
        if k == 2000:
            saved["state"] = fmu.s.getFMUState()
    names, rows = drive(f, cs.circuit, np.zeros((n, 1)), n, h, on_step=control)
    x = rows[:, names.index("cyl.x")]
    assert np.array_equal(x, ref.column("cyl.x"))                              # (measured: equal)
    f.s.setFMUState(saved["state"])
    again = []
    for k in range(2000, 4000):
        control(k, f) if k > 2000 else None
        again.append(f.real("cyl.x")[0])
        f.step(k * h, h)
    assert np.array_equal(np.array(again), x[2000:4000])


def test_export_fmu_of_a_circuit_as_a_user_types_it(tmp_path):
    """`hydrohil export fmu --circuit NAME --set ...` and `--scenario FILE`; errors exit 2 naming the key."""
    def cli(*args):
        return subprocess.run([sys.executable, "-m", "hydrohil.cli", *map(str, args)], capture_output=True, text=True)
    r = cli("export", "fmu", "--circuit", "motor_speed", "--out", tmp_path / "m.fmu", "--fmi", "3", "--set",
            "motor.inertia=0.05 kg.m2")
    assert r.returncode == 0, r.stderr
    assert "FMI 3.0 Model Exchange and Co-Simulation of circuit motor_speed" in r.stdout and validate_fmu(str(tmp_path / "m.fmu")) == []
    from fmpy import read_model_description
    md = read_model_description(str(tmp_path / "m.fmu"))
    units = {v.name: v.unit for v in md.modelVariables}
    assert units["motor.w"] == "rad/s" and units["a.p"] == "Pa" and units["motor.load_torque"] == "N.m"
    bad = cli("export", "fmu", "--circuit", "motor_speed", "--out", tmp_path / "b.fmu", "--set", "motor.inertia=3 bar")
    assert bad.returncode == 2 and "components.motor.inertia" in bad.stderr and not (tmp_path / "b.fmu").exists()
    none = cli("export", "fmu", "--circuit", "nowhere", "--out", tmp_path / "n.fmu")
    assert none.returncode == 2 and "no circuit 'nowhere'" in none.stderr
    both = cli("export", "fmu", "--out", tmp_path / "p.fmu", "--set", "cyl.mass=3")   # (the paper's rig's keys)
    assert both.returncode == 2 and "--set: cyl.mass: unknown parameter group 'cyl'" in both.stderr
    assert not (tmp_path / "p.fmu").exists()


@pytest.mark.slow
@pytest.mark.parametrize("name, fmi, limit", [("two_cylinders", 2, 6e-5), ("counterbalance_hose_burst", 3, 5e-5)])
def test_a_circuit_as_model_exchange_with_cvode_gives_its_reference(tmp_path, name, fmi, limit):
    """Issue #28 §3, §5: a circuit's FMU as Model Exchange (its states, derivatives, guards as event indicators,
    modes switched at the events), integrated by FMPy with CVode (rtol 1e-7) under its drives held over each 0.5 ms
    for 3 s: every pressure, position and speed within ``limit`` RMS of its peak from its continuous reference
    (measured at most 1.9e-5 and 1.8e-5, a pressure each)."""
    from fmpy import read_model_description, simulate_fmu
    c = load_circuit(name)
    path = export_circuit_fmu(c, tmp_path / f"{name}.fmu", fmi=fmi, platforms=["host"])
    md = read_model_description(str(path))
    assert md.modelExchange is not None and md.numberOfContinuousStates == len(compile_circuit(c).layout.states)
    h, duration = 5e-4, 3.0
    n = int(round(duration / h))
    u, t = input_table(c, n, h), np.arange(n + 1) * h
    held = np.array(list(zip(np.repeat(t, 2)[1:], *(np.repeat(u[:n + 1, j], 2)[:-1] for j in range(len(c.inputs))))),
                    dtype=[("time", float)] + [(s, float) for s in c.inputs])
    outs = [v.name for v in md.modelVariables if v.causality == "output" and v.name.endswith((".p", ".x", ".v"))]
    r = simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=duration, output_interval=h, input=held,
                     output=outs, relative_tolerance=1e-7, record_events=False)
    ref = simulate_circuit(c, duration, method="reference")
    for col in outs:
        peak = np.max(np.abs(ref.column(col)))
        if peak > 0:
            assert np.sqrt(np.mean((r[col] - ref.column(col)) ** 2)) <= limit * peak, col


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_circuit_fmu_under_address_and_undefined_behaviour_sanitizers(tmp_path, fmi):
    """tests/c/circuit_fmu_edges.c built with the FMU's own sources under ASan and UBSan: NULL and wrong-state
    calls, inputs set before initialisation, unknown references, a state into a fresh instance, truncated and
    foreign states: each answered with a status and a message, nothing read past the bytes given."""
    from conftest import sanitized_harness
    path = export_circuit_fmu(load_circuit("counterbalance_hose_burst"), tmp_path / "c.fmu", fmi=fmi,
                              platforms=["host"])
    src = f"{extract(str(path), unzipdir=tmp_path / 'u')}/sources"
    out = sanitized_harness(tmp_path, "circuit_fmu_edges.c", src, ["circuit.c", "plant_fmu.c", "fmu_instance.c",
                                                                   f"fmi{fmi}Functions.c"], fmi)
    for message in ("outputs exist from initialisation mode on", "is not a settable Real", "must be finite",
                    "before the last communication point", "too short for a hydrohil FMU state",
                    "not a hydrohil FMU state", "this FMU reads format 2", "FMU state of another export"):
        assert message in out, (message, out)


def test_a_circuit_without_inputs_exports_and_exports_differing_in_values_differ(tmp_path):
    """A circuit with no input signal still makes an FMU (validates, steps); two exports differing only in a
    parameter value have different tokens (a state of one is refused by the other)."""
    from fmpy import read_model_description
    from hydrohil.circuits.circuit import circuit_from_dict
    c = circuit_from_dict({"name": "no \"inputs\"", "components": {
        "s": {"type": "pressure_source", "p": "s", "pressure": "100 bar"}, "t": {"type": "tank", "p": "t"},
        "o": {"type": "orifice", "a": "s", "b": "n", "area": "1 mm2"},
        "o2": {"type": "orifice", "a": "n", "b": "t", "area": "1 mm2"},
        "v": {"type": "volume", "p": "n", "volume": "1 l"}}}, "test.toml")
    path = export_circuit_fmu(c, tmp_path / "none.fmu", fmi=2, platforms=["host"])
    assert validate_fmu(str(path)) == []
    f = Fmu(str(path), extract(str(path), unzipdir=tmp_path / "u"))
    f.s.enterInitializationMode()
    f.s.exitInitializationMode()
    f.step(0.0, 0.01)
    assert f.real("n.p")[0] == pytest.approx(50e5, rel=1e-9)
    c2 = circuit_from_dict({"name": "x", "components": {**{k: dict(v) for k, v in {
        "s": {"type": "pressure_source", "p": "s", "pressure": "100 bar"}, "t": {"type": "tank", "p": "t"},
        "o": {"type": "orifice", "a": "s", "b": "n", "area": "1 mm2"},
        "o2": {"type": "orifice", "a": "n", "b": "t", "area": "1 mm2"},
        "v": {"type": "volume", "p": "n", "volume": "2 l"}}.items()}}}, "test.toml")
    c1 = circuit_from_dict({"name": "x", "components": {**{k: dict(v) for k, v in {
        "s": {"type": "pressure_source", "p": "s", "pressure": "100 bar"}, "t": {"type": "tank", "p": "t"},
        "o": {"type": "orifice", "a": "s", "b": "n", "area": "1 mm2"},
        "o2": {"type": "orifice", "a": "n", "b": "t", "area": "1 mm2"},
        "v": {"type": "volume", "p": "n", "volume": "1 l"}}.items()}}}, "test.toml")
    g1 = read_model_description(str(export_circuit_fmu(c1, tmp_path / "a.fmu", platforms=["host"]))).guid
    g2 = read_model_description(str(export_circuit_fmu(c2, tmp_path / "b.fmu", platforms=["host"]))).guid
    assert g1 != g2
