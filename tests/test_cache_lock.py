"""Saving lgvi's cached kernels is serialised between processes (``lgvi._jit._install_save_lock``).

Numba's save of a cache entry reads the index, picks the first free data-file name and writes both,
unlocked: two processes saving different signatures of one kernel at once (the suite's two workers)
could pick the same data file. lgvi holds ``<index>.lock`` around the save of its kernels.
"""

from __future__ import annotations


import os
import subprocess
import sys
import time

import pytest

import lgvi._jit as lj

numba_caching = pytest.importorskip("numba.core.caching")
fcntl = pytest.importorskip("fcntl")  # the lock is POSIX (lgvi saves unlocked where there is no fcntl)

CHILD = r"""
import sys
import lgvi._jit  # installs the lock
from numba.core import caching
f = caching.IndexDataCacheFile(cache_path=sys.argv[1], filename_base="k.f-1.py", source_stamp=("s", 1))
print("ready", flush=True)
f.save(("sig", sys.argv[2]), b"payload " + sys.argv[2].encode())
print("saved", flush=True)
"""


@pytest.mark.skipif(not lj.CACHE, reason="the lock is installed with the on-disk cache")
def test_the_save_of_an_lgvi_kernel_waits_for_the_index_lock(tmp_path):
    assert getattr(numba_caching.IndexDataCacheFile.save, "_lgvi_locked", False)
    folder = tmp_path / "_kernels_x"
    folder.mkdir()
    index = folder / "k.f-1.py.nbi"
    lock = open(str(index) + ".lock", "a+b")
    fcntl.flock(lock, fcntl.LOCK_EX)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(folder), "a"], stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert child.stdout.readline().strip() == "ready"
        time.sleep(0.5)  # whatever the child's speed, it cannot have saved while the lock is held
        assert not index.exists() and child.poll() is None
    finally:
        fcntl.flock(lock, fcntl.LOCK_UN)
        lock.close()
    out, _ = child.communicate(timeout=600)
    assert child.returncode == 0 and out.strip() == "saved"
    f = numba_caching.IndexDataCacheFile(cache_path=str(folder), filename_base="k.f-1.py", source_stamp=("s", 1))
    assert f.load(("sig", "a")) == b"payload a"


def test_two_processes_saving_different_signatures_keep_both(tmp_path):
    """Two processes save one kernel's two signatures into one index: both entries, each its own data."""
    folder = tmp_path / "_kernels_y"
    folder.mkdir()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, str(folder), s], stdout=subprocess.PIPE, text=True, env=env)
             for s in ("a", "b")]
    for p in procs:
        p.communicate(timeout=600)
        assert p.returncode == 0
    f = numba_caching.IndexDataCacheFile(cache_path=str(folder), filename_base="k.f-1.py", source_stamp=("s", 1))
    assert f.load(("sig", "a")) == b"payload a" and f.load(("sig", "b")) == b"payload b"
