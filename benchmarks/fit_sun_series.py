"""Fit the lunar and planetary corrections of lgvi's sun series to astropy's ephemeris.

``lgvi._kernels.environment_components.sun_teme`` is Meeus' low-precision solar series plus a
small fitted series; this script prints the fitted constants (``_LON``, ``_DIST``) from the
uncorrected series' residuals at 4000 random dates of 1950-2050 (seed 1), and the largest angle
of the corrected series at 4000 other dates (seed 2). The reference: astropy's ``get_sun``
(built-in ERFA ephemeris, no download) taken from GCRS to the true equator and equinox of date
with ERFA's ``pnm06a``, then to TEME's mean equinox by the equation of the equinoxes (``ee06a``).
The test ``tests/test_environment_components.py`` repeats the check at other dates.

    PYTHONPATH=src python benchmarks/fit_sun_series.py
"""

from __future__ import annotations

import sys
import warnings

import numpy as np


def astropy_sun_teme(jd_utc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(TT days after J2000.0, sun in TEME, metres) at the UTC Julian dates ``jd_utc``."""
    import astropy.units as u
    import erfa
    from astropy.coordinates import get_sun
    from astropy.time import Time
    from astropy.utils import iers

    iers.conf.auto_download = False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")            # ERFA's 'dubious year' for dates after the last leap second
        t = Time(jd_utc, format="jd", scale="utc")
        tt = t.tt
        g = get_sun(t).cartesian.xyz.to(u.m).value.T
        M = erfa.pnm06a(tt.jd1, tt.jd2)            # GCRS -> true equator and equinox of date
        x = np.einsum("nij,nj->ni", M, g)
        ee = erfa.ee06a(tt.jd1, tt.jd2)            # true -> mean equinox (TEME)
    c, s = np.cos(ee), np.sin(ee)
    teme = np.stack([c * x[:, 0] + s * x[:, 1], c * x[:, 1] - s * x[:, 0], x[:, 2]], axis=-1)
    return (tt.jd1 - 2451545.0) + tt.jd2, teme


def random_dates(seed: int, n: int = 4000) -> np.ndarray:
    """UTC Julian dates uniform in 1950-01-01 .. 2050-01-01."""
    return 2433282.5 + np.random.default_rng(seed).uniform(0.0, 36525.0, n)


def angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    c = np.cross(a, b)
    return np.degrees(np.arctan2(np.linalg.norm(c, axis=-1), np.sum(a * b, axis=-1)))


def _ecliptic(v: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Longitude (rad) and distance of TEME vectors in the ecliptic of date (as sun_teme builds them)."""
    Om = np.radians(125.04 - 1934.136 * T)
    dpsi = -0.00478 * np.sin(Om)
    eps = np.radians(23.439291 - 0.0130042 * T + 0.00256 * np.cos(Om))
    ee = np.radians(dpsi) * np.cos(eps)
    c, s = np.cos(ee), np.sin(ee)
    x, y = c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]
    return np.arctan2(np.cos(eps) * y + np.sin(eps) * v[:, 2], x), np.linalg.norm(v, axis=1)


def fit() -> tuple[np.ndarray, np.ndarray]:
    from lgvi._kernels.environment_components import sun_many

    days, ref = astropy_sun_teme(random_dates(1))
    T = days / 36525.0
    base = sun_many(days, 0.0)
    l1, r1 = _ecliptic(base, T)
    l2, r2 = _ecliptic(ref, T)
    dl = np.degrees(np.angle(np.exp(1j * (l2 - l1)))) * 3600.0
    dr = r2 / r1 - 1.0
    D = np.radians(297.85036 + 445267.111480 * T)
    VE = np.radians(181.979801 - 100.466457 + (58517.8156760 - 35999.3728565) * T)
    EJ = np.radians(100.466457 - 34.351519 + (35999.3728565 - 3034.9056606) * T)
    EM = np.radians(100.466457 - 355.433 + (35999.3728565 - 19140.2993) * T)
    args = [D, VE, 2 * VE, 3 * VE, EJ, 2 * EJ, 2 * EM]
    lon, *_ = np.linalg.lstsq(np.stack([np.ones_like(T), T] + [np.sin(a) for a in args], 1), dl, rcond=None)
    dist, *_ = np.linalg.lstsq(np.stack([np.ones_like(T)] + [np.cos(a) for a in args], 1), dr, rcond=None)
    print(f"uncorrected series: largest angle {angle_deg(base, ref).max():.5f} deg")
    return lon, dist


def main() -> int:
    lon, dist = fit()
    print("_LON = (" + ", ".join(f"{v:.3f}" for v in lon) + ")")
    print("_DIST = (" + ", ".join(f"{v:.4e}" for v in dist) + ")")
    from lgvi._kernels.environment_components import sun_many

    days, ref = astropy_sun_teme(random_dates(2))
    ang = angle_deg(sun_many(days, 1.0), ref)
    rel = np.abs(np.linalg.norm(sun_many(days, 1.0), axis=1) / np.linalg.norm(ref, axis=1) - 1.0)
    print(f"corrected series (constants in the kernel now), other dates: largest angle {ang.max():.5f} deg, "
          f"largest relative distance error {rel.max():.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
