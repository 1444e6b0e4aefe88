"""Torque-model benchmark: cost per step of the built-in models against the free body.

Usage::

    python benchmarks/bench_torques.py            # 5e5 steps per run, 7 rounds
    python benchmarks/bench_torques.py --quick    # reduced size, for CI (no timing assertions)

Every case runs the same body (Lee's 3D pendulum inertia, ``J = diag(0.13, 0.28, 0.17)``) from
the same initial state with ``h = 0.01`` on one core. The cases are interleaved round by round
and every ratio is taken between runs of the same round (then the median over rounds), so the
noise of a shared machine affects both sides of a ratio alike. ``iters/step`` is the mean number
of solver updates per step (the solver dominates the cost, and different motions need
different numbers of updates, which the ``cost per update`` ratio factors out).

The gravity cases are the 3D pendulum started inverted, as when the published figures were
measured: centre of mass 0.3 m *above* the pivot at ``R0 = I`` (``com = +0.3 e3``, lgvi's ``e3``
up), ``E0 = 7.91 J``. Lee, Leok and McClamroch's own start hangs (``com = -0.3 e3`` here,
``E0 = 2.03 J``, ``examples/pendulum3d.py``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numba  # noqa: E402

import lgvi  # noqa: E402
from lgvi.torques import (  # noqa: E402
    AttitudePD,
    Compiled,
    Constant,
    GravityGradient,
    LinearDamping,
    UniformGravity,
)

J = (0.13, 0.28, 0.17)
OMEGA0 = (4.14, 4.14, 4.14)
H = 0.01


@numba.njit
def user_gravity(t, R, Pi, p):
    """A user's compiled uniform gravity: (R^T e3) x p, p = mass g com."""
    return (R[2, 1] * p[2] - R[2, 2] * p[1], R[2, 2] * p[0] - R[2, 0] * p[2], R[2, 0] * p[1] - R[2, 1] * p[0])


@numba.njit
def user_gravity_potential(t, R, p):
    return R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2]


USER = "user's compiled gravity (Compiled)"


def cases():
    gravity = UniformGravity(1.0, [0.0, 0.0, 0.3])   # inverted start (Lee's hanging start: -0.3 e3)
    user = Compiled(user_gravity, potential=user_gravity_potential, params=gravity.mass * gravity.g * gravity.com)
    return [
        ("free body", None, {}),
        ("3D pendulum, inverted start (UniformGravity)", gravity, {}),
        ("GravityGradient", GravityGradient(mu=1.0, radius=1.0), {}),
        ("Constant", Constant([1e-4, -2e-4, 3e-4]), {}),
        ("LinearDamping, paper", LinearDamping(1e-6), {}),
        ("LinearDamping, symmetric", LinearDamping(1e-6), {"forcing": "symmetric"}),
        ("AttitudePD, symmetric", AttitudePD(1e-6, 1e-6), {"forcing": "symmetric"}),
        ("gravity + damping, symmetric", gravity + LinearDamping(1e-6), {"forcing": "symmetric"}),
        ("3D pendulum, inverted, order 4 (per step)", gravity, {"order": 4}),
        ("3D pendulum, inverted, order 6 (per step)", gravity, {"order": 6}),
        (USER, user, {}),
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced size for CI")
    parser.add_argument("--rounds", type=int, default=None, help="interleaved rounds (median)")
    parser.add_argument("--steps", type=int, default=None, help="steps per run")
    args = parser.parse_args(argv)
    steps = args.steps or (20_000 if args.quick else 500_000)
    rounds = args.rounds or (2 if args.quick else 7)
    save_every = 1000 if steps % 1000 == 0 else 1

    body = lgvi.RigidBody(J)
    todo = cases()

    def run(torque, kw, n):
        return lgvi.simulate(body, np.eye(3), omega0=OMEGA0, h=H, steps=n, torque=torque,
                             save_every=save_every if n == steps else 1, **kw)

    for _, torque, kw in todo:  # compile / load from cache
        run(torque, kw, 10)
    times = {name: [] for name, _, _ in todo}
    iters = {}
    for _ in range(rounds):
        for name, torque, kw in todo:
            t0 = time.perf_counter()
            traj = run(torque, kw, steps)
            times[name].append(time.perf_counter() - t0)
            iters[name] = float(traj.iterations.mean())

    free = todo[0][0]
    print(f"lgvi {lgvi.__version__}: {steps} steps of h = {H} per run, median of {rounds} interleaved rounds, "
          f"J = diag{J}, Omega0 = {OMEGA0}")
    print(f"{'case':44s} {'steps/s':>12s} {'x free':>8s} {'iters/step':>11s} {'x free/update':>14s}")
    for name, _, _ in todo:
        rate = steps / statistics.median(times[name])
        ratio = statistics.median(a / b for a, b in zip(times[name], times[free]))
        per_update = ratio * (iters[free] / iters[name]) if iters[name] > 0 else float("nan")
        print(f"{name:44s} {rate:12.4g} {ratio:8.2f} {iters[name]:11.2f} {per_update:14.2f}")
    grav = todo[1][0]
    user = statistics.median(a / b for a, b in zip(times[USER], times[grav]))
    print(f"{USER} / UniformGravity, time per step: {user:.2f} (goal <= 1.5; same motion, bit-identical states)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
