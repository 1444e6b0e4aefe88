"""Sensors as compiled components (issue 27): the counter-based random streams, the gyro (Basilisk
``imuSensor`` corruptions, Allan deviation), the star tracker, the magnetometer, the coarse and fine
sun sensors.

Statistics tests are seeded (deterministic); each tolerance is several standard deviations of the
estimator it bounds (stated next to it), so a test fails for a wrong model, not for bad luck.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from lgvi import components, so3
from lgvi._kernels import random as rnd
from lgvi.fsw._drive import bus_layout, run_components
from lgvi.spacecraft import CoarseSunSensors, FineSunSensor, Gyro, Magnetometer, StarTracker
from lgvi.spacecraft.sensors import period_steps


def still(n: int, R: np.ndarray | None = None) -> dict[str, np.ndarray]:
    R = np.eye(3) if R is None else R
    return {"omega": np.zeros((n, 3)), "R": np.tile(R.ravel(), (n, 1))}


# ------------------------------------------------------------------------------------------------
# random streams
# ------------------------------------------------------------------------------------------------
def test_samples_are_pure_functions_of_seed_stream_counter():
    a = rnd.uniforms(7.0, 3.0, 0, 1000)
    assert np.array_equal(rnd.uniforms(7.0, 3.0, 400, 600), a[400:])          # any start, same values
    assert np.array_equal(rnd.uniforms.py_func(7.0, 3.0, 990, 10), a[990:])   # interpreted: bit for bit
    z = rnd.normals(7.0, 3.0, 0, 100_000)
    assert np.array_equal(rnd.normals(7.0, 3.0, 50_000, 50_000), z[50_000:])
    assert np.array_equal(rnd.normals.py_func(7.0, 3.0, 0, 2000), z[:2000])    # wedges and tail included
    assert not np.array_equal(rnd.uniforms(7.0, 4.0, 0, 1000), a)
    assert not np.array_equal(rnd.uniforms(8.0, 3.0, 0, 1000), a)
    assert 0.0 < a.min() and a.max() < 1.0


def test_uniform_moments_and_histogram():
    n = 2_000_000
    u = rnd.uniforms(11.0, 1.0, 0, n)
    # mean 1/2 (sd 0.2887/sqrt(n)), variance 1/12 (sd 0.0745/sqrt(n)): 5 sd bounds
    assert abs(u.mean() - 0.5) < 5 * 0.2887 / math.sqrt(n)
    assert abs(u.var() - 1 / 12) < 5 * 0.0745 / math.sqrt(n)
    counts = np.bincount((u * 1000).astype(int), minlength=1000)
    assert stats.chisquare(counts).pvalue > 1e-4
    # pairs of consecutive draws fill the unit square evenly (32 x 32 cells)
    cells = np.bincount((u[0::2] * 32).astype(int) * 32 + (u[1::2] * 32).astype(int), minlength=1024)
    assert stats.chisquare(cells).pvalue > 1e-4


def test_normal_moments_and_distribution():
    z = rnd.normals(5.0, 2.0, 0, 2_000_000)
    n = z.size
    # sample mean sd 1/sqrt(n), variance sd sqrt(2/n), skewness sd sqrt(6/n), kurtosis sd sqrt(24/n)
    assert abs(z.mean()) < 5 / math.sqrt(n)
    assert abs(z.var() - 1.0) < 5 * math.sqrt(2 / n)
    assert abs(stats.skew(z)) < 5 * math.sqrt(6 / n)
    assert abs(stats.kurtosis(z)) < 5 * math.sqrt(24 / n)
    assert stats.kstest(z[:200_000], "norm").pvalue > 1e-4
    # the tail beyond the ziggurat's base (r = 3.4426) and far into it: binomial counts within 5 sd
    for a in (1.0, 3.0, 3.4426, 4.0, 4.5):
        p = 2 * stats.norm.sf(a)
        assert abs(np.sum(np.abs(z) > a) - n * p) < 5 * math.sqrt(n * p * (1 - p)) + 1
    # a histogram over 200 bins of [-4, 4]: the density, layer edges included
    counts, edges = np.histogram(z, bins=200, range=(-4.0, 4.0))
    expected = n * np.diff(stats.norm.cdf(edges))
    assert stats.chisquare(counts, expected * counts.sum() / expected.sum()).pvalue > 1e-4


def test_streams_seeds_and_lags_are_uncorrelated():
    n = 1_000_000
    base = rnd.normals(1.0, 1.0, 0, n)
    others = [rnd.normals(1.0, 2.0, 0, n), rnd.normals(2.0, 1.0, 0, n), rnd.normals(0.0, 1.0, 0, n),
              np.roll(base, 1), np.roll(base, 2)]
    for other in others:
        assert abs(np.corrcoef(base, other)[0, 1]) < 5 / math.sqrt(n)
        # squares too (dependence that the correlation of the values misses)
        assert abs(np.corrcoef(base ** 2, other ** 2)[0, 1]) < 5 / math.sqrt(n)


# ------------------------------------------------------------------------------------------------
# gyro
# ------------------------------------------------------------------------------------------------
def _avar(y: np.ndarray, m: int) -> float:
    """Overlapping Allan variance of the rate samples ``y`` with clusters of ``m`` samples."""
    c = np.concatenate([[0.0], np.cumsum(y)])
    a = (c[m:] - c[:-m]) / m
    d = a[m:] - a[:-m]
    return 0.5 * float(np.mean(d * d))


def test_allan_deviation_recovers_arw_and_rrw():
    """A static gyro's Allan variance is ``arw^2 / tau + rrw^2 dt (2 m^2 + 1) / (6 m)`` (the exact
    expectation for samples every ``dt``, ``tau = m dt``: white rate noise plus a discrete rate random
    walk; ``-> rrw^2 tau / 3``). A weighted fit over 25 cluster sizes recovers both to 5%: the fit's
    scatter over seeds is 0.03% (ARW) and 0.5% (RRW) at this length (3 axes x 2^20 samples)."""
    dt, arw, rrw, n = 0.01, 1e-3, 1e-3, 2 ** 20
    gyro = Gyro(rate=dt, arw=arw, rrw=rrw, bias=[2e-3, -1e-3, 5e-4], seed=2024)
    y = run_components([gyro], still(n), dt, record=["gyro_B"]).records["gyro_B"]
    ms = [int(x) for x in np.unique(np.round(np.logspace(0, math.log10(n / 16), 25)))]
    v = np.mean([[_avar(y[:, i], m) for m in ms] for i in range(3)], axis=0)
    A = np.array([[1 / (m * dt), dt * (2 * m * m + 1) / (6 * m)] for m in ms])
    w = np.sqrt(n / np.array(ms, float))                # relative sd of each estimate ~ sqrt(m / n)
    x = np.array([arw, rrw]) ** 2 * 1.5                  # a start off by 50%, then reweighted
    for _ in range(4):
        model = A @ x
        x = np.linalg.lstsq(A / model[:, None] * w[:, None], v / model * w, rcond=None)[0]
    arw_fit, rrw_fit = np.sqrt(x)
    assert abs(arw_fit / arw - 1) < 0.05
    assert abs(rrw_fit / rrw - 1) < 0.05


def test_gyro_deterministic_corruptions_in_basilisk_order():
    """Without noise: ``sat(quant(scale * (M omega + bias)))``, quantised towards zero (Basilisk's
    default) or to the nearest step, saturated at +-limit."""
    omega = np.array([[0.3, -0.2, 0.05], [1.7, -2.5, 0.0123], [-0.0004, 0.00049, 0.7]])
    M = so3.exp(np.array([0.01, -0.02, 0.03])).T
    bias = np.array([1e-3, -2e-3, 3e-4])
    scale = np.array([1.01, 0.99, 1.002])
    for rounding, rnd_fn in (("zero", np.trunc), ("nearest", lambda x: np.sign(x) * np.floor(np.abs(x) + 0.5))):
        g = Gyro(rate=0.1, bias=bias, scale=scale, misalignment=[0.01, -0.02, 0.03], saturation=1.5, lsb=1e-3,
                 rounding=rounding)
        out = run_components([g], {"omega": omega}, 0.1, record=["gyro_B", "gyro_bias"]).records
        want = np.clip(rnd_fn(scale * (omega @ M.T + bias) / 1e-3) * 1e-3, -1.5, 1.5)
        np.testing.assert_allclose(out["gyro_B"], want, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(out["gyro_bias"], np.tile(bias, (3, 1)))


def test_gyro_noise_per_sample_and_bias_walk():
    dt, arw, rrw, n = 0.05, 2e-4, 3e-5, 200_000
    g = Gyro(rate=dt, arw=arw, rrw=rrw, seed=9)
    r = run_components([g], still(n), dt, record=["gyro_B", "gyro_bias"]).records
    white = r["gyro_B"] - r["gyro_bias"]
    sd = white.std(axis=0) / (arw / math.sqrt(dt))
    assert np.all(np.abs(sd - 1) < 5 / math.sqrt(2 * n))
    steps = np.diff(r["gyro_bias"], axis=0).std(axis=0) / (rrw * math.sqrt(dt))
    assert np.all(np.abs(steps - 1) < 5 / math.sqrt(2 * n))
    # the white noise and the walk's steps are independent
    assert abs(np.corrcoef(white[1:, 0], np.diff(r["gyro_bias"][:, 0]))[0, 1]) < 5 / math.sqrt(n)


def test_gyro_bounded_walk_as_basilisk_walk_bounds():
    """``walk_bound`` (Basilisk's ``walkBoundsGyro``): each sample the walk steps by ``rrw sqrt(dt) n``
    and is clipped to ``+-bound`` per axis. Checked three ways on 1e5 samples of a static gyro with
    the bound at 20 steps (the walk's unbounded spread, 316 steps, reaches it many times):
    - bounded: never beyond the bound, and at it exactly on each axis;
    - the steps from states at least 6 steps inside the bound are never clipped (P(|n| > 6) = 2e-9),
      so they are the specification's: standard deviation ``rrw sqrt(dt)`` to 5/sqrt(2m) (m of them,
      the sample sd's own relative sd is 1/sqrt(2m)), mean 0 to 5 sd/sqrt(m);
    - the walk equals NumPy's clipped cumulative sum of the stream's own normals (draws 6k+3..6k+5
      of sample k), bit for bit; an unbounded gyro of the same seed walks the plain cumulative sum."""
    dt, rrw, n = 0.1, 2e-5, 100_000
    step = rrw * math.sqrt(dt)
    bound = 20.0 * step * np.array([1.0, 1.5, 0.8])
    g = Gyro(rate=dt, rrw=rrw, walk_bound=bound, seed=11)
    walk = run_components([g], still(n), dt, record=["gyro_bias"]).records["gyro_bias"]   # before each step
    assert np.all(np.abs(walk) <= bound)
    assert np.array_equal(np.abs(walk).max(axis=0), bound)
    d = np.diff(walk, axis=0)
    inside = np.abs(walk[:-1]) < bound - 6.0 * step
    for i in range(3):
        di = d[inside[:, i], i]
        m = di.size
        assert m > 0.5 * (n - 1)
        assert abs(di.std() / step - 1.0) < 5.0 / math.sqrt(2 * m)
        assert abs(di.mean()) < 5.0 * step / math.sqrt(m)
    z = rnd.normals(11.0, 1.0, 0, 6 * n).reshape(n, 6)[:, 3:]
    ref = np.zeros((n, 3))
    x = np.zeros(3)
    for k in range(n - 1):
        x = np.clip(x + step * z[k], -bound, bound)
        ref[k + 1] = x
    np.testing.assert_array_equal(walk, ref)
    free = run_components([Gyro(rate=dt, rrw=rrw, seed=11)], still(n), dt, record=["gyro_bias"]).records["gyro_bias"]
    x = np.zeros(3)
    for k in range(n - 1):
        x = x + step * z[k]
        ref[k + 1] = x
    np.testing.assert_array_equal(free, ref)
    assert np.all(np.abs(free).max(axis=0) > bound)           # unbounded, it goes beyond the bounds


def test_rotvec_series_is_atan2_to_round_off_near_identity_and_pi():
    """``quat_rotvec_over`` (the gyro's mean rate, the MEKF's innovation and error; ``quat_rotvec`` is
    it with ``dt = 1``): its series branch (below 0.1 rad: no square root, no ``atan2``) and its
    ``atan2`` branch give ``2 atan2(s, w) / s (q0, q1, q2) / dt`` (in double precision, NumPy) to a
    few ulp, from 1e-14 rad through the branches' edge (both sides) to pi, for ``q`` and ``-q`` and
    at any scale."""
    from lgvi._kernels.attitude_kernels import ROTVEC_SERIES, quat_rotvec, quat_rotvec_over

    edge = 2.0 * math.atan(math.sqrt(ROTVEC_SERIES))      # the angle where the branches meet
    assert edge == pytest.approx(0.1, rel=1e-3)
    rng = np.random.default_rng(11)
    angles = np.r_[np.logspace(-14, 0.5, 600), edge * (1 - 1e-9), edge * (1 + 1e-9), math.pi - 1e-6, math.pi - 1e-9]
    dt = 0.1
    for a in angles:
        axis = rng.normal(size=3)
        q = Rotation.from_rotvec(a * axis / np.linalg.norm(axis)).as_quat()
        q = q if q[3] >= 0.0 else -q             # angle in [0, pi]
        s = np.linalg.norm(q[:3])
        want = 2.0 * math.atan2(s, q[3]) / s * q[:3] / dt
        for d in (q, -q, 3.7 * q, -2.1 * q):     # either sign, any scale
            got = np.array(quat_rotvec_over(*d, dt))
            assert np.abs(got - want).max() <= 8 * 2.2e-16 * np.abs(want).max(), a
        assert np.abs(np.array(quat_rotvec(*q)) - want * dt).max() <= 8 * 2.2e-16 * np.abs(want * dt).max()
    assert quat_rotvec_over(0.0, 0.0, 0.0, 1.0, dt) == (0.0, 0.0, 0.0)
    assert quat_rotvec_over(0.0, 0.0, 0.0, -4.0, dt) == (0.0, 0.0, 0.0)
    np.testing.assert_allclose(quat_rotvec(1.0, 0.0, 0.0, 0.0), (math.pi, 0.0, 0.0), rtol=1e-15)


def test_scaled_quaternion_is_shepperds_times_4c():
    """``quat_from_matrix_scaled`` (no square root, no division) is ``quat_from_matrix`` times
    ``4 c``, ``c`` its largest component (norm 2 to 4), to round-off: near the identity, near rotations
    by pi about each axis (Shepperd's four branches) and at random."""
    from lgvi._kernels.attitude_kernels import quat_from_matrix, quat_from_matrix_scaled

    rng = np.random.default_rng(2)
    vecs = [np.zeros(3), np.array([1e-9, -2e-9, 3e-9])] + [math.pi * e + 1e-7 * rng.normal(size=3) for e in np.eye(3)]
    vecs += [math.pi * e for e in np.eye(3)] + list(rng.normal(size=(20, 3)))
    for v in vecs:
        R = so3.exp(v).ravel()
        q = np.array(quat_from_matrix(R, 0))
        qs = np.array(quat_from_matrix_scaled(R, 0))
        n = np.linalg.norm(qs)
        assert 2.0 - 1e-15 <= n <= 4.0 + 1e-15
        assert n == pytest.approx(4.0 * np.abs(q).max(), rel=1e-15)
        np.testing.assert_allclose(qs / n * np.sign(qs @ q), q, rtol=0, atol=4e-16)


def test_mean_rate_gyro_follows_the_attitude_increments():
    """``output="mean"`` without noise: each sample is ``log(R_prev^T R) / dt`` (the rotation vector of
    the attitude's increment over the sample), near the identity, around the series' edge (0.1 rad)
    and near pi, from attitudes near the identity and near a rotation by pi (Shepperd's other
    branches, either sign of the kept quaternion); the first sample gives the rate."""
    rng = np.random.default_rng(5)
    dt = 0.1
    steps = np.r_[0.0, 1e-13, 1e-9, 1e-6, 1e-3, 0.05, 0.0999, 0.1001, 0.7, 2.5, math.pi - 1e-6]
    for start in (np.zeros(3), np.array([math.pi, 0.0, 0.0]), np.array([0.0, 0.0, math.pi - 1e-8]),
                  np.array([1.2, -0.9, 2.0])):
        inc = [a * v / np.linalg.norm(v) for a, v in zip(steps, rng.normal(size=(len(steps), 3)))]
        R = [so3.exp(start)]
        for v in inc:
            R.append(R[-1] @ so3.exp(v))
        R = np.array(R)
        omega = np.tile([0.3, -0.2, 0.1], (len(R), 1))
        out = run_components([Gyro(rate=dt, output="mean")], {"omega": omega, "R": R.reshape(-1, 9)}, dt,
                             record=["gyro_B"]).records["gyro_B"]
        np.testing.assert_array_equal(out[0], omega[0])
        for k, v in enumerate(inc):
            exact = so3.log(R[k].T @ R[k + 1]) / dt     # the increment as the matrices hold it
            # a few ulp of the attitudes (2.2e-16 rad each) over dt
            np.testing.assert_allclose(out[k + 1], exact, rtol=0, atol=1e-14 / dt, err_msg=f"start {start}, step {k}")
            assert np.linalg.norm(out[k + 1] - v / dt) < 1e-13 / dt + 1e-12 * np.linalg.norm(v) / dt


def test_gyro_walk_bound_validation():
    with pytest.raises(ValueError, match=r"walk_bound must be positive on each axis .* got \[ 0\.001 -0\.001"):
        Gyro(rate=0.1, rrw=1e-5, walk_bound=[1e-3, -1e-3, 1e-3])
    with pytest.raises(ValueError, match=r"walk_bound"):
        Gyro(rate=0.1, rrw=1e-5, walk_bound=math.nan)
    with pytest.warns(UserWarning, match=r"below three standard deviations of the walk's step"):
        Gyro(rate=0.1, rrw=1e-3, walk_bound=1e-4)
    assert np.array_equal(Gyro(rate=0.1, walk_bound=2e-3).walk_bound, [2e-3] * 3)


def test_same_seed_same_stream_bit_for_bit_and_members_differ():
    n = 500
    a = run_components([Gyro(rate=0.1, arw=1e-3, rrw=1e-4, seed=4)], still(n), 0.1, record=["gyro_B"])
    b = run_components([Gyro(rate=0.1, arw=1e-3, rrw=1e-4, seed=4)], still(n), 0.1, record=["gyro_B"])
    c = run_components([Gyro(rate=0.1, arw=1e-3, rrw=1e-4, seed=5)], still(n), 0.1, record=["gyro_B"])
    assert np.array_equal(a.records["gyro_B"], b.records["gyro_B"])
    assert not np.array_equal(a.records["gyro_B"], c.records["gyro_B"])
    # a run cut in two (resume from the state) gives the same draws
    g = Gyro(rate=0.1, arw=1e-3, rrw=1e-4, seed=4)
    first = run_components([g], still(200), 0.1, record=["gyro_B"])
    g2 = Gyro(rate=0.1, arw=1e-3, rrw=1e-4, seed=4)
    g2.state0 = lambda: first.states[0]
    second = run_components([g2], still(300), 0.1, record=["gyro_B"], t0=20.0)
    assert np.array_equal(np.concatenate([first.records["gyro_B"], second.records["gyro_B"]]), a.records["gyro_B"])


def test_rates_are_whole_multiples_of_the_step():
    assert period_steps(0.5, 0.1) == 5
    with pytest.raises(ValueError, match=r"rate must be a whole multiple of the step h = 0\.1, got 0\.25"):
        period_steps(0.25, 0.1)
    # a sensor at 5 steps: it samples at k = 0, 5, 10, ... and holds its value in between
    g = Gyro(rate=0.5, arw=1e-3, seed=1)
    y = run_components([g], still(20), 0.1, record=["gyro_B"]).records["gyro_B"]
    assert np.array_equal(y[0], y[4]) and not np.array_equal(y[4], y[5])


# ------------------------------------------------------------------------------------------------
# star tracker
# ------------------------------------------------------------------------------------------------
def test_star_tracker_error_statistics_in_the_case_frame():
    """1e5 samples: the error angles about the case axes have the standard deviations of the
    specification to 3% (the sample sd's own sd is 0.22% here), zero means, no correlation."""
    n = 100_000
    case = Rotation.from_rotvec([0.4, -1.1, 0.7]).as_matrix()       # case -> body
    R = Rotation.from_rotvec([2.0, 1.0, -0.5]).as_matrix()
    st = StarTracker(sigma_cross=2e-5, sigma_about=1.5e-4, case=case, seed=77)
    q = run_components([st], still(n, R), 0.1, record=["st_q"]).records["st_q"]
    assert np.all(q[:, 3] >= 0.0)
    R_meas = Rotation.from_quat(q).as_matrix()
    err_body = Rotation.from_matrix(np.einsum("ji,njk->nik", R, R_meas)).as_rotvec()   # R^T R_meas
    err_case = err_body @ case                                                          # C^T e
    sd = err_case.std(axis=0)
    np.testing.assert_allclose(sd, [2e-5, 2e-5, 1.5e-4], rtol=0.03)
    assert np.all(np.abs(err_case.mean(axis=0)) < 5 * np.array([2e-5, 2e-5, 1.5e-4]) / math.sqrt(n))
    c = np.corrcoef(err_case.T)
    assert np.all(np.abs(c[np.triu_indices(3, 1)]) < 5 / math.sqrt(n))


def test_star_tracker_near_pi_rotation_and_exclusions():
    # near a rotation by pi the quaternion's scalar part is ~0: the measurement stays close
    R = Rotation.from_rotvec(np.array([1.0, 2.0, -2.0]) / 3.0 * (math.pi - 1e-9)).as_matrix()
    st = StarTracker(sigma_cross=1e-6, sigma_about=1e-6, seed=1)
    q = run_components([st], still(50, R), 0.1, record=["st_q"]).records["st_q"]
    ang = (Rotation.from_matrix(R).inv() * Rotation.from_quat(q)).magnitude()
    assert ang.max() < 6e-6
    # the sun 10 degrees off the boresight (body z) with a 30-degree exclusion: no measurement
    sun = np.array([math.sin(math.radians(10)), 0.0, math.cos(math.radians(10))])
    st = StarTracker(sigma_cross=1e-5, sigma_about=1e-5, sun_exclusion=math.radians(30))
    r = run_components([st], still(3), 0.1, record=["st_valid", "st_time"], constants={"sun_N": sun}).records
    assert np.all(r["st_valid"] == 0.0) and np.all(np.isnan(r["st_time"]))
    st = StarTracker(sigma_cross=1e-5, sigma_about=1e-5, sun_exclusion=math.radians(5))
    r = run_components([st], still(3), 0.1, record=["st_valid", "st_time"], constants={"sun_N": sun}).records
    assert np.all(r["st_valid"] == 1.0) and np.array_equal(r["st_time"][:, 0], [0.0, 0.1, 0.2])
    # Earth below at 7000 km, boresight nadir-ward 20 degrees off: inside the limb (58.6 deg): excluded
    tilt = math.radians(20)
    r_N = -7e6 * np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    for margin, valid in ((0.0, 0.0), (None, 1.0)):
        st = StarTracker(sigma_cross=1e-5, sigma_about=1e-5, earth_exclusion=margin)
        r = run_components([st], still(2), 0.1, record=["st_valid"], constants={"r_N": r_N}).records
        assert np.all(r["st_valid"] == valid)


def test_star_tracker_earth_exclusion_equals_the_angle_rule():
    """The kernel decides the Earth exclusion by cosines (no acos/asin); the decision is the angle
    rule ``angle(boresight, nadir) < asin(R_E / |r|) + margin`` at 2000 random attitudes per margin,
    margins from 0 to 3 rad (beyond pi/2 the rule can cover the whole sky: ``asin(x) + m >= pi``),
    altitudes 300 km to 40000 km. Draws landing within 1e-9 rad of the boundary (where round-off
    may decide either way) are left out; there are none at this seed."""
    rng = np.random.default_rng(5)
    n = 2000
    Rs = Rotation.random(n, random_state=rng).as_matrix()
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    r_N = dirs * (6378137.0 + rng.uniform(3e5, 4e7, n))[:, None]
    for margin in (0.0, 0.2, 1.0, 1.6, 2.5, 3.0):
        st = StarTracker(sigma_cross=0.0, sigma_about=0.0, earth_exclusion=margin)
        got = run_components([st], {"R": Rs.reshape(n, 9), "r_N": r_N}, 0.1, record=["st_valid"]).records["st_valid"][:, 0]
        bore = Rs[:, :, 2]
        nr = np.linalg.norm(r_N, axis=1)
        angle = np.arccos(np.clip(-np.einsum("ij,ij->i", bore, r_N) / nr, -1.0, 1.0))
        limit = np.arcsin(6378137.0 / nr) + margin
        clear = np.abs(angle - limit) > 1e-9
        assert clear.all()
        np.testing.assert_array_equal(got, np.where(angle < limit, 0.0, 1.0))
        assert 0 < got.sum() < n or margin >= 2.5     # both outcomes occur (all excluded near m = pi)


# ------------------------------------------------------------------------------------------------
# magnetometer, coarse and fine sun sensors
# ------------------------------------------------------------------------------------------------
def test_magnetometer():
    R = Rotation.from_rotvec([0.3, -0.8, 1.2]).as_matrix()
    B_N = np.array([2e-5, -1e-5, 3.5e-5])
    bias = np.array([1e-7, 2e-7, -3e-7])
    mag = Magnetometer(sigma=0.0, bias=bias, misalignment=[0.002, 0.0, -0.001])
    out = run_components([mag], still(2, R), 0.1, record=["mag_B"], constants={"B_N": B_N}).records["mag_B"]
    np.testing.assert_allclose(out[0], so3.exp(np.array([0.002, 0.0, -0.001])).T @ R.T @ B_N + bias,
                               rtol=0, atol=1e-20)
    n = 100_000
    mag = Magnetometer(sigma=1e-7, seed=3)
    out = run_components([mag], still(n, R), 0.1, record=["mag_B"], constants={"B_N": B_N}).records["mag_B"]
    np.testing.assert_allclose((out - R.T @ B_N).std(axis=0), 1e-7, rtol=5 * math.sqrt(1 / (2 * n)))


def test_coarse_sun_sensors_cosine_law_field_of_view_and_eclipse():
    normals = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [0.6, 0.8, 0]])
    sun_B = np.array([math.cos(0.3), math.sin(0.3), 0.0])
    R = Rotation.from_rotvec([0.2, 0.5, -0.4]).as_matrix()
    css = CoarseSunSensors(normals, scale=2.0, fov=math.radians(60))
    lay = bus_layout([css])
    assert lay["css"][1] == 5
    out = run_components([css], still(2, R), 0.1, record=["css"],
                         constants={"sun_N": R @ sun_B, "shadow": 1.0}).records["css"][0]
    cosines = normals @ sun_B
    want = np.where(cosines >= 0.5, 2.0 * cosines, 0.0)       # head 3 (cos = 0.296, 72.8 deg): outside
    np.testing.assert_allclose(out, want, rtol=0, atol=1e-15)
    half = run_components([css], still(2, R), 0.1, record=["css"],
                          constants={"sun_N": R @ sun_B, "shadow": 0.5}).records["css"][0]
    np.testing.assert_allclose(half, 0.5 * want, rtol=0, atol=1e-15)
    dark = run_components([CoarseSunSensors(normals, sigma=0.01, seed=2)], still(1000, R), 0.1, record=["css"],
                          constants={"sun_N": R @ sun_B, "shadow": 0.0}).records["css"]
    assert dark.min() == 0.0 and 0.0 < dark.mean() < 0.01       # clipped noise, nothing else


def test_fine_sun_sensor_angle_noise_and_validity():
    n = 100_000
    R = Rotation.from_rotvec([0.1, -0.3, 0.2]).as_matrix()
    sun_B = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    fss = FineSunSensor(sigma=1e-3, seed=8)
    r = run_components([fss], still(n, R), 0.1, record=["sun_B", "sun_valid"],
                       constants={"sun_N": R @ sun_B, "shadow": 1.0}).records
    assert np.all(r["sun_valid"] == 1.0)
    np.testing.assert_allclose(np.linalg.norm(r["sun_B"], axis=1), 1.0, rtol=0, atol=1e-15)
    err = np.cross(sun_B, r["sun_B"])            # ~ the small rotation across the sun line
    e1 = np.cross(sun_B, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(sun_B, e1)
    sd = np.array([(err @ e1).std(), (err @ e2).std()])
    np.testing.assert_allclose(sd, 1e-3, rtol=0.03)
    # eclipse, or the sun beyond the field of view (60 deg): no measurement
    for sun, shadow in ((R @ sun_B, 0.2), (R @ np.array([1.0, 0.0, 0.2]) / math.hypot(1.0, 0.2), 1.0)):
        r = run_components([fss], still(2, R), 0.1, record=["sun_valid"],
                           constants={"sun_N": sun, "shadow": shadow}).records
        assert np.all(r["sun_valid"] == 0.0)


def test_sensor_kinds_are_registered_with_their_codes():
    for name, code in (("gyro", 301), ("star_tracker", 302), ("magnetometer", 303), ("coarse_sun_sensors", 304),
                       ("fine_sun_sensor", 305)):
        kind = components.COMPONENT_KINDS[name]
        assert kind.family == "sensor" and kind.code == code and kind.cls.kind == name


def test_rows_per_member_and_sizes():
    """A sequence of seeds gives one parameter row per member (the rest of the row shared); each
    member's row drives the stream of its own seed."""
    one = Gyro(rate=0.1, arw=1e-3, seed=4).params()
    rows = Gyro(rate=0.1, arw=1e-3, seed=[4, 5, 6]).params()
    assert rows.shape == (3, one.size) and np.array_equal(rows[0], one)
    assert np.array_equal(rows[:, 0], [4.0, 5.0, 6.0]) and np.all(rows[:, 1:] == one[1:])
    assert CoarseSunSensors(np.eye(3)).sizes() == {"css": 3} and StarTracker(sigma_cross=0, sigma_about=0).sizes() == {}
    with pytest.raises(TypeError, match=r"seed must be an integer"):
        Gyro(rate=0.1, seed=1.5)


def test_a_parameter_row_holding_nan_is_refused_naming_its_component():
    """The loop checks the parameter rows once, together, and names the component whose row holds a
    NaN (here the second sensor: a star tracker whose earth_radius was set to NaN after validation)."""
    import lgvi
    from lgvi.spacecraft import Spacecraft

    st = StarTracker(rate=0.5, sigma_cross=5e-5, sigma_about=4e-4, seed=7)
    st.earth_radius = math.nan
    sat = Spacecraft([0.18, 0.14, 0.06], sensors=[Gyro(rate=0.5, arw=1e-4, seed=7), st])
    with pytest.raises(ValueError, match=r"^star_tracker: params\(\) holds NaN"):
        lgvi.simulate(sat, np.eye(3), omega0=[0.01, 0.0, 0.0], h=0.1, steps=10)
    st.earth_radius = 6378137.0
    assert lgvi.simulate(sat, np.eye(3), omega0=[0.01, 0.0, 0.0], h=0.1, steps=10).records["st_q"].values.shape == (2, 4)
