"""LuGre friction with asymmetric static parameters (SPEC §5, eq 25)."""

from __future__ import annotations

import numpy as np
from hydrohil._jit import jit

from hydrohil.models.layout import (FC_NEG, FC_POS, FS_NEG, FS_POS, KV_NEG, KV_POS, SIGMA0, SIGMA1, VS_NEG,
                                    VS_POS)


@jit(inline=True)
def stribeck(v, p):
    """g(v) = Fc + (Fs - Fc)*exp(-(v/vs)^2) [N] with the set of the direction of v (v >= 0: positive)."""
    if v >= 0.0:
        r = v / p[VS_POS]
        return p[FC_POS] + (p[FS_POS] - p[FC_POS]) * np.exp(-r * r)
    r = v / p[VS_NEG]
    return p[FC_NEG] + (p[FS_NEG] - p[FC_NEG]) * np.exp(-r * r)


@jit(inline=True)
def viscous(v, p):
    """Viscous coefficient Kv [N.s/m] of the direction of v."""
    return p[KV_POS] if v >= 0.0 else p[KV_NEG]


@jit(inline=True)
def slip_friction(v, direction, p):
    """Steady-state (sliding) friction of eq 25 in a slip mode of the given direction (+1/-1) [N]."""
    if direction > 0:
        r = v / p[VS_POS]
        return p[FC_POS] + (p[FS_POS] - p[FC_POS]) * np.exp(-r * r) + p[KV_POS] * v
    r = v / p[VS_NEG]
    return -(p[FC_NEG] + (p[FS_NEG] - p[FC_NEG]) * np.exp(-r * r)) + p[KV_NEG] * v


@jit(inline=True)
def lugre(v, z, p):
    """Continuous LuGre: (dz/dt [m/s], Ff [N]); dz = v - sigma0*|v|*z/g(v), Ff = s0*z + s1*dz + Kv*v."""
    dz = v - p[SIGMA0] * abs(v) * z / stribeck(v, p)
    return dz, p[SIGMA0] * z + p[SIGMA1] * dz + viscous(v, p) * v


def steady_state_friction(v, fc, fs, vs, kv):
    """Eq 25 on arrays: [Fc + (Fs - Fc) exp(-(v/vs)^2)] sgn(v) + Kv v, fs the breakaway force [N]."""
    v = np.asarray(v, dtype=float)
    return (fc + (fs - fc) * np.exp(-(v / vs) ** 2)) * np.sign(v) + kv * v


def steady_state_friction_asym(v, pos, neg):
    """Eq 25 with a (fc, fs, vs, kv) set per direction."""
    v = np.asarray(v, dtype=float)
    return np.where(v >= 0, steady_state_friction(v, *pos), steady_state_friction(v, *neg))
