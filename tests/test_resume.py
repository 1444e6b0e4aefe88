"""Nothing lost: streamed runs survive Ctrl-C and SIGKILL, and resume bit for bit.

The stream folder (``lgvi.streaming``) lists only complete chunks, each written by an atomic
rename, so a run killed at any moment leaves a readable folder; ``resume`` restarts from the exact
state after the last complete chunk (attitude, momentum and the solver's warm-start history), so
the resumed result equals the uninterrupted one bit for bit.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi.io.streaming import read_manifest, read_stream
from lgvi.torques import UniformGravity

PENDULUM = dict(omega0=[4.14, 4.14, 4.14], h=0.01, save_every=10, torque=UniformGravity(1.0, [0.0, 0.0, 0.3]))
BODY = lgvi.RigidBody([0.13, 0.28, 0.17])


def same(a: lgvi.Trajectory, b: lgvi.Trajectory) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f))
               for f in ("t", "R", "Pi", "iterations", "residual", "potential"))


def same_totals(a: lgvi.Trajectory, b: lgvi.Trajectory) -> bool:
    """The solver's run totals (steps, iterations, largest residual, histogram) agree exactly."""
    sa, sb = a.solver_summary, b.solver_summary
    return all(np.array_equal(sa[k], sb[k]) for k in ("steps", "iterations_total", "iterations_max",
                                                        "residual_max", "histogram"))


@pytest.mark.parametrize("kw", [
    dict(PENDULUM, steps=3000),
    dict(omega0=[0.3, 1.0, 0.2], h=0.01, steps=3000, save_every=3, method="cayley"),
    dict(omega0=[1.0, 2.0, 3.0], h=0.01, steps=1200, save_every=4, forcing="symmetric", order=4,
         torque=lambda t, R, Pi: 0.01 * np.array([np.cos(t), 0.0, 0.0]) - 0.01 * Pi),
    dict(PENDULUM, steps=3000, solver_record="full"),
], ids=["pendulum", "free-cayley", "callable-order4", "pendulum-full-record"])
def test_stream_equals_simulate_and_resumes_exactly(tmp_path, kw):
    ref = lgvi.simulate(BODY, np.eye(3), **kw)
    per = 1 if kw.get("solver_record") == "full" else kw["save_every"]   # steps per record entry
    assert ref.iterations.shape == (kw["steps"] // per,) and ref.steps == kw["steps"]
    lgvi.simulate_stream(tmp_path / "full", BODY, np.eye(3), chunk_steps=480, **kw)
    assert same(read_stream(tmp_path / "full"), ref) and same_totals(read_stream(tmp_path / "full"), ref)

    stop_at = 2 * 480

    def interrupt(k, n):  # a Ctrl-C arriving between two chunks
        if k >= stop_at:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        lgvi.simulate_stream(tmp_path / "cut", BODY, np.eye(3), chunk_steps=480, progress=interrupt, **kw)
    part = read_stream(tmp_path / "cut")
    assert part.steps == stop_at and not part.meta["complete"]
    assert same(part, lgvi.Trajectory(t=ref.t[:len(part.t)], R=ref.R[:len(part.t)], Pi=ref.Pi[:len(part.t)],
                                      inertia=ref.inertia, iterations=ref.iterations[:stop_at // per],
                                      residual=ref.residual[:stop_at // per], h=ref.h,
                                      potential=None if ref.potential is None else ref.potential[:len(part.t)]))
    lgvi.simulate_stream(tmp_path / "cut", BODY, np.eye(3), chunk_steps=480, resume=True, **kw)
    assert same(read_stream(tmp_path / "cut"), ref) and same_totals(read_stream(tmp_path / "cut"), ref)


def test_resume_refuses_a_different_run(tmp_path):
    kw = dict(PENDULUM, steps=1000)
    lgvi.simulate_stream(tmp_path / "s", BODY, np.eye(3), chunk_steps=500, **kw)
    with pytest.raises(ValueError, match="resume.*h=0.01.*now h=0.02"):
        lgvi.simulate_stream(tmp_path / "s", BODY, np.eye(3), chunk_steps=500, resume=True, **dict(kw, h=0.02))
    with pytest.raises(FileExistsError, match="resume=True"):
        lgvi.simulate_stream(tmp_path / "s", BODY, np.eye(3), chunk_steps=500, **kw)


def test_stream_failure_keeps_the_part_computed(tmp_path):
    with pytest.raises(lgvi.ConvergenceError) as info:
        lgvi.simulate_stream(tmp_path / "f", [1.0, 2.0, 3.0], np.eye(3), [0.3, 2.0, 0.6], h=10.0, steps=10,
                             chunk_steps=5)
    err = info.value
    assert err.step == 0 and len(err.trajectory.t) == 1 and np.all(np.isfinite(err.trajectory.R))


SCENARIO = """
name = "long pendulum"
[body]
inertia = [0.13, 0.28, 0.17]
[initial]
omega = [4.14, 4.14, 4.14]
[integrator]
h = 0.001
steps = 3_000_000
save_every = 100
[[torque]]
type = "uniform_gravity"
mass = 1.0
com = [0.0, 0.0, 0.3]
[output]
plots = false
"""


def lgvi_cli(*args: str | os.PathLike) -> list[str]:
    return [sys.executable, "-m", "lgvi", *map(str, args)]


def wait_for_chunks(stream: Path, n: int, proc: subprocess.Popen) -> None:
    """Wait until the run has written ``n`` chunks, as long as it runs (no clock: a busy machine is slow)."""
    while True:
        try:
            if len(read_manifest(stream)["chunks"]) >= n:
                return
        except ValueError:
            pass
        if proc.poll() is not None:
            raise AssertionError(f"the run ended early: {proc.communicate()}")
        time.sleep(0.02)


@pytest.mark.slow
def test_kill_then_resume_equals_uninterrupted_run(tmp_path):
    """SIGKILL `lgvi run` at a random moment after its first chunk, resume it, compare with a clean run."""
    scenario = tmp_path / "long.toml"
    scenario.write_text(SCENARIO)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    subprocess.run(lgvi_cli("run", scenario, "-o", tmp_path / "clean"), check=True, env=env,
                   capture_output=True)
    clean = lgvi.load(tmp_path / "clean" / "trajectory.npz")

    out = tmp_path / "killed"
    proc = subprocess.Popen(lgvi_cli("run", scenario, "-o", out), env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    try:
        wait_for_chunks(out / "stream", 1, proc)
        time.sleep(random.uniform(0.0, 0.3))  # somewhere inside a later chunk, or while writing one
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.communicate()
    done = read_stream(out / "stream")  # readable after the kill
    assert 0 < done.steps < clean.steps
    res = subprocess.run(lgvi_cli("run", scenario, "-o", out, "--resume"), env=env, capture_output=True,
                         text=True)
    assert res.returncode == 0, res.stderr
    resumed = lgvi.load(out / "trajectory.npz")
    assert same(resumed, clean)


@pytest.mark.slow
def test_ctrl_c_writes_the_part_computed_and_resume_finishes(tmp_path):
    scenario = tmp_path / "long.toml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "o"
    proc = subprocess.Popen(lgvi_cli("run", scenario, "-o", out), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    wait_for_chunks(out / "stream", 1, proc)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate()
    assert proc.returncode == 130, err
    assert "interrupted" in err and "--resume" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    part = lgvi.load(out / "trajectory.npz")
    assert 0 < part.steps < 3_000_000 and np.all(np.isfinite(part.R))
    res = subprocess.run(lgvi_cli("run", scenario, "-o", out, "--resume", "--no-plots"), capture_output=True,
                         text=True)
    assert res.returncode == 0, res.stderr
    assert lgvi.load(out / "trajectory.npz").steps == 3_000_000
