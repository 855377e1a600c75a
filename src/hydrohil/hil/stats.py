"""Latency statistics in bounded memory: a log-spaced histogram (0.1 µs .. 100 s, 1.2 % bins)."""

from __future__ import annotations

import math

import numpy as np

LOW_US = 0.1
BINS_PER_DECADE = 200
DECADES = 9


class LatencyHistogram:
    """``add(value_ns)``; ``percentile(q)`` in µs (bin centre, 1.2 % resolution), exact max, count."""

    def __init__(self):
        self.counts = np.zeros(BINS_PER_DECADE * DECADES + 2, dtype=np.int64)
        self.n = 0
        self.max_ns = 0
        self._k = BINS_PER_DECADE / math.log(10.0)
        self._last = len(self.counts) - 1

    def add(self, value_ns: int) -> None:
        us = value_ns / 1e3
        if us <= LOW_US:
            i = 0
        else:
            i = min(int(math.log(us / LOW_US) * self._k) + 1, self._last)
        self.counts[i] += 1
        self.n += 1
        if value_ns > self.max_ns:
            self.max_ns = value_ns

    def percentile(self, q: float) -> float:
        if self.n == 0:
            return float("nan")
        target = q / 100.0 * self.n
        i = int(np.searchsorted(np.cumsum(self.counts), max(target, 1), side="left"))
        if i == 0:
            return 0.0               # at or below 0.1 us
        lo = LOW_US * 10 ** ((i - 1) / BINS_PER_DECADE)
        return min(lo * 10 ** (0.5 / BINS_PER_DECADE), self.max_ns / 1e3)
