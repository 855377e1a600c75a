"""The common result of every identification procedure."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from hydrohil.parameters import Parameters, replace_values


@dataclass
class Fit:
    """Fitted values of one procedure.

    ``values`` are the JSON keys of the procedure (SI unless stated), ``cost`` the final value of the
    procedure's cost function, ``achieved`` the characteristics the fit reproduces (same names as the
    inputs) where that applies, ``updates`` the dotted parameter keys it sets, ``curves`` the arrays the
    report plots (data vs fit), ``wall_time_s`` the time the fit took, ``not_identifiable`` what the data
    cannot determine (key -> the least value the data need, the value set instead, its unit and why).
    """

    procedure: str
    values: dict[str, Any]
    cost: float
    updates: dict[str, Any]
    achieved: dict[str, Any] | None = None
    curves: dict[str, Any] = field(default_factory=dict, repr=False)
    wall_time_s: float = 0.0
    notes: list[str] = field(default_factory=list)
    not_identifiable: dict[str, dict[str, Any]] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        out = {"procedure": self.procedure, **self.values, "cost": self.cost}
        if self.achieved is not None:
            out["achieved"] = self.achieved
        if self.not_identifiable:
            out["not_identifiable"] = self.not_identifiable
        if self.notes:
            out["notes"] = self.notes
        out["wall_time_s"] = round(self.wall_time_s, 3)
        return out

    def apply(self, params: Parameters) -> Parameters:
        """``params`` with this fit's values set (validated: a fit outside the schema's ranges is an error)."""
        return replace_values(params, self.updates, source=f"identify {self.procedure} result")
