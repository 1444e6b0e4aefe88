"""Run a benchmark's child process on one source tree (the ``--compare OLD NEW`` scripts).

``run_child(src, code)`` runs ``python -c code`` with ``src`` (a folder holding ``lgvi/``) first on
``PYTHONPATH`` and returns the JSON object the child prints on its last line. When that object
names the imported package's ``file``, it is checked to lie in ``src``, so a comparison never
measures the installed tree twice.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any


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
