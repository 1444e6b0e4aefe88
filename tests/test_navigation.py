"""SimpleNav (lgvi.fsw.SimpleNav, code 402): Basilisk's simpleNav attitude and rate channels in the
compiled loop. The navigation a run hands its controller is checked against the walk rebuilt in
NumPy from the same random numbers (lgvi._kernels.random.normals), near the identity and near a
rotation by pi; the flight software reads it; bad arguments name themselves."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi._kernels.random import normals
from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, SimpleNav
from lgvi.spacecraft import Spacecraft


def _walk(nav: SimpleNav, runs: int) -> np.ndarray:
    """The errors (a, d) after each run, (runs, 6): Basilisk's GaussMarkov with identity propagation."""
    n = normals(float(nav.seed), nav.stream, 0, 6 * runs).reshape(runs, 6)
    sigma = np.concatenate([nav.attitude_noise, nav.rate_noise])
    bound = np.concatenate([nav.attitude_bound, nav.rate_bound])
    e, out = np.zeros(6), np.empty((runs, 6))
    for k in range(runs):
        e = e + sigma * n[k]
        e = np.where((bound > 0) & (np.abs(e) > bound), np.copysign(bound, e), e)
        out[k] = e
    return out


@pytest.mark.parametrize("start", ["identity", "near pi"])
def test_simple_nav_is_the_truth_with_basilisks_walk(start):
    R0 = np.eye(3) if start == "identity" else Rotation.from_rotvec((np.pi - 1e-9) * np.array([0.6, 0.0, 0.8])).as_matrix()
    nav = SimpleNav([2e-5, 1e-5, 3e-5], 1e-6, attitude_bound=[5e-5, 0.0, 6e-5], rate_bound=[2e-6, 2e-6, 0.0],
                    seed=5, rate=0.2)
    sat = Spacecraft([0.15, 0.12, 0.05])
    tr = lgvi.simulate(sat, R0, omega0=[1e-3, -2e-3, 5e-4], h=0.1, steps=400, fsw=FlightSoftware(estimator=nav),
                       save_every=2)
    sig = tr.signals
    e = _walk(nav, len(tr.signal_t))                 # the nav runs every 0.2 s: once per record
    a, d = e[:, :3], e[:, 3:]
    phi = 4.0 * np.arctan(np.linalg.norm(a, axis=1))[:, None] * a / np.linalg.norm(a, axis=1)[:, None]
    np.testing.assert_allclose(sig["est_error"], -phi, rtol=0, atol=1e-15)
    R = tr.R[: len(tr.signal_t)]
    R_est = sig["R_est"].reshape(-1, 3, 3)
    np.testing.assert_allclose(R_est, R @ Rotation.from_rotvec(phi).as_matrix(), rtol=0, atol=1e-14)
    np.testing.assert_allclose(sig["omega_est"] - tr.omega[: len(tr.signal_t)], d, rtol=0, atol=1e-17)
    # the bounds hold, clamped as Basilisk clamps (values at the bound), and an unbounded axis walks past
    assert np.abs(a[:, 0]).max() == 5e-5 and np.abs(a[:, 1]).max() > 5e-5 and np.abs(d[:, 2]).max() > 2e-6
    # Basilisk's addMRP: [B'N] = C(a) [BN] with C the MRP's DCM; lgvi's R is [BN]^T
    s = a[7]
    s2 = s @ s
    S = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    C = np.eye(3) + (8 * S @ S - 4 * (1 - s2) * S) / (1 + s2) ** 2
    np.testing.assert_allclose(R_est[7], (C @ R[7].T).T, rtol=0, atol=1e-14)


def test_the_controller_reads_the_navigation():
    """MRP feedback on a SimpleNav points the navigation: the truth's error is the navigation's."""
    nav = SimpleNav(1e-5, 0.0, attitude_bound=1e-4, seed=2, rate=0.5)
    sat = Spacecraft([0.15, 0.12, 0.05], wheels=lgvi.ReactionWheels(np.eye(3), 2e-5, max_torque=2e-3))
    fsw = FlightSoftware(estimator=nav, guidance=InertialPointing(np.eye(3)), control=MRPControl(K=0.004, P=0.04),
                         actuators=lgvi.fsw.RWMotorTorque(), rate=0.5)
    tr = lgvi.simulate(sat, np.eye(3), omega0=np.zeros(3), h=0.1, steps=3000, fsw=fsw, save_every=5)
    truth = np.linalg.norm(Rotation.from_matrix(tr.R).as_rotvec(), axis=1)
    k = len(tr.t) // 2
    # the body follows the navigation's error (up to 4e-4 rad) instead of staying at the identity
    assert 5e-5 < truth[k:].mean() < 4e-4
    assert np.abs(np.linalg.norm(tr.signals["est_error"], axis=1)).max() <= 4 * np.arctan(np.sqrt(3) * 1e-4) + 1e-15


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(attitude_noise=-1e-5), ValueError, r"attitude_noise must be >= 0"),
    (dict(rate_noise=[1e-6, 1e-6]), ValueError, r"rate_noise"),
    (dict(attitude_bound="big"), TypeError, r"attitude_bound"),
    (dict(seed=1.5), TypeError, r"seed must be an integer"),
    (dict(stream=-1), ValueError, r"stream must be an integer in \[0, 2\^53\)"),
])
def test_bad_arguments(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        SimpleNav(**kwargs)
