"""The sensors + MEKF member's compiled loop of this tree against another tree's, in one process;
and where one run of each member spends its time (``--parts``).

On the shared development machine a process sometimes runs a third slower throughout, so figures
of separate processes mislead; this script takes a before/after of the loop kernel in one process.
The other tree's ``lgvi/_jit.py`` and ``lgvi/_kernels/`` are copied into a package ``lgvi_other``
(``benchmarks/_trees.py``, ``other_kernels``) and compiled there. Each run builds the member of
``bench_loop_sensors.py --member`` (``sensors + MEKF``: a gyro, a star tracker and the MEKF at
2 Hz, the controller on the estimate; ``true-state feedback``: the controller on the truth) with
this tree's ``LoopRun`` and its ``MemorySink`` buffers, and calls one tree's ``run_loop`` on them
(the call ``LoopRun._kernel`` makes); the trees alternate run by run (their order flipped every
round), CPU time of the kernel call per step, medians over ``--rounds``, the ratio this / other
taken within each round (median, min, max). The two trees' attitudes and records are compared
first (bit for bit, or not).

``--parts``: this tree only, one ``lgvi.simulate`` of each member taken apart as the driver runs
it: ``LoopRun`` (the Python set-up: validation, wiring, parameter rows), the ``MemorySink`` (the
result buffers), the kernel, the result (``sink.finish()``); each run's objects are dropped before
the next, as a benchmark's are. Medians over ``--rounds``, us a run and ns a step.

    python benchmarks/bench_loop_against.py /tmp/base/src [--rounds 31] [--steps 20000]
    python benchmarks/bench_loop_against.py --parts [--rounds 31]
"""

from __future__ import annotations

import argparse
import importlib
import os
import statistics
import sys
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_loop_sensors as bench  # noqa: E402
from _trees import other_kernels  # noqa: E402  (benchmarks/_trees.py)

from lgvi.driver import MemorySink  # noqa: E402
from lgvi.systems.spacecraft import LoopRun  # noqa: E402


def members():
    """``{name: (spacecraft, fsw factory)}`` of the two members (a fresh flight software a run)."""
    sensed, est, plain = bench._members()
    return {"sensors + MEKF": (sensed, lambda: bench._fsw(est)), "true-state feedback": (plain, lambda: bench._fsw())}


def build(sc, fsw, steps):
    return LoopRun(sc, np.eye(3), omega0=bench.OMEGA0, h=bench.H, steps=steps, save_every=steps, fsw=fsw())


def kernel_run(run_loop, user, sc, fsw, steps):
    """One member's run with ``run_loop``: (ns a step of the kernel call, (R, signal_data, status))."""
    run = build(sc, fsw, steps)
    sink = MemorySink(run)
    R_out, Pi_out, rho_out, it_out, res_out, u_out, sig_out = sink.buffers(0, steps)
    t = time.process_time()
    out = run_loop(user, run.gg, run.ggp, run.Rs, run.JdB, run.JB_inv, run.h, run.gam, run.t0, run.R, run.Pi,
                   run.wheel_momentum, run.G, run.wheels.axes, run.wp, run.cmd, run.u_now, run.bus, run.io, run.codes,
                   run.spc_c, run.mask, run.nr, run.P, run.po, run.S, run.so, run.W, run.wo, run.WS, run.sig_idx,
                   run.sig_fast, 0, steps, 0, run.tol, run.max_iter, run.save_every, steps, R_out, Pi_out, rho_out,
                   u_out, it_out, res_out, sig_out, run.counts, run.fail, run.nxt)
    dt = time.process_time() - t
    return dt / steps * 1e9, (R_out.copy(), sig_out.copy(), int(out[0]))


def against(other: str, rounds: int, steps: int) -> None:
    from lgvi._kernels.loop_kernels import no_user_component, run_loop

    loops = {"this": run_loop,
             "other": importlib.import_module(other_kernels(other) + "._kernels.loop_kernels").run_loop}
    user = no_user_component()
    cases = members()
    first = {(n, c): kernel_run(rl, user, sc, f, steps)[1] for n, rl in loops.items() for c, (sc, f) in cases.items()}
    times = {(n, c): [] for n in loops for c in cases}
    for r in range(rounds):
        for n in (("this", "other") if r % 2 == 0 else ("other", "this")):
            for c, (sc, f) in cases.items():
                times[n, c].append(kernel_run(loops[n], user, sc, f, steps)[0])
    print(f"the loop kernel, {steps} steps a run, {rounds} rounds, CPU time, the trees alternating; other: {other}")
    print(f"{'member':22s} {'this ns':>8s} {'other ns':>9s} {'ratio':>6s} {'min':>6s} {'max':>6s}  attitude, records")
    for c in cases:
        a, b = times["this", c], times["other", c]
        r = [x / y for x, y in zip(a, b)]
        (R1, s1, st1), (R2, s2, st2) = first["this", c], first["other", c]
        same = st1 == st2 and np.array_equal(R1, R2) and np.array_equal(s1, s2, equal_nan=True)
        print(f"{c:22s} {statistics.median(a):8.1f} {statistics.median(b):9.1f} {statistics.median(r):6.3f} "
              f"{min(r):6.3f} {max(r):6.3f}  {'bit for bit' if same else 'DIFFER'}")
    names = list(cases)
    for n in loops:
        r = [x / y for x, y in zip(times[n, names[0]], times[n, names[1]])]
        print(f"kernel {names[0]} / {names[1]}, {n} tree: {statistics.median(r):.3f}")


def parts(rounds: int, steps: int) -> None:
    cases = members()
    pt = time.process_time
    out = {c: {k: [] for k in ("LoopRun", "MemorySink", "kernel", "result", "whole")} for c in cases}
    for r in range(rounds + 3):
        for c, (sc, f) in cases.items():
            t0 = pt()
            run = build(sc, f, steps)
            t1 = pt()
            sink = MemorySink(run)
            t2 = pt()
            run.advance(steps, *sink.buffers(0, steps), sink.partial)
            t3 = pt()
            tr = sink.finish()
            t4 = pt()
            del tr, sink, run
            if r >= 3:                           # the first rounds warm the caches
                for k, v in zip(out[c], (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t4 - t0)):
                    out[c][k].append(v)
    print(f"one run of {steps} steps taken apart, {rounds} rounds, CPU time, medians: us a run (ns a step)")
    for c, d in out.items():
        print(f"{c:22s} " + "  ".join(f"{k} {statistics.median(v) * 1e6:7.1f} ({statistics.median(v) * 1e9 / steps:5.1f})"
                                      for k, v in d.items()))
    names = list(cases)
    r = [x / y for x, y in zip(out[names[0]]["whole"], out[names[1]]["whole"])]
    print(f"{names[0]} / {names[1]}, whole runs: {statistics.median(r):.3f} (min {min(r):.3f}, max {max(r):.3f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("other", nargs="?", help="the other tree's src folder (e.g. from git archive <commit> src)")
    ap.add_argument("--parts", action="store_true", help="this tree's run taken apart instead")
    ap.add_argument("--rounds", type=int, default=31)
    ap.add_argument("--steps", type=int, default=20000)
    args = ap.parse_args()
    if args.parts:
        parts(args.rounds, args.steps)
    elif args.other:
        against(args.other, args.rounds, args.steps)
    else:
        ap.error("give the other tree's src folder, or --parts")


if __name__ == "__main__":
    main()
