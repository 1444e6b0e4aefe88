"""Slosh benchmark: the cost of a step of ``lgvi.simulate_slosh`` (a rigid hub with spherical
pendulums) against a rigid-body step, and time to equal accuracy against SciPy's DOP853.

Usage::

    python benchmarks/bench_slosh.py            # 2e5 steps per speed run, 7 rounds
    python benchmarks/bench_slosh.py --quick    # reduced size, for CI (no timing assertions)

Case: the hub of ``tests/test_slosh.py`` (1500 kg, inertia diag(900, 800, 600) kg m^2, spinning at
(0.3, -0.2, 0.5) rad/s) with one, two or three pendulums (0.3 to 0.5 m, 40 to 60 kg) started
moving relative to it; "damped": the two-pendulum case with damping (30, 50) N s/m.

Table 1: CPU time per step (``time.process_time``, median of interleaved rounds, one core) of the
hub with 1, 2, 3 pendulums at order 2, damped, and at order 4, and of the free rigid body
(``lgvi.simulate`` of the same hub alone, the default solver); ratios to the free body measured in
the same run, and the mean Newton iterations per step.

Table 2: the error at ``T`` (the largest of the hub's attitude error angle and of the pendulum
direction errors) against DOP853 at ``rtol = 1e-13`` (checked against ``1e-12``), for lgvi at
several steps (orders 2 and 4, two pendulums, damped) and for DOP853 at the loosest tolerance
that is at least as accurate, with the CPU time of each and the ratio DOP853 / lgvi. DOP853
integrates the same mechanics in maximal coordinates (``lgvi.systems.slosh.newton_euler``: NumPy,
one dense solve per call, as a user of ``solve_ivp`` would write it).
"""

from __future__ import annotations

import argparse
import os

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

from bench_chain import step_table, timed  # noqa: E402  (the chain benchmark's timers)
from scipy.integrate import solve_ivp  # noqa: E402

import lgvi  # noqa: E402
from lgvi.systems.slosh import newton_euler, newton_euler_split, newton_euler_state, slosh_parameters  # noqa: E402

J = [900.0, 800.0, 600.0]
M0 = 1500.0
W0 = np.array([0.3, -0.2, 0.5])
PIV = np.array([[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1], [0.1, -0.5, 0.3]])
LEN = np.array([0.3, 0.4, 0.5])
MASS = np.array([40.0, 60.0, 50.0])
Q0 = np.array([[0.0, 0.0, -1.0], [0.6, 0.0, -0.8], [0.0, 0.8, -0.6]])
QD0 = np.array([[0.5, 0.2, 0.0], [0.0, 1.0, 0.0], [0.7, 0.0, 0.0]])
DAMP = np.array([30.0, 50.0, 40.0])
BODY = lgvi.RigidBody(J)


def slosh(n, h, steps, **kw):
    return lgvi.simulate_slosh(BODY, M0, PIV[:n], LEN[:n], MASS[:n], np.eye(3), Q0[:n], QD0[:n], omega0=W0, h=h,
                               steps=steps, **kw)


def speed(steps, rounds):
    se = 1000 if steps % 1000 == 0 else steps
    h = 0.01
    cases = {
        "rigid body (free)": lambda n: lgvi.simulate(BODY, np.eye(3), omega0=W0, h=h, steps=n,
                                                     save_every=se if n == steps else 1),
        "1 pendulum, order 2": lambda n: slosh(1, h, n, save_every=se if n == steps else 1),
        "2 pendulums, order 2": lambda n: slosh(2, h, n, save_every=se if n == steps else 1),
        "3 pendulums, order 2": lambda n: slosh(3, h, n, save_every=se if n == steps else 1),
        "2 pendulums, damped": lambda n: slosh(2, h, n, damping=DAMP[:2], save_every=se if n == steps else 1),
        "2 pendulums, order 4": lambda n: slosh(2, h, n, order=4, save_every=se if n == steps else 1),
    }
    print(f"\nTable 1: CPU time per step, {steps} steps of {h:g} s, median of {rounds} interleaved rounds (one core)")
    step_table(cases, steps, rounds, 26)


def angle(Ra, Rb):
    D = Ra.T @ Rb
    return float(np.arcsin(min(1.0, 0.5 * np.linalg.norm([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]]))))


def accuracy(T, rounds):
    n = 2
    P = slosh_parameters(np.diag(J), M0, PIV[:n], LEN[:n], MASS[:n])
    f = newton_euler(P, DAMP[:n])
    y0 = newton_euler_state(P, np.eye(3), W0, Q0[:n], QD0[:n])

    def dop(rtol):
        return solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=rtol, atol=rtol)

    Rr, qr = newton_euler_split(P, dop(1e-13).y[:, -1])

    def err(R, q):
        return max(angle(R, Rr), float(np.abs(q - qr).max()))

    check = err(*newton_euler_split(P, dop(1e-12).y[:, -1]))

    print(f"\nTable 2: error at T = {T:g} s (2 pendulums, damped) against DOP853 (rtol 1e-13; its distance to "
          f"rtol 1e-12: {check:.1e}), CPU time, median of {rounds}")
    print(f"{'solver':<22}{'h or rtol':>11}{'error':>11}{'nfev':>8}{'CPU s':>10}{'DOP853/lgvi':>13}")
    for order, hs in ((2, (0.01, 0.005)), (4, (0.04, 0.02))):
        for h in hs:
            steps = int(round(T / h))
            slosh(n, h, 2, order=order, damping=DAMP[:n])
            tr, t = timed(lambda: slosh(n, h, steps, order=order, damping=DAMP[:n], save_every=steps), rounds)
            e = err(tr.R[-1], tr.q[-1])
            rtol = None
            for r in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
                if err(*newton_euler_split(P, dop(r).y[:, -1])) <= e:
                    rtol = r
                    break
            print(f"{f'lgvi order {order}':<22}{h:>11.3g}{e:>11.2e}{'':>8}{t:>10.4f}{'':>13}")
            if rtol is None:
                print(f"{'scipy DOP853':<22}{'none':>11} (no tolerance down to 1e-12 reaches this error)")
                continue
            sol, td = timed(lambda: dop(rtol), rounds)
            print(f"{'scipy DOP853':<22}{rtol:>11.0e}{err(*newton_euler_split(P, sol.y[:, -1])):>11.2e}"
                  f"{sol.nfev:>8}{td:>10.4f}{td / t:>13.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size (CI)")
    args = ap.parse_args()
    print("slosh benchmark (lgvi.simulate_slosh); the machine may be shared: compare ratios, not seconds")
    if args.quick:
        speed(2_000, 2)
        accuracy(1.0, 1)
    else:
        speed(200_000, 7)
        accuracy(10.0, 3)


if __name__ == "__main__":
    main()
