"""Ensemble stepping: the loop over bodies inside the compiled kernel, parallel over cores.

Each body runs exactly the per-step code of :func:`lgvi.simulate` on its own state: the free
body at order 2 calls :func:`.stepping.lgvi_step` (as :func:`.stepping.run_chunk` does), every
other scheme calls :func:`.stepping.forced_stage` per substep (as
:func:`.stepping.run_chunk_forced` does), with the same arguments in the same order. With IEEE
arithmetic (``fastmath`` is never on) a body of the ensemble therefore follows bit for bit the
trajectory ``simulate`` gives it, whichever thread runs it and however the steps are chunked.

Layout (``B`` bodies, ``s`` substeps per step, ``nb`` distinct bodies)::

    R (B,3,3), Pi (B,3)         state, in place
    G (B,s,4,3)                 solver histories, one per body and substep (see .stepping)
    S (B,7)                     moment caches of the forced scheme (see .stepping)
    ib (B,) int64               body b has inertia number ib[b]
    Jd, J, J_inv (nb,3,3)       per distinct inertia
    A (nb,s,3,3)                symmetric momentum matrices per distinct inertia and substep
    R_out (B,M,3,3), Pi_out (B,M,3)   samples, sample j = state after step j * save_every
    its (B,) int64, res (B,)    solver updates summed, largest final residual (successful steps)
    status, fail_step, fail_its (B,) int64, fail_res (B,)   a failing body stops: solver status,
                                step, the step's iterations and residual

Every array of one body is contiguous, and a thread works through a contiguous block of
bodies, each for a whole chunk of steps with its state in cache; the step loop allocates
nothing (views are made once per body and chunk). Samples may fall anywhere in a chunk: the
chunk start ``k0`` need not be a multiple of ``save_every``.

Each driver comes twice: ``*_parallel`` (``numba.prange`` over bodies) and ``*_serial`` (a plain
loop, used for ``threads=1``, which never touches Numba's threading layer and so is safe to call
from many Python threads at once, as Dask workers do).
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import jit, jit_parallel
from .codes import OK
from .solvers import initial_guess
from .stepping import forced_stage, init_moments, lgvi_step
from .torque_kernels import momentum_diag


@jit
def init_histories(method, J, ib, hs, Pi, G):
    """Cold-start the solver histories: ``G[b, i, 0]`` from the linearisation ``J w = hs[i] Pi[b]``.

    ``G`` (B,s,4,3) must be zero on entry (no valid history). The same values as
    ``integrator._solver_state(method, body, hs[i], Pi[b])``.
    """
    hPi = np.empty(3)
    for b in range(Pi.shape[0]):
        for i in range(hs.shape[0]):
            hPi[0] = hs[i] * Pi[b, 0]
            hPi[1] = hs[i] * Pi[b, 1]
            hPi[2] = hs[i] * Pi[b, 2]
            initial_guess(method, J[ib[b]], hPi, G[b, i, 0])


@jit
def advance_free(b, method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                 its, res, status, fail_step, fail_res, fail_its, hist):
    """Free body, order 2: body ``b`` through steps ``k0 .. k0+n-1`` (see :func:`.stepping.run_chunk`)."""
    Rb = R[b]
    Pib = Pi[b]
    Gb = G[b, 0]
    Jdb = Jd[ib[b]]
    j = k0 // save_every + 1
    countdown = save_every - k0 % save_every
    it_sum = its[b]
    rmax = res[b]
    for k in range(k0, k0 + n):
        it, rn, st = lgvi_step(method, Jdb, h, Rb, Pib, Gb, 0.0, 0.0, 0.0, tol, max_iter, alpha, hist)
        it_sum += it
        if st != OK:
            status[b] = st
            fail_step[b] = k
            fail_res[b] = rn
            fail_its[b] = it
            break
        if rn > rmax:
            rmax = rn
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            for a in range(3):
                Pi_out[b, j, a] = Pib[a]
                for c in range(3):
                    R_out[b, j, a, c] = Rb[a, c]
            j += 1
    its[b] = it_sum
    res[b] = rmax


@jit
def advance_forced(b, method, Jd, J, J_inv, ib, h, t0, gam, cum, A, R, Pi, G, S, codes, params, sym, k0, n, tol,
                   max_iter, alpha, save_every, R_out, Pi_out, its, res, status, fail_step, fail_res, fail_its,
                   hist):
    """Torque model and/or composition: body ``b`` through steps ``k0 .. k0+n-1``.

    The same substeps as :func:`.stepping.run_chunk_forced` (no explicit torque arrays). After a
    failure the body's state is left as the failing substep found it (the ensemble reports only
    samples before the failing step).
    """
    s = gam.shape[0]
    Rb = R[b]
    Pib = Pi[b]
    Gb = G[b]
    Sb = S[b]
    q = ib[b]
    Jdb = Jd[q]
    Jb = J[q]
    Jib = J_inv[q]
    Ab = A[q]
    D0, D1, D2 = momentum_diag(codes, params)
    has_D = D0 != 0.0 or D1 != 0.0 or D2 != 0.0
    if Sb[6] == 0.0:
        init_moments(codes, params, Jb, Jib, t0 + k0 * h, Rb, Pib, Sb, 0.0, 0.0, 0.0)
    j = k0 // save_every + 1
    countdown = save_every - k0 % save_every
    it_sum = its[b]
    rmax = res[b]
    for k in range(k0, k0 + n):
        failed = False
        for i in range(s):
            t1 = t0 + (k + cum[i + 1]) * h
            it, rn, st = forced_stage(method, Jdb, Jb, Jib, gam[i] * h, t1, Rb, Pib, Gb, i, Sb, codes, params,
                                      D0, D1, D2, has_D, Ab, i, sym, 0.0, 0.0, 0.0, tol, max_iter, alpha, hist)
            it_sum += it
            if st != OK:
                status[b] = st
                fail_step[b] = k
                fail_res[b] = rn
                fail_its[b] = it
                failed = True
                break
            if rn > rmax:
                rmax = rn
        if failed:
            break
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            for a in range(3):
                Pi_out[b, j, a] = Pib[a]
                for c in range(3):
                    R_out[b, j, a, c] = Rb[a, c]
            j += 1
    its[b] = it_sum
    res[b] = rmax


@jit_parallel
def run_free_parallel(method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                      its, res, status, fail_step, fail_res, fail_its, hist):
    """Every running body (``status[b] == OK``) through steps ``k0 .. k0+n-1``, bodies in parallel."""
    for b in numba.prange(R.shape[0]):
        if status[b] == OK:
            advance_free(b, method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                         its, res, status, fail_step, fail_res, fail_its, hist)


@jit
def run_free_serial(method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                    its, res, status, fail_step, fail_res, fail_its, hist):
    """:func:`run_free_parallel` on the calling thread only."""
    for b in range(R.shape[0]):
        if status[b] == OK:
            advance_free(b, method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, R_out, Pi_out,
                         its, res, status, fail_step, fail_res, fail_its, hist)


@jit_parallel
def run_forced_parallel(method, Jd, J, J_inv, ib, h, t0, gam, cum, A, R, Pi, G, S, codes, params, sym, k0, n,
                        tol, max_iter, alpha, save_every, R_out, Pi_out, its, res, status, fail_step, fail_res,
                        fail_its, hist):
    """Every running body through steps ``k0 .. k0+n-1`` of the forced/composed scheme, in parallel."""
    for b in numba.prange(R.shape[0]):
        if status[b] == OK:
            advance_forced(b, method, Jd, J, J_inv, ib, h, t0, gam, cum, A, R, Pi, G, S, codes, params, sym, k0,
                           n, tol, max_iter, alpha, save_every, R_out, Pi_out, its, res, status, fail_step,
                           fail_res, fail_its, hist)


@jit
def run_forced_serial(method, Jd, J, J_inv, ib, h, t0, gam, cum, A, R, Pi, G, S, codes, params, sym, k0, n,
                      tol, max_iter, alpha, save_every, R_out, Pi_out, its, res, status, fail_step, fail_res,
                      fail_its, hist):
    """:func:`run_forced_parallel` on the calling thread only."""
    for b in range(R.shape[0]):
        if status[b] == OK:
            advance_forced(b, method, Jd, J, J_inv, ib, h, t0, gam, cum, A, R, Pi, G, S, codes, params, sym, k0,
                           n, tol, max_iter, alpha, save_every, R_out, Pi_out, its, res, status, fail_step,
                           fail_res, fail_its, hist)
