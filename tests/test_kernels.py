"""The fast free-body loop against the single-step kernel it unrolls, bit for bit.

:func:`lgvi._kernels.stepping.free_steps` keeps the state in local variables and the Cayley chunk
kernel is compiled with the method as a constant; both are speed measures only, so every sample,
iteration count, residual and the solver history they leave must be exactly those of
:func:`lgvi._kernels.stepping.lgvi_step` applied step by step on the same arrays.
"""

from __future__ import annotations

import numpy as np
import pytest

from lgvi._kernels.codes import METHOD_CAYLEY, METHOD_NEWTON, METHOD_PAPER, OK, OVERFLOW
from lgvi._kernels.stepping import lgvi_step, run_chunk, run_chunk_cayley, run_chunk_newton

NO_HIST = np.zeros(0)


def _start(body, code, h, Pi0):
    G = np.zeros((5, 3))
    G[0] = np.linalg.solve(body.J, h * Pi0) * (0.5 if code == METHOD_CAYLEY else 1.0)
    G[3, 0] = 1.0
    return G


def _by_single_steps(body, code, h, R0, Pi0, U, n):
    R, Pi, G = R0.copy(), Pi0.copy(), _start(body, code, h, Pi0)
    Rs, Ps, its, res = [], [], [], []
    for k in range(n):
        u = U[k] if U.shape[0] else np.zeros(3)
        it, rn, st = lgvi_step(code, body.Jd, h, R, Pi, G, u[0], u[1], u[2], 1e-14, 50, 1.0, NO_HIST)
        assert st == OK
        Rs.append(R.copy())
        Ps.append(Pi.copy())
        its.append(it)
        res.append(rn)
    return np.array(Rs), np.array(Ps), np.array(its), np.array(res), G


def _by_chunks(kernel, body, code, h, R0, Pi0, U, n, chunk, save_every, per_interval=False, counts=None):
    """Run in chunks; the record per step, or with ``per_interval`` per saved interval."""
    R, Pi, G = R0.copy(), Pi0.copy(), _start(body, code, h, Pi0)
    R_out = np.full((n // save_every, 3, 3), np.nan)
    Pi_out = np.full((n // save_every, 3), np.nan)
    per = save_every if per_interval else 1
    its = np.full(n // per, -1, np.int32)
    res = np.full(n // per, np.nan)
    counts = np.zeros(0, np.int64) if counts is None else counts
    for k0 in range(0, n, chunk):
        m = min(chunk, n - k0)
        j0 = k0 // save_every
        r0, r1 = k0 // per, (k0 + m) // per
        st, k, *_ = kernel(code, body.Jd, h, R, Pi, G, U, k0, m, 1e-14, 50, 1.0, save_every,
                           R_out[j0:j0 + m // save_every], Pi_out[j0:j0 + m // save_every], its[r0:r1],
                           res[r0:r1], NO_HIST, counts)
        assert (st, k) == (OK, k0 + m)
    return R_out, Pi_out, its, res, G, R, Pi


@pytest.mark.parametrize("torque", [False, True], ids=["free", "torque"])
@pytest.mark.parametrize("code", [METHOD_PAPER, METHOD_NEWTON, METHOD_CAYLEY], ids=["paper", "newton", "cayley"])
def test_chunk_loop_is_the_single_step_bit_for_bit(code, torque, full_body, R0):
    n, h = 240, 0.05
    Pi0 = full_body.J @ np.array([0.3, 1.0, 0.2])
    U = 0.3 * np.random.default_rng(5).standard_normal((n, 3)) if torque else np.zeros((0, 3))
    Rs, Ps, its, res, G = _by_single_steps(full_body, code, h, R0, Pi0, U, n)
    kernels = [run_chunk] + {METHOD_CAYLEY: [run_chunk_cayley], METHOD_NEWTON: [run_chunk_newton]}.get(code, [])
    for kernel in kernels:
        for chunk, save_every in ((n, 1), (48, 1), (60, 3), (240, 8)):
            R_out, Pi_out, it_c, res_c, G_c, R_end, Pi_end = _by_chunks(kernel, full_body, code, h, R0, Pi0, U, n,
                                                                        chunk, save_every)
            np.testing.assert_array_equal(R_out, Rs[save_every - 1::save_every])
            np.testing.assert_array_equal(Pi_out, Ps[save_every - 1::save_every])
            np.testing.assert_array_equal(it_c, its)
            np.testing.assert_array_equal(res_c, res)
            np.testing.assert_array_equal(G_c, G)          # the warm-start history carries over exactly
            np.testing.assert_array_equal(R_end, Rs[-1])
            np.testing.assert_array_equal(Pi_end, Ps[-1])
            # the record per saved interval: the largest of each interval, and the histogram of every step
            counts = np.zeros(4, np.int64)
            R_i, Pi_i, it_i, res_i, G_i, _, _ = _by_chunks(kernel, full_body, code, h, R0, Pi0, U, n, chunk,
                                                           save_every, per_interval=True, counts=counts)
            np.testing.assert_array_equal(R_i, R_out)
            np.testing.assert_array_equal(G_i, G)
            np.testing.assert_array_equal(it_i, its.reshape(-1, save_every).max(axis=1))
            np.testing.assert_array_equal(res_i, res.reshape(-1, save_every).max(axis=1))
            np.testing.assert_array_equal(counts, np.bincount(np.minimum(its, 3), minlength=4))


@pytest.mark.parametrize("kernel", [run_chunk, run_chunk_cayley], ids=["run_chunk", "run_chunk_cayley"])
def test_chunk_loop_failure_keeps_the_state_before_the_step(kernel, diag_body):
    """A moment that overflows the momentum stops the loop at that step, state as before it."""
    n, h = 10, 0.01
    Pi0 = diag_body.J @ np.array([0.3, 1.0, 0.2])
    U = np.zeros((n, 3))
    U[6, 1] = 1e308 / h * 10.0
    R, Pi, G = np.eye(3), Pi0.copy(), _start(diag_body, METHOD_CAYLEY, h, Pi0)
    R_out = np.zeros((n, 3, 3))
    Pi_out = np.zeros((n, 3))
    its = np.zeros(n, np.int32)
    res = np.zeros(n)
    st, k, _, _, it_fail, _ = kernel(METHOD_CAYLEY, diag_body.Jd, h, R, Pi, G, U, 0, n, 1e-14, 50, 1.0, 1, R_out,
                                     Pi_out, its, res, NO_HIST, np.zeros(0, np.int64))
    assert (st, k) == (OVERFLOW, 6) and it_fail == its[6]
    np.testing.assert_array_equal(R, R_out[5])
    np.testing.assert_array_equal(Pi, Pi_out[5])
    assert np.isfinite(Pi).all() and G[3, 0] == 3.0
