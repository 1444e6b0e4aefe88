"""Monte Carlo of a system with ``lgvi.simulate_members``: members per second on threads and
against a plain loop of ``lgvi.simulate_orbit``.

Usage::

    python benchmarks/bench_members.py            # 8 members of 1 000 000 steps, 5 rounds
    python benchmarks/bench_members.py --quick    # reduced size, for CI (no timing assertions)

Case: a body in low Earth orbit (``docs/orbit.md``), the members differing in their initial spin.
Each round runs the loop, ``threads=1`` and ``threads=2`` one after the other (interleaved); the
table prints the median wall time of each and its ratio to the loop, measured in the same run.
Every member of every run is checked bit for bit against the loop's.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import lgvi


def members(n: int, steps: int) -> list[dict]:
    rng = np.random.default_rng(0)
    return [dict(body=[1.0, 2.0, 3.0], mass=10.0, x0=[7000.0, 0.0, 0.0], v0=[0.0, 7.546, 0.0], R0=np.eye(3),
                 omega0=1e-3 * rng.standard_normal(3), h=1.0, steps=steps, mu=398600.4418, save_every=steps // 10)
            for _ in range(n)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size (CI)")
    a = ap.parse_args()
    n, steps, rounds = (4, 2_000, 2) if a.quick else (8, 1_000_000, 5)
    ms = members(n, steps)
    ref = [lgvi.simulate_orbit(**m) for m in ms]               # compiles (or loads) the kernels
    runs = {"loop of simulate_orbit": lambda: [lgvi.simulate_orbit(**m) for m in ms],
            "simulate_members, threads=1": lambda: lgvi.simulate_members("orbit", ms, threads=1).members,
            "simulate_members, threads=2": lambda: lgvi.simulate_members("orbit", ms, threads=2).members}
    times: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(rounds):
        for name, fn in runs.items():
            t = time.perf_counter()
            out = fn()
            times[name].append(time.perf_counter() - t)
            assert all(np.array_equal(o.x, r.x) and np.array_equal(o.R, r.R) for o, r in zip(out, ref)), name
    print(f"orbit members: {n} x {steps} steps, median of {rounds} interleaved rounds, "
          f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}")
    print(f"{'run':<30} {'wall s':>9} {'members/s':>10} {'loop/this':>10}")
    base = statistics.median(times["loop of simulate_orbit"])
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{name:<30} {med:9.3f} {n / med:10.2f} {base / med:10.2f}")


if __name__ == "__main__":
    main()
