"""The MEKF's compiled step of this tree against another tree's, in one process: a before/after free
of the machine's process-to-process changes of speed (on the shared development machine a process
sometimes runs a third slower throughout, so figures of separate processes mislead).

The other tree's ``lgvi/_jit.py`` and ``lgvi/_kernels/`` are copied into a temporary package
``lgvi_other`` (the kernels import only ``_jit`` and each other, relatively) and compiled there.
Each row calls ``estimator_dispatch`` ``--n`` times in ``bench_estimation.py``'s compiled loop
(the same bus, rows and states: its ``rows()``), the two trees alternating run by run; CPU time
per call, medians over ``--repeat`` rounds, and the ratio this tree / other tree taken within each
round (median, min, max). The two trees' final states are compared too (bit for bit, or the
largest difference).

    python benchmarks/bench_mekf_against.py /tmp/base/src [--repeat 11] [--n 200000]
"""

from __future__ import annotations

import argparse
import importlib
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _trees import other_kernels  # noqa: E402  (benchmarks/_trees.py)
from bench_estimation import make_loop, rows  # noqa: E402


def other_dispatch(src):
    """``estimator_dispatch`` of the tree whose ``src`` folder is given, as ``lgvi_other``."""
    return importlib.import_module(other_kernels(src) + "._kernels.estimation_components").estimator_dispatch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("other", help="the other tree's src folder (e.g. from git archive <commit> src)")
    ap.add_argument("--repeat", type=int, default=11)
    ap.add_argument("--n", type=int, default=200_000)
    args = ap.parse_args()
    loops = {"this tree": make_loop(False), "other tree": make_loop(False, other_dispatch(args.other))}
    cases = [(label, case, bump) for label, case, bump in rows() if label.startswith("MEKF")]
    finals = {}
    for name, loop in loops.items():          # compile, warm, and the final states of one run each
        for label, (code, bus, p, s, w, layout), bump in cases:
            b, st = bus.copy(), s.copy()
            loop(code, args.n, b, p, st, w, layout[bump][0] if bump else -1)
            finals[name, label] = (b, st)
    times = {(name, label): [] for name in loops for label, _, _ in cases}
    for _ in range(args.repeat):
        for name, loop in loops.items():
            for label, (code, bus, p, s, w, layout), bump in cases:
                b, st = bus.copy(), s.copy()
                t0 = time.process_time()
                loop(code, args.n, b, p, st, w, layout[bump][0] if bump else -1)
                times[name, label].append((time.process_time() - t0) / args.n * 1e9)
    print(f"estimator_dispatch called {args.n} times in a compiled loop, CPU time per call (ns), "
          f"{args.repeat} rounds, the trees alternating; other tree: {args.other}")
    print(f"{'case':42s} {'this ns':>8s} {'other ns':>9s} {'ratio':>6s} {'min':>6s} {'max':>6s}  final states")
    for label, _, _ in cases:
        a, b = times["this tree", label], times["other tree", label]
        r = [x / y for x, y in zip(a, b)]
        (b1, s1), (b2, s2) = finals["this tree", label], finals["other tree", label]
        same = np.array_equal(b1, b2) and np.array_equal(s1[:50], s2[:50])
        diff = "bit for bit" if same else f"differ by {np.max(np.abs(s1[:50] - s2[:50])):.2e}"
        print(f"{label:42s} {statistics.median(a):8.1f} {statistics.median(b):9.1f} {statistics.median(r):6.3f} "
              f"{min(r):6.3f} {max(r):6.3f}  {diff}")


if __name__ == "__main__":
    main()
