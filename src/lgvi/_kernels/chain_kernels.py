r"""Compiled steps of a chain of spherical pendulums on ``(S^2)^n`` (see ``docs/two_spheres.md``).

State: unit vectors ``q`` (n, 3) (link ``i`` points from its joint to its outer end) and the
discrete angular momenta ``pi`` (n, 3), ``pi_i . q_i = 0``. Kinetic energy
``T = 1/2 sum_ij M_ij qdot_i . qdot_j``, potential ``U = -sum_i w_i g . q_i`` (uniform gravity
``g``). One step of size ``h`` of the discrete Lagrangian

    L_d = 1/(2h) sum_ij M_ij (q_i^+ - q_i) . (q_j^+ - q_j) - h/2 (U(q) + U(q^+))

is, with ``b_i = h pi_i + h^2/2 w_i q_i x g``:

    q_i x sum_j M_ij (q_j^+ - q_j) = b_i                 (implicit: 2n equations for q^+)
    pi_i^+ = q_i^+ x (1/h sum_j M_ij (q_j^+ - q_j) + h/2 w_i g)

The implicit equations are solved by Newton's method on the spheres: each ``q_j^+`` is moved by
a rotation, ``q_j^+ <- exp(hat(d_j)) q_j^+`` (so it stays a unit vector), with ``d`` from the
linear system of 3x3 blocks ``m_ij ((q_i . q_j^+) I - q_j^+ q_i^T)`` (``m_ij = M_ij / M_ii``) plus
``q_i q_i^{+T}`` on the diagonal, whose rows along ``q_i`` force ``d_i . q_i^+ = 0``. The matrix is
factored once a step (at the first guess) and kept while the residual falls fast (a chord
iteration); the first guess continues the previous (sub)step's rotation of each link, divided by
its length (extrapolating ``2 (q . q_prev) q - q_prev`` multiplies an error of ``|q|`` by about 4
a step; the unit guess carries none over, and the rotations of Newton's updates keep it unit).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .codes import NOT_CONVERGED, NOT_FINITE, OK, SINGULAR


@jit
def lu_factor(A, piv, m):
    """In-place LU factorisation with partial pivoting of ``A[:m, :m]``; False if singular."""
    for c in range(m):
        p = c
        big = abs(A[c, c])
        for r in range(c + 1, m):
            v = abs(A[r, c])
            if v > big:
                big = v
                p = r
        if not big > 0.0:
            return False
        piv[c] = p
        if p != c:
            for s in range(m):
                tmp = A[c, s]
                A[c, s] = A[p, s]
                A[p, s] = tmp
        inv = 1.0 / A[c, c]
        for r in range(c + 1, m):
            f = A[r, c] * inv
            A[r, c] = f
            if f != 0.0:
                for s in range(c + 1, m):
                    A[r, s] -= f * A[c, s]
    return True


@jit
def lu_solve(A, piv, b, m):
    """Solve ``A x = b`` in place in ``b`` with the factors of :func:`lu_factor`."""
    for c in range(m):
        p = piv[c]
        if p != c:
            tmp = b[c]
            b[c] = b[p]
            b[p] = tmp
    for r in range(1, m):
        s = b[r]
        for c in range(r):
            s -= A[r, c] * b[c]
        b[r] = s
    for r in range(m - 1, -1, -1):
        s = b[r]
        for c in range(r + 1, m):
            s -= A[r, c] * b[c]
        b[r] = s / A[r, r]


@jit(inline="always")
def turn(d0, d1, d2, x0, x1, x2):
    """``exp(hat(d)) x - x`` (Rodrigues), computed to the relative precision of ``|d|``."""
    t2 = d0 * d0 + d1 * d1 + d2 * d2
    if t2 < 1e-8:
        a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0)
        b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0)
    else:
        t = math.sqrt(t2)
        a = math.sin(t) / t
        b = (1.0 - math.cos(t)) / t2
    c0 = d1 * x2 - d2 * x1
    c1 = d2 * x0 - d0 * x2
    c2 = d0 * x1 - d1 * x0
    e0 = d1 * c2 - d2 * c1
    e1 = d2 * c0 - d0 * c2
    e2 = d0 * c1 - d1 * c0
    return a * c0 + b * e0, a * c1 + b * e1, a * c2 + b * e2


@jit
def chain_residual(Mn, q, D, B, r, n):
    """``r_i = q_i x sum_j m_ij D_j - B_i`` (``m = M / diag(M)``, ``B = b / diag(M)``, ``D = q^+ - q``)
    into ``r`` (3n,); returns its largest magnitude."""
    big = 0.0
    for i in range(n):
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for j in range(n):
            m = Mn[i, j]
            s0 += m * D[j, 0]
            s1 += m * D[j, 1]
            s2 += m * D[j, 2]
        r0 = q[i, 1] * s2 - q[i, 2] * s1 - B[i, 0]
        r1 = q[i, 2] * s0 - q[i, 0] * s2 - B[i, 1]
        r2 = q[i, 0] * s1 - q[i, 1] * s0 - B[i, 2]
        r[3 * i] = r0
        r[3 * i + 1] = r1
        r[3 * i + 2] = r2
        big = max(big, abs(r0), abs(r1), abs(r2))
    return big


@jit
def chain_jacobian(Mn, q, D, A, n):
    """The Newton matrix (3n, 3n) at ``X = q + D``: blocks ``m_ij ((q_i . X_j) I - X_j q_i^T)``, plus
    ``q_i X_i^T`` on the diagonal (see the module notes)."""
    for i in range(n):
        for j in range(n):
            m = Mn[i, j]
            x0 = q[j, 0] + D[j, 0]
            x1 = q[j, 1] + D[j, 1]
            x2 = q[j, 2] + D[j, 2]
            c = m * (q[i, 0] * x0 + q[i, 1] * x1 + q[i, 2] * x2)
            A[3 * i, 3 * j] = c - m * x0 * q[i, 0]
            A[3 * i, 3 * j + 1] = -m * x0 * q[i, 1]
            A[3 * i, 3 * j + 2] = -m * x0 * q[i, 2]
            A[3 * i + 1, 3 * j] = -m * x1 * q[i, 0]
            A[3 * i + 1, 3 * j + 1] = c - m * x1 * q[i, 1]
            A[3 * i + 1, 3 * j + 2] = -m * x1 * q[i, 2]
            A[3 * i + 2, 3 * j] = -m * x2 * q[i, 0]
            A[3 * i + 2, 3 * j + 1] = -m * x2 * q[i, 1]
            A[3 * i + 2, 3 * j + 2] = c - m * x2 * q[i, 2]
            if i == j:
                for a in range(3):
                    for b in range(3):
                        A[3 * i + a, 3 * i + b] += q[i, a] * (q[i, b] + D[i, b])


@jit
def chain_substep(M, Mn, w, g, h, q, pi, dprev, hprev, D, B, A, piv, r, tol, max_iter):
    """One step of size ``h`` (module notes): ``q`` and ``pi`` updated in place, ``dprev`` gets the
    step's ``q^+ - q``; ``hprev[0]`` is the size of the step that led to ``q`` (0: none, no history
    to continue). The unknown is ``D = q^+ - q``, built from rotations and kept to the relative
    precision of the turn (``q^+ - q`` rounded would lose it: ``pi^+`` divides ``D`` by ``h``).
    Returns ``(status, iterations, residual)``, the residual relative to the size of its terms."""
    n = q.shape[0]
    m3 = 3 * n
    hh = 0.5 * h
    # right-hand side, scaled by 1 / M_ii
    for i in range(n):
        c = h * hh * w[i]
        B[i, 0] = (h * pi[i, 0] + c * (q[i, 1] * g[2] - q[i, 2] * g[1])) / M[i, i]
        B[i, 1] = (h * pi[i, 1] + c * (q[i, 2] * g[0] - q[i, 0] * g[2])) / M[i, i]
        B[i, 2] = (h * pi[i, 2] + c * (q[i, 0] * g[1] - q[i, 1] * g[0])) / M[i, i]
        # pi_i . q_i is zero but for the solve's residual of the last step (see the momenta below):
        # the left-hand side has no part along q_i, so the equation drops it
        c = B[i, 0] * q[i, 0] + B[i, 1] * q[i, 1] + B[i, 2] * q[i, 2]
        B[i, 0] -= c * q[i, 0]
        B[i, 1] -= c * q[i, 1]
        B[i, 2] -= c * q[i, 2]
    # first guess: each link turns as in the last (sub)step, scaled to this one (rotation from
    # q_prev = q - dprev to q: e = q_prev x dprev = q x dprev = sin(theta) axis,
    # cos(theta) - 1 = q_prev . dprev = -|dprev|^2 / 2)
    ratio = h / hprev[0] if hprev[0] != 0.0 else 0.0
    for i in range(n):
        p0 = dprev[i, 0]
        p1 = dprev[i, 1]
        p2 = dprev[i, 2]
        e0 = q[i, 1] * p2 - q[i, 2] * p1
        e1 = q[i, 2] * p0 - q[i, 0] * p2
        e2 = q[i, 0] * p1 - q[i, 1] * p0
        if ratio == 1.0:
            cm = -0.5 * (p0 * p0 + p1 * p1 + p2 * p2)
            D[i, 0] = cm * q[i, 0] + e1 * q[i, 2] - e2 * q[i, 1]
            D[i, 1] = cm * q[i, 1] + e2 * q[i, 0] - e0 * q[i, 2]
            D[i, 2] = cm * q[i, 2] + e0 * q[i, 1] - e1 * q[i, 0]
        else:
            s = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            f = 0.0
            if ratio != 0.0 and s > 0.0:
                f = math.atan2(s, 1.0 - 0.5 * (p0 * p0 + p1 * p1 + p2 * p2)) * ratio / s
            D[i, 0], D[i, 1], D[i, 2] = turn(f * e0, f * e1, f * e2, q[i, 0], q[i, 1], q[i, 2])
    # the size of the terms of the residual (its round-off floor is relative to it): the right-hand
    # side and the first guess's turn of every link, times the largest coupling row
    scale = 0.0
    size = 0.0
    for i in range(n):
        scale = max(scale, abs(B[i, 0]), abs(B[i, 1]), abs(B[i, 2]))
        size = max(size, abs(D[i, 0]), abs(D[i, 1]), abs(D[i, 2]))
    row = 0.0
    for i in range(n):
        s0 = 0.0
        for j in range(n):
            s0 += abs(Mn[i, j])
        row = max(row, s0)
    scale = max(scale, row * size)
    if scale == 0.0:
        scale = 1.0
    tol = tol * scale
    res = chain_residual(Mn, q, D, B, r, n)
    its = 0
    last = math.inf
    while res > tol:
        if its > 0 and res > 0.25 * last and res <= 64.0 * tol:
            break                              # the round-off floor, just above tol
        if its >= max_iter or not math.isfinite(res):
            return (NOT_CONVERGED if math.isfinite(res) else NOT_FINITE), its, res / scale
        if its == 0 or res > 0.125 * last:     # (re)factor; else keep the factors (chord iteration)
            chain_jacobian(Mn, q, D, A, n)
            if not lu_factor(A, piv, m3):
                return SINGULAR, its, res / scale
        for a in range(m3):
            r[a] = -r[a]
        lu_solve(A, piv, r, m3)
        for j in range(n):
            t0, t1, t2 = turn(r[3 * j], r[3 * j + 1], r[3 * j + 2], q[j, 0] + D[j, 0], q[j, 1] + D[j, 1],
                              q[j, 2] + D[j, 2])
            D[j, 0] += t0
            D[j, 1] += t1
            D[j, 2] += t2
        last = res
        res = chain_residual(Mn, q, D, B, r, n)
        its += 1
    # new momenta: pi_i^+ = q_i^+ x p_i, p_i = 1/h sum_j M_ij D_j + h/2 w_i g, written with the
    # implicit equation (q_i x (1/h sum_j M_ij D_j) = pi_i + h/2 w_i q_i x g) as
    #     pi_i^+ = pi_i + h w_i q_i x g + D_i x p_i,
    # the same numbers when the equation holds exactly; the sum over the links of the last term,
    # 1/h sum_ij M_ij D_i x D_j + h/2 sum_i w_i D_i x g, has no part along g whatever the solve's
    # residual, so sum_i pi_i . g changes only by round-off
    ih = 1.0 / h
    fin = 0.0
    for i in range(n):
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for j in range(n):
            m = M[i, j]
            s0 += m * D[j, 0]
            s1 += m * D[j, 1]
            s2 += m * D[j, 2]
        c = hh * w[i]
        s0 = s0 * ih + c * g[0]
        s1 = s1 * ih + c * g[1]
        s2 = s2 * ih + c * g[2]
        c = h * w[i]
        B[i, 0] = pi[i, 0] + c * (q[i, 1] * g[2] - q[i, 2] * g[1]) + (D[i, 1] * s2 - D[i, 2] * s1)
        B[i, 1] = pi[i, 1] + c * (q[i, 2] * g[0] - q[i, 0] * g[2]) + (D[i, 2] * s0 - D[i, 0] * s2)
        B[i, 2] = pi[i, 2] + c * (q[i, 0] * g[1] - q[i, 1] * g[0]) + (D[i, 0] * s1 - D[i, 1] * s0)
        fin += B[i, 0] + B[i, 1] + B[i, 2] + D[i, 0] + D[i, 1] + D[i, 2]
    if not math.isfinite(fin):
        return NOT_FINITE, its, res / scale
    for i in range(n):
        x0 = q[i, 0] + D[i, 0]
        x1 = q[i, 1] + D[i, 1]
        x2 = q[i, 2] + D[i, 2]
        c = 1.0 / math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)   # |x| = 1 but for the rounding of the sum
        q[i, 0] = x0 * c
        q[i, 1] = x1 * c
        q[i, 2] = x2 * c
        for a in range(3):
            pi[i, a] = B[i, a]
            dprev[i, a] = D[i, a]
    hprev[0] = h
    return OK, its, res / scale


@jit
def run_chain(M, w, g, gam, h, q, pi, dprev, hprev, k0, n_steps, tol, max_iter, save_every, q_out, pi_out,
              it_out, res_out, last):
    """``n_steps`` steps from step ``k0``: each the composition of substeps ``gam[s] h`` (``gam =
    (1,)``: the second-order step). Every ``save_every`` steps the state goes to ``q_out``,
    ``pi_out`` (row ``j``) and the largest iterations and residual of the interval to ``it_out``,
    ``res_out``. ``last`` (2,) gets the iterations and residual of the last substep.
    Returns ``(status, steps done from k0)``."""
    n = q.shape[0]
    Mn = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            Mn[i, j] = M[i, j] / M[i, i]
    D = np.empty((n, 3))
    B = np.empty((n, 3))
    A = np.empty((3 * n, 3 * n))
    piv = np.zeros(3 * n, dtype=np.int64)
    r = np.empty(3 * n)
    j = 0
    its_max = 0
    res_max = 0.0
    countdown = save_every
    for s in range(n_steps):
        k = k0 + s
        for c in range(gam.shape[0]):
            st, its, res = chain_substep(M, Mn, w, g, gam[c] * h, q, pi, dprev, hprev, D, B, A, piv, r, tol,
                                         max_iter)
            last[0] = its
            last[1] = res
            if st != OK:
                return st, k
            if its > its_max:
                its_max = its
            if res > res_max:
                res_max = res
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            for i in range(n):
                for a in range(3):
                    q_out[j, i, a] = q[i, a]
                    pi_out[j, i, a] = pi[i, a]
            it_out[j] = its_max
            res_out[j] = res_max
            its_max = 0
            res_max = 0.0
            j += 1
    return OK, k0 + n_steps


__all__ = ["chain_jacobian", "chain_residual", "chain_substep", "lu_factor", "lu_solve", "run_chain", "turn"]
