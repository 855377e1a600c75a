"""Keep every CPU busy, to run the test suite (or anything) on a loaded machine.

    python benchmarks/hog.py [--cpus N] [--seconds S] [-- COMMAND ...]

Starts N busy-loop processes (default: one per CPU this process may use) at normal priority. With a
COMMAND, runs it while the loops spin and exits with its exit code; without, spins for ``--seconds``
(default: until Ctrl-C). The loops stop with it in every case. The suite must pass under it:

    python benchmarks/hog.py -- python -m pytest -q
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import subprocess
import sys
import time


def _spin(stop) -> None:
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    command = []
    if "--" in argv:
        i = argv.index("--")
        argv, command = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cpus", type=int, default=len(os.sched_getaffinity(0)), help="busy loops (default: one per CPU)")
    ap.add_argument("--seconds", type=float, default=None, help="spin this long without a command")
    a = ap.parse_args(argv)
    stop = mp.Event()
    loops = [mp.Process(target=_spin, args=(stop,), daemon=True) for _ in range(a.cpus)]
    for p in loops:
        p.start()
    print(f"hog: {a.cpus} busy loop(s) running", file=sys.stderr, flush=True)
    try:
        if command:
            return subprocess.call(command)
        end = time.monotonic() + (a.seconds if a.seconds is not None else float("inf"))
        while time.monotonic() < end:
            time.sleep(min(1.0, max(end - time.monotonic(), 0.0)))
        return 0
    except KeyboardInterrupt:
        return 130
    finally:
        stop.set()
        for p in loops:
            p.join(timeout=5)
            if p.is_alive():
                p.kill()


if __name__ == "__main__":
    sys.exit(main())
