"""Writing and reading trajectories: ``.npz`` (exact, default), CSV (+ JSON sidecar), netCDF.

=========  ==========================  ===============================================================
format     writer / reader             what is kept
=========  ==========================  ===============================================================
npz        ``Trajectory.save`` /       everything, bit for bit: arrays, the solver's record
           :func:`lgvi.load`           ``iterations`` and ``residual``, ``meta`` (scenario text,
                                       version, the solver's totals) in the header
csv        :func:`write_csv` /         one row per saved state, ``%.17g`` (floats round-trip exactly);
           :func:`read_csv`            the sidecar ``NAME.meta.json`` holds the inertia, ``h``, the
                                       column units, ``meta`` with the scenario text, version and the
                                       solver's totals (``meta["solver_summary"]``: steps, iterations,
                                       histogram). The solver's record ``iterations`` and ``residual``
                                       is **not** kept: a trajectory read from CSV has empty ones
                                       (``meta["steps"]`` still says how many steps were taken).
netcdf     :func:`write_netcdf` /      everything (as npz), via xarray; ``meta`` as the JSON attribute
           :func:`read_netcdf`         ``lgvi_meta``, the scenario text also as attribute ``scenario``.
                                       Needs the optional extra: ``pip install 'lgvi[io]'``.
=========  ==========================  ===============================================================

CSV columns, in order: ``t``; ``R11 R12 R13 R21 ... R33`` (row ``i``, column ``j`` of the attitude
matrix, body to inertial); ``qx qy qz qw`` (the unit quaternion, **scalar last** as in scipy,
Hamilton convention, sign-continuous in time); ``Pi1 Pi2 Pi3`` (body angular momentum);
``omega1 omega2 omega3`` (body angular velocity); ``energy`` (total: kinetic plus potential);
``potential`` (only when the run had a potential). The first line is the header; there are no
comment lines, so any CSV reader takes the file as it is. Every output is sized by the saved
states unless the run kept its per-step solver record (``solver_record="full"``).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from .._files import write_atomic, write_text
from .._untrusted import load_json
from .._version import __version__
from ..trajectory import Trajectory, check_arrays as _check_arrays, load

__all__ = [
    "CSV_COLUMNS",
    "conservation_drifts",
    "orthogonality_max",
    "read_csv",
    "read_netcdf",
    "read_trajectory",
    "sidecar_path",
    "write_csv",
    "write_netcdf",
    "write_trajectory",
]

CSV_FORMAT = "lgvi.csv/1"
NETCDF_FORMAT = "lgvi.netcdf/1"
CSV_COLUMNS: tuple[str, ...] = (
    ("t",) + tuple(f"R{i}{j}" for i in range(1, 4) for j in range(1, 4)) + ("qx", "qy", "qz", "qw")
    + ("Pi1", "Pi2", "Pi3", "omega1", "omega2", "omega3", "energy")
)
UNITS = {"t": "s", "R": "1", "q": "1", "Pi": "kg m^2/s", "omega": "rad/s", "energy": "J", "potential": "J"}
EXTENSIONS = {"npz": ".npz", "csv": ".csv", "netcdf": ".nc"}
IO_HINT = "pip install 'lgvi[io]'"


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _meta(traj: Trajectory) -> dict[str, Any]:
    meta = dict(traj.meta)
    meta.setdefault("lgvi_version", __version__)
    meta.setdefault("steps", traj.steps)
    return meta


def _unit(column: str) -> str:
    for prefix in ("omega", "Pi", "R", "q"):
        if column.startswith(prefix):
            return UNITS[prefix]
    return UNITS[column]


def sidecar_path(path: str | os.PathLike[str]) -> Path:
    """The JSON sidecar of a CSV file: ``run.csv`` -> ``run.meta.json``."""
    p = Path(path)
    return p.with_name(p.stem + ".meta.json")


# ------------------------------------------------------------------------------------ CSV
def write_csv(traj: Trajectory, path: str | os.PathLike[str]) -> Path:
    """Write one row per saved state, with named columns, and a JSON sidecar with the metadata.

    Parameters
    ----------
    traj : Trajectory
    path : str or path-like
        The CSV file; the sidecar goes to ``sidecar_path(path)`` (``NAME.meta.json``).

    Returns
    -------
    pathlib.Path
        The CSV path.

    Notes
    -----
    Columns (see the module docstring): ``t, R11..R33, qx, qy, qz, qw`` (scalar last),
    ``Pi1..3, omega1..3, energy`` and ``potential`` when present. Values are written with 17
    significant digits, so ``t``, ``R`` and ``Pi`` read back exactly.
    """
    path = Path(path)
    M = len(traj.t)
    cols = [traj.t[:, None], traj.R.reshape(M, 9), traj.quaternion, traj.Pi, traj.omega, traj.energy[:, None]]
    names = list(CSV_COLUMNS)
    if traj.potential is not None:
        cols.append(np.asarray(traj.potential)[:, None])
        names.append("potential")
    data = np.hstack(cols)
    write_atomic(path, lambda fh: np.savetxt(fh, data, delimiter=",", fmt="%.17g", header=",".join(names),
                                             comments="", encoding="utf-8"), what="CSV file")
    side = {
        "format": CSV_FORMAT,
        "lgvi_version": __version__,
        "csv": path.name,
        "columns": names,
        "units": {n: _unit(n) for n in names},
        "quaternion": "qx, qy, qz, qw: scalar last (as scipy), Hamilton product, rotates body to inertial",
        "attitude": "Rij: row i, column j of R, which maps body vectors to inertial ones",
        "not_kept": "the solver's record of iterations and residuals (use the npz or netCDF output for those; "
                    "meta holds its totals)",
        "h": traj.h,
        "inertia": traj.inertia,
        "samples": M,
        "meta": _meta(traj),
    }
    write_text(sidecar_path(path), json.dumps(side, indent=2, default=_jsonable, allow_nan=True) + "\n",
               "CSV sidecar")
    return path


def read_csv(path: str | os.PathLike[str], *, inertia: Any = None) -> Trajectory:
    """Read a CSV written by :func:`write_csv` (with its sidecar) back into a :class:`Trajectory`.

    Parameters
    ----------
    path : str or path-like
    inertia : array_like, optional
        Needed only when the sidecar ``NAME.meta.json`` is missing.

    Returns
    -------
    Trajectory
        ``t``, ``R``, ``Pi`` (exact) and ``potential``; ``iterations`` and ``residual`` are empty
        (CSV does not keep them); ``meta["steps"]`` holds the number of steps of the run and
        ``meta["solver_summary"]`` the solver's totals (:attr:`Trajectory.solver_summary`).

    Raises
    ------
    ValueError
        If the file is not such a CSV (missing columns, unreadable), or neither a sidecar nor
        ``inertia`` gives the inertia.
    """
    path = Path(path)
    try:
        with open(path) as fh:
            header = fh.readline().strip().split(",")
            data = np.loadtxt(fh, delimiter=",", ndmin=2, dtype=np.float64)
    except (OSError, ValueError) as exc:
        raise ValueError(f"cannot read CSV trajectory {path}: {exc}") from exc
    missing = [c for c in CSV_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path} is not an lgvi CSV trajectory: missing columns {', '.join(missing)}")
    if data.size and data.shape[1] != len(header):
        raise ValueError(f"{path}: {data.shape[1]} values per row but {len(header)} column names")
    col = {name: data[:, i] if data.size else np.zeros(0) for i, name in enumerate(header)}
    side: Any = {}
    sp = sidecar_path(path)
    if sp.exists():
        try:
            side = load_json(sp.read_text(), str(sp))
        except (OSError, ValueError) as exc:  # JSONDecodeError, UnicodeDecodeError
            raise ValueError(f"cannot read the sidecar {sp} of {path}: {exc}") from exc
        if not isinstance(side, dict):
            raise ValueError(f"the sidecar {sp} of {path} must hold a JSON object, got {type(side).__name__}")
    if inertia is None:
        if "inertia" not in side:
            raise ValueError(f"{path}: the sidecar {sp.name} with the inertia is missing; pass inertia= to read_csv")
        inertia = side["inertia"]
    try:
        J = np.asarray(inertia, dtype=np.float64)
        if J.shape == (3,):
            J = np.diag(J)
        meta = dict(side.get("meta", {}))
        h = side.get("h")
        h = float("nan") if h is None else float(h)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: invalid inertia, h or meta in the sidecar {sp.name}: {exc}") from exc
    R = np.stack([col[f"R{i}{j}"] for i in range(1, 4) for j in range(1, 4)], axis=-1).reshape(-1, 3, 3)
    Pi = np.stack([col["Pi1"], col["Pi2"], col["Pi3"]], axis=-1)
    meta["read_from"] = "csv"
    fields = dict(t=col["t"].copy(), R=np.ascontiguousarray(R), Pi=np.ascontiguousarray(Pi), inertia=J,
                  iterations=np.zeros(0, dtype=np.int32), residual=np.zeros(0))
    potential = col["potential"].copy() if "potential" in col else None
    try:
        _check_arrays(fields, potential)
    except ValueError as exc:
        raise ValueError(f"{path} is not a valid lgvi CSV trajectory: {exc}") from exc
    return Trajectory(h=h, potential=potential, meta=meta, **fields)


# ------------------------------------------------------------------------------------ netCDF
def _xarray():
    try:
        import xarray
    except ImportError as exc:
        raise ImportError(f"netCDF output needs the optional packages xarray and netCDF4: {IO_HINT} "
                          f"({exc})") from exc
    return xarray


def write_netcdf(traj: Trajectory, path: str | os.PathLike[str]) -> Path:
    """Write the whole trajectory to a netCDF file through xarray (optional extra ``lgvi[io]``).

    Dimensions ``time`` (M), ``interval`` (M - 1, a solver record per saved interval) or
    ``step`` (steps, a per-step record), ``row``/``col``/``axis`` (3) and ``component`` (4,
    coordinate ``x y z w``: scalar last). Variables ``R``, ``Pi``, ``omega``, ``quaternion``,
    ``energy`` (and ``potential``), ``inertia``, ``iterations``, ``residual``, with units.
    Attributes: ``lgvi_format``, ``lgvi_version``, ``h``, ``lgvi_meta`` (JSON of ``meta``) and
    ``scenario`` (the scenario text, empty if none).

    Raises
    ------
    ImportError
        If xarray (or a netCDF engine) is missing; the message says ``pip install 'lgvi[io]'``.
    """
    _xarray()
    path = Path(path)
    meta = _meta(traj)
    ds = traj.to_xarray()     # the variables (lgvi.Trajectory.to_xarray); the file's attributes here
    _add_system_arrays(ds, traj)
    ds.attrs = {"title": f"lgvi trajectory{': ' + str(meta['scenario_name']) if 'scenario_name' in meta else ''}",
                "lgvi_format": NETCDF_FORMAT, "lgvi_version": __version__, "h": float(traj.h),
                "lgvi_meta": json.dumps(meta, default=_jsonable), "scenario": str(meta.get("scenario", ""))}
    try:
        write_atomic(path, lambda tmp: ds.to_netcdf(tmp), by_path=True, what="netCDF file")
    except ValueError as exc:
        if "engine" in str(exc).lower():
            raise ImportError(f"no netCDF engine found for xarray: {IO_HINT} ({exc})") from exc
        raise
    return path


def _check_declared_size(ds: Any, path: Path) -> None:
    """Refuse a netCDF file whose variables declare more data than its bytes could hold, even
    compressed (:data:`lgvi._untrusted.MAX_DEFLATE_RATIO`): a small file declaring 2e8 samples
    would otherwise make the reader allocate gigabytes of fill values."""
    from .._untrusted import MAX_DEFLATE_RATIO

    declared = sum(int(v.size) * v.dtype.itemsize for v in ds.variables.values())
    held = path.stat().st_size
    if declared > MAX_DEFLATE_RATIO * held + 2**20:
        dims = ", ".join(f"{k} = {v}" for k, v in ds.sizes.items())
        raise ValueError(f"its variables declare {declared} bytes ({dims}) but the file holds {held} bytes; "
                         "damaged or hostile file, refused before reading")


def read_netcdf(path: str | os.PathLike[str]) -> Trajectory:
    """Read a file written by :func:`write_netcdf` back into a :class:`Trajectory` (exact).

    Raises
    ------
    ValueError
        If the file cannot be read (truncated, corrupt, not netCDF) or is not an lgvi netCDF
        trajectory (missing variables or attributes, wrong shapes); the message names the file.
    ImportError
        If xarray or netCDF4 is missing.
    """
    xr = _xarray()
    path = Path(path)
    try:
        with xr.open_dataset(path) as ds:
            _check_declared_size(ds, path)       # before anything is read into memory
            ds = ds.load()
    except (ImportError, MemoryError):
        raise
    except Exception as exc:  # OSError, ValueError, and RuntimeError("NetCDF: HDF error") from corrupt files
        raise ValueError(f"cannot read netCDF trajectory {path}: {type(exc).__name__}: {exc}") from exc
    if ds.attrs.get("lgvi_format") != NETCDF_FORMAT:
        raise ValueError(f"{path} is not an lgvi netCDF trajectory (attribute lgvi_format = "
                         f"{ds.attrs.get('lgvi_format')!r}, expected {NETCDF_FORMAT!r})")
    try:
        meta = load_json(ds.attrs.get("lgvi_meta", "{}"), f"{path}: the attribute lgvi_meta")
        if not isinstance(meta, dict):
            raise ValueError(f"attribute lgvi_meta must hold a JSON object, got {type(meta).__name__}")
        fields = dict(t=ds["time"].values.astype(np.float64), R=ds["R"].values.astype(np.float64),
                      Pi=ds["Pi"].values.astype(np.float64), inertia=ds["inertia"].values.astype(np.float64),
                      iterations=ds["iterations"].values.astype(np.int32),
                      residual=ds["residual"].values.astype(np.float64))
        potential = ds["potential"].values.astype(np.float64) if "potential" in ds else None
        h = float(ds.attrs["h"])
        _check_arrays(fields, potential)
        names, factory = _system_arrays(meta)
        if factory is not None and all(name in ds for name in names):   # another system's result, whole
            for name in names:
                if ds[name].dtype.kind not in "iuf":
                    raise ValueError(f"variable {name!r} must hold real numbers, got dtype {ds[name].dtype}")
                fields[name] = np.ascontiguousarray(ds[name].values.astype(np.float64))
            return factory(h=h, potential=potential, meta=meta, **fields)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{path} is not a valid lgvi netCDF trajectory: {type(exc).__name__}: {exc}") from exc
    return Trajectory(h=h, potential=potential, meta=meta, **fields)


def _system_arrays(meta: dict[str, Any]) -> tuple[tuple[str, ...], Any]:
    """The arrays beyond the rigid body's that a system's result saves (``lgvi.trajectory.RESULT_TYPES``:
    the gyrostat's wheels, the spacecraft's records ``signal_data``) and its reader, or ``((), None)``."""
    from ..trajectory import RESULT_TYPES

    names, factory = RESULT_TYPES.get(str(meta.get("system")), ((), None))
    return tuple(names), (factory if names else None)


def _add_system_arrays(ds: Any, traj: Trajectory) -> None:
    """Put a system's own arrays (:func:`_system_arrays`) that ``to_xarray`` leaves out into ``ds``,
    exactly: the wheels' axes and spin inertias along ``wheel``, the loop's records ``signal_data``
    along ``record`` (coordinate ``record_time``, ``signal_t``) and ``signal_column`` (the JSON
    ``meta["signals"]`` names each signal's columns)."""
    names, _ = _system_arrays(traj.meta or {})
    extra = traj._extra_arrays() if names else {}
    for name in names:
        if name in ds or extra.get(name) is None:
            continue
        arr = np.asarray(extra[name])
        if name == "signal_data":
            ds[name] = (("record", "signal_column"), arr.reshape(len(arr), -1),
                        {"long_name": "the loop's records, one row per record entry (columns: lgvi_meta signals)"})
            ds.coords["record_time"] = ("record", np.asarray(traj.signal_t), {"units": "s"})
        elif name == "wheel_axes":
            ds[name] = (("wheel", "axis"), arr, {"long_name": "wheel spin axes, body frame", "units": "1"})
        elif name == "spin_inertia":
            ds[name] = (("wheel",), arr, {"long_name": "wheel spin inertias", "units": "kg m2"})
        else:
            ds[name] = (tuple(f"{name}_{i}" for i in range(arr.ndim)), arr)


# ------------------------------------------------------------------------------------ any
def _npz_format(path: str | os.PathLike[str]) -> str | None:
    """The ``format`` of an lgvi ``.npz`` result's header, ``None`` when it cannot be told (then
    :func:`lgvi.load` reads the file and says what is wrong with it)."""
    from .._untrusted import check_npz

    try:
        with open(path, "rb") as fh:
            if fh.read(2) != b"PK":
                return None
        check_npz(os.fspath(path))        # no object arrays, no declared size beyond the file's bytes
        with np.load(path, allow_pickle=False) as data:
            if "__lgvi__" not in data.files:
                return None
            header = load_json(str(data["__lgvi__"]), f"{path}: the '__lgvi__' header")
    except Exception:  # noqa: BLE001 - lgvi.load reports the problem
        return None
    fmt = header.get("format") if isinstance(header, dict) else None
    return fmt if isinstance(fmt, str) else None


def _npz_readers() -> dict[str, Any]:
    """Readers of the ``.npz`` results of other systems, by the format in their header."""
    from ..systems import SYSTEMS, gyrostat_ensemble, orbit, two_body

    return {orbit.FORMAT: orbit.OrbitTrajectory.load, two_body.FORMAT: two_body.TwoBodyTrajectory.load,
            gyrostat_ensemble.FORMAT: gyrostat_ensemble.GyrostatEnsemble.load,
            **{s.saved_as[0]: s.saved_as[1] for s in SYSTEMS.values() if s.saved_as is not None}}


def read_trajectory(path: str | os.PathLike[str]) -> Any:
    """Read a trajectory by its extension: ``.npz`` (:func:`lgvi.load`; the results of
    :func:`lgvi.simulate_orbit`, :func:`lgvi.simulate_two_body` and gyrostat ensembles by the
    format in their header), ``.csv``, ``.nc``."""
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        return read_csv(path)
    if suffix in (".nc", ".nc4", ".netcdf"):
        return read_netcdf(path)
    if suffix == ".npz":
        reader = _npz_readers().get(_npz_format(path))
        return reader(path) if reader is not None else load(path)
    raise ValueError(f"{path}: unknown trajectory file type {suffix!r}; expected .npz, .csv or .nc")


def write_trajectory(traj: Trajectory, outdir: str | os.PathLike[str], formats: Iterable[str] = ("npz",), *,
                     stem: str = "trajectory") -> list[Path]:
    """Write ``traj`` to ``outdir/stem.npz``, ``.csv`` (+ ``.meta.json``), ``.nc`` as asked.

    Returns the paths written (the CSV sidecar included).
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for fmt in formats:
        if fmt not in EXTENSIONS:
            raise ValueError(f"unknown output format {fmt!r}; expected one of {', '.join(EXTENSIONS)}")
        if fmt != "npz" and not isinstance(traj, Trajectory):
            raise ValueError(f"output format {fmt!r}: a {type(traj).__name__} is saved as npz only")
        p = outdir / (stem + EXTENSIONS[fmt])
        if fmt == "npz":
            traj.save(p)
        elif fmt == "csv":
            write_csv(traj, p)
            written.append(p)
            p = sidecar_path(p)
        else:
            write_netcdf(traj, p)
        written.append(p)
    return written


# ------------------------------------------------------------------------------------ diagnostics
def conservation_drifts(traj: Trajectory, invariants: Any = None) -> dict[str, float | None]:
    """Largest changes over the run of the quantities the run's system conserves.

    Which quantities: the system's declaration of invariants (:func:`lgvi.invariants.declared`,
    from ``meta["invariants"]``; a free body conserves all of the ones below, uniform gravity the
    energy and ``e3 . R Pi``, the gravity gradient the Jacobi integral, damping and control
    nothing). Quantities that are not invariants are left out.

    Parameters
    ----------
    traj : Trajectory
    invariants : lgvi.invariants.Declaration, optional
        Use this declaration instead of the trajectory's own (e.g. the problem's, for a baseline).

    Returns
    -------
    dict
        Of the declared quantities: ``energy_abs`` = ``max |E - E0|`` (total energy), ``energy_rel`` =
        that / ``|E0|``; ``casimir_rel`` = ``max ||Pi| - |Pi0|| / |Pi0|``; ``spatial_momentum_rel`` =
        ``max |R Pi - R0 Pi0| / |R0 Pi0|``; ``spatial_momentum_e3_rel`` the same for the vertical
        component ``e3 . R Pi``; ``jacobi_abs`` = ``max |C - C0|`` (``C = E - n e3 . R Pi``),
        ``jacobi_rel`` = that / ``|C0|``. Always ``orthogonality_max`` = ``max |R^T R - I|_F``. A
        relative value is ``None`` where its scale is zero.
    """
    from ..invariants import declared, drifts

    decl = invariants if invariants is not None else declared(traj)
    out = drifts(traj, decl)
    out["orthogonality_max"] = orthogonality_max(traj)
    return out


def orthogonality_max(traj: Any) -> float:
    """``max |R^T R - I|_F`` over the samples (and the bodies, for results with several)."""
    if hasattr(traj, "orthogonality_error"):
        return float(np.max(traj.orthogonality_error))
    R = np.asarray(traj.R, dtype=np.float64).reshape(-1, 3, 3)
    if not len(R):
        return 0.0
    err = np.einsum("kji,kjl->kil", R, R) - np.eye(3)
    return float(np.max(np.linalg.norm(err, axis=(1, 2))))
