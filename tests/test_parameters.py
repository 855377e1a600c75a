"""SPEC §8 sanity figures and parameter-file validation."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hydrohil.errors import InputError
from hydrohil.models import valve
from hydrohil.models.linear import equilibrium_pressures
from hydrohil.parameters import load_parameters, read_toml, save_parameters
from hydrohil.parameters import BUILTIN_DIR


def test_sanity_figures(paper):
    k, kt = paper.valve.k, paper.valve.kt
    assert valve.delta_pm(70.0, k, kt) == pytest.approx(8.0, abs=0.05)
    assert valve.pressure_gain(k, kt) == pytest.approx(36.4, abs=0.2)
    assert valve.flow_gain(70.0, k, kt) == pytest.approx(28.2, abs=0.2)
    as1, as2, a1t, a2t = valve.pseudo_sections_np(1.0, k, kt)
    assert as1 == pytest.approx(25.5 / np.sqrt(35), rel=0.005)   # eq 10: 4.310
    assert a2t == pytest.approx(25.5 / np.sqrt(35), rel=0.005)   # eq 11
    assert as2 < 0.01 and a1t < 0.01                            # closed at full opening


def test_equilibrium_pressures_eq18(paper):
    p10, p20 = equilibrium_pressures(paper)
    assert p10 / 1e5 == pytest.approx(25.1, abs=0.05)
    assert p20 / 1e5 == pytest.approx(44.9, abs=0.05)


def test_leakage_eq23_from_paper_drift(paper):
    # the paper's drift test (§3.2.2): 1504 um in 200 s with P2 = 5.28 bar -> g_lkc = v*A2/P2 = 1.248e-14
    from hydrohil.identification import identify_leakage
    fit = identify_leakage({"displacement_m": 1504e-6, "duration_s": 200.0, "p2_pa": 5.28e5, "a2_m2": 8.7650e-4})
    assert fit.values["g_lkc"] == pytest.approx(1.248e-14, rel=1e-3)
    assert fit.values["g_lkc"] == pytest.approx(paper.cylinder.g_lkc, rel=1e-3)   # the set quotes the same


def test_every_value_is_commented():
    for line in (BUILTIN_DIR / "ferreira2004.toml").read_text().splitlines():
        if "=" in line and not line.lstrip().startswith("#"):
            assert "#" in line, f"uncommented value: {line}"


def test_overrides_by_dotted_name():
    prm = load_parameters("ferreira2004", {"supply.ps": 1.2e7, "supply.pt": 1e5, "load.mass": 40.0,
                                           "load.gravity_direction": 0, "load.force": 100.0,
                                           "cylinder.stroke": 0.2})
    assert (prm.supply.ps, prm.supply.pt, prm.load.mass, prm.cylinder.stroke) == (1.2e7, 1e5, 40.0, 0.2)


def test_round_trip_save_load(tmp_path, paper):
    save_parameters(paper, tmp_path / "p.toml", header="copy")
    assert load_parameters(tmp_path / "p.toml") == paper


def _write(tmp_path, data):
    import tomli_w
    f = tmp_path / "bad.toml"
    f.write_text(tomli_w.dumps(data))
    return f


@pytest.mark.parametrize("mutate,key,words", [
    (lambda d: d["supply"].update(bogus=1), "supply.bogus", "unknown key"),
    (lambda d: d["cylinder"].pop("a1"), "cylinder.a1", "missing"),
    (lambda d: d["load"].update(mass="heavy"), "load.mass", "number"),
    (lambda d: d["cylinder"].update(a1=-1e-3), "cylinder.a1", "m^2"),
    (lambda d: d["supply"].update(ps=70.0), "supply.ps", "Pa"),          # bar where Pa expected
    (lambda d: d["friction"]["positive"].update(fs=10.0), "friction.positive", "breakaway"),
])
def test_bad_parameter_files_name_file_and_key(tmp_path, mutate, key, words):
    d = read_toml(BUILTIN_DIR / "ferreira2004.toml")
    mutate(d)
    f = _write(tmp_path, d)
    with pytest.raises(InputError) as ei:
        load_parameters(f)
    msg = str(ei.value)
    assert str(f) in msg and key in msg and words in msg


def test_unknown_override_is_an_error():
    with pytest.raises(InputError, match="supply.psx"):
        load_parameters("ferreira2004", {"supply.psx": 1.0})


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(["cylinder.a1", "cylinder.v01", "spool.wn", "load.mass", "friction.sigma0"]),
       st.floats(max_value=0.0, allow_nan=False, allow_infinity=False))
def test_nonpositive_physical_quantities_rejected(key, value):
    with pytest.raises(InputError, match=key.replace(".", r"\.")):
        load_parameters("ferreira2004", {key: value})


def _without_linear(tmp_path, **changes):
    """The paper's set as a user writes it: no [linear] group; ``changes`` replace 'key = value' lines."""
    text = (BUILTIN_DIR / "ferreira2004.toml").read_text()
    head, _, tail = text.partition("[linear]")
    tail = tail[tail.index("\n["):]                       # drop the group up to the next table
    text = head + tail
    for key, value in changes.items():
        import re
        text = re.sub(rf"^{key} = [^#\n]*", f"{key} = {value} ", text, count=1, flags=re.M)
    path = tmp_path / "mine.toml"
    path.write_text(text)
    return path


def test_a_file_without_linear_gets_it_derived(tmp_path, paper):
    """Issue #25 §6: [linear] means nothing to most users: derived when absent. On the paper's k-set the
    derived eq 19 gains come out near the paper's own numbers (an independent check: the paper measured
    them at x̄s0 = 0.009, we derive at the centre): kq 4.74e-4 vs 4.76e-4, kp1 18.2 vs 19, kp2 -18.2 vs -15.6."""
    p = load_parameters(_without_linear(tmp_path))
    lin = p.linear
    assert lin.xp0 == pytest.approx(paper.cylinder.stroke / 2) and lin.xs0 == 0.0 and lin.pn == 35e5
    assert lin.kq == pytest.approx(paper.linear.kq, rel=0.01)
    assert lin.kp1 == pytest.approx(paper.linear.kp1, rel=0.05)
    assert lin.kp2 == pytest.approx(paper.linear.kp2, rel=0.20)
    f = paper.friction
    assert lin.friction_factor == pytest.approx((f.positive.kv + f.negative.kv) / 2)
    for k in ("spool", "valve", "supply", "cylinder", "friction", "load", "sensors"):
        assert getattr(p, k) == getattr(paper, k)


def test_params_show_units_descriptions_and_derived(tmp_path, paper):
    from conftest import hh
    r = hh("params", "show", "ferreira2004")
    assert r.returncode == 0 and "wn = 1007.01" in r.stdout and "# [rad/s] natural frequency" in r.stdout
    assert "mass = 80.0" in r.stdout and "# [kg] moved mass" in r.stdout and "derived" not in r.stdout
    (tmp_path / "shown.toml").write_text(r.stdout)
    assert load_parameters(tmp_path / "shown.toml") == paper          # what it prints loads back unchanged
    mine = _without_linear(tmp_path)
    r = hh("params", "show", mine)
    assert r.returncode == 0 and "[linear]" in r.stdout and "# derived: the file has no [linear]" in r.stdout
    import json
    doc = json.loads(hh("params", "show", mine, "--json").stdout)
    assert doc["derived"] == ["linear"] and doc["parameters"]["load"]["mass"] == 80.0
    row = next(f for f in doc["fields"] if f["key"] == "linear.kq")
    assert row["derived"] and row["unit"] == "m^3/s" and "flow gain" in row["description"]
    assert next(f for f in doc["fields"] if f["key"] == "spool.wn")["unit"] == "rad/s"


def test_probable_unit_mistakes_warn(tmp_path):
    """A spool ωn of 80 given as if Hz, a delay in ms: the set loads (they are valid numbers) with a warning
    that names the file, the key and the value the user probably meant."""
    from hydrohil.errors import InputWarning
    with pytest.warns(InputWarning, match=r"spool.wn: 80 rad/s is 12.7 Hz.*give 502.655 rad/s"):
        load_parameters(_without_linear(tmp_path, wn="80.0"))
    with pytest.warns(InputWarning, match=r"spool.delay: 0.05 s is 50 ms.*give 5e-05 s"):
        load_parameters(_without_linear(tmp_path, delay="0.05"))
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_parameters("ferreira2004")                           # the paper's set: nothing to say
    from conftest import hh
    r = hh("params", "show", _without_linear(tmp_path, wn="80.0"))
    assert r.returncode == 0 and "warning:" in r.stderr and "spool.wn" in r.stderr and "mine.toml" in r.stderr


def test_derived_linear_follows_changed_values(tmp_path):
    """A derived [linear] is derived again when the values it comes from change (an override when loading,
    replace_values in a sweep), and left out of a saved file; a key that sets one of its values makes it
    given."""
    from hydrohil.parameters import replace_values
    p = load_parameters(_without_linear(tmp_path), overrides={"cylinder.stroke": 0.08})
    assert p.derived_groups == {"linear"} and p.linear.xp0 == pytest.approx(0.04)
    q = replace_values(p, {"friction.positive.kv": 2000.0, "friction.negative.kv": 1000.0})
    assert q.linear.friction_factor == pytest.approx(1500.0) and q.derived_groups == {"linear"}
    r = replace_values(p, {"linear.xp0": 0.03})
    assert r.linear.xp0 == 0.03 and r.derived_groups == frozenset() and r.linear.kq == p.linear.kq
    save_parameters(q, tmp_path / "saved.toml")
    assert "[linear]" not in (tmp_path / "saved.toml").read_text()
    assert load_parameters(tmp_path / "saved.toml").linear == q.linear
    assert load_parameters("ferreira2004").derived_groups == frozenset()


def test_derived_pressure_gains_are_the_closed_port_slopes(tmp_path, paper):
    """The derived kp1, kp2 are the slopes at the valve's centre of the closed-port pressures written out
    here from eq 3 (P1/Ps = As1²/(As1² + A1t²)), differentiated analytically: a self-consistent check (the
    paper's own 19 / -15.6 were measured at its x̄s0 = 0.009, so they are near, not equal)."""
    k, kt = paper.valve.k, paper.valve.kt

    def sec(x, c):        # value and slope of one pseudo-section at x (inside its sqrt's domain)
        q = c[2] * x * x + c[3] * x + c[4]
        return c[0] * x + c[1] + np.sqrt(q), c[0] + (2 * c[2] * x + c[3]) / (2 * np.sqrt(q))

    def ratio_slope(a, da, b, db):    # d/dx of a² / (a² + b²)
        return (2 * a * da * (a * a + b * b) - a * a * (2 * a * da + 2 * b * db)) / (a * a + b * b) ** 2
    as1, das1 = sec(0.0, k)
    das1 = -das1                       # As1(x) = section(-x)
    a1t, da1t = sec(0.0, kt)
    as2, das2 = sec(0.0, k)
    a2t, da2t = sec(0.0, kt)
    da2t = -da2t
    lin = load_parameters(_without_linear(tmp_path)).linear
    assert lin.kp1 == pytest.approx(ratio_slope(as1, das1, a1t, da1t), rel=1e-6)
    assert lin.kp2 == pytest.approx(ratio_slope(as2, das2, a2t, da2t), rel=1e-6)
    assert lin.kq == pytest.approx((das1 - da1t) * np.sqrt(35.0) / 60000.0, rel=1e-6)


def test_read_toml_parses_a_file_once_and_sees_every_change(tmp_path):
    """A TOML file read again unchanged is not parsed again (a study reads its parameter file every run), each
    read its own copy; a change of its content or of its modification time is read anew; an error still names
    the file."""
    import os
    from hydrohil.parameters import _parsed, read_toml
    f = tmp_path / "a.toml"
    f.write_text('x = 1\n[t]\nv = [1, 2]\n')
    first = read_toml(f)
    first["t"]["v"].append(3)
    hits = _parsed.cache_info().hits
    assert read_toml(f) == {"x": 1, "t": {"v": [1, 2]}} and _parsed.cache_info().hits == hits + 1
    f.write_text('x = 2\n[t]\nv = [1, 2]\n')                      # (the same size: its time differs)
    st = f.stat()
    os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert read_toml(f)["x"] == 2
    f.write_text('x = 30\n')
    assert read_toml(f) == {"x": 30}
    f.write_text('x = \n')
    with pytest.raises(InputError, match="invalid TOML") as e:
        read_toml(f)
    assert str(f) in str(e.value)
