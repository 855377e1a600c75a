"""The state of one ``hydrohil reproduce`` run: output folder, the rig's true and identified parameters,
results and figures (filled by :mod:`hydrohil.reproduce.runner`, read by :mod:`hydrohil.reproduce.report`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hydrohil.identification.report import write_report
from hydrohil.parameters import load_parameters
from hydrohil.simulation.outputs import write_table
from hydrohil.simulation.scenario import EXPERIMENTS_DIR, load_scenario


class Reproduction:
    """State of one reproduce run: output folder, truth and identified parameters, results, figures."""

    def __init__(self, out: Path, quick: bool, lockstep: bool, params: str | Path | None = None,
                 sets: dict | None = None):
        self.out, self.quick, self.lockstep = out, quick, lockstep
        self.params, self.sets = params, sets    # the rig reproduced: the paper's set unless told otherwise
        self.truth = load_parameters(params or "ferreira2004", sets)
        self.data = out / "data"
        self.data.mkdir(parents=True, exist_ok=True)
        self.identified = self.truth
        self.results: dict = {"mode": {"quick": quick, "hil": "lock-step" if lockstep else "real time"}}
        self.figures: dict[str, list[str]] = {}
        self.fits = {}

    def scenario(self, name: str, **kw):
        """An experiment file of the paper, on the rig reproduced (``--params`` / ``--set``)."""
        return load_scenario(EXPERIMENTS_DIR / name, params=self.params, sets=self.sets, **kw)

    def rel(self, paths) -> list[str]:
        return [str(Path(p).relative_to(self.out)) for p in paths]

    def save_data(self, name: str, cols: dict[str, np.ndarray]) -> Path:
        path = self.data / name
        write_table(path, list(cols), np.column_stack([np.asarray(v, float) for v in cols.values()]))
        return path

    def chain(self, fit) -> None:
        """Record a fit, its report figures, and carry its values into the identified set."""
        self.fits[fit.procedure] = fit
        self.identified = fit.apply(self.identified)
        self.figures[fit.procedure] = self.rel(write_report(fit, self.out / "figures"))
        self.results[fit.procedure] = fit.to_json()
