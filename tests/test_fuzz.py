"""Fuzzing the file readers for a bounded time (issue 6, part 6): only documented exceptions.

Readers and what each may raise (anything else, a hang or a crash is a bug):

==============================  =============================================================
reader                          documented exception (the message names the file)
==============================  =============================================================
``lgvi.load``                   ``ValueError``
``lgvi.outputs.read_csv``       ``ValueError``
``lgvi.outputs.read_netcdf``    ``ValueError`` (``ImportError`` only without xarray/netCDF4)
``lgvi.scenario.load_scenario`` ``lgvi.scenario.ScenarioError`` (a ``ValueError`` subclass)
``Scenario.from_dict``          ``ScenarioError``
``lgvi.streaming.read_stream``  ``ValueError``
==============================  =============================================================

Inputs: byte-level mutations (truncation, bit flips, overwritten runs, inserted bytes) of valid
files, random bytes, and structure-aware mutations (random JSON headers and sidecars, arrays of
random shapes and dtypes, scenario dicts with a leaf replaced, a key dropped or added). A file
that still reads must give a consistent :class:`lgvi.Trajectory` (or :class:`Scenario`).

Each test runs at most ``MAX_EXAMPLES`` examples with a per-example deadline, so the module stays
under ~30 s; ``LGVI_FUZZ_EXAMPLES`` raises the count for a longer session. The netCDF byte fuzzing
runs in a subprocess because the HDF5 C library parses the corrupt files (a crash there must fail
one test, not kill the run).
"""

from __future__ import annotations

import copy
import io
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import zipfile
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import lgvi
from lgvi.io import outputs, streaming
from lgvi.io.scenario import Scenario, ScenarioError, load_scenario

MAX_EXAMPLES = int(os.environ.get("LGVI_FUZZ_EXAMPLES", "60"))
pytestmark = pytest.mark.filterwarnings("ignore::UserWarning", "ignore::RuntimeWarning")
FUZZ = settings(max_examples=MAX_EXAMPLES, deadline=timedelta(seconds=2), database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

SCENARIO = textwrap.dedent("""\
    name = "fuzz"
    description = "a heavy top with every section"

    [body]
    inertia = [0.13, 0.28, 0.17]

    [initial]
    euler = { sequence = "ZYX", angles = [10.0, 5.0, 0.0], unit = "deg" }
    omega = [4.14, 4.14, 4.14]

    [integrator]
    h = 0.01
    duration = 0.2
    method = "newton"
    tol = 1e-14
    max_iter = 50
    save_every = 2

    [[torque]]
    type = "uniform_gravity"
    mass = 1.0
    com = [0.0, 0.0, 0.3]

    [[torque]]
    type = "pd"
    kp = [2.0, 2.0, 1.0]
    kd = 0.5
    target = { rotvec = [0.0, 0.0, 0.5] }

    [output]
    formats = ["npz", "csv"]
    plots = false
    """)


# --------------------------------------------------------------------------------------------
# shared valid inputs
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def traj() -> lgvi.Trajectory:
    return lgvi.simulate(lgvi.RigidBody([0.13, 0.28, 0.17]), np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01,
                         steps=12, torque=lgvi.torques.UniformGravity(1.0, [0.0, 0.0, 0.3]), save_every=2)


@pytest.fixture(scope="module")
def npz_bytes(traj, tmp_path_factory) -> bytes:
    p = tmp_path_factory.mktemp("npz") / "run.npz"
    traj.save(p)
    return p.read_bytes()


@pytest.fixture(scope="module")
def csv_files(traj, tmp_path_factory) -> tuple[str, str]:
    p = tmp_path_factory.mktemp("csv") / "run.csv"
    outputs.write_csv(traj, p)
    return p.read_text(), outputs.sidecar_path(p).read_text()


@pytest.fixture(scope="module")
def stream_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("stream") / "run"
    lgvi.simulate_stream(folder, lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01,
                         steps=24, save_every=2, chunk_steps=8)
    assert len(streaming.read_manifest(folder)["chunks"]) == 3
    return folder


# --------------------------------------------------------------------------------------------
# strategies
# --------------------------------------------------------------------------------------------
json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


@st.composite
def mutated(draw, data: bytes) -> bytes:
    """``data`` truncated, with bits flipped, a run overwritten, bytes inserted or deleted."""
    b = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["truncate", "flip", "overwrite", "insert", "delete"]))
        if not b:
            break
        i = draw(st.integers(0, len(b) - 1))
        if kind == "truncate":
            del b[i:]
        elif kind == "flip":
            b[i] ^= 1 << draw(st.integers(0, 7))
        elif kind == "overwrite":
            run = draw(st.binary(min_size=1, max_size=16))
            b[i:i + len(run)] = run
        elif kind == "insert":
            b[i:i] = draw(st.binary(min_size=1, max_size=16))
        else:
            del b[i:i + draw(st.integers(1, 64))]
    return bytes(b)


def _write(folder: str, name: str, data: bytes | str) -> Path:
    p = Path(folder) / name
    if isinstance(data, str):
        p.write_text(data, encoding="utf-8", errors="surrogatepass")
    else:
        p.write_bytes(data)
    return p


def _consistent(tr: lgvi.Trajectory) -> None:
    """A trajectory a reader returned must hang together (the readers check this)."""
    M = len(tr.t)
    assert tr.t.shape == (M,) and tr.R.shape == (M, 3, 3) and tr.Pi.shape == (M, 3)
    assert tr.inertia.shape == (3, 3)
    assert tr.iterations.ndim == 1 and tr.residual.ndim == 1
    assert tr.potential is None or tr.potential.shape == (M,)
    assert isinstance(tr.meta, dict)


def _expect_value_error(read, path: Path) -> None:
    try:
        tr = read(path)
    except ValueError as exc:
        assert str(path) in str(exc) or path.name in str(exc), f"message does not name the file: {exc}"
        return
    _consistent(tr)


# --------------------------------------------------------------------------------------------
# lgvi.load
# --------------------------------------------------------------------------------------------
@FUZZ
@given(data=st.data())
def test_load_mutated_bytes(npz_bytes, data):
    blob = data.draw(mutated(npz_bytes))
    with tempfile.TemporaryDirectory() as d:
        _expect_value_error(lgvi.load, _write(d, "run.npz", blob))


@FUZZ
@given(blob=st.binary(max_size=512) | st.builds(lambda b: b"PK\x03\x04" + b, st.binary(max_size=512)))
def test_load_random_bytes(blob):
    with tempfile.TemporaryDirectory() as d:
        _expect_value_error(lgvi.load, _write(d, "run.npz", blob))


_ARRAY = hnp.arrays(
    dtype=st.sampled_from([np.float64, np.float32, np.int64, np.int8, np.bool_, np.complex128, "U3"]),
    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4),
)


@FUZZ
@given(field=st.sampled_from(["t", "R", "Pi", "inertia", "iterations", "residual", "potential", "h", "__lgvi__"]),
       value=_ARRAY, header=json_values, drop=st.booleans())
def test_load_structured(npz_bytes, field, value, header, drop):
    """A valid archive with one member replaced by a random array (or dropped), or a random header."""
    with zipfile.ZipFile(io.BytesIO(npz_bytes)) as zf, np.load(io.BytesIO(npz_bytes)) as data:
        arrays = {k: data[k] for k in data.files}
        assert len(zf.namelist()) == len(arrays)
    if field == "__lgvi__" and not drop:
        value = np.array(json.dumps(header, allow_nan=True))
    if drop:
        arrays.pop(field, None)
    else:
        arrays[field] = value
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "run.npz"
        np.savez(p, **arrays)
        _expect_value_error(lgvi.load, p)


# --------------------------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------------------------
@FUZZ
@given(data=st.data(), which=st.sampled_from(["csv", "sidecar", "both"]))
def test_read_csv_mutated(csv_files, data, which):
    text, side = csv_files
    if which in ("csv", "both"):
        text = data.draw(mutated(text.encode())).decode("utf-8", errors="replace")
    if which in ("sidecar", "both"):
        side = data.draw(mutated(side.encode())).decode("utf-8", errors="replace")
    with tempfile.TemporaryDirectory() as d:
        p = _write(d, "run.csv", text)
        _write(d, "run.meta.json", side)
        _expect_value_error(outputs.read_csv, p)


@FUZZ
@given(side=json_values, key=st.sampled_from(["inertia", "h", "meta", None]), value=json_values,
       with_sidecar=st.booleans())
def test_read_csv_random_sidecar(csv_files, side, key, value, with_sidecar):
    text, good = csv_files
    if key is not None:
        side = json.loads(good)
        side[key] = value
    with tempfile.TemporaryDirectory() as d:
        p = _write(d, "run.csv", text)
        if with_sidecar:
            _write(d, "run.meta.json", json.dumps(side, allow_nan=True))
        _expect_value_error(outputs.read_csv, p)


@FUZZ
@given(lines=st.lists(st.text(alphabet=st.sampled_from(list("0123456789.,-+eE naif\t\"")), max_size=40), max_size=5))
def test_read_csv_random_rows(csv_files, lines):
    header = csv_files[0].splitlines()[0]
    with tempfile.TemporaryDirectory() as d:
        p = _write(d, "run.csv", "\n".join([header] + lines) + "\n")
        _write(d, "run.meta.json", csv_files[1])
        _expect_value_error(outputs.read_csv, p)


# --------------------------------------------------------------------------------------------
# netCDF
# --------------------------------------------------------------------------------------------
_NC_FUZZ = textwrap.dedent("""\
    import json, os, random, sys, tempfile
    import numpy as np
    import lgvi
    from lgvi.io.outputs import read_netcdf, write_netcdf

    seed, n = int(sys.argv[1]), int(sys.argv[2])
    d = tempfile.mkdtemp()
    tr = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), [0.3, 2.0, 0.6], h=0.01, steps=6)
    p = os.path.join(d, "a.nc")
    write_netcdf(tr, p)
    data = open(p, "rb").read()
    rng = random.Random(seed)
    out = {}
    for i in range(n):
        b = bytearray(data)
        kind = rng.choice(["truncate", "flip", "overwrite"])
        j = rng.randrange(len(b))
        if kind == "truncate":
            del b[j:]
        elif kind == "flip":
            for _ in range(rng.randint(1, 8)):
                b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        else:
            b[j:j + 8] = bytes(rng.randrange(256) for _ in range(8))
        q = os.path.join(d, f"m{i}.nc")  # a new file each time: HDF5 keeps a file whose close failed open
        open(q, "wb").write(b)             # and would serve a rewrite of the same inode from it
        try:
            read_netcdf(q)
            r = "read"
        except ValueError as exc:
            r = "ValueError" if q in str(exc) else "ValueError without the file name: " + str(exc)[:200]
        except Exception as exc:
            r = type(exc).__name__ + ": " + str(exc)[:200]
        out[r] = out.get(r, 0) + 1
    print(json.dumps(out))
    """)


def test_read_netcdf_mutated_bytes_in_a_subprocess():
    pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    n = max(40, MAX_EXAMPLES)
    run = subprocess.run([sys.executable, "-c", _NC_FUZZ, "7", str(n)], capture_output=True, text=True)
    assert run.returncode == 0, f"the netCDF reader crashed (return code {run.returncode}): {run.stderr[-2000:]}"
    counts = json.loads(run.stdout.strip().splitlines()[-1])
    assert set(counts) <= {"read", "ValueError"}, counts
    assert counts.get("ValueError", 0) > n // 2, counts


@FUZZ
@given(drop=st.sampled_from(["R", "Pi", "time", "inertia", "iterations", "residual", None]),
       attr=st.sampled_from(["lgvi_meta", "h", "lgvi_format", None]), value=st.one_of(st.text(max_size=12),
                                                                                     st.integers(-5, 5)))
def test_read_netcdf_structured(traj, drop, attr, value):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "run.nc"
        outputs.write_netcdf(traj, p)
        with xr.open_dataset(p) as ds:
            ds = ds.load()
        if drop is not None:
            ds = ds.drop_vars(drop)
        if attr is not None:
            ds.attrs[attr] = value
        q = Path(d) / "changed.nc"
        ds.to_netcdf(q)
        _expect_value_error(outputs.read_netcdf, q)


# --------------------------------------------------------------------------------------------
# scenarios
# --------------------------------------------------------------------------------------------
def _expect_scenario_error(path: Path) -> None:
    try:
        sc = load_scenario(path)
    except ScenarioError as exc:
        assert str(path) in str(exc)
        return
    assert isinstance(sc, Scenario)
    assert np.all(np.isfinite(sc.R0)) and np.all(np.isfinite(sc.Pi0)) and np.isfinite(sc.h)
    assert sc.steps >= 0 and sc.steps % sc.save_every == 0


@FUZZ
@given(data=st.data())
def test_load_scenario_mutated_text(data):
    blob = data.draw(mutated(SCENARIO.encode()))
    with tempfile.TemporaryDirectory() as d:
        _expect_scenario_error(_write(d, "fuzz.toml", blob))


@FUZZ
@given(text=st.text(max_size=200) | st.binary(max_size=200).map(lambda b: b.decode("latin-1")))
def test_load_scenario_random_text(text):
    with tempfile.TemporaryDirectory() as d:
        _expect_scenario_error(_write(d, "fuzz.toml", text.encode("utf-8", errors="surrogatepass")))


toml_values = st.recursive(
    st.booleans() | st.integers(-2**63, 2**63 - 1) | st.floats(allow_nan=True) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(min_size=1, max_size=8), inner, max_size=3),
    max_leaves=8,
)


def _paths(d, prefix=()):
    """Every path (a tuple of keys and indices) to a value in a nested dict/list."""
    items = d.items() if isinstance(d, dict) else enumerate(d)
    for k, v in items:
        yield prefix + (k,)
        if isinstance(v, (dict, list)):
            yield from _paths(v, prefix + (k,))


def _mutate(data, d, action: str, value) -> None:
    """At a drawn path of the nested dict/list ``d``: replace the value, drop it, or add ``value``
    beside it (a new random key in a dict, appended to a list)."""
    *head, last = data.draw(st.sampled_from(list(_paths(d))))
    parent = d
    for k in head:
        parent = parent[k]
    if action == "replace":
        parent[last] = value
    elif action == "drop":
        del parent[last]
    elif isinstance(parent, dict):
        parent[data.draw(st.text(min_size=1, max_size=8))] = value
    else:
        parent.append(value)


@FUZZ
@given(data=st.data(), action=st.sampled_from(["replace", "drop", "add"]), value=toml_values,
       via_file=st.booleans())
def test_scenario_structured(data, action, value, via_file):
    """The valid scenario with one value replaced by a random one, one key dropped, or one added."""
    import tomllib

    d = tomllib.loads(SCENARIO)
    _mutate(data, d, action, value)
    if not via_file:
        try:
            sc = Scenario.from_dict(copy.deepcopy(d), "fuzz.toml")
        except ScenarioError as exc:
            assert "fuzz.toml" in str(exc)
            return
        assert np.all(np.isfinite(sc.R0)) and np.all(np.isfinite(sc.Pi0))
        return
    try:
        text = lgvi.io.scenario.to_toml(d)
    except TypeError:
        return
    with tempfile.TemporaryDirectory() as tmp:
        _expect_scenario_error(_write(tmp, "fuzz.toml", text))


# --------------------------------------------------------------------------------------------
# streams
# --------------------------------------------------------------------------------------------
def _read_or_reject(folder: Path) -> None:
    """A damaged stream folder is read consistently or refused with a ValueError naming it."""
    try:
        tr = streaming.read_stream(folder)
    except ValueError as exc:
        assert str(folder) in str(exc), str(exc)
        return
    _consistent(tr)


def _copy_stream(src: Path, dst: Path) -> None:
    dst.mkdir()
    for f in src.iterdir():
        (dst / f.name).write_bytes(f.read_bytes())


@FUZZ
@given(data=st.data(), target=st.sampled_from(["manifest.json", "chunk-000000.npz", "chunk-000001.npz",
                                                "chunk-000002.npz"]))
def test_read_stream_mutated_files(stream_folder, data, target):
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d) / "run"
        _copy_stream(stream_folder, folder)
        f = folder / target
        f.write_bytes(data.draw(mutated(f.read_bytes())))
        _read_or_reject(folder)


@FUZZ
@given(data=st.data(), value=json_values, action=st.sampled_from(["replace", "drop"]),
       remove_chunk=st.sampled_from([None, "chunk-000000.npz", "chunk-000002.npz"]))
def test_read_stream_structured_manifest(stream_folder, data, value, action, remove_chunk):
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d) / "run"
        _copy_stream(stream_folder, folder)
        manifest = json.loads((folder / "manifest.json").read_text())
        _mutate(data, manifest, action, value)
        (folder / "manifest.json").write_text(json.dumps(manifest, allow_nan=True))
        if remove_chunk:
            (folder / remove_chunk).unlink()
        _read_or_reject(folder)


def test_read_stream_refuses_paths_outside_the_folder(stream_folder, tmp_path, traj):
    """A manifest naming a file outside its folder is damaged, not followed."""
    folder = tmp_path / "run"
    _copy_stream(stream_folder, folder)
    outside = tmp_path / "elsewhere.npz"
    traj.save(outside)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["chunks"][1]["file"] = "../elsewhere.npz"
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match=r"chunk 1 must name a file in the stream folder"):
        streaming.read_stream(folder)


# --------------------------------------------------------------------------------------------
# what the fuzzing (and reading the code) found, kept as regressions
# --------------------------------------------------------------------------------------------
_BASE = "[body]\ninertia = [1.0, 2.0, 3.0]\n[initial]\nomega = [0.0, 1.0, 0.0]\n[integrator]\nh = 0.01\nsteps = 10\n"


@pytest.mark.parametrize("text,pattern", [
    ("a = " + "[" * 5000 + "]" * 5000, r"nested too deeply"),                        # was RecursionError
    ("a = " + "{x = " * 3000 + "1" + "}" * 3000, r"nested too deeply"),
    (_BASE.replace("h = 0.01\nsteps = 10", "h = 1e-300\nduration = 1e300"),            # was OverflowError
     r"integrator\.duration: .*overflows"),
    (_BASE.replace("omega = [0.0, 1.0, 0.0]", "omega = [0.0, 1e308, 0.0]"),           # was Pi0 = inf
     r"initial\.omega: .*finite"),
    (_BASE.replace("omega = [0.0, 1.0, 0.0]", "rotvec = [1e308, 1e308, 0.0]\nomega = [0.0, 1.0, 0.0]"),
     r"initial\.rotvec: .*finite length"),                                            # was R0 = NaN
    (_BASE + '[[torque]]\ntype = "uniform_gravity"\nmass = 1e300\ncom = [0.0, 0.0, 1e300]\n',
     r"torque\[0\]: .*mass \* g \* com must be finite"),                              # was accepted
    (_BASE.replace("[1.0, 2.0, 3.0]", "[1e308, 1e308, 1e308]"), r"body\.inertia: .*range of double"),
    ("\x00\xff\xfe", r"TOML syntax error|not UTF-8"),
], ids=["deep-array", "deep-table", "duration-overflow", "omega-overflow", "rotvec-inf", "gravity-overflow",
        "inertia-overflow", "binary"])
def test_scenario_regressions(tmp_path, text, pattern):
    p = tmp_path / "s.toml"
    p.write_bytes(text.encode("utf-8", errors="surrogatepass") if text != "\x00\xff\xfe" else b"\x00\xff\xfe")
    with pytest.raises(ScenarioError, match=pattern) as info:
        load_scenario(p)
    assert str(p) in str(info.value)
