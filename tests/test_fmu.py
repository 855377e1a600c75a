"""`hydrohil export fmu`: the FMU validates with FMPy, reproduces `hydrohil simulate` of Fig 11 and Fig 12
when stepped from Python with the paper's P controller, runs as independent instances, round-trips its
state and refuses bad parameters with a status and a message."""

from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")   # a test dependency ([test] extra): always there in CI
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from hydrohil.control import p_control  # noqa: E402
from hydrohil.export.fmu import export_fmu  # noqa: E402
from hydrohil.models.layout import SLOTS, pack  # noqa: E402
from hydrohil.parameters import load_parameters  # noqa: E402
from hydrohil.simulation.run import run_scenario  # noqa: E402
from hydrohil.simulation.scenario import load_scenario  # noqa: E402

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
FMI = (2, 3)


class Fmu:
    """One instance of an exported FMU, FMI 2 or 3, through FMPy's slave classes."""

    def __init__(self, path, unzipped, name="plant", log=None):
        md = read_model_description(path)
        self.fmi = 3 if md.fmiVersion.startswith("3") else 2
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        if self.fmi == 2:
            from fmpy.fmi2 import FMU2Slave
            self.s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier="hydrohil_plant",
                               instanceName=name)
            if log:
                from ctypes import byref
                from fmpy import calloc, free
                from fmpy import fmi2
                from fmpy.logging import addLoggerProxy      # formats the FMU's printf-style message
                self.cb = fmi2.fmi2CallbackFunctions()
                self.cb.logger = fmi2.fmi2CallbackLoggerTYPE(lambda env, inst, status, cat, msg: log(msg))
                self.cb.allocateMemory = fmi2.fmi2CallbackAllocateMemoryTYPE(calloc)
                self.cb.freeMemory = fmi2.fmi2CallbackFreeMemoryTYPE(free)
                addLoggerProxy(byref(self.cb))
                self.s.instantiate(loggingOn=True, callbacks=self.cb)
            else:
                self.s.instantiate()
            self.s.setupExperiment(startTime=0.0)
        else:
            from fmpy.fmi3 import FMU3Slave
            self.s = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier="hydrohil_plant",
                               instanceName=name)
            if log:
                self.s.instantiate(loggingOn=True, logMessage=lambda env, status, cat, msg: log(msg))
            else:
                self.s.instantiate()

    def set(self, **values):
        vrs, vals = [self.vr[k] for k in values], [float(v) for v in values.values()]
        (self.s.setReal if self.fmi == 2 else self.s.setFloat64)(vrs, vals)

    def real(self, *names):
        return (self.s.getReal if self.fmi == 2 else self.s.getFloat64)([self.vr[n] for n in names])

    def integer(self, *names):
        return (self.s.getInteger if self.fmi == 2 else self.s.getInt32)([self.vr[n] for n in names])

    def init(self, **values):
        self.s.enterInitializationMode()
        self.set(**values)
        self.s.exitInitializationMode()

    def step(self, t, h):
        self.s.doStep(currentCommunicationPoint=t, communicationStepSize=h)


@pytest.fixture(scope="module", params=FMI)
def fmu(request, tmp_path_factory):
    tmp = tmp_path_factory.mktemp(f"fmi{request.param}")
    path = export_fmu(load_parameters("ferreira2004"), tmp / "plant.fmu", fmi=request.param)
    return path, extract(path, unzipdir=tmp / "unzipped")


def test_validates_with_fmpy(fmu):
    assert validate_fmu(str(fmu[0])) == []


def _closed_loop(f: Fmu, sc, n=None):
    """The paper's P controller stepping the FMU at the scenario's step, as `hydrohil simulate` samples it."""
    s = sc.scenario
    h, n = s.solver.step, s.n_steps() if n is None else n
    res = sc.params.sensors.encoder_resolution
    ref = s.references()[0]
    values = pack(sc.params)          # the scenario's parameter set, set through the FMU's parameters
    f.init(xp0=s.initial.xp, step=h, **{slot.key: values[i] for i, slot in enumerate(SLOTS) if slot.schema})
    xp = np.empty(n + 1)
    for k in range(n + 1):
        xp[k] = f.real("xp")[0]
        if k == n:
            break
        x_meas = f.integer("encoder")[0] * res
        f.set(u=p_control(s.controller.kp, ref[k], x_meas))
        f.step(k * h, h)
    return xp


@pytest.mark.parametrize("name", ["fig11_p_control.toml", "fig12_steps_ramps.toml"])
def test_reproduces_simulate(fmu, name, tmp_path):
    sc = load_scenario(EXAMPLES / name)
    offline = run_scenario(sc).column("xp")
    xp = _closed_loop(Fmu(*fmu), sc)
    every = sc.scenario.solver.output_every
    assert np.max(np.abs(xp[::every] - offline)) <= 1e-9        # measured: 0 (the same C, the same flags)


def test_two_instances_are_independent(fmu):
    a, b = Fmu(*fmu, name="a"), Fmu(*fmu, name="b")
    a.init(xp0=0.03)
    b.init(xp0=0.03)
    xa, xb = [], []
    for k in range(2000):        # interleaved: a's steps must not disturb b
        a.set(u=0.3)
        a.step(k * 5e-4, 5e-4)
        if k % 2 == 0:
            b.set(u=0.3)
            b.step(k // 2 * 1e-3, 1e-3)   # b at twice the communication step: 2 internal steps
            xb.append(b.real("xp")[0])
        if k % 2 == 1:
            xa.append(a.real("xp")[0])
    assert xa == xb and xa[-1] > 0.1


def test_state_round_trip(fmu):
    f = Fmu(*fmu)
    f.init(xp0=0.05)
    for k in range(400):
        f.set(u=0.5 if k < 200 else -0.4)
        f.step(k * 5e-4, 5e-4)
    state = f.s.getFMUState() if f.fmi == 3 else f.s.getFMUstate()
    first = []
    for k in range(400, 1200):
        f.set(u=0.2 * np.sin(k / 40))
        f.step(k * 5e-4, 5e-4)
        first.append(f.real("xp", "p1", "p2", "vp"))
    (f.s.setFMUState if f.fmi == 3 else f.s.setFMUstate)(state)
    again = []
    for k in range(400, 1200):
        f.set(u=0.2 * np.sin(k / 40))
        f.step(k * 5e-4, 5e-4)
        again.append(f.real("xp", "p1", "p2", "vp"))
    assert first == again


def test_bad_parameters_are_refused_with_a_message(fmu):
    from fmpy.fmi1 import FMICallException      # FMPy raises it for an fmi2Error / fmi3Error status
    messages = []

    def log(message):
        messages.append(message.decode() if isinstance(message, bytes) else str(message))

    f = Fmu(*fmu, log=log)
    f.s.enterInitializationMode()
    f.set(**{"load.mass": -3.0})
    with pytest.raises(FMICallException):
        f.s.exitInitializationMode()
    assert any("load.mass = -3" in m and "must be > 0" in m for m in messages), messages
    f2 = Fmu(*fmu, log=log)
    f2.init()
    with pytest.raises(FMICallException):
        f2.step(0.0, 3e-4)                  # not a whole multiple of the 0.5 ms internal step
    assert any("whole multiple" in m for m in messages)
    with pytest.raises(FMICallException):
        f2.set(u=1.5)
    assert any("must be in [-1, 1]" in m for m in messages)
