"""The panel's end of the side channel (:mod:`hydrohil.hil.sidechannel`): one UDP socket on loopback that
takes the telemetry batches of the plant and the controller into :class:`~hydrohil.panel.traces.Traces`
(and the plant's counters), and sends steering messages to either process, resent until answered with the
step index at which they were applied."""

from __future__ import annotations

import asyncio
import json
import socket
import time

import numpy as np

from hydrohil.errors import HydrohilError, InputError
from hydrohil.hil.sidechannel import (CONTROLLER_COLUMNS, PLANT_COLUMNS, PLANT_COUNTERS, ROLE_CONTROLLER, ROLE_PLANT,
                                      parse_batch)
from hydrohil.panel.traces import Traces

ACK_TIMEOUT_S = 3.0


class _Protocol(asyncio.DatagramProtocol):
    def __init__(self, hub: "SideHub"):
        self.hub = hub

    def datagram_received(self, data: bytes, addr) -> None:
        self.hub.on_datagram(data, addr)


class SideHub:
    """The side-channel socket of one panel and what came through it: ``traces``, ``counters`` (the plant's,
    and the telemetry steps lost), ``peers`` (role -> address of that process)."""

    def __init__(self, h: float, plant_columns=PLANT_COLUMNS, controller_columns=CONTROLLER_COLUMNS):
        self.h = h
        self.plant_columns, self.controller_columns = tuple(plant_columns), tuple(controller_columns)
        self.acks: dict[int, asyncio.Future] = {}
        self.next_id = 1
        self.udp = None
        self.reset()

    def reset(self) -> None:
        """Forget what came before (a new session: new processes, step 0 again)."""
        self.traces = Traces(self.h, plant_columns=self.plant_columns, controller_columns=self.controller_columns)
        self.counters = {**dict.fromkeys(PLANT_COUNTERS, 0), "telemetry_lost_steps": 0}
        self.peers: dict[str, tuple] = {}

    async def open(self, port: int = 0) -> None:
        loop = asyncio.get_running_loop()
        self.udp, _ = await loop.create_datagram_endpoint(lambda: _Protocol(self), local_addr=("127.0.0.1", port))
        self.udp.get_extra_info("socket").setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)

    @property
    def address(self) -> str:
        """HOST:PORT to give the plant and the controller (``--panel``)."""
        return f"127.0.0.1:{self.udp.get_extra_info('sockname')[1]}"

    def on_datagram(self, data: bytes, addr) -> None:
        if data[:4] == b"HHTM":
            b = parse_batch(data)
            if b is None:
                return
            role, k0, counters, ncols, nrows, payload = b
            rows = np.frombuffer(payload, dtype="<f8").reshape(nrows, ncols)
            if role == ROLE_PLANT and ncols == len(self.plant_columns):
                self.peers.setdefault("plant", addr)
                self.traces.add_plant(k0, rows)
                self.counters = {**dict(zip(PLANT_COUNTERS, counters)), "telemetry_lost_steps": self.traces.lost}
            elif role == ROLE_CONTROLLER and ncols == len(self.controller_columns) and ncols:
                self.peers.setdefault("controller", addr)
                self.traces.add_controller(k0, rows)
            return
        try:
            msg = json.loads(data)
        except ValueError:
            return
        if "hello" in msg:
            self.peers[msg["hello"]] = addr
        elif "ack" in msg:
            fut = self.acks.pop(int(msg["ack"]), None)
            if fut is not None and not fut.done():
                fut.set_result(msg)

    async def send(self, role: str, msg: dict) -> dict:
        """Send a steering message to ``role``'s process, resent until answered (at most ACK_TIMEOUT_S);
        returns the answer ({"k": step applied, ...} or {"error": ...})."""
        addr = self.peers.get(role)
        if addr is None:
            raise InputError(f"no {role} process is connected to the panel", source="panel")
        mid = self.next_id
        self.next_id += 1
        msg = {**msg, "id": mid}
        fut = asyncio.get_running_loop().create_future()
        self.acks[mid] = fut
        data = json.dumps(msg).encode()
        end = time.monotonic() + ACK_TIMEOUT_S
        while time.monotonic() < end:
            self.udp.sendto(data, addr)
            try:
                return await asyncio.wait_for(asyncio.shield(fut), 0.5)
            except asyncio.TimeoutError:
                continue
        self.acks.pop(mid, None)
        raise HydrohilError(f"the {role} did not answer within {ACK_TIMEOUT_S:g} s")

    def close(self) -> None:
        if self.udp is not None:
            self.udp.close()
