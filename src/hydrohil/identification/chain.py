"""``identify all``: run the procedures listed in a config file in chain order, one parameter file out.

Config (TOML; paths relative to the config file)::

    params = "ferreira2004"          # starting set: every value not identified below is kept
    [spool]
    file = "spool_bode.csv"
    [friction-dynamic]
    file = "friction_sine.csv"
    conditions = { "load.gravity_direction" = 0 }   # the experiment's set-up, for that fit only

Sections: any of :data:`~hydrohil.identification.PROCEDURES`; each later fit uses the parameters
identified before it (friction-dynamic simulates with the new spool, valve, bulk-modulus, leakage and
static friction values).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from hydrohil.errors import InputError, unknown_name
from hydrohil.identification import PROCEDURES, Fit, identify
from hydrohil.parameters import Parameters, load_parameters, read_toml


def identify_all(config: str | Path, *, on_start: Callable[[str], None] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> tuple[Parameters, list[Fit]]:
    """Run the chain; returns the final parameter set and the fits in the order run."""
    config = Path(config)
    cfg = read_toml(config)
    src = str(config)
    unknown = set(cfg) - set(PROCEDURES) - {"params"}
    if unknown:
        raise InputError(unknown_name(sorted(unknown)[0], ("params", *PROCEDURES), "section"), source=src)
    steps = [name for name in PROCEDURES if name in cfg]
    if not steps:
        raise InputError(f"no procedure section (expected one or more of {', '.join(PROCEDURES)})", source=src)
    base = cfg.get("params", "ferreira2004")
    base_path = config.parent / base
    params = load_parameters(base_path if base_path.suffix == ".toml" else base)
    fits = []
    for name in steps:
        sec = cfg[name]
        if not isinstance(sec, dict) or "file" not in sec:
            raise InputError("section needs a 'file' key (path of the input data)", source=src, key=f"{name}.file")
        extra = set(sec) - {"file", "conditions"}
        if extra:
            raise InputError(unknown_name(sorted(extra)[0], ("file", "conditions")), source=src, key=name)
        if on_start:
            on_start(name)
        fit = identify(name, config.parent / sec["file"], params, sec.get("conditions"), progress=progress)
        params = fit.apply(params)
        fits.append(fit)
    return params, fits
