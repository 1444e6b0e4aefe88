"""Monte Carlo of the CubeSat ADCS mission (``examples/cubesat_mission.toml``): N dispersed members,
statistics with confidence intervals, the failing members named with why, and the wall time.

Each member ``b`` is the file's mission with its own draws from ``numpy.random.default_rng((seed, b))``
(so member ``b`` is the same whatever N, the batch or the thread count):

* initial attitude uniform on SO(3); initial rate 10 deg/s about a uniform direction; the MEKF's
  first estimate off by a rotation of 1 deg rms per axis;
* inertia: principal moments scaled by 1 + U(-5 %, 5 %), the matrix turned by a rotation of
  1 deg rms per axis (its axes);
* wheel axes and magnetorquer rods each tilted by 0.5 deg rms per axis (the flight software maps
  onto the true axes: no misalignment knowledge error);
* gyro bias N(0, 1e-4 rad/s) per axis, magnetometer bias N(0, 3e-8 T) per axis (the filter does not
  estimate it); noise seeds: every sensor's seed is ``1000 + b``;
* drag coefficient U(2.0, 2.4); radiation pressure: absorbed U(0.5, 0.7), the rest half specular,
  half diffuse; residual dipole N(0, 0.01 A m^2) per axis;
* gains: K, P of the MRP feedback x U(0.9, 1.1); B-dot and dumping gains x U(0.8, 1.2).

A member *fails* when it does not detumble (never leaves mode 0, detumble), saturates (a wheel above
``--max-speed`` rad/s, 6000 rpm by default: 0.0126 N m s a wheel), its estimator diverges (the
MEKF's status 2, or a knowledge error above 1 deg after settling), does not end in nadir pointing,
or never settles below 0.1 deg in a pointing mode (``loop_summary``'s ``not_settled`` says why).
Statistics are over the members that reached nadir pointing: mean with its 95 % interval
(Student t), and the 95th percentile with its 95 % interval from the order statistics (binomial).

Usage::

    PYTHONPATH=src python benchmarks/mission_monte_carlo.py --members 1000 [--threads 2] [--orbits 3]
    PYTHONPATH=src python benchmarks/mission_monte_carlo.py --quick       # 8 members, one orbit
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import stats
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.fsw import BDotControl, FlightSoftware, MEKF, MomentumDumpingControl, MRPControl
from lgvi.io import examples
from lgvi.io.scenario import Scenario
from lgvi.io.scenario_loop import loop_summary
from lgvi.spacecraft import FacetDrag, FacetSRP, Gyro, Magnetometer, ResidualDipole, Spacecraft, StarTracker

PERIOD = 5677.0                       # [s] the orbit's period
RECORD = ["mode", "R_ref", "sigma_BR", "omega_BR_B", "est_error", "tau_facet_drag_B", "tau_facet_srp_B",
          "tau_residual_dipole_B", "r_N"]


def nominal() -> Scenario:
    """The shipped mission file, checked."""
    return Scenario.from_dict(tomllib.loads(examples.text("cubesat_mission")), "cubesat_mission.toml")


def _tilt(rng: np.random.Generator, axes: np.ndarray, sigma: float) -> np.ndarray:
    return np.stack([Rotation.from_rotvec(rng.normal(0.0, sigma, 3)).apply(np.array(a)) for a in axes])


def member(b: int, *, seed: int = 2026, base: Scenario | None = None):
    """Member ``b``: ``(spacecraft, fsw, R0, omega0)``, its draws from ``default_rng((seed, b))``."""
    base = nominal() if base is None else base
    rng = np.random.default_rng((seed, b))
    sc, fsw = base.spacecraft, base.fsw
    deg = math.radians(1.0)
    # attitude, rate and the filter's first estimate
    R0 = Rotation.random(random_state=rng).as_matrix()
    direction = rng.normal(size=3)
    omega0 = math.radians(10.0) * direction / np.linalg.norm(direction)
    R_est0 = R0 @ Rotation.from_rotvec(rng.normal(0.0, deg, 3)).as_matrix()
    # inertia: moments and axes
    w, V = np.linalg.eigh(sc.body.J)
    Q = Rotation.from_rotvec(rng.normal(0.0, deg, 3)).as_matrix()
    J = Q @ V @ np.diag(w * (1.0 + rng.uniform(-0.05, 0.05, 3))) @ V.T @ Q.T
    J = 0.5 * (J + J.T)
    wh = sc.wheels
    wheels = lgvi.ReactionWheels(_tilt(rng, wh.axes, 0.5 * deg), wh.spin_inertia, max_torque=wh.max_torque)
    rods = lgvi.Magnetorquers(_tilt(rng, sc.magnetorquers.axes, 0.5 * deg), sc.magnetorquers.max_dipole)
    # sensors (their noise seeds) and biases
    kinds = {c.kind: c for c in sc.sensors}
    g, st, m, css = kinds["gyro"], kinds["star_tracker"], kinds["magnetometer"], kinds["coarse_sun_sensors"]
    s = 1000 + b
    gyro = Gyro(rate=g.rate, arw=g.arw, rrw=g.rrw, bias=rng.normal(0.0, 1e-4, 3), seed=s)
    tracker = StarTracker(rate=st.rate, sigma_cross=st.sigma_cross, sigma_about=st.sigma_about,
                          sun_exclusion=st.sun_exclusion, earth_exclusion=st.earth_exclusion, seed=s)
    mag = Magnetometer(rate=m.rate, sigma=m.sigma, bias=rng.normal(0.0, 3e-8, 3), seed=s)
    sensors = [gyro, tracker, mag, replace_seed(css, s)]
    # disturbances: drag and radiation coefficients, residual dipole
    dist = []
    for d in sc.disturbances:
        if d.kind == "facet_drag":
            d = FacetDrag(d.area[0], d.normal[0], d.centre[0], rng.uniform(2.0, 2.4), rate=d.rate)
        elif d.kind == "facet_srp":
            a = rng.uniform(0.5, 0.7)
            d = FacetSRP(d.area[0], d.normal[0], d.centre[0], absorbed=a, specular=(1 - a) / 2, diffuse=(1 - a) / 2,
                         rate=d.rate)
        elif d.kind == "residual_dipole":
            d = ResidualDipole(rng.normal(0.0, 0.01, 3), rate=d.rate)
        dist.append(d)
    sat = Spacecraft(J, wheels=wheels, magnetorquers=rods, orbit=sc.orbit, field=sc.field, epoch=sc.epoch,
                     disturbances=dist, sensors=sensors, environment=sc.environment, orbit_dt=sc.orbit_dt,
                     environment_rate=sc.environment_rate, magnetorquer_rate=sc.magnetorquer_rate)
    # flight software: the filter's first estimate, the gains
    est = fsw.estimator[0]
    mekf = MEKF(rate=est.rate, arw=est.arw, rrw=est.rrw, star_tracker=True, mag_sigma=est.mag_sigma, R0=R_est0,
                P0=est.P0)
    control = []
    for c in fsw.control:
        if c.kind == "mrp_feedback":
            c = MRPControl(K=c.K * rng.uniform(0.9, 1.1), P=c.P * rng.uniform(0.9, 1.1), rate=c.rate, modes=c.modes)
        elif c.kind == "bdot":
            c = BDotControl(c.gain * rng.uniform(0.8, 1.2), derivative=c.derivative, rate=c.rate, modes=c.modes)
        elif c.kind == "momentum_dumping":
            c = MomentumDumpingControl(c.gain * rng.uniform(0.8, 1.2), rate=c.rate, modes=c.modes)
        control.append(c)
    flight = FlightSoftware(estimator=mekf, guidance=fsw.guidance, modes=fsw.modes, control=control,
                            actuators=fsw.actuators, rate=fsw.rate, record=RECORD,
                            record_rate="grid")     # the statistics read the record grid only
    return sat, flight, R0, omega0


def replace_seed(sensor, seed: int):
    """A copy of ``sensor`` with another noise seed."""
    import copy

    out = copy.copy(sensor)
    out.seed = np.asarray(float(seed))
    return out


def verdict(s: dict, traj, max_speed: float) -> str | None:
    """Why member's run failed (None: it did not)."""
    if s["detumble_time_s"] is None:
        return (f"did not detumble ({s['not_settled'] or 'never left its first mode'}, |omega| "
                f"{s['rate_final_deg_s']:.2g} deg/s at the end)")
    top = float(np.abs(traj.wheel_speed).max())
    if top >= max_speed:
        return f"saturated (a wheel at {top:.0f} rad/s, the limit {max_speed:.0f})"
    if s["knowledge_error_deg"] is not None and s["knowledge_error_deg"]["max"] > 1.0:
        return f"estimator diverged (knowledge error {s['knowledge_error_deg']['max']:.2g} deg after settling)"
    if s["modes"][-1]["name"] != "nadir":
        return f"did not reach nadir pointing (ended in {s['modes'][-1]['name']})"
    if s["settle_time_s"] is None:
        return f"did not settle below {s['settle_deg']:g} deg ({s['not_settled']}, final error " + (
            "none" if s["error_final_deg"] is None else f"{s['error_final_deg']:.2g} deg") + ")"
    return None


def run(members: range, *, seed: int, steps: int, threads: int, max_speed: float, batch: int):
    """Fly ``members`` in batches; returns (rows, failures): a row of figures per member that
    reached nadir pointing, and ``{b: why}``."""
    base = nominal()
    rows, failures = {}, {}
    todo = list(members)
    while todo:
        chunk, todo = todo[:batch], todo[batch:]
        built = {b: member(b, seed=seed, base=base) for b in chunk}
        try:
            ens = lgvi.simulate_ensemble([built[b][0] for b in chunk], np.stack([built[b][2] for b in chunk]),
                                         omega0=np.stack([built[b][3] for b in chunk]),
                                         fsw=[built[b][1] for b in chunk], h=base.h, steps=steps,
                                         save_every=base.save_every, threads=threads)
        except lgvi.ConvergenceError as exc:             # a component stopped a member: name it, fly the rest
            bad = chunk[getattr(exc, "body", 0)]
            why = str(exc).split(": ", 1)[-1]
            failures[bad] = ("estimator diverged: " if "mekf" in why else "stopped: ") + why
            todo = [b for b in chunk if b != bad] + todo
            continue
        for b, traj in zip(chunk, ens.members):
            s = loop_summary(traj)
            why = verdict(s, traj, max_speed)
            if why is not None:
                failures[b] = why
                continue
            rows[b] = {"detumble time (s)": s["detumble_time_s"], "settle time (s)": s["settle_time_s"],
                       "control error mean (deg)": s["control_error_deg"]["mean"],
                       "control error p95 (deg)": s["control_error_deg"]["p95"],
                       "control error max (deg)": s["control_error_deg"]["max"],
                       "knowledge error p95 (deg)": s["knowledge_error_deg"]["p95"],
                       "knowledge error max (deg)": s["knowledge_error_deg"]["max"],
                       "wheel momentum peak (mN m s)": 1e3 * s["wheel_momentum_total_peak_Nms"],
                       "wheel momentum end (mN m s)": 1e3 * s["wheel_momentum_final_Nms"],
                       "dipole momentum (mN m s)": 1e3 * s["disturbances"]["residual_dipole"]["momentum_Nms"]}
    return rows, failures


def interval_mean(x: np.ndarray) -> tuple[float, float, float]:
    m = float(x.mean())
    if len(x) < 2:
        return m, math.nan, math.nan
    half = float(stats.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / math.sqrt(len(x)))
    return m, m - half, m + half


def interval_quantile(x: np.ndarray, q: float = 0.95) -> tuple[float, float, float]:
    """The q-quantile and a 95 % distribution-free interval: order statistics from the binomial."""
    xs = np.sort(x)
    n = len(xs)
    lo = int(stats.binom.ppf(0.025, n, q))
    hi = int(stats.binom.ppf(0.975, n, q)) + 1
    return float(np.percentile(xs, 100 * q)), float(xs[max(lo - 1, 0)]), float(xs[min(hi - 1, n - 1)])


def table(rows: dict) -> list[str]:
    names = list(next(iter(rows.values())))
    out = [f"| {'figure':<30} | {'mean [95 % CI]':<28} | {'95th percentile [95 % CI]':<28} |",
           f"|{'-' * 32}|{'-' * 30}|{'-' * 30}|"]
    for name in names:
        x = np.array([r[name] for r in rows.values()])
        m, a, b = interval_mean(x)
        p, c, d = interval_quantile(x)
        out.append(f"| {name:<30} | {m:9.4g} [{a:.4g}, {b:.4g}]".ljust(63) + f" | {p:9.4g} [{c:.4g}, {d:.4g}]".ljust(31)
                   + "|")
    return out


def split(m: int, orbits: float, seed: int) -> int:
    """Process time of each part of a member's run, averaged over ``m`` lone members."""
    from lgvi.systems.spacecraft import LoopRun

    base = nominal()
    steps = int(round(orbits * PERIOD / base.h / base.save_every)) * base.save_every
    run(range(1), seed=seed, steps=base.save_every, threads=1, max_speed=math.inf, batch=1)      # load the loop
    t = dict.fromkeys(("dispersions drawn", "run built", "simulate", "summary"), 0.0)
    for b in range(m):
        c = time.process_time()
        sat, fsw, R0, omega0 = member(b, seed=seed, base=base)
        t["dispersions drawn"] += time.process_time() - c
        c = time.process_time()
        LoopRun(sat, R0, None, omega0=omega0, h=base.h, steps=steps, fsw=fsw, save_every=base.save_every)
        t["run built"] += time.process_time() - c
        c = time.process_time()
        traj = lgvi.simulate(sat, R0, omega0=omega0, h=base.h, steps=steps, fsw=fsw, save_every=base.save_every)
        t["simulate"] += time.process_time() - c
        c = time.process_time()
        loop_summary(traj)
        t["summary"] += time.process_time() - c
    print(f"CPU a member ({m} lone members, {orbits:g} orbits, {steps} steps): "
          + ", ".join(f"{k} {v / m:.4f} s" for k, v in t.items()) + " (simulate builds the run again)")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=100)
    ap.add_argument("--orbits", type=float, default=3.0)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--batch", type=int, default=50, help="members flown together (memory: records of a batch)")
    ap.add_argument("--max-speed", type=float, default=628.3, help="wheel speed counted as saturated [rad/s]")
    ap.add_argument("--quick", action="store_true", help="8 members, one orbit")
    ap.add_argument("--split", type=int, default=0, metavar="M",
                    help="instead: where the CPU of M lone members goes (draws, build, simulate, summary)")
    args = ap.parse_args(argv)
    if args.split:
        return split(args.split, args.orbits, args.seed)
    if args.quick:
        args.members, args.orbits = 8, 1.0
    if args.members < 1:
        raise SystemExit(f"--members must be >= 1, got {args.members}")
    base = nominal()
    steps = int(round(args.orbits * PERIOD / base.h / base.save_every)) * base.save_every
    warm = time.perf_counter()
    run(range(1), seed=args.seed, steps=base.save_every, threads=1, max_speed=args.max_speed, batch=1)
    warm = time.perf_counter() - warm
    load = os.getloadavg()[0]
    wall, cpu = time.perf_counter(), time.process_time()
    rows, failures = run(range(args.members), seed=args.seed, steps=steps, threads=args.threads,
                         max_speed=args.max_speed, batch=args.batch)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(f"CubeSat ADCS mission Monte Carlo: {args.members} members x {args.orbits:g} orbits ({steps} steps of "
          f"{base.h:g} s each), seed {args.seed}, {args.threads} threads on {os.cpu_count()} cores, load "
          f"{load:.1f} -> {os.getloadavg()[0]:.1f}")
    print(f"wall {wall:.1f} s ({wall / args.members:.3f} s a member), CPU {cpu:.1f} s "
          f"({cpu / args.members:.3f} s a member); first load of the compiled loop {warm:.1f} s, not counted")
    print(f"1000 members x 3 orbits at this rate: {wall / args.members * 1000 * 3 / args.orbits:.0f} s wall "
          "(extrapolated linearly)")
    print(f"reached nadir pointing: {len(rows)} of {args.members}; failed: {len(failures)}")
    for b in sorted(failures):
        print(f"  member {b}: {failures[b]}")
    if rows:
        print("\n".join(table(rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
