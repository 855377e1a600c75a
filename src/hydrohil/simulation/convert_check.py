"""A paper scenario and its conversion (:mod:`hydrohil.simulation.as_circuit`) run side by side: the core's run
against the generated code's, column by column (``hydrohil circuit convert --check``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def check(ls, spath: str | Path) -> dict:
    """The paper scenario ``ls`` run by the core and its conversion (circuit scenario ``spath``,
    :func:`hydrohil.simulation.as_circuit.convert`'s)
    run by the generated code, compared column by column of the core's log (the circuit's through
    :func:`hydrohil.circuits.paper.paper_log`): per real column the largest difference, the core's peak and
    their ratio; per discrete column (the modes, the events) the rows that differ. ``same_discrete``: no row
    differs; ``worst``: the real column of the largest ratio."""
    import warnings

    from hydrohil.circuits.paper import paper_log
    from hydrohil.circuits.scenario import run_circuit_scenario, load_circuit_scenario
    from hydrohil.core.shape import LOG
    from hydrohil.simulation.run import run_scenario
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")              # (the scenario's own warnings: said by the runs themselves)
        core = run_scenario(ls, engine="core")
        res = run_circuit_scenario(load_circuit_scenario(spath))[0]
    if core.diverged is not None:
        raise core.diverged
    a, b = core.log, paper_log(res)
    columns = {}
    for j, col in enumerate(LOG):
        if col.kind == "real":
            diff, peak = float(np.max(np.abs(a[:, j] - b[:, j]))), float(np.max(np.abs(a[:, j])))
            columns[col.name] = {"max_abs_difference": diff, "peak": peak, "relative": diff / peak if peak else diff}
        else:
            columns[col.name] = {"rows_differing": int(np.count_nonzero(a[:, j] != b[:, j]))}
    reals = {k: v for k, v in columns.items() if "relative" in v and k != "t"}
    return {"scenario": str(ls.source), "rows": len(a), "columns": columns,
            "same_discrete": all(v.get("rows_differing", 0) == 0 for v in columns.values()),
            "worst": max(reals, key=lambda k: reals[k]["relative"])}
