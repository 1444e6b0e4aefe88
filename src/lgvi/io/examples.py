"""The example scenarios shipped with lgvi: ``lgvi example`` lists them, ``lgvi example NAME``
writes one out (to give to ``lgvi run``).

In an installed wheel they are package data (``lgvi/_examples/*.toml``, copied from the
repository's ``examples/`` when the wheel is built); in a source tree they are read from
``examples/`` directly, so the two never differ.

>>> from lgvi.io import examples
>>> "dzhanibekov" in examples.names()
True
>>> examples.text("dzhanibekov").startswith("#")
True
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["folder", "names", "summary", "text", "write"]


def folder() -> Path:
    """The folder that holds the example scenarios (``NAME.toml``).

    Raises
    ------
    FileNotFoundError
        Neither the installed package data nor a source tree's ``examples/`` is there.
    """
    here = Path(__file__).resolve().parent.parent          # the lgvi package
    for candidate in (here / "_examples", here.parent.parent / "examples"):
        if candidate.is_dir() and any(candidate.glob("*.toml")):
            return candidate
    raise FileNotFoundError(f"no example scenarios found: neither {here / '_examples'} (an installed lgvi) nor "
                            f"{here.parent.parent / 'examples'} (a source tree) holds any; reinstall lgvi")


def names() -> list[str]:
    """The names of the example scenarios, sorted (``dzhanibekov``, ``heavy_top``, ...)."""
    return sorted(p.stem for p in folder().glob("*.toml"))


def _path(name: str) -> Path:
    if not isinstance(name, str):
        raise TypeError(f"name must be a string (an example's name), got {type(name).__name__}")
    stem = name[:-5] if name.endswith(".toml") else name
    known = names()
    if stem not in known:
        raise ValueError(f"name={name!r} is not an example scenario; the examples are: {', '.join(known)}")
    return folder() / f"{stem}.toml"


def text(name: str) -> str:
    """The TOML text of the example scenario ``name`` (with or without ``.toml``).

    Raises
    ------
    ValueError
        ``name`` is not one of :func:`names`.
    """
    return _path(name).read_text(encoding="utf-8")


def summary(name: str, width: int = 72) -> str:
    """The first sentence of the example's leading comment, cut to ``width`` characters."""
    words = []
    for line in text(name).splitlines():
        if not line.startswith("#"):
            break
        words += line.lstrip("#").split()
    sentence = " ".join(words).split(". ")[0].split(": ")[0].rstrip(".")
    return sentence if len(sentence) <= width else sentence[:width - 3].rstrip() + "..."


def write(name: str, path: str | os.PathLike[str] | None = None, *, overwrite: bool = False) -> Path:
    """Write the example scenario ``name`` to ``path`` (default ``NAME.toml`` in the current folder).

    A ``path`` that is an existing folder receives ``NAME.toml`` inside it. An existing file is
    kept unless ``overwrite=True`` (a ``FileExistsError`` says so). Returns the path written.
    """
    source = _path(name)
    target = Path(source.name) if path is None else Path(path)
    if target.is_dir():
        target = target / source.name
    if target.exists() and not overwrite:
        raise FileExistsError(f"{target} exists; choose another path, or overwrite it (overwrite=True; "
                              "--force on the command line)")
    target.write_text(source.read_text(encoding="utf-8"), encoding="utf-8")
    return target
