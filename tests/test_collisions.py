"""Impossible physics stops (issue 29, part 2): a collision or a passage through a centre raises
:class:`lgvi.CollisionError` naming the step, the time and the distance, with the run up to that
step; ``simulate_orbit`` and ``simulate_two_body`` estimate their error as ``simulate`` does."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

import lgvi
from lgvi._kernels.contact_kernels import ellipsoids_overlap
from lgvi.systems.orbit import orbit_equations

J = np.array([[0.04, 0.003, -0.002], [0.003, 0.06, 0.001], [-0.002, 0.001, 0.075]])
E1, E2 = lgvi.Ellipsoid(1.0, 0.7, 0.5), lgvi.Ellipsoid(0.3, 0.25, 0.2)
SPIN = dict(omega1_0=[0.0, 0.0, 1.0], omega2_0=[0.0, 0.0, 0.2])


def fall(**kw):
    """A body let go at rest at distance 1 of a point mass (mu = 1): it falls straight in."""
    return lgvi.simulate_orbit(J, 1.0, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], np.eye(3), omega0=[0.0, 0.0, 0.0], h=0.01,
                               steps=1000, mu=1.0, potential="point", **kw)


def test_fall_through_the_centre_stops_with_the_part():
    # before: the body went through the centre and out again, energy -1 -> +2e5; now the step
    # that would jump past the centre raises, and what came before is kept
    with pytest.raises(lgvi.CollisionError, match=r"orbit step \d+ \(t = [\d.]+\): collision.*fall through the "
                                                  r"centre") as info:
        fall()
    err = info.value
    part = err.trajectory
    assert isinstance(err, lgvi.ConvergenceError) and not isinstance(err, ValueError)
    assert len(part.t) == err.step + 1 and part.meta["partial"] and err.time == pytest.approx(err.step * 0.01)
    # the free fall from rest at r = 1 reaches the centre at t = pi / (2 sqrt 2) (Kepler, e -> 1)
    assert abs(err.time - np.pi / (2 * np.sqrt(2))) < 0.05
    assert 0.0 <= err.distance < np.linalg.norm(part.x[-1]) and np.all(part.x[:, 0] > 0.0)


def test_orbit_entering_the_central_body_and_starting_inside_it():
    # an ellipse of periapsis 0.25 about a body of radius 0.5: it hits the surface on the way down
    with pytest.raises(lgvi.CollisionError, match=r"inside the central body \(radius 0.5\)") as info:
        lgvi.simulate_orbit(J, 1.0, [1.0, 0.0, 0.0], [0.0, 0.6, 0.0], np.eye(3), omega0=[0.0, 0.0, 0.0], h=0.005,
                            steps=2000, mu=1.0, radius=0.5, potential="point")
    err = info.value
    assert err.distance <= 0.5 < np.linalg.norm(err.trajectory.x, axis=1).min()
    # the same orbit about a point (no radius) passes its periapsis: resolved, no error, energy kept
    ok = lgvi.simulate_orbit(J, 1.0, [1.0, 0.0, 0.0], [0.0, 0.6, 0.0], np.eye(3), omega0=[0.0, 0.0, 0.0], h=0.005,
                             steps=2000, mu=1.0, potential="point")
    assert np.linalg.norm(ok.x, axis=1).min() < 0.3 and np.ptp(ok.energy) < 1e-2 * abs(ok.energy[0])  # Verlet: 1.3e-3
    with pytest.raises(lgvi.CollisionError, match=r"x0 is inside the central body: \|x0\| = 1 <= radius = 2") as start:
        lgvi.simulate_orbit(J, 1.0, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], np.eye(3), omega0=[0.0, 0.0, 0.0], h=0.01,
                            steps=10, mu=1.0, radius=2.0)
    assert isinstance(start.value, ValueError) and start.value.step == 0 and start.value.trajectory is None


def head_on(body1, body2, m1, m2, **kw):
    kw = {**SPIN, "h": 0.05, "steps": 400, **kw}
    return lgvi.simulate_two_body(body1, body2, m1, m2, [3.0, 0.0, 0.0], [-0.5, 0.0, 0.0], np.eye(3), np.eye(3),
                                  **kw)


@pytest.mark.parametrize("potential", ["order2", "order4"])
def test_ellipsoids_on_a_collision_course_stop_where_they_would_overlap(potential):
    with pytest.raises(lgvi.CollisionError, match=r"two-body step \d+ .*the bodies overlap") as info:
        head_on(E1, E2, 1.0, 0.1, potential=potential)
    err = info.value
    part = err.trajectory
    # the kept part never overlaps (the independent test below), and the contact is within the
    # bodies' reach: between the sums of the smallest and of the largest semi-axes
    assert not overlap_by_optimisation(part.x[-1], part.R[-1], (E1, E2))
    assert 0.5 + 0.2 < err.distance < 1.0 + 0.3 and len(part.t) == err.step + 1
    assert np.ptp(part.energy) < 1e-3 * np.abs(part.energy).max()       # no blow-up kept


def test_spheres_touch_at_the_sum_of_their_radii_and_bodies_without_shape_pass_no_centre():
    one = lgvi.PointMasses([1.0], [[0.0, 0.0, 0.0]], radii=[0.4])
    two = lgvi.PointMasses([0.5], [[0.0, 0.0, 0.0]], radii=[0.3])
    with pytest.raises(lgvi.CollisionError) as info:
        head_on(one, two, None, None, potential="points", omega1_0=[0.0, 0.0, 0.0], omega2_0=[0.0, 0.0, 0.0])
    d = info.value.trajectory.distance
    assert info.value.distance < 0.7 < d[-1] and np.all(np.diff(d) < 0)
    # bodies given by their inertia only: the centres cannot pass each other
    with pytest.raises(lgvi.CollisionError, match="fall through the centre"):
        head_on([1.0, 2.0, 2.5], [1.0, 1.0, 1.5], 1.0, 1.0, steps=4000, omega1_0=[0.0, 0.0, 0.0],
                omega2_0=[0.0, 0.0, 0.0])


def test_bodies_overlapping_at_the_start_are_refused():
    with pytest.raises(lgvi.CollisionError, match=r"x0 puts the bodies in contact at the start: the centres of mass "
                                                  r"are 1.2 apart") as info:
        lgvi.simulate_two_body(E1, E2, 1.0, 0.1, [1.2, 0.0, 0.0], [0.0, 0.6, 0.0], np.eye(3), np.eye(3), h=0.05,
                               steps=10, **SPIN)
    assert isinstance(info.value, ValueError)
    # turned a quarter turn, the long axis of body 1 points away from body 2: no contact at 1.2
    quarter = Rotation.from_rotvec([0.0, 0.0, np.pi / 2]).as_matrix()
    lgvi.simulate_two_body(E1, E2, 1.0, 0.1, [1.2, 0.0, 0.0], [0.0, 0.0, 0.0], quarter, np.eye(3), h=0.01, steps=1,
                           omega1_0=[0.0, 0.0, 0.0], omega2_0=[0.0, 0.0, 0.0])


def overlap_by_optimisation(x, R, shapes):
    """Independent check: two ellipsoids overlap iff some point lies strictly inside both, i.e.
    ``min_y max(q1(y), q2(y)) < 1`` (a convex problem, solved by SLSQP on ``(y, s)``)."""
    Q = [Ri @ np.diag(1.0 / np.array([e.a, e.b, e.c]) ** 2) @ Ri.T for Ri, e in zip(R, shapes)]

    def q(i, y):
        e = y - x[i]
        return e @ Q[i] @ e

    cons = [{"type": "ineq", "fun": (lambda z, i=i: z[3] - q(i, z[:3]))} for i in range(2)]
    z0 = np.append(0.5 * (x[0] + x[1]), 10.0)
    res = minimize(lambda z: z[3], z0, constraints=cons, method="SLSQP", options={"ftol": 1e-12, "maxiter": 500})
    return res.x[3] < 1.0


def test_perram_wertheim_agrees_with_an_independent_minimisation():
    rng = np.random.default_rng(29)
    found = {True: 0, False: 0}
    for _ in range(40):
        shapes = [lgvi.Ellipsoid(*rng.uniform(0.2, 1.0, 3)) for _ in range(2)]
        R = Rotation.random(2, random_state=rng).as_matrix()
        d = rng.normal(size=3)
        d *= rng.uniform(0.3, 2.0) / np.linalg.norm(d)
        x = np.stack([np.zeros(3), d])
        want = overlap_by_optimisation(x, R, shapes)
        got = ellipsoids_overlap(d[0], d[1], d[2], np.ascontiguousarray(R), np.array([shapes[0].a, shapes[0].b,
                                 shapes[0].c]), np.array([shapes[1].a, shapes[1].b, shapes[1].c]))
        assert got == want
        found[bool(got)] += 1
    assert min(found.values()) >= 5          # both answers were tested


def test_orbit_error_estimate_matches_the_true_error_and_warns():
    x0, v0, w0 = [1.0, 0.0, 0.1], [0.0, 1.15, 0.05], [0.3, -0.4, 1.3]
    R0 = Rotation.from_rotvec([0.4, -0.3, 0.8]).as_matrix()
    T, h = 4.0, 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("error")       # below error_warn: no warning
        tr = lgvi.simulate_orbit(J, 1.0, x0, v0, R0, omega0=w0, h=h, steps=int(T / h), mu=1.0, error_estimate=True)
    est = tr.error_estimate
    f = orbit_equations(1.0, J, 1.0)
    y0 = np.concatenate([x0, v0, R0.ravel(), J @ w0])
    y = solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    true_x = np.linalg.norm(tr.x[-1] - y[0:3])
    true_R = np.linalg.norm(Rotation.from_matrix(tr.R[-1].T @ y[6:15].reshape(3, 3)).as_rotvec())
    assert 0.7 < est.position / true_x < 1.4 and 0.7 < est.attitude / true_R < 1.4
    assert est.position_rel == pytest.approx(est.position / np.linalg.norm(tr.x, axis=1).max())
    with pytest.warns(lgvi.AccuracyWarning, match="position error .* use a smaller h, or h="):
        lgvi.simulate_orbit(J, 1.0, x0, v0, R0, omega0=w0, h=0.1, steps=40, mu=1.0, error_estimate=True,
                            error_warn=1e-4)
    with pytest.raises(ValueError, match="error_estimate needs the extra moment between the grid times"):
        lgvi.simulate_orbit(J, 1.0, x0, v0, R0, omega0=w0, h=0.1, steps=4, mu=1.0, torque=np.zeros((5, 3)),
                            error_estimate=True)


def test_two_body_error_estimate_is_richardson_of_the_shadow_run():
    kw = dict(h=0.05, steps=100, potential="order4", **SPIN)
    args = (E1, E2, 1.0, 0.1, [3.0, 0, 0], [0, 0.6, 0], np.eye(3), np.eye(3))
    tr = lgvi.simulate_two_body(*args, error_estimate=True, **kw)
    half = lgvi.simulate_two_body(*args, **dict(kw, h=0.025, steps=200, save_every=2))
    quarter = lgvi.simulate_two_body(*args, **dict(kw, h=0.0125, steps=400, save_every=4))
    est = tr.error_estimate
    d = np.linalg.norm(tr.relative_position[-1] - half.relative_position[-1])
    assert est.position == pytest.approx(4.0 / 3.0 * d, rel=1e-12)
    # and it is the error: the h run against the (Richardson-extrapolated) h/4 run
    best = quarter.relative_position[-1] + (quarter.relative_position[-1] - half.relative_position[-1]) / 3.0
    assert 0.8 < est.position / np.linalg.norm(tr.relative_position[-1] - best) < 1.25
    assert tr.meta["error_estimate"]["position"] == est.position
