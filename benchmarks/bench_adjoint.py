"""Cost of a gradient through an LGVI run (discrete adjoint) against a forward run.

Usage::

    python benchmarks/bench_adjoint.py            # 1e4 steps, 15 rounds
    python benchmarks/bench_adjoint.py --quick    # reduced size, for CI (no timing assertions)

One body (``J = diag(1, 2, 2.5)``), a tumbling start, a smooth control array, ``h = 0.01``, one
core. Per round, interleaved: ``simulate`` (``lgvi.simulate`` with the control array, the
library's forward run), ``rollout`` (the forward run that keeps every state and ``F_k`` for the
reverse pass), ``reverse`` (the reverse pass alone, one cost) and ``gradient`` (rollout plus the
cost and the reverse pass: value and gradient in ``u``, ``R0``, ``Pi0``, ``J``, ``h``). The
ratios are taken within each round, then the median over rounds, so the load of a shared machine
affects both sides of a ratio alike. ``7 seeds`` is the reverse pass of :func:`lgvi.optimal.transfer`
(cost plus six terminal constraints).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import lgvi  # noqa: E402
from lgvi import so3  # noqa: E402
from lgvi.optimal import AttitudeError, Effort, RateError, cost_gradient, rollout  # noqa: E402
from lgvi.optimal.adjoint import reverse  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size (CI)")
    ap.add_argument("--steps", type=int, default=10_000)
    ap.add_argument("--rounds", type=int, default=15)
    args = ap.parse_args()
    steps, rounds = (1000, 3) if args.quick else (args.steps, args.rounds)
    repeat = 1 if args.quick else 5      # calls per sample: samples of ~10 ms, longer than a time slice
    body = lgvi.RigidBody([1.0, 2.0, 2.5])
    h = 0.01
    t = h * np.arange(steps)
    u = np.stack([0.1 * np.sin(t), 0.05 * np.cos(0.3 * t), 0.02 * np.ones_like(t)], axis=1)
    R0, Pi0 = so3.exp([0.1, 0.2, 0.3]), body.J @ np.array([0.5, -0.3, 0.8])
    cost = [Effort(), AttitudeError(so3.exp([0.3, 0.0, 0.0])), RateError()]
    run = rollout(body, R0, Pi0, h, u)
    seeds7 = (np.zeros((7, 1, 3)), np.zeros((7, 1, 3)), np.zeros((7, steps, 3)))
    seeds7[0][:, -1] = 1.0

    cases = {
        "simulate": lambda: lgvi.simulate(body, R0, Pi0, h=h, steps=steps, torque=u),
        "rollout": lambda: rollout(body, R0, Pi0, h, u),
        "reverse": lambda: cost_gradient(run, cost),
        "gradient": lambda: cost_gradient(rollout(body, R0, Pi0, h, u), cost),
        "7 seeds": lambda: reverse(run, *seeds7),
    }
    for f in cases.values():          # compile / warm up
        f()
    times: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(rounds):
        for name, f in cases.items():
            t0 = time.perf_counter()
            for _ in range(repeat):
                f()
            times[name].append((time.perf_counter() - t0) / repeat)
    print(f"discrete adjoint: {steps} steps, h = {h}, median of {rounds} rounds of {repeat} calls "
          f"(ratios within each round)")
    print(f"{'case':10s} {'ms':>9s} {'/ simulate':>11s} {'/ rollout':>10s}")
    for name in cases:
        ms = 1e3 * statistics.median(times[name])
        r_sim = statistics.median(a / b for a, b in zip(times[name], times["simulate"]))
        r_run = statistics.median(a / b for a, b in zip(times[name], times["rollout"]))
        print(f"{name:10s} {ms:9.3f} {r_sim:11.2f} {r_run:10.2f}")


if __name__ == "__main__":
    main()
