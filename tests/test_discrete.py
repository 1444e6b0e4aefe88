"""Discrete mechanics on vector spaces (lgvi.discrete, the paper's section 2).

By purpose: the Kepler problem of the paper's introduction (angular momentum to round-off, energy
bounded, RK4 drifting), agreement of the compiled, closed-form and Newton paths, second order
against a tight DOP853 reference, exact quadratic invariants of the harmonic oscillator, the
discrete Euler-Lagrange equations and Legendre transforms, errors and validation.
"""

from __future__ import annotations

import dataclasses
import doctest

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lgvi
from lgvi import discrete
from lgvi._kernels.discrete_kernels import kepler_verlet_run
from lgvi.discrete import (DiscreteLagrangian, DiscreteTrajectory, KeplerPotential, MechanicalSystem, kepler,
                           kepler_angular_momentum, kepler_energy, kepler_initial_state, mechanical_lagrangian,
                           numerical_jacobian, simulate_discrete)
from lgvi.errors import ConvergenceError

ECC = 0.5
H_LONG = 0.05          # step of the long runs: ~800 orbits in 1e5 steps
STEPS_LONG = 100_000


def drift_stats(E: np.ndarray, L: np.ndarray) -> dict[str, float]:
    dE = E - E[0]
    m = len(E) // 10
    return {
        "L_rel": float(np.max(np.abs(L - L[0])) / abs(L[0])),
        "E_max": float(np.max(np.abs(dE))),
        "E_first": float(np.max(np.abs(dE[:m]))),
        "E_last": float(np.max(np.abs(dE[-m:]))),
        # secular drift: change of the mean energy error between the first and last tenth
        "E_drift": float(abs(dE[-m:].mean() - dE[:m].mean())),
    }


@pytest.fixture(scope="module")
def kepler_runs():
    q0, p0 = kepler_initial_state(ECC)
    Ld = kepler().discrete_lagrangian(H_LONG)
    sv = simulate_discrete(Ld, q0, p0, steps=STEPS_LONG)
    Q, P = discrete.kepler_rk4(q0, p0, H_LONG, STEPS_LONG)
    return {
        "traj": sv,
        "sv": drift_stats(kepler_energy(sv.q, sv.p), kepler_angular_momentum(sv.q, sv.p)),
        "rk4": drift_stats(kepler_energy(Q, P), kepler_angular_momentum(Q, P)),
    }


# ---------------------------------------------------------------------------------------------
# Kepler: the paper's introduction
# ---------------------------------------------------------------------------------------------
def test_kepler_initial_state_and_invariants() -> None:
    q0, p0 = kepler_initial_state(ECC)
    np.testing.assert_allclose(q0, [0.5, 0.0])
    np.testing.assert_allclose(p0, [0.0, np.sqrt(3.0)])
    assert kepler_energy(q0, p0) == pytest.approx(-0.5, rel=1e-15)
    assert kepler_angular_momentum(q0, p0) == pytest.approx(np.sqrt(1 - ECC**2), rel=1e-15)
    system = kepler(mu=2.0)
    assert isinstance(system, MechanicalSystem) and system.n == 2
    np.testing.assert_array_equal(system.M, np.eye(2))
    q = np.array([[0.3, -1.2], [2.0, 0.1]])
    p = np.array([[0.5, 0.2], [-0.1, 0.7]])
    np.testing.assert_allclose(system.energy(q, p), kepler_energy(q, p, mu=2.0), rtol=1e-15)
    # 3D: angular momentum is a vector; the planar value is its z component
    q3 = np.array([0.3, -1.2, 0.0])
    p3 = np.array([0.5, 0.2, 0.0])
    np.testing.assert_allclose(kepler_angular_momentum(q3, p3), [0, 0, kepler_angular_momentum(q[0], p[0])])
    assert kepler(dim=3).n == 3


@pytest.mark.slow
@pytest.mark.parametrize("h", [0.01, H_LONG])
def test_kepler_stormer_verlet_long_run(h: float) -> None:
    """1e5 compiled steps: angular momentum to round-off, energy error bounded without drift."""
    q0, p0 = kepler_initial_state(ECC)
    traj = simulate_discrete(kepler().discrete_lagrangian(h), q0, p0, steps=STEPS_LONG)
    assert traj.meta["solver"] == "compiled"
    stats = drift_stats(kepler_energy(traj.q, traj.p), kepler_angular_momentum(traj.q, traj.p))
    assert stats["L_rel"] < 1e-12
    # bounded energy error of size O(h^2) ...
    assert stats["E_max"] < 2.0 * h**2
    # ... with no secular drift: the first and the last tenth of the run look alike
    assert stats["E_last"] / stats["E_first"] < 2.0
    assert stats["E_first"] / stats["E_last"] < 2.0
    assert np.all(traj.residual < 1e-13)
    assert np.all(traj.iterations == 0)


@pytest.mark.slow
def test_rk4_drifts_where_the_variational_integrator_does_not(kepler_runs) -> None:
    sv, rk = kepler_runs["sv"], kepler_runs["rk4"]
    assert sv["L_rel"] < 1e-12
    assert rk["L_rel"] > 1e-5                      # RK4 loses angular momentum ...
    assert rk["L_rel"] > 1e6 * sv["L_rel"]
    assert rk["E_last"] / rk["E_first"] > 5.0      # ... and its energy error grows linearly
    assert rk["E_drift"] > 100.0 * sv["E_drift"]   # secular drift >> the variational one
    assert sv["E_last"] / sv["E_first"] < 2.0


def test_compiled_path_matches_generic_paths() -> None:
    q0, p0 = kepler_initial_state(ECC)
    h = H_LONG
    Ld = kepler().discrete_lagrangian(h)
    compiled = simulate_discrete(Ld, q0, p0, steps=2000, solver="compiled")
    explicit = simulate_discrete(Ld, q0, p0, steps=2000, solver="explicit")
    # the closed form and the kernel do the same arithmetic
    np.testing.assert_allclose(explicit.q, compiled.q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(explicit.p, compiled.p, rtol=0, atol=1e-14)
    np.testing.assert_allclose(explicit.residual, compiled.residual, rtol=0, atol=1e-15)

    # the generic path: Newton on user-supplied D1, D2 (written out here by hand), p1 = D2
    mu = 1.0

    def grad(q):
        return mu * q / np.linalg.norm(q) ** 3

    user = DiscreteLagrangian(
        lambda q0, q1: -(q1 - q0) / h - h / 2 * grad(q0),
        lambda q0, q1: (q1 - q0) / h - h / 2 * grad(q1),
        D1_q1=lambda q0, q1: -np.eye(2) / h, h=h)
    generic = simulate_discrete(user, q0, p0, steps=500)
    assert generic.meta["solver"] == "newton"
    scale = np.max(np.abs(compiled.p[:501]))
    assert np.max(np.abs(generic.q - compiled.q[:501])) < 1e-12 * scale
    assert np.max(np.abs(generic.p - compiled.p[:501])) < 1e-12 * scale
    assert np.all(generic.iterations == 1)         # linear in q1: one exact Newton step


def test_compiled_kernel_interpreted_equals_compiled() -> None:
    q0, p0 = kepler_initial_state(0.3)
    M = np.diag([1.0, 2.0])
    Minv = np.linalg.inv(M)
    out = []
    for fn in (kepler_verlet_run, getattr(kepler_verlet_run, "py_func", kepler_verlet_run)):
        q, p = q0.copy(), p0.copy()
        Q, P, res = np.empty((201, 2)), np.empty((201, 2)), np.empty(200)
        assert fn(q, p, M, Minv, 0.02, 1.5, 200, Q, P, res) == 200
        out.append((Q, P, res))
    for a, b in zip(*out):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-14)


def test_compiled_kernel_reports_a_collision() -> None:
    q = np.zeros(2)
    p = np.ones(2)
    Q, P, res = np.empty((11, 2)), np.empty((11, 2)), np.empty(10)
    assert kepler_verlet_run(q, p, np.eye(2), np.eye(2), 0.1, 1.0, 10, Q, P, res) == 0
    with pytest.raises(ConvergenceError, match=r"step 0 .*singularity"):
        simulate_discrete(kepler().discrete_lagrangian(0.1), [0.0, 0.0], [1.0, 0.0], steps=10)


def test_midpoint_newton_conserves_angular_momentum() -> None:
    q0, p0 = kepler_initial_state(ECC)
    traj = simulate_discrete(kepler().discrete_lagrangian(H_LONG, "midpoint"), q0, p0, steps=1500)
    assert traj.meta["solver"] == "newton"
    L = kepler_angular_momentum(traj.q, traj.p)
    assert np.max(np.abs(L - L[0])) < 1e-12 * abs(L[0])
    E = kepler_energy(traj.q, traj.p)
    assert np.max(np.abs(E - E[0])) < 2.0 * H_LONG**2
    assert traj.iterations.max() <= 4              # quadratic convergence from the Verlet guess


# ---------------------------------------------------------------------------------------------
# order of accuracy
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("quadrature", ["trapezoidal", "midpoint"])
def test_second_order_against_dop853(quadrature: str) -> None:
    q0, p0 = kepler_initial_state(ECC)
    T = 3.0
    ref = solve_ivp(lambda t, y: np.r_[y[2:], -y[:2] / np.linalg.norm(y[:2]) ** 3], (0.0, T), np.r_[q0, p0],
                    method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    hs = T / np.array([40, 80, 160, 320])
    errors = []
    for h in hs:
        steps = int(round(T / h))
        traj = simulate_discrete(kepler().discrete_lagrangian(h, quadrature), q0, p0, steps=steps)
        assert traj.t[-1] == pytest.approx(T, rel=1e-14)
        errors.append(np.linalg.norm(np.r_[traj.q[-1], traj.p[-1]] - ref))
    errors = np.array(errors)
    assert errors.min() > 1e-8                     # far above the reference's error and round-off
    slope = np.polyfit(np.log(hs), np.log(errors), 1)[0]
    assert 1.9 < slope < 2.1, (slope, errors)


# ---------------------------------------------------------------------------------------------
# harmonic oscillator: exact quadratic invariants
# ---------------------------------------------------------------------------------------------
def test_harmonic_oscillator_exact_invariants() -> None:
    M = np.diag([2.0, 0.5])
    K = np.array([[3.0, 1.0], [1.0, 2.0]])
    Minv = np.linalg.inv(M)
    h = 0.1

    def V(q):
        return 0.5 * q @ K @ q

    def energy(q, p):
        return 0.5 * np.einsum("ki,ij,kj->k", p, Minv, p) + 0.5 * np.einsum("ki,ij,kj->k", q, K, q)

    # midpoint = implicit midpoint rule: conserves the quadratic energy itself
    mid = simulate_discrete(mechanical_lagrangian(M, V, lambda q: K @ q, lambda q: K, h=h, quadrature="midpoint"),
                            [1.0, -0.5], [0.3, 0.7], steps=5000)
    E = energy(mid.q, mid.p)
    assert np.max(np.abs(E - E[0])) < 1e-13 * E[0]
    # Stormer-Verlet: conserves the modified energy H - h^2/8 (Kq)^T M^-1 (Kq) exactly
    sv = simulate_discrete(mechanical_lagrangian(M, V, lambda q: K @ q, h=h), [1.0, -0.5], [0.3, 0.7], steps=5000)
    assert sv.meta["solver"] == "explicit"
    Kq = sv.q @ K
    E_mod = energy(sv.q, sv.p) - h**2 / 8 * np.einsum("ki,ij,kj->k", Kq, Minv, Kq)
    assert np.max(np.abs(E_mod - E_mod[0])) < 1e-13 * E_mod[0]
    E_sv = energy(sv.q, sv.p)
    assert np.ptp(E_sv) > 1e-4 * E_sv[0]          # the true energy itself is not exactly conserved
    # and the closed form agrees with Newton on the same discrete Lagrangian
    Ld = mechanical_lagrangian(M, V, lambda q: K @ q, h=h)
    newton = simulate_discrete(Ld, [1.0, -0.5], [0.3, 0.7], steps=300, solver="newton")
    np.testing.assert_allclose(newton.q, sv.q[:301], rtol=0, atol=1e-12)
    np.testing.assert_allclose(newton.p, sv.p[:301], rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# discrete Euler-Lagrange equations, Legendre transforms, numerical Jacobian
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("quadrature", ["trapezoidal", "midpoint"])
def test_discrete_euler_lagrange_and_legendre_transforms(quadrature: str) -> None:
    q0, p0 = kepler_initial_state(ECC)
    Ld = kepler().discrete_lagrangian(0.05, quadrature)
    traj = simulate_discrete(Ld, q0, p0, steps=200)
    assert np.max(np.abs(Ld.el_residual(traj.q))) < 1e-12
    for k in (0, 57, 199):
        np.testing.assert_allclose(Ld.legendre_minus(traj.q[k], traj.q[k + 1]), traj.p[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(Ld.legendre_plus(traj.q[k], traj.q[k + 1]), traj.p[k + 1], rtol=0, atol=1e-12)
    # the discrete Euler-Lagrange equations are the stationarity of the discrete action
    k, eps = 100, 1e-6
    grad = []
    for i in range(2):
        qp, qm = traj.q.copy(), traj.q.copy()
        qp[k, i] += eps
        qm[k, i] -= eps
        grad.append((Ld.action(qp) - Ld.action(qm)) / (2 * eps))
    np.testing.assert_allclose(grad, Ld.el_residual(traj.q)[k - 1], atol=1e-7)
    np.testing.assert_allclose(grad, 0.0, atol=1e-7)


def test_numerical_jacobian_agrees_with_exact() -> None:
    pot = KeplerPotential(1.3)
    rng = np.random.default_rng(7)
    # |q| of order 1 and above: about eps^(2/3) relative (documented); below 1 the step stays
    # cbrt(eps) absolute, so a function varying on length scale l < 1 loses (cbrt(eps)/l)^2
    for scale, bound in [(1.0, 1e-9), (30.0, 1e-9), (0.1, 1e-7)]:
        for _ in range(10):
            q = rng.normal(size=3)
            q *= scale * rng.uniform(1.0, 2.0) / np.linalg.norm(q)
            exact = pot.hessian(q)
            approx = numerical_jacobian(pot.gradient, q)
            assert np.max(np.abs(approx - exact)) < bound * np.max(np.abs(exact)), (scale, q)


def test_user_lagrangian_with_and_without_jacobian_agree() -> None:
    """Generic Newton path: user D1, D2 (midpoint rule for Kepler) with exact vs numerical D1_q1."""
    h = 0.05
    pot = KeplerPotential(1.0)

    def D1(q0, q1):
        return -(q1 - q0) / h - h / 2 * pot.gradient((q0 + q1) / 2)

    def D2(q0, q1):
        return (q1 - q0) / h - h / 2 * pot.gradient((q0 + q1) / 2)

    def D1_q1(q0, q1):
        return -np.eye(2) / h - h / 4 * pot.hessian((q0 + q1) / 2)

    q0, p0 = kepler_initial_state(ECC)
    exact = simulate_discrete(DiscreteLagrangian(D1, D2, D1_q1=D1_q1, h=h), q0, p0, steps=300, tol=1e-14)
    fd = simulate_discrete(DiscreteLagrangian(D1, D2, h=h), q0, p0, steps=300, tol=1e-14)
    np.testing.assert_allclose(fd.q, exact.q, rtol=0, atol=1e-11)
    np.testing.assert_allclose(fd.p, exact.p, rtol=0, atol=1e-11)
    assert fd.iterations.max() <= exact.iterations.max() + 1
    # and both agree with the built-in midpoint Lagrangian
    builtin = simulate_discrete(kepler().discrete_lagrangian(h, "midpoint"), q0, p0, steps=300, tol=1e-14)
    np.testing.assert_allclose(builtin.q, exact.q, rtol=0, atol=1e-11)


def test_reversibility() -> None:
    """Both quadratures are symmetric: stepping back with -h from (q_N, p_N) retraces the path."""
    q0, p0 = kepler_initial_state(ECC)
    for quadrature in ("trapezoidal", "midpoint"):
        fwd = simulate_discrete(kepler().discrete_lagrangian(0.05, quadrature), q0, p0, steps=200)
        back = simulate_discrete(kepler().discrete_lagrangian(-0.05, quadrature), fwd.q[-1], fwd.p[-1], steps=200,
                                 t0=fwd.t[-1])
        np.testing.assert_allclose(back.q[::-1], fwd.q, rtol=0, atol=1e-11)
        np.testing.assert_allclose(back.p[::-1], fwd.p, rtol=0, atol=1e-11)
        np.testing.assert_allclose(back.t[-1], 0.0, atol=1e-12)


def test_step_method() -> None:
    q0, p0 = kepler_initial_state(ECC)
    Ld = kepler().discrete_lagrangian(0.05, "midpoint")
    q1, p1 = Ld.step(q0, p0)
    traj = simulate_discrete(Ld, q0, p0, steps=1)
    np.testing.assert_array_equal(q1, traj.q[1])
    np.testing.assert_array_equal(p1, traj.p[1])


# ---------------------------------------------------------------------------------------------
# errors and validation
# ---------------------------------------------------------------------------------------------
def test_nonconvergence_raises_convergence_error() -> None:
    # p0 = -D1 = -q1^2 has no real solution for p0 = 1: Newton wanders and must give up
    Ld = DiscreteLagrangian(lambda q0, q1: q1**2, lambda q0, q1: q1, D1_q1=lambda q0, q1: np.diag(2 * q1), h=0.1)
    with pytest.raises(ConvergenceError) as info:
        simulate_discrete(Ld, [0.3], [1.0], steps=5, max_iter=20)
    err = info.value
    assert isinstance(err, lgvi.ConvergenceError)
    assert err.step == 0 and err.iterations == 20 and err.residual > 0.5
    message = str(err)
    assert "step 0" in message and "residual" in message and "max_iter" in message and "smaller step" in message
    assert isinstance(err.trajectory, DiscreteTrajectory) and len(err.trajectory) == 1

    # a later step: the midpoint rule needs 2-3 Newton iterations, not 1
    q0, p0 = kepler_initial_state(ECC)
    with pytest.raises(ConvergenceError, match="step 0") as info:
        simulate_discrete(kepler().discrete_lagrangian(0.05, "midpoint"), q0, p0, steps=10, max_iter=1)
    assert info.value.iterations == 1

    # a singular Jacobian
    Ld = DiscreteLagrangian(lambda q0, q1: q1 - q0, lambda q0, q1: q1, D1_q1=lambda q0, q1: np.zeros((1, 1)), h=1.0)
    with pytest.raises(ConvergenceError, match="singular"):
        simulate_discrete(Ld, [0.0], [1.0], steps=1)

    # D1 producing NaN is reported, not propagated
    Ld = DiscreteLagrangian(lambda q0, q1: np.full(1, np.nan), lambda q0, q1: q1, h=1.0)
    with pytest.raises(ConvergenceError, match="not finite"):
        simulate_discrete(Ld, [0.0], [1.0], steps=1)


def _hook(D1=None) -> DiscreteLagrangian:
    return DiscreteLagrangian(D1 or (lambda q0, q1: q0 - q1), lambda q0, q1: q1 - q0, h=0.1)


@pytest.mark.parametrize("call, match", [
    (lambda: simulate_discrete(_hook(), [[0.0, 1.0]], [0.0, 1.0], steps=1), "q0"),
    (lambda: simulate_discrete(_hook(), [0.0, 1.0], [0.0, 1.0, 2.0], steps=1), "p0"),
    (lambda: simulate_discrete(_hook(), [0.0, np.nan], [0.0, 1.0], steps=1), "q0"),
    (lambda: simulate_discrete(_hook(), [0.0], [0.0], steps=-1), "steps"),
    (lambda: simulate_discrete(_hook(), [0.0], [0.0], steps=1, h=0.2), "h"),
    (lambda: simulate_discrete(_hook(), [0.0], [0.0], steps=1, tol=0.0), "tol"),
    (lambda: simulate_discrete(_hook(), [0.0], [0.0], steps=1, max_iter=0), "max_iter"),
    (lambda: simulate_discrete(_hook(), [0.0], [0.0], steps=1, solver="rk4"), "solver"),
    (lambda: simulate_discrete(_hook(), [0.0], [0.0], steps=1, solver="compiled"), "compiled"),
    (lambda: simulate_discrete(_hook(), [0.0], [0.0], steps=1, solver="explicit"), "explicit"),
    (lambda: simulate_discrete(DiscreteLagrangian(lambda a, b: a, lambda a, b: b), [0.0], [0.0], steps=1), "h"),
    (lambda: simulate_discrete(_hook(lambda q0, q1: np.zeros(3)), [0.0], [0.0], steps=1), "D1"),
    (lambda: DiscreteLagrangian(lambda a, b: a, lambda a, b: b, h=0.0), "h"),
    (lambda: mechanical_lagrangian(np.eye(2), lambda q: 0.0, lambda q: q, h=0.1, quadrature="simpson"), "quadrature"),
    (lambda: mechanical_lagrangian(np.eye(2), lambda q: 0.0, lambda q: q, h=0.0), "h"),
    (lambda: mechanical_lagrangian(np.eye(2), lambda q: 0.0, h=0.1), "gradV"),
    (lambda: mechanical_lagrangian([[1.0, 2.0], [2.0, 1.0]], lambda q: 0.0, lambda q: q, h=0.1), "M"),
    (lambda: mechanical_lagrangian([[1.0, 0.5], [0.0, 1.0]], lambda q: 0.0, lambda q: q, h=0.1), "M"),
    (lambda: mechanical_lagrangian([1.0, -1.0], lambda q: 0.0, lambda q: q, h=0.1), "M"),
    (lambda: mechanical_lagrangian(np.ones((2, 3)), lambda q: 0.0, lambda q: q, h=0.1), "M"),
    (lambda: simulate_discrete(kepler().discrete_lagrangian(0.1), [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], steps=1), "q0"),
    (lambda: kepler(mu=-1.0), "mu"),
    (lambda: kepler(dim=4), "dim"),
    (lambda: kepler_initial_state(1.0), "eccentricity"),
    (lambda: kepler_angular_momentum(np.ones(4), np.ones(4)), "q"),
])
def test_bad_inputs_raise_value_errors(call, match) -> None:
    with pytest.raises(ValueError, match=match):
        call()


def test_bad_types_raise_type_errors() -> None:
    with pytest.raises(TypeError, match="D1"):
        DiscreteLagrangian(1.0, lambda a, b: b)
    with pytest.raises(TypeError, match="D1_q1"):
        DiscreteLagrangian(lambda a, b: a, lambda a, b: b, D1_q1=np.eye(2))
    with pytest.raises(TypeError, match="Ld"):
        simulate_discrete("not a Lagrangian", [0.0], [0.0], steps=1)
    with pytest.raises(TypeError, match="steps"):
        simulate_discrete(_hook(), [0.0], [0.0], steps=1.5)
    with pytest.raises(ValueError, match="action"):
        _hook().action(np.zeros((3, 1)))


def test_trajectory_is_immutable_with_time_first_arrays() -> None:
    q0, p0 = kepler_initial_state(ECC)
    traj = simulate_discrete(kepler().discrete_lagrangian(0.05), q0, p0, steps=7, t0=1.0)
    assert traj.t.shape == (8,) and traj.q.shape == (8, 2) and traj.p.shape == (8, 2)
    assert traj.iterations.shape == (7,) and traj.residual.shape == (7,)
    assert traj.iterations.dtype.kind == "i"
    np.testing.assert_allclose(traj.t, 1.0 + 0.05 * np.arange(8))
    assert len(traj) == 8
    assert "DiscreteTrajectory(samples=8" in repr(traj) and "compiled" in repr(traj)
    with pytest.raises(dataclasses.FrozenInstanceError):
        traj.h = 1.0
    with pytest.raises(ValueError):
        traj.q[0, 0] = 1.0
    empty = simulate_discrete(kepler().discrete_lagrangian(0.05), q0, p0, steps=0)
    assert empty.q.shape == (1, 2) and empty.iterations.shape == (0,)


def test_docstring_examples_run() -> None:
    result = doctest.testmod(discrete, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
