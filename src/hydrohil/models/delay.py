"""Pure input delay of the valve (SPEC §3.1) as a ring buffer of zero-order-held commands.

The command u_k is held over [t_k, t_k + h). Delayed by dt = (n + alpha)*h, the spool input over step
k is u_{k-n-1} for a fraction alpha of the step and u_{k-n} for the rest; the fixed-step model uses
their step average (1 - alpha)*u_{k-n} + alpha*u_{k-n-1}: a fractional delay is interpolated, not rounded.
"""

from __future__ import annotations

import math

import numpy as np
from hydrohil._jit import jit


def split_delay(delay: float, h: float) -> tuple[int, float]:
    """(whole steps n, fraction alpha) with delay = (n + alpha)*h."""
    r = delay / h
    n = int(math.floor(r + 1e-9))
    return n, max(0.0, r - n)


def make_buffer(n: int, u0: float) -> np.ndarray:
    """A delay ring buffer for n whole steps, pre-filled with the command u0 held before t = 0."""
    return np.full(n + 2, float(u0))


@jit(inline=True)
def delay_push(buf, pos, u, n):
    """Push command u of the current step into ``buf`` (write index ``pos[0]``); return the two held
    commands the delayed input straddles this step: (u_{k-n}, u_{k-n-1})."""
    size = buf.shape[0]
    pos[0] = (pos[0] + 1) % size
    buf[pos[0]] = u
    return buf[(pos[0] - n) % size], buf[(pos[0] - n - 1) % size]


@jit(inline=True)
def delay_push_read(buf, pos, u, n, alpha):
    """Push command u of the current step and return the delayed spool input for this step (the step
    average of the two held commands it straddles)."""
    u_new, u_old = delay_push(buf, pos, u, n)
    return (1.0 - alpha) * u_new + alpha * u_old
