import subprocess
import sys

import numpy as np
import pytest

from hydrohil.parameters import load_parameters

from pathlib import Path

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.fixture(scope="session")
def paper():
    return load_parameters("ferreira2004")


def rms(e):
    return float(np.sqrt(np.mean(np.asarray(e) ** 2)))


def hh(*args, cwd=None, timeout=300, env=None):
    """Run the ``hydrohil`` CLI as a subprocess (what a user types); ``env``: extra environment variables."""
    full_env = None if env is None else {**__import__("os").environ, **env}
    return subprocess.run([sys.executable, "-m", "hydrohil.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout, env=full_env)


@pytest.fixture(scope="session")
def c_plant():
    """The standalone C plant (``hydrohil export c``) of the paper's set, built once (cached)."""
    from hydrohil.export.cplant import cached_plant
    return cached_plant(load_parameters("ferreira2004"), step=5e-4, duration=10.0, label="ferreira2004")


def plant_cmd(kind: str, c_plant, *args) -> list:
    """The command line of a plant server: ``hydrohil plant`` or the standalone C plant, same options."""
    from hydrohil.hil.processes import cli
    return cli("plant", *args) if kind == "python" else [c_plant, *args]


def lockstep_equals_offline(scen, out, *args, steps: int):
    """Run ``hydrohil hil SCEN --lockstep`` into ``out`` and the same scenario offline; assert that the plant
    stepped the model exactly as the offline run did (``steps`` + 1 rows, state bit for bit). Returns (plant
    log columns, offline result)."""
    from hydrohil.hil.run import read_csv_columns
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    r = hh("hil", scen, "--out", out, "--lockstep", *args, timeout=600)
    assert r.returncode == 0, r.stderr
    log = read_csv_columns(Path(out) / "plant_log.csv")
    off = run_scenario(load_scenario(scen))
    assert len(log["t"]) == len(off.log) == steps + 1
    for c in ("xp", "p1", "p2", "xs"):
        assert np.array_equal(log[c], off.column(c)), c
    return log, off
