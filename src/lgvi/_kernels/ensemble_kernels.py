"""Ensemble stepping: the loop over bodies inside the compiled kernel, parallel over cores.

Each body runs the same per-step code as :func:`lgvi.simulate` (:func:`.stepping.lgvi_step`) on
its own state, so a body of the ensemble follows exactly the trajectory ``simulate`` gives it.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import jit_parallel
from .solvers import OK
from .stepping import lgvi_step


@jit_parallel
def run_ensemble_chunk(method, Jd, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every,
                       R_out, Pi_out, its, res, status, fail_step):
    """Advance every body ``b`` still running (``status[b] == OK``) by steps ``k0 .. k0+n-1``.

    ``Jd`` (B,3,3), ``R`` (B,3,3), ``Pi`` (B,3), ``G`` (B,4,3) state in/out; samples after step
    ``k`` with ``(k+1) % save_every == 0`` go to ``R_out[b, (k+1)//save_every]``. ``its[b]`` sums
    the solver updates, ``res[b]`` keeps the largest final residual; a failing body gets its
    solver status in ``status[b]`` and the failing step in ``fail_step[b]`` and stops there.
    """
    B = R.shape[0]
    for b in numba.prange(B):
        if status[b] != OK:
            continue
        hist = np.zeros(0)
        Rb = R[b]
        Pib = Pi[b]
        Gb = G[b]
        Jdb = Jd[b]
        for k in range(k0, k0 + n):
            it, rn, st = lgvi_step(method, Jdb, h, Rb, Pib, Gb, 0.0, 0.0, 0.0, tol, max_iter, alpha, hist)
            its[b] += it
            if rn > res[b]:
                res[b] = rn
            if st != OK:
                status[b] = st
                fail_step[b] = k
                break
            if (k + 1) % save_every == 0:
                j = (k + 1) // save_every
                for a in range(3):
                    Pi_out[b, j, a] = Pib[a]
                    for c in range(3):
                        R_out[b, j, a, c] = Rb[a, c]
