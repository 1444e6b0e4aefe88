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

import math
from dataclasses import dataclass
from typing import Any, Callable, Literal

import numpy as np

from .. import so3
from .._kernels.codes import METHOD_CAYLEY, OK, USER_RAISED
from .._validation import as_float, as_float_array, as_rotation, choice
from .._version import __version__
from ..accuracy import check_options, provide_simulate
from ..body import RigidBody
from ..driver import (MemorySink, check_memory as _check_memory, drive,  # noqa: F401
                     initial_momentum as _initial_momentum, run_solver_options, sample_times, steps_from,
                     time_grid)
from ..errors import ConvergenceError, TorqueError
from ..implicit import METHODS, failure_message, largest_step
from ..invariants import declaration_of, forcing_used
from ..registry import (COMPOSITIONS, DEFAULT_COMPOSITION, FORCINGS, SCHEMES, SOLVER_METHODS,  # noqa: F401
                       Composition, ForcingName, MethodName, check_composable, composition_for, torque_kind)
from . import provide_run
from .rigid_body import RIGID_BODY, momentum_matrices
from ..torques import TorqueModel
from ..trajectory import HIST_BINS, Trajectory, summary_dict

#: Steps per compiled call; between chunks Ctrl-C is honoured and progress reported.
CHUNK_STEPS = 1 << 18
#: Steps per chunk of the Python loop that serves a torque callable.
CALLABLE_CHUNK_STEPS = 1 << 12

EPS = float(np.finfo(np.float64).eps)
METHOD_NAMES = {code: name for name, code in METHODS.items()}

TorqueCallable = Callable[[float, np.ndarray, np.ndarray], Any]

_NO_HIST = np.zeros(0)
_NO_CODES = np.zeros((0, 2), dtype=np.int64)

#: Resolutions of the solver's record (``solver_record=``): largest per saved interval, or every step.
SOLVER_RECORDS = ("interval", "full")


def _cold_start_factors(code: int, J: np.ndarray) -> tuple[float, ...] | None:
    """The cofactors of ``J`` and the scale of the kernels' cold start
    (:func:`lgvi._kernels.solvers.initial_guess`), in Python floats: its operations in its order,
    so the same bits. ``None`` when any is not finite (a huge or tiny ``J``): then the kernel's
    own source runs, with NumPy's warnings."""
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = J.tolist()
    c00 = j11 * j22 - j12 * j21
    c01 = j12 * j20 - j10 * j22
    c02 = j10 * j21 - j11 * j20
    c10 = j02 * j21 - j01 * j22
    c11 = j00 * j22 - j02 * j20
    c12 = j01 * j20 - j00 * j21
    c20 = j01 * j12 - j02 * j11
    c21 = j02 * j10 - j00 * j12
    c22 = j00 * j11 - j01 * j10
    det = j00 * c00 + j01 * c01 + j02 * c02
    if det == 0.0 or not math.isfinite(det + c00 + c01 + c02 + c10 + c11 + c12 + c20 + c21 + c22):
        return None
    scale = 1.0 / det
    if code == METHOD_CAYLEY:
        scale *= 0.5
    if not math.isfinite(scale):
        return None
    return c00, c01, c02, c10, c11, c12, c20, c21, c22, scale


def _cold_start(factors: tuple[float, ...] | None, code: int, J: np.ndarray, h: float, Pi: np.ndarray,
                g: np.ndarray) -> None:
    """``g`` (3,) = the kernels' cold start of the step ``h`` from ``Pi`` (``initial_guess(code, J,
    h * Pi, g)``, bit for bit), from the :func:`_cold_start_factors` of ``J``."""
    if factors is not None:
        c00, c01, c02, c10, c11, c12, c20, c21, c22, scale = factors
        p0, p1, p2 = Pi.tolist()
        x, y, z = h * p0, h * p1, h * p2          # h * Pi
        g0 = (c00 * x + c10 * y + c20 * z) * scale
        g1 = (c01 * x + c11 * y + c21 * z) * scale
        g2 = (c02 * x + c12 * y + c22 * z) * scale
        if math.isfinite(g0 + g1 + g2):
            g[0], g[1], g[2] = g0, g1, g2
            return
    from .._kernels.solvers import initial_guess

    # the kernel's Python source: the same IEEE operations (so the same bits as the compiled
    # ensemble path), without loading one more compiled function on a run's first call
    getattr(initial_guess, "py_func", initial_guess)(code, J, h * Pi, g)


def _solver_state(code: int, body: RigidBody, h: float, Pi: np.ndarray) -> np.ndarray:
    """Solver history ``G`` (5,3) of the stepping kernels (row 4: the low part of ``Pi``, zero), cold-started
    from the linearisation."""
    G = np.zeros((5, 3))
    _cold_start(_cold_start_factors(code, body.J), code, body.J, h, Pi, G[0])
    return G


def _solver_states(code: int, body: RigidBody, hs: np.ndarray, Pi: np.ndarray) -> np.ndarray:
    """:func:`_solver_state` for each substep ``hs[i]``, (s, 5, 3), filled in place (no stack)."""
    G = np.zeros((len(hs), 5, 3))
    factors = _cold_start_factors(code, body.J)
    for i, hi in enumerate(hs.tolist()):
        _cold_start(factors, code, body.J, hi, Pi, G[i, 0])
    return G


def cold_start_histories(code: int, J: np.ndarray, ib: np.ndarray, hs: np.ndarray, Pi: np.ndarray,
                         G: np.ndarray) -> None:
    """The cold start of :func:`_solver_state` for a stack of bodies, in place: ``G[b, i, 0]`` from
    ``J[ib[b]]``, ``hs[i]`` and ``Pi[b]`` (``G`` (B, s, 5, 3) zero on entry), the same bits as the
    compiled ``ensemble_kernels.init_histories`` (a few microseconds a history, nothing compiled)."""
    factors = [_cold_start_factors(code, Jq) for Jq in J]
    for b in range(len(Pi)):
        q = int(ib[b])
        for i, hi in enumerate(hs.tolist()):
            _cold_start(factors[q], code, J[q], hi, Pi[b], G[b, i, 0])


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


_options = run_solver_options


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


def step(body: Any, R: Any, Pi: Any, *, h: float, u: Any = None, method: MethodName = "newton",
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
    from .._kernels.stepping import lgvi_step

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
        raise ConvergenceError(failure_message(st, res, its, abs(h) * float(np.linalg.norm(Pi)), tol, code, alpha),
                               residual=float(res), iterations=int(its))
    F = so3.cayley(G[0]) if SOLVER_METHODS[method].coordinates == "cayley" else so3.exp(G[0])
    return StepResult(R=Rn, Pi=Pin, F=F, iterations=int(its), residual=float(res))


def simulate(body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: float, steps: int | None = None,
             torque: Any = None, method: MethodName = "newton", tol: float = 1e-14,
             max_iter: int = 50, alpha: float = 1.0, save_every: int = 1, t0: float = 0.0,
             forcing: ForcingName = "paper", order: int = 2, composition: str | None = None,
             progress: Any = False, error_estimate: Any = False, error_warn: float | None = 0.01,
             solver_record: Literal["interval", "full"] = "interval",
             scheme: Literal["lgvi", "splitting", "rkmk4"] | None = None, wheels: Any = None,
             controller: Any = None, control_period: Any = None, environment: Any = None,
             magnetorquers: Any = None, duration: float | None = None, fsw: Any = None) -> Trajectory:
    r"""Simulate the attitude of a rigid body with the Lie group variational integrator.

    Each step solves ``hat(h Pi_k) = F_k Jd - Jd F_k^T`` for ``F_k`` in SO(3), then sets
    ``R_{k+1} = R_k F_k`` and ``Pi_{k+1} = F_k^T Pi_k + h u_k`` (the paper's equations).
    Potentials and ``forcing="symmetric"`` use the symmetric form below; ``order`` composes it.

    Parameters
    ----------
    body : RigidBody, lgvi.Spacecraft or array_like
        The body, or its inertia: ``(3,)`` principal moments or ``(3, 3)`` matrix; or a
        :class:`lgvi.Spacecraft` (body, wheels, magnetorquers, orbit, field, disturbances), which
        runs with its flight software ``fsw`` in the compiled loop (``docs/loop.md``; the result a
        :class:`lgvi.systems.spacecraft.SpacecraftTrajectory` with the records by name in
        ``signals``; ``torque``, ``wheels``, ``controller``, ``environment``, ``magnetorquers``,
        ``forcing``, ``scheme`` and ``error_estimate`` are then refused: the spacecraft and its
        flight software say all of it).
    R0 : (3, 3) array_like or scipy.spatial.transform.Rotation
        Initial attitude (body to inertial), a rotation to 1e-9 (to 1e-6: replaced by the
        nearest rotation, with an ``AttitudeWarning``).
    Pi0 : (3,) array_like, optional
        Initial body angular momentum. Give this or ``omega0``.
    omega0 : (3,) array_like, optional
        Initial body angular velocity (``Pi0 = J omega0``).
    h : float
        Step size, non-zero; ``h < 0`` integrates backwards in time.
    steps : int
        Number of steps, ``>= 0``. Give this or ``duration``.
    duration : float
        The time span instead of ``steps``: ``steps = duration / h``, which must be a whole
        number (``duration`` is signed like ``h``).
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

        With ``wheels=`` or ``controller=`` only one :class:`lgvi.torques.Compiled` model (e.g.
        :class:`lgvi.environment.OrbitGravityGradient`, not depending on ``Pi``) is taken, in the
        symmetric form inside the gyrostat's loop (``docs/gyrostat.md``).
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
    progress : bool or callable
        ``True`` draws a ``tqdm`` progress bar (on a terminal; a widget in Jupyter; nothing when
        stderr goes to a file or a log) between compiled chunks;
        a callable is called as ``progress(steps_done, steps)``; ``False`` (default) is silent.
    error_estimate : {False, True, "richardson"}
        ``True`` (or ``"richardson"``) runs the problem again at ``h/2`` (twice the steps, about
        3x the wall time in all) and stores the Richardson estimate of the global error in
        :attr:`Trajectory.error_estimate` (see :mod:`lgvi.accuracy`). Not for torque arrays.
    error_warn : float or None
        With ``error_estimate``: emit :class:`lgvi.AccuracyWarning` when the estimated final
        attitude error exceeds this many radians (default 0.01); ``None`` never warns.
    solver_record : {"interval", "full"}
        Resolution of the solver's record in ``iterations`` and ``residual``: ``"interval"``
        (default) the largest of each over the steps between two saved states, shape
        ``(M - 1,)``, so the result is sized by the saved states; ``"full"`` every step, shape
        ``(steps,)``. With ``save_every=1`` both are the per-step record. Run totals and a
        histogram of the iterations are kept either way (:attr:`Trajectory.solver_summary`).
    scheme : {None, "lgvi", "splitting", "rkmk4"}
        ``None`` (or ``"lgvi"``): the LGVI above and its compositions. ``"splitting"``: exact
        free-body flows and kicks of the torque model's moment ``M(t, R)`` (:mod:`lgvi.splitting`),
        for potentials and other moments of the attitude and time; ``order`` 2, 4 or 6 and
        ``composition`` a name in :data:`lgvi.registry.SPLITTINGS`. The solver options are unused
        (no implicit equation), the record's iterations and residuals are zero. ``"rkmk4"``: the
        gyrostat (with or without ``wheels``) by an explicit 4th-order Runge-Kutta-Munthe-Kaas
        method in Cayley coordinates, momentum-exact but not symplectic (``docs/gyrostat_rkmk.md``;
        ``composition`` its tableau, ``torque`` refused, iterations and residuals zero).
    wheels : lgvi.ReactionWheels, optional
        Balanced reaction wheels (a gyrostat, ``docs/gyrostat.md``); ``body`` is then the
        spacecraft with the wheels locked, ``Pi0`` the total body momentum. The result is a
        :class:`lgvi.systems.gyrostat.GyrostatTrajectory` (``wheel_speed``, ``wheel_torque``,
        ``wheel_momentum`` (M, N)). ``error_estimate`` as above; ``order=4, 6``
        compose the step, the wheel and controller torques held over each whole step.
        Deprecated, with ``controller``, ``control_period``, ``environment`` and
        ``magnetorquers``, where the compiled loop has an exact equivalent
        (:mod:`lgvi.systems.loop_keywords`): the call then runs that ``lgvi.Spacecraft`` and
        ``lgvi.FlightSoftware``, bit for bit the same run, returns a
        :class:`lgvi.systems.spacecraft.SpacecraftTrajectory` (a ``GyrostatTrajectory`` with the
        records) and warns with a ``DeprecationWarning`` naming them (``docs/loop.md``).
    controller : lgvi.control.Controller, optional
        Called every ``control_period`` (zero-order hold); :class:`lgvi.control.MRPFeedback`
        with a fixed target runs compiled, others from Python between compiled chunks.
    control_period : float, optional
        Seconds between controller calls, a positive multiple of ``|h|`` (with ``controller``).
    environment : object with ``sample(t) -> dict``, optional
        Sampled at the control rate and handed to the controller (see :mod:`lgvi.control`).
    magnetorquers : object with ``torque(dipole, B_body) -> (3,)``, optional
        Turns a controller's dipole into a body torque held over the control period.
    fsw : lgvi.FlightSoftware, optional
        With a :class:`lgvi.Spacecraft` as ``body``: its flight software (guidance, control,
        actuator maps, modes, estimator, each at its rate), compiled in the loop.

    Returns
    -------
    Trajectory
        ``M = steps // save_every + 1`` samples; ``iterations`` (summed over substeps) and
        ``residual`` (largest over substeps) per saved interval or per step (``solver_record``);
        ``potential`` for torque models with a conservative part; ``error_estimate`` when asked for.

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
    steps = steps_from(h, steps, duration)
    if fsw is None and type(body).__name__ != "Spacecraft":    # today's keywords onto the descriptions
        from .loop_keywords import KeywordsDeprecationWarning, describe, replacement

        described = describe(body, wheels=wheels, controller=controller, control_period=control_period,
                             environment=environment, magnetorquers=magnetorquers, torque=torque, scheme=scheme,
                             error_estimate=error_estimate)
        if described is not None:
            import warnings

            body, fsw = described
            warnings.warn(replacement(body, fsw), KeywordsDeprecationWarning, stacklevel=2)
            wheels = controller = control_period = environment = magnetorquers = scheme = None
            forcing = "paper"                   # the gyrostat takes either; the loop's step is the same
    if fsw is not None or type(body).__name__ == "Spacecraft":     # the compiled loop (lgvi.systems.spacecraft)
        from ..spacecraft import Spacecraft
        from .spacecraft import simulate_spacecraft

        if not isinstance(body, Spacecraft):
            raise TypeError(f"fsw= runs with a spacecraft: give body an lgvi.Spacecraft, got {type(body).__name__}")
        given = {name: value for name, value in (("torque", torque), ("wheels", wheels), ("controller", controller),
                                                 ("control_period", control_period), ("environment", environment),
                                                 ("magnetorquers", magnetorquers), ("scheme", scheme))
                 if value is not None}
        if forcing != "paper":
            given["forcing"] = forcing
        if error_estimate:
            given["error_estimate"] = error_estimate
        if given:
            raise ValueError(f"{', '.join(sorted(given))}: not with an lgvi.Spacecraft, whose description (wheels, "
                             "magnetorquers, orbit, disturbances) and flight software (fsw=) say all of it")
        return simulate_spacecraft(body, R0, Pi0, omega0=omega0, h=h, steps=steps, fsw=fsw, progress=progress,
                                   method=method, tol=tol, max_iter=max_iter, alpha=alpha, save_every=save_every,
                                   t0=t0, solver_record=solver_record, order=order, composition=composition)
    if wheels is not None or controller is not None or control_period is not None or environment is not None \
            or magnetorquers is not None or scheme == "rkmk4":   # the gyrostat (lgvi.systems.gyrostat)
        from .gyrostat import gyrostat_options, simulate_gyrostat

        if scheme is not None and scheme not in ("lgvi", "rkmk4"):
            raise ValueError(f"scheme={scheme!r} cannot be combined with wheels=, controller=, "
                             "environment= or magnetorquers=: reaction wheels and the control loop run "
                             "with the LGVI (scheme=None) or the explicit RKMK scheme (scheme='rkmk4')")
        if scheme == "rkmk4":
            from .gyrostat_rkmk import check_rkmk_options

            check_rkmk_options(torque=torque, order=order, composition=composition)
        else:
            gyrostat_options(torque=torque, forcing=forcing, order=order, composition=composition,
                             error_estimate=error_estimate)
        from .loop_keywords import as_given

        with as_given():        # its shadow run (error_estimate) stays the gyrostat too
            return simulate_gyrostat(body, R0, Pi0, omega0=omega0, h=h, steps=steps, wheels=wheels,
                                     controller=controller, control_period=control_period, environment=environment,
                                     magnetorquers=magnetorquers, progress=progress, method=method, tol=tol,
                                     max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0,
                                     solver_record=solver_record, order=order, composition=composition, torque=torque,
                                     error_estimate=error_estimate, error_warn=error_warn, scheme=scheme)
    estimate, warn = check_options(error_estimate, error_warn, torque)
    run_class = _Run
    if scheme is not None and scheme != "lgvi":
        choice(scheme, "scheme", SCHEMES)
        run_class = RIGID_BODY.runner(scheme)  # lgvi.splitting provides it (lgvi.systems.provide_run)
    run = run_class(body, R0, Pi0, omega0=omega0, h=h, steps=steps, torque=torque, method=method, tol=tol,
               max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0, forcing=forcing, order=order,
               composition=composition, solver_record=solver_record)
    steps, save_every = run.steps, run.save_every
    traj = drive(run, MemorySink(run), progress)  # lgvi.driver: chunks, progress, Ctrl-C, failures
    if estimate:  # a shadow run of this very function at h/2 (lgvi.accuracy)
        from ..accuracy import with_estimate

        traj = with_estimate(traj, dict(body=run.body, R0=R0, Pi0=Pi0, omega0=omega0, h=run.h, steps=steps,
                                        torque=torque, method=method, tol=tol, max_iter=max_iter, alpha=alpha,
                                        save_every=save_every, t0=t0, forcing=forcing, order=order,
                                        composition=composition, progress=progress, scheme=scheme), warn=warn,
                           stacklevel=2)
    return traj


class Run:
    """One validated simulation of a rigid body (:data:`lgvi.systems.rigid_body.RIGID_BODY`): the
    inputs, the kernel choice and the state carried across chunks, run by :func:`lgvi.driver.drive`.

    ``advance(n, ...)`` runs the next ``n`` steps (``n`` a multiple of ``save_every``) in place;
    ``k`` counts the steps done (after a failure: the index of the failed step). ``state()`` and
    ``load_state()`` carry everything the kernels keep between steps, so a run continued from a
    saved state is bit for bit the uninterrupted run.
    """
    tol: float
    t0: float
    sym: Any
    steps: int
    save_every: int
    params: np.ndarray
    max_iter: int
    h: float
    gam: np.ndarray
    cum: np.ndarray
    comp: Composition
    codes: np.ndarray
    code: int
    body: RigidBody
    alpha: float

    #: The system this run steps (its state layout sizes the driver's buffers).
    system = RIGID_BODY

    def __init__(self, body: Any, R0: Any, Pi0: Any, *, omega0: Any, h: Any, steps: Any, torque: Any,
                 method: str, tol: Any, max_iter: Any, alpha: Any, save_every: Any, t0: Any, forcing: Any,
                 order: Any, composition: Any, solver_record: Any = "interval") -> None:
        self.body = body = as_body(body)
        self.code, self.tol, self.max_iter, self.alpha = _options(method, tol, max_iter, alpha)
        self.R = as_rotation(R0, "R0").copy()
        self.Pi: np.ndarray = _initial_momentum(body, Pi0, omega0)
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        h, steps, save_every = self.h, self.steps, self.save_every
        choice(solver_record, "solver_record", SOLVER_RECORDS)
        self.full: Any = solver_record == "full"
        _check_memory(steps, save_every, self.full)
        # run totals of the solver (steps taken), the histogram filled by the kernels
        self.counts: np.ndarray = np.zeros(HIST_BINS, dtype=np.int64)
        self.it_total: int = 0
        self.res_max: float = 0.0
        self.last_its: int = 0      # iterations and residual of the last step tried (the failed one)
        self.last_res: float = 0.0
        self.new_chunk()
        choice(forcing, "forcing", FORCINGS)
        self.comp = comp = _composition(order, composition)
        self.sym = sym = forcing == "symmetric"
        self.U = np.zeros((0, 3))
        self.func: Any | None = None
        self.model: Any | None = None
        kind = torque_kind(torque)  # lgvi.registry: the one classification of torque=
        if kind == "model":
            self.model = torque
            if getattr(torque, "moment_func", None) is not None:
                torque.row()                  # lgvi.torques.Compiled: params (P,) for one body
                torque.check_sample(self.t0, self.R, self.Pi)     # its Python form, before the run
        elif kind == "callable":
            self.func = torque
        elif kind == "array":
            shape = (steps + 1, 3) if sym else (steps, 3)
            self.U = np.ascontiguousarray(as_float_array(torque, "torque", shape))
        self.kind = kind
        _check_order(comp, kind, forcing, self.model)
        self.meta: dict[str, Any] = {"method": method, "tol": self.tol, "max_iter": self.max_iter,
                                     "alpha": self.alpha, "save_every": save_every, "torque": kind,
                                     "forcing": forcing, "lgvi_version": __version__, "t0": self.t0,
                                     "order": comp.order, "solver_record": solver_record}
        if comp.order != 2:
            self.meta["composition"] = comp.name
        if self.model is not None:
            self.meta["torque_model"] = repr(self.model)
        self.meta["forcing"] = forcing_used(kind, forcing, self.model)
        if kind != "none":  # the free body's are implied by torque "none" (lgvi.invariants.declared)
            self.meta["invariants"] = declaration_of(self.model or torque)
        self.has_potential: bool = self.model is not None and any(m.conservative for m in self.model.terms)
        # the paper's scheme (and the free body at order 2) keeps the original kernels, bit for bit
        self.legacy: bool = comp.order == 2 and (kind == "none" or (kind in ("array", "callable") and not sym))
        self.k: int = 0
        self.M_cb: np.ndarray | None = None  # last moment of a callable with symmetric forcing
        if self.legacy:
            self.G = _solver_state(self.code, body, h, self.Pi)
        else:
            self.gam, self.cum = comp.arrays()
            self.G = _solver_states(self.code, body, self.gam * h, self.Pi)
            if self.func is None:
                self.codes, self.params = (self.model.encode() if self.model is not None
                                           else (_NO_CODES, np.zeros(0)))
                if sym:
                    self.A = _momentum_matrices(body, self.codes, self.params, self.gam * h, sym)
                else:   # the paper's forcing: what momentum_matrices returns, identities (s, 3, 3)
                    self.A = np.zeros((len(self.gam), 3, 3))
                    self.A[:, 0, 0] = self.A[:, 1, 1] = self.A[:, 2, 2] = 1.0
                self.S = np.zeros(7)
                self.gidx: np.ndarray = np.arange(len(self.gam), dtype=np.int64)
        base = CHUNK_STEPS if self.func is None else CALLABLE_CHUNK_STEPS
        self.chunk: Any = max(1, base // save_every) * save_every

    # ------------------------------------------------------------------ results
    def times(self, j0: int, j1: int) -> np.ndarray:
        """Times of samples ``j0 .. j1-1`` (the same floating-point values in every code path)."""
        return sample_times(self.t0, self.h * self.save_every, j0, j1)

    def potential(self, t: np.ndarray, R_saved: np.ndarray) -> np.ndarray | None:
        return self.model.potential(t, R_saved, self.body) if self.has_potential else None

    def trajectory(self, t, R_out, Pi_out, it_out, res_out, partial: bool = False,
                   summary: dict[str, Any] | None = None) -> Trajectory:
        meta = dict(self.meta, partial=True) if partial else dict(self.meta)
        if summary is None:
            summary = self.summary()
        meta["solver_summary"] = dict(summary, iterations_max=max(summary["iterations_max"],
                                                                  int(it_out.max()) if len(it_out) else 0))
        return Trajectory(t=t, R=R_out, Pi=Pi_out, inertia=self.body.J.copy(), iterations=it_out,
                          residual=res_out, h=self.h, potential=self.potential(t, R_out), meta=meta)

    # ------------------------------------------------------------------ solver totals
    def summary(self) -> dict[str, Any]:
        """Totals of the solver over the steps taken so far (see :attr:`Trajectory.solver_summary`)."""
        return summary_dict(self.counts, self.it_total, self.res_max)

    def new_chunk(self) -> None:
        """Start the totals of a new chunk (:meth:`chunk_summary`)."""
        self._mark = (self.counts.copy(), self.it_total)

    def chunk_summary(self) -> dict[str, Any]:
        """Totals of the steps taken since :meth:`new_chunk` (the largest residual: of the run so far)."""
        counts0, it0 = self._mark
        return summary_dict(self.counts - counts0, self.it_total - it0, self.res_max)

    def count_steps(self, its: np.ndarray, res: np.ndarray) -> None:
        """Add the steps taken, their iterations ``its`` and residuals ``res``, to the totals."""
        if len(its):
            self.counts += np.bincount(np.minimum(its, HIST_BINS - 1), minlength=HIST_BINS)
            self.it_total += int(its.sum())
            self.res_max = max(self.res_max, float(res.max()))

    def tally(self, status: int, it_sum: int, rmax: float, its: int, rn: float) -> None:
        """Add a kernel call's totals (``it_sum`` counts the failed step's iterations too)."""
        self.last_its, self.last_res = int(its), float(rn)
        self.it_total += int(it_sum) - (int(its) if status != OK else 0)
        self.res_max = max(self.res_max, float(rmax))

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any,
                where: str = "") -> Exception:
        k = self.k
        t_fail = self.t0 + k * self.h
        if status == USER_RAISED:         # lgvi.torques.Compiled: its function raised in the compiled loop
            return self.model.raised_error(k, t_fail, self.h, self.R, self.Pi, None, trajectory, where)
        hnorm = abs(self.h) * float(np.linalg.norm(self.Pi))
        hint = ""
        if self.legacy and self.func is None and self.kind == "none":
            h_ok = largest_step(self.body.Jd, self.Pi, self.h, METHOD_NAMES[self.code], tol=self.tol,
                                max_iter=self.max_iter)
            # the bisection finds the edge of what converges in max_iter; stay 10 % inside it
            hint = (f" At this state steps up to about h = {0.9 * h_ok:.4g} solve (the largest found is "
                    f"{h_ok:.4g})." if h_ok != 0.0 else " No step size solves at this state.")
        msg = (f"step {k} (t = {t_fail:g}) failed: " + failure_message(status, residual, iterations, hnorm, self.tol, self.code, self.alpha)
               + hint + f" The run up to step {k} is in .trajectory." + where)
        err = ConvergenceError(msg, residual=residual, iterations=iterations, step=k, time=t_fail,
                               trajectory=trajectory)
        return err

    # ------------------------------------------------------------------ state
    def state(self) -> dict[str, Any]:
        st: dict[str, Any] = {"k": self.k, "R": self.R.copy(), "Pi": self.Pi.copy(), "G": self.G.copy()}
        if not self.legacy and self.func is None:
            st["S"] = self.S.copy()
        if self.M_cb is not None:
            st["M_cb"] = self.M_cb.copy()
        return st

    def load_state(self, st: dict[str, Any]) -> None:
        self.k = int(st["k"])
        self.R[:] = np.asarray(st["R"], dtype=np.float64)
        self.Pi[:] = np.asarray(st["Pi"], dtype=np.float64)
        G = np.asarray(st["G"], dtype=np.float64)
        self.G[:] = 0.0
        self.G[..., :G.shape[-2], :] = G        # a state saved with 4 rows: no low part of Pi yet
        if "S" in st:
            self.S[:] = np.asarray(st["S"], dtype=np.float64)
        self.M_cb = np.asarray(st["M_cb"], dtype=np.float64) if "M_cb" in st else None

    # ------------------------------------------------------------------ stepping
    def advance(self, n: int, R_out, Pi_out, it_out, res_out, partial) -> int:
        """Run steps ``k .. k+n-1`` into the chunk buffers; returns the status (``k`` is updated).

        ``it_out``, ``res_out`` hold ``n`` entries (a record per step) or ``n // save_every``
        (per saved interval); the histogram and totals of the solver are updated either way.
        """
        from .._kernels.stepping import (METHOD_CAYLEY, METHOD_NEWTON, run_chunk, run_chunk_cayley, run_chunk_forced,
                                        run_chunk_newton)

        body = self.body
        if self.func is not None:
            runner = _run_callable if self.legacy else _run_callable_symmetric
            status, self.k = runner(self, n, R_out, Pi_out, it_out, res_out, partial)
        elif self.legacy:
            kernel = {METHOD_CAYLEY: run_chunk_cayley, METHOD_NEWTON: run_chunk_newton}.get(self.code, run_chunk)
            status, self.k, *tot = kernel(self.code, body.Jd, self.h, self.R, self.Pi, self.G, self.U, self.k, n,
                                          self.tol, self.max_iter, self.alpha, self.save_every, R_out, Pi_out,
                                          it_out, res_out, _NO_HIST, self.counts)
            self.tally(status, *tot)
        elif getattr(self.model, "moment_func", None) is not None:   # lgvi.torques.Compiled
            from .._kernels.user_kernels import guarded, run_chunk_user

            m = self.model
            status, self.k, *tot = run_chunk_user(guarded(m.moment_func), m.row(), np.zeros((3, 3)), np.zeros(3),
                                                  m.conservative, m.depends_on_momentum, self.code, body.Jd, body.J,
                                                  body.J_inv, self.h, self.t0, self.gam, self.cum, self.A, self.R,
                                                  self.Pi, self.G, self.gidx, self.S, self.codes, self.params,
                                                  int(self.sym), self.k, n, self.tol, self.max_iter, self.alpha,
                                                  self.save_every, self.save_every, R_out, Pi_out, it_out,
                                                  res_out, _NO_HIST,
                                                  self.counts)
            self.tally(status, *tot)
        else:
            status, self.k, *tot = run_chunk_forced(self.code, body.Jd, body.J, body.J_inv, self.h, self.t0,
                                                    self.gam, self.cum, self.A, self.R, self.Pi, self.G, self.gidx,
                                                    self.S, self.codes, self.params, self.U, int(self.sym), self.k, n,
                                                    self.tol, self.max_iter, self.alpha, self.save_every,
                                                    self.save_every, R_out, Pi_out, it_out, res_out, _NO_HIST,
                                                    self.counts)
            self.tally(status, *tot)
        return int(status)



provide_run(RIGID_BODY, Run)
provide_simulate(simulate)  # the shadow run of lgvi.accuracy.with_estimate (no import back up)
_Run = Run  # its name before the system seam (lgvi.systems.rigid_body)
_composition = composition_for
_check_order = check_composable
_momentum_matrices = momentum_matrices


def _call_torque(func, t, R, Pi, k, partial):
    try:
        u = func(t, R.copy(), Pi.copy())
    except KeyboardInterrupt:
        raise
    except Exception as exc:  # the user's own TorqueError too: it gets the step, time and trajectory
        raise TorqueError(f"the torque callable raised {type(exc).__name__} at step {k} (t = {t:g}): {exc}. "
                          f"The run up to step {k} is in .trajectory.", step=k, time=t,
                          trajectory=partial(k)) from exc
    try:
        return _check_torque_value(u, k, t)
    except TorqueError as exc:
        exc.trajectory = partial(k)
        raise


def _run_callable_symmetric(run: _Run, n: int, R_out, Pi_out, it_out, res_out, partial) -> tuple[int, int]:
    """Symmetric forcing (and compositions) for a Python torque callable, steps ``run.k .. +n-1``.

    Per substep: the compiled :func:`shifted_step` gives ``R_{k+1}`` and ``a = F^T (Pi_k + hs/2
    M_k)``; then ``Pi = a + hs/2 M(t_{k+1}, R_{k+1}, Pi)`` is solved by fixed-point iteration. The
    accepted ``Pi_{k+1}`` is the last point where ``M`` was evaluated, so ``M_{k+1}`` is exact for
    the next step (kept in ``run.M_cb``) and the momentum equation holds to ``tol``.
    """
    from .._kernels.stepping import shifted_step

    func, code, body, h, gam, cum = run.func, run.code, run.body, run.h, run.gam, run.cum
    R, Pi, G, t0, tol, max_iter, alpha = run.R, run.Pi, run.G, run.t0, run.tol, run.max_iter, run.alpha
    Jd = body.Jd
    s = len(gam)
    k0 = run.k
    rec = _CallableRecord(run, n, R_out, Pi_out, it_out, res_out, partial)
    partial = rec.partial
    try:
        for k in range(k0, k0 + n):
            R_start = R.copy()
            Pi_start = Pi.copy()
            M_start = run.M_cb
            its_sum = 0
            rmax = 0.0
            for i in range(s):
                hs = gam[i] * h
                t1 = t0 + (k + cum[i + 1]) * h
                if run.M_cb is None:
                    run.M_cb = _call_torque(func, t0 + (k + cum[i]) * h, R, Pi, k, partial)
                M = run.M_cb
                its, rn, st = shifted_step(code, Jd, body.J_inv, hs, R, Pi, G, i, M[0], M[1], M[2], tol, max_iter,
                                           alpha, _NO_HIST)
                its_sum += its
                rmax = max(rmax, rn)
                if st != OK:
                    rec.failed(k - k0, its_sum, rn)
                    R[:] = R_start
                    Pi[:] = Pi_start
                    run.M_cb = M_start
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
                    run.M_cb = M_start
                    t = t0 + k * h
                    raise ConvergenceError(
                        f"step {k} (t = {t:g}): the momentum equation Pi_(k+1) = F^T (Pi_k + h/2 M_k) + h/2 "
                        f"M(t_(k+1), R_(k+1), Pi_(k+1)) of the symmetric forcing did not converge by fixed-point "
                        f"iteration in max_iter={max_iter} evaluations (last change {change:.3g}); the torque "
                        f"callable depends too strongly on Pi for this step: reduce |h|. The run up to step "
                        f"{k} is in .trajectory.", residual=change, iterations=max_iter, step=k, time=t,
                        trajectory=partial(k))
                run.M_cb = M
                Pi[:] = P
            rec.step(k - k0, its_sum, rmax, R, Pi)
        return OK, k0 + n
    finally:
        rec.flush()


def _run_callable(run: _Run, n: int, R_out, Pi_out, it_out, res_out, partial) -> tuple[int, int]:
    """Per-step loop for a Python torque callable (paper forcing): Python calls the torque and one
    compiled step, steps ``run.k .. run.k + n - 1``."""
    from .._kernels.stepping import lgvi_step

    func, code, h, R, Pi, G, t0 = run.func, run.code, run.h, run.R, run.Pi, run.G, run.t0
    Jd, tol, max_iter, alpha = run.body.Jd, run.tol, run.max_iter, run.alpha
    k0 = run.k
    rec = _CallableRecord(run, n, R_out, Pi_out, it_out, res_out, partial)
    try:
        for k in range(k0, k0 + n):
            u = _call_torque(func, t0 + k * h, R, Pi, k, rec.partial)
            its, res, st = lgvi_step(code, Jd, h, R, Pi, G, u[0], u[1], u[2], tol, max_iter, alpha, _NO_HIST)
            if st != OK:
                rec.failed(k - k0, its, res)
                return st, k
            rec.step(k - k0, its, res, R, Pi)
        return OK, k0 + n
    finally:
        rec.flush()


class _CallableRecord:
    """The solver record of a Python-callable loop's chunk. Each step's iterations and residual go
    to a buffer (the caller's per-step record, or a scratch one); a saved sample takes its
    interval's largest; the run's totals are added once per chunk, and before a partial trajectory
    is built (:meth:`partial`), never per step."""

    def __init__(self, run: _Run, n: int, R_out, Pi_out, it_out, res_out, partial) -> None:
        self.run, self.R_out, self.Pi_out, self.it_out, self.res_out = run, R_out, Pi_out, it_out, res_out
        self.per_step = per_step = len(it_out) == n
        self.its = it_out if per_step else np.empty(n, np.int32)
        self.res = res_out if per_step else np.empty(n)
        self.done = self.counted = self.start = self.j = 0
        self.countdown = run.save_every
        self._partial = partial

    def failed(self, i: int, its: int, res: float) -> None:
        """Step ``i`` of the chunk failed: kept in a per-step record, not counted."""
        self.its[i], self.res[i] = its, res
        self.run.last_its, self.run.last_res = int(its), float(res)

    def step(self, i: int, its: int, res: float, R, Pi) -> None:
        """Step ``i`` of the chunk is done, the state is now ``(R, Pi)``."""
        self.its[i], self.res[i] = its, res
        self.done = i + 1
        self.countdown -= 1
        if self.countdown == 0:
            self.countdown = self.run.save_every
            j = self.j
            self.R_out[j] = R
            self.Pi_out[j] = Pi
            if not self.per_step:
                self.it_out[j] = self.its[self.start:self.done].max()
                self.res_out[j] = self.res[self.start:self.done].max()
            self.start = self.done
            self.j = j + 1

    def flush(self) -> None:
        """Add the steps not yet counted to the run's totals."""
        self.run.count_steps(self.its[self.counted:self.done], self.res[self.counted:self.done])
        self.counted = self.done

    def partial(self, k: int):
        """The run's partial trajectory up to step ``k`` (it reads the totals: count first)."""
        self.flush()
        return self._partial(k)


__all__ = ["COMPOSITIONS", "Composition", "DEFAULT_COMPOSITION", "Run", "StepResult", "simulate",
           "step"]
