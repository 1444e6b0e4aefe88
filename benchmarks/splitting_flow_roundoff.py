"""Round-off of many exact free flows (``scheme="splitting"``, Strang, no torque) near and away from the
separatrix: the attitude against one flow over the whole time, and the drift of ``|Pi|^2`` and ``2E``.

Usage::

    python benchmarks/splitting_flow_roundoff.py                            # the lgvi this Python imports
    python benchmarks/splitting_flow_roundoff.py --compare OLD/src NEW/src  # two source trees, side by side
    python benchmarks/splitting_flow_roundoff.py --quick                    # 10000 flows (a smoke run)

Each case runs ``--flows`` steps of ``lgvi.simulate(..., scheme="splitting", order=2,
composition="strang")`` (one exact flow of ``h`` a step) for each step ``h`` in ``--steps`` and
prints the median and the largest over them of ``att``, the angle (rad) between the final attitude and
one :func:`lgvi.splitting.free_flow` over ``flows * h``, and the largest of ``dL2`` and ``dE`` the largest relative change of
``|Pi|^2`` and ``2E`` over ten saved points. Round-off near the separatrix depends on where the
constants fall between floats, so single cases vary by 10x between nearby ``h``: compare the trend,
not one number. Cases: the CubeSat, ``J = (1, 2, 3)`` with ``Pi = (2, 0.3, 0.6)`` (far) and
``(0.3, 2, 0.6)`` (``m = 0.97``), and ``Pi = (s (1 + d), 2, 0.6)`` with ``s = 0.6/sqrt(3)`` on the
separatrix and ``d = -+1e-3, -+1e-6`` (the orbits about the smallest and the largest moment's axis).
"""

from __future__ import annotations

import argparse
import math

from _trees import run_child  # benchmarks/_trees.py (the script's folder is on the path)

S = 0.6 / math.sqrt(3.0)
#: case -> (moments, Pi0, step scale)
CASES: dict[str, tuple[list[float], list[float], float]] = {
    "CubeSat": ([0.0433, 0.0418, 0.0067], [0.003464, -0.002508, 0.000603], 6.0 / 0.7),
    "J=(1,2,3) Pi=(2,0.3,0.6)": ([1.0, 2.0, 3.0], [2.0, 0.3, 0.6], 1.0),
    "J=(1,2,3) Pi=(0.3,2,0.6)": ([1.0, 2.0, 3.0], [0.3, 2.0, 0.6], 1.0),
    "separatrix d=-1e-3": ([1.0, 2.0, 3.0], [S * (1.0 - 1e-3), 2.0, 0.6], 1.0),
    "separatrix d=+1e-3": ([1.0, 2.0, 3.0], [S * (1.0 + 1e-3), 2.0, 0.6], 1.0),
    "separatrix d=-1e-6": ([1.0, 2.0, 3.0], [S * (1.0 - 1e-6), 2.0, 0.6], 1.0),
    "separatrix d=+1e-6": ([1.0, 2.0, 3.0], [S * (1.0 + 1e-6), 2.0, 0.6], 1.0),
}

CHILD = """
import json

import numpy as np
import lgvi
out = {{}}
N = {flows}
for name, (moments, Pi0, scale) in {cases!r}.items():
    body = lgvi.RigidBody(moments)
    J = np.array(moments)
    att = []
    dl2 = de = 0.0
    for h0 in {steps!r}:
        h = h0 * scale
        tr = lgvi.simulate(body, np.eye(3), Pi0, h=h, steps=N, save_every=N // 10, scheme="splitting", order=2,
                           composition="strang")
        L2 = (tr.Pi ** 2).sum(axis=1)
        E = (tr.Pi ** 2 / J).sum(axis=1)
        R1, _ = lgvi.splitting.free_flow(body, np.eye(3), Pi0, h * N)
        att.append(float(np.linalg.norm(lgvi.so3.log(R1.T @ tr.R[-1]))))
        dl2 = max(dl2, float(np.abs(L2 / L2[0] - 1.0).max()))
        de = max(de, float(np.abs(E / E[0] - 1.0).max()))
    out[name] = (float(np.median(att)), max(att), dl2, de)
print(json.dumps(out))
"""


def measure(src: str | None, flows: int, steps: list[float]) -> dict[str, list[float]]:
    return run_child(src, CHILD.format(cases=CASES, flows=flows, steps=steps))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--compare", nargs=2, metavar=("OLD", "NEW"), help="two source trees (their src folders)")
    ap.add_argument("--flows", type=int, default=100000, help="flows (steps) a run")
    ap.add_argument("--steps", type=float, nargs="+", default=[0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3], help="steps h (times the case's scale)")
    ap.add_argument("--quick", action="store_true", help="10000 flows, one step (a smoke run)")
    args = ap.parse_args(argv)
    flows = 10000 if args.quick else args.flows
    steps = [0.7] if args.quick else args.steps
    print(f"{flows} flows, steps {steps}; att: median and largest over the steps, dL2, dE: largest")
    if not args.compare:
        res = measure(None, flows, steps)
        print(f"{'case':26s} {'att med':>9s} {'att max':>9s} {'dL2':>9s} {'dE':>9s}")
        for name, (med, att, dl2, de) in res.items():
            print(f"{name:26s} {med:9.1e} {att:9.1e} {dl2:9.1e} {de:9.1e}")
        return 0
    old = measure(args.compare[0], flows, steps)
    new = measure(args.compare[1], flows, steps)
    print(f"{'case':26s} {'att med':>17s} {'att max':>17s} {'dL2':>17s} {'dE':>17s}   (old new)")
    for name in CASES:
        print(f"{name:26s} " + " ".join(f"{old[name][i]:8.1e} {new[name][i]:8.1e}" for i in range(4)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
