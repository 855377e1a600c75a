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


def write_log_csv(path: Path, log: np.ndarray, extra: dict[str, np.ndarray] | None = None) -> None:
    """One row per output interval; header = column names (units in README/docs); modes as names."""
    extra = extra or {}
    cols = list(LOG_COLUMNS) + list(extra)
    idx = {c: i for i, c in enumerate(LOG_COLUMNS)}
    tmp = Path(str(path) + ".part")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in range(log.shape[0]):
            row = []
            for c in LOG_COLUMNS:
                v = log[r, idx[c]]
                if c in MODE_COLUMNS:
                    row.append(MODE_COLUMNS[c][int(v)])
                elif c == "events":
                    row.append(int(v))
                else:
                    row.append(repr(float(v)))
            row.extend(repr(float(extra[c][r])) for c in extra)
            w.writerow(row)
    tmp.replace(path)


def write_json(path: Path, data: dict) -> None:
    tmp = Path(str(path) + ".part")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=False) + "\n")
    tmp.replace(path)
