"""Chain benchmark: the cost of a step of ``lgvi.simulate_chain`` against a rigid-body step, and
time to equal accuracy against SciPy's DOP853 on the same equations.

Usage::

    python benchmarks/bench_chain.py            # 1e6 steps per speed run, 7 rounds
    python benchmarks/bench_chain.py --quick    # reduced size, for CI (no timing assertions)

Case: three links of lengths (1, 0.5, 0.5) m and point masses (1, 1, 1) kg from a fixed pivot,
standard gravity, started tilted (0.5, 0.8 and 1.1 rad from the vertical) and moving (swinging
and turning about the vertical), a regular motion for the time of the accuracy table.

Table 1: CPU time per step (``time.process_time``, median of interleaved rounds, one core) of the
3-link chain at order 2 and 4, of the free rigid body (``lgvi.simulate``, J = diag(1, 2, 3), the
default solver) and of the heavy top (``torque=UniformGravity``); ratios to the free body
measured in the same run.

Table 2: the error of the link directions at ``T`` (max abs) against DOP853 at ``rtol = 1e-13``
(checked against ``rtol = 1e-12``), for lgvi at several steps (orders 2 and 4) and for DOP853 at
the loosest tolerance that is at least as accurate, with the CPU time of each and the ratio
DOP853 / lgvi. DOP853 integrates the same mechanics in R^3 with the constraints
(``lgvi.systems.chain.chain_equations``, NumPy, as a user of ``solve_ivp`` would write it).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

from scipy.integrate import solve_ivp  # noqa: E402

import lgvi  # noqa: E402
from lgvi.systems.chain import chain_equations, chain_parameters, velocities  # noqa: E402
from lgvi.systems.chain.model import G0  # noqa: E402

LENGTHS, MASSES = [1.0, 0.5, 0.5], [1.0, 1.0, 1.0]


def initial():
    th = np.array([0.5, 0.8, 1.1])
    ph = np.array([0.0, 0.7, 1.9])
    q0 = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)], axis=1)
    # turning about the vertical at 1.5 rad/s, plus a swing of the last link
    qd = np.cross([0.0, 0.0, 1.5], q0)
    qd[2] += 0.8 * np.cross(q0[2], [0.0, 1.0, 0.0])
    qd -= np.einsum("ij,ij->i", q0, qd)[:, None] * q0
    return q0, qd


Q0, QD0 = initial()
BODY = lgvi.RigidBody([1.0, 2.0, 3.0])


def cpu(fn):
    t = time.process_time()
    out = fn()
    return out, time.process_time() - t


def timed(fn, rounds):
    """``(result, median CPU seconds)`` of ``rounds`` calls of ``fn``."""
    ts, out = [], None
    for _ in range(rounds):
        out, t = cpu(fn)
        ts.append(t)
    return out, statistics.median(ts)


def step_table(cases, steps, rounds, width):
    """Print CPU ns a step of each ``cases[name](steps)`` (median of interleaved rounds, after a
    compiling call), its ratio to the first case and its mean Newton iterations."""
    for fn in cases.values():
        fn(10)                                   # compile (or load) outside the timing
    times = {k: [] for k in cases}
    its = {}
    for _ in range(rounds):
        for k, fn in cases.items():
            out, t = cpu(lambda: fn(steps))
            times[k].append(t)
            its[k] = float(np.mean(out.iterations))
    base = statistics.median(times[next(iter(cases))])
    print(f"{'case':<{width}}{'ns/step':>10}{'/rigid body':>13}{'iterations':>12}")
    for k in cases:
        t = statistics.median(times[k])
        print(f"{k:<{width}}{1e9 * t / steps:>10.0f}{t / base:>13.2f}{its[k]:>12.2f}")


def speed(steps, rounds):
    se = 1000 if steps % 1000 == 0 else steps
    gravity = lgvi.torques.UniformGravity(mass=1.0, com=[0.0, 0.0, 0.3])
    cases = {
        "rigid body (free)": lambda n: lgvi.simulate(BODY, np.eye(3), omega0=[0.3, 1.0, 0.2], h=1e-3, steps=n,
                                                     save_every=se if n == steps else 1),
        "heavy top (UniformGravity)": lambda n: lgvi.simulate(BODY, np.eye(3), omega0=[0.3, 1.0, 0.2], h=1e-3,
                                                              steps=n, torque=gravity,
                                                              save_every=se if n == steps else 1),
        "chain, 3 links, order 2": lambda n: lgvi.simulate_chain(LENGTHS, MASSES, Q0, QD0, h=1e-3, steps=n,
                                                                 save_every=se if n == steps else 1),
        "chain, 3 links, order 4": lambda n: lgvi.simulate_chain(LENGTHS, MASSES, Q0, QD0, h=1e-3, steps=n,
                                                                 order=4, save_every=se if n == steps else 1),
    }
    print(f"\nTable 1: CPU time per step, {steps} steps, median of {rounds} interleaved rounds (one core)")
    step_table(cases, steps, rounds, 30)


def accuracy(T, rounds):
    M, w = chain_parameters(LENGTHS, MASSES)
    f = chain_equations(M, w, [0.0, 0.0, -G0])
    y0 = np.concatenate([Q0.ravel(), QD0.ravel()])

    def dop(rtol):
        return solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=rtol, atol=rtol)

    ref = dop(1e-13).y[:9, -1]
    check = np.abs(dop(1e-12).y[:9, -1] - ref).max()

    def err(q):
        return float(np.abs(np.ravel(q) - ref).max())

    print(f"\nTable 2: error of q at T = {T:g} s against DOP853 (rtol 1e-13; its distance to rtol 1e-12: "
          f"{check:.1e}), CPU time, median of {rounds}")
    print(f"{'solver':<22}{'h or rtol':>11}{'error':>11}{'nfev':>8}{'CPU s':>10}{'DOP853/lgvi':>13}")
    for order, hs in ((2, (2e-3, 1e-3)), (4, (1e-2, 5e-3))):
        for h in hs:
            steps = int(round(T / h))
            lgvi.simulate_chain(LENGTHS, MASSES, Q0, QD0, h=h, steps=2, order=order)
            tr, t = timed(lambda: lgvi.simulate_chain(LENGTHS, MASSES, Q0, QD0, h=h, steps=steps, order=order,
                                                       save_every=steps), rounds)
            e = err(tr.q[-1])
            rtol = None
            for r in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
                if err(dop(r).y[:9, -1]) <= e:
                    rtol = r
                    break
            print(f"{f'lgvi order {order}':<22}{h:>11.3g}{e:>11.2e}{'':>8}{t:>10.4f}{'':>13}")
            if rtol is None:
                print(f"{'scipy DOP853':<22}{'none':>11} (no tolerance down to 1e-12 reaches this error)")
                continue
            sol, td = timed(lambda: dop(rtol), rounds)
            print(f"{'scipy DOP853':<22}{rtol:>11.0e}{err(sol.y[:9, -1]):>11.2e}{sol.nfev:>8}{td:>10.4f}"
                  f"{td / t:>13.1f}")


def check_velocities():
    """The start state of both solvers is the same (the chain's momenta give back QD0)."""
    M, _ = chain_parameters(LENGTHS, MASSES)
    tr = lgvi.simulate_chain(LENGTHS, MASSES, Q0, QD0, h=1e-3, steps=0)
    assert np.abs(velocities(M, tr.q[0], tr.pi[0]) - QD0).max() < 1e-13


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size (CI)")
    args = ap.parse_args()
    print("chain benchmark (lgvi.simulate_chain); the machine may be shared: compare ratios, not seconds")
    check_velocities()
    if args.quick:
        speed(20_000, 2)
        accuracy(1.0, 1)
    else:
        speed(1_000_000, 7)
        accuracy(10.0, 3)


if __name__ == "__main__":
    main()
