"""How often attitude-only inertia identification converges: 100 noise draws (issue 29, part 5).

Usage::

    python benchmarks/identify_draws.py                 # 100 draws, sigma 1e-3, all starts
    python benchmarks/identify_draws.py --draws 10 --jobs 2
    python benchmarks/identify_draws.py --quick         # 3 draws (a smoke run)

The problem is ``tests/test_optimal.py``'s synthetic one, attitudes only: a body with moments
1, 1.7, 2.4 turned off its axes, tumbling under a known sinusoidal torque, 101 attitudes over
10 s (``h = 0.05``, ``every = 2``), noise ``sigma_R`` per axis. Every draw starts from the
documented guess ``inertia0 = diag(1.2, 1.5, 2.2)``, ``R0 = R_meas[0]``, with the initial rate

* ``data``: ``omega0=None``, the short fit to the first seven attitudes, and the windows (the
  default of ``identify_inertia``);
* ``difference``: the rotation between the first two attitudes over their interval, one fit of
  the whole series (``windows=False``): the start the issue's 55-of-100 failures came from;
* ``zero``: ``omega0 = 0`` with the windows (a poor guess: does the continuation rescue it?).

A draw *succeeds* when the fit converges and each entry of ``J`` is within 5 of its standard
errors of the truth (a failure raises ``ConvergenceError``; its message and the best iterate's
error are counted). The table gives the successes, the failures whose message names ``omega0``,
and the median wall time per fit (the machine may be shared: the times are indicative; the
success counts do not depend on it).
"""

from __future__ import annotations

import argparse
import statistics
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

STARTS = ("data", "difference", "zero")


def draw(seed: int, sigma: float, M: int = 101, every: int = 2, h: float = 0.05):
    from lgvi import so3
    from lgvi.optimal import rollout

    Q = so3.exp([0.3, -0.4, 0.5])
    J_true = Q @ np.diag([1.0, 1.7, 2.4]) @ Q.T
    N = (M - 1) * every
    t = h * np.arange(N)
    U = np.stack([0.5 * np.sin(t), 0.4 * np.cos(0.7 * t), 0.3 * np.sin(1.3 * t + 1.0)], axis=1)
    run = rollout(J_true, so3.exp([0.2, 0.1, 0.3]), J_true @ np.array([0.8, -0.5, 0.9]), h, U)
    rng = np.random.default_rng(seed)
    R_meas = run.R[np.arange(M) * every] @ so3.exp(sigma * rng.normal(size=(M, 3)))
    return J_true, U, R_meas, h, every


def one(args: tuple[str, int, float]) -> tuple[str, bool, bool, float]:
    """``(start, success, failure naming omega0, seconds)`` of one draw."""
    from lgvi import so3
    from lgvi.errors import ConvergenceError
    from lgvi.optimal import identify_inertia
    from lgvi.optimal.identify import ENTRIES

    start, seed, sigma = args
    J_true, U, R_meas, h, every = draw(seed, sigma)
    kw = dict(h=h, R_meas=R_meas, sigma_R=sigma, every=every, u=U)
    if start == "data":
        kw.update(omega0=None)
    elif start == "difference":
        kw.update(omega0=so3.log(R_meas[0].T @ R_meas[1]) / (h * every), windows=False)
    else:
        kw.update(omega0=np.zeros(3))
    t0 = time.perf_counter()
    try:
        fit = identify_inertia(np.diag([1.2, 1.5, 2.2]), **kw)
    except ConvergenceError as exc:
        return start, False, "omega0 is the poor guess" in str(exc), time.perf_counter() - t0
    z = [abs(fit.inertia[i, j] - J_true[i, j]) / fit.standard_error[i, j] for i, j in ENTRIES]
    return start, max(z) < 5.0, False, time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=100)
    ap.add_argument("--sigma", type=float, default=1e-3)
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--starts", default=",".join(STARTS), help="comma-separated subset of " + ", ".join(STARTS))
    ap.add_argument("--quick", action="store_true", help="3 draws")
    args = ap.parse_args(argv)
    draws = 3 if args.quick else args.draws
    starts = [s for s in args.starts.split(",") if s]
    todo = [(s, seed, args.sigma) for seed in range(draws) for s in starts]
    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            out = list(pool.map(one, todo))
    else:
        out = [one(a) for a in todo]
    print(f"attitude-only identify_inertia, {draws} noise draws, sigma_R = {args.sigma:g}, 101 samples; success = "
          "converged with every entry within 5 standard errors")
    print(f"{'start':12s} {'success':>9s} {'failed':>7s} {'naming omega0':>14s} {'s per fit':>10s}")
    for s in starts:
        rows = [r for r in out if r[0] == s]
        ok = sum(r[1] for r in rows)
        failed = [r for r in rows if not r[1]]
        print(f"{s:12s} {ok:5d}/{len(rows):<3d} {len(failed):7d} {sum(r[2] for r in failed):14d} "
              f"{statistics.median(r[3] for r in rows):10.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
