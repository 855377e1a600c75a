"""One place for the numba compilation options of every compiled kernel.

Cached to disk (``cache=True``: a warm start skips compilation), NumPy error model (no Python
ZeroDivisionError checks in the hot loop) and the fast-math flags that keep IEEE NaN/Inf semantics
(so divergence detection still sees non-finite values): contraction to FMA and reciprocal division.
"""

from __future__ import annotations

import hashlib
import os
import types
from pathlib import Path

import numba
from numba import njit


def _cache_dir() -> Path | None:
    """numba's on-disk cache is keyed on each function's own file only: a kernel in loop.py inlines the
    models of other files and would keep stale code after they change. So the cache lives in a folder
    named by a hash of the whole package source (``~/.cache/hydrohil/numba/<hash>``); ``NUMBA_CACHE_DIR``
    set by the user wins."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    digest = hashlib.sha1()
    root = Path(__file__).resolve().parent
    for f in sorted(root.rglob("*.py")):
        digest.update(f.relative_to(root).as_posix().encode())
        digest.update(f.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    path = base / "hydrohil" / "numba" / digest.hexdigest()[:16]
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None              # read-only home: numba's default (next to the sources)
    return path


_CACHE = _cache_dir()
if _CACHE is not None:
    numba.config.CACHE_DIR = str(_CACHE)

FASTMATH = {"contract", "arcp"}


def jit(func=None, *, inline: bool = False, parallel: bool = False, nrt: bool = True):
    """``@jit`` / ``@jit(inline=True)`` / ``@jit(parallel=True)``: numba ``njit`` with the project's
    options (``parallel`` turns ``numba.prange`` loops into threads).

    ``inline=True`` marks a helper of the hot loop: compiled (and cached) once, inlined into each caller
    by LLVM (numba's ``forceinline``), and free of reference counting (``nrt=False``, below). numba's
    own IR-level inlining (``inline="always"``) re-types a helper at every call site: it took 7.6 s of
    the 12.7 s cold compile of the simulation loop; LLVM inlining gives the same code in 5.5 s in all.

    ``nrt=False`` compiles a kernel without numba's reference-counting runtime. Kernels that allocate
    nothing (the caller owns every array) need no reference counts, and numba's pruning pass leaves
    many atomic incref/decref pairs in inlined, branching code (numba issues #2345, #2350): in the
    hybrid step they cost two thirds of the time (560 -> 160 ns per RK3 step on the bench machine).
    Such a kernel cannot create arrays (``np.empty`` fails at compile time).
    """
    opts = dict(cache=True, error_model="numpy", fastmath=FASTMATH)
    if inline:
        opts["forceinline"] = True
        nrt = False
    if parallel:
        opts["parallel"] = True
    if not nrt:
        opts["_nrt"] = False
    if func is None:
        return lambda f: njit(**opts)(f)
    return njit(**opts)(func)


def specialize(template, name: str, *, inline: bool = False, nrt: bool = True, **bindings):
    """Compile a copy of the module-level function ``template`` whose global names ``bindings`` are
    bound to the given compiled functions / constants (tableaus, right-hand sides, steppers).

    Binding through globals (not closures) keeps numba's on-disk cache valid across processes
    (closure cells holding dispatchers change identity per process); the unique ``name`` gives each
    specialisation its own cache file.
    """
    g = dict(template.__globals__)
    g.update(bindings)
    fn = types.FunctionType(template.__code__, g, name, template.__defaults__)
    fn.__qualname__ = name
    fn.__module__ = template.__module__
    fn.__doc__ = template.__doc__
    return jit(fn, inline=inline, nrt=nrt)
