"""lgvi.optimal: the discrete adjoint against central differences, transfers against known optima.

Finite-difference step: the costs below are O(1) with O(1) third derivatives, so a central
difference with step d has truncation error ~ d^2 / 6 ~ 2e-11 and round-off ~ eps / d ~ 2e-11
(the forward solves stop at round-off, tol = 1e-15) for d = 1e-5: a relative error of 1e-8 leaves
a factor of ~100 for unlucky third derivatives.
"""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi import so3
from lgvi.optimal import (AttitudeError, Effort, InfeasibleTransferError, RateError, Terminal, TransferError,
                          cost_gradient, rollout, transfer)
from lgvi.optimal.adjoint import reverse
from lgvi.torques import GravityGradient, UniformGravity

D = 1e-5
J_FULL = np.array([[1.5, 0.1, -0.05], [0.1, 2.0, 0.2], [-0.05, 0.2, 2.8]])
POTENTIALS = {"free": None, "gravity": UniformGravity(mass=1.0, com=[0.1, 0.0, -0.3]),
              "gravity_gradient": GravityGradient(mu=1.0, radius=1.0)}   # n = 1: time-dependent too


def _rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


def _check_gradient(forcing, torque, R0, cost, N=10, h=0.07):
    rng = np.random.default_rng(3)
    nu = N + 1 if forcing == "symmetric" else N
    u = 0.3 * rng.normal(size=(nu, 3))
    Pi0 = rng.normal(size=3)

    def f(J=J_FULL, R0=R0, Pi0=Pi0, u=u, h=h):
        return cost_gradient(rollout(J, R0, Pi0, h, u, forcing=forcing, torque=torque), cost)

    g = f()
    gu = np.zeros_like(u)
    for idx in np.ndindex(u.shape):
        e = np.zeros_like(u)
        e[idx] = D
        gu[idx] = (f(u=u + e).cost - f(u=u - e).cost) / (2 * D)
    gR = [(f(R0=R0 @ so3.exp(D * e)).cost - f(R0=R0 @ so3.exp(-D * e)).cost) / (2 * D) for e in np.eye(3)]
    gP = [(f(Pi0=Pi0 + D * e).cost - f(Pi0=Pi0 - D * e).cost) / (2 * D) for e in np.eye(3)]
    gJ = np.zeros((3, 3))
    for a in range(3):
        for b in range(a, 3):
            E = np.zeros((3, 3))
            E[a, b] = E[b, a] = D
            v = (f(J=J_FULL + E).cost - f(J=J_FULL - E).cost) / (2 * D)
            gJ[a, b] = gJ[b, a] = v if a == b else v / 2     # <G, E> = 2 G_ab off the diagonal
    gh = (f(h=h * (1 + D)).cost - f(h=h * (1 - D)).cost) / (2 * D * h)
    errors = {"u": _rel(gu, g.u), "R0": _rel(gR, g.R0), "Pi0": _rel(gP, g.Pi0), "inertia": _rel(gJ, g.inertia),
              "h": abs(gh - g.h) / abs(g.h)}
    assert max(errors.values()) <= 1e-8, errors


@pytest.mark.parametrize("forcing", ["paper", "symmetric"])
@pytest.mark.parametrize("potential", list(POTENTIALS))
def test_adjoint_matches_central_differences_near_identity(forcing, potential):
    R0 = so3.exp([1e-3, -2e-3, 5e-4])
    target = so3.exp([0.2, 0.1, -0.1])
    cost = [Effort(0.7), AttitudeError(target, 1.3), RateError([0.1, 0.2, 0.3], 0.9)]
    _check_gradient(forcing, POTENTIALS[potential], R0, cost)


@pytest.mark.parametrize("forcing", ["paper", "symmetric"])
def test_adjoint_matches_central_differences_near_pi(forcing):
    # start a hair short of a half turn and measure the final error with the chordal distance
    # (smooth through pi), plus a user's terminal cost with its derivative
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    R0 = so3.exp((np.pi - 1e-4) * axis)
    b = np.array([0.3, -0.2, 0.9])

    def value(R, Pi):                      # (R b) . e3 + |Pi|^2 / 2
        return float((R @ b)[2] + 0.5 * Pi @ Pi)

    def derivative(R, Pi):                 # d/dzeta (R exp(zeta) b) . e3 = (b x R^T e3) . zeta
        return np.cross(b, R[2]), Pi.copy()

    cost = [Effort(), AttitudeError(np.eye(3), 2.0, kind="chordal"), Terminal(value, derivative)]
    _check_gradient(forcing, POTENTIALS["gravity_gradient"], R0, cost)


def test_reverse_pass_takes_many_seeds_at_once():
    run = rollout(J_FULL, np.eye(3), [0.1, 0.2, 0.3], 0.1, np.ones((8, 3)))
    rng = np.random.default_rng(0)
    dR, dP, du = rng.normal(size=(3, 9, 3)), rng.normal(size=(3, 9, 3)), rng.normal(size=(3, 8, 3))
    lam, gu, gJ, gh = reverse(run, dR, dP, du)
    for s in range(3):
        one = reverse(run, dR[s:s + 1], dP[s:s + 1], du[s:s + 1])
        np.testing.assert_array_equal(one[0][0], lam[s])
        np.testing.assert_array_equal(one[1][0], gu[s])
    # terminal-only partials, (S, 1, 3), are the full arrays with zeros before step N
    full = [np.zeros_like(dR), np.zeros_like(dP)]
    full[0][:, -1], full[1][:, -1] = dR[:, -1], dP[:, -1]
    a, b = reverse(run, full[0], full[1], du), reverse(run, dR[:, -1:], dP[:, -1:], du)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_rollout_agrees_with_simulate():
    u = np.outer(np.linspace(0.0, 1.0, 50), [0.2, -0.1, 0.3])
    run = rollout(J_FULL, so3.exp([0.1, 0.2, 0.3]), [0.4, 0.1, -0.2], 0.05, u)
    traj = lgvi.simulate(J_FULL, so3.exp([0.1, 0.2, 0.3]), [0.4, 0.1, -0.2], h=0.05, steps=50, torque=u)
    assert np.abs(run.R - traj.R).max() < 1e-13 and np.abs(run.Pi - traj.Pi).max() < 1e-13


# ------------------------------------------------------------------------------- known optima
AXIS = np.array([1.0, 2.0, 2.0]) / 3.0
SPHERE = lgvi.RigidBody([1.0, 1.0, 1.0])


def test_minimum_energy_sphere_is_the_discrete_eigenaxis_optimum():
    costs = {}
    for N, expected in ((20, 47.871081), (40, 47.968157), (80, 47.992063)):
        res = transfer(SPHERE, np.eye(3), so3.exp(2.0 * AXIS), 1.0, N)
        costs[N] = res.cost
        assert abs(res.cost - expected) < 2e-6, (N, res.cost)
        off_axis = res.u - np.outer(res.u @ AXIS, AXIS)
        assert np.abs(off_axis).max() < 1e-6
        assert res.violation["attitude"] < 1e-8 and res.violation["rate"] < 1e-8
        assert res.u.shape == (N, 3) and res.T == 1.0 and len(res.trajectory.t) == N + 1
    # O(h^2) towards the continuous optimum 12 j^2 theta^2 / T^3 = 48
    for coarse, fine in ((20, 40), (40, 80)):
        ratio = (48.0 - costs[coarse]) / (48.0 - costs[fine])
        assert abs(ratio - 4.0) < 0.1, ratio


def test_minimum_time_half_turn_is_bang_bang_and_beats_the_eigenaxis():
    # Bilimoria and Wie (1993): 180 deg about a body axis, |u_i| <= 1, J = I: T* = 3.243 < 2 sqrt(pi)
    res = transfer(SPHERE, np.eye(3), so3.exp([np.pi, 0.0, 0.0]), 3.6, 30, cost="time", max_torque=1.0,
                   method="SLSQP")
    assert res.T < 0.95 * 2.0 * np.sqrt(np.pi)
    assert abs(res.T - 3.243) < 0.01, res.T
    saturated = np.abs(np.abs(res.u) - 1.0) < 1e-6
    assert saturated.mean() > 0.9                        # bang-bang (a sample per switch may be interior)
    switches = [int(np.sum(np.diff(np.sign(res.u[:, i])) != 0)) for i in range(3)]
    assert sorted(switches) == [1, 2, 2], switches        # five switches, all three axes used
    assert res.violation["attitude"] < 1e-8 and res.violation["torque_bound"] == 0.0


def test_asymmetric_slew_meets_its_constraints_with_consistent_jacobian():
    body = lgvi.RigidBody([1.0, 2.0, 2.5])
    Rf = so3.exp([0.8, -0.5, 1.2])
    res = transfer(body, np.eye(3), Rf, 3.0, 20, omega0=[0.1, 0.0, -0.1], omegaf=[0.0, 0.05, 0.0],
                   max_torque=1.5)
    assert res.violation["attitude"] < 1e-8 and res.violation["rate"] < 1e-8
    assert np.abs(res.u).max() <= 1.5 + 1e-12
    np.testing.assert_allclose(res.trajectory.R[-1], Rf, atol=1e-8)
    np.testing.assert_allclose(res.trajectory.omega[-1], [0.0, 0.05, 0.0], atol=1e-8)
    # first-order optimality: the cost gradient lies in the span of the active constraints' gradients
    run = rollout(body, np.eye(3), body.J @ [0.1, 0.0, -0.1], 3.0 / 20, res.u)
    e = so3.log(Rf.T @ run.R[-1])
    dR = np.zeros((6, 21, 3))
    dP = np.zeros((6, 21, 3))
    dR[:3, -1] = so3.right_jacobian_inv(e)
    dP[3:, -1] = body.J_inv
    jac = reverse(run, dR, dP, np.zeros((6, 20, 3)))[1].reshape(6, -1)
    free = (np.abs(np.abs(res.u) - 1.5) > 1e-6).ravel()
    assert not free.all()                                # the bound is active somewhere
    g = (2 * 3.0 / 20 * res.u).ravel()
    mult, *_ = np.linalg.lstsq(jac[:, free].T, g[free], rcond=None)
    assert np.abs(jac[:, free].T @ mult - g[free]).max() < 1e-5 * np.abs(g).max()


def test_slew_under_gravity_gradient():
    body = lgvi.RigidBody([1.0, 2.0, 2.5])
    gg = GravityGradient(mu=0.5, radius=1.0)
    Rf = so3.exp([0.0, 0.0, 1.0])
    res = transfer(body, np.eye(3), Rf, 2.0, 16, torque=gg)
    assert res.violation["attitude"] < 1e-8 and res.violation["rate"] < 1e-8
    assert res.trajectory.potential is not None
    free = transfer(body, np.eye(3), Rf, 2.0, 16)
    assert abs(res.cost - free.cost) > 1e-3 * free.cost      # the potential changes the optimum
    # the constraint Jacobian the solver used (one reverse pass, six seeds) against central
    # differences along random directions of the controls, at the optimum
    h = 2.0 / 16

    def constraints(u):
        run = rollout(body, np.eye(3), np.zeros(3), h, u, torque=gg)
        return run, np.concatenate([so3.log(Rf.T @ run.R[-1]), body.J_inv @ run.Pi[-1]])

    run, c = constraints(res.u)
    dR, dP = np.zeros((6, 1, 3)), np.zeros((6, 1, 3))
    dR[:3, -1] = so3.right_jacobian_inv(c[:3])
    dP[3:, -1] = body.J_inv
    jac = reverse(run, dR, dP, np.zeros((6, 16, 3)))[1].reshape(6, -1)
    for seed in range(3):
        v = np.random.default_rng(seed).normal(size=res.u.shape)
        fd = (constraints(res.u + D * v)[1] - constraints(res.u - D * v)[1]) / (2 * D)
        assert np.abs(fd - jac @ v.ravel()).max() <= 1e-8 * np.abs(fd).max()


def test_infeasible_and_bad_requests_are_refused():
    # half turn of a unit sphere with |u_i| <= 1 needs T >= 2 sqrt(pi / sqrt(3)) = 2.69
    with pytest.raises(InfeasibleTransferError, match="too short"):
        transfer(SPHERE, np.eye(3), so3.exp([np.pi, 0, 0]), 2.5, 10, max_torque=1.0)
    with pytest.raises(InfeasibleTransferError, match="max_torque"):
        transfer(SPHERE, np.eye(3), so3.exp([1.0, 0, 0]), 2.5, 10, cost="time")
    with pytest.raises(ValueError, match="T must be positive"):
        transfer(SPHERE, np.eye(3), np.eye(3), -1.0, 10)
    with pytest.raises(ValueError, match="N must be an integer >= 2"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 1)
    with pytest.raises(ValueError, match="cost must be one of"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, cost="fuel")
    with pytest.raises(ValueError, match="max_torque must be positive"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, max_torque=[1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="omega0 must be 0 or a vector"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, omega0=0.5)
    with pytest.raises(ValueError, match="omegaf must have shape"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, omegaf=[1.0, 2.0])
    with pytest.raises(ValueError, match="Rf"):
        transfer(SPHERE, np.eye(3), 2 * np.eye(3), 1.0, 10)
    with pytest.raises(TypeError, match="torque"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, torque=lambda t, R, Pi: np.zeros(3))
    with pytest.raises(ValueError, match="u0 must have shape"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, u0=np.zeros((9, 3)))


def test_failure_raises_with_the_best_iterate():
    with pytest.raises(TransferError) as info:
        transfer(lgvi.RigidBody([1.0, 2.0, 2.5]), np.eye(3), so3.exp([2.0, -1.0, 0.5]), 1.0, 12, maxiter=2)
    err = info.value
    assert err.best is not None and err.best.u.shape == (12, 3)
    assert "attitude" in str(err) or "rate" in str(err) or "did not converge" in str(err)
    assert set(err.violation) >= {"attitude", "rate"}


# ------------------------------------------------------------------------------- identification
def _synthetic(sigma, seed, M=101, every=2, h=0.05):
    from lgvi.optimal import identify_inertia

    Q = so3.exp([0.3, -0.4, 0.5])
    J_true = Q @ np.diag([1.0, 1.7, 2.4]) @ Q.T
    N = (M - 1) * every
    t = h * np.arange(N)
    U = np.stack([0.5 * np.sin(t), 0.4 * np.cos(0.7 * t), 0.3 * np.sin(1.3 * t + 1.0)], axis=1)
    w0 = np.array([0.8, -0.5, 0.9])
    run = rollout(J_true, so3.exp([0.2, 0.1, 0.3]), J_true @ w0, h, U)
    idx = np.arange(M) * every
    rng = np.random.default_rng(seed)
    R_meas = run.R[idx] @ so3.exp(sigma * rng.normal(size=(M, 3)))
    omega_meas = run.omega[idx] + sigma * rng.normal(size=(M, 3))
    fit = identify_inertia(np.diag([1.2, 1.5, 2.2]), h=h, R0=R_meas[0], omega0=omega_meas[0], R_meas=R_meas,
                           omega_meas=omega_meas, sigma_R=sigma, sigma_omega=sigma, every=every, u=U)
    return fit, J_true


def test_identify_inertia_recovers_J_within_the_noise():
    from lgvi.optimal.identify import ENTRIES

    for sigma in (1e-3, 1e-4):
        fit, J_true = _synthetic(sigma, seed=0)
        d = np.array([(fit.inertia - J_true)[i, j] for i, j in ENTRIES])
        z = d / np.array([fit.standard_error[i, j] for i, j in ENTRIES])
        assert np.abs(z).max() < 4.0, z                                  # error / predicted standard error
        assert d @ np.linalg.solve(fit.covariance, d) < 27.9            # chi^2(6) at 0.9999
        assert 0.2 * sigma < fit.standard_error.max() < 2.0 * sigma     # the uncertainty follows the noise
        assert 0.7 < 2 * fit.cost / fit.residuals < 1.3                 # whitened residuals of unit variance
        assert np.all(np.linalg.eigvalsh(fit.inertia) > 0)


def test_identify_inertia_refuses_an_unobservable_scale():
    from lgvi.optimal import identify_inertia

    with pytest.raises(ValueError, match="scale of J is unobservable"):
        identify_inertia([1.0, 2.0, 2.5], h=0.1, R0=np.eye(3), omega0=[0.1, 0.2, 0.3],
                         omega_meas=np.zeros((5, 3)), sigma_omega=1e-3)
    with pytest.raises(ValueError, match="sigma_R"):
        identify_inertia([1.0, 2.0, 2.5], h=0.1, R0=np.eye(3), omega0=[0.1, 0.2, 0.3],
                         R_meas=np.stack([np.eye(3)] * 5), u=np.ones((4, 3)))


def test_symmetric_forcing_and_trust_constr_transfers():
    Rf = so3.exp(2.0 * AXIS)
    slsqp = transfer(SPHERE, np.eye(3), Rf, 1.0, 10)
    tc = transfer(SPHERE, np.eye(3), Rf, 1.0, 10, method="trust-constr")
    assert abs(tc.cost - slsqp.cost) < 1e-6 * slsqp.cost
    sym = transfer(SPHERE, np.eye(3), Rf, 1.0, 10, forcing="symmetric")
    assert sym.u.shape == (11, 3) and sym.violation["attitude"] < 1e-8 and sym.violation["rate"] < 1e-8
    sym20 = transfer(SPHERE, np.eye(3), Rf, 1.0, 20, forcing="symmetric")
    ratio = (48.0 - sym.cost) / (48.0 - sym20.cost)               # 46.1157, 47.5172: O(h^2) to 48
    assert abs(ratio - 4.0) < 0.3, ratio


def test_cost_terms_validate_their_arguments():
    with pytest.raises(ValueError, match="Effort.weight must be >= 0"):
        Effort(-1.0)
    with pytest.raises(ValueError, match="AttitudeError.kind must be one of"):
        AttitudeError(np.eye(3), kind="angle")
    with pytest.raises(ValueError, match="RateError.target must have shape"):
        RateError([1.0, 2.0])
    with pytest.raises(TypeError, match="Terminal.value must be callable"):
        Terminal(1.0, lambda R, Pi: (R, Pi))
    with pytest.raises(TypeError, match="cost must be a cost term"):
        cost_gradient(rollout(J_FULL, np.eye(3), np.zeros(3), 0.1, np.zeros((3, 3))), "energy")
    with pytest.raises(ValueError, match="forcing must be one of"):
        rollout(J_FULL, np.eye(3), np.zeros(3), 0.1, np.zeros((3, 3)), forcing="euler")
    with pytest.raises(ValueError, match="h must be non-zero"):
        rollout(J_FULL, np.eye(3), np.zeros(3), 0.0, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="torque must be built from the conservative models"):
        rollout(J_FULL, np.eye(3), np.zeros(3), 0.1, np.zeros((3, 3)), torque=lgvi.torques.Constant([1.0, 0, 0]))


def test_indirect_method_solves_the_discrete_necessary_conditions():
    # shooting on the initial multipliers reproduces the direct optimum (an independent solver of
    # the same discrete problem): sphere, asymmetric body with a torque bound, gravity gradient
    res = transfer(SPHERE, np.eye(3), so3.exp(2.0 * AXIS), 1.0, 20, method="indirect")
    assert abs(res.cost - 47.871081) < 2e-6
    assert np.abs(res.u - np.outer(res.u @ AXIS, AXIS)).max() < 1e-9
    body = lgvi.RigidBody([1.0, 2.0, 2.5])
    cases = [dict(R0=np.eye(3), Rf=so3.exp([0.8, -0.5, 1.2]), T=3.0, N=20, omega0=[0.1, 0.0, -0.1],
                  omegaf=[0.0, 0.05, 0.0], max_torque=1.5),
             dict(R0=np.eye(3), Rf=so3.exp([0.0, 0.0, 1.0]), T=2.0, N=16, torque=GravityGradient(mu=0.5, radius=1.0))]
    for kw in cases:
        R0, Rf, T, N = kw.pop("R0"), kw.pop("Rf"), kw.pop("T"), kw.pop("N")
        indirect = transfer(body, R0, Rf, T, N, method="indirect", **kw)
        direct = transfer(body, R0, Rf, T, N, **kw)
        assert indirect.violation["attitude"] < 1e-12 and indirect.violation["rate"] < 1e-12
        assert abs(indirect.cost - direct.cost) < 1e-9 * direct.cost
        assert np.abs(indirect.u - direct.u).max() < 1e-4 * np.abs(direct.u).max()
    with pytest.raises(ValueError, match="method='indirect' solves cost='energy'"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, method="indirect", forcing="symmetric")
