"""The environment, disturbance, sensor and estimator kinds (issues 26 and 27) in the compiled loop
(issue 25): a tumbling 6U under every disturbance against Basilisk, the MEKF closing a pointing
loop from a gyro and a star tracker, an ensemble member with sensors equal to its lone run.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.environment import CentredDipole, CircularOrbit, ExponentialAtmosphere, KeplerOrbit, Shadow, Sun
from lgvi.fsw import MEKF, FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
from lgvi.spacecraft import FacetDrag, FacetSRP, GravityGradient, Gyro, ResidualDipole, Spacecraft, StarTracker

ROOT = Path(__file__).resolve().parents[1]
S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
R_TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))


def _basilisk_6u(gravity_gradient: bool = True) -> tuple[Spacecraft, dict]:
    """The tumbling 6U of ``benchmarks/basilisk_loop_scenario.py`` as an lgvi Spacecraft."""
    d = dict(np.load(ROOT / "benchmarks" / "basilisk_loop_scenario.npz"))
    mu = float(d["mu"])
    orbit = KeplerOrbit(float(np.linalg.norm(d["r0"])), 0.0, np.radians(97.4), 0.0, 0.0, 0.0, mu=mu)
    facets = (d["fac_area"], d["fac_normal"], d["fac_centre"])
    sc = Spacecraft(d["J"], orbit=orbit, field=CentredDipole(*d["g10_g11_h11"]),
                    epoch=dt.datetime.fromisoformat(str(d["epoch"])),
                    environment=[Shadow("conical", planet_radius=6378136.6, sun_radius=float(d["R_sun"])), Sun(),
                                 ExponentialAtmosphere(float(d["rho0"]), float(d["H"]),
                                                       planet_radius=float(d["planet_radius"]),
                                                       omega=float(d["omega_earth"]))],
                    disturbances=[FacetDrag(*facets, d["fac_cd"]),
                                  FacetSRP(*facets, absorbed=1.0 - d["fac_specular"] - d["fac_diffuse"],
                                           specular=d["fac_specular"], diffuse=d["fac_diffuse"], solar_flux=1368.0),
                                  ResidualDipole(d["dipole"])] + ([GravityGradient(mu=mu)] if gravity_gradient else []))
    return sc, d


def _extrapolated(coarse: Rotation, fine: Rotation, order: int) -> Rotation:
    """Richardson's extrapolation to h = 0 of a method of this order from its runs at 2h and h, along the
    geodesic: ``fine exp(log(coarse^-1 fine) / (2^order - 1))``."""
    return fine * Rotation.from_rotvec((coarse.inv() * fine).as_rotvec() / (2 ** order - 1))


def test_tumbling_6u_under_every_disturbance_converges_to_basilisk():
    """One orbit (5680 s) of the tumbling 6U under gravity gradient, facet drag, facet SRP (with the
    conical shadow) and a residual dipole. The loop forces the step symmetrically (each disturbance at
    both ends of the step, docs/environment.md), so it is second order. Basilisk's RK4 holds the
    environment (density, wind, shadow, field) over each of its steps, which makes it first order
    (fixtures at h = 0.1, 0.05, 0.025, flown on Kepler's orbit as lgvi flies: the hub 1e9 times
    heavier); both extrapolated to h = 0 agree to 3.3e-7 rad, and lgvi's error against Basilisk's
    limit falls by 4 with each halving of h. The environment on the bus is Basilisk's along its orbit
    (shadow, density, field), and the disturbance sum is the sum of the recorded torques."""
    sc, d = _basilisk_6u()
    R0 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    T = float(d["t"][-1])
    bsk = {h: Rotation.from_mrp(np.load(ROOT / "benchmarks" / f"basilisk_loop_scenario_kepler{n}.npz")["sigma"])
           for h, n in ((0.1, ""), (0.05, "_half"), (0.025, "_quarter"))}
    b_diff = [(bsk[0.1].inv() * bsk[0.05]).magnitude().max(), (bsk[0.05].inv() * bsk[0.025]).magnitude().max()]
    assert 1.8 < b_diff[0] / b_diff[1] < 2.2, b_diff         # Basilisk first order: 2.05e-5, 1.03e-5
    b_zero = _extrapolated(bsk[0.05], bsk[0.025], 1)

    def run(h, **kw):
        return lgvi.simulate(sc, R0, omega0=d["omega0"], h=h, steps=int(round(T / h)), save_every=int(round(10.0 / h)),
                             **kw)

    runs = {}
    for h in (0.2, 0.1, 0.05, 0.025):
        traj = run(h)
        assert np.allclose(traj.t, d["t"], rtol=0, atol=1e-9)
        runs[h] = Rotation.from_matrix(traj.R)
        if h == 0.1:
            s = traj.signals
            E = len(d["t"]) - 1                                 # entries at 0, 10, ... s; the last one ends the run
            # lgvi flies the Kepler orbit, Basilisk integrates its own with the drag and SRP forces: 35 m
            # apart after one orbit (along track), which moves the environment by as much
            assert np.max(np.linalg.norm(s["r_N"] - d["r"][:E], axis=1)) < 50.0
            assert np.max(np.abs(s["shadow"][:, 0] - d["shadow"][:E])) < 1e-4         # 2 samples in penumbra
            assert np.max(np.abs(s["density"][:, 0] / d["density"][:E] - 1.0)) < 1e-3
            assert np.max(np.linalg.norm(s["B_N"] - d["B_N"][:E], axis=1) / np.linalg.norm(d["B_N"][:E], axis=1)) \
                < 1e-4
            parts = s["tau_facet_drag_B"] + s["tau_facet_srp_B"] + s["tau_residual_dipole_B"]
            assert np.array_equal(s["tau_dist_B"], parts) or np.allclose(s["tau_dist_B"], parts, rtol=1e-15,
                                                                          atol=1e-24)
            assert np.all(np.linalg.norm(s["tau_facet_srp_B"][d["shadow"][:E] == 0.0], axis=1) == 0.0)
            assert np.all(np.linalg.norm(s["tau_facet_drag_B"], axis=1) > 0.0)
    # second order against Basilisk's limit: 1.20e-2, 3.01e-3, 7.52e-4, 1.88e-4 rad (ratios 4.00, 4.00, 3.99)
    err = {h: (b_zero.inv() * R).magnitude().max() for h, R in runs.items()}
    ratios = [err[0.2] / err[0.1], err[0.1] / err[0.05], err[0.05] / err[0.025]]
    assert all(3.8 < r < 4.2 for r in ratios), (err, ratios)
    # the two limits agree (measured 3.3e-7 rad over the orbit)
    assert (b_zero.inv() * _extrapolated(runs[0.05], runs[0.025], 2)).magnitude().max() < 1e-6
    # at h = 0.1 the default step errs by 3e-3 rad (the free rotation's second-order phase error); the
    # fourth-order composition (disturbances still symmetric over the whole step) by 9.8e-7
    assert (b_zero.inv() * Rotation.from_matrix(run(0.1, order=4).R)).magnitude().max() < 1.1e-6
    # the 35 m of Basilisk's orbit under the drag and SRP forces move the attitude by 1.1e-6 rad in an orbit
    heavy = (Rotation.from_mrp(d["sigma"]).inv() * bsk[0.1]).magnitude().max()
    assert 5e-7 < heavy < 2e-6, heavy


def test_the_symmetric_forcing_balances_the_spatial_momentum_with_the_trapezoidal_impulse(tmp_path):
    """With the disturbances forced symmetrically, the discrete spatial momentum changes over a step by
    exactly the trapezoidal impulse of the recorded disturbance torques,
    ``R_k+1 Pi_k+1 - R_k Pi_k = h/2 (R_k tau_k + R_k+1 tau_k+1)`` (round-off); held over the step it
    would be ``h/2 (R_k + R_k+1) tau_k``, which misses by ``h/2 R_k+1 (tau_k+1 - tau_k)``. A run streamed
    in chunks (the end-of-step torque recomputed at each chunk's start) equals the run in memory bit for bit."""
    from lgvi.io.streaming import read_stream, stream_system

    sc, d = _basilisk_6u(gravity_gradient=False)
    R0 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    h = 0.5
    kw = dict(omega0=d["omega0"], h=h, steps=400, solver_record="full")
    tr = lgvi.simulate(sc, R0, **kw)
    tau = tr.signals["tau_dist_B"]                       # at steps 0 .. steps - 1
    L = np.einsum("kij,kj->ki", tr.R, tr.Pi)
    Rt = np.einsum("kij,kj->ki", tr.R[:len(tau)], tau)
    n = len(tau) - 1
    step = L[1:n + 1] - L[:n]
    trapezoid = 0.5 * h * (Rt[:n] + Rt[1:n + 1])
    held = 0.5 * h * np.einsum("kij,kj->ki", tr.R[:n] + tr.R[1:n + 1], tau[:n])
    scale = np.abs(L).max()
    assert np.abs(step - trapezoid).max() < 1e-14 * scale          # measured 2.8e-18 (scale 5.7e-3)
    assert np.abs(step - held).max() > 1e3 * np.abs(step - trapezoid).max()    # measured 5.8e-9
    # a disturbance restricted to a mode keeps them all held (first order, as before): then the balance is
    # the held one, and tau_dist_B is still the sum of the torques, step after step
    held_sc, _ = _basilisk_6u(gravity_gradient=False)
    for c in held_sc.components():
        if c.kind == "residual_dipole":
            c.modes = (0,)                      # the only mode of a run without mode rules
    hr = lgvi.simulate(held_sc, R0, **kw)
    hs = hr.signals
    assert np.array_equal(hs["tau_dist_B"], hs["tau_facet_drag_B"] + hs["tau_facet_srp_B"]
                          + hs["tau_residual_dipole_B"]) or np.allclose(
        hs["tau_dist_B"], hs["tau_facet_drag_B"] + hs["tau_facet_srp_B"] + hs["tau_residual_dipole_B"], rtol=1e-15,
        atol=1e-24)
    Lh = np.einsum("kij,kj->ki", hr.R, hr.Pi)
    held_step = 0.5 * h * np.einsum("kij,kj->ki", hr.R[:n] + hr.R[1:n + 1], hs["tau_dist_B"][:n])
    assert np.abs(Lh[1:n + 1] - Lh[:n] - held_step).max() < 1e-14 * scale
    folder = tmp_path / "six_u"
    stream_system(folder, "spacecraft", sc, R0, chunk_steps=70, **kw)
    back = read_stream(folder)
    assert np.array_equal(back.R, tr.R) and np.array_equal(back.Pi, tr.Pi)
    for name in tr.signals:
        assert np.array_equal(back.signals[name], tr.signals[name]), name


def _pointing(**mekf_kw):
    wheels = lgvi.ReactionWheels(PYRAMID, 1e-4, speed0=[10.0, -20.0, 5.0, 0.0], max_torque=0.004)
    gyro = Gyro(rate=0.5, arw=1e-4, rrw=1e-5, bias=[2e-4, -1e-4, 5e-5], seed=7)
    st = StarTracker(rate=0.5, sigma_cross=5e-5, sigma_about=4e-4, seed=7)
    sc = Spacecraft([0.18, 0.14, 0.06], wheels=wheels, sensors=[gyro, st])
    err0 = np.array([0.02, -0.03, 0.01])
    est = MEKF(rate=0.5, arw=1e-4, rrw=1e-5, star_tracker=st, R0=lgvi.so3.exp(-err0),
               P0=[0.03 ** 2] * 3 + [3e-4 ** 2] * 3, **mekf_kw)
    fsw = FlightSoftware(estimator=est, guidance=InertialPointing(R_TARGET),
                         control=MRPControl(K=0.004, P=0.04), actuators=RWMotorTorque(), rate=1.0)
    return sc, fsw


def test_mekf_in_the_pointing_loop_stays_inside_its_3_sigma_bounds():
    """Gyro and star tracker at 2 Hz, the MEKF at 2 Hz, MRP feedback at 1 Hz on the estimate: the
    recorded estimation error is the error of the recorded estimate, lies inside +-3 sigma of the
    recorded covariance on (at least) 99% of the samples, and the spacecraft reaches its target
    within the knowledge error; the run differs from the one with true-state feedback."""
    sc, fsw = _pointing()
    kw = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=3000, save_every=5)
    traj = lgvi.simulate(sc, np.eye(3), fsw=fsw, **kw)
    s = traj.signals
    for name in ("gyro_B", "st_q", "R_est", "omega_est", "bias_est", "P_diag", "est_error", "sigma_BR"):
        assert name in s, name
    R_est = s["R_est"].reshape(-1, 3, 3)
    R_true = traj.R[:-1]
    # the estimator's error, recomputed from the records: R = R_est Exp(est_error)
    err = Rotation.from_matrix(np.einsum("kji,kjl->kil", R_est, R_true)).as_rotvec()
    assert np.allclose(err, s["est_error"], rtol=0, atol=1e-12)
    sd = np.sqrt(s["P_diag"][:, :3])
    inside = np.abs(s["est_error"]) <= 3.0 * sd
    assert inside.mean() >= 0.99, inside.mean()
    assert np.abs(s["est_error"][-100:]).max() < 1e-3                   # converged from 0.04 rad
    assert abs(s["P_diag"][-1, 0]) < 1e-7
    # pointing: the true attitude reaches the target within a few times the knowledge error
    final = Rotation.from_matrix(R_TARGET.T @ traj.R[-1]).magnitude()
    assert final < 2e-3, final
    truth = lgvi.simulate(Spacecraft([0.18, 0.14, 0.06], wheels=sc.wheels), np.eye(3),
                          fsw=FlightSoftware(guidance=InertialPointing(R_TARGET), control=MRPControl(K=0.004, P=0.04),
                                             actuators=RWMotorTorque(), rate=1.0), **kw)
    assert not np.array_equal(truth.R, traj.R)


@pytest.mark.parametrize("threads", [1, 2])
def test_an_ensemble_member_with_sensors_equals_its_lone_run(threads):
    """Per-member seeds and initial estimates: member b is the lone run with seed b's sensors and
    member b's estimate, bit for bit, on one or two threads."""
    seeds = [3, 11]
    R0s = np.stack([lgvi.so3.exp(np.array([0.01, 0.0, 0.0])), lgvi.so3.exp(np.array([0.0, -0.02, 0.01]))])

    def build(seed, R0):
        wheels = lgvi.ReactionWheels(PYRAMID, 1e-4, max_torque=0.004)
        gyro = Gyro(rate=0.5, arw=1e-4, rrw=1e-5, seed=seed)
        st = StarTracker(rate=0.5, sigma_cross=5e-5, sigma_about=4e-4, seed=seed)
        est = MEKF(rate=0.5, arw=1e-4, rrw=1e-5, star_tracker=st, R0=R0, P0=[0.03 ** 2] * 3 + [3e-4 ** 2] * 3)
        return (Spacecraft([0.18, 0.14, 0.06], wheels=wheels, sensors=[gyro, st]),
                FlightSoftware(estimator=est, guidance=InertialPointing(R_TARGET), control=MRPControl(K=0.004, P=0.04),
                               actuators=RWMotorTorque(), rate=1.0))

    sc, fsw = build(seeds, R0s)              # one description, one row per member
    kw = dict(h=0.1, steps=400, save_every=10)
    R = np.stack([np.eye(3)] * 2)
    w0 = np.array([[0.01, -0.02, 0.015], [0.0, 0.01, 0.0]])
    ens = lgvi.simulate_ensemble(sc, R, omega0=w0, fsw=fsw, threads=threads, **kw)
    for b in range(2):
        one = lgvi.simulate(*build(seeds[b], R0s[b])[:1], R[b], omega0=w0[b], fsw=build(seeds[b], R0s[b])[1], **kw)
        assert np.array_equal(ens[b].R, one.R) and np.array_equal(ens[b].Pi, one.Pi)
        assert np.array_equal(ens[b].signal_data, one.signal_data, equal_nan=True)
    assert not np.array_equal(ens[0].signals["gyro_B"], ens[1].signals["gyro_B"])
    assert "mag_B" not in ens[0].signals             # read by the MEKF, written by no sensor: not recorded
    with pytest.raises(ValueError, match="one per member"):
        lgvi.simulate(sc, R[0], omega0=w0[0], fsw=fsw, **kw)
    with pytest.raises(ValueError, match="gyro: params.. gives 2 rows .one per member., and the ensemble has 3"):
        lgvi.simulate_ensemble(sc, np.stack([np.eye(3)] * 3), omega0=np.zeros((3, 3)), fsw=fsw, **kw)


def test_io_layout_of_the_loop_matches_the_run():
    """``io`` is the loop's own signal offsets (``_IO``), then the disturbance count at ``IO_NDIST``:
    the kernel's constants and the run's list must agree (two branches once both took ``io[8]``)."""
    from lgvi._kernels import loop_kernels
    from lgvi.systems import spacecraft

    assert len(spacecraft._IO) == loop_kernels.IO_NDIST
    assert spacecraft._IO.index("tau_dist_B") == loop_kernels.IO_DIST
    assert spacecraft._IO.index("mode") == loop_kernels.IO_MODE


def test_environment_coefficients_per_member_bit_for_bit():
    """The sun's, the shadow's and the atmosphere's coefficients given one per member (with the
    facets' drag coefficients and the dipole): member b of the ensemble is the lone run of the
    spacecraft with member b's numbers, bit for bit; the members differ. The momentum budget has
    every source by name, the gravity gradient's too (tau_gravity_gradient_B, not in tau_dist_B)."""
    epoch = dt.datetime(2026, 3, 20, 6)
    facets = ([0.06, 0.03], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [[0.05, 0.01, 0.0], [0.0, 0.05, 0.02]])

    def sat(rho0, H, r_sun, interp, cd, dipole):
        return Spacecraft([0.18, 0.14, 0.06], orbit=CircularOrbit(6778137.0, np.radians(97.4)),
                          field=CentredDipole(), epoch=epoch,
                          environment=[Sun(interpolation=interp), Shadow("conical", sun_radius=r_sun),
                                       ExponentialAtmosphere(rho0, H)],
                          disturbances=[FacetDrag(*facets, drag_coefficient=cd),
                                        FacetSRP(*facets, absorbed=0.6, specular=0.2, diffuse=0.2),
                                        ResidualDipole(dipole), GravityGradient()])

    rho0, H, r_sun, interp = [1.217, 2.4], [8500.0, 7000.0], [6.957e8, 6.96e8], [60.0, 30.0]
    cd, dipole = [[2.2, 2.1], [2.4, 2.0]], [[0.01, 0.0, 0.0], [0.0, 0.02, 0.005]]
    ens_sc = sat(np.array(rho0), np.array(H), np.array(r_sun), np.array(interp), np.array(cd), np.array(dipole))
    kw = dict(h=0.5, steps=120, save_every=10)
    R0 = np.stack([np.eye(3), lgvi.so3.exp([0.2, -0.1, 0.3])])
    w0 = np.array([[0.01, -0.02, 0.015], [0.0, 0.01, -0.01]])
    ens = lgvi.simulate_ensemble(ens_sc, R0, omega0=w0, threads=1, **kw)
    for b in range(2):
        one = lgvi.simulate(sat(rho0[b], H[b], r_sun[b], interp[b], cd[b], dipole[b]), R0[b], omega0=w0[b], **kw)
        assert np.array_equal(ens[b].R, one.R) and np.array_equal(ens[b].Pi, one.Pi), b
        assert np.array_equal(ens[b].signal_data, one.signal_data), b
    assert not np.array_equal(ens[0].signals["density"], ens[1].signals["density"])
    budget = {n for n in ens[0].signals if n.startswith("tau_") and n.endswith("_B")}
    assert budget == {"tau_facet_drag_B", "tau_facet_srp_B", "tau_residual_dipole_B", "tau_gravity_gradient_B",
                      "tau_dist_B"}
    sig = ens[0].signals
    total = sig["tau_facet_drag_B"] + sig["tau_facet_srp_B"] + sig["tau_residual_dipole_B"]
    assert np.allclose(sig["tau_dist_B"], total, rtol=0.0, atol=1e-15 * np.abs(total).max())
