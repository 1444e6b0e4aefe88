"""Stepping loops of the attitude LGVI (paper, section 3), compiled.

One step with body-frame moment ``u_k`` (the paper's equation):

    hat(h Pi_k) = F_k Jd - Jd F_k^T      (solved by :mod:`.solvers`)
    R_{k+1}     = R_k F_k
    Pi_{k+1}    = F_k^T Pi_k + h u_k

The state ``R`` (3,3), ``Pi`` (3,) and the solver coordinates ``g`` (3,) are updated in place,
so the Python layer can run a long simulation as a sequence of chunks.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit
from .solvers import OK, solve_implicit_kernel


@jit
def advance(R, Pi, E, h, u0, u1, u2, Rn, Pin):
    """Rn = R (I + E), Pin = (I + E)^T Pi + h u. Rn, Pin may not alias R, Pi."""
    for i in range(3):
        for j in range(3):
            Rn[i, j] = R[i, j] + R[i, 0] * E[0, j] + R[i, 1] * E[1, j] + R[i, 2] * E[2, j]
    p0 = Pi[0]
    p1 = Pi[1]
    p2 = Pi[2]
    Pin[0] = p0 + E[0, 0] * p0 + E[1, 0] * p1 + E[2, 0] * p2 + h * u0
    Pin[1] = p1 + E[0, 1] * p0 + E[1, 1] * p1 + E[2, 1] * p2 + h * u1
    Pin[2] = p2 + E[0, 2] * p0 + E[1, 2] * p1 + E[2, 2] * p2 + h * u2


@jit
def run_chunk(method, Jd, J, h, R, Pi, g, U, k0, n, tol, max_iter, alpha, save_every,
              R_out, Pi_out, it_out, res_out):
    """Advance ``n`` steps ``k0 .. k0+n-1`` with moments ``U`` (``U.shape[0] == 0``: free body).

    Samples are saved after step ``k`` when ``(k + 1) % save_every == 0``, at index
    ``(k + 1) // save_every`` of ``R_out``/``Pi_out``; ``it_out[k]``, ``res_out[k]`` record the
    solver's iterations and final residual for every step.

    Returns ``(status, k)``: ``status`` is ``OK`` and ``k = k0 + n`` on success; otherwise the
    solver status of the failed step ``k``, with ``R, Pi`` still the state before that step.
    """
    E = np.zeros((3, 3))
    work = np.zeros((4, 3, 3))
    hist = np.zeros(0)
    hPi = np.zeros(3)
    Rn = np.zeros((3, 3))
    Pin = np.zeros(3)
    has_u = U.shape[0] > 0
    for k in range(k0, k0 + n):
        hPi[0] = h * Pi[0]
        hPi[1] = h * Pi[1]
        hPi[2] = h * Pi[2]
        its, rn, st = solve_implicit_kernel(method, Jd, J, hPi, g, tol, max_iter, alpha, E, work, hist)
        it_out[k] = its
        res_out[k] = rn
        if st != OK:
            return st, k
        if has_u:
            advance(R, Pi, E, h, U[k, 0], U[k, 1], U[k, 2], Rn, Pin)
        else:
            advance(R, Pi, E, h, 0.0, 0.0, 0.0, Rn, Pin)
        R[:, :] = Rn
        Pi[:] = Pin
        if (k + 1) % save_every == 0:
            j = (k + 1) // save_every
            R_out[j] = R
            Pi_out[j] = Pi
    return OK, k0 + n


@jit
def one_step(method, Jd, J, h, R, Pi, g, u, tol, max_iter, alpha, Rn, Pin, E, work):
    """One step from ``(R, Pi)`` with moment ``u`` (3,) into ``(Rn, Pin)``; returns (its, res, status)."""
    hPi = np.empty(3)
    hPi[0] = h * Pi[0]
    hPi[1] = h * Pi[1]
    hPi[2] = h * Pi[2]
    hist = np.zeros(0)
    its, rn, st = solve_implicit_kernel(method, Jd, J, hPi, g, tol, max_iter, alpha, E, work, hist)
    if st == OK:
        advance(R, Pi, E, h, u[0], u[1], u[2], Rn, Pin)
    return its, rn, st
