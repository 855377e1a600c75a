"""The report figures carry what a reader needs (issue #12 §6): three labelled mode strips, a verdict banner,
the jitter on a log axis with p50/p99, the watchdog and the HIL − offline difference on axes of their own."""

import numpy as np
import pytest

import hydrohil.plotting as plotting
from hydrohil.models.layout import FRICTION_NAMES, SPOOL_NAMES, TRAVEL_NAMES
from hydrohil.simulation.scenario import load_scenario
from hydrohil.simulation.run import run_scenario
from conftest import EXAMPLES


@pytest.fixture
def figures(monkeypatch):
    """The figures the plotting functions close (kept open for inspection)."""
    kept, close = [], plotting.plt.close
    monkeypatch.setattr(plotting.plt, "close", kept.append)
    yield kept
    for f in kept:
        close(f)


def _texts(fig) -> list[str]:
    out = [t.get_text() for t in fig.texts]
    for a in fig.axes:
        out += [t.get_text() for t in a.texts] + [a.get_ylabel(), a.get_title()]
        if a.get_legend():
            out += [t.get_text() for t in a.get_legend().get_texts()]
    return out


def _axis(fig, ylabel):
    return next(a for a in fig.axes if a.get_ylabel() == ylabel)


@pytest.fixture(scope="module")
def offline():
    return run_scenario(load_scenario(EXAMPLES / "fig11_p_control.toml", duration=1.0))


def _hil_log(offline, jitter, watchdog):
    """A plant log as ``hydrohil hil`` reads it back: mode columns as names."""
    n = len(offline.log)
    names = lambda col, table: np.array([table[int(c)] for c in offline.column(col)])  # noqa: E731
    return {"t": offline.column("t"), "xp": offline.column("xp") + 1e-4, "p1": offline.column("p1"),
            "p2": offline.column("p2"), "jitter_us": np.resize(jitter, n), "watchdog": np.resize(watchdog, n),
            "travel_mode": names("travel_mode", TRAVEL_NAMES), "friction_mode": names("friction_mode", FRICTION_NAMES),
            "spool_mode": names("spool_mode", SPOOL_NAMES), "faults": np.zeros(n)}


def test_plot_run_has_three_labelled_mode_strips(tmp_path, figures, offline):
    c = offline.column
    plotting.plot_run(tmp_path / "s.png", c("t"), c("xp"), c("p1"), c("p2"), c("u"), c("xs"), c("travel_mode"),
                      c("friction_mode"), c("spool_mode"), title="t")
    assert (tmp_path / "s.png").stat().st_size > 10000
    fig, = figures
    texts = _texts(fig)
    for strip in ("travel", "friction", "spool"):
        assert strip in [a.get_ylabel() for a in fig.axes]
    for _, names, shown, _ in plotting.MODE_STRIPS:     # every state named as a person reads it, not its code
        assert len(shown) == len(names)
        for name in shown:
            assert any(t.startswith(name) for t in texts), name
    assert not any(t.startswith(code) for t in texts for code in ("at_retract_stop", "slip_pos", "acc_limited"))


@pytest.mark.parametrize("verdict, banner, jitter", [
    ({"valid": True, "reasons": []}, "VALID real-time run", [2.0, 3.0, 2.5, 40.0]),
    ({"valid": True, "reasons": []}, "VALID lock-step run", [0.0]),
    ({"valid": False, "reasons": ["3 overruns", "watchdog tripped"]}, "INVALID: 3 overruns; watchdog tripped",
     [2.0, 3.0, 2.5, 40.0]),
    (None, None, [2.0]),
])
def test_plot_hil_verdict_banner(tmp_path, figures, offline, verdict, banner, jitter):
    hil = _hil_log(offline, jitter, [0])
    plotting.plot_hil(tmp_path / "r.png", hil, offline, offline.column("t") * 0 + 0.03, title="x", verdict=verdict)
    fig, = figures
    texts = _texts(fig)
    if banner:
        assert banner in texts
    else:
        assert not any(t.startswith(("VALID", "INVALID")) for t in texts)


def test_plot_hil_jitter_log_watchdog_and_difference_apart(tmp_path, figures, offline):
    jitter = np.r_[np.full(97, 2.0), 30.0, 30.0, 800.0]
    watchdog = np.zeros(len(offline.log))
    watchdog[100:300] = 1
    plotting.plot_hil(tmp_path / "r.png", _hil_log(offline, jitter, watchdog), offline,
                      offline.column("t") * 0 + 0.03)
    fig, = figures
    jit = _axis(fig, "jitter [µs]")
    assert jit.get_yscale() == "log"
    labels = [t.get_text() for t in jit.get_legend().get_texts()]
    assert any(t.startswith("p50 = 2 µs") for t in labels) and any(t.startswith("p99 = ") for t in labels)
    assert not any("watchdog" in t for t in labels)                  # the watchdog has its own strip
    assert any("active" in t for t in _texts(fig) if t) and _axis(fig, "watchdog") is not jit
    track, diff = _axis(fig, "error\nx_ref − xp [mm]"), _axis(fig, "HIL − offline\n[mm]")
    assert track is not diff
    assert diff.get_ylim()[1] < 1.0                                  # 0.1 mm, not drowned by the tracking error


def test_step_metrics_stand_above_the_curves(tmp_path, figures):
    """Issue #25 §5: the moves' figures were a 6.5 pt box inside the position axis, over the Fig 11 down-ramp;
    they are the axis' left title now (outside the data, 8 pt)."""
    from hydrohil.metrics import metrics_lines, step_metrics
    full = run_scenario(load_scenario(EXAMPLES / "fig11_p_control.toml"))
    c = full.column
    ref = load_scenario(EXAMPLES / "fig11_p_control.toml").scenario.reference.sample(c("t"))[0]
    m = step_metrics(c("t"), c("xp"), ref)
    plotting.plot_run(tmp_path / "m.png", c("t"), c("xp"), c("p1"), c("p2"), c("u"), c("xs"), c("travel_mode"),
                      c("friction_mode"), c("spool_mode"), xref=ref, metrics=m)
    fig, = figures
    pos = _axis(fig, "position [mm]")
    title = pos.get_title(loc="left")
    assert title == "\n".join(metrics_lines(m)) and len(m["moves"]) == 2
    assert pos._left_title.get_fontsize() >= 8
    legends = [a for a in pos.get_children() if a.__class__.__name__ == "Legend"]
    assert not any("rise" in t.get_text() for lg in legends for t in lg.get_texts())   # no box over the data
