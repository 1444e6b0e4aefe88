"""Environment and disturbance components: compiled cost per evaluation, and all of them against a
gyrostat step, measured in the same run.

Usage::

    python benchmarks/bench_environment.py            # 2e5 evaluations per case, 7 rounds
    python benchmarks/bench_environment.py --quick    # reduced size (no timing assertions anywhere)

Each kind runs its compiled ``step`` (through the family's dispatcher, as the loop will call it)
over 1000 bus rows held in cache, repeated, at times 0.1 s apart (the sun's series then runs once
every 600 evaluations; "sun (series every call)" runs it at every one); the time is the process's CPU time (one thread) per
evaluation, the median over rounds, the cases interleaved round by round so a shared machine's load
falls on all alike. "all together" is the sum of one evaluation of each kind a 6U needs per step
(sun, conical shadow, exponential atmosphere, facet drag and facet radiation pressure on 10
facets, residual dipole); "gyrostat step" is one step of ``lgvi.simulate`` with 3 reaction wheels
(motors off, ``J = diag(1, 2, 3)``, ``h = 0.01``, as ``bench_gyrostat.py``), measured in the same
rounds; the ratio is taken within each round, then the median.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import lgvi  # noqa: E402
from lgvi._kernels.environment_components import disturbance_many, environment_many  # noqa: E402
from lgvi.components import COMPONENT_KINDS  # noqa: E402
from lgvi.environment._evaluate import layout  # noqa: E402
from lgvi.environment import ExponentialAtmosphere, Shadow, Sun, TabulatedAtmosphere  # noqa: E402
from lgvi.spacecraft import FacetDrag, FacetSRP, ResidualDipole  # noqa: E402

#: The 6U's facets of the Basilisk fixture (benchmarks/basilisk_environment.py): 6 faces, 2 panels (both sides)
FACETS = np.load(Path(__file__).with_name("basilisk_environment.npz"))

ROWS = 1000


def _bus(component, rng):
    """(ROWS, nbus) buses with plausible read signals, the offsets, the times."""
    kind = COMPONENT_KINDS[component.kind]
    sizes, offsets = layout(kind)
    buses = np.zeros((ROWS, int(sum(sizes))))
    fill = {
        "r_N": lambda: rng.normal(size=(ROWS, 3)) * 4e6 + [0.0, 0.0, 0.0],
        "v_N": lambda: rng.normal(size=(ROWS, 3)) * 5e3,
        "R": lambda: lgvi.so3.exp(rng.normal(size=(ROWS, 3))).reshape(ROWS, 9),
        "density": lambda: np.full((ROWS, 1), 1e-12),
        "v_rel_N": lambda: rng.normal(size=(ROWS, 3)) * 5e3,
        "sun_N": lambda: (lambda u: u / np.linalg.norm(u, axis=1, keepdims=True))(rng.normal(size=(ROWS, 3))),
        "sun_distance": lambda: np.full((ROWS, 1), 1.496e11),
        "shadow": lambda: np.ones((ROWS, 1)),
        "B_N": lambda: rng.normal(size=(ROWS, 3)) * 3e-5,
    }
    for name, off, size in zip(kind.reads, offsets, sizes):
        v = fill[name]()
        if name == "r_N":
            v *= (7.0e6 / np.linalg.norm(v, axis=1))[:, None]
        buses[:, off:off + size] = v
    return kind, buses, offsets, 0.1 * np.arange(ROWS)


def components():
    fac = FACETS
    epoch = dt.datetime(2026, 3, 20)
    table = TabulatedAtmosphere(0.0, 10.0, 1e-12 * np.exp(0.1 * np.sin(np.arange(600) / 50.0)))
    return {
        "sun": Sun(epoch),
        "shadow (conical)": Shadow("conical"),
        "exponential atmosphere": ExponentialAtmosphere.from_reference(500e3, 6.967e-13, 63822.0),
        "tabulated atmosphere": table,
        "facet drag (10 facets)": FacetDrag(fac["fac_area"], fac["fac_normal"], fac["fac_centre"], fac["fac_cd"]),
        "facet SRP (10 facets)": FacetSRP(fac["fac_area"], fac["fac_normal"], fac["fac_centre"],
                                          absorbed=1.0 - fac["fac_specular"] - fac["fac_diffuse"],
                                          specular=fac["fac_specular"], diffuse=fac["fac_diffuse"]),
        "residual dipole": ResidualDipole([0.01, -0.004, 0.007]),
    }


TOGETHER = ("sun", "shadow (conical)", "exponential atmosphere", "facet drag (10 facets)", "facet SRP (10 facets)",
            "residual dipole")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size")
    ap.add_argument("--evals", type=int, default=200_000, help="evaluations per case and round")
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()
    evals, rounds = (20_000, 3) if args.quick else (args.evals, args.rounds)
    repeat = max(1, evals // ROWS)
    times = [0.1 * ROWS * k + 0.1 * np.arange(ROWS) for k in range(repeat)]   # steps of 0.1 s, as a loop
    rng = np.random.default_rng(0)
    setups = {}
    comp0 = ResidualDipole([0.0, 0.0, 0.0])
    kind, buses, w, t = _bus(comp0, rng)
    setups["dispatch only (no kind)"] = (disturbance_many, -1, t, buses, comp0.params(), comp0.state0(), w)
    for name, comp in components().items():
        kind, buses, w, t = _bus(comp, rng)
        run = environment_many if kind.family == "environment" else disturbance_many
        p = np.ascontiguousarray(comp.params())
        s = comp.state0()
        assert not np.any(run(kind.code, t, buses, p, s, w))      # compiles, and every row is in range
        if name == "sun":
            setups["sun (series every call)"] = (run, kind.code, t, buses, np.array([p[0], 0.0]), s.copy(), w)
        setups[name] = (run, kind.code, t, buses, p, s, w)
    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    wheels = lgvi.ReactionWheels(np.eye(3), 0.02, speed0=[10.0, -5.0, 3.0])
    gsteps = max(1000, evals // 4)
    gyro = dict(omega0=[0.3, 1.0, 0.2], h=0.01, steps=gsteps, wheels=wheels, save_every=100)
    lgvi.simulate(body, np.eye(3), **gyro)                            # compile
    per: dict[str, list[float]] = {name: [] for name in setups}
    per["gyrostat step"] = []
    ratio: list[float] = []
    for _ in range(rounds):
        for name, (run, code, t, buses, p, s, w) in setups.items():
            t0 = time.process_time()
            for tk in times:
                run(code, tk, buses, p, s, w)
            per[name].append((time.process_time() - t0) / (repeat * ROWS) * 1e9)
        t0 = time.process_time()
        lgvi.simulate(body, np.eye(3), **gyro)
        per["gyrostat step"].append((time.process_time() - t0) / gsteps * 1e9)
        ratio.append(sum(per[n][-1] for n in TOGETHER) / per["gyrostat step"][-1])
    print(f"environment and disturbance components: CPU ns per evaluation, median of {rounds} rounds "
          f"({repeat * ROWS} evaluations each); the machine may be loaded by other jobs")
    base = statistics.median(per["dispatch only (no kind)"])
    print(f"{'case':<28}{'ns/eval':>10}{'min':>10}{'max':>10}{'net':>10}")
    for name, xs in per.items():
        net = statistics.median(xs) - base if name != "gyrostat step" else float("nan")
        print(f"{name:<28}{statistics.median(xs):>10.1f}{min(xs):>10.1f}{max(xs):>10.1f}{net:>10.1f}")
    print("net: the median less the dispatch-only case (a call of the dispatcher on a bus row that runs no kind)")
    together = [sum(per[n][i] for n in TOGETHER) for i in range(rounds)]
    print(f"{'all together (6U, per step)':<28}{statistics.median(together):>10.1f}{min(together):>10.1f}"
          f"{max(together):>10.1f}{statistics.median(together) - len(TOGETHER) * base:>10.1f}")
    print(f"all together / gyrostat step: {statistics.median(ratio):.2f} (median of the rounds' ratios; "
          f"min {min(ratio):.2f}, max {max(ratio):.2f})")
    return 0


if __name__ == "__main__":
    from lgvi.systems.loop_keywords import as_given

    with as_given():   # wheels=, controller= here measure the gyrostat, as before (docs/loop.md)
        sys.exit(main())
