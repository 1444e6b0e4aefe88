r"""Compiled steps of a chain of spherical pendulums on ``(S^2)^n`` (see ``docs/two_spheres.md``).

State: unit vectors ``q`` (n, 3) (link ``i`` points from its joint to its outer end) and the
discrete angular momenta ``pi`` (n, 3), ``pi_i . q_i = 0``. Kinetic energy
``T = 1/2 sum_ij M_ij qdot_i . qdot_j``, potential ``U = -sum_i w_i g . q_i`` (uniform gravity
``g``). One step of size ``h`` of the discrete Lagrangian

    L_d = 1/(2h) sum_ij M_ij (q_i^+ - q_i) . (q_j^+ - q_j) - h/2 (U(q) + U(q^+))

is, with ``b_i = h pi_i + h^2/2 w_i q_i x g``:

    q_i x sum_j M_ij (q_j^+ - q_j) = b_i                 (implicit: 2n equations for q^+)
    pi_i^+ = q_i^+ x (1/h sum_j M_ij (q_j^+ - q_j) + h/2 w_i g)

The implicit equation is solved exactly for its tangent part: ``q_i x v = c_i`` (``c_i`` the part of
``b_i`` across ``q_i``) holds if and only if ``v = c_i x q_i + lambda_i q_i`` for some number
``lambda_i``, so ``sum_j M_ij D_j = y_i + lambda_i q_i`` with ``D = q^+ - q`` and ``y_i = c_i x q_i``:

    D_j = sum_i Minv_ji (y_i + lambda_i q_i),

and the ``n`` numbers ``lambda`` are fixed by ``|q_j + D_j| = 1``, written without cancellation as
``F_j = q_j . D_j + |D_j|^2 / 2 = 0``: Newton's method on ``n`` unknowns, the matrix
``dF_j / dlambda_i = Minv_ji (q_j + D_j) . q_i`` (factored at the first iterate and kept while the
residual falls fast). It starts from ``lambda`` of the last steps extrapolated, and the root it
finds is the one near ``q^+ = q`` (the other roots turn links by about pi in one step). ``q^+`` is
``q + D``, the rotation of ``q`` about ``q x D``, divided by its length (which is 1 but for the
residual and rounding); ``D`` is computed directly (a small vector to its own relative precision),
never as a difference of unit vectors, because ``pi^+`` divides it by ``h``. See
``docs/two_spheres.md``.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .codes import NOT_CONVERGED, NOT_FINITE, OK, SINGULAR


@jit(inline="always")
def lu_factor(A, m):
    """In-place LU factorisation of ``A[:m, :m]`` without pivoting (the Newton matrix is near the
    Hadamard product of two positive definite matrices: its pivots are positive); False when a
    pivot is not."""
    for c in range(m):
        p = A[c, c]
        if not p > 0.0:
            return False
        inv = 1.0 / p
        for r in range(c + 1, m):
            f = A[r, c] * inv
            A[r, c] = f
            for s in range(c + 1, m):
                A[r, s] -= f * A[c, s]
    return True


@jit(inline="always")
def lu_solve(A, b, m):
    """Solve ``A x = b`` in place in ``b`` with the factors of :func:`lu_factor`."""
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
def newton_matrix(Minv, q, D, A, n):
    """Factor ``A_ji = dF_j / dlambda_i = Minv_ji (q_j + D_j) . q_i`` (False if singular)."""
    for j in range(n):
        x0 = q[j, 0] + D[j, 0]
        x1 = q[j, 1] + D[j, 1]
        x2 = q[j, 2] + D[j, 2]
        for i in range(n):
            A[j, i] = Minv[j, i] * (x0 * q[i, 0] + x1 * q[i, 1] + x2 * q[i, 2])
    return lu_factor(A, n)


@jit(_nrt=False)
def chain_substep(M, Minv, w, g, h, q, pi, lam, D, Y, A, r, tol, max_iter):
    """One step of size ``h`` (module notes): ``q`` and ``pi`` updated in place; ``lam`` (n,) is the first
    guess of the multipliers ``lambda`` and gets their solution. ``D``, ``Y`` (n, 3), ``A`` (n, n), ``r`` (n,)
    are work arrays. Returns ``(status, iterations, residual)``, the residual
    ``max_j |q_j . D_j + |D_j|^2 / 2|`` relative to ``max_j |D_j|``."""
    n = q.shape[0]
    hh = 0.5 * h
    # y_i = c_i x q_i, c_i = b_i less its part along q_i (zero but for round-off)
    for i in range(n):
        c = h * hh * w[i]
        b0 = h * pi[i, 0] + c * (q[i, 1] * g[2] - q[i, 2] * g[1])
        b1 = h * pi[i, 1] + c * (q[i, 2] * g[0] - q[i, 0] * g[2])
        b2 = h * pi[i, 2] + c * (q[i, 0] * g[1] - q[i, 1] * g[0])
        c = b0 * q[i, 0] + b1 * q[i, 1] + b2 * q[i, 2]
        b0 -= c * q[i, 0]
        b1 -= c * q[i, 1]
        b2 -= c * q[i, 2]
        Y[i, 0] = b1 * q[i, 2] - b2 * q[i, 1]
        Y[i, 1] = b2 * q[i, 0] - b0 * q[i, 2]
        Y[i, 2] = b0 * q[i, 1] - b1 * q[i, 0]
    # D_j = sum_i Minv_ji (y_i + lambda_i q_i); after each Newton update of lambda it moves by
    # sum_i Minv_ji dlambda_i q_i
    for j in range(n):
        d0 = 0.0
        d1 = 0.0
        d2 = 0.0
        for i in range(n):
            m = Minv[j, i]
            li = lam[i]
            d0 += m * (Y[i, 0] + li * q[i, 0])
            d1 += m * (Y[i, 1] + li * q[i, 1])
            d2 += m * (Y[i, 2] + li * q[i, 2])
        D[j, 0] = d0
        D[j, 1] = d1
        D[j, 2] = d2
    its = 0
    last = math.inf
    while True:
        # F_j = q_j . D_j + |D_j|^2 / 2, relative to the largest component of D
        size = 0.0
        res = 0.0
        for j in range(n):
            d0 = D[j, 0]
            d1 = D[j, 1]
            d2 = D[j, 2]
            F = d0 * (q[j, 0] + 0.5 * d0) + d1 * (q[j, 1] + 0.5 * d1) + d2 * (q[j, 2] + 0.5 * d2)
            r[j] = -F
            size = max(size, abs(d0), abs(d1), abs(d2))
            res = max(res, abs(F))
        if not math.isfinite(res):
            return NOT_FINITE, its, res
        res = res / size if size > 0.0 else 0.0
        if res <= tol or (its > 0 and res > 0.25 * last and res <= 64.0 * tol):
            break                              # converged (or at the round-off floor, just above tol)
        if its >= max_iter:
            return NOT_CONVERGED, its, res
        # Newton: dF_j / dlambda_i = Minv_ji (q_j + D_j) . q_i; the first factors are kept while the
        # residual falls by 1e-6 an iteration (they change by the size of the first correction)
        if its == 0 or res > 1e-6 * last:
            if not newton_matrix(Minv, q, D, A, n):
                return SINGULAR, its, res
        lu_solve(A, r, n)
        for i in range(n):
            lam[i] += r[i]
        for j in range(n):
            d0 = 0.0
            d1 = 0.0
            d2 = 0.0
            for i in range(n):
                m = Minv[j, i] * r[i]
                d0 += m * q[i, 0]
                d1 += m * q[i, 1]
                d2 += m * q[i, 2]
            D[j, 0] += d0
            D[j, 1] += d1
            D[j, 2] += d2
        last = res
        its += 1
    # new momenta: pi_i^+ = q_i^+ x p_i, p_i = 1/h sum_j M_ij D_j + h/2 w_i g, written with
    # q_i x (sum_j M_ij D_j) = q_i x (y_i + lambda_i q_i) = c_i = h pi_i + h^2/2 w_i q_i x g as
    #     pi_i^+ = pi_i + h w_i q_i x g + D_i x p_i,
    # which sums D_i (small, exact to its own precision) instead of q_i^+ = q_i + D_i (rounded to
    # 1e-16, an error that p_i ~ pi / |q| would carry into the momenta every step). Summed over the
    # links, the last term 1/h sum_ij M_ij D_i x D_j + h/2 sum_i w_i D_i x g has no part along g,
    # so sum_i pi_i . g changes by round-off only.
    ih = 1.0 / h
    fin = 0.0
    for i in range(n):
        c = hh * w[i]
        li = lam[i]
        s0 = (Y[i, 0] + li * q[i, 0]) * ih + c * g[0]
        s1 = (Y[i, 1] + li * q[i, 1]) * ih + c * g[1]
        s2 = (Y[i, 2] + li * q[i, 2]) * ih + c * g[2]
        c = h * w[i]
        d0 = D[i, 0]
        d1 = D[i, 1]
        d2 = D[i, 2]
        Y[i, 0] = pi[i, 0] + c * (q[i, 1] * g[2] - q[i, 2] * g[1]) + (d1 * s2 - d2 * s1)  # Y is free now
        Y[i, 1] = pi[i, 1] + c * (q[i, 2] * g[0] - q[i, 0] * g[2]) + (d2 * s0 - d0 * s2)
        Y[i, 2] = pi[i, 2] + c * (q[i, 0] * g[1] - q[i, 1] * g[0]) + (d0 * s1 - d1 * s0)
        fin += Y[i, 0] + Y[i, 1] + Y[i, 2] + d0 + d1 + d2
    if not math.isfinite(fin):
        return NOT_FINITE, its, res
    for i in range(n):
        x0 = q[i, 0] + D[i, 0]
        x1 = q[i, 1] + D[i, 1]
        x2 = q[i, 2] + D[i, 2]
        c = 1.0 / math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)   # 1 but for the solve's residual and rounding
        q[i, 0] = x0 * c
        q[i, 1] = x1 * c
        q[i, 2] = x2 * c
        for a in range(3):
            pi[i, a] = Y[i, a]
    return OK, its, res


@jit(inline="always")
def first_guess(lam, hist, hh, c, cp, h, n):
    """The first guess of ``lambda`` (about ``h`` times a smooth function of time) for substep ``c``
    of size ``h`` into ``lam``: from ``hist[c]`` (4, n), its values at substep ``c`` of the last four
    steps, extrapolated (cubic) when those had this size (``hh[c]`` (4,) their sizes, 0: none);
    else the last solution (substep ``cp``, just before) scaled to this size; else 0."""
    if hh[c, 0] == h and hh[c, 1] == h and hh[c, 2] == h and hh[c, 3] == h:
        for i in range(n):
            lam[i] = 4.0 * (hist[c, 0, i] + hist[c, 2, i]) - 6.0 * hist[c, 1, i] - hist[c, 3, i]
    elif hh[cp, 0] != 0.0:
        ratio = h / hh[cp, 0]
        for i in range(n):
            lam[i] = hist[cp, 0, i] * ratio
    else:
        for i in range(n):
            lam[i] = 0.0


@jit(inline="always")
def push_history(lam, hist, hh, c, h, n):
    """Record the solution ``lam`` of substep ``c`` (size ``h``) as the newest of ``hist[c]``."""
    for a in range(3, 0, -1):
        hh[c, a] = hh[c, a - 1]
        for i in range(n):
            hist[c, a, i] = hist[c, a - 1, i]
    hh[c, 0] = h
    for i in range(n):
        hist[c, 0, i] = lam[i]


@jit(_nrt=False)
def run_chain(M, Minv, w, g, gam, h, q, pi, hist, hh, k0, n_steps, tol, max_iter, save_every, q_out, pi_out,
              it_out, res_out, last, D, Y, A, r, lam):
    """``n_steps`` steps from step ``k0``: each the composition of substeps ``gam[s] h`` (``gam =
    (1,)``: the second-order step). ``hist`` (S, 4, n) and ``hh`` (S, 4) are the multipliers of each
    substep over the last four steps and their sizes (:func:`first_guess`). Every ``save_every``
    steps the state goes to ``q_out``, ``pi_out`` (row ``j``) and the largest iterations and
    residual of the interval to ``it_out``, ``res_out``. ``last`` (2,) gets the iterations and
    residual of the last substep. ``D``, ``Y`` (n, 3), ``A`` (n, n), ``r``, ``lam`` (n,) are scratch,
    allocated by the run: the kernels are compiled without Numba's runtime (``_nrt=False``), so
    passing arrays between them costs no reference counting (a third of a 3-link step with it).
    Returns ``(status, steps done from k0)``."""
    n = q.shape[0]
    S = gam.shape[0]
    j = 0
    its_max = 0
    res_max = 0.0
    countdown = save_every
    for s in range(n_steps):
        k = k0 + s
        for c in range(S):
            hc = gam[c] * h
            first_guess(lam, hist, hh, c, (c - 1) % S, hc, n)
            st, its, res = chain_substep(M, Minv, w, g, hc, q, pi, lam, D, Y, A, r, tol, max_iter)
            last[0] = its
            last[1] = res
            if st != OK:
                return st, k
            push_history(lam, hist, hh, c, hc, n)
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


__all__ = ["chain_substep", "first_guess", "lu_factor", "lu_solve", "newton_matrix", "push_history", "run_chain"]
