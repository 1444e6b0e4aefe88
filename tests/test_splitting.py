"""scheme="splitting": the exact free-body flow, the coefficients' order conditions, the orders by
slope, and the structure (SO(3), momentum components, bounded energy)."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

import lgvi
from lgvi import so3
from lgvi.verification.exact import free_body_attitude, free_body_momentum
from lgvi.registry import DEFAULT_SPLITTING, SPLITTINGS
from lgvi.splitting import free_flow
from lgvi.torques import Compiled, GravityGradient, LinearDamping, UniformGravity

TOP = lgvi.RigidBody([0.13, 0.28, 0.17])
HANGING = UniformGravity(1.0, [0.0, 0.0, -0.3])        # Lee's 3D pendulum, hanging at R = I
CUBESAT = lgvi.RigidBody([0.0433, 0.0418, 0.0067])
GG = GravityGradient(3.986004418e14, 6878.137e3)


def angle(Ra, Rb):
    return float(np.linalg.norm(so3.log(Ra.T @ Rb)))


# ------------------------------------------------------------------------------------------------
# the exact flow
# ------------------------------------------------------------------------------------------------
def test_carlson_integrals_match_scipy():
    from scipy.special import elliprf, elliprj

    from lgvi._kernels.splitting_kernels import carlson_rf, carlson_rj

    rng = np.random.default_rng(3)
    for _ in range(100):
        x, y, z = rng.uniform(0.0, 3.0, 3)
        p = rng.uniform(0.01, 3.0)
        assert carlson_rf(x, y, z) == pytest.approx(elliprf(x, y, z), rel=4e-15)
        assert carlson_rj(x, y, z, p) == pytest.approx(elliprj(x, y, z, p), rel=4e-15)


@pytest.mark.parametrize("moments, Pi0", [
    ([1.0, 2.0, 3.0], [0.3, 2.0, 0.6]),        # one side of the separatrix (D < 0)
    ([1.0, 2.0, 3.0], [2.0, 0.3, 0.6]),        # ... and the other (D > 0)
    ([3.0, 1.0, 2.0], [0.1, -1.0, 0.5]),       # moments in any order, negative components
    ([0.0433, 0.0418, 0.0067], [0.003464, -0.002508, 0.000603]),   # the CubeSat
    ([1.0, 1.0, 2.0], [0.3, 0.4, 1.0]),        # axisymmetric
    ([2.0, 1.0, 1.0], [0.3, 0.4, 1.0]),
    ([1.0, 2.0, 3.0], [0.0, 0.0, 1.0]),        # steady spins
    ([1.0, 2.0, 3.0], [0.0, 1.0, 0.0]),
])
def test_free_flow_is_the_exact_solution(moments, Pi0):
    """The compiled flow against lgvi.exact (an independent solution: Fourier series of the
    precession rate), forwards and backwards, to 1e-12."""
    R0 = so3.exp(np.array([0.3, -0.2, 0.5]))
    for tau in (0.1, 1.7, -2.3, 25.0):
        R, Pi = free_flow(moments, R0, Pi0, tau)
        if np.count_nonzero(Pi0) == 1:                 # (lgvi.exact rejects the middle axis' separatrix)
            Re, Pe = R0 @ so3.exp(np.array(Pi0) / np.array(moments) * tau), np.array(Pi0, dtype=float)
        else:
            Re = free_body_attitude(moments, R0, Pi0, np.array([tau]))[0]
            Pe = free_body_momentum(moments, Pi0, np.array([tau]))[0]
        assert angle(Re, R) < 1e-12
        assert np.linalg.norm(Pi - Pe) < 1e-12 * np.linalg.norm(Pe)


def test_free_flow_on_and_near_the_separatrix():
    """|Pi|^2 = 2 E J_mid: the flow stays finite and conserves |Pi|, E and R Pi; near it, flowing
    tau then -tau returns to the start."""
    J = np.array([1.0, 2.0, 3.0])
    # on the separatrix: Pi_max^2 (Jmax - Jmid)/Jmax = Pi_min^2 (Jmid - Jmin)/Jmin
    p3 = 0.5
    p1 = math.sqrt(p3 ** 2 * (1.0 / 3.0) / 1.0)
    for Pi0 in ([p1, 0.7, p3], [p1 * (1 + 1e-9), 0.7, p3]):
        Pi0 = np.array(Pi0)
        R, Pi = free_flow(J, np.eye(3), Pi0, 3.0)
        assert np.all(np.isfinite(R)) and np.all(np.isfinite(Pi))
        assert np.linalg.norm(R @ Pi - Pi0) < 1e-13
        assert abs(Pi @ (Pi / J) - Pi0 @ (Pi0 / J)) < 1e-13
        Rb, Pb = free_flow(J, R, Pi, -3.0)
        assert angle(np.eye(3), Rb) < 1e-9 and np.linalg.norm(Pb - Pi0) < 1e-9


def test_free_flow_with_a_full_inertia_matrix():
    """A non-diagonal J is flowed in its principal frame: the same motion as the diagonal body seen
    in rotated axes."""
    Q = so3.exp(np.array([0.4, 0.1, -0.3]))
    moments = np.array([1.0, 2.0, 3.0])
    body = lgvi.RigidBody(Q @ np.diag(moments) @ Q.T)
    R0 = so3.exp(np.array([0.1, 0.2, 0.3]))
    Pi0 = np.array([0.5, -1.0, 0.4])
    R, Pi = free_flow(body, R0, Pi0, 2.5)
    Rd, Pd = free_flow(moments, R0 @ Q, Q.T @ Pi0, 2.5)
    assert angle(Rd @ Q.T, R) < 1e-13
    assert np.linalg.norm(Q @ Pd - Pi) < 1e-13


# ------------------------------------------------------------------------------------------------
# coefficients
# ------------------------------------------------------------------------------------------------
def _pair_sum(c, b, k, l):
    """sum over kicks i after j of b_i b_j (c_i^k c_j^l - c_i^l c_j^k)."""
    return sum(b[i] * b[j] * (c[i] ** k * c[j] ** l - c[i] ** l * c[j] ** k) for i in range(len(c)) for j in range(i))


def _pair_exact(k, l):
    return 1.0 / ((l + 1) * (k + l + 2)) - 1.0 / ((k + 1) * (k + l + 2))


EXACT_BASE = sorted(n for n, sp in SPLITTINGS.items() if sp.base == "exact")
AXES = sorted(n for n, sp in SPLITTINGS.items() if sp.base == "axes")


@pytest.mark.parametrize("name", EXACT_BASE)
def test_coefficients_satisfy_their_order_conditions(name):
    """docs/splitting.md: the eps terms are the quadrature conditions sum b c^k = 1/(k+1),
    k < s1; the eps^2 terms of degree 3 and 5 the pair sums. Each method meets the conditions of
    its stated orders to round-off and fails the next ones (its orders are not understated)."""
    sp = SPLITTINGS[name]
    c, b = np.array(sp.nodes), np.array(sp.weights)
    s1, s2 = sp.eps_orders
    for k in range(s1 + 1):
        res = abs(float(b @ c ** k) - 1.0 / (k + 1))
        assert (res < 1e-14) if k < s1 else (res > 1e-6), (k, res)
    eps2 = {3: [(0, 1)], 5: [(0, 3), (1, 2)]}
    for degree, pairs in eps2.items():
        res = max(abs(_pair_sum(c, b, k, l) - _pair_exact(k, l)) for k, l in pairs)
        assert (res < 1e-14) if degree < s2 else (res > 1e-6), (degree, res)
    assert sp.order == min(s1, s2) or (sp.order == 2 and s2 == 2)
    drift, weight, node = sp.arrays()
    assert drift.sum() == pytest.approx(1.0, abs=1e-15) and weight.sum() == pytest.approx(1.0, abs=1e-15)
    # symmetric: reversed nodes are 1 - nodes (the composition is its own adjoint)
    assert np.allclose(c[::-1], 1.0 - c, atol=1e-15) and np.allclose(b[::-1], b, atol=1e-15)


# ------------------------------------------------------------------------------------------------
# orders by slope, structure
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pendulum_reference():
    """Lee's 3D pendulum (hanging start, T = 1 s): order 6 at 8000 steps, checked against 4000 steps."""
    kw = dict(omega0=4.14 * np.ones(3), torque=HANGING, scheme="splitting", order=6)
    a = lgvi.simulate(TOP, np.eye(3), h=1.0 / 8000, steps=8000, save_every=8000, **kw)
    b = lgvi.simulate(TOP, np.eye(3), h=1.0 / 4000, steps=4000, save_every=4000, **kw)
    assert angle(a.R[-1], b.R[-1]) < 1e-11
    return a


def _axes_step(sp, mats, h):
    """One step of an axis splitting with the flows exp(t X) of four matrices (three rotations and
    the kick): the composition as the kernel runs it, stage by stage."""
    from scipy.linalg import expm

    A, B, C, D = mats
    out = np.eye(A.shape[0])
    for g in sp.weights:
        t = g * h
        for X, tau in ((D, t / 2), (A, t / 2), (B, t / 2), (C, t), (B, t / 2), (A, t / 2), (D, t / 2)):
            out = expm(tau * X) @ out
    return out


@pytest.mark.parametrize("name", AXES)
def test_axis_compositions_have_their_order(name):
    """docs/splitting.md: the local error of the composition, with four random (non-commuting)
    matrices as the pieces' vector fields, against exp(h (A + B + C + D)), falls like h^(p+1):
    the least-squares slope over h = 0.2 .. 0.05 is p + 1 within 0.3 (and so not p + 2: the order
    is not understated). With h |X| ~ 0.1 .. 0.4 the errors (1e-2 .. 1e-12) are above round-off (1e-15)."""
    from scipy.linalg import expm

    sp = SPLITTINGS[name]
    rng = np.random.default_rng(7)
    mats = [rng.standard_normal((4, 4)) for _ in range(4)]
    hs = np.array([0.2, 0.14, 0.1, 0.07, 0.05])
    errs = [np.abs(_axes_step(sp, mats, h) - expm(h * sum(mats))).max() for h in hs]
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert slope == pytest.approx(sp.order + 1, abs=0.3), errs
    assert sum(sp.weights) == pytest.approx(1.0, abs=1e-15)
    for k in range(3, sp.order, 2):                  # the power sums of the one-bracket terms
        assert abs(float(np.sum(np.array(sp.weights) ** k))) < 1e-14, k
    assert np.allclose(sp.weights, sp.weights[::-1], atol=0) and sp.eps_orders == (sp.order, sp.order)
    assert np.allclose(sp.nodes, np.cumsum(sp.weights), atol=1e-15) and sp.nodes[-1] == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("name", ["strang", "saba3", "bab64", "aba84", "aba84-tj6", "axes-suzuki4", "axes-kl6",
                                  "axes-kl8"])
def test_order_by_slope(name, pendulum_reference):
    """Least-squares slope of log(error) against log(h) over h = 1/20 .. 1/160 s (order 6: 1/10 ..
    1/80 s), where the errors (1e-2 .. 1e-10) are far above the reference's (below 1e-12) and the
    step is small enough for the asymptotic regime (successive ratios within 0.1 of 2^p there).
    The pendulum is not a small perturbation, so the classical order shows; tolerance 0.15."""
    sp = SPLITTINGS[name]
    Ns = {6: np.array([10, 20, 40, 80]), 8: np.array([20, 28, 40])}.get(sp.order, np.array([20, 40, 80, 160]))
    errs = []
    for N in Ns:
        tr = lgvi.simulate(TOP, np.eye(3), omega0=4.14 * np.ones(3), h=1.0 / N, steps=int(N), save_every=int(N),
                           torque=HANGING, scheme="splitting", order=sp.order, composition=name)
        errs.append(angle(pendulum_reference.R[-1], tr.R[-1]))
    slope = np.polyfit(np.log(1.0 / Ns), np.log(errs), 1)[0]
    # order 8: h = 1/20 .. 1/40 s (errors 2e-9 .. 6e-12; at 1/80 the reference's error shows), where the
    # successive slopes still fall towards 8 (8.7 at 1/10 .. 1/20, 8.2 at 1/20 .. 1/40): tolerance 0.3
    assert slope == pytest.approx(sp.order, abs=0.3 if sp.order == 8 else 0.15), errs


def test_near_integrable_error_is_small_in_eps():
    """The CubeSat under gravity gradient (eps ~ 1e-4): SABA_3 (order 2, eps h^6 + eps^2 h^2)
    beats Strang (eps h^2) by orders of magnitude at the same step, and ABA(8,4) reaches 1e-7 rad
    after 2 hours at h = 8 s (reference: ABA(8,4) at h = 1 s)."""
    kw = dict(omega0=[0.08, -0.06, 0.09], torque=GG, scheme="splitting")
    T = 7200.0
    ref = lgvi.simulate(CUBESAT, np.eye(3), h=1.0, steps=7200, save_every=7200, order=4, **kw)
    e = {}
    for name, order in (("strang", 2), ("saba3", 2), ("aba84", 4)):
        tr = lgvi.simulate(CUBESAT, np.eye(3), h=8.0, steps=int(T / 8), save_every=int(T / 8), order=order,
                           composition=name, **kw)
        e[name] = angle(ref.R[-1], tr.R[-1])
    assert e["saba3"] < 1e-3 * e["strang"]
    assert e["aba84"] < 1e-7


@pytest.mark.parametrize("order, name", [(4, "aba84"), (4, "axes-suzuki4"), (8, "axes-kl8")])
def test_structure_so3_momentum_and_energy(order, name):
    """Heavy pendulum over 2000 steps: R on SO(3) to round-off, e3 . R Pi (the vertical momentum,
    kept by uniform gravity) exact to round-off, total energy bounded (no drift: the second half
    deviates no more than the first)."""
    tr = lgvi.simulate(TOP, np.eye(3), omega0=4.14 * np.ones(3), h=0.01, steps=2000, torque=HANGING,
                       scheme="splitting", order=order, composition=name)
    orth = np.abs(np.einsum("kji,kjl->kil", tr.R, tr.R) - np.eye(3)).max()
    # round-off walks: 5 flows a step (aba84), 25 or 75 rotations (axes-suzuki4, axes-kl8): 150000
    # rotations in 2000 steps of axes-kl8, sqrt(150000) * 2.2e-16 ~ 1e-13
    assert orth < (1e-13 if order == 4 else 5e-13)
    vertical = tr.spatial_momentum[:, 2]
    assert np.abs(vertical - vertical[0]).max() < 1e-13 * np.linalg.norm(tr.Pi[0])
    dE = np.abs(tr.energy - tr.energy[0])
    assert dE.max() < 1e-5 * abs(tr.energy[0])
    assert dE[1000:].max() < 2.0 * dE[:1001].max()


def test_axis_splitting_keeps_the_free_bodys_momentum_and_the_sphere():
    """Without a torque the axis splitting is not exact, but each rotation keeps R Pi and |Pi|:
    both to round-off over 400 steps, while the attitude error is the method's (order 8)."""
    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    tr = lgvi.simulate(body, np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.5, steps=400, scheme="splitting", order=8)
    assert tr.meta["composition"] == "axes-kl8"
    L = tr.spatial_momentum
    assert np.abs(L - L[0]).max() < 1e-13 * np.linalg.norm(L[0])
    nrm = np.linalg.norm(tr.Pi, axis=1)
    assert np.abs(nrm - nrm[0]).max() < 1e-13 * nrm[0]
    ref = free_body_attitude([1.0, 2.0, 3.0], np.eye(3), tr.Pi[0], np.array([200.0]))[0]
    assert 1e-12 < angle(ref, tr.R[-1]) < 1e-5


def test_free_body_keeps_every_momentum_component():
    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    tr = lgvi.simulate(body, np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.5, steps=400, scheme="splitting", order=2)
    L = tr.spatial_momentum
    assert np.abs(L - L[0]).max() < 1e-13 * np.linalg.norm(L[0])
    ref = free_body_attitude([1.0, 2.0, 3.0], np.eye(3), tr.Pi[0], np.array([200.0]))[0]
    assert angle(ref, tr.R[-1]) < 1e-11             # the drifts are exact: no error without a torque


@pytest.mark.parametrize("order, name", [(4, "aba84"), (8, "axes-kl8")])
def test_compiled_potential_equals_the_builtin_model(order, name):
    @numba.njit
    def gravity(t, R, Pi, p):
        return (R[2, 1] * p[2] - R[2, 2] * p[1], R[2, 2] * p[0] - R[2, 0] * p[2], R[2, 0] * p[1] - R[2, 1] * p[0])

    @numba.njit
    def height(t, R, p):
        return R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2]

    model = Compiled(gravity, potential=height, params=[0.0, 0.0, -0.3 * 9.81])
    kw = dict(omega0=4.14 * np.ones(3), h=0.01, steps=300, scheme="splitting", order=order, composition=name)
    a = lgvi.simulate(TOP, np.eye(3), torque=model, **kw)
    b = lgvi.simulate(TOP, np.eye(3), torque=HANGING, **kw)
    assert np.abs(a.R - b.R).max() < 1e-13 and np.abs(a.Pi - b.Pi).max() < 1e-12
    assert np.abs(a.energy - b.energy).max() < 1e-12


@pytest.mark.parametrize("order, name", [(4, "aba84"), (8, "axes-kl8")])
def test_full_inertia_matrix_under_gravity_gradient(order, name):
    """The kicks see the body frame: a body given with a rotated (full) inertia and rotated
    initial state moves as the diagonal one."""
    Q = so3.exp(np.array([0.2, -0.1, 0.3]))
    J = np.diag([0.0433, 0.0418, 0.0067])
    full = lgvi.RigidBody(Q @ J @ Q.T)
    w0 = np.array([0.08, -0.06, 0.09])
    kw = dict(h=5.0, steps=200, torque=GG, scheme="splitting", order=order, composition=name, save_every=200)
    a = lgvi.simulate(CUBESAT, np.eye(3), omega0=w0, **kw)
    b = lgvi.simulate(full, Q.T, omega0=Q @ w0, **kw)
    assert angle(a.R[-1], b.R[-1] @ Q) < 1e-12


def test_meta_and_save_every():
    kw = dict(omega0=4.14 * np.ones(3), torque=HANGING, scheme="splitting", order=4, h=0.01, steps=100)
    a = lgvi.simulate(TOP, np.eye(3), **kw)
    b = lgvi.simulate(TOP, np.eye(3), save_every=10, **kw)
    assert a.meta["scheme"] == "splitting" and a.meta["composition"] == DEFAULT_SPLITTING[4]
    assert np.abs(a.R[::10] - b.R).max() < 1e-13
    assert a.iterations.shape == (100,) and not a.iterations.any()
    assert a.solver_summary["steps"] == 100


def test_error_estimate_uses_the_splittings_order():
    """error_estimate=True re-runs the splitting at h/2; with a constant moment (not a potential)
    the order is still 2 (the LGVI's paper forcing would be 1), and the estimate is the error
    within a factor 1.5."""
    from lgvi.torques import Constant

    kw = dict(omega0=[0.3, 1.0, 0.2], torque=Constant([0.0, 0.05, 0.1]), scheme="splitting", order=2,
              composition="strang", save_every=200)
    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    tr = lgvi.simulate(body, np.eye(3), h=0.05, steps=200, error_estimate=True, error_warn=None, **kw)
    ref = lgvi.simulate(body, np.eye(3), h=0.05 / 64, steps=200 * 64, **dict(kw, save_every=200 * 64))
    est = tr.meta["error_estimate"]
    assert est["order"] == 2
    assert 1 / 1.5 < est["attitude"] / angle(ref.R[-1], tr.R[-1]) < 1.5


def test_stream(tmp_path):
    """simulate_stream runs the splitting too: in chunks of 100 steps, the same bits as in memory."""
    from lgvi.io.streaming import read_stream

    kw = dict(omega0=4.14 * np.ones(3), torque=HANGING, scheme="splitting", order=4, h=0.01, steps=400,
              save_every=10)
    lgvi.simulate_stream(tmp_path / "s", TOP, np.eye(3), chunk_steps=100, **kw)
    direct = lgvi.simulate(TOP, np.eye(3), **kw)
    streamed = read_stream(tmp_path / "s")
    assert np.array_equal(streamed.R, direct.R) and streamed.meta["scheme"] == "splitting"


@pytest.mark.parametrize("kwargs, match", [
    (dict(torque=lambda t, R, Pi: np.zeros(3)), "torque callable"),
    (dict(torque=np.zeros((10, 3))), "torque array"),
    (dict(torque=LinearDamping(0.1)), "depends on the angular momentum"),
    (dict(order=3), "order must be 2, 4, 6 or 8"),
    (dict(order=2, composition="aba84"), "of order 4"),
    (dict(order=6, composition="axes-kl8"), "of order 8"),
    (dict(composition="nope"), "composition"),
    (dict(forcing="symmetric"), "forcing"),
    (dict(scheme="rk4"), "scheme"),
])
def test_bad_input(kwargs, match):
    kw = dict(omega0=np.ones(3), h=0.01, steps=10, scheme="splitting", order=4)
    kw.update(kwargs)
    with pytest.raises(ValueError, match=match):
        lgvi.simulate(TOP, np.eye(3), **kw)


def test_scenario_chooses_the_splitting():
    from lgvi.io.scenario import Scenario

    d = {"body": {"inertia": [0.13, 0.28, 0.17]}, "initial": {"omega": [4.14, 4.14, 4.14]},
         "integrator": {"h": 0.01, "steps": 50, "scheme": "splitting", "composition": "aba84"},
         "torque": [{"type": "uniform_gravity", "mass": 1.0, "com": [0.0, 0.0, -0.3]}]}
    sc = Scenario.from_dict(d)
    assert sc.order == 4 and sc.simulate_kwargs()["scheme"] == "splitting"
    tr = sc.run()
    direct = lgvi.simulate(TOP, np.eye(3), omega0=4.14 * np.ones(3), h=0.01, steps=50, torque=HANGING,
                           scheme="splitting", order=4, composition="aba84")
    assert tr.meta["composition"] == "aba84" and np.array_equal(tr.R, direct.R)
    d["integrator"]["composition"] = "suzuki4"          # an LGVI composition is not a splitting
    with pytest.raises(ValueError, match="composition"):
        Scenario.from_dict(d)


def test_scenario_chooses_an_axis_splitting():
    """A scenario file names an axis splitting by its composition (order 8 follows from it)."""
    from lgvi.io.scenario import Scenario

    d = {"body": {"inertia": [0.13, 0.28, 0.17]}, "initial": {"omega": [4.14, 4.14, 4.14]},
         "integrator": {"h": 0.01, "steps": 50, "scheme": "splitting", "composition": "axes-kl8"},
         "torque": [{"type": "uniform_gravity", "mass": 1.0, "com": [0.0, 0.0, -0.3]}]}
    sc = Scenario.from_dict(d)
    tr = sc.run()
    direct = lgvi.simulate(TOP, np.eye(3), omega0=4.14 * np.ones(3), h=0.01, steps=50, torque=HANGING,
                           scheme="splitting", order=8)
    assert sc.order == 8 and tr.meta["composition"] == "axes-kl8" and tr.meta["order"] == 8
    assert np.array_equal(tr.R, direct.R)
    del d["integrator"]["composition"]                  # order = 8 alone picks the default splitting
    d["integrator"]["order"] = 8
    assert np.array_equal(Scenario.from_dict(d).run().R, direct.R)
    d["integrator"]["order"] = 10
    with pytest.raises(ValueError, match=r"integrator\.order.*2, 4, 6, 8"):
        Scenario.from_dict(d)
    d["integrator"].pop("scheme")                       # the LGVI compositions stop at order 6
    d["integrator"]["order"] = 8
    with pytest.raises(ValueError, match=r"integrator\.order.*2, 4, 6\b"):
        Scenario.from_dict(d)


def test_axis_splitting_save_every_and_stream(tmp_path):
    """Saving every 10th step gives the same states as saving every step (the step leaves nothing
    pending); streamed in chunks, the same bits as in memory."""
    from lgvi.io.streaming import read_stream

    kw = dict(omega0=4.14 * np.ones(3), torque=HANGING, scheme="splitting", order=8, h=0.01, steps=400)
    a = lgvi.simulate(TOP, np.eye(3), **kw)
    b = lgvi.simulate(TOP, np.eye(3), save_every=10, **kw)
    assert np.array_equal(a.R[::10], b.R) and a.meta["composition"] == "axes-kl8"
    lgvi.simulate_stream(tmp_path / "s", TOP, np.eye(3), chunk_steps=100, save_every=10, **kw)
    assert np.array_equal(read_stream(tmp_path / "s").R, b.R)
