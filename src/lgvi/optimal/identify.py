"""Inertia identification: fit ``J`` (and the initial state) to a noisy attitude and/or rate series.

The model is the discrete LGVI (:func:`lgvi.optimal.rollout`) under known controls and potentials.
The residuals are whitened by the noise levels, ``log(R_meas^T R_k) / sigma_R`` and
``(J^-1 Pi_k - omega_meas) / sigma_omega``; their Jacobian comes from one reverse pass of the
discrete adjoint with one seed per residual, and SciPy's ``least_squares`` minimises their sum of
squares. ``J`` is parametrised by the Cholesky factor of the nonstandard inertia,
``Jd = L L^T`` (``L`` lower triangular with a positive diagonal ``exp(l_ii)``), and
``J = tr(Jd) I - Jd``: every iterate is a physical body (positive moments that satisfy the
triangle inequality). The covariance of the estimate is the Gauss-Newton one,
``(A^T A)^-1`` with ``A`` the whitened Jacobian at the solution.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import so3
from .._validation import as_float, as_float_array, as_int, as_rotation
from ..errors import ConvergenceError
from .adjoint import as_body, reverse, rollout

__all__ = ["InertiaFit", "identify_inertia"]

#: Order of the six unique entries of ``J`` in :attr:`InertiaFit.covariance`.
ENTRIES = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
_TRIL = ((0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (2, 2))


@dataclass(frozen=True)
class InertiaFit:
    """Result of :func:`identify_inertia`.

    Attributes
    ----------
    inertia : (3, 3) ndarray
        The fitted ``J``.
    covariance : (6, 6) ndarray
        Gauss-Newton covariance of ``(J11, J22, J33, J12, J13, J23)``.
    standard_error : (3, 3) ndarray
        Standard errors of the entries of ``J`` (square roots of the covariance's diagonal).
    R0 : (3, 3) ndarray; omega0 : (3,) ndarray
        Fitted (or given) initial state.
    cost : float
        Half the sum of the squared whitened residuals at the solution.
    residuals : int
        Number of residuals.
    stats : dict
        ``least_squares``' status, message and evaluation counts.
    """

    inertia: np.ndarray
    covariance: np.ndarray
    standard_error: np.ndarray
    R0: np.ndarray
    omega0: np.ndarray
    cost: float
    residuals: int
    stats: dict = field(default_factory=dict)


def _jd_from_theta(th):
    L = np.zeros((3, 3))
    for v, (i, j) in zip(th, _TRIL):
        L[i, j] = np.exp(v) if i == j else v
    Jd = L @ L.T
    return L, Jd, np.trace(Jd) * np.eye(3) - Jd


def _theta_from_J(J):
    Jd = 0.5 * np.trace(J) * np.eye(3) - J
    L = np.linalg.cholesky(Jd)
    return np.array([np.log(L[i, j]) if i == j else L[i, j] for i, j in _TRIL])


def _theta_gradient(G, L):
    """``d/dtheta`` of a function with symmetric gradient ``G`` (S, 3, 3) in ``J``."""
    tr = np.trace(G, axis1=1, axis2=2)
    GJd = tr[:, None, None] * np.eye(3) - G
    GL = 2.0 * GJd @ L
    out = np.empty((G.shape[0], 6))
    for c, (i, j) in enumerate(_TRIL):
        out[:, c] = GL[:, i, j] * (L[i, j] if i == j else 1.0)
    return out


def identify_inertia(inertia0: Any, *, h: Any, R0: Any, omega0: Any, R_meas: Any = None, omega_meas: Any = None,
                     sigma_R: Any = None, sigma_omega: Any = None, every: int = 1, u: Any = None,
                     torque: Any = None, fit_initial: bool = True, max_nfev: int = 200) -> InertiaFit:
    """Fit the inertia (and the initial state) to noisy samples of a discrete LGVI run.

    Parameters
    ----------
    inertia0 : lgvi.RigidBody, (3,) or (3, 3)
        Initial guess of ``J`` (physical).
    h : float
        Step size of the model; the samples are at steps ``0, every, 2 every, ...``.
    R0 : (3, 3) rotation; omega0 : (3,)
        Initial state (the guess when ``fit_initial``).
    R_meas : None or (M, 3, 3) rotations
        Measured attitudes (noise ``R_meas = R exp(hat(n))``, ``n ~ N(0, sigma_R^2 I)``).
    omega_meas : None or (M, 3)
        Measured body rates (noise ``N(0, sigma_omega^2 I)``).
    sigma_R, sigma_omega : float
        Noise levels (rad, rad/s), required with their series.
    every : int
        Steps between samples.
    u : None or ((M - 1) every, 3)
        Known controls (the paper's forcing); ``torque`` a known conservative model.
    fit_initial : bool
        Fit ``R0`` and ``omega0`` too (default), or hold them at the given values.
    max_nfev : int
        Limit of model evaluations.

    Returns
    -------
    InertiaFit

    Raises
    ------
    lgvi.ConvergenceError
        When the least-squares solver does not converge.
    """
    from scipy import optimize

    body0 = as_body(inertia0, "inertia0")
    h = as_float(h, "h", nonzero=True)
    R0 = as_rotation(R0, "R0")
    w0 = as_float_array(omega0, "omega0", (3,))
    every = as_int(every, "every", minimum=1)
    max_nfev = as_int(max_nfev, "max_nfev", minimum=1)
    if R_meas is None and omega_meas is None:
        raise ValueError("give R_meas (M, 3, 3) and/or omega_meas (M, 3): there is nothing to fit")
    M = None
    if R_meas is not None:
        R_meas = as_float_array(R_meas, "R_meas", (None, 3, 3))
        sR = as_float(sigma_R, "sigma_R", positive=True) if sigma_R is not None else None
        if sR is None:
            raise ValueError("sigma_R (the attitude noise, rad) is required with R_meas")
        M = R_meas.shape[0]
    if omega_meas is not None:
        omega_meas = as_float_array(omega_meas, "omega_meas", (None, 3))
        sW = as_float(sigma_omega, "sigma_omega", positive=True) if sigma_omega is not None else None
        if sW is None:
            raise ValueError("sigma_omega (the rate noise, rad/s) is required with omega_meas")
        if M is not None and omega_meas.shape[0] != M:
            raise ValueError(f"omega_meas must have as many samples as R_meas ({M}), got {omega_meas.shape[0]}")
        M = omega_meas.shape[0]
    if M < 2:
        raise ValueError(f"at least 2 samples are needed, got {M}")
    N = (M - 1) * every
    if u is None:
        u = np.zeros((N, 3))
    u = as_float_array(u, "u", (N, 3))
    if torque is None and not np.any(u):
        raise ValueError("without a known moment (u or torque) the scale of J is unobservable: J and c J give the "
                         "same attitudes and rates; give the known controls u or a torque model")
    idx = np.arange(M) * every
    nR = 3 * M if R_meas is not None else 0
    nW = 3 * M if omega_meas is not None else 0
    S = nR + nW

    def unpack(p):
        L, Jd, J = _jd_from_theta(p[:6])
        if fit_initial:
            z, w = p[6:9], p[9:12]
        else:
            z, w = np.zeros(3), w0
        return L, J, R0 @ so3.exp(z), z, w

    def model(p):
        L, J, Ra, z, w = unpack(p)
        run = rollout(J, Ra, J @ w, h, u, torque=torque)
        return run, L, J, z, w

    def residuals(p):
        run, *_ = model(p)
        out = []
        if nR:
            out.append((so3.log(np.swapaxes(R_meas, 1, 2) @ run.R[idx]) / sR).ravel())
        if nW:
            out.append(((run.Pi[idx] @ run.body.J_inv.T - omega_meas) / sW).ravel())
        return np.concatenate(out)

    def jacobian(p):
        run, L, J, z, w = model(p)
        Jinv = run.body.J_inv
        dR = np.zeros((S, N + 1, 3))
        dP = np.zeros((S, N + 1, 3))
        Gd = np.zeros((S, 3, 3))
        rows = np.arange(M)
        if nR:
            phi = so3.log(np.swapaxes(R_meas, 1, 2) @ run.R[idx])
            Jri = so3.right_jacobian_inv(phi) / sR                          # (M, 3, 3)
            for i in range(3):
                dR[3 * rows + i, idx] = Jri[:, i, :]
        if nW:
            om = run.Pi[idx] @ Jinv.T
            for i in range(3):
                s = nR + 3 * rows + i
                dP[s, idx] = Jinv[i] / sW
                g = -np.einsum("a,mb->mab", Jinv[i], om) / sW                # d omega_i / dJ = -J^-1[i] omega^T
                Gd[s] = 0.5 * (g + np.swapaxes(g, 1, 2))
        lam, gu, gJ, gh = reverse(run, dR, dP, np.zeros((S, N, 3)))
        # Pi0 = J omega0
        G = gJ + Gd + 0.5 * (np.einsum("sa,b->sab", lam[:, 3:], w) + np.einsum("a,sb->sab", w, lam[:, 3:]))
        cols = [_theta_gradient(G, L)]
        if fit_initial:
            cols.append(lam[:, :3] @ so3.right_jacobian(z))                   # R0 exp(z): dzeta = Jr(z) dz
            cols.append(lam[:, 3:] @ J)
        return np.hstack(cols)

    p0 = _theta_from_J(body0.J)
    if fit_initial:
        p0 = np.concatenate([p0, np.zeros(3), w0])
    res = optimize.least_squares(residuals, p0, jac=jacobian, method="trf", x_scale="jac", xtol=1e-12,
                                 ftol=1e-12, gtol=1e-10, max_nfev=max_nfev)
    if res.status <= 0:
        raise ConvergenceError(f"identify_inertia: least squares did not converge ({res.message}); "
                               f"give a better inertia0 or more samples")
    A = res.jac
    L, J, Ra, z, w = unpack(res.x)
    cov_p = np.linalg.pinv(A.T @ A)
    # propagate to the six entries of J (the map theta -> J by central differences of a closed form)
    B = np.zeros((6, 6))
    for c in range(6):
        d = np.zeros(res.x.size)
        d[c] = 1e-6
        Jp = unpack(res.x + d)[1]
        Jm = unpack(res.x - d)[1]
        B[:, c] = [(Jp[i, j] - Jm[i, j]) / 2e-6 for i, j in ENTRIES]
    cov = B @ cov_p[:6, :6] @ B.T
    se = np.zeros((3, 3))
    for c, (i, j) in enumerate(ENTRIES):
        se[i, j] = se[j, i] = np.sqrt(max(cov[c, c], 0.0))
    stats = {"status": int(res.status), "message": str(res.message), "nfev": int(res.nfev),
             "njev": int(res.njev or 0), "optimality": float(res.optimality)}
    return InertiaFit(inertia=J, covariance=cov, standard_error=se, R0=Ra, omega0=w, cost=float(res.cost),
                      residuals=S, stats=stats)
