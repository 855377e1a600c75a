"""Build of the core's Python binding (cffi, out-of-line API mode), run by ``pip install``.

Writes ``hh_params.h`` from the pydantic schema (:mod:`hydrohil.core.layout`) and ``hh_shape.h`` from the
plant's shape (:mod:`hydrohil.core.shape`), both loaded by path (the package is not importable yet), derives cffi's declarations from ``hh.h`` (the one header of the interface) and
compiles ``hh_core.c`` into the extension ``hydrohil.core._hh``. The C calls release the GIL.
"""

from __future__ import annotations

import importlib.util
import os
import re
import sys
from pathlib import Path

from cffi import FFI

HERE = Path(__file__).resolve().parent
CFLAGS = ["-std=c99", "-O3", "-ffp-contract=off", "-fno-math-errno"]


def c_compiler() -> str:
    """The C compiler of this Python's build configuration (``CC``, else ``cc``), used for the FMU's binary and
    bench's instruction-count driver."""
    import sysconfig
    return (sysconfig.get_config_var("CC") or "cc").split()[0]


def core_sources() -> list[Path]:
    """The core's C sources and headers (what the binding, the FMU and the standalone plant compile)."""
    return sorted(p for p in HERE.glob("*.[ch]") if p.name != "_hh.c")


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def write_headers(directory: Path = HERE) -> list[Path]:
    """(Re)write the generated headers in ``directory``: ``hh_params.h`` from the schema
    (:mod:`hydrohil.core.layout`) and ``hh_shape.h`` from the plant's shape (:mod:`hydrohil.core.shape`);
    returns their paths."""
    schema = _load("_hh_schema", HERE.parent / "parameters" / "schema.py")
    layout = _load("_hh_layout", HERE / "layout.py")
    shape = _load("_hh_shape", HERE / "shape.py")
    out = []
    for name, text in (("hh_params.h", layout.c_header(schema.Parameters)), ("hh_shape.h", shape.c_header())):
        path = directory / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
        out.append(path)
    return out


def _macros(text: str) -> dict[str, str]:
    return dict(re.findall(r"^#define\s+(HH_\w+)\s+(\d+)\b", text, flags=re.M))


def cdef_text() -> str:
    """The declarations of ``hh.h`` as cffi reads them: preprocessor lines and C++ guards dropped, the
    integer macros of ``hh.h``/``hh_params.h`` kept as constants and substituted in array sizes."""
    header = (HERE / "hh_shape.h").read_text() + (HERE / "hh.h").read_text()    # hh.h includes hh_shape.h
    macros = _macros((HERE / "hh_params.h").read_text())
    macros.update(_macros(header))
    body = re.sub(r"#ifdef __cplusplus.*?#endif", "", header, flags=re.S)
    body = "\n".join(line for line in body.splitlines() if not line.lstrip().startswith("#"))
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    body = re.sub(r"\[(HH_\w+)\]", lambda m: f"[{macros.get(m.group(1), m.group(1))}]", body)
    consts = "\n".join(f"#define {k} {v}" for k, v in macros.items())
    reals = [k for k in re.findall(r"^#define\s+(HH_\w+)\s+\S", header, flags=re.M)
             if k not in macros and not k.endswith("_H")]
    consts += "\n" + "\n".join(f"static const double {k};" for k in reals)
    return consts + "\n" + body + """
extern "Python" int hh_py_advance(void *, double, double, double, double, double, double *);
extern "Python" int hh_py_progress(void *, int64_t);
extern "Python" double hh_py_command(void *, int64_t, double, double, double, const hh_rig_reading *);
extern "Python" int hh_py_event(void *, int64_t);
"""


def ffibuilder() -> FFI:
    """The cffi builder of ``hydrohil.core._hh`` (setup.py's ``cffi_modules`` calls this)."""
    write_headers()
    ffi = FFI()
    ffi.cdef(cdef_text())
    rel = Path(os.path.relpath(HERE))          # setuptools wants paths relative to setup.py's folder
    ffi.set_source("hydrohil.core._hh", '#include "hh.h"\n', sources=[(rel / "hh_core.c").as_posix()],
                   include_dirs=[rel.as_posix()], extra_compile_args=CFLAGS, libraries=["m"],
                   depends=[(rel / p.name).as_posix() for p in sorted(HERE.glob("*.[ch]"))])
    return ffi


if __name__ == "__main__":
    ffibuilder().compile(verbose=True)
