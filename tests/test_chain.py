"""Chains of spherical pendulums on (S^2)^n (issue 30, part 1): ``lgvi.simulate_chain``.

The reference is an independent formulation of the same mechanics: positions and velocities in
R^3 with the unit-length constraints as Lagrange multipliers (``chain_equations``), integrated by
SciPy's DOP853 at rtol 1e-13. The chain: three links of lengths (1, 0.5, 0.5) and unit masses,
started with the links at right angles and moving (a chaotic regime: the test of a long run).
"""

from __future__ import annotations

import numpy as np
from jit_pair import interpreted_and_compiled
from scenario_cases import assert_scenario_error
import pytest
from scipy.integrate import solve_ivp

import lgvi
from lgvi.systems import SYSTEMS
from lgvi.systems.chain import chain_equations, chain_parameters, momenta, velocities
from lgvi.systems.chain.model import G0

L3 = [1.0, 0.5, 0.5]
M3 = [1.0, 1.0, 1.0]
Q0 = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
QD0 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 2.0], [1.0, 0.0, 0.0]])
GRAVITY = np.array([0.0, 0.0, -G0])
EPS = np.finfo(float).eps


def chain(h, steps, **kw):
    return lgvi.simulate_chain(L3, M3, Q0, QD0, h=h, steps=steps, **kw)


def reference(T, lengths=L3, masses=M3, q0=Q0, qd0=QD0, gravity=GRAVITY, **kw):
    """``q`` (n, 3) at ``T`` from the constrained equations in R^3 by DOP853."""
    M, w = chain_parameters(lengths, masses, kw.get("link_masses"))
    f = chain_equations(M, w, gravity)
    sol = solve_ivp(f, (0.0, T), np.concatenate([np.ravel(q0), np.ravel(qd0)]), method="DOP853", rtol=1e-13,
                    atol=1e-13)
    n = len(w)
    return sol.y[:3 * n, -1].reshape(n, 3)


def test_registered_with_its_invariants():
    system = SYSTEMS["chain"]
    assert [f.name for f in system.state] == ["q", "pi"]
    assert system.invariants({"gravity": GRAVITY}) == {"angular_momentum_e3": {"kind": "exact"},
                                                       "energy": {"kind": "bounded"}}
    assert "angular_momentum" in system.invariants({"gravity": np.zeros(3)})
    assert set(system.invariants({"gravity": [1.0, 0.0, -9.0]})) == {"energy"}   # tilted: no e3 symmetry


def test_vertical_momentum_is_exact_unit_lengths_too():
    traj = chain(1e-3, 20000, save_every=10)
    Lz = traj.vertical_momentum
    # round-off: a random walk of a few eps |L| a step (2e-13 here; the solve's residual adds nothing)
    assert np.abs(Lz - Lz[0]).max() < 4 * np.sqrt(20000) * EPS * abs(Lz[0])
    # the momentum about a horizontal axis is not conserved (gravity's moment): a test that can fail
    Lx = traj.angular_momentum[:, 0]
    assert np.ptp(Lx) > 0.1
    assert np.abs(np.linalg.norm(traj.q, axis=2) - 1.0).max() <= 2 * EPS
    assert traj.meta["invariants"]["angular_momentum_e3"]["kind"] == "exact"
    # pi_i stays across q_i (to round-off)
    assert np.abs(np.einsum("kij,kij->ki", traj.q, traj.pi)).max() < 1e-13


def test_without_gravity_the_whole_angular_momentum_is_exact():
    traj = chain(2e-3, 5000, gravity=np.zeros(3))
    L = traj.angular_momentum
    assert np.linalg.norm(L - L[0], axis=1).max() < 1e-13 * np.linalg.norm(L[0])
    assert np.ptp(traj.energy) < 1e-4 * abs(traj.energy[0])


def test_energy_has_no_drift_over_a_long_run():
    """A regular motion (three links tilted and turning about the vertical, as in
    benchmarks/bench_chain.py), 1e5 steps of h = 4e-3 (400 s): the energy error of the last tenth
    is that of the first tenth (bounded, no drift), and it is the O(h^2) oscillation of a
    second-order symplectic method (a quarter of it at h / 2)."""
    th, ph = np.array([0.5, 0.8, 1.1]), np.array([0.0, 0.7, 1.9])
    q0 = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)], axis=1)
    qd0 = np.cross([0.0, 0.0, 1.5], q0)
    qd0[2] += 0.8 * np.cross(q0[2], [0.0, 1.0, 0.0])
    qd0 -= np.einsum("ij,ij->i", q0, qd0)[:, None] * q0

    def energy_error(h, steps):
        traj = lgvi.simulate_chain(L3, M3, q0, qd0, h=h, steps=steps, save_every=10)
        return np.abs(traj.energy - traj.energy[0])

    dE = energy_error(4e-3, 100000)
    tenth = len(dE) // 10
    first, last = dE[:tenth].max(), dE[-tenth:].max()
    assert last < 1.25 * first
    half = energy_error(2e-3, 20000).max()          # the first 40 s again at h / 2
    assert 3.2 < first / half < 4.8, (first, half)


@pytest.mark.parametrize("order, hs, slope", [(2, (1e-2, 5e-3, 2.5e-3), 2.0), (4, (2e-2, 1e-2, 5e-3), 4.0)])
def test_order_against_dop853(order, hs, slope):
    T = 1.0
    q_ref = reference(T)
    errs = [np.abs(chain(h, int(round(T / h)), order=order).q[-1] - q_ref).max() for h in hs]
    fit = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert abs(fit - slope) < 0.15, (errs, fit)
    assert errs[-1] < (1e-3 if order == 2 else 1e-6)


def test_sixth_order_composition():
    T = 0.5
    q_ref = reference(T)
    hs = (2.5e-2, 1.25e-2)
    errs = [np.abs(chain(h, int(round(T / h)), order=6).q[-1] - q_ref).max() for h in hs]
    assert 5.3 < np.log2(errs[0] / errs[1]) < 6.7, errs


def test_symmetric_backwards_step_retraces():
    fwd = chain(1e-3, 500)
    back = lgvi.simulate_chain(L3, M3, fwd.q[-1], fwd.qdot[-1], h=-1e-3, steps=500)
    # qdot of the end state maps back to its discrete momentum exactly (velocities and momenta are
    # inverse), so the backward run starts from the end state and retraces the path
    assert np.abs(back.q[-1] - Q0).max() < 1e-11
    assert np.abs(back.pi[-1] - fwd.pi[0]).max() < 1e-10


def test_single_pendulum_small_oscillation_period():
    """A rod (link mass only: the rigid-link option) and a point mass: small oscillations with
    omega^2 = w g / M, 3 g / (2 l) for a rod, g / l for a point mass."""
    for masses, link_masses, omega2 in (([1e-12], [2.0], 1.5 * G0 / 0.8), ([2.0], None, G0 / 0.8)):
        a = 1e-3
        q0 = [[np.sin(a), 0.0, -np.cos(a)]]
        h = 1e-3
        traj = lgvi.simulate_chain([0.8], masses, q0, h=h, steps=4000, link_masses=link_masses)
        x = traj.q[:, 0, 0]
        up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))      # upward zero crossings
        t_cross = traj.t[up] - x[up] * h / (x[up + 1] - x[up])
        period = np.diff(t_cross).mean()
        assert abs(period - 2 * np.pi / np.sqrt(omega2)) < 1e-5 * period + 2 * h ** 2


def test_momenta_and_velocities_are_inverse():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(4, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    v = rng.normal(size=(4, 3))
    v -= np.einsum("ij,ij->i", q, v)[:, None] * q
    M, _ = chain_parameters([1.0, 0.3, 0.7, 0.2], [0.5, 1.0, 2.0, 0.1], [0.1, 0.0, 1.0, 0.2])
    assert np.abs(velocities(M, q, momenta(M, q, v)) - v).max() < 1e-12


def test_rod_mass_matrix_against_quadrature():
    """The kinetic energy of thin rods from the formula against a quadrature along the rods."""
    rng = np.random.default_rng(5)
    lengths, masses, rods = np.array([1.0, 0.4, 0.7]), np.array([0.3, 0.2, 0.5]), np.array([1.0, 0.6, 0.2])
    q = rng.normal(size=(3, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    v = rng.normal(size=(3, 3))
    v -= np.einsum("ij,ij->i", q, v)[:, None] * q
    M, w = chain_parameters(lengths, masses, rods)
    T = 0.5 * np.einsum("ij,ik,jk->", M, v, v)
    s, wq = np.polynomial.legendre.leggauss(8)
    T_ref = 0.0
    base = np.zeros(3)
    for i in range(3):
        tip = base + lengths[i] * v[i]
        for sk, wk in zip(0.5 * (s + 1), 0.5 * wq):
            vel = base + sk * lengths[i] * v[i]
            T_ref += 0.5 * rods[i] * wk * vel @ vel
        T_ref += 0.5 * masses[i] * tip @ tip
        base = tip
    assert abs(T - T_ref) < 1e-13 * T_ref
    # the potential's weights: the height of the centre of mass
    com = sum(masses[i] * (lengths[:i + 1] @ q[:i + 1, 2])
              + rods[i] * (lengths[:i] @ q[:i, 2] + 0.5 * lengths[i] * q[i, 2]) for i in range(3))
    assert abs(w @ q[:, 2] - com) < 1e-14


def test_rigid_links_against_dop853():
    kw = dict(link_masses=[0.5, 1.0, 0.2])
    q_ref = reference(0.5, **kw)
    traj = chain(1e-3, 500, **kw)
    assert np.abs(traj.q[-1] - q_ref).max() < 5e-5


def test_save_load_round_trip(tmp_path):
    traj = chain(1e-2, 50, save_every=5)
    traj.save(tmp_path / "c.npz")
    back = lgvi.ChainTrajectory.load(tmp_path / "c.npz")
    for name in lgvi.ChainTrajectory.ARRAYS:
        assert np.array_equal(getattr(back, name), getattr(traj, name))
    assert back.h == traj.h and back.meta == traj.meta


def test_newton_record_and_failure_keeps_the_computed_part():
    traj = chain(1e-3, 200)
    assert traj.iterations.max() <= 4 and traj.residual.max() <= 1e-14
    with pytest.raises(lgvi.ConvergenceError, match=r"chain step \d+ .*Newton") as err:
        chain(1e-3, 200, max_iter=1, tol=1e-15)
    partial = err.value.trajectory
    assert partial.meta.get("partial") and len(partial.t) >= 1
    assert np.array_equal(partial.q, traj.q[:len(partial.t)])


# ------------------------------------------------------------------------------------------------
# through the seam: streams, resume, members, interrupts (issue 30, part 4)
# ------------------------------------------------------------------------------------------------
CHAIN_ARGS = (L3, M3, Q0, QD0)
CHAIN_KW = dict(h=1e-3, steps=3000, save_every=5, order=4)
FIELDS = ("t", "q", "pi", "iterations", "residual", "lengths", "masses", "link_masses", "gravity")


def same(a, b) -> None:
    assert type(a) is type(b) is lgvi.ChainTrajectory and a.h == b.h
    for name in FIELDS:
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.shape == y.shape and x.dtype == y.dtype and np.array_equal(x, y), name
    assert a.meta["invariants"] == b.meta["invariants"]


def test_stream_equals_memory_and_resumes_bit_for_bit(tmp_path):
    from lgvi.io.streaming import read_stream, stream_system

    ref = lgvi.simulate_chain(*CHAIN_ARGS, **CHAIN_KW)
    stream_system(tmp_path / "full", "chain", *CHAIN_ARGS, chunk_steps=700, **CHAIN_KW)
    same(read_stream(tmp_path / "full"), ref)

    with pytest.raises(KeyboardInterrupt):
        stream_system(tmp_path / "cut", "chain", *CHAIN_ARGS, chunk_steps=700, **CHAIN_KW,
                      progress=lambda k, n: (_ for _ in ()).throw(KeyboardInterrupt) if k >= 1400 else None)
    part = read_stream(tmp_path / "cut")
    assert len(part.t) == 1400 // 5 + 1 and np.array_equal(part.q, ref.q[:len(part.t)])
    with pytest.raises(ValueError, match=r"resume: .*resumes only the same run \(differences: initial, masses\)"):
        stream_system(tmp_path / "cut", "chain", L3, [1.0, 2.0, 1.0], Q0, QD0, chunk_steps=700, resume=True,
                      **CHAIN_KW)
    # resumed: the multipliers' history (the first guesses) carries over, so bit for bit
    stream_system(tmp_path / "cut", "chain", *CHAIN_ARGS, chunk_steps=700, resume=True, **CHAIN_KW)
    same(read_stream(tmp_path / "cut"), ref)


def test_members_are_the_single_runs():
    members = [dict(lengths=L3, masses=M3, q0=Q0, qdot0=QD0 * s, h=2e-3, steps=500, save_every=50)
               for s in (0.5, 1.0, 1.5)]
    ens = lgvi.simulate_members("chain", members, threads=2)
    assert ens.stack("q").shape == (3, 11, 3, 3)
    for b, kw in enumerate(members):
        same(ens[b], lgvi.simulate_chain(**kw))
    with pytest.raises(ValueError, match=r"member 1: .*masses"):
        lgvi.simulate_members("chain", [members[0], dict(members[1], masses=[1.0, -1.0, 1.0])])


def test_ctrl_c_keeps_the_computed_part():
    ref = chain(1e-3, 4000)
    from lgvi.systems.chain import ChainRun
    from lgvi.driver import MemorySink, drive

    run = ChainRun(*CHAIN_ARGS, h=1e-3, steps=4000)
    run.chunk = 1000

    def stop(k, n):
        if k >= 2000:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        drive(run, MemorySink(run), progress=stop)
    run2 = ChainRun(*CHAIN_ARGS, h=1e-3, steps=4000)
    run2.chunk = 1000
    state = None

    def save(k, n):
        nonlocal state
        if k == 2000:
            state = run2.state()
    drive(run2, MemorySink(run2), progress=save)
    run3 = ChainRun(*CHAIN_ARGS, h=1e-3, steps=4000)
    run3.load_state(state)
    sink = MemorySink(run3)
    end = drive(run3, sink)
    assert np.array_equal(end.q[-1], ref.q[-1]) and np.array_equal(end.pi[-1], ref.pi[-1])


# ------------------------------------------------------------------------------------------------
# scenario files and the command line, through System.from_scenario (no io or cli code names it)
# ------------------------------------------------------------------------------------------------
SCENARIO = """
name = "chain3"

[chain]
lengths = [1.0, 0.5, 0.5]
masses = [1.0, 1.0, 1.0]
q0 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]
qdot0 = [[0.0, 1.0, 0.0], [0.0, 0.0, 2.0], [1.0, 0.0, 0.0]]
link_masses = [0.0, 0.2, 0.0]
order = 4

[integrator]
h = 0.002
steps = 1500
save_every = 5
"""


def test_scenario_runs_the_chain_bit_for_bit(tmp_path):
    from lgvi.io.scenario import load_scenario

    path = tmp_path / "chain3.toml"
    path.write_text(SCENARIO)
    sc = load_scenario(path)
    assert sc.kind == "chain" and sc.steps == 1500
    got = sc.run()
    ref = lgvi.simulate_chain(L3, M3, Q0, QD0, h=2e-3, steps=1500, save_every=5, link_masses=[0.0, 0.2, 0.0], order=4)
    for name in FIELDS:
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    assert got.meta["scenario_name"] == "chain3"


@pytest.mark.parametrize("old, new, key, rule", [
    ("masses = [1.0, 1.0, 1.0]", "masses = [1.0, 0.0, 1.0]", "chain.masses", r"positive.*masses\[1\] = 0\.0"),
    ("order = 4", "order = 3", "chain.order", r"order must be 2, 4 or 6"),
    ("order = 4", 'order = "4"', "chain.order", r"an integer"),
    ("order = 4", "spring = 1.0", "chain.spring", r"unknown key"),
    ("lengths = [1.0, 0.5, 0.5]\n", "", "chain.lengths", r"missing"),
    ("q0 = [[1.0, 0.0, 0.0]", "q0 = [[2.0, 0.0, 0.0]", "chain.q0", r"unit vectors"),
])
def test_scenario_errors_name_the_key(tmp_path, old, new, key, rule):
    assert_scenario_error(tmp_path, SCENARIO, old, new, key, rule)


def test_lgvi_run_writes_results_figure_summary_and_resumes(capsys, tmp_path):
    import json

    from lgvi import cli
    from lgvi.io.outputs import read_trajectory
    from lgvi.io.scenario import load_scenario

    path = tmp_path / "chain3.toml"
    path.write_text(SCENARIO)
    sc = load_scenario(path)
    whole = sc.run()

    def ctrl_c(k, n):
        if k >= 750:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        sc.run_stream(tmp_path / "out" / "stream", chunk_steps=250, progress=ctrl_c)
    code = cli.main(["run", str(path), "-o", str(tmp_path / "out"), "--resume"])
    out, err = capsys.readouterr()
    assert code == 0, err
    back = read_trajectory(tmp_path / "out" / "trajectory.npz")
    assert isinstance(back, lgvi.ChainTrajectory)
    for name in FIELDS:
        assert np.array_equal(getattr(back, name), getattr(whole, name)), name
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["chain.png", "report.html", "scenario.toml", "summary.json", "summary.txt", "trajectory.npz"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["system"] == "chain" and summary["drifts"]["angular_momentum_e3_rel"] < 1e-13
    assert "a chain of 3 spherical pendulums" in (tmp_path / "out" / "summary.txt").read_text()
    assert cli.main(["info", str(tmp_path / "out" / "trajectory.npz")]) == 0
    out, _ = capsys.readouterr()
    assert "q (301, 3, 3), pi (301, 3, 3)" in out


def test_kernel_interpreted_matches_compiled():
    """The chain kernel run as plain Python (NUMBA_DISABLE_JIT=1) gives the compiled result (orders 2
    and 4, rods), to round-off: the same arithmetic, in another order only where LLVM reorders."""

    code = (
        "import numpy as np, lgvi\n"
        "q0 = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]]\n"
        "qd = [[0, 1.0, 0], [0, 0, 2.0], [1.0, 0, 0]]\n"
        "out = []\n"
        "for kw in (dict(order=2), dict(order=4, link_masses=[0.1, 0.2, 0.3])):\n"
        "    t = lgvi.simulate_chain([1.0, 0.5, 0.5], [1.0, 1.0, 1.0], q0, qd, h=2e-3, steps=30, **kw)\n"
        "    out.append(np.concatenate([t.q[-1].ravel(), t.pi[-1].ravel()]).tolist())\n"
        "print(out)\n"
    )
    interpreted, compiled = interpreted_and_compiled(code)
    np.testing.assert_allclose(interpreted, compiled, rtol=0, atol=1e-13)


def test_the_figure_of_the_paper_chain_lgvi_bounded_runge_kutta_drifts():
    """What docs/figures/chain_energy_momentum.png and chain_unit_length.png show, over 20 s of
    their 200 s (the same case, built by ``docs/make_two_spheres_figures.py``: five links of 1 m
    and 1 kg, h = 1e-3 s, RK45 at its default tolerances and at 1e-8 on the same mechanics in
    R^3): lgvi's energy error is no larger over the second 10 s than over the first (bounded), its
    vertical momentum and unit lengths are exact to round-off; RK45's energy error grows (at both
    tolerances) and, at the defaults, the links leave their unit length by more than 1 %."""
    import importlib.util
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "docs" / "make_two_spheres_figures.py"
    spec = importlib.util.spec_from_file_location("make_two_spheres_figures", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    traj, rk, _ = module.runs(20.0, 1e-3)
    half = len(traj.t) // 2
    dE = np.abs(traj.energy - traj.energy[0])
    assert dE[half:].max() <= 1.25 * dE[:half].max()
    Lz = traj.vertical_momentum
    assert np.abs(Lz - Lz[0]).max() <= 4 * np.sqrt(20000) * EPS * np.abs(traj.angular_momentum[0]).max()
    assert np.abs(np.linalg.norm(traj.q, axis=2) - 1.0).max() <= 2 * EPS
    for label, r in rk.items():
        e = np.abs(r["E"] - traj.energy[0])
        assert e[half:].max() > 2.0 * e[:half].max(), label           # drifts: doubles (and more) in 10 s
    loose = rk["RK45, rtol 1e-3 (ode45 defaults)"]
    assert np.abs(np.linalg.norm(loose["q"], axis=2) - 1.0).max() > 1e-2
    assert np.abs(loose["E"] - traj.energy[0]).max() > 1e3 * dE.max()


def test_the_invariants_note_names_the_chain_not_the_free_body():
    """A chain's declaration of invariants says whose they are (it read "the free body": no torque in meta)."""
    from lgvi.invariants import declared

    tr = lgvi.simulate_chain([1.0, 1.0], [1.0, 1.0], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], h=0.01, steps=4)
    d = declared(tr)
    assert d.note() == "invariants of the chain"
    assert set(d.entries) == {"angular_momentum_e3", "energy"}
