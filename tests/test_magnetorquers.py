"""Magnetorquers and the magnetic control laws (issue 12, part 3).

* ``Magnetorquers.torque`` is ``m x B`` with the request mapped to the rods by least squares and
  each rod clipped at its limit (not the whole vector scaled).
* ``BDot`` with the rate form never adds rotational energy (``omega . (m x B) <= 0``), and the
  difference form is ``-k dB/dt``: for a body spinning in a constant field it equals the rate form
  to first order in the control period.
* ``MomentumDumping``'s torque is ``-k h_perp``: it removes the wheels' momentum across the field.
"""

from __future__ import annotations

import types

import numpy as np
import pytest

import lgvi
from lgvi.control import Command, Controller
from lgvi.environment import BDot, MomentumDumping
from lgvi.so3 import exp


def test_torque_is_m_cross_b_with_per_rod_saturation():
    rods = lgvi.Magnetorquers(np.eye(3), max_dipole=[0.2, 0.5, 1.0])
    B = np.array([2e-5, -3e-5, 4e-5])
    m = np.array([0.1, -0.3, 0.2])
    assert np.allclose(rods.torque(m, B), np.cross(m, B), rtol=1e-15, atol=0)
    big = np.array([1.0, -2.0, 0.5])
    assert np.allclose(rods.rod_dipoles(big), [0.2, -0.5, 0.5])
    assert np.allclose(rods.torque(big, B), np.cross([0.2, -0.5, 0.5], B), rtol=1e-15, atol=0)


def test_skewed_and_redundant_rods():
    axes = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]) / np.array([1, 1, 1, np.sqrt(3)])[:, None]
    rods = lgvi.Magnetorquers(axes, max_dipole=10.0)
    m = np.array([0.3, -0.1, 0.7])
    assert np.allclose(rods.dipole(m), m, atol=1e-15)                 # reproduced when nothing saturates
    d = rods.rod_dipoles(m)
    assert np.isclose(d @ d, np.linalg.lstsq(axes.T, m, rcond=None)[0] @ np.linalg.lstsq(axes.T, m, rcond=None)[0])
    two = lgvi.Magnetorquers([[1.0, 0, 0], [0, 1.0, 0]], 1.0)         # no z rod: the z part is lost
    assert np.allclose(two.dipole([0.1, 0.2, 0.3]), [0.1, 0.2, 0.0])


def test_bdot_rate_form_never_adds_energy():
    rng = np.random.default_rng(0)
    ctrl = BDot(5e4, derivative="rate")
    assert isinstance(ctrl, Controller)
    for _ in range(50):
        R = exp(rng.normal(size=3))
        w = rng.normal(size=3) * 0.1
        Bi = rng.normal(size=3) * 3e-5
        cmd = ctrl.command(0.0, R, w, np.zeros(0), {"B_inertial": Bi})
        assert isinstance(cmd, Command) and cmd.torque is None and cmd.wheel_torque is None
        tau = np.cross(cmd.dipole, R.T @ Bi)
        assert w @ tau <= 1e-30
        Bb = R.T @ Bi
        assert np.allclose(tau, -5e4 * (w * (Bb @ Bb) - Bb * (Bb @ w)), rtol=1e-12, atol=1e-30)


def test_bdot_difference_form_is_minus_k_dbdt():
    ctrl = BDot(2.0)
    w = np.array([0.02, -0.05, 0.1])
    Bi = np.array([1e-5, 2e-5, -3e-5])
    dt = 1e-3
    first = ctrl.command(0.0, np.eye(3), w, np.zeros(0), {"B_inertial": Bi})
    assert np.array_equal(first.dipole, np.zeros(3))                 # nothing to difference yet
    R1 = exp(w * dt)
    second = ctrl.command(dt, R1, w, np.zeros(0), {"B_inertial": Bi})
    rate = BDot(2.0, derivative="rate").command(dt, R1, w, np.zeros(0), {"B_inertial": Bi})
    assert np.allclose(second.dipole, rate.dipole, rtol=0, atol=1e-3 * np.linalg.norm(rate.dipole))
    ctrl.reset()
    assert np.array_equal(ctrl.command(dt, R1, w, np.zeros(0), {"B_body": R1.T @ Bi}).dipole, np.zeros(3))


def test_momentum_dumping_torque_removes_the_wheel_momentum_across_the_field():
    wheels = types.SimpleNamespace(axes=np.eye(3), spin_inertia=np.array([0.01, 0.02, 0.03]))
    ctrl = MomentumDumping(0.05, wheels=wheels)
    w = np.array([0.001, -0.002, 0.0005])
    speeds = np.array([100.0, -50.0, 30.0])
    B = np.array([1e-5, -2e-5, 3e-5])
    cmd = ctrl.command(0.0, np.eye(3), w, speeds, {"B_body": B})
    h = wheels.spin_inertia * (w + speeds)
    h_perp = h - B * (B @ h) / (B @ B)
    assert np.allclose(np.cross(cmd.dipole, B), -0.05 * h_perp, rtol=1e-12, atol=0)
    assert cmd.torque is None and cmd.wheel_torque is None


def test_momentum_dumping_passes_the_attitude_controller_on():
    class Fixed(Controller):
        def command(self, t, R, omega, wheel_speed, env):
            return Command(wheel_torque=np.array([0.1, 0.2, 0.3]))

    wheels = types.SimpleNamespace(axes=np.eye(3), spin_inertia=np.ones(3))
    cmd = MomentumDumping(0.1, controller=Fixed(), wheels=wheels).command(
        0.0, np.eye(3), np.zeros(3), np.ones(3), {"B_body": [0.0, 0.0, 1e-5]})
    assert np.array_equal(cmd.wheel_torque, [0.1, 0.2, 0.3]) and np.allclose(cmd.dipole, [1e4, -1e4, 0.0])


def test_controllers_need_the_field():
    with pytest.raises(KeyError, match="B_inertial"):
        BDot(1.0).command(0.0, np.eye(3), np.zeros(3), np.zeros(0), {"r": np.ones(3)})


# ---- through lgvi.simulate (the control loop of the gyrostat) --------------------------------
def _dumping_run(k: float | None):
    import datetime as dt

    from lgvi.control import MRPFeedback
    from lgvi.environment import CentredDipole, CircularOrbit, OrbitEnvironment

    orbit = CircularOrbit(7.0e6, np.radians(90.0))
    env = OrbitEnvironment(orbit, CentredDipole(), epoch=dt.datetime(2026, 1, 1))
    wheels = lgvi.ReactionWheels(np.eye(3), 0.01, speed0=[20.0, -15.0, 10.0])
    attitude = MRPFeedback(K=0.5, P=5.0)
    ctrl = attitude if k is None else MomentumDumping(k, controller=attitude)
    return lgvi.simulate(lgvi.RigidBody([10.0, 12.0, 14.0]), np.eye(3), omega0=np.zeros(3), h=1.0, steps=5800,
                         wheels=wheels, controller=ctrl, control_period=2.0, environment=env,
                         magnetorquers=lgvi.Magnetorquers(np.eye(3), 10.0), save_every=50)


def test_momentum_dumping_empties_the_wheels_in_orbit():
    held = _dumping_run(None)                       # no dipole: the wheels keep their momentum
    dumped = _dumping_run(1e-3)
    h_held = np.linalg.norm(held.wheel_momentum, axis=1)
    h_dumped = np.linalg.norm(dumped.wheel_momentum, axis=1)
    assert np.isclose(h_dumped[0], np.linalg.norm([0.2, 0.15, 0.1]), rtol=1e-12)
    assert np.allclose(h_held, h_held[0], rtol=1e-3)
    assert h_dumped[-1] < 0.1 * h_dumped[0]
    angle = np.linalg.norm(lgvi.so3.log(dumped.R), axis=-1)
    assert angle.max() < 0.05                        # the attitude is held meanwhile (rad)
