"""The compiled loop's records (traj.signals) in files: netCDF round trips and saved ensembles."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
from lgvi.spacecraft import Spacecraft
from lgvi.systems.gyrostat_ensemble import GyrostatEnsemble
from lgvi.systems.spacecraft import LoopRun, SpacecraftEnsemble, SpacecraftTrajectory

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
R_TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))
KW = dict(h=0.1, steps=120, save_every=10)
FIELDS = ("t", "R", "Pi", "inertia", "iterations", "residual", "wheel_momentum", "wheel_torque", "wheel_axes",
          "spin_inertia", "signal_data")


def _wheels():
    return lgvi.ReactionWheels(PYRAMID, 1e-4, speed0=[10.0, -20.0, 5.0, 0.0], max_torque=0.004)


def _fsw(K=0.004):
    """Guidance every 1 s, the control law every 0.5 s: on the 1 s record grid of KW, the law's
    signals are recorded in their own slots (meta["signal_fast"]) too."""
    return FlightSoftware(guidance=InertialPointing(R_TARGET), control=MRPControl(K=K, P=0.04, rate=0.5),
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
    assert a.meta["signal_fast"] == b.meta["signal_fast"]
    for name, r in a.records.items():
        assert np.array_equal(r.t, b.records[name].t) and np.array_equal(r.values, b.records[name].values), name


@pytest.mark.parametrize("solver_record", ["interval", "full"])
def test_a_spacecraft_run_round_trips_through_netcdf(tmp_path, solver_record):
    pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    from lgvi.io.outputs import read_trajectory, write_netcdf

    tr = lgvi.simulate(Spacecraft([0.18, 0.14, 0.06], wheels=_wheels()), np.eye(3), omega0=[0.01, -0.02, 0.015],
                       fsw=_fsw(), solver_record=solver_record, **KW)
    assert isinstance(tr, SpacecraftTrajectory) and tr.signal_data.size
    fast = {row[0] for row in tr.meta["signal_fast"]}
    assert ("sigma_BR" in fast and "R_ref" not in fast) == (solver_record == "interval")   # the full grid: none
    assert tr.records["sigma_BR"].complete and len(tr.records["sigma_BR"].t) == 24
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
    gyro = rec["gyro_B"]                     # faster than the grid: every value, in its own columns
    assert gyro.complete and gyro.period == pytest.approx(0.2) and np.allclose(gyro.t, np.arange(60) * 0.2)
    # the periods are in the metadata: the records survive a save and a load
    tr.save(tmp_path / "run.npz")
    back = lgvi.load(tmp_path / "run.npz")
    for name, r in rec.items():
        b = back.records[name]
        assert np.array_equal(b.t, r.t) and np.array_equal(b.values, r.values) and b.complete == r.complete, name


def _sensed(**fsw_options):
    """A spacecraft whose gyro runs every 2 steps, with the control law every 3 steps and the
    guidance every 10 (h = 0.1 s), in a circular orbit with the gravity gradient."""
    from lgvi.environment import CircularOrbit
    from lgvi.spacecraft import GravityGradient, Gyro

    sat = Spacecraft([0.18, 0.14, 0.06], wheels=_wheels(), sensors=[Gyro(rate=0.2, arw=1e-4, rrw=1e-5, seed=1)],
                     orbit=CircularOrbit(6878137.0, np.radians(97.4)), disturbances=[GravityGradient()])
    fsw = FlightSoftware(guidance=InertialPointing(R_TARGET), control=MRPControl(K=0.004, P=0.04, rate=0.3),
                         actuators=RWMotorTorque(), rate=1.0, **fsw_options)
    return sat, fsw


def _same_records(a, b):
    assert sorted(a) == sorted(b)
    for name in a:
        assert np.array_equal(a[name].t, b[name].t) and np.array_equal(a[name].values, b[name].values), name
        assert a[name].complete and b[name].complete and a[name].period == b[name].period, name


def test_records_faster_than_the_grid_hold_every_value():
    """A gyro every 2 steps and a control law every 3 on a grid of 5 steps: each record holds every
    value its writer wrote, bit for bit the record of the same run saved at every step (where the
    grid itself holds them), the off-grid slots of an entry NaN; record_rate="grid" keeps the grid."""
    sat, fsw = _sensed()
    kw = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=60)
    coarse = lgvi.simulate(sat, np.eye(3), fsw=fsw, save_every=5, **kw)
    fine = lgvi.simulate(sat, np.eye(3), fsw=fsw, save_every=1, **kw)
    assert np.array_equal(coarse.R, fine.R[::5])                  # recording changes nothing else
    rec = coarse.records
    _same_records(rec, fine.records)
    assert np.allclose(rec["gyro_B"].t, 0.2 * np.arange(30)) and np.allclose(rec["sigma_BR"].t, 0.3 * np.arange(20))
    assert rec["gyro_B"].period == pytest.approx(0.2) and rec["torque_request_B"].period == pytest.approx(0.3)
    # the grid's own columns are as before: the bus at each entry's first step
    assert np.array_equal(coarse.signals["gyro_B"], fine.signals["gyro_B"][::5])
    # layout: (name, column, size, period, slots); entry 1 (steps 5..9) has the law at steps 6, 9 only
    fast = {row[0]: row[1:] for row in coarse.meta["signal_fast"]}
    assert fast["gyro_B"][2:] == [2, 3] and fast["sigma_BR"][2:] == [3, 2]
    col = fast["gyro_B"][0]
    assert np.isnan(coarse.signal_data[1, col + 6:col + 9]).all()  # steps 6, 8; no third (10 is the next entry's)
    grid = lgvi.simulate(sat, np.eye(3), fsw=_sensed(record_rate="grid")[1], save_every=5, **kw)
    assert "signal_fast" in grid.meta and grid.meta["signal_fast"] == [] and np.array_equal(grid.R, coarse.R)
    assert not grid.records["gyro_B"].complete and len(grid.records["gyro_B"].t) == 12
    assert np.array_equal(grid.signal_data, coarse.signal_data[:, :grid.signal_data.shape[1]])


def test_records_of_interleaved_periods_in_chunks_hold_every_value(tmp_path):
    """Records named in an order that interleaves their writers' periods (the control law every 3
    steps, the gyro every 2, the guidance every 10) on a grid of 4 steps that 3 and 10 do not divide,
    run in one call and as a stream of chunks of 7 steps (a chunk boundary inside an entry and between
    writer steps): each record is bit for bit that of the run saved at every step, where the grid
    itself holds every value (the loop visits the rows by period group: ``_fast_layout``)."""
    from lgvi.io.streaming import read_stream, stream_system

    order = ["sigma_BR", "gyro_B", "R_ref", "torque_request_B", "wheel_command", "omega_BR_B"]
    sat, fsw = _sensed(record=order)
    kw = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=84)
    fine = lgvi.simulate(sat, np.eye(3), fsw=fsw, save_every=1, **kw)
    coarse = lgvi.simulate(sat, np.eye(3), fsw=fsw, save_every=4, **kw)
    periods = [row[3] for row in coarse.meta["signal_fast"]]
    assert [row[0] for row in coarse.meta["signal_fast"]] == ["sigma_BR", "gyro_B", "R_ref", "torque_request_B",
                                                               "wheel_command", "omega_BR_B"]
    assert periods == [3, 2, 10, 3, 10, 3]          # interleaved; 3 and 10 do not divide the grid of 4
    _same_records(coarse.records, fine.records)
    stream_system(tmp_path / "s", "spacecraft", sat, np.eye(3), fsw=fsw, chunk_steps=7, save_every=4, **kw)
    back = read_stream(tmp_path / "s")
    assert np.array_equal(back.signal_data, coarse.signal_data, equal_nan=True)
    _same_records(back.records, fine.records)


def test_the_gravity_gradient_is_recorded_by_name():
    """tau_gravity_gradient_B is the variational moment at each step's start: 3 mu / r^5 (r_B x J r_B)
    of the saved attitude and the orbit's position (the tabulated orbit: relative error about 4e-11)."""
    sat, fsw = _sensed()
    tr = lgvi.simulate(sat, np.eye(3), fsw=fsw, omega0=[0.01, -0.02, 0.015], h=0.1, steps=60)
    rec = tr.records["tau_gravity_gradient_B"]
    assert rec.complete and rec.period == pytest.approx(0.1) and len(rec.t) == 60
    r_N, _ = sat.orbit.position_velocity(rec.t)
    mu = 3.986004418e14
    J = np.diag([0.18, 0.14, 0.06])
    expect = []
    for R, r in zip(tr.R[:60], r_N):
        rB = R.T @ r
        expect.append(3.0 * mu / np.linalg.norm(rB) ** 5 * np.cross(rB, J @ rB))
    expect = np.array(expect)
    assert np.abs(rec.values - expect).max() <= 1e-8 * np.abs(expect).max()
    assert np.abs(expect).max() > 1e-9                            # the torque is there (about 1e-8 N m)


STREAM_KW = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=200, save_every=5)


def _interrupted_stream(folder):
    """The sensed spacecraft's stream in ``folder``, stopped (Ctrl-C) after 100 of its 200 steps."""
    from lgvi.io.streaming import stream_system

    sat, fsw = _sensed()

    def stop(done, total):
        if done >= 100:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        stream_system(folder, "spacecraft", sat, np.eye(3), fsw=fsw, chunk_steps=50, progress=stop, **STREAM_KW)
    return sat, fsw


def test_a_stream_interrupted_and_resumed_keeps_the_records_bit_for_bit(tmp_path):
    from lgvi.io.streaming import read_stream, stream_system

    kw = STREAM_KW
    folder = tmp_path / "loop"
    sat, fsw = _interrupted_stream(folder)
    memory = lgvi.simulate(sat, np.eye(3), fsw=fsw, **kw)
    stream_system(folder, "spacecraft", sat, np.eye(3), fsw=fsw, chunk_steps=50, resume=True, **kw)
    back = read_stream(folder)
    assert np.array_equal(back.signal_data, memory.signal_data, equal_nan=True)
    _same_records(back.records, memory.records)
    assert len(back.records["gyro_B"].t) == 100


def test_a_stream_saved_with_another_component_state_layout_refuses_to_resume(tmp_path):
    """The gyro's state went from 14 values to fewer (its noise scales moved into its parameter
    row): a stream saved before, its state 14 wide, used to fail on resume with NumPy's "could not
    broadcast" (or, had the widths summed alike, continue on a shuffled state). It is refused with a
    message naming the gyro and the rule; the same for any component whose saved width differs
    from this run's (the widths are saved with the state now), and for the signal bus."""
    import json

    from lgvi.io.streaming import stream_system

    kw = STREAM_KW
    folder = tmp_path / "loop"
    sat, fsw = _interrupted_stream(folder)
    manifest = folder / "manifest.json"
    saved = json.loads(manifest.read_text())
    run = LoopRun(sat, np.eye(3), fsw=fsw, **kw)
    widths = [[name, int(run.so[i + 1] - run.so[i])] for i, name in enumerate(run.names)]
    g = [w[0] for w in widths].index("gyro")
    at = sum(w[1] for w in widths[:g + 1])                 # the end of the gyro's slice of S

    def resume(state):
        manifest.write_text(json.dumps(dict(saved, state=state)))
        stream_system(folder, "spacecraft", sat, np.eye(3), fsw=fsw, chunk_steps=50, resume=True, **kw)

    old = dict(saved["state"])                              # as an lgvi before saved it: 14 values, no widths
    old.pop("S_widths", None)
    old["S"] = old["S"][:at] + [0.0] * (14 - widths[g][1]) + old["S"][at:]
    with pytest.raises(ValueError, match=rf"resume: the stream's saved component state holds {len(old['S'])} "
                                         rf"values, this run's components hold {len(saved['state']['S'])} \(.*"
                                         rf"gyro {widths[g][1]}.*\): the gyro's state held 14 values in the lgvi "
                                         rf"that saved it, {widths[g][1]} in this one; a stream resumes only with "
                                         r"the components' state layout it was saved with"):
        resume(old)
    assert saved["state"]["S_widths"] == widths
    other = dict(saved["state"], S=saved["state"]["S"] + [0.0],  # any component, its widths saved
                 S_widths=[list(w) for w in widths])
    other["S_widths"][-1][1] += 1
    name = widths[-1][0]
    with pytest.raises(ValueError, match=rf"resume: the stream's saved state of component {len(widths) - 1} "
                                         rf"\({name}\) holds {widths[-1][1] + 1} values, this run's \({name}\) "
                                         rf"holds {widths[-1][1]}; a stream resumes only with the components' "
                                         r"state layout"):
        resume(other)
    with pytest.raises(ValueError, match=r"resume: the stream's saved signal bus holds \d+ values, this run's \d+; "
                                         r"a stream resumes only"):
        resume(dict(saved["state"], bus=saved["state"]["bus"][:-1]))
    resume(saved["state"])                                  # the stream as saved resumes


SENTINEL = -1.2345e300


def test_the_records_are_allocated_uninitialised_and_the_loop_writes_every_value(monkeypatch):
    """``signals`` is allocated uninitialised (``Field.filled``): the loop writes every value of each
    complete entry (the grid's columns at its first step; each off-grid slot at its writer's step, or
    NaN first where the period does not divide the grid). With the buffer filled with a sentinel, none
    survives, and the records are bit for bit those of a zeroed buffer: writers off the grid whose
    periods divide it (2 in 4) and do not (3 in 4, 2 and 3 in 5), the grid only, a Python
    controller's chunks of 3 steps across entries of 4, and a run a filter stops (its partial result)."""
    from lgvi.control import RotationPD
    from lgvi.fsw import MEKF
    from lgvi.systems import Field

    kw = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=60)
    pd = dict(controller=RotationPD(0.004, 0.04, target=R_TARGET), control_period=0.3, rate=1.0)
    sat, fsw = _sensed()
    runs = {"writers off the grid of 5": (sat, fsw, 5), "of 4": (sat, fsw, 4),
            "the grid only": (sat, _sensed(record_rate="grid")[1], 5),
            "a Python controller": (sat, FlightSoftware(guidance=InertialPointing(R_TARGET), **pd), 4)}
    zeroed = {name: lgvi.simulate(s, np.eye(3), fsw=f, save_every=se, **kw) for name, (s, f, se) in runs.items()}

    def diverging(max_variance):
        """The MEKF with no update: its attitude variance grows by arw^2 * 0.2 s a call past max_variance."""
        return FlightSoftware(estimator=MEKF(rate=0.2, arw=1e-2, rrw=1e-5, P0=[1e-6] * 6, max_variance=max_variance),
                              guidance=InertialPointing(R_TARGET), control=MRPControl(K=0.004, P=0.04, rate=0.3),
                              actuators=RWMotorTorque(), rate=1.0)

    whole = lgvi.simulate(sat, np.eye(3), fsw=diverging(1e6), save_every=4, **kw)
    filled = []

    def sentinel(self, n):
        if self.name == "signals":
            filled.append(self.shape)
        return np.full((n,) + self.shape, SENTINEL, dtype=self.dtype)

    monkeypatch.setattr(Field, "empty", sentinel)
    for name, (s, f, se) in runs.items():
        tr = lgvi.simulate(s, np.eye(3), fsw=f, save_every=se, **kw)
        assert not np.any(tr.signal_data == SENTINEL), name
        assert np.array_equal(tr.signal_data, zeroed[name].signal_data, equal_nan=True), name
        assert np.array_equal(tr.R, zeroed[name].R), name
    assert len(filled) == len(runs) and all(shape[0] > 0 for shape in filled)     # the sentinel was there
    with pytest.raises(lgvi.ComponentError, match="mekf") as err:
        lgvi.simulate(sat, np.eye(3), fsw=diverging(3e-4), save_every=4, **kw)
    part = err.value.trajectory
    assert 0 < part.signal_data.shape[0] < whole.signal_data.shape[0]
    assert not np.any(part.signal_data == SENTINEL)
    assert np.array_equal(part.signal_data, whole.signal_data[:part.signal_data.shape[0]], equal_nan=True)
