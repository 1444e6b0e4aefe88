"""Floor of one free-body step: the step's operations over this core's measured rates.

Usage::

    python benchmarks/floor.py               # full size (as quoted in the README)
    python benchmarks/floor.py --quick       # reduced size, for CI (no timing assertions)
    python benchmarks/floor.py --callgrind   # also count the instructions per step with valgrind (~4 min)

What is printed, all measured in this run:

1. The core's rates: latency (one dependent chain) and throughput (eight independent chains) of
   scalar float64 add, multiply, divide and square root, from compiled loops.
2. The operations of one step of each solver, counted by running the kernel's own source
   (:func:`lgvi._kernels.stepping.free_steps`, interpreted with ``NUMBA_DISABLE_JIT=1`` in a
   subprocess) on numbers that count every floating-point operation applied to them and carry
   the time at which their value is ready. Quantities computed from ``Jd``, ``h`` and ``tol``
   alone stay plain numbers: the compiled loop computes them once, outside the loop.
3. Two floors per step. The *latency floor* is the critical path of the chain of dependent
   steps (``Pi_k -> solve -> F_k -> Pi_{k+1}``): every operation's result is ready the measured
   latency after its last operand, and the floor is how fast that time advances per step. The
   *throughput floor* is the step's add/multiply/compare count at the core's measured peak rate,
   or its divisions and square roots at theirs, whichever is larger. Neither counts loads,
   stores, integer work or branches, so both are lower bounds.
4. The measured time per step: the compiled loop alone (output buffers already in memory) and
   ``lgvi.simulate`` (every step saved, buffers allocated by the call), 1e6 steps.

With ``--callgrind`` the script also runs the kernel under ``valgrind --tool=callgrind`` for
``N`` and ``2N`` steps; the difference of the two instruction totals over ``N`` is the number of
machine instructions per step (start-up cancels), exact and repeatable on a noisy machine.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

J = (1.0, 2.0, 3.0)
OMEGA0 = (0.3, 1.0, 0.2)
H = 0.01
TOL = 1e-14
METHODS = {"newton": 1, "cayley": 2}
OPS = ("add", "mul", "div", "sqrt", "cmp")


# ------------------------------------------------------------------------------ core rates
def _core_kernels():
    import numba

    @numba.njit(cache=False)
    def lat_add(n, x, c):
        for _ in range(n):
            x = x + c
            x = x + c
            x = x + c
            x = x + c
        return x

    @numba.njit(cache=False)
    def lat_mul(n, x, c):
        for _ in range(n):
            x = x * c
            x = x * c
            x = x * c
            x = x * c
        return x

    @numba.njit(cache=False)
    def lat_div(n, x, c):
        for _ in range(n):
            x = c / x
            x = c / x
            x = c / x
            x = c / x
        return x

    @numba.njit(cache=False)
    def lat_sqrt(n, x, c):
        for _ in range(n):
            x = math.sqrt(x) * c
            x = math.sqrt(x) * c
            x = math.sqrt(x) * c
            x = math.sqrt(x) * c
        return x

    @numba.njit(cache=False)
    def thr_addmul(n, x, c):
        # six add chains and six multiply chains, independent: enough operations in flight to keep
        # two adders and two multipliers of 3-4 cycles latency busy, without spilling registers
        a0 = a1 = a2 = a3 = a4 = a5 = x
        m0 = m1 = m2 = m3 = m4 = m5 = x
        for _ in range(n):
            a0 = a0 + c
            m0 = m0 * c
            a1 = a1 + c
            m1 = m1 * c
            a2 = a2 + c
            m2 = m2 * c
            a3 = a3 + c
            m3 = m3 * c
            a4 = a4 + c
            m4 = m4 * c
            a5 = a5 + c
            m5 = m5 * c
        return a0 + a1 + a2 + a3 + a4 + a5 + m0 + m1 + m2 + m3 + m4 + m5

    @numba.njit(cache=False)
    def thr_div(n, x, c):
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = x
        for _ in range(n):
            a0 = c / a0
            a1 = c / a1
            a2 = c / a2
            a3 = c / a3
            a4 = c / a4
            a5 = c / a5
            a6 = c / a6
            a7 = c / a7
        return a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7

    @numba.njit(cache=False)
    def thr_sqrt(n, x, c):
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = x
        for _ in range(n):
            a0 = math.sqrt(a0 + c)
            a1 = math.sqrt(a1 + c)
            a2 = math.sqrt(a2 + c)
            a3 = math.sqrt(a3 + c)
            a4 = math.sqrt(a4 + c)
            a5 = math.sqrt(a5 + c)
            a6 = math.sqrt(a6 + c)
            a7 = math.sqrt(a7 + c)
        return a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7

    return lat_add, lat_mul, lat_div, lat_sqrt, thr_addmul, thr_div, thr_sqrt


def _ns_per_op(fn, n, ops_per_iter, c, repeat):
    fn(10, 1.5, c)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(n, 1.5, c)
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e9 / (n * ops_per_iter)


def core_rates(n: int, repeat: int) -> dict[str, float]:
    lat_add, lat_mul, lat_div, lat_sqrt, thr_addmul, thr_div, thr_sqrt = _core_kernels()
    rates = {
        "lat_add": _ns_per_op(lat_add, n, 4, 1e-9, repeat),
        "lat_mul": _ns_per_op(lat_mul, n, 4, 1.0 + 1e-12, repeat),
        "lat_div": _ns_per_op(lat_div, n, 4, 1.0 + 1e-9, repeat),
        # one multiply per square root keeps the chain away from 1.0; its latency is subtracted
        "lat_sqrt": _ns_per_op(lat_sqrt, n, 4, 1.5, repeat),
        "thr_addmul": _ns_per_op(thr_addmul, n, 12, 1.0 + 1e-12, repeat),
        "thr_div": _ns_per_op(thr_div, n, 8, 1.0 + 1e-9, repeat),
        # each square root has its add; the pair is charged to the square root (an upper estimate)
        "thr_sqrt": _ns_per_op(thr_sqrt, n, 8, 0.5, repeat),
    }
    rates["lat_sqrt"] -= rates["lat_mul"]
    rates["lat_cmp"] = 0.0       # a comparison only steers a (predicted) branch: no data waits on it
    return rates


# ------------------------------------------------------------------------------ counting child
class Tracked:
    """A float that counts the operations applied to it and carries the time its value is ready."""

    __slots__ = ("v", "t")
    counts: dict[str, int] = dict.fromkeys(OPS, 0)
    lat: dict[str, float] = {}

    def __init__(self, v: float, t: float = 0.0) -> None:
        self.v = float(v)
        self.t = t

    @classmethod
    def op(cls, kind: str, v: float, *operands) -> Tracked:
        cls.counts[kind] += 1
        t = max(getattr(o, "t", 0.0) for o in operands)
        return Tracked(v, t + cls.lat[kind])

    def __float__(self):
        return self.v

    def __add__(self, o):
        return Tracked.op("add", self.v + float(o), self, o)

    __radd__ = __add__

    def __sub__(self, o):
        return Tracked.op("add", self.v - float(o), self, o)

    def __rsub__(self, o):
        return Tracked.op("add", float(o) - self.v, self, o)

    def __mul__(self, o):
        return Tracked.op("mul", self.v * float(o), self, o)

    __rmul__ = __mul__

    def __truediv__(self, o):
        return Tracked.op("div", self.v / float(o), self, o)

    def __rtruediv__(self, o):
        return Tracked.op("div", float(o) / self.v, self, o)

    def __neg__(self):
        return Tracked(-self.v, self.t)           # a sign flip folds into the next add/subtract

    __hash__ = None


def _comparison(f):
    def compare(self, o):
        Tracked.counts["cmp"] += 1
        return f(self.v, float(o))

    return compare


for _name in ("lt", "le", "gt", "ge", "eq", "ne"):
    setattr(Tracked, f"__{_name}__", _comparison(getattr(float, f"__{_name}__")))


class _TrackedMath:
    """Stand-in for the ``math`` module inside the kernels while counting."""

    inf = math.inf
    pi = math.pi

    @staticmethod
    def sqrt(x):
        return Tracked.op("sqrt", math.sqrt(float(x)), x) if isinstance(x, Tracked) else math.sqrt(x)

    @staticmethod
    def isfinite(x):
        return math.isfinite(float(x))     # a bit test on the exponent: integer work, not counted

    @staticmethod
    def sin(x):
        raise AssertionError("trigonometry on the counted path")

    cos = sin


def count_child(method: str, lat: dict[str, float], steps: int) -> dict:
    os.environ["NUMBA_DISABLE_JIT"] = "1"
    import lgvi
    from lgvi._kernels import solvers, stepping

    solvers.math = stepping.math = _TrackedMath
    Tracked.lat = {k: lat["lat_" + k] for k in OPS}
    body = lgvi.RigidBody(J)
    Pi0 = body.J @ np.array(OMEGA0)
    code = METHODS[method]
    G0 = np.zeros((5, 3))
    G0[0] = np.linalg.solve(body.J, H * Pi0) * (0.5 if code == 2 else 1.0)
    G0[3, 0] = 1.0
    R = np.array([[Tracked(v) for v in row] for row in np.eye(3)], dtype=object)
    Pi = np.array([Tracked(v) for v in Pi0], dtype=object)
    G = np.array([[Tracked(v) for v in row] for row in G0], dtype=object)
    R_out = np.zeros((1, 3, 3))
    Pi_out = np.zeros((1, 3))
    it_out = np.zeros(1, np.int32)
    res_out = np.zeros(1)
    empty = np.zeros(0)
    ready, per_step = [], []
    for k in range(steps):
        before = dict(Tracked.counts)
        st, _, _, _, _, _ = stepping.free_steps(code, body.Jd, H, R, Pi, G, np.zeros((0, 3)), k, 1, TOL, 50, 1.0,
                                                1, 1, 0, R_out, Pi_out, 1, it_out, res_out, empty,
                                                np.zeros(0, np.int64))
        assert st == 0, st
        per_step.append({op: Tracked.counts[op] - before[op] for op in OPS} | {"iterations": int(it_out[0])})
        ready.append(max(x.t for x in list(Pi) + list(R.ravel())))
    half = steps // 2
    last = per_step[-1]
    assert all(p == last for p in per_step[half:]), "the counted path changed between steps"
    return {"counts": last, "latency_ns": (ready[-1] - ready[half - 1]) / (steps - half)}


# ------------------------------------------------------------------------------ measured
def measured(method: str, steps: int, repeat: int) -> tuple[float, float]:
    import lgvi
    from lgvi._kernels.stepping import run_chunk, run_chunk_cayley

    body = lgvi.RigidBody(J)
    Pi0 = body.J @ np.array(OMEGA0)
    code = METHODS[method]
    R_out = np.ones((steps, 3, 3))
    Pi_out = np.ones((steps, 3))
    it = np.ones(steps, np.int32)
    res = np.ones(steps)
    kernel = run_chunk_cayley if code == 2 else run_chunk
    times = []
    for _ in range(repeat + 1):
        R = np.eye(3)
        Pi = Pi0.copy()
        G = np.zeros((5, 3))
        G[0] = np.linalg.solve(body.J, H * Pi0) * (0.5 if code == 2 else 1.0)
        G[3, 0] = 1.0
        t0 = time.perf_counter()
        st, *_ = kernel(code, body.Jd, H, R, Pi, G, np.zeros((0, 3)), 0, steps, TOL, 50, 1.0, 1, R_out, Pi_out,
                        it, res, np.zeros(0), np.zeros(64, np.int64))
        times.append(time.perf_counter() - t0)
        assert st == 0
    sim = []
    for _ in range(repeat + 1):
        t0 = time.perf_counter()
        lgvi.simulate(body, np.eye(3), Pi0, h=H, steps=steps, method=method, tol=TOL)
        sim.append(time.perf_counter() - t0)
    return statistics.median(times[1:]) * 1e9 / steps, statistics.median(sim[1:]) * 1e9 / steps


# ------------------------------------------------------------------------------ callgrind
_CG_CHILD = """
import sys, numpy as np, lgvi
from lgvi._kernels.stepping import run_chunk, run_chunk_cayley
code, N = int(sys.argv[1]), int(sys.argv[2])
body = lgvi.RigidBody({J}); Pi0 = body.J @ np.array({OMEGA0})
out = [np.ones((N, 3, 3)), np.ones((N, 3)), np.ones(N, np.int32), np.ones(N)]
G = np.zeros((5, 3)); G[0] = np.linalg.solve(body.J, {H} * Pi0) * (0.5 if code == 2 else 1.0); G[3, 0] = 1.0
kernel = run_chunk_cayley if code == 2 else run_chunk
kernel(code, body.Jd, {H}, np.eye(3), Pi0.copy(), G, np.zeros((0, 3)), 0, N, {TOL}, 50, 1.0, 1, *out, np.zeros(0),
       np.zeros(64, np.int64))
""".format(J=J, OMEGA0=OMEGA0, H=H, TOL=TOL)


def callgrind_per_step(method: str, n: int) -> float | None:
    """Machine instructions per step: callgrind totals of runs of ``2n`` and ``n`` steps, differenced."""
    from shutil import which

    if which("valgrind") is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        script = os.path.join(tmp, "child.py")
        with open(script, "w") as fh:
            fh.write(_CG_CHILD)
        code = str(METHODS[method])
        subprocess.run([sys.executable, script, code, "10"], check=True)    # the kernel in Numba's cache
        procs = [subprocess.Popen(["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/cg.{m}",
                                   sys.executable, script, code, str(m)], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True) for m in (n, 2 * n)]
        totals = []
        for p in procs:
            _, err = p.communicate()
            found = re.findall(r"Collected\s*:\s*(\d+)", err)
            if p.returncode != 0 or not found:
                raise RuntimeError(f"valgrind failed:\n{err[-2000:]}")
            totals.append(int(found[-1]))
    return (totals[1] - totals[0]) / n


def cpu_mhz() -> float | None:
    try:
        with open("/proc/cpuinfo") as fh:
            found = re.findall(r"cpu MHz\s*:\s*([\d.]+)", fh.read())
        return float(found[0]) if found else None
    except OSError:
        return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced size for CI")
    parser.add_argument("--repeat", type=int, default=None, help="timed runs per entry (median)")
    parser.add_argument("--callgrind", action="store_true", help="count instructions per step with valgrind")
    parser.add_argument("--count-child", nargs=2, metavar=("METHOD", "LATENCIES"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.count_child:
        print(json.dumps(count_child(args.count_child[0], json.loads(args.count_child[1]), 40)))
        return 0
    steps = 20_000 if args.quick else 1_000_000
    repeat = args.repeat or (2 if args.quick else 7)
    rates = core_rates(200_000 if args.quick else 5_000_000, repeat)
    mhz = cpu_mhz()
    print(f"core (one thread{f', {mhz:.0f} MHz nominal' if mhz else ''}), ns per scalar float64 operation, "
          f"median of {repeat}:")
    print(f"  latency: add {rates['lat_add']:.3f}, mul {rates['lat_mul']:.3f}, div {rates['lat_div']:.3f}, "
          f"sqrt {rates['lat_sqrt']:.3f}")
    print(f"  throughput: add/mul mix {rates['thr_addmul']:.3f}, div {rates['thr_div']:.3f}, "
          f"sqrt {rates['thr_sqrt']:.3f}")
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    rows = []
    for method in METHODS:
        out = subprocess.run([sys.executable, __file__, "--count-child", method, json.dumps(rates)], env=env,
                             capture_output=True, text=True)
        if out.returncode != 0:
            raise RuntimeError(f"counting {method} failed:\n{out.stderr}")
        child = json.loads(out.stdout.strip().splitlines()[-1])
        c = child["counts"]
        thr = max((c["add"] + c["mul"] + c["cmp"]) * rates["thr_addmul"],
                  c["div"] * rates["thr_div"] + c["sqrt"] * rates["thr_sqrt"])
        floor = max(thr, child["latency_ns"])
        k_ns, s_ns = measured(method, steps, repeat)
        ir = callgrind_per_step(method, 100_000) if args.callgrind else None
        rows.append((method, c, child["latency_ns"], thr, floor, k_ns, s_ns, ir))
    print(f"\nfree body J = diag{J}, omega0 = {OMEGA0}, h = {H}, tol = {TOL}, {steps} steps, every step saved; "
          "ns per step")
    print(f"{'method':<8} {'it':>3} {'add':>4} {'mul':>4} {'div':>4} {'sqrt':>4} {'cmp':>4} {'lat.floor':>10} "
          f"{'thr.floor':>10} {'kernel':>8} {'kern/floor':>10} {'simulate':>9} {'steps/s':>10} {'instr':>7}")
    for method, c, lat, thr, floor, k_ns, s_ns, ir in rows:
        ir_s = f"{ir:7.0f}" if ir is not None else f"{'-':>7}"
        print(f"{method:<8} {c['iterations']:>3} {c['add']:>4} {c['mul']:>4} {c['div']:>4} {c['sqrt']:>4} "
              f"{c['cmp']:>4} {lat:>10.1f} {thr:>10.1f} {k_ns:>8.1f} {k_ns / floor:>10.2f} {s_ns:>9.1f} "
              f"{1e9 / s_ns:>10.3g} {ir_s}")
    print("floors: lat. = critical path of the dependent steps at the measured latencies; thr. = the step's "
          "operations at the measured peak rates (loads, stores, integer work and branches not counted)")
    if args.callgrind:
        # the clock from the add latency: 3 cycles on AMD Zen cores (4 on recent Intel cores)
        ghz = 3.0 / rates["lat_add"]
        print(f"instructions per step (callgrind); clock estimated at {ghz:.2f} GHz from the add latency "
              "(3 cycles on AMD Zen; nominal clocks understate a boosted core)")
        for method, *_, k_ns, _, ir in rows:
            if ir is not None:
                ipc = ir / (k_ns * ghz)
                issue = ir / (4.0 * ghz)
                print(f"  {method}: {ir:.0f} instructions, {ir / k_ns:.1f} per ns = {ipc:.2f} per cycle; at 4 per "
                      f"cycle (the decode width) the step needs {issue:.1f} ns, the kernel takes {k_ns:.1f} "
                      f"({k_ns / issue:.2f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
