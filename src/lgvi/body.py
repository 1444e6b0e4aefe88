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

__all__ = ["RigidBody", "check_inertia", "inertia_to_jd", "jd_to_inertia", "sphere_moments"]

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


def check_inertia(inertia: ArrayLike, name: str = "inertia", *, physical: bool = True) -> _FloatArray:
    """Validate an inertia and return it as a symmetric ``(3, 3)`` float64 matrix.

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Principal moments (a diagonal inertia) or a full inertia matrix.
    name : str, optional
        Name of the argument, used in error messages.
    physical : bool, optional
        Check the triangle inequality (default). ``False`` allows the inertia of no physical
        body (e.g. the textbook test case ``(2, 1, 2/3)``), for tests of the method.

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
    if physical and J3 - (J1 + J2) > RTOL * J3:
        raise ValueError(
            f"{name} violates the triangle inequality of a physical body: "
            f"J3 = {J3:.10g} > J1 + J2 = {J1 + J2:.10g} "
            f"(Jd = tr(J)/2 I - J must be positive semidefinite; principal moments "
            f"J1 <= J2 <= J3 = {_fmt(np.array(moments))}); for a test of the method with such an "
            f"inertia pass allow_nonphysical=True, got {_fmt(arr)}"
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

    allow_nonphysical : bool, keyword-only
        Accept an inertia that violates the triangle inequality (no physical body has it; its
        ``Jd`` is indefinite), for tests of the method such as the textbook ``(2, 1, 2/3)``.
        Default False.

    Raises
    ------
    ValueError
        If ``inertia`` has the wrong shape, is not finite, not symmetric, not positive definite
        or violates the triangle inequality ``J3 <= J1 + J2`` of a physical body (unless
        ``allow_nonphysical``); see :func:`check_inertia`.

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
    allow_nonphysical: InitVar[bool] = field(default=False, kw_only=True)
    J: _FloatArray = field(init=False)
    Jd: _FloatArray = field(init=False)
    J_inv: _FloatArray = field(init=False)
    principal_moments: _FloatArray = field(init=False)
    principal_axes: _FloatArray = field(init=False)
    is_diagonal: bool = field(init=False)
    physical: bool = field(init=False, default=True)

    def __post_init__(self, inertia: ArrayLike, allow_nonphysical: bool = False) -> None:
        if not isinstance(allow_nonphysical, (bool, np.bool_)):
            raise TypeError(f"allow_nonphysical must be True or False, got {allow_nonphysical!r}")
        if isinstance(inertia, RigidBody):  # checked when it was made, and immutable: its arrays
            for key in ("J", "Jd", "J_inv", "principal_moments", "principal_axes"):
                object.__setattr__(self, key, _readonly(getattr(inertia, key)))
            object.__setattr__(self, "is_diagonal", bool(inertia.is_diagonal))
            object.__setattr__(self, "physical", bool(inertia.physical))
            return
        J = check_inertia(inertia, "inertia", physical=not allow_nonphysical)
        if allow_nonphysical:
            m = np.linalg.eigvalsh(J)
            object.__setattr__(self, "physical", bool(m[2] - (m[0] + m[1]) <= RTOL * m[2]))
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

        flag = "" if self.physical else ", allow_nonphysical=True"
        if self.is_diagonal:
            inner = ", ".join(num(x) for x in np.diag(self.J))
            return f"RigidBody(inertia=[{inner}]{flag})"
        inner = ", ".join(num(x) for x in self.principal_moments)
        return f"RigidBody(principal_moments=[{inner}], diagonal=False{flag})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RigidBody):
            return NotImplemented
        return bool(np.array_equal(self.J, other.J))

    def __hash__(self) -> int:
        return hash((RigidBody, (self.J + 0.0).tobytes()))  # + 0.0 maps -0.0 to 0.0, as == does

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # Rebuild through the constructor, so that a copy or an unpickled body is checked and its
        # arrays are read-only again.
        if not self.physical:
            return (_nonphysical, (np.array(self.J),))
        return (RigidBody, (np.array(self.J),))

    @classmethod
    def from_masses(cls, masses: ArrayLike, positions: ArrayLike, radii: ArrayLike | None = None) -> "RigidBody":
        """The body made of point masses, or homogeneous spheres, rigidly joined by massless rods.

        Parameters
        ----------
        masses : (n,) array_like
            Masses, ``> 0``.
        positions : (n, 3) array_like
            Their positions (the centres of the spheres) in the body frame; any origin: the
            inertia is taken about their centre of mass.
        radii : (n,) array_like, optional
            Radii of the spheres, ``>= 0`` (default: points, radius 0).

        Returns
        -------
        RigidBody
            The inertia ``sum_a m_a (|q_a|^2 I - q_a q_a^T) + 2/5 m_a rho_a^2 I`` about the centre of
            mass (``q_a`` from it), in the body frame of ``positions``.

        Raises
        ------
        ValueError
            If the arrays do not match or are not finite, a mass is not positive, a radius is
            negative, or the body has a zero principal moment (points on one line with no
            sphere: add a sphere or a point off the line).

        Examples
        --------
        >>> import lgvi
        >>> dumbbell = lgvi.RigidBody.from_masses([1.0, 1.0], [[-1.0, 0, 0], [1.0, 0, 0]], radii=[0.5, 0.5])
        >>> dumbbell.principal_moments.tolist()         # 2 (2/5 0.25), then 2 + 0.2 twice
        [0.2, 2.2, 2.2]
        """
        w, q, rho = sphere_moments(masses, positions, radii, "RigidBody.from_masses", order=2)[:3]
        per = np.einsum("ai,ai->a", q, q)[:, None, None] * np.eye(3) - np.einsum("ai,aj->aij", q, q)
        J = np.einsum("a,aij->ij", w, per) + 0.4 * (w @ rho ** 2) * np.eye(3)
        return cls(J)


def _nonphysical(J: _FloatArray) -> RigidBody:
    """Rebuild a body made with ``allow_nonphysical=True`` (pickling)."""
    return RigidBody(J, allow_nonphysical=True)


def sphere_moments(masses: ArrayLike, positions: ArrayLike, radii: ArrayLike | None, who: str,
                   order: int = 4) -> tuple[Any, ...]:
    r"""Validated points or homogeneous spheres and their mass moments about their centre of mass.

    Parameters
    ----------
    masses : (n,) array_like
        ``> 0``.
    positions : (n, 3) array_like
        Centres, any origin.
    radii : (n,) array_like or None
        ``>= 0`` (None: points).
    who : str
        Named in error messages.
    order : {2, 4}
        Compute ``T3`` and ``T4`` too (4) or not (2: they are returned as None).

    Returns
    -------
    (w (n,), q (n, 3), rho (n,), S (3, 3), T3 (3, 3, 3), T4 (3, 3, 3, 3))
        The masses, the centres relative to the centre of mass, the radii, and ``int r r^T dm``,
        ``int r^(x3) dm``, ``int r^(x4) dm`` about the centre of mass. A sphere of mass ``m``
        and radius ``rho`` adds ``m rho^2 / 5 I`` to ``S``, ``q_i <s_j s_k>`` and its
        permutations to ``T3`` and the six ``q q <s s>`` terms plus
        ``m rho^4 / 35 (d_ij d_kl + d_ik d_jl + d_il d_jk)`` to ``T4`` (``<s_i s_j> = m rho^2 / 5
        d_ij``: the moments of a homogeneous ball about its centre).
    """
    w = np.asarray(masses, dtype=np.float64) if not isinstance(masses, (str, bytes)) else None
    if w is None or w.ndim != 1 or len(w) == 0:
        raise ValueError(f"{who}: masses must be a non-empty array of shape (n,), got {masses!r}")
    q = np.asarray(positions, dtype=np.float64) if not isinstance(positions, (str, bytes)) else None
    if q is None or q.shape != (len(w), 3):
        raise ValueError(f"{who} needs as many masses as positions (n,) and (n, 3), got {len(w)} masses and "
                         f"positions of shape {getattr(q, 'shape', None)}")
    rho = np.zeros(len(w)) if radii is None else np.asarray(radii, dtype=np.float64)
    if rho.shape != w.shape:
        raise ValueError(f"{who}: radii must have shape ({len(w)},) like masses, got shape {rho.shape}")
    for name, a in (("masses", w), ("positions", q), ("radii", rho)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{who}: {name} must be finite, got {a.tolist()}")
    if not np.all(w > 0):
        raise ValueError(f"{who}: masses must be positive, got {w[~(w > 0)][0]}")
    if not np.all(rho >= 0):
        raise ValueError(f"{who}: radii must be >= 0, got {rho[~(rho >= 0)][0]}")
    q = q - (w @ q) / w.sum()
    s2 = w * rho ** 2 / 5.0                      # <s s^T> = s2 I for each sphere
    S = np.einsum("a,ai,aj->ij", w, q, q) + s2.sum() * np.eye(3)
    moments = np.linalg.eigvalsh(np.trace(S) * np.eye(3) - S)
    if not moments[0] > 1e-12 * moments[-1]:
        raise ValueError(f"{who}: the positions must not all lie on one line: a rigid body needs three non-zero "
                         f"principal moments of inertia, got {moments.tolist()} (give the spheres radii, or add a "
                         "point off the line, e.g. a light cross bar)")
    if order == 2:
        return w, q, rho, S, None, None
    d = np.eye(3)
    T3 = np.einsum("a,ai,aj,ak->ijk", w, q, q, q)
    qs = np.einsum("a,ai->ai", s2, q)          # s2_a q_a
    T3 = T3 + (np.einsum("ai,jk->ijk", qs, d) + np.einsum("aj,ik->ijk", qs, d) + np.einsum("ak,ij->ijk", qs, d))
    T4 = np.einsum("a,ai,aj,ak,al->ijkl", w, q, q, q, q)
    qq = np.einsum("a,ai,aj->ij", s2, q, q)      # sum_a s2_a q_a q_a^T
    for a, b, c, e in ("ijkl", "ikjl", "iljk", "jkil", "jlik", "klij"):
        T4 = T4 + np.einsum(f"{a}{b},{c}{e}->ijkl", qq, d)
    iso = (w * rho ** 4 / 35.0).sum()
    T4 = T4 + iso * (np.einsum("ij,kl->ijkl", d, d) + np.einsum("ik,jl->ijkl", d, d) + np.einsum("il,jk->ijkl", d, d))
    return w, q, rho, S, T3, T4
