"""RigidBody and the inertia conversions: values, vectorisation, immutability, validation."""

from __future__ import annotations

import copy
import dataclasses
import doctest
import pickle

import numpy as np
import pytest

from lgvi import body as body_module
from lgvi.body import RigidBody, check_inertia, inertia_to_jd, jd_to_inertia


def random_inertia(rng: np.random.Generator) -> np.ndarray:
    """A random physical inertia matrix: random principal moments, random principal axes."""
    a, b = rng.uniform(0.5, 2.0, size=2)
    c = rng.uniform(abs(a - b), a + b)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q @ np.diag([a, b, c]) @ Q.T


# ---------------------------------------------------------------------------------------------
# inertia_to_jd / jd_to_inertia
# ---------------------------------------------------------------------------------------------
def test_conversions_match_the_paper_formulas() -> None:
    J = np.diag([1.0, 2.0, 3.0])
    Jd = inertia_to_jd(J)
    np.testing.assert_array_equal(Jd, np.diag([2.0, 1.0, 0.0]))
    np.testing.assert_array_equal(jd_to_inertia(Jd), J)
    # J = tr(Jd) I - Jd and Jd = tr(J)/2 I - J, entry by entry on a full matrix
    rng = np.random.default_rng(1)
    J = random_inertia(rng)
    np.testing.assert_allclose(inertia_to_jd(J), np.trace(J) / 2 * np.eye(3) - J, rtol=0, atol=1e-15)
    Jd = inertia_to_jd(J)
    np.testing.assert_allclose(jd_to_inertia(Jd), np.trace(Jd) * np.eye(3) - Jd, rtol=0, atol=1e-15)


def test_conversions_are_vectorised_and_inverse() -> None:
    rng = np.random.default_rng(2)
    J = np.array([[random_inertia(rng) for _ in range(4)] for _ in range(2)])
    Jd = inertia_to_jd(J)
    assert Jd.shape == (2, 4, 3, 3)
    assert Jd.dtype == np.float64
    np.testing.assert_allclose(jd_to_inertia(Jd), J, rtol=0, atol=1e-15)
    for i in range(2):
        for j in range(4):
            np.testing.assert_array_equal(Jd[i, j], inertia_to_jd(J[i, j]))
    # integer input is accepted and promoted
    assert inertia_to_jd(np.eye(3, dtype=int)).dtype == np.float64


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((3, 4)), np.zeros((2, 2))])
def test_conversions_reject_wrong_shapes(bad: np.ndarray) -> None:
    with pytest.raises(ValueError, match=r"J must have shape \(\.\.\., 3, 3\)"):
        inertia_to_jd(bad)
    with pytest.raises(ValueError, match=r"Jd must have shape \(\.\.\., 3, 3\)"):
        jd_to_inertia(bad)


# ---------------------------------------------------------------------------------------------
# RigidBody: attributes
# ---------------------------------------------------------------------------------------------
def test_principal_moments_give_a_diagonal_body() -> None:
    b = RigidBody([3.0, 1.0, 2.5])
    np.testing.assert_array_equal(b.J, np.diag([3.0, 1.0, 2.5]))
    np.testing.assert_array_equal(b.Jd, np.diag([0.25, 2.25, 0.75]))
    np.testing.assert_array_equal(b.J_inv, np.diag([1 / 3.0, 1.0, 1 / 2.5]))
    np.testing.assert_array_equal(b.principal_moments, [1.0, 2.5, 3.0])
    assert b.is_diagonal
    V = b.principal_axes
    assert np.linalg.det(V) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_array_equal(b.J @ V, V * b.principal_moments)


def test_matrix_input() -> None:
    rng = np.random.default_rng(3)
    J = random_inertia(rng)
    J = 0.5 * (J + J.T)
    b = RigidBody(J)
    assert not b.is_diagonal
    np.testing.assert_array_equal(b.J, J)
    np.testing.assert_allclose(b.J_inv @ b.J, np.eye(3), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(b.J_inv, b.J_inv.T)
    np.testing.assert_allclose(b.Jd, np.trace(J) / 2 * np.eye(3) - J, rtol=0, atol=0)
    moments, V = b.principal_moments, b.principal_axes
    assert np.all(np.diff(moments) >= 0)
    np.testing.assert_allclose(moments, np.linalg.eigvalsh(J), rtol=1e-14)
    np.testing.assert_allclose(V.T @ V, np.eye(3), rtol=0, atol=1e-14)
    assert np.linalg.det(V) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(J @ V, V * moments, rtol=0, atol=1e-14)
    # a diagonal matrix given as (3, 3) is recognised as diagonal
    assert RigidBody(np.diag([1.0, 2.0, 2.0])).is_diagonal


@pytest.mark.parametrize("moments", [[1.0, 1.0, 1.0], [2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [3.0, 2.0, 1.5]])
def test_principal_axes_are_a_proper_rotation_for_any_order(moments: list[float]) -> None:
    b = RigidBody(moments)
    V = b.principal_axes
    assert np.linalg.det(V) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_array_equal(b.J @ V, V * b.principal_moments)


def test_arrays_are_float64_and_read_only() -> None:
    source = np.array([1.0, 2.0, 2.5])
    b = RigidBody(source)
    for name in ("J", "Jd", "J_inv", "principal_moments", "principal_axes"):
        arr = getattr(b, name)
        assert arr.dtype == np.float64
        assert not arr.flags.writeable
        with pytest.raises(ValueError):
            arr[0] = 7.0
    assert b.J.shape == b.Jd.shape == b.J_inv.shape == b.principal_axes.shape == (3, 3)
    assert b.principal_moments.shape == (3,)
    source[0] = 100.0  # the body does not share memory with its input
    assert b.J[0, 0] == 1.0


def test_body_is_frozen() -> None:
    b = RigidBody([1.0, 2.0, 2.5])
    with pytest.raises(dataclasses.FrozenInstanceError):
        b.J = np.eye(3)  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        b.is_diagonal = False  # type: ignore[misc]


def test_integer_and_list_input() -> None:
    b = RigidBody([1, 2, 2])
    assert b.J.dtype == np.float64
    assert RigidBody([[2, 0, 0], [0, 2, 0], [0, 0, 3]]) == RigidBody([2.0, 2.0, 3.0])


def test_equality_hash_copy_pickle() -> None:
    a = RigidBody([1.0, 2.0, 2.5])
    b = RigidBody(np.diag([1.0, 2.0, 2.5]))
    assert a == b and hash(a) == hash(b)
    assert a != RigidBody([1.0, 2.0, 2.4])
    assert a != "not a body"
    assert len({a, b}) == 1
    c = RigidBody(np.array([[1.0, -0.0, 0.0], [-0.0, 2.0, 0.0], [0.0, 0.0, 2.5]]))
    assert c == a and hash(c) == hash(a)
    for other in (copy.copy(a), copy.deepcopy(a), pickle.loads(pickle.dumps(a))):
        assert other == a
        assert not other.J.flags.writeable
        assert not other.principal_axes.flags.writeable
    assert RigidBody(a) == a


def test_repr_is_short() -> None:
    assert repr(RigidBody([1.0, 2.0, 2.5])) == "RigidBody(inertia=[1, 2, 2.5])"
    rng = np.random.default_rng(4)
    text = repr(RigidBody(random_inertia(rng)))
    assert text.startswith("RigidBody(principal_moments=[") and "\n" not in text
    assert len(text) < 100


# ---------------------------------------------------------------------------------------------
# RigidBody: physics
# ---------------------------------------------------------------------------------------------
def test_kinetic_energy_omega_momentum() -> None:
    rng = np.random.default_rng(5)
    b = RigidBody(random_inertia(rng))
    Pi = rng.normal(size=(4, 5, 3))
    omega = b.omega(Pi)
    assert omega.shape == (4, 5, 3)
    np.testing.assert_allclose(b.momentum(omega), Pi, rtol=1e-13, atol=1e-14)
    T = b.kinetic_energy(Pi)
    assert T.shape == (4, 5)
    expected = 0.5 * np.einsum("...i,ij,...j->...", omega, b.J, omega)
    np.testing.assert_allclose(T, expected, rtol=1e-13)
    # the paper's form: K = 1/2 tr(hat(Omega) Jd hat(Omega)^T)
    w = omega[0, 0]
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    assert 0.5 * np.trace(W @ b.Jd @ W.T) == pytest.approx(T[0, 0], rel=1e-13)
    # a single vector gives a scalar
    assert np.ndim(b.kinetic_energy(Pi[0, 0])) == 0
    assert b.omega(Pi[0, 0]).shape == (3,)


def test_physics_methods_reject_wrong_shapes() -> None:
    b = RigidBody([1.0, 2.0, 2.5])
    with pytest.raises(ValueError, match=r"Pi must have shape \(\.\.\., 3\)"):
        b.kinetic_energy(np.ones((3, 2)))
    with pytest.raises(ValueError, match=r"Pi must have shape"):
        b.omega(1.0)
    with pytest.raises(ValueError, match=r"omega must have shape"):
        b.momentum(np.ones(4))


# ---------------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("inertia", "pattern"),
    [
        ([1.0, 2.0], r"inertia must have shape \(3,\) .* or \(3, 3\) .*got shape \(2,\)"),
        (np.ones((3, 3, 1)), r"inertia must have shape .*got shape \(3, 3, 1\)"),
        (np.eye(4), r"inertia must have shape .*got shape \(4, 4\)"),
        ([1.0, np.nan, 2.0], r"inertia must be finite .*nan"),
        ([1.0, np.inf, 2.0], r"inertia must be finite .*inf"),
        ([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r"inertia must be symmetric: max \|J - J\^T\| = 0\.1"),
        ([-1.0, 2.0, 2.0], r"inertia must be positive definite: its smallest eigenvalue is -1"),
        ([0.0, 1.0, 1.0], r"inertia must be positive definite: its smallest eigenvalue is 0"),
        (
            [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            r"inertia must be positive definite: its smallest eigenvalue is -1",
        ),
        ([1.0, 2.0, 5.0], r"inertia violates the triangle inequality of a physical body: J3 = 5 > J1 \+ J2 = 3 "
                          r"\(Jd = tr\(J\)/2 I - J must be positive semidefinite"),
        ([5.0, 1.0, 2.0], r"J3 = 5 > J1 \+ J2 = 3"),
        ("abc", r"inertia must be an array of real numbers"),
        ([1 + 1j, 2.0, 2.0], r"inertia must be an array of real numbers"),
        ([[1.0, 2.0], [3.0]], r"inertia must be an array of shape"),
    ],
)
def test_invalid_inertia_is_rejected_with_a_clear_message(inertia: object, pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        RigidBody(inertia)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=pattern):
        check_inertia(inertia)  # type: ignore[arg-type]


def test_triangle_inequality_on_a_rotated_matrix() -> None:
    rng = np.random.default_rng(6)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    J = Q @ np.diag([1.0, 1.0, 3.0]) @ Q.T
    with pytest.raises(ValueError, match="triangle inequality"):
        RigidBody(0.5 * (J + J.T))


def test_flat_body_is_legal_within_tolerance() -> None:
    b = RigidBody([1.0, 2.0, 3.0])  # J1 + J2 = J3: a lamina
    assert np.min(np.linalg.eigvalsh(b.Jd)) == 0.0
    RigidBody([1.0, 2.0, 3.0 * (1 + 5e-13)])  # within 1e-12 relative
    with pytest.raises(ValueError, match="triangle inequality"):
        RigidBody([1.0, 2.0, 3.0 * (1 + 1e-11)])
    # a thin rod: J1 -> 0, J2 = J3
    RigidBody([1e-9, 1.0, 1.0])


def test_nearly_symmetric_input_is_symmetrised_exactly() -> None:
    J = np.array([[2.0, 0.1, 0.0], [0.1 * (1 + 1e-14), 2.5, 0.0], [0.0, 0.0, 3.0]])
    b = RigidBody(J)
    np.testing.assert_array_equal(b.J, b.J.T)
    assert b.J[0, 1] == pytest.approx(0.1, rel=1e-13)
    with pytest.raises(ValueError, match="symmetric"):
        RigidBody(np.array([[2.0, 0.1, 0.0], [0.1 * (1 + 1e-9), 2.5, 0.0], [0.0, 0.0, 3.0]]))


def test_docstring_examples_run() -> None:
    result = doctest.testmod(body_module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0


@pytest.mark.parametrize("moments", [[1.0, 2.0, 3.0], [3.0, 2.0, 1.0], [2.0, 3.0, 1.0], [3.0, 1.0, 2.0],
                                     [1.0, 3.0, 2.0], [2.0, 1.0, 3.0], [2.0, 2.0, 1.0], [1.0, 1.0, 1.0],
                                     [0.0433, 0.0418, 0.0067], [900.0, 800.0, 600.0]])
def test_diagonal_body_in_floats_is_the_numpy_formulas_bit_for_bit(moments) -> None:
    """A diagonal body's arrays are computed in Python floats: the same bits as the NumPy
    formulas of the general path (signs of zeros included), for every order of the moments."""
    from lgvi.body import _principal

    for J in (np.diag(moments), np.array(moments)):
        b = RigidBody(J)
        Jm = np.diag(np.asarray(moments, dtype=np.float64))
        want_moments, want_axes, diagonal = _principal(Jm)
        assert b.is_diagonal and diagonal
        for got, want in ((b.J, Jm), (b.Jd, inertia_to_jd(Jm)), (b.J_inv, np.diag(1.0 / np.diag(Jm))),
                          (b.principal_moments, want_moments), (b.principal_axes, want_axes)):
            assert got.dtype == np.float64 and got.shape == want.shape and got.tobytes() == want.tobytes()
            assert not got.flags.writeable
        assert np.linalg.det(b.principal_axes) == 1.0
        copy = RigidBody(b)                                   # a body from a body: the same arrays
        for name in ("J", "Jd", "J_inv", "principal_moments", "principal_axes"):
            assert getattr(copy, name).tobytes() == getattr(b, name).tobytes()
