"""Classical baselines (lgvi.baselines): RK4 and solve_ivp on Euler's equations with quaternions.

By purpose: the quaternion helpers against scipy and finite differences; RK4's order against a
tight DOP853 reference; DOP853 against the exact free body; the torque paths (callable, stand-in
model, built-in models compiled) against each other; the drift that motivates the LGVI, shown
with asserts on both sides; validation messages that name the argument.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.verification import baselines, exact
from lgvi._kernels import rk4_kernels
from lgvi.verification.baselines import compare, homogeneous_matrix, quat_rhs, rk4, solve_ivp_baseline
from lgvi.errors import TorqueError

MOMENTS = (1.0, 2.0, 3.0)
OMEGA0 = np.array([0.3, 1.0, 0.2])


@pytest.fixture(scope="module")
def body() -> lgvi.RigidBody:
    return lgvi.RigidBody(MOMENTS)


def relative_drift(traj):
    """Max relative deviation of energy, spatial momentum R Pi and |Pi| from their initial values."""
    E = traj.energy
    L = traj.spatial_momentum
    n = np.linalg.norm(traj.Pi, axis=1)
    return (np.max(np.abs(E - E[0])) / abs(E[0]),
            np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0]),
            np.max(np.abs(n - n[0])) / n[0])


class HeavyTopStandIn:
    """A torque model with the lgvi.torques interface, written here (not a built-in model).

    Uniform gravity about a fixed pivot: ``U = m g e3 . (R com)``, ``M = m g (R^T e3) x com``.
    """

    conservative = True

    def __init__(self, mass=1.0, com=(0.0, 0.1, 0.3), g=9.81):
        self.mg = mass * g
        self.com = np.asarray(com, dtype=float)

    def moment(self, t, R, Pi, body):
        return np.cross(np.asarray(R)[2], self.mg * self.com)

    def potential(self, t, R, body):
        return float(self.mg * np.asarray(R)[2] @ self.com)


class DampingStandIn:
    """A non-conservative stand-in: ``u = -c Omega + a sin(t) e1`` (time- and momentum-dependent)."""

    conservative = False

    def __init__(self, c=0.05, a=0.2):
        self.c, self.a = c, a

    def moment(self, t, R, Pi, body):
        return -self.c * (body.J_inv @ Pi) + np.array([self.a * np.sin(t), 0.0, 0.0])


# ------------------------------------------------------------------------------------------------
# quaternion helpers
# ------------------------------------------------------------------------------------------------
def test_homogeneous_matrix_is_norm_squared_times_scipy_rotation():
    rng = np.random.default_rng(0)
    q = rng.standard_normal((50, 4)) * rng.uniform(0.5, 2.0, (50, 1))
    R = homogeneous_matrix(q)
    expected = np.einsum("m,mij->mij", np.einsum("mi,mi->m", q, q), Rotation.from_quat(q).as_matrix())
    np.testing.assert_allclose(R, expected, rtol=0, atol=1e-13 * np.abs(expected).max())
    # a unit quaternion gives scipy's rotation itself
    qu = q / np.linalg.norm(q, axis=1, keepdims=True)
    np.testing.assert_allclose(homogeneous_matrix(qu), Rotation.from_quat(qu).as_matrix(), atol=1e-15)


def test_quat_rhs_is_the_derivative_of_the_kinematics():
    rng = np.random.default_rng(1)
    eps = 1e-6
    for _ in range(20):
        q0 = Rotation.random(random_state=rng).as_quat()
        omega = rng.standard_normal(3)
        # q(t) = q0 (x) exp(omega t / 2): constant body rate omega; central difference at t = 0
        qp = (Rotation.from_quat(q0) * Rotation.from_rotvec(omega * eps)).as_quat()
        qm = (Rotation.from_quat(q0) * Rotation.from_rotvec(-omega * eps)).as_quat()
        qp = qp if qp @ q0 > 0 else -qp
        qm = qm if qm @ q0 > 0 else -qm
        np.testing.assert_allclose(quat_rhs(q0, omega), (qp - qm) / (2 * eps), atol=1e-9)
        # and as matrices: d/dt R(q) along quat_rhs is R hat(omega)
        dq = quat_rhs(q0, omega)
        dR = (homogeneous_matrix(q0 + eps * dq) - homogeneous_matrix(q0 - eps * dq)) / (2 * eps)
        np.testing.assert_allclose(dR, homogeneous_matrix(q0) @ lgvi.so3.hat(omega), atol=1e-9)
    # vectorised over a leading axis
    qs = Rotation.random(4, random_state=2).as_quat()
    ws = rng.standard_normal((4, 3))
    np.testing.assert_array_equal(quat_rhs(qs, ws), np.stack([quat_rhs(a, b) for a, b in zip(qs, ws)]))


def test_compiled_rhs_matches_numpy_rhs(body):
    rng = np.random.default_rng(3)
    J, J_inv = np.ascontiguousarray(body.J), np.ascontiguousarray(body.J_inv)
    free = baselines._resolve_torque(None, body)
    f_np = baselines._python_rhs(baselines._Torque("callable", func=lambda t, R, Pi: np.zeros(3)), body)
    for _ in range(5):
        y = np.concatenate([1.1 * Rotation.random(random_state=rng).as_quat(), rng.standard_normal(3)])
        got = rk4_kernels.rhs(0.3, y, J, J_inv, free.codes, free.params, free.D)
        np.testing.assert_allclose(got, f_np(0.3, y), rtol=1e-14, atol=1e-15)


# ------------------------------------------------------------------------------------------------
# accuracy
# ------------------------------------------------------------------------------------------------
def test_rk4_is_fourth_order(body):
    T = 10.0
    ref = solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=T, samples=2, method="DOP853",
                             rtol=1e-13, atol=1e-13)
    hs = np.array([0.2, 0.1, 0.05, 0.025])
    errors = []
    for h in hs:
        traj = rk4(body, np.eye(3), omega0=OMEGA0, h=h, steps=int(round(T / h)))
        assert traj.t[-1] == pytest.approx(T, rel=1e-14)
        errors.append(max(np.abs(traj.R[-1] - ref.R[-1]).max(), np.abs(traj.Pi[-1] - ref.Pi[-1]).max()))
    errors = np.array(errors)
    assert errors[-1] > 1e-3 * 1e-6  # well above the reference's own error (~1e-12)
    slope = np.polyfit(np.log(hs), np.log(errors), 1)[0]
    assert 3.8 < slope < 4.2, (slope, errors)


def test_dop853_tight_matches_exact_free_body(body):
    t = np.linspace(0.0, 20.0, 21)
    Pi0 = body.J @ OMEGA0
    traj = solve_ivp_baseline(body, np.eye(3), Pi0, t_final=20.0, samples=21, method="DOP853",
                              rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(traj.t, t, atol=1e-14)
    R_exact = exact.free_body_attitude(MOMENTS, np.eye(3), Pi0, t)
    Pi_exact = exact.free_body_momentum(MOMENTS, Pi0, t)
    assert np.abs(traj.R - R_exact).max() < 1e-9
    assert np.abs(traj.Pi - Pi_exact).max() < 1e-9
    assert traj.meta["method"] == "solve_ivp:DOP853" and traj.iterations[0] == traj.meta["nfev"] > 100


def test_solve_ivp_backwards_retraces(body):
    fwd = solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=5.0, samples=2, method="DOP853",
                             rtol=1e-12, atol=1e-12)
    back = solve_ivp_baseline(body, fwd.R[-1] / np.linalg.norm(fwd.R[-1], 2), fwd.Pi[-1], t0=5.0, t_final=0.0,
                              samples=3, method="DOP853", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(back.t, [5.0, 2.5, 0.0])
    np.testing.assert_allclose(back.R[-1], np.eye(3), atol=1e-9)
    np.testing.assert_allclose(back.Pi[-1], body.J @ OMEGA0, atol=1e-9)


# ------------------------------------------------------------------------------------------------
# torques: callable, stand-in model, built-in models
# ------------------------------------------------------------------------------------------------
def test_rk4_callable_equals_standin_model_and_fills_potential(body):
    model = HeavyTopStandIn()
    R0 = Rotation.from_rotvec([0.4, -0.2, 0.1]).as_matrix()
    kw = dict(omega0=OMEGA0, h=0.01, steps=1000, save_every=10)
    with_model = rk4(body, R0, torque=model, **kw)
    with_call = rk4(body, R0, torque=lambda t, R, Pi: model.moment(t, R, Pi, body), **kw)
    free = rk4(body, R0, **kw)
    np.testing.assert_allclose(with_model.R, with_call.R, rtol=0, atol=1e-13)
    np.testing.assert_allclose(with_model.Pi, with_call.Pi, rtol=0, atol=1e-13)
    assert np.abs(with_model.Pi - free.Pi).max() > 0.1  # the torque does act
    assert with_model.meta["torque"] == "model" and with_call.meta["torque"] == "callable"
    assert with_call.potential is None
    expected_U = [model.potential(0.0, R / np.linalg.norm(R, 2), body) for R in with_model.R]
    np.testing.assert_allclose(with_model.potential, expected_U, rtol=1e-12, atol=1e-12)
    # energy is kinetic + potential: conserved to RK4 accuracy, while each part swings by O(1)
    assert np.ptp(with_model.kinetic_energy) > 0.1
    assert np.ptp(with_model.energy) < 1e-6 * np.ptp(with_model.kinetic_energy)


def test_non_conservative_standin_has_no_potential(body):
    model = DampingStandIn()
    kw = dict(omega0=OMEGA0, h=0.01, steps=500)
    a = rk4(body, np.eye(3), torque=model, **kw)
    b = rk4(body, np.eye(3), torque=lambda t, R, Pi: model.moment(t, R, Pi, body), **kw)
    np.testing.assert_array_equal(a.Pi, b.Pi)
    assert a.potential is None
    s = solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=5.0, samples=6, torque=model, method="DOP853",
                           rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(s.Pi[-1], a.Pi[-1], atol=1e-8)


def _builtin_models():
    torques = pytest.importorskip("lgvi.torques")
    Rd = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    return torques, [
        torques.UniformGravity(1.0, [0.0, 0.0, 0.3]),
        torques.UniformGravity(1.0, [0.05, 0.0, 0.3]) + torques.LinearDamping([0.01, 0.02, 0.03]),
        torques.GravityGradient(mu=1.0, radius=2.0),
        torques.AttitudePD(kp=2.0, kd=[1.0, 1.5, 2.0], R_target=Rd),
        torques.Constant([0.1, 0.2, -0.3]),
    ]


def test_rk4_builtin_models_compiled_equal_callable():
    torques, models = _builtin_models()
    body = lgvi.RigidBody([0.13, 0.28, 0.17])
    for model in models:
        kw = dict(omega0=[1.0, 2.0, 0.5], h=0.01, steps=300)
        fast = rk4(body, np.eye(3), torque=model, **kw)
        slow = rk4(body, np.eye(3), torque=lambda t, R, Pi: model.moment(t, R, Pi, body), **kw)
        assert fast.meta["torque_path"] == "compiled" and slow.meta["torque_path"] == "python", model
        scale = 1.0 + np.abs(slow.Pi).max()
        np.testing.assert_allclose(fast.R, slow.R, rtol=0, atol=1e-12, err_msg=repr(model))
        np.testing.assert_allclose(fast.Pi, slow.Pi, rtol=0, atol=1e-12 * scale, err_msg=repr(model))
        ivp = solve_ivp_baseline(body, np.eye(3), omega0=[1.0, 2.0, 0.5], t_final=3.0, samples=4, torque=model,
                                 method="DOP853", rtol=1e-12, atol=1e-12)
        assert ivp.meta["torque_path"] == "compiled"
        np.testing.assert_allclose(ivp.Pi[-1], fast.Pi[-1], rtol=0, atol=1e-6 * scale, err_msg=repr(model))


def test_uniform_gravity_potential_and_total_energy():
    torques, _ = _builtin_models()
    body = lgvi.RigidBody([0.13, 0.28, 0.17])
    model = torques.UniformGravity(1.0, [0.0, 0.0, 0.3])
    traj = rk4(body, np.eye(3), omega0=4.14 * np.ones(3), h=0.001, steps=2000, torque=model)
    Rn = traj.R / np.linalg.norm(traj.R, 2, axis=(1, 2))[:, None, None]
    np.testing.assert_allclose(traj.potential, model.potential(traj.t, Rn, body), rtol=1e-13, atol=1e-13)
    assert np.ptp(traj.potential) > 1.0
    assert np.ptp(traj.energy) < 1e-8 * abs(traj.energy[0])
    # the vertical spatial momentum e3 . R Pi is a first integral (RK4 keeps it to its accuracy)
    assert np.ptp(traj.spatial_momentum[:, 2]) < 1e-8


# ------------------------------------------------------------------------------------------------
# the drift the LGVI avoids (asserts on both sides)
# ------------------------------------------------------------------------------------------------
def test_rk4_energy_drifts_secularly_while_lgvi_does_not(body):
    steps, h = 100_000, 0.01
    lg = lgvi.simulate(body, np.eye(3), omega0=OMEGA0, h=h, steps=steps, save_every=10)
    rk = rk4(body, np.eye(3), omega0=OMEGA0, h=h, steps=steps, save_every=10)
    dE_lgvi = relative_drift(lg)[0]
    dE_rk4 = relative_drift(rk)[0]
    assert dE_lgvi < 1e-12
    assert dE_rk4 > 100 * dE_lgvi and dE_rk4 > 1e-11
    # secular: the mean energy error of the last tenth is many times that of the first tenth
    e = (rk.energy - rk.energy[0]) / rk.energy[0]
    tenth = len(e) // 10
    assert abs(e[-tenth:].mean()) > 5 * abs(e[:tenth].mean())
    # and RK4 leaves SO(3) (its quaternion is not renormalised), the LGVI does not
    assert rk.orthogonality_error.max() > 1e-11 > lg.orthogonality_error.max()


def test_rk45_loses_invariants_while_lgvi_keeps_them(body):
    steps, h = 100_000, 0.01
    lg = lgvi.simulate(body, np.eye(3), omega0=OMEGA0, h=h, steps=steps, save_every=100)
    rk = solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=steps * h, samples=steps // 100 + 1,
                            method="RK45", rtol=1e-6, atol=1e-9)
    for d in relative_drift(lg):
        assert d < 1e-12
    dE, dL, dPi = relative_drift(rk)
    assert dE > 1e-7 and dL > 1e-6 and dPi > 1e-7


def test_normalize_keeps_rk4_on_so3(body):
    kw = dict(omega0=OMEGA0, h=0.05, steps=20_000, save_every=100)
    raw = rk4(body, np.eye(3), **kw)
    unit = rk4(body, np.eye(3), normalize=True, **kw)
    assert raw.orthogonality_error.max() > 1e-8
    assert unit.orthogonality_error.max() < 1e-14
    assert unit.meta["normalize"] is True


# ------------------------------------------------------------------------------------------------
# bookkeeping and one-line comparisons
# ------------------------------------------------------------------------------------------------
def test_rk4_trajectory_fields_and_save_every(body):
    full = rk4(body, np.eye(3), omega0=OMEGA0, h=0.02, steps=60, t0=1.0)
    sub = rk4(body, np.eye(3), omega0=OMEGA0, h=0.02, steps=60, save_every=20, t0=1.0)
    assert full.R.shape == (61, 3, 3) and full.Pi.shape == (61, 3) and full.t.shape == (61,)
    assert full.iterations.dtype == np.int32 and full.iterations.shape == (60,) and not full.iterations.any()
    assert full.residual.shape == (60,) and not full.residual.any()
    assert full.h == 0.02 and full.meta["method"] == "rk4" and full.potential is None
    np.testing.assert_allclose(full.t, 1.0 + 0.02 * np.arange(61))
    np.testing.assert_array_equal(sub.R, full.R[::20])
    np.testing.assert_array_equal(sub.Pi, full.Pi[::20])
    np.testing.assert_allclose(sub.t, full.t[::20])
    zero = rk4(body, np.eye(3), omega0=OMEGA0, h=0.02, steps=0)
    assert len(zero) == 1 and zero.steps == 0


def test_compare_is_one_line(body):
    runs = compare(body, np.eye(3), omega0=OMEGA0, h=0.01, steps=400, save_every=4,
                   options={"rk45": {"rtol": 1e-8, "atol": 1e-11}, "dop853": {"rtol": 1e-12, "atol": 1e-12}})
    assert list(runs) == ["lgvi", "rk4", "rk45", "dop853"]
    for name, (traj, seconds) in runs.items():
        assert isinstance(traj, lgvi.Trajectory) and seconds > 0.0, name
        np.testing.assert_allclose(traj.t, runs["lgvi"][0].t, atol=1e-12, err_msg=name)
    assert runs["rk45"][0].meta["rtol"] == 1e-8
    # every method follows the same motion (lgvi is second order: 1e-4 at h = 0.01)
    ref = runs["dop853"][0]
    for name in ("lgvi", "rk4", "rk45"):
        assert np.abs(runs[name][0].Pi - ref.Pi).max() < 1e-3, name
    assert np.abs(runs["rk4"][0].Pi - ref.Pi).max() < 1e-8
    one = compare(body, np.eye(3), omega0=OMEGA0, h=0.01, steps=10, methods=["RK4"], warmup=False)
    assert list(one) == ["rk4"]


def test_compare_with_a_model_reports_total_energy():
    torques, _ = _builtin_models()
    body = lgvi.RigidBody([0.13, 0.28, 0.17])
    model = torques.UniformGravity(1.0, [0.0, 0.0, 0.3])
    runs = compare(body, np.eye(3), omega0=4.14 * np.ones(3), h=0.001, steps=200, torque=model,
                   methods=("lgvi", "rk4", "dop853"), options={"dop853": {"rtol": 1e-10, "atol": 1e-12}})
    for name, (traj, _) in runs.items():
        assert traj.potential is not None, name
        np.testing.assert_allclose(traj.energy[0], runs["rk4"][0].energy[0], rtol=1e-12, err_msg=name)
    assert np.ptp(runs["rk4"][0].energy) < 1e-9 * runs["rk4"][0].energy[0]


# ------------------------------------------------------------------------------------------------
# validation and errors
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, exc, name", [
    (dict(h=0.0, steps=10), ValueError, "h"),
    (dict(h=float("nan"), steps=10), ValueError, "h"),
    (dict(h=0.1, steps=-1), ValueError, "steps"),
    (dict(h=0.1, steps=2.5), TypeError, "steps"),
    (dict(h=0.1, steps=10, save_every=3), ValueError, "save_every"),
    (dict(h=0.1, steps=10, save_every=0), ValueError, "save_every"),
    (dict(h=0.1, steps=10, normalize="yes"), TypeError, "normalize"),
    (dict(h=0.1, steps=10, torque=np.zeros((10, 3))), TypeError, "torque"),
    (dict(h=0.1, steps=10, t0="0"), TypeError, "t0"),
])
def test_rk4_validation_names_the_argument(body, kwargs, exc, name):
    with pytest.raises(exc, match=rf"^{name}\b"):
        rk4(body, np.eye(3), omega0=OMEGA0, **kwargs)


def test_initial_state_validation(body):
    with pytest.raises(ValueError, match="R0"):
        rk4(body, 2 * np.eye(3), omega0=OMEGA0, h=0.1, steps=1)
    with pytest.raises(ValueError, match="Pi0"):
        rk4(body, np.eye(3), h=0.1, steps=1)
    with pytest.raises(ValueError, match="omega0"):
        rk4(body, np.eye(3), omega0=[1.0, 2.0], h=0.1, steps=1)
    with pytest.raises(ValueError, match="inertia"):
        rk4([1.0, 1.0, 5.0], np.eye(3), omega0=OMEGA0, h=0.1, steps=1)


def test_solve_ivp_and_compare_validation(body):
    with pytest.raises(ValueError, match="^t_final"):
        solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=0.0)
    with pytest.raises(ValueError, match="^samples"):
        solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=1.0, samples=1)
    with pytest.raises(ValueError, match="^rtol"):
        solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=1.0, rtol=-1e-6)
    with pytest.raises(ValueError, match="^method"):
        solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=1.0, method="RK99")
    with pytest.raises(ValueError, match="^methods"):
        compare(body, np.eye(3), omega0=OMEGA0, h=0.1, steps=10, methods=("lgvi", "euler"))
    with pytest.raises(ValueError, match="^methods"):
        compare(body, np.eye(3), omega0=OMEGA0, h=0.1, steps=10, methods=("rk4", "RK4"))
    with pytest.raises(ValueError, match="^options"):
        compare(body, np.eye(3), omega0=OMEGA0, h=0.1, steps=10, methods=("rk4",), options={"rk45": {}})


def test_torque_errors_name_step_and_keep_the_run(body):
    def bad(t, R, Pi):
        if t > 0.25:
            raise RuntimeError("sensor offline")
        return np.zeros(3)

    with pytest.raises(TorqueError, match="sensor offline") as info:
        rk4(body, np.eye(3), omega0=OMEGA0, h=0.1, steps=10, torque=bad)
    assert info.value.step == 2 and info.value.trajectory is not None
    assert len(info.value.trajectory) == 3 and info.value.trajectory.meta["partial"]
    with pytest.raises(TorqueError, match=r"shape \(3,\)"):
        rk4(body, np.eye(3), omega0=OMEGA0, h=0.1, steps=10, torque=lambda t, R, Pi: np.zeros(2))
    with pytest.raises(TorqueError, match="finite"):
        solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=1.0,
                           torque=lambda t, R, Pi: np.array([np.nan, 0.0, 0.0]))


@pytest.mark.parametrize("path", ["compiled", "python"])
def test_rk4_runs_on_the_driver_in_chunks_and_ctrl_c_keeps_the_part(body, monkeypatch, path):
    """``rk4`` runs in chunks of lgvi.driver: the chunked run is the one-chunk run bit for bit, progress
    is reported between chunks, and a Ctrl-C in the middle keeps the part computed."""
    import signal

    def nudge(t, R, Pi):
        return np.array([0.01 * np.sin(t), -0.02 * R[0, 1], 0.003 * Pi[2]])

    kw = dict(omega0=OMEGA0, h=0.05, steps=64, save_every=2, torque=None if path == "compiled" else nudge)
    whole = rk4(body, np.eye(3), **kw)
    assert whole.meta["torque_path"] == path
    monkeypatch.setattr(baselines, "CHUNK_STEPS", 8)
    monkeypatch.setattr(baselines, "CALLABLE_CHUNK_STEPS", 8)
    seen = []
    parts = rk4(body, np.eye(3), progress=lambda k, n: seen.append(k), **kw)
    assert seen == list(range(8, 65, 8))
    for key in ("t", "R", "Pi"):
        assert np.array_equal(getattr(parts, key), getattr(whole, key))

    def stop(k, n):
        if k == 16:
            signal.raise_signal(signal.SIGINT)   # delivered to this (the main) thread before it returns

    with pytest.raises(lgvi.SimulationInterrupted, match="rk4 interrupted after 16 of 64 steps") as info:
        rk4(body, np.eye(3), progress=stop, **kw)
    part = info.value.trajectory
    assert part.meta["partial"] is True and part.meta["solver_summary"]["steps"] == 16 and len(part.t) == 9
    for key in ("t", "R", "Pi"):
        assert np.array_equal(getattr(part, key), getattr(whole, key)[:9])


@pytest.mark.parametrize("path", ["compiled", "python"])
@pytest.mark.parametrize("save_every, normalize", [(1, False), (2, True)])
def test_rk4_overflow_raises_with_the_step_and_keeps_the_finite_part(body, path, save_every, normalize):
    """A torque that blows the state up stops the run as lgvi.simulate does (a ConvergenceError
    naming the step and time, the finite run up to that step attached), never a NaN trajectory."""
    u = np.array([1e6, 2e6, 0.0])
    torque = lgvi.torques.Constant(u) if path == "compiled" else (lambda t, R, Pi: u.copy())
    kw = dict(omega0=OMEGA0, h=0.01, torque=torque, save_every=save_every, normalize=normalize)
    with np.errstate(over="ignore", invalid="ignore"):
        with pytest.raises(lgvi.ConvergenceError, match=r"rk4 step \d+ \(t = .*\) failed: .*non-finite") as info:
            rk4(body, np.eye(3), steps=1000, **kw)
    err = info.value
    assert 0 < err.step < 1000 and f"step {err.step} " in str(err) and err.time == pytest.approx(0.01 * err.step)
    part = err.trajectory
    assert part.meta["partial"] is True and part.meta["torque_path"] == path
    assert len(part.t) == err.step // save_every + 1 and np.isfinite(part.Pi).all() and np.isfinite(part.R).all()
    done = err.step // save_every * save_every      # the same run stopped at the last saved sample
    whole = rk4(body, np.eye(3), steps=done, **kw)
    for key in ("t", "R", "Pi"):
        assert np.array_equal(getattr(part, key), getattr(whole, key))
    with np.errstate(over="ignore", invalid="ignore"):   # the brief's example: a moment of 1e308
        with pytest.raises(lgvi.ConvergenceError, match=r"rk4 step 0 \(t = 0\)") as info:
            rk4(body, np.eye(3), steps=10, omega0=OMEGA0, h=0.01,
                torque=(lambda t, R, Pi: np.full(3, 1e308)) if path == "python" else lgvi.torques.Constant([1e308] * 3))
    assert info.value.step == 0 and len(info.value.trajectory.t) == 1
