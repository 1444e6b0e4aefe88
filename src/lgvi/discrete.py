"""Discrete mechanics on vector spaces: the paper's section 2.

A discrete Lagrangian ``L_d(q0, q1) ~ int_0^h L(q, qdot) dt`` on ``Q = R^n`` defines, through the
discrete Legendre transforms

    F- L_d : (q_k, q_{k+1}) -> (q_k,     p_k     = -D1 L_d(q_k, q_{k+1}))
    F+ L_d : (q_k, q_{k+1}) -> (q_{k+1}, p_{k+1} =  D2 L_d(q_k, q_{k+1}))

a symplectic, momentum-preserving map ``(q_k, p_k) -> (q_{k+1}, p_{k+1})``: solve the first
equation for ``q_{k+1}`` (Newton), then evaluate the second. Eliminating ``p`` gives the discrete
Euler-Lagrange equations ``D2 L_d(q_{k-1}, q_k) + D1 L_d(q_k, q_{k+1}) = 0``.

Contents
--------
:class:`DiscreteLagrangian`
    A user's ``L_d`` through its partial derivatives ``D1``, ``D2`` (and optionally the Jacobian
    ``D1_q1`` of ``D1`` in ``q1``; otherwise a central-difference Jacobian).
:func:`simulate_discrete`, :class:`DiscreteTrajectory`
    Run the position-momentum map for ``steps`` steps.
:func:`mechanical_lagrangian`, :class:`MechanicalSystem`
    ``L = 1/2 qdot^T M qdot - V(q)`` with midpoint or trapezoidal quadrature (the latter is
    Stormer-Verlet and is solved in closed form).
:func:`kepler`, :class:`KeplerPotential`, :func:`kepler_energy`, :func:`kepler_angular_momentum`, :func:`kepler_initial_state`
    The Kepler problem of the paper's introduction, with a compiled Stormer-Verlet path.

Examples
--------
>>> import numpy as np
>>> from lgvi import discrete
>>> system = discrete.kepler(mu=1.0)
>>> Ld = system.discrete_lagrangian(h=0.01)              # trapezoidal: Stormer-Verlet
>>> q0, p0 = discrete.kepler_initial_state(0.5)
>>> traj = discrete.simulate_discrete(Ld, q0, p0, steps=1000)
>>> L = discrete.kepler_angular_momentum(traj.q, traj.p)
>>> bool(np.max(np.abs(L - L[0])) < 1e-13 * abs(L[0]))
True
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field
from typing import Any, Callable

import numpy as np

from ._kernels.discrete_kernels import kepler_verlet_run
from ._validation import as_float, as_float_array, as_int, choice
from ._version import __version__
from .errors import ConvergenceError

ArrayFunction = Callable[[np.ndarray, np.ndarray], Any]

#: Relative step of the central-difference Jacobian: ``h_i = FD_STEP * max(1, |x_i|)``.
FD_STEP: float = float(np.finfo(np.float64).eps ** (1.0 / 3.0))

QUADRATURES = ("trapezoidal", "midpoint")
SOLVERS = ("auto", "compiled", "explicit", "newton")

__all__ = [
    "DiscreteLagrangian",
    "DiscreteTrajectory",
    "FD_STEP",
    "KeplerPotential",
    "MechanicalSystem",
    "kepler",
    "kepler_angular_momentum",
    "kepler_energy",
    "kepler_initial_state",
    "kepler_rk4",
    "mechanical_lagrangian",
    "numerical_jacobian",
    "simulate_discrete",
]


# ---------------------------------------------------------------------------------------------
# numerical Jacobian
# ---------------------------------------------------------------------------------------------
def numerical_jacobian(fun: Callable[[np.ndarray], Any], x: Any) -> np.ndarray:
    """Central-difference Jacobian ``J[i, j] = d fun(x)_i / d x_j``.

    Parameters
    ----------
    fun : callable ``fun(x) -> (m,)``
    x : (n,) array_like

    Returns
    -------
    (m, n) ndarray

    Notes
    -----
    Column ``j`` is ``(fun(x + d_j e_j) - fun(x - d_j e_j)) / (2 d_j)`` with the step scaled to
    the coordinate, ``d_j = cbrt(eps) * max(1, |x_j|)`` (``cbrt(eps) ~ 6.1e-6``); the divisor is
    the step actually represented in floating point. The truncation error ``d^2/6 |f'''|`` and
    the round-off error ``eps |f| / d`` balance at this step, so for a function whose
    derivatives are of the size of its values the Jacobian is accurate to about
    ``eps^(2/3) ~ 4e-11`` relative (``1e-10`` for ``grad(-1/|q|)`` at ``|q| ~ 1``). The step
    does not shrink below ``cbrt(eps)`` for ``|x_j| < 1``: a function that varies on a length
    scale ``l < 1`` gets a relative truncation error of about ``(cbrt(eps)/l)^2`` (``~1e-8``
    for ``l = 0.1``); rescale such coordinates or pass the exact Jacobian.
    Newton's method with it converges linearly with a
    contraction factor of that size: in practice one extra iteration, and the same root, since
    the root is fixed by the residual, not by the Jacobian. Costs ``2 n`` calls of ``fun``.
    """
    x = np.array(x, dtype=np.float64)
    n = x.shape[0]
    step = FD_STEP * np.maximum(1.0, np.abs(x))
    cols = []
    for j in range(n):
        xp = x.copy()
        xm = x.copy()
        xp[j] = x[j] + step[j]
        xm[j] = x[j] - step[j]
        cols.append((np.asarray(fun(xp), dtype=np.float64) - np.asarray(fun(xm), dtype=np.float64))
                    / (xp[j] - xm[j]))
    return np.stack(cols, axis=-1)


def _check_callable(value: Any, name: str, *, optional: bool = False) -> None:
    if value is None and optional:
        return
    if not callable(value):
        raise TypeError(f"{name} must be callable, got {value!r} of type {type(value).__name__}")


# ---------------------------------------------------------------------------------------------
# the discrete Lagrangian
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class DiscreteLagrangian:
    """A discrete Lagrangian ``L_d(q0, q1)`` on ``R^n``, given by its partial derivatives.

    Parameters
    ----------
    D1, D2 : callable ``(q0, q1) -> (n,)``
        Gradients of ``L_d`` in its first and second argument, ``q0, q1`` of shape ``(n,)``.
    D1_q1 : callable ``(q0, q1) -> (n, n)``, optional
        Jacobian of ``D1`` in ``q1``: ``D1_q1(q0, q1)[i, j] = d^2 L_d / dq0_i dq1_j``, the
        matrix Newton needs. Default: :func:`numerical_jacobian` of ``D1(q0, .)``. (The Jacobian
        of ``D2`` in ``q0`` is its transpose, so it is never needed.)
    Ld : callable ``(q0, q1) -> float``, optional
        ``L_d`` itself; only :meth:`action` uses it.
    h : float, optional
        The step the discrete Lagrangian was built for; :func:`simulate_discrete` uses it (and
        checks a step given there against it).
    explicit_step : callable ``(q0, p0) -> (q1, p1)``, optional
        The step in closed form, for discrete Lagrangians where ``p0 = -D1 L_d(q0, q1)`` can be
        solved for ``q1`` explicitly (:func:`mechanical_lagrangian` sets it for the trapezoidal
        rule). :func:`simulate_discrete` checks its residual every step.
    initial_guess : callable ``(q0, p0) -> (n,)``, optional
        First Newton iterate for ``q1`` at step 0 (default ``q0``); later steps extrapolate
        ``2 q_k - q_{k-1}``.
    name : str
        A label carried into the trajectory's metadata.

    Notes
    -----
    One step in position-momentum form, by the discrete Legendre transforms (paper, section 2):

    .. math::

        p_k = -D_1 L_d(q_k, q_{k+1}) \\quad (\\text{solved for } q_{k+1} \\text{ by Newton}),
        \\qquad p_{k+1} = D_2 L_d(q_k, q_{k+1}).

    Newton iterates ``q1 <- q1 - D1_q1(q_k, q1)^{-1} (p_k + D1(q_k, q1))`` and stops when the
    residual ``r = p_k + D1(q_k, q1)`` has ``|r|_inf <= tol max(1, |p_k|_inf)``, or when a
    (contracting) correction has ``|dq|_inf <= tol max(1, |q1|_inf)`` (the residual of a
    difference quotient ``M (q1 - q0)/h`` cannot fall below ``eps |M q| / h``, so for small
    ``h`` only the second test is reachable).

    Examples
    --------
    The harmonic oscillator ``L = qdot^2/2 - q^2/2`` with the midpoint rule:

    >>> import numpy as np
    >>> h = 0.1
    >>> Ld = DiscreteLagrangian(
    ...     D1=lambda q0, q1: -(q1 - q0) / h - h / 4 * (q0 + q1),
    ...     D2=lambda q0, q1: (q1 - q0) / h - h / 4 * (q0 + q1), h=h)
    >>> q1, p1 = Ld.step(np.array([1.0]), np.array([0.0]))
    >>> bool(abs(0.5 * p1[0]**2 + 0.5 * q1[0]**2 - 0.5) < 1e-14)   # implicit midpoint: exact
    True
    """

    D1: ArrayFunction
    D2: ArrayFunction
    _: KW_ONLY
    D1_q1: ArrayFunction | None = None
    Ld: Callable[[np.ndarray, np.ndarray], float] | None = None
    h: float | None = None
    explicit_step: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None
    initial_guess: Callable[[np.ndarray, np.ndarray], Any] | None = None
    name: str = "user"
    # Data (never callables) for a compiled stepping kernel; set by built-in systems only.
    _compiled: tuple | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        _check_callable(self.D1, "D1")
        _check_callable(self.D2, "D2")
        for name in ("D1_q1", "Ld", "explicit_step", "initial_guess"):
            _check_callable(getattr(self, name), name, optional=True)
        if self.h is not None:
            object.__setattr__(self, "h", as_float(self.h, "h", nonzero=True))
        if not isinstance(self.name, str):
            raise TypeError(f"name must be a str, got {self.name!r}")

    # --- the discrete Legendre transforms ------------------------------------------------------
    def legendre_minus(self, q0: Any, q1: Any) -> np.ndarray:
        """``F- L_d``: the momentum ``p0 = -D1 L_d(q0, q1)`` at the start of the step, (n,)."""
        return -np.asarray(self.D1(np.asarray(q0, float), np.asarray(q1, float)), dtype=np.float64)

    def legendre_plus(self, q0: Any, q1: Any) -> np.ndarray:
        """``F+ L_d``: the momentum ``p1 = D2 L_d(q0, q1)`` at the end of the step, (n,)."""
        return np.asarray(self.D2(np.asarray(q0, float), np.asarray(q1, float)), dtype=np.float64)

    def jacobian(self, q0: Any, q1: Any) -> np.ndarray:
        """``d D1(q0, q1) / d q1``, (n, n): ``D1_q1`` if given, else central differences."""
        q0 = np.asarray(q0, dtype=np.float64)
        if self.D1_q1 is not None:
            return np.asarray(self.D1_q1(q0, np.asarray(q1, float)), dtype=np.float64)
        return numerical_jacobian(lambda x: self.D1(q0, x), q1)

    def el_residual(self, q: Any) -> np.ndarray:
        """Discrete Euler-Lagrange residual ``D2 L_d(q_{k-1}, q_k) + D1 L_d(q_k, q_{k+1})``.

        Parameters
        ----------
        q : (M, n) array_like
            A discrete path.

        Returns
        -------
        (M - 2, n) ndarray
            Zero (to solver tolerance) along a trajectory of :func:`simulate_discrete`.
        """
        q = np.asarray(q, dtype=np.float64)
        out = [np.asarray(self.D2(q[k - 1], q[k]), float) + np.asarray(self.D1(q[k], q[k + 1]), float)
               for k in range(1, len(q) - 1)]
        return np.array(out).reshape(max(len(q) - 2, 0), q.shape[-1])

    def action(self, q: Any) -> float:
        """Discrete action ``A_d = sum_k L_d(q_k, q_{k+1})`` of a path ``q`` (M, n); needs ``Ld``."""
        if self.Ld is None:
            raise ValueError("action needs the discrete Lagrangian itself: pass Ld=... to DiscreteLagrangian")
        q = np.asarray(q, dtype=np.float64)
        return float(sum(float(self.Ld(q[k], q[k + 1])) for k in range(len(q) - 1)))

    def step(self, q0: Any, p0: Any, *, tol: float = 1e-13, max_iter: int = 50,
             solver: str = "auto") -> tuple[np.ndarray, np.ndarray]:
        """One step ``(q0, p0) -> (q1, p1)``; see :func:`simulate_discrete` for the options.

        Returns
        -------
        q1, p1 : (n,) ndarray
        """
        traj = simulate_discrete(self, q0, p0, steps=1, h=self.h if self.h is not None else 1.0,
                                 tol=tol, max_iter=max_iter, solver=solver)
        return traj.q[1].copy(), traj.p[1].copy()


# ---------------------------------------------------------------------------------------------
# trajectory
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class DiscreteTrajectory:
    """A run of the discrete position-momentum map, sampled every step.

    Attributes
    ----------
    t : (M,) ndarray
        Times ``t0 + k h``, ``M = steps + 1``.
    q : (M, n) ndarray
        Positions ``q_k``.
    p : (M, n) ndarray
        Momenta ``p_k`` (``p_0`` as given, then ``D2 L_d(q_{k-1}, q_k)``).
    iterations : (steps,) ndarray of int
        Newton updates of each step (0 for the closed-form solvers).
    residual : (steps,) ndarray of float
        Final ``|p_k + D1 L_d(q_k, q_{k+1})|_inf`` of each step.
    h : float
        Step size.
    meta : dict
        Solver, tolerance, Lagrangian name, package version.
    """

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    h: float
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("t", "q", "p", "iterations", "residual"):
            arr = np.asarray(getattr(self, name))
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        span = f"t=[{self.t[0]:.6g}, {self.t[-1]:.6g}]" if len(self.t) else "empty"
        return (f"DiscreteTrajectory(samples={len(self.t)}, steps={len(self.iterations)}, n={self.q.shape[-1]}, "
                f"h={self.h:g}, {span}, solver={self.meta.get('solver')!r})")


# ---------------------------------------------------------------------------------------------
# simulation
# ---------------------------------------------------------------------------------------------
def _evaluate(fun: Callable, args: tuple, name: str, shape: tuple[int, ...], k: int) -> np.ndarray:
    value = fun(*args)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must return real numbers of shape {shape}; at step {k} it returned "
                         f"{value!r}") from exc
    if arr.shape != shape:
        raise ValueError(f"{name} must return shape {shape}; at step {k} it returned shape {arr.shape}")
    return arr


def _newton(Ld: DiscreteLagrangian, q0: np.ndarray, p0: np.ndarray, q1: np.ndarray, tol: float,
            max_iter: int, k: int) -> tuple[np.ndarray, int, float, str | None]:
    """Solve ``p0 + D1(q0, q1) = 0`` for ``q1`` from the guess ``q1``.

    Returns ``(q1, iterations, residual, failure)`` with ``failure`` None on success.
    """
    n = q0.shape[0]
    tol_r = tol * max(1.0, float(np.max(np.abs(p0))))
    dn_prev = np.inf
    dn = np.inf
    for it in range(max_iter + 1):
        r = p0 + _evaluate(Ld.D1, (q0, q1), "D1", (n,), k)
        rn = float(np.max(np.abs(r)))
        if not np.isfinite(rn):
            return q1, it, rn, "the residual is not finite (D1 returned NaN or inf)"
        if rn <= tol_r or (dn <= tol * max(1.0, float(np.max(np.abs(q1)))) and dn <= dn_prev):
            return q1, it, rn, None
        if it == max_iter:
            return q1, it, rn, f"max_iter = {max_iter} Newton iterations were not enough"
        if Ld.D1_q1 is not None:
            Jac = _evaluate(Ld.D1_q1, (q0, q1), "D1_q1", (n, n), k)
        else:
            Jac = numerical_jacobian(lambda x: Ld.D1(q0, x), q1)
        try:
            d = np.linalg.solve(Jac, -r)
        except np.linalg.LinAlgError:
            return q1, it, rn, "the Jacobian D1_q1 is singular"
        if not np.all(np.isfinite(d)):
            return q1, it, rn, "the Newton correction is not finite (singular or non-finite Jacobian)"
        dn_prev, dn = dn, float(np.max(np.abs(d)))
        q1 = q1 + d
    raise AssertionError("unreachable")  # pragma: no cover


def _pick_solver(Ld: DiscreteLagrangian, solver: str) -> str:
    choice(solver, "solver", SOLVERS)
    if solver == "auto":
        return "compiled" if Ld._compiled is not None else "explicit" if Ld.explicit_step is not None else "newton"
    if solver == "compiled" and Ld._compiled is None:
        raise ValueError(f"solver='compiled' needs a built-in system with a compiled kernel (the Kepler problem "
                         f"with trapezoidal quadrature, see kepler()); {Ld.name!r} has none. Use 'auto'.")
    if solver == "explicit" and Ld.explicit_step is None:
        raise ValueError(f"solver='explicit' needs a closed-form step (explicit_step); {Ld.name!r} has none. "
                         "Use 'newton' or 'auto'.")
    return solver


def simulate_discrete(Ld: DiscreteLagrangian, q0: Any, p0: Any, *, steps: int, h: float | None = None,
                      t0: float = 0.0, tol: float = 1e-13, max_iter: int = 50,
                      solver: str = "auto") -> DiscreteTrajectory:
    """Iterate the discrete position-momentum map of ``Ld`` for ``steps`` steps.

    Parameters
    ----------
    Ld : DiscreteLagrangian
    q0, p0 : (n,) array_like
        Initial position and momentum.
    steps : int
        Number of steps (>= 0).
    h : float, optional
        Step size, used for the time stamps ``t0 + k h``. Defaults to ``Ld.h``; if both are
        given they must agree (the step is built into ``L_d``).
    t0 : float
        Initial time.
    tol : float
        Newton tolerance (> 0), see :class:`DiscreteLagrangian` Notes.
    max_iter : int
        Newton iterations allowed per step (>= 1).
    solver : {"auto", "compiled", "explicit", "newton"}
        ``"newton"``: the generic path, Newton on ``p_k = -D1 L_d(q_k, q_{k+1})`` calling the
        user's functions from Python every step. ``"explicit"``: ``Ld.explicit_step``
        (closed-form trapezoidal rule). ``"compiled"``: a Numba kernel, for built-in systems
        (Stormer-Verlet for :func:`kepler`; about 10 ns per step). ``"auto"``: the first of
        compiled, explicit, newton that ``Ld`` offers.

    Returns
    -------
    DiscreteTrajectory
        ``t`` (steps+1,), ``q``, ``p`` (steps+1, n), ``iterations``, ``residual`` (steps,).

    Raises
    ------
    ConvergenceError
        If Newton does not reach ``tol`` at some step (names the step, the residual and what
        to try; ``.trajectory`` holds the states computed before it), or the compiled kernel
        meets a collision ``|q| = 0``.
    ValueError
        For invalid arguments, or user functions returning the wrong shape.

    Notes
    -----
    Each step applies the discrete Legendre transforms (paper, section 2, eqs. 5-6):

    .. math::

        p_k = -D_1 L_d(q_k, q_{k+1}) \\;\\Rightarrow\\; q_{k+1} \\text{ (Newton)}, \\qquad
        p_{k+1} = D_2 L_d(q_k, q_{k+1}),

    which together are the discrete Euler-Lagrange equations
    ``D2 L_d(q_{k-1}, q_k) + D1 L_d(q_k, q_{k+1}) = 0``. The map is symplectic and, when
    ``L_d`` is invariant under a symmetry, preserves the discrete Noether momentum exactly
    (up to the solver tolerance and round-off).
    """
    if not isinstance(Ld, DiscreteLagrangian):
        raise TypeError(f"Ld must be a DiscreteLagrangian, got {type(Ld).__name__}")
    q0 = as_float_array(q0, "q0", (None,)).copy()
    n = q0.shape[0]
    if n == 0:
        raise ValueError("q0 must have at least one coordinate, got shape (0,)")
    p0 = as_float_array(p0, "p0", (n,)).copy()
    steps = as_int(steps, "steps", minimum=0)
    if h is None:
        if Ld.h is None:
            raise ValueError("h must be given (the discrete Lagrangian does not record its step)")
        h = Ld.h
    h = as_float(h, "h", nonzero=True)
    if Ld.h is not None and abs(h - Ld.h) > 1e-12 * abs(Ld.h):
        raise ValueError(f"h = {h!r} differs from the step the discrete Lagrangian was built for, Ld.h = {Ld.h!r}")
    t0 = as_float(t0, "t0")
    tol = as_float(tol, "tol", positive=True)
    max_iter = as_int(max_iter, "max_iter", minimum=1)
    solver = _pick_solver(Ld, solver)

    t = t0 + h * np.arange(steps + 1, dtype=np.float64)
    q = np.empty((steps + 1, n))
    p = np.empty((steps + 1, n))
    iterations = np.zeros(steps, dtype=np.int64)
    residual = np.zeros(steps)
    meta = {"solver": solver, "lagrangian": Ld.name, "tol": tol, "max_iter": max_iter,
            "version": __version__}

    def partial(k: int) -> DiscreteTrajectory:
        return DiscreteTrajectory(t[:k + 1].copy(), q[:k + 1].copy(), p[:k + 1].copy(),
                                  iterations[:k].copy(), residual[:k].copy(), h, dict(meta))

    if solver == "compiled":
        kind, M, Minv, mu = Ld._compiled
        if kind != "kepler_verlet" or M.shape != (n, n):
            raise ValueError(f"q0 must have shape ({M.shape[0]},) for this system, got ({n},)")
        reached = kepler_verlet_run(q0, p0, M, Minv, h, mu, steps, q, p, residual)
        if reached != steps:
            raise ConvergenceError(
                f"simulate_discrete: step {reached} (t = {t[reached]:g}) hit the Kepler singularity "
                f"|q| = 0 or a non-finite state at q = {q[reached]}; the orbit collides with the centre. "
                "Try a smaller step h, or an initial state with non-zero angular momentum.",
                residual=float("nan"), iterations=0, step=reached, time=float(t[reached]),
                trajectory=partial(reached))
        return DiscreteTrajectory(t, q, p, iterations, residual, h, meta)

    q[0] = q0
    p[0] = p0
    for k in range(steps):
        qk, pk = q[k], p[k]
        if solver == "explicit":
            out = Ld.explicit_step(qk, pk)
            if not (isinstance(out, tuple) and len(out) == 2):
                raise ValueError(f"explicit_step must return a pair (q1, p1); at step {k} it returned {out!r}")
            q1 = _evaluate(lambda: out[0], (), "explicit_step (q1)", (n,), k)
            p1 = _evaluate(lambda: out[1], (), "explicit_step (p1)", (n,), k)
            rn = float(np.max(np.abs(pk + _evaluate(Ld.D1, (qk, q1), "D1", (n,), k))))
            its = 0
            failure = None
            if not (np.isfinite(rn) and np.all(np.isfinite(q1)) and np.all(np.isfinite(p1))):
                failure = "the closed-form step returned non-finite values"
        else:
            if k > 0:
                guess = 2.0 * qk - q[k - 1]
            elif Ld.initial_guess is not None:
                guess = _evaluate(Ld.initial_guess, (qk, pk), "initial_guess", (n,), k)
            else:
                guess = qk.copy()
            q1, its, rn, failure = _newton(Ld, qk, pk, guess, tol, max_iter, k)
            if failure is None:
                p1 = _evaluate(Ld.D2, (qk, q1), "D2", (n,), k)
                if not np.all(np.isfinite(p1)):
                    failure = "D2 returned non-finite values"
        iterations[k] = its
        residual[k] = rn
        if failure is not None:
            raise ConvergenceError(
                f"simulate_discrete: step {k} (t = {t[k]:g}) did not solve p_k = -D1 L_d(q_k, q_k+1): "
                f"{failure}; residual |p_k + D1 L_d|_inf = {rn:.3g} after {its} Newton iterations "
                f"(tol = {tol:g}). Try a smaller step h, a larger max_iter, a looser tol, or check "
                "D1 and D1_q1 against each other (the derivative of D1 in q1).",
                residual=rn, iterations=int(its), step=k, time=float(t[k]), trajectory=partial(k))
        q[k + 1] = q1
        p[k + 1] = p1
    return DiscreteTrajectory(t, q, p, iterations, residual, h, meta)


# ---------------------------------------------------------------------------------------------
# mechanical systems L = 1/2 qdot^T M qdot - V(q)
# ---------------------------------------------------------------------------------------------
def _mass_matrix(M: Any) -> np.ndarray:
    arr = as_float_array(M, "M")
    if arr.ndim == 1:
        if arr.size == 0 or not np.all(arr > 0):
            raise ValueError(f"M given as a diagonal (n,) must have positive entries, got {arr}")
        return np.diag(arr)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or arr.shape[0] == 0:
        raise ValueError(f"M must be a (n, n) symmetric positive definite matrix or its diagonal (n,), "
                         f"got shape {arr.shape}")
    scale = float(np.max(np.abs(arr)))
    if not np.allclose(arr, arr.T, rtol=0, atol=1e-12 * scale):
        raise ValueError(f"M must be symmetric, got M - M^T with max |entry| {np.max(np.abs(arr - arr.T)):.3g}")
    try:
        np.linalg.cholesky(arr)
    except np.linalg.LinAlgError:
        raise ValueError(f"M must be positive definite, got eigenvalues {np.linalg.eigvalsh(arr)}") from None
    return 0.5 * (arr + arr.T)


@dataclass(frozen=True, eq=False)
class KeplerPotential:
    """``V(q) = -mu / |q|`` on ``R^n``, as data (so a compiled kernel can use it).

    Calls are vectorised over leading axes: ``V(q)`` (...,), :meth:`gradient` (..., n),
    :meth:`hessian` (..., n, n).
    """

    mu: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "mu", as_float(self.mu, "mu", positive=True))

    def __call__(self, q: Any) -> np.ndarray:
        q = np.asarray(q, dtype=np.float64)
        return -self.mu / np.sqrt(np.sum(q * q, axis=-1))

    def gradient(self, q: Any) -> np.ndarray:
        """``grad V = mu q / |q|^3``."""
        q = np.asarray(q, dtype=np.float64)
        r2 = np.sum(q * q, axis=-1)
        return (self.mu / (r2 * np.sqrt(r2)))[..., None] * q

    def hessian(self, q: Any) -> np.ndarray:
        """``mu (I / |q|^3 - 3 q q^T / |q|^5)``."""
        q = np.asarray(q, dtype=np.float64)
        r2 = np.sum(q * q, axis=-1)[..., None, None]
        r3 = r2 * np.sqrt(r2)
        eye = np.eye(q.shape[-1])
        return self.mu * (eye / r3 - 3.0 * q[..., :, None] * q[..., None, :] / (r3 * r2))


def mechanical_lagrangian(M: Any, V: Callable[[np.ndarray], float], gradV: Callable | None = None,
                          hessV: Callable | None = None, *, h: float,
                          quadrature: str = "trapezoidal") -> DiscreteLagrangian:
    """Discrete Lagrangian of ``L = 1/2 qdot^T M qdot - V(q)`` by a quadrature rule.

    Parameters
    ----------
    M : (n, n) or (n,) array_like
        Constant mass matrix (symmetric positive definite) or its diagonal.
    V : callable ``V(q) -> float``
        Potential energy, ``q`` of shape (n,).
    gradV : callable ``gradV(q) -> (n,)``
        Its gradient. May be omitted when ``V`` is a :class:`KeplerPotential`.
    hessV : callable ``hessV(q) -> (n, n)``, optional
        Its Hessian, for the exact Newton matrix of the midpoint rule (else central differences
        of ``gradV``). The trapezoidal rule never needs it.
    h : float
        Step size (non-zero; negative integrates backwards).
    quadrature : {"trapezoidal", "midpoint"}

    Returns
    -------
    DiscreteLagrangian
        With exact ``D1``, ``D2``, ``D1_q1`` and ``Ld``; the trapezoidal rule also has a
        closed-form ``explicit_step`` and, for a :class:`KeplerPotential`, a compiled kernel.

    Notes
    -----
    With ``v = (q1 - q0)/h``:

    trapezoidal (Stormer-Verlet, explicit)
        ``L_d = h [1/2 v^T M v - (V(q0) + V(q1))/2]``,
        ``D1 = -M v - h/2 grad V(q0)``, ``D2 = M v - h/2 grad V(q1)``, ``D1_q1 = -M/h``, so
        ``p_k = -D1`` gives ``q_{k+1} = q_k + h M^{-1} (p_k - h/2 grad V(q_k))`` in closed form.
    midpoint (implicit)
        ``L_d = h [1/2 v^T M v - V((q0 + q1)/2)]``,
        ``D1 = -M v - h/2 grad V(m)``, ``D2 = M v - h/2 grad V(m)`` with ``m = (q0 + q1)/2``,
        ``D1_q1 = -M/h - h/4 hess V(m)``; the resulting map is the implicit midpoint rule.

    Both are symmetric and second order; both preserve any momentum of a symmetry of ``V``
    that is linear in ``q`` and respected by ``M`` (e.g. angular momentum for a central
    potential and ``M = m I``).
    """
    Mm = _mass_matrix(M)
    n = Mm.shape[0]
    Minv = np.linalg.inv(Mm)
    _check_callable(V, "V")
    builtin = isinstance(V, KeplerPotential)
    if gradV is None:
        if not builtin:
            raise ValueError("gradV must be given (the gradient of V); only a KeplerPotential V provides its own")
        gradV = V.gradient
    _check_callable(gradV, "gradV")
    if hessV is None and builtin:
        hessV = V.hessian
    _check_callable(hessV, "hessV", optional=True)
    h = as_float(h, "h", nonzero=True)
    choice(quadrature, "quadrature", QUADRATURES)

    def grad(q: np.ndarray) -> np.ndarray:
        return np.asarray(gradV(q), dtype=np.float64)

    def kinetic(q0: np.ndarray, q1: np.ndarray) -> float:
        v = (q1 - q0) / h
        return 0.5 * float(v @ Mm @ v)

    def initial_guess(q0: np.ndarray, p0: np.ndarray) -> np.ndarray:
        return q0 + h * (Minv @ (p0 - 0.5 * h * grad(q0)))

    if quadrature == "trapezoidal":
        def Ld(q0, q1):
            return h * (kinetic(q0, q1) - 0.5 * (float(V(q0)) + float(V(q1))))

        def D1(q0, q1):
            return -(Mm @ (q1 - q0)) / h - 0.5 * h * grad(q0)

        def D2(q0, q1):
            return (Mm @ (q1 - q0)) / h - 0.5 * h * grad(q1)

        D1_q1_matrix = -Mm / h

        def D1_q1(q0, q1):
            return D1_q1_matrix.copy()

        def explicit_step(q0, p0):
            p_half = p0 - 0.5 * h * grad(q0)
            q1 = q0 + h * (Minv @ p_half)
            return q1, p_half - 0.5 * h * grad(q1)
    else:
        def Ld(q0, q1):
            return h * (kinetic(q0, q1) - float(V(0.5 * (q0 + q1))))

        def D1(q0, q1):
            return -(Mm @ (q1 - q0)) / h - 0.5 * h * grad(0.5 * (q0 + q1))

        def D2(q0, q1):
            return (Mm @ (q1 - q0)) / h - 0.5 * h * grad(0.5 * (q0 + q1))

        def D1_q1(q0, q1):
            m = 0.5 * (q0 + q1)
            H = np.asarray(hessV(m), dtype=np.float64) if hessV is not None else numerical_jacobian(grad, m)
            return -Mm / h - 0.25 * h * H

        explicit_step = None

    name = f"{'kepler' if builtin else 'mechanical'}/{quadrature}"
    out = DiscreteLagrangian(D1, D2, D1_q1=D1_q1, Ld=Ld, h=h, explicit_step=explicit_step,
                             initial_guess=initial_guess, name=name)
    if builtin and quadrature == "trapezoidal" and gradV == V.gradient:
        object.__setattr__(out, "_compiled", ("kepler_verlet", Mm.copy(), Minv.copy(), V.mu))
    return out


@dataclass(frozen=True, eq=False)
class MechanicalSystem:
    """A mechanical system ``L = 1/2 qdot^T M qdot - V(q)`` on ``R^n`` with constant ``M``.

    Attributes
    ----------
    M : (n, n) ndarray
        Mass matrix.
    V, gradV, hessV : callables
        Potential, gradient, Hessian (``hessV`` may be None).
    name : str
    """

    M: np.ndarray
    V: Callable[[np.ndarray], float]
    gradV: Callable[[np.ndarray], np.ndarray]
    hessV: Callable[[np.ndarray], np.ndarray] | None = None
    name: str = "mechanical"

    def __post_init__(self) -> None:
        M = _mass_matrix(self.M)
        M.flags.writeable = False
        object.__setattr__(self, "M", M)
        _check_callable(self.V, "V")
        _check_callable(self.gradV, "gradV")
        _check_callable(self.hessV, "hessV", optional=True)

    @property
    def n(self) -> int:
        """Number of coordinates."""
        return self.M.shape[0]

    def discrete_lagrangian(self, h: float, quadrature: str = "trapezoidal") -> DiscreteLagrangian:
        """:func:`mechanical_lagrangian` of this system with step ``h``."""
        return mechanical_lagrangian(self.M, self.V, self.gradV, self.hessV, h=h, quadrature=quadrature)

    def energy(self, q: Any, p: Any) -> np.ndarray:
        """``H = 1/2 p^T M^{-1} p + V(q)`` for ``q, p`` of shape (..., n); returns (...,)."""
        q = np.asarray(q, dtype=np.float64)
        p = np.asarray(p, dtype=np.float64)
        kin = 0.5 * np.einsum("...i,ij,...j->...", p, np.linalg.inv(self.M), p)
        if isinstance(self.V, KeplerPotential):
            pot = self.V(q)
        else:
            flat = q.reshape(-1, q.shape[-1])
            pot = np.array([float(self.V(x)) for x in flat]).reshape(q.shape[:-1])
        return kin + pot


# ---------------------------------------------------------------------------------------------
# the Kepler problem
# ---------------------------------------------------------------------------------------------
def kepler(mu: float = 1.0, *, dim: int = 2) -> MechanicalSystem:
    """The Kepler problem: unit mass (``M = I``) in ``V(q) = -mu/|q|``.

    Its discrete Lagrangians (``kepler().discrete_lagrangian(h, quadrature)``) use the
    compiled Stormer-Verlet kernel for the trapezoidal rule.

    Parameters
    ----------
    mu : float
        Gravitational parameter (> 0).
    dim : {2, 3}
        Dimension of the configuration space.
    """
    dim = as_int(dim, "dim", minimum=1)
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    pot = KeplerPotential(mu)
    return MechanicalSystem(np.eye(dim), pot, pot.gradient, pot.hessian, name="kepler")


def kepler_initial_state(eccentricity: float, mu: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Periapsis of the orbit with semi-major axis 1: ``q0 = (1-e, 0)``, ``p0 = (0, sqrt(mu (1+e)/(1-e)))``.

    The period is ``2 pi / sqrt(mu)``, the energy ``-mu/2``, the angular momentum
    ``sqrt(mu (1 - e^2))``.
    """
    e = as_float(eccentricity, "eccentricity")
    if not 0.0 <= e < 1.0:
        raise ValueError(f"eccentricity must be in [0, 1) (a bound orbit), got {e}")
    mu = as_float(mu, "mu", positive=True)
    return np.array([1.0 - e, 0.0]), np.array([0.0, np.sqrt(mu * (1.0 + e) / (1.0 - e))])


def kepler_energy(q: Any, p: Any, mu: float = 1.0) -> np.ndarray:
    """``H = |p|^2/2 - mu/|q|`` for ``q, p`` of shape (..., n); returns (...,)."""
    q = np.asarray(q, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    return 0.5 * np.sum(p * p, axis=-1) - mu / np.sqrt(np.sum(q * q, axis=-1))


def kepler_angular_momentum(q: Any, p: Any) -> np.ndarray:
    """``q x p``: shape (...,) in the plane (``q1 p2 - q2 p1``), (..., 3) in space."""
    q = np.asarray(q, dtype=np.float64)
    p = np.asarray(p, dtype=np.float64)
    if q.shape[-1] == 2:
        return q[..., 0] * p[..., 1] - q[..., 1] * p[..., 0]
    if q.shape[-1] == 3:
        return np.cross(q, p)
    raise ValueError(f"q must have 2 or 3 coordinates in its last axis, got shape {q.shape}")


def kepler_rk4(q0: Any, p0: Any, h: float, steps: int, mu: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Classical fixed-step RK4 for ``q' = p, p' = -mu q/|q|^3``: the paper's non-variational contrast.

    Vectorised over leading axes of ``q0``/``p0``; returns ``Q, P`` of shape ``(steps + 1,) + q0.shape``.
    A NumPy loop: a baseline for short comparisons, not a production integrator.
    """

    def acc(q):
        r2 = np.einsum("...i,...i->...", q, q)[..., None]
        return (-mu / (r2 * np.sqrt(r2))) * q

    q = np.array(q0, dtype=float)
    p = np.array(p0, dtype=float)
    Q = np.empty((steps + 1,) + q.shape)
    P = np.empty_like(Q)
    Q[0], P[0] = q, p
    for k in range(steps):
        a1 = acc(q)
        q2, p2 = q + 0.5 * h * p, p + 0.5 * h * a1
        a2 = acc(q2)
        q3, p3 = q + 0.5 * h * p2, p + 0.5 * h * a2
        a3 = acc(q3)
        q4, p4 = q + h * p3, p + h * a3
        a4 = acc(q4)
        q = q + h / 6 * (p + 2 * p2 + 2 * p3 + p4)
        p = p + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        Q[k + 1], P[k + 1] = q, p
    return Q, P
