"""The step's rewritten laws give the bits of the laws they stand for (issue #29). Compiled with the package's
compiler and flags, each C function is evaluated on the same inputs as an independent numpy evaluation of its
equation in the order the C writes it (float64 operations are IEEE, correctly rounded, no fused multiply-add
either side), and compared bit for bit:

* hc_sqrt_law_g(k, dp, dp_t, &g) (rhs_start: a flow and its conductance from one square root; hc_sqrt_law and
  hc_sqrt_law_slope are it) against the law of SPEC §3.2 and its slope;
* hc_section(x, ...) and hc_section_neg(x, ...) (an edge pair's negative section from the products of its
  positive one) against eq 3's section at x and at -x;
* hh_exp (the friction's exp, plain IEEE arithmetic) against 40-digit decimal arithmetic: its error in ulps.

And the model's run is the same bits whichever variant of glibc's libm the CPU selects (its FMA variants and
its AVX ones differ in the last bit for some arguments): the paper's rig on one drive in two processes, one with
the FMA and AVX variants turned off (GLIBC_TUNABLES).

Inputs: seeded random magnitudes over many decades of both signs, the transitions +-dp_t themselves and their
neighbouring doubles, zeros of both signs, subnormals, infinities and NaN."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from decimal import Decimal, getcontext
from pathlib import Path

import numpy as np
import pytest

from hydrohil.core.build import CFLAGS, HERE as CORE, c_compiler

PROGRAM = r"""
#include <stdio.h>
#include "hc_servo_valve.h"
#include "hh_exp.h"

int main(int argc, char **argv)
{
    FILE *in = fopen(argv[1], "rb"), *out = fopen(argv[2], "wb");
    double r[9];
    if (argc > 3) {                          /* hh_exp of each double of argv[1] */
        while (fread(r, sizeof(double), 1, in) == 1) {
            r[1] = hh_exp(r[0]);
            fwrite(&r[1], sizeof(double), 1, out);
        }
        fclose(in);
        fclose(out);
        return 0;
    }
    while (fread(r, sizeof(double), 9, in) == 9) {
        double o[6];
        o[0] = hc_sqrt_law_g(r[0], r[1], r[2], &o[1]);
        o[2] = hc_sqrt_law(r[0], r[1], r[2]);
        o[3] = hc_sqrt_law_slope(r[0], r[1], r[2]);
        o[4] = hc_section(r[3], r[4], r[5], r[6], r[7], r[8]);
        o[5] = hc_section_neg(r[3], r[4], r[5], r[6], r[7], r[8]);
        fwrite(o, sizeof(double), 6, out);
    }
    fclose(in);
    fclose(out);
    return 0;
}
"""


def _inputs(n: int = 100_000) -> np.ndarray:
    """Rows (k, dp, dp_t, x, k1, k2, k3, k4, k5): seeded random values, the edges, and the special values."""
    rng = np.random.default_rng(29)

    def mag(lo, hi):
        return 10.0 ** rng.uniform(lo, hi, n)

    def sign():
        return rng.choice([-1.0, 1.0], n)
    dp_t = mag(-2, 7)
    edge = rng.integers(0, 12, n)            # half the rows at +dp_t, -dp_t or a double either side of them
    near = np.choose(edge % 3, [dp_t, np.nextafter(dp_t, np.inf), np.nextafter(dp_t, 0.0)])
    dp = np.where(edge < 6, near * np.where(edge < 3, 1.0, -1.0), sign() * mag(-3, 9))
    x = sign() * mag(-8, 0.3)                # spool positions, within the clamp and beyond
    rows = np.column_stack([mag(-12, -3), dp, dp_t, x, sign() * mag(-3, 1), sign() * mag(-4, -1), mag(-1, 1),
                            sign() * mag(-3, 0), sign() * mag(-4, -1)])
    special = [0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324]
    extra = [[1e-8, s, 1e5, s, -2.1, 1.6e-2, 4.6, -8.1e-2, 1.6e-2] for s in special]
    return np.vstack([rows, np.array(extra)])


def _max(a, b):
    """C's a > b ? a : b (core.h's hh_max: b where they are unordered)."""
    return np.where(a > b, a, b)


def _law(k, dp, dp_t):
    """SPEC §3.2's square-root law with its cubic laminar region (hc_sqrt_law.h's order of operations)."""
    with np.errstate(all="ignore"):
        r = dp / dp_t
        laminar = k * np.sqrt(dp_t) * r * (1.25 - 0.25 * r * r)
        return np.where(dp >= dp_t, k * np.sqrt(dp), np.where(dp <= -dp_t, -k * np.sqrt(-dp), laminar))


def _slope(k, dp, dp_t):
    with np.errstate(all="ignore"):
        a, r = np.abs(dp), dp / dp_t
        return np.where(a >= dp_t, 0.5 * k / np.sqrt(a), k / np.sqrt(dp_t) * (1.25 - 0.75 * r * r))


def _section(x, k1, k2, k3, k4, k5):
    """Eq 3's pseudo-section, floored at zero."""
    with np.errstate(all="ignore"):
        return _max(k1 * x + k2 + np.sqrt(_max(k3 * x * x + k4 * x + k5, 0.0)), 0.0)


def _same(a, b) -> np.ndarray:
    """Bit for bit, any NaN equal to any NaN (its payload is not a result)."""
    return (a.view(np.uint64) == b.view(np.uint64)) | (np.isnan(a) & np.isnan(b))


@pytest.fixture(scope="module")
def program(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("identities")
    src, exe = folder / "identities.c", folder / "identities"
    src.write_text(PROGRAM)
    build = subprocess.run([*c_compiler().split(), *CFLAGS, f"-I{CORE}", str(src), "-lm", "-o", str(exe)],
                           capture_output=True, text=True)
    if build.returncode:
        pytest.fail(f"the identities program did not build: {build.stderr[-2000:]}")
    return exe


def test_rewritten_laws_give_the_bits_of_their_equations(program, tmp_path):
    data, result = tmp_path / "inputs.bin", tmp_path / "outputs.bin"
    rows = _inputs()
    np.ascontiguousarray(rows, dtype=np.float64).tofile(data)
    subprocess.run([str(program), str(data), str(result)], check=True)
    out = np.fromfile(result, dtype=np.float64).reshape(-1, 6)
    assert len(out) == len(rows)
    k, dp, dp_t, x = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
    q, g = _law(k, dp, dp_t), _slope(k, dp, dp_t)
    sections = [rows[:, i] for i in range(4, 9)]
    expected = [q, g, q, g, _section(x, *sections), _section(-x, *sections)]
    names = ["hc_sqrt_law_g's flow", "hc_sqrt_law_g's slope", "hc_sqrt_law", "hc_sqrt_law_slope", "hc_section",
             "hc_section_neg"]
    wrong = {name: int((~_same(out[:, j], e)).sum()) for j, (name, e) in enumerate(zip(names, expected))}
    assert wrong == dict.fromkeys(names, 0)
    assert np.isfinite(q).mean() > 0.99 and (np.abs(dp) < dp_t).mean() > 0.05   # (the rows reach each branch)
    assert min((dp == d).sum() for d in (dp_t, -dp_t, np.nextafter(dp_t, 0.0), -np.nextafter(dp_t, 0.0))) > 1000


def test_exp_is_within_half_an_ulp_and_a_hundredth(program, tmp_path):
    """hh_exp against exp in 40-digit decimal arithmetic: below 0.51 ulp where exp(x) is normal (glibc's own: 0.504
    on these inputs), 0.76 ulp of the subnormals' spacing (rounded twice there: 0.751 seen); its special values."""
    rng = np.random.default_rng(25)
    x = np.concatenate([-rng.uniform(0, 1, 6000) ** 2 * 40,        # the friction's -(v/vs)^2: most near 0
                        -rng.uniform(0, 745, 3000), rng.uniform(-1e-3, 1e-3, 1000), rng.uniform(0, 709.7, 1000),
                        [0.0, -0.0, 1e-300, -1e-300, -708.39, -708.4, -744.4, -745.1, 709.78]])
    special = np.array([np.nan, -np.inf, np.inf, -746.0, -1e9, 710.0])
    data, result = tmp_path / "x.bin", tmp_path / "exp.bin"
    np.concatenate([x, special]).tofile(data)
    subprocess.run([str(program), str(data), str(result), "exp"], check=True)
    got = np.fromfile(result, dtype=np.float64)
    assert len(got) == len(x) + len(special)
    getcontext().prec = 40
    normal, subnormal = 0.0, 0.0
    for xi, yi in zip(x, got[:len(x)]):
        exact = Decimal(float(xi)).exp()
        near = float(exact)
        err = float(abs(Decimal(float(yi)) - exact) / Decimal(float(np.spacing(near))))
        if near >= 2.2250738585072014e-308:
            normal = max(normal, err)
        else:
            subnormal = max(subnormal, err)
    assert normal < 0.51 and subnormal < 0.76
    assert got[len(x) - 9] == 1.0 and got[len(x) - 8] == 1.0         # exp(0) = exp(-0) = 1
    s = got[len(x):]                                                # NaN; -inf, underflow: 0; overflow: inf
    assert np.isnan(s[0]) and list(s[1:]) == [0.0, np.inf, 0.0, 0.0, np.inf]


CHILD = """
import math, sys, warnings
import numpy as np
from hydrohil.bench import _scenario
from hydrohil.circuits.paper import paper_circuit
from hydrohil.circuits.run import simulate_circuit
drive = np.load(sys.argv[1])
sc = _scenario("fig10_open_loop_sine.toml", float(drive[0, -1]))
c = paper_circuit(sc.params, sc.scenario.initial.xp)
with warnings.catch_warnings():
    warnings.simplefilter("ignore")                 # (open loop: the piston is not held at rest)
    r = simulate_circuit(c, float(drive[0, -1]), h=5e-4, every=1, inputs={"valve.command": (drive[0], drive[1])})
np.savez(sys.argv[2], libm=np.array([math.exp(v) for v in np.linspace(-40.0, 0.0, 20001)]), **r.columns)
"""


def _fma_cpu() -> bool:
    try:
        return platform.machine() == "x86_64" and " fma " in Path("/proc/cpuinfo").read_text()
    except OSError:
        return False


def test_a_run_is_the_same_bits_with_and_without_the_cpus_fma(tmp_path):
    """Fig 10's open loop (stick-slip at every reversal), 6 s, its drive made once: the generated model's every column
    bit for bit in a process where glibc uses its FMA variants and in one where it may not (on an x86-64 CPU with
    FMA, the switch is seen: glibc's own exp differs there). With glibc's exp in the friction, ~9 000 of the 12 001
    rows of every column differed (the events moved by the last bits)."""
    from hydrohil.bench import _scenario
    sc = _scenario("fig10_open_loop_sine.toml", 6.0)
    s = sc.scenario
    drive = tmp_path / "drive.npy"
    np.save(drive, np.stack([np.arange(s.n_steps() + 1) * s.solver.step, s.commands()]))
    logs = {}
    for name, extra in (("fma", {}), ("no_fma", {"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX"})):
        env = {**os.environ, **extra}
        subprocess.run([sys.executable, "-c", CHILD, str(drive), str(tmp_path / f"{name}.npz")], env=env, check=True)
        logs[name] = np.load(tmp_path / f"{name}.npz")
    a, b = logs["fma"], logs["no_fma"]
    if _fma_cpu():
        assert (a["libm"] != b["libm"]).sum() > 0, "GLIBC_TUNABLES did not switch glibc's variants: nothing tested"
    columns = [k for k in a.files if k != "libm"]
    assert len(columns) >= 13 and len(a["t"]) == 12001
    differ = {k: int((a[k].view(np.uint64) != b[k].view(np.uint64)).sum()) for k in columns
              if a[k].dtype == np.float64}
    assert differ == dict.fromkeys(differ, 0)
