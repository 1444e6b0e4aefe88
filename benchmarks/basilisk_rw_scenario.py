"""Basilisk's ``scenarioAttitudeFeedbackRW`` against lgvi: the fixture, agreement and wall time.

Usage::

    python benchmarks/basilisk_rw_scenario.py --write-fixture      # needs Basilisk (pip install bsk)
    python benchmarks/basilisk_rw_scenario.py                       # lgvi vs Basilisk, same run
    python benchmarks/basilisk_rw_scenario.py --bsk-python /tmp/venv/bin/python   # Basilisk in another venv
    python benchmarks/basilisk_rw_scenario.py --quick       # against the fixture only, reduced

The scenario (Basilisk's example, without its plots and visualisation): hub inertia
diag(900, 800, 600) kg m^2 (750 kg, centre of mass at B), three Honeywell HR16 wheels (50 N m s:
``Js = 50 / (6000 rpm)``, ``Jt = Jg = Js / 2``, 9 kg, torque limit 0.2 N m, speed limit 6000 rpm,
no friction, no deadband) on the body axes at 100, 200 and 300 rpm, the third one at
``r = (0.5, 0.5, 0.5)`` m; ``sigma_BN = (0.1, 0.2, -0.3)``, ``omega = (0.001, -0.01, 0.03)``
rad/s; an inertial target, ``mrpFeedback`` with ``K = 3.5``, ``P = 30``, no integral term, mapped
to the wheels by ``rwMotorTorque``, everything every 0.1 s, for 600 s (RK4 at 0.1 s).

lgvi's body inertia is Basilisk's hub inertia diag(900, 800, 600): for balanced wheels Basilisk's
hub inertia plays the role of the locked inertia (checked: with it lgvi agrees to 4.7e-7 in MRP
at h = 0.1 s, falling as h^2; adding the wheels' transverse inertia, masses and offset about the
centre of mass, :func:`locked_inertia`, leaves 3.6e-3). The attitude does not depend on the orbit
(Basilisk applies no gravity torque here). The fixture ``basilisk_rw_scenario.npz`` beside this script keeps every 10th
sample (1 s) of Basilisk's ``sigma_BN``, ``omega_BN_B`` and wheel speeds, and Basilisk's wall
time of ``ExecuteSimulation()`` when it was written; ``basilisk_rw_scenario_ki.npz`` (written by
``--write-ki-fixture``) the same with ``mrpFeedback``'s integral term on (``Ki = 2e-4``, integral
limit ``2 / Ki * 0.1``, as Basilisk's example sets it).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FIXTURE = HERE / "basilisk_rw_scenario.npz"
#: The same scenario with ``mrpFeedback``'s integral term on (``KI``, limit ``2 / KI * 0.1``).
FIXTURE_KI = HERE / "basilisk_rw_scenario_ki.npz"

HUB_INERTIA = np.diag([900.0, 800.0, 600.0])
HUB_MASS = 750.0
RPM = 2.0 * np.pi / 60.0
OMEGA_MAX = 6000.0 * RPM
JS = 50.0 / OMEGA_MAX
WHEEL_MASS = 9.0
WHEEL_AXES = np.eye(3)
WHEEL_POS = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.5, 0.5, 0.5]])
SPEED0 = np.array([100.0, 200.0, 300.0]) * RPM
SIGMA0 = np.array([0.1, 0.2, -0.3])
OMEGA0 = np.array([0.001, -0.01, 0.03])
K, P, U_MAX = 3.5, 30.0, 0.2
DT, T_END, DECIMATE = 0.1, 600.0, 10
KI = 0.0002


def locked_inertia() -> np.ndarray:
    """The hub plus the wheels' inertias, masses and offset about the centre of mass (3, 3): *not* what
    Basilisk's balanced wheels integrate (see the module notes); kept for that check."""
    J = HUB_INERTIA.copy()
    m_tot = HUB_MASS + WHEEL_MASS * len(WHEEL_AXES)
    first = np.zeros(3)
    for a, r in zip(WHEEL_AXES, WHEEL_POS):
        J += JS * np.outer(a, a) + 0.5 * JS * (np.eye(3) - np.outer(a, a))
        J += WHEEL_MASS * (r @ r * np.eye(3) - np.outer(r, r))
        first += WHEEL_MASS * r
    c = first / m_tot
    return J - m_tot * (c @ c * np.eye(3) - np.outer(c, c))


# ------------------------------------------------------------------------------------------------
# Basilisk
# ------------------------------------------------------------------------------------------------
def run_basilisk(dt: float = DT, ki: float | None = None) -> dict:
    """Basilisk's scenario; returns the logged arrays (every task step) and the wall time.

    ``ki``: the integral gain of ``mrpFeedback`` (integral limit ``2 / ki * 0.1`` as Basilisk's
    example), ``None``: off (the scenario's default)."""
    from Basilisk.architecture import messaging
    from Basilisk.fswAlgorithms import attTrackingError, inertial3D, mrpFeedback, rwMotorTorque
    from Basilisk.simulation import reactionWheelStateEffector, simpleNav, spacecraft
    from Basilisk.utilities import SimulationBaseClass, macros, orbitalMotion, simHelpers, simIncludeGravBody, \
        simIncludeRW

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("simProcess")
    step = macros.sec2nano(dt)
    proc.addTask(sim.CreateNewTask("simTask", step))
    sc = spacecraft.Spacecraft()
    sc.hub.mHub = HUB_MASS
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = simHelpers.np2EigenMatrix3d(HUB_INERTIA.ravel().tolist())
    sim.AddModelToTask("simTask", sc, 1)
    grav = simIncludeGravBody.gravBodyFactory()
    earth = grav.createEarth()
    earth.isCentralBody = True
    grav.addBodiesTo(sc)
    rwf = simIncludeRW.rwFactory()
    for a, rpm, r in zip(WHEEL_AXES, (100.0, 200.0, 300.0), WHEEL_POS):
        kw = {"rWB_B": r.tolist()} if np.any(r) else {}
        rwf.create("Honeywell_HR16", a.tolist(), maxMomentum=50.0, Omega=rpm, RWModel=messaging.BalancedWheels, **kw)
    rwe = reactionWheelStateEffector.ReactionWheelStateEffector()
    rwf.addToSpacecraft("RW_cluster", rwe, sc)
    sim.AddModelToTask("simTask", rwe, 2)
    nav = simpleNav.SimpleNav()
    sim.AddModelToTask("simTask", nav)
    ref = inertial3D.inertial3D()
    sim.AddModelToTask("simTask", ref)
    ref.sigma_R0N = [0.0, 0.0, 0.0]
    err = attTrackingError.attTrackingError()
    sim.AddModelToTask("simTask", err)
    ctrl = mrpFeedback.mrpFeedback()
    sim.AddModelToTask("simTask", ctrl)
    ctrl.K, ctrl.Ki, ctrl.P = K, (-1.0 if ki is None else ki), P
    ctrl.integralLimit = 2.0 / ctrl.Ki * 0.1
    mt = rwMotorTorque.rwMotorTorque()
    sim.AddModelToTask("simTask", mt)
    mt.controlAxes_B = [1, 0, 0, 0, 1, 0, 0, 0, 1]
    state_log = sc.scStateOutMsg.recorder(step)
    speed_log = rwe.rwSpeedOutMsg.recorder(step)
    torque_log = mt.rwMotorTorqueOutMsg.recorder(step)
    for log in (state_log, speed_log, torque_log):
        sim.AddModelToTask("simTask", log)
    oe = orbitalMotion.ClassicElements()
    oe.a, oe.e, oe.i = 10000000.0, 0.01, 33.3 * macros.D2R
    oe.Omega, oe.omega, oe.f = 48.2 * macros.D2R, 347.8 * macros.D2R, 85.3 * macros.D2R
    rN, vN = orbitalMotion.elem2rv(earth.mu, oe)
    sc.hub.r_CN_NInit = rN
    sc.hub.v_CN_NInit = vN
    sc.hub.sigma_BNInit = [[s] for s in SIGMA0]
    sc.hub.omega_BN_BInit = [[w] for w in OMEGA0]
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _basilisk as bsk

    msgs = bsk.connect_mrp_chain(sc, rwe, rwf, HUB_INERTIA, nav, ref.attRefOutMsg, err, ctrl, mt)  # noqa: F841
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(T_END))
    t0, c0 = time.perf_counter(), time.process_time()
    sim.ExecuteSimulation()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    n = len(WHEEL_AXES)
    return {"t": state_log.times() * 1e-9, "sigma": np.array(state_log.sigma_BN),
            "omega": np.array(state_log.omega_BN_B), "wheel_speed": np.array(speed_log.wheelSpeeds)[:, :n],
            "wheel_torque": np.array(torque_log.motorTorque)[:, :n], "wall": wall, "cpu": cpu,
            "bsk": _bsk_version()}


def basilisk_repeated(ki: float | None = None, repeat: int = 1) -> dict:
    """:func:`run_basilisk` ``repeat`` times: the first run's arrays, the medians of wall and CPU time."""
    runs = [run_basilisk(ki=ki) for _ in range(repeat)]
    d = runs[0]
    d["wall"] = float(np.median([r["wall"] for r in runs]))
    d["cpu"] = float(np.median([r["cpu"] for r in runs]))
    return d


def basilisk_in(python: str | None, ki: float | None = None, repeat: int = 1) -> dict:
    """:func:`basilisk_repeated` here, or with another interpreter (a venv with ``bsk``)."""
    if python is None:
        return basilisk_repeated(ki, repeat)
    out = Path(os.environ.get("TMPDIR", "/tmp")) / f"lgvi_bsk_rw_{os.getpid()}.npz"
    extra = ["--bsk-repeat", str(repeat)] + ([] if ki is None else ["--ki", repr(ki)])
    subprocess.run([python, str(Path(__file__).resolve()), "--basilisk-only", str(out)] + extra, check=True)
    with np.load(out) as z:
        d = {k: z[k] for k in z.files}
    out.unlink()
    d["wall"] = float(d["wall"])
    d["cpu"] = float(d["cpu"])
    d["bsk"] = str(d["bsk"])
    return d


# ------------------------------------------------------------------------------------------------
# lgvi
# ------------------------------------------------------------------------------------------------
def lgvi_call(h: float = DT, save_every: int | None = None, order: int = 2, composition: str | None = None,
              ki: float | None = None, steps: int | None = None, scheme: str | None = None):
    """The ``lgvi.simulate`` call of the scenario, as a function of no arguments: the body, wheels,
    controller and ``R0`` are built here, outside it (as Basilisk's objects and
    ``InitializeSimulation()`` are outside its timed ``ExecuteSimulation()``). The controller's
    state is reset by each call (``Controller.reset``), so the function can be called repeatedly."""
    import lgvi
    from lgvi.control import MRPFeedback, matrix_from_mrp

    steps = int(round(T_END / h)) if steps is None else steps
    se = save_every if save_every is not None else int(round(DT * DECIMATE / h))
    wheels = lgvi.ReactionWheels(WHEEL_AXES, JS, speed0=SPEED0, max_torque=U_MAX, max_speed=OMEGA_MAX)
    body = lgvi.RigidBody(HUB_INERTIA)
    ctrl = MRPFeedback(K, P, Ki=ki, integral_limit=None if ki is None else 2.0 / ki * 0.1, inertia=HUB_INERTIA)
    R0 = matrix_from_mrp(SIGMA0)
    simulate = lgvi.simulate

    def call():
        return simulate(body, R0, omega0=OMEGA0, h=h, steps=steps, wheels=wheels, controller=ctrl,
                        control_period=DT, save_every=se, order=order, composition=composition, scheme=scheme)
    return call


def run_lgvi(h: float = DT, save_every: int | None = None, order: int = 2, composition: str | None = None,
             ki: float | None = None, steps: int | None = None, scheme: str | None = None):
    """lgvi on the scenario at step ``h`` (a divisor of 0.1 s); samples every ``DT * DECIMATE`` by default.
    ``ki``: the integral gain (limit ``2 / ki * 0.1``), ``None``: off; ``steps``: fewer than the 600 s;
    ``scheme``: ``"rkmk4"`` the explicit RKMK scheme (``order`` 4, ``composition`` its tableau)."""
    return lgvi_call(h, save_every, order, composition, ki, steps, scheme)()


def timed(call, repeat: int) -> tuple[float, float]:
    """Medians of the wall and CPU time of ``call()`` over ``repeat`` calls (seconds)."""
    ts, cs = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        call()
        ts.append(time.perf_counter() - t0)
        cs.append(time.process_time() - c0)
    return float(np.median(ts)), float(np.median(cs))


def differences(traj, fix) -> tuple[float, float, float]:
    """Largest differences (MRP, rate rad/s, wheel speed rad/s) of an lgvi run from the fixture."""
    from lgvi.control import mrp_from_matrix

    t = np.asarray(fix["t"])
    idx = np.searchsorted(traj.t, t - 1e-9)
    assert np.allclose(traj.t[idx], t, atol=1e-9)
    sig = mrp_from_matrix(traj.R[idx])
    ds = np.abs(sig - fix["sigma"]).max()
    dw = np.abs(traj.omega[idx] - fix["omega"]).max()
    dv = np.abs(traj.wheel_speed[idx] - fix["wheel_speed"]).max()
    return float(ds), float(dw), float(dv)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write-fixture", action="store_true", help="run Basilisk and write the fixture")
    ap.add_argument("--bsk-python", default=None, help="a Python with Basilisk (bsk) installed")
    ap.add_argument("--basilisk-only", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--ki", type=float, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--bsk-repeat", type=int, default=3, help="Basilisk runs (median of their times)")
    ap.add_argument("--write-ki-fixture", action="store_true",
                    help=f"run Basilisk with the integral term (Ki = {KI:g}) and write {FIXTURE_KI.name}")
    ap.add_argument("--repeat", type=int, default=9, help="timing repetitions for lgvi (median)")
    ap.add_argument("--quick", action="store_true", help="one repetition, three rows (for the tests)")
    args = ap.parse_args(argv)
    if args.basilisk_only:
        d = basilisk_repeated(args.ki, args.bsk_repeat)
        np.savez(args.basilisk_only, **d)
        return 0
    if args.write_fixture or args.write_ki_fixture:
        ki = KI if args.write_ki_fixture else None
        path = FIXTURE_KI if args.write_ki_fixture else FIXTURE
        d = basilisk_in(args.bsk_python, ki, 1)
        sl = slice(None, None, DECIMATE)
        bsk = str(d.get("bsk", "unknown"))         # the version of the interpreter that ran Basilisk
        info = {"bsk": bsk, "dt": DT, "T": T_END, "decimate": DECIMATE}
        if ki is not None:
            info.update(Ki=ki, integralLimit=2.0 / ki * 0.1)
        np.savez_compressed(path, t=d["t"][sl], sigma=d["sigma"][sl], omega=d["omega"][sl],
                            wheel_speed=d["wheel_speed"][sl], wheel_torque=d["wheel_torque"][sl],
                            wall=d["wall"], info=json.dumps(info))
        print(f"wrote {path} ({path.stat().st_size} bytes); Basilisk ExecuteSimulation {d['wall']:.3f} s")
        return 0
    fix = np.load(FIXTURE)
    with_bsk = (args.bsk_python or _have_basilisk()) and not args.quick
    bsk = basilisk_in(args.bsk_python, None, args.bsk_repeat) if with_bsk else None
    run_lgvi()  # compile / load the kernels
    run_lgvi(scheme="rkmk4")
    lg = timed(lgvi_call(), args.repeat)[0]
    print("Basilisk scenarioAttitudeFeedbackRW, 600 s at 0.1 s (machine shared with other jobs: medians; "
          f"load average {os.getloadavg()[0]:.2f})")
    ref_wall = bsk["wall"] if bsk is not None else float(fix["wall"])
    ref_cpu = bsk["cpu"] if bsk is not None else None
    print("(times: medians of --repeat runs, Basilisk's of --bsk-repeat; wall clock, and the CPU time of the process, "
          "which the load of other jobs disturbs less)")
    print("(timed: Basilisk's ExecuteSimulation() only; lgvi's lgvi.simulate(...) call only, its RigidBody, "
          "ReactionWheels, MRPFeedback and R0 built before, as Basilisk's objects and InitializeSimulation())")
    print(f"{'h':>8} {'order':>9} {'max |d sigma|':>14} {'max |d omega|':>14} {'max |d speed|':>14} {'err vs ref':>12} "
          f"{'lgvi ms':>9} {'Basilisk/lgvi':>14} {'lgvi CPU ms':>12} {'ratio CPU':>10}")
    rows = [(DT / sub, 2, None) for sub in (1, 2, 4, 8, 16)] + [(DT, 4, None), (DT, 4, "yoshida4"), (DT, 6, None)]
    # the explicit RKMK scheme (scheme="rkmk4") with its tableaux
    rows += [(DT, "rkmk4", tab) for tab in ("rk4", "rk38", "ralston4")] + [(DT / 2, "rkmk4", "rk4")]
    if args.quick:
        args.repeat, rows = 1, [(DT, 2, None), (DT / 2, 2, None), (DT, 4, None), (DT, "rkmk4", "rk4")]
    # a converged reference (order 6 at h = 0.1/16: changes below 2e-13 from h = 0.1/32) for the accuracy
    # of both: Basilisk's RK4 at 0.1 s and each lgvi row, largest MRP difference over the 1 s samples
    from lgvi.control import mrp_from_matrix

    sig_ref = mrp_from_matrix(run_lgvi(DT / 16, order=6).R)
    print(f"Basilisk RK4 at 0.1 s: max |sigma - sigma_ref| = {np.abs(fix['sigma'] - sig_ref).max():.2e} "
          "(the reference: lgvi order 6 at h = 0.1/16)")
    rk = None
    for h, order, comp in rows:
        kw = dict(order=4, composition=comp, scheme=order) if order == "rkmk4" else dict(order=order, composition=comp)
        call = lgvi_call(h, **kw)
        traj = call()
        ds, dw, dv = differences(traj, fix)
        err = np.abs(mrp_from_matrix(traj.R) - sig_ref).max()
        wall, cpu = timed(call, args.repeat)
        if order == "rkmk4" and comp == "rk4" and h == DT:
            rk = (wall, cpu, err)
        name = str(order) if comp is None else (f"rk {comp[:6]}" if order == "rkmk4" else f"{order} {comp[:7]}")
        cpu_ratio = f"{ref_cpu / cpu:9.0f}x" if ref_cpu is not None else f"{'-':>10}"
        print(f"{h:8.4f} {name:>9} {ds:14.3e} {dw:14.3e} {dv:14.3e} {err:12.2e} {wall * 1e3:9.2f} "
              f"{ref_wall / wall:13.0f}x {cpu * 1e3:12.2f} {cpu_ratio}")
    print("(the differences fall as h^2 at order 2 towards Basilisk's own RK4 error; order 4 and 6 compose the "
          "step with the wheel torques held over it; 'rk TAB': scheme='rkmk4', the explicit Runge-Kutta-Munthe-Kaas "
          "method in Cayley coordinates with tableau TAB)")
    if not args.quick:
        per = {}
        for sch, order in (("rkmk4", 4), (None, 4)):
            c6, c60 = lgvi_call(DT, order=order, scheme=sch), lgvi_call(DT, order=order, scheme=sch, steps=60000)
            w6, w60 = [], []
            for _ in range(max(3, args.repeat // 3)):      # alternated
                w6.append(timed(c6, 1)[1])
                w60.append(timed(c60, 1)[1])
            per[sch] = (float(np.median(w60)) - float(np.median(w6))) / 54000
        print(f"cost per step (CPU time of 60000 steps minus 6000, / 54000; h = 0.1 with the compiled MRP feedback "
              f"every step): rkmk4 {per['rkmk4'] * 1e9:.0f} ns, LGVI order 4 (suzuki4) {per[None] * 1e9:.0f} ns")
    fix_ki = np.load(FIXTURE_KI)
    ds, dw, dv = differences(run_lgvi(DT, ki=KI), fix_ki)
    print(f"with the integral term (Ki = {KI:g}, fixture {FIXTURE_KI.name}), h = 0.1, order 2: max |d sigma| = "
          f"{ds:.3e}, max |d omega| = {dw:.3e}, max |d speed| = {dv:.3e}")
    print(f"lgvi simulate (h = 0.1 s, compiled MRPFeedback): {lg * 1e3:.2f} ms (median of {args.repeat})")
    fixed = timed(lgvi_call(DT, save_every=10, order=4, steps=10), max(args.repeat, 5))[1]
    fixed_rk = timed(lgvi_call(DT, save_every=10, order=4, steps=10, scheme="rkmk4"), max(args.repeat, 5))[1]
    print(f"fixed cost per call (the same call for 10 steps: checks, set-up, result; CPU): order 4 "
          f"{fixed * 1e3:.2f} ms, rkmk4 {fixed_rk * 1e3:.2f} ms")
    if bsk is not None:
        print(f"Basilisk ExecuteSimulation (this run, median of {args.bsk_repeat}): {bsk['wall'] * 1e3:.1f} ms wall, "
              f"{bsk['cpu'] * 1e3:.1f} ms CPU; ratio Basilisk / lgvi (wall) = {bsk['wall'] / lg:.0f}x")
    else:
        print(f"Basilisk ExecuteSimulation (fixture, another run): {float(fix['wall']) * 1e3:.1f} ms; ratio = "
              f"{float(fix['wall']) / lg:.0f}x (give --bsk-python for a same-run figure)")
    if rk is not None:
        cpu_part = f", {ref_cpu / rk[1]:.0f}x (CPU)" if ref_cpu is not None else ""
        print(f"scheme='rkmk4' (tableau rk4) at h = 0.1: {rk[0] * 1e3:.2f} ms wall, {rk[1] * 1e3:.2f} ms CPU; "
              f"Basilisk / rkmk4 = {ref_wall / rk[0]:.0f}x (wall){cpu_part}; error against the reference {rk[2]:.2e}, "
              f"Basilisk's {np.abs(fix['sigma'] - sig_ref).max():.2e}")
    return 0


def _bsk_version() -> str:
    from importlib.metadata import version

    try:
        return version("bsk")
    except Exception:
        return "unknown"


def _have_basilisk() -> bool:
    try:
        import Basilisk  # noqa: F401
    except ImportError:
        return False
    return True


if __name__ == "__main__":
    from lgvi.systems.loop_keywords import as_given

    with as_given():   # wheels=, controller= here measure the gyrostat, as before (docs/loop.md)
        sys.exit(main())
