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


# --- evaluating a trajectory's samples: one compiled loop (user_kernels.user_*_series) ---------

def per_sample_moment(func, t, R, Pi, p):
    """The evaluation before the series loop: one call from Python per sample."""
    lead = R.shape[:-2]
    t = np.broadcast_to(np.asarray(t, dtype=np.float64), lead)
    Pi = np.broadcast_to(Pi, lead + (3,))
    out = np.empty(lead + (3,))
    for i in np.ndindex(*lead):
        out[i] = np.asarray(func(float(t[i]), np.ascontiguousarray(R[i]), np.ascontiguousarray(Pi[i]), p))
    return out


def per_sample_potential(func, t, R, p):
    lead = R.shape[:-2]
    t = np.broadcast_to(np.asarray(t, dtype=np.float64), lead)
    out = np.empty(lead)
    for i in np.ndindex(*lead):
        out[i] = float(func(float(t[i]), np.ascontiguousarray(R[i]), p))
    return out


@numba.njit
def wobbly_moment(t, R, Pi, p):
    # uses t, R, Pi and the params with operations whose rounding a different order would change
    out = np.empty(3)
    for i in range(3):
        out[i] = p[0] * np.sin(t * p[1] + R[i, 0]) * R[2, i] + p[2] * Pi[i] * Pi[(i + 1) % 3] / 3.0
    return out


@numba.njit
def wobbly_potential(t, R, p):
    return p[0] * np.cos(t * p[1]) * (R[2, 0] + R[2, 1] / 7.0) + p[2] * R[0, 0] * R[1, 1] * R[2, 2]


def samples(lead, seed=3):
    rng = np.random.default_rng(seed)
    R = np.stack([lgvi.so3.exp(v) for v in rng.standard_normal((int(np.prod(lead)), 3))]).reshape(lead + (3, 3))
    return rng.uniform(0.0, 5.0, lead), R, rng.standard_normal(lead + (3,))


def series_model(moment, potential=None, params=None):
    m = Compiled(moment, potential=potential, params=params)
    m.series_min = 1                      # the compiled series loop for every sample count
    m.series_compile = 0
    return m


@pytest.mark.parametrize("lead", [(), (1,), (5,), (300,), (4, 70)])
@pytest.mark.parametrize("funcs", [(gravity_moment, gravity_potential), (wobbly_moment, wobbly_potential)])
def test_series_equals_per_sample_bit_for_bit(lead, funcs):
    from lgvi._kernels import guards, user_kernels

    p = np.array([0.7, 1.9, -0.4])
    model = series_model(*funcs, params=p)
    t, R, Pi = samples(lead)
    assert np.array_equal(model.moment(t, R, Pi, None), per_sample_moment(funcs[0], t, R, Pi, p))
    assert np.array_equal(model.potential(t, R, None), per_sample_potential(funcs[1], t, R, p))
    # scalar time and a single momentum broadcast over the samples
    pi = Pi.reshape(-1, 3)[0]
    assert np.array_equal(model.moment(1.25, R, pi, None), per_sample_moment(funcs[0], 1.25, R, pi, p))
    assert np.array_equal(model.potential(1.25, R, None), per_sample_potential(funcs[1], 1.25, R, p))
    assert model.moment(t, R, Pi, None).shape == lead + (3,)
    assert model.potential(t, R, None).shape == lead
    if lead:        # the compiled loops did run (a single sample stays one call from Python), through the
        # guarded functions: compiled loops (cached on disk) for every user's function
        assert guards.made(funcs[0]) and guards.made(funcs[1])
        for kernel in (user_kernels.user_moment_series, user_kernels.user_potential_series):
            assert kernel.signatures and all(isinstance(sig[0], numba.core.types.FunctionType)
                                             for sig in kernel.signatures)      # never specialised for one


def test_series_per_body_params_rows():
    rows = np.array([[0.7, 1.9, -0.4], [-1.1, 0.3, 2.0]])
    model = series_model(wobbly_moment, wobbly_potential, params=rows)
    t, R, Pi = samples((50,))
    for b in range(2):
        assert np.array_equal(model.moment(t, R, Pi, None, b=b), per_sample_moment(wobbly_moment, t, R, Pi, rows[b]))
        assert np.array_equal(model.potential(t, R, None, b=b), per_sample_potential(wobbly_potential, t, R, rows[b]))
    assert not np.array_equal(model.potential(t, R, None, b=0), model.potential(t, R, None, b=1))
    with pytest.raises(ValueError, match="one row per body"):
        model.potential(t, R, None)


def test_series_default_thresholds_and_python_path_agree():
    # the default model (Python calls below series_compile unless compiled) gives the same numbers
    p = np.array([0.7, 1.9, -0.4])
    t, R, Pi = samples((3, 40))
    a = Compiled(wobbly_moment, potential=wobbly_potential, params=p)
    a.series_min = 1 << 62                                   # always one call per sample
    b = series_model(wobbly_moment, wobbly_potential, params=p)
    c = Compiled(wobbly_moment, potential=wobbly_potential, params=p)
    for m in (b, c):
        assert np.array_equal(m.moment(t, R, Pi, None), a.moment(t, R, Pi, None))
        assert np.array_equal(m.potential(t, R, None), a.potential(t, R, None))


def test_series_bad_input_raises_as_before():
    model = series_model(wobbly_moment, wobbly_potential, params=[1.0, 1.0, 1.0])
    t, R, Pi = samples((30,))
    with pytest.raises(ValueError, match="R must have shape"):
        model.potential(t, R[:, :2], None)
    with pytest.raises(ValueError, match="Pi must have shape"):
        model.moment(t, R, Pi[:, :2], None)
    with pytest.raises(ValueError):
        model.moment(t[:7], R, Pi, None)                     # t does not broadcast to the samples

    @numba.njit
    def grows(t, R, Pi, p):
        return np.zeros(3 if t < 1.0 else 4)                 # passes the trial call at t = 0

    g = series_model(grows)
    with pytest.raises(ValueError, match="could not broadcast"):
        g.moment(np.linspace(0.0, 2.0, 30), R, Pi, None)     # the per-sample error, as before
    assert np.array_equal(g.moment(np.zeros(30), R, Pi, None), np.zeros((30, 3)))


@pytest.mark.parametrize("series", [True, False])
def test_series_leaves_the_samples_alone(series):
    @numba.njit
    def scribbles(t, R, Pi, p):
        R[0, 0] = 99.0              # the per-sample calls passed views of the samples: this wrote into them
        return (R[0, 0], 0.0, 0.0)

    t, R, Pi = samples((20,))
    R0_, Pi0_ = R.copy(), Pi.copy()
    out = (series_model(scribbles) if series else Compiled(scribbles)).moment(t, R, Pi, None)
    assert np.array_equal(out[:, 0], np.full(20, 99.0))
    assert np.array_equal(R, R0_) and np.array_equal(Pi, Pi0_)


def test_energy_of_a_compiled_run_unchanged_by_the_series_loop():
    p = GRAVITY.mass * GRAVITY.g * GRAVITY.com
    a = Compiled(gravity_moment, potential=gravity_potential, params=p)
    a.series_min = 1 << 62                                   # the per-sample Python calls
    b = series_model(gravity_moment, gravity_potential, params=p)
    ta, tb = run(a, steps=500), run(b, steps=500)
    assert np.array_equal(ta.R, tb.R)
    assert np.array_equal(tb.potential, per_sample_potential(gravity_potential, tb.t, tb.R, p))
    assert np.array_equal(ta.energy, tb.energy)
    assert np.array_equal(ta.potential, tb.potential)


@numba.njit
def spring_moment(t, R, Pi, p):
    return (-p[0] * R[2, 1], p[0] * R[2, 0], 0.0)


def test_one_cached_loop_serves_every_compiled_model():
    """The user's moment reaches the loops as a value of one function type (a ``cfunc``,
    ``user_kernels.guarded``), not as a function the loop is specialised for: a second model, in
    ``simulate``, in an ensemble, beside wheels and in both splittings, adds no specialisation of the
    loops (the ones
    cached on disk: a later process compiles only the user's function), and gives each model its
    own numbers."""
    if numba.config.DISABLE_JIT:
        pytest.skip("the loops run as Python: nothing is compiled")
    from lgvi._kernels.gyrostat_kernels import run_gyro_model
    from lgvi._kernels.splitting_kernels import run_axes_user, run_split_user
    from lgvi._kernels.user_kernels import advance_user, run_chunk_user

    def runs(model):
        one = run(model, steps=20, forcing="symmetric")
        ens = lgvi.simulate_ensemble(lgvi.RigidBody(J), np.stack([R0] * 2), omega0=np.tile(OMEGA0, (2, 1)), h=0.02,
                                     steps=20, torque=model, forcing="symmetric", threads=1)
        wheels = lgvi.simulate(lgvi.RigidBody(J), R0, omega0=OMEGA0, h=0.02, steps=20, torque=model,
                               wheels=lgvi.ReactionWheels(np.eye(3), 0.01))
        split = [lgvi.simulate(lgvi.RigidBody(J), R0, omega0=OMEGA0, h=0.02, steps=20, torque=model, scheme="splitting",
                               order=order, composition=name) for order, name in ((4, "aba84"), (8, "axes-kl8"))]
        return one, ens, wheels, *split

    first = runs(user_gravity())
    kernels = (run_chunk_user, advance_user, run_gyro_model, run_split_user, run_axes_user)
    compiled = [set(k.signatures) for k in kernels]
    second = runs(Compiled(spring_moment, params=[0.4]))
    assert [set(k.signatures) for k in kernels] == compiled       # the same compiled loops for both models
    assert all(type(k._cache).__name__ != "NullCache" for k in kernels) or not lgvi._jit.CACHE
    assert np.array_equal(first[1].R[0], first[0].R) and np.array_equal(second[1].R[1], second[0].R)
    assert all(not np.array_equal(first[i].R, second[i].R) for i in (0, 2, 3, 4))
