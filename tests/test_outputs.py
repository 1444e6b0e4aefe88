"""Output formats: CSV columns and rows, sidecar metadata, exact round trips, netCDF, errors."""

from __future__ import annotations

import csv
import json
import sys

import numpy as np
import pytest

import lgvi
from lgvi.io import outputs
from lgvi.io.outputs import (CSV_COLUMNS, conservation_drifts, read_csv, read_netcdf, read_trajectory, sidecar_path,
                          write_csv, write_netcdf, write_trajectory)

SCENARIO_TEXT = '[body]\ninertia = [1.0, 2.0, 3.0]\n# a "quoted" comment\n'


@pytest.fixture(scope="module")
def traj():
    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    t = lgvi.simulate(body, lgvi.so3.exp([0.1, -0.2, 0.3]), omega0=[0.3, 1.0, -0.2], h=0.01, steps=60,
                      save_every=3)
    from dataclasses import replace

    return replace(t, meta=dict(t.meta, scenario=SCENARIO_TEXT, scenario_name="unit"))


@pytest.fixture(scope="module")
def traj_potential():
    torques = pytest.importorskip("lgvi.torques")
    return lgvi.simulate(lgvi.RigidBody([0.13, 0.28, 0.17]), np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01,
                         steps=50, torque=torques.UniformGravity(1.0, [0.0, 0.0, 0.3]))


# ------------------------------------------------------------------------------------ CSV
def test_csv_columns_rows_and_values(tmp_path, traj):
    p = write_csv(traj, tmp_path / "run.csv")
    with open(p, newline="") as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], rows[1:]
    assert header == ["t", "R11", "R12", "R13", "R21", "R22", "R23", "R31", "R32", "R33", "qx", "qy", "qz", "qw",
                      "Pi1", "Pi2", "Pi3", "omega1", "omega2", "omega3", "energy"]
    assert tuple(header) == CSV_COLUMNS
    M = 60 // 3 + 1
    assert len(body) == M and all(len(r) == len(header) for r in body)
    data = np.array(body, dtype=float)
    np.testing.assert_array_equal(data[:, 0], traj.t)
    np.testing.assert_array_equal(data[:, 1:10].reshape(M, 3, 3), traj.R)   # row-major R_ij
    np.testing.assert_array_equal(data[:, 10:14], traj.quaternion)           # scalar last
    assert data[0, 13] > 0 and abs(data[0, 13] - np.cos(np.linalg.norm([0.1, -0.2, 0.3]) / 2)) < 1e-15
    np.testing.assert_array_equal(data[:, 14:17], traj.Pi)
    np.testing.assert_array_equal(data[:, 17:20], traj.omega)
    np.testing.assert_array_equal(data[:, 20], traj.energy)


def test_csv_sidecar_holds_version_scenario_and_units(tmp_path, traj):
    p = write_csv(traj, tmp_path / "run.csv")
    side = json.loads(sidecar_path(p).read_text())
    assert sidecar_path(p).name == "run.meta.json"
    assert side["lgvi_version"] == lgvi.__version__
    assert side["meta"]["scenario"] == SCENARIO_TEXT
    assert side["meta"]["steps"] == 60 and side["samples"] == 21
    assert side["h"] == 0.01 and np.array_equal(side["inertia"], np.diag([1.0, 2.0, 3.0]))
    assert side["units"]["omega2"] == "rad/s" and side["units"]["t"] == "s" and side["units"]["Pi3"] == "kg m^2/s"
    assert "scalar last" in side["quaternion"]
    assert side["columns"] == list(CSV_COLUMNS)


def test_csv_round_trip_is_exact_but_drops_the_solver_record(tmp_path, traj):
    back = read_csv(write_csv(traj, tmp_path / "run.csv"))
    for name in ("t", "R", "Pi", "inertia"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.h == traj.h
    assert back.iterations.size == 0 and back.residual.size == 0
    assert back.meta["scenario"] == SCENARIO_TEXT and back.meta["steps"] == 60 and back.meta["read_from"] == "csv"
    np.testing.assert_array_equal(back.energy, traj.energy)


def test_csv_without_sidecar_needs_inertia(tmp_path, traj):
    p = write_csv(traj, tmp_path / "run.csv")
    sidecar_path(p).unlink()
    with pytest.raises(ValueError, match="inertia="):
        read_csv(p)
    back = read_csv(p, inertia=[1.0, 2.0, 3.0])
    np.testing.assert_array_equal(back.R, traj.R)


def test_csv_with_potential_column(tmp_path, traj_potential):
    p = write_csv(traj_potential, tmp_path / "pend.csv")
    header = p.read_text().splitlines()[0].split(",")
    assert header[-2:] == ["energy", "potential"]
    back = read_csv(p)
    np.testing.assert_array_equal(back.potential, traj_potential.potential)
    np.testing.assert_array_equal(back.energy, traj_potential.energy)


def test_read_csv_rejects_other_csv(tmp_path):
    p = tmp_path / "other.csv"
    p.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not an lgvi CSV trajectory"):
        read_csv(p)


# ------------------------------------------------------------------------------------ netCDF
def test_netcdf_round_trip_exact(tmp_path, traj):
    pytest.importorskip("xarray")
    p = write_netcdf(traj, tmp_path / "run.nc")
    back = read_netcdf(p)
    for name in ("t", "R", "Pi", "inertia", "iterations", "residual"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.h == traj.h and back.potential is None
    assert back.meta["scenario"] == SCENARIO_TEXT and back.meta["lgvi_version"] == lgvi.__version__
    import xarray as xr

    with xr.open_dataset(p) as ds:
        assert ds.attrs["scenario"] == SCENARIO_TEXT and ds.attrs["lgvi_version"] == lgvi.__version__
        assert list(ds["component"].values) == ["x", "y", "z", "w"]
        assert ds["omega"].attrs["units"] == "rad s-1"
        np.testing.assert_array_equal(ds["quaternion"].values, traj.quaternion)


def test_netcdf_keeps_the_potential(tmp_path, traj_potential):
    pytest.importorskip("xarray")
    back = read_netcdf(write_netcdf(traj_potential, tmp_path / "pend.nc"))
    np.testing.assert_array_equal(back.potential, traj_potential.potential)


def test_netcdf_without_xarray_says_how_to_install(tmp_path, traj, monkeypatch):
    monkeypatch.setitem(sys.modules, "xarray", None)  # import xarray -> ImportError
    with pytest.raises(ImportError, match=r"pip install 'lgvi\[io\]'"):
        write_netcdf(traj, tmp_path / "run.nc")
    with pytest.raises(ImportError, match=r"lgvi\[io\]"):
        read_netcdf(tmp_path / "run.nc")


# ------------------------------------------------------------------------------------ any format
def test_write_trajectory_all_formats_and_read_back(tmp_path, traj):
    formats = ["npz", "csv"] + (["netcdf"] if _has_xarray() else [])
    files = write_trajectory(traj, tmp_path / "out", formats)
    names = [f.name for f in files]
    assert names[:3] == ["trajectory.npz", "trajectory.csv", "trajectory.meta.json"]
    for f in files:
        assert f.exists()
        if f.suffix in (".npz", ".csv", ".nc"):
            back = read_trajectory(f)
            np.testing.assert_array_equal(back.R, traj.R)
            assert back.meta["scenario"] == SCENARIO_TEXT
    assert lgvi.load(tmp_path / "out" / "trajectory.npz").meta["scenario"] == SCENARIO_TEXT


def test_write_and_read_errors(tmp_path, traj):
    with pytest.raises(ValueError, match="unknown output format 'hdf5'"):
        write_trajectory(traj, tmp_path, ["hdf5"])
    with pytest.raises(ValueError, match="unknown trajectory file type"):
        read_trajectory(tmp_path / "x.mat")


def _has_xarray() -> bool:
    try:
        import xarray  # noqa: F401
    except ImportError:
        return False
    return True


# ------------------------------------------------------------------------------------ drifts
def test_conservation_drifts(traj):
    d = conservation_drifts(traj)
    assert set(d) == {"energy_abs", "energy_rel", "casimir_rel", "spatial_momentum_rel", "spatial_momentum_e3_rel",
                      "orthogonality_max"}
    assert all(v is not None and 0 <= v < 1e-13 for v in d.values())


def test_conservation_drifts_zero_scale_and_real_drift():
    rest = lgvi.simulate(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), omega0=[0.0, 0.0, 0.0], h=0.1, steps=3)
    d = conservation_drifts(rest)
    assert d["energy_rel"] is None and d["casimir_rel"] is None and d["spatial_momentum_rel"] is None
    assert d["energy_abs"] == 0.0
    # a hand-made trajectory whose |Pi| grows by 10 %: the drift must show it
    R = np.repeat(np.eye(3)[None], 2, axis=0)
    t = lgvi.Trajectory(t=np.array([0.0, 1.0]), R=R, Pi=np.array([[1.0, 0.0, 0.0], [1.1, 0.0, 0.0]]),
                        inertia=np.eye(3), iterations=np.zeros(1, dtype=np.int32), residual=np.zeros(1), h=1.0)
    d = outputs.conservation_drifts(t)
    assert d["casimir_rel"] == pytest.approx(0.1) and d["energy_rel"] == pytest.approx(0.21)
