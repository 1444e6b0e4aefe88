"""The compiled kernels against :mod:`lgvi.reference`, the paper's equations in plain NumPy.

The reference solves with the paper's Newton-Raphson (``Df`` as written, additive update) to an
absolute ``|f| <= tol``; here ``tol = 1e-15`` so that its solutions are as accurate as the kernels'
(with the default 1e-14 the reference itself is off by ~1e-14 per step). Two correct
implementations then differ only by round-off amplified along the run: measured <= 5e-13 after 200
steps of h = 0.05, bound 1e-12. The reference is slow (~1 s per 200 steps), so its runs are cached
per module.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import lgvi
from lgvi import so3
from lgvi.verification import reference

LGVI_SETTINGS = settings.get_profile("lgvi-active")  # registered in conftest.py
METHODS = ("paper", "newton", "cayley")
OMEGA0 = np.array([0.3, 1.0, 0.2])
H = 0.05
N = 200
REF_TOL = 1e-15

_REF: dict = {}


@pytest.fixture(scope="module", params=[(b, f) for b in ("diag", "full") for f in (False, True)],
                ids=lambda p: f"{p[0]}-{'torque' if p[1] else 'free'}")
def reference_run(request, diag_body, full_body, R0):
    key = request.param
    if key not in _REF:
        body = diag_body if key[0] == "diag" else full_body
        U = 0.3 * np.random.default_rng(3).standard_normal((N, 3)) if key[1] else None
        Pi0 = body.J @ OMEGA0
        R, Pi = reference.simulate(body.J, R0, Pi0, H, N, U=U, tol=REF_TOL)
        _REF[key] = (body, Pi0, U, R, Pi)
    return _REF[key]


@pytest.mark.parametrize("method", METHODS)
def test_simulate_matches_reference(method, reference_run, R0):
    body, Pi0, U, R_ref, Pi_ref = reference_run
    traj = lgvi.simulate(body, R0, Pi0, h=H, steps=N, torque=U, method=method)
    assert traj.R.shape == R_ref.shape and traj.Pi.shape == Pi_ref.shape
    assert np.max(np.abs(traj.R - R_ref)) <= 1e-12
    assert np.max(np.abs(traj.Pi - Pi_ref)) <= 1e-12 * np.linalg.norm(Pi0)
    # not a vacuous comparison: the run moves far from the initial state
    assert np.max(np.abs(R_ref[-1] - R0)) > 0.1


@pytest.mark.parametrize("method", METHODS)
def test_step_matches_reference_step(method, full_body, R0):
    Pi = full_body.J @ OMEGA0
    u = np.array([0.2, -0.1, 0.3])
    s = lgvi.step(full_body, R0, Pi, h=H, u=u, method=method)
    w0 = np.linalg.solve(full_body.J, H * Pi)
    R_ref, Pi_ref, w = reference.lgvi_step(R0, Pi, u, H, full_body.Jd, w0, tol=REF_TOL)
    assert np.max(np.abs(s.R - R_ref)) <= 1e-14
    assert np.max(np.abs(s.Pi - Pi_ref)) <= 1e-14 * np.linalg.norm(Pi)
    assert np.max(np.abs(s.F - so3.exp(w))) <= 1e-14


# --------------------------------------------------------------------------------------------
# solve_implicit against reference.newton_raphson
# --------------------------------------------------------------------------------------------
unit = st.floats(-1.0, 1.0, allow_nan=False)


def _rotated(moments, seed):
    Q = Rotation.random(random_state=seed).as_matrix()
    J = Q @ np.diag(moments) @ Q.T
    return 0.5 * (J + J.T)


# the conftest bodies as plain data (fixtures cannot be used inside @given)
INERTIAS = {"diag": np.diag([1.0, 2.0, 3.0]), "full": _rotated([1.0, 1.7, 2.4], 7),
            "flat": _rotated([1.0, 2.0, 2.999], 11)}


@settings(LGVI_SETTINGS)
@given(v=st.tuples(unit, unit, unit), size=st.floats(0.01, 0.5), which=st.sampled_from(["diag", "full", "flat"]),
       method=st.sampled_from(METHODS))
def test_solve_implicit_matches_reference(v, size, which, method):
    J = INERTIAS[which]
    body = lgvi.RigidBody(J)
    v = np.array(v)
    if np.linalg.norm(v) < 0.1:
        v = np.array([0.3, -0.5, 0.8])
    hPi = body.J @ (size * v / np.linalg.norm(v))
    sol = lgvi.solve_implicit(body.Jd, hPi, method=method)
    w, _ = reference.newton_raphson(body.Jd, hPi, body.J_inv @ hPi, tol=REF_TOL)
    # both residuals ~1e-15 with |Df^-1| <= 1/min moment: the roots agree to ~1e-15
    assert np.max(np.abs(sol.F - so3.exp(w))) <= 1e-13
    assert np.linalg.norm(reference.f(w, body.Jd, hPi)) <= REF_TOL


def test_reference_newton_raphson_honours_alpha(full_body):
    """The reference's damped iteration (alpha = 0.5) reaches the same root as the kernel's."""
    hPi = full_body.J @ np.array([0.2, -0.1, 0.3])
    w, n_full = reference.newton_raphson(full_body.Jd, hPi, np.zeros(3), tol=REF_TOL)
    w_half, n_half = reference.newton_raphson(full_body.Jd, hPi, np.zeros(3), alpha=0.5, tol=REF_TOL)
    assert n_half > n_full
    sol = lgvi.solve_implicit(full_body.Jd, hPi, method="paper", alpha=0.5, max_iter=500)
    assert np.max(np.abs(sol.F - so3.exp(w_half))) <= 1e-13
    assert np.max(np.abs(so3.exp(w) - so3.exp(w_half))) <= 1e-13


# --------------------------------------------------------------------------------------------
# the paper's Df: the derivative for a right update, not d f / d w
# --------------------------------------------------------------------------------------------
W_POINTS = [np.array([0.4, -0.7, 0.5]), np.array([1e-3, 2e-3, -1e-3]), np.array([0.0, 0.0, 1.2])]


def central_difference(fun, n_dirs=3, eps=1e-5) -> np.ndarray:
    """Columns (fun(+eps e_i) - fun(-eps e_i)) / (2 eps): truncation ~ eps^2 |f'''| ~ 1e-10."""
    cols = []
    for i in range(n_dirs):
        e = np.zeros(3)
        e[i] = eps
        cols.append((fun(e) - fun(-e)) / (2 * eps))
    return np.column_stack(cols)


@pytest.mark.parametrize("w", W_POINTS, ids=["generic", "small", "axis"])
def test_paper_Df_is_right_update_derivative(w, full_body):
    """Column i of Df = d/de f(log(exp(w) exp(e E_i))) at e = 0 (finite differences, 1e-8)."""
    Jd = full_body.Jd
    hPi = np.array([0.1, 0.2, -0.3])
    D = reference.Df(w, Jd)
    fd = central_difference(lambda d: reference.f(so3.log(so3.exp(w) @ so3.exp(d)), Jd, hPi))
    assert np.max(np.abs(fd - D)) <= 1e-8


@pytest.mark.parametrize("w", W_POINTS, ids=["generic", "small", "axis"])
def test_paper_Df_is_not_df_dw(w, full_body):
    """The derivative of f(w) itself is Df(w) Jr(w) (exp(w + d) = exp(w) exp(Jr(w) d)): it equals
    the paper's Df only at w = 0, off by O(|w|) |Jd| otherwise. This is why the paper's
    additive update converges linearly (rate ~ |w|)."""
    Jd = full_body.Jd
    hPi = np.array([0.1, 0.2, -0.3])
    D = reference.Df(w, Jd)
    fd = central_difference(lambda d: reference.f(w + d, Jd, hPi))
    assert np.max(np.abs(fd - D @ so3.right_jacobian(w))) <= 1e-8
    gap = np.max(np.abs(fd - D))
    assert gap > 0.05 * np.linalg.norm(w) * np.linalg.norm(Jd, 2)  # measured ~0.3 |w| |Jd|


def test_reference_f_is_the_equation(full_body):
    """f(w) = 0 exactly when exp(w) solves hat(hPi) = F Jd - Jd F^T (and f is skew-derived)."""
    hPi = full_body.J @ np.array([0.2, -0.1, 0.3])
    sol = lgvi.solve_implicit(full_body.Jd, hPi)
    w = so3.log(sol.F)
    assert np.linalg.norm(reference.f(w, full_body.Jd, hPi)) <= 1e-14
    assert np.linalg.norm(reference.f(np.zeros(3), full_body.Jd, hPi) + hPi) == 0.0


def test_reference_helpers(full_body):
    J = full_body.J
    Jd = reference.jd_from_inertia(J)
    assert np.allclose(Jd, full_body.Jd, rtol=0, atol=1e-15)
    assert np.allclose(reference.inertia_from_jd(Jd), J, rtol=0, atol=1e-15)
    Omega = np.array([0.3, -1.0, 0.7])
    # eq. KE: 1/2 tr(hat(Omega) Jd hat(Omega)^T) = 1/2 Omega . J Omega
    assert reference.kinetic_energy(Omega, Jd) == pytest.approx(0.5 * Omega @ J @ Omega, rel=1e-14)
    # the discrete Lagrangian vanishes at F = I and is h-scaled
    assert reference.discrete_lagrangian(np.eye(3), Jd, 0.1) == 0.0
    F = so3.exp([0.01, 0.02, -0.01])
    assert reference.discrete_lagrangian(F, Jd, 0.1) == pytest.approx(
        2.0 * reference.discrete_lagrangian(F, Jd, 0.2), rel=1e-14)


def test_discrete_lagrangian_generates_the_momentum():
    """Left-trivialised derivative of L_d(F) = 1/h tr((I - F) Jd) along exp(eps hat(e_i)) F is
    vee(F Jd - Jd F^T)/h = Pi_k at the solution F_k; the paper's printed 1/(2h) would give Pi_k / 2."""
    from lgvi import so3
    from lgvi.verification import reference

    J = np.diag([1.0, 2.0, 3.0])
    Jd = reference.jd_from_inertia(J)
    h = 0.1
    Pi = np.array([0.3, 2.0, 0.6])
    F = lgvi.solve_implicit(Jd, h * Pi).F
    eps = 1e-6
    grad = [(reference.discrete_lagrangian(so3.exp(eps * e) @ F, Jd, h)
             - reference.discrete_lagrangian(so3.exp(-eps * e) @ F, Jd, h)) / (2 * eps) for e in np.eye(3)]
    # central difference error ~ eps^2 |L_d'''| ~ 1e-12 relative, round-off ~ 1e-16 |L_d| / eps ~ 1e-10
    np.testing.assert_allclose(grad, Pi, rtol=0, atol=1e-8)
