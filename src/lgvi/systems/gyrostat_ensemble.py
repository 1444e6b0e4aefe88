"""Monte Carlo ensembles of the gyrostat: ``lgvi.simulate_ensemble(..., wheels=, controller=)``.

Every member is one :class:`lgvi.systems.gyrostat.GyrostatRun`, driven through the gyrostat's
compiled loop exactly as :func:`lgvi.simulate` drives it, so member ``b`` equals
``lgvi.simulate(bodies[b], R0[b], ..., wheels=wheels[b], controller=controller[b])`` bit for bit.
The members run in a pool of threads: the compiled loop releases the GIL (``nogil=True``), so
members whose controller is compiled (:class:`lgvi.control.MRPFeedback` without an environment)
step in parallel; a Python controller takes the GIL at each of its calls (the steps between
calls still run in parallel). Everything that may differ per member (inertia, initial state,
wheel axes, spin inertias, initial speeds, limits, the controller's numeric parameters) is
recorded in ``params`` and, where it differs, in ``dispersions``.
"""

from __future__ import annotations

import copy
import json
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Sequence

import numpy as np

from .._validation import as_float_array, as_int
from ..control import Controller
from ..driver import MemorySink, drive
from ..errors import ConvergenceError, TorqueError
from .gyrostat import GyrostatRun, GyrostatTrajectory, ReactionWheels

__all__ = ["FORMAT", "GyrostatEnsemble", "controller_params", "drive_members", "per_member", "simulate_gyrostat_ensemble",
           "thread_count", "wheel_params"]

#: Format of a saved gyrostat ensemble (the ``__lgvi__`` header of its ``.npz``).
FORMAT = "lgvi.gyrostat_ensemble/1"
#: The members' arrays, stacked over members in the file (``t`` and ``h`` are shared).
_MEMBER_ARRAYS = ("R", "Pi", "inertia", "iterations", "residual", "wheel_momentum", "wheel_torque", "wheel_axes",
                  "spin_inertia")
#: Prefix of the entries of ``params`` in the file.
_PARAM_PREFIX = "param:"
#: The ensemble class of each member system (``meta["system"]`` of the members): a system whose
#: members carry more arrays (the spacecraft's records, ``RESULT_TYPES``) registers its class here,
#: and :meth:`GyrostatEnsemble.save`/``load`` keep those arrays too.
ENSEMBLE_TYPES: dict[str, type] = {}


@dataclass(frozen=True, eq=False)
class GyrostatEnsemble:
    """``B`` gyrostat runs (reaction wheels, a control loop) at the same ``M`` times.

    Attributes
    ----------
    members : tuple of B :class:`lgvi.systems.gyrostat.GyrostatTrajectory`
        Member ``b``'s run, the result of ``lgvi.simulate`` with its inputs (``ens[b]``).
    params : dict
        Every member's inputs that may be dispersed, name -> ``(B, ...)`` array: ``"inertia"``
        (B, 3, 3) (wheels locked), ``"R0"`` (B, 3, 3), ``"Pi0"`` (B, 3) (total body momentum),
        ``"wheels.axes"`` (B, N, 3), ``"wheels.spin_inertia"``, ``"wheels.speed0"``,
        ``"wheels.max_torque"``, ... (B, N), and ``"controller.<name>"`` for the controller's
        numeric attributes (``controller.K``, ``controller.P``, ... of
        :class:`lgvi.control.MRPFeedback`).
    meta : dict
        The run's options and how the members ran (``"threads"``).

    Stacked over members (computed on first access): ``t`` (M,), ``R`` (B, M, 3, 3), ``Pi``
    (B, M, 3), ``omega`` (B, M, 3), ``wheel_momentum``, ``wheel_speed``, ``wheel_torque``
    (B, M, N), ``spatial_momentum`` (B, M, 3); ``dispersions``: the entries of ``params`` that
    differ between members.
    """

    members: tuple[GyrostatTrajectory, ...]
    params: dict[str, np.ndarray]
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for arr in self.params.values():
            arr.flags.writeable = False

    def __len__(self) -> int:
        return len(self.members)

    def __getitem__(self, b: int) -> GyrostatTrajectory:
        return self.members[b]

    def __repr__(self) -> str:
        return (f"GyrostatEnsemble(members={len(self)}, samples={len(self.t)}, wheels={self.wheel_momentum.shape[-1]}, "
                f"dispersions={sorted(self.dispersions)})")

    @property
    def dispersions(self) -> dict[str, np.ndarray]:
        """The entries of :attr:`params` that differ between members, name -> ``(B, ...)``."""
        return {k: v for k, v in self.params.items() if not np.array_equal(v, v[:1].repeat(len(v), axis=0))}

    def _stack(self, name: str) -> np.ndarray:
        out = np.stack([getattr(m, name) for m in self.members])
        out.flags.writeable = False
        return out

    @cached_property
    def t(self) -> np.ndarray:
        return self.members[0].t

    @cached_property
    def R(self) -> np.ndarray:
        return self._stack("R")

    @cached_property
    def Pi(self) -> np.ndarray:
        return self._stack("Pi")

    @cached_property
    def omega(self) -> np.ndarray:
        return self._stack("omega")

    @cached_property
    def wheel_momentum(self) -> np.ndarray:
        return self._stack("wheel_momentum")

    @cached_property
    def wheel_speed(self) -> np.ndarray:
        return self._stack("wheel_speed")

    @cached_property
    def wheel_torque(self) -> np.ndarray:
        return self._stack("wheel_torque")

    @cached_property
    def spatial_momentum(self) -> np.ndarray:
        return self._stack("spatial_momentum")

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write to ``path`` (``.npz``, uncompressed, atomically); :meth:`load` (or
        ``lgvi info``) reads it back bit for bit.

        The members' arrays are stacked over members (``R`` (B, M, 3, 3), ``wheel_momentum``
        (B, M, N), ...), ``t`` and ``h`` stored once, ``params`` as ``param:<name>``; the header
        holds the ensemble's ``meta`` and every member's. Raises ``OSError`` naming the file and
        its folder if the write fails (a full disk).
        """
        from .._files import write_atomic, write_failure
        from .._version import __version__

        members = self.members
        if any(m.potential is not None for m in members) and any(m.potential is None for m in members):
            raise ValueError("cannot save an ensemble whose members differ in having a potential")
        arrays: dict[str, np.ndarray] = {"t": np.asarray(members[0].t), "h": np.float64(members[0].h)}
        for name in _MEMBER_ARRAYS + _extra_arrays(members[0].meta):
            shapes = {np.shape(getattr(m, name)) for m in members}
            if len(shapes) > 1:
                raise ValueError(f"cannot save an ensemble whose members' {name!r} differ in shape ({sorted(shapes)}): "
                                 "save the members one by one (lgvi.Trajectory.save)")
            arrays[name] = np.stack([np.asarray(getattr(m, name)) for m in members])
        if members[0].potential is not None:
            arrays["potential"] = np.stack([np.asarray(m.potential) for m in members])
        for name, arr in self.params.items():
            arrays[_PARAM_PREFIX + name] = np.asarray(arr)
        header = json.dumps({"format": FORMAT, "meta": dict(self.meta, lgvi_version=self.meta.get(
            "lgvi_version", __version__)), "members": [m.meta for m in members]})
        try:
            write_atomic(os.fspath(path), lambda fh: np.savez(fh, __lgvi__=np.array(header), **arrays))
        except OSError as exc:
            raise write_failure(exc, os.fspath(path), "the gyrostat ensemble", "The file was left as it was "
                                "(files are replaced only once complete).") from exc

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "GyrostatEnsemble":
        """Read an ensemble written by :meth:`save`.

        Raises
        ------
        ValueError
            Naming the file, when it is not such an ensemble: not an ``.npz``, object arrays or
            sizes beyond the file (refused before reading), another format, missing fields,
            arrays of the wrong shape or type.
        """
        path = os.fspath(path)
        try:
            return _read(path)
        except MemoryError:
            raise
        except ValueError as exc:
            raise (exc if path in str(exc) else ValueError(f"cannot read gyrostat ensemble {path}: {exc}")) from exc
        except Exception as exc:  # OSError, zip, JSON and numpy errors of damaged files
            raise ValueError(f"cannot read gyrostat ensemble {path}: {type(exc).__name__}: {exc}") from exc


def _read(path: str) -> GyrostatEnsemble:
    """The ensemble in ``path`` (checked: see :meth:`GyrostatEnsemble.load`)."""
    from .._files import lgvi_header
    from .._untrusted import check_npz
    from ..trajectory import RESULT_TYPES, check_arrays

    from_file = RESULT_TYPES["gyrostat"][1]          # a member as lgvi.load reads one (shapes checked)
    names = _MEMBER_ARRAYS

    with open(path, "rb") as fh:
        if fh.read(2) != b"PK":
            raise ValueError("not an .npz (zip) archive")
    check_npz(path)       # no object arrays, no declared size beyond the file's bytes
    with np.load(path, allow_pickle=False) as data:
        header = lgvi_header(data, FORMAT)
        metas = header.get("members")
        system = str(metas[0].get("system")) if isinstance(metas, list) and metas and isinstance(metas[0], dict) \
            else "gyrostat"
        if system in ENSEMBLE_TYPES and system in RESULT_TYPES:      # members with more arrays (the records)
            names, from_file = _MEMBER_ARRAYS + _extra_arrays({"system": system}), RESULT_TYPES[system][1]
        missing = [k for k in ("t", "h") + names if k not in data.files]
        if missing:
            raise ValueError(f"missing field(s) {', '.join(missing)}")
        arrays = {k: data[k] for k in ("t", "h") + names}
        potential = data["potential"] if "potential" in data.files else None
        params = {k[len(_PARAM_PREFIX):]: data[k] for k in data.files if k.startswith(_PARAM_PREFIX)}
    meta, metas = header.get("meta", {}), header.get("members")
    if not isinstance(meta, dict):
        raise ValueError("the header's 'meta' must be a JSON object")
    B = arrays["R"].shape[0] if arrays["R"].ndim else -1
    if not isinstance(metas, list) or len(metas) != B or B < 1 or not all(isinstance(m, dict) for m in metas):
        raise ValueError(f"the header's 'members' must be a list of one JSON object per member ({B})")
    h = arrays.pop("h")
    if h.size != 1 or h.dtype.kind not in "iuf":
        raise ValueError(f"field 'h' must be one real number, got shape {h.shape}, dtype {h.dtype}")
    for name, arr in list(arrays.items()) + [("potential", potential)]:
        if arr is not None and name != "t" and (arr.ndim < 1 or arr.shape[0] != B):
            raise ValueError(f"field {name!r} must have one entry per member ({B}), got shape {arr.shape}")
    for name, arr in params.items():
        if arr.ndim < 1 or arr.shape[0] != B or arr.dtype.kind not in "iuf":
            raise ValueError(f"field {_PARAM_PREFIX + name!r} must have one row per member ({B}), got shape "
                             f"{arr.shape} and dtype {arr.dtype}")
    members = []
    for b in range(B):
        fields = {k: arrays[k][b] for k in names}
        fields["t"] = arrays["t"].copy()
        pot = None if potential is None else potential[b]
        try:
            check_arrays({k: fields[k] for k in ("t", "R", "Pi", "inertia", "iterations", "residual")}, pot)
            for k in names[5:]:
                if fields[k].dtype.kind not in "iuf":
                    raise ValueError(f"field {k!r} must hold real numbers, got dtype {fields[k].dtype}")
            members.append(from_file(h=float(h.reshape(())), potential=pot, meta=metas[b], **fields))
        except ValueError as exc:
            raise ValueError(f"member {b}: {exc}") from None
    return ENSEMBLE_TYPES.get(system, GyrostatEnsemble)(members=tuple(members), params=params, meta=meta)


def _extra_arrays(meta: dict[str, Any]) -> tuple[str, ...]:
    """The member arrays beyond the gyrostat's of a registered member system (:data:`ENSEMBLE_TYPES`)."""
    from ..trajectory import RESULT_TYPES

    system = str(meta.get("system"))
    if system not in ENSEMBLE_TYPES or system not in RESULT_TYPES:
        return ()
    return tuple(k for k in RESULT_TYPES[system][0] if k not in _MEMBER_ARRAYS)


def per_member(value: Any, name: str, B: int, kind: type) -> list[Any]:
    """``value`` for every member: one object (copied per member) or a sequence of ``B``."""
    if isinstance(value, (list, tuple)):
        if len(value) != B:
            raise ValueError(f"{name} gives {len(value)} entries but R0 has {B} attitudes; give one for all or "
                             "one per member")
        for b, v in enumerate(value):
            if not isinstance(v, kind):
                raise TypeError(f"{name}[{b}] must be an {kind.__module__.replace('.systems.gyrostat', '')}."
                                f"{kind.__name__}, got {type(v).__name__}")
        items = list(value)
    else:
        if not isinstance(value, kind):
            raise TypeError(f"{name} must be an lgvi {kind.__name__} or a sequence of B of them, got "
                            f"{type(value).__name__}")
        items = [value] * B
    return [copy.deepcopy(v) for v in items]


def _numeric(value: Any) -> np.ndarray | None:
    if isinstance(value, (bool, np.bool_)) or value is None or callable(value):
        return None
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    return arr if arr.size <= 64 else None


#: a controller's attributes that ``setup``/``reset`` derive from the run (not inputs)
_RUN_STATE = frozenset({"body", "wheels", "J", "axes", "spin_inertia", "wheel_map", "int_sigma", "prior_time"})


def wheel_params(wl: Sequence[Any]) -> dict[str, np.ndarray]:
    """``wheels.<name>``: every member's wheel description (``ReactionWheels.describe``), stacked."""
    return {f"wheels.{key}": np.stack([np.asarray(w.describe()[key], dtype=np.float64) for w in wl])
            for key in wl[0].describe()}


def controller_params(ctrls: Sequence[Any]) -> dict[str, np.ndarray]:
    """``controller.<name>``: the numeric public attributes every member's controller has, same shapes."""
    out: dict[str, np.ndarray] = {}
    names = [k for k in vars(ctrls[0]) if not k.startswith("_") and k not in _RUN_STATE]
    for name in names:
        vals = [_numeric(getattr(c, name, None)) for c in ctrls]
        if all(v is not None and v.shape == vals[0].shape for v in vals):
            out[f"controller.{name}"] = np.stack(vals)
    return out


def thread_count(threads: Any, B: int) -> int:
    """The threads an ensemble of ``B`` members runs in: ``threads`` (checked), default one per core."""
    return min(B, os.cpu_count() or 1) if threads is None else as_int(threads, "threads", minimum=1)


def drive_members(runs: Sequence[Any], threads: Any) -> list[Any]:
    """Drive each run into its own :class:`lgvi.driver.MemorySink`, in ``threads`` threads (default one
    per core); a failure names its member (``err.body``)."""
    B = len(runs)
    threads = thread_count(threads, B)

    def one(b: int) -> Any:
        try:
            return drive(runs[b], MemorySink(runs[b]), False)
        except (ConvergenceError, TorqueError) as exc:
            exc.body = b
            exc.args = (f"member {b}: {exc.args[0]}",) + exc.args[1:] if exc.args else exc.args
            raise

    if threads == 1 or B == 1:
        return [one(b) for b in range(B)]
    with ThreadPoolExecutor(max_workers=min(threads, B)) as pool:
        return list(pool.map(one, range(B)))


def simulate_gyrostat_ensemble(bodies: Sequence[Any], R: np.ndarray, Pi0: Any = None, *, omega0: Any = None,
                               h: Any, steps: Any, wheels: Any = None, controller: Any = None,
                               control_period: Any = None, environment: Any = None, magnetorquers: Any = None,
                               torque: Any = None, threads: Any = None, **options: Any) -> GyrostatEnsemble:
    """:func:`lgvi.simulate_ensemble` with ``wheels=`` or ``controller=`` (see there); ``bodies`` (B
    :class:`lgvi.RigidBody`) and ``R`` (B, 3, 3) rotations are validated by the caller."""
    B = len(R)
    if (Pi0 is None) == (omega0 is None):
        raise ValueError("give the initial body angular momenta Pi0 (B, 3) or the angular velocities omega0 (B, 3), "
                         "one of the two")
    init = as_float_array(Pi0 if omega0 is None else omega0, "Pi0" if omega0 is None else "omega0", (B, 3))
    wl = per_member(wheels, "wheels", B, ReactionWheels) if wheels is not None else [None] * B
    if wheels is not None:
        n = {len(w) for w in wl}
        if len(n) > 1:
            raise ValueError(f"wheels must have the same number of wheels in every member, got {sorted(n)}")
    cl = per_member(controller, "controller", B, Controller) if controller is not None else [None] * B
    ctrl_params = controller_params(cl) if controller is not None else {}     # before setup
    threads = thread_count(threads, B)
    runs = []
    for b in range(B):
        kw = {"Pi0": init[b], "omega0": None} if omega0 is None else {"Pi0": None, "omega0": init[b]}
        try:
            runs.append(GyrostatRun(bodies[b], R[b], kw["Pi0"], omega0=kw["omega0"], h=h, steps=steps,
                                    wheels=wl[b], controller=cl[b], control_period=control_period,
                                    environment=environment, magnetorquers=magnetorquers, torque=torque, **options))
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"member {b}: {exc}") from exc
    params: dict[str, np.ndarray] = {
        "inertia": np.stack([r.body.J for r in runs]),
        "R0": R.copy(),
        "Pi0": np.stack([r.Pi for r in runs]),
    }
    if wheels is not None:
        params.update(wheel_params(wl))
    params.update(ctrl_params)

    members = drive_members(runs, threads)
    meta = dict(members[0].meta, members=B, threads=min(threads, B))
    for key in ("wheels", "controller", "solver_summary", "invariants"):
        meta.pop(key, None)
    return GyrostatEnsemble(members=tuple(members), params=params, meta=meta)
