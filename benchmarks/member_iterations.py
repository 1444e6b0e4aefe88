"""Why the sensors + MEKF member takes more Newton iterations a step than the true-state member.

Usage::

    python benchmarks/member_iterations.py                  # 20 000 steps, the figures of docs/performance.md
    python benchmarks/member_iterations.py --steps 2000     # a quick look

The two members of ``bench_loop_sensors.py --member`` (a gyro, a star tracker and the MEKF at 2 Hz, the
controller on the estimate; the controller on the truth), each run once with every step saved. Printed:

* the Newton iterations a step at the solver's tolerance ``tol`` of 1e-14 (lgvi's default) and looser ones:
  an iteration the member keeps at a loose tolerance is one its guess misses by more than that;
* the miss of the solver's guess, the quadratic extrapolation of the last three momenta (its error is the
  momentum's third difference), relative to the momentum, at a few steps of the run: the member's body keeps
  turning under the estimate's noise, the true-state member's comes to rest on its target.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_loop_sensors as bench  # noqa: E402


def _run(name: str, steps: int, tol: float, save_every: int):
    sensed, est, plain = bench._members()
    sc, e = (sensed, est) if name == "sensors + MEKF" else (plain, None)
    return bench.lgvi.simulate(sc, np.eye(3), omega0=bench.OMEGA0, fsw=bench._fsw(e), h=bench.H, steps=steps,
                               save_every=save_every, tol=tol)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20000)
    args = ap.parse_args()
    names = ("sensors + MEKF", "true-state feedback")
    print(f"Newton iterations a step, {args.steps} steps of h = {bench.H} s")
    print(f"{'tol':>8s}" + "".join(f"{n:>22s}" for n in names))
    for tol in (1e-14, 1e-13, 1e-12, 1e-11, 1e-10, 1e-9):
        row = []
        for n in names:
            s = _run(n, args.steps, tol, args.steps).meta["solver_summary"]
            row.append(s["iterations_total"] / s["steps"])
        print(f"{tol:8.0e}" + "".join(f"{x:22.4f}" for x in row))
    print("\nthe guess's miss (the momentum's third difference) over the momentum, tol = 1e-14")
    at = sorted({k for k in (args.steps // 20, args.steps // 4, args.steps // 2, 3 * args.steps // 4, args.steps - 10)
                 if 3 <= k < args.steps - 2})
    print(f"{'step':>8s}" + "".join(f"{n:>22s}" for n in names))
    rel = {}
    for n in names:
        Pi = _run(n, args.steps, 1e-14, 1).Pi
        d3 = np.linalg.norm(Pi[3:] - 3 * Pi[2:-1] + 3 * Pi[1:-2] - Pi[:-3], axis=1)
        rel[n] = d3 / np.linalg.norm(Pi[3:], axis=1)
    for k in at:
        print(f"{k:8d}" + "".join(f"{rel[n][k - 3]:22.1e}" for n in names))


if __name__ == "__main__":
    main()
