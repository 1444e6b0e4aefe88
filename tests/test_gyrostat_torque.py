"""A compiled torque model beside reaction wheels or a controller (``simulate(..., wheels=, torque=)``).

The model's moment enters the gyrostat step in the variational form of a time-dependent potential
(``lgvi._kernels.gyrostat_kernels.gyro_steps``): checked against the rigid body's own forced LGVI,
against the exact discrete momentum balance, and bit for bit against no model when it is zero.
"""

from __future__ import annotations

import numpy as np
import pytest

numba = pytest.importorskip("numba")

import lgvi  # noqa: E402
from lgvi.control import Command, Controller  # noqa: E402
from lgvi.environment import CircularOrbit, OrbitGravityGradient  # noqa: E402
from lgvi.torques import Compiled  # noqa: E402

J = np.array([[2.0, 0.1, 0.0], [0.1, 3.0, -0.2], [0.0, -0.2, 4.0]])
R0 = lgvi.so3.exp([0.3, -0.2, 0.5])
W0 = np.array([0.02, -0.01, 0.03])
ORBIT = CircularOrbit(6371e3 + 500e3, np.radians(51.6))
AXES = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]) / np.array(
    [[1.0], [1.0], [1.0], [np.sqrt(3.0)]])
WHEELS = lgvi.ReactionWheels(AXES, [0.01, 0.02, 0.015, 0.01], speed0=[30.0, -20.0, 10.0, 5.0],
                             friction={"coulomb": 1e-4, "viscous": 1e-5})


@numba.njit
def _spring(t, R, Pi, p):
    # the moment of U = p0 (1 - R[2, 2]) plus a time-dependent pull (not conservative in t)
    return (-p[0] * R[2, 1] + p[1] * np.sin(t), p[0] * R[2, 0], 0.0)


class Nothing(Controller):
    """A controller that commands nothing (puts the run on the gyrostat path without wheels)."""

    def command(self, t, R, omega, wheel_speed, env):
        return Command()


class Wobble(Controller):
    """Wheel motor torques that change every call."""

    def command(self, t, R, omega, wheel_speed, env):
        return Command(wheel_torque=1e-3 * np.array([np.sin(t), np.cos(2 * t), -np.sin(3 * t), 0.5]))


def gravity(duration):
    return OrbitGravityGradient(ORBIT, J, duration=duration)


@pytest.mark.parametrize("order", [2, 4])
def test_without_wheels_equals_the_rigid_body_lgvi(order):
    # no wheels, a controller that does nothing: the gyrostat step with the model is the rigid
    # body's forced (symmetric) LGVI with it; both solve to 1e-14, different Newton iterations
    h, steps = 1.0, 600
    model = gravity(h * steps)
    rigid = lgvi.simulate(J, R0, omega0=W0, h=h, steps=steps, torque=model, order=order)
    gyro = lgvi.simulate(J, R0, omega0=W0, h=h, steps=steps, torque=model, order=order, controller=Nothing(),
                         control_period=h)
    assert np.abs(gyro.R - rigid.R).max() < 1e-12
    assert np.abs(gyro.Pi - rigid.Pi).max() < 1e-12 * np.abs(rigid.Pi).max()
    # the model acted: without it the runs part by far more than that
    free = lgvi.simulate(J, R0, omega0=W0, h=h, steps=steps, order=order)
    assert np.abs(free.Pi - rigid.Pi).max() > 1e-6 * np.abs(rigid.Pi).max()


def test_total_momentum_balance_is_exact_with_wheels():
    # R_{k+1} Pi_{k+1} - R_k Pi_k = h/2 (R_k M_k + R_{k+1} M_{k+1}): the inertial momentum (hub plus
    # wheels) changes by the trapezoid of the model's moment, whatever the wheels do
    h, steps = 0.05, 400
    model = Compiled(_spring, params=[0.3, 0.05])
    traj = lgvi.simulate(J, R0, omega0=W0, h=h, steps=steps, wheels=WHEELS, torque=model, controller=Wobble(),
                         control_period=2 * h)
    M = np.array([_spring(t, R, P, model.params) for t, R, P in zip(traj.t, traj.R, traj.Pi)])
    L = np.einsum("kij,kj->ki", traj.R, traj.Pi)
    RM = np.einsum("kij,kj->ki", traj.R, M)
    balance = (L[1:] - L[:-1]) - 0.5 * h * (RM[1:] + RM[:-1])
    assert np.abs(balance).max() < 1e-14 * np.abs(L).max() * 20
    assert np.abs(L[-1] - L[0]).max() > 1e-3 * np.abs(L).max()       # the model changed it
    assert np.abs(traj.wheel_torque).max() > 5e-4                     # and the wheels turned


def test_a_zero_model_changes_no_bit():
    h, steps = 0.05, 200
    kw = dict(omega0=W0, h=h, steps=steps, wheels=WHEELS, controller=Wobble(), control_period=2 * h)
    ref = lgvi.simulate(J, R0, **kw)
    zero = lgvi.simulate(J, R0, torque=Compiled(_spring, params=[0.0, 0.0]), **kw)   # one compile less
    for name in ("R", "Pi", "wheel_momentum", "wheel_torque"):
        assert np.array_equal(getattr(ref, name), getattr(zero, name)), name
    assert "spatial_momentum" in ref.meta["invariants"] and zero.meta["invariants"] == {}


def test_a_non_finite_moment_stops_the_run_with_the_part_computed():
    # the tabulated orbit ends at t = 10 s (two nodes 10 s apart): past it the moment is NaN
    with pytest.raises(lgvi.ConvergenceError) as info:
        lgvi.simulate(J, R0, omega0=W0, h=0.1, steps=150, wheels=WHEELS, torque=gravity(1.0))
    part = info.value.trajectory
    assert part is not None and 99 <= len(part.t) - 1 <= 100, len(part.t)
    assert np.all(np.isfinite(part.Pi)) and np.all(np.isfinite(part.wheel_momentum))


@numba.njit
def _pi_damping(t, R, Pi, p):
    return (-Pi[0], -Pi[1], -Pi[2])


def test_a_momentum_dependent_model_is_refused_by_name():
    # (here, not in test_bad_inputs: that table also runs interpreted, where Compiled needs Numba)
    with pytest.raises(ValueError, match=r"torque= with wheels= or controller= must not depend on Pi"):
        lgvi.simulate(J, R0, omega0=W0, h=0.1, steps=5, wheels=WHEELS,
                      torque=Compiled(_pi_damping, momentum_dependent=True))


@numba.njit
def _fails_late(t, R, Pi, p):
    # a spring about e3, and from t = p[0] on a division by zero (0 < p[0]: never at the first sample)
    c = 0.0 if t < p[0] else 1.0 / (t - t)
    return (-0.1 * R[2, 1] + c, 0.1 * R[2, 0], 0.0)


def test_an_exception_in_the_compiled_loop_stops_at_its_step_and_keeps_the_part():
    # the user's function is called through its guarded cfunc (one cached loop for every model): what
    # it raises stops the run at its step with a TorqueError naming it, the part up to that step kept
    kw = dict(omega0=W0, h=0.01, steps=300, save_every=3, wheels=WHEELS)
    with pytest.raises(lgvi.TorqueError, match=r"Compiled\(_fails_late.*raised an exception inside the compiled "
                                               r"loop at step 149 \(t = 1.49\).*ZeroDivisionError") as info:
        lgvi.simulate(J, R0, torque=Compiled(_fails_late, params=[1.5]), **kw)
    err = info.value
    part = err.trajectory
    clean = lgvi.simulate(J, R0, torque=Compiled(_fails_late, params=[1e9]), **kw)
    assert err.step == 149 and part.meta["partial"] and len(part.t) == 50
    for name in ("R", "Pi", "wheel_momentum"):
        assert np.array_equal(getattr(part, name), getattr(clean, name)[:50]), name
