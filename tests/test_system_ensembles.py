"""Monte Carlo runs of any system (:func:`lgvi.simulate_members`): member b is the single run, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi import ConvergenceError, simulate_members
from lgvi.systems.orbit import OrbitRun


@pytest.fixture(autouse=True)
def _old_keywords_run_the_gyrostat():
    """``lgvi.simulate(..., wheels=, controller=)`` here is the gyrostat's run as given (the reference
    of its streams and of simulate_members), not the loop it maps onto (lgvi.systems.loop_keywords)."""
    from lgvi.systems.loop_keywords import as_given

    with as_given():
        yield


def _orbit_members(n: int = 3) -> list[dict]:
    out = []
    for b in range(n):
        out.append(dict(body=[1.0, 2.0, 3.0], mass=10.0, x0=[7000.0 + 50.0 * b, 0.0, 0.0], v0=[0.0, 7.546, 0.0],
                        R0=np.eye(3), omega0=[0.0, 1e-3 * b, 1e-3], h=10.0, steps=120, mu=398600.4418,
                        save_every=4))
    return out


def _two_body_members(n: int = 3) -> list[tuple[tuple, dict]]:
    out = []
    for b in range(n):
        args = (lgvi.Ellipsoid(1.0, 0.7, 0.5), lgvi.Ellipsoid(0.3, 0.25, 0.2), 1.0, 0.1, [3.0 + 0.1 * b, 0, 0],
                [0, 0.6, 0], np.eye(3), np.eye(3))
        out.append((args, dict(omega1_0=[0, 0, 1.0], omega2_0=[0, 0.1 * b, 0.2], h=0.05, steps=60,
                               potential="order4", save_every=3)))
    return out


def _same(a, b, fields) -> None:
    assert type(a) is type(b)
    for name in ("t",) + fields + ("iterations", "residual"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


ORBIT_FIELDS = ("x", "p", "R", "Pi")


@pytest.mark.parametrize("threads", [1, 2])
def test_orbit_members_bit_for_bit(threads):
    members = _orbit_members()
    ens = simulate_members("orbit", members, threads=threads)
    assert len(ens) == 3 and ens.system == "orbit"
    for b, kw in enumerate(members):
        _same(ens[b], lgvi.simulate_orbit(**kw), ORBIT_FIELDS)
    assert ens.x.shape == (3, 31, 3) and ens.R.shape == (3, 31, 3, 3)
    assert np.array_equal(ens.x[2], ens[2].x)
    assert not np.array_equal(ens.x[0], ens.x[1])        # the members differ


@pytest.mark.parametrize("threads", [1, 2])
def test_two_body_members_bit_for_bit(threads):
    members = _two_body_members()
    ens = simulate_members("two_body", members, threads=threads)
    for b, (args, kw) in enumerate(members):
        _same(ens[b], lgvi.simulate_two_body(*args, **kw), ORBIT_FIELDS)
    assert ens.Pi.shape == (3, 21, 2, 3)


def test_dask_client_same_as_single_runs(monkeypatch):
    distributed = pytest.importorskip("dask.distributed")
    members = _orbit_members(3)
    seen = []
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=":0") as cluster, distributed.Client(cluster) as client:
        ens = simulate_members("orbit", members, client=client, progress=lambda done, total: seen.append((done, total)))
        for b, kw in enumerate(members):
            _same(ens[b], lgvi.simulate_orbit(**kw), ORBIT_FIELDS)
        assert seen[-1] == (3, 3)
        real = OrbitRun.advance

        def advance(self, *a):
            if self.x[0] > 7090.0:          # member 2 fails on its worker
                raise ConvergenceError("orbit step failed", step=self.k)
            return real(self, *a)

        monkeypatch.setattr(OrbitRun, "advance", advance)
        with pytest.raises(ConvergenceError, match=r"^member 2: orbit step failed") as info:
            simulate_members("orbit", members, client=client)
    assert info.value.member == 2 and sorted(info.value.members) == [0, 1]


def test_bad_member_names_its_index():
    members = _orbit_members()
    members[1]["mass"] = -1.0
    with pytest.raises(ValueError, match=r"member 1: .*mass") as info:
        simulate_members("orbit", members, threads=2)
    assert info.value.member == 1
    members = _orbit_members(2) + [[1, 2]]
    with pytest.raises(TypeError, match=r"members\[2\]"):
        simulate_members("orbit", members)
    with pytest.raises(ValueError, match="system must be one of"):
        simulate_members("moon", _orbit_members(1))


@pytest.mark.parametrize("threads", [1, 2])
def test_failing_member_names_its_index_and_keeps_the_others(monkeypatch, threads):
    real = OrbitRun.advance

    def advance(self, *a):
        if self.x[0] > 7090.0:          # member 2 only (x0 = 7100)
            raise ConvergenceError("orbit step failed", step=self.k)
        return real(self, *a)

    monkeypatch.setattr(OrbitRun, "advance", advance)
    members = _orbit_members()
    with pytest.raises(ConvergenceError, match=r"^member 2: orbit step failed") as info:
        simulate_members("orbit", members, threads=threads)
    assert info.value.member == 2
    done = info.value.members
    assert 2 not in done
    if threads == 1:
        assert sorted(done) == [0, 1]
    for b, traj in done.items():
        _same(traj, lgvi.simulate_orbit(**members[b]), ORBIT_FIELDS)


@pytest.mark.parametrize("threads", [1, 2])
def test_ctrl_c_keeps_the_finished_members(monkeypatch, threads):
    import os
    import signal
    import threading
    import types

    real = OrbitRun.advance
    stops: list[threading.Event] = []

    class Stop(threading.Event):       # the stop request of simulate_members' thread pool, seen by the test
        def __init__(self) -> None:
            super().__init__()
            stops.append(self)

    def advance(self, *a):
        if 7040.0 < self.x[0] < 7060.0 and self.k == 0:     # member 1 presses Ctrl-C in its first chunk
            os.kill(os.getpid(), signal.SIGINT)
            if stops:                  # on a thread: wait until the main thread has seen it and asked to stop,
                stops[0].wait()        # however long a busy machine takes (no race on thread timing)
        return real(self, *a)

    namespace = types.SimpleNamespace(**{**vars(threading), "Event": Stop})
    monkeypatch.setattr(lgvi.system_ensembles, "threading", namespace)
    monkeypatch.setattr(OrbitRun, "advance", advance)
    monkeypatch.setattr(lgvi.systems.orbit, "CHUNK_STEPS", 8)     # 15 chunks a member: stops between them
    members = _orbit_members()
    with pytest.raises(lgvi.SimulationInterrupted, match="members finished") as info:
        simulate_members("orbit", members, threads=threads)
    done = info.value.members
    assert 1 not in done
    if threads == 1:
        assert sorted(done) == [0]
    for b, traj in done.items():
        _same(traj, lgvi.simulate_orbit(**members[b]), ORBIT_FIELDS)


@pytest.mark.parametrize("threads", [1, 2])
def test_real_convergence_failure_keeps_the_members_run(threads):
    members = _orbit_members()
    members[1].update(max_iter=1, tol=1e-300, omega0=[0.5, 0.3, 1.0])   # cannot converge in one iteration
    with pytest.raises(ConvergenceError, match=r"^member 1: orbit step 0 ") as info:
        simulate_members("orbit", members, threads=threads)
    err = info.value
    assert err.member == 1 and err.step == 0 and isinstance(err.trajectory, lgvi.OrbitTrajectory)
    assert 1 not in err.members
    if threads == 1:
        assert sorted(err.members) == [0]
    for b, traj in err.members.items():
        _same(traj, lgvi.simulate_orbit(**members[b]), ORBIT_FIELDS)


# ------------------------------------------------------------------------------------------------
# the gyrostat: reaction wheels and a control loop (SYSTEMS["gyrostat"].run = gyrostat_run)
# ------------------------------------------------------------------------------------------------
from lgvi.control import Command, Controller, MRPFeedback  # noqa: E402

GYRO_FIELDS = ("R", "Pi", "wheel_momentum", "wheel_torque")
AXES = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]) / np.array(
    [[1.0], [1.0], [1.0], [np.sqrt(3.0)]])


class Counting(Controller):
    """A stateful Python controller: the command depends on how often it was called since reset."""

    def __init__(self, scale: float) -> None:
        self.scale = scale
        self.calls = 0

    def reset(self) -> None:
        self.calls = 0

    def __repr__(self) -> str:
        return f"Counting({self.scale})"

    def command(self, t, R, omega, wheel_speed, env):
        self.calls += 1
        return Command(wheel_torque=self.scale * np.sin(0.3 * self.calls + np.arange(len(wheel_speed))))


def _gyro_members(shared: Controller) -> list[dict]:
    wheels = lgvi.ReactionWheels(AXES, [0.02, 0.03, 0.04, 0.05], speed0=[10.0, -5.0, 3.0, 7.0], max_torque=0.5)
    base = dict(body=lgvi.RigidBody([1.0, 2.0, 3.0]), R0=lgvi.so3.exp([0.3, -0.2, 0.5]), h=0.02, steps=400,
                wheels=wheels, control_period=0.1, save_every=4)
    return [dict(base, omega0=[0.3, 1.0, 0.2], controller=shared),          # one Python controller object ...
            dict(base, omega0=[0.3, 1.1, 0.2], controller=shared),          # ... given to three members
            dict(base, omega0=[0.2, 1.0, 0.2], controller=MRPFeedback(0.5, 2.0, Ki=0.01, integral_limit=0.2)),
            dict(base, omega0=[0.3, 1.0, 0.3], controller=shared, Pi0=None, order=4)]


@pytest.mark.parametrize("threads", [1, 2])
def test_gyrostat_members_bit_for_bit_each_with_its_own_controller(threads):
    """simulate_members("gyrostat", ...) gives lgvi.simulate(..., wheels=, controller=) bit for bit; a
    stateful controller object given to several members is copied per member (left untouched)."""
    shared = Counting(0.05)
    members = _gyro_members(shared)
    ens = simulate_members("gyrostat", members, threads=threads)
    assert shared.calls == 0                            # each member ran its own copy
    for b, kw in enumerate(members):
        ctrl = kw["controller"]
        fresh = Counting(0.05) if isinstance(ctrl, Counting) else MRPFeedback(0.5, 2.0, Ki=0.01, integral_limit=0.2)
        single = lgvi.simulate(**dict(kw, controller=fresh))
        _same(ens[b], single, GYRO_FIELDS)
        assert ens[b].meta["controller"] == single.meta["controller"]
    assert ens.wheel_momentum.shape == (4, 101, 4)
    assert not np.array_equal(ens.R[0], ens.R[1])


@pytest.mark.parametrize("threads", [1, 2])
def test_gyrostat_members_with_scheme_rkmk4_are_the_lone_runs_bit_for_bit(threads):
    """scheme="rkmk4" (and its tableau) reaches every member: member b is lgvi.simulate(**member b)."""
    shared = Counting(0.05)
    members = [dict(kw, scheme="rkmk4", **tab) for kw, tab in
               zip(_gyro_members(shared), ({}, {"composition": "rk38"}, {"composition": "ralston4"}, {}))]
    ens = simulate_members("gyrostat", members, threads=threads)
    assert shared.calls == 0
    for b, kw in enumerate(members):
        fresh = Counting(0.05) if isinstance(kw["controller"], Counting) else \
            MRPFeedback(0.5, 2.0, Ki=0.01, integral_limit=0.2)
        single = lgvi.simulate(**dict(kw, controller=fresh))
        assert ens[b].meta["scheme"] == single.meta["scheme"] == "rkmk4"
        assert ens[b].meta["composition"] == single.meta["composition"]
        _same(ens[b], single, GYRO_FIELDS)
        assert np.all(ens[b].iterations == 0)            # explicit: the RKMK run, not the LGVI's
    lgvi_run = lgvi.simulate(**dict(members[1], scheme=None, composition=None, controller=Counting(0.05)))
    assert not np.array_equal(ens.R[1], lgvi_run.R)


def test_gyrostat_member_refuses_what_simulate_members_cannot_run():
    members = _gyro_members(Counting(0.05))
    with pytest.raises(ValueError, match=r"^member 1: error_estimate must be False") as info:
        simulate_members("gyrostat", [members[0], dict(members[1], error_estimate=True)])
    assert info.value.member == 1
    with pytest.raises(ValueError, match=r"^member 0: scheme must be None or 'lgvi'"):
        simulate_members("gyrostat", [dict(members[0], scheme="splitting")])
    with pytest.raises(TypeError, match=r"^member 0: controller: .*cannot be copied"):
        gen = (x for x in range(3))

        class Uncopyable(Counting):
            def __deepcopy__(self, memo):
                raise TypeError(f"holds {gen!r}")

        simulate_members("gyrostat", [dict(members[0], controller=Uncopyable(0.05))])


def test_gyrostat_members_on_dask_same_as_single_runs():
    distributed = pytest.importorskip("dask.distributed")
    shared = Counting(0.05)
    members = _gyro_members(shared)[:3]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=":0") as cluster, distributed.Client(cluster) as client:
        ens = simulate_members("gyrostat", members, client=client)
    assert shared.calls == 0
    for b, kw in enumerate(members):
        fresh = Counting(0.05) if kw["controller"] is shared else MRPFeedback(0.5, 2.0, Ki=0.01, integral_limit=0.2)
        _same(ens[b], lgvi.simulate(**dict(kw, controller=fresh)), GYRO_FIELDS)
