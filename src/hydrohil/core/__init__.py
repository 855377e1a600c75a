"""The C core (``src/hydrohil/core/*.c``, interface ``hh.h``) and its binding.

The physics, the hybrid statechart, the Runge-Kutta tableaus, the input delay, the sensor models, the
built-in controllers and the one sampled loop are C99 (libm only, no allocation or global state in a step).
``pip install`` compiles them into the cffi extension :mod:`hydrohil.core._hh` (``build.py``); ``lib`` holds
the functions and constants of ``hh.h``, ``ffi`` the types. C calls release the GIL.
"""

from __future__ import annotations

import numpy as np

try:
    from hydrohil.core._hh import ffi, lib
except ImportError as exc:        # pragma: no cover - a source tree that was never built
    raise ImportError("hydrohil's C core is not built: install the package with `pip install -e .` "
                      f"(it compiles src/hydrohil/core/*.c; needs a C compiler): {exc}") from exc

__all__ = ["ffi", "lib", "dptr", "iptr", "METHODS", "method_code"]

METHODS = {"euler": lib.HH_EULER, "heun": lib.HH_HEUN, "rk3": lib.HH_RK3, "rk4": lib.HH_RK4}


def method_code(name: str) -> int:
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"unknown fixed-step solver '{name}' (expected one of {', '.join(METHODS)})") from None


def dptr(a: np.ndarray):
    """``double *`` into a C-contiguous float64 array (no copy). The pointer holds a reference to the array,
    so a temporary passed straight to a call (``lib.f(dptr(pack(params)))``) lives until the call returns; a
    pointer stored in a C struct needs the array kept alive by its owner."""
    if a.dtype != np.float64 or not a.flags.c_contiguous:
        raise TypeError("expected a C-contiguous float64 array")
    return ffi.from_buffer("double[]", a)


def iptr(a: np.ndarray):
    """``int64_t *`` into a C-contiguous int64 array (no copy; holds a reference to it, as :func:`dptr`)."""
    if a.dtype != np.int64 or not a.flags.c_contiguous:
        raise TypeError("expected a C-contiguous int64 array")
    return ffi.from_buffer("int64_t[]", a)


def view(cdata, dtype, n: int) -> np.ndarray:
    """A NumPy view (no copy) of ``n`` values of a C array inside a struct owned by ``cdata``'s owner."""
    return np.frombuffer(ffi.buffer(cdata, n * np.dtype(dtype).itemsize), dtype=dtype)
