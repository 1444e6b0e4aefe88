"""Stepping loops of the attitude LGVI (paper, section 3), compiled.

One step with body-frame moment ``u_k`` (the paper's equation):

    hat(h Pi_k) = F_k Jd - Jd F_k^T      (solved by :func:`.solvers.solve_scalar`)
    R_{k+1}     = R_k F_k
    Pi_{k+1}    = F_k^T Pi_k + h u_k

The state is carried in arrays updated in place, so the Python layer can run a long simulation
as a sequence of chunks that continue exactly where the previous one stopped:

``R`` (3,3), ``Pi`` (3,), and the solver history ``G`` (5,3): rows 0-2 hold the coordinates of
the last three solutions (row 0 the newest), ``G[3, 0]`` how many of them are valid, and row 4
the low part of ``Pi``: the momentum update of a step without moment is summed with
compensation (:func:`momentum_step`), ``Pi + G[4]`` carrying the rounding error of the last
addition to the next step, so the momentum (and with it ``|Pi|``, the energy and the phase) does
not random-walk by an ulp per step. The next
solve starts from the quadratic extrapolation ``3 G0 - 3 G1 + G2`` (linear with two, ``G0`` with
fewer): the coordinates of ``F_k`` vary smoothly with ``k``, so the guess is O(h^3) off and one
Newton update usually reaches 1e-14. The guess only changes the iteration count, never the
converged result beyond the tolerance.

The second half of this module (:func:`run_chunk_forced`) adds torque models given as data
(:mod:`.torque_kernels`), the symmetric forcing of Lee, Leok and McClamroch and symmetric
compositions of it; there ``G`` is a stack (m,5,3) with one history per substep.
"""

from __future__ import annotations

import math

from .._jit import jit
from .codes import OVERFLOW
from .solvers import METHOD_CAYLEY, METHOD_NEWTON, OK, solve_call, solve_scalar
from .torque_kernels import model_moments_call, momentum_diag


@jit(inline="always")
def extrapolate(n, a0, a1, a2, b0, b1, b2, c0, c1, c2):
    """Guess from the last three solutions ``a`` (newest), ``b``, ``c`` of which ``n`` are valid."""
    if n >= 3.0:
        return 3.0 * (a0 - b0) + c0, 3.0 * (a1 - b1) + c1, 3.0 * (a2 - b2) + c2
    if n >= 2.0:
        return 2.0 * a0 - b0, 2.0 * a1 - b1, 2.0 * a2 - b2
    return a0, a1, a2


@jit(inline="always")
def predict(G):
    """Initial coordinates for the next solve from the history ``G`` (see the module notes)."""
    return extrapolate(G[3, 0], G[0, 0], G[0, 1], G[0, 2], G[1, 0], G[1, 1], G[1, 2], G[2, 0], G[2, 1], G[2, 2])


@jit(inline="always")
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


@jit(inline="always")
def predict_at(G, j):
    """:func:`predict` for history ``G[j]`` of a stack ``G`` (m,5,3), without making a view."""
    return extrapolate(G[j, 3, 0], G[j, 0, 0], G[j, 0, 1], G[j, 0, 2], G[j, 1, 0], G[j, 1, 1], G[j, 1, 2],
                       G[j, 2, 0], G[j, 2, 1], G[j, 2, 2])


@jit(inline="always")
def push_at(G, j, g0, g1, g2):
    """:func:`push` for history ``G[j]`` of a stack ``G`` (m,5,3)."""
    for i in range(2, 0, -1):
        G[j, i, 0] = G[j, i - 1, 0]
        G[j, i, 1] = G[j, i - 1, 1]
        G[j, i, 2] = G[j, i - 1, 2]
    G[j, 0, 0] = g0
    G[j, 0, 1] = g1
    G[j, 0, 2] = g2
    if G[j, 3, 0] < 3.0:
        G[j, 3, 0] += 1.0


@jit(inline="always")
def rotated_row(a0, a1, a2, E00, E01, E02, E10, E11, E12, E20, E21, E22):
    """Row ``a (I + E)`` of the attitude update ``R_{k+1} = R_k F_k`` (``E = F_k - I``)."""
    return (a0 + a0 * E00 + a1 * E10 + a2 * E20, a1 + a0 * E01 + a1 * E11 + a2 * E21,
            a2 + a0 * E02 + a1 * E12 + a2 * E22)


@jit(inline="always")
def rotate(R, E00, E01, E02, E10, E11, E12, E20, E21, E22):
    """``R <- R (I + E)`` in place: the attitude update ``R_{k+1} = R_k F_k`` with ``E = F_k - I``."""
    for i in range(3):
        R[i, 0], R[i, 1], R[i, 2] = rotated_row(R[i, 0], R[i, 1], R[i, 2], E00, E01, E02, E10, E11, E12,
                                                E20, E21, E22)


@jit(inline="always")
def momentum(b0, b1, b2, E00, E01, E02, E10, E11, E12, E20, E21, E22, hu0, hu1, hu2):
    """``(I + E)^T Pi + h u``: the momentum update ``Pi_{k+1} = F_k^T Pi_k + h u_k``."""
    return (b0 + (E00 * b0 + E10 * b1 + E20 * b2) + hu0, b1 + (E01 * b0 + E11 * b1 + E21 * b2) + hu1,
            b2 + (E02 * b0 + E12 * b1 + E22 * b2) + hu2)


@jit(inline="always")
def momentum_c(b0, b1, b2, l0, l1, l2, E00, E01, E02, E10, E11, E12, E20, E21, E22, hu0, hu1, hu2):
    """:func:`momentum` with compensated summation: ``Pi + l`` (``l`` the low part carried between
    steps) maps to ``m + n``, ``m`` the rounded momentum and ``n`` its rounding error (Fast2Sum)."""
    d0 = ((E00 * b0 + E10 * b1 + E20 * b2) + hu0) + l0
    d1 = ((E01 * b0 + E11 * b1 + E21 * b2) + hu1) + l1
    d2 = ((E02 * b0 + E12 * b1 + E22 * b2) + hu2) + l2
    m0 = b0 + d0
    m1 = b1 + d1
    m2 = b2 + d2
    return m0, m1, m2, (b0 - m0) + d0, (b1 - m1) + d1, (b2 - m2) + d2


@jit(inline="always")
def momentum_step(b0, b1, b2, l0, l1, l2, E00, E01, E02, E10, E11, E12, E20, E21, E22, hu0, hu1, hu2):
    """The momentum update of a step: :func:`momentum_c` (compensated) when the step's moment is
    zero, else :func:`momentum` with a zero low part, the sum of the forced kernels (so a moment
    given as an array and as a model keep identical bits). Returns ``(m0, m1, m2, n0, n1, n2)``."""
    if hu0 == 0.0 and hu1 == 0.0 and hu2 == 0.0:
        return momentum_c(b0, b1, b2, l0, l1, l2, E00, E01, E02, E10, E11, E12, E20, E21, E22, hu0, hu1, hu2)
    m0, m1, m2 = momentum(b0, b1, b2, E00, E01, E02, E10, E11, E12, E20, E21, E22, hu0, hu1, hu2)
    return m0, m1, m2, 0.0, 0.0, 0.0


@jit(inline="always")
def store(R_out, Pi_out, j, R, Pi):
    """Write the state ``(R, Pi)`` as sample ``j`` of the output buffers."""
    for a in range(3):
        Pi_out[j, a] = Pi[a]
        for b in range(3):
            R_out[j, a, b] = R[a, b]


@jit(inline="always")
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
                        p0, p1, p2, q0, q1, q2, tol, max_iter, alpha, hist, True)
    if st != OK:
        return its, rn, st
    # Pi <- (I + E)^T Pi + h u, checked before anything is written (a huge moment can overflow it)
    c0, c1, c2, n0, n1, n2 = momentum_step(Pi[0], Pi[1], Pi[2], G[4, 0], G[4, 1], G[4, 2], E00, E01, E02, E10, E11,
                                           E12, E20, E21, E22, h * u0, h * u1, h * u2)
    if not (math.isfinite(c0) and math.isfinite(c1) and math.isfinite(c2)):
        return its, rn, OVERFLOW
    push(G, g0, g1, g2)
    G[4, 0] = n0
    G[4, 1] = n1
    G[4, 2] = n2
    rotate(R, E00, E01, E02, E10, E11, E12, E20, E21, E22)      # R <- R (I + E)
    Pi[0] = c0
    Pi[1] = c1
    Pi[2] = c2
    return its, rn, st


@jit(inline="always")
def free_steps(method, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every, countdown, j, R_out, Pi_out,
               records, it_out, res_out, hist, counts):
    """Steps ``k0 .. k0+n-1`` of :func:`lgvi_step` in a loop: the body of :func:`run_chunk` and of
    the ensemble's per-body loop.

    The state (``R``, ``Pi``, ``G``) and ``Jd`` are held in local scalars between steps and
    written back at the end: no memory round trip on the chain of dependent steps, and the
    solver's set-up for ``Jd`` is loop-invariant. Every helper is inlined and nothing allocates,
    so a caller compiled without reference counting (``_nrt=False``) runs pure arithmetic per step.

    The first sample is stored after ``countdown`` steps at ``R_out[j]``, then every
    ``save_every`` steps. The solver's record: ``records == 1`` (per step) writes the iterations
    and final residual of step ``k`` to ``it_out[k - k0]``, ``res_out[k - k0]`` (the failed step's
    too); ``records == 2`` (per saved interval) writes the largest iterations and residual of the
    steps taken since the previous sample to ``it_out[j]``, ``res_out[j]`` with the sample ``j``;
    ``records == 0`` writes neither. A non-empty int64 ``counts`` (B,) is a histogram: every step
    taken adds 1 to ``counts[min(iterations, B - 1)]``. Returns ``(status, k, its, rmax, it,
    rn)``: ``OK`` and ``k = k0 + n``, or the status and index of the failed step (the state is
    the one before it); ``its`` the iterations summed over the steps tried, ``rmax`` the largest
    final residual of the steps taken, ``it``, ``rn`` those of the last step tried.
    """
    has_u = U.shape[0] > 0
    d00 = Jd[0, 0]
    d01 = Jd[0, 1]
    d02 = Jd[0, 2]
    d11 = Jd[1, 1]
    d12 = Jd[1, 2]
    d22 = Jd[2, 2]
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    P0, P1, P2 = Pi[0], Pi[1], Pi[2]
    a0, a1, a2 = G[0, 0], G[0, 1], G[0, 2]
    b0, b1, b2 = G[1, 0], G[1, 1], G[1, 2]
    c0, c1, c2 = G[2, 0], G[2, 1], G[2, 2]
    ng = G[3, 0]
    l0, l1, l2 = G[4, 0], G[4, 1], G[4, 2]
    u0 = 0.0
    u1 = 0.0
    u2 = 0.0
    status = OK
    kend = k0 + n
    it_sum = 0
    rmax = 0.0
    its = 0
    rn = 0.0
    imax = 0                 # largest iterations and residual of the saved interval in progress
    rimax = 0.0
    nbins = counts.shape[0]
    ones = 0                 # steps of one update (the usual count), added to the histogram at the end
    for k in range(k0, k0 + n):
        if has_u:
            u0 = U[k, 0]
            u1 = U[k, 1]
            u2 = U[k, 2]
        q0, q1, q2 = extrapolate(ng, a0, a1, a2, b0, b1, b2, c0, c1, c2)
        (g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, its, rn,
         st) = solve_scalar(method, d00, d01, d02, d11, d12, d22, h * P0, h * P1, h * P2, q0, q1, q2,
                            tol, max_iter, alpha, hist, True)
        it_sum += its
        if records == 1:
            it_out[k - k0] = its
            res_out[k - k0] = rn
        if st != OK:
            status = st
            kend = k
            break
        m0, m1, m2, n0, n1, n2 = momentum_step(P0, P1, P2, l0, l1, l2, E00, E01, E02, E10, E11, E12, E20, E21, E22,
                                               h * u0, h * u1, h * u2)
        if not (math.isfinite(m0) and math.isfinite(m1) and math.isfinite(m2)):
            status = OVERFLOW
            kend = k
            break
        if rn > rmax:
            rmax = rn
        if records == 2:
            if its > imax:
                imax = its
            if rn > rimax:
                rimax = rn
        if its == 1:
            ones += 1
        elif nbins > 0:
            counts[its if its < nbins - 1 else nbins - 1] += 1      # not min(): see step_done
        c0, c1, c2 = b0, b1, b2
        b0, b1, b2 = a0, a1, a2
        a0, a1, a2 = g0, g1, g2
        if ng < 3.0:
            ng += 1.0
        r00, r01, r02 = rotated_row(r00, r01, r02, E00, E01, E02, E10, E11, E12, E20, E21, E22)
        r10, r11, r12 = rotated_row(r10, r11, r12, E00, E01, E02, E10, E11, E12, E20, E21, E22)
        r20, r21, r22 = rotated_row(r20, r21, r22, E00, E01, E02, E10, E11, E12, E20, E21, E22)
        P0, P1, P2 = m0, m1, m2
        l0, l1, l2 = n0, n1, n2
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            R_out[j, 0, 0], R_out[j, 0, 1], R_out[j, 0, 2] = r00, r01, r02
            R_out[j, 1, 0], R_out[j, 1, 1], R_out[j, 1, 2] = r10, r11, r12
            R_out[j, 2, 0], R_out[j, 2, 1], R_out[j, 2, 2] = r20, r21, r22
            Pi_out[j, 0], Pi_out[j, 1], Pi_out[j, 2] = P0, P1, P2
            if records == 2:
                it_out[j] = imax
                res_out[j] = rimax
            imax = 0
            rimax = 0.0
            j += 1
    R[0, 0], R[0, 1], R[0, 2] = r00, r01, r02
    R[1, 0], R[1, 1], R[1, 2] = r10, r11, r12
    R[2, 0], R[2, 1], R[2, 2] = r20, r21, r22
    Pi[0], Pi[1], Pi[2] = P0, P1, P2
    G[0, 0], G[0, 1], G[0, 2] = a0, a1, a2
    G[1, 0], G[1, 1], G[1, 2] = b0, b1, b2
    G[2, 0], G[2, 1], G[2, 2] = c0, c1, c2
    G[3, 0] = ng
    G[4, 0], G[4, 1], G[4, 2] = l0, l1, l2
    if nbins > 1:
        counts[1] += ones
    return status, kend, it_sum, rmax, its, rn


@jit(_nrt=False)
def run_chunk(method, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every,
              R_out, Pi_out, it_out, res_out, hist, counts):
    """Advance ``n`` steps ``k0 .. k0+n-1`` with moments ``U`` (``U.shape[0] == 0``: free body).

    Output buffers are relative to the chunk, whose start ``k0`` must be a multiple of
    ``save_every``: the sample after step ``k`` with ``(k + 1 - k0) % save_every == 0`` goes to
    ``R_out[(k + 1 - k0) // save_every - 1]`` (the caller passes a view starting at sample
    ``k0 // save_every + 1``). The solver's record goes to ``it_out``, ``res_out`` at the
    resolution their length gives: ``n`` entries, the iterations and final residual of every
    step (``it_out[k - k0]``); ``n // save_every`` entries, the largest of each over the steps
    of each saved interval (``it_out[j]`` with sample ``R_out[j]``; with ``save_every = 1`` the
    same numbers). ``counts`` (B,) int64 gains the histogram of the iterations of the steps
    taken (see :func:`free_steps`). ``hist`` is an empty float64 array.

    Returns ``(status, k, it_sum, rmax, its, rn)``: ``OK`` and ``k = k0 + n`` on success;
    otherwise the solver status of the failed step ``k``, with ``R, Pi`` the state before that
    step; ``it_sum`` the iterations summed over the steps tried, ``rmax`` the largest residual of
    the steps taken, ``its``, ``rn`` those of the last step tried (the failed one on failure).

    Compiled without Numba's reference counting: the loop (:func:`free_steps`) is inlined and
    allocates nothing, so no step pays for reference-count updates of array arguments (atomic
    operations, about a third of a step's time when the step was a call of its own).
    """
    records = 1 if it_out.shape[0] == n else 2
    return free_steps(method, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every, save_every, 0,
                      R_out, Pi_out, records, it_out, res_out, hist, counts)


@jit(_nrt=False)
def run_chunk_cayley(method, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every,
                     R_out, Pi_out, it_out, res_out, hist, counts):
    """:func:`run_chunk` compiled for ``method == METHOD_CAYLEY`` only (the argument is ignored).

    With the method a constant, LLVM drops the other solvers' branches from the loop: fewer
    values live across a step, fewer register spills, about 10 % less time per step. A separate
    kernel rather than a branch in :func:`run_chunk`, because each inlined copy of the loop costs
    seconds of compilation and a kernel compiles only when first used.
    """
    records = 1 if it_out.shape[0] == n else 2
    return free_steps(METHOD_CAYLEY, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every, save_every, 0,
                      R_out, Pi_out, records, it_out, res_out, hist, counts)


@jit(_nrt=False)
def run_chunk_newton(method, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every,
                     R_out, Pi_out, it_out, res_out, hist, counts):
    """:func:`run_chunk` compiled for ``method == METHOD_NEWTON`` only (the argument is ignored):
    ``simulate``'s default method, specialised as :func:`run_chunk_cayley` is (the same bits;
    LLVM drops the other solvers' branches, which also shortens the first call's compilation)."""
    records = 1 if it_out.shape[0] == n else 2
    return free_steps(METHOD_NEWTON, Jd, h, R, Pi, G, U, k0, n, tol, max_iter, alpha, save_every, save_every, 0,
                      R_out, Pi_out, records, it_out, res_out, hist, counts)


# ------------------------------------------------------------------------------------------------
# Forced steps: potentials (variational), paper or symmetric forcing, and compositions
# ------------------------------------------------------------------------------------------------
#
# One (sub)step of size ``hs`` from ``(t, R_k, Pi_k)`` to ``t1``, with the moments split as in
# :mod:`.torque_kernels` (``P`` conservative, ``N = Q - D Omega`` the rest):
#
#     mu       = Pi_k + hs/2 P_k (+ hs/2 N_k if symmetric)
#     hat(hs mu) = F Jd - Jd F^T                        (solve_scalar with right-hand side hs mu)
#     R_{k+1}  = R_k F
#     Pi_{k+1} = F^T mu + hs/2 P_{k+1} + hs N_k                          (forcing "paper")
#     Pi_{k+1} = F^T mu + hs/2 P_{k+1} + hs/2 N_{k+1}(Pi_{k+1})           (forcing "symmetric")
#
# With ``N = Q - D J^-1 Pi`` the symmetric momentum equation is linear in ``Pi_{k+1}``:
# ``(I + hs/2 D J^-1) Pi_{k+1} = F^T mu + hs/2 (P_{k+1} + Q_{k+1})``, solved with the
# precomputed inverse ``A`` of the matrix on the left (no iteration, exact to round-off).
#
# The moments at the current state are cached in ``S`` (7,): ``P`` in ``S[0:3]``, ``N`` in
# ``S[3:6]``, ``S[6]`` = 1 when valid. A step evaluates the model once, at its end, and leaves
# the result for the next step; the cache travels between chunks with ``R``, ``Pi`` and ``G``.


@jit(inline="always")
def solve_warm(method, Jd, J_inv, p0, p1, p2, G, j, tol, max_iter, alpha, hist):
    """``solve_scalar`` from the extrapolated guess, with fallbacks after a failure.

    Quadratic extrapolation is excellent for smooth motions but can overshoot when steps turn the
    body by large angles (long substeps of a composition), and Newton may then not come back.
    After a failure the solve is repeated from the last solution, then from the linearisation
    ``J w = h Pi`` (the cold start). The fallbacks only run after a failure, so they never change
    a result that converged; the reported iterations include every attempt.
    """
    q0, q1, q2 = predict_at(G, j)
    spent = 0
    # one call site for the three attempts: each inlined copy of the solver costs compilation time
    for attempt in range(3):
        if attempt == 1:
            if G[j, 3, 0] < 2.0:
                continue                      # the first guess was the last solution already
            q0 = G[j, 0, 0]
            q1 = G[j, 0, 1]
            q2 = G[j, 0, 2]
        elif attempt == 2:
            c = 0.5 if method == METHOD_CAYLEY else 1.0
            q0 = c * (J_inv[0, 0] * p0 + J_inv[0, 1] * p1 + J_inv[0, 2] * p2)
            q1 = c * (J_inv[1, 0] * p0 + J_inv[1, 1] * p1 + J_inv[1, 2] * p2)
            q2 = c * (J_inv[2, 0] * p0 + J_inv[2, 1] * p1 + J_inv[2, 2] * p2)
        res = solve_call(method, Jd[0, 0], Jd[0, 1], Jd[0, 2], Jd[1, 1], Jd[1, 2], Jd[2, 2],
                         p0, p1, p2, q0, q1, q2, tol, max_iter, alpha, hist, attempt == 0)
        spent += res[12]
        if res[14] == OK:
            break
    return (res[0], res[1], res[2], res[3], res[4], res[5], res[6], res[7], res[8], res[9], res[10], res[11],
            spent, res[13], res[14])


@jit(inline="always")
def forced_stage_s(method, Jd, J, J_inv, hs, t1, Rt, Pt, Mt, G, j, codes, params, D0, D1, D2, has_D, A, i_A, sym,
                   v0, v1, v2, tol, max_iter, alpha, hist):
    """One substep from the state ``Rt`` (the 9 entries of ``R``, row-major), ``Pt`` (``Pi``),
    ``Mt`` (the cached moments ``P``, ``N``) and the history ``G[j]`` (this stage's, updated in
    place on success). Tuples rather than 18 separate numbers: a call with more than 30
    arguments compiles to a star-args call, which Numba cannot inline.

    ``A[i_A]`` is the momentum matrix of this substep (see :func:`run_chunk_forced`).

    ``v`` is an extra explicit moment at the end point added to ``Q`` (torque arrays in symmetric
    mode; zero otherwise). Returns ``(iterations, residual, status, Rt, Pt, Mt)``, the new state;
    on failure the state given, and ``G`` unchanged.
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = Rt
    pi0, pi1, pi2 = Pt
    P0, P1, P2, N0, N1, N2 = Mt
    hh = 0.5 * hs
    if sym:
        m0 = pi0 + hh * (P0 + N0)
        m1 = pi1 + hh * (P1 + N1)
        m2 = pi2 + hh * (P2 + N2)
    else:
        m0 = pi0 + hh * P0
        m1 = pi1 + hh * P1
        m2 = pi2 + hh * P2
    (g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, its, rn,
     st) = solve_warm(method, Jd, J_inv, hs * m0, hs * m1, hs * m2, G, j, tol, max_iter, alpha, hist)
    if st != OK:
        return its, rn, st, Rt, Pt, Mt
    push_at(G, j, g0, g1, g2)
    # R <- R (I + E)
    r00, r01, r02 = rotated_row(r00, r01, r02, E00, E01, E02, E10, E11, E12, E20, E21, E22)
    r10, r11, r12 = rotated_row(r10, r11, r12, E00, E01, E02, E10, E11, E12, E20, E21, E22)
    r20, r21, r22 = rotated_row(r20, r21, r22, E00, E01, E02, E10, E11, E12, E20, E21, E22)
    # F^T mu
    b0 = m0 + (E00 * m0 + E10 * m1 + E20 * m2)
    b1 = m1 + (E01 * m0 + E11 * m1 + E21 * m2)
    b2 = m2 + (E02 * m0 + E12 * m1 + E22 * m2)
    P0, P1, P2, Q0, Q1, Q2 = model_moments_call(codes, params, J, t1, r00, r01, r02, r10, r11, r12, r20, r21, r22)
    Q0 += v0
    Q1 += v1
    Q2 += v2
    if sym:
        b0 += hh * (P0 + Q0)
        b1 += hh * (P1 + Q1)
        b2 += hh * (P2 + Q2)
        if has_D:
            c0 = A[i_A, 0, 0] * b0 + A[i_A, 0, 1] * b1 + A[i_A, 0, 2] * b2
            c1 = A[i_A, 1, 0] * b0 + A[i_A, 1, 1] * b1 + A[i_A, 1, 2] * b2
            c2 = A[i_A, 2, 0] * b0 + A[i_A, 2, 1] * b1 + A[i_A, 2, 2] * b2
            b0 = c0
            b1 = c1
            b2 = c2
    else:
        b0 += hh * P0 + hs * N0
        b1 += hh * P1 + hs * N1
        b2 += hh * P2 + hs * N2
    if has_D:
        Q0 -= D0 * (J_inv[0, 0] * b0 + J_inv[0, 1] * b1 + J_inv[0, 2] * b2)
        Q1 -= D1 * (J_inv[1, 0] * b0 + J_inv[1, 1] * b1 + J_inv[1, 2] * b2)
        Q2 -= D2 * (J_inv[2, 0] * b0 + J_inv[2, 1] * b1 + J_inv[2, 2] * b2)
    return (its, rn, st, (r00, r01, r02, r10, r11, r12, r20, r21, r22), (b0, b1, b2), (P0, P1, P2, Q0, Q1, Q2))


@jit(inline="always")
def forced_stage(method, Jd, J, J_inv, hs, t1, R, Pi, G, j, S, codes, params, D0, D1, D2, has_D, A, i_A, sym,
                 v0, v1, v2, tol, max_iter, alpha, hist):
    """:func:`forced_stage_s` in place on the arrays ``R``, ``Pi``, ``G[j]`` and the moment cache
    ``S``. Returns ``(iterations, residual, status)``; on failure nothing changed."""
    Rt = (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2])
    its, rn, st, Rt, Pt, Mt = forced_stage_s(method, Jd, J, J_inv, hs, t1, Rt, (Pi[0], Pi[1], Pi[2]),
                                             (S[0], S[1], S[2], S[3], S[4], S[5]), G, j, codes, params, D0, D1, D2,
                                             has_D, A, i_A, sym, v0, v1, v2, tol, max_iter, alpha, hist)
    if st != OK:
        return its, rn, st
    R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2] = Rt
    Pi[0], Pi[1], Pi[2] = Pt
    S[0], S[1], S[2], S[3], S[4], S[5] = Mt
    S[6] = 1.0
    return its, rn, st


@jit(inline="always")
def finite_moments(Pt, Mt):
    """True when the momentum ``Pt`` and the cached moments ``Mt`` are all finite."""
    ok = math.isfinite(Pt[0]) and math.isfinite(Pt[1]) and math.isfinite(Pt[2])
    for i in range(6):
        ok = ok and math.isfinite(Mt[i])
    return ok


@jit(inline="always")
def load_state(R, Pi, S):
    """The state of a forced chunk loop as tuples ``(Rt, Pt, Mt)``: ``R`` (9 entries, row-major),
    ``Pi`` and the cached moments ``S[0:6]`` (the loops keep them in locals, see :func:`save_state`)."""
    return ((R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2]), (Pi[0], Pi[1], Pi[2]),
            (S[0], S[1], S[2], S[3], S[4], S[5]))


@jit(inline="always")
def save_state(R, Pi, S, Rt, Pt, Mt):
    """Write the tuples of :func:`load_state` back to the arrays."""
    R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2] = Rt
    Pi[0], Pi[1], Pi[2] = Pt
    S[0], S[1], S[2], S[3], S[4], S[5] = Mt


@jit(inline="always")
def stage_done(its_sum, rmax, its, rn, st, Px, Mx):
    """Account one substep: ``(its_sum, rmax, st)`` with its iterations and residual added, and
    ``st`` set to ``OVERFLOW`` when a moment overflowed the momentum (never keep such a state)."""
    its_sum += its
    if rn > rmax:
        rmax = rn
    if st == OK and not finite_moments(Px, Mx):
        st = OVERFLOW
    return its_sum, rmax, st


@jit(inline="always")
def step_done(k, k0, status, its_sum, rmax, rn, Rt, Pt, book, per_step, save_every, R_out, Pi_out, it_out,
              res_out, counts):
    """The bookkeeping of step ``k`` once its substeps ran, shared by the forced chunk loops.

    ``book`` = ``(it_total, rmax_all, rlast, imax, rimax, countdown, jout)``: the chunk's solver
    totals, the last step's residual, the saved interval's largest iterations and residual, steps
    to the next sample and the next sample's index. Records the step (per step, or per saved
    interval at each sample), the histogram ``counts``, and on success stores the new state
    ``(Rt, Pt)`` when a sample falls due. Returns the new ``book``.
    """
    it_total, rmax_all, rlast, imax, rimax, countdown, jout = book
    it_total += its_sum
    if per_step:
        it_out[k - k0] = its_sum
    if status != OK:
        if per_step:
            res_out[k - k0] = rn
        return it_total, rmax_all, rn, imax, rimax, countdown, jout
    if per_step:
        res_out[k - k0] = rmax
    if rmax > rmax_all:
        rmax_all = rmax
    if its_sum > imax:
        imax = its_sum
    if rmax > rimax:
        rimax = rmax
    nbins = counts.shape[0]
    if nbins > 0:
        # a conditional, not min(): Numba's CUDA target cannot compile its overload of min (star-args)
        counts[its_sum if its_sum < nbins - 1 else nbins - 1] += 1
    countdown -= 1
    if countdown == 0:
        countdown = save_every
        (R_out[jout, 0, 0], R_out[jout, 0, 1], R_out[jout, 0, 2], R_out[jout, 1, 0], R_out[jout, 1, 1],
         R_out[jout, 1, 2], R_out[jout, 2, 0], R_out[jout, 2, 1], R_out[jout, 2, 2]) = Rt
        Pi_out[jout, 0], Pi_out[jout, 1], Pi_out[jout, 2] = Pt
        if not per_step:
            it_out[jout] = imax
            res_out[jout] = rimax
        imax = 0
        rimax = 0.0
        jout += 1
    return it_total, rmax_all, rmax, imax, rimax, countdown, jout


@jit(inline="always")
def init_moments(codes, params, J, J_inv, t, R, Pi, S, v0, v1, v2):
    """Fill the moment cache ``S`` at the state ``(t, R, Pi)`` (``v`` an extra explicit moment).

    Inlined at its one call site (:func:`run_chunk_forced`'s start): as a function of its own it was
    a fourth compilation of the first call, about 1 s of CPU on its own (it calls the models through
    :func:`.torque_kernels.model_moments_call`, compiled once for both)."""
    P0, P1, P2, Q0, Q1, Q2 = model_moments_call(codes, params, J, t, R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1],
                                                R[1, 2], R[2, 0], R[2, 1], R[2, 2])
    D0, D1, D2 = momentum_diag(codes, params)
    S[0] = P0
    S[1] = P1
    S[2] = P2
    S[3] = (Q0 + v0) - D0 * (J_inv[0, 0] * Pi[0] + J_inv[0, 1] * Pi[1] + J_inv[0, 2] * Pi[2])
    S[4] = (Q1 + v1) - D1 * (J_inv[1, 0] * Pi[0] + J_inv[1, 1] * Pi[1] + J_inv[1, 2] * Pi[2])
    S[5] = (Q2 + v2) - D2 * (J_inv[2, 0] * Pi[0] + J_inv[2, 1] * Pi[1] + J_inv[2, 2] * Pi[2])
    S[6] = 1.0


@jit(_nrt=False)
def run_chunk_forced(method, Jd, J, J_inv, h, t0, gam, cum, A, R, Pi, G, gidx, S, codes, params, U, sym,
                     k0, n, tol, max_iter, alpha, save_every, countdown, R_out, Pi_out, it_out, res_out, hist, counts):
    """Advance ``n`` steps ``k0 .. k0+n-1`` of a forced and/or composed scheme (see notes above).

    Each step of size ``h`` is the composition of ``s = gam.shape[0]`` substeps of sizes
    ``gam[i] h`` (``s = 1``, ``gam = [1]``: the plain second-order scheme). Substep ``i`` of step
    ``k`` ends at ``t0 + (k + cum[i + 1]) h`` (``cum[0] = 0``, ``cum[s] = 1``). ``A`` (s,3,3)
    holds ``(I + gam[i] h/2 D J^-1)^-1`` (used only with symmetric forcing and ``D != 0``).
    ``G`` (m,5,3) holds solver histories and substep ``i`` uses ``G[gidx[i]]``; the integrator
    keeps one history per substep (``gidx = 0 .. s-1``), so each warm start extrapolates
    solutions of the same substep, equally spaced by ``h`` (a history shared by substeps of
    different sizes, or by equal substeps at unequal spacing, extrapolates badly). ``U`` (steps+1, 3) or empty: explicit
    moments at the grid points (symmetric forcing, ``s = 1``). Output buffers, ``counts`` and the
    record's resolution are as in :func:`run_chunk`, except that the first sample is stored after
    ``countdown`` steps (``save_every`` when ``k0`` is a multiple of it) at ``R_out[0]``, then every
    ``save_every`` steps; a step's iterations are the solver updates summed over its substeps, its
    residual the largest final residual of its substeps.

    One compiled loop for every run of the built-in models: :func:`lgvi.simulate`, its streams and
    each body of an ensemble (:func:`.ensemble_kernels.advance_forced` calls this with the body's
    views, of the same types; an ensemble of up to 64 bodies calls it from Python, a body at a
    time), so a cold first call of any of them compiles it once for all.

    Returns ``(status, k, it_sum, rmax, its, rn)`` as :func:`run_chunk`; after a failure ``R``,
    ``Pi`` and ``S`` are the state at the start of step ``k``.
    """
    s = gam.shape[0]
    has_u = U.shape[0] > 0
    D0, D1, D2 = momentum_diag(codes, params)
    has_D = D0 != 0.0 or D1 != 0.0 or D2 != 0.0
    v0 = 0.0
    v1 = 0.0
    v2 = 0.0
    if S[6] == 0.0:
        if has_u:
            v0 = U[k0, 0]
            v1 = U[k0, 1]
            v2 = U[k0, 2]
        init_moments(codes, params, J, J_inv, t0 + k0 * h, R, Pi, S, v0, v1, v2)
    # the state in local tuples (written back at the end, as in free_steps)
    Rt, Pt, Mt = load_state(R, Pi, S)
    status = OK
    kend = k0 + n
    per_step = it_out.shape[0] == n
    its_sum = 0
    book = (0, 0.0, 0.0, 0, 0.0, countdown, 0)     # see step_done
    for k in range(k0, k0 + n):
        if has_u:
            v0 = U[k + 1, 0]
            v1 = U[k + 1, 1]
            v2 = U[k + 1, 2]
        its_sum = 0
        rmax = 0.0
        # substeps work on copies: a failed step leaves the state at its start
        Rx, Px, Mx = Rt, Pt, Mt
        for i in range(s):
            t1 = t0 + (k + cum[i + 1]) * h
            its, rn, st, Rx, Px, Mx = forced_stage_s(method, Jd, J, J_inv, gam[i] * h, t1, Rx, Px, Mx, G, gidx[i],
                                                     codes, params, D0, D1, D2, has_D, A, i, sym, v0, v1, v2, tol,
                                                     max_iter, alpha, hist)
            its_sum, rmax, st = stage_done(its_sum, rmax, its, rn, st, Px, Mx)
            if st != OK:
                status = st
                break
        book = step_done(k, k0, status, its_sum, rmax, rn, Rx, Px, book, per_step, save_every, R_out, Pi_out,
                         it_out, res_out, counts)
        if status != OK:
            kend = k
            break
        Rt, Pt, Mt = Rx, Px, Mx
    save_state(R, Pi, S, Rt, Pt, Mt)
    return status, kend, book[0], book[1], its_sum, book[2]


@jit
def shifted_step(method, Jd, J_inv, hs, R, Pi, G, j, m0, m1, m2, tol, max_iter, alpha, hist):
    """Variational half of a symmetric step for a Python torque callable, in place.

    With ``mu = Pi + hs/2 m``: solves ``hat(hs mu) = F Jd - Jd F^T``, sets ``R <- R F`` and
    ``Pi <- F^T mu``; the caller then adds ``hs/2 M_{k+1}``. Returns ``(iterations, residual,
    status)``; on failure nothing changed.
    """
    hh = 0.5 * hs
    m0 = Pi[0] + hh * m0
    m1 = Pi[1] + hh * m1
    m2 = Pi[2] + hh * m2
    (g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, its, rn,
     st) = solve_warm(method, Jd, J_inv, hs * m0, hs * m1, hs * m2, G, j, tol, max_iter, alpha, hist)
    if st != OK:
        return its, rn, st
    push_at(G, j, g0, g1, g2)
    rotate(R, E00, E01, E02, E10, E11, E12, E20, E21, E22)      # R <- R (I + E)
    Pi[0] = m0 + (E00 * m0 + E10 * m1 + E20 * m2)
    Pi[1] = m1 + (E01 * m0 + E11 * m1 + E21 * m2)
    Pi[2] = m2 + (E02 * m0 + E12 * m1 + E22 * m2)
    return its, rn, st
