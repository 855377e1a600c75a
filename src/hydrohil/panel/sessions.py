"""The panel's sessions (``hydrohil panel``): the plant and controller processes of each, started, watched
and stopped here, and the recordings made during a session (the plant writes them; their scenario, events,
replay check and report are completed here, in worker threads, by :mod:`hydrohil.panel.recording`)."""

from __future__ import annotations

import asyncio
import json
import os
from pathlib import Path

from hydrohil.errors import HydrohilError, InputError


class SessionSupervisor:
    """The session under way (``folder``, ``running``, ``children``), the folders of this panel's sessions
    (``folders``), how the last one ended (``ended``), and its recordings. ``panel``: the
    :class:`~hydrohil.panel.server.Panel` whose scenario, options, side channel and steering state it uses."""

    def __init__(self, panel):
        self.panel = panel
        self.folder: Path | None = None
        self.number = 0
        self.folders: list[Path] = []                # the session folders this panel made
        self.running = False
        self.stopping = False                        # a stop is under way (the watcher leaves the children alone)
        self.children: list = []
        self.ended: dict | None = None               # the last session's timing (when it ended)
        self.recording: dict | None = None          # the recording under way
        self.recordings: list[dict] = []
        self.reports: list = []                      # recordings' reports being made (awaited at a session's end)

    def tables(self) -> dict:
        """What a session changes in its scenario: it runs until stopped, so the reference repeats
        (x_ref(t mod duration)); on fewer than 4 CPUs the browser needs one, so neither process busy-waits
        unless the scenario says so (``[hil] wait``: "sleep" here by default, "spin-controller" elsewhere)."""
        pn, tables = self.panel, {}
        if pn.cs is not None:                     # a circuit: its drives and reference repeat (``repeat``)
            wait_given = "wait" in pn.cs.hil
        else:
            s = pn.sc.scenario
            if s.closed_loop and s.reference.repeat is None:
                tables["reference"] = {"repeat": s.duration}
            wait_given = "wait" in s.hil.model_fields_set
        if not wait_given and (os.cpu_count() or 1) < 4:
            tables["hil"] = {"wait": "sleep", "busy_poll": True}
        return tables

    async def start(self) -> None:
        from hydrohil.hil.processes import Child, free_udp_port, process_command
        from hydrohil.hil.run import plant_command
        from hydrohil.simulation.scenario import load_scenario, write_scenario
        pn = self.panel
        if self.running:
            raise InputError("a session is running: stop it first", source="panel")
        self.number += 1
        while (pn.out / f"session-{self.number:03d}").exists():
            self.number += 1
        folder = self.folder = pn.out / f"session-{self.number:03d}"
        folder.mkdir(parents=True)
        self.folders.append(folder)
        if pn.cs is not None:
            from hydrohil.circuits.scenario import load_circuit_scenario, write_circuit_scenario
            scenario = write_circuit_scenario(pn.scenario_path, folder / "scenario.toml", sets=pn.sets or {},
                                              repeat=True, hil=self.tables().get("hil"))
            sc = load_circuit_scenario(scenario)
        else:
            scenario = write_scenario(pn.scenario_path, folder / "scenario.toml", params=pn.params_arg,
                                      sets=pn.sets, tables=self.tables())
            sc = load_scenario(scenario)
        pn.hub.reset()
        pn.reset_steering()
        self.ended = self.recording = None
        side = pn.hub.address
        builtin = pn.controller_kind == "builtin"
        ctl_addr = f"127.0.0.1:{free_udp_port()}" if builtin else None
        bind = "127.0.0.1:0" if builtin else f"127.0.0.1:{pn.plant_port}"
        plant = Child(plant_command(sc, scenario, folder, ctl_addr, lockstep=pn.lockstep, plant=pn.plant, bind=bind,
                                    extra=("--panel", side, "--no-rows", "--duration", "0",
                                           *([] if builtin else ["--connect-timeout", "3600"]))), "plant")
        self.children = [plant]
        loop = asyncio.get_running_loop()
        address = await loop.run_in_executor(None, plant.wait_line, "READY ", 120.0)
        if builtin:
            self.children.append(Child(process_command("controller", "--scenario", scenario, "--connect", address,
                                                       "--local", ctl_addr, "--panel", side, "--log", folder),
                                       "controller"))
        self.running = True
        print(f"SESSION {folder} plant {address}", flush=True)

    async def stop(self) -> dict:
        """Stop the plant at a step boundary (it ends the controller with its final packet); wait for both."""
        if not self.running or self.stopping:
            raise InputError("no session is running", source="panel")
        self.stopping = True
        try:
            return await self._stop()
        finally:
            self.stopping = False

    async def _stop(self) -> dict:
        if self.recording is not None:
            try:
                await self.record_stop()
            except HydrohilError:
                self._recording_ended()
        try:
            await self.panel.hub.send("plant", {"op": "stop"})
        except HydrohilError:
            pass
        loop = asyncio.get_running_loop()
        for ch in self.children:
            try:
                await loop.run_in_executor(None, ch.wait, 30)
            except Exception:     # noqa: BLE001 - a stuck child is stopped, whatever went wrong
                ch.stop()
        self.running = False
        await self.finish_reports()
        return self._ended("the plant wrote no timing.json")

    def _ended(self, error: str) -> dict:
        """The ended session's timing (``error`` when the plant wrote none) with the processes' exit codes."""
        t = self.folder / "timing.json"
        self.ended = json.loads(t.read_text()) if t.is_file() else {"error": error}
        self.ended["exit_codes"] = {ch.name: ch.returncode for ch in self.children}
        return self.ended

    async def watch(self) -> None:
        """A session whose plant ended by itself (a model fault, the controller gone) is marked ended."""
        while True:
            await asyncio.sleep(0.2)
            if (self.panel.own and self.running and not self.stopping and self.children
                    and self.children[0].poll() is not None):
                for ch in self.children[1:]:
                    if ch.poll() is None:
                        ch.stop()
                self.running = False
                self._recording_ended()
                self._ended(self.children[0].stderr()[-500:])

    def stop_children(self) -> None:
        for ch in self.children:
            if ch.poll() is None:
                ch.stop()

    # -- recordings --------------------------------------------------------------------------------
    async def record_start(self) -> dict:
        if self.recording is not None:
            raise InputError("already recording", source="panel")
        if self.folder is None:
            raise InputError("no session", source="panel")
        n = len(self.recordings) + 1
        folder = self.folder / "recordings" / f"rec-{n:03d}"
        while folder.exists():
            n += 1
            folder = self.folder / "recordings" / f"rec-{n:03d}"
        ans = await self.panel.hub.send("plant", {"op": "record_start", "dir": str(folder.resolve())})
        if "error" in ans:
            raise InputError(ans["error"], source="plant")
        self.recording = {"name": folder.name, "dir": str(folder), "k0": ans["k"]}
        return self.recording

    async def record_stop(self) -> dict:
        if self.recording is None:
            raise InputError("not recording", source="panel")
        ans = await self.panel.hub.send("plant", {"op": "record_stop"})
        if "error" in ans:
            raise InputError(ans["error"], source="plant")
        rec = {**self.recording, "k1": ans["k"], "steps": ans["steps"], "verdict": ans["verdict"], "report": "pending"}
        self.recording = None
        self.recordings.append(rec)
        loop = asyncio.get_running_loop()
        self.reports.append(loop.run_in_executor(None, self._finish_recording, rec))
        return rec

    def _recording_ended(self) -> None:
        """The plant ended while recording (it closes the recording itself): list it and make its report."""
        rec, self.recording = self.recording, None
        if rec is None:
            return
        from hydrohil.simulation.outputs import read_csv_columns
        folder = Path(rec["dir"])
        try:
            k = read_csv_columns(folder / "plant_log.csv")["k"]
            timing = json.loads((folder / "timing.json").read_text())
        except (OSError, ValueError, KeyError):
            rec.update(report="failed: the plant ended before the recording was complete")
            self.recordings.append(rec)
            return
        k1 = int(k[-1]) if len(k) else rec["k0"]
        rec.update(k1=k1, steps=k1 - rec["k0"], verdict=timing["verdict"]["verdict"], report="pending")
        self.recordings.append(rec)
        self.reports.append(asyncio.get_running_loop().run_in_executor(None, self._finish_recording, rec))

    async def finish_reports(self) -> None:
        pending, self.reports = self.reports, []
        if pending:
            await asyncio.gather(*pending)

    def _finish_recording(self, rec: dict) -> None:
        """Complete a recording's folder: scenario, the events up to its end, the replay check, report.png."""
        from hydrohil.panel.recording import finish_circuit_recording, finish_recording
        finish = finish_circuit_recording if self.panel.cs is not None else finish_recording
        try:
            rec.update(finish(self.panel.sc or self.panel.cs, self.folder, Path(rec["dir"]), rec["k0"], rec["k1"]))
            rec["report"] = "done"
        except Exception as exc:       # noqa: BLE001 - shown on the page, the recording's logs stay
            rec["report"] = f"failed: {exc}"
