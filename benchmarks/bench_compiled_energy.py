"""Evaluating a :class:`lgvi.torques.Compiled` model over a trajectory's samples.

Usage::

    python benchmarks/bench_compiled_energy.py            # 1e3, 1e5, 1e6 samples, 5 rounds
    python benchmarks/bench_compiled_energy.py --quick    # reduced size, for CI (no timing assertions)

``Compiled.moment`` / ``Compiled.potential`` (what :attr:`lgvi.Trajectory.energy`, the plots and
the summaries call for every saved sample) evaluate the user's ``numba.njit`` functions either
with one call from Python per sample (``python``: ``series_min`` set above the sample count, the
evaluation before issue 11 part 5) or in one compiled loop over the samples (``compiled``:
``user_kernels.user_moment_series`` / ``user_potential_series``). The two are interleaved round
by round, the ratio is taken within a round, medians over rounds are printed. The compiled
loop is compiled in memory per user function on first use: that first-call cost is printed
separately (first call minus the median of later calls at the same size), with the per-sample
cost of the Python loop, whose quotient is the break-even sample count for a one-off evaluation
(``Compiled.series_compile``: below it the loop is used only once compiled). The small sizes
(16 to 256 samples) locate ``Compiled.series_min`` (below it, always the Python calls).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numba  # noqa: E402

from lgvi.torques import Compiled  # noqa: E402


@numba.njit
def gravity_moment(t, R, Pi, p):
    s0 = R[2, 0]
    s1 = R[2, 1]
    s2 = R[2, 2]
    return (s1 * p[2] - s2 * p[1], s2 * p[0] - s0 * p[2], s0 * p[1] - s1 * p[0])


@numba.njit
def gravity_potential(t, R, p):
    return R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2]


def samples(n, seed=0):
    """``n`` rotations (QR of Gaussian matrices), momenta and times."""
    rng = np.random.default_rng(seed)
    q, r = np.linalg.qr(rng.standard_normal((n, 3, 3)))
    R = q * np.sign(np.diagonal(r, axis1=1, axis2=2))[:, None, :]
    R *= np.sign(np.linalg.det(R))[:, None, None]
    return np.linspace(0.0, 1.0, n), R, rng.standard_normal((n, 3))


def timed(f):
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, 2 rounds")
    args = ap.parse_args()
    sizes = [16, 64, 256, 1000, 10000] if args.quick else [16, 64, 256, 1000, 100_000, 1_000_000]
    rounds = 2 if args.quick else 5
    model = Compiled(gravity_moment, potential=gravity_potential, params=[0.3, -0.2, 2.9])
    model.series_compile = 0                  # compiled side: always the series loop (compiled on first call)
    compiled = Compiled.series_min
    t, R, Pi = samples(1000)

    # first calls (compile of the series loops for these functions), then per-sample Python cost
    first_u = timed(lambda: model.potential(t, R, None))
    first_m = timed(lambda: model.moment(t, R, Pi, None))
    later_u = statistics.median(timed(lambda: model.potential(t, R, None)) for _ in range(5))
    later_m = statistics.median(timed(lambda: model.moment(t, R, Pi, None)) for _ in range(5))
    model.series_min = 1 << 62
    per_u = statistics.median(timed(lambda: model.potential(t, R, None)) for _ in range(5)) / len(t)
    per_m = statistics.median(timed(lambda: model.moment(t, R, Pi, None)) for _ in range(5)) / len(t)
    print(f"first call (compile) at {len(t)} samples: potential {first_u - later_u:.3f} s, "
          f"moment {first_m - later_m:.3f} s")
    print(f"python loop per sample: potential {per_u * 1e6:.2f} us, moment {per_m * 1e6:.2f} us; "
          f"break-even for a one-off call: {(first_u - later_u) / per_u:.0f} / "
          f"{(first_m - later_m) / per_m:.0f} samples")

    print(f"\n{'samples':>9} {'what':>9} {'python s':>10} {'compiled s':>11} {'ratio':>8}")
    for n in sizes:
        t, R, Pi = samples(n)
        for what, call in (("potential", lambda: model.potential(t, R, None)),
                           ("moment", lambda: model.moment(t, R, Pi, None))):
            py, co, ratio = [], [], []
            for _ in range(rounds):
                model.series_min = 1 << 62
                a = timed(call)
                model.series_min = compiled
                c = timed(call)
                py.append(a)
                co.append(c)
                ratio.append(a / c)
            print(f"{n:>9} {what:>9} {statistics.median(py):>10.6f} {statistics.median(co):>11.6f} "
                  f"{statistics.median(ratio):>7.1f}x")
        model.series_min = compiled
    print(f"\n(load: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()
