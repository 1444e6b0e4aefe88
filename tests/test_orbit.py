"""A rigid body in a central field (issue 16, part 1): ``lgvi.simulate_orbit``.

Units are normalised (``mu = 1``, a circular orbit of radius 1 has period 2 pi); the body is large
for its orbit (``tr(J) / (m r^2) ~ 0.1``) so that orbit and attitude are strongly coupled.
"""

from __future__ import annotations

import signal

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.systems import SYSTEMS
from lgvi.systems.orbit import OrbitTrajectory, orbit_equations

J = np.array([[0.04, 0.003, -0.002], [0.003, 0.06, 0.001], [-0.002, 0.001, 0.075]])
MASS = 1.0
X0 = [1.0, 0.0, 0.1]
V0 = [0.0, 1.15, 0.05]                      # eccentric (e ~ 0.3), inclined
OMEGA0 = [0.3, -0.4, 1.3]
R_GEN = Rotation.from_rotvec([0.4, -0.3, 0.8]).as_matrix()


def run(h, steps, R0=R_GEN, **kw):
    kw.setdefault("mu", 1.0)
    return lgvi.simulate_orbit(J, MASS, X0, V0, R0, omega0=OMEGA0, h=h, steps=steps, **kw)


def reference(T, R0=R_GEN, **kw):
    """The continuous equations at ``T`` by DOP853 (rtol 1e-13): ``(x, R)``."""
    f = orbit_equations(MASS, J, kw.pop("mu", 1.0), **kw)
    y0 = np.concatenate([X0, MASS * np.asarray(V0), np.asarray(R0).ravel(), J @ OMEGA0])
    sol = solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=1e-13, atol=1e-13)
    y = sol.y[:, -1]
    return y[0:3], y[6:15].reshape(3, 3)


def test_registered_with_its_invariants():
    system = SYSTEMS["orbit"]
    assert [f.name for f in system.state] == ["x", "p", "R", "Pi"]
    assert system.invariants({})["angular_momentum"]["kind"] == "exact"
    assert "angular_momentum" not in system.invariants({"J2": True})
    assert system.invariants({"J2": True})["angular_momentum_e3"]["kind"] == "exact"
    assert system.invariants({"torque": True}) == {}


def test_total_angular_momentum_is_exact_and_spin_orbit_exchange_it():
    traj = run(0.02, 3000)
    L = traj.angular_momentum
    scale = np.linalg.norm(L[0])
    assert np.linalg.norm(L - L[0], axis=1).max() < 5e-14 * scale
    # a test that can fail: the spin and the orbit exchange momentum (the coupling is real)
    spin = traj.spatial_momentum
    assert np.linalg.norm(spin - spin[0], axis=1).max() > 1e-4 * scale
    assert traj.meta["invariants"]["angular_momentum"]["kind"] == "exact"


def test_energy_is_bounded_over_many_orbits():
    # 100 orbits (about 630 time units) at 100 steps an orbit on average
    traj = run(0.0625, 10_240, save_every=10)
    E = traj.energy
    dE = np.abs(E - E[0])
    n = len(E) // 5
    first, last = dE[:n].max(), dE[-n:].max()
    assert first < 2e-3 * abs(E[0])
    assert last < 1.5 * first             # no drift: the last fifth oscillates like the first
    slope = np.polyfit(traj.t, E - E[0], 1)[0] * traj.t[-1]
    assert abs(slope) < 0.05 * first


@pytest.mark.parametrize("R0", [np.eye(3), Rotation.from_rotvec(np.pi * np.array([0.6, 0.0, 0.8])).as_matrix(),
                                R_GEN], ids=["identity", "pi", "general"])
def test_second_order_against_dop853(R0):
    T = 2.0
    x_ref, R_ref = reference(T, R0)
    errs = []
    hs = [0.04, 0.02, 0.01]
    for h in hs:
        traj = run(h, int(round(T / h)), R0)
        errs.append(max(np.linalg.norm(traj.x[-1] - x_ref), np.linalg.norm(traj.R[-1] - R_ref)))
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 1.9 < slope < 2.1, (errs, slope)
    assert errs[-1] < 3e-4


def test_near_identity_and_near_pi_keep_the_invariants():
    for R0 in (Rotation.from_rotvec([1e-9, -2e-9, 0.0]).as_matrix(),
               Rotation.from_rotvec((np.pi - 1e-9) * np.array([0.0, 0.6, 0.8])).as_matrix()):
        traj = run(0.05, 400, R0)
        L = traj.angular_momentum
        assert np.linalg.norm(L - L[0], axis=1).max() < 5e-14 * np.linalg.norm(L[0])
        assert np.abs(np.einsum("kji,kjl->kil", traj.R, traj.R) - np.eye(3)).max() < 1e-13


def test_j2_keeps_the_polar_momentum_only():
    traj = run(0.02, 2000, J2=0.05, radius=0.5)
    L = traj.angular_momentum
    scale = np.linalg.norm(L[0])
    assert np.abs(L[:, 2] - L[0, 2]).max() < 5e-14 * scale
    assert np.abs(L[:, :2] - L[0, :2]).max() > 1e-3 * scale     # J2 turns the orbit plane
    E = traj.energy
    assert np.ptp(E) < 2e-3 * abs(E[0])
    assert "angular_momentum" not in traj.meta["invariants"]
    # J2 reaches the reference equations too: second order against DOP853 with J2
    x_ref, _ = reference(1.0, J2=0.05, radius=0.5)
    e1 = np.linalg.norm(run(0.02, 50, J2=0.05, radius=0.5).x[-1] - x_ref)
    e2 = np.linalg.norm(run(0.01, 100, J2=0.05, radius=0.5).x[-1] - x_ref)
    assert 3.5 < e1 / e2 < 4.5


def test_point_mass_is_kepler_and_a_free_spin():
    traj = run(0.01, 300, potential="point")
    # the attitude is that of the free body: lgvi.simulate with the same step, bit for bit in spirit
    free = lgvi.simulate(J, R_GEN, omega0=OMEGA0, h=0.01, steps=300, method="cayley")
    assert np.abs(traj.R[-1] - free.R[-1]).max() < 1e-12
    x_ref, _ = reference(3.0, potential="point")
    assert np.linalg.norm(traj.x[-1] - x_ref) < 1e-4


def test_extra_torque_is_applied_and_breaks_the_invariant():
    u = np.array([0.0, 0.0, 0.01])
    traj = run(0.01, 200, torque=u)
    assert traj.meta["invariants"] == {}
    free = run(0.01, 200)
    dL = traj.angular_momentum[-1] - free.angular_momentum[-1]
    # the inertial moment integrated: about 2 time units of R u
    assert 0.005 < np.linalg.norm(dL) < 0.03
    x_ref, R_ref = reference(2.0, torque=u)
    assert np.linalg.norm(traj.R[-1] - R_ref) < 1e-3
    grid = np.tile(u, (201, 1))
    assert np.array_equal(run(0.01, 200, torque=grid).R, traj.R)


def test_save_load_roundtrip(tmp_path):
    traj = run(0.05, 40, save_every=4)
    path = tmp_path / "orbit.npz"
    traj.save(path)
    back = OrbitTrajectory.load(path)
    for key in ("t", "x", "p", "R", "Pi", "iterations", "inertia"):
        assert np.array_equal(getattr(back, key), getattr(traj, key))
    assert back.meta["invariants"] == traj.meta["invariants"]
    assert np.array_equal(back.energy, traj.energy)
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(ValueError, match="other.npz"):
        OrbitTrajectory.load(tmp_path / "other.npz")


def test_chunks_and_progress_match_one_run_and_ctrl_c_keeps_the_part():
    from lgvi.systems import orbit as mod

    whole = run(0.05, 64, save_every=2)
    old = mod.CHUNK_STEPS
    seen = []
    try:
        mod.CHUNK_STEPS = 8
        parts = run(0.05, 64, save_every=2, progress=lambda k, n: seen.append(k))
        assert seen == list(range(8, 65, 8))
        for key in ("x", "p", "R", "Pi"):
            assert np.array_equal(getattr(parts, key), getattr(whole, key))

        def stop(k, n):
            if k == 16:
                signal.raise_signal(signal.SIGINT)   # delivered to this (the main) thread before it returns

        with pytest.raises(lgvi.SimulationInterrupted) as info:
            run(0.05, 64, save_every=2, progress=stop)
    finally:
        mod.CHUNK_STEPS = old
    part = info.value.trajectory
    assert part.meta["partial"] is True and len(part.t) == 9
    assert np.array_equal(part.x, whole.x[:9])


def test_failure_raises_with_the_part():
    # a body started at the centre's doorstep with no angular momentum falls in: non-finite state
    with pytest.raises(lgvi.ConvergenceError, match="orbit step") as info:
        lgvi.simulate_orbit(J, MASS, [1e-3, 0, 0], [0, 0, 0], np.eye(3), omega0=OMEGA0, h=0.01, steps=1000, mu=1.0)
    part = info.value.trajectory
    assert part is not None and np.all(np.isfinite(part.x))
