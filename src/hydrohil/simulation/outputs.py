"""Writing simulation results: ``log.csv`` (SI units, readable mode names), ``summary.json`` and a PNG."""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path

import numpy as np

from hydrohil.core import shape


def column_formats(columns) -> tuple[dict[int, tuple], set[int]]:
    """How :class:`CsvStream` writes the columns of a table of :mod:`hydrohil.core.shape` (``shape.LOG``,
    ``shape.PLANT_LOG``): {index: the names of a mode's values}, {indices of integer columns}."""
    names = {i: shape.MODE_NAMES[c.kind] for i, c in enumerate(columns) if c.kind in shape.MODE_NAMES}
    return names, {i for i, c in enumerate(columns) if c.kind == "int"}


def write_table(path: Path, columns, arr: np.ndarray, *, names: dict[int, tuple] | None = None,
                ints=frozenset()) -> None:
    """Write the rows of ``arr`` as CSV with header ``columns``, atomically (``.part`` then rename); the
    cells are formatted as :class:`CsvStream` does (mode names, integers, round-trip exact floats)."""
    tmp = Path(str(path) + ".part")
    out = CsvStream(tmp, columns, names=names, ints=ints, flush_rows=10_000, flush_s=float("inf"))
    try:
        for r in arr:
            out.write(r)
    finally:
        out.close()
    tmp.replace(path)


def write_log_csv(path: Path, log: np.ndarray, extra: dict[str, np.ndarray] | None = None) -> None:
    """One row per output interval; header = column names (units in README/docs); modes as names."""
    extra = extra or {}
    arr = np.column_stack([log, *(np.asarray(v, float)[: log.shape[0]] for v in extra.values())]) if extra else log
    names, ints = column_formats(shape.LOG)
    write_table(path, [*shape.LOG_COLUMNS, *extra], arr, names=names, ints=ints)


def finite_or_none(d: dict) -> dict:
    """``d`` with its non-finite float values as None (JSON has no NaN or Infinity)."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


def write_json(path: Path, data: dict) -> None:
    tmp = Path(str(path) + ".part")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=False) + "\n")
    tmp.replace(path)


class CsvStream:
    """A CSV log written while the run goes: one formatted line per row, handed to the OS every
    ``flush_rows`` rows or ``flush_s`` seconds, so a process killed with SIGKILL leaves a readable file
    up to its last flush and memory stays bounded however long the run. Columns in ``names`` are written
    as ``names[i][int(v)]``, in ``ints`` as integers, others as ``repr(float)``."""

    def __init__(self, path: Path, columns, *, names: dict[int, tuple] | None = None, ints=frozenset(),
                 flush_rows: int = 2000, flush_s: float = 0.5):
        self._time = time.monotonic
        self.path = Path(path)
        self.fh = open(self.path, "w", newline="")
        self.fh.write(",".join(columns) + "\n")
        self.fh.flush()
        names = names or {}
        self.fmt = [(lambda v, n=names[i]: n[int(v)]) if i in names else (lambda v: str(int(v))) if i in ints
                    else repr for i in range(len(columns))]
        self.buf: list[str] = []
        self.flush_rows, self.flush_s = flush_rows, flush_s
        self.last_flush = self._time()
        self.rows = 0

    def write(self, row) -> None:
        self.buf.append(",".join([f(float(v)) for f, v in zip(self.fmt, row)]))
        self.rows += 1
        if len(self.buf) >= self.flush_rows or self._time() - self.last_flush >= self.flush_s:
            self.flush()

    def flush(self) -> None:
        if self.buf:
            self.fh.write("\n".join(self.buf) + "\n")
            self.buf.clear()
        self.fh.flush()
        self.last_flush = self._time()

    def close(self) -> None:
        if not self.fh.closed:
            self.flush()
            self.fh.close()


def read_csv_columns(path: Path) -> dict[str, np.ndarray]:
    """A CSV log (plant_log.csv, controller_log.csv, log.csv) as {column: array}: numbers as floats, a
    column of names (modes) as strings."""
    with open(path, newline="") as fh:
        r = csv.reader(fh)
        header = next(r)
        rows = list(r)
    out = {}
    for j, name in enumerate(header):
        col = [row[j] for row in rows]
        try:
            out[name] = np.array(col, dtype=float)
        except ValueError:
            out[name] = np.array(col)
    return out
