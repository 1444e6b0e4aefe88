"""Gravity gradient along any orbit, as a compiled torque model (a :class:`lgvi.torques.Compiled`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._kernels.orbit_table_kernels import orbit_gravity_gradient_moment, orbit_gravity_gradient_potential
from .._validation import as_float, as_float_array
from ..body import RigidBody
from ..torques import Compiled

__all__ = ["OrbitGravityGradient"]


class OrbitGravityGradient(Compiled):
    r"""The gravity-gradient moment on a body moving along ``orbit``, inside the compiled loops.

    Parameters
    ----------
    orbit : Orbit
        Any orbit of :mod:`lgvi.environment` (circular, Kepler, J2, SGP4) or an object with
        ``position_velocity(t)`` and ``mu``.
    inertia : lgvi.RigidBody or array_like
        The body (or its (3,) principal moments or (3, 3) inertia), kg m^2: the moment needs ``J``.
    duration : float
        The run's length, s, > 0: the orbit is tabulated on ``[0, duration]`` (a run past it stops
        with :class:`lgvi.ConvergenceError`).
    dt : float
        Table spacing, s (default 10 s): cubic Hermite interpolation of position and velocity,
        relative position error about ``(n dt)^4 / 384`` (``n`` the mean motion), ``4e-11`` in LEO.
    mu : float, optional
        Gravitational parameter (default ``orbit.mu``).

    Notes
    -----
    With ``b = R^T r(t)``: ``U = 3 mu / (2 |r|^5) b . J b`` and ``M = 3 mu / |r|^5 b x J b``; the
    variational LGVI is used for it (a time-dependent potential), the dropped terms of the
    potential depend on ``t`` only. On a circular equatorial orbit it equals
    :class:`lgvi.torques.GravityGradient`.
    """
    orbit: Any
    duration: float
    dt: float

    def __init__(self, orbit: Any, inertia: Any, *, duration: float, dt: float = 10.0, mu: float | None = None):
        if not callable(getattr(orbit, "position_velocity", None)):
            raise TypeError(f"orbit must have a position_velocity(t) method, got {type(orbit).__name__}")
        J = inertia.J if isinstance(inertia, RigidBody) else RigidBody(inertia).J
        duration = as_float(duration, "duration", positive=True)
        dt = as_float(dt, "dt", positive=True)
        mu = as_float(getattr(orbit, "mu", None) if mu is None else mu, "mu", positive=True)
        K = max(2, int(math.ceil(duration / dt)) + 1)
        if K > 10_000_000:
            raise ValueError(f"duration / dt = {duration / dt:.3g} table nodes is too many (> 1e7): raise dt")
        r, v = orbit.position_velocity(np.arange(K) * dt)
        table = np.concatenate([r, v], axis=1).reshape(-1)
        params = np.concatenate([[mu], np.asarray(J, dtype=np.float64).reshape(-1), [0.0, dt, float(K)], table])
        as_float_array(params, "the tabulated orbit")
        self.orbit, self.duration, self.dt = orbit, duration, dt
        super().__init__(orbit_gravity_gradient_moment, potential=orbit_gravity_gradient_potential, params=params)

    def __repr__(self) -> str:
        return f"OrbitGravityGradient({self.orbit!r}, duration={self.duration:g}, dt={self.dt:g})"
