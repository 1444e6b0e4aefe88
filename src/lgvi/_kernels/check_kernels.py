"""Checks of arrays read from files (stream chunks), compiled: one pass over the samples, no
temporaries (a million attitudes in a few milliseconds, where NumPy's batched ``R^T R`` and
``det`` took most of a second and gigabytes of temporaries).
"""

from __future__ import annotations

import math

from .._jit import jit


@jit
def first_non_rotation(R, tol):
    """Index of the first matrix of ``R`` (M, 3, 3) that is not a rotation: some entry of
    ``R^T R - I`` above ``tol`` in magnitude (or not finite), or ``det R <= 0``; -1 if none."""
    for k in range(R.shape[0]):
        a, b, c = R[k, 0, 0], R[k, 0, 1], R[k, 0, 2]
        d, e, f = R[k, 1, 0], R[k, 1, 1], R[k, 1, 2]
        g, h, i = R[k, 2, 0], R[k, 2, 1], R[k, 2, 2]
        err = max(abs(a * a + d * d + g * g - 1.0), abs(b * b + e * e + h * h - 1.0),
                  abs(c * c + f * f + i * i - 1.0), abs(a * b + d * e + g * h), abs(a * c + d * f + g * i),
                  abs(b * c + e * f + h * i))
        det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
        if not (err <= tol) or not (det > 0.0) or not math.isfinite(det):
            return k
    return -1


@jit
def first_time_back(t):
    """Index of the first sample of ``t`` (M,) that is not finite or steps against the direction
    of ``t[-1] - t[0]`` (equal neighbours allowed); -1 if none."""
    n = t.shape[0]
    for k in range(n):
        if not math.isfinite(t[k]):
            return k
    if n < 2:
        return -1
    sign = 1.0 if t[n - 1] >= t[0] else -1.0
    for k in range(1, n):
        if (t[k] - t[k - 1]) * sign < 0.0:
            return k
    return -1
