"""The slosh hub with reaction wheels and the compiled MRP feedback (issue 30, part 2: "usable with the
wheels and the control loop"): ``lgvi.simulate_slosh(..., wheels=, controller=, wheel_torque=)``.

References: the code before the kernel took wheels (``benchmarks/slosh_no_wheels.npz``, made by
``benchmarks/slosh_no_wheels.py`` from commit 864252c), lgvi's gyrostat (the same wheels, the same
controller) in the limit of massless pendulums, and an independent formulation in maximal coordinates
with the wheels in Euler's law of the hub (``newton_euler(..., wheels=)``) integrated by DOP853.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lgvi
from lgvi.systems.gyrostat import simulate_gyrostat
from lgvi.systems.slosh import newton_euler, newton_euler_split, newton_euler_state, slosh_parameters
from scenario_cases import SLOSH_HUB, assert_scenario_error, cut_and_resume

EPS = np.finfo(float).eps
BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
J = [900.0, 800.0, 600.0]
M0 = 1500.0
PIV = [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]]
LEN = [0.3, 0.4]
MASS = [40.0, 60.0]
Q0 = np.array([[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]])
QD0 = np.array([[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]])
W0 = np.array([0.03, -0.02, 0.05])
DAMP = [30.0, 50.0]
# four wheels, one skewed; spin inertia 0.08 kg m^2
AXES = np.vstack([np.eye(3), np.full(3, 1.0 / np.sqrt(3.0))])
JS = 0.08
SPEED0 = [10.0, 20.0, 30.0, -5.0]
U = np.array([0.05, -0.03, 0.02, 0.04])          # constant motor commands [N m]


def wheels(**kw):
    return lgvi.ReactionWheels(AXES, JS, speed0=SPEED0, **kw)


def slosh(h, steps, masses=MASS, R0=np.eye(3), **kw):
    return lgvi.simulate_slosh(J, M0, PIV, LEN, masses, R0, Q0, QD0, omega0=W0, h=h, steps=steps, **kw)


def test_without_wheels_the_kernel_gives_the_numbers_of_the_code_before_it():
    """The kernel now carries the wheels; without them it must be the slosh hub it was (commit
    864252c): the fixture holds that code's states (damped at order 2, undamped at order 4). Equal
    to round-off here (bit for bit on the machine that made the fixture: the same operations)."""
    sys.path.insert(0, str(BENCH))
    try:
        import slosh_no_wheels as before
    finally:
        sys.path.remove(str(BENCH))
    ref = np.load(BENCH / "slosh_no_wheels.npz")
    for name in before.RUNS:
        traj = before.run(name)
        assert traj.wheel_momentum.shape == (len(traj.t), 0) and traj.n_wheels == 0
        for f in ("R", "Pi", "q", "pi"):
            a, b = getattr(traj, f), ref[f"{name}_{f}"]
            # 400 steps of a chaotic flow: a libm ulp at the first step grows a few hundred times at most
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * np.abs(b).max(), err_msg=f"{name} {f}")


@pytest.mark.parametrize("damping", [None, DAMP])
def test_total_angular_momentum_exact_while_the_motors_spin_the_wheels_up_and_down(damping):
    N = 3000
    t = 0.01 * np.arange(N)[:, None]
    u = 0.3 * np.sin(t * np.array([0.7, 1.3, 2.1, 0.4]))           # up and down, one row a step
    traj = slosh(0.01, N, save_every=10, damping=damping, wheels=wheels(), wheel_torque=u)
    L = traj.angular_momentum
    assert np.abs(L - L[0]).max() < 4 * np.sqrt(N) * EPS * np.abs(L[0]).max()
    # what the motors do shows: the wheels' momenta swing (a test that can fail) and the wheel
    # momenta follow rho_{k+1} = rho_k + h u exactly summed
    rho = traj.wheel_momentum
    np.testing.assert_allclose(rho[-1] - rho[0], 0.01 * u.sum(axis=0), rtol=0, atol=1e-12)
    assert np.ptp(rho, axis=0).min() > 0.05
    np.testing.assert_array_equal(traj.wheel_torque, u[::10])      # the record: each interval's first step
    hub = np.einsum("tab,tb->ta", traj.R, traj.Pi - rho @ AXES)
    assert np.ptp(hub, axis=0).max() > 0.1                           # the hub's share moves too
    assert traj.unit_error.max() <= 2 * EPS and traj.orthogonality_error.max() < 4 * np.sqrt(N) * EPS
    assert traj.meta["invariants"] == {"angular_momentum": {"kind": "exact"}}


def test_massless_pendulums_give_the_gyrostat_with_the_same_wheels_and_controller():
    """With the pendulum masses -> 0 the hub is lgvi's gyrostat: the same discrete equations (the
    Routhian with the shifted matrix), solved by another Newton. The difference is the pendulums'
    physical effect, linear in their mass, down to round-off."""
    R0 = lgvi.so3.exp(np.array([0.4, -0.3, 0.2]))
    kw = dict(h=0.1, steps=600, save_every=60, control_period=0.1)
    gyro = simulate_gyrostat(np.diag(J), R0, omega0=W0, wheels=wheels(max_torque=5.0),
                             controller=lgvi.control.MRPFeedback(K=3.5, P=30.0), **kw)
    diffs = []
    for m in (1e-3, 1e-6, 1e-9):
        traj = slosh(masses=[m, m], R0=R0, wheels=wheels(max_torque=5.0),
                     controller=lgvi.control.MRPFeedback(K=3.5, P=30.0), **kw)
        diffs.append(max(np.abs(traj.R - gyro.R).max(), np.abs(traj.Pi - gyro.Pi).max() / np.abs(gyro.Pi).max(),
                         np.abs(traj.wheel_momentum - gyro.wheel_momentum).max() / np.abs(gyro.wheel_momentum).max()))
    ratios = np.array(diffs[:-1]) / np.array(diffs[1:])
    assert np.all(np.abs(ratios / 1e3 - 1.0) < 0.02), diffs          # linear in the mass
    assert diffs[-1] < 1e-11                                         # m = 1e-9 kg: round-off level
    assert np.abs(gyro.R[-1] - gyro.R[0]).max() > 0.1                 # the controller did turn it
    assert np.abs(gyro.wheel_torque).max() < 5.0                       # unsaturated: the wheels follow the law


def reference(T, damping, rtol):
    """``(R, q, rho)`` at ``T``: maximal coordinates with the wheels in the hub's Euler law, DOP853."""
    P = slosh_parameters(np.diag(J), M0, PIV, LEN, MASS)
    rho0 = JS * (AXES @ W0 + SPEED0)
    sol = solve_ivp(newton_euler(P, damping, (AXES, np.full(4, JS), U)), (0.0, T),
                    newton_euler_state(P, np.eye(3), W0, Q0, QD0, rho0), method="DOP853", rtol=rtol, atol=rtol)
    R, q = newton_euler_split(P, sol.y[:, -1])
    return R, q, sol.y[18 + 6 * len(LEN):, -1]


@pytest.mark.parametrize("order, hs, rtol", [(2, (0.02, 0.01, 0.005), 1e-12), (4, (0.08, 0.04, 0.02), 1e-13)])
@pytest.mark.parametrize("damping", [None, DAMP])
def test_order_against_dop853_with_motors_on(order, hs, rtol, damping):
    T = 4.0
    Rr, qr, rr = reference(T, damping, rtol)
    errs = []
    for h in hs:
        n = int(round(T / h))
        traj = slosh(h, n, save_every=n, order=order, damping=damping, wheels=wheels(), wheel_torque=U)
        errs.append(max(np.abs(traj.R[-1] - Rr).max(), np.abs(traj.q[-1] - qr).max()))
        np.testing.assert_allclose(traj.wheel_momentum[-1], rr, rtol=0, atol=1e-12)    # rho' = u: exact
    slopes = np.diff(np.log(errs)) / np.diff(np.log(hs))
    assert np.all(np.abs(slopes - order) < 0.25), (errs, slopes)


def test_energy_bounded_with_the_motors_off():
    """Motors off, no friction, no damping: the wheel momenta are constant, the step is symplectic on
    the reduced space, the energy (with ``sum rho^2 / 2 Js``) oscillates at O(h^2) and does not drift."""
    errs = []
    for h, n in ((0.02, 10000), (0.01, 20000)):
        traj = slosh(h, n, save_every=n // 1000, wheels=wheels())
        assert np.array_equal(traj.wheel_momentum, np.broadcast_to(traj.wheel_momentum[0], traj.wheel_momentum.shape))
        E = traj.energy
        err = np.abs(E - E[0])
        tenth = len(E) // 10
        assert err[-tenth:].max() <= 1.5 * err[:tenth].max() + 1e-12 * E[0]     # no drift over 200 s
        errs.append(err.max())
    assert 3.5 < errs[0] / errs[1] < 4.5, errs                                  # second order
    assert traj.meta["invariants"] == {"angular_momentum": {"kind": "exact"}, "energy": {"kind": "bounded"}}


@pytest.mark.parametrize("damping", [DAMP, None])
def test_mrp_feedback_slews_the_hub_and_the_slosh_settles(damping):
    """The compiled MRP feedback turns the hub with sloshing propellant 40 degrees to a target; with the
    pendulums damped the slosh dies out and, the hub at rest, the wheels hold the whole angular
    momentum; undamped, the pendulums keep swinging and the hub keeps wandering."""
    target = lgvi.so3.exp(np.array([0.3, -0.5, 0.4]))
    rw = lgvi.ReactionWheels(np.eye(3), JS, speed0=[10.0, -20.0, 30.0], max_torque=2.0, max_speed=600.0)
    traj = lgvi.simulate_slosh(J, M0, PIV, LEN, MASS, np.eye(3), Q0, QD0, omega0=[0.01, -0.02, 0.015],
                               damping=damping, h=0.1, steps=3000, save_every=10, wheels=rw,
                               controller=lgvi.control.MRPFeedback(K=20.0, P=150.0, target=target),
                               control_period=0.5)
    err = np.degrees(np.arccos(np.clip((np.einsum("tab,ab->t", traj.R, target) - 1.0) / 2.0, -1.0, 1.0)))
    slosh_rate = np.linalg.norm(traj.qdot_body, axis=2).max(axis=1)       # relative to the hub [1/s]
    L = traj.angular_momentum
    assert err[0] > 40.0 and np.abs(L - L[0]).max() < 1e-13 * np.abs(L[0]).max() * np.sqrt(3000)
    assert 0.5 < np.abs(traj.wheel_torque).max() <= 2.0                  # the motors work, within their limit
    if damping is not None:
        assert err[-1] < 1e-3 and slosh_rate[-1] < 1e-6 and np.linalg.norm(traj.omega[-1]) < 1e-6
        # at rest, all the momentum is in the wheels
        Lw = traj.R[-1] @ (traj.wheel_momentum[-1] @ traj.wheel_axes)
        assert np.abs(Lw - L[0]).max() < 1e-3 * np.abs(L[0]).max()
    else:
        assert err[-1] > 0.1 and slosh_rate[-1] > 0.1


def test_save_load_and_stream_resume_bit_for_bit_with_wheels(tmp_path):
    from lgvi.io.streaming import read_stream, stream_system

    args = (J, M0, PIV, LEN, MASS, np.eye(3), Q0, QD0)
    kw = dict(omega0=W0, damping=DAMP, h=0.1, steps=600, save_every=5, wheels=wheels(max_torque=0.2),
              controller=lgvi.control.MRPFeedback(K=3.5, P=30.0, Ki=2e-4, integral_limit=100.0), control_period=0.5)
    ref = lgvi.simulate_slosh(*args, **kw)
    ref.save(tmp_path / "t.npz")
    back = lgvi.SloshTrajectory.load(tmp_path / "t.npz")
    names = ("t", "R", "Pi", "q", "pi", "iterations", "residual", "wheel_momentum", "wheel_torque", "wheel_axes",
             "spin_inertia")
    for name in names:
        assert np.array_equal(getattr(back, name), getattr(ref, name)), name
    assert back.meta == ref.meta and back.meta["controller"]["K"] == 3.5
    # wheel arrays that do not fit are refused, naming the field
    z = dict(np.load(tmp_path / "t.npz", allow_pickle=False))
    z["wheel_momentum"] = z["wheel_momentum"][:, :3]
    np.savez(tmp_path / "bad.npz", **z)
    with pytest.raises(ValueError, match=r"field 'wheel_momentum' must have shape \(121, 4\)"):
        lgvi.SloshTrajectory.load(tmp_path / "bad.npz")
    kw["controller"] = lgvi.control.MRPFeedback(K=3.5, P=30.0, Ki=2e-4, integral_limit=100.0)
    with pytest.raises(KeyboardInterrupt):
        stream_system(tmp_path / "cut", "slosh", *args, chunk_steps=200, **kw,
                      progress=lambda k, n: (_ for _ in ()).throw(KeyboardInterrupt) if k >= 400 else None)
    kw["controller"] = lgvi.control.MRPFeedback(K=3.5, P=30.0, Ki=2e-4, integral_limit=100.0)
    stream_system(tmp_path / "cut", "slosh", *args, chunk_steps=200, resume=True, **kw)
    back = read_stream(tmp_path / "cut")
    assert type(back) is lgvi.SloshTrajectory and back.n_wheels == 4
    for name in names:
        assert np.array_equal(getattr(back, name), getattr(ref, name)), name
    # another controller is another run: refused, naming it
    kw["controller"] = lgvi.control.MRPFeedback(K=3.0, P=30.0, Ki=2e-4, integral_limit=100.0)
    with pytest.raises(ValueError, match="controller"):
        stream_system(tmp_path / "cut", "slosh", *args, chunk_steps=200, resume=True, **kw)


def test_kernel_with_wheels_interpreted_matches_compiled():
    """The kernel's wheel and controller branches run as plain Python (NUMBA_DISABLE_JIT=1) give the
    compiled result to round-off (damped, order 2, the MRP feedback at every other step)."""
    from jit_pair import interpreted_and_compiled

    code = (
        "import numpy as np, lgvi\n"
        "rw = lgvi.ReactionWheels(np.eye(3), 0.08, speed0=[10.0, 20.0, 30.0], max_torque=0.2)\n"
        "t = lgvi.simulate_slosh([900.0, 800.0, 600.0], 1500.0, [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]], [0.3, 0.4],\n"
        "                        [40.0, 60.0], np.eye(3), [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]],\n"
        "                        [[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]], omega0=[0.3, -0.2, 0.5], h=0.01, steps=20,\n"
        "                        damping=[30.0, 50.0], wheels=rw, control_period=0.02,\n"
        "                        controller=lgvi.control.MRPFeedback(K=3.5, P=30.0, target=lgvi.so3.exp(np.array([0.1, 0.2, 0.3]))))\n"
        "print([np.concatenate([t.R[-1].ravel(), t.Pi[-1], t.q[-1].ravel(), t.pi[-1].ravel(), t.wheel_momentum[-1],\n"
        "                       t.wheel_torque[-1]]).tolist()])\n"
    )
    interpreted, compiled = interpreted_and_compiled(code)
    np.testing.assert_allclose(interpreted, compiled, rtol=0, atol=1e-12)


def test_members_with_wheels_and_controller_are_the_single_runs():
    members = [dict(body=J, hub_mass=M0, pivots=PIV, lengths=LEN, masses=MASS, R0=np.eye(3), q0=Q0, qdot0=QD0,
                    omega0=W0, damping=DAMP, h=0.1, steps=200, save_every=20, wheels=wheels(max_torque=5.0),
                    controller=lgvi.control.MRPFeedback(K=K, P=30.0, target=lgvi.so3.exp(np.array([0.2, 0.0, 0.1]))),
                    control_period=0.2) for K in (2.0, 3.5)]
    ens = lgvi.simulate_members("slosh", members, threads=2)
    for b, kw in enumerate(members):
        one = lgvi.simulate_slosh(**kw)
        for name in ("R", "Pi", "q", "pi", "wheel_momentum", "wheel_torque"):
            assert np.array_equal(getattr(ens[b], name), getattr(one, name)), name
    assert np.abs(ens[0].R[-1] - ens[1].R[-1]).max() > 1e-6          # the gains differ, so do the runs


SCENARIO = """
name = "slosh_wheels"

[slosh]
""" + SLOSH_HUB + """\
omega0 = [0.01, -0.02, 0.015]
damping = [30.0, 50.0]
wheels = {axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], spin_inertia = 0.08, speed0 = [10.0, -20.0, 30.0], max_torque = 2.0}
controller = {K = 20.0, P = 150.0, Ki = 0.001, integral_limit = 10.0, target = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]}
control_period = 0.5

[integrator]
h = 0.1
steps = 600
save_every = 5
"""


def test_lgvi_run_of_a_scenario_with_wheels_and_controller_resumes_bit_for_bit(capsys, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from lgvi.io.scenario import load_scenario

    path = tmp_path / "slosh_wheels.toml"
    path.write_text(SCENARIO)
    sc = load_scenario(path)
    whole = sc.run()
    rw = lgvi.ReactionWheels(np.eye(3), JS, speed0=[10.0, -20.0, 30.0], max_torque=2.0)
    ctrl = lgvi.control.MRPFeedback(K=20.0, P=150.0, Ki=0.001, integral_limit=10.0,
                                    target=[[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    ref = lgvi.simulate_slosh(J, M0, PIV, LEN, MASS, np.eye(3), Q0, QD0, omega0=[0.01, -0.02, 0.015], damping=DAMP,
                              h=0.1, steps=600, save_every=5, wheels=rw, controller=ctrl, control_period=0.5)
    fields = ("t", "R", "Pi", "q", "pi", "wheel_momentum", "wheel_torque", "iterations", "residual")
    for name in fields:
        assert np.array_equal(getattr(whole, name), getattr(ref, name)), name

    back = cut_and_resume(sc, path, tmp_path / "out", capsys, cut_at=300, chunk_steps=100)
    for name in fields:
        assert np.array_equal(getattr(back, name), getattr(whole, name)), name
    text = (tmp_path / "out" / "summary.txt").read_text()
    assert "3 reaction wheels" in text and "MRP feedback K = 20" in text


@pytest.mark.parametrize("old, new, key, rule", [
    ("spin_inertia = 0.08", "spin_inertia = -0.08", "slosh.wheels", r"spin_inertia must be > 0"),
    ("spin_inertia = 0.08", "inertia = 0.08", "slosh.wheels", r"unknown key 'inertia'"),
    ("[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]", "[2.0, 0.0, 0.0], [0.0, 1.0, 0.0]", "slosh.wheels", r"unit vectors"),
    ("K = 20.0, ", "", "slosh.controller", r"missing 'K'"),
    ("control_period = 0.5", 'control_period = "0.5"', "slosh.control_period", r"a number"),
])
def test_scenario_wheel_errors_name_the_key(tmp_path, old, new, key, rule):
    assert_scenario_error(tmp_path, SCENARIO, old, new, key, rule)


def test_lgvi_info_reads_a_slosh_result_and_a_failed_step_keeps_the_wheels(capsys, tmp_path):
    from lgvi import cli

    traj = slosh(0.01, 100, save_every=10, wheels=wheels(), wheel_torque=U)
    traj.save(tmp_path / "t.npz")
    assert cli.main(["info", str(tmp_path / "t.npz")]) == 0
    out = capsys.readouterr().out
    assert "wheel_momentum (11, 4)" in out and "4 reaction wheels" in out and "motor commands given" in out
    with pytest.raises(lgvi.ConvergenceError, match=r"slosh step \d+ .*Newton") as err:
        slosh(0.01, 50, max_iter=1, tol=1e-15, wheels=wheels(), wheel_torque=U)
    part = err.value.trajectory
    assert part.meta.get("partial") and part.wheel_momentum.shape == (len(part.t), 4)
    assert part.wheel_torque.shape == (len(part.t) - 1, 4)
