"""Compiled right-hand side and fixed-step RK4 chunk of the classical baselines.

The ODE is Euler's equations with quaternion kinematics, on ``y = (q, Pi)`` with ``q = (x, y, z, w)``
scalar-last (body to inertial, Hamilton product) and ``Pi`` the body angular momentum:

    dq/dt  = 1/2 q (x) (Omega, 0),      Omega = J^-1 Pi
    dPi/dt = Pi x Omega + u(t, R(q), Pi)

``R(q)`` in the moment is the rotation of the *normalised* quaternion (the homogeneous matrix
divided by ``|q|^2``), so a torque model sees a rotation even when ``|q|`` has drifted.

Built-in torque models (:mod:`lgvi.torques`) arrive as their kernel encoding ``codes`` (n, 2)
int64 and ``params`` float64 and are evaluated by :mod:`.torque_kernels` (the same code the LGVI
steps use): ``u = P(t, R) + Q(t, R) - D Omega`` with ``D`` the constant diagonal of
:func:`.torque_kernels.momentum_diag`, passed in as ``D`` (3,). ``codes.shape[0] == 0`` is the free
body.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .codes import OK, OVERFLOW
from .torque_kernels import model_moments


@jit
def rotation_of(x, y, z, w, Rs):
    """Write the rotation of the (possibly unnormalised) quaternion into ``Rs`` (3,3)."""
    s = 1.0 / (x * x + y * y + z * z + w * w)
    Rs[0, 0] = (w * w + x * x - y * y - z * z) * s
    Rs[1, 1] = (w * w - x * x + y * y - z * z) * s
    Rs[2, 2] = (w * w - x * x - y * y + z * z) * s
    Rs[0, 1] = 2.0 * (x * y - w * z) * s
    Rs[1, 0] = 2.0 * (x * y + w * z) * s
    Rs[0, 2] = 2.0 * (x * z + w * y) * s
    Rs[2, 0] = 2.0 * (x * z - w * y) * s
    Rs[1, 2] = 2.0 * (y * z - w * x) * s
    Rs[2, 1] = 2.0 * (y * z + w * x) * s


@jit
def rhs_scalar(t, x, y, z, w, p0, p1, p2, J, J_inv, codes, params, D, Rs):
    """Right-hand side at one state; returns the 7 derivatives ``(dq (4), dPi (3))``."""
    o0 = J_inv[0, 0] * p0 + J_inv[0, 1] * p1 + J_inv[0, 2] * p2
    o1 = J_inv[1, 0] * p0 + J_inv[1, 1] * p1 + J_inv[1, 2] * p2
    o2 = J_inv[2, 0] * p0 + J_inv[2, 1] * p1 + J_inv[2, 2] * p2
    dx = 0.5 * (w * o0 + y * o2 - z * o1)
    dy = 0.5 * (w * o1 + z * o0 - x * o2)
    dz = 0.5 * (w * o2 + x * o1 - y * o0)
    dw = -0.5 * (x * o0 + y * o1 + z * o2)
    d0 = p1 * o2 - p2 * o1
    d1 = p2 * o0 - p0 * o2
    d2 = p0 * o1 - p1 * o0
    if codes.shape[0] > 0:
        rotation_of(x, y, z, w, Rs)
        P0, P1, P2, Q0, Q1, Q2 = model_moments(codes, params, J, t, Rs)
        d0 += P0 + (Q0 - D[0] * o0)
        d1 += P1 + (Q1 - D[1] * o1)
        d2 += P2 + (Q2 - D[2] * o2)
    return dx, dy, dz, dw, d0, d1, d2


@jit
def rhs(t, y, J, J_inv, codes, params, D):
    """``dy/dt`` as a new (7,) array, for ``scipy.integrate.solve_ivp``."""
    Rs = np.empty((3, 3))
    out = np.empty(7)
    (out[0], out[1], out[2], out[3], out[4], out[5],
     out[6]) = rhs_scalar(t, y[0], y[1], y[2], y[3], y[4], y[5], y[6], J, J_inv, codes, params, D, Rs)
    return out


@jit
def rk4_chunk(h, t0, q, Pi, J, J_inv, codes, params, D, k0, n, save_every, normalize, q_out, Pi_out):
    """Advance ``n`` classic RK4 steps ``k0 .. k0+n-1`` in place on ``q`` (4,) and ``Pi`` (3,): one
    chunk of :func:`lgvi.driver.drive`.

    Step ``k`` starts at ``t0 + k h``. ``k0`` and ``n`` are multiples of ``save_every``; the chunk's
    samples go to its own buffers ``q_out`` (n // save_every, 4) and ``Pi_out`` (n // save_every, 3),
    from index 0: the state after step ``k`` is the chunk's next sample when
    ``(k + 1) % save_every == 0`` (a running index: cheaper in the loop than computing it from
    ``k``). With ``normalize`` the quaternion is rescaled to unit length after every step.

    Returns ``(status, k)``: ``(OK, k0 + n)``, or ``(OVERFLOW, k)`` when step ``k`` made the state
    non-finite (or, with ``normalize``, overflowed ``|q|^2``); then ``q``, ``Pi`` hold the state
    before step ``k`` (the last finite one) and the samples of steps before ``k`` are written.
    """
    Rs = np.empty((3, 3))
    h2 = 0.5 * h
    h6 = h / 6.0
    x = q[0]
    y = q[1]
    z = q[2]
    w = q[3]
    p0 = Pi[0]
    p1 = Pi[1]
    p2 = Pi[2]
    j = 0                                   # the chunk's next sample
    status = OK
    kend = k0 + n
    for k in range(k0, k0 + n):
        t = t0 + k * h
        a0, a1, a2, a3, a4, a5, a6 = rhs_scalar(t, x, y, z, w, p0, p1, p2, J, J_inv, codes, params, D, Rs)
        b0, b1, b2, b3, b4, b5, b6 = rhs_scalar(t + h2, x + h2 * a0, y + h2 * a1, z + h2 * a2, w + h2 * a3,
                                                p0 + h2 * a4, p1 + h2 * a5, p2 + h2 * a6,
                                                J, J_inv, codes, params, D, Rs)
        c0, c1, c2, c3, c4, c5, c6 = rhs_scalar(t + h2, x + h2 * b0, y + h2 * b1, z + h2 * b2, w + h2 * b3,
                                                p0 + h2 * b4, p1 + h2 * b5, p2 + h2 * b6,
                                                J, J_inv, codes, params, D, Rs)
        d0, d1, d2, d3, d4, d5, d6 = rhs_scalar(t + h, x + h * c0, y + h * c1, z + h * c2, w + h * c3,
                                                p0 + h * c4, p1 + h * c5, p2 + h * c6,
                                                J, J_inv, codes, params, D, Rs)
        nx = x + h6 * (a0 + 2.0 * (b0 + c0) + d0)
        ny = y + h6 * (a1 + 2.0 * (b1 + c1) + d1)
        nz = z + h6 * (a2 + 2.0 * (b2 + c2) + d2)
        nw = w + h6 * (a3 + 2.0 * (b3 + c3) + d3)
        n0 = p0 + h6 * (a4 + 2.0 * (b4 + c4) + d4)
        n1 = p1 + h6 * (a5 + 2.0 * (b5 + c5) + d5)
        n2 = p2 + h6 * (a6 + 2.0 * (b6 + c6) + d6)
        if not (math.isfinite(nx) and math.isfinite(ny) and math.isfinite(nz) and math.isfinite(nw)
                and math.isfinite(n0) and math.isfinite(n1) and math.isfinite(n2)):
            status = OVERFLOW               # stop before the step: the state stays the last finite one
            kend = k
            break
        if normalize:
            qq = nx * nx + ny * ny + nz * nz + nw * nw
            if not (0.0 < qq < math.inf):   # |q|^2 overflowed (or q = 0): no rotation to rescale to
                status = OVERFLOW
                kend = k
                break
            s = 1.0 / math.sqrt(qq)
            nx *= s
            ny *= s
            nz *= s
            nw *= s
        x = nx
        y = ny
        z = nz
        w = nw
        p0 = n0
        p1 = n1
        p2 = n2
        if (k + 1) % save_every == 0:
            q_out[j, 0] = x
            q_out[j, 1] = y
            q_out[j, 2] = z
            q_out[j, 3] = w
            Pi_out[j, 0] = p0
            Pi_out[j, 1] = p1
            Pi_out[j, 2] = p2
            j += 1
    q[0] = x
    q[1] = y
    q[2] = z
    q[3] = w
    Pi[0] = p0
    Pi[1] = p1
    Pi[2] = p2
    return status, kend
