"""Compiled steps of a rigid body in a central field, on ``R^3 x SO(3)`` (see ``docs/orbit.md``).

State: position ``x`` (3,) of the centre of mass (inertial), linear momentum ``p`` (3,),
attitude ``R`` (3,3) (body to inertial), body angular momentum ``Pi`` (3,). One step of size
``h`` from ``(x_k, p_k, R_k, Pi_k)`` with ``g = dU/dx`` and the body moment ``M`` (gravity)
plus ``u`` (an extra body moment) known at step ``k``:

    mu_k        = Pi_k + h/2 (M_k + u_k)
    hat(h mu_k) = F Jd - Jd F^T                     (Cayley solve, :func:`.solvers.solve_scalar`)
    R_{k+1}     = R_k F
    x_{k+1}     = x_k + h p_k / m - h^2 / (2 m) g_k
    (g, M)_{k+1} at (x_{k+1}, R_{k+1})              (the one force evaluation of the step)
    p_{k+1}     = p_k - h/2 (g_k + g_{k+1})
    Pi_{k+1}    = F^T mu_k + h/2 (M_{k+1} + u_{k+1})

The force and moment at the current state are cached in ``C`` (7,): ``g`` in ``C[0:3]``, ``M``
in ``C[3:6]``, ``C[6]`` = 1 when valid, so the state, ``G`` (the solver history) and ``C``
continue a run exactly across chunks.

Potentials (``code``): :data:`POINT` ``U = -mu m / r``; :data:`ORDER2` adds the second-order
(MacCullagh) term of the body's second moments ``S = Jd = int r r^T dm``:
``U2 = mu tr(S) / (2 r^3) - 3 mu (b . S b) / (2 r^5)``, ``b = R^T x``. ``c2 = mu J2 Re^2``
adds the zonal ``J2`` term of the central body on the centre of mass,
``U_J2 = m c2 (3 z^2 / r^2 - 1) / (2 r^3)``.
"""

from __future__ import annotations

import math

from .._jit import jit
from .codes import COLLISION, METHOD_CAYLEY, NOT_FINITE, OK, OVERFLOW
from .contact_kernels import passage
from .solvers import solve_scalar
from .stepping import predict_at, push_at, rotated_row

POINT = 0
ORDER2 = 1


@jit(inline="always")
def second_order(S00, S01, S02, S11, S12, S22, trS, mu, x0, x1, x2, R00, R01, R02, R10, R11, R12, R20, R21, R22):
    """Gradient in ``x`` and body moment of ``U2 = mu tr(S) / (2 r^3) - 3 mu (b . S b) / (2 r^5)``
    (``b = R^T x``). Returns ``(g0, g1, g2, M0, M1, M2)``."""
    r2 = x0 * x0 + x1 * x1 + x2 * x2
    ir2 = 1.0 / r2
    ir = math.sqrt(ir2)
    ir5 = ir2 * ir2 * ir
    b0 = R00 * x0 + R10 * x1 + R20 * x2
    b1 = R01 * x0 + R11 * x1 + R21 * x2
    b2 = R02 * x0 + R12 * x1 + R22 * x2
    s0 = S00 * b0 + S01 * b1 + S02 * b2
    s1 = S01 * b0 + S11 * b1 + S12 * b2
    s2 = S02 * b0 + S12 * b1 + S22 * b2
    bsb = b0 * s0 + b1 * s1 + b2 * s2
    # dU2/dx = -3 mu r^-5 R S b + (15/2 mu (b.Sb) r^-7 - 3/2 mu tr(S) r^-5) x
    c = mu * ir5 * (7.5 * bsb * ir2 - 1.5 * trS)
    a = -3.0 * mu * ir5
    g0 = a * (R00 * s0 + R01 * s1 + R02 * s2) + c * x0
    g1 = a * (R10 * s0 + R11 * s1 + R12 * s2) + c * x1
    g2 = a * (R20 * s0 + R21 * s1 + R22 * s2) + c * x2
    # M = b x dU/db = -3 mu r^-5 b x S b
    return g0, g1, g2, a * (b1 * s2 - b2 * s1), a * (b2 * s0 - b0 * s2), a * (b0 * s1 - b1 * s0)


@jit(inline="always")
def central_force(code, Jd, mass, mu, c2, x0, x1, x2, R00, R01, R02, R10, R11, R12, R20, R21, R22):
    """``(g = dU/dx, M)`` of the body at ``x`` with attitude ``R`` (entries): see the module notes."""
    r2 = x0 * x0 + x1 * x1 + x2 * x2
    ir2 = 1.0 / r2
    ir = math.sqrt(ir2)
    ir3 = ir2 * ir
    a = mu * mass * ir3
    g0 = a * x0
    g1 = a * x1
    g2 = a * x2
    M0 = 0.0
    M1 = 0.0
    M2 = 0.0
    if code == ORDER2:
        trS = Jd[0, 0] + Jd[1, 1] + Jd[2, 2]
        q0, q1, q2, M0, M1, M2 = second_order(Jd[0, 0], Jd[0, 1], Jd[0, 2], Jd[1, 1], Jd[1, 2], Jd[2, 2], trS, mu,
                                              x0, x1, x2, R00, R01, R02, R10, R11, R12, R20, R21, R22)
        g0 += q0
        g1 += q1
        g2 += q2
    if c2 != 0.0:
        # U_J2 = m c2 (3 z^2 r^-5 - r^-3) / 2: gradient m c2 ((3/2 r^-5 - 15/2 z^2 r^-7) x + 3 z r^-5 e3)
        ir5 = ir3 * ir2
        e = mass * c2 * ir5 * (1.5 - 7.5 * x2 * x2 * ir2)
        g0 += e * x0
        g1 += e * x1
        g2 += e * x2 + 3.0 * mass * c2 * ir5 * x2
    return g0, g1, g2, M0, M1, M2


@jit(_nrt=False)
def run_orbit(code, Jd, mass, mu, c2, h, x, p, R, Pi, G, C, U, k0, n, tol, max_iter, save_every,
              x_out, p_out, R_out, Pi_out, it_out, res_out, hist, last, core, contact):
    """Steps ``k0 .. k0+n-1`` in place on ``x, p, R, Pi, G`` (1,5,3), ``C`` (7,); sample ``j``
    (every ``save_every`` steps) into the ``*_out`` buffers, the largest iterations and residual
    of each saved interval into ``it_out``, ``res_out``. ``U`` is ``(1, 3)`` (a constant extra
    body moment) or ``(steps + 1, 3)`` (its value at each grid time). ``last`` (2,) gets the
    iterations and residual of the last step tried. A step whose path touches the central body
    (radius ``core``, 0 for a point) or passes its centre closer than its own length fails with
    ``COLLISION`` and ``contact`` (3,) = ``(kind, d_min, L)`` (:func:`.contact_kernels.passage`).
    Returns ``(status, k)``: ``k`` the steps done (on failure the failed step; the state is then
    that before it)."""
    one = U.shape[0] == 1
    if C[6] == 0.0:
        g0, g1, g2, M0, M1, M2 = central_force(code, Jd, mass, mu, c2, x[0], x[1], x[2], R[0, 0], R[0, 1], R[0, 2],
                                               R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2])
        C[0] = g0
        C[1] = g1
        C[2] = g2
        C[3] = M0
        C[4] = M1
        C[5] = M2
        C[6] = 1.0
    hh = 0.5 * h
    hm = h / mass
    hhm = 0.5 * h * hm
    j = 0
    its_max = 0
    res_max = 0.0
    countdown = save_every
    for s in range(n):
        k = k0 + s
        ku = 0 if one else k
        ku1 = 0 if one else k + 1
        m0 = Pi[0] + hh * (C[3] + U[ku, 0])
        m1 = Pi[1] + hh * (C[4] + U[ku, 1])
        m2 = Pi[2] + hh * (C[5] + U[ku, 2])
        q0, q1, q2 = predict_at(G, 0)
        (f0, f1, f2, E00, E01, E02, E10, E11, E12, E20, E21, E22, its, rn,
         st) = solve_scalar(METHOD_CAYLEY, Jd[0, 0], Jd[0, 1], Jd[0, 2], Jd[1, 1], Jd[1, 2], Jd[2, 2],
                            h * m0, h * m1, h * m2, q0, q1, q2, tol, max_iter, 1.0, hist, True)
        last[0] = its
        last[1] = rn
        if st != OK:
            return st, k
        a00, a01, a02 = rotated_row(R[0, 0], R[0, 1], R[0, 2], E00, E01, E02, E10, E11, E12, E20, E21, E22)
        a10, a11, a12 = rotated_row(R[1, 0], R[1, 1], R[1, 2], E00, E01, E02, E10, E11, E12, E20, E21, E22)
        a20, a21, a22 = rotated_row(R[2, 0], R[2, 1], R[2, 2], E00, E01, E02, E10, E11, E12, E20, E21, E22)
        y0 = x[0] + hm * p[0] - hhm * C[0]
        y1 = x[1] + hm * p[1] - hhm * C[1]
        y2 = x[2] + hm * p[2] - hhm * C[2]
        if passage(x[0], x[1], x[2], y0, y1, y2, core, contact):
            return COLLISION, k
        g0, g1, g2, M0, M1, M2 = central_force(code, Jd, mass, mu, c2, y0, y1, y2, a00, a01, a02, a10, a11, a12,
                                               a20, a21, a22)
        n0 = p[0] - hh * (C[0] + g0)
        n1 = p[1] - hh * (C[1] + g1)
        n2 = p[2] - hh * (C[2] + g2)
        P0 = m0 + (E00 * m0 + E10 * m1 + E20 * m2) + hh * (M0 + U[ku1, 0])
        P1 = m1 + (E01 * m0 + E11 * m1 + E21 * m2) + hh * (M1 + U[ku1, 1])
        P2 = m2 + (E02 * m0 + E12 * m1 + E22 * m2) + hh * (M2 + U[ku1, 2])
        fin = (y0 + y1 + y2 + n0 + n1 + n2 + P0 + P1 + P2 + g0 + g1 + g2)
        if not math.isfinite(fin):
            return (NOT_FINITE if not math.isfinite(y0 + y1 + y2) else OVERFLOW), k
        push_at(G, 0, f0, f1, f2)
        R[0, 0], R[0, 1], R[0, 2] = a00, a01, a02
        R[1, 0], R[1, 1], R[1, 2] = a10, a11, a12
        R[2, 0], R[2, 1], R[2, 2] = a20, a21, a22
        x[0] = y0
        x[1] = y1
        x[2] = y2
        p[0] = n0
        p[1] = n1
        p[2] = n2
        Pi[0] = P0
        Pi[1] = P1
        Pi[2] = P2
        C[0] = g0
        C[1] = g1
        C[2] = g2
        C[3] = M0
        C[4] = M1
        C[5] = M2
        if its > its_max:
            its_max = its
        if rn > res_max:
            res_max = rn
        countdown -= 1
        if countdown == 0:
            countdown = save_every
            for a in range(3):
                x_out[j, a] = x[a]
                p_out[j, a] = p[a]
                Pi_out[j, a] = Pi[a]
                for b in range(3):
                    R_out[j, a, b] = R[a, b]
            it_out[j] = its_max
            res_out[j] = res_max
            its_max = 0
            res_max = 0.0
            j += 1
    return OK, k0 + n


__all__ = ["ORDER2", "POINT", "central_force", "run_orbit", "second_order"]
