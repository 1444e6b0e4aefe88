"""The atmosphere, as components of the compiled loop (``docs/environment.md``).

Both kinds read ``r_N``, ``v_N`` and write ``density`` (kg/m^3) and ``v_rel_N``, the velocity
relative to an atmosphere that turns with the Earth about the inertial z axis (TEME's, the Earth's
rotation axis): ``v_rel = v - omega e_z x r`` (``omega = 0``: a still atmosphere, as Basilisk's
facet drag without a wind message).

* :class:`ExponentialAtmosphere` (kind ``"exponential_atmosphere"``, code 110): Basilisk's
  ``exponentialAtmosphere``: ``rho = rho_0 exp(-(|r| - R) / H)`` (a spherical planet).
* :class:`TabulatedAtmosphere` (kind ``"tabulated_atmosphere"``, code 111): a density tabulated
  along the orbit every ``dt`` and interpolated by the cubic spline of ``log rho``;
  :meth:`TabulatedAtmosphere.from_msis` fills the table from NRLMSIS 2.x (the ``pymsis`` package,
  the ``atmosphere`` extra) along an lgvi orbit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._kernels.environment_components import (EXPONENTIAL_ATMOSPHERE, TABULATED_ATMOSPHERE,
                                               exponential_atmosphere_step, tabulated_atmosphere_step)
from .._validation import as_float, as_float_array
from ..components import Component, ComponentKind, LoopContext, member_coefficient, member_rows, register_kind
from ._evaluate import evaluate
from .clock import Clock
from .field import WGS84_A, WGS84_F
from .sun import EARTH_RADIUS

__all__ = ["ExponentialAtmosphere", "TabulatedAtmosphere", "ecef_to_geodetic", "EARTH_ROTATION"]

#: The Earth's rotation rate (rad/s, IERS conventions).
EARTH_ROTATION = 7.292115e-5
#: Highest altitude (m) NRLMSIS is tabulated at (the model's documented range).
MSIS_MAX_ALTITUDE = 1000e3


def _short(value: Any) -> str:
    """A coefficient in a repr: the number, or the members' values."""
    return f"{value:g}" if np.ndim(value) == 0 else "[" + ", ".join(f"{v:g}" for v in value) + "]"


def _rate(rate: Any) -> float | None:
    return None if rate is None else as_float(rate, "rate", positive=True)


class ExponentialAtmosphere(Component):
    """``rho = base_density exp(-(|r| - planet_radius) / scale_height)`` (Basilisk's exponentialAtmosphere).

    Parameters
    ----------
    base_density : float
        kg/m^3 at the surface (Basilisk's ``baseDensity``; its example for the Earth 1.217).
    scale_height : float
        m (Basilisk's ``scaleHeight``; its example 8500 m).
    planet_radius : float
        m (Basilisk's ``planetRadius``).
    omega : float
        Rotation rate of the atmosphere about z (rad/s); 0 for a still one.
    min_altitude, max_altitude : float
        Basilisk's ``envMinReach``, ``envMaxReach`` (m): below ``min_altitude`` the run stops
        (status 3), above ``max_altitude`` the density is 0.

    Each coefficient may also be a 1-D array, one value per member of an ensemble
    (``lgvi.simulate_ensemble``): :meth:`params` then gives one row per member.

    :meth:`from_reference` builds one from a density at a reference altitude.
    """

    kind = "exponential_atmosphere"

    def __init__(self, base_density: float = 1.217, scale_height: float = 8500.0, *,
                 planet_radius: float = EARTH_RADIUS, omega: float = EARTH_ROTATION, min_altitude: float = 0.0,
                 max_altitude: float = math.inf, rate: float | None = None):
        self.base_density: Any = member_coefficient(base_density, "base_density", positive=True)
        self.scale_height: Any = member_coefficient(scale_height, "scale_height", positive=True)
        self.planet_radius: Any = member_coefficient(planet_radius, "planet_radius", positive=True)
        self.omega: Any = member_coefficient(omega, "omega")
        self.min_altitude: Any = member_coefficient(min_altitude, "min_altitude")
        self.max_altitude: Any = member_coefficient(max_altitude, "max_altitude", infinite=True)
        low, high = np.broadcast_arrays(self.min_altitude, self.max_altitude)
        if not np.all(high > low):
            i = int(np.flatnonzero(~(np.atleast_1d(high) > np.atleast_1d(low)))[0])
            raise ValueError(f"max_altitude must be above min_altitude ({np.atleast_1d(low)[i]:g} m), got "
                             f"{np.atleast_1d(high)[i]:g}" + (f" for member {i}" if np.ndim(high) else ""))
        self.params()                                  # the members' counts agree
        self.rate: Any = _rate(rate)

    @classmethod
    def from_reference(cls, altitude: float, density: float, scale_height: float, **kwargs: Any
                       ) -> "ExponentialAtmosphere":
        """The exponential through ``density`` (kg/m^3) at ``altitude`` (m) with ``scale_height`` (m)."""
        altitude = as_float(altitude, "altitude")
        density = as_float(density, "density", positive=True)
        scale_height = as_float(scale_height, "scale_height", positive=True)
        return cls(density * math.exp(altitude / scale_height), scale_height, **kwargs)

    def __repr__(self) -> str:
        return f"ExponentialAtmosphere({_short(self.base_density)}, {_short(self.scale_height)})"

    def params(self) -> np.ndarray:
        """``[base_density, scale_height, planet_radius, omega, min_altitude, max_altitude]``, (6,) or
        (B, 6) with coefficients given per member."""
        return member_rows(self.base_density, self.scale_height, self.planet_radius, self.omega, self.min_altitude,
                           self.max_altitude, what="ExponentialAtmosphere: the coefficients given per member")

    def state0(self) -> np.ndarray:
        return np.zeros(0)

    def sizes(self) -> dict[str, int]:
        return {}

    def evaluate(self, r_N: Any, v_N: Any = (0.0, 0.0, 0.0), t: Any = 0.0, *, member: int = 0
                 ) -> dict[str, np.ndarray]:
        """``density`` (n,) and ``v_rel_N`` (n, 3) at positions ``r_N`` and velocities ``v_N`` (with
        coefficients per member: ``member``'s)."""
        return evaluate(self, t, member=member, r_N=r_N, v_N=v_N)


def ecef_to_geodetic(r: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS84 geodetic latitude, longitude (degrees) and height (m) of Earth-fixed points ``r`` (..., 3).

    Fixed-point iteration on the latitude (converged to round-off in six steps below 10 000 km);
    ``h = p cos(lat) + z sin(lat) - a^2 / N``, valid at the poles too."""
    r = as_float_array(r, "r")
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    e2 = WGS84_F * (2.0 - WGS84_F)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1.0 - e2))
    for _ in range(6):
        N = WGS84_A / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
        h = p * np.cos(lat) + z * np.sin(lat) - WGS84_A * WGS84_A / N
        lat = np.arctan2(z, p * (1.0 - e2 * N / (N + h)))
    N = WGS84_A / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
    h = p * np.cos(lat) + z * np.sin(lat) - WGS84_A * WGS84_A / N
    return np.degrees(lat), np.degrees(np.arctan2(y, x)), h


class TabulatedAtmosphere(Component):
    """A density tabulated along the orbit, ``density[k]`` at ``t0 + k dt``, interpolated in the loop
    by the not-a-knot cubic spline of ``log rho`` (evaluated as cubic Hermite pieces with the spline's
    slopes). Outside ``[t0, t0 + (K - 1) dt]`` the run stops (status 3).

    Parameters
    ----------
    t0, dt : float
        Seconds (the run's clock) of the first sample and between samples.
    density : (K,) array, or (B, K): one table per member of an ensemble
        kg/m^3, positive, ``K >= 4``.
    omega : float, or (B,) one per member
        Rotation rate of the atmosphere about z (rad/s).
    """

    kind = "tabulated_atmosphere"

    def __init__(self, t0: float, dt: float, density: Any, *, omega: float = EARTH_ROTATION,
                 rate: float | None = None):
        self.t0: float = as_float(t0, "t0")
        self.dt: float = as_float(dt, "dt", positive=True)
        rho = as_float_array(density, "density")
        if rho.ndim not in (1, 2):
            raise ValueError(f"density must be a (K,) table or (B, K), one table per member, got shape {rho.shape}")
        if rho.shape[-1] < 4:
            raise ValueError(f"density must have at least 4 samples (a cubic spline), got {rho.shape[-1]}")
        if not np.all(rho > 0.0):
            i = tuple(int(j) for j in np.argwhere(~(rho > 0.0))[0])
            raise ValueError(f"density must be positive (kg/m^3), got {rho[i]} at index {i if rho.ndim > 1 else i[0]}")
        self.density = rho
        self.omega: Any = member_coefficient(omega, "omega")
        self.rate: Any = _rate(rate)
        from scipy.interpolate import CubicSpline

        K = rho.shape[-1]
        spline = CubicSpline(self.t0 + self.dt * np.arange(K), np.log(rho), axis=rho.ndim - 1)
        self._slopes = spline(self.t0 + self.dt * np.arange(K), 1)
        self.params()                                  # the members' counts agree

    @property
    def span(self) -> tuple[float, float]:
        """The times the table covers (s)."""
        return self.t0, self.t0 + self.dt * (self.density.shape[-1] - 1)

    @classmethod
    def from_msis(cls, orbit: Any, epoch: Any, duration: float, *, dt: float = 10.0, f107: float | None = 150.0,
                  f107a: float | None = 150.0, ap: float | None = 4.0, version: float = 2.1,
                  omega: float = EARTH_ROTATION, rate: float | None = None) -> "TabulatedAtmosphere":
        """NRLMSIS (``pymsis``) along ``orbit`` from ``t = 0`` to ``duration`` every ``dt`` seconds.

        Parameters
        ----------
        orbit : an lgvi orbit
            Anything with ``position_velocity(t)`` (inertial TEME positions, m).
        epoch : datetime.datetime, numpy.datetime64 or Clock
            UTC date of ``t = 0``; the Earth-fixed positions turn by GMST (:class:`Clock`).
        f107, f107a, ap : float or None
            Daily F10.7 of the previous day, its 81-day mean, and the daily Ap (all 3-hour values
            set to it), held over the table. ``None`` for all three: the historical values that
            pymsis reads from its space-weather file (it downloads it when absent; there is no
            network here, so the file must be in pymsis' cache).
        version : float
            NRLMSIS version (2.1, 2.0; 0 for NRLMSISE-00).
        """
        try:
            import pymsis
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ModuleNotFoundError("TabulatedAtmosphere.from_msis needs pymsis: pip install 'lgvi[atmosphere]'"
                                      ) from exc
        clock = epoch if isinstance(epoch, Clock) else Clock(epoch)
        duration = as_float(duration, "duration", positive=True)
        dt = as_float(dt, "dt", positive=True)
        given = [v is None for v in (f107, f107a, ap)]
        if any(given) and not all(given):
            raise ValueError(f"f107, f107a and ap must all be given or all be None (read from pymsis' file), got "
                             f"f107={f107!r}, f107a={f107a!r}, ap={ap!r}")
        K = int(math.ceil(duration / dt)) + 1
        t = dt * np.arange(K)
        lat, lon, alt = msis_track(orbit, clock, t)
        dates = np.datetime64(clock.epoch, "us") + (t * 1e6).astype("timedelta64[us]")
        kw: dict[str, Any] = {}
        if f107 is not None:
            f107, f107a, ap = (as_float(f107, "f107", positive=True), as_float(f107a, "f107a", positive=True),
                               as_float(ap, "ap"))
            kw = dict(f107s=np.full(K, f107), f107as=np.full(K, f107a), aps=np.full((K, 7), ap))
        out = pymsis.calculate(dates, lon, lat, alt / 1e3, version=version, **kw)
        rho = np.asarray(out[:, 0], dtype=np.float64)
        return cls(0.0, dt, rho, omega=omega, rate=rate)

    def setup(self, ctx: LoopContext) -> None:
        """The table must cover the run (seconds of the run's clock), checked before any step."""
        lo, hi = self.span
        a, b = min(ctx.t0, ctx.t1), max(ctx.t0, ctx.t1)
        if a < lo or b > hi:
            raise ValueError(f"TabulatedAtmosphere: the run's times [{a:g}, {b:g}] s must lie in the table's span "
                             f"[{lo:g}, {hi:g}] s")

    def __repr__(self) -> str:
        per = f", {self.density.shape[0]} members" if self.density.ndim == 2 else ""
        return f"TabulatedAtmosphere(t0={self.t0:g}, dt={self.dt:g}, {self.density.shape[-1]} samples{per})"

    def params(self) -> np.ndarray:
        """``[omega, t0, dt, K, log density (K), slopes of the spline of log density (K)]``, (2K + 4,)
        or (B, 2K + 4) with tables or ``omega`` given per member."""
        log_rho = np.log(self.density)
        return member_rows(self.omega, self.t0, self.dt, self.density.shape[-1], np.atleast_2d(log_rho),
                           np.atleast_2d(self._slopes), what="TabulatedAtmosphere: density (B, K) and omega (B,)")

    def state0(self) -> np.ndarray:
        return np.zeros(0)

    def sizes(self) -> dict[str, int]:
        return {}

    def evaluate(self, t: Any, r_N: Any = (0.0, 0.0, 0.0), v_N: Any = (0.0, 0.0, 0.0), *, member: int = 0
                 ) -> dict[str, np.ndarray]:
        """``density`` (n,) and ``v_rel_N`` (n, 3) at times ``t``; a time outside the table raises."""
        tt = np.atleast_1d(as_float_array(t, "t"))
        lo, hi = self.span
        if np.any((tt < lo) | (tt > hi)):
            bad = tt[(tt < lo) | (tt > hi)][0]
            raise ValueError(f"t must lie in the table's span [{lo:g}, {hi:g}] s, got {bad:g}")
        return evaluate(self, tt, member=member, r_N=r_N, v_N=v_N)


def msis_track(orbit: Any, clock: Clock, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geodetic latitude, longitude (deg) and height (m) of ``orbit`` at ``t``; heights must lie in
    NRLMSIS' range, ``0 < h <= 1000 km``."""
    if not callable(getattr(orbit, "position_velocity", None)):
        raise TypeError(f"orbit must have a position_velocity(t) method (an lgvi.environment orbit), got "
                        f"{type(orbit).__name__}")
    r, _ = orbit.position_velocity(t)
    theta = clock.gmst(t)
    c, s = np.cos(theta), np.sin(theta)
    ecef = np.stack([c * r[:, 0] + s * r[:, 1], -s * r[:, 0] + c * r[:, 1], r[:, 2]], axis=-1)
    lat, lon, h = ecef_to_geodetic(ecef)
    bad = np.flatnonzero(~((h > 0.0) & (h <= MSIS_MAX_ALTITUDE)))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"orbit must stay between the surface and {MSIS_MAX_ALTITUDE / 1e3:g} km (NRLMSIS' range), "
                         f"got a height of {h[i] / 1e3:.3f} km at t = {t[i]:g} s")
    return lat, lon, h


register_kind(ComponentKind("exponential_atmosphere", "environment", EXPONENTIAL_ATMOSPHERE,
                            exponential_atmosphere_step, reads=("r_N", "v_N"), writes=("density", "v_rel_N"),
                            cls=ExponentialAtmosphere, doc="exponential density, co-rotating atmosphere"))
register_kind(ComponentKind("tabulated_atmosphere", "environment", TABULATED_ATMOSPHERE, tabulated_atmosphere_step,
                            reads=("r_N", "v_N"), writes=("density", "v_rel_N"), cls=TabulatedAtmosphere,
                            doc="density tabulated along the orbit (NRLMSIS through pymsis), co-rotating"))
