"""What keys the cache of lgvi's kernels (``lgvi._jit._install_cache_key``).

Numba's cache key of a compiled function is its signature, the CPU and the bytecode: no compilation
setting. A process run with ``NUMBA_BOUNDSCHECK=1`` or ``NUMBA_OPT=0`` that compiles a kernel (a cache
miss) would leave bounds-checked or unoptimised code in the cache, and every later run of the same
tree, with the default settings, would load it (slower, silently). lgvi keeps a sub-folder per
code-shaping setting; and the options of ``lgvi._jit`` (``error_model``, ``nogil``) are in the stamp.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from lgvi import _jit

if not _jit.CACHE:
    pytest.skip("LGVI_NUMBA_CACHE=0: no cache, no key", allow_module_level=True)

CHILD = "from lgvi._kernels import stepping; print(stepping.run_chunk._cache.cache_path)"


def _cache_path(tmp_path, **settings):
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(NUMBA_CACHE_DIR=str(tmp_path), **settings)
    out = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip().splitlines()[-1]


def test_code_shaping_numba_settings_have_their_own_cache(tmp_path):
    default = _cache_path(tmp_path)
    assert default.startswith(str(tmp_path)) and "_kernels" in default
    assert _cache_path(tmp_path) == default                        # the same settings: the same cache
    assert _cache_path(tmp_path, NUMBA_BOUNDSCHECK="1") != default
    assert _cache_path(tmp_path, NUMBA_OPT="0") != default
    assert _cache_path(tmp_path, NUMBA_DEBUGINFO="1") != default


def test_the_options_file_is_in_the_stamp():
    assert os.path.abspath(_jit.__file__) in [os.path.abspath(p) for p in _jit._key_files()]
