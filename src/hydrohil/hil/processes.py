"""Plant and controller as child processes: start them, wait for their handshake lines, stop them.

The plant prints ``READY host:port`` once bound and ``PEER host:port`` once its controller has spoken;
the reference controller prints ``CONNECTED host:port`` at the plant's first sensor packet. Waiting for
these lines (never for a fixed time) makes scripts and tests hold on a loaded machine.
"""

from __future__ import annotations

import queue
import signal
import socket
import subprocess
import sys
import threading
import time

from hydrohil.errors import HydrohilError


def process_command(role: str, *args) -> list[str]:
    """The command line of a HIL process (``role``: ``plant`` or ``controller``) with this interpreter:
    ``python -m hydrohil.hil ROLE ARGS`` (:mod:`hydrohil.hil.commands`, the options of ``hydrohil ROLE``)."""
    if role not in ("plant", "controller"):
        raise ValueError(f"no HIL process {role!r}")
    return [sys.executable, "-m", "hydrohil.hil", role, *map(str, args)]


def free_udp_port(host: str = "127.0.0.1") -> int:
    """A UDP port free right now on ``host`` (for a controller whose address the plant must know)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


class Child:
    """A child process whose stdout lines are collected by a thread (its stderr too, so that neither pipe
    can fill up and block it)."""

    def __init__(self, args: list, name: str, **popen):
        self.name = name
        self.proc = subprocess.Popen([str(a) for a in args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, errors="replace", **popen)
        self.ended = False
        self.lines: queue.Queue[str | None] = queue.Queue()
        self.stderr_lines: list[str] = []
        self._threads = [threading.Thread(target=self._pump, args=(self.proc.stdout, self.lines.put, True),
                                          daemon=True),
                         threading.Thread(target=self._pump, args=(self.proc.stderr, self.stderr_lines.append, False),
                                          daemon=True)]
        for t in self._threads:
            t.start()

    @staticmethod
    def _pump(stream, put, end_marker: bool) -> None:
        for line in stream:
            put(line)
        if end_marker:
            put(None)

    def wait_line(self, prefix: str, timeout: float) -> str:
        """The first stdout line starting with ``prefix`` (without it); HydrohilError when the process ends
        or ``timeout`` passes first."""
        end = time.monotonic() + timeout
        while True:
            try:
                line = None if self.ended else self.lines.get(timeout=max(end - time.monotonic(), 0.0))
            except queue.Empty:
                raise HydrohilError(f"{self.name} did not say {prefix.strip()} within {timeout:g} s") from None
            if line is None:
                self.ended = True
                self.proc.wait()
                raise HydrohilError(f"{self.name} exited (code {self.proc.returncode}) before saying "
                                    f"{prefix.strip()}: {self.stderr()[-2000:]}")
            if line.startswith(prefix):
                return line[len(prefix):].strip()

    def stderr(self) -> str:
        for t in self._threads:
            if self.proc.poll() is not None:
                t.join(timeout=5)
        return "".join(self.stderr_lines).strip()

    def poll(self):
        return self.proc.poll()

    @property
    def returncode(self):
        return self.proc.returncode

    def wait(self, timeout: float | None = None):
        return self.proc.wait(timeout)

    def send_signal(self, sig) -> None:
        self.proc.send_signal(sig)

    def kill(self) -> None:
        self.proc.kill()

    def stop(self, grace: float = 10.0) -> None:
        """SIGINT (it finishes its logs), then kill after ``grace`` seconds."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(grace)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
