"""Writing simulation results: ``log.csv`` (SI units, readable mode names), ``summary.json`` and a PNG."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from hydrohil.models.layout import FRICTION_NAMES, SPOOL_NAMES, TRAVEL_NAMES
from hydrohil.simulation.loop import LOG_COLUMNS

MODE_COLUMNS = {"travel_mode": TRAVEL_NAMES, "friction_mode": FRICTION_NAMES, "spool_mode": SPOOL_NAMES}
UNITS = {"t": "s", "u": "-", "ud": "-", "xs": "-", "vs": "1/s", "p1": "Pa", "p2": "Pa", "xp": "m", "vp": "m/s",
         "z": "m", "ff": "N", "events": "count"}


def write_table(path: Path, columns, arr: np.ndarray, *, names: dict[int, tuple] | None = None,
                ints=frozenset()) -> None:
    """Write the rows of ``arr`` as CSV with header ``columns``, atomically (``.part`` then rename).

    Column i in ``names`` is written as ``names[i][int(v)]`` (mode names), in ``ints`` as an integer,
    others as ``repr(float)`` (round-trip exact).
    """
    names = names or {}
    tmp = Path(str(path) + ".part")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for r in arr:
            w.writerow([names[i][int(v)] if i in names else int(v) if i in ints else repr(float(v))
                        for i, v in enumerate(r)])
    tmp.replace(path)


def write_log_csv(path: Path, log: np.ndarray, extra: dict[str, np.ndarray] | None = None) -> None:
    """One row per output interval; header = column names (units in README/docs); modes as names."""
    extra = extra or {}
    arr = np.column_stack([log, *(np.asarray(v, float)[: log.shape[0]] for v in extra.values())]) if extra else log
    names = {LOG_COLUMNS.index(c): v for c, v in MODE_COLUMNS.items()}
    write_table(path, [*LOG_COLUMNS, *extra], arr, names=names, ints={LOG_COLUMNS.index("events")})


def write_json(path: Path, data: dict) -> None:
    tmp = Path(str(path) + ".part")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=False) + "\n")
    tmp.replace(path)
