"""The spacecraft loop's set-up (``LoopRun``): the copies of the user's components, the layout of
the bus and of the records, and that nothing of a run is kept on the user's objects."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi.fsw import MEKF, FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
from lgvi.spacecraft import Gyro, Spacecraft, StarTracker
from lgvi.systems.spacecraft import LoopRun, signal_width

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
R_TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))


def _member(**fsw_kw):
    """The sensors + MEKF member of ``benchmarks/bench_loop_sensors.py --member``."""
    gyro = Gyro(rate=0.5, arw=1e-4, rrw=1e-5, bias=[2e-4, -1e-4, 5e-5], seed=7)
    st = StarTracker(rate=0.5, sigma_cross=5e-5, sigma_about=4e-4, seed=7)
    est = MEKF(rate=0.5, arw=1e-4, rrw=1e-5, star_tracker=st, P0=[0.03 ** 2] * 3 + [3e-4 ** 2] * 3)
    sc = Spacecraft([0.18, 0.14, 0.06], wheels=lgvi.ReactionWheels(PYRAMID, 1e-4, max_torque=0.004),
                    sensors=[gyro, st])
    fsw = FlightSoftware(estimator=est, guidance=InertialPointing(R_TARGET), control=MRPControl(K=0.004, P=0.04),
                         actuators=RWMotorTorque(), rate=1.0, **fsw_kw)
    return sc, fsw


def _run(sc, fsw, **kw):
    kw = dict(h=0.1, steps=120, save_every=10) | kw
    return LoopRun(sc, np.eye(3), omega0=[0.01, -0.02, 0.015], fsw=fsw, **kw)


def test_a_run_sees_each_component_as_it_is_now_and_leaves_it_as_given():
    """Nothing of a run stays on the user's objects: a second run sees the attributes changed since the
    first (the gyro's noise, the star tracker's about-boresight noise in the filter's row, the filter's
    first estimate), and the filter told to take the spacecraft's star tracker still says so."""
    sc, fsw = _member()
    gyro, st = sc.sensors
    est = fsw.estimator[0]
    first = _run(sc, fsw)
    gyro.arw = 2e-4
    st.sigma_about = 8e-4
    est.R0 = lgvi.so3.exp(np.array([0.01, 0.0, 0.0]))
    second = _run(sc, fsw)
    g, m = first.names.index("gyro"), first.names.index("mekf")
    p1, p2 = (r.P[r.po[g]:r.po[g + 1]] for r in (first, second))
    assert p1[3] == 1e-4 and p2[3] == 2e-4 and p2[-2] == 2e-4 / np.sqrt(0.5)     # arw and its per-sample sigma
    q1, q2 = (r.P[r.po[m]:r.po[m + 1]] for r in (first, second))
    assert q1[3] == 4e-4 and q2[3] == 8e-4 and q2[28] == pytest.approx(8e-4 ** 2, rel=1e-15)   # noise, R_m[2, 2]
    s1, s2 = (r.S[r.so[m]:r.so[m + 1]] for r in (first, second))
    assert np.array_equal(s1[:4], [0.0, 0.0, 0.0, 1.0])
    assert np.allclose(s2[:4], [np.sin(0.005), 0.0, 0.0, np.cos(0.005)], rtol=0, atol=1e-16)
    found = MEKF(rate=0.5, arw=1e-4, rrw=1e-5, star_tracker=True, P0=[1e-4] * 6)
    fsw2 = FlightSoftware(estimator=found, guidance=InertialPointing(R_TARGET), control=MRPControl(K=0.004, P=0.04),
                          actuators=RWMotorTorque(), rate=1.0)
    third = _run(sc, fsw2)
    assert found.star_tracker is True                      # the run's copy took the spacecraft's
    assert third.P[third.po[m] + 3] == 8e-4


@pytest.mark.parametrize("save_every", [1, 3, 4, 10])
def test_record_layout_and_the_fast_rows(save_every):
    """The record layout's columns follow each other; each column reads its signal's bus slot; the
    off-grid records' kernel rows are those of ``meta["signal_fast"]`` grouped by period (stably), each
    with the row after its group's last; the width is that of the meta."""
    order = ["sigma_BR", "gyro_B", "R_ref", "torque_request_B", "wheel_command", "omega_BR_B", "P_diag"]
    sc, fsw = _member(record=order)
    fsw.control[0].rate = 0.3                            # the law every 3 steps, the gyro every 5, the guidance 10
    run = _run(sc, fsw, steps=120, save_every=save_every)
    col = 0
    for (name, start, size), want in zip(run.record_layout, order):
        assert name == want and start == col
        assert run.sig_idx[start:start + size].tolist() == list(range(run.offsets[name], run.offsets[name] + size))
        col += size
    assert len(run.sig_idx) == col
    fast = run.meta["signal_fast"]
    periods = run.meta["signal_periods"]
    assert [row[0] for row in fast] == [n for n in order if periods[n] % save_every]
    expect = sorted(([p, run.offsets[name], size, c, slots] for name, c, size, p, slots in fast if size),
                    key=lambda r: r[0])
    rows = run.sig_fast.tolist()
    assert [r[:5] for r in rows] == expect
    for f, r in enumerate(rows):
        last = max(i for i, q in enumerate(rows) if q[0] == r[0])
        assert r[5] == r[6] == 0 and r[7] == last + 1
    assert run.system.records[-1].shape == (signal_width(run.meta),)
    assert signal_width(run.meta) == col + sum(size * slots for _, _, size, _, slots in fast)
