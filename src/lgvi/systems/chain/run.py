r"""A chain of spherical pendulums on ``(S^2)^n``: the run the driver drives, its result, and
:func:`simulate_chain`.

The discrete Lagrangian (derivation in ``docs/two_spheres.md``; Lee, Leok and McClamroch, Int. J.
Numer. Meth. Engng 79 (2009) 1147)

    L_d = 1/(2h) sum_ij M_ij (q_i^+ - q_i) . (q_j^+ - q_j) - h/2 (U(q) + U(q^+))

gives a symmetric, second-order step that keeps every ``q_i`` on its sphere (it moves by
rotations) and conserves the angular momentum about the gravity axis to round-off
(:mod:`lgvi._kernels.chain_kernels`); compositions raise the order.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..._kernels.codes import NOT_CONVERGED, NOT_FINITE, SINGULAR
from ..._validation import as_float, as_float_array
from ..._version import __version__
from ...driver import MemorySink, Progress, check_memory, drive, time_grid
from ...registry import Composition, composition_for
from .. import CarriedState, Field, provide_run
from ..orbit import array_digest, read_result_npz, save_result_npz
from .model import (G0, chain_parameters, kinetic_energy, potential_energy, tangent_velocities, unit_directions,
                    velocities)
from .system import CHAIN, chain_invariants

#: Steps per compiled call (progress and Ctrl-C between chunks).
CHUNK_STEPS = 1 << 16
FORMAT = CHAIN.saved_as[0]


@dataclass
class ChainTrajectory:
    """The result of :func:`simulate_chain`, ``M`` samples of a chain of ``n`` links.

    Attributes
    ----------
    t : (M,) ndarray
        Sample times.
    q : (M, n, 3) ndarray
        Link directions (unit vectors, from each link's inner joint to its outer end).
    pi : (M, n, 3) ndarray
        Discrete angular momenta ``pi_i`` (``q_i . pi_i = 0``; ``sum_i pi_i`` is the angular
        momentum of the chain about the pivot).
    iterations, residual : (M - 1,) ndarray
        Largest Newton iterations and final residual over each saved interval.
    h : float
        Step.
    lengths, masses, link_masses : (n,) ndarray
        The chain.
    gravity : (3,) ndarray
        Gravity acceleration.
    meta : dict
        ``order``, ``composition``, ``invariants`` (the declaration), ``partial``...
    """

    t: np.ndarray
    q: np.ndarray
    pi: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    h: float
    lengths: np.ndarray
    masses: np.ndarray
    link_masses: np.ndarray
    gravity: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)

    ARRAYS = ("t", "q", "pi", "iterations", "residual", "lengths", "masses", "link_masses", "gravity")

    def __repr__(self) -> str:
        return (f"ChainTrajectory({self.q.shape[1]} links, {len(self.t)} samples, t = {self.t[0]:g} .. "
                f"{self.t[-1]:g}, h = {self.h:g}{', partial' if self.meta.get('partial') else ''})")

    @property
    def n_links(self) -> int:
        return int(self.q.shape[1])

    def _parameters(self) -> tuple[np.ndarray, np.ndarray]:
        return chain_parameters(self.lengths, self.masses, self.link_masses)

    @property
    def positions(self) -> np.ndarray:
        """Outer ends of the links ``x_i = sum_{k <= i} l_k q_k`` (M, n, 3), the pivot at the origin."""
        return np.cumsum(self.lengths[None, :, None] * self.q, axis=1)

    @property
    def orthogonality_error(self) -> np.ndarray:
        """``max_i ||q_i| - 1|`` (M,): the distance from the configuration space (round-off)."""
        return np.abs(np.linalg.norm(self.q, axis=2) - 1.0).max(axis=1)

    @property
    def qdot(self) -> np.ndarray:
        """Tangent velocities (M, n, 3) of the momenta (the inverse Legendre map)."""
        M, _ = self._parameters()
        return velocities(M, self.q, self.pi)

    @property
    def angular_momentum(self) -> np.ndarray:
        """Angular momentum about the pivot ``sum_i pi_i`` (M, 3)."""
        return self.pi.sum(axis=1)

    @property
    def vertical_momentum(self) -> np.ndarray:
        """Its component along gravity's axis (M,) (conserved to round-off; ``e3`` without gravity)."""
        gn = np.linalg.norm(self.gravity)
        axis = self.gravity / gn if gn > 0.0 else np.array([0.0, 0.0, -1.0])
        return -self.angular_momentum @ axis

    @property
    def kinetic_energy(self) -> np.ndarray:
        M, _ = self._parameters()
        return kinetic_energy(M, self.qdot)

    @property
    def potential_energy(self) -> np.ndarray:
        _, w = self._parameters()
        return potential_energy(w, self.gravity, self.q)

    @property
    def energy(self) -> np.ndarray:
        """Total energy (M,): kinetic (of the velocities of the momenta) plus gravity's potential."""
        return self.kinetic_energy + self.potential_energy

    def save(self, path: str | os.PathLike) -> None:
        """Write to ``path`` (``.npz``, atomically); :meth:`load` reads it back exactly."""
        arrays = {k: np.asarray(getattr(self, k)) for k in self.ARRAYS}
        arrays["scalars"] = np.array([self.h])
        save_result_npz(path, FORMAT, arrays, self.meta)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "ChainTrajectory":
        """Read a result written by :meth:`save` (ValueError naming the file if it is not one)."""
        arrays, meta = read_result_npz(path, FORMAT, cls.ARRAYS + ("scalars",))
        _check_shapes(arrays, ValueError, f"cannot read {FORMAT} result {path}: ")
        h = float(arrays.pop("scalars")[0])
        return cls(h=h, meta=meta, **arrays)


def _check_shapes(arrays: dict[str, np.ndarray], exc: type, prefix: str) -> None:
    M = len(arrays["t"])
    n = np.shape(arrays.get("lengths", arrays["q"][0] if len(arrays["q"]) else []))[0]
    want = {"q": (M, n, 3), "pi": (M, n, 3), "iterations": (max(M - 1, 0),), "residual": (max(M - 1, 0),)}
    for name in ("masses", "link_masses"):
        if name in arrays:
            want[name] = (n,)
    if "gravity" in arrays:
        want["gravity"] = (3,)
    for name, shape in want.items():
        a = np.asarray(arrays[name])
        if a.shape != shape or a.dtype.kind not in "iuf":
            raise exc(f"{prefix}field {name!r} must have shape {shape} of real numbers (M = {M} samples, n = {n} "
                      f"links), got shape {a.shape} and dtype {a.dtype}")


class ChainRun(CarriedState):
    """One validated run of :func:`simulate_chain` (driven by :func:`lgvi.driver.drive`)."""
    link_masses: np.ndarray
    w: np.ndarray
    n: int
    gam: np.ndarray

    system = CHAIN
    CARRIED = ("q", "pi", "hist", "hh")
    full = False          # records: the largest per saved interval
    label = "chain simulation"

    def __init__(self, lengths: Any, masses: Any, q0: Any, qdot0: Any = None, *, h: Any, steps: Any,
                 link_masses: Any = None, gravity: Any = (0.0, 0.0, -G0), order: Any = 2, composition: Any = None,
                 tol: Any = 1e-14, max_iter: Any = 30, save_every: Any = 1, t0: Any = 0.0) -> None:
        from ..._validation import as_int

        self.M, self.w = chain_parameters(lengths, masses, link_masses)
        n = self.n = len(self.w)
        self.lengths: np.ndarray = as_float_array(lengths, "lengths", (n,)).copy()
        self.masses: np.ndarray = as_float_array(masses, "masses", (n,)).copy()
        self.link_masses = np.zeros(n) if link_masses is None else as_float_array(link_masses, "link_masses",
                                                                                  (n,)).copy()
        self.gravity: np.ndarray = as_float_array(gravity, "gravity", (3,)).copy()
        self.q: np.ndarray = unit_directions(q0, n, "q0")
        qdot = tangent_velocities(qdot0, self.q, "qdot0")
        self.pi: np.ndarray = np.cross(self.q, self.M @ qdot)
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        self.comp: Composition = composition_for(order, composition)
        self.gam, _ = self.comp.arrays()
        self.tol: float = as_float(tol, "tol")
        if not 0.0 < self.tol < 1e-6:
            raise ValueError(f"tol must be in (0, 1e-6) (the largest Newton residual, an angle), got {tol!r}")
        self.max_iter: int = as_int(max_iter, "max_iter", minimum=1)
        check_memory(self.steps * n, self.save_every, False)
        self.chunk: int = max(self.save_every, (CHUNK_STEPS // self.save_every) * self.save_every)
        self.k: int = 0
        self.hist: np.ndarray = np.zeros((len(self.gam), 4, n))
        self.Minv: np.ndarray = np.linalg.inv(self.M)
        self.hh: np.ndarray = np.zeros((len(self.gam), 4))
        self.last = np.zeros(2)
        self.declaration: dict[str, dict[str, Any]] = chain_invariants({"gravity": self.gravity})
        self.meta: dict[str, Any] = {"system": CHAIN.name, "order": self.comp.order, "composition": self.comp.name,
                     "invariants": self.declaration, "t0": self.t0, "save_every": self.save_every,
                     "method": "newton (multipliers of the unit lengths)", "tol": self.tol,
                     "lgvi_version": __version__}
        self.initial: dict[str, Any] = {"q": self.q.tolist(), "pi": self.pi.tolist()}

    def layout(self) -> tuple[tuple[Field, ...], tuple[Field, ...]]:
        """The state fields with this chain's ``n`` (:func:`lgvi.systems.layout`)."""
        return tuple(Field(f.name, (self.n, 3), f.dtype, f.doc) for f in CHAIN.state), CHAIN.records

    def stream_meta(self) -> dict[str, Any]:
        """JSON metadata of a stream of this run: what :func:`chain_from_stream` needs and what
        identifies the run (compared on resume)."""
        return dict(self.meta, h=self.h, steps=self.steps, lengths=self.lengths.tolist(), masses=self.masses.tolist(),
                    link_masses=self.link_masses.tolist(), gravity=self.gravity.tolist(), max_iter=self.max_iter,
                    initial={k: array_digest(np.asarray(v)) for k, v in self.initial.items()})

    def advance(self, n: int, q_out, pi_out, it_out, res_out, partial) -> int:
        from ..._kernels.chain_kernels import run_chain

        if not hasattr(self, "_scratch"):     # D, Y, A, r, lambda (the kernel allocates nothing)
            links = self.n
            self._scratch = (np.empty((links, 3)), np.empty((links, 3)), np.empty((links, links)), np.empty(links),
                             np.empty(links))

        status, self.k = run_chain(self.M, self.Minv, self.w, self.gravity, self.gam, self.h, self.q, self.pi,
                                   self.hist, self.hh, self.k, n, self.tol, self.max_iter, self.save_every, q_out,
                                   pi_out, it_out, res_out, self.last, *self._scratch)
        return int(status)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = "") -> Exception:
        what = {NOT_FINITE: "the state became non-finite",
                SINGULAR: "the Newton matrix is singular (the step turns a link too far)",
                NOT_CONVERGED: f"Newton's method did not reach tol = {self.tol:g} in {iterations} iterations "
                               f"(residual {residual:.3e}); a larger max_iter or tol may also do"}.get(status, "")
        return self.step_failure(what, residual, iterations, trajectory, where)

    def trajectory(self, t, q, pi, it, res, partial: bool = False) -> ChainTrajectory:
        meta = dict(self.meta, partial=True) if partial else dict(self.meta)
        return ChainTrajectory(t=t, q=q, pi=pi, iterations=it, residual=res, h=self.h, lengths=self.lengths.copy(),
                               masses=self.masses.copy(), link_masses=self.link_masses.copy(),
                               gravity=self.gravity.copy(), meta=meta)


def chain_from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> ChainTrajectory:
    """The :class:`ChainTrajectory` of a stream folder (``System.from_stream``)."""
    par = {k: np.asarray(meta[k], dtype=np.float64) for k in ("lengths", "masses", "link_masses", "gravity")}
    _check_shapes(dict(arrays, **par), ValueError, "")
    return ChainTrajectory(t=arrays["t"], q=arrays["q"], pi=arrays["pi"], iterations=arrays["iterations"],
                           residual=arrays["residual"], h=float(meta["h"]), meta=dict(meta), **par)


def simulate_chain(lengths: Any, masses: Any, q0: Any, qdot0: Any = None, *, h: float, steps: int,
                   link_masses: Any = None, gravity: Any = (0.0, 0.0, -G0), order: int = 2,
                   composition: str | None = None, save_every: int = 1, t0: float = 0.0, tol: float = 1e-14,
                   max_iter: int = 30, progress: Any = False) -> ChainTrajectory:
    r"""Simulate a chain of ``n`` spherical pendulums hanging from a fixed pivot, on ``(S^2)^n``.

    The Lie group variational integrator on two-spheres (Lee, Leok and McClamroch 2009; the
    derivation is in ``docs/two_spheres.md``): each link direction ``q_i`` moves by a rotation, so
    it stays a unit vector to round-off, with no angles and no constraints; the angular momentum
    about the gravity axis is conserved to round-off and the energy has no drift. Second order
    (symmetric); ``order=4`` or ``6`` composes it.

    Parameters
    ----------
    lengths : (n,) array_like
        Link lengths, ``> 0``.
    masses : (n,) array_like
        Point masses at the outer ends of the links, ``> 0``.
    q0 : (n, 3) array_like
        Initial link directions, unit vectors (within ``1e-9``; up to ``1e-6`` off they are
        normalised with an :class:`lgvi.errors.AttitudeWarning`; further off, refused).
    qdot0 : (n, 3) array_like, optional
        Initial velocities ``dq_i/dt``, tangent to the spheres (``q_i . qdot_i = 0``); default rest.
    h : float
        Step, non-zero (``h < 0`` integrates backwards).
    steps : int
        Number of steps, ``>= 0``.
    link_masses : (n,) array_like, optional
        Masses of the links themselves, ``>= 0``, spread uniformly along each (thin rigid rods).
    gravity : (3,) array_like
        Gravity acceleration (default ``(0, 0, -9.80665)``: ``e3`` up).
    order : {2, 4, 6}
        Order; 4 and 6 by the registry's compositions (:data:`lgvi.registry.COMPOSITIONS`).
    composition : str, optional
        A composition of ``lgvi.registry.COMPOSITIONS`` of that order (default: the registry's).
    save_every : int
        Keep every ``save_every``-th state (must divide ``steps``).
    t0 : float
        Initial time.
    tol, max_iter
        Newton's method on the spheres: largest residual (an angle, rad) and iterations per step.
    progress : bool or callable
        As in :func:`lgvi.simulate`.

    Returns
    -------
    ChainTrajectory
        ``t`` (M,), ``q``, ``pi`` (M, n, 3); ``positions``, ``qdot``, ``energy``,
        ``angular_momentum``, ``vertical_momentum``; ``save``/``load``.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> q0 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]
    >>> qdot0 = [[0.0, 1.0, 0.0], [0.0, 0.0, 2.0], [1.0, 0.0, 0.0]]
    >>> traj = lgvi.simulate_chain([1.0, 0.5, 0.5], [1.0, 1.0, 1.0], q0, qdot0, h=1e-3, steps=2000)
    >>> L = traj.vertical_momentum
    >>> bool(np.abs(L - L[0]).max() < 1e-13)
    True
    """
    run = ChainRun(lengths, masses, q0, qdot0, h=h, steps=steps, link_masses=link_masses, gravity=gravity,
                   order=order, composition=composition, tol=tol, max_iter=max_iter, save_every=save_every, t0=t0)
    Progress(progress, 0)   # validates progress before any work
    return drive(run, MemorySink(run), progress=progress)


provide_run(CHAIN, ChainRun)

__all__ = ["ChainRun", "ChainTrajectory", "chain_from_stream", "simulate_chain"]
