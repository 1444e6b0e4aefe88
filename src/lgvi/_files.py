"""Writing result files safely: atomic replacement, clear messages on a full disk, one writer per folder.

* :func:`write_atomic`: write a file under a temporary name, flush it to disk and rename it into
  place, so that a reader (or a retried Dask task) never sees a half-written file, whatever
  happens to the writer (killed, out of space); on failure the temporary file is removed.
* :func:`write_text`, :func:`refuse_link`: every file lgvi writes goes through
  :func:`write_atomic`, never through a symbolic link.
* :func:`write_failure`: the ``OSError`` of a failed write, re-raised with a message naming the
  file and its folder (and, for a full disk or quota, saying so and what is still there).
* :class:`FolderLock`: an exclusive lock on a folder (the file ``.lgvi.lock`` holding the
  writer's process id, locked with ``flock``); a second writer gets :class:`FolderLocked`. The
  operating system drops the lock when its process ends, so the lock of a crashed writer is
  taken over (with a :class:`StaleLockWarning`), never left to be removed by hand.
"""

from __future__ import annotations

import errno
import os
import secrets
import warnings
from pathlib import Path
from typing import Any, Callable

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

#: Name of the lock file in a locked folder.
LOCK_NAME = ".lgvi.lock"
#: ``errno`` values of a full disk or an exhausted quota.
NO_SPACE = tuple(e for e in (getattr(errno, "ENOSPC", None), getattr(errno, "EDQUOT", None)) if e is not None)


def lgvi_header(data: Any, expected: str) -> dict[str, Any]:
    """The JSON ``__lgvi__`` header of an opened lgvi ``.npz`` whose format must be ``expected``;
    ValueError saying what is wrong otherwise."""
    from ._untrusted import load_json

    if "__lgvi__" not in data.files:
        raise ValueError("no '__lgvi__' header")
    header = load_json(str(data["__lgvi__"]), "the '__lgvi__' header")
    if not isinstance(header, dict) or header.get("format") != expected:
        what = header.get("format") if isinstance(header, dict) else header
        raise ValueError(f"format {what!r}, expected {expected!r}")
    return header


class WriteFailed(OSError):
    """A failed write whose message already names the file and its folder; ``reason`` is the
    operating system's own words (``strerror``), so :func:`write_failure` can name it again."""

    def __init__(self, err: int | None, message: str, reason: str) -> None:
        super().__init__(err, message)
        self.reason = reason


def _temporary(path: Path) -> Path:
    """An unpredictable hidden name next to ``path`` (128 random bits: a name planted in advance,
    a link included, is never the one used; it is created with ``O_EXCL`` anyway)."""
    return path.with_name(f".{path.name}.{secrets.token_hex(16)}.tmp{path.suffix}")  # the suffix kept: some
    # writers (Pillow, ffmpeg) choose the format by it


def refuse_link(path: str | os.PathLike[str], what: str = "file") -> None:
    """Raise :class:`WriteFailed` (``errno.ELOOP``) if ``path`` is a symbolic link: lgvi never
    writes through, nor replaces, a link it did not make (a planted ``out.png -> ../victim``)."""
    path = Path(path)
    if path.is_symlink():
        raise WriteFailed(errno.ELOOP, f"cannot write the {what} {path.name} in the folder {path.parent}: it is a "
                          f"symbolic link (to {os.readlink(path)}), and lgvi never writes through a link; remove "
                          "it or choose another folder", "a symbolic link")


def write_atomic(path: str | os.PathLike[str], write: Callable[[Any], Any], *, by_path: bool = False,
                 what: str = "file") -> None:
    """Write ``path`` as ``write(fh)`` does into a binary file, atomically.

    The data go to a hidden temporary file in the same folder (an unpredictable name, created
    exclusively, so that two attempts of one task never share it and a planted name or link is
    never written through), are flushed to disk and renamed over ``path``. ``path`` itself must
    not be a symbolic link (:func:`refuse_link`). On any error the temporary file is removed and
    the error is raised, an ``OSError`` as :class:`WriteFailed` naming the file and its folder (a
    full disk says so); ``path`` is then untouched. With ``by_path=True`` the writer is called
    with the temporary file's path instead (for libraries that open files by name: netCDF,
    animations), the file already created empty.
    """
    path = Path(path)
    refuse_link(path, what)
    tmp = _temporary(path)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(tmp, flags, 0o666)
    except OSError as exc:
        raise _named(exc, path, what) from exc
    try:
        if by_path:
            os.close(fd)
            write(tmp)
            fd = os.open(tmp, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        else:
            with open(fd, "wb") as fh:
                write(fh)
                fh.flush()
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError) and not isinstance(exc, WriteFailed):
            raise _named(exc, path, what) from exc
        raise


def _named(exc: OSError, path: Path, what: str) -> WriteFailed:
    reason = exc.strerror or str(exc)
    text = f"the disk is full ({reason})" if exc.errno in NO_SPACE else reason
    return WriteFailed(exc.errno, f"cannot write the {what} {path.name} in the folder {path.parent}: {text}", reason)


def write_text(path: str | os.PathLike[str], text: str, what: str = "file") -> Path:
    """Write ``text`` (UTF-8) to ``path`` with :func:`write_atomic`; returns ``path``."""
    data = text.encode("utf-8")
    write_atomic(path, lambda fh: fh.write(data), what=what)
    return Path(path)


def write_failure(exc: OSError, path: str | os.PathLike[str], what: str, kept: str) -> OSError:
    """``exc`` (a failed write of ``path``) as an ``OSError`` of the same kind whose message names
    the file and its folder; ``what`` says what was written, ``kept`` what is still usable."""
    path = Path(path)
    reason = exc.reason if isinstance(exc, WriteFailed) else (exc.strerror or str(exc))
    if exc.errno in NO_SPACE:
        reason = f"the disk is full ({reason})"
    return OSError(exc.errno, f"cannot write {what} {path.name} in the folder {path.parent}: {reason}. {kept}")


class FolderLocked(BlockingIOError):
    """Another writer (process or object) holds the lock of the folder; ``pid`` is its process id
    as written in the lock file (``None`` if unknown)."""

    def __init__(self, message: str, pid: int | None = None):
        super().__init__(errno.EAGAIN, message)
        self.pid = pid


class StaleLockWarning(UserWarning):
    """The lock file of a folder named a writer that ended without releasing it (a crash or a
    kill); the lock was taken over."""


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 64, 0).decode("ascii", "replace").strip()
        return int(text) if text else None
    except (OSError, ValueError):
        return None


class FolderLock:
    """An exclusive, non-blocking lock on ``folder`` for one writer (see the module notes).

    ``acquire()`` raises :class:`FolderLocked` naming the folder and the holder's process id if
    another writer (in this or another process) holds it; ``release()`` removes the lock file.
    Use as a context manager, or call the two methods.
    """

    def __init__(self, folder: str | os.PathLike[str], what: str = "folder") -> None:
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self.what = what
        self.fd: int | None = None

    def acquire(self) -> "FolderLock":
        if self.fd is not None:
            return self
        flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
        while True:
            try:
                fd = os.open(self.path, flags, 0o666)
            except OSError as exc:
                raise OSError(exc.errno, f"cannot lock the {self.what} {self.folder}: cannot open {self.path} "
                                         f"({exc.strerror}; a symbolic link there is refused)") from exc
            try:
                if fcntl is not None:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                else:  # pragma: no cover - Windows: lock the first byte
                    import msvcrt

                    msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
            except OSError as exc:
                pid = _read_pid(fd)
                os.close(fd)
                if exc.errno not in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EACCES):
                    raise
                who = f"process {pid}" if pid is not None else "another process"
                if pid == os.getpid():
                    who = "another writer in this process"
                raise FolderLocked(f"the {self.what} {self.folder} is being written by {who} (it holds "
                                   f"{self.path}); two writers would interleave their chunks. Wait for it to "
                                   "finish or stop it, or use another folder", pid) from None
            # the holder may have released and removed the file between our open and our lock: retry then
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path, follow_symlinks=False))
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            break
        old = _read_pid(fd)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self.fd = fd
        if old is not None:
            warnings.warn(f"the {self.what} {self.folder} was locked by process {old}, which ended without "
                          "releasing it (crashed or killed?); the lock was taken over", StaleLockWarning,
                          stacklevel=3)
        return self

    def release(self) -> None:
        """Remove the lock file and drop the lock (does nothing if not held)."""
        fd, self.fd = self.fd, None
        if fd is None:
            return
        try:
            os.unlink(self.path)  # while still locked, so that a waiting writer sees another file and retries
        except OSError:
            pass
        os.close(fd)

    @property
    def held(self) -> bool:
        return self.fd is not None

    def __enter__(self) -> "FolderLock":
        return self.acquire()

    def __exit__(self, *exc: Any) -> None:
        self.release()

    def __del__(self) -> None:  # pragma: no cover - a writer dropped without closing
        try:
            self.release()
        except Exception:
            pass
