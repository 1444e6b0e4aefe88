"""Input checks shared by the Python layer. Each error names the argument, the value and the rule."""

from __future__ import annotations

import math
import numbers
import sys
import operator
from typing import Any

import numpy as np

#: An attitude matrix orthogonal to this (``||R^T R - I||_F``, det +1) is used exactly as given.
ROTATION_TOL = 1e-9
#: One orthogonal to this but not to ROTATION_TOL is replaced by its nearest rotation, with a
#: warning; beyond it, refused. 1e-6 admits a rotation written with 7 significant digits (a
#: printout, a table: rounding each entry by 5e-8 gives ||R^T R - I||_F up to about 3e-7); a
#: matrix further off is not a rounded rotation but a mistake (a wrong sign or digit) that a
#: silent projection would hide. The replacement moves the attitude by about the defect (rad).
REPAIR_TOL = 1e-6


def _short(value: Any) -> str:
    text = np.array2string(np.asarray(value), precision=6, threshold=12) if isinstance(
        value, np.ndarray) else repr(value)
    return text if len(text) <= 120 else text[:117] + "..."


def _not_real(value: Any, name: str) -> None:
    raise TypeError(f"{name} must be an array of real numbers, got {_short(value)}"
                    + (" (complex values)" if np.iscomplexobj(value) else ""))


def as_float_array(value: Any, name: str, shape: tuple[int | None, ...] | None = None) -> np.ndarray:
    """Convert to a float64 array, check its shape (``None`` entries are free) and finiteness."""
    # NumPy would drop an imaginary part, and read the text "1.0" as the number 1.0 (lists, the common
    # case, skip the checks: NumPy refuses a complex number in a list itself)
    if type(value) is np.ndarray:
        if value.dtype.kind in "cUS":
            _not_real(value, name)
    elif type(value) is not list and type(value) is not tuple and (
            isinstance(value, (str, bytes)) or getattr(getattr(value, "dtype", None), "kind", "") in ("c", "U", "S")):
        _not_real(value, name)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of real numbers, got {_short(value)}") from exc
    if shape is not None and arr.shape != shape:     # equal: the common case, no loop over the axes
        ok = arr.ndim == len(shape) and all(s is None or s == d for s, d in zip(shape, arr.shape))
        if not ok:
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
            raise ValueError(f"{name} must have shape {want}, got shape {arr.shape}")
    # a small array (a vector, a matrix): its sum is finite only if every entry is (a NaN or an
    # infinity makes it NaN or infinite); a finite sum is the answer, anything else is checked
    if arr.size <= 64 and math.isfinite(sum(arr.ravel().tolist())):
        return arr
    if not np.isfinite(arr).all():
        bad = np.argwhere(~np.isfinite(arr))[0]
        where = f" at index {tuple(int(i) for i in bad)}" if arr.ndim else ""
        raise ValueError(f"{name} must be finite (no NaN or inf), found {arr[tuple(bad)]}{where}")
    return arr


def as_float(value: Any, name: str, *, nonzero: bool = False, positive: bool = False) -> float:
    """A finite real scalar."""
    if type(value) is not float and type(value) is not int:  # the common cases skip the ABC checks
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
            if not (isinstance(value, np.ndarray) and value.ndim == 0 and np.issubdtype(value.dtype, np.number)):
                raise TypeError(f"{name} must be a real number, got {_short(value)} of type "
                                f"{type(value).__name__}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x}")
    if nonzero and x == 0.0:
        raise ValueError(f"{name} must be non-zero, got {x}")
    if positive and not x > 0.0:
        raise ValueError(f"{name} must be positive, got {x}")
    return x


def as_int(value: Any, name: str, *, minimum: int = 0) -> int:
    """An integer (Python or NumPy, not bool, not a float) not below ``minimum``."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    try:
        n = operator.index(value)
    except TypeError as exc:
        raise TypeError(f"{name} must be an integer, got {_short(value)} of type {type(value).__name__}") from exc
    if n < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {n}")
    return n


def is_scipy_rotation(value: Any) -> bool:
    """``isinstance(value, scipy.spatial.transform.Rotation)`` without importing SciPy (0.4 s): a
    Rotation can only exist if its module is loaded already."""
    module = sys.modules.get("scipy.spatial.transform")
    return module is not None and isinstance(value, module.Rotation)


def as_rotation(value: Any, name: str = "R0", tol: float = ROTATION_TOL) -> np.ndarray:
    """A (3,3) rotation matrix (or a scipy ``Rotation``), orthogonal to ``tol`` with det +1.

    A matrix orthogonal to :data:`REPAIR_TOL` but not to ``tol`` is replaced by its nearest
    rotation (:func:`lgvi.so3.project`) with an :class:`lgvi.errors.AttitudeWarning`.
    """
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (3, 3) \
            and _surely_rotation(value, tol):
        return value            # what the checks below return for it (finite, a rotation to tol)
    if is_scipy_rotation(value):
        if not value.single:
            raise ValueError(f"{name} must be a single rotation, got a stack of {len(value)}")
        return value.as_matrix().astype(np.float64)
    R = as_float_array(value, name, (3, 3))
    R, err = nearest_rotation(R, name, f"Use lgvi.so3.project({name}) for the nearest rotation.", tol)
    if err is not None:
        warn_repaired(f"{name} is {err:.2g} away from a rotation", R)
    return R


def nearest_rotation(R: np.ndarray, name: str, fix: str, tol: float = ROTATION_TOL) -> tuple[np.ndarray, float | None]:
    """``(R, None)`` for a rotation to ``tol``; ``(nearest rotation, its defect)`` within
    :data:`REPAIR_TOL`; else ValueError ending in ``fix`` (what the user should change)."""
    if _surely_rotation(R, tol):
        return R, None
    err = float(np.linalg.norm(R.T @ R - np.eye(3)))
    det = float(np.linalg.det(R))
    if err <= tol and det > 0.0:
        return R, None
    if err <= REPAIR_TOL and det > 0.0:
        from .so3 import project

        return project(R), err
    rule = ("determinant -1 (a reflection)" if det < 0 and err <= REPAIR_TOL
            else f"orthogonality error |R^T R - I| = {err:.3g} > {REPAIR_TOL:g}")
    raise ValueError(f"{name} must be a rotation matrix (orthogonal to {REPAIR_TOL:g}, determinant +1); "
                     f"got {rule}. {fix}")


def _surely_rotation(R: np.ndarray, tol: float) -> bool:
    """True when ``R`` (3, 3) is orthogonal to ``tol / 2`` with det +1, in plain float arithmetic
    (a few us; the NumPy check costs about 7 us a call). The margin covers any difference in
    rounding from the NumPy check, so every ``R`` accepted here is one that check accepts as is
    (and returns unchanged); anything else, NaN included, goes to the full check."""
    (a, b, c), (d, e, f), (g, h, i) = R.tolist()
    # R^T R - I: the column Gram matrix (symmetric: the off-diagonal entries count twice)
    d11 = a * a + d * d + g * g - 1.0
    d22 = b * b + e * e + h * h - 1.0
    d33 = c * c + f * f + i * i - 1.0
    d12 = a * b + d * e + g * h
    d13 = a * c + d * f + g * i
    d23 = b * c + e * f + h * i
    err2 = d11 * d11 + d22 * d22 + d33 * d33 + 2.0 * (d12 * d12 + d13 * d13 + d23 * d23)
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return tol >= 0.0 and err2 <= 0.25 * tol * tol and det > 0.5


def warn_repaired(what: str, R: np.ndarray, stacklevel: int = 4) -> None:
    """Warn that an attitude was replaced by its nearest rotation ``R``."""
    import warnings

    from .errors import AttitudeWarning

    warnings.warn(f"{what} (||R^T R - I||_F, accepted up to {REPAIR_TOL:g}, used as is up to {ROTATION_TOL:g}); "
                  f"using the nearest rotation instead: {_short(R)}", AttitudeWarning, stacklevel=stacklevel)


def choice(value: Any, name: str, options: dict[str, int] | tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name} must be one of {', '.join(repr(o) for o in options)}; got {value!r}")
    return value
