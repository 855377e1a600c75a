"""Memory layout shared by the compiled models: state vector, parameter vector and mode codes.

The compiled (numba) code reads parameters from one float64 vector; :func:`pack` builds it from a
validated :class:`~hydrohil.parameters.Parameters`. Index names are module constants so numba folds them.
"""

from __future__ import annotations

import numpy as np

from hydrohil.parameters import Parameters

# --- state vector y ---------------------------------------------------------------------------
XS, VS, P1, P2, XP, VP, Z = range(7)  # spool pos [-], spool vel [1/s], pressures [Pa], piston [m, m/s], bristle [m]
NY = 7
STATE_NAMES = ("xs", "vs", "p1", "p2", "xp", "vp", "z")

# --- modes ------------------------------------------------------------------------------------
# mode vector m: [travel, friction, spool]
M_TRAVEL, M_FRICTION, M_SPOOL = range(3)
NM = 3
FREE, AT_RETRACT, AT_EXTEND = 0, 1, 2
STICK, SLIP_POS, SLIP_NEG = 0, 1, 2
SPOOL_LINEAR, SPOOL_ACC_LIMITED, SPOOL_VEL_LIMITED, SPOOL_AT_END = 0, 1, 2, 3
TRAVEL_NAMES = ("free", "at_retract_stop", "at_extend_stop")
FRICTION_NAMES = ("stick", "slip_pos", "slip_neg")
SPOOL_NAMES = ("linear", "acc_limited", "vel_limited", "at_end")

# --- parameter vector p -----------------------------------------------------------------------
(WN, XI, LV, LA, DELAY,
 K1, K2, K3, K4, K5, K1T, K2T, K3T, K4T, K5T, DP_LAM,
 PS, PT,
 A1, A2, V01, V02, STROKE, G_LKC, BULK_CONST, BB, BC, BETA1, BETA2,
 SIGMA0, SIGMA1, FC_POS, FS_POS, VS_POS, KV_POS, FC_NEG, FS_NEG, VS_NEG, KV_NEG,
 MASS, GDIR, GRAV, FLOAD,
 ENC_RES,
 STOP_K, STOP_C, DP_LAM_REF, LAMBDA_H_MAX,
 VALVE_WEAR, BURST1, BURST2) = range(51)
NP = 51
# VALVE_WEAR, BURST1, BURST2 [(l/min)/sqrt(bar)] are zero in every parameter set; fault injection sets them:
# worn spool lands (added to each pseudo-section) and a burst hose from chamber 1 / 2 to tank (faults.py).

# Continuous reference model: unilateral spring-damper end stops (SPEC §6) and a narrow laminar region.
REFERENCE_STOP_K = 1e10      # N/m
REFERENCE_STOP_C = 1e10      # N.s/m
REFERENCE_DP_LAMINAR = 1e3   # Pa (0.01 bar): keeps the Jacobian finite at dp = 0 for the stiff solver
# Spool end stops of the continuous reference model (the hybrid model clamps x̄s exactly): 100x the paper's
# spool bandwidth, critically damped (omega = 1e5 rad/s), per unit x̄s.
SPOOL_STOP_K = 1e10          # 1/s^2
SPOOL_STOP_C = 2e5           # 1/s
# Hybrid model: largest lambda*h allowed for the pressure relaxation of a chamber (see hybrid.py).
HYBRID_LAMBDA_H_MAX = 1.5

# 1 (l/min)/sqrt(bar) expressed in (m^3/s)/sqrt(Pa)
LPM_PER_SQRT_BAR = 1.0 / 60000.0 / np.sqrt(1e5)


def pack(params: Parameters) -> np.ndarray:
    """Flatten a validated parameter set into the float64 vector the compiled models read."""
    p = np.zeros(NP)
    s, v, c, f, ld = params.spool, params.valve, params.cylinder, params.friction, params.load
    p[WN], p[XI], p[LV], p[LA], p[DELAY] = s.wn, s.xi, s.lv, s.la, s.delay
    p[K1:K5 + 1] = v.k
    p[K1T:K5T + 1] = v.kt
    p[DP_LAM] = v.dp_laminar
    p[PS], p[PT] = params.supply.ps, params.supply.pt
    p[A1], p[A2], p[V01], p[V02], p[STROKE], p[G_LKC] = c.a1, c.a2, c.v01, c.v02, c.stroke, c.g_lkc
    p[BULK_CONST] = 1.0 if c.bulk_modulus == "constant" else 0.0
    p[BB], p[BC], p[BETA1], p[BETA2] = c.b, c.c, c.beta1, c.beta2
    pos, neg = params.friction_sets()
    p[SIGMA0], p[SIGMA1] = f.sigma0, f.sigma1
    p[FC_POS], p[FS_POS], p[VS_POS], p[KV_POS] = pos.fc, pos.fs, pos.vs, pos.kv
    p[FC_NEG], p[FS_NEG], p[VS_NEG], p[KV_NEG] = neg.fc, neg.fs, neg.vs, neg.kv
    p[MASS], p[GDIR], p[GRAV], p[FLOAD] = ld.mass, ld.gravity_direction, ld.gravity, ld.force
    p[ENC_RES] = params.sensors.encoder_resolution
    p[STOP_K], p[STOP_C], p[DP_LAM_REF] = REFERENCE_STOP_K, REFERENCE_STOP_C, REFERENCE_DP_LAMINAR
    p[LAMBDA_H_MAX] = HYBRID_LAMBDA_H_MAX
    return p
