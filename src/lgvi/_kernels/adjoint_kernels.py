"""Forward runs that keep what the reverse pass needs, and the discrete adjoint of the LGVI.

One step, both forcings (``a = 1`` symmetric, ``a = 0`` the paper's), ``P`` the potential moment
of the built-in conservative models at ``(t_k, R_k)`` and ``u`` the control (an array):

    m_k      = Pi_k + h/2 (P_k + a u_k)
    vee(F_k Jd - Jd F_k^T) = h m_k
    R_{k+1}  = R_k F_k
    Pi_{k+1} = F_k^T m_k + h/2 (P_{k+1} + a u_{k+1}) + (1 - a) h u_k

The reverse pass propagates the left-trivialised multipliers ``lam_R`` (``R -> R exp(hat zeta)``)
and ``lam_P`` of any number of scalar functions at once (one row of ``lam`` per function); the
derivation is in docs/optimal.md. Per step it solves one 3x3 system with ``K(F)^T``,
``K(F) = (tr(F Jd) I - F Jd) F``, reusing the forward ``F``; no allocation (``_nrt=False``).
"""

from __future__ import annotations

import math

from .._jit import jit
from .codes import METHOD_NEWTON, NOT_FINITE, OK
from .solvers import solve_scalar
from .torque_kernels import GRAVITY, GRAVITY_GRADIENT

__all__ = ["adjoint_run", "forward_run", "potential_moment"]


@jit(inline="always")
def cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@jit(inline="always")
def matvec(A, x0, x1, x2):
    return (A[0, 0] * x0 + A[0, 1] * x1 + A[0, 2] * x2, A[1, 0] * x0 + A[1, 1] * x1 + A[1, 2] * x2,
            A[2, 0] * x0 + A[2, 1] * x1 + A[2, 2] * x2)


@jit(inline="always")
def store_step(F, R, k, E):
    """``F[k] = I + E`` and ``R[k+1] = R[k] F[k]`` (with ``E = F - I``, the solver's form, added last
    so the identity part is exact)."""
    E00, E01, E02, E10, E11, E12, E20, E21, E22 = E
    F[k, 0, 0] = 1.0 + E00
    F[k, 0, 1] = E01
    F[k, 0, 2] = E02
    F[k, 1, 0] = E10
    F[k, 1, 1] = 1.0 + E11
    F[k, 1, 2] = E12
    F[k, 2, 0] = E20
    F[k, 2, 1] = E21
    F[k, 2, 2] = 1.0 + E22
    for i in range(3):
        a0 = R[k, i, 0]
        a1 = R[k, i, 1]
        a2 = R[k, i, 2]
        R[k + 1, i, 0] = a0 + (a0 * E00 + a1 * E10 + a2 * E20)
        R[k + 1, i, 1] = a1 + (a0 * E01 + a1 * E11 + a2 * E21)
        R[k + 1, i, 2] = a2 + (a0 * E02 + a1 * E12 + a2 * E22)


@jit(inline="always")
def potential_moment(codes, params, J, t, R, k):
    """Potential moment ``P`` (3 numbers) of the conservative terms at ``(t, R[k])``."""
    P0 = 0.0
    P1 = 0.0
    P2 = 0.0
    for i in range(codes.shape[0]):
        kind = codes[i, 0]
        o = codes[i, 1]
        if kind == GRAVITY:
            s0 = R[k, 2, 0]
            s1 = R[k, 2, 1]
            s2 = R[k, 2, 2]
            q0, q1, q2 = cross(s0, s1, s2, params[o], params[o + 1], params[o + 2])
            P0 += q0
            P1 += q1
            P2 += q2
        elif kind == GRAVITY_GRADIENT:
            kk = params[o]
            nt = params[o + 1] * t
            ct = math.cos(nt)
            st = math.sin(nt)
            c0 = -(R[k, 0, 0] * ct + R[k, 1, 0] * st)
            c1 = -(R[k, 0, 1] * ct + R[k, 1, 1] * st)
            c2 = -(R[k, 0, 2] * ct + R[k, 1, 2] * st)
            j0, j1, j2 = matvec(J, c0, c1, c2)
            q0, q1, q2 = cross(c0, c1, c2, j0, j1, j2)
            P0 += kk * q0
            P1 += kk * q1
            P2 += kk * q2
    return P0, P1, P2


@jit(inline="always")
def potential_adjoint(codes, params, J, t, R, k, l0, l1, l2, gJ, s, tk):
    """Pull the multiplier ``l`` of the moment ``P(t, R[k])`` back.

    Returns ``(G^T l, l . dP/dt * tk)`` (``G`` the left-trivialised derivative of ``P`` in ``R``;
    ``tk = dt_k/dh``) and adds ``l . dP/dJ`` (symmetric) to ``gJ[s]``.
    """
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    gt = 0.0
    for i in range(codes.shape[0]):
        kind = codes[i, 0]
        o = codes[i, 1]
        if kind == GRAVITY:
            # P = s x w, s = R^T e3: dP = -w x (s x zeta), G^T l = -s x (w x l)
            s0 = R[k, 2, 0]
            s1 = R[k, 2, 1]
            s2 = R[k, 2, 2]
            a0, a1, a2 = cross(params[o], params[o + 1], params[o + 2], l0, l1, l2)
            b0, b1, b2 = cross(s0, s1, s2, a0, a1, a2)
            g0 -= b0
            g1 -= b1
            g2 -= b2
        elif kind == GRAVITY_GRADIENT:
            # P = kk c x J c, c = -R^T rhat(t); dc = c x zeta
            # G^T l = kk [c x J (c x l) - c x (J c x l)]
            kk = params[o]
            n = params[o + 1]
            nt = n * t
            ct = math.cos(nt)
            st = math.sin(nt)
            c0 = -(R[k, 0, 0] * ct + R[k, 1, 0] * st)
            c1 = -(R[k, 0, 1] * ct + R[k, 1, 1] * st)
            c2 = -(R[k, 0, 2] * ct + R[k, 1, 2] * st)
            j0, j1, j2 = matvec(J, c0, c1, c2)
            a0, a1, a2 = cross(c0, c1, c2, l0, l1, l2)
            b0, b1, b2 = matvec(J, a0, a1, a2)
            d0, d1, d2 = cross(j0, j1, j2, l0, l1, l2)
            e0, e1, e2 = cross(c0, c1, c2, b0 - d0, b1 - d1, b2 - d2)
            g0 += kk * e0
            g1 += kk * e1
            g2 += kk * e2
            # dP/dJ: l . (c x dJ c) = (l x c) . dJ c
            x0, x1, x2 = cross(l0, l1, l2, c0, c1, c2)
            cc = (c0, c1, c2)
            xx = (x0, x1, x2)
            for p in range(3):
                for q in range(3):
                    gJ[s, p, q] += 0.5 * kk * (xx[p] * cc[q] + cc[p] * xx[q])
            if tk != 0.0 and n != 0.0:
                # dc/dt = -R^T drhat/dt, drhat/dt = n (-sin nt, cos nt, 0)
                f0 = -n * (-R[k, 0, 0] * st + R[k, 1, 0] * ct)
                f1 = -n * (-R[k, 0, 1] * st + R[k, 1, 1] * ct)
                f2 = -n * (-R[k, 0, 2] * st + R[k, 1, 2] * ct)
                h0, h1, h2 = matvec(J, f0, f1, f2)
                p0, p1, p2 = cross(f0, f1, f2, j0, j1, j2)
                q0, q1, q2 = cross(c0, c1, c2, h0, h1, h2)
                gt += kk * tk * (l0 * (p0 + q0) + l1 * (p1 + q1) + l2 * (p2 + q2))
    return g0, g1, g2, gt


@jit(_nrt=False)
def forward_run(Jd, J, J_inv, h, t0, R, Pi, F, P, U, sym, codes, params, tol, max_iter, its, res, hist):
    """Run ``N = F.shape[0]`` steps from ``R[0]``, ``Pi[0]`` and keep every state.

    ``R`` (N+1,3,3), ``Pi`` (N+1,3), ``F`` (N,3,3) and ``P`` (N+1,3) (the potential moments) are
    filled; ``U`` holds the controls, (N,3) for the paper's forcing (``sym`` False) or (N+1,3) for
    the symmetric one. ``its`` (N,) and ``res`` (N,) take the solver's record. Returns
    ``(status, k)``: ``OK`` and ``N``, or the failing solver status and the step.
    """
    N = F.shape[0]
    d00 = Jd[0, 0]
    d01 = Jd[0, 1]
    d02 = Jd[0, 2]
    d11 = Jd[1, 1]
    d12 = Jd[1, 2]
    d22 = Jd[2, 2]
    aa = 1.0 if sym else 0.0
    P[0, 0], P[0, 1], P[0, 2] = potential_moment(codes, params, J, t0, R, 0)
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    q0 = 0.0
    q1 = 0.0
    q2 = 0.0
    z0 = 0.0
    z1 = 0.0
    z2 = 0.0
    for k in range(N):
        hh = 0.5 * h
        m0 = Pi[k, 0] + hh * (P[k, 0] + aa * U[k, 0])
        m1 = Pi[k, 1] + hh * (P[k, 1] + aa * U[k, 1])
        m2 = Pi[k, 2] + hh * (P[k, 2] + aa * U[k, 2])
        p0 = h * m0
        p1 = h * m1
        p2 = h * m2
        # guess: the linearisation J w = h m, then the extrapolation of the last solutions
        # (quadratic from the fourth step: O(h^3) off, one Newton update usually lands at round-off)
        if k == 0:
            w0, w1, w2 = matvec(J_inv, p0, p1, p2)
        elif k == 1:
            w0, w1, w2 = g0, g1, g2
        elif k == 2:
            w0, w1, w2 = 2.0 * g0 - q0, 2.0 * g1 - q1, 2.0 * g2 - q2
        else:
            w0 = 3.0 * (g0 - q0) + z0
            w1 = 3.0 * (g1 - q1) + z1
            w2 = 3.0 * (g2 - q2) + z2
        (n0, n1, n2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, rn,
         st) = solve_scalar(METHOD_NEWTON, d00, d01, d02, d11, d12, d22, p0, p1, p2, w0, w1, w2, tol, max_iter,
                            1.0, hist)
        its[k] = it
        res[k] = rn
        if st != OK:
            return st, k
        z0, z1, z2 = q0, q1, q2
        q0, q1, q2 = g0, g1, g2
        g0, g1, g2 = n0, n1, n2
        store_step(F, R, k, (E00, E01, E02, E10, E11, E12, E20, E21, E22))
        P[k + 1, 0], P[k + 1, 1], P[k + 1, 2] = potential_moment(codes, params, J, t0 + (k + 1) * h, R, k + 1)
        b0 = m0 + (E00 * m0 + E10 * m1 + E20 * m2)
        b1 = m1 + (E01 * m0 + E11 * m1 + E21 * m2)
        b2 = m2 + (E02 * m0 + E12 * m1 + E22 * m2)
        if sym:
            b0 += hh * (P[k + 1, 0] + U[k + 1, 0])
            b1 += hh * (P[k + 1, 1] + U[k + 1, 1])
            b2 += hh * (P[k + 1, 2] + U[k + 1, 2])
        else:
            b0 += hh * P[k + 1, 0] + h * U[k, 0]
            b1 += hh * P[k + 1, 1] + h * U[k, 1]
            b2 += hh * P[k + 1, 2] + h * U[k, 2]
        if not (math.isfinite(b0) and math.isfinite(b1) and math.isfinite(b2)):
            return NOT_FINITE, k
        Pi[k + 1, 0] = b0
        Pi[k + 1, 1] = b1
        Pi[k + 1, 2] = b2
    return OK, N


@jit(_nrt=False)
def adjoint_run(Jd, h, t0, J, R, Pi, F, P, U, sym, codes, params, dR, dP, du, lam, gu, gJ, gh):
    """Reverse pass of :func:`forward_run` for ``S = lam.shape[0]`` scalar functions at once.

    ``dR`` (S,N+1,3), ``dP`` (S,N+1,3): the partial derivatives of each function with respect to
    ``zeta_k`` (left-trivialised, ``R_k -> R_k exp(hat zeta_k)``) and ``Pi_k`` at every step;
    ``du`` (S,Nu,3) its partials in the controls. ``dR`` and ``dP`` of shape (S,1,3) hold the
    partials at step ``N`` only (a terminal cost: no (S,N+1,3) arrays to fill and read).
    Out: ``lam`` (S,6) the gradients in ``(zeta_0, Pi_0)``; ``gu`` (S,Nu,3) in the controls;
    ``gJ`` (S,3,3) in the inertia (symmetric, ``dC = <gJ, dJ>`` for symmetric ``dJ``); ``gh`` (S,)
    in the step size (the grid ``t_k = t0 + k h`` moving with it).
    """
    N = F.shape[0]
    S = lam.shape[0]
    aa = 1.0 if sym else 0.0
    hh = 0.5 * h
    tr = Jd[0, 0] + Jd[1, 1] + Jd[2, 2]
    running = dR.shape[1] > 1
    last = dR.shape[1] - 1
    for s in range(S):
        lam[s, 0] = dR[s, last, 0]
        lam[s, 1] = dR[s, last, 1]
        lam[s, 2] = dR[s, last, 2]
        lam[s, 3] = dP[s, last, 0]
        lam[s, 4] = dP[s, last, 1]
        lam[s, 5] = dP[s, last, 2]
        gh[s] = 0.0
        for i in range(3):
            for j in range(3):
                gJ[s, i, j] = 0.0
        for k in range(du.shape[1]):
            gu[s, k, 0] = du[s, k, 0]
            gu[s, k, 1] = du[s, k, 1]
            gu[s, k, 2] = du[s, k, 2]
    for k in range(N - 1, -1, -1):
        t1 = t0 + (k + 1) * h
        tk = t0 + k * h
        # A = F Jd, K = (tr(A) I - A) F, then its inverse transpose by cofactors
        A00 = F[k, 0, 0] * Jd[0, 0] + F[k, 0, 1] * Jd[1, 0] + F[k, 0, 2] * Jd[2, 0]
        A01 = F[k, 0, 0] * Jd[0, 1] + F[k, 0, 1] * Jd[1, 1] + F[k, 0, 2] * Jd[2, 1]
        A02 = F[k, 0, 0] * Jd[0, 2] + F[k, 0, 1] * Jd[1, 2] + F[k, 0, 2] * Jd[2, 2]
        A10 = F[k, 1, 0] * Jd[0, 0] + F[k, 1, 1] * Jd[1, 0] + F[k, 1, 2] * Jd[2, 0]
        A11 = F[k, 1, 0] * Jd[0, 1] + F[k, 1, 1] * Jd[1, 1] + F[k, 1, 2] * Jd[2, 1]
        A12 = F[k, 1, 0] * Jd[0, 2] + F[k, 1, 1] * Jd[1, 2] + F[k, 1, 2] * Jd[2, 2]
        A20 = F[k, 2, 0] * Jd[0, 0] + F[k, 2, 1] * Jd[1, 0] + F[k, 2, 2] * Jd[2, 0]
        A21 = F[k, 2, 0] * Jd[0, 1] + F[k, 2, 1] * Jd[1, 1] + F[k, 2, 2] * Jd[2, 1]
        A22 = F[k, 2, 0] * Jd[0, 2] + F[k, 2, 1] * Jd[1, 2] + F[k, 2, 2] * Jd[2, 2]
        ta = A00 + A11 + A22
        B00 = ta - A00
        B01 = -A01
        B02 = -A02
        B10 = -A10
        B11 = ta - A11
        B12 = -A12
        B20 = -A20
        B21 = -A21
        B22 = ta - A22
        K00 = B00 * F[k, 0, 0] + B01 * F[k, 1, 0] + B02 * F[k, 2, 0]
        K01 = B00 * F[k, 0, 1] + B01 * F[k, 1, 1] + B02 * F[k, 2, 1]
        K02 = B00 * F[k, 0, 2] + B01 * F[k, 1, 2] + B02 * F[k, 2, 2]
        K10 = B10 * F[k, 0, 0] + B11 * F[k, 1, 0] + B12 * F[k, 2, 0]
        K11 = B10 * F[k, 0, 1] + B11 * F[k, 1, 1] + B12 * F[k, 2, 1]
        K12 = B10 * F[k, 0, 2] + B11 * F[k, 1, 2] + B12 * F[k, 2, 2]
        K20 = B20 * F[k, 0, 0] + B21 * F[k, 1, 0] + B22 * F[k, 2, 0]
        K21 = B20 * F[k, 0, 1] + B21 * F[k, 1, 1] + B22 * F[k, 2, 1]
        K22 = B20 * F[k, 0, 2] + B21 * F[k, 1, 2] + B22 * F[k, 2, 2]
        # cofactors C of K: K^-1 = C^T / det, so K^-T = C / det
        C00 = K11 * K22 - K12 * K21
        C01 = K12 * K20 - K10 * K22
        C02 = K10 * K21 - K11 * K20
        C10 = K02 * K21 - K01 * K22
        C11 = K00 * K22 - K02 * K20
        C12 = K01 * K20 - K00 * K21
        C20 = K01 * K12 - K02 * K11
        C21 = K02 * K10 - K00 * K12
        C22 = K00 * K11 - K01 * K10
        inv = 1.0 / (K00 * C00 + K01 * C01 + K02 * C02)
        # m_k and v = F^T m_k
        Mk0 = P[k, 0] + aa * U[k, 0]
        Mk1 = P[k, 1] + aa * U[k, 1]
        Mk2 = P[k, 2] + aa * U[k, 2]
        m0 = Pi[k, 0] + hh * Mk0
        m1 = Pi[k, 1] + hh * Mk1
        m2 = Pi[k, 2] + hh * Mk2
        v0 = F[k, 0, 0] * m0 + F[k, 1, 0] * m1 + F[k, 2, 0] * m2
        v1 = F[k, 0, 1] * m0 + F[k, 1, 1] * m1 + F[k, 2, 1] * m2
        v2 = F[k, 0, 2] * m0 + F[k, 1, 2] * m1 + F[k, 2, 2] * m2
        if sym:
            Me0 = P[k + 1, 0] + U[k + 1, 0]
            Me1 = P[k + 1, 1] + U[k + 1, 1]
            Me2 = P[k + 1, 2] + U[k + 1, 2]
        else:
            Me0 = 0.5 * P[k + 1, 0] + U[k, 0]
            Me1 = 0.5 * P[k + 1, 1] + U[k, 1]
            Me2 = 0.5 * P[k + 1, 2] + U[k, 2]
        for s in range(S):
            lR0 = lam[s, 0]
            lR1 = lam[s, 1]
            lR2 = lam[s, 2]
            lP0 = lam[s, 3]
            lP1 = lam[s, 4]
            lP2 = lam[s, 5]
            # Pi_{k+1} = F^T m + h/2 (P_{k+1} + a u_{k+1}) + (1 - a) h u_k
            if sym:
                gu[s, k + 1, 0] += hh * lP0
                gu[s, k + 1, 1] += hh * lP1
                gu[s, k + 1, 2] += hh * lP2
                gh[s] += 0.5 * (lP0 * Me0 + lP1 * Me1 + lP2 * Me2)
            else:
                gu[s, k, 0] += h * lP0
                gu[s, k, 1] += h * lP1
                gu[s, k, 2] += h * lP2
                gh[s] += lP0 * Me0 + lP1 * Me1 + lP2 * Me2
            e0, e1, e2, et = potential_adjoint(codes, params, J, t1, R, k + 1, hh * lP0, hh * lP1, hh * lP2, gJ, s,
                                               k + 1.0)
            lR0 += e0
            lR1 += e1
            lR2 += e2
            gh[s] += et
            # w = K^-T (lam_R - v x lam_P)
            x0, x1, x2 = cross(v0, v1, v2, lP0, lP1, lP2)
            c0 = lR0 - x0
            c1 = lR1 - x1
            c2 = lR2 - x2
            w0 = (C00 * c0 + C01 * c1 + C02 * c2) * inv
            w1 = (C10 * c0 + C11 * c1 + C12 * c2) * inv
            w2 = (C20 * c0 + C21 * c1 + C22 * c2) * inv
            # d(h m) = h dm + m dh
            gh[s] += w0 * m0 + w1 * m1 + w2 * m2
            # inertia through Jd: <(W F - F^T W)/2, dJd> with (F^T W) = -(W F)^T, so the gradient
            # in Jd is sym(W F) (columns w x F[:, q]); then dJd = tr(dJ)/2 I - dJ
            a00, a10, a20 = cross(w0, w1, w2, F[k, 0, 0], F[k, 1, 0], F[k, 2, 0])
            a01, a11, a21 = cross(w0, w1, w2, F[k, 0, 1], F[k, 1, 1], F[k, 2, 1])
            a02, a12, a22 = cross(w0, w1, w2, F[k, 0, 2], F[k, 1, 2], F[k, 2, 2])
            tg = 0.5 * (a00 + a11 + a22)
            gJ[s, 0, 0] += tg - a00
            gJ[s, 1, 1] += tg - a11
            gJ[s, 2, 2] += tg - a22
            o01 = 0.5 * (a01 + a10)
            o02 = 0.5 * (a02 + a20)
            o12 = 0.5 * (a12 + a21)
            gJ[s, 0, 1] -= o01
            gJ[s, 1, 0] -= o01
            gJ[s, 0, 2] -= o02
            gJ[s, 2, 0] -= o02
            gJ[s, 1, 2] -= o12
            gJ[s, 2, 1] -= o12
            # lam_P = F lam_P+ + h w;  lam_M = h/2 lam_P
            n0 = F[k, 0, 0] * lP0 + F[k, 0, 1] * lP1 + F[k, 0, 2] * lP2 + h * w0
            n1 = F[k, 1, 0] * lP0 + F[k, 1, 1] * lP1 + F[k, 1, 2] * lP2 + h * w1
            n2 = F[k, 2, 0] * lP0 + F[k, 2, 1] * lP1 + F[k, 2, 2] * lP2 + h * w2
            gh[s] += 0.5 * (n0 * Mk0 + n1 * Mk1 + n2 * Mk2)
            lM0 = hh * n0
            lM1 = hh * n1
            lM2 = hh * n2
            if sym:
                gu[s, k, 0] += lM0
                gu[s, k, 1] += lM1
                gu[s, k, 2] += lM2
            # lam_R = F lam_R+ + G_k^T lam_M
            r0 = F[k, 0, 0] * lR0 + F[k, 0, 1] * lR1 + F[k, 0, 2] * lR2
            r1 = F[k, 1, 0] * lR0 + F[k, 1, 1] * lR1 + F[k, 1, 2] * lR2
            r2 = F[k, 2, 0] * lR0 + F[k, 2, 1] * lR1 + F[k, 2, 2] * lR2
            e0, e1, e2, et = potential_adjoint(codes, params, J, tk, R, k, lM0, lM1, lM2, gJ, s, k * 1.0)
            gh[s] += et
            lam[s, 0] = r0 + e0
            lam[s, 1] = r1 + e1
            lam[s, 2] = r2 + e2
            lam[s, 3] = n0
            lam[s, 4] = n1
            lam[s, 5] = n2
            if running:
                lam[s, 0] += dR[s, k, 0]
                lam[s, 1] += dR[s, k, 1]
                lam[s, 2] += dR[s, k, 2]
                lam[s, 3] += dP[s, k, 0]
                lam[s, 4] += dP[s, k, 1]
                lam[s, 5] += dP[s, k, 2]


@jit(_nrt=False)
def shoot_run(Jd, J, J_inv, h, t0, lam0, umax, R, Pi, F, P, U, codes, params, tol, max_iter, its, res, hist, gJ):
    """The discrete necessary conditions of the minimum-effort problem, integrated forwards.

    The paper's forcing: from ``(R_0, Pi_0)`` in ``R``, ``Pi`` and the multipliers ``lam0`` (6,)
    (``lam_R``, ``lam_P`` at step 0), each step solves ``F_k``, carries the multipliers forwards by
    inverting the adjoint recursion of :func:`adjoint_run` (one 3x3 solve), and takes the control
    that minimises ``h |u|^2 + h lam_P,k+1 . u`` over the box ``|u_i| <= umax_i``:
    ``u_k = clip(-lam_P,k+1 / 2)``. Fills ``R``, ``Pi``, ``F``, ``P``, ``U`` (N,3); ``gJ`` (1,3,3)
    is scratch. Returns ``(status, k)`` as :func:`forward_run`.
    """
    N = F.shape[0]
    d00 = Jd[0, 0]
    d01 = Jd[0, 1]
    d02 = Jd[0, 2]
    d11 = Jd[1, 1]
    d12 = Jd[1, 2]
    d22 = Jd[2, 2]
    hh = 0.5 * h
    lR0 = lam0[0]
    lR1 = lam0[1]
    lR2 = lam0[2]
    lP0 = lam0[3]
    lP1 = lam0[4]
    lP2 = lam0[5]
    P[0, 0], P[0, 1], P[0, 2] = potential_moment(codes, params, J, t0, R, 0)
    for k in range(N):
        m0 = Pi[k, 0] + hh * P[k, 0]
        m1 = Pi[k, 1] + hh * P[k, 1]
        m2 = Pi[k, 2] + hh * P[k, 2]
        w0, w1, w2 = matvec(J_inv, h * m0, h * m1, h * m2)
        (n0, n1, n2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, rn,
         st) = solve_scalar(METHOD_NEWTON, d00, d01, d02, d11, d12, d22, h * m0, h * m1, h * m2, w0, w1, w2, tol,
                            max_iter, 1.0, hist)
        its[k] = it
        res[k] = rn
        if st != OK:
            return st, k
        store_step(F, R, k, (E00, E01, E02, E10, E11, E12, E20, E21, E22))
        P[k + 1, 0], P[k + 1, 1], P[k + 1, 2] = potential_moment(codes, params, J, t0 + (k + 1) * h, R, k + 1)
        # lam_R+' = F^T (lam_R - G_k^T (h/2 lam_P))
        e0, e1, e2, et = potential_adjoint(codes, params, J, t0 + k * h, R, k, hh * lP0, hh * lP1, hh * lP2, gJ, 0,
                                           0.0)
        x0 = lR0 - e0
        x1 = lR1 - e1
        x2 = lR2 - e2
        q0 = F[k, 0, 0] * x0 + F[k, 1, 0] * x1 + F[k, 2, 0] * x2
        q1 = F[k, 0, 1] * x0 + F[k, 1, 1] * x1 + F[k, 2, 1] * x2
        q2 = F[k, 0, 2] * x0 + F[k, 1, 2] * x1 + F[k, 2, 2] * x2
        # K = (tr(F Jd) I - F Jd) F and C = cofactors (K^-T = C / det)
        A00 = F[k, 0, 0] * Jd[0, 0] + F[k, 0, 1] * Jd[1, 0] + F[k, 0, 2] * Jd[2, 0]
        A01 = F[k, 0, 0] * Jd[0, 1] + F[k, 0, 1] * Jd[1, 1] + F[k, 0, 2] * Jd[2, 1]
        A02 = F[k, 0, 0] * Jd[0, 2] + F[k, 0, 1] * Jd[1, 2] + F[k, 0, 2] * Jd[2, 2]
        A10 = F[k, 1, 0] * Jd[0, 0] + F[k, 1, 1] * Jd[1, 0] + F[k, 1, 2] * Jd[2, 0]
        A11 = F[k, 1, 0] * Jd[0, 1] + F[k, 1, 1] * Jd[1, 1] + F[k, 1, 2] * Jd[2, 1]
        A12 = F[k, 1, 0] * Jd[0, 2] + F[k, 1, 1] * Jd[1, 2] + F[k, 1, 2] * Jd[2, 2]
        A20 = F[k, 2, 0] * Jd[0, 0] + F[k, 2, 1] * Jd[1, 0] + F[k, 2, 2] * Jd[2, 0]
        A21 = F[k, 2, 0] * Jd[0, 1] + F[k, 2, 1] * Jd[1, 1] + F[k, 2, 2] * Jd[2, 1]
        A22 = F[k, 2, 0] * Jd[0, 2] + F[k, 2, 1] * Jd[1, 2] + F[k, 2, 2] * Jd[2, 2]
        ta = A00 + A11 + A22
        K00 = (ta - A00) * F[k, 0, 0] - A01 * F[k, 1, 0] - A02 * F[k, 2, 0]
        K01 = (ta - A00) * F[k, 0, 1] - A01 * F[k, 1, 1] - A02 * F[k, 2, 1]
        K02 = (ta - A00) * F[k, 0, 2] - A01 * F[k, 1, 2] - A02 * F[k, 2, 2]
        K10 = -A10 * F[k, 0, 0] + (ta - A11) * F[k, 1, 0] - A12 * F[k, 2, 0]
        K11 = -A10 * F[k, 0, 1] + (ta - A11) * F[k, 1, 1] - A12 * F[k, 2, 1]
        K12 = -A10 * F[k, 0, 2] + (ta - A11) * F[k, 1, 2] - A12 * F[k, 2, 2]
        K20 = -A20 * F[k, 0, 0] - A21 * F[k, 1, 0] + (ta - A22) * F[k, 2, 0]
        K21 = -A20 * F[k, 0, 1] - A21 * F[k, 1, 1] + (ta - A22) * F[k, 2, 1]
        K22 = -A20 * F[k, 0, 2] - A21 * F[k, 1, 2] + (ta - A22) * F[k, 2, 2]
        C00 = K11 * K22 - K12 * K21
        C01 = K12 * K20 - K10 * K22
        C02 = K10 * K21 - K11 * K20
        C10 = K02 * K21 - K01 * K22
        C11 = K00 * K22 - K02 * K20
        C12 = K01 * K20 - K00 * K21
        C20 = K01 * K12 - K02 * K11
        C21 = K02 * K10 - K00 * K12
        C22 = K00 * K11 - K01 * K10
        c = h / (K00 * C00 + K01 * C01 + K02 * C02)          # h K^-T = c C
        # (F - h K^-T hat(v)) lam_P+ = lam_P - h K^-T lam_R+',  v = F^T m
        v0 = F[k, 0, 0] * m0 + F[k, 1, 0] * m1 + F[k, 2, 0] * m2
        v1 = F[k, 0, 1] * m0 + F[k, 1, 1] * m1 + F[k, 2, 1] * m2
        v2 = F[k, 0, 2] * m0 + F[k, 1, 2] * m1 + F[k, 2, 2] * m2
        # columns of hat(v): hat(v) e_j = v x e_j
        H00, H10, H20 = 0.0, v2, -v1
        H01, H11, H21 = -v2, 0.0, v0
        H02, H12, H22 = v1, -v0, 0.0
        M00 = F[k, 0, 0] - c * (C00 * H00 + C01 * H10 + C02 * H20)
        M01 = F[k, 0, 1] - c * (C00 * H01 + C01 * H11 + C02 * H21)
        M02 = F[k, 0, 2] - c * (C00 * H02 + C01 * H12 + C02 * H22)
        M10 = F[k, 1, 0] - c * (C10 * H00 + C11 * H10 + C12 * H20)
        M11 = F[k, 1, 1] - c * (C10 * H01 + C11 * H11 + C12 * H21)
        M12 = F[k, 1, 2] - c * (C10 * H02 + C11 * H12 + C12 * H22)
        M20 = F[k, 2, 0] - c * (C20 * H00 + C21 * H10 + C22 * H20)
        M21 = F[k, 2, 1] - c * (C20 * H01 + C21 * H11 + C22 * H21)
        M22 = F[k, 2, 2] - c * (C20 * H02 + C21 * H12 + C22 * H22)
        b0 = lP0 - c * (C00 * q0 + C01 * q1 + C02 * q2)
        b1 = lP1 - c * (C10 * q0 + C11 * q1 + C12 * q2)
        b2 = lP2 - c * (C20 * q0 + C21 * q1 + C22 * q2)
        D00 = M11 * M22 - M12 * M21
        D01 = M12 * M20 - M10 * M22
        D02 = M10 * M21 - M11 * M20
        D10 = M02 * M21 - M01 * M22
        D11 = M00 * M22 - M02 * M20
        D12 = M01 * M20 - M00 * M21
        D20 = M01 * M12 - M02 * M11
        D21 = M02 * M10 - M00 * M12
        D22 = M00 * M11 - M01 * M10
        det = M00 * D00 + M01 * D01 + M02 * D02
        if det == 0.0 or not math.isfinite(det):
            return NOT_FINITE, k
        lP0 = (D00 * b0 + D10 * b1 + D20 * b2) / det
        lP1 = (D01 * b0 + D11 * b1 + D21 * b2) / det
        lP2 = (D02 * b0 + D12 * b1 + D22 * b2) / det
        # lam_R+ = lam_R+' - G_{k+1}^T (h/2 lam_P+)
        e0, e1, e2, et = potential_adjoint(codes, params, J, t0 + (k + 1) * h, R, k + 1, hh * lP0, hh * lP1, hh * lP2,
                                           gJ, 0, 0.0)
        lR0 = q0 - e0
        lR1 = q1 - e1
        lR2 = q2 - e2
        # the control minimising h |u|^2 + h lam_P+ . u in the box
        U[k, 0] = min(max(-0.5 * lP0, -umax[0]), umax[0])
        U[k, 1] = min(max(-0.5 * lP1, -umax[1]), umax[1])
        U[k, 2] = min(max(-0.5 * lP2, -umax[2]), umax[2])
        b0 = v0 + hh * P[k + 1, 0] + h * U[k, 0]
        b1 = v1 + hh * P[k + 1, 1] + h * U[k, 1]
        b2 = v2 + hh * P[k + 1, 2] + h * U[k, 2]
        if not (math.isfinite(b0) and math.isfinite(b1) and math.isfinite(b2)):
            return NOT_FINITE, k
        Pi[k + 1, 0] = b0
        Pi[k + 1, 1] = b1
        Pi[k + 1, 2] = b2
    return OK, N
