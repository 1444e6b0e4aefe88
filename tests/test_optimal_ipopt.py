"""lgvi.optimal.transfer(..., method="ipopt"): IPOPT through CasADi on the known-answer transfers.

CasADi is in the ``test`` extra, so these run in CI; elsewhere they skip cleanly without it (the
refusal test without CasADi always runs).

Tolerances: both solvers stop at a KKT point of the same discrete problem (IPOPT: scaled KKT error
``tol = 1e-10``, constraints to ``constraint_tol = 1e-8``; SLSQP: ``ftol = 1e-10``), and both meet
the terminal constraints to ~1e-13 or better here. At a minimum the cost is stationary: controls
that differ by ``du`` give costs that differ by ``O(|du|^2)`` plus the multipliers times the
constraint violations, so the costs must agree to ~1e-10 relative; 1e-9 leaves a factor of ten.
The controls themselves are determined only to ``sqrt`` of the cost tolerance along the flat
directions (~1e-5), and agree to 1e-4 relative (the indirect method's test uses the same bound).
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import lgvi
from lgvi import so3
from lgvi.optimal import InfeasibleTransferError, TransferError, transfer

try:
    import casadi  # noqa: F401
    HAVE_CASADI = True
except ImportError:
    HAVE_CASADI = False

needs_casadi = pytest.mark.skipif(not HAVE_CASADI, reason="casadi not installed (pip install lgvi[ipopt])")

AXIS = np.array([1.0, 2.0, 2.0]) / 3.0
SPHERE = lgvi.RigidBody([1.0, 1.0, 1.0])
BODY = lgvi.RigidBody([1.0, 2.0, 2.5])
SLEW = dict(omega0=[0.1, 0.0, -0.1], omegaf=[0.0, 0.05, 0.0], max_torque=1.5)


@needs_casadi
def test_minimum_energy_sphere_matches_the_known_optimum_and_slsqp():
    costs = {}
    for N, expected in ((20, 47.871081), (40, 47.968157), (80, 47.992063)):
        res = transfer(SPHERE, np.eye(3), so3.exp(2.0 * AXIS), 1.0, N, method="ipopt")
        costs[N] = res.cost
        assert abs(res.cost - expected) < 2e-6, (N, res.cost)
        assert np.abs(res.u - np.outer(res.u @ AXIS, AXIS)).max() < 1e-6          # on the eigenaxis
        assert res.violation["attitude"] < 1e-8 and res.violation["rate"] < 1e-8
        assert res.u.shape == (N, 3) and res.T == 1.0 and len(res.trajectory.t) == N + 1
        assert res.stats["method"] == "ipopt" and res.stats["success"] and res.stats["iterations"] > 0
    for coarse, fine in ((20, 40), (40, 80)):                                     # O(h^2) to 12 theta^2 = 48
        assert abs((48.0 - costs[coarse]) / (48.0 - costs[fine]) - 4.0) < 0.1
    slsqp = transfer(SPHERE, np.eye(3), so3.exp(2.0 * AXIS), 1.0, 20)
    assert abs(costs[20] - slsqp.cost) < 1e-9 * slsqp.cost


@needs_casadi
def test_asymmetric_slew_with_a_torque_bound_agrees_with_slsqp():
    Rf = so3.exp([0.8, -0.5, 1.2])
    ip = transfer(BODY, np.eye(3), Rf, 3.0, 20, method="ipopt", **SLEW)
    sq = transfer(BODY, np.eye(3), Rf, 3.0, 20, **SLEW)
    assert ip.violation["attitude"] < 1e-8 and ip.violation["rate"] < 1e-8
    assert np.abs(ip.u).max() <= 1.5                       # the box is hard: no relaxation of the bound
    assert np.isclose(np.abs(ip.u).max(), 1.5, rtol=0, atol=1e-9)   # ... and active
    np.testing.assert_allclose(ip.trajectory.R[-1], Rf, atol=1e-8)
    np.testing.assert_allclose(ip.trajectory.omega[-1], [0.0, 0.05, 0.0], atol=1e-8)
    assert abs(ip.cost - sq.cost) < 1e-9 * sq.cost, (ip.cost, sq.cost)
    assert np.abs(ip.u - sq.u).max() < 1e-4 * np.abs(sq.u).max()


@needs_casadi
def test_minimum_time_half_turn_agrees_with_slsqp():
    # SLSQP's T for this request (test_optimal.py runs it): 3.2366991109087895; IPOPT needs ~800
    # iterations here (bang-bang controls: every bound active somewhere), so SLSQP is not rerun
    ip = transfer(SPHERE, np.eye(3), so3.exp([np.pi, 0.0, 0.0]), 3.6, 30, cost="time", max_torque=1.0,
                  method="ipopt")
    assert abs(ip.T - 3.2366991109087895) < 1e-8 * ip.T, ip.T
    assert ip.cost == ip.T and ip.violation["torque_bound"] == 0.0
    assert (np.abs(np.abs(ip.u) - 1.0) < 1e-6).mean() > 0.9                          # bang-bang
    assert sorted(int(np.sum(np.diff(np.sign(ip.u[:, i])) != 0)) for i in range(3)) == [1, 2, 2]


@needs_casadi
def test_symmetric_forcing_and_a_potential():
    Rf = so3.exp(2.0 * AXIS)
    ip = transfer(SPHERE, np.eye(3), Rf, 1.0, 10, forcing="symmetric", method="ipopt")
    sq = transfer(SPHERE, np.eye(3), Rf, 1.0, 10, forcing="symmetric")
    assert ip.u.shape == (11, 3) and abs(ip.cost - sq.cost) < 1e-9 * sq.cost
    gg = lgvi.torques.GravityGradient(mu=0.5, radius=1.0)
    ip = transfer(BODY, np.eye(3), so3.exp([0.0, 0.0, 1.0]), 2.0, 16, torque=gg, method="ipopt")
    sq = transfer(BODY, np.eye(3), so3.exp([0.0, 0.0, 1.0]), 2.0, 16, torque=gg)
    assert ip.violation["attitude"] < 1e-8 and ip.violation["rate"] < 1e-8
    assert abs(ip.cost - sq.cost) < 1e-9 * sq.cost


@needs_casadi
def test_failure_raises_with_the_best_iterate_and_what_was_violated():
    with pytest.raises(TransferError, match=r"ipopt: Maximum_Iterations_Exceeded.*violated beyond") as info:
        transfer(BODY, np.eye(3), so3.exp([2.0, -1.0, 0.5]), 1.0, 12, maxiter=2, method="ipopt")
    err = info.value
    assert err.best is not None and err.best.u.shape == (12, 3) and err.best.stats["method"] == "ipopt"
    assert set(err.violation) >= {"attitude", "rate"} and max(err.violation.values()) > 1e-8
    # the best iterate is no worse than the last one
    best = max(err.best.violation["attitude"], err.best.violation["rate"])
    assert best <= max(err.violation["attitude"], err.violation["rate"])


@needs_casadi
def test_infeasible_requests_are_refused_before_solving():
    with pytest.raises(InfeasibleTransferError, match="too short"):
        transfer(SPHERE, np.eye(3), so3.exp([np.pi, 0, 0]), 2.5, 10, max_torque=1.0, method="ipopt")
    with pytest.raises(InfeasibleTransferError, match="max_torque"):
        transfer(SPHERE, np.eye(3), so3.exp([1.0, 0, 0]), 2.5, 10, cost="time", method="ipopt")


def test_unknown_method_names_the_argument_and_the_choices():
    with pytest.raises(ValueError, match=r"method must be one of .*'SLSQP'.*'ipopt'; got 'IPOPT3'"):
        transfer(SPHERE, np.eye(3), np.eye(3), 1.0, 10, method="IPOPT3")


def test_ipopt_without_casadi_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "casadi", None)          # import casadi raises ImportError
    with pytest.raises(ImportError, match=r"pip install lgvi\[ipopt\]"):
        transfer(SPHERE, np.eye(3), so3.exp(2.0 * AXIS), 1.0, 10, method="ipopt")


def test_minimum_time_uses_ipopt_when_casadi_is_installed_and_says_which(monkeypatch):
    # issue 29: cost="time" with SciPy's SLSQP took 780 s at N = 200 where IPOPT takes 0.3 s
    args = (SPHERE, np.eye(3), so3.exp([1.0, 0.0, 0.0]), 2.5, 10)
    if HAVE_CASADI:
        res = transfer(*args, cost="time", max_torque=1.0)
        assert res.stats["method"] == "ipopt" and "CasADi is installed" in res.stats["method_choice"]
    monkeypatch.setitem(sys.modules, "casadi", None)          # as without CasADi: import casadi fails
    res = transfer(*args, cost="time", max_torque=1.0)
    assert res.stats["method"] == "SLSQP" and "pip install lgvi[ipopt]" in res.stats["method_choice"]
    assert transfer(*args).stats["method"] == "SLSQP"        # cost="energy": SLSQP by default
