"""Compiled steps of two rigid bodies in mutual gravity (the full two-body problem; ``docs/orbit.md``).

State (inertial frame): positions ``X`` (2,3) of the centres of mass, linear momenta ``P`` (2,3),
attitudes ``R`` (2,3,3) (body to inertial), body angular momenta ``Pi`` (2,3). The mutual
potential ``U(d, R1, R2)`` depends on the positions through ``d = x2 - x1`` only; with
``g = dU/dd`` and the body moments ``M1``, ``M2`` at step ``k``, one step is

    mu_i        = Pi_i + h/2 M_i                      (i = 1, 2)
    hat(h mu_i) = F_i Jd_i - Jd_i F_i^T              (Cayley solves)
    R_i        <- R_i F_i
    x1         <- x1 + h p1 / m1 + h^2 / (2 m1) g ;   x2 <- x2 + h p2 / m2 - h^2 / (2 m2) g
    (g, M1, M2) at the new state                      (one evaluation of the mutual potential)
    p1         <- p1 + h/2 (g_k + g_{k+1}) ;          p2 <- p2 - h/2 (g_k + g_{k+1})
    Pi_i       <- F_i^T mu_i + h/2 M_i,{k+1}

The cache ``C`` (10,) carries ``g`` (0:3), ``M1`` (3:6), ``M2`` (6:9) and a valid flag (9).

Potentials (``code``), with ``u_i = R_i^T d`` and the body moments ``S`` (second, ``= Jd``),
``T3``, ``T4`` (third and fourth, body frame):

* :data:`ORDER2`: ``-G m1 m2 / r`` and, for each body, the second-order (MacCullagh) term
  ``-G m_j (3 u.S u / r^2 - tr S) / (2 r^3)``;
* :data:`ORDER4`: adds each body's third- and fourth-order terms (Legendre ``P3``, ``P4`` of its
  moments; the third-order term of body 2 changes sign) and the fourth-order cross term of the two
  second moments;
* :data:`POINTS`: exact for bodies made of point masses, the pairwise sum
  ``-G sum_ab m_a m_b / |d + R2 q_b - R1 q_a|``.
"""

from __future__ import annotations

import math

from .._jit import jit
from .codes import COLLISION, METHOD_CAYLEY, NOT_FINITE, OK, OVERFLOW
from .contact_kernels import passage, shapes_overlap
from .solvers import solve_scalar
from .stepping import predict_at, push_at, rotated_row

ORDER2 = 0
ORDER4 = 1
POINTS = 2


@jit(inline="always")
def body_gradient(order4, i, c2, c3, S, T3, t3, T4, Q4, q4, u0, u1, u2):
    """``dU/du`` of body ``i``'s own terms (``u = R_i^T d``): the second order with ``c2 = G m_j``,
    with ``order4`` the third (``c3 = +-G m_j``) and fourth (``c2`` again) orders."""
    r2 = u0 * u0 + u1 * u1 + u2 * u2
    ir2 = 1.0 / r2
    ir = math.sqrt(ir2)
    ir5 = ir2 * ir2 * ir
    ir7 = ir5 * ir2
    s0 = S[i, 0, 0] * u0 + S[i, 0, 1] * u1 + S[i, 0, 2] * u2
    s1 = S[i, 1, 0] * u0 + S[i, 1, 1] * u1 + S[i, 1, 2] * u2
    s2 = S[i, 2, 0] * u0 + S[i, 2, 1] * u1 + S[i, 2, 2] * u2
    usu = u0 * s0 + u1 * s1 + u2 * s2
    trS = S[i, 0, 0] + S[i, 1, 1] + S[i, 2, 2]
    # U2 = -c2 (3/2 u.Su r^-5 - 1/2 trS r^-3)
    a = -3.0 * c2 * ir5
    b = c2 * (7.5 * usu * ir7 - 1.5 * trS * ir5)
    g0 = a * s0 + b * u0
    g1 = a * s1 + b * u1
    g2 = a * s2 + b * u2
    if order4:
        ir9 = ir7 * ir2
        ir11 = ir9 * ir2
        # third order: U3 = -c3/2 (5 A3 r^-7 - 3 B3 r^-5), A3 = T3[u,u,u], B3 = t3.u
        v0 = 0.0
        v1 = 0.0
        v2 = 0.0
        uu = (u0, u1, u2)
        for j in range(3):
            for k in range(3):
                ujk = uu[j] * uu[k]
                v0 += T3[i, 0, j, k] * ujk
                v1 += T3[i, 1, j, k] * ujk
                v2 += T3[i, 2, j, k] * ujk
        A3 = v0 * u0 + v1 * u1 + v2 * u2
        B3 = t3[i, 0] * u0 + t3[i, 1] * u1 + t3[i, 2] * u2
        e = -0.5 * c3
        f = e * (-35.0 * A3 * ir9 + 15.0 * B3 * ir7)
        g0 += e * (15.0 * v0 * ir7 - 3.0 * t3[i, 0] * ir5) + f * u0
        g1 += e * (15.0 * v1 * ir7 - 3.0 * t3[i, 1] * ir5) + f * u1
        g2 += e * (15.0 * v2 * ir7 - 3.0 * t3[i, 2] * ir5) + f * u2
        # fourth order: U4 = -c2/8 (35 A4 r^-9 - 30 B4 r^-7 + 3 q r^-5), A4 = T4[u^4], B4 = u.Q u
        w0 = 0.0
        w1 = 0.0
        w2 = 0.0
        for j in range(3):
            for k in range(3):
                for m in range(3):
                    ujkm = uu[j] * uu[k] * uu[m]
                    w0 += T4[i, 0, j, k, m] * ujkm
                    w1 += T4[i, 1, j, k, m] * ujkm
                    w2 += T4[i, 2, j, k, m] * ujkm
        A4 = w0 * u0 + w1 * u1 + w2 * u2
        z0 = Q4[i, 0, 0] * u0 + Q4[i, 0, 1] * u1 + Q4[i, 0, 2] * u2
        z1 = Q4[i, 1, 0] * u0 + Q4[i, 1, 1] * u1 + Q4[i, 1, 2] * u2
        z2 = Q4[i, 2, 0] * u0 + Q4[i, 2, 1] * u1 + Q4[i, 2, 2] * u2
        B4 = z0 * u0 + z1 * u1 + z2 * u2
        e = -0.125 * c2
        f = e * (-315.0 * A4 * ir11 + 210.0 * B4 * ir9 - 15.0 * q4[i] * ir7)
        g0 += e * (140.0 * w0 * ir9 - 60.0 * z0 * ir7) + f * u0
        g1 += e * (140.0 * w1 * ir9 - 60.0 * z1 * ir7) + f * u1
        g2 += e * (140.0 * w2 * ir9 - 60.0 * z2 * ir7) + f * u2
    return g0, g1, g2


@jit(inline="always")
def cross_term(G, d0, d1, d2, A, B):
    """The fourth-order cross term of the second moments ``A = R1 S1 R1^T``, ``B = R2 S2 R2^T``
    (inertial, (3,3) arrays): ``X = -G/4 (105 a b r^-9 - 15 r^-7 (trA b + trB a + 4 c) + 3 r^-5
    (trA trB + 2 tr(AB)))`` with ``a = d.Ad``, ``b = d.Bd``, ``c = d.ABd``. Returns ``dX/dd`` and the
    inertial moments ``tau1``, ``tau2`` (9 numbers)."""
    r2 = d0 * d0 + d1 * d1 + d2 * d2
    ir2 = 1.0 / r2
    ir = math.sqrt(ir2)
    ir5 = ir2 * ir2 * ir
    ir7 = ir5 * ir2
    ir9 = ir7 * ir2
    ir11 = ir9 * ir2
    ad0 = A[0, 0] * d0 + A[0, 1] * d1 + A[0, 2] * d2
    ad1 = A[1, 0] * d0 + A[1, 1] * d1 + A[1, 2] * d2
    ad2 = A[2, 0] * d0 + A[2, 1] * d1 + A[2, 2] * d2
    bd0 = B[0, 0] * d0 + B[0, 1] * d1 + B[0, 2] * d2
    bd1 = B[1, 0] * d0 + B[1, 1] * d1 + B[1, 2] * d2
    bd2 = B[2, 0] * d0 + B[2, 1] * d1 + B[2, 2] * d2
    abd0 = A[0, 0] * bd0 + A[0, 1] * bd1 + A[0, 2] * bd2
    abd1 = A[1, 0] * bd0 + A[1, 1] * bd1 + A[1, 2] * bd2
    abd2 = A[2, 0] * bd0 + A[2, 1] * bd1 + A[2, 2] * bd2
    bad0 = B[0, 0] * ad0 + B[0, 1] * ad1 + B[0, 2] * ad2
    bad1 = B[1, 0] * ad0 + B[1, 1] * ad1 + B[1, 2] * ad2
    bad2 = B[2, 0] * ad0 + B[2, 1] * ad1 + B[2, 2] * ad2
    al = d0 * ad0 + d1 * ad1 + d2 * ad2
    be = d0 * bd0 + d1 * bd1 + d2 * bd2
    ga = d0 * abd0 + d1 * abd1 + d2 * abd2
    trA = A[0, 0] + A[1, 1] + A[2, 2]
    trB = B[0, 0] + B[1, 1] + B[2, 2]
    trAB = 0.0
    for i in range(3):
        for j in range(3):
            trAB += A[i, j] * B[j, i]
    c = -0.25 * G
    # gradient in d
    radial = c * (-945.0 * al * be * ir11 + 105.0 * ir9 * (trA * be + trB * al + 4.0 * ga)
                  - 15.0 * ir7 * (trA * trB + 2.0 * trAB))
    ka = c * (210.0 * be * ir9 - 30.0 * trB * ir7)       # times A d
    kb = c * (210.0 * al * ir9 - 30.0 * trA * ir7)       # times B d
    kc = c * (-60.0 * ir7)                                # times (AB + BA) d
    g0 = ka * ad0 + kb * bd0 + kc * (abd0 + bad0) + radial * d0
    g1 = ka * ad1 + kb * bd1 + kc * (abd1 + bad1) + radial * d1
    g2 = ka * ad2 + kb * bd2 + kc * (abd2 + bad2) + radial * d2
    # moments: tau1 = 2 vee(A Y - Y A), Y = dX/dA = Ka d d^T + Kc sym(d (Bd)^T) + Kt B
    Ka = c * (105.0 * be * ir9 - 15.0 * trB * ir7)
    Kb = c * (105.0 * al * ir9 - 15.0 * trA * ir7)
    Kc = c * (-60.0 * ir7)
    Kt = c * (6.0 * ir5)
    # vee(AB - BA) = -vee(BA - AB); (AB - BA)_{ij}: vee = ((AB-BA)_21, (AB-BA)_02, (AB-BA)_10)
    ab21 = 0.0
    ab02 = 0.0
    ab10 = 0.0
    for k in range(3):
        ab21 += A[2, k] * B[k, 1] - B[2, k] * A[k, 1]
        ab02 += A[0, k] * B[k, 2] - B[0, k] * A[k, 2]
        ab10 += A[1, k] * B[k, 0] - B[1, k] * A[k, 0]
    # d x Ad, Bd x Ad, d x ABd
    t10 = 2.0 * (Ka * (d1 * ad2 - d2 * ad1) + 0.5 * Kc * ((bd1 * ad2 - bd2 * ad1) + (d1 * abd2 - d2 * abd1))
                 + Kt * ab21)
    t11 = 2.0 * (Ka * (d2 * ad0 - d0 * ad2) + 0.5 * Kc * ((bd2 * ad0 - bd0 * ad2) + (d2 * abd0 - d0 * abd2))
                 + Kt * ab02)
    t12 = 2.0 * (Ka * (d0 * ad1 - d1 * ad0) + 0.5 * Kc * ((bd0 * ad1 - bd1 * ad0) + (d0 * abd1 - d1 * abd0))
                 + Kt * ab10)
    t20 = 2.0 * (Kb * (d1 * bd2 - d2 * bd1) + 0.5 * Kc * ((ad1 * bd2 - ad2 * bd1) + (d1 * bad2 - d2 * bad1))
                 - Kt * ab21)
    t21 = 2.0 * (Kb * (d2 * bd0 - d0 * bd2) + 0.5 * Kc * ((ad2 * bd0 - ad0 * bd2) + (d2 * bad0 - d0 * bad2))
                 - Kt * ab02)
    t22 = 2.0 * (Kb * (d0 * bd1 - d1 * bd0) + 0.5 * Kc * ((ad0 * bd1 - ad1 * bd0) + (d0 * bad1 - d1 * bad0))
                 - Kt * ab10)
    return g0, g1, g2, t10, t11, t12, t20, t21, t22


@jit(inline="always")
def mutual(code, G, m1, m2, S, T3, t3, T4, Q4, q4, Q1, w1, Q2, w2, Y, Z, A, B, d0, d1, d2, R, C):
    """``g = dU/dd``, ``M1``, ``M2`` (body frames) at ``d`` and attitudes ``R`` (2,3,3), into ``C[0:9]``.
    ``Y``, ``Z``, ``A``, ``B`` are scratch arrays."""
    if code == POINTS:
        for a in range(Q1.shape[0]):
            for i in range(3):
                Y[a, i] = R[0, i, 0] * Q1[a, 0] + R[0, i, 1] * Q1[a, 1] + R[0, i, 2] * Q1[a, 2]
        for b in range(Q2.shape[0]):
            for i in range(3):
                Z[b, i] = R[1, i, 0] * Q2[b, 0] + R[1, i, 1] * Q2[b, 1] + R[1, i, 2] * Q2[b, 2]
        g0 = g1 = g2 = 0.0
        s0 = s1 = s2 = 0.0    # inertial moment on body 1: sum_a y_a x f_a
        for a in range(Q1.shape[0]):
            f0 = f1 = f2 = 0.0
            for b in range(Q2.shape[0]):
                e0 = d0 + Z[b, 0] - Y[a, 0]
                e1 = d1 + Z[b, 1] - Y[a, 1]
                e2 = d2 + Z[b, 2] - Y[a, 2]
                ie2 = 1.0 / (e0 * e0 + e1 * e1 + e2 * e2)
                c = G * w1[a] * w2[b] * ie2 * math.sqrt(ie2)
                f0 += c * e0
                f1 += c * e1
                f2 += c * e2
            g0 += f0
            g1 += f1
            g2 += f2
            s0 += Y[a, 1] * f2 - Y[a, 2] * f1
            s1 += Y[a, 2] * f0 - Y[a, 0] * f2
            s2 += Y[a, 0] * f1 - Y[a, 1] * f0
        # body 2: force on point b is -sum_a f_ab; its moment sum_b z_b x (-f_b)
        t0 = t1 = t2 = 0.0
        for b in range(Q2.shape[0]):
            f0 = f1 = f2 = 0.0
            for a in range(Q1.shape[0]):
                e0 = d0 + Z[b, 0] - Y[a, 0]
                e1 = d1 + Z[b, 1] - Y[a, 1]
                e2 = d2 + Z[b, 2] - Y[a, 2]
                ie2 = 1.0 / (e0 * e0 + e1 * e1 + e2 * e2)
                c = G * w1[a] * w2[b] * ie2 * math.sqrt(ie2)
                f0 -= c * e0
                f1 -= c * e1
                f2 -= c * e2
            t0 += Z[b, 1] * f2 - Z[b, 2] * f1
            t1 += Z[b, 2] * f0 - Z[b, 0] * f2
            t2 += Z[b, 0] * f1 - Z[b, 1] * f0
        C[0] = g0
        C[1] = g1
        C[2] = g2
        C[3] = R[0, 0, 0] * s0 + R[0, 1, 0] * s1 + R[0, 2, 0] * s2
        C[4] = R[0, 0, 1] * s0 + R[0, 1, 1] * s1 + R[0, 2, 1] * s2
        C[5] = R[0, 0, 2] * s0 + R[0, 1, 2] * s1 + R[0, 2, 2] * s2
        C[6] = R[1, 0, 0] * t0 + R[1, 1, 0] * t1 + R[1, 2, 0] * t2
        C[7] = R[1, 0, 1] * t0 + R[1, 1, 1] * t1 + R[1, 2, 1] * t2
        C[8] = R[1, 0, 2] * t0 + R[1, 1, 2] * t1 + R[1, 2, 2] * t2
        return
    order4 = code == ORDER4
    r2 = d0 * d0 + d1 * d1 + d2 * d2
    ir2 = 1.0 / r2
    c = G * m1 * m2 * ir2 * math.sqrt(ir2)
    g0 = c * d0
    g1 = c * d1
    g2 = c * d2
    for i in range(2):
        u0 = R[i, 0, 0] * d0 + R[i, 1, 0] * d1 + R[i, 2, 0] * d2
        u1 = R[i, 0, 1] * d0 + R[i, 1, 1] * d1 + R[i, 2, 1] * d2
        u2 = R[i, 0, 2] * d0 + R[i, 1, 2] * d1 + R[i, 2, 2] * d2
        mj = m2 if i == 0 else m1
        c3 = G * mj if i == 0 else -G * mj
        v0, v1, v2 = body_gradient(order4, i, G * mj, c3, S, T3, t3, T4, Q4, q4, u0, u1, u2)
        g0 += R[i, 0, 0] * v0 + R[i, 0, 1] * v1 + R[i, 0, 2] * v2
        g1 += R[i, 1, 0] * v0 + R[i, 1, 1] * v1 + R[i, 1, 2] * v2
        g2 += R[i, 2, 0] * v0 + R[i, 2, 1] * v1 + R[i, 2, 2] * v2
        # M = u x dU/du
        C[3 + 3 * i] = u1 * v2 - u2 * v1
        C[4 + 3 * i] = u2 * v0 - u0 * v2
        C[5 + 3 * i] = u0 * v1 - u1 * v0
    if order4:
        for i in range(3):
            for j in range(3):
                sa = 0.0
                sb = 0.0
                for k in range(3):
                    for m in range(3):
                        sa += R[0, i, k] * S[0, k, m] * R[0, j, m]
                        sb += R[1, i, k] * S[1, k, m] * R[1, j, m]
                A[i, j] = sa
                B[i, j] = sb
        x0, x1, x2, t10, t11, t12, t20, t21, t22 = cross_term(G, d0, d1, d2, A, B)
        g0 += x0
        g1 += x1
        g2 += x2
        C[3] += R[0, 0, 0] * t10 + R[0, 1, 0] * t11 + R[0, 2, 0] * t12
        C[4] += R[0, 0, 1] * t10 + R[0, 1, 1] * t11 + R[0, 2, 1] * t12
        C[5] += R[0, 0, 2] * t10 + R[0, 1, 2] * t11 + R[0, 2, 2] * t12
        C[6] += R[1, 0, 0] * t20 + R[1, 1, 0] * t21 + R[1, 2, 0] * t22
        C[7] += R[1, 0, 1] * t20 + R[1, 1, 1] * t21 + R[1, 2, 1] * t22
        C[8] += R[1, 0, 2] * t20 + R[1, 1, 2] * t21 + R[1, 2, 2] * t22
    C[0] = g0
    C[1] = g1
    C[2] = g2


@jit
def mutual_force(code, G, m1, m2, S, T3, t3, T4, Q4, q4, Q1, w1, Q2, w2, d, R, out):
    """Array wrapper of :func:`mutual` (Python-callable): ``out`` (9,) gets ``g, M1, M2``."""
    Y = Q1.copy()
    Z = Q2.copy()
    A = S[0].copy()
    B = S[1].copy()
    mutual(code, G, m1, m2, S, T3, t3, T4, Q4, q4, Q1, w1, Q2, w2, Y, Z, A, B, d[0], d[1], d[2], R, out)


@jit(_nrt=False)
def run_two_body(code, G, m1, m2, S, T3, t3, T4, Q4, q4, Q1, w1, Q2, w2, Y, Z, A, B, h, X, P, R, Pi, Gh, C,
                 N, k0, n, tol, max_iter, save_every, X_out, P_out, R_out, Pi_out, it_out, res_out, hist, last,
                 E1, A1, E2, A2, bound, core, Xn, Rn, contact):
    """Steps ``k0 .. k0+n-1`` in place (see the module notes); ``N`` (10,) scratch for the new
    force and moments. Samples every ``save_every`` steps into the ``*_out`` buffers, the largest
    iterations (both solves summed) and residual of each saved interval into ``it_out``,
    ``res_out``; ``last`` (2,) the last step's.

    Contact (:mod:`.contact_kernels`): the path of ``d = x2 - x1`` over a step must stay farther
    than ``core`` from the origin and pass it no closer than its own length; where the centres are
    closer than ``bound`` at the new state, the bodies' ellipsoids (centres ``E_i`` (n_i, 3), semi-axes
    ``A_i`` (n_i, 3), body frame) must not overlap there (``Xn`` (2, 3), ``Rn`` (2, 3, 3) scratch for
    the new state). Otherwise the step fails with ``COLLISION`` and ``contact`` (3,) =
    ``(kind, distance, L)`` (kind 3: overlapping shapes).

    Returns ``(status, k)``: ``k`` the steps done (on failure the failed step; a failed solve or a
    collision leaves the state as before the step, an overflow of the new state may leave it partly
    advanced: the saved samples are intact, the run is over)."""
    if C[9] == 0.0:
        mutual(code, G, m1, m2, S, T3, t3, T4, Q4, q4, Q1, w1, Q2, w2, Y, Z, A, B, X[1, 0] - X[0, 0],
               X[1, 1] - X[0, 1], X[1, 2] - X[0, 2], R, C)
        C[9] = 1.0
    hh = 0.5 * h
    hm1 = h / m1
    hm2 = h / m2
    j = 0
    its_max = 0
    res_max = 0.0
    countdown = save_every
    for s in range(n):
        k = k0 + s
        its = 0
        rmax = 0.0
        # the two attitude solves; both succeed before any state is written
        e = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        e1 = e
        mu0 = (0.0, 0.0, 0.0)
        mu1 = mu0
        f = mu0
        f1 = mu0
        for i in range(2):
            a0 = Pi[i, 0] + hh * C[3 + 3 * i]
            a1 = Pi[i, 1] + hh * C[4 + 3 * i]
            a2 = Pi[i, 2] + hh * C[5 + 3 * i]
            q0, q1, q2 = predict_at(Gh, i)
            (g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it,
             rn, st) = solve_scalar(METHOD_CAYLEY, S[i, 0, 0], S[i, 0, 1], S[i, 0, 2], S[i, 1, 1], S[i, 1, 2],
                                    S[i, 2, 2], h * a0, h * a1, h * a2, q0, q1, q2, tol, max_iter, 1.0, hist, True)
            its += it
            if rn > rmax:
                rmax = rn
            if st != OK:
                last[0] = its
                last[1] = rmax
                return st, k
            if i == 0:
                e = (E00, E01, E02, E10, E11, E12, E20, E21, E22)
                mu0 = (a0, a1, a2)
                f = (g0, g1, g2)
            else:
                e1 = (E00, E01, E02, E10, E11, E12, E20, E21, E22)
                mu1 = (a0, a1, a2)
                f1 = (g0, g1, g2)
        last[0] = its
        last[1] = rmax
        # new positions and attitudes
        y0 = X[0, 0] + hm1 * P[0, 0] + hm1 * hh * C[0]
        y1 = X[0, 1] + hm1 * P[0, 1] + hm1 * hh * C[1]
        y2 = X[0, 2] + hm1 * P[0, 2] + hm1 * hh * C[2]
        z0 = X[1, 0] + hm2 * P[1, 0] - hm2 * hh * C[0]
        z1 = X[1, 1] + hm2 * P[1, 1] - hm2 * hh * C[1]
        z2 = X[1, 2] + hm2 * P[1, 2] - hm2 * hh * C[2]
        if not math.isfinite(y0 + y1 + y2 + z0 + z1 + z2):
            return NOT_FINITE, k
        if passage(X[1, 0] - X[0, 0], X[1, 1] - X[0, 1], X[1, 2] - X[0, 2], z0 - y0, z1 - y1, z2 - y2, core, contact):
            return COLLISION, k
        for i in range(2):
            E00, E01, E02, E10, E11, E12, E20, E21, E22 = e if i == 0 else e1
            for r in range(3):
                Rn[i, r, 0], Rn[i, r, 1], Rn[i, r, 2] = rotated_row(R[i, r, 0], R[i, r, 1], R[i, r, 2], E00, E01,
                                                                    E02, E10, E11, E12, E20, E21, E22)
        Xn[0, 0] = y0
        Xn[0, 1] = y1
        Xn[0, 2] = y2
        Xn[1, 0] = z0
        Xn[1, 1] = z1
        Xn[1, 2] = z2
        dn = math.sqrt((z0 - y0) ** 2 + (z1 - y1) ** 2 + (z2 - y2) ** 2)
        if dn < bound:
            if shapes_overlap(Xn, Rn, E1, A1, E2, A2) >= 0:
                contact[0] = 3.0
                contact[1] = dn
                contact[2] = 0.0
                return COLLISION, k
        for i in range(2):
            for r in range(3):
                R[i, r, 0] = Rn[i, r, 0]
                R[i, r, 1] = Rn[i, r, 1]
                R[i, r, 2] = Rn[i, r, 2]
        mutual(code, G, m1, m2, S, T3, t3, T4, Q4, q4, Q1, w1, Q2, w2, Y, Z, A, B, z0 - y0, z1 - y1, z2 - y2, R, N)
        n0 = hh * (C[0] + N[0])
        n1 = hh * (C[1] + N[1])
        n2 = hh * (C[2] + N[2])
        fin = n0 + n1 + n2
        for i in range(2):
            E00, E01, E02, E10, E11, E12, E20, E21, E22 = e if i == 0 else e1
            a0, a1, a2 = mu0 if i == 0 else mu1
            c0 = a0 + (E00 * a0 + E10 * a1 + E20 * a2) + hh * N[3 + 3 * i]
            c1 = a1 + (E01 * a0 + E11 * a1 + E21 * a2) + hh * N[4 + 3 * i]
            c2 = a2 + (E02 * a0 + E12 * a1 + E22 * a2) + hh * N[5 + 3 * i]
            fin += c0 + c1 + c2
            Pi[i, 0] = c0
            Pi[i, 1] = c1
            Pi[i, 2] = c2
            g0, g1, g2 = f if i == 0 else f1
            push_at(Gh, i, g0, g1, g2)
        if not math.isfinite(fin):
            return OVERFLOW, k
        for a in range(3):
            X[0, a] = Xn[0, a]
            X[1, a] = Xn[1, a]
        P[0, 0] += n0
        P[0, 1] += n1
        P[0, 2] += n2
        P[1, 0] -= n0
        P[1, 1] -= n1
        P[1, 2] -= n2
        for a in range(9):
            C[a] = N[a]
        if its > its_max:
            its_max = its
        if rmax > res_max:
            res_max = rmax
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            for b in range(2):
                for a in range(3):
                    X_out[j, b, a] = X[b, a]
                    P_out[j, b, a] = P[b, a]
                    Pi_out[j, b, a] = Pi[b, a]
                    for c in range(3):
                        R_out[j, b, a, c] = R[b, a, c]
            it_out[j] = its_max
            res_out[j] = res_max
            its_max = 0
            res_max = 0.0
            j += 1
    return OK, k0 + n


__all__ = ["ORDER2", "ORDER4", "POINTS", "body_gradient", "cross_term", "mutual", "mutual_force", "run_two_body"]
