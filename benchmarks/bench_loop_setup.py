"""The Python set-up the sensors + MEKF member pays and the true-state member does not (issue 27 part 4).

One ``LoopRun`` build (validation, wiring, parameter rows, the flight software built first, as in
``bench_loop_against.py --parts``) of each member of ``bench_loop_sensors.py --member``, measured
two ways:

* what it executes, by Python function: the opcodes the interpreter runs and the C functions it
  calls (``sys.settrace`` with opcode events, ``sys.setprofile``), the member's minus the
  true-state member's. The counts are the same on every machine and under any load, so a change of
  the set-up shows at once; an opcode is not a fixed time (a call or an allocation costs many times a
  local load), so the time is measured too;
* CPU time: builds in pairs (the member and the true-state member, alternately first), the median
  of each and of the pairs' differences, the member's extra over the true-state build.

``--compare OLD_SRC NEW_SRC``: both trees in child processes, alternated (``--rounds`` each), the
totals of each; the machine's speed changes from process to process (a third or more on the shared
development machine), so compare the trees by the counts and by the extra over the true-state build.

    python benchmarks/bench_loop_setup.py [--top 25] [--pairs 2000]
    python benchmarks/bench_loop_setup.py --quick                       # 50 pairs (checks it runs)
    python benchmarks/bench_loop_setup.py --compare /tmp/base/src src [--rounds 3]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def _cases():
    import numpy as np

    import bench_loop_sensors as bench
    from lgvi.systems.spacecraft import LoopRun

    sensed, est, plain = bench._members()

    def build(sc, fsw):
        return lambda: LoopRun(sc, np.eye(3), omega0=bench.OMEGA0, h=bench.H, steps=20000, save_every=20000, fsw=fsw())

    return {"sensors + MEKF": build(sensed, lambda: bench._fsw(est)),
            "true-state feedback": build(plain, lambda: bench._fsw())}


def counts(build) -> tuple[collections.Counter, collections.Counter]:
    """(opcodes, C calls) of one ``build()``, by Python function ``file:line(name)``."""
    ops: collections.Counter = collections.Counter()
    calls: collections.Counter = collections.Counter()

    def where(frame):
        c = frame.f_code
        return f"{os.path.basename(c.co_filename)}:{c.co_firstlineno}({c.co_name})"

    def trace(frame, event, arg):
        frame.f_trace_opcodes, frame.f_trace_lines = True, False
        if event == "opcode":
            ops[where(frame)] += 1
        return trace

    def profile(frame, event, arg):
        if event == "c_call":
            calls[where(frame)] += 1

    sys.settrace(trace)
    sys.setprofile(profile)
    try:
        build()
    finally:
        sys.settrace(None)
        sys.setprofile(None)
    return ops, calls


def times(cases, pairs: int) -> dict[str, float]:
    """Medians (us) of each member's build and of the pairs' differences."""
    (a, build_a), (b, build_b) = cases.items()
    pt = time.process_time_ns
    ta, tb, d = [], [], []
    for i in range(pairs):
        first, second = (build_a, build_b) if i % 2 == 0 else (build_b, build_a)
        t0 = pt()
        first()
        t1 = pt()
        second()
        t2 = pt()
        x, y = (t1 - t0, t2 - t1) if i % 2 == 0 else (t2 - t1, t1 - t0)
        ta.append(x / 1e3)
        tb.append(y / 1e3)
        d.append((x - y) / 1e3)
    return {a: statistics.median(ta), b: statistics.median(tb), "extra": statistics.median(d)}


def measure(pairs: int, top: int) -> dict:
    cases = _cases()
    for build in cases.values():            # the first builds import and warm what the set-up uses
        for _ in range(20):
            build()
    got = {name: counts(build) for name, build in cases.items()}
    (ops_a, calls_a), (ops_b, calls_b) = got.values()
    rows = sorted(((ops_a[k] - ops_b[k], calls_a[k] - calls_b[k], k) for k in set(ops_a) | set(calls_a)
                   | set(ops_b) | set(calls_b)), key=lambda r: (-(r[0] + 10 * r[1]), r[2]))
    return {"opcodes": [sum(ops_a.values()), sum(ops_b.values())],
            "C calls": [sum(calls_a.values()), sum(calls_b.values())],
            "functions": [r for r in rows if r[0] or r[1]][:top], "us": times(cases, pairs)}


def report(res: dict, label: str = "") -> None:
    (oa, ob), (ca, cb) = res["opcodes"], res["C calls"]
    us = res["us"]
    print(f"{label}one LoopRun build, sensors + MEKF / true-state feedback: opcodes {oa} / {ob} (extra {oa - ob}), "
          f"C calls {ca} / {cb} (extra {ca - cb}); CPU time medians {us['sensors + MEKF']:.1f} / "
          f"{us['true-state feedback']:.1f} us, extra (pairs) {us['extra']:.1f} us")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=25, help="functions listed (default 25)")
    ap.add_argument("--pairs", type=int, default=2000, help="timed pairs of builds (default 2000)")
    ap.add_argument("--compare", nargs=2, metavar=("OLD_SRC", "NEW_SRC"))
    ap.add_argument("--rounds", type=int, default=3, help="child processes per tree with --compare (default 3)")
    ap.add_argument("--quick", action="store_true", help="50 pairs, one process per tree (checks it runs)")
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)      # a child's answer
    args = ap.parse_args(argv)
    if args.quick:
        args.pairs, args.rounds = 50, 1
    if args.compare:
        from _trees import alternate, run_child

        here = os.path.dirname(os.path.abspath(__file__))
        code = (f"import sys; sys.argv = ['x', '--json', '--pairs', '{args.pairs}', '--top', '0']; "
                f"sys.path.insert(0, {here!r}); import bench_loop_setup; bench_loop_setup.main(sys.argv[1:])")
        runs = alternate(args.compare[0], args.compare[1], args.rounds, lambda src: run_child(src, code))
        for src, results in runs.items():
            for i, res in enumerate(results):
                report(res, f"{src} (process {i + 1}): ")
        for src, results in runs.items():
            print(f"{src}: the member's extra, median over the processes: "
                  f"{statistics.median(r['us']['extra'] for r in results):.1f} us, "
                  f"{results[0]['opcodes'][0] - results[0]['opcodes'][1]} opcodes, "
                  f"{results[0]['C calls'][0] - results[0]['C calls'][1]} C calls")
        return 0
    res = measure(args.pairs, args.top)
    if args.json:
        import lgvi

        print(json.dumps(dict(res, file=lgvi.__file__)))
        return 0
    report(res)
    print(f"{'opcodes':>8s} {'C calls':>8s}  function (the member's minus the true-state member's)")
    for d_ops, d_calls, name in res["functions"]:
        print(f"{d_ops:8d} {d_calls:8d}  {name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
