"""Crash-safe streaming of long runs to disk, chunk by chunk.

A stream is a folder::

    run/
      manifest.json          # format, metadata, the list of complete chunks, the resume state
      chunk-000000.npz       # t, R, Pi, the solver's record (per saved interval, or per step with
                             # solver_record="full") and totals of the samples/steps of that chunk
      chunk-000001.npz
      ...

The chunks of another system (``meta["system"]``: the gyrostat, a body in orbit, two bodies) hold
``t`` and its declared state and record fields by name (:class:`lgvi.systems.System`: ``state``,
``records``), and :func:`read_stream` returns its result type through its ``from_stream``
(:func:`simulate_stream` with ``wheels=``, :func:`stream_system`).

Every chunk file is written to a temporary name, flushed to disk and renamed into place, and only
then is the manifest (also written by rename) updated to list it. A rename is atomic, so after a
crash at any point the folder holds a consistent manifest that lists only complete chunks;
:func:`read_stream` returns exactly those, and the manifest's ``state`` lets a run resume from the
end of the last listed chunk (see :func:`lgvi.simulate`'s ``stream=`` and ``resume=``).

A write that fails (a full disk) raises an ``OSError`` naming the file and the folder; the chunks
listed before stay readable and ``resume=True`` continues once there is room. One folder has one
writer at a time: :class:`StreamWriter` holds an exclusive lock (the file ``.lgvi.lock`` with its
process id, locked with ``flock``), so a second writer, in this or another process, gets
``FolderLocked`` (a ``BlockingIOError``) instead of interleaving chunks; the lock of a writer that
crashed is released by the operating system and taken over with a ``StaleLockWarning``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from .._files import LOCK_NAME, FolderLock, write_atomic, write_failure
from .._untrusted import check_npz, inside, load_json
from .._validation import as_int
from .._version import __version__
from ..driver import drive, layout, record_every
from ..trajectory import Trajectory, check_arrays as _check_arrays, merge_summaries, summary_dict

STREAM_FORMAT = "lgvi.stream/1"
MANIFEST = "manifest.json"


def _fsync_write(path: Path, write) -> None:
    """Write ``path`` atomically (a unique hidden temporary name, flushed, renamed into place): a
    leftover or planted temporary file, or a symbolic link, is never written through."""
    write_atomic(path, write)


def stream_folder(folder: Any) -> Path:
    """``folder`` as a path; an empty name (which ``Path`` reads as the current folder) or a value
    that is not a path is refused, naming the rule."""
    if not isinstance(folder, (str, os.PathLike)):
        raise TypeError(f"folder must be a path (str or os.PathLike), got {type(folder).__name__}")
    name = os.fspath(folder)
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"folder must name a stream folder, got {name!r} (an empty name would stream into the "
                         "current folder; pass '.' to mean it)")
    return Path(name)


class StreamWriter:
    """Append chunks of a run to a stream folder (see the module notes).

    Parameters
    ----------
    folder : path
        Created if missing. An existing stream there is continued (``resume=True``) or refused.
    meta : dict
        Run metadata (JSON-serialisable); stored in the manifest.
    resume : bool
        Continue an existing stream instead of refusing to overwrite it.
    check : callable, optional
        Called as ``check(manifest)`` on an existing stream's manifest before it is continued
        (e.g. to compare the run's options); its error is raised with the lock released.

    Raises
    ------
    lgvi._files.FolderLocked
        (a ``BlockingIOError``) Another writer, in this or another process, holds the folder:
        one stream folder has one writer at a time. The lock is dropped by :meth:`close`,
        :meth:`release`, the end of a ``with`` block, or the end of the writer's process (a
        crashed writer's lock is taken over with a ``StaleLockWarning``).
    OSError
        A write failed (a full disk: ``errno.ENOSPC``); the message names the file and the
        folder. The chunks listed before stay readable and the stream can be resumed; the
        writer is released.
    """

    def __init__(self, folder: str | os.PathLike[str], meta: dict[str, Any], *, resume: bool = False,
                 check: Any = None):
        self.folder: Path = stream_folder(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.lock: FolderLock = FolderLock(self.folder, "stream folder").acquire()
        try:
            manifest = self.folder / MANIFEST
            if manifest.exists():
                if not resume:
                    raise FileExistsError(f"{self.folder} already holds an lgvi stream; pass resume=True to continue "
                                          "it or choose another folder")
                self.manifest: dict[str, Any] = read_manifest(self.folder)
                _check_resume_state(self.manifest, manifest)
                _check_state_against_chunks(self.folder, self.manifest, manifest)
                if check is not None and self.manifest.get("state") is not None:
                    check(self.manifest)
            else:
                self.manifest = {"format": STREAM_FORMAT, "lgvi_version": __version__, "meta": meta, "chunks": [],
                                 "state": None, "complete": False}
                self._write_manifest()
        except BaseException:
            self.release()
            raise

    @property
    def state(self) -> dict[str, Any] | None:
        """The state after the last complete chunk (``k`` steps done, ``R``, ``Pi``, solver history ``G``)."""
        return self.manifest["state"]

    def _write(self, name: str, write, what: str, listed: int) -> None:
        """Write ``name`` atomically; on failure release the writer and raise an error naming the folder."""
        try:
            _fsync_write(self.folder / name, write)
        except OSError as exc:
            self.release()
            kept = (f"The {listed} complete chunk(s) listed in {MANIFEST} are intact and readable "
                    "(lgvi.streaming.read_stream); make room and continue the run with resume=True (lgvi run --resume)."
                    if listed else "No chunk was complete yet.")
            raise write_failure(exc, self.folder / name, what, kept) from exc

    def _write_manifest(self, listed: int | None = None) -> None:
        text = json.dumps(self.manifest, indent=1).encode()
        self._write(MANIFEST, lambda fh: fh.write(text), "the stream manifest",
                    len(self.manifest["chunks"]) if listed is None else listed)

    def append(self, *, t: np.ndarray, R: np.ndarray, Pi: np.ndarray, iterations: np.ndarray,
               residual: np.ndarray, state: dict[str, Any], potential: np.ndarray | None = None,
               summary: dict[str, Any] | None = None) -> Path:
        """Write one chunk (samples ``t, R, Pi``; the solver's record ``iterations, residual``) and
        the state after it. ``summary`` (as :func:`lgvi.trajectory.summary_dict`): the solver's
        totals over the chunk's steps, stored as the arrays ``iteration_counts`` (histogram),
        ``iterations_total``, ``residual_max`` and ``iterations_max``."""
        arrays = dict(t=t, R=R, Pi=Pi, iterations=iterations, residual=residual)
        if potential is not None:
            arrays["potential"] = potential
        if summary is not None:
            arrays.update(iteration_counts=np.asarray(summary["histogram"], dtype=np.int64),
                          iterations_total=np.int64(summary["iterations_total"]),
                          residual_max=np.float64(summary["residual_max"]),
                          iterations_max=np.int64(summary["iterations_max"]))
        steps = int(np.sum(summary["histogram"])) if summary is not None else int(len(iterations))
        return self.append_arrays(arrays, state=state, steps=steps)

    def append_arrays(self, arrays: dict[str, np.ndarray], *, state: dict[str, Any], steps: int) -> Path:
        """Write one chunk of any system: ``arrays`` by field name (``t`` (m,), the system's state
        fields (m, ...) and records), ``steps`` the steps it covers and ``state`` (JSON-serialisable
        after ``tolist``) the run's state after it."""
        if not self.lock.held:
            raise ValueError(f"this writer of the stream {self.folder} is closed; open a new one (resume=True)")
        index = len(self.manifest["chunks"])
        name = chunk_name(index)
        t = arrays["t"]
        self._write(name, lambda fh: np.savez(fh, **arrays), "the stream chunk", index)
        before = dict(self.manifest, chunks=list(self.manifest["chunks"]))
        self.manifest["chunks"].append({"file": name, "samples": int(len(t)), "steps": steps})
        self.manifest["state"] = {key: (np.asarray(val).tolist() if isinstance(val, np.ndarray) else val)
                                  for key, val in state.items()}
        try:
            self._write_manifest(listed=index)
        except OSError:
            self.manifest = before  # the manifest on disk still lists the chunks before this one
            raise
        return self.folder / name

    def close(self, complete: bool = True) -> None:
        """Mark the stream complete (or not, for an interrupted run) and release the folder."""
        if self.lock.held:
            self.manifest["complete"] = bool(complete)
            self._write_manifest()
        self.release()

    def release(self) -> None:
        """Release the folder's lock without changing the stream (another writer may then continue it)."""
        self.lock.release()

    def __enter__(self) -> "StreamWriter":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.release()


def _check_resume_state(manifest: dict[str, Any], path: Path) -> None:
    """The resume state of a manifest read from disk: ``k`` steps done must be the steps of the
    listed chunks and within the run (a hostile ``k`` would index the run's arrays out of range)."""
    chunks, state, meta = manifest.get("chunks"), manifest.get("state"), manifest.get("meta")
    if not isinstance(chunks, list) or not isinstance(meta, dict):
        raise ValueError(f"{path} is damaged: 'chunks' must be a list and 'meta' an object")
    counts = [c.get("steps") if isinstance(c, dict) else None for c in chunks]
    if not all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in counts):
        raise ValueError(f"{path} is damaged: every chunk must give its 'steps' as an integer >= 0")
    if state is None and not chunks:
        return
    k = state.get("k") if isinstance(state, dict) else None
    total = meta.get("steps")
    if not isinstance(k, int) or isinstance(k, bool) or k != sum(counts) or not isinstance(total, int) \
            or not 0 <= k <= total:
        raise ValueError(f"{path} is damaged: the resume state must have k = the steps of the listed chunks "
                         f"({sum(counts)}), within the run's {total!r} steps; got state {str(state)[:80]}")
    M_cb = state.get("M_cb")
    if M_cb is not None and np.shape(M_cb) != (3,):
        raise ValueError(f"{path} is damaged: state M_cb must hold 3 numbers, got {str(M_cb)[:80]}")


def read_manifest(folder: str | os.PathLike[str]) -> dict[str, Any]:
    """The manifest of a stream folder; ``ValueError`` if missing or not an lgvi stream."""
    path = Path(folder) / MANIFEST
    if path.is_symlink() and not inside(folder, path):
        raise ValueError(f"{path} is a symbolic link to {os.path.realpath(path)}, outside the stream folder; "
                         "it is not followed")
    if path.exists() and not path.is_file():
        raise ValueError(f"{path} is not a regular file")
    try:
        manifest = load_json(path.read_text(), str(path))
    except FileNotFoundError as exc:
        raise ValueError(f"{folder} is not an lgvi stream (no {MANIFEST})") from exc
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read {path}: {exc}") from exc
    if not isinstance(manifest, dict) or manifest.get("format") != STREAM_FORMAT:
        raise ValueError(f"{path} is not an lgvi stream manifest (format {STREAM_FORMAT!r} expected)")
    return manifest


_CHUNK_FIELDS = ("t", "R", "Pi", "iterations", "residual")
#: How far a stored attitude may be from a rotation, ``max |R^T R - I|`` (a run keeps round-off).
ROTATION_TOL = 1e-9


def chunk_name(i: int) -> str:
    """The file name of chunk ``i`` of a stream (``chunk-000007.npz``)."""
    return f"chunk-{i:06d}.npz"


def _check_times(t: np.ndarray, where: str) -> None:
    """The times of a stream's samples are finite and monotonic (a run forwards or backwards;
    equal neighbours only where ``h`` is below the resolution of ``t``); reordered or repeated
    chunks would make them run back."""
    from .._kernels.check_kernels import first_time_back

    i = int(first_time_back(np.ascontiguousarray(t, dtype=np.float64)))
    if i >= 0:
        raise ValueError(f"{where}: the times must be finite and run in one direction; sample {i} has t = "
                         f"{t[i]!r} after t = {t[i - 1] if i else None!r} (chunks reordered, repeated or damaged)")


def _check_rotations(R: np.ndarray, where: str) -> None:
    """Every attitude in ``R`` (..., 3, 3) is a rotation to :data:`ROTATION_TOL` (a compiled pass)."""
    from .._kernels.check_kernels import first_non_rotation

    R = np.asarray(R, dtype=np.float64)
    if not R.size:
        return
    k = int(first_non_rotation(np.ascontiguousarray(R).reshape(-1, 3, 3), ROTATION_TOL))
    if k >= 0:
        i = tuple(int(x) for x in np.unravel_index(k, R.shape[:-2]))
        Ri = R[i]
        err = float(np.abs(Ri.T @ Ri - np.eye(3)).max())
        raise ValueError(f"{where}: attitude {i} is not a rotation (|R^T R - I| = {err:.3g}, det R = "
                         f"{float(np.linalg.det(Ri)):.3g}; a run keeps it within {ROTATION_TOL:g})")


def _check_state_against_chunks(folder: Path, manifest: dict[str, Any], mpath: Path) -> None:
    """The resume state is the end of the last listed chunk: each state field (``R``, ``Pi``,
    the wheels' momenta, ``x``, ``p``) equal bit for bit to that chunk's last sample (so its energy
    and momenta are those of the run), and its attitudes rotations."""
    chunks, state = manifest["chunks"], manifest.get("state")
    if not chunks or not isinstance(state, dict):
        return
    system = _stream_system(manifest["meta"], mpath)
    names = tuple(f.name for f in system.state)
    last = _chunk_arrays(folder, mpath, len(chunks) - 1, chunks[-1], ("t",) + names)
    where = f"{mpath} is damaged: the resume state"
    for name in names:
        if name not in state:
            raise ValueError(f"{where} has no {name!r}")
        try:
            got = np.asarray(state[name], dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}'s {name!r} is not an array of numbers ({exc})") from None
        want = np.asarray(last[name][-1])
        if got.shape != want.shape or not np.array_equal(got, want):
            raise ValueError(f"{where}'s {name!r} is not the last sample of {chunks[-1]['file']} (a resumed run "
                             f"continues from where its chunks end): {str(got.tolist())[:80]} against "
                             f"{str(want.tolist())[:80]}")
        if name == "R":
            _check_rotations(got, f"{where}")


def _chunk_file(folder: str | os.PathLike[str], mpath: Path, i: int, entry: Any) -> Path:
    """The path of chunk ``i`` listed as ``entry`` (a plain file name inside the folder, checked)."""
    name = entry.get("file") if isinstance(entry, dict) else None
    if not isinstance(name, str) or not name or Path(name).name != name or name.startswith("."):
        raise ValueError(f"{mpath} is damaged: chunk {i} must name a file in the stream folder, got {entry!r}")
    if name != chunk_name(i):   # the writer names chunk i so: a repeated, reordered or foreign entry is refused
        raise ValueError(f"{mpath} is damaged: chunk {i} must be the file {chunk_name(i)} (the chunks are listed "
                         f"once each, in the order written), got {name[:80]!r}")
    path = Path(folder) / name
    if not inside(folder, path):
        raise ValueError(f"{mpath}: chunk {i} ({name}) is a symbolic link to {os.path.realpath(path)}, outside "
                         "the stream folder; it is not followed")
    if path.exists() and not path.is_file():  # a FIFO or a device would block or never end
        raise ValueError(f"{mpath}: chunk {i} ({name}) is not a regular file")
    return path


def _stream_system(meta: dict[str, Any], mpath: Path) -> Any:
    """The :class:`lgvi.systems.System` a stream's ``meta["system"]`` names (one with a stream format)."""
    from ..systems import SYSTEMS

    name = meta.get("system", "rigid_body")
    system = SYSTEMS.get(name) if isinstance(name, str) else None
    if system is None or (system.from_stream is None and name != "rigid_body"):
        streamable = sorted(k for k, v in SYSTEMS.items() if v.from_stream is not None or k == "rigid_body")
        raise ValueError(f"{mpath}: meta names the system {str(name)[:80]!r}, which has no stream format "
                         f"(streamable: {', '.join(streamable)})")
    return system


def _chunk_arrays(folder: Any, mpath: Path, i: int, entry: Any, required: tuple[str, ...],
                  optional: tuple[str, ...] = (), totals: Any = None) -> dict[str, Any]:
    """The arrays ``required`` (each must be there) and those of ``optional`` that are there, of
    the stream's chunk ``i``, checked before loading; ``totals(arrays)``, if given, is stored under
    ``"totals"``. Any failure is a ValueError naming the chunk file."""
    path = _chunk_file(folder, mpath, i, entry)
    try:
        check_npz(path)
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in required if k not in data.files]
            if missing:
                raise ValueError(f"missing field(s) {', '.join(missing)}")
            arrays: dict[str, Any] = {k: data[k] for k in required + optional if k in data.files}
        declared = entry.get("samples")
        if "t" in arrays and declared is not None and declared != len(arrays["t"]):
            raise ValueError(f"the manifest lists {declared!r} samples, the file holds {len(arrays['t'])}")
        if totals is not None:
            arrays["totals"] = totals(arrays)
        return arrays
    except MemoryError:
        raise
    except Exception as exc:  # OSError, EOFError, zipfile.BadZipFile, numpy's ValueErrors, ...
        raise ValueError(f"cannot read stream chunk {path}: {type(exc).__name__}: {exc}") from exc


def system_arrays(folder: str | os.PathLike[str]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """``(manifest, arrays)`` of a stream of any system: the complete chunks' arrays concatenated by
    field name (``t``, the system's ``state`` and ``records`` fields), checked to fit together."""
    manifest = read_manifest(folder)
    mpath = Path(folder) / MANIFEST
    chunks, meta = manifest.get("chunks"), manifest.get("meta")
    if not isinstance(chunks, list) or not isinstance(meta, dict):
        raise ValueError(f"{mpath} is damaged: 'chunks' must be a list and 'meta' an object")
    system = _stream_system(meta, mpath)
    names = ("t",) + tuple(f.name for f in system.state) + tuple(f.name for f in system.records)
    parts: dict[str, list[np.ndarray]] = {k: [] for k in names}
    for i, entry in enumerate(chunks):
        data = _chunk_arrays(folder, mpath, i, entry, names)
        for key in names:
            parts[key].append(data[key])
    if not parts["t"]:
        raise ValueError(f"{folder} holds no complete chunk yet")
    try:
        arrays = {k: np.concatenate(v) for k, v in parts.items()}
    except ValueError as exc:
        raise ValueError(f"the chunks of the stream {folder} do not fit together: {exc}") from exc
    M = len(arrays["t"])
    for f in system.state:
        if len(arrays[f.name]) != M:
            raise ValueError(f"the chunks of the stream {folder} do not fit together: {len(arrays[f.name])} samples "
                             f"of {f.name!r}, {M} times")
    _check_times(np.asarray(arrays["t"], dtype=np.float64), f"the stream {folder}")
    if "R" in arrays:
        _check_rotations(arrays["R"], f"the stream {folder}")
    return manifest, arrays


def _read_system(folder: str | os.PathLike[str], meta: dict[str, Any]) -> Any:
    """:func:`read_stream` of a system other than the rigid body: its ``from_stream`` result."""
    system = _stream_system(meta, Path(folder) / MANIFEST)
    manifest, arrays = system_arrays(folder)
    state = manifest.get("state")
    meta = dict(manifest["meta"], complete=manifest.get("complete", False))
    try:
        return system.from_stream(meta, arrays, state if isinstance(state, dict) else {})
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"the stream {folder} ({system.name}) is damaged: {type(exc).__name__}: {exc}") from exc


_SUMMARY_FIELDS = ("iteration_counts", "iterations_total", "residual_max", "iterations_max")


def read_stream(folder: str | os.PathLike[str]) -> Any:
    """Read every complete chunk of a stream folder as one :class:`Trajectory` (or, for another
    system, its result type: :class:`lgvi.systems.gyrostat.GyrostatTrajectory`,
    :class:`lgvi.OrbitTrajectory`, :class:`lgvi.TwoBodyTrajectory`, through ``System.from_stream``).

    The first chunk holds the initial sample; chunks not listed in the manifest (a crash while
    writing them) are ignored.

    Raises
    ------
    ValueError
        If the folder holds no lgvi stream, the manifest is damaged, or a listed chunk cannot be
        read or does not fit the others; the message names the file.
    """
    manifest = read_manifest(folder)
    mpath = Path(folder) / MANIFEST
    chunks = manifest.get("chunks")
    meta = manifest.get("meta")
    if not isinstance(chunks, list) or not isinstance(meta, dict):
        raise ValueError(f"{mpath} is damaged: 'chunks' must be a list and 'meta' an object")
    if meta.get("system", "rigid_body") != "rigid_body":
        return _read_system(folder, meta)
    try:
        inertia = np.asarray(meta["inertia"], dtype=np.float64)
        h = float(meta["h"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{mpath} is damaged: meta needs the inertia (3, 3) and h ({type(exc).__name__}: "
                         f"{exc})") from exc
    parts: dict[str, list[np.ndarray]] = {k: [] for k in _CHUNK_FIELDS + ("potential",)}
    summaries: list[dict[str, Any] | None] = []
    def totals(data: dict[str, np.ndarray]) -> dict[str, Any] | None:
        if all(k in data for k in _SUMMARY_FIELDS):
            return summary_dict(data["iteration_counts"], int(data["iterations_total"]),
                                float(data["residual_max"]), int(data["iterations_max"]))
        return None   # a stream written before lgvi kept the solver's totals: per-step records

    for i, entry in enumerate(chunks):
        data = _chunk_arrays(folder, mpath, i, entry, _CHUNK_FIELDS, ("potential",) + _SUMMARY_FIELDS, totals)
        for key in parts:
            if key in data:
                parts[key].append(data[key])
        summaries.append(data["totals"])
    meta = dict(meta, complete=manifest.get("complete", False))
    if summaries and all(x is not None for x in summaries):
        total = summaries[0]
        for x in summaries[1:]:
            total = merge_summaries(total, x)
        meta["solver_summary"] = total
    else:
        meta.pop("solver_summary", None)
    if not parts["t"]:
        raise ValueError(f"{folder} holds no complete chunk yet")
    if parts["potential"] and len(parts["potential"]) != len(parts["t"]):
        raise ValueError(f"{folder}: only some chunks hold the potential")
    try:
        cat = {k: np.concatenate(v) for k, v in parts.items() if v}
        _check_arrays(dict(inertia=inertia, **{k: cat[k] for k in _CHUNK_FIELDS}), cat.get("potential"))
    except ValueError as exc:
        raise ValueError(f"the chunks of the stream {folder} do not fit together: {exc}") from exc
    _check_times(cat["t"], f"the stream {folder}")
    _check_rotations(cat["R"], f"the stream {folder}")
    if "solver_summary" in meta and len(cat["iterations"]):
        summary = meta["solver_summary"]
        meta["solver_summary"] = dict(summary, iterations_max=max(int(summary["iterations_max"]),
                                                                  int(cat["iterations"].max())))
    return Trajectory(t=cat["t"], R=cat["R"], Pi=cat["Pi"], inertia=inertia,
                      iterations=cat["iterations"], residual=cat["residual"], h=h,
                      potential=cat.get("potential"), meta=meta)


# ------------------------------------------------------------------------------------------------
# simulate_stream: the driver with a stream sink
# ------------------------------------------------------------------------------------------------
def simulate_stream(folder: str | os.PathLike[str], body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None,
                    h: float, steps: int, torque: Any = None, method: str = "newton", tol: float = 1e-14,
                    max_iter: int = 50, alpha: float = 1.0, save_every: int = 1, t0: float = 0.0,
                    forcing: str = "paper", order: int = 2, composition: str | None = None,
                    progress: Any = False, resume: bool = False, chunk_steps: int | None = None,
                    meta: dict[str, Any] | None = None, solver_record: str = "interval",
                    scheme: str | None = None, wheels: Any = None, controller: Any = None,
                    control_period: Any = None, environment: Any = None, magnetorquers: Any = None) -> Path:
    """Run :func:`simulate` straight to a crash-safe stream folder, in bounded memory.

    The run goes in chunks of ``chunk_steps`` steps (a multiple of ``save_every``); each chunk's
    samples and per-step solver records are written to ``folder`` as soon as it is done (see
    :mod:`lgvi.streaming`), so memory stays bounded whatever ``steps`` is, an interrupted or
    killed run keeps every complete chunk, and ``resume=True`` continues a stream from its last
    complete chunk with the exact state (attitude, momentum, solver history), giving bit for bit
    the result of an uninterrupted run.

    Parameters
    ----------
    folder : path
        The stream folder (created; must not hold a stream unless ``resume=True``).
    body, R0, Pi0, omega0, h, steps, torque, method, tol, max_iter, alpha, save_every, t0, forcing,
    order, composition, progress, solver_record, scheme
        As in :func:`simulate` (a callable torque works too); with the default
        ``solver_record="interval"`` the chunk files are sized by the saved states. With ``resume=True`` they must be
        the same as in the interrupted run (checked against the stream's metadata).
    resume : bool
        Continue the stream in ``folder`` (a complete stream is left as it is).
    chunk_steps : int, optional
        Steps per chunk (default: about 2^18, rounded to a multiple of ``save_every``).
    meta : dict, optional
        Extra JSON-serialisable metadata stored with the stream (e.g. the scenario text).
    wheels, controller, control_period, environment, magnetorquers
        As in :func:`simulate`: a body with reaction wheels or a control loop (the gyrostat,
        :mod:`lgvi.systems.gyrostat`). Its chunks hold ``wheel_momentum`` and the records
        ``wheel_torque``; :func:`read_stream` returns the :class:`GyrostatTrajectory`; ``resume``
        restores the held command, the compiled MRP feedback's integral and a known Python
        controller's state (:func:`lgvi.systems.gyrostat.controller_state`; another Python
        controller's run is refused on resume, since its state cannot be restored).

    Returns
    -------
    pathlib.Path
        The folder; read it with :func:`lgvi.streaming.read_stream`.

    Examples
    --------
    >>> import numpy as np, lgvi, tempfile, pathlib
    >>> from lgvi.streaming import read_stream
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "run"
    >>> _ = lgvi.simulate_stream(folder, [1., 2., 3.], np.eye(3), omega0=[0.3, 1., 0.2], h=0.01,
    ...                          steps=1000, save_every=10, chunk_steps=200)
    >>> traj = read_stream(folder)
    >>> traj.R.shape, traj.iterations.shape, traj.steps
    ((101, 3, 3), (100,), 1000)
    """
    from ..integrator import Run

    folder = stream_folder(folder)
    mapped = _described(folder, body, resume, wheels=wheels, controller=controller, control_period=control_period,
                        environment=environment, magnetorquers=magnetorquers, torque=torque, scheme=scheme)
    if mapped is not None:                  # today's keywords onto the descriptions (lgvi.systems.loop_keywords)
        return stream_system(folder, "spacecraft", mapped[0], R0, Pi0, omega0=omega0, h=h, steps=steps, fsw=mapped[1],
                             method=method, tol=tol, max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0,
                             solver_record=solver_record, order=order, composition=composition, progress=progress,
                             resume=resume, chunk_steps=chunk_steps, meta=meta)
    if wheels is not None or controller is not None or control_period is not None or environment is not None \
            or magnetorquers is not None or scheme == "rkmk4":   # the gyrostat (lgvi.systems.gyrostat)
        from ..systems.gyrostat import gyrostat_options, scheme_run_class

        if scheme is not None and scheme not in ("lgvi", "rkmk4"):
            raise ValueError(f"scheme={scheme!r} cannot be combined with wheels=, controller=, environment= or "
                             "magnetorquers=: reaction wheels and the control loop run with the LGVI (scheme=None) "
                             "or the explicit RKMK scheme (scheme='rkmk4')")
        if scheme != "rkmk4":
            gyrostat_options(torque=torque, forcing=forcing, order=order, composition=composition,
                             error_estimate=None)
        run_class = scheme_run_class(scheme)       # GyrostatRun, or the explicit RKMK run
        run = run_class(body, R0, Pi0, omega0=omega0, h=h, steps=steps, wheels=wheels, controller=controller,
                        control_period=control_period, environment=environment, magnetorquers=magnetorquers,
                        method=method, tol=tol, max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0,
                        solver_record=solver_record, order=order, composition=composition, torque=torque)
        return stream_run(folder, run, resume=resume, progress=progress, chunk_steps=chunk_steps, meta=meta)
    if scheme is not None and scheme != "lgvi":
        from .._validation import choice
        from ..registry import SCHEMES
        from ..splitting import SplittingRun as Run      # type: ignore[assignment]

        choice(scheme, "scheme", SCHEMES)
    run = Run(body, R0, Pi0, omega0=omega0, h=h, steps=steps, torque=torque, method=method, tol=tol,
              max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0, forcing=forcing, order=order,
              composition=composition, solver_record=solver_record)
    _chunk_steps(run, chunk_steps)
    stream_meta = dict(run.meta, **(meta or {}), h=run.h, steps=run.steps, inertia=run.body.J.tolist())
    folder = Path(folder)
    return _drive_stream(folder, run, stream_meta, resume, progress,
                         lambda manifest: _check_resume(manifest["meta"], stream_meta, folder))


def _described(folder: Path, body: Any, resume: bool, **keywords: Any) -> tuple[Any, Any] | None:
    """``(Spacecraft, FlightSoftware or None)`` for :func:`simulate_stream`'s gyrostat keywords where
    the loop runs them bit for bit (:func:`lgvi.systems.loop_keywords.describe`; warns), or ``None``:
    also when resuming a stream that the gyrostat wrote (it continues as it began)."""
    from ..systems.loop_keywords import KeywordsDeprecationWarning, describe, replacement

    if resume and (folder / MANIFEST).is_file():
        try:
            if read_manifest(folder).get("meta", {}).get("system") != "spacecraft":
                return None
        except (OSError, ValueError):
            return None                       # the resume itself names what is wrong with the folder
    described = describe(body, error_estimate=None, **keywords)
    if described is not None:
        import warnings

        warnings.warn(replacement(*described, "lgvi.simulate_stream"), KeywordsDeprecationWarning, stacklevel=3)
    return described


def stream_system(folder: str | os.PathLike[str], system: str, *args: Any, progress: Any = False, resume: bool = False,
                  chunk_steps: int | None = None, meta: dict[str, Any] | None = None, **kwargs: Any) -> Path:
    """Run any streamable system (``lgvi.systems.SYSTEMS[system]``) to a crash-safe stream folder.

    ``args`` and ``kwargs`` are those of the system's run: ``"orbit"`` takes the arguments of
    :func:`lgvi.simulate_orbit`, ``"two_body"`` those of :func:`lgvi.simulate_two_body` (without
    ``progress``), ``"gyrostat"`` those of :func:`simulate` with ``wheels=`` (or use
    :func:`simulate_stream` with ``wheels=``). ``progress``, ``resume``, ``chunk_steps``, ``meta`` as
    in :func:`simulate_stream`: chunks of the system's state fields and records, ``resume=True``
    continues bit for bit (a run with other arguments is refused, naming them), and
    :func:`read_stream` returns the system's result (e.g. :class:`lgvi.OrbitTrajectory`), equal bit
    for bit to the run in memory.

    Returns
    -------
    pathlib.Path
        The folder.

    Examples
    --------
    >>> import numpy as np, lgvi, tempfile, pathlib
    >>> from lgvi.io.streaming import read_stream, stream_system
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "orbit"
    >>> _ = stream_system(folder, "orbit", [1.0, 2.0, 3.0], 10.0, [7000.0, 0, 0], [0, 7.546, 0], np.eye(3),
    ...                   omega0=[0, 0, 1e-3], h=10.0, steps=600, mu=398600.4418, save_every=10, chunk_steps=200)
    >>> type(read_stream(folder)).__name__, read_stream(folder).x.shape
    ('OrbitTrajectory', (61, 3))
    """
    from .._validation import choice
    from ..driver import Progress
    from ..systems import SYSTEMS

    stream_folder(folder)
    streamable = tuple(k for k, v in SYSTEMS.items() if v.from_stream is not None)
    choice(system, "system", streamable)
    Progress(progress, 0)   # validates progress before any work
    run = SYSTEMS[system].run(*args, **kwargs)
    return stream_run(folder, run, resume=resume, progress=progress, chunk_steps=chunk_steps, meta=meta)


def stream_run(folder: str | os.PathLike[str], run: Any, *, resume: bool = False, progress: Any = False,
               chunk_steps: int | None = None, meta: dict[str, Any] | None = None) -> Path:
    """Drive a validated run of a streamable system (its ``system.from_stream`` set, with
    ``stream_meta()``, ``state()`` and ``load_state()``) into the stream folder ``folder``."""
    folder = stream_folder(folder)
    _chunk_steps(run, chunk_steps)
    stream_meta = json.loads(json.dumps(dict(run.stream_meta(), **(meta or {}))))
    # keys derived from the compared ones (a run's ``derived_meta``: a stream begun before lgvi wrote
    # them resumes)
    ignore = {"lgvi_version", *(meta or {}), *getattr(run, "derived_meta", ())}
    return _drive_stream(folder, run, stream_meta, resume, progress,
                         lambda manifest: _check_resume_system(manifest["meta"], stream_meta, folder, ignore))


def _chunk_steps(run: Any, chunk_steps: int | None) -> None:
    """Set the run's chunk to ``chunk_steps`` rounded down to whole saved intervals (at least one)."""
    if chunk_steps is not None:
        run.chunk = max(1, as_int(chunk_steps, "chunk_steps", minimum=1) // run.save_every) * run.save_every


def _drive_stream(folder: Path, run: Any, stream_meta: dict[str, Any], resume: bool, progress: Any,
                  check: Any) -> Path:
    """Open the stream folder (``check(manifest)`` refuses to resume another run), continue from
    its saved state when resuming (an already complete stream is left as it is), and drive the run
    into it chunk by chunk."""
    remaining = run.steps
    if resume and (folder / MANIFEST).is_file():
        try:
            k = read_manifest(folder).get("state", {}).get("k")
            remaining = run.steps - k if isinstance(k, int) and 0 <= k <= run.steps else run.steps
        except (ValueError, AttributeError):   # the writer below reports a damaged manifest
            pass
    check_disk_space(folder, run, remaining)      # before anything is written
    writer = StreamWriter(folder, stream_meta, resume=resume, check=check)
    if resume and writer.state is not None:
        try:
            run.load_state(writer.state)
        except BaseException:
            writer.release()
            raise
        if writer.manifest.get("complete") and run.k == run.steps:
            writer.release()
            return folder
    sink = StreamSink(run, writer, folder)
    with writer:
        drive(run, sink, progress)  # lgvi.driver: chunks, progress, Ctrl-C, failures
    return folder


#: Bytes of a chunk file beyond its arrays (zip directory, ``.npy`` headers), a generous bound.
CHUNK_OVERHEAD = 4096


def estimated_bytes(run: Any, steps: int) -> int:
    """The bytes ``steps`` more steps of ``run`` write to a stream: the saved samples (``t`` and
    the system's state fields), the per-step or per-interval records and each chunk's overhead."""
    state, records = layout(run)     # the run's concrete shapes (a chain's q is (n, 3))
    samples = steps // run.save_every + 1
    per_sample = 8 + sum(int(np.prod(f.shape, dtype=np.int64)) * np.dtype(f.dtype).itemsize for f in state)
    per_record = sum(int(np.prod(f.shape, dtype=np.int64)) * np.dtype(f.dtype).itemsize for f in records)
    chunks = steps // max(1, int(getattr(run, "chunk", steps) or 1)) + 1
    return samples * per_sample + (steps // record_every(run)) * per_record + chunks * CHUNK_OVERHEAD


def check_disk_space(folder: str | os.PathLike, run: Any, steps: int) -> None:
    """``OSError`` (``errno.ENOSPC``) naming ``folder``, the estimate and the free space when the
    stream of ``steps`` more steps of ``run`` would not fit on its disk: checked before a long run
    starts, so that it does not stop hours later on a full disk (an estimate: the final result
    files written next to it need about as much again)."""
    import errno
    import shutil

    need = estimated_bytes(run, steps)
    where = Path(folder).absolute()
    while not where.exists() and where.parent != where:   # the folder is made later: its nearest existing parent
        where = where.parent
    free = shutil.disk_usage(where).free
    if need > free:
        raise OSError(errno.ENOSPC, f"the stream of {steps} steps (about {_size(need)}: {steps // run.save_every + 1} "
                                    f"saved states) would not fit in the folder {folder}, whose disk has "
                                    f"{_size(free)} free; make room, save fewer states (a larger save_every) or "
                                    "stream to another disk")


def _size(n: int) -> str:
    """``n`` bytes for a message: ``'812 kB'``, ``'16.2 GB'``."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n} bytes"


def _check_resume_system(old: dict[str, Any], new: dict[str, Any], folder: Path, ignore: set[str]) -> None:
    """Refuse to continue a stream of another run: every key of the run's metadata must agree."""
    diff = [k for k in sorted(set(old) | set(new)) if k not in ignore and k != "complete" and old.get(k) != new.get(k)]
    if diff:
        k = diff[0]

        def show(v: Any) -> str:
            text = repr(v)
            return text if len(text) <= 200 else text[:200] + "..."

        raise ValueError(f"resume: the stream in {folder} was started with {k}={show(old.get(k))}, now {k}="
                         f"{show(new.get(k))}; a stream resumes only the same run (differences: {', '.join(diff)})")


class StreamSink:
    """A sink of :func:`lgvi.driver.drive` that writes every chunk to a stream folder as soon as it is
    done (bounded memory: one chunk's buffers), for any system whose run has ``state()``.

    The samples of each chunk, its records, the exact state at its end (for ``resume``) and the
    potential go to :class:`StreamWriter`; a partial result is the complete chunks on disk plus the
    current chunk's steps.
    """
    se: Any
    layout: tuple[tuple[Any, ...], tuple[Any, ...]]

    def __init__(self, run: Any, writer: StreamWriter, folder: Path) -> None:
        self.run = run
        self.writer = writer
        self.folder = folder
        self.where: str = f" Complete chunks are in {folder}."
        self.interrupted: str = f"every complete chunk is in {folder} (resume=True continues it)"
        se = self.se = run.save_every
        state, records = self.layout = layout(run)
        self.state: list[Any] = [f.empty(run.chunk // se) for f in state]
        self.per: int = record_every(run)
        self.records: list[Any] = [f.zeros(run.chunk // self.per) for f in records]
        self.chunk_start: dict[str, Any] = {}
        #: a system with its own stream format (``system.from_stream``); else the rigid body's
        self.generic: bool = run.system.from_stream is not None
        if run.k == 0 and not writer.manifest["chunks"] and run.steps == 0:
            self._append(run.times(0, 1), [getattr(run, f.name)[None].copy() for f in run.system.state],
                         [f.zeros(0) for f in records], 0)

    def _append(self, t: np.ndarray, state: list[np.ndarray], records: list[np.ndarray], steps: int) -> None:
        run = self.run
        fields = {f.name: a for f, a in zip(run.system.state, state)}
        fields.update({f.name: a for f, a in zip(run.system.records, records)})
        if self.generic:
            self.writer.append_arrays(dict(t=t, **fields), state=run.state(), steps=steps)
            return
        self.writer.append(t=t, **fields, state=run.state(), potential=run.potential(t, fields["R"]),
                           summary=run.chunk_summary())

    def buffers(self, k0: int, n: int) -> list[np.ndarray]:
        run = self.run
        self.chunk_start = dict(k0=k0, **{f.name: getattr(run, f.name).copy() for f in run.system.state})
        if not self.generic:
            run.new_chunk()
        m = n // self.se
        return [b[:m] for b in self.state] + [r[:n // self.per] for r in self.records]

    def partial(self, k_done: int | None = None) -> Trajectory:
        """The complete chunks on disk plus the steps of the current chunk up to ``k_done``."""
        run, se, start = self.run, self.se, self.chunk_start
        names = [f.name for f in run.system.state] + [f.name for f in run.system.records]
        summary = None if self.generic else run.chunk_summary()
        try:
            if self.generic:    # the raw chunk arrays (records, not the result's fields)
                _, done_arrays = system_arrays(self.folder)
                parts = [tuple(done_arrays[name] for name in ["t"] + names)]
            else:
                done = read_stream(self.folder)
                parts = [(done.t, *(getattr(done, name) for name in names))]
                summary = merge_summaries(done.solver_summary, summary)
        except ValueError:  # no complete chunk yet
            parts = [(run.times(0, 1), *(start[f.name][None] for f in run.system.state),
                      *(f.zeros(0) for f in self.layout[1]))]
        k0 = start["k0"]
        if k_done is not None and k_done > k0:
            m = (k_done - k0) // se
            j0 = k0 // se + 1
            r = (k_done - k0) // self.per
            parts.append((run.times(j0, j0 + m), *(b[:m] for b in self.state), *(a[:r] for a in self.records)))
        t, *arrays = (np.concatenate(a) for a in zip(*parts))
        if self.generic:
            return run.trajectory(t, *arrays, partial=True)
        return run.trajectory(t, *arrays, partial=True, summary=summary)

    def failed(self, k0: int, k: int) -> tuple[float, int]:
        self.writer.close(complete=False)
        return self.run.last_res, self.run.last_its

    def commit(self, k0: int, n: int) -> None:
        run, se = self.run, self.se
        m = n // se
        j0 = k0 // se + 1
        t = run.times(j0, j0 + m)
        state = [b[:m] for b in self.state]
        if k0 == 0:
            t = np.concatenate([run.times(0, 1), t])
            state = [np.concatenate([self.chunk_start[f.name][None], b]) for f, b in zip(run.system.state, state)]
        self._append(t, state, [r[:n // self.per] for r in self.records], n)

    def interrupt(self, k: int) -> Trajectory:
        self.writer.close(complete=False)
        return self.partial()

    def finish(self) -> Path:
        self.writer.close(complete=True)
        return self.folder


def remove_stream(folder: str | os.PathLike) -> list[str]:
    """Remove the stream in ``folder``: the chunks its manifest lists, the manifest and the lock,
    then the folder if nothing else is left. Anything else (files the user keeps there) is never
    touched; returns their names (empty when the folder was removed). A folder that is a
    symbolic link, or holds no lgvi stream, is left alone."""
    folder = Path(folder)
    if folder.is_symlink() or not folder.is_dir():
        return []
    try:
        manifest = read_manifest(folder)
    except ValueError:
        return sorted(p.name for p in folder.iterdir())
    chunks = manifest.get("chunks") if isinstance(manifest.get("chunks"), list) else []
    ours = {chunk_name(i) for i in range(len(chunks))} | {MANIFEST, LOCK_NAME}
    for name in sorted(ours):
        path = folder / name
        if path.is_file() or path.is_symlink():
            try:
                path.unlink()
            except FileNotFoundError:
                pass
    left = sorted(p.name for p in folder.iterdir())
    if not left:
        folder.rmdir()
    return left


def _check_resume(old: dict[str, Any], new: dict[str, Any], folder: Path) -> None:
    keys = ("method", "tol", "max_iter", "alpha", "save_every", "forcing", "order", "composition", "torque",
            "torque_model", "t0", "h", "steps", "inertia", "solver_record", "scheme")
    old = dict(old, solver_record=old.get("solver_record", "full"))  # streams written before the option
    diff = [k for k in keys if old.get(k) != new.get(k)]
    if diff:
        k = diff[0]
        raise ValueError(f"resume: the stream in {folder} was started with {k}={old.get(k)!r}, now {k}="
                         f"{new.get(k)!r}; a stream resumes only the same run (differences: {', '.join(diff)})")


__all__ = ["StreamSink", "StreamWriter", "chunk_name", "read_manifest", "read_stream", "remove_stream",
           "simulate_stream", "stream_run",
           "stream_system", "system_arrays"]
