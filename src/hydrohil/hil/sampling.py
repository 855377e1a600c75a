"""A controller's sampling over the HIL link: one loop for the paper rig's controller
(:func:`hydrohil.hil.controller.run_position_controller`) and a circuit's
(:func:`hydrohil.hil.circuit.run_circuit_controller`): answer each sensor packet, or act on the controller's own
clock on the newest one (``[hil] controller_mode``)."""

from __future__ import annotations

import time
from typing import Callable

from hydrohil.errors import LinkError


def sample_loop(client, act: Callable, *, mode: str = "packet", sample_time: float = 5e-4,
                should_stop: Callable[[], bool] = lambda: False) -> None:
    """A controller's sampling over the link, the one loop of the paper rig's and a circuit's controller:
    ``act(packet)`` once per sensor packet (``mode = "packet"``: it answers each), or on the controller's own
    periodic clock of ``sample_time`` on the newest packet received (``mode = "clock"``: the same packet again
    when none came). Runs until the plant finishes or ``should_stop()``; LinkError when the plant goes silent
    for longer than the client's timeout."""
    if mode == "packet":
        for s in client.sensors():
            act(s)
            if should_stop():
                break
        return
    last = next(client.sensors(), None)      # LinkError when no plant answers
    t_last = time.monotonic()
    next_t = time.perf_counter()
    while last is not None and not client.finished and not should_stop():
        while True:   # take the newest packet available now
            s = client.receive(timeout=0.0)
            if s is None:
                break
            last, t_last = s, time.monotonic()
        act(last)
        next_t += sample_time
        delay = next_t - time.perf_counter()
        if delay > 0:
            s = client.receive(timeout=delay)
            if s is not None:
                last, t_last = s, time.monotonic()
            while time.perf_counter() < next_t:
                pass
        if not client.finished and time.monotonic() - t_last > client.timeout:
            raise LinkError(f"the plant at {client.address[0]}:{client.address[1]} went silent for "
                            f"{client.timeout:g} s after step {client.last_seq}")
