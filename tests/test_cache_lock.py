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
import os
import sys
import lgvi._jit  # installs the lock
from numba.core import caching
f = caching.IndexDataCacheFile(cache_path=sys.argv[1], filename_base="k.f-1.py", source_stamp=("s", 1))
marker = sys.argv[3] if len(sys.argv) > 3 else None
if marker:
    # inside the locked save (Numba's save writes the index after choosing the data file): was the
    # holder's marker, written while it held the lock, there?
    save_index = caching.IndexDataCacheFile._save_index

    def _save_index(self, overloads):
        print("marker " + ("seen" if os.path.exists(marker) else "absent"), flush=True)
        return save_index(self, overloads)

    caching.IndexDataCacheFile._save_index = _save_index
print("ready", flush=True)
f.save(("sig", sys.argv[2]), b"payload " + sys.argv[2].encode())
print("saved", flush=True)
"""
#: /proc/locks (Linux) lists each process blocked on a lock with "->" before the lock's kind
PROC_LOCKS = "/proc/locks"


def _blocked_on(pid: int, inode: int) -> bool:
    """Whether process ``pid`` is blocked on a ``flock`` of the file whose inode is ``inode``."""
    with open(PROC_LOCKS) as fh:
        for line in fh:
            f = line.split()
            if len(f) >= 7 and f[1] == "->" and f[2] == "FLOCK" and f[5] == str(pid) \
                    and f[6].rsplit(":", 1)[-1] == str(inode):
                return True
    return False


@pytest.mark.skipif(not lj.CACHE, reason="the lock is installed with the on-disk cache")
@pytest.mark.skipif(not os.path.exists(PROC_LOCKS), reason="the kernel's table of blocked locks is Linux's")
def test_the_save_of_an_lgvi_kernel_waits_for_the_index_lock(tmp_path):
    """The child's save blocks on ``<index>.lock`` while this process holds it (the kernel lists it
    as blocked on that file: no guess from a sleep), and it saves only after the holder's release:
    it sees the marker the holder wrote just before releasing."""
    assert getattr(numba_caching.IndexDataCacheFile.save, "_lgvi_locked", False)
    folder = tmp_path / "_kernels_x"
    folder.mkdir()
    index = folder / "k.f-1.py.nbi"
    marker = tmp_path / "released"
    lock = open(str(index) + ".lock", "a+b")
    fcntl.flock(lock, fcntl.LOCK_EX)
    inode = os.fstat(lock.fileno()).st_ino
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(folder), "a", str(marker)], stdout=subprocess.PIPE,
                             text=True, env=env)
    try:
        assert child.stdout.readline().strip() == "ready"
        # wait until the child is blocked on the lock; a child that did not wait would end (or print)
        while not _blocked_on(child.pid, inode):
            assert child.poll() is None, "the child finished its save without waiting for the lock"
            time.sleep(0.01)
        assert not index.exists()       # blocked: it cannot have written the index
        marker.write_text("the holder released the lock after this")
    finally:
        fcntl.flock(lock, fcntl.LOCK_UN)
        lock.close()
    out, _ = child.communicate(timeout=600)
    assert child.returncode == 0 and out.split() == ["marker", "seen", "saved"]
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
