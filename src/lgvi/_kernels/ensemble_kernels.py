"""Ensemble stepping: the loop over bodies inside the compiled kernel, parallel over cores.

Each body runs exactly the per-step code of :func:`lgvi.simulate` on its own state: the free
body at order 2 runs :func:`.stepping.free_steps` (the loop of :func:`.stepping.run_chunk`), every
other scheme calls :func:`.stepping.run_chunk_forced` itself on the body's views
(:func:`advance_forced`). With IEEE
arithmetic (``fastmath`` is never on) a body of the ensemble therefore follows bit for bit the
trajectory ``simulate`` gives it, whichever thread runs it and however the steps are chunked.
The free body with the Cayley solver has a third path, :func:`run_lockstep_parallel`: groups of
``LANES`` bodies step in lockstep in SIMD registers, with the same operations per lane (see the
notes before :data:`LANES`).

Layout (``B`` bodies, ``s`` substeps per step, ``nb`` distinct bodies)::

    R (B,3,3), Pi (B,3)         state, in place
    G (B,s,5,3)                 solver histories, one per body and substep (see .stepping)
    S (B,7)                     moment caches of the forced scheme (see .stepping)
    ib (B,) int64               body b has inertia number ib[b]
    Jd, J, J_inv (nb,3,3)       per distinct inertia
    params (1,P) or (B,P)       torque model parameters: one row for all bodies, or one per body
                                (codes (n,2), the kinds, are the same for all; see .torque_kernels)
    ia (B,) int64               body b uses the momentum matrices A[ia[b]]
    A (na,s,3,3)                symmetric momentum matrices per distinct (inertia, damping) and substep
    R_out (B,M,3,3), Pi_out (B,M,3)   samples, sample j = state after step j * save_every
    its (B,) int64, res (B,)    solver updates summed, largest final residual (successful steps)
    status, fail_step, fail_its (B,) int64, fail_res (B,)   a failing body stops: solver status,
                                step, the step's iterations and residual

Every array of one body is contiguous, and a thread works through a contiguous block of
bodies, each for a whole chunk of steps with its state in cache; the step loop allocates
nothing (views are made once per body and chunk). Samples may fall anywhere in a chunk: the
chunk start ``k0`` need not be a multiple of ``save_every``.

The free body's drivers come twice: ``*_parallel`` (``numba.prange`` over bodies or groups) and
``*_serial`` (a plain loop, used for ``threads=1``, which never touches Numba's threading layer and so
is safe to call from many Python threads at once, as Dask workers do). The forced scheme has one,
:func:`advance_forced` (a plain loop over a range of bodies), which the CPU ensemble calls from a
pool of Python threads, one range each, and the GPU's kernel for one body a thread (see its notes).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import jit, jit_parallel
from .codes import OK
from .solvers import CHEBYSHEV_MIN, cofactors3, initial_guess
from .stepping import free_steps, lgvi_step, run_chunk_forced


@jit(_nrt=False)
def init_histories(method, J, ib, hs, Pi, G):
    """Cold-start the solver histories: ``G[b, i, 0]`` from the linearisation ``J w = hs[i] Pi[b]``.

    ``G`` (B,s,5,3) must be zero on entry (no valid history). The same values as
    ``integrator._solver_state(method, body, hs[i], Pi[b])``.
    """
    for b in range(Pi.shape[0]):
        for i in range(hs.shape[0]):
            # h Pi in the (still zero) history row 1, not in an array of its own: no allocation, so
            # the first call compiles no array constructor
            hPi = G[b, i, 1]
            hPi[0] = hs[i] * Pi[b, 0]
            hPi[1] = hs[i] * Pi[b, 1]
            hPi[2] = hs[i] * Pi[b, 2]
            initial_guess(method, J[ib[b]], hPi, G[b, i, 0])
            hPi[0] = 0.0
            hPi[1] = 0.0
            hPi[2] = 0.0


@jit(inline="always")
def record_body(b, its, res, status, fail_step, fail_res, fail_its, it_sum, rmax, st, k, it, rn):
    """Add a chunk's solver work ``it_sum`` and largest residual ``rmax`` to body ``b``'s records; on a
    failure (``st``) record its status, the failed step ``k`` and that step's iterations and residual."""
    its[b] += it_sum
    if rmax > res[b]:
        res[b] = rmax
    if st != OK:
        status[b] = st
        fail_step[b] = k
        fail_res[b] = rn
        fail_its[b] = it


@jit(_nrt=False)
def advance_free(b, method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, out0, R_out, Pi_out,
                 its, res, status, fail_step, fail_res, fail_its, hist):
    """Free body, order 2: body ``b`` through steps ``k0 .. k0+n-1`` (the loop of
    :func:`.stepping.run_chunk`, without per-step records). ``R_out[:, 0]`` holds sample ``out0``
    (0: the buffers hold the whole run; the GPU's chunk buffers start at the chunk's first sample)."""
    st, k, it_sum, rmax, it, rn = free_steps(method, Jd[ib[b]], h, R[b], Pi[b], G[b, 0], hist[:0, None], k0, n,
                                             tol, max_iter, alpha, save_every, save_every - k0 % save_every,
                                             k0 // save_every + 1 - out0, R_out[b], Pi_out[b], 0, hist, hist, hist,
                                             fail_its[:0])
    record_body(b, its, res, status, fail_step, fail_res, fail_its, it_sum, rmax, st, k, it, rn)


@jit_parallel
def run_free_parallel(method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                      its, res, status, fail_step, fail_res, fail_its, hist):
    """Every running body (``status[b] == OK``) through steps ``k0 .. k0+n-1``, bodies in parallel."""
    for b in numba.prange(R.shape[0]):
        if status[b] == OK:
            # np.int64: the prange index is uint64 in the compiled loop body but int64 when Numba
            # first types the loop, so a bare ``b`` compiles the per-body kernel twice
            advance_free(np.int64(b), method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, 0,
                         R_out, Pi_out, its, res, status, fail_step, fail_res, fail_its, hist)


@jit
def run_free_serial(method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                    its, res, status, fail_step, fail_res, fail_its, hist):
    """:func:`run_free_parallel` on the calling thread only."""
    for b in range(R.shape[0]):
        if status[b] == OK:
            advance_free(b, method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, 0, R_out, Pi_out,
                         its, res, status, fail_step, fail_res, fail_its, hist)


@jit(_nrt=False)
def advance_forced(b0, b1, method, Jd, J, J_inv, ib, h, t0, gam, cum, ia, A, R, Pi, G, gidx, S, codes, params, sym, k0,
                   n, tol, max_iter, alpha, save_every, out0, R_out, Pi_out, it_rec, res_rec, its, res, status,
                   fail_step, fail_res, fail_its, hist, counts):
    """Torque model and/or composition: the bodies ``b0 .. b1-1`` whose status is still ``OK`` through
    steps ``k0 .. k0+n-1`` of :func:`.stepping.run_chunk_forced` itself (no explicit torque arrays),
    each with its views and its parameter row (``params[b]``, or ``params[0]`` for all): the loop
    :func:`lgvi.simulate` compiles, of the same types, so a cold ensemble compiles only this call
    around it and a cached loop serves both. ``gidx`` (s,) int64 is ``0 .. s-1`` (one solver history
    per substep); ``it_rec``, ``res_rec`` are the caller's scratch for the solver's record (``n``
    entries, or the chunk's samples; not kept: the ensemble keeps totals), ``counts`` an empty int64
    array. After a failure the body's state is that at the start of the failed step (as in
    ``simulate``). ``R_out[:, 0]`` holds sample ``out0`` (see :func:`advance_free`).

    The CPU ensemble runs its bodies in contiguous ranges, one Python thread a range (the kernel
    releases the GIL; each thread has its own scratch), rather than in a ``numba.prange`` loop
    (up to ``PER_BODY_CALLS_MAX`` bodies, 64, the ensemble calls :func:`.stepping.run_chunk_forced` once a
    body from Python with this loop's arguments instead, so a small ensemble's first call compiles
    nothing that :func:`lgvi.simulate` does not):
    Numba's parallel compilation of such a loop (its type inference and parfor lowering) was more
    than half of an ensemble's cold first call. The GPU's kernel runs one body a thread
    (``b1 = b0 + 1``). The step loop is called from here directly: a call of a compiled function
    links the callee's code into the caller, where LLVM optimises all of it again, so each level of
    calls between this loop and :func:`.stepping.run_chunk_forced` would cost one more optimisation
    of the step loop.
    """
    for b in range(b0, b1):
        if status[b] != OK:
            continue
        q = ib[b]
        pb = params[b] if params.shape[0] > 1 else params[0]
        j = k0 // save_every + 1 - out0
        st, kend, it_total, rmax, it, rn = run_chunk_forced(
            method, Jd[q], J[q], J_inv[q], h, t0, gam, cum, A[ia[b]], R[b], Pi[b], G[b], gidx, S[b], codes, pb,
            hist[:0, None], sym, k0, n, tol, max_iter, alpha, save_every, save_every - k0 % save_every, R_out[b, j:],
            Pi_out[b, j:], it_rec, res_rec, hist, counts)
        record_body(b, its, res, status, fail_step, fail_res, fail_its, it_total, rmax, st, kend, it, rn)


# ------------------------------------------------------------------------------------------------
# Lockstep path: free body, Cayley, order 2, LANES bodies per group in SIMD registers
# ------------------------------------------------------------------------------------------------
#
# The scalar step runs near the core's scalar floating-point throughput; the remaining lever for
# an ensemble is SIMD across bodies. Bodies are packed in groups of LANES, structure of arrays
# X (ngroups, NF * LANES): field f of lane l at f * LANES + l. With LANES a compile-time constant
# every access of a lane loop sits at a constant offset from the group's start, so LLVM proves the
# fields do not overlap and vectorises the loop over lanes, which has no branches (AVX2: four
# doubles per instruction). Every lane evaluates the same IEEE operations, in the same order, as
# the scalar path (lgvi_step -> solve_scalar with eager=True: predict, one Cayley Newton update
# with its third-order correction, the residual check, R <- R (I + E), Pi <- (I + E)^T Pi compensated);
# without fast-math LLVM neither reassociates nor fuses a * b + c, so a lane's result is bit for
# bit the scalar one. A lane that the one update does not settle (its residual above the round-off
# floor: more iterations needed, or a singular or
# non-finite Newton matrix) is left untouched by the vector step and redone by the scalar
# lgvi_step from the same state, which then decides exactly as simulate does. The expressions
# below must stay those of solvers.solve_scalar and stepping.lgvi_step; tests/test_ensemble.py
# checks the equality for every solver path.

LANES = 8
# fields: X[g, f * LANES + lane]
X_R = 0        # R row-major (9)
X_PI = 9       # Pi (3)
X_G = 12       # solver history rows 0..2 (9), row-major as G[0:3, :]
X_N = 21       # number of valid history rows, G[3, 0]
X_D = 22       # d00, d01, d02, d11, d12, d22 (6)
X_ALIVE = 28   # 1.0 while the body runs
X_RMAX = 29    # largest residual so far
X_OK = 30      # 1.0 when the last vector step settled this lane
X_ITS = 31     # solver updates so far (a float counts exactly to 2^53)
X_L = 32       # low part of Pi (3), G[4, :] (compensated momentum update, stepping.momentum_c)
NF = 35
EPS = 2.220446049250313e-16


@jit
def lockstep_cayley(X, h, tol, alpha):
    """One Cayley step of every lane of the group ``X`` (NF * LANES,) that it settles (see notes).

    Returns the number of running lanes it did not settle (``X_OK`` zero), to be redone by
    the scalar step.
    """
    u0 = 0.0
    bad = 0
    for l in range(LANES):
        d00 = X[X_D * LANES + l]
        d01 = X[(X_D + 1) * LANES + l]
        d02 = X[(X_D + 2) * LANES + l]
        d11 = X[(X_D + 3) * LANES + l]
        d12 = X[(X_D + 4) * LANES + l]
        d22 = X[(X_D + 5) * LANES + l]
        b0 = X[X_PI * LANES + l]
        b1 = X[(X_PI + 1) * LANES + l]
        b2 = X[(X_PI + 2) * LANES + l]
        l0 = X[X_L * LANES + l]
        l1 = X[(X_L + 1) * LANES + l]
        l2 = X[(X_L + 2) * LANES + l]
        p0 = h * b0
        p1 = h * b1
        p2 = h * b2
        # predict (stepping.predict)
        n = X[X_N * LANES + l]
        G00 = X[X_G * LANES + l]
        G01 = X[(X_G + 1) * LANES + l]
        G02 = X[(X_G + 2) * LANES + l]
        G10 = X[(X_G + 3) * LANES + l]
        G11 = X[(X_G + 4) * LANES + l]
        G12 = X[(X_G + 5) * LANES + l]
        G20 = X[(X_G + 6) * LANES + l]
        G21 = X[(X_G + 7) * LANES + l]
        G22 = X[(X_G + 8) * LANES + l]
        e0 = 3.0 * (G00 - G10) + G20
        e1 = 3.0 * (G01 - G11) + G21
        e2 = 3.0 * (G02 - G12) + G22
        f0 = 2.0 * G00 - G10
        f1 = 2.0 * G01 - G11
        f2 = 2.0 * G02 - G12
        three = n >= 3.0
        two = n >= 2.0
        g0 = e0 if three else (f0 if two else G00)
        g1 = e1 if three else (f1 if two else G01)
        g2 = e2 if three else (f2 if two else G02)
        # solvers.solve_scalar, METHOD_CAYLEY, eager: one update, then the check
        tr = d00 + d11 + d22
        j00 = tr - d00
        j11 = tr - d11
        j22 = tr - d22
        hn2 = p0 * p0 + p1 * p1 + p2 * p2
        hn = math.sqrt(hn2)
        jdn = math.sqrt(d00 * d00 + d11 * d11 + d22 * d22 + 2.0 * (d01 * d01 + d02 * d02 + d12 * d12))
        pf = p0 * g0 + p1 * g1 + p2 * g2
        q0 = -(p0 + (p1 * g2 - p2 * g1) + pf * g0 - 2.0 * (j00 * g0 - d01 * g1 - d02 * g2))
        q1 = -(p1 + (p2 * g0 - p0 * g2) + pf * g1 - 2.0 * (-d01 * g0 + j11 * g1 - d12 * g2))
        q2 = -(p2 + (p0 * g1 - p1 * g0) + pf * g2 - 2.0 * (-d02 * g0 - d12 * g1 + j22 * g2))
        m00 = pf + g0 * p0 - 2.0 * j00
        m01 = -p2 + g0 * p1 + 2.0 * d01
        m02 = p1 + g0 * p2 + 2.0 * d02
        m10 = p2 + g1 * p0 + 2.0 * d01
        m11 = pf + g1 * p1 - 2.0 * j11
        m12 = -p0 + g1 * p2 + 2.0 * d12
        m20 = -p1 + g2 * p0 + 2.0 * d02
        m21 = p0 + g2 * p1 + 2.0 * d12
        m22 = pf + g2 * p2 - 2.0 * j22
        c00, c01, c02, c10, c11, c12, c20, c21, c22, det = cofactors3(m00, m01, m02, m10, m11, m12, m20, m21, m22)
        inv = 1.0 / det
        s0 = (c00 * q0 + c10 * q1 + c20 * q2) * inv
        s1 = (c01 * q0 + c11 * q1 + c21 * q2) * inv
        s2 = (c02 * q0 + c12 * q1 + c22 * q2) * inv
        cheb = s0 * s0 + s1 * s1 + s2 * s2 > CHEBYSHEV_MIN
        ps = (p0 * s0 + p1 * s1 + p2 * s2) * inv
        ch0 = s0 - ps * (c00 * s0 + c10 * s1 + c20 * s2)
        ch1 = s1 - ps * (c01 * s0 + c11 * s1 + c21 * s2)
        ch2 = s2 - ps * (c02 * s0 + c12 * s1 + c22 * s2)
        s0 = ch0 if cheb else s0
        s1 = ch1 if cheb else s1
        s2 = ch2 if cheb else s2
        g0 += alpha * s0
        g1 += alpha * s1
        g2 += alpha * s2
        t2 = g0 * g0 + g1 * g1 + g2 * g2
        a = 2.0 / (1.0 + t2)
        b = a
        enorm = 2.0 * math.sqrt(b * t2)
        # solvers.expm1_entries
        xx = g0 * g0
        yy = g1 * g1
        zz = g2 * g2
        bxy = b * g0 * g1
        bxz = b * g0 * g2
        byz = b * g1 * g2
        E00 = -b * (yy + zz)
        E01 = -a * g2 + bxy
        E02 = a * g1 + bxz
        E10 = a * g2 + bxy
        E11 = -b * (xx + zz)
        E12 = -a * g0 + byz
        E20 = -a * g1 + bxz
        E21 = a * g0 + byz
        E22 = -b * (xx + yy)
        x01 = E00 * d01 + E01 * d11 + E02 * d12
        x02 = E00 * d02 + E01 * d12 + E02 * d22
        x10 = E10 * d00 + E11 * d01 + E12 * d02
        x12 = E10 * d02 + E11 * d12 + E12 * d22
        x20 = E20 * d00 + E21 * d01 + E22 * d02
        x21 = E20 * d01 + E21 * d11 + E22 * d12
        r0 = (x21 - x12) - p0
        r1 = (x02 - x20) - p1
        r2 = (x10 - x01) - p2
        rn2 = r0 * r0 + r1 * r1 + r2 * r2
        floor = 8.0 * EPS * (jdn * enorm + hn)
        thr = tol * hn + floor
        alive = X[X_ALIVE * LANES + l] != 0.0
        # settled only where every test of the scalar solver passes (a finite Newton matrix, iterate,
        # residual and threshold, and the residual at the round-off floor: within tol but above it,
        # the scalar solver polishes once more); anything else goes to the scalar step
        ok = ((rn2 <= floor * floor) & (rn2 < math.inf) & (thr < math.inf) & (t2 < math.inf) & (det != 0.0)
              & (abs(det) < math.inf) & alive)
        bad += 1 if (alive and not ok) else 0
        # stepping.push
        X[(X_G + 6) * LANES + l] = G10 if ok else G20
        X[(X_G + 7) * LANES + l] = G11 if ok else G21
        X[(X_G + 8) * LANES + l] = G12 if ok else G22
        X[(X_G + 3) * LANES + l] = G00 if ok else G10
        X[(X_G + 4) * LANES + l] = G01 if ok else G11
        X[(X_G + 5) * LANES + l] = G02 if ok else G12
        X[X_G * LANES + l] = g0 if ok else G00
        X[(X_G + 1) * LANES + l] = g1 if ok else G01
        X[(X_G + 2) * LANES + l] = g2 if ok else G02
        X[X_N * LANES + l] = (n + 1.0 if n < 3.0 else n) if ok else n
        # R <- R (I + E)
        for i in range(3):
            a0 = X[(X_R + 3 * i) * LANES + l]
            a1 = X[(X_R + 3 * i + 1) * LANES + l]
            a2 = X[(X_R + 3 * i + 2) * LANES + l]
            y0 = a0 + a0 * E00 + a1 * E10 + a2 * E20
            y1 = a1 + a0 * E01 + a1 * E11 + a2 * E21
            y2 = a2 + a0 * E02 + a1 * E12 + a2 * E22
            X[(X_R + 3 * i) * LANES + l] = y0 if ok else a0
            X[(X_R + 3 * i + 1) * LANES + l] = y1 if ok else a1
            X[(X_R + 3 * i + 2) * LANES + l] = y2 if ok else a2
        # Pi <- (I + E)^T Pi + h u, compensated (stepping.momentum_c)
        v0 = ((E00 * b0 + E10 * b1 + E20 * b2) + h * u0) + l0
        v1 = ((E01 * b0 + E11 * b1 + E21 * b2) + h * u0) + l1
        v2 = ((E02 * b0 + E12 * b1 + E22 * b2) + h * u0) + l2
        z0 = b0 + v0
        z1 = b1 + v1
        z2 = b2 + v2
        X[X_PI * LANES + l] = z0 if ok else b0
        X[(X_PI + 1) * LANES + l] = z1 if ok else b1
        X[(X_PI + 2) * LANES + l] = z2 if ok else b2
        X[X_L * LANES + l] = ((b0 - z0) + v0) if ok else l0
        X[(X_L + 1) * LANES + l] = ((b1 - z1) + v1) if ok else l1
        X[(X_L + 2) * LANES + l] = ((b2 - z2) + v2) if ok else l2
        rn = math.sqrt(rn2)
        rmax = X[X_RMAX * LANES + l]
        X[X_RMAX * LANES + l] = rn if (ok & (rn > rmax)) else rmax
        X[X_OK * LANES + l] = 1.0 if ok else 0.0
        X[X_ITS * LANES + l] += 1.0 if ok else 0.0
    return bad


@jit
def pack_groups(R, Pi, G, Jd, ib, status, its, res, X):
    """Fill the groups ``X`` (ngroups, NF * LANES) from the per-body state; padding lanes copy the
    last body and never run."""
    B = R.shape[0]
    for gi in range(X.shape[0]):
        for l in range(LANES):
            b = gi * LANES + l
            src = b if b < B else B - 1
            for i in range(3):
                X[gi, (X_PI + i) * LANES + l] = Pi[src, i]
                for c in range(3):
                    X[gi, (X_R + 3 * i + c) * LANES + l] = R[src, i, c]
                    X[gi, (X_G + 3 * i + c) * LANES + l] = G[src, 0, i, c]
            X[gi, X_N * LANES + l] = G[src, 0, 3, 0]
            for i in range(3):
                X[gi, (X_L + i) * LANES + l] = G[src, 0, 4, i]
            q = ib[src]
            X[gi, X_D * LANES + l] = Jd[q, 0, 0]
            X[gi, (X_D + 1) * LANES + l] = Jd[q, 0, 1]
            X[gi, (X_D + 2) * LANES + l] = Jd[q, 0, 2]
            X[gi, (X_D + 3) * LANES + l] = Jd[q, 1, 1]
            X[gi, (X_D + 4) * LANES + l] = Jd[q, 1, 2]
            X[gi, (X_D + 5) * LANES + l] = Jd[q, 2, 2]
            X[gi, X_ALIVE * LANES + l] = 1.0 if (b < B and status[src] == OK) else 0.0
            X[gi, X_RMAX * LANES + l] = res[src]
            X[gi, X_OK * LANES + l] = 0.0
            X[gi, X_ITS * LANES + l] = float(its[src])


@jit
def advance_group(gi, X, Jd, ib, method, h, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out, its, res,
                  status, fail_step, fail_res, fail_its, hist):
    """Group ``gi`` of ``X`` through steps ``k0 .. k0+n-1`` of the free-body Cayley step in lockstep,
    lanes the vector step does not settle redone by :func:`.stepping.lgvi_step`."""
    B = R_out.shape[0]
    Xg = X[gi]
    alive = 0
    for l in range(LANES):
        if Xg[X_ALIVE * LANES + l] != 0.0:
            alive += 1
    if alive == 0:
        return
    Rs = np.empty((3, 3))
    Ps = np.empty(3)
    Gs = np.zeros((5, 3))
    j = k0 // save_every + 1
    countdown = save_every - k0 % save_every
    for k in range(k0, k0 + n):
        bad = lockstep_cayley(Xg, h, tol, alpha)
        if bad > 0:
            for l in range(LANES):
                if Xg[X_ALIVE * LANES + l] == 0.0 or Xg[X_OK * LANES + l] != 0.0:
                    continue
                b = gi * LANES + l
                for i in range(3):
                    Ps[i] = Xg[(X_PI + i) * LANES + l]
                    for c in range(3):
                        Rs[i, c] = Xg[(X_R + 3 * i + c) * LANES + l]
                        Gs[i, c] = Xg[(X_G + 3 * i + c) * LANES + l]
                Gs[3, 0] = Xg[X_N * LANES + l]
                for i in range(3):
                    Gs[4, i] = Xg[(X_L + i) * LANES + l]
                it, rn, st = lgvi_step(method, Jd[ib[b]], h, Rs, Ps, Gs, 0.0, 0.0, 0.0, tol, max_iter, alpha, hist)
                Xg[X_ITS * LANES + l] += it
                if st != OK:
                    status[b] = st
                    fail_step[b] = k
                    fail_res[b] = rn
                    fail_its[b] = it
                    Xg[X_ALIVE * LANES + l] = 0.0
                    alive -= 1
                    continue
                if rn > Xg[X_RMAX * LANES + l]:
                    Xg[X_RMAX * LANES + l] = rn
                for i in range(3):
                    Xg[(X_PI + i) * LANES + l] = Ps[i]
                    for c in range(3):
                        Xg[(X_R + 3 * i + c) * LANES + l] = Rs[i, c]
                        Xg[(X_G + 3 * i + c) * LANES + l] = Gs[i, c]
                Xg[X_N * LANES + l] = Gs[3, 0]
                for i in range(3):
                    Xg[(X_L + i) * LANES + l] = Gs[4, i]
            if alive == 0:
                break
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            for l in range(LANES):
                if Xg[X_ALIVE * LANES + l] != 0.0:
                    b = gi * LANES + l
                    for i in range(3):
                        Pi_out[b, j, i] = Xg[(X_PI + i) * LANES + l]
                        for c in range(3):
                            R_out[b, j, i, c] = Xg[(X_R + 3 * i + c) * LANES + l]
            j += 1
    for l in range(LANES):
        b = gi * LANES + l
        if b < B:
            its[b] = np.int64(Xg[X_ITS * LANES + l])
            res[b] = Xg[X_RMAX * LANES + l]


@jit_parallel
def run_lockstep_parallel(X, Jd, ib, method, h, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out, its, res,
                          status, fail_step, fail_res, fail_its, hist):
    """Every group through steps ``k0 .. k0+n-1`` (free body, Cayley), groups in parallel."""
    for gi in numba.prange(X.shape[0]):
        advance_group(np.int64(gi), X, Jd, ib, method, h, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                      its, res, status, fail_step, fail_res, fail_its, hist)      # np.int64: see run_free_parallel


@jit
def run_lockstep_serial(X, Jd, ib, method, h, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out, its, res,
                        status, fail_step, fail_res, fail_its, hist):
    """:func:`run_lockstep_parallel` on the calling thread only."""
    for gi in range(X.shape[0]):
        advance_group(gi, X, Jd, ib, method, h, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out, its, res,
                      status, fail_step, fail_res, fail_its, hist)


@jit
def unpack_groups(X, R, Pi):
    """Copy the attitudes and momenta of the groups ``X`` back to ``R`` (B,3,3) and ``Pi`` (B,3)."""
    B = R.shape[0]
    for gi in range(X.shape[0]):
        for l in range(LANES):
            b = gi * LANES + l
            if b >= B:
                break
            for i in range(3):
                Pi[b, i] = X[gi, (X_PI + i) * LANES + l]
                for c in range(3):
                    R[b, i, c] = X[gi, (X_R + 3 * i + c) * LANES + l]
