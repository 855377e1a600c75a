"""Exceptions with the context a user needs to fix the problem (file, key, expected range, state).

Exit codes of the CLI (README): 0 ok; 1 the simulation diverged (or another runtime failure); 2 bad input;
3 a real-time run finished but is INVALID (timing criteria of ``[hil]``, the verdict says why); 4 no peer
(no plant / controller answered within the timeout, or it went silent); 130 interrupted (Ctrl-C, SIGINT),
143 terminated (SIGTERM).
"""

from __future__ import annotations


class HydrohilError(Exception):
    """Base class. ``exit_code`` is what the CLI returns for it."""

    exit_code = 1


class InputError(HydrohilError):
    """Bad user input: a file, key or value that is missing, malformed or out of range (exit 2)."""

    exit_code = 2

    def __init__(self, message: str, *, source: str | None = None, key: str | None = None):
        self.source, self.key, self.message = source, key, message
        where = ": ".join(x for x in (source, key) if x)
        super().__init__(f"{where}: {message}" if where else message)


class InputWarning(UserWarning):
    """Input that loads but is probably not what the user meant (the CLI prints it as ``warning: ...``)."""


class SimulationDiverged(HydrohilError):
    """The integration produced a non-finite or unphysical state (exit 1)."""

    exit_code = 1

    def __init__(self, t: float, modes: dict[str, str], state: dict[str, float], reason: str, partial=None):
        self.t, self.modes, self.state, self.reason = t, modes, state, reason
        self.partial = partial          # the run's result up to the stop, where the runner gives it
        st = ", ".join(f"{k}={v:.6g}" for k, v in state.items())
        md = ", ".join(f"{k}={v}" for k, v in modes.items())
        super().__init__(f"simulation diverged at t = {t:.6f} s ({reason}); modes: {md}; state: {st}")


class ControllerError(HydrohilError):
    """A user's controller raised or returned a non-finite command (exit 1); the run stops there."""

    exit_code = 1


class RunInvalid(HydrohilError):
    """A real-time run finished, but its timing does not meet the validity criteria (exit 3)."""

    exit_code = 3

    def __init__(self, message: str, reasons: list[str]):
        self.reasons = list(reasons)
        super().__init__(message)


class LinkError(HydrohilError):
    """The other end of the HIL link did not answer within the timeout, or went silent (exit 4)."""

    exit_code = 4


class Interrupted(HydrohilError):
    """The run was stopped by a signal; its logs and summary were written (exit 128 + signal: 130, 143)."""

    def __init__(self, signum: int, message: str = ""):
        import signal
        self.signum = signum
        self.exit_code = 128 + int(signum)
        super().__init__(message or f"stopped by {signal.Signals(signum).name}")


def unknown_name(name: str, valid, what: str = "key", prefix: str = "") -> str:
    """Message for a name that is not one of ``valid``, with the closest valid one (difflib) when there is
    one: ``unknown key 'duraton' (did you mean 'duration'?)``, otherwise the valid names. ``prefix``
    (``supply.``) is shown before the unknown name and the suggestion but takes no part in the matching."""
    valid = [str(v) for v in valid]
    close = closest_name(name, valid)
    if close:
        return f"unknown {what} '{prefix}{name}' (did you mean '{prefix}{close}'?)"
    return f"unknown {what} '{prefix}{name}' (valid: {', '.join(valid) if valid else 'none'})"


def closest_name(name: str, valid, cutoff: float = 0.6) -> str | None:
    """The one of ``valid`` that ``name`` most likely misspells: the same but for case (``B`` for ``b``), else
    the closest by difflib's ratio (at least ``cutoff``); None when none is close."""
    import difflib
    valid = [str(v) for v in valid]
    same = [v for v in valid if v.lower() == str(name).lower()]
    if same:
        return same[0]
    close = difflib.get_close_matches(str(name), valid, n=1, cutoff=cutoff)
    return close[0] if close else None
