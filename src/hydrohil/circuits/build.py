"""A circuit's generated C compiled with the core's flags into a Python extension, cached by the hash of
everything it is made of (~/.cache/hydrohil/circuits/): built once per circuit and core version (a few
seconds), then loaded at once."""

from __future__ import annotations

import functools
import hashlib
import importlib.machinery
import importlib.util
import math
import os
import shutil
import sys
import tempfile
import threading
from pathlib import Path

from hydrohil.circuits.circuit import Circuit
from hydrohil.circuits.cache import cache_dir
from hydrohil.circuits.generate import Layout, generated
from hydrohil.errors import HydrohilError

CORE = Path(__file__).resolve().parent.parent / "core"
CDEF = """
void hc_init(const double *P, const double *u, double h, double *y, int64_t *m);
void hc_hold(const double *P, const double *u, double *y, int64_t *m);
double hc_lambda_h_max(void);
double hc_lambda_h_row(void);
void hc_stiff_constants(const double *P, const double *y, const int64_t *m, const double *u, double h, double *sc);
int64_t hc_state_size(const double *P, double h);
int hc_delayed_inputs(const double *P, double h, double *y, const double *u, double *ud);
void hc_rhs(const double *P, const double *y, const int64_t *m, const double *u, double *dy);
int64_t hc_rest(const double *P, const double *u, double *y, int64_t *m, const int64_t *held, int method, double h,
                int64_t max_steps, double rel_tol);
int hc_run(const double *P, double *y, int64_t *m, int method, double h, int64_t n, int64_t every,
           double *u, double *log, int64_t *rows, const void *ctl, void *ctl_state, const double *ref,
           const double *dref, int64_t meas, int64_t cmd, double *sensor, void *rng, double sign, void *path,
           double lo, double hi, double *sent, double *press, void *command, void *command_ctx,
           double *seen_log, double *events_log, double *watchdog_log, int64_t *steps, void *progress,
           void *progress_ctx, const int64_t *cols, int64_t ncols);
extern "Python" double hc_py_command(void *ctx, int64_t k, const double *row, double sensed, double p1, double p2,
                                     double ps, double pt, int saturated);
extern "Python" int hc_py_progress(void *ctx, int64_t k);
int hc_pressures_read(const double *v, double *press, void *rng, int64_t k, double *out);
void hc_pressures_rows(const double *v, int64_t rows, int64_t every, double *press, void *rng, double *out);
double hc_sensed(double x, double *sensor, void *rng, int64_t k);
void hc_sensed_rows(const double *x, int64_t rows, int64_t every, double *sensor, void *rng, double *out);
int hc_step(const double *P, double *y, int64_t *m, const double *u, int method, double h);
void hc_row(const double *P, const double *y, const int64_t *m, const double *u, double t, double *row);
void hc_state_bounds(const double *P, double *lo, double *hi);
int64_t hc_unphysical(const double *P, const double *y);
void hc_reference_rhs(const double *P, const double *y, const double *u, double *dy);
void hc_reference_row(const double *P, const double *y, const double *u, double t, double *row);
void hc_me_sizes(int64_t *ny, int64_t *nm, int64_t *nz, int64_t *nd);
""" + (CORE / "hc_core.h").read_text().split("/* cdef: begin */")[1].split("/* cdef: end */")[0]


class CompiledCircuit:
    """The loaded module of a circuit (``ffi``, ``lib``) with its layout and source."""

    def __init__(self, module, layout: Layout, source: str, path: Path):
        self.ffi, self.lib, self.layout, self.source, self.path = module.ffi, module.lib, layout, source, path
        _python_command(module.ffi)


_RAISED = threading.local()                # what a callback raised outside its callable (callback_raised)


def _kept(fail):
    """cffi's ``onerror`` of a callback: what was raised on the way into it or out of it (a Ctrl-C arrives at
    the first Python line after C) kept for :func:`callback_raised`, and ``fail`` returned (hc_run stops)."""
    def onerror(exc_type, exc_value, tb):
        _RAISED.exc = exc_value
        return fail
    return onerror


def callback_raised():
    """What an hc_run callback raised outside its callable since the last call (a Ctrl-C), or None; cleared."""
    exc, _RAISED.exc = getattr(_RAISED, "exc", None), None
    return exc


def _python_command(ffi) -> None:
    """hc_run's callbacks (a user's controller; the progress) compiled into the module (cffi's extern "Python": no code
    written at run time, so it works where memory is never both writable and executable): ``ctx`` the handle of
    a Python callable (k, the log row of step k (a C pointer), sensed, p1, p2, ps, pt, saturated) -> the
    command; what it raises is the callable's to keep (NaN); what is raised around it, :func:`callback_raised`'s
    (NaN: the run stops)."""
    @ffi.def_extern(name="hc_py_command", onerror=_kept(math.nan))
    def hc_py_command(ctx, k, row, sensed, p1, p2, ps, pt, saturated):
        return ffi.from_handle(ctx)(int(k), row, sensed, p1, p2, ps, pt, saturated)

    @ffi.def_extern(name="hc_py_progress", onerror=_kept(1))
    def hc_py_progress(ctx, k):               # (hc_run's progress: a callable (k) -> nonzero to stop)
        return ffi.from_handle(ctx)(int(k))


_LOADED: dict[Path, object] = {}           # the modules this process loaded, by the file they came from


@functools.lru_cache(maxsize=1)
def _build_digest() -> bytes:
    """The hash of what every circuit's build shares (the interface, the Python, the compiler and its flags, the
    core's C the generated code includes): read once per process (a core edited while a process runs is seen
    by the next process)."""
    from hydrohil.core.build import CFLAGS, c_compiler
    digest = hashlib.sha256(CDEF.encode())
    digest.update(f"{sys.version}|{importlib.machinery.EXTENSION_SUFFIXES[0]}|{c_compiler()}".encode())
    for f in sorted(CORE.glob("*.[ch]")):
        digest.update(f.name.encode() + b"\0" + f.read_bytes())
    digest.update(" ".join(CFLAGS).encode())
    return digest.digest()


@functools.lru_cache(maxsize=64)
def _module_name(source: str) -> str:
    """The module's name: its source's hash with the build's (hashed once per source in a process: a study's
    runs share one structure's text; the str caches its own hash for the lookup)."""
    return f"_hc_{hashlib.sha256(source.encode() + _build_digest()).hexdigest()[:16]}"


def compile_circuit(c: Circuit) -> CompiledCircuit:
    """The circuit's extension, built into the cache unless it is there (loaded once per process)."""
    from cffi import FFI
    from hydrohil.core.build import CFLAGS
    source, lay = generated(c)
    name = _module_name(source)
    folder = cache_dir()
    path = folder / (name + importlib.machinery.EXTENSION_SUFFIXES[0])
    if path in _LOADED:                             # (loaded: its name is its content's hash; CPython keeps it)
        return CompiledCircuit(_LOADED[path], lay, source, path)
    folder.mkdir(parents=True, exist_ok=True)
    if not path.exists():
        ffi = FFI()
        ffi.cdef(CDEF)
        ffi.set_source(name, source, include_dirs=[str(CORE)], extra_compile_args=list(CFLAGS), libraries=["m"])
        with tempfile.TemporaryDirectory() as tmp:
            try:
                built = Path(ffi.compile(tmpdir=tmp, verbose=False))
            except Exception as exc:        # noqa: BLE001 - the compiler's message, with the file it failed on
                raise HydrohilError(f"compiling circuit {c.name!r} ({c.source}) failed: {exc}") from None
            part = path.with_name(path.name + f".part{os.getpid()}-{threading.get_ident()}")
            shutil.copyfile(built, part)
            os.replace(part, path)                  # (atomic: another process may build the same meanwhile)
    loader = importlib.machinery.ExtensionFileLoader(name, str(path))
    spec = importlib.util.spec_from_file_location(name, path, loader=loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    _LOADED[path] = module
    return CompiledCircuit(module, lay, source, path)
