"""Order of accuracy, by the slope of log(error) against log(h).

Free body: second order against the exact solution (:mod:`lgvi.exact`, accurate to ~1e-14).
Paper's torque update ``Pi_{k+1} = F_k^T Pi_k + h u_k`` (left-endpoint torque): first order against
a tight DOP853 solution (rtol = atol = 1e-12) of Euler's equations and ``dR/dt = R hat(Omega)``.

Step sizes h = 0.04 ... 0.0025 over T = 10: the errors (1e-3 ... 1e-6) sit 8+ orders above the
round-off plateau (~1e-13) and the reference error, so the fitted slope is the order. Measured
slopes: 2.0001 (Pi and R, all methods); 1.02 (Pi) and 1.01 (R) with torque.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lgvi
from lgvi import so3
from lgvi.verification.exact import free_body_attitude, free_body_momentum

METHODS = ("paper", "newton", "cayley")
MOMENTS = np.array([1.0, 2.0, 3.0])
OMEGA0 = np.array([0.3, 1.0, 0.2])
T = 10.0
HS = np.array([0.04, 0.02, 0.01, 0.005, 0.0025])
SAMPLES = 10  # compare at t = 0, 1, ..., 10 (common to every h)


def attitude_error(R_exact: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Angle of R_exact^T R (geodesic distance on SO(3))."""
    return np.linalg.norm(so3.log(np.swapaxes(R_exact, -1, -2) @ R), axis=-1)


def slope(hs, errors) -> float:
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])


def run(h, **kwargs):
    steps = int(round(T / h))
    return lgvi.simulate(MOMENTS, so3.exp([0.1, -0.2, 0.3]), MOMENTS * OMEGA0, h=h, steps=steps,
                         save_every=steps // SAMPLES, **kwargs)


@pytest.fixture(scope="module")
def exact_free_body():
    t = np.linspace(0.0, T, SAMPLES + 1)
    Pi0 = MOMENTS * OMEGA0
    R0 = so3.exp([0.1, -0.2, 0.3])
    return t, free_body_momentum(MOMENTS, Pi0, t), free_body_attitude(MOMENTS, R0, Pi0, t)


@pytest.mark.parametrize("method", METHODS)
def test_free_body_second_order(method, exact_free_body):
    t, Pi_ex, R_ex = exact_free_body
    err_Pi, err_R = [], []
    for h in HS:
        traj = run(h, method=method)
        assert np.allclose(traj.t, t, rtol=0, atol=1e-12)
        err_Pi.append(np.max(np.linalg.norm(traj.Pi - Pi_ex, axis=1)))
        err_R.append(np.max(attitude_error(R_ex, traj.R)))
    # errors are well above round-off and the exact solution's accuracy (~1e-14)
    assert min(err_Pi) > 1e-8 and min(err_R) > 1e-8
    assert 1.9 <= slope(HS, err_Pi) <= 2.1
    assert 1.9 <= slope(HS, err_R) <= 2.1
    # and each halving of h divides the error by ~4 (local slopes, not just the fit)
    local = np.diff(np.log(err_Pi)) / np.diff(np.log(HS))
    assert np.all((local > 1.8) & (local < 2.2))


# --------------------------------------------------------------------------------------------
# first order of the paper's torque update
# --------------------------------------------------------------------------------------------
def torque(t):
    """A smooth time-dependent body torque u(t) (broadcasts over t)."""
    t = np.asarray(t, dtype=float)
    return np.stack([0.1 * np.cos(t), 0.2 * np.sin(2.0 * t), np.full_like(t, -0.05)], axis=-1)


@pytest.fixture(scope="module")
def forced_reference():
    """DOP853, rtol = atol = 1e-12, on (R as 9 components, Pi): error ~1e-10, far below 1e-6."""
    J_inv = np.diag(1.0 / MOMENTS)
    R0 = so3.exp([0.1, -0.2, 0.3])
    Pi0 = MOMENTS * OMEGA0

    def rhs(t, y):
        R = y[:9].reshape(3, 3)
        Pi = y[9:]
        Omega = J_inv @ Pi
        return np.concatenate([(R @ so3.hat(Omega)).ravel(), np.cross(Pi, Omega) + torque(t)])

    t = np.linspace(0.0, T, SAMPLES + 1)
    sol = solve_ivp(rhs, (0.0, T), np.concatenate([R0.ravel(), Pi0]), method="DOP853",
                    t_eval=t, rtol=1e-12, atol=1e-12)
    assert sol.success
    R = sol.y[:9].T.reshape(-1, 3, 3)
    Pi = sol.y[9:].T
    # sanity of the reference: R stays orthogonal to the integration tolerance
    assert np.max(np.abs(np.einsum("mki,mkj->mij", R, R) - np.eye(3))) < 1e-9
    return t, Pi, R


@pytest.mark.parametrize("method", METHODS)
def test_paper_torque_update_first_order(method, forced_reference):
    t, Pi_ref, R_ref = forced_reference
    err_Pi, err_R = [], []
    for h in HS:
        steps = int(round(T / h))
        U = torque(h * np.arange(steps))  # u_k = u(t_k)
        traj = run(h, method=method, torque=U)
        err_Pi.append(np.max(np.linalg.norm(traj.Pi - Pi_ref, axis=1)))
        err_R.append(np.max(attitude_error(R_ref, traj.R)))
    assert min(err_Pi) > 1e-5 and min(err_R) > 1e-5  # 1e5 x the reference's error
    assert 0.9 <= slope(HS, err_Pi) <= 1.1
    assert 0.9 <= slope(HS, err_R) <= 1.1
