"""Every number the paper (Part 2) gives that a model can reproduce, quoted with where it stands.

Each entry: key -> (value, unit, where). These are the only typed-in numbers of the reproduce report;
everything beside them is computed in the run.
"""

from __future__ import annotations

PAPER: dict[str, tuple[float, str, str]] = {
    # §3.1.1 spool dynamics (Fig 4)
    "spool.wn": (1007.01, "rad/s", "§3.1.1"),
    "spool.xi": (0.48, "-", "§3.1.1"),
    "spool.lv": (125.56, "1/s", "§3.1.1"),
    "spool.la": (81184.24, "1/s²", "§3.1.1"),
    "spool.delay": (7.625e-4, "s", "§3.1.1"),
    # §3.1.2 valve datasheet characteristics (Fig 5) and the identified pseudo-sections
    "valve.dpm_bar": (8.0, "bar", "§3.1.2 (crossing at 43 bar, Ps = 70 bar)"),
    "valve.crossing_bar": (43.0, "bar", "§3.1.2, Fig 5a"),
    "valve.kp0": (36.5, "-", "§3.1.2"),
    "valve.kq0_lpm": (28.0, "l/min", "§3.1.2"),
    "valve.ql0_lpm": (1.36, "l/min", "§3.1.2"),
    "valve.qn_lpm": (25.5, "l/min", "§3.1.2 (at Pn = 35 bar)"),
    "valve.k1": (-2.136, "l/min/√bar", "§3.1.2"), "valve.k2": (1.602e-2, "-", "§3.1.2"),
    "valve.k3": (4.561, "l/min/√bar", "§3.1.2"), "valve.k4": (-8.084e-2, "-", "§3.1.2"),
    "valve.k5": (1.563e-2, "l/min/√bar", "§3.1.2"),
    "valve.k1t": (-2.145, "l/min/√bar", "§3.1.2"), "valve.k2t": (7.276e-3, "-", "§3.1.2"),
    "valve.k3t": (4.602, "l/min/√bar", "§3.1.2"), "valve.k4t": (-4.208e-2, "-", "§3.1.2"),
    "valve.k5t": (1.092e-2, "l/min/√bar", "§3.1.2"),
    # §3.2.1 bulk modulus (Figs 7, 8)
    "cylinder.b": (9.71e-10, "1/Pa", "§3.2.1, eq 21"),
    "cylinder.c": (1.15e-3, "-", "§3.2.1, eq 21"),
    "beta1_70bar": (7.7e8, "Pa", "§3.2.1 (linear model, Ps = 70 bar)"),
    "beta2_70bar": (9.6e8, "Pa", "§3.2.1 (linear model, Ps = 70 bar)"),
    "f_70bar": (8100.0, "N·s/m", "§3.2.1 (friction factor, Ps = 70 bar)"),
    # §3.2.2 leakage
    "cylinder.g_lkc": (1.248e-14, "m³/(s·Pa)", "§3.2.2, eq 23"),
    # §3.2.3 friction (Fig 9) and dynamic friction (Fig 10)
    "symmetric.fc": (101.8, "N", "§3.2.3"), "symmetric.fs_minus_fc": (153.0, "N", "§3.2.3"),
    "symmetric.vs": (0.019, "m/s", "§3.2.3"), "symmetric.kv": (1090.0, "N·s/m", "§3.2.3"),
    "negative.fc": (89.26, "N", "§3.2.3"), "negative.fs_minus_fc": (160.3, "N", "§3.2.3"),
    "negative.vs": (0.0251, "m/s", "§3.2.3"), "negative.kv": (1387.0, "N·s/m", "§3.2.3"),
    "positive.fc": (110.2, "N", "§3.2.3"), "positive.fs_minus_fc": (150.8, "N", "§3.2.3"),
    "positive.vs": (0.0152, "m/s", "§3.2.3"), "positive.kv": (818.4, "N·s/m", "§3.2.3"),
    "friction.sigma0": (2.114e7, "N/m", "§3.2.3 b"),
    "friction.sigma1": (2.914e3, "N·s/m", "§3.2.3 b"),
    # §4 step sizes
    "step.hybrid": (5e-4, "s", "§4 (hybrid model, 3rd-order explicit, real time)"),
    "step.stiff": (2e-6, "s", "§4 (commercial library, 1e10 N/m and 1e10 N·s/m end stops)"),
}

# SPEC §8 sanity figures computed from the paper's numbers (not printed in the paper itself)
SPEC_SANITY: dict[str, tuple[float, str, str]] = {
    "p10_bar": (25.1, "bar", "SPEC §8, eq 18 at Ps = 70 bar"),
    "p20_bar": (44.9, "bar", "SPEC §8, eq 18 at Ps = 70 bar"),
    "as1_at_1": (4.31, "l/min/√bar", "SPEC §8, eq 3 with the paper's k-set"),
}

# the experiments of the paper that reproduce stands in for with synthetic data
PAPER_DATASHEET = {"qn_lpm": 25.5, "pn_bar": 35.0, "ps_bar": 70.0, "kq0_lpm": 28.0, "kp0": 36.5, "dpm_bar": 8.0,
                   "ql0_lpm": 1.36}                           # §3.1.2
PAPER_DRIFT = {"displacement_m": 1.504e-3, "duration_s": 200.0, "p2_pa": 5.28e5}   # §3.2.2
BULK_PRESSURES = (5e6, 7e6, 1e7, 1.4e7)                       # Pa, supply pressures of the Fig 7 tests
BULK_FRICTION = (6500.0, 8100.0, 9500.0, 12000.0)             # N·s/m, f per pressure (8100 at 70 bar, §3.2.1)
