"""Fixed cost of one gyrostat run (issue 12): the objects, and the ``lgvi.simulate`` call with wheels.

Usage::

    python benchmarks/bench_gyrostat_call.py                            # the lgvi this Python imports
    python benchmarks/bench_gyrostat_call.py --compare OLD/src NEW/src  # two source trees, alternated
    python benchmarks/bench_gyrostat_call.py --quick                    # a smoke run (tests/test_benchmarks.py)

The run is Basilisk's ``scenarioAttitudeFeedbackRW`` as ``benchmarks/basilisk_rw_scenario.py``
runs it (three wheels with torque and speed limits, the compiled MRP feedback every 0.1 s, order
4, a sample every 10 steps). Cases: ``objects`` builds the inputs (``ReactionWheels``,
``RigidBody``, ``matrix_from_mrp``, ``MRPFeedback``); ``simulate 10`` and ``simulate 6000`` call
``lgvi.simulate`` on inputs built before (10 steps: nearly all fixed cost; 6000 steps: the whole
600 s scenario); ``objects + simulate 10`` both, as a caller building everything each time; the
``rkmk4`` rows the same calls with ``scheme="rkmk4"`` (a tree without it shows no row).
Each case is timed in a child process (kernels compiled or loaded from the cache first, not
timed): ``--calls`` calls a batch, the median of ``--batches`` batches, in microseconds a call,
wall (``perf_counter``) and CPU (``process_time``). With ``--compare`` the two trees are measured
in alternating child processes (``--rounds`` each, the median of their medians), so both see the
same machine load; the table gives the ratio new / old.
"""

from __future__ import annotations

import argparse
import os
import statistics

from _trees import add_batch_args, alternate, parse_batch_args, run_child  # benchmarks/_trees.py

SETUP = """
import numpy as np
import lgvi
from lgvi.control import MRPFeedback, matrix_from_mrp
RPM = 2.0 * np.pi / 60.0
OMEGA_MAX = 6000.0 * RPM
JS = 50.0 / OMEGA_MAX
HUB = np.diag([900.0, 800.0, 600.0])
AXES = np.eye(3)
SPEED0 = np.array([100.0, 200.0, 300.0]) * RPM
SIGMA0 = np.array([0.1, 0.2, -0.3])
OMEGA0 = np.array([0.001, -0.01, 0.03])

def objects():
    wheels = lgvi.ReactionWheels(AXES, JS, speed0=SPEED0, max_torque=0.2, max_speed=OMEGA_MAX)
    body = lgvi.RigidBody(HUB)
    return wheels, body, matrix_from_mrp(SIGMA0), MRPFeedback(3.5, 30.0, inertia=HUB)

def run(obj, steps, **kw):
    wheels, body, R0, ctrl = obj
    kw.setdefault("order", 4)
    return lgvi.simulate(body, R0, omega0=OMEGA0, h=0.1, steps=steps, wheels=wheels, controller=ctrl,
                         control_period=0.1, save_every=10, **kw)

built = objects()
"""
#: case -> (the call, calls per batch relative to --calls)
CASES: dict[str, tuple[str, float]] = {
    "objects": ("objects()", 1.0),
    "simulate 10": ("run(built, 10)", 1.0),
    "simulate 6000": ("run(built, 6000)", 0.1),
    "objects + simulate 10": ("run(objects(), 10)", 1.0),
    "rkmk4: simulate 10": ("run(built, 10, scheme='rkmk4')", 1.0),
    "rkmk4: simulate 6000": ("run(built, 6000, scheme='rkmk4')", 0.1),
}

CHILD = """
import json, time
{setup}
cases = {cases!r}
out = {{}}
for name, (code, scale) in cases.items():
    f = eval("lambda: " + code)
    try:
        for _ in range(20):
            f()                           # compile / load the kernels, warm the caches
    except (TypeError, ValueError):       # a tree without this case (e.g. before scheme="rkmk4")
        out[name] = None
        continue
    calls = max(1, int({calls} * scale))
    wall, cpu = [], []
    for _ in range({batches}):
        c0, t0 = time.process_time(), time.perf_counter()
        for _ in range(calls):
            f()
        wall.append((time.perf_counter() - t0) / calls * 1e6)
        cpu.append((time.process_time() - c0) / calls * 1e6)
    wall.sort()
    cpu.sort()
    out[name] = [wall[len(wall) // 2], cpu[len(cpu) // 2]]
print(json.dumps({{"file": lgvi.__file__, "us": out}}))
"""


def measure(src: str | None, calls: int, batches: int) -> dict[str, list[float]]:
    """``{case: [wall us, CPU us]}`` medians of one child process importing lgvi from ``src``."""
    return run_child(src, CHILD.format(setup=SETUP, cases=CASES, calls=calls, batches=batches))["us"]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_batch_args(ap, "calls per timed batch (default 200; 6000 steps: 1/10)")
    args = parse_batch_args(ap, argv)
    print(f"gyrostat (Basilisk's RW scenario, order 4): median us per call ({args.batches} batches of "
          f"{args.calls} calls; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    if args.compare is None:
        us = measure(None, args.calls, args.batches)
        print(f"{'case':<24}{'wall us':>10}{'CPU us':>10}")
        for name, v in us.items():
            print(f"{name:<24}" + (f"{v[0]:>10.1f}{v[1]:>10.1f}" if v is not None else f"{'-':>10}{'-':>10}"))
        return
    old_src, new_src = args.compare
    runs = alternate(old_src, new_src, args.rounds, lambda src: measure(src, args.calls, args.batches))
    print(f"old: {old_src}\nnew: {new_src}\n({args.rounds} alternated child processes each, median of their medians; "
          f"load average now {os.getloadavg()[0]:.1f})")
    print(f"{'case':<24}{'old wall':>10}{'new wall':>10}{'new/old':>9}{'old CPU':>10}{'new CPU':>10}{'new/old':>9}")
    for name in CASES:
        if any(m[name] is None for src in (old_src, new_src) for m in runs[src]):
            print(f"{name:<24}  (not in both trees)")
            continue
        ow, nw, oc, nc = (statistics.median(m[name][i] for m in runs[src])
                          for i, src in ((0, old_src), (0, new_src), (1, old_src), (1, new_src)))
        print(f"{name:<24}{ow:>10.1f}{nw:>10.1f}{nw / ow:>9.2f}{oc:>10.1f}{nc:>10.1f}{nc / oc:>9.2f}")


if __name__ == "__main__":
    from lgvi.systems.loop_keywords import as_given

    with as_given():   # wheels=, controller= here measure the gyrostat, as before (docs/loop.md)
        main()
