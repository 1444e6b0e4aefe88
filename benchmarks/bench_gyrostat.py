"""Gyrostat benchmark: cost per step with 3 and 4 reaction wheels against the free body, same run.

Usage::

    python benchmarks/bench_gyrostat.py            # 5e5 steps per run, 7 rounds
    python benchmarks/bench_gyrostat.py --quick    # reduced size (no timing assertions anywhere)

Every case runs the same body (``J = diag(1, 2, 3)``, ``omega0 = (0.3, 1.0, 0.2)`` rad/s) with
``h = 0.01`` on one core, ``save_every = 100``. The cases are interleaved round by round and each
ratio is taken within a round (then the median over rounds), so the load of a shared machine
affects both sides alike; times are the CPU time of the process (one thread), which other jobs
disturb less than the wall clock. Cases: the free body (``lgvi.simulate`` without wheels), 3 wheels on
the body axes and 4 wheels (a pyramid) with the motors off, 4 wheels with friction and limits,
and 3 wheels driven by the compiled ``MRPFeedback`` every 0.1 s, by the same law called from
Python every 0.1 s (the per-call cost of a Python controller) and by an empty Python controller
(the cost per control period of returning to Python: one compiled chunk per call).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import lgvi  # noqa: E402
from lgvi.control import Command, Controller, MRPFeedback  # noqa: E402

BODY = lgvi.RigidBody([1.0, 2.0, 3.0])
W0 = np.array([0.3, 1.0, 0.2])
H = 0.01
AX3 = np.eye(3)
_b = 1.0 / np.sqrt(3.0)
AX4 = np.array([[_b, _b, _b], [-_b, _b, _b], [-_b, -_b, _b], [_b, -_b, _b]])


class PythonMRP(MRPFeedback):
    """The same law called from Python (a subclass is not compiled)."""


class Hold(Controller):
    """A Python controller that does nothing but return a held command: the loop's own cost per call."""

    def command(self, t, R, omega, wheel_speed, env):
        return Command(wheel_torque=np.zeros(len(wheel_speed)))


def cases():
    w3 = lgvi.ReactionWheels(AX3, 0.02, speed0=[10.0, -5.0, 3.0])
    w4 = lgvi.ReactionWheels(AX4, 0.02, speed0=[10.0, -5.0, 3.0, 7.0])
    w4f = lgvi.ReactionWheels(AX4, 0.02, speed0=[10.0, -5.0, 3.0, 7.0], max_torque=0.1, max_speed=300.0,
                              friction={"coulomb": 1e-4, "viscous": 1e-5})
    ref = lgvi.so3.exp([0.2, 0.1, 0.0])
    return {
        "free body": {},
        "3 wheels, motors off": {"wheels": w3},
        "4 wheels, motors off": {"wheels": w4},
        "4 wheels, friction + limits": {"wheels": w4f},
        "3 wheels, MRPFeedback compiled @0.1 s": {"wheels": w3, "controller": MRPFeedback(0.5, 2.0, target=ref),
                                                  "control_period": 0.1},
        "3 wheels, MRPFeedback Python @0.1 s": {"wheels": w3, "controller": PythonMRP(0.5, 2.0, target=ref),
                                                "control_period": 0.1},
        "3 wheels, empty Python controller @0.1 s": {"wheels": w3, "controller": Hold(), "control_period": 0.1},
    }


def run(kw, steps):
    t0 = time.process_time()
    traj = lgvi.simulate(BODY, np.eye(3), omega0=W0, h=H, steps=steps, save_every=100, **kw)
    return time.process_time() - t0, traj.solver_summary["iterations_mean"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--rounds", type=int, default=7, help="rounds (each runs every case once)")
    args = ap.parse_args(argv)
    steps, rounds = (20_000, 2) if args.quick else (500_000, args.rounds)
    cs = cases()
    for kw in cs.values():            # compile / load the kernels
        run(kw, 1000)
    times = {name: [] for name in cs}
    iters = {}
    for _ in range(rounds):
        for name, kw in cs.items():
            dt, it = run(kw, steps)
            times[name].append(dt)
            iters[name] = it
    print(f"gyrostat step vs free body: {steps} steps, h = {H}, median of {rounds} rounds "
          "(CPU time of this single-threaded process: the machine is shared with other jobs)")
    print(f"{'case':40} {'ns/step':>9} {'ratio':>7} {'iters/step':>11}")
    free = times["free body"]
    for name in cs:
        ratio = statistics.median(a / b for a, b in zip(times[name], free))
        ns = statistics.median(times[name]) / steps * 1e9
        print(f"{name:40} {ns:9.1f} {ratio:7.2f} {iters[name]:11.3f}")
    py = statistics.median(times["3 wheels, MRPFeedback Python @0.1 s"])
    cc = statistics.median(times["3 wheels, MRPFeedback compiled @0.1 s"])
    calls = steps * H / 0.1
    empty = statistics.median(times["3 wheels, empty Python controller @0.1 s"])
    base = statistics.median(times["3 wheels, motors off"])
    print(f"Python controller: {(py - cc) / calls * 1e6:.1f} us per call over the compiled law ({calls:.0f} calls); "
          f"the loop's own cost (an empty controller, a compiled chunk per call): "
          f"{(empty - base) / calls * 1e6:.1f} us per call")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
