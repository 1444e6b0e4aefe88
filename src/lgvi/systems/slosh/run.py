r"""A rigid hub with ``n`` spherical slosh pendulums on ``SO(3) x (S^2)^n``: the run the driver
drives, its result, and :func:`simulate_slosh` (derivation in ``docs/slosh.md``)."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..._kernels.codes import NOT_CONVERGED, NOT_FINITE, SINGULAR
from ..._validation import as_float, as_float_array, as_int, as_rotation
from ..._version import __version__
from ...body import RigidBody
from ...driver import MemorySink, Progress, check_memory, drive, time_grid
from ...registry import composition_for
from .. import CarriedState, Field, provide_run
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

    ARRAYS = ("t", "R", "Pi", "q", "pi", "iterations", "residual", "inertia", "pivots", "lengths", "masses",
              "damping")

    def __repr__(self) -> str:
        return (f"SloshTrajectory({self.q.shape[1]} pendulums, {len(self.t)} samples, t = {self.t[0]:g} .. "
                f"{self.t[-1]:g}, h = {self.h:g}{', partial' if self.meta.get('partial') else ''})")

    @property
    def n_pendulums(self) -> int:
        return int(self.q.shape[1])

    def parameters(self) -> dict[str, Any]:
        """The reduced system's constants (:func:`lgvi.systems.slosh.slosh_parameters`)."""
        return slosh_parameters(self.inertia, self.hub_mass, self.pivots, self.lengths, self.masses)

    @property
    def q_body(self) -> np.ndarray:
        """Pendulum directions in the hub frame ``R^T q`` (M, n, 3) (Basilisk's ``l_B / l``)."""
        return np.einsum("tba,tib->tia", self.R, self.q)

    def _velocities(self) -> tuple[np.ndarray, np.ndarray]:
        return velocities(self.parameters(), self.R, self.Pi, self.q, self.pi)

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
        """Total angular momentum about the centre of mass, inertial ``R Pi + sum_i pi_i`` (M, 3)."""
        return np.einsum("tab,tb->ta", self.R, self.Pi) + self.pi.sum(axis=1)

    @property
    def energy(self) -> np.ndarray:
        """Kinetic energy (M,) (relative to the centre of mass)."""
        W, vb = self._velocities()
        return kinetic_energy(self.parameters(), W, vb)

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
        arrays = {k: np.asarray(getattr(self, k)) for k in self.ARRAYS}
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


class SloshRun(CarriedState):
    """One validated run of :func:`simulate_slosh` (driven by :func:`lgvi.driver.drive`)."""

    system = SLOSH
    CARRIED = ("R", "Pi", "q", "pi", "hist", "hh")
    full = False
    label = "slosh simulation"

    def __init__(self, body: Any, hub_mass: Any, pivots: Any, lengths: Any, masses: Any, R0: Any, q0: Any,
                 qdot0: Any = None, *, omega0: Any = None, damping: Any = None, h: Any, steps: Any, order: Any = 2,
                 composition: Any = None, tol: Any = 1e-14, max_iter: Any = 30, save_every: Any = 1,
                 t0: Any = 0.0) -> None:
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
        self.Pi, self.pi = momenta(P, self.R, W, qb, vb)
        self.q = qb @ self.R.T
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
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

    def layout(self) -> tuple[tuple[Field, ...], tuple[Field, ...]]:
        """The state fields with this run's ``n``."""
        shapes = {"R": (3, 3), "Pi": (3,), "q": (self.n, 3), "pi": (self.n, 3)}
        return tuple(Field(f.name, shapes[f.name], f.dtype, f.doc) for f in SLOSH.state), SLOSH.records

    def stream_meta(self) -> dict[str, Any]:
        """JSON metadata of a stream of this run (what :func:`slosh_from_stream` needs, what identifies it)."""
        P = self.P
        return dict(self.meta, h=self.h, steps=self.steps, inertia=P["J0"].tolist(), hub_mass=P["hub_mass"],
                    pivots=P["pivots"].tolist(), lengths=P["lengths"].tolist(), masses=P["masses"].tolist(),
                    damping=self.damping.tolist(), max_iter=self.max_iter,
                    initial={k: array_digest(np.asarray(v)) for k, v in self.initial.items()})

    def advance(self, n: int, R_out, Pi_out, q_out, pi_out, it_out, res_out, partial) -> int:
        from ..._kernels.slosh_kernels import kick_workspace, run_slosh, workspace

        P = self.P
        if not hasattr(self, "_scratch"):
            self._scratch = (np.empty(self.n + 3), np.empty(self.n + 3, dtype=np.int64), workspace(self.n),
                             kick_workspace(self.n))
        status, self.k = run_slosh(P["Jd"], P["Jp"], P["c"], P["Ct"], P["M"], P["Minv"], self.kcoef,
                                   bool(self.kcoef.any()), self.sA, self.gam, self.h, self.R, self.Pi, self.q,
                                   self.pi, self.hist, self.hh, self.k, n, self.tol, self.max_iter,
                                   self.save_every, R_out, Pi_out, q_out, pi_out, it_out, res_out, self.last,
                                   *self._scratch)
        return int(status)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = "") -> Exception:
        what = {NOT_FINITE: "the state became non-finite",
                SINGULAR: "a linear system of the step is singular (the step turns the hub or a pendulum too far)",
                NOT_CONVERGED: f"Newton's method did not reach tol = {self.tol:g} in {iterations} iterations "
                               f"(residual {residual:.3e}); a larger max_iter or tol may also do"}.get(status, "")
        return self.step_failure(what, residual, iterations, trajectory, where)

    def trajectory(self, t, R, Pi, q, pi, it, res, partial: bool = False) -> SloshTrajectory:
        meta = dict(self.meta, partial=True) if partial else dict(self.meta)
        P = self.P
        return SloshTrajectory(t=t, R=R, Pi=Pi, q=q, pi=pi, iterations=it, residual=res, h=self.h,
                               inertia=P["J0"].copy(), hub_mass=P["hub_mass"], pivots=P["pivots"].copy(),
                               lengths=P["lengths"].copy(), masses=P["masses"].copy(), damping=self.damping.copy(),
                               meta=meta)


def slosh_from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> SloshTrajectory:
    """The :class:`SloshTrajectory` of a stream folder (``System.from_stream``)."""
    par = {k: np.asarray(meta[k], dtype=np.float64) for k in ("inertia", "pivots", "lengths", "masses", "damping")}
    _check_shapes(dict(arrays, **par), "")
    return SloshTrajectory(t=arrays["t"], R=arrays["R"], Pi=arrays["Pi"], q=arrays["q"], pi=arrays["pi"],
                           iterations=arrays["iterations"], residual=arrays["residual"], h=float(meta["h"]),
                           hub_mass=float(meta["hub_mass"]), meta=dict(meta), **par)


def simulate_slosh(body: Any, hub_mass: float, pivots: Any, lengths: Any, masses: Any, R0: Any, q0: Any,
                   qdot0: Any = None, *, omega0: Any = None, damping: Any = None, h: float, steps: int,
                   order: int = 2, composition: str | None = None, save_every: int = 1, t0: float = 0.0,
                   tol: float = 1e-14, max_iter: int = 30, progress: Any = False) -> SloshTrajectory:
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

    Returns
    -------
    SloshTrajectory
        ``t``, ``R``, ``Pi``, ``q``, ``pi``; ``q_body``, ``omega``, ``qdot_body``, ``energy``,
        ``angular_momentum``; ``save``/``load``.

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
                   save_every=save_every, t0=t0)
    Progress(progress, 0)
    return drive(run, MemorySink(run), progress=progress)


provide_run(SLOSH, SloshRun)

__all__ = ["SloshRun", "SloshTrajectory", "simulate_slosh", "slosh_from_stream"]
