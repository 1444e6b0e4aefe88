"""Estimator components of the compiled loop (codes 400-499): the multiplicative extended Kalman
filter (MEKF) of Lefferts, Markley and Shuster (1982; Markley and Crassidis 2014, ch. 6).

The equations, derived, are in ``docs/estimation.md``; the symbols here are those of that page.
State: the attitude estimate ``q`` (scalar-last, of ``R_est``: body -> inertial), the gyro bias
estimate ``b`` and the 6x6 covariance ``P`` of the error ``x = (dtheta, db)`` with
``R = R_est Exp(dtheta)`` (the error angles in the body frame) and ``b = b_est + db``.

MEKF (code 401), reads gyro_B, st_q, st_valid, st_time, mag_B, mag_time, B_N, sun_B, sun_valid,
sun_time, sun_N, R; writes R_est, omega_est, bias_est, P_diag, est_error.
p: 0 sigma_v (ARW, rad/s^0.5), 1 sigma_u (RRW, rad/s^1.5), 2 star tracker sigma across the
   boresight (rad), 3 sigma about it (rad), 4..12 star tracker case -> body (row-major),
   13 magnetometer sigma (T), 14 sun sensor sigma (rad), 15 use the star tracker (0/1),
   16 use the magnetometer, 17 use the sun sensor, 18 largest admissible covariance diagonal
   (beyond it, or not finite: status 2), 19 the gyro's output (0: rates at the samples, propagated
   by the trapezoid; 1: mean rates over each sample interval, propagated as constant),
   20..28 the star tracker's noise covariance in the body frame, C diag(sx^2, sx^2, sz^2) C^T
   (row-major; set once by the Python class)
s: 0..3 q, 4..6 b, 7..42 P (6x6 row-major), 43 time of the last run (NaN before the first),
   44..46 the gyro sample of the last run, 47..49 times of the last star tracker, magnetometer and
   sun measurements used (each measurement is used once)
"""

from __future__ import annotations

import math

from .._jit import jit
from .attitude_kernels import (mat_t_vec, quat_from_matrix_scaled, quat_from_rotvec, quat_mul, quat_normalised,
                               quat_rotvec, quat_to_matrix, rotation_coefficients)
from .navigation_components import SIMPLE_NAV, simple_nav_step

MEKF = 401
_P = 7          # offset of P in the state
#: The state's work space (after the 50 entries of the filter): the small matrices of the
#: propagation and the updates live there, so the kernel allocates nothing (the loop is compiled
#: without Numba's runtime). Offsets: A, B (propagation), M; PH, S, (Si: unused since S^-1 lives in
#: scalars), K, U = K S / 2 - PH (update, the Joseph form's factor); H, Rm, R.
#: They are indexed flat, row-major (``s[_WK + 3 * i + j]`` is ``K[i, j]``): reshaped views of
#: slices cost a call each, which was a third of the filter's time.
_WA, _WB, _WM = 50, 59, 68
_WPH, _WS, _WSI, _WK, _WKS = 86, 104, 113, 122, 140
_WH, _WRM, _WR = 158, 167, 176
#: The length of the state: the filter's 50 entries and the work space.
STATE_SIZE = 185


@jit(inline="always")
def turn(s, x, y, z):
    """``q <- q Exp((x, y, z))`` for the estimate's quaternion ``s[0:4]``, renormalised."""
    d0, d1, d2, d3 = quat_from_rotvec(x, y, z)
    q0, q1, q2, q3 = quat_mul(s[0], s[1], s[2], s[3], d0, d1, d2, d3)
    q0, q1, q2, q3 = quat_normalised(q0, q1, q2, q3)
    s[0] = q0
    s[1] = q1
    s[2] = q2
    s[3] = q3


@jit(inline="always")
def propagate(s, ax, ay, az, wx, wy, wz, dt, sv2, su2):
    """Move the estimate and the covariance from ``t`` to ``t + dt`` with the bias-corrected gyro
    samples ``a`` (at ``t``) and ``w`` (at ``t + dt``): the attitude by the rotation vector
    ``phi = dt (a + w)/2 + dt^2/12 a x w``, the covariance by ``Phi P Phi^T + Qd``."""
    px = 0.5 * dt * (ax + wx) + dt * dt / 12.0 * (ay * wz - az * wy)
    py = 0.5 * dt * (ay + wy) + dt * dt / 12.0 * (az * wx - ax * wz)
    pz = 0.5 * dt * (az + wz) + dt * dt / 12.0 * (ax * wy - ay * wx)
    # the five coefficients of the step's rotation at once: its quaternion's and Rodrigues' (series
    # below 0.1 rad, else one sine and cosine of half the angle)
    t2 = px * px + py * py + pz * pz
    qc, qw, sa, ca, c2 = rotation_coefficients(t2)
    q0, q1, q2, q3 = quat_mul(s[0], s[1], s[2], s[3], qc * px, qc * py, qc * pz, qw)
    q0, q1, q2, q3 = quat_normalised(q0, q1, q2, q3)
    s[0] = q0
    s[1] = q1
    s[2] = q2
    s[3] = q3
    # Phi = [[A, B], [0, I]]: A = Exp(-phi), B = -dt (I - c1 hat(phi) + c2 hat(phi)^2)
    h00 = -(py * py + pz * pz)                             # hat(phi)^2 = phi phi^T - t2 I
    h11 = -(px * px + pz * pz)
    h22 = -(px * px + py * py)
    h01 = px * py
    h02 = px * pz
    h12 = py * pz
    s[_WA] = 1.0 + ca * h00
    s[_WA + 4] = 1.0 + ca * h11
    s[_WA + 8] = 1.0 + ca * h22
    s[_WA + 1] = sa * pz + ca * h01
    s[_WA + 3] = -sa * pz + ca * h01
    s[_WA + 2] = -sa * py + ca * h02
    s[_WA + 6] = sa * py + ca * h02
    s[_WA + 5] = sa * px + ca * h12
    s[_WA + 7] = -sa * px + ca * h12
    s[_WB] = -dt * (1.0 + c2 * h00)
    s[_WB + 4] = -dt * (1.0 + c2 * h11)
    s[_WB + 8] = -dt * (1.0 + c2 * h22)
    s[_WB + 1] = -dt * (ca * pz + c2 * h01)
    s[_WB + 3] = -dt * (-ca * pz + c2 * h01)
    s[_WB + 2] = -dt * (-ca * py + c2 * h02)
    s[_WB + 6] = -dt * (ca * py + c2 * h02)
    s[_WB + 5] = -dt * (ca * px + c2 * h12)
    s[_WB + 7] = -dt * (-ca * px + c2 * h12)
    # M = Phi P: rows 0..2 = A P[0:3, :] + B P[3:6, :], rows 3..5 = P[3:6, :]
    for i in range(3):
        for j in range(6):
            s[_WM + 6 * i + j] = (s[_WA + 3 * i] * s[_P + j] + s[_WA + 3 * i + 1] * s[_P + 6 + j]
                                  + s[_WA + 3 * i + 2] * s[_P + 12 + j] + s[_WB + 3 * i] * s[_P + 18 + j]
                                  + s[_WB + 3 * i + 1] * s[_P + 24 + j] + s[_WB + 3 * i + 2] * s[_P + 30 + j])
    # P' = M Phi^T + Qd
    q11 = sv2 * dt + su2 * dt * dt * dt / 3.0
    q12 = -0.5 * su2 * dt * dt
    q22 = su2 * dt
    for i in range(3):
        for j in range(i, 3):
            v = 0.0
            for k in range(3):
                v += s[_WM + 6 * i + k] * s[_WA + 3 * j + k] + s[_WM + 6 * i + 3 + k] * s[_WB + 3 * j + k]
            if i == j:
                v += q11
            s[_P + 6 * i + j] = v
            s[_P + 6 * j + i] = v
        for j in range(3):
            v = s[_WM + 6 * i + 3 + j] + (q12 if i == j else 0.0)
            s[_P + 6 * i + 3 + j] = v
            s[_P + 6 * (3 + j) + i] = v
    for i in range(3):
        s[_P + 6 * (3 + i) + 3 + i] += q22


@jit(inline="always")
def update(s, y0, y1, y2):
    """The Kalman update with the measurement ``y = H dtheta + v`` (``H`` 3x3 on the attitude block,
    ``v ~ N(0, Rm)``; both in the work space, row-major at ``_WH`` and ``_WRM``), in Joseph form,
    then the reset of the error into ``q`` and ``b``.
    Returns False when the innovation covariance is not positive definite."""
    # PH = P[:, 0:3] H^T (6x3), S = H PH[0:3] + Rm
    for i in range(6):
        for j in range(3):
            s[_WPH + 3 * i + j] = (s[_P + 6 * i] * s[_WH + 3 * j] + s[_P + 6 * i + 1] * s[_WH + 3 * j + 1]
                                   + s[_P + 6 * i + 2] * s[_WH + 3 * j + 2])
    for i in range(3):
        for j in range(3):
            s[_WS + 3 * i + j] = (s[_WH + 3 * i] * s[_WPH + j] + s[_WH + 3 * i + 1] * s[_WPH + 3 + j]
                                  + s[_WH + 3 * i + 2] * s[_WPH + 6 + j] + s[_WRM + 3 * i + j])
    return update_with(s, y0, y1, y2)


@jit(inline="always")
def update_attitude(s, y0, y1, y2):
    """:func:`update` with ``H = I`` (the star tracker's): ``PH = P[:, 0:3]`` and
    ``S = P[0:3, 0:3] + Rm`` taken as they are, the same numbers as the products with ``I``."""
    for i in range(6):
        for j in range(3):
            s[_WPH + 3 * i + j] = s[_P + 6 * i + j]
    for i in range(3):
        for j in range(3):
            s[_WS + 3 * i + j] = s[_WPH + 3 * i + j] + s[_WRM + 3 * i + j]
    return update_with(s, y0, y1, y2)


@jit(inline="always")
def update_with(s, y0, y1, y2):
    """The gain, the Joseph-form covariance and the reset, from ``PH = P H^T`` and ``S``."""
    # S^-1 by cofactors of S's upper triangle (S is symmetric; bit for bit only for the star tracker,
    # H = I: for H = hat(p) its two triangles are summed in different orders and differ by round-off,
    # and reading one of them symmetrises it), so six of them, and one division (1 / det)
    S0 = s[_WS]
    S1 = s[_WS + 1]
    S2 = s[_WS + 2]
    S4 = s[_WS + 4]
    S5 = s[_WS + 5]
    S8 = s[_WS + 8]
    c00 = S4 * S8 - S5 * S5
    c01 = S5 * S2 - S1 * S8
    c02 = S1 * S5 - S4 * S2
    det = S0 * c00 + S1 * c01 + S2 * c02
    if not (det > 0.0 and S0 > 0.0 and S0 * S4 - S1 * S1 > 0.0):
        return False
    r = 1.0 / det
    i00 = c00 * r
    i01 = c01 * r
    i02 = c02 * r
    i11 = (S0 * S8 - S2 * S2) * r
    i12 = (S2 * S1 - S0 * S5) * r
    i22 = (S0 * S4 - S1 * S1) * r
    # K = PH S^-1 and, for the Joseph form, U = K S / 2 - PH: P - K PH^T - PH K^T + K S K^T
    # = P + U K^T + K U^T (the same polynomial in K, so an error in K still enters at second order;
    # six products an entry instead of nine)
    for i in range(6):
        a0 = s[_WPH + 3 * i]
        a1 = s[_WPH + 3 * i + 1]
        a2 = s[_WPH + 3 * i + 2]
        k0 = a0 * i00 + a1 * i01 + a2 * i02
        k1 = a0 * i01 + a1 * i11 + a2 * i12
        k2 = a0 * i02 + a1 * i12 + a2 * i22
        s[_WK + 3 * i] = k0
        s[_WK + 3 * i + 1] = k1
        s[_WK + 3 * i + 2] = k2
        s[_WKS + 3 * i] = 0.5 * (k0 * S0 + k1 * S1 + k2 * S2) - a0
        s[_WKS + 3 * i + 1] = 0.5 * (k0 * S1 + k1 * S4 + k2 * S5) - a1
        s[_WKS + 3 * i + 2] = 0.5 * (k0 * S2 + k1 * S5 + k2 * S8) - a2
    for i in range(6):
        u0 = s[_WKS + 3 * i]
        u1 = s[_WKS + 3 * i + 1]
        u2 = s[_WKS + 3 * i + 2]
        k0 = s[_WK + 3 * i]
        k1 = s[_WK + 3 * i + 1]
        k2 = s[_WK + 3 * i + 2]
        for j in range(i, 6):
            v = s[_P + 6 * i + j] + (u0 * s[_WK + 3 * j] + u1 * s[_WK + 3 * j + 1] + u2 * s[_WK + 3 * j + 2]
                                     + k0 * s[_WKS + 3 * j] + k1 * s[_WKS + 3 * j + 1] + k2 * s[_WKS + 3 * j + 2])
            s[_P + 6 * i + j] = v
            s[_P + 6 * j + i] = v
    # the error estimate and the reset: q <- q Exp(dtheta), b <- b + db
    dx = s[_WK] * y0 + s[_WK + 1] * y1 + s[_WK + 2] * y2
    dy = s[_WK + 3] * y0 + s[_WK + 4] * y1 + s[_WK + 5] * y2
    dz = s[_WK + 6] * y0 + s[_WK + 7] * y1 + s[_WK + 8] * y2
    for i in range(3):
        s[4 + i] += s[_WK + 3 * (3 + i)] * y0 + s[_WK + 3 * (3 + i) + 1] * y1 + s[_WK + 3 * (3 + i) + 2] * y2
    turn(s, dx, dy, dz)
    return True


@jit(inline="always")
def vector_update(s, bx, by, bz, mx, my, mz, sigma):
    """Update with a measured body-frame vector ``m`` of the inertial vector ``b``: the prediction
    ``p = R_est^T b``, ``H = hat(p)``, noise ``sigma^2 I``."""
    quat_to_matrix(s[0], s[1], s[2], s[3], s, _WR)
    px, py, pz = mat_t_vec(s, _WR, bx, by, bz)
    for i in range(9):
        s[_WH + i] = 0.0
        s[_WRM + i] = 0.0
    s[_WH + 1] = -pz
    s[_WH + 2] = py
    s[_WH + 3] = pz
    s[_WH + 5] = -px
    s[_WH + 6] = -py
    s[_WH + 7] = px
    v = sigma * sigma
    s[_WRM] = v
    s[_WRM + 4] = v
    s[_WRM + 8] = v
    return update(s, mx - px, my - py, mz - pz)


@jit(inline="always")
def mekf_step(t, bus, p, s, w):
    g = w[0]
    mx = bus[g]
    my = bus[g + 1]
    mz = bus[g + 2]
    if s[43] == s[43]:            # not the first run: propagate from the last one
        dt = t - s[43]
        if dt > 0.0:
            if p[19] != 0.0:      # the sample is the mean rate over (t - dt, t]: a constant rate
                propagate(s, mx - s[4], my - s[5], mz - s[6], mx - s[4], my - s[5], mz - s[6], dt,
                          p[0] * p[0], p[1] * p[1])
            else:                 # rates at the samples: the trapezoid and its commutator term
                propagate(s, s[44] - s[4], s[45] - s[5], s[46] - s[6], mx - s[4], my - s[5], mz - s[6], dt,
                          p[0] * p[0], p[1] * p[1])
    s[43] = t
    s[44] = mx
    s[45] = my
    s[46] = mz
    ok = True
    # star tracker: the attitude error measured directly, H = I, noise C diag(sx^2, sx^2, sz^2) C^T
    if p[15] != 0.0 and bus[w[2]] != 0.0 and bus[w[3]] > s[47]:
        s[47] = bus[w[3]]
        o = w[1]
        e0, e1, e2, e3 = quat_mul(-s[0], -s[1], -s[2], s[3], bus[o], bus[o + 1], bus[o + 2], bus[o + 3])
        y0, y1, y2 = quat_rotvec(e0, e1, e2, e3)
        for i in range(9):                   # R_m = C diag(sx^2, sx^2, sz^2) C^T, computed once in the row
            s[_WRM + i] = p[20 + i]
        ok = update_attitude(s, y0, y1, y2)
    if ok and p[16] != 0.0 and bus[w[5]] > s[48]:
        s[48] = bus[w[5]]
        f = w[6]
        m = w[4]
        ok = vector_update(s, bus[f], bus[f + 1], bus[f + 2], bus[m], bus[m + 1], bus[m + 2], p[13])
    if ok and p[17] != 0.0 and bus[w[8]] != 0.0 and bus[w[9]] > s[49]:
        s[49] = bus[w[9]]
        f = w[10]
        m = w[7]
        ok = vector_update(s, bus[f], bus[f + 1], bus[f + 2], bus[m], bus[m + 1], bus[m + 2], p[14])
    # outputs: R_est, omega_est, bias_est, P_diag, est_error
    quat_to_matrix(s[0], s[1], s[2], s[3], bus, w[12])
    o = w[13]
    bus[o] = mx - s[4]
    bus[o + 1] = my - s[5]
    bus[o + 2] = mz - s[6]
    o = w[14]
    bus[o] = s[4]
    bus[o + 1] = s[5]
    bus[o + 2] = s[6]
    o = w[15]
    good = ok
    for i in range(6):
        d = s[_P + 7 * i]
        bus[o + i] = d
        if not (d > 0.0 and d <= p[18]):      # NaN fails too
            good = False
    # the truth's quaternion scaled (no square root, no division): the error's rotation vector does
    # not depend on the scale
    t0, t1, t2, t3 = quat_from_matrix_scaled(bus, w[11])
    e0, e1, e2, e3 = quat_mul(-s[0], -s[1], -s[2], s[3], t0, t1, t2, t3)
    x, y, z = quat_rotvec(e0, e1, e2, e3)
    o = w[16]
    bus[o] = x
    bus[o + 1] = y
    bus[o + 2] = z
    if not good or not (s[0] == s[0] and s[4] + s[5] + s[6] == s[4] + s[5] + s[6]):
        return 2
    return 0


@jit(_nrt=False)
def estimator_dispatch(code, t, bus, p, s, w):
    """Run the built-in estimator kind ``code`` (400-499); an unknown code returns status 3 (compiled
    without Numba's runtime, as :func:`.sensor_components.sensor_dispatch`)."""
    if code == MEKF:
        return mekf_step(t, bus, p, s, w)
    if code == SIMPLE_NAV:
        return simple_nav_step(t, bus, p, s, w)
    return 3
