"""The hybrid model generated from a parameter set's circuit (:func:`hydrohil.circuits.paper.paper_circuit`) behind
the core's loop and rig (core/loop.c's ``HH_MODEL_GENERATED``): :class:`~hydrohil.simulation.loop.Sim`'s model
"generated", so the virtual rig (its faults, sensors, command path and watchdog), the HIL plant, the panel and the
per-step API run the generated equations; the core's runs bit for bit (tests)."""

from __future__ import annotations

import math

import numpy as np


# the core's parameters (models.layout.INDEX) and the paper circuit's value each is (circuits.parameter_set)
CORE_VALUES = {**{f"spool.{k}": f"valve.{k}" for k in ("wn", "xi", "lv", "la")},
               **{f"valve.k[{i}]": f"valve.k{i}" for i in range(1, 6)},
               **{f"valve.kt[{i}]": f"valve.kt{i}" for i in range(1, 6)},
               "valve.dp_laminar": "valve.dp_laminar", "model.dp_lam_ref": "valve.reference_dp_laminar",
               "model.valve_wear": "valve.wear", "model.burst1": "valve.burst_a", "model.burst2": "valve.burst_b",
               "supply.ps": "supply.pressure", "supply.pt": "tank.pressure",
               "cylinder.a1": "cyl.area_a", "cylinder.a2": "cyl.area_b", "cylinder.v01": "cyl.dead_volume_a",
               "cylinder.v02": "cyl.dead_volume_b", "cylinder.stroke": "cyl.stroke", "cylinder.g_lkc": "cyl.leakage",
               "friction.sigma0": "cyl.sigma0", "friction.sigma1": "cyl.sigma1",
               **{f"model.{k}_{d}": f"cyl.{k}_{d}" for k in ("fc", "fs", "vs", "kv") for d in ("pos", "neg")},
               "load.mass": "cyl.mass", "load.gravity": "cyl.gravity", "load.force": "cyl.force",
               "model.stop_k": "cyl.stop_stiffness", "model.stop_c": "cyl.stop_damping"}
CORE_BULK = {"pressure": {"cylinder.b": "cyl.bulk_b", "cylinder.c": "cyl.bulk_c"},
             "constant": {"cylinder.beta1": "cyl.beta_a", "cylinder.beta2": "cyl.beta_b"}}


def generated_hybrid_model(params, sim, solver: str):
    """Make the core's loop ``sim`` (:class:`~hydrohil.simulation.loop.Sim`, model "generated") step the hybrid
    model generated from the circuit of parameter set ``params`` (circuits.paper.paper_circuit, its valve's delay
    0: the loop's delay line gives the spool its input): ``hc_core_hybrid_step`` and ``hc_core_friction`` behind
    the loop's state, modes and parameters, which it reads at every call (:data:`CORE_VALUES`, and the cylinder's
    weight = mass * gravity * sin(incline), so a fault or a tunable that changes the loop's parameters changes
    the circuit's), so the core's rig (rig.c: its faults, sensors, command path, watchdog; the HIL plants, the
    panel) runs the generated equations. Returns what must stay alive while ``sim`` runs, or None where the
    component library refuses the parameter set (a value the schema takes beyond a component's range): ``sim``
    keeps the core's model then (the same bits). A step that leaves the finite keeps the state before it, where
    the core's model stores the non-finite one (the run stops there either way: only the divergence message's
    state differs)."""
    import warnings

    from hydrohil.circuits.build import compile_circuit
    from hydrohil.circuits.paper import CYL_MODE, PAPER_VIEW, paper_circuit
    from hydrohil.circuits.run import new_state
    from hydrohil.core import ffi as core_ffi, method_code
    from hydrohil.core.shape import MODE_NAMES
    from hydrohil.models.layout import INDEX, STATE_NAMES
    from hydrohil.errors import InputError
    if params is None:
        raise ValueError("a generated model needs the parameter set its parameters were packed from")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # (the parameter set's own: said where it was loaded)
        try:
            c = paper_circuit(params)
        except InputError:                       # (a value the schema takes and the component library's ranges
            return None                          # do not, e.g. a valve coefficient beyond ±1000: the core's model)
    cc = compile_circuit(c)
    lay, ffi, lib = cc.layout, cc.ffi, cc.lib
    P = np.ascontiguousarray(lay.values())
    P[lay.slot["valve.delay"]] = 0.0             # (the loop's delay line delays the command)
    u = np.zeros(max(len(lay.inputs), 1))
    yc = new_state(cc, P, sim.h)
    mc = np.zeros(max(len(lay.modes), 1), dtype=np.int64)
    lib.hc_init(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", u), sim.h,
                ffi.from_buffer("double[]", yc), ffi.from_buffer("int64_t[]", mc))
    values = {**CORE_VALUES, **CORE_BULK[params.cylinder.bulk_modulus]}
    pmap = np.array([(INDEX[k], lay.slot[v]) for k, v in values.items()], dtype=np.int64).ravel()
    cyl = c.components["cyl"].values
    wmap = np.array([lay.slot["cyl.weight"], INDEX["load.mass"], INDEX["load.gravity"]], dtype=np.int64)
    wc = np.array([math.sin(math.radians(cyl["incline"]))])
    travel, friction = MODE_NAMES["travel"], MODE_NAMES["friction"]
    names = lay.mode_names["cyl.mode"]
    cyl_of = np.array([names.index(next(n for n in names if CYL_MODE[n] == (t, f if t == "free" else "stick")))
                       for t in travel for f in friction], dtype=np.int64)
    travel_of = np.array([travel.index(CYL_MODE[n][0]) for n in names], dtype=np.int64)
    friction_of = np.array([friction.index(CYL_MODE[n][1]) for n in names], dtype=np.int64)
    at = np.array([lay.states.index(PAPER_VIEW[name]) for name in STATE_NAMES], dtype=np.int64)
    ctx = ffi.new("hc_core_ctx *")
    arrays = {"P": ("double[]", P), "at": ("int64_t[]", at), "yc": ("double[]", yc), "u": ("double[]", u),
              "mc": ("int64_t[]", mc), "cyl_of": ("int64_t[]", cyl_of), "travel_of": ("int64_t[]", travel_of),
              "friction_of": ("int64_t[]", friction_of), "pmap": ("int64_t[]", pmap), "wmap": ("int64_t[]", wmap),
              "wc": ("double[]", wc)}
    for field, (kind, a) in arrays.items():
        setattr(ctx, field, ffi.from_buffer(kind, a))
    ctx.n, ctx.command, ctx.method = len(at), lay.inputs.index("valve.command"), method_code(solver)
    ctx.cyl_mode, ctx.valve_mode = lay.modes.index("cyl.mode"), lay.modes.index("valve.mode")
    ctx.nfriction, ctx.friction_column = len(friction), lay.log_columns.index("cyl.friction")
    ctx.npmap, ctx.nwmap = len(pmap) // 2, 1
    address = lambda x: int(ffi.cast("uintptr_t", x))     # noqa: E731 - (the core's ffi is another module's)
    sim._sim.model_step = core_ffi.cast("hh_model_step_fn", address(ffi.addressof(lib, "hc_core_hybrid_step")))
    sim._sim.model_friction = core_ffi.cast("hh_model_friction_fn", address(ffi.addressof(lib, "hc_core_friction")))
    sim._sim.ctx = core_ffi.cast("void *", address(ctx))
    return cc, ctx, arrays
