"""What the mapping of today's keywords onto the loop costs (lgvi.systems.loop_keywords).

``lgvi.simulate(body, ..., wheels=, controller=MRPFeedback(...), control_period=)`` now runs the
compiled loop (an ``lgvi.Spacecraft`` with ``InertialPointing``, ``MRPControl``,
``RWMotorTorque``); inside ``loop_keywords.as_given()`` it runs the gyrostat's compiled MRP
feedback as before. Both give the same trajectory bit for bit (checked here too); this prints the
CPU time of each (medians of alternated runs, after a warm-up call) and their ratio.

Usage::

    PYTHONPATH=src python benchmarks/loop_keywords.py [--repeat 7] [--steps 20000]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np

import lgvi
from lgvi.control import MRPFeedback
from lgvi.systems.loop_keywords import as_given

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])


def call(steps: int):
    wheels = lgvi.ReactionWheels(PYRAMID, 1e-4, speed0=[10.0, -20.0, 5.0, 0.0], max_torque=0.004)
    ctrl = MRPFeedback(K=0.004, P=0.04, target=lgvi.so3.exp([0.3, -0.2, 0.5]))
    return lgvi.simulate(lgvi.RigidBody([0.18, 0.14, 0.06]), np.eye(3), omega0=[0.01, -0.02, 0.015], h=0.1,
                         steps=steps, save_every=10, wheels=wheels, controller=ctrl, control_period=1.0)


def gyrostat(steps: int):
    with as_given():
        return call(steps)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--steps", type=int, default=20000)
    args = ap.parse_args()
    warnings.simplefilter("ignore", DeprecationWarning)
    a, b = call(args.steps), gyrostat(args.steps)              # warm-up (compiles or loads the kernels)
    assert np.array_equal(a.R, b.R) and np.array_equal(a.wheel_momentum, b.wheel_momentum)
    times: dict[str, list[float]] = {"old keywords, mapped (the loop)": [], "as_given (the gyrostat)": []}
    for _ in range(args.repeat):
        for name, f in zip(times, (call, gyrostat)):
            t0 = time.process_time()
            f(args.steps)
            times[name].append(time.process_time() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    base = med["as_given (the gyrostat)"]
    print(f"{args.steps} steps, h = 0.1 s, 4 wheels, MRP feedback every 1 s; CPU s, median of {args.repeat} "
          "alternated runs")
    print(f"{'path':<34} {'CPU s':>9} {'ratio':>7}")
    for k, v in med.items():
        print(f"{k:<34} {v:9.4f} {v / base:7.2f}")


if __name__ == "__main__":
    main()
