"""Nothing silent, nothing lost (issue 29, files and helpers): outputs never delete or write
through what the user did not create, and every reader checks what a file declares against what
it holds and against limits.

Each test builds ``root/work`` (the current folder) beside ``root/elsewhere/victim.txt`` (a file
an attacker would like to overwrite), does what a user would do, and checks the outcome: the
user's files kept, links refused, the damaged or hostile file refused with an error naming it.

=============================================  ==================================================
situation                                      expected
=============================================  ==================================================
``lgvi run -o .`` with the user's ``stream/``  the user's files in ``stream/`` kept (only the
                                               stream's own files removed)
default output folder ``NAME_output`` a link   exit 2 naming the link; the target untouched
``lgvi plot`` with ``attitude.png -> victim``  refused naming the link; the victim untouched
a link at any path lgvi writes                 refused (``write_atomic``, ``write_html``, ``save``)
a temporary name planted in advance            never used: names are random (128 bits)
a full disk while writing                      ``OSError`` naming the file and the folder
manifest listing a chunk twice or reordered    refused ("chunk 1 must be the file ...")
resume state not the last chunk's end          refused ("not the last sample"); a stored
                                               attitude that is not a rotation refused
npz member ``R`` without ``.npy``              refused by every reader (``lgvi info`` exit 2)
netCDF declaring 2e8 samples in a small file   refused before reading
deeply nested JSON (manifest, npz header)      ValueError "nested too deeply", no RecursionError
a stream larger than the free disk space       ``OSError`` naming the folder before any write
bidirectional override in a scenario name      refused, naming the character
=============================================  ==================================================
"""

from __future__ import annotations

import errno
import io
import json
import os
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi import _files, cli
from lgvi.io import streaming

from test_hostile import SCENARIO, STREAM, _interrupted, _stream, run_cli, tree  # noqa: F401  (tests/ on the path)


def _manifest(folder: Path) -> dict:
    return json.loads((folder / "manifest.json").read_text())


def _set_manifest(folder: Path, manifest: dict) -> None:
    (folder / "manifest.json").write_text(json.dumps(manifest))


# ------------------------------------------------------------------------------------ 1. nothing lost
def test_run_keeps_the_users_files_in_the_stream_folder(tree, capsys):
    work = tree / "work"
    (work / "spin.toml").write_text(SCENARIO)
    (work / "stream").mkdir()
    (work / "stream" / "notes.txt").write_text("mine\n")
    code, out = run_cli(capsys, "run", "spin.toml", "-o", ".")
    assert code == 0, out
    assert (work / "stream" / "notes.txt").read_text() == "mine\n"
    assert sorted(p.name for p in (work / "stream").iterdir()) == ["notes.txt"]   # the stream's own files gone
    assert "notes.txt" in out                                                    # and the user told why it stays


def test_run_removes_the_stream_folder_it_made(tree, capsys):
    (tree / "work" / "spin.toml").write_text(SCENARIO)
    code, out = run_cli(capsys, "run", "spin.toml", "-o", "out")
    assert code == 0, out
    assert not (tree / "work" / "out" / "stream").exists()
    assert (tree / "work" / "out" / "trajectory.npz").is_file()


def test_remove_stream_leaves_a_folder_that_is_not_a_stream(tree):
    folder = tree / "work" / "mine"
    folder.mkdir()
    (folder / "chunk-000000.npz").write_text("my own file with a chunk's name\n")
    assert streaming.remove_stream(folder) == ["chunk-000000.npz"]
    assert (folder / "chunk-000000.npz").read_text() == "my own file with a chunk's name\n"


def test_default_output_folder_that_is_a_link_is_refused(tree, capsys):
    work = tree / "work"
    (work / "spin.toml").write_text(SCENARIO)
    target = tree / "elsewhere" / "results"
    target.mkdir()
    (target / "stream").mkdir()
    (target / "stream" / "keep.txt").write_text("keep\n")
    (work / "spin_output").symlink_to(target)
    code, out = run_cli(capsys, "run", "spin.toml")
    assert code == 2, out
    assert "spin_output is a symbolic link" in out and "-o" in out
    assert sorted(p.name for p in target.rglob("*")) == ["keep.txt", "stream"]


def test_plot_never_writes_through_a_planted_link(tree, capsys):
    pytest.importorskip("matplotlib")
    work = tree / "work"
    lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=20).save(work / "run.npz")
    victim = tree / "elsewhere" / "victim.txt"
    (work / "attitude.png").symlink_to(Path("..") / "elsewhere" / "victim.txt")
    code, out = run_cli(capsys, "plot", "run.npz")
    assert code == 1, out
    assert "attitude.png" in out and "symbolic link" in out
    assert victim.read_text() == "precious\n"
    assert (work / "attitude.png").is_symlink()                  # the link is not replaced either


def test_every_writer_refuses_a_link(tree, capsys):
    victim = tree / "elsewhere" / "victim.txt"
    traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=5)
    link = tree / "work" / "link.out"
    link.symlink_to(victim)
    with pytest.raises(OSError, match=r"link\.out .*symbolic link"):
        _files.write_atomic(link, lambda fh: fh.write(b"x"))
    with pytest.raises(OSError, match=r"link\.out .*symbolic link"):
        _files.write_text(link, "x")
    with pytest.raises(OSError, match=r"link\.out .*symbolic link"):
        traj.save(link)
    from lgvi.io.outputs import write_csv

    with pytest.raises(OSError, match=r"link\.out .*symbolic link"):
        write_csv(traj, link)
    pytest.importorskip("plotly")
    from lgvi import view

    with pytest.raises(OSError, match=r"link\.out .*symbolic link"):
        view.write_html(traj, link, max_frames=5)
    assert victim.read_text() == "precious\n"


def test_temporary_names_are_unpredictable_and_planted_ones_unused(tree, monkeypatch):
    victim = tree / "elsewhere" / "victim.txt"
    target = tree / "work" / "page.html"
    # the old predictable names (.NAME.tmp<pid>, .NAME.<pid>-...) planted as links: never followed
    (tree / "work" / f".page.html.tmp{os.getpid()}").symlink_to(victim)
    names = []

    def write(fh):
        names.append(sorted(p.name for p in (tree / "work").iterdir() if p.name.endswith(".tmp.html")))
        fh.write(b"<html></html>")

    for _ in range(2):
        _files.write_atomic(target, write)
    assert victim.read_text() == "precious\n"
    assert target.read_bytes() == b"<html></html>"
    (a,), (b,) = names
    assert a != b and str(os.getpid()) not in a
    assert len(a) == len(".page.html.") + 32 + len(".tmp.html")          # 128 random bits
    assert not [p for p in (tree / "work").iterdir() if p.name.endswith(".tmp.html")]   # none left


def test_a_full_disk_names_the_file_being_written(tree, monkeypatch):
    traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=5)

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(_files.os, "fsync", full)
    out = tree / "work" / "out"
    out.mkdir()
    for write in (lambda: traj.save(out / "trajectory.npz"), lambda: _files.write_text(out / "summary.json", "{}")):
        with pytest.raises(OSError) as info:
            write()
        assert info.value.errno == errno.ENOSPC
        msg = str(info.value)
        assert "disk is full" in msg and str(out) in msg
        assert ("trajectory.npz" in msg) or ("summary.json" in msg)
    assert list(out.iterdir()) == []                                  # no temporary file left


def test_a_full_disk_in_lgvi_run_names_the_file(tree, capsys, monkeypatch):
    (tree / "work" / "spin.toml").write_text(SCENARIO)
    real = _files.write_atomic

    def full_for_results(path, write, **kw):
        if Path(path).name == "summary.json":     # the disk fills up at the last of the final outputs
            def write(fh, write=write):
                raise OSError(errno.ENOSPC, "No space left on device")
        return real(path, write, **kw)

    monkeypatch.setattr(_files, "write_atomic", full_for_results)
    code, out = run_cli(capsys, "run", "spin.toml", "-o", "out")
    assert code == 1
    assert "summary.json" in out and "disk is full" in out and "out" in out


# ------------------------------------------------------------------------------------ 2. streams
@pytest.mark.parametrize("how", ["repeated", "reordered", "listed-1000-times"])
def test_a_manifest_listing_chunks_twice_or_out_of_order_is_refused(tree, how):
    folder = _stream(tree / "work" / "run")
    manifest = _manifest(folder)
    first, second = manifest["chunks"][0], manifest["chunks"][1]
    manifest["chunks"] = {"repeated": [first, first, second], "reordered": [second, first],
                          "listed-1000-times": [first] + [second] * 1000}[how]
    _set_manifest(folder, manifest)
    with pytest.raises(ValueError, match=r"chunk \d must be the file chunk-\d{6}\.npz .*once each, in the order"):
        streaming.read_stream(folder)


def test_times_that_run_back_are_refused(tree):
    folder = _stream(tree / "work" / "run")
    with np.load(folder / "chunk-000001.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["t"] = arrays["t"] - 1.0                       # chunk 1's times before chunk 0's end
    np.savez(folder / "chunk-000001.npz", **arrays)
    with pytest.raises(ValueError, match=r"times must be finite and run in one direction"):
        streaming.read_stream(folder)


def test_a_manifest_declaring_other_sample_counts_is_refused(tree):
    folder = _stream(tree / "work" / "run")
    manifest = _manifest(folder)
    manifest["chunks"][1]["samples"] = 10**9
    _set_manifest(folder, manifest)
    with pytest.raises(ValueError, match=r"chunk-000001\.npz.*lists 1000000000 samples, the file holds 10"):
        streaming.read_stream(folder)


def _resume(folder: Path):
    return lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], chunk_steps=20,
                                resume=True, **STREAM)


@pytest.mark.parametrize("hack", ["R=2I", "Pi*10", "Pi-missing"])
def test_resume_state_is_checked_against_the_last_chunk(tree, hack):
    folder, _ = _interrupted(tree)
    manifest = _manifest(folder)
    st = manifest["state"]
    if hack == "R=2I":
        st["R"] = (2.0 * np.eye(3)).tolist()
    elif hack == "Pi*10":
        st["Pi"] = (10.0 * np.array(st["Pi"])).tolist()
    else:
        del st["Pi"]
    _set_manifest(folder, manifest)
    with pytest.raises(ValueError, match=r"manifest\.json is damaged: the resume state.*(not the last sample of "
                                         r"chunk-000000\.npz|has no 'Pi')"):
        _resume(folder)
    assert _manifest(folder)["state"] == st                      # nothing written


def test_resume_refuses_an_attitude_that_is_not_a_rotation_in_state_and_chunk(tree):
    folder, _ = _interrupted(tree)
    with np.load(folder / "chunk-000000.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["R"][-1] = 2.0 * np.eye(3)
    np.savez(folder / "chunk-000000.npz", **arrays)
    manifest = _manifest(folder)
    manifest["state"]["R"] = (2.0 * np.eye(3)).tolist()
    _set_manifest(folder, manifest)
    with pytest.raises(ValueError, match=r"resume state.*is not a rotation \(\|R\^T R - I\| = 3"):
        _resume(folder)
    with pytest.raises(ValueError, match=r"attitude \(10,\) is not a rotation"):
        streaming.read_stream(folder)


def test_an_honest_resume_still_continues_bit_for_bit(tree):
    ref = streaming.read_stream(_stream(tree / "work" / "ref"))
    folder, _ = _interrupted(tree)
    got = streaming.read_stream(_resume(folder))
    assert np.array_equal(got.R, ref.R) and np.array_equal(got.Pi, ref.Pi) and np.array_equal(got.t, ref.t)


def test_resume_state_checked_for_another_system(tree):
    """The gyrostat's state (R, Pi and the wheels' momenta) against its last chunk."""
    kw = dict(h=0.05, save_every=2, chunk_steps=10, omega0=[0.01, 0.02, 0.03],
              wheels=lgvi.ReactionWheels(np.eye(3), 0.01, speed0=[10.0, -5.0, 3.0]))
    folder = lgvi.simulate_stream(tree / "work" / "gyro", [10.0, 12.0, 14.0], np.eye(3), steps=20, **kw)
    half = lgvi.simulate_stream(tree / "work" / "half", [10.0, 12.0, 14.0], np.eye(3), steps=10, **kw)
    manifest = _manifest(folder)
    manifest["chunks"], manifest["complete"] = manifest["chunks"][:1], False
    manifest["state"] = _manifest(half)["state"]
    (folder / "chunk-000001.npz").unlink()
    honest = json.loads(json.dumps(manifest))
    manifest["state"]["wheel_momentum"][0] *= 10.0
    _set_manifest(folder, manifest)
    with pytest.raises(ValueError, match=r"resume state's 'wheel_momentum' is not the last sample"):
        lgvi.simulate_stream(folder, [10.0, 12.0, 14.0], np.eye(3), steps=20, resume=True, **kw)
    _set_manifest(folder, honest)
    got = streaming.read_stream(lgvi.simulate_stream(folder, [10.0, 12.0, 14.0], np.eye(3), steps=20, resume=True,
                                                     **kw))
    ref = lgvi.simulate([10.0, 12.0, 14.0], np.eye(3), steps=20, **{k: v for k, v in kw.items() if k != "chunk_steps"})
    assert np.array_equal(got.R, ref.R) and np.array_equal(got.wheel_speed, ref.wheel_speed)


def _npy(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, arr)
    return buf.getvalue()


def _huge_header(shape: tuple[int, ...]) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return buf.getvalue()


def test_an_npz_member_without_the_npy_suffix_is_refused(tree, capsys):
    work = tree / "work"
    traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=5)
    traj.save(work / "valid.npz")
    with zipfile.ZipFile(work / "valid.npz") as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    members["R"] = _huge_header((10**10, 3, 3))            # numpy would read 'R' for data["R"], unchecked
    with zipfile.ZipFile(work / "bad.npz", "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    with pytest.raises(ValueError, match=r"member 'R' is not an array file NAME\.npy"):
        lgvi.load(work / "bad.npz")
    code, out = run_cli(capsys, "info", "bad.npz")
    assert code == 2 and "Traceback" not in out and "member 'R'" in out


def test_a_netcdf_file_declaring_more_than_it_holds_is_refused(tree):
    netCDF4 = pytest.importorskip("netCDF4")
    pytest.importorskip("xarray")
    from lgvi.io.outputs import read_netcdf

    path = tree / "work" / "bad.nc"
    with netCDF4.Dataset(path, "w") as ds:        # 2e8 samples declared, none written (compressed chunks)
        ds.createDimension("time", 200_000_000)
        ds.createDimension("i", 3)
        ds.createDimension("j", 3)
        ds.createVariable("R", "f8", ("time", "i", "j"), zlib=True, chunksizes=(1024, 3, 3))
        ds.setncattr("lgvi_format", "lgvi.netcdf/1")
    assert path.stat().st_size < 100_000
    with pytest.raises(ValueError, match=r"bad\.nc.*declare 14400000000 bytes .*time = 200000000.*refused before "
                                         r"reading"):
        read_netcdf(path)


@pytest.mark.parametrize("where", ["manifest", "npz-header"])
def test_deeply_nested_json_is_a_clear_error(tree, where):
    deep = "[" * 100_000 + "]" * 100_000
    if where == "manifest":
        folder = _stream(tree / "work" / "run")
        (folder / "manifest.json").write_text(deep)
        with pytest.raises(ValueError, match=r"manifest\.json: JSON nested too deeply"):
            streaming.read_stream(folder)
    else:
        path = tree / "work" / "deep.npz"
        np.savez(path, __lgvi__=np.array(deep), t=np.zeros(1))
        with pytest.raises(ValueError, match=r"deep\.npz: the '__lgvi__' header: JSON nested too deeply"):
            lgvi.load(path)


def test_a_stream_that_would_not_fit_on_the_disk_is_refused_before_writing(tree, monkeypatch, capsys):
    import shutil as _shutil

    usage = _shutil.disk_usage(tree)
    monkeypatch.setattr(_shutil, "disk_usage", lambda p: usage._replace(free=1000))
    folder = tree / "work" / "big"
    with pytest.raises(OSError, match=r"stream of 40 steps \(about 8\.\d+ kB: 41 saved states\) would not fit "
                                      r"in the folder .*big, whose disk has 1 kB free") as info:
        lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=40)
    assert info.value.errno == errno.ENOSPC
    assert not folder.exists()
    (tree / "work" / "spin.toml").write_text(SCENARIO.replace("steps = 20", "steps = 200000"))
    code, out = run_cli(capsys, "run", "spin.toml", "-o", "out")
    assert code == 1 and "would not fit in the folder" in out and "out" in out


def test_the_estimate_of_a_stream_is_an_upper_bound(tree):
    """The stream actually written is within the estimate the disk check uses (and not far below)."""
    from lgvi.integrator import Run

    folder = _stream(tree / "work" / "run", steps=400)
    written = sum(p.stat().st_size for p in folder.iterdir() if p.name.startswith("chunk-"))
    run = Run(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), None, omega0=[0.1, 1.0, 0.2], h=0.01, steps=400,
              save_every=2, torque=None, method="newton", tol=1e-14, max_iter=50, alpha=1.0, t0=0.0,
              forcing="paper", order=2, composition=None)
    run.chunk = 20
    estimate = streaming.estimated_bytes(run, 400)
    assert written <= estimate < 3 * written


@pytest.mark.parametrize("char", ["\u202e", "\u2066", "\u200b", "\u2028"],
                         ids=["RLO", "LRI", "zero-width-space", "line-separator"])
def test_bidirectional_and_invisible_characters_are_refused_in_scenario_names(tree, capsys, char):
    (tree / "work" / "s.toml").write_text(SCENARIO.replace('name = "spin"', f'name = "spin{char}txt.exe"'))
    code, out = run_cli(capsys, "run", "s.toml")
    assert code == 2
    assert repr(char)[1:-1] in out and "formatting characters" in out
    assert sorted(p.name for p in (tree / "work").iterdir()) == ["s.toml"]


def test_a_scenario_with_steps_beyond_the_loop_counter_is_refused(tree, capsys):
    """``steps = save_every = 10**20`` passes the memory check (one saved state) but not a 64-bit
    counter: refused with one line naming steps and the rule, not a Numba TypingError."""
    (tree / "work" / "big.toml").write_text(SCENARIO.replace("steps = 20", "steps = 100000000000000000000\n"
                                                             "save_every = 100000000000000000000"))
    code, out = run_cli(capsys, "run", "big.toml")
    assert code == 2
    assert "steps must be at most 2**62" in out and "Traceback" not in out and "Typing" not in out
    assert sorted(p.name for p in (tree / "work").iterdir()) == ["big.toml"]
