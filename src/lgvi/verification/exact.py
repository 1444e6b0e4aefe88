"""Exact solution of the torque-free rigid body, for validating the integrators.

The body frame is the principal frame, ``J = diag(J1, J2, J3)`` (any order). The body angular
momentum obeys Euler's equations and the attitude ``R`` (body to inertial) its kinematics,

.. math::

    \\dot\\Pi = \\Pi \\times J^{-1}\\Pi, \\qquad \\dot R = R\\,\\widehat{J^{-1}\\Pi}.

:func:`free_body_momentum` gives ``Pi(t)`` in closed form with Jacobi elliptic functions (both
momentum regimes) or, for an axisymmetric body, with sines and cosines.
:func:`free_body_attitude` gives ``R(t)``: the spatial momentum ``L = R Pi`` is constant, the
body's attitude relative to a frame whose third axis is ``L`` follows from ``Pi(t)/|L|`` up to one
angle ``psi`` about ``L``, and ``psi(t)`` is the integral of a smooth periodic function of time,
integrated to round-off with a Fourier series (spectrally accurate, any ``t``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ellipj, ellipk, ellipkinc

__all__ = ["free_body", "free_body_attitude", "free_body_momentum"]

_FloatArray = NDArray[np.float64]

#: Times processed at once when summing the Fourier series of ``psi`` (bounds memory).
_CHUNK = 4096
#: Largest number of Fourier samples of ``psi'`` tried before giving up (near the separatrix).
_MAX_MODES = 2**16
#: Largest elliptic parameter handled: above it scipy's ``ellipj`` uses an approximation.
_MAX_M = 1.0 - 1e-10


# ---------------------------------------------------------------------------------------------
# input checks
# ---------------------------------------------------------------------------------------------
def _real_array(x: ArrayLike, name: str) -> _FloatArray:
    try:
        arr = np.asarray(x)
    except Exception as exc:
        raise ValueError(f"{name} must be an array of real numbers, got {x!r}") from exc
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{name} must be an array of real numbers, got {x!r} (dtype {arr.dtype})")
    arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {arr}")
    return arr


def _check_moments(inertia_moments: ArrayLike) -> _FloatArray:
    moments = _real_array(inertia_moments, "inertia_moments")
    if moments.shape != (3,):
        raise ValueError(
            "inertia_moments must have shape (3,) (the principal moments J1, J2, J3), "
            f"got shape {moments.shape}"
        )
    if not np.all(moments > 0.0):
        raise ValueError(f"inertia_moments must be positive, got {moments}")
    return moments


def _check_vector(x: ArrayLike, name: str) -> _FloatArray:
    arr = _real_array(x, name)
    if arr.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got shape {arr.shape}")
    return arr


def _check_rotation(R0: ArrayLike) -> _FloatArray:
    if hasattr(R0, "as_matrix") and not isinstance(R0, np.ndarray):  # scipy Rotation
        R0 = R0.as_matrix()
    R = _real_array(R0, "R0")
    if R.shape != (3, 3):
        raise ValueError(f"R0 must be a rotation matrix of shape (3, 3), got shape {R.shape}")
    err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if err > 1e-10 or np.linalg.det(R) <= 0.0:
        raise ValueError(
            f"R0 must be a rotation matrix (R0^T R0 = I to 1e-10, det R0 = +1); got "
            f"max|R0^T R0 - I| = {err:.3g}, det R0 = {np.linalg.det(R):.6g}"
        )
    return R


# ---------------------------------------------------------------------------------------------
# small rotation helpers (kept local: this module is an independent oracle)
# ---------------------------------------------------------------------------------------------
def _hat(v: _FloatArray) -> _FloatArray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _axis_rotation(axis: _FloatArray, angle: _FloatArray) -> _FloatArray:
    """Rotations by ``angle`` (shape (...)) about the unit vector ``axis`` (3,): (..., 3, 3)."""
    K = _hat(axis)
    K2 = K @ K
    s = np.sin(angle)[..., None, None]
    c = np.cos(angle)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * K2


# ---------------------------------------------------------------------------------------------
# the motions
# ---------------------------------------------------------------------------------------------
class _Steady:
    """Momentum along a principal axis (or zero): Pi constant, R = R0 exp(t hat(Omega))."""

    def __init__(self, moments: _FloatArray, Pi0: _FloatArray) -> None:
        self.Pi0 = Pi0
        self.omega = Pi0 / moments

    def momentum(self, t: _FloatArray) -> _FloatArray:
        return np.broadcast_to(self.Pi0, t.shape + (3,)).copy()

    def attitude(self, R0: _FloatArray, t: _FloatArray) -> _FloatArray:
        rate = float(np.linalg.norm(self.omega))
        if rate == 0.0:
            return np.broadcast_to(R0, t.shape + (3, 3)).copy()
        return R0 @ _axis_rotation(self.omega / rate, rate * t)


class _Axisymmetric:
    """Two equal moments ``J_perp`` and a symmetry axis ``s`` (any third moment).

    ``Pi(t) = exp(-t mu hat(e_s)) Pi0`` and ``R(t) = exp(t hat(L)/J_perp) R0 exp(t mu hat(e_s))``
    with ``mu = (1/J_s - 1/J_perp) Pi0_s``.
    """

    def __init__(self, moments: _FloatArray, Pi0: _FloatArray, s: int) -> None:
        others = [i for i in range(3) if i != s]
        self.J_perp = float(moments[others[0]])
        self.e_s = np.eye(3)[s]
        self.mu = (1.0 / moments[s] - 1.0 / self.J_perp) * Pi0[s]
        self.Pi0 = Pi0

    def momentum(self, t: _FloatArray) -> _FloatArray:
        F = _axis_rotation(self.e_s, -self.mu * t)
        return F @ self.Pi0

    def attitude(self, R0: _FloatArray, t: _FloatArray) -> _FloatArray:
        L = R0 @ self.Pi0
        nL = float(np.linalg.norm(L))
        body = _axis_rotation(self.e_s, self.mu * t)
        if nL == 0.0:
            return R0 @ body
        precession = _axis_rotation(L / nL, (nL / self.J_perp) * t)
        return precession @ R0 @ body


class _Elliptic:
    """Three distinct moments and a momentum off the separatrix: Jacobi elliptic functions.

    In a frame ``q = S Pi`` (``S`` a signed permutation with det +1) whose moments ``(I1, I2, I3)``
    have ``I2`` the middle one and ``I3`` the moment of the axis the momentum never leaves the
    hemisphere of (the largest moment if ``|Pi|^2 > 2 E J_mid``, the smallest otherwise),

        q(t) = (A1 cn(u, m), A2 sn(u, m), A3 dn(u, m)),   u = lam t + u0,

    with ``A1 >= 0``, ``sign(A3) = sign(q3)``, ``lam > 0`` and ``A2`` of the sign that makes
    ``q' = q x I^{-1} q`` hold.
    """

    def __init__(self, moments: _FloatArray, Pi0: _FloatArray) -> None:
        imin, imid, imax = (int(i) for i in np.argsort(moments))
        Jmin, Jmid, Jmax = moments[imin], moments[imid], moments[imax]
        # D = |Pi|^2 - 2 E Jmid, written without cancellation of the large terms.
        D = Pi0[imax] ** 2 * (Jmax - Jmid) / Jmax - Pi0[imin] ** 2 * (Jmid - Jmin) / Jmin
        if D == 0.0:
            raise NotImplementedError(
                "free-body solution on the separatrix |Pi|^2 = 2 E J_mid (a heteroclinic orbit) "
                f"is not implemented: inertia_moments = {moments}, Pi0 = {Pi0}"
            )
        axes = (imin, imid, imax) if D > 0.0 else (imax, imid, imin)
        P = np.zeros((3, 3))
        P[[0, 1, 2], list(axes)] = 1.0
        if np.linalg.det(P) < 0.0:
            P[1] = -P[1]
        self.S = P
        I1, I2, I3 = (float(moments[i]) for i in axes)
        q1, q2, q3 = P @ Pi0

        # Amplitudes from the invariants, each a sum of non-negative terms.
        A1 = np.sqrt(q1**2 + q2**2 * (I1 * (I3 - I2)) / (I2 * (I3 - I1)))
        A2 = np.sqrt(q2**2 + q1**2 * (I2 * (I3 - I1)) / (I1 * (I3 - I2)))
        A3 = np.sqrt(q3**2 + q2**2 * (I3 * (I2 - I1)) / (I2 * (I3 - I1)))
        m = float((A1**2 * I3 * (I2 - I1)) / (A3**2 * I1 * (I3 - I2)))
        if not 0.0 <= m <= _MAX_M:
            raise NotImplementedError(
                "free-body solution too close to the separatrix |Pi|^2 = 2 E J_mid "
                f"(elliptic parameter m = {m!r} > {_MAX_M!r}, where scipy.special.ellipj "
                f"switches to an approximation): inertia_moments = {moments}, Pi0 = {Pi0}"
            )
        self.lam = float(A3 / I3 * np.sqrt((I3 - I2) * (I3 - I1) / (I1 * I2)))
        s3 = 1.0 if q3 > 0.0 else -1.0
        s23 = 1.0 if I3 > I2 else -1.0
        self.A = np.array([A1, s3 * s23 * A2, s3 * A3])
        self.m = float(m)
        # Phase: sn(u0) = q2/A2, cn(u0) = q1/A1, i.e. the amplitude am(u0) = phi0.
        phi0 = np.arctan2(q2 * A1 * s3 * s23, q1 * A2)
        self.u0 = float(ellipkinc(phi0, self.m))
        self.K = float(ellipk(self.m))
        self.moments = moments
        # |A_i| per body axis: the largest |Pi_i| reaches along the orbit.
        self.amplitude = np.empty(3)
        self.amplitude[list(axes)] = np.abs(self.A)
        self.Pi0 = Pi0
        self._psi_coeffs: tuple[int, int, _FloatArray] | None = None

    # -- momentum ------------------------------------------------------------------------------
    def momentum_at_u(self, u: _FloatArray) -> _FloatArray:
        # Reduce modulo the period 4K first: ellipj loses accuracy ~ eps * |u| (which would
        # break the invariants); the reduction moves that error into the phase only.
        period = 4.0 * self.K
        u = u - np.round(u / period) * period
        sn, cn, dn, _ = ellipj(u, self.m)
        q = np.stack([self.A[0] * cn, self.A[1] * sn, self.A[2] * dn], axis=-1)
        return q @ self.S  # Pi = S^T q

    def momentum(self, t: _FloatArray) -> _FloatArray:
        return self.momentum_at_u(self.lam * t + self.u0)

    # -- attitude ------------------------------------------------------------------------------
    def _euler_axes(self) -> tuple[int, int, int]:
        # Euler 3-1-3 sequence about the body axis e whose |Pi_e| stays smallest: then
        # Pi_a^2 + Pi_b^2 >= |L|^2 / 2 along the whole orbit (no gimbal lock).
        e = int(np.argmin(self.amplitude))
        return (e + 1) % 3, (e + 2) % 3, e

    def _psi_rate(self, u: _FloatArray) -> _FloatArray:
        a, b, _ = self._euler_axes()
        Pi = self.momentum_at_u(u)
        nL = float(np.linalg.norm(self.Pi0))
        pa2, pb2 = Pi[..., a] ** 2, Pi[..., b] ** 2
        return nL * (pa2 / self.moments[a] + pb2 / self.moments[b]) / (pa2 + pb2)

    def _fourier(self) -> tuple[int, int, _FloatArray]:
        """Fourier coefficients of psi'(u) over one period 2K in u, converged to round-off."""
        if self._psi_coeffs is None:
            period = 2.0 * self.K
            M = 32
            while True:
                u = self.u0 + period * np.arange(M) / M
                c = np.fft.rfft(self._psi_rate(u)) / M
                tail = float(np.max(np.abs(c[M // 4 :])))
                if tail <= 1e-15 * abs(c[0]):
                    break
                if M >= _MAX_MODES:
                    raise NotImplementedError(
                        "free-body attitude too close to the separatrix: the precession rate "
                        f"needs more than {_MAX_MODES} Fourier modes (m = {self.m!r})"
                    )
                M *= 2
            self._psi_coeffs = (M, M // 2, c[: M // 2])
        return self._psi_coeffs

    def psi(self, t: _FloatArray) -> _FloatArray:
        """Precession angle about L since t = 0: the integral of psi' from 0 to t."""
        _, n_modes, c = self._fourier()
        period = 2.0 * self.K
        w = (self.lam * t).ravel()
        n = np.floor(w / period)
        r = w - n * period  # in [0, period)
        k = np.arange(1, n_modes)
        alpha = c[1:].real
        beta = c[1:].imag
        weight = period / (np.pi * k)
        out = np.empty_like(w)
        for start in range(0, w.size, _CHUNK):
            rr = r[start : start + _CHUNK]
            theta = (2.0 * np.pi / period) * np.multiply.outer(rr, k)
            periodic = (np.sin(theta) * alpha + (np.cos(theta) - 1.0) * beta) @ weight
            out[start : start + _CHUNK] = c[0].real * (n[start : start + _CHUNK] * period + rr) + periodic
        return (out / self.lam).reshape(t.shape)

    @staticmethod
    def _Q(p: _FloatArray) -> _FloatArray:
        """Rx(theta) Rz(phi) with third row p/|p| (p in the Euler frame (a, b, e))."""
        p1, p2, p3 = p[..., 0], p[..., 1], p[..., 2]
        rho = np.hypot(p1, p2)
        norm = np.sqrt(rho**2 + p3**2)
        sth, cth = rho / norm, p3 / norm
        sph, cph = p1 / rho, p2 / rho
        Q = np.empty(p.shape[:-1] + (3, 3))
        Q[..., 0, 0], Q[..., 0, 1], Q[..., 0, 2] = cph, -sph, 0.0
        Q[..., 1, 0], Q[..., 1, 1], Q[..., 1, 2] = cth * sph, cth * cph, -sth
        Q[..., 2, 0], Q[..., 2, 1], Q[..., 2, 2] = sth * sph, sth * cph, cth
        return Q

    def attitude(self, R0: _FloatArray, t: _FloatArray, Pi: _FloatArray) -> _FloatArray:
        order = list(self._euler_axes())
        P = np.eye(3)[order]  # cyclic permutation: p = P Pi
        Q0P = self._Q(self.Pi0[order]) @ P
        QtP = self._Q(Pi[..., order]) @ P
        L = R0 @ self.Pi0
        precession = _axis_rotation(L / np.linalg.norm(L), self.psi(t))
        return precession @ (R0 @ Q0P.T) @ QtP


def _motion(moments: _FloatArray, Pi0: _FloatArray) -> _Steady | _Axisymmetric | _Elliptic:
    if np.count_nonzero(Pi0) <= 1:
        return _Steady(moments, Pi0)
    a, b, c = moments
    if a == b == c:
        return _Axisymmetric(moments, Pi0, 2)
    if a == b:
        return _Axisymmetric(moments, Pi0, 2)
    if b == c:
        return _Axisymmetric(moments, Pi0, 0)
    if a == c:
        return _Axisymmetric(moments, Pi0, 1)
    return _Elliptic(moments, Pi0)


# ---------------------------------------------------------------------------------------------
# public functions
# ---------------------------------------------------------------------------------------------
def free_body_momentum(inertia_moments: ArrayLike, Pi0: ArrayLike, t: ArrayLike) -> _FloatArray:
    """Exact body angular momentum ``Pi(t)`` of the torque-free rigid body.

    Parameters
    ----------
    inertia_moments : array_like, shape (3,)
        Principal moments ``(J1, J2, J3)``, positive, in any order; the body frame is the
        principal frame, ``J = diag(J1, J2, J3)``.
    Pi0 : array_like, shape (3,)
        Body angular momentum at ``t = 0``.
    t : array_like, shape (N,) or any shape
        Times (any order, negative allowed).

    Returns
    -------
    Pi : ndarray, shape t.shape + (3,)
        ``Pi(t)``; ``Pi(0) = Pi0`` to round-off.

    Raises
    ------
    ValueError
        On a wrong shape, a value that is not finite, or a moment that is not positive.
    NotImplementedError
        On the separatrix ``|Pi0|^2 = 2 E J_mid`` of a body with three distinct moments (unless
        ``Pi0`` lies along the middle axis, an equilibrium), or so close to it that the elliptic
        parameter ``m`` exceeds ``1 - 1e-10`` (where ``scipy.special.ellipj`` switches to an
        approximation).

    Notes
    -----
    Euler's equations ``Pi' = Pi x J^{-1} Pi`` conserve ``|Pi|^2`` and ``2E = Pi . J^{-1} Pi``.
    For three distinct moments, in a frame ``q`` obtained from the principal one by a proper
    signed permutation with ``I2`` the middle moment and ``I3`` the moment of the axis that
    ``Pi`` circles (the largest if ``|Pi|^2 > 2 E J_mid``, the smallest otherwise),

    .. math::

        q = (A_1 \\operatorname{cn} u,\\ A_2 \\operatorname{sn} u,\\ A_3 \\operatorname{dn} u),
        \\quad u = \\lambda t + u_0, \\quad
        m = \\frac{A_1^2 I_3 (I_2 - I_1)}{A_3^2 I_1 (I_3 - I_2)}, \\quad
        \\lambda = \\frac{|A_3|}{I_3}\\sqrt{\\frac{(I_3 - I_2)(I_3 - I_1)}{I_1 I_2}},

    with ``u0 = F(phi0 | m)`` the incomplete elliptic integral of the amplitude ``phi0`` for which
    ``sn = q2/A2`` and ``cn = q1/A1`` at ``t = 0``. With two equal moments ``J_perp`` and the
    symmetry axis ``s``, ``Pi(t) = exp(-t mu hat(e_s)) Pi0`` with
    ``mu = (1/J_s - 1/J_perp) Pi0_s``. Accuracy: a few ``1e-15 |Pi0|`` times ``1 + |lambda t|``,
    degrading as the motion approaches the separatrix.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.exact import free_body_momentum
    >>> Pi = free_body_momentum([1.0, 2.0, 3.0], [0.3, 0.2, 1.0], np.linspace(0.0, 10.0, 5))
    >>> Pi.shape
    (5, 3)
    >>> bool(np.allclose(np.linalg.norm(Pi, axis=1), np.linalg.norm([0.3, 0.2, 1.0]), rtol=1e-14))
    True
    """
    moments = _check_moments(inertia_moments)
    Pi0 = _check_vector(Pi0, "Pi0")
    t = _real_array(t, "t")
    return _motion(moments, Pi0).momentum(t)


def free_body(
    inertia_moments: ArrayLike, R0: ArrayLike, Pi0: ArrayLike, t: ArrayLike
) -> tuple[_FloatArray, _FloatArray]:
    """Exact attitude and body angular momentum of the torque-free rigid body.

    Parameters
    ----------
    inertia_moments : array_like, shape (3,)
        Principal moments ``(J1, J2, J3)``, positive, in any order (body frame = principal frame).
    R0 : array_like, shape (3, 3), or scipy.spatial.transform.Rotation
        Attitude at ``t = 0`` (maps body vectors to inertial ones).
    Pi0 : array_like, shape (3,)
        Body angular momentum at ``t = 0``.
    t : array_like, shape (N,) or any shape
        Times (any order, negative allowed).

    Returns
    -------
    R : ndarray, shape t.shape + (3, 3)
        Attitudes, ``R' = R hat(J^{-1} Pi)``.
    Pi : ndarray, shape t.shape + (3,)
        Body angular momenta, as :func:`free_body_momentum`.

    Raises
    ------
    ValueError
        On invalid input (``R0`` must be orthogonal to 1e-10 with det +1).
    NotImplementedError
        On (or numerically at) the separatrix, see :func:`free_body_momentum`.

    See Also
    --------
    free_body_attitude : the attitude alone.
    """
    moments = _check_moments(inertia_moments)
    R0 = _check_rotation(R0)
    Pi0 = _check_vector(Pi0, "Pi0")
    t = _real_array(t, "t")
    motion = _motion(moments, Pi0)
    Pi = motion.momentum(t)
    if isinstance(motion, _Elliptic):
        R = motion.attitude(R0, t, Pi)
    else:
        R = motion.attitude(R0, t)
    return R, Pi


def free_body_attitude(
    inertia_moments: ArrayLike, R0: ArrayLike, Pi0: ArrayLike, t: ArrayLike
) -> _FloatArray:
    """Exact attitude ``R(t)`` of the torque-free rigid body.

    Parameters
    ----------
    inertia_moments : array_like, shape (3,)
        Principal moments ``(J1, J2, J3)``, positive, in any order (body frame = principal frame).
    R0 : array_like, shape (3, 3), or scipy.spatial.transform.Rotation
        Attitude at ``t = 0`` (maps body vectors to inertial ones).
    Pi0 : array_like, shape (3,)
        Body angular momentum at ``t = 0``.
    t : array_like, shape (N,) or any shape
        Times (any order, negative allowed).

    Returns
    -------
    R : ndarray, shape t.shape + (3, 3)
        Attitudes solving ``R' = R hat(Omega)``, ``Omega = J^{-1} Pi``, ``R(0) = R0``.

    Raises
    ------
    ValueError
        On invalid input (``R0`` must be orthogonal to 1e-10 with det +1).
    NotImplementedError
        On (or numerically at) the separatrix, see :func:`free_body_momentum`.

    Notes
    -----
    The spatial momentum ``L = R Pi`` is constant. Pick the body axis ``e`` along which
    ``|Pi_e|`` stays smallest and complete it to the cyclic triple ``(a, b, e)``; write
    ``R = Rot_L(psi) R0 Q(0)^T Q(t)`` where ``Q = Rx(theta) Rz(phi)`` (in the axes
    ``(a, b, e)``) is the rotation whose third row is ``Pi/|L|`` and ``Rot_L`` turns about
    ``L``. The kinematics then reduce to

    .. math::

        \\dot\\psi = |L| \\frac{\\Pi_a^2 / J_a + \\Pi_b^2 / J_b}{\\Pi_a^2 + \\Pi_b^2},

    a smooth function of ``u = lambda t + u0`` with period ``2K(m)``. Its Fourier series is
    computed by FFT until the coefficients reach round-off and integrated term by term, so
    ``psi(t)`` is accurate to round-off for any ``t``. The choice of ``e`` keeps
    ``Pi_a^2 + Pi_b^2 >= |L|^2 / 2``. Axisymmetric bodies use the closed form
    ``R = exp(t hat(L)/J_perp) R0 exp(t mu hat(e_s))``; a momentum along a principal axis gives
    ``R = R0 exp(t hat(Omega0))``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.exact import free_body_attitude, free_body_momentum
    >>> t = np.linspace(0.0, 5.0, 6)
    >>> R = free_body_attitude([1.0, 2.0, 3.0], np.eye(3), [0.3, 0.2, 1.0], t)
    >>> Pi = free_body_momentum([1.0, 2.0, 3.0], [0.3, 0.2, 1.0], t)
    >>> L = np.einsum("nij,nj->ni", R, Pi)   # spatial momentum, constant
    >>> bool(np.allclose(L, [0.3, 0.2, 1.0], atol=1e-14))
    True
    """
    return free_body(inertia_moments, R0, Pi0, t)[0]
