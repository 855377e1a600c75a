"""Input files of the identification procedures: CSV tables with a header row, and TOML datasheets.

Every check raises :class:`~hydrohil.errors.InputError` naming the file, the column/key and what was
expected (unit, range, number of points), so a bad measurement file never yields a silent bad fit.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from hydrohil.errors import InputError
from hydrohil.parameters import read_toml


@dataclass(frozen=True)
class Column:
    """A required (or optional) numeric column: name, unit text and plausible range of its values."""

    name: str
    unit: str
    lo: float = -np.inf
    hi: float = np.inf
    hint: str = ""          # shown when values are out of range, e.g. "looks like bar, expected Pa"
    default: float | None = None  # optional column when not None


def read_table(path: str | Path, columns: tuple[Column, ...], *, min_rows: int) -> dict[str, np.ndarray]:
    """Read a CSV file with a header row into float arrays, checking columns, values and size."""
    path = Path(path)
    src = str(path)
    try:
        with open(path, newline="") as fh:
            rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    except FileNotFoundError:
        raise InputError("file not found", source=src) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read as CSV text: {exc}", source=src) from None
    if not rows:
        raise InputError("empty file (expected a header row and data rows)", source=src)
    header = [h.strip() for h in rows[0]]
    data = rows[1:]
    out: dict[str, np.ndarray] = {}
    for col in columns:
        if col.name not in header:
            if col.default is not None:
                out[col.name] = np.full(len(data), float(col.default))
                continue
            raise InputError(f"missing column (header has: {', '.join(header)}; expected unit {col.unit})",
                             source=src, key=col.name)
        j = header.index(col.name)
        vals = np.empty(len(data))
        for i, r in enumerate(data):
            line = i + 2
            try:
                vals[i] = float(r[j])
            except (IndexError, ValueError):
                cell = r[j] if j < len(r) else "<missing>"
                raise InputError(f"line {line}: not a number: {cell!r}", source=src, key=col.name) from None
            if not np.isfinite(vals[i]):
                raise InputError(f"line {line}: non-finite value {r[j]!r} (remove or fix the row)",
                                 source=src, key=col.name)
        out[col.name] = vals
    n = len(data)
    if n < min_rows:
        raise InputError(f"too few data rows: {n} (need at least {min_rows})", source=src)
    for col in columns:
        check_range(out[col.name], col, src)
    return out


def check_range(values: np.ndarray, col: Column, source: str) -> None:
    """Raise if any value is not finite or lies outside the column's plausible range."""
    bad = ~np.isfinite(values) | (values < col.lo) | (values > col.hi)
    if bad.any():
        i = int(np.argmax(bad))
        hint = f"; {col.hint}" if col.hint else ""
        raise InputError(f"value {values[i]:g} (row {i + 1}) outside [{col.lo:g}, {col.hi:g}] {col.unit}{hint}",
                         source=source, key=col.name)


def read_keys(path: str | Path, fields: tuple[Column, ...], table: str | None = None) -> dict[str, float]:
    """Read scalar keys from a TOML file (optionally inside ``[table]``) with unit/range checks."""
    data = read_toml(path)
    return keys_from_mapping(data if table is None else data.get(table, {}), fields, str(path))


def keys_from_mapping(data: Mapping, fields: tuple[Column, ...], source: str) -> dict[str, float]:
    known = {f.name for f in fields}
    for key in data:
        if key not in known:
            raise InputError(f"unknown key (expected: {', '.join(sorted(known))})", source=source, key=key)
    out = {}
    for f in fields:
        if f.name not in data:
            if f.default is not None:
                out[f.name] = float(f.default) if np.isfinite(f.default) else f.default
                continue
            raise InputError(f"missing key (unit: {f.unit})", source=source, key=f.name)
        v = data[f.name]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"expected a number in {f.unit}; got {v!r}", source=source, key=f.name)
        check_range(np.array([float(v)]), f, source)
        out[f.name] = float(v)
    return out
