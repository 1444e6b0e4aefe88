"""Two-body benchmark: steps per second of ``lgvi.simulate_two_body`` and time to equal accuracy
against SciPy's DOP853 on the same case.

Usage::

    python benchmarks/bench_bodies.py            # 1e6 steps per speed run, 5 rounds
    python benchmarks/bench_bodies.py --quick    # reduced size, for CI (no timing assertions)

Case: two homogeneous ellipsoids (semi-axes 1, 0.7, 0.5 and 0.3, 0.25, 0.2; masses 1 and 0.1;
``G = 1``) at distance 3, spinning and tumbling, on an inclined mutual orbit (period about 30).

Table 1: the cost of a step of each mutual potential (median wall time of interleaved rounds,
one core). Table 2: the error at ``T = 60`` (positions and attitudes, max abs) against a DOP853
reference at ``rtol = 1e-13``, for lgvi at three steps and for DOP853 at the loosest tolerance
that is at least as accurate, with the wall time of each and the ratio DOP853 / lgvi measured in
the same run. DOP853 evaluates the same compiled mutual force (called from Python per stage), so
the comparison is of integrators, not of force code.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

from scipy.integrate import solve_ivp  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

import lgvi  # noqa: E402
from lgvi.systems.two_body import Moments, two_body_equations  # noqa: E402

B1, B2 = lgvi.Ellipsoid(1.0, 0.7, 0.5), lgvi.Ellipsoid(0.3, 0.25, 0.2)
M1, M2 = 1.0, 0.1
X0, V0 = [3.0, 0.0, 0.3], [0.0, 0.6, 0.1]
R1 = Rotation.from_rotvec([0.3, 0.5, -1.0]).as_matrix()
R2 = Rotation.from_rotvec([2.0, -0.5, 0.4]).as_matrix()
W1, W2 = [0.1, 0.2, 1.0], [0.3, 0.0, 0.2]


def run(h, steps, potential="order2", save_every=None):
    return lgvi.simulate_two_body(B1, B2, M1, M2, X0, V0, R1, R2, omega1_0=W1, omega2_0=W2, h=h, steps=steps,
                                  potential=potential, save_every=save_every or steps or 1)


def speed(steps, rounds):
    cases = ("order2", "order4")
    for p in cases:
        run(0.01, 10, p)                         # compile outside the timing
    times = {p: [] for p in cases}
    for _ in range(rounds):
        for p in cases:
            t = time.perf_counter()
            run(0.01, steps, p, save_every=1000 if steps % 1000 == 0 else steps)
            times[p].append(time.perf_counter() - t)
    print(f"\nTable 1: cost per step, {steps} steps, median of {rounds} interleaved rounds (one core)")
    print(f"{'potential':<10}{'wall s':>10}{'steps/s':>14}{'us/step':>10}{'/order2':>9}")
    base = statistics.median(times["order2"])
    for p in cases:
        w = statistics.median(times[p])
        print(f"{p:<10}{w:>10.3f}{steps / w:>14.3g}{1e6 * w / steps:>10.3f}{w / base:>9.2f}")


def accuracy(T, rounds):
    b1, b2 = Moments(B1, M1, "order2", "body1", "m1"), Moments(B2, M2, "order2", "body2", "m2")
    start = run(0.01, 0)
    y0 = np.concatenate([start.x[0].ravel(), start.p[0].ravel(), start.R[0, 0].ravel(), start.R[0, 1].ravel(),
                         start.Pi[0].ravel()])
    f = two_body_equations("order2", 1.0, b1, b2)
    ref = solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]

    def err_of(y):
        return max(np.abs(y[0:6] - ref[0:6]).max(), np.abs(y[12:30] - ref[12:30]).max())

    def timed(fn):
        best = []
        for _ in range(rounds):
            t = time.perf_counter()
            out = fn()
            best.append(time.perf_counter() - t)
        return out, statistics.median(best)

    print(f"\nTable 2: error at T = {T:g} against DOP853 (rtol 1e-13), same-run wall times (median of {rounds})")
    print(f"{'solver':<22}{'h or rtol':>11}{'error':>11}{'wall s':>10}{'DOP853/lgvi':>13}")
    for h in (0.02, 0.01, 0.005):
        steps = int(round(T / h))
        tr, w = timed(lambda: run(h, steps))
        e = err_of(np.concatenate([tr.x[-1].ravel(), tr.p[-1].ravel(), tr.R[-1, 0].ravel(), tr.R[-1, 1].ravel()]))
        # the loosest DOP853 tolerance that is at least as accurate
        for rtol in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
            sol = solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=rtol, atol=rtol)
            if err_of(sol.y[:, -1]) <= e:
                break
        sol, wd = timed(lambda: solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=rtol, atol=rtol))
        print(f"{'lgvi order2':<22}{h:>11.3g}{e:>11.2e}{w:>10.4f}{'':>13}")
        print(f"{'scipy DOP853':<22}{rtol:>11.0e}{err_of(sol.y[:, -1]):>11.2e}{wd:>10.4f}{wd / w:>13.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size (CI)")
    args = ap.parse_args()
    print("two-body benchmark (lgvi.simulate_two_body); the machine may be shared: compare ratios, not seconds")
    if args.quick:
        speed(20_000, 2)
        accuracy(6.0, 1)
    else:
        speed(1_000_000, 5)
        accuracy(60.0, 3)


if __name__ == "__main__":
    main()
