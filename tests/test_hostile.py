"""Hostile files (issue 18): nothing a file says may make lgvi write or read outside where the
user pointed, run code, or allocate what the file merely declares.

Each test builds a small tree ``root/work`` (the current folder, or the folder the user names)
beside ``root/elsewhere`` (a sibling holding a file an attacker would like to overwrite or read),
snapshots the whole tree, does what a user would do with the hostile file, and checks that the
file is refused with a clear error (or contained) and that nothing changed outside the folder the
user named.

=====================================  ===========================================================
attack                                 expected
=====================================  ===========================================================
scenario ``name`` with ``../``,        ``lgvi run`` exits 2 naming the file, ``name`` and the
absolute path, ``\\``, ``:``, control   rule; nothing written anywhere; ``_default_outdir`` slugs
characters, ``..``, 1000 characters    any name into the current folder anyway
scenario ``steps = 10**15``            exits 2 before anything is written (the library's memory
                                       check: the result would not fit)
deeply nested TOML                     exits 2 with "nested too deeply", no traceback
output folder with a link to outside   exits 2; the target is untouched
.npz with an object (pickle) array     refused by every reader; the pickle never runs
.npz declaring a huge array            refused from its header, before allocating
.npz with a decompression bomb size    refused from the zip directory
paths in .npz metadata / CSV sidecar   never used as paths: ``info`` writes nothing, ``plot``
                                       writes only in ``-o``
manifest naming ``../x.npz`` or an     refused ("must name a file in the stream folder")
absolute path
chunk or manifest symlinked outside    refused ("symbolic link ... not followed")
a FIFO as a chunk, manifest or block   refused ("not a regular file"), never waited on
planted ``*.tmp`` symlink on resume    replaced, never followed; the resumed run is exact
resume state ``k`` out of range /      refused ("resume state")
enormous chunk counts
ensemble block symlinked outside       refused
=====================================  ===========================================================
"""

from __future__ import annotations

import ast
import contextlib
import io
import json
import os
import shutil
import threading
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi import cli
from lgvi.io import streaming
from lgvi.ensemble import load_ensemble
from lgvi.io.outputs import read_csv, write_csv
from lgvi.io.scenario import ScenarioError, load_scenario

SRC = Path(lgvi.__file__).resolve().parent

SCENARIO = """\
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


# ------------------------------------------------------------------------------------ helpers
def snapshot(root: Path) -> dict[str, object]:
    """Every entry under ``root`` (links not followed): a link's target, a file's bytes, a folder."""
    snap: dict[str, object] = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            key = str(p.relative_to(root))
            if p.is_symlink():
                snap[key] = ("link", os.readlink(p))
            elif p.is_dir():
                snap[key] = ("dir",)
            else:
                snap[key] = ("file", p.read_bytes())
    return snap


def changed(before: dict, after: dict) -> set[str]:
    return {k for k in before.keys() | after.keys() if before.get(k) != after.get(k)}


@pytest.fixture
def tree(tmp_path, monkeypatch):
    """``root/work`` (the current folder) and ``root/elsewhere/victim.txt``."""
    root = tmp_path / "root"
    work = root / "work"
    work.mkdir(parents=True)
    (root / "elsewhere").mkdir()
    (root / "elsewhere" / "victim.txt").write_text("precious\n")
    monkeypatch.chdir(work)
    return root


def run_cli(capsys, *argv) -> tuple[int, str]:
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out + err


def with_name(name: str) -> str:
    return SCENARIO.replace('name = "spin"', "name = " + json.dumps(name))


@pytest.fixture(scope="module")
def traj():
    return lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=20)


def npz_with(path: Path, members: dict[str, bytes], compress: int = zipfile.ZIP_STORED) -> Path:
    with zipfile.ZipFile(path, "w", compression=compress) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return path


def npy_bytes(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, arr, allow_pickle=True)
    return buf.getvalue()


def valid_members(traj, tmp: Path) -> dict[str, bytes]:
    traj.save(tmp / "valid.npz")
    with zipfile.ZipFile(tmp / "valid.npz") as zf:
        return {n: zf.read(n) for n in zf.namelist()}


# ------------------------------------------------------------------------------------ scenario names
HOSTILE_NAMES = {
    "parent": "../../elsewhere/evil",
    "absolute": None,  # filled in with the absolute path of root/elsewhere/evil
    "backslash": "..\\..\\elsewhere\\evil",
    "drive": "C:evil",
    "dotdot": "..",
    "dot": ".",
    "escape-sequence": "\x1b[2Jevil",
    "newline": "evil\nname",
    "nul": "evil\x00name",
    "long": "x" * 1000,
    "empty": "",
}


@pytest.mark.parametrize("case", list(HOSTILE_NAMES))
def test_run_refuses_a_hostile_scenario_name(tree, capsys, case):
    name = HOSTILE_NAMES[case] or str(tree / "elsewhere" / "evil")
    (tree / "work" / "evil.toml").write_text(with_name(name))
    before = snapshot(tree)
    code, out = run_cli(capsys, "run", "evil.toml")
    assert code == 2, out
    assert "evil.toml: name: expected a name of 1 to 100 characters" in out, out
    assert "Traceback" not in out
    assert changed(before, snapshot(tree)) == set()


@pytest.mark.parametrize("case", list(HOSTILE_NAMES))
def test_default_outdir_stays_in_the_current_folder(tree, case):
    """Defence in depth: a Scenario built in Python (not checked at load) still lands in ./."""
    name = HOSTILE_NAMES[case] or str(tree / "elsewhere" / "evil")
    sc = replace(load_scenario(_write(tree / "work" / "s.toml", SCENARIO)), name=name)
    out = cli._default_outdir(sc)
    assert out.parent == Path.cwd()
    assert out.name.endswith("_output") and len(out.name) <= 64 + len("_output")
    assert out.name.isascii() and out.name.isprintable() and not out.name.startswith(".")
    assert not any(c in out.name for c in "/\\:")


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_safe_names_are_kept_and_others_contained(tree, capsys):
    """A name with a space is accepted; its results go to ./my_run_output and nowhere else."""
    (tree / "work" / "s.toml").write_text(with_name("my run"))
    before = snapshot(tree)
    code, out = run_cli(capsys, "run", "s.toml", "--no-plots")
    assert code == 0, out
    diff = changed(before, snapshot(tree))
    assert diff and all(k == "work/my_run_output" or k.startswith("work/my_run_output/") for k in diff), diff
    assert lgvi.load(tree / "work" / "my_run_output" / "trajectory.npz").meta["scenario_name"] == "my run"


def test_scenario_name_error_names_file_key_and_rule(tmp_path):
    p = _write(tmp_path / "evil.toml", with_name("../x"))
    with pytest.raises(ScenarioError, match=r"evil\.toml: name: .*path separators.*got '\.\./x'") as info:
        load_scenario(p)
    assert info.value.key == "name"


# ------------------------------------------------------------------------------------ sizes, nesting
def test_run_refuses_a_huge_declared_step_count(tree, capsys):
    (tree / "work" / "huge.toml").write_text(SCENARIO.replace("steps = 20", "steps = 1_000_000_000_000_000"))
    before = snapshot(tree)
    code, out = run_cli(capsys, "run", "huge.toml")
    assert code == 2, out
    assert "steps=1000000000000000 with save_every=1 needs" in out and "GiB" in out, out
    assert changed(before, snapshot(tree)) == set()


@pytest.mark.parametrize("text", ["a = " + "[" * 100_000 + "]" * 100_000,
                                  "a = " + "{b = " * 50_000 + "1" + "}" * 50_000])
def test_run_refuses_deeply_nested_toml(tree, capsys, text):
    (tree / "work" / "deep.toml").write_text(text)
    before = snapshot(tree)
    code, out = run_cli(capsys, "run", "deep.toml")
    assert code == 2 and "nested too deeply" in out and "Traceback" not in out, out
    assert changed(before, snapshot(tree)) == set()


# ------------------------------------------------------------------------------------ output folder links
@pytest.mark.parametrize("link", ["summary.json", "trajectory.npz", "stream"])
def test_run_refuses_an_output_folder_with_links_out(tree, capsys, link):
    out_dir = tree / "work" / "out"
    out_dir.mkdir()
    target = tree / "elsewhere" / ("victim.txt" if link != "stream" else "")
    (out_dir / link).symlink_to(target)
    (tree / "work" / "s.toml").write_text(SCENARIO)
    before = snapshot(tree)
    code, out = run_cli(capsys, "run", "s.toml", "-o", out_dir)
    assert code == 2, out
    assert "is a symbolic link to" in out and "outside the output folder" in out, out
    assert changed(before, snapshot(tree)) == set()


# ------------------------------------------------------------------------------------ .npz files
class _Trap:
    """Unpickling this creates a marker file: proof that a reader ran code from the file."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _pickle_trap_npz(path: Path, traj, marker: Path) -> Path:
    members = valid_members(traj, path.parent)
    evil = np.empty(1, dtype=object)
    evil[0] = _Trap(str(marker))
    members["t.npy"] = npy_bytes(evil)
    return npz_with(path, members)


def test_no_reader_unpickles_an_object_array(tree, traj):
    marker = tree / "elsewhere" / "pwned"
    bad = _pickle_trap_npz(tree / "work" / "t.npz", traj, marker)
    live = tree / "work" / "live"  # the trap is live: numpy with allow_pickle=True runs it
    np.load(_pickle_trap_npz(tree / "work" / "live.npz", traj, live), allow_pickle=True)["t"]
    assert live.exists()
    with pytest.raises(ValueError, match=r"t\.npz.*member 't\.npy' holds an object array.*never unpickles"):
        lgvi.load(bad)
    # the same member as a stream chunk and as an ensemble block
    folder = tree / "work" / "run"
    lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=20)
    with zipfile.ZipFile(folder / "chunk-000000.npz") as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    members["t.npy"] = npy_bytes(np.array([_Trap(str(marker))], dtype=object))
    npz_with(folder / "chunk-000000.npz", members)
    with pytest.raises(ValueError, match=r"chunk-000000\.npz.*holds an object array"):
        streaming.read_stream(folder)
    with pytest.raises(ValueError, match=r"t\.npz.*holds an object array"):
        load_ensemble(bad)
    assert not marker.exists()


def _huge_header(shape: tuple[int, ...]) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return buf.getvalue() + np.zeros(3).tobytes()


@pytest.mark.parametrize("shape", [(10**15,), (10**6, 10**6, 3)])
def test_huge_declared_arrays_are_refused_before_allocating(tree, traj, shape):
    members = valid_members(traj, tree / "elsewhere")
    members["R.npy"] = _huge_header(shape)
    bad = npz_with(tree / "work" / "huge.npz", members)
    with pytest.raises(ValueError, match=r"huge\.npz.*member 'R\.npy' declares an array of shape .* but holds 24 "
                                         r"bytes"):
        lgvi.load(bad)
    with pytest.raises(ValueError, match=r"huge\.npz.*declares an array"):
        load_ensemble(bad)


def test_a_declared_size_beyond_compression_is_refused(tree, traj):
    members = valid_members(traj, tree / "elsewhere")
    bad = npz_with(tree / "work" / "bomb.npz", members, zipfile.ZIP_DEFLATED)
    raw = bytearray(bad.read_bytes())
    with zipfile.ZipFile(bad) as zf:
        info = zf.getinfo("R.npy")
    # patch the uncompressed size of R.npy in its central directory entry to 2**32 - 1
    pos = raw.find(b"R.npy", raw.find(b"PK\x01\x02"))
    entry = raw.rfind(b"PK\x01\x02", 0, pos)
    assert raw[entry + 24:entry + 28] == info.file_size.to_bytes(4, "little")
    raw[entry + 24:entry + 28] = (2**32 - 1).to_bytes(4, "little")
    bad.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"bomb\.npz.*'R\.npy' declares 4294967295 bytes.*more than compression"):
        lgvi.load(bad)


def test_paths_in_metadata_are_never_used_as_paths(tree, traj, capsys):
    """``info`` and ``plot`` of a trajectory whose metadata and sidecar are full of paths."""
    evil = str(tree / "elsewhere" / "victim.txt")
    meta = dict(traj.meta, scenario_name="../../elsewhere/victim.txt", scenario_source=evil, prefix=evil,
                scenario='name = "../../elsewhere/x"\n', file=evil, out=evil)
    t = replace(traj, meta=meta)
    t.save(tree / "work" / "t.npz")
    write_csv(t, tree / "work" / "t.csv")
    side = json.loads((tree / "work" / "t.meta.json").read_text())
    side["csv"] = evil
    (tree / "work" / "t.meta.json").write_text(json.dumps(side))
    before = snapshot(tree)
    for f in ("t.npz", "t.csv"):
        code, out = run_cli(capsys, "info", f)
        assert code == 0, out
    assert read_csv(tree / "work" / "t.csv").meta["scenario_name"] == "../../elsewhere/victim.txt"
    assert changed(before, snapshot(tree)) == set()
    try:
        import lgvi.plot  # noqa: F401
    except ImportError:
        return
    code, out = run_cli(capsys, "plot", "t.npz", "-o", "figs")
    assert code == 0, out
    diff = changed(before, snapshot(tree))
    assert diff and all(k == "work/figs" or k.startswith("work/figs/") for k in diff), diff


# ------------------------------------------------------------------------------------ stream folders
STREAM = dict(h=0.01, steps=40, save_every=2)


def _stream(folder: Path, steps: int = 40) -> Path:
    return lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], chunk_steps=20,
                                **dict(STREAM, steps=steps))


@pytest.mark.parametrize("entry", ["../outside.npz", "ABSOLUTE", "sub/../../outside.npz", "", ".hidden.npz"])
def test_manifest_naming_files_outside_the_folder_is_refused(tree, entry):
    folder = _stream(tree / "work" / "run")
    outside = tree / "work" / "outside.npz"
    shutil.copy(folder / "chunk-000001.npz", outside)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["chunks"][1]["file"] = str(outside) if entry == "ABSOLUTE" else entry
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match=r"chunk 1 must name a file in the stream folder"):
        streaming.read_stream(folder)


def test_chunk_symlinked_outside_the_folder_is_refused(tree):
    folder = _stream(tree / "work" / "run")
    outside = tree / "elsewhere" / "chunk.npz"
    shutil.move(folder / "chunk-000001.npz", outside)
    (folder / "chunk-000001.npz").symlink_to(outside)
    with pytest.raises(ValueError, match=r"chunk 1 \(chunk-000001\.npz\) is a symbolic link to .*elsewhere.*not "
                                         r"followed"):
        streaming.read_stream(folder)
    # a link to another file inside the folder is harmless and still read
    (folder / "chunk-000001.npz").unlink()
    shutil.move(outside, folder / "real.npz")
    (folder / "chunk-000001.npz").symlink_to("real.npz")
    assert len(streaming.read_stream(folder).t) == 21


def test_manifest_symlinked_outside_the_folder_is_refused(tree):
    folder = _stream(tree / "work" / "run")
    shutil.move(folder / "manifest.json", tree / "elsewhere" / "manifest.json")
    (folder / "manifest.json").symlink_to(tree / "elsewhere" / "manifest.json")
    with pytest.raises(ValueError, match=r"manifest\.json is a symbolic link to .*outside the stream folder"):
        streaming.read_stream(folder)


@contextlib.contextmanager
def fifo(path: Path):
    """A named pipe at ``path`` with a writer that closes at once: a reader that opens it gets an
    empty file instead of waiting forever, so a regression fails the test instead of hanging it."""
    os.mkfifo(path)
    writer = threading.Thread(target=lambda: os.close(os.open(path, os.O_WRONLY)), daemon=True)
    writer.start()
    try:
        yield path
    finally:
        if writer.is_alive():  # nobody opened it (the fix): let the writer's open return
            fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
            writer.join()
            os.close(fd)
        writer.join()


@pytest.mark.parametrize("which", ["chunk-000001.npz", "manifest.json"])
def test_a_fifo_in_a_stream_folder_is_refused_not_waited_on(tree, which):
    folder = _stream(tree / "work" / "run")
    (folder / which).unlink()
    with fifo(folder / which), pytest.raises(ValueError, match=r"is not a regular file"):
        streaming.read_stream(folder)


def test_a_fifo_in_an_ensemble_folder_is_refused_not_waited_on(tree):
    folder = tree / "work" / "ens"
    folder.mkdir()
    with fifo(folder / "ensemble-00000.npz"), pytest.raises(ValueError, match=r"ensemble-00000\.npz is not a "
                                                                              r"regular file"):
        load_ensemble(folder)


def _interrupted(tree: Path) -> tuple[Path, lgvi.Trajectory]:
    """A stream of 40 steps cut after its first chunk (20 steps), and the uninterrupted result."""
    folder = _stream(tree / "work" / "run")
    ref = streaming.read_stream(folder)
    half = _stream(tree / "work" / "half", steps=20)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["chunks"] = manifest["chunks"][:1]
    manifest["state"] = json.loads((half / "manifest.json").read_text())["state"]
    manifest["complete"] = False
    (folder / "manifest.json").write_text(json.dumps(manifest))
    (folder / "chunk-000001.npz").unlink()
    shutil.rmtree(half)
    return folder, ref


def test_resume_never_follows_planted_temporary_links(tree):
    folder, ref = _interrupted(tree)
    victim = tree / "elsewhere" / "victim.txt"
    for name in ("chunk-000001.npz.tmp", "manifest.json.tmp"):
        (folder / name).symlink_to(victim)
    before = snapshot(tree)
    lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], chunk_steps=20, resume=True,
                         **STREAM)
    assert victim.read_text() == "precious\n"
    diff = changed(before, snapshot(tree))
    assert all(k.startswith("work/run/") for k in diff), diff
    got = streaming.read_stream(folder)
    assert np.array_equal(got.R, ref.R) and np.array_equal(got.Pi, ref.Pi)


@pytest.mark.parametrize("hack", ["k=-5", "k=10**15", "k=mismatch", "k=string", "steps=10**15", "M_cb"])
def test_resume_refuses_a_hostile_state(tree, hack):
    folder, _ = _interrupted(tree)
    manifest = json.loads((folder / "manifest.json").read_text())
    st = manifest["state"]
    if hack == "k=-5":
        st["k"] = -5
    elif hack == "k=10**15":
        st["k"] = 10**15
    elif hack == "k=mismatch":
        st["k"] = 40
    elif hack == "k=string":
        st["k"] = "20"
    elif hack == "steps=10**15":
        manifest["chunks"][0]["steps"] = 10**15
    else:
        st["M_cb"] = [1.0]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    before = snapshot(tree)
    with pytest.raises(ValueError, match=r"manifest\.json is damaged: .*(resume state|M_cb)"):
        lgvi.simulate_stream(folder, [1.0, 2.0, 3.0], np.eye(3), omega0=[0.1, 1.0, 0.2], chunk_steps=20,
                             resume=True, **STREAM)
    assert changed(before, snapshot(tree)) == set()


# ------------------------------------------------------------------------------------ ensemble folders
def test_ensemble_block_symlinked_outside_is_refused(tree, traj):
    folder = tree / "work" / "ens"
    folder.mkdir()
    (folder / "ensemble-00000.npz").symlink_to(tree / "elsewhere" / "victim.txt")
    with pytest.raises(ValueError, match=r"ensemble-00000\.npz is a symbolic link to .*outside the folder"):
        load_ensemble(folder)


# ------------------------------------------------------------------------------------ the source itself
def _calls(tree_: ast.AST):
    for node in ast.walk(tree_):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
            yield name, node


def _constant_tables(tree_: ast.Module) -> set[str]:
    """Names bound at module level to a dict literal of constants only (``MOVED = {"a": "b"}``)."""
    out = set()
    for node in tree_.body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        if isinstance(node.value if targets else None, ast.Dict) and all(
                isinstance(x, ast.Constant) for x in node.value.keys + node.value.values):
            out.update(t.id for t in targets if isinstance(t, ast.Name))
    return out


@pytest.mark.parametrize("path", sorted(SRC.rglob("*.py")), ids=lambda p: str(p.relative_to(SRC)))
def test_source_never_executes_or_unpickles_file_content(path):
    """No eval/exec/pickle/marshal/yaml; every ``np.load`` passes ``allow_pickle=False``; dynamic
    imports only of constant module names; TOML through tomllib, JSON through json."""
    mod = ast.parse(path.read_text(), str(path))
    for node in ast.walk(mod):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            names = [a.name for a in node.names] + ([node.module] if isinstance(node, ast.ImportFrom) else [])
            for n in names:
                assert (n or "").split(".")[0] not in ("pickle", "cPickle", "dill", "cloudpickle", "marshal", "shelve",
                                                       "yaml", "joblib"), f"{path}: imports {n}"
    for name, call in _calls(mod):
        # the builtins (a bare name or builtins.X); `re.compile(pattern)` compiles a regular expression, not code
        owner = getattr(call.func.value, "id", "") if isinstance(call.func, ast.Attribute) else "builtins"
        assert not (name in ("eval", "exec", "compile", "__import__") and owner == "builtins"), \
            f"{path}:{call.lineno}: {name}()"
        if name == "load" and isinstance(call.func, ast.Attribute) and getattr(call.func.value, "id", "") == "np":
            kw = {k.arg: k.value for k in call.keywords}
            assert isinstance(kw.get("allow_pickle"), ast.Constant) and kw["allow_pickle"].value is False, \
                f"{path}:{call.lineno}: np.load without allow_pickle=False"
        if name == "import_module":  # a constant, or a value of a module-level dict of constants
            assert all(isinstance(a, ast.Constant) or (isinstance(a, ast.Subscript) and getattr(a.value, "id", "")
                                                       in _constant_tables(mod)) for a in call.args), \
                f"{path}:{call.lineno}: import_module of a computed name"
