"""Peak memory of the command line on long runs: ``lgvi run``, ``info`` and ``plot`` of its result.

Usage::

    python benchmarks/memory.py            # 1e7 and 1e8 free-body steps, save_every = 1000
    python benchmarks/memory.py --quick    # 1e5 and 1e6 steps, save_every = 10, no figures (for CI)
    python benchmarks/memory.py --full-record   # also the 1e7 run with --solver-record full

Each command runs in a fresh interpreter under a small wrapper process whose only child it is, so
the wrapper's ``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` is the command's own peak
resident memory (kernels, figures and all). The run is a free body (J = diag(1, 2, 3), Cayley
solver, h = 0.01) with the default outputs (``trajectory.npz``, summary, figures).

The goal of issue 17: at most 300 MB for 1e8 steps, and the same peak (within 10 %) for 1e7 and
1e8 steps: memory bounded independently of the number of steps. The table gives each peak and
its ratio to the smallest run's, measured in the same sitting.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GOAL_MB = 300.0
GOAL_RATIO = 1.10

SCENARIO = """name = "memory"
[body]
inertia = [1.0, 2.0, 3.0]
[initial]
omega = [0.3, 1.0, 0.2]
[integrator]
h = 0.01
steps = {steps}
method = "cayley"
save_every = {save_every}
"""

_WRAPPER = """
import json, resource, subprocess, sys, time
t = time.perf_counter()
proc = subprocess.run(sys.argv[1:], capture_output=True, text=True)
wall = time.perf_counter() - t
print(json.dumps({"rc": proc.returncode, "wall": wall, "stderr": proc.stderr[-2000:],
                  "peak_kb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}))
"""


def peak(cmd: list[str]) -> tuple[float, float]:
    """Peak resident memory (MB) and wall time (s) of ``cmd`` run in a fresh process."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", _WRAPPER, *cmd], capture_output=True, text=True, env=env,
                         check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    if res["rc"] != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited with {res['rc']}:\n{res['stderr']}")
    return res["peak_kb"] / 1024.0, res["wall"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced size for CI")
    parser.add_argument("--full-record", action="store_true",
                        help="also run the smaller case with --solver-record full (the per-step record)")
    args = parser.parse_args(argv)
    sizes = (100_000, 1_000_000) if args.quick else (10_000_000, 100_000_000)
    save_every = 10 if args.quick else 1000
    lgvi_cmd = [sys.executable, "-m", "lgvi"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if not args.quick:  # load (or compile) the kernels once, so no measured run pays for a compilation
            warm = tmp / "warm.toml"
            warm.write_text(SCENARIO.format(steps=save_every, save_every=save_every))
            peak(lgvi_cmd + ["run", str(warm), "-o", str(tmp / "warm")])
        runs = [(n, "interval") for n in sizes] + ([(sizes[0], "full")] if args.full_record else [])
        for steps, record in runs:
            scen = tmp / f"s{steps}.toml"
            scen.write_text(SCENARIO.format(steps=steps, save_every=save_every))
            out = tmp / f"out{steps}-{record}"
            mb, wall = peak(lgvi_cmd + ["run", str(scen), "-o", str(out), "--solver-record", record]
                            + (["--no-plots"] if args.quick else []))
            npz = (out / "trajectory.npz").stat().st_size / 2**20
            rows.append((f"lgvi run ({record} record)", steps, steps // save_every + 1, mb, wall, npz))
            if record == "interval" and (steps == sizes[-1] or not args.quick):
                mb, wall = peak(lgvi_cmd + ["info", str(out / "trajectory.npz")])
                rows.append(("lgvi info", steps, steps // save_every + 1, mb, wall, npz))
                if not args.quick:
                    mb, wall = peak(lgvi_cmd + ["plot", str(out / "trajectory.npz"), "-o", str(tmp / "plots")])
                    rows.append(("lgvi plot", steps, steps // save_every + 1, mb, wall, npz))
    print(f"peak resident memory of the command line: free body, cayley, h = 0.01, save_every = {save_every}")
    print(f"{'command':<28} {'steps':>11} {'samples':>9} {'peak MB':>9} {'wall s':>8} {'npz MB':>8} {'vs first':>9}")
    first = {}
    for name, steps, samples, mb, wall, npz in rows:
        ref = first.setdefault(name, mb)
        print(f"{name:<28} {steps:>11d} {samples:>9d} {mb:>9.1f} {wall:>8.2f} {npz:>8.2f} {mb / ref:>9.3f}")
    runs_i = [r for r in rows if r[0] == "lgvi run (interval record)"]
    small, large = runs_i[0][3], runs_i[-1][3]
    print(f"lgvi run: {runs_i[-1][1]:.0e} steps peak {large:.1f} MB (goal <= {GOAL_MB:.0f} MB: "
          f"{'met' if large <= GOAL_MB else 'MISSED'}); {runs_i[-1][1]:.0e} / {runs_i[0][1]:.0e} steps peak ratio "
          f"{large / small:.3f} (goal <= {GOAL_RATIO:.2f}: {'met' if large / small <= GOAL_RATIO else 'MISSED'})"
          + (" [--quick sizes: the goal is for 1e7 and 1e8 steps]" if args.quick else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
