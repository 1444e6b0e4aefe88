"""Every streamable system streams, reads back and resumes bit for bit (``lgvi.io.streaming``).

A system declares its state layout, records and ``from_stream`` (``lgvi.systems.System``); the
stream sink writes its fields chunk by chunk, :func:`read_stream` returns its result type, and
``resume=True`` continues from the state after the last complete chunk (for the gyrostat the held
command, the MRP feedback's integral and a Python controller's state too), so the streamed, the
interrupted-and-resumed and the in-memory runs are equal bit for bit.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import lgvi
from lgvi.control import Command, Controller, MRPFeedback, RotationPD
from lgvi.io.streaming import read_manifest, read_stream, simulate_stream, stream_system
from lgvi.systems.gyrostat import GyrostatTrajectory
from lgvi.systems.orbit import OrbitTrajectory
from lgvi.systems.two_body import PointMasses, TwoBodyTrajectory

from gyrostat_cases import BODY, R0, R_REF, W0  # tests/ is on the path
from gyrostat_cases import wheels as _wheels


@pytest.fixture(autouse=True)
def _old_keywords_run_the_gyrostat():
    """``lgvi.simulate(..., wheels=, controller=)`` here is the gyrostat's run as given (the reference
    of its streams and of simulate_members), not the loop it maps onto (lgvi.systems.loop_keywords)."""
    from lgvi.systems.loop_keywords import as_given

    with as_given():
        yield


def wheels(**kw):
    kw.setdefault("max_torque", 0.5)
    return _wheels(**kw)


def same_arrays(a, b, names) -> None:
    for name in names:
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.shape == y.shape and x.dtype == y.dtype, (name, x.shape, y.shape, x.dtype, y.dtype)
        assert np.array_equal(x, y), f"{name} differs (largest difference {np.abs(x - y).max():.3g})"


GYRO_FIELDS = ("t", "R", "Pi", "wheel_momentum", "wheel_torque", "wheel_speed", "iterations", "residual",
               "wheel_axes", "spin_inertia", "inertia")
ORBIT_FIELDS = ("t", "x", "p", "R", "Pi", "iterations", "residual", "inertia")
TWO_FIELDS = ("t", "x", "p", "R", "Pi", "iterations", "residual", "masses")


def same_gyro(a, b) -> None:
    assert type(a) is type(b) is GyrostatTrajectory
    same_arrays(a, b, GYRO_FIELDS)
    assert a.h == b.h
    sa, sb = a.solver_summary, b.solver_summary
    for key in ("steps", "iterations_total", "iterations_max", "residual_max", "histogram"):
        assert np.array_equal(sa[key], sb[key]), key
    assert a.meta["invariants"] == b.meta["invariants"]


class PythonMRP(MRPFeedback):
    """The MRP law evaluated in Python (a subclass is not compiled): its integral lives in Python."""

    def state(self):
        return {"int_sigma": self.int_sigma.tolist(), "prior_time": self.prior_time}

    def load_state(self, st):
        self.int_sigma = np.array(st["int_sigma"], dtype=np.float64)
        self.prior_time = st["prior_time"]


class Forgetful(Controller):
    """A Python controller with hidden state lgvi cannot save (a call counter)."""

    def reset(self):
        self.calls = 0

    def command(self, t, R, omega, wheel_speed, env):
        self.calls += 1
        return Command(wheel_torque=np.full(len(wheel_speed), 1e-3 * (self.calls % 3 - 1)))


def profile(t):
    """A slowly turning reference attitude (a callable target: MRPFeedback runs in Python)."""
    return lgvi.so3.exp([0.0, 0.001 * t, 0.0])


GYRO_RUNS = {
    # the compiled MRP feedback with its integral; the control period (7 steps) does not divide a chunk
    "mrp-integral": lambda: dict(wheels=wheels(), controller=MRPFeedback(0.5, 2.0, Ki=0.01, integral_limit=0.2,
                                                                          target=R_REF),
                                 control_period=0.14, save_every=5, steps=3000, h=0.02),
    # the same law evaluated in Python (state saved by the controller), per-step solver records
    "python-mrp-full-record": lambda: dict(wheels=wheels(), controller=PythonMRP(0.5, 2.0, Ki=0.01, target=R_REF),
                                           control_period=0.14, save_every=5, steps=3000, h=0.02,
                                           solver_record="full"),
    # MRPFeedback with a reference profile runs in Python; its integral is saved by lgvi
    "mrp-profile": lambda: dict(wheels=wheels(), controller=MRPFeedback(0.5, 2.0, Ki=0.01, target=profile),
                                control_period=0.1, save_every=5, steps=3000, h=0.02),
    # no wheels: the compiled law's torque acts on the body (no invariant is declared)
    "mrp-no-wheels": lambda: dict(controller=MRPFeedback(0.5, 2.0, Ki=0.01, target=R_REF), control_period=0.06,
                                  save_every=5, steps=3000, h=0.02),
    # free wheels with friction, no controller, fourth order
    "friction-order4": lambda: dict(wheels=wheels(friction={"coulomb": 1e-4, "viscous": 1e-5}), order=4,
                                    save_every=3, steps=3000, h=0.02),
    # the explicit RKMK scheme (its attitude quaternion is saved): compiled and Python law
    "rkmk4-mrp": lambda: dict(wheels=wheels(), controller=MRPFeedback(0.5, 2.0, Ki=0.01, target=R_REF),
                              control_period=0.1, save_every=5, steps=3000, h=0.02, scheme="rkmk4"),
    "rkmk4-python-mrp": lambda: dict(wheels=wheels(), controller=PythonMRP(0.5, 2.0, target=R_REF),
                                     control_period=0.14, save_every=5, steps=3000, h=0.02, scheme="rkmk4"),
}


@pytest.mark.parametrize("name", list(GYRO_RUNS))
def test_gyrostat_stream_equals_memory_and_resumes_exactly(tmp_path, name):
    ref = lgvi.simulate(BODY, R0, omega0=W0, **GYRO_RUNS[name]())
    assert len(ref.t) > 100
    assert np.ptp(ref.wheel_momentum, axis=0).min() > 0.0 if ref.wheel_axes.size else np.ptp(ref.Pi) > 0.0
    simulate_stream(tmp_path / "full", BODY, R0, omega0=W0, chunk_steps=450, **GYRO_RUNS[name]())
    assert len(read_manifest(tmp_path / "full")["chunks"]) == 7
    same_gyro(read_stream(tmp_path / "full"), ref)

    def interrupt(k, n):          # a Ctrl-C arriving between two chunks
        if k >= 3 * 450:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate_stream(tmp_path / "cut", BODY, R0, omega0=W0, chunk_steps=450, progress=interrupt,
                        **GYRO_RUNS[name]())
    part = read_stream(tmp_path / "cut")
    m = len(part.t)
    assert part.steps == 3 * 450 and not part.meta["complete"] and m < len(ref.t)
    # the samples so far are the run's (the last sample's torque is that of the next record: not yet known)
    same_arrays(part, type(ref)(**{**{k: getattr(ref, k) for k in ("inertia", "h", "meta", "wheel_axes",
                                                                    "spin_inertia")},
                                   **{k: getattr(ref, k)[:m] for k in ("t", "R", "Pi", "wheel_momentum",
                                                                        "wheel_torque")},
                                   "iterations": ref.iterations[:len(part.iterations)],
                                   "residual": ref.residual[:len(part.residual)], "potential": None}),
                ("t", "R", "Pi", "wheel_momentum", "iterations", "residual"))
    assert np.array_equal(part.wheel_torque[:-1], ref.wheel_torque[:m - 1])
    simulate_stream(tmp_path / "cut", BODY, R0, omega0=W0, chunk_steps=450, resume=True, **GYRO_RUNS[name]())
    same_gyro(read_stream(tmp_path / "cut"), ref)
    assert read_stream(tmp_path / "cut").meta["complete"]


def test_gyrostat_resumes_a_state_saved_with_the_five_row_solver_history(tmp_path):
    """A stream saved before the solver's guess kept the forcing and the right sides (``G`` (s, 5, 3)
    then, (s, 11, 3) now) resumes: the guess's history starts empty, so the run continues from the
    plain extrapolation and agrees with the uninterrupted one to the solver's tolerance."""
    kw = GYRO_RUNS["mrp-integral"]()
    ref = lgvi.simulate(BODY, R0, omega0=W0, **kw)

    def interrupt(k, n):
        if k >= 3 * 450:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulate_stream(tmp_path / "old", BODY, R0, omega0=W0, chunk_steps=450, progress=interrupt, **kw)
    path = tmp_path / "old" / "manifest.json"
    manifest = json.loads(path.read_text())
    G = np.asarray(manifest["state"]["G"])
    assert G.shape == (1, 11, 3) and G[0, 3, 1] == 3.0 and G[0, 3, 2] == 3.0
    manifest["state"]["G"] = G[:, :5].tolist()
    path.write_text(json.dumps(manifest))
    simulate_stream(tmp_path / "old", BODY, R0, omega0=W0, chunk_steps=450, resume=True, **kw)
    out = read_stream(tmp_path / "old")
    assert out.meta["complete"] and out.R.shape == ref.R.shape
    np.testing.assert_allclose(out.R, ref.R, rtol=0, atol=1e-13)
    np.testing.assert_allclose(out.wheel_momentum, ref.wheel_momentum, rtol=1e-12, atol=1e-15)


def test_gyrostat_resume_refuses_other_wheels_and_unsaved_controllers(tmp_path):
    kw = GYRO_RUNS["mrp-integral"]()
    with pytest.raises(KeyboardInterrupt):
        simulate_stream(tmp_path / "s", BODY, R0, omega0=W0, chunk_steps=450,
                        progress=lambda k, n: (_ for _ in ()).throw(KeyboardInterrupt) if k >= 900 else None, **kw)
    other = dict(kw, wheels=wheels(max_torque=0.4))
    with pytest.raises(ValueError, match=r"resume: .*started with wheels=.*now wheels=.*differences: wheels"):
        simulate_stream(tmp_path / "s", BODY, R0, omega0=W0, chunk_steps=450, resume=True, **other)
    with pytest.raises(ValueError, match=r"controller=.*MRPFeedback\(K=0.5.*now controller=.*K=0.6"):
        simulate_stream(tmp_path / "s", BODY, R0, omega0=W0, chunk_steps=450, resume=True,
                        **dict(kw, controller=MRPFeedback(0.6, 2.0, Ki=0.01, integral_limit=0.2, target=R_REF)))
    # the refused resumes left the folder as it was (and unlocked): the right run still finishes it
    simulate_stream(tmp_path / "s", BODY, R0, omega0=W0, chunk_steps=450, resume=True, **kw)
    same_gyro(read_stream(tmp_path / "s"), lgvi.simulate(BODY, R0, omega0=W0, **GYRO_RUNS["mrp-integral"]()))

    forgetful = dict(wheels=wheels(), control_period=0.1, steps=2000, h=0.02)
    with pytest.raises(KeyboardInterrupt):
        simulate_stream(tmp_path / "f", BODY, R0, omega0=W0, chunk_steps=400, controller=Forgetful(),
                        progress=lambda k, n: (_ for _ in ()).throw(KeyboardInterrupt) if k >= 800 else None,
                        **forgetful)
    assert read_stream(tmp_path / "f").steps == 800       # the stream itself is kept and readable
    with pytest.raises(ValueError, match=r"resume: the run's Python controller .*Forgetful.* cannot save"):
        simulate_stream(tmp_path / "f", BODY, R0, omega0=W0, chunk_steps=400, controller=Forgetful(), resume=True,
                        **forgetful)
    # a stateless Python law (RotationPD) resumes
    pd = dict(wheels=wheels(), controller=RotationPD(0.5, 2.0, target=R_REF), control_period=0.1, steps=2000,
              h=0.02, save_every=4)
    with pytest.raises(KeyboardInterrupt):
        simulate_stream(tmp_path / "pd", BODY, R0, omega0=W0, chunk_steps=400,
                        progress=lambda k, n: (_ for _ in ()).throw(KeyboardInterrupt) if k >= 800 else None, **pd)
    simulate_stream(tmp_path / "pd", BODY, R0, omega0=W0, chunk_steps=400, resume=True, **pd)
    same_gyro(read_stream(tmp_path / "pd"), lgvi.simulate(BODY, R0, omega0=W0, **pd))


ORBIT_J = np.array([[0.04, 0.003, -0.002], [0.003, 0.06, 0.001], [-0.002, 0.001, 0.075]])
ORBIT = dict(omega0=[0.3, -0.4, 1.3], h=0.01, steps=3000, mu=1.0, save_every=4, J2=0.05, radius=0.3,
             torque=[1e-4, 0.0, -2e-4])
ORBIT_ARGS = (ORBIT_J, 1.0, [1.0, 0.0, 0.1], [0.0, 1.15, 0.05], lgvi.so3.exp([0.4, -0.3, 0.8]))


def test_orbit_stream_equals_memory_and_resumes_exactly(tmp_path):
    ref = lgvi.simulate_orbit(*ORBIT_ARGS, **ORBIT)
    stream_system(tmp_path / "full", "orbit", *ORBIT_ARGS, chunk_steps=400, **ORBIT)
    got = read_stream(tmp_path / "full")
    assert type(got) is OrbitTrajectory and (got.h, got.mass, got.mu) == (ref.h, ref.mass, ref.mu)
    same_arrays(got, ref, ORBIT_FIELDS)
    assert got.meta["invariants"] == ref.meta["invariants"] and np.array_equal(got.energy, ref.energy)

    with pytest.raises(KeyboardInterrupt):
        stream_system(tmp_path / "cut", "orbit", *ORBIT_ARGS, chunk_steps=400, **ORBIT,
                      progress=lambda k, n: (_ for _ in ()).throw(KeyboardInterrupt) if k >= 1200 else None)
    part = read_stream(tmp_path / "cut")
    assert len(part.t) == 1200 // 4 + 1 and np.array_equal(part.x, ref.x[:len(part.t)])
    with pytest.raises(ValueError, match=r"resume: .*started with mu=1.0, now mu=1.1"):
        stream_system(tmp_path / "cut", "orbit", *ORBIT_ARGS, chunk_steps=400, resume=True, **dict(ORBIT, mu=1.1))
    stream_system(tmp_path / "cut", "orbit", *ORBIT_ARGS, chunk_steps=400, resume=True, **ORBIT)
    same_arrays(read_stream(tmp_path / "cut"), ref, ORBIT_FIELDS)


def lump(seed: int, size: float) -> PointMasses:
    """Five point masses at random (an asymmetric body: odd moments too)."""
    rng = np.random.default_rng(seed)
    return PointMasses(rng.uniform(0.1, 0.3, 5), size * rng.normal(size=(5, 3)))


TWO_ARGS = (lump(1, 0.5), lump(2, 0.3), None, None, [4.0, 0.5, 0.3], [0.0, 0.5, 0.1],
            lgvi.so3.exp([0.1, 0.2, 0.3]), lgvi.so3.exp([-0.3, 0.1, 0.2]))
TWO = dict(omega1_0=[0.1, 0.2, 0.6], omega2_0=[0.4, -0.2, 0.1], h=0.02, steps=2000, potential="points",
           save_every=2)


def test_two_body_stream_equals_memory_and_resumes_exactly(tmp_path):
    ref = lgvi.simulate_two_body(*TWO_ARGS, **TWO)
    stream_system(tmp_path / "full", "two_body", *TWO_ARGS, chunk_steps=300, **TWO)
    got = read_stream(tmp_path / "full")
    assert type(got) is TwoBodyTrajectory and (got.h, got.G) == (ref.h, ref.G)
    same_arrays(got, ref, TWO_FIELDS)
    for key, value in ref.moments.items():
        assert got.moments[key].shape == value.shape and np.array_equal(got.moments[key], value), key
    assert np.array_equal(got.energy, ref.energy)

    def interrupt(k, n):
        if k >= 900:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        stream_system(tmp_path / "cut", "two_body", *TWO_ARGS, chunk_steps=300, progress=interrupt, **TWO)
    assert len(read_stream(tmp_path / "cut").t) == 900 // 2 + 1
    with pytest.raises(ValueError, match=r"resume: .*differences: .*moments"):
        stream_system(tmp_path / "cut", "two_body", lump(1, 0.5), lump(3, 0.3), *TWO_ARGS[2:], chunk_steps=300,
                      resume=True, **TWO)
    stream_system(tmp_path / "cut", "two_body", *TWO_ARGS, chunk_steps=300, resume=True, **TWO)
    same_arrays(read_stream(tmp_path / "cut"), ref, TWO_FIELDS)


def test_a_failed_chunk_write_keeps_the_listed_chunks_and_resumes(tmp_path, monkeypatch):
    """A chunk whose write is interrupted (patched): the folder keeps the chunks before it; resume finishes."""
    import lgvi.io.streaming as streaming

    ref = lgvi.simulate_orbit(*ORBIT_ARGS, **ORBIT)
    real = streaming.StreamWriter.append_arrays
    calls = []

    def flaky(self, arrays, **kw):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(self, arrays, **kw)

    monkeypatch.setattr(streaming.StreamWriter, "append_arrays", flaky)
    with pytest.raises(KeyboardInterrupt):
        stream_system(tmp_path / "s", "orbit", *ORBIT_ARGS, chunk_steps=400, **ORBIT)
    monkeypatch.setattr(streaming.StreamWriter, "append_arrays", real)
    assert len(read_manifest(tmp_path / "s")["chunks"]) == 3
    stream_system(tmp_path / "s", "orbit", *ORBIT_ARGS, chunk_steps=400, resume=True, **ORBIT)
    same_arrays(read_stream(tmp_path / "s"), ref, ORBIT_FIELDS)


def test_system_streams_zero_steps_and_bad_names(tmp_path):
    ref = lgvi.simulate(BODY, R0, omega0=W0, h=0.1, steps=0, wheels=wheels())
    simulate_stream(tmp_path / "z", BODY, R0, omega0=W0, h=0.1, steps=0, wheels=wheels())
    same_gyro(read_stream(tmp_path / "z"), ref)
    with pytest.raises(ValueError, match="system.*'rigid_body'|system.*orbit"):
        stream_system(tmp_path / "x", "planet", h=0.1, steps=1)
    # a manifest naming an unknown system is refused, naming it
    path = tmp_path / "z" / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest["meta"]["system"] = "planet"
    path.write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match="'planet', which has no stream format"):
        read_stream(tmp_path / "z")


def test_scenario_with_wheels_streams_and_resumes_like_the_run_in_memory(tmp_path):
    """``lgvi run`` streams [[wheel]] scenarios (Scenario.run_stream): --resume finishes them bit for bit."""
    from pathlib import Path

    from lgvi.io.scenario import load_scenario

    sc = load_scenario(Path(__file__).resolve().parents[1] / "examples" / "wheel_slew.toml")
    ref = sc.run()

    def interrupt(k, n):
        if k >= 2000:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sc.run_stream(tmp_path / "stream", chunk_steps=1000, progress=interrupt)
    assert len(read_manifest(tmp_path / "stream")["chunks"]) == 2
    got = sc.run_stream(tmp_path / "stream", chunk_steps=1000, resume=True)
    same_gyro(got, ref)
    assert got.meta["scenario_name"] == "wheel_slew"


def test_stream_system_runs_the_gyrostat_by_name(tmp_path):
    # stream_system(folder, "gyrostat", ...) goes through the gyrostat's registered run factory:
    # the same stream as simulate_stream(wheels=...), and the in-memory run, bit for bit
    kw = dict(omega0=W0, h=0.01, steps=600, wheels=wheels(), controller=MRPFeedback(K=0.5, P=1.0, target=R_REF),
              control_period=0.05, save_every=3)
    ref = lgvi.simulate(BODY, R0, **kw)
    kw["controller"] = MRPFeedback(K=0.5, P=1.0, target=R_REF)
    stream_system(tmp_path / "s", "gyrostat", BODY, R0, chunk_steps=150, **kw)
    same_gyro(read_stream(tmp_path / "s"), ref)
