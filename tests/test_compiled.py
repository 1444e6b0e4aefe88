"""Torque models the user compiles (lgvi.torques.Compiled): the user's numba.njit moment and
potential run inside the compiled loops and give the built-in models' numbers."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import lgvi
from lgvi.errors import ConvergenceError
from lgvi.torques import Compiled, LinearDamping, TorqueModel, UniformGravity

J = np.array([[0.9, 0.05, -0.1], [0.05, 1.3, 0.08], [-0.1, 0.08, 1.7]])
R0 = lgvi.so3.exp([0.3, -0.8, 0.5])
OMEGA0 = np.array([1.1, -0.7, 2.3])
GRAVITY = UniformGravity(1.3, [0.05, -0.1, 0.3])


@numba.njit
def gravity_moment(t, R, Pi, p):
    # (R^T e3) x p with p = mass g com, in the built-in kernel's order of operations
    s0 = R[2, 0]
    s1 = R[2, 1]
    s2 = R[2, 2]
    return (s1 * p[2] - s2 * p[1], s2 * p[0] - s0 * p[2], s0 * p[1] - s1 * p[0])


@numba.njit
def gravity_potential(t, R, p):
    return R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2]


@numba.njit
def damping_moment(t, R, Pi, p):
    # -c J^-1 Pi as an array, p = (c (3), J^-1 row-major (9))
    out = np.empty(3)
    for i in range(3):
        w = p[3 + 3 * i] * Pi[0] + p[4 + 3 * i] * Pi[1] + p[5 + 3 * i] * Pi[2]
        out[i] = -(p[i] * w)
    return out


def user_gravity(params=None):
    p = GRAVITY.mass * GRAVITY.g * GRAVITY.com if params is None else params
    return Compiled(gravity_moment, potential=gravity_potential, params=p)


def run(torque, **kw):
    kw = {"h": 0.02, "steps": 300, **kw}
    return lgvi.simulate(lgvi.RigidBody(J), R0, omega0=OMEGA0, torque=torque, **kw)


@pytest.mark.parametrize("forcing, order", [("paper", 2), ("symmetric", 2), ("paper", 4), ("symmetric", 4),
                                            ("symmetric", 6)])
def test_user_gravity_equals_builtin_bit_for_bit(forcing, order):
    a = run(GRAVITY, forcing=forcing, order=order)
    b = run(user_gravity(), forcing=forcing, order=order)
    assert np.array_equal(a.R, b.R)
    assert np.array_equal(a.Pi, b.Pi)
    assert np.array_equal(a.iterations, b.iterations)
    assert b.meta["forcing"] == "symmetric"          # a potential takes the variational step


def test_energy_includes_the_user_potential():
    b = run(user_gravity(), steps=2000)
    assert b.potential is not None
    U = np.array([gravity_potential(0.0, R, GRAVITY.mass * GRAVITY.g * GRAVITY.com) for R in b.R])
    np.testing.assert_array_equal(b.potential, U)
    kinetic = 0.5 * np.einsum("mi,mi->m", b.Pi, np.linalg.solve(J, b.Pi.T).T)
    np.testing.assert_allclose(b.energy, kinetic + U, rtol=1e-14, atol=1e-14)
    # the built-in potential is the same function summed in another order: round-off apart
    a = run(GRAVITY, steps=2000)
    np.testing.assert_allclose(b.energy, a.energy, rtol=0, atol=1e-13 * np.abs(a.energy).max())
    # and the variational step keeps it bounded (the energy varies a lot without the potential)
    assert np.ptp(b.energy) < 1e-2 * np.ptp(U)


def test_momentum_dependent_damping_paper_equals_builtin_bit_for_bit():
    c = np.array([0.1, 0.2, 0.3])
    body = lgvi.RigidBody(J)
    user = Compiled(damping_moment, params=np.concatenate([c, body.J_inv.ravel()]), momentum_dependent=True)
    a = run(LinearDamping(c), forcing="paper")
    b = run(user, forcing="paper")
    assert np.array_equal(a.R, b.R)
    assert np.array_equal(a.Pi, b.Pi)


@pytest.mark.parametrize("order", [2, 4])
def test_momentum_dependent_damping_symmetric_to_the_tolerance(order):
    c = np.array([0.1, 0.2, 0.3])
    body = lgvi.RigidBody(J)
    user = Compiled(damping_moment, params=np.concatenate([c, body.J_inv.ravel()]), momentum_dependent=True)
    a = run(LinearDamping(c), forcing="symmetric", order=order)
    b = run(user, forcing="symmetric", order=order)
    # built-in: the linear momentum equation solved exactly; user: fixed-point iteration to tol=1e-14
    np.testing.assert_allclose(b.Pi, a.Pi, rtol=0, atol=1e-12 * np.abs(a.Pi).max())
    np.testing.assert_allclose(b.R, a.R, rtol=0, atol=1e-12)
    assert np.linalg.norm(b.Pi[-1]) < 0.9 * np.linalg.norm(b.Pi[0])      # it does damp


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("forcing, order", [("paper", 2), ("symmetric", 4)])
def test_ensemble_per_body_params_equal_single_runs(forcing, order, threads):
    base = GRAVITY.mass * GRAVITY.g * GRAVITY.com
    rows = np.array([base, 0.5 * base, [0.2, -0.4, 1.0]])
    R0s = np.stack([R0, lgvi.so3.exp([0.1, 0.2, 0.3]), np.eye(3)])
    w0 = np.stack([OMEGA0, -OMEGA0, [0.3, 0.2, 0.1]])
    kw = {"h": 0.02, "steps": 300, "save_every": 3, "forcing": forcing, "order": order}
    e = lgvi.simulate_ensemble(lgvi.RigidBody(J), R0s, omega0=w0, torque=user_gravity(rows), threads=threads, **kw)
    for b in range(3):
        s = lgvi.simulate(lgvi.RigidBody(J), R0s[b], omega0=w0[b], torque=user_gravity(rows[b]), **kw)
        assert np.array_equal(e.R[b], s.R)
        assert np.array_equal(e.Pi[b], s.Pi)
        assert np.array_equal(e.potential[b], s.potential)


def test_non_finite_moment_stops_with_the_partial_trajectory():
    @numba.njit
    def blows_up(t, R, Pi, p):
        return (np.inf if t > 1.0 else 0.0, 0.0, 0.0)

    with pytest.raises(ConvergenceError) as info:
        run(Compiled(blows_up))
    traj = info.value.trajectory
    assert traj is not None and 0 < len(traj.t) < 301 and np.all(np.isfinite(traj.Pi))


def test_bad_inputs_raise_clearly():
    def plain(t, R, Pi, p):
        return (0.0, 0.0, 0.0)

    with pytest.raises(TypeError, match="numba.njit"):
        Compiled(plain)
    with pytest.raises(TypeError, match="numba.njit"):
        Compiled(gravity_moment, potential=lambda t, R, p: 0.0)
    with pytest.raises(ValueError, match=r"shape \(P,\) or \(B, P\)"):
        Compiled(gravity_moment, params=np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match="finite"):
        Compiled(gravity_moment, params=[1.0, np.nan, 0.0])

    @numba.njit
    def two(t, R, Pi, p):
        return np.zeros(2)

    with pytest.raises(ValueError, match="two.*3 finite numbers"):
        Compiled(two)
    @numba.njit
    def three_args(t, R, Pi):
        return (0.0, 0.0, 0.0)

    with pytest.raises(TypeError, match="trial call three_args"):
        Compiled(three_args)
    with pytest.raises(ValueError, match="momentum_dependent"):
        Compiled(gravity_moment, potential=gravity_potential, params=np.ones(3), momentum_dependent=True)
    rows = np.ones((2, 3))
    with pytest.raises(ValueError, match="simulate_ensemble"):
        run(user_gravity(rows))
    with pytest.raises(ValueError, match="one row per body"):
        lgvi.simulate_ensemble(lgvi.RigidBody(J), np.stack([np.eye(3)] * 3), omega0=np.ones((3, 3)), h=0.01,
                               steps=10, torque=user_gravity(rows))
    with pytest.raises(TypeError, match="cannot be added"):
        user_gravity() + GRAVITY


def test_torque_model_subclass_without_methods_says_what_to_implement():
    class Half(TorqueModel):
        pass

    with pytest.raises(NotImplementedError, match=r"does not implement _terms\(\)"):
        run(Half(), steps=5)
    with pytest.raises(NotImplementedError, match=r"does not implement moment\(t, R, Pi, body\)"):
        Half().moment(0.0, np.eye(3), np.zeros(3), J)


def test_ensemble_blocks_keep_each_body_its_row(tmp_path):
    base = GRAVITY.mass * GRAVITY.g * GRAVITY.com
    rows = np.array([base, 0.5 * base, [0.2, -0.4, 1.0]])
    kw = {"h": 0.02, "steps": 60, "save_every": 3}
    lgvi.simulate_ensemble(lgvi.RigidBody(J), np.stack([R0] * 3), omega0=np.stack([OMEGA0] * 3),
                           torque=user_gravity(rows), out_dir=tmp_path / "ens", block_size=1, **kw)
    e = lgvi.load_ensemble(tmp_path / "ens")
    for b in range(3):
        s = lgvi.simulate(lgvi.RigidBody(J), R0, omega0=OMEGA0, torque=user_gravity(rows[b]), **kw)
        assert np.array_equal(np.asarray(e.R[b]), s.R)
        assert np.array_equal(np.asarray(e.potential[b]), s.potential)
    # the per-body rows are recorded with the ensemble (issue 11 part 6), through the block files
    np.testing.assert_array_equal(e.model_params["params"], rows)
    assert list(e.dispersions) == ["params"] and e[2].meta["model_params"]["params"] == rows[2].tolist()


@pytest.mark.parametrize("threads", [1, 2])
def test_ensemble_threads_keep_each_body_its_row(threads):
    # more bodies than threads, split into groups of 3 and 2: members equal the single runs
    base = GRAVITY.mass * GRAVITY.g * GRAVITY.com
    rng = np.random.default_rng(3)
    B = 5
    rows = base * (1.0 + 0.3 * rng.normal(size=(B, 3)))
    R0s = lgvi.so3.exp(0.5 * rng.normal(size=(B, 3)))
    w0 = OMEGA0 * (1.0 + 0.2 * rng.normal(size=(B, 3)))
    kw = {"h": 0.02, "steps": 200, "save_every": 2, "forcing": "symmetric", "order": 4}
    e = lgvi.simulate_ensemble(lgvi.RigidBody(J), R0s, omega0=w0, torque=user_gravity(rows), threads=threads, **kw)
    for b in range(B):
        s = lgvi.simulate(lgvi.RigidBody(J), R0s[b], omega0=w0[b], torque=user_gravity(rows[b]), **kw)
        assert np.array_equal(e.R[b], s.R)
        assert np.array_equal(e.Pi[b], s.Pi)
        assert np.array_equal(e.potential[b], s.potential)


@numba.njit
def blows_up_late(t, R, Pi, p):
    # a body whose row has p[0] > 0 gets a non-finite moment from t = p[0] on
    return (np.inf if p[0] > 0.0 and t >= p[0] else 0.0, 0.0, 0.0)


def test_ensemble_threads_report_the_first_failed_body():
    # bodies 1 and 3 fail (at t = 1.5 and 1.0), in different threads: the error names body 3 and
    # the partial ensemble holds every body up to its step
    rows = np.array([[0.0], [1.5], [0.0], [1.0], [0.0]])
    R0s = np.stack([R0] * 5)
    w0 = np.stack([OMEGA0] * 5)
    with pytest.raises(ConvergenceError) as info:
        lgvi.simulate_ensemble(lgvi.RigidBody(J), R0s, omega0=w0, h=0.02, steps=200, threads=2,
                               torque=Compiled(blows_up_late, params=rows))
    err = info.value
    with pytest.raises(ConvergenceError) as single:
        lgvi.simulate(lgvi.RigidBody(J), R0, omega0=OMEGA0, h=0.02, steps=200, torque=Compiled(blows_up_late,
                                                                                            params=rows[3]))
    assert err.body == 3 and err.step == single.value.step and 0 < err.step < 200
    e = err.trajectory
    s = lgvi.simulate(lgvi.RigidBody(J), R0, omega0=OMEGA0, h=0.02, steps=200, torque=Compiled(blows_up_late,
                                                                                            params=rows[0]))
    m = e.R.shape[1]
    assert m == err.step + 1 and np.array_equal(e.R[4], s.R[:m]) and np.all(np.isfinite(e.Pi))


@pytest.mark.parametrize("threads", [None, 2])
def test_momentum_equation_that_does_not_converge_stops_the_run(threads):
    # Pi = b - hs/2 c Pi by fixed-point iteration diverges when hs c / 2 > 1 (here 3 from t = 0.5 on):
    # the run stops with the partial trajectory, each saved state finite
    @numba.njit
    def late_stiff(t, R, Pi, p):
        c = p[0] if t > 0.5 else 0.1
        return (-c * Pi[0], -c * Pi[1], -c * Pi[2])

    model = Compiled(late_stiff, params=[300.0], momentum_dependent=True)
    with pytest.raises(ConvergenceError, match="did not reach the tolerance") as info:
        if threads is None:
            run(model, forcing="symmetric")
        else:
            lgvi.simulate_ensemble(lgvi.RigidBody(J), np.stack([R0] * 3), omega0=np.stack([OMEGA0] * 3), h=0.02,
                                   steps=300, forcing="symmetric", threads=threads,
                                   torque=Compiled(late_stiff, params=[[300.0], [300.0], [300.0]],
                                                   momentum_dependent=True))
    assert info.value.step == 25
    traj = info.value.trajectory
    assert np.all(np.isfinite(traj.Pi)) and np.all(np.isfinite(traj.R))
