"""Simulation of the attitude LGVI (paper, section 3): :func:`simulate` and :func:`step`.

The Python layer here validates inputs once, picks a compiled kernel and wraps the result. Every
per-step loop runs in :mod:`lgvi._kernels.stepping`; only a user's Python torque callable is
called from Python, once per step (per substep), around a compiled single-step kernel.

Schemes (see :func:`simulate`):

* the paper's step, ``Pi_{k+1} = F^T Pi_k + h u_k`` (``forcing="paper"``, first order in ``u``);
* the symmetric step of Lee, Leok and McClamroch, used for every potential (torque models with
  ``conservative=True``) and, with ``forcing="symmetric"``, for every other moment too
  (second order);
* symmetric compositions of the symmetric step (``order=4``, ``order=6``), see
  :data:`COMPOSITIONS`.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from . import so3
from ._kernels.solvers import EPS, OK, initial_guess
from ._kernels.stepping import lgvi_step, run_chunk, run_chunk_forced, shifted_step
from ._kernels.torque_kernels import momentum_diag
from ._validation import as_float, as_float_array, as_int, as_rotation, choice
from ._version import __version__
from .body import RigidBody
from .errors import ConvergenceError, SimulationInterrupted, TorqueError
from .implicit import METHODS, failure_message
from .torques import TorqueModel
from .trajectory import Trajectory

#: Steps per compiled call; between chunks Ctrl-C is honoured and progress reported.
CHUNK_STEPS = 1 << 18

TorqueCallable = Callable[[float, np.ndarray, np.ndarray], Any]

_NO_HIST = np.zeros(0)
_NO_CODES = np.zeros((0, 2), dtype=np.int64)

FORCINGS = ("paper", "symmetric")


@dataclass(frozen=True)
class Composition:
    """A symmetric composition ``Phi_{g_s h} o ... o Phi_{g_1 h}`` of the symmetric step.

    Composing a symmetric method of order 2 with coefficients ``g`` that are symmetric
    (``g_i = g_{s+1-i}``), sum to 1 and satisfy the order conditions gives a symmetric method of
    the stated order (Hairer, Lubich and Wanner, *Geometric Numerical Integration*, 2nd ed.,
    Section V.3).
    """

    name: str
    order: int
    coefficients: tuple[float, ...]
    source: str

    @property
    def stages(self) -> int:
        return len(self.coefficients)


def _symmetric(half: list[float]) -> tuple[float, ...]:
    """``half + [middle] + reversed(half)`` with the middle fixing the sum to 1."""
    middle = 1.0 - 2.0 * sum(half)
    return tuple(half) + (middle,) + tuple(reversed(half))


def _triple_jump(base: tuple[float, ...], p: int) -> tuple[float, ...]:
    """Yoshida's triple jump raising a symmetric method of order ``p`` to ``p + 2``."""
    g1 = 1.0 / (2.0 - 2.0 ** (1.0 / (p + 1)))
    g0 = 1.0 - 2.0 * g1                         # = -2^(1/(p+1)) / (2 - 2^(1/(p+1)))
    return tuple(g1 * c for c in base) + tuple(g0 * c for c in base) + tuple(g1 * c for c in base)


_SUZUKI = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))

#: Registry of compositions by name (``simulate(..., composition=name)``).
COMPOSITIONS: dict[str, Composition] = {
    c.name: c for c in (
        Composition("yoshida4", 4, _triple_jump((1.0,), 2),
                    "Yoshida (1990), Phys. Lett. A 150, 262: triple jump, "
                    "g1 = g3 = 1/(2 - 2^(1/3)), g2 = 1 - 2 g1"),
        Composition("suzuki4", 4, _symmetric([_SUZUKI, _SUZUKI]),
                    "Suzuki (1990), Phys. Lett. A 146, 319: fractal 5-stage, "
                    "g1 = g2 = g4 = g5 = 1/(4 - 4^(1/3)), g3 = 1 - 4 g1"),
        Composition("yoshida6", 6, _triple_jump(_triple_jump((1.0,), 2), 4),
                    "Yoshida (1990): triple jump of the triple jump, 9 stages"),
        Composition("kahan-li6", 6, _symmetric([0.39216144400731413927925056, 0.33259913678935943859974864,
                                                 -0.70624617255763935980996482, 0.08221359629355080023149045]),
                    "Kahan and Li (1997), Math. Comp. 66, 1089, scheme s9odr6a, as printed in "
                    "Hairer, Lubich and Wanner, Geometric Numerical Integration, Sect. V.3.2"),
    )
}

#: Composition used by ``order=4`` and ``order=6`` unless ``composition=`` names another.
DEFAULT_COMPOSITION = {4: "suzuki4", 6: "kahan-li6"}


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
             alpha: float = 1.0, save_every: int = 1, t0: float = 0.0, forcing: str = "paper",
             order: int = 2, composition: str | None = None) -> Trajectory:
    r"""Simulate the attitude of a rigid body with the Lie group variational integrator.

    Each step solves ``hat(h Pi_k) = F_k Jd - Jd F_k^T`` for ``F_k`` in SO(3), then sets
    ``R_{k+1} = R_k F_k`` and ``Pi_{k+1} = F_k^T Pi_k + h u_k`` (the paper's equations).
    Potentials and ``forcing="symmetric"`` use the symmetric form below; ``order`` composes it.

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
    torque : None, array_like, callable, or lgvi.torques.TorqueModel
        Body-frame moments:

        * ``None``: the free body;
        * an array of moments at the grid times: ``(steps, 3)`` values ``u_k`` for
          ``forcing="paper"``; ``(steps + 1, 3)`` values ``u_0 .. u_steps`` for
          ``forcing="symmetric"``, which uses the moment at both ends of each step;
        * a callable ``torque(t, R, Pi) -> (3,)``, called from Python: once per step at
          ``(t_k, R_k, Pi_k)`` with ``forcing="paper"``; with ``forcing="symmetric"`` at the end
          point of every (sub)step, at least twice per step (the momentum equation is solved by
          fixed-point iteration, so ``Pi``-dependent torques work);
        * a torque model from :mod:`lgvi.torques` (or a sum of them), evaluated in compiled code.
          Its conservative part always uses the symmetric (variational) scheme, the rest follows
          ``forcing``; its potential is reported in :attr:`Trajectory.potential`.
    method : {"newton", "paper", "cayley"}
        Solver of the implicit equation, see :func:`lgvi.solve_implicit`.
    tol, max_iter, alpha
        Solver options, see :func:`lgvi.solve_implicit`. ``tol`` and ``max_iter`` also bound the
        fixed-point iteration of a callable's momentum equation with symmetric forcing.
    save_every : int
        Keep every ``save_every``-th state; must divide ``steps`` so the final state is kept.
    t0 : float
        Initial time.
    forcing : {"paper", "symmetric"}
        Treatment of moments that do not come from a potential: ``"paper"`` (default) the
        paper's first-order update ``Pi_{k+1} = F_k^T Pi_k + h u_k``; ``"symmetric"`` the
        second-order symmetric update (see Notes).
    order : {2, 4, 6}
        Order of the scheme: 2 is the (symmetric) LGVI; 4 and 6 compose it symmetrically
        (:data:`COMPOSITIONS`), costing 5 and 9 solves per step with the defaults. Requires a
        symmetric base step: the free body, torque models whose non-conservative part (if any)
        uses ``forcing="symmetric"``, or callables with ``forcing="symmetric"``. Torque arrays
        cannot be composed (they hold no values between grid points).
    composition : str, optional
        Name in :data:`COMPOSITIONS` (``"suzuki4"``, ``"yoshida4"``, ``"kahan-li6"``,
        ``"yoshida6"``); its order must equal ``order``. Default :data:`DEFAULT_COMPOSITION`.

    Returns
    -------
    Trajectory
        ``M = steps // save_every + 1`` samples; ``iterations`` (summed over substeps) and
        ``residual`` (largest over substeps) for every step; ``potential`` for torque models
        with a conservative part.

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

    The symmetric step (Lee, Leok and McClamroch's LGVI when ``M`` comes from a potential) is

    .. math::

        \widehat{h \Pi_k + \tfrac{h^2}{2} M_k} = F_k J_d - J_d F_k^T, \quad
        R_{k+1} = R_k F_k, \quad
        \Pi_{k+1} = F_k^T \Pi_k + \tfrac{h}{2} F_k^T M_k + \tfrac{h}{2} M_{k+1},

    with ``M_k = M(t_k, R_k, Pi_k)``. When ``M`` depends on ``Pi`` the last equation is implicit;
    for the built-in models it is linear in ``Pi_{k+1}`` and solved exactly. The step is
    symmetric (``h -> -h`` retraces it) for any smooth ``M(t, R, Pi)``, which is what the
    compositions of ``order=4, 6`` need; the paper's forcing is not symmetric.

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

    A heavy top, with its energy (kinetic plus potential):

    >>> from lgvi.torques import UniformGravity
    >>> top = lgvi.RigidBody([0.13, 0.28, 0.17])
    >>> traj = lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=1000,
    ...                      torque=UniformGravity(1.0, [0.0, 0.0, 0.3]))
    >>> bool(np.abs(traj.energy - traj.energy[0]).max() < 1e-2 * traj.energy[0])
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
    choice(forcing, "forcing", FORCINGS)
    comp = _composition(order, composition)
    sym = forcing == "symmetric"
    U = np.zeros((0, 3))
    func = None
    model = None
    if torque is None:
        kind = "none"
    elif isinstance(torque, TorqueModel):
        model, kind = torque, "model"
    elif callable(torque):
        func, kind = torque, "callable"
    else:
        kind = "array"
        if sym:
            U = as_float_array(torque, "torque", (steps + 1, 3))
        else:
            U = as_float_array(torque, "torque", (steps, 3))
        U = np.ascontiguousarray(U)
    _check_order(comp, kind, forcing, model)

    M = steps // save_every + 1
    R_out = np.empty((M, 3, 3))
    Pi_out = np.empty((M, 3))
    R_out[0] = R
    Pi_out[0] = Pi
    it_out = np.zeros(steps, dtype=np.int32)
    res_out = np.zeros(steps)
    meta = {"method": method, "tol": tol, "max_iter": max_iter, "alpha": alpha, "save_every": save_every,
            "torque": kind, "forcing": forcing, "lgvi_version": __version__, "t0": t0, "order": comp.order}
    if comp.order != 2:
        meta["composition"] = comp.name
    if model is not None:
        meta["torque_model"] = repr(model)
    has_potential = model is not None and any(m.conservative for m in model.terms)

    def potential(t: np.ndarray, R_saved: np.ndarray) -> np.ndarray | None:
        return model.potential(t, R_saved, body) if has_potential else None

    def partial(k_done: int) -> Trajectory:
        m = k_done // save_every + 1
        t = t0 + h * save_every * np.arange(m)
        return Trajectory(t=t, R=R_out[:m].copy(), Pi=Pi_out[:m].copy(),
                          inertia=body.J.copy(), iterations=it_out[:k_done].copy(),
                          residual=res_out[:k_done].copy(), h=h, potential=potential(t, R_out[:m]),
                          meta=dict(meta, partial=True))

    # the paper's scheme (and the free body at order 2) keeps the original kernels, bit for bit
    legacy = comp.order == 2 and (kind == "none" or (kind in ("array", "callable") and not sym))
    k = 0
    status = OK
    try:
        if legacy:
            G = _solver_state(code, body, h, Pi)
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
        else:
            gam = np.array(comp.coefficients)
            cum = np.concatenate([[0.0], np.cumsum(gam)])
            cum[-1] = 1.0
            G = np.stack([_solver_state(code, body, g * h, Pi) for g in gam])
            if func is None:
                codes, params = model.encode() if model is not None else (_NO_CODES, np.zeros(0))
                A = _momentum_matrices(body, codes, params, gam * h, sym)
                S = np.zeros(7)
                gidx = np.arange(len(gam), dtype=np.int64)
                while k < steps:
                    n = min(CHUNK_STEPS, steps - k)
                    status, k = run_chunk_forced(code, body.Jd, body.J, body.J_inv, h, t0, gam, cum, A, R, Pi, G,
                                                 gidx, S, codes, params, U, int(sym), k, n, tol, max_iter, alpha,
                                                 save_every, R_out, Pi_out, it_out, res_out, _NO_HIST)
                    if status != OK:
                        break
            else:
                status, k = _run_callable_symmetric(func, code, body, h, gam, cum, R, Pi, G, t0, steps, tol,
                                                    max_iter, alpha, save_every, R_out, Pi_out, it_out,
                                                    res_out, partial)
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
    t = t0 + h * save_every * np.arange(M)
    return Trajectory(t=t, R=R_out, Pi=Pi_out, inertia=body.J.copy(), iterations=it_out, residual=res_out,
                      h=h, potential=potential(t, R_out), meta=meta)


def _composition(order: Any, composition: Any) -> Composition:
    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)) or order not in (2, 4, 6):
        raise ValueError(f"order must be 2, 4 or 6, got {order!r}")
    order = int(order)
    if composition is None:
        if order == 2:
            return _SECOND_ORDER
        return COMPOSITIONS[DEFAULT_COMPOSITION[order]]
    choice(composition, "composition", tuple(COMPOSITIONS))
    comp = COMPOSITIONS[composition]
    if comp.order != order:
        raise ValueError(f"composition {composition!r} is of order {comp.order}, but order={order}; "
                         f"pass order={comp.order} with it")
    return comp


_SECOND_ORDER = Composition("none", 2, (1.0,), "the symmetric LGVI step itself")


def _check_order(comp: Composition, kind: str, forcing: str, model: TorqueModel | None) -> None:
    """Reject compositions whose base step is not symmetric (they would not raise the order)."""
    if comp.order == 2:
        return
    why = (f"order={comp.order} composes the symmetric step, and composition raises the order only of "
           f"a symmetric method")
    if kind == "array":
        raise ValueError(f"{why}; a torque array holds moments at the grid times only, but the substeps of "
                         f"order={comp.order} need them at intermediate times (some substeps even step "
                         "backwards). Pass a callable torque(t, R, Pi) or a torque model instead.")
    if forcing == "paper":
        if kind == "callable":
            raise ValueError(f"{why}; the paper's update Pi_(k+1) = F^T Pi_k + h u_k is first order and "
                             "not symmetric. Pass forcing='symmetric' to compose the callable torque.")
        if model is not None and not all(m.conservative for m in model.terms):
            bad = ", ".join(repr(m) for m in model.terms if not m.conservative)
            raise ValueError(f"{why}; the non-conservative part of the torque model ({bad}) uses the "
                             "paper's first-order update Pi_(k+1) = F^T Pi_k + h u_k, which is not symmetric. "
                             "Pass forcing='symmetric'.")


def _momentum_matrices(body: RigidBody, codes: np.ndarray, params: np.ndarray, hs: np.ndarray,
                       sym: bool) -> np.ndarray:
    """``(I + hs/2 D J^-1)^-1`` per substep: the symmetric momentum equation of damped models."""
    D = np.array(momentum_diag(codes, params))
    A = np.tile(np.eye(3), (len(hs), 1, 1))
    if not sym or not np.any(D):
        return A
    for i, hi in enumerate(hs):
        Mi = np.eye(3) + 0.5 * hi * (D[:, None] * body.J_inv)
        # D J^-1 has real eigenvalues >= 0; a backward (sub)step can make Mi singular
        lam = np.linalg.eigvals(Mi).real.min()
        if not lam > 1e-6:
            raise ValueError(f"the step h={hi:g} (substep {i}) is too large a backward step for "
                             f"the damping of the torque model: I + h/2 D J^-1 is (nearly) singular "
                             f"(smallest eigenvalue {lam:.3g}) in the symmetric momentum equation; "
                             "reduce |h|")
        A[i] = np.linalg.inv(Mi)
    return A


def _call_torque(func, t, R, Pi, k, partial):
    try:
        u = func(t, R.copy(), Pi.copy())
    except (KeyboardInterrupt, TorqueError):
        raise
    except Exception as exc:
        raise TorqueError(f"the torque callable raised {type(exc).__name__} at step {k} (t = {t:g}): {exc}. "
                          f"The run up to step {k} is in .trajectory.", step=k, time=t,
                          trajectory=partial(k)) from exc
    try:
        return _check_torque_value(u, k, t)
    except TorqueError as exc:
        exc.trajectory = partial(k)
        raise


def _run_callable_symmetric(func, code, body, h, gam, cum, R, Pi, G, t0, steps, tol, max_iter, alpha,
                            save_every, R_out, Pi_out, it_out, res_out, partial):
    """Symmetric forcing (and compositions) for a Python torque callable.

    Per substep: the compiled :func:`shifted_step` gives ``R_{k+1}`` and ``a = F^T (Pi_k + hs/2
    M_k)``; then ``Pi = a + hs/2 M(t_{k+1}, R_{k+1}, Pi)`` is solved by fixed-point iteration. The
    accepted ``Pi_{k+1}`` is the last point where ``M`` was evaluated, so ``M_{k+1}`` is exact for
    the next step and the momentum equation holds to ``tol``.
    """
    Jd = body.Jd
    s = len(gam)
    M = None
    for k in range(steps):
        R_start = R.copy()
        Pi_start = Pi.copy()
        its_sum = 0
        rmax = 0.0
        for i in range(s):
            hs = gam[i] * h
            t1 = t0 + (k + cum[i + 1]) * h
            if M is None:
                M = _call_torque(func, t0 + (k + cum[i]) * h, R, Pi, k, partial)
            its, rn, st = shifted_step(code, Jd, body.J_inv, hs, R, Pi, G, i, M[0], M[1], M[2], tol, max_iter, alpha,
                                       _NO_HIST)
            its_sum += its
            rmax = max(rmax, rn)
            if st != OK:
                it_out[k] = its_sum
                res_out[k] = rn
                R[:] = R_start
                Pi[:] = Pi_start
                return st, k
            a = Pi.copy()
            P = a + (0.5 * hs) * M
            for _ in range(max_iter + 1):
                M = _call_torque(func, t1, R, P, k, partial)
                P_next = a + (0.5 * hs) * M
                change = float(np.linalg.norm(P_next - P))
                if change <= tol * float(np.linalg.norm(P_next)) + 4.0 * EPS * (
                        float(np.linalg.norm(a)) + float(np.linalg.norm(0.5 * hs * M))):
                    break
                P = P_next
            else:
                R[:] = R_start
                Pi[:] = Pi_start
                t = t0 + k * h
                raise ConvergenceError(
                    f"step {k} (t = {t:g}): the momentum equation Pi_(k+1) = F^T (Pi_k + h/2 M_k) + h/2 "
                    f"M(t_(k+1), R_(k+1), Pi_(k+1)) of the symmetric forcing did not converge by fixed-point "
                    f"iteration in max_iter={max_iter} evaluations (last change {change:.3g}); the torque "
                    f"callable depends too strongly on Pi for this step: reduce |h|. The run up to step "
                    f"{k} is in .trajectory.", residual=change, iterations=max_iter, step=k, time=t,
                    trajectory=partial(k))
            Pi[:] = P
        it_out[k] = its_sum
        res_out[k] = rmax
        if (k + 1) % save_every == 0:
            j = (k + 1) // save_every
            R_out[j] = R
            Pi_out[j] = Pi
    return OK, steps


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


__all__ = ["COMPOSITIONS", "Composition", "DEFAULT_COMPOSITION", "StepResult", "simulate", "step"]
