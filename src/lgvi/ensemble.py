"""Ensembles: many bodies propagated at once, the loop over bodies compiled and parallel.

:func:`simulate_ensemble` runs ``B`` bodies (each with its own inertia if wanted) through the
same attitude LGVI as :func:`lgvi.simulate`, in one compiled kernel that splits the bodies over
the machine's cores (Numba ``prange``). With ``client=`` (a ``dask.distributed.Client``) the
bodies are split into blocks that run on a Dask cluster; every body gives bit for bit the
trajectory :func:`lgvi.simulate` gives it, whichever path runs it.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ._validation import as_float, as_float_array, as_int, ROTATION_TOL
from ._version import __version__
from .body import RigidBody, check_inertia
from .errors import ConvergenceError, SimulationInterrupted
from .implicit import METHODS, failure_message
from .trajectory import Trajectory

#: Steps per compiled call (for all bodies); Ctrl-C is honoured between chunks.
CHUNK_STEPS = 1 << 14

ENSEMBLE_FORMAT = "lgvi.ensemble/1"


@dataclass(frozen=True, eq=False)
class EnsembleTrajectory:
    """``B`` simulated bodies sampled at the same ``M`` times (batch axis first).

    Attributes
    ----------
    t : (M,) ndarray
    R : (B, M, 3, 3) ndarray
    Pi : (B, M, 3) ndarray
    inertia : (B, 3, 3) ndarray
    iterations : (B,) ndarray of int
        Total solver updates of each body over the run.
    residual : (B,) ndarray
        Largest final residual of any step of each body.
    h : float
    meta : dict
    """

    t: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    inertia: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    h: float
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("t", "R", "Pi", "inertia", "iterations", "residual"):
            arr = np.asarray(getattr(self, name))
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.R.shape[0])

    def __repr__(self) -> str:
        return (f"EnsembleTrajectory(bodies={len(self)}, samples={len(self.t)}, h={self.h:g}, "
                f"method={self.meta.get('method', '?')!r})")

    def __getitem__(self, b: int) -> Trajectory:
        """Body ``b`` as a :class:`Trajectory` (without per-step solver records)."""
        b = int(b)
        if not -len(self) <= b < len(self):
            raise IndexError(f"body index {b} out of range for an ensemble of {len(self)}")
        return Trajectory(t=self.t, R=self.R[b], Pi=self.Pi[b], inertia=self.inertia[b],
                          iterations=np.zeros(0, dtype=np.int32), residual=np.zeros(0), h=self.h,
                          meta=dict(self.meta, body=b))

    @cached_property
    def omega(self) -> np.ndarray:
        """(B, M, 3) body angular velocity."""
        return np.linalg.solve(self.inertia[:, None], self.Pi[..., None])[..., 0]

    @cached_property
    def energy(self) -> np.ndarray:
        """(B, M) kinetic energy."""
        return 0.5 * np.einsum("bmi,bmi->bm", self.Pi, self.omega)

    @cached_property
    def spatial_momentum(self) -> np.ndarray:
        """(B, M, 3) inertial angular momentum ``R Pi``."""
        return np.einsum("bmij,bmj->bmi", self.R, self.Pi)

    def save(self, path: str | os.PathLike) -> None:
        """Write to ``.npz`` (exact round trip with :func:`load_ensemble`)."""
        header = json.dumps({"format": ENSEMBLE_FORMAT, "meta": self.meta})
        with open(os.fspath(path), "wb") as fh:
            np.savez(fh, __lgvi__=np.array(header), t=self.t, R=self.R, Pi=self.Pi, inertia=self.inertia,
                     iterations=self.iterations, residual=self.residual, h=np.float64(self.h))


def load_ensemble(path: str | os.PathLike) -> EnsembleTrajectory:
    """Read an ensemble written by :meth:`EnsembleTrajectory.save`."""
    path = os.fspath(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            header = json.loads(str(data["__lgvi__"]))
            if header.get("format") != ENSEMBLE_FORMAT:
                raise ValueError(f"{path} is not an lgvi ensemble (format {header.get('format')!r})")
            fields = {k: data[k] for k in ("t", "R", "Pi", "inertia", "iterations", "residual")}
            h = float(data["h"])
    except (OSError, KeyError, EOFError, json.JSONDecodeError) as exc:
        raise ValueError(f"cannot read ensemble {path}: {exc}") from exc
    return EnsembleTrajectory(h=h, meta=header.get("meta", {}), **fields)


def concatenate(parts: list[EnsembleTrajectory]) -> EnsembleTrajectory:
    """Join ensembles of the same run split by bodies, in order."""
    if not parts:
        raise ValueError("parts must hold at least one ensemble")
    first = parts[0]
    return EnsembleTrajectory(t=first.t, R=np.concatenate([p.R for p in parts]),
                              Pi=np.concatenate([p.Pi for p in parts]),
                              inertia=np.concatenate([p.inertia for p in parts]),
                              iterations=np.concatenate([p.iterations for p in parts]),
                              residual=np.concatenate([p.residual for p in parts]), h=first.h,
                              meta=dict(first.meta))


def _inertias(bodies: Any, B: int | None) -> np.ndarray:
    """(B, 3, 3) inertia matrices from a body, a list of bodies, or arrays of inertias."""
    if isinstance(bodies, RigidBody):
        J = bodies.J[None]
    elif isinstance(bodies, (list, tuple)) and bodies and all(isinstance(b, RigidBody) for b in bodies):
        J = np.stack([b.J for b in bodies])
    else:
        arr = as_float_array(bodies, "bodies")
        if arr.shape in ((3,), (3, 3)):
            J = RigidBody(arr).J[None]
        elif arr.ndim in (2, 3) and arr.shape[1:] in ((3,), (3, 3)):
            J = np.stack([check_inertia(a, name=f"bodies[{i}]") for i, a in enumerate(arr)])
        else:
            raise ValueError(f"bodies must be a RigidBody, a list of them, or inertias of shape (3,), (3,3), "
                             f"(B,3) or (B,3,3); got shape {arr.shape}")
    if B is not None and len(J) == 1:
        J = np.repeat(J, B, axis=0)
    if B is not None and len(J) != B:
        raise ValueError(f"bodies gives {len(J)} inertias but R0 has {B} attitudes")
    return J


def _rotations(R0: Any) -> np.ndarray:
    try:
        from scipy.spatial.transform import Rotation
        if isinstance(R0, Rotation):
            R0 = R0.as_matrix()
    except ImportError:  # pragma: no cover
        pass
    R = as_float_array(R0, "R0")
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise ValueError(f"R0 must have shape (B, 3, 3), got shape {R.shape}")
    err = np.linalg.norm(np.einsum("bki,bkj->bij", R, R) - np.eye(3), axis=(1, 2))
    det = np.linalg.det(R)
    bad = np.flatnonzero((err > ROTATION_TOL) | (det <= 0))
    if bad.size:
        b = int(bad[0])
        raise ValueError(f"R0[{b}] must be a rotation matrix (orthogonal to {ROTATION_TOL:g}, determinant +1); "
                         f"got orthogonality error {err[b]:.3g}, determinant {det[b]:.6g} ({bad.size} bad in all). "
                         "Use lgvi.so3.project(R0) for the nearest rotations.")
    return np.array(R, dtype=np.float64, order="C", copy=True)


def simulate_ensemble(bodies: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: float, steps: int,
                      torque: Any = None, method: str = "newton", tol: float = 1e-14, max_iter: int = 50,
                      alpha: float = 1.0, save_every: int = 1, threads: int | None = None,
                      client: Any = None, block_size: int | None = None,
                      out_dir: str | os.PathLike | None = None) -> EnsembleTrajectory | list[Path]:
    """Simulate ``B`` rigid bodies at once with the attitude LGVI.

    Parameters
    ----------
    bodies : RigidBody, sequence of RigidBody, or array_like
        One body for all, ``B`` bodies, or inertias ``(B, 3)`` / ``(B, 3, 3)``.
    R0 : (B, 3, 3) array_like or scipy Rotation stack
        Initial attitudes.
    Pi0, omega0 : (B, 3) array_like
        Initial body momenta or angular velocities (one of the two).
    h, steps, method, tol, max_iter, alpha, save_every
        As in :func:`lgvi.simulate`.
    torque : None
        Only the free body is supported by the ensemble kernel so far; anything else raises
        ``NotImplementedError``.
    threads : int, optional
        Numba threads for this call (default: all cores).
    client : dask.distributed.Client, optional
        Run blocks of ``block_size`` bodies as Dask tasks and gather them (``pip install lgvi[dask]``).
    block_size : int, optional
        Bodies per Dask task (default: the ensemble split into two blocks per worker).
    out_dir : path, optional
        With ``client``: each block writes ``ensemble-XXXXX.npz`` there and the paths are returned
        instead of the gathered ensemble (for ensembles larger than memory).

    Returns
    -------
    EnsembleTrajectory
        ``R`` (B, M, 3, 3), ``Pi`` (B, M, 3) with ``M = steps // save_every + 1`` (or the list of
        block files with ``out_dir``).

    Raises
    ------
    ConvergenceError
        If any body's implicit equation fails; ``err.trajectory`` holds the ensemble up to the
        first failing step (all bodies), ``err.step`` that step.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> rng = np.random.default_rng(0)
    >>> R0 = lgvi.so3.exp(0.1 * rng.normal(size=(8, 3)))
    >>> ens = lgvi.simulate_ensemble(lgvi.RigidBody([1., 2., 3.]), R0, omega0=rng.normal(size=(8, 3)),
    ...                              h=0.01, steps=100, save_every=10)
    >>> ens.R.shape, ens.Pi.shape
    ((8, 11, 3, 3), (8, 11, 3))
    """
    from .integrator import _options

    code, tol, max_iter, alpha = _options(method, tol, max_iter, alpha)
    R = _rotations(R0)
    B = R.shape[0]
    J = _inertias(bodies, B)
    if (Pi0 is None) == (omega0 is None):
        raise ValueError("give exactly one of Pi0 (B, 3) and omega0 (B, 3)")
    if Pi0 is not None:
        Pi = as_float_array(Pi0, "Pi0", (B, 3)).copy()
    else:
        Pi = np.einsum("bij,bj->bi", J, as_float_array(omega0, "omega0", (B, 3)))
    h = as_float(h, "h", nonzero=True)
    steps = as_int(steps, "steps", minimum=0)
    save_every = as_int(save_every, "save_every", minimum=1)
    if steps % save_every != 0:
        raise ValueError(f"save_every must divide steps so that the final state is saved; got steps={steps}, "
                         f"save_every={save_every}")
    if torque is not None:
        raise NotImplementedError("simulate_ensemble supports the free body only (torque=None) so far")
    if threads is not None:
        threads = as_int(threads, "threads", minimum=1)
    meta = {"method": method, "tol": tol, "max_iter": max_iter, "alpha": alpha, "save_every": save_every,
            "steps": steps, "lgvi_version": __version__}
    if client is not None:
        return _run_dask(client, J, R, Pi, h=h, steps=steps, method=method, tol=tol, max_iter=max_iter,
                         alpha=alpha, save_every=save_every, block_size=block_size, out_dir=out_dir)
    if out_dir is not None:
        raise ValueError("out_dir is used with client= (per-block files); for one process call .save()")
    return _run_local(code, J, R, Pi, h, steps, tol, max_iter, alpha, save_every, threads, meta)


def _run_local(code, J, R, Pi, h, steps, tol, max_iter, alpha, save_every, threads, meta) -> EnsembleTrajectory:
    import numba

    from ._kernels.ensemble_kernels import run_ensemble_chunk
    from ._kernels.solvers import OK, initial_guess

    B = R.shape[0]
    Jd = np.ascontiguousarray(0.5 * np.trace(J, axis1=1, axis2=2)[:, None, None] * np.eye(3) - J)
    M = steps // save_every + 1
    R_out = np.empty((B, M, 3, 3))
    Pi_out = np.empty((B, M, 3))
    R_out[:, 0] = R
    Pi_out[:, 0] = Pi
    G = np.zeros((B, 4, 3))
    for b in range(B):
        initial_guess(code, J[b], h * Pi[b], G[b, 0])
    its = np.zeros(B, dtype=np.int64)
    res = np.zeros(B)
    status = np.zeros(B, dtype=np.int64)
    fail_step = np.full(B, -1, dtype=np.int64)
    old_threads = numba.get_num_threads()
    k = 0

    def result(m: int, partial: bool = False) -> EnsembleTrajectory:
        return EnsembleTrajectory(t=h * save_every * np.arange(m), R=R_out[:, :m], Pi=Pi_out[:, :m],
                                  inertia=J, iterations=its, residual=res, h=h,
                                  meta=dict(meta, partial=partial) if partial else meta)

    try:
        if threads is not None:
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        while k < steps:
            n = min(CHUNK_STEPS, steps - k)
            run_ensemble_chunk(code, Jd, h, R, Pi, G, k, n, tol, max_iter, alpha, save_every,
                               R_out, Pi_out, its, res, status, fail_step)
            if np.any(status != OK):
                break
            k += n
    except KeyboardInterrupt:
        raise SimulationInterrupted(f"ensemble interrupted after {k} of {steps} steps; the computed part is "
                                    "in .trajectory", trajectory=result(k // save_every + 1, True)) from None
    finally:
        numba.set_num_threads(old_threads)
    failed = np.flatnonzero(status != OK)
    if failed.size:
        first = int(failed[np.argmin(fail_step[failed])])
        kf = int(fail_step[first])
        hn = abs(h) * float(np.linalg.norm(Pi[first]))
        msg = (f"body {first} failed at step {kf} (t = {kf * h:g}), {failed.size} of {B} bodies failed: "
               + failure_message(int(status[first]), float("nan"), max_iter, hn, tol))
        raise ConvergenceError(msg, step=kf, time=kf * h, trajectory=result(kf // save_every + 1, True))
    return result(M)


def _block_task(J, R, Pi, kwargs, path):
    ens = simulate_ensemble(J, R, Pi, **kwargs)
    if path is None:
        return ens
    ens.save(path)
    return path


def _run_dask(client, J, R, Pi, *, block_size, out_dir, **kwargs):
    B = R.shape[0]
    if block_size is None:
        try:
            workers = max(1, len(client.scheduler_info()["workers"]))
        except Exception:  # pragma: no cover - defensive: any client without that call
            workers = 1
        block_size = max(1, math.ceil(B / (2 * workers)))
    block_size = as_int(block_size, "block_size", minimum=1)
    futures = []
    for i, start in enumerate(range(0, B, block_size)):
        sl = slice(start, start + block_size)
        path = None
        if out_dir is not None:
            Path(out_dir).mkdir(parents=True, exist_ok=True)
            path = Path(out_dir) / f"ensemble-{i:05d}.npz"
        futures.append(client.submit(_block_task, J[sl], R[sl], Pi[sl], kwargs, path, pure=False))
    results = client.gather(futures)
    if out_dir is not None:
        return [Path(p) for p in results]
    return concatenate(results)


__all__ = ["EnsembleTrajectory", "concatenate", "load_ensemble", "simulate_ensemble"]
