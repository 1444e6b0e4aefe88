"""Solving the implicit equation ``hat(h Pi) = F Jd - Jd F^T`` for ``F`` in SO(3) (paper, section 4)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._kernels.codes import METHOD_NEWTON, NOT_CONVERGED, NOT_FINITE, OVERFLOW, SINGULAR
from ._validation import as_float, as_float_array, as_int, choice
from .errors import ConvergenceError
from .registry import SOLVER_METHODS, MethodName

#: Solver names (as accepted by ``method=``) to kernel codes, derived from
#: :data:`lgvi.registry.SOLVER_METHODS` (the registry of the solver methods).
METHODS: dict[str, int] = {m.name: m.code for m in SOLVER_METHODS.values()}


@dataclass(frozen=True)
class ImplicitSolution:
    """Result of :func:`solve_implicit`.

    Attributes
    ----------
    F : (3, 3) ndarray
        The rotation solving ``hat(h Pi) = F Jd - Jd F^T``.
    iterations : int
        Updates applied (0 if the initial guess already satisfied the tolerance).
    residual : float
        ``|vee(F Jd - Jd F^T) - h Pi|_2`` at the returned ``F``.
    converged : bool
        Always ``True`` for a returned solution (failures raise :class:`ConvergenceError`).
    history : (iterations + 1,) ndarray
        Residual of every iterate, the initial guess first.
    coordinates : (3,) ndarray
        Coordinates of ``F``: rotation vector (``"paper"``, ``"newton"``) or Cayley vector.
    """

    F: np.ndarray
    iterations: int
    residual: float
    converged: bool
    history: np.ndarray = field(repr=False)
    coordinates: np.ndarray = field(repr=False)


def _text(A: np.ndarray) -> str:
    return " ".join(np.array2string(np.asarray(A), precision=10, separator=", ").split())


def check_inertia_matrix(Jd: np.ndarray) -> np.ndarray:
    """``Jd`` symmetrised, after checking it is the nonstandard inertia of a physical body.

    ``Jd = tr(J)/2 I - J`` of an SPD ``J`` obeying the triangle inequality is positive
    semidefinite (zero eigenvalue for a flat body) and ``J = tr(Jd) I - Jd`` is positive
    definite (the sum of the two smallest eigenvalues of ``Jd`` is positive).
    """
    scale = float(np.max(np.abs(Jd)))
    asym = float(np.max(np.abs(Jd - Jd.T)))
    if asym > 1e-12 * max(1.0, scale):
        raise ValueError(f"Jd must be symmetric (Jd = tr(J)/2 I - J for a symmetric inertia J): "
                         f"max |Jd - Jd^T| = {asym:.3g}, got {_text(Jd)}")
    Jd = 0.5 * (Jd + Jd.T)
    d = np.linalg.eigvalsh(Jd)
    if not (d[0] >= -1e-12 * scale and d[0] + d[1] > 0.0):
        raise ValueError(f"Jd must be the nonstandard inertia tr(J)/2 I - J of a physical body: positive "
                         f"semidefinite, with J = tr(Jd) I - Jd positive definite; its eigenvalues are "
                         f"{_text(d)}, got {_text(Jd)}")
    return Jd


def solver_options(method: str, tol: Any, max_iter: Any, alpha: Any, *,
                   min_iter: int = 1) -> tuple[int, float, int, float]:
    """Validate the solver options shared by every entry point; returns ``(code, tol, max_iter, alpha)``."""
    choice(method, "method", METHODS)
    tol = as_float(tol, "tol")
    if not 0.0 <= tol < 1.0:
        raise ValueError(f"tol must be in [0, 1) (it is relative to |h Pi|), got {tol}")
    max_iter = as_int(max_iter, "max_iter", minimum=min_iter)
    alpha = as_float(alpha, "alpha")
    if not 0.0 < alpha <= 1.0:
        raise ValueError(f"alpha must be in (0, 1], got {alpha}")
    return METHODS[method], tol, max_iter, alpha


def failure_message(status: int, residual: float, iterations: int, hnorm: float, tol: float,
                    method: int | None = None, alpha: float = 1.0) -> str:
    """The text of a :class:`ConvergenceError` for a kernel status code.

    ``method`` (a code of :data:`METHODS`) and ``alpha`` are the run's solver options: the hint
    suggests only what would change something (``method='newton'`` to a run that uses another
    solver, ``alpha < 1`` to an undamped one, more iterations only when they ran out).
    """
    if status == OVERFLOW:
        return (f"the momentum Pi after the step is not finite (the implicit equation was solved, residual "
                f"{residual:.3e}, but the torque term h u overflowed, or the moment at the new state is "
                "infinite): check the torque's magnitude, or reduce the step h.")
    what = {NOT_CONVERGED: f"did not reach the tolerance in {iterations} iterations",
            NOT_FINITE: f"produced a non-finite iterate or residual after {iterations} iterations",
            SINGULAR: f"hit a singular Newton matrix after {iterations} iterations"}[status]
    tries = ["a smaller step h"]
    if status == NOT_CONVERGED:
        tries.append(f"more iterations (max_iter > {iterations})")
    if alpha == 1.0:
        tries.append("a damped update alpha < 1")
    if method != METHOD_NEWTON:
        tries.append("method='newton'" if method is None else
                     f"method='newton' (this run uses {next(k for k, v in METHODS.items() if v == method)!r})")
    hint = f"{', '.join(tries[:-1])} or {tries[-1]}" if len(tries) > 1 else tries[0]
    return (f"the implicit equation hat(h Pi) = F Jd - Jd F^T {what}: residual {residual:.3e} "
            f"(relative {residual / hnorm if hnorm else float('inf'):.3e}, tolerance {tol:g}) at |h Pi| = {hnorm:.3g}. "
            f"Try {hint}.")


def largest_step(Jd: np.ndarray, Pi: np.ndarray, h: float, method: MethodName = "newton", *, tol: float = 1e-14,
                 max_iter: int = 50, bisections: int = 30) -> float:
    """Largest ``|h'| <= |h|`` for which ``hat(h' Pi) = F Jd - Jd F^T`` is solved from a cold start.

    A bisection on the step (each trial a cold-started solve), used to turn a failed step into a
    concrete hint. The solution branch near the identity exists only while ``|h Pi|`` is below a
    bound of the order of ``|Jd|``; beyond it no step size works at this state.

    Returns
    -------
    float
        The largest working step found, with the sign of ``h`` (0.0 if none was found).
    """
    from ._kernels.solvers import initial_guess, solve_implicit_kernel

    code = METHODS[method]
    Jd = np.asarray(Jd, dtype=np.float64)
    J = np.trace(Jd) * np.eye(3) - Jd
    E = np.zeros((3, 3))
    nohist = np.zeros(0)

    def works(step: float) -> bool:
        hPi = step * np.asarray(Pi, dtype=np.float64)
        g = np.zeros(3)
        initial_guess(code, J, hPi, g)
        return solve_implicit_kernel(code, Jd, hPi, g, tol, max_iter, 1.0, E, nohist)[2] == 0

    lo, hi = 0.0, abs(float(h))
    if works(hi):
        return float(h)
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        if works(np.copysign(mid, h)):
            lo = mid
        else:
            hi = mid
    return float(np.copysign(lo, h))


def solve_implicit(Jd: Any, hPi: Any, *, method: MethodName = "newton", tol: float = 1e-14, max_iter: int = 50,
                   alpha: float = 1.0, guess: Any = None) -> ImplicitSolution:
    """Solve ``hat(h Pi) = F Jd - Jd F^T`` for ``F`` in SO(3).

    Parameters
    ----------
    Jd : (3, 3) array_like
        Nonstandard inertia ``Jd = tr(J)/2 I - J`` of a physical body: symmetric, positive
        semidefinite, with ``J = tr(Jd) I - Jd`` positive definite (``ValueError`` otherwise).
    hPi : (3,) array_like
        Step size times body angular momentum, ``h Pi_k``.
    method : {"newton", "paper", "cayley"}
        ``"paper"``: the paper's iteration as written: ``F = exp(hat w)``,
        ``w <- w - alpha Df(w)^-1 f(w)`` with the paper's ``Df`` (linear convergence).
        ``"newton"``: exact Newton in exponential coordinates (quadratic convergence).
        ``"cayley"``: Newton in Cayley coordinates, ``F = (I + hat f)(I - hat f)^-1``
        (Lee et al.), quadratic, no trigonometry.
    tol : float
        Relative tolerance: stop when ``|f| <= tol |h Pi| + 8 eps (|Jd| |F - I| + |h Pi|)``
        with ``f = vee(F Jd - Jd F^T) - h Pi``; the second term is the round-off floor of ``f``,
        so any ``|h Pi|`` from 1e-8 to 1e3 is solved to the same relative accuracy.
    max_iter : int
        Largest number of updates.
    alpha : float in (0, 1]
        Step length of each update (damping).
    guess : (3,) array_like, optional
        Initial coordinates (rotation vector, or Cayley vector for ``"cayley"``). Default: the
        linearisation ``w = J^-1 h Pi`` (``f = w / 2``).

    Returns
    -------
    ImplicitSolution

    Raises
    ------
    ConvergenceError
        If the tolerance is not met within ``max_iter`` updates (never returns an unconverged ``F``).

    Notes
    -----
    The paper's ``Df`` has columns ``vee(e^w E_i Jd + Jd E_i e^-w) = (tr(A) I - A) F`` with
    ``A = F Jd``; it is the exact derivative for a right update ``F <- F exp(hat d)``, so with the
    paper's additive update it converges linearly. ``"newton"`` uses the exact derivative
    ``(tr(A) I - A) Jl(w)`` of ``f(w)``.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> body = lgvi.RigidBody([1.0, 2.0, 3.0])
    >>> sol = lgvi.solve_implicit(body.Jd, 0.01 * np.array([0.3, 2.0, 0.6]))
    >>> sol.converged, sol.iterations <= 5
    (True, True)
    >>> bool(np.allclose(sol.F @ sol.F.T, np.eye(3), atol=1e-14))
    True
    """
    from ._kernels.solvers import initial_guess, solve_implicit_kernel  # compiled on first use

    code, tol, max_iter, alpha = solver_options(method, tol, max_iter, alpha, min_iter=0)
    Jd = check_inertia_matrix(as_float_array(Jd, "Jd", (3, 3)))
    hPi = as_float_array(hPi, "hPi", (3,))
    J = np.trace(Jd) * np.eye(3) - Jd
    g = np.zeros(3)
    if guess is None:
        initial_guess(code, J, hPi, g)
    else:
        g[:] = as_float_array(guess, "guess", (3,))
    E = np.zeros((3, 3))
    hist = np.full(max_iter + 1, np.nan)
    its, res, status = solve_implicit_kernel(code, Jd, hPi, g, tol, max_iter, alpha, E, hist)
    if status == 0 and not (np.isfinite(res) and np.all(np.isfinite(E)) and np.all(np.isfinite(g))):
        status = NOT_FINITE  # never hand out a non-finite F (the stopping rule overflows for |hPi| > 1e154)
    if status != 0:
        raise ConvergenceError(failure_message(status, res, its, float(np.linalg.norm(hPi)), tol, code, alpha),
                               residual=float(res), iterations=int(its))
    return ImplicitSolution(F=np.eye(3) + E, iterations=int(its), residual=float(res), converged=True,
                            history=hist[: its + 1].copy(), coordinates=g)


__all__ = ["METHODS", "ImplicitSolution", "solve_implicit"]
