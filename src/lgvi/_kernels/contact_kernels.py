"""Compiled contact checks of the orbit and two-body steps (:data:`.codes.COLLISION`).

A step of a body about a centre (the central body of an orbit, or body 1 seen from body 2) moves
the relative position from ``a = r_k`` to ``b = r_{k+1}``. Two checks are made on the straight
segment between them (:func:`segment_approach`), each a few flops a step:

* the segment comes within ``core`` of the centre (the central body's radius; for two bodies the
  sum of the radii of balls about their centres of mass that lie inside them): the bodies touch;
* the segment passes the centre closer than its own length ``L`` (``d_min < L``): the step swept
  more than about 53 degrees about the centre, which no resolved close approach does (Verlet's
  energy error is then of order one): the body fell through the centre, or the step is far too
  large for this approach. Both are impossible physics, never a result.

Bodies with a shape are also checked for overlap at the new state (:func:`ellipsoids_overlap`,
only when their bounding spheres meet): each body is a set of ellipsoids aligned with its axes
(an :class:`lgvi.Ellipsoid` is one, a body of spheres one per sphere), and two ellipsoids
overlap exactly when the Perram-Wertheim contact function ``F(l) = l (1 - l) d^T ((1 - l)
A1^-1 + l A2^-1)^-1 d`` (``A_i^-1 = R_i diag(axes_i^2) R_i^T``, ``d`` between their centres)
stays below 1 for every ``l`` in ``[0, 1]`` (it is concave in ``l``: a golden-section search
finds its maximum; J. W. Perram and M. S. Wertheim, J. Comput. Phys. 58, 409 (1985)).
"""

from __future__ import annotations

import math

from .._jit import jit

#: Golden-section steps of the contact function's maximum (``0.618^40 ~ 4e-9`` in ``l``).
GOLDEN_STEPS = 40


@jit(inline="always")
def segment_approach(a0, a1, a2, b0, b1, b2):
    """``(d_min, L)``: the closest approach to the origin of the segment from ``a`` to ``b``, and
    its length."""
    e0 = b0 - a0
    e1 = b1 - a1
    e2 = b2 - a2
    L2 = e0 * e0 + e1 * e1 + e2 * e2
    s = 0.0
    if L2 > 0.0:
        s = -(a0 * e0 + a1 * e1 + a2 * e2) / L2
        if s < 0.0:
            s = 0.0
        elif s > 1.0:
            s = 1.0
    c0 = a0 + s * e0
    c1 = a1 + s * e1
    c2 = a2 + s * e2
    return math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), math.sqrt(L2)


@jit(inline="always")
def passage(a0, a1, a2, b0, b1, b2, core, contact):
    """Whether the step from ``a`` to ``b`` (relative positions) touches a core of radius ``core``
    or passes the centre closer than its own length (see the module notes). On a hit ``contact``
    (3,) gets ``(kind, d_min, L)``: kind 1 for the core, 2 for the passage. Returns True on a hit."""
    d, L = segment_approach(a0, a1, a2, b0, b1, b2)
    if core > 0.0 and d <= core:
        contact[0] = 1.0
    elif d < L:
        contact[0] = 2.0
    else:
        return False
    contact[1] = d
    contact[2] = L
    return True


@jit(inline="always")
def _rotated_quadric(R, i, ax0, ax1, ax2):
    """``R_i diag(ax^2) R_i^T`` (symmetric, 6 entries)."""
    s0 = ax0 * ax0
    s1 = ax1 * ax1
    s2 = ax2 * ax2
    q00 = R[i, 0, 0] * R[i, 0, 0] * s0 + R[i, 0, 1] * R[i, 0, 1] * s1 + R[i, 0, 2] * R[i, 0, 2] * s2
    q01 = R[i, 0, 0] * R[i, 1, 0] * s0 + R[i, 0, 1] * R[i, 1, 1] * s1 + R[i, 0, 2] * R[i, 1, 2] * s2
    q02 = R[i, 0, 0] * R[i, 2, 0] * s0 + R[i, 0, 1] * R[i, 2, 1] * s1 + R[i, 0, 2] * R[i, 2, 2] * s2
    q11 = R[i, 1, 0] * R[i, 1, 0] * s0 + R[i, 1, 1] * R[i, 1, 1] * s1 + R[i, 1, 2] * R[i, 1, 2] * s2
    q12 = R[i, 1, 0] * R[i, 2, 0] * s0 + R[i, 1, 1] * R[i, 2, 1] * s1 + R[i, 1, 2] * R[i, 2, 2] * s2
    q22 = R[i, 2, 0] * R[i, 2, 0] * s0 + R[i, 2, 1] * R[i, 2, 1] * s1 + R[i, 2, 2] * R[i, 2, 2] * s2
    return q00, q01, q02, q11, q12, q22


@jit(inline="always")
def _contact_function(lam, P, Q, d0, d1, d2):
    """``l (1 - l) d^T ((1 - l) P + l Q)^-1 d`` for symmetric ``P``, ``Q`` (6 entries each)."""
    u = 1.0 - lam
    c00 = u * P[0] + lam * Q[0]
    c01 = u * P[1] + lam * Q[1]
    c02 = u * P[2] + lam * Q[2]
    c11 = u * P[3] + lam * Q[3]
    c12 = u * P[4] + lam * Q[4]
    c22 = u * P[5] + lam * Q[5]
    # adjugate of C (symmetric): C^-1 d = adj(C) d / det(C)
    k00 = c11 * c22 - c12 * c12
    k01 = c02 * c12 - c01 * c22
    k02 = c01 * c12 - c02 * c11
    k11 = c00 * c22 - c02 * c02
    k12 = c01 * c02 - c00 * c12
    k22 = c00 * c11 - c01 * c01
    det = c00 * k00 + c01 * k01 + c02 * k02
    quad = (d0 * (k00 * d0 + k01 * d1 + k02 * d2) + d1 * (k01 * d0 + k11 * d1 + k12 * d2)
            + d2 * (k02 * d0 + k12 * d1 + k22 * d2))
    return lam * u * quad / det


@jit
def ellipsoids_overlap(d0, d1, d2, R, ax1, ax2):
    """Whether ellipsoid 1 (semi-axes ``ax1`` (3,) along the axes of ``R[0]``) and ellipsoid 2
    (``ax2``, ``R[1]``), centre 2 at ``d`` from centre 1, overlap (Perram-Wertheim, see the
    module notes). Touching counts as apart."""
    P = _rotated_quadric(R, 0, ax1[0], ax1[1], ax1[2])
    Q = _rotated_quadric(R, 1, ax2[0], ax2[1], ax2[2])
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    lo = 0.0
    hi = 1.0
    x1 = hi - g * (hi - lo)
    x2 = lo + g * (hi - lo)
    f1 = _contact_function(x1, P, Q, d0, d1, d2)
    f2 = _contact_function(x2, P, Q, d0, d1, d2)
    for _ in range(GOLDEN_STEPS):
        if f1 >= 1.0 or f2 >= 1.0:
            return False
        if f1 < f2:
            lo = x1
            x1 = x2
            f1 = f2
            x2 = lo + g * (hi - lo)
            f2 = _contact_function(x2, P, Q, d0, d1, d2)
        else:
            hi = x2
            x2 = x1
            f2 = f1
            x1 = hi - g * (hi - lo)
            f1 = _contact_function(x1, P, Q, d0, d1, d2)
    return f1 < 1.0 and f2 < 1.0


@jit
def shapes_overlap(X, R, E1, A1, E2, A2):
    """Whether the bodies at positions ``X`` (2, 3), attitudes ``R`` (2, 3, 3) overlap: body ``i``
    the ellipsoids centred at ``E_i`` (n_i, 3) (body frame, from its centre of mass) with semi-axes
    ``A_i`` (n_i, 3) along its axes. Returns the index ``a * n2 + b`` of the first overlapping
    pair, or -1."""
    for a in range(E1.shape[0]):
        c0 = X[0, 0] + R[0, 0, 0] * E1[a, 0] + R[0, 0, 1] * E1[a, 1] + R[0, 0, 2] * E1[a, 2]
        c1 = X[0, 1] + R[0, 1, 0] * E1[a, 0] + R[0, 1, 1] * E1[a, 1] + R[0, 1, 2] * E1[a, 2]
        c2 = X[0, 2] + R[0, 2, 0] * E1[a, 0] + R[0, 2, 1] * E1[a, 1] + R[0, 2, 2] * E1[a, 2]
        r1 = max(A1[a, 0], max(A1[a, 1], A1[a, 2]))
        for b in range(E2.shape[0]):
            e0 = X[1, 0] + R[1, 0, 0] * E2[b, 0] + R[1, 0, 1] * E2[b, 1] + R[1, 0, 2] * E2[b, 2] - c0
            e1 = X[1, 1] + R[1, 1, 0] * E2[b, 0] + R[1, 1, 1] * E2[b, 1] + R[1, 1, 2] * E2[b, 2] - c1
            e2 = X[1, 2] + R[1, 2, 0] * E2[b, 0] + R[1, 2, 1] * E2[b, 1] + R[1, 2, 2] * E2[b, 2] - c2
            r2 = max(A2[b, 0], max(A2[b, 1], A2[b, 2]))
            if e0 * e0 + e1 * e1 + e2 * e2 >= (r1 + r2) * (r1 + r2):
                continue
            if ellipsoids_overlap(e0, e1, e2, R, A1[a], A2[b]):
                return a * E2.shape[0] + b
    return -1


__all__ = ["GOLDEN_STEPS", "ellipsoids_overlap", "passage", "segment_approach", "shapes_overlap"]
