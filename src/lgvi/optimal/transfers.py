"""State-to-state transfers on the discrete LGVI: minimum energy and minimum time (direct method).

The controls ``u_k`` (and, for ``cost="time"``, the final time ``T`` with ``h = T / N``) are the
variables of a nonlinear program; the terminal attitude and rate are equality constraints
``vee(log(Rf^T R_N)) = 0`` and ``J^-1 Pi_N - omega_f = 0``; SciPy's SLSQP (or trust-constr, or
IPOPT through CasADi for large ``N``: :mod:`lgvi.optimal._ipopt`) solves it with the cost gradient
and the constraint Jacobian from one reverse pass of the discrete adjoint
(:mod:`lgvi.optimal.adjoint`, seven seeds at once).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .. import so3
from .._validation import as_float, as_float_array, as_int, as_rotation, choice
from ..registry import ForcingName
from ..trajectory import Trajectory
from .adjoint import as_body, potential_encoding, reverse, rollout

__all__ = ["InfeasibleTransferError", "TransferError", "TransferResult", "reachable_angle", "transfer"]

COSTS = ("energy", "time")
METHODS = ("SLSQP", "trust-constr", "indirect", "ipopt")
#: ``cost=`` and ``method=`` of :func:`transfer` as types (``COSTS``, ``METHODS``).
CostName = Literal["energy", "time"]
TransferMethod = Literal["SLSQP", "trust-constr", "indirect", "ipopt"]


@dataclass(frozen=True)
class TransferResult:
    """A transfer found by :func:`transfer`.

    Attributes
    ----------
    u : (N, 3) ndarray (N+1 rows with ``forcing="symmetric"``)
        Body-frame controls ``u_k`` at ``t_k = k h``.
    cost : float
        ``sum_k h |u_k|^2`` for ``"energy"`` (trapezoidal weights ``1/2`` at both ends with
        ``forcing="symmetric"``), the final time for ``"time"``.
    T : float
        Final time; ``h = T / N``.
    trajectory : lgvi.Trajectory
        The controlled run (every step).
    violation : dict
        Final attitude error (rad) and rate error of the terminal constraints.
    stats : dict
        The solver's statistics: method, iterations, function and gradient evaluations, message,
        wall time.
    """

    u: np.ndarray
    cost: float
    T: float
    trajectory: Trajectory
    violation: dict
    stats: dict = field(default_factory=dict)

    @property
    def h(self) -> float:
        """Step size ``T / N``."""
        return self.trajectory.h


class TransferError(RuntimeError):
    """The optimiser failed; ``best`` holds the best iterate (a :class:`TransferResult`) and
    ``violation`` what was violated."""

    def __init__(self, message: str, best: TransferResult | None, violation: dict):
        super().__init__(message)
        self.best = best
        self.violation = violation


class InfeasibleTransferError(ValueError):
    """The request cannot be met (for example ``T`` too short for ``max_torque``)."""


def reachable_angle(inertia_min: float, p0: float, pf: float, a: float, T: float) -> float:
    """Upper bound of the rotation angle reachable in time ``T`` (continuous problem).

    With ``|u| <= a`` the momentum's magnitude changes at most at rate ``a`` (``d|Pi|/dt = Pi.u/|Pi|``),
    so ``|Pi(t)| <= min(p0 + a t, pf + a (T - t))``, and the rotation angle between the end
    attitudes is at most the path length ``int |Omega| dt <= int |Pi| dt / J_min``. For a sphere
    at rest at both ends this is the eigenaxis bang-bang angle ``a T^2 / (4 J)``.

    ``inertia_min`` must be > 0, the magnitudes ``p0``, ``pf``, the torque bound ``a`` and the
    time ``T`` >= 0, all finite (ValueError naming the argument otherwise).
    """
    inertia_min = as_float(inertia_min, "inertia_min", positive=True)
    for name, value in (("p0", p0), ("pf", pf), ("a", a), ("T", T)):
        if as_float(value, name) < 0.0:
            raise ValueError(f"{name} must be >= 0 (a magnitude, a torque bound, a duration), got {value!r}")
    p0, pf, a, T = float(p0), float(pf), float(a), float(T)
    if a <= 0.0:
        return (p0 * T) / inertia_min if abs(p0 - pf) == 0.0 else 0.0
    ts = min(max((pf - p0 + a * T) / (2.0 * a), 0.0), T)
    area = p0 * ts + 0.5 * a * ts * ts + pf * (T - ts) + 0.5 * a * (T - ts) ** 2
    return area / inertia_min


#: Bytes a transfer holds per control step (the rollout's attitudes, momenta, adjoints and
#: gradients, with room for the solver's vectors), a generous bound.
BYTES_PER_STEP = 2048
#: Methods whose solver keeps a dense (3 nu)^2 matrix (SciPy's SLSQP and trust-constr).
DENSE_METHODS = ("SLSQP", "trust-constr")


def _check_size(nu: int, method: str) -> None:
    """Refuse a transfer of ``nu`` control steps whose arrays cannot fit in this machine's memory
    (a clear ValueError before NumPy's MemoryError)."""
    from ..driver import physical_memory

    need = BYTES_PER_STEP * nu + (8 * (3 * nu) ** 2 if method in DENSE_METHODS else 0)
    have = physical_memory()
    if need > have:
        raise ValueError(f"N = {nu} control steps with method={method!r} need about {need / 2**30:.3g} GiB"
                         + (" (its dense (3N)^2 matrix)" if method in DENSE_METHODS else "")
                         + f", more than this machine's {have / 2**30:.3g} GiB: use fewer steps"
                         + ("" if method not in DENSE_METHODS else " or method='ipopt' (sparse)"))


def _rate(value: Any, name: str) -> np.ndarray:
    """A body rate: 0 (at rest) or a (3,) vector."""
    if np.ndim(value) == 0:
        if as_float(value, name) != 0.0:
            raise ValueError(f"{name} must be 0 or a vector of shape (3,), got {value!r}")
        return np.zeros(3)
    return as_float_array(value, name, (3,))


def _eigenaxis_guess(body, R0, Rf, w0, wf, T, N, sym):
    """Controls of a cubic Hermite rotation vector from ``0`` to ``log(R0^T Rf)`` (rates at the ends)."""
    phi = so3.log(R0.T @ Rf)
    n = N + 1 if sym else N
    s = np.arange(n) / N
    # phi(t) = a t^2 + b t^3 + w0 t: phi(T) = phi, phi'(T) = wf
    a = (3.0 * (phi - w0 * T) - (wf - w0) * T) / T ** 2
    b = ((wf - w0) * T - 2.0 * (phi - w0 * T)) / T ** 3
    acc = 2.0 * a[None, :] + 6.0 * b[None, :] * (s * T)[:, None]
    return acc @ body.J.T


def transfer(body: Any, R0: Any, Rf: Any, T: Any, N: Any, *, omega0: Any = 0, omegaf: Any = 0,
             cost: CostName = "energy", max_torque: Any = None, torque: Any = None, forcing: ForcingName = "paper",
             method: TransferMethod | None = None, u0: Any = None, tol: float = 1e-10, constraint_tol: float = 1e-8,
             maxiter: int = 1000) -> TransferResult:
    """Transfer the body from ``(R0, omega0)`` to ``(Rf, omegaf)`` on the discrete LGVI.

    Parameters
    ----------
    body : lgvi.RigidBody, (3,) principal moments or (3, 3) inertia
    R0, Rf : (3, 3) rotations (or scipy Rotations)
        Initial and final attitudes.
    T : float
        Final time for ``cost="energy"``; the initial guess of it for ``cost="time"``.
    N : int
        Number of steps (``h = T / N``), at least 2.
    omega0, omegaf : 0 or (3,)
        Initial and final body rates.
    cost : {"energy", "time"}
        ``sum_k h |u_k|^2`` (the discrete integral of ``|u|^2``), or the final time (free ``T``;
        needs ``max_torque``).
    max_torque : None, float or (3,)
        Per-axis bound ``|u_i| <= max_torque_i``.
    torque : None or conservative lgvi.torques model
        Potential moments acting besides the controls (gravity, gravity gradient).
    forcing : {"paper", "symmetric"}
        The LGVI's treatment of the controls; ``"symmetric"`` uses ``N + 1`` controls ``u_0..u_N``.
    method : {None, "SLSQP", "trust-constr", "indirect", "ipopt"}
        ``None`` (default): ``"ipopt"`` for ``cost="time"`` when CasADi is installed (SLSQP took
        780 s where IPOPT takes 0.3 s at ``N = 200``), else ``"SLSQP"``; the result's
        ``stats["method"]`` says which ran and ``stats["method_choice"]`` why.
        SciPy's solver for the direct method; ``"ipopt"``: IPOPT through CasADi for the same direct
        method (exact adjoint gradients, limited-memory Hessian; linear cost per iteration in ``N``,
        for large ``N``; needs ``pip install lgvi[ipopt]``); or ``"indirect"``: the discrete necessary conditions
        integrated forwards from the initial multipliers (``cost="energy"``, the paper's
        forcing), with SciPy's ``root`` on the six initial multipliers to meet the terminal
        conditions (the shooting is sensitive: for short manoeuvres and moderate ``N``).
    u0 : None or (N, 3) array
        Initial guess of the controls (default: the eigenaxis cubic, clipped to ``max_torque``).
    tol, constraint_tol, maxiter
        Solver tolerance; largest accepted terminal violation (rad, rad/s); iteration limit.

    Returns
    -------
    TransferResult

    Raises
    ------
    InfeasibleTransferError
        When ``T`` is too short for ``max_torque`` (checked before solving, with the bound of
        :func:`reachable_angle`) or for ``cost="time"`` without ``max_torque``.
    ImportError
        For ``method="ipopt"`` without CasADi (``pip install lgvi[ipopt]``).
    TransferError
        When the solver fails or the terminal constraints are violated by more than
        ``constraint_tol``; ``err.best`` holds the best iterate, ``err.violation`` the violation.
    """
    from scipy import optimize

    body = as_body(body)
    R0 = as_rotation(R0, "R0")
    Rf = as_rotation(Rf, "Rf")
    T = as_float(T, "T", positive=True)
    N = as_int(N, "N", minimum=2)
    w0 = _rate(omega0, "omega0")
    wf = _rate(omegaf, "omegaf")
    cost = choice(cost, "cost", COSTS)
    method_choice = "given"
    if method is None:
        method = "SLSQP"
        method_choice = "default SLSQP"
        if cost == "time":
            try:
                import casadi  # noqa: F401
            except ImportError:
                method_choice = ("default SLSQP for cost='time': CasADi is not installed (pip install lgvi[ipopt] "
                                 "for IPOPT, much faster at large N)")
            else:
                method, method_choice = "ipopt", "default IPOPT for cost='time' (CasADi is installed)"
    method = choice(method, "method", METHODS)
    if method == "ipopt":
        from ._ipopt import require_casadi
        require_casadi()
    forcing = choice(forcing, "forcing", ("paper", "symmetric"))
    sym = forcing == "symmetric"
    potential_encoding(torque)        # validates torque
    tol = as_float(tol, "tol", positive=True)
    constraint_tol = as_float(constraint_tol, "constraint_tol", positive=True)
    maxiter = as_int(maxiter, "maxiter", minimum=1)
    umax = None
    if max_torque is not None:
        umax = np.zeros(3) + as_float_array(max_torque, "max_torque") if np.ndim(max_torque) == 0 else \
            as_float_array(max_torque, "max_torque", (3,))
        if not np.all(umax > 0):
            raise ValueError(f"max_torque must be positive, got {max_torque!r}")
    if cost == "time" and umax is None:
        raise InfeasibleTransferError("cost='time' needs max_torque: without a torque bound the minimum time is 0")
    nu = N + 1 if sym else N
    _check_size(nu, method)
    if u0 is not None:
        u0 = as_float_array(u0, "u0", (nu, 3))

    # necessary condition of the continuous problem (checked with a 2% margin for the discretisation)
    Pi0, Pif = body.J @ w0, body.J @ wf
    angle = float(np.linalg.norm(so3.log(R0.T @ Rf)))
    jmin = float(np.linalg.eigvalsh(body.J)[0])
    if umax is not None and torque is None:
        a = float(np.linalg.norm(umax))
        p0, pf = float(np.linalg.norm(Pi0)), float(np.linalg.norm(Pif))
        if cost == "energy":
            reach = reachable_angle(jmin, p0, pf, a, T)
            if abs(pf - p0) > a * T * 1.02 or angle > 1.02 * reach:
                raise InfeasibleTransferError(
                    f"T = {T:g} is too short for max_torque = {umax.tolist()}: a rotation of {angle:.6g} rad with "
                    f"|Pi| from {p0:.6g} to {pf:.6g} needs more time (at most {reach:.6g} rad and a momentum change "
                    f"of {a * T:.6g} are reachable in T; the bound uses |u| <= |max_torque| and the smallest moment "
                    f"of inertia {jmin:.6g})")
    if abs(angle - np.pi) < 1e-6:
        pass  # log is defined (one of the two axes); the constraint below is smooth near the solution

    t_start = _time.perf_counter()
    if method == "indirect":
        if cost != "energy" or sym:
            raise ValueError(f"method='indirect' solves cost='energy' with forcing='paper', got cost={cost!r}, "
                             f"forcing={forcing!r}")
        return _indirect(body, R0, Rf, Pi0, wf, T, N, umax, torque, u0, w0, constraint_tol, maxiter, t_start)
    free_T = cost == "time"
    cache: dict[bytes, Any] = {}

    def unpack(x):
        if free_T:
            return x[:-1].reshape(nu, 3), float(x[-1])
        return x.reshape(nu, 3), T

    def evaluate(x):
        key = x.tobytes()
        hit = cache.get(key)
        if hit is not None:
            return hit
        u, TT = unpack(x)
        h = TT / N
        run = rollout(body, R0, Pi0, h, u, forcing=forcing, torque=torque)
        e = so3.log(Rf.T @ run.R[-1])
        c = np.concatenate([e, body.J_inv @ run.Pi[-1] - wf])
        # seeds: the six constraints (the energy cost's gradient is explicit)
        dR = np.zeros((6, 1, 3))                     # terminal partials only
        dP = np.zeros((6, 1, 3))
        dR[:3, -1] = so3.right_jacobian_inv(e)       # row i: d e_i / d zeta_N
        dP[3:, -1] = body.J_inv                       # row i: d omega_i / d Pi_N (J^-1 symmetric)
        lam, gu, gJ, gh = reverse(run, dR, dP, np.zeros((6, nu, 3)))
        jac = gu.reshape(6, -1)
        if free_T:
            jac = np.hstack([jac, (gh / N)[:, None]])
        out = (run, c, jac)
        cache.clear()
        cache[key] = out
        return out

    wts = np.ones(nu)
    if sym:
        wts[0] = wts[-1] = 0.5

    def fun(x):
        if free_T:
            return float(x[-1])
        u, _ = unpack(x)
        return float(T / N * (wts @ np.einsum("ki,ki->k", u, u)))

    def grad(x):
        if free_T:
            g = np.zeros_like(x)
            g[-1] = 1.0
            return g
        u, _ = unpack(x)
        return (2.0 * T / N * wts[:, None] * u).ravel()

    if u0 is None:
        u0 = _eigenaxis_guess(body, R0, Rf, w0, wf, T, N, sym)
        if free_T:
            # break the symmetry of the eigenaxis guess (an eigenaxis path is a stationary point of
            # symmetric problems but need not be the minimum)
            u0 = u0 + 0.05 * np.abs(u0).max() * np.sin(np.arange(nu)[:, None] * 0.7 + np.arange(3)[None, :])
    if umax is not None:
        u0 = np.clip(u0, -umax, umax)
    x0 = u0.ravel().copy()
    bounds = None
    if umax is not None:
        lb = np.tile(-umax, nu)
        ub = np.tile(umax, nu)
        if free_T:
            lb = np.append(lb, 1e-6 * T)
            ub = np.append(ub, np.inf)
        bounds = optimize.Bounds(lb, ub)
    if free_T:
        x0 = np.append(x0, T)

    best = {"x": x0, "viol": np.inf, "f": np.inf}

    def cons(x):
        c = evaluate(x)[1]
        v = float(np.abs(c).max())
        f = fun(x)
        if v < best["viol"] * 0.999 or (v <= 10 * constraint_tol and f < best["f"]):
            best.update(x=x.copy(), viol=v, f=f)
        return c

    def cjac(x):
        return evaluate(x)[2]

    if method == "ipopt":
        from . import _ipopt
        res = _ipopt.solve(fun, grad, cons, cjac, x0, None if bounds is None else bounds.lb,
                           None if bounds is None else bounds.ub, 6, tol, constraint_tol, maxiter)
    elif method == "SLSQP":
        res = optimize.minimize(fun, x0, jac=grad, method="SLSQP", bounds=bounds,
                                constraints=[{"type": "eq", "fun": cons, "jac": cjac}],
                                options={"ftol": tol, "maxiter": maxiter})
    else:
        res = optimize.minimize(fun, x0, jac=grad, hess=lambda x: np.zeros((x.size, x.size)) if free_T else
                                2.0 * T / N * np.diag(np.repeat(wts, 3)), method="trust-constr", bounds=bounds,
                                constraints=[optimize.NonlinearConstraint(cons, 0.0, 0.0, jac=cjac)],
                                options={"xtol": tol, "gtol": tol, "maxiter": maxiter})

    def result(x, message):
        run, c, _ = evaluate(x)
        u, TT = unpack(x)
        viol = {"attitude": float(np.linalg.norm(c[:3])), "rate": float(np.linalg.norm(c[3:]))}
        if umax is not None:
            viol["torque_bound"] = float(max(0.0, (np.abs(u) - umax).max()))
        stats = {"method": method, "method_choice": method_choice, "success": bool(res.success),
                 "message": str(message),
                 "iterations": int(getattr(res, "nit", 0) or 0), "function_evaluations": int(res.nfev),
                 "gradient_evaluations": int(getattr(res, "njev", 0) or 0),
                 "wall_time": _time.perf_counter() - t_start, "constraint_tol": constraint_tol}
        return TransferResult(u=u.copy(), cost=fun(x), T=TT, trajectory=run.trajectory(), violation=viol, stats=stats)

    out = result(res.x, res.message)
    bad = [k for k, v in out.violation.items() if v > constraint_tol]
    if bad or not res.success:
        best_res = result(best["x"], res.message) if np.isfinite(best["viol"]) else out
        what = ", ".join(f"{k} {out.violation[k]:.3g}" for k in bad) or "none"
        raise TransferError(f"the transfer did not converge ({method}: {res.message}); violated beyond "
                            f"constraint_tol = {constraint_tol:g}: {what}; err.best holds the best iterate "
                            f"(try a longer T, more iterations, or a guess u0)", best_res, out.violation)
    return out


def _indirect(body, R0, Rf, Pi0, wf, T, N, umax, torque, u0, w0, constraint_tol, maxiter, t_start):
    """Shooting on the discrete necessary conditions (see :func:`transfer`, ``method="indirect"``)."""
    from scipy import optimize

    from .._kernels import adjoint_kernels as ak
    from .._kernels.codes import OK
    from .adjoint import Rollout, potential_encoding

    codes, params = potential_encoding(torque)
    h = T / N
    box = np.full(3, np.inf) if umax is None else umax
    R = np.empty((N + 1, 3, 3))
    Pi = np.empty((N + 1, 3))
    F = np.empty((N, 3, 3))
    P = np.empty((N + 1, 3))
    U = np.empty((N, 3))
    its = np.zeros(N, dtype=np.int64)
    res_ = np.zeros(N)
    gJ = np.zeros((1, 3, 3))
    R[0] = R0
    Pi[0] = Pi0

    def shoot(lam0):
        st, k = ak.shoot_run(body.Jd, body.J, body.J_inv, h, 0.0, np.ascontiguousarray(lam0, dtype=np.float64), box,
                             R, Pi, F, P, U, codes, params, 1e-15, 50, its, res_, np.zeros(0), gJ)
        if st != OK:
            return np.full(6, 1e6)
        return np.concatenate([so3.log(Rf.T @ R[-1]), body.J_inv @ Pi[-1] - wf])

    guess = _eigenaxis_guess(body, R0, Rf, w0, wf, T, N, False) if u0 is None else u0
    lam0 = np.concatenate([2.0 * body.J @ (guess[1] - guess[0]) / h, -2.0 * guess[0]])
    sol = optimize.root(shoot, lam0, method="hybr", options={"xtol": 1e-13, "maxfev": 200 * maxiter})
    c = shoot(sol.x)
    u = U.copy()
    run = Rollout(R=R.copy(), Pi=Pi.copy(), F=F.copy(), P=P.copy(), u=u, body=body, h=h, t0=0.0, forcing="paper",
                  codes=codes, params=params, iterations=its.copy(), residual=res_.copy(), torque=torque)
    viol = {"attitude": float(np.linalg.norm(c[:3])), "rate": float(np.linalg.norm(c[3:]))}
    stats = {"method": "indirect", "success": bool(sol.success), "message": str(sol.message),
             "iterations": int(getattr(sol, "nit", 0) or 0), "function_evaluations": int(sol.nfev),
             "gradient_evaluations": 0, "wall_time": _time.perf_counter() - t_start,
             "constraint_tol": constraint_tol, "initial_multipliers": sol.x.copy()}
    out = TransferResult(u=u, cost=float(h * np.sum(u * u)), T=T, trajectory=run.trajectory(), violation=viol,
                         stats=stats)
    bad = [k for k, v in viol.items() if v > constraint_tol]
    if bad:
        what = ", ".join(f"{k} {viol[k]:.3g}" for k in bad)
        raise TransferError(f"the indirect method did not meet the terminal conditions ({sol.message}); violated "
                            f"beyond constraint_tol = {constraint_tol:g}: {what}; err.best holds the last iterate "
                            f"(try the direct method)", out, viol)
    return out
