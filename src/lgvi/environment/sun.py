"""The sun and the Earth's shadow, as components of the compiled loop (``docs/environment.md``).

* :class:`Sun` (kind ``"sun"``, code 100): the unit vector from the spacecraft to the sun
  (``sun_N``) and its distance (``sun_distance``), from an analytic series (Meeus' low-precision
  solar coordinates plus a fitted series of the lunar and planetary perturbations) in TEME, the
  inertial frame of lgvi's orbits (SGP4's frame; the Earth-fixed frame is it turned by GMST).
  Within 0.003 degrees of astropy's ephemeris from 1950 to 2050 (``tests/test_environment_components.py``).
* :class:`Shadow` (kind ``"shadow"``, code 101): the fraction of the solar disc visible
  (``shadow``: 1 sunlit, 0 umbra), cylindrical or conical (Montenbruck and Gill, section 3.4).
"""

from __future__ import annotations

import datetime as _dt
from typing import Any, Literal

import numpy as np

from .._kernels.environment_components import SHADOW, SUN, shadow_step, sun_many, sun_step
from .._validation import as_float, as_float_array, choice
from ..components import Component, ComponentKind, LoopContext, member_coefficient, member_rows, register_kind
from ._evaluate import evaluate
from .clock import Clock

__all__ = ["Sun", "Shadow", "sun_position", "shadow_fraction", "EARTH_RADIUS", "SUN_RADIUS",
           "SUN_VALID_YEARS"]

#: Earth's equatorial radius (m), Basilisk's REQ_EARTH (SPICE).
EARTH_RADIUS = 6378136.6
#: The sun's radius (m), IAU 2015 nominal (Basilisk's eclipse uses 695000 km).
SUN_RADIUS = 6.957e8
#: The dates over which the sun's series was checked against astropy (UTC years).
SUN_VALID_YEARS = (1950, 2050)
SHADOW_MODELS = {"none": 0, "cylindrical": 1, "conical": 2}
#: ``model=`` of :class:`Shadow` and :func:`shadow_fraction` as a type (the keys of ``SHADOW_MODELS``).
ShadowModel = Literal["none", "cylindrical", "conical"]


def _clock(epoch: Any) -> Clock:
    clock = epoch if isinstance(epoch, Clock) else Clock(epoch)
    lo, hi = SUN_VALID_YEARS
    if not _dt.datetime(lo, 1, 1) <= clock.epoch <= _dt.datetime(hi, 1, 1):
        raise ValueError(f"epoch must lie in {lo}-01-01 .. {hi}-01-01 (the range the sun's series is checked "
                         f"over), got {clock.epoch.isoformat()}")
    return clock


def sun_position(epoch: Any, t: Any = 0.0) -> np.ndarray:
    """The sun's geocentric position (m, TEME) at ``t`` seconds (any shape) after the UTC ``epoch``.

    Returns ``shape(t) + (3,)``."""
    clock = _clock(epoch)
    days = np.asarray(clock.days_tt(as_float_array(t, "t")), dtype=np.float64)
    return sun_many(np.ascontiguousarray(days.ravel()), 1.0).reshape(days.shape + (3,))


class Sun(Component):
    """The sun seen from the spacecraft: writes ``sun_N`` (unit, inertial) and ``sun_distance`` (m).

    Parameters
    ----------
    epoch : datetime.datetime, numpy.datetime64 or Clock, optional
        UTC date of the run's ``t = 0`` (1950 to 2050). In the loop the spacecraft's ``epoch`` is
        the one clock: ``None`` takes it, and a different one is refused.
    interpolation : float, or (B,) one per member of an ensemble
        Seconds between the series' evaluations: the sun's geocentric position is the straight line
        between its values at the multiples of ``interpolation`` around ``t`` (60 s: 2e-11 rad from
        the series, one evaluation a minute); ``0`` evaluates the series at every call. (The date
        is the run's one clock, the spacecraft's ``epoch``: members with other dates are other
        spacecraft, ``lgvi.simulate_ensemble([sc_0, sc_1, ...], ...)``.)
    rate : float, optional
        Seconds between runs in the loop (``None``: every step).
    """

    kind = "sun"

    def __init__(self, epoch: Any = None, *, interpolation: float = 60.0, rate: float | None = None):
        self.clock = None if epoch is None else _clock(epoch)
        self.interpolation: Any = member_coefficient(interpolation, "interpolation")
        if np.any(np.asarray(self.interpolation) < 0.0):
            raise ValueError(f"interpolation must be >= 0 seconds (0: no interpolation), got {self.interpolation}")
        self.rate: Any = None if rate is None else as_float(rate, "rate", positive=True)

    def __repr__(self) -> str:
        return "Sun()" if self.clock is None else f"Sun(epoch={self.clock.epoch.isoformat()})"

    def setup(self, ctx: LoopContext) -> None:
        """The run's clock: the spacecraft's ``epoch`` (one clock for the field, the orbit and the sun)."""
        epoch = ctx.spacecraft.epoch
        if epoch is None:
            if self.clock is None:
                raise ValueError("Sun needs a date: give Spacecraft(..., epoch=datetime.datetime(...)) (or an orbit "
                                 "with an epoch)")
            return
        clock = _clock(epoch)
        if self.clock is not None and self.clock.epoch != clock.epoch:
            raise ValueError(f"Sun(epoch={self.clock.epoch.isoformat()}) differs from the spacecraft's epoch "
                             f"{clock.epoch.isoformat()}: the run has one clock; give Sun() without an epoch")
        self.clock = clock

    def params(self) -> np.ndarray:
        if self.clock is None:
            raise ValueError("Sun has no epoch: give Sun(epoch) or run it on a Spacecraft with an epoch")
        return member_rows(self.clock.epoch_days_tt, self.interpolation)

    def state0(self) -> np.ndarray:
        """[k, the node k's and the node k+1's positions]; k NaN: none computed yet."""
        return np.array([np.nan, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])

    def sizes(self) -> dict[str, int]:
        return {}

    def evaluate(self, t: Any, r_N: Any, *, member: int = 0) -> dict[str, np.ndarray]:
        """``sun_N`` (n, 3) and ``sun_distance`` (n,) at times ``t`` and positions ``r_N`` (m)."""
        return evaluate(self, t, member=member, r_N=r_N)


class Shadow(Component):
    """The fraction of the solar disc visible from the spacecraft: writes ``shadow``.

    Parameters
    ----------
    model : {"conical", "cylindrical", "none"}
        ``"conical"``: umbra, penumbra and the visible fraction of the disc (overlapping discs of
        apparent radii ``asin(R_sun / d)`` and ``asin(R_planet / |r|)``); ``"cylindrical"``: 0 in
        the cylinder of the planet's radius behind it, else 1; ``"none"``: always 1.
    planet_radius, sun_radius : float, or (B,) one per member of an ensemble
        Metres (Earth's equatorial radius and the IAU nominal solar radius by default).
    """

    kind = "shadow"

    def __init__(self, model: ShadowModel = "conical", *, planet_radius: float = EARTH_RADIUS,
                 sun_radius: float = SUN_RADIUS, rate: float | None = None):
        self.model: str = choice(model, "model", tuple(SHADOW_MODELS))
        self.planet_radius: Any = member_coefficient(planet_radius, "planet_radius", positive=True)
        self.sun_radius: Any = member_coefficient(sun_radius, "sun_radius", positive=True)
        self.rate: Any = None if rate is None else as_float(rate, "rate", positive=True)
        self.params()                                   # the members' counts agree

    def __repr__(self) -> str:
        return f"Shadow({self.model!r})"

    def params(self) -> np.ndarray:
        """``[model code, planet_radius, sun_radius]``, (3,) or (B, 3) with radii given per member."""
        return member_rows(SHADOW_MODELS[self.model], self.planet_radius, self.sun_radius,
                           what="Shadow: planet_radius and sun_radius given per member")

    def state0(self) -> np.ndarray:
        return np.zeros(0)

    def sizes(self) -> dict[str, int]:
        return {}

    def evaluate(self, r_N: Any, sun_N: Any, sun_distance: Any, *, member: int = 0) -> np.ndarray:
        """The visible fraction (n,) from the bus signals (with radii per member: ``member``'s)."""
        return evaluate(self, 0.0, member=member, r_N=r_N, sun_N=sun_N, sun_distance=sun_distance)["shadow"]


def shadow_fraction(r: Any, r_sun: Any, model: ShadowModel = "conical", *, planet_radius: float = EARTH_RADIUS,
                    sun_radius: float = SUN_RADIUS) -> np.ndarray:
    """The visible fraction of the solar disc at planet-centred positions ``r`` (..., 3) with the sun
    at ``r_sun`` (..., 3), metres. Returns shape ``(...)``."""
    r = as_float_array(r, "r")
    r_sun = as_float_array(r_sun, "r_sun")
    d = r_sun - r
    dist = np.linalg.norm(d, axis=-1)
    out = Shadow(model, planet_radius=planet_radius, sun_radius=sun_radius).evaluate(
        r, d / dist[..., None], dist)
    return out.reshape(np.broadcast_shapes(r.shape, r_sun.shape)[:-1])


register_kind(ComponentKind("sun", "environment", SUN, sun_step, reads=("r_N",), writes=("sun_N", "sun_distance"),
                            cls=Sun, doc="the sun's direction and distance (analytic series, TEME)"))
register_kind(ComponentKind("shadow", "environment", SHADOW, shadow_step, reads=("r_N", "sun_N", "sun_distance"),
                            writes=("shadow",), cls=Shadow,
                            doc="visible fraction of the solar disc (cylindrical or conical shadow)"))
