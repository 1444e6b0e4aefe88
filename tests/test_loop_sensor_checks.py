"""A built-in sensor that writes a value that is not finite stops the loop, naming it, the step and
the time (issue 27 part 7; round 10: the sensor and estimator kinds test their own writes,
``lgvi._kernels.finite``, and the loop runs no other test after them: ``loop_kernels.run_one``)."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi.fsw import MEKF, FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
from lgvi.spacecraft import Gyro, Spacecraft, StarTracker

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
KW = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=40, save_every=1)


def _run(gyro, tracker):
    """The member of ``benchmarks/bench_loop_sensors.py --member`` (a gyro, a star tracker and the MEKF
    at 2 Hz, MRP control on the estimate at 1 Hz) with the sensors given; the MEKF's model of the star
    tracker is the sane one (its noise covariance from the sane sigmas)."""
    sc = Spacecraft([0.18, 0.14, 0.06], wheels=lgvi.ReactionWheels(PYRAMID, 1e-4, max_torque=0.004),
                    sensors=[gyro, tracker])
    est = MEKF(rate=0.5, arw=1e-4, rrw=1e-5, star_tracker=_tracker(), P0=[0.03 ** 2] * 3 + [3e-4 ** 2] * 3)
    fsw = FlightSoftware(estimator=est, guidance=InertialPointing(lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))),
                         control=MRPControl(K=0.004, P=0.04), actuators=RWMotorTorque(), rate=1.0)
    return lgvi.simulate(sc, np.eye(3), fsw=fsw, **KW)


def _gyro(**kw):
    return Gyro(**{"rate": 0.5, "arw": 1e-4, "rrw": 1e-5, "bias": [2e-4, -1e-4, 5e-5], "seed": 7, **kw})


def _tracker(**kw):
    return StarTracker(**{"rate": 0.5, "sigma_cross": 5e-5, "sigma_about": 4e-4, "seed": 7, **kw})


def test_the_sane_member_runs_and_records_finite_measurements():
    """The control of the tests below: the same member with sane noise runs its 40 steps."""
    tr = _run(_gyro(), _tracker())
    assert np.isfinite(tr.records["gyro_B"].values).all() and np.isfinite(tr.records["st_q"].values).all()


@pytest.mark.parametrize(("kw", "step"), [({"bias": [1e308, 0.0, 0.0], "scale": 10.0}, 0),
                                          ({"rrw": 1e300, "scale": 1e10}, 5)])
def test_a_gyro_whose_output_overflows_stops_the_run_naming_it(kw, step):
    """A bias of 1e308 rad/s scaled by 10 overflows at the first sample (step 0); a rate random walk
    of 1e300 rad/s^1.5 with a scale factor of 1e10 leaves the first sample finite (its walk starts at
    zero) and overflows at the second (step 5, t = 0.5 s), the walk's first step times 1e10. The run
    stops there naming the gyro, and keeps the steps before it, equal to the same run's up to there."""
    with pytest.raises(lgvi.ComponentError, match=r"gyro .*not finite") as err:
        _run(_gyro(**kw), _tracker())
    e = err.value
    assert e.component == "gyro" and e.status == 1 and e.step == step and e.time == pytest.approx(0.1 * step)
    if step:
        sane = _run(_gyro(**{**kw, "rrw": 1e-5}), _tracker())
        part = e.trajectory
        assert part.meta.get("partial") and len(part.t) == step + 1
        assert np.array_equal(part.R, sane.R[:step + 1])


def test_a_star_tracker_whose_noise_overflows_stops_the_run_naming_it():
    """Noise about the boresight of 1e308 rad: the measured rotation's angle overflows and its
    quaternion is not finite at the first sample (step 0)."""
    with pytest.raises(lgvi.ComponentError, match=r"star_tracker .*not finite") as err:
        _run(_gyro(), _tracker(sigma_about=1e308))
    assert err.value.component == "star_tracker" and err.value.status == 1 and err.value.step == 0
