"""Sensor components of the compiled loop (codes 300-399): ``step(t, bus, p, s, w) -> int``.

Each kind reads the truth (``R``, ``omega``) and the environment (``B_N``, ``sun_N``, ``shadow``,
``r_N``) from the bus at the offsets ``w`` (its kind's ``reads`` then ``writes``), and writes its
measurement. Parameter rows ``p`` and states ``s`` are laid out by the Python classes of
:mod:`lgvi.spacecraft.sensors` (the layouts are repeated above each kind). Every random draw comes
from :mod:`lgvi._kernels.random` with ``(seed, stream) = (p[0], p[1])`` and the counter ``s[0]``
(counted in normals), so a measurement is a pure function of the member's seed, the sensor's
stream and the sample number.

All measurements are taken at the step's time from the truth on the bus ("instantaneous"
sampling, as Basilisk's sensors do). Each kind tests the values it writes (:mod:`.finite`) and
returns 1 when one is not finite; the loop runs no test after a sensor.
"""

from __future__ import annotations

import math

from .._jit import jit
from .attitude_kernels import (mat_t_vec, mat_vec, quat_from_matrix, quat_from_matrix_scaled, quat_from_rotvec, quat_mul,
                                quat_rotvec_over)
from .finite import finite_status, written
from .random import normal_at, normals3_at, stream_key

GYRO = 301
STAR_TRACKER = 302
MAGNETOMETER = 303
COARSE_SUN_SENSORS = 304
FINE_SUN_SENSOR = 305


@jit(inline="always")
def quantise(x, lsb, nearest):
    """``x`` on the grid of step ``lsb`` (Basilisk's ``Discretize``: towards zero, or to the nearest)."""
    if lsb <= 0.0:
        return x
    a = abs(x) / lsb
    a = math.floor(a + 0.5) if nearest else math.floor(a)
    return math.copysign(a * lsb, x)


@jit(inline="always")
def saturate(x, limit):
    return min(max(x, -limit), limit)


@jit(inline="always")
def sun_in_body(bus, w):
    """``R^T sun_N`` for a kind that reads ``R`` then ``sun_N`` (offsets ``w[0]``, ``w[1]``)."""
    u = w[1]
    return mat_t_vec(bus, w[0], bus[u], bus[u + 1], bus[u + 2])


# --------------------------------------------------------------------------------------------------
# gyro (Basilisk imuSensor's rate channel), reads omega, R; writes gyro_B, gyro_bias
# p: 0 seed, 1 stream, 2 dt (sample period, s), 3 sigma_v (ARW, rad/s^0.5), 4 sigma_u (RRW,
#    rad/s^1.5), 5..13 M (body -> gyro axes, row-major; misalignment), 14..16 constant bias (rad/s),
#    17..19 scale factor (multiplies, Basilisk's gyroScale), 20 saturation (rad/s, inf: none),
#    21 LSB (rad/s, 0: none), 22 rounding (0 towards zero, 1 nearest), 23 output (0: the rate at the
#    sample, Basilisk's omega_PN_P; 1: the mean rate over the sample interval, log(R_prev^T R) / dt,
#    Basilisk's prv_PN / dt; the first sample gives the rate), 24..26 bounds of the rate random walk
#    per axis (rad/s, inf: none; Basilisk's walkBoundsGyro), 27 sigma_v / sqrt(dt) (the white rate
#    noise of a sample), 28 sigma_u sqrt(dt) (the walk's step per sample): 27 and 28 are set once by
#    the Python class, so a sample computes no square root
# s: 0 counter (normals), 1..3 rate-random-walk part of the bias (rad/s), 4..7 the scaled quaternion of R
#    at the last sample (mean-rate output), 8: 1 once a sample was taken
# --------------------------------------------------------------------------------------------------
@jit(inline="always")
def gyro_step(t, bus, p, s, w):
    key = stream_key(p[0], p[1])
    c = s[0]
    n0, n1, n2 = normals3_at(key, c)
    n3, n4, n5 = normals3_at(key, c + 3)
    s[0] = c + 6
    sv = p[27]                              # white rate noise of the sample: ARW / sqrt(dt)
    su = p[28]                              # bias increment over a sample: RRW sqrt(dt)
    o = w[0]
    x, y, z = bus[o], bus[o + 1], bus[o + 2]
    if p[23] != 0.0:
        # the rotation vector of R_prev^T R over the sample period: the mean rate, exactly; the
        # quaternion of R is kept for the next sample (one conversion a sample, scaled: norm 2 to 4,
        # either sign; the rotation vector depends on neither: quat_rotvec_over, its series below
        # 0.1 rad with no square root, no atan2 and one division)
        f0, f1, f2, f3 = quat_from_matrix_scaled(bus, w[1])
        if s[8] != 0.0:
            d0, d1, d2, d3 = quat_mul(-s[4], -s[5], -s[6], s[7], f0, f1, f2, f3)
            x, y, z = quat_rotvec_over(d0, d1, d2, d3, p[2])
        s[4] = f0
        s[5] = f1
        s[6] = f2
        s[7] = f3
        s[8] = 1.0
    x, y, z = mat_vec(p, 5, x, y, z)
    b0 = p[14] + s[1]
    b1 = p[15] + s[2]
    b2 = p[16] + s[3]
    g = w[2]
    near = p[22] != 0.0
    g0 = saturate(quantise(p[17] * (x + b0 + sv * n0), p[21], near), p[20])
    g1 = saturate(quantise(p[18] * (y + b1 + sv * n1), p[21], near), p[20])
    g2 = saturate(quantise(p[19] * (z + b2 + sv * n2), p[21], near), p[20])
    bus[g] = g0
    bus[g + 1] = g1
    bus[g + 2] = g2
    b = w[3]
    bus[b] = b0
    bus[b + 1] = b1
    bus[b + 2] = b2
    # the walk's step, then its bounds (Basilisk's GaussMarkov: clipped to +-bound; inf: unbounded)
    s[1] = saturate(s[1] + su * n3, p[24])
    s[2] = saturate(s[2] + su * n4, p[25])
    s[3] = saturate(s[3] + su * n5, p[26])
    return finite_status(written(g0, g1, g2) + written(b0, b1, b2))


# --------------------------------------------------------------------------------------------------
# star tracker, reads R, sun_N, r_N; writes st_q, st_valid, st_time
# p: 0 seed, 1 stream, 2 sigma across the boresight (rad, about case x and y), 3 sigma about the
#    boresight (rad, case z), 4..12 C (case -> body, row-major; the boresight is case z),
#    13 cos of the sun exclusion angle (> 1: none), 14 Earth exclusion angle beyond the limb (rad,
#    < 0: none), 15 Earth radius (m), 16, 17 cos and sin of the Earth exclusion angle
# s: 0 counter
# The measured attitude is R Exp(C e), e = (sx n0, sx n1, sz n2) in the case frame.
# --------------------------------------------------------------------------------------------------
@jit(inline="always")
def star_tracker_step(t, bus, p, s, w):
    o = w[0]
    # boresight in N: R C e_z
    bx, by, bz = mat_vec(bus, o, p[6], p[9], p[12])
    valid = True
    if p[13] <= 1.0:
        u = w[1]
        sx = bus[u]
        sy = bus[u + 1]
        sz = bus[u + 2]
        ns = math.sqrt(sx * sx + sy * sy + sz * sz)
        if ns > 0.0 and (bx * sx + by * sy + bz * sz) > p[13] * ns:
            valid = False
    if p[14] >= 0.0:
        r = w[2]
        rx = bus[r]
        ry = bus[r + 1]
        rz = bus[r + 2]
        nr = math.sqrt(rx * rx + ry * ry + rz * rz)
        if nr > p[15]:
            # the angle between the boresight and the nadir, theta = acos(c), against the Earth's
            # angular radius plus the margin, a = asin(x) + m: theta < a iff a >= pi (then always), else
            # iff c > cos(a) = sqrt(1 - x^2) cos m - x sin m (cos decreases on [0, pi]); a >= pi iff
            # m >= pi/2 and x >= sin m (asin(x) <= pi/2). No inverse trigonometric function.
            c = -(bx * rx + by * ry + bz * rz) / nr
            x = p[15] / nr
            if (p[14] >= 0.5 * math.pi and x >= p[17]) or c > math.sqrt(1.0 - x * x) * p[16] - x * p[17]:
                valid = False
    key = stream_key(p[0], p[1])
    c = s[0]
    s[0] = c + 3
    v = w[4]
    if not valid:
        bus[v] = 0.0
        return 0
    n0, n1, n2 = normals3_at(key, c)
    ex, ey, ez = mat_vec(p, 4, p[2] * n0, p[2] * n1, p[3] * n2)
    d0, d1, d2, d3 = quat_from_rotvec(ex, ey, ez)
    q0, q1, q2, q3 = quat_from_matrix(bus, o)
    m0, m1, m2, m3 = quat_mul(q0, q1, q2, q3, d0, d1, d2, d3)
    if m3 < 0.0:
        m0, m1, m2, m3 = -m0, -m1, -m2, -m3
    q = w[3]
    bus[q] = m0
    bus[q + 1] = m1
    bus[q + 2] = m2
    bus[q + 3] = m3
    bus[v] = 1.0
    bus[w[5]] = t
    return finite_status(written(m0, m1, m2) + written(m3, t, 0.0))


# --------------------------------------------------------------------------------------------------
# magnetometer, reads R, B_N; writes mag_B, mag_time
# p: 0 seed, 1 stream, 2 sigma (T, each axis), 3..11 M (body -> sensor axes, row-major),
#    12..14 bias (T)
# s: 0 counter
# --------------------------------------------------------------------------------------------------
@jit(inline="always")
def magnetometer_step(t, bus, p, s, w):
    o = w[0]
    f = w[1]
    bx, by, bz = mat_t_vec(bus, o, bus[f], bus[f + 1], bus[f + 2])       # R^T B_N
    x, y, z = mat_vec(p, 3, bx, by, bz)
    key = stream_key(p[0], p[1])
    c = s[0]
    s[0] = c + 3
    n0, n1, n2 = normals3_at(key, c)
    m = w[2]
    x = x + p[12] + p[2] * n0
    y = y + p[13] + p[2] * n1
    z = z + p[14] + p[2] * n2
    bus[m] = x
    bus[m + 1] = y
    bus[m + 2] = z
    bus[w[3]] = t
    return finite_status(written(x, y, z) + t * 0.0)


# --------------------------------------------------------------------------------------------------
# coarse sun sensors (N heads), reads R, sun_N, shadow; writes css (N)
# p: 0 seed, 1 stream, 2 sigma (output units), 3 N, 4 scale (output at normal incidence, full sun),
#    5 cos of the field-of-view half angle, 6 max output, 7.. the unit normals (N, 3) in B
# s: 0 counter
# output_i = clip(scale shadow cos(a_i) [cos(a_i) >= max(cos(fov), 0)] + sigma n_i, 0, max)
# (no albedo: Earth's reflected light is not modelled)
# --------------------------------------------------------------------------------------------------
@jit(inline="always")
def coarse_sun_sensors_step(t, bus, p, s, w):
    sx, sy, sz = sun_in_body(bus, w)
    lit = bus[w[2]]
    key = stream_key(p[0], p[1])
    N = int(p[3])
    c0 = s[0]
    out = w[3]
    z = 0.0
    for i in range(N):
        n0 = normal_at(key, c0 + i)
        k = 7 + 3 * i
        c = p[k] * sx + p[k + 1] * sy + p[k + 2] * sz
        signal = lit * c if c >= p[5] and c > 0.0 else 0.0
        v = min(max(p[4] * signal + p[2] * n0, 0.0), p[6])
        bus[out + i] = v
        z += v * 0.0
    s[0] = c0 + N
    return finite_status(z)


# --------------------------------------------------------------------------------------------------
# fine sun sensor, reads R, sun_N, shadow; writes sun_B, sun_valid, sun_time
# p: 0 seed, 1 stream, 2 sigma (rad, each of two axes across the sun line), 3..11 C (sensor -> body,
#    row-major; boresight sensor z), 12 cos of the field-of-view half angle, 13 least shadow value
#    (the fraction of the solar disc) for a measurement
# s: 0 counter
# --------------------------------------------------------------------------------------------------
@jit(inline="always")
def fine_sun_sensor_step(t, bus, p, s, w):
    sx, sy, sz = sun_in_body(bus, w)
    n = math.sqrt(sx * sx + sy * sy + sz * sz)
    key = stream_key(p[0], p[1])
    c0 = s[0]
    s[0] = c0 + 2
    v = w[4]
    c = (p[5] * sx + p[8] * sy + p[11] * sz) / n if n > 0.0 else -2.0      # boresight . sun
    if bus[w[2]] < p[13] or c < p[12]:
        bus[v] = 0.0
        return 0
    sx /= n
    sy /= n
    sz /= n
    # two unit vectors across the sun line: e1 = s x a (a: the axis of the smallest component)
    ax = abs(sx)
    ay = abs(sy)
    az = abs(sz)
    if ax <= ay and ax <= az:
        e1x, e1y, e1z = 0.0, sz, -sy
    elif ay <= az:
        e1x, e1y, e1z = -sz, 0.0, sx
    else:
        e1x, e1y, e1z = sy, -sx, 0.0
    m = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    e1x /= m
    e1y /= m
    e1z /= m
    e2x = sy * e1z - sz * e1y
    e2y = sz * e1x - sx * e1z
    e2z = sx * e1y - sy * e1x
    # rotate the sun line by the small angle sigma (n0, n1) across it: exact on the sphere
    a = p[2] * normal_at(key, c0)
    b = p[2] * normal_at(key, c0 + 1)
    th = math.sqrt(a * a + b * b)
    if th > 0.0:
        k = math.sin(th) / th
        cs = math.cos(th)
    else:
        k = 1.0
        cs = 1.0
    r = w[3]
    ux = cs * sx + k * (a * e1x + b * e2x)
    uy = cs * sy + k * (a * e1y + b * e2y)
    uz = cs * sz + k * (a * e1z + b * e2z)
    bus[r] = ux
    bus[r + 1] = uy
    bus[r + 2] = uz
    bus[v] = 1.0
    bus[w[5]] = t
    return finite_status(written(ux, uy, uz) + t * 0.0)


@jit(_nrt=False)
def sensor_dispatch(code, t, bus, p, s, w):
    """Run the built-in sensor kind ``code`` (300-399); an unknown code returns status 3.

    Compiled without Numba's runtime (nothing here allocates): no reference counts of the four
    arrays on each call."""
    if code == GYRO:
        return gyro_step(t, bus, p, s, w)
    elif code == STAR_TRACKER:
        return star_tracker_step(t, bus, p, s, w)
    elif code == MAGNETOMETER:
        return magnetometer_step(t, bus, p, s, w)
    elif code == COARSE_SUN_SENSORS:
        return coarse_sun_sensors_step(t, bus, p, s, w)
    elif code == FINE_SUN_SENSOR:
        return fine_sun_sensor_step(t, bus, p, s, w)
    return 3
