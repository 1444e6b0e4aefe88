"""Newton-type solvers for the implicit equation ``hat(hPi) = F Jd - Jd F^T`` (paper, section 4).

Each solver works on a coordinate vector ``g`` of the unknown ``F`` (updated in place, so the
caller can warm start the next solve from it) and leaves ``E = F - I`` in a caller array.
Keeping ``F - I`` rather than ``F`` lets the residual be evaluated without cancellation, so the
relative stopping rule works for ``|h Pi|`` from 1e-8 to 1e3.

Methods (integer codes, shared with :mod:`lgvi.implicit`):

``METHOD_PAPER``  (0)  ``g = w``, ``F = exp(hat w)``; the paper's additive update
                       ``w <- w - alpha Df(w)^-1 f(w)`` with the paper's ``Df``, whose columns
                       are ``vee(e^w E_i Jd + Jd E_i e^-w)`` = ``(tr(A) I - A) F`` with
                       ``A = F Jd``. That ``Df`` is exact for ``F <- F exp(hat d)``, not for the
                       additive update, so the iteration converges linearly.
``METHOD_NEWTON`` (1)  ``g = w``; exact Newton: the true derivative of ``f(w)`` is
                       ``(tr(A) I - A) Jl(w)`` (``Jl`` the left Jacobian of ``exp``), because a
                       left update ``F <- exp(hat d) F`` changes ``f`` by ``(tr(A) I - A) d``.
``METHOD_CAYLEY`` (2)  ``g = f``, ``F = (I + hat f)(I - hat f)^-1``; Newton on Lee's equivalent
                       form ``G(f) = hPi + hPi x f + (hPi . f) f - 2 J f = 0`` with
                       ``DG = hat(hPi) + (hPi . f) I + f hPi^T - 2 J``. No trigonometry.

Stopping rule (all methods): with ``r = vee(E Jd - Jd E^T) - hPi`` the residual of the paper's
``f``, stop when ``|r| <= tol |hPi| + 8 eps (|Jd| |E| + |hPi|)``: ``tol`` is relative to the
size of the right-hand side, and the second term is the round-off floor of evaluating ``r``.

Status codes: ``OK`` (0), ``NOT_CONVERGED`` (1, ``max_iter`` updates did not reach the
tolerance), ``NOT_FINITE`` (2, the iterate or the residual became NaN/inf), ``SINGULAR`` (3, the
Newton matrix was singular).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .so3k import (
    cayley_minus_identity,
    expm1_from_coeffs,
    left_jacobian_from_coeffs,
    matmul3,
    rodrigues_coeffs,
    solve3,
)

METHOD_PAPER = 0
METHOD_NEWTON = 1
METHOD_CAYLEY = 2

OK = 0
NOT_CONVERGED = 1
NOT_FINITE = 2
SINGULAR = 3

EPS = 2.220446049250313e-16


@jit
def residual(E, Jd, hPi, r):
    """r = vee(E Jd - Jd E^T) - hPi (E = F - I; ``F Jd - Jd F^T = E Jd - Jd E^T``)."""
    # vee(X - X^T) with X = E Jd needs only the off-diagonal entries of X.
    x21 = E[2, 0] * Jd[0, 1] + E[2, 1] * Jd[1, 1] + E[2, 2] * Jd[2, 1]
    x12 = E[1, 0] * Jd[0, 2] + E[1, 1] * Jd[1, 2] + E[1, 2] * Jd[2, 2]
    x02 = E[0, 0] * Jd[0, 2] + E[0, 1] * Jd[1, 2] + E[0, 2] * Jd[2, 2]
    x20 = E[2, 0] * Jd[0, 0] + E[2, 1] * Jd[1, 0] + E[2, 2] * Jd[2, 0]
    x10 = E[1, 0] * Jd[0, 0] + E[1, 1] * Jd[1, 0] + E[1, 2] * Jd[2, 0]
    x01 = E[0, 0] * Jd[0, 1] + E[0, 1] * Jd[1, 1] + E[0, 2] * Jd[2, 1]
    r[0] = (x21 - x12) - hPi[0]
    r[1] = (x02 - x20) - hPi[1]
    r[2] = (x10 - x01) - hPi[2]
    return math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])


@jit
def frob3(A):
    s = 0.0
    for i in range(3):
        for j in range(3):
            s += A[i, j] * A[i, j]
    return math.sqrt(s)


@jit
def newton_matrix(E, Jd, M):
    """M = tr(A) I - A with A = F Jd = Jd + E Jd."""
    matmul3(E, Jd, M)
    for i in range(3):
        for j in range(3):
            M[i, j] = -(M[i, j] + Jd[i, j])
    tr = -(M[0, 0] + M[1, 1] + M[2, 2])
    for i in range(3):
        M[i, i] += tr


@jit
def solve_implicit_kernel(method, Jd, J, hPi, g, tol, max_iter, alpha, E, work, hist):
    """Solve ``hat(hPi) = F Jd - Jd F^T``; see the module docstring.

    Parameters
    ----------
    method : int
        ``METHOD_PAPER``, ``METHOD_NEWTON`` or ``METHOD_CAYLEY``.
    Jd, J : (3, 3) float64
        Nonstandard and standard inertia (``J = tr(Jd) I - Jd``).
    hPi : (3,) float64
    g : (3,) float64, in/out
        Initial coordinates of ``F`` on entry, converged coordinates on exit.
    tol : float
    max_iter : int
    alpha : float
        Step length of the update (1 for full Newton steps).
    E : (3, 3) float64, out
        ``F - I`` of the last iterate.
    work : (4, 3, 3) float64
        Scratch space.
    hist : (n,) float64
        Residual history ``|r|`` per iterate (entries ``0..iterations``); pass ``n = 0`` to skip.

    Returns
    -------
    iterations : int
        Number of updates applied.
    rnorm : float
        ``|r|`` of the returned ``E``.
    status : int
    """
    M = work[0]
    B = work[1]
    Jl = work[2]
    r = work[3, 0]
    x = work[3, 1]
    nhist = hist.shape[0]
    hnorm = math.sqrt(hPi[0] * hPi[0] + hPi[1] * hPi[1] + hPi[2] * hPi[2])
    jdnorm = frob3(Jd)
    it = 0
    while True:
        if method == METHOD_CAYLEY:
            cayley_minus_identity(g, E)
            b = 0.0
            c = 0.0
        else:
            a, b, c = rodrigues_coeffs(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
            expm1_from_coeffs(g, a, b, E)
        rn = residual(E, Jd, hPi, r)
        if it < nhist:
            hist[it] = rn
        if not math.isfinite(rn):
            return it, rn, NOT_FINITE
        if rn <= tol * hnorm + 8.0 * EPS * (jdnorm * frob3(E) + hnorm):
            return it, rn, OK
        if it >= max_iter:
            return it, rn, NOT_CONVERGED
        if method == METHOD_CAYLEY:
            # Lee's G(f) and its Jacobian
            f0 = g[0]
            f1 = g[1]
            f2 = g[2]
            p0 = hPi[0]
            p1 = hPi[1]
            p2 = hPi[2]
            pf = p0 * f0 + p1 * f1 + p2 * f2
            Jf0 = J[0, 0] * f0 + J[0, 1] * f1 + J[0, 2] * f2
            Jf1 = J[1, 0] * f0 + J[1, 1] * f1 + J[1, 2] * f2
            Jf2 = J[2, 0] * f0 + J[2, 1] * f1 + J[2, 2] * f2
            r[0] = -(p0 + (p1 * f2 - p2 * f1) + pf * f0 - 2.0 * Jf0)
            r[1] = -(p1 + (p2 * f0 - p0 * f2) + pf * f1 - 2.0 * Jf1)
            r[2] = -(p2 + (p0 * f1 - p1 * f0) + pf * f2 - 2.0 * Jf2)
            M[0, 0] = pf + f0 * p0 - 2.0 * J[0, 0]
            M[0, 1] = -p2 + f0 * p1 - 2.0 * J[0, 1]
            M[0, 2] = p1 + f0 * p2 - 2.0 * J[0, 2]
            M[1, 0] = p2 + f1 * p0 - 2.0 * J[1, 0]
            M[1, 1] = pf + f1 * p1 - 2.0 * J[1, 1]
            M[1, 2] = -p0 + f1 * p2 - 2.0 * J[1, 2]
            M[2, 0] = -p1 + f2 * p0 - 2.0 * J[2, 0]
            M[2, 1] = p0 + f2 * p1 - 2.0 * J[2, 1]
            M[2, 2] = pf + f2 * p2 - 2.0 * J[2, 2]
            if solve3(M, r, x) == 0.0:
                return it, rn, SINGULAR
        else:
            newton_matrix(E, Jd, M)
            if method == METHOD_PAPER:
                # paper's Df = (tr(A) I - A) F, F = I + E
                matmul3(M, E, B)
                for i in range(3):
                    for j in range(3):
                        B[i, j] += M[i, j]
            else:
                left_jacobian_from_coeffs(g, b, c, Jl)
                matmul3(M, Jl, B)
            for i in range(3):
                r[i] = -r[i]
            if solve3(B, r, x) == 0.0:
                return it, rn, SINGULAR
        g[0] += alpha * x[0]
        g[1] += alpha * x[1]
        g[2] += alpha * x[2]
        it += 1


@jit
def initial_guess(method, J, hPi, g):
    """Cold start from the linearisation ``hPi = J w`` (``w = 2 f`` for Cayley)."""
    M = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            M[i, j] = J[i, j]
    solve3(M, hPi, g)
    if method == METHOD_CAYLEY:
        for i in range(3):
            g[i] *= 0.5
