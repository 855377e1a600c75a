"""pytest plugin (entry point ``hydrohil``): the ``rig`` fixture for HIL tests written in pytest.

::

    def test_p_controller_rides_out_a_supply_drop(rig):
        run = rig.run("fig11_p_control", actions=[{"at": 2.0, "until": 2.5, "type": "supply_pressure", "ps": 4e6}])
        run.check({"type": "tracking", "after": 2.5, "within": 0.5, "tol": 1e-3})    # AssertionError if not met
        assert run.metrics()["rms_error"] < 0.01
        assert run.signals["p_max"].max() < 7e6

``rig.run`` builds a test sequence (:mod:`hydrohil.sequences.sequence`) from its arguments and runs it
offline (default), in lock-step or in real time (``mode=``, or ``pytest --hydrohil-mode lockstep`` for every
run that does not name one) with the scenario's controller, a Python callable or an external program.
A real-time run that is INVALID fails the test with the timing verdict's reasons.
"""

from __future__ import annotations

from pathlib import Path

import pytest


def pytest_addoption(parser):
    group = parser.getgroup("hydrohil")
    group.addoption("--hydrohil-mode", default="offline", choices=("offline", "lockstep", "realtime"),
                    help="hydrohil rig fixture: run mode of runs that do not name one (default offline)")


class RigRun:
    """A finished run: ``signals`` (name -> array, :mod:`hydrohil.sequences.expectations`), ``result``
    (:class:`~hydrohil.sequences.runner.SequenceResult`), expectations judged by :meth:`check`."""

    def __init__(self, result):
        self.result = result
        self.signals = result.signals
        self.out = result.out

    def metrics(self) -> dict:
        """Step-response metrics of the run (:func:`hydrohil.metrics.step_metrics`)."""
        from hydrohil.metrics import step_metrics
        s = self.signals
        return step_metrics(s.t, s["xp"], s["x_ref"], s["p1"], s["p2"])

    def expect(self, expectation: dict):
        """The :class:`~hydrohil.sequences.expectations.Outcome` of one ``[[expect]]`` table on this run."""
        from pydantic import TypeAdapter

        from hydrohil.sequences.expectations import Expectation
        e = TypeAdapter(Expectation).validate_python(expectation)
        return e.evaluate(self.signals)

    def check(self, expectation: dict):
        """Assert one expectation (AssertionError with what was measured)."""
        o = self.expect(expectation)
        assert o.passed, f"{o.name}: {o.message}"
        return o

    def assert_passed(self):
        """Every expectation given to ``rig.run`` passed (AssertionError listing the others)."""
        r = self.result
        bad = [f"{o.name}: {o.status}: {o.message}" for o in r.outcomes if not o.passed]
        assert r.status == "pass", f"{r.name} ({r.mode}): {r.error or ''} " + "; ".join(bad)


class Rig:
    """The ``rig`` fixture: run scenarios with actions, faults and expectations in a test's tmp folder."""

    def __init__(self, folder: Path, mode: str):
        self.folder, self.default_mode, self.runs = Path(folder), mode, 0

    def run(self, scenario: str | Path = "fig11_p_control", *, actions=(), expect=(), mode: str | None = None,
            controller=None, duration: float | None = None, set: dict | None = None,
            controller_table: dict | None = None, hil: dict | None = None, check_timing: bool = True) -> RigRun:
        """Run ``scenario`` (a path, or a built-in experiment name) with ``actions`` ([[actions]] tables) and
        ``expect`` ([[expect]] tables). ``controller``: a Python callable (offline) or an external program's
        command line; ``controller_table`` replaces the scenario's [controller]. An INVALID real-time run
        fails the test (``check_timing=False``: returned, its ``result.verdict`` to inspect)."""
        import tomli_w

        from hydrohil.sequences.runner import run_sequence
        from hydrohil.sequences.sequence import load_sequence
        from hydrohil.simulation.scenario import resolve_scenario
        self.runs += 1
        d = self.folder / f"run{self.runs}"
        d.mkdir(parents=True, exist_ok=True)
        data = {"name": f"{Path(str(scenario)).stem} run {self.runs}",
                "scenario": str(Path(resolve_scenario(scenario, Path.cwd())).resolve()),
                "actions": [dict(a) for a in actions], "expect": [dict(e) for e in expect]}
        for key, v in (("duration", duration), ("set", set), ("controller", controller_table), ("hil", hil)):
            if v is not None:
                data[key] = v
        path = d / "sequence.toml"
        path.write_text(tomli_w.dumps(data))
        result = run_sequence(load_sequence(path, allow_empty=True), d, mode=mode or self.default_mode,
                              controller=controller)
        if result.signals is None or (result.error and (check_timing or result.verdict is None)):
            pytest.fail(f"hydrohil run failed ({result.mode}): {result.error}", pytrace=False)
        return RigRun(result)


@pytest.fixture
def rig(tmp_path, request) -> Rig:
    """Runs the virtual rig offline, in lock-step or in real time: ``rig.run(scenario, actions=, expect=)``."""
    return Rig(tmp_path / "hydrohil", request.config.getoption("hydrohil_mode"))
