"""A user's compiled moment in a CPU ensemble beside the same built-in model: CPU time, same run.

Usage::

    python benchmarks/bench_user_ensemble.py                 # 2048 x 50 and 512 x 2000, median of 5
    python benchmarks/bench_user_ensemble.py --quick         # small sizes, one repeat (checks output)

Case: the heavy top of ``benchmarks/bench_gpu.py`` (inertia (0.13, 0.28, 0.17), ``UniformGravity``,
order 2, ``cayley``), as the built-in model and as the user's :class:`lgvi.torques.Compiled` gravity
with one parameter row a body (its potential too). The two alternate run by run; each row prints the
median CPU time of the whole ``simulate_ensemble`` call (set-up, trial of the user's functions,
steps, potentials), the ratio user/built-in and the largest difference of the final attitudes (the
same physics: round-off only). Few steps make the fixed per-body costs show; many steps the per-step
cost. CPU time, not wall: the machines here are shared.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import lgvi  # noqa: E402
from bench_gpu import GRAVITY, TOP, initial, user_gravity, user_gravity_potential  # noqa: E402
from lgvi.torques import Compiled  # noqa: E402


def run(torque, R0: np.ndarray, Pi0: np.ndarray, steps: int) -> tuple[float, np.ndarray]:
    c = time.process_time()
    ens = lgvi.simulate_ensemble(TOP, R0, Pi0, h=0.01, steps=steps, save_every=steps, torque=torque,
                                 method="cayley", progress=False)
    return time.process_time() - c, ens.R[:, -1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="small sizes, one repeat")
    args = ap.parse_args()
    sizes = [(64, 20), (16, 200)] if args.quick else [(2048, 50), (512, 2000)]
    repeat = 1 if args.quick else args.repeat
    p = GRAVITY.mass * GRAVITY.g * GRAVITY.com
    print(f"CPU time of simulate_ensemble, median of {repeat} (alternating), numba threads {lgvi._jit.numba.get_num_threads()}")
    print(f"{'bodies':>7} | {'steps':>6} | {'built-in s':>10} | {'Compiled s':>10} | {'Compiled/built-in':>17} | {'max |dR|':>9}")
    print("-" * 74)
    for bodies, steps in sizes:
        R0, Pi0 = initial(bodies, True)
        user = Compiled(user_gravity, potential=user_gravity_potential, params=np.tile(p, (bodies, 1)))
        run(GRAVITY, R0[:2], Pi0[:2], 2)                            # compile both, untimed
        run(Compiled(user_gravity, potential=user_gravity_potential, params=np.tile(p, (2, 1))), R0[:2], Pi0[:2], 2)
        tb, tu = [], []
        for _ in range(repeat):
            a, Ra = run(GRAVITY, R0, Pi0, steps)
            b, Rb = run(user, R0, Pi0, steps)
            tb.append(a)
            tu.append(b)
        mb, mu = statistics.median(tb), statistics.median(tu)
        print(f"{bodies:>7} | {steps:>6} | {mb:>10.3f} | {mu:>10.3f} | {mu / mb:>17.2f} | {np.abs(Ra - Rb).max():>9.1e}")


if __name__ == "__main__":
    main()
