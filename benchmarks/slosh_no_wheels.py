"""Write ``benchmarks/slosh_no_wheels.npz``: two slosh runs of the code before the slosh kernel took
reaction wheels (commit 864252c), for ``tests/test_slosh_wheels.py``, which checks that the kernel with
wheels, run without them, gives the same numbers.

Run it with that commit's sources first on the path::

    mkdir -p /tmp/before && git archive 864252c src | tar -x -C /tmp/before
    PYTHONPATH=/tmp/before/src python benchmarks/slosh_no_wheels.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import lgvi

#: The runs (shared with the test): damped at order 2, undamped at order 4.
HUB = ([900.0, 800.0, 600.0], 1500.0, [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]], [0.3, 0.4], [40.0, 60.0])
START = dict(R0=lgvi.so3.exp(np.array([0.3, -1.2, 2.0])), q0=[[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]],
             qdot0=[[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]], omega0=[0.3, -0.2, 0.5])
RUNS = {"damped2": dict(damping=[30.0, 50.0], h=0.01, steps=400, save_every=100, order=2),
        "free4": dict(h=0.02, steps=400, save_every=100, order=4)}


def run(name: str) -> lgvi.SloshTrajectory:
    s = dict(START)
    return lgvi.simulate_slosh(*HUB, s.pop("R0"), s.pop("q0"), s.pop("qdot0"), **s, **RUNS[name])


def main() -> None:
    out = {}
    for name in RUNS:
        tr = run(name)
        for f in ("R", "Pi", "q", "pi"):
            out[f"{name}_{f}"] = getattr(tr, f)
    path = Path(__file__).with_suffix(".npz")
    np.savez(path, version=np.array(lgvi.__version__), **out)
    print(f"wrote {path} with lgvi {lgvi.__version__} from {lgvi.__file__}")


if __name__ == "__main__":
    main()
