"""What a cold first call compiles: each Numba kernel it compiles and where the time goes.

Usage::

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/first_call_compiles.py simulate-sum
    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/first_call_compiles.py ensemble-model
    D=$(mktemp -d); for i in 1 2; do NUMBA_CACHE_DIR=$D python benchmarks/first_call_compiles.py simulate-compiled; done

The case runs once in this process (the cases of ``benchmarks/latency.py``); with an empty
``NUMBA_CACHE_DIR`` every kernel it needs is compiled. Numba's compile events name each kernel
compiled (a kernel called by another is compiled inside its caller's type inference, so the
caller's figures include it); Numba's own record of each compilation gives the wall time of its
locks (``compiler``: the whole front and middle end; ``llvm``: LLVM's optimisation and machine
code) and of its largest passes (``inline_inlinables``: copying the ``inline="always"`` helpers'
IR into the caller; ``nopython_type_inference``; ``native_lowering``: the LLVM IR). On a loaded
machine the wall times grow with the load; compare shares, and the CPU time of the call.

With ``--compare OLD_SRC NEW_SRC`` (two source trees, the folders holding ``lgvi/``) it runs each
case in fresh processes with an empty ``NUMBA_CACHE_DIR`` each, the two trees alternated
(``--rounds`` processes per tree and case), and prints a table of the first call's CPU seconds:
each tree's runs, their medians and the ratio new/old::

    python benchmarks/first_call_compiles.py --compare /tmp/base/src src --rounds 3 simulate-sum ensemble-model
    python benchmarks/first_call_compiles.py --compare /tmp/base/src src --rounds 3 loop-disturbances

The ``*-compiled`` cases run a user's :class:`lgvi.torques.Compiled` model. Run twice with one
``NUMBA_CACHE_DIR`` (the third line above), the second process shows what every later process
pays: the user's function and its ``cfunc`` (the loop comes from the cache; a loop specialised for
the function, as before, was compiled again in memory by every process). ``series-compiled``
evaluates a model's moment and potential at 100000 samples (``Compiled.series_compile``: the
compiled series loops of ``user_kernels``); ``run-series-compiled`` runs the model, then evaluates its
moment at those samples.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

#: the cases of benchmarks/latency.py this script runs (same calls)
SETUP = """
import numpy as np
import lgvi
from lgvi.torques import GravityGradient, LinearDamping, UniformGravity
top = lgvi.RigidBody([0.13, 0.28, 0.17])
gravity = UniformGravity(1.0, [0.0, 0.0, -0.3])
"""
#: the loop's cases (tests/test_loop.py's cubesat with four wheels, inertial pointing at 1 s)
LOOP = """
import numba
from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque, UserComponent
from lgvi.spacecraft import Spacecraft
s3 = 1.0 / np.sqrt(3.0)
wheels = lgvi.ReactionWheels([[s3, s3, s3], [-s3, s3, s3], [s3, -s3, s3], [-s3, -s3, s3]], 1e-4,
                             speed0=[10.0, -20.0, 5.0, 0.0], max_torque=0.004)
sc = Spacecraft([0.18, 0.14, 0.06], wheels=wheels)
target = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))
control = dict(control=MRPControl(K=0.004, P=0.04), actuators=RWMotorTorque(), rate=1.0)


@numba.njit
def guidance(t, bus, p, s, w):
    for i in range(9):
        bus[w[0] + i] = p[i]
    for i in range(3):
        bus[w[1] + i] = 0.0
        bus[w[2] + i] = 0.0
    return 0


mine = UserComponent(guidance, family="guidance", writes=("R_ref", "omega_ref_N", "domega_ref_N"),
                     params=target.ravel())
kw = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=100, save_every=10)
"""
#: a user's compiled model (lgvi.torques.Compiled): the gravity of SETUP written by the user
COMPILED = """
import numba
from lgvi.torques import Compiled


@numba.njit
def user_gravity(t, R, Pi, p):
    return (R[2, 1] * p[2] - R[2, 2] * p[1], R[2, 2] * p[0] - R[2, 0] * p[2], R[2, 0] * p[1] - R[2, 1] * p[0])


@numba.njit
def user_height(t, R, p):
    return R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2]


user = Compiled(user_gravity, params=1.0 * 9.81 * np.array([0.0, 0.0, -0.3]))
user_p = Compiled(user_gravity, potential=user_height, params=1.0 * 9.81 * np.array([0.0, 0.0, -0.3]))
many = (np.zeros(100_000), np.broadcast_to(np.eye(3), (100_000, 3, 3)))     # Compiled.series_compile samples
"""
CASES = {
    "simulate-free": "lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100)",
    "simulate-sum": ("lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100, "
                     "torque=gravity + LinearDamping(0.01), forcing='symmetric')"),
    "ensemble-model": ("lgvi.simulate_ensemble(top, np.stack([np.eye(3)] * 4), omega0=np.ones((4, 3)), h=0.01, "
                       "steps=100, torque=gravity)"),
    "simulate-compiled": "lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100, torque=user)",
    "ensemble-compiled": ("lgvi.simulate_ensemble(top, np.stack([np.eye(3)] * 4), omega0=np.ones((4, 3)), h=0.01, "
                          "steps=100, torque=user)"),
    "splitting-compiled": ("lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100, torque=user, "
                           "scheme='splitting', order=4)"),
    "series-compiled": "user_p.moment(*many, np.zeros(3), None); user_p.potential(*many, None)",
    "run-series-compiled": ("lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=100, torque=user); "
                        "user.moment(*many, np.zeros(3), None)"),
    "gyrostat-compiled": ("lgvi.simulate(top, np.eye(3), omega0=[0.1, 0.2, 0.3], h=0.01, steps=100, torque=user, "
                          "wheels=lgvi.ReactionWheels(np.eye(3), 1e-4))"),
    "loop-builtin": "lgvi.simulate(sc, np.eye(3), fsw=FlightSoftware(guidance=InertialPointing(target), **control), **kw)",
    "loop-user": "lgvi.simulate(sc, np.eye(3), fsw=FlightSoftware(guidance=mine, **control), **kw)",
}
#: the tumbling 6U under every disturbance at a GNC engineer's rates, the records on the grid
#: (``bench_loop_sensors.py``'s ``all dist., GNC rates, grid``: issue 26 part 5's case)
DISTURBANCES = """
sys.path.insert(0, HERE)
import bench_loop_sensors as bls
from scipy.spatial.transform import Rotation
gnc, d6 = bls.six_u(bls.ADDED, env_rate=1.0, rates=bls.GNC)
R6 = Rotation.from_mrp(d6["sigma0"]).as_matrix()
grid = bls._records("grid")
"""
CASES["loop-disturbances"] = ("lgvi.simulate(gnc, R6, omega0=d6['omega0'], fsw=grid, h=0.1, steps=100, "
                              "save_every=100)")
PASSES = ("inline_inlinables", "nopython_type_inference", "native_lowering", "native_parfor_lowering")


def first_call_cpu(src: str, case: str) -> float:
    """CPU seconds of ``case``'s first call in a fresh process on ``src`` with an empty Numba cache."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.path.abspath(src) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    with tempfile.TemporaryDirectory() as cache:
        env["NUMBA_CACHE_DIR"] = cache
        proc = subprocess.run([sys.executable, os.path.abspath(__file__), case], env=env, capture_output=True,
                              text=True, check=True)
    first = next(line for line in proc.stdout.splitlines() if line.startswith(f"{case}: first call"))
    return float(first.split("first call ")[1].split(" s CPU")[0])


def compare(old_src: str, new_src: str, cases: list[str], rounds: int) -> None:
    """Each case's first call on both trees, in fresh processes, alternated (see the module notes)."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from _trees import alternate

    print(f"first call, CPU s, fresh process and empty cache each; old {old_src}, new {new_src}; "
          f"load average {os.getloadavg()[0]:.1f} at the start")
    print(f"{'case':<20} {'old runs':<24} {'new runs':<24} {'old':>6} {'new':>6} {'new/old':>8}")
    for case in cases:
        runs = alternate(old_src, new_src, rounds, lambda src: first_call_cpu(src, case))
        old, new = statistics.median(runs[old_src]), statistics.median(runs[new_src])
        print(f"{case:<20} {', '.join(f'{x:.2f}' for x in runs[old_src]):<24} "
              f"{', '.join(f'{x:.2f}' for x in runs[new_src]):<24} {old:>6.2f} {new:>6.2f} {new / old:>8.2f}",
              flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", nargs="+", choices=tuple(CASES))
    parser.add_argument("--compare", nargs=2, metavar=("OLD_SRC", "NEW_SRC"),
                        help="two source trees (the folders holding lgvi/), measured alternately")
    parser.add_argument("--rounds", type=int, default=3, help="fresh processes per tree and case (default 3)")
    args = parser.parse_args(argv)
    if args.compare:
        compare(*args.compare, args.case, args.rounds)
        return 0
    if len(args.case) > 1:
        parser.error("one case at a time without --compare")
    args.case = args.case[0]
    from numba.core import event

    compiled: list = []

    class Listener(event.Listener):
        def on_start(self, ev):
            pass

        def on_end(self, ev):
            compiled.append(ev.data["dispatcher"])

    event.register("numba:compile", Listener())
    namespace: dict = {"sys": sys, "HERE": os.path.dirname(os.path.abspath(__file__))}
    exec(SETUP + (LOOP if args.case.startswith("loop") else "") + (COMPILED if args.case.endswith("compiled") else "")
         + (DISTURBANCES if args.case == "loop-disturbances" else ""), namespace)
    c0, w0 = time.process_time(), time.perf_counter()
    exec(CASES[args.case], namespace)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    print(f"{args.case}: first call {cpu:.2f} s CPU, {wall:.2f} s wall; {len(compiled)} kernels compiled "
          f"(each includes the kernels it calls that compiled inside it)")
    header = f"{'kernel':<24} {'compiler s':>10} {'llvm s':>7} " + " ".join(f"{p[:18]:>18}" for p in PASSES)
    print(header)
    print("-" * len(header))
    seen = set()
    for d in compiled:
        for sig, cres in d.overloads.items():
            if (id(d), sig) in seen:
                continue
            seen.add((id(d), sig))
            md = cres.metadata or {}
            timers = md.get("timers", {})
            spent: dict[str, float] = {}
            for passes in md.get("pipeline_times", {}).values():
                for name, t in passes.items():
                    key = name.split("_", 1)[1] if name[:1].isdigit() else name
                    spent[key] = spent.get(key, 0.0) + t.init + t.run + t.finalize
            print(f"{d.py_func.__name__:<24} {timers.get('compiler_lock', 0.0):>10.2f} "
                  f"{timers.get('llvm_lock', 0.0):>7.2f} " + " ".join(f"{spent.get(p, 0.0):>18.2f}" for p in PASSES))
    return 0


if __name__ == "__main__":
    sys.exit(main())
