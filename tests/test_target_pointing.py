"""TargetPointing's reference acceleration: the derivative of its own reference rate.

The compiled guidance (``lgvi._kernels.fsw_components.target_frame``) is called on a bus that holds
a Kepler orbit's exact position and velocity; ``domega_ref_N`` must be the time derivative of the
``omega_ref_N`` it writes (central differences, whose error is O(dt^2)), near the ground station
and far from it.
"""

from __future__ import annotations

import datetime as dt
from types import SimpleNamespace

import numpy as np
import pytest

from lgvi._kernels.fsw_components import target_frame
from lgvi.environment import KeplerOrbit
from lgvi.fsw import TargetPointing

ORBIT = KeplerOrbit(6.878e6, 0.01, np.radians(97.4), 0.3, 1.0, 0.2)
EPOCH = dt.datetime(2026, 3, 20, 6)
W = np.array([0, 3, 6, 15, 18], dtype=np.int64)    # r_N, v_N, R_ref, omega_ref_N, domega_ref_N


def _guidance(target_ecef, **kw):
    g = TargetPointing(target_ecef, **kw)
    g.setup(SimpleNamespace(spacecraft=SimpleNamespace(epoch=EPOCH, orbit=ORBIT)))
    return g.params()


def _reference(p, t):
    bus = np.zeros(21)
    r, v = ORBIT.position_velocity(t)
    bus[0:3], bus[3:6] = r, v
    assert target_frame(t, bus, p, np.zeros(0), W) == 0
    return bus[6:15].reshape(3, 3), bus[15:18].copy(), bus[18:21].copy()


@pytest.mark.parametrize("t", [0.0, 1234.5, 4000.0])
def test_the_reference_acceleration_is_the_derivative_of_the_reference_rate(t):
    p = _guidance([4.0e6, 1.0e6, 4.8e6])           # a station at mid-latitude
    assert p[10] == ORBIT.mu
    R, omega, domega = _reference(p, t)
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-14)
    assert np.linalg.norm(domega) > 0
    errors = []
    for dt_ in (2.0, 1.0):
        fd = (_reference(p, t + dt_)[1] - _reference(p, t - dt_)[1]) / (2 * dt_)
        errors.append(np.linalg.norm(fd - domega))
    assert errors[1] < 1e-5 * np.linalg.norm(domega)
    assert 3.0 < errors[0] / errors[1] < 5.0              # second order: the difference converges to it


def test_mu_is_the_orbits_unless_given():
    assert _guidance([6.378e6, 0.0, 0.0], mu=3.986e14)[10] == 3.986e14
    with pytest.raises(ValueError, match="mu"):
        TargetPointing([6.378e6, 0.0, 0.0], mu=-1.0)
