"""Ensembles on one NVIDIA GPU: ``simulate_ensemble(..., device="cuda")``.

The run is the CPU ensemble's (:mod:`lgvi.systems.rigid_body_ensemble`: the same validation, set-up, solver histories,
momentum matrices, sink, progress, Ctrl-C and failure messages, through :func:`lgvi.driver.drive`);
only ``advance`` differs. It launches one kernel of :mod:`lgvi._kernels.cuda_kernels` per chunk of
steps, one body a GPU thread, each thread running the CPU kernels' own per-body function compiled
for the GPU, and brings the chunk's samples back to the host. The device holds the state of every
body and the samples of one chunk, so its memory stays bounded whatever the number of steps
(:data:`DEVICE_SAMPLE_BYTES`).

``numba.cuda`` is imported on the first GPU run, never by ``import lgvi``. The package is Numba's
built-in CUDA target where Numba still ships it (0.68 does, deprecated) or NVIDIA's ``numba-cuda``
(``pip install lgvi[cuda]``), which replaces it when installed. With ``NUMBA_ENABLE_CUDASIM=1`` in
the environment before Numba is imported, the kernels run in Numba's CUDA simulator (no GPU: the
test suite's way; small ensembles only, it runs each GPU thread as a Python thread).
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from ._kernels.codes import OK
from .ensemble import EnsembleSetup, EnsembleTrajectory, LocalRun, LocalSink, provide_device, quiet_function_argument

#: Device memory for one chunk's samples (``R`` and ``Pi``, 96 bytes a body and sample); a chunk
#: holds at least one sample of every body.
DEVICE_SAMPLE_BYTES = 1 << 30
#: Body-substeps per kernel launch at most: about 0.1 s on an H100 (progress and Ctrl-C are
#: honoured between launches).
GPU_CHUNK_BODY_STEPS = 1 << 32
#: Threads per block of the kernels (the step keeps its state in registers; 128 keeps enough of
#: them per thread).
THREADS_PER_BLOCK = 128

_NO_HIST = np.zeros(0)


def numpy_shim() -> bool:
    """Give NumPy back ``np.row_stack`` (an alias of ``np.vstack``) if this NumPy lacks it.

    NumPy 2.5 removed ``row_stack``; ``numba-cuda`` releases that register an implementation of it
    when their array support loads then fail to compile any kernel (``AttributeError``). The alias
    is the documented equivalent. It is set before ``numba.cuda`` is imported and only by a GPU
    run; returns whether it was needed.
    """
    if hasattr(np, "row_stack"):
        return False
    np.row_stack = np.vstack  # type: ignore[attr-defined]
    return True


def cuda_module() -> Any:
    """``numba.cuda``, imported after :func:`numpy_shim`, with a GPU to run on (or the simulator).

    Raises
    ------
    ImportError
        No CUDA target for Numba is installed (names the package to install).
    RuntimeError
        No usable GPU: no CUDA driver, or no device (the message says which, and how to use the
        simulator).
    """
    numpy_shim()
    try:
        from numba import cuda
    except ImportError as exc:
        raise ImportError("device='cuda' needs Numba's CUDA target, which this Numba does not ship: install "
                          "NVIDIA's numba-cuda (pip install 'lgvi[cuda]', or 'numba-cuda[cu12]' to bring the "
                          f"CUDA 12 toolkit libraries too) ({exc})") from exc
    if simulator(cuda):
        return cuda
    if not cuda.is_available():
        try:
            from numba.cuda.cudadrv.driver import driver

            driver.get_device_count()
            reason = "no CUDA GPU was found"
        except Exception as exc:  # the driver's own message: library not found, no device, version
            reason = " ".join(str(exc).split())
        raise RuntimeError(f"device='cuda' needs an NVIDIA GPU with its CUDA driver, and none is usable here: "
                           f"{reason}. Run on the CPU (device='cpu', the default), or set NUMBA_ENABLE_CUDASIM=1 "
                           "before importing lgvi to run the GPU kernels in Numba's simulator (small sizes)")
    return cuda


def simulator(cuda: Any | None = None) -> bool:
    """Whether ``numba.cuda`` is Numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1`` when Numba's CUDA
    target was first imported)."""
    if cuda is None:
        from numba import cuda
    return "simulator" in getattr(cuda.jit, "__module__", "")


class _Host:
    """The simulator's stand-in of a launch argument: the array itself, not a copy (Numba's simulator
    wraps arrays in objects that a CPU-compiled function cannot take; an ``ArgHint`` is passed through)."""

    def __init__(self, cuda: Any) -> None:
        from numba.cuda.args import ArgHint

        class Raw(ArgHint):
            def to_device(self, retr: Any, stream: int = 0) -> Any:
                return self.value

        self.Raw = Raw

    def __call__(self, a: Any) -> Any:
        if isinstance(a, np.ndarray):
            return self.Raw(a)
        inner = getattr(a, "_ary", None)       # the simulator's device array wraps a NumPy array
        return self.Raw(inner) if isinstance(inner, np.ndarray) else a


_USER_KERNELS: dict[Any, Any] = {}


class CudaRun(LocalRun):
    """The bodies of an ensemble on the GPU: a run of :func:`lgvi.driver.drive` (see the module notes)."""
    d: dict[Any, Any]
    cuda: Any

    label = "ensemble"
    lockstep_allowed = False

    def __init__(self, s: EnsembleSetup) -> None:
        self.cuda = cuda = cuda_module()       # before any work: no GPU, no run
        from ._kernels import cuda_kernels as ck

        super().__init__(s, False, getattr(s, "body0", 0))

        self.sim: bool = simulator(cuda)
        self.wrap: Callable[[Any], Any] = _Host(cuda) if self.sim else (lambda a: a)
        B, se = len(s), self.save_every
        stages = 1 if s.legacy else len(s.gam)
        # steps per launch: a multiple of save_every, at most GPU_CHUNK_BODY_STEPS body-substeps and
        # DEVICE_SAMPLE_BYTES of samples (at least one sample)
        by_work = max(1, GPU_CHUNK_BODY_STEPS // (B * stages * se))
        by_memory = max(1, DEVICE_SAMPLE_BYTES // (B * 96))
        self.m: int = max(1, min(by_work, by_memory, max(1, s.steps // se)))
        self.chunk: int = self.m * se
        dev = cuda.to_device
        self.d = d = {}
        for name in ("Jd", "J", "J_inv", "R", "Pi", "G", "its", "res", "status", "fail_step", "fail_res",
                     "fail_its"):
            d[name] = dev(np.ascontiguousarray(getattr(self, name)))
        d["ib"] = dev(np.ascontiguousarray(s.ib))
        d["hist"] = dev(_NO_HIST)
        if not s.legacy:
            for name in ("A", "S", "ia"):
                d[name] = dev(np.ascontiguousarray(getattr(self, name)))
            d["gam"], d["cum"] = dev(np.ascontiguousarray(s.gam)), dev(np.ascontiguousarray(s.cum))
            d["codes"], d["ptab"] = dev(np.ascontiguousarray(s.codes)), dev(np.ascontiguousarray(s.ptab))
            d["params"] = dev(np.ascontiguousarray(s.params))
            d["gidx"] = dev(np.arange(stages, dtype=np.int64))
            d["counts"] = dev(np.zeros(0, dtype=np.int64))
            # the solver's record of a chunk, per body (not kept: the ensemble records totals)
            d["it_rec"] = cuda.device_array((B, self.m), dtype=np.int32)
            d["res_rec"] = cuda.device_array((B, self.m), dtype=np.float64)
        self.user: bool = getattr(s.model, "moment_func", None) is not None
        if self.user:
            m = s.model
            d["table"] = dev(self.user_table())
            key = (m.moment_func, self.sim)
            if key not in _USER_KERNELS:
                from ._kernels.user_kernels import guarded

                # the simulator runs the CPU's compiled code: the guarded cfunc the CPU loops take
                _USER_KERNELS[key] = ck.user_kernel(guarded(m.moment_func) if self.sim else m.moment_func)
            self.kernel: Any = _USER_KERNELS[key]
        else:
            self.kernel = ck.free_kernel if s.legacy else ck.forced_kernel
        d["R_out"] = cuda.device_array((B, self.m, 3, 3))
        d["Pi_out"] = cuda.device_array((B, self.m, 3))
        self.blocks: int = math.ceil(B / THREADS_PER_BLOCK) if not self.sim else math.ceil(B / min(B, 32))
        self.threads_per_block: int = THREADS_PER_BLOCK if not self.sim else min(B, 32)

    def _args(self, n: int) -> tuple:
        s, d, k, se = self.s, self.d, self.k, self.save_every
        out0 = k // se + 1
        common = (s.tol, s.max_iter, s.alpha, se, out0, d["R_out"], d["Pi_out"])
        if self.user:
            m = s.model
            return (d["table"], m.conservative, m.depends_on_momentum, s.code, d["Jd"], d["J"],
                    d["J_inv"], d["ib"], s.h, s.t0, d["gam"], d["cum"], d["ia"], d["A"], d["R"], d["Pi"], d["G"],
                    d["gidx"], d["S"], d["codes"], d["params"], int(s.sym), k, n, *common, d["it_rec"],
                    d["res_rec"], d["its"], d["res"], d["status"], d["fail_step"], d["fail_res"], d["fail_its"],
                    d["hist"], d["counts"])
        tail = (d["its"], d["res"], d["status"], d["fail_step"], d["fail_res"], d["fail_its"], d["hist"])
        if s.legacy:
            return (s.code, d["Jd"], d["ib"], s.h, d["R"], d["Pi"], d["G"], k, n, *common, *tail)
        return (s.code, d["Jd"], d["J"], d["J_inv"], d["ib"], s.h, s.t0, d["gam"], d["cum"], d["ia"], d["A"], d["R"],
                d["Pi"], d["G"], d["gidx"], d["S"], d["codes"], d["ptab"], int(s.sym), k, n, *common, d["it_rec"],
                d["res_rec"], *tail, d["counts"])

    def _launch(self, n: int) -> None:
        args = tuple(self.wrap(a) for a in self._args(n))
        try:
            with quiet_function_argument():
                self.kernel[self.blocks, self.threads_per_block](*args)
        except Exception as exc:
            if not self.user or self.sim:
                raise
            name = getattr(self.s.model.moment_func, "__name__", repr(self.s.model.moment_func))
            raise TypeError(f"Compiled: the moment {name} could not be compiled for the GPU ({type(exc).__name__}: "
                            f"{exc}). On the device a moment must return a tuple of 3 floats (no new array: "
                            "nothing allocates there) and call only numba.njit functions and math.") from exc

    def advance(self, n: int, R_out: np.ndarray, Pi_out: np.ndarray, partial: Any) -> int:
        """Steps ``k .. k + n - 1`` of every body on the GPU; their samples are copied into the host's
        ``R_out``, ``Pi_out``. On a failure ``k`` is the first failed step."""
        se, k = self.save_every, self.k
        self._launch(n)
        m, j0 = n // se, k // se + 1
        R_out[:, j0:j0 + m] = self.d["R_out"].copy_to_host()[:, :m]
        Pi_out[:, j0:j0 + m] = self.d["Pi_out"].copy_to_host()[:, :m]
        self.status: Any = self.d["status"].copy_to_host()
        failed = np.flatnonzero(self.status != OK)
        if failed.size:
            self.sync()
            b = int(failed[np.argmin(self.fail_step[failed])])
            self.k: int = int(self.fail_step[b])
            return int(self.status[b])
        self.k = k + n
        return OK

    def sync(self) -> None:
        """Copy the per-body records and state from the device to the run's host arrays."""
        for name in ("its", "res", "status", "fail_step", "fail_res", "fail_its", "R", "Pi"):
            setattr(self, name, self.d[name].copy_to_host())


class CudaSink(LocalSink):
    """The ensemble's samples in host memory (as on the CPU); the per-body records come from the device."""

    def result(self, m: int, partial: bool = False) -> EnsembleTrajectory:
        self.run.sync()
        return super().result(m, partial)


def run_cuda(s: EnsembleSetup, progress: Any = False) -> EnsembleTrajectory:
    """Run the validated ensemble ``s`` on the GPU (``simulate_ensemble(..., device="cuda")``)."""
    from .driver import drive

    s.meta = dict(s.meta, device="cuda")     # the result says where it ran (bits differ from the CPU's on a GPU)
    run = CudaRun(s)
    return drive(run, CudaSink(run), progress)


provide_device("cuda", run_cuda)

__all__ = ["DEVICE_SAMPLE_BYTES", "GPU_CHUNK_BODY_STEPS", "THREADS_PER_BLOCK", "CudaRun", "CudaSink", "cuda_module",
           "numpy_shim", "run_cuda", "simulator"]
