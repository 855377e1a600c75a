pytest_plugins = ["pytester"]    # tests of the hydrohil pytest plugin (rig fixture) run pytest in pytest

import math
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


def sequence_scenario(out) -> dict:
    """The scenario a circuit sequence's run under ``out`` compiled and ran (its [[faults]] from the actions)."""
    import tomllib
    return tomllib.loads(next(Path(out).rglob("scenario.toml")).read_text())


def hh_command(*args) -> list[str]:
    """The ``hydrohil`` command line (what a user types) with this interpreter."""
    return [sys.executable, "-m", "hydrohil.cli", *map(str, args)]


def hh(*args, cwd=None, timeout=300, env=None):
    """Run the ``hydrohil`` CLI as a subprocess (what a user types); ``env``: extra environment variables."""
    full_env = None if env is None else {**__import__("os").environ, **env}
    return subprocess.run(hh_command(*args), capture_output=True, text=True, cwd=cwd, timeout=timeout, env=full_env)


@pytest.fixture(scope="session")
def c_plant():
    """The standalone C plant (``hydrohil export c``) of the paper's set, built once (cached)."""
    from hydrohil.export.cplant import cached_plant
    return cached_plant(load_parameters("ferreira2004"), step=5e-4, duration=10.0, label="ferreira2004")


def plant_cmd(kind: str, c_plant, *args) -> list:
    """The command line of a plant server: the Python plant as the library starts it (``python -m hydrohil.hil
    plant``, the options of ``hydrohil plant``) or the standalone C plant, same options."""
    from hydrohil.hil.processes import process_command
    return process_command("plant", *args) if kind == "python" else [c_plant, *args]


def lockstep_equals_offline(scen, out, *args, steps: int):
    """Run ``hydrohil hil SCEN --lockstep`` into ``out`` and the same scenario offline; assert that the plant
    stepped the model exactly as the offline run did (``steps`` + 1 rows, state bit for bit). Returns (plant
    log columns, offline result)."""
    from hydrohil.simulation.outputs import read_csv_columns
    from hydrohil.simulation.run import run_scenario
    from hydrohil.simulation.scenario import load_scenario
    r = hh("hil", scen, "--out", out, "--lockstep", *args, timeout=600)
    assert r.returncode == 0, r.stderr
    log = read_csv_columns(Path(out) / "plant_log.csv")
    off = run_scenario(load_scenario(scen))      # (the generated code: the core's plants' run bit for bit)
    assert len(log["t"]) == len(off.log) == steps + 1
    for c in ("xp", "p1", "p2", "xs"):
        assert np.array_equal(log[c], off.column(c)), c
    return log, off


class PanelProcess:
    """``hydrohil panel`` as a user starts it (a subprocess), driven through its HTTP API. Every wait is for
    a handshake (the PANEL / SESSION lines, a step count in /api/state), never a fixed time."""

    def __init__(self, out, *args):
        from hydrohil.hil.processes import Child
        self.child = Child(hh_command("panel", "--out", out, "--port", "0", *args), "panel")
        self.url = self.child.wait_line("PANEL ", 120)
        self.session = Path(self.child.wait_line("SESSION ", 120).split()[0])     # (``out`` is absolute)

    def api(self, path, body=None, token=True):
        import json as _json
        import urllib.request
        base = self.url.split("?")[0]
        q = ("?" + self.url.split("?")[1]) if ("?" in self.url and token) else ""
        req = urllib.request.Request(base + path.lstrip("/") + q, data=None if body is None else _json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"}, method="GET" if body is None else "POST")
        with urllib.request.urlopen(req, timeout=60) as r:
            return _json.loads(r.read())

    def wait_steps(self, n, timeout=120):
        """Until the plant has streamed ``n`` steps to the panel (its telemetry is the handshake)."""
        import time
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            s = self.api("api/state")
            if s["counters"]["steps"] >= n:
                return s
            time.sleep(0.05)              # polling the panel's state (not waiting for a time to pass)
        raise AssertionError(f"the plant did not reach {n} steps within {timeout} s")

    def close(self):
        self.child.stop(30)


def sanitized_harness(tmp_path, harness: str, src: str, units: list[str], fmi: int) -> str:
    """Build tests/c/<harness> with an FMU's sources (``src``: its sources folder; ``units``: its C files) under
    AddressSanitizer and UBSan (-DFMI=fmi, warnings as errors), run it, check it passed with no sanitizer
    report; returns what it printed (the FMU's messages)."""
    import shutil
    cc = shutil.which("gcc") or shutil.which("cc")
    here = Path(__file__).parent / "c"
    exe = tmp_path / "edges"
    build = subprocess.run([cc, "-std=c99", "-g", "-O1", f"-DFMI={fmi}", "-fsanitize=address,undefined",
                            "-fno-sanitize-recover=all", "-Wall", "-Wextra", "-Werror", "-I", src, "-I", here,
                            here / harness, *[f"{src}/{u}" for u in units], "-lm", "-o", exe],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    r = subprocess.run([exe], capture_output=True, text=True, timeout=120,
                       env={"ASAN_OPTIONS": "detect_leaks=1", "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0 and "ok: 0 failed" in r.stdout, r.stdout + r.stderr
    assert "ERROR: AddressSanitizer" not in r.stderr and "runtime error" not in r.stderr, r.stderr
    return r.stdout


class Xoshiro:
    """xoshiro256** seeded by splitmix64 (Blackman & Vigna) and Box-Muller normals, written here from the published
    algorithms: the random streams of the rig's faults computed apart from the core's rng.c."""
    M = (1 << 64) - 1

    @classmethod
    def stream(cls, seed: int, slot: int) -> "Xoshiro":
        """A fault's stream: the run's seed and its place in the table (docs: [hil] seed)."""
        return cls(seed ^ ((0xD1B54A32D192ED03 * (slot + 1)) & cls.M))

    def __init__(self, seed):
        self.s, x = [], seed & self.M
        for _ in range(4):
            x = (x + 0x9E3779B97F4A7C15) & self.M
            z = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & self.M
            z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & self.M
            self.s.append(z ^ (z >> 31))

    def uniform(self):
        s, M = self.s, self.M
        rotl = lambda x, k: ((x << k) | (x >> (64 - k))) & M   # noqa: E731
        out = (rotl((s[1] * 5) & M, 7) * 9) & M
        t = (s[1] << 17) & M
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = rotl(s[3], 45)
        return ((out >> 11) + 1) * 2.0 ** -53

    def normal(self):
        r = math.sqrt(-2.0 * math.log(self.uniform()))
        return r * math.cos(6.283185307179586 * self.uniform())
