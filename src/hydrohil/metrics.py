"""Step-response metrics of a closed-loop run, as a control engineer reads them off the position plot.

The reference is cut into *moves*: each hold (the reference constant for at least ``min_hold`` seconds) that
starts at another value than the previous hold's (or than the initial position) ends a move that began when
the previous hold ended (a step, or a ramp). Per move, over [move start, hold end]:

- ``rise_time``: from the position's first crossing of 10 % of the move to its first crossing of 90 % [s];
- ``overshoot``: the largest excursion beyond the hold's value during the hold [m], and in % of the move;
- ``settling_time``: from the move's start until the position stays within ``band`` (a fraction of the
  move, 2 % by default, but never below ``min_band``) of the hold's value to the end of the hold [s];
- ``steady_state_error``: hold value − mean position over the last 10 % of the hold [m];
- ``via``: the reference's farthest point beyond from..to on its way (Fig 12's step back to 60 mm before its
  ramp from 100 to 140 mm), else None: the move's figures are then those of that whole way.

None where a move never gets there (e.g. it does not settle before the hold ends). Whole-run figures: RMS
and largest |error|, the largest chamber pressures, and the friction's breakaways (stick-to-slip
transitions: a smooth move has one, stick-slip hunting hundreds).
"""

from __future__ import annotations

import numpy as np

MIN_MOVE = 1e-5     # m: a change of the reference smaller than this is not a move


def holds(t: np.ndarray, x_ref: np.ndarray, min_hold: float = 0.05) -> list[tuple[int, int]]:
    """(first, last) sample indices of each run of a constant reference lasting at least ``min_hold`` s (a NaN
    sample a run of its own)."""
    t, x_ref = np.asarray(t), np.asarray(x_ref)
    if len(t) == 0:
        return []
    change = np.flatnonzero(x_ref[1:] != x_ref[:-1])          # the last sample of each run but the last run's
    first, last = np.concatenate(([0], change + 1)), np.append(change, len(t) - 1)
    kept = t[last] - t[first] >= min_hold
    return list(zip(first[kept].tolist(), last[kept].tolist()))


def _first_crossing(t, x, level, rising):
    hit = np.nonzero(x >= level if rising else x <= level)[0]
    return float(t[hit[0]]) if hit.size else None


def step_metrics(t, x, x_ref, p1=None, p2=None, *, sliding=None, band: float = 0.02, min_band: float = 2e-6,
                 min_hold: float = 0.05, spans: list[tuple[int, int]] | None = None) -> dict:
    """Metrics of the position ``x`` following ``x_ref`` (samples at times ``t``; module docstring).
    ``sliding`` (non-zero while the friction slips) adds ``breakaways``, the stick-to-slip transitions.
    ``spans``: :func:`holds` (t, x_ref, min_hold), when the caller has them."""
    t, x, x_ref = (np.asarray(a, dtype=float) for a in (t, x, x_ref))
    moves = []
    prev_end, prev_val = 0, float(x[0])
    for first, last in holds(t, x_ref, min_hold) if spans is None else spans:
        r1 = float(x_ref[first])
        amp = r1 - prev_val
        if abs(amp) >= MIN_MOVE:
            s0 = prev_end
            seg_t, seg_x = t[s0:last + 1], x[s0:last + 1]
            up = amp > 0
            t10 = _first_crossing(seg_t, seg_x, prev_val + 0.1 * amp, up)
            t90 = _first_crossing(seg_t, seg_x, prev_val + 0.9 * amp, up)
            hold_x = x[first:last + 1]
            over = float(max(0.0, np.max((hold_x - r1) if up else (r1 - hold_x))))
            tol = max(band * abs(amp), min_band)
            outside = np.nonzero(np.abs(seg_x - r1) > tol)[0]
            if outside.size and outside[-1] == len(seg_x) - 1:
                settle = None
            else:
                k = outside[-1] + 1 if outside.size else 0
                settle = float(seg_t[k] - seg_t[0])
            tail = hold_x[int(0.9 * len(hold_x)):]
            path = x_ref[s0:first + 1]             # the reference on its way: beyond from..to, it went via there
            lo, hi = min(prev_val, r1), max(prev_val, r1)
            via = float(path.min()) if path.min() < lo - MIN_MOVE else float(path.max()) if path.max() > hi + MIN_MOVE \
                else None
            moves.append({
                "start": float(t[s0]), "hold": [float(t[first]), float(t[last])], "from": prev_val, "to": r1,
                "via": via,
                "rise_time": None if t10 is None or t90 is None else t90 - t10,
                "overshoot": over, "overshoot_pct": 100.0 * over / abs(amp),
                "settling_time": settle, "band": tol,
                "steady_state_error": float(r1 - tail.mean()),
            })
        prev_end, prev_val = last, r1
    e = x_ref - x
    out = {"moves": moves, "rms_error": float(np.sqrt(np.mean(e ** 2))), "max_abs_error": float(np.abs(e).max())}
    if p1 is not None:
        out["max_p1"] = float(np.max(p1))
    if p2 is not None:
        out["max_p2"] = float(np.max(p2))
    if sliding is not None:
        s = np.asarray(sliding) != 0
        out["breakaways"] = int(np.count_nonzero(s[1:] & ~s[:-1]))
    return out


def metrics_lines(m: dict) -> list[str]:
    """One line per move (for figures and the terminal): rise, overshoot, settling, steady-state error."""
    def s(v, scale=1.0, fmt="{:.3g}"):
        return "-" if v is None else fmt.format(v * scale)
    lines = []
    for i, mv in enumerate(m["moves"], 1):
        via = f" (via {mv['via'] * 1e3:.0f})" if mv.get("via") is not None else ""
        lines.append(f"{i}: {mv['from'] * 1e3:.0f}→{mv['to'] * 1e3:.0f} mm{via}  rise {s(mv['rise_time'])} s  "
                     f"OS {mv['overshoot_pct']:.1f} %  ts({mv['band'] * 1e3:.2g} mm) {s(mv['settling_time'])} s  "
                     f"e_ss {mv['steady_state_error'] * 1e6:.1f} µm")
    return lines
