"""Forcing schemes of simulate: the paper's update, the symmetric (variational) update, compositions.

The compiled forced kernels are checked against a plain NumPy implementation of the same
equations (which resolves the implicit momentum equation by fixed-point iteration, where the
kernel solves it exactly), against the original kernels where the schemes coincide, and for
the properties the higher-order compositions rely on (symmetry: stepping back with -h retraces
the path).
"""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi import integrator, so3
from lgvi.verification import reference
from lgvi.torques import AttitudePD, Constant, GravityGradient, LinearDamping, UniformGravity

BODY = lgvi.RigidBody(np.array([[0.9, 0.05, -0.1], [0.05, 1.3, 0.08], [-0.1, 0.08, 1.7]]))
R0 = so3.exp([0.3, -0.2, 0.5])
PI0 = np.array([0.6, -0.9, 1.2])


def mixed_model():
    return (UniformGravity(1.0, [0.05, 0.0, 0.3]) + GravityGradient(3.0, 1.2) + LinearDamping([0.05, 0.1, 0.02])
            + AttitudePD(0.4, 0.1, so3.exp([0.2, 0.1, -0.3])) + Constant([0.01, -0.02, 0.03]))


def numpy_scheme(body, model, R0, Pi0, h, steps, forcing, coefficients=(1.0,), t0=0.0):
    """The forced LGVI in plain NumPy, one line per equation (oracle for the kernels)."""
    cons = [m for m in model.terms if m.conservative]
    other = [m for m in model.terms if not m.conservative]

    def P(t, R):
        return sum((m.moment(t, R, np.zeros(3), body) for m in cons), np.zeros(3))

    def N(t, R, Pi):
        return sum((m.moment(t, R, Pi, body) for m in other), np.zeros(3))

    gam = np.asarray(coefficients)
    cum = np.concatenate([[0.0], np.cumsum(gam)])
    cum[-1] = 1.0
    R, Pi = R0.copy(), Pi0.copy()
    Rs, Pis = [R], [Pi]
    w = [np.linalg.solve(body.J, g * h * Pi0) for g in gam]
    for k in range(steps):
        for i, g in enumerate(gam):
            hs = g * h
            t, t1 = t0 + (k + cum[i]) * h, t0 + (k + cum[i + 1]) * h
            Pk, Nk = P(t, R), N(t, R, Pi)
            mu = Pi + hs / 2 * (Pk + Nk) if forcing == "symmetric" else Pi + hs / 2 * Pk
            w[i], _ = reference.newton_raphson(body.Jd, hs * mu, w[i], tol=1e-16, max_iter=1000)
            F = so3.exp(w[i])                                   # hat(hs mu) = F Jd - Jd F^T
            R = R @ F                                           # R_{k+1} = R_k F
            P1 = P(t1, R)
            if forcing == "symmetric":                          # Pi_{k+1} = F^T mu + hs/2 M_{k+1}
                Pi_next = F.T @ mu + hs / 2 * P1
                for _ in range(200):
                    new = F.T @ mu + hs / 2 * (P1 + N(t1, R, Pi_next))
                    if np.array_equal(new, Pi_next):
                        break
                    Pi_next = new
                Pi = Pi_next
            else:                                               # Pi_{k+1} = F^T mu + hs/2 P_{k+1} + hs N_k
                Pi = F.T @ mu + hs / 2 * P1 + hs * Nk
        Rs.append(R)
        Pis.append(Pi)
    return np.array(Rs), np.array(Pis)


@pytest.mark.parametrize("forcing, composition", [("symmetric", None), ("paper", None), ("symmetric", "suzuki4")])
def test_kernel_matches_numpy_scheme(forcing, composition):
    """Same equations, same data: agreement to round-off (1e-12 over 60 steps; measured ~1e-15)."""
    model = mixed_model()
    order = 2 if composition is None else 4
    coeffs = (1.0,) if composition is None else integrator.COMPOSITIONS[composition].coefficients
    h, steps, t0 = 0.05, 60, 0.7
    traj = lgvi.simulate(BODY, R0, PI0, h=h, steps=steps, torque=model, forcing=forcing, order=order, t0=t0)
    R, Pi = numpy_scheme(BODY, model, R0, PI0, h, steps, forcing, coeffs, t0=t0)
    np.testing.assert_allclose(traj.R, R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.Pi, Pi, rtol=0, atol=1e-12 * np.abs(PI0).max())
    np.testing.assert_allclose(traj.t, t0 + h * np.arange(steps + 1), rtol=0, atol=1e-15)


def test_numpy_scheme_matches_reference_without_torque_terms():
    """The oracle itself reduces to lgvi.reference.simulate (the paper's equations) for a zero
    constant torque, so the comparison above tests the forcing and not the oracle's solver."""
    R, Pi = numpy_scheme(BODY, Constant([0.0, 0.0, 0.0]), R0, PI0, 0.05, 20, "paper")
    R_ref, Pi_ref = reference.simulate(BODY.J, R0, PI0, 0.05, 20)
    np.testing.assert_allclose(R, R_ref, rtol=0, atol=1e-13)
    np.testing.assert_allclose(Pi, Pi_ref, rtol=0, atol=1e-13)


# ------------------------------------------------------------------ reduction to the original scheme
def test_constant_model_equals_torque_array_bit_for_bit():
    """With forcing="paper" the forced kernel reduces exactly to the paper's step: a Constant model
    and the same moment as a (steps, 3) array give identical bits (same warm start, same sums)."""
    u = np.array([0.03, -0.01, 0.02])
    a = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=500, torque=Constant(u))
    b = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=500, torque=np.tile(u, (500, 1)))
    np.testing.assert_array_equal(a.R, b.R)
    np.testing.assert_array_equal(a.Pi, b.Pi)
    np.testing.assert_array_equal(a.iterations, b.iterations)


def test_defaults_unchanged():
    """The new keywords default to today's scheme: explicit defaults give identical bits."""
    u = np.random.default_rng(1).normal(size=(300, 3)) * 0.1
    for torque in (None, u, lambda t, R, Pi: np.array([np.sin(t), 0.0, 0.1])):
        a = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=300, torque=torque)
        b = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=300, torque=torque, forcing="paper", order=2)
        np.testing.assert_array_equal(a.R, b.R)
        np.testing.assert_array_equal(a.Pi, b.Pi)
        assert a.meta["forcing"] == "paper" and a.meta["order"] == 2
        assert a.potential is None


def test_free_body_symmetric_forcing_is_the_free_body():
    a = lgvi.simulate(BODY, R0, PI0, h=0.02, steps=200)
    b = lgvi.simulate(BODY, R0, PI0, h=0.02, steps=200, forcing="symmetric")
    np.testing.assert_array_equal(a.R, b.R)


# ------------------------------------------------------------------ arrays and callables, symmetric
def test_symmetric_array_callable_and_kernel_agree():
    """A time-only torque given three ways: array of u(t_0..t_N) (steps+1, 3), callable, and the
    kernel path. Same equations, so the same bits up to the order of additions (1e-14)."""
    steps, h = 400, 0.01
    f = lambda t: np.array([0.2 * np.sin(3 * t), 0.1 * np.cos(2 * t), 0.05])  # noqa: E731
    U = np.array([f(k * h) for k in range(steps + 1)])
    a = lgvi.simulate(BODY, R0, PI0, h=h, steps=steps, torque=U, forcing="symmetric")
    b = lgvi.simulate(BODY, R0, PI0, h=h, steps=steps, torque=lambda t, R, Pi: f(t), forcing="symmetric")
    np.testing.assert_allclose(a.R, b.R, rtol=0, atol=1e-14)
    np.testing.assert_allclose(a.Pi, b.Pi, rtol=0, atol=1e-14)
    # and the paper's scheme is measurably different (first order): the test can fail
    c = lgvi.simulate(BODY, R0, PI0, h=h, steps=steps, torque=U[:-1])
    assert np.abs(c.Pi - a.Pi).max() > 1e-5


def test_symmetric_array_needs_steps_plus_one_rows():
    with pytest.raises(ValueError, match=r"torque must have shape \(101, 3\)"):
        lgvi.simulate(BODY, R0, PI0, h=0.01, steps=100, torque=np.zeros((100, 3)), forcing="symmetric")
    with pytest.raises(ValueError, match=r"torque must have shape \(100, 3\)"):
        lgvi.simulate(BODY, R0, PI0, h=0.01, steps=100, torque=np.zeros((101, 3)))


def test_momentum_dependent_callable_matches_model():
    """Damping as a callable (fixed-point iteration to tol) and as a model (exact linear solve)."""
    model = LinearDamping([0.3, 0.1, 0.2]) + UniformGravity(1.0, [0.0, 0.1, 0.2])
    cb = lambda t, R, Pi: model.moment(t, R, Pi, BODY)  # noqa: E731
    a = lgvi.simulate(BODY, R0, PI0, h=0.02, steps=300, torque=model, forcing="symmetric")
    b = lgvi.simulate(BODY, R0, PI0, h=0.02, steps=300, torque=cb, forcing="symmetric")
    np.testing.assert_allclose(a.R, b.R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.Pi, b.Pi, rtol=0, atol=1e-12)
    # gravity through the callable is "forced", through the model variational: same formulas
    c = lgvi.simulate(BODY, R0, PI0, h=0.02, steps=300, torque=cb)   # paper forcing differs
    assert np.abs(c.Pi - a.Pi).max() > 1e-4


def test_callable_fixed_point_failure_is_a_convergence_error():
    # M = -30 Pi: the solve sees Pi + h/2 M = -0.5 Pi (fine), but the fixed-point map
    # Pi -> a + h/2 M(Pi) has gain h/2 * 30 = 1.5 > 1 and diverges
    stiff = lambda t, R, Pi: -30.0 * Pi  # noqa: E731
    with pytest.raises(lgvi.ConvergenceError, match="fixed-point") as info:
        lgvi.simulate(BODY, R0, PI0, h=0.1, steps=10, torque=stiff, forcing="symmetric")
    assert info.value.step == 0
    assert info.value.trajectory is not None


def test_callable_errors_in_symmetric_mode():
    def bad(t, R, Pi):
        if t > 0.05:
            raise RuntimeError("sensor offline")
        return np.zeros(3)

    with pytest.raises(lgvi.TorqueError, match="sensor offline") as info:
        lgvi.simulate(BODY, R0, PI0, h=0.01, steps=100, torque=bad, forcing="symmetric")
    assert len(info.value.trajectory.t) >= 5
    with pytest.raises(lgvi.TorqueError, match="shape"):
        lgvi.simulate(BODY, R0, PI0, h=0.01, steps=10, torque=lambda t, R, Pi: np.zeros(2), forcing="symmetric")


# ------------------------------------------------------------------ symmetry (what compositions need)
@pytest.mark.parametrize("order", [2, 4])
def test_symmetric_scheme_retraces_its_path(order):
    """Forward N steps with h, then N steps with -h from the end: back to the start to round-off,
    for a time-dependent, momentum-dependent, non-conservative model (the scheme is symmetric
    for any smooth M(t, R, Pi), so its compositions raise the order)."""
    model = mixed_model()
    h, steps = 0.02, 200
    fwd = lgvi.simulate(BODY, R0, PI0, h=h, steps=steps, torque=model, forcing="symmetric", order=order)
    back = lgvi.simulate(BODY, fwd.R[-1], fwd.Pi[-1], h=-h, steps=steps, torque=model, forcing="symmetric",
                         order=order, t0=fwd.t[-1])
    # 2 x 200 steps, each solved to 1e-14 relative: ~1e-12 accumulates (measured 1.5e-12);
    # the paper's forcing misses by > 1e-4 (next test)
    np.testing.assert_allclose(back.R[-1], R0, rtol=0, atol=1e-11)
    np.testing.assert_allclose(back.Pi[-1], PI0, rtol=0, atol=1e-11)
    np.testing.assert_allclose(back.R[::-1], fwd.R, rtol=0, atol=1e-11)


def test_paper_forcing_does_not_retrace():
    """The contrast that makes the symmetry test meaningful: the paper's update misses by O(h)."""
    model = mixed_model()
    h, steps = 0.02, 200
    fwd = lgvi.simulate(BODY, R0, PI0, h=h, steps=steps, torque=model)
    back = lgvi.simulate(BODY, fwd.R[-1], fwd.Pi[-1], h=-h, steps=steps, torque=model, t0=fwd.t[-1])
    assert np.abs(back.Pi[-1] - PI0).max() > 1e-4


# ------------------------------------------------------------------ chunks, saving, metadata
@pytest.mark.parametrize("order", [2, 6])
def test_chunks_continue_exactly(monkeypatch, order):
    """State (R, Pi, solver histories, moment cache) carries over between compiled chunks."""
    model = mixed_model()
    kw = dict(h=0.01, steps=120, torque=model, forcing="symmetric", order=order, save_every=4)
    whole = lgvi.simulate(BODY, R0, PI0, **kw)
    monkeypatch.setattr(integrator, "CHUNK_STEPS", 7)
    chunked = lgvi.simulate(BODY, R0, PI0, **kw)
    np.testing.assert_array_equal(whole.R, chunked.R)
    np.testing.assert_array_equal(whole.Pi, chunked.Pi)
    np.testing.assert_array_equal(whole.iterations, chunked.iterations)


def test_potential_energy_and_save_every():
    model = UniformGravity(1.0, [0.0, 0.0, 0.3]) + GravityGradient(2.0, 1.0) + LinearDamping(0.01)
    traj = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=100, torque=model, save_every=10, t0=0.5)
    assert traj.potential.shape == (11,)
    cons = UniformGravity(1.0, [0.0, 0.0, 0.3]) + GravityGradient(2.0, 1.0)
    np.testing.assert_array_equal(traj.potential, cons.potential(traj.t, traj.R, BODY))
    np.testing.assert_allclose(traj.energy, traj.kinetic_energy + traj.potential, rtol=1e-15)
    # without the (time-dependent) gravity gradient, damping makes the energy decrease
    damped = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=1000, torque=UniformGravity(1.0, [0, 0, 0.3])
                           + LinearDamping(0.05), forcing="symmetric", save_every=100)
    assert np.all(np.diff(damped.energy) < 0)


def test_meta_and_round_trip(tmp_path):
    model = UniformGravity(1.0, [0.0, 0.0, 0.3]) + LinearDamping(0.01)
    traj = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=50, torque=model, forcing="symmetric", order=4)
    assert traj.meta["forcing"] == "symmetric"
    assert traj.meta["order"] == 4
    assert traj.meta["composition"] == "suzuki4"
    assert traj.meta["torque"] == "model"
    assert traj.meta["torque_model"] == repr(model)
    traj.save(tmp_path / "t.npz")
    back = lgvi.load(tmp_path / "t.npz")
    assert back.meta == traj.meta
    np.testing.assert_array_equal(back.potential, traj.potential)


def test_iterations_and_residual_per_step_with_compositions():
    traj = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=50, torque=UniformGravity(1.0, [0, 0, 0.3]), order=6)
    assert traj.iterations.shape == (50,) and traj.residual.shape == (50,)
    assert traj.iterations.min() >= 9          # nine substeps, >= 1 update each after the start
    assert traj.residual.max() < 1e-14 * np.linalg.norm(PI0) * 0.01 * 10


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize("kwargs, match", [
    (dict(forcing="midpoint"), "forcing must be one of 'paper', 'symmetric'"),
    (dict(order=3), "order must be 2, 4 or 6"),
    (dict(order=4.0), "order must be 2, 4 or 6"),
    (dict(order=True), "order must be 2, 4 or 6"),
    (dict(order=4, composition="rk4"), "composition must be one of"),
    (dict(order=6, composition="suzuki4"), "composition 'suzuki4' is of order 4, but order=6"),
    (dict(order=4, torque=np.zeros((11, 3)), forcing="symmetric"), "torque array holds moments at the grid"),
    (dict(order=4, torque=lambda t, R, Pi: np.zeros(3)), "forcing='symmetric'"),
    (dict(order=6, torque=LinearDamping(0.1)), "not symmetric"),
    (dict(order=4, torque=UniformGravity(1.0, [0, 0, 1]) + Constant([0, 0, 1])), "Constant"),
])
def test_invalid_options(kwargs, match):
    kw = dict(h=0.01, steps=10)
    kw.update(kwargs)
    with pytest.raises(ValueError, match=match):
        lgvi.simulate(BODY, R0, PI0, **kw)


def test_potential_models_compose_with_default_forcing():
    """A purely conservative model needs no forcing choice: order 4 works with the default."""
    traj = lgvi.simulate(BODY, R0, PI0, h=0.01, steps=20, torque=GravityGradient(1.0, 1.0), order=4)
    assert traj.meta["order"] == 4


def test_backward_damped_step_too_large_is_rejected():
    """Backwards, I + h/2 D J^-1 can become singular; a clear error instead of garbage."""
    with pytest.raises(ValueError, match="reduce \\|h\\|"):
        lgvi.simulate(BODY, R0, PI0, h=-1.0, steps=2, torque=LinearDamping(100.0), forcing="symmetric")


def test_forced_kernels_interpreted_match_compiled():
    """The forced kernels run as plain Python (NUMBA_DISABLE_JIT=1) give the compiled results:
    catches typing or integer-width differences between the two modes (same IEEE arithmetic,
    so agreement to round-off; 1e-13 allows for LLVM's different operation order)."""
    import os
    import subprocess
    import sys

    code = (
        "import numpy as np, lgvi\n"
        "from lgvi.torques import *\n"
        "b = lgvi.RigidBody([[0.9, 0.05, -0.1], [0.05, 1.3, 0.08], [-0.1, 0.08, 1.7]])\n"
        "m = UniformGravity(1, [0.05, 0, .3]) + LinearDamping(0.1) + GravityGradient(1, 1) + AttitudePD(1, 1)\n"
        "a = lgvi.simulate(b, lgvi.so3.exp([0.3, -0.2, 0.5]), [0.6, -0.9, 1.2], h=0.02, steps=30, torque=m,\n"
        "                  forcing='symmetric', order=4)\n"
        "c = lgvi.simulate(b, np.eye(3), [0.6, -0.9, 1.2], h=0.02, steps=30, torque=m)\n"
        "result = np.concatenate([a.R[-1].ravel(), a.Pi[-1], c.R[-1].ravel(), c.Pi[-1]])\n"
    )
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    out = subprocess.run([sys.executable, "-c", code + "print(repr(result.tolist()))\n"], env=env,
                         capture_output=True, text=True, check=True)
    interpreted = np.array(eval(out.stdout.strip().splitlines()[-1]))
    ns: dict = {}
    exec(code, ns)
    np.testing.assert_allclose(interpreted, np.array(ns["result"]), rtol=0, atol=1e-13)
