r"""Scenario files: a whole run described in TOML, checked once, run with one call.

>>> from lgvi.scenario import Scenario
>>> sc = Scenario.from_dict({"body": {"inertia": [1.0, 2.0, 3.0]},
...                          "initial": {"omega": [0.0, 1.0, 0.01]},
...                          "integrator": {"h": 0.01, "duration": 1.0}})
>>> sc.steps, sc.save_every
(100, 1)
>>> traj = sc.run()
>>> traj.R.shape
(101, 3, 3)

Use :func:`load_scenario` for a file; ``lgvi run FILE.toml`` does the same from the command line.

Schema
------
A complete example (every key shown; comments say which keys are alternatives)::

    name = "dzhanibekov"                 # optional; default: the file name without .toml; at most 100
                                         # characters, no '/', '\\', ':', control characters, leading '.'
    description = "T-handle flip"        # optional

    [body]                               # exactly one of: inertia, matrix, shape
    inertia = [1.0, 2.0, 3.0]            # principal moments [kg m^2]
    # matrix = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]]   # full inertia [kg m^2]
    # shape = "box"                      # solid box about its centre of mass:
    # mass = 2.0                         #   [kg]
    # dimensions = [0.1, 0.2, 0.3]       #   edge lengths along body x, y, z [m]
    # shape = "cylinder"                 # solid cylinder about its centre of mass:
    # mass = 2.0                         #   [kg]
    # radius = 0.1                       #   [m]
    # height = 0.5                       #   [m]
    # axis = "z"                         #   body axis of symmetry: "x", "y" or "z"

    [initial]                            # attitude R0 (body to inertial): at most one of
    euler = { sequence = "ZYX", angles = [10.0, 5.0, 0.0], unit = "deg" }
    # matrix = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]   # a rotation: orthogonal, det +1 (see Rules)
    # quat_xyzw = [0.0, 0.0, 0.0, 1.0]   # scalar last (as scipy)
    # quat_wxyz = [1.0, 0.0, 0.0, 0.0]   # scalar first
    # rotvec = [0.0, 0.0, 0.1]           # rotation vector [rad]
    omega = [0.001, 1.0, 0.001]          # body angular velocity [rad/s] ...
    # omega = { values = [0.06, 57.3, 0.06], unit = "deg/s" }   # ... with a unit: "rad/s" or "deg/s"
    # Pi = [0.001, 2.0, 0.003]           # ... or body angular momentum [kg m^2/s]: exactly one

    [integrator]
    h = 0.01                             # step [s]; negative integrates backwards
    duration = 100.0                     # [s]; or steps = 10000 (exactly one of the two)
    method = "newton"                    # "newton" (default), "paper" or "cayley"
    tol = 1e-14                          # solver tolerance (default 1e-14)
    max_iter = 50                        # solver iterations per step (default 50)
    alpha = 1.0                          # step length of the "paper" iteration, in (0, 1]
    forcing = "paper"                    # "paper" or "symmetric" (default: the library's)
    order = 2                            # 2, 4 or 6 (default: the library's)
    # composition = "suzuki4"          # a composition of lgvi.registry.COMPOSITIONS (sets the order)
    # scheme = "splitting"             # exact free-body flows and kicks (lgvi.splitting); composition
                                         # then names one of lgvi.registry.SPLITTINGS
    # scheme = "rkmk4"                 # with [[wheel]] / [controller]: the explicit RKMK scheme
                                         # (lgvi.systems.gyrostat_rkmk); composition then names its
                                         # tableau: "rk4" (default), "rk38" or "ralston4"; no [[torque]]
    save_every = 10                      # keep every 10th state; must divide the steps
    error_estimate = true                # also run at h/2 and report the estimated final
                                         # attitude error (lgvi.accuracy; default false)
    error_warn = 0.01                    # warn above this estimate [rad] (default 0.01)

    [[torque]]                           # any number of models; their moments add up
    type = "uniform_gravity"             # heavy top / 3D pendulum about a fixed pivot
    mass = 1.0                           # [kg]
    com = [0.0, 0.0, 0.3]                # centre of mass from the pivot, body frame [m]
    g = 9.81                             # optional [m/s^2]

    [[torque]]
    type = "gravity_gradient"            # circular orbit
    mu = 3.986004418e14                  # gravitational parameter [m^3/s^2]
    radius = 6778e3                      # orbit radius [m]

    [[torque]]
    type = "constant"
    u = [0.0, 0.0, 0.01]                 # body-frame moment [N m]

    [[torque]]
    type = "damping"
    c = 0.1                              # u = -c omega; a number or 3 numbers (per body axis)

    [[torque]]
    type = "pd"                          # geometric attitude PD controller
    kp = 2.0                             # a number or 3 numbers (per body axis), >= 0
    kd = 5.0                             # same
    target = { euler = { sequence = "ZYX", angles = [60.0, 0.0, 0.0], unit = "deg" } }
                                         # optional, any attitude form of [initial]; default I

    [[wheel]]                            # reaction wheels (lgvi.ReactionWheels), one table each;
    axis = [1.0, 0.0, 0.0]               # then [body] is the spacecraft with the wheels locked
    spin_inertia = 0.08                  # [kg m^2]
    speed0 = 10.0                        # optional, relative to the body [rad/s]
    max_torque = 0.2                     # optional limits: [N m], max_power [W], max_speed [rad/s]
    # min_torque, coulomb, viscous, omega_limit_cycle: optional (deadband, friction)

    [controller]                         # a control loop (lgvi.control), held between calls
    type = "mrp_feedback"                # or "rotation_pd" (kp, kd, error = "rotation"/"quaternion")
    K = 3.5                              # Basilisk's mrpFeedback gains (Ki, integral_limit optional)
    P = 30.0
    period = 0.1                         # [s], a multiple of integrator.h
    # target = { ... }                   # optional, any attitude form of [initial]; default I
    # [orbit], [field], [[magnetorquer]] and type = "bdot": see lgvi.io.scenario_space
    # a spacecraft with its flight software in the compiled loop: [spacecraft] and [fsw] instead of
    # [body], [[wheel]], [controller]: see lgvi.io.scenario_loop

    [output]
    formats = ["npz", "csv"]             # any of "npz" (default), "csv", "netcdf"
    plots = true                         # write figures with ``lgvi run`` (default true)

Rules
-----
- Unknown keys, wrong types and missing required keys are errors; every error is a
  :class:`ScenarioError` (a ``ValueError``) whose message names the file, the key as a dotted
  path (``initial.euler.unit``, ``torque[1].mass``; torque tables are counted from 0) and what
  was expected. TOML syntax errors name the file, line and column.
- Numbers: integers are accepted where a real number is expected, not the other way round
  (``steps = 1e4`` is an error). Booleans are never numbers.
- The attitude defaults to the identity when no form is given. Euler angles use scipy's
  convention: an uppercase ``sequence`` (``"ZYX"``) is intrinsic, lowercase (``"zyx"``)
  extrinsic; ``unit`` is required. A quaternion is normalised if its norm is within ``1e-3`` of
  1 (rounded decimals) and rejected otherwise. A ``matrix`` orthogonal to ``1e-9``
  (``||R^T R - I||_F``, det +1) is used as written; one orthogonal to ``1e-6`` only (a rotation
  rounded to 7 digits) is replaced by its nearest rotation with an
  :class:`lgvi.errors.AttitudeWarning`; beyond that it is an error.
- ``omega`` is in rad/s as an array; as a table ``{ values = [...], unit = "..." }`` the
  ``unit`` (required there) is ``"rad/s"`` or ``"deg/s"``. ``Pi`` is in the body's units.
- ``duration / h`` must be a non-negative integer to a relative ``1e-9``.
- ``forcing`` and ``order`` are passed to :func:`lgvi.simulate` only when given, so the
  library's defaults (and its rules, e.g. potentials always use the symmetric scheme) apply.
- ``error_estimate = true`` (or ``"richardson"``) runs the scenario a second time at ``h/2``
  (about 3x the time in all) and stores the Richardson estimate of the global error with the
  result (``Trajectory.error_estimate``, ``summary.txt``); ``error_warn`` (a positive number of
  radians) is the estimate above which a warning is given, and needs ``error_estimate = true``.
- Torque models are built from :mod:`lgvi.torques` (``UniformGravity``, ``GravityGradient``,
  ``Constant``, ``LinearDamping``, ``AttitudePD``) and summed with ``+``.
"""

from __future__ import annotations

import difflib
import functools
import math
import operator
import os
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from . import scenario_space
from .._untrusted import name_problem
from .._version import __version__
from ..registry import COMPOSITIONS, DEFAULT_SPLITTING, FORCINGS, ORDERS, SCHEMES, SPLITTINGS, method_names
from ..torques import TORQUE_MODELS

__all__ = ["BodiesScenario", "Scenario", "ScenarioError", "load_scenario", "to_toml"]

FORMATS = ("npz", "csv", "netcdf")
METHODS = method_names()            # from lgvi.registry, the default first
COMPOSITION_NAMES = tuple(COMPOSITIONS)
ERROR_ESTIMATES = (True, False, "richardson")
QUAT_NORM_TOL = 1e-3
DURATION_RTOL = 1e-9

_TOP_KEYS = ("name", "description", "body", "initial", "integrator", "torque", "wheel", "controller", "output")
_TOP_KEYS += ("orbit", "field", "magnetorquer")         # lgvi.io.scenario_space (issue 12)
_ATTITUDE_KEYS = ("matrix", "quat_xyzw", "quat_wxyz", "euler", "rotvec")
#: type: {key: (kind, required)}, read from the registered torque models (lgvi.torques); kinds:
#: number, positive (number > 0), vector, gain (number | 3 numbers), attitude
def _torque_params() -> dict[str, dict[str, tuple[str, bool]]]:
    return {k: dict(cls.scenario_params) for k, cls in TORQUE_MODELS.items()}


_TORQUE_PARAMS = _torque_params()


class ScenarioError(ValueError):
    """An invalid scenario: the message names the file, the key and what was expected.

    Attributes
    ----------
    source : str
        File name (or ``"<dict>"``).
    key : str or None
        Dotted path of the offending key (``None`` for file-level problems such as syntax).
    line, column : int or None
        Position of a TOML syntax error.
    """

    def __init__(self, source: str, key: str | None, message: str, *, line: int | None = None,
                 column: int | None = None):
        where = source if key is None else f"{source}: {key}"
        super().__init__(f"{where}: {message}")
        self.source = source
        self.key = key
        self.line = line
        self.column = column


_MISSING = object()


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _typename(value: Any) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "an array",
            dict: "a table"}.get(type(value), type(value).__name__)


class _Checker:
    """Typed access to the parsed TOML, raising :class:`ScenarioError` with dotted key paths."""

    def __init__(self, source: str):
        self.source = source

    def error(self, key: str | None, message: str) -> ScenarioError:
        return ScenarioError(self.source, key, message)

    def expected(self, key: str, what: str, value: Any = _MISSING) -> ScenarioError:
        if value is _MISSING:
            return self.error(key, f"missing; expected {what}")
        return self.error(key, f"expected {what}, got {_show(value)} ({_typename(value)})")

    def table(self, value: Any, key: str, allowed: tuple[str, ...]) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.expected(key, "a table", value)
        for k in value:
            if k not in allowed:
                close = difflib.get_close_matches(k, allowed, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                path = f"{key}.{k}" if key else k
                raise self.error(path, f"unknown key{hint}; expected one of {', '.join(allowed)}")
        return value

    def number(self, value: Any, key: str, *, positive: bool = False, nonzero: bool = False,
               nonnegative: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.expected(key, "a number", value)
        x = float(value)
        if not math.isfinite(x):
            raise self.error(key, f"expected a finite number, got {value!r}")
        if positive and not x > 0:
            raise self.error(key, f"expected a positive number, got {value!r}")
        if nonzero and x == 0:
            raise self.error(key, f"expected a non-zero number, got {value!r}")
        if nonnegative and x < 0:
            raise self.error(key, f"expected a number >= 0, got {value!r}")
        return x

    def integer(self, value: Any, key: str, *, minimum: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.expected(key, f"an integer >= {minimum}", value)
        if value < minimum:
            raise self.error(key, f"expected an integer >= {minimum}, got {value}")
        return int(value)

    def string(self, value: Any, key: str, options: tuple[str, ...] | None = None) -> str:
        if not isinstance(value, str):
            want = "a string" if options is None else "one of " + ", ".join(f'"{o}"' for o in options)
            raise self.expected(key, want, value)
        if options is not None and value not in options:
            close = difflib.get_close_matches(value, options, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise self.error(key, f"expected one of {', '.join(repr(o) for o in options)}, got {value!r}{hint}")
        return value

    def boolean(self, value: Any, key: str) -> bool:
        if not isinstance(value, bool):
            raise self.expected(key, "true or false", value)
        return value

    def vector(self, value: Any, key: str, n: int = 3) -> np.ndarray:
        what = f"an array of {n} numbers"
        if not isinstance(value, list) or len(value) != n:
            raise self.expected(key, what, value)
        return np.array([self.number(v, f"{key}[{i}]") for i, v in enumerate(value)], dtype=np.float64)

    def matrix(self, value: Any, key: str) -> np.ndarray:
        what = "a 3x3 matrix (an array of 3 arrays of 3 numbers)"
        if not isinstance(value, list) or len(value) != 3 or not all(isinstance(r, list) and len(r) == 3
                                                                      for r in value):
            raise self.expected(key, what, value)
        return np.array([[self.number(v, f"{key}[{i}][{j}]") for j, v in enumerate(row)]
                         for i, row in enumerate(value)], dtype=np.float64)

    def gain(self, value: Any, key: str) -> float | np.ndarray:
        """A gain >= 0: one number (every body axis) or 3 numbers (per body axis)."""
        what = "a number >= 0 or an array of 3 numbers >= 0 (one per body axis)"
        if isinstance(value, list):
            if len(value) != 3:
                raise self.expected(key, what, value)
            g = self.vector(value, key)
        elif isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.expected(key, what, value)
        else:
            g = np.array(self.number(value, key))
        if np.any(g < 0):
            raise self.error(key, f"expected {what}, got {value!r}")
        return g if g.ndim else float(g)


# ------------------------------------------------------------------------------------ pieces
def _body(c: _Checker, tbl: Any):
    from ..body import RigidBody

    allowed = ("inertia", "matrix", "shape", "mass", "dimensions", "radius", "height", "axis")
    tbl = c.table(tbl, "body", allowed)
    given = [k for k in ("inertia", "matrix", "shape") if k in tbl]
    if len(given) != 1:
        got = "none" if not given else " and ".join(given)
        raise c.error("body", f"expected exactly one of body.inertia, body.matrix, body.shape; got {got}")
    kind = given[0]
    shape_keys = {"box": ("mass", "dimensions"), "cylinder": ("mass", "radius", "height", "axis")}
    if kind != "shape":
        extra = [k for k in tbl if k != kind]
        if extra:
            raise c.error(f"body.{extra[0]}", f"only used with body.shape; with body.{kind} remove it")
        J = c.vector(tbl[kind], f"body.{kind}") if kind == "inertia" else c.matrix(tbl[kind], "body.matrix")
        key = f"body.{kind}"
    else:
        shape = c.string(tbl["shape"], "body.shape", tuple(shape_keys))
        need = shape_keys[shape]
        for k in tbl:
            if k != "shape" and k not in need:
                raise c.error(f"body.{k}", f"not a parameter of shape = \"{shape}\"; expected {', '.join(need)}")
        for k in need:
            if k not in tbl:
                raise c.expected(f"body.{k}", {"mass": "a positive number [kg]",
                                               "dimensions": "an array of 3 positive edge lengths [m]",
                                               "radius": "a positive number [m]",
                                               "height": "a positive number [m]",
                                               "axis": 'one of "x", "y", "z"'}[k])
        m = c.number(tbl["mass"], "body.mass", positive=True)
        if shape == "box":
            a, b, cc = c.vector(tbl["dimensions"], "body.dimensions")
            for i, d in enumerate((a, b, cc)):
                if not d > 0:
                    raise c.error(f"body.dimensions[{i}]", f"expected a positive edge length, got {d}")
            J = m / 12.0 * np.array([b * b + cc * cc, a * a + cc * cc, a * a + b * b])
        else:
            r = c.number(tbl["radius"], "body.radius", positive=True)
            H = c.number(tbl["height"], "body.height", positive=True)
            axis = "xyz".index(c.string(tbl["axis"], "body.axis", ("x", "y", "z")))
            J = np.full(3, m * (3.0 * r * r + H * H) / 12.0)
            J[axis] = 0.5 * m * r * r
        key = f"body.{'dimensions' if shape == 'box' else 'shape'}"
    try:
        return RigidBody(J)
    except ValueError as exc:
        raise c.error(key, f"not a valid inertia: {exc}") from None


def _attitude(c: _Checker, tbl: dict[str, Any], key: str) -> np.ndarray:
    """R from whichever attitude form ``tbl`` holds (identity if none); ``tbl`` already key-checked."""
    from scipy.spatial.transform import Rotation

    from .._validation import nearest_rotation, warn_repaired

    given = [k for k in _ATTITUDE_KEYS if k in tbl]
    if len(given) > 1:
        raise c.error(key, f"give the attitude in one form only; got {' and '.join(given)}")
    if not given:
        return np.eye(3)
    form = given[0]
    path = f"{key}.{form}"
    value = tbl[form]
    if form == "matrix":
        R = c.matrix(value, path)
        fix = (f"Write {path} with orthonormal rows and determinant +1 to at least 7 significant digits, "
               "or give the attitude as rotvec, quat_xyzw, quat_wxyz or euler instead.")
        try:
            R, err = nearest_rotation(R, path, fix)
        except ValueError as exc:
            raise c.error(path, f"expected a rotation matrix: {exc}") from None
        if err is not None:
            warn_repaired(f"{c.source}: {path} is {err:.2g} away from a rotation; write it with more digits "
                          "to silence this", R)
        return R
    if form in ("quat_xyzw", "quat_wxyz"):
        q = c.vector(value, path, 4)
        n = float(np.linalg.norm(q))
        if abs(n - 1.0) > QUAT_NORM_TOL:
            raise c.error(path, f"expected a unit quaternion (norm within {QUAT_NORM_TOL:g} of 1), got norm {n:.6g}")
        if form == "quat_wxyz":
            q = q[[1, 2, 3, 0]]
        return Rotation.from_quat(q / n).as_matrix()
    if form == "rotvec":
        v = c.vector(value, path)
        with np.errstate(over="ignore"):
            angle = float(np.linalg.norm(v))
        if not math.isfinite(angle):
            raise c.error(path, f"expected a rotation vector of finite length, got length {angle}")
        return Rotation.from_rotvec(v).as_matrix()
    # euler
    eul = c.table(value, path, ("sequence", "angles", "unit"))
    for k, what in (("sequence", 'a string such as "ZYX" (intrinsic) or "zyx" (extrinsic)'),
                    ("angles", "an array of 3 numbers"), ("unit", '"deg" or "rad"')):
        if k not in eul:
            raise c.expected(f"{path}.{k}", what)
    seq = c.string(eul["sequence"], f"{path}.sequence")
    if not re.fullmatch(r"[XYZ]{3}|[xyz]{3}", seq) or seq[0] == seq[1] or seq[1] == seq[2]:
        raise c.error(f"{path}.sequence", "expected 3 axes from x, y, z, all uppercase (intrinsic) or all "
                      f"lowercase (extrinsic), no axis twice in a row (e.g. \"ZYX\", \"zxz\"); got {seq!r}")
    angles = c.vector(eul["angles"], f"{path}.angles")
    unit = c.string(eul["unit"], f"{path}.unit", ("deg", "rad"))
    return Rotation.from_euler(seq, angles, degrees=(unit == "deg")).as_matrix()


def _omega(c: _Checker, value: Any, key: str) -> np.ndarray:
    """Body angular velocity in rad/s: an array (rad/s) or ``{ values = [...], unit = "rad/s" | "deg/s" }``."""
    if not isinstance(value, dict):
        return c.vector(value, key)
    tbl = c.table(value, key, ("values", "unit"))
    for k, what in (("values", "an array of 3 numbers"), ("unit", '"rad/s" or "deg/s"')):
        if k not in tbl:
            raise c.expected(f"{key}.{k}", what)
    values = c.vector(tbl["values"], f"{key}.values")
    unit = c.string(tbl["unit"], f"{key}.unit", ("rad/s", "deg/s"))
    return np.radians(values) if unit == "deg/s" else values


def _torque(c: _Checker, entries: Any) -> tuple[Any, tuple[dict[str, Any], ...]]:
    if isinstance(entries, dict):
        raise c.error("torque", "expected an array of tables: write [[torque]] (double brackets) "
                      "for each torque model")
    if not isinstance(entries, list):
        raise c.expected("torque", "an array of tables ([[torque]] sections)", entries)
    torque_params = _torque_params()  # read now: a model registered after import is a valid type too
    specs = []
    for i, entry in enumerate(entries):
        key = f"torque[{i}]"
        if not isinstance(entry, dict):
            raise c.expected(key, "a table", entry)
        if "type" not in entry:
            raise c.expected(f"{key}.type", "one of " + ", ".join(f'"{t}"' for t in torque_params))
        kind = c.string(entry["type"], f"{key}.type", tuple(torque_params))
        params = torque_params[kind]
        c.table(entry, key, ("type",) + tuple(params))
        spec: dict[str, Any] = {"type": kind}
        for name, (what, required) in params.items():
            path = f"{key}.{name}"
            if name not in entry:
                if required:
                    raise c.expected(path, {"number": "a number", "positive": "a number", "vector": "an array of 3 numbers",
                                            "gain": "a number or an array of 3 numbers"}[what])
                continue
            v = entry[name]
            if what in ("number", "positive"):
                spec[name] = c.number(v, path, positive=what == "positive")
            elif what == "vector":
                spec[name] = c.vector(v, path)
            elif what == "gain":
                spec[name] = c.gain(v, path)
            else:  # attitude
                spec[name] = _attitude(c, c.table(v, path, _ATTITUDE_KEYS), path)
        specs.append(spec)
    if not specs:
        return None, ()
    models = []
    for i, spec in enumerate(specs):
        kind = spec["type"]
        try:
            model = TORQUE_MODELS[kind].from_scenario(spec)
        except (ValueError, TypeError) as exc:
            raise c.error(f"torque[{i}]", f"invalid {kind} model: {exc}") from None
        models.append(model)
    return functools.reduce(operator.add, models), tuple(specs)


# ------------------------------------------------------------------------------------ scenario
_WHEEL_KEYS = {"axis": "vector", "spin_inertia": "positive", "speed0": "number", "max_torque": "positive",
               "min_torque": "number", "max_power": "positive", "max_speed": "positive", "coulomb": "number",
               "viscous": "number", "omega_limit_cycle": "positive"}
_CONTROLLERS = {"mrp_feedback": ("K", "P", "Ki", "integral_limit"), "rotation_pd": ("kp", "kd", "error")}
_CONTROLLERS["bdot"] = scenario_space.BDOT_KEYS


def _wheels(c: _Checker, entries: Any, body: Any) -> Any:
    """The ``[[wheel]]`` tables: one :class:`lgvi.ReactionWheels` (issue 12)."""
    from ..systems.gyrostat import ReactionWheels

    if isinstance(entries, dict):
        raise c.error("wheel", "expected an array of tables: write [[wheel]] (double brackets) for each wheel")
    if not isinstance(entries, list) or not entries:
        raise c.expected("wheel", "an array of tables ([[wheel]] sections)", entries)
    cols: dict[str, list[float]] = {k: [] for k in _WHEEL_KEYS}
    for i, entry in enumerate(entries):
        key = f"wheel[{i}]"
        c.table(entry, key, tuple(_WHEEL_KEYS))
        for name in ("axis", "spin_inertia"):
            if name not in entry:
                raise c.expected(f"{key}.{name}", "an array of 3 numbers" if name == "axis" else "a positive number")
        for name, what in _WHEEL_KEYS.items():
            path = f"{key}.{name}"
            if name not in entry:
                cols[name].append(np.nan)
            elif what == "vector":
                cols[name].append(c.vector(entry[name], path))
            else:
                cols[name].append(c.number(entry[name], path, positive=what == "positive"))
    n = len(entries)

    def col(name: str, default: Any) -> Any:
        v = np.array(cols[name], dtype=float)
        if np.all(np.isnan(v)):
            return default
        return np.where(np.isnan(v), np.nan if default is None else default, v)

    limits = {}
    for name in ("max_torque", "max_power", "max_speed"):
        v = col(name, None)
        if v is not None and np.any(np.isnan(v)):
            raise c.error("wheel", f"give {name} for every wheel or for none (wheel "
                          f"{int(np.argmax(np.isnan(v)))} has none)")
        limits[name] = v
    friction = {k: col(k, d) for k, d in (("coulomb", 0.0), ("viscous", 0.0), ("omega_limit_cycle", 1e-4))}
    try:
        wheels = ReactionWheels(np.array(cols["axis"]).reshape(n, 3), np.array(cols["spin_inertia"]),
                                speed0=col("speed0", 0.0), min_torque=col("min_torque", 0.0), friction=friction,
                                **limits)
        wheels.hub_inertia(body)
    except (ValueError, TypeError) as exc:
        raise c.error("wheel", f"invalid wheels: {exc}") from None
    return wheels


def _controller(c: _Checker, tbl: Any, h: float) -> tuple[Any, float]:
    """The ``[controller]`` table: a controller of :mod:`lgvi.control` and its period (issue 12)."""
    from .. import control

    if not isinstance(tbl, dict) or "type" not in tbl:
        raise c.expected("controller.type", "one of " + ", ".join(f'"{t}"' for t in _CONTROLLERS))
    kind = c.string(tbl["type"], "controller.type", tuple(_CONTROLLERS))
    tbl = c.table(tbl, "controller", ("type", "period", "target") + _CONTROLLERS[kind])
    if "period" not in tbl:
        raise c.expected("controller.period", "a positive number (seconds, a multiple of integrator.h)")
    period = c.number(tbl["period"], "controller.period", positive=True)
    target = _attitude(c, c.table(tbl["target"], "controller.target", _ATTITUDE_KEYS),
                       "controller.target") if "target" in tbl else None
    try:
        if kind == "mrp_feedback":
            for name in ("K", "P"):
                if name not in tbl:
                    raise c.expected(f"controller.{name}", "a positive number")
            opt = {k: c.number(tbl[k], f"controller.{k}", positive=True) for k in ("Ki", "integral_limit") if k in tbl}
            ctrl = control.MRPFeedback(c.number(tbl["K"], "controller.K"), c.number(tbl["P"], "controller.P"),
                                       target=target, **opt)
        elif kind == "bdot":
            ctrl = scenario_space.bdot(c, tbl)
        else:
            for name in ("kp", "kd"):
                if name not in tbl:
                    raise c.expected(f"controller.{name}", "a positive number")
            ctrl = control.RotationPD(c.number(tbl["kp"], "controller.kp"), c.number(tbl["kd"], "controller.kd"),
                                      target=target, error=c.string(tbl.get("error", "rotation"), "controller.error",
                                                                    ("rotation", "quaternion")))
    except ValueError as exc:
        if isinstance(exc, ScenarioError):
            raise
        raise c.error("controller", f"invalid {kind} controller: {exc}") from None
    ratio = period / abs(h)
    if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio) or round(ratio) < 1:
        raise c.error("controller.period", f"expected a positive multiple of |integrator.h| = {abs(h)!r}; "
                      f"got {period!r} (ratio {ratio!r})")
    return ctrl, period


@dataclass(frozen=True, eq=False)
class Scenario:
    """A checked, ready-to-run scenario (see the module docstring for the file format).

    Attributes
    ----------
    name, description : str
    body : RigidBody
    R0 : (3, 3) ndarray
        Initial attitude.
    Pi0 : (3,) ndarray
        Initial body angular momentum (``J omega`` when ``omega`` was given).
    h : float
    steps : int
    torque : torque model or None
        Sum of the :mod:`lgvi.torques` models of the ``[[torque]]`` tables.
    torque_spec : tuple of dict
        The checked ``[[torque]]`` tables (arrays as NumPy arrays).
    forcing : str or None
    order : int or None
        ``None`` means "the library's default" (not passed to :func:`lgvi.simulate`).
    method : str
    tol, alpha : float
    max_iter, save_every : int
    error_estimate : bool
        Run a shadow at ``h/2`` and attach the error estimate (:mod:`lgvi.accuracy`).
    error_warn : float
        Threshold of the estimated final attitude error for a warning [rad].
    formats : tuple of str
        Output formats, ``"npz"`` first when present.
    plots : bool
    source : str
        File name (or ``"<dict>"``).
    text : str
        The scenario as TOML: the file's own text, or a rendering of the dict.
    """

    name: str
    description: str
    body: Any
    R0: np.ndarray
    Pi0: np.ndarray
    h: float
    steps: int
    torque: Any = None
    torque_spec: tuple[dict[str, Any], ...] = ()
    forcing: str | None = None
    order: int | None = None
    method: str = "newton"
    tol: float = 1e-14
    max_iter: int = 50
    alpha: float = 1.0
    save_every: int = 1
    error_estimate: bool = False
    error_warn: float = 0.01
    formats: tuple[str, ...] = ("npz",)
    plots: bool = True
    source: str = "<dict>"
    text: str = field(default="", repr=False)
    composition: str | None = None
    scheme: str | None = None
    wheels: Any = None
    controller: Any = None
    control_period: float | None = None
    environment: Any = None
    magnetorquers: Any = None

    @property
    def duration(self) -> float:
        """``steps * h``."""
        return self.steps * self.h

    @property
    def samples(self) -> int:
        """Number of saved states, ``steps // save_every + 1``."""
        return self.steps // self.save_every + 1

    def __repr__(self) -> str:
        tq = "none" if not self.torque_spec else "+".join(s["type"] for s in self.torque_spec)
        return (f"Scenario(name={self.name!r}, steps={self.steps}, h={self.h:g}, method={self.method!r}, "
                f"torque={tq}, source={self.source!r})")

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "<dict>", *, text: str | None = None) -> "Scenario":
        """Check a parsed scenario (the dict ``tomllib`` returns) and resolve it.

        Parameters
        ----------
        d : dict
            Tables as in the module docstring.
        source : str
            Name used in error messages (the file name).
        text : str, optional
            Original text to keep with the results; default: ``d`` rendered as TOML.

        Raises
        ------
        ScenarioError
            For any invalid, missing or unknown key.
        """
        c = _Checker(source)
        if isinstance(d, dict) and ("spacecraft" in d or "fsw" in d):   # the compiled loop (issue 25)
            from .scenario_loop import LoopScenario

            return LoopScenario.from_dict(d, source, text=text)  # type: ignore[return-value]
        if isinstance(d, dict) and any(k in d for k in _system_sections()):   # orbit, two bodies, any system
                                                                                # with a scenario section
            return BodiesScenario.from_dict(d, source, text=text)  # type: ignore[return-value]
        d = c.table(d, "", _TOP_KEYS)
        for req in ("body", "initial", "integrator"):
            if req not in d:
                raise c.error(req, f"missing; expected a [{req}] table")
        default_name = Path(source).stem if not source.startswith("<") else "scenario"
        name = c.string(d.get("name", default_name), "name")
        if "name" in d and (problem := name_problem(name)):
            raise c.error("name", problem)
        description = c.string(d.get("description", ""), "description")

        body = _body(c, d["body"])

        init = c.table(d["initial"], "initial", _ATTITUDE_KEYS + ("omega", "Pi"))
        R0 = _attitude(c, init, "initial")
        if ("omega" in init) == ("Pi" in init):
            got = "both" if "omega" in init else "neither"
            raise c.error("initial", f"expected exactly one of initial.omega [rad/s] or initial.Pi [kg m^2/s]; "
                          f"got {got}")
        with np.errstate(over="ignore", invalid="ignore"):
            Pi0 = (body.J @ _omega(c, init["omega"], "initial.omega")) if "omega" in init else \
                c.vector(init["Pi"], "initial.Pi")
        if not np.all(np.isfinite(Pi0)):
            raise c.error("initial.omega", f"expected an angular velocity whose momentum J omega is finite, "
                          f"got J omega = {Pi0.tolist()}")

        integ = c.table(d["integrator"], "integrator", ("h", "steps", "duration", "method", "tol", "max_iter",
                                                        "alpha", "forcing", "order", "save_every",
                                                        "error_estimate", "error_warn", "composition", "scheme"))
        if "h" not in integ:
            raise c.expected("integrator.h", "a non-zero number (the step size in seconds)")
        h = c.number(integ["h"], "integrator.h", nonzero=True)
        if ("steps" in integ) == ("duration" in integ):
            got = "both" if "steps" in integ else "neither"
            raise c.error("integrator", f"expected exactly one of integrator.steps or integrator.duration; got {got}")
        if "steps" in integ:
            steps = c.integer(integ["steps"], "integrator.steps", minimum=0)
        else:
            duration = c.number(integ["duration"], "integrator.duration")
            ratio = duration / h
            if not math.isfinite(ratio):
                raise c.error("integrator.duration", f"expected a whole number of steps h = {h!r}; "
                              f"duration / h = {duration!r} / {h!r} overflows")
            steps = round(ratio)
            if ratio < -0.5 or abs(ratio - steps) > DURATION_RTOL * abs(ratio):
                sign = "" if ratio >= 0 else " (and have the sign of h)"
                raise c.error("integrator.duration", f"expected a whole number of steps h = {h!r}{sign}; "
                              f"duration / h = {duration!r} / {h!r} = {ratio!r}")
            steps = int(steps)
        method = c.string(integ.get("method", "newton"), "integrator.method", METHODS)
        tol = c.number(integ.get("tol", 1e-14), "integrator.tol", nonnegative=True)
        max_iter = c.integer(integ.get("max_iter", 50), "integrator.max_iter", minimum=1)
        alpha = c.number(integ.get("alpha", 1.0), "integrator.alpha")
        if not 0.0 < alpha <= 1.0:
            raise c.error("integrator.alpha", f"expected a number in (0, 1], got {alpha!r}")
        forcing = c.string(integ["forcing"], "integrator.forcing", FORCINGS) if "forcing" in integ else None
        scheme = c.string(integ["scheme"], "integrator.scheme", SCHEMES) if "scheme" in integ else None
        order = None
        if "order" in integ:
            order = integ["order"]
            orders = tuple(sorted(DEFAULT_SPLITTING)) if scheme == "splitting" else ORDERS
            orders = (4,) if scheme == "rkmk4" else orders
            if isinstance(order, bool) or order not in orders or not isinstance(order, int):
                raise c.expected("integrator.order", "one of " + ", ".join(str(o) for o in orders)
                                 + (f' (scheme = "{scheme}")' if scheme in ("splitting", "rkmk4") else ""), order)
        composition = None
        comps = SPLITTINGS if scheme == "splitting" else COMPOSITIONS
        if scheme == "rkmk4":   # the Runge-Kutta tableaux, all of order 4
            from ..systems.gyrostat_rkmk import TABLEAUS as comps  # type: ignore[assignment]
        if "composition" in integ:
            composition = c.string(integ["composition"], "integrator.composition", tuple(comps))
            comp_order = 4 if scheme == "rkmk4" else comps[composition].order
            if order is None:
                order = comp_order
            elif order != comp_order:
                raise c.error("integrator.composition", f"composition {composition!r} is of order {comp_order}, "
                              f"but integrator.order = {order}; remove order or set it to {comp_order}")
        save_every = c.integer(integ.get("save_every", 1), "integrator.save_every", minimum=1)
        if steps % save_every:
            raise c.error("integrator.save_every", f"expected a divisor of the number of steps ({steps}) so the "
                          f"final state is saved; got {save_every}")

        error_estimate = integ.get("error_estimate", False)
        if not isinstance(error_estimate, (bool, str)) or error_estimate not in ERROR_ESTIMATES:
            raise c.expected("integrator.error_estimate", 'true, false or "richardson"', error_estimate)
        error_estimate = bool(error_estimate)
        error_warn = 0.01
        if "error_warn" in integ:
            error_warn = c.number(integ["error_warn"], "integrator.error_warn", positive=True)
            if not error_estimate:
                raise c.error("integrator.error_warn", "only used with the error estimate; add "
                              "error_estimate = true to [integrator], or remove error_warn")

        torque, spec = _torque(c, d["torque"]) if "torque" in d else (None, ())
        if scheme == "rkmk4" and "torque" in d:
            raise c.error("torque", 'not available with integrator.scheme = "rkmk4" (a compiled torque model runs in '
                          'the LGVI\'s loop only); remove the [[torque]] tables, or set integrator.scheme = "lgvi" '
                          '(or leave it out)')
        wheels = _wheels(c, d["wheel"], body) if "wheel" in d else None
        controller, control_period = _controller(c, d["controller"], h) if "controller" in d else (None, None)
        environment = scenario_space.environment(c, d)
        rods = scenario_space.magnetorquers(c, d["magnetorquer"]) if "magnetorquer" in d else None
        if wheels is not None and "omega" in init:   # Pi0 is the total momentum: J omega + G diag(Js) speed0
            Pi0 = Pi0 + wheels.axes.T @ (wheels.spin_inertia * wheels.speed0)

        out = c.table(d.get("output", {}), "output", ("formats", "plots"))
        formats: tuple[str, ...] = ("npz",)
        if "formats" in out:
            raw = out["formats"]
            if isinstance(raw, str):
                raw = [raw]
            if not isinstance(raw, list) or not raw:
                raise c.expected("output.formats", 'a non-empty array of "npz", "csv", "netcdf"', out["formats"])
            formats = tuple(dict.fromkeys(c.string(f, f"output.formats[{i}]", FORMATS) for i, f in enumerate(raw)))
        plots = c.boolean(out.get("plots", True), "output.plots")

        return cls(name=name, description=description, body=body, R0=R0, Pi0=Pi0, h=h, steps=steps, torque=torque,
                   torque_spec=spec, forcing=forcing, order=order, method=method, tol=tol, max_iter=max_iter,
                   alpha=alpha, save_every=save_every, error_estimate=error_estimate, error_warn=error_warn,
                   formats=formats, plots=plots, source=source, composition=composition, scheme=scheme,
                   text=to_toml(d) if text is None else text, wheels=wheels, controller=controller,
                   control_period=control_period, environment=environment, magnetorquers=rods)

    def simulate_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`lgvi.simulate` for this scenario (after body, R0, Pi0)."""
        kw: dict[str, Any] = dict(h=self.h, steps=self.steps, torque=self.torque, method=self.method, tol=self.tol,
                                  max_iter=self.max_iter, alpha=self.alpha, save_every=self.save_every)
        if self.forcing is not None:
            kw["forcing"] = self.forcing
        if self.order is not None:
            kw["order"] = self.order
        if self.composition is not None:
            kw["composition"] = self.composition
        if self.scheme is not None:
            kw["scheme"] = self.scheme
        if self.wheels is not None:
            kw["wheels"] = self.wheels
        if self.controller is not None:
            kw.update(controller=self.controller, control_period=self.control_period)
        if self.environment is not None:
            kw["environment"] = self.environment
        if self.magnetorquers is not None:
            kw["magnetorquers"] = self.magnetorquers
        return kw

    def run(self, progress: bool = False):
        """Simulate the scenario with :func:`lgvi.simulate`.

        Parameters
        ----------
        progress : bool
            Show the library's progress bar on stderr.

        Returns
        -------
        Trajectory
            With ``meta["scenario"]`` (the TOML text), ``meta["scenario_name"]`` and
            ``meta["scenario_source"]`` added, so every saved result carries its scenario.

        Raises
        ------
        ConvergenceError, TorqueError, SimulationInterrupted
            As :func:`lgvi.simulate`; their ``.trajectory`` carries the scenario metadata too.
        """
        from ..integrator import simulate
        from ..systems.loop_keywords import as_given

        est = dict(error_estimate=True, error_warn=self.error_warn) if self.error_estimate else {}
        try:
            with as_given():   # a file's [[wheel]]/[controller] run the gyrostat, as its stream does ([spacecraft]: the loop)
                traj = simulate(self.body, self.R0, self.Pi0, progress=progress, **self.simulate_kwargs(), **est)
        except (KeyboardInterrupt, RuntimeError) as exc:
            part = getattr(exc, "trajectory", None)
            if part is not None:
                exc.trajectory = self.attach(part)
            raise
        return self.attach(traj)

    def run_stream(self, folder, *, resume: bool = False, progress: bool = False, chunk_steps: int | None = None,
                   solver_record: str = "interval"):
        """Simulate the scenario into a crash-safe stream folder (:func:`lgvi.simulate_stream`) and
        read it back; ``resume=True`` continues an interrupted or killed run bit for bit;
        ``solver_record`` as in :func:`lgvi.simulate`.

        Returns
        -------
        Trajectory
            As :meth:`run`; with ``error_estimate`` the shadow run at ``h/2`` is made in memory
            after the stream is complete.
        """
        from .streaming import read_stream, simulate_stream

        try:   # with [[wheel]] or [controller]: the gyrostat's stream (wheel fields, controller state)
            simulate_stream(folder, self.body, self.R0, self.Pi0, progress=progress, resume=resume,
                            chunk_steps=chunk_steps, meta={"scenario_name": self.name},
                            solver_record=solver_record, **self.simulate_kwargs())
            traj = read_stream(folder)
            if self.error_estimate:
                from ..accuracy import with_estimate

                traj = with_estimate(traj, dict(body=self.body, R0=self.R0, Pi0=self.Pi0, progress=progress,
                                                **self.simulate_kwargs()), warn=self.error_warn, stacklevel=2)
        except (KeyboardInterrupt, RuntimeError) as exc:
            part = getattr(exc, "trajectory", None)
            if part is not None:
                exc.trajectory = self.attach(part)
            raise
        return self.attach(traj)

    def attach(self, traj):
        """A copy of ``traj`` whose ``meta`` also holds this scenario's text, name and source."""
        meta = dict(traj.meta)
        meta.update(scenario=self.text, scenario_name=self.name, scenario_source=self.source)
        meta.setdefault("lgvi_version", __version__)
        return replace(traj, meta=meta)


def load_scenario(path: str | os.PathLike[str]) -> Scenario:
    """Read and check a scenario file (TOML).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    Scenario

    Raises
    ------
    ScenarioError
        If the file cannot be read, is not valid TOML (the message gives the line and column),
        or breaks the schema (the message names the key).
    """
    source = os.fspath(path)
    try:
        with open(source, "rb") as fh:
            raw = fh.read()
    except OSError as exc:
        raise ScenarioError(source, None, f"cannot read the scenario file: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(source, None, f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        d = tomllib.loads(text)
    except RecursionError:
        raise ScenarioError(source, None, "TOML syntax error: arrays or tables nested too deeply") from None
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        if m:
            line, col = int(m.group(1)), int(m.group(2))
            detail = msg[:m.start()].strip()
            raise ScenarioError(source, None, f"line {line}, column {col}: TOML syntax error: {detail}",
                                line=line, column=col) from None
        raise ScenarioError(source, None, f"TOML syntax error: {msg}") from None
    return Scenario.from_dict(d, source=source, text=text)


# ------------------------------------------------------------------------------------ TOML out
def _plain(v: Any) -> Any:
    """``v`` with numpy scalars and arrays and tuples turned into the Python values TOML writes."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def to_toml(d: dict[str, Any]) -> str:
    """Render a scenario dict as TOML text that :func:`tomllib.loads` reads back to the same dict.

    Written by ``tomli_w`` (top-level tables become ``[table]`` sections, lists of tables
    ``[[table]]`` sections); numpy arrays and scalars are written as lists and numbers. A value
    TOML cannot hold (``None``, an object) raises ``TypeError``.
    """
    import tomli_w

    return tomli_w.dumps(_plain(d))


# ------------------------------------------------------------------------------------ bodies in orbit, two bodies
#: The sections of a scenario of lgvi.simulate_orbit ([orbiting_body]) or lgvi.simulate_two_body ([two_body]),
#: and the system each runs. (A spacecraft scenario's [orbit] is the orbit that drives its environment:
#: lgvi.io.scenario_space.)
_BODIES_SECTIONS = {"orbiting_body": "orbit", "two_body": "two_body"}


def _system_sections() -> dict[str, str]:
    """Scenario section -> system name: the two above and every registered system that reads its
    own section (``System.from_scenario``, e.g. ``[chain]``)."""
    from ..systems import SYSTEMS

    out = dict(_BODIES_SECTIONS)
    out.update({s.scenario_section: s.name for s in SYSTEMS.values() if s.from_scenario is not None})
    return out
_BODIES_TOP = ("name", "description", "initial", "integrator", "output")
_BODIES_INTEGRATOR = ("h", "steps", "duration", "save_every", "tol", "max_iter")


def _steps(c: _Checker, integ: dict[str, Any]) -> tuple[float, int]:
    if "h" not in integ:
        raise c.expected("integrator.h", "a non-zero number (the step size)")
    h = c.number(integ["h"], "integrator.h", nonzero=True)
    if ("steps" in integ) == ("duration" in integ):
        raise c.error("integrator", "expected exactly one of integrator.steps or integrator.duration; got "
                      + ("both" if "steps" in integ else "neither"))
    if "steps" in integ:
        return h, c.integer(integ["steps"], "integrator.steps", minimum=0)
    duration = c.number(integ["duration"], "integrator.duration")
    ratio = duration / h
    steps = round(ratio) if math.isfinite(ratio) else -1
    if steps < 0 or abs(ratio - steps) > DURATION_RTOL * abs(ratio):
        raise c.error("integrator.duration", f"expected a whole, non-negative number of steps h = {h!r}; "
                      f"duration / h = {ratio!r}")
    return h, int(steps)


def _inertia_or_shape(c: _Checker, tbl: dict[str, Any], key: str, shapes: bool) -> Any:
    """One of ``inertia`` (3 numbers), ``matrix`` (3x3), and with ``shapes`` ``ellipsoid`` (semi-axes)
    or ``points = { masses = [...], positions = [[...], ...] }``."""
    from ..systems.two_body import Ellipsoid, PointMasses

    forms = ("inertia", "matrix") + (("ellipsoid", "points") if shapes else ())
    given = [k for k in forms if k in tbl]
    if len(given) != 1:
        raise c.error(key, f"expected exactly one of {', '.join(key + '.' + f for f in forms)}; got "
                      + (" and ".join(given) or "none"))
    form = given[0]
    path = f"{key}.{form}"
    try:
        if form == "inertia":
            return c.vector(tbl[form], path)
        if form == "matrix":
            return c.matrix(tbl[form], path)
        if form == "ellipsoid":
            return Ellipsoid(*c.vector(tbl[form], path))
        pts = c.table(tbl[form], path, ("masses", "positions"))
        if not isinstance(pts.get("masses"), list) or not isinstance(pts.get("positions"), list):
            raise c.expected(path, "a table with masses = [m1, ...] and positions = [[x, y, z], ...]", tbl[form])
        return PointMasses([c.number(m, f"{path}.masses[{i}]", positive=True) for i, m in enumerate(pts["masses"])],
                           [c.vector(q, f"{path}.positions[{i}]") for i, q in enumerate(pts["positions"])])
    except ValueError as exc:
        if isinstance(exc, ScenarioError):
            raise
        raise c.error(path, str(exc)) from None


def _spin(c: _Checker, tbl: dict[str, Any], key: str) -> dict[str, Any]:
    """The attitude (any form of [initial]) and ``omega`` or ``Pi`` of one body."""
    out: dict[str, Any] = {"R": _attitude(c, tbl, key)}
    if ("omega" in tbl) == ("Pi" in tbl):
        raise c.error(key, f"expected exactly one of {key}.omega or {key}.Pi; got "
                      + ("both" if "omega" in tbl else "neither"))
    if "omega" in tbl:
        out["omega"] = _omega(c, tbl["omega"], f"{key}.omega")
    else:
        out["Pi"] = c.vector(tbl["Pi"], f"{key}.Pi")
    return out


def _position(c: _Checker, value: Any, key: str) -> np.ndarray:
    if isinstance(value, list) and len(value) == 2 and all(isinstance(v, list) for v in value):
        return np.stack([c.vector(v, f"{key}[{i}]") for i, v in enumerate(value)])
    return c.vector(value, key)


@dataclass(frozen=True)
class BodiesScenario:
    """A checked scenario of a body in orbit, of two bodies, or of another registered system.

    An ``[orbiting_body]`` section runs :func:`lgvi.simulate_orbit`, a ``[two_body]`` section
    :func:`lgvi.simulate_two_body`, the section of a system that reads its own
    (``lgvi.systems.System.from_scenario``, e.g. ``[chain]`` for :func:`lgvi.simulate_chain`) that
    system (``lgvi run`` runs them all; ``[output]`` takes ``formats = ["npz"]``,
    the only format of their results, and ``plots``). The schema::

        [orbiting_body]                      # a rigid body in a central field
        inertia = [1.0, 2.0, 3.0]            # or matrix = [[...], [...], [...]]  [kg m^2]
        mass = 10.0                          # [kg]
        mu = 3.986004418e14                  # G M of the central body [m^3/s^2]
        position = [7.0e6, 0.0, 0.0]         # x0 [m];  velocity = v0 [m/s]
        velocity = [0.0, 7546.0, 0.0]
        potential = "order2"                 # or "point"
        J2 = 1.08263e-3                      # optional, with radius = 6378137.0 [m]
        [initial]                            # attitude (any form of the rigid body's [initial])
        omega = [0.0, 0.0, 0.001]            # or Pi

        [two_body]                           # two rigid bodies in mutual gravity
        G = 6.674e-11                        # default 1
        potential = "order4"                 # "order2", "order4" or "points"
        position = [1190.0, 0.0, 0.0]        # x2 - x1 (3,) or both [[...], [...]]; velocity alike
        velocity = [0.0, 0.17, 0.0]
        [two_body.body1]                     # and [two_body.body2]
        ellipsoid = [409.5, 400.5, 303.5]    # or inertia, matrix, points = { masses, positions }
        mass = 5.0e11                        # (not with points: their sum)
        omega = [0.0, 0.0, 7.7e-4]           # or Pi; the attitude as in [initial]

        [integrator]                         # h, steps or duration, save_every, tol, max_iter
    """

    kind: str
    name: str
    description: str
    args: tuple[Any, ...]
    kwargs: dict[str, Any]
    h: float
    steps: int
    save_every: int = 1
    source: str = "<dict>"
    text: str = field(default="", repr=False)
    formats: tuple[str, ...] = ("npz",)
    plots: bool = True

    def __repr__(self) -> str:
        return (f"BodiesScenario(kind={self.kind!r}, name={self.name!r}, steps={self.steps}, h={self.h:g}, "
                f"potential={self.kwargs.get('potential')!r}, source={self.source!r})")

    @property
    def samples(self) -> int:
        """Number of saved states, ``steps // save_every + 1``."""
        return self.steps // self.save_every + 1

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "<dict>", *, text: str | None = None) -> "BodiesScenario":
        c = _Checker(source)
        known = _system_sections()
        sections = [k for k in known if k in d]
        if len(sections) != 1:
            raise c.error(None, "a scenario describes one system: one of "
                          + ", ".join(f"[{k}]" for k in known) + f"; got {', '.join(f'[{k}]' for k in sections)}")
        section = sections[0]
        kind = known[section]
        d = c.table(d, "", _BODIES_TOP + (section,))
        if "integrator" not in d:
            raise c.error("integrator", "missing; expected an [integrator] table")
        name = c.string(d.get("name", Path(source).stem if not source.startswith("<") else "scenario"), "name")
        if "name" in d and (problem := name_problem(name)):
            raise c.error("name", problem)
        description = c.string(d.get("description", ""), "description")
        integ = c.table(d["integrator"], "integrator", _BODIES_INTEGRATOR)
        h, steps = _steps(c, integ)
        kw: dict[str, Any] = {}
        save_every = c.integer(integ.get("save_every", 1), "integrator.save_every", minimum=1)
        if steps % save_every:
            raise c.error("integrator.save_every", f"expected a divisor of the number of steps ({steps}) so the "
                          f"final state is saved; got {save_every}")
        if "tol" in integ:
            kw["tol"] = c.number(integ["tol"], "integrator.tol", nonnegative=True)
        if "max_iter" in integ:
            kw["max_iter"] = c.integer(integ["max_iter"], "integrator.max_iter", minimum=1)
        out = c.table(d.get("output", {}), "output", ("formats", "plots"))
        formats: tuple[str, ...] = ("npz",)      # the results of these systems are saved as npz only
        if "formats" in out:
            raw = out["formats"]
            if not isinstance(raw, list) or not raw:
                raise c.expected("output.formats", 'a non-empty array holding "npz"', raw)
            for i, f in enumerate(raw):
                if c.string(f, f"output.formats[{i}]") != "npz":
                    raise c.error(f"output.formats[{i}]", f"the result of an [{section}] scenario is saved as npz "
                                  f"only; got {f!r}")
        plots = c.boolean(out.get("plots", True), "output.plots")
        if section not in _BODIES_SECTIONS:     # a system that reads its own section (System.from_scenario)
            from ..systems import SYSTEMS

            if "initial" in d:
                raise c.error("initial", f"a [{section}] scenario gives its initial state in [{section}]")
            try:
                args, own = SYSTEMS[kind].from_scenario(d[section])
            except (ValueError, TypeError) as exc:
                key, _, rest = str(exc).partition(": ")
                if key.startswith(section) and " " not in key and rest:
                    raise c.error(key, rest) from None
                raise c.error(section, str(exc)) from None
            kw.update(own)
        elif kind == "orbit":
            o = c.table(d[section], "orbiting_body", ("inertia", "matrix", "mass", "mu", "position", "velocity", "potential",
                                           "J2", "radius"))
            for req in ("mass", "mu", "position", "velocity"):
                if req not in o:
                    raise c.expected(f"orbiting_body.{req}", "a number" if req in ("mass", "mu") else "an array of 3 numbers")
            body = _inertia_or_shape(c, o, "orbiting_body", shapes=False)
            init = c.table(d.get("initial", {}), "initial", _ATTITUDE_KEYS + ("omega", "Pi"))
            spin = _spin(c, init, "initial")
            args = (body, c.number(o["mass"], "orbiting_body.mass", positive=True), c.vector(o["position"], "orbiting_body.position"),
                    c.vector(o["velocity"], "orbiting_body.velocity"), spin["R"])
            kw.update(mu=c.number(o["mu"], "orbiting_body.mu", positive=True),
                      potential=c.string(o.get("potential", "order2"), "orbiting_body.potential", ("order2", "point")))
            kw["Pi0" if "Pi" in spin else "omega0"] = spin.get("Pi", spin.get("omega"))
            if "J2" in o:
                kw["J2"] = c.number(o["J2"], "orbiting_body.J2")
                if "radius" not in o:
                    raise c.expected("orbiting_body.radius", "the central body's equatorial radius (a positive number) "
                                     "with orbiting_body.J2")
            if "radius" in o:
                if "J2" not in o:
                    raise c.error("orbiting_body.radius", "only used with orbiting_body.J2; add J2 or remove radius")
                kw["radius"] = c.number(o["radius"], "orbiting_body.radius", positive=True)
        else:
            if "initial" in d:
                raise c.error("initial", "a [two_body] scenario gives each body's attitude and spin in "
                              "[two_body.body1] and [two_body.body2]")
            t = c.table(d[kind], "two_body", ("G", "potential", "position", "velocity", "body1", "body2"))
            for req in ("position", "velocity", "body1", "body2"):
                if req not in t:
                    raise c.expected(f"two_body.{req}", "a table" if req.startswith("body") else
                                     "an array of 3 numbers (x2 - x1) or of two such arrays")
            potential = c.string(t.get("potential", "order2"), "two_body.potential", ("order2", "order4", "points"))
            bodies, masses = [], []
            for i in (1, 2):
                key = f"two_body.body{i}"
                b = c.table(t[f"body{i}"], key, ("inertia", "matrix", "ellipsoid", "points", "mass", "omega", "Pi")
                            + _ATTITUDE_KEYS)
                shape = _inertia_or_shape(c, b, key, shapes=True)
                if "mass" in b:
                    masses.append(c.number(b["mass"], f"{key}.mass", positive=True))
                elif "points" in b:
                    masses.append(None)
                else:
                    raise c.expected(f"{key}.mass", "a positive number (the body's mass)")
                bodies.append((shape, _spin(c, b, key)))
            args = (bodies[0][0], bodies[1][0], masses[0], masses[1], _position(c, t["position"], "two_body.position"),
                    _position(c, t["velocity"], "two_body.velocity"), bodies[0][1]["R"], bodies[1][1]["R"])
            kw.update(potential=potential, G=c.number(t.get("G", 1.0), "two_body.G", positive=True))
            for i, (_, spin) in enumerate(bodies, 1):
                kw[f"Pi{i}_0" if "Pi" in spin else f"omega{i}_0"] = spin.get("Pi", spin.get("omega"))
        sc = cls(kind=kind, name=name, description=description, args=args, kwargs=kw, h=h, steps=steps,
                 save_every=save_every, source=source, text=to_toml(d) if text is None else text,
                 formats=formats, plots=plots)
        try:
            sc._run(check_only=True)
        except (ValueError, TypeError) as exc:
            # the run's own message names its argument first; a key of the section by that name is the key
            word = str(exc).split(" ", 1)[0]
            if section not in _BODIES_SECTIONS and isinstance(d[section], dict) and word in d[section]:
                raise c.error(f"{section}.{word}", str(exc)) from None
            raise c.error(section, str(exc)) from None
        return sc

    def _run(self, check_only: bool = False, progress: Any = False):
        from ..systems.orbit import OrbitRun, simulate_orbit
        from ..systems.two_body import TwoBodyRun, simulate_two_body

        grid = {"h": self.h, "steps": self.steps, "save_every": self.save_every}
        if self.kind not in ("orbit", "two_body"):      # a system that reads its own section
            from ..driver import MemorySink, drive
            from ..systems import SYSTEMS

            run = SYSTEMS[self.kind].run(*self.args, **self.kwargs, **grid)
            return run if check_only else drive(run, MemorySink(run), progress=progress)
        if check_only:      # the library's own validation, without running
            kw = {**self.kwargs, **grid}
            if self.kind == "orbit":
                kw = {"Pi0": None, "omega0": None, "J2": None, "radius": None, "torque": None, "tol": 1e-14,
                      "max_iter": 50, "t0": 0.0, "potential": "order2", **kw}
                body, mass, x0, v0, R0 = self.args
                Pi0 = kw.pop("Pi0")
                return OrbitRun(body, mass, x0, v0, R0, Pi0, **kw)
            kw = {"Pi1_0": None, "Pi2_0": None, "omega1_0": None, "omega2_0": None, "tol": 1e-14, "max_iter": 50,
                  "t0": 0.0, "G": 1.0, **kw}
            return TwoBodyRun(*self.args, **kw)
        fn = simulate_orbit if self.kind == "orbit" else simulate_two_body
        return fn(*self.args, progress=progress, **self.kwargs, **grid)

    def run(self, progress: Any = False):
        """Simulate (:func:`lgvi.simulate_orbit` or :func:`lgvi.simulate_two_body`); the result's
        ``meta`` holds the scenario text, name and source."""
        return self._attached(lambda: self._run(progress=progress))

    def run_stream(self, folder, *, resume: bool = False, progress: Any = False, chunk_steps: int | None = None):
        """Simulate into a crash-safe stream folder (:func:`lgvi.io.streaming.stream_system`) and read
        it back; ``resume=True`` continues an interrupted or killed run bit for bit. Returns what
        :meth:`run` returns, equal to it bit for bit."""
        from .streaming import read_stream, stream_system

        def go():
            stream_system(folder, self.kind, *self.args, progress=progress, resume=resume, chunk_steps=chunk_steps,
                          meta={"scenario_name": self.name}, h=self.h, steps=self.steps, save_every=self.save_every,
                          **self.kwargs)
            return read_stream(folder)

        return self._attached(go)

    def _attached(self, go: Any):
        try:
            traj = go()
        except (KeyboardInterrupt, RuntimeError) as exc:
            part = getattr(exc, "trajectory", None)
            if part is not None:
                exc.trajectory = self.attach(part)
            raise
        return self.attach(traj)

    def attach(self, traj):
        meta = dict(traj.meta)
        meta.update(scenario=self.text, scenario_name=self.name, scenario_source=self.source)
        return replace(traj, meta=meta)


# ------------------------------------------------------------------------------------ shared with section modules
#: The readers the section modules share (:mod:`lgvi.io.scenario_loop` reads ``[spacecraft.body]``,
#: ``[[spacecraft.wheel]]`` and ``[initial]`` with them), under public names.
Checker = _Checker
ATTITUDE_KEYS = _ATTITUDE_KEYS
read_body, read_wheels, read_attitude, read_omega, read_steps = _body, _wheels, _attitude, _omega, _steps
