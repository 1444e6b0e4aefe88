"""Monte Carlo dispersions with reaction wheels: ``simulate_ensemble(..., wheels=, controller=)``.

Member ``b`` equals ``lgvi.simulate`` with its inputs bit for bit (serial and threaded), the
dispersions (inertia, wheel misalignment, initial wheel speeds, gains) are recorded, bad inputs
are named.
"""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi.control import MRPFeedback, RotationPD

B = 5
RPM = 2 * np.pi / 60
RNG = np.random.default_rng(3)
J0 = np.diag([900.0, 800.0, 600.0])
INERTIA = np.array([J0 * (1 + 0.05 * RNG.normal(size=3)) for _ in range(B)])      # (B, 3, 3) diagonal
MISALIGN = [lgvi.so3.exp(np.radians(0.5) * RNG.normal(size=3)) for _ in range(B)]
WHEELS = [lgvi.ReactionWheels(np.eye(3) @ M.T, 0.08, speed0=(np.array([100.0, 200.0, 300.0]) + 20 * RNG.normal(size=3))
                              * RPM, max_torque=0.2, max_speed=6000 * RPM) for M in MISALIGN]
GAINS = [(3.5 * (1 + 0.1 * RNG.normal()), 30.0 * (1 + 0.1 * RNG.normal())) for _ in range(B)]
R0 = lgvi.so3.exp(0.2 * RNG.normal(size=(B, 3)))
W0 = np.array([0.001, -0.01, 0.03]) + 1e-3 * RNG.normal(size=(B, 3))
H, STEPS = 0.1, 600


def mrp(b):
    return MRPFeedback(K=GAINS[b][0], P=GAINS[b][1])


@pytest.mark.parametrize("threads", [1, 2])
def test_members_equal_simulate_bit_for_bit_and_dispersions_are_recorded(threads):
    ens = lgvi.simulate_ensemble(INERTIA, R0, omega0=W0, h=H, steps=STEPS, wheels=WHEELS,
                                 controller=[mrp(b) for b in range(B)], control_period=H, threads=threads,
                                 save_every=10)
    assert ens.R.shape == (B, STEPS // 10 + 1, 3, 3) and ens.wheel_speed.shape == (B, STEPS // 10 + 1, 3)
    for b in (0, 3, B - 1):
        one = lgvi.simulate(INERTIA[b], R0[b], omega0=W0[b], h=H, steps=STEPS, wheels=WHEELS[b], controller=mrp(b),
                            control_period=H, save_every=10)
        for name in ("R", "Pi", "wheel_momentum", "wheel_torque"):
            assert np.array_equal(getattr(ens[b], name), getattr(one, name)), (b, name)
            assert np.array_equal(getattr(ens, name)[b], getattr(one, name)), (b, name)
    d = ens.dispersions
    for key in ("inertia", "R0", "Pi0", "wheels.axes", "wheels.speed0", "controller.K", "controller.P"):
        assert key in d, (key, sorted(d))
    assert "wheels.spin_inertia" not in d and "wheels.max_torque" in ens.params
    assert np.array_equal(d["inertia"], INERTIA)
    assert np.array_equal(d["controller.K"], [g[0] for g in GAINS])
    assert np.array_equal(d["wheels.axes"], np.stack([w.axes for w in WHEELS]))
    assert np.array_equal(d["wheels.speed0"], np.stack([w.speed0 for w in WHEELS]))
    assert ens.meta["threads"] == threads
    # the dispersions matter: the members' wheel speeds part by more than 1 rpm
    assert np.ptp(ens.wheel_speed[:, -1, 0]) > RPM


def test_one_python_controller_for_all_is_copied_per_member_and_threads_change_no_bit():
    pd = RotationPD(2.0, 40.0)
    kw = dict(omega0=W0, h=H, steps=300, wheels=WHEELS[0], controller=pd, control_period=0.5, save_every=30)
    serial = lgvi.simulate_ensemble(J0, R0, threads=1, **kw)
    threaded = lgvi.simulate_ensemble(J0, R0, threads=2, **kw)
    assert np.array_equal(serial.R, threaded.R) and np.array_equal(serial.wheel_torque, threaded.wheel_torque)
    one = lgvi.simulate(J0, R0[2], omega0=W0[2], h=H, steps=300, wheels=WHEELS[0], controller=RotationPD(2.0, 40.0),
                        control_period=0.5, save_every=30)
    assert np.array_equal(serial.R[2], one.R)
    assert serial.dispersions.keys() == {"R0", "Pi0"}


def _sim(**kw):
    base = dict(omega0=W0, h=H, steps=10, wheels=WHEELS, controller=mrp(0), control_period=H)
    base.update(kw)
    return lgvi.simulate_ensemble(INERTIA, R0, **base)


@pytest.mark.parametrize("kw,exc,pattern", [
    (dict(wheels=WHEELS[:3]), ValueError, r"wheels gives 3 entries but R0 has 5"),
    (dict(wheels=WHEELS[:4] + [np.eye(3)]), TypeError, r"wheels\[4\] must be an lgvi\.ReactionWheels, got ndarray"),
    (dict(wheels=WHEELS[:4] + [lgvi.ReactionWheels(np.eye(2, 3), 0.08)]), ValueError,
     r"wheels must have the same number of wheels in every member, got \[2, 3\]"),
    (dict(controller=[mrp(0)] * 4 + ["pd"]), TypeError, r"controller\[4\] must be an lgvi\.control\.Controller"),
    (dict(wheels=WHEELS[:4] + [lgvi.ReactionWheels(np.eye(3), 700.0)]), ValueError,
     r"member 4: .*wheels"),
    (dict(out_dir="x"), ValueError, r"out_dir='x' cannot be combined with wheels="),
    (dict(progress=True), ValueError, r"progress=True cannot be combined with wheels="),
    (dict(threads=0), ValueError, r"threads"),
])
def test_bad_inputs_are_named(kw, exc, pattern):
    with pytest.raises(exc, match=pattern):
        _sim(**kw)
