"""Today's keywords of lgvi.simulate (wheels=, controller=, control_period=, environment=,
magnetorquers=) mapped onto lgvi.Spacecraft and lgvi.FlightSoftware (lgvi.systems.loop_keywords).

Each mapped call is checked three ways: it warns (a DeprecationWarning naming the replacement), it
is the run of the descriptions it names, and it is the gyrostat's run of the same keywords (the
path it took before, still reachable with ``loop_keywords.as_given()``), bit for bit.
"""

from __future__ import annotations

import datetime as dt
import warnings

import numpy as np
import pytest

import lgvi
from lgvi.control import MRPFeedback, RotationPD
from lgvi.environment import BDot, CentredDipole, CircularOrbit, OrbitEnvironment
from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
from lgvi.spacecraft import Spacecraft
from lgvi.systems.gyrostat import GyrostatTrajectory
from lgvi.systems.loop_keywords import KeywordsDeprecationWarning, as_given
from lgvi.systems.spacecraft import SpacecraftTrajectory

S3 = 1.0 / np.sqrt(3.0)
PYRAMID = np.array([[S3, S3, S3], [-S3, S3, S3], [S3, -S3, S3], [-S3, -S3, S3]])
CUBESAT = [0.18, 0.14, 0.06]
R_TARGET = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))
ORBIT = CircularOrbit(6878137.0, np.radians(97.4))
EPOCH = dt.datetime(2026, 1, 1)
KW = dict(omega0=[0.01, -0.02, 0.015], h=0.1, steps=200, save_every=10)
FIELDS = ("t", "R", "Pi", "wheel_momentum", "wheel_torque", "iterations", "residual")


def _wheels():
    return lgvi.ReactionWheels(PYRAMID, 1e-4, speed0=[10.0, -20.0, 5.0, 0.0], max_torque=0.004)


def _same(a, b):
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        if x is None and y is None:
            continue
        assert np.array_equal(x, y), name


def _old_new_given(old, new_spacecraft, new_fsw, match):
    body = lgvi.RigidBody(CUBESAT)
    with pytest.warns(KeywordsDeprecationWarning, match=match) as record:
        mapped = lgvi.simulate(body, np.eye(3), **old(), **KW)
    assert all(issubclass(w.category, DeprecationWarning) for w in record)
    assert record[0].filename == __file__                 # the warning points at the caller's line
    assert isinstance(mapped, SpacecraftTrajectory)
    new = lgvi.simulate(new_spacecraft(body), np.eye(3), fsw=new_fsw(), **KW)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        with as_given():
            given = lgvi.simulate(body, np.eye(3), **old(), **KW)
    assert type(given) is GyrostatTrajectory
    _same(mapped, new)
    _same(mapped, given)
    assert mapped.meta["invariants"] == given.meta["invariants"]        # what summaries and figures check
    return mapped, given


def test_wheels_alone_are_a_spacecraft_with_wheels():
    _old_new_given(lambda: dict(wheels=_wheels()), lambda body: Spacecraft(body, wheels=_wheels()),
                   lambda: None, r"lgvi\.Spacecraft\(body, wheels=wheels\)")


def test_the_compiled_mrp_feedback_is_inertial_pointing_and_mrp_control():
    mapped, given = _old_new_given(
        lambda: dict(wheels=_wheels(), control_period=1.0,
                     controller=MRPFeedback(K=0.004, P=0.04, Ki=0.002, integral_limit=0.1, target=R_TARGET)),
        lambda body: Spacecraft(body, wheels=_wheels()),
        lambda: FlightSoftware(guidance=InertialPointing(R_TARGET),
                               control=MRPControl(K=0.004, P=0.04, Ki=0.002, integral_limit=0.1),
                               actuators=RWMotorTorque(), rate=1.0),
        r"InertialPointing\(target\).*MRPControl")
    assert np.abs(mapped.wheel_torque).max() > 0                  # the controller acted
    assert "sigma_BR" in mapped.signals


def test_a_python_controller_with_an_orbit_environment():
    env = OrbitEnvironment(ORBIT)
    mapped, _ = _old_new_given(
        lambda: dict(wheels=_wheels(), controller=RotationPD(0.004, 0.04, target=R_TARGET), control_period=0.5,
                     environment=env),
        lambda body: Spacecraft(body, wheels=_wheels(), orbit=ORBIT, environment_rate=0.5),
        lambda: FlightSoftware(controller=RotationPD(0.004, 0.04, target=R_TARGET), control_period=0.5),
        r"FlightSoftware\(controller=controller, control_period=control_period\)")
    assert "r_N" in mapped.signals                                 # the orbit ran in the loop too


def test_bdot_with_magnetorquers_and_a_field():
    rods = lgvi.Magnetorquers(np.eye(3), 0.2)
    env = OrbitEnvironment(ORBIT, CentredDipole(), epoch=EPOCH)
    mapped, _ = _old_new_given(
        lambda: dict(controller=BDot(2e4, derivative="difference"), control_period=1.0, environment=env,
                     magnetorquers=rods),
        lambda body: Spacecraft(body, magnetorquers=rods, orbit=ORBIT, field=CentredDipole(), epoch=EPOCH,
                                environment_rate=1.0),
        lambda: FlightSoftware(controller=BDot(2e4, derivative="difference"), control_period=1.0),
        r"magnetorquers=magnetorquers")
    assert mapped.kinetic_energy[-1] < mapped.kinetic_energy[0]


@pytest.mark.parametrize("extra", ["torque", "rkmk4", "error_estimate"])
def test_keywords_without_an_exact_equivalent_keep_the_gyrostat_silently(extra):
    body = lgvi.RigidBody(CUBESAT)
    kw = dict(wheels=_wheels(), **KW)
    if extra == "torque":                 # a torque model: the loop has disturbances, not torque= models
        kw["torque"] = lgvi.environment.OrbitGravityGradient(ORBIT, body, duration=30.0)
    elif extra == "rkmk4":
        kw["scheme"] = "rkmk4"
    else:
        kw["error_estimate"] = True
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        tr = lgvi.simulate(body, np.eye(3), **kw)
    assert isinstance(tr, GyrostatTrajectory) and not isinstance(tr, SpacecraftTrajectory)


def test_bad_old_keywords_are_still_named_by_the_gyrostat():
    with pytest.raises(ValueError, match="control_period"):
        lgvi.simulate(lgvi.RigidBody(CUBESAT), np.eye(3), wheels=_wheels(), control_period=1.0, **KW)
    with pytest.raises(ValueError, match="control_period"):
        lgvi.simulate(lgvi.RigidBody(CUBESAT), np.eye(3), wheels=_wheels(), controller=RotationPD(0.004, 0.04),
                      control_period=0.15, **KW)


def _members_same(mapped, given):
    assert len(mapped.members) == len(given.members)
    for a, b in zip(mapped.members, given.members):
        _same(a, b)


@pytest.mark.parametrize("case", ["wheels", "mrp_feedback", "python_controller"])
def test_simulate_ensemble_maps_the_keywords_member_by_member(case):
    """simulate_ensemble(wheels=, controller=) runs the descriptions (a SpacecraftEnsemble) with a
    warning naming them, each member bit for bit the gyrostat ensemble's, its params kept."""
    from lgvi.systems.gyrostat_ensemble import GyrostatEnsemble
    from lgvi.systems.spacecraft import SpacecraftEnsemble

    bodies = [lgvi.RigidBody(CUBESAT), lgvi.RigidBody([0.2, 0.14, 0.07])]
    R0 = np.stack([np.eye(3), lgvi.so3.exp([0.1, 0.0, -0.2])])
    kw = dict(omega0=[[0.01, -0.02, 0.015], [0.0, 0.01, 0.0]], h=0.1, steps=120, save_every=10, threads=1)
    if case == "wheels":
        old = dict(wheels=[_wheels(), lgvi.ReactionWheels(PYRAMID, 2e-4, speed0=1.0)])
    elif case == "mrp_feedback":
        old = dict(wheels=_wheels(), control_period=1.0,
                   controller=[MRPFeedback(K=k, P=0.04, Ki=0.002, integral_limit=0.1, target=R_TARGET)
                               for k in (0.004, 0.006)])
    else:
        old = dict(wheels=_wheels(), controller=RotationPD(0.004, 0.04, target=R_TARGET), control_period=0.5,
                   environment=OrbitEnvironment(ORBIT))
    with pytest.warns(KeywordsDeprecationWarning, match=r"lgvi\.simulate_ensemble\(lgvi\.Spacecraft") as record:
        mapped = lgvi.simulate_ensemble(bodies, R0, **old, **kw)
    assert record[0].filename == __file__
    assert type(mapped) is SpacecraftEnsemble
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        with as_given():
            given = lgvi.simulate_ensemble(bodies, R0, **old, **kw)
    assert type(given) is GyrostatEnsemble
    _members_same(mapped, given)
    assert not np.array_equal(mapped[0].R, mapped[1].R)
    for name, value in given.params.items():              # the dispersions stay readable by their names
        assert np.array_equal(mapped.params[name], value), name


def test_simulate_stream_maps_the_keywords_and_resumes_either_kind(tmp_path):
    from lgvi.io.streaming import read_manifest, read_stream, simulate_stream

    body = lgvi.RigidBody(CUBESAT)

    def old():
        return dict(wheels=_wheels(), control_period=1.0,
                    controller=MRPFeedback(K=0.004, P=0.04, Ki=0.002, integral_limit=0.1, target=R_TARGET))

    with as_given():
        memory = lgvi.simulate(body, np.eye(3), **old(), **KW)

    def stop(done, total):
        if done >= 100:
            raise KeyboardInterrupt

    with pytest.warns(KeywordsDeprecationWarning, match=r"lgvi\.simulate_stream\(lgvi\.Spacecraft") as record:
        with pytest.raises(KeyboardInterrupt):
            simulate_stream(tmp_path / "new", body, np.eye(3), **old(), chunk_steps=50, progress=stop, **KW)
    assert record[0].filename == __file__
    with pytest.warns(KeywordsDeprecationWarning):
        simulate_stream(tmp_path / "new", body, np.eye(3), **old(), chunk_steps=50, resume=True, **KW)
    assert read_manifest(tmp_path / "new")["meta"]["system"] == "spacecraft"
    back = read_stream(tmp_path / "new")
    assert isinstance(back, SpacecraftTrajectory)
    _same(back, memory)
    # a stream the gyrostat began (before the mapping) resumes as the gyrostat, silently
    with as_given(), pytest.raises(KeyboardInterrupt):
        simulate_stream(tmp_path / "old", body, np.eye(3), **old(), chunk_steps=50, progress=stop, **KW)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        simulate_stream(tmp_path / "old", body, np.eye(3), **old(), chunk_steps=50, resume=True, **KW)
    old_back = read_stream(tmp_path / "old")
    assert type(old_back) is GyrostatTrajectory
    _same(old_back, memory)
