"""Attitude estimation (issue 27): TRIAD and Davenport's q-method against SciPy, and the MEKF as a
compiled component on truth trajectories from ``lgvi.simulate`` (statistics over 100 seeded
members: NEES in its 95% chi-square band, convergence from 10 degrees, 3-sigma coverage).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

import lgvi
from lgvi import components
from lgvi.fsw import MEKF, davenport, triad
from lgvi.fsw._drive import run_components
from lgvi._kernels.estimation_components import STATE_SIZE
from lgvi.spacecraft import Gyro, StarTracker

from estimation_cases import (ARW, BODY, H, MEMBERS, POINTING, RRW, ST_ABOUT, ST_CROSS, STEPS, TUMBLING, member,
                              nees, truth)

# ------------------------------------------------------------------------------------------------
# static attitude determination
# ------------------------------------------------------------------------------------------------
ROTATIONS = [Rotation.identity(), Rotation.from_rotvec([1e-9, -2e-9, 3e-9]),
             Rotation.from_rotvec(np.array([2.0, -1.0, 2.0]) / 3.0 * (math.pi - 1e-7)),
             Rotation.from_rotvec([0.0, 0.0, math.pi]), Rotation.from_rotvec([0.7, -1.9, 0.4])]


@pytest.mark.parametrize("rot", ROTATIONS, ids=["identity", "near-identity", "near-pi", "pi", "generic"])
def test_triad_equals_scipy_align_vectors_with_a_primary_vector(rot):
    rng = np.random.default_rng(1)
    for _ in range(20):
        r = rng.normal(size=(2, 3)) * rng.uniform(0.1, 10.0, size=(2, 1))
        b = rot.inv().apply(r) + rng.normal(scale=1e-3, size=(2, 3))          # noisy body measurements
        ref, _ = Rotation.align_vectors(r, b, weights=[np.inf, 1.0])
        np.testing.assert_allclose(triad(b, r), ref.as_matrix(), rtol=0, atol=1e-12)
    exact = rot.inv().apply(r)
    np.testing.assert_allclose(triad(exact, r), rot.as_matrix(), rtol=0, atol=1e-12)


@pytest.mark.parametrize("rot", ROTATIONS, ids=["identity", "near-identity", "near-pi", "pi", "generic"])
def test_davenport_equals_scipy_align_vectors(rot):
    rng = np.random.default_rng(2)
    for n in (2, 3, 7):
        r = rng.normal(size=(n, 3))
        b = rot.inv().apply(r) + rng.normal(scale=1e-2, size=(n, 3))
        w = rng.uniform(0.1, 3.0, size=n)
        ref, _ = Rotation.align_vectors(r, b, weights=w)
        np.testing.assert_allclose(davenport(b, r, w), ref.as_matrix(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(davenport(rot.inv().apply(r), r), rot.as_matrix(), rtol=0, atol=1e-12)


def test_static_solvers_refuse_parallel_vectors():
    with pytest.raises(ValueError, match=r"(?s)body must hold two vectors that are not parallel.*TRIAD"):
        triad([[1.0, 0.0, 0.0], [2.0, 1e-12, 0.0]], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match=r"reference must hold two vectors that are not parallel"):
        triad([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [[0.0, 0.0, 1.0], [0.0, 0.0, -3.0]])
    with pytest.raises(ValueError, match=r"undetermined"):
        davenport([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], [[0.0, 1.0, 0.0], [0.0, 2.0, 0.0]])


# ------------------------------------------------------------------------------------------------
# the MEKF
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tumbling():
    return truth(TUMBLING)


@pytest.fixture(scope="module")
def pointing():
    return truth(POINTING)


@pytest.fixture(scope="module")
def tumbling_fine():
    return truth(TUMBLING, sub=10)


@pytest.mark.parametrize("case, output", [("tumbling", "mean"), ("pointing", "mean"), ("tumbling_fine", "rate"),
                                          ("pointing", "rate")])
def test_mekf_nees_in_the_chi_square_band(case, output, request):
    """The NEES of (attitude error, bias error), averaged over 100 members, against chi-square(600)/100,
    on a tumble at 0.28 rad/s and an Earth-pointing attitude, over the filter's 1200 outputs.

    A consistent filter puts the member-averaged NEES inside the two-sided 95% band 95% of the time
    *on average*: "at least 95%" (the issue's words) would fail half the runs of a perfect filter.
    Because the errors (the bias's above all) are correlated over tens of seconds, the fraction over
    one run scatters: 0.92-0.97 over 8 seed sets of each case (``python benchmarks/bench_estimation.py
    --nees 8``). The test asks for >= 90% inside, and for the mean NEES over the run within 5% of 6
    (measured: 5.84-6.12 over those seed sets; a process noise off by a factor 2 moves it by 20% or
    more).

    With the gyro's ``"rate"`` output (rates at the samples, propagated by the trapezoid) the same
    holds (measured: inside 0.907 and 0.925, mean 5.78 and 5.79; slightly conservative, since the
    trapezoid averages each sample's noise over two steps: 4.5 against the modelled 5 sample
    variances per star tracker interval), on a truth the LGVI integrates with steps of ``H / 10``
    for the tumble: at the filter's own step ``H`` the LGVI's sampled rates and attitudes differ
    by its O(h^3) local error, which at 0.28 rad/s the trapezoid reads as a wandering bias and the
    filter does not model (inside 0.53-0.61, mean 6.6-6.7 over two seed sets).
    """
    tr = request.getfixturevalue(case)
    total = np.zeros(STEPS)
    for seed in range(MEMBERS):
        e, P = member(tr, 1000 + seed, att_sd=math.radians(1.0), output=output)
        total += nees(e, P)
    avg = total / MEMBERS
    lo, hi = stats.chi2.ppf([0.025, 0.975], 6 * MEMBERS) / MEMBERS
    inside = np.mean((avg >= lo) & (avg <= hi))
    assert inside >= 0.90, (inside, avg.mean(), lo, hi)
    assert abs(avg.mean() / 6.0 - 1.0) < 0.05, avg.mean()


def test_mekf_converges_from_ten_degrees_and_its_three_sigma_bounds_cover_the_error(tumbling):
    """From a 10-degree prior (initial errors of 10 degrees per axis, drawn from it).

    With the star tracker (a linear update): the error lies inside the filter's own 3-sigma bounds
    at >= 99% of all outputs from the first (99.7% for a consistent filter).

    With the magnetometer (2 Hz) and the fine sun sensor (1 Hz) only, the first updates are far from
    linear and, as any EKF's, leave the filter overconfident for a while (over 40 members the RMS of
    error / sigma is 4.5 at 30 s, 2.1 at 60 s, 1.3 at 105 s and 0.97-1.05 from 150 s to 300 s; from a
    1-degree prior it is 1.0 throughout): after 30 s the attitude sigma is below 0.5 degree and the
    error below 3 degrees (converged from 10), and from 150 s on the error matches its sigma (RMS of
    error / sigma over members, axes and outputs within 15% of 1) and its 3-sigma bounds cover it at
    >= 99% of the outputs.
    """
    covered = []
    for seed in range(20):
        e, P = member(tumbling, 2500 + seed, att_sd=math.radians(10.0))
        covered.append(np.abs(e) <= 3 * np.sqrt(np.einsum("nii->ni", P)))
    assert np.mean(covered) >= 0.99
    long = truth(TUMBLING, steps=3000)
    covered, late, start = [], [], []
    for seed in range(20):
        e, P = member(long, 2000 + seed, att_sd=math.radians(10.0), sensors="vectors")
        sd = np.sqrt(np.einsum("nii->ni", P))
        err0 = np.random.default_rng(2000 + seed).normal(size=(2, 3))[1] * math.radians(10.0)   # member's draw
        start.append(np.linalg.norm(err0))
        assert sd[300:, :3].max() < math.radians(0.5)
        assert np.linalg.norm(e[300:, :3], axis=1).max() < math.radians(3.0)
        late.append(e[1500:, :3] / sd[1500:, :3])
        covered.append(np.abs(e[1500:]) <= 3 * sd[1500:])
    assert np.median(start) > math.radians(10.0)           # a 10-degree start, per axis
    assert abs(math.sqrt(np.mean(np.square(late))) - 1.0) < 0.15
    assert np.mean(covered) >= 0.99


def test_mekf_propagation_without_noise_exact_or_second_order(tumbling):
    """With a noiseless, bias-free gyro and no update: the mean-rate gyro propagated as constant
    follows the truth to round-off (log(R_prev^T R) / dt is the truth's increment); rates at the
    samples propagated by the trapezoid follow it to second order (the error over 120 s falls by 4
    when h is halved: 3e-3 rad at h = 0.1 s)."""
    R0 = tumbling["R"][0].reshape(3, 3)

    def error(output, tr, h):
        comps = [Gyro(rate=h, output=output), MEKF(rate=h, arw=ARW, rrw=RRW, R0=R0, P0=np.ones(6) * 1e-6,
                                                  gyro_output=output)]
        return np.abs(run_components(comps, tr, h, record=["est_error"]).records["est_error"]).max()

    assert error("mean", tumbling, H) < 1e-12
    fine = lgvi.simulate(BODY, R0, omega0=TUMBLING, h=H / 2, steps=2 * STEPS - 2)
    e1 = error("rate", tumbling, H)
    e2 = error("rate", {"R": fine.R.reshape(-1, 9), "omega": fine.omega}, H / 2)
    assert 1e-4 < e1 < 1e-2 and 3.6 < e1 / e2 < 4.4


def test_rotation_coefficients_equal_the_trigonometric_forms_near_zero_the_edge_and_pi():
    """The MEKF's propagation takes its quaternion (``sin(t/2)/t``, ``cos(t/2)``) and Rodrigues'
    coefficients (``sin t / t``, ``(1 - cos t)/t^2``, ``(t - sin t)/t^3``) from one call: their
    series below 0.1 rad, one sine and cosine of ``t/2`` above. Each equals the value computed in
    high precision (mpmath, 40 digits, from the same ``t^2``) to a few ulp of its value at 0 (1/2, 1,
    1, 1/2, 1/6: near pi ``cos(t/2)`` and ``sin t`` are near 0, and their error is absolute), from
    1e-9 rad through the series' edge (both sides) to pi; the last one to its own cancellation above
    the edge (``t - sin t``, 3 digits of it lost at 0.1 rad, hence 2e-13 there; it multiplies
    ``hat(phi)^2``, of size ``t^2``)."""
    import mpmath  # with sympy (the test extra)
    from lgvi._kernels.attitude_kernels import ROTATION_SERIES, quat_from_rotvec, rotation_coefficients

    mpmath.mp.dps = 40
    edge = math.sqrt(ROTATION_SERIES)
    ts = np.r_[np.logspace(-9, math.log10(math.pi), 300), edge * (1 - 1e-12), edge * (1 + 1e-12), math.pi]
    for t in ts:
        t2 = float(t) * float(t)
        T = mpmath.sqrt(mpmath.mpf(t2))
        want = [mpmath.sin(T / 2) / T, mpmath.cos(T / 2), mpmath.sin(T) / T, (1 - mpmath.cos(T)) / T ** 2,
                (T - mpmath.sin(T)) / T ** 3]
        got = rotation_coefficients(t2)
        for i, (g, w, at0) in enumerate(zip(got, want, (0.5, 1.0, 1.0, 0.5, 1.0 / 6.0))):
            tol = 6e-16 if (i < 4 or t2 < ROTATION_SERIES) else 2e-13
            assert abs(g - float(w)) <= tol * at0, (t, i, g, float(w))
    # quat_from_rotvec (a star tracker's noise, the filter's reset) takes the first two: SciPy's quaternion
    rng = np.random.default_rng(3)
    for t in ts:
        v = rng.normal(size=3)
        v *= t / np.linalg.norm(v)
        np.testing.assert_allclose(quat_from_rotvec(*v), Rotation.from_rotvec(v).as_quat(), rtol=0, atol=4e-16)


def test_mekf_divergence_stops_with_status_2(tumbling):
    """A filter whose covariance stops being finite (its process noise overflows: an ARW of 1e200
    rad/s^0.5 squared) stops at its first propagation (row 1) with status 2, the row before kept."""
    st = StarTracker(sigma_cross=ST_CROSS, sigma_about=ST_ABOUT)
    comps = [Gyro(rate=H, arw=ARW), st, MEKF(arw=1e200, rrw=RRW, star_tracker=st, P0=np.ones(6) * 1e-4)]
    run = run_components(comps, tumbling, H, record=["R_est"])
    assert run.status == 2 and run.rows == 1
    assert np.all(np.isfinite(run.records["R_est"][:1]))


def test_a_gyro_gone_wild_stops_the_components_at_its_own_sample(tumbling):
    """A truth rate that turns infinite at row 50: the gyro writes an infinite rate and stops the run
    there with status 1 ("wrote a value that is not finite"), before the filter reads it (a sensor
    tests its own writes since round 10, as the loop always tested them); the rows before are kept."""
    st = StarTracker(sigma_cross=ST_CROSS, sigma_about=ST_ABOUT)
    comps = [Gyro(rate=H, arw=ARW), st, MEKF(arw=ARW, rrw=RRW, star_tracker=st, P0=np.ones(6) * 1e-4,
                                              max_variance=1.0)]
    bad = dict(tumbling)
    bad["omega"] = tumbling["omega"].copy()
    bad["omega"][50:] = np.inf
    run = run_components(comps, bad, H, record=["R_est"])
    assert run.status == 1 and run.rows == 50
    assert np.all(np.isfinite(run.records["R_est"][:50]))


def test_mekf_kind_is_registered():
    kind = components.COMPONENT_KINDS["mekf"]
    assert kind.family == "estimator" and kind.code == 401 and kind.cls is MEKF
    assert {"R_est", "omega_est", "bias_est", "P_diag", "est_error"} == set(kind.writes)


_INTERPRETED = """
import json, sys
import numpy as np
sys.path.insert(0, {tests!r})
from estimation_cases import H, truth, TUMBLING
from lgvi.fsw import MEKF
from lgvi.fsw._drive import run_components
from lgvi.spacecraft import CoarseSunSensors, FineSunSensor, Gyro, Magnetometer, StarTracker
tr = truth(TUMBLING, steps=40)
st = StarTracker(rate=0.5, sigma_cross=5e-5, sigma_about=4e-4, sun_exclusion=0.2, seed=3)
comps = [Gyro(rate=H, arw=1e-4, rrw=1e-5, lsb=1e-7, saturation=1.0, output="mean", seed=3), st,
         Magnetometer(rate=0.2, sigma=1e-7, seed=3), CoarseSunSensors(np.eye(3), sigma=0.01, seed=3),
         FineSunSensor(rate=0.3, sigma=1e-3, seed=3),
         MEKF(rate=H, arw=1e-4, rrw=1e-5, star_tracker=st, mag_sigma=1e-7, sun_sigma=1e-3,
              P0=[1e-3] * 3 + [1e-8] * 3, gyro_output="mean")]
run = run_components(comps, tr, H, record=["gyro_B", "st_q", "mag_B", "css", "sun_B", "R_est", "P_diag"],
                     constants={{"B_N": [2e-5, -1e-5, 3.5e-5], "sun_N": [0.6, 0.0, 0.8], "shadow": 1.0}})
print(json.dumps({{k: v.tolist() for k, v in run.records.items()}}))
"""


def test_components_interpreted_match_compiled():
    """Every sensor kind and the MEKF run as plain Python (NUMBA_DISABLE_JIT=1) give the compiled
    records: the random words bit for bit (uint64 arithmetic wraps alike), the floats to round-off."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    tests = str(Path(__file__).resolve().parent)
    src = str(Path(lgvi.__file__).resolve().parents[1])
    script = _INTERPRETED.format(tests=tests)
    out = {}
    for flag in ("0", "1"):
        env = dict(os.environ, NUMBA_DISABLE_JIT=flag, PYTHONPATH=src)
        proc = subprocess.run([sys.executable, "-W", "ignore", "-c", script], capture_output=True, text=True,
                              env=env)
        assert proc.returncode == 0, proc.stderr[-3000:]
        out[flag] = json.loads(proc.stdout.strip().splitlines()[-1])
    for name in out["0"]:
        np.testing.assert_allclose(np.array(out["1"][name]), np.array(out["0"][name]), rtol=1e-12, atol=1e-18,
                                   err_msg=name)


def test_mekf_initial_quaternion_follows_a_new_r0():
    """The filter keeps R0's quaternion (SciPy's conversion costs more than a short run's steps): a new
    R0, assigned or changed in place, is converted again, so the row is always a fresh filter's."""
    Ra, Rb = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix(), Rotation.from_rotvec([3.0, 0.1, -0.2]).as_matrix()
    est = MEKF(arw=1e-4, rrw=1e-6, R0=Ra, P0=np.ones(6))
    fresh = MEKF(arw=1e-4, rrw=1e-6, R0=Rb, P0=np.ones(6)).state0()
    est.R0 = Rb.copy()
    assert np.array_equal(est.state0(), fresh, equal_nan=True)
    est.R0[...] = Ra
    assert np.array_equal(est.state0(), MEKF(arw=1e-4, rrw=1e-6, R0=Ra, P0=np.ones(6)).state0(), equal_nan=True)
    est.R0 = np.stack([Ra, Rb])                  # one row per member
    assert np.array_equal(est.state0()[1], fresh, equal_nan=True)


def test_mekf_state_rows_per_member():
    R0 = Rotation.from_rotvec([[0.1, 0.2, 0.3], [3.0, 0.1, 0.0], [0.0, 0.0, 0.0]])
    est = MEKF(arw=1e-4, rrw=1e-6, R0=R0, P0=np.ones(6))
    rows = est.state0()
    assert rows.shape == (3, STATE_SIZE)
    for i in range(3):
        q = rows[i, :4]
        assert q[3] >= 0.0 and np.allclose(Rotation.from_quat(q).as_matrix(), R0[i].as_matrix(), atol=1e-15)
        assert np.array_equal(MEKF(arw=1e-4, rrw=1e-6, R0=R0[i], P0=np.ones(6)).state0(), rows[i], equal_nan=True)
    assert MEKF(arw=1e-4, rrw=1e-6, bias0=np.zeros((2, 3)), P0=np.ones(6)).state0().shape == (2, STATE_SIZE)
    with pytest.raises(ValueError, match=r"same number of members"):
        MEKF(arw=1e-4, rrw=1e-6, R0=R0, bias0=np.zeros((2, 3)), P0=np.ones(6))
