"""One orbit of Hill-frame pointing of a 6U CubeSat: lgvi's compiled loop against Basilisk.

Usage::

    python benchmarks/loop_hill_pointing.py --write-fixture --bsk-python /path/to/bsk-venv/bin/python
    python benchmarks/loop_hill_pointing.py --bsk-python /path/to/bsk-venv/bin/python   # agreement and CPU time
    python benchmarks/loop_hill_pointing.py --quick         # against the fixture only (no Basilisk)
    python benchmarks/loop_hill_pointing.py --user --repeat 7   # a user's component against the built-in

The scenario: inertia diag(0.18, 0.14, 0.06) kg m^2 (Basilisk's hub inertia, lgvi's locked inertia:
see ``basilisk_rw_scenario.py``), four balanced wheels in a pyramid (axes ``(+-1, +-1, 1)/sqrt(3)``,
``Js = 1e-4`` kg m^2, 4 mN m torque limit, initial speeds 100, -200, 150, 50 rad/s), a circular
500 km orbit at 97.4 degrees (Basilisk's Earth ``mu``; the orbit integrated by Basilisk, tabulated
analytically by lgvi), the gravity gradient, perfect navigation, the flight software at 1 Hz:
``hillPoint`` -> ``attTrackingError`` -> ``mrpFeedback`` (K = 0.0035, P = 0.035, no integral term)
-> ``rwMotorTorque`` (body axes), dynamics at h = 0.1 s (Basilisk: RK4), for one orbit (5670 s of its 5677 s).
The spacecraft starts 10 degrees off the Hill frame, with the orbit rate plus 1 mrad/s.

It prints the largest attitude difference over the orbit, the CPU time of each code (medians of
alternated runs, in the same process for lgvi and in a child for Basilisk), the first call in a
fresh process with a warm cache, and a user's compiled guidance against the built-in one, each
running at every step. ``loop_hill_pointing.npz`` beside this script keeps Basilisk's attitude
(``sigma_BN``), rate and wheel speeds every 10 s and its CPU time when it was written.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FIXTURE = HERE / "loop_hill_pointing.npz"

INERTIA = np.diag([0.18, 0.14, 0.06])
S3 = 1.0 / np.sqrt(3.0)
AXES = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
JS = 1e-4
U_MAX = 0.004
SPEED0 = np.array([100.0, -200.0, 150.0, 50.0])
K, P = 0.0035, 0.035
DT, FSW_DT, DECIMATE = 0.1, 1.0, 100
MU = 3.98600436e14                # Basilisk's Earth (simIncludeGravBody.createEarth().mu)
R_EARTH = 6378136.6               # Basilisk's Earth radius (REQ_EARTH, km -> m)
A = R_EARTH + 500e3
INC = np.radians(97.4)
RAAN, ARGLAT = np.radians(20.0), np.radians(10.0)
PERIOD = 2.0 * np.pi * np.sqrt(A ** 3 / MU)
STEPS = int(PERIOD / (DT * DECIMATE)) * DECIMATE                  # one orbit, whole samples (5670 s)
OFFSET = np.radians(10.0) * np.array([0.6, -0.48, 0.64])           # the initial attitude error (rotation vector)


def initial_state() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``r0, v0`` (inertial), ``R0`` (body to inertial) and ``omega0`` (body)."""
    c, s = np.cos, np.sin
    # circular orbit, argument of latitude ARGLAT, node RAAN, inclination INC
    P_ = np.array([c(RAAN) * c(ARGLAT) - s(RAAN) * s(ARGLAT) * c(INC),
                   s(RAAN) * c(ARGLAT) + c(RAAN) * s(ARGLAT) * c(INC), s(ARGLAT) * s(INC)])
    Q_ = np.array([-c(RAAN) * s(ARGLAT) - s(RAAN) * c(ARGLAT) * c(INC),
                   -s(RAAN) * s(ARGLAT) + c(RAAN) * c(ARGLAT) * c(INC), c(ARGLAT) * s(INC)])
    r0 = A * P_
    v0 = np.sqrt(MU / A) * Q_
    h = np.cross(r0, v0)
    hill = np.stack([r0 / np.linalg.norm(r0), np.cross(h, r0) / np.linalg.norm(np.cross(h, r0)),
                     h / np.linalg.norm(h)], axis=1)
    R0 = hill @ rotation(OFFSET)
    n = np.sqrt(MU / A ** 3)
    omega0 = R0.T @ (n * h / np.linalg.norm(h)) + np.array([1e-3, 0.0, 0.0])
    return r0, v0, R0, omega0


def rotation(v: np.ndarray) -> np.ndarray:
    """``exp(hat(v))`` (Rodrigues; NumPy only: Basilisk's environment has no SciPy)."""
    th = np.linalg.norm(v)
    K_ = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]) / th
    return np.eye(3) + np.sin(th) * K_ + (1.0 - np.cos(th)) * K_ @ K_


def mrp_of(R: np.ndarray) -> np.ndarray:
    """MRP (|sigma| <= 1) of one body-to-inertial matrix ``R``: Basilisk's ``sigma_BN``."""
    tr = np.trace(R)
    i = int(np.argmax([tr, R[0, 0], R[1, 1], R[2, 2]]))
    if i == 0:
        w = 0.5 * np.sqrt(1.0 + tr)
        q = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (4.0 * w)
    else:
        a, b, c = (i - 1, i % 3, (i + 1) % 3)
        qa = 0.5 * np.sqrt(1.0 + R[a, a] - R[b, b] - R[c, c])
        q = np.zeros(3)
        q[a] = qa
        q[b] = (R[a, b] + R[b, a]) / (4.0 * qa)
        q[c] = (R[a, c] + R[c, a]) / (4.0 * qa)
        w = (R[c, b] - R[b, c]) / (4.0 * qa)
    if w < 0.0:
        w, q = -w, -q
    return q / (1.0 + w)


def matrix_of(sigma: np.ndarray) -> np.ndarray:
    s2 = np.sum(sigma * sigma, axis=-1)[..., None, None]
    S = np.zeros(sigma.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -sigma[..., 2], sigma[..., 1], -sigma[..., 0]
    S = S - np.swapaxes(S, -1, -2)
    return np.eye(3) + (8.0 * S @ S + 4.0 * (1.0 - s2) * S) / (1.0 + s2) ** 2


# ------------------------------------------------------------------------------------------------
# Basilisk
# ------------------------------------------------------------------------------------------------
def run_basilisk() -> dict:
    """The scenario in Basilisk; the logged arrays every ``DECIMATE`` steps and the CPU time of
    ``ExecuteSimulation()``."""
    from Basilisk.utilities import SimulationBaseClass, macros

    import _basilisk as bsk

    r0, v0, R0, omega0 = initial_state()
    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("proc")
    dyn_step, fsw_step = macros.sec2nano(DT), macros.sec2nano(FSW_DT)
    proc.addTask(sim.CreateNewTask("dyn", dyn_step), 200)          # the dynamics first at a common time
    proc.addTask(sim.CreateNewTask("fsw", fsw_step), 100)
    sc = bsk.hub("cubesat", 8.0, INERTIA, r0, v0, mrp_of(R0), omega0)
    sim.AddModelToTask("dyn", sc, 1)
    planet = bsk.earth(sc)
    rwe, rwf = bsk.wheels(sc, AXES, JS, SPEED0, U_MAX)
    sim.AddModelToTask("dyn", rwe, 2)
    gg = bsk.gravity_gradient(sc, planet, tag=sc.ModelTag)
    sim.AddModelToTask("dyn", gg, 3)
    fsw = bsk.hill_pointing_fsw(sim, "dyn", "fsw", sc, rwe, rwf, INERTIA, K, P)  # noqa: F841 (kept alive)
    return bsk.record_and_run(sim, "dyn", sc, rwe, DT * DECIMATE, STEPS * DT)


def basilisk_in(python: str | None, repeat: int = 1) -> dict:
    """:func:`run_basilisk` ``repeat`` times in a child process (``python``: an interpreter with
    Basilisk; ``None``: this one): the first run's arrays, the median CPU time."""
    import _basilisk as bsk

    return bsk.run_child(__file__, python, "--repeat", str(repeat))


# ------------------------------------------------------------------------------------------------
# lgvi
# ------------------------------------------------------------------------------------------------
def lgvi_scenario(guidance=None, fsw_rate: float | None = FSW_DT):
    """``(spacecraft, R0, omega0, fsw)`` of the scenario (``guidance`` default :class:`HillPointing`)."""
    import lgvi
    from lgvi.environment import CircularOrbit
    from lgvi.fsw import FlightSoftware, HillPointing, MRPControl, RWMotorTorque
    from lgvi.spacecraft import GravityGradient, Spacecraft

    r0, v0, R0, omega0 = initial_state()
    orbit = CircularOrbit(A, INC, raan=RAAN, arg_latitude=ARGLAT, mu=MU)
    wheels = lgvi.ReactionWheels(AXES, JS, speed0=SPEED0, max_torque=U_MAX)
    sc = Spacecraft(INERTIA, wheels=wheels, orbit=orbit, disturbances=[GravityGradient(mu=MU)])
    fsw = FlightSoftware(guidance=guidance or HillPointing(), control=MRPControl(K=K, P=P), actuators=RWMotorTorque(),
                         rate=fsw_rate)
    return sc, R0, omega0, fsw


def lgvi_run(guidance=None, fsw_rate: float | None = FSW_DT, steps: int = STEPS):
    import lgvi

    sc, R0, omega0, fsw = lgvi_scenario(guidance, fsw_rate)
    return lgvi.simulate(sc, R0, omega0=omega0, h=DT, steps=steps, fsw=fsw, save_every=DECIMATE)


def user_hill():
    """A user's Hill-frame guidance as a ``numba.njit`` component (the same equations as the built-in)."""
    import numba

    from lgvi.fsw import UserComponent

    @numba.njit
    def hill(t, bus, p, s, w):
        o, q = w[0], w[1]
        r0, r1, r2 = bus[o], bus[o + 1], bus[o + 2]
        v0, v1, v2 = bus[q], bus[q + 1], bus[q + 2]
        h0, h1, h2 = r1 * v2 - r2 * v1, r2 * v0 - r0 * v2, r0 * v1 - r1 * v0
        rr = r0 * r0 + r1 * r1 + r2 * r2
        rn, hn = np.sqrt(rr), np.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
        x0, x1, x2 = r0 / rn, r1 / rn, r2 / rn
        z0, z1, z2 = h0 / hn, h1 / hn, h2 / hn
        y0, y1, y2 = z1 * x2 - z2 * x1, z2 * x0 - z0 * x2, z0 * x1 - z1 * x0
        c = w[2]
        bus[c], bus[c + 1], bus[c + 2] = x0, y0, z0
        bus[c + 3], bus[c + 4], bus[c + 5] = x1, y1, z1
        bus[c + 6], bus[c + 7], bus[c + 8] = x2, y2, z2
        k = -2.0 * (r0 * v0 + r1 * v1 + r2 * v2) / (rr * rr)
        for i, hi in enumerate((h0, h1, h2)):
            bus[w[3] + i] = hi / rr
            bus[w[4] + i] = k * hi
        return 0

    return UserComponent(hill, family="guidance", reads=("r_N", "v_N"), writes=("R_ref", "omega_ref_N", "domega_ref_N"),
                         name="user_hill")


def attitude_difference(traj, fixture: dict) -> np.ndarray:
    """Angle (rad) between lgvi's and Basilisk's attitudes at the fixture's times."""
    Rb = matrix_of(np.asarray(fixture["sigma"]))
    n = min(len(Rb), len(traj.R))
    D = np.einsum("kji,kjl->kil", traj.R[:n], Rb[:n])
    return np.arccos(np.clip((np.trace(D, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0))


def cpu_of(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        c0 = time.process_time()
        fn()
        times.append(time.process_time() - c0)
    return float(np.median(times))


def first_call_fresh_process(guidance: str = "") -> float:
    """CPU seconds of the scenario's first call in a new process (the cache warm), the imports apart;
    ``guidance="user"``: with the user's Hill guidance (its function compiled in that process)."""
    make = "m.user_hill()" if guidance == "user" else "None"
    code = ("import time, sys; sys.path.insert(0, %r); import lgvi, loop_hill_pointing as m; g = %s; "
            "c = time.process_time(); m.lgvi_run(guidance=g, steps=100); print(time.process_time() - c)"
            % (str(HERE), make))
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--write-fixture", action="store_true")
    ap.add_argument("--bsk-python", default=None, help="an interpreter with Basilisk (default: this one)")
    ap.add_argument("--basilisk-only", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="against the fixture only, no Basilisk run")
    ap.add_argument("--user", action="store_true",
                    help="only the user's compiled guidance against the built-in one (no Basilisk run)")
    args = ap.parse_args()
    if args.user:
        user_against_built_in(args.repeat)
        return
    if args.basilisk_only:
        runs = [run_basilisk() for _ in range(args.repeat)]
        d = dict(runs[0], cpu=float(np.median([r["cpu"] for r in runs])))
        np.savez(args.basilisk_only, **d)
        return
    if args.write_fixture:
        d = basilisk_in(args.bsk_python, repeat=1)
        np.savez_compressed(FIXTURE, t=d["t"], sigma=d["sigma"], omega=d["omega"], wheel_speed=d["wheel_speed"],
                            cpu=d["cpu"], bsk=d["bsk"])
        print(f"wrote {FIXTURE} ({FIXTURE.stat().st_size} bytes), Basilisk {d['bsk']}, CPU {d['cpu']:.3f} s")
        return
    with np.load(FIXTURE) as z:
        fixture = {k: z[k] for k in z.files}
    traj = lgvi_run()                                     # compiles or loads the cache
    diff = attitude_difference(traj, fixture)
    print(f"one orbit ({STEPS} steps of {DT} s, FSW at {FSW_DT} s): max attitude difference lgvi - Basilisk "
          f"{diff.max():.3e} rad (fixture: Basilisk {fixture['bsk']})")
    dw = np.abs(traj.wheel_speed[:len(fixture['wheel_speed'])] - fixture["wheel_speed"]).max()
    print(f"max wheel speed difference {dw:.3e} rad/s; final pointing error "
          f"{np.degrees(4 * np.arctan(np.linalg.norm(traj.signals['sigma_BR'][-1]))):.3e} deg")
    if args.quick:
        return
    repeat = args.repeat
    # alternate lgvi and Basilisk runs (the machine is shared: medians of alternated runs)
    lg, bs = [], []
    for _ in range(repeat):
        lg.append(cpu_of(lgvi_run, 1))
        bs.append(basilisk_in(args.bsk_python, repeat=1)["cpu"])
    lg_cpu, bs_cpu = float(np.median(lg)), float(np.median(bs))
    print("\n| run | CPU s (median of %d) | ratio |" % repeat)
    print("|---|---|---|")
    print(f"| Basilisk {fixture['bsk']} (ExecuteSimulation) | {bs_cpu:.3f} | 1 |")
    print(f"| lgvi loop (simulate, whole call) | {lg_cpu:.4f} | {bs_cpu / lg_cpu:.1f}x faster |")
    # the loop against the gyrostat's own compiled MRP feedback, same inertial-target run (no orbit)
    gy, lp = [], []
    gyro_call, loop_call = inertial_pair()
    gyro_call(), loop_call()
    for _ in range(repeat):
        gy.append(cpu_of(gyro_call, 1))
        lp.append(cpu_of(loop_call, 1))
    print(f"| lgvi gyrostat, compiled MRPFeedback, inertial target (no orbit) | {np.median(gy):.4f} | - |")
    print(f"| lgvi loop, InertialPointing + MRPControl + RWMotorTorque (same run) | {np.median(lp):.4f} | "
          f"loop / gyrostat {np.median(lp) / np.median(gy):.2f} |")
    first = [first_call_fresh_process() for _ in range(repeat)]
    print(f"\nfirst call in a fresh process, warm cache (100 steps, imports apart): median {np.median(first):.3f} s CPU")
    user_against_built_in(repeat)


def user_against_built_in(repeat: int) -> None:
    """The user's njit Hill guidance against the built-in ``HillPointing``, each at every step of
    the orbit (alternated rounds, medians), and the first call of a run with the user's component
    in a fresh process (the cache warm: what the user's function costs to compile)."""
    user = user_hill()
    from lgvi.fsw import HillPointing

    lgvi_run(guidance=user, steps=100)                   # compiles the user's function (in memory)
    lgvi_run(guidance=HillPointing(rate=DT), steps=100)
    bi, us = [], []
    for _ in range(repeat):
        bi.append(cpu_of(lambda: lgvi_run(guidance=HillPointing(rate=DT), fsw_rate=FSW_DT), 1))
        us.append(cpu_of(lambda: lgvi_run(guidance=user_hill_every_step(user), fsw_rate=FSW_DT), 1))
    print(f"guidance at every step ({STEPS} steps, CPU s, median of {repeat} alternated rounds): built-in "
          f"HillPointing {np.median(bi):.4f} s, the user's njit Hill guidance {np.median(us):.4f} s: ratio "
          f"{np.median(us) / np.median(bi):.2f}")
    first = [first_call_fresh_process("user") for _ in range(repeat)]
    print(f"first call with the user's component in a fresh process, warm cache (100 steps, imports apart): "
          f"median {np.median(first):.3f} s CPU")


def inertial_pair():
    """Two calls of the same run (inertial target, no orbit, the scenario's wheels and gains, one
    orbit's steps): the gyrostat's compiled ``MRPFeedback`` loop, and the spacecraft loop."""
    import lgvi
    from lgvi.control import MRPFeedback
    from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
    from lgvi.spacecraft import Spacecraft

    r0, v0, R0, omega0 = initial_state()
    wheels = lgvi.ReactionWheels(AXES, JS, speed0=SPEED0, max_torque=U_MAX)
    body = lgvi.RigidBody(INERTIA)
    kw = dict(omega0=omega0, h=DT, steps=STEPS, save_every=DECIMATE)
    ctrl = MRPFeedback(K, P, target=np.eye(3))
    sc = Spacecraft(body, wheels=wheels)
    fsw = FlightSoftware(guidance=InertialPointing(), control=MRPControl(K=K, P=P), actuators=RWMotorTorque(),
                         rate=FSW_DT)
    return (lambda: lgvi.simulate(body, R0, wheels=wheels, controller=ctrl, control_period=FSW_DT, **kw),
            lambda: lgvi.simulate(sc, R0, fsw=fsw, **kw))


def user_hill_every_step(user):
    import copy

    u = copy.copy(user)
    u.rate = DT
    return u


if __name__ == "__main__":
    from lgvi.systems.loop_keywords import as_given

    with as_given():   # wheels=, controller= here measure the gyrostat, as before (docs/loop.md)
        main()
