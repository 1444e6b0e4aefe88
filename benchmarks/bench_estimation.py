"""Cost of the sensor and estimator components (issue 27), and the long version of the MEKF's NEES test.

Each row times one compiled component called ``n`` times in a compiled loop (the call the loop
makes: ``sensor_dispatch`` / ``estimator_dispatch`` with the bus, the parameter row, the state and
the offsets), CPU time per call, the median of ``--repeat`` runs; the rows alternate run by run so
a change of the machine's load touches all of them. An empty loop (the same loop calling no
component) is the floor. Goals (issue 27): a sensor sample <= 100 ns, an MEKF propagation plus star
tracker update <= 2 us.

``--nees`` runs the MEKF's NEES test of tests/test_estimation.py on more seed sets (100 members
each, both cases) and prints, per set, the fraction of outputs whose member-averaged NEES lies in
the 95% band of chi-square(600)/100, and the mean NEES.

    python benchmarks/bench_estimation.py [--quick] [--repeat 7] [--nees 8]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

import numba
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

from lgvi._kernels.estimation_components import estimator_dispatch  # noqa: E402
from lgvi._kernels.sensor_components import sensor_dispatch  # noqa: E402
from lgvi.components import COMPONENT_KINDS  # noqa: E402
from lgvi.fsw import MEKF  # noqa: E402
from lgvi.fsw._drive import bus_layout  # noqa: E402
from lgvi.spacecraft import CoarseSunSensors, FineSunSensor, Gyro, Magnetometer, StarTracker  # noqa: E402


def make_loop(inline, estimator_kernel=estimator_dispatch):
    """A compiled loop of ``n`` calls of component ``code`` at t = 0, 0.1, ...: through the
    dispatchers as they are (one call a step), or with the dispatchers inlined into the loop (what
    a loop kernel that inlines them pays). ``bump >= 0``: the bus entry at that offset is set to t
    before each call (a new star tracker measurement every call). ``code`` 0: the loop alone.
    ``estimator_kernel``: another tree's ``estimator_dispatch`` (``bench_mekf_against.py``)."""
    sensor = numba.njit(inline="always")(sensor_dispatch.py_func) if inline else sensor_dispatch
    estimator = numba.njit(inline="always")(estimator_kernel.py_func) if inline else estimator_kernel

    @numba.njit(cache=False)
    def calls(code, n, bus, p, s, w, bump):
        st = 0
        for k in range(n):
            t = 0.1 * k
            if bump >= 0:
                bus[bump] = t
            if code == 0:
                st += k & 1
            elif code < 400:
                st += sensor(code, t, bus, p, s, w)
            else:
                st += estimator(code, t, bus, p, s, w)
        return st

    return calls


def setup(components, constants):
    """Bus, rows, states and offsets of the last of ``components`` (the others only lay out the bus)."""
    layout = bus_layout(components)
    bus = np.zeros(sum(size for _, size in layout.values()))
    bus[layout["R"][0]:layout["R"][0] + 9] = np.eye(3).ravel()
    for name, value in constants.items():
        if name not in layout:
            continue
        o, size = layout[name]
        bus[o:o + size] = np.ravel(value)
    comp = components[-1]
    kind = COMPONENT_KINDS[comp.kind]
    w = np.array([layout[name][0] for name in kind.reads + kind.writes], dtype=np.int64)
    return kind.code, bus, comp.params().astype(float), comp.state0().astype(float), w, layout


def rows():
    st = StarTracker(sigma_cross=5e-5, sigma_about=4e-4)
    env = {"omega": [0.01, -0.02, 0.03], "B_N": [2e-5, -1e-5, 3.5e-5], "sun_N": [0.6, 0.0, 0.8], "shadow": 1.0,
           "st_valid": 1.0, "st_q": [0.0, 0.0, 0.0, 1.0], "r_N": [7e6, 0.0, 0.0]}
    P0 = np.r_[[1e-6] * 3, [1e-8] * 3]
    mekf = MEKF(arw=1e-4, rrw=1e-5, star_tracker=st, P0=P0)
    out = [
        ("gyro (ARW, RRW, bias, misalignment, scale)", [Gyro(rate=0.1, arw=1e-4, rrw=1e-5, bias=[1e-3, 0, 0],
                                                             misalignment=[1e-3, 0, 0], scale=1.001)], None),
        ("gyro, + quantisation, saturation, mean rate", [Gyro(rate=0.1, arw=1e-4, rrw=1e-5, lsb=1e-6,
                                                              saturation=1.0, output="mean")], None),
        ("star tracker (noise about 3 axes, quaternion)", [st], None),
        ("star tracker, + sun and Earth exclusion", [StarTracker(sigma_cross=5e-5, sigma_about=4e-4,
                                                                 sun_exclusion=0.5, earth_exclusion=0.3)], None),
        ("magnetometer", [Magnetometer(sigma=1e-7, misalignment=[1e-3, 0, 0])], None),
        ("coarse sun sensors, 6 heads", [CoarseSunSensors(np.vstack([np.eye(3), -np.eye(3)]), sigma=0.01)], None),
        ("fine sun sensor", [FineSunSensor(sigma=1e-3)], None),
        ("MEKF propagation (no new measurement)", [Gyro(rate=0.1), st, mekf], None),
        ("MEKF propagation + star tracker update", [Gyro(rate=0.1), st, mekf], "st_time"),
    ]
    return [(label, setup(comps, env), bump) for label, comps, bump in out]


def timing(args):
    cases = rows()
    n = 20_000 if args.quick else 1_000_000
    # --quick (the test suite) skips the inlined loop: compiling it takes a minute on a loaded machine
    loops = {"called": make_loop(False)} if args.quick else {"called": make_loop(False), "inlined": make_loop(True)}
    empty = (np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1, dtype=np.int64))
    for loop in loops.values():             # compile and warm every row
        loop(0, 10, *empty, -1)
        for _, (code, bus, p, s, w, layout), bump in cases:
            loop(code, 10, bus.copy(), p, s.copy(), w, layout[bump][0] if bump else -1)
    times = {(how, label): [] for how in loops for label, _, _ in cases + [("empty loop", None, None)]}
    for _ in range(args.repeat):
        for how, loop in loops.items():
            t0 = time.process_time()
            loop(0, n, *empty, -1)
            times[how, "empty loop"].append((time.process_time() - t0) / n)
            for label, (code, bus, p, s, w, layout), bump in cases:
                b, st = bus.copy(), s.copy()
                t0 = time.process_time()
                loop(code, n, b, p, st, w, layout[bump][0] if bump else -1)
                times[how, label].append((time.process_time() - t0) / n)
    print(f"components called {n} times in a compiled loop; CPU time per call, median of {args.repeat} "
          "alternating runs (a shared, loaded machine)")
    print("called: the loop calls the family's dispatcher (one function call a step); inlined: the dispatcher "
          "is inlined into the loop")
    print("the loop (_kernels/loop_kernels.py) calls the dispatchers, compiled without Numba's runtime: 'called' is "
          "what it pays")
    print(f"{'component':50s} {'called ns':>9s} {'inlined ns':>10s} {'goal ns':>8s} {'goal/called':>12s}")
    med = {key: statistics.median(v) * 1e9 for key, v in times.items()}
    for label, _, _ in [("empty loop", None, None)] + cases:
        goal = 2000.0 if label.startswith("MEKF propagation +") else (100.0 if not label.startswith(("MEKF", "empty"))
                                                                      else float("nan"))
        inl = med.get(("inlined", label), float("nan"))
        print(f"{label:50s} {med['called', label]:9.1f} {inl:10.1f} {goal:8.0f} {goal / med['called', label]:12.2f}")
    for how in loops:
        upd = med[how, "MEKF propagation + star tracker update"] - med[how, "MEKF propagation (no new measurement)"]
        print(f"star tracker update alone ({how}): {upd:.0f} ns (the difference of the two MEKF rows)")


def nees_runs(args):
    from scipy import stats

    import estimation_cases as C

    lo, hi = stats.chi2.ppf([0.025, 0.975], 6 * C.MEMBERS) / C.MEMBERS
    print(f"\nMEKF NEES, {C.MEMBERS} members a set, {C.STEPS} outputs; band [{lo:.3f}, {hi:.3f}]")
    print(f"{'case':10s} {'seeds':>12s} {'inside':>8s} {'mean NEES':>10s}")
    for name, w0 in (("tumbling", C.TUMBLING), ("pointing", C.POINTING)):
        tr = C.truth(w0)
        for i in range(args.nees):
            base = 1000 + 4000 * i
            total = np.zeros(C.STEPS)
            for seed in range(C.MEMBERS):
                e, P = C.member(tr, base + seed, att_sd=math.radians(1.0))
                total += C.nees(e, P)
            avg = total / C.MEMBERS
            print(f"{name:10s} {base:6d}+0..99 {np.mean((avg >= lo) & (avg <= hi)):8.3f} {avg.mean():10.3f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small n, for the test suite")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--nees", type=int, default=0, help="seed sets of the NEES test to run (0: none)")
    args = ap.parse_args()
    if args.quick:
        args.repeat = min(args.repeat, 3)
    timing(args)
    if args.nees:
        nees_runs(args)


if __name__ == "__main__":
    main()
