"""The CubeSat ADCS mission of issue 28 (``examples/cubesat_mission.toml``): the loop fixes it
showed, a short run of the file, its summary and figures, and the Monte Carlo's member equal to
its lone run."""

from __future__ import annotations

import numpy as np

import lgvi
from lgvi.environment import CircularOrbit
from lgvi.fsw import MEKF, FlightSoftware
from lgvi.spacecraft import Gyro, Spacecraft, StarTracker


def test_star_tracker_excluded_at_its_first_sample_with_an_mekf():
    """A star tracker whose boresight is inside the Earth's limb at t = 0 measures nothing then; with
    an MEKF in the run the loop used to start its time st_time at the MEKF's NaN ("nothing yet"), so
    the tracker 'wrote' a value that is not finite and the run stopped at step 0. It must run, take
    no measurement while excluded, and the filter must use the first one once the Earth leaves the
    field of view (the body turns at 0.05 rad/s: ~26 s to clear the limb plus 0.1 rad)."""
    orbit = CircularOrbit(6878137.0, np.radians(97.4))
    r0 = np.asarray(orbit.position_velocity(np.array([0.0]))[0]).reshape(3)
    z = -r0 / np.linalg.norm(r0)                                  # boresight (body z) at nadir
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    R0 = np.column_stack([x, np.cross(z, x), z])
    st = StarTracker(rate=0.5, sigma_cross=1e-5, sigma_about=1e-4, earth_exclusion=0.1, seed=1)
    sat = Spacecraft([0.18, 0.14, 0.06], orbit=orbit, sensors=[Gyro(rate=0.5, arw=1e-5, seed=1), st])
    est = MEKF(rate=0.5, arw=1e-5, rrw=0.0, star_tracker=True, R0=lgvi.so3.exp([2e-3, -1e-3, 1e-3]) @ R0,
               P0=[1e-5] * 3 + [1e-10] * 3)
    tr = lgvi.simulate(sat, R0, omega0=[0.05, 0.0, 0.0], h=0.1, steps=600, fsw=FlightSoftware(estimator=est),
                       save_every=5)
    valid = tr.signals["st_valid"].ravel()
    assert valid[0] == 0.0 and valid[-1] == 1.0
    first = int(np.argmax(valid == 1.0))
    assert 20.0 < tr.signal_t[first] < 40.0
    assert np.all(np.isfinite(tr.signals["st_time"]))
    err = np.linalg.norm(tr.signals["est_error"], axis=1)
    assert err[first - 1] > 1e-3                      # the 2.4e-3 rad first estimate, not corrected yet
    assert err[-1] < 2e-4                             # corrected by the star tracker (1e-5 rad across)
