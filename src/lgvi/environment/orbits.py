"""Orbits that drive the environment: circular, Kepler, J2-secular and SGP4 (from a TLE).

Each orbit gives ``position_velocity(t) -> (r, v)``, vectorised over ``t`` (seconds since the
orbit's epoch; ``(..., 3)`` arrays, metres and metres per second, inertial frame) and
``sample(t) -> {"r": r, "v": v}``. :class:`OrbitEnvironment` adds the geomagnetic field in
inertial components (and optionally the nadir-pointing reference) for
``lgvi.simulate(..., environment=...)``.

Frames: the inertial frame is the Earth-centred frame of the orbit elements; for :class:`SGP4Orbit`
it is SGP4's TEME. The Earth-fixed frame is the inertial one turned about ``e3`` by the Greenwich
mean sidereal time (IAU 1982, UT1 taken as UTC, polar motion and the equation of the equinoxes
neglected: the TEME-to-pseudo-Earth-fixed rotation SGP4 users apply), so the field model sees
``r_ecef = R3(gmst) r``.

Angles are radians. The local-vertical local-horizontal frame (:func:`lvlh_frame`) is that of
:class:`lgvi.torques.GravityGradient`: ``x`` along the velocity (for a circular orbit), ``y``
against the orbit normal, ``z`` to nadir.
"""

from __future__ import annotations

import datetime as _dt
import math
from typing import Any

import numpy as np

from .._validation import as_float, as_float_array
from .field import SphericalHarmonicField, decimal_year

__all__ = ["MU_EARTH", "J2_EARTH", "R_EARTH", "Orbit", "KeplerOrbit", "CircularOrbit", "J2Orbit", "SGP4Orbit",
           "OrbitEnvironment", "solve_kepler", "lvlh_frame", "nadir_reference", "gmst"]

#: Earth's gravitational parameter (m^3/s^2, EGM2008/WGS84), J2 and its reference radius (m).
MU_EARTH = 3.986004418e14
J2_EARTH = 1.08262668e-3
R_EARTH = 6378137.0


def solve_kepler(M: Any, e: float, *, tol: float = 1e-15, max_iter: int = 60) -> np.ndarray:
    """Eccentric anomaly ``E`` with ``E - e sin E = M``, elliptic ``0 <= e < 1``, vectorised over ``M``.

    Newton's method from Danby's start ``E0 = M + 0.85 e sign(sin M)`` on ``M`` reduced to
    ``(-pi, pi]``, converging for every ``M`` and every ``e < 1`` (also ``e`` near 0 and near 1);
    the result keeps ``M``'s revolutions. Raises :class:`lgvi.ConvergenceError` if it does not
    reach ``|E - e sin E - M| <= tol (1 + |M|)`` in ``max_iter`` iterations.
    """
    from ..errors import ConvergenceError

    M = as_float_array(M, "M")
    e = as_float(e, "e")
    if not 0.0 <= e < 1.0:
        raise ValueError(f"e must satisfy 0 <= e < 1 (an ellipse), got {e}")
    if M.ndim == 0:                                # one value: the same iteration on floats
        Mf = float(M)
        turns = round(Mf / (2.0 * math.pi))
        m = Mf - 2.0 * math.pi * turns
        Ef = m + 0.85 * e * math.copysign(1.0, math.sin(m)) if math.sin(m) != 0.0 else m
        for _ in range(max_iter):
            f = Ef - e * math.sin(Ef) - m
            Ef -= f / (1.0 - e * math.cos(Ef))
            if abs(f) <= tol * (1.0 + abs(m)):
                return np.array(Ef + 2.0 * math.pi * turns)
        res = abs(Ef - e * math.sin(Ef) - m)
        if res > 1e-12:
            raise ConvergenceError(f"Kepler's equation not solved in {max_iter} iterations (e = {e}, residual "
                                   f"{res:.3g})", residual=res, iterations=max_iter)
        return np.array(Ef + 2.0 * math.pi * turns)
    turns = np.round(M / (2.0 * np.pi))
    m = M - 2.0 * np.pi * turns                  # (-pi, pi]
    E = m + 0.85 * e * np.sign(np.sin(m))
    for _ in range(max_iter):
        f = E - e * np.sin(E) - m
        E = E - f / (1.0 - e * np.cos(E))
        if np.all(np.abs(f) <= tol * (1.0 + np.abs(m))):
            break
    else:
        res = float(np.max(np.abs(E - e * np.sin(E) - m)))
        if res > 1e-12:
            raise ConvergenceError(f"Kepler's equation not solved in {max_iter} iterations (e = {e}, residual "
                                   f"{res:.3g})", residual=res, iterations=max_iter)
    return E + 2.0 * np.pi * turns


def _times(t: Any) -> np.ndarray:
    return as_float_array(t, "t")


def _rotation(raan: Any, inc: Any, argp: Any) -> np.ndarray:
    """Perifocal to inertial, ``R3(-raan) R1(-inc) R3(-argp)`` (..., 3, 3)."""
    if np.ndim(raan) == 0 and np.ndim(argp) == 0:
        cO, sO, ci, si = math.cos(raan), math.sin(raan), math.cos(inc), math.sin(inc)
        cw, sw = math.cos(argp), math.sin(argp)
        return np.array([[cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
                         [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
                         [sw * si, cw * si, ci]])
    cO, sO, ci, si, cw, sw = np.cos(raan), np.sin(raan), np.cos(inc), np.sin(inc), np.cos(argp), np.sin(argp)
    cO, sO, ci, si, cw, sw = np.broadcast_arrays(cO, sO, ci, si, cw, sw)
    P = np.stack([cO * cw - sO * sw * ci, sO * cw + cO * sw * ci, sw * si], axis=-1)
    Q = np.stack([-cO * sw - sO * cw * ci, -sO * sw + cO * cw * ci, cw * si], axis=-1)
    W = np.stack([sO * si, -cO * si, ci], axis=-1)
    return np.stack([P, Q, W], axis=-1)


class Orbit:
    """Base of the orbits: ``position_velocity(t)`` and ``sample(t)``; ``epoch`` (UTC) or ``None``."""

    mu: float = MU_EARTH
    epoch: _dt.datetime | None = None

    def position_velocity(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(r, v)``, each ``shape(t) + (3,)``, m and m/s, inertial, at ``t`` seconds after the epoch."""
        raise NotImplementedError

    def sample(self, t: Any) -> dict[str, np.ndarray]:
        """``{"r": r, "v": v}`` at ``t`` (see :meth:`position_velocity`)."""
        r, v = self.position_velocity(t)
        return {"r": r, "v": v}


def _check_elements(a, e, inclination, raan, arg_perigee, mean_anomaly, mu):
    a = as_float(a, "a", positive=True)
    e = as_float(e, "e")
    if not 0.0 <= e < 1.0:
        raise ValueError(f"e must satisfy 0 <= e < 1 (a closed orbit), got {e}")
    inclination = as_float(inclination, "inclination")
    if not 0.0 <= inclination <= np.pi:
        raise ValueError(f"inclination must lie in [0, pi] radians, got {inclination}")
    mu = as_float(mu, "mu", positive=True)
    try:
        n = math.sqrt(mu / a ** 3) * math.sqrt(mu * a)     # the mean motion and the speed scale, in floats
        ok = math.isfinite(n) and n > 0.0 and a ** 3 > 0.0
    except (OverflowError, ZeroDivisionError):
        ok = False
    if not ok:   # a = 1e-120 m: a^3 underflows to 0 and the mean motion divides by it
        raise ValueError(f"a = {a!r} m with mu = {mu!r} m^3/s^2 gives no finite mean motion sqrt(mu/a^3) and "
                         "speed sqrt(mu a) in double precision; give the semi-major axis in metres")
    return (a, e, inclination, as_float(raan, "raan"), as_float(arg_perigee, "arg_perigee"),
            as_float(mean_anomaly, "mean_anomaly"), mu)


class KeplerOrbit(Orbit):
    r"""An unperturbed elliptic orbit from classical elements.

    Parameters
    ----------
    a : float
        Semi-major axis, m, > 0.
    e : float
        Eccentricity, ``0 <= e < 1``.
    inclination, raan, arg_perigee, mean_anomaly : float
        Radians; ``inclination`` in ``[0, pi]``; ``mean_anomaly`` at ``t = 0``.
    mu : float
        Gravitational parameter, m^3/s^2 (default Earth's).

    Notes
    -----
    ``n = sqrt(mu / a^3)``, ``M(t) = M0 + n t``, Kepler's equation by :func:`solve_kepler`;
    ``r = a (cos E - e, sqrt(1 - e^2) sin E)`` and ``v = sqrt(mu a) / |r| (-sin E,
    sqrt(1 - e^2) cos E)`` in the perifocal frame, rotated by ``R3(-raan) R1(-i) R3(-argp)``.
    """
    raan: float
    mu: float
    mean_anomaly: float
    inclination: float
    e: float
    arg_perigee: float
    a: float

    def __init__(self, a: float, e: float = 0.0, inclination: float = 0.0, raan: float = 0.0,
                 arg_perigee: float = 0.0, mean_anomaly: float = 0.0, *, mu: float = MU_EARTH):
        (self.a, self.e, self.inclination, self.raan, self.arg_perigee, self.mean_anomaly,
         self.mu) = _check_elements(a, e, inclination, raan, arg_perigee, mean_anomaly, mu)

    @property
    def mean_motion(self) -> float:
        """``n = sqrt(mu / a^3)``, rad/s."""
        return math.sqrt(self.mu / self.a ** 3)

    @property
    def period(self) -> float:
        """``2 pi / n``, s."""
        return 2.0 * np.pi / self.mean_motion

    def _angles(self, t: np.ndarray) -> tuple[Any, Any, Any]:
        """``(raan, arg_perigee, mean anomaly)`` at ``t``."""
        return self.raan, self.arg_perigee, self.mean_anomaly + self.mean_motion * t

    def position_velocity(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        t = _times(t)
        raan, argp, M = self._angles(t)
        if t.ndim == 0:
            return self._one(float(raan), float(argp), float(M))
        E = solve_kepler(M, self.e)
        a, e = self.a, self.e
        b = math.sqrt(1.0 - e * e)
        cE, sE = np.cos(E), np.sin(E)
        r_norm = a * (1.0 - e * cE)
        rp = np.stack([a * (cE - e), a * b * sE, np.zeros_like(E)], axis=-1)
        k = math.sqrt(self.mu * a) / r_norm
        vp = np.stack([-k * sE, k * b * cE, np.zeros_like(E)], axis=-1)
        Q = _rotation(raan, self.inclination, argp)
        return np.einsum("...ij,...j->...i", Q, rp), np.einsum("...ij,...j->...i", Q, vp)

    def _one(self, raan: float, argp: float, M: float) -> tuple[np.ndarray, np.ndarray]:
        """One time (the controller's call): the same formulas on floats."""
        E = float(solve_kepler(M, self.e))
        a, e = self.a, self.e
        b = math.sqrt(1.0 - e * e)
        cE, sE = math.cos(E), math.sin(E)
        k = math.sqrt(self.mu * a) / (a * (1.0 - e * cE))
        Q = _rotation(raan, self.inclination, argp)
        return Q @ np.array([a * (cE - e), a * b * sE, 0.0]), Q @ np.array([-k * sE, k * b * cE, 0.0])

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(a={self.a:g}, e={self.e:g}, inclination={self.inclination:g}, "
                f"raan={self.raan:g}, arg_perigee={self.arg_perigee:g}, mean_anomaly={self.mean_anomaly:g})")


class CircularOrbit(KeplerOrbit):
    """A circular orbit of ``radius`` (m) at any inclination and RAAN (radians).

    ``arg_latitude`` is the argument of latitude at ``t = 0`` (the angle from the ascending node).
    """

    def __init__(self, radius: float, inclination: float = 0.0, raan: float = 0.0, arg_latitude: float = 0.0,
                 *, mu: float = MU_EARTH):
        super().__init__(as_float(radius, "radius", positive=True), 0.0, inclination, raan, 0.0,
                         as_float(arg_latitude, "arg_latitude"), mu=mu)


class J2Orbit(KeplerOrbit):
    r"""A Kepler orbit with the secular drift of the Earth's oblateness (first order in J2).

    Parameters as :class:`KeplerOrbit`, plus ``J2`` (default Earth's) and ``radius`` (its
    reference radius, m). With ``p = a (1 - e^2)`` and ``k = n J2 (R / p)^2``:

    ``dRAAN/dt = -3/2 k cos i``, ``darg_perigee/dt = 3/4 k (5 cos^2 i - 1)``,
    ``dM/dt = n + 3/4 k sqrt(1 - e^2) (3 cos^2 i - 1)``;

    ``a``, ``e``, ``i`` stay constant (the short-periodic terms are not modelled).
    """

    def __init__(self, a: float, e: float = 0.0, inclination: float = 0.0, raan: float = 0.0,
                 arg_perigee: float = 0.0, mean_anomaly: float = 0.0, *, mu: float = MU_EARTH,
                 J2: float = J2_EARTH, radius: float = R_EARTH):
        super().__init__(a, e, inclination, raan, arg_perigee, mean_anomaly, mu=mu)
        self.J2 = as_float(J2, "J2")
        self.radius: float = as_float(radius, "radius", positive=True)

    @property
    def rates(self) -> tuple[float, float, float]:
        """``(dRAAN/dt, darg_perigee/dt, dM/dt)``, rad/s."""
        n, e, ci = self.mean_motion, self.e, math.cos(self.inclination)
        k = n * self.J2 * (self.radius / (self.a * (1.0 - e * e))) ** 2
        return (-1.5 * k * ci, 0.75 * k * (5.0 * ci * ci - 1.0),
                n + 0.75 * k * math.sqrt(1.0 - e * e) * (3.0 * ci * ci - 1.0))

    def _angles(self, t: np.ndarray) -> tuple[Any, Any, Any]:
        dO, dw, dM = self.rates
        return self.raan + dO * t, self.arg_perigee + dw * t, self.mean_anomaly + dM * t


def _tle_checksum(line: str) -> int:
    """The TLE checksum of a line: the sum of its digits in columns 1-68, each '-' counting 1, modulo 10."""
    return sum(int(c) if c.isdigit() else (c == "-") for c in line[:68]) % 10


def check_tle(line1: str, line2: str) -> tuple[str, str]:
    """The two lines of a TLE, checked as the format defines them (ValueError naming the line and
    the rule): ASCII only (a Unicode digit, which ``int`` reads, shifts the epoch silently), 69
    columns (trailing blanks dropped), the checksum in column 69, the same satellite number on both
    lines, and an epoch day of year from 1 to the last day (plus fraction) of the epoch's year
    (SGP4 rolls day 400 into the next year)."""
    lines = []
    for name, line in (("line1", line1), ("line2", line2)):
        line = line.rstrip()
        if not line.isascii():
            bad = next(c for c in line if not c.isascii())
            raise ValueError(f"{name} must hold ASCII characters only (a TLE line); got {bad!r} at column "
                             f"{line.index(bad) + 1}")
        if len(line) != 69:
            raise ValueError(f"{name} must have 69 columns (a TLE line), got {len(line)}: {line[:75]!r}")
        if not line[68].isdigit() or int(line[68]) != _tle_checksum(line):
            raise ValueError(f"{name} fails its checksum: column 69 is {line[68]!r}, the sum of its digits (each '-' "
                             f"counting 1) modulo 10 is {_tle_checksum(line)}; the line is damaged or mistyped")
        lines.append(line)
    line1, line2 = lines
    if line1[2:7] != line2[2:7]:
        raise ValueError(f"line1 and line2 must be of one satellite: numbers {line1[2:7]!r} and {line2[2:7]!r}")
    field = line1[18:32]
    try:
        yy, day = int(field[:2]), float(field[2:])
    except ValueError:
        raise ValueError(f"line1's epoch (columns 19-32) must be YYDDD.DDDDDDDD, got {field!r}") from None
    year = 1900 + yy if yy >= 57 else 2000 + yy              # the TLE convention
    days = 366 if (year % 4 == 0 and year % 100 != 0) or year % 400 == 0 else 365
    if not 1.0 <= day < days + 1.0:
        raise ValueError(f"line1's epoch day of year must be from 1 to {days}.99999999 in {year}, got {field[2:]!r}")
    return line1, line2


class SGP4Orbit(Orbit):
    """SGP4 from a two-line element set (the ``sgp4`` package; the ``space`` extra installs it).

    Parameters
    ----------
    line1, line2 : str
        The TLE's two lines.

    Positions and velocities are SGP4's TEME frame (WGS72 constants, as the TLEs are fitted);
    ``t`` is in seconds after the TLE's epoch (:attr:`epoch`, UTC). A propagation error (decay,
    eccentricity out of range) raises ValueError with SGP4's message.
    """
    line2: str
    line1: str

    def __init__(self, line1: str, line2: str):
        for name, line in (("line1", line1), ("line2", line2)):
            if not isinstance(line, str):
                raise TypeError(f"{name} must be a str (a TLE line), got {type(line).__name__}")
        try:
            from sgp4.api import Satrec
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ModuleNotFoundError("SGP4Orbit needs the sgp4 package: pip install 'lgvi[space]'") from exc
        if not (line1.startswith("1 ") and line2.startswith("2 ")):
            raise ValueError(f"line1 must start with '1 ' and line2 with '2 ' (a TLE), got {line1[:10]!r}, "
                             f"{line2[:10]!r}")
        line1, line2 = check_tle(line1, line2)
        sat = Satrec.twoline2rv(line1, line2)
        if sat.error != 0:
            raise ValueError(f"the TLE does not parse or initialise (SGP4 error {sat.error})")
        self.satrec = sat
        self.line1, self.line2 = line1, line2
        jd = sat.jdsatepoch + sat.jdsatepochF
        base = _dt.datetime(2000, 1, 1, 12)                   # JD 2451545.0
        self.epoch: _dt.datetime | None = base + _dt.timedelta(days=(sat.jdsatepoch - 2451545.0) + sat.jdsatepochF)
        self._jd = jd

    def position_velocity(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        from sgp4.api import SGP4_ERRORS

        t = _times(t)
        flat = t.reshape(-1)
        jd = np.full(flat.shape, self.satrec.jdsatepoch)
        fr = self.satrec.jdsatepochF + flat / 86400.0
        err, r, v = self.satrec.sgp4_array(jd, fr)
        if np.any(err != 0):
            i = int(np.flatnonzero(err)[0])
            raise ValueError(f"SGP4 failed at t = {flat[i]:g} s: {SGP4_ERRORS.get(int(err[i]), err[i])}")
        return r.reshape(t.shape + (3,)) * 1e3, v.reshape(t.shape + (3,)) * 1e3

    def __reduce__(self) -> tuple[Any, tuple[str, str]]:
        """Copies and pickles rebuild the orbit from its TLE (sgp4's ``Satrec`` does not pickle): an
        ensemble copies each member's spacecraft, a Dask task pickles it."""
        return type(self), (self.line1, self.line2)

    def __repr__(self) -> str:
        return f"SGP4Orbit(satnum={self.satrec.satnum_str!r}, epoch={self.epoch.isoformat()})"


def gmst(when: _dt.datetime, t: Any = 0.0) -> np.ndarray:
    """Greenwich mean sidereal time (rad, IAU 1982) at ``when + t`` seconds, UT1 taken as UTC."""
    t = _times(t)
    jd0 = (when - _dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0
    T = (jd0 + t / 86400.0) / 36525.0
    sec = (67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * T + 0.093104 * T * T - 6.2e-6 * T ** 3)
    return np.mod(sec * (2.0 * np.pi / 86400.0), 2.0 * np.pi)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def lvlh_frame(r: Any, v: Any) -> np.ndarray:
    """The LVLH frame: columns ``x = y x z``, ``y = -(r x v)/|r x v|``, ``z = -r/|r|`` (..., 3, 3).

    ``R_LVLH`` maps LVLH components to inertial ones (a rotation, like lgvi's ``R``).
    """
    r = as_float_array(r, "r")
    v = as_float_array(v, "v")
    if r.shape[-1:] != (3,) or v.shape != r.shape:
        raise ValueError(f"r and v must have the same shape (..., 3), got {r.shape} and {v.shape}")
    h = _cross(r, v)
    hn = np.sqrt(np.sum(h * h, axis=-1, keepdims=True))
    rn = np.sqrt(np.sum(r * r, axis=-1, keepdims=True))
    if np.any(hn == 0.0):
        raise ValueError("r and v must not be parallel (no orbit plane: r x v = 0)")
    z = -r / rn
    y = -h / hn
    x = _cross(y, z)
    return np.stack([x, y, z], axis=-1)


def nadir_reference(r: Any, v: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nadir pointing (body axes on the LVLH axes): ``(R_ref, omega_ref, domega_ref)``.

    ``R_ref = lvlh_frame(r, v)``; ``omega_ref = (r x v) / |r|^2`` (inertial components, rad/s) and
    ``domega_ref = -2 (r . v) (r x v) / |r|^4``, exact for a Kepler orbit (the LVLH frame turns
    about the orbit normal). In body components the rate is ``(0, -|r x v| / |r|^2, 0)``.
    """
    R = lvlh_frame(r, v)
    r = np.asarray(r, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    h = _cross(r, v)
    r2 = np.sum(r * r, axis=-1, keepdims=True)
    w = h / r2
    dw = -2.0 * np.sum(r * v, axis=-1, keepdims=True) * h / (r2 * r2)
    return R, w, dw


def _mrp(R: np.ndarray) -> np.ndarray:
    """MRP (|sigma| <= 1) of rotation matrices (..., 3, 3), Shepperd's branch choice."""
    R = np.asarray(R)
    flat = R.reshape(-1, 3, 3)
    out = np.empty((flat.shape[0], 3))
    for i, m in enumerate(flat):
        tr = m[0, 0] + m[1, 1] + m[2, 2]
        k = int(np.argmax([tr, m[0, 0], m[1, 1], m[2, 2]]))
        if k == 0:
            w = 0.5 * math.sqrt(1.0 + tr)
            q = ((m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w), w)
        else:
            a = k - 1
            b, c = (a + 1) % 3, (a + 2) % 3
            x = 0.5 * math.sqrt(1.0 + 2.0 * m[a, a] - tr)
            q = [0.0, 0.0, 0.0, (m[c, b] - m[b, c]) / (4 * x)]
            q[a], q[b], q[c] = x, (m[a, b] + m[b, a]) / (4 * x), (m[a, c] + m[c, a]) / (4 * x)
        if q[3] < 0.0:
            q = [-v for v in q]
        out[i] = np.array(q[:3]) / (1.0 + q[3])
    return out.reshape(R.shape[:-2] + (3,))


def utc_epoch(epoch: Any) -> _dt.datetime:
    """``epoch`` (a ``datetime.datetime`` or ``numpy.datetime64``) as a naive UTC ``datetime``."""
    if isinstance(epoch, np.datetime64):
        epoch = epoch.astype("datetime64[us]").item()
    if not isinstance(epoch, _dt.datetime):
        raise TypeError(f"epoch must be a datetime.datetime or numpy.datetime64 (UTC), got {epoch!r}")
    if epoch.tzinfo is not None:
        epoch = epoch.astimezone(_dt.timezone.utc).replace(tzinfo=None)
    return epoch


class OrbitEnvironment:
    r"""What a controller reads along an orbit: ``sample(t)`` for ``lgvi.simulate(..., environment=)``.

    Parameters
    ----------
    orbit : Orbit
        :class:`CircularOrbit`, :class:`KeplerOrbit`, :class:`J2Orbit`, :class:`SGP4Orbit` or any
        object with ``position_velocity(t)``.
    field : SphericalHarmonicField, optional
        :class:`~lgvi.environment.IGRF`, :class:`~lgvi.environment.WMM` or
        :class:`~lgvi.environment.CentredDipole`; then ``sample`` holds ``"B_inertial"``.
    epoch : datetime.datetime or numpy.datetime64, optional
        UTC date of ``t = 0``: sets the Earth's rotation angle and the field's date. Default the
        orbit's epoch (an SGP4 orbit's TLE epoch); required with a field otherwise.
    reference : {None, "nadir"}
        ``"nadir"`` adds the nadir-pointing reference ``"sigma_ref"``, ``"omega_ref"``,
        ``"domega_ref"`` (see :func:`nadir_reference`), which
        :class:`lgvi.control.MRPFeedback` tracks.

    Notes
    -----
    ``sample(t)`` (``t`` seconds since ``epoch``, a float or an array) returns ``"r"``, ``"v"``
    (inertial, m, m/s) and ``"B_inertial"`` (tesla), each ``shape(t) + (3,)``. For an orbit with
    its own epoch, the orbit is evaluated at ``t + (epoch - orbit.epoch)``.
    """

    def __init__(self, orbit: Any, field: SphericalHarmonicField | None = None, *, epoch: Any = None,
                 reference: str | None = None):
        if not callable(getattr(orbit, "position_velocity", None)):
            raise TypeError(f"orbit must have a position_velocity(t) method (an lgvi.environment orbit), "
                            f"got {type(orbit).__name__}")
        if field is not None and not isinstance(field, SphericalHarmonicField):
            raise TypeError(f"field must be an lgvi.environment field model (IGRF, WMM, CentredDipole) or None, "
                            f"got {type(field).__name__}")
        if reference not in (None, "nadir"):
            raise ValueError(f"reference must be None or 'nadir', got {reference!r}")
        orbit_epoch = getattr(orbit, "epoch", None)
        if epoch is None:
            epoch = orbit_epoch
        if epoch is not None:
            epoch = utc_epoch(epoch)
        elif field is not None:
            raise ValueError("epoch is required with a field (the Earth's rotation angle and the field's date at "
                             "t = 0): OrbitEnvironment(orbit, field, epoch=datetime.datetime(2026, 1, 1))")
        self.orbit = orbit
        self.field = field
        self.epoch = epoch
        self.reference = reference
        self._offset = 0.0 if orbit_epoch is None or epoch is None else (epoch - orbit_epoch).total_seconds()
        if field is not None:
            lo, hi = field.valid
            year = decimal_year(epoch)
            if not lo <= year <= hi:
                raise ValueError(f"epoch must lie in {field.name}'s validity, {lo:g} <= year <= {hi:g}; got {epoch} "
                                 f"(decimal year {year:.6f})")

    def __repr__(self) -> str:
        return f"OrbitEnvironment({self.orbit!r}, field={self.field!r}, epoch={self.epoch!r})"

    def sample(self, t: Any) -> dict[str, np.ndarray]:
        """The environment at ``t`` seconds after ``epoch`` (see the class notes)."""
        t = _times(t)
        r, v = self.orbit.position_velocity(t + self._offset)
        out = {"r": r, "v": v}
        if self.field is not None and t.ndim == 0:
            theta = float(gmst(self.epoch, t))
            c, s = math.cos(theta), math.sin(theta)
            x, y, z = r
            bx, by, bz = self.field.ecef_one(c * x + s * y, -s * x + c * y, z, self._years(t))
            out["B_inertial"] = np.array([c * bx - s * by, s * bx + c * by, bz])
        elif self.field is not None:
            theta = gmst(self.epoch, t)
            c, s = np.cos(theta), np.sin(theta)
            x = c * r[..., 0] + s * r[..., 1]              # r_ecef = R3(theta) r
            y = -s * r[..., 0] + c * r[..., 1]
            r_ecef = np.stack([x, y, r[..., 2]], axis=-1)
            years = self._years(t)
            if np.ndim(years) == 0:
                b = self.field.ecef(r_ecef, float(years))
            else:
                b = np.stack([self.field.ecef(p, float(yr)) for p, yr in
                              zip(r_ecef.reshape(-1, 3), np.ravel(years))]).reshape(r.shape)
            bx = c * b[..., 0] - s * b[..., 1]             # back: R3(theta)^T b_ecef
            by = s * b[..., 0] + c * b[..., 1]
            out["B_inertial"] = np.stack([bx, by, b[..., 2]], axis=-1)
        if self.reference == "nadir":
            R, w, dw = nadir_reference(r, v)
            out["sigma_ref"], out["omega_ref"], out["domega_ref"] = _mrp(R), w, dw
        return out

    def _years(self, t: np.ndarray) -> Any:
        """Decimal years at ``epoch + t`` (a float for a scalar ``t``)."""
        years = [decimal_year(self.epoch + _dt.timedelta(seconds=float(x))) for x in np.ravel(t)]
        return years[0] if np.ndim(t) == 0 else np.reshape(years, np.shape(t))
