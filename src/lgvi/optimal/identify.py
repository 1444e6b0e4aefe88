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

__all__ = ["FIRST_WINDOW", "InertiaFit", "MISFIT", "identify_inertia"]

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


def _rates_from_data(R_meas, omega_meas, dt, K=7):
    """A short fit of the initial body rate to the first ``K`` samples (spacing ``dt``): the measured
    rates' straight line at ``t = 0``, or with attitudes only the rotation vectors
    ``log(R_meas[0]^T R_meas[i]) ~ a + omega t_i + b t_i^2`` (body frame, first order in the motion)."""
    K = min(K, (R_meas if omega_meas is None else omega_meas).shape[0])
    t = dt * np.arange(K)
    if omega_meas is not None:
        A = np.stack([np.ones(K), t], axis=1)
        return np.linalg.lstsq(A, omega_meas[:K], rcond=None)[0][0]
    phi = so3.log(np.swapaxes(np.broadcast_to(R_meas[0], (K, 3, 3)), 1, 2) @ R_meas[:K])
    A = np.stack([np.ones(K), t, t * t], axis=1)
    return np.linalg.lstsq(A, phi, rcond=None)[0][1]


#: The first window of the continuation: samples of the first fit (then doubled up to all of them).
FIRST_WINDOW = 11
#: A converged fit whose whitened residuals have a larger variance (1 expected) is refused.
MISFIT = 10.0


def identify_inertia(inertia0: Any, *, h: Any, R0: Any = None, omega0: Any = None, R_meas: Any = None,
                     omega_meas: Any = None, sigma_R: Any = None, sigma_omega: Any = None, every: int = 1, u: Any = None,
                     torque: Any = None, fit_initial: bool = True, max_nfev: int = 200,
                     windows: bool = True) -> InertiaFit:
    """Fit the inertia (and the initial state) to noisy samples of a discrete LGVI run.

    Parameters
    ----------
    inertia0 : lgvi.RigidBody, (3,) or (3, 3)
        Initial guess of ``J`` (physical).
    h : float
        Step size of the model; the samples are at steps ``0, every, 2 every, ...``.
    R0 : (3, 3) rotation, optional
        Initial attitude (the guess when ``fit_initial``); default ``R_meas[0]``.
    omega0 : (3,), optional
        Initial body rate (the guess when ``fit_initial``); default: a short fit to the first
        samples (the measured rates' line at ``t = 0``, or with attitudes only the rotation
        vectors of the first seven attitudes relative to the first, a quadratic in ``t``).
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
        Limit of model evaluations (of each window).
    windows : bool
        Fit the first :data:`FIRST_WINDOW` samples, then twice as many from that solution, and
        so on up to all of them (default): a poor starting guess is corrected where the model
        cannot drift far from the data. ``False``: one fit of the whole series.

    Returns
    -------
    InertiaFit

    Raises
    ------
    lgvi.ConvergenceError
        When the least-squares solver does not converge. Its message names the poor guess (the
        initial rate when the first samples are far off, else the inertia) and its ``fit``
        attribute holds the best iterate (an :class:`InertiaFit` with ``stats["converged"]``
        False).
    """
    body0 = as_body(inertia0, "inertia0")
    h = as_float(h, "h", nonzero=True)
    every = as_int(every, "every", minimum=1)
    max_nfev = as_int(max_nfev, "max_nfev", minimum=1)
    if R_meas is None and omega_meas is None:
        raise ValueError("give R_meas (M, 3, 3) and/or omega_meas (M, 3): there is nothing to fit")
    M = None
    sR = sW = None
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
    if R0 is None:
        if R_meas is None:
            raise ValueError("R0 is required without R_meas (there is no measured attitude to start from)")
        R0 = R_meas[0]
    R0 = as_rotation(R0, "R0")
    guessed = omega0 is None
    w0 = _rates_from_data(R_meas, omega_meas, h * every) if guessed else as_float_array(omega0, "omega0", (3,))
    N = (M - 1) * every
    if u is None:
        u = np.zeros((N, 3))
    u = as_float_array(u, "u", (N, 3))
    if torque is None and not np.any(u):
        raise ValueError("without a known moment (u or torque) the scale of J is unobservable: J and c J give the "
                         "same attitudes and rates; give the known controls u or a torque model")
    if not isinstance(windows, (bool, np.bool_)):
        raise TypeError(f"windows must be True or False, got {windows!r}")
    sizes = [M]
    if windows:
        m = FIRST_WINDOW
        sizes = []
        while m < M:
            sizes.append(m)
            m = 2 * m - 1
        sizes.append(M)
    p = _theta_from_J(body0.J)
    if fit_initial:
        p = np.concatenate([p, np.zeros(3), w0])
    problem = dict(R0=R0, w0=w0, R_meas=R_meas, omega_meas=omega_meas, sR=sR, sW=sW, every=every, u=u, h=h,
                   torque=torque, fit_initial=fit_initial)
    start = p.copy()
    for n, m in enumerate(sizes):
        # the first window holds J at its guess: a second of data fixes the initial state, not J
        free = np.arange(6, p.size) if n == 0 and len(sizes) > 1 and fit_initial else np.arange(p.size)
        fit, p, res = _fit_window(problem, m, p, max_nfev, free)
        if res.status <= 0 or not np.all(np.isfinite(res.x)):
            raise _failure(problem, m, M, start, fit, res, guessed)
    variance = 2.0 * fit.cost / fit.residuals
    if variance > MISFIT:
        err = ConvergenceError(f"identify_inertia: the least squares converged to a fit that does not explain the "
                               f"data: the whitened residuals have variance {variance:.3g} (1 expected with the "
                               f"given noise levels, above {MISFIT:g} refused): a local minimum from a poor start, "
                               "or sigma_R/sigma_omega understate the noise; try another inertia0. The fit is in .fit")
        err.fit = fit  # type: ignore[attr-defined]
        raise err
    return fit


def _window(problem, m):
    """``(residuals, jacobian, unpack, S)`` of the fit to the first ``m`` samples."""
    R_meas, omega_meas, sR, sW = problem["R_meas"], problem["omega_meas"], problem["sR"], problem["sW"]
    R0, w0, every, h, torque = problem["R0"], problem["w0"], problem["every"], problem["h"], problem["torque"]
    fit_initial = problem["fit_initial"]
    N = (m - 1) * every
    u = problem["u"][:N]
    Rm = None if R_meas is None else R_meas[:m]
    Wm = None if omega_meas is None else omega_meas[:m]
    idx = np.arange(m) * every
    nR = 3 * m if Rm is not None else 0
    nW = 3 * m if Wm is not None else 0
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
            out.append((so3.log(np.swapaxes(Rm, 1, 2) @ run.R[idx]) / sR).ravel())
        if nW:
            out.append(((run.Pi[idx] @ run.body.J_inv.T - Wm) / sW).ravel())
        return np.concatenate(out)

    def jacobian(p):
        run, L, J, z, w = model(p)
        Jinv = run.body.J_inv
        dR = np.zeros((S, N + 1, 3))
        dP = np.zeros((S, N + 1, 3))
        Gd = np.zeros((S, 3, 3))
        rows = np.arange(m)
        if nR:
            phi = so3.log(np.swapaxes(Rm, 1, 2) @ run.R[idx])
            Jri = so3.right_jacobian_inv(phi) / sR                          # (m, 3, 3)
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

    return residuals, jacobian, unpack, S


def _fit_window(problem, m, p0, max_nfev, free):
    """Least squares on the first ``m`` samples from ``p0``, over the parameters ``free`` (the others
    held): ``(fit, x, res)``, the fit at the best iterate seen (the solution when it converged)."""
    from scipy import optimize

    residuals, jacobian, unpack, S = _window(problem, m)
    p0 = np.array(p0, dtype=np.float64)
    best = {"cost": np.inf, "x": p0.copy()}

    def full(q):
        p = p0.copy()
        p[free] = q
        return p

    def tracked(q):
        p = full(q)
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                r = residuals(p)
        except (ConvergenceError, FloatingPointError, np.linalg.LinAlgError, ValueError):
            r = np.full(S, np.nan)
        if not np.all(np.isfinite(r)):
            return np.full(S, 1e150)          # an iterate the model cannot run: far off
        c = 0.5 * float(r @ r)
        if c < best["cost"]:
            best["cost"], best["x"] = c, p.copy()
        return r

    res = optimize.least_squares(tracked, p0[free], jac=lambda q: jacobian(full(q))[:, free], method="trf",
                                 x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-10, max_nfev=max_nfev)
    x = full(res.x) if res.status > 0 else best["x"]
    return _inertia_fit(x, jacobian(x), unpack, S, min(res.cost, best["cost"]), res), x, res


def _inertia_fit(x, A, unpack, S, cost, res) -> InertiaFit:
    L, J, Ra, z, w = unpack(x)
    cov_p = np.linalg.pinv(A.T @ A)
    # propagate to the six entries of J (the map theta -> J by central differences of a closed form)
    B = np.zeros((6, 6))
    for c in range(6):
        d = np.zeros(x.size)
        d[c] = 1e-6
        Jp = unpack(x + d)[1]
        Jm = unpack(x - d)[1]
        B[:, c] = [(Jp[i, j] - Jm[i, j]) / 2e-6 for i, j in ENTRIES]
    cov = B @ cov_p[:6, :6] @ B.T
    se = np.zeros((3, 3))
    for c, (i, j) in enumerate(ENTRIES):
        se[i, j] = se[j, i] = np.sqrt(max(cov[c, c], 0.0))
    stats = {"status": int(res.status), "message": str(res.message), "nfev": int(res.nfev),
             "njev": int(res.njev or 0), "optimality": float(res.optimality), "converged": bool(res.status > 0)}
    return InertiaFit(inertia=J, covariance=cov, standard_error=se, R0=Ra, omega0=w, cost=float(cost), residuals=S,
                      stats=stats)


def _failure(problem, m, M, start, fit, res, guessed) -> ConvergenceError:
    """The error of a fit that did not converge on the first ``m`` of ``M`` samples, naming the poor
    guess: the initial rate when the starting guess already misses the first samples (their
    whitened residuals' RMS above 10), else the inertia."""
    residuals, _, _, _ = _window(problem, min(4, M))
    try:
        early = float(np.sqrt(np.mean(residuals(start) ** 2)))
    except Exception:               # the start cannot even be run
        early = np.inf
    where = f"on the first {m} of {M} samples" if m < M else f"on all {M} samples"
    if early > 10.0 and problem["fit_initial"]:
        tip = ("omega0 is the poor guess: the starting state already misses the first samples (RMS "
               f"{early:.3g} noise levels); " + ("give a better omega0" if guessed else
                                                "give omega0=None to estimate it from the first samples"))
    else:
        tip = (f"the starting state fits the first samples (RMS {early:.3g} noise levels), so inertia0 is the poor "
               "guess (or the data do not determine J): give a better inertia0 or more samples")
    err = ConvergenceError(f"identify_inertia: least squares did not converge {where} ({res.message}); {tip}. The "
                           "best iterate is in .fit")
    err.fit = fit  # type: ignore[attr-defined]
    return err
