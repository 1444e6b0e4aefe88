"""The MEKF's test cases (issue 27), shared by tests/test_estimation.py and
benchmarks/bench_estimation.py (its long NEES runs): truth trajectories from ``lgvi.simulate`` and
one Monte Carlo member (sensors with their own streams, a true bias and an initial attitude error
drawn from the filter's prior, the MEKF) run by :func:`lgvi.fsw._drive.run_components`.
"""

from __future__ import annotations


import numpy as np
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.fsw import MEKF
from lgvi.fsw._drive import run_components
from lgvi.spacecraft import FineSunSensor, Gyro, Magnetometer, StarTracker

H = 0.1                 # dynamics step, gyro and filter period (s)
ARW, RRW = 1e-4, 1e-5   # rad/s^0.5, rad/s^1.5 (a MEMS-grade gyro)
ST_CROSS, ST_ABOUT = 5e-5, 4e-4
BIAS_SD = 1e-4          # rad/s, the spread of the true constant biases (and the filter's prior)
BODY = lgvi.RigidBody([0.03, 0.04, 0.05])   # a 6U-like inertia, kg m^2
CASE = Rotation.from_rotvec([0.3, 1.2, -0.5]).as_matrix()
STEPS = 1200            # 120 s
MEMBERS = 100


def truth(omega0, steps=STEPS, sub=1):
    """``steps`` samples, every ``H``, of a free tumble from ``omega0``, integrated by the LGVI with
    steps of ``H / sub`` (``sub > 1``: sampled rates consistent with the sampled attitudes to the
    LGVI's error at the finer step, for the gyro's ``"rate"`` output)."""
    R0 = Rotation.from_rotvec([0.4, -0.3, 1.0]).as_matrix()
    traj = lgvi.simulate(BODY, R0, omega0=omega0, h=H / sub, steps=(steps - 1) * sub)
    return {"R": traj.R[::sub].reshape(steps, 9), "omega": traj.omega[::sub]}


TUMBLING = [0.1, -0.2, 0.15]
POINTING = [0.0, -1.1e-3, 0.0]      # an Earth-pointing rate


def member(tr, seed, *, att_sd, output="mean", sensors="st", st_rate=0.5, **mekf_kw):
    """One member: gyro and star tracker (or magnetometer and sun sensor) with their own streams,
    a random true bias and a random initial attitude error, both drawn from the filter's prior."""
    rng = np.random.default_rng(seed)
    bias = rng.normal(scale=BIAS_SD, size=3)
    err0 = rng.normal(scale=att_sd, size=3)
    R0 = tr["R"][0].reshape(3, 3)
    gyro = Gyro(rate=H, arw=ARW, rrw=RRW, bias=bias, output=output, seed=seed)
    comps = [gyro]
    if sensors == "st":
        st = StarTracker(rate=st_rate, sigma_cross=ST_CROSS, sigma_about=ST_ABOUT, case=CASE, seed=seed)
        comps.append(st)
        kw = dict(star_tracker=st)
    else:
        comps += [Magnetometer(rate=0.5, sigma=1e-7, seed=seed), FineSunSensor(rate=1.0, sigma=2e-3, seed=seed)]
        kw = dict(mag_sigma=1e-7, sun_sigma=2e-3)
    P0 = np.r_[[att_sd ** 2] * 3, [BIAS_SD ** 2] * 3]
    est = MEKF(rate=H, arw=ARW, rrw=RRW, R0=R0 @ Rotation.from_rotvec(-err0).as_matrix(), P0=P0,
               gyro_output=output, **kw, **mekf_kw)
    comps.append(est)
    consts = {"B_N": [2e-5, -1e-5, 3.5e-5], "sun_N": np.array([0.6, 0.0, 0.8]), "shadow": 1.0} \
        if sensors != "st" else None
    run = run_components(comps, tr, H, record=["est_error", "gyro_bias", "bias_est", "P_diag"],
                         record_state={"P": (len(comps) - 1, np.arange(7, 43))}, constants=consts)
    assert run.status == 0 and run.rows == len(tr["R"])
    e = np.concatenate([run.records["est_error"], run.records["gyro_bias"] - run.records["bias_est"]], axis=1)
    return e, run.records["P"].reshape(-1, 6, 6)


def nees(e, P):
    return np.einsum("ni,ni->n", e, np.linalg.solve(P, e[..., None])[..., 0])
