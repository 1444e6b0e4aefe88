"""Estimator components of the compiled loop (codes 400-499): the multiplicative extended Kalman
filter (MEKF) of Lefferts, Markley and Shuster (1982; Markley and Crassidis 2014, ch. 6).

The equations, derived, are in ``docs/estimation.md``; the symbols here are those of that page.
State: the attitude estimate ``q`` (scalar-last, of ``R_est``: body -> inertial), the gyro bias
estimate ``b`` and the 6x6 covariance ``P`` of the error ``x = (dtheta, db)`` with
``R = R_est Exp(dtheta)`` (the error angles in the body frame) and ``b = b_est + db``.

MEKF (code 401), reads gyro_B, st_q, st_valid, st_time, mag_B, mag_time, B_N, sun_B, sun_valid,
sun_time, sun_N, R; writes R_est, omega_est, bias_est, P_diag, est_error. Status 2 when the covariance or
the state is not finite (or a diagonal exceeds p[18]), else 1 when a value it wrote is not finite
(it tests its own writes, :mod:`.finite`; the loop tests nothing after an estimator), else 0.
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
from .finite import finite_status, written, written_at
from .navigation_components import SIMPLE_NAV, simple_nav_step

MEKF = 401
_P = 7          # offset of P in the state
#: The state's work space (after the 50 entries of the filter): the small matrices of the updates
#: live there, so the kernel allocates nothing (the loop is compiled without Numba's runtime).
#: Offsets: PH, S (update), H, Rm, R (vector updates). Unused since the propagation's Phi and Phi P
#: and the update's K and U became locals (round 8), their slots kept so that the state's length and
#: saved states stay as they were: A, B, M, Si, K, U.
#: They are indexed flat, row-major (``s[_WPH + 3 * i + j]`` is ``PH[i, j]``): reshaped views of
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
def put_sym(s, i, j, v):
    """``P[i, j] = P[j, i] = v`` in the state."""
    s[_P + 6 * i + j] = v
    s[_P + 6 * j + i] = v


@jit(inline="always")
def phi_row(a0, a1, a2, b0, b1, b2, p00, p01, p02, p03, p04, p05, p11, p12, p13, p14, p15, p22, p23, p24, p25,
            p33, p34, p35, p44, p45, p55):
    """Row ``(A[i], B[i]) P`` of ``Phi P`` from ``P``'s upper triangle (six sums of six products, the
    products in the order of the row's entries)."""
    return (a0 * p00 + a1 * p01 + a2 * p02 + b0 * p03 + b1 * p04 + b2 * p05,
            a0 * p01 + a1 * p11 + a2 * p12 + b0 * p13 + b1 * p14 + b2 * p15,
            a0 * p02 + a1 * p12 + a2 * p22 + b0 * p23 + b1 * p24 + b2 * p25,
            a0 * p03 + a1 * p13 + a2 * p23 + b0 * p33 + b1 * p34 + b2 * p35,
            a0 * p04 + a1 * p14 + a2 * p24 + b0 * p34 + b1 * p44 + b2 * p45,
            a0 * p05 + a1 * p15 + a2 * p25 + b0 * p35 + b1 * p45 + b2 * p55)


@jit(inline="always")
def phi_col(m0, m1, m2, m3, m4, m5, a0, a1, a2, b0, b1, b2):
    """``M[i] Phi[j]^T`` for a row ``M[i]`` of ``Phi P`` and the attitude row ``Phi[j] = (A[j], B[j])``."""
    return (m0 * a0 + m3 * b0) + (m1 * a1 + m4 * b1) + (m2 * a2 + m5 * b2)


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
    a00 = 1.0 + ca * h00
    a11 = 1.0 + ca * h11
    a22 = 1.0 + ca * h22
    a01 = sa * pz + ca * h01
    a10 = -sa * pz + ca * h01
    a02 = -sa * py + ca * h02
    a20 = sa * py + ca * h02
    a12 = sa * px + ca * h12
    a21 = -sa * px + ca * h12
    b00 = -dt * (1.0 + c2 * h00)
    b11 = -dt * (1.0 + c2 * h11)
    b22 = -dt * (1.0 + c2 * h22)
    b01 = -dt * (ca * pz + c2 * h01)
    b10 = -dt * (-ca * pz + c2 * h01)
    b02 = -dt * (-ca * py + c2 * h02)
    b20 = -dt * (ca * py + c2 * h02)
    b12 = -dt * (ca * px + c2 * h12)
    b21 = -dt * (-ca * px + c2 * h12)
    # P's upper triangle in locals (P is symmetric by construction: every write sets both triangles,
    # so reading P[j, i] for P[i, j] gives the same numbers)
    p00, p01, p02, p03, p04, p05 = s[_P], s[_P + 1], s[_P + 2], s[_P + 3], s[_P + 4], s[_P + 5]
    p11, p12, p13, p14, p15 = s[_P + 7], s[_P + 8], s[_P + 9], s[_P + 10], s[_P + 11]
    p22, p23, p24, p25 = s[_P + 14], s[_P + 15], s[_P + 16], s[_P + 17]
    p33, p34, p35 = s[_P + 21], s[_P + 22], s[_P + 23]
    p44, p45 = s[_P + 28], s[_P + 29]
    p55 = s[_P + 35]
    # M = Phi P, its rows 0..2 (rows 3..5 are P[3:6, :]): row i = A[i] P[0:3, :] + B[i] P[3:6, :]
    m00, m01, m02, m03, m04, m05 = phi_row(a00, a01, a02, b00, b01, b02, p00, p01, p02, p03, p04, p05, p11, p12,
                                           p13, p14, p15, p22, p23, p24, p25, p33, p34, p35, p44, p45, p55)
    m10, m11, m12, m13, m14, m15 = phi_row(a10, a11, a12, b10, b11, b12, p00, p01, p02, p03, p04, p05, p11, p12,
                                           p13, p14, p15, p22, p23, p24, p25, p33, p34, p35, p44, p45, p55)
    m20, m21, m22, m23, m24, m25 = phi_row(a20, a21, a22, b20, b21, b22, p00, p01, p02, p03, p04, p05, p11, p12,
                                           p13, p14, p15, p22, p23, p24, p25, p33, p34, p35, p44, p45, p55)
    # P' = M Phi^T + Qd: the attitude block's upper triangle M[i] Phi[j]^T (j >= i), the coupling block
    # M[0:3, 3:6] (Phi's bias rows are [0, I]), the bias block P22 + q22 I
    q11 = sv2 * dt + su2 * dt * dt * dt / 3.0
    q12 = -0.5 * su2 * dt * dt
    q22 = su2 * dt
    v00 = phi_col(m00, m01, m02, m03, m04, m05, a00, a01, a02, b00, b01, b02) + q11
    v01 = phi_col(m00, m01, m02, m03, m04, m05, a10, a11, a12, b10, b11, b12)
    v02 = phi_col(m00, m01, m02, m03, m04, m05, a20, a21, a22, b20, b21, b22)
    v11 = phi_col(m10, m11, m12, m13, m14, m15, a10, a11, a12, b10, b11, b12) + q11
    v12 = phi_col(m10, m11, m12, m13, m14, m15, a20, a21, a22, b20, b21, b22)
    v22 = phi_col(m20, m21, m22, m23, m24, m25, a20, a21, a22, b20, b21, b22) + q11
    put_sym(s, 0, 0, v00)
    put_sym(s, 0, 1, v01)
    put_sym(s, 0, 2, v02)
    put_sym(s, 1, 1, v11)
    put_sym(s, 1, 2, v12)
    put_sym(s, 2, 2, v22)
    put_sym(s, 0, 3, m03 + q12)
    put_sym(s, 0, 4, m04)
    put_sym(s, 0, 5, m05)
    put_sym(s, 1, 3, m13)
    put_sym(s, 1, 4, m14 + q12)
    put_sym(s, 1, 5, m15)
    put_sym(s, 2, 3, m23)
    put_sym(s, 2, 4, m24)
    put_sym(s, 2, 5, m25 + q12)
    s[_P + 21] = p33 + q22
    s[_P + 28] = p44 + q22
    s[_P + 35] = p55 + q22


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
    return update_with(s, _WPH, 3, y0, y1, y2)


@jit(inline="always")
def update_attitude(s, Rm, r, y0, y1, y2):
    """:func:`update` with ``H = I`` (the star tracker's): ``PH = P[:, 0:3]`` read where it is and
    ``S = P[0:3, 0:3] + Rm``, the same numbers as the products with ``I``; ``Rm`` (row-major) read
    where it is, ``Rm[r:r + 9]`` (the parameter row's, computed once by the Python class)."""
    for i in range(3):
        for j in range(3):
            s[_WS + 3 * i + j] = s[_P + 6 * i + j] + Rm[r + 3 * i + j]
    return update_with(s, _P, 6, y0, y1, y2)


@jit(inline="always")
def gain_row(a0, a1, a2, i00, i01, i02, i11, i12, i22, S0, S1, S2, S4, S5, S8):
    """Row ``k = a S^-1`` of the gain for the row ``a`` of ``PH`` (``S^-1`` symmetric, from its upper
    triangle), and the row ``u = k S / 2 - a`` of the Joseph form's factor ``U``."""
    k0 = a0 * i00 + a1 * i01 + a2 * i02
    k1 = a0 * i01 + a1 * i11 + a2 * i12
    k2 = a0 * i02 + a1 * i12 + a2 * i22
    return (k0, k1, k2, 0.5 * (k0 * S0 + k1 * S1 + k2 * S2) - a0, 0.5 * (k0 * S1 + k1 * S4 + k2 * S5) - a1,
            0.5 * (k0 * S2 + k1 * S5 + k2 * S8) - a2)


@jit(inline="always")
def joseph(u0, u1, u2, k0, k1, k2, U0, U1, U2, K0, K1, K2):
    """``(U K^T + K U^T)[i, j]`` from the rows ``u, k`` (i) and ``U, K`` (j)."""
    return u0 * K0 + u1 * K1 + u2 * K2 + k0 * U0 + k1 * U1 + k2 * U2


@jit(inline="always")
def update_with(s, o, n, y0, y1, y2):
    """The gain, the Joseph-form covariance and the reset, from ``PH = P H^T`` (6x3, row ``i`` at
    ``s[o + n i:o + n i + 3]``: the work space, or ``P``'s own first three columns for ``H = I``; read
    whole before ``P`` is written) and ``S`` (at ``_WS``). The gain and the factor ``U`` stay in locals."""
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
    # six products an entry instead of nine); one triangle computed, both written
    a00, a01, a02 = s[o], s[o + 1], s[o + 2]
    a10, a11, a12 = s[o + n], s[o + n + 1], s[o + n + 2]
    a20, a21, a22 = s[o + 2 * n], s[o + 2 * n + 1], s[o + 2 * n + 2]
    a30, a31, a32 = s[o + 3 * n], s[o + 3 * n + 1], s[o + 3 * n + 2]
    a40, a41, a42 = s[o + 4 * n], s[o + 4 * n + 1], s[o + 4 * n + 2]
    a50, a51, a52 = s[o + 5 * n], s[o + 5 * n + 1], s[o + 5 * n + 2]
    k00, k01, k02, u00, u01, u02 = gain_row(a00, a01, a02, i00, i01, i02, i11, i12, i22, S0, S1, S2, S4, S5, S8)
    k10, k11, k12, u10, u11, u12 = gain_row(a10, a11, a12, i00, i01, i02, i11, i12, i22, S0, S1, S2, S4, S5, S8)
    k20, k21, k22, u20, u21, u22 = gain_row(a20, a21, a22, i00, i01, i02, i11, i12, i22, S0, S1, S2, S4, S5, S8)
    k30, k31, k32, u30, u31, u32 = gain_row(a30, a31, a32, i00, i01, i02, i11, i12, i22, S0, S1, S2, S4, S5, S8)
    k40, k41, k42, u40, u41, u42 = gain_row(a40, a41, a42, i00, i01, i02, i11, i12, i22, S0, S1, S2, S4, S5, S8)
    k50, k51, k52, u50, u51, u52 = gain_row(a50, a51, a52, i00, i01, i02, i11, i12, i22, S0, S1, S2, S4, S5, S8)
    put_sym(s, 0, 0, s[_P + 0] + joseph(u00, u01, u02, k00, k01, k02, u00, u01, u02, k00, k01, k02))
    put_sym(s, 0, 1, s[_P + 1] + joseph(u00, u01, u02, k00, k01, k02, u10, u11, u12, k10, k11, k12))
    put_sym(s, 0, 2, s[_P + 2] + joseph(u00, u01, u02, k00, k01, k02, u20, u21, u22, k20, k21, k22))
    put_sym(s, 0, 3, s[_P + 3] + joseph(u00, u01, u02, k00, k01, k02, u30, u31, u32, k30, k31, k32))
    put_sym(s, 0, 4, s[_P + 4] + joseph(u00, u01, u02, k00, k01, k02, u40, u41, u42, k40, k41, k42))
    put_sym(s, 0, 5, s[_P + 5] + joseph(u00, u01, u02, k00, k01, k02, u50, u51, u52, k50, k51, k52))
    put_sym(s, 1, 1, s[_P + 7] + joseph(u10, u11, u12, k10, k11, k12, u10, u11, u12, k10, k11, k12))
    put_sym(s, 1, 2, s[_P + 8] + joseph(u10, u11, u12, k10, k11, k12, u20, u21, u22, k20, k21, k22))
    put_sym(s, 1, 3, s[_P + 9] + joseph(u10, u11, u12, k10, k11, k12, u30, u31, u32, k30, k31, k32))
    put_sym(s, 1, 4, s[_P + 10] + joseph(u10, u11, u12, k10, k11, k12, u40, u41, u42, k40, k41, k42))
    put_sym(s, 1, 5, s[_P + 11] + joseph(u10, u11, u12, k10, k11, k12, u50, u51, u52, k50, k51, k52))
    put_sym(s, 2, 2, s[_P + 14] + joseph(u20, u21, u22, k20, k21, k22, u20, u21, u22, k20, k21, k22))
    put_sym(s, 2, 3, s[_P + 15] + joseph(u20, u21, u22, k20, k21, k22, u30, u31, u32, k30, k31, k32))
    put_sym(s, 2, 4, s[_P + 16] + joseph(u20, u21, u22, k20, k21, k22, u40, u41, u42, k40, k41, k42))
    put_sym(s, 2, 5, s[_P + 17] + joseph(u20, u21, u22, k20, k21, k22, u50, u51, u52, k50, k51, k52))
    put_sym(s, 3, 3, s[_P + 21] + joseph(u30, u31, u32, k30, k31, k32, u30, u31, u32, k30, k31, k32))
    put_sym(s, 3, 4, s[_P + 22] + joseph(u30, u31, u32, k30, k31, k32, u40, u41, u42, k40, k41, k42))
    put_sym(s, 3, 5, s[_P + 23] + joseph(u30, u31, u32, k30, k31, k32, u50, u51, u52, k50, k51, k52))
    put_sym(s, 4, 4, s[_P + 28] + joseph(u40, u41, u42, k40, k41, k42, u40, u41, u42, k40, k41, k42))
    put_sym(s, 4, 5, s[_P + 29] + joseph(u40, u41, u42, k40, k41, k42, u50, u51, u52, k50, k51, k52))
    put_sym(s, 5, 5, s[_P + 35] + joseph(u50, u51, u52, k50, k51, k52, u50, u51, u52, k50, k51, k52))
    # the error estimate and the reset: q <- q Exp(dtheta), b <- b + db
    dx = k00 * y0 + k01 * y1 + k02 * y2
    dy = k10 * y0 + k11 * y1 + k12 * y2
    dz = k20 * y0 + k21 * y1 + k22 * y2
    s[4] += k30 * y0 + k31 * y1 + k32 * y2
    s[5] += k40 * y0 + k41 * y1 + k42 * y2
    s[6] += k50 * y0 + k51 * y1 + k52 * y2
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
        ok = update_attitude(s, p, 20, y0, y1, y2)     # R_m = C diag(sx^2, sx^2, sz^2) C^T, in the row
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
    # outputs: R_est, omega_est, bias_est, P_diag, est_error, each tested here (the loop tests nothing
    # after an estimator): zw sums x * 0 over every value written (:mod:`.finite`)
    quat_to_matrix(s[0], s[1], s[2], s[3], bus, w[12])
    zw = written_at(bus, w[12], 9)
    o = w[13]
    ox = mx - s[4]
    oy = my - s[5]
    oz = mz - s[6]
    bus[o] = ox
    bus[o + 1] = oy
    bus[o + 2] = oz
    zw += written(ox, oy, oz)
    o = w[14]
    bus[o] = s[4]
    bus[o + 1] = s[5]
    bus[o + 2] = s[6]
    zw += written(s[4], s[5], s[6])
    o = w[15]
    good = ok
    for i in range(6):
        d = s[_P + 7 * i]
        bus[o + i] = d
        zw += d * 0.0
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
    return finite_status(zw + written(x, y, z))


@jit(_nrt=False)
def estimator_dispatch(code, t, bus, p, s, w):
    """Run the built-in estimator kind ``code`` (400-499); an unknown code returns status 3 (compiled
    without Numba's runtime, as :func:`.sensor_components.sensor_dispatch`)."""
    if code == MEKF:
        return mekf_step(t, bus, p, s, w)
    if code == SIMPLE_NAV:
        return simple_nav_step(t, bus, p, s, w)
    return 3
