"""Monte Carlo ensembles with reaction wheels: members one after the other against members in threads.

``lgvi.simulate_ensemble(..., wheels=, controller=, threads=)`` runs every member through the
gyrostat's compiled loop (``nogil=True``) in a thread pool. Same run, same members: ``threads=1``
against ``threads=2`` (and more when the machine has them), for a compiled controller
(``MRPFeedback`` with a fixed target: the whole run compiled) and a Python controller
(``RotationPD``, called every control period with the GIL). Prints medians and the ratio.

Usage::

    python benchmarks/bench_gyrostat_ensemble.py [--members 16] [--repeat 5] [--quick]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import lgvi
from lgvi.control import MRPFeedback, RotationPD
from lgvi.systems.loop_keywords import as_given


def inputs(B: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    J = [np.diag([900.0, 800.0, 600.0]) * (1 + 0.05 * rng.normal(size=3)) for _ in range(B)]
    wheels = [lgvi.ReactionWheels(lgvi.so3.exp(np.radians(0.5) * rng.normal(size=3)).T, 0.08,
                                  speed0=10.0 + rng.normal(size=3), max_torque=0.2) for _ in range(B)]
    R0 = lgvi.so3.exp(0.3 * rng.normal(size=(B, 3)))
    w0 = 0.01 * rng.normal(size=(B, 3))
    return J, wheels, R0, w0


def timed(fn, repeat: int) -> float:
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="4 members, 1 repetition, shorter runs")
    args = ap.parse_args(argv)
    B, repeat, steps = (4, 1, 600) if args.quick else (args.members, args.repeat, 6000)
    J, wheels, R0, w0 = inputs(B)
    cores = os.cpu_count() or 1
    print(f"simulate_ensemble with wheels: {B} members, {steps} steps of 0.1 s, {cores} cores "
          "(machine shared with other jobs: medians)")
    print(f"{'controller':>34} {'threads':>7} {'ms':>9} {'vs threads=1':>12}")
    cases = [("MRPFeedback compiled (0.1 s)", lambda b: MRPFeedback(K=3.5, P=30.0), 0.1),
             ("RotationPD, Python (1 s)", lambda b: RotationPD(2.0, 40.0), 1.0)]
    for name, make, period in cases:
        base = None
        for threads in sorted({1, 2, cores}):
            def run(threads=threads):
                with as_given():     # the gyrostat ensemble (the keywords alone now map onto the loop)
                    return lgvi.simulate_ensemble(J, R0, omega0=w0, h=0.1, steps=steps, wheels=wheels,
                                                  controller=[make(b) for b in range(B)], control_period=period,
                                                  threads=threads, save_every=10)
            wall = timed(run, repeat)
            base = wall if base is None else base
            print(f"{name:>34} {threads:7d} {wall * 1e3:9.2f} {base / wall:11.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
