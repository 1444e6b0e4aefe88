"""Scalar SO(3) operations for the kernels (3-vectors and 3x3 matrices, written out).

All functions write into caller-provided arrays; none allocates. The Taylor thresholds are the
same as in :mod:`lgvi.so3`: below ``t = 1e-4`` the dropped terms of the series are smaller
than ``t**6 / 5040 < 2e-28`` relative to the leading term, far below double rounding.
"""

from __future__ import annotations

import math

from .._jit import jit

SMALL_ANGLE = 1e-4


@jit
def rodrigues_coeffs(t2):
    """Return ``(a, b, c)`` with a = sin t / t, b = (1 - cos t)/t^2, c = (1 - a)/t^2 for t^2 = |w|^2."""
    if t2 < SMALL_ANGLE * SMALL_ANGLE:
        a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0)
        b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0)
        c = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0)
    else:
        t = math.sqrt(t2)
        s = math.sin(t)
        a = s / t
        # 1 - cos t = 2 sin^2(t/2): no cancellation for small t
        sh = math.sin(0.5 * t)
        b = 2.0 * sh * sh / t2
        c = (1.0 - a) / t2
    return a, b, c


@jit
def expm1_from_coeffs(w, a, b, E):
    """E = a hat(w) + b hat(w)^2 = exp(hat w) - I (accurate for tiny w)."""
    x = w[0]
    y = w[1]
    z = w[2]
    xx = x * x
    yy = y * y
    zz = z * z
    xy = x * y
    xz = x * z
    yz = y * z
    E[0, 0] = -b * (yy + zz)
    E[1, 1] = -b * (xx + zz)
    E[2, 2] = -b * (xx + yy)
    E[0, 1] = -a * z + b * xy
    E[1, 0] = a * z + b * xy
    E[0, 2] = a * y + b * xz
    E[2, 0] = -a * y + b * xz
    E[1, 2] = -a * x + b * yz
    E[2, 1] = a * x + b * yz


@jit
def expm1_so3(w, E):
    """E = exp(hat w) - I."""
    a, b, _ = rodrigues_coeffs(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    expm1_from_coeffs(w, a, b, E)


@jit
def cayley_minus_identity(f, E):
    """E = cay(f) - I = 2 (hat f + hat f^2) / (1 + |f|^2), with cay(f) = (I + hat f)(I - hat f)^-1."""
    s = 2.0 / (1.0 + f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
    expm1_from_coeffs(f, s, s, E)


@jit
def left_jacobian_from_coeffs(w, b, c, Jl):
    """Jl = I + b hat(w) + c hat(w)^2 (left Jacobian of exp)."""
    x = w[0]
    y = w[1]
    z = w[2]
    Jl[0, 0] = 1.0 - c * (y * y + z * z)
    Jl[1, 1] = 1.0 - c * (x * x + z * z)
    Jl[2, 2] = 1.0 - c * (x * x + y * y)
    Jl[0, 1] = -b * z + c * x * y
    Jl[1, 0] = b * z + c * x * y
    Jl[0, 2] = b * y + c * x * z
    Jl[2, 0] = -b * y + c * x * z
    Jl[1, 2] = -b * x + c * y * z
    Jl[2, 1] = b * x + c * y * z


@jit
def matmul3(A, B, C):
    """C = A @ B for 3x3 (C must not alias A or B)."""
    for i in range(3):
        a0 = A[i, 0]
        a1 = A[i, 1]
        a2 = A[i, 2]
        for j in range(3):
            C[i, j] = a0 * B[0, j] + a1 * B[1, j] + a2 * B[2, j]


@jit
def solve3(M, r, x):
    """Solve M x = r for 3x3 M by Cramer's rule; returns the determinant (0 if singular)."""
    c00 = M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]
    c01 = M[1, 2] * M[2, 0] - M[1, 0] * M[2, 2]
    c02 = M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0]
    det = M[0, 0] * c00 + M[0, 1] * c01 + M[0, 2] * c02
    if det == 0.0 or not math.isfinite(det):
        return 0.0
    inv = 1.0 / det
    c10 = M[0, 2] * M[2, 1] - M[0, 1] * M[2, 2]
    c11 = M[0, 0] * M[2, 2] - M[0, 2] * M[2, 0]
    c12 = M[0, 1] * M[2, 0] - M[0, 0] * M[2, 1]
    c20 = M[0, 1] * M[1, 2] - M[0, 2] * M[1, 1]
    c21 = M[0, 2] * M[1, 0] - M[0, 0] * M[1, 2]
    c22 = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    r0 = r[0]
    r1 = r[1]
    r2 = r[2]
    x[0] = (c00 * r0 + c10 * r1 + c20 * r2) * inv
    x[1] = (c01 * r0 + c11 * r1 + c21 * r2) * inv
    x[2] = (c02 * r0 + c12 * r1 + c22 * r2) * inv
    return det
