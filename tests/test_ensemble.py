"""Ensembles: every body of simulate_ensemble is bit for bit lgvi.simulate of that body.

Checked for each kernel path (the per-body free-body kernel, the lockstep SIMD kernel of the
Cayley free body, the forced/composed kernel), for per-body inertias, for any number of threads
and any chunking, through Dask and through block files; plus validation, failures with partial
results, interrupts, the example and the benchmark in their short forms.
"""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi import ensemble, so3
from lgvi.torques import Constant, GravityGradient, LinearDamping, UniformGravity

ROOT = Path(__file__).resolve().parents[1]
HAVE_DASK = importlib.util.find_spec("dask") is not None and importlib.util.find_spec("distributed") is not None

FULL = lgvi.RigidBody(np.array([[0.9, 0.05, -0.1], [0.05, 1.3, 0.08], [-0.1, 0.08, 1.7]]))
B = 13  # not a multiple of the lockstep group size (8): one group is padded


def initial(n: int = B, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    R0 = so3.exp(0.5 * rng.normal(size=(n, 3)))
    Pi0 = np.array([0.6, -0.9, 1.2]) + 0.3 * rng.normal(size=(n, 3))
    return R0, Pi0


def assert_matches_simulate(ens, bodies, R0, Pi0, **options) -> None:
    """Body by body: R and Pi bit for bit, solver totals and potential as simulate's."""
    for b in range(len(R0)):
        body = bodies[b] if isinstance(bodies, (list, tuple, np.ndarray)) else bodies
        one = lgvi.simulate(body, R0[b], Pi0[b], **options)
        np.testing.assert_array_equal(ens.R[b], one.R, err_msg=f"body {b}")
        np.testing.assert_array_equal(ens.Pi[b], one.Pi, err_msg=f"body {b}")
        assert ens.iterations[b] == one.solver_summary["iterations_total"], b
        assert ens.residual[b] == one.solver_summary["residual_max"], b
        if one.potential is None:
            assert ens.potential is None
        else:
            np.testing.assert_allclose(ens.potential[b], one.potential, rtol=1e-14, atol=1e-14)
            np.testing.assert_allclose(ens.energy[b], one.energy, rtol=1e-13)
    np.testing.assert_array_equal(ens.t, one.t)


@pytest.mark.parametrize("method", ["newton", "cayley", "paper"])
def test_free_body_equals_simulate(method):
    R0, Pi0 = initial()
    opts = dict(h=0.02, steps=120, save_every=6, method=method)
    ens = lgvi.simulate_ensemble(FULL, R0, Pi0, **opts)
    assert ens.R.shape == (B, 21, 3, 3) and ens.Pi.shape == (B, 21, 3) and ens.t.shape == (21,)
    assert ens.iterations.shape == (B,) and ens.residual.shape == (B,)
    assert_matches_simulate(ens, FULL, R0, Pi0, **opts)


def test_torque_model_equals_simulate():
    R0, Pi0 = initial()
    opts = dict(h=0.01, steps=100, save_every=5, torque=UniformGravity(1.0, [0.05, 0.0, 0.3]), method="cayley")
    ens = lgvi.simulate_ensemble(FULL, R0, Pi0, **opts)
    assert ens.potential.shape == (B, 21)
    assert_matches_simulate(ens, FULL, R0, Pi0, **opts)
    # the heavy top's energy is bounded, and its vertical momentum kept to round-off
    assert np.abs(ens.energy - ens.energy[:, :1]).max() < 1e-2 * np.abs(ens.energy).max()
    Lz = ens.spatial_momentum[..., 2]
    assert np.abs(Lz - Lz[:, :1]).max() < 1e-12


def test_damping_symmetric_forcing_equals_simulate():
    R0, Pi0 = initial()
    opts = dict(h=0.02, steps=80, save_every=4, torque=LinearDamping([0.05, 0.1, 0.02]), forcing="symmetric")
    ens = lgvi.simulate_ensemble(FULL, R0, Pi0, **opts)
    assert_matches_simulate(ens, FULL, R0, Pi0, **opts)
    assert np.all(np.diff(ens.kinetic_energy, axis=1) < 0)


@pytest.mark.parametrize("order, torque", [(4, None), (6, GravityGradient(3.0, 1.2))])
def test_higher_order_equals_simulate(order, torque):
    R0, Pi0 = initial(9)
    opts = dict(h=0.05, steps=40, save_every=10, order=order, torque=torque, t0=1.5)
    ens = lgvi.simulate_ensemble(FULL, R0, Pi0, **opts)
    assert ens.meta["order"] == order and ens.t[0] == 1.5
    assert_matches_simulate(ens, FULL, R0, Pi0, **opts)


def test_per_body_inertia():
    R0, Pi0 = initial(10)
    rng = np.random.default_rng(5)
    moments = np.sort(1.0 + rng.random((10, 3)), axis=1)          # J1 <= J2 <= J3 < J1 + J2
    opts = dict(h=0.02, steps=60, save_every=3, method="cayley")
    ens = lgvi.simulate_ensemble(moments, R0, Pi0, **opts)
    assert_matches_simulate(ens, list(moments), R0, Pi0, **opts)
    np.testing.assert_array_equal(ens.inertia, np.stack([np.diag(m) for m in moments]))
    # a list of bodies (full inertias, some repeated), with a torque model and omega0
    bodies = [FULL, lgvi.RigidBody([1.0, 2.0, 2.5])] * 5
    w0 = Pi0 / 2
    opts = dict(h=0.02, steps=60, save_every=3, torque=UniformGravity(0.5, [0.0, 0.1, 0.2]))
    ens = lgvi.simulate_ensemble(bodies, R0, omega0=w0, **opts)
    for b in range(10):
        one = lgvi.simulate(bodies[b], R0[b], omega0=w0[b], **opts)
        np.testing.assert_array_equal(ens.R[b], one.R)
        np.testing.assert_array_equal(ens.Pi[b], one.Pi)
    np.testing.assert_allclose(ens.omega[-1], one.omega, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("options", [dict(method="cayley"), dict(method="newton"),
                                     dict(torque=UniformGravity(1.0, [0.0, 0.0, 0.3]), order=4)])
def test_threads_and_chunks_do_not_change_results(options, monkeypatch):
    R0, Pi0 = initial(37)
    opts = dict(h=0.01, steps=90, save_every=9, **options)
    one = lgvi.simulate_ensemble(FULL, R0, Pi0, threads=1, **opts)
    two = lgvi.simulate_ensemble(FULL, R0, Pi0, threads=2, **opts)
    monkeypatch.setattr(ensemble, "PYTHON_COLD_START_MAX", 0)       # the compiled cold start (large ensembles)
    compiled_start = lgvi.simulate_ensemble(FULL, R0, Pi0, threads=2, **opts)
    monkeypatch.setattr(ensemble, "CHUNK_BODY_STEPS", 37 * 5 * 7)  # chunks of 7 (or 1) steps: not multiples of 9
    chunked = lgvi.simulate_ensemble(FULL, R0, Pi0, **opts)
    # the models' bodies in compiled ranges (ensemble_kernels.advance_forced, beyond PER_BODY_CALLS_MAX
    # bodies) rather than one call of simulate's loop a body from Python
    monkeypatch.setattr(ensemble, "PER_BODY_CALLS_MAX", 0)
    ranges = lgvi.simulate_ensemble(FULL, R0, Pi0, threads=2, **opts)
    for other in (two, compiled_start, chunked, ranges):
        for name in ("R", "Pi", "iterations", "residual"):
            np.testing.assert_array_equal(getattr(one, name), getattr(other, name), err_msg=name)


def test_progress_and_interrupt(monkeypatch):
    R0, Pi0 = initial(8)
    monkeypatch.setattr(ensemble, "CHUNK_BODY_STEPS", 8 * 10)   # chunks of 10 steps
    calls = []
    lgvi.simulate_ensemble(FULL, R0, Pi0, h=0.01, steps=50, progress=lambda d, n: calls.append((d, n)))
    assert calls == [(10, 50), (20, 50), (30, 50), (40, 50), (50, 50)]

    def interrupt(done, total):
        if done == 20:
            signal.raise_signal(signal.SIGINT)   # delivered to this (the main) thread before it returns

    with pytest.raises(lgvi.SimulationInterrupted) as info:
        lgvi.simulate_ensemble(FULL, R0, Pi0, h=0.01, steps=50, save_every=5, progress=interrupt)
    part = info.value.trajectory
    assert part.meta["partial"] and part.R.shape == (8, 5, 3, 3)
    full = lgvi.simulate_ensemble(FULL, R0, Pi0, h=0.01, steps=50, save_every=5)
    np.testing.assert_array_equal(part.R, full.R[:, :5])


@pytest.mark.parametrize("per_body_calls_max", [64, 0])
def test_failure_names_body_and_keeps_partial_result(per_body_calls_max, monkeypatch):
    """A constant torque spins the bodies up until the implicit equation has no solution; the
    body with the largest initial momentum fails first (as simulate says), the others are kept;
    with one call of the step loop a body from Python (5 bodies) and in a compiled range (0)."""
    monkeypatch.setattr(ensemble, "PER_BODY_CALLS_MAX", per_body_calls_max)
    R0 = np.stack([np.eye(3)] * 5)
    Pi0 = np.tile([0.1, 0.5, 0.2], (5, 1))
    Pi0[3, 1] = 4.0
    opts = dict(h=0.1, steps=9, save_every=1, torque=Constant([0.0, 20.0, 0.0]))
    with pytest.raises(lgvi.ConvergenceError) as info:
        lgvi.simulate_ensemble([1.0, 2.0, 3.0], R0, Pi0, **opts)
    with pytest.raises(lgvi.ConvergenceError) as single:
        lgvi.simulate([1.0, 2.0, 3.0], R0[3], Pi0[3], **opts)
    err = info.value
    assert err.body == 3 and err.step == single.value.step > 0
    assert f"body 3 failed at step {err.step} (t = {err.time:g})" in str(err)
    assert "did not reach the tolerance" in str(err)
    part = err.trajectory
    assert part.R.shape == (5, err.step + 1, 3, 3) and part.meta["partial"]
    np.testing.assert_array_equal(part.R[3], single.value.trajectory.R)
    ok = lgvi.simulate([1.0, 2.0, 3.0], R0[0], Pi0[0], **opts)
    np.testing.assert_array_equal(part.R[0], ok.R[:err.step + 1])


def test_failure_in_lockstep_path():
    R0 = np.stack([np.eye(3)] * 11)
    Pi0 = np.tile([0.3, 1.0, 0.2], (11, 1))
    Pi0[9] = [0.0, 1e4, 0.0]          # |h Pi| beyond any solution near the identity
    with pytest.raises(lgvi.ConvergenceError) as info:
        lgvi.simulate_ensemble([1.0, 2.0, 3.0], R0, Pi0, h=0.1, steps=20, method="cayley", max_iter=5)
    assert info.value.body == 9 and info.value.step == 0 and "body 9" in str(info.value)
    assert info.value.trajectory.R.shape == (11, 1, 3, 3)


def test_validation_errors():
    R0, Pi0 = initial(4)
    ok = dict(h=0.01, steps=10)
    with pytest.raises(ValueError, match=r"R0 must have shape \(B, 3, 3\)"):
        lgvi.simulate_ensemble(FULL, np.eye(3), Pi0[0], **ok)
    with pytest.raises(ValueError, match=r"Pi0 must have shape \(4, 3\)"):
        lgvi.simulate_ensemble(FULL, R0, Pi0[:3], **ok)
    with pytest.raises(ValueError, match=r"omega0 must have shape \(4, 3\)"):
        lgvi.simulate_ensemble(FULL, R0, omega0=Pi0.T, **ok)
    with pytest.raises(ValueError, match="either Pi0 or omega0"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, omega0=Pi0, **ok)
    bad = R0.copy()
    bad[2] *= 1.01
    with pytest.raises(ValueError, match=r"R0\[2\] must be a rotation matrix"):
        lgvi.simulate_ensemble(FULL, bad, Pi0, **ok)
    bad = R0.copy()
    bad[3] = -bad[3]
    with pytest.raises(ValueError, match=r"R0\[3\] .*reflection"):
        lgvi.simulate_ensemble(FULL, bad, Pi0, **ok)
    with pytest.raises(ValueError, match="bodies gives 2 bodies but R0 has 4"):
        lgvi.simulate_ensemble([[1.0, 2.0, 3.0]] * 2, R0, Pi0, **ok)
    with pytest.raises(ValueError, match="bodies gives 5 bodies but R0 has 4"):
        lgvi.simulate_ensemble([FULL] * 5, R0, Pi0, **ok)
    with pytest.raises(ValueError, match=r"bodies\[1\]: .*triangle inequality"):
        lgvi.simulate_ensemble([[1.0, 2.0, 3.0], [1.0, 1.0, 5.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]], R0, Pi0, **ok)
    with pytest.raises(TypeError, match="callable .* cannot run inside the compiled parallel kernel"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, torque=lambda t, R, Pi: np.zeros(3), **ok)
    with pytest.raises(TypeError, match="torque arrays are not supported"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, torque=np.zeros((10, 3)), **ok)
    with pytest.raises(ValueError, match="save_every must divide steps"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, h=0.01, steps=10, save_every=3)
    with pytest.raises(ValueError, match="order must be 2, 4 or 6"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, order=3, **ok)
    with pytest.raises(ValueError, match="forcing='symmetric'"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, order=4, torque=LinearDamping(0.1), **ok)
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, threads=0, **ok)
    with pytest.raises(ValueError, match="block_size is used with client= or out_dir="):
        lgvi.simulate_ensemble(FULL, R0, Pi0, block_size=2, **ok)
    with pytest.raises(ValueError, match="h must be non-zero"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, h=0.0, steps=10)


def test_blocks_on_disk(tmp_path):
    R0, Pi0 = initial(11)
    opts = dict(h=0.01, steps=40, save_every=10, torque=UniformGravity(1.0, [0.0, 0.0, 0.3]))
    whole = lgvi.simulate_ensemble(FULL, R0, Pi0, **opts)
    paths = lgvi.simulate_ensemble(FULL, R0, Pi0, out_dir=tmp_path / "run", block_size=4, **opts)
    assert [p.name for p in paths] == ["ensemble-00000.npz", "ensemble-00001.npz", "ensemble-00002.npz"]
    for loaded in (lgvi.load_ensemble(tmp_path / "run"), lgvi.load_ensemble(paths),
                   ensemble.concatenate([lgvi.load_ensemble(p) for p in paths])):
        for name in ("t", "R", "Pi", "inertia", "iterations", "residual", "potential"):
            np.testing.assert_array_equal(getattr(loaded, name), getattr(whole, name), err_msg=name)
    assert lgvi.load_ensemble(paths[1]).meta["first_body"] == 4
    with pytest.raises(ValueError, match="already holds ensemble blocks"):
        lgvi.simulate_ensemble(FULL, R0, Pi0, out_dir=tmp_path / "run", **opts)
    paths[1].unlink()
    with pytest.raises(ValueError, match="block starts at body 8"):
        lgvi.load_ensemble(tmp_path / "run")
    # one file round trip, and a body as a Trajectory
    whole.save(tmp_path / "one.npz")
    again = lgvi.load_ensemble(tmp_path / "one.npz")
    np.testing.assert_array_equal(again.R, whole.R)
    assert again.meta == whole.meta
    body5 = whole[5]
    assert isinstance(body5, lgvi.Trajectory)
    np.testing.assert_array_equal(body5.potential, whole.potential[5])
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="junk.npz"):
        lgvi.load_ensemble(tmp_path / "junk.npz")


def test_kernels_interpreted_match_compiled():
    """The ensemble kernels run as plain Python (NUMBA_DISABLE_JIT=1) give the compiled results."""
    code = (
        "import numpy as np, lgvi\n"
        "from lgvi.torques import UniformGravity\n"
        "R0 = lgvi.so3.exp(0.3 * np.arange(27.0).reshape(9, 3) / 27)\n"
        "Pi0 = np.tile([0.6, -0.9, 1.2], (9, 1)) + 0.01 * np.arange(27.0).reshape(9, 3)\n"
        "out = []\n"
        "for kw in (dict(method='cayley'), dict(method='newton'), dict(torque=UniformGravity(1.0, [0, 0, 0.3]))):\n"
        "    e = lgvi.simulate_ensemble([1.0, 2.0, 2.5], R0, Pi0, h=0.05, steps=6, threads=1, **kw)\n"
        "    out.append(e.R[:, -1].tolist())\n"
        "print(out)\n"
    )
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    interpreted = np.array(eval(proc.stdout.strip().splitlines()[-1]))
    env.pop("NUMBA_DISABLE_JIT")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    compiled = np.array(eval(proc.stdout.strip().splitlines()[-1]))
    np.testing.assert_allclose(interpreted, compiled, rtol=0, atol=1e-13)


@pytest.mark.skipif(not HAVE_DASK, reason="dask[distributed] not installed (pip install 'lgvi[dask]')")
def test_dask_equals_in_process_and_simulate(tmp_path):
    from dask.distributed import Client, LocalCluster

    R0, Pi0 = initial(29)
    free = dict(h=0.01, steps=60, save_every=6, method="cayley")
    forced = dict(h=0.01, steps=60, save_every=6, torque=UniformGravity(1.0, [0.0, 0.05, 0.3]), order=4)
    local = {k: lgvi.simulate_ensemble(FULL, R0, Pi0, **o) for k, o in (("free", free), ("forced", forced))}
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        remote = lgvi.simulate_ensemble(FULL, R0, Pi0, client=client, block_size=8, **free)
        remote_forced = lgvi.simulate_ensemble(FULL, R0, Pi0, client=client, **forced)
        paths = lgvi.simulate_ensemble(FULL, R0, Pi0, client=client, block_size=10, out_dir=tmp_path / "blocks",
                                       **free)
        with pytest.raises(lgvi.ConvergenceError, match="body 3 failed"):
            bad = Pi0.copy()
            bad[3] = [0.0, 1e4, 0.0]
            lgvi.simulate_ensemble(FULL, R0, bad, client=client, block_size=2, h=0.1, steps=5, max_iter=5)
    assert len(paths) == 3
    on_disk = lgvi.load_ensemble(tmp_path / "blocks")
    for got, want in ((remote, local["free"]), (on_disk, local["free"]), (remote_forced, local["forced"])):
        for name in ("t", "R", "Pi", "iterations", "residual"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    assert_matches_simulate(remote, FULL, R0, Pi0, **free)
    assert_matches_simulate(remote_forced, FULL, R0, Pi0, **forced)


def test_uncertainty_example_quick(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("NUMBA_DISABLE_JIT", None)
    proc = subprocess.run([sys.executable, str(ROOT / "examples" / "uncertainty.py"), "--quick", "--out",
                           str(tmp_path / "figs")], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "bodies" in proc.stdout and "spread" in proc.stdout
    for name in ("axis_spread.png",):
        png = tmp_path / "figs" / name
        assert png.exists() and png.stat().st_size > 10_000


def test_benchmark_quick():
    """The throughput benchmark runs at reduced size and prints its table (no timing assertions)."""
    env = dict(os.environ)
    env.pop("NUMBA_DISABLE_JIT", None)
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_ensemble.py"), "--quick"],
                          capture_output=True, text=True, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for needle in ("body-steps/s", "threads", "2 threads / 1", "load average"):
        assert needle in proc.stdout, proc.stdout


def test_docstring_examples():
    import doctest

    result = doctest.testmod(ensemble, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
