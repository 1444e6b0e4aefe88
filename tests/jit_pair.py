"""Run a snippet twice in fresh interpreters, with Numba's JIT disabled and enabled: the kernels'
interpreted and compiled forms on the same inputs (tests of the chain and slosh systems)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np


def interpreted_and_compiled(code: str) -> tuple[np.ndarray, np.ndarray]:
    """``code`` prints a list of numbers on its last line; returns that list interpreted, then compiled."""
    results = []
    for jit in (False, True):
        env = dict(os.environ)
        env.pop("NUMBA_DISABLE_JIT", None)
        if not jit:
            env["NUMBA_DISABLE_JIT"] = "1"
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
        assert proc.returncode == 0, proc.stderr
        results.append(np.array(eval(proc.stdout.strip().splitlines()[-1])))
    return results[0], results[1]
