"""The error estimate (``simulate(..., error_estimate=True)``) on a tumbling CubeSat: its accuracy and cost.

Usage::

    python benchmarks/error_estimate.py            # one day (about 2 minutes, most of it the references)
    python benchmarks/error_estimate.py --quick    # 2880 s, for CI (no assertions)

Problem (issue 10): a 3U CubeSat, ``J = diag(0.0433, 0.0418, 0.0067)`` kg m^2, tumbling with
``omega0 = (0.08, -0.06, 0.09)`` rad/s from ``R0 = I`` under gravity gradient on a circular orbit of
radius 6878.137 km (``mu = 3.986004418e14``), for ``T = 86400`` s.

The true final attitude error ``|log(R_ref^T R(T))|`` is taken against order 6 at ``h = 0.01``,
checked against order 4 at ``h = 0.005`` (their disagreement is printed and must be far below the
errors in the table). For each configuration the table gives the true error, the estimate, their
ratio, and the wall time of the run alone and with the estimate (the best of ``--repeat`` runs of
each, measured in the same process after a warm-up, so the ratio is meaningful on a shared machine).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import lgvi
from lgvi.accuracy import geodesic_distance
from lgvi.torques import GravityGradient

J = np.diag([0.0433, 0.0418, 0.0067])
OMEGA0 = np.array([0.08, -0.06, 0.09])
GG = GravityGradient(3.986004418e14, 6878.137e3)
CONFIGS = [(2, 0.1), (2, 0.05), (2, 0.018), (4, 0.2), (4, 0.1), (6, 0.2)]


def run(T: float, h: float, order: int, **kw):
    n = int(round(T / h))
    if abs(n * h - T) > 1e-9 * T:  # compare at the same final time
        raise SystemExit(f"h = {h:g} does not divide T = {T:g}")
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", lgvi.AccuracyWarning)
        traj = lgvi.simulate(J, np.eye(3), omega0=OMEGA0, h=h, steps=n, save_every=n, torque=GG, order=order, **kw)
    return traj, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="T = 2880 s and coarser references")
    ap.add_argument("--repeat", type=int, default=3, help="runs per timing (best is reported)")
    args = ap.parse_args()
    T, (h6, h4) = (2880.0, (0.02, 0.01)) if args.quick else (86400.0, (0.01, 0.005))
    for order, h in CONFIGS:  # load or compile the kernels
        run(h * 30, h, order, error_estimate=True)
    t0 = time.perf_counter()
    ref, _ = run(T, h6, 6)
    check, _ = run(T, h4, 4)
    print(f"CubeSat under gravity gradient, T = {T:g} s; reference order 6 h = {h6:g} against order 4 "
          f"h = {h4:g}: {geodesic_distance(ref.R[-1], check.R[-1]):.2e} rad apart ({time.perf_counter() - t0:.0f} s)")
    print()
    print(f"{'order':>5} {'h':>7} {'true error rad':>14} {'deg':>9} {'estimate rad':>12} {'est/true':>8} "
          f"{'wall s':>8} {'with est s':>10} {'with/without':>12}")
    for order, h in CONFIGS:
        plain = [run(T, h, order) for _ in range(args.repeat)]
        est = [run(T, h, order, error_estimate=True) for _ in range(args.repeat)]
        traj, w0 = plain[0][0], min(w for _, w in plain)
        e = est[0][0].error_estimate
        w1 = min(w for _, w in est)
        true = float(geodesic_distance(traj.R[-1], ref.R[-1]))
        print(f"{order:>5} {h:>7g} {true:>14.3e} {np.degrees(true):>9.3g} {e.attitude:>12.3e} "
              f"{e.attitude / true:>8.3f} {w0:>8.3f} {w1:>10.3f} {w1 / w0:>12.2f}")
    print()
    print("  estimate: Richardson, 2^p/(2^p-1) |log(R_h^T R_h/2)| from a shadow run at h/2 (lgvi.accuracy);")
    print("  wall: best of", args.repeat, "runs, warm; 'with est' includes the shadow run (twice the steps).")


if __name__ == "__main__":
    main()
