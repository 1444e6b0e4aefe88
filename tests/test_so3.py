"""Group axioms and accuracy of :mod:`lgvi.so3` (property-based, with SciPy as an oracle).

Angles are sampled on purpose near 0 (down to 1e-300), in the generic range and near pi, where
closed forms lose accuracy; series coefficients are checked against exact rational arithmetic.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from lgvi import so3

EPS = np.finfo(np.float64).eps
I3 = np.eye(3)

#: settings for every property test here (no deadline: the first call pays NumPy warm-up)
props = settings(deadline=None, max_examples=60)

# --------------------------------------------------------------------------------------------
# strategies and helpers
# --------------------------------------------------------------------------------------------

unit = st.floats(-1.0, 1.0, allow_nan=False)


@st.composite
def axes(draw: st.DrawFn) -> np.ndarray:
    """Unit vectors (directions sampled from a cube, far from degenerate)."""
    v = np.array([draw(unit), draw(unit), draw(unit)])
    n = np.linalg.norm(v)
    if n < 0.1:
        v, n = np.array([0.3, -0.5, 0.8]), np.linalg.norm([0.3, -0.5, 0.8])
    return v / n


vectors = st.tuples(*[st.floats(-10.0, 10.0, allow_nan=False)] * 3).map(np.array)
small_vectors = st.tuples(*[st.floats(-3.0, 3.0, allow_nan=False)] * 3).map(np.array)

log_tiny_angles = st.floats(-300.0, -7.0).map(lambda e: 10.0**e)  # 1e-300 ... 1e-7
log_small_angles = st.floats(-12.0, -7.0).map(lambda e: 10.0**e)  # 1e-12 ... 1e-7
generic_angles = st.floats(1e-6, math.pi - 1e-6)
near_pi_angles = st.floats(-7.0, -3.0).map(lambda e: math.pi - 10.0**e)  # pi-1e-7 ... pi-1e-3


def random_rotations(n: int, seed: int = 0) -> np.ndarray:
    return Rotation.random(n, random_state=seed).as_matrix()


def central_jacobian(fun, w: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of ``fun`` (R^3 -> R^3) at ``w``, columns per direction."""
    cols = []
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        cols.append((fun(w + e) - fun(w - e)) / (2 * h))
    return np.stack(cols, axis=-1)


def _exact_sin_cos(x: Fraction) -> tuple[Fraction, Fraction]:
    """sin and cos of a rational ``|x| <= 4`` by exact Taylor series (error < 1e-60)."""
    s, c, term, n = Fraction(0), Fraction(0), Fraction(1), 0
    tol = Fraction(1, 10**60)
    while True:
        if n % 2 == 0:
            c += term if (n // 2) % 2 == 0 else -term
        else:
            s += term if (n // 2) % 2 == 0 else -term
        n += 1
        term = term * x / n
        if n > 4 and abs(term) < tol:
            return s, c


def exact_coefficients(t: float) -> dict[str, float]:
    """sin(t)/t, (1-cos t)/t^2, (t-sin t)/t^3, (1-(t/2)cot(t/2))/t^2, correctly rounded."""
    T = Fraction(t)
    s, c = _exact_sin_cos(T)
    h = T / 2
    sh, ch = _exact_sin_cos(h)
    return {
        "a": float(s / T),
        "b": float((1 - c) / T**2),
        "c": float((T - s) / T**3),
        "d": float((sh - h * ch) / (sh * T**2)),
    }


# --------------------------------------------------------------------------------------------
# hat / vee
# --------------------------------------------------------------------------------------------


@props
@given(vectors, vectors)
def test_hat_is_cross_product(w, v):
    np.testing.assert_allclose(so3.hat(w) @ v, np.cross(w, v), rtol=1e-14, atol=1e-12)
    np.testing.assert_array_equal(so3.hat(w), -so3.hat(w).T)


@props
@given(vectors)
def test_hat_vee_inverse(w):
    np.testing.assert_array_equal(so3.vee(so3.hat(w)), w)


def test_vee_uses_antisymmetric_part():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(5, 3, 3))
    S = A + np.swapaxes(A, -1, -2)  # symmetric: contributes nothing
    w = rng.normal(size=(5, 3))
    np.testing.assert_allclose(so3.vee(so3.hat(w) + S), w, atol=1e-14)
    np.testing.assert_allclose(so3.vee(A), so3.vee((A - np.swapaxes(A, -1, -2)) / 2), atol=0)


def test_vectorised_over_leading_axes_and_float64():
    rng = np.random.default_rng(2)
    w = rng.normal(size=(2, 4, 3))
    R = so3.exp(w)
    assert R.shape == (2, 4, 3, 3) and R.dtype == np.float64
    for idx in np.ndindex(2, 4):
        np.testing.assert_array_equal(R[idx], so3.exp(w[idx]))
        np.testing.assert_array_equal(so3.log(R)[idx], so3.log(R[idx]))
    assert so3.hat([1, 2, 3]).dtype == np.float64
    assert so3.exp(np.zeros((0, 3))).shape == (0, 3, 3)
    funcs_vec = [so3.left_jacobian, so3.right_jacobian, so3.left_jacobian_inv,
                 so3.right_jacobian_inv, so3.cayley, so3.exp_minus_identity]
    for f in funcs_vec:
        out = f(w)
        assert out.shape == (2, 4, 3, 3)
        np.testing.assert_array_equal(out[1, 2], f(w[1, 2]))


# --------------------------------------------------------------------------------------------
# exp / log
# --------------------------------------------------------------------------------------------


@props
@given(axes(), log_tiny_angles)
def test_log_exp_round_trip_tiny_angles_relative(n, t):
    w = t * n
    err = np.linalg.norm(so3.log(so3.exp(w)) - w)
    assert err <= 8 * EPS * t


@props
@given(axes(), log_small_angles)
def test_exp_minus_identity_keeps_relative_precision(n, t):
    w = t * n
    E = so3.exp_minus_identity(w)
    # exact first two orders: a hat + b hat^2 with a ~ 1 - t^2/6, b ~ 1/2 (t <= 1e-7)
    W = so3.hat(w)
    expected = (1 - t * t / 6) * W + 0.5 * (W @ W)
    scale = np.abs(W) + np.abs(W @ W)
    assert np.all(np.abs(E - expected) <= 4 * EPS * scale + 1e-300)
    # the diagonal is second order, far below what exp(w) - I could resolve
    off_axis = np.roll(w, 1) ** 2 + np.roll(w, 2) ** 2  # w_j^2 + w_k^2, no cancellation
    np.testing.assert_allclose(np.diag(E), -0.5 * off_axis, rtol=1e-13)
    assert np.all(np.diag(so3.exp(w) - I3) == 0.0) or t > 1e-8  # what subtraction would give


@props
@given(axes(), generic_angles)
def test_log_exp_round_trip_generic(n, t):
    w = t * n
    np.testing.assert_allclose(so3.log(so3.exp(w)), w, rtol=0, atol=1e-12)


@props
@given(axes(), near_pi_angles)
def test_log_exp_round_trip_near_pi(n, t):
    w = t * n
    R = so3.exp(w)
    np.testing.assert_allclose(so3.log(R), w, rtol=0, atol=1e-12)
    np.testing.assert_allclose(so3.exp(so3.log(R)), R, rtol=0, atol=1e-12)


@props
@given(axes())
def test_log_at_exactly_pi(n):
    R = 2.0 * np.outer(n, n) - I3  # rotation by pi about n, built without exp
    w = so3.log(R)
    assert abs(np.linalg.norm(w) - math.pi) <= 1e-12
    assert abs(abs(w @ n) - math.pi) <= 1e-12  # parallel to +-n
    np.testing.assert_allclose(so3.exp(w), R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(so3.exp(so3.log(so3.exp(math.pi * n))), so3.exp(math.pi * n),
                               rtol=0, atol=1e-12)


@props
@given(st.one_of(vectors, st.tuples(*[st.floats(-1e-6, 1e-6)] * 3).map(np.array)))
def test_exp_is_rotation_and_inverse_is_transpose(w):
    R = so3.exp(w)
    assert so3.orthogonality_error(R) <= 1e-14
    assert abs(np.linalg.det(R) - 1.0) <= 1e-14
    np.testing.assert_allclose(so3.exp(-w), R.T, rtol=0, atol=1e-15)
    # log always returns an angle in [0, pi] that reproduces R
    v = so3.log(R)
    assert np.linalg.norm(v) <= math.pi + 1e-15
    np.testing.assert_allclose(so3.exp(v), R, rtol=0, atol=1e-13)


def test_exp_log_against_scipy():
    rng = np.random.default_rng(3)
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    t = np.concatenate([10.0 ** rng.uniform(-12, 0, 250), rng.uniform(0.0, math.pi - 1e-3, 250)])
    w = n * t[:, None]
    np.testing.assert_allclose(so3.exp(w), Rotation.from_rotvec(w).as_matrix(), rtol=0, atol=1e-14)
    R = random_rotations(500, seed=4)
    np.testing.assert_allclose(so3.log(R), Rotation.from_matrix(R).as_rotvec(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(so3.log(so3.exp(w)), Rotation.from_rotvec(w).as_rotvec(),
                               rtol=1e-13, atol=1e-15)


def test_exp_large_angles_wrap():
    n = np.array([0.0, 0.6, 0.8])
    np.testing.assert_allclose(so3.exp(2 * math.pi * n), I3, atol=1e-14)
    np.testing.assert_allclose(so3.log(so3.exp(2.5 * math.pi * n)), 0.5 * math.pi * n, atol=1e-13)
    np.testing.assert_allclose(so3.log(so3.exp(1.5 * math.pi * n)), -0.5 * math.pi * n, atol=1e-13)


def test_log_of_identity_and_tiny_exact():
    np.testing.assert_array_equal(so3.log(I3), np.zeros(3))
    w = np.array([1e-300, -2e-300, 3e-300])
    np.testing.assert_allclose(so3.log(so3.exp(w)), w, rtol=1e-15)


def test_log_tolerates_roundoff_off_so3():
    R = random_rotations(50, seed=5)
    rng = np.random.default_rng(6)
    Rp = R + 1e-12 * rng.normal(size=R.shape)
    np.testing.assert_allclose(so3.exp(so3.log(Rp)), R, atol=1e-11)



@pytest.mark.parametrize("M,values", [
    (np.ones((3, 3)), r"\|\|R\^T R - I\|\|_F = 8\.12, det R = 0"),   # returned zeros, silently
    (np.zeros((3, 3)), r"\|\|R\^T R - I\|\|_F = 1\.73, det R = 0"),
    (-np.eye(3), r"\|\|R\^T R - I\|\|_F = 0, det R = -1"),            # orthogonal, a reflection
    (2.0 * np.eye(3), r"\|\|R\^T R - I\|\|_F = 5\.2, det R = 8"),
])
def test_log_refuses_non_rotations(M, values):
    """A matrix that is not a rotation has no rotation vector: log names the rule and the values."""
    with pytest.raises(ValueError, match=r"log: R is not a rotation matrix \(the rule: \|\|R\^T R - I\|\|_F <= "
                       r"tol = 1e-06 and det R > 0\); got " + values + r"\. lgvi\.so3\.project\(R\)"):
        so3.log(M)


def test_log_names_the_first_bad_matrix_of_a_stack_and_honours_tol():
    R = random_rotations(30, seed=7).reshape(6, 5, 3, 3)
    R[2, 3] = np.ones((3, 3))
    R[4, 0] = -R[4, 0]
    with pytest.raises(ValueError, match=r"log: R\[2, 3\] is not a rotation.*\(2 of 30 matrices fail\)"):
        so3.log(R)
    # the documented bound, 1e-6 on ||R^T R - I||_F: inside it log answers, beyond it log refuses
    # (unless a looser tol is passed); NaN propagates as NaN
    Q = random_rotations(1, seed=8)[0]
    near, far = Q @ (np.eye(3) + np.diag([2e-7, 0.0, 0.0])), Q @ (np.eye(3) + np.diag([2e-6, 0.0, 0.0]))
    assert so3.orthogonality_error(near) < 1e-6 < so3.orthogonality_error(far)
    np.testing.assert_allclose(so3.exp(so3.log(near)), Q, atol=1e-6)
    with pytest.raises(ValueError, match=r"got \|\|R\^T R - I\|\|_F = 4e-06"):
        so3.log(far)
    np.testing.assert_allclose(so3.exp(so3.log(far, tol=1e-5)), Q, atol=1e-5)
    assert np.all(np.isnan(so3.log(np.full((2, 3, 3), np.nan))))
    with pytest.raises(ValueError, match="tol must be a finite non-negative number"):
        so3.log(Q, tol=-1.0)

# --------------------------------------------------------------------------------------------
# Series coefficients near their thresholds, checked in exact arithmetic
# --------------------------------------------------------------------------------------------


def _threshold_grid() -> np.ndarray:
    pts = [1e-9, 1e-6, 1e-4, 1e-3, 0.01, 0.1, 0.5, 1.0, 1.5, 2.5, 3.0, 3.5]
    for thr in (so3._EXP_TAYLOR, so3._JAC_SERIES):
        pts += [np.nextafter(thr, 0.0), thr, np.nextafter(thr, 4.0), 0.99 * thr, 1.01 * thr]
    return np.array(pts)


@pytest.mark.parametrize("t", _threshold_grid())
def test_series_coefficients_full_precision(t):
    exact = exact_coefficients(float(t))
    ta = np.array(t)
    a, b = so3._coeff_a_b(ta)
    got = {"a": a, "b": b, "c": so3._coeff_c(ta), "d": so3._coeff_d(ta)}
    for key, value in got.items():
        assert abs(float(value) - exact[key]) <= 4 * EPS * abs(exact[key]), key


# --------------------------------------------------------------------------------------------
# Jacobians
# --------------------------------------------------------------------------------------------

jac_vectors = st.one_of(
    small_vectors,
    st.tuples(axes(), log_small_angles).map(lambda p: p[0] * p[1]),
    st.tuples(axes(), st.floats(1.9, 2.1)).map(lambda p: p[0] * p[1]),  # across the series switch
)


@props
@given(jac_vectors)
def test_left_jacobian_finite_differences(w):
    Rw_T = so3.exp(w).T
    fd = central_jacobian(lambda x: so3.log(so3.exp(x) @ Rw_T), w)
    np.testing.assert_allclose(so3.left_jacobian(w), fd, rtol=0, atol=2e-8)


@props
@given(jac_vectors)
def test_right_jacobian_finite_differences(w):
    Rw_T = so3.exp(w).T
    fd = central_jacobian(lambda x: so3.log(Rw_T @ so3.exp(x)), w)
    np.testing.assert_allclose(so3.right_jacobian(w), fd, rtol=0, atol=2e-8)


@props
@given(jac_vectors)
def test_jacobian_symmetries_and_inverses(w):
    Jl, Jr = so3.left_jacobian(w), so3.right_jacobian(w)
    np.testing.assert_allclose(Jr, Jl.T, rtol=0, atol=1e-15)
    np.testing.assert_allclose(Jr, so3.left_jacobian(-w), rtol=0, atol=1e-15)
    np.testing.assert_allclose(so3.left_jacobian_inv(w) @ Jl, I3, rtol=0, atol=1e-13)
    np.testing.assert_allclose(Jl @ so3.left_jacobian_inv(w), I3, rtol=0, atol=1e-13)
    np.testing.assert_allclose(so3.right_jacobian_inv(w) @ Jr, I3, rtol=0, atol=1e-13)
    np.testing.assert_allclose(so3.right_jacobian_inv(w), so3.left_jacobian_inv(-w), atol=1e-15)
    # Jl(w) maps w to itself and hat(w) commutes: Jl = R Jr with R = exp(w)
    np.testing.assert_allclose(Jl @ w, w, rtol=0, atol=1e-13)
    np.testing.assert_allclose(Jl, so3.exp(w) @ Jr, rtol=0, atol=1e-13)


def test_jacobians_at_zero():
    for f in (so3.left_jacobian, so3.right_jacobian, so3.left_jacobian_inv,
              so3.right_jacobian_inv):
        np.testing.assert_array_equal(f(np.zeros(3)), I3)


def test_left_jacobian_inverse_up_to_two_pi():
    n = np.array([0.48, -0.6, 0.64])
    for t in (3.0, 4.0, 5.5):
        w = t * n
        np.testing.assert_allclose(so3.left_jacobian_inv(w) @ so3.left_jacobian(w), I3,
                                   atol=1e-12)


# --------------------------------------------------------------------------------------------
# Cayley map
# --------------------------------------------------------------------------------------------

cayley_vectors = st.one_of(
    small_vectors,
    st.tuples(axes(), st.floats(-12.0, 6.0).map(lambda e: 10.0**e)).map(lambda p: p[0] * p[1]),
)


@props
@given(cayley_vectors)
def test_cayley_round_trip_and_rotation(f):
    R = so3.cayley(f)
    assert so3.orthogonality_error(R) <= 1e-14
    assert abs(np.linalg.det(R) - 1.0) <= 1e-14
    s = np.linalg.norm(f)
    if s < 1e4:
        # R carries absolute errors ~eps and 1 + tr R = 4/(1 + s^2), so f is recovered to
        # ~eps (1 + s^2) relative: the conditioning of the Cayley map near pi, not a defect
        assert np.linalg.norm(so3.cayley_inv(R) - f) <= 8 * EPS * s * (1.0 + s * s)


@props
@given(cayley_vectors)
def test_cayley_matches_definition_and_angle(f):
    F = so3.hat(f)
    R = so3.cayley(f)
    s = np.linalg.norm(f)
    # the definition (I + F)(I - F)^-1, solved with cond(I - F) ~ s, as a less accurate oracle
    definition = np.linalg.solve((I3 - F).T, (I3 + F).T).T
    np.testing.assert_allclose(R, definition, rtol=0, atol=1e-14 * (1.0 + s))
    w = so3.log(R)
    assert abs(np.linalg.norm(w) - 2.0 * math.atan(s)) <= 1e-13
    if s > 0:
        np.testing.assert_allclose(w, 2.0 * math.atan(s) * f / s, rtol=0, atol=1e-12)


def test_cayley_inv_definition():
    R = random_rotations(100, seed=7)
    R = R[1.0 + np.trace(R, axis1=1, axis2=2) > 0.1]
    f = so3.cayley_inv(R)
    expected = np.linalg.solve(np.swapaxes(R + I3, -1, -2), np.swapaxes(R - I3, -1, -2))
    np.testing.assert_allclose(so3.hat(f), np.swapaxes(expected, -1, -2), atol=1e-10)


def test_cayley_huge_parameters_do_not_overflow():
    n = np.array([0.0, 0.6, 0.8])
    R = so3.cayley(1e200 * n)
    assert so3.is_rotation(R)
    np.testing.assert_allclose(R, 2 * np.outer(n, n) - I3, atol=1e-15)


def test_cayley_inv_rejects_rotation_by_pi():
    with pytest.raises(ValueError, match=r"rotation by \(nearly\) pi"):
        so3.cayley_inv(np.diag([1.0, -1.0, -1.0]))
    stack = np.stack([I3, so3.exp([0.0, 0.0, math.pi])])
    with pytest.raises(ValueError, match=r"R\[1\]"):
        so3.cayley_inv(stack)


# --------------------------------------------------------------------------------------------
# Quaternions
# --------------------------------------------------------------------------------------------


def _to_first(q: np.ndarray) -> np.ndarray:
    return q[..., [3, 0, 1, 2]]


def _align_sign(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return np.where(np.sum(q * ref, axis=-1, keepdims=True) < 0, -q, q)


def test_quaternions_against_scipy():
    rng = np.random.default_rng(8)
    q = rng.normal(size=(300, 4)) * rng.uniform(0.1, 10.0, size=(300, 1))  # not normalised
    expected = Rotation.from_quat(q).as_matrix()
    np.testing.assert_allclose(so3.quat_to_matrix(q), expected, atol=1e-14)
    np.testing.assert_allclose(so3.quat_to_matrix(_to_first(q), scalar_first=True), expected,
                               atol=1e-14)
    R = random_rotations(300, seed=9)
    q_ref = Rotation.from_matrix(R).as_quat(canonical=True)
    q = so3.matrix_to_quat(R)
    np.testing.assert_allclose(q, q_ref, atol=1e-14)
    np.testing.assert_allclose(so3.matrix_to_quat(R, scalar_first=True), _to_first(q_ref),
                               atol=1e-14)
    assert np.all(q[:, 3] >= 0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-15)


def test_quaternions_against_scipy_scalar_first_keyword():
    try:  # (SciPy < 1.14 has no scalar_first; its compiled Rotation has no inspectable signature)
        Rotation.from_quat([0.0, 0.0, 0.0, 1.0], scalar_first=True)
    except TypeError:
        pytest.skip("installed scipy has no scalar_first keyword")
    R = random_rotations(50, seed=10)
    q_first = Rotation.from_matrix(R).as_quat(canonical=True, scalar_first=True)
    np.testing.assert_allclose(so3.matrix_to_quat(R, scalar_first=True), q_first, atol=1e-14)
    np.testing.assert_allclose(so3.quat_to_matrix(q_first, scalar_first=True),
                               Rotation.from_quat(q_first, scalar_first=True).as_matrix(),
                               atol=1e-14)


def test_matrix_to_quat_canonical_at_pi_and_identity():
    rotvecs = math.pi * np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0],
                                  [0, -0.6, 0.8], [0.6, -0.8, 0]])
    R = so3.exp(rotvecs)
    q = so3.matrix_to_quat(R)
    np.testing.assert_allclose(q, Rotation.from_matrix(R).as_quat(canonical=True), atol=1e-15)
    np.testing.assert_allclose(so3.quat_to_matrix(q), R, atol=1e-15)
    np.testing.assert_array_equal(so3.matrix_to_quat(I3), [0.0, 0.0, 0.0, 1.0])


@props
@given(axes(), st.one_of(log_small_angles, generic_angles, near_pi_angles))
def test_quaternion_round_trip(n, t):
    R = so3.exp(t * n)
    q = so3.matrix_to_quat(R)
    np.testing.assert_allclose(so3.quat_to_matrix(q), R, rtol=0, atol=2e-15)
    np.testing.assert_allclose(q[:3], math.sin(t / 2) * n, rtol=0, atol=1e-15)
    np.testing.assert_allclose(q[3], math.cos(t / 2), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(so3.quat_to_matrix(-q), R, rtol=0, atol=2e-15)


def test_quat_multiply_against_scipy():
    rng = np.random.default_rng(11)
    p, q = rng.normal(size=(2, 200, 4))
    p /= np.linalg.norm(p, axis=-1, keepdims=True)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    pq = so3.quat_multiply(p, q)
    ref = (Rotation.from_quat(p) * Rotation.from_quat(q)).as_quat()
    np.testing.assert_allclose(_align_sign(pq, ref), ref, atol=1e-15)
    np.testing.assert_allclose(so3.quat_to_matrix(pq),
                               so3.quat_to_matrix(p) @ so3.quat_to_matrix(q), atol=1e-14)
    pq_first = so3.quat_multiply(_to_first(p), _to_first(q), scalar_first=True)
    np.testing.assert_allclose(pq_first, _to_first(pq), atol=0)
    # broadcasting of leading axes
    out = so3.quat_multiply(p[:5, None, :], q[None, :7, :])
    assert out.shape == (5, 7, 4)
    np.testing.assert_allclose(out[3, 4], so3.quat_multiply(p[3], q[4]), atol=0)
    # Hamilton convention: i j = k, and the product is not normalised
    np.testing.assert_array_equal(so3.quat_multiply([1.0, 0, 0, 0], [0, 1.0, 0, 0]), [0, 0, 1, 0])
    np.testing.assert_array_equal(so3.quat_multiply([0, 0, 0, 2.0], [0, 0, 0, 3.0]), [0, 0, 0, 6])


def test_quat_continuous():
    rng = np.random.default_rng(12)
    w = np.cumsum(0.2 * rng.normal(size=(200, 3)), axis=0)  # a wandering trajectory
    q = Rotation.from_rotvec(w).as_quat()
    flips = rng.choice([-1.0, 1.0], size=(200, 1))
    q_noisy = q * flips
    q_c = so3.quat_continuous(q_noisy)
    assert np.all(np.sum(q_c[1:] * q_c[:-1], axis=-1) >= 0)
    np.testing.assert_array_equal(q_c[0], q_noisy[0])
    assert np.all(np.all(q_c == q_noisy, axis=-1) | np.all(q_c == -q_noisy, axis=-1))
    np.testing.assert_allclose(so3.quat_to_matrix(q_c), so3.quat_to_matrix(q_noisy), atol=1e-15)
    assert np.sum(np.sum(q_noisy[1:] * q_noisy[:-1], axis=-1) < 0) > 10  # the test means it
    # another time axis, batch first
    batch = np.stack([q_noisy, -q_noisy[::-1]])  # (2, 200, 4)
    out = so3.quat_continuous(batch, axis=1)
    np.testing.assert_array_equal(out[0], q_c)
    np.testing.assert_array_equal(so3.quat_continuous(batch, axis=-1), out)
    assert np.all(np.sum(out[:, 1:] * out[:, :-1], axis=-1) >= 0)
    np.testing.assert_array_equal(
        np.moveaxis(so3.quat_continuous(np.moveaxis(batch, 1, 0)), 0, 1), out)


def test_quat_continuous_rejects_bad_axis_and_shape():
    q = np.zeros((5, 4))
    with pytest.raises(ValueError, match=r"axis must be an integer in \[-1, 0\]"):
        so3.quat_continuous(q, axis=1)
    with pytest.raises(ValueError, match=r"q must have shape \(n, \.\.\., 4\)"):
        so3.quat_continuous(np.array([0.0, 0.0, 0.0, 1.0]))


def test_quat_to_matrix_rejects_zero_quaternion():
    with pytest.raises(ValueError, match=r"q must have a finite, non-zero norm; q\[1\]"):
        so3.quat_to_matrix(np.array([[0.0, 0, 0, 1], [0, 0, 0, 0]]))
    # tiny but non-zero quaternions are fine (normalised without underflow)
    np.testing.assert_allclose(so3.quat_to_matrix([0.0, 0.0, 1e-200, 1e-200]),
                               so3.exp([0.0, 0.0, math.pi / 2]), atol=1e-15)


# --------------------------------------------------------------------------------------------
# Projection and checks
# --------------------------------------------------------------------------------------------


def test_project_returns_nearest_rotation():
    rng = np.random.default_rng(13)
    M = rng.normal(size=(100, 3, 3))
    P = so3.project(M)
    assert np.all(so3.is_rotation(P, tol=1e-13))
    Q = random_rotations(2000, seed=14)
    d_best = np.linalg.norm(M - P, axis=(-2, -1))
    d_any = np.linalg.norm(M[:, None] - Q[None, :], axis=(-2, -1)).min(axis=1)
    assert np.all(d_best <= d_any + 1e-12)


def test_project_fixes_perturbed_rotation():
    rng = np.random.default_rng(15)
    R = random_rotations(100, seed=16)
    E = 1e-6 * rng.normal(size=R.shape)
    P = so3.project(R + E)
    assert np.all(so3.is_rotation(P, tol=1e-13))
    err = np.linalg.norm(P - R, axis=(-2, -1))
    assert np.all(err <= np.linalg.norm(E, axis=(-2, -1)))


def test_project_reflection_and_idempotent():
    rng = np.random.default_rng(17)
    R = random_rotations(50, seed=18)
    reflected = R @ np.diag([1.0, 1.0, -1.0])
    P = so3.project(reflected)
    np.testing.assert_allclose(np.linalg.det(P), 1.0, atol=1e-14)
    np.testing.assert_allclose(so3.project(R), R, atol=1e-14)
    np.testing.assert_allclose(so3.project(np.diag([3.0, 2.0, -1.0])), I3, atol=1e-15)
    M = rng.normal(size=(50, 3, 3))
    np.testing.assert_allclose(so3.project(so3.project(M)), so3.project(M), atol=1e-14)


def test_orthogonality_error_and_is_rotation():
    R = random_rotations(10, seed=19)
    assert np.all(so3.orthogonality_error(R) < 1e-14)
    np.testing.assert_allclose(so3.orthogonality_error(2 * I3), math.sqrt(27.0))
    bad = np.stack([I3, -I3, 1.001 * I3, np.full((3, 3), np.nan), I3 + 1e-10])
    np.testing.assert_array_equal(so3.is_rotation(bad), [True, False, False, False, True])
    np.testing.assert_array_equal(so3.is_rotation(I3 + 1e-10, tol=1e-12), False)
    assert so3.is_rotation(R).shape == (10,)
    with pytest.raises(ValueError, match="tol must be a finite non-negative number"):
        so3.is_rotation(I3, tol=-1.0)


# --------------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------------

VEC_FUNCS = [so3.hat, so3.exp, so3.exp_minus_identity, so3.left_jacobian, so3.right_jacobian,
             so3.left_jacobian_inv, so3.right_jacobian_inv]
MAT_FUNCS = [(so3.vee, "W"), (so3.log, "R"), (so3.cayley_inv, "R"), (so3.matrix_to_quat, "R"),
             (so3.project, "M"), (so3.orthogonality_error, "R"), (so3.is_rotation, "R")]


@pytest.mark.parametrize("func", VEC_FUNCS)
def test_vector_shape_errors(func):
    with pytest.raises(ValueError, match=r"^w must have shape \(\.\.\., 3\), got \(4, 2\)$"):
        func(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"^w must have shape \(\.\.\., 3\), got \(\)$"):
        func(1.0)


def test_cayley_shape_error():
    with pytest.raises(ValueError, match=r"^f must have shape \(\.\.\., 3\), got \(4,\)$"):
        so3.cayley(np.zeros(4))


@pytest.mark.parametrize(("func", "name"), MAT_FUNCS)
def test_matrix_shape_errors(func, name):
    expected = rf"^{name} must have shape \(\.\.\., 3, 3\), got "
    with pytest.raises(ValueError, match=expected + r"\(3, 4\)$"):
        func(np.zeros((3, 4)))
    with pytest.raises(ValueError, match=expected + r"\(3,\)$"):
        func(np.zeros(3))


def test_quaternion_shape_errors():
    with pytest.raises(ValueError, match=r"^q must have shape \(\.\.\., 4\), got \(2, 3\)$"):
        so3.quat_to_matrix(np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"^p must have shape \(\.\.\., 4\), got \(3,\)$"):
        so3.quat_multiply(np.zeros(3), np.zeros(4))
    with pytest.raises(ValueError, match=r"^q must have shape \(\.\.\., 4\), got \(3,\)$"):
        so3.quat_multiply(np.zeros(4), np.zeros(3))
    with pytest.raises(ValueError, match=r"^q must have shape \(\.\.\., 4\), got \(5, 3\)$"):
        so3.quat_continuous(np.zeros((5, 3)))


def test_public_names():
    assert set(so3.__all__) == {
        "hat", "vee", "exp", "exp_minus_identity", "log", "left_jacobian", "right_jacobian",
        "left_jacobian_inv", "right_jacobian_inv", "cayley", "cayley_inv", "quat_to_matrix",
        "matrix_to_quat", "quat_multiply", "quat_continuous", "project", "orthogonality_error",
        "is_rotation", "mrp_from_matrix", "matrix_from_mrp",
    }
    for name in so3.__all__:
        assert getattr(so3, name).__doc__
