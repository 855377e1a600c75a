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
