"""hydrohil wire protocol v1: fixed-layout little-endian UDP datagrams (specified in docs/protocol.md).

Every datagram = 32-byte header + payload + CRC-32 (zlib/IEEE, over everything before it):

    header  <4s H H I q q I>   magic b"HHIL", version, type, seq, t_send_ns, echo_t_ns, echo_seq
    SENSOR  <d Q q d d d d I B B B x>   t_sim, step, encoder_counts, p1, p2, ps, pt, status, modes
    COMMAND <d I I>             u (command in the configured unit, ū by default), flags, reserved
    HELLO / BYE                 no payload
    SIGNALS <d Q I I H H> + n·d  t_sim, step, status, layout, n, reserved, the circuit's n signal values
    INPUTS  <I I I H H> + n·d    layout, flags, mask, n, reserved, the circuit's n input values

SENSOR/COMMAND are the paper's rig; SIGNALS/INPUTS any circuit (``hydrohil.circuits``): their values in the
order of the circuit's signal and input lists, whose names and SI units ``layout`` (CRC-32) fingerprints.

A datagram that is too short/long for its type, has a wrong magic, version, type or CRC is *bad*:
:func:`decode` returns None and the receiver counts it. Nothing here raises on network input.
"""

from __future__ import annotations

import functools
import struct
import zlib
from typing import NamedTuple

from hydrohil.circuits.link import LINK_MAX_INPUTS, LINK_MAX_SIGNALS
from hydrohil.circuits.link import layout_id  # noqa: F401  (the circuit packets' fingerprint)
from hydrohil.core import shape
from hydrohil.errors import InputError

MAGIC = b"HHIL"
VERSION = 1
T_SENSOR, T_COMMAND, T_HELLO, T_BYE, T_SIGNALS, T_INPUTS = 1, 2, 3, 4, 5, 6

HEADER = struct.Struct("<4sHHIqqI")          # 32 bytes
SENSOR = struct.Struct("<dQqddddIBBBx")       # 64 bytes
COMMAND = struct.Struct("<dII")               # 16 bytes
SIGNALS = struct.Struct("<dQIIHH")           # 28 bytes, then n float64
INPUTS = struct.Struct("<IIIHH")             # 16 bytes, then n float64
CRC = struct.Struct("<I")
SIZES = {T_SENSOR: HEADER.size + SENSOR.size + CRC.size,      # 100
         T_COMMAND: HEADER.size + COMMAND.size + CRC.size,    # 52
         T_HELLO: HEADER.size + CRC.size,                     # 36
         T_BYE: HEADER.size + CRC.size}
MAX_DATAGRAM = 1472                          # a UDP payload in one 1500-byte Ethernet frame
MAX_SIGNALS = (MAX_DATAGRAM - HEADER.size - SIGNALS.size - CRC.size) // 8     # 176 signals of a circuit
MAX_INPUTS = 32                              # (the mask's bits)
assert (MAX_SIGNALS, MAX_INPUTS) == (LINK_MAX_SIGNALS, LINK_MAX_INPUTS)    # (circuits/link.py: the export's check)

# status bits of a sensor packet (core/shape.py STATUS: each bit and its meaning)
STATUS_BITS = {b.name: 1 << b.bit for b in shape.STATUS}
ST_WATCHDOG, ST_LOCKSTEP = STATUS_BITS["watchdog"], STATUS_BITS["lockstep"]
ST_AT_RETRACT, ST_AT_EXTEND, ST_STICK = STATUS_BITS["at_retract"], STATUS_BITS["at_extend"], STATUS_BITS["stick"]
ST_OVERRUN, ST_SATURATED = STATUS_BITS["overrun"], STATUS_BITS["saturated"]
ST_LATE_COMMAND, ST_FAULT, ST_FINAL = STATUS_BITS["late_command"], STATUS_BITS["fault"], STATUS_BITS["final"]
ST_FAULT_INJECTED = STATUS_BITS["fault_injected"]
# command flags
CMD_STOP = 1 << 0         # controller asks the plant to end the run


class Header(NamedTuple):
    type: int
    seq: int
    t_send_ns: int
    echo_t_ns: int
    echo_seq: int


class Sensor(NamedTuple):
    header: Header
    t_sim: float
    step: int
    encoder_counts: int
    p1: float
    p2: float
    ps: float
    pt: float
    status: int
    travel_mode: int
    friction_mode: int
    spool_mode: int


class Command(NamedTuple):
    header: Header
    u: float
    flags: int


class Signals(NamedTuple):
    """A circuit plant's state as its sensors report it (the counterpart of :class:`Sensor`)."""
    header: Header
    t_sim: float
    step: int
    status: int
    layout: int
    values: tuple


class Inputs(NamedTuple):
    """A controller's values for a circuit's inputs: input i is set when bit i of ``mask`` is (the others keep
    their drive from the scenario)."""
    header: Header
    layout: int
    flags: int
    mask: int
    values: tuple


def _seal(buf: bytearray) -> bytes:
    CRC.pack_into(buf, len(buf) - CRC.size, zlib.crc32(memoryview(buf)[:-CRC.size]))
    return bytes(buf)


def encode_header(buf: bytearray, typ: int, seq: int, t_send_ns: int, echo_t_ns: int, echo_seq: int) -> None:
    HEADER.pack_into(buf, 0, MAGIC, VERSION, typ, seq & 0xFFFFFFFF, t_send_ns, echo_t_ns, echo_seq & 0xFFFFFFFF)


def encode_sensor(seq, t_send_ns, echo_t_ns, echo_seq, t_sim, step, encoder_counts, p1, p2, ps, pt, status,
                  travel_mode, friction_mode, spool_mode) -> bytes:
    buf = bytearray(SIZES[T_SENSOR])
    encode_header(buf, T_SENSOR, seq, t_send_ns, echo_t_ns, echo_seq)
    SENSOR.pack_into(buf, HEADER.size, t_sim, step, encoder_counts, p1, p2, ps, pt, status, travel_mode,
                     friction_mode, spool_mode)
    return _seal(buf)


def encode_command(seq, t_send_ns, echo_t_ns, echo_seq, u, flags=0) -> bytes:
    buf = bytearray(SIZES[T_COMMAND])
    encode_header(buf, T_COMMAND, seq, t_send_ns, echo_t_ns, echo_seq)
    COMMAND.pack_into(buf, HEADER.size, u, flags, 0)
    return _seal(buf)


@functools.lru_cache(maxsize=64)
def _values(n: int) -> struct.Struct:
    """n little-endian float64 (the circuit packets' values; made once per count)."""
    return struct.Struct(f"<{n}d")


def encode_signals(seq, t_send_ns, echo_t_ns, echo_seq, t_sim, step, status, layout, values) -> bytes:
    n = len(values)
    buf = bytearray(HEADER.size + SIGNALS.size + 8 * n + CRC.size)
    encode_header(buf, T_SIGNALS, seq, t_send_ns, echo_t_ns, echo_seq)
    SIGNALS.pack_into(buf, HEADER.size, t_sim, step, status, layout, n, 0)
    _values(n).pack_into(buf, HEADER.size + SIGNALS.size, *values)
    return _seal(buf)


def encode_inputs(seq, t_send_ns, echo_t_ns, echo_seq, layout, mask, values, flags=0) -> bytes:
    n = len(values)
    buf = bytearray(HEADER.size + INPUTS.size + 8 * n + CRC.size)
    encode_header(buf, T_INPUTS, seq, t_send_ns, echo_t_ns, echo_seq)
    INPUTS.pack_into(buf, HEADER.size, layout, flags, mask, n, 0)
    _values(n).pack_into(buf, HEADER.size + INPUTS.size, *values)
    return _seal(buf)


def encode_simple(typ: int, seq: int, t_send_ns: int, echo_t_ns: int = 0, echo_seq: int = 0) -> bytes:
    """HELLO or BYE."""
    buf = bytearray(SIZES[typ])
    encode_header(buf, typ, seq, t_send_ns, echo_t_ns, echo_seq)
    return _seal(buf)


def decode(data: bytes) -> Header | Sensor | Command | None:
    """Decode one datagram; None for anything malformed, foreign, truncated, corrupted or of another
    version (the caller counts it)."""
    n = len(data)
    if n < HEADER.size + CRC.size or n > MAX_DATAGRAM:
        return None
    magic, version, typ, seq, t_send, echo_t, echo_seq = HEADER.unpack_from(data, 0)
    if magic != MAGIC or version != VERSION or _size(typ, data) != n:
        return None
    if CRC.unpack_from(data, n - CRC.size)[0] != zlib.crc32(memoryview(data)[:-CRC.size]):
        return None
    hdr = Header(typ, seq, t_send, echo_t, echo_seq)
    if typ == T_SIGNALS:
        t_sim, step, status, layout, count, _ = SIGNALS.unpack_from(data, HEADER.size)
        return Signals(hdr, t_sim, step, status, layout, _values(count).unpack_from(data, HEADER.size + SIGNALS.size))
    if typ == T_INPUTS:
        layout, flags, mask, count, _ = INPUTS.unpack_from(data, HEADER.size)
        values = _values(count).unpack_from(data, HEADER.size + INPUTS.size)
        if count > MAX_INPUTS or mask >> count or any(
                (mask >> i) & 1 and (v != v or abs(v) == float("inf")) for i, v in enumerate(values)):
            return None   # a set input that is not finite, or a bit beyond the values: bad packet
        return Inputs(hdr, layout, flags, mask, values)
    if typ == T_SENSOR:
        return Sensor(hdr, *SENSOR.unpack_from(data, HEADER.size))
    if typ == T_COMMAND:
        u, flags, _ = COMMAND.unpack_from(data, HEADER.size)
        if u != u or abs(u) == float("inf"):
            return None   # NaN/inf command: bad packet
        return Command(hdr, u, flags)
    return hdr


def _size(typ: int, data: bytes) -> int | None:
    """The length a datagram of type ``typ`` must have (the circuit types: from their value count)."""
    if typ == T_SIGNALS and len(data) >= HEADER.size + SIGNALS.size:
        return HEADER.size + SIGNALS.size + 8 * SIGNALS.unpack_from(data, HEADER.size)[4] + CRC.size
    if typ == T_INPUTS and len(data) >= HEADER.size + INPUTS.size:
        return HEADER.size + INPUTS.size + 8 * INPUTS.unpack_from(data, HEADER.size)[3] + CRC.size
    return SIZES.get(typ)


def parse_address(text: str, *, allow_remote: bool = False) -> tuple[str, int]:
    """'HOST:PORT' -> (host, port); a non-loopback host needs ``allow_remote``."""
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise InputError("expected HOST:PORT, e.g. 127.0.0.1:47000", source="address", key=text)
    host = host or "127.0.0.1"
    if not allow_remote and host not in ("127.0.0.1", "localhost", "::1"):
        raise InputError("binding a non-loopback address exposes the plant to the network; pass --allow-remote",
                         source="address", key=text)
    return host, int(port)
