"""Splitting methods for perturbed rigid bodies: ``lgvi.simulate(..., scheme="splitting", order=p)``.

The Hamiltonian ``H = T(Pi) + U(t, R)`` is split into the free rigid body ``T``, whose flow is
computed exactly (elliptic functions, :mod:`lgvi._kernels.splitting_kernels`), and the
potential ``U``, whose flow is the kick ``Pi += tau M(t, R)`` (``R`` fixed). A symmetric
composition of these flows (:data:`lgvi.registry.SPLITTINGS`) is a symplectic, symmetric method
that stays exactly on SO(3) (each drift is a rotation, computed as one), conserves ``|Pi|``
across every drift, and keeps every component of the spatial momentum ``R Pi`` that the
potential's moment keeps (the kicks change ``R Pi`` by ``tau R M``). The error of a method of
classical order ``p`` made for near-integrable problems is ``O(eps h^s1 + eps^2 h^s2)``, with
``eps`` the size of the perturbation relative to the free body: small for a tumbling satellite
under gravity gradient. See ``docs/splitting.md``.

The ``axes-*`` splittings (``Splitting.base == "axes"``, ``order=8`` by default) split the free
body further into the rotations about its three principal axes (one sine and cosine each, exact
flows of ``Pi_i^2 / (2 I_i)``) and compose Strang's step to order 4, 6 or 8: for problems where
the moment is not small (the 3D pendulum, a librating satellite), cheap stages at the classical
order; the same structure (SO(3), ``|Pi|`` and ``R Pi`` across every rotation).

Moments that depend on ``Pi`` (damping, the PD controller, a ``Compiled`` model with
``momentum_dependent=True``), torque callables and torque arrays are not split here: use the LGVI
(``scheme=None``).
"""

from __future__ import annotations

import functools
import weakref
from typing import Any

import numpy as np

from ._kernels.codes import USER_RAISED
from ._validation import as_rotation, choice
from ._version import __version__
from .body import RigidBody
from .driver import check_memory, initial_momentum, run_solver_options, time_grid
from .errors import ConvergenceError
from .integrator import CHUNK_STEPS, SOLVER_RECORDS, Run, as_body
from .invariants import declaration_of
from .registry import FORCINGS, Splitting, splitting_for, torque_kind
from .systems import provide_run
from .systems.rigid_body import RIGID_BODY
from .trajectory import HIST_BINS

_NO_CODES = np.zeros((0, 2), dtype=np.int64)


#: id(body) -> (weak reference, principal_data) of each RigidBody seen while it lives (a body is
#: immutable: validated once, read-only arrays); a plain dict: a WeakKeyDictionary look-up costs 3 us
_PRINCIPAL: dict[int, tuple[weakref.ref, tuple]] = {}


def _forget(ref: weakref.ref, key: int, cache: dict = _PRINCIPAL) -> None:
    """The body behind ``ref`` died: drop its entry (no global looked up: safe at interpreter exit)."""
    if cache.get(key, (None,))[0] is ref:
        del cache[key]


def principal_data(body: Any) -> tuple[np.ndarray, np.ndarray, int, np.ndarray, bool]:
    """``(I, ax, symax, Pax, diag)`` of the kernels: principal moments per axis (3,), the axes of
    the smallest, middle, largest moment (3,) int64, the symmetry code (``-1`` distinct moments,
    ``0..2`` the odd axis of two equal moments, ``3`` a sphere), the principal axes (3, 3) and
    whether ``J`` is diagonal (then the body frame is the principal frame and ``Pax = I``).

    Computed once per :class:`lgvi.RigidBody` (it is immutable); each call returns new arrays."""
    if type(body) is RigidBody:
        key = id(body)
        hit = _PRINCIPAL.get(key)
        if hit is None or hit[0]() is not body:
            hit = _PRINCIPAL[key] = (weakref.ref(body, functools.partial(_forget, key=key)), _principal_data(body))
        I, ax, symax, Pax, diag = hit[1]
        return I.copy(), ax.copy(), symax, Pax.copy(), diag
    return _principal_data(body)


def _principal_data(body: Any) -> tuple[np.ndarray, np.ndarray, int, np.ndarray, bool]:
    J = np.array(body.J)
    diag = bool(np.count_nonzero(J - np.diag(np.diag(J))) == 0)
    if diag:
        moments = np.diag(J).copy()
        axes = np.eye(3)
    else:
        moments = np.array(body.principal_moments, dtype=np.float64)
        axes = np.array(body.principal_axes, dtype=np.float64)
    a, b, c = moments
    if a == b == c:
        symax = 3
    elif a == b:
        symax = 2
    elif b == c:
        symax = 0
    elif a == c:
        symax = 1
    else:
        symax = -1
    ax = np.argsort(moments, kind="stable").astype(np.int64)
    return moments, ax, symax, np.ascontiguousarray(axes), diag


_KERNELS: dict[bool, tuple[Any, Any]] = {}


def _kernels(axes: bool) -> tuple[Any, Any]:
    """The compiled loops ``(run, run_user)`` of the exact or (``axes``) the axis splittings,
    imported on a run's first step (importing this module loads no Numba); ``run_user`` takes the
    user's moment guarded (:func:`lgvi._kernels.user_kernels.guarded`)."""
    pair = _KERNELS.get(axes)
    if pair is None:
        from ._kernels.splitting_kernels import run_axes, run_axes_user, run_split, run_split_user

        _KERNELS[True], _KERNELS[False] = (run_axes, run_axes_user), (run_split, run_split_user)
        pair = _KERNELS[axes]
    return pair


class SplittingRun(Run):
    """A validated splitting run (``scheme="splitting"``), driven by :func:`lgvi.driver.drive` like
    :class:`lgvi.systems.rigid_body_run.Run`; it reuses that class's results and bookkeeping.

    Its record has no solver: ``iterations`` and ``residual`` are zero.
    """
    weight: np.ndarray
    tol: float
    t0: float
    symax: int
    steps: int
    split: Splitting
    save_every: int
    params: np.ndarray
    node: np.ndarray
    max_iter: int
    h: float
    drift: np.ndarray
    diag: bool
    codes: np.ndarray
    code: int
    body: RigidBody
    ax: np.ndarray
    alpha: float
    Pax: np.ndarray

    def __init__(self, body: Any, R0: Any, Pi0: Any, *, omega0: Any, h: Any, steps: Any, torque: Any,
                 method: str, tol: Any, max_iter: Any, alpha: Any, save_every: Any, t0: Any, forcing: Any,
                 order: Any, composition: Any, solver_record: Any = "interval") -> None:
        self.body = body = as_body(body)
        # the LGVI's solver options do not apply here, but stay validated (a typo is an error)
        self.code, self.tol, self.max_iter, self.alpha = run_solver_options(method, tol, max_iter, alpha)
        choice(forcing, "forcing", FORCINGS)
        if forcing != "paper":
            raise ValueError(f"forcing={forcing!r} chooses how the LGVI treats non-conservative moments; "
                             "scheme='splitting' kicks every moment and takes no forcing= (leave the default)")
        self.R = as_rotation(R0, "R0").copy()
        self.Pi: np.ndarray = initial_momentum(body, Pi0, omega0)
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        choice(solver_record, "solver_record", SOLVER_RECORDS)
        self.full: Any = solver_record == "full"
        check_memory(self.steps, self.save_every, self.full)
        self.counts: np.ndarray = np.zeros(HIST_BINS, dtype=np.int64)
        self.it_total = 0
        self.res_max: float = 0.0
        self.last_its = 0
        self.last_res: float = 0.0
        self.new_chunk()
        self.split = sp = splitting_for(order, composition)
        kind = torque_kind(torque)
        self.kind = kind
        self.func: Any | None = None
        self.model: Any | None = None
        self.legacy = False
        self.M_cb: np.ndarray | None = None
        if kind in ("callable", "array"):
            raise ValueError(f"scheme='splitting' takes torque=None or a torque model from lgvi.torques (its moment "
                             f"evaluated at the kicks in compiled code), got a torque {kind}; use the LGVI "
                             "(scheme=None) for callables and arrays, or write the moment as "
                             "lgvi.torques.Compiled")
        if kind == "model":
            if torque.depends_on_momentum:
                bad = ", ".join(repr(m) for m in torque.terms if m.depends_on_momentum) or repr(torque)
                raise ValueError(f"scheme='splitting' kicks moments M(t, R) of the attitude and time; {bad} depends "
                                 "on the angular momentum Pi. Use the LGVI (scheme=None) for damping and "
                                 "controllers")
            self.model = torque
            if getattr(torque, "moment_func", None) is not None:
                torque.row()
                torque.check_sample(self.t0, self.R, self.Pi)     # its Python form, before the run
        self.codes, self.params = self.model.encode() if self.model is not None else (_NO_CODES, np.zeros(0))
        self.I, self.ax, self.symax, self.Pax, self.diag = principal_data(body)
        self.drift, self.weight, self.node = sp.arrays()
        self.ws: np.ndarray = np.zeros(64)
        self.Rb: np.ndarray = np.zeros((3, 3))
        self.Pb: np.ndarray = np.zeros(3)
        self.Rs: np.ndarray = np.zeros((3, 3))
        self.Ps: np.ndarray = np.zeros(3)
        self.meta: dict[str, Any] = {"scheme": "splitting", "composition": sp.name, "order": sp.order,
                                     "eps_orders": list(sp.eps_orders), "save_every": self.save_every,
                                     "torque": kind, "lgvi_version": __version__, "t0": self.t0,
                                     "solver_record": solver_record}
        if self.model is not None:
            self.meta["torque_model"] = repr(self.model)
        if kind != "none":
            self.meta["invariants"] = declaration_of(self.model)
        self.has_potential: bool = self.model is not None and any(m.conservative for m in self.model.terms)
        self.k: int = 0
        self.chunk: int = max(1, CHUNK_STEPS // self.save_every) * self.save_every

    def state(self) -> dict[str, Any]:
        return {"k": self.k, "R": self.R.copy(), "Pi": self.Pi.copy()}

    def load_state(self, st: dict[str, Any]) -> None:
        self.k = int(st["k"])
        self.R[:] = np.asarray(st["R"], dtype=np.float64)
        self.Pi[:] = np.asarray(st["Pi"], dtype=np.float64)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any,
                where: str = "") -> Exception:
        k = self.k
        t_fail = self.t0 + k * self.h
        if status == USER_RAISED:         # lgvi.torques.Compiled: its function raised in the compiled loop
            return self.model.raised_error(k, t_fail, self.h, self.R, self.Pi, None, trajectory, where)
        return ConvergenceError(f"step {k} (t = {t_fail:g}) of the splitting failed: the torque model's moment "
                                "made the state non-finite (overflow); reduce |h| or check the model. The run up "
                                f"to step {k} is in .trajectory." + where, residual=float("nan"), iterations=0,
                                step=k, time=t_fail, trajectory=trajectory)

    def advance(self, n: int, R_out, Pi_out, it_out, res_out, partial) -> int:
        run_split, run_split_user = _kernels(self.split.base == "axes")

        args = (self.I, self.ax, self.symax, self.Pax, self.diag, self.body.J, self.drift, self.weight, self.node,
                self.h, self.t0, self.R, self.Pi, self.codes, self.params, self.k, n, self.save_every, R_out, Pi_out,
                self.ws, self.Rb, self.Pb, self.Rs, self.Ps)
        m = self.model
        k0 = self.k
        if m is not None and getattr(m, "moment_func", None) is not None:   # lgvi.torques.Compiled
            from ._kernels.user_kernels import guarded

            status, self.k = run_split_user(guarded(m.moment_func), m.row(), *args)
        else:
            status, self.k = run_split(*args)
        self.counts[0] += self.k - k0          # the record's histogram: steps with no solver iteration
        return int(status)


def free_flow(body: Any, R: Any, Pi: Any, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """The exact flow of the free rigid body over the time ``tau``: ``(R(tau), Pi(tau))``.

    Parameters
    ----------
    body : RigidBody or array_like
        The body (or its inertia).
    R : (3, 3) array_like
        Attitude at time 0 (body to inertial).
    Pi : (3,) array_like
        Body angular momentum at time 0.
    tau : float
        Time (any sign).

    Returns
    -------
    R : (3, 3) ndarray
    Pi : (3,) ndarray
    """
    from ._kernels.splitting_kernels import flow_once
    from ._validation import as_float, as_float_array

    body = as_body(body)
    R = as_rotation(R, "R").copy()
    Pi = as_float_array(Pi, "Pi", (3,)).copy()
    tau = as_float(tau, "tau")
    I, ax, symax, Pax, diag = principal_data(body)
    R = R @ Pax
    Pi = Pax.T @ Pi
    flow_once(I, ax, symax, R, Pi, tau, np.zeros(64))
    return R @ Pax.T, Pax @ Pi


provide_run(RIGID_BODY, SplittingRun, scheme="splitting")  # lgvi.simulate(scheme="splitting") runs it

__all__ = ["SplittingRun", "free_flow", "principal_data"]
