"""Core benchmark: steps per second of the attitude LGVI, with ratios measured in the same run.

Usage::

    python benchmarks/run.py            # full size (1e6 free-body steps, as quoted in the README)
    python benchmarks/run.py --quick    # reduced size, for CI (no timing assertions)

Every figure is the median of ``--repeat`` runs after a warm-up; ratios are taken between numbers
measured in this process, so machine noise affects both sides alike.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import lgvi
from lgvi.verification import reference

J = (1.0, 2.0, 3.0)
OMEGA0 = (0.3, 1.0, 0.2)
H = 0.01


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def subprocess_seconds(code: str, env: dict[str, str]) -> float:
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced size for CI")
    parser.add_argument("--repeat", type=int, default=None, help="timed runs per entry (median)")
    args = parser.parse_args(argv)
    steps = 20_000 if args.quick else 1_000_000
    ref_steps = 50 if args.quick else 300
    cb_steps = 2_000 if args.quick else 100_000
    repeat = args.repeat or (2 if args.quick else 5)

    body = lgvi.RigidBody(J)
    Pi0 = body.J @ np.array(OMEGA0)
    rows = []

    def run(method, save_every=1, n=steps, torque=None):
        return lgvi.simulate(body, np.eye(3), Pi0, h=H, steps=n, method=method, save_every=save_every, torque=torque)

    for method in ("newton", "cayley", "paper"):
        run(method, n=100)
        t = median_time(lambda: run(method), repeat)
        traj = run(method, n=1000)
        rows.append((f"free body, {method}, save_every=1", steps, steps / t, float(traj.iterations.mean())))
    t = median_time(lambda: run("newton", save_every=100), repeat)
    rows.append(("free body, newton, save_every=100", steps, steps / t, float("nan")))

    t_ref = median_time(lambda: reference.simulate(body.J, np.eye(3), Pi0, H, ref_steps), max(1, repeat // 2))
    rows.append(("pure-NumPy reference (paper's iteration)", ref_steps, ref_steps / t_ref, float("nan")))

    const = np.array([0.0, 0.0, 0.01])
    run("newton", n=100, torque=lambda t, R, Pi: const)
    t_cb = median_time(lambda: run("newton", n=cb_steps, torque=lambda t, R, Pi: const), max(1, repeat // 2))
    rows.append(("Python callable torque (constant), newton", cb_steps, cb_steps / t_cb, float("nan")))

    newton_rate = rows[0][2]
    print(f"lgvi {lgvi.__version__} core benchmark: J = diag{J}, omega0 = {OMEGA0}, h = {H}, median of {repeat}")
    print(f"{'case':<46} {'steps':>9} {'steps/s':>11} {'vs newton':>10} {'iter/step':>10}")
    for name, n, rate, its in rows:
        its_s = f"{its:10.2f}" if its == its else f"{'':>10}"
        print(f"{name:<46} {n:>9d} {rate:>11.3e} {rate / newton_rate:>10.3g} {its_s}")
    print(f"compiled newton / pure-NumPy reference: {newton_rate / rows[4][2]:.0f}x")

    # start-up costs, each in a fresh interpreter
    env = dict(os.environ)
    t_import = subprocess_seconds("import time; t=time.perf_counter(); import lgvi; print(time.perf_counter()-t)", env)
    first_call = ("import time, numpy as np, lgvi; b=lgvi.RigidBody([1.,2.,3.]); t=time.perf_counter(); "
                  "lgvi.simulate(b, np.eye(3), [0.3,2.,0.6], h=0.01, steps=10); print(time.perf_counter()-t)")
    t_warm = subprocess_seconds(first_call, env)
    with tempfile.TemporaryDirectory() as cache:
        cold_env = dict(env, NUMBA_CACHE_DIR=cache)
        t_cold = subprocess_seconds(first_call, cold_env)
    print(f"import lgvi: {t_import:.3f} s; first simulate call, warm cache: {t_warm:.3f} s; "
          f"cold cache (compilation): {t_cold:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
