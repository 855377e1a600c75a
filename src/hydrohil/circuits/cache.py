"""Where hydrohil keeps what it builds for circuits: their compiled modules (:mod:`hydrohil.circuits.build`) and
the circuit files of parameter sets (:mod:`hydrohil.circuits.parameter_set`), by content."""

from __future__ import annotations

import functools
import os
from pathlib import Path


def cache_dir() -> Path:
    """$XDG_CACHE_HOME/hydrohil/circuits, else ~/.cache/hydrohil/circuits (read at each call: a test or a user's
    process may set it)."""
    return _cache_dir(os.environ.get("XDG_CACHE_HOME"), os.environ.get("HOME"))


@functools.lru_cache(maxsize=8)
def _cache_dir(xdg: str | None, home: str | None) -> Path:   # (home: a key only; Path.home() reads $HOME)
    return Path(xdg or str(Path.home() / ".cache")) / "hydrohil" / "circuits"
