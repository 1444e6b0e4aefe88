"""Measured orders of convergence of the forcing schemes and compositions.

Every scheme is run to a fixed time T with N = T/h steps and compared with a tight DOP853
solution (rtol = atol = 1e-13) of the same equations, Euler's equations and dR/dt = R hat(Omega)
with the model's NumPy moment. The order is the slope of a least-squares fit of log(error)
against log(h) over step sizes whose errors lie between ~1e-2 and ~1e-10: in the asymptotic
range, above the reference's error (~1e-12) and the solver's round-off plateau. A slope is
asserted within 0.25 of the nominal order, which separates it from the neighbouring orders
(a symmetric scheme's error expansion has even powers only, so the next candidates are p +- 2
for the compositions and p +- 1 for the forcing schemes).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lgvi
from lgvi import integrator, so3
from lgvi.torques import AttitudePD, Constant, GravityGradient, LinearDamping, UniformGravity

PENDULUM = lgvi.RigidBody([0.13, 0.28, 0.17])
BODY = lgvi.RigidBody(np.array([[0.9, 0.05, -0.1], [0.05, 1.3, 0.08], [-0.1, 0.08, 1.7]]))
R0 = so3.exp([0.3, -0.2, 0.5])
T = 1.0
TOLERANCE = 0.25


def reference(body, moment, R0, Pi0, T):
    J_inv = body.J_inv

    def rhs(t, y):
        R, Pi = y[:9].reshape(3, 3), y[9:]
        W = J_inv @ Pi
        return np.concatenate([(R @ so3.hat(W)).ravel(), np.cross(Pi, W) + moment(t, R, Pi)])

    sol = solve_ivp(rhs, (0.0, T), np.concatenate([R0.ravel(), Pi0]), method="DOP853", rtol=1e-13, atol=1e-13)
    assert sol.success
    return sol.y[:9, -1].reshape(3, 3), sol.y[9:, -1]


def fitted_order(body, torque, Pi0, Ns, ref, **kw):
    R_ref, Pi_ref = ref
    hs, errs = [], []
    for N in Ns:
        tq = torque(N) if callable(torque) and getattr(torque, "per_grid", False) else torque
        traj = lgvi.simulate(body, R0, Pi0, h=T / N, steps=N, torque=tq, **kw)
        err = max(np.linalg.norm(traj.R[-1] - R_ref), np.linalg.norm(traj.Pi[-1] - Pi_ref) / np.linalg.norm(Pi_ref))
        hs.append(T / N)
        errs.append(err)
    errs = np.array(errs)
    assert errs.min() > 1e-11, f"errors {errs} reach the round-off plateau: choose larger steps"
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    return slope, errs


# ------------------------------------------------------------------ potentials: the heavy top
PENDULUM_PI0 = PENDULUM.J @ np.full(3, 4.14 * 0.25)
GRAVITY = UniformGravity(1.0, [0.0, 0.0, 0.3])


@pytest.fixture(scope="module")
def pendulum_ref():
    return reference(PENDULUM, lambda t, R, Pi: GRAVITY.moment(t, R, Pi, PENDULUM), R0, PENDULUM_PI0, T)


@pytest.mark.parametrize("order, composition, Ns", [
    (2, None, (23, 32, 45, 64)),
    (4, "suzuki4", (16, 23, 32, 45, 64)),
    (4, "yoshida4", (32, 45, 64, 90)),
    (6, "kahan-li6", (32, 45, 64, 90)),
    (6, "yoshida6", (64, 90, 128)),
])
def test_pendulum_orders(pendulum_ref, order, composition, Ns):
    slope, _ = fitted_order(PENDULUM, GRAVITY, PENDULUM_PI0, Ns, pendulum_ref, order=order, composition=composition)
    assert slope == pytest.approx(order, abs=TOLERANCE)


def test_better_constants_pay_off(pendulum_ref):
    """Suzuki's 5 stages beat Yoshida's 3 by more than their 5/3 cost (measured ~30x smaller
    error at the same h), Kahan-Li's 9 stages beat the 9-stage Yoshida triple-triple jump
    (measured ~150x); these are why they are the defaults."""
    def err(**kw):
        traj = lgvi.simulate(PENDULUM, R0, PENDULUM_PI0, h=T / 64, steps=64, torque=GRAVITY, **kw)
        return np.linalg.norm(traj.R[-1] - pendulum_ref[0])

    assert err(order=4) < err(order=4, composition="yoshida4") / 5
    assert err(order=6) < err(order=6, composition="yoshida6") / 20


def test_warm_start_per_substep(pendulum_ref):
    """One solver history per substep keeps the warm start as good as at order 2 (the same
    updates per solve, 2.00 measured for this motion); a history shared by all substeps
    extrapolates across unequal sizes and needs ~3.5 per solve (measured)."""
    h, steps = 0.01, 2000
    per_solve = {}
    for order, stages in ((2, 1), (4, 5), (6, 9)):
        traj = lgvi.simulate(PENDULUM, R0, PENDULUM_PI0 * 4, h=h, steps=steps, torque=GRAVITY, order=order)
        per_solve[order] = traj.iterations[10:].mean() / stages
    assert per_solve[4] <= per_solve[2] * 1.05
    assert per_solve[6] <= per_solve[2] * 1.05


# ------------------------------------------------------------------ time-dependent, non-conservative
def mixed_model():
    return (GravityGradient(40.0, 2.0) + LinearDamping([0.05, 0.02, 0.03])
            + AttitudePD(0.3, 0.02, so3.exp([0.1, 0.2, 0.3])) + Constant([0.01, 0.0, -0.02]))


MIXED_PI0 = PENDULUM.J @ np.full(3, 4.14 * 0.25)


@pytest.fixture(scope="module")
def mixed_ref():
    model = mixed_model()
    return reference(PENDULUM, lambda t, R, Pi: model.moment(t, R, Pi, PENDULUM), R0, MIXED_PI0, T)


@pytest.mark.parametrize("forcing, order, Ns", [
    ("paper", 2, (16, 23, 32, 45, 64)),
    ("symmetric", 2, (16, 23, 32, 45, 64)),
    ("symmetric", 4, (8, 11, 16, 23, 32)),
    ("symmetric", 6, (8, 11, 16, 23, 32)),
])
def test_mixed_model_orders(mixed_ref, forcing, order, Ns):
    """Gravity gradient (time-dependent potential) + damping + PD (momentum-dependent) + constant:
    order 1 with the paper's forcing, 2 with the symmetric one, 4 and 6 composed."""
    slope, _ = fitted_order(PENDULUM, mixed_model(), MIXED_PI0, Ns, mixed_ref, forcing=forcing, order=order)
    expected = 1 if forcing == "paper" else order
    assert slope == pytest.approx(expected, abs=TOLERANCE)


# ------------------------------------------------------------------ user torques: callables and arrays
def user_torque(t, R, Pi):
    """Explicitly time-dependent, attitude-dependent torque."""
    return np.array([0.3 * np.sin(3.0 * t), 0.2 * np.cos(2.0 * t), 0.0]) + 0.1 * R[2]


@pytest.fixture(scope="module")
def user_ref():
    return reference(BODY, user_torque, R0, np.array([0.6, -0.9, 1.2]), T)


@pytest.mark.parametrize("forcing, order, expected", [
    ("paper", 2, 1),
    ("symmetric", 2, 2),
    ("symmetric", 4, 4),
])
def test_callable_orders(user_ref, forcing, order, expected):
    Ns = (16, 23, 32, 45, 64) if order == 2 else (6, 8, 11, 16)
    slope, _ = fitted_order(BODY, user_torque, np.array([0.6, -0.9, 1.2]), Ns, user_ref, forcing=forcing, order=order)
    assert slope == pytest.approx(expected, abs=TOLERANCE)


@pytest.mark.parametrize("forcing, expected", [("paper", 1), ("symmetric", 2)])
def test_time_dependent_array_orders(forcing, expected):
    """A torque array u_k = u(t_k): (steps, 3) with the paper's update, first order;
    (steps + 1, 3) with the symmetric update, second order."""
    u = lambda t: np.array([0.3 * np.sin(3.0 * t), 0.2 * np.cos(2.0 * t), 0.1])  # noqa: E731
    Pi0 = np.array([0.6, -0.9, 1.2])
    R_ref, Pi_ref = reference(BODY, lambda t, R, Pi: u(t), R0, Pi0, T)
    hs, errs = [], []
    for N in (16, 23, 32, 45, 64):
        rows = N + 1 if forcing == "symmetric" else N
        U = np.array([u(k * T / N) for k in range(rows)])
        traj = lgvi.simulate(BODY, R0, Pi0, h=T / N, steps=N, torque=U, forcing=forcing)
        hs.append(T / N)
        errs.append(max(np.linalg.norm(traj.R[-1] - R_ref), np.linalg.norm(traj.Pi[-1] - Pi_ref)))
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert slope == pytest.approx(expected, abs=TOLERANCE)


# ------------------------------------------------------------------ free body
@pytest.mark.parametrize("order, Ns", [(2, (11, 16, 23, 32)), (4, (8, 11, 16, 23)), (6, (11, 16, 23, 32))])
def test_free_body_orders(order, Ns):
    Pi0 = np.array([0.6, -0.9, 1.2]) * 3
    ref = reference(BODY, lambda t, R, Pi: np.zeros(3), R0, Pi0, T)
    slope, _ = fitted_order(BODY, None, Pi0, Ns, ref, order=order)
    assert slope == pytest.approx(order, abs=TOLERANCE)


# ------------------------------------------------------------------ the coefficients
@pytest.mark.parametrize("name", sorted(integrator.COMPOSITIONS))
def test_composition_coefficients(name):
    """Consistency (sum 1), symmetry, and the order conditions sum g^3 = 0 (order 4) and
    sum g^5 = 0 (order 6) that symmetric compositions of a symmetric second-order method need
    (the remaining order-6 condition is covered by the measured slopes above)."""
    comp = integrator.COMPOSITIONS[name]
    g = np.array(comp.coefficients)
    assert g.sum() == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_array_equal(g, g[::-1])
    assert abs(np.sum(g ** 3)) < 1e-14
    if comp.order == 6:
        assert abs(np.sum(g ** 5)) < 1e-13
    else:
        assert abs(np.sum(g ** 5)) > 1e-3          # an order-4 method is not accidentally more
    assert comp.stages == {"yoshida4": 3, "suzuki4": 5, "kahan-li6": 9, "yoshida6": 9}[name]
    assert integrator.DEFAULT_COMPOSITION == {4: "suzuki4", 6: "kahan-li6"}


def test_kahan_li_middle_coefficient_matches_the_published_value():
    g = integrator.COMPOSITIONS["kahan-li6"].coefficients
    assert g[4] == pytest.approx(0.79854399093482996339895035, abs=2e-16)
