"""Ensemble throughput: body-steps per second of simulate_ensemble on 1 thread and on all cores.

Usage::

    python benchmarks/bench_ensemble.py            # full size: 4000 bodies x 2000 steps per run
    python benchmarks/bench_ensemble.py --quick    # reduced size, for CI (no timing assertions)

Case: the free body ``J = diag(1, 2, 3)``, rates ``(0.3, 1, 0.2) rad/s`` perturbed by 1 % and
attitudes by 2 degrees per body, ``h = 0.01``, ``tol = 1e-14``, saved sparsely
(``save_every = steps``: the first and last state of each body). Rows: the solver (``cayley``
runs bodies in SIMD lockstep groups, ``newton`` the per-body kernel), and the heavy top
(``UniformGravity``) at order 4 for the forced kernel (a step is one composed step of size
``h``, five solves), and the same top with the user's compiled gravity
(:class:`lgvi.torques.Compiled`, per-body ``params`` (B, 3), all rows equal: the same motion bit
for bit; its bodies go one compiled call each through :func:`lgvi.simulate`'s loop, split over a
pool of threads; not with ``--quick``: compiling the user's loop takes seconds); each on 1 thread
and on ``--threads`` (default: all of Numba's threads).

Every figure is the median of ``--repeat`` timed runs after an untimed warm-up (compilation
excluded), the configurations interleaved repeat by repeat so that changes in the machine's load
hit all of them alike; ratios are taken between numbers measured in this run. The column
"vs simulate" compares with :func:`lgvi.simulate` of one body for the same number of steps in
total (same solver, saved sparsely). The column "cores used" is the process's CPU time (all its
threads) over the wall time: with 2 threads it reaches 2.0 only when nothing else runs. On a
shared machine other processes take cores (Linux's autogroup scheduling gives each session a
fair share, so one busy process elsewhere leaves this one a single core), and the
multi-thread ratio drops with them; the load average before and after is printed too.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time

import numpy as np

import lgvi
from bench_torques import user_gravity, user_gravity_potential   # the user's compiled gravity (this folder)
from lgvi.torques import Compiled, UniformGravity

J = (1.0, 2.0, 3.0)
OMEGA0 = (0.3, 1.0, 0.2)
H = 0.01
TOP = lgvi.RigidBody([0.13, 0.28, 0.17])
GRAVITY = UniformGravity(1.0, [0.0, 0.0, 0.3])
USER = "heavy top, order 4, Compiled"


def user_top(bodies: int | None) -> Compiled:
    """The user's compiled gravity: params (bodies, 3), all rows GRAVITY's, or (3,) when ``bodies`` is None."""
    p = GRAVITY.mass * GRAVITY.g * GRAVITY.com
    return Compiled(user_gravity, potential=user_gravity_potential,
                    params=p if bodies is None else np.tile(p, (bodies, 1)))


def initial(bodies: int, top: bool = False) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    R0 = lgvi.so3.exp(np.deg2rad(2.0) * rng.normal(size=(bodies, 3)))
    w = np.array([4.14, 4.14, 4.14]) if top else np.array(OMEGA0)
    return R0, w * (1.0 + 0.01 * rng.normal(size=(bodies, 3)))


def machine_busy() -> float | None:
    """CPU seconds all processes of the machine have spent so far (Linux ``/proc/stat``), or None."""
    try:
        with open("/proc/stat") as fh:
            ticks = [int(x) for x in fh.readline().split()[1:]]
        return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")   # all but idle and iowait
    except (OSError, ValueError, IndexError):
        return None


def main(argv: list[str] | None = None) -> int:
    import numba

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced size for CI: 256 bodies x 200 steps")
    parser.add_argument("--bodies", type=int, default=4000, help="bodies per run (default 4000)")
    parser.add_argument("--steps", type=int, default=2000, help="steps per run (default 2000)")
    parser.add_argument("--repeat", type=int, default=7, help="timed runs per configuration (default 7)")
    parser.add_argument("--threads", type=int, default=numba.config.NUMBA_NUM_THREADS,
                        help=f"threads of the parallel rows (default {numba.config.NUMBA_NUM_THREADS})")
    args = parser.parse_args(argv)
    B, steps, repeat = (256, 200, 3) if args.quick else (args.bodies, args.steps, args.repeat)
    threads = sorted({1, max(1, args.threads)})
    load0 = os.getloadavg()

    body = lgvi.RigidBody(J)
    R0, w0 = initial(B)
    R0_top, w0_top = initial(B, top=True)
    top_steps = max(1, steps // 5)
    cases = {
        "free body, cayley": (dict(bodies=body, R0=R0, omega0=w0, method="cayley"), steps),
        "free body, newton": (dict(bodies=body, R0=R0, omega0=w0, method="newton"), steps),
        "heavy top, order 4": (dict(bodies=TOP, R0=R0_top, omega0=w0_top, torque=GRAVITY, order=4), top_steps),
    }
    if not args.quick:
        cases[USER] = (dict(bodies=TOP, R0=R0_top, omega0=w0_top, torque=user_top(B), order=4), top_steps)

    others: list[float] = []

    def timed(fn) -> tuple[float, float]:
        """Wall time and the cores the process used meanwhile (CPU time of all its threads / wall);
        the cores the rest of the machine used meanwhile go to ``others``."""
        m0 = machine_busy()
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        t0 = time.perf_counter()
        fn()
        wall = time.perf_counter() - t0
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        m1 = machine_busy()
        mine = (r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime) / wall
        if m0 is not None and m1 is not None:
            others.append(max(0.0, (m1 - m0) / wall - mine))
        return wall, mine

    def ensemble_run(case: str, n_threads: int) -> tuple[float, float]:
        kw, n = cases[case]
        kw = dict(kw)
        return timed(lambda: lgvi.simulate_ensemble(kw.pop("bodies"), kw.pop("R0"), omega0=kw.pop("omega0"), h=H,
                                                    steps=n, save_every=n, threads=n_threads, **kw))

    def single_run(case: str) -> tuple[float, float]:
        kw, n = cases[case]
        total = B * n
        extra = {k: v for k, v in kw.items() if k not in ("bodies", "R0", "omega0")}
        if case == USER:
            extra["torque"] = user_top(None)
        return timed(lambda: lgvi.simulate(kw["bodies"], kw["R0"][0], omega0=kw["omega0"][0], h=H, steps=total,
                                           save_every=total, **extra))

    configs = [(c, th) for c in cases for th in threads] + [(c, "simulate") for c in cases]
    for c, th in configs:                                  # warm-up: compile or load every kernel
        kw, _ = cases[c]
        small = dict(kw, R0=kw["R0"][:16], omega0=kw["omega0"][:16])
        if c == USER:
            small["torque"] = user_top(None if th == "simulate" else 16)
        extra = {k: v for k, v in small.items() if k not in ("bodies", "R0", "omega0")}
        if th == "simulate":
            lgvi.simulate(small["bodies"], small["R0"][0], omega0=small["omega0"][0], h=H, steps=10, **extra)
        else:
            lgvi.simulate_ensemble(small["bodies"], small["R0"], omega0=small["omega0"], h=H, steps=10,
                                   threads=th, **extra)
    times: dict[tuple[str, object], list[tuple[float, float]]] = {cfg: [] for cfg in configs}
    for _ in range(repeat):
        for c, th in configs:
            times[(c, th)].append(single_run(c) if th == "simulate" else ensemble_run(c, th))
    load1 = os.getloadavg()

    def rate(c: str, th: object) -> float:
        return B * cases[c][1] / statistics.median(w for w, _ in times[(c, th)])

    def cores(c: str, th: object) -> float:
        return statistics.median(u for _, u in times[(c, th)])

    print(f"ensemble throughput: {B} bodies x {steps} steps (heavy top {top_steps}), h = {H}, saved sparsely, "
          f"median of {repeat}")
    print(f"machine: {os.cpu_count()} cores, Numba threading layer {numba.threading_layer()}, "
          f"load average {load0[0]:.2f} before, {load1[0]:.2f} after (1 min)")
    many = threads[-1]
    head = (f"{'case':<39} {'threads':>7} {'body-steps/s':>13} {'us/body-step':>12} "
            f"{f'{many} threads / 1':>16} {'vs simulate':>11} {'cores used':>10}")
    print(head)
    print("-" * len(head))
    for c in cases:
        single = rate(c, "simulate")
        for th in threads:
            r = rate(c, th)
            scale = f"{r / rate(c, 1):.2f}x" if th != 1 else ""
            print(f"{c:<39} {th:>7} {r:>13.3g} {1e6 / r:>12.4f} {scale:>16} {r / single:>10.2f}x "
                  f"{cores(c, th):>10.2f}")
        print(f"{c + ' (simulate)':<39} {1:>7} {single:>13.3g} {1e6 / single:>12.4f} {'':>16} {'1.00x':>11} "
              f"{cores(c, 'simulate'):>10.2f}")
    best = rate("free body, cayley", many)
    scaling = best / rate("free body, cayley", 1)
    if USER in cases:
        user = statistics.median(a / b for (a, _), (b, _) in zip(times[(USER, many)], times[(USER, 1)]))
        print(f"{USER}: {many} threads / 1 = {1 / user:.2f}x (median of the per-repeat ratios); vs the built-in "
              f"UniformGravity row on {many} threads: {rate(USER, many) / rate('heavy top, order 4', many):.2f}x")
    print(f"targets: {many} threads / 1 >= 1.8x on 2 cores (cayley: {scaling:.2f}x); >= 2e7 body-steps/s in "
          f"total for the free body (cayley: {best:.3g}, {best / 2e7:.2f} of it)")
    print("'cores used' is the CPU time of all the process's threads over the wall time: below the thread count, "
          "other processes held the cores (compare the scaling with it)")
    if others:
        print(f"other processes on the machine used {statistics.median(others):.2f} cores (median over the runs, "
              "from /proc/stat)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
