"""The result of a simulation: time-first arrays plus diagnostics, saved and loaded as ``.npz``."""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ._untrusted import check_npz, load_json
from ._version import __version__

if TYPE_CHECKING:  # annotations only: none of these is imported at run time here
    import pandas
    import xarray
    from scipy.spatial.transform import Rotation

    from .accuracy import ErrorEstimate

FORMAT = "lgvi.trajectory/1"

#: The array fields of a result (``potential`` may be ``None``).
ARRAY_FIELDS = ("t", "R", "Pi", "inertia", "iterations", "residual", "potential")

#: Bins of the solver's iteration histogram: bin ``i`` counts the steps with ``i`` solver
#: updates, the last bin those with ``HIST_BINS - 1`` or more.
HIST_BINS = 64


def summary_dict(counts: Any, iterations_total: int, residual_max: float,
                 iterations_max: int | None = None) -> dict[str, Any]:
    """The solver's run totals as stored in ``meta["solver_summary"]`` (JSON-serialisable).

    ``counts`` is the iteration histogram (see :data:`HIST_BINS`); the number of steps is its sum
    and, unless given, the largest iteration count its last non-empty bin.
    """
    counts = np.asarray(counts, dtype=np.int64)
    nz = counts.nonzero()[0]
    top = int(nz[-1]) if len(nz) else 0
    hist = counts.tolist()                      # Python ints (JSON), without a loop over the bins
    return {"steps": sum(hist), "iterations_total": int(iterations_total),
            "iterations_max": top if iterations_max is None else max(int(iterations_max), top),
            "residual_max": float(residual_max), "histogram": hist}


def merge_summaries(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """The totals of two consecutive parts of a run (as :func:`summary_dict`)."""
    ha, hb = np.asarray(a["histogram"], dtype=np.int64), np.asarray(b["histogram"], dtype=np.int64)
    n = max(len(ha), len(hb))
    hist = np.pad(ha, (0, n - len(ha))) + np.pad(hb, (0, n - len(hb)))
    return summary_dict(hist, int(a["iterations_total"]) + int(b["iterations_total"]),
                        max(float(a["residual_max"]), float(b["residual_max"])),
                        max(int(a["iterations_max"]), int(b["iterations_max"])))


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)):
        return obj.tolist()
    return str(obj)


#: Jupyter's rich display of a trajectory, ``rich_display(traj, include, exclude) -> mimebundle``:
#: set by :mod:`lgvi.view` (a layer above, imported by the package), ``None`` without it.
rich_display = None


def freeze_arrays(obj: Any, names: tuple[str, ...]) -> None:
    """Turn the named fields of a frozen dataclass into read-only arrays (``None`` stays)."""
    for name in names:
        arr = getattr(obj, name)
        if arr is not None:
            if type(arr) is not np.ndarray:
                arr = np.asarray(arr)
                object.__setattr__(obj, name, arr)
            arr.setflags(write=False)


def _continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs along axis 0 so consecutive quaternions have non-negative dot products."""
    if len(q) < 2:
        return q
    flips = np.einsum("ij,ij->i", q[1:], q[:-1]) < 0
    sign = np.concatenate([[1.0], np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)])
    return q * sign[:, None]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A simulated attitude motion, sampled at ``M`` times.

    Attributes
    ----------
    t : (M,) ndarray
        Sample times.
    R : (M, 3, 3) ndarray
        Attitude (maps body vectors to inertial ones).
    Pi : (M, 3) ndarray
        Body angular momentum ``J Omega``.
    inertia : (3, 3) ndarray
        Standard inertia ``J`` of the body.
    iterations : (M - 1,) or (steps,) ndarray of int
        The solver's record of iterations, at the resolution the run asked for
        (``solver_record``, ``meta["solver_record"]``): with ``"interval"`` (the default), entry
        ``i`` is the largest number of solver updates of the ``save_every`` steps from sample
        ``i`` to sample ``i + 1``, shape ``(M - 1,)``; with ``"full"`` (and for files written
        before lgvi recorded by interval), the updates of every step, shape ``(steps,)``. With
        ``save_every = 1`` the two are the same array. Totals over every step are in
        :attr:`solver_summary`.
    residual : (M - 1,) or (steps,) ndarray of float
        Final residual ``|vee(F Jd - Jd F^T) - h Pi|`` of the solves, as ``iterations``: the
        largest of each saved interval, or of every step.
    potential : (M,) ndarray or None
        Potential energy at each sample, for conservative torque models; ``energy`` adds it.
    h : float
        Step size.
    meta : dict
        Method, tolerance, package version and any run metadata (JSON-serialisable).

    error_estimate : lgvi.accuracy.ErrorEstimate or None
        The estimated global error of the run (``simulate(..., error_estimate=True)``), read
        from ``meta["error_estimate"]`` so that it is saved and loaded with the trajectory;
        ``None`` when the run was made without it.

    Derived (computed on first access): ``steps``, ``solver_summary`` (run totals and
    histogram of the solver's iterations), ``omega`` (M,3), ``energy`` (M,),
    ``kinetic_energy`` (M,), ``spatial_momentum`` (M,3), ``quaternion`` (M,4) scalar-last and
    sign-continuous, ``rotation`` (a scipy ``Rotation``), ``orthogonality_error`` (M,).
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

    #: Array fields that describe the body, not a sample (never sliced or interpolated; the
    #: gyrostat's wheels too).
    STATIC_FIELDS: ClassVar[frozenset[str]] = frozenset({"inertia", "wheel_axes", "spin_inertia"})
    #: The solver's record (per saved interval or per step), reduced by maximum when sliced.
    RECORD_FIELDS: ClassVar[tuple[str, ...]] = ("iterations", "residual")

    def __post_init__(self) -> None:
        freeze_arrays(self, ARRAY_FIELDS)

    # ---------------------------------------------------------------- samples: slices, times
    def _sampled(self) -> dict[str, np.ndarray]:
        """The array fields with one entry per sample (``t``, ``R``, ``Pi``, ``potential``, ...)."""
        M = len(self.t)
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if (isinstance(v, np.ndarray) and v.ndim >= 1 and len(v) == M and f.name not in self.STATIC_FIELDS
                    and f.name not in self.RECORD_FIELDS):
                out[f.name] = v
        return out

    def _interval_record(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The solver's record as one entry per saved interval (the largest over its steps), or
        ``None`` when it cannot be told (a baseline's record of another length)."""
        n = len(self.t) - 1
        its, res = np.asarray(self.iterations), np.asarray(self.residual)
        if n <= 0 or len(its) != len(res) or len(its) % n:
            return None
        per = len(its) // n                      # 1 for an interval record, save_every for a per-step one
        return its.reshape(n, per).max(axis=1), res.reshape(n, per).max(axis=1)

    def __getitem__(self, key: slice) -> "Trajectory":
        """The samples ``key`` (a slice stepping forward in time) as a trajectory of the same kind.

        ``traj[::10]`` keeps every tenth sample, ``traj[100:]`` drops the first hundred. The
        solver's record becomes one entry per new interval: the largest over the steps it
        covers. The run totals (:attr:`solver_summary`) are kept when the slice still spans the
        whole run, and otherwise computed from that record.

        >>> import numpy as np, lgvi
        >>> traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=100)
        >>> traj[::10].t.shape, traj[::10].R.shape
        ((11,), (11, 3, 3))
        """
        if not isinstance(key, slice):
            raise TypeError(f"a trajectory is indexed by a slice of its samples (traj[a:b:k]), got "
                            f"{type(key).__name__} {key!r}; the state at sample k is traj.R[k], traj.Pi[k], "
                            "and at a time t, traj.at(t)")
        M = len(self.t)
        start, stop, step = key.indices(M)
        if step < 1:
            raise ValueError(f"a trajectory slice must step forward in time (step >= 1), got step={key.step!r}; "
                             "reverse an array itself (traj.R[::-1]) instead")
        idx = np.arange(start, stop, step)
        changes: dict[str, Any] = {name: v[idx] for name, v in self._sampled().items()}
        record = self._interval_record()
        meta = dict(self.meta)
        whole = len(idx) > 0 and idx[0] == 0 and idx[-1] == M - 1
        if not whole:
            meta.pop("solver_summary", None)
        if record is not None and len(idx) >= 2:
            its, res = record
            changes["iterations"] = np.maximum.reduceat(its[:idx[-1]], idx[:-1])
            changes["residual"] = np.maximum.reduceat(res[:idx[-1]], idx[:-1])
            meta["solver_record"] = "interval"
        else:
            changes["iterations"] = np.zeros(0, dtype=np.asarray(self.iterations).dtype)
            changes["residual"] = np.zeros(0)
        return dataclasses.replace(self, meta=meta, **changes)

    def at(self, t: Any) -> "Trajectory":
        """The state at the times ``t`` (a number or an array inside the run), as a trajectory.

        The attitude is interpolated along the geodesic of SO(3) between the neighbouring samples
        (slerp: ``R_k exp(s log(R_k^T R_{k+1}))``), every other sampled array (``Pi``, the
        potential, wheel momenta, ...) linearly; at a sample's time the sample itself is
        returned, bit for bit. The samples must be closer than half a turn of the body for the
        geodesic to be the motion. The result has one sample per time and no solver record (its
        run totals are the run's).

        Raises
        ------
        ValueError
            A time outside ``[t[0], t[-1]]`` or not finite.

        >>> import numpy as np, lgvi
        >>> traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=100)
        >>> mid = traj.at(0.505)
        >>> mid.R.shape, bool(np.allclose(mid.R[0].T @ mid.R[0], np.eye(3)))
        ((1, 3, 3), True)
        """
        from . import so3

        tq = np.atleast_1d(np.asarray(t, dtype=np.float64))
        ts = np.asarray(self.t)
        M = len(ts)
        if tq.ndim != 1:
            raise ValueError(f"t must be a number or a one-dimensional array of times, got shape {tq.shape}")
        lo, hi = (float(ts.min()), float(ts.max())) if M else (np.nan, np.nan)
        bad = ~np.isfinite(tq) | (tq < lo) | (tq > hi)
        if M == 0 or bad.any():
            raise ValueError(f"t must lie inside the run, [{lo:.17g}, {hi:.17g}]; got {tq[bad][:3].tolist()}")
        order = np.arange(M) if M < 2 or ts[-1] >= ts[0] else np.arange(M)[::-1]   # a backward run: h < 0
        asc = ts[order]
        j = np.clip(np.searchsorted(asc, tq, side="right") - 1, 0, max(M - 2, 0))
        a, b = order[j], order[np.minimum(j + 1, M - 1)]
        span = ts[b] - ts[a]
        s = np.divide(tq - ts[a], span, out=np.zeros_like(tq), where=span != 0)
        at_a, at_b = tq == ts[a], tq == ts[b]
        R = np.asarray(self.R)
        Rq = np.einsum("mij,mjk->mik", R[a], so3.exp(s[:, None] * so3.log(np.einsum("mji,mjk->mik", R[a], R[b]))))
        Rq[at_a], Rq[at_b & ~at_a] = R[a][at_a], R[b][at_b & ~at_a]
        changes: dict[str, Any] = {"t": tq.copy(), "R": Rq}
        for name, v in self._sampled().items():
            if name in ("t", "R"):
                continue
            w = s.reshape((-1,) + (1,) * (v.ndim - 1))
            out = v[a] + w * (v[b] - v[a])
            out[at_a], out[at_b & ~at_a] = v[a][at_a], v[b][at_b & ~at_a]
            changes[name] = out
        changes["iterations"] = np.zeros(0, dtype=np.asarray(self.iterations).dtype)
        changes["residual"] = np.zeros(0)
        meta = dict(self.meta, interpolated=True)
        if "solver_summary" not in meta:
            meta["solver_summary"] = dict(self.solver_summary, histogram=self.solver_summary["histogram"].tolist())
        return dataclasses.replace(self, meta=meta, **changes)

    def to_xarray(self) -> "xarray.Dataset":
        """The trajectory as an ``xarray.Dataset`` (the ``io`` extra): dimension ``time`` (M),
        ``row``/``col``/``axis`` (3), ``component`` (4: ``x y z w``, scalar last), the solver's
        record along ``interval`` (M - 1) or ``step``; variables ``R``, ``Pi``, ``omega``,
        ``quaternion``, ``energy`` (and ``potential``), ``inertia``, ``iterations``, ``residual``
        and a subclass's sampled arrays (``wheel_momentum``: ``time`` x ``wheel``), with units;
        attributes ``h`` and ``lgvi_meta`` (the JSON of ``meta``)."""
        try:
            import xarray as xr
        except ImportError as exc:
            raise ImportError(f"to_xarray needs xarray: pip install 'lgvi[io]' ({exc})") from exc
        interval = (self.meta or {}).get("solver_record") == "interval" and len(self.iterations) == len(self.t) - 1
        rec_dim = "interval" if interval else "step"
        rec_what = "largest over the steps of each saved interval" if interval else "of each step"
        data: dict[str, Any] = {
            "R": (("time", "row", "col"), np.asarray(self.R),
                  {"long_name": "attitude matrix, maps body vectors to inertial ones", "units": "1"}),
            "Pi": (("time", "axis"), np.asarray(self.Pi), {"long_name": "body angular momentum", "units": "kg m2 s-1"}),
            "omega": (("time", "axis"), self.omega, {"long_name": "body angular velocity", "units": "rad s-1"}),
            "quaternion": (("time", "component"), self.quaternion,
                           {"long_name": "unit quaternion, scalar last (x, y, z, w), Hamilton", "units": "1"}),
            "energy": (("time",), self.energy, {"long_name": "total energy (kinetic + potential)", "units": "J"}),
            "inertia": (("row", "col"), np.asarray(self.inertia), {"long_name": "inertia matrix J", "units": "kg m2"}),
            "iterations": ((rec_dim,), np.asarray(self.iterations, dtype=np.int32),
                           {"long_name": f"solver iterations, {rec_what}"}),
            "residual": ((rec_dim,), np.asarray(self.residual, dtype=np.float64),
                         {"long_name": f"final residual of the implicit solves, {rec_what}"}),
        }
        if self.potential is not None:
            data["potential"] = (("time",), np.asarray(self.potential), {"long_name": "potential energy", "units": "J"})
        for name, v in self._sampled().items():
            if name not in data and name != "t":
                data[name] = (("time",) + tuple(f"{name.split('_')[0]}{'' if i == 1 else i}" for i in range(1, v.ndim)),
                              np.asarray(v))
        return xr.Dataset(data, coords={"time": ("time", np.asarray(self.t), {"units": "s", "long_name": "time"}),
                                        "component": ("component", np.array(["x", "y", "z", "w"]))},
                          attrs={"h": float(self.h), "lgvi_meta": json.dumps(self.meta, default=_json_default)})

    def to_dataframe(self) -> "pandas.DataFrame":
        """The samples as a ``pandas.DataFrame`` indexed by time ``t`` (pandas, e.g. from the ``io``
        extra): columns ``qx qy qz qw`` (scalar-last quaternion), ``omega_x .. omega_z`` (rad/s),
        ``Pi_x .. Pi_z``, ``energy`` (and ``potential``), ``R11 .. R33``."""
        try:
            import pandas as pd
        except ImportError as exc:
            raise ImportError(f"to_dataframe needs pandas: pip install pandas, or 'lgvi[io]' ({exc})") from exc
        cols: dict[str, np.ndarray] = {}
        q = self.quaternion
        for i, c in enumerate("xyzw"):
            cols[f"q{c}"] = q[:, i]
        for i, c in enumerate("xyz"):
            cols[f"omega_{c}"] = self.omega[:, i]
        for i, c in enumerate("xyz"):
            cols[f"Pi_{c}"] = np.asarray(self.Pi)[:, i]
        cols["energy"] = self.energy
        if self.potential is not None:
            cols["potential"] = np.asarray(self.potential)
        R = np.asarray(self.R)
        for i in range(3):
            for j in range(3):
                cols[f"R{i + 1}{j + 1}"] = R[:, i, j]
        return pd.DataFrame(cols, index=pd.Index(np.asarray(self.t), name="t"))

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        span = f"t=[{self.t[0]:.6g}, {self.t[-1]:.6g}]" if len(self.t) else "empty"
        return (f"Trajectory(samples={len(self.t)}, steps={self.steps}, h={self.h:g}, {span}, "
                f"method={self.meta.get('method', '?')!r})")

    def _repr_mimebundle_(self, include=None, exclude=None):
        """Jupyter's display: the interactive view of :mod:`lgvi.view` (plotly), else the repr."""
        if rich_display is None:
            return {"text/plain": repr(self)}
        return rich_display(self, include, exclude)

    @property
    def error_estimate(self) -> "ErrorEstimate | None":
        """The run's :class:`lgvi.accuracy.ErrorEstimate` (from ``meta["error_estimate"]``) or ``None``."""
        from .accuracy import ErrorEstimate

        d = self.meta.get("error_estimate")
        return None if d is None else ErrorEstimate.from_dict(d)

    @property
    def steps(self) -> int:
        """Number of steps taken (``solver_summary["steps"]``; the record's length for results
        without a summary, or whose record has more entries than saved intervals: per step)."""
        summary = (self.meta or {}).get("solver_summary")
        if (isinstance(summary, dict) and isinstance(summary.get("steps"), int)
                and len(self.iterations) <= max(len(self.t) - 1, 0)):
            return int(summary["steps"])
        return int(len(self.iterations))

    @cached_property
    def solver_summary(self) -> dict[str, Any]:
        """Totals of the solver over every step taken, whatever the record's resolution.

        A dict: ``steps``; ``iterations_total`` (solver updates summed over the steps),
        ``iterations_mean``, ``iterations_max``; ``residual_max`` (largest final residual);
        ``histogram`` ((:data:`HIST_BINS`,) int64 ndarray: entry ``i`` counts the steps with
        ``i`` updates, the last entry those with more); ``record`` (``"interval"`` or
        ``"full"``). Results saved before lgvi kept these totals, and per-step records of
        ``save_every > 1``, give them from the record itself.
        """
        stored = (self.meta or {}).get("solver_summary")
        out = None
        if isinstance(stored, dict) and len(self.iterations) <= max(len(self.t) - 1, 0):
            try:
                out = summary_dict(stored["histogram"], stored["iterations_total"], stored["residual_max"],
                                   stored.get("iterations_max"))
                record = str((self.meta or {}).get("solver_record", "full"))
            except (KeyError, TypeError, ValueError, OverflowError):  # a damaged header: use the record
                out = None
        if out is None:
            its = np.asarray(self.iterations, dtype=np.int64)
            counts = np.bincount(np.clip(its, 0, HIST_BINS - 1), minlength=HIST_BINS)
            res = np.asarray(self.residual, dtype=np.float64)
            out = summary_dict(counts, int(its.sum()), float(res.max()) if res.size else 0.0,
                               int(its.max()) if its.size else 0)
            record = "full"
        out["histogram"] = np.asarray(out["histogram"], dtype=np.int64)
        out["iterations_mean"] = out["iterations_total"] / out["steps"] if out["steps"] else None
        out["record"] = record
        return out

    @cached_property
    def omega(self) -> np.ndarray:
        """(M, 3) body angular velocity ``J^-1 Pi``."""
        return np.linalg.solve(self.inertia, self.Pi.T).T

    @cached_property
    def kinetic_energy(self) -> np.ndarray:
        """(M,) kinetic energy ``1/2 Pi . J^-1 Pi``."""
        return 0.5 * np.einsum("ij,ij->i", self.Pi, self.omega)

    @cached_property
    def energy(self) -> np.ndarray:
        """(M,) total energy: kinetic plus, for conservative torque models, potential."""
        if self.potential is None:
            return self.kinetic_energy
        return self.kinetic_energy + self.potential

    @cached_property
    def spatial_momentum(self) -> np.ndarray:
        """(M, 3) inertial angular momentum ``R Pi``."""
        return np.einsum("mij,mj->mi", self.R, self.Pi)

    @cached_property
    def orthogonality_error(self) -> np.ndarray:
        """(M,) ``|R^T R - I|_F``."""
        eye = np.eye(3)
        return np.linalg.norm(np.einsum("mki,mkj->mij", self.R, self.R) - eye, axis=(1, 2))

    @cached_property
    def quaternion(self) -> np.ndarray:
        """(M, 4) unit quaternions, scalar-last (as scipy), sign-continuous over time."""
        return self.quaternions()

    def quaternions(self, *, scalar_first: bool = False) -> np.ndarray:
        """(M, 4) sign-continuous unit quaternions; ``scalar_first`` as in scipy."""
        from scipy.spatial.transform import Rotation

        # a writable copy: SciPy < 1.16 rejects read-only arrays (and self.R is read-only)
        q = _continuous(Rotation.from_matrix(np.array(self.R)).as_quat()) if len(self.R) else np.zeros((0, 4))
        return q[:, [3, 0, 1, 2]] if scalar_first else q

    @property
    def rotation(self) -> "Rotation":
        """The attitudes as a scipy ``Rotation`` (a stack of ``M``)."""
        from scipy.spatial.transform import Rotation

        return Rotation.from_matrix(np.array(self.R))  # writable copy, as in quaternions()

    # ---------------------------------------------------------------- persistence
    def _extra_arrays(self) -> dict[str, np.ndarray]:
        """Arrays a subclass (another system's result, :data:`RESULT_TYPES`) saves too."""
        return {}

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write to ``path`` (``.npz``, uncompressed, atomically); :func:`lgvi.load` reads it back exactly."""
        meta = dict(self.meta)
        meta.setdefault("lgvi_version", __version__)
        arrays = dict(t=self.t, R=self.R, Pi=self.Pi, inertia=self.inertia, iterations=self.iterations,
                      residual=self.residual, h=np.float64(self.h))
        if self.potential is not None:
            arrays["potential"] = self.potential
        arrays.update(self._extra_arrays())
        header = json.dumps({"format": FORMAT, "meta": meta})
        from ._files import write_atomic  # a half-written file is never left under ``path``

        write_atomic(os.fspath(path), lambda fh: np.savez(fh, __lgvi__=np.array(header), **arrays))


_FIELDS = ("t", "R", "Pi", "inertia", "iterations", "residual")

#: Result classes of other systems by ``meta["system"]`` (each registers itself on import):
#: ``(names of its extra arrays, factory(**fields) -> Trajectory)``; :func:`load` uses them.
RESULT_TYPES: dict[str, tuple[tuple[str, ...], Any]] = {}


def _check_arrays(fields: dict[str, np.ndarray], potential: np.ndarray | None) -> None:
    """Shapes and dtypes of a stored trajectory (ValueError naming the field and the rule)."""
    for name, arr in list(fields.items()) + [("potential", potential)]:
        if arr is None:
            continue
        kinds = "iu" if name == "iterations" else "iuf"
        if arr.dtype.kind not in kinds:
            raise ValueError(f"field {name!r} must hold {'integers' if kinds == 'iu' else 'real numbers'}, "
                             f"got dtype {arr.dtype}")
    t = fields["t"]
    if t.ndim != 1:
        raise ValueError(f"field 't' must have shape (M,), got shape {t.shape}")
    M = len(t)
    want = {"R": (M, 3, 3), "Pi": (M, 3), "inertia": (3, 3)}
    for name, shape in want.items():
        if fields[name].shape != shape:
            raise ValueError(f"field {name!r} must have shape {shape} (M = {M} samples), got shape {fields[name].shape}")
    for name in ("iterations", "residual"):  # (steps,), or other lengths for baselines (solve_ivp: [nfev], [])
        if fields[name].ndim != 1:
            raise ValueError(f"field {name!r} must be one-dimensional, got shape {fields[name].shape}")
    if potential is not None and potential.shape != (M,):
        raise ValueError(f"field 'potential' must have shape ({M},), got shape {potential.shape}")


def _read(path: str) -> tuple[dict[str, Any], dict[str, np.ndarray], np.ndarray | None, float]:
    with open(path, "rb") as fh:
        head = fh.read(4)
    if head[:2] != b"PK":  # an .npz is a zip archive; anything else (a PNG, an .npy, text) is refused here
        what = "an empty file" if not head else f"a file starting with {head!r}"
        raise ValueError(f"{path} is not an lgvi trajectory: an .npz (zip) archive was expected, got {what}")
    check_npz(path)  # no object arrays, no declared size beyond the file's bytes: refused before allocating
    with np.load(path, allow_pickle=False) as data:
        if "__lgvi__" not in data.files:
            raise ValueError(f"{path} is not an lgvi trajectory (no '__lgvi__' header)")
        header = load_json(str(data["__lgvi__"]), f"{path}: the '__lgvi__' header")
        if not isinstance(header, dict):
            raise ValueError(f"{path} is not an lgvi trajectory (the '__lgvi__' header is not a JSON object)")
        if header.get("format") != FORMAT:
            raise ValueError(f"{path}: unsupported trajectory format {header.get('format')!r}, expected {FORMAT!r}")
        if not isinstance(header.get("meta", {}), dict):
            raise ValueError(f"{path}: the header's 'meta' must be a JSON object, got {type(header['meta']).__name__}")
        missing = [k for k in _FIELDS + ("h",) if k not in data.files]
        if missing:
            raise ValueError(f"{path} is not a complete lgvi trajectory: missing field(s) {', '.join(missing)}")
        fields = {k: data[k] for k in _FIELDS}
        extra = RESULT_TYPES.get(str(header.get("meta", {}).get("system")), ((), None))[0]
        for k in extra:
            if k not in data.files:
                raise ValueError(f"{path} is not a complete lgvi trajectory: missing field {k}")
            if data[k].dtype.kind not in "iuf":
                raise ValueError(f"field {k!r} must hold real numbers, got dtype {data[k].dtype}")
            fields[k] = data[k]
        potential = data["potential"] if "potential" in data.files else None
        h_arr = data["h"]
    if h_arr.size != 1 or h_arr.dtype.kind not in "iuf":
        raise ValueError(f"field 'h' must be one real number, got shape {h_arr.shape}, dtype {h_arr.dtype}")
    _check_arrays({k: fields[k] for k in _FIELDS}, potential)
    return header, fields, potential, float(h_arr.reshape(()))


def load(path: str | os.PathLike[str]) -> Trajectory:
    """Read a trajectory written by :meth:`Trajectory.save`.

    Raises
    ------
    ValueError
        If the file cannot be read or is not an lgvi trajectory (wrong format, truncated, missing
        fields, arrays of the wrong shape or type); the message names the file.
    """
    path = os.fspath(path)
    try:
        header, fields, potential, h = _read(path)
    except MemoryError:
        raise
    except ValueError as exc:  # numpy's own ValueErrors (pickled data, bad .npy headers) lack the path
        raise (exc if path in str(exc) else ValueError(f"cannot read trajectory {path}: {exc}")) from exc
    except Exception as exc:  # OSError, EOFError, zipfile.BadZipFile and friends from truncated files
        raise ValueError(f"cannot read trajectory {path}: {type(exc).__name__}: {exc}") from exc
    factory = RESULT_TYPES.get(str(header.get("meta", {}).get("system")), ((), Trajectory))[1]
    return factory(h=h, potential=potential, meta=header.get("meta", {}), **fields)


#: Public name of the array checks (readers of stored results call it: lgvi.outputs, lgvi.streaming).
check_arrays = _check_arrays

__all__ = ["HIST_BINS", "Trajectory", "load"]
