"""The rotation group SO(3): hat/vee, exponential and logarithm, Jacobians, Cayley map,
quaternions and projection.

Every function is pure NumPy, works on stacks of vectors ``(..., 3)``, quaternions ``(..., 4)``
or matrices ``(..., 3, 3)`` with arbitrary leading axes, and returns ``float64`` arrays. Inputs
are validated once: a wrong trailing shape raises a :class:`ValueError` that names the argument
and the expected shape.

Conventions
-----------
* ``hat(w) @ v == np.cross(w, v)``; ``vee`` is its inverse on skew matrices.
* Rotation vectors ``w`` (axis times angle) map to rotations by ``exp``; ``log`` returns the
  rotation vector with angle in ``[0, pi]``.
* Jacobians: ``exp(w + d) ~ exp(hat(Jl(w) d)) exp(w) ~ exp(w) exp(hat(Jr(w) d))`` to first order
  in ``d``; ``Jr(w) = Jl(-w) = Jl(w).T``.
* Quaternions are Hamilton quaternions of an active rotation, stored scalar-last ``(x, y, z, w)``
  by default exactly like :class:`scipy.spatial.transform.Rotation`; ``scalar_first=True`` gives
  ``(w, x, y, z)``.

Near the identity the closed forms (``sin(t)/t``, ``(1 - cos t)/t**2``, ...) are replaced by
Taylor series below thresholds chosen so that the neglected terms are below ``1e-17`` relative;
where a closed form suffers from cancellation (the Jacobian coefficients) the series is used over
a wider range, so that the coefficients keep close to full relative precision.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "hat",
    "vee",
    "exp",
    "exp_minus_identity",
    "log",
    "left_jacobian",
    "right_jacobian",
    "left_jacobian_inv",
    "right_jacobian_inv",
    "cayley",
    "cayley_inv",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_multiply",
    "quat_continuous",
    "project",
    "orthogonality_error",
    "is_rotation",
    "mrp_from_matrix",
    "matrix_from_mrp",
]

FloatArray = NDArray[np.float64]

# --------------------------------------------------------------------------------------------
# Thresholds and series coefficients
# --------------------------------------------------------------------------------------------

# exp: a(t) = sin(t)/t = 1 - t^2/6 + t^4/120 - t^6/5040 + ... and
#      b(t) = (1 - cos t)/t^2 = 1/2 - t^2/24 + t^4/720 - t^6/40320 + ...
# With the series truncated after the t^4 term, the first neglected term relative to the
# leading one is t^6/5040 for a and t^6/20160 for b; both are below 1e-17 when
# t^6 < 5.04e-14, i.e. t < 6.07e-3. We switch at 5e-3 (relative truncation error < 3.1e-18).
# Above the threshold the closed forms are evaluated without cancellation:
# a = sin(t)/t directly, b = (1/2) (sin(t/2)/(t/2))^2 (the half-angle form of (1 - cos t)/t^2),
# so the threshold only guards the division by t (and t**2 underflow), not accuracy.
_EXP_TAYLOR = 5e-3

# log: the angle is recovered from a unit quaternion (v, s) as theta = 2 atan(r) |v| / r with
# r = |v|/|s|, so the scale theta/|v| = (2/|s|) atan(r)/r, and
# atan(r)/r = 1 - r^2/3 + r^4/5 - r^6/7 + ...; truncated after r^4 the neglected term r^6/7 is
# below 1e-17 for r < 2.03e-3. We switch at r = 1e-3 (truncation error < 1.5e-19).
_LOG_TAYLOR = 1e-3

# Jacobians: c(t) = (t - sin t)/t^3 and d(t) = (1 - (t/2) cot(t/2))/t^2 lose about
# log10(1/t^2) digits to cancellation when evaluated in closed form, so their series are used up
# to t = 2 (closed-form relative error there is ~5e-16):
#   c(t) = sum_k (-1)^k t^(2k) / (2k+3)!,                k = 0..11; at t = 2 the first
#          neglected term 4^12/27! ~ 1.5e-21 is ~1e-20 relative to c(2) ~ 0.136;
#   d(t) = sum_n |B_2n| t^(2n-2) / (2n)!  (Bernoulli numbers), n = 1..20; the terms shrink
#          like (t/2pi)^2 ~ 0.1, and at t = 2 the first neglected term ~7e-22 is ~1e-20 relative
#          to d(2) ~ 0.0895.
# The coefficient b(t) of the Jacobians is the one of exp (no cancellation in its half-angle form).
_JAC_SERIES = 2.0


def _bernoulli_even(n_max: int) -> list[Fraction]:
    """Exact Bernoulli numbers ``B_0 .. B_{2 n_max}`` (all indices), by the usual recurrence."""
    m_max = 2 * n_max
    B: list[Fraction] = [Fraction(1)]
    for m in range(1, m_max + 1):
        acc = sum((math.comb(m + 1, k) * B[k] for k in range(m)), Fraction(0))
        B.append(-acc / (m + 1))
    return B


_C_COEFFS = np.array(
    [float(Fraction((-1) ** k, math.factorial(2 * k + 3))) for k in range(12)], dtype=np.float64
)
_BERN = _bernoulli_even(20)
_D_COEFFS = np.array(
    [float(abs(_BERN[2 * n]) / math.factorial(2 * n)) for n in range(1, 21)], dtype=np.float64
)
del _BERN

# cayley_inv: 1 + tr(R) = 4 cos^2(theta/2) has an absolute rounding error of a few ulp (~1e-15)
# for a computed rotation; below 1e-14 the Cayley parameters would carry a relative error of
# order 10 %, and at a rotation by exactly pi they do not exist.
_CAYLEY_TINY = 1e-14


# --------------------------------------------------------------------------------------------
# Validation and small helpers
# --------------------------------------------------------------------------------------------


def _as_stack(x: Any, name: str, trailing: tuple[int, ...]) -> FloatArray:
    """``x`` as a float64 array whose trailing shape is ``trailing``, or a ValueError."""
    if getattr(getattr(x, "dtype", None), "kind", None) in ("c", "U", "S") or isinstance(x, (str, bytes)):
        raise TypeError(f"{name} must be an array of real numbers, got {str(x)[:60]!r}"
                        + (" (complex values)" if np.iscomplexobj(x) else ""))   # NumPy would drop an imaginary part
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {str(x)[:60]!r} ({exc})") from None
    k = len(trailing)
    if a.ndim < k or a.shape[a.ndim - k :] != trailing:
        expected = "(..., " + ", ".join(str(n) for n in trailing) + ")"
        raise ValueError(f"{name} must have shape {expected}, got {a.shape}")
    return a


def _finite(a: FloatArray, name: str) -> FloatArray:
    """``a`` if every entry is finite; else a ValueError naming ``name`` and the first bad entry
    (a NaN vector has no rotation: ``exp(nan)`` would be a NaN matrix returned as a result)."""
    if not np.isfinite(a).all():
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise ValueError(f"{name} must be finite (no NaN or inf), found {a[bad]} at index {bad}")
    return a


def _vec3(x: Any, name: str) -> FloatArray:
    """Vectors (..., 3), finite (rotation vectors, Cayley parameters)."""
    return _finite(_as_stack(x, name, (3,)), name)


def _vec4(x: Any, name: str) -> FloatArray:
    """Quaternions (..., 4), finite."""
    return _finite(_as_stack(x, name, (4,)), name)


def _mat3(x: Any, name: str) -> FloatArray:
    return _as_stack(x, name, (3, 3))


def _norm3(w: FloatArray) -> FloatArray:
    """Euclidean norm over the last axis of size 3, free of overflow and underflow."""
    return np.hypot(np.hypot(w[..., 0], w[..., 1]), w[..., 2])


def _horner(x: FloatArray, coeffs: FloatArray) -> FloatArray:
    """``sum_k coeffs[k] x**k`` by Horner's rule."""
    acc = np.full_like(x, coeffs[-1])
    for c in coeffs[-2::-1]:
        acc = acc * x + c
    return acc


def _hat(w: FloatArray) -> FloatArray:
    W = np.zeros(w.shape + (3,), dtype=np.float64)
    W[..., 0, 1] = -w[..., 2]
    W[..., 0, 2] = w[..., 1]
    W[..., 1, 0] = w[..., 2]
    W[..., 1, 2] = -w[..., 0]
    W[..., 2, 0] = -w[..., 1]
    W[..., 2, 1] = w[..., 0]
    return W


def _coeff_a_b(t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``a = sin(t)/t`` and ``b = (1 - cos t)/t**2`` for angles ``t >= 0``."""
    small = t < _EXP_TAYLOR
    t2 = t * t
    ts = np.where(small, 1.0, t)
    half = 0.5 * ts
    a = np.where(small, 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0), np.sin(ts) / ts)
    sinc_half = np.sin(half) / half
    b = np.where(small, 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0), 0.5 * sinc_half * sinc_half)
    return a, b


def _coeff_c(t: FloatArray) -> FloatArray:
    """``c = (t - sin t)/t**3`` for ``t >= 0``."""
    small = t < _JAC_SERIES
    ts = np.where(small, 1.0, t)
    return np.where(small, _horner(t * t, _C_COEFFS), (ts - np.sin(ts)) / (ts * ts * ts))


def _coeff_d(t: FloatArray) -> FloatArray:
    """``d = (1 - (t/2) cot(t/2))/t**2`` for ``t >= 0`` (infinite at t = 2 pi k, k >= 1)."""
    small = t < _JAC_SERIES
    ts = np.where(small, 1.0, t)
    half = 0.5 * ts
    with np.errstate(divide="ignore", invalid="ignore"):
        closed = (1.0 - half * np.cos(half) / np.sin(half)) / (ts * ts)
    return np.where(small, _horner(t * t, _D_COEFFS), closed)


def _jacobian(w: FloatArray, c1: FloatArray, c2: FloatArray) -> FloatArray:
    """``I + c1 hat(w) + c2 hat(w)^2`` with scalar coefficient arrays of shape ``w.shape[:-1]``."""
    W = _hat(w)
    return np.eye(3) + c1[..., None, None] * W + c2[..., None, None] * (W @ W)


def _quat_from_matrix(R: FloatArray) -> FloatArray:
    """Unit quaternion ``(x, y, z, w)`` of ``R`` by Shepperd's method (sign not normalised).

    The four rows of the symmetric matrix ``K`` below are ``4 q_i q`` for each component ``q_i``
    of the quaternion; the row whose pivot ``q_i^2`` is largest (``q_i^2 >= 1/4``) is used, so
    no quantity is formed by cancellation or divided by a small number.
    """
    R00, R01, R02 = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    R10, R11, R12 = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    R20, R21, R22 = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    tr = R00 + R11 + R22
    # candidate rows, each ordered (x, y, z, w)
    rows = np.stack(
        [
            np.stack([1.0 + R00 - R11 - R22, R01 + R10, R02 + R20, R21 - R12], axis=-1),
            np.stack([R01 + R10, 1.0 - R00 + R11 - R22, R12 + R21, R02 - R20], axis=-1),
            np.stack([R02 + R20, R12 + R21, 1.0 - R00 - R11 + R22, R10 - R01], axis=-1),
            np.stack([R21 - R12, R02 - R20, R10 - R01, 1.0 + tr], axis=-1),
        ],
        axis=-2,
    )
    pivot = np.argmax(np.stack([R00, R11, R22, tr], axis=-1), axis=-1)
    q = np.take_along_axis(rows, pivot[..., None, None], axis=-2)[..., 0, :]
    n = np.sqrt(np.sum(q * q, axis=-1))
    return q / n[..., None]


def _rotation_defects(R: Any) -> tuple[Any, Any]:
    """``(||R^T R - I||_F^2, det R)`` from the nine entries (floats for one matrix, else arrays)."""
    if isinstance(R, np.ndarray):
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = (
            (R[..., i, 0], R[..., i, 1], R[..., i, 2]) for i in range(3))
    else:
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R
    g00 = r00 * r00 + r10 * r10 + r20 * r20 - 1.0
    g11 = r01 * r01 + r11 * r11 + r21 * r21 - 1.0
    g22 = r02 * r02 + r12 * r12 + r22 * r22 - 1.0
    g01 = r00 * r01 + r10 * r11 + r20 * r21
    g02 = r00 * r02 + r10 * r12 + r20 * r22
    g12 = r01 * r02 + r11 * r12 + r21 * r22
    err2 = g00 * g00 + g11 * g11 + g22 * g22 + 2.0 * (g01 * g01 + g02 * g02 + g12 * g12)
    det = r00 * (r11 * r22 - r12 * r21) + r01 * (r12 * r20 - r10 * r22) + r02 * (r10 * r21 - r11 * r20)
    return err2, det


def _check_rotations(R: FloatArray, tol: float, func: str) -> None:
    """Raise ValueError naming the first finite matrix of ``R`` that is not a rotation to ``tol``.

    Non-finite matrices pass (their results are NaN). One matrix is checked in Python floats,
    a stack with array arithmetic on its nine entries (no temporaries of shape (..., 3, 3)).
    """
    tol = float(tol)
    if not (tol >= 0.0 and math.isfinite(tol)):
        raise ValueError(f"tol must be a finite non-negative number, got {tol!r}")
    if R.ndim == 2:
        err2, det = _rotation_defects(R.tolist())
        if not (err2 > tol * tol or det <= 0.0):  # passes NaN
            return
        err2, det = np.asarray(err2), np.asarray(det)
    else:
        err2, det = _rotation_defects(R)
        if not np.any((err2 > tol * tol) | (det <= 0.0)):
            return
    bad = (err2 > tol * tol) | (det <= 0.0)
    i = tuple(int(k) for k in np.argwhere(bad)[0]) if bad.ndim else ()
    where = f"R[{', '.join(map(str, i))}]" if i else "R"
    raise ValueError(
        f"{func}: {where} is not a rotation matrix (the rule: ||R^T R - I||_F <= tol = {tol:g} and "
        f"det R > 0); got ||R^T R - I||_F = {math.sqrt(err2[i]):.3g}, det R = {det[i]:.3g}"
        + (f" ({int(np.count_nonzero(bad))} of {bad.size} matrices fail)" if bad.ndim else "")
        + ". lgvi.so3.project(R) gives the nearest rotation.")


# --------------------------------------------------------------------------------------------
# hat / vee
# --------------------------------------------------------------------------------------------


def hat(w: ArrayLike) -> FloatArray:
    """Skew-symmetric matrix of a vector: ``hat(w) @ v == np.cross(w, v)``.

    Parameters
    ----------
    w : array_like, shape (..., 3)
        Vectors.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``[[0, -w3, w2], [w3, 0, -w1], [-w2, w1, 0]]`` for each vector.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import hat
    >>> hat([1.0, 2.0, 3.0])
    array([[ 0., -3.,  2.],
           [ 3.,  0., -1.],
           [-2.,  1.,  0.]])
    >>> np.allclose(hat([1, 2, 3]) @ [4, 5, 6], np.cross([1, 2, 3], [4, 5, 6]))
    True
    """
    return _hat(_vec3(w, "w"))


def vee(W: ArrayLike) -> FloatArray:
    """Vector of a skew-symmetric matrix, the inverse of :func:`hat`.

    Parameters
    ----------
    W : array_like, shape (..., 3, 3)
        Matrices. Only the antisymmetric part ``(W - W^T)/2`` is used, so ``vee`` is the
        least-squares inverse of :func:`hat` for matrices that are not exactly skew.

    Returns
    -------
    ndarray, shape (..., 3)
        ``w`` with ``hat(w) == (W - W^T)/2``.

    Examples
    --------
    >>> from lgvi.so3 import hat, vee
    >>> vee(hat([1.0, 2.0, 3.0]))
    array([1., 2., 3.])
    """
    W = _mat3(W, "W")
    return 0.5 * np.stack(
        [W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0], W[..., 1, 0] - W[..., 0, 1]],
        axis=-1,
    )


# --------------------------------------------------------------------------------------------
# exp / log
# --------------------------------------------------------------------------------------------


def exp_minus_identity(w: ArrayLike) -> FloatArray:
    """``exp(w) - I`` without cancellation, for accurate small rotations.

    Parameters
    ----------
    w : array_like, shape (..., 3)
        Rotation vectors (axis times angle in radians).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``a hat(w) + b hat(w)^2`` with ``a = sin(t)/t``, ``b = (1 - cos t)/t^2``, ``t = |w|``.
        Every entry keeps full relative precision even when ``t`` is far below machine epsilon,
        where ``exp(w) - I`` computed by subtraction would be zero or pure round-off.

    Examples
    --------
    >>> from lgvi.so3 import exp_minus_identity
    >>> E = exp_minus_identity([0.0, 0.0, 1e-20])
    >>> float(E[1, 0])
    1e-20
    """
    w = _vec3(w, "w")
    t = _norm3(w)
    a, b = _coeff_a_b(t)
    W = _hat(w)
    return a[..., None, None] * W + b[..., None, None] * (W @ W)


def exp(w: ArrayLike) -> FloatArray:
    """Exponential map from rotation vectors to rotation matrices (Rodrigues' formula).

    Parameters
    ----------
    w : array_like, shape (..., 3)
        Rotation vectors: unit axis times angle in radians (any magnitude).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Rotation matrices ``R = I + a hat(w) + b hat(w)^2``.

    Notes
    -----
    With ``t = |w|``, ``a = sin(t)/t`` and ``b = (1 - cos t)/t^2``. For ``t < 5e-3`` both are
    replaced by their Taylor series through ``t^4`` (truncation error below ``1e-17``
    relative); above, ``b`` is evaluated as ``(1/2) (sin(t/2)/(t/2))^2``, which is free of
    cancellation. ``exp(-w) == exp(w).T``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import exp
    >>> R = exp([0.0, 0.0, np.pi / 2])
    >>> np.round(R, 12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    return exp_minus_identity(w) + np.eye(3)


#: Default bound of :func:`log` on ``||R^T R - I||_F``: matrices further from SO(3) are refused.
LOG_TOL = 1e-6


def log(R: ArrayLike, *, tol: float = LOG_TOL) -> FloatArray:
    """Logarithm map from rotation matrices to rotation vectors with angle in ``[0, pi]``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices. Slightly non-orthogonal input (round-off) is tolerated: the result is
        the rotation vector of the nearest unit quaternion found by Shepperd's method. Non-finite
        matrices give NaN.
    tol : float, optional
        Bound on the orthogonality error ``||R^T R - I||_F`` (default ``1e-6``, :data:`LOG_TOL`):
        a finite matrix beyond it, or with ``det R <= 0`` (a reflection), is not a rotation and
        has no rotation vector. Within it the result is that of a rotation at most about ``tol``
        away from ``R``. Use :func:`project` first for the nearest rotation of a matrix that
        drifted further (e.g. the attitude of an explicit Runge-Kutta run).

    Returns
    -------
    ndarray, shape (..., 3)
        Rotation vectors ``w`` with ``exp(w) == R`` and ``|w| <= pi``. For a rotation by exactly
        ``pi`` either of the two equivalent vectors ``+-pi n`` may be returned.

    Raises
    ------
    ValueError
        If a finite matrix of ``R`` is not a rotation (see ``tol``); the message gives its index,
        orthogonality error and determinant.

    Notes
    -----
    ``R`` is converted to a unit quaternion ``(v, s)`` with Shepperd's method: the largest of
    ``1 + tr R, 1 + 2 R_ii - tr R`` selects which component is taken from the diagonal, the others
    come from sums and differences of off-diagonal pairs, so the axis is recovered from the
    symmetric part near ``pi`` (where the antisymmetric part vanishes) and from the antisymmetric
    part near ``0``. Then ``theta = 2 atan2(|v|, |s|)`` and ``w = sign(s) theta v / |v|``; for
    ``|v| < 1e-3 |s|`` the factor ``theta / |v| = (2/|s|) atan(r)/r`` (``r = |v|/|s|``) uses the
    series ``1 - r^2/3 + r^4/5``. Norms are computed with ``hypot``, so rotation vectors as small
    as ``1e-300`` keep full relative precision.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import exp, log
    >>> w = np.array([0.3, -0.2, 0.1])
    >>> np.allclose(log(exp(w)), w)
    True
    >>> np.round(log(np.diag([1.0, -1.0, -1.0])), 12)
    array([3.14159265, 0.        , 0.        ])
    """
    R = _mat3(R, "R")
    _check_rotations(R, tol, "log")
    q = _quat_from_matrix(R)
    v = q[..., :3]
    s = q[..., 3]
    abs_s = np.abs(s)
    nv = _norm3(v)
    small = nv < _LOG_TAYLOR * abs_s
    nv_safe = np.where(small, 1.0, nv)
    s_safe = np.where(small, abs_s, 1.0)
    r = nv / s_safe
    r2 = r * r
    series = 2.0 / s_safe * (1.0 - r2 / 3.0 * (1.0 - 0.6 * r2))
    closed = 2.0 * np.arctan2(nv_safe, abs_s) / nv_safe
    scale = np.where(small, series, closed)
    scale = np.where(s < 0.0, -scale, scale)
    return scale[..., None] * v


# --------------------------------------------------------------------------------------------
# Jacobians
# --------------------------------------------------------------------------------------------


def left_jacobian(w: ArrayLike) -> FloatArray:
    """Left Jacobian of SO(3): ``exp(w + d) ~ exp(hat(Jl(w) d)) exp(w)``.

    Parameters
    ----------
    w : array_like, shape (..., 3)
        Rotation vectors.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``Jl(w) = I + b hat(w) + c hat(w)^2``.

    Notes
    -----
    ``b = (1 - cos t)/t^2``, ``c = (t - sin t)/t^3`` with ``t = |w|``; ``c`` is evaluated by its
    series ``sum_k (-1)^k t^(2k)/(2k+3)!`` for ``t < 2`` to avoid cancellation.
    ``Jl(w) = Jr(-w) = Jr(w).T``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import exp, left_jacobian
    >>> w, d = np.array([0.4, 0.1, -0.3]), 1e-7 * np.array([1.0, -2.0, 0.5])
    >>> np.allclose(exp(w + d), exp(left_jacobian(w) @ d) @ exp(w), atol=1e-13)
    True
    """
    w = _vec3(w, "w")
    t = _norm3(w)
    _, b = _coeff_a_b(t)
    return _jacobian(w, b, _coeff_c(t))


def right_jacobian(w: ArrayLike) -> FloatArray:
    """Right Jacobian of SO(3): ``exp(w + d) ~ exp(w) exp(hat(Jr(w) d))``.

    Parameters
    ----------
    w : array_like, shape (..., 3)
        Rotation vectors.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``Jr(w) = I - b hat(w) + c hat(w)^2 = Jl(-w) = Jl(w).T`` (coefficients as in
        :func:`left_jacobian`).

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import exp, right_jacobian
    >>> w, d = np.array([0.4, 0.1, -0.3]), 1e-7 * np.array([1.0, -2.0, 0.5])
    >>> np.allclose(exp(w + d), exp(w) @ exp(right_jacobian(w) @ d), atol=1e-13)
    True
    """
    w = _vec3(w, "w")
    t = _norm3(w)
    _, b = _coeff_a_b(t)
    return _jacobian(w, -b, _coeff_c(t))


def left_jacobian_inv(w: ArrayLike) -> FloatArray:
    """Inverse of the left Jacobian, ``Jl(w)^-1``.

    Parameters
    ----------
    w : array_like, shape (..., 3)
        Rotation vectors. ``Jl`` is singular at ``|w| = 2 pi k`` (``k >= 1``), where the result
        is infinite or meaningless; use ``|w| <= pi`` (the range of :func:`log`).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``Jl(w)^-1 = I - hat(w)/2 + d hat(w)^2``.

    Notes
    -----
    ``d = (1 - (t/2) cot(t/2))/t^2 = 1/12 + t^2/720 + t^4/30240 + ...``, evaluated by its series
    ``sum_n |B_2n| t^(2n-2)/(2n)!`` (Bernoulli numbers) for ``t < 2``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import left_jacobian, left_jacobian_inv
    >>> w = np.array([0.4, 0.1, -0.3])
    >>> np.allclose(left_jacobian_inv(w) @ left_jacobian(w), np.eye(3))
    True
    """
    w = _vec3(w, "w")
    t = _norm3(w)
    return _jacobian(w, np.full_like(t, -0.5), _coeff_d(t))


def right_jacobian_inv(w: ArrayLike) -> FloatArray:
    """Inverse of the right Jacobian, ``Jr(w)^-1 = Jl(-w)^-1``.

    Parameters
    ----------
    w : array_like, shape (..., 3)
        Rotation vectors (singular at ``|w| = 2 pi k``, ``k >= 1``; see
        :func:`left_jacobian_inv`).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``Jr(w)^-1 = I + hat(w)/2 + d hat(w)^2``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import right_jacobian, right_jacobian_inv
    >>> w = np.array([0.4, 0.1, -0.3])
    >>> np.allclose(right_jacobian(w) @ right_jacobian_inv(w), np.eye(3))
    True
    """
    w = _vec3(w, "w")
    t = _norm3(w)
    return _jacobian(w, np.full_like(t, 0.5), _coeff_d(t))


# --------------------------------------------------------------------------------------------
# Cayley map
# --------------------------------------------------------------------------------------------


def cayley(f: ArrayLike) -> FloatArray:
    """Cayley map ``(I + hat f)(I - hat f)^-1`` from Cayley parameters to rotations.

    Parameters
    ----------
    f : array_like, shape (..., 3)
        Cayley (Gibbs / Rodrigues) parameters, ``f = tan(theta/2) n``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Rotation matrices ``I + 2 (hat f + hat f^2)/(1 + |f|^2)``, a rotation about ``f`` by the
        angle ``2 atan |f|``.

    Notes
    -----
    The closed form is evaluated with ``f`` scaled by ``max(1, |f|)`` so that very large
    parameters (rotations close to ``pi``) do not overflow.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import cayley, exp
    >>> np.allclose(cayley([0.0, 0.0, 1.0]), exp([0.0, 0.0, np.pi / 2]))
    True
    """
    f = _vec3(f, "f")
    rho = np.maximum(1.0, _norm3(f))
    g = f / rho[..., None]
    G = _hat(g)
    inv_rho = 1.0 / rho
    denom = inv_rho * inv_rho + np.sum(g * g, axis=-1)
    coef = (2.0 / denom)[..., None, None]
    return np.eye(3) + coef * (inv_rho[..., None, None] * G + G @ G)


def cayley_inv(R: ArrayLike) -> FloatArray:
    """Inverse Cayley map: ``f`` with ``hat(f) = (R - I)(R + I)^-1``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices, none of them a rotation by (nearly) ``pi``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``f = vee(R - R^T) / (1 + tr R)``.

    Raises
    ------
    ValueError
        If ``1 + tr R <= 1e-14`` for any matrix: the Cayley parameters ``tan(theta/2) n`` do not
        exist for a rotation by ``pi`` and are pure round-off that close to it.

    Notes
    -----
    For ``R = cayley(f)`` with ``s = |f|``: ``R - R^T = 4 hat(f)/(1 + s^2)`` and
    ``1 + tr R = 4/(1 + s^2)``, so the quotient is ``f``.

    Examples
    --------
    >>> from lgvi.so3 import cayley, cayley_inv
    >>> cayley_inv(cayley([0.1, -0.2, 0.3]))
    array([ 0.1, -0.2,  0.3])
    """
    R = _mat3(R, "R")
    denom = 1.0 + R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    bad = ~(denom > _CAYLEY_TINY)
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"R{list(idx) if idx else ''} is a rotation by (nearly) pi: 1 + trace(R) = "
            f"{denom[idx]:.3g} <= {_CAYLEY_TINY:g}, where the inverse Cayley map is undefined"
        )
    num = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
        axis=-1,
    )
    return num / denom[..., None]


# --------------------------------------------------------------------------------------------
# Quaternions
# --------------------------------------------------------------------------------------------


def _to_scalar_last(q: FloatArray, scalar_first: bool) -> FloatArray:
    return q[..., [1, 2, 3, 0]] if scalar_first else q


def _from_scalar_last(q: FloatArray, scalar_first: bool) -> FloatArray:
    return q[..., [3, 0, 1, 2]] if scalar_first else q


def quat_to_matrix(q: ArrayLike, *, scalar_first: bool = False) -> FloatArray:
    """Rotation matrices of quaternions (Hamilton convention, active rotation).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, ``(x, y, z, w)`` (scalar-last, as :meth:`scipy.spatial.transform.Rotation.
        from_quat`) or ``(w, x, y, z)`` with ``scalar_first=True``. They are normalised first,
        so any non-zero multiple of a unit quaternion is accepted.
    scalar_first : bool, optional
        Whether the scalar part comes first. Default False.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Rotation matrices; ``q`` and ``-q`` give the same matrix.

    Raises
    ------
    ValueError
        If a quaternion has zero (or non-finite) norm.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import quat_to_matrix
    >>> s = np.sqrt(0.5)
    >>> np.round(quat_to_matrix([0.0, 0.0, s, s]), 12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    q = _to_scalar_last(_vec4(q, "q"), scalar_first)
    m = np.max(np.abs(q), axis=-1)
    bad = ~((m > 0.0) & np.isfinite(m))
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"q must have a finite, non-zero norm; q{list(idx) if idx else ''} = {q[idx]} "
            "(scalar-last order)"
        )
    q = q / m[..., None]
    q = q / np.sqrt(np.sum(q * q, axis=-1))[..., None]
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    R = np.empty(q.shape[:-1] + (3, 3), dtype=np.float64)
    R[..., 0, 0] = 1.0 - 2.0 * (yy + zz)
    R[..., 0, 1] = 2.0 * (xy - wz)
    R[..., 0, 2] = 2.0 * (xz + wy)
    R[..., 1, 0] = 2.0 * (xy + wz)
    R[..., 1, 1] = 1.0 - 2.0 * (xx + zz)
    R[..., 1, 2] = 2.0 * (yz - wx)
    R[..., 2, 0] = 2.0 * (xz - wy)
    R[..., 2, 1] = 2.0 * (yz + wx)
    R[..., 2, 2] = 1.0 - 2.0 * (xx + yy)
    return R


def matrix_to_quat(R: ArrayLike, *, scalar_first: bool = False) -> FloatArray:
    """Unit quaternions of rotation matrices (Shepperd's method), canonical sign ``w >= 0``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices. They are not orthogonalised; for matrices off SO(3) by round-off the
        result is the normalised quaternion of Shepperd's largest-pivot formula (use
        :func:`project` first for matrices far from SO(3)).
    scalar_first : bool, optional
        Return ``(w, x, y, z)`` instead of the default ``(x, y, z, w)``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions with the sign chosen so that ``w >= 0``; when ``w == 0`` the first
        non-zero of ``x, y, z`` is positive. This is scipy's ``as_quat(canonical=True)``
        (scipy's default ``canonical=False`` may return either sign).

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import exp, matrix_to_quat
    >>> np.round(matrix_to_quat(exp([0.0, 0.0, np.pi / 2])), 12)
    array([0.        , 0.        , 0.70710678, 0.70710678])
    >>> np.round(matrix_to_quat(np.eye(3), scalar_first=True), 12)
    array([1., 0., 0., 0.])
    """
    R = _mat3(R, "R")
    q = _quat_from_matrix(R)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    first_vec = np.where(x != 0.0, x, np.where(y != 0.0, y, z))
    flip = (w < 0.0) | ((w == 0.0) & (first_vec < 0.0))
    q = np.where(flip[..., None], -q, q)
    return _from_scalar_last(q, scalar_first)


def quat_multiply(p: ArrayLike, q: ArrayLike, *, scalar_first: bool = False) -> FloatArray:
    """Hamilton product ``p q``: the rotation ``q`` followed by ``p``.

    Parameters
    ----------
    p, q : array_like, shape (..., 4)
        Quaternions (scalar-last unless ``scalar_first=True``); leading axes broadcast. They are
        not normalised.
    scalar_first : bool, optional
        Order of the components of ``p``, ``q`` and the result. Default False.

    Returns
    -------
    ndarray, shape (..., 4)
        ``(p_w q_v + q_w p_v + p_v x q_v, p_w q_w - p_v . q_v)`` (in the chosen order), so that
        ``quat_to_matrix(quat_multiply(p, q)) == quat_to_matrix(p) @ quat_to_matrix(q)``, like
        ``Rotation.from_quat(p) * Rotation.from_quat(q)``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import quat_multiply
    >>> i, j = [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]
    >>> quat_multiply(i, j)
    array([0., 0., 1., 0.])
    """
    p = _to_scalar_last(_vec4(p, "p"), scalar_first)
    q = _to_scalar_last(_vec4(q, "q"), scalar_first)
    pv, pw = p[..., :3], p[..., 3:]
    qv, qw = q[..., :3], q[..., 3:]
    vec = pw * qv + qw * pv + np.cross(pv, qv)
    sca = pw * qw - np.sum(pv * qv, axis=-1, keepdims=True)
    out = np.concatenate([vec, sca], axis=-1)  # both carry the broadcast leading shape
    return _from_scalar_last(out, scalar_first)


def quat_continuous(q: ArrayLike, axis: int = 0) -> FloatArray:
    """Flip quaternion signs along a time axis so that the series is sign-continuous.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, with at least one leading (time) axis. The component order does not matter.
    axis : int, optional
        The time axis, counted among the leading axes ``q.shape[:-1]`` (default 0; ``-1`` is the
        last leading axis, never the component axis).

    Returns
    -------
    ndarray, same shape as ``q``
        ``+-q`` with the first quaternion unchanged and every consecutive pair having a
        non-negative dot product; each quaternion describes the same rotation as before.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import quat_continuous
    >>> q = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -0.1, -0.995], [0.0, 0.0, 0.2, 0.98]])
    >>> quat_continuous(q) + 0.0
    array([[0.   , 0.   , 0.   , 1.   ],
           [0.   , 0.   , 0.1  , 0.995],
           [0.   , 0.   , 0.2  , 0.98 ]])
    """
    q = _vec4(q, "q")
    n_lead = q.ndim - 1
    if n_lead < 1:
        raise ValueError(f"q must have shape (n, ..., 4) with a time axis, got {q.shape}")
    if not isinstance(axis, (int, np.integer)) or not -n_lead <= axis < n_lead:
        raise ValueError(
            f"axis must be an integer in [{-n_lead}, {n_lead - 1}] (a leading axis of q with "
            f"shape {q.shape}), got {axis!r}"
        )
    axis = int(axis) % n_lead
    qm = np.moveaxis(q, axis, 0)
    if qm.shape[0] == 0:
        return q.copy()
    dots = np.sum(qm[1:] * qm[:-1], axis=-1)
    steps = np.where(dots < 0.0, -1.0, 1.0)
    signs = np.concatenate([np.ones((1,) + qm.shape[1:-1]), np.cumprod(steps, axis=0)], axis=0)
    return np.moveaxis(qm * signs[..., None], 0, axis)


# --------------------------------------------------------------------------------------------
# Projection and checks
# --------------------------------------------------------------------------------------------


def project(M: ArrayLike) -> FloatArray:
    """Nearest rotation matrix in the Frobenius norm.

    Parameters
    ----------
    M : array_like, shape (..., 3, 3)
        Arbitrary real matrices.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``U diag(1, 1, det(U V^T)) V^T`` from the SVD ``M = U S V^T``: the rotation closest to
        ``M``. For a reflection-like ``M`` (``det M < 0``) the direction of the smallest
        singular value is flipped. The result is not unique when ``M`` has rank below 2 (or
        ``det M < 0`` with repeated smallest singular values).

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import project, is_rotation
    >>> bool(is_rotation(project(np.eye(3) + 1e-3 * np.arange(9.0).reshape(3, 3))))
    True
    >>> project(np.diag([3.0, 2.0, -1.0])) + 0.0
    array([[1., 0., 0.],
           [0., 1., 0.],
           [0., 0., 1.]])
    """
    M = _mat3(M, "M")
    U, _, Vt = np.linalg.svd(M)
    d = np.linalg.det(U @ Vt)
    U = U.copy()
    U[..., :, 2] *= np.where(d < 0.0, -1.0, 1.0)[..., None]
    return U @ Vt


def orthogonality_error(R: ArrayLike) -> FloatArray:
    """Distance from orthogonality, ``||R^T R - I||_F``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Matrices.

    Returns
    -------
    ndarray, shape (...)
        Frobenius norm of ``R^T R - I`` for each matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import orthogonality_error
    >>> orthogonality_error(np.stack([np.eye(3), 2 * np.eye(3)]))
    array([0.        , 5.19615242])
    """
    R = _mat3(R, "R")
    E = np.swapaxes(R, -1, -2) @ R - np.eye(3)
    return np.sqrt(np.sum(E * E, axis=(-2, -1)))


def is_rotation(R: ArrayLike, tol: float = 1e-9) -> NDArray[np.bool_]:
    """Whether matrices are rotations: orthogonal to ``tol`` and with positive determinant.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Matrices.
    tol : float, optional
        Bound on :func:`orthogonality_error`. Default ``1e-9``.

    Returns
    -------
    ndarray of bool, shape (...)
        True where ``||R^T R - I||_F <= tol`` and ``det R > 0`` (False for non-finite entries).

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.so3 import is_rotation
    >>> is_rotation(np.stack([np.eye(3), -np.eye(3), 1.1 * np.eye(3)]))
    array([ True, False, False])
    """
    R = _mat3(R, "R")
    tol = float(tol)
    if not (tol >= 0.0 and math.isfinite(tol)):
        raise ValueError(f"tol must be a finite non-negative number, got {tol!r}")
    err = orthogonality_error(R)
    finite = np.all(np.isfinite(R), axis=(-2, -1))
    det = np.linalg.det(np.where(finite[..., None, None], R, 0.0))
    return np.asarray(finite & (err <= tol) & (det > 0.0))


# --------------------------------------------------------------------------------------------
# Modified Rodrigues parameters (Basilisk's attitude coordinates; lgvi.control keeps these names)
# --------------------------------------------------------------------------------------------
#: How far from a rotation a matrix given to :func:`mrp_from_matrix` may be (``lgvi._validation.REPAIR_TOL``).
_MRP_TOL = 1e-6


def mrp_from_matrix(R: Any) -> np.ndarray:
    """The MRP ``sigma`` (``|sigma| <= 1``) of the rotation ``R = exp(hat(phi e))``: ``e tan(phi/4)``.

    For lgvi's ``R`` (body to inertial) that is Basilisk's ``sigma_BN``; for ``R_ref.T @ R`` it is
    ``sigma_BR``. Vectorised over leading axes: ``(..., 3, 3) -> (..., 3)``. The shadow set
    (``|sigma| > 1``) is never returned: the rotation angle is taken in ``[0, pi]``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi import so3
    >>> sigma = so3.mrp_from_matrix(so3.exp([0.0, 0.0, np.pi / 2]))   # a quarter turn about z
    >>> bool(np.allclose(sigma, [0.0, 0.0, np.tan(np.pi / 8)]))
    True
    """
    R = _mat3(R, "R")
    err, det = orthogonality_error(R), np.linalg.det(R)
    bad = ~(err <= _MRP_TOL) | ~(det > 0.0)
    if np.any(bad):     # a zero or scaled matrix has no MRP (matrix_to_quat would return one anyway)
        i = tuple(int(x) for x in np.argwhere(np.atleast_1d(bad))[0]) if R.ndim > 2 else ()
        raise ValueError(f"R must hold rotation matrices (orthogonal to {_MRP_TOL:g}, determinant +1); "
                         f"R{list(i) if i else ''} has |R^T R - I| = {float(np.asarray(err)[i]):.3g}, "
                         f"det = {float(np.asarray(det)[i]):.3g}")
    q = matrix_to_quat(R)     # scalar-last
    q = np.where(q[..., 3:4] < 0.0, -q, q)
    return q[..., :3] / (1.0 + q[..., 3:4])


def matrix_from_mrp(sigma: Any) -> np.ndarray:
    """The rotation matrix of the MRP ``sigma`` (inverse of :func:`mrp_from_matrix`): ``(..., 3) -> (..., 3, 3)``."""
    s = _as_stack(sigma, "sigma", (3,))
    if s.shape == (3,):
        R = _matrix_from_mrp3(*s.tolist())
        if R is not None:
            return R
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    q = np.concatenate([2.0 * s, 1.0 - s2], axis=-1) / (1.0 + s2)
    if not np.all(np.isfinite(q)):
        raise ValueError(f"sigma must give a quaternion of finite, non-zero norm; |sigma|^2 overflows for "
                         f"{np.asarray(s).reshape(-1, 3)[np.flatnonzero(~np.isfinite(q).all(axis=-1))[0]].tolist()}")
    return quat_to_matrix(q)


def _matrix_from_mrp3(a: float, b: float, c: float) -> np.ndarray | None:
    """:func:`matrix_from_mrp` of one MRP in Python floats: the same IEEE operations in the same
    order as the NumPy code and :func:`lgvi.so3.quat_to_matrix` (so the same bits), a tenth of
    the time; ``None`` for a quaternion that is not finite (the NumPy code says why)."""
    s2 = (a * a + b * b) + c * c                      # np.sum(s * s, axis=-1)
    d = 1.0 + s2
    q = [2.0 * a / d, 2.0 * b / d, 2.0 * c / d, (1.0 - s2) / d]
    if not all(map(math.isfinite, q)):
        return None
    m = max(map(abs, q))                              # quat_to_matrix: q / max|q|, then / |q|
    if not m > 0.0:
        return None
    x, y, z, w = (v / m for v in q)
    n = math.sqrt(((x * x + y * y) + z * z) + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    return np.array([[1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy)],
                     [2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx)],
                     [2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)]])
