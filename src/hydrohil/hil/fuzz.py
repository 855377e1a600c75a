"""Protocol fuzzing: random and mutated datagrams against the decoder and against a live plant.

``fuzz_decoder(n)``: n datagrams (valid packets of every type, then mutated: bit flips, byte
overwrites, truncation, extension, header fields rewritten with a correct CRC, NaN/Inf commands,
pure random bytes) through :func:`~hydrohil.hil.protocol.decode`: it must return a message or None,
never raise; the malformed ones must be None.

``fuzz_c_decoder(n)``: the same datagrams through the standalone C plant's decoder (``protocol.c`` of
``hydrohil export c``) and the Python one: they must agree on every datagram and on every field read.

``fuzz_live_plant(n)``: a real-time plant (``hydrohil plant`` or the C plant) (its own process, loopback) with the P controller running,
while a third process-side socket sends n fuzz datagrams at a steady rate; once all are sent the plant
is stopped (SIGINT: it drains its socket, finishes its log and ``timing.json``). Checks afterwards: the
plant was alive all along and served every step, every datagram is accounted for (``packets_bad`` for the
malformed, ``packets_foreign`` for the well-formed ones from the fuzzer's address, and the kernel's drop
counter for those a full socket buffer discarded), the controller's run was not disturbed, and the
timing figures.
"""

from __future__ import annotations

import json
import math
import signal
import socket
import struct
import tempfile
import time
import zlib
from pathlib import Path
from typing import Callable

import numpy as np

from hydrohil.hil import protocol as pr


def _valid_packets(rng: np.random.Generator) -> list[bytes]:
    t = int(rng.integers(0, 2**62))
    return [pr.encode_sensor(int(rng.integers(0, 2**32)), t, t, 1, 0.5, 1000, 123456, 4e6, 3e6, 7e6, 0.0, 3, 0, 1, 0),
            pr.encode_command(int(rng.integers(0, 2**32)), t, t, 1, float(rng.uniform(-2, 2))),
            pr.encode_simple(pr.T_HELLO, 0, t), pr.encode_simple(pr.T_BYE, 1, t)]


def _reseal(buf: bytearray) -> bytes:
    struct.pack_into("<I", buf, len(buf) - 4, zlib.crc32(bytes(buf[:-4])))
    return bytes(buf)


def mutate(rng: np.random.Generator, base: bytes) -> bytes:
    """One fuzz datagram derived from ``base`` (or random bytes)."""
    kind = int(rng.integers(0, 9))
    b = bytearray(base)
    if kind == 0:                                       # flip 1-8 bits
        for _ in range(int(rng.integers(1, 9))):
            i = int(rng.integers(0, len(b)))
            b[i] ^= 1 << int(rng.integers(0, 8))
    elif kind == 1:                                     # overwrite a byte run
        i = int(rng.integers(0, len(b)))
        n = int(rng.integers(1, 9))
        b[i:i + n] = rng.integers(0, 256, size=len(b[i:i + n]), dtype=np.uint8).tobytes()
    elif kind == 2:                                     # truncate
        b = b[: int(rng.integers(0, len(b)))]
    elif kind == 3:                                     # extend
        b += rng.integers(0, 256, size=int(rng.integers(1, 64)), dtype=np.uint8).tobytes()
    elif kind == 4:                                     # header field rewritten, CRC made valid again
        field = int(rng.integers(0, 4))
        if field == 0:
            b[0:4] = rng.integers(0, 256, size=4, dtype=np.uint8).tobytes()
        elif field == 1:
            struct.pack_into("<H", b, 4, int(rng.integers(0, 65536)))       # version
        elif field == 2:
            struct.pack_into("<H", b, 6, int(rng.integers(0, 65536)))       # type
        else:
            struct.pack_into("<I", b, 8, int(rng.integers(0, 2**32)))       # seq
        return _reseal(b)
    elif kind == 5 and len(b) == pr.SIZES[pr.T_COMMAND]:   # NaN / Inf / huge command, CRC valid
        struct.pack_into("<d", b, pr.HEADER.size, [math.nan, math.inf, -math.inf, 1e308][int(rng.integers(0, 4))])
        return _reseal(b)
    elif kind == 6:                                     # random bytes of a plausible length
        return rng.integers(0, 256, size=int(rng.integers(0, 200)), dtype=np.uint8).tobytes()
    elif kind == 7:                                     # empty or 1 byte
        return bytes(int(rng.integers(0, 2)))
    else:                                               # a valid packet, unchanged
        return bytes(b)
    return bytes(b)


def fuzz_stream(n: int, seed: int = 0):
    """Yield ``n`` fuzz datagrams (deterministic for a seed)."""
    rng = np.random.default_rng(seed)
    base = _valid_packets(rng)
    for i in range(n):
        if i % 1000 == 0:
            base = _valid_packets(rng)
        yield mutate(rng, base[int(rng.integers(0, len(base)))])


def fuzz_decoder(n: int = 1_000_000, seed: int = 0, progress: Callable[[int, int], None] | None = None) -> dict:
    """Decode ``n`` fuzz datagrams; returns counts. Raises AssertionError on a decoder exception or on a
    malformed datagram accepted (CRC, length, magic, version, type and finite command are all checked)."""
    accepted = rejected = 0
    t0 = time.perf_counter()
    for i, d in enumerate(fuzz_stream(n, seed)):
        try:
            msg = pr.decode(d)
        except Exception as exc:                       # noqa: BLE001 - the point of the test
            raise AssertionError(f"decoder raised {exc!r} on datagram {i}: {d.hex()}") from exc
        if msg is None:
            rejected += 1
        else:
            ok = (len(d) >= pr.HEADER.size + 4 and d[:4] == pr.MAGIC
                  and zlib.crc32(d[:-4]) == struct.unpack_from("<I", d, len(d) - 4)[0])
            assert ok, f"malformed datagram {i} accepted: {d.hex()}"
            accepted += 1
        if progress and i % 50_000 == 0:
            progress(i, n)
    return {"datagrams": n, "accepted": accepted, "rejected": rejected, "wall_s": time.perf_counter() - t0}


def c_decoder():
    """(ffi, lib) of the standalone C plant's ``protocol.c`` (``hydrohil export c``) built as a shared library
    with this Python's compiler (cached beside the C plant's builds), for differential fuzzing."""
    import hashlib
    import os
    import re
    import subprocess
    from cffi import FFI
    from hydrohil.core.build import c_compiler
    from hydrohil.export.cplant import RT, cache_dir
    header, source = (RT / "protocol.h").read_text(), (RT / "protocol.c").read_text()
    lib_path = cache_dir() / f"protocol-{hashlib.sha256((header + source).encode()).hexdigest()[:16]}.so"
    if not lib_path.exists():
        lib_path.parent.mkdir(parents=True, exist_ok=True)
        part = lib_path.with_suffix(f".part{os.getpid()}")
        subprocess.run([c_compiler(), "-std=c99", "-O2", "-shared", "-fPIC", "-I", str(RT), str(RT / "protocol.c"),
                        "-lm", "-o", str(part)], check=True, capture_output=True)
        part.replace(lib_path)
    decl = re.sub(r"/\*.*?\*/", "", header, flags=re.S)
    decl = "\n".join(line for line in decl.splitlines() if not line.lstrip().startswith("#"))
    ffi = FFI()
    ffi.cdef(decl)
    return ffi, ffi.dlopen(str(lib_path))


def _same(a: float, b: float) -> bool:
    return a == b or (a != a and b != b)


def fuzz_c_decoder(n: int = 1_000_000, seed: int = 0, progress: Callable[[int, int], None] | None = None) -> dict:
    """The fuzz datagrams through the C plant's decoder and the Python one: both must accept the same
    datagrams and read the same fields from them (AssertionError with the datagram otherwise)."""
    ffi, lib = c_decoder()
    msg = ffi.new("hhil_message *")
    accepted = rejected = 0
    t0 = time.perf_counter()
    for i, d in enumerate(fuzz_stream(n, seed)):
        py = pr.decode(d)
        ok = lib.hhil_decode(d, len(d), msg)
        assert bool(ok) == (py is not None), f"C decoder {'accepts' if ok else 'rejects'} datagram {i}: {d.hex()}"
        if py is None:
            rejected += 1
        else:
            accepted += 1
            h = msg.header
            hdr = py if isinstance(py, pr.Header) else py.header
            assert (h.type, h.seq, h.t_send_ns, h.echo_t_ns, h.echo_seq) == tuple(hdr), f"header of {i}: {d.hex()}"
            if isinstance(py, pr.Sensor):
                c = msg.sensor
                got = (c.t_sim, c.step, c.encoder_counts, c.p1, c.p2, c.ps, c.pt, c.status, c.travel_mode,
                       c.friction_mode, c.spool_mode)
                assert all(_same(a, b) for a, b in zip(got, py[1:])), f"sensor fields of {i}: {d.hex()}"
            elif isinstance(py, pr.Command):
                assert (msg.command.u, msg.command.flags) == (py.u, py.flags), f"command of {i}: {d.hex()}"
        if progress and i % 50_000 == 0:
            progress(i, n)
    return {"datagrams": n, "accepted": accepted, "rejected": rejected, "wall_s": time.perf_counter() - t0}


def fuzz_live_plant(n: int = 1_000_000, rate_hz: float = 20_000.0, seed: int = 0, *, step: float = 5e-4,
                    out: Path | None = None, progress: Callable[[int, int], None] | None = None,
                    plant: str = "python") -> dict:
    """Fuzz a real-time plant (loopback) while the P controller runs against it: ``hydrohil plant``, or
    with ``plant="c"`` the standalone C plant; see the module docstring for what is checked. Returns the
    figures."""
    from hydrohil.hil.processes import Child, free_udp_port, process_command
    from hydrohil.hil.run import plant_command
    from hydrohil.simulation.scenario import load_scenario
    duration = n / rate_hz + 120.0      # an upper bound: the plant is stopped once everything is sent
    tmp = tempfile.TemporaryDirectory() if out is None else None
    out = Path(tmp.name) if tmp else Path(out)
    out.mkdir(parents=True, exist_ok=True)
    scen = out / "fuzz_scenario.toml"
    scen.write_text(f'params = "ferreira2004"\nduration = {duration}\n[solver]\nstep = {step}\n[initial]\nxp = 0.05\n'
                    '[controller]\ntype = "p"\nkp = 50.0\n[reference]\ntype = "table"\nt = [0.0, 1.0]\n'
                    'x = [0.05, 0.10]\n')
    ctl_address = f"127.0.0.1:{free_udp_port()}"
    (out / "plant").mkdir(exist_ok=True)
    plant = Child(plant_command(load_scenario(scen), scen, out / "plant", ctl_address, plant=plant), "plant")
    ctl = None
    try:
        host, port = plant.wait_line("READY ", 120.0).rsplit(":", 1)
        ctl = Child(process_command("controller", "--scenario", scen, "--connect", f"{host}:{port}", "--log", out / "controller",
                        "--local", ctl_address), "controller")
        plant.wait_line("PEER ", 120.0)                   # the controller is the peer: the fuzzer can only be foreign
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        target = (host, int(port))
        bad = good = refused = 0
        burst = max(1, int(rate_hz / 1000))
        t0 = time.perf_counter()
        for i, d in enumerate(fuzz_stream(n, seed)):
            try:
                sock.sendto(d, target)
            except OSError:          # refused by the OS: never reached the plant, counted apart
                refused += 1
                continue
            if pr.decode(d) is None:
                bad += 1
            else:
                good += 1
            if progress and i % 20_000 == 0:
                progress(i, n)
            if i % burst == burst - 1:            # paced in 1 ms bursts, sleeping between (no busy loop)
                wait = t0 + (i + 1) / rate_hz - time.perf_counter()
                if wait > 0:
                    time.sleep(wait)
        fuzz_wall = time.perf_counter() - t0
        sent_while_plant_ran = plant.poll() is None        # else the last datagrams found no socket (a slow sender)
        sock.close()
        plant.send_signal(signal.SIGINT)
        plant_rc = plant.wait(timeout=60)
        ctl_rc = ctl.wait(timeout=60)
    except BaseException:                            # stop both children whatever went wrong
        for c in (ctl, plant):
            if c is not None:
                c.stop()
        raise
    timing = json.loads((out / "plant" / "timing.json").read_text())
    res = {"datagrams": n, "sent_malformed": bad, "sent_well_formed": good, "fuzz_wall_s": fuzz_wall,
           "plant_exit": plant_rc, "controller_exit": ctl_rc, "verdict": timing["verdict"],
           "sent_while_plant_ran": sent_while_plant_ran, "send_refused": refused,
           **{k: timing.get(k) for k in ("steps", "steps_planned", "packets_bad", "packets_foreign", "packets_rx",
                                         "packets_dropped_kernel",
                                         "packets_lost", "watchdog_trips", "late_commands", "overruns",
                                         "jitter_us_p50", "jitter_us_p99", "jitter_us_p999", "jitter_us_max",
                                         "rtt_us_p99", "drift_ms")}}
    if tmp:
        tmp.cleanup()
    return res
