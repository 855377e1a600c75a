"""LuGre friction with asymmetric static parameters (SPEC §5, eq 25): the model is in the C core
(``core/friction.c``); the steady-state curve of eq 25 on arrays serves identification and plots."""

from __future__ import annotations

import numpy as np


def steady_state_friction(v, fc, fs, vs, kv):
    """Eq 25 on arrays: [Fc + (Fs - Fc) exp(-(v/vs)^2)] sgn(v) + Kv v, fs the breakaway force [N]."""
    v = np.asarray(v, dtype=float)
    return (fc + (fs - fc) * np.exp(-(v / vs) ** 2)) * np.sign(v) + kv * v

