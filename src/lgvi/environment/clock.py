"""One clock for the environment: UTC, TT, decimal years and the Earth's rotation angle.

A run's ``t`` is seconds of elapsed (SI) time since its epoch, a UTC date. Everything that needs a
date reads it from one :class:`Clock`:

* the geomagnetic field: the UTC decimal year (:meth:`Clock.decimal_year`, as
  :func:`lgvi.environment.decimal_year`);
* the Earth's rotation (field, co-rotating atmosphere, SGP4's TEME to Earth-fixed): Greenwich
  mean sidereal time with UT1 taken as UTC (:meth:`Clock.gmst`, as :func:`lgvi.environment.gmst`);
* the sun: Terrestrial Time, ``TT = UTC + (TAI - UTC) + 32.184 s``, as days or Julian centuries
  after J2000.0 (:meth:`Clock.days_tt`, :meth:`Clock.tt_centuries`). ``TAI - UTC`` is the leap
  second count at the epoch (:func:`tai_minus_utc`; a leap second inside a run is not inserted,
  an error of one second in the sun's position, 0.04 arcsec).
"""

from __future__ import annotations

import datetime as _dt
from typing import Any

import numpy as np

from .field import decimal_year
from .orbits import gmst

__all__ = ["Clock", "tai_minus_utc", "as_epoch", "J2000_UTC"]

#: 2000-01-01 12:00:00 TT, the epoch J2000.0, as a UTC date (TT - UTC = 64.184 s then).
J2000_UTC = _dt.datetime(2000, 1, 1, 11, 58, 55, 816000)

# (date from which, TAI - UTC in seconds): the leap seconds of the IERS since 1972.
_LEAP = ((1972, 1, 10), (1972, 7, 11), (1973, 1, 12), (1974, 1, 13), (1975, 1, 14), (1976, 1, 15),
         (1977, 1, 16), (1978, 1, 17), (1979, 1, 18), (1980, 1, 19), (1981, 7, 20), (1982, 7, 21),
         (1983, 7, 22), (1985, 7, 23), (1988, 1, 24), (1990, 1, 25), (1991, 1, 26), (1992, 7, 27),
         (1993, 7, 28), (1994, 7, 29), (1996, 1, 30), (1997, 7, 31), (1999, 1, 32), (2006, 1, 33),
         (2009, 1, 34), (2012, 7, 35), (2015, 7, 36), (2017, 1, 37))


def tai_minus_utc(when: _dt.datetime) -> float:
    """``TAI - UTC`` in seconds at the UTC date ``when``: the leap-second table from 1972 on (37 s
    since 2017; later leap seconds, if any are announced, are not in it). Before 1972 UTC's rate
    differed from TAI's; the 1972 value (10 s) is used, a few seconds off (0.1 arcsec of the sun)."""
    out = 10.0
    for year, month, value in _LEAP:
        if when >= _dt.datetime(year, month, 1):
            out = float(value)
    return out


def as_epoch(epoch: Any, name: str = "epoch") -> _dt.datetime:
    """A naive UTC ``datetime`` from a ``datetime`` (naive: UTC; aware: converted) or ``datetime64``."""
    if isinstance(epoch, np.datetime64):
        epoch = epoch.astype("datetime64[us]").item()
    if not isinstance(epoch, _dt.datetime):
        raise TypeError(f"{name} must be a datetime.datetime or numpy.datetime64 (UTC), got {epoch!r}")
    if epoch.tzinfo is not None:
        epoch = epoch.astimezone(_dt.timezone.utc).replace(tzinfo=None)
    return epoch


class Clock:
    """The clock of a run: its UTC ``epoch`` and the time scales derived from it.

    Parameters
    ----------
    epoch : datetime.datetime or numpy.datetime64
        UTC date of ``t = 0`` (a naive ``datetime`` is UTC).

    Examples
    --------
    >>> import datetime as dt
    >>> c = Clock(dt.datetime(2000, 1, 1, 11, 58, 55, 816000))
    >>> round(float(c.days_tt(0.0)), 9)
    0.0
    """
    epoch_days_tt: float

    def __init__(self, epoch: Any):
        self.epoch: _dt.datetime = as_epoch(epoch)
        #: TT - UTC at the epoch, seconds
        self.tt_minus_utc: float = tai_minus_utc(self.epoch) + 32.184
        delta = self.epoch - _dt.datetime(2000, 1, 1, 12)
        #: TT days of the epoch after J2000.0 (a parameter of the sun's kind)
        self.epoch_days_tt = delta.days + (delta.seconds + delta.microseconds * 1e-6 + self.tt_minus_utc) / 86400.0

    def __repr__(self) -> str:
        return f"Clock({self.epoch.isoformat()} UTC)"

    def utc(self, t: float = 0.0) -> _dt.datetime:
        """The UTC date at ``t`` seconds."""
        return self.epoch + _dt.timedelta(seconds=float(t))

    def days_tt(self, t: Any = 0.0) -> np.ndarray:
        """TT days after J2000.0 at ``t`` (seconds, any shape)."""
        return self.epoch_days_tt + np.asarray(t, dtype=np.float64) / 86400.0

    def tt_centuries(self, t: Any = 0.0) -> np.ndarray:
        """TT Julian centuries after J2000.0 at ``t``."""
        return self.days_tt(t) / 36525.0

    def decimal_year(self, t: Any = 0.0) -> Any:
        """UTC decimal year at ``t`` (a float for a scalar ``t``), the field models' time."""
        ts = np.asarray(t, dtype=np.float64)
        years = [decimal_year(self.utc(x)) for x in ts.ravel()]
        return years[0] if ts.ndim == 0 else np.reshape(years, ts.shape)

    def gmst(self, t: Any = 0.0) -> np.ndarray:
        """Greenwich mean sidereal time (rad) at ``t``, UT1 taken as UTC (SGP4's TEME to Earth-fixed)."""
        return gmst(self.epoch, t)
