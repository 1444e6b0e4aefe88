"""The solver's record at the resolution asked for (``solver_record``), sized by the saved states.

By default (``"interval"``) ``iterations``/``residual`` hold the largest of each saved interval,
kept by the compiled loops, with run totals and a histogram in ``meta["solver_summary"]``;
``"full"`` keeps every step. Both runs are the same motion bit for bit, the interval record is
exactly the per-interval maximum of the full one, the totals are those of every step, and every
format (npz, CSV sidecar, netCDF, stream) carries them back. Files written before the option
(per-step records, no totals) still read.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi.io.outputs import read_csv, read_netcdf, write_csv, write_netcdf
from lgvi.io.streaming import read_stream
from lgvi.torques import LinearDamping, UniformGravity

BODY = lgvi.RigidBody([0.13, 0.28, 0.17])
SE = 8


def _cases():
    return {
        "free-newton": dict(omega0=[0.3, 1.0, 0.2], h=0.05, steps=400),
        "free-cayley": dict(omega0=[0.3, 1.0, 0.2], h=0.05, steps=400, method="cayley"),
        "model": dict(omega0=[4.14, 4.14, 4.14], h=0.01, steps=400,
                      torque=UniformGravity(1.0, [0.0, 0.0, 0.3]) + LinearDamping(0.01)),
        "order4": dict(omega0=[1.0, 2.0, 3.0], h=0.02, steps=400, order=4),
        "callable-paper": dict(omega0=[1.0, 2.0, 3.0], h=0.02, steps=400,
                               torque=lambda t, R, Pi: [0.01 * np.cos(t), 0.0, 0.0]),
        "callable-symmetric": dict(omega0=[1.0, 2.0, 3.0], h=0.02, steps=400, forcing="symmetric",
                                   torque=lambda t, R, Pi: 0.01 * np.array([np.cos(t), 0.0, 0.0]) - 0.01 * Pi),
    }


@pytest.mark.parametrize("name", list(_cases()))
def test_interval_record_is_the_maximum_of_the_full_record(name):
    kw = _cases()[name]
    full = lgvi.simulate(BODY, np.eye(3), save_every=SE, solver_record="full", **kw)
    inter = lgvi.simulate(BODY, np.eye(3), save_every=SE, **kw)
    steps, M = kw["steps"], kw["steps"] // SE + 1
    assert inter.meta["solver_record"] == "interval" and full.meta["solver_record"] == "full"
    for f in ("t", "R", "Pi"):
        assert np.array_equal(getattr(inter, f), getattr(full, f))      # the same motion, bit for bit
    assert full.iterations.shape == (steps,) and inter.iterations.shape == (M - 1,)
    assert inter.residual.shape == (M - 1,) and inter.iterations.dtype == full.iterations.dtype
    assert np.array_equal(inter.iterations, full.iterations.reshape(M - 1, SE).max(axis=1))
    assert np.array_equal(inter.residual, full.residual.reshape(M - 1, SE).max(axis=1))
    # totals over every step, equal in both modes and to the full record's own
    s_full, s_int = full.solver_summary, inter.solver_summary
    assert inter.steps == full.steps == steps == s_int["steps"]
    assert s_int["iterations_total"] == s_full["iterations_total"] == int(full.iterations.sum())
    assert s_int["iterations_max"] == int(full.iterations.max())
    assert s_int["residual_max"] == float(full.residual.max())
    assert np.array_equal(s_int["histogram"], np.bincount(full.iterations, minlength=lgvi.trajectory.HIST_BINS))
    assert s_int["iterations_mean"] == pytest.approx(full.iterations.mean(), rel=1e-15)


def test_save_every_1_record_is_the_per_step_record():
    kw = _cases()["model"]
    a = lgvi.simulate(BODY, np.eye(3), **kw)
    b = lgvi.simulate(BODY, np.eye(3), solver_record="full", **kw)
    assert a.iterations.shape == (kw["steps"],)
    assert np.array_equal(a.iterations, b.iterations) and np.array_equal(a.residual, b.residual)


@pytest.mark.parametrize("bad", ["per-step", "", None, 1])
def test_solver_record_is_validated(bad):
    with pytest.raises((ValueError, TypeError), match="solver_record"):
        lgvi.simulate(BODY, np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.05, steps=10, solver_record=bad)
    with pytest.raises((ValueError, TypeError), match="solver_record"):
        lgvi.simulate_stream("unused", BODY, np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.05, steps=10,
                             solver_record=bad)


def test_convergence_error_reports_the_failed_step_with_an_interval_record():
    """The failed step's iterations and residual reach the error whatever the record keeps."""
    steps = 40
    U = np.tile([0.0, 0.0, 20.0], (steps, 1))
    kw = dict(Pi0=[0.0, 0.0, 1.0], h=0.1, steps=steps, torque=U, save_every=4)
    errs = {}
    for rec in ("interval", "full"):
        with pytest.raises(lgvi.ConvergenceError) as info:
            lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), solver_record=rec, **kw)
        errs[rec] = info.value
    a, b = errs["interval"], errs["full"]
    assert a.step == b.step and a.iterations == b.iterations and a.residual == b.residual
    part = a.trajectory
    assert part.steps == a.step and part.iterations.shape == (len(part.t) - 1,)
    assert np.array_equal(part.iterations, b.trajectory.iterations[:4 * (len(part.t) - 1)].reshape(-1, 4).max(axis=1))


# ------------------------------------------------------------------------------------ round trips
@pytest.fixture(scope="module")
def interval_run():
    return lgvi.simulate(BODY, np.eye(3), save_every=SE, **_cases()["model"])


def _same_record(a, b):
    for f in ("t", "R", "Pi", "iterations", "residual"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    assert a.steps == b.steps
    for k in ("steps", "iterations_total", "iterations_max", "residual_max", "histogram", "record"):
        assert np.array_equal(a.solver_summary[k], b.solver_summary[k]), k


def test_npz_round_trip_of_the_interval_record(tmp_path, interval_run):
    interval_run.save(tmp_path / "r.npz")
    _same_record(lgvi.load(tmp_path / "r.npz"), interval_run)


def test_csv_round_trip_keeps_the_totals(tmp_path, interval_run):
    back = read_csv(write_csv(interval_run, tmp_path / "r.csv"))
    assert back.iterations.size == 0 and back.steps == interval_run.steps
    for k in ("steps", "iterations_total", "iterations_max", "residual_max", "histogram"):
        assert np.array_equal(back.solver_summary[k], interval_run.solver_summary[k]), k


def test_netcdf_round_trip_of_the_interval_record(tmp_path, interval_run):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    p = write_netcdf(interval_run, tmp_path / "r.nc")
    with xr.open_dataset(p) as ds:
        assert ds["iterations"].dims == ("interval",) and ds.sizes["interval"] == len(interval_run.t) - 1
    _same_record(read_netcdf(p), interval_run)


def test_stream_round_trip_and_sizes(tmp_path, interval_run):
    kw = _cases()["model"]
    lgvi.simulate_stream(tmp_path / "s", BODY, np.eye(3), save_every=SE, chunk_steps=96, **kw)
    _same_record(read_stream(tmp_path / "s"), interval_run)
    chunk = np.load(tmp_path / "s" / "chunk-000001.npz")
    assert chunk["iterations"].shape == (96 // SE,) and int(chunk["iteration_counts"].sum()) == 96


def test_outputs_are_sized_by_the_saved_states(tmp_path):
    """A long run saved sparsely: the npz holds M - 1 record entries, not one per step."""
    kw = dict(omega0=[0.3, 1.0, 0.2], h=0.01, steps=200_000, method="cayley", save_every=1000)
    inter = lgvi.simulate(BODY, np.eye(3), **kw)
    inter.save(tmp_path / "i.npz")
    full = lgvi.simulate(BODY, np.eye(3), solver_record="full", **kw)
    full.save(tmp_path / "f.npz")
    with zipfile.ZipFile(tmp_path / "i.npz") as z:
        assert z.getinfo("iterations.npy").file_size < 1000 and z.getinfo("residual.npy").file_size < 2000
    assert (tmp_path / "i.npz").stat().st_size < 30_000 < 2_000_000 < (tmp_path / "f.npz").stat().st_size


# ------------------------------------------------------------------------------------ older files
def _old_npz(path: Path, traj: lgvi.Trajectory) -> None:
    """The layout of ``Trajectory.save`` before ``solver_record``: per-step records, no totals."""
    meta = {k: v for k, v in traj.meta.items() if k not in ("solver_record", "solver_summary")}
    header = json.dumps({"format": "lgvi.trajectory/1", "meta": meta})
    with open(path, "wb") as fh:
        np.savez(fh, __lgvi__=np.array(header), t=traj.t, R=traj.R, Pi=traj.Pi, inertia=traj.inertia,
                 iterations=traj.iterations, residual=traj.residual, h=np.float64(traj.h))


def test_older_npz_with_per_step_records_still_reads(tmp_path):
    full = lgvi.simulate(BODY, np.eye(3), save_every=SE, solver_record="full", **_cases()["free-newton"])
    _old_npz(tmp_path / "old.npz", full)
    old = lgvi.load(tmp_path / "old.npz")
    assert "solver_summary" not in old.meta and old.iterations.shape == (400,)
    assert old.steps == 400
    s = old.solver_summary
    assert s["record"] == "full" and s["steps"] == 400 and s["iterations_total"] == int(full.iterations.sum())
    assert s["iterations_max"] == int(full.iterations.max()) and s["residual_max"] == float(full.residual.max())
    assert np.array_equal(s["histogram"], full.solver_summary["histogram"])


def test_older_stream_with_per_step_records_reads_and_resumes(tmp_path):
    """A stream of the old layout (no totals in the chunks, no solver_record in the manifest)
    reads back, and resumes (as a full record) bit for bit."""
    kw = dict(_cases()["free-newton"], save_every=SE, solver_record="full")
    ref = lgvi.simulate(BODY, np.eye(3), **kw)
    folder = tmp_path / "s"

    def stop(k, n):
        if k >= 160:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=80, progress=stop, **kw)
    for p in sorted(folder.glob("chunk-*.npz")):   # strip what the old layout did not have
        with np.load(p) as d:
            arrays = {k: d[k] for k in ("t", "R", "Pi", "iterations", "residual")}
        with open(p, "wb") as fh:
            np.savez(fh, **arrays)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["meta"].pop("solver_record")
    (folder / "manifest.json").write_text(json.dumps(manifest))
    part = read_stream(folder)
    assert "solver_summary" not in part.meta and part.steps == 160 and part.solver_summary["steps"] == 160
    lgvi.simulate_stream(folder, BODY, np.eye(3), chunk_steps=80, resume=True, **kw)
    back = read_stream(folder)
    for f in ("t", "R", "Pi", "iterations", "residual"):
        assert np.array_equal(getattr(back, f), getattr(ref, f)), f
    assert back.solver_summary["iterations_total"] == ref.solver_summary["iterations_total"]


def test_plot_and_info_of_an_interval_record(tmp_path, interval_run, capsys):
    pytest.importorskip("matplotlib")
    import lgvi.plot
    from lgvi.cli import main

    fig = lgvi.plot.iterations(interval_run)
    title = fig.axes[0].get_title()
    assert f"mean {interval_run.solver_summary['iterations_mean']:.2f} updates/step" in title
    line = fig.axes[0].get_lines()[0]
    assert np.array_equal(line.get_xdata(), interval_run.t[:-1])   # interval i drawn from t_i
    interval_run.save(tmp_path / "r.npz")
    assert main(["info", str(tmp_path / "r.npz")]) == 0
    out = capsys.readouterr().out
    s = interval_run.solver_summary
    assert f"max {s['iterations_max']}, max residual {s['residual_max']:.3e} (record: interval)" in out
    assert f"steps       {interval_run.steps}," in out
