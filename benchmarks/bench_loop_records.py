"""What recording every write at its writer's rate costs in the compiled loop: CPU time, same run.

Usage::

    PYTHONPATH=src python benchmarks/bench_loop_records.py              # 100000 steps, 7 rounds
    PYTHONPATH=src python benchmarks/bench_loop_records.py --quick      # 2000 steps, 3 rounds

The 6U of issue 25 (inertia diag(0.18, 0.14, 0.06) kg m^2, four pyramid wheels, h = 0.1 s), a gyro
every step, MRP feedback every 0.2 s to a fixed target (``RWMotorTorque``), records every
``save_every = 10`` steps, in three cases:

* ``writer`` (the default ``FlightSoftware(record_rate="writer")``): the gyro's and the control
  law's signals written at each of their steps into their slots (every write recorded);
* ``grid`` (``record_rate="grid"``): the grid's columns only (one row every 10 steps);
* ``no records`` (``record=[]``): nothing on the record grid.

Each case is one ``lgvi.simulate`` call (the kernels warm), timed with the process's CPU time; the
cases alternate within each round, the ratios are taken within a round, then the median, min and
max over the rounds; the record sizes are printed too. The machine may be shared: say so.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import lgvi  # noqa: E402
from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque  # noqa: E402
from lgvi.spacecraft import Gyro, Spacecraft  # noqa: E402

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))


def case(record_rate: str, record=None):
    sat = Spacecraft([0.18, 0.14, 0.06], wheels=lgvi.ReactionWheels(PYRAMID, 1e-4, max_torque=0.004),
                     sensors=[Gyro(rate=0.1, arw=1e-4, rrw=1e-5, seed=1)])
    fsw = FlightSoftware(guidance=InertialPointing(TARGET), control=MRPControl(K=0.004, P=0.04, rate=0.2),
                         actuators=RWMotorTorque(), rate=1.0, record=record, record_rate=record_rate)
    return sat, fsw


def run(sat, fsw, steps):
    return lgvi.simulate(sat, np.eye(3), omega0=[0.01, -0.02, 0.015], h=0.1, steps=steps, save_every=10, fsw=fsw)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=100000)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    steps, repeat = (2000, 3) if args.quick else (args.steps, args.repeat)
    cases = {"writer": case("writer"), "grid": case("grid"), "no records": case("grid", record=[])}
    runs = {name: run(*c, 100) for name, c in cases.items()}                 # warm
    assert np.array_equal(runs["writer"].R, runs["grid"].R) and np.array_equal(runs["writer"].R, runs["no records"].R)
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(repeat):
        for name, c in cases.items():
            t0 = time.process_time()
            tr = run(*c, steps)
            times[name].append(time.process_time() - t0)
            runs[name] = tr
    print(f"{steps} steps of h = 0.1 s, save_every = 10, {repeat} rounds (CPU time, medians), load "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"{'case':<12} {'us/step':>8} {'record floats/entry':>20} {'MB':>7}")
    for name in cases:
        data = runs[name].signal_data
        print(f"{name:<12} {1e6 * statistics.median(times[name]) / steps:8.3f} {data.shape[1]:20d} "
              f"{data.nbytes / 1e6:7.2f}")
    for a, b in (("writer", "grid"), ("grid", "no records")):
        r = [x / y for x, y in zip(times[a], times[b])]
        print(f"{a} / {b}: median {statistics.median(r):.3f}, min {min(r):.3f}, max {max(r):.3f}")


if __name__ == "__main__":
    main()
