"""The public API of DESIGN.md by name and shape, its conveniences, and every public error path.

Names, shapes and keyword-only options are a contract (tests outside the project call them), so
they are checked literally. Errors must name the argument and the rule; failures during a run
carry where they happened and the part of the run computed before.
"""

from __future__ import annotations

import inspect
import json
import warnings
import zipfile

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi import so3

OMEGA0 = np.array([0.3, 1.0, 0.2])
H = 0.01


def assert_same_run(a: lgvi.Trajectory, b: lgvi.Trajectory) -> None:
    """Bit-for-bit identical states and solver records."""
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.R, b.R)
    assert np.array_equal(a.Pi, b.Pi)
    assert np.array_equal(a.iterations, b.iterations)
    assert np.array_equal(a.residual, b.residual)


# --------------------------------------------------------------------------------------------
# names and signatures
# --------------------------------------------------------------------------------------------
def test_public_names():
    for name in ("RigidBody", "simulate", "step", "Trajectory", "load", "solve_implicit",
                 "ImplicitSolution", "ConvergenceError", "TorqueError", "so3"):
        assert hasattr(lgvi, name), name
        assert name in lgvi.__all__, name
    for name in lgvi.__all__:
        assert hasattr(lgvi, name), name
    for name in ("hat", "vee", "exp", "log", "project"):
        assert callable(getattr(lgvi.so3, name)), name
    assert issubclass(lgvi.ConvergenceError, Exception)
    assert isinstance(lgvi.__version__, str) and lgvi.__version__


def test_so3_vectorised_over_leading_axes():
    w = np.random.default_rng(0).standard_normal((4, 5, 3))
    R = so3.exp(w)
    assert R.shape == (4, 5, 3, 3)
    assert so3.hat(w).shape == (4, 5, 3, 3)
    assert np.allclose(so3.vee(so3.hat(w)), w, rtol=0, atol=0)
    assert so3.log(R).shape == (4, 5, 3)


def test_simulate_signature():
    sig = inspect.signature(lgvi.simulate)
    params = sig.parameters
    assert list(params)[:3] == ["body", "R0", "Pi0"]
    assert params["body"].kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
    assert params["R0"].kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
    assert params["Pi0"].default is None
    expected = {"omega0": None, "h": inspect.Parameter.empty, "steps": None, "duration": None,
                "torque": None, "method": "newton", "tol": 1e-14, "max_iter": 50, "alpha": 1.0,
                "save_every": 1}     # exactly one of steps and duration (tests/test_conventions.py)
    for name, default in expected.items():
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY, name
        assert params[name].default == default or (default is inspect.Parameter.empty
                                                    and params[name].default is default), name


def test_simulate_options_are_keyword_only(diag_body):
    with pytest.raises(TypeError):
        lgvi.simulate(diag_body, np.eye(3), [0.1, 0.2, 0.3], 0.01, 10)  # h, steps positional


def test_solve_implicit_signature():
    params = inspect.signature(lgvi.solve_implicit).parameters
    assert list(params)[:2] == ["Jd", "hPi"]
    for name, default in {"method": "newton", "tol": 1e-14, "max_iter": 50, "alpha": 1.0}.items():
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY, name
        assert params[name].default == default, name


def test_implicit_solution_fields(diag_body):
    sol = lgvi.solve_implicit(diag_body.Jd, [0.01, 0.02, 0.03])
    assert sol.F.shape == (3, 3)
    assert isinstance(sol.iterations, int) and sol.iterations >= 1
    assert isinstance(sol.residual, float)
    assert sol.converged is True
    with pytest.raises(AttributeError):
        sol.F = np.eye(3)  # frozen


# --------------------------------------------------------------------------------------------
# RigidBody
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("inertia", [[1.0, 2.0, 3.0], np.diag([1.0, 2.0, 3.0]), "full"])
def test_rigid_body_attributes(inertia, full_body):
    body = full_body if isinstance(inertia, str) else lgvi.RigidBody(inertia)
    for name in ("J", "Jd", "J_inv"):
        arr = getattr(body, name)
        assert arr.shape == (3, 3) and arr.dtype == np.float64, name
        assert not arr.flags.writeable, name
    assert np.allclose(body.Jd, 0.5 * np.trace(body.J) * np.eye(3) - body.J, rtol=0, atol=1e-15)
    assert np.allclose(body.J_inv @ body.J, np.eye(3), rtol=0, atol=1e-14)
    assert np.array_equal(body.J, body.J.T)


def test_rigid_body_rejects_bad_inertia():
    with pytest.raises(ValueError, match="positive definite"):
        lgvi.RigidBody([1.0, -2.0, 3.0])
    with pytest.raises(ValueError, match="triangle inequality"):
        lgvi.RigidBody([1.0, 1.0, 5.0])
    with pytest.raises(ValueError, match="shape"):
        lgvi.RigidBody([1.0, 2.0])


def test_simulate_accepts_inertia_instead_of_body(diag_body, R0):
    a = lgvi.simulate(diag_body, R0, omega0=OMEGA0, h=H, steps=20)
    b = lgvi.simulate([1.0, 2.0, 3.0], R0, omega0=OMEGA0, h=H, steps=20)
    assert_same_run(a, b)


# --------------------------------------------------------------------------------------------
# Trajectory
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def run12(full_body):
    R0 = so3.exp([0.1, -0.2, 0.3])
    full = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=12)
    sub = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=12, save_every=3)
    return full, sub


def test_trajectory_shapes(run12):
    full, sub = run12
    for traj, M in ((full, 13), (sub, 5)):  # M = steps // save_every + 1
        # the solver's record: per step with save_every = 1, per saved interval (M - 1,) by default
        n_rec = 12 if traj is full else M - 1
        assert traj.t.shape == (M,)
        assert traj.R.shape == (M, 3, 3)
        assert traj.Pi.shape == (M, 3)
        assert traj.omega.shape == (M, 3)
        assert traj.energy.shape == (M,)
        assert traj.spatial_momentum.shape == (M, 3)
        assert traj.quaternion.shape == (M, 4)
        assert isinstance(traj.rotation, Rotation) and len(traj.rotation) == M
        assert traj.iterations.shape == (n_rec,) and np.issubdtype(traj.iterations.dtype, np.integer)
        assert traj.residual.shape == (n_rec,) and traj.residual.dtype == np.float64
        assert traj.steps == 12 and traj.meta["solver_record"] == "interval"
        for name in ("t", "R", "Pi"):
            assert getattr(traj, name).dtype == np.float64
        assert len(traj) == M


def test_trajectory_derived_values(run12, full_body):
    full, _ = run12
    assert np.allclose(full.omega, full.Pi @ full_body.J_inv.T, rtol=1e-14, atol=0)
    assert np.allclose(full.energy, 0.5 * np.einsum("mi,mi->m", full.Pi, full.omega), rtol=1e-15, atol=0)
    assert np.allclose(full.spatial_momentum, np.einsum("mij,mj->mi", full.R, full.Pi), rtol=0, atol=1e-15)
    assert np.allclose(full.t, H * np.arange(13), rtol=0, atol=1e-15)
    assert np.allclose(full.rotation.as_matrix(), full.R, rtol=0, atol=1e-15)
    assert np.all(full.iterations >= 1)
    assert np.all(full.residual <= 1e-14 * H * np.linalg.norm(full.Pi[:-1], axis=1) + 1e-15)


def test_trajectory_is_immutable(run12):
    full, _ = run12
    with pytest.raises(ValueError):
        full.R[0, 0, 0] = 2.0
    with pytest.raises(AttributeError):
        full.h = 1.0


def test_save_every_keeps_every_nth_state(run12):
    full, sub = run12
    assert np.array_equal(sub.R, full.R[::3])
    assert np.array_equal(sub.Pi, full.Pi[::3])
    assert np.array_equal(sub.t, full.t[::3])
    # the record per saved interval: the largest of the 3 steps of each; the totals of every step
    assert np.array_equal(sub.iterations, full.iterations.reshape(4, 3).max(axis=1))
    assert np.array_equal(sub.residual, full.residual.reshape(4, 3).max(axis=1))
    for key in ("steps", "iterations_total", "iterations_max", "residual_max"):
        assert sub.solver_summary[key] == full.solver_summary[key]
    assert np.array_equal(sub.solver_summary["histogram"], full.solver_summary["histogram"])
    assert full.solver_summary["iterations_total"] == full.iterations.sum()


def test_save_load_round_trip(run12, tmp_path):
    _, traj = run12
    path = tmp_path / "run.npz"
    traj.save(path)
    back = lgvi.load(path)
    assert isinstance(back, lgvi.Trajectory)
    assert_same_run(traj, back)
    assert np.array_equal(back.inertia, traj.inertia)
    assert back.h == traj.h
    assert back.meta == traj.meta
    assert back.meta["method"] == "newton"
    assert back.meta["tol"] == 1e-14
    assert back.meta["lgvi_version"] == lgvi.__version__
    assert back.meta["save_every"] == 3
    assert np.array_equal(back.quaternion, traj.quaternion)
    assert np.array_equal(back.energy, traj.energy)
    for name in ("t", "R", "Pi", "inertia", "iterations", "residual"):
        assert getattr(back, name).dtype == getattr(traj, name).dtype, name
    # str paths work too, and the metadata survives a second round trip unchanged
    back.save(str(tmp_path / "again.npz"))
    assert lgvi.load(str(tmp_path / "again.npz")).meta == traj.meta


def test_quaternion_convention_and_continuity(diag_body):
    """Spinning at 2 rad/s for 10 s crosses angle pi several times, where scipy's canonical
    quaternion (w >= 0) flips sign: the trajectory's must not."""
    traj = lgvi.simulate(diag_body, np.eye(3), omega0=[0.1, 0.2, 2.0], h=0.05, steps=200)
    q = traj.quaternion
    q_scipy = Rotation.from_matrix(np.array(traj.R)).as_quat()  # scalar-last (SciPy < 1.16 wants writable)
    assert np.any(np.einsum("ij,ij->i", q_scipy[1:], q_scipy[:-1]) < 0)  # scipy's does flip
    same = np.all(np.isclose(q, q_scipy, rtol=0, atol=1e-14), axis=1)
    opposite = np.all(np.isclose(q, -q_scipy, rtol=0, atol=1e-14), axis=1)
    assert np.all(same | opposite)
    assert np.all(np.einsum("ij,ij->i", q[1:], q[:-1]) > 0)
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, rtol=0, atol=1e-15)
    # scalar-last: q = (sin(a/2) n, cos(a/2)); the first step turns by a small angle about ~z
    assert abs(q[0, 3]) == pytest.approx(1.0, abs=1e-15)
    assert np.allclose(Rotation.from_quat(q).as_matrix(), traj.R, rtol=0, atol=1e-14)
    q_first = traj.quaternions(scalar_first=True)
    assert np.array_equal(q_first, q[:, [3, 0, 1, 2]])


# --------------------------------------------------------------------------------------------
# input conveniences
# --------------------------------------------------------------------------------------------
def test_R0_as_scipy_rotation(full_body):
    rot = Rotation.from_rotvec([0.4, -0.1, 0.9])
    a = lgvi.simulate(full_body, rot, omega0=OMEGA0, h=H, steps=30)
    b = lgvi.simulate(full_body, rot.as_matrix(), omega0=OMEGA0, h=H, steps=30)
    assert_same_run(a, b)


def test_omega0_instead_of_Pi0(full_body, R0):
    a = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=30)
    b = lgvi.simulate(full_body, R0, full_body.J @ OMEGA0, h=H, steps=30)
    assert_same_run(a, b)
    assert np.allclose(a.omega[0], OMEGA0, rtol=1e-15, atol=1e-15)


def test_inputs_not_mutated(full_body):
    R0 = so3.exp([0.1, 0.2, 0.3])
    Pi0 = full_body.J @ OMEGA0
    U = np.full((10, 3), 0.1)
    copies = R0.copy(), Pi0.copy(), U.copy()
    lgvi.simulate(full_body, R0, Pi0, h=H, steps=10, torque=U)
    assert np.array_equal(R0, copies[0]) and np.array_equal(Pi0, copies[1]) and np.array_equal(U, copies[2])


def u_of_t(t):
    return np.array([0.1 * np.cos(t), 0.2 * np.sin(2.0 * t), -0.05])


def test_torque_callable_sees_the_current_state(full_body, R0):
    calls = []

    def torque(t, R, Pi):
        calls.append((t, np.array(R), np.array(Pi)))
        return u_of_t(t)

    traj = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=25, torque=torque, t0=0.5)
    assert len(calls) == 25
    for k, (t, R, Pi) in enumerate(calls):
        assert t == traj.t[k]
        assert np.array_equal(R, traj.R[k])
        assert np.array_equal(Pi, traj.Pi[k])
    assert traj.meta["torque"] == "callable"


def test_torque_callable_equals_torque_array(full_body, R0):
    """The same u_k through the callable path and the compiled array path: identical bits."""
    steps = 40
    U = np.array([u_of_t(H * k) for k in range(steps)])
    a = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=steps, torque=lambda t, R, Pi: u_of_t(t))
    b = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=steps, torque=U)
    assert_same_run(a, b)
    const = np.array([0.05, -0.1, 0.2])
    c = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=steps, torque=lambda t, R, Pi: const)
    d = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=steps, torque=np.tile(const, (steps, 1)))
    assert_same_run(c, d)
    # and a torque changes the motion (not silently ignored)
    free = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=steps)
    assert np.max(np.abs(free.Pi[-1] - d.Pi[-1])) > 1e-3


def test_torque_callable_cannot_corrupt_state(full_body, R0):
    """The callable gets copies: writing into R and Pi does not change the run."""
    def vandal(t, R, Pi):
        R[:] = 0.0
        Pi[:] = 1e6
        return [0.0, 0.0, 0.0]

    a = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=10, torque=vandal)
    b = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=10)
    assert_same_run(a, b)


@pytest.mark.parametrize("method", ["paper", "newton", "cayley"])
@pytest.mark.parametrize("u", [None, [0.3, -0.2, 0.1]])
def test_step_equals_one_simulated_step(method, u, full_body, R0):
    Pi0 = full_body.J @ OMEGA0
    s = lgvi.step(full_body, R0, Pi0, h=H, u=u, method=method)
    traj = lgvi.simulate(full_body, R0, Pi0, h=H, steps=1, method=method,
                         torque=None if u is None else np.array([u]))
    assert np.array_equal(s.R, traj.R[1])
    assert np.array_equal(s.Pi, traj.Pi[1])
    assert s.iterations == traj.iterations[0]
    assert s.residual == traj.residual[0]
    assert np.allclose(s.F, R0.T @ s.R, rtol=0, atol=1e-15)


def test_steps_zero(full_body, R0):
    traj = lgvi.simulate(full_body, R0, omega0=OMEGA0, h=H, steps=0)
    assert traj.R.shape == (1, 3, 3) and traj.iterations.shape == (0,)
    assert np.array_equal(traj.R[0], R0)


# --------------------------------------------------------------------------------------------
# error paths of simulate
# --------------------------------------------------------------------------------------------
def sim(body, **overrides):
    kwargs = dict(R0=np.eye(3), Pi0=[0.3, 2.0, 0.6], h=H, steps=10)
    kwargs.update(overrides)
    R0 = kwargs.pop("R0")
    return lgvi.simulate(body, R0, **kwargs)


def test_initial_matrix_slightly_off_so3_is_replaced_by_its_nearest_rotation():
    """1e-9 < ||R^T R - I||_F <= 1e-6 (a rotation with 7 digits): the run starts from
    ``so3.project(R0)`` with an AttitudeWarning; a rotation to round-off is used bit for bit,
    silently; beyond 1e-6 the error says what to do."""
    R = so3.exp([0.3, -0.2, 0.1])
    rounded = np.round(R, 7)
    assert 1e-9 < so3.orthogonality_error(rounded) <= 1e-6
    kw = dict(Pi0=[0.3, 2.0, 0.6], h=0.01, steps=20)
    with pytest.warns(lgvi.errors.AttitudeWarning, match=r"R0 is [0-9.e-]+ away from a rotation .*accepted up to "
                      r"1e-06.*using the nearest rotation"):
        traj = lgvi.simulate([1.0, 2.0, 3.0], rounded, **kw)
    assert np.array_equal(traj.R, lgvi.simulate([1.0, 2.0, 3.0], so3.project(rounded), **kw).R)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.array_equal(lgvi.simulate([1.0, 2.0, 3.0], R, **kw).R[0], R)
        assert np.array_equal(lgvi.simulate([1.0, 2.0, 3.0], R + 1e-12, **kw).R[0], R + 1e-12)
    with pytest.raises(ValueError, match=r"R0 must be a rotation matrix \(orthogonal to 1e-06, determinant \+1\); "
                       r"got orthogonality error \|R\^T R - I\| = 2e-05 > 1e-06\. Use lgvi\.so3\.project\(R0\)"):
        lgvi.simulate([1.0, 2.0, 3.0], R @ np.diag([1.0, 1.0, 1.0 + 1e-5]), **kw)
    # ensembles alike, per attitude
    from lgvi.ensemble import _rotations

    with pytest.warns(lgvi.errors.AttitudeWarning, match=r"R0\[1\] is [0-9.e-]+ away .*\(1 of 2 attitudes\)"):
        both = _rotations(np.stack([R, rounded]))
    assert np.array_equal(both[0], R) and np.array_equal(both[1], so3.project(rounded))


def test_quick_rotation_check_accepts_only_what_the_full_check_uses_as_is():
    """The plain-float check that skips the NumPy one (issue 13, call overhead) accepts only
    matrices orthogonal to tol / 2 with det +1, so every matrix it passes is one the full check
    uses unchanged; near the thresholds the decision of ``nearest_rotation`` is the full check's."""
    from lgvi._validation import ROTATION_TOL, _surely_rotation, nearest_rotation

    rng = np.random.default_rng(13)
    tol = ROTATION_TOL
    accepted = rejected = 0
    for i in range(400):
        R = so3.exp(rng.normal(size=3))
        S = rng.normal(size=(3, 3))
        if i % 2:
            S = np.triu(S, 1) + np.triu(S, 1).T       # off-diagonal defects only
        S *= rng.uniform(0.02, 1.5) * tol / np.linalg.norm(S)
        A = R @ (np.eye(3) + S) if i % 3 else -(R @ (np.eye(3) + S))  # and reflections
        err = np.linalg.norm(A.T @ A - np.eye(3))
        det = np.linalg.det(A)
        if _surely_rotation(A, tol):
            accepted += 1
            assert err <= 0.5 * tol * (1 + 1e-6) and det > 0.0, (err, det)
        else:
            rejected += 1
        if err <= 1e-6 and det > 0.0:
            out, defect = nearest_rotation(A, "R0", "")
            assert (defect is None) == (err <= tol)
            if defect is None:
                assert out is A
    assert accepted > 30 and rejected > 30


@pytest.mark.parametrize(
    "overrides,exc,pattern",
    [
        (dict(R0=1.01 * np.eye(3)), ValueError, r"R0 must be a rotation matrix.*lgvi\.so3\.project"),
        (dict(R0=np.diag([1.0, 1.0, -1.0])), ValueError, r"determinant -1.*lgvi\.so3\.project"),
        (dict(R0=-np.eye(3)), ValueError, r"R0 must be a rotation matrix"),
        (dict(R0=np.eye(2)), ValueError, r"R0 must have shape \(3, 3\)"),
        (dict(R0=np.where(np.eye(3) > 0, np.nan, 0.0)), ValueError, r"R0 must be finite"),
        (dict(R0=Rotation.random(2, random_state=0)), ValueError, r"R0 must be a single rotation"),
        (dict(Pi0=[0.1, np.nan, 0.2]), ValueError, r"Pi0 must be finite"),
        (dict(Pi0=[0.1, 0.2]), ValueError, r"Pi0 must have shape \(3,\)"),
        (dict(Pi0=None, omega0=[np.inf, 0.0, 0.0]), ValueError, r"omega0 must be finite"),
        (dict(Pi0=None), ValueError, r"Pi0 .* or .*omega0"),
        (dict(omega0=[0.1, 0.2, 0.3]), ValueError, r"either Pi0 or omega0, not both"),
        (dict(h=float("nan")), ValueError, r"h must be finite"),
        (dict(h=float("inf")), ValueError, r"h must be finite"),
        (dict(h=0.0), ValueError, r"h must be non-zero"),
        (dict(h=0), ValueError, r"h must be non-zero"),
        (dict(h="0.01"), TypeError, r"h must be a real number"),
        (dict(steps=-1), ValueError, r"steps must be an integer >= 0, got -1"),
        (dict(steps=10.0), TypeError, r"steps must be an integer"),
        (dict(steps=True), TypeError, r"steps must be an integer"),
        (dict(save_every=3), ValueError, r"save_every must divide steps.*steps=10, save_every=3"),
        (dict(save_every=0), ValueError, r"save_every must be an integer >= 1"),
        (dict(torque=np.zeros((9, 3))), ValueError, r"torque must have shape \(10, 3\), got shape \(9, 3\)"),
        (dict(torque=np.zeros((10, 2))), ValueError, r"torque must have shape \(10, 3\)"),
        (dict(torque=np.zeros(3)), ValueError, r"torque must have shape \(10, 3\)"),
        (dict(torque=np.where(np.arange(30).reshape(10, 3) == 17, np.nan, 0.0)), ValueError,
         r"torque must be finite.*at index \(5, 2\)"),
        (dict(torque="gravity"), TypeError, r"torque must be an array of real numbers"),
        (dict(method="rk45"), ValueError, r"method must be one of 'paper', 'newton', 'cayley'; got 'rk45'"),
        (dict(alpha=0.0), ValueError, r"alpha must be in \(0, 1\]"),
        (dict(tol=-1.0), ValueError, r"tol must be in \[0, 1\)"),
        (dict(max_iter=0), ValueError, r"max_iter must be an integer >= 1"),
    ],
)
def test_simulate_validation(overrides, exc, pattern, diag_body):
    with pytest.raises(exc, match=pattern):
        sim(diag_body, **overrides)


@pytest.mark.parametrize(
    "bad,pattern",
    [
        (lambda t: [0.0, 0.0], r"must return shape \(3,\).*step 3.*shape \(2,\)"),
        (lambda t: [0.0, np.nan, 0.0], r"must return finite values.*step 3"),
        (lambda t: "xyz", r"must return 3 real numbers.*step 3"),
    ],
)
def test_torque_callable_bad_value(bad, pattern, diag_body):
    good = [0.01, 0.0, 0.0]

    def torque(t, R, Pi):
        return bad(t) if t > 2.5 * H else good

    with pytest.raises(lgvi.TorqueError, match=pattern) as info:
        sim(diag_body, torque=torque)
    err = info.value
    assert err.step == 3
    assert err.time == pytest.approx(3 * H, rel=1e-15)
    part = err.trajectory
    assert isinstance(part, lgvi.Trajectory)
    assert part.R.shape == (4, 3, 3) and part.iterations.shape == (3,)
    ok = sim(diag_body, torque=np.tile(good, (3, 1)), steps=3)
    assert np.array_equal(part.R, ok.R) and np.array_equal(part.Pi, ok.Pi)


def test_torque_callable_raising(diag_body):
    def torque(t, R, Pi):
        if t > 4.5 * H:
            raise ZeroDivisionError("boom")
        return np.zeros(3)

    with pytest.raises(lgvi.TorqueError, match=r"raised ZeroDivisionError at step 5.*boom") as info:
        sim(diag_body, torque=torque)
    err = info.value
    assert isinstance(err.__cause__, ZeroDivisionError)
    assert err.step == 5
    assert err.trajectory.R.shape == (6, 3, 3)
    assert err.trajectory.meta.get("partial") is True
    free = sim(diag_body, steps=5)
    assert np.array_equal(err.trajectory.R, free.R)


@pytest.mark.parametrize("method", ["newton", "paper", "cayley"])
def test_convergence_error_huge_h(method, diag_body):
    """|h Pi| = 21 > sqrt(2) |Jd|_F = 3.2 bounds |vee(F Jd - Jd F^T)|: step 0 has no solution."""
    with pytest.raises(lgvi.ConvergenceError, match=r"step 0 .*residual") as info:
        sim(diag_body, h=10.0, method=method)
    err = info.value
    assert err.step == 0 and err.time == 0.0
    assert err.trajectory.R.shape == (1, 3, 3)
    assert np.array_equal(err.trajectory.R[0], np.eye(3))
    assert "smaller step h" in str(err)


@pytest.mark.parametrize("method", ["paper", "newton", "cayley"])
def test_convergence_error_mid_run(method, diag_body):
    """A spin-up torque about e3 grows Pi3 by 2 per step (h = 0.1, u3 = 20). Solvability needs
    J3 sin(theta) = h Pi3, i.e. Pi3 <= 30: some step k > 0 must fail; the error says which, and
    carries the states 0..k exactly as a run of k steps computes them."""
    steps = 40
    U = np.tile([0.0, 0.0, 20.0], (steps, 1))
    kwargs = dict(R0=np.eye(3), Pi0=[0.0, 0.0, 1.0], h=0.1, method=method)
    with pytest.raises(lgvi.ConvergenceError) as info:
        sim(diag_body, steps=steps, torque=U, **kwargs)
    err = info.value
    k = err.step
    assert 0 < k <= 15  # Pi3 at step k is 1 + 2k > 30 for k >= 15
    assert err.time == pytest.approx(0.1 * k, rel=1e-14)
    assert f"step {k}" in str(err) and "residual" in str(err)
    assert err.trajectory.R.shape == (k + 1, 3, 3)
    assert err.trajectory.iterations.shape == (k,)
    ok = sim(diag_body, steps=k, torque=U[:k], **kwargs)
    assert np.array_equal(err.trajectory.R, ok.R)
    assert np.array_equal(err.trajectory.Pi, ok.Pi)
    assert np.array_equal(err.trajectory.t, ok.t)


# --------------------------------------------------------------------------------------------
# load errors
# --------------------------------------------------------------------------------------------
def test_load_rejects_non_trajectories(tmp_path, run12):
    plain = tmp_path / "plain.npz"
    np.savez(plain, R=np.eye(3))
    with pytest.raises(ValueError, match="not an lgvi trajectory"):
        lgvi.load(plain)
    text = tmp_path / "notes.txt"
    text.write_text("this is not a trajectory\n")
    with pytest.raises(ValueError):
        lgvi.load(text)
    # a foreign format tag
    good = tmp_path / "good.npz"
    run12[0].save(good)
    with np.load(good) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(str(arrays["__lgvi__"]))
    header["format"] = "something.else/9"
    arrays["__lgvi__"] = np.array(json.dumps(header))
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, **arrays)
    with pytest.raises(ValueError, match="unsupported trajectory format"):
        lgvi.load(foreign)
    # a header without the arrays
    del arrays["R"]
    arrays["__lgvi__"] = np.array(json.dumps(dict(header, format="lgvi.trajectory/1")))
    missing = tmp_path / "missing.npz"
    np.savez(missing, **arrays)
    with pytest.raises(ValueError):
        lgvi.load(missing)


@pytest.mark.parametrize("fraction", [0.5, 0.9, 0.02])
def test_load_truncated_file(tmp_path, run12, fraction):
    path = tmp_path / "run.npz"
    run12[0].save(path)
    data = path.read_bytes()
    assert zipfile.is_zipfile(path)
    path.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(ValueError):
        lgvi.load(path)


# --------------------------------------------------------------------------------------------
# error paths of step
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs,exc,pattern",
    [
        (dict(h=0.0), ValueError, r"h must be non-zero"),
        (dict(R=1.01 * np.eye(3)), ValueError, r"R must be a rotation matrix.*lgvi\.so3\.project"),
        (dict(Pi=[0.1, np.nan, 0.2]), ValueError, r"Pi must be finite"),
        (dict(u=[0.1, 0.2]), ValueError, r"u must have shape \(3,\)"),
        (dict(method="euler"), ValueError, r"method must be one of"),
        (dict(alpha=2.0), ValueError, r"alpha must be in \(0, 1\]"),
    ],
)
def test_step_validation(kwargs, exc, pattern, diag_body):
    args = dict(R=np.eye(3), Pi=[0.3, 2.0, 0.6], h=H)
    args.update(kwargs)
    R, Pi = args.pop("R"), args.pop("Pi")
    with pytest.raises(exc, match=pattern):
        lgvi.step(diag_body, R, Pi, **args)


@pytest.mark.parametrize("method", ["paper", "cayley"])
def test_step_convergence_error(method, diag_body):
    with pytest.raises(lgvi.ConvergenceError, match="residual") as info:
        lgvi.step(diag_body, np.eye(3), [0.3, 2.0, 0.6], h=10.0, method=method)
    assert info.value.residual > 1.0
