"""Position controllers: the scenario's ``[controller]`` table, the built-in laws of the C core and a user's
own Python controller.

Built-in types (``p``, ``pi``, ``pid``, ``p_ff``, ``state_feedback``) are one sampled law in the core
(``core/control.h`` states it with units); the same C code runs in the compiled loop of ``simulate``, in
the virtual rig's per-step loop and in the HIL controller process, so offline and lock-step HIL agree bit
for bit. ``type = "python"`` names a callable (``callable = "module:function"``, or a class: one instance
per run, built with ``options``) that is called once per sample with a :class:`Measurement` and returns ū;
the same object runs offline (``hydrohil simulate``) and against the real-time plant (``hydrohil hil``,
or your own loop with :class:`~hydrohil.hil.controller.PlantClient` and :func:`measurement`).
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import sys
from pathlib import Path
from typing import Any, Callable, Literal, NamedTuple, Union

from pydantic import Field, ValidationError, model_validator

from hydrohil.core import ffi, lib
from hydrohil.errors import ControllerError, InputError
from hydrohil.parameters import Parameters
from hydrohil.parameters.schema import StrictModel

# ---- the scenario's [controller] table --------------------------------------------------------------------


class _Limits(StrictModel):
    u_min: float = Field(-1.0, ge=-1, le=1, description="lower limit of the command [ū]")
    u_max: float = Field(1.0, ge=-1, le=1, description="upper limit of the command [ū]")

    @model_validator(mode="after")
    def _order(self):
        if not self.u_min < self.u_max:
            raise ValueError(f"u_min ({self.u_min}) must be < u_max ({self.u_max})")
        return self


_KP = dict(gt=0, le=1e5, description="proportional gain [ū/m]")
_KI = dict(gt=0, le=1e8, description="integral gain [ū/(m·s)]")
_KD = dict(ge=0, le=1e3, description="gain on the measured velocity [ū/(m/s)]")
_TF = dict(ge=1e-5, le=1.0, description="time constant of the velocity estimate's first-order filter [s]")
_AW = dict(description="integrator anti-windup: clamp (stop integrating into a limit) or back_calculation")
_TT = dict(gt=0, le=100, description="back-calculation tracking time constant [s] (default kp/ki)")


class PControllerCfg(_Limits):
    """The paper's P law (§4): ū = clamp(kp·e)."""
    type: Literal["p"]
    kp: float = Field(**_KP)


class _Integral(_Limits):
    ki: float = Field(**_KI)
    antiwindup: Literal["clamp", "back_calculation"] = Field("clamp", **_AW)
    tt: float | None = Field(None, **_TT)


class PIControllerCfg(_Integral):
    """ū = kp·e + ki·∫e dt, with anti-windup."""
    type: Literal["pi"]
    kp: float = Field(**_KP)


class PIDControllerCfg(_Integral):
    """PI + derivative on the measured position through a first-order filter: − kd·v̂."""
    type: Literal["pid"]
    kp: float = Field(**_KP)
    kd: float = Field(**_KD)
    tf: float = Field(2e-3, **_TF)


class PFFControllerCfg(_Limits):
    """P + velocity feed-forward from the reference's slope + valve-null (bias and deadband) compensation."""
    type: Literal["p_ff"]
    kp: float = Field(**_KP)
    kff: float = Field(0.0, ge=0, le=1e3, description="velocity feed-forward gain [ū/(m/s)] "
                       "(1/(valve flow gain/A) for a perfect match)")
    u_bias: float = Field(0.0, ge=-1, le=1, description="constant valve-null compensation [ū] (the "
                          "equilibrium spool offset of `hydrohil linear`)")
    u_deadband: float = Field(0.0, ge=0, le=1, description="deadband compensation added with the error's "
                              "sign [ū]")
    e_deadband: float = Field(1e-4, gt=0, le=0.1, description="error at which the deadband compensation is "
                              "complete (linear below) [m]")


class StateFeedbackControllerCfg(_Limits):
    """The hydraulic servo's state feedback: ū = kp·e − kd·v̂ − kpl·p̂L (+ ki·∫e dt)."""
    type: Literal["state_feedback"]
    kp: float = Field(**_KP)
    kd: float = Field(0.0, **_KD)
    tf: float = Field(2e-3, **_TF)
    kpl: float = Field(0.0, ge=0, le=1e-3, description="load-pressure gain on pL = p1 − (A2/A1)·p2 [ū/Pa]")
    tpl: float = Field(0.0, ge=0, le=100, description="high-pass time constant of the load pressure [s] "
                       "(0: static pressure feedback; > 0: dynamic, no steady-state error from a load)")
    ki: float = Field(0.0, ge=0, le=1e8, description="integral gain [ū/(m·s)]")
    antiwindup: Literal["clamp", "back_calculation"] = Field("clamp", **_AW)
    tt: float | None = Field(None, **_TT)


class PythonControllerCfg(StrictModel):
    """A user's controller: ``callable`` = "module:name" or "path/to/file.py:name", looked up in ``path``
    (default: the scenario file's folder, put on the import path while loading, so the module may import
    its neighbours), a function ``f(measurement) -> ū`` or a class instantiated once per run with
    ``options`` whose instances are called so."""
    type: Literal["python"]
    callable: str = Field(pattern=r"^.+:[A-Za-z_][A-Za-z0-9_.]*$", description="module:name or file.py:name")
    options: dict[str, Any] = Field(default_factory=dict, description="keyword arguments of a class")
    path: str | None = Field(None, description="folder of the module (default: the scenario's folder)")


ControllerCfg = Union[PControllerCfg, PIControllerCfg, PIDControllerCfg, PFFControllerCfg,
                      StateFeedbackControllerCfg, PythonControllerCfg]
BUILTIN_TYPES = {"p": lib.HH_CTRL_P, "pi": lib.HH_CTRL_PI, "pid": lib.HH_CTRL_PID, "p_ff": lib.HH_CTRL_P_FF,
                 "state_feedback": lib.HH_CTRL_STATE_FEEDBACK}


# ---- what a controller is given each sample --------------------------------------------------------------


class Measurement(NamedTuple):
    """One sample of a position controller's inputs (SI; pressures gauge, as the transducers report)."""
    t: float          # plant time of the reading [s]
    x_ref: float      # position reference [m]
    dx_ref: float     # its slope [m/s]
    x: float          # encoder reading [m]
    p1: float         # chamber pressures [Pa]
    p2: float
    ps: float         # supply and tank pressures [Pa]
    pt: float
    status: int       # status bits of the sensor packet (docs/protocol.md)


def measurement(sensor, x_ref: float, dx_ref: float = 0.0, count: float = 1e-6) -> Measurement:
    """A :class:`Measurement` from a sensor packet of :class:`~hydrohil.hil.controller.PlantClient` (``count``:
    the encoder's count size [m])."""
    return Measurement(sensor.t_sim, x_ref, dx_ref, sensor.encoder_counts * count, sensor.p1, sensor.p2,
                       sensor.ps, sensor.pt, sensor.status)


# ---- controllers ------------------------------------------------------------------------------------------


class BuiltinController:
    """A built-in law of the core (``hh_controller``): ``ctl(measurement) -> ū``, or :meth:`update`.

    ``h`` is the sample time [s] (the plant step: one command per sensor packet). ``limits``: the command's
    clamp (u_min, u_max) in place of the config's (a circuit's loop: its command's range), kept by a retune.
    ``area_ratio``: A2/A1 of the load pressure in place of the parameters' cylinder's (a circuit's state
    feedback: its cylinder's area_b/area_a)."""

    def __init__(self, cfg: ControllerCfg, params: Parameters | None, h: float, limits: tuple | None = None,
                 area_ratio: float | None = None):
        if cfg.type not in BUILTIN_TYPES:
            raise ValueError(f"'{cfg.type}' is not a built-in controller ({', '.join(BUILTIN_TYPES)})")
        self.h, self.params, self.limits, self.area_ratio = float(h), params, limits, area_ratio
        self.c = ffi.new("hh_controller *")
        self._load(cfg)
        self.state = ffi.new("hh_controller_state *")
        self.reset()

    def _load(self, cfg: ControllerCfg) -> None:
        self.cfg, c, params = cfg, self.c, self.params
        c.type = BUILTIN_TYPES[cfg.type]
        c.h = self.h
        c.kp = cfg.kp
        c.ki = getattr(cfg, "ki", 0.0)
        c.kd = getattr(cfg, "kd", 0.0)
        c.tf = getattr(cfg, "tf", 2e-3)
        c.antiwindup = (lib.HH_AW_BACK_CALCULATION if getattr(cfg, "antiwindup", "clamp") == "back_calculation"
                        else lib.HH_AW_CLAMP)
        tt = getattr(cfg, "tt", None)
        c.tt = tt if tt is not None else (cfg.kp / c.ki if c.ki > 0 else 1.0)
        c.kff = getattr(cfg, "kff", 0.0)
        c.u_bias = getattr(cfg, "u_bias", 0.0)
        c.u_deadband = getattr(cfg, "u_deadband", 0.0)
        c.e_deadband = getattr(cfg, "e_deadband", 1e-4)
        c.kpl = getattr(cfg, "kpl", 0.0)
        c.tpl = getattr(cfg, "tpl", 0.0)
        c.area_ratio = (self.area_ratio if self.area_ratio is not None else      # (a circuit's loop: its cylinder's)
                        params.cylinder.a2 / params.cylinder.a1 if params is not None else 0.0)
        c.u_min, c.u_max = self.limits if self.limits is not None else (cfg.u_min, cfg.u_max)

    def retune(self, **gains: float) -> None:
        """Change gains (``kp ki kd kff kpl``, units of ``[controller]``) between two samples, the law's state
        kept; checked as the scenario file is (InputError naming the gain). A tracking time derived from the
        gains (``tt`` not given) follows them."""
        bad = [g for g in gains if g not in type(self.cfg).model_fields]
        if bad:
            raise InputError(f"a '{self.cfg.type}' controller has no gain {bad[0]}", source="controller", key=bad[0])
        try:
            cfg = type(self.cfg).model_validate({**self.cfg.model_dump(), **gains})
        except ValidationError as exc:
            e = exc.errors()[0]
            raise InputError(e["msg"], source="controller", key=".".join(map(str, e["loc"]))) from None
        self._load(cfg)

    def reset(self) -> None:
        lib.hh_controller_reset(self.state)

    def update(self, x_ref: float, dx_ref: float, x: float, p1: float = 0.0, p2: float = 0.0) -> float:
        return lib.hh_controller_update(self.c, self.state, x_ref, dx_ref, x, p1, p2)

    def __call__(self, m: Measurement) -> float:
        return lib.hh_controller_update(self.c, self.state, m.x_ref, m.dx_ref, m.x, m.p1, m.p2)


def load_callable(spec: str, base: Path | None = None, source: str | None = None,
                  key: str = "controller.callable") -> Callable:
    """The object named by ``module:name`` or ``file.py:name`` (relative to ``base``), with ``base`` and the
    file's folder on the import path while it loads. Errors name ``source`` and ``key``."""
    mod_name, _, attr = spec.rpartition(":")
    base = Path(base) if base is not None else Path.cwd()

    def fail(msg):
        return InputError(msg, source=source, key=key)

    folders = [str(base)]
    if mod_name.endswith(".py"):
        path = Path(mod_name) if Path(mod_name).is_absolute() else base / mod_name
        if not path.is_file():
            raise fail(f"no such file {path}")
        folders.insert(0, str(path.parent))
    added = [d for d in dict.fromkeys(folders) if d not in sys.path]
    sys.path[:0] = added
    try:
        if mod_name.endswith(".py"):
            name = f"hydrohil_user_{path.stem}"
            spec_ = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(spec_)
            sys.modules[name] = module
            spec_.loader.exec_module(module)
        else:
            module = importlib.import_module(mod_name)
    except ImportError as exc:
        raise fail(f"cannot import '{mod_name}': {exc}") from None
    except Exception as exc:            # the user's module failed while it loaded
        raise fail(f"loading '{mod_name}' failed: {type(exc).__name__}: {exc}") from exc
    finally:
        for d in added:
            if d in sys.path:
                sys.path.remove(d)
    obj = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise fail(f"'{mod_name}' has no '{attr}'")
        obj = getattr(obj, part)
    if not callable(obj):
        raise fail(f"'{spec}' is not callable")
    return obj


def make_controller(cfg: ControllerCfg | Callable, params: Parameters, h: float, *,
                    base: Path | None = None, source: str | None = None) -> Callable[[Measurement], float]:
    """A fresh controller for one run: ``ctl(measurement) -> ū``. ``cfg`` is a ``[controller]`` table, or a
    Python callable (a function, or a class instantiated here without arguments). ``base``: the folder a
    Python controller's module is looked up in when its table has no ``path``; ``source``: the scenario
    file, named by errors."""
    if isinstance(cfg, BuiltinController):
        cfg.reset()                       # a fresh run: no integrator or filter state from the last one
        return cfg
    if callable(cfg) and not isinstance(cfg, StrictModel):
        return cfg() if inspect.isclass(cfg) else cfg
    if cfg.type in BUILTIN_TYPES:
        return BuiltinController(cfg, params, h)
    return user_controller(load_callable(cfg.callable, Path(cfg.path) if cfg.path else base, source), cfg, source)


def anchor_controller(table: dict | None, base: Path) -> None:
    """A scenario's [controller] table as a copy elsewhere reads it: a user's controller's folder (its ``path``,
    relative to the scenario's folder ``base``; default ``base``) made absolute, in place (paper and circuit
    scenarios alike)."""
    if isinstance(table, dict) and table.get("type") == "python":
        p = Path(table["path"]) if isinstance(table.get("path"), str) else Path(".")
        table["path"] = str(p if p.is_absolute() else (base / p).resolve())


def user_controller(obj: Callable, cfg: PythonControllerCfg, source: str | None = None) -> Callable:
    """A user's controller for one run from its loaded callable ``obj``: a class instantiated with the table's
    ``options``, a function as it is (options refused)."""
    if inspect.isclass(obj):
        try:
            return obj(**cfg.options)
        except Exception as exc:
            raise InputError(f"{cfg.callable}({', '.join(cfg.options)}): {type(exc).__name__}: {exc}",
                             source=source, key="controller.options") from None
    if cfg.options:
        raise InputError(f"'{cfg.callable}' is a function: options apply to a class only", source=source,
                         key="controller.options")
    return obj


def call_controller(ctl: Callable[[Measurement], float], m: Measurement) -> float:
    """ū = ctl(m) as a finite float; a user's controller that raises or returns something else stops the run
    with an error naming the time and the measurement."""
    try:
        u = float(ctl(m))
    except Exception as exc:
        raise ControllerError(f"the controller failed at t = {m.t:.6g} s on {m}: {type(exc).__name__}: {exc}") from exc
    if u != u or u in (float("inf"), float("-inf")):
        raise ControllerError(f"the controller returned {u} at t = {m.t:.6g} s on {m}")
    return u


def p_control(kp: float, x_ref: float, x_meas: float) -> float:
    """The paper's saturated P law clamp(kp*(x_ref - x_meas), -1, 1) (the watchdog's 'hold' safe state)."""
    return lib.hh_p_control(kp, x_ref, x_meas)
