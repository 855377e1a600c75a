"""Memory layout of the C core as Python sees it: state vector, mode codes and the parameter vector.

The parameter vector's slots are generated from the pydantic schema (:mod:`hydrohil.core.layout`: the
same function writes the C header ``hh_params.h`` at build time), so Python and C cannot disagree;
:func:`pack` fills it from a validated :class:`~hydrohil.parameters.Parameters` and lets the core derive its
model slots. State and mode codes are the core's constants, generated with their names from :mod:`hydrohil.core.shape`.
"""

from __future__ import annotations

import numpy as np

from hydrohil.core import dptr, lib, shape
from hydrohil.core.layout import slots
from hydrohil.parameters import Parameters

# --- state vector y ---------------------------------------------------------------------------
XS, VS, P1, P2, XP, VP, Z = (lib.HH_XS, lib.HH_VS, lib.HH_P1, lib.HH_P2, lib.HH_XP, lib.HH_VP, lib.HH_Z)
NY = lib.HH_NY
STATE_NAMES = tuple(s.name for s in shape.STATES)

# --- modes ------------------------------------------------------------------------------------
M_TRAVEL, M_FRICTION, M_SPOOL = lib.HH_M_TRAVEL, lib.HH_M_FRICTION, lib.HH_M_SPOOL
NM = lib.HH_NM
FREE, AT_RETRACT, AT_EXTEND = lib.HH_FREE, lib.HH_AT_RETRACT, lib.HH_AT_EXTEND
STICK, SLIP_POS, SLIP_NEG = lib.HH_STICK, lib.HH_SLIP_POS, lib.HH_SLIP_NEG
SPOOL_LINEAR, SPOOL_ACC_LIMITED, SPOOL_VEL_LIMITED, SPOOL_AT_END = (
    lib.HH_SPOOL_LINEAR, lib.HH_SPOOL_ACC_LIMITED, lib.HH_SPOOL_VEL_LIMITED, lib.HH_SPOOL_AT_END)
TRAVEL_NAMES, FRICTION_NAMES, SPOOL_NAMES = (shape.MODE_NAMES[m] for m in ("travel", "friction", "spool"))
MODE_COLUMNS = tuple(f"{m.name}_mode" for m in shape.MODES)     # the modes' log columns, in m[] order

# --- parameter vector p -----------------------------------------------------------------------
SLOTS = tuple(slots(Parameters))
NP = lib.HH_NP
if len(SLOTS) != NP:        # the extension was built from another schema: rebuild it
    raise ImportError(f"hydrohil's C core was built for {NP} parameter slots, the schema has {len(SLOTS)}: "
                      "reinstall the package (pip install -e .)")
INDEX = {s.key: i for i, s in enumerate(SLOTS)}

WN, XI, LV, LA, DELAY = (INDEX[f"spool.{k}"] for k in ("wn", "xi", "lv", "la", "delay"))
PS, PT = INDEX["supply.ps"], INDEX["supply.pt"]
G_LKC, STROKE = INDEX["cylinder.g_lkc"], INDEX["cylinder.stroke"]
SIGMA0, SIGMA1 = INDEX["friction.sigma0"], INDEX["friction.sigma1"]
MASS, FLOAD = INDEX["load.mass"], INDEX["load.force"]
ENC_RES = INDEX["sensors.encoder_resolution"]
# fault slots (0 in every parameter set; fault injection sets them, faults.py): worn spool lands (added to
# each pseudo-section) and a burst hose from chamber 1 / 2 to tank [(l/min)/sqrt(bar)]
VALVE_WEAR, BURST1, BURST2 = INDEX["model.valve_wear"], INDEX["model.burst1"], INDEX["model.burst2"]
STOP_K, STOP_C = INDEX["model.stop_k"], INDEX["model.stop_c"]


def _value(tree: dict, key: str):
    name, _, item = key.partition("[")
    node = tree
    for part in name.split("."):
        node = node[part]
    return node[int(item[:-1]) - 1] if item else node


def pack(params: Parameters) -> np.ndarray:
    """Flatten a validated parameter set into the float64 vector the core reads (schema slots in schema
    order, then the model slots the core derives: friction set per direction, model constants, faults 0)."""
    tree = params.model_dump()
    p = np.zeros(NP)
    for i, s in enumerate(SLOTS):
        if not s.schema:
            break
        v = _value(tree, s.key)
        p[i] = s.options.index(v) if s.kind == "enum" else float(v)
    lib.hh_params_derive(dptr(p))
    return p


def pack_defaults() -> np.ndarray:
    """A parameter vector with only the model constants set (schema slots 0)."""
    p = np.zeros(NP)
    lib.hh_params_derive(dptr(p))
    return p


# the continuous reference model's end stops (SPEC §6), as the core sets them [N/m, N.s/m]
REFERENCE_STOP_K, REFERENCE_STOP_C = (float(pack_defaults()[i]) for i in (STOP_K, STOP_C))
MAX_EVENTS = lib.HH_MAX_EVENTS   # event budget of one hybrid step (core/hybrid.h)
