"""Checks for values that come from files (scenarios, trajectories, stream folders), which may
have been written by someone else: see ``SECURITY.md``.

* :func:`name_problem` / :func:`safe_name`: a name from a file never becomes a path outside the
  folder it is put in (no separators, ``..``, absolute paths, control characters, huge lengths).
* :func:`inside`: a path (after following symbolic links) lies in a folder.
* :func:`check_npz`: an ``.npz`` archive holds only ``NAME.npy`` members, no object (pickled)
  arrays and declares no array larger than the bytes it holds, checked from the headers before
  anything is read or allocated.
* :func:`load_json`: JSON text from a file; nesting too deep is a clear ValueError, not
  Python's ``RecursionError``.
* :func:`check_count`: a size a file declares (samples, steps) against a limit.
"""

from __future__ import annotations

import math
import os
import re
import unicodedata
import zipfile
from pathlib import Path

import numpy as np

#: Longest scenario name accepted (characters).
MAX_NAME = 100
#: Longest slug used in a file name (characters).
MAX_SLUG = 64
#: Deflate expands at most ~1032:1; a member declaring more than this ratio is damaged or hostile.
MAX_DEFLATE_RATIO = 1100
def load_json(text: str | bytes, what: str) -> object:
    """``json.loads(text)`` of JSON read from a file, ``what`` naming it: a ValueError for a
    syntax error (``json.JSONDecodeError``, a ValueError) or for nesting too deep for Python's
    parser (which raises a bare ``RecursionError``), naming the file."""
    import json

    try:
        return json.loads(text)
    except RecursionError:
        raise ValueError(f"{what}: JSON nested too deeply to read (lgvi writes a few levels); damaged or hostile "
                         "file") from None


def check_count(value: object, limit: int, what: str, where: str) -> int:
    """A count a file declares (``what``: samples, steps) as an int in ``0 .. limit``; ValueError
    naming ``where`` (the file) otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= int(value) <= limit:
        raise ValueError(f"{where} declares {what} = {str(value)[:40]}, expected an integer from 0 to {limit}")
    return int(value)


#: Unicode categories refused in names: control, format (bidirectional overrides such as U+202E,
#: zero-width characters), surrogates, private use, unassigned, line and paragraph separators.
_HIDDEN = ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp")


def name_problem(name: str) -> str | None:
    """Why ``name`` cannot name a run (``None`` if it can): the rule it breaks, for a message."""
    rule = (f"a name of 1 to {MAX_NAME} characters without path separators ('/', '\\', ':'), control or "
            "invisible formatting characters (bidirectional overrides, zero-width characters, line separators) or "
            "a leading '.'; it names the default output folder NAME_output")
    if not name.strip():
        return f"expected {rule}; got an empty name"
    if len(name) > MAX_NAME:
        return f"expected {rule}; got {len(name)} characters"
    bad = sorted({c for c in name if c in "/\\:" or unicodedata.category(c) in _HIDDEN})
    if bad:
        return f"expected {rule}; got {name[:60]!r} (contains {', '.join(repr(c) for c in bad)})"
    if name.startswith("."):
        return f"expected {rule}; got {name[:60]!r}"
    return None


def safe_name(name: str, fallback: str = "scenario") -> str:
    """A file-name slug of ``name``: ASCII letters, digits, ``_``, ``-`` and ``.`` (not leading),
    other runs of characters replaced by ``_``, at most :data:`MAX_SLUG` characters; ``fallback``
    if nothing is left. It never contains a separator and is never ``.`` or ``..``."""
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(name)).lstrip(".-")[:MAX_SLUG]
    return slug if slug.strip("_") else fallback


def inside(folder: str | os.PathLike[str], path: str | os.PathLike[str]) -> bool:
    """Whether ``path``, symbolic links followed, lies inside ``folder`` (links followed too)."""
    root = Path(folder).resolve()
    target = Path(path).resolve()
    return target == root or root in target.parents


def check_npz(path: str | os.PathLike[str]) -> None:
    """Refuse an ``.npz`` whose headers declare object arrays or more data than it holds.

    Reads only the zip directory and the ``.npy`` headers, so a hostile file is refused before
    :func:`numpy.load` allocates anything.

    Raises
    ------
    ValueError
        Naming the member and the rule; ``zipfile.BadZipFile`` and numpy's header errors pass
        through (callers wrap them with the file name).
    """
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            what = f"member {info.filename[:80]!r}"
            if not info.filename.endswith(".npy"):   # numpy would read a member 'R' as the array R, unchecked
                raise ValueError(f"{what} is not an array file NAME.npy; an lgvi .npz holds only those, so the "
                                 "file is refused")
            if info.compress_type != zipfile.ZIP_STORED and \
                    info.file_size > MAX_DEFLATE_RATIO * info.compress_size + 65536:
                raise ValueError(f"{what} declares {info.file_size} bytes from {info.compress_size} compressed "
                                 "bytes, more than compression can produce (damaged or hostile file)")
            with zf.open(info) as fh:
                version = np.lib.format.read_magic(fh)
                if version == (1, 0):
                    shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
                else:
                    shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
                offset = fh.tell()
            if dtype.hasobject:
                raise ValueError(f"{what} holds an object array (dtype {dtype}); lgvi never unpickles data "
                                 "from a file, so it is refused")
            nbytes = math.prod(shape) * dtype.itemsize
            if nbytes > info.file_size - offset:
                raise ValueError(f"{what} declares an array of shape {shape} and dtype {dtype} ({nbytes} bytes) "
                                 f"but holds {info.file_size - offset} bytes of data")
