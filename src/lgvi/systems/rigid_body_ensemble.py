"""Ensembles: many bodies propagated at once, the loop over bodies compiled and parallel.

:func:`simulate_ensemble` runs ``B`` bodies (each with its own inertia if wanted) through the
same attitude LGVI as :func:`lgvi.simulate`, the bodies split over the machine's cores (the free
body in one compiled kernel with a Numba ``prange`` loop; torque models and compositions in
contiguous ranges of bodies on a pool of threads, each running ``simulate``'s compiled loop, which
releases the GIL). With ``client=`` (a ``dask.distributed.Client``) the
bodies are split into blocks that run as Dask tasks; with ``out_dir=`` each block is written to
its own file, for ensembles larger than memory. Every body gives bit for bit the trajectory
:func:`lgvi.simulate` gives it, whichever path, thread or block runs it.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .._files import lgvi_header, write_atomic, write_failure
from .._kernels.codes import METHOD_CAYLEY, OK, USER_RAISED
from .._untrusted import check_npz, inside, load_json
from .._validation import REPAIR_TOL, ROTATION_TOL, as_float_array, as_int, choice, is_scipy_rotation, warn_repaired
from .._version import __version__
from ..body import RigidBody
from ..errors import ConvergenceError, SimulationInterrupted
from ..implicit import failure_message
from ..invariants import combine, declaration_of, forcing_used
from ..so3 import project
from ..registry import DeviceName, ForcingName, MethodName, torque_kind
from ..torques import tried_rows
from ..trajectory import ARRAY_FIELDS, Trajectory, freeze_arrays

#: Body-substeps per compiled call (about 0.1-0.5 s); Ctrl-C and progress are handled between calls.
CHUNK_BODY_STEPS = 1 << 22
#: Solver histories (bodies x substeps) up to which an ensemble cold-starts them in Python, as
#: lgvi.simulate does (beyond it, the compiled init_histories).
PYTHON_COLD_START_MAX = 4096
#: Bodies up to which an ensemble of built-in models calls the loop of lgvi.simulate
#: (``stepping.run_chunk_forced``) once a body from Python: its first call then compiles nothing beyond
#: what simulate compiles (the range kernel ``ensemble_kernels.advance_forced`` is a compilation of its
#: own, about a second). A body runs at least CHUNK_BODY_STEPS // 64 substeps a call, so the
#: call's dispatch (tens of microseconds) is below 0.3 % of its time.
PER_BODY_CALLS_MAX = 64
#: Default size of one block's samples (``R`` and ``Pi``) with ``client=`` or ``out_dir=``.
BLOCK_BYTES = 1 << 28

ENSEMBLE_FORMAT = "lgvi.ensemble/1"
#: File names of the blocks written with ``out_dir=`` (block number, from 0).
BLOCK_PATTERN = "ensemble-{:05d}.npz"
_BLOCK_KEYS = ("block", "first_body", "bodies_total", "bodies", "inputs")

_NO_HIST = np.zeros(0)
_NO_CODES = np.zeros((0, 2), dtype=np.int64)
#: Prefix of the per-body model parameters in a saved ensemble (``model_params:pd.kp``, ...).
_PARAMS_PREFIX = "model_params:"


# ------------------------------------------------------------------------------------------------
# Result
# ------------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class EnsembleTrajectory:
    """``B`` simulated bodies sampled at the same ``M`` times (batch axis first).

    Attributes
    ----------
    t : (M,) ndarray
        Sample times (the same for every body).
    R : (B, M, 3, 3) ndarray
        Attitudes.
    Pi : (B, M, 3) ndarray
        Body angular momenta.
    inertia : (B, 3, 3) ndarray
        Standard inertia of each body.
    iterations : (B,) ndarray of int
        Total solver updates of each body over the run (all steps and substeps).
    residual : (B,) ndarray
        Largest final residual of any step of each body.
    h : float
        Step size.
    potential : (B, M) ndarray or None
        Potential energy at each sample, for torque models with a conservative part.
    meta : dict
        Run options (method, forcing, order, torque model, ...), JSON-serialisable.
    model_params : dict or None
        Per-body torque model parameters, when the run had one model per body (a list of
        models, or a :class:`lgvi.torques.Compiled` model with ``params`` (B, P)): parameter
        name -> ``(B, ...)`` array of every body's value. Names are ``"<model key>.<parameter>"``
        (``"pd.kp"``, ``"uniform_gravity.com"``; ``"damping[1].c"`` for the second term of a sum
        when a key repeats) and ``"params"`` for a ``Compiled`` model. ``None`` when one model
        applied to all bodies (``meta["torque_model"]`` describes it).

    Derived (computed on first access): ``omega`` (B,M,3), ``kinetic_energy`` (B,M),
    ``energy`` (B,M) kinetic plus potential, ``spatial_momentum`` (B,M,3), ``dispersions`` (the
    entries of ``model_params`` that differ between bodies). ``ens[b]`` is body ``b`` as a
    :class:`lgvi.Trajectory` (without per-step solver records; with per-body models its
    ``meta["torque_model"]`` and ``meta["invariants"]`` are body ``b``'s); ``ens.torque_model(b)``
    is body ``b``'s model.
    """

    t: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    inertia: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    h: float
    potential: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    model_params: dict[str, np.ndarray] | None = None

    def __post_init__(self) -> None:
        freeze_arrays(self, ARRAY_FIELDS)
        if self.model_params is not None:
            frozen = {}
            for name, arr in self.model_params.items():
                arr = np.asarray(arr, dtype=np.float64)
                if arr.ndim < 1 or arr.shape[0] != self.R.shape[0]:
                    raise ValueError(f"model_params[{name!r}] must have one row per body ({self.R.shape[0]}), "
                                     f"got shape {arr.shape}")
                arr.flags.writeable = False
                frozen[str(name)] = arr
            object.__setattr__(self, "model_params", frozen)

    @property
    def dispersions(self) -> dict[str, np.ndarray]:
        """The per-body torque model parameters that differ between bodies: name -> ``(B, ...)``
        (a subset of :attr:`model_params`; empty when one model applied to all)."""
        if not self.model_params:
            return {}
        return {k: v for k, v in self.model_params.items() if len(v) and not np.all(v == v[:1])}

    def torque_model(self, b: int) -> Any:
        """The torque model body ``b`` ran with (``lgvi.simulate`` with it gives body ``b`` bit for bit).

        Rebuilt from :attr:`model_params` for per-body built-in models; ``None`` for the free body.
        A single model for all bodies, or a ``Compiled`` model (its functions are not recorded),
        cannot be rebuilt from the record: ``ValueError``.
        """
        b = self._index(b)
        if self.meta.get("torque", "none") == "none":
            return None
        terms = self.meta.get("torque_terms")
        if self.model_params is None or not terms:
            raise ValueError("this ensemble ran one torque model for all bodies (meta['torque_model'] = "
                             f"{self.meta.get('torque_model')!r}) or a Compiled model; only per-body built-in "
                             "models are recorded so that they can be rebuilt")
        return _rebuild(terms, self.model_params, b)

    def _index(self, b: int) -> int:
        b = int(b)
        if not -len(self) <= b < len(self):
            raise IndexError(f"body index {b} out of range for an ensemble of {len(self)} bodies")
        return b % len(self)

    def __len__(self) -> int:
        return int(self.R.shape[0])

    @property
    def bodies(self) -> int:
        """Number of bodies ``B``."""
        return len(self)

    def __repr__(self) -> str:
        span = f", t=[{self.t[0]:.6g}, {self.t[-1]:.6g}]" if len(self.t) else ""
        return (f"EnsembleTrajectory(bodies={len(self)}, samples={len(self.t)}, h={self.h:g}{span}, "
                f"method={self.meta.get('method', '?')!r})")

    def __getitem__(self, b: int) -> Trajectory:
        """Body ``b`` as a :class:`lgvi.Trajectory` (its ``iterations``/``residual`` are empty)."""
        b = self._index(b)
        meta = dict(self.meta, body=b)
        if self.model_params:
            meta["model_params"] = {k: v[b].tolist() for k, v in self.model_params.items()}
            if self.meta.get("torque_terms"):
                model = _rebuild(self.meta["torque_terms"], self.model_params, b)
                meta["torque_model"] = repr(model)
                meta["invariants"] = declaration_of(model)
            meta.pop("torque_terms", None)
        return Trajectory(t=self.t, R=self.R[b], Pi=self.Pi[b], inertia=self.inertia[b],
                          iterations=np.zeros(0, dtype=np.int32), residual=np.zeros(0), h=self.h,
                          potential=None if self.potential is None else self.potential[b], meta=meta)

    @cached_property
    def omega(self) -> np.ndarray:
        """(B, M, 3) body angular velocity ``J^-1 Pi``."""
        return np.linalg.solve(self.inertia[:, None], self.Pi[..., None])[..., 0]

    @cached_property
    def kinetic_energy(self) -> np.ndarray:
        """(B, M) kinetic energy ``1/2 Pi . J^-1 Pi``."""
        return 0.5 * np.einsum("bmi,bmi->bm", self.Pi, self.omega)

    @cached_property
    def energy(self) -> np.ndarray:
        """(B, M) total energy: kinetic plus, for conservative torque models, potential."""
        if self.potential is None:
            return self.kinetic_energy
        return self.kinetic_energy + self.potential

    @cached_property
    def spatial_momentum(self) -> np.ndarray:
        """(B, M, 3) inertial angular momentum ``R Pi``."""
        return np.einsum("bmij,bmj->bmi", self.R, self.Pi)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write to ``path`` (``.npz``, uncompressed) atomically; :func:`load_ensemble` reads it back exactly.

        Raises ``OSError`` naming the file and its folder if the write fails (a full disk).
        """
        arrays = dict(t=self.t, R=self.R, Pi=self.Pi, inertia=self.inertia, iterations=self.iterations,
                      residual=self.residual, h=np.float64(self.h))
        if self.potential is not None:
            arrays["potential"] = self.potential
        for name, arr in (self.model_params or {}).items():
            arrays[_PARAMS_PREFIX + name] = arr
        header = json.dumps({"format": ENSEMBLE_FORMAT, "meta": self.meta})
        try:  # atomic: a reader, or a retried Dask task, never sees a half-written file
            write_atomic(os.fspath(path), lambda fh: np.savez(fh, __lgvi__=np.array(header), **arrays))
        except OSError as exc:
            raise write_failure(exc, os.fspath(path), "the ensemble", "The file was left as it was (files are "
                                "replaced only once complete); blocks written before are intact.") from exc


def _load_one(path: str) -> EnsembleTrajectory:
    try:
        with open(path, "rb") as fh:
            head = fh.read(2)
        if head != b"PK":
            raise ValueError("not an .npz (zip) archive")
        check_npz(path)
        with np.load(path, allow_pickle=False) as data:
            header = lgvi_header(data, ENSEMBLE_FORMAT)
            names = ("t", "R", "Pi", "inertia", "iterations", "residual", "h")
            missing = [k for k in names if k not in data.files]
            if missing:
                raise ValueError(f"missing field(s) {', '.join(missing)}")
            fields = {k: data[k] for k in names[:-1]}
            potential = data["potential"] if "potential" in data.files else None
            h = data["h"]
            params = {k[len(_PARAMS_PREFIX):]: data[k] for k in data.files if k.startswith(_PARAMS_PREFIX)}
    except OSError as exc:
        raise ValueError(f"cannot read ensemble {path}: {exc}") from exc
    except Exception as exc:  # zip, JSON and numpy errors of damaged files
        raise ValueError(f"{path} is not a readable lgvi ensemble: {type(exc).__name__}: {exc}") from exc
    t = fields["t"]
    B = fields["R"].shape[0] if fields["R"].ndim else -1
    M = t.shape[0] if t.ndim == 1 else -1
    want = {"R": (B, M, 3, 3), "Pi": (B, M, 3), "inertia": (B, 3, 3), "iterations": (B,), "residual": (B,)}
    if potential is not None:
        want["potential"] = (B, M)
    for name, shape in want.items():
        arr = potential if name == "potential" else fields[name]
        if t.ndim != 1 or arr.shape != shape or arr.dtype.kind not in ("iu" if name == "iterations" else "iuf"):
            raise ValueError(f"{path}: field {name!r} must have shape {shape} (B bodies, M samples), got shape "
                             f"{arr.shape} and dtype {arr.dtype}")
    if h.size != 1:
        raise ValueError(f"{path}: field 'h' must be one number, got shape {h.shape}")
    for name, arr in params.items():
        if arr.ndim < 1 or arr.shape[0] != B or arr.dtype.kind not in "iuf":
            raise ValueError(f"{path}: field {_PARAMS_PREFIX + name!r} must have one row per body ({B}), got "
                             f"shape {arr.shape} and dtype {arr.dtype}")
    meta = header.get("meta", {})
    if not isinstance(meta, dict):
        raise ValueError(f"{path}: the header's 'meta' must be a JSON object")
    return EnsembleTrajectory(h=float(h.reshape(())), potential=potential, meta=meta,
                              model_params=params or None, **fields)


def load_ensemble(path: str | os.PathLike[str] | Sequence[str | os.PathLike[str]]) -> EnsembleTrajectory:
    """Read an ensemble written by :meth:`EnsembleTrajectory.save` or by ``simulate_ensemble(out_dir=)``.

    Parameters
    ----------
    path : path, folder, or sequence of paths
        One ``.npz`` file; a folder written with ``out_dir=`` (all its ``ensemble-XXXXX.npz``
        blocks, checked to cover the ensemble in order); or a list of files, joined in order.

    Returns
    -------
    EnsembleTrajectory

    Raises
    ------
    ValueError
        If a file is not an lgvi ensemble, or the blocks of a folder are incomplete or overlap;
        the message names the file.
    """
    if isinstance(path, (list, tuple)):
        return concatenate([_load_one(os.fspath(p)) for p in path])
    folder = Path(os.fspath(path))
    if not folder.is_dir():
        return _load_one(str(folder))
    files = sorted(folder.glob("ensemble-*.npz"))
    for p in files:
        if not inside(folder, p):
            raise ValueError(f"{p} is a symbolic link to {os.path.realpath(p)}, outside the folder {folder}; "
                             "it is not followed")
        if not p.is_file():  # a FIFO or a device would block or never end
            raise ValueError(f"{p} is not a regular file")
    if not files:
        raise ValueError(f"{folder} holds no ensemble blocks (ensemble-XXXXX.npz)")
    parts = [_load_one(str(p)) for p in files]
    expected = 0
    total = parts[0].meta.get("bodies_total")
    for p, part in zip(files, parts):
        first = part.meta.get("first_body")
        if first is not None and first != expected:
            raise ValueError(f"{p}: block starts at body {first}, but the blocks before it end at body {expected} "
                             f"(a block is missing or the folder mixes runs)")
        expected += len(part)
    if total is not None and expected != total:
        raise ValueError(f"{folder}: the blocks hold {expected} bodies, but the run had {total} "
                         "(the last blocks are missing: the run did not finish?)")
    return concatenate(parts)


def concatenate(parts: Sequence[EnsembleTrajectory]) -> EnsembleTrajectory:
    """Join ensembles of the same run split by bodies, in the given order.

    Raises ``ValueError`` if the parts differ in their sample times, step size or run options.
    """
    parts = list(parts)
    if not parts:
        raise ValueError("parts must hold at least one ensemble")
    first = parts[0]
    keep = {k: v for k, v in first.meta.items() if k not in _BLOCK_KEYS}
    for i, p in enumerate(parts[1:], 1):
        if not isinstance(p, EnsembleTrajectory):
            raise TypeError(f"parts[{i}] must be an EnsembleTrajectory, got {type(p).__name__}")
        if p.h != first.h or not np.array_equal(p.t, first.t):
            raise ValueError(f"parts[{i}] has other sample times or step size than parts[0]; only blocks of "
                             "one run can be joined")
        if (p.potential is None) != (first.potential is None):
            raise ValueError(f"parts[{i}] {'lacks' if p.potential is None else 'has'} a potential, parts[0] "
                             f"{'has' if first.potential is not None else 'lacks'} one")
        if (p.model_params is None) != (first.model_params is None) or \
                (p.model_params is not None and set(p.model_params) != set(first.model_params)):
            raise ValueError(f"parts[{i}] records other per-body model parameters than parts[0]")
        other = {k: v for k, v in p.meta.items() if k not in _BLOCK_KEYS}
        if other != keep:
            diff = sorted(k for k in set(other) | set(keep) if other.get(k) != keep.get(k))
            raise ValueError(f"parts[{i}] was run with other options than parts[0] (differences: {', '.join(diff)})")

    def cat(name: str) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in parts])

    return EnsembleTrajectory(t=first.t, R=cat("R"), Pi=cat("Pi"), inertia=cat("inertia"),
                              iterations=cat("iterations"), residual=cat("residual"), h=first.h,
                              potential=None if first.potential is None else cat("potential"),
                              meta=dict(keep, bodies=sum(len(p) for p in parts)),
                              model_params=None if first.model_params is None else
                              {k: np.concatenate([p.model_params[k] for p in parts]) for k in first.model_params})


# ------------------------------------------------------------------------------------------------
# Validation
# ------------------------------------------------------------------------------------------------

def _rotations(R0: Any) -> np.ndarray:
    if is_scipy_rotation(R0):
        R0 = R0.as_matrix()
    R = as_float_array(R0, "R0")
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise ValueError(f"R0 must have shape (B, 3, 3) (one rotation matrix per body), got shape {R.shape}")
    if R.shape[0] == 0:
        raise ValueError("R0 must hold at least one attitude, got shape (0, 3, 3)")
    err = np.linalg.norm(np.einsum("bki,bkj->bij", R, R) - np.eye(3), axis=(1, 2))
    det = np.linalg.det(R)
    bad = np.flatnonzero((err > REPAIR_TOL) | (det <= 0))
    if bad.size:
        b = int(bad[0])
        rule = ("determinant -1 (a reflection)" if det[b] < 0 and err[b] <= REPAIR_TOL
                else f"orthogonality error |R^T R - I| = {err[b]:.3g} > {REPAIR_TOL:g}")
        raise ValueError(f"R0[{b}] must be a rotation matrix (orthogonal to {REPAIR_TOL:g}, determinant +1); "
                         f"got {rule} ({bad.size} of {len(R)} attitudes are not rotations). "
                         "Use lgvi.so3.project(R0) for the nearest rotations.")
    R = np.array(R, dtype=np.float64, order="C", copy=True)
    off = np.flatnonzero(err > ROTATION_TOL)
    if off.size:  # rotations to REPAIR_TOL only (e.g. 7 digits): their nearest rotations, with a warning
        R[off] = project(R[off])
        warn_repaired(f"R0[{int(off[0])}] is {err[off[0]]:.2g} away from a rotation ({off.size} of {len(R)} "
                      f"attitudes)", R[off[0]])
    return R


def _bodies(bodies: Any, B: int) -> tuple[list[RigidBody], np.ndarray]:
    """Distinct bodies and the index ``ib`` (B,) of each body's among them."""
    if isinstance(bodies, RigidBody):
        return [bodies], np.zeros(B, dtype=np.int64)
    if isinstance(bodies, (list, tuple)) and any(isinstance(x, RigidBody) for x in bodies):
        items = list(bodies)
    else:
        try:
            arr = np.asarray(bodies)
        except Exception as exc:
            raise TypeError(f"bodies must be a RigidBody, a sequence of B of them, or inertias; got "
                            f"{type(bodies).__name__}") from exc
        if arr.shape in ((3,), (3, 3)):
            return [RigidBody(arr)], np.zeros(B, dtype=np.int64)
        if arr.ndim not in (2, 3) or arr.shape[1:] not in ((3,), (3, 3)):
            raise ValueError(f"bodies must be a RigidBody, a sequence of them, or inertias of shape (3,), (3, 3), "
                             f"(B, 3) or (B, 3, 3); got shape {arr.shape}")
        items = list(arr)
    if len(items) != B:
        raise ValueError(f"bodies gives {len(items)} bodies but R0 has {B} attitudes; give one body for all "
                         "or one per attitude")
    unique: list[RigidBody] = []
    seen: dict[bytes, int] = {}
    ib = np.empty(B, dtype=np.int64)
    for b, item in enumerate(items):
        if isinstance(item, RigidBody):
            key = b"J" + item.J.tobytes()
        else:
            a = np.asarray(item)
            key = str(a.shape).encode() + a.dtype.str.encode() + a.tobytes()
        q = seen.get(key)
        if q is None:
            try:
                body = item if isinstance(item, RigidBody) else RigidBody(item)
            except (TypeError, ValueError) as exc:
                raise type(exc)(f"bodies[{b}]: {exc}") from exc
            q = seen[key] = len(unique)
            unique.append(body)
        ib[b] = q
    return unique, ib


def _momenta(bodies: list[RigidBody], ib: np.ndarray, Pi0: Any, omega0: Any) -> np.ndarray:
    B = len(ib)
    if Pi0 is None and omega0 is None:
        raise ValueError("give the initial body angular momenta Pi0 (B, 3) or the angular velocities omega0 (B, 3)")
    if Pi0 is not None and omega0 is not None:
        raise ValueError("give either Pi0 or omega0, not both")
    if Pi0 is not None:
        return np.array(as_float_array(Pi0, "Pi0", (B, 3)), dtype=np.float64, order="C", copy=True)
    omega = as_float_array(omega0, "omega0", (B, 3))
    Pi = np.empty((B, 3))
    for b in range(B):  # as simulate computes it (J @ omega0), bit for bit
        Pi[b] = bodies[ib[b]].J @ omega[b]
    return Pi


def _term_prefixes(keys: Sequence[str]) -> list[str]:
    """Name prefix of each term's parameters: its model key, ``key[i]`` (term index) when a key repeats."""
    return [k if list(keys).count(k) == 1 else f"{k}[{i}]" for i, k in enumerate(keys)]


def _rebuild(keys: Sequence[str], model_params: dict[str, np.ndarray], b: int) -> Any:
    """Body ``b``'s model from the recorded per-body parameters (terms ``keys``, in order)."""
    from ..torques import TORQUE_MODELS

    terms = []
    for key, prefix in zip(keys, _term_prefixes(keys)):
        if key not in TORQUE_MODELS:
            raise ValueError(f"cannot rebuild torque model {key!r}: not a registered model "
                             f"({', '.join(TORQUE_MODELS)})")
        spec = {name[len(prefix) + 1:]: np.array(arr[b]) for name, arr in model_params.items()
                if name.startswith(prefix + ".")}
        terms.append(TORQUE_MODELS[key].from_scenario(spec))
    return terms[0] if len(terms) == 1 else sum(terms[1:], terms[0])


def _per_body_models(torque: Any, B: int) -> list[Any] | None:
    """The list of B models of ``torque=`` given per body (checked), or ``None`` for anything else."""
    from ..torques import Compiled, TorqueModel

    if isinstance(torque, np.ndarray) and torque.dtype == object:
        torque = list(torque.ravel())
    if not isinstance(torque, (list, tuple)) or not any(isinstance(m, TorqueModel) for m in torque):
        return None
    models = list(torque)
    for i, m in enumerate(models):
        if not isinstance(m, TorqueModel):
            raise TypeError(f"torque[{i}] must be a torque model of lgvi.torques like torque[0] (a list gives one "
                            f"model per body), got {type(m).__name__} {m!r}")
        if isinstance(m, Compiled):
            raise TypeError(f"torque[{i}] is a Compiled model: a list of models is for the built-in models; give "
                            "one Compiled model with params of shape (B, P), one row per body, instead")
    if len(models) != B:
        raise ValueError(f"torque: a list of torque models gives one model per body, so it must hold {B} models "
                         f"(R0 has {B} attitudes), got {len(models)}")
    kinds0 = [type(t) for t in models[0].terms]
    for i, m in enumerate(models):
        kinds = [type(t) for t in m.terms]
        if kinds != kinds0:
            raise ValueError(
                f"torque[{i}] = {m!r} is not of the same kind as torque[0] = {models[0]!r}: per-body models must "
                f"have the same terms in the same order ({' + '.join(k.__name__ for k in kinds0)}); only their "
                "parameters may differ between bodies")
    return models


def _model_params(models: list[Any]) -> tuple[list[str], dict[str, np.ndarray]]:
    """The term keys of per-body models and every term parameter's per-body values (B, ...)."""
    keys = [t.key for t in models[0].terms]
    table: dict[str, list[np.ndarray]] = {}
    prefixes = _term_prefixes(keys)
    for m in models:
        for prefix, term in zip(prefixes, m.terms):
            for name, value in term.parameters().items():
                table.setdefault(f"{prefix}.{name}", []).append(value)
    return keys, {name: np.stack(values) for name, values in table.items()}


class _Setup:
    """A validated ensemble run: inputs, scheme, and everything the kernels need but the state."""

    def __init__(self, bodies: Any, R0: Any, Pi0: Any, omega0: Any, *, h: Any, steps: Any, torque: Any,
                 method: str, tol: Any, max_iter: Any, alpha: Any, save_every: Any, t0: Any, forcing: Any,
                 order: Any, composition: Any, threads: Any) -> None:
        from ..driver import run_solver_options as _options, time_grid
        from ..registry import FORCINGS, check_composable as _check_order, composition_for as _composition

        self.code, self.tol, self.max_iter, self.alpha = _options(method, tol, max_iter, alpha)
        self.R = _rotations(R0)
        B = len(self.R)
        self.bodies, self.ib = _bodies(bodies, B)
        self.Pi = _momenta(self.bodies, self.ib, Pi0, omega0)
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        steps, save_every = self.steps, self.save_every
        choice(forcing, "forcing", FORCINGS)
        self.comp = comp = _composition(order, composition)
        self.sym = forcing == "symmetric"
        self.models = _per_body_models(torque, B)       # one built-in model per body, or None
        if self.models is not None:
            torque = self.models[0]                      # their kinds: the run's options are checked on it
        kind = torque_kind(torque)  # lgvi.registry: the one classification of torque=
        self.model = torque if kind == "model" else None
        if kind == "callable":
            raise TypeError("simulate_ensemble takes torque=None, a torque model of lgvi.torques or a list of one "
                            f"model per body, got the callable {torque!r}: a Python function cannot run "
                            "inside the compiled parallel kernel. Write the moment as a model (or a sum of "
                            "models), or call lgvi.simulate per body.")
        elif kind == "array":
            raise TypeError("simulate_ensemble takes torque=None, a torque model of lgvi.torques or a list of one "
                            f"model per body, got {type(torque).__name__}: torque arrays are not supported "
                            "for ensembles; call lgvi.simulate per body for tabulated moments.")
        _check_order(comp, kind, forcing, self.model)
        user = getattr(self.model, "params", None)      # lgvi.torques.Compiled: one row per body or one for all
        if getattr(self.model, "moment_func", None) is not None and user.ndim == 2 and user.shape[0] != B:
            raise ValueError(f"Compiled: params of shape {user.shape} must have one row per body ({B} bodies) "
                             "or shape (P,) for all")
        if getattr(self.model, "moment_func", None) is not None:   # its Python form at bodies' first samples
            for b in tried_rows(B):
                self.model.check_sample(self.t0, self.R[b], self.Pi[b], b if user.ndim == 2 else None,
                                        where=f"the first sample of body {b}")
        if threads is not None:
            threads = as_int(threads, "threads", minimum=1)
        self.threads = threads
        # the free body at order 2 runs the original step (as simulate does), bit for bit
        self.legacy = comp.order == 2 and kind == "none"
        self.gam, self.cum = comp.arrays()
        if self.model is not None:
            self.codes, self.params = self.model.encode()
        else:
            self.codes, self.params = _NO_CODES, np.zeros(0)
        # the kernels' parameter table: one row for all bodies, or one per body (same codes for all)
        self.ptab = self.params.reshape(1, -1)
        self.model_params: dict[str, np.ndarray] | None = None
        keys: list[str] = []
        if self.models is not None:
            self.ptab = np.ascontiguousarray(np.stack([m.encode()[1] for m in self.models]))
            keys, self.model_params = _model_params(self.models)
        elif getattr(self.model, "moment_func", None) is not None and user.ndim == 2:
            self.model_params = {"params": user}
        self.has_potential = self.model is not None and any(m.conservative for m in self.model.terms)
        self.meta: dict[str, Any] = {"method": method, "tol": self.tol, "max_iter": self.max_iter,
                                     "alpha": self.alpha, "save_every": save_every, "steps": steps,
                                     "torque": kind, "forcing": forcing, "order": comp.order, "t0": self.t0,
                                     "bodies": B, "lgvi_version": __version__}
        if comp.order != 2:
            self.meta["composition"] = comp.name
        if self.model is not None:
            self.meta["torque_model"] = repr(self.model)
        self.meta["forcing"] = forcing_used(kind, forcing, self.model)
        if self.model is not None:  # the free body's are implied by torque "none"
            self.meta["invariants"] = declaration_of(self.model)
        if self.models is not None:
            # body b's own model, invariants and parameters: ens.torque_model(b), ens[b].meta, ens.model_params
            names = " + ".join(type(t).__name__ for t in self.model.terms)
            self.meta["torque_model"] = f"{names}, one model per body (body 0: {self.model!r})"
            self.meta["torque_terms"] = keys
            _, reps = self.groups()
            self.meta["invariants"] = combine([declaration_of(self.models[r]) for r in reps])

    def __len__(self) -> int:
        return len(self.ib)

    def block(self, start: int, stop: int, threads: int | None) -> "_Setup":
        """Bodies ``start .. stop-1`` as a run of their own (only the bodies it uses)."""
        sub = object.__new__(_Setup)
        sub.__dict__.update(self.__dict__)
        used, ib = np.unique(self.ib[start:stop], return_inverse=True)
        sub.bodies = [self.bodies[q] for q in used]
        sub.ib = ib.astype(np.int64).reshape(-1)
        sub.R = self.R[start:stop].copy()
        sub.Pi = self.Pi[start:stop].copy()
        sub.threads = threads
        if self.ptab.shape[0] > 1:
            sub.ptab = self.ptab[start:stop]
        if self.models is not None:
            sub.models = self.models[start:stop]
        if self.model_params is not None:
            sub.model_params = {k: v[start:stop] for k, v in self.model_params.items()}
        sub.meta = dict(self.meta, bodies=stop - start)
        sub.body0 = getattr(self, "body0", 0) + start    # index of its first body in the whole ensemble
        return sub

    def groups(self) -> tuple[np.ndarray, np.ndarray]:
        """``(ia, reps)``: body ``b`` is in group ``ia[b]`` of the bodies with the same inertia and
        torque model; ``reps[g]`` is a body of group ``g`` (momentum matrices and potentials are
        computed once per group)."""
        if self.models is None:
            reps = np.array([np.flatnonzero(self.ib == q)[0] for q in range(len(self.bodies))], dtype=np.int64)
            return self.ib, reps
        B = len(self.ib)
        key = np.column_stack([self.ib.astype(np.float64)] + [v.reshape(B, -1) for v in self.model_params.values()])
        _, reps, ia = np.unique(key, axis=0, return_index=True, return_inverse=True)
        return ia.reshape(-1).astype(np.int64), reps.astype(np.int64)

    def times(self, m: int) -> np.ndarray:
        """Times of the first ``m`` samples (the same floating-point values as :func:`lgvi.simulate`)."""
        from ..driver import sample_times

        return sample_times(self.t0, self.h * self.save_every, 0, m)

    def inertia(self) -> np.ndarray:
        return np.stack([b.J for b in self.bodies])[self.ib]

    def potential(self, t: np.ndarray, R_out: np.ndarray) -> np.ndarray | None:
        if not self.has_potential:
            return None
        U = np.empty(R_out.shape[:2])
        if getattr(self.model, "moment_func", None) is not None:   # lgvi.torques.Compiled: per-body params
            return self.model.potential_of_bodies(t, R_out, getattr(self, "body0", 0))
        if self.models is not None:       # one model per body: once per group of equal bodies and models
            ia, reps = self.groups()
            order = np.argsort(ia, kind="stable")
            for r, idx in zip(reps, np.split(order, np.cumsum(np.bincount(ia, minlength=len(reps)))[:-1])):
                U[idx] = self.models[r].potential(t, R_out[idx], self.bodies[self.ib[r]])
            return U
        for q, body in enumerate(self.bodies):
            idx = np.flatnonzero(self.ib == q)
            U[idx] = self.model.potential(t, R_out[idx], body)
        return U


# ------------------------------------------------------------------------------------------------
# Runs
# ------------------------------------------------------------------------------------------------

def simulate_ensemble(bodies: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: float, steps: int,
                      torque: Any = None, method: MethodName = "newton", tol: float = 1e-14, max_iter: int = 50,
                      alpha: float = 1.0, save_every: int = 1, t0: float = 0.0, forcing: ForcingName = "paper",
                      order: int = 2, composition: str | None = None, threads: int | None = None,
                      client: Any = None, block_size: int | None = None,
                      out_dir: str | os.PathLike[str] | None = None, resume: bool = False,
                      progress: Any = False, wheels: Any = None, controller: Any = None,
                      control_period: Any = None, environment: Any = None,
                      magnetorquers: Any = None, fsw: Any = None,
                      device: DeviceName = "cpu") -> EnsembleTrajectory | list[Path] | Any:
    """Simulate ``B`` rigid bodies at once with the attitude LGVI, in parallel over cores.

    Body ``b`` follows bit for bit the trajectory of
    ``lgvi.simulate(body_b, R0[b], Pi0[b], <same options>)``: the ensemble kernel runs the same
    compiled steps on each body's own state (its solver histories and moment cache included).

    Parameters
    ----------
    bodies : RigidBody, sequence of B RigidBody, or array_like
        One body for all, or one per body: inertias ``(3,)``/``(3, 3)`` for all, ``(B, 3)``
        principal moments or ``(B, 3, 3)`` matrices. A ``(3, 3)`` array is always one inertia
        matrix (for three bodies' principal moments pass three ``RigidBody``).
    R0 : (B, 3, 3) array_like or scipy Rotation stack
        Initial attitudes, rotations to 1e-9 (to 1e-6: replaced by the nearest rotations, with
        an ``AttitudeWarning``; the error names the first bad index).
    Pi0, omega0 : (B, 3) array_like
        Initial body angular momenta or angular velocities (give one of the two).
    h, steps, method, tol, max_iter, alpha, save_every, t0, forcing, order, composition
        As in :func:`lgvi.simulate`.
    torque : None, lgvi.torques.TorqueModel, or sequence of B of them
        The free body; one torque model (or a sum of them) applied to every body, evaluated with
        each body's own inertia and state; or **one model per body** for Monte Carlo dispersions
        of gains, targets, disturbance torques, centres of mass, orbits:
        ``[AttitudePD(kp=k, kd=1.0) for k in kps]``. Per-body models must be of the same kind
        (the same terms in the same order, e.g. all ``UniformGravity + LinearDamping``); only
        their parameters may differ (else ``ValueError`` naming the first body that differs).
        Their parameters are recorded in ``ens.model_params`` (those that differ in
        ``ens.dispersions``), ``ens.torque_model(b)`` rebuilds body ``b``'s model, and body ``b``
        equals ``lgvi.simulate(..., torque=torque[b])`` bit for bit. A
        :class:`lgvi.torques.Compiled` model takes per-body parameters as ``params`` (B, P)
        instead (recorded as ``model_params["params"]``; its bodies run through the compiled loop
        of :func:`lgvi.simulate`, split over ``threads`` threads). Python callables and torque
        arrays are refused (``TypeError``): they cannot run inside the compiled parallel kernel.
    threads : int, optional
        Threads of this call (default: Numba's current number, all cores unless changed; at most
        ``numba.config.NUMBA_NUM_THREADS``). ``threads=1`` runs a serial kernel. With ``client``
        it is the threads of each Dask task (default 1: the cluster's workers give the
        parallelism).
    client : dask.distributed.Client, optional
        Split the bodies into blocks of ``block_size`` that run as Dask tasks, each one an
        in-process ensemble run on its worker, and gather them (``pip install lgvi[dask]``).
    block_size : int, optional
        Bodies per block with ``client`` or ``out_dir`` (default: two blocks per Dask worker,
        at most about 256 MB of samples per block).
    out_dir : path, optional
        Write each block to ``out_dir/ensemble-XXXXX.npz`` (block number from 0) and return the
        paths instead of an ensemble, for ensembles larger than memory; read them back with
        :func:`load_ensemble` (one file, a list of them, or the whole folder). Without
        ``client`` the blocks run one after the other in this process; with it, on the
        workers, which must see ``out_dir`` (a shared file system). The folder must not hold
        ensemble blocks already, unless ``resume``.
    resume : bool
        With ``out_dir``: keep the blocks of this run that the folder already holds (from a call
        that was interrupted, ran out of disk or lost its cluster) and compute only the others;
        the folder then holds the same ensemble bit for bit as an uninterrupted run. Each
        block's header records the run's options and a digest of its bodies' initial states,
        inertias and model parameters; a block written by another run, or with another block
        layout (give the same ``block_size``), is refused with ``ValueError`` naming the file.
    progress : bool or callable
        ``True`` draws a ``tqdm`` progress bar, a callable is called as ``progress(done, total)``
        (steps of the whole ensemble in process; bodies of finished blocks with ``client`` or
        ``out_dir``).
    wheels, controller : lgvi.ReactionWheels, lgvi.control.Controller, or sequences of B of them
        Monte Carlo dispersions of spacecraft with reaction wheels and a control loop: one for
        every member (each member gets its own copy) or one per member (wheel misalignment as
        per-member ``axes``, initial wheel speeds as ``speed0``, gains as per-member
        controllers). ``bodies`` disperses the inertia, ``R0``, ``Pi0``/``omega0`` the initial
        state. ``control_period``, ``environment``, ``magnetorquers`` and ``torque`` (one
        :class:`lgvi.torques.Compiled` model) are as in :func:`lgvi.simulate` and shared. Member
        ``b`` equals ``lgvi.simulate`` with its inputs bit for bit; the members run through the
        gyrostat's compiled loop in ``threads`` threads (it releases the GIL; a Python
        controller takes it at its calls). Returns a
        :class:`lgvi.systems.gyrostat_ensemble.GyrostatEnsemble` (``ens[b]``, stacked ``R``,
        ``wheel_speed``, ..., and ``params``/``dispersions`` recording every member's inputs);
        ``client``, ``out_dir``, ``resume``, ``block_size`` and ``progress`` are not taken.
    device : {"cpu", "cuda"}
        Where the bodies run (``lgvi.registry.DEVICES``): ``"cpu"``, the machine's cores (the
        default); ``"cuda"``, one NVIDIA GPU, one body a GPU thread, running the CPU kernels' own
        per-body code compiled for the GPU by Numba's CUDA target (``pip install lgvi[cuda]``; see
        ``docs/gpu.md`` and :mod:`lgvi.gpu`). On the GPU the samples come back to the host in
        chunks that bound the device memory; progress, Ctrl-C and failures are as on the CPU.
        Free bodies, the built-in torque models and their sums (one model per body too), both
        forcings, the compositions and :class:`lgvi.torques.Compiled` models run there;
        ``threads``, ``client``, ``out_dir``, ``resume``, ``block_size`` and the gyrostat's
        ``wheels``/``controller`` (and their options) are CPU-only and refused.
    fsw : lgvi.FlightSoftware or sequence of B, optional
        With ``bodies`` an :class:`lgvi.Spacecraft` (or B of them): the members fly their
        spacecraft with this flight software in the compiled loop (``docs/loop.md``), in
        ``threads`` threads; member ``b`` equals ``lgvi.simulate(spacecraft[b], R0[b], ...,
        fsw=fsw[b])`` bit for bit (its own inertia in its gravity gradient, its own gains). Returns
        a :class:`lgvi.systems.spacecraft.SpacecraftEnsemble` (``signals`` (B, E, size) by name,
        ``params["component.<i>.<kind>"]`` the members' parameter rows).

    Returns
    -------
    EnsembleTrajectory or list of pathlib.Path
        ``R`` (B, M, 3, 3), ``Pi`` (B, M, 3) with ``M = steps // save_every + 1``, ``potential``
        (B, M) for conservative models, ``iterations`` and ``residual`` (B,) per body; with
        ``out_dir`` the block files in order.

    Raises
    ------
    ValueError, TypeError
        Invalid input; the message names the argument (and the index of a bad body or attitude).
    ConvergenceError
        A body's implicit equation failed: the message names the body, the step and the time
        (``err.body``, ``err.step``, ``err.time``); ``err.trajectory`` holds the ensemble up to the
        failing step (all bodies). With ``client`` it holds that of the failing block.
    SimulationInterrupted
        Ctrl-C (honoured between compiled chunks of steps); ``err.trajectory`` holds the part
        computed so far (in process; with ``client`` the tasks are cancelled and it is ``None``).

    Notes
    -----
    The loop over bodies runs inside compiled code (for the free body a Numba ``prange`` loop; with
    a torque model or a composition one compiled call a thread, each running ``simulate``'s loop
    on its bodies); each thread takes a contiguous block of bodies and advances each one through a
    whole chunk of steps with its state in cache. Results do not depend on the number of threads, the chunking or the blocks.
    The free body with ``method="cayley"`` (order 2) steps groups of 8 bodies in lockstep in SIMD
    registers, with the same floating-point operations per body as the scalar step (bodies whose
    step needs more than one Newton update take the scalar step): the fastest path, about four
    times the per-body kernel (``benchmarks/bench_ensemble.py``).

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> rng = np.random.default_rng(0)
    >>> R0 = lgvi.so3.exp(0.1 * rng.normal(size=(8, 3)))
    >>> body = lgvi.RigidBody([1., 2., 3.])
    >>> w0 = [0.3, 1.0, 0.2] + 0.01 * rng.normal(size=(8, 3))
    >>> ens = lgvi.simulate_ensemble(body, R0, omega0=w0, h=0.01, steps=100, save_every=10)
    >>> ens.R.shape, ens.Pi.shape
    ((8, 11, 3, 3), (8, 11, 3))
    >>> one = lgvi.simulate(body, R0[3], omega0=w0[3], h=0.01, steps=100, save_every=10)
    >>> bool(np.array_equal(ens.R[3], one.R))
    True

    Dispersed controller gains, one model per body:

    >>> from lgvi.torques import AttitudePD
    >>> pd = [AttitudePD(kp=k, kd=1.0) for k in np.linspace(0.5, 2.0, 8)]
    >>> ens = lgvi.simulate_ensemble(body, R0, omega0=w0, h=0.01, steps=100, torque=pd, forcing="symmetric")
    >>> list(ens.dispersions), ens.dispersions["pd.kp"].shape
    (['pd.kp'], (8, 3))
    >>> one = lgvi.simulate(body, R0[5], omega0=w0[5], h=0.01, steps=100, torque=pd[5], forcing="symmetric")
    >>> bool(np.array_equal(ens.R[5], one.R)), ens.torque_model(5) == pd[5]
    (True, True)
    """
    from ..registry import DEVICES

    choice(device, "device", DEVICES)
    if device != "cpu":
        _device_options(device, threads=threads, client=client, block_size=block_size, out_dir=out_dir,
                        resume=resume, wheels=wheels, controller=controller, control_period=control_period,
                        environment=environment, magnetorquers=magnetorquers)
    first = bodies[0] if isinstance(bodies, (list, tuple)) and bodies else bodies
    if fsw is not None or type(first).__name__ == "Spacecraft":        # the compiled loop (lgvi.systems.spacecraft)
        from .spacecraft import simulate_spacecraft_ensemble

        given = {name: value for name, value in (("torque", torque), ("wheels", wheels), ("controller", controller),
                                                 ("control_period", control_period), ("environment", environment),
                                                 ("magnetorquers", magnetorquers), ("client", client),
                                                 ("out_dir", out_dir), ("block_size", block_size))
                 if value is not None}
        given.update({name: True for name, value in (("resume", resume), ("progress", progress)) if value})
        if forcing != "paper":
            given["forcing"] = forcing
        if device != "cpu":
            given["device"] = device
        if given:
            raise ValueError(f"{', '.join(sorted(given))}: not with lgvi.Spacecraft members, whose descriptions and "
                             "flight software (fsw=) say all of it (the members run in threads in this process)")
        return simulate_spacecraft_ensemble(bodies, _rotations(R0), Pi0, omega0=omega0, h=h, steps=steps, fsw=fsw,
                                            threads=threads, method=method, tol=tol, max_iter=max_iter, alpha=alpha,
                                            save_every=save_every, t0=t0, order=order, composition=composition)
    if any(x is not None for x in (wheels, controller, control_period, environment, magnetorquers)):
        from .gyrostat import gyrostat_options
        from .gyrostat_ensemble import simulate_gyrostat_ensemble

        for name, value, default in (("client", client, None), ("out_dir", out_dir, None), ("resume", resume, False),
                                     ("block_size", block_size, None), ("progress", progress, False)):
            if value is not default and not (default is False and value is False):
                raise ValueError(f"{name}={value!r} cannot be combined with wheels= or controller= in "
                                 "simulate_ensemble (the members run in threads in this process)")
        gyrostat_options(torque=torque, forcing=forcing, order=order, composition=composition, error_estimate=None)
        R = _rotations(R0)
        unique, ib = _bodies(bodies, len(R))
        from .loop_keywords import KeywordsDeprecationWarning, describe_members, replacement

        mapped = describe_members([unique[i] for i in ib], len(R), wheels=wheels, controller=controller,
                                  control_period=control_period, environment=environment,
                                  magnetorquers=magnetorquers, torque=torque)
        if mapped is not None:            # today's keywords onto the descriptions (lgvi.systems.loop_keywords)
            import warnings

            from .spacecraft import simulate_spacecraft_ensemble

            scs, fl, kept = mapped
            warnings.warn(replacement(scs[0], None if fl is None else fl[0], "lgvi.simulate_ensemble"),
                          KeywordsDeprecationWarning, stacklevel=2)
            ens = simulate_spacecraft_ensemble(scs, R, Pi0, omega0=omega0, h=h, steps=steps, fsw=fl, threads=threads,
                                               method=method, tol=tol, max_iter=max_iter, alpha=alpha,
                                               save_every=save_every, t0=t0, order=order, composition=composition)
            ens.params.update(kept)
            return ens
        return simulate_gyrostat_ensemble([unique[i] for i in ib], R, Pi0, omega0=omega0, h=h, steps=steps, wheels=wheels,
                                          controller=controller, control_period=control_period,
                                          environment=environment, magnetorquers=magnetorquers, torque=torque,
                                          threads=threads, method=method, tol=tol, max_iter=max_iter, alpha=alpha,
                                          save_every=save_every, t0=t0, order=order, composition=composition)
    setup = _Setup(bodies, R0, Pi0, omega0, h=h, steps=steps, torque=torque, method=method, tol=tol,
                   max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0, forcing=forcing, order=order,
                   composition=composition, threads=threads)
    if not (isinstance(progress, bool) or callable(progress)):
        raise TypeError(f"progress must be True, False or a callable progress(done, total), got {progress!r}")
    if block_size is not None:
        block_size = as_int(block_size, "block_size", minimum=1)
        if client is None and out_dir is None:
            raise ValueError("block_size is used with client= or out_dir= (blocks of bodies); an in-process run "
                             "needs no blocks")
    if not isinstance(resume, (bool, np.bool_)):
        raise TypeError(f"resume must be True or False, got {resume!r}")
    if resume and out_dir is None:
        raise ValueError("resume=True continues the blocks of an out_dir= run; give out_dir (the folder of the "
                         "interrupted run)")
    if device != "cpu":
        if not (isinstance(progress, bool) or callable(progress)):
            raise TypeError(f"progress must be True, False or a callable progress(done, total), got {progress!r}")
        return _device_run(device)(setup, progress)
    if client is not None:
        return _run_dask(setup, client, block_size, out_dir, progress, bool(resume))
    if out_dir is not None:
        return _run_blocks(setup, block_size, out_dir, progress, bool(resume))
    return _run_local(setup, progress)


#: Runners of ``simulate_ensemble(device=...)`` other than ``"cpu"``, provided by the modules that
#: define them (:mod:`lgvi.gpu` provides ``"cuda"``): ``run(setup, progress) -> EnsembleTrajectory``.
_DEVICE_RUNS: dict[str, Any] = {}


def provide_device(name: str, run: Any) -> None:
    """Register ``run(setup, progress)`` as the runner of ``simulate_ensemble(device=name)`` (called by
    the module that defines it on import, so that this module never imports it)."""
    _DEVICE_RUNS[name] = run


def _device_run(device: str) -> Any:
    if device not in _DEVICE_RUNS:  # pragma: no cover - `import lgvi` imports lgvi.gpu, which provides it
        raise RuntimeError(f"device={device!r} has no runner: import lgvi.gpu")
    return _DEVICE_RUNS[device]


def _device_options(device: str, **options: Any) -> None:
    """Refuse the options of ``simulate_ensemble`` that run on the CPU only, naming each."""
    for name in ("wheels", "controller", "control_period", "environment", "magnetorquers"):
        if options[name] is not None:
            raise ValueError(f"{name}= cannot be combined with device={device!r}: the gyrostat (reaction wheels "
                             "and its compiled control loop) runs on the CPU only (see docs/gpu.md); drop "
                             "device= to run it on the cores")
    for name, what in (("threads", "CPU threads"), ("client", "Dask blocks"), ("block_size", "blocks of bodies"),
                       ("out_dir", "blocks written to disk")):
        if options[name] is not None:
            raise ValueError(f"{name}={options[name]!r} ({what}) cannot be combined with device={device!r}; the "
                             "GPU runs all bodies in one process and brings the samples back in chunks")
    if options["resume"] is not False:
        raise ValueError(f"resume={options['resume']!r} continues an out_dir= run, which device={device!r} "
                         "does not write")


@contextlib.contextmanager
def quiet_function_argument() -> Any:
    """Silence Numba's note that passing the user's function on to another compiled function (the
    ensemble's :func:`lgvi._kernels.user_kernels.advance_user` to the loop it calls) is an experimental
    feature: it is what a :class:`lgvi.torques.Compiled` model is, tested bit for bit."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="First-class function type feature is experimental")
        yield



class _Threads:
    """Set Numba's thread count for the calling thread during a run, and restore it."""

    def __init__(self, threads: int | None) -> None:
        self.threads = threads
        self.old: int | None = None

    def __enter__(self) -> bool:
        """Returns whether to run the parallel kernel."""
        if self.threads is None:
            return True
        if self.threads == 1:
            return False
        import numba

        self.old = numba.get_num_threads()
        numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))
        return True

    def __exit__(self, *exc: Any) -> None:
        if self.old is not None:
            import numba

            numba.set_num_threads(self.old)


class _LocalRun:
    """The bodies of an ensemble advancing together in this process: a run of :func:`lgvi.driver.drive`
    (``advance`` calls the compiled ensemble kernels; the kernels write at the global sample index)."""

    label = "ensemble"
    #: whether the free body with Cayley may take the SIMD lockstep path (a GPU run steps one body a thread)
    lockstep_allowed = True

    def __init__(self, s: _Setup, parallel: bool, first_body: int) -> None:
        from .._kernels import ensemble_kernels as ek
        from .rigid_body import momentum_matrices

        self.s, self.parallel, self.first_body = s, parallel, first_body
        B, h = len(s), s.h
        self.k, self.steps, self.save_every = 0, s.steps, s.save_every
        self.R = s.R.copy()
        self.Pi = s.Pi.copy()
        self.Jd = np.ascontiguousarray(np.stack([b.Jd for b in s.bodies]))
        self.J = np.ascontiguousarray(np.stack([b.J for b in s.bodies]))
        self.J_inv = np.ascontiguousarray(np.stack([b.J_inv for b in s.bodies]))
        for a in (self.Jd, self.J, self.J_inv):
            # read-only as a body's own (RigidBody's arrays are): a body's views are then of the types
            # lgvi.simulate passes, and one compiled loop serves both (run_chunk_forced, run_chunk_user)
            a.flags.writeable = False
        stages = 1 if s.legacy else len(s.gam)
        hs = np.array([h]) if s.legacy else s.gam * h
        self.G = np.zeros((B, stages, 5, 3))
        if B * stages <= PYTHON_COLD_START_MAX:
            # the cold start of simulate (the kernel's operations in Python: the same bits), a few
            # microseconds a history: a small ensemble's first call then does not compile init_histories
            from .rigid_body_run import cold_start_histories

            cold_start_histories(s.code, self.J, s.ib, hs, self.Pi, self.G)
        else:
            ek.init_histories(s.code, self.J, s.ib, hs, self.Pi, self.G)
        if not s.legacy:
            # momentum matrices per group of bodies with the same inertia and model (A[ia[b]])
            self.ia, reps = s.groups()
            rows = [s.ptab[r if len(s.ptab) > 1 else 0] for r in reps]
            self.A = np.ascontiguousarray(np.stack([momentum_matrices(s.bodies[s.ib[r]], s.codes, p, s.gam * h, s.sym)
                                                    for r, p in zip(reps, rows)]))
            self.S = np.zeros((B, 7))
        self.its = np.zeros(B, dtype=np.int64)
        self.res = np.zeros(B)
        self.status = np.zeros(B, dtype=np.int64)
        self.fail_step = np.full(B, -1, dtype=np.int64)
        self.fail_res = np.zeros(B)
        self.fail_its = np.zeros(B, dtype=np.int64)
        self.chunk = max(1, CHUNK_BODY_STEPS // (B * stages))
        # the built-in models and a user's compiled model (lgvi.torques.Compiled) run their bodies in
        # a pool of this many Python threads, one contiguous group each (_run_groups)
        self.threads = 1
        if parallel and not s.legacy:
            import numba

            self.threads = numba.get_num_threads()
        # the free body with Cayley runs LANES bodies in lockstep (SIMD), the same values bit for bit
        self.lockstep = self.lockstep_allowed and s.legacy and s.code == METHOD_CAYLEY
        if self.lockstep:
            self.X = np.zeros(((B + ek.LANES - 1) // ek.LANES, ek.NF * ek.LANES))
            ek.pack_groups(self.R, self.Pi, self.G, self.Jd, s.ib, self.status, self.its, self.res, self.X)

    def user_table(self) -> np.ndarray:
        """The user's parameter rows of this run's bodies: (B, P), or (1, P) for all (C-contiguous)."""
        m, body0 = self.s.model, getattr(self.s, "body0", 0)
        table = m.params[body0:body0 + len(self.s)] if m.params.ndim == 2 else m.params.reshape(1, -1)
        table = np.ascontiguousarray(table, dtype=np.float64)
        if table.flags.writeable:           # read-only as simulate's row: one compiled loop serves both
            table = table.copy()
            table.flags.writeable = False
        return table

    def _run_groups(self, call: Any) -> None:
        """``call(b0, b1)`` for the bodies split into ``self.threads`` contiguous ranges ``b0 .. b1-1``,
        each range on a thread of a pool (one compiled call a range: the compiled loops release the
        GIL; a call per body cost tens of microseconds of dispatch under the GIL, which serialised
        the threads). Each body has its own state and ``call`` gives each thread its own scratch
        arrays, so the numbers do not depend on the threads."""
        B = len(self.s)
        workers = min(self.threads, B)
        with quiet_function_argument():
            if workers <= 1:
                call(0, B)
                return
            ends = [int(g[-1]) + 1 for g in np.array_split(np.arange(B), workers)]
            with ThreadPoolExecutor(max_workers=workers) as pool:
                list(pool.map(call, [0] + ends[:-1], ends))

    def _advance_forced(self, n: int, R_out: np.ndarray, Pi_out: np.ndarray) -> None:
        """Steps ``k .. k + n - 1`` of the built-in models: each body runs the loop of
        :func:`lgvi.simulate` (:func:`lgvi._kernels.stepping.run_chunk_forced`), the bodies in ranges
        on threads (:meth:`_run_groups`, :func:`lgvi._kernels.ensemble_kernels.advance_forced`); up to
        ``PER_BODY_CALLS_MAX`` bodies, the range's loop over bodies runs here in Python (one compiled
        call a body, the arguments of :func:`~lgvi._kernels.ensemble_kernels.advance_forced`'s call),
        so that the first call compiles only the step loop that :func:`lgvi.simulate` compiles."""
        from .._kernels.ensemble_kernels import advance_forced, record_body
        from .._kernels.stepping import run_chunk_forced

        s, k, se = self.s, self.k, self.save_every
        gidx = np.arange(self.G.shape[1], dtype=np.int64)
        counts = np.zeros(0, dtype=np.int64)
        # the loop's record scratch, one entry a sample of the chunk (the loop then records per sample,
        # not per step; it records per step only when this is n entries, and then it is long enough)
        m = n // se + 1
        if len(s) <= PER_BODY_CALLS_MAX:
            record = getattr(record_body, "py_func", record_body)     # NUMBA_DISABLE_JIT: the function
            j, U = k // se + 1, _NO_HIST[:0, None]

            def each(b0: int, b1: int) -> None:
                it_rec, res_rec = np.zeros(m, np.int32), np.zeros(m)
                for b in range(b0, b1):
                    if self.status[b] != OK:
                        continue
                    q = s.ib[b]
                    st, kend, it_sum, rmax, it, rn = run_chunk_forced(
                        s.code, self.Jd[q], self.J[q], self.J_inv[q], s.h, s.t0, s.gam, s.cum, self.A[self.ia[b]],
                        self.R[b], self.Pi[b], self.G[b], gidx, self.S[b], s.codes,
                        s.ptab[b] if len(s.ptab) > 1 else s.ptab[0], U, int(s.sym), k, n, s.tol, s.max_iter,
                        s.alpha, se, se - k % se, R_out[b, j:], Pi_out[b, j:], it_rec, res_rec, _NO_HIST, counts)
                    record(b, self.its, self.res, self.status, self.fail_step, self.fail_res, self.fail_its, it_sum,
                           rmax, st, kend, it, rn)

            self._run_groups(each)
            return

        def bodies(b0: int, b1: int) -> None:
            advance_forced(b0, b1, s.code, self.Jd, self.J, self.J_inv, s.ib, s.h, s.t0, s.gam, s.cum, self.ia,
                                 self.A, self.R, self.Pi, self.G, gidx, self.S, s.codes, s.ptab, int(s.sym), k, n,
                                 s.tol, s.max_iter, s.alpha, se, 0, R_out, Pi_out, np.zeros(m, np.int32), np.zeros(m),
                                 self.its, self.res, self.status, self.fail_step, self.fail_res, self.fail_its,
                                 _NO_HIST, counts)

        self._run_groups(bodies)

    def _advance_user(self, n: int, R_out: np.ndarray, Pi_out: np.ndarray) -> None:
        """Steps ``k .. k + n - 1`` of a user's compiled model: each body runs the loop of
        :func:`lgvi.simulate` (:func:`lgvi._kernels.user_kernels.run_chunk_user`) with its parameter
        row, the bodies in ranges on threads (:meth:`_run_groups`,
        :func:`lgvi._kernels.user_kernels.advance_user`, which the GPU's kernel calls too)."""
        from .._kernels.user_kernels import advance_user, guarded

        s, k, se = self.s, self.k, self.save_every
        m = s.model
        gidx = np.arange(self.G.shape[1], dtype=np.int64)
        counts = np.zeros(0, dtype=np.int64)
        table = self.user_table()

        def bodies(b0: int, b1: int) -> None:
            Rs, Ps, it_buf, res_buf = np.zeros((3, 3)), np.zeros(3), np.zeros(n, np.int32), np.zeros(n)
            advance_user(b0, b1, guarded(m.moment_func), table, Rs, Ps,
                          m.conservative, m.depends_on_momentum, s.code, self.Jd, self.J, self.J_inv, s.ib, s.h, s.t0,
                          s.gam, s.cum, self.ia, self.A, self.R, self.Pi, self.G, gidx, self.S, s.codes, s.params,
                          int(s.sym), k, n, s.tol, s.max_iter, s.alpha, se, 0, R_out, Pi_out, it_buf, res_buf,
                          self.its, self.res, self.status, self.fail_step, self.fail_res, self.fail_its, _NO_HIST,
                          counts)

        self._run_groups(bodies)

    def advance(self, n: int, R_out: np.ndarray, Pi_out: np.ndarray, partial: Any) -> int:
        """Steps ``k .. k + n - 1`` of every body; on a failure ``k`` is the first failed step."""
        from .._kernels import ensemble_kernels as ek

        s, k, se, h, parallel = self.s, self.k, self.save_every, self.s.h, self.parallel
        if self.lockstep:
            run = ek.run_lockstep_parallel if parallel else ek.run_lockstep_serial
            run(self.X, self.Jd, s.ib, s.code, h, k, n, s.tol, s.max_iter, s.alpha, se, R_out, Pi_out, self.its,
                self.res, self.status, self.fail_step, self.fail_res, self.fail_its, _NO_HIST)
        elif s.legacy:
            run = ek.run_free_parallel if parallel else ek.run_free_serial
            run(s.code, self.Jd, s.ib, h, self.R, self.Pi, self.G, k, n, s.tol, s.max_iter, s.alpha, se, R_out,
                Pi_out, self.its, self.res, self.status, self.fail_step, self.fail_res, self.fail_its, _NO_HIST)
        elif getattr(s.model, "moment_func", None) is not None:    # lgvi.torques.Compiled
            self._advance_user(n, R_out, Pi_out)
        else:
            self._advance_forced(n, R_out, Pi_out)
        failed = np.flatnonzero(self.status != OK)
        if failed.size:
            b = int(failed[np.argmin(self.fail_step[failed])])
            self.k = int(self.fail_step[b])
            return int(self.status[b])
        self.k = k + n
        return OK

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any,
                where: str = "") -> ConvergenceError:
        """The error of the first failed body (the records are per body, kept here)."""
        from .._kernels import ensemble_kernels as ek

        s, h, B = self.s, self.s.h, len(self.s)
        if self.lockstep:
            ek.unpack_groups(self.X, self.R, self.Pi)
        failed = np.flatnonzero(self.status != OK)
        b = int(failed[np.argmin(self.fail_step[failed])])
        kf = int(self.fail_step[b])
        t_fail = s.t0 + kf * h
        hnorm = abs(h) * float(np.linalg.norm(self.Pi[b]))
        body = self.first_body + b
        if int(self.status[b]) == USER_RAISED:      # lgvi.torques.Compiled: its function raised in the loop
            row = getattr(s, "body0", 0) + b if s.model.params.ndim == 2 else None
            err = s.model.raised_error(kf, t_fail, h, self.R[b], self.Pi[b], row, trajectory,
                                       f" (the ensemble up to step {kf}, all bodies){where}")
            err.body = body  # type: ignore[attr-defined]
            return err
        more = f" ({failed.size} of {B} bodies failed)" if failed.size > 1 else ""
        msg = (f"body {body} failed at step {kf} (t = {t_fail:g}){more}: "
               + failure_message(int(self.status[b]), float(self.fail_res[b]), int(self.fail_its[b]), hnorm, s.tol,
                                 s.code, s.alpha)
               + f" The ensemble up to step {kf} (all bodies) is in .trajectory." + where)
        err = ConvergenceError(msg, residual=float(self.fail_res[b]), iterations=int(self.fail_its[b]), step=kf,
                               time=t_fail, trajectory=trajectory)
        err.body = body  # type: ignore[attr-defined]
        return err


class _LocalSink:
    """The ensemble's samples in memory, ``(B, M, ...)`` (a sink of :func:`lgvi.driver.drive`)."""

    where = ""
    interrupted = "the computed part (all bodies) is in .trajectory"

    def __init__(self, run: _LocalRun) -> None:
        s = run.s
        self.run, self.M = run, s.steps // s.save_every + 1
        self.R_out = np.empty((len(s), self.M, 3, 3))
        self.Pi_out = np.empty((len(s), self.M, 3))
        self.R_out[:, 0] = s.R
        self.Pi_out[:, 0] = s.Pi

    def buffers(self, k0: int, n: int) -> list[np.ndarray]:
        return [self.R_out, self.Pi_out]

    def result(self, m: int, partial: bool = False) -> EnsembleTrajectory:
        s, run = self.run.s, self.run
        t = s.times(m)
        Rm = self.R_out[:, :m].copy() if partial else self.R_out
        Pim = self.Pi_out[:, :m].copy() if partial else self.Pi_out
        meta = dict(s.meta, partial=True) if partial else s.meta
        return EnsembleTrajectory(t=t, R=Rm, Pi=Pim, inertia=s.inertia(), iterations=run.its.copy(),
                                  residual=run.res.copy(), h=s.h, potential=s.potential(t, Rm), meta=meta,
                                  model_params=s.model_params)

    def partial(self, k_done: int | None = None) -> EnsembleTrajectory:
        return self.result(k_done // self.run.save_every + 1, True)

    def failed(self, k0: int, k: int) -> tuple[float, int]:
        return 0.0, 0  # the run's failure reads its per-body records

    def commit(self, k0: int, n: int) -> None:
        pass

    def interrupt(self, k: int) -> EnsembleTrajectory:
        return self.partial(k)

    def finish(self) -> EnsembleTrajectory:
        return self.result(self.M)


def _run_local(s: _Setup, progress: Any = False, first_body: int = 0) -> EnsembleTrajectory:
    """Run the whole ensemble ``s`` in this process (``first_body``: global index of body 0, for messages)."""
    from ..driver import drive

    with _Threads(s.threads) as parallel:
        run = _LocalRun(s, parallel, first_body)
        return drive(run, _LocalSink(run), progress)  # lgvi.driver: chunks, progress, Ctrl-C, failures


def _blocks(s: _Setup, block_size: int | None, workers: int) -> list[tuple[int, int]]:
    B = len(s)
    per_body = (s.steps // s.save_every + 1) * 12 * 8
    cap = max(1, BLOCK_BYTES // per_body)
    if block_size is None:
        block_size = min(cap, math.ceil(B / (2 * workers)) if workers > 0 else B)
    return [(a, min(a + block_size, B)) for a in range(0, B, block_size)]


def _prepare_dir(out_dir: str | os.PathLike[str], resume: bool = False, blocks: int = 0) -> Path:
    folder = Path(os.fspath(out_dir))
    folder.mkdir(parents=True, exist_ok=True)
    old = sorted(folder.glob("ensemble-*.npz"))
    if old and not resume:
        raise ValueError(f"out_dir {folder} already holds ensemble blocks ({old[0].name}, ...); use an empty "
                         "folder or remove them (load_ensemble(folder) would mix the runs), or pass resume=True "
                         "to finish that run")
    mine = {BLOCK_PATTERN.format(i) for i in range(blocks)}
    extra = [p.name for p in old if p.name not in mine]
    if extra:
        raise ValueError(f"resume: out_dir {folder} holds block files that this run of {blocks} blocks would not "
                         f"write ({', '.join(extra[:3])}{', ...' if len(extra) > 3 else ''}): another run, or "
                         "another block_size; resume with the block_size of the first call")
    return folder


def _inputs_digest(s: _Setup) -> str:
    """Digest of what a block's bodies start from: attitudes, momenta, inertias, model parameters."""
    d = hashlib.sha256()
    for arr in (s.R, s.Pi, s.inertia(), s.ptab):
        d.update(str(arr.shape).encode())
        d.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
    for name, arr in sorted((s.model_params or {}).items()):
        d.update(name.encode())
        d.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
    return d.hexdigest()


def _block_header(sub: _Setup, index: int, start: int, total: int) -> dict[str, Any]:
    return dict(sub.meta, block=index, first_body=start, bodies_total=total, inputs=_inputs_digest(sub))


def _done_block(path: Path, sub: _Setup, index: int, start: int, total: int) -> bool:
    """True when ``path`` holds block ``index`` of this very run (by its header), False when there is
    no such file; ``ValueError`` naming the file when it holds anything else."""
    if not path.exists():
        return False
    try:
        if not path.is_file() or path.is_symlink():
            raise ValueError("not a regular file")
        check_npz(path)
        with np.load(path, allow_pickle=False) as data:
            header = load_json(str(data["__lgvi__"]), f"{path}: the '__lgvi__' header")
        meta = header["meta"]
    except Exception as exc:
        raise ValueError(f"resume: {path} is not a readable ensemble block ({type(exc).__name__}: {exc}); remove "
                         "it to have it computed again") from exc
    want = json.loads(json.dumps(_block_header(sub, index, start, total)))
    if meta != want:
        diff = sorted(str(k) for k in set(meta) | set(want) if meta.get(k) != want.get(k))
        why = ("the initial states, inertias or model parameters of its bodies differ" if diff == ["inputs"]
               else f"differences: {', '.join(diff)}")
        raise ValueError(f"resume: {path} was not written by this run ({why}); resume with the arguments of the "
                         "first call, or use another out_dir")
    return True


class _BlockProgress:
    """Progress over blocks: ``True`` draws a ``tqdm`` bar of bodies done, a callable gets ``(done, total)``."""

    def __init__(self, progress: Any, total: int) -> None:
        from ..driver import Progress as _Progress

        self.bar, self.done = _Progress(progress, total, unit="body"), 0

    def add(self, n: int) -> None:
        self.done += n
        self.bar.update(self.done)
        if self.done >= self.bar.steps:
            self.bar.__exit__(None, None, None)


def _block_meta(ens: EnsembleTrajectory, meta: dict[str, Any]) -> EnsembleTrajectory:
    return EnsembleTrajectory(t=ens.t, R=ens.R, Pi=ens.Pi, inertia=ens.inertia, iterations=ens.iterations,
                              residual=ens.residual, h=ens.h, potential=ens.potential, meta=meta,
                              model_params=ens.model_params)


def _block_task(sub: _Setup, start: int, path: str | None, index: int, total: int) -> Any:
    """One block: an in-process ensemble run (on a Dask worker), returned or written to ``path``."""
    ens = _run_local(sub, first_body=start)
    if path is None:
        return ens
    _block_meta(ens, _block_header(sub, index, start, total)).save(path)
    return path


def _run_blocks(s: _Setup, block_size: int | None, out_dir: Any, progress: Any, resume: bool = False) -> list[Path]:
    blocks = _blocks(s, block_size, 0)
    folder = _prepare_dir(out_dir, resume, len(blocks))
    bar = _BlockProgress(progress, len(s))
    paths = []
    for i, (a, b) in enumerate(blocks):
        path = folder / BLOCK_PATTERN.format(i)
        sub = s.block(a, b, s.threads)
        if not (resume and _done_block(path, sub, i, a, len(s))):     # resume: a finished block is kept
            _block_task(sub, a, str(path), i, len(s))
        paths.append(path)
        bar.add(b - a)
    return paths


def _run_dask(s: _Setup, client: Any, block_size: int | None, out_dir: Any,
              progress: Any, resume: bool = False) -> EnsembleTrajectory | list[Path]:
    try:
        from distributed import as_completed
    except ImportError as exc:  # pragma: no cover - a client without distributed cannot exist
        raise ImportError("client= needs dask.distributed: pip install 'lgvi[dask]'") from exc
    try:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
    except Exception:  # pragma: no cover - clients without scheduler_info
        workers = 1
    threads = 1 if s.threads is None else s.threads
    blocks = _blocks(s, block_size, workers)
    folder = _prepare_dir(out_dir, resume, len(blocks)) if out_dir is not None else None
    futures = []
    index = {}
    results: list[Any] = [None] * len(blocks)
    bar = _BlockProgress(progress, len(s))
    for i, (a, b) in enumerate(blocks):
        path = None if folder is None else str(folder / BLOCK_PATTERN.format(i))
        sub = s.block(a, b, threads)
        if resume and _done_block(Path(path), sub, i, a, len(s)):     # resume: a finished block is kept
            results[i] = path
            bar.add(b - a)
            continue
        futures.append(client.submit(_block_task, sub, a, path, i, len(s), pure=False))
        index[futures[-1].key] = i
    try:
        for fut in as_completed(futures):
            i = index[fut.key]
            results[i] = fut.result()  # raises the task's error (ConvergenceError names the global body)
            bar.add(blocks[i][1] - blocks[i][0])
    except KeyboardInterrupt:
        client.cancel(futures)
        raise SimulationInterrupted("ensemble interrupted: the Dask tasks were cancelled"
                                    + (f"; finished blocks are in {folder}" if folder else ""),
                                    trajectory=None) from None
    except BaseException:
        client.cancel(futures)
        raise
    if folder is not None:
        return [Path(p) for p in results]
    return concatenate(results)


#: The in-process run's pieces by public name, for the runs of other devices (:mod:`lgvi.gpu` builds
#: its run and sink on them: the same set-up, records, failures and results)
EnsembleSetup, LocalRun, LocalSink = _Setup, _LocalRun, _LocalSink

__all__ = ["EnsembleSetup", "EnsembleTrajectory", "LocalRun", "LocalSink", "concatenate", "load_ensemble",
           "provide_device", "quiet_function_argument", "simulate_ensemble"]
