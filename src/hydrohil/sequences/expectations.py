"""Expectations of a test sequence (``[[expect]]``) and their evaluation on a run's logged signals.

Every expectation judges a window of the run: from ``after`` (an action's name or a time [s], default 0)
to ``until`` (same, default the end of the run). Signals are the plant log's columns at every step
(:data:`SIGNALS`): ``t u xs p1 p2 xp vp ff watchdog faults x_meas p1_meas p2_meas ps_meas`` and the derived
``x_ref`` (the reference), ``error`` (x_ref − xp), ``p_max`` (max(p1, p2)). SI units throughout.

===============  ==========================================================================================
type             passes when (keys)
===============  ==========================================================================================
bounds           ``min`` ≤ ``signal`` ≤ ``max`` over the window (either bound may be omitted); e.g. peak
                 pressure: ``signal = "p_max"``, ``max = 1.6e7``
tracking         |x_ref − xp| ≤ ``tol`` [m] from ``within`` [s] after ``after`` to ``until``
step_response    the move of the reference that starts at ``after`` (metrics.py): ``max_overshoot_pct`` [%],
                 ``max_settling_time`` [s] (to ``band``, default 2 % of the move), ``max_steady_state_error``
                 [m], ``max_rise_time`` [s]; the limits given must all hold
watchdog         at most ``max_trips`` (default 0) watchdog trips in the window; with ``safe_within`` [s]:
                 the safe state is reached (watchdog on and, for ``[hil] safe_state = "centre"``, ū = 0)
                 within that time after ``after``, e.g. a controller silence
reaction         within ``within`` [s] after ``after`` the ``signal`` (default ``u``, the valve command)
                 ``reverses`` (changes sign from its value at ``after``, beyond ``margin``), or falls
                 ``below`` / rises ``above`` a level (pressure relieved: ``signal = "p1"``, ``below = 2e6``)
predicate        a Python function ``function = "checks.py:name"`` (file relative to the sequence) called
                 with the :class:`Signals`; returns True/False or (bool, message)
===============  ==========================================================================================
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, Any, Callable, Literal, Union

import numpy as np
from pydantic import Field, model_validator

from hydrohil.parameters.schema import StrictModel

LOGGED = ("t", "u", "xs", "p1", "p2", "xp", "vp", "ff", "watchdog", "faults", "x_meas", "p1_meas", "p2_meas",
          "ps_meas")
SIGNALS = (*LOGGED, "x_ref", "error", "p_max")
UNITS = {"t": "s", "u": "-", "xs": "-", "p1": "Pa", "p2": "Pa", "xp": "m", "vp": "m/s", "ff": "N", "watchdog": "-",
         "faults": "-", "x_meas": "m", "p1_meas": "Pa", "p2_meas": "Pa", "ps_meas": "Pa", "x_ref": "m", "error": "m",
         "p_max": "Pa"}
When = Union[float, str]
DISPLAY = {"m": (1e3, "mm"), "Pa": (1e-5, "bar"), "m/s": (1e3, "mm/s"), "rad/s": (30 / np.pi, "rpm"),
           "m3/s": (6e4, "l/min")}                                            # how people read these units


def loop_units(units: dict, loop) -> dict:
    """The units of a circuit loop's signals under the rig's names (x_ref, xp, error: its measured signal's; u:
    its command's), from its run's ``units``."""
    return {**dict.fromkeys(("x_ref", "xp", "error"), units.get(loop.measure, "")), "u": units[loop.command]}


def unit_of(signal: str, units: dict | None = None) -> str:
    """A signal's SI unit: the rig's (UNITS) or, for a circuit's ``component.variable``, its run's."""
    return (units or {}).get(signal) or UNITS.get(signal, "")


def fmt(signal: str, v: float, units: dict | None = None) -> str:
    """A value of ``signal`` as people read it: 6.19 mm, 58.5 bar."""
    unit = unit_of(signal, units)
    k, shown = DISPLAY.get(unit, (1.0, unit))
    return f"{v * k:.4g} {shown}".rstrip()


def _error_text(v: float, s) -> str:
    """A tracking error: in mm for a position loop (the rig's), else in the measured signal's unit."""
    return f"{v * 1e3:.3f} mm" if unit_of("error", s.units) == "m" else fmt("error", v, s.units)


class Signals(dict):
    """The run's signals by name (numpy arrays, one value per logged step) and its actions' times."""

    def __init__(self, columns: dict[str, np.ndarray], events: dict[str, float], *, safe_state: str = "centre",
                 mode: str = "offline", units: dict[str, str] | None = None):
        super().__init__(columns)
        self.events, self.safe_state, self.mode = dict(events), safe_state, mode
        self.units = dict(units or UNITS)          # a circuit's run: its signals' SI units

    @property
    def t(self) -> np.ndarray:
        return self["t"]

    def time(self, when: When | None, default: float) -> float:
        """An action's time (its name) or a time [s]."""
        if when is None:
            return default
        return float(self.events[when]) if isinstance(when, str) else float(when)

    def mask(self, t0: float, t1: float) -> np.ndarray:
        t = self.t
        eps = 1e-9
        return (t >= t0 - eps) & (t <= t1 + eps)


@dataclass
class Outcome:
    """The verdict on one expectation: ``status`` pass / fail / error, what was measured against which limit,
    and what the report's figure shows (``plot``: signal, window, bounds, the violation)."""
    name: str
    type: str
    status: str
    message: str
    measured: float | None = None
    limit: float | None = None
    plot: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return self.status == "pass"


class _Expect(StrictModel):
    name: str | None = Field(None, min_length=1, max_length=200, description="shown in reports (default: made "
                             "from the type and keys)")
    after: When = Field(0.0, description="start of the window: an action's name or a time [s]")
    until: When | None = Field(None, description="end of the window: an action's name or a time [s] (default: "
                               "the end of the run)")

    def label(self) -> str:
        return self.name or self.describe()

    def window(self, s: Signals) -> tuple[float, float]:
        return s.time(self.after, 0.0), s.time(self.until, float(s.t[-1]))

    def describe(self) -> str:
        return self.type

    def _first_within(self, t, ok, t0: float, limit: float, plot: dict, subject: str, late: str, met: str) -> Outcome:
        """Passes when ``ok`` first holds at most ``limit`` after ``t0`` (samples at ``t``): "``subject``
        never / ``late`` N ms" when it fails, "``met`` after N ms" when it passes."""
        hit = np.nonzero(ok)[0]
        delay = float(t[hit[0]] - t0) if hit.size else None
        if delay is None or delay > limit + 1e-9:
            when = "never" if delay is None else f"{late} {delay * 1e3:.1f} ms"
            if delay is None:
                plot["deadline_label"] = f"deadline ({met}: never)"
            else:
                plot["violation"] = (t0 + delay, None)
                plot["violation_label"] = f"{met} (too late)"
            return Outcome(self.label(), self.type, "fail", f"{subject} {when} (limit {limit * 1e3:g} ms)", delay,
                           limit, plot)
        return Outcome(self.label(), self.type, "pass", f"{met} after {delay * 1e3:.1f} ms", delay, limit, plot)


def _no_loop(e) -> Outcome:
    return Outcome(e.label(), e.type, "error", "no reference to follow: the circuit scenario is an open loop (no "
                   "[controller] and [reference])")


def _signal_field(default=None):
    if default is None:
        return Field(description=f"one of: {', '.join(SIGNALS)}")
    return Field(default, description=f"one of: {', '.join(SIGNALS)}")


def _check_signal(name: str) -> None:
    """A rig signal (SIGNALS), or a circuit's ``component.variable`` (checked against its run)."""
    if name not in SIGNALS and "." not in name:
        from hydrohil.errors import unknown_name
        raise ValueError(unknown_name(name, SIGNALS, what="signal"))


def _when(v: When) -> str:
    return v if isinstance(v, str) else f"{v:g} s"


class Bounds(_Expect):
    type: Literal["bounds"]
    signal: str = _signal_field()
    min: float | None = Field(None, description="lower bound [signal's SI unit; a sequence file may write "
                              "\"<number> <unit>\"]")
    max: float | None = Field(None, description="upper bound [signal's SI unit; a sequence file may write "
                              "\"<number> <unit>\"]")

    @model_validator(mode="after")
    def _check(self):
        _check_signal(self.signal)
        if self.min is None and self.max is None:
            raise ValueError("give min, max or both")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"min ({self.min:g}) is above max ({self.max:g})")
        return self

    def describe(self):
        lo = "" if self.min is None else f"{self.min:g} ≤ "
        hi = "" if self.max is None else f" ≤ {self.max:g}"
        return f"{lo}{self.signal}{hi} [{UNITS.get(self.signal, 'SI')}]"

    def evaluate(self, s: Signals) -> Outcome:
        t0, t1 = self.window(s)
        m = s.mask(t0, t1)
        v, t = s[self.signal][m], s.t[m]
        lo = -np.inf if self.min is None else self.min
        hi = np.inf if self.max is None else self.max
        excess = np.maximum(lo - v, v - hi)          # > 0 where a bound is broken
        i = int(np.argmax(excess))
        worst = float(v[i])
        plot = {"signal": self.signal, "window": (t0, t1), "lo": self.min, "hi": self.max}
        limit = self.max if (self.max is not None and worst > self.max) or self.min is None else self.min
        if excess[i] > 0:
            bad = np.nonzero(excess > 0)[0]
            plot["violation"] = (float(t[bad[0]]), float(v[bad[0]]))
            return Outcome(self.label(), self.type, "fail", f"{self.signal} = {fmt(self.signal, worst, s.units)} at "
                           f"t = {t[i]:.4f} s (first outside at {t[bad[0]]:.4f} s, {len(bad)} samples)",
                           worst, limit, plot)
        return Outcome(self.label(), self.type, "pass", f"{self.signal} stayed within bounds (extreme "
                       f"{fmt(self.signal, worst, s.units)})", worst, limit, plot)


class Tracking(_Expect):
    type: Literal["tracking"]
    tol: float = Field(gt=0, le=1e9, description="largest |x_ref − xp| [m] (a circuit's loop: |reference − measure| "
                       "in the measured signal's SI unit)")
    within: float = Field(0.0, ge=0, le=3600, description="time after 'after' from which the error is judged [s]")

    def describe(self):
        return f"|x_ref − xp| ≤ {self.tol * 1e3:g} mm from {self.within:g} s after {_when(self.after)}"

    def evaluate(self, s: Signals) -> Outcome:
        if "error" not in s:
            return _no_loop(self)
        t0, t1 = self.window(s)
        t0 = t0 + self.within
        m = s.mask(t0, t1)
        e, t = np.abs(s["error"][m]), s.t[m]
        plot = {"signal": "error", "window": (t0, t1), "lo": -self.tol, "hi": self.tol}
        if not e.size:
            return Outcome(self.label(), self.type, "error", f"empty window [{t0:g}, {t1:g}] s", plot=plot)
        i = int(np.argmax(e))
        if e[i] > self.tol:
            bad = np.nonzero(e > self.tol)[0]
            plot["violation"] = (float(t[bad[0]]), float(s["error"][m][bad[0]]))
            return Outcome(self.label(), self.type, "fail", f"|error| = {_error_text(e[i], s)} at t = {t[i]:.4f} s "
                           f"(limit {_error_text(self.tol, s)}; first beyond at {t[bad[0]]:.4f} s)", float(e[i]),
                           self.tol, plot)
        return Outcome(self.label(), self.type, "pass", f"largest |error| {_error_text(e[i], s)}", float(e[i]),
                       self.tol, plot)


class StepResponse(_Expect):
    type: Literal["step_response"]
    max_overshoot_pct: float | None = Field(None, ge=0, le=1e4, description="[%] of the move")
    max_settling_time: float | None = Field(None, gt=0, le=3600, description="[s] from the move's start")
    max_steady_state_error: float | None = Field(None, gt=0, le=1e9, description="|e_ss| [m] (a circuit's loop: the "
                                                 "measured signal's SI unit)")
    max_rise_time: float | None = Field(None, gt=0, le=3600, description="10-90 % [s]")
    band: float = Field(0.02, gt=0, lt=1, description="settling band, a fraction of the move [-]")

    @model_validator(mode="after")
    def _check(self):
        if all(v is None for v in (self.max_overshoot_pct, self.max_settling_time, self.max_steady_state_error,
                                   self.max_rise_time)):
            raise ValueError("give at least one of max_overshoot_pct, max_settling_time, max_steady_state_error, "
                             "max_rise_time")
        return self

    def describe(self):
        return f"step response of the move at {_when(self.after)}"

    def evaluate(self, s: Signals) -> Outcome:
        from hydrohil.metrics import step_metrics
        if "x_ref" not in s:
            return _no_loop(self)
        t0, t1 = self.window(s)
        m = step_metrics(s.t, s["xp"], s["x_ref"], band=self.band)
        move = next((mv for mv in m["moves"] if t0 - 0.01 <= mv["start"] < t1), None)
        plot = {"signal": "xp", "window": (t0, t1), "ref": True}
        if move is None:
            return Outcome(self.label(), self.type, "error", f"no move of the reference starts in "
                           f"[{t0:g}, {t1:g}] s", plot=plot)
        e_unit, e_k = ("mm", 1e3) if unit_of("error", s.units) == "m" else (unit_of("error", s.units), 1.0)
        checks = (("overshoot", move["overshoot_pct"], self.max_overshoot_pct, "%", 1.0),
                  ("settling time", move["settling_time"], self.max_settling_time, "s", 1.0),
                  ("steady-state error", None if move["steady_state_error"] is None else abs(move["steady_state_error"]),
                   self.max_steady_state_error, e_unit, e_k),
                  ("rise time", move["rise_time"], self.max_rise_time, "s", 1.0))
        broken, said = [], []
        for label, v, lim, unit, k in checks:
            if lim is None:
                continue
            if v is None or v > lim:
                broken.append((label, v, lim))
                said.append(f"{label} {'never reached' if v is None else f'{v * k:.4g} {unit}'} > {lim * k:g} {unit}")
            else:
                said.append(f"{label} {v * k:.4g} {unit} ≤ {lim * k:g} {unit}")
        plot["window"] = (move["start"], move["hold"][1])
        plot["band"] = (move["to"] - move["band"], move["to"] + move["band"])
        if self.max_settling_time is not None:
            plot["deadline"] = move["start"] + self.max_settling_time
        if broken:
            label, v, lim = broken[0]
            if move["settling_time"] is not None:
                plot["violation"] = (move["start"] + move["settling_time"], None)
                plot["violation_label"] = "settled in the band"
            if self.max_settling_time is not None:
                plot["deadline_label"] = "settling deadline"
            return Outcome(self.label(), self.type, "fail", "; ".join(said), v, lim, plot)
        return Outcome(self.label(), self.type, "pass", "; ".join(said), None, None, plot)


class Watchdog(_Expect):
    type: Literal["watchdog"]
    max_trips: int = Field(0, ge=0, le=10**6, description="watchdog trips allowed in the window")
    safe_within: float | None = Field(None, gt=0, le=60, description="the safe state is reached this long after "
                                      "'after' at the latest [s]")

    def describe(self):
        if self.safe_within is not None:
            return f"safe state within {self.safe_within * 1e3:g} ms after {_when(self.after)}"
        return f"at most {self.max_trips} watchdog trips" if self.max_trips else "no watchdog trip"

    def evaluate(self, s: Signals) -> Outcome:
        t0, t1 = self.window(s)
        if "watchdog" not in s:
            return Outcome(self.label(), self.type, "error", "no watchdog in this run (a circuit's offline loop has "
                           "none: run it in lock-step or real time)")
        m = s.mask(t0, t1)
        on = s["watchdog"] != 0
        rise = np.zeros_like(on)
        rise[1:] = on[1:] & ~on[:-1]                    # a trip: the watchdog switches on
        rises = np.nonzero(rise & m)[0]
        trips = len(rises)
        plot = {"signal": "watchdog", "window": (t0, t1), "also": "u" if "u" in s else None}
        if self.safe_within is None:
            if trips > self.max_trips:
                plot["violation"] = (float(s.t[rises[0]]), 1.0)
                return Outcome(self.label(), self.type, "fail", f"{trips} watchdog trip(s) (first at "
                               f"t = {plot['violation'][0]:.4f} s), at most {self.max_trips} allowed", trips,
                               self.max_trips, plot)
            return Outcome(self.label(), self.type, "pass", f"{trips} watchdog trip(s)", trips, self.max_trips, plot)
        w, t = on[m], s.t[m]
        # the safe state: the valve centred (a circuit's loop command at 0, its "u"; an open loop: the watchdog on)
        safe = w & ((np.abs(s["u"][m]) <= 1e-12) if s.safe_state == "centre" and "u" in s else True)
        plot["window"] = (t0, t0 + self.safe_within)
        plot["view"] = (max(0.0, t0 - 0.05), min(t1, t0 + 4 * self.safe_within + 0.05))
        plot["deadline"] = t0 + self.safe_within
        return self._first_within(t, safe, t0, self.safe_within, plot, "safe state reached", "after", "safe state")


class Reaction(_Expect):
    type: Literal["reaction"]
    within: float = Field(gt=0, le=3600, description="the reaction must come within this time [s]")
    signal: str = _signal_field("u")
    reverses: bool = Field(False, description="the signal changes sign from its value at 'after'")
    margin: float = Field(0.0, ge=0, description="… by more than this [signal's unit]")
    below: float | None = Field(None, description="the signal falls below this level [signal's unit]")
    above: float | None = Field(None, description="the signal rises above this level [signal's unit]")

    @model_validator(mode="after")
    def _check(self):
        _check_signal(self.signal)
        if (self.reverses, self.below is not None, self.above is not None).count(True) != 1:
            raise ValueError("give exactly one of reverses = true, below, above")
        return self

    def describe(self):
        what = ("reverses" if self.reverses else f"< {self.below:g}" if self.below is not None else f"> {self.above:g}")
        return f"{self.signal} {what} within {self.within * 1e3:g} ms after {_when(self.after)}"

    def evaluate(self, s: Signals) -> Outcome:
        t0 = s.time(self.after, 0.0)
        m = s.mask(t0, float(s.t[-1]))
        v, t = s[self.signal][m], s.t[m]
        plot = {"signal": self.signal, "window": (t0, t0 + self.within), "deadline": t0 + self.within,
                "view": (max(0.0, t0 - 0.1), min(float(s.t[-1]), t0 + 3 * self.within + 0.1))}
        if self.reverses:
            sign = np.sign(v[0]) if v.size else 0.0
            if sign == 0:
                return Outcome(self.label(), self.type, "error", f"{self.signal} is 0 at {_when(self.after)}: "
                               "nothing to reverse", plot=plot)
            ok = sign * v < -self.margin
            plot["level"] = -sign * self.margin
        else:
            ok = v < self.below if self.below is not None else v > self.above
            plot["level"] = self.above if self.above is not None else self.below
        return self._first_within(t, ok, t0, self.within, plot, f"{self.signal} reacted", "only after",
                                  f"{self.signal} reacted")


class Predicate(_Expect):
    type: Literal["predicate"]
    function: str = Field(pattern=r"^.+:[A-Za-z_][A-Za-z0-9_.]*$", description="FILE.py:NAME (relative to the "
                          "sequence file) or module:name")

    def describe(self):
        return f"predicate {self.function}"

    def evaluate(self, s: Signals, func: Callable | None = None) -> Outcome:
        try:
            r = func(s)
        except Exception as exc:        # the user's code: its error is this expectation's error, not a crash
            return Outcome(self.label(), self.type, "error", f"{self.function} raised {type(exc).__name__}: {exc}")
        ok, msg = (r if isinstance(r, tuple) else (r, ""))
        return Outcome(self.label(), self.type, "pass" if ok else "fail", msg or ("holds" if ok else "does not hold"))


Expectation = Annotated[Union[Bounds, Tracking, StepResponse, Watchdog, Reaction, Predicate],
                        Field(discriminator="type")]


def evaluate(expectations: list, s: Signals, predicates: dict[int, Callable] | None = None) -> list[Outcome]:
    """Every expectation's outcome on the signals ``s``."""
    out = []
    for i, e in enumerate(expectations):
        if isinstance(e, Predicate):
            out.append(e.evaluate(s, (predicates or {}).get(i)))
        else:
            out.append(e.evaluate(s))
    return out


def signals_from_columns(cols: dict[str, Any], x_ref: np.ndarray, events: dict[str, float], **kw) -> Signals:
    """:class:`Signals` from a log's columns (offline result or plant_log.csv) and the reference at its times."""
    sig = {}
    for c in LOGGED:
        if c in cols:
            sig[c] = np.asarray(cols[c], dtype=float)
    n = len(sig["t"])
    sig["x_ref"] = np.asarray(x_ref, dtype=float)[:n]
    sig["error"] = sig["x_ref"] - sig["xp"]
    sig["p_max"] = np.maximum(sig["p1"], sig["p2"])
    return Signals(sig, events, **kw)
