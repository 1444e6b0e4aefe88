"""The exact free rigid body (lgvi.exact) against Euler's equations integrated by DOP853."""

from __future__ import annotations

import doctest
import functools

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from lgvi.verification import exact as exact_module
from lgvi.verification.exact import free_body, free_body_attitude, free_body_momentum

T_END = 20.0
TIMES = np.linspace(0.0, T_END, 81)


def hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rhs(t: float, y: np.ndarray, moments: np.ndarray) -> np.ndarray:
    R = y[:9].reshape(3, 3)
    Pi = y[9:]
    omega = Pi / moments
    return np.concatenate([(R @ hat(omega)).ravel(), np.cross(Pi, omega)])


@functools.lru_cache(maxsize=None)
def reference(moments: tuple[float, ...], Pi0: tuple[float, ...], seed: int) -> tuple[np.ndarray, ...]:
    """R0, and (R, Pi) at TIMES from DOP853 with rtol = atol = 1e-13 (cached across tests)."""
    R0 = Rotation.random(random_state=seed).as_matrix()
    y0 = np.concatenate([R0.ravel(), Pi0])
    sol = solve_ivp(
        rhs, (0.0, T_END), y0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=TIMES,
        args=(np.array(moments),),
    )
    assert sol.success
    return R0, sol.y[:9].T.reshape(-1, 3, 3), sol.y[9:].T


def regime(moments: tuple[float, ...], Pi0: tuple[float, ...]) -> str:
    I = np.array(moments)
    P = np.array(Pi0)
    two_E = np.sum(P**2 / I)
    return "major" if np.sum(P**2) > two_E * np.sort(I)[1] else "minor"


BODIES = [(1.0, 2.0, 3.0), (3.0, 1.0, 2.0), (2.0, 3.0, 1.5), (0.5, 0.9, 1.3)]
MOMENTA = [(0.3, 0.2, 1.0), (1.0, -0.4, 0.2), (-0.5, 0.8, -0.6), (-0.1, -1.0, 0.05), (0.7, 0.6, -0.5)]
CASES = [(b, p) for b in BODIES for p in MOMENTA]


def test_cases_cover_both_regimes_and_signs() -> None:
    regimes = {regime(b, p) for b, p in CASES}
    assert regimes == {"major", "minor"}
    signs = {tuple(np.sign(p)) for _, p in CASES}
    assert len(signs) >= 4


# ---------------------------------------------------------------------------------------------
# (a) Euler's equations, (b) invariants
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("moments", "Pi0"), CASES)
def test_momentum_matches_dop853(moments: tuple[float, ...], Pi0: tuple[float, ...]) -> None:
    _, _, Pi_ref = reference(moments, Pi0, 0)
    Pi = free_body_momentum(moments, Pi0, TIMES)
    assert Pi.shape == (TIMES.size, 3)
    np.testing.assert_allclose(Pi, Pi_ref, rtol=0, atol=1e-9 * np.linalg.norm(Pi0))
    np.testing.assert_allclose(Pi[0], Pi0, rtol=0, atol=1e-15)


@pytest.mark.parametrize(("moments", "Pi0"), CASES)
def test_casimir_and_energy_are_conserved(moments: tuple[float, ...], Pi0: tuple[float, ...]) -> None:
    t = np.linspace(-50.0, 200.0, 2001)
    Pi = free_body_momentum(moments, Pi0, t)
    I = np.array(moments)
    P0 = np.array(Pi0)
    np.testing.assert_allclose(np.sum(Pi**2, axis=1), np.sum(P0**2), rtol=1e-13)
    np.testing.assert_allclose(np.sum(Pi**2 / I, axis=1), np.sum(P0**2 / I), rtol=1e-13)


def test_momentum_at_scattered_times_and_shapes() -> None:
    moments, Pi0 = (1.0, 2.0, 3.0), (0.3, 0.2, 1.0)
    t = np.array([3.0, -1.5, 0.0, 17.25])
    Pi = free_body_momentum(moments, Pi0, t)
    for k, tk in enumerate(t):
        np.testing.assert_allclose(Pi[k], free_body_momentum(moments, Pi0, [tk])[0], rtol=0, atol=1e-15)
    assert free_body_momentum(moments, Pi0, 1.0).shape == (3,)
    assert free_body_momentum(moments, Pi0, np.zeros((2, 4))).shape == (2, 4, 3)
    # backwards in time: Pi(-t) from Pi(t) retraces
    Pi_t = free_body_momentum(moments, Pi0, [4.0])[0]
    np.testing.assert_allclose(free_body_momentum(moments, Pi_t, [-4.0])[0], Pi0, rtol=0, atol=1e-14)


def test_momentum_is_independent_of_the_axis_order() -> None:
    """Relabelling the body axes cyclically relabels the solution."""
    moments, Pi0 = np.array([1.0, 2.0, 3.0]), np.array([0.7, 0.6, -0.5])
    Pi = free_body_momentum(moments, Pi0, TIMES)
    for shift in (1, 2):
        order = np.roll(np.arange(3), shift)
        Pi_perm = free_body_momentum(moments[order], Pi0[order], TIMES)
        np.testing.assert_allclose(Pi_perm, Pi[:, order], rtol=0, atol=1e-13)


# ---------------------------------------------------------------------------------------------
# (c) attitude
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("moments", "Pi0"), CASES)
def test_attitude_matches_dop853(moments: tuple[float, ...], Pi0: tuple[float, ...]) -> None:
    R0, R_ref, Pi_ref = reference(moments, Pi0, 0)
    R, Pi = free_body(moments, R0, Pi0, TIMES)
    np.testing.assert_allclose(R, R_ref, rtol=0, atol=1e-8)
    np.testing.assert_allclose(Pi, Pi_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(R[0], R0, rtol=0, atol=1e-14)
    # orthogonality, det +1, and a constant spatial momentum
    np.testing.assert_allclose(np.einsum("nji,njk->nik", R, R), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    L = np.einsum("nij,nj->ni", R, Pi)
    np.testing.assert_allclose(L, np.broadcast_to(R0 @ np.array(Pi0), L.shape), rtol=0, atol=1e-12)
    # free_body_attitude is the attitude part of free_body
    np.testing.assert_array_equal(free_body_attitude(moments, R0, Pi0, TIMES), R)


def test_attitude_has_the_flow_property() -> None:
    """Advancing by s then by t equals advancing by s + t (also backwards)."""
    moments, Pi0 = (0.5, 0.9, 1.3), (1.0, -0.4, 0.2)
    R0 = Rotation.random(random_state=7).as_matrix()
    R_s, Pi_s = free_body(moments, R0, Pi0, [7.3])
    R_st, Pi_st = free_body(moments, R_s[0], Pi_s[0], [5.1, -7.3])
    R_direct, Pi_direct = free_body(moments, R0, Pi0, [12.4, 0.0])
    np.testing.assert_allclose(R_st, R_direct, rtol=0, atol=1e-13)
    np.testing.assert_allclose(Pi_st, Pi_direct, rtol=0, atol=1e-13)


def test_attitude_accepts_a_scipy_rotation_and_any_time_shape() -> None:
    rot = Rotation.from_rotvec([0.1, -0.2, 0.3])
    R = free_body_attitude((1.0, 2.0, 3.0), rot, (0.3, 0.2, 1.0), np.full((2, 3), 0.5))
    assert R.shape == (2, 3, 3, 3)
    R1 = free_body_attitude((1.0, 2.0, 3.0), rot.as_matrix(), (0.3, 0.2, 1.0), 0.5)
    assert R1.shape == (3, 3)
    np.testing.assert_array_equal(R[1, 2], R1)


# ---------------------------------------------------------------------------------------------
# (d) axisymmetric bodies, (e) steady spins
# ---------------------------------------------------------------------------------------------
AXISYMMETRIC = [
    ((1.0, 1.0, 1.5), (0.3, -0.4, 1.0)),
    ((2.0, 1.0, 1.0), (0.7, 0.2, -0.4)),
    ((1.0, 1.8, 1.0), (-0.3, 0.5, 0.6)),
    ((1.5, 1.5, 1.5), (0.3, 0.5, -0.6)),
]


@pytest.mark.parametrize(("moments", "Pi0"), AXISYMMETRIC)
def test_axisymmetric_body_matches_the_closed_form(moments: tuple[float, ...], Pi0: tuple[float, ...]) -> None:
    I = np.array(moments)
    P0 = np.array(Pi0)
    values, counts = np.unique(I, return_counts=True)
    J_perp = values[np.argmax(counts)]
    s = int(np.argmax(I != J_perp)) if len(values) > 1 else 2
    e_s = np.eye(3)[s]
    mu = (1.0 / I[s] - 1.0 / J_perp) * P0[s]
    R0 = Rotation.random(random_state=3).as_matrix()
    L = R0 @ P0
    R, Pi = free_body(moments, R0, Pi0, TIMES)
    for k, t in enumerate(TIMES):
        np.testing.assert_allclose(Pi[k], expm(-t * mu * hat(e_s)) @ P0, rtol=0, atol=1e-13)
        R_closed = expm(t * hat(L) / J_perp) @ R0 @ expm(t * mu * hat(e_s))
        np.testing.assert_allclose(R[k], R_closed, rtol=0, atol=1e-12)
    # and the ODE
    R0_ref, R_ref, Pi_ref = reference(moments, Pi0, 3)
    np.testing.assert_allclose(R, R_ref, rtol=0, atol=1e-8)
    np.testing.assert_allclose(Pi, Pi_ref, rtol=0, atol=1e-9)


@pytest.mark.parametrize("moments", [(1.0, 2.0, 3.0), (2.0, 2.0, 3.0), (1.0, 2.5, 2.0)])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_spin_about_a_principal_axis(moments: tuple[float, ...], axis: int) -> None:
    Pi0 = np.zeros(3)
    Pi0[axis] = -1.3
    omega0 = Pi0 / np.array(moments)
    R0 = Rotation.random(random_state=11).as_matrix()
    R, Pi = free_body(moments, R0, Pi0, TIMES)
    np.testing.assert_array_equal(Pi, np.broadcast_to(Pi0, Pi.shape))
    for k, t in enumerate(TIMES):
        # expm's scaling and squaring loses ~eps per radian: 1e-12 over the 26 rad turned here
        np.testing.assert_allclose(R[k], R0 @ expm(t * hat(omega0)), rtol=0, atol=1e-12)


def test_spin_about_the_major_axis_through_the_elliptic_path() -> None:
    """A tiny wobble about the major axis stays close to the steady spin (continuity)."""
    moments = (1.0, 2.0, 3.0)
    Pi0 = np.array([1e-9, -1e-9, 1.0])
    R0 = Rotation.random(random_state=12).as_matrix()
    R = free_body_attitude(moments, R0, Pi0, TIMES)
    omega0 = np.array([0.0, 0.0, 1.0 / 3.0])
    for k, t in enumerate(TIMES):
        np.testing.assert_allclose(R[k], R0 @ expm(t * hat(omega0)), rtol=0, atol=1e-7)


def test_zero_momentum_is_at_rest() -> None:
    R0 = Rotation.random(random_state=13).as_matrix()
    R, Pi = free_body((1.0, 2.0, 3.0), R0, np.zeros(3), TIMES)
    np.testing.assert_array_equal(Pi, 0.0)
    np.testing.assert_array_equal(R, np.broadcast_to(R0, R.shape))


# ---------------------------------------------------------------------------------------------
# near and on the separatrix, input checks
# ---------------------------------------------------------------------------------------------
def test_close_to_the_separatrix() -> None:
    # |Pi|^2 = 2 E J2 for J = (1, 2, 3) when Pi3^2 = 3 Pi1^2
    moments = (1.0, 2.0, 3.0)
    Pi0 = (1.0, 0.5, np.sqrt(3.0) * (1.0 + 1e-6))
    R0, R_ref, Pi_ref = reference(moments, Pi0, 5)
    R, Pi = free_body(moments, R0, Pi0, TIMES)
    np.testing.assert_allclose(Pi, Pi_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(R, R_ref, rtol=0, atol=1e-8)


def test_separatrix_raises_not_implemented() -> None:
    with pytest.raises(NotImplementedError, match="separatrix"):
        free_body_momentum((1.0, 2.0, 3.0), (1.0, 0.5, np.sqrt(3.0)), TIMES)
    with pytest.raises(NotImplementedError, match="separatrix"):
        free_body_attitude((1.0, 2.0, 3.0), np.eye(3), (2.0, 0.0, np.sqrt(12.0)), TIMES)
    # the middle-axis equilibrium lies on the separatrix but is steady
    np.testing.assert_array_equal(free_body_momentum((1.0, 2.0, 3.0), (0.0, 1.0, 0.0), [5.0]), [[0.0, 1.0, 0.0]])


@pytest.mark.parametrize(
    ("args", "pattern"),
    [
        (((1.0, 2.0), np.eye(3), (1.0, 0.0, 0.0), [1.0]), r"inertia_moments must have shape \(3,\)"),
        (((1.0, -2.0, 3.0), np.eye(3), (1.0, 0.0, 0.0), [1.0]), "inertia_moments must be positive"),
        (((1.0, np.nan, 3.0), np.eye(3), (1.0, 0.0, 0.0), [1.0]), "inertia_moments must be finite"),
        (((1.0, 2.0, 3.0), np.eye(3), (1.0, 0.0), [1.0]), r"Pi0 must have shape \(3,\)"),
        (((1.0, 2.0, 3.0), np.eye(3), (1.0, 0.0, np.inf), [1.0]), "Pi0 must be finite"),
        (((1.0, 2.0, 3.0), np.eye(3), (1.0, 0.0, 0.0), [np.nan]), "t must be finite"),
        (((1.0, 2.0, 3.0), 2 * np.eye(3), (1.0, 0.0, 0.0), [1.0]), "R0 must be a rotation matrix"),
        (((1.0, 2.0, 3.0), -np.eye(3), (1.0, 0.0, 0.0), [1.0]), "R0 must be a rotation matrix"),
        (((1.0, 2.0, 3.0), np.eye(2), (1.0, 0.0, 0.0), [1.0]), r"R0 must be a rotation matrix of shape"),
        ((("a", 2.0, 3.0), np.eye(3), (1.0, 0.0, 0.0), [1.0]), "inertia_moments must be an array of real"),
    ],
)
def test_invalid_input(args: tuple[object, ...], pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        free_body(*args)  # type: ignore[arg-type]


def test_docstring_examples_run() -> None:
    result = doctest.testmod(exact_module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
