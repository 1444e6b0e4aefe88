"""The distributed engine under faults: a worker killed, a full disk, two writers on one folder.

* A Dask ``LocalCluster`` with two worker processes, one of them killed in the middle of an
  ensemble (deterministically: the first block task anywhere ``os._exit``s, chosen through a
  marker file created with ``O_EXCL``): Dask reruns the lost task on a live worker and the result
  is complete and bit for bit the serial run, in memory and with ``out_dir`` (where the killed
  worker dies half-way through writing a block: the half-written file is never read).
* A full disk (``ENOSPC``, injected into the low-level atomic write after some chunks, on a
  chunk or on the manifest): the error names the folder and says the disk is full, every
  complete chunk is readable, nothing half-written is left, and ``resume=True`` finishes the run
  bit for bit. The same for the block files of an ``out_dir`` ensemble.
* Two writers on one stream folder, in one process and in two: the second gets
  ``FolderLocked`` naming the folder and the holder's process id, and the first run's chunks are
  never interleaved with anything; a killed writer's lock is taken over with a warning.
"""

from __future__ import annotations

import concurrent.futures
import errno
import importlib.util
import io
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi import ensemble, so3
from lgvi.io import streaming
from lgvi._files import FolderLock, FolderLocked, StaleLockWarning
from lgvi.io.streaming import StreamWriter, read_manifest, read_stream
from lgvi.torques import UniformGravity

HAVE_DASK = importlib.util.find_spec("dask") is not None and importlib.util.find_spec("distributed") is not None
BODY = lgvi.RigidBody([0.13, 0.28, 0.17])
RUN = dict(omega0=[4.14, 4.14, 4.14], h=0.01, steps=600, save_every=10, torque=UniformGravity(1.0, [0.0, 0.0, 0.3]))
FIELDS = ("t", "R", "Pi", "iterations", "residual", "potential")


def same(a, b) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in FIELDS)


def no_space_after(monkeypatch, writes: int, target: str) -> list[str]:
    """Make the ``writes``-th atomic write of ``target`` files ("chunk" or "manifest") of a stream
    fail with ENOSPC after writing part of the file (the real temporary-file path runs)."""
    real = streaming._fsync_write
    seen: list[str] = []

    def fake(path: Path, write) -> None:
        kind = "manifest" if path.name == streaming.MANIFEST else "chunk"
        if kind == target:
            seen.append(path.name)
        if kind != target or len(seen) != writes:
            return real(path, write)

        def half_then_full(fh) -> None:
            buf = io.BytesIO()
            write(buf)
            fh.write(buf.getvalue()[: len(buf.getvalue()) // 2])
            fh.flush()
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        return real(path, half_then_full)

    monkeypatch.setattr(streaming, "_fsync_write", fake)
    return seen


# ------------------------------------------------------------------------------------------------
# A full disk
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("target, writes", [("chunk", 4), ("manifest", 5)])
def test_full_disk_during_stream_names_the_folder_keeps_chunks_and_resumes(tmp_path, monkeypatch, target, writes):
    folder = tmp_path / "run"
    clean = lgvi.simulate(BODY, np.eye(3), **RUN)
    seen = no_space_after(monkeypatch, writes, target)  # chunk 3 (or the manifest listing it) hits the full disk
    with pytest.raises(OSError) as info:
        lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, **RUN)
    err = info.value
    assert err.errno == errno.ENOSPC and len(seen) == writes
    msg = str(err)
    assert str(folder) in msg and "disk is full" in msg and "resume=True" in msg, msg
    assert "3 complete chunk(s)" in msg, msg
    monkeypatch.undo()
    # the complete chunks are readable: exactly the first 300 steps of the clean run
    part = read_stream(folder)
    assert part.steps == 300 and len(read_manifest(folder)["chunks"]) == 3
    np.testing.assert_array_equal(part.R, clean.R[:31])
    np.testing.assert_array_equal(part.iterations, clean.iterations[:len(part.iterations)])
    assert len(part.iterations) in (30, 300)  # the solver record: per sample or per step
    # nothing half-written is left (no temporary file, no lock)
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".")]
    lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, resume=True, **RUN)
    done = read_stream(folder)
    assert done.meta["complete"] and same(done, clean)


def test_full_disk_at_the_start_of_a_stream(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    no_space_after(monkeypatch, 1, "manifest")
    with pytest.raises(OSError, match="disk is full") as info:
        lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, **RUN)
    assert str(folder) in str(info.value) and "No chunk was complete yet" in str(info.value)
    assert not (folder / streaming.MANIFEST).exists() and not list(folder.iterdir())


def test_full_disk_during_out_dir_ensemble_names_the_folder(tmp_path, monkeypatch):
    rng = np.random.default_rng(5)
    R0 = so3.exp(0.4 * rng.normal(size=(9, 3)))
    Pi0 = [0.2, 0.5, -0.3] + 0.1 * rng.normal(size=(9, 3))
    opts = dict(h=0.01, steps=40, save_every=4)
    serial = lgvi.simulate_ensemble(BODY, R0, Pi0, **opts)
    real = ensemble.write_atomic
    calls = []

    def fake(path, write):
        calls.append(path)
        if len(calls) != 2:
            return real(path, write)

        def fail(fh):
            fh.write(b"PK\x03\x04 half a block")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        return real(path, fail)

    monkeypatch.setattr(ensemble, "write_atomic", fake)
    out = tmp_path / "blocks"
    with pytest.raises(OSError, match="disk is full") as info:
        lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=4, **opts)
    assert info.value.errno == errno.ENOSPC and str(out) in str(info.value)
    assert sorted(p.name for p in out.iterdir()) == ["ensemble-00000.npz"]  # no half-written block 1
    first = lgvi.load_ensemble(out / "ensemble-00000.npz")
    np.testing.assert_array_equal(first.R, serial.R[:4])
    with pytest.raises(ValueError, match="the last blocks are missing"):
        lgvi.load_ensemble(out)


CLI_SCENARIO = """\
name = "spin"

[body]
inertia = [1.0, 2.0, 3.0]

[initial]
omega = [0.01, 1.0, 0.01]

[integrator]
h = 0.01
steps = 20

[output]
plots = false
"""


def test_full_disk_in_lgvi_run_is_one_line_and_resume_finishes(tmp_path, monkeypatch, capsys):
    from lgvi import cli, integrator

    (tmp_path / "s.toml").write_text(CLI_SCENARIO)
    out = tmp_path / "o"
    monkeypatch.setattr(integrator, "CHUNK_STEPS", 5)  # four chunks
    no_space_after(monkeypatch, 3, "chunk")
    code = cli.main(["run", str(tmp_path / "s.toml"), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and "Traceback" not in err, err
    assert "disk is full" in err and str(out / "stream") in err and "2 complete chunk(s)" in err, err
    assert read_stream(out / "stream").steps == 10
    monkeypatch.setattr(streaming, "_fsync_write", streaming.write_atomic)
    assert cli.main(["run", str(tmp_path / "s.toml"), "-o", str(out), "--resume"]) == 0, capsys.readouterr().err
    clean = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.01, 1.0, 0.01], h=0.01, steps=20)
    got = lgvi.load(out / "trajectory.npz")
    assert np.array_equal(got.R, clean.R) and np.array_equal(got.Pi, clean.Pi)


# ------------------------------------------------------------------------------------------------
# Two writers
# ------------------------------------------------------------------------------------------------

def test_second_writer_in_the_same_process_is_refused(tmp_path):
    folder = tmp_path / "run"
    first = StreamWriter(folder, {"h": 0.1})
    with pytest.raises(FolderLocked, match="being written by another writer in this process") as info:
        StreamWriter(folder, {"h": 0.1}, resume=True)
    assert str(folder) in str(info.value) and info.value.pid == os.getpid()
    assert isinstance(info.value, BlockingIOError)
    first.close()
    assert not (folder / ".lgvi.lock").exists()
    StreamWriter(folder, {"h": 0.1}, resume=True).close()  # free again


def test_second_run_on_a_folder_being_written_is_refused_and_the_first_is_intact(tmp_path):
    folder = tmp_path / "run"
    clean = lgvi.simulate(BODY, np.eye(3), **RUN)
    refused = []

    def intruder(done: int, total: int) -> None:
        if done == 200:  # the first run is between chunks: a second run on its folder
            with pytest.raises(FolderLocked) as info:
                lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=50, resume=True, **RUN)
            refused.append(str(info.value))

    lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, progress=intruder, **RUN)
    assert len(refused) == 1 and str(folder) in refused[0]
    assert [c["steps"] for c in read_manifest(folder)["chunks"]] == [100] * 6
    assert same(read_stream(folder), clean)


WRITER = """
import sys, time
import numpy as np
import lgvi
from lgvi.torques import UniformGravity
RUN = dict(omega0=[4.14, 4.14, 4.14], h=0.01, steps=600, save_every=10, torque=UniformGravity(1.0, [0.0, 0.0, 0.3]))
body = lgvi.RigidBody([0.13, 0.28, 0.17])
try:
    lgvi.simulate_stream(sys.argv[1], body, np.eye(3), chunk_steps=100, resume=True,
                         progress=lambda d, n: time.sleep(float(sys.argv[2])), **RUN)
except BlockingIOError as exc:
    print("REFUSED", exc)
    sys.exit(3)
print("DONE")
"""


def _writer(folder: Path, pause: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", WRITER, str(folder), str(pause)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def test_second_writer_in_another_process_is_refused(tmp_path):
    folder = tmp_path / "run"
    lock = StreamWriter(folder, {"h": 0.1})  # this process writes the folder...
    proc = _writer(folder, 0.0)              # ...another process tries to
    out, err = proc.communicate()
    assert proc.returncode == 3, out + err
    assert "REFUSED" in out and str(folder) in out and f"process {os.getpid()}" in out, out
    lock.close()
    assert read_manifest(folder)["chunks"] == []  # the refused writer wrote nothing


def test_writer_process_holds_the_folder_and_a_killed_writer_is_taken_over(tmp_path):
    folder = tmp_path / "run"
    clean = lgvi.simulate(BODY, np.eye(3), **RUN)
    proc = _writer(folder, 1e6)   # a chunk, then asleep between chunks until killed, holding the lock (no race:
                                  # however slow the machine, it writes no second chunk while the test looks)
    try:
        while not (folder / streaming.MANIFEST).exists() or not read_manifest(folder)["chunks"]:
            assert proc.poll() is None, proc.communicate()   # waits as long as the writer lives
            time.sleep(0.05)
        with pytest.raises(FolderLocked, match=f"process {proc.pid}") as info:
            lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, resume=True, **RUN)
        assert str(folder) in str(info.value) and "interleave" in str(info.value)
        assert len(read_manifest(folder)["chunks"]) == 1  # the refused run wrote nothing
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.communicate()
    assert (folder / ".lgvi.lock").exists()  # left behind by the killed writer: stale
    with pytest.warns(StaleLockWarning, match=f"locked by process {proc.pid}"):
        lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, resume=True, **RUN)
    done = read_stream(folder)
    assert done.meta["complete"] and same(done, clean)
    assert not (folder / ".lgvi.lock").exists()


def test_lock_refuses_a_planted_symbolic_link(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    (folder / ".lgvi.lock").symlink_to(victim)
    with pytest.raises(OSError, match="cannot lock the stream folder"):
        StreamWriter(folder, {"h": 0.1})
    assert victim.read_text() == "precious\n"


def test_lock_released_when_a_resume_is_refused(tmp_path):
    folder = tmp_path / "run"
    lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, **dict(RUN, steps=200))
    with pytest.raises(ValueError, match="resume"):
        lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=100, resume=True, **dict(RUN, h=0.02, steps=200))
    assert not (folder / ".lgvi.lock").exists()
    with FolderLock(folder):
        pass


# ------------------------------------------------------------------------------------------------
# A Dask worker killed in the middle of an ensemble
# ------------------------------------------------------------------------------------------------

def _arm_killer(marker: str, mode: str) -> None:
    """Run on each worker: the first block task anywhere (the marker file is created with O_EXCL)
    kills its worker process, after computing its block ("memory") or half-way through writing
    its block file ("out_dir")."""
    import io as _io
    import os as _os

    import lgvi.ensemble as e

    def first() -> bool:
        try:
            _os.close(_os.open(marker, _os.O_CREAT | _os.O_EXCL | _os.O_WRONLY))
            return True
        except FileExistsError:
            return False

    if mode == "memory":
        real_run = e._run_local

        def run_local(*args, **kwargs):
            out = real_run(*args, **kwargs)
            if first():
                _os._exit(17)
            return out

        e._run_local = run_local
    else:
        real_write = e.write_atomic

        def write_atomic(path, write):
            if not first():
                return real_write(path, write)

            def half_then_die(fh):
                buf = _io.BytesIO()
                write(buf)
                fh.write(buf.getvalue()[: len(buf.getvalue()) // 2])
                fh.flush()
                _os._exit(17)

            return real_write(path, half_then_die)

        e.write_atomic = write_atomic


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_DASK, reason="dask[distributed] not installed (pip install 'lgvi[dask]')")
def test_dask_worker_killed_mid_ensemble_gives_the_serial_result(tmp_path):
    from dask.distributed import Client, LocalCluster

    try:  # the workers import this module's _arm_killer by value, wherever the tests run from
        import cloudpickle

        cloudpickle.register_pickle_by_value(sys.modules[__name__])
    except (ImportError, AttributeError, ValueError):  # pragma: no cover
        pass
    rng = np.random.default_rng(11)
    R0 = so3.exp(0.5 * rng.normal(size=(24, 3)))
    Pi0 = np.array([0.6, -0.9, 1.2]) + 0.3 * rng.normal(size=(24, 3))
    opts = dict(h=0.01, steps=200, save_every=10, torque=UniformGravity(1.0, [0.0, 0.05, 0.3]), order=4)
    serial = lgvi.simulate_ensemble(BODY, R0, Pi0, threads=1, **opts)
    pool = concurrent.futures.ThreadPoolExecutor(1)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.wait_for_workers(2)
        pids = set(client.run(os.getpid).values())
        got = {}
        for mode in ("memory", "out_dir"):
            marker = tmp_path / f"killed-{mode}"
            client.run(_arm_killer, str(marker), mode)
            kw = dict(out_dir=tmp_path / "blocks") if mode == "out_dir" else {}
            job = pool.submit(lgvi.simulate_ensemble, BODY, R0, Pi0, client=client, block_size=3, **kw, **opts)
            got[mode] = job.result()
            assert marker.exists()  # a worker was killed...
            client.wait_for_workers(2)
            now = set(client.run(os.getpid).values())
            assert len(pids - now) == 1, (pids, now)  # ...exactly one, and its nanny restarted it
            pids = now
    pool.shutdown()
    on_disk = lgvi.load_ensemble(tmp_path / "blocks")
    assert [p.name for p in got["out_dir"]] == [f"ensemble-{i:05d}.npz" for i in range(8)]
    # the dead worker's half-written block is a hidden temporary file, never a block
    assert all(p.name.startswith(".") for p in (tmp_path / "blocks").iterdir() if not p.name.startswith("ens"))
    for result in (got["memory"], on_disk):
        assert len(result) == 24
        for name in ("t", "R", "Pi", "iterations", "residual", "potential"):
            np.testing.assert_array_equal(getattr(result, name), getattr(serial, name), err_msg=name)
