"""What every hydrohil process prints on a terminal: an error as one line with its exit code, input warnings
as one ``warning: ...`` line, and SIGINT/SIGTERM as an interruption the running command can clean up after.
Used by the command line (:mod:`hydrohil.cli`) and by the plant and controller processes
(:mod:`hydrohil.hil.commands`)."""

from __future__ import annotations

import warnings

import typer

from hydrohil.errors import HydrohilError, InputWarning


def fail(exc: HydrohilError):
    """Print ``error: ...`` on stderr and exit with the error's code (2 bad input, 1 runtime, ...)."""
    typer.echo(f"error: {exc}", err=True)
    raise typer.Exit(exc.exit_code)


def interruptible() -> None:
    """SIGINT (Ctrl-C) and SIGTERM raise KeyboardInterrupt (with the signal's number as ``signum``), also when
    the process was started with SIGINT ignored (a background job of a non-interactive shell inherits that):
    the commands that run a plant and a controller must stop both cleanly, and exit 130 / 143."""
    import signal

    def _raise(signum, frame):
        exc = KeyboardInterrupt()
        exc.signum = signum
        raise exc
    signal.signal(signal.SIGINT, _raise)
    signal.signal(signal.SIGTERM, _raise)


_python_showwarning = warnings.showwarning


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Input warnings as one ``warning: ...`` line on stderr (no source location); others as Python's."""
    if issubclass(category, InputWarning):
        typer.echo(f"warning: {message}", err=True)
    else:
        _python_showwarning(message, category, filename, lineno, file, line)


def show_warnings_as_lines() -> None:
    """Print warnings from here on as :func:`_show_warning` does (a process's first call)."""
    warnings.showwarning = _show_warning
