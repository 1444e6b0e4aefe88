"""Polyhedra in the two-body problem (issue 16, part 2): ``lgvi.Polyhedron``'s exact moments."""

from __future__ import annotations

from itertools import product
from math import factorial

import numpy as np
import pytest
from scipy.special import roots_jacobi
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.systems.two_body import Moments, mutual_potential

R1 = Rotation.from_rotvec([0.3, 0.5, -1.0]).as_matrix()
R2 = Rotation.from_rotvec([2.0, -0.5, 0.4]).as_matrix()

#: Box faces over vertices ``4 ix + 2 iy + iz`` (corner signs), counter-clockwise from outside.
BOX_FACES = [[0, 1, 3], [0, 3, 2], [4, 7, 5], [4, 6, 7], [0, 4, 5], [0, 5, 1], [2, 7, 6], [2, 3, 7],
             [0, 2, 6], [0, 6, 4], [1, 7, 3], [1, 5, 7]]
TET = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TET_FACES = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]


def box(a, b, c, center=(0.0, 0.0, 0.0), **kw):
    """The box ``|x| <= a, |y| <= b, |z| <= c`` moved to ``center``."""
    V = np.array([[x, y, z] for x in (-a, a) for y in (-b, b) for z in (-c, c)]) + np.asarray(center)
    return lgvi.Polyhedron(V, BOX_FACES, **kw)


def icosphere(level):
    """The unit icosahedron subdivided ``level`` times, projected to the sphere: (vertices, faces)."""
    t = (1.0 + 5 ** 0.5) / 2.0
    V = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    F = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
         [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11],
         [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    V = [np.array(v, dtype=float) / np.linalg.norm(v) for v in V]
    for _ in range(level):
        mid = {}

        def middle(i, j):
            key = (min(i, j), max(i, j))
            if key not in mid:
                m = V[i] + V[j]
                V.append(m / np.linalg.norm(m))
                mid[key] = len(V) - 1
            return mid[key]

        F = [g for a, b, c in F for g in ([a, middle(a, b), middle(c, a)], [b, middle(b, c), middle(a, b)],
                                          [c, middle(c, a), middle(b, c)], [middle(a, b), middle(b, c), middle(c, a)])]
    V, F = np.array(V), np.array(F)
    normal = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    assert np.all(np.einsum("ij,ij->i", normal, V[F].mean(axis=1)) > 0)     # outward, as built
    return V, F


def sample(poly, mass):
    """The polyhedron as point masses: a positive 27-point rule on each tetrahedron from the centre of
    mass (Gauss-Jacobi in collapsed coordinates), exact for polynomials of degree 5, so the points
    have the polyhedron's moments through the fifth order."""
    rules = [roots_jacobi(3, alpha, 0.0) for alpha in (2.0, 1.0, 0.0)]
    rules = [((x + 1.0) / 2.0, w / 2.0 ** (alpha + 1)) for (x, w), alpha in zip(rules, (2.0, 1.0, 0.0))]
    P = poly.vertices[poly.faces] - poly.center_of_mass
    vol = np.linalg.det(P) / 6.0
    assert np.all(vol > 0)                                      # star-shaped about the centre of mass
    pts, wts = [], []
    for (t1, w1), (t2, w2), (t3, w3) in product(*[list(zip(*r)) for r in rules]):
        bary = np.array([t1, (1 - t1) * t2, (1 - t1) * (1 - t2) * t3])
        pts.append(np.einsum("a,tai->ti", bary, P))
        wts.append(6.0 * vol * w1 * w2 * w3)
    w = np.concatenate(wts)
    return lgvi.PointMasses(mass * w / w.sum(), np.concatenate(pts))


def central_moments_exact(V, n):
    """The moments (3,)*n per unit volume of the tetrahedron ``V`` about its centroid, from the
    monomial integrals over the unit tetrahedron ``int x^a y^b z^c = a! b! c! / (a + b + c + 3)!``
    (``V`` must be the unit tetrahedron)."""
    c = np.full(3, 0.25)

    def raw(idx):
        k = np.bincount(np.array(idx, dtype=int), minlength=3)
        return np.prod([factorial(int(x)) for x in k]) / factorial(len(idx) + 3) * 6.0

    out = np.zeros((3,) * n)
    for idx in np.ndindex(*out.shape):
        for keep in product((0, 1), repeat=n):
            out[idx] += (raw([i for i, s in zip(idx, keep) if s])
                         * np.prod([-c[i] for i, s in zip(idx, keep) if not s]))
    return out


def box_moments(m, ax):
    S = np.diag(m * np.asarray(ax) ** 2 / 3.0)
    T4 = np.zeros((3, 3, 3, 3))
    for idx in np.ndindex(3, 3, 3, 3):
        k = np.bincount(idx, minlength=3)
        if np.all(k % 2 == 0):          # int x^4 = a^4/5 (per unit volume), int x^2 y^2 = a^2 b^2 / 9
            T4[idx] = m * np.prod([{0: 1.0, 2: a ** 2 / 3.0, 4: a ** 4 / 5.0}[int(kk)] for kk, a in zip(k, ax)])
    return S, T4


def test_box_and_cube_against_closed_forms():
    ax = (1.0, 0.7, 0.4)
    p = box(*ax, center=(3.0, -2.0, 1.5), density=2.0)
    assert abs(p.volume - 8 * 0.28) < 1e-14 * p.volume
    assert np.abs(p.center_of_mass - [3.0, -2.0, 1.5]).max() < 1e-14 * 3
    assert abs(p.mass - 2.0 * p.volume) < 1e-14 * p.mass
    S, T3, T4 = p.moments()
    S_want, T4_want = box_moments(p.mass, ax)
    assert np.abs(S - S_want).max() < 1e-14 * np.abs(S_want).max()
    assert np.abs(T3).max() < 1e-14 * p.mass
    assert np.abs(T4 - T4_want).max() < 1e-14 * np.abs(T4_want).max()
    assert np.array_equal(T4, np.transpose(T4, (1, 0, 3, 2))) and np.array_equal(S, S.T)
    # a cube of side 2 s and mass m: inertia m (2 s)^2 / 6 I; the mass scales the moments
    cube = box(0.5, 0.5, 0.5, center=(10.0, 0.0, 0.0))
    assert cube.mass is None
    J = cube.inertia(3.0)
    assert np.abs(J - 3.0 / 6.0 * np.eye(3)).max() < 1e-14
    assert np.allclose(cube.moments(3.0)[2], 3.0 * cube.moments(1.0)[2], rtol=1e-15, atol=0)


@pytest.mark.parametrize("n", [2, 3, 4])
def test_tetrahedron_against_monomial_integrals(n):
    # an asymmetric body (odd moments too) against the monomial integrals, expanded independently
    p = lgvi.Polyhedron(TET, TET_FACES, mass=6.0)              # volume 1/6: density 36
    assert abs(p.volume - 1.0 / 6.0) < 1e-16 and np.allclose(p.center_of_mass, 0.25, rtol=0, atol=1e-16)
    got = p.moments()[n - 2]
    want = 6.0 * central_moments_exact(TET, n)
    assert np.abs(want).max() > 1e-3
    assert np.abs(got - want).max() < 1e-14 * np.abs(want).max()


def test_icosphere_scaled_to_an_ellipsoid_converges_to_its_moments():
    # inscribed polyhedra: the moments' error falls as the square of the edge (4x per subdivision)
    axes = np.array([1.0, 0.7, 0.5])
    S_e, _, T4_e = lgvi.Ellipsoid(*axes).moments(2.0)
    errs = []
    for level in range(1, 5):
        V, F = icosphere(level)
        S, T3, T4 = lgvi.Polyhedron(V * axes, F).moments(2.0)
        assert np.abs(T3).max() < 1e-14            # centrally symmetric
        errs.append(max(np.abs(S - S_e).max() / np.abs(S_e).max(), np.abs(T4 - T4_e).max() / np.abs(T4_e).max()))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((3.5 < ratios) & (ratios < 4.5)), (errs, ratios)
    assert errs[-1] < 5e-3                       # 2.9e-3 at 5120 faces


def test_moments_transform_with_the_mesh():
    # a lumpy (asymmetric, non-convex) mesh: translation leaves the moments, a rotation Q turns them
    rng = np.random.default_rng(7)
    V, F = icosphere(2)
    V = V * rng.uniform(0.8, 1.2, (len(V), 1)) * [1.0, 0.8, 0.6] + [0.3, 0.0, 0.1]
    p = lgvi.Polyhedron(V, F, mass=1.5)
    S, T3, T4 = p.moments()
    assert np.abs(T3).max() > 1e-3 * np.abs(S).max() ** 1.5          # the odd moments are there
    Q = Rotation.from_rotvec([0.4, -1.1, 0.7]).as_matrix()
    t = np.array([5.0, -3.0, 2.0])
    q = lgvi.Polyhedron(V @ Q.T + t, F, mass=1.5)
    assert abs(q.volume - p.volume) < 1e-14 * p.volume
    assert np.abs(q.center_of_mass - (Q @ p.center_of_mass + t)).max() < 1e-14 * 6
    S2, T32, T42 = q.moments()
    assert np.abs(S2 - Q @ S @ Q.T).max() < 1e-14 * np.abs(S).max()
    assert np.abs(T32 - np.einsum("ai,bj,ck,ijk->abc", Q, Q, Q, T3)).max() < 1e-14 * np.abs(T3).max() * 10
    assert np.abs(T42 - np.einsum("ai,bj,ck,dl,ijkl->abcd", Q, Q, Q, Q, T4)).max() < 1e-13 * np.abs(T4).max()
    # and a wrong transform (Q^T) is caught by the same check
    assert np.abs(T32 - np.einsum("ia,jb,kc,ijk->abc", Q, Q, Q, T3)).max() > 1e-3 * np.abs(T3).max()


def _bodies():
    """An icosphere ellipsoid and a box, each with its mass-point sample (the same moments through fifth order)."""
    V, F = icosphere(1)
    p1 = lgvi.Polyhedron(V * [1.0, 0.7, 0.5], F, mass=1.0)
    p2 = box(0.6, 0.4, 0.3, mass=0.5)
    return p1, p2, sample(p1, 1.0), sample(p2, 0.5)


def test_mass_point_sample_has_the_polyhedron_moments():
    for poly, points in _bodies()[0::2], _bodies()[1::2]:
        for got, want in zip(points.moments(), poly.moments()):
            assert np.abs(got - want).max() < 1e-13 * max(np.abs(want).max(), 1e-2)


def test_truncation_error_scales_as_r_minus_7_at_fourth_order():
    # the polyhedra's order-4 potential against the exact potential of their mass-point samples:
    # odd moments vanish (both bodies centrally symmetric), so the first neglected order is the
    # sixth, r^-7 (order2: the fourth, r^-5)
    p1, p2, s1, s2 = _bodies()
    exact = (Moments(s1, None, "points", "body1", "m1"), Moments(s2, None, "points", "body2", "m2"))
    rs = np.array([6.0, 12.0, 24.0, 48.0])
    direction = np.array([0.6, 0.64, 0.48])
    slopes = {}
    for potential in ("order2", "order4"):
        trunc = (Moments(p1, None, potential, "body1", "m1"), Moments(p2, None, potential, "body2", "m2"))
        err = []
        for r in rs:
            d = (r * direction)[None]
            U = mutual_potential("points", 1.0, d, R1[None], R2[None], *exact)[0]
            err.append(abs(mutual_potential(potential, 1.0, d, R1[None], R2[None], *trunc)[0] - U))
        slopes[potential] = np.polyfit(np.log(rs), np.log(err), 1)[0]
    assert -5.1 < slopes["order2"] < -4.9, slopes
    assert -7.1 < slopes["order4"] < -6.9, slopes


def test_two_body_run_with_polyhedra():
    p1, p2, s1, s2 = _bodies()
    kw = dict(x0=[4.0, 0.5, 0.3], v0=[0.0, 0.5, 0.1], R1_0=R1, R2_0=R2, omega1_0=[0.1, 0.2, 0.6],
              omega2_0=[0.4, -0.2, 0.1], h=0.05, steps=40)
    runs = {"poly": lgvi.simulate_two_body(p1, p2, None, None, potential="order4", **kw),
            "poly-mass": lgvi.simulate_two_body(box(0.6, 0.4, 0.3), p1, 0.5, None, potential="order4", **kw)}
    for potential in ("order2", "order4", "points"):
        runs[potential] = lgvi.simulate_two_body(s1, s2, None, None, potential=potential, **kw)
    poly, o2, o4, exact = runs["poly"], runs["order2"], runs["order4"], runs["points"]
    # the same moments: the polyhedra and their samples run alike at order 4
    assert np.abs(poly.x - o4.x).max() < 1e-12 and np.abs(poly.R - o4.R).max() < 1e-12
    # and order 4 follows the exact potential of the points much closer than order 2
    e4 = np.abs(poly.R[-1] - exact.R[-1]).max()
    e2 = np.abs(o2.R[-1] - exact.R[-1]).max()
    assert e4 < 0.1 * e2, (e4, e2)
    L = poly.angular_momentum
    assert np.linalg.norm(L - L[0], axis=1).max() < 5e-14 * np.linalg.norm(L[0])
    assert runs["poly-mass"].masses.tolist() == [0.5, 1.0]
