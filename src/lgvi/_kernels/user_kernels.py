"""Stepping loop for a torque model the user compiles (:class:`lgvi.torques.Compiled`).

:func:`run_chunk_user` is :func:`.stepping.run_chunk_forced` with one more moment: the user's
``moment(t, R, Pi, params)``. Only the substep differs (:func:`user_stage_s`); the state tuples,
the per-step bookkeeping and the sample store are :func:`.stepping.load_state`,
:func:`.stepping.stage_done`, :func:`.stepping.step_done` and :func:`.stepping.save_state`,
written once for both loops.

The user's function reaches the loop as a value of one function type, :data:`MOMENT_SIGNATURE`
(a Numba ``cfunc`` made once per function and process by :func:`guarded`, which calls the user's
function and catches what it raises), not as a function
the loop is specialised for: ONE compiled loop, cached on disk, serves every user's model (as the
control loop's user components, :mod:`.loop_kernels`), and a new model costs only the compilation
of its own function and of the small ``cfunc`` around it. The loop is compiled without Numba's
reference counting: an array the user's function returns is made and freed inside the ``cfunc``.

The user's moment goes into the conservative part ``P`` when the model has a potential, into
``N`` otherwise. A moment that depends on ``Pi`` (``mdep``) with symmetric forcing makes the
momentum equation ``Pi = b + hs/2 (P + N(Pi))`` implicit; it is solved by fixed-point
iteration (``NOT_CONVERGED`` when it does not converge in ``max_iter`` evaluations).
The user's function receives ``R`` and ``Pi`` in the scratch arrays ``Rs`` (3,3), ``Ps`` (3,).
An exception it raises inside the loop is caught (:func:`guarded`): the step fails with
``USER_RAISED`` and the part computed before it is kept.
"""

from __future__ import annotations

import math

from numba import types

from .._jit import jit
from .codes import NOT_CONVERGED, OK, USER_RAISED
from .ensemble_kernels import record_body
from .guards import guarded_function
from .solvers import EPS
from .stepping import load_state, push_at, rotated_row, save_state, solve_warm, stage_done, step_done
from .torque_kernels import model_moments_call, momentum_diag


#: ``moment(t, R, Pi, params) -> (m0, m1, m2)`` of a user's moment as the CPU loops call it: ``R``
#: (3,3) and ``Pi`` (3,) C-contiguous (the loops' scratch copies of the state), ``params`` the model's
#: read-only row; the body-frame moment as three floats.
MOMENT_SIGNATURE = types.UniTuple(types.float64, 3)(types.float64, types.float64[:, ::1], types.float64[::1],
                                                    types.Array(types.float64, 1, "C", readonly=True))


#: ``potential(t, R, params) -> float`` of a user's potential as the series loops call it (``R``
#: (3,3) C-contiguous scratch, ``params`` read-only).
POTENTIAL_SIGNATURE = types.float64(types.float64, types.float64[:, ::1],
                                    types.Array(types.float64, 1, "C", readonly=True))


@jit
def moment_result(m):
    """The call adapter of :func:`guarded`: the three numbers of the user's moment (a tuple or a
    (3,) array; an array it makes is freed inside the ``cfunc``). An array of another length raises
    (inside the guard: the call fails as a raise does, never reading past the array). Not inlined:
    Numba's ``try`` catches what a called function raises, not a ``raise`` inlined into its body."""
    if len(m) != 3:
        raise ValueError("a moment is 3 numbers")
    return float(m[0]), float(m[1]), float(m[2])


@jit(inline="always")
def moment_failed(t, R, P, p):
    """The failure marking of :func:`guarded`: NaN in the loop's scratch ``R[0, 0]`` (the mark
    :func:`user_raised` reads) and a NaN moment, so the step fails."""
    R[0, 0] = math.nan
    return math.nan, math.nan, math.nan


def guarded(moment):
    """The user's ``moment(t, R, Pi, params)`` as the CPU loops' ``moment`` argument: a ``cfunc`` of
    :data:`MOMENT_SIGNATURE` (compiled in memory, once per function and process, by
    :func:`.guards.guarded_function`) that calls it and returns the three numbers it returns
    (:func:`moment_result`). An exception it raises (a division by zero, an error it raises) is
    caught there (a ``cfunc`` cannot raise into its caller): the moment is NaN, so the step fails,
    and ``R[0, 0]`` (the loop's scratch) is set to NaN, the mark :func:`user_raised` reads
    (:func:`moment_failed`). A function that does not fit the signature raises Numba's typing error
    here. With ``NUMBA_DISABLE_JIT=1`` (the kernels as Python) the guard itself."""
    return guarded_function(moment, MOMENT_SIGNATURE, moment_result, moment_failed)


@jit(inline="always")
def potential_result(v):
    """The call adapter of :func:`guarded_potential`: the user's potential as a float."""
    return float(v)


@jit(inline="always")
def potential_failed(t, R, p):
    """The failure marking of :func:`guarded_potential`: NaN in the scratch ``R[0, 0]``, a NaN value."""
    R[0, 0] = math.nan
    return math.nan


def guarded_potential(potential):
    """The user's ``potential(t, R, params)`` as the series loops' ``potential`` argument: a ``cfunc``
    of :data:`POTENTIAL_SIGNATURE` (as :func:`guarded` for the moment: an exception it raises marks
    ``R[0, 0]`` with NaN)."""
    return guarded_function(potential, POTENTIAL_SIGNATURE, potential_result, potential_failed)


@jit(inline="always")
def user_moment(moment, up, Rs, Ps, t, Rt, p0, p1, p2):
    """The user's moment at ``(t, R, Pi)`` as three numbers.

    On the CPU ``moment`` is the user's function wrapped by :func:`guarded`: an exception it raises is
    caught there, the moment is NaN, so the step fails, and ``Rs[0, 0]`` is set to NaN, the mark
    :func:`user_raised` reads (a rotation passed to the function is never NaN); once marked, the
    function is not called again in that chunk. On the GPU (:mod:`.cuda_kernels`) the user's function
    is called as it is: the CUDA target has no exception handling (and cannot call a ``cfunc``)."""
    if Rs[0, 0] != Rs[0, 0]:
        return math.nan, math.nan, math.nan
    Rs[0, 0], Rs[0, 1], Rs[0, 2], Rs[1, 0], Rs[1, 1], Rs[1, 2], Rs[2, 0], Rs[2, 1], Rs[2, 2] = Rt
    Ps[0] = p0
    Ps[1] = p1
    Ps[2] = p2
    m = moment(t, Rs, Ps, up)
    return float(m[0]), float(m[1]), float(m[2])


@jit(inline="always")
def user_raised(st, Rs):
    """``USER_RAISED`` for a failed substep whose user function raised (see :func:`user_moment`)."""
    if st != OK and Rs[0, 0] != Rs[0, 0]:
        return USER_RAISED
    return st


@jit(inline="always")
def user_stage_s(moment, up, Rs, Ps, cons, mdep, method, Jd, J, J_inv, hs, t1, Rt, Pt, Mt, G, j, codes, params,
                 D0, D1, D2, has_D, A, i_A, sym, tol, max_iter, alpha, hist):
    """:func:`.stepping.forced_stage_s` with the user's moment added (see the module notes)."""
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
    r00, r01, r02 = rotated_row(r00, r01, r02, E00, E01, E02, E10, E11, E12, E20, E21, E22)
    r10, r11, r12 = rotated_row(r10, r11, r12, E00, E01, E02, E10, E11, E12, E20, E21, E22)
    r20, r21, r22 = rotated_row(r20, r21, r22, E00, E01, E02, E10, E11, E12, E20, E21, E22)
    R1 = (r00, r01, r02, r10, r11, r12, r20, r21, r22)
    b0 = m0 + (E00 * m0 + E10 * m1 + E20 * m2)
    b1 = m1 + (E01 * m0 + E11 * m1 + E21 * m2)
    b2 = m2 + (E02 * m0 + E12 * m1 + E22 * m2)
    P0, P1, P2, Q0, Q1, Q2 = model_moments_call(codes, params, J, t1, r00, r01, r02, r10, r11, r12, r20, r21, r22)
    u0 = 0.0
    u1 = 0.0
    u2 = 0.0
    if cons:
        u0, u1, u2 = user_moment(moment, up, Rs, Ps, t1, R1, b0, b1, b2)
        P0 += u0
        P1 += u1
        P2 += u2
    elif not mdep:
        u0, u1, u2 = user_moment(moment, up, Rs, Ps, t1, R1, b0, b1, b2)
        Q0 += u0
        Q1 += u1
        Q2 += u2
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
        if mdep and not cons:
            # Pi = b + hs/2 N_user(Pi): fixed-point iteration (converged when the change is at the
            # tolerance or at round-off of the terms)
            a0 = b0
            a1 = b1
            a2 = b2
            x0 = b0
            x1 = b1
            x2 = b2
            done = False
            for it in range(max_iter + 1):
                u0, u1, u2 = user_moment(moment, up, Rs, Ps, t1, R1, x0, x1, x2)
                y0 = a0 + hh * u0
                y1 = a1 + hh * u1
                y2 = a2 + hh * u2
                ch = math.sqrt((y0 - x0) ** 2 + (y1 - x1) ** 2 + (y2 - x2) ** 2)
                ny = math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
                na = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
                nu = abs(hh) * math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
                x0 = y0
                x1 = y1
                x2 = y2
                if not (ch <= tol * ny + 4.0 * EPS * (na + nu)):
                    continue
                done = True
                break
            if not done:
                return its, ch, NOT_CONVERGED, Rt, Pt, Mt
            # the accepted momentum is the last point where N was evaluated
            u0, u1, u2 = user_moment(moment, up, Rs, Ps, t1, R1, x0, x1, x2)
            b0 = x0
            b1 = x1
            b2 = x2
    else:
        b0 += hh * P0 + hs * N0
        b1 += hh * P1 + hs * N1
        b2 += hh * P2 + hs * N2
        if mdep and not cons:
            u0, u1, u2 = user_moment(moment, up, Rs, Ps, t1, R1, b0, b1, b2)
    if mdep and not cons:
        Q0 += u0
        Q1 += u1
        Q2 += u2
    if has_D:
        Q0 -= D0 * (J_inv[0, 0] * b0 + J_inv[0, 1] * b1 + J_inv[0, 2] * b2)
        Q1 -= D1 * (J_inv[1, 0] * b0 + J_inv[1, 1] * b1 + J_inv[1, 2] * b2)
        Q2 -= D2 * (J_inv[2, 0] * b0 + J_inv[2, 1] * b1 + J_inv[2, 2] * b2)
    push_at(G, j, g0, g1, g2)
    return its, rn, st, R1, (b0, b1, b2), (P0, P1, P2, Q0, Q1, Q2)


@jit(inline="always")
def init_user_moments(moment, up, Rs, Ps, cons, codes, params, J, J_inv, t, R, Pi, S):
    """Fill the moment cache ``S`` at ``(t, R, Pi)`` (built-in terms plus the user's moment); inlined
    at its one call site (a function of its own is one more compilation of a first call)."""
    Rt = (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2])
    P0, P1, P2, Q0, Q1, Q2 = model_moments_call(codes, params, J, t, R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1],
                                                R[1, 2], R[2, 0], R[2, 1], R[2, 2])
    D0, D1, D2 = momentum_diag(codes, params)
    u0, u1, u2 = user_moment(moment, up, Rs, Ps, t, Rt, Pi[0], Pi[1], Pi[2])
    if cons:
        P0 += u0
        P1 += u1
        P2 += u2
    else:
        Q0 += u0
        Q1 += u1
        Q2 += u2
    S[0] = P0
    S[1] = P1
    S[2] = P2
    S[3] = Q0 - D0 * (J_inv[0, 0] * Pi[0] + J_inv[0, 1] * Pi[1] + J_inv[0, 2] * Pi[2])
    S[4] = Q1 - D1 * (J_inv[1, 0] * Pi[0] + J_inv[1, 1] * Pi[1] + J_inv[1, 2] * Pi[2])
    S[5] = Q2 - D2 * (J_inv[2, 0] * Pi[0] + J_inv[2, 1] * Pi[1] + J_inv[2, 2] * Pi[2])
    S[6] = 1.0


@jit(_nrt=False)
def run_chunk_user(moment, up, Rs, Ps, cons, mdep, method, Jd, J, J_inv, h, t0, gam, cum, A, R, Pi, G, gidx, S,
                   codes, params, sym, k0, n, tol, max_iter, alpha, save_every, countdown, R_out, Pi_out, it_out,
                   res_out, hist, counts):
    """:func:`.stepping.run_chunk_forced` (no torque array) with the user's moment; same outputs.
    A step whose user function raised fails with ``USER_RAISED`` (``Rs`` (3, 3) zeros on entry,
    ``Ps`` (3,) scratch; ``moment`` of :data:`MOMENT_SIGNATURE`, see :func:`guarded`). Cached on
    disk: one compiled loop for every user's model, of :func:`lgvi.simulate` and of each body of an
    ensemble (:func:`advance_user`; the ensemble's views are of the same types).

    The first sample is stored after ``countdown`` steps (``save_every`` when ``k0`` is a multiple
    of it) at ``R_out[0]``, then every ``save_every`` steps.
    """
    s = gam.shape[0]
    D0, D1, D2 = momentum_diag(codes, params)
    has_D = D0 != 0.0 or D1 != 0.0 or D2 != 0.0
    if S[6] == 0.0:
        init_user_moments(moment, up, Rs, Ps, cons, codes, params, J, J_inv, t0 + k0 * h, R, Pi, S)
    Rt, Pt, Mt = load_state(R, Pi, S)
    status = OK
    kend = k0 + n
    per_step = it_out.shape[0] == n
    its_sum = 0
    rn = 0.0
    book = (0, 0.0, 0.0, 0, 0.0, countdown, 0)     # see stepping.step_done
    for k in range(k0, k0 + n):
        its_sum = 0
        rmax = 0.0
        Rx, Px, Mx = Rt, Pt, Mt
        for i in range(s):
            t1 = t0 + (k + cum[i + 1]) * h
            its, rn, st, Rx, Px, Mx = user_stage_s(moment, up, Rs, Ps, cons, mdep, method, Jd, J, J_inv, gam[i] * h,
                                                   t1, Rx, Px, Mx, G, gidx[i], codes, params, D0, D1, D2, has_D, A,
                                                   i, sym, tol, max_iter, alpha, hist)
            its_sum, rmax, st = stage_done(its_sum, rmax, its, rn, st, Px, Mx)
            st = user_raised(st, Rs)
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


@jit(_nrt=False)
def user_moment_series(moment, t, R, Pi, up, Rs, Ps, out):
    """The user's moment at each sample: ``out[i] = moment(t[i], R[i], Pi[i], up)``.

    ``moment`` of :data:`MOMENT_SIGNATURE` (:func:`guarded`): one loop, cached on disk, for every
    user's function. ``t`` (M,), ``R`` (M, 3, 3), ``Pi`` (M, 3), ``out`` (M, 3). Each sample is
    copied into the scratch arrays ``Rs`` (3, 3), ``Ps`` (3,) (C-contiguous, as the per-sample
    evaluation passes them) so the user's function cannot change the samples. Returns -1, or the
    index of the first sample where the function raised or returned other than 3 numbers (the
    guard's mark; ``out`` is then incomplete: the caller re-evaluates in Python to raise the
    per-sample error). A sample whose own ``R[0, 0]`` is NaN is returned too (the mark cannot be
    told from it): the caller's per-sample evaluation then gives what the function gives there.
    """
    for i in range(t.shape[0]):
        for a in range(3):
            for c in range(3):
                Rs[a, c] = R[i, a, c]
            Ps[a] = Pi[i, a]
        m0, m1, m2 = moment(t[i], Rs, Ps, up)
        if Rs[0, 0] != Rs[0, 0]:
            return i
        out[i, 0] = m0
        out[i, 1] = m1
        out[i, 2] = m2
    return -1


@jit(_nrt=False)
def user_potential_bodies(potential, t, R, table, Rs, out):
    """The user's potential of every body's samples in one compiled loop: ``out[b, i] =
    potential(t[i], R[b, i], row)`` with ``row = table[b]`` (``table`` (B, P), read-only) or
    ``table[0]`` for all; ``potential`` of :data:`POTENTIAL_SIGNATURE` (:func:`guarded_potential`).

    ``t`` (M,), ``R`` (B, M, 3, 3), ``out`` (B, M); ``Rs`` (3, 3) scratch. Returns -1, or the first
    body whose function raised (``out`` is then incomplete from it on).
    """
    for b in range(R.shape[0]):
        up = table[b] if table.shape[0] > 1 else table[0]
        for i in range(t.shape[0]):
            for a in range(3):
                for c in range(3):
                    Rs[a, c] = R[b, i, a, c]
            out[b, i] = potential(t[i], Rs, up)
            if Rs[0, 0] != Rs[0, 0]:
                return b
    return -1


@jit(_nrt=False)
def user_potential_series(potential, t, R, up, Rs, out):
    """The user's potential at each sample: ``out[i] = potential(t[i], R[i], up)``.

    ``potential`` of :data:`POTENTIAL_SIGNATURE` (:func:`guarded_potential`). ``t`` (M,), ``R``
    (M, 3, 3), ``out`` (M,); ``Rs`` (3, 3) scratch as in :func:`user_moment_series`. Returns -1, or
    the index of the first sample where the function raised.
    """
    for i in range(t.shape[0]):
        for a in range(3):
            for c in range(3):
                Rs[a, c] = R[i, a, c]
        out[i] = potential(t[i], Rs, up)
        if Rs[0, 0] != Rs[0, 0]:
            return i
    return -1


@jit(_nrt=False)
def advance_user(b0, b1, moment, table, Rs, Ps, cons, mdep, method, Jd, J, J_inv, ib, h, t0, gam, cum, ia, A, R, Pi,
                 G, gidx, S, codes, params, sym, k0, n, tol, max_iter, alpha, save_every, out0, R_out, Pi_out, it_rec,
                 res_rec, its, res, status, fail_step, fail_res, fail_its, hist, counts):
    """The bodies ``b0 .. b1-1`` of an ensemble whose status is still ``OK`` through steps
    ``k0 .. k0+n-1`` of :func:`run_chunk_user`, each with the ensemble's per-body arrays (as
    :func:`.ensemble_kernels.advance_forced`) and its parameter row ``table[b]`` (``table`` (B, P), or
    (1, P) for all); ``R_out[:, 0]`` holds sample ``out0``. ``Rs`` (3, 3), ``Ps`` (3,), ``it_rec`` and
    ``res_rec`` (at least ``n // save_every`` entries, the solver's record, not kept) are the caller's
    scratch. The CPU ensemble's threads each call this once a chunk with their range of bodies (a call
    per body cost tens of microseconds of dispatch under the GIL, which serialised the threads); the
    GPU's kernel once a thread, for one body (``b1 = b0 + 1``, :mod:`.cuda_kernels`). The step loop
    is called from here directly (see :func:`.ensemble_kernels.advance_forced`).
    """
    for b in range(b0, b1):
        if status[b] != OK:
            continue
        Rs[0, 0] = 0.0          # the mark of a user function that raised (user_moment)
        q = ib[b]
        up = table[b] if table.shape[0] > 1 else table[0]
        j = k0 // save_every + 1 - out0
        st, kend, it_total, rmax, it, rn = run_chunk_user(
            moment, up, Rs, Ps, cons, mdep, method, Jd[q], J[q], J_inv[q], h, t0, gam, cum, A[ia[b]], R[b], Pi[b],
            G[b], gidx, S[b], codes, params, sym, k0, n, tol, max_iter, alpha, save_every,
            save_every - k0 % save_every, R_out[b, j:], Pi_out[b, j:], it_rec[:n], res_rec[:n], hist, counts)
        record_body(b, its, res, status, fail_step, fail_res, fail_its, it_total, rmax, st, kend, it, rn)
