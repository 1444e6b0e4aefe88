"""Write the intersphinx inventories of NumPy and SciPy that the documentation links through.

``docs/conf.py`` maps ``numpy`` and ``scipy`` to the inventories in ``docs/_inventories/`` rather
than to the projects' sites, so ``make docs`` (``-W``) needs no network. The inventories hold the
NumPy and SciPy names that lgvi's sources and pages use, each with the address it has in the
projects' documentation (https://numpy.org/doc/stable/, https://docs.scipy.org/doc/scipy/: a
function or class ``scipy.x.f`` at ``reference/generated/scipy.x.f.html#scipy.x.f``, NumPy's
scalar types, constants, typing and random generator on their own pages), found by importing
them from the installed packages. Run it again after the sources name new NumPy or SciPy
objects::

    python docs/make_inventories.py

An inventory is Sphinx's ``objects.inv`` format, version 2: four header lines, then zlib-compressed
lines ``name domain:role priority uri display-name`` (``$`` in the uri stands for the name).
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
import types
import zlib
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
OUT = DOCS / "_inventories"

#: names the docstrings' type lines use through numpydoc's aliases (``docs/conf.py``), always listed
ALWAYS = ("numpy.ndarray", "numpy.typing.ArrayLike", "numpy.random.Generator", "numpy.random.default_rng",
          "numpy.float64", "numpy.int64", "scipy.spatial.transform.Rotation", "scipy.integrate.solve_ivp",
          "scipy.optimize.minimize", "scipy.optimize.OptimizeResult")
#: NumPy's pages that are not ``reference/generated/<name>.html``
NUMPY_PAGES = {"numpy.typing.ArrayLike": "reference/typing.html", "numpy.typing.NDArray": "reference/typing.html",
               "numpy.random.Generator": "reference/random/generator.html",
               "numpy.random.default_rng": "reference/random/generator.html"}
NUMPY_MODULES = {"numpy": "reference/index.html", "numpy.linalg": "reference/routines.linalg.html",
                 "numpy.typing": "reference/typing.html", "numpy.random": "reference/random/index.html",
                 "numpy.fft": "reference/routines.fft.html"}
NUMPY_CONSTANTS = ("pi", "e", "inf", "nan", "newaxis")


def used_names() -> set[str]:
    """``numpy.x``, ``np.x`` and ``scipy.x`` names in the package's sources and the pages."""
    files = list((ROOT / "src" / "lgvi").rglob("*.py")) + list(DOCS.glob("*.md")) + list((ROOT / "examples").glob("*.py"))
    found = set(ALWAYS)
    for path in files:
        for m in re.finditer(r"\b(numpy|np|scipy)((?:\.[A-Za-z_][A-Za-z0-9_]*)+)", path.read_text(encoding="utf-8")):
            found.add(("numpy" if m.group(1) == "np" else m.group(1)) + m.group(2))
    return found


def resolve(name: str) -> object | None:
    """The object ``name`` names in the installed packages, or None."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr, None)
            if obj is None:
                return None
        return obj
    return None


def role(obj: object, name: str) -> str | None:
    if name.startswith("numpy.typing."):
        return "py:data"              # type aliases, documented as data
    if isinstance(obj, types.ModuleType):
        return "py:module"
    if inspect.isclass(obj):
        return "py:class"
    if callable(obj):
        owner = resolve(name.rsplit(".", 1)[0])
        return "py:method" if inspect.isclass(owner) else "py:function"
    return "py:data" if name.startswith("numpy.") and name.split(".")[-1] in NUMPY_CONSTANTS else None


def uri(name: str, kind: str) -> str:
    if name.startswith("numpy."):
        if kind == "py:module":
            return NUMPY_MODULES[name] + "#module-" + name
        if name in NUMPY_PAGES:
            return NUMPY_PAGES[name] + "#" + name
        if kind == "py:data":
            return "reference/constants.html#" + name
        obj = resolve(name)
        if inspect.isclass(obj) and issubclass(obj, resolve("numpy.generic")):     # scalar types
            return "reference/arrays.scalars.html#" + name
        return "reference/generated/" + name + ".html#" + name
    if kind == "py:module":
        return "reference/" + name.split(".", 1)[1] + ".html#module-" + name
    return "reference/generated/" + name + ".html#" + name


def entries(package: str) -> list[str]:
    lines = []
    names = sorted(n for n in used_names() if n.split(".")[0] == package)
    if package == "scipy":        # the rotation class's public methods: the conventions page names them
        R = "scipy.spatial.transform.Rotation"
        names += [f"{R}.{m}" for m in dir(resolve(R)) if not m.startswith("_")]
    for name in sorted(set(names)):
        obj = resolve(name)
        if obj is None or (package == "numpy" and name.count(".") >= 2
                           and isinstance(resolve(name.rsplit(".", 1)[0]), resolve("numpy.ufunc"))):
            continue      # not a public object, or a ufunc's method (documented on numpy.ufunc)
        if name in NUMPY_MODULES or (package == "scipy" and isinstance(obj, types.ModuleType)):
            kind = "py:module"
            if package == "numpy" and name not in NUMPY_MODULES:
                continue
        else:
            kind = role(obj, name)
            if kind is None or kind == "py:module":
                continue
        lines.append(f"{name} {kind} 1 {uri(name, kind)} -")
    if package == "numpy":
        lines.append("array_like std:term -1 glossary.html#term-array_like array_like")
    return lines


def write(package: str, version: str) -> Path:
    body = "\n".join(entries(package)) + "\n"
    head = f"# Sphinx inventory version 2\n# Project: {package}\n# Version: {version}\n" \
           "# The remainder of this file is compressed using zlib.\n"
    path = OUT / f"{package}.inv"
    OUT.mkdir(exist_ok=True)
    path.write_bytes(head.encode() + zlib.compress(body.encode(), 9))
    return path


def main() -> int:
    import numpy
    import scipy

    for package, module in (("numpy", numpy), ("scipy", scipy)):
        path = write(package, module.__version__)
        n = zlib.decompress(path.read_bytes().split(b"\n", 4)[4]).decode().count("\n")
        print(f"{path.relative_to(ROOT)}: {n} names, {path.stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
