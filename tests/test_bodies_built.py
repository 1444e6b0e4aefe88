"""Bodies built from spheres and points, and inertias outside the triangle inequality for method
tests (issue 29, part 5)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.systems.two_body import Moments, mutual_potential

R1 = Rotation.from_rotvec([0.3, 0.5, -1.0]).as_matrix()
R2 = Rotation.from_rotvec([2.0, -0.5, 0.4]).as_matrix()


def test_the_dumbbell_of_two_spheres_on_a_rod():
    # Lee, Leok and McClamroch's dumbbell: two spheres on a massless rod. Points on a line have no
    # moment about it (refused); the spheres' own 2/5 m rho^2 give it one
    m, rho, L = 1.5, 0.3, 2.0
    with pytest.raises(ValueError, match="must not all lie on one line"):
        lgvi.RigidBody.from_masses([m, m], [[-L / 2, 0, 0], [L / 2, 0, 0]])
    body = lgvi.RigidBody.from_masses([m, m], [[1.0 - L / 2, 5.0, 0], [1.0 + L / 2, 5.0, 0]], radii=[rho, rho])
    axial = 2 * 0.4 * m * rho ** 2
    assert np.allclose(body.principal_moments, [axial, axial + 2 * m * (L / 2) ** 2, axial + 2 * m * (L / 2) ** 2],
                       rtol=1e-15, atol=0)
    spheres = lgvi.PointMasses([m, m], [[-L / 2, 0, 0], [L / 2, 0, 0]], radii=[rho, rho])
    assert np.allclose(Moments(spheres, None, "points", "body1", "m1").body.J, body.J, rtol=1e-14, atol=0)
    with pytest.raises(ValueError, match="radii must be >= 0"):
        lgvi.RigidBody.from_masses([1.0, 1.0], [[0, 0, 0], [1, 0, 0]], radii=[0.1, -0.1])


def test_spheres_attract_as_points_at_every_order():
    # the moments of a body of spheres (sphere_moments) differ from its points' by isotropic parts,
    # which the Legendre terms of the potential annihilate: the order2/order4 potentials of the
    # spheres equal those of the points, and converge to the exact pairwise sum
    q = np.array([[1.0, 0.2, 0.0], [-0.7, 0.1, 0.3], [0.1, -0.9, 0.2]])
    w = np.array([1.0, 0.6, 0.8])
    balls = lgvi.PointMasses(w, q, radii=[0.4, 0.3, 0.35])
    dots = lgvi.PointMasses(w, q)
    other = lgvi.PointMasses([0.5, 0.5], [[0.5, 0, 0], [-0.5, 0, 0]], radii=[0.2, 0.2])
    d = np.array([[4.0, 1.0, -0.5], [9.0, -2.0, 3.0]])
    for potential in ("order2", "order4", "points"):
        with_r = mutual_potential(potential, 1.0, d, np.stack([R1] * 2), np.stack([R2] * 2),
                                  Moments(balls, None, potential, "body1", "m1"),
                                  Moments(other, None, potential, "body2", "m2"))
        without = mutual_potential(potential, 1.0, d, np.stack([R1] * 2), np.stack([R2] * 2),
                                   Moments(dots, None, potential, "body1", "m1"),
                                   Moments(other, None, potential, "body2", "m2"))
        assert np.allclose(with_r, without, rtol=1e-14, atol=0)
    # but the inertia has the spheres' own moments
    assert np.allclose(Moments(balls, None, "points", "b", "m").body.J - Moments(dots, None, "points", "b", "m").body.J,
                       0.4 * (w * np.array([0.4, 0.3, 0.35]) ** 2).sum() * np.eye(3), rtol=1e-13, atol=1e-15)


def test_the_textbook_inertia_outside_the_triangle_inequality_behind_a_flag():
    J = [2.0, 1.0, 2.0 / 3.0]                      # J1 = 2 > J2 + J3: no physical body
    with pytest.raises(ValueError, match="triangle inequality.*allow_nonphysical=True"):
        lgvi.RigidBody(J)
    with pytest.raises(TypeError, match="allow_nonphysical must be True or False"):
        lgvi.RigidBody(J, allow_nonphysical="yes")
    body = lgvi.RigidBody(J, allow_nonphysical=True)
    assert not body.physical and lgvi.RigidBody([1.0, 2.0, 3.0]).physical
    assert repr(body) == "RigidBody(inertia=[2, 1, 0.6666666667], allow_nonphysical=True)"
    copy = pickle.loads(pickle.dumps(body))
    assert not copy.physical and np.array_equal(copy.J, body.J)
    assert np.linalg.eigvalsh(body.Jd).min() < 0        # Jd indefinite
    # the method's properties still hold: the free body keeps |Pi| and the energy to round-off
    tr = lgvi.simulate(body, np.eye(3), omega0=[1.0, 1.0, 1.0], h=0.05, steps=400)
    Pi = np.linalg.norm(tr.Pi, axis=1)
    assert np.ptp(Pi) < 1e-13 * Pi[0] and np.ptp(tr.energy) < 1e-13 * tr.energy[0]
    L = tr.spatial_momentum
    assert np.abs(L - L[0]).max() < 1e-13 * np.abs(L[0]).max()
