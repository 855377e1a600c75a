"""Parameter identification: every procedure of the paper's §3 (SPEC §9), each a function that takes
a data file (or arrays) and returns a :class:`Fit` whose values a parameter file takes directly.

=================  ==========================================  ===============================
procedure          input                                        function
=================  ==========================================  ===============================
spool              Bode CSV (amplitude, frequency_hz, ...)      :func:`identify_spool`
valve-static       datasheet TOML (qn_lpm, pn_bar, ...)         :func:`identify_valve_static`
bulk-modulus       CSV (ps, frequency_hz, accel)                :func:`identify_bulk_modulus`
leakage            drift-test TOML or CSV (t, xp, p2)           :func:`identify_leakage`
friction-static    CSV (v, ff)                                  :func:`identify_friction_static`
friction-dynamic   CSV (t, u, p1, p2, xp)                       :func:`identify_friction_dynamic`
=================  ==========================================  ===============================
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Mapping

from hydrohil.identification.bulk_modulus import identify_bulk_modulus
from hydrohil.identification.friction_dynamic import identify_friction_dynamic
from hydrohil.identification.friction_static import identify_friction_static
from hydrohil.identification.leakage import identify_leakage
from hydrohil.identification.result import Fit
from hydrohil.identification.spool import identify_spool
from hydrohil.identification.valve_static import identify_valve_static
from hydrohil.parameters import Parameters, replace_values

# chain order of `identify all`: later procedures use the parameters identified before them
PROCEDURES = ("spool", "valve-static", "bulk-modulus", "leakage", "friction-static", "friction-dynamic")

__all__ = ["Fit", "PROCEDURES", "identify", "identify_spool", "identify_valve_static", "identify_bulk_modulus",
           "identify_leakage", "identify_friction_static", "identify_friction_dynamic"]


def identify(procedure: str, data: str | Path | Mapping[str, Any], params: Parameters,
             conditions: Mapping[str, Any] | None = None, progress: Callable[[int, int], None] | None = None) -> Fit:
    """Run one procedure by name. ``params`` supplies what the procedure does not identify (areas,
    mass, ...); ``conditions`` are dotted overrides describing the experiment (e.g. a horizontal rig:
    ``{"load.gravity_direction": 0}``), applied for the fit only."""
    test_params = replace_values(params, conditions, source="conditions") if conditions else params
    if procedure == "spool":
        return identify_spool(data, progress=progress)
    if procedure == "valve-static":
        return identify_valve_static(data)
    if procedure == "bulk-modulus":
        return identify_bulk_modulus(data, test_params, progress=progress)
    if procedure == "leakage":
        return identify_leakage(data, a2_m2=test_params.cylinder.a2)
    if procedure == "friction-static":
        return identify_friction_static(data)
    if procedure == "friction-dynamic":
        return identify_friction_dynamic(data, test_params, progress=progress)
    raise ValueError(f"unknown procedure {procedure!r} (one of {', '.join(PROCEDURES)})")
