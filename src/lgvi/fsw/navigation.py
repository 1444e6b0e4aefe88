"""Navigation with errors: :class:`SimpleNav`, Basilisk's ``simpleNav`` attitude and rate channels
as an estimator-family component of the compiled loop (kernel
:mod:`lgvi._kernels.navigation_components`, code 402).

It is the navigation a Basilisk scenario with ``simpleNav`` hands its flight software: the truth
with a bounded Gauss-Markov walk added (the MRP error composed with the attitude, the rate error
added to the rate), not a filter. With it in ``FlightSoftware(estimator=...)`` the controllers read
``R_est``, ``omega_est`` as they do with an estimator; ``est_error`` records the error
(``R = R_est Exp(est_error)``), so ``loop_summary`` reports the knowledge error.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._kernels import navigation_components as _k
from .._validation import as_float_array
from ..components import Component, ComponentKind, register_kind
from ..spacecraft.sensors import Sensor, describe
from .estimation import EST_ERROR

__all__ = ["SimpleNav"]


def _per_axis(value: Any, name: str) -> np.ndarray:
    a = np.broadcast_to(as_float_array(value, name), (3,)).astype(np.float64) if np.ndim(value) == 0 \
        else as_float_array(value, name, (3,))
    if (a < 0.0).any():
        raise ValueError(f"{name} must be >= 0 (one value, or one per axis), got {describe(value)}")
    return a


class SimpleNav(Sensor):       # a Sensor for its seed and stream (one per member); an estimator by its kind
    """Basilisk's ``simpleNav`` (attitude and rate channels): the truth with a bounded random walk.

    At each run (``rate``), with standard normals ``n``: ``a <- clamp(a + attitude_noise n, +-attitude_bound)``
    (an MRP error, per axis), ``d <- clamp(d + rate_noise n', +-rate_bound)`` (rad/s, body), a bound
    of 0 leaving the axis unbounded (``GaussMarkov::computeNextState`` with ``simpleNav``'s identity
    propagation, ``crossAtt`` off); then ``R_est = R Exp(4 atan(|a|) a / |a|)`` (Basilisk's
    ``addMRP(sigma_BN, a)``) and ``omega_est = omega + d``. Basilisk's ``PMatrix`` diagonal entries
    6..8 are ``attitude_noise``, 9..11 ``rate_noise``; its ``walkBounds`` 6..11 the bounds. The
    noise is per run, not per second (as Basilisk's): run it at the rate Basilisk runs ``simpleNav``.

    Parameters
    ----------
    attitude_noise, rate_noise : float or (3,)
        Standard deviation of one step of the walk: MRP, rad/s (>= 0).
    attitude_bound, rate_bound : float or (3,)
        The walk's bounds (MRP, rad/s; 0: none), as Basilisk's ``walkBounds``.
    seed : int or (B,) ints
        The random stream's seed (one per member in an ensemble); ``stream`` its stream number.
    rate, modes
        As every component.
    """

    kind = "simple_nav"

    def __init__(self, attitude_noise: Any = 0.0, rate_noise: Any = 0.0, *, attitude_bound: Any = 0.0,
                 rate_bound: Any = 0.0, seed: Any = 0, stream: int = 11, rate: Any = None, modes: Any = None) -> None:
        Component.__init__(self, rate=rate, modes=modes)
        Sensor.__init__(self, rate, seed, stream)
        self.attitude_noise = _per_axis(attitude_noise, "attitude_noise")
        self.rate_noise = _per_axis(rate_noise, "rate_noise")
        self.attitude_bound = _per_axis(attitude_bound, "attitude_bound")
        self.rate_bound = _per_axis(rate_bound, "rate_bound")

    def params(self) -> np.ndarray:
        return self._row(np.concatenate([self.attitude_noise, self.rate_noise, self.attitude_bound, self.rate_bound]))

    def state0(self) -> np.ndarray:
        return np.zeros(7)

    def __repr__(self) -> str:
        return (f"SimpleNav(attitude_noise={self.attitude_noise.tolist()}, rate_noise={self.rate_noise.tolist()}, "
                f"rate={self.rate}, stream={self.stream})")


register_kind(ComponentKind(
    "simple_nav", "estimator", _k.SIMPLE_NAV, _k.simple_nav_step, ("R", "omega"), ("R_est", "omega_est", "est_error"),
    cls=SimpleNav, own=(EST_ERROR,), doc=SimpleNav.__doc__.splitlines()[0]))
