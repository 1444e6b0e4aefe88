"""Gravity gradient along a tabulated orbit (:class:`lgvi.environment.OrbitGravityGradient`).

``params`` = ``[mu, J (9, row-major), t0, dt, K, r_0, v_0, r_1, v_1, ..., r_{K-1}, v_{K-1}]``:
positions and velocities of the orbit at ``t0 + k dt``, interpolated by cubic Hermite
polynomials (position and velocity at both ends of the interval). Outside ``[t0, t0 + (K-1) dt]``
the functions return NaN, which stops a run with :class:`lgvi.ConvergenceError`.
With ``b = R^T r`` the position in the body frame:
``U = 3 mu / (2 |r|^5) b . J b``, ``M = 3 mu / |r|^5 b x J b`` (``M = -dU``, left-trivialised).
"""

from __future__ import annotations

import math

from .._jit import jit

_HEAD = 13


@jit(inline="always")
def hermite_interval(t, p):
    """``(i, s, dt)``: the table index ``i`` of the interval's first node and ``t``'s place ``s`` in it
    (0..1); ``i = -1`` outside the table."""
    t0 = p[10]
    dt = p[11]
    K = int(p[12])
    u = (t - t0) / dt
    if not (u >= 0.0 and u <= K - 1.0):
        return -1, 0.0, dt
    k = int(math.floor(u))
    if k >= K - 1:
        k = K - 2
    return _HEAD + 6 * k, u - k, dt


@jit(inline="always")
def hermite_position(t, p):
    """Inertial position at ``t`` from the table in ``p`` (NaN outside it)."""
    i, s, dt = hermite_interval(t, p)
    if i < 0:
        return math.nan, math.nan, math.nan
    return hermite_position_in(i, s, dt, p)


@jit(inline="always")
def hermite_position_in(i, s, dt, p):
    """:func:`hermite_position` in the interval ``(i, s, dt)`` of :func:`hermite_interval`."""
    s2 = s * s
    s3 = s2 * s
    h00 = 2.0 * s3 - 3.0 * s2 + 1.0
    h10 = (s3 - 2.0 * s2 + s) * dt
    h01 = -2.0 * s3 + 3.0 * s2
    h11 = (s3 - s2) * dt
    x = h00 * p[i] + h10 * p[i + 3] + h01 * p[i + 6] + h11 * p[i + 9]
    y = h00 * p[i + 1] + h10 * p[i + 4] + h01 * p[i + 7] + h11 * p[i + 10]
    z = h00 * p[i + 2] + h10 * p[i + 5] + h01 * p[i + 8] + h11 * p[i + 11]
    return x, y, z


@jit(inline="always")
def body_terms(t, R, p):
    x, y, z = hermite_position(t, p)
    b0 = R[0, 0] * x + R[1, 0] * y + R[2, 0] * z          # b = R^T r
    b1 = R[0, 1] * x + R[1, 1] * y + R[2, 1] * z
    b2 = R[0, 2] * x + R[1, 2] * y + R[2, 2] * z
    r2 = x * x + y * y + z * z
    k = 3.0 * p[0] / (r2 * r2 * math.sqrt(r2))
    j0 = p[1] * b0 + p[2] * b1 + p[3] * b2
    j1 = p[4] * b0 + p[5] * b1 + p[6] * b2
    j2 = p[7] * b0 + p[8] * b1 + p[9] * b2
    return k, b0, b1, b2, j0, j1, j2


@jit
def orbit_gravity_gradient_moment(t, R, Pi, p):
    """``3 mu / |r|^5 b x J b`` (3 floats), body frame."""
    k, b0, b1, b2, j0, j1, j2 = body_terms(t, R, p)
    return k * (b1 * j2 - b2 * j1), k * (b2 * j0 - b0 * j2), k * (b0 * j1 - b1 * j0)


@jit
def orbit_gravity_gradient_potential(t, R, p):
    """``3 mu / (2 |r|^5) b . J b``."""
    k, b0, b1, b2, j0, j1, j2 = body_terms(t, R, p)
    return 0.5 * k * (b0 * j0 + b1 * j1 + b2 * j2)
