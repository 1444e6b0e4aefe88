"""What the checks of a stream folder cost (issue 29): reading a long stream with
:func:`read_stream`, which checks the chunk names, the declared sample counts, that the times run
one way and that every attitude is a rotation.

Usage::

    python benchmarks/read_checks.py --compare OLD/src NEW/src   # two source trees, alternated
    python benchmarks/read_checks.py --quick                     # a smoke run

One stream of ``--steps`` steps (every state saved, chunks of 2**18 steps) is written once by the
new tree; each child process of a tree reads it ``--batches`` times, timing the CPU time of each
read (``time.process_time``, median). With ``--compare`` the trees alternate over
``--rounds`` children each (median of medians) and the table gives new / old.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile

from _trees import alternate, run_child  # benchmarks/_trees.py

CHILD = """
import json, time, statistics
import lgvi
from lgvi.io import streaming
folder = {folder!r}
reads = []
for _ in range({batches}):
    t0 = time.process_time()
    traj = streaming.read_stream(folder)
    reads.append(time.process_time() - t0)
print(json.dumps({{"file": lgvi.__file__, "read_s": statistics.median(reads), "samples": len(traj.t)}}))
"""


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", nargs=2, metavar=("OLD_SRC", "NEW_SRC"))
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--batches", type=int, default=5)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    if args.quick:
        args.steps, args.rounds, args.batches = 20_000, 1, 2
    new_src = args.compare[1] if args.compare else None
    tmp = tempfile.mkdtemp()
    try:
        folder = os.path.join(tmp, "run")
        run_child(new_src, f"""
import json, numpy as np, lgvi
lgvi.simulate_stream({folder!r}, [1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.001, steps={args.steps})
print(json.dumps({{"file": lgvi.__file__}}))
""")
        size = sum(os.path.getsize(os.path.join(folder, f)) for f in os.listdir(folder))
        code = CHILD.format(folder=folder, batches=args.batches)
        trees = args.compare or [None]
        if args.compare:
            runs = alternate(args.compare[0], args.compare[1], args.rounds, lambda src: run_child(src, code))
        else:
            runs = {None: [run_child(None, code) for _ in range(args.rounds)]}
        print(f"read_stream of {args.steps} steps, every state saved ({size / 1e6:.0f} MB in the folder); "
              f"CPU s, median of {args.batches} reads, median over {args.rounds} children per tree")
        med = {src: statistics.median(r["read_s"] for r in runs[src]) for src in trees}
        for src in trees:
            print(f"  {src or 'installed'}: {med[src]:.3f} s")
        if args.compare:
            print(f"  new / old: {med[args.compare[1]] / med[args.compare[0]]:.2f}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
