"""The step of the torque-model loops, built-in against a user's compiled model, warm: CPU ns a step.

Usage::

    python benchmarks/model_step.py                                   # this tree
    python benchmarks/model_step.py --compare OLD_SRC NEW_SRC         # two trees, alternated
    python benchmarks/model_step.py --quick                           # small sizes (checks output)

Cases (the heavy top of ``benchmarks/latency.py``, ``UniformGravity``, order 2, Newton):

* ``simulate gravity``: :func:`lgvi.simulate` with the built-in model (``run_chunk_forced``);
* ``simulate Compiled``: the same gravity as the user's :class:`lgvi.torques.Compiled` model
  (``run_chunk_user``, the user's function called through :func:`lgvi._kernels.user_kernels.guarded`);
* ``gravity + damping``: the built-in sum with the symmetric forcing (``simulate-sum`` of
  ``latency.py``);
* ``ensemble gravity``: :func:`lgvi.simulate_ensemble` of 8 bodies, one thread (ns a body-step);
* ``ensemble Compiled``: the same with the user's model;
* ``splitting gravity``, ``splitting Compiled``: ``scheme="splitting", order=4`` (the exact flows
  and kicks, ``run_split`` and ``run_split_user``) with the built-in model and the user's.

Each child process runs every case once untimed (compiling, or loading from the cache), then
``--repeat`` timed runs of each in turn; a case's figure is the median CPU time over the runs
divided by the steps. With ``--compare`` the trees' child processes alternate (``--rounds`` each)
and the table gives each tree's median and the ratio new/old of the medians. CPU time, not wall:
the machines here are shared, and the figures move with the load.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _trees import alternate, run_child  # noqa: E402

CHILD = """
import json, os, statistics, time
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
import numba, numpy as np
import lgvi
from lgvi.torques import Compiled, LinearDamping, UniformGravity

@numba.njit
def user_gravity(t, R, Pi, p):
    return (R[2, 1] * p[2] - R[2, 2] * p[1], R[2, 2] * p[0] - R[2, 0] * p[2], R[2, 0] * p[1] - R[2, 1] * p[0])

top = lgvi.RigidBody([0.13, 0.28, 0.17])
gravity = UniformGravity(1.0, [0.0, 0.0, -0.3])
w = 1.0 * 9.81 * np.array([0.0, 0.0, -0.3])     # mass g com: the moment (R^T e3) x w, as the built-in
user = Compiled(user_gravity, params=w)
STEPS, B, REPEAT = {steps}, 8, {repeat}
R0 = np.stack([lgvi.so3.exp(0.1 * np.array([i, 1.0, -i])) for i in range(B)])
kw = dict(h=0.01, save_every=STEPS // 10, progress=False)
cases = {{
    "simulate gravity": (lambda n: lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], steps=n, torque=gravity, **kw), 1),
    "simulate Compiled": (lambda n: lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], steps=n, torque=user, **kw), 1),
    "gravity + damping": (lambda n: lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], steps=n, forcing="symmetric",
                                                   torque=gravity + LinearDamping(0.01), **kw), 1),
    "ensemble gravity": (lambda n: lgvi.simulate_ensemble(top, R0, omega0=np.ones((B, 3)), steps=n, torque=gravity,
                                                          threads=1, **kw), B),
    "ensemble Compiled": (lambda n: lgvi.simulate_ensemble(top, R0, omega0=np.ones((B, 3)), steps=n, torque=user,
                                                           threads=1, **kw), B),
    "splitting gravity": (lambda n: lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], steps=n, torque=gravity,
                                                   scheme="splitting", order=4, **kw), 1),
    "splitting Compiled": (lambda n: lgvi.simulate(top, np.eye(3), omega0=[4.14, 4.14, 4.14], steps=n, torque=user,
                                                    scheme="splitting", order=4, **kw), 1),
}}
for f, _ in cases.values():
    f(10 * (STEPS // 10 // 10 or 1))
times = {{name: [] for name in cases}}
for _ in range(REPEAT):
    for name, (f, bodies) in cases.items():
        c = time.process_time()
        f(STEPS)
        times[name].append((time.process_time() - c) / (STEPS * bodies) * 1e9)
print(json.dumps({{"file": lgvi.__file__, "ns": {{k: statistics.median(v) for k, v in times.items()}}}}))
"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", nargs=2, metavar=("OLD_SRC", "NEW_SRC"),
                    help="two source trees (the folders holding lgvi/), measured alternately")
    ap.add_argument("--rounds", type=int, default=3, help="child processes per tree (default 3)")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs of each case per child (default 5)")
    ap.add_argument("--steps", type=int, default=200_000, help="steps of each timed run (default 200000)")
    ap.add_argument("--quick", action="store_true", help="1 round, 1 run of 2000 steps (a smoke run)")
    args = ap.parse_args(argv)
    if args.quick:
        args.rounds, args.repeat, args.steps = 1, 1, 2000
    code = CHILD.format(steps=args.steps, repeat=args.repeat)
    trees = args.compare or [None]
    if args.compare:
        runs = alternate(args.compare[0], args.compare[1], args.rounds, lambda src: run_child(src, code)["ns"])
    else:
        runs = {None: [run_child(None, code)["ns"] for _ in range(args.rounds)]}
    names = list(next(iter(runs.values()))[0])
    med = {src: {n: statistics.median(r[n] for r in runs[src]) for n in names} for src in trees}
    print(f"CPU ns a step (a body-step for ensembles), median of {args.rounds} processes x {args.repeat} runs of "
          f"{args.steps} steps")
    if args.compare:
        old, new = args.compare
        print(f"{'case':<20} {'old ns':>9} {'new ns':>9} {'new/old':>8}")
        for n in names:
            print(f"{n:<20} {med[old][n]:>9.1f} {med[new][n]:>9.1f} {med[new][n] / med[old][n]:>8.3f}")
        print(f"Compiled / built-in: simulate old {med[old]['simulate Compiled'] / med[old]['simulate gravity']:.3f}, "
              f"new {med[new]['simulate Compiled'] / med[new]['simulate gravity']:.3f}; ensemble old "
              f"{med[old]['ensemble Compiled'] / med[old]['ensemble gravity']:.3f}, new "
              f"{med[new]['ensemble Compiled'] / med[new]['ensemble gravity']:.3f}; splitting old "
              f"{med[old]['splitting Compiled'] / med[old]['splitting gravity']:.3f}, new "
              f"{med[new]['splitting Compiled'] / med[new]['splitting gravity']:.3f}")
    else:
        m = med[None]
        print(f"{'case':<20} {'ns':>9}")
        for n in names:
            print(f"{n:<20} {m[n]:>9.1f}")
        print(f"Compiled / built-in: simulate {m['simulate Compiled'] / m['simulate gravity']:.3f}, "
              f"ensemble {m['ensemble Compiled'] / m['ensemble gravity']:.3f}, "
              f"splitting {m['splitting Compiled'] / m['splitting gravity']:.3f}")
    print(json.dumps({"medians": {str(k): v for k, v in med.items()}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
