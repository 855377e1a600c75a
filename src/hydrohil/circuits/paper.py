"""The paper's rig as a circuit of the library (SPEC §8, §12): a parameter set (``ferreira2004`` or a user's
file of its shape) as the circuit of an ideal supply, the paper's servo valve and its LuGre cylinder, so the
same physics runs through the circuit generator. ``examples/circuits/ferreira2004/circuit.toml`` is the
built-in set written out as a file; a circuit named by a parameter set (``ferreira2004``, or a parameter file)
is its rig as a circuit in any install (:func:`hydrohil.circuits.parameter_set.paper_circuit_file`)."""

from __future__ import annotations

import numpy as np

from hydrohil.circuits.circuit import Circuit, circuit_from_dict
from hydrohil.circuits.parameter_set import paper_tables
from hydrohil.core.shape import LOG_COLUMNS, MODE_NAMES
from hydrohil.parameters import Parameters


def paper_circuit(p: Parameters, x0: float | None = None, command: float = 0.0) -> Circuit:
    """The circuit of parameter set ``p``: supply ps, tank pt, the servo valve (eq 3's sections, the limited
    spool, the input delay of its command), the cylinder (eq 21 or
    constant chambers, leakage, the friction set(s) in use, the load with gravity along the rod), the
    piston at ``x0`` (default: linear.xp0), the command a constant (drive it with inputs=)."""
    return circuit_from_dict(paper_tables(p, x0, command), "ferreira2004 (hydrohil.circuits.paper)")


# The core's log (core/shape.LOG_COLUMNS) from a run of the paper's circuit: its column of each, by name
PAPER_VIEW = {"u": "valve.command", "ud": "valve.command.seen", "xs": "valve.x", "vs": "valve.v", "p1": "cap.p",
              "p2": "rod.p", "xp": "cyl.x", "vp": "cyl.v", "z": "cyl.z", "ff": "cyl.friction",
              "spool_mode": "valve.mode", "events": "events"}
# the core's modes the cylinder's one mode gives (paper_columns): the place of each in CYL_MODE's pairs
CYL_SPLIT = {"travel_mode": 0, "friction_mode": 1}
# the cylinder's one mode (hc_lugre_cylinder.h: the friction's three, then the two end stops) as the core's two
CYL_MODE = {"stick": ("free", "stick"), "slip_pos": ("free", "slip_pos"), "slip_neg": ("free", "slip_neg"),
            "at_retract": ("at_retract_stop", "stick"), "at_extend": ("at_extend_stop", "stick")}


def paper_log(res) -> np.ndarray:
    """The run ``res`` (:class:`~hydrohil.circuits.run.CircuitResult`) of a paper's circuit (:func:`paper_circuit`,
    ``hydrohil circuit convert``) as the core's log: a row per log row, the core's 15 columns in its order
    (LOG_COLUMNS: t, u, ud, the state, ff, the travel, friction and spool modes, events), each
    :func:`paper_columns`' (the array in column order, the same values). KeyError naming a column the run lacks
    (not the paper's circuit)."""
    cols = paper_columns(res, LOG_COLUMNS)
    log = np.empty((len(LOG_COLUMNS), len(cols["t"])))    # (column by column: a fifth of column_stack's time)
    for i, name in enumerate(LOG_COLUMNS):
        log[i] = cols[name]
    return log.T


def paper_columns(res, names) -> dict[str, np.ndarray]:
    """The core's log columns ``names`` (LOG_COLUMNS') of the run ``res`` of a paper's circuit: each the circuit's
    column of :data:`PAPER_VIEW`, the cylinder's mode split into the core's travel and friction modes (at an end
    stop, stick: the core's reset there). KeyError naming a column the run lacks, or when the valve's modes are
    not the core's spool modes."""
    check_core_columns(names)
    if "spool_mode" in names and res.mode_names["valve.mode"] != MODE_NAMES["spool"]:
        raise KeyError(f"valve.mode's modes {res.mode_names['valve.mode']} are not the core's spool modes")
    out = {}
    for name in names:
        if name in CYL_SPLIT:
            code = np.array([MODE_NAMES[name[:-5]].index(CYL_MODE[mode][CYL_SPLIT[name]])
                             for mode in res.mode_names["cyl.mode"]], dtype=float)
            out[name] = code[res.columns["cyl.mode"].astype(int)]
        else:
            out[name] = res.columns["t" if name == "t" else PAPER_VIEW[name]]
    return out


def circuit_columns(names) -> set[str]:
    """The columns of a paper circuit's run that :func:`paper_columns` reads for the core's columns ``names``."""
    check_core_columns(names)
    return {"cyl.mode" if name in CYL_SPLIT else "t" if name == "t" else PAPER_VIEW[name] for name in names}


def check_core_columns(names) -> None:
    """KeyError naming the first of ``names`` that is not a column of the core's log (LOG_COLUMNS)."""
    unknown = [n for n in names if n not in LOG_COLUMNS]
    if unknown:
        raise KeyError(f"no column {unknown[0]!r} in the core's log ({', '.join(LOG_COLUMNS)})")


def paper_start(c: Circuit, core_row, h: float = 5e-4, command: str = "valve.command", compiled=None) -> tuple:
    """(y, m, u0) of the paper's circuit ``c`` for :func:`~hydrohil.circuits.run.simulate_circuit`'s ``start``:
    the core's state of its log row ``core_row`` (the 15 columns of LOG_COLUMNS; row 0: the core's start at
    rest) in the circuit's layout, the valve's delay line full of the spool's position there (the core's reset,
    loop.c: hh_sim_reset) and step 0's ``command`` at it (a loop's held command). From the same start the
    generated code steps as the core does (README: bit for bit on the paper's examples). ``compiled``:
    ``compile_circuit(c)`` when the caller has it."""
    from hydrohil.circuits.build import compile_circuit
    from hydrohil.circuits.run import input_table, new_state
    cc = compile_circuit(c) if compiled is None else compiled
    lay, ffi = cc.layout, cc.ffi
    P = np.ascontiguousarray(lay.values())
    col = dict(zip(LOG_COLUMNS, (float(v) for v in core_row)))
    u = np.ascontiguousarray(input_table(c, 1, h))
    u[0, lay.inputs.index(command)] = col["xs"]
    y = new_state(cc, P, h)
    m = np.zeros(max(len(lay.modes), 1), dtype=np.int64)
    cc.lib.hc_init(ffi.from_buffer("double[]", P), ffi.from_buffer("double[]", u), float(h),
                   ffi.from_buffer("double[]", y), ffi.from_buffer("int64_t[]", m))
    for core, name in PAPER_VIEW.items():
        if name in lay.states:
            y[lay.states.index(name)] = col[core]
    travel, friction = (MODE_NAMES[k][int(col[f"{k}_mode"])] for k in ("travel", "friction"))
    cyl = (travel, friction if travel == "free" else "stick")        # (the cylinder's one mode: CYL_MODE's)
    m[lay.modes.index("cyl.mode")] = [CYL_MODE[name] for name in lay.mode_names["cyl.mode"]].index(cyl)
    m[lay.modes.index("valve.mode")] = int(col["spool_mode"])
    return y, m, u[0].copy()
