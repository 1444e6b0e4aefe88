"""Cost of a step of ``scheme="splitting"`` on issue 13's CubeSat: per step and per exact free flow.

Usage::

    python benchmarks/splitting_flow_cost.py                            # the lgvi this Python imports
    python benchmarks/splitting_flow_cost.py --compare OLD/src NEW/src  # two source trees, alternated
    python benchmarks/splitting_flow_cost.py --quick                    # a smoke run (tests/test_benchmarks.py)

Each case is one ``lgvi.simulate`` run of the one-day CubeSat (J = diag(0.0433, 0.0418, 0.0067),
omega0 = (0.08, -0.06, 0.09) rad/s, ``save_every = steps``) timed in a child process after a warm-up
call (kernels compiled or loaded from the cache first): the median of ``--repeat`` runs of the CPU
time (``time.process_time``, less sensitive to other jobs than the wall time, which is printed too),
divided by the steps and by the flows (a flow and its kick). The case without a torque is the flows
alone (the kick adds a zero moment). With ``--compare`` the two trees run in alternating child
processes (``--rounds`` each, the median of their medians), so both see the same machine load.
"""

from __future__ import annotations

import argparse
import os
import statistics

from _trees import run_child  # benchmarks/_trees.py (the script's folder is on the path)

#: case -> (composition, order, h, steps, torque?)
CASES: dict[str, tuple[str, int, float, int, bool]] = {
    "saba4 h=24 s, gravity gradient": ("saba4", 2, 24.0, 3600, True),
    "saba4 h=24 s, no torque": ("saba4", 2, 24.0, 3600, False),
    "aba84 h=10.6 s, gravity gradient": ("aba84", 4, 10.6, 8151, True),
}

CHILD = """
import json, time

import numpy as np
import lgvi
from lgvi.registry import SPLITTINGS
from lgvi.torques import GravityGradient
body = lgvi.RigidBody([0.0433, 0.0418, 0.0067])
gg = GravityGradient(3.986004418e14, 6878.137e3)
cases = {cases!r}
out = {{}}
for name, (comp, order, h, steps, torque) in cases.items():
    steps = max(10, int(steps * {scale}))
    def run():
        return lgvi.simulate(body, np.eye(3), omega0=[0.08, -0.06, 0.09], h=h, steps=steps, save_every=steps,
                             torque=gg if torque else None, scheme="splitting", order=order, composition=comp)
    run()
    cpu, wall = [], []
    for _ in range({repeat}):
        c0, w0 = time.process_time(), time.perf_counter()
        run()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    cpu.sort()
    wall.sort()
    flows = steps * SPLITTINGS[comp].kicks
    out[name] = (cpu[len(cpu) // 2] / steps * 1e6, cpu[len(cpu) // 2] / flows * 1e9, wall[len(wall) // 2] * 1e3)
print(json.dumps(out))
"""


def measure(src: str | None, repeat: int, scale: float) -> dict[str, list[float]]:
    return run_child(src, CHILD.format(cases=CASES, repeat=repeat, scale=scale))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--compare", nargs=2, metavar=("OLD", "NEW"), help="two source trees (their src folders)")
    ap.add_argument("--repeat", type=int, default=9, help="runs per case in a child (median)")
    ap.add_argument("--rounds", type=int, default=3, help="child processes per tree with --compare")
    ap.add_argument("--quick", action="store_true", help="short runs, one round (a smoke test)")
    args = ap.parse_args(argv)
    scale = 0.05 if args.quick else 1.0
    repeat = 3 if args.quick else args.repeat
    rounds = 1 if args.quick else args.rounds
    print(f"load average {os.getloadavg()[0]:.2f} (2-core machine); CPU time, median of {repeat} runs"
          + (f", median of {rounds} alternating child processes per tree" if args.compare else ""))
    if not args.compare:
        res = measure(None, repeat, scale)
        print(f"{'case':36s} {'us/step':>9s} {'ns/flow':>9s} {'wall ms':>9s}")
        for name, (step, flow, wall) in res.items():
            print(f"{name:36s} {step:9.3f} {flow:9.0f} {wall:9.2f}")
        return 0
    old_src, new_src = args.compare
    runs: dict[str, list[dict[str, list[float]]]] = {"old": [], "new": []}
    for _ in range(rounds):
        runs["old"].append(measure(old_src, repeat, scale))
        runs["new"].append(measure(new_src, repeat, scale))
    print(f"{'case':36s} {'old us/step':>12s} {'new us/step':>12s} {'old ns/flow':>12s} {'new ns/flow':>12s} "
          f"{'new/old':>8s}")
    for name in CASES:
        o = [statistics.median(r[name][i] for r in runs["old"]) for i in range(2)]
        n = [statistics.median(r[name][i] for r in runs["new"]) for i in range(2)]
        print(f"{name:36s} {o[0]:12.3f} {n[0]:12.3f} {o[1]:12.0f} {n[1]:12.0f} {n[0] / o[0]:8.3f}")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
