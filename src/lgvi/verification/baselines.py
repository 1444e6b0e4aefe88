"""Classical baselines on the same problems: Euler's equations with quaternion kinematics.

State ``y = (q, Pi)`` with ``q`` a scalar-last unit quaternion (body to inertial) and ``Pi`` the
body angular momentum:

    dq/dt  = 1/2 q (x) (Omega, 0),      Omega = J^-1 Pi
    dPi/dt = Pi x Omega + u(t, R, Pi)

The quaternion is integrated as a vector in R^4 and *not* renormalised, so the attitude that
comes back, ``R = R(q)`` from the homogeneous formula (``|q|^2`` times a rotation), shows the
drift off SO(3) that a Runge-Kutta method accumulates; that is the honest comparison with the
LGVI, which stays on SO(3) by construction. A torque always sees the rotation of ``q / |q|``.

Three integrators take the same ``RigidBody``, initial state and torque as :func:`lgvi.simulate`
and return a :class:`lgvi.Trajectory`, so a comparison is one line:

- :func:`rk4`: classic fixed-step Runge-Kutta (compiled loop for the free body and built-in
  torque models, a Python loop for a torque callable);
- :func:`solve_ivp_baseline`: any ``scipy.integrate.solve_ivp`` method (RK45, DOP853, ...);
- :func:`compare`: several of them (and the LGVI) on one problem, with wall-clock times.

``torque`` is ``None`` (free body), a callable ``torque(t, R, Pi) -> (3,)`` or a torque model
(an object with ``moment(t, R, Pi, body) -> (3,)``, such as those of :mod:`lgvi.torques`). For a
conservative model (``model.conservative`` true, with ``potential(t, R, body)``) the returned
trajectory carries the potential energy, so ``Trajectory.energy`` is the total energy; a sum of
built-in models with some conservative terms (a damped heavy top) reports their potential, as
:func:`lgvi.simulate` does.
"""

from __future__ import annotations

import dataclasses
import time as _time
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .._kernels import rk4_kernels as _rk
from .._kernels.codes import OK, OVERFLOW
from .._validation import as_float, as_float_array, as_int, as_rotation
from .._version import __version__
from ..driver import MemorySink, drive, time_grid
from ..errors import ConvergenceError, TorqueError
from ..registry import torque_kind
from ..systems import Field, System
from ..trajectory import Trajectory, summary_dict

#: RK4 steps per compiled call; between chunks Ctrl-C is honoured and progress reported.
CHUNK_STEPS = 1 << 18
#: RK4 steps per chunk of the Python loop that serves a torque callable.
CALLABLE_CHUNK_STEPS = 1 << 12

#: ``compare`` method names (lower case) of ``solve_ivp`` methods.
SOLVE_IVP_METHODS: dict[str, str] = {"rk45": "RK45", "dop853": "DOP853", "rk23": "RK23", "radau": "Radau",
                                     "bdf": "BDF", "lsoda": "LSODA"}

# ------------------------------------------------------------------------------------------------
# quaternion helpers
# ------------------------------------------------------------------------------------------------
def quat_rhs(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """dq/dt for scalar-last ``q`` and body rate ``omega`` (vectorised over a leading axis).

    ``dq/dt = 1/2 q (x) (omega, 0)`` (Hamilton product), the kinematics of a body-to-inertial
    quaternion, i.e. ``d/dt R(q) = R(q) hat(omega)``.
    """
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    a, b, c = omega[..., 0], omega[..., 1], omega[..., 2]
    return 0.5 * np.stack([w * a + y * c - z * b,
                           w * b + z * a - x * c,
                           w * c + x * b - y * a,
                           -(x * a + y * b + z * c)], axis=-1)


def homogeneous_matrix(q: np.ndarray) -> np.ndarray:
    """``R(q) = (w^2 - v.v) I + 2 v v^T + 2 w hat(v)``: ``|q|^2`` times the rotation of ``q``."""
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = w * w + x * x - y * y - z * z
    R[..., 1, 1] = w * w - x * x + y * y - z * z
    R[..., 2, 2] = w * w - x * x - y * y + z * z
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 1] = 2 * (y * z + w * x)
    return R


def _quat_of(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(np.array(R)).as_quat()  # writable: SciPy < 1.16 rejects read-only R


# ------------------------------------------------------------------------------------------------
# torques: None, a callable, or a model; built-in models run compiled from their encoding
# ------------------------------------------------------------------------------------------------
def _builtin_model(torque: Any) -> bool:
    return torque_kind(torque) == "model"


@dataclasses.dataclass
class _Torque:
    """A resolved ``torque=``: kernel data for the compiled path, or a Python function."""

    kind: str                                  # "none" | "callable" | "model"
    codes: np.ndarray | None = None            # compiled path (free body or built-in model) ...
    params: np.ndarray | None = None
    D: np.ndarray | None = None
    func: Callable | None = None               # ... else the Python path: func(t, R, Pi) -> (3,)
    model: Any = None

    @property
    def path(self) -> str:
        return "compiled" if self.codes is not None else "python"

    def potential(self, t: np.ndarray, R: np.ndarray, body) -> np.ndarray | None:
        """(M,) potential energy at the samples, or ``None`` (no potential).

        Filled for a conservative model, and for a sum of built-in models with conservative terms
        (a damped heavy top reports its gravity energy, as :mod:`lgvi.torques` defines). ``R`` may
        be homogeneous (``|q|^2`` times a rotation): it is normalised first.
        """
        model = self.model
        if model is None or not hasattr(model, "potential"):
            return None
        builtin = _builtin_model(model)
        if not (getattr(model, "conservative", False) or builtin):
            return None
        scale = np.sqrt(np.einsum("mij,mij->m", R, R) / 3.0)   # |q|^2 (1 for a rotation)
        Rn = R / scale[:, None, None]
        if builtin:                                           # vectorised over samples
            U = model.potential(np.asarray(t, dtype=np.float64), Rn, body)
            return None if U is None else np.asarray(U, dtype=np.float64).reshape(len(t))
        return np.array([float(model.potential(float(ti), Ri, body)) for ti, Ri in zip(t, Rn)])


_FREE = dict(codes=np.zeros((0, 2), dtype=np.int64), params=np.zeros(0), D=np.zeros(3))


def _resolve_torque(torque: Any, body) -> _Torque:
    kind = torque_kind(torque)  # lgvi.registry: the one classification of torque=
    if kind == "none":
        return _Torque("none", **_FREE)
    if kind == "model" or hasattr(torque, "moment"):  # a built-in model, or any object with moment()
        if kind == "model":
            try:
                codes, params = torque.encode()
            except NotImplementedError:       # a user subclass without a kernel encoding
                codes = None
            if codes is not None:
                from .._kernels.torque_kernels import momentum_diag

                codes = np.ascontiguousarray(codes, dtype=np.int64)
                params = np.ascontiguousarray(params, dtype=np.float64)
                D = np.array(momentum_diag(codes, params), dtype=np.float64)
                return _Torque("model", codes=codes, params=params, D=D, model=torque)
        moment = torque.moment
        return _Torque("model", func=lambda t, R, Pi: moment(t, R, Pi, body), model=torque)
    if kind == "callable":
        return _Torque("callable", func=torque)
    raise TypeError(f"torque must be None, a callable torque(t, R, Pi) -> (3,), or a torque model with a "
                    f"moment(t, R, Pi, body) method; got {type(torque).__name__}. (The Runge-Kutta baselines need "
                    f"the moment at any time, so an array of u_k is not accepted.)")


def _check_moment(u: Any, t: float, where: str) -> np.ndarray:
    try:
        arr = np.asarray(u, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TorqueError(f"torque must return 3 real numbers; at {where} (t = {t:g}) it returned {u!r}",
                          time=t) from exc
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise TorqueError(f"torque must return 3 finite numbers (shape (3,)); at {where} (t = {t:g}) it "
                          f"returned {arr!r}", time=t)
    return arr


def _python_rhs(tq: _Torque, body) -> Callable[[float, np.ndarray], np.ndarray]:
    """NumPy right-hand side ``f(t, y)`` for a Python torque."""
    J_inv = np.array(body.J_inv)
    func = tq.func

    def f(t: float, y: np.ndarray) -> np.ndarray:
        q = y[:4]
        Pi = y[4:]
        omega = J_inv @ Pi
        try:
            u = func(t, homogeneous_matrix(q) / (q @ q), Pi.copy())
        except (KeyboardInterrupt, TorqueError):
            raise
        except Exception as exc:
            raise TorqueError(f"the torque raised {type(exc).__name__} at t = {t:g}: {exc}", time=t) from exc
        dPi = np.cross(Pi, omega) + _check_moment(u, t, "a right-hand-side evaluation")
        return np.concatenate([quat_rhs(q, omega), dPi])

    return f


def _initial_state(body: Any, R0: Any, Pi0: Any, omega0: Any):
    from ..driver import initial_momentum as _initial_momentum
    from ..integrator import as_body

    body = as_body(body)
    R0 = as_rotation(R0, "R0")
    Pi0 = _initial_momentum(body, Pi0, omega0)
    return body, R0, Pi0


# ------------------------------------------------------------------------------------------------
# classic RK4
# ------------------------------------------------------------------------------------------------
def rk4(body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: float, steps: int, torque: Any = None,
        save_every: int = 1, normalize: bool = False, t0: float = 0.0, progress: Any = False) -> Trajectory:
    r"""Integrate the same problem as :func:`lgvi.simulate` with classic fixed-step RK4.

    Parameters
    ----------
    body : RigidBody or array_like
        The body, or its inertia (``(3,)`` principal moments or ``(3, 3)``).
    R0 : (3, 3) array_like or scipy.spatial.transform.Rotation
        Initial attitude (body to inertial), a rotation to 1e-9 (to 1e-6: replaced by the
        nearest rotation, with an ``AttitudeWarning``).
    Pi0, omega0 : (3,) array_like
        Initial body angular momentum or angular velocity (one of them).
    h : float
        Step size, non-zero (``h < 0`` integrates backwards).
    steps : int
        Number of steps, ``>= 0``.
    torque : None, callable or torque model
        ``None`` (free body), ``torque(t, R, Pi) -> (3,)`` (called four times per step from
        Python), or a model with ``moment(t, R, Pi, body)``; the built-in models of
        :mod:`lgvi.torques` and their sums run in the compiled loop.
    save_every : int
        Keep every ``save_every``-th state; must divide ``steps``.
    normalize : bool
        Rescale ``q`` to unit length after every step (the common "projected" RK4). Default
        ``False``: ``q`` drifts in norm and ``R`` (homogeneous formula) drifts off SO(3), visibly.
    t0 : float
        Initial time.
    progress : bool or callable
        As in :func:`lgvi.simulate`: ``True`` draws a progress bar, a callable is called as
        ``progress(steps_done, steps)`` between chunks; ``False`` (default) is silent.

    Returns
    -------
    Trajectory
        ``M = steps // save_every + 1`` samples; ``R`` is ``R(q)`` from the homogeneous formula
        (``|q|^2`` times a rotation); ``iterations`` and ``residual`` are zeros (explicit method),
        one per saved interval, shape ``(M - 1,)``, as lgvi's default record;
        ``potential`` is filled for a conservative model (see the module notes);
        ``meta["method"] == "rk4"``, ``meta["torque_path"]`` is ``"compiled"`` or ``"python"``.

    Raises
    ------
    lgvi.SimulationInterrupted
        On Ctrl-C (honoured between chunks, :func:`lgvi.driver.drive`), with the part computed in
        ``.trajectory``.
    lgvi.TorqueError
        When a torque callable or model raises or returns other than 3 finite numbers, with the
        step in ``.step`` and the run up to that step in ``.trajectory``.
    lgvi.ConvergenceError
        When a step makes the state ``(q, Pi)`` non-finite (overflow; with ``normalize`` also when
        ``|q|^2`` overflows), as :func:`lgvi.simulate` reports it: the step in ``.step``, its time
        in ``.time`` and the finite run up to that step in ``.trajectory``.

    Notes
    -----
    ``y = (q, Pi)``, ``y' = f(t, y)`` with ``q' = 1/2 q (x) (J^-1 Pi, 0)`` and
    ``Pi' = Pi x J^-1 Pi + u(t, R(q/|q|), Pi)``;
    ``k1 = f(t, y)``, ``k2 = f(t + h/2, y + h/2 k1)``, ``k3 = f(t + h/2, y + h/2 k2)``,
    ``k4 = f(t + h, y + h k3)``, ``y <- y + h/6 (k1 + 2 k2 + 2 k3 + k4)``. Fourth order; neither
    the energy, nor ``|Pi|``, nor ``R Pi`` is conserved exactly.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> from lgvi.baselines import rk4
    >>> traj = rk4(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=1000)
    >>> traj.R.shape, traj.meta["method"]
    ((1001, 3, 3), 'rk4')
    >>> bool(1e-14 < abs(traj.energy[-1] / traj.energy[0] - 1) < 1e-8)
    True
    """
    body, R0, Pi = _initial_state(body, R0, Pi0, omega0)
    h, t0, steps, save_every = time_grid(h, t0, steps, save_every)  # lgvi.driver: the shared checks
    if not isinstance(normalize, (bool, np.bool_)):
        raise TypeError(f"normalize must be True or False, got {normalize!r}")
    run = RK4Run(body, R0, Pi, h, steps, _resolve_torque(torque, body), save_every, bool(normalize), t0)
    return drive(run, MemorySink(run), progress)  # lgvi.driver: chunks, progress, Ctrl-C, partial results


#: The state layout of :func:`rk4` that the driver allocates: the quaternion and the momentum (not a
#: registered system of :mod:`lgvi.systems`: a baseline of the rigid body in other coordinates).
RK4_LAYOUT = System(
    name="rk4", doc="the rigid body in quaternion coordinates, classic RK4: q (4,) scalar-last, Pi (3,)",
    state=(Field("q", (4,), doc="scalar-last quaternion, body to inertial, not renormalised"),
           Field("Pi", (3,), doc="body angular momentum")),
    records=(), kernels=lambda: {"rk4_chunk": _rk.rk4_chunk},
    results=("t", "R", "Pi", "inertia", "iterations", "residual", "h", "potential", "meta"), scenario_section="",
    run_factory=None, invariants=lambda torque: {})


class RK4Run:
    """One validated :func:`rk4` run, driven by :func:`lgvi.driver.drive` in chunks of :attr:`chunk`
    steps (a multiple of ``save_every``): the compiled chunk :func:`lgvi._kernels.rk4_kernels.rk4_chunk`
    for the free body and the built-in models, a Python loop for a torque callable. ``q`` (4,) and
    ``Pi`` (3,) carry the state from chunk to chunk."""
    meta: dict[str, Any]
    t0: float
    steps: int
    save_every: int
    normalize: bool
    last_res: float
    last_its: int
    h: float
    body: Any

    system = RK4_LAYOUT
    label = "rk4"

    def __init__(self, body: Any, R0: np.ndarray, Pi: np.ndarray, h: float, steps: int, tq: "_Torque",
                 save_every: int, normalize: bool, t0: float) -> None:
        self.body, self.h, self.steps, self.save_every, self.normalize, self.t0 = body, h, steps, save_every, normalize, t0
        self.tq = tq
        self.k: int = 0
        self.last_res, self.last_its = float("nan"), 0    # of a failed step (lgvi.driver.MemorySink.failed)
        self.q: np.ndarray = _quat_of(R0)
        self.Pi = Pi
        base = CHUNK_STEPS if tq.codes is not None else CALLABLE_CHUNK_STEPS
        self.chunk: int = max(1, base // save_every) * save_every
        if tq.codes is None:
            self.f = _python_rhs(tq, body)
            self.y: np.ndarray = np.concatenate([self.q, self.Pi])
        else:
            self.J = np.ascontiguousarray(body.J)
            self.J_inv: np.ndarray = np.ascontiguousarray(body.J_inv)
        self.meta = {"method": "rk4", "h": h, "steps": steps, "save_every": save_every, "normalize": normalize,
                     "torque": tq.kind, "torque_path": tq.path, "t0": t0, "lgvi_version": __version__}

    def times(self, j0: int, j1: int) -> np.ndarray:
        return self.t0 + self.h * self.save_every * np.arange(j0, j1)

    def advance(self, n: int, q_out: np.ndarray, Pi_out: np.ndarray, partial: Callable) -> int:
        """Steps ``k .. k+n-1`` into the chunk's buffers (``n // save_every`` samples each)."""
        tq = self.tq
        if tq.codes is not None:
            status, self.k = _rk.rk4_chunk(self.h, self.t0, self.q, self.Pi, self.J, self.J_inv, tq.codes, tq.params,
                                           tq.D, self.k, n, self.save_every, self.normalize, q_out, Pi_out)
            return status
        f, y, h, t0, se, normalize = self.f, self.y, self.h, self.t0, self.save_every, self.normalize
        h2, h6 = 0.5 * h, h / 6.0
        k0 = self.k
        for i in range(n):
            k = k0 + i
            t = t0 + k * h
            try:
                k1 = f(t, y)
                k2 = f(t + h2, y + h2 * k1)
                k3 = f(t + h2, y + h2 * k2)
                k4 = f(t + h, y + h * k3)
            except TorqueError as exc:
                self.k = k
                exc.step = k
                exc.args = (f"{exc.args[0]} (in step {k}; the run up to step {k} is in .trajectory)",)
                exc.trajectory = partial(k)
                raise
            y_new = y + h6 * (k1 + 2.0 * (k2 + k3) + k4)
            if normalize:
                qq = y_new[:4] @ y_new[:4]
                y_new[:4] /= np.sqrt(qq)
            if not (np.isfinite(y_new).all() and (not normalize or 0.0 < qq < np.inf)):
                self.y = y                  # the last finite state, before step k (as the compiled chunk)
                self.k = k
                return OVERFLOW
            y = y_new
            if (i + 1) % se == 0:
                j = (i + 1) // se - 1
                q_out[j] = y[:4]
                Pi_out[j] = y[4:]
        self.y = y
        self.k = k0 + n
        return OK

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any,
                where: str = "") -> ConvergenceError:
        """The error of a step that made the state non-finite (``OVERFLOW``, the only failing status
        of an explicit method), as :func:`lgvi.simulate` reports one: step, time and the run up to it."""
        k = self.k
        t_fail = self.t0 + k * self.h
        return ConvergenceError(f"rk4 step {k} (t = {t_fail:g}) failed: the state (q, Pi) became non-finite "
                                "(overflow): check the torque's magnitude, or reduce the step h. The run up to "
                                f"step {k} is in .trajectory." + where, residual=float("nan"), iterations=0,
                                step=k, time=t_fail, trajectory=trajectory)

    def state(self) -> dict[str, Any]:
        st = {"k": self.k, "q": self.q.copy(), "Pi": self.Pi.copy()}
        if self.tq.codes is None:
            st["y"] = self.y.copy()
        return st

    def load_state(self, st: dict[str, Any]) -> None:
        self.k = int(st["k"])
        self.q[...] = st["q"]
        self.Pi[...] = st["Pi"]
        if "y" in st:
            self.y = np.array(st["y"], dtype=np.float64)

    def trajectory(self, t: np.ndarray, q: np.ndarray, Pi: np.ndarray, partial: bool = False) -> Trajectory:
        """The :class:`lgvi.Trajectory` of samples ``q`` (m, 4), ``Pi`` (m, 3) after :attr:`k` steps."""
        m = len(t)
        R = homogeneous_matrix(q)
        # no implicit solves: a record of zeros per saved interval, sized by the samples as lgvi's
        solver = summary_dict(np.array([self.k]), 0, 0.0)
        extra = {"partial": True} if partial else {}
        return Trajectory(t=t, R=R, Pi=Pi, inertia=self.body.J.copy(), iterations=np.zeros(m - 1, dtype=np.int32),
                          residual=np.zeros(m - 1), h=self.h, potential=self.tq.potential(t, R, self.body),
                          meta=dict(self.meta, solver_record="interval", solver_summary=solver, **extra))


# ------------------------------------------------------------------------------------------------
# scipy.integrate.solve_ivp
# ------------------------------------------------------------------------------------------------
def solve_ivp_baseline(body, R0, Pi0=None, *, omega0=None, t_final: float, samples: int | None = 1001,
                       method: str = "RK45", rtol: float = 1e-6, atol: float = 1e-9,
                       torque=None, t0: float = 0.0) -> Trajectory:
    """Integrate the same problem with ``scipy.integrate.solve_ivp``.

    Parameters
    ----------
    body : RigidBody or array_like
    R0 : (3, 3) array_like or scipy.spatial.transform.Rotation
    Pi0, omega0 : (3,) array_like
        Initial body momentum or angular velocity (one of them).
    t_final : float
        Final time (``!= t0``; ``t_final < t0`` integrates backwards).
    samples : int or None
        Number of output times, evenly spaced on ``[t0, t_final]``; ``None`` keeps every
        accepted step of the integrator.
    method : str
        Any ``solve_ivp`` method (``"RK45"``, ``"DOP853"``, ...).
    rtol, atol : float
        Tolerances passed to ``solve_ivp`` (positive).
    torque : None, callable or torque model
        As in :func:`rk4`; built-in models and the free body use a compiled right-hand side.
    t0 : float
        Initial time.

    Returns
    -------
    Trajectory
        ``iterations`` holds the number of right-hand-side evaluations (one entry), ``residual``
        is empty, ``h`` is NaN; ``R`` is built from the unnormalised quaternion (see the module
        notes); ``potential`` is filled for a conservative model.

    Raises
    ------
    RuntimeError
        If ``solve_ivp`` reports failure.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> from lgvi.baselines import solve_ivp_baseline
    >>> traj = solve_ivp_baseline([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], t_final=10.0,
    ...                           samples=11, method="DOP853", rtol=1e-12, atol=1e-12)
    >>> traj.t.shape, traj.meta["method"]
    ((11,), 'solve_ivp:DOP853')
    """
    from scipy.integrate import solve_ivp

    body, R0, Pi0 = _initial_state(body, R0, Pi0, omega0)
    t0 = as_float(t0, "t0")
    t_final = as_float(t_final, "t_final")
    if t_final == t0:
        raise ValueError(f"t_final must differ from t0 = {t0:g}, got {t_final:g}")
    if samples is not None:
        samples = as_int(samples, "samples", minimum=2)
    if not isinstance(method, str):
        raise TypeError(f"method must be the name of a solve_ivp method (a str such as 'RK45'), got {method!r}")
    rtol = as_float(rtol, "rtol", positive=True)
    atol = as_float(atol, "atol", positive=True)
    tq = _resolve_torque(torque, body)

    if tq.codes is not None:
        J = np.ascontiguousarray(body.J)
        J_inv = np.ascontiguousarray(body.J_inv)
        codes, params, D = tq.codes, tq.params, tq.D

        def rhs(t, y):
            return _rk.rhs(t, y, J, J_inv, codes, params, D)
    else:
        rhs = _python_rhs(tq, body)

    y0 = np.concatenate([_quat_of(R0), Pi0])
    t_eval = None if samples is None else np.linspace(t0, t_final, samples)
    try:
        sol = solve_ivp(rhs, (t0, t_final), y0, method=method, t_eval=t_eval, rtol=rtol, atol=atol)
    except ValueError as exc:
        if "method" in str(exc).lower():
            raise ValueError(f"method must be a solve_ivp method such as 'RK45' or 'DOP853'; got {method!r} "
                             f"({exc})") from exc
        raise
    if not sol.success:
        raise RuntimeError(f"solve_ivp({method}) failed: {sol.message}")
    q = sol.y[:4].T
    R = homogeneous_matrix(q)
    return Trajectory(t=sol.t, R=R, Pi=as_float_array(sol.y[4:].T, "Pi"),
                      inertia=body.J.copy(), iterations=np.array([sol.nfev], dtype=np.int32),
                      residual=np.zeros(0), h=float("nan"), potential=tq.potential(sol.t, R, body),
                      meta={"method": f"solve_ivp:{method}", "rtol": rtol, "atol": atol, "nfev": int(sol.nfev),
                            "torque": tq.kind, "torque_path": tq.path, "t0": t0, "lgvi_version": __version__})


# ------------------------------------------------------------------------------------------------
# one-line comparisons
# ------------------------------------------------------------------------------------------------
def _run_lgvi(body, R0, Pi0, h, steps, torque, save_every, opts) -> Trajectory:
    from ..integrator import simulate

    try:
        traj = simulate(body, R0, Pi0, h=h, steps=steps, torque=torque, save_every=save_every, **opts)
    except (TypeError, ValueError) as exc:
        # a simulate() that does not take model objects yet: pass the model as a callable
        if not (hasattr(torque, "moment") and str(exc).startswith("torque")):
            raise
        moment = torque.moment
        traj = simulate(body, R0, Pi0, h=h, steps=steps, torque=lambda t, R, Pi: moment(t, R, Pi, body),
                        save_every=save_every, **opts)
        traj = dataclasses.replace(traj, meta=dict(traj.meta, torque="model (as callable)"))
    if traj.potential is None and hasattr(torque, "moment"):
        U = _Torque("model", model=torque).potential(traj.t, traj.R, body)
        if U is not None:
            traj = dataclasses.replace(traj, potential=U)
    return traj


def compare(body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: float, steps: int,
            torque: Any = None, methods: Sequence[str] = ("lgvi", "rk4", "rk45", "dop853"), save_every: int = 1,
            options: Mapping[str, Mapping[str, Any]] | None = None,
            warmup: bool = True) -> dict[str, tuple[Trajectory, float]]:
    """Run one problem with the LGVI and the baselines; return trajectories and wall times.

    Parameters
    ----------
    body, R0, Pi0, omega0, torque
        The problem, as in :func:`lgvi.simulate` (``torque``: ``None``, a callable or a model).
    h : float
        Step size of ``"lgvi"`` and ``"rk4"``; the adaptive methods integrate to
        ``T = h * steps`` and are sampled on the same grid.
    steps : int
        Number of fixed steps (``>= 1``).
    methods : sequence of str
        From ``"lgvi"`` (:func:`lgvi.simulate`), ``"rk4"`` (:func:`rk4`) and the ``solve_ivp``
        methods ``"rk45"``, ``"dop853"``, ``"rk23"``, ``"radau"``, ``"bdf"``, ``"lsoda"``
        (:func:`solve_ivp_baseline`, case-insensitive).
    save_every : int
        Keep every ``save_every``-th step (all methods share the sample times).
    options : mapping, optional
        Extra keyword arguments per method name, e.g. ``{"rk45": {"rtol": 1e-9}, "lgvi":
        {"method": "cayley"}, "rk4": {"normalize": True}}``.
    warmup : bool
        First run each compiled method for one step (untimed), so the wall times exclude Numba
        compilation or cache loading. A torque callable is then called a few extra times.

    Returns
    -------
    dict
        ``name -> (Trajectory, wall seconds)`` in the order of ``methods`` (names lower case).

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> from lgvi.baselines import compare
    >>> runs = compare(lgvi.RigidBody([1., 2., 3.]), np.eye(3), omega0=[0.3, 1., 0.2], h=0.01, steps=500)
    >>> list(runs)
    ['lgvi', 'rk4', 'rk45', 'dop853']
    >>> drift = {k: float(np.ptp(tr.energy) / tr.energy[0]) for k, (tr, sec) in runs.items()}
    >>> drift["lgvi"] < 1e-13 < drift["rk45"]
    True
    """
    body, R0, Pi0 = _initial_state(body, R0, Pi0, omega0)
    h = as_float(h, "h", nonzero=True)
    steps = as_int(steps, "steps", minimum=1)
    save_every = as_int(save_every, "save_every", minimum=1)
    if steps % save_every != 0:
        raise ValueError(f"save_every must divide steps so that the final state is saved; got "
                         f"steps={steps}, save_every={save_every}")
    if isinstance(methods, str):
        methods = (methods,)
    names: list[str] = []
    for m in methods:
        key = m.lower() if isinstance(m, str) else None
        if key not in ("lgvi", "rk4") and key not in SOLVE_IVP_METHODS:
            raise ValueError(f"methods must name 'lgvi', 'rk4' or a solve_ivp method "
                             f"({', '.join(repr(k) for k in SOLVE_IVP_METHODS)}); got {m!r}")
        if key in names:
            raise ValueError(f"methods must not repeat a name; {m!r} appears twice")
        names.append(key)
    options = {str(k).lower(): dict(v) for k, v in (options or {}).items()}
    unknown = set(options) - set(names)
    if unknown:
        raise ValueError(f"options names methods not in methods: {sorted(unknown)}")
    _resolve_torque(torque, body)  # a TypeError naming torque before any run

    M = steps // save_every + 1
    out: dict[str, tuple[Trajectory, float]] = {}
    for name in names:
        opts = options.get(name, {})
        if name == "lgvi":
            def run(n=steps, opts=opts):
                return _run_lgvi(body, R0, Pi0, h, n, torque, save_every if n == steps else 1, opts)
        elif name == "rk4":
            def run(n=steps, opts=opts):
                return rk4(body, R0, Pi0, h=h, steps=n, torque=torque,
                           save_every=save_every if n == steps else 1, **opts)
        else:
            def run(n=steps, opts=opts, method=SOLVE_IVP_METHODS[name]):
                return solve_ivp_baseline(body, R0, Pi0, t_final=h * n, samples=M if n == steps else 2,
                                          method=method, torque=torque, **opts)
        if warmup:
            run(1)
        start = _time.perf_counter()
        traj = run()
        out[name] = (traj, _time.perf_counter() - start)
    return out


__all__ = ["compare", "homogeneous_matrix", "quat_rhs", "rk4", "solve_ivp_baseline"]
