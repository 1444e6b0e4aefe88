"""First-call latency: the wall time of the first call in a fresh process, cold and warm.

Usage::

    python benchmarks/latency.py              # every case, cold then warm (a few minutes)
    python benchmarks/latency.py --case simulate-model --repeat 3

Each case runs in a fresh Python subprocess. *Cold*: with a fresh, empty ``NUMBA_CACHE_DIR``
(everything the call needs is compiled). *Warm*: a second fresh subprocess with the cache that
the cold run left (the kernels are loaded from disk). The time is that of the first call itself
(``import lgvi`` is timed separately and not included); the figure is the median of
``--repeat`` subprocesses. Each time is printed twice: wall clock (what a user waits) and the CPU
time of the subprocess (``time.process_time``: compilation is single-threaded, so on an idle
machine the two agree; on a loaded one the wall time grows with the load and the CPU time much
less, which makes the CPU column the one to compare between runs). Goals (issue 13): cold ``simulate`` with a built-in model <= 5 s,
cold ``simulate_ensemble`` with models <= 10 s, warm first call <= 0.5 s.

The machine is shared: run it on an idle machine for figures to quote, and compare cases
measured in the same run. The script measures whichever ``lgvi`` its subprocesses import, so one
copy of it compares two trees: ``PYTHONPATH=path/to/other/src python benchmarks/latency.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

#: case -> (code run after ``import lgvi`` and the setup, goal of the cold call in s)
SETUP = """
import numpy as np
import lgvi
from lgvi.torques import GravityGradient, LinearDamping, UniformGravity
top = lgvi.RigidBody([0.13, 0.28, 0.17])
cubesat = lgvi.RigidBody([0.0433, 0.0418, 0.0067])
gravity = UniformGravity(1.0, [0.0, 0.0, -0.3])
gg = GravityGradient(3.986004418e14, 6878.137e3)
"""
CASES: dict[str, tuple[str, float]] = {
    "simulate-free": ("lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100)", 5.0),
    "simulate-model": ("lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100, "
                       "torque=gravity)", 5.0),
    "simulate-sum": ("lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100, "
                     "torque=gravity + LinearDamping(0.01), forcing='symmetric')", 5.0),
    "simulate-model-order4": ("lgvi.simulate(cubesat, np.eye(3), omega0=[0.08, -0.06, 0.09], h=1.0, steps=100, "
                              "torque=gg, order=4)", 5.0),
    "simulate-splitting": ("lgvi.simulate(cubesat, np.eye(3), omega0=[0.08, -0.06, 0.09], h=8.0, steps=100, "
                           "torque=gg, scheme='splitting', order=4)", 5.0),
    "ensemble-model": ("lgvi.simulate_ensemble(top, np.stack([np.eye(3)] * 4), omega0=np.ones((4, 3)), h=0.01, "
                       "steps=100, torque=gravity)", 10.0),
}
WARM_GOAL = 0.5

CHILD = """
import json, time
t0 = time.perf_counter()
{setup}
t1 = time.perf_counter()
c1 = time.process_time()
{call}
t2 = time.perf_counter()
c2 = time.process_time()
print(json.dumps({{"import": t1 - t0, "first_call": t2 - t1, "cpu": c2 - c1}}))
"""


def run_case(call: str, cache: str) -> dict[str, float]:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    env.pop("LGVI_NUMBA_CACHE", None)
    code = CHILD.format(setup=SETUP, call=call)
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=900)
    if proc.returncode != 0:
        raise RuntimeError(f"the case failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=tuple(CASES), action="append", help="run only these cases")
    parser.add_argument("--repeat", type=int, default=1, help="fresh subprocesses per figure (median)")
    args = parser.parse_args(argv)
    cases = args.case or list(CASES)
    import lgvi

    print(f"lgvi {lgvi.__version__} first-call latency (fresh subprocesses; cold: empty NUMBA_CACHE_DIR; "
          f"median of {args.repeat}); machine load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    header = (f"{'case':<24} {'import s':>9} {'cold s':>8} {'cold cpu':>9} {'goal':>6} {'warm s':>8} "
              f"{'warm cpu':>9} {'goal':>6}")
    print(header)
    print("-" * len(header))
    ok = True
    start = time.perf_counter()
    for name in cases:
        call, goal = CASES[name]
        cold, warm, imp, cold_cpu, warm_cpu = [], [], [], [], []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory(prefix="lgvi-latency-") as cache:
                c = run_case(call, cache)
                w = run_case(call, cache)
            cold.append(c["first_call"])
            warm.append(w["first_call"])
            cold_cpu.append(c["cpu"])
            warm_cpu.append(w["cpu"])
            imp.append(w["import"])
        mc, mw = statistics.median(cold), statistics.median(warm)
        ok &= mc <= goal and mw <= WARM_GOAL
        print(f"{name:<24} {statistics.median(imp):>9.2f} {mc:>8.2f} {statistics.median(cold_cpu):>9.2f} "
              f"{goal:>6.1f} {mw:>8.3f} {statistics.median(warm_cpu):>9.3f} {WARM_GOAL:>6.1f}", flush=True)
    print(f"all goals met (wall clock): {'yes' if ok else 'no'}; total {time.perf_counter() - start:.0f} s; "
          f"machine load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
