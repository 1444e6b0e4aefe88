"""Stepping loop for a torque model the user compiles (:class:`lgvi.torques.Compiled`).

:func:`run_chunk_user` is :func:`.stepping.run_chunk_forced` with one more moment: the user's
``moment(t, R, Pi, params)``, a ``numba.njit`` function passed as an argument, so Numba
specialises the loop for it. Only the substep differs (:func:`user_stage_s`): the built-in substep
:func:`.stepping.forced_stage_s` (with no moments of its own: a ``Compiled`` model has no built-in
terms), then the user's moment at the end point added. The state tuples, the per-step bookkeeping
and the sample store are :func:`.stepping.load_state`, :func:`.stepping.stage_done`,
:func:`.stepping.step_done` and :func:`.stepping.save_state`, written once for both loops. The loop
is compiled without the on-disk cache (a user's function is not importable by a later process) and
with reference counting on (the user's function may return a new array; a loop without reference
counting would leak it). (Calling the built-in substep as a separate compiled function, cached on
disk, halves the compile time of a user's loop but makes a step 1.5 to 1.9 times slower: it stays
inlined.)

The user's moment goes into the conservative part ``P`` when the model has a potential, into
``N`` otherwise. A moment that depends on ``Pi`` (``mdep``) with symmetric forcing makes the
momentum equation ``Pi = b + hs/2 (P + N(Pi))`` implicit; it is solved by fixed-point
iteration (``NOT_CONVERGED`` when it does not converge in ``max_iter`` evaluations).
The user's function receives ``R`` and ``Pi`` in the scratch arrays ``Rs`` (3,3), ``Ps`` (3,);
a moment declared independent of ``Pi`` is evaluated once, at ``Pi = F^T mu`` (``+ hs N_k``
with the paper forcing: the built-in substep's momentum before the user's moment is added).
"""

from __future__ import annotations

import math

from .._jit import jit
from .codes import NOT_CONVERGED, OK
from .solvers import EPS
from .stepping import forced_stage_s, load_state, save_state, stage_done, step_done
from .torque_kernels import model_moments, momentum_diag


@jit(inline="always")
def user_moment(moment, up, Rs, Ps, t, Rt, p0, p1, p2):
    """The user's moment at ``(t, R, Pi)`` as three numbers (a returned tuple or array)."""
    Rs[0, 0], Rs[0, 1], Rs[0, 2], Rs[1, 0], Rs[1, 1], Rs[1, 2], Rs[2, 0], Rs[2, 1], Rs[2, 2] = Rt
    Ps[0] = p0
    Ps[1] = p1
    Ps[2] = p2
    m = moment(t, Rs, Ps, up)
    return float(m[0]), float(m[1]), float(m[2])


@jit(inline="always")
def user_stage_s(moment, up, Rs, Ps, cons, mdep, method, Jd, J, J_inv, hs, t1, Rt, Pt, Mt, G, j, codes, params, A,
                 i_A, sym, tol, max_iter, alpha, hist):
    """One substep: :func:`.stepping.forced_stage_s` with no moments of its own (a ``Compiled``
    model has no built-in terms, hence no damping; the user's moments of the start are in ``Mt``),
    then the user's moment at the end point added (see the module notes). On failure the state
    given and ``G[j]`` unchanged."""
    implicit = sym != 0 and mdep and not cons
    # the oldest solution and the count of G[j], restored if the momentum equation fails after the push
    o0, o1, o2, oc = (G[j, 2, 0], G[j, 2, 1], G[j, 2, 2], G[j, 3, 0]) if implicit else (0.0, 0.0, 0.0, 0.0)
    its, rn, st, R1, Pb, Mb = forced_stage_s(method, Jd, J, J_inv, hs, t1, Rt, Pt, Mt, G, j, codes, params, 0.0, 0.0,
                                             0.0, False, A, i_A, sym, 0.0, 0.0, 0.0, tol, max_iter, alpha, hist)
    if st != OK:
        return its, rn, st, Rt, Pt, Mt
    b0, b1, b2 = Pb
    P0, P1, P2, Q0, Q1, Q2 = Mb
    hh = 0.5 * hs
    if cons or not mdep:
        # a moment of (t, R): it receives Pi = b (F^T mu in the symmetric forcing)
        u0, u1, u2 = user_moment(moment, up, Rs, Ps, t1, R1, b0, b1, b2)
        if cons:
            P0 += u0
            P1 += u1
            P2 += u2
            b0 += hh * P0
            b1 += hh * P1
            b2 += hh * P2
        else:
            Q0 += u0
            Q1 += u1
            Q2 += u2
            if sym:
                b0 += hh * Q0
                b1 += hh * Q1
                b2 += hh * Q2
        return its, rn, st, R1, (b0, b1, b2), (P0, P1, P2, Q0, Q1, Q2)
    if implicit:
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
            unpush_at(G, j, o0, o1, o2, oc)
            return its, ch, NOT_CONVERGED, Rt, Pt, Mt
        # the accepted momentum is the last point where N was evaluated
        b0 = x0
        b1 = x1
        b2 = x2
    u0, u1, u2 = user_moment(moment, up, Rs, Ps, t1, R1, b0, b1, b2)
    Q0 += u0
    Q1 += u1
    Q2 += u2
    return its, rn, st, R1, (b0, b1, b2), (P0, P1, P2, Q0, Q1, Q2)


@jit(inline="always")
def unpush_at(G, j, o0, o1, o2, oc):
    """Undo the last :func:`.stepping.push_at` of ``G[j]``: ``o`` is the oldest solution it dropped,
    ``oc`` the count before it."""
    for i in range(2):
        G[j, i, 0] = G[j, i + 1, 0]
        G[j, i, 1] = G[j, i + 1, 1]
        G[j, i, 2] = G[j, i + 1, 2]
    G[j, 2, 0] = o0
    G[j, 2, 1] = o1
    G[j, 2, 2] = o2
    G[j, 3, 0] = oc


@jit(cache=False)
def init_user_moments(moment, up, Rs, Ps, cons, codes, params, J, J_inv, t, R, Pi, S):
    """Fill the moment cache ``S`` at ``(t, R, Pi)`` (built-in terms plus the user's moment)."""
    Rt = (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2])
    P0, P1, P2, Q0, Q1, Q2 = model_moments(codes, params, J, t, R)
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


@jit(cache=False)
def run_chunk_user(moment, up, Rs, Ps, cons, mdep, method, Jd, J, J_inv, h, t0, gam, cum, A, R, Pi, G, gidx, S,
                   codes, params, sym, k0, n, tol, max_iter, alpha, save_every, countdown, R_out, Pi_out, it_out,
                   res_out, hist, counts):
    """:func:`.stepping.run_chunk_forced` (no torque array) with the user's moment; same outputs.

    The first sample is stored after ``countdown`` steps (``save_every`` when ``k0`` is a multiple
    of it) at ``R_out[0]``, then every ``save_every`` steps.
    """
    s = gam.shape[0]
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
                                                   t1, Rx, Px, Mx, G, gidx[i], codes, params, A, i, sym, tol,
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
