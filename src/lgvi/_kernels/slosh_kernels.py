r"""Compiled steps of a rigid hub with ``n`` spherical (slosh) pendulums, on ``SO(3) x (S^2)^n``
(derivation in ``docs/slosh.md``).

State: the hub attitude ``R`` (3, 3), its body momentum ``Pi`` (3,), the pendulum directions ``q``
(n, 3) (inertial unit vectors, from each pivot to its mass) and their angular momenta ``pi``
(n, 3) (inertial, ``pi_i . q_i = 0``). Constants of the system (the centre of mass eliminated):
``Jd`` (3, 3), the nonstandard inertia of the hub with the pendulum masses locked at their pivots;
``c`` (n, 3) body vectors of the hub-pendulum coupling; ``M`` (n, n) the pendulums' mass matrix
and ``Minv`` its inverse; ``Ct_i = sum_j Minv_ji c_j``. The discrete Lagrangian

    L_d = 1/h tr((I - F) Jd) + 1/h sum_j ((F - I) c_j) . dqb_j + 1/(2h) sum_ij M_ij dqb_i . dqb_j,

``F = R^T R^+``, ``dqb_j = R^T (q_j^+ - q_j)``, gives the step (body frame of the old ``R``,
``qb = R^T q``, ``pib = R^T pi``):

    vee(F Jd - Jd F^T) + sum_j c_j x dqb_j = h Pi                           (3 equations)
    qb_i x ((F - I) c_i + sum_j M_ij dqb_j) = h pib_i                       (2n equations)
    h Pi^+ = F^T (h Pi + sum_j ((F - I) c_j) x dqb_j)
    h pib_i^+ = h pib_i + dqb_i x ((F - I) c_i + sum_j M_ij dqb_j)

The second line says ``(F - I) c_i + sum_j M_ij dqb_j = y_i + lambda_i qb_i`` with
``y_i = h pib_i x qb_i`` and one number ``lambda_i`` a pendulum, so
``dqb_j = sum_i Minv_ji (y_i + lambda_i qb_i - (F - I) c_i)``; Newton's method then solves the
first line and ``|qb_j + dqb_j| = 1`` (as ``qb_j . dqb_j + |dqb_j|^2 / 2 = 0``) for the ``3 + n``
unknowns ``w`` (``F = exp(hat(w))``) and ``lambda``. The momentum updates are written so that the
total angular momentum ``R Pi + sum_i pi_i`` changes by round-off only whatever the residual.

Damping (a Rayleigh function ``1/2 sum_i k_i |omega_rel_i|^2`` of each pendulum's rate relative to
the hub, ``k_i = d_i l_i^2`` for a force ``-d_i`` times the mass's velocity relative to the hub) is
a kick of the momenta at fixed configuration, solved by the implicit midpoint rule (the energy
falls, the angular momentum is kept to round-off) and placed symmetrically: kick ``h/2``, step,
kick ``h/2``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .codes import NOT_CONVERGED, NOT_FINITE, OK, SINGULAR
from .chain_kernels import first_guess, lu_factor, lu_solve, push_history
from .gyrostat_kernels import mrp_feedback, wheel_torque


@jit(inline="always")
def exp_minus_identity(w, FmI):
    """``FmI = exp(hat(w)) - I`` (3, 3) to its own relative precision (Taylor branch near 0)."""
    t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    if t2 < 1e-8:
        a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0)
        b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0)
    else:
        t = math.sqrt(t2)
        a = math.sin(t) / t
        b = 2.0 * math.sin(0.5 * t) ** 2 / t2        # (1 - cos t) / t^2 without cancellation
    # a hat(w) + b hat(w)^2, hat(w)^2 = w w^T - t2 I
    FmI[0, 0] = b * (w[0] * w[0] - t2)
    FmI[1, 1] = b * (w[1] * w[1] - t2)
    FmI[2, 2] = b * (w[2] * w[2] - t2)
    FmI[0, 1] = b * w[0] * w[1] - a * w[2]
    FmI[1, 0] = b * w[0] * w[1] + a * w[2]
    FmI[0, 2] = b * w[0] * w[2] + a * w[1]
    FmI[2, 0] = b * w[0] * w[2] - a * w[1]
    FmI[1, 2] = b * w[1] * w[2] - a * w[0]
    FmI[2, 1] = b * w[1] * w[2] + a * w[0]


@jit(inline="always")
def right_jacobian(w, Jr):
    """``Jr`` (3, 3) with ``exp(hat(w + e)) = exp(hat(w)) exp(hat(Jr e)) + O(e^2)``:
    ``I - (1 - cos t)/t^2 hat(w) + (t - sin t)/t^3 hat(w)^2``."""
    t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    if t2 < 1e-8:
        b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0)
        c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0)
    else:
        t = math.sqrt(t2)
        b = 2.0 * math.sin(0.5 * t) ** 2 / t2
        c = (t - math.sin(t)) / (t2 * t)
    Jr[0, 0] = 1.0 + c * (w[0] * w[0] - t2)
    Jr[1, 1] = 1.0 + c * (w[1] * w[1] - t2)
    Jr[2, 2] = 1.0 + c * (w[2] * w[2] - t2)
    Jr[0, 1] = c * w[0] * w[1] + b * w[2]
    Jr[1, 0] = c * w[0] * w[1] - b * w[2]
    Jr[0, 2] = c * w[0] * w[2] - b * w[1]
    Jr[2, 0] = c * w[0] * w[2] + b * w[1]
    Jr[1, 2] = c * w[1] * w[2] + b * w[0]
    Jr[2, 1] = c * w[1] * w[2] - b * w[0]


@jit(inline="always")
def lu_pivot_solve(A, b, piv, m):
    """Solve ``A[:m, :m] x = b`` in place in ``b`` by Gaussian elimination with partial pivoting
    (``A`` overwritten, ``piv`` (m,) int work); False when ``A`` is singular."""
    for c in range(m):
        p = c
        big = abs(A[c, c])
        for r in range(c + 1, m):
            if abs(A[r, c]) > big:
                big = abs(A[r, c])
                p = r
        if not big > 0.0:
            return False
        piv[c] = p
        if p != c:
            for s in range(m):
                tmp = A[c, s]
                A[c, s] = A[p, s]
                A[p, s] = tmp
            tmp = b[c]
            b[c] = b[p]
            b[p] = tmp
        inv = 1.0 / A[c, c]
        for r in range(c + 1, m):
            f = A[r, c] * inv
            if f != 0.0:
                for s in range(c + 1, m):
                    A[r, s] -= f * A[c, s]
                b[r] -= f * b[c]
    for r in range(m - 1, -1, -1):
        s = b[r]
        for c in range(r + 1, m):
            s -= A[r, c] * b[c]
        b[r] = s / A[r, r]
    return True


def workspace(n):
    """Scratch arrays of :func:`slosh_substep` for ``n`` pendulums (allocated by the run, once: the
    kernels are compiled without Numba's runtime, ``_nrt=False``, so that passing arrays costs no
    reference counting); the last, (3, 3), is the shifted hub matrix of :func:`run_slosh` with wheels."""
    m = 3 + n
    return (np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3, 3)),
            np.empty((3, 3)), np.empty((3, 3)), np.empty((m, m)), np.empty(m), np.empty((3, 3)), np.empty((3, 3)))


@jit(_nrt=False)
def slosh_substep(Ah, c, Ct, M, Minv, sA, h, R, Pi, g, q, pi, w, lam, ws, piv, tol, max_iter):
    """One conservative step of size ``h`` (module notes); ``R``, ``Pi``, ``q``, ``pi`` updated in
    place. ``Ah`` (3, 3) is the hub's matrix of the discrete Lagrangian: ``Jd`` without wheels, the
    shifted ``Ah = Jd_B + h/2 hat(g)`` with wheels (``g = G rho_bar`` (3,), zero without wheels); the hub
    equation is solved as ``vee(E Ah - Ah^T E^T) + sum_j c_j x dqb_j = h (Pi - g)``, ``E = F - I``. ``w`` (3,) and ``lam`` (n,) are the first guesses of the rotation vector of ``F`` and of
    the multipliers and get their solutions. ``sA`` scales the hub residual to an angle (``tr Jd``).
    ``ws`` is the scratch of :func:`workspace`, ``piv`` (3 + n,) int scratch. Returns
    ``(status, iterations, residual)``."""
    n = q.shape[0]
    m = 3 + n
    qb, yb, e, dq, H, FmI, Jr, A, r, Y, _ = ws
    # body-frame directions and y_i = h pib_i x qb_i (pib less its rounding along qb)
    for i in range(n):
        for a in range(3):
            qb[i, a] = R[0, a] * q[i, 0] + R[1, a] * q[i, 1] + R[2, a] * q[i, 2]
        p0 = R[0, 0] * pi[i, 0] + R[1, 0] * pi[i, 1] + R[2, 0] * pi[i, 2]
        p1 = R[0, 1] * pi[i, 0] + R[1, 1] * pi[i, 1] + R[2, 1] * pi[i, 2]
        p2 = R[0, 2] * pi[i, 0] + R[1, 2] * pi[i, 1] + R[2, 2] * pi[i, 2]
        s = p0 * qb[i, 0] + p1 * qb[i, 1] + p2 * qb[i, 2]
        p0 = h * (p0 - s * qb[i, 0])
        p1 = h * (p1 - s * qb[i, 1])
        p2 = h * (p2 - s * qb[i, 2])
        yb[i, 0] = p1 * qb[i, 2] - p2 * qb[i, 1]
        yb[i, 1] = p2 * qb[i, 0] - p0 * qb[i, 2]
        yb[i, 2] = p0 * qb[i, 1] - p1 * qb[i, 0]
    hP0 = h * (Pi[0] - g[0])
    hP1 = h * (Pi[1] - g[1])
    hP2 = h * (Pi[2] - g[2])
    its = 0
    last = math.inf
    res = 0.0
    while True:
        exp_minus_identity(w, FmI)
        # e_i = y_i + lambda_i qb_i - (F - I) c_i;  dqb_j = sum_i Minv_ji e_i
        for i in range(n):
            for a in range(3):
                e[i, a] = yb[i, a] + lam[i] * qb[i, a] - (FmI[a, 0] * c[i, 0] + FmI[a, 1] * c[i, 1]
                                                         + FmI[a, 2] * c[i, 2])
        for j in range(n):
            for a in range(3):
                s = 0.0
                for i in range(n):
                    s += Minv[j, i] * e[i, a]
                dq[j, a] = s
        # hub residual: vee(Z - Z^T), Z = (F - I) Ah, plus sum_j c_j x dqb_j, less h Pi
        r0 = 0.0
        r1 = 0.0
        r2 = 0.0
        for a in range(3):
            r0 += FmI[2, a] * Ah[a, 1] - FmI[1, a] * Ah[a, 2]
            r1 += FmI[0, a] * Ah[a, 2] - FmI[2, a] * Ah[a, 0]
            r2 += FmI[1, a] * Ah[a, 0] - FmI[0, a] * Ah[a, 1]
        for j in range(n):
            r0 += c[j, 1] * dq[j, 2] - c[j, 2] * dq[j, 1]
            r1 += c[j, 2] * dq[j, 0] - c[j, 0] * dq[j, 2]
            r2 += c[j, 0] * dq[j, 1] - c[j, 1] * dq[j, 0]
        r[0] = -(r0 - hP0)
        r[1] = -(r1 - hP1)
        r[2] = -(r2 - hP2)
        res = max(abs(r[0]), abs(r[1]), abs(r[2])) / sA
        for j in range(n):
            F = (dq[j, 0] * (qb[j, 0] + 0.5 * dq[j, 0]) + dq[j, 1] * (qb[j, 1] + 0.5 * dq[j, 1])
                 + dq[j, 2] * (qb[j, 2] + 0.5 * dq[j, 2]))
            r[3 + j] = -F
            res = max(res, abs(F))
        if not math.isfinite(res):
            return NOT_FINITE, its, res
        if res <= tol or (its > 0 and res > 0.25 * last and res <= 64.0 * tol):
            break
        if its >= max_iter:
            return NOT_CONVERGED, its, res
        # Jacobian in (delta, lambda), delta the rotation vector of F -> F exp(hat(delta)):
        # d dqb_j = -sum_k H_jk delta_k + sum_i Minv_ji qb_i dlambda_i,  H_jk = sum_i Minv_ji F (e_k x c_i)
        for j in range(n):
            for k in range(3):
                for a in range(3):
                    H[j, k, a] = 0.0
        for i in range(n):
            for k in range(3):
                # g = e_k x c_i, then F g = g + FmI g
                g0 = 0.0
                g1 = 0.0
                g2 = 0.0
                if k == 0:
                    g1 = -c[i, 2]
                    g2 = c[i, 1]
                elif k == 1:
                    g0 = c[i, 2]
                    g2 = -c[i, 0]
                else:
                    g0 = -c[i, 1]
                    g1 = c[i, 0]
                f0 = g0 + FmI[0, 0] * g0 + FmI[0, 1] * g1 + FmI[0, 2] * g2
                f1 = g1 + FmI[1, 0] * g0 + FmI[1, 1] * g1 + FmI[1, 2] * g2
                f2 = g2 + FmI[2, 0] * g0 + FmI[2, 1] * g1 + FmI[2, 2] * g2
                for j in range(n):
                    mji = Minv[j, i]
                    H[j, k, 0] += mji * f0
                    H[j, k, 1] += mji * f1
                    H[j, k, 2] += mji * f2
        for k in range(3):
            # vee(Y - Y^T), Y = F E_k Ah: row a of F E_k is (F column cross), E_k x = e_k x x
            # (F E_k)[a, b] = sum_s F[a, s] eps(s, k, b)... computed as F times hat(e_k)
            for a in range(3):
                Fa0 = FmI[a, 0] + (1.0 if a == 0 else 0.0)
                Fa1 = FmI[a, 1] + (1.0 if a == 1 else 0.0)
                Fa2 = FmI[a, 2] + (1.0 if a == 2 else 0.0)
                # row a of F hat(e_k)
                if k == 0:
                    x0, x1, x2 = 0.0, Fa2, -Fa1
                elif k == 1:
                    x0, x1, x2 = -Fa2, 0.0, Fa0
                else:
                    x0, x1, x2 = Fa1, -Fa0, 0.0
                for b in range(3):
                    Y[a, b] = x0 * Ah[0, b] + x1 * Ah[1, b] + x2 * Ah[2, b]
            A[0, k] = Y[2, 1] - Y[1, 2]
            A[1, k] = Y[0, 2] - Y[2, 0]
            A[2, k] = Y[1, 0] - Y[0, 1]
            for j in range(n):
                A[0, k] -= c[j, 1] * H[j, k, 2] - c[j, 2] * H[j, k, 1]
                A[1, k] -= c[j, 2] * H[j, k, 0] - c[j, 0] * H[j, k, 2]
                A[2, k] -= c[j, 0] * H[j, k, 1] - c[j, 1] * H[j, k, 0]
                A[3 + j, k] = -((qb[j, 0] + dq[j, 0]) * H[j, k, 0] + (qb[j, 1] + dq[j, 1]) * H[j, k, 1]
                                + (qb[j, 2] + dq[j, 2]) * H[j, k, 2])
        for i in range(n):
            A[0, 3 + i] = Ct[i, 1] * qb[i, 2] - Ct[i, 2] * qb[i, 1]
            A[1, 3 + i] = Ct[i, 2] * qb[i, 0] - Ct[i, 0] * qb[i, 2]
            A[2, 3 + i] = Ct[i, 0] * qb[i, 1] - Ct[i, 1] * qb[i, 0]
            for j in range(n):
                A[3 + j, 3 + i] = Minv[j, i] * ((qb[j, 0] + dq[j, 0]) * qb[i, 0] + (qb[j, 1] + dq[j, 1]) * qb[i, 1]
                                                + (qb[j, 2] + dq[j, 2]) * qb[i, 2])
        # in the coordinates w of F = exp(hat(w)): columns of delta times Jr(w)
        right_jacobian(w, Jr)
        for a in range(m):
            x0 = A[a, 0]
            x1 = A[a, 1]
            x2 = A[a, 2]
            A[a, 0] = x0 * Jr[0, 0] + x1 * Jr[1, 0] + x2 * Jr[2, 0]
            A[a, 1] = x0 * Jr[0, 1] + x1 * Jr[1, 1] + x2 * Jr[2, 1]
            A[a, 2] = x0 * Jr[0, 2] + x1 * Jr[1, 2] + x2 * Jr[2, 2]
        if not lu_pivot_solve(A, r, piv, m):
            return SINGULAR, its, res
        for a in range(3):
            w[a] += r[a]
        for i in range(n):
            lam[i] += r[3 + i]
        last = res
        its += 1
    # momenta, then configuration (e, dq, FmI are those of the converged iterate)
    ih = 1.0 / h
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for j in range(n):
        g0 = FmI[0, 0] * c[j, 0] + FmI[0, 1] * c[j, 1] + FmI[0, 2] * c[j, 2]
        g1 = FmI[1, 0] * c[j, 0] + FmI[1, 1] * c[j, 1] + FmI[1, 2] * c[j, 2]
        g2 = FmI[2, 0] * c[j, 0] + FmI[2, 1] * c[j, 1] + FmI[2, 2] * c[j, 2]
        s0 += g1 * dq[j, 2] - g2 * dq[j, 1]
        s1 += g2 * dq[j, 0] - g0 * dq[j, 2]
        s2 += g0 * dq[j, 1] - g1 * dq[j, 0]
    u0 = Pi[0] + s0 * ih
    u1 = Pi[1] + s1 * ih
    u2 = Pi[2] + s2 * ih
    fin = u0 + u1 + u2
    for a in range(3):       # Pi^+ = F^T u
        Pi[a] = (u0 * (FmI[0, a] + (1.0 if a == 0 else 0.0)) + u1 * (FmI[1, a] + (1.0 if a == 1 else 0.0))
                 + u2 * (FmI[2, a] + (1.0 if a == 2 else 0.0)))
    for i in range(n):
        # (F - I) c_i + sum_j M_ij dqb_j = y_i + lambda_i qb_i = e_i + (F - I) c_i
        p0 = (yb[i, 0] + lam[i] * qb[i, 0]) * ih
        p1 = (yb[i, 1] + lam[i] * qb[i, 1]) * ih
        p2 = (yb[i, 2] + lam[i] * qb[i, 2]) * ih
        b0 = dq[i, 1] * p2 - dq[i, 2] * p1
        b1 = dq[i, 2] * p0 - dq[i, 0] * p2
        b2 = dq[i, 0] * p1 - dq[i, 1] * p0
        # inertial: pi_i += R (dqb_i x p_i);  q_i += R dqb_i
        for a in range(3):
            pi[i, a] += R[a, 0] * b0 + R[a, 1] * b1 + R[a, 2] * b2
        x0 = q[i, 0] + (R[0, 0] * dq[i, 0] + R[0, 1] * dq[i, 1] + R[0, 2] * dq[i, 2])
        x1 = q[i, 1] + (R[1, 0] * dq[i, 0] + R[1, 1] * dq[i, 1] + R[1, 2] * dq[i, 2])
        x2 = q[i, 2] + (R[2, 0] * dq[i, 0] + R[2, 1] * dq[i, 1] + R[2, 2] * dq[i, 2])
        nq = 1.0 / math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        q[i, 0] = x0 * nq
        q[i, 1] = x1 * nq
        q[i, 2] = x2 * nq
        fin += b0 + b1 + b2
    if not math.isfinite(fin):
        return NOT_FINITE, its, res
    # R^+ = R F = R + R (F - I)
    for a in range(3):
        x0 = R[a, 0]
        x1 = R[a, 1]
        x2 = R[a, 2]
        for b in range(3):
            R[a, b] += x0 * FmI[0, b] + x1 * FmI[1, b] + x2 * FmI[2, b]
    return OK, its, res


def kick_workspace(n):
    """Scratch of :func:`kick_build` / :func:`kick_apply` for ``n`` pendulums (see :func:`workspace`)."""
    m = 3 + 2 * n
    return (np.empty((n, 3)), np.empty((n, 3, 2)), np.empty((m, m)), np.empty((n, 3, m)), np.empty((m, m)),
            np.empty((m, m)), np.empty((m, m)), np.empty(m), np.empty(m), np.empty(m))


@jit(_nrt=False)
def mass_build(Jp, c, M, R, q, kw):
    """The mass matrix ``G`` of the generalised velocities ``u = (Omega, a_1..a_n)`` at the
    configuration ``(R, q)`` into ``kw`` (:func:`kick_workspace`), with the bases ``E_i`` across
    ``qb_i`` (:func:`kick_build`); its LU factors in ``kw``'s ``A``. False when ``G`` is singular.
    With wheels ``Jp`` is the hub's inertia less the wheels' axial part (``J'_B``)."""
    qb, E, G, W, K, A, B, p, u, rhs = kw
    n = q.shape[0]
    m = 3 + 2 * n
    for a in range(m):
        for b in range(m):
            G[a, b] = 0.0
    for i in range(n):
        for a in range(3):
            qb[i, a] = R[0, a] * q[i, 0] + R[1, a] * q[i, 1] + R[2, a] * q[i, 2]
        # a unit vector across qb_i, then qb_i x it
        x0 = qb[i, 0]
        x1 = qb[i, 1]
        x2 = qb[i, 2]
        if abs(x0) <= abs(x1) and abs(x0) <= abs(x2):
            t0, t1, t2 = 0.0, -x2, x1
        elif abs(x1) <= abs(x2):
            t0, t1, t2 = x2, 0.0, -x0
        else:
            t0, t1, t2 = -x1, x0, 0.0
        nt = 1.0 / math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        t0 *= nt
        t1 *= nt
        t2 *= nt
        E[i, 0, 0] = t0
        E[i, 1, 0] = t1
        E[i, 2, 0] = t2
        E[i, 0, 1] = x1 * t2 - x2 * t1
        E[i, 1, 1] = x2 * t0 - x0 * t2
        E[i, 2, 1] = x0 * t1 - x1 * t0
    # G: [[J', hat(c_j) E_j], [., M_ij E_i^T E_j]]
    for a in range(3):
        for b in range(3):
            G[a, b] = Jp[a, b]
    for j in range(n):
        for s in range(2):
            e0 = E[j, 0, s]
            e1 = E[j, 1, s]
            e2 = E[j, 2, s]
            x0 = c[j, 1] * e2 - c[j, 2] * e1
            x1 = c[j, 2] * e0 - c[j, 0] * e2
            x2 = c[j, 0] * e1 - c[j, 1] * e0
            G[0, 3 + 2 * j + s] = x0
            G[1, 3 + 2 * j + s] = x1
            G[2, 3 + 2 * j + s] = x2
            G[3 + 2 * j + s, 0] = x0
            G[3 + 2 * j + s, 1] = x1
            G[3 + 2 * j + s, 2] = x2
        for i in range(n):
            for s in range(2):
                for t in range(2):
                    G[3 + 2 * i + s, 3 + 2 * j + t] = M[i, j] * (E[i, 0, s] * E[j, 0, t] + E[i, 1, s] * E[j, 1, t]
                                                               + E[i, 2, s] * E[j, 2, t])
    for a in range(m):
        for b in range(m):
            A[a, b] = G[a, b]
    return lu_factor(A, m)


@jit(_nrt=False)
def kick_build(Jp, c, M, k, tau, R, q, kw):
    """Build the damping kick of duration ``tau`` at the configuration ``(R, q)`` into ``kw``
    (:func:`kick_workspace`); False when a matrix is singular.

    The momenta after a time ``tau`` of the damping alone at fixed configuration, by the implicit
    midpoint rule (linear: one solve). Generalised velocities ``u = (Omega, a_1..a_n)``,
    ``vb_i = E_i a_i`` (``E_i`` (3, 2) an orthonormal basis across ``qb_i``); mass matrix ``G``,
    damping matrix ``K`` from ``omega_rel_i = qb_i x vb_i - (Omega less its part along qb_i)``.
    ``(G + tau/2 K) u^+ = (G - tau/2 K) u`` and the momenta change by ``-tau K (u + u^+)/2``
    (:func:`kick_apply`)."""
    qb, E, G, W, K, A, B, p, u, rhs = kw
    n = q.shape[0]
    m = 3 + 2 * n
    if not mass_build(Jp, c, M, R, q, kw):
        return False
    for a in range(m):
        for b in range(m):
            K[a, b] = 0.0
    # W_i u = omega_rel_i = qb_i x E_i a_i - (I - qb_i qb_i^T) Omega (only the columns of Omega and
    # a_i are non-zero);  K = sum_i k_i W_i^T W_i
    for i in range(n):
        if k[i] == 0.0:
            continue
        for a in range(3):
            for b in range(3):
                W[i, a, b] = qb[i, a] * qb[i, b] - (1.0 if a == b else 0.0)
        for s in range(2):
            e0 = E[i, 0, s]
            e1 = E[i, 1, s]
            e2 = E[i, 2, s]
            W[i, 0, 3 + 2 * i + s] = qb[i, 1] * e2 - qb[i, 2] * e1
            W[i, 1, 3 + 2 * i + s] = qb[i, 2] * e0 - qb[i, 0] * e2
            W[i, 2, 3 + 2 * i + s] = qb[i, 0] * e1 - qb[i, 1] * e0
        for ia in range(5):
            a = ia if ia < 3 else 3 + 2 * i + ia - 3
            for ib in range(5):
                b = ib if ib < 3 else 3 + 2 * i + ib - 3
                K[a, b] += k[i] * (W[i, 0, a] * W[i, 0, b] + W[i, 1, a] * W[i, 1, b] + W[i, 2, a] * W[i, 2, b])
    for a in range(m):
        for b in range(m):
            B[a, b] = G[a, b] + 0.5 * tau * K[a, b]
    return lu_factor(B, m)


@jit(_nrt=False)
def generalised_velocities(R, Pi, g, pi, kw):
    """The momenta ``p = (Pi - g, E_i^T (pib_i x qb_i))`` into ``kw``'s ``p`` and the velocities
    ``u = G^-1 p`` (``u[:3]`` the hub's rate ``Omega``) into its ``u``, with the factors of
    :func:`mass_build` (or :func:`kick_build`) at the current configuration."""
    qb, E, G, W, K, A, B, p, u, rhs = kw
    n = qb.shape[0]
    m = 3 + 2 * n
    for a in range(3):
        p[a] = Pi[a] - g[a]
    for i in range(n):
        p0 = R[0, 0] * pi[i, 0] + R[1, 0] * pi[i, 1] + R[2, 0] * pi[i, 2]
        p1 = R[0, 1] * pi[i, 0] + R[1, 1] * pi[i, 1] + R[2, 1] * pi[i, 2]
        p2 = R[0, 2] * pi[i, 0] + R[1, 2] * pi[i, 1] + R[2, 2] * pi[i, 2]
        g0 = p1 * qb[i, 2] - p2 * qb[i, 1]
        g1 = p2 * qb[i, 0] - p0 * qb[i, 2]
        g2 = p0 * qb[i, 1] - p1 * qb[i, 0]
        for s in range(2):
            p[3 + 2 * i + s] = E[i, 0, s] * g0 + E[i, 1, s] * g1 + E[i, 2, s] * g2
    for a in range(m):
        u[a] = p[a]
    lu_solve(A, u, m)


@jit(_nrt=False)
def kick_apply(tau, R, Pi, g, pi, kw):
    """Apply the kick built by :func:`kick_build` (same ``tau``, same configuration) to the momenta;
    ``g = G rho`` (3,) the wheels' momentum in the body (zero without wheels: the hub's share of
    ``Pi`` is ``Pi - g``; the wheels' momenta do not change in the kick)."""
    qb, E, G, W, K, A, B, p, u, rhs = kw
    n = qb.shape[0]
    m = 3 + 2 * n
    generalised_velocities(R, Pi, g, pi, kw)
    # (G + tau/2 K) u^+ = (G - tau/2 K) u = p - tau/2 K u
    for a in range(m):
        s = 0.0
        for b in range(m):
            s += K[a, b] * u[b]
        rhs[a] = p[a] - 0.5 * tau * s
    lu_solve(B, rhs, m)
    # dp = -tau K (u + u^+)/2
    for a in range(m):
        u[a] = 0.5 * (u[a] + rhs[a])
    for a in range(m):
        s = 0.0
        for b in range(m):
            s += K[a, b] * u[b]
        p[a] = -tau * s
    for a in range(3):
        Pi[a] += p[a]
    for i in range(n):
        # pib_i += qb_i x (E_i dp_a_i), to inertial with R
        g0 = E[i, 0, 0] * p[3 + 2 * i] + E[i, 0, 1] * p[4 + 2 * i]
        g1 = E[i, 1, 0] * p[3 + 2 * i] + E[i, 1, 1] * p[4 + 2 * i]
        g2 = E[i, 2, 0] * p[3 + 2 * i] + E[i, 2, 1] * p[4 + 2 * i]
        b0 = qb[i, 1] * g2 - qb[i, 2] * g1
        b1 = qb[i, 2] * g0 - qb[i, 0] * g2
        b2 = qb[i, 0] * g1 - qb[i, 1] * g0
        for a in range(3):
            pi[i, a] += R[a, 0] * b0 + R[a, 1] * b1 + R[a, 2] * b2
    return math.isfinite(Pi[0] + Pi[1] + Pi[2])


@jit(inline="always")
def wheel_vector(axes, rho, u_now, f, gv):
    """``gv = G (rho + f u)`` (3,): the wheels' momentum in the body, ``f`` of a step ahead with the
    wheels' torques ``u_now[N:]`` (``f = 0``: now; ``f = h/2``: ``G rho_bar``)."""
    N = rho.shape[0]
    gv[0] = 0.0
    gv[1] = 0.0
    gv[2] = 0.0
    for i in range(N):
        r = rho[i] + f * u_now[N + i]
        gv[0] += axes[i, 0] * r
        gv[1] += axes[i, 1] * r
        gv[2] += axes[i, 2] * r


@jit(_nrt=False)
def run_slosh(Jd, Jp, c, Ct, M, Minv, k, damped, sA, gam, h, t0, R, Pi, q, pi, rho, hist, hh, k0, n_steps, tol,
              max_iter, save_every, axes, wp, need_speed, cmd, ucmd, u_now, ctrl, cp, cs, spc, R_out, Pi_out, q_out, pi_out, rho_out,
              it_out, res_out, u_out, last, x, piv, ws, kw, wv):
    """``n_steps`` steps from step ``k0``, each the composition of substeps ``gam[s] h`` (each: damping
    kick ``gam h / 2`` if ``damped``, conservative step, kick). ``hist`` (S, 4, n + 3) and ``hh`` (S, 4)
    hold the solutions ``(lambda, w)`` of each substep over the last four steps and their sizes, the
    first guess of the next (:func:`lgvi._kernels.chain_kernels.first_guess`: cubic extrapolation).
    Every ``save_every`` steps the state goes to row ``j`` of the outputs, with the largest iterations
    and residual of the interval. ``x`` (n + 3,), ``piv`` (n + 3,) int, ``ws`` (:func:`workspace`) and
    ``kw`` (:func:`kick_workspace`) are scratch. Returns ``(status, steps done from k0)``.

    Reaction wheels (``N = rho.shape[0]`` of them, ``N = 0``: none; ``docs/slosh.md``): ``rho`` (N,)
    their absolute axial momenta, ``axes`` (N, 3), ``wp`` (N, 8) the gyrostat's wheel rows
    (:mod:`lgvi._kernels.gyrostat_kernels`), ``Jd`` and ``Jp`` then the hub's matrices less the
    wheels' axial inertia (``Jd_B``, ``J'_B``). At a step's start the hub rate is computed from the
    momenta (the inverse Legendre map, :func:`generalised_velocities`) when the controller is called
    or ``need_speed`` (a power or speed limit or friction needs the wheel speeds); with ``ctrl = 1`` the MRP
    feedback (``cp``, its state ``cs``) sets the motor command ``cmd`` every ``spc`` steps
    (:func:`lgvi._kernels.gyrostat_kernels.mrp_feedback`), with ``ctrl = 2`` row ``k`` of the table
    ``ucmd`` (steps, N) is step ``k``'s command, else ``cmd`` holds the caller's command;
    the command after the wheels' limits plus friction (``u_now`` (2N,): motor, total) is held over
    the step, ``rho`` grows by ``h u`` and every substep uses ``Ah = Jd_B + hc/2 hat(G rho_bar)``.
    ``rho_out`` (samples) gets ``rho``, ``u_out`` (intervals) the motor torques of each saved
    interval's first step. ``wv`` (3, 3) scratch: ``G rho``, ``G rho_bar``, the controller's body
    torque (unused with wheels)."""
    n = q.shape[0]
    N = rho.shape[0]
    S = gam.shape[0]
    lam = x[:n]
    w = x[n:]
    gv = wv[0]
    gb = wv[1]
    Ah = ws[10]
    built = 0.0                  # the tau of the kick built at the current configuration (0: none)
    j = 0
    its_max = 0
    res_max = 0.0
    countdown = save_every
    for a in range(3):
        gv[a] = 0.0
        gb[a] = 0.0
    for s in range(n_steps):
        kk = k0 + s
        if N > 0:
            # the hub rate at the step's start (the controller's measurement; the wheel speeds when
            # a power or speed limit or friction needs them)
            control = ctrl == 1 and kk % spc == 0
            w0 = 0.0
            w1 = 0.0
            w2 = 0.0
            if control or need_speed:
                if damped:
                    tau0 = 0.5 * gam[0] * h
                    if built != tau0:
                        if not kick_build(Jp, c, M, k, tau0, R, q, kw):
                            return SINGULAR, kk
                        built = tau0
                elif not mass_build(Jp, c, M, R, q, kw):
                    return SINGULAR, kk
                wheel_vector(axes, rho, u_now, 0.0, gv)
                generalised_velocities(R, Pi, gv, pi, kw)
                uv = kw[8]
                w0 = uv[0]
                w1 = uv[1]
                w2 = uv[2]
            if control:
                mrp_feedback(cp, cs, t0 + kk * h, R, w0, w1, w2, axes, wp, rho, cmd, wv[2])
            elif ctrl == 2:
                for i in range(N):
                    cmd[i] = ucmd[kk, i]
            for i in range(N):
                wheel_torque(i, cmd, rho, axes, wp, w0, w1, w2, u_now, N)
            if countdown == save_every:
                for i in range(N):
                    u_out[j, i] = u_now[i]
        for cc in range(S):
            hc = gam[cc] * h
            first_guess(x, hist, hh, cc, (cc - 1) % S, hc, n + 3)
            if damped:
                if built != 0.5 * hc:        # the last kick's matrices serve when tau is the same
                    if not kick_build(Jp, c, M, k, 0.5 * hc, R, q, kw):
                        return SINGULAR, kk
                    built = 0.5 * hc
                if N > 0:
                    wheel_vector(axes, rho, u_now, 0.0, gv)
                if not kick_apply(0.5 * hc, R, Pi, gv, pi, kw):
                    return NOT_FINITE, kk
            if N > 0:
                # Ah = Jd_B + hc/2 hat(G rho_bar), rho_bar = rho + hc/2 u
                wheel_vector(axes, rho, u_now, 0.5 * hc, gb)
                f = 0.5 * hc
                for a in range(3):
                    for b in range(3):
                        Ah[a, b] = Jd[a, b]
                Ah[0, 1] -= f * gb[2]
                Ah[0, 2] += f * gb[1]
                Ah[1, 0] += f * gb[2]
                Ah[1, 2] -= f * gb[0]
                Ah[2, 0] -= f * gb[1]
                Ah[2, 1] += f * gb[0]
                st, its, res = slosh_substep(Ah, c, Ct, M, Minv, sA, hc, R, Pi, gb, q, pi, w, lam, ws, piv, tol,
                                             max_iter)
                if st == OK:
                    for i in range(N):
                        rho[i] += hc * u_now[N + i]
            else:
                st, its, res = slosh_substep(Jd, c, Ct, M, Minv, sA, hc, R, Pi, gb, q, pi, w, lam, ws, piv, tol,
                                             max_iter)
            last[0] = its
            last[1] = res
            if st != OK:
                return st, kk
            if damped:
                if not kick_build(Jp, c, M, k, 0.5 * hc, R, q, kw):
                    return SINGULAR, kk
                built = 0.5 * hc
                if N > 0:
                    wheel_vector(axes, rho, u_now, 0.0, gv)
                if not kick_apply(0.5 * hc, R, Pi, gv, pi, kw):
                    return NOT_FINITE, kk
            push_history(x, hist, hh, cc, hc, n + 3)
            if its > its_max:
                its_max = its
            if res > res_max:
                res_max = res
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            for a in range(3):
                Pi_out[j, a] = Pi[a]
                for b in range(3):
                    R_out[j, a, b] = R[a, b]
            for i in range(n):
                for a in range(3):
                    q_out[j, i, a] = q[i, a]
                    pi_out[j, i, a] = pi[i, a]
            for i in range(N):
                rho_out[j, i] = rho[i]
            it_out[j] = its_max
            res_out[j] = res_max
            its_max = 0
            res_max = 0.0
            j += 1
    return OK, k0 + n_steps


__all__ = ["exp_minus_identity", "generalised_velocities", "kick_apply", "kick_build", "kick_workspace", "lu_pivot_solve",
           "mass_build", "right_jacobian", "run_slosh", "slosh_substep", "wheel_vector", "workspace"]
