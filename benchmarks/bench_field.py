"""Geomagnetic field benchmark: cost of one IGRF-14 degree-13 evaluation (issue 12, part 6).

Usage::

    python benchmarks/bench_field.py            # 2e5 points per round, 7 rounds
    python benchmarks/bench_field.py --quick    # reduced size, for CI (no timing assertions)

Rows (per point, median over rounds, all rows interleaved round by round on one core):

* ``compiled, batch``: the compiled kernel over a (K, 3) array of Earth-fixed points
  (``lgvi._kernels.field_kernels.sh_field_many``), what a compiled loop pays per evaluation;
* ``compiled, one call``: ``IGRF.ecef_one`` from Python, one point per call (a controller's call);
* ``ecef(r, year)``: the validated NumPy front end, one point per call;
* ``centred dipole, batch``: the degree-1 kernel, for scale;
* ``ppigrf``: the pure-NumPy ``ppigrf.igrf_gc``, one point per call (if installed).

The ratio column is each row's time over ``compiled, batch`` in the same round. Times are CPU time
(``time.process_time``, one thread): on a shared machine wall clock counts the other jobs too.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

from lgvi._kernels.field_kernels import sh_field_many  # noqa: E402
from lgvi.environment import IGRF, CentredDipole  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    K = 2000 if args.quick else 200_000
    calls = 200 if args.quick else 5000
    rounds = 3 if args.quick else 7
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(K, 3))
    pts *= (rng.uniform(6.6e6, 7.5e6, K) / np.linalg.norm(pts, axis=1))[:, None]
    year = 2026.4
    igrf = IGRF()
    dip = CentredDipole.from_model(igrf, year)
    try:
        import ppigrf
    except ImportError:
        ppigrf = None

    def batch(model):
        g, h, P, dP, Q = model._at(year)
        out = np.empty_like(pts)

        def run():
            t0 = time.process_time()
            sh_field_many(pts, g, h, model.degree, model.radius, P, dP, Q, model._constants, out)
            return (time.process_time() - t0) / K
        return run

    def one_call():
        t0 = time.process_time()
        for x, y, z in pts[:calls]:
            igrf.ecef_one(x, y, z, year)
        return (time.process_time() - t0) / calls

    def front():
        t0 = time.process_time()
        for p in pts[:calls // 5]:
            igrf.ecef(p, year)
        return (time.process_time() - t0) / (calls // 5)

    d = dt.datetime(2026, 5, 27)

    def pp():
        n = max(calls // 50, 5)
        t0 = time.process_time()
        for p in pts[:n]:
            r = np.linalg.norm(p)
            ppigrf.igrf_gc(r / 1e3, np.degrees(np.arccos(p[2] / r)), np.degrees(np.arctan2(p[1], p[0])), d)
        return (time.process_time() - t0) / n

    rows = {"IGRF-14 n=13, compiled, batch": batch(igrf), "IGRF-14 n=13, compiled, one call": one_call,
            "IGRF-14 n=13, ecef(r, year)": front, "centred dipole n=1, compiled, batch": batch(dip)}
    if ppigrf is not None:
        rows["ppigrf.igrf_gc n=13, one call"] = pp
    for f in rows.values():        # warm-up (compilation)
        f()
    times = {k: [] for k in rows}
    ratios = {k: [] for k in rows}
    base = "IGRF-14 n=13, compiled, batch"
    for _ in range(rounds):
        this = {k: f() for k, f in rows.items()}
        for k in rows:
            times[k].append(this[k])
            ratios[k].append(this[k] / this[base])
    print(f"field evaluation, {K} points per batch, {rounds} rounds (medians; ratio to the compiled batch, "
          f"same round)")
    print(f"{'case':40s} {'us/point':>10s} {'ratio':>9s}")
    for k in rows:
        print(f"{k:40s} {statistics.median(times[k]) * 1e6:10.3f} {statistics.median(ratios[k]):9.2f}")


if __name__ == "__main__":
    main()
