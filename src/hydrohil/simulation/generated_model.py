"""The code generated from a parameter set's circuit (:func:`hydrohil.circuits.paper.paper_circuit`) behind the
core's loop, in the core's state order: its hybrid model (core/loop.c's ``HH_MODEL_GENERATED``,
:class:`~hydrohil.simulation.loop.Sim`'s model "generated": the virtual rig with its faults, sensors, command path
and watchdog, the HIL plant, the panel, the per-step API), its continuous reference's right-hand side (the
reference's LSODA steps) and an explicit step of it (maxstep's continuous model); the core's runs bit for bit
(tests)."""

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


def _paper_code(params):
    """(the circuit of parameter set ``params``, its compiled code). The component library takes every value the
    parameter schema takes (tested over the schema's ranges), so no layer keeps a model of its own for a set."""
    import warnings

    from hydrohil.circuits.build import compile_circuit
    from hydrohil.circuits.paper import paper_circuit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # (the parameter set's own: said where it was loaded)
        c = paper_circuit(params)
    return c, compile_circuit(c)


def _core_order(lay) -> np.ndarray:
    """at[i]: the circuit's state that is the core's state i (models.layout.STATE_NAMES)."""
    from hydrohil.circuits.paper import PAPER_VIEW
    from hydrohil.models.layout import STATE_NAMES
    return np.array([lay.states.index(PAPER_VIEW[name]) for name in STATE_NAMES], dtype=np.int64)


def _to_core(ffi, ctype: str, pointer):
    """A pointer of the circuit's module (``ffi``) as the core module's ``ctype`` (the two are separate cffi
    modules: the address itself)."""
    from hydrohil.core import ffi as core_ffi
    return core_ffi.cast(ctype, int(ffi.cast("uintptr_t", pointer)))


class CoreTables:
    """The paper's circuit of a parameter set in the core's layout: what an hc_core_ctx (core/hc_core.h) holds
    besides the state, made once here for every layer that fills one (this module's adapters; the exported C
    plant's and FMU's, export/paper_model.py). ``P``: the circuit's values (its valve's delay 0: the loop's delay
    line gives the spool its input); ``arrays``: the maps (name -> C type, array); ``sizes``: the context's
    integers and the sizes of its arrays."""

    def __init__(self, c, cc, h: float):
        from hydrohil.circuits.paper import CYL_MODE
        from hydrohil.circuits.run import new_state
        from hydrohil.core.shape import MODE_NAMES
        from hydrohil.models.layout import INDEX
        lay = cc.layout
        self.circuit, self.compiled = c, cc
        self.P = np.ascontiguousarray(lay.values())
        self.P[lay.slot["valve.delay"]] = 0.0
        # (the circuit's structure: eq 21's coefficients given, or constant chambers: circuits.library's rule)
        bulk = "constant" if math.isnan(c.components["cyl"].values["bulk_b"]) else "pressure"
        self.bulk_modulus = bulk
        values = {**CORE_VALUES, **CORE_BULK[bulk]}
        pmap = np.array([(INDEX[k], lay.slot[v]) for k, v in values.items()], dtype=np.int64).ravel()
        # the weight the core adds, gravity_direction * mass * gravity, is the circuit's cyl.weight subtracted
        wmap = np.array([lay.slot["cyl.weight"], INDEX["load.gravity_direction"], INDEX["load.mass"],
                         INDEX["load.gravity"]], dtype=np.int64)
        travel, friction = MODE_NAMES["travel"], MODE_NAMES["friction"]
        names = lay.mode_names["cyl.mode"]
        cyl_of = [names.index(next(n for n in names if CYL_MODE[n] == (t, f if t == "free" else "stick")))
                  for t in travel for f in friction]
        self.arrays = {"at": ("int64_t[]", _core_order(lay)),
                       "cyl_of": ("int64_t[]", np.array(cyl_of, dtype=np.int64)),
                       "travel_of": ("int64_t[]", np.array([travel.index(CYL_MODE[n][0]) for n in names],
                                                           dtype=np.int64)),
                       "friction_of": ("int64_t[]", np.array([friction.index(CYL_MODE[n][1]) for n in names],
                                                             dtype=np.int64)),
                       "pmap": ("int64_t[]", pmap), "wmap": ("int64_t[]", wmap),
                       "wc": ("double[]", np.array([-1.0]))}
        self.sizes = {"n": len(self.arrays["at"][1]), "command": lay.inputs.index("valve.command"),
                      "cyl_mode": lay.modes.index("cyl.mode"), "valve_mode": lay.modes.index("valve.mode"),
                      "nfriction": len(friction), "friction_column": lay.log_columns.index("cyl.friction"),
                      "npmap": len(pmap) // 2, "nwmap": len(wmap) // 4,
                      "nstate": len(new_state(cc, self.P, h)), "nmodes": max(len(lay.modes), 1),
                      "ninputs": max(len(lay.inputs), 1)}

    def context(self, solver: str, yc: np.ndarray | None = None):
        """An hc_core_ctx of these tables (a copy of ``P``: the context's own) for steps of ``solver``, its state
        ``yc`` (default zeros); returns (ctx, the arrays it points into: keep them alive while it is used)."""
        from hydrohil.core import method_code
        cc, s = self.compiled, self.sizes
        ffi = cc.ffi
        arrays = {**self.arrays, "P": ("double[]", self.P.copy()),
                  "yc": ("double[]", np.zeros(s["nstate"]) if yc is None else yc),
                  "u": ("double[]", np.zeros(s["ninputs"])), "mc": ("int64_t[]", np.zeros(s["nmodes"], dtype=np.int64))}
        ctx = ffi.new("hc_core_ctx *")
        for field, (kind, a) in arrays.items():
            setattr(ctx, field, ffi.from_buffer(kind, a))
        for field in ("n", "command", "cyl_mode", "valve_mode", "nfriction", "friction_column", "npmap", "nwmap"):
            setattr(ctx, field, s[field])
        ctx.method = method_code(solver)
        return ctx, arrays


def core_tables(params, h: float = 5e-4) -> CoreTables:
    """The :class:`CoreTables` of parameter set ``params`` for steps of ``h``."""
    return CoreTables(*_paper_code(params), h)


def generated_hybrid_model(params, sim, solver: str):
    """Make the core's loop ``sim`` (:class:`~hydrohil.simulation.loop.Sim`, model "generated") step the hybrid
    model generated from the circuit of parameter set ``params`` (circuits.paper.paper_circuit, its valve's delay
    0: the loop's delay line gives the spool its input): ``hc_core_hybrid_step`` and ``hc_core_friction`` behind
    the loop's state, modes and parameters, which it reads at every call (:data:`CORE_VALUES`, and the cylinder's
    weight = -gravity_direction * mass * gravity, so a fault or a tunable that changes the loop's parameters
    changes the circuit's), so the core's rig (rig.c: its faults, sensors, command path, watchdog; the HIL plants,
    the panel) runs the generated equations. Returns what must stay alive while ``sim`` runs. A step that leaves
    the finite keeps the state before it, where the core's model stores the non-finite one (the run stops there
    either way: only the divergence message's state differs)."""
    if params is None:
        raise ValueError("a generated model needs the parameter set its parameters were packed from")
    tables = core_tables(params, sim.h)
    cc = tables.compiled
    ffi, lib = cc.ffi, cc.lib
    ctx, arrays = tables.context(solver)
    lib.hc_init(ctx.P, ctx.u, sim.h, ctx.yc, ctx.mc)
    sim._sim.model_step = _to_core(ffi, "hh_model_step_fn", ffi.addressof(lib, "hc_core_hybrid_step"))
    sim._sim.model_friction = _to_core(ffi, "hh_model_friction_fn", ffi.addressof(lib, "hc_core_friction"))
    sim._sim.ctx = _to_core(ffi, "void *", ctx)
    return cc, ctx, arrays


def generated_reference_rhs(params):
    """The continuous reference's right-hand side ``f(y, t, ud) -> dy/dt`` generated from the circuit of parameter
    set ``params`` (``hc_reference_rhs``), in the core's state order with the valve's input ``ud``: for the core's
    sampled loop of the reference (:func:`hydrohil.simulation.reference.solve_reference`: the delayed command
    switching at alpha*h within the step, LSODA per interval), which so runs the circuit's equations (the core's
    reference.c's bit for bit: tests, 3 000 random states)."""
    cc = _paper_code(params)[1]
    lay, ffi = cc.layout, cc.ffi
    at = _core_order(lay)
    P = np.ascontiguousarray(lay.values())
    yc, dyc, u, dy = (np.zeros(len(lay.states)), np.zeros(len(lay.states)), np.zeros(max(len(lay.inputs), 1)),
                      np.empty(len(at)))
    command = lay.inputs.index("valve.command")
    Pb, ycb, dycb, ub = (ffi.from_buffer("double[]", a) for a in (P, yc, dyc, u))
    rhs = cc.lib.hc_reference_rhs

    def f(y, t, ud):
        yc[at] = y
        u[command] = ud
        rhs(Pb, ycb, ub, dycb)
        dy[:] = dyc[at]
        return dy
    f.keep = (cc, P)                             # (alive while the solver calls f)
    return f


def generated_continuous_model(params, sim, solver: str):
    """Make the core's loop ``sim`` (:class:`~hydrohil.simulation.loop.Sim`, model "external") step the continuous
    model of parameter set ``params`` by the code generated from its circuit (``hc_core_continuous_advance``: an
    explicit step of ``solver`` of the generated reference's right-hand side, the core's state order): maxstep's
    explicit runs of the continuous model, the core's (reference.c's continuous_step) bit for bit. What must stay
    alive while ``sim`` runs is kept by ``sim`` (and returned)."""
    c, cc = _paper_code(params)
    ffi = cc.ffi
    tables = CoreTables(c, cc, sim.h)
    ctx, arrays = tables.context(solver, yc=np.zeros(len(cc.layout.states)))
    sim._sim.advance = _to_core(ffi, "hh_advance_fn", ffi.addressof(cc.lib, "hc_core_continuous_advance"))
    sim._sim.ctx = _to_core(ffi, "void *", ctx)
    sim._model = cc, ctx, arrays
    return sim._model
