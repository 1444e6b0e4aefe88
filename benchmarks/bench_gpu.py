"""GPU ensembles beside the CPU ensemble on all cores: body-steps per second, in the same run.

Usage::

    python benchmarks/bench_gpu.py                 # on a machine with an NVIDIA GPU (about 5 minutes)
    NUMBA_ENABLE_CUDASIM=1 python benchmarks/bench_gpu.py --smoke    # Numba's CUDA simulator, tiny sizes

Cases (``h = 0.01``, ``tol = 1e-14``, saved sparsely: ``save_every = steps``, the first and last
state of each body): the free body ``J = diag(1, 2, 3)`` with ``cayley`` and with ``newton``; the
heavy top (``UniformGravity``, order 2); the free body's inertia in a circular orbit
(``GravityGradient``, ``newton``); the heavy top with the user's compiled gravity
(:class:`lgvi.torques.Compiled`, per-body ``params``). Rates ``(0.3, 1, 0.2) rad/s`` perturbed
by 1 % and attitudes by 2 degrees per body (the top: ``(4.14, 4.14, 4.14)``).

The GPU runs ``--bodies`` bodies, the CPU (``simulate_ensemble`` on all of Numba's threads: the
SIMD lockstep path for the free body with ``cayley``) ``--cpu-bodies``, the GPU's first ones.
Columns: ``cpu body-steps/s`` and ``gpu body-steps/s`` are the bodies times the steps over the
time spent advancing them (the compiled chunks on the CPU; the kernel launches and the copies of
the samples back to the host on the GPU), the median of ``--repeat`` runs after an untimed
warm-up (compilation excluded, its time printed as ``gpu compile s``), the two devices
alternating run by run; ``gpu/cpu`` their ratio; ``gpu call s`` the median wall time of the whole
``simulate_ensemble`` call (validation, set-up and results on the host included); ``max |dR|``
the largest difference of the final attitudes of the bodies both devices ran (0: bit for bit, as
in the simulator; on a GPU the compiler fuses multiply-adds, so expect round-off growth) and
``rel d|Pi|``, ``rel dE`` the largest change over the run of ``|Pi|`` and of the kinetic energy of
any GPU body, relative (free body only: both are invariants; ``-`` otherwise). Times are wall
clock: a GPU's time is not CPU time, and the CPU ensemble's threads would count once each.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numba  # noqa: E402

import lgvi  # noqa: E402
from lgvi import ensemble, gpu  # noqa: E402
from lgvi.torques import Compiled, GravityGradient, UniformGravity  # noqa: E402


@numba.njit
def user_gravity(t, R, Pi, p):
    """The user's uniform gravity (``p`` = mass g com), as in docs/architecture.md: a tuple, which
    the GPU needs (nothing allocates there)."""
    return (R[2, 1] * p[2] - R[2, 2] * p[1], R[2, 2] * p[0] - R[2, 0] * p[2], R[2, 0] * p[1] - R[2, 1] * p[0])


@numba.njit
def user_gravity_potential(t, R, p):
    return R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2]


J = (1.0, 2.0, 3.0)
TOP = (0.13, 0.28, 0.17)
GRAVITY = UniformGravity(1.0, [0.0, 0.0, 0.3])
H = 0.01


def cases(bodies: int) -> dict[str, dict]:
    p = GRAVITY.mass * GRAVITY.g * GRAVITY.com
    return {
        "free body cayley": dict(inertia=J, method="cayley"),
        "free body newton": dict(inertia=J, method="newton"),
        "heavy top": dict(inertia=TOP, method="cayley", torque=GRAVITY, top=True),
        "gravity gradient": dict(inertia=J, method="newton", torque=GravityGradient(398600.4418, 7000.0)),
        "user model": dict(inertia=TOP, method="cayley", top=True,
                           torque=Compiled(user_gravity, potential=user_gravity_potential, params=np.tile(p, (bodies, 1)))),
    }


def initial(bodies: int, top: bool) -> tuple[np.ndarray, np.ndarray]:
    """Body ``b``'s initial state whatever ``bodies`` (the CPU's bodies are the GPU's first ones)."""
    R0 = lgvi.so3.exp(np.deg2rad(2.0) * np.random.default_rng(0).normal(size=(bodies, 3)))
    w = np.array([4.14, 4.14, 4.14] if top else [0.3, 1.0, 0.2])
    return R0, w * (1.0 + 0.01 * np.random.default_rng(1).normal(size=(bodies, 3)))


class Timer:
    """Time spent in a run's ``advance`` (the compiled chunks, or the kernel launches and copies)."""

    def __init__(self, cls: type) -> None:
        self.cls, self.seconds = cls, 0.0

    def __enter__(self) -> "Timer":
        self.inner = inner = self.cls.__dict__["advance"]

        def advance(run, *args):
            t = time.perf_counter()
            try:
                return inner(run, *args)
            finally:
                self.seconds += time.perf_counter() - t

        self.cls.advance = advance
        return self

    def __exit__(self, *exc) -> None:
        self.cls.advance = self.inner


TIMERS = {"cpu": Timer(ensemble.LocalRun), "cuda": Timer(gpu.CudaRun)}


def run(device: str, case: dict, bodies: int, steps: int, torque) -> tuple[float, float, object]:
    R0, w0 = initial(bodies, case.get("top", False))
    Pi0 = np.asarray(case["inertia"]) * w0      # J omega0 for a diagonal J, exact (omega0= would convert body by body)
    with TIMERS[device] as timer:
        timer.seconds = 0.0
        t = time.perf_counter()
        ens = lgvi.simulate_ensemble(case["inertia"], R0, Pi0, h=H, steps=steps, save_every=steps,
                                     method=case["method"], torque=torque, device=device)
        return timer.seconds, time.perf_counter() - t, ens


def subset(torque, n: int):
    """The model for the first ``n`` bodies (a Compiled model's per-body params cut to ``n`` rows)."""
    if isinstance(torque, Compiled):
        return Compiled(torque.moment_func, potential=torque.potential_func, params=torque.params[:n])
    return torque


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bodies", type=int, default=1 << 20, help="bodies on the GPU (default 2^20)")
    ap.add_argument("--cpu-bodies", type=int, default=16384, help="bodies on the CPU (default 16384)")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--case", action="append", help="run only this case (repeatable)")
    ap.add_argument("--tpb", type=int, default=gpu.THREADS_PER_BLOCK,
                    help=f"GPU threads per block (default lgvi.gpu.THREADS_PER_BLOCK = {gpu.THREADS_PER_BLOCK})")
    ap.add_argument("--smoke", action="store_true", help="tiny sizes, one repeat (the simulator)")
    args = ap.parse_args(argv)
    gpu.THREADS_PER_BLOCK = args.tpb
    if args.smoke:
        args.bodies, args.cpu_bodies, args.steps, args.repeat = 8, 4, 6, 1
    cuda = gpu.cuda_module()
    sim = gpu.simulator(cuda)
    if sim:
        where = "Numba's CUDA simulator (NUMBA_ENABLE_CUDASIM=1): checks the pipeline, the timings are not GPU figures"
    else:
        dev = cuda.get_current_device()
        name = dev.name.decode() if isinstance(dev.name, bytes) else dev.name
        where = f"GPU {name}, compute capability {dev.compute_capability}"
    print(f"device: {where}")
    print(f"cpu: {os.cpu_count()} cores, {numba.get_num_threads()} Numba threads; load average before "
          f"{os.getloadavg()[0]:.1f}; numpy {np.__version__}, numba {numba.__version__}")
    print(f"gpu bodies {args.bodies} ({args.tpb} threads a block), cpu bodies {args.cpu_bodies} (the gpu's first), "
          f"steps {args.steps}, h {H}, median of {args.repeat} (wall clock, devices alternating)\n")
    head = (f"{'case':<18} | {'bodies':>8} | {'steps':>6} | {'cpu body-steps/s':>16} | {'gpu body-steps/s':>16} | "
            f"{'gpu/cpu':>8} | {'gpu call s':>10} | {'gpu compile s':>13} | {'rel d|Pi|':>9} | {'rel dE':>9} | "
            f"{'max |dR|':>8}")
    print(head)
    print("-" * len(head))
    table = cases(args.bodies)
    for name in args.case or list(table):
        case = table[name]
        gpu_torque = case.get("torque")
        cpu_torque = subset(gpu_torque, args.cpu_bodies)
        t = time.perf_counter()
        run("cuda", case, min(args.bodies, 256), 2, subset(gpu_torque, min(args.bodies, 256)))   # compile
        compile_s = time.perf_counter() - t
        run("cpu", case, min(args.cpu_bodies, 256), 2, subset(gpu_torque, min(args.cpu_bodies, 256)))
        cpu_adv, gpu_adv, gpu_call = [], [], []
        for _ in range(args.repeat):
            a, _, cpu_ens = run("cpu", case, args.cpu_bodies, args.steps, cpu_torque)
            cpu_adv.append(a)
            a, c, gpu_ens = run("cuda", case, args.bodies, args.steps, gpu_torque)
            gpu_adv.append(a)
            gpu_call.append(c)
        cpu_rate = args.cpu_bodies * args.steps / statistics.median(cpu_adv)
        gpu_rate = args.bodies * args.steps / statistics.median(gpu_adv)
        dR = float(np.abs(gpu_ens.R[:args.cpu_bodies, -1] - cpu_ens.R[:, -1]).max())
        if gpu_torque is None:
            norm = np.linalg.norm(gpu_ens.Pi, axis=-1)
            energy = gpu_ens.kinetic_energy
            dpi = f"{float((np.abs(norm[:, -1] - norm[:, 0]) / norm[:, 0]).max()):9.1e}"
            de = f"{float((np.abs(energy[:, -1] - energy[:, 0]) / energy[:, 0]).max()):9.1e}"
        else:
            dpi = de = f"{'-':>9}"
        print(f"{name:<18} | {args.bodies:>8} | {args.steps:>6} | {cpu_rate:>16.3e} | {gpu_rate:>16.3e} | "
              f"{gpu_rate / cpu_rate:>8.1f} | {statistics.median(gpu_call):>10.3f} | {compile_s:>13.1f} | {dpi} | "
              f"{de} | {'0' if dR == 0.0 else f'{dR:.1e}':>8}", flush=True)
    print(f"\nload average after {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
