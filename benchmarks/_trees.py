"""Run a benchmark's child process on one source tree (the ``--compare OLD NEW`` scripts).

``run_child(src, code)`` runs ``python -c code`` with ``src`` (a folder holding ``lgvi/``) first on
``PYTHONPATH`` and returns the JSON object the child prints on its last line. When that object
names the imported package's ``file``, it is checked to lie in ``src``, so a comparison never
measures the installed tree twice.

``other_kernels(src)``: another tree's compiled kernels in this process, beside this tree's (a
before/after in one process, free of the process-to-process changes of the machine's speed).
"""

from __future__ import annotations

import atexit
import importlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from typing import Any, Callable


def run_child(src: str | None, code: str) -> Any:
    """The last stdout line of ``python -c code`` as JSON, lgvi imported from ``src`` (``None``: as installed)."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = os.path.abspath(src) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    if src is not None and isinstance(res, dict) and "file" in res \
            and not os.path.abspath(res["file"]).startswith(os.path.abspath(src)):
        raise RuntimeError(f"{src}: the child imported lgvi from {res['file']}")
    return res


def add_batch_args(ap: Any, calls_help: str = "calls per timed batch (default 200)") -> None:
    """The options of a per-call benchmark run in child processes: ``--compare OLD NEW``, ``--rounds``,
    ``--calls``, ``--batches`` and ``--quick`` (applied by :func:`parse_batch_args`)."""
    ap.add_argument("--compare", nargs=2, metavar=("OLD_SRC", "NEW_SRC"),
                    help="two source trees (the folders holding lgvi/), measured alternately")
    ap.add_argument("--rounds", type=int, default=3, help="child processes per tree (default 3)")
    ap.add_argument("--calls", type=int, default=200, help=calls_help)
    ap.add_argument("--batches", type=int, default=7, help="timed batches per child (default 7)")
    ap.add_argument("--quick", action="store_true", help="1 round, 3 batches of 20 calls (a smoke run)")


def parse_batch_args(ap: Any, argv: list[str] | None) -> Any:
    """``ap.parse_args(argv)`` with ``--quick`` turned into 1 round of 3 batches of 20 calls."""
    args = ap.parse_args(argv)
    if args.quick:
        args.rounds, args.batches, args.calls = 1, 3, 20
    return args


def alternate(old_src: str, new_src: str, rounds: int, measure: Callable[[str], Any]) -> dict[str, list[Any]]:
    """``{src: [measure(src), ...]}`` over ``rounds`` child processes per tree, the trees alternated
    (old first in even rounds), so both see the same machine load."""
    runs: dict[str, list[Any]] = {old_src: [], new_src: []}
    for r in range(rounds):
        for src in ((old_src, new_src) if r % 2 == 0 else (new_src, old_src)):
            runs[src].append(measure(src))
    return runs


def other_kernels(src: str) -> str:
    """Another tree's ``lgvi/_jit.py`` and ``lgvi/_kernels/`` (``src`` the folder holding ``lgvi/``)
    copied into a temporary package ``lgvi_other`` (the kernels import only ``_jit`` and each other,
    relatively) put on ``sys.path``: import ``lgvi_other._kernels.<module>`` for its kernels (compiled
    there, apart from this tree's). Returns the package's name."""
    tmp = tempfile.mkdtemp(prefix="lgvi_other_")
    atexit.register(shutil.rmtree, tmp, True)
    pkg = os.path.join(tmp, "lgvi_other")
    shutil.copytree(os.path.join(src, "lgvi", "_kernels"), os.path.join(pkg, "_kernels"))
    shutil.copy(os.path.join(src, "lgvi", "_jit.py"), pkg)
    open(os.path.join(pkg, "__init__.py"), "w").close()
    sys.path.insert(0, tmp)
    importlib.invalidate_caches()
    return "lgvi_other"
