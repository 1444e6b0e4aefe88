"""Compile lgvi's GPU kernels to PTX without a GPU: the CUDA target's typing and code generation.

Usage::

    python benchmarks/gpu_ptx.py                 # all three kernels for sm_90 (H100)
    python benchmarks/gpu_ptx.py --cc 8.0 free   # one kernel, another compute capability

Needs Numba's CUDA target and NVVM (a CUDA toolkit, or ``numba-cuda[cu12]``'s libraries); no GPU,
no driver. For each kernel of :mod:`lgvi._kernels.cuda_kernels` (the free body, the torque models,
a user's ``Compiled`` model) it builds the arguments a :class:`lgvi.gpu.CudaRun` would launch it
with, compiles the kernel and every CPU kernel it calls for the GPU, and prints the PTX's size, the
compile time, and the number of fused multiply-adds (``fma.rn.f64``: NVVM contracts ``a * b + c``,
the reason a GPU's numbers differ from the CPU's in the last bits) beside the plain multiplies.
This is the check that the CPU kernels stay compilable for the GPU; the simulator (the test suite)
runs them as CPU code and cannot see a construct the CUDA target refuses.
"""

from __future__ import annotations

import argparse
import time
import types

import numba
import numpy as np

import lgvi
from lgvi import gpu
from lgvi.torques import Compiled, LinearDamping, UniformGravity

gpu.numpy_shim()          # before numba.cuda loads (NumPy 2.5 and numba-cuda: see docs/gpu.md)
from numba import cuda  # noqa: E402


@numba.njit
def spring(t, R, Pi, p):
    return (-p[0] * R[2, 1], p[0] * R[2, 0], 0.0)


class HostArrays:
    """Stands in for ``numba.cuda`` in :class:`lgvi.gpu.CudaRun`: host arrays have the device arrays' types."""

    jit = cuda.jit

    @staticmethod
    def to_device(a):
        return np.ascontiguousarray(a)

    @staticmethod
    def device_array(shape, dtype=np.float64):
        return np.empty(shape, dtype)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("kernels", nargs="*", default=["free", "forced", "user"])
    ap.add_argument("--cc", default="9.0", help="compute capability (default 9.0, an H100)")
    args = ap.parse_args()
    cc = tuple(int(x) for x in args.cc.split("."))
    # the device functions a kernel calls are compiled for the current device's compute capability;
    # there is none here, so the one asked for stands in (Numba's own attribute, a development check)
    import numba.cuda.dispatcher as dispatcher

    dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=cc)
    gpu.cuda_module = lambda: HostArrays()
    gpu.simulator = lambda cuda=None: False
    B = 4
    rng = np.random.default_rng(0)
    R0 = lgvi.so3.exp(0.3 * rng.normal(size=(B, 3)))
    w0 = rng.normal(size=(B, 3))
    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    schemes = {
        "free": dict(),
        "forced": dict(torque=UniformGravity(1.0, [0, 0, 0.3]) + LinearDamping([0.1, 0.1, 0.1]), forcing="symmetric",
                       order=4),
        "user": dict(torque=Compiled(spring, params=np.ones((B, 1)))),
    }
    print(f"Numba {numba.__version__}, target sm_{cc[0]}{cc[1]}")
    print(f"{'kernel':<8} {'PTX chars':>10} {'compile s':>10} {'fma.rn.f64':>11} {'mul.f64':>8}")
    for name in args.kernels:
        opts = schemes[name]
        s = lgvi.ensemble.EnsembleSetup(body, R0, None, w0, h=0.01, steps=10, method="cayley", tol=1e-14, max_iter=50,
                                 alpha=1.0, save_every=1, t0=0.0, order=opts.get("order", 2), composition=None,
                                 threads=None, torque=opts.get("torque"), forcing=opts.get("forcing", "paper"))
        run = gpu.CudaRun(s)
        sig = tuple(numba.typeof(a) for a in run._args(10))
        t = time.perf_counter()
        ptx, _ = cuda.compile_ptx(run.kernel.py_func, sig, cc=cc)
        print(f"{name:<8} {len(ptx):>10} {time.perf_counter() - t:>10.1f} {ptx.count('fma.rn.f64'):>11} "
              f"{ptx.count('mul.f64'):>8}", flush=True)


if __name__ == "__main__":
    main()
