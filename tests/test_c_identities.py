"""The step's rewritten laws give the bits of the laws they stand for (issue #29). Compiled with the package's
compiler and flags, each C function is evaluated on the same inputs as an independent numpy evaluation of its
equation in the order the C writes it (float64 operations are IEEE, correctly rounded, no fused multiply-add
either side), and compared bit for bit:

* hc_sqrt_law_g(k, dp, dp_t, &g) (rhs_start: a flow and its conductance from one square root; hc_sqrt_law and
  hc_sqrt_law_slope are it) against the law of SPEC §3.2 and its slope;
* hc_section(x, ...) and hc_section_neg(x, ...) (an edge pair's negative section from the products of its
  positive one) against eq 3's section at x and at -x.

Inputs: seeded random magnitudes over many decades of both signs, the transitions +-dp_t themselves and their
neighbouring doubles, zeros of both signs, subnormals, infinities and NaN."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from hydrohil.core.build import CFLAGS, HERE as CORE, c_compiler

PROGRAM = r"""
#include <stdio.h>
#include "hc_servo_valve.h"

int main(int argc, char **argv)
{
    FILE *in = fopen(argv[1], "rb"), *out = fopen(argv[2], "wb");
    double r[9];
    (void)argc;
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
    edge = rng.integers(0, 6, n)             # a third of the rows at +-dp_t or a double beside it
    near = np.choose(edge % 3, [dp_t, np.nextafter(dp_t, np.inf), np.nextafter(dp_t, 0.0)])
    dp = np.where(edge < 2, near * np.where(edge == 0, 1.0, -1.0), sign() * mag(-3, 9))
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


def test_rewritten_laws_give_the_bits_of_their_equations(tmp_path):
    src, exe = tmp_path / "identities.c", tmp_path / "identities"
    data, result = tmp_path / "inputs.bin", tmp_path / "outputs.bin"
    src.write_text(PROGRAM)
    rows = _inputs()
    np.ascontiguousarray(rows, dtype=np.float64).tofile(data)
    build = subprocess.run([*c_compiler().split(), *CFLAGS, f"-I{CORE}", str(src), "-lm", "-o", str(exe)],
                           capture_output=True, text=True)
    if build.returncode:
        pytest.fail(f"the identities program did not build: {build.stderr[-2000:]}")
    subprocess.run([str(exe), str(data), str(result)], check=True)
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
