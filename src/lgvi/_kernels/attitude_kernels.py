"""Small attitude helpers shared by the sensor and estimator components (scalar arithmetic, no
allocation): rotation vectors, quaternions (scalar-last, Hamilton product, of the rotation that maps
body vectors to inertial ones, as lgvi's ``R``) and 3x3 matrices stored row-major in flat slices.
"""

from __future__ import annotations

import math

from .._jit import jit


#: ``t^2`` below which :func:`rotation_coefficients` takes its series: ``t < 0.1`` rad, where the
#: series to ``t^8`` are exact to round-off (the first term left out is below 3e-18 of each value).
ROTATION_SERIES = 1e-2


@jit(inline="always")
def rotation_coefficients(t2):
    """For ``t2 = t^2``: ``sin(t/2)/t`` and ``cos(t/2)`` (the unit quaternion of a rotation vector
    ``phi``, ``|phi| = t``, is ``(sin(t/2)/t phi, cos(t/2))``), and Rodrigues' ``sin(t)/t``,
    ``(1 - cos t)/t^2`` and ``(t - sin t)/t^3``. Below ``ROTATION_SERIES`` (``t < 0.1``) their Taylor
    series to ``t^8`` (no square root, no trigonometric function); above, one square root and the
    sine and cosine of ``t/2`` (``sin t = 2 sin(t/2) cos(t/2)``, ``1 - cos t = 2 sin^2(t/2)``).
    Each within 1 ulp of the exact value (40 digits), except ``(t - sin t)/t^3`` just above the series'
    edge, where the cancellation of ``t - sin t`` leaves about 100 ulp at ``t = 0.1`` (61 at 0.2, 1 at
    0.5); it multiplies ``hat(phi)^2``, of size ``t^2``, so the rotation it builds is exact to
    round-off (``tests/test_estimation.py``)."""
    if t2 < ROTATION_SERIES:
        qc = 0.5 - t2 * (1.0 / 48.0 - t2 * (1.0 / 3840.0 - t2 * (1.0 / 645120.0 - t2 * (1.0 / 185794560.0))))
        qw = 1.0 - t2 * (0.125 - t2 * (1.0 / 384.0 - t2 * (1.0 / 46080.0 - t2 * (1.0 / 10321920.0))))
        sa = 1.0 - t2 * (1.0 / 6.0 - t2 * (1.0 / 120.0 - t2 * (1.0 / 5040.0 - t2 * (1.0 / 362880.0))))
        ca = 0.5 - t2 * (1.0 / 24.0 - t2 * (1.0 / 720.0 - t2 * (1.0 / 40320.0 - t2 * (1.0 / 3628800.0))))
        c2 = 1.0 / 6.0 - t2 * (1.0 / 120.0 - t2 * (1.0 / 5040.0 - t2 * (1.0 / 362880.0 - t2 * (1.0 / 39916800.0))))
        return qc, qw, sa, ca, c2
    t = math.sqrt(t2)
    sh = math.sin(0.5 * t)
    ch = math.cos(0.5 * t)
    st = 2.0 * sh * ch
    return sh / t, ch, st / t, 2.0 * sh * sh / t2, (t - st) / (t2 * t)


@jit(inline="always")
def quat_from_rotvec(x, y, z):
    """The unit quaternion ``(qx, qy, qz, qw)`` of the rotation vector ``(x, y, z)``: the series of
    :func:`rotation_coefficients` below 0.1 rad (no trigonometric function: a star tracker's noise,
    an estimator's correction), ``sin(t/2)/t`` and ``cos(t/2)`` above."""
    c, w, _, _, _ = rotation_coefficients(x * x + y * y + z * z)
    return c * x, c * y, c * z, w


@jit(inline="always")
def quat_mul(a0, a1, a2, a3, b0, b1, b2, b3):
    """The Hamilton product ``a b`` of scalar-last quaternions."""
    return (a3 * b0 + a0 * b3 + a1 * b2 - a2 * b1,
            a3 * b1 - a0 * b2 + a1 * b3 + a2 * b0,
            a3 * b2 + a0 * b1 - a1 * b0 + a2 * b3,
            a3 * b3 - a0 * b0 - a1 * b1 - a2 * b2)


@jit(inline="always")
def quat_normalised(q0, q1, q2, q3):
    """``q / |q|`` with the scalar part made nonnegative (one representative of the rotation)."""
    n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    if q3 < 0.0:
        n = -n
    return q0 / n, q1 / n, q2 / n, q3 / n


@jit(inline="always")
def quat_to_matrix(q0, q1, q2, q3, out, o):
    """Write the rotation matrix of the unit quaternion ``q`` into ``out[o:o + 9]`` (row-major)."""
    out[o + 0] = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
    out[o + 1] = 2.0 * (q0 * q1 - q2 * q3)
    out[o + 2] = 2.0 * (q0 * q2 + q1 * q3)
    out[o + 3] = 2.0 * (q0 * q1 + q2 * q3)
    out[o + 4] = 1.0 - 2.0 * (q0 * q0 + q2 * q2)
    out[o + 5] = 2.0 * (q1 * q2 - q0 * q3)
    out[o + 6] = 2.0 * (q0 * q2 - q1 * q3)
    out[o + 7] = 2.0 * (q1 * q2 + q0 * q3)
    out[o + 8] = 1.0 - 2.0 * (q0 * q0 + q1 * q1)


@jit(inline="always")
def quat_from_matrix(R, o):
    """The quaternion (scalar-last, scalar part >= 0) of the rotation matrix ``R[o:o + 9]``
    (row-major), by Shepperd's method (the largest of the four candidates, no cancellation)."""
    r00 = R[o]
    r11 = R[o + 4]
    r22 = R[o + 8]
    tr = r00 + r11 + r22
    if tr >= r00 and tr >= r11 and tr >= r22:
        w = 0.5 * math.sqrt(1.0 + tr)
        f = 0.25 / w
        x = (R[o + 7] - R[o + 5]) * f
        y = (R[o + 2] - R[o + 6]) * f
        z = (R[o + 3] - R[o + 1]) * f
    elif r00 >= r11 and r00 >= r22:
        x = 0.5 * math.sqrt(1.0 + 2.0 * r00 - tr)
        f = 0.25 / x
        w = (R[o + 7] - R[o + 5]) * f
        y = (R[o + 1] + R[o + 3]) * f
        z = (R[o + 2] + R[o + 6]) * f
    elif r11 >= r22:
        y = 0.5 * math.sqrt(1.0 + 2.0 * r11 - tr)
        f = 0.25 / y
        w = (R[o + 2] - R[o + 6]) * f
        x = (R[o + 1] + R[o + 3]) * f
        z = (R[o + 5] + R[o + 7]) * f
    else:
        z = 0.5 * math.sqrt(1.0 + 2.0 * r22 - tr)
        f = 0.25 / z
        w = (R[o + 3] - R[o + 1]) * f
        x = (R[o + 2] + R[o + 6]) * f
        y = (R[o + 5] + R[o + 7]) * f
    return quat_normalised(x, y, z, w)


@jit(inline="always")
def quat_from_matrix_scaled(R, o):
    """Shepperd's quaternion of ``R[o:o + 9]`` times ``4 c`` (``c`` its largest component, the one
    :func:`quat_from_matrix` takes a square root for): ``4 c^2`` from the diagonal and the other three
    from sums and differences of the off-diagonal entries, so no square root and no division. Its norm
    is ``4 c``, between 2 and 4 for a rotation matrix; the sign is either. For functions of the
    rotation that do not depend on the quaternion's scale (the mean rate of :mod:`.sensor_components`)."""
    r00 = R[o]
    r11 = R[o + 4]
    r22 = R[o + 8]
    tr = r00 + r11 + r22
    if tr >= r00 and tr >= r11 and tr >= r22:
        return R[o + 7] - R[o + 5], R[o + 2] - R[o + 6], R[o + 3] - R[o + 1], 1.0 + tr
    if r00 >= r11 and r00 >= r22:
        return 1.0 + 2.0 * r00 - tr, R[o + 1] + R[o + 3], R[o + 2] + R[o + 6], R[o + 7] - R[o + 5]
    if r11 >= r22:
        return R[o + 1] + R[o + 3], 1.0 + 2.0 * r11 - tr, R[o + 5] + R[o + 7], R[o + 2] - R[o + 6]
    return R[o + 2] + R[o + 6], R[o + 5] + R[o + 7], 1.0 + 2.0 * r22 - tr, R[o + 3] - R[o + 1]


#: ``x^2 = (s / w)^2 = tan^2(angle / 2)`` below which :func:`quat_rotvec_over` takes its series:
#: angles below 0.1 rad (2 atan(0.05) = 0.0999), where the series to ``x^10`` is exact to round-off
#: (the first term left out, ``x^12 / 13``, is below 2e-17 of the result).
ROTVEC_SERIES = 2.5e-3


@jit(inline="always")
def quat_rotvec_over(q0, q1, q2, q3, dt):
    """The rotation vector (angle in ``[0, pi]``) of the quaternion ``q`` divided by ``dt``:
    ``2 atan2(s, w) / s (q0, q1, q2) / dt``, ``s = |(q0, q1, q2)|``, ``w = q3`` made nonnegative.
    Independent of the norm of ``q`` (any nonzero scale, either sign: a product of scaled quaternions
    of :func:`quat_from_matrix_scaled` is fine).

    Below 0.1 rad (``x^2 = s^2 / w^2 < ROTVEC_SERIES``) ``atan(x) / x`` is its series ``1 - x^2/3 +
    x^4/5 - ... - x^10/11`` and the result ``2 atan(x)/x (q0, q1, q2) / (w dt)``: no square root, no
    ``atan2``, the division ``1 / w`` (and ``2 / dt``, off the chain); the same value as ``atan2`` to
    round-off (a few ulp; ``tests/test_sensors.py``). The series is summed in Estrin's form, three
    pairs ``(1 - x^2/3) + x^4 ((1/5 - x^2/7) + x^4 (1/9 - x^2/11))``: three dependent products and sums
    after ``x^4`` instead of Horner's ten (the gyro's mean rate waits for it). Larger angles, up to pi
    (``w`` near 0), take ``atan2``."""
    if q3 < 0.0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    s2 = q0 * q0 + q1 * q1 + q2 * q2
    if s2 < ROTVEC_SERIES * (q3 * q3):
        v = 1.0 / q3
        x2 = s2 * (v * v)
        x4 = x2 * x2
        a = 1.0 - x2 * (1.0 / 3.0)
        b = 0.2 - x2 * (1.0 / 7.0)
        c = 1.0 / 9.0 - x2 * (1.0 / 11.0)
        f = (2.0 / dt) * v * (a + x4 * (b + x4 * c))
        return f * q0, f * q1, f * q2
    s = math.sqrt(s2)
    f = 2.0 * math.atan2(s, q3) / s
    return f * q0 / dt, f * q1 / dt, f * q2 / dt


@jit(inline="always")
def quat_rotvec(q0, q1, q2, q3):
    """The rotation vector (angle in ``[0, pi]``) of the quaternion ``q`` (:func:`quat_rotvec_over`
    with ``dt = 1``: the series below 0.1 rad, ``atan2`` above)."""
    return quat_rotvec_over(q0, q1, q2, q3, 1.0)


@jit(inline="always")
def mat_vec(M, o, x, y, z):
    """``M[o:o + 9] (x, y, z)`` for a row-major 3x3 ``M``."""
    return (M[o] * x + M[o + 1] * y + M[o + 2] * z,
            M[o + 3] * x + M[o + 4] * y + M[o + 5] * z,
            M[o + 6] * x + M[o + 7] * y + M[o + 8] * z)


@jit(inline="always")
def mat_t_vec(M, o, x, y, z):
    """``M[o:o + 9]^T (x, y, z)`` for a row-major 3x3 ``M``."""
    return (M[o] * x + M[o + 3] * y + M[o + 6] * z,
            M[o + 1] * x + M[o + 4] * y + M[o + 7] * z,
            M[o + 2] * x + M[o + 5] * y + M[o + 8] * z)
