"""Per-call overhead of :func:`lgvi.simulate` (and of the compiled RK4 baseline, driven the same way):
median microseconds a call of a short run (issue 13).

Usage::

    python benchmarks/call_overhead.py                          # the lgvi this Python imports
    python benchmarks/call_overhead.py --compare OLD/src NEW/src  # two source trees, alternated
    python benchmarks/call_overhead.py --quick                  # a smoke run (tests/test_benchmarks.py)

Short runs (``steps=10``) are dominated by the Python work of one call (validation, set-up,
result wrapping), which is what optimisation and MPC loops pay on every call. Each case is timed
in a child process (kernels compiled or loaded from the cache first, not timed): ``--calls``
calls a batch, the median of ``--batches`` batches, in microseconds a call (wall, and the CPU
time of the process, ``time.process_time``). With ``--compare``
the two trees are measured in alternating child processes (``--rounds`` each, the median of
their medians), so both see the same machine load; the table gives the ratio new / old.
"""

from __future__ import annotations

import argparse
import os
import statistics

from _trees import add_batch_args, alternate, parse_batch_args, run_child  # benchmarks/_trees.py

SETUP = """
import numpy as np
import lgvi
from lgvi.torques import GravityGradient, UniformGravity
top = lgvi.RigidBody([0.13, 0.28, 0.17])
cubesat = lgvi.RigidBody([0.0433, 0.0418, 0.0067])
gravity = UniformGravity(1.0, [0.0, 0.0, -0.3])
down = UniformGravity(1.0, [0.0, 0.0, -0.3], 9.81)
from lgvi.verification.baselines import rk4
gg = GravityGradient(3.986004418e14, 6878.137e3)
both = gravity + GravityGradient(3.986004418e14, 6878.137e3)
R0 = np.eye(3)
"""
#: case -> the call (a 10-step run)
CASES: dict[str, str] = {
    "free body": "lgvi.simulate(top, R0, omega0=[4.14, 4.14, 4.14], h=0.01, steps=10)",
    "UniformGravity": "lgvi.simulate(top, R0, omega0=[4.14, 4.14, 4.14], h=0.01, steps=10, torque=gravity)",
    "sum of two models": "lgvi.simulate(top, R0, omega0=[4.14, 4.14, 4.14], h=0.01, steps=10, torque=both)",
    "GravityGradient order 4": ("lgvi.simulate(cubesat, R0, omega0=[0.08, -0.06, 0.09], h=1.0, steps=10, "
                                "torque=gg, order=4)"),
    "splitting order 4": ("lgvi.simulate(cubesat, R0, omega0=[0.08, -0.06, 0.09], h=8.0, steps=10, torque=gg, "
                          "scheme='splitting', order=4)"),
    # the hanging pendulum's best of benchmarks/time_to_accuracy.py (one saved sample at the end)
    "splitting axes-kl8": ("lgvi.simulate(top, R0, omega0=[4.14, 4.14, 4.14], h=0.01, steps=10, torque=down, "
                           "save_every=10, scheme='splitting', order=8, composition='axes-kl8')"),
    "compiled RK4 baseline": ("rk4(top, R0, top.J @ np.array([4.14, 4.14, 4.14]), h=0.01, steps=10, torque=down, "
                              "save_every=10)"),
}

CHILD = """
import json, time
{setup}
cases = {cases!r}
out = {{}}
for name, code in cases.items():
    f = eval("lambda: " + code)
    for _ in range(20):
        f()                               # compile / load the kernels, warm the caches
    per, cpu = [], []
    for _ in range({batches}):
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range({calls}):
            f()
        per.append((time.perf_counter() - t0) / {calls} * 1e6)
        cpu.append((time.process_time() - c0) / {calls} * 1e6)
    per.sort()
    cpu.sort()
    out[name] = per[len(per) // 2]
    out["cpu " + name] = cpu[len(cpu) // 2]
print(json.dumps({{"file": lgvi.__file__, "us": out}}))
"""


def measure(src: str | None, calls: int, batches: int) -> dict[str, float]:
    return run_child(src, CHILD.format(setup=SETUP, cases=CASES, calls=calls, batches=batches))["us"]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_batch_args(ap)
    args = parse_batch_args(ap, argv)
    print(f"lgvi.simulate, steps=10: median us per call ({args.batches} batches of {args.calls} calls; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    if args.compare is None:
        us = measure(None, args.calls, args.batches)
        print(f"{'case':<26}{'us/call':>10}{'cpu us':>10}")
        for name in CASES:
            print(f"{name:<26}{us[name]:>10.1f}{us['cpu ' + name]:>10.1f}")
        return
    old_src, new_src = args.compare
    runs = alternate(old_src, new_src, args.rounds, lambda src: measure(src, args.calls, args.batches))
    print(f"old: {old_src}\nnew: {new_src}\n({args.rounds} alternated child processes each, median of their medians)")
    print(f"{'case':<26}{'old us':>10}{'new us':>10}{'new/old':>10}{'old cpu':>10}{'new cpu':>10}{'new/old':>10}")
    for name in CASES:
        o = statistics.median(m[name] for m in runs[old_src])
        n = statistics.median(m[name] for m in runs[new_src])
        oc = statistics.median(m["cpu " + name] for m in runs[old_src])
        nc = statistics.median(m["cpu " + name] for m in runs[new_src])
        print(f"{name:<26}{o:>10.1f}{n:>10.1f}{n / o:>10.2f}{oc:>10.1f}{nc:>10.1f}{nc / oc:>10.2f}")


if __name__ == "__main__":
    main()
