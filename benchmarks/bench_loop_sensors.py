"""The compiled loop with sensors, the MEKF and every disturbance: CPU time per step, same run.

Usage::

    python benchmarks/bench_loop_sensors.py            # 20000 steps a run, 7 rounds
    python benchmarks/bench_loop_sensors.py --quick    # 2000 steps, 3 rounds (checks it runs)
    python benchmarks/bench_loop_sensors.py --steps 100000 --rounds 9 --accuracy   # the figures of docs/performance.md
    python benchmarks/bench_loop_sensors.py --member --steps 50000 --rounds 9       # the two members only
    python benchmarks/bench_loop_sensors.py --floor --steps 50000 --rounds 9        # what each disturbance costs a step

Cases (h = 0.1 s, the 6U of issue 25: inertia diag(0.18, 0.14, 0.06) kg m^2, four pyramid wheels,
MRP feedback at 1 Hz to a fixed target, motor torques by ``RWMotorTorque``):

* ``sensors + MEKF``: a gyro and a star tracker at 2 Hz, the MEKF at 2 Hz, the controller on the
  estimate;
* ``true-state feedback``: the same member without sensors and estimator (the controller on the truth);
* ``all disturbances``: the tumbling 6U of ``basilisk_loop_scenario.py`` (orbit, IGRF-like centred
  dipole, sun, conical shadow, exponential atmosphere, facet drag and SRP on 10 facets, residual
  dipole, gravity gradient), no flight software;
* ``all dist., held (1st order)``: the same, with the disturbances held over each step as the loop
  did before the symmetric forcing (the residual dipole restricted to mode 0, the only mode of a
  run without mode rules: the loop then runs no component at the step's end);
* ``orbit, field, gravity grad.``: the same 6U with only the orbit, the field and the gravity
  gradient (what the loop of issue 25 had before the disturbances of issue 26);
* ``+ sun`` ... ``+ residual dipole``: the same 6U with the components added one at a time in the
  loop's order (orbit; field; gravity gradient; sun; shadow; exponential atmosphere; facet drag;
  facet SRP; residual dipole: the last is ``all disturbances``), so the difference of two rows is
  what one component costs in the loop;
* ``orbit, IGRF-13 field``: the orbit and the field of IGRF-14 at its full degree 13 (the 6U's
  field is the centred dipole, degree 1): against ``orbit only``, what the full field costs a step;
* ``all dist., env. at 1 s``: ``all disturbances`` with the orbit, the field, the sun, the shadow
  and the atmosphere every 10th step (1 s; ``environment_rate=1.0`` and each model's ``rate=1.0``),
  the attitude-dependent torques (drag, SRP, dipole, gravity gradient) every step; its accuracy
  cost is printed by ``--accuracy``;
* ``all dist., env. slow``: the same with the orbit every step and the sun, the shadow, the
  atmosphere and the field every 10th step (``SLOW``);
* ``all dist., GNC rates``: the rates a GNC engineer would pick (``GNC``): the orbit, the field,
  the shadow and the atmosphere at 1 s, the sun at 60 s (held in between), every torque every step;
  ``--accuracy`` prints its cost, and the angle by which the held sun departs from the sun of every
  step;
* ``the loop, no component``: the 6U in the loop with nothing on it (no orbit, no wheels): what
  the loop itself costs over the gyrostat step, the floor under every row that adds components;
* ``all dist., records on grid`` and ``all dist., no records``: ``all disturbances`` with the
  records on the record grid only (``FlightSoftware(record_rate="grid")``: each source's torque by
  name at the save rate, what issue 26 part 4 asks) and with none (``record=[]``); the default
  records every value at its writer's rate (every step here);
* ``--overhead``: ``orbit, field, 1 dipole`` and ``orbit, field, 5 dipoles`` (residual dipoles,
  records on the grid): their difference over four is what one more component costs the loop
  (its call, its finite checks, its arithmetic of about 10 ns, its turn in the loop's per-component
  bookkeeping); running the environment and the disturbances as one fused call (tried in round 8,
  ``docs/performance.md``) saved only 4-8 ns of it, the call;
* ``all dist., GNC rates, grid``: the GNC rates with the records on the grid. The goal of issue 26
  part 5 is read both ways: (a) the whole step with every disturbance over the gyrostat step, (b)
  what the disturbances add, ``(case - the loop, no component)``, over the gyrostat step;
* ``--goal``: only the goal's cases and what they are read against; ``--floor``: those and the GNC
  rates on the grid without one item at a time (facet drag, facet SRP, residual dipole, gravity
  gradient, the three torques, every disturbance), printed as what each item costs a step;
* ``calibration``: a pure-Python loop timed in each round beside the cases (the machine's own speed
  in that round: a round on a slowed vCPU shows in it);
* ``--member``: only ``sensors + MEKF`` and ``true-state feedback``, and each again with no records
  (``FlightSoftware(record=[])``): what the records at the writers' rates cost the member; each with
  its Newton iterations a step (the solver's summary of the first run);
* ``gyrostat step``: ``lgvi.simulate`` of the same body with the same wheels and no controller
  (the gyrostat's compiled step); ``6U gyrostat step``: the same with the 6U's inertia and
  initial state.

``--accuracy`` flies the 6U for one orbit (5680 s) at h = 0.1 and 0.05 with every component every
step and with slower environments (the sun and the shadow at 1 s; and the atmosphere; and the
field; and the orbit), and prints the largest attitude differences from every step, beside the
step's own error.

Each case is one ``lgvi.simulate`` call (the kernels warm), timed with the process's CPU time; the
cases alternate within each round, the ratios are taken within a round, then the median over the
rounds. The machine may be shared: say so with the figures.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import lgvi  # noqa: E402
from lgvi.fsw import MEKF, FlightSoftware, InertialPointing, MRPControl, RWMotorTorque  # noqa: E402
from lgvi.spacecraft import Gyro, ResidualDipole, Spacecraft, StarTracker  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_loop_integration import _basilisk_6u  # noqa: E402

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
J = [0.18, 0.14, 0.06]
H = 0.1
TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))
OMEGA0 = [0.01, -0.02, 0.015]


def _wheels():
    return lgvi.ReactionWheels(PYRAMID, 1e-4, speed0=[10.0, -20.0, 5.0, 0.0], max_torque=0.004)


def _fsw(estimator=None, **extra):
    return FlightSoftware(estimator=estimator, guidance=InertialPointing(TARGET), control=MRPControl(K=0.004, P=0.04),
                          actuators=RWMotorTorque(), rate=1.0, **extra)


ADDED = ("field", "orbit_gravity_gradient", "sun", "shadow", "exponential_atmosphere", "facet_drag", "facet_srp",
         "residual_dipole")
LABELS = {"field": "+ field", "orbit_gravity_gradient": "+ gravity gradient", "sun": "+ sun", "shadow": "+ shadow",
          "exponential_atmosphere": "+ exp. atmosphere", "facet_drag": "+ facet drag", "facet_srp": "+ facet SRP",
          "residual_dipole": "+ residual dipole (all)"}


def six_u(kinds, env_rate=None, rates=None):
    """The tumbling 6U of ``basilisk_loop_scenario.py`` with the orbit and only the components of
    ``kinds`` (its own new components); ``env_rate``: the period of the orbit, field, sun, shadow and
    atmosphere (None: every step); ``rates``: the period of single kinds (``{"field": 1.0}``)."""
    sc, d = _basilisk_6u()
    env = [c for c in sc.environment if c.kind in kinds]
    dist = [c for c in sc.disturbances if c.kind in kinds]
    if env_rate is not None:
        for c in env:
            c.rate = env_rate
    out = Spacecraft(sc.body, orbit=sc.orbit, field=sc.field if "field" in kinds else None, epoch=sc.epoch,
                     environment=env, disturbances=dist, environment_rate=env_rate)
    for c in out.components():
        if c.kind in (rates or {}):
            c.rate = rates[c.kind]
    return out, d


#: Environments at slower rates than the step (s): the sun and the shadow (SUN_SHADOW), with the
#: atmosphere and the field (SLOW, the benchmark's ``env. slow`` case); the orbit every step.
SUN_SHADOW = {"sun": 1.0, "shadow": 1.0}
SLOW = {"sun": 1.0, "shadow": 1.0, "exponential_atmosphere": 1.0, "field": 1.0}
#: A GNC engineer's rates (s): the environment at 1 s (``env_rate=1.0``), the sun at 60 s.
GNC = {"sun": 60.0}


def _members():
    """The sensors + MEKF member's spacecraft and estimator, and the true-state member's spacecraft."""
    gyro = Gyro(rate=0.5, arw=1e-4, rrw=1e-5, bias=[2e-4, -1e-4, 5e-5], seed=7)
    st = StarTracker(rate=0.5, sigma_cross=5e-5, sigma_about=4e-4, seed=7)
    est = MEKF(rate=0.5, arw=1e-4, rrw=1e-5, star_tracker=st, P0=[0.03 ** 2] * 3 + [3e-4 ** 2] * 3)
    return Spacecraft(J, wheels=_wheels(), sensors=[gyro, st]), est, Spacecraft(J, wheels=_wheels())


def member_cases(steps):
    """``--member``: the two members, with their records (at the writers' rates) and without any."""
    sensed, est, plain = _members()
    kw = dict(h=H, steps=steps, save_every=steps)
    return {
        "sensors + MEKF": lambda: lgvi.simulate(sensed, np.eye(3), omega0=OMEGA0, fsw=_fsw(est), **kw),
        "true-state feedback": lambda: lgvi.simulate(plain, np.eye(3), omega0=OMEGA0, fsw=_fsw(), **kw),
        "sensors + MEKF, no records": lambda: lgvi.simulate(sensed, np.eye(3), omega0=OMEGA0, fsw=_fsw(est, record=[]),
                                                            **kw),
        "true-state, no records": lambda: lgvi.simulate(plain, np.eye(3), omega0=OMEGA0, fsw=_fsw(record=[]), **kw),
    }


#: The cases of issue 26 part 5's goal, read (a) the case / gyrostat step and (b) (case - the loop,
#: no component) / gyrostat step.
GOAL = ("all disturbances", "all dist., records on grid", "all dist., GNC rates", "all dist., GNC rates, grid")
#: What the goal's two readings divide by and subtract (``--goal`` runs these and GOAL only).
GOAL_BASE = ("gyrostat step", "the loop, no component", "calibration (Python loop)")


def calibration():
    """A pure-Python loop (the machine's speed in this round)."""
    return sum(i * i for i in range(100000))


def cases(steps, components=True, overhead=False):
    sensed, est, plain = _members()
    six, d = _basilisk_6u()
    from scipy.spatial.transform import Rotation

    R6 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    bare, _ = six_u(("field", "orbit_gravity_gradient"))
    held, _ = _basilisk_6u()                    # its own components: the dipole's modes set on its copy only
    for c in held.components():
        if c.kind == "residual_dipole":
            c.modes = (0,)
    slow, _ = six_u(ADDED, env_rate=1.0)
    slower, _ = six_u(ADDED, rates=SLOW)
    gnc, _ = six_u(ADDED, env_rate=1.0, rates=GNC)
    nothing = Spacecraft(six.body)
    kw = dict(h=H, steps=steps, save_every=steps)
    out = {
        "sensors + MEKF": lambda: lgvi.simulate(sensed, np.eye(3), omega0=OMEGA0, fsw=_fsw(est), **kw),
        "true-state feedback": lambda: lgvi.simulate(plain, np.eye(3), omega0=OMEGA0, fsw=_fsw(), **kw),
        "all disturbances": lambda: lgvi.simulate(six, R6, omega0=d["omega0"], **kw),
        "all dist., held (1st order)": lambda: lgvi.simulate(held, R6, omega0=d["omega0"], **kw),
        "all dist., env. at 1 s": lambda: lgvi.simulate(slow, R6, omega0=d["omega0"], **kw),
        "all dist., env. slow": lambda: lgvi.simulate(slower, R6, omega0=d["omega0"], **kw),
        "all dist., GNC rates": lambda: lgvi.simulate(gnc, R6, omega0=d["omega0"], **kw),
        "the loop, no component": lambda: lgvi.simulate(nothing, R6, omega0=d["omega0"], **kw),
        "orbit, field, gravity grad.": lambda: lgvi.simulate(bare, R6, omega0=d["omega0"], **kw),
        "gyrostat step": lambda: lgvi.simulate(lgvi.RigidBody(J), np.eye(3), omega0=OMEGA0, wheels=_wheels(), **kw),
        "6U gyrostat step": lambda: lgvi.simulate(six.body, R6, omega0=d["omega0"], wheels=_wheels(), **kw),
        "all dist., records on grid": lambda: lgvi.simulate(six, R6, omega0=d["omega0"], fsw=_records("grid"), **kw),
        "all dist., no records": lambda: lgvi.simulate(six, R6, omega0=d["omega0"], fsw=_records(None), **kw),
        "all dist., GNC rates, grid": lambda: lgvi.simulate(gnc, R6, omega0=d["omega0"], fsw=_records("grid"), **kw),
    }
    out["calibration (Python loop)"] = calibration
    if overhead:
        for n in (1, 5):
            sc_n = Spacecraft(six.body, orbit=six.orbit, field=six.field, epoch=six.epoch,
                              disturbances=[ResidualDipole([0.01, 0.0, 0.0]) for _ in range(n)])
            out[f"orbit, field, {n} dipole{'s' if n > 1 else ''}"] = (
                lambda sc: lambda: lgvi.simulate(sc, R6, omega0=d["omega0"], fsw=_records("grid"), **kw))(sc_n)
    if components:
        out["orbit only"] = (lambda sc: lambda: lgvi.simulate(sc, R6, omega0=d["omega0"], **kw))(six_u(())[0])
        for i, kind in enumerate(ADDED):
            sc_i = six_u(ADDED[:i + 1])[0]
            out[LABELS[kind]] = (lambda sc: lambda: lgvi.simulate(sc, R6, omega0=d["omega0"], **kw))(sc_i)
        from lgvi.environment.field import IGRF

        dip, _ = six_u(("field",))
        igrf = Spacecraft(dip.body, orbit=dip.orbit, field=IGRF(), epoch=dip.epoch, environment=dip.environment)
        out["orbit, IGRF-13 field"] = lambda: lgvi.simulate(igrf, R6, omega0=d["omega0"], **kw)
    return out


#: ``--floor``: the GNC rates with the records on the grid without these kinds; the difference from
#: ``all dist., GNC rates, grid`` is what they cost a step.
FLOOR = {"facet drag": ("facet_drag",), "facet SRP": ("facet_srp",), "residual dipole": ("residual_dipole",),
         "gravity gradient": ("orbit_gravity_gradient",),
         "drag, SRP, dipole": ("facet_drag", "facet_srp", "residual_dipole"),
         "every disturbance": ("facet_drag", "facet_srp", "residual_dipole", "orbit_gravity_gradient")}


def floor_cases(steps):
    """``--floor``'s runs: ``GNC grid without <item>`` for each item of :data:`FLOOR`."""
    d = _basilisk_6u()[1]
    from scipy.spatial.transform import Rotation

    R6 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    kw = dict(h=H, steps=steps, save_every=steps)
    out = {}
    for item, drop in FLOOR.items():
        sc, _ = six_u(tuple(k for k in ADDED if k not in drop), env_rate=1.0, rates=GNC)
        out[f"GNC grid without {item}"] = (lambda sc: lambda: lgvi.simulate(sc, R6, omega0=d["omega0"],
                                                                            fsw=_records("grid"), **kw))(sc)
    return out


def _records(rate):
    """No flight software, the records on the grid (``"grid"``) or none (``None``)."""
    return FlightSoftware(components=[], record_rate="grid") if rate else FlightSoftware(components=[], record=[])


def accuracy() -> None:
    """One orbit of the tumbling 6U: slower environments against every step, and h against h/2."""
    from scipy.spatial.transform import Rotation

    six, d = _basilisk_6u()
    R6 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    T = float(d["t"][-1])
    configs = {"every step": six, "sun, shadow at 1 s": six_u(ADDED, rates=SUN_SHADOW)[0],
               "+ atmosphere at 1 s": six_u(ADDED, rates={**SUN_SHADOW, "exponential_atmosphere": 1.0})[0],
               "+ field at 1 s (env. slow)": six_u(ADDED, rates=SLOW)[0],
               "env. at 1 s (+ the orbit)": six_u(ADDED, env_rate=1.0)[0],
               "GNC rates (+ the sun at 60 s)": six_u(ADDED, env_rate=1.0, rates=GNC)[0]}
    runs = {}
    for h in (0.1, 0.05):
        for name, sc in configs.items():
            tr = lgvi.simulate(sc, R6, omega0=d["omega0"], h=h, steps=int(round(T / h)), save_every=int(round(10.0 / h)))
            runs[name, h] = Rotation.from_matrix(tr.R)

    def gap(a, b):
        return float((runs[a].inv() * runs[b]).magnitude().max())

    print(f"one orbit ({T:.0f} s) of the tumbling 6U, largest attitude difference from every step (samples every 10 s):")
    print(f"{'configuration':30s} {'h = 0.1':>10s} {'h = 0.05':>10s}")
    for name in configs:
        if name != "every step":
            print(f"{name:30s} {gap(('every step', 0.1), (name, 0.1)):10.2e} {gap(('every step', 0.05), (name, 0.05)):10.2e}")
    print(f"{'every step, h = 0.1 vs 0.05':30s} {gap(('every step', 0.1), ('every step', 0.05)):10.2e} "
          "(the step's own error is about 4/3 of it)")
    # the sun held over 60 s: the direction from the spacecraft against the sun of every step, over
    # the orbit at 1 s (the sun's own motion, 0.04 deg an hour, and the spacecraft's 450 km in a minute)
    from lgvi.environment.sun import sun_position

    t = np.arange(0.0, T, 1.0)
    r, _ = six.orbit.position_velocity(t)
    sun = sun_position(six.epoch, t)
    held = sun_position(six.epoch, np.floor(t / 60.0) * 60.0) - six.orbit.position_velocity(np.floor(t / 60.0) * 60.0)[0]
    now = sun - r
    ang = np.arctan2(np.linalg.norm(np.cross(held, now), axis=1), np.sum(held * now, axis=1))
    print(f"the sun held 60 s: largest angle from the sun of every step {np.degrees(ang.max()):.2e} deg "
          "(goal 0.01 deg)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--accuracy", action="store_true", help="also the accuracy cost of the environment at 1 s")
    ap.add_argument("--no-components", action="store_true", help="without the rows that add one component at a time")
    ap.add_argument("--overhead", action="store_true", help="also 1 and 5 residual dipoles: one component's cost")
    ap.add_argument("--member", action="store_true", help="only the sensors + MEKF and true-state members")
    ap.add_argument("--goal", action="store_true", help="only the cases of issue 26 part 5's goal (GOAL, GOAL_BASE)")
    ap.add_argument("--floor", action="store_true",
                    help="the goal's cases and the GNC rates on the grid without one item at a time (FLOOR)")
    ap.add_argument("--steps", type=int, default=20000, help="steps a run (default 20000)")
    ap.add_argument("--rounds", type=int, default=7, help="rounds (default 7)")
    args = ap.parse_args()
    steps, rounds = (2000, 3) if args.quick else (args.steps, args.rounds)
    runs = (member_cases(steps) if args.member
            else cases(steps, components=not args.no_components, overhead=args.overhead))
    if args.goal or args.floor:
        runs = {name: f for name, f in runs.items() if name in GOAL + GOAL_BASE}
    if args.floor:
        runs.update(floor_cases(steps))
    its = {}
    for name, f in runs.items():                # compile or load, once (the calibration returns a number)
        out = f()
        if hasattr(out, "meta"):
            its[name] = out.meta["solver_summary"]
    per_step = {name: [] for name in runs}
    for _ in range(rounds):
        for name, f in runs.items():
            t = time.process_time()
            f()
            per_step[name].append((time.process_time() - t) / steps)

    def ratio(a, b):
        if a not in per_step or b not in per_step:
            return []                           # a case --goal leaves out
        return [x / y for x, y in zip(per_step[a], per_step[b])]

    if args.member:
        print(f"{steps} steps of h = {H} s a run, {rounds} rounds, CPU time, medians (cases alternating)")
        for name, v in per_step.items():
            n = its[name]
            print(f"{name:28s} {statistics.median(v) * 1e6:9.3f} us/step  "
                  f"{n['iterations_total'] / n['steps']:.3f} Newton iterations a step")
        for a, b in (("sensors + MEKF", "true-state feedback"), ("sensors + MEKF, no records", "true-state, no records")):
            v = ratio(a, b)
            print(f"{a + ' / ' + b:58s} {statistics.median(v):7.2f} (min {min(v):.2f}, max {max(v):.2f})")
        return
    ratios = {
        "sensors + MEKF / true-state feedback": ratio("sensors + MEKF", "true-state feedback"),
        "all disturbances / gyrostat step": ratio("all disturbances", "gyrostat step"),
        "all disturbances / 6U gyrostat step": ratio("all disturbances", "6U gyrostat step"),
        "all dist., env. at 1 s / gyrostat step": ratio("all dist., env. at 1 s", "gyrostat step"),
        "all dist., env. at 1 s / 6U gyrostat step": ratio("all dist., env. at 1 s", "6U gyrostat step"),
        "all dist., env. slow / gyrostat step": ratio("all dist., env. slow", "gyrostat step"),
        "all dist., GNC rates / gyrostat step": ratio("all dist., GNC rates", "gyrostat step"),
        "the loop, no component / 6U gyrostat step": ratio("the loop, no component", "6U gyrostat step"),
        "all dist., records on grid / gyrostat step": ratio("all dist., records on grid", "gyrostat step"),
        "all dist., no records / gyrostat step": ratio("all dist., no records", "gyrostat step"),
        "all disturbances / orbit, field, g.g.": ratio("all disturbances", "orbit, field, gravity grad."),
        "all disturbances / all dist., held": ratio("all disturbances", "all dist., held (1st order)"),
        "true-state feedback / gyrostat step": ratio("true-state feedback", "gyrostat step"),
    }
    for name in GOAL:
        ratios[f"(a) {name} / gyrostat step"] = ratio(name, "gyrostat step")
        ratios[f"(b) {name} - loop / gyrostat step"] = [(x - z) / y for x, y, z in zip(
            per_step[name], per_step["gyrostat step"], per_step["the loop, no component"])]
    if "orbit only" in per_step:
        ratios["orbit only / 6U gyrostat step"] = ratio("orbit only", "6U gyrostat step")
        ratios["orbit, IGRF-13 field / orbit only"] = ratio("orbit, IGRF-13 field", "orbit only")
    print(f"{steps} steps of h = {H} s a run, {rounds} rounds, CPU time, medians (cases alternating)")
    print(f"{'case':36s} {'us/step':>9s} {'added':>9s}")
    prev = None
    for name, v in per_step.items():
        if name.startswith("calibration"):
            continue
        med = statistics.median(v) * 1e6
        added = f"{med - prev:9.3f}" if name.startswith("+ ") and prev is not None else ""
        print(f"{name:36s} {med:9.3f} {added:>9s}")
        if name == "orbit only" or name.startswith("+ "):
            prev = med
    if "orbit, field, 5 dipoles" in per_step:
        one = [(a - b) / 4.0 * 1e6 for a, b in zip(per_step["orbit, field, 5 dipoles"], per_step["orbit, field, 1 dipole"])]
        print(f"one more component (a residual dipole): {statistics.median(one):.3f} us/step (min {min(one):.3f}, "
              f"max {max(one):.3f})")
    if args.floor:
        full = statistics.median(per_step["all dist., GNC rates, grid"])
        gyro = statistics.median(per_step["gyrostat step"])
        print("what each item costs a step at the GNC rates on the grid (the case less the case without it):")
        for item in FLOOR:
            v = statistics.median(per_step[f"GNC grid without {item}"])
            print(f"  {item:20s} {(full - v) * 1e9:7.1f} ns  {(full - v) / gyro:5.2f} gyrostat steps")
        v = statistics.median(per_step["GNC grid without every disturbance"])
        loop = statistics.median(per_step["the loop, no component"])
        print(f"  {'the environment':20s} {(v - loop) * 1e9:7.1f} ns  {(v - loop) / gyro:5.2f} gyrostat steps "
              "(orbit, field, shadow, atmosphere at 1 s, sun at 60 s: the case without every disturbance less the loop)")
    cal = per_step.get("calibration (Python loop)")
    if cal:
        print("calibration (Python loop) per round, ms: " + " ".join(f"{x * steps * 1e3:.1f}" for x in cal))
    print(f"{'ratio':58s} {'median':>7s} {'min':>7s} {'max':>7s}")
    for name, v in ratios.items():
        if not v:
            continue
        print(f"{name:58s} {statistics.median(v):7.2f} {min(v):7.2f} {max(v):7.2f}")
    if args.accuracy:
        accuracy()


if __name__ == "__main__":
    from lgvi.systems.loop_keywords import as_given

    with as_given():   # wheels=, controller= here measure the gyrostat, as before (docs/loop.md)
        main()
