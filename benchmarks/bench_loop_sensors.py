"""The compiled loop with sensors, the MEKF and every disturbance: CPU time per step, same run.

Usage::

    python benchmarks/bench_loop_sensors.py            # 20000 steps a run, 7 rounds
    python benchmarks/bench_loop_sensors.py --quick    # 2000 steps, 3 rounds (checks it runs)

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
* ``gyrostat step``: ``lgvi.simulate`` of the same body with the same wheels and no controller
  (the gyrostat's compiled step).

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
from lgvi.spacecraft import Gyro, Spacecraft, StarTracker  # noqa: E402

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


def _fsw(estimator=None):
    return FlightSoftware(estimator=estimator, guidance=InertialPointing(TARGET), control=MRPControl(K=0.004, P=0.04),
                          actuators=RWMotorTorque(), rate=1.0)


def cases(steps):
    gyro = Gyro(rate=0.5, arw=1e-4, rrw=1e-5, bias=[2e-4, -1e-4, 5e-5], seed=7)
    st = StarTracker(rate=0.5, sigma_cross=5e-5, sigma_about=4e-4, seed=7)
    est = MEKF(rate=0.5, arw=1e-4, rrw=1e-5, star_tracker=st, P0=[0.03 ** 2] * 3 + [3e-4 ** 2] * 3)
    sensed = Spacecraft(J, wheels=_wheels(), sensors=[gyro, st])
    plain = Spacecraft(J, wheels=_wheels())
    six_u, d = _basilisk_6u()
    from scipy.spatial.transform import Rotation

    R6 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    bare = Spacecraft(six_u.body, orbit=six_u.orbit, field=six_u.field, epoch=six_u.epoch,
                      disturbances=[c for c in six_u.disturbances if c.kind == "orbit_gravity_gradient"])
    held, _ = _basilisk_6u()                    # its own components: the dipole's modes set on its copy only
    for c in held.components():
        if c.kind == "residual_dipole":
            c.modes = (0,)
    kw = dict(h=H, steps=steps, save_every=steps)
    return {
        "sensors + MEKF": lambda: lgvi.simulate(sensed, np.eye(3), omega0=OMEGA0, fsw=_fsw(est), **kw),
        "true-state feedback": lambda: lgvi.simulate(plain, np.eye(3), omega0=OMEGA0, fsw=_fsw(), **kw),
        "all disturbances": lambda: lgvi.simulate(six_u, R6, omega0=d["omega0"], **kw),
        "all dist., held (1st order)": lambda: lgvi.simulate(held, R6, omega0=d["omega0"], **kw),
        "orbit, field, gravity grad.": lambda: lgvi.simulate(bare, R6, omega0=d["omega0"], **kw),
        "gyrostat step": lambda: lgvi.simulate(lgvi.RigidBody(J), np.eye(3), omega0=OMEGA0, wheels=_wheels(), **kw),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    steps, rounds = (2000, 3) if args.quick else (20000, 7)
    runs = cases(steps)
    for f in runs.values():                     # compile or load, once
        f()
    per_step = {name: [] for name in runs}
    for _ in range(rounds):
        for name, f in runs.items():
            t = time.process_time()
            f()
            per_step[name].append((time.process_time() - t) / steps)
    ratios = {
        "sensors + MEKF / true-state feedback": [a / b for a, b in zip(per_step["sensors + MEKF"],
                                                                        per_step["true-state feedback"])],
        "all disturbances / gyrostat step": [a / b for a, b in zip(per_step["all disturbances"],
                                                                    per_step["gyrostat step"])],
        "all disturbances / orbit, field, g.g.": [a / b for a, b in zip(per_step["all disturbances"],
                                                                         per_step["orbit, field, gravity grad."])],
        "all disturbances / all dist., held": [a / b for a, b in zip(per_step["all disturbances"],
                                                                      per_step["all dist., held (1st order)"])],
        "true-state feedback / gyrostat step": [a / b for a, b in zip(per_step["true-state feedback"],
                                                                       per_step["gyrostat step"])],
    }
    print(f"{steps} steps of h = {H} s a run, {rounds} rounds, CPU time, medians (cases alternating)")
    print(f"{'case':28s} {'us/step':>9s}")
    for name, v in per_step.items():
        print(f"{name:28s} {statistics.median(v) * 1e6:9.3f}")
    print(f"{'ratio':40s} {'median':>7s} {'min':>7s} {'max':>7s}")
    for name, v in ratios.items():
        print(f"{name:40s} {statistics.median(v):7.2f} {min(v):7.2f} {max(v):7.2f}")


if __name__ == "__main__":
    from lgvi.systems.loop_keywords import as_given

    with as_given():   # wheels=, controller= here measure the gyrostat, as before (docs/loop.md)
        main()
