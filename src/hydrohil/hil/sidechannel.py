"""The side channel between a real-time process (plant, controller) and the live panel: telemetry out,
steering in, never a blocking call in the loop (docs/protocol.md, "Panel side channel").

* Telemetry: rows of float64 values, one per step, sent in batches of :data:`BATCH` rows (10 ms at 0.5 ms)
  as one UDP datagram to the panel: header ``<4s B B H H H q`` (magic ``HHTM``, version, role, columns,
  rows, reserved, first step index k0), eight int64 counters (the plant's: :data:`PLANT_COUNTERS`), then
  rows × columns float64 (little-endian). The socket is non-blocking: when the panel (or its machine) does
  not keep up, the kernel's buffer fills and the batch is *dropped and counted* — the loop never waits.
* Steering: JSON objects (``{"id": n, "op": ...}``) from the panel, read without blocking once per batch
  and answered with ``{"ack": id, "k": step, ...}`` or ``{"ack": id, "error": "..."}``. A repeated id
  (the panel's retry) is answered again, never applied twice.
"""

from __future__ import annotations

import json
import socket
import struct
from collections import OrderedDict

from hydrohil.core import shape

BATCH = 20
MAGIC = b"HHTM"
VERSION = 1
ROLE_PLANT, ROLE_CONTROLLER = 1, 2
HEADER = struct.Struct("<4sBBHHHq")       # 20 bytes
COUNTERS = struct.Struct("<8q")           # 64 bytes
PLANT_COLUMNS = shape.SIDE_PLANT_COLUMNS              # telemetry columns and counters: core/shape.py
CONTROLLER_COLUMNS = shape.SIDE_CONTROLLER_COLUMNS
PLANT_COUNTERS = shape.SIDE_PLANT_COUNTERS


def parse_batch(data: bytes):
    """(role, k0, counters tuple, rows as a list of column tuples) of a telemetry datagram, or None."""
    if len(data) < HEADER.size + COUNTERS.size:
        return None
    magic, version, role, ncols, nrows, _, k0 = HEADER.unpack_from(data, 0)
    if magic != MAGIC or version != VERSION or len(data) != HEADER.size + COUNTERS.size + 8 * ncols * nrows:
        return None
    counters = COUNTERS.unpack_from(data, HEADER.size)
    return role, k0, counters, ncols, nrows, memoryview(data)[HEADER.size + COUNTERS.size:]


class SideChannel:
    """One process's end of the side channel: ``row(k, *values)`` every step, ``flush``/``poll`` every
    :data:`BATCH` steps. Costs about a microsecond a step; drops, never blocks."""

    def __init__(self, panel: tuple[str, int], role: int, columns: tuple[str, ...], *, batch: int = BATCH):
        self.role, self.columns, self.batch = role, columns, batch
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.sock.connect(panel)
        self.row_struct = struct.Struct("<" + "d" * len(columns))
        self.offset0 = HEADER.size + COUNTERS.size
        self.buf = bytearray(self.offset0 + batch * self.row_struct.size)
        self.n = 0
        self.k0 = 0
        self.sent = 0
        self.dropped = 0
        self.seen: OrderedDict[int, dict] = OrderedDict()   # id -> answer (a retry is answered again)
        self.say({"hello": "plant" if role == ROLE_PLANT else "controller", "columns": list(columns)})

    @property
    def address(self) -> tuple[str, int]:
        return self.sock.getsockname()

    def row(self, k: int, *values: float) -> bool:
        """Add the row of step k; True when the batch is full (then call :meth:`flush`)."""
        if self.n == 0:
            self.k0 = k
        self.row_struct.pack_into(self.buf, self.offset0 + self.n * self.row_struct.size, *values)
        self.n += 1
        return self.n == self.batch

    def flush(self, counters=(0, 0, 0, 0, 0, 0, 0, 0)) -> None:
        if not self.n:
            return
        HEADER.pack_into(self.buf, 0, MAGIC, VERSION, self.role, len(self.columns), self.n, 0, self.k0)
        COUNTERS.pack_into(self.buf, HEADER.size, *counters)
        try:
            self.sock.send(memoryview(self.buf)[:self.offset0 + self.n * self.row_struct.size])
            self.sent += 1
        except OSError:          # EAGAIN (buffer full: the panel stalls), ECONNREFUSED (no panel): drop it
            self.dropped += 1
        self.n = 0

    def poll(self) -> list[dict]:
        """Steering messages that arrived (valid JSON objects with an integer id, not seen before)."""
        out = []
        while True:
            try:
                data = self.sock.recv(65536)
            except OSError:          # nothing more (or the panel is gone: ICMP refused)
                return out
            try:
                msg = json.loads(data)
                mid = int(msg["id"])
            except (ValueError, KeyError, TypeError):
                continue
            if mid in self.seen:
                if self.seen[mid] is not None:      # answered: answer again (None: taken in this poll already)
                    self.say(self.seen[mid])
                continue
            self.seen[mid] = None
            out.append(msg)

    def answer(self, msg: dict, **fields) -> None:
        ans = {"ack": int(msg["id"]), **fields}
        self.seen[int(msg["id"])] = ans
        while len(self.seen) > 256:
            self.seen.popitem(last=False)
        self.say(ans)

    def say(self, obj: dict) -> None:
        try:
            self.sock.send(json.dumps(obj).encode())
        except OSError:
            pass

    def close(self) -> None:
        self.flush()
        self.say({"bye": True})
        self.sock.close()
