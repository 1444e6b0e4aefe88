"""``simulate_ensemble(..., device="cuda")`` on Numba's CUDA simulator (no GPU needed).

The GPU kernels (``lgvi._kernels.cuda_kernels``) run the CPU ensemble's per-body functions; in the
simulator those run as the CPU's compiled code, with the same arguments, so every body must agree
with the CPU ensemble bit for bit (``R``, ``Pi``, iterations, residuals) whatever the chunking of
the samples. On a GPU the same source is compiled by NVVM, which contracts ``a * b + c`` into fused
multiply-adds: there agreement is to round-off growth, measured by ``benchmarks/bench_gpu.py``.

The simulator is switched on here (before ``numba.cuda`` is first imported) unless
``LGVI_TEST_CUDA=hardware`` asks for the real GPU. Sizes are small: the simulator runs each GPU
thread as a Python thread.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest

import lgvi
from lgvi import gpu
from lgvi.torques import AttitudePD, Compiled, Constant, GravityGradient, LinearDamping, UniformGravity

HARDWARE = os.environ.get("LGVI_TEST_CUDA") == "hardware"
if not HARDWARE and "numba.cuda" not in sys.modules:
    # Numba's CUDA target picks the simulator when first imported; the environment of the session (and
    # of the other tests' subprocesses) is left as it is
    numba.core.config.ENABLE_CUDASIM = 1
    gpu.numpy_shim()
    import numba.cuda  # noqa: E402, F401


def _cuda_or_skip():
    try:
        return gpu.cuda_module()
    except (ImportError, RuntimeError) as exc:  # pragma: no cover - numba.cuda imported without the simulator
        pytest.skip(f"no CUDA simulator or GPU here: {exc}")


@pytest.fixture
def cuda(monkeypatch):
    mod = _cuda_or_skip()
    if not HARDWARE:
        assert gpu.simulator(mod)
    return mod


ROOT = Path(__file__).resolve().parent.parent
EPS = np.finfo(float).eps
B = 6


def _initial(n=B, seed=0):
    rng = np.random.default_rng(seed)
    R0 = lgvi.so3.exp(rng.normal(size=(n, 3)))
    R0[0] = np.eye(3)
    R0[1] = lgvi.so3.exp([np.pi - 1e-9, 0.0, 0.0])           # near a rotation by pi
    w0 = [0.3, 1.0, 0.2] + 0.2 * rng.normal(size=(n, 3))
    w0[0] = [0.0, 1.0, 1e-7]                                  # the intermediate axis
    inertia = np.array([1.0, 2.0, 3.0]) + 0.2 * rng.random(size=(n, 3))
    return inertia, R0, w0


def _same(cpu, dev, exact=True):
    """Bit for bit (the simulator, or one device run to run); on a GPU (``exact=False``, FMA
    contraction) to round-off growth over these few steps, and the same solver work within 2 %."""
    np.testing.assert_array_equal(cpu.t, dev.t)
    for name in ("R", "Pi", "iterations", "residual"):
        a, b = getattr(cpu, name), getattr(dev, name)
        if exact:
            np.testing.assert_array_equal(a, b, err_msg=name)
        elif name == "iterations":  # pragma: no cover - on a GPU
            assert np.all(np.abs(a - b) <= np.maximum(2, a // 50)), (a, b)
        else:  # pragma: no cover - on a GPU
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9, err_msg=name)


def _same_potential(cpu, dev):
    """The potential of each saved sample: evaluated from the device's attitudes, so bit for bit in the
    simulator and within round-off of them on a GPU (the attitudes there differ by FMA contraction: on an
    H200 the potentials of this file's runs differed in the last bit, 2.2e-16 absolute)."""
    if cpu.potential is None:
        assert dev.potential is None
    elif HARDWARE:  # pragma: no cover - on a GPU
        np.testing.assert_allclose(dev.potential, cpu.potential, rtol=0, atol=1e-9 * np.abs(cpu.potential).max())
    else:
        np.testing.assert_array_equal(cpu.potential, dev.potential)


@pytest.mark.parametrize("method", ["cayley", "newton"])
def test_free_body_agrees_with_cpu_in_chunks_and_conserves(cuda, monkeypatch, method):
    inertia, R0, w0 = _initial()
    opts = dict(omega0=w0, h=0.02, steps=24, save_every=2, method=method)
    cpu = lgvi.simulate_ensemble(inertia, R0, **opts)
    monkeypatch.setattr(gpu, "DEVICE_SAMPLE_BYTES", B * 96 * 5)   # chunks of 5 samples: 10, 10, 4 steps
    dev = lgvi.simulate_ensemble(inertia, R0, device="cuda", **opts)
    _same(cpu, dev, exact=not HARDWARE)
    again = lgvi.simulate_ensemble(inertia, R0, device="cuda", **opts)
    _same(dev, again)                                                 # reproducible run to run
    # the free body's invariants to round-off: |Pi|, R Pi and the energy (120 ulp over 24 steps)
    norm = np.linalg.norm(dev.Pi, axis=-1)
    spatial = dev.spatial_momentum
    energy = dev.energy
    assert np.all(np.ptp(norm, axis=1) <= 16 * EPS * norm[:, 0])
    assert np.all(np.abs(spatial - spatial[:, :1]).max(axis=(1, 2)) <= 16 * EPS * norm[:, 0])
    assert np.all(np.ptp(energy, axis=1) <= 32 * EPS * energy[:, 0])
    RtR = np.einsum("bmji,bmjk->bmik", dev.R, dev.R)
    assert np.abs(RtR - np.eye(3)).max() <= 16 * EPS


MODELS = {
    "heavy top, symmetric, order 4": dict(torque=UniformGravity(1.0, [0.0, 0.02, 0.3]), forcing="symmetric",
                                          order=4, method="cayley"),
    "gravity gradient + constant, paper": dict(torque=GravityGradient(398600.4418, 7000.0) + Constant([1e-3, 0, 0]),
                                               method="newton"),
    "PD + damping per body, symmetric": dict(torque=[AttitudePD(kp=0.5 + 0.1 * b, kd=1.0) + LinearDamping(0.05)
                                                     for b in range(B)], forcing="symmetric", method="cayley"),
}


@pytest.mark.parametrize("case", list(MODELS))
def test_torque_models_agree_with_cpu(cuda, monkeypatch, case):
    inertia, R0, w0 = _initial()
    opts = dict(dict(omega0=w0, h=0.02, steps=12, save_every=3), **MODELS[case])
    cpu = lgvi.simulate_ensemble(inertia, R0, **opts)
    monkeypatch.setattr(gpu, "DEVICE_SAMPLE_BYTES", B * 96 * 2)   # chunks of 2 samples (6 steps)
    dev = lgvi.simulate_ensemble(inertia, R0, device="cuda", **opts)
    _same(cpu, dev, exact=not HARDWARE)
    assert dev.meta == dict(cpu.meta, device="cuda")
    _same_potential(cpu, dev)
    if isinstance(opts["torque"], list):
        assert dev.torque_model(3) == opts["torque"][3]


sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
# the benchmark's compiled gravity (docs/architecture.md's example, with its potential): the user's kernel
# is compiled once per function and process, so the smoke run of the benchmark below reuses it
from bench_gpu import user_gravity as _gravity, user_gravity_potential as _height  # noqa: E402


def test_compiled_user_models_agree_with_cpu(cuda, monkeypatch):
    inertia, R0, w0 = _initial()
    rows = np.column_stack([np.zeros(B), 0.01 * np.arange(B), -0.3 * 9.81 * (1 + 0.1 * np.arange(B))])
    monkeypatch.setattr(gpu, "DEVICE_SAMPLE_BYTES", B * 96 * 2)
    for model, extra in ((Compiled(_gravity, potential=_height, params=rows), dict(order=4, method="cayley")),
                         # the same function declared momentum dependent (its fixed-point iteration), one row for
                         # all: the same compiled kernel (a compile per function: the simulator's costs most here)
                         (Compiled(_gravity, params=rows[2], momentum_dependent=True),
                          dict(forcing="symmetric", method="newton"))):
        opts = dict(omega0=w0, h=0.02, steps=8, save_every=2, torque=model, **extra)
        cpu = lgvi.simulate_ensemble(inertia, R0, **opts)
        dev = lgvi.simulate_ensemble(inertia, R0, device="cuda", **opts)
        _same(cpu, dev, exact=not HARDWARE)
        _same_potential(cpu, dev)
        if model.params.ndim == 2:
            np.testing.assert_array_equal(dev.model_params["params"], rows)


def test_failure_names_the_body_and_keeps_the_partial_result(cuda):
    """A constant torque spins the bodies up until the implicit equation has no solution: the
    error is the CPU ensemble's (body, step, message) and its partial ensemble is the CPU's."""
    R0 = np.stack([np.eye(3)] * 5)
    Pi0 = np.tile([0.1, 0.5, 0.2], (5, 1))
    Pi0[3, 1] = 4.0
    opts = dict(h=0.1, steps=9, save_every=1, torque=Constant([0.0, 20.0, 0.0]))
    with pytest.raises(lgvi.ConvergenceError) as on_cpu:
        lgvi.simulate_ensemble([1.0, 2.0, 3.0], R0, Pi0, **opts)
    with pytest.raises(lgvi.ConvergenceError) as on_gpu:
        lgvi.simulate_ensemble([1.0, 2.0, 3.0], R0, Pi0, device="cuda", **opts)
    a, b = on_cpu.value, on_gpu.value
    assert (b.body, b.step) == (a.body, a.step) == (3, a.step)
    assert str(b) == str(a) or HARDWARE       # on a GPU the residual quoted may differ in its last digits
    assert b.trajectory.meta["partial"]
    _same(a.trajectory, b.trajectory, exact=not HARDWARE)


def test_progress_and_interrupt_between_chunks(cuda, monkeypatch):
    inertia, R0, w0 = _initial()
    monkeypatch.setattr(gpu, "DEVICE_SAMPLE_BYTES", B * 96 * 2)   # chunks of 2 samples
    calls = []
    opts = dict(omega0=w0, h=0.02, steps=20, save_every=2, method="cayley")
    full = lgvi.simulate_ensemble(inertia, R0, device="cuda", progress=lambda d, n: calls.append((d, n)), **opts)
    assert calls == [(4 * i, 20) for i in range(1, 6)]

    def interrupt(done, total):
        if done == 8:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(lgvi.SimulationInterrupted) as info:
        lgvi.simulate_ensemble(inertia, R0, device="cuda", progress=interrupt, **opts)
    part = info.value.trajectory
    assert part.meta["partial"] and part.R.shape == (B, 5, 3, 3)
    np.testing.assert_array_equal(part.R, full.R[:, :5])
    np.testing.assert_array_equal(part.Pi, full.Pi[:, :5])


def test_cpu_only_options_are_refused_by_name():
    inertia, R0, w0 = _initial()
    opts = dict(omega0=w0, h=0.01, steps=4)
    with pytest.raises(ValueError, match="device must be one of 'cpu', 'cuda'; got 'gpu'"):
        lgvi.simulate_ensemble(inertia, R0, device="gpu", **opts)
    for extra, name in ((dict(threads=2), "threads=2"), (dict(out_dir="x"), "out_dir='x'"),
                        (dict(block_size=2), "block_size=2"), (dict(client=object()), "client=")):
        with pytest.raises(ValueError, match=name):
            lgvi.simulate_ensemble(inertia, R0, device="cuda", **opts, **extra)
    with pytest.raises(ValueError, match="resume=True continues an out_dir= run"):
        lgvi.simulate_ensemble(inertia, R0, device="cuda", resume=True, **opts)
    wheels = lgvi.ReactionWheels(np.eye(3), [0.01] * 3)
    with pytest.raises(ValueError, match="wheels= cannot be combined with device='cuda': the gyrostat"):
        lgvi.simulate_ensemble(inertia, R0, device="cuda", wheels=wheels, **opts)


def test_numpy_shim_restores_row_stack_only_when_missing(monkeypatch):
    assert gpu.numpy_shim() is (not hasattr(np, "row_stack"))  # False on NumPy < 2.5: nothing to do
    monkeypatch.delattr(np, "row_stack", raising=False)          # NumPy 2.5 and later
    assert gpu.numpy_shim() is True
    assert np.row_stack is np.vstack
    assert gpu.numpy_shim() is False


def test_core_never_imports_cuda_and_no_gpu_is_a_clear_error():
    """``import lgvi`` and CPU ensembles leave ``numba.cuda`` alone; ``device="cuda"`` without a GPU
    (no simulator) raises RuntimeError naming what is missing and what to do."""
    code = (
        "import sys, numpy as np, lgvi\n"
        "ens = lgvi.simulate_ensemble([1., 2., 3.], np.stack([np.eye(3)] * 2), omega0=np.ones((2, 3)), h=0.01,"
        " steps=4)\n"
        "print('cuda imported:', 'numba.cuda' in sys.modules)\n"
        "try:\n"
        "    lgvi.simulate_ensemble([1., 2., 3.], np.stack([np.eye(3)] * 2), omega0=np.ones((2, 3)), h=0.01,"
        " steps=4, device='cuda')\n"
        "    print('ran on a GPU')\n"
        "except (RuntimeError, ImportError) as exc:\n"
        "    print(type(exc).__name__, exc)\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "cuda imported: False"
    if lines[1] == "ran on a GPU":  # pragma: no cover - a machine with a GPU
        return
    assert lines[1].startswith("RuntimeError device='cuda' needs an NVIDIA GPU with its CUDA driver") or \
        lines[1].startswith("ImportError device='cuda' needs Numba's CUDA target"), lines[1]
    assert "NUMBA_ENABLE_CUDASIM=1" in lines[1] or "numba-cuda" in lines[1]


def test_bench_gpu_smoke_prints_its_table(cuda, capsys):
    """``benchmarks/bench_gpu.py --smoke`` in the simulator: every case runs on both devices and
    agrees bit for bit (no timing is checked). In this process: the kernels are compiled already."""
    import bench_gpu

    advance = (lgvi.ensemble.LocalRun.advance, gpu.CudaRun.advance)
    bench_gpu.main(["--smoke"])
    assert (lgvi.ensemble.LocalRun.advance, gpu.CudaRun.advance) == advance     # its timers are undone
    out = capsys.readouterr().out
    for needle in ("case", "bodies", "steps", "cpu body-steps/s", "gpu body-steps/s", "gpu/cpu", "max |dR|",
                   "free body cayley", "free body newton", "heavy top", "gravity gradient", "user model",
                   "simulator"):
        assert needle in out, out
    rows = [line for line in out.splitlines() if line.startswith(("free", "heavy", "gravity", "user"))]
    assert len(rows) == 5
    assert all(line.split("|")[-1].split()[0] == "0" for line in rows), out    # bit for bit in the simulator
