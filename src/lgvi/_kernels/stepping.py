"""Stepping loops of the attitude LGVI (paper, section 3), compiled.

One step with body-frame moment ``u_k`` (the paper's equation):

    hat(h Pi_k) = F_k Jd - Jd F_k^T      (solved by :func:`.solvers.solve_scalar`)
    R_{k+1}     = R_k F_k
    Pi_{k+1}    = F_k^T Pi_k + h u_k

The state is carried in arrays updated in place, so the Python layer can run a long simulation
as a sequence of chunks that continue exactly where the previous one stopped:

``R`` (3,3), ``Pi`` (3,), and the solver history ``G`` (4,3): rows 0-2 hold the coordinates of
the last three solutions (row 0 the newest) and ``G[3, 0]`` how many of them are valid. The next
solve starts from the quadratic extrapolation ``3 G0 - 3 G1 + G2`` (linear with two, ``G0`` with
fewer): the coordinates of ``F_k`` vary smoothly with ``k``, so the guess is O(h^3) off and one
Newton update usually reaches 1e-14. The guess only changes the iteration count, never the
converged result beyond the tolerance.
"""

from __future__ import annotations

from .._jit import jit
from .solvers import OK, solve_scalar


@jit
def predict(G):
    """Initial coordinates for the next solve from the history ``G`` (see the module notes)."""
    n = G[3, 0]
    if n >= 3.0:
        return (3.0 * (G[0, 0] - G[1, 0]) + G[2, 0], 3.0 * (G[0, 1] - G[1, 1]) + G[2, 1],
                3.0 * (G[0, 2] - G[1, 2]) + G[2, 2])
    if n >= 2.0:
        return 2.0 * G[0, 0] - G[1, 0], 2.0 * G[0, 1] - G[1, 1], 2.0 * G[0, 2] - G[1, 2]
    return G[0, 0], G[0, 1], G[0, 2]


@jit
def push(G, g0, g1, g2):
    """Record a converged solution in the history ``G``."""
    for i in range(2, 0, -1):
        G[i, 0] = G[i - 1, 0]
        G[i, 1] = G[i - 1, 1]
        G[i, 2] = G[i - 1, 2]
    G[0, 0] = g0
    G[0, 1] = g1
    G[0, 2] = g2
    if G[3, 0] < 3.0:
        G[3, 0] += 1.0


@jit
def lgvi_step(method, Jd, h, R, Pi, G, u0, u1, u2, tol, max_iter, alpha, hist):
    """One step in place on ``R``, ``Pi``, ``G``; returns ``(iterations, residual, status)``.

    On failure the state is left unchanged.
    """
    p0 = h * Pi[0]
    p1 = h * Pi[1]
    p2 = h * Pi[2]
    q0, q1, q2 = predict(G)
    (g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, its, rn,
     st) = solve_scalar(method, Jd[0, 0], Jd[0, 1], Jd[0, 2], Jd[1, 1], Jd[1, 2], Jd[2, 2],
                        p0, p1, p2, q0, q1, q2, tol, max_iter, alpha, hist)
    if st != OK:
        return its, rn, st
    push(G, g0, g1, g2)
    # R <- R (I + E)
    for i in range(3):
        a0 = R[i, 0]
        a1 = R[i, 1]
        a2 = R[i, 2]
        R[i, 0] = a0 + a0 * E00 + a1 * E10 + a2 * E20
        R[i, 1] = a1 + a0 * E01 + a1 * E11 + a2 * E21
        R[i, 2] = a2 + a0 * E02 + a1 * E12 + a2 * E22
    # Pi <- (I + E)^T Pi + h u
    b0 = Pi[0]
    b1 = Pi[1]
    b2 = Pi[2]
    Pi[0] = b0 + (E00 * b0 + E10 * b1 + E20 * b2) + h * u0
    Pi[1] = b1 + (E01 * b0 + E11 * b1 + E21 * b2) + h * u1
    Pi[2] = b2 + (E02 * b0 + E12 * b1 + E22 * b2) + h * u2
    return its, rn, st


@jit
def run_chunk(method, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every,
              R_out, Pi_out, it_out, res_out, hist):
    """Advance ``n`` steps ``k0 .. k0+n-1`` with moments ``U`` (``U.shape[0] == 0``: free body).

    Samples are saved after step ``k`` when ``(k + 1) % save_every == 0``, at index
    ``(k + 1) // save_every`` of ``R_out``/``Pi_out``; ``it_out[k]``, ``res_out[k]`` record the
    solver's iterations and final residual of every step. ``hist`` is an empty float64 array.

    Returns ``(status, k)``: ``OK`` and ``k = k0 + n`` on success; otherwise the solver status of
    the failed step ``k``, with ``R, Pi`` the state before that step.
    """
    has_u = U.shape[0] > 0
    u0 = 0.0
    u1 = 0.0
    u2 = 0.0
    for k in range(k0, k0 + n):
        if has_u:
            u0 = U[k, 0]
            u1 = U[k, 1]
            u2 = U[k, 2]
        its, rn, st = lgvi_step(method, Jd, h, R, Pi, G, u0, u1, u2, tol, max_iter, alpha, hist)
        it_out[k] = its
        res_out[k] = rn
        if st != OK:
            return st, k
        if (k + 1) % save_every == 0:
            j = (k + 1) // save_every
            for a in range(3):
                Pi_out[j, a] = Pi[a]
                for b in range(3):
                    R_out[j, a, b] = R[a, b]
    return OK, k0 + n
