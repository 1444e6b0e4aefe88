"""Geomagnetic field models: a centred dipole, IGRF-14 and the World Magnetic Model.

Every model is a Schmidt semi-normalised spherical-harmonic expansion evaluated by one compiled
kernel (:mod:`lgvi._kernels.field_kernels`) at Earth-fixed (ECEF) Cartesian points, in tesla.
The coefficients are read from the files that maintained packages ship, never copied here:

* IGRF-14 from ``ppigrf`` (its ``IGRF14.shc``; the ``space`` extra installs it): degree 13,
  epochs 1900 to 2025 every five years, interpolated linearly in decimal years between them, and
  after 2025 extrapolated with the secular variation (the file's 2030 column is
  ``g(2025) + 5 SV``), as the IGRF specifies; valid 1900.0 to 2030.0.
* WMM2025 from NOAA's ``wmm-calculator`` (its ``wmm/coefs/WMM.COF``): degree 12,
  ``g(t) = g(2025) + (t - 2025) gdot``; valid 2025.0 to 2030.0.

Times are decimal years (:func:`decimal_year` converts a ``datetime`` or ``numpy.datetime64``,
taken as UTC). Positions are geocentric Earth-fixed Cartesian, metres;
:func:`geodetic_to_ecef` converts WGS84 geodetic coordinates and :func:`ned_frame` gives the local
north-east-down axes, so ``ned_frame(lat, lon).T @ field.ecef(r, year)`` is the field in the
components ``X`` (north), ``Y`` (east), ``Z`` (down) that magnetic tables list.
"""

from __future__ import annotations

import datetime as _dt
import math
import importlib.util
from pathlib import Path
from typing import Any

import numpy as np

from .._kernels.field_kernels import (recursion_constants_size, sh_coefficients_at, sh_field_many, sh_field_one,
                                      sh_recursion_constants)
from .._validation import as_float, as_float_array, as_int

__all__ = ["CentredDipole", "IGRF", "WMM", "SphericalHarmonicField", "decimal_year", "geodetic_to_ecef",
           "ned_frame", "WGS84_A", "WGS84_F"]

#: WGS84 semi-major axis (m) and flattening.
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
#: Geomagnetic reference radius of IGRF and WMM (m).
GEOMAGNETIC_RADIUS = 6371200.0
_NT = 1e-9


def decimal_year(when: Any) -> float:
    """A decimal year: ``year + (time since 1 January 00:00) / (length of that year)``.

    Parameters
    ----------
    when : float, datetime.datetime, datetime.date or numpy.datetime64
        A real number is taken as a decimal year already; a naive ``datetime`` or a
        ``datetime64`` as UTC; an aware ``datetime`` is converted to UTC.

    Returns
    -------
    float
    """
    if isinstance(when, np.datetime64):
        when = when.astype("datetime64[us]").item()
    if isinstance(when, _dt.datetime):
        if when.tzinfo is not None:
            when = when.astimezone(_dt.timezone.utc).replace(tzinfo=None)
        start = _dt.datetime(when.year, 1, 1)
        end = _dt.datetime(when.year + 1, 1, 1)
        return when.year + (when - start).total_seconds() / (end - start).total_seconds()
    if isinstance(when, _dt.date):
        return decimal_year(_dt.datetime(when.year, when.month, when.day))
    return as_float(when, "when (a decimal year, datetime or numpy.datetime64)")


def geodetic_to_ecef(lat: Any, lon: Any, height: Any) -> np.ndarray:
    """WGS84 geodetic latitude, longitude (degrees) and height above the ellipsoid (m) to ECEF (m).

    Broadcasts its inputs; returns an array of shape ``broadcast shape + (3,)``.
    """
    lat = as_float_array(lat, "lat")
    lon = as_float_array(lon, "lon")
    height = as_float_array(height, "height")
    if np.any(np.abs(lat) > 90.0):
        raise ValueError(f"lat must be in [-90, 90] degrees, got {lat[np.abs(lat) > 90.0].ravel()[0]}")
    phi, lam = np.radians(lat), np.radians(lon)
    e2 = WGS84_F * (2.0 - WGS84_F)
    N = WGS84_A / np.sqrt(1.0 - e2 * np.sin(phi) ** 2)
    x = (N + height) * np.cos(phi) * np.cos(lam)
    y = (N + height) * np.cos(phi) * np.sin(lam)
    z = (N * (1.0 - e2) + height) * np.sin(phi)
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1)


def ned_frame(lat: Any, lon: Any) -> np.ndarray:
    """Local north, east, down unit vectors (columns) in ECEF at geodetic ``lat``, ``lon`` (degrees).

    Returns ``(..., 3, 3)``; ``ned_frame(lat, lon).T @ b_ecef`` is ``(X, Y, Z)``.
    """
    lat = as_float_array(lat, "lat")
    if np.any(np.abs(lat) > 90.0):   # as geodetic_to_ecef: a latitude beyond a pole names no place
        raise ValueError(f"lat must be in [-90, 90] degrees, got {lat[np.abs(lat) > 90.0].ravel()[0]}")
    phi = np.radians(lat)
    lam = np.radians(as_float_array(lon, "lon"))
    phi, lam = np.broadcast_arrays(phi, lam)
    sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
    north = np.stack([-sp * cl, -sp * sl, cp], axis=-1)
    east = np.stack([-sl, cl, np.zeros_like(sl)], axis=-1)
    down = np.stack([-cp * cl, -cp * sl, -sp], axis=-1)
    return np.stack([north, east, down], axis=-1)


def _package_file(package: str, relative: str, extra: str) -> Path:
    """A data file shipped inside ``package``, found without importing it."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError(f"the coefficients come from the package {package!r}, which is not installed: "
                                  f"pip install 'lgvi[{extra}]' (or pip install {package}), or pass path=")
    path = Path(list(spec.submodule_search_locations)[0]) / relative
    if not path.is_file():
        raise FileNotFoundError(f"{package} is installed but has no {relative} ({path}); pass path=")
    return path


class SphericalHarmonicField:
    r"""An internal field given by Gauss coefficients at epochs, linear in time between them.

    Parameters
    ----------
    times : array_like
        (T,) epochs, decimal years, increasing, T >= 2.
    g, h : array_like
        (T, N+1, N+1) Schmidt semi-normalised Gauss coefficients, nT, indexed ``[epoch, n, m]``.
    radius : float
        Reference radius, m (default 6371.2 km).
    valid : (float, float), optional
        Decimal years the model is defined for (default ``times[0], times[-1]``); outside,
        evaluation raises ValueError.
    degree : int, optional
        Truncate at this degree (default all of ``N``).
    name : str
        For messages and ``repr``.
    """

    def __init__(self, times: Any, g: Any, h: Any, *, radius: float = GEOMAGNETIC_RADIUS,
                 valid: tuple[float, float] | None = None, degree: int | None = None, name: str = "field"):
        times = as_float_array(times, "times", (None,))
        g = as_float_array(g, "g")
        h = as_float_array(h, "h")
        if times.size < 2 or np.any(np.diff(times) <= 0):
            raise ValueError(f"times must hold at least 2 increasing epochs, got {times}")
        if g.ndim != 3 or g.shape[0] != times.size or g.shape[1] != g.shape[2] or g.shape[1] < 2:
            raise ValueError(f"g must have shape (T, N+1, N+1) with T = len(times) = {times.size} and N >= 1, "
                             f"got shape {g.shape}")
        if h.shape != g.shape:
            raise ValueError(f"h must have the shape of g {g.shape}, got shape {h.shape}")
        nmax = g.shape[1] - 1
        if degree is not None:
            degree = as_int(degree, "degree", minimum=1)
            if degree > nmax:
                raise ValueError(f"degree must be <= {nmax} (the coefficients' degree), got {degree}")
            nmax = degree
        self.radius: float = as_float(radius, "radius", positive=True)
        self.name: str = str(name)
        self.degree = nmax
        self.times = times
        self._G = np.ascontiguousarray(g[:, :nmax + 1, :nmax + 1])
        self._H = np.ascontiguousarray(h[:, :nmax + 1, :nmax + 1])
        lo, hi = (times[0], times[-1]) if valid is None else (float(valid[0]), float(valid[1]))
        self.valid: tuple[Any | float, Any | float] = (lo, hi)
        n1 = nmax + 1
        self._scratch = tuple(np.zeros((n1, n1)) for _ in range(5))   # g, h, P, dP, Q
        self._constants = np.zeros(recursion_constants_size(n1))      # the recursions' factors, once
        sh_recursion_constants(n1, self._constants)
        self._year: float | None = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}(degree={self.degree}, valid={self.valid[0]:g}..{self.valid[1]:g})"

    def coefficients(self, when: Any) -> tuple[np.ndarray, np.ndarray]:
        """Gauss coefficients ``(g, h)`` (N+1, N+1), nT, at ``when`` (see :func:`decimal_year`)."""
        year = self._check_year(when)
        g, h = np.zeros_like(self._G[0]), np.zeros_like(self._H[0])
        sh_coefficients_at(self.times, self._G, self._H, year, g, h)
        return g, h

    def _check_year(self, when: Any) -> float:
        year = decimal_year(when)
        lo, hi = self.valid
        if not lo <= year <= hi:
            raise ValueError(f"when must lie in {self.name}'s validity, {lo:g} <= year <= {hi:g}; got {year:.6f}")
        return year

    def _at(self, year: float) -> tuple[np.ndarray, ...]:
        g, h, P, dP, Q = self._scratch
        if year != self._year:
            sh_coefficients_at(self.times, self._G, self._H, year, g, h)
            self._year = year
        return g, h, P, dP, Q

    def ecef(self, r: Any, when: Any) -> np.ndarray:
        """Field (tesla) at Earth-fixed points ``r`` (..., 3), metres, at time ``when``.

        Returns an array of the shape of ``r``. A point at the centre raises ValueError.
        """
        r = as_float_array(r, "r")
        if r.ndim == 0 or r.shape[-1] != 3:
            raise ValueError(f"r must have shape (..., 3), got shape {r.shape}")
        flat = np.ascontiguousarray(r.reshape(-1, 3))
        zero = np.flatnonzero(np.einsum("ij,ij->i", flat, flat) == 0.0)
        if zero.size:
            raise ValueError(f"r must not be the Earth's centre [0, 0, 0] (the field is singular there); point "
                             f"{int(zero[0])} is")
        g, h, P, dP, Q = self._at(self._check_year(when))
        out = np.empty_like(flat)
        sh_field_many(flat, g, h, self.degree, self.radius, P, dP, Q, self._constants, out)
        return (out * _NT).reshape(r.shape)

    def ecef_one(self, x: float, y: float, z: float, year: float) -> tuple[float, float, float]:
        """One point, no validation (for loops that validated already): ``(bx, by, bz)`` tesla."""
        g, h, P, dP, Q = self._at(year)
        bx, by, bz = sh_field_one(x, y, z, g, h, self.degree, self.radius, P, dP, Q, self._constants)
        return bx * _NT, by * _NT, bz * _NT

    def geodetic(self, lat: Any, lon: Any, height: Any, when: Any) -> np.ndarray:
        """Field (tesla) in north, east, down components at WGS84 geodetic points (degrees, m).

        Returns ``broadcast shape + (3,)``: ``(X, Y, Z)`` as magnetic tables list them.
        """
        r = geodetic_to_ecef(lat, lon, height)
        b = self.ecef(r, when)
        return np.einsum("...ji,...j->...i", ned_frame(lat, lon) * np.ones(r.shape[:-1] + (1, 1)), b)


#: Largest degree accepted from a coefficient file (IGRF: 13, WMM: 12; high-degree models ~ 133).
MAX_FILE_DEGREE = 200


def _coefficient_file(path: Path, kind: str, parse: Any) -> Any:
    """``parse(lines)`` of the coefficient file ``path``; anything wrong with it (not text, a
    missing or malformed field, a degree or order out of range) is a ValueError naming the file
    and the format expected, not an IndexError from inside the parser."""
    try:
        text = path.read_text(encoding="ascii")
    except (UnicodeDecodeError, IsADirectoryError) as exc:
        raise ValueError(f"{path} is not {kind} coefficient file (plain ASCII text expected): {exc}") from None
    try:
        return parse(text.splitlines())
    except (IndexError, ValueError, OverflowError) as exc:
        raise ValueError(f"{path} is not {kind} coefficient file as expected: {type(exc).__name__}: {exc}") from None


def _degree_order(n: int, m: int, nmax: int) -> None:
    if not (1 <= n <= nmax and abs(m) <= n):
        raise ValueError(f"row of degree {n}, order {m}: expected 1 <= n <= {nmax} and |m| <= n")


def _read_shc(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    def parse(raw: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        lines = [ln for ln in raw if ln.strip() and not ln.lstrip().startswith("#")]
        if len(lines) < 3:
            raise ValueError(f"{len(lines)} data lines, expected a header, the epochs and coefficient rows")
        head = lines[0].split()
        nmax = int(head[1])
        if not 1 <= nmax <= MAX_FILE_DEGREE:
            raise ValueError(f"the header declares degree {nmax}, expected 1 to {MAX_FILE_DEGREE}")
        times = np.array([float(v) for v in lines[1].split()])
        if not times.size or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
            raise ValueError(f"the epochs must be finite and increasing, got {lines[1][:80]!r}")
        G = np.zeros((times.size, nmax + 1, nmax + 1))
        H = np.zeros_like(G)
        for ln in lines[2:]:
            vals = ln.split()
            n, m = int(vals[0]), int(vals[1])
            _degree_order(n, m, nmax)
            coef = np.array([float(v) for v in vals[2:]])
            if coef.size != times.size or not np.all(np.isfinite(coef)):
                raise ValueError(f"row {n} {m} has {coef.size} values for {times.size} epochs (all finite expected)")
            if m >= 0:
                G[:, n, m] = coef
            else:
                H[:, n, -m] = coef
        return times, G, H

    return _coefficient_file(path, "an IGRF .shc", parse)


def _read_cof(path: Path) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    def parse(lines: list[str]) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        epoch = float(lines[0].split()[0])
        rows = []
        for ln in lines[1:]:
            vals = ln.split()
            if len(vals) != 6:
                break                    # the 9999... trailer
            rows.append([float(v) for v in vals])
        if not rows:
            raise ValueError("no coefficient rows (n m g h dg dh) after the header")
        rows = np.array(rows)
        if not np.all(np.isfinite(rows)) or not math.isfinite(epoch):
            raise ValueError("the epoch and coefficients must be finite")
        nmax = int(rows[:, 0].max())
        if not 1 <= nmax <= MAX_FILE_DEGREE:
            raise ValueError(f"the rows reach degree {nmax}, expected 1 to {MAX_FILE_DEGREE}")
        g, h, gd, hd = (np.zeros((nmax + 1, nmax + 1)) for _ in range(4))
        for n, m, a, b, c, d in rows:
            n, m = int(n), int(m)
            if m < 0:
                raise ValueError(f"row of degree {n}, order {m}: orders are >= 0 in a .COF file")
            _degree_order(n, m, nmax)
            g[n, m], h[n, m], gd[n, m], hd[n, m] = a, b, c, d
        return epoch, g, h, gd, hd

    return _coefficient_file(path, "a WMM .COF", parse)


class IGRF(SphericalHarmonicField):
    """The International Geomagnetic Reference Field, 14th generation (1900.0 to 2030.0).

    Parameters
    ----------
    degree : int
        Truncation degree, 1 to 13 (default 13).
    path : str or Path, optional
        An IGRF ``.shc`` coefficient file; default ``IGRF14.shc`` of the installed ``ppigrf``.

    Examples
    --------
    >>> from lgvi.environment import IGRF
    >>> b = IGRF().ecef([7.0e6, 0.0, 0.0], 2026.0)      # tesla, Earth-fixed
    """

    def __init__(self, degree: int = 13, *, path: Any = None):
        path = _package_file("ppigrf", "IGRF14.shc", "space") if path is None else Path(path)
        times, G, H = _read_shc(path)
        super().__init__(times, G, H, degree=degree, name="IGRF")


class WMM(SphericalHarmonicField):
    """The World Magnetic Model (WMM2025: 2025.0 to 2030.0), main field plus secular variation.

    Parameters
    ----------
    degree : int
        Truncation degree, 1 to 12 (default 12).
    path : str or Path, optional
        A WMM ``.COF`` file; default ``WMM.COF`` of NOAA's installed ``wmm-calculator``.
    """

    def __init__(self, degree: int = 12, *, path: Any = None):
        path = _package_file("wmm", "coefs/WMM.COF", "space") if path is None else Path(path)
        epoch, g, h, gd, hd = _read_cof(path)
        times = np.array([epoch, epoch + 5.0])
        super().__init__(times, np.stack([g, g + 5.0 * gd]), np.stack([h, h + 5.0 * hd]), degree=degree,
                         name="WMM")


class CentredDipole(SphericalHarmonicField):
    """The centred (tilted) dipole: the degree-1 terms ``g10, g11, h11`` (nT), constant in time.

    The default coefficients are IGRF-14's at 2025.0. ``CentredDipole.from_model(IGRF(), when)``
    takes another model's degree-1 terms at a date.
    """

    def __init__(self, g10: float = -29350.0, g11: float = -1410.3, h11: float = 4545.5, *,
                 radius: float = GEOMAGNETIC_RADIUS):
        g = np.zeros((2, 2, 2))
        h = np.zeros((2, 2, 2))
        g[:, 1, 0] = as_float(g10, "g10")
        g[:, 1, 1] = as_float(g11, "g11")
        h[:, 1, 1] = as_float(h11, "h11")
        if g[0, 1, 0] == 0.0 and g[0, 1, 1] == 0.0 and h[0, 1, 1] == 0.0:
            raise ValueError("CentredDipole: g10, g11, h11 must not all be zero (no field), got 0, 0, 0")
        super().__init__([0.0, 1.0], g, h, radius=radius, valid=(-np.inf, np.inf), name="CentredDipole")

    @classmethod
    def from_model(cls, model: SphericalHarmonicField, when: Any) -> "CentredDipole":
        """The degree-1 part of ``model`` at ``when``."""
        g, h = model.coefficients(when)
        return cls(g[1, 0], g[1, 1], h[1, 1], radius=model.radius)

    @property
    def moment(self) -> np.ndarray:
        """The dipole moment (A m^2), Earth-fixed: ``4 pi a^3 / mu0 (g11, h11, g10)``."""
        g, h = self._G[0], self._H[0]
        return 4.0 * np.pi * self.radius ** 3 / (4e-7 * np.pi) * _NT * np.array([g[1, 1], h[1, 1], g[1, 0]])
