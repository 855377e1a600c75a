"""Kernel receive timestamps of UDP datagrams (Linux ``SO_TIMESTAMPNS``).

The plant's round-trip time is "sensor packet out -> answering command in". A process that sleeps
between steps learns of the command only when the kernel wakes it, which on a virtual machine can be
100+ µs later; that delay is the plant's own scheduling, not the round trip. The kernel stamps each
datagram as it is queued on the socket (CLOCK_REALTIME, ns): :func:`recv_stamped` returns that stamp,
so the plant can report both the wire round trip and the round trip as its process saw it.
Where the option is missing (non-Linux), the stamp is ``None`` and only the latter exists.

The same call reads the socket's kernel drop counter (``SO_RXQ_OVFL``): datagrams the kernel discarded
because the socket's receive buffer was full (a flood, or a plant that could not drain it in time). The
plant reports it as ``packets_dropped_kernel``, so every datagram sent to it is accounted for.
"""

from __future__ import annotations

import socket
import struct
import sys

# <asm-generic/socket.h>: SO_TIMESTAMPNS_OLD = 35, delivered as SCM_TIMESTAMPNS (same number)
SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35 if sys.platform.startswith("linux") else None)
SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40 if sys.platform.startswith("linux") else None)
_TIMESPEC = struct.Struct("@qq")          # struct timespec {time_t tv_sec; long tv_nsec;} on 64-bit Linux
_DROPS = struct.Struct("@I")              # uint32: datagrams dropped by the socket so far
_ANC_SIZE = socket.CMSG_SPACE(_TIMESPEC.size) + socket.CMSG_SPACE(_DROPS.size)


def enable_kernel_timestamps(sock: socket.socket) -> bool:
    """Ask the kernel to stamp every datagram received on ``sock``; False where unsupported."""
    if SO_RXQ_OVFL is not None:
        try:
            sock.setsockopt(socket.SOL_SOCKET, SO_RXQ_OVFL, 1)
        except OSError:
            pass
    if SO_TIMESTAMPNS is None:
        return False
    try:
        sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
    except OSError:
        return False
    return True


def recv_stamped(sock: socket.socket, bufsize: int) -> tuple[bytes, tuple, int | None, int | None]:
    """(data, sender address, kernel arrival time [ns, CLOCK_REALTIME] or None, the socket's kernel drop
    count so far or None) of one datagram. Raises ``BlockingIOError`` on an empty non-blocking socket, like
    ``recvfrom``."""
    data, anc, _flags, addr = sock.recvmsg(bufsize, _ANC_SIZE)
    stamp = drops = None
    for level, kind, payload in anc:
        if level != socket.SOL_SOCKET:
            continue
        if kind == SO_TIMESTAMPNS and len(payload) >= _TIMESPEC.size:
            sec, nsec = _TIMESPEC.unpack_from(payload)
            stamp = sec * 1_000_000_000 + nsec
        elif kind == SO_RXQ_OVFL and len(payload) >= _DROPS.size:
            drops = _DROPS.unpack_from(payload)[0]
    return data, addr, stamp, drops
