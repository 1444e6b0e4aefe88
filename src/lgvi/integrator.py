"""Simulation of the attitude LGVI (paper, section 3): :func:`simulate` and :func:`step`.

The Python layer here validates inputs once, picks a compiled kernel and wraps the result. Every
per-step loop runs in :mod:`lgvi._kernels.stepping`; only a user's Python torque callable is
called from Python, once per step, around the compiled single-step kernel.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from . import so3
from ._kernels.solvers import OK, initial_guess
from ._kernels.stepping import lgvi_step, run_chunk
from ._validation import as_float, as_float_array, as_int, as_rotation, choice
from ._version import __version__
from .body import RigidBody
from .errors import ConvergenceError, SimulationInterrupted, TorqueError
from .implicit import METHODS, failure_message
from .trajectory import Trajectory

#: Steps per compiled call; between chunks Ctrl-C is honoured and progress reported.
CHUNK_STEPS = 1 << 18

TorqueCallable = Callable[[float, np.ndarray, np.ndarray], Any]

_NO_HIST = np.zeros(0)


def _solver_state(code: int, body: RigidBody, h: float, Pi: np.ndarray) -> np.ndarray:
    """Solver history ``G`` (4,3) of the stepping kernels, cold-started from the linearisation."""
    G = np.zeros((4, 3))
    initial_guess(code, body.J, h * Pi, G[0])
    return G


@dataclass(frozen=True)
class StepResult:
    """Result of :func:`step`: the next state and the solve that produced it."""

    R: np.ndarray
    Pi: np.ndarray
    F: np.ndarray
    iterations: int
    residual: float


def as_body(body: Any) -> RigidBody:
    return body if isinstance(body, RigidBody) else RigidBody(body)


def _options(method: str, tol: Any, max_iter: Any, alpha: Any) -> tuple[int, float, int, float]:
    choice(method, "method", METHODS)
    tol = as_float(tol, "tol")
    if tol < 0:
        raise ValueError(f"tol must be >= 0, got {tol}")
    max_iter = as_int(max_iter, "max_iter", minimum=1)
    alpha = as_float(alpha, "alpha")
    if not 0.0 < alpha <= 1.0:
        raise ValueError(f"alpha must be in (0, 1], got {alpha}")
    return METHODS[method], tol, max_iter, alpha


def _initial_momentum(body: RigidBody, Pi0: Any, omega0: Any) -> np.ndarray:
    if Pi0 is None and omega0 is None:
        raise ValueError("give the initial body angular momentum Pi0 (3,) or the angular velocity omega0 (3,)")
    if Pi0 is not None and omega0 is not None:
        raise ValueError("give either Pi0 or omega0, not both")
    if Pi0 is not None:
        return as_float_array(Pi0, "Pi0", (3,)).copy()
    return body.J @ as_float_array(omega0, "omega0", (3,))


def _check_torque_value(u: Any, k: int, t: float) -> np.ndarray:
    try:
        arr = np.asarray(u, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TorqueError(f"torque(t, R, Pi) must return 3 real numbers; at step {k} (t = {t:g}) it "
                          f"returned {u!r}", step=k, time=t) from exc
    if arr.shape != (3,):
        raise TorqueError(f"torque(t, R, Pi) must return shape (3,); at step {k} (t = {t:g}) it returned "
                          f"shape {arr.shape}", step=k, time=t)
    if not (np.isfinite(arr[0]) and np.isfinite(arr[1]) and np.isfinite(arr[2])):
        raise TorqueError(f"torque(t, R, Pi) must return finite values; at step {k} (t = {t:g}) it returned "
                          f"{arr}", step=k, time=t)
    return arr


def step(body: Any, R: Any, Pi: Any, *, h: float, u: Any = None, method: str = "newton",
         tol: float = 1e-14, max_iter: int = 50, alpha: float = 1.0, guess: Any = None) -> StepResult:
    """Take one step of the attitude LGVI.

    Parameters
    ----------
    body : RigidBody or array_like
        The body (or its inertia, ``(3,)`` or ``(3, 3)``).
    R : (3, 3) array_like
        Attitude ``R_k``.
    Pi : (3,) array_like
        Body angular momentum ``Pi_k``.
    h : float
        Step size (non-zero; negative steps go backwards).
    u : (3,) array_like, optional
        Body-frame moment ``u_k`` (default zero).
    method, tol, max_iter, alpha
        As in :func:`lgvi.solve_implicit`.
    guess : (3,) array_like, optional
        Initial solver coordinates (default: the linearisation).

    Returns
    -------
    StepResult
        ``R`` = ``R_k F_k``, ``Pi`` = ``F_k^T Pi_k + h u_k``, the ``F``, iterations and residual.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> s = lgvi.step(lgvi.RigidBody([1., 2., 3.]), np.eye(3), [0.1, 1.0, 0.2], h=0.01)
    >>> bool(np.isclose(np.linalg.norm(s.Pi), np.linalg.norm([0.1, 1.0, 0.2]), rtol=1e-14))
    True
    """
    body = as_body(body)
    code, tol, max_iter, alpha = _options(method, tol, max_iter, alpha)
    R = as_rotation(R, "R")
    Pi = as_float_array(Pi, "Pi", (3,))
    h = as_float(h, "h", nonzero=True)
    uu = np.zeros(3) if u is None else as_float_array(u, "u", (3,))
    G = _solver_state(code, body, h, Pi)
    if guess is not None:
        G[0] = as_float_array(guess, "guess", (3,))
    Rn = R.copy()
    Pin = Pi.copy()
    its, res, st = lgvi_step(code, body.Jd, h, Rn, Pin, G, uu[0], uu[1], uu[2], tol, max_iter, alpha, _NO_HIST)
    if st != OK:
        raise ConvergenceError(failure_message(st, res, its, abs(h) * float(np.linalg.norm(Pi)), tol),
                               residual=float(res), iterations=int(its))
    F = so3.cayley(G[0]) if code == METHODS["cayley"] else so3.exp(G[0])
    return StepResult(R=Rn, Pi=Pin, F=F, iterations=int(its), residual=float(res))


def simulate(body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: float, steps: int,
             torque: Any = None, method: str = "newton", tol: float = 1e-14, max_iter: int = 50,
             alpha: float = 1.0, save_every: int = 1, t0: float = 0.0) -> Trajectory:
    r"""Simulate the attitude of a rigid body with the Lie group variational integrator.

    Each step solves ``hat(h Pi_k) = F_k Jd - Jd F_k^T`` for ``F_k`` in SO(3), then sets
    ``R_{k+1} = R_k F_k`` and ``Pi_{k+1} = F_k^T Pi_k + h u_k`` (the paper's equations).

    Parameters
    ----------
    body : RigidBody or array_like
        The body, or its inertia: ``(3,)`` principal moments or ``(3, 3)`` matrix.
    R0 : (3, 3) array_like or scipy.spatial.transform.Rotation
        Initial attitude (body to inertial), a rotation to 1e-9.
    Pi0 : (3,) array_like, optional
        Initial body angular momentum. Give this or ``omega0``.
    omega0 : (3,) array_like, optional
        Initial body angular velocity (``Pi0 = J omega0``).
    h : float
        Step size, non-zero; ``h < 0`` integrates backwards in time.
    steps : int
        Number of steps, ``>= 0``.
    torque : None, (steps, 3) array_like, or callable
        Body-frame moments: ``None`` for the free body; an array of ``u_k``; or a callable
        ``torque(t, R, Pi) -> (3,)`` evaluated at ``(t_k, R_k, Pi_k)`` (called once per step from
        Python: slower than the array path).
    method : {"newton", "paper", "cayley"}
        Solver of the implicit equation, see :func:`lgvi.solve_implicit`.
    tol, max_iter, alpha
        Solver options, see :func:`lgvi.solve_implicit`.
    save_every : int
        Keep every ``save_every``-th state; must divide ``steps`` so the final state is kept.
    t0 : float
        Initial time.

    Returns
    -------
    Trajectory
        ``M = steps // save_every + 1`` samples; ``iterations`` and ``residual`` for every step.

    Raises
    ------
    ValueError, TypeError
        Invalid input (the message names the argument and the rule).
    ConvergenceError
        A step's implicit equation could not be solved; ``err.trajectory`` holds the run up to
        that step and ``err.step``/``err.time`` say where.
    TorqueError
        The torque callable raised or returned a bad value; ``err.trajectory`` as above.
    SimulationInterrupted
        Ctrl-C during the run (a ``KeyboardInterrupt``); ``err.trajectory`` holds the part computed.

    Notes
    -----
    The solver of each step starts from the previous step's solution (warm start). The free body
    conserves the spatial momentum ``R Pi``, ``|Pi|`` and the kinetic energy to round-off.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> body = lgvi.RigidBody([1.0, 2.0, 3.0])
    >>> traj = lgvi.simulate(body, np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=1000)
    >>> traj.R.shape, traj.Pi.shape
    ((1001, 3, 3), (1001, 3))
    >>> drift = np.abs(traj.energy - traj.energy[0]).max() / traj.energy[0]
    >>> bool(drift < 1e-13)
    True
    """
    body = as_body(body)
    code, tol, max_iter, alpha = _options(method, tol, max_iter, alpha)
    R = as_rotation(R0, "R0").copy()
    Pi = _initial_momentum(body, Pi0, omega0)
    h = as_float(h, "h", nonzero=True)
    t0 = as_float(t0, "t0")
    steps = as_int(steps, "steps", minimum=0)
    save_every = as_int(save_every, "save_every", minimum=1)
    if steps % save_every != 0:
        raise ValueError(f"save_every must divide steps so that the final state is saved; got "
                         f"steps={steps}, save_every={save_every} (steps % save_every = {steps % save_every})")
    U = np.zeros((0, 3))
    func = None
    if torque is None:
        kind = "none"
    elif callable(torque):
        func, kind = torque, "callable"
    else:
        U = as_float_array(torque, "torque", (steps, 3))
        U = np.ascontiguousarray(U)
        kind = "array"

    M = steps // save_every + 1
    R_out = np.empty((M, 3, 3))
    Pi_out = np.empty((M, 3))
    R_out[0] = R
    Pi_out[0] = Pi
    it_out = np.zeros(steps, dtype=np.int32)
    res_out = np.zeros(steps)
    G = _solver_state(code, body, h, Pi)
    meta = {"method": method, "tol": tol, "max_iter": max_iter, "alpha": alpha, "save_every": save_every,
            "torque": kind, "forcing": "paper", "lgvi_version": __version__, "t0": t0}

    def partial(k_done: int) -> Trajectory:
        m = k_done // save_every + 1
        return Trajectory(t=t0 + h * save_every * np.arange(m), R=R_out[:m].copy(), Pi=Pi_out[:m].copy(),
                          inertia=body.J.copy(), iterations=it_out[:k_done].copy(),
                          residual=res_out[:k_done].copy(), h=h, meta=dict(meta, partial=True))

    k = 0
    status = OK
    try:
        if func is None:
            while k < steps:
                n = min(CHUNK_STEPS, steps - k)
                status, k = run_chunk(code, body.Jd, h, R, Pi, G, U, k, n, tol, max_iter, alpha,
                                      save_every, R_out, Pi_out, it_out, res_out, _NO_HIST)
                if status != OK:
                    break
        else:
            status, k = _run_callable(func, code, body, h, R, Pi, G, t0, steps, tol, max_iter, alpha,
                                      save_every, R_out, Pi_out, it_out, res_out, partial)
    except KeyboardInterrupt:
        raise SimulationInterrupted(f"simulation interrupted after {k} of {steps} steps; "
                                    "the computed part is in .trajectory", trajectory=partial(k)) from None
    if status != OK:
        t_fail = t0 + k * h
        hnorm = abs(h) * float(np.linalg.norm(Pi))
        msg = (f"step {k} (t = {t_fail:g}) failed: "
               + failure_message(status, float(res_out[k]), int(it_out[k]), hnorm, tol)
               + f" The run up to step {k} is in .trajectory.")
        # the saved samples stop at the last multiple of save_every; keep the failing state too
        raise ConvergenceError(msg, residual=float(res_out[k]), iterations=int(it_out[k]), step=k, time=t_fail,
                               trajectory=partial(k))
    return Trajectory(t=t0 + h * save_every * np.arange(M), R=R_out, Pi=Pi_out, inertia=body.J.copy(),
                      iterations=it_out, residual=res_out, h=h, meta=meta)


def _run_callable(func, code, body, h, R, Pi, G, t0, steps, tol, max_iter, alpha, save_every,
                  R_out, Pi_out, it_out, res_out, partial):
    """Per-step loop for a Python torque callable: Python calls ``func`` and one compiled step."""
    Jd = body.Jd
    for k in range(steps):
        t = t0 + k * h
        try:
            u = func(t, R.copy(), Pi.copy())
        except (KeyboardInterrupt, TorqueError):
            raise
        except Exception as exc:
            raise TorqueError(f"the torque callable raised {type(exc).__name__} at step {k} (t = {t:g}): {exc}. "
                              f"The run up to step {k} is in .trajectory.", step=k, time=t,
                              trajectory=partial(k)) from exc
        try:
            u = _check_torque_value(u, k, t)
        except TorqueError as exc:
            exc.trajectory = partial(k)
            raise
        its, res, st = lgvi_step(code, Jd, h, R, Pi, G, u[0], u[1], u[2], tol, max_iter, alpha, _NO_HIST)
        it_out[k] = its
        res_out[k] = res
        if st != OK:
            return st, k
        if (k + 1) % save_every == 0:
            j = (k + 1) // save_every
            R_out[j] = R
            Pi_out[j] = Pi
    return OK, steps


__all__ = ["StepResult", "simulate", "step"]
