"""The one place Numba is configured.

Every compiled kernel in :mod:`lgvi._kernels` is decorated with :func:`jit` from here, so the
compilation options live in a single spot:

* ``nopython`` mode, always (no object-mode fallback);
* ``cache=True`` unless the environment variable ``LGVI_NUMBA_CACHE`` is ``0``; an unwritable
  cache folder is tolerated by Numba (it warns and compiles in memory);
* ``fastmath`` is never enabled: conservation to round-off depends on IEEE semantics.

Setting ``NUMBA_DISABLE_JIT=1`` runs every kernel as plain Python (slow, but identical maths),
which the test suite uses to check the kernels interpreted.
"""

from __future__ import annotations

import functools
import os

import numba

CACHE: bool = os.environ.get("LGVI_NUMBA_CACHE", "1").strip().lower() not in {"0", "false", "no", "off"}

#: ``jit(func)`` compiles ``func`` in nopython mode with the project's options.
jit = functools.partial(numba.njit, cache=CACHE, nogil=True, error_model="numpy")

#: Parallel variant, for kernels with a ``numba.prange`` loop over independent bodies.
jit_parallel = functools.partial(numba.njit, cache=CACHE, nogil=True, error_model="numpy", parallel=True)

__all__ = ["CACHE", "jit", "jit_parallel"]
