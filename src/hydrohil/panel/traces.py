"""Live traces of the panel: a ring of the last ~65 s of steps and a min/max pyramid over it.

Rows are indexed by the plant's step k (slot k mod :data:`CAPACITY`). Level L of the pyramid holds the
minimum and maximum of every column over aligned blocks of 2^L steps; it is brought up to date lazily,
only for the blocks touched since the last frame, so a frame costs O(points shown) whatever the window:
a 60 s window at 2 kHz (120 000 steps) is drawn from ~1 000 blocks of 128 steps, a 1 s window from ~1 000
single steps. The envelope of every block is kept: a spike of one step shows at any zoom.
"""

from __future__ import annotations

import numpy as np

from hydrohil.hil.sidechannel import CONTROLLER_COLUMNS, PLANT_COLUMNS

CAPACITY = 1 << 17                         # 131 072 steps: 65.5 s at 0.5 ms
LEVELS = 11                                # blocks of 1 .. 1024 steps
DERIVED = ("error",)                       # reference − measured (the controller's first two columns)
JITTER_BINS = np.concatenate([[-np.inf, 0.0], np.logspace(0, 5, 41), [np.inf]])   # µs: ≤0, 1 µs .. 100 ms


class Traces:
    """``plant_columns`` / ``controller_columns``: the telemetry columns of either process (the paper's rig's
    by default; a circuit's: :func:`hydrohil.circuits.link.side_columns`)."""

    def __init__(self, h: float, capacity: int = CAPACITY, plant_columns=PLANT_COLUMNS,
                 controller_columns=CONTROLLER_COLUMNS):
        self.h, self.cap = h, capacity
        self.plant_columns, self.controller_columns = tuple(plant_columns), tuple(controller_columns)
        self.columns = self.plant_columns + self.controller_columns + DERIVED
        self.index = {c: i for i, c in enumerate(self.columns)}
        self._jitter = self.plant_columns.index("jitter_us")
        nc = len(self.columns)
        self.raw = np.full((capacity, nc), np.nan)
        self.lo = [self.raw] + [np.full((capacity >> L, nc), np.nan) for L in range(1, LEVELS)]
        self.hi = [self.raw] + [np.full((capacity >> L, nc), np.nan) for L in range(1, LEVELS)]
        self.k_max = -1                     # newest step with plant data
        self.dirty_from: int | None = None      # steps written since the pyramid was last brought up to date
        self.dirty_to = -1
        self.cleared_to = 0
        self.jitter_counts = np.zeros(len(JITTER_BINS) - 1, dtype=np.int64)
        self.rows = 0
        self.lost = 0                        # plant steps whose telemetry never arrived (the panel stalled)

    # -- input ---------------------------------------------------------------------------------
    def _clear_ahead(self, k_last: int) -> None:
        """Slots of steps not received yet hold a lap-old value: blank them ahead of the newest step."""
        while k_last >= self.cleared_to:
            a = self.cleared_to
            self.raw[np.arange(a, a + 4096) % self.cap] = np.nan
            for L in range(1, LEVELS):      # and the blocks over them (a block's other half keeps no lap-old value)
                nb = self.cap >> L
                self.lo[L][np.arange(a >> L, (a + 4096) >> L) % nb] = np.nan
                self.hi[L][np.arange(a >> L, (a + 4096) >> L) % nb] = np.nan
            self.cleared_to = a + 4096

    def add_plant(self, k0: int, rows: np.ndarray) -> None:
        """Plant telemetry rows of steps k0, k0+1, ... (columns ``plant_columns``)."""
        n = len(rows)
        if k0 > self.k_max + 1 and self.k_max >= 0:
            self.lost += k0 - self.k_max - 1
        self._clear_ahead(k0 + n - 1)
        idx = np.arange(k0, k0 + n) % self.cap
        self.raw[idx, :len(self.plant_columns)] = rows
        self._touch(k0, k0 + n - 1)
        self.k_max = max(self.k_max, k0 + n - 1)
        j = rows[:, self._jitter]
        self.jitter_counts += np.bincount(np.searchsorted(JITTER_BINS, j, side="left") - 1,
                                          minlength=len(self.jitter_counts))[:len(self.jitter_counts)]
        self.rows += n

    def add_controller(self, k0: int, rows: np.ndarray) -> None:
        """Controller telemetry rows (columns ``controller_columns``) of steps k0, k0+1, ..."""
        n = len(rows)
        if k0 + n - 1 < self.k_max - self.cap + 1:
            return                                   # older than the ring
        self._clear_ahead(k0 + n - 1)
        idx = np.arange(k0, k0 + n) % self.cap
        a = len(self.plant_columns)
        self.raw[idx, a:a + len(self.controller_columns)] = rows
        if rows.shape[1] >= 2:
            self.raw[idx, self.index["error"]] = rows[:, 0] - rows[:, 1]
        self._touch(k0, k0 + n - 1)

    def _touch(self, a: int, b: int) -> None:
        if self.dirty_from is None:
            self.dirty_from, self.dirty_to = a, b
        else:
            self.dirty_from, self.dirty_to = min(self.dirty_from, a), max(self.dirty_to, b)

    # -- the pyramid -----------------------------------------------------------------------------
    def _update(self) -> None:
        if self.dirty_from is None:
            return
        a, b = max(self.dirty_from, self.k_max - self.cap + 1, 0), self.dirty_to
        self.dirty_from = None
        with np.errstate(invalid="ignore"):
            for L in range(1, LEVELS):
                nb = self.cap >> L
                blocks = np.arange(a >> L, (b >> L) + 1) % nb
                lo_prev, hi_prev = self.lo[L - 1], self.hi[L - 1]
                self.lo[L][blocks] = np.fmin(lo_prev[2 * blocks], lo_prev[2 * blocks + 1])
                self.hi[L][blocks] = np.fmax(hi_prev[2 * blocks], hi_prev[2 * blocks + 1])

    def frame(self, window_s: float, end_k: int | None, columns: list[str], points: int = 1000) -> dict:
        """Min/max envelopes of ``columns`` over the ``window_s`` seconds ending at step ``end_k`` (None: the
        newest), at most ``points`` blocks: {"level", "block", "b0", "n", "lo": (ncols, n), "hi": (ncols, n)}."""
        self._update()
        k_end = self.k_max if end_k is None else min(int(end_k), self.k_max)
        n_steps = max(int(round(window_s / self.h)), 2)
        n_steps = min(n_steps, self.cap - 4096)
        L = 0
        while L < LEVELS - 1 and (n_steps >> L) > points:
            L += 1
        b_end = k_end >> L
        b0 = max((k_end - n_steps + 1) >> L, max(self.k_max - self.cap + 4097, 0) >> L)
        if k_end < 0 or b_end < b0:
            empty = np.zeros((len(columns), 0), np.float32)
            return {"level": L, "block": 1 << L, "b0": 0, "n": 0, "lo": empty, "hi": empty}
        nb = self.cap >> L
        blocks = np.arange(b0, b_end + 1) % nb
        cols = [self.index[c] for c in columns]
        lo = self.lo[L][blocks][:, cols].T.astype(np.float32)
        hi = self.hi[L][blocks][:, cols].T.astype(np.float32)
        return {"level": L, "block": 1 << L, "b0": int(b0), "n": int(len(blocks)), "lo": lo, "hi": hi}
