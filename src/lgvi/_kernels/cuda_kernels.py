"""CUDA kernels of the ensembles: one body a GPU thread, running the CPU kernels' own per-body code.

Each kernel is a thin launch wrapper: thread ``b`` runs exactly the function the CPU ensemble's
``prange`` loop runs for body ``b`` (:func:`.ensemble_kernels.advance_free`,
:func:`.ensemble_kernels.advance_forced`, :func:`.user_kernels.advance_user`). Those are ``@jit``
functions of the CPU layer; Numba's CUDA target compiles their Python source (and everything they
call: the solvers, the stepping helpers, the torque models, a user's ``numba.njit`` moment) again
as device functions. There is no second copy of the physics here: a change of a kernel changes
both targets.

Importing this module imports ``numba.cuda`` (the core never does: :mod:`lgvi.gpu` imports this
module when a run asks for ``device="cuda"``). Under ``NUMBA_ENABLE_CUDASIM=1`` the kernels run in
Numba's CUDA simulator, where the per-body functions run as the CPU's compiled code.
"""

from __future__ import annotations

import numba
from numba import cuda

from .codes import OK
from .ensemble_kernels import advance_forced, advance_free
from .user_kernels import advance_user


@cuda.jit
def free_kernel(method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, out0, R_out, Pi_out, its, res,
                status, fail_step, fail_res, fail_its, hist):
    """Free body, order 2: thread ``b`` runs :func:`.ensemble_kernels.advance_free` for body ``b``."""
    b = cuda.grid(1)
    if b < R.shape[0] and status[b] == OK:
        advance_free(b, method, Jd, ib, h, R, Pi, G, k0, n, tol, max_iter, alpha, save_every, out0, R_out, Pi_out,
                     its, res, status, fail_step, fail_res, fail_its, hist)


@cuda.jit
def forced_kernel(method, Jd, J, J_inv, ib, h, t0, gam, cum, ia, A, R, Pi, G, gidx, S, codes, params, sym, k0, n, tol,
                  max_iter, alpha, save_every, out0, R_out, Pi_out, it_rec, res_rec, its, res, status, fail_step,
                  fail_res, fail_its, hist, counts):
    """Torque models and compositions: thread ``b`` runs :func:`.ensemble_kernels.advance_forced` with
    its row of the record scratch ``it_rec``, ``res_rec`` (B, r)."""
    b = cuda.grid(1)
    if b < R.shape[0] and status[b] == OK:
        advance_forced(b, b + 1, method, Jd, J, J_inv, ib, h, t0, gam, cum, ia, A, R, Pi, G, gidx, S, codes, params,
                       sym, k0, n, tol, max_iter, alpha, save_every, out0, R_out, Pi_out, it_rec[b], res_rec[b], its,
                       res, status, fail_step, fail_res, fail_its, hist, counts)


def user_kernel(moment):
    """A kernel for the user's compiled ``moment`` (:class:`lgvi.torques.Compiled`; on the GPU the user's
    function itself, in the simulator, which runs the CPU's compiled code, the CPU loops'
    :func:`.user_kernels.guarded` ``cfunc`` of it): thread ``b`` runs :func:`.user_kernels.advance_user`
    with scratch ``R``, ``Pi`` in its local memory and its row of the record scratch ``it_rec``,
    ``res_rec`` (B, r).

    A CUDA kernel cannot take a function as an argument, so the function is a free variable of the
    kernel, which is made (and compiled on its first launch) once per function.
    """

    @cuda.jit
    def kernel(table, cons, mdep, method, Jd, J, J_inv, ib, h, t0, gam, cum, ia, A, R, Pi, G, gidx, S, codes, params,
               sym, k0, n, tol, max_iter, alpha, save_every, out0, R_out, Pi_out, it_rec, res_rec, its, res, status,
               fail_step, fail_res, fail_its, hist, counts):
        b = cuda.grid(1)
        if b < R.shape[0] and status[b] == OK:
            Rs = cuda.local.array((3, 3), numba.float64)
            Ps = cuda.local.array(3, numba.float64)
            advance_user(b, b + 1, moment, table, Rs, Ps, cons, mdep, method, Jd, J, J_inv, ib, h, t0, gam, cum, ia,
                         A, R, Pi, G, gidx, S, codes, params, sym, k0, n, tol, max_iter, alpha, save_every, out0,
                         R_out, Pi_out, it_rec[b], res_rec[b], its, res, status, fail_step, fail_res, fail_its, hist,
                         counts)

    return kernel
