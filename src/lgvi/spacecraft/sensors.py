"""Sensors as components of the compiled loop: gyro (IMU rate channel), star tracker, magnetometer,
coarse sun sensors and a fine sun sensor.

Each class validates its arguments once, names the argument and the rule in every error, and gives
the rows of the contract (``docs/components.md``): ``params()`` (one float64 row, or one row per
member when ``seed`` is a sequence), ``state0()`` and ``sizes()``. The compiled step of each kind is
in :mod:`lgvi._kernels.sensor_components` (codes 300-399, ``sensor_dispatch``). Noise comes from the
counter-based generator :mod:`lgvi._kernels.random`: the draws of a sensor are a pure function of
``(seed, stream, sample number)``, whatever the thread count, the Dask layout or a resume.

Noise densities follow the usual gyro conventions (IEEE Std 952): the angle random walk ``arw`` in
rad/s^0.5 (= rad/s/sqrt(Hz)) and the rate random walk ``rrw`` in rad/s^1.5; a gyro sampled every
``dt`` then has a white rate noise of standard deviation ``arw / sqrt(dt)`` per sample and a bias
that steps by ``rrw sqrt(dt)`` per sample, so its Allan variance is
``arw^2 / tau + rrw^2 tau / 3`` (the test checks it).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from .._validation import as_float, as_float_array, as_rotation
from ..so3 import exp as _so3_exp
from ..components import Component, ComponentKind, LoopContext, Signal, register_kind
from .._kernels import sensor_components as _k

__all__ = ["Gyro", "StarTracker", "Magnetometer", "CoarseSunSensors", "FineSunSensor", "period_steps",
           "GYRO_BIAS", "ST_TIME", "MAG_TIME", "SUN_TIME"]

#: Own signals of the sensor kinds (the estimator reads the ``*_time`` ones to use each measurement once).
GYRO_BIAS = Signal("gyro_bias", 3, "rad/s", "B", "the gyro's true bias (constant plus rate random walk), for records")
ST_TIME = Signal("st_time", 1, "s", "-", "time of the star tracker measurement on the bus")
MAG_TIME = Signal("mag_time", 1, "s", "-", "time of the magnetometer measurement on the bus")
SUN_TIME = Signal("sun_time", 1, "s", "-", "time of the fine sun sensor measurement on the bus")

_MAX_SEED = 2 ** 53


def describe(value: Any) -> str:
    """A short rendering of a value for error messages."""
    return np.array2string(np.asarray(value), precision=6, threshold=12) if np.ndim(value) else repr(value)


def period_steps(rate: float, h: float, name: str = "rate") -> int:
    """The whole number of dynamics steps ``h`` in the sample period ``rate``; any other rate is refused."""
    rate = as_float(rate, name, positive=True)
    h = as_float(h, "h", positive=True)
    n = round(rate / h)
    if n < 1 or abs(n * h - rate) > 1e-9 * rate:
        raise ValueError(f"{name} must be a whole multiple of the step h = {h!r}, got {rate!r} "
                         f"({rate / h:.6g} steps)")
    return int(n)


def _seeds(seed: Any) -> np.ndarray:
    arr = np.asarray(seed)
    if arr.dtype == bool or not np.issubdtype(arr.dtype, np.integer) or arr.ndim > 1:
        raise TypeError(f"seed must be an integer or a 1-D sequence of integers (one per member), got {describe(seed)}")
    if (arr < 0).any() or (arr >= _MAX_SEED).any():
        raise ValueError(f"seed must lie in [0, 2^53), got {describe(seed)}")
    return arr.astype(np.float64)


def _density(value: Any, name: str) -> float:
    x = as_float(value, name)
    if x < 0.0:
        raise ValueError(f"{name} must be a nonnegative noise density or standard deviation, got {x}")
    return x


def _angle(value: Any, name: str, upper: float) -> float:
    x = as_float(value, name)
    if not 0.0 <= x <= upper:
        raise ValueError(f"{name} must be an angle in [0, {upper:.6g}] rad, got {x}")
    return x


def _frame(value: Any, name: str) -> np.ndarray:
    """A (3, 3) rotation matrix, or a (3,) rotation vector turned into one, or None (identity)."""
    if value is None:
        return np.eye(3)
    arr = np.asarray(value, dtype=float) if not hasattr(value, "as_matrix") else value
    if isinstance(arr, np.ndarray) and arr.shape == (3,):
        return np.asarray(_so3_exp(as_float_array(arr, name, (3,))), dtype=float)
    return as_rotation(value, name)


class Sensor(Component):
    """Common part: ``rate`` (seconds between samples, or None: every step), ``seed``, ``stream``."""

    kind: str = ""

    def __init__(self, rate: float | None, seed: Any, stream: int) -> None:
        self.rate: Any = None if rate is None else as_float(rate, "rate", positive=True)
        self.seed: np.ndarray = _seeds(seed)
        if isinstance(stream, (bool, np.bool_)) or not isinstance(stream, (int, np.integer)) \
                or not 0 <= stream < _MAX_SEED:
            raise ValueError(f"stream must be an integer in [0, 2^53), got {describe(stream)}")
        self.stream: int = int(stream)

    def _row(self, rest: Any) -> np.ndarray:
        """``(seed, stream, *rest)``: one row, or one per member's seed; ``rest`` the values (a list of
        floats or a 1-D array)."""
        if self.seed.ndim == 0:
            return np.array([float(self.seed), float(self.stream), *rest], dtype=np.float64)
        rest = np.asarray(rest, dtype=np.float64)
        rows = np.empty((self.seed.size, 2 + rest.size))
        rows[:, 0] = self.seed
        rows[:, 1] = self.stream
        rows[:, 2:] = rest
        return rows

    def state0(self) -> np.ndarray:
        return np.zeros(1)

    def sizes(self) -> dict[str, int]:
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}(rate={self.rate}, stream={self.stream})"


class Gyro(Sensor):
    """A three-axis rate gyro with the corruptions of Basilisk's ``imuSensor`` (rate channel).

    ``gyro_B = sat(quant(scale * (M omega + bias + b_rw + arw / sqrt(dt) n)))``, with ``b_rw`` the
    rate random walk (steps of ``rrw sqrt(dt)`` per sample, from 0), applied in Basilisk's order:
    misalignment, errors, scale factor, quantisation (``rounding="zero"``: Basilisk's default
    ``Discretize``, or ``"nearest"``), saturation. The walk is unbounded by default (a pure rate
    random walk, as the Allan variance specifications state it); ``walk_bound`` bounds it as
    Basilisk's ``imuSensor`` does with ``walkBoundsGyro`` (its Gauss-Markov state with the identity
    propagation matrix: each step ``b_rw <- clip(b_rw + rrw sqrt(dt) n, -walk_bound, walk_bound)``
    per axis; docs/estimation.md).

    Parameters
    ----------
    rate : float
        Sample period in seconds (the noise per sample depends on it), a whole multiple of ``h``.
    arw : float
        Angle random walk, rad/s^0.5 (>= 0).
    rrw : float
        Rate random walk, rad/s^1.5 (>= 0).
    bias : (3,) rad/s, constant bias.  scale : (3,) or float, scale factor (1: none).
    misalignment : (3,) rotation vector or (3, 3) matrix taking body components to gyro axes
        (any invertible matrix: non-orthogonal axes too); None: aligned.
    saturation : float, rad/s (None: none).  lsb : float, rad/s (None: no quantisation).
    output : ``"rate"`` (the rate at the sample, Basilisk's ``omega_PN_P``) or ``"mean"`` (the mean
        rate over the sample interval, ``log(R_prev^T R) / dt``: Basilisk's ``prv_PN / dt``, an
        integrating gyro; the first sample gives the rate). The MEKF propagates either exactly as
        its ``gyro_output`` says.
    walk_bound : float or (3,), rad/s, optional
        Bound of the rate random walk on each gyro axis (> 0; None: unbounded): the walk is clipped
        to ``[-walk_bound, walk_bound]`` after each step, as Basilisk's ``walkBoundsGyro``. The
        constant ``bias`` is not bounded. Basilisk warns when a bound is below three standard
        deviations of the walk's step; so does this class (a ``UserWarning``).
    seed, stream : the random stream.
    """

    kind = "gyro"

    def __init__(self, *, rate: float, arw: float = 0.0, rrw: float = 0.0, bias: Any = (0.0, 0.0, 0.0),
                 scale: Any = 1.0, misalignment: Any = None, saturation: float | None = None,
                 lsb: float | None = None, rounding: str = "zero", output: str = "rate",
                 walk_bound: Any = None, seed: Any = 0, stream: int = 1) -> None:
        super().__init__(rate, seed, stream)
        self.arw: float = _density(arw, "arw")
        self.rrw: float = _density(rrw, "rrw")
        self.bias: np.ndarray = as_float_array(bias, "bias", (3,))
        self.scale: np.ndarray = np.broadcast_to(as_float_array(scale, "scale"), (3,)).astype(float) \
            if np.ndim(scale) == 0 else as_float_array(scale, "scale", (3,))
        if (self.scale == 0.0).any():
            raise ValueError(f"scale must be non-zero on each axis, got {describe(self.scale)}")
        if misalignment is not None and np.shape(misalignment) == (3, 3):
            M = as_float_array(misalignment, "misalignment", (3, 3))
            if abs(np.linalg.det(M)) < 1e-12:
                raise ValueError(f"misalignment must be an invertible matrix, got {describe(M)}")
            self.misalignment: np.ndarray = M
        else:
            self.misalignment = _frame(misalignment, "misalignment").T     # body -> gyro axes
        self.saturation: float = math.inf if saturation is None else as_float(saturation, "saturation", positive=True)
        self.lsb: float = 0.0 if lsb is None else as_float(lsb, "lsb", positive=True)
        if rounding not in ("zero", "nearest"):
            raise ValueError(f"rounding must be 'zero' or 'nearest', got {rounding!r}")
        self.rounding = rounding
        if output not in ("rate", "mean"):
            raise ValueError(f"output must be 'rate' (the rate at the sample) or 'mean' (the mean rate over the "
                             f"sample interval), got {output!r}")
        self.output = output
        self.walk_bound: np.ndarray | None = None
        if walk_bound is not None:
            wb = np.broadcast_to(as_float_array(walk_bound, "walk_bound"), (3,)).astype(float) \
                if np.ndim(walk_bound) == 0 else as_float_array(walk_bound, "walk_bound", (3,))
            if not (wb > 0.0).all():
                raise ValueError(f"walk_bound must be positive on each axis (rad/s; None: unbounded), got {describe(wb)}")
            step = self.rrw * math.sqrt(self.rate)
            if (wb < 3.0 * step).any():
                warnings.warn(f"Gyro: walk_bound {describe(wb)} rad/s is below three standard deviations of the walk's "
                              f"step per sample (rrw sqrt(rate) = {step:.6g} rad/s): the walk is mostly at its bounds",
                              UserWarning, stacklevel=2)
            self.walk_bound = wb

    def params(self) -> np.ndarray:
        wb = self.walk_bound
        bound = [math.inf] * 3 if wb is None else np.asarray(wb, dtype=np.float64).tolist()
        return self._row([self.rate, self.arw, self.rrw, *self.misalignment.ravel().tolist(), *self.bias.tolist(),
                          *self.scale.tolist(), self.saturation, self.lsb, float(self.rounding == "nearest"),
                          float(self.output == "mean"), *bound, self.arw / math.sqrt(self.rate),
                          self.rrw * math.sqrt(self.rate)])

    def state0(self) -> np.ndarray:
        return np.zeros(9)


class StarTracker(Sensor):
    """A star tracker: the attitude with a small rotation error in its case frame, as a quaternion.

    ``R_meas = R C Exp(e) C^T = R Exp(C e)``, ``e = (sigma_cross n0, sigma_cross n1, sigma_about n2)``
    in the case frame (boresight: case z), so the error's standard deviation is ``sigma_cross``
    about each axis across the boresight and ``sigma_about`` about it. Writes ``st_q`` (scalar-last,
    scalar part >= 0), ``st_valid`` (0 while the sun is within ``sun_exclusion`` of the boresight, or
    the Earth's limb within ``earth_exclusion``), ``st_time``.

    ``case`` is the rotation taking case components to body components (a (3, 3) matrix or a (3,)
    rotation vector; None: aligned). ``sun_exclusion``/``earth_exclusion`` (rad; None: off) need the
    environment's ``sun_N`` and ``r_N`` on the bus.
    """
    earth_exclusion: float | None
    sun_exclusion: float | None

    kind = "star_tracker"

    def __init__(self, *, rate: float | None = None, sigma_cross: float, sigma_about: float, case: Any = None,
                 sun_exclusion: float | None = None, earth_exclusion: float | None = None,
                 earth_radius: float = 6378137.0, seed: Any = 0, stream: int = 2) -> None:
        super().__init__(rate, seed, stream)
        self.sigma_cross: float = _density(sigma_cross, "sigma_cross")
        self.sigma_about: float = _density(sigma_about, "sigma_about")
        self.case: np.ndarray = _frame(case, "case")
        self.sun_exclusion = None if sun_exclusion is None else _angle(sun_exclusion, "sun_exclusion", math.pi)
        self.earth_exclusion = None if earth_exclusion is None else _angle(earth_exclusion, "earth_exclusion",
                                                                           math.pi)
        self.earth_radius: float = as_float(earth_radius, "earth_radius", positive=True)

    def setup(self, ctx: LoopContext) -> None:
        """The exclusions need the environment: a sun model for ``sun_N``, an orbit for ``r_N``."""
        sc = ctx.spacecraft
        if self.sun_exclusion is not None and not any(getattr(c, "kind", "") == "sun" for c in sc.components()):
            raise ValueError("StarTracker(sun_exclusion=...) needs the sun's direction: give "
                             "Spacecraft(..., environment=[lgvi.environment.Sun()])")
        if self.earth_exclusion is not None and sc.orbit is None:
            raise ValueError("StarTracker(earth_exclusion=...) needs the spacecraft's position: give Spacecraft(..., orbit=...)")

    def params(self) -> np.ndarray:
        cos_sun = 2.0 if self.sun_exclusion is None else math.cos(self.sun_exclusion)
        earth = -1.0 if self.earth_exclusion is None else self.earth_exclusion
        return self._row([self.sigma_cross, self.sigma_about, *self.case.ravel().tolist(), cos_sun, earth,
                          self.earth_radius, math.cos(earth), math.sin(earth)])


class Magnetometer(Sensor):
    """A three-axis magnetometer: ``mag_B = M R^T B_N + bias + sigma n`` (tesla).

    ``misalignment``: (3,) rotation vector or (3, 3) matrix taking body components to sensor axes.
    """

    kind = "magnetometer"

    def __init__(self, *, rate: float | None = None, sigma: float, bias: Any = (0.0, 0.0, 0.0),
                 misalignment: Any = None, seed: Any = 0, stream: int = 3) -> None:
        super().__init__(rate, seed, stream)
        self.sigma: float = _density(sigma, "sigma")
        self.bias: np.ndarray = as_float_array(bias, "bias", (3,))
        if misalignment is not None and np.shape(misalignment) == (3, 3):
            self.misalignment: np.ndarray = as_float_array(misalignment, "misalignment", (3, 3))
        else:
            self.misalignment = _frame(misalignment, "misalignment").T

    def params(self) -> np.ndarray:
        return self._row(np.concatenate([[self.sigma], self.misalignment.ravel(), self.bias]))


class CoarseSunSensors(Sensor):
    """Coarse sun sensors (cosine detectors), one output per head in ``css``.

    ``css_i = clip(scale * shadow * cos(a_i) + sigma n_i, 0, max_output)`` while the sun is within
    the head's field of view (``cos(a_i) >= cos(fov)``, and in front of it), ``clip(sigma n_i, 0, ..)``
    otherwise; ``a_i`` is the angle between the head's normal and the sun, ``shadow`` the
    environment's visible fraction of the solar disc (eclipse). Earth albedo is not modelled.
    """

    kind = "coarse_sun_sensors"

    def __init__(self, normals: Any, *, rate: float | None = None, sigma: float = 0.0, scale: float = 1.0,
                 fov: float = math.pi / 2, max_output: float | None = None, seed: Any = 0, stream: int = 4) -> None:
        super().__init__(rate, seed, stream)
        n = as_float_array(normals, "normals", (None, 3))
        if n.shape[0] < 1:
            raise ValueError("normals must hold at least one head, got none")
        norms = np.linalg.norm(n, axis=1)
        if (norms == 0.0).any():
            raise ValueError(f"normals must be non-zero vectors, got {describe(n)}")
        self.normals: Any = n / norms[:, None]
        self.sigma: float = _density(sigma, "sigma")
        self.scale: float = as_float(scale, "scale", positive=True)
        self.fov: float = _angle(fov, "fov", math.pi / 2)
        self.max_output: float = math.inf if max_output is None else as_float(max_output, "max_output", positive=True)

    def params(self) -> np.ndarray:
        return self._row(np.concatenate([[self.sigma, len(self.normals), self.scale, math.cos(self.fov),
                                          self.max_output], self.normals.ravel()]))

    def sizes(self) -> dict[str, int]:
        return {"css": len(self.normals)}


class FineSunSensor(Sensor):
    """A fine (two-axis) sun sensor: the sun direction in the body frame, ``sun_B``, turned by a small
    random angle across the sun line (``sigma`` rad about each of two axes), ``sun_valid`` = 1 while
    the sun is within ``fov`` of the boresight (sensor z, ``mount`` taking sensor components to
    body components) and at least ``min_shadow`` of the solar disc is visible."""

    kind = "fine_sun_sensor"

    def __init__(self, *, rate: float | None = None, sigma: float, mount: Any = None, fov: float = math.radians(60),
                 min_shadow: float = 0.5, seed: Any = 0, stream: int = 5) -> None:
        super().__init__(rate, seed, stream)
        self.sigma: float = _density(sigma, "sigma")
        self.mount: np.ndarray = _frame(mount, "mount")
        self.fov: float = _angle(fov, "fov", math.pi)
        self.min_shadow: float = as_float(min_shadow, "min_shadow")
        if not 0.0 <= self.min_shadow <= 1.0:
            raise ValueError(f"min_shadow must lie in [0, 1], got {self.min_shadow}")

    def params(self) -> np.ndarray:
        return self._row(np.concatenate([[self.sigma], self.mount.ravel(), [math.cos(self.fov), self.min_shadow]]))


def _register() -> None:
    register_kind(ComponentKind("gyro", "sensor", _k.GYRO, _k.gyro_step, ("omega", "R"), ("gyro_B", "gyro_bias"),
                                cls=Gyro, own=(GYRO_BIAS,), doc=Gyro.__doc__.splitlines()[0]))
    register_kind(ComponentKind("star_tracker", "sensor", _k.STAR_TRACKER, _k.star_tracker_step,
                                ("R", "sun_N", "r_N"), ("st_q", "st_valid", "st_time"), cls=StarTracker,
                                own=(ST_TIME,), doc=StarTracker.__doc__.splitlines()[0],
                                extra={"zeros": ("sun_N", "r_N"), "initial": {"st_time": math.nan}}))
    register_kind(ComponentKind("magnetometer", "sensor", _k.MAGNETOMETER, _k.magnetometer_step, ("R", "B_N"),
                                ("mag_B", "mag_time"), cls=Magnetometer, own=(MAG_TIME,),
                                doc=Magnetometer.__doc__.splitlines()[0], extra={"initial": {"mag_time": math.nan}}))
    register_kind(ComponentKind("coarse_sun_sensors", "sensor", _k.COARSE_SUN_SENSORS, _k.coarse_sun_sensors_step,
                                ("R", "sun_N", "shadow"), ("css",), cls=CoarseSunSensors,
                                doc=CoarseSunSensors.__doc__.splitlines()[0]))
    register_kind(ComponentKind("fine_sun_sensor", "sensor", _k.FINE_SUN_SENSOR, _k.fine_sun_sensor_step,
                                ("R", "sun_N", "shadow"), ("sun_B", "sun_valid", "sun_time"), cls=FineSunSensor,
                                own=(SUN_TIME,), doc=FineSunSensor.__doc__.splitlines()[0],
                                extra={"initial": {"sun_time": math.nan}}))


_register()
