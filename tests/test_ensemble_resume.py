"""``simulate_ensemble(..., out_dir=, resume=True)``: a second call finishes an interrupted run.

The blocks a first call completed are kept (not recomputed), the others are computed, and the
folder then holds the uninterrupted ensemble bit for bit. Blocks of another run are refused.
"""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest

import lgvi
from lgvi import ensemble, so3
from lgvi.torques import AttitudePD

BODY = lgvi.RigidBody([1.0, 2.0, 2.5])


def inputs(n: int = 10):
    rng = np.random.default_rng(21)
    R0 = so3.exp(0.4 * rng.normal(size=(n, 3)))
    Pi0 = [0.2, 0.5, -0.3] + 0.1 * rng.normal(size=(n, 3))
    models = [AttitudePD(kp=1.0 + rng.random(), kd=0.5) for _ in range(n)]
    return R0, Pi0, dict(h=0.01, steps=40, save_every=4, torque=models, forcing="symmetric")


def test_resume_keeps_finished_blocks_and_finishes_bit_for_bit(tmp_path, monkeypatch):
    R0, Pi0, opts = inputs()
    whole = lgvi.simulate_ensemble(BODY, R0, Pi0, **opts)
    out = tmp_path / "blocks"
    real = ensemble.write_atomic
    written = []

    def full_disk_on_third(path, write):
        written.append(os.path.basename(path))
        if len(written) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(path, write)

    monkeypatch.setattr(ensemble, "write_atomic", full_disk_on_third)
    with pytest.raises(OSError, match="disk is full"):
        lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=3, **opts)
    assert sorted(p.name for p in out.iterdir()) == ["ensemble-00000.npz", "ensemble-00001.npz"]
    stamps = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    with pytest.raises(ValueError, match="resume=True"):            # without resume: refused as before
        lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=3, **opts)

    written.clear()
    monkeypatch.setattr(ensemble, "write_atomic", lambda path, write: (written.append(os.path.basename(path)),
                                                                        real(path, write))[1])
    paths = lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=3, resume=True, **opts)
    assert written == ["ensemble-00002.npz", "ensemble-00003.npz"]      # only the missing blocks ran
    assert {n: (out / n).stat().st_mtime_ns for n in stamps} == stamps  # the finished ones untouched
    assert [p.name for p in paths] == [f"ensemble-{i:05d}.npz" for i in range(4)]
    done = lgvi.load_ensemble(out)
    for name in ("t", "R", "Pi", "iterations", "residual", "inertia"):
        np.testing.assert_array_equal(getattr(done, name), getattr(whole, name), err_msg=name)
    np.testing.assert_array_equal(done.model_params["pd.kp"], whole.model_params["pd.kp"])
    # resuming a finished run computes nothing
    written.clear()
    lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=3, resume=True, **opts)
    assert written == []


def test_resume_refuses_blocks_of_another_run(tmp_path):
    R0, Pi0, opts = inputs()
    out = tmp_path / "blocks"
    lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=3, **opts)
    (out / "ensemble-00003.npz").unlink()
    other = Pi0.copy()
    other[1, 0] += 1e-9
    with pytest.raises(ValueError, match=r"ensemble-00000.npz was not written by this run \(the initial states"):
        lgvi.simulate_ensemble(BODY, R0, other, out_dir=out, block_size=3, resume=True, **opts)
    with pytest.raises(ValueError, match=r"ensemble-00000.npz was not written by this run \(differences: steps"):
        lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=3, resume=True, **dict(opts, steps=44))
    with pytest.raises(ValueError, match="another block_size"):
        lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=5, resume=True, **opts)
    with pytest.raises(ValueError, match="give out_dir"):
        lgvi.simulate_ensemble(BODY, R0, Pi0, resume=True, **opts)
    (out / "ensemble-00001.npz").write_bytes(b"PK not a block")
    with pytest.raises(ValueError, match="ensemble-00001.npz is not a readable ensemble block"):
        lgvi.simulate_ensemble(BODY, R0, Pi0, out_dir=out, block_size=3, resume=True, **opts)
