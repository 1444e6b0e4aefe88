"""Slosh with reaction wheels: the cost of a step of ``lgvi.simulate_slosh(..., wheels=, controller=)``
against the same hub without wheels and against lgvi's gyrostat (the hub alone with the same wheels).

Usage::

    python benchmarks/bench_slosh_wheels.py            # 1e5 steps per run, 7 interleaved rounds
    python benchmarks/bench_slosh_wheels.py --quick    # reduced size (no timing assertions anywhere)

Case: the hub of ``tests/test_slosh.py`` (1500 kg, inertia diag(900, 800, 600) kg m^2) with two
pendulums (0.3 m 40 kg, 0.4 m 60 kg) and three wheels on the body axes (0.08 kg m^2, 0.2 N m), at
h = 0.01 s, order 2, saving every 1000 steps. CPU time per step (``time.process_time``, median of
interleaved rounds, one core, after a compiling call); ratios to the two-pendulum hub without
wheels and to the gyrostat with the same wheels and the same MRP feedback, measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import statistics

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

from bench_chain import cpu  # noqa: E402  (the chain benchmark's timer)

import lgvi  # noqa: E402
from lgvi.systems.gyrostat import simulate_gyrostat  # noqa: E402

J = [900.0, 800.0, 600.0]
W0 = np.array([0.03, -0.02, 0.05])
HUB = (J, 1500.0, [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]], [0.3, 0.4], [40.0, 60.0], np.eye(3),
       [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]], [[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]])
H = 0.01
TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.1]))


def wheels():
    return lgvi.ReactionWheels(np.eye(3), 0.08, speed0=[10.0, 20.0, 30.0], max_torque=0.2)


def mrp():
    return lgvi.control.MRPFeedback(K=3.5, P=30.0, target=TARGET)


def cases(steps):
    se = 1000 if steps % 1000 == 0 else steps

    def sl(**kw):
        return lambda n: lgvi.simulate_slosh(*HUB, omega0=W0, h=H, steps=n, save_every=se if n == steps else 1, **kw)

    return {
        "slosh, no wheels": sl(),
        "slosh + wheels, motors off": sl(wheels=wheels()),
        "slosh + wheels, held torques": sl(wheels=wheels(), wheel_torque=[0.1, -0.05, 0.02]),
        "slosh + wheels, MRP every step": sl(wheels=wheels(), controller=mrp(), control_period=H),
        "slosh + wheels, MRP every 10": sl(wheels=wheels(), controller=mrp(), control_period=10 * H),
        "slosh damped + wheels + MRP": sl(wheels=wheels(), controller=mrp(), control_period=H, damping=[30.0, 50.0]),
        "slosh no wheels, damped": sl(damping=[30.0, 50.0]),
        "gyrostat + wheels + MRP": lambda n: simulate_gyrostat(J, np.eye(3), omega0=W0, h=H, steps=n, wheels=wheels(),
                                                              controller=mrp(), control_period=H,
                                                              save_every=se if n == steps else 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size")
    args = ap.parse_args()
    steps, rounds = (2_000, 2) if args.quick else (100_000, 7)
    print("slosh + wheels benchmark; the machine may be shared: compare ratios, not seconds")
    table = cases(steps)
    for fn in table.values():
        fn(10)                                   # compile (or load) outside the timing
    times = {k: [] for k in table}
    for _ in range(rounds):                      # interleaved: a load spike hits every case alike
        for k, fn in table.items():
            times[k].append(cpu(lambda: fn(steps))[1])
    med = {k: statistics.median(v) for k, v in times.items()}
    base, gyro = med["slosh, no wheels"], med["gyrostat + wheels + MRP"]
    print(f"\nCPU time per step, {steps} steps of {H:g} s, median of {rounds} interleaved rounds (one core)")
    print(f"{'case':<32}{'ns/step':>10}{'/no wheels':>12}{'/gyrostat':>11}")
    for k, t in med.items():
        print(f"{k:<32}{1e9 * t / steps:>10.0f}{t / base:>12.2f}{t / gyro:>11.2f}")


if __name__ == "__main__":
    main()
