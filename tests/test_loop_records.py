"""The compiled loop's records (traj.signals) in files: netCDF round trips and saved ensembles."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
from lgvi.spacecraft import Spacecraft
from lgvi.systems.gyrostat_ensemble import GyrostatEnsemble
from lgvi.systems.spacecraft import SpacecraftEnsemble, SpacecraftTrajectory

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
R_TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))
KW = dict(h=0.1, steps=120, save_every=10)
FIELDS = ("t", "R", "Pi", "inertia", "iterations", "residual", "wheel_momentum", "wheel_torque", "wheel_axes",
          "spin_inertia", "signal_data")


def _wheels():
    return lgvi.ReactionWheels(PYRAMID, 1e-4, speed0=[10.0, -20.0, 5.0, 0.0], max_torque=0.004)


def _fsw(K=0.004):
    return FlightSoftware(guidance=InertialPointing(R_TARGET), control=MRPControl(K=K, P=0.04),
                          actuators=RWMotorTorque(), rate=1.0)


def _same(a, b):
    assert type(a) is type(b)
    for name in FIELDS:
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.meta["signals"] == b.meta["signals"]
    assert sorted(a.signals) == sorted(b.signals)
    for name in a.signals:
        assert np.array_equal(a.signals[name], b.signals[name]), name
    assert np.array_equal(a.signal_t, b.signal_t)


@pytest.mark.parametrize("solver_record", ["interval", "full"])
def test_a_spacecraft_run_round_trips_through_netcdf(tmp_path, solver_record):
    pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    from lgvi.io.outputs import read_trajectory, write_netcdf

    tr = lgvi.simulate(Spacecraft([0.18, 0.14, 0.06], wheels=_wheels()), np.eye(3), omega0=[0.01, -0.02, 0.015],
                       fsw=_fsw(), solver_record=solver_record, **KW)
    assert isinstance(tr, SpacecraftTrajectory) and tr.signal_data.size
    back = read_trajectory(write_netcdf(tr, tmp_path / "run.nc"))
    _same(back, tr)
    import xarray as xr

    with xr.open_dataset(tmp_path / "run.nc") as ds:       # a reader without lgvi sees the records' times
        assert np.array_equal(ds["record_time"].values, tr.signal_t)
        assert ds["wheel_axes"].dims == ("wheel", "axis")


def test_a_saved_spacecraft_ensemble_keeps_its_records(tmp_path):
    sat = Spacecraft([0.18, 0.14, 0.06], wheels=_wheels())
    R0 = np.stack([np.eye(3), lgvi.so3.exp([0.1, 0.0, 0.0])])
    ens = lgvi.simulate_ensemble(sat, R0, omega0=np.zeros((2, 3)), fsw=[_fsw(0.004), _fsw(0.005)], **KW)
    assert isinstance(ens, SpacecraftEnsemble)
    ens.save(tmp_path / "ens.npz")
    for back in (GyrostatEnsemble.load(tmp_path / "ens.npz"), lgvi.io.outputs.read_trajectory(tmp_path / "ens.npz")):
        assert isinstance(back, SpacecraftEnsemble)
        for b in range(2):
            _same(back[b], ens[b])
        assert np.array_equal(back.signals["sigma_BR"], ens.signals["sigma_BR"])
        assert back.signals["sigma_BR"].shape == (2, 12, 3)
        for name, value in ens.params.items():
            assert np.array_equal(back.params[name], value), name


def test_records_at_each_components_rate(tmp_path):
    """Guidance every 1 s, control every 2 s, a gyro every 0.2 s, records on a 0.5 s grid: each
    signal's record holds the rows where its writer ran, at the writer's times (checked against the
    error computed from the saved attitude at those times), and follows the trajectory into files."""
    from lgvi.control import mrp_from_matrix
    from lgvi.spacecraft import Gyro

    sat = Spacecraft([0.18, 0.14, 0.06], wheels=_wheels(), sensors=[Gyro(rate=0.2, arw=1e-4, rrw=1e-5, seed=1)])
    fsw = FlightSoftware(guidance=InertialPointing(R_TARGET), control=MRPControl(K=0.004, P=0.04, rate=2.0),
                         actuators=RWMotorTorque(), rate=1.0)
    tr = lgvi.simulate(sat, np.eye(3), omega0=[0.01, -0.02, 0.015], h=0.1, steps=120, save_every=5, fsw=fsw)
    rec = tr.records
    assert tr.signal_t[1] == 0.5 and len(tr.signal_t) == 24
    sig = rec["sigma_BR"]
    assert sig.complete and sig.period == pytest.approx(2.0) and np.allclose(sig.t, np.arange(6) * 2.0)
    assert np.array_equal(sig.values, tr.signals["sigma_BR"][::4])
    # the control law's error at its own times: the MRP of R_ref^T R(t) from the saved attitude
    R_at = tr.R[np.searchsorted(tr.t, sig.t)]
    expect = np.array([mrp_from_matrix(R_TARGET.T @ R) for R in R_at])
    assert np.abs(sig.values - expect).max() < 1e-12
    # between two runs of the law the grid holds its last value: the record drops those rows only
    assert np.array_equal(tr.signals["torque_request_B"][1], tr.signals["torque_request_B"][0])
    assert not np.array_equal(rec["torque_request_B"].values[1], rec["torque_request_B"].values[0])
    assert rec["R_ref"].period == pytest.approx(1.0) and len(rec["R_ref"].t) == 12
    gyro = rec["gyro_B"]                     # faster than the grid: the grid, marked incomplete
    assert not gyro.complete and gyro.period == pytest.approx(0.5) and len(gyro.t) == 24
    # the periods are in the metadata: the records survive a save and a load
    tr.save(tmp_path / "run.npz")
    back = lgvi.load(tmp_path / "run.npz")
    for name, r in rec.items():
        b = back.records[name]
        assert np.array_equal(b.t, r.t) and np.array_equal(b.values, r.values) and b.complete == r.complete, name
