"""The two HIL processes' command lines, ``plant`` and ``controller``: the options of
:func:`hydrohil.hil.plant.serve_plant` and :func:`hydrohil.hil.controller.run_controller`, one definition
for ``hydrohil plant`` / ``hydrohil controller`` (:mod:`hydrohil.cli`) and for ``python -m hydrohil.hil plant``
/ ``... controller``, which is how the library starts them (:func:`hydrohil.hil.processes.process_command`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from hydrohil.errors import HydrohilError
from hydrohil.terminal import fail

process_app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,
                          help="The HIL plant and controller processes (python -m hydrohil.hil).")


@process_app.command("plant")
def plant_cmd(params: str = typer.Option("ferreira2004", help="parameter set (name or path)"),
              bind: str = typer.Option("127.0.0.1:47000", help="HOST:PORT to listen on (port 0: any free port)"),
              step: float = typer.Option(5e-4, help="plant step [s]"),
              duration: Optional[float] = typer.Option(None, help="simulated time to serve [s] (default: the "
                                                       "scenario's, else 10; 0: until stopped)"),
              log: Optional[Path] = typer.Option(None, help="folder for plant_log.csv and timing.json"),
              lockstep: bool = typer.Option(False, help="advance one step per command, as fast as possible"),
              scenario: Optional[Path] = typer.Option(None, help="take params/step/duration/initial/[hil] from it "
                                                      "(a scenario naming its circuit: serve that circuit)"),
              allow_remote: bool = typer.Option(False, help="allow binding a non-loopback address"),
              cpu: Optional[int] = typer.Option(None, help="pin the plant to this CPU"),
              peer: Optional[str] = typer.Option(None, help="accept commands only from this HOST:PORT "
                                                 "(default: the first valid sender)"),
              connect_timeout: Optional[float] = typer.Option(None, help="wait this long for the controller's "
                                                              "first packet [s] (default: [hil] connect_timeout, 30)"),
              panel: Optional[str] = typer.Option(None, help="HOST:PORT of a live panel: telemetry to it, steering "
                                                  "from it (loopback)"),
              rows: bool = typer.Option(True, help="write plant_log.csv of the whole run (--no-rows: a panel "
                                        "session, recordings only)")):
    """Serve the virtual rig, or a scenario's circuit, over UDP (protocol: docs/protocol.md), locked to the wall
    clock.

    Ends with the run's verdict (VALID / INVALID and why) on stdout; exit 3 when INVALID, 4 when no
    controller spoke, 130/143 when stopped by SIGINT/SIGTERM (logs and timing.json are written in every case).
    """
    from hydrohil.circuits.scenario import is_circuit_scenario
    from hydrohil.hil.plant import serve_plant
    from hydrohil.hil.verdict import raise_for_outcome, summary_line
    try:
        if scenario is not None and is_circuit_scenario(scenario):      # any circuit (hil/circuit.py)
            from hydrohil.hil.circuit import serve_circuit_plant
            t = serve_circuit_plant(scenario, bind, duration, log, lockstep, allow_remote, cpu, peer, connect_timeout,
                                    panel=panel, rows=rows)
        else:
            t = serve_plant(params, bind, step, duration, log, lockstep, scenario, allow_remote, cpu, peer,
                            connect_timeout, panel=panel, rows=rows)
        typer.echo(json.dumps(t), err=True)
        typer.echo(f"verdict: {summary_line(t)}", err=False)
        raise_for_outcome(t, "plant run")
    except HydrohilError as exc:
        fail(exc)


@process_app.command("controller")
def controller_cmd(connect: str = typer.Option("127.0.0.1:47000", help="plant HOST:PORT"),
                   scenario: Optional[Path] = typer.Option(None, help="take Kp, reference and [hil] from it (a "
                                                           "circuit scenario: its loop and drives)"),
                   kp: float = typer.Option(50.0, help="P gain [1/m] on ū"),
                   reference: str = typer.Option("0:0.03,0.5:0.03,1.5:0.15,3:0.15,4:0.03,6:0.03",
                                                 help="trajectory t:x pairs [s:m], linear between points "
                                                 "(repeat a time for a step)"),
                   mode: str = typer.Option("packet", help="packet (answer each sensor packet) | clock"),
                   log: Optional[Path] = typer.Option(None, help="folder for controller_log.csv"),
                   local: Optional[str] = typer.Option(None, help="bind to this local HOST:PORT (the plant's "
                                                       "--peer)"),
                   link_timeout: Optional[float] = typer.Option(None, help="give up when the plant does not "
                                                                "answer for this long [s] (default 5)"),
                   panel: Optional[str] = typer.Option(None, help="HOST:PORT of a live panel: telemetry to it, "
                                                       "gains and reference from it (loopback)")):
    """Run the reference P position controller against a plant server.

    Exit 4 when no plant answers within the link timeout (or it goes silent), 130/143 when stopped by
    SIGINT/SIGTERM; with --log DIR, controller_log.csv and controller.json are written there in every case.
    """
    from hydrohil.errors import Interrupted
    from hydrohil.hil.controller import run_controller
    try:
        s = run_controller(connect, scenario, kp, reference, log, mode, local=local, link_timeout=link_timeout,
                           panel=panel)
        typer.echo(json.dumps(s), err=True)
        if s.get("stop_signal"):
            raise Interrupted(s["stop_signal"], f"controller stopped by signal after {s.get('commands_sent')} "
                              "commands")
    except HydrohilError as exc:
        fail(exc)
