"""The paper's rig as a circuit of the library (SPEC §8, §12): a parameter set (``ferreira2004`` or a user's
file of its shape) as the circuit of an ideal supply, the paper's servo valve and its LuGre cylinder, so the
same physics runs through the circuit generator. ``examples/circuits/ferreira2004/circuit.toml`` is the
built-in set written out as a file; a circuit named by a parameter set (``ferreira2004``, or a parameter file)
is its rig as a circuit in any install (:func:`hydrohil.circuits.parameter_set.paper_circuit_file`)."""

from __future__ import annotations

from hydrohil.circuits.circuit import Circuit, circuit_from_dict
from hydrohil.circuits.parameter_set import paper_tables
from hydrohil.parameters import Parameters


def paper_circuit(p: Parameters, x0: float | None = None, command: float = 0.0) -> Circuit:
    """The circuit of parameter set ``p``: supply ps, tank pt, the servo valve (eq 3's sections, the limited
    spool, the input delay of its command), the cylinder (eq 21 or
    constant chambers, leakage, the friction set(s) in use, the load with gravity along the rod), the
    piston at ``x0`` (default: linear.xp0), the command a constant (drive it with inputs=)."""
    return circuit_from_dict(paper_tables(p, x0, command), "ferreira2004 (hydrohil.circuits.paper)")
