"""The gyrostat by the explicit RKMK scheme in Cayley coordinates (``scheme="rkmk4"``, docs/gyrostat_rkmk.md):
order 4, exact momentum map, agreement with Basilisk, the compiled and the Python controller, refusals."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi.control import Command, Controller, MRPFeedback, matrix_from_mrp, mrp_from_matrix

from gyrostat_cases import BODY, R0, R_REF, Random, W0, basilisk_scenario, wheels  # tests/ is on the path


class PythonMRP(MRPFeedback):
    """The same law, called from Python (a subclass is not compiled)."""


def rel_drift(x):
    x = np.asarray(x)
    return float(np.abs(x - x[0]).max() / np.abs(x[0]).max())


def angle(Ra, Rb):
    return float(np.linalg.norm(lgvi.so3.log(Ra.T @ Rb)))


def test_fourth_order_with_the_motors_on_and_saturated():
    """Compiled MRP feedback every 0.4 s through saturated wheels: errors at h = 0.4/2^m against the
    LGVI at order 6 and h = 0.4/64 (the same zero-order hold) fall as h^4, for every tableau."""
    T, cp = 8.0, 0.4
    kw = dict(wheels=wheels(max_torque=0.05), controller=MRPFeedback(0.5, 2.0, target=R_REF), control_period=cp,
              save_every=None)
    ref = lgvi.simulate(BODY, R0, omega0=W0, h=cp / 64, steps=int(round(T * 64 / cp)), order=6,
                        **dict(kw, save_every=int(round(T * 64 / cp))))
    assert np.abs(ref.wheel_torque).max() == pytest.approx(0.05)      # the torque limit acts
    for tab in ("rk4", "rk38", "ralston4"):
        errs = []
        for m in (2, 4, 8):
            steps = int(round(T * m / cp))
            traj = lgvi.simulate(BODY, R0, omega0=W0, h=cp / m, steps=steps, scheme="rkmk4", composition=tab,
                                 **dict(kw, save_every=steps))
            errs.append(max(angle(ref.R[-1], traj.R[-1]), np.abs(ref.Pi[-1] - traj.Pi[-1]).max(),
                            np.abs(ref.wheel_momentum[-1] - traj.wheel_momentum[-1]).max()))
            assert traj.meta["order"] == 4 and traj.meta["composition"] == tab and traj.meta["scheme"] == "rkmk4"
        assert errs[0] > 1e-9            # well above round-off
        for a, b in zip(errs[:-1], errs[1:]):
            assert 16 * 0.75 < a / b < 16 * 1.3, (tab, errs)


def test_rotating_reference_agrees_with_the_lgvi_at_order_4():
    """MRPFeedback with a rotating reference (a target profile with rates: the Python law; the
    compiled law never sees reference rates): rkmk4 and the LGVI at order 4, the same zero-order
    hold, differ by O(h^4), and the rates reach the law in both."""
    w_ref = np.array([0.02, -0.05, 0.08])                 # [rad/s], inertial

    def rot(t):
        return lgvi.so3.exp(t * w_ref) @ R_REF

    T, cp = 40.0, 0.4

    def run(m, target, **kw):
        steps = int(round(T * m / cp))
        return lgvi.simulate(BODY, R0, omega0=W0, h=cp / m, steps=steps, wheels=wheels(), save_every=steps,
                             controller=MRPFeedback(0.5, 2.0, target=target), control_period=cp, **kw)

    diffs = []
    for m in (2, 4, 8):
        a = run(m, lambda t: (rot(t), w_ref, np.zeros(3)), order=4)
        b = run(m, lambda t: (rot(t), w_ref, np.zeros(3)), scheme="rkmk4")
        assert b.meta["scheme"] == "rkmk4" and a.meta.get("scheme") != "rkmk4"
        diffs.append(max(angle(a.R[-1], b.R[-1]), np.abs(a.Pi[-1] - b.Pi[-1]).max(),
                         np.abs(a.wheel_momentum[-1] - b.wheel_momentum[-1]).max()))
    assert diffs[0] > 1e-7 and diffs[-1] < 1e-7, diffs
    for x, y in zip(diffs[:-1], diffs[1:]):
        assert 16 * 0.75 < x / y < 16 * 1.3, diffs
    for kw in ({"order": 4}, {"scheme": "rkmk4"}):       # without the rates: another run, far off
        still = run(8, rot, **kw)
        assert angle(still.R[-1], b.R[-1]) > 0.1 and angle(still.R[-1], rot(T)) > angle(b.R[-1], rot(T)) + 0.5


def test_momentum_exact_under_wheel_torques_friction_and_saturation():
    w = wheels(max_torque=0.05, min_torque=0.01, max_power=0.3, max_speed=12.0,
               friction={"coulomb": 1e-3, "viscous": 1e-4})
    traj = lgvi.simulate(BODY, R0, omega0=W0, h=0.01, steps=20000, wheels=w, controller=Random(0.2),
                         control_period=0.05, save_every=10, scheme="rkmk4")
    assert np.abs(traj.wheel_torque).max() == pytest.approx(0.05)
    assert np.any(traj.wheel_torque == 0.0)
    assert np.abs(traj.wheel_speed).max() > 11.0
    # round-off only: a random walk of a few ulp per step over 20000 steps (sqrt(20000) 4 eps = 6e-14);
    # a scheme that were not exact would drift by its truncation error (~1e-6 here)
    assert rel_drift(traj.spatial_momentum) < 1e-13
    assert rel_drift(np.linalg.norm(traj.Pi, axis=1)) < 1e-13
    RtR = np.einsum("mji,mjk->mik", traj.R, traj.R)
    assert np.abs(RtR - np.eye(3)).max() < 1e-15 * 8
    assert np.all(traj.iterations == 0) and np.all(traj.residual == 0.0)
    inv = traj.meta["invariants"]
    assert inv["spatial_momentum"]["kind"] == "exact" and "energy" not in inv


def test_energy_drifts_with_the_motors_off():
    """Not symplectic: with the motors off the energy error grows linearly in time (documented; the
    LGVI's stays bounded), here at a rate falling as h^5 (measured: 2.2e-5 and 6.9e-7 over 400 s)."""
    drifts = []
    for h in (0.1, 0.05):
        traj = lgvi.simulate(BODY, R0, omega0=W0, h=h, steps=int(round(400 / h)), wheels=wheels(),
                             save_every=int(round(0.5 / h)), scheme="rkmk4")
        d = np.abs(traj.energy / traj.energy[0] - 1.0)
        n = len(d)
        assert d[-1] > 5.0 * d[: n // 10].max()        # a drift, not a bounded oscillation
        drifts.append(d.max())
        assert rel_drift(traj.spatial_momentum) < 1e-13
        assert "energy" not in traj.meta["invariants"]
    assert drifts[0] < 5e-5
    assert 20.0 < drifts[0] / drifts[1] < 40.0


def test_compiled_and_python_controller_agree():
    kw = dict(h=0.02, steps=5000, wheels=wheels(max_torque=0.5), control_period=0.1, save_every=5, scheme="rkmk4")
    for K, P, Ki in ((0.5, 2.0, None), (0.5, 2.0, 0.01)):
        extra = {} if Ki is None else dict(Ki=Ki, integral_limit=0.2)
        a = lgvi.simulate(BODY, R0, omega0=W0, controller=MRPFeedback(K, P, target=R_REF, **extra), **kw)
        b = lgvi.simulate(BODY, R0, omega0=W0, controller=PythonMRP(K, P, target=R_REF, **extra), **kw)
        c = lgvi.simulate(BODY, R0, omega0=W0, controller=MRPFeedback(K, P, target=R_REF, **extra),
                          **dict(kw, scheme=None, order=4))
        assert np.abs(a.R - b.R).max() < 1e-10
        assert np.abs(a.wheel_torque - b.wheel_torque).max() < 1e-9
        assert np.abs(a.R - c.R).max() < 1e-6            # the LGVI at order 4: the same solution
        assert rel_drift(a.spatial_momentum) < 1e-13


def test_body_torque_enters_as_the_inertial_impulse():
    """MRP feedback without wheels is a body torque: order 4 against the LGVI at order 6, the
    inertial momentum changes (no invariant declared), and the law settles the body."""
    T = 6.0
    ref = lgvi.simulate(BODY, R0, omega0=W0, h=0.1 / 64, steps=int(round(T * 640)),
                        controller=MRPFeedback(1.0, 3.0), control_period=0.1, order=6, save_every=int(round(T * 640)))
    errs = []
    for m in (1, 2, 4):
        steps = int(round(T * 10 * m))
        traj = lgvi.simulate(BODY, R0, omega0=W0, h=0.1 / m, steps=steps, controller=MRPFeedback(1.0, 3.0),
                             control_period=0.1, scheme="rkmk4", save_every=steps)
        errs.append(angle(ref.R[-1], traj.R[-1]) + np.abs(ref.Pi[-1] - traj.Pi[-1]).max())
        assert traj.meta["invariants"] == {}
    assert 16 * 0.7 < errs[0] / errs[1] < 16 * 1.3 and 16 * 0.7 < errs[1] / errs[2] < 16 * 1.3
    long = lgvi.simulate(BODY, R0, omega0=W0, h=0.05, steps=4000, controller=MRPFeedback(1.0, 3.0),
                         control_period=0.1, scheme="rkmk4")
    assert np.linalg.norm(long.omega[-1]) < 1e-4 and np.linalg.norm(mrp_from_matrix(long.R[-1])) < 1e-4


def test_agrees_with_basilisk_scenario_attitude_feedback_rw():
    scen = basilisk_scenario()
    fix = np.load(scen.FIXTURE)
    w = lgvi.ReactionWheels(scen.WHEEL_AXES, scen.JS, speed0=scen.SPEED0, max_torque=scen.U_MAX,
                            max_speed=scen.OMEGA_MAX)
    traj = lgvi.simulate(lgvi.RigidBody(scen.HUB_INERTIA), matrix_from_mrp(scen.SIGMA0), omega0=scen.OMEGA0, h=0.1,
                         steps=6000, wheels=w, controller=MRPFeedback(scen.K, scen.P, inertia=scen.HUB_INERTIA),
                         control_period=0.1, save_every=10, scheme="rkmk4")
    ds, dw, dv = scen.differences(traj, fix)
    assert ds < 1e-6 and dw < 1e-7
    # in fact both are RK4 on the same zero-order hold: they agree to round-off (2.7e-14 measured)
    assert ds < 1e-12 and dw < 1e-13 and dv < 1e-9


def test_controller_nan_stops_with_the_part_computed():
    class Bad(Controller):
        def command(self, t, R, omega, wheel_speed, env):
            return Command(wheel_torque=[0.01, 0.0, 0.0, np.nan if t >= 1.0 else 0.0])

    with pytest.raises(lgvi.TorqueError, match="non-finite") as info:
        lgvi.simulate(BODY, R0, omega0=W0, h=0.01, steps=500, wheels=wheels(), controller=Bad(), control_period=0.1,
                      scheme="rkmk4")
    err = info.value
    assert err.step == 100 and err.trajectory.meta["partial"]
    assert len(err.trajectory.t) == 101 and np.all(np.isfinite(err.trajectory.R))


def test_large_rotation_per_step_is_refused_with_the_part_computed():
    """Cayley coordinates reach rotations below pi; beyond 90 degrees per step the run stops."""
    fast = np.array([0.0, 0.0, 20.0])           # 20 rad/s about the major axis
    ok = lgvi.simulate(BODY, R0, omega0=fast, h=0.07, steps=50, scheme="rkmk4")   # 80 degrees per step
    assert np.all(np.isfinite(ok.R))
    with pytest.raises(lgvi.ConvergenceError, match=r"step 0 .*Cayley coordinate \|theta\| = .* more than 90 "
                                                    r"degrees per step.*reduce h") as info:
        lgvi.simulate(BODY, R0, omega0=fast, h=0.1, steps=50, scheme="rkmk4")    # 115 degrees per step
    assert len(info.value.trajectory.t) == 1


def test_near_identity_steps_are_exact_for_a_sphere():
    """A spherical body turns at a constant rate: R(t) = R0 exp(t hat(w)); tiny and moderate steps."""
    sphere = lgvi.RigidBody([2.0, 2.0, 2.0])
    # measured: 5e-14 (round-off of 1000 quaternion products) and 3e-13 (RK4's error at h |w| = 0.004);
    # the LGVI (order 2) is 2e-5 off in the second case
    for w, h, tol in ((np.array([1e-9, -2e-9, 3e-9]), 0.1, 2e-13), (np.array([0.3, -0.2, 0.1]), 0.01, 1e-12),
                      (np.zeros(3), 0.1, 2e-16)):
        traj = lgvi.simulate(sphere, R0, omega0=w, h=h, steps=1000, save_every=100, scheme="rkmk4")
        exact = np.array([R0 @ lgvi.so3.exp(t * w) for t in traj.t])
        assert np.abs(traj.R - exact).max() < tol


@pytest.mark.parametrize("kw, match", [
    (dict(order=6), "order must be 4 .* with scheme='rkmk4'"),
    (dict(composition="suzuki4"), r"composition must be None or one of \['ralston4', 'rk38', 'rk4'\]"),
    (dict(torque=lgvi.torques.UniformGravity(1.0, [0.0, 0.0, 0.3])), "torque= is not available with "
                                                                     "scheme='rkmk4'"),
])
def test_bad_combinations_are_refused(kw, match):
    with pytest.raises(ValueError, match=match):
        lgvi.simulate(BODY, R0, omega0=W0, h=0.1, steps=10, wheels=wheels(), scheme="rkmk4", **kw)


def test_other_schemes_with_wheels_are_refused():
    with pytest.raises(ValueError, match="scheme='splitting' cannot be combined with wheels=.*'rkmk4'"):
        lgvi.simulate(BODY, R0, omega0=W0, h=0.1, steps=10, wheels=wheels(), scheme="splitting")
    from lgvi.systems.gyrostat import gyrostat_run

    with pytest.raises(ValueError, match="scheme must be None or 'lgvi' .* or 'rkmk4'"):
        gyrostat_run(BODY, R0, omega0=W0, h=0.1, steps=10, wheels=wheels(), scheme="rk4")
    run = gyrostat_run(BODY, R0, omega0=W0, h=0.1, steps=10, wheels=wheels(), scheme="rkmk4")
    assert run.meta["scheme"] == "rkmk4"


def test_free_body_without_wheels_runs_rkmk():
    traj = lgvi.simulate(BODY, R0, omega0=W0, h=0.01, steps=2000, save_every=100, scheme="rkmk4")
    ref = lgvi.simulate(BODY, R0, omega0=W0, h=0.01, steps=2000, save_every=100, order=6)
    assert np.abs(traj.R - ref.R).max() < 1e-9
    assert rel_drift(traj.spatial_momentum) < 1e-14


def test_environment_and_magnetorquers_are_a_held_body_torque():
    """A dipole through magnetorquers and the same torque given as Command.torque step the same,
    bit for bit, and agree with the LGVI at order 4."""
    B_N = np.array([2e-5, -1e-5, 3e-5])

    class Env:
        def sample(self, t):
            return {"B_inertial": B_N}

    class Rods:
        def torque(self, m, B):
            return np.cross(np.clip(m, -50, 50), B)

    class Dipole(Controller):
        def command(self, t, R, omega, wheel_speed, env):
            return Command(dipole=np.array([80.0, 10.0, -20.0]))

    class Same(Controller):
        def command(self, t, R, omega, wheel_speed, env):
            return Command(torque=np.cross(np.clip([80.0, 10.0, -20.0], -50, 50), R.T @ B_N))

    kw = dict(h=0.01, steps=1000, control_period=0.1, wheels=wheels())
    a = lgvi.simulate(BODY, R0, omega0=W0, controller=Dipole(), environment=Env(), magnetorquers=Rods(),
                      scheme="rkmk4", **kw)
    b = lgvi.simulate(BODY, R0, omega0=W0, controller=Same(), scheme="rkmk4", **kw)
    c = lgvi.simulate(BODY, R0, omega0=W0, controller=Same(), order=4, **kw)
    assert np.array_equal(a.R, b.R) and np.array_equal(a.Pi, b.Pi)
    assert np.abs(a.R - c.R).max() < 2e-9 and np.abs(a.Pi - c.Pi).max() < 2e-9      # measured 5.6e-10
    assert np.abs(a.spatial_momentum[-1] - a.spatial_momentum[0]).max() > 1e-4     # the torque acted
    assert a.meta["invariants"] == {}


def test_error_estimate_runs_the_same_scheme_at_half_the_step():
    kw = dict(h=0.05, steps=400, wheels=wheels(max_torque=0.05), controller=MRPFeedback(0.5, 2.0, target=R_REF),
              control_period=0.1, save_every=20)
    traj = lgvi.simulate(BODY, R0, omega0=W0, scheme="rkmk4", error_estimate=True, **kw)
    est = traj.meta["error_estimate"]
    assert est["order"] == 4 and est["h"] == 0.05
    # the estimate (Richardson, order 4) is near the actual error against a converged run
    ref = lgvi.simulate(BODY, R0, omega0=W0, **dict(kw, h=0.1 / 64, steps=400 * 32, save_every=640), order=6)
    actual = max(angle(a, b) for a, b in zip(ref.R, traj.R))
    assert 0.3 < est["attitude_max"] / actual < 3.0, (est["attitude_max"], actual)
