r"""A rigid hub with ``n`` spherical slosh pendulums on ``SO(3) x (S^2)^n``: the run the driver
drives, its result, and :func:`simulate_slosh` (derivation in ``docs/slosh.md``)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..._kernels.codes import NOT_CONVERGED, NOT_FINITE, SINGULAR
from ..._validation import as_float, as_float_array, as_int, as_rotation
from ..._version import __version__
from ...body import RigidBody
from ...control import Controller, MRPFeedback
from ...driver import MemorySink, Progress, check_memory, drive, time_grid
from ...registry import composition_for
from .. import CarriedState, Field, provide_run
from ..gyrostat import ReactionWheels, controller_period_steps, mrp_params
from ..chain.model import tangent_velocities, unit_directions
from ..orbit import array_digest, read_result_npz, save_result_npz
from .model import kinetic_energy, momenta, slosh_parameters, velocities
from .system import SLOSH, slosh_invariants

#: Steps per compiled call (progress and Ctrl-C between chunks).
CHUNK_STEPS = 1 << 15
FORMAT = SLOSH.saved_as[0]


@dataclass
class SloshTrajectory:
    """The result of :func:`simulate_slosh`: ``M`` samples of a hub with ``n`` pendulums.

    Attributes
    ----------
    t : (M,) ndarray
        Sample times.
    R : (M, 3, 3) ndarray
        Hub attitude (body to inertial).
    Pi : (M, 3) ndarray
        The hub's momentum conjugate to its attitude, body frame (module ``model``:
        ``J' Omega + sum_j c_j x vb_j``, not the hub's own ``J0 Omega``).
    q : (M, n, 3) ndarray
        Pendulum directions, inertial unit vectors (pivot to mass); ``q_body`` in the hub frame.
    pi : (M, n, 3) ndarray
        Their angular momenta, inertial (``pi_i . q_i = 0``).
    iterations, residual : (M - 1,) ndarray
        Largest Newton iterations and final residual over each saved interval.
    h : float
        Step.
    inertia : (3, 3) ndarray
        The hub's inertia about its centre of mass.
    hub_mass : float
    pivots : (n, 3) ndarray
        Pivots in the body frame, from the hub's centre of mass.
    lengths, masses, damping : (n,) ndarray
    meta : dict
        ``order``, ``composition``, ``invariants``, ``partial``...
    """

    t: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    q: np.ndarray
    pi: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    h: float
    inertia: np.ndarray
    hub_mass: float
    pivots: np.ndarray
    lengths: np.ndarray
    masses: np.ndarray
    damping: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)
    wheel_momentum: np.ndarray | None = None
    wheel_torque: np.ndarray | None = None
    wheel_axes: np.ndarray | None = None
    spin_inertia: np.ndarray | None = None

    ARRAYS = ("t", "R", "Pi", "q", "pi", "iterations", "residual", "inertia", "pivots", "lengths", "masses",
              "damping")
    #: The arrays of a run with reaction wheels, saved after :attr:`ARRAYS` when there are wheels.
    WHEEL_ARRAYS = ("wheel_momentum", "wheel_torque", "wheel_axes", "spin_inertia")

    def __post_init__(self) -> None:
        M = len(self.t)
        N = 0 if self.wheel_axes is None else int(np.shape(self.wheel_axes)[0])
        if self.wheel_axes is None:
            self.wheel_axes = np.zeros((0, 3))
        if self.spin_inertia is None:
            self.spin_inertia = np.zeros(N)
        if self.wheel_momentum is None:
            self.wheel_momentum = np.zeros((M, N))
        if self.wheel_torque is None:
            self.wheel_torque = np.zeros((max(M - 1, 0), N))

    def __repr__(self) -> str:
        wheels = f", {self.n_wheels} wheels" if self.n_wheels else ""
        return (f"SloshTrajectory({self.q.shape[1]} pendulums{wheels}, {len(self.t)} samples, t = {self.t[0]:g} .. "
                f"{self.t[-1]:g}, h = {self.h:g}{', partial' if self.meta.get('partial') else ''})")

    @property
    def n_pendulums(self) -> int:
        return int(self.q.shape[1])

    @property
    def n_wheels(self) -> int:
        return int(self.wheel_axes.shape[0])

    def parameters(self) -> dict[str, Any]:
        """The reduced system's constants (:func:`lgvi.systems.slosh.slosh_parameters`); with wheels
        ``Jp`` is ``J'_B``, the locked inertia less the wheels' axial part (:func:`with_wheels`)."""
        P = slosh_parameters(self.inertia, self.hub_mass, self.pivots, self.lengths, self.masses)
        return with_wheels(P, self.wheel_axes, self.spin_inertia) if self.n_wheels else P

    @property
    def wheel_speed(self) -> np.ndarray:
        """Wheel speeds relative to the hub, rad/s (M, N): ``rho_i / Js_i - a_i . Omega``."""
        return self.wheel_momentum / self.spin_inertia - self.omega @ self.wheel_axes.T

    @property
    def q_body(self) -> np.ndarray:
        """Pendulum directions in the hub frame ``R^T q`` (M, n, 3) (Basilisk's ``l_B / l``)."""
        return np.einsum("tba,tib->tia", self.R, self.q)

    def _velocities(self) -> tuple[np.ndarray, np.ndarray]:
        Pi = self.Pi - self.wheel_momentum @ self.wheel_axes if self.n_wheels else self.Pi
        return velocities(self.parameters(), self.R, Pi, self.q, self.pi)

    @property
    def omega(self) -> np.ndarray:
        """Hub angular velocity, body frame (M, 3)."""
        return self._velocities()[0]

    @property
    def qdot_body(self) -> np.ndarray:
        """Rates of ``q_body``: the pendulums' motion relative to the hub, hub axes (M, n, 3)."""
        W, vb = self._velocities()
        return vb - np.cross(W[:, None, :], self.q_body)

    @property
    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum about the centre of mass, inertial ``R Pi + sum_i pi_i`` (M, 3) (``Pi``
        holds the wheels' momenta too)."""
        return np.einsum("tab,tb->ta", self.R, self.Pi) + self.pi.sum(axis=1)

    @property
    def energy(self) -> np.ndarray:
        """Kinetic energy (M,) (relative to the centre of mass; with wheels plus ``sum_i rho_i^2 / (2 Js_i)``)."""
        W, vb = self._velocities()
        T = kinetic_energy(self.parameters(), W, vb)
        if self.n_wheels:
            T = T + 0.5 * (self.wheel_momentum ** 2 / self.spin_inertia).sum(axis=1)
        return T

    @property
    def orthogonality_error(self) -> np.ndarray:
        """``||R^T R - I||_F`` (M,)."""
        E = np.einsum("tba,tbc->tac", self.R, self.R) - np.eye(3)
        return np.sqrt(np.einsum("tab,tab->t", E, E))

    @property
    def unit_error(self) -> np.ndarray:
        """``max_i ||q_i| - 1|`` (M,)."""
        return np.abs(np.linalg.norm(self.q, axis=2) - 1.0).max(axis=1)

    def save(self, path: str | os.PathLike) -> None:
        """Write to ``path`` (``.npz``, atomically); :meth:`load` reads it back exactly."""
        arrays = {k: np.asarray(getattr(self, k)) for k in self.ARRAYS + (self.WHEEL_ARRAYS if self.n_wheels else ())}
        arrays["scalars"] = np.array([self.h, self.hub_mass])
        save_result_npz(path, FORMAT, arrays, self.meta)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "SloshTrajectory":
        """Read a result written by :meth:`save`."""
        arrays, meta = read_result_npz(path, FORMAT, cls.ARRAYS + ("scalars",))
        _check_shapes(arrays, f"cannot read {FORMAT} result {path}: ")
        if np.shape(arrays["scalars"]) != (2,):
            raise ValueError(f"cannot read {FORMAT} result {path}: field 'scalars' must have shape (2,) (h, hub_mass), "
                             f"got {np.shape(arrays['scalars'])}")
        h, m0 = (float(x) for x in arrays.pop("scalars"))
        if meta.get("wheels"):
            wheels, _ = read_result_npz(path, FORMAT, cls.WHEEL_ARRAYS)
            _check_wheel_shapes(dict(arrays, **wheels), f"cannot read {FORMAT} result {path}: ")
            arrays.update(wheels)
        return cls(h=h, hub_mass=m0, meta=meta, **arrays)


def _check_shapes(arrays: dict[str, np.ndarray], prefix: str) -> None:
    """Refuse arrays (read from a file or a stream) whose shapes do not fit ``M`` samples of ``n``
    pendulums, with a ValueError naming the field."""
    M = len(arrays["t"])
    n = np.shape(arrays["lengths"])[0] if np.ndim(arrays["lengths"]) == 1 else -1
    want = {"R": (M, 3, 3), "Pi": (M, 3), "q": (M, n, 3), "pi": (M, n, 3), "iterations": (max(M - 1, 0),),
            "residual": (max(M - 1, 0),), "inertia": (3, 3), "pivots": (n, 3), "lengths": (n,), "masses": (n,),
            "damping": (n,)}
    for name, shape in want.items():
        a = np.asarray(arrays[name])
        if a.shape != shape or a.dtype.kind not in "iuf":
            raise ValueError(f"{prefix}field {name!r} must have shape {shape} of real numbers (M = {M} samples, "
                             f"n = {n} pendulums), got shape {a.shape} and dtype {a.dtype}")


def _check_wheel_shapes(arrays: dict[str, np.ndarray], prefix: str) -> None:
    """Refuse wheel arrays whose shapes do not fit ``M`` samples of ``N`` wheels."""
    M = len(arrays["t"])
    N = np.shape(arrays["spin_inertia"])[0] if np.ndim(arrays["spin_inertia"]) == 1 else -1
    want = {"wheel_momentum": (M, N), "wheel_torque": (max(M - 1, 0), N), "wheel_axes": (N, 3), "spin_inertia": (N,)}
    for name, shape in want.items():
        a = np.asarray(arrays[name])
        if a.shape != shape or a.dtype.kind not in "iuf":
            raise ValueError(f"{prefix}field {name!r} must have shape {shape} of real numbers (M = {M} samples, "
                             f"N = {N} wheels), got shape {a.shape} and dtype {a.dtype}")


def with_wheels(P: dict[str, Any], axes: np.ndarray, spin_inertia: np.ndarray) -> dict[str, Any]:
    """The constants ``P`` (:func:`slosh_parameters`) of a hub with balanced reaction wheels (axes
    (N, 3), spin inertias (N,)): ``Jp`` becomes ``J'_B = J' - G diag(Js) G^T`` and ``Jd``
    ``tr(J'_B)/2 I - J'_B``; the locked ``J'`` is kept as ``Jp_locked``."""
    JB = P["Jp"] - (axes.T * spin_inertia) @ axes
    JB = 0.5 * (JB + JB.T)
    return dict(P, Jp_locked=P["Jp"], Jp=JB, Jd=0.5 * np.trace(JB) * np.eye(3) - JB)


class SloshRun(CarriedState):
    """One validated run of :func:`simulate_slosh` (driven by :func:`lgvi.driver.drive`)."""

    system = SLOSH
    CARRIED = ("R", "Pi", "q", "pi", "hist", "hh", "wheel_momentum", "cmd", "cs", "u_now")
    full = False
    label = "slosh simulation"

    def __init__(self, body: Any, hub_mass: Any, pivots: Any, lengths: Any, masses: Any, R0: Any, q0: Any,
                 qdot0: Any = None, *, omega0: Any = None, damping: Any = None, h: Any, steps: Any, order: Any = 2,
                 composition: Any = None, tol: Any = 1e-14, max_iter: Any = 30, save_every: Any = 1,
                 t0: Any = 0.0, wheels: Any = None, controller: Any = None, control_period: Any = None,
                 wheel_torque: Any = None) -> None:
        J0 = (body if isinstance(body, RigidBody) else RigidBody(body)).J
        P = self.P = slosh_parameters(J0, hub_mass, pivots, lengths, masses)
        n = self.n = len(P["lengths"])
        if damping is None:
            self.damping = np.zeros(n)
        else:
            d = np.broadcast_to(as_float_array(damping, "damping"), (n,)) if np.ndim(damping) == 0 else \
                as_float_array(damping, "damping", (n,))
            self.damping = np.array(d, dtype=np.float64)
            bad = np.flatnonzero(~(self.damping >= 0.0))
            if bad.size:
                raise ValueError(f"damping must be >= 0 (N s/m, a force against the mass's velocity relative to "
                                 f"the hub), got damping[{bad[0]}] = {float(self.damping[bad[0]])!r}")
        self.R = as_rotation(R0, "R0").copy()
        qb = unit_directions(q0, n, "q0")
        rate = tangent_velocities(qdot0, qb, "qdot0")
        W = np.zeros(3) if omega0 is None else as_float_array(omega0, "omega0", (3,)).copy()
        vb = rate + np.cross(W[None, :], qb)
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        self._wheels(wheels, controller, control_period, wheel_torque)
        P = self.P
        self.Pi, self.pi = momenta(P, self.R, W, qb, vb)
        if self.N:
            # rho = Js (a . Omega + speed0); Pi = J'_B Omega + G rho + sum_j c_j x vb_j
            self.wheel_momentum = self.wheels.spin_inertia * (self.wheels.axes @ W + self.wheels.speed0)
            self.Pi = self.Pi + self.wheel_momentum @ self.wheels.axes
        self.q = qb @ self.R.T
        self.comp = composition_for(order, composition)
        self.gam, _ = self.comp.arrays()
        self.tol = as_float(tol, "tol")
        if not 0.0 < self.tol < 1e-6:
            raise ValueError(f"tol must be in (0, 1e-6) (the largest Newton residual, an angle), got {tol!r}")
        self.max_iter = as_int(max_iter, "max_iter", minimum=1)
        check_memory(self.steps * (n + 4), self.save_every, False)
        self.chunk = max(self.save_every, (CHUNK_STEPS // self.save_every) * self.save_every)
        self.k = 0
        S = len(self.gam)
        self.hist = np.zeros((S, 4, n + 3))      # (lambda, w) of each substep, last four steps
        self.hh = np.zeros((S, 4))
        self.last = np.zeros(2)
        self.kcoef = self.damping * P["lengths"] ** 2
        self.sA = float(np.trace(P["Jd"]))
        self.declaration = slosh_invariants({"damping": self.damping})
        self.meta = {"system": SLOSH.name, "order": self.comp.order, "composition": self.comp.name,
                     "invariants": self.declaration, "t0": self.t0, "save_every": self.save_every,
                     "method": "newton (rotation vector and multipliers of the unit lengths)", "tol": self.tol,
                     "lgvi_version": __version__}
        self.initial = {"R": self.R.copy(), "Pi": self.Pi.copy(), "q": self.q.copy(), "pi": self.pi.copy()}
        if self.N:
            self.initial["wheel_momentum"] = self.wheel_momentum.copy()
            self.meta.update(self.wheel_meta)
            self.meta["invariants"] = self.declaration = slosh_invariants(
                {"damping": self.damping, "motors": self.motors})

    def _wheels(self, wheels: Any, controller: Any, control_period: Any, wheel_torque: Any) -> None:
        """Validate the reaction wheels, the controller and the motor torques; set the run's wheel
        arrays (empty without wheels) and, with wheels, the hub constants less the wheels' axial
        inertia (:func:`with_wheels`)."""
        if wheels is not None and not isinstance(wheels, ReactionWheels):
            raise TypeError(f"wheels must be an lgvi.ReactionWheels, got {type(wheels).__name__}")
        N = self.N = 0 if wheels is None else len(wheels)
        self.wheels = wheels
        self.wheel_momentum = np.zeros(N)
        self.cmd = np.zeros(N)
        self.ucmd = np.zeros((0, N))
        self.u_now = np.zeros(2 * N)
        self.cs = np.zeros(5)
        self.cp = np.zeros(0)
        self.ctrl = 0
        self.axes = np.zeros((0, 3)) if wheels is None else wheels.axes.copy()
        self.wp = np.zeros((0, 8)) if wheels is None else wheels.params()
        # the wheel speeds matter each step only to a power or speed limit or to friction
        self.need_speed = bool(N and ((self.wp[:, 3] > 0.0).any() or (self.wp[:, 4] > 0.0).any()
                                      or wheels.has_friction))
        if N == 0:
            for name, value in (("controller", controller), ("control_period", control_period),
                                ("wheel_torque", wheel_torque)):
                if value is not None:
                    raise ValueError(f"{name} drives reaction wheels: give wheels= (an lgvi.ReactionWheels with at "
                                     f"least one wheel), got wheels={wheels!r}")
            self.spc = 1
            self.motors = False
            return
        P = self.P
        # the locked inertia J' (the hub's J0 includes the wheels) must hold the wheels' spin inertia
        wheels.hub_inertia(RigidBody(P["Jp"]))
        self.P = with_wheels(P, wheels.axes, wheels.spin_inertia)
        if controller is not None and wheel_torque is not None:
            raise ValueError("give either a controller or wheel_torque (the motors' commands), not both")
        self.spc = controller_period_steps(controller, control_period, self.h)
        ctrl_desc = None
        if controller is not None:
            if not isinstance(controller, Controller) or not getattr(controller, "compiled", False):
                raise TypeError("controller must be a controller the compiled loop evaluates (an "
                                "lgvi.control.MRPFeedback with a fixed target), got "
                                f"{type(controller).__name__}" + ("" if not isinstance(controller, MRPFeedback)
                                                                  else " with a target profile"))
            controller.setup(RigidBody(P["Jp"]), wheels)        # the law's inertia: the locked J'
            controller.reset()
            self.cp = mrp_params(controller, wheels)
            self.ctrl = 1
            ctrl_desc = {"K": controller.K, "P": controller.P, "Ki": controller.Ki,
                         "integral_limit": None if not math.isfinite(controller.integral_limit)
                         else controller.integral_limit, "inertia": np.asarray(controller.J).tolist(),
                         "target": None if controller.R_ref is None else controller.R_ref.tolist()}
        elif wheel_torque is not None:
            u = as_float_array(wheel_torque, "wheel_torque")
            if u.shape == (N,):
                self.cmd[:] = u
            elif u.shape == (self.steps, N):
                self.ucmd = u.copy()
                self.ctrl = 2
            else:
                raise ValueError(f"wheel_torque must have shape ({N},) (one motor torque per wheel, held) or "
                                 f"({self.steps}, {N}) (one row per step), N m; got shape {u.shape}")
        self.motors = controller is not None or wheel_torque is not None or bool(wheels.has_friction)
        self.wheel_meta = {"wheels": wheels.describe(), "controller": ctrl_desc,
                           "control_period": None if controller is None else self.spc * abs(self.h),
                           "wheel_torque": None if wheel_torque is None else array_digest(np.asarray(u))}

    def layout(self) -> tuple[tuple[Field, ...], tuple[Field, ...]]:
        """The fields with this run's ``n`` pendulums and ``N`` wheels (``N = 0``: empty wheel fields)."""
        shapes = {"R": (3, 3), "Pi": (3,), "q": (self.n, 3), "pi": (self.n, 3), "wheel_momentum": (self.N,),
                  "iterations": (), "residual": (), "wheel_torque": (self.N,)}
        return tuple(tuple(Field(f.name, shapes[f.name], f.dtype, f.doc) for f in fields)
                     for fields in (SLOSH.state, SLOSH.records))

    def stream_meta(self) -> dict[str, Any]:
        """JSON metadata of a stream of this run (what :func:`slosh_from_stream` needs, what identifies it)."""
        P = self.P
        return dict(self.meta, h=self.h, steps=self.steps, inertia=P["J0"].tolist(), hub_mass=P["hub_mass"],
                    pivots=P["pivots"].tolist(), lengths=P["lengths"].tolist(), masses=P["masses"].tolist(),
                    damping=self.damping.tolist(), max_iter=self.max_iter,
                    initial={k: array_digest(np.asarray(v)) for k, v in self.initial.items()})

    def advance(self, n: int, *buffers: np.ndarray) -> int:
        from ..._kernels.slosh_kernels import kick_workspace, run_slosh, workspace

        P = self.P
        R_out, Pi_out, q_out, pi_out, rho_out, it_out, res_out, u_out, partial = buffers
        if not hasattr(self, "_scratch"):
            self._scratch = (np.empty(self.n + 3), np.empty(self.n + 3, dtype=np.int64), workspace(self.n),
                             kick_workspace(self.n), np.zeros((3, 3)))
        status, self.k = run_slosh(P["Jd"], P["Jp"], P["c"], P["Ct"], P["M"], P["Minv"], self.kcoef,
                                   bool(self.kcoef.any()), self.sA, self.gam, self.h, self.t0, self.R, self.Pi,
                                   self.q, self.pi, self.wheel_momentum, self.hist, self.hh, self.k, n, self.tol,
                                   self.max_iter, self.save_every, self.axes, self.wp, self.need_speed, self.cmd,
                                   self.ucmd,
                                   self.u_now, self.ctrl, self.cp, self.cs, self.spc, R_out, Pi_out, q_out, pi_out,
                                   rho_out, it_out, res_out, u_out, self.last, *self._scratch)
        return int(status)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = "") -> Exception:
        what = {NOT_FINITE: "the state became non-finite",
                SINGULAR: "a linear system of the step is singular (the step turns the hub or a pendulum too far)",
                NOT_CONVERGED: f"Newton's method did not reach tol = {self.tol:g} in {iterations} iterations "
                               f"(residual {residual:.3e}); a larger max_iter or tol may also do"}.get(status, "")
        return self.step_failure(what, residual, iterations, trajectory, where)

    def trajectory(self, t, *arrays: np.ndarray, partial: bool = False) -> SloshTrajectory:
        meta = dict(self.meta, partial=True) if partial else dict(self.meta)
        P = self.P
        R, Pi, q, pi, rho, it, res, u = arrays
        wheels = {"wheel_momentum": rho, "wheel_torque": u, "wheel_axes": self.axes.copy(),
                  "spin_inertia": np.zeros(0) if self.wheels is None else self.wheels.spin_inertia.copy()}
        return SloshTrajectory(t=t, R=R, Pi=Pi, q=q, pi=pi, iterations=it, residual=res, h=self.h,
                               inertia=P["J0"].copy(), hub_mass=P["hub_mass"], pivots=P["pivots"].copy(),
                               lengths=P["lengths"].copy(), masses=P["masses"].copy(), damping=self.damping.copy(),
                               meta=meta, **wheels)


def slosh_from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> SloshTrajectory:
    """The :class:`SloshTrajectory` of a stream folder (``System.from_stream``)."""
    par = {k: np.asarray(meta[k], dtype=np.float64) for k in ("inertia", "pivots", "lengths", "masses", "damping")}
    _check_shapes(dict(arrays, **par), "")
    desc = meta.get("wheels") or {"axes": [], "spin_inertia": []}
    wheels = {"wheel_momentum": arrays["wheel_momentum"], "wheel_torque": arrays["wheel_torque"],
              "wheel_axes": np.asarray(desc["axes"], dtype=np.float64).reshape(-1, 3),
              "spin_inertia": np.asarray(desc["spin_inertia"], dtype=np.float64)}
    _check_wheel_shapes(dict(wheels, t=arrays["t"]), "")
    return SloshTrajectory(t=arrays["t"], R=arrays["R"], Pi=arrays["Pi"], q=arrays["q"], pi=arrays["pi"],
                           iterations=arrays["iterations"], residual=arrays["residual"], h=float(meta["h"]),
                           hub_mass=float(meta["hub_mass"]), meta=dict(meta), **par, **wheels)


def simulate_slosh(body: Any, hub_mass: float, pivots: Any, lengths: Any, masses: Any, R0: Any, q0: Any,
                   qdot0: Any = None, *, omega0: Any = None, damping: Any = None, h: float, steps: int,
                   order: int = 2, composition: str | None = None, save_every: int = 1, t0: float = 0.0,
                   tol: float = 1e-14, max_iter: int = 30, progress: Any = False, wheels: Any = None,
                   controller: Any = None, control_period: Any = None, wheel_torque: Any = None) -> SloshTrajectory:
    r"""Simulate a rigid hub carrying ``n`` spherical pendulums (propellant slosh), on ``SO(3) x (S^2)^n``.

    A Lie group variational integrator (derivation in ``docs/slosh.md``): the hub attitude moves
    by rotations ``R^+ = R F`` and each pendulum direction on its sphere, so ``R`` stays on SO(3)
    and every ``|q_i| = 1`` to round-off; without damping the total angular momentum is conserved
    to round-off and the energy error stays bounded; damping (a force ``-damping_i`` times the
    mass's velocity relative to the hub, as Basilisk's ``sphericalPendulum`` with ``D = d I``)
    lowers the energy and keeps the momentum. No external force or torque: the centre of mass of
    the spacecraft moves uniformly and is eliminated. Second order (symmetric); ``order=4`` or ``6``
    composes it.

    Parameters
    ----------
    body : RigidBody or array_like
        The hub's inertia about its own centre of mass (``(3,)`` or ``(3, 3)``), kg m^2.
    hub_mass : float
        The hub's mass, kg, ``> 0``.
    pivots : (n, 3) array_like
        Pendulum pivots in the body frame, from the hub's centre of mass, m.
    lengths, masses : (n,) array_like
        Rod lengths (m) and point masses (kg), ``> 0``.
    R0 : (3, 3) array_like or scipy Rotation
        Initial hub attitude (body to inertial).
    q0 : (n, 3) array_like
        Initial pendulum directions in the **body** frame (pivot to mass), unit vectors (within
        ``1e-9``; up to ``1e-6`` normalised with a warning; further off, refused).
    qdot0 : (n, 3) array_like, optional
        Their initial rates relative to the hub, body frame, tangent (``q0_i . qdot0_i = 0``).
    omega0 : (3,) array_like, optional
        Initial hub angular velocity, body frame, rad/s.
    damping : float or (n,) array_like, optional
        Damping coefficient of each pendulum, N s/m, ``>= 0``.
    h, steps, order, composition, save_every, t0, tol, max_iter, progress
        As in :func:`lgvi.simulate_chain`.
    wheels : lgvi.ReactionWheels, optional
        Balanced reaction wheels in the hub (``body`` is then the hub's inertia with the wheels
        locked, as for :func:`lgvi.simulate`); their absolute axial momenta are in the state
        (``wheel_momentum``), their motor torques are internal moments between wheel and hub, and
        the wheels' limits and friction apply as in the gyrostat (``docs/slosh.md``).
    controller : lgvi.control.MRPFeedback, optional
        The MRP feedback law evaluated in the compiled loop every ``control_period`` (a multiple of
        ``h``), its torque request mapped to the wheels; its inertia is the locked ``J'`` (the
        pendulum masses at their pivots) unless it was given one. Needs ``wheels``.
    wheel_torque : (N,) or (steps, N) array_like, optional
        Instead of a controller, the motors' commands, N m: held, or one row per step.

    Returns
    -------
    SloshTrajectory
        ``t``, ``R``, ``Pi``, ``q``, ``pi``; ``q_body``, ``omega``, ``qdot_body``, ``energy``,
        ``angular_momentum``; with wheels ``wheel_momentum`` (M, N), ``wheel_speed`` (M, N),
        ``wheel_torque`` (M - 1, N); ``save``/``load``.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> traj = lgvi.simulate_slosh([900.0, 800.0, 600.0], 1500.0, [[0.5, 0.0, 0.2]], [0.3], [40.0], np.eye(3),
    ...                            [[0.0, 0.0, -1.0]], [[0.1, 0.0, 0.0]], omega0=[0.01, 0.02, 0.3], h=0.01,
    ...                            steps=1000)
    >>> L = traj.angular_momentum
    >>> bool(np.abs(L - L[0]).max() < 1e-12 * np.abs(L[0]).max())
    True
    """
    run = SloshRun(body, hub_mass, pivots, lengths, masses, R0, q0, qdot0, omega0=omega0, damping=damping, h=h,
                   steps=steps, order=order, composition=composition, tol=tol, max_iter=max_iter,
                   save_every=save_every, t0=t0, wheels=wheels, controller=controller,
                   control_period=control_period, wheel_torque=wheel_torque)
    Progress(progress, 0)
    return drive(run, MemorySink(run), progress=progress)


provide_run(SLOSH, SloshRun)

__all__ = ["SloshRun", "SloshTrajectory", "simulate_slosh", "slosh_from_stream"]
