"""What issue 29's checks cost per step: the contact check of the orbit and two-body kernels, and the
caught exceptions of a user's compiled moment (``torques.Compiled``).

Usage::

    python benchmarks/contact_cost.py --compare OLD_SRC NEW_SRC   # e.g. a checkout of main, and src
    python benchmarks/contact_cost.py --quick --compare src src   # a smoke run

Each round runs one child process per tree (alternating OLD, NEW), which times the cases below
(CPU time of the process, the median of its repeats, after a warm-up that compiles or loads the
kernels); the table gives the median over rounds of each tree's time per step and their ratio
NEW / OLD. On a machine shared with other jobs the times move; the ratio of runs made in the same
round moves less.
"""

from __future__ import annotations

import argparse
import statistics

from _trees import run_child

CHILD = r'''
import json, time
import numba
import numpy as np
import lgvi
from lgvi.torques import Compiled

STEPS, REPEATS = {steps}, {repeats}
J = np.array([[0.04, 0.003, -0.002], [0.003, 0.06, 0.001], [-0.002, 0.001, 0.075]])


@numba.njit
def spring(t, R, Pi, p):
    return (-p[0] * R[2, 1], p[0] * R[2, 0], 0.0)


cases = {{
    "simulate_orbit, order2": lambda n: lgvi.simulate_orbit(J, 1.0, [1.0, 0.0, 0.1], [0.0, 1.15, 0.05], np.eye(3),
                                                          omega0=[0.3, -0.4, 1.3], h=1e-3, steps=n, mu=1.0,
                                                          save_every=n),
    "simulate_two_body, ellipsoids order4": lambda n: lgvi.simulate_two_body(
        lgvi.Ellipsoid(1.0, 0.7, 0.5), lgvi.Ellipsoid(0.3, 0.25, 0.2), 1.0, 0.1, [3.0, 0, 0], [0, 0.6, 0], np.eye(3),
        np.eye(3), omega1_0=[0, 0, 1.0], omega2_0=[0, 0, 0.2], h=1e-3, steps=n, potential="order4", save_every=n),
    "simulate, Compiled moment": lambda n: lgvi.simulate(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3),
                                                         omega0=[0.3, 0.5, 0.9], h=1e-3, steps=n, save_every=n,
                                                         torque=Compiled(spring, params=[0.1])),
}}
out = {{"file": lgvi.__file__}}
for name, f in cases.items():
    f(10)
    ts = []
    for _ in range(REPEATS):
        t0 = time.process_time()
        f(STEPS)
        ts.append(time.process_time() - t0)
    out[name] = sorted(ts)[len(ts) // 2] / STEPS
print(json.dumps(out))
'''


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", nargs=2, metavar=("OLD_SRC", "NEW_SRC"), required=True)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    rounds, steps, repeats = (1, 2000, 2) if args.quick else (args.rounds, args.steps, args.repeats)
    code = CHILD.format(steps=steps, repeats=repeats)
    runs: dict[str, list[dict]] = {"old": [], "new": []}
    for _ in range(rounds):
        for key, src in zip(("old", "new"), args.compare):
            runs[key].append(run_child(src, code))
    names = [k for k in runs["new"][0] if k != "file"]
    print(f"{steps} steps per run, median of {repeats} repeats per child, {rounds} rounds alternating "
          f"OLD = {args.compare[0]}, NEW = {args.compare[1]} (CPU time)")
    print(f"{'case':40s} {'OLD us/step':>12s} {'NEW us/step':>12s} {'NEW / OLD':>10s}")
    for name in names:
        old = statistics.median(r[name] for r in runs["old"]) * 1e6
        new = statistics.median(r[name] for r in runs["new"]) * 1e6
        ratio = statistics.median(n[name] / o[name] for o, n in zip(runs["old"], runs["new"]))
        print(f"{name:40s} {old:12.3f} {new:12.3f} {ratio:10.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
