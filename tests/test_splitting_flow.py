"""The exact free flow's Jacobi functions by the descending Landen transformation
(``splitting_kernels.jacobi_sncn``): values against SciPy and the AGM amplitude, the branch count,
and the round-off of many flows (|Pi| and the energy do not drift)."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

import lgvi
from lgvi._kernels.splitting_kernels import jacobi_am, jacobi_sncn


@numba.njit
def _sncn(u, m, m1, ws):
    return jacobi_sncn(u, m, m1, ws)


@numba.njit
def _am(u, m, m1, ws):
    return jacobi_am(u, m, m1, ws)


def test_sncn_matches_scipy_and_the_branch_of_the_amplitude():
    """sn, cn to 2e-14 (|u| <= 10) against scipy.special.ellipj (accurate for m <= 0.999), and j with
    am(u) = r + j pi, |r| <= pi/2 (away from the branch points r = +-pi/2 where both j fit)."""
    from scipy.special import ellipj

    rng = np.random.default_rng(11)
    ws = np.zeros(64)
    for m in list(rng.uniform(0.0, 0.999, 60)) + [0.0, 1e-20, 1e-9, 0.5]:
        for u in rng.uniform(-10.0, 10.0, 25):
            s, c, j = _sncn(u, m, 1.0 - m, ws)
            sn, cn, _, ph = ellipj(u, m)
            assert abs(s - sn) < 2e-14 and abs(c - cn) < 2e-14, (m, u, s, sn, c, cn)
            r = ph - round(ph / math.pi) * math.pi
            if abs(abs(r) - 0.5 * math.pi) > 1e-9:
                assert j == round(ph / math.pi), (m, u, j, ph)


def test_sncn_near_the_separatrix_matches_the_agm_amplitude():
    """m -> 1 (m1 down to 1e-15; SciPy's ellipj is not accurate there): sin and cos of the AGM's
    am(u | m) (jacobi_am, an independent algorithm) to 1e-13."""
    ws = np.zeros(64)
    rng = np.random.default_rng(5)
    for m1 in (1e-3, 1e-6, 1e-9, 1e-12, 1e-15):
        for u in rng.uniform(-20.0, 20.0, 25):
            s, c, j = _sncn(u, 1.0 - m1, m1, ws)
            ph = _am(u, 1.0 - m1, m1, ws)
            assert abs(s - math.sin(ph)) < 1e-13 and abs(c - math.cos(ph)) < 1e-13, (m1, u)
            assert s * s + c * c == pytest.approx(1.0, abs=4e-16)


@pytest.mark.parametrize("moments, Pi0, h", [
    ([0.0433, 0.0418, 0.0067], [0.003464, -0.002508, 0.000603], 6.0),    # the CubeSat
    ([1.0, 2.0, 3.0], [0.3, 2.0, 0.6], 0.7),
    ([1.0, 2.0, 3.0], [2.0, 0.3, 0.6], 0.7),
])
def test_many_flows_keep_the_invariants(moments, Pi0, h):
    """30000 exact flows (no torque): |Pi|^2 and 2E stay within 2e-12 (relative) of the start, and the
    attitude agrees with one flow over the whole time to 5e-8 rad. Measured (amplitudes divided per
    flow; before that, with quotients rounded once per run; with the AGM amplitude):
    |dL^2| 5e-15, 2.1e-14, 1.8e-14 (1.3e-13, 4.4e-13, 1.7e-14; 1.4e-14, 4.3e-13, 1.9e-14),
    attitude 4.2e-12, 7.2e-10, 3.9e-10 rad (6.5e-10, 1.1e-8, 3.7e-10; 1.8e-9, 1.1e-8, 4.1e-10); without
    the final projection of (sn, cn) onto the circle |Pi|^2 drifts linearly, to about 5e-12 here."""
    body = lgvi.RigidBody(moments)
    J = np.array(moments)
    N = 30000
    tr = lgvi.simulate(body, np.eye(3), Pi0, h=h, steps=N, save_every=N // 10, scheme="splitting", order=2,
                       composition="strang")
    L2 = (tr.Pi ** 2).sum(axis=1)
    E = (tr.Pi ** 2 / J).sum(axis=1)
    assert np.abs(L2 / L2[0] - 1.0).max() < 2e-12
    assert np.abs(E / E[0] - 1.0).max() < 2e-12
    R1, _ = lgvi.splitting.free_flow(body, np.eye(3), Pi0, h * N)
    assert np.linalg.norm(lgvi.so3.log(R1.T @ tr.R[-1])) < 5e-8


@pytest.mark.parametrize("Pi1", [0.3, 0.6 / math.sqrt(3.0) * (1.0 - 1e-3), 0.6 / math.sqrt(3.0) * (1.0 + 1e-3),
                                 0.6 / math.sqrt(3.0) * (1.0 - 1e-6), 0.6 / math.sqrt(3.0) * (1.0 + 1e-6)])
def test_many_flows_near_the_separatrix_do_not_drift(Pi1):
    """J = (1, 2, 3), Pi = (Pi1, 2, 0.6): the separatrix is Pi1^2 = 0.6^2/3 (2E J2 = |Pi|^2); 0.3 gives
    m = 0.97, the others m1 ~ 1e-3 and 1e-6 on both sides (the orbits about the smallest and the largest
    moment's axis). Over 100000 exact flows |Pi|^2 and 2E stay within 2e-13 (relative) of the start: an
    unbiased round-off of eps/2 a flow walks to sqrt(N) eps/2 = 3.5e-14, a bias of eps/100 a flow reaches
    2.2e-13. The amplitudes and m1 used to carry a rounding error that is the same every flow (the
    body's ratios rounded once per run; m1 as a difference of two rounded squares, its error times 1/m1):
    1.5e-12, 1.5e-12, 3.3e-13, 7.7e-13 and 1.7e-13 here (the AGM code before: 1.3e-12, 5.4e-13, 3e-15,
    2e-13, 7e-15); now at most 4e-14. At Pi1 = 0.3 the attitude agrees with one flow over the whole time
    to 3e-8 rad (6.2e-9; 2.6e-7 before, 1.3e-8 with the AGM code)."""
    moments = [1.0, 2.0, 3.0]
    Pi0 = [Pi1, 2.0, 0.6]
    body = lgvi.RigidBody(moments)
    J = np.array(moments)
    N, h = 100000, 0.7
    tr = lgvi.simulate(body, np.eye(3), Pi0, h=h, steps=N, save_every=N // 10, scheme="splitting", order=2,
                       composition="strang")
    L2 = (tr.Pi ** 2).sum(axis=1)
    E = (tr.Pi ** 2 / J).sum(axis=1)
    assert np.abs(L2 / L2[0] - 1.0).max() < 2e-13
    assert np.abs(E / E[0] - 1.0).max() < 2e-13
    if Pi1 == 0.3:
        R1, _ = lgvi.splitting.free_flow(body, np.eye(3), Pi0, h * N)
        assert np.linalg.norm(lgvi.so3.log(R1.T @ tr.R[-1])) < 3e-8
