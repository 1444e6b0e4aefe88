r"""A rigid body in a central gravity field, on ``R^3 x SO(3)``: :func:`simulate_orbit`.

The discrete Lagrangian (derivation in ``docs/orbit.md``)

    L_d = m / (2h) |x_{k+1} - x_k|^2 + (1/h) tr((I - F_k) Jd) - h/2 (U(x_k, R_k) + U(x_{k+1}, R_{k+1}))

gives an explicit (Verlet-like) update of the orbit and the LGVI update of the attitude, with one
evaluation of the force and the moment per step (:mod:`lgvi._kernels.orbit_kernels`). The run
object :class:`OrbitRun` is driven by :func:`lgvi.driver.drive`, so progress, Ctrl-C (partial
result in ``.trajectory``) and failures behave as for :func:`lgvi.simulate`.

Invariants (:mod:`lgvi.invariants`): the total angular momentum ``x x p + R Pi`` to round-off
(the discrete Lagrangian is invariant under rotations of the inertial frame); with ``J2`` (an
oblate central body, symmetric about the inertial ``e3``) its ``e3`` component; the energy
bounded (no drift). An extra ``torque`` breaks both.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .._kernels.codes import COLLISION, NOT_FINITE, OVERFLOW
from .._validation import as_float, as_float_array, as_rotation, choice
from ..accuracy import check_options, with_estimate
from .._version import __version__
from ..body import RigidBody
from ..errors import InitialContactError
from ..driver import MemorySink, Progress, check_memory, drive, initial_momentum, time_grid
from ..invariants import BOUNDED, EXACT
from . import CarriedState, Field, System, register

#: Steps per compiled call (progress and Ctrl-C between chunks).
CHUNK_STEPS = 1 << 18
#: Central-field potentials by name: the point-mass field, or with the body's second moments.
POTENTIALS = {"point": 0, "order2": 1}
#: ``potential=`` of :func:`simulate_orbit` as a type (the keys of ``POTENTIALS``).
OrbitPotential = Literal["point", "order2"]
FORMAT = "lgvi.orbit/1"


def positive_number(value: Any, name: str) -> float:
    x = as_float(value, name)
    if not x > 0.0:
        raise ValueError(f"{name} must be positive, got {value!r}")
    return x


def _invariants(config: Any) -> dict[str, dict[str, Any]]:
    """The declaration of a run: ``config`` a dict with ``J2`` (bool) and ``torque`` (bool)."""
    config = config or {}
    if config.get("torque"):
        return {}
    out: dict[str, dict[str, Any]] = {}
    out["angular_momentum_e3" if config.get("J2") else "angular_momentum"] = {"kind": EXACT}
    out["energy"] = {"kind": BOUNDED}
    return out


def _kernels() -> dict[str, Any]:
    from .._kernels import orbit_kernels

    return {"run_orbit": orbit_kernels.run_orbit, "central_force": orbit_kernels.central_force}


_RECORDS = (Field("iterations", (), np.int32, "largest solver iterations per saved interval"),
            Field("residual", (), np.float64, "largest final solver residual per saved interval"))

ORBIT = register(System(
    name="orbit",
    doc="a rigid body in a central field: position x (3,), momentum p (3,), attitude R (3, 3), body momentum Pi (3,)",
    state=(Field("x", (3,), doc="centre of mass position, inertial"),
           Field("p", (3,), doc="linear momentum m v, inertial"),
           Field("R", (3, 3), doc="attitude, body to inertial"),
           Field("Pi", (3,), doc="body angular momentum")),
    records=_RECORDS,
    kernels=_kernels,
    results=("t", "x", "p", "R", "Pi", "iterations", "residual", "h", "meta"),
    scenario_section="orbiting_body",
    run_factory=None,
    invariants=_invariants,
    from_stream=lambda meta, arrays, state: _from_stream(meta, arrays, state),
))


# ------------------------------------------------------------------------------------------------
# potential, energy and the continuous equations (NumPy; for results and references)
# ------------------------------------------------------------------------------------------------
def orbit_potential(x: np.ndarray, R: np.ndarray, mass: float, inertia: np.ndarray, mu: float,
                    potential: str = "order2", J2: float = 0.0, radius: float = 0.0) -> np.ndarray:
    """Potential energy ``U`` (M,) at positions ``x`` (M, 3) and attitudes ``R`` (M, 3, 3)."""
    x = np.asarray(x, dtype=np.float64)
    R = np.asarray(R, dtype=np.float64)
    r = np.linalg.norm(x, axis=-1)
    U = -mu * mass / r
    if potential == "order2":
        S = np.trace(inertia) / 2.0 * np.eye(3) - inertia
        b = np.einsum("...ji,...j->...i", R, x)
        bsb = np.einsum("...i,ij,...j->...", b, S, b)
        U = U + mu * np.trace(S) / (2.0 * r ** 3) - 1.5 * mu * bsb / r ** 5
    if J2:
        U = U + mass * mu * J2 * radius ** 2 * (3.0 * x[..., 2] ** 2 / r ** 2 - 1.0) / (2.0 * r ** 3)
    return U


def orbit_equations(mass: float, inertia: Any, mu: float, potential: str = "order2", J2: float = 0.0,
                    radius: float = 0.0, torque: Any = None):
    """The continuous equations, ``f(t, y)`` for ``y = (x, p, R (row-major), Pi)`` (18,):
    ``x' = p / m``, ``p' = -dU/dx``, ``R' = R hat(J^-1 Pi)``, ``Pi' = Pi x J^-1 Pi + M + u``
    (for a reference solution with :func:`scipy.integrate.solve_ivp`; ``torque`` a constant
    (3,) body moment or None)."""
    J = RigidBody(inertia).J
    J_inv = np.linalg.inv(J)
    S = np.trace(J) / 2.0 * np.eye(3) - J
    c2 = mu * J2 * radius ** 2
    u = np.zeros(3) if torque is None else np.asarray(torque, dtype=np.float64)

    def f(t: float, y: np.ndarray) -> np.ndarray:
        x, p, R, Pi = y[0:3], y[3:6], y[6:15].reshape(3, 3), y[15:18]
        r2 = x @ x
        r = np.sqrt(r2)
        g = mu * mass * x / r ** 3
        M = np.zeros(3)
        if potential == "order2":
            b = R.T @ x
            Sb = S @ b
            g = g - 3.0 * mu / r ** 5 * (R @ Sb) + mu / r ** 5 * (7.5 * (b @ Sb) / r2 - 1.5 * np.trace(S)) * x
            M = -3.0 * mu / r ** 5 * np.cross(b, Sb)
        if c2:
            g = g + mass * c2 / r ** 5 * (1.5 - 7.5 * x[2] ** 2 / r2) * x + np.array([0, 0, 3.0 * mass * c2 * x[2] / r ** 5])
        w = J_inv @ Pi
        Rd = R @ np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        return np.concatenate([p / mass, -g, Rd.ravel(), np.cross(Pi, w) + M + u])

    return f


# ------------------------------------------------------------------------------------------------
# results
# ------------------------------------------------------------------------------------------------
def save_result_npz(path: Any, fmt: str, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    from .._files import write_atomic

    meta = dict(meta)
    meta.setdefault("lgvi_version", __version__)
    header = json.dumps({"format": fmt, "meta": meta})
    write_atomic(os.fspath(path), lambda fh: np.savez(fh, __lgvi__=np.array(header), **arrays))


def read_result_npz(path: Any, fmt: str, names: tuple[str, ...]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``(arrays, meta)`` of a result written by :func:`save_result_npz` in format ``fmt``: the
    arrays ``names`` (an untrusted file is checked first), ValueError naming the file otherwise."""
    from .._untrusted import check_npz, load_json

    path = os.fspath(path)
    try:
        check_npz(path)     # no object arrays, no declared size beyond the file's bytes
        with np.load(path, allow_pickle=False) as z:
            header = load_json(str(z["__lgvi__"]), f"{path}: the '__lgvi__' header")
            arrays = {k: np.array(z[k]) for k in names}
    except Exception as exc:
        raise ValueError(f"cannot read {fmt} result {path}: {type(exc).__name__}: {exc}") from exc
    if header.get("format") != fmt:
        raise ValueError(f"{path} is not a {fmt} result (format {header.get('format')!r})")
    return arrays, header.get("meta", {})


def load_result_npz(path: Any, fmt: str, names: tuple[str, ...]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    arrays, meta = read_result_npz(path, fmt, names)
    M = arrays["t"].shape[0] if arrays["t"].ndim == 1 else -1
    per = 2 if fmt.startswith("lgvi.two_body") else 0
    want = {"x": (M,) + ((2, 3) if per else (3,)), "p": (M,) + ((2, 3) if per else (3,)),
            "R": (M,) + ((2, 3, 3) if per else (3, 3)), "Pi": (M,) + ((2, 3) if per else (3,)),
            "iterations": (max(M - 1, 0),), "residual": (max(M - 1, 0),)}
    for key, shape in want.items():
        a = arrays[key]
        if M < 0 or a.shape != shape or a.dtype.kind not in "iuf":
            raise ValueError(f"cannot read {fmt} result {path}: field {key!r} has shape {a.shape} and dtype "
                             f"{a.dtype}, expected shape {shape} of real numbers")
    return arrays, meta


def estimate_of(meta: dict[str, Any]) -> Any:
    """The :class:`lgvi.accuracy.ErrorEstimate` in ``meta["error_estimate"]``, or ``None``."""
    from ..accuracy import ErrorEstimate

    d = meta.get("error_estimate")
    return None if d is None else ErrorEstimate.from_dict(d)


@dataclass
class OrbitTrajectory:
    """The result of :func:`simulate_orbit`, ``M`` samples.

    Attributes
    ----------
    t : (M,) ndarray
        Sample times.
    x, p : (M, 3) ndarray
        Centre of mass position and linear momentum ``m v`` (inertial frame).
    R : (M, 3, 3) ndarray
        Attitude, body to inertial.
    Pi : (M, 3) ndarray
        Body angular momentum.
    iterations, residual : (M - 1,) ndarray
        Largest solver iterations and final residual over each saved interval.
    h, mass, mu : float
        Step, body mass, gravitational parameter of the central body.
    inertia : (3, 3) ndarray
        Body inertia about its centre of mass.
    meta : dict
        ``potential``, ``J2``, ``radius``, ``torque``, ``invariants`` (the declaration), ``partial``...
    """

    t: np.ndarray
    x: np.ndarray
    p: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    h: float
    mass: float
    inertia: np.ndarray
    mu: float
    meta: dict[str, Any] = field(default_factory=dict)

    ARRAYS = ("t", "x", "p", "R", "Pi", "iterations", "residual", "inertia")

    @property
    def error_estimate(self) -> Any:
        """The run's :class:`lgvi.accuracy.ErrorEstimate` (``simulate_orbit(..., error_estimate=True)``,
        from ``meta["error_estimate"]``) or ``None``."""
        return estimate_of(self.meta)

    @property
    def v(self) -> np.ndarray:
        """Velocity ``p / m`` (M, 3)."""
        return self.p / self.mass

    @property
    def omega(self) -> np.ndarray:
        """Body angular velocity ``J^-1 Pi`` (M, 3)."""
        return np.linalg.solve(self.inertia, self.Pi.T).T

    @property
    def spatial_momentum(self) -> np.ndarray:
        """Spin angular momentum ``R Pi`` (M, 3), inertial."""
        return np.einsum("kij,kj->ki", self.R, self.Pi)

    @property
    def orbital_momentum(self) -> np.ndarray:
        """Orbital angular momentum ``x x p`` (M, 3)."""
        return np.cross(self.x, self.p)

    @property
    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum ``x x p + R Pi`` (M, 3) about the central body."""
        return self.orbital_momentum + self.spatial_momentum

    @property
    def potential_energy(self) -> np.ndarray:
        m = self.meta
        return orbit_potential(self.x, self.R, self.mass, self.inertia, self.mu, m.get("potential", "order2"),
                               float(m.get("J2") or 0.0), float(m.get("radius") or 0.0))

    @property
    def kinetic_energy(self) -> np.ndarray:
        """``|p|^2 / (2 m) + Pi . J^-1 Pi / 2`` (M,)."""
        return 0.5 * np.einsum("ki,ki->k", self.p, self.p) / self.mass + 0.5 * np.einsum("ki,ki->k", self.Pi, self.omega)

    @property
    def energy(self) -> np.ndarray:
        """Total energy (M,): kinetic plus the potential of the run's field."""
        return self.kinetic_energy + self.potential_energy

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write to ``path`` (``.npz``, atomically); :meth:`load` reads it back exactly."""
        arrays = {k: np.asarray(getattr(self, k)) for k in self.ARRAYS}
        arrays["scalars"] = np.array([self.h, self.mass, self.mu])
        save_result_npz(path, FORMAT, arrays, self.meta)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "OrbitTrajectory":
        """Read a result written by :meth:`save` (ValueError naming the file if it is not one)."""
        arrays, meta = load_result_npz(path, FORMAT, cls.ARRAYS + ("scalars",))
        h, mass, mu = (float(v) for v in arrays.pop("scalars"))
        return cls(h=h, mass=mass, mu=mu, meta=meta, **arrays)


# ------------------------------------------------------------------------------------------------
# the run
# ------------------------------------------------------------------------------------------------
def extra_torque(torque: Any, steps: int, name: str = "torque") -> np.ndarray:
    """A validated extra body moment: ``None`` (zero), a constant (3,), or (steps + 1, 3) values at
    the grid times; returned as ``(1, 3)`` or ``(steps + 1, 3)``."""
    if torque is None:
        return np.zeros((1, 3))
    if callable(torque) or not hasattr(torque, "__len__"):
        raise TypeError(f"{name} must be None, a constant body moment (3,) or moments at the grid times "
                        f"(steps + 1, 3), got {type(torque).__name__}")
    arr = np.asarray(torque)
    if arr.shape == (3,):
        return as_float_array(torque, name, (3,)).reshape(1, 3).copy()
    if arr.ndim == 2 and arr.shape != (steps + 1, 3):
        raise ValueError(f"{name} given at the grid times must have shape (steps + 1, 3) = ({steps + 1}, 3), "
                         f"got {arr.shape}")
    return as_float_array(torque, name, (steps + 1, 3)).copy()


class OrbitRun(CarriedState):
    """One validated run of :func:`simulate_orbit` (driven by :func:`lgvi.driver.drive`)."""
    meta: dict[str, Any]
    tol: float
    max_iter: int

    system = ORBIT
    CARRIED = ('x', 'p', 'R', 'Pi', 'G', 'C')
    full = False          # records: the largest per saved interval
    label = "orbit simulation"

    def __init__(self, body: Any, mass: Any, x0: Any, v0: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None,
                 h: Any, steps: Any, mu: Any, potential: Any = "order2", J2: Any = None, radius: Any = None,
                 torque: Any = None, tol: Any = 1e-14, max_iter: Any = 50, save_every: Any = 1,
                 t0: Any = 0.0) -> None:
        from ..driver import run_solver_options

        self.body: RigidBody = body if isinstance(body, RigidBody) else RigidBody(body)
        self.mass: float = positive_number(mass, "mass")
        self.mu: float = positive_number(mu, "mu")
        self.potential: str = choice(potential, "potential", tuple(POTENTIALS))
        self.code: int = POTENTIALS[self.potential]
        self.x: np.ndarray = as_float_array(x0, "x0", (3,)).copy()
        if not np.linalg.norm(self.x) > 0.0:
            raise ValueError("x0 must be away from the central body (|x0| > 0), got the origin")
        self.p: np.ndarray = self.mass * as_float_array(v0, "v0", (3,))
        self.R = as_rotation(R0, "R0").copy()
        self.Pi: np.ndarray = initial_momentum(self.body, Pi0, omega0)
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        _, self.tol, self.max_iter, _ = run_solver_options("cayley", tol, max_iter, 1.0)
        self.radius: float = 0.0 if radius is None else positive_number(radius, "radius")
        if J2 is None:
            self.J2 = 0.0
        else:
            self.J2 = as_float(J2, "J2")
            if radius is None:
                raise ValueError(f"J2 needs the central body's equatorial radius: give radius= (same length unit "
                                 f"as x0); got J2={J2!r} and radius=None")
        r0 = float(np.linalg.norm(self.x))
        if r0 <= self.radius:
            raise InitialContactError(f"x0 is inside the central body: |x0| = {r0:.6g} <= radius = {self.radius:.6g} "
                                      "(the orbit must start outside it)", step=0, time=float(self.t0),
                                      distance=r0)
        self.contact: np.ndarray = np.zeros(3)
        self.U = extra_torque(torque, self.steps)
        self.has_torque: bool = torque is not None
        check_memory(self.steps, self.save_every, False)
        self.chunk: int = max(self.save_every, (CHUNK_STEPS // self.save_every) * self.save_every)
        self.k: int = 0
        self.G = np.zeros((1, 5, 3))
        self.G[0, 0] = 0.5 * self.h * (self.body.J_inv @ self.Pi)
        self.G[0, 3, 0] = 1.0
        self.C = np.zeros(7)
        self.last = np.zeros(2)
        self.hist: np.ndarray = np.zeros(0)
        self.declaration: dict[str, dict[str, Any]] = _invariants({"J2": self.J2 != 0.0, "torque": self.has_torque})
        self.meta = {"system": ORBIT.name, "potential": self.potential, "J2": self.J2, "radius": self.radius,
                     "torque": "none" if not self.has_torque else ("constant" if len(self.U) == 1 else "array"),
                     "invariants": self.declaration, "t0": self.t0, "save_every": self.save_every,
                     "method": "cayley", "tol": self.tol, "lgvi_version": __version__}
        self.initial: dict[str, Any] = {key: getattr(self, key).tolist() for key in ("x", "p", "R", "Pi")}

    def stream_meta(self) -> dict[str, Any]:
        """JSON-serialisable metadata of a stream of this run (:mod:`lgvi.io.streaming`): what
        :func:`_from_stream` needs and what identifies the run (compared on resume)."""
        return dict(self.meta, h=self.h, steps=self.steps, inertia=self.body.J.tolist(), mass=self.mass, mu=self.mu,
                    max_iter=self.max_iter, initial=self.initial, torque_values=array_digest(self.U))

    def advance(self, n: int, x_out, p_out, R_out, Pi_out, it_out, res_out, partial) -> int:
        from .._kernels.orbit_kernels import run_orbit

        status, self.k = run_orbit(self.code, self.body.Jd, self.mass, self.mu, self.mu * self.J2 * self.radius ** 2,
                                   self.h, self.x, self.p, self.R, self.Pi, self.G, self.C, self.U, self.k, n, self.tol,
                                   self.max_iter, self.save_every, x_out, p_out, R_out, Pi_out, it_out, res_out,
                                   self.hist, self.last, self.radius, self.contact)
        return int(status)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = "") -> Exception:
        if status == COLLISION:
            core = f"the central body (radius {self.radius:g})"
            return self.collision(self.contact, trajectory, where, core)
        what = {OVERFLOW: "the momentum after the step is not finite",
                NOT_FINITE: "the state became non-finite (the body reached the centre, or the step is far too large)",
                }.get(status, f"the attitude equation was not solved (status {status}, residual {residual:.3e}, "
                              f"{iterations} iterations)")
        return self.step_failure(what, residual, iterations, trajectory, where)

    def trajectory(self, t, x, p, R, Pi, it, res, partial: bool = False) -> OrbitTrajectory:
        meta = dict(self.meta, partial=True) if partial else dict(self.meta)
        return OrbitTrajectory(t=t, x=x, p=p, R=R, Pi=Pi, iterations=it, residual=res, h=self.h, mass=self.mass,
                               inertia=self.body.J.copy(), mu=self.mu, meta=meta)


def array_digest(a: np.ndarray) -> Any:
    """A short JSON-serialisable identity of ``a``: its values if small, else its shape and SHA-256."""
    import hashlib

    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.size <= 16:
        return a.tolist()
    return {"shape": list(a.shape), "sha256": hashlib.sha256(a.tobytes()).hexdigest()}


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> OrbitTrajectory:
    """The :class:`OrbitTrajectory` of a stream folder (``System.from_stream``)."""
    M = len(arrays["t"])
    for name, shape in (("x", (M, 3)), ("p", (M, 3)), ("R", (M, 3, 3)), ("Pi", (M, 3)), ("iterations", (M - 1,)),
                        ("residual", (M - 1,))):
        if arrays[name].shape != shape:
            raise ValueError(f"field {name!r} must have shape {shape} (M = {M} samples), got {arrays[name].shape}")
    return OrbitTrajectory(t=arrays["t"], x=arrays["x"], p=arrays["p"], R=arrays["R"], Pi=arrays["Pi"],
                           iterations=arrays["iterations"], residual=arrays["residual"], h=float(meta["h"]),
                           mass=float(meta["mass"]), inertia=np.asarray(meta["inertia"], dtype=np.float64),
                           mu=float(meta["mu"]), meta=dict(meta))


def simulate_orbit(body: Any, mass: float, x0: Any, v0: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None,
                   h: float, steps: int, mu: float, potential: OrbitPotential = "order2", J2: float | None = None,
                   radius: float | None = None, torque: Any = None, save_every: int = 1, t0: float = 0.0,
                   tol: float = 1e-14, max_iter: int = 50, progress: Any = False, error_estimate: Any = False,
                   error_warn: float | None = 0.01) -> OrbitTrajectory:
    r"""Simulate a rigid body in the gravity field of a central body (orbit and attitude coupled).

    Each step: the attitude by the LGVI (``hat(h mu_k) = F Jd - Jd F^T``, ``mu_k = Pi_k + h/2 M_k``),
    the orbit by the explicit variational (Verlet) update, one force and moment evaluation; see
    ``docs/orbit.md``. Second order; the total angular momentum ``x x p + R Pi`` is conserved to
    round-off (with ``J2``: its ``e3`` component), the energy has no drift.

    Parameters
    ----------
    body : RigidBody or array_like
        The body, or its inertia about the centre of mass (``(3,)`` or ``(3, 3)``).
    mass : float
        Body mass, ``> 0``.
    x0, v0 : (3,) array_like
        Initial position of the centre of mass relative to the central body, and velocity
        (inertial frame); ``|x0| > 0``.
    R0 : (3, 3) array_like or scipy Rotation
        Initial attitude, body to inertial.
    Pi0 : (3,) array_like, optional
        Initial body angular momentum; or give ``omega0`` (body angular velocity).
    h : float
        Step, non-zero (``h < 0`` integrates backwards).
    steps : int
        Number of steps, ``>= 0``.
    mu : float
        Gravitational parameter ``G M`` of the central body, ``> 0``.
    potential : {"order2", "point"}
        ``"order2"``: the second-order (MacCullagh) truncation of the body's potential, coupling
        orbit and attitude; ``"point"``: the body as a point mass (the attitude is free).
    J2 : float, optional
        Zonal harmonic of the central body (oblate about the inertial ``e3``), acting on the
        body's centre of mass; needs ``radius``.
    radius : float, optional
        Equatorial radius of the central body, ``> 0``: needed with ``J2``; with or without it, a
        step whose path enters the sphere of this radius raises :class:`lgvi.CollisionError`
        (default: the central body is a point).
    torque : None or array_like
        Extra body moment: a constant ``(3,)`` or its values at the grid times ``(steps + 1, 3)``
        (used at both ends of each step).
    save_every : int
        Keep every ``save_every``-th state (must divide ``steps``).
    t0 : float
        Initial time.
    tol, max_iter
        The attitude solve (Cayley form of the LGVI, relative tolerance).
    progress : bool or callable
        As in :func:`lgvi.simulate`.
    error_estimate : {False, True, "richardson"}
        Estimate the global error by a second run at ``h/2`` (:mod:`lgvi.accuracy`): attitude,
        body momentum and position (``position``, ``position_rel`` of the
        :class:`lgvi.accuracy.ErrorEstimate` in ``.error_estimate``); not with a torque given at
        the grid times.
    error_warn : float or None
        With ``error_estimate``: emit :class:`lgvi.AccuracyWarning` when the estimated final
        attitude error [rad] or the position error relative to the largest distance exceeds it.

    Raises
    ------
    lgvi.CollisionError
        At the step whose path enters the central body (``radius``) or passes its centre closer
        than the step's own length (a fall through the centre, or a step far too large for the
        approach), with the run up to that step in ``.trajectory``; a start inside the central
        body raises it (as a ``ValueError`` too) before any step.

    Returns
    -------
    OrbitTrajectory
        ``t`` (M,), ``x``, ``p`` (M, 3), ``R`` (M, 3, 3), ``Pi`` (M, 3); ``v``, ``omega``,
        ``energy``, ``angular_momentum`` (M, 3); ``save``/``load``.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> traj = lgvi.simulate_orbit([1.0, 2.0, 3.0], 10.0, [7000.0, 0, 0], [0, 7.546, 0], np.eye(3),
    ...                            omega0=[0, 0, 1e-3], h=10.0, steps=600, mu=398600.4418)
    >>> L = traj.angular_momentum
    >>> bool(np.abs(L - L[0]).max() < 1e-12 * np.abs(L[0]).max())
    True
    """
    estimate, warn = check_options(error_estimate, error_warn, None)
    run = OrbitRun(body, mass, x0, v0, R0, Pi0, omega0=omega0, h=h, steps=steps, mu=mu, potential=potential,
                   J2=J2, radius=radius, torque=torque, tol=tol, max_iter=max_iter, save_every=save_every, t0=t0)
    if estimate and len(run.U) > 1:
        raise ValueError("error_estimate needs the extra moment between the grid times (the shadow run steps at h/2), "
                         "but a torque of shape (steps + 1, 3) holds it at the grid times only; give a constant "
                         "torque (3,), or error_estimate=False")
    Progress(progress, 0)   # validates progress before any work
    traj = drive(run, MemorySink(run), progress=progress)
    if not estimate:
        return traj
    args = dict(body=run.body, mass=mass, x0=x0, v0=v0, R0=R0, Pi0=Pi0, omega0=omega0, h=run.h, steps=run.steps,
                mu=mu, potential=potential, J2=J2, radius=radius, torque=torque, save_every=run.save_every, t0=t0,
                tol=tol, max_iter=max_iter, progress=progress)
    return with_estimate(traj, args, warn=warn, stacklevel=2, order=2, runner=simulate_orbit,
                         position=lambda tr: tr.x)


def _provide() -> None:
    from . import provide_run

    provide_run(ORBIT, OrbitRun)


_provide()

__all__ = ["ORBIT", "OrbitRun", "OrbitTrajectory", "estimate_of", "orbit_equations", "orbit_potential", "simulate_orbit"]
