"""A parameter set of the paper's shape (``ferreira2004``, or a user's file, SPEC §8) as a circuit file of the
component library: the tables of its rig (an ideal supply, the paper's servo valve, its LuGre cylinder), and the
file a circuit name or path that is a parameter set stands for, written once into the cache. (Apart from
:mod:`hydrohil.circuits.paper`, which builds the Circuit: the circuit file's loader finds parameter sets here.)"""

from __future__ import annotations

import os
from pathlib import Path

from hydrohil.circuits.cache import cache_dir
from hydrohil.parameters import Parameters


def paper_circuit_file(name_or_path: str | Path) -> Path:
    """The circuit file of a parameter set (a built-in name such as ``ferreira2004``, or a parameter file of its
    shape): :func:`paper_tables` written once into the cache, by the content of its tables (what a circuit
    name or path that is a parameter set stands for: its rig as a circuit, in every layer)."""
    import hashlib
    import tomli_w
    from hydrohil.parameters import load_parameters
    tables = paper_tables(load_parameters(name_or_path))
    tables["name"] = Path(str(name_or_path)).stem
    tables["description"] = f"the paper's rig of the parameter set {name_or_path} (hydrohil.circuits.paper)"
    text = tomli_w.dumps(tables)
    path = cache_dir() / "paper" / f"{tables['name']}-{hashlib.sha256(text.encode()).hexdigest()[:16]}" / "circuit.toml"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"circuit.toml.part{os.getpid()}")     # (another process may write it meanwhile)
        tmp.write_text(f"# {tables['description']}: written by hydrohil, do not edit\n" + text)
        tmp.replace(path)
    return path


def paper_tables(p: Parameters, x0: float | None = None, command: float = 0.0) -> dict:
    """The tables of a circuit file of parameter set ``p`` (:func:`paper_circuit`)."""
    pos, neg = p.friction_sets()
    cyl = p.cylinder
    chambers = ({"bulk_b": cyl.b, "bulk_c": cyl.c} if cyl.bulk_modulus == "pressure" else
                {"beta_a": cyl.beta1, "beta_b": cyl.beta2})
    body = {"name": "ferreira2004", "components": {
        "supply": {"type": "pressure_source", "p": "supply", "pressure": p.supply.ps},
        "tank": {"type": "tank", "p": "tank", "pressure": p.supply.pt},
        "valve": {"type": "servo_valve", "P": "supply", "T": "tank", "A": "cap", "B": "rod",
                  **{f"k{i}": k for i, k in enumerate(p.valve.k, 1)},
                  **{f"kt{i}": k for i, k in enumerate(p.valve.kt, 1)},
                  "dp_laminar": p.valve.dp_laminar, "wn": p.spool.wn, "xi": p.spool.xi, "la": p.spool.la,
                  "lv": p.spool.lv, "delay": p.spool.delay},
        "cyl": {"type": "lugre_cylinder", "a": "cap", "b": "rod", "area_a": cyl.a1, "area_b": cyl.a2,
                "stroke": cyl.stroke, "dead_volume_a": cyl.v01, "dead_volume_b": cyl.v02, "leakage": cyl.g_lkc,
                **chambers, "mass": p.load.mass, "gravity": p.load.gravity,
                "incline": -90.0 * p.load.gravity_direction, "force": p.load.force,
                "sigma0": p.friction.sigma0, "sigma1": p.friction.sigma1,
                "fc_pos": pos.fc, "fs_pos": pos.fs, "vs_pos": pos.vs, "kv_pos": pos.kv,
                "fc_neg": neg.fc, "fs_neg": neg.fs, "vs_neg": neg.vs, "kv_neg": neg.kv,
                "x0": p.linear.xp0 if x0 is None else x0}},
        "inputs": {"valve.command": command}}
    return body
