"""Rigid bodies: the inertia matrix, its nonstandard counterpart and their checks.

The paper writes the kinetic energy of a rigid body with the *nonstandard* inertia matrix
``Jd = 1/2 * integral(rho X X^T)``, which is related to the standard inertia matrix ``J`` by

.. math::

    J = \\operatorname{tr}(J_d) I_{3\\times3} - J_d, \\qquad
    J_d = \\tfrac12 \\operatorname{tr}(J) I_{3\\times3} - J.

:class:`RigidBody` validates an inertia once, at the boundary, and keeps ``J``, ``Jd`` and
``J^{-1}`` as read-only float64 arrays for the integrators.
"""

from __future__ import annotations

import math
from dataclasses import InitVar, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["RigidBody", "check_inertia", "inertia_to_jd", "jd_to_inertia"]

#: Relative tolerance of the symmetry check and of the triangle inequality (equality allowed).
RTOL: float = 1e-12

_FloatArray = NDArray[np.float64]


def _fmt(value: Any) -> str:
    """Short, one-line text of a value for an error message."""
    try:
        arr = np.asarray(value)
    except Exception:  # pragma: no cover - only for exotic objects
        return repr(value)
    if arr.dtype.kind in "biufc":
        text = np.array2string(arr, precision=10, separator=", ", threshold=20)
        return " ".join(text.split())
    return " ".join(repr(value).split())


def _square_3x3(M: ArrayLike, name: str) -> _FloatArray:
    """``M`` as a float64 array of shape ``(..., 3, 3)``, or a ValueError naming ``name``."""
    try:
        arr = np.asarray(M)
    except Exception as exc:  # ragged nested sequences and the like
        raise ValueError(f"{name} must be an array of shape (..., 3, 3), got {_fmt(M)}") from exc
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{name} must be an array of real numbers, got {_fmt(M)} (dtype {arr.dtype})")
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must have shape (..., 3, 3), got shape {arr.shape}")
    return arr.astype(np.float64, copy=False)


def inertia_to_jd(J: ArrayLike) -> _FloatArray:
    """Nonstandard inertia matrix ``Jd = tr(J)/2 I - J`` of a standard inertia matrix ``J``.

    Parameters
    ----------
    J : array_like, shape (..., 3, 3)
        Standard inertia matrices (vectorised over leading axes). No physical check is made.

    Returns
    -------
    Jd : ndarray, shape (..., 3, 3)
        The nonstandard inertia matrices, float64.

    See Also
    --------
    jd_to_inertia : the inverse map.

    Notes
    -----
    With ``Jd = 1/2 * integral(rho X X^T dX)`` one has ``J = tr(Jd) I - Jd``; taking the trace
    gives ``tr(J) = 2 tr(Jd)`` and hence ``Jd = tr(J)/2 I - J``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.body import inertia_to_jd
    >>> print(inertia_to_jd(np.diag([1.0, 2.0, 3.0])))
    [[2. 0. 0.]
     [0. 1. 0.]
     [0. 0. 0.]]
    """
    J = _square_3x3(J, "J")
    tr = np.trace(J, axis1=-2, axis2=-1)
    return 0.5 * tr[..., None, None] * np.eye(3) - J


def jd_to_inertia(Jd: ArrayLike) -> _FloatArray:
    """Standard inertia matrix ``J = tr(Jd) I - Jd`` of a nonstandard inertia matrix ``Jd``.

    Parameters
    ----------
    Jd : array_like, shape (..., 3, 3)
        Nonstandard inertia matrices (vectorised over leading axes). No physical check is made.

    Returns
    -------
    J : ndarray, shape (..., 3, 3)
        The standard inertia matrices, float64.

    See Also
    --------
    inertia_to_jd : the inverse map.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.body import jd_to_inertia
    >>> print(jd_to_inertia(np.diag([2.0, 1.0, 0.0])))
    [[1. 0. 0.]
     [0. 2. 0.]
     [0. 0. 3.]]
    """
    Jd = _square_3x3(Jd, "Jd")
    tr = np.trace(Jd, axis1=-2, axis2=-1)
    return tr[..., None, None] * np.eye(3) - Jd


def check_inertia(inertia: ArrayLike, name: str = "inertia") -> _FloatArray:
    """Validate an inertia and return it as a symmetric ``(3, 3)`` float64 matrix.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Principal moments (a diagonal inertia) or a full inertia matrix.
    name : str, optional
        Name of the argument, used in error messages.

    Returns
    -------
    J : ndarray, shape (3, 3)
        A new array; symmetric exactly (an input symmetric within tolerance is replaced by
        ``(J + J^T) / 2``).

    Raises
    ------
    ValueError
        If the shape is neither (3,) nor (3, 3); if the values are not real numbers (booleans
        are refused) or not finite; if the matrix is not symmetric to ``1e-12 * max|J|``; if it
        is not positive definite; if ``tr(J)`` or ``1 / J1`` overflows (no finite ``Jd`` or
        ``J^-1``); or if it violates the triangle inequality of a physical body (each principal
        moment at most the sum of the other two, within ``1e-12`` relative), i.e. ``Jd`` is not
        positive semidefinite.

    Examples
    --------
    >>> from lgvi.body import check_inertia
    >>> print(check_inertia([1.0, 2.0, 3.0]))
    [[1. 0. 0.]
     [0. 2. 0.]
     [0. 0. 3.]]
    >>> check_inertia([1.0, 1.0, 5.0])
    Traceback (most recent call last):
    ...
    ValueError: inertia violates the triangle inequality of a physical body: J3 = 5 > J1 + J2 = 2 ...
    """
    try:
        arr = np.asarray(inertia)
    except Exception as exc:
        raise ValueError(
            f"{name} must be an array of shape (3,) or (3, 3), got {_fmt(inertia)}"
        ) from exc
    if arr.dtype.kind not in "iuf":  # booleans are not moments of inertia
        raise ValueError(
            f"{name} must be an array of real numbers of shape (3,) or (3, 3), "
            f"got {_fmt(inertia)} (dtype {arr.dtype})"
        )
    if arr.shape == (3,):
        d = arr.astype(np.float64).tolist()
        rows = [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]]
    elif arr.shape == (3, 3):
        rows = arr.astype(np.float64).tolist()
    else:
        raise ValueError(
            f"{name} must have shape (3,) (principal moments) or (3, 3) (inertia matrix), "
            f"got shape {arr.shape}: {_fmt(arr)}"
        )
    # The checks run on the nine numbers as Python floats: the same IEEE operations as the
    # NumPy expressions they stand for (noted beside each), without a dozen small-array calls.
    flat = rows[0] + rows[1] + rows[2]
    if not all(map(math.isfinite, flat)):  # np.all(np.isfinite(J))
        raise ValueError(f"{name} must be finite (no NaN or inf), got {_fmt(arr)}")

    scale = max(map(abs, flat))  # np.max(np.abs(J))
    # np.max(np.abs(J - J.T)): its diagonal is zero and (i, j), (j, i) are the same number
    asym = max(abs(rows[0][1] - rows[1][0]), abs(rows[0][2] - rows[2][0]), abs(rows[1][2] - rows[2][1]))
    if asym > RTOL * scale:
        raise ValueError(
            f"{name} must be symmetric: max |J - J^T| = {asym:.3g} exceeds "
            f"{RTOL:g} * max|J| = {RTOL * scale:.3g}, got {_fmt(arr)}"
        )
    if asym > 0.0:
        rows = [[0.5 * (rows[i][j] + rows[j][i]) for j in range(3)] for i in range(3)]  # 0.5 * (J + J.T)
    J = np.array(rows, dtype=np.float64)

    if _is_diagonal(rows):
        moments = sorted([rows[0][0], rows[1][1], rows[2][2]])  # np.sort(np.diag(J))
    else:
        moments = np.linalg.eigvalsh(J).tolist()
    if not moments[0] > 0.0:
        raise ValueError(
            f"{name} must be positive definite: its smallest eigenvalue is {moments[0]:.10g}, "
            f"got {_fmt(arr)}"
        )
    J1, J2, J3 = moments
    trace, inverse = (rows[0][0] + rows[1][1]) + rows[2][2], 1.0 / J1  # np.trace(J); no overflow error in Python
    if not (math.isfinite(trace) and math.isfinite(inverse)):
        raise ValueError(
            f"{name} is outside the range of double precision: tr(J) = {trace:.10g} and "
            f"1 / (smallest principal moment) = {inverse:.10g} must be finite for Jd and J^-1; "
            f"change the units, got {_fmt(arr)}"
        )
    if J3 - (J1 + J2) > RTOL * J3:
        raise ValueError(
            f"{name} violates the triangle inequality of a physical body: "
            f"J3 = {J3:.10g} > J1 + J2 = {J1 + J2:.10g} "
            f"(Jd = tr(J)/2 I - J must be positive semidefinite; principal moments "
            f"J1 <= J2 <= J3 = {_fmt(np.array(moments))}), got {_fmt(arr)}"
        )
    return J


def _is_diagonal(rows: list[list[float]]) -> bool:
    """Whether the off-diagonal entries of ``rows`` (3 x 3 floats) are all zero (``-0.0`` too)."""
    return rows[0][1] == 0.0 and rows[0][2] == 0.0 and rows[1][0] == 0.0 and rows[1][2] == 0.0 \
        and rows[2][0] == 0.0 and rows[2][1] == 0.0


def _readonly(a: _FloatArray) -> _FloatArray:
    a = np.array(a, dtype=np.float64)  # own the memory
    a.flags.writeable = False
    return a


def _frozen(rows: list[list[float]] | list[float]) -> _FloatArray:
    """A new read-only float64 array of ``rows``."""
    a = np.array(rows, dtype=np.float64)
    a.flags.writeable = False
    return a


def _principal(J: _FloatArray) -> tuple[_FloatArray, _FloatArray, bool]:
    """Ascending principal moments, principal axes (columns, det +1), and whether J is diagonal."""
    diagonal = bool(np.count_nonzero(J - np.diag(np.diag(J))) == 0)
    if diagonal:
        d = np.diag(J)
        order = np.argsort(d, kind="stable")
        moments = d[order].copy()
        axes = np.eye(3)[:, order]
    else:
        moments, axes = np.linalg.eigh(J)
        # Deterministic signs: the largest-magnitude entry of each column is positive.
        idx = np.argmax(np.abs(axes), axis=0)
        signs = np.sign(axes[idx, np.arange(3)])
        axes = axes * signs
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes, diagonal


def _as_vectors(x: ArrayLike, name: str) -> _FloatArray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got shape {arr.shape}")
    return arr


@dataclass(frozen=True, eq=False, repr=False)
class RigidBody:
    """A rigid body given by its inertia, checked once and immutable.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Principal moments ``(J1, J2, J3)`` (a body whose body frame is its principal frame) or
        the full symmetric positive definite inertia matrix in the body frame.

    Attributes
    ----------
    J : ndarray, shape (3, 3)
        Standard inertia matrix (read-only, float64).
    Jd : ndarray, shape (3, 3)
        Nonstandard inertia matrix ``tr(J)/2 I - J`` (read-only).
    J_inv : ndarray, shape (3, 3)
        Inverse of ``J`` (read-only, symmetric).
    principal_moments : ndarray, shape (3,)
        Eigenvalues of ``J`` in ascending order (read-only).
    principal_axes : ndarray, shape (3, 3)
        Unit eigenvectors of ``J`` as columns, in the order of ``principal_moments``; a proper
        rotation (det +1), so ``J = V diag(moments) V^T`` (read-only).
    is_diagonal : bool
        Whether ``J`` is diagonal (its off-diagonal entries are exactly zero).

    Raises
    ------
    ValueError
        If ``inertia`` has the wrong shape, is not finite, not symmetric, not positive definite
        or violates the triangle inequality ``J3 <= J1 + J2`` of a physical body; see
        :func:`check_inertia`.

    Notes
    -----
    The kinetic energy is ``K = 1/2 Pi^T J^{-1} Pi = 1/2 tr(hat(Omega) Jd hat(Omega)^T)`` with
    ``Pi = J Omega``. A flat body (``J1 + J2 = J3``) is legal: its ``Jd`` is singular.

    Examples
    --------
    >>> from lgvi import body
    >>> b = body.RigidBody([1.0, 2.0, 3.0])
    >>> b
    RigidBody(inertia=[1, 2, 3])
    >>> print(b.Jd)
    [[2. 0. 0.]
     [0. 1. 0.]
     [0. 0. 0.]]
    >>> print(b.kinetic_energy([1.0, 2.0, 3.0]))
    3.0
    >>> print(b.omega([1.0, 2.0, 3.0]))
    [1. 1. 1.]
    """

    inertia: InitVar[ArrayLike]
    J: _FloatArray = field(init=False)
    Jd: _FloatArray = field(init=False)
    J_inv: _FloatArray = field(init=False)
    principal_moments: _FloatArray = field(init=False)
    principal_axes: _FloatArray = field(init=False)
    is_diagonal: bool = field(init=False)

    def __post_init__(self, inertia: ArrayLike) -> None:
        if isinstance(inertia, RigidBody):  # checked when it was made, and immutable: its arrays
            for key in ("J", "Jd", "J_inv", "principal_moments", "principal_axes"):
                object.__setattr__(self, key, _readonly(getattr(inertia, key)))
            object.__setattr__(self, "is_diagonal", bool(inertia.is_diagonal))
            return
        J = check_inertia(inertia, "inertia")
        rows = J.tolist()
        if _is_diagonal(rows):
            self._set_diagonal(rows)
            return
        moments, axes, diagonal = _principal(J)
        if diagonal:
            J_inv = np.diag(1.0 / np.diag(J))
        else:
            J_inv = np.linalg.inv(J)
            J_inv = 0.5 * (J_inv + J_inv.T)
        values = {
            "J": _readonly(J),
            "Jd": _readonly(inertia_to_jd(J)),
            "J_inv": _readonly(J_inv),
            "principal_moments": _readonly(moments),
            "principal_axes": _readonly(axes),
        }
        for key, value in values.items():
            object.__setattr__(self, key, value)
        object.__setattr__(self, "is_diagonal", diagonal)

    def _set_diagonal(self, rows: list[list[float]]) -> None:
        """The arrays of a diagonal ``J`` (3 x 3 floats, checked) in Python floats: the same IEEE
        operations, and so the same bits, as :func:`_principal`, ``np.diag(1.0 / np.diag(J))`` and
        :func:`inertia_to_jd` (a diagonal body is the common case; about 30 us less a body)."""
        d = [rows[0][0], rows[1][1], rows[2][2]]
        order = sorted(range(3), key=d.__getitem__)  # np.argsort(d, kind="stable")
        axes = [[1.0 if r == c else 0.0 for c in order] for r in range(3)]  # np.eye(3)[:, order]
        if order in ([0, 2, 1], [1, 0, 2], [2, 1, 0]):  # an odd permutation: det(axes) = -1 exactly
            for r in range(3):
                axes[r][2] = -axes[r][2]
        half = 0.5 * ((d[0] + d[1]) + d[2])  # 0.5 * np.trace(J)
        jd = [[(half if r == c else 0.0) - rows[r][c] for c in range(3)] for r in range(3)]
        inv = [[1.0 / d[r] if r == c else 0.0 for c in range(3)] for r in range(3)]
        for key, value in (("J", rows), ("Jd", jd), ("J_inv", inv), ("principal_moments", [d[i] for i in order]),
                           ("principal_axes", axes)):
            object.__setattr__(self, key, _frozen(value))
        object.__setattr__(self, "is_diagonal", True)

    # -- physics -------------------------------------------------------------------------------
    def omega(self, Pi: ArrayLike) -> _FloatArray:
        """Body angular velocity ``Omega = J^{-1} Pi``.

        Parameters
        ----------
        Pi : array_like, shape (..., 3)
            Body angular momenta.

        Returns
        -------
        Omega : ndarray, shape (..., 3)

        Examples
        --------
        >>> from lgvi.body import RigidBody
        >>> print(RigidBody([2.0, 3.0, 4.0]).omega([2.0, 6.0, 2.0]))
        [1.  2.  0.5]
        """
        Pi = _as_vectors(Pi, "Pi")
        return Pi @ self.J_inv.T

    def momentum(self, omega: ArrayLike) -> _FloatArray:
        """Body angular momentum ``Pi = J Omega``.

        Parameters
        ----------
        omega : array_like, shape (..., 3)
            Body angular velocities.

        Returns
        -------
        Pi : ndarray, shape (..., 3)

        Examples
        --------
        >>> from lgvi.body import RigidBody
        >>> print(RigidBody([1.0, 2.0, 3.0]).momentum([1.0, 1.0, 1.0]))
        [1. 2. 3.]
        """
        omega = _as_vectors(omega, "omega")
        return omega @ self.J.T

    def kinetic_energy(self, Pi: ArrayLike) -> _FloatArray:
        """Kinetic energy ``1/2 Pi . J^{-1} Pi``.

        Parameters
        ----------
        Pi : array_like, shape (..., 3)
            Body angular momenta.

        Returns
        -------
        energy : ndarray, shape (...)
            A NumPy scalar for a single momentum of shape (3,).

        Examples
        --------
        >>> import numpy as np
        >>> from lgvi.body import RigidBody
        >>> print(RigidBody([1.0, 2.0, 3.0]).kinetic_energy(np.eye(3)))
        [0.5        0.25       0.16666667]
        """
        Pi = _as_vectors(Pi, "Pi")
        return 0.5 * np.einsum("...i,...i->...", Pi, Pi @ self.J_inv.T)

    # -- dunder --------------------------------------------------------------------------------
    def __repr__(self) -> str:
        def num(x: float) -> str:
            return f"{x:.10g}"

        if self.is_diagonal:
            inner = ", ".join(num(x) for x in np.diag(self.J))
            return f"RigidBody(inertia=[{inner}])"
        inner = ", ".join(num(x) for x in self.principal_moments)
        return f"RigidBody(principal_moments=[{inner}], diagonal=False)"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RigidBody):
            return NotImplemented
        return bool(np.array_equal(self.J, other.J))

    def __hash__(self) -> int:
        return hash((RigidBody, (self.J + 0.0).tobytes()))  # + 0.0 maps -0.0 to 0.0, as == does

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # Rebuild through the constructor, so that a copy or an unpickled body is checked and its
        # arrays are read-only again.
        return (RigidBody, (np.array(self.J),))
