"""Stepping loop of the gyrostat by an explicit Runge-Kutta-Munthe-Kaas method in Cayley coordinates.

Derivation: ``docs/gyrostat_rkmk.md``. Over a step the wheel torques ``u`` (saturated motor command
plus friction, from the state at the step's start) and a body torque ``tau`` are held, so
``rho(t) = rho_k + (t - t_k) u``. With ``R(t) = R_k Q(t)``, ``m' = Q tau``, ``m(t_k) = 0`` (the
body impulse in the frame of ``R_k``) and ``Pi(t) = Q^T (Pi_k + m)``::

    Q' = Q hat(w),   w = J_B^-1 (Q^T (Pi_k + m) - G rho(t)),   Q(t_k) = I

an ODE on SO(3) (times R^3 for ``m``, zero without ``tau``). Writing ``Q = cay(theta) = I + c
(hat(theta) + hat(theta)^2 / 2)``, ``c = 4 / (4 + |theta|^2)`` (a rotation by ``2 atan(|theta|/2)``
about ``theta``; quaternion ``(2, theta) / |(2, theta)|``), the coordinates obey
``theta' = w + theta x w / 2 + (theta . w) theta / 4`` (``dcay^-1``, the body trivialisation), an
ODE in R^3 that an explicit 4-stage Runge-Kutta tableau integrates. Then::

    R_{k+1} = R_k cay(theta),   Pi_{k+1} = cay(theta)^T (Pi_k + m),   rho_{k+1} = rho_k + h u

so ``R Pi`` changes by exactly ``R_k m`` (nothing without ``tau``) and ``|Pi|`` by nothing without
``tau``, whatever ``u``. The attitude is kept as a unit quaternion ``q`` (``w, x, y, z``; ``R`` is
formed from it at the saved samples, for the controller and at the end of a call).

The tableau ``tab`` (13,): ``a21, a31, a32, a41, a42, a43, b1, b2, b3, b4, c2, c3, c4``.
"""

from __future__ import annotations

import math

from .._jit import jit
from .codes import NOT_FINITE, OK
from .gyrostat_kernels import CP_K, CP_KI, CP_MAP, CP_P, mrp_law, record_step, reference_rates, save_sample, \
    wheel_torque

#: Status: the rotation per step left the part of the Cayley chart this scheme accepts (``|theta| > theta_max``).
CHART = 5


@jit(inline="always")
def cay_apply(sign, t0, t1, t2, c, y0, y1, y2):
    """``cay(theta) y`` (``sign = 1``) or ``cay(theta)^T y = cay(-theta) y`` (``sign = -1``), with
    ``c = 4 / (4 + |theta|^2)``: ``y + sign c theta x y + c/2 theta x (theta x y)``."""
    a0 = t1 * y2 - t2 * y1
    a1 = t2 * y0 - t0 * y2
    a2 = t0 * y1 - t1 * y0
    b0 = t1 * a2 - t2 * a1
    b1 = t2 * a0 - t0 * a2
    b2 = t0 * a1 - t1 * a0
    sc = sign * c
    hc = 0.5 * c
    return y0 + sc * a0 + hc * b0, y1 + sc * a1 + hc * b1, y2 + sc * a2 + hc * b2


@jit(inline="always")
def stage(JBi, P0, P1, P2, t0, t1, t2, g0, g1, g2, z0, z1, z2, tq, ta0, ta1, ta2):
    """One stage at the coordinates ``theta`` with ``P = Pi_k + m`` (the stage's impulse added),
    ``g = G rho_k`` and ``z = c_i h J_B^-1 G u`` (the wheels' momentum gained since the step's
    start, as a rate): returns ``(K, M)``, ``K = dcay^-1(w)`` with
    ``w = J_B^-1 (cay(theta)^T P - G rho(t))``, ``M = cay(theta) tau`` (zero unless ``tq``).

    Arranged for a short chain of dependent operations: with ``s = 4 + |theta|^2``,
    ``s cay(theta)^T P = s P - 4 theta x P + 2 theta x (theta x P)``, ``dcay^-1`` is the matrix
    ``D = I + hat(theta)/2 + theta theta^T/4`` and ``K = D (J_B^-1 (s cay^T P - s g) / s - z)``:
    the division and ``D`` are computed beside the cross products, the wheel torques (which wait
    for the controller and the saturation) enter last.
    """
    s = 4.0 + (t0 * t0 + t1 * t1 + t2 * t2)
    a0 = t1 * P2 - t2 * P1
    a1 = t2 * P0 - t0 * P2
    a2 = t0 * P1 - t1 * P0
    b0 = t1 * a2 - t2 * a1
    b1 = t2 * a0 - t0 * a2
    b2 = t0 * a1 - t1 * a0
    y0 = (s * (P0 - g0) - 4.0 * a0) + 2.0 * b0
    y1 = (s * (P1 - g1) - 4.0 * a1) + 2.0 * b1
    y2 = (s * (P2 - g2) - 4.0 * a2) + 2.0 * b2
    inv = 1.0 / s
    w0 = (JBi[0, 0] * y0 + JBi[0, 1] * y1 + JBi[0, 2] * y2) * inv - z0
    w1 = (JBi[1, 0] * y0 + JBi[1, 1] * y1 + JBi[1, 2] * y2) * inv - z1
    w2 = (JBi[2, 0] * y0 + JBi[2, 1] * y1 + JBi[2, 2] * y2) * inv - z2
    h0 = 0.5 * t0
    h1 = 0.5 * t1
    h2 = 0.5 * t2
    e01 = 0.25 * t0 * t1
    e02 = 0.25 * t0 * t2
    e12 = 0.25 * t1 * t2
    k0 = (1.0 + 0.25 * t0 * t0) * w0 + (e01 - h2) * w1 + (e02 + h1) * w2
    k1 = (e01 + h2) * w0 + (1.0 + 0.25 * t1 * t1) * w1 + (e12 - h0) * w2
    k2 = (e02 - h1) * w0 + (e12 + h0) * w1 + (1.0 + 0.25 * t2 * t2) * w2
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    if tq:
        m0, m1, m2 = cay_apply(1.0, t0, t1, t2, 4.0 * inv, ta0, ta1, ta2)
    return k0, k1, k2, m0, m1, m2


@jit(inline="always")
def quat_to_matrix(q, R):
    """``R`` (3, 3) of the unit quaternion ``q = (w, x, y, z)``."""
    w = q[0]
    x = q[1]
    y = q[2]
    z = q[3]
    xx = x * x
    yy = y * y
    zz = z * z
    xy = x * y
    xz = x * z
    yz = y * z
    wx = w * x
    wy = w * y
    wz = w * z
    R[0, 0] = 1.0 - 2.0 * (yy + zz)
    R[0, 1] = 2.0 * (xy - wz)
    R[0, 2] = 2.0 * (xz + wy)
    R[1, 0] = 2.0 * (xy + wz)
    R[1, 1] = 1.0 - 2.0 * (xx + zz)
    R[1, 2] = 2.0 * (yz - wx)
    R[2, 0] = 2.0 * (xz - wy)
    R[2, 1] = 2.0 * (yz + wx)
    R[2, 2] = 1.0 - 2.0 * (xx + yy)


@jit(inline="always")
def mrp_error_q(qr, q):
    """The MRP ``sigma`` (3 scalars, ``|sigma| <= 1``) of ``R_ref^T R`` from the quaternions:
    ``qr`` of ``R_ref``, ``q`` of ``R`` (``qr^* q``, its sign made ``w >= 0``, ``v / (1 + w)``)."""
    aw = qr[0]
    ax = qr[1]
    ay = qr[2]
    az = qr[3]
    bw = q[0]
    bx = q[1]
    by = q[2]
    bz = q[3]
    ew = aw * bw + ax * bx + ay * by + az * bz
    ex = aw * bx - bw * ax - (ay * bz - az * by)
    ey = aw * by - bw * ay - (az * bx - ax * bz)
    ez = aw * bz - bw * az - (ax * by - ay * bx)
    if ew < 0.0:
        ew = -ew
        ex = -ex
        ey = -ey
        ez = -ez
    d = 1.0 + ew
    return ex / d, ey / d, ez / d


def rkmk_steps(tab, JBi, h, t0, q, R, Pi, rho, axes, wp, cmd, tau, u_now, ctrl, cp, cs, qr, spc, k0, n, kb,
               save_every, per, theta_max, R_out, Pi_out, rho_out, u_out, it_out, res_out, counts):
    """Steps ``k0 .. k0 + n - 1`` of the gyrostat by RKMK (tableau ``tab``) in place on ``q``, ``Pi``, ``rho``.

    The compiled MRP feedback (``ctrl = 1``, every ``spc`` steps; :func:`lgvi._kernels.gyrostat_kernels.mrp_law`)
    takes its error from the quaternions (:func:`mrp_error_q`, ``qr[:4]`` the quaternion of
    ``R_ref``); ``qr[4] != 0``: the reference rates in ``cp`` are not zero, ``R`` is then formed for
    them. ``R`` (3, 3) is set from ``q`` at the saved samples and at the end. Buffers and records as
    :func:`lgvi._kernels.gyrostat_kernels.gyro_steps` (iterations and residuals zero). A step whose ``|theta|`` exceeds ``theta_max`` or whose new
    momentum is not finite is not taken: returns ``(status, k, |theta|)`` with the state of its
    start; else ``(OK, k0 + n, 0.0)``.
    """
    N = rho.shape[0]
    a21 = tab[0]
    a31 = tab[1]
    a32 = tab[2]
    a41 = tab[3]
    a42 = tab[4]
    a43 = tab[5]
    b1 = tab[6]
    b2 = tab[7]
    b3 = tab[8]
    b4 = tab[9]
    c2 = tab[10]
    c3 = tab[11]
    c4 = tab[12]
    tmax2 = theta_max * theta_max
    c_ctl = k0 % spc
    e = (k0 - kb) // per
    c_rec = (k0 - kb) % per
    c_save = (k0 + 1 - kb) % save_every
    j = (k0 - kb) // save_every - 1
    # the compiled MRP feedback without integral term and reference rates: its law reduces to
    # L = -(K sigma + P omega) (bit for bit: the other terms are zeros)
    fast = ctrl == 1 and N > 0 and cp[CP_KI] == 0.0 and qr[4] == 0.0
    for k in range(k0, k0 + n):
        # G rho_k, the body rate (stage 1's K)
        g0 = 0.0
        g1 = 0.0
        g2 = 0.0
        for i in range(N):
            g0 += axes[i, 0] * rho[i]
            g1 += axes[i, 1] * rho[i]
            g2 += axes[i, 2] * rho[i]
        P0 = Pi[0]
        P1 = Pi[1]
        P2 = Pi[2]
        y0 = P0 - g0
        y1 = P1 - g1
        y2 = P2 - g2
        w0 = JBi[0, 0] * y0 + JBi[0, 1] * y1 + JBi[0, 2] * y2
        w1 = JBi[1, 0] * y0 + JBi[1, 1] * y1 + JBi[1, 2] * y2
        w2 = JBi[2, 0] * y0 + JBi[2, 1] * y1 + JBi[2, 2] * y2
        if ctrl == 1 and c_ctl == 0:
            s0, s1, s2 = mrp_error_q(qr, q)
            if fast:
                L0 = -(cp[CP_K] * s0 + cp[CP_P] * w0)
                L1 = -(cp[CP_K] * s1 + cp[CP_P] * w1)
                L2 = -(cp[CP_K] * s2 + cp[CP_P] * w2)
                for i in range(N):
                    m = CP_MAP + 3 * i
                    cmd[i] = cp[m] * L0 + cp[m + 1] * L1 + cp[m + 2] * L2
                cs[3] = t0 + k * h
                cs[4] = 1.0
            else:
                r0 = 0.0
                r1 = 0.0
                r2 = 0.0
                e0 = 0.0
                e1 = 0.0
                e2 = 0.0
                if qr[4] != 0.0:
                    quat_to_matrix(q, R)
                    r0, r1, r2, e0, e1, e2 = reference_rates(cp, R)
                mrp_law(cp, cs, t0 + k * h, s0, s1, s2, r0, r1, r2, e0, e1, e2, w0, w1, w2, axes, rho, cmd, tau)
        c_ctl += 1
        if c_ctl == spc:
            c_ctl = 0
        # wheel torques held over the step, and G u
        v0 = 0.0
        v1 = 0.0
        v2 = 0.0
        for i in range(N):
            ut = wheel_torque(i, cmd, rho, axes, wp, w0, w1, w2, u_now, N)
            v0 += axes[i, 0] * ut
            v1 += axes[i, 1] * ut
            v2 += axes[i, 2] * ut
        z0 = JBi[0, 0] * v0 + JBi[0, 1] * v1 + JBi[0, 2] * v2
        z1 = JBi[1, 0] * v0 + JBi[1, 1] * v1 + JBi[1, 2] * v2
        z2 = JBi[2, 0] * v0 + JBi[2, 1] * v1 + JBi[2, 2] * v2
        ta0 = tau[0]
        ta1 = tau[1]
        ta2 = tau[2]
        tq = ta0 != 0.0 or ta1 != 0.0 or ta2 != 0.0
        # stage 1: theta = 0, K = w
        K10 = w0
        K11 = w1
        K12 = w2
        # stage 2
        ha = h * a21
        hc = h * c2
        K20, K21, K22, M20, M21, M22 = stage(JBi, P0 + ha * ta0, P1 + ha * ta1, P2 + ha * ta2, ha * K10, ha * K11,
                                             ha * K12, g0, g1, g2, hc * z0, hc * z1, hc * z2, tq, ta0, ta1, ta2)
        # stage 3
        ha = h * a31
        hb = h * a32
        hc = h * c3
        K30, K31, K32, M30, M31, M32 = stage(JBi, P0 + ha * ta0 + hb * M20, P1 + ha * ta1 + hb * M21,
                                             P2 + ha * ta2 + hb * M22, ha * K10 + hb * K20, ha * K11 + hb * K21,
                                             ha * K12 + hb * K22, g0, g1, g2, hc * z0, hc * z1, hc * z2, tq, ta0,
                                             ta1, ta2)
        # stage 4
        ha = h * a41
        hb = h * a42
        hd = h * a43
        hc = h * c4
        K40, K41, K42, M40, M41, M42 = stage(JBi, P0 + ha * ta0 + hb * M20 + hd * M30,
                                             P1 + ha * ta1 + hb * M21 + hd * M31,
                                             P2 + ha * ta2 + hb * M22 + hd * M32,
                                             ha * K10 + hb * K20 + hd * K30, ha * K11 + hb * K21 + hd * K31,
                                             ha * K12 + hb * K22 + hd * K32, g0, g1, g2, hc * z0, hc * z1, hc * z2,
                                             tq, ta0, ta1, ta2)
        th0 = h * (b1 * K10 + b2 * K20 + b3 * K30 + b4 * K40)
        th1 = h * (b1 * K11 + b2 * K21 + b3 * K31 + b4 * K41)
        th2 = h * (b1 * K12 + b2 * K22 + b3 * K32 + b4 * K42)
        tt = th0 * th0 + th1 * th1 + th2 * th2
        if not tt <= tmax2:
            quat_to_matrix(q, R)
            if not math.isfinite(tt):
                return NOT_FINITE, k, tt
            return CHART, k, math.sqrt(tt)
        if tq:
            P0 += h * (b1 * ta0 + b2 * M20 + b3 * M30 + b4 * M40)
            P1 += h * (b1 * ta1 + b2 * M21 + b3 * M31 + b4 * M41)
            P2 += h * (b1 * ta2 + b2 * M22 + b3 * M32 + b4 * M42)
        n0, n1, n2 = cay_apply(-1.0, th0, th1, th2, 4.0 / (4.0 + tt), P0, P1, P2)
        if not (math.isfinite(n0) and math.isfinite(n1) and math.isfinite(n2)):
            quat_to_matrix(q, R)
            return NOT_FINITE, k, math.sqrt(tt)
        Pi[0] = n0
        Pi[1] = n1
        Pi[2] = n2
        # q <- q (2, theta), normalised
        qw = q[0]
        qx = q[1]
        qy = q[2]
        qz = q[3]
        rw = 2.0 * qw - qx * th0 - qy * th1 - qz * th2
        rx = 2.0 * qx + qw * th0 + qy * th2 - qz * th1
        ry = 2.0 * qy + qw * th1 + qz * th0 - qx * th2
        rz = 2.0 * qz + qw * th2 + qx * th1 - qy * th0
        s = 1.0 / math.sqrt(rw * rw + rx * rx + ry * ry + rz * rz)
        q[0] = rw * s
        q[1] = rx * s
        q[2] = ry * s
        q[3] = rz * s
        for i in range(N):
            rho[i] += h * u_now[N + i]
        counts[0] += 1
        c_rec, e = record_step(c_rec, e, per, 0, 0.0, it_out, res_out, u_out, u_now, N)   # no iterations
        if c_save == 0:
            j += 1
            quat_to_matrix(q, R)
            save_sample(j, R, Pi, rho, R_out, Pi_out, rho_out)
        c_save += 1
        if c_save == save_every:
            c_save = 0
    quat_to_matrix(q, R)
    return OK, k0 + n, 0.0


#: :func:`rkmk_steps`, compiled (cached on disk).
run_rkmk = jit(_nrt=False)(rkmk_steps)
