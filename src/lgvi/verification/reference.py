"""The paper's equations in plain NumPy, one line per equation: the oracle for the kernels.

Read beside the paper (N. Potu Surya Prakash, "A Computational Approach for Variational
Integration of Attitude Dynamics on SO(3)", UC Berkeley). Nothing here is fast; everything is literal.
The compiled kernels (:mod:`lgvi._kernels`) are tested against these functions.
"""

from __future__ import annotations

import numpy as np

from ..so3 import exp, hat, vee

E_BASIS = [hat(e) for e in np.eye(3)]  # d hat(w) / d w_i


def jd_from_inertia(J: np.ndarray) -> np.ndarray:
    """``J_d = 1/2 tr(J) I - J``."""
    return 0.5 * np.trace(J) * np.eye(3) - J


def inertia_from_jd(Jd: np.ndarray) -> np.ndarray:
    """``J = tr(J_d) I - J_d`` (eq. JtoJd)."""
    return np.trace(Jd) * np.eye(3) - Jd


def kinetic_energy(Omega: np.ndarray, Jd: np.ndarray) -> float:
    """``K = 1/2 tr(hat(Omega) J_d hat(Omega)^T)`` (eq. KE)."""
    return 0.5 * np.trace(hat(Omega) @ Jd @ hat(Omega).T)


def discrete_lagrangian(F: np.ndarray, Jd: np.ndarray, h: float) -> float:
    """``L_d(R_k, R_{k+1}) = h L(R_k, (R_{k+1} - R_k)/h) = 1/h tr((I - F_k) J_d)``.

    The paper prints ``1/(2h)``; expanding its previous line,
    ``1/(2h) tr((F - I) J_d (F - I)^T) = 1/(2h) (2 tr J_d - 2 tr(F J_d))``, gives ``1/h``, and only
    ``1/h`` yields the momentum ``Pi_k`` of eq. AttDyn (checked in ``tests/test_reference.py``).
    """
    return np.trace((np.eye(3) - F) @ Jd) / h


def f(w: np.ndarray, Jd: np.ndarray, hPi: np.ndarray) -> np.ndarray:
    """``f(w) = [e^{hat w} J_d - J_d (e^{hat w})^T - hat(h Pi_k)]^vee``."""
    return vee(exp(w) @ Jd - Jd @ exp(w).T - hat(hPi))


def Df(w: np.ndarray, Jd: np.ndarray) -> np.ndarray:
    """The paper's ``Df(w)``: columns ``[e^{hat w} E_i J_d + J_d E_i (e^{hat w})^T]^vee``."""
    return np.column_stack([vee(exp(w) @ Ei @ Jd + Jd @ Ei @ exp(w).T) for Ei in E_BASIS])


def newton_raphson(Jd: np.ndarray, hPi: np.ndarray, w0: np.ndarray, *, alpha: float = 1.0,
                   tol: float = 1e-14, max_iter: int = 500) -> tuple[np.ndarray, int]:
    """``w^{n+1} = w^n - alpha Df(w^n)^{-1} f(w^n)`` until ``|f(w^n)|_2 <= tol`` (eq. NRupdate)."""
    w = np.array(w0, dtype=float)
    for n in range(max_iter + 1):
        if np.linalg.norm(f(w, Jd, hPi)) <= tol:
            return w, n
        w = w - alpha * np.linalg.solve(Df(w, Jd), f(w, Jd, hPi))
    raise RuntimeError(f"reference Newton-Raphson did not reach |f| <= {tol} in {max_iter} iterations")


def lgvi_step(R: np.ndarray, Pi: np.ndarray, u: np.ndarray, h: float, Jd: np.ndarray, w0: np.ndarray,
              tol: float = 1e-14) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One step of eq. AttDyn; returns ``(R_{k+1}, Pi_{k+1}, w_k)``."""
    w, _ = newton_raphson(Jd, h * Pi, w0, tol=tol)      # hat(h Pi_k) = F_k J_d - J_d F_k^T
    F = exp(w)                                             # F_k = e^{hat w}
    R_next = R @ F                                         # R_{k+1} = R_k F_k
    Pi_next = F.T @ Pi + h * u                             # Pi_{k+1} = F_k^T Pi_k + h u_k
    return R_next, Pi_next, w


def simulate(J: np.ndarray, R0: np.ndarray, Pi0: np.ndarray, h: float, steps: int,
             U: np.ndarray | None = None, tol: float = 1e-14) -> tuple[np.ndarray, np.ndarray]:
    """Propagate eq. AttDyn for ``steps`` steps; returns ``R`` (steps+1, 3, 3), ``Pi`` (steps+1, 3)."""
    Jd = jd_from_inertia(np.asarray(J, dtype=float))
    R = np.empty((steps + 1, 3, 3))
    Pi = np.empty((steps + 1, 3))
    R[0], Pi[0] = R0, Pi0
    w = np.linalg.solve(inertia_from_jd(Jd), h * Pi[0])  # initial guess: hat(h Pi) ~ hat(J w)
    for k in range(steps):
        u = np.zeros(3) if U is None else U[k]
        R[k + 1], Pi[k + 1], w = lgvi_step(R[k], Pi[k], u, h, Jd, w, tol)
    return R, Pi
