"""One description of the plant (core/shape.py): the C enums, the Python names, the logs and the FMU's
variables all come from it, and no layer spells an index of its own."""

import re
from pathlib import Path

from hydrohil.core import lib, shape
from hydrohil.hil import protocol
from hydrohil.hil.plant import LOG_COLUMNS as PLANT_LOG
from hydrohil.models.layout import FRICTION_NAMES, SPOOL_NAMES, STATE_NAMES, TRAVEL_NAMES
from hydrohil.simulation.loop import LOG_COLUMNS

SRC = Path(__file__).resolve().parent.parent / "src" / "hydrohil"


def test_the_cores_enums_are_the_descriptions_order():
    """hh_shape.h is generated from the description at build: the extension in use has its indices."""
    assert [getattr(lib, s.c) for s in shape.STATES] == list(range(len(shape.STATES))) and lib.HH_NY == 7
    for mode_index, m in enumerate(shape.MODES):
        assert getattr(lib, m.c) == mode_index
        assert [getattr(lib, v.c) for v in m.values] == list(range(len(m.values)))
        assert getattr(lib, f"HH_N_{m.name.upper()}") == len(m.values)
    assert [getattr(lib, f"HH_LOG_{c.name.upper().removesuffix('_MODE')}") for c in shape.LOG] == list(range(lib.HH_NLOG))
    assert [getattr(lib, f"HH_PLOG_{c.name.upper()}") for c in shape.PLANT_LOG] == list(range(lib.HH_NPLOG))
    assert lib.HH_NOUT == len(shape.OUTPUT_NAMES) and lib.HH_OUT_FF == shape.OUTPUT_NAMES.index("ff")
    assert [getattr(lib, f"HH_ST_{b.name.upper()}") for b in shape.STATUS] == [1 << b.bit for b in shape.STATUS]
    assert [getattr(lib, f"HH_PRESSURE_{p.upper()}") for p in shape.PRESSURES] == list(range(lib.HH_NPRESSURES))


def test_python_names_come_from_the_description():
    assert STATE_NAMES == tuple(s.name for s in shape.STATES)
    assert (TRAVEL_NAMES, FRICTION_NAMES, SPOOL_NAMES) == tuple(shape.MODE_NAMES.values())
    assert LOG_COLUMNS == shape.LOG_COLUMNS and PLANT_LOG == shape.PLANT_LOG_COLUMNS
    assert protocol.ST_FAULT_INJECTED == lib.HH_ST_FAULT_INJECTED == 1 << 10
    assert len(set(shape.TIMING_KEYS)) == len(shape.TIMING_KEYS)
    # every column the FMU outputs is a quantity or a mode of the description, with its unit
    from hydrohil.export.fmu import MODE_OUTPUTS, REAL_OUTPUTS
    for name, unit, desc, _ in REAL_OUTPUTS:
        q = shape.QUANTITIES[name]
        assert desc == q.description and unit == ("1" if q.unit == "-" else q.unit)   # FMI: "1" for a dimensionless Real
    assert [n for n, *_ in MODE_OUTPUTS] == [f"{m.name}_mode" for m in shape.MODES]


# the shape's arrays indexed by a number instead of a name: out[5], y[2], m[0], row[9], r->p[3], sim.m[1]
LITERAL_INDEX = re.compile(r"\b(out|row|y|m)\[[0-9]+\]|(->|\.)(p|y|m|out)\[[0-9]+\]")


def test_no_layer_indexes_the_shape_by_number():
    """The issue's six layers indexed out[], y[], m[] and the log rows by literal numbers; now by the
    generated names. A literal index anywhere in the package's Python or C is reported here."""
    hits = []
    for path in sorted(SRC.rglob("*")):
        if path.suffix not in (".py", ".c", ".h") or path.name in ("hh_params.h", "hh_shape.h", "_hh.c"):
            continue
        for i, line in enumerate(path.read_text().splitlines(), 1):
            if LITERAL_INDEX.search(line.split("#")[0] if path.suffix == ".py" else line):
                hits.append(f"{path.relative_to(SRC)}:{i}: {line.strip()}")
    assert not hits, "\n".join(hits)


def test_the_literal_index_check_finds_one():
    assert LITERAL_INDEX.search("row[9], row[10] = out[1], out[3]")
    assert LITERAL_INDEX.search("s.p1 = r->p[0];") and LITERAL_INDEX.search("(int)pl->sim.m[2]")
    assert not LITERAL_INDEX.search("row[lib.HH_PLOG_XS] = out[lib.HH_OUT_Y + lib.HH_XS]")
