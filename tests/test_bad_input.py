"""Bad input everywhere (issue #6): property-based mutations of parameter, scenario and identification
files. Each either loads (the mutation was valid) or fails with :class:`InputError` naming the file, and a
command given the bad file exits 2 and writes nothing."""

import copy
import math

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from conftest import EXAMPLES, hh
from hydrohil.errors import InputError
from hydrohil.identification import PROCEDURES, identify
from hydrohil.parameters import BUILTIN_DIR, load_parameters, read_toml
from hydrohil.simulation.scenario import load_scenario

PARAMS = read_toml(BUILTIN_DIR / "ferreira2004.toml")
SCENARIO = read_toml(EXAMPLES / "faults" / "hose_burst.toml")

BAD_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**12, 10**12), st.text(max_size=8),
    st.booleans(), st.lists(st.floats(allow_nan=False), max_size=3), st.just({"x": 1}),
    st.sampled_from([0.0, -1.0, 1e30, -1e30, math.nan, math.inf, "", "70 bar"]))


def leaves(d, prefix=()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from leaves(v, prefix + (k,))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for i, item in enumerate(v):
                yield from leaves(item, prefix + (k, i))
        else:
            yield prefix + (k,)


def mutated(base, path, op, value):
    d = copy.deepcopy(base)
    node = d
    for part in path[:-1]:
        node = node[part]
    if op == "delete":
        del node[path[-1]]
    elif op == "unknown":
        node[f"{path[-1]}_typo"] = 1.0
    else:
        node[path[-1]] = value
    return d


def _write(tmp_path, name, data):
    f = tmp_path / name
    f.write_text(tomli_w.dumps(data))
    return f


PARAM_LEAVES = list(leaves(PARAMS))
SCENARIO_LEAVES = list(leaves(SCENARIO))
MUTATION = st.sampled_from(["replace", "replace", "replace", "delete", "unknown"])


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(path=st.sampled_from(PARAM_LEAVES), op=MUTATION, value=BAD_VALUES)
def test_mutated_parameter_files_load_or_name_file_and_key(tmp_path, path, op, value):
    f = _write(tmp_path, "params.toml", mutated(PARAMS, path, op, value))
    try:
        p = load_parameters(f)
    except InputError as exc:
        msg = str(exc)
        assert str(f) in msg
        assert path[0] in msg                  # the group (and usually the dotted key) is named
        return
    for v in (p.supply.ps, p.cylinder.a1, p.cylinder.v01, p.load.mass, p.spool.wn):
        assert math.isfinite(v) and v > 0      # whatever loads is physical


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(path=st.sampled_from(SCENARIO_LEAVES), op=MUTATION, value=BAD_VALUES)
@example(path=("params",), op="replace", value="0")          # found by hypothesis: unknown parameter set
@example(path=("params",), op="replace", value="")           # ... and a directory
def test_mutated_scenario_files_load_or_name_file_and_key(tmp_path, path, op, value):
    f = _write(tmp_path, "scenario.toml", mutated(SCENARIO, path, op, value))
    try:
        sc = load_scenario(f)
    except InputError as exc:
        assert str(f) in str(exc)
        return
    assert sc.scenario.duration > 0 and 0 <= sc.scenario.initial.xp <= sc.params.cylinder.stroke


@pytest.mark.parametrize("edit, key", [
    (lambda d: d["initial"].update(xp=0.5), "initial.xp"),                      # beyond the 0.18 m stroke
    (lambda d: d["faults"][0].update(line=0), "faults.0"),
    (lambda d: d.update(overrides={"cylinder.v01": 0.0}), "cylinder.v01"),     # zero dead volume
    (lambda d: d.update(overrides={"cylinder.a2": -8e-4}), "cylinder.a2"),     # negative area
    (lambda d: d["solver"].update(step=float("nan")), "solver.step"),
])
def test_simulate_bad_scenario_exits_2_and_writes_nothing(tmp_path, edit, key):
    d = copy.deepcopy(SCENARIO)
    edit(d)
    f = _write(tmp_path, "bad.toml", d)
    out = tmp_path / "out"
    for cmd in (("simulate", f, "--out", out), ("hil", f, "--out", out, "--lockstep")):
        r = hh(*cmd)
        assert r.returncode == 2, r.stderr
        line = r.stderr.strip().splitlines()[-1]
        assert str(f) in line and key in line
        assert not out.exists()


CSV_GARBAGE = st.one_of(
    st.binary(max_size=300).map(lambda b: b.decode("latin-1")),
    st.lists(st.lists(st.sampled_from(["1", "-2.5", "nan", "x", "", "1e400", "0"]), min_size=1, max_size=6),
             max_size=30).map(lambda rows: "\n".join(",".join(r) for r in rows)))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(proc=st.sampled_from([p for p in PROCEDURES if p != "valve-static"]), body=CSV_GARBAGE,
       header=st.booleans())
def test_malformed_identification_csv_is_an_input_error(tmp_path, proc, body, header):
    heads = {"spool": "amplitude,frequency_hz,gain_db,phase_deg", "bulk-modulus": "ps,frequency_hz,accel",
             "leakage": "t,xp,p2", "friction-static": "v,ff", "friction-dynamic": "t,u,p1,p2,xp"}
    f = tmp_path / "data.csv"
    f.write_text((heads[proc] + "\n" if header else "") + body)
    try:
        identify(proc, f, load_parameters("ferreira2004"))
    except InputError as exc:
        assert str(f) in str(exc)
    # a garbage file that happens to be valid data may fit; any other exception fails the test


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(["qn_lpm", "pn_bar", "ps_bar", "kq0_lpm", "kp0", "dpm_bar"]), value=BAD_VALUES)
def test_malformed_valve_datasheet_is_an_input_error(tmp_path, key, value):
    d = read_toml(EXAMPLES / "identification" / "valve_datasheet.toml")
    d[key] = value
    f = _write(tmp_path, "datasheet.toml", d)
    try:
        fit = identify("valve-static", f, load_parameters("ferreira2004"))
    except InputError as exc:
        assert str(f) in str(exc) and key in str(exc)
        return
    assert np.all(np.isfinite(fit.values["k"] + fit.values["kt"]))


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_datasheet_value_is_rejected(tmp_path, value):
    # NaN passed the range check (comparisons with NaN are false) and produced a "fit"; found by the review
    d = read_toml(EXAMPLES / "identification" / "valve_datasheet.toml")
    d["qn_lpm"] = value
    f = _write(tmp_path, "datasheet.toml", d)
    with pytest.raises(InputError, match="qn_lpm"):
        identify("valve-static", f, load_parameters("ferreira2004"))


FIG11 = read_toml(EXAMPLES / "fig11_p_control.toml")


def _renamed(d, path, new):
    """``d`` with the key at ``path`` renamed to ``new`` (a misspelling)."""
    d = copy.deepcopy(d)
    node = d
    for part in path[:-1]:
        node = node[part]
    node[new] = node.pop(path[-1])
    return d


def test_misspelt_key_is_named_with_a_suggestion_exit_2_nothing_written(tmp_path):
    f = _write(tmp_path, "typo.toml", _renamed(FIG11, ("duration",), "duraton"))
    out = tmp_path / "out"
    r = hh("simulate", f, "--out", out)
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip().splitlines()[-1]
    assert line == f"error: {f}: unknown key 'duraton' (did you mean 'duration'?)"
    assert "missing key" not in r.stderr
    assert not out.exists()


@pytest.mark.parametrize("base, path, typo, expected", [
    (FIG11, ("solver", "method"), "methd", "unknown key 'solver.methd' (did you mean 'solver.method'?)"),
    (FIG11, ("controller", "kp"), "kpp", "unknown key 'controller.kpp' (did you mean 'controller.kp'?)"),
    (FIG11, ("reference", "x"), "xx", "unknown key 'reference.xx' (did you mean 'reference.x'?)"),
    (SCENARIO, ("faults", 0, "section"), "sectoin",
     "unknown key 'faults.0.sectoin' (did you mean 'faults.0.section'?)"),
    (SCENARIO, ("initial", "xp"), "x_p", "unknown key 'initial.x_p' (did you mean 'initial.xp'?)"),
])
def test_misspelt_scenario_key_suggests_the_closest(tmp_path, base, path, typo, expected):
    f = _write(tmp_path, "typo.toml", _renamed(base, path, typo))
    with pytest.raises(InputError) as e:
        load_scenario(f)
    assert str(e.value) == f"{f}: {expected}"


def test_misspelt_key_far_from_any_lists_the_valid_ones(tmp_path):
    d = copy.deepcopy(FIG11)
    d["solver"]["zzzzzz"] = 1
    f = _write(tmp_path, "typo.toml", d)
    with pytest.raises(InputError, match=r"unknown key 'solver.zzzzzz' \(valid: method, step, output_every, rtol\)"):
        load_scenario(f)


def test_misspelt_fault_type_suggests_the_closest(tmp_path):
    d = copy.deepcopy(SCENARIO)
    d["faults"][0]["type"] = "hose_brust"
    f = _write(tmp_path, "typo.toml", d)
    with pytest.raises(InputError) as e:
        load_scenario(f)
    assert str(e.value) == f"{f}: faults.0.type: unknown type 'hose_brust' (did you mean 'hose_burst'?)"


def test_misspelt_parameter_key_suggests_the_closest(tmp_path):
    f = _write(tmp_path, "params.toml", _renamed(PARAMS, ("cylinder", "stroke"), "strok"))
    with pytest.raises(InputError) as e:
        load_parameters(f)
    assert str(e.value) == f"{f}: unknown key 'cylinder.strok' (did you mean 'cylinder.stroke'?)"


@pytest.mark.parametrize("key, expected", [
    ("supply.pss", "unknown parameter 'supply.pss' (did you mean 'supply.ps'?)"),
    ("suply.ps", "unknown parameter group 'suply' (did you mean 'supply'?)"),
    ("load.gravity_directon", "unknown parameter 'load.gravity_directon' (did you mean 'load.gravity_direction'?)"),
])
def test_misspelt_override_suggests_the_closest(tmp_path, key, expected):
    d = copy.deepcopy(SCENARIO)
    d["overrides"] = {key: 1}
    f = _write(tmp_path, "typo.toml", d)
    with pytest.raises(InputError) as e:
        load_scenario(f)
    assert str(e.value).startswith(f"{f}: overrides.{key}: {expected}")
    r = hh("identify", "leakage", EXAMPLES / "identification" / "drift_test.toml", "--set", f"{key}=1")
    assert r.returncode == 2 and expected in r.stderr, r.stderr       # the same for --set


@pytest.mark.parametrize("edit, expected", [
    (lambda d: d["solver"].update(step=-1), "solver.step: must be > 1e-09 [s], got -1"),
    (lambda d: d.update(duration=7200.0), "duration: must be <= 3600 [s], got 7200.0"),
    (lambda d: d.update(hil={"watchdog_timeout": 0}), "hil.watchdog_timeout: must be > 0 [s], got 0"),
    (lambda d: d["faults"][0].update(section=-1.0), "faults.0.section: must be > 0 [(l/min)/sqrt(bar)], got -1.0"),
    (lambda d: d["faults"][0].update(end=1e4), "faults.0.end: must be <= 3600 [s], got 10000.0"),
    (lambda d: d.update(overrides={"cylinder.stroke": -0.1}), "overrides.cylinder.stroke: must be > 0 [m], got -0.1"),
    (lambda d: d.update(overrides={"supply.ps": 70}), "overrides.supply.ps: must be > 100000 [Pa], got 70"),
])
def test_range_errors_state_bound_and_unit(tmp_path, edit, expected):
    d = copy.deepcopy(SCENARIO)
    edit(d)
    f = _write(tmp_path, "bad.toml", d)
    with pytest.raises(InputError) as e:
        load_scenario(f)
    assert str(e.value) == f"{f}: {expected}"


def test_reference_beyond_stroke_warns_and_runs(tmp_path):
    d = copy.deepcopy(FIG11)
    d["reference"]["x"] = [0.03, 0.03, 0.25, 0.25, 0.03, 0.03]    # the stroke is 0.18 m
    d["duration"] = 2.0
    f = _write(tmp_path, "far.toml", d)
    with pytest.warns(UserWarning, match=r"reference\.x = 0\.25 m .*outside the stroke \[0, 0\.18\] m"):
        load_scenario(f)
    r = hh("simulate", f, "--out", tmp_path / "out", "--no-plot")
    assert r.returncode == 0, r.stderr
    assert f"warning: {f}: reference.x = 0.25 m (at t = 1.5 s) lies outside the stroke [0, 0.18] m" in r.stderr
    assert (tmp_path / "out" / "log.csv").exists()


def test_reference_inside_stroke_does_not_warn():
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_scenario(EXAMPLES / "fig11_p_control.toml")


@pytest.mark.parametrize("args", [
    ("simulate", EXAMPLES / "fig11_p_control.toml", "--out", "{file}"),
    ("hil", EXAMPLES / "fig11_p_control.toml", "--lockstep", "--out", "{file}"),
    ("test", EXAMPLES / "sequences" / "fig11_p_passes.toml", "--out", "{file}"),
    ("circuit", "draw", "two_cylinders", "--out", "{file}/x.png"),
    ("identify", "friction-static", EXAMPLES / "identification" / "friction_static.csv", "--out", "{file}/x.toml"),
])
def test_an_out_that_cannot_be_written_is_refused_before_anything_runs(tmp_path, args):
    """--out naming an existing file (a folder wanted) or a path through a file: exit 2 at once, the option and
    the file named, no traceback, nothing run."""
    f = tmp_path / "afile"
    f.write_text("mine\n")
    r = hh(*[str(a).format(file=f) for a in args])
    assert r.returncode == 2 and "Invalid value for '--out'" in r.stderr and str(f) in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and f.read_text() == "mine\n"


def test_a_command_lines_bad_value_is_blamed_on_its_option_not_the_file(tmp_path):
    """--step and --solver out of range name the option (the scenario file is right), on the paper's rig and on
    a circuit scenario alike."""
    for scen in (EXAMPLES / "fig11_p_control.toml", EXAMPLES / "circuits" / "two_cylinders" / "scenario.toml"):
        r = hh("simulate", scen, "--out", tmp_path / "o", "--step", "-0.001")
        assert r.returncode == 2 and r.stderr.startswith("error: --step: "), r.stderr
        r = hh("simulate", scen, "--out", tmp_path / "o", "--solver", "rk5")
        assert r.returncode == 2 and r.stderr.startswith("error: --solver: ") and "rk5" in r.stderr, r.stderr
    assert not (tmp_path / "o").exists()
