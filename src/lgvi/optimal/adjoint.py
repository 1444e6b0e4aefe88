"""Gradients through a discrete LGVI run: the discrete adjoint (reverse mode), compiled.

A run is ``N`` steps of the LGVI with step ``h`` from ``(R_0, Pi_0)`` under an array of controls
``u`` (body-frame moments) and, optionally, the potential moments of the built-in conservative
torque models (:class:`lgvi.torques.UniformGravity`, :class:`lgvi.torques.GravityGradient`). A
cost is a sum of terms (:class:`Effort`, :class:`AttitudeError`, :class:`RateError`,
:class:`Terminal`); :func:`gradient` returns its value and its derivatives with respect to the
controls, the initial attitude (left-trivialised: ``R_0 -> R_0 exp(hat(zeta))``), the initial
momentum, the inertia and the step size, from one forward and one reverse pass. The equations are
in ``docs/optimal.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .. import so3
from .._kernels.codes import OK
from .._validation import as_float, as_float_array, as_int, as_rotation, choice
from ..body import RigidBody
from ..errors import ConvergenceError
from ..torques import TorqueModel
from ..trajectory import Trajectory

__all__ = ["AttitudeError", "Effort", "Gradient", "RateError", "Rollout", "Terminal", "gradient", "rollout"]

#: Kind codes of the conservative models the adjoint differentiates (see torque_kernels).
_POTENTIAL_KINDS = {1: "UniformGravity", 2: "GravityGradient"}
FORCINGS = ("paper", "symmetric")


def as_body(body: Any, name: str = "body") -> RigidBody:
    """A :class:`lgvi.RigidBody` from a body, principal moments (3,) or an inertia (3, 3)."""
    if isinstance(body, RigidBody):
        return body
    try:
        return RigidBody(body)
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"{name}: {exc}") from exc


def potential_encoding(torque: Any, name: str = "torque") -> tuple[np.ndarray, np.ndarray]:
    """``(codes, params)`` of a conservative torque model (or ``None``: empty)."""
    if torque is None:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(1)
    if not isinstance(torque, TorqueModel):
        raise TypeError(f"{name} must be None or a conservative torque model of lgvi.torques (UniformGravity, "
                        f"GravityGradient or their sum), got {type(torque).__name__}; give controls as u")
    try:
        codes, params = torque.encode()
    except Exception as exc:  # a Compiled model has no kernel encoding
        raise TypeError(f"{name}: {type(torque).__name__} cannot be differentiated by the adjoint; use "
                        f"UniformGravity, GravityGradient or their sum") from exc
    bad = [int(c) for c in codes[:, 0] if int(c) not in _POTENTIAL_KINDS]
    if bad:
        raise ValueError(f"{name} must be built from the conservative models UniformGravity and GravityGradient "
                         f"(the adjoint differentiates their potential moments); {torque!r} has kernel kinds {bad}")
    params = np.asarray(params, dtype=np.float64)
    return np.ascontiguousarray(codes, dtype=np.int64), (params if params.size else np.zeros(1))


@dataclass(frozen=True)
class Rollout:
    """A forward run that keeps what the reverse pass needs.

    Attributes
    ----------
    R : (N+1, 3, 3) ndarray
        Attitudes.
    Pi : (N+1, 3) ndarray
        Body momenta.
    F : (N, 3, 3) ndarray
        Relative rotations ``F_k = R_k^T R_{k+1}``.
    P : (N+1, 3) ndarray
        Potential moments at the grid points (zero without a potential).
    u : (N, 3) or (N+1, 3) ndarray
        Controls (paper's forcing: ``N``; symmetric: ``N+1``).
    body, h, t0, forcing, codes, params, iterations, residual
        The run's data and the solver's record (iterations, residual: (N,)).
    """

    R: np.ndarray
    Pi: np.ndarray
    F: np.ndarray
    P: np.ndarray
    u: np.ndarray
    body: RigidBody
    h: float
    t0: float
    forcing: str
    codes: np.ndarray
    params: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    torque: Any = None

    @property
    def steps(self) -> int:
        return self.F.shape[0]

    @property
    def omega(self) -> np.ndarray:
        """(N+1, 3) body angular velocity."""
        return self.Pi @ self.body.J_inv.T

    def trajectory(self) -> Trajectory:
        """The run as a :class:`lgvi.Trajectory` (every step saved)."""
        t = self.t0 + self.h * np.arange(self.steps + 1)
        pot = None
        if self.torque is not None:
            pot = np.asarray(self.torque.potential(t, self.R, self.body), dtype=np.float64)
        its = self.iterations.astype(np.int64)
        meta = {"method": "newton", "forcing": self.forcing, "source": "lgvi.optimal", "solver_record": "full"}
        return Trajectory(t=t, R=self.R.copy(), Pi=self.Pi.copy(), inertia=self.body.J.copy(), iterations=its,
                          residual=self.residual.copy(), h=self.h, potential=pot, meta=meta)


def _kernels():
    from .._kernels import adjoint_kernels

    return adjoint_kernels


def rollout(body: Any, R0: Any, Pi0: Any, h: Any, u: Any, *, forcing: str = "paper", torque: Any = None,
            t0: float = 0.0, tol: float = 1e-15, max_iter: int = 50) -> Rollout:
    """Run the LGVI under the controls ``u`` and keep every state (see :class:`Rollout`).

    Parameters
    ----------
    body : lgvi.RigidBody, (3,) or (3, 3)
        The body.
    R0 : (3, 3) rotation; Pi0 : (3,) body momentum
        Initial state.
    h : float
        Step size (non-zero).
    u : (N, 3) array (``forcing="paper"``) or (N+1, 3) (``"symmetric"``)
        Body-frame controls at the grid points.
    forcing : {"paper", "symmetric"}
        The paper's first-order update ``Pi_{k+1} = F^T Pi_k + h u_k`` or the symmetric one.
    torque : None or conservative lgvi.torques model
        Potential moments (gravity, gravity gradient), always in the symmetric form.
    t0, tol, max_iter
        Start time; the solver's relative tolerance and update limit.

    Raises
    ------
    lgvi.ConvergenceError
        When a step's implicit equation is not solved.
    """
    body = as_body(body)
    forcing = choice(forcing, "forcing", FORCINGS)
    sym = forcing == "symmetric"
    R0 = as_rotation(R0, "R0")
    Pi0 = as_float_array(Pi0, "Pi0", (3,))
    h = as_float(h, "h", nonzero=True)
    t0 = as_float(t0, "t0")
    u = as_float_array(u, "u", (None, 3))
    N = u.shape[0] - 1 if sym else u.shape[0]
    if N < 1:
        raise ValueError(f"u must hold at least {'2 rows (N+1 with the symmetric forcing)' if sym else '1 row'}, "
                         f"got shape {u.shape}")
    codes, params = potential_encoding(torque)
    tol = as_float(tol, "tol", positive=True)
    max_iter = as_int(max_iter, "max_iter", minimum=1)
    R = np.empty((N + 1, 3, 3))
    Pi = np.empty((N + 1, 3))
    F = np.empty((N, 3, 3))
    P = np.empty((N + 1, 3))
    its = np.zeros(N, dtype=np.int64)
    res = np.zeros(N)
    R[0] = R0
    Pi[0] = Pi0
    u = np.ascontiguousarray(u)
    st, k = _kernels().forward_run(body.Jd, body.J, body.J_inv, h, t0, R, Pi, F, P, u, sym, codes, params,
                                   float(tol), int(max_iter), its, res, np.zeros(0))
    if st != OK:
        raise ConvergenceError(f"the implicit equation of step {k} (t = {t0 + k * h:.6g}) was not solved "
                               f"(status {st}, residual {res[k]:.3g} after {its[k]} updates); reduce h = {h:g} "
                               f"or the controls")
    return Rollout(R=R, Pi=Pi, F=F, P=P, u=u, body=body, h=h, t0=t0, forcing=forcing, codes=codes, params=params,
                   iterations=its, residual=res, torque=torque)


# ---------------------------------------------------------------------------------------------- costs
class CostTerm:
    """A term of a cost: its value and partial derivatives on a :class:`Rollout`.

    ``partials(run, dR, dP, du)`` adds the partial derivatives with respect to ``zeta_k``,
    ``Pi_k`` (arrays (N+1, 3); (1, 3), the final step only, unless the class sets
    ``running_state = True``) and the controls (like ``u``) and returns ``(value, dJ, dh)``:
    the value, the direct partial in the inertia (3, 3) symmetric, and in ``h``.
    """

    running_state = False

    def partials(self, run: Rollout, dR: np.ndarray, dP: np.ndarray, du: np.ndarray):  # pragma: no cover
        raise NotImplementedError


def _check_weight(term: Any) -> None:
    w = as_float(term.weight, f"{type(term).__name__}.weight")
    if w < 0.0:
        raise ValueError(f"{type(term).__name__}.weight must be >= 0, got {w}")


def _weights(run: Rollout) -> np.ndarray:
    """Quadrature weights of the controls: 1 each (paper), trapezoidal (symmetric)."""
    w = np.ones(run.u.shape[0])
    if run.forcing == "symmetric":
        w[0] = w[-1] = 0.5
    return w


@dataclass(frozen=True)
class Effort(CostTerm):
    """Control effort ``weight * h * sum_k |u_k|^2`` (trapezoidal weights with symmetric forcing)."""

    weight: float = 1.0

    def __post_init__(self):
        _check_weight(self)

    def partials(self, run, dR, dP, du):
        w = self.weight * _weights(run)
        sq = (run.u * run.u).sum(axis=1)
        du += (2.0 * run.h * w)[:, None] * run.u
        return run.h * float(w @ sq), np.zeros((3, 3)), float(w @ sq)


@dataclass(frozen=True)
class AttitudeError(CostTerm):
    """Final attitude error ``weight/2 |log(Rf^T R_N)|^2`` (``"geodesic"``, the squared angle) or
    ``weight * tr(I - Rf^T R_N)`` (``"chordal"``, ``2 (1 - cos angle)``, smooth everywhere)."""

    target: Any
    weight: float = 1.0
    kind: str = "geodesic"

    def __post_init__(self):
        _check_weight(self)
        as_rotation(self.target, "AttitudeError.target")
        choice(self.kind, "AttitudeError.kind", ("geodesic", "chordal"))

    def partials(self, run, dR, dP, du):
        Rf = as_rotation(self.target, "target")
        A = Rf.T @ run.R[-1]
        if self.kind == "chordal":
            dR[-1] += self.weight * so3.vee(A - A.T)
            return self.weight * float(3.0 - np.trace(A)), np.zeros((3, 3)), 0.0
        phi = so3.log(A)
        dR[-1] += self.weight * phi          # J_r^-T phi = J_l^-1 phi = phi
        return 0.5 * self.weight * float(phi @ phi), np.zeros((3, 3)), 0.0


@dataclass(frozen=True)
class RateError(CostTerm):
    """Final rate error ``weight/2 |J^-1 Pi_N - omega_f|^2``."""

    target: Any = (0.0, 0.0, 0.0)
    weight: float = 1.0

    def __post_init__(self):
        _check_weight(self)
        as_float_array(self.target, "RateError.target", (3,))

    def partials(self, run, dR, dP, du):
        Jinv = run.body.J_inv
        om = Jinv @ run.Pi[-1]
        e = om - as_float_array(self.target, "target", (3,))
        g = self.weight * (Jinv @ e)
        dP[-1] += g
        G = -np.outer(g, om)
        return 0.5 * self.weight * float(e @ e), 0.5 * (G + G.T), 0.0


@dataclass(frozen=True)
class Terminal(CostTerm):
    """A user's terminal cost ``value(R_N, Pi_N)`` with its derivative
    ``derivative(R_N, Pi_N) -> (d/dzeta (3,), d/dPi (3,))`` (left-trivialised in ``R``)."""

    value: Callable[[np.ndarray, np.ndarray], float]
    derivative: Callable[[np.ndarray, np.ndarray], tuple[Any, Any]]

    def __post_init__(self):
        for name in ("value", "derivative"):
            if not callable(getattr(self, name)):
                raise TypeError(f"Terminal.{name} must be callable, got {getattr(self, name)!r}")

    def partials(self, run, dR, dP, du):
        v = as_float(self.value(run.R[-1].copy(), run.Pi[-1].copy()), "Terminal.value(R, Pi)")
        out = self.derivative(run.R[-1].copy(), run.Pi[-1].copy())
        if not isinstance(out, tuple) or len(out) != 2:
            raise TypeError("Terminal.derivative(R, Pi) must return a tuple (d/dzeta (3,), d/dPi (3,))")
        dR[-1] += as_float_array(out[0], "Terminal.derivative(R, Pi)[0]", (3,))
        dP[-1] += as_float_array(out[1], "Terminal.derivative(R, Pi)[1]", (3,))
        return v, np.zeros((3, 3)), 0.0


def as_cost(cost: Any, name: str = "cost") -> tuple[CostTerm, ...]:
    terms = (cost,) if isinstance(cost, CostTerm) else tuple(cost) if isinstance(cost, (list, tuple)) else None
    if not terms or not all(isinstance(c, CostTerm) for c in terms):
        raise TypeError(f"{name} must be a cost term (Effort, AttitudeError, RateError, Terminal) or a list of them, "
                        f"got {cost!r}")
    return terms


@dataclass(frozen=True)
class Gradient:
    """Value and gradient of a cost through a run.

    Attributes
    ----------
    cost : float
    u : (N, 3) or (N+1, 3) ndarray
        Gradient in the controls.
    R0 : (3,) ndarray
        Gradient in the initial attitude, left-trivialised (``R0 -> R0 exp(hat(zeta))``).
    Pi0 : (3,) ndarray
        Gradient in the initial body momentum.
    inertia : (3, 3) ndarray
        Gradient in the inertia, symmetric: ``d cost = <inertia, dJ>`` for symmetric ``dJ``
        (``Pi0`` held fixed).
    h : float
        Derivative in the step size (the grid ``t_k = t0 + k h`` moving with it).
    run : Rollout
        The forward run.
    """

    cost: float
    u: np.ndarray
    R0: np.ndarray
    Pi0: np.ndarray
    inertia: np.ndarray
    h: float
    run: Rollout = field(repr=False)


def reverse(run: Rollout, dR: np.ndarray, dP: np.ndarray, du: np.ndarray):
    """The reverse pass for ``S`` seeds: ``dR``, ``dP`` (S, N+1, 3) or (S, 1, 3) (partials at
    the final step only), ``du`` (S, Nu, 3).

    Returns ``(lam (S, 6), gu (S, Nu, 3), gJ (S, 3, 3), gh (S,))``.
    """
    S = dR.shape[0]
    lam = np.empty((S, 6))
    gu = np.empty_like(du)
    gJ = np.empty((S, 3, 3))
    gh = np.empty(S)
    _kernels().adjoint_run(run.body.Jd, run.h, run.t0, run.body.J, run.R, run.Pi, run.F, run.P, run.u,
                           run.forcing == "symmetric", run.codes, run.params, np.ascontiguousarray(dR),
                           np.ascontiguousarray(dP), np.ascontiguousarray(du), lam, gu, gJ, gh)
    return lam, gu, gJ, gh


def cost_gradient(run: Rollout, cost: Any) -> Gradient:
    """Value and gradient of ``cost`` on an existing :class:`Rollout`."""
    terms = as_cost(cost)
    rows = run.steps + 1 if any(t.running_state for t in terms) else 1
    dR = np.zeros((1, rows, 3))
    dP = np.zeros((1, rows, 3))
    du = np.zeros((1,) + run.u.shape)
    value = 0.0
    gJ_direct = np.zeros((3, 3))
    gh_direct = 0.0
    for term in terms:
        v, gJ, gh = term.partials(run, dR[0], dP[0], du[0])
        value += v
        gJ_direct += gJ
        gh_direct += gh
    lam, gu, gJ, gh = reverse(run, dR, dP, du)
    return Gradient(cost=value, u=gu[0], R0=lam[0, :3].copy(), Pi0=lam[0, 3:].copy(), inertia=gJ[0] + gJ_direct,
                    h=float(gh[0] + gh_direct), run=run)


def gradient(body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: Any, u: Any, cost: Any,
             forcing: str = "paper", torque: Any = None, t0: float = 0.0, tol: float = 1e-15,
             max_iter: int = 50) -> Gradient:
    """Value and gradient of a cost through an LGVI run (one forward, one reverse pass).

    Parameters
    ----------
    body, R0, h, u, forcing, torque, t0, tol, max_iter
        As :func:`rollout`.
    Pi0 : (3,) body momentum, or omega0 : (3,) body rate
        Initial momentum (``Pi0 = J omega0``); the gradient is always in ``Pi0``.
    cost : cost term or list of them
        :class:`Effort`, :class:`AttitudeError`, :class:`RateError`, :class:`Terminal`.

    Returns
    -------
    Gradient

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> from lgvi.optimal import gradient, Effort, AttitudeError
    >>> g = gradient([1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 0.0, 0.0], h=0.1, u=np.zeros((10, 3)),
    ...              cost=[Effort(), AttitudeError(lgvi.so3.exp([0.0, 0.0, 0.5]))])
    >>> g.u.shape
    (10, 3)
    """
    body = as_body(body)
    if Pi0 is None and omega0 is None:
        Pi0 = np.zeros(3)
    elif Pi0 is not None and omega0 is not None:
        raise ValueError("give either Pi0 or omega0, not both")
    elif omega0 is not None:
        Pi0 = body.J @ as_float_array(omega0, "omega0", (3,))
    run = rollout(body, R0, Pi0, h, u, forcing=forcing, torque=torque, t0=t0, tol=tol, max_iter=max_iter)
    return cost_gradient(run, cost)
