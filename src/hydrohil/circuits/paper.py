"""The paper's rig as a circuit of the library (SPEC §8, §12): a parameter set (``ferreira2004`` or a user's
file of its shape) as the circuit of an ideal supply, the paper's servo valve and its LuGre cylinder, so the
same physics runs through the circuit generator. ``examples/circuits/ferreira2004/circuit.toml`` is the
built-in set written out as a file."""

from __future__ import annotations

from hydrohil.circuits.circuit import Circuit, circuit_from_dict
from hydrohil.parameters import Parameters


def paper_circuit(p: Parameters, x0: float | None = None, command: float = 0.0) -> Circuit:
    """The circuit of parameter set ``p``: supply ps, tank pt, the servo valve (eq 3's sections, the limited
    spool, the input delay of its command), the cylinder (eq 21 or
    constant chambers, leakage, the friction set(s) in use, the load with gravity along the rod), the
    piston at ``x0`` (default: linear.xp0), the command a constant (drive it with inputs=)."""
    pos, neg = p.friction_sets()
    cyl = p.cylinder
    chambers = ({"bulk_b": cyl.b, "bulk_c": cyl.c} if cyl.bulk_modulus == "pressure" else
                {"beta_a": cyl.beta1, "beta_b": cyl.beta2})
    body = {"name": "ferreira2004", "components": {
        "supply": {"type": "pressure_source", "p": "supply", "pressure": p.supply.ps},
        "tank": {"type": "tank", "p": "tank", "pressure": p.supply.pt},
        "valve": {"type": "servo_valve", "P": "supply", "T": "tank", "A": "cap", "B": "rod",
                  **{f"k{i}": k for i, k in enumerate(p.valve.k, 1)},
                  **{f"kt{i}": k for i, k in enumerate(p.valve.kt, 1)},
                  "dp_laminar": p.valve.dp_laminar, "wn": p.spool.wn, "xi": p.spool.xi, "la": p.spool.la,
                  "lv": p.spool.lv, "delay": p.spool.delay},
        "cyl": {"type": "lugre_cylinder", "a": "cap", "b": "rod", "area_a": cyl.a1, "area_b": cyl.a2,
                "stroke": cyl.stroke, "dead_volume_a": cyl.v01, "dead_volume_b": cyl.v02, "leakage": cyl.g_lkc,
                **chambers, "mass": p.load.mass, "gravity": p.load.gravity,
                "incline": -90.0 * p.load.gravity_direction, "force": p.load.force,
                "sigma0": p.friction.sigma0, "sigma1": p.friction.sigma1,
                "fc_pos": pos.fc, "fs_pos": pos.fs, "vs_pos": pos.vs, "kv_pos": pos.kv,
                "fc_neg": neg.fc, "fs_neg": neg.fs, "vs_neg": neg.vs, "kv_neg": neg.kv,
                "x0": p.linear.xp0 if x0 is None else x0}},
        "inputs": {"valve.command": command}}
    return circuit_from_dict(body, "ferreira2004 (hydrohil.circuits.paper)")
