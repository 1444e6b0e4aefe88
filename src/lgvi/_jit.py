"""The one place Numba is configured.

Every compiled kernel in :mod:`lgvi._kernels` is decorated with :func:`jit` from here, so the
compilation options live in a single spot:

* ``nopython`` mode, always (no object-mode fallback);
* ``cache=True`` unless the environment variable ``LGVI_NUMBA_CACHE`` is ``0``. When no cache
  location is writable (a read-only install with an unwritable ``NUMBA_CACHE_DIR`` and home),
  Numba refuses ``cache=True``; the kernels are then compiled in memory and a warning says so;
* ``fastmath`` is never enabled: conservation to round-off depends on IEEE semantics.

Setting ``NUMBA_DISABLE_JIT=1`` runs every kernel as plain Python (slow, but identical maths),
which the test suite uses to check the kernels interpreted.
"""

from __future__ import annotations

import os
import warnings
from typing import Any, Callable

import numba

CACHE: bool = os.environ.get("LGVI_NUMBA_CACHE", "1").strip().lower() not in {"0", "false", "no", "off"}

_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy"}
_warned = False


def _compile(func: Callable, options: dict[str, Any]) -> Callable:
    global _warned
    try:
        return numba.njit(cache=CACHE, **options)(func)
    except RuntimeError as exc:
        if "cannot cache" not in str(exc):
            raise
        if not _warned:
            warnings.warn(f"lgvi: Numba cannot cache the kernels here ({exc}); compiling them in memory on "
                          "every run. Set NUMBA_CACHE_DIR to a writable folder to keep the compiled kernels.",
                          RuntimeWarning, stacklevel=3)
            _warned = True
        return numba.njit(cache=False, **options)(func)


def _decorator(extra: dict[str, Any]) -> Callable:
    def jit(func: Callable | None = None, **kwargs: Any) -> Callable:
        options = {**_OPTIONS, **extra, **kwargs}
        if func is None:
            return lambda f: _compile(f, options)
        return _compile(func, options)

    return jit


#: ``@jit`` or ``@jit(**numba_options)`` compiles in nopython mode with the project's options.
jit = _decorator({})

#: Parallel variant, for kernels with a ``numba.prange`` loop over independent bodies.
jit_parallel = _decorator({"parallel": True})

__all__ = ["CACHE", "jit", "jit_parallel"]
