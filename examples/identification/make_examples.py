"""Regenerate the example inputs of `hydrohil identify` in this folder (deterministic, seeded).

They are synthetic "measurements" made from the `ferreira2004` parameter set (the paper's values) with
realistic sensor noise, so that each procedure should recover the paper's numbers. Run:
    python examples/identification/make_examples.py
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from hydrohil.identification.bulk_modulus import synthetic_accel
from hydrohil.identification.friction_dynamic import synthetic_experiment
from hydrohil.identification.friction_static import synthetic_friction
from hydrohil.identification.spool import synthetic_bode
from hydrohil.parameters import load_parameters, replace_values

HERE = Path(__file__).parent


def write_csv(name: str, cols: dict[str, np.ndarray], fmt: str = "{:.9g}") -> None:
    keys = list(cols)
    with open(HERE / name, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        for row in zip(*(cols[k] for k in keys)):
            w.writerow([fmt.format(v) for v in row])


def main() -> None:
    P = load_parameters("ferreira2004")
    s = P.spool
    write_csv("spool_bode.csv", synthetic_bode(s.wn, s.xi, s.lv, s.la, s.delay, noise_db=0.1, noise_deg=1.0, seed=1))
    write_csv("bulk_modulus_accel.csv",
              synthetic_accel(P, [5e6, 7e6, 1e7, 1.4e7], P.cylinder.b, P.cylinder.c, [6500, 8100, 9500, 12000],
                              noise=0.01, seed=2))
    f = P.friction
    write_csv("friction_static.csv", synthetic_friction(f.positive.model_dump(), f.negative.model_dump(),
                                                        noise=2.0, seed=3))
    horizontal = replace_values(P, {"load.gravity_direction": 0})
    write_csv("friction_dynamic.csv", synthetic_experiment(horizontal, duration=6.0, amplitude=0.03, frequency=0.5,
                                                           noise_pa=2e3, noise_m=1e-6, seed=4))
    # drift test as a time series: 200 s at the paper's mean P2 = 5.28 bar and 1504 um
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 200.0 + 1e-9, 1.0)
    write_csv("drift_test.csv", {"t": t, "xp": 1504e-6 * t / 200 + 0.5e-6 * rng.standard_normal(t.size),
                                 "p2": 5.28e5 + 2e3 * rng.standard_normal(t.size)})


if __name__ == "__main__":
    main()
