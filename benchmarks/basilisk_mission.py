"""The CubeSat mission's nadir phase (``examples/cubesat_mission.toml``) for one orbit: lgvi's
compiled loop against Basilisk 2.12.1.

Usage::

    python benchmarks/basilisk_mission.py --write-fixture      # with Basilisk (the bench extra): h and h/2
    PYTHONPATH=src python benchmarks/basilisk_mission.py --bsk-python /path/to/bsk-venv/bin/python
    PYTHONPATH=src python benchmarks/basilisk_mission.py --quick    # agreement with the fixture only
    python benchmarks/basilisk_mission.py --write-noisy-fixture --members 50    # with Basilisk: noise on
    PYTHONPATH=src python benchmarks/basilisk_mission.py --noisy    # lgvi's 50 noisy members against it

The mission's 6U, from the mission file: its inertia (with the products), the four pyramid wheels
(2e-5 kg m^2, 2 mN m), the six facets (drag coefficient 2.2; absorbed 0.6, specular 0.2, diffuse
0.2), the residual dipole, the exponential atmosphere (co-rotating), the MRP gains (K 0.004, P 0.04),
the flight software at 2 Hz and the dynamics step h = 0.1 s. Its nadir mode: ``hillPoint`` ->
``attTrackingError`` -> ``mrpFeedback`` -> ``rwMotorTorque``, perfect navigation, no sensors.
Disturbances on both sides: the gravity gradient, facet drag, facet SRP with the conical shadow,
the residual dipole. What differs from the mission, on both sides alike:

* no magnetic momentum dumping (Basilisk's ``mtbMomentumManagement`` needs its own rod and wheel
  configuration messages and a torque-rod effector in the loop: not wired here);
* the field is the centred dipole of IGRF's first degree (``magneticFieldCenteredDipole``; Basilisk
  has no IGRF) and the orbit a circular Kepler orbit with the TLE's elements (RAAN 0, i 97.4 deg,
  argument of latitude 0 at the epoch 2026-03-20 00:00 UTC), Basilisk's ``mu``, no J2; Basilisk's
  hub mass is 1e6 kg so that the facets' forces do not move its orbit off lgvi's Kepler orbit (the
  attitude does not depend on the mass: the centre of mass is at B);
* the sun is lgvi's (``basilisk_loop_scenario_ephemeris.json``: the same epoch), the environment
  and the disturbance torques are evaluated at every dynamics step (the mission holds them 0.5 s).

The spacecraft starts 3 degrees off the Hill frame, at the orbit rate plus (0.2, -0.1, 0.15) mrad/s,
the wheels at (30, -50, 40, 10) rad/s. Basilisk integrates with RK4 (the torques at its stages,
the environment held over each step: first order, 3.7e-8 rad between h and h/2); lgvi's loop forces
each disturbance torque symmetrically over its step (second order: 1.38e-8, 3.46e-9, 8.6e-10 rad
between h and h/2, h/2 and h/4, h/4 and h/8). The two agree to 7.1e-8 rad over the orbit, the rest
being Basilisk's own first-order error (docs/mission.md). The reaction-wheel effector runs before the
hub integrates, so the wheels apply each command from the step it is computed at (as lgvi does).
``basilisk_mission.npz`` keeps Basilisk's ``sigma_BN``, rate and wheel speeds every 10 s at h and
at h/2 (its own convergence), and its CPU time.

**With noise on** (``--write-noisy-fixture``, ``--noisy``): the same orbit, 50 members, each with
its own noise, on both sides the navigation of Basilisk's ``simpleNav`` (lgvi's
:class:`lgvi.fsw.SimpleNav`, the same law): every dynamics step (``simpleNav`` runs in the dynamics
task) a bounded random walk of the MRP attitude error (``NAV_ATTITUDE`` a step, bound
``NAV_ATTITUDE_BOUND``) and of the rate error (``NAV_RATE``, ``NAV_RATE_BOUND``), composed with the
truth; the flight software reads it at 2 Hz. Neither side has an estimator: the comparison is of the
loop's response to the same navigation error law, not of two filters (Basilisk has no MEKF). Member
``b``: Basilisk's ``RNGSeed = 1000 + b``, lgvi's ``seed = b`` (different streams of the same law).
Per member, from ``SETTLE`` s on, every second: the mean and the 95th percentile of the true
pointing error (the truth against the Hill frame of the true orbit) and the mean navigation error.
``basilisk_mission_noisy.npz`` keeps Basilisk's 50 rows; ``tests/test_mission.py`` flies lgvi's 50
and compares the distributions (Welch intervals of the difference of means, two-sample
Kolmogorov-Smirnov).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from loop_hill_pointing import matrix_of, mrp_of  # noqa: E402  (the MRP conversions, NumPy only)

HERE = Path(__file__).resolve().parent
FIXTURE = HERE / "basilisk_mission.npz"
EPHEMERIS = HERE / "basilisk_loop_scenario_ephemeris.json"
MISSION = tomllib.loads((HERE.parent / "examples" / "cubesat_mission.toml").read_text())

EPOCH = dt.datetime(2026, 3, 20)
MU = 3.98600436e14                       # Basilisk's Earth
R_EARTH = 6378136.6
A = R_EARTH + 500e3
INC = np.radians(97.4)
PERIOD = 2.0 * np.pi * np.sqrt(A ** 3 / MU)
H = MISSION["integrator"]["h"]           # 0.1 s
FSW_DT = MISSION["fsw"]["rate"]          # 0.5 s
SAVE = 10.0
DURATION = 5670.0                        # one orbit (of 5677 s), whole records
OMEGA_EARTH = 7.292115e-5
G10_G11_H11 = np.array([-29350.0, -1410.3, 4545.5])   # IGRF's first degree (nT)
OFFSET = np.radians(3.0) * np.array([0.48, 0.6, -0.64])
DOMEGA = np.array([2e-4, -1e-4, 1.5e-4])
SPEED0 = np.array([30.0, -50.0, 40.0, 10.0])
BSK_MASS = 1e6
NOISY_FIXTURE = HERE / "basilisk_mission_noisy.npz"
NAV_ATTITUDE, NAV_ATTITUDE_BOUND = 2e-5, 2.5e-4     # MRP a step (0.1 s), bound: 1e-3 rad
NAV_RATE, NAV_RATE_BOUND = 1e-6, 1e-5               # rad/s a step, bound
SETTLE = 1000.0                                     # [s] the statistics from here (the 3 deg start settled)
EVERY = 1.0                                         # [s] the statistics' sampling

_SC = MISSION["spacecraft"]
J = np.array(_SC["body"]["matrix"])
AXES = np.array([w["axis"] for w in _SC["wheel"]])
JS = _SC["wheel"][0]["spin_inertia"]
U_MAX = _SC["wheel"][0]["max_torque"]
_DIST = {d["type"]: d for d in _SC["disturbance"]}
_ATM = next(e for e in _SC["environment"] if e["type"] == "exponential_atmosphere")
RHO0, SCALE_H = _ATM["base_density"], _ATM["scale_height"]
DIPOLE = np.array(_DIST["residual_dipole"]["dipole"])
_MRP = next(c for c in MISSION["fsw"]["control"] if c["type"] == "mrp_feedback")
K, P = _MRP["K"], _MRP["P"]


def facets() -> dict[str, np.ndarray]:
    """The mission's six facets in the ``fac_*`` layout of ``basilisk_environment.py``."""
    drag, srp = _DIST["facet_drag"], _DIST["facet_srp"]
    n = len(drag["area"])
    return dict(fac_area=np.array(drag["area"]), fac_normal=np.array(drag["normal"], dtype=float),
                fac_centre=np.array(drag["centre"]), fac_cd=np.full(n, drag["drag_coefficient"]),
                fac_specular=np.full(n, srp["specular"]), fac_diffuse=np.full(n, srp["diffuse"]))


def rotation(v: np.ndarray) -> np.ndarray:
    """``exp(hat(v))`` (Rodrigues; NumPy only)."""
    th = np.linalg.norm(v)
    K_ = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]) / th
    return np.eye(3) + np.sin(th) * K_ + (1.0 - np.cos(th)) * K_ @ K_


def initial_state() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``r0, v0`` (inertial), ``R0`` (body to inertial) and ``omega0`` (body)."""
    r0 = A * np.array([1.0, 0.0, 0.0])
    v0 = np.sqrt(MU / A) * np.array([0.0, np.cos(INC), np.sin(INC)])
    hn = np.cross(r0, v0)
    hn /= np.linalg.norm(hn)
    x = r0 / np.linalg.norm(r0)
    hill = np.stack([x, np.cross(hn, x), hn], axis=1)
    R0 = hill @ rotation(OFFSET)
    omega0 = R0.T @ (np.sqrt(MU / A ** 3) * hn) + DOMEGA
    return r0, v0, R0, omega0


# ------------------------------------------------------------------------------------------------
# Basilisk
# ------------------------------------------------------------------------------------------------
def run_basilisk(h: float = H, nav_seed: int | None = None) -> dict:
    """The nadir phase in Basilisk at the dynamics step ``h``: records every ``SAVE`` s and the CPU
    time of ``ExecuteSimulation()``; with ``nav_seed``, ``simpleNav``'s noise on (that ``RNGSeed``)
    and, instead of the records, the member's statistics (:func:`noisy_statistics`)."""
    from Basilisk.utilities import SimulationBaseClass, macros

    import _basilisk as bsk

    eph = json.loads(EPHEMERIS.read_text())
    assert eph["epoch"] == EPOCH.isoformat() and eph["t"][-1] >= DURATION + 60.0
    r0, v0, R0, omega0 = initial_state()
    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("p")
    proc.addTask(sim.CreateNewTask("dyn", macros.sec2nano(h)), 200)      # the dynamics first at a common time
    proc.addTask(sim.CreateNewTask("fsw", macros.sec2nano(FSW_DT)), 100)
    eph_mod = bsk.ephemeris_module(eph["t"], eph["sun"], eph["gmst"], 60.0)
    sim.AddModelToTask("dyn", eph_mod, 100)
    sc = bsk.hub("mission6U", BSK_MASS, J, r0, v0, mrp_of(R0), omega0)
    planet = bsk.earth(sc, MU)
    rwe, rwf = bsk.wheels(sc, AXES, JS, SPEED0, U_MAX)
    sim.AddModelToTask("dyn", rwe, 120)   # before the hub integrates [t - h, t]: reads the command of t - h
    gg = bsk.gravity_gradient(sc, planet)
    env = bsk.disturbances(sc, eph_mod, facets(), rho0=RHO0, H=SCALE_H, planet_radius=R_EARTH,
                           omega_earth=OMEGA_EARTH, g10_g11_h11=G10_G11_H11, dipole=DIPOLE)
    bsk.add_environment(sim, "dyn", sc, env, gg)
    fsw = bsk.hill_pointing_fsw(sim, "dyn", "fsw", sc, rwe, rwf, J, K, P)  # noqa: F841 (kept alive)
    if nav_seed is None:
        return bsk.record_and_run(sim, "dyn", sc, rwe, SAVE, DURATION)
    nav = fsw["nav"]
    noise, bounds = np.zeros((18, 18)), np.zeros(18)
    noise[6:9, 6:9], noise[9:12, 9:12] = NAV_ATTITUDE * np.eye(3), NAV_RATE * np.eye(3)
    bounds[6:9], bounds[9:12] = NAV_ATTITUDE_BOUND, NAV_RATE_BOUND
    nav.PMatrix, nav.walkBounds, nav.RNGSeed = noise.tolist(), bounds.tolist(), int(nav_seed)
    state_log = sc.scStateOutMsg.recorder(macros.sec2nano(EVERY))
    nav_log = nav.attOutMsg.recorder(macros.sec2nano(EVERY))
    for log in (state_log, nav_log):
        sim.AddModelToTask("dyn", log)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(DURATION))
    c0 = time.process_time()
    sim.ExecuteSimulation()
    cpu = time.process_time() - c0
    t = state_log.times() * 1e-9
    R = matrix_of(np.array(state_log.sigma_BN))             # body -> inertial, as lgvi's R
    R_nav = matrix_of(np.array(nav_log.sigma_BN))
    out = noisy_statistics(t, R, np.array(state_log.r_BN_N), np.array(state_log.v_BN_N), R_nav)
    out["cpu"] = cpu
    return out


def basilisk_in(python: str | None, h: float = H) -> dict:
    """:func:`run_basilisk` in a child process (``python``: an interpreter with Basilisk)."""
    import _basilisk as bsk

    return bsk.run_child(__file__, python, "--h", repr(h))


# ------------------------------------------------------------------------------------------------
# lgvi
# ------------------------------------------------------------------------------------------------
def lgvi_scenario(nav=None):
    """``(spacecraft, R0, omega0, fsw)``: the same nadir phase in lgvi (``nav``: a navigation
    component the flight software reads, :class:`lgvi.fsw.SimpleNav`; default the truth)."""
    import lgvi
    from lgvi.environment import CentredDipole, ExponentialAtmosphere, KeplerOrbit, Shadow, Sun
    from lgvi.fsw import FlightSoftware, HillPointing, MRPControl, RWMotorTorque
    from lgvi.spacecraft import FacetDrag, FacetSRP, GravityGradient, ResidualDipole, Spacecraft

    r0, v0, R0, omega0 = initial_state()
    fac = facets()
    geometry = (fac["fac_area"], fac["fac_normal"], fac["fac_centre"])
    srp = _DIST["facet_srp"]
    sc = Spacecraft(J, wheels=lgvi.ReactionWheels(AXES, JS, speed0=SPEED0, max_torque=U_MAX),
                    orbit=KeplerOrbit(A, 0.0, INC, 0.0, 0.0, 0.0, mu=MU), field=CentredDipole(*G10_G11_H11),
                    epoch=EPOCH,
                    environment=[Shadow("conical", planet_radius=R_EARTH, sun_radius=695e6), Sun(),
                                 ExponentialAtmosphere(RHO0, SCALE_H, planet_radius=R_EARTH, omega=OMEGA_EARTH)],
                    disturbances=[FacetDrag(*geometry, fac["fac_cd"]),
                                  FacetSRP(*geometry, absorbed=srp["absorbed"], specular=srp["specular"],
                                           diffuse=srp["diffuse"], solar_flux=1368.0),
                                  ResidualDipole(DIPOLE), GravityGradient(mu=MU)])
    fsw = FlightSoftware(guidance=HillPointing(), control=MRPControl(K=K, P=P), actuators=RWMotorTorque(),
                         estimator=nav, rate=FSW_DT)
    return sc, R0, omega0, fsw


def lgvi_run(h: float = H, duration: float = DURATION):
    """lgvi's run at the step ``h``, a record every ``SAVE`` s."""
    import lgvi

    sc, R0, omega0, fsw = lgvi_scenario()
    return lgvi.simulate(sc, R0, omega0=omega0, h=h, steps=int(round(duration / h)), fsw=fsw,
                         save_every=int(round(SAVE / h)))


def hill_frames(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(n, 3, 3) Hill frames (columns x radial, y along track, z orbit normal) of positions and velocities."""
    x = r / np.linalg.norm(r, axis=1)[:, None]
    z = np.cross(r, v)
    z /= np.linalg.norm(z, axis=1)[:, None]
    return np.stack([x, np.cross(z, x), z], axis=2)


def angles(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """The angles (rad) of ``A_k^T B_k``."""
    D = np.einsum("kji,kjl->kil", A, B)
    s = 0.5 * np.linalg.norm(np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0], D[:, 1, 0] - D[:, 0, 1]],
                                      axis=1), axis=1)
    return np.arctan2(s, 0.5 * (np.trace(D, axis1=1, axis2=2) - 1.0))


def noisy_statistics(t: np.ndarray, R: np.ndarray, r: np.ndarray, v: np.ndarray, R_nav: np.ndarray) -> dict:
    """A member's figures from ``SETTLE`` s on (degrees): the mean and 95th percentile of the true
    pointing error (``R`` against the Hill frame of ``r``, ``v``) and the mean navigation error
    (``R_nav`` against ``R``)."""
    k = t >= SETTLE - 1e-9
    err = np.degrees(angles(hill_frames(r[k], v[k]), R[k]))
    nav = np.degrees(angles(R[k], R_nav[k]))
    return {"pointing_mean": float(err.mean()), "pointing_p95": float(np.percentile(err, 95.0)),
            "nav_mean": float(nav.mean()), "samples": int(k.sum())}


def lgvi_noisy(members: int, *, attitude_noise: float = NAV_ATTITUDE, attitude_bound: float = NAV_ATTITUDE_BOUND,
               duration: float = DURATION) -> dict:
    """lgvi's ``members`` noisy members (member ``b``: ``SimpleNav(seed=b)``): their statistics, arrays."""
    import lgvi
    from lgvi.fsw import SimpleNav

    rows = []
    every = int(round(EVERY / H))
    for b in range(members):
        nav = SimpleNav(attitude_noise, NAV_RATE, attitude_bound=attitude_bound, rate_bound=NAV_RATE_BOUND,
                        seed=b, rate=H)
        sc, R0, omega0, fsw = lgvi_scenario(nav)
        tr = lgvi.simulate(sc, R0, omega0=omega0, h=H, steps=int(round(duration / H)), fsw=fsw, save_every=every)
        sig, ts = tr.signals, tr.signal_t
        R = tr.R[: len(ts)]
        R_nav = R @ np.asarray(lgvi.so3.exp(-np.asarray(sig["est_error"])))       # R = R_est Exp(est_error)
        rows.append(noisy_statistics(ts, R, sig["r_N"], sig["v_N"], R_nav))
    return {k: np.array([row[k] for row in rows]) for k in rows[0]}


def attitude_difference(R: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Angle (rad) between lgvi's attitudes ``R`` and Basilisk's ``sigma_BN`` at the same times."""
    Rb = matrix_of(np.asarray(sigma))
    n = min(len(Rb), len(R))
    D = np.einsum("kji,kjl->kil", R[:n], Rb[:n])
    s = 0.5 * np.linalg.norm(np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0], D[:, 1, 0] - D[:, 0, 1]],
                                      axis=1), axis=1)
    return np.arctan2(s, 0.5 * (np.trace(D, axis1=1, axis2=2) - 1.0))     # exact below 1e-8 too


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--write-fixture", action="store_true")
    ap.add_argument("--bsk-python", default=None, help="an interpreter with Basilisk (default: this one)")
    ap.add_argument("--basilisk-only", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--h", type=float, default=H, help=argparse.SUPPRESS)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="against the fixture only, no Basilisk run")
    ap.add_argument("--write-noisy-fixture", action="store_true", help="with Basilisk: the noisy members' statistics")
    ap.add_argument("--noisy", action="store_true", help="lgvi's noisy members against the noisy fixture")
    ap.add_argument("--members", type=int, default=50)
    ap.add_argument("--first", type=int, default=0, help="--write-noisy-fixture: the first member")
    ap.add_argument("--part", default=None, help="--write-noisy-fixture: write these members' rows here (to merge)")
    ap.add_argument("--merge", nargs="+", default=None, help="parts written with --part: merged into the fixture")
    args = ap.parse_args()
    if args.basilisk_only:
        np.savez(args.basilisk_only, **run_basilisk(args.h))
        return
    if args.write_noisy_fixture or args.merge:
        nav = np.array([NAV_ATTITUDE, NAV_ATTITUDE_BOUND, NAV_RATE, NAV_RATE_BOUND, SETTLE, EVERY, H, DURATION])
        if args.merge:                         # parts flown in several processes (members in order)
            parts = [dict(np.load(f)) for f in args.merge]
            parts.sort(key=lambda d: int(d["member"][0]))
            data = {k: np.concatenate([d[k] for d in parts]) for k in parts[0] if k not in ("bsk", "nav")}
            assert np.array_equal(data["member"], np.arange(len(data["member"]))), data["member"]
            assert all(np.array_equal(d["nav"], nav) for d in parts)
            data["bsk"] = parts[0]["bsk"]
        else:
            rows = []
            for b in range(args.first, args.first + args.members):
                rows.append(dict(run_basilisk(H, nav_seed=1000 + b), member=b))
                print(f"member {b}: " + ", ".join(f"{k} {v:.6g}" for k, v in rows[-1].items()), flush=True)
            from Basilisk import __version__ as bsk_version

            data = {k: np.array([row[k] for row in rows]) for k in rows[0]}
            data["bsk"] = str(bsk_version)
        out = Path(args.part) if args.part else NOISY_FIXTURE
        np.savez_compressed(out, **data, nav=nav)
        print(f"wrote {out} ({out.stat().st_size} bytes)")
        return
    if args.noisy:
        print(noisy_table(args.members))
        return
    if args.write_fixture:
        a, b = run_basilisk(H), run_basilisk(H / 2)
        np.savez_compressed(FIXTURE, t=a["t"], sigma=a["sigma"], omega=a["omega"], wheel_speed=a["wheel_speed"],
                            sigma_half=b["sigma"], omega_half=b["omega"], wheel_speed_half=b["wheel_speed"],
                            h=H, cpu=a["cpu"], bsk=a["bsk"])
        print(f"wrote {FIXTURE} ({FIXTURE.stat().st_size} bytes), Basilisk {a['bsk']}, CPU {a['cpu']:.3f} s; "
              f"Basilisk h against h/2: {attitude_difference(matrix_of(a['sigma']), b['sigma']).max():.3e} rad")
        return
    with np.load(FIXTURE) as z:
        fx = {k: z[k] for k in z.files}
    print(f"Basilisk {fx['bsk']} at h = {H} s against h/2: "
          f"{attitude_difference(matrix_of(fx['sigma']), fx['sigma_half']).max():.3e} rad")
    print("\n| lgvi step h (s) | max attitude difference (rad) | ratio to h/2's | max wheel speed difference (rad/s) |")
    print("|---|---|---|---|")
    prev = None
    for h in (H, H / 2, H / 4):
        traj = lgvi_run(h)
        e = attitude_difference(traj.R, fx["sigma"]).max()
        dw = np.abs(traj.wheel_speed[:len(fx["wheel_speed"])] - fx["wheel_speed"]).max()
        ratio = "" if prev is None else f"{prev / e:.2f}"
        print(f"| {h:g} | {e:.3e} | {ratio} | {dw:.3e} |")
        prev = e
    if args.quick:
        return
    lgvi_run(H, duration=100.0)                            # compiled (or the cache loaded)
    lg, bs = [], []
    for _ in range(args.repeat):                          # alternated: the machine is shared
        c0 = time.process_time()
        lgvi_run(H)
        lg.append(time.process_time() - c0)
        bs.append(basilisk_in(args.bsk_python)["cpu"])
    lg_cpu, bs_cpu = float(np.median(lg)), float(np.median(bs))
    print(f"\n| one orbit at h = {H} s, FSW at {FSW_DT} s | CPU s (median of {args.repeat}) | ratio |")
    print("|---|---|---|")
    print(f"| Basilisk {fx['bsk']} (ExecuteSimulation) | {bs_cpu:.3f} | 1 |")
    print(f"| lgvi loop (simulate, whole call) | {lg_cpu:.4f} | {bs_cpu / lg_cpu:.1f}x faster |")


def compare(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float, float]:
    """``(difference of means, its 95 % Welch interval half-width, Welch p, two-sample KS p)``."""
    from scipy import stats

    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    dof = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1))
    half = float(stats.t.ppf(0.975, dof) * np.sqrt(va + vb))
    return (float(a.mean() - b.mean()), half, float(stats.ttest_ind(a, b, equal_var=False).pvalue),
            float(stats.ks_2samp(a, b).pvalue))


def noisy_table(members: int) -> str:
    """lgvi's noisy members against Basilisk's (the fixture), a table."""
    from scipy import stats

    with np.load(NOISY_FIXTURE) as z:
        fx = {k: z[k] for k in z.files}
    lgvi_run(H, duration=100.0)                            # compiled (or the cache loaded)
    c0 = time.process_time()
    mine = lgvi_noisy(members)
    cpu = (time.process_time() - c0) / members
    out = [f"lgvi {members} members: CPU {cpu:.3f} s a member (simulate and the statistics); Basilisk "
           f"{len(fx['cpu'])} members (the fixture, ExecuteSimulation only, recorded when it was written): "
           f"{np.median(fx['cpu']):.3f} s a member, median; ratio {np.median(fx['cpu']) / cpu:.0f}x", "",
           f"| figure (deg, from {SETTLE:g} s) | Basilisk {fx['bsk']} mean [95 % CI] | lgvi mean [95 % CI] | "
           "difference [95 % Welch] | Welch p | KS p |", "|---|---|---|---|---|---|"]
    for key in ("pointing_mean", "pointing_p95", "nav_mean"):
        cells = []
        for x in (fx[key], mine[key]):
            half = stats.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x))
            cells.append(f"{x.mean():.5f} [{x.mean() - half:.5f}, {x.mean() + half:.5f}]")
        d, half, pw, pk = compare(mine[key], fx[key])
        out.append(f"| {key} | {cells[0]} | {cells[1]} | {d:+.5f} [{d - half:+.5f}, {d + half:+.5f}] | {pw:.2f} | "
                   f"{pk:.2f} |")
    return "\n".join(out)


if __name__ == "__main__":
    main()
