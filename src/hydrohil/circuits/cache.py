"""Where hydrohil keeps what it builds for circuits: their compiled modules (:mod:`hydrohil.circuits.build`) and
the circuit files of parameter sets (:mod:`hydrohil.circuits.parameter_set`), by content."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hydrohil" / "circuits"
