"""Compiled evaluation of the torque models of :mod:`lgvi.torques` from their data encoding.

A model arrives as ``codes`` (n, 2) int64 rows ``(kind, offset)`` and ``params`` float64 (layout
in :mod:`lgvi.torques`). The moment of every built-in model splits as

    M(t, R, Pi) = P(t, R) + Q(t, R) - D Omega,      Omega = J^-1 Pi,

with ``P`` the conservative (potential) moments, ``Q`` the other moments of the attitude and time,
and ``D`` a constant diagonal (damping ``c`` plus derivative gains ``kd``). The stepping kernels
use ``P`` in the variational update, ``Q - D Omega`` as the forcing, and ``D`` to solve the
symmetric scheme's momentum equation exactly.

The kind numbers are repeated here (the compiled layer imports nothing from the Python layer);
``tests/test_torques.py`` checks they agree with :mod:`lgvi.torques`.
"""

from __future__ import annotations

import math

from .._jit import jit, jit_copy

GRAVITY = 1
GRAVITY_GRADIENT = 2
CONSTANT = 3
DAMPING = 4
ATTITUDE_PD = 5


@jit(inline="always")
def model_moments_s(codes, params, J, t, r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """``(P0, P1, P2, Q0, Q1, Q2)``: conservative and other attitude/time moments at ``(t, R)``,
    ``R`` given by its entries ``rij``."""
    P0 = 0.0
    P1 = 0.0
    P2 = 0.0
    Q0 = 0.0
    Q1 = 0.0
    Q2 = 0.0
    for i in range(codes.shape[0]):
        kind = codes[i, 0]
        o = codes[i, 1]
        if kind == GRAVITY:
            # M = (R^T e3) x (mass g com); R^T e3 is the third row of R
            s0 = r20
            s1 = r21
            s2 = r22
            w0 = params[o]
            w1 = params[o + 1]
            w2 = params[o + 2]
            P0 += s1 * w2 - s2 * w1
            P1 += s2 * w0 - s0 * w2
            P2 += s0 * w1 - s1 * w0
        elif kind == GRAVITY_GRADIENT:
            # c = -R^T r_hat(t), r_hat = (cos nt, sin nt, 0); M = 3 mu / r^3 c x (J c)
            k = params[o]
            nt = params[o + 1] * t
            ct = math.cos(nt)
            st = math.sin(nt)
            c0 = -(r00 * ct + r10 * st)
            c1 = -(r01 * ct + r11 * st)
            c2 = -(r02 * ct + r12 * st)
            j0 = J[0, 0] * c0 + J[0, 1] * c1 + J[0, 2] * c2
            j1 = J[1, 0] * c0 + J[1, 1] * c1 + J[1, 2] * c2
            j2 = J[2, 0] * c0 + J[2, 1] * c1 + J[2, 2] * c2
            P0 += k * (c1 * j2 - c2 * j1)
            P1 += k * (c2 * j0 - c0 * j2)
            P2 += k * (c0 * j1 - c1 * j0)
        elif kind == CONSTANT:
            Q0 += params[o]
            Q1 += params[o + 1]
            Q2 += params[o + 2]
        elif kind == ATTITUDE_PD:
            # e_R = vee(A - A^T) / 2 with A = R_d^T R; only the off-diagonal entries are needed
            # R_d row-major at params[o + 6 ...]: (R_d^T R)_ij = sum_m R_d[m, i] R[m, j]
            d = o + 6
            a01 = params[d] * r01 + params[d + 3] * r11 + params[d + 6] * r21
            a02 = params[d] * r02 + params[d + 3] * r12 + params[d + 6] * r22
            a10 = params[d + 1] * r00 + params[d + 4] * r10 + params[d + 7] * r20
            a12 = params[d + 1] * r02 + params[d + 4] * r12 + params[d + 7] * r22
            a20 = params[d + 2] * r00 + params[d + 5] * r10 + params[d + 8] * r20
            a21 = params[d + 2] * r01 + params[d + 5] * r11 + params[d + 8] * r21
            Q0 -= params[o] * (0.5 * (a21 - a12))
            Q1 -= params[o + 1] * (0.5 * (a02 - a20))
            Q2 -= params[o + 2] * (0.5 * (a10 - a01))
        # DAMPING: only the -D Omega part, see momentum_diag
    return P0, P1, P2, Q0, Q1, Q2


#: :func:`model_moments_s` as a function of its own (not inlined at Numba's level; LLVM decides): the
#: stepping loops call the models through this, so their first compilation types and lowers every
#: model's branch once rather than once per call site (see :func:`.._jit.jit_copy`).
model_moments_call = jit_copy(model_moments_s, "model_moments_call", "model_moments_s compiled as a function of its "
                              "own (see the module's model_moments_call).", _nrt=False)


@jit(inline="always")
def model_moments(codes, params, J, t, R):
    """:func:`model_moments_s` of the array ``R`` (3,3)."""
    return model_moments_s(codes, params, J, t, R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0],
                           R[2, 1], R[2, 2])


@jit(inline="always")
def momentum_diag(codes, params):
    """Diagonal ``D`` of the momentum dependence ``-D Omega`` (damping ``c`` plus gains ``kd``)."""
    D0 = 0.0
    D1 = 0.0
    D2 = 0.0
    for i in range(codes.shape[0]):
        kind = codes[i, 0]
        o = codes[i, 1]
        if kind == DAMPING:
            D0 += params[o]
            D1 += params[o + 1]
            D2 += params[o + 2]
        elif kind == ATTITUDE_PD:
            D0 += params[o + 3]
            D1 += params[o + 4]
            D2 += params[o + 5]
    return D0, D1, D2


@jit
def moment_kernel(codes, params, J, J_inv, t, R, Pi, out):
    """Full moment ``P + Q - D J^-1 Pi`` into ``out`` (3,) (used by tests and diagnostics).

    Returns the conservative part ``P`` and the rest ``Q - D Omega`` summed in ``out``.
    """
    P0, P1, P2, Q0, Q1, Q2 = model_moments(codes, params, J, t, R)
    D0, D1, D2 = momentum_diag(codes, params)
    w0 = J_inv[0, 0] * Pi[0] + J_inv[0, 1] * Pi[1] + J_inv[0, 2] * Pi[2]
    w1 = J_inv[1, 0] * Pi[0] + J_inv[1, 1] * Pi[1] + J_inv[1, 2] * Pi[2]
    w2 = J_inv[2, 0] * Pi[0] + J_inv[2, 1] * Pi[1] + J_inv[2, 2] * Pi[2]
    out[0] = P0 + (Q0 - D0 * w0)
    out[1] = P1 + (Q1 - D1 * w1)
    out[2] = P2 + (Q2 - D2 * w2)
