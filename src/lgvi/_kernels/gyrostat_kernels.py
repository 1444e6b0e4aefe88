"""Stepping loop of the gyrostat (a rigid body with balanced reaction wheels), compiled.

One step (derivation: ``docs/gyrostat.md``), with ``A = Jd_B + h/2 hat(G rho_bar)``,
``rho_bar = rho_k + h/2 u`` (``u`` the wheels' axial torques, motor plus friction, held over the
step) and ``tau`` a body torque held over the step:

    vee(F A - A^T F^T) = h Pi_k + h^2/2 tau          (Newton on the group, shifted matrix A)
    R_{k+1}   = R_k F
    Pi_{k+1}  = F^T (Pi_k + h/2 tau) + h/2 tau
    rho_{k+1} = rho_k + h u

``Pi`` is the total body momentum (hub plus wheels), ``rho_i`` the absolute axial momentum of
wheel ``i``. Since ``vee(A - A^T) = h G rho_bar`` the equation is solved for ``E = F - I`` as
``vee(E A - A^T E^T) = h (Pi_k - G rho_bar) + h^2/2 tau``.

The wheels' parameters are rows of ``wp`` (N, 8): spin inertia, torque limit, deadband, power
limit, speed limit (limits ``<= 0``: none), Coulomb and viscous friction and the speed below which
friction is linear (Basilisk's ``omegaLimitCycle``).

Controllers: ``ctrl = 0`` holds the command ``cmd`` (wheel motor torques) and ``tau`` set by the
caller; ``ctrl = 1`` evaluates the MRP feedback law of :class:`lgvi.control.MRPFeedback` every
``spc`` steps here (parameters ``cp``, integral state ``cs``).
"""

from __future__ import annotations

import math

from .._jit import jit, jit_copy
from .codes import NOT_CONVERGED, NOT_FINITE, OK, OVERFLOW, SINGULAR, USER_RAISED
from .solvers import EPS, SERIES_ANGLE, cramer3, expm1_entries
from .stepping import momentum_step, predict_at, push_at, rotate, rotated_row

# Taylor coefficients below SERIES_ANGLE, as in the rigid body's solver (:mod:`.solvers`)
A1, A2, A3, A4 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0          # sin t / t
B1, B2, B3, B4 = -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0, 1.0 / 3628800.0       # (1 - cos t) / t^2
E0, E1, E2, E3 = 1.0 / 12.0, 1.0 / 720.0, 1.0 / 30240.0, 1.0 / 1209600.0       # (1 - t/2 cot t/2) / t^2
W_JS, W_UMAX, W_UMIN, W_PMAX, W_OMAX, W_FC, W_FV, W_OLC = 0, 1, 2, 3, 4, 5, 6, 7
#: ``cp`` layout of the compiled MRP feedback: K, P, Ki, integral limit, R_ref (9, row-major),
#: omega_ref (3, inertial), domega_ref (3, inertial), J (9), then the wheel map (N x 3, row-major)
CP_K, CP_P, CP_KI, CP_LIM, CP_RREF, CP_WREF, CP_DWREF, CP_J, CP_MAP = 0, 1, 2, 3, 4, 13, 16, 19, 28


@jit(inline="always")
def solve_shifted(a00, a01, a02, a10, a11, a12, a20, a21, a22, p0, p1, p2, g0, g1, g2, tol, max_iter):
    """Newton for ``vee(E A - A^T E^T) = p`` (``F = I + E = exp(hat(g))``, ``A`` not symmetric).

    Left updates ``F <- exp(hat(d)) F`` with ``(tr(B) I - B) d = -r``, ``B = F A`` (the exact
    derivative), mapped to the coordinates by ``Jl(g)^-1``. Stops when ``|r| <= tol |p| + 8 eps
    (|A| |E| + |p|)``. Returns ``(g, E, its, |r|, status)``.
    """
    pn = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    an = math.sqrt(a00 * a00 + a01 * a01 + a02 * a02 + a10 * a10 + a11 * a11 + a12 * a12
                   + a20 * a20 + a21 * a21 + a22 * a22)
    tr = a00 + a11 + a22
    it = 0
    while True:
        t2 = g0 * g0 + g1 * g1 + g2 * g2
        if not math.isfinite(t2):
            return g0, g1, g2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, it, math.inf, NOT_FINITE
        if t2 < SERIES_ANGLE * SERIES_ANGLE:
            a = 1.0 + t2 * (A1 + t2 * (A2 + t2 * (A3 + t2 * A4)))
            b = 0.5 + t2 * (B1 + t2 * (B2 + t2 * (B3 + t2 * B4)))
        else:
            t = math.sqrt(t2)
            sh = math.sin(0.5 * t)
            ch = math.cos(0.5 * t)
            a = 2.0 * sh * ch / t
            b = 2.0 * sh * sh / t2
        E00, E01, E02, E10, E11, E12, E20, E21, E22 = expm1_entries(g0, g1, g2, a, b)
        # X = E A: the residual needs the off-diagonal entries only (the diagonal after the test)
        x01 = E00 * a01 + E01 * a11 + E02 * a21
        x02 = E00 * a02 + E01 * a12 + E02 * a22
        x10 = E10 * a00 + E11 * a10 + E12 * a20
        x12 = E10 * a02 + E11 * a12 + E12 * a22
        x20 = E20 * a00 + E21 * a10 + E22 * a20
        x21 = E20 * a01 + E21 * a11 + E22 * a21
        r0 = (x21 - x12) - p0
        r1 = (x02 - x20) - p1
        r2 = (x10 - x01) - p2
        rn2 = r0 * r0 + r1 * r1 + r2 * r2
        enorm = 2.0 * math.sqrt(b * t2)
        thr = tol * pn + 8.0 * EPS * (an * enorm + pn)
        if not math.isfinite(rn2):
            return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.inf, NOT_FINITE
        if rn2 <= thr * thr:
            return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), OK
        if it >= max_iter:
            return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), NOT_CONVERGED
        # M = tr(B) I - B, B = A + X
        x00 = E00 * a00 + E01 * a10 + E02 * a20
        x11 = E10 * a01 + E11 * a11 + E12 * a21
        x22 = E20 * a02 + E21 * a12 + E22 * a22
        tb = tr + x00 + x11 + x22
        m00 = tb - a00 - x00
        m01 = -a01 - x01
        m02 = -a02 - x02
        m10 = -a10 - x10
        m11 = tb - a11 - x11
        m12 = -a12 - x12
        m20 = -a20 - x20
        m21 = -a21 - x21
        m22 = tb - a22 - x22
        # M s = -r (the products and sums of -r are those of r negated: the same numbers)
        s0, s1, s2, ok = cramer3(m00, m01, m02, m10, m11, m12, m20, m21, m22, -r0, -r1, -r2)
        if not ok:
            return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), SINGULAR
        if t2 < SERIES_ANGLE * SERIES_ANGLE:
            e = E0 + t2 * (E1 + t2 * (E2 + t2 * E3))
        else:
            e = (1.0 - 0.5 * a / b) / t2
        u0 = g1 * s2 - g2 * s1
        u1 = g2 * s0 - g0 * s2
        u2 = g0 * s1 - g1 * s0
        v0 = g1 * u2 - g2 * u1
        v1 = g2 * u0 - g0 * u2
        v2 = g0 * u1 - g1 * u0
        g0 += s0 - 0.5 * u0 + e * v0
        g1 += s1 - 0.5 * u1 + e * v1
        g2 += s2 - 0.5 * u2 + e * v2
        it += 1


@jit(inline="always")
def saturate(u, Omega, js, umax, umin, pmax, omax):
    """A motor torque request ``u`` after the wheel's limits, in Basilisk's order: torque limit,
    deadband, power limit, then no torque that drives ``|Omega|`` beyond the speed limit."""
    if umax > 0.0:
        if u > umax:
            u = umax
        elif u < -umax:
            u = -umax
    if abs(u) < umin:
        u = 0.0
    if pmax > 0.0 and abs(u * Omega) >= pmax:
        u = math.copysign(pmax / abs(Omega), u)
    if omax > 0.0 and abs(Omega) >= omax and Omega * u >= 0.0:
        u = 0.0
    return u


@jit(inline="always")
def friction(Omega, fc, fv, olc):
    """Friction torque on a wheel spinning at ``Omega`` (relative): ``-(fc sign + fv Omega)``,
    linear through zero below ``olc`` (Basilisk's Coulomb and viscous model)."""
    if fc == 0.0 and fv == 0.0:
        return 0.0
    if abs(Omega) < olc:
        return -(fc + fv * olc) / olc * Omega
    return -(math.copysign(fc, Omega) + fv * Omega)


@jit(inline="always")
def body_rate(JBi, Pi, axes, rho):
    """``Omega = J_B^-1 (Pi - G rho)`` (3 scalars)."""
    q0 = Pi[0]
    q1 = Pi[1]
    q2 = Pi[2]
    for i in range(rho.shape[0]):
        q0 -= axes[i, 0] * rho[i]
        q1 -= axes[i, 1] * rho[i]
        q2 -= axes[i, 2] * rho[i]
    return (JBi[0, 0] * q0 + JBi[0, 1] * q1 + JBi[0, 2] * q2, JBi[1, 0] * q0 + JBi[1, 1] * q1 + JBi[1, 2] * q2,
            JBi[2, 0] * q0 + JBi[2, 1] * q1 + JBi[2, 2] * q2)


@jit(inline="always")
def mrp_feedback(cp, cs, t, R, w0, w1, w2, axes, wp, rho, cmd, tau):
    """The MRP feedback law (as :meth:`lgvi.control.MRPFeedback.torque_request`) into ``cmd``
    (wheel motor torques through the wheel map) or, without wheels, ``tau``. ``cs``: int_sigma
    (3), prior time, has prior (0/1)."""
    s0, s1, s2 = mrp_error(cp, R)
    r0, r1, r2, e0, e1, e2 = reference_rates(cp, R)
    mrp_law(cp, cs, t, s0, s1, s2, r0, r1, r2, e0, e1, e2, w0, w1, w2, axes, rho, cmd, tau)


@jit(inline="always")
def wheel_torque(i, cmd, rho, axes, wp, w0, w1, w2, u_now, N):
    """Wheel ``i``'s torques held over a step, from the state at its start (body rate ``w``): the motor
    command ``cmd[i]`` after :func:`saturate` into ``u_now[i]``, plus :func:`friction` into
    ``u_now[N + i]``, which is returned."""
    js = wp[i, W_JS]
    Om = rho[i] / js - (axes[i, 0] * w0 + axes[i, 1] * w1 + axes[i, 2] * w2)
    um = saturate(cmd[i], Om, js, wp[i, W_UMAX], wp[i, W_UMIN], wp[i, W_PMAX], wp[i, W_OMAX])
    u_now[i] = um
    ut = um + friction(Om, wp[i, W_FC], wp[i, W_FV], wp[i, W_OLC])
    u_now[N + i] = ut
    return ut


@jit(inline="always")
def record_step(c_rec, e, per, its, rn, it_out, res_out, u_out, u_now, N):
    """A step's records into entry ``e`` (``per`` steps an entry, ``c_rec`` this step's place in it):
    the largest iterations and residual, and the motor torques at the entry's first step. Returns
    the next ``(c_rec, e)``."""
    if c_rec == 0:
        it_out[e] = its
        res_out[e] = rn
        for i in range(N):
            u_out[e, i] = u_now[i]
    else:
        if its > it_out[e]:
            it_out[e] = its
        if rn > res_out[e]:
            res_out[e] = rn
    c_rec += 1
    if c_rec == per:
        c_rec = 0
        e += 1
    return c_rec, e


@jit(inline="always")
def after_step(its, rn, rmax, counts, c_rec, e, per, it_out, res_out, u_out, u_now, c_save, j, save_every, R, Pi, rho,
               R_out, Pi_out, rho_out):
    """The bookkeeping after a step: the largest residual, the iteration histogram ``counts``, the
    step's records (:func:`record_step`) and, every ``save_every`` steps, the sample ``j``
    (:func:`save_sample`). Returns the next ``(rmax, c_rec, e, c_save, j)``."""
    if rn > rmax:
        rmax = rn
    nb = counts.shape[0]
    counts[its if its < nb else nb - 1] += 1
    c_rec, e = record_step(c_rec, e, per, its, rn, it_out, res_out, u_out, u_now, rho.shape[0])
    if c_save == 0:
        j += 1
        save_sample(j, R, Pi, rho, R_out, Pi_out, rho_out)
    c_save += 1
    if c_save == save_every:
        c_save = 0
    return rmax, c_rec, e, c_save, j


@jit(inline="always")
def save_sample(j, R, Pi, rho, R_out, Pi_out, rho_out):
    """Sample ``j`` of the state into the output buffers: ``R``, ``Pi`` and the wheel momenta ``rho``."""
    for a in range(3):
        Pi_out[j, a] = Pi[a]
        for b in range(3):
            R_out[j, a, b] = R[a, b]
    for i in range(rho.shape[0]):
        rho_out[j, i] = rho[i]


@jit(inline="always")
def mrp_error(cp, R):
    """The attitude error ``sigma`` (3 scalars) of ``R_ref^T R``, the set with ``|sigma| <= 1``."""
    return mrp_error_at(cp, CP_RREF, R)


@jit(inline="always")
def mrp_error_at(cp, c, R):
    """:func:`mrp_error` with ``R_ref`` (row-major) at ``cp[c:c + 9]`` (a parameter row or a bus)."""
    # C = R_ref^T R
    C00 = cp[c] * R[0, 0] + cp[c + 3] * R[1, 0] + cp[c + 6] * R[2, 0]
    C01 = cp[c] * R[0, 1] + cp[c + 3] * R[1, 1] + cp[c + 6] * R[2, 1]
    C02 = cp[c] * R[0, 2] + cp[c + 3] * R[1, 2] + cp[c + 6] * R[2, 2]
    C10 = cp[c + 1] * R[0, 0] + cp[c + 4] * R[1, 0] + cp[c + 7] * R[2, 0]
    C11 = cp[c + 1] * R[0, 1] + cp[c + 4] * R[1, 1] + cp[c + 7] * R[2, 1]
    C12 = cp[c + 1] * R[0, 2] + cp[c + 4] * R[1, 2] + cp[c + 7] * R[2, 2]
    C20 = cp[c + 2] * R[0, 0] + cp[c + 5] * R[1, 0] + cp[c + 8] * R[2, 0]
    C21 = cp[c + 2] * R[0, 1] + cp[c + 5] * R[1, 1] + cp[c + 8] * R[2, 1]
    C22 = cp[c + 2] * R[0, 2] + cp[c + 5] * R[1, 2] + cp[c + 8] * R[2, 2]
    # quaternion (Shepperd), scalar part >= 0, then sigma = q / (1 + q4)
    trc = C00 + C11 + C22
    if trc >= C00 and trc >= C11 and trc >= C22:
        s = math.sqrt(1.0 + trc) * 2.0
        qw = 0.25 * s
        qx = (C21 - C12) / s
        qy = (C02 - C20) / s
        qz = (C10 - C01) / s
    elif C00 >= C11 and C00 >= C22:
        s = math.sqrt(1.0 + C00 - C11 - C22) * 2.0
        qw = (C21 - C12) / s
        qx = 0.25 * s
        qy = (C01 + C10) / s
        qz = (C02 + C20) / s
    elif C11 >= C22:
        s = math.sqrt(1.0 + C11 - C00 - C22) * 2.0
        qw = (C02 - C20) / s
        qx = (C01 + C10) / s
        qy = 0.25 * s
        qz = (C12 + C21) / s
    else:
        s = math.sqrt(1.0 + C22 - C00 - C11) * 2.0
        qw = (C10 - C01) / s
        qx = (C02 + C20) / s
        qy = (C12 + C21) / s
        qz = 0.25 * s
    if qw < 0.0:
        qw, qx, qy, qz = -qw, -qx, -qy, -qz
    d = 1.0 + qw
    return qx / d, qy / d, qz / d


@jit(inline="always")
def reference_rates(cp, R):
    """The reference rate and its derivative in the body frame, ``R^T omega_ref``, ``R^T domega_ref``."""
    return reference_rates_at(cp, CP_WREF, CP_DWREF, R)


@jit(inline="always")
def reference_rates_at(cp, wr, dwr, R):
    """:func:`reference_rates` with ``omega_ref`` at ``cp[wr:wr + 3]``, ``domega_ref`` at ``cp[dwr:dwr + 3]``."""
    r0 = R[0, 0] * cp[wr] + R[1, 0] * cp[wr + 1] + R[2, 0] * cp[wr + 2]
    r1 = R[0, 1] * cp[wr] + R[1, 1] * cp[wr + 1] + R[2, 1] * cp[wr + 2]
    r2 = R[0, 2] * cp[wr] + R[1, 2] * cp[wr + 1] + R[2, 2] * cp[wr + 2]
    e0 = R[0, 0] * cp[dwr] + R[1, 0] * cp[dwr + 1] + R[2, 0] * cp[dwr + 2]
    e1 = R[0, 1] * cp[dwr] + R[1, 1] * cp[dwr + 1] + R[2, 1] * cp[dwr + 2]
    e2 = R[0, 2] * cp[dwr] + R[1, 2] * cp[dwr + 1] + R[2, 2] * cp[dwr + 2]
    return r0, r1, r2, e0, e1, e2


@jit(inline="always")
def mrp_law(cp, cs, t, s0, s1, s2, r0, r1, r2, e0, e1, e2, w0, w1, w2, axes, rho, cmd, tau):
    """The feedback law of :func:`mrp_feedback` from the error ``sigma`` and the reference rates
    ``r``, ``e`` in the body frame (:func:`mrp_error`, :func:`reference_rates`)."""
    j = CP_J
    H0 = cp[j] * w0 + cp[j + 1] * w1 + cp[j + 2] * w2
    H1 = cp[j + 3] * w0 + cp[j + 4] * w1 + cp[j + 5] * w2
    H2 = cp[j + 6] * w0 + cp[j + 7] * w1 + cp[j + 8] * w2
    for i in range(rho.shape[0]):
        # h_s = Js (a . w + Omega_w) = rho (absolute axial momentum)
        H0 += axes[i, 0] * rho[i]
        H1 += axes[i, 1] * rho[i]
        H2 += axes[i, 2] * rho[i]
    L0, L1, L2 = mrp_request(cp, CP_J, cs, t, s0, s1, s2, r0, r1, r2, e0, e1, e2, w0, w1, w2, H0, H1, H2)
    n = rho.shape[0]
    if n == 0:
        tau[0] = L0
        tau[1] = L1
        tau[2] = L2
    else:
        for i in range(n):
            m = CP_MAP + 3 * i
            cmd[i] = cp[m] * L0 + cp[m + 1] * L1 + cp[m + 2] * L2


@jit(inline="always")
def mrp_request(cp, jo, cs, t, s0, s1, s2, r0, r1, r2, e0, e1, e2, w0, w1, w2, H0, H1, H2):
    """The body torque request ``L`` (3 scalars) of Basilisk's ``mrpFeedback``: gains ``K, P, Ki``
    and the integral limit at ``cp[0:4]``, the inertia ``J`` (row-major) at ``cp[jo:jo + 9]``,
    the integral state ``cs`` (int_sigma (3), prior time, has prior), the error ``sigma``, the
    reference rates ``r``, ``e`` and the rate ``w`` in the body frame and the total momentum
    ``H = J w + sum rho_i a_i``."""
    K = cp[CP_K]
    P = cp[CP_P]
    Ki = cp[CP_KI]
    dw0 = w0 - r0
    dw1 = w1 - r1
    dw2 = w2 - r2
    J0 = cp[jo]
    J1 = cp[jo + 1]
    J2 = cp[jo + 2]
    J3 = cp[jo + 3]
    J4 = cp[jo + 4]
    J5 = cp[jo + 5]
    J6 = cp[jo + 6]
    J7 = cp[jo + 7]
    J8 = cp[jo + 8]
    z0 = 0.0
    z1 = 0.0
    z2 = 0.0
    if Ki > 0.0:
        # no prior call, or one at t = 0 (Basilisk's mrpFeedback: prior time 0 is "none"): dt = 0
        dt = t - cs[3] if cs[4] > 0.0 and cs[3] != 0.0 else 0.0
        lim = cp[CP_LIM]
        cs[0] = min(max(cs[0] + K * dt * s0, -lim), lim)
        cs[1] = min(max(cs[1] + K * dt * s1, -lim), lim)
        cs[2] = min(max(cs[2] + K * dt * s2, -lim), lim)
        z0 = cs[0] + (J0 * dw0 + J1 * dw1 + J2 * dw2)
        z1 = cs[1] + (J3 * dw0 + J4 * dw1 + J5 * dw2)
        z2 = cs[2] + (J6 * dw0 + J7 * dw1 + J8 * dw2)
    cs[3] = t
    cs[4] = 1.0
    L0 = K * s0 + P * dw0 + P * Ki * z0
    L1 = K * s1 + P * dw1 + P * Ki * z1
    L2 = K * s2 + P * dw2 + P * Ki * z2
    v0 = r0 + Ki * z0
    v1 = r1 + Ki * z1
    v2 = r2 + Ki * z2
    L0 -= v1 * H2 - v2 * H1
    L1 -= v2 * H0 - v0 * H2
    L2 -= v0 * H1 - v1 * H0
    k0 = (w1 * r2 - w2 * r1) - e0
    k1 = (w2 * r0 - w0 * r2) - e1
    k2 = (w0 * r1 - w1 * r0) - e2
    L0 = -(L0 + J0 * k0 + J1 * k1 + J2 * k2)
    L1 = -(L1 + J3 * k0 + J4 * k1 + J5 * k2)
    L2 = -(L2 + J6 * k0 + J7 * k1 + J8 * k2)
    return L0, L1, L2


#: The relative miss of the right side's extrapolation below which :func:`forcing_guess` keeps the
#: extrapolated guess: from a guess that close, the one Newton iteration a step takes anyway reaches
#: the tolerance (quadratic convergence: 1e-16 relative), so the correction would only cost its solve
#: (a smooth torque, such as the disturbances', changes every step and misses by far less).
GUESS_GATE = 1e-8


@jit(inline="always")
def forcing_guess(q0, q1, q2, G, sub, changed, p0, p1, p2, a00, a01, a02, a10, a11, a12, a20, a21, a22):
    """The guess ``q`` of substep ``sub`` (the extrapolation of its last solutions,
    :func:`.stepping.predict_at`), moved by what the extrapolation of the right-hand side ``p`` misses
    while the hub's forcing changes (``docs/gyrostat.md``, "The solver's guess").

    ``changed``: the hub's forcing ``phi = tau - G u`` changed over the last three steps (a control
    update; those of its values kept, ``G[0, 3, 1]``, compared) and the miss ``p - p_hat`` is above
    :data:`GUESS_GATE` ``|p|``. Then the right side ``p`` has a kink the extrapolation of the solutions does not see; the
    same extrapolation of the last right sides ``G[sub, 8:11]`` (``G[sub, 3, 2]`` of them valid) gives
    ``p_hat``, and the guess adds ``M^-1 (p - p_hat)``, ``M = tr(A) I - A`` the equation's derivative at
    ``F = I``. Otherwise (no torque, or one that did not change: every step of a free or coasting
    body; or a torque that changes smoothly, as the disturbances do) the guess is the extrapolation,
    bit for bit. The guess moves only the iteration count, never
    the solution beyond the solver's tolerance."""
    if not changed:
        return q0, q1, q2
    ng = G[sub, 3, 0]
    npp = G[sub, 3, 2]
    if ng >= 3.0 and npp >= 3.0:
        e0 = p0 - (3.0 * (G[sub, 8, 0] - G[sub, 9, 0]) + G[sub, 10, 0])
        e1 = p1 - (3.0 * (G[sub, 8, 1] - G[sub, 9, 1]) + G[sub, 10, 1])
        e2 = p2 - (3.0 * (G[sub, 8, 2] - G[sub, 9, 2]) + G[sub, 10, 2])
    elif ng >= 2.0 and npp >= 2.0:
        e0 = p0 - (2.0 * G[sub, 8, 0] - G[sub, 9, 0])
        e1 = p1 - (2.0 * G[sub, 8, 1] - G[sub, 9, 1])
        e2 = p2 - (2.0 * G[sub, 8, 2] - G[sub, 9, 2])
    else:
        return q0, q1, q2
    if e0 * e0 + e1 * e1 + e2 * e2 <= GUESS_GATE * GUESS_GATE * (p0 * p0 + p1 * p1 + p2 * p2):
        return q0, q1, q2                        # a smooth change: the extrapolation is as good
    tr = a00 + a11 + a22
    x0, x1, x2, ok = cramer3(tr - a00, -a01, -a02, -a10, tr - a11, -a12, -a20, -a21, tr - a22, e0, e1, e2)
    if not ok:
        return q0, q1, q2
    return q0 + x0, q1 + x1, q2 + x2


@jit(inline="always")
def gyro_advance(moment, up, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now, ta0, ta1, ta2, m0, m1, m2, tol,
                 max_iter):
    """Step ``k`` of the gyrostat in place on ``R``, ``Pi``, ``rho``, ``G`` (see :func:`gyro_steps`):
    the substeps ``gam[i] h`` with the wheels' torques ``u_now[N:]`` and the body torque ``ta``
    held over the step, and, with ``moment``, the model's moment ``m`` at the step's start in the
    variational form. Returns ``(status, iterations, residual, iterations_added, m)`` (``m`` the
    moment at the step's end, the next step's start)."""
    N = rho.shape[0]
    d00 = JdB[0, 0]
    d01 = JdB[0, 1]
    d02 = JdB[0, 2]
    d10 = JdB[1, 0]
    d11 = JdB[1, 1]
    d12 = JdB[1, 2]
    d20 = JdB[2, 0]
    d21 = JdB[2, 1]
    d22 = JdB[2, 2]
    s = gam.shape[0]
    it_sum = 0
    its = 0
    rn = 0.0
    its_k = 0
    rn_k = 0.0
    cum = 0.0
    # the hub's forcing of this step, phi = tau (+ m) - G u (the wheels' reaction), against those of the
    # last three steps in G[0, 5:8] (G[0, 3, 1] of them valid): while it changed, the guess of each
    # substep adds what the extrapolation of its right side misses (:func:`forcing_guess`)
    phi0 = ta0
    phi1 = ta1
    phi2 = ta2
    if moment is not None:
        phi0 += m0
        phi1 += m1
        phi2 += m2
    for i in range(N):
        phi0 -= axes[i, 0] * u_now[N + i]
        phi1 -= axes[i, 1] * u_now[N + i]
        phi2 -= axes[i, 2] * u_now[N + i]
    nphi = G[0, 3, 1]
    changed = False
    if nphi >= 1.0:
        changed = phi0 != G[0, 5, 0] or phi1 != G[0, 5, 1] or phi2 != G[0, 5, 2]
    if nphi >= 2.0:
        changed = changed or G[0, 5, 0] != G[0, 6, 0] or G[0, 5, 1] != G[0, 6, 1] or G[0, 5, 2] != G[0, 6, 2]
    if nphi >= 3.0:
        changed = changed or G[0, 6, 0] != G[0, 7, 0] or G[0, 6, 1] != G[0, 7, 1] or G[0, 6, 2] != G[0, 7, 2]
    for sub in range(s):
        hs = gam[sub] * h
        hh = 0.5 * hs
        f0 = ta0
        f1 = ta1
        f2 = ta2
        if moment is not None:
            f0 = ta0 + m0
            f1 = ta1 + m1
            f2 = ta2 + m2
        g0 = 0.0
        g1 = 0.0
        g2 = 0.0
        for i in range(N):
            rb = rho[i] + hh * u_now[N + i]
            g0 += axes[i, 0] * rb
            g1 += axes[i, 1] * rb
            g2 += axes[i, 2] * rb
        # A = Jd_B + hs/2 hat(g)
        a01 = d01 - hh * g2
        a02 = d02 + hh * g1
        a10 = d10 + hh * g2
        a12 = d12 - hh * g0
        a20 = d20 - hh * g1
        a21 = d21 + hh * g0
        p0 = hs * (Pi[0] - g0) + hs * hh * f0
        p1 = hs * (Pi[1] - g1) + hs * hh * f1
        p2 = hs * (Pi[2] - g2) + hs * hh * f2
        q0, q1, q2 = predict_at(G, sub)
        q0, q1, q2 = forcing_guess(q0, q1, q2, G, sub, changed, p0, p1, p2, d00, a01, a02, a10, d11, a12, a20,
                                   a21, d22)
        (x0, x1, x2, E00, E01, E02, E10, E11, E12, E20, E21, E22, its,
         rn, st) = solve_shifted(d00, a01, a02, a10, d11, a12, a20, a21, d22, p0, p1, p2, q0, q1, q2, tol,
                                 max_iter)
        its_k += its
        it_sum += its
        n0 = ta0
        n1 = ta1
        n2 = ta2
        e0 = 0.0
        e1 = 0.0
        e2 = 0.0
        cum += gam[sub]
        if moment is not None and st == OK:
            # the model's moment at the substep's end (R_k F, its time)
            t_end = t0 + (k + 1) * h if sub == s - 1 else t0 + k * h + cum * h
            for i in range(3):
                Rs[i, 0], Rs[i, 1], Rs[i, 2] = rotated_row(R[i, 0], R[i, 1], R[i, 2], E00, E01, E02, E10, E11,
                                                           E12, E20, E21, E22)
            mm = moment(t_end, Rs, Pi, up)
            e0 = float(mm[0])
            e1 = float(mm[1])
            e2 = float(mm[2])
            if not (math.isfinite(e0) and math.isfinite(e1) and math.isfinite(e2)):
                st = NOT_FINITE
            n0 = ta0 + e0
            n1 = ta1 + e1
            n2 = ta2 + e2
        if st == OK:
            b0 = Pi[0] + hh * f0
            b1 = Pi[1] + hh * f1
            b2 = Pi[2] + hh * f2
            c0, c1, c2, l0, l1, l2 = momentum_step(b0, b1, b2, G[sub, 4, 0], G[sub, 4, 1], G[sub, 4, 2], E00,
                                                   E01, E02, E10, E11, E12, E20, E21, E22, hh * n0, hh * n1,
                                                   hh * n2)
            if not (math.isfinite(c0) and math.isfinite(c1) and math.isfinite(c2)):
                st = OVERFLOW
        if st != OK:
            return st, its_k, rn, it_sum, m0, m1, m2
        if rn > rn_k:
            rn_k = rn
        push_at(G, sub, x0, x1, x2)
        for i in range(3):                       # the right sides of the last three steps
            G[sub, 10, i] = G[sub, 9, i]
            G[sub, 9, i] = G[sub, 8, i]
        G[sub, 8, 0] = p0
        G[sub, 8, 1] = p1
        G[sub, 8, 2] = p2
        if G[sub, 3, 2] < 3.0:
            G[sub, 3, 2] += 1.0
        G[sub, 4, 0] = l0
        G[sub, 4, 1] = l1
        G[sub, 4, 2] = l2
        rotate(R, E00, E01, E02, E10, E11, E12, E20, E21, E22)
        Pi[0] = c0
        Pi[1] = c1
        Pi[2] = c2
        for i in range(N):
            rho[i] += hs * u_now[N + i]
        if moment is not None:
            m0 = e0
            m1 = e1
            m2 = e2
    for i in range(3):
        G[0, 7, i] = G[0, 6, i]
        G[0, 6, i] = G[0, 5, i]
    G[0, 5, 0] = phi0
    G[0, 5, 1] = phi1
    G[0, 5, 2] = phi2
    if nphi < 3.0:
        G[0, 3, 1] = nphi + 1.0
    return OK, its_k, rn_k, it_sum, m0, m1, m2


def gyro_steps(moment, up, Rs, JdB, JBi, h, gam, t0, R, Pi, rho, G, axes, wp, cmd, tau, u_now, ctrl, cp, cs,
               spc, k0, n, kb, tol, max_iter, save_every, per, R_out, Pi_out, rho_out, u_out, it_out, res_out, counts):
    """Steps ``k0 .. k0 + n - 1`` of the gyrostat in place on ``R``, ``Pi``, ``rho``, ``G``.

    Each step is the composition of substeps ``gam[i] h`` (``gam = [1]``: the second-order step;
    a symmetric composition raises the order), ``G`` (s, 11, 3) one solver history per substep (rows
    0-4 as the rigid body's, :mod:`.stepping`; rows 8-10 its right sides of the last three steps,
    ``G[i, 3, 2]`` of them valid) and, in ``G[0, 5:8]``, the hub's forcing of the last three steps
    (``G[0, 3, 1]`` of them valid), for the solver's guess (:func:`forcing_guess`).
    The wheel torques (saturated command plus friction, from the state at the step's start) and
    ``tau`` are held over the whole step. The buffers start at step ``kb`` (a multiple of
    ``save_every``): sample ``j`` after step ``k`` with ``(k + 1 - kb) % save_every == 0`` is
    ``(k + 1 - kb) // save_every - 1``; record entry ``(k - kb) // per``. ``u_now`` (2N,): the
    motor torques and the total wheel torques of the last step. Returns ``(status, k,
    iterations_total, residual_max, its, residual)`` (the last of the step that stopped the loop;
    on failure the state is that of the step's start only for a single substep).

    With ``moment`` (not ``None``) the torque model's moment ``M = moment(t, R, Pi, up)`` is added to ``tau`` in
    the variational (symmetric) form of a time-dependent potential: ``h^2/2 (tau + M_k)`` in the
    implicit equation, ``Pi_{k+1} = F^T (Pi_k + h/2 (tau + M_k)) + h/2 (tau + M_{k+1})``, each
    substep at its own times; a non-finite moment stops the run (``NOT_FINITE``).
    """
    N = rho.shape[0]
    it_sum = 0
    rmax = 0.0
    its = 0
    rn = 0.0
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    if moment is not None:
        # the moment at the chunk's start, given a copy of R in the scratch Rs (as the substeps give it):
        # a guarded user's function marks Rs[0, 0] with NaN when it raises (user_kernels.guarded)
        for i in range(3):
            Rs[i, 0], Rs[i, 1], Rs[i, 2] = R[i, 0], R[i, 1], R[i, 2]
        mm = moment(t0 + k0 * h, Rs, Pi, up)
        m0 = float(mm[0])
        m1 = float(mm[1])
        m2 = float(mm[2])
        if not (math.isfinite(m0) and math.isfinite(m1) and math.isfinite(m2)):
            return USER_RAISED if Rs[0, 0] != Rs[0, 0] else NOT_FINITE, k0, 0, 0.0, 0, 0.0
    # counters instead of a division per step: k % spc, (k - kb) // per, (k - kb) % per, (k + 1 - kb) % save_every
    c_ctl = k0 % spc
    e = (k0 - kb) // per
    c_rec = (k0 - kb) % per
    c_save = (k0 + 1 - kb) % save_every
    j = (k0 - kb) // save_every - 1              # the last sample written before k0
    for k in range(k0, k0 + n):
        w0, w1, w2 = body_rate(JBi, Pi, axes, rho)
        if ctrl == 1 and c_ctl == 0:
            mrp_feedback(cp, cs, t0 + k * h, R, w0, w1, w2, axes, wp, rho, cmd, tau)
        c_ctl += 1
        if c_ctl == spc:
            c_ctl = 0
        # wheel torques: saturated motor command plus friction, held over the step
        for i in range(N):
            wheel_torque(i, cmd, rho, axes, wp, w0, w1, w2, u_now, N)
        st, its, rn, it_add, m0, m1, m2 = gyro_advance(moment, up, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now,
                                                      tau[0], tau[1], tau[2], m0, m1, m2, tol, max_iter)
        it_sum += it_add
        if st != OK:
            if st == NOT_FINITE and moment is not None and Rs[0, 0] != Rs[0, 0]:
                st = USER_RAISED            # the guarded user's function raised (its mark, see above)
            return st, k, it_sum, rmax, its, rn
        rmax, c_rec, e, c_save, j = after_step(its, rn, rmax, counts, c_rec, e, per, it_out, res_out, u_out, u_now,
                                               c_save, j, save_every, R, Pi, rho, R_out, Pi_out, rho_out)
    return OK, k0 + n, it_sum, rmax, its, rn


#: :func:`gyro_steps` without a torque model (``moment=None``; cached on disk).
run_gyro = jit(_nrt=False)(gyro_steps)
#: :func:`gyro_steps` with a torque model ``moment(t, R, Pi, up)`` (an ``lgvi.torques.Compiled``, not
#: depending on ``Pi``): the user's function as a value of one function type
#: (:func:`.user_kernels.guarded`, :data:`.user_kernels.MOMENT_SIGNATURE`), so one compiled loop,
#: cached on disk, serves every user's model; an exception the function raises stops the run with
#: ``USER_RAISED`` at its step.
run_gyro_model = jit_copy(gyro_steps, "run_gyro_model", "gyro_steps compiled for a user's moment (see the "
                          "module's run_gyro_model).", _nrt=False)
