"""Scenario sections of the environment (issue 12, part 7): ``[orbit]``, ``[field]``,
``[[magnetorquer]]`` and ``[controller] type = "bdot"`` build the same run as the Python calls,
and every mistake names its key."""

from __future__ import annotations

import datetime as dt
import re

import numpy as np
import pytest

import lgvi
from lgvi.environment import IGRF, BDot, CircularOrbit, OrbitEnvironment
from lgvi.scenario import Scenario, ScenarioError

pytest.importorskip("ppigrf")


def _scenario(**changes):
    d = {"body": {"inertia": [0.02, 0.025, 0.03]}, "initial": {"omega": [0.17, -0.14, 0.1]},
         "integrator": {"h": 0.1, "duration": 30.0},
         "controller": {"type": "bdot", "gain": 5e4, "period": 1.0},
         "orbit": {"type": "circular", "radius": 6871e3, "inclination": 97.4,
                   "epoch": dt.datetime(2026, 3, 20, tzinfo=dt.timezone.utc)},
         "field": {"model": "igrf"},
         "magnetorquer": [{"axis": list(a), "max_dipole": 0.2} for a in np.eye(3)]}
    for key, value in changes.items():
        if value is None:
            d.pop(key)
        else:
            d[key] = value
    return d


def test_scenario_is_the_python_run():
    traj = Scenario.from_dict(_scenario()).run()
    env = OrbitEnvironment(CircularOrbit(6871e3, np.radians(97.4)), IGRF(), epoch=dt.datetime(2026, 3, 20))
    ref = lgvi.simulate(lgvi.RigidBody([0.02, 0.025, 0.03]), np.eye(3), omega0=[0.17, -0.14, 0.1], h=0.1,
                        steps=300, controller=BDot(5e4), control_period=1.0, environment=env,
                        magnetorquers=lgvi.Magnetorquers(np.eye(3), 0.2))
    assert np.array_equal(traj.R, ref.R) and np.array_equal(traj.Pi, ref.Pi)
    assert np.linalg.norm(traj.omega[-1]) < np.linalg.norm(traj.omega[0])


def test_sgp4_orbit_takes_the_tle_epoch():
    pytest.importorskip("sgp4")
    tle = {"type": "sgp4", "line1": "1 25544U 98067A   26079.50000000  .00016717  00000-0  10270-3 0  9006",
           "line2": "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815361  2048"}
    sc = Scenario.from_dict(_scenario(orbit=tle))
    assert sc.environment.epoch == dt.datetime(2026, 3, 20, 12)


@pytest.mark.parametrize("changes, key, rule", [
    (dict(orbit={"type": "elliptic", "a": 7e6}), r"orbit\.type", r"'circular', 'kepler', 'j2', 'sgp4'"),
    (dict(orbit={"type": "kepler", "a": 7e6, "e": 1.2}), r"\borbit\b", r"0 <= e < 1"),
    (dict(orbit={"type": "circular", "radius": 7e6, "inclination": 97.4}), r"orbit\.epoch", r"needs a date"),
    (dict(orbit={"type": "circular", "radius": 7e6, "epoch": "yesterday"}), r"orbit\.epoch", r"date-time"),
    (dict(orbit={"type": "circular", "radis": 7e6}), r"orbit\.radis", r"did you mean 'radius'"),
    (dict(orbit=None), r"\bfield\b", r"add an \[orbit\] table"),
    (dict(field={"model": "igrf", "degree": 14}), r"\bfield\b", r"degree must be <= 13"),
    (dict(field={"model": "chaos"}), r"field\.model", r"'igrf', 'wmm', 'dipole'"),
    (dict(magnetorquer=[{"axis": [1.0, 0.0, 0.0], "max_dipole": -1.0}]), r"magnetorquer\[0\]\.max_dipole",
     r"positive"),
    (dict(magnetorquer={"axis": [1.0, 0.0, 0.0], "max_dipole": 1.0}), r"\bmagnetorquer\b", r"double brackets"),
    (dict(controller={"type": "bdot", "period": 1.0}), r"controller\.gain", r"positive number"),
    (dict(controller={"type": "bdot", "gain": 1.0, "period": 1.0, "derivative": "exact"}),
     r"controller\.derivative", r"'difference', 'rate'"),
])
def test_scenario_mistakes_name_the_key(changes, key, rule):
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(_scenario(**changes))
    msg = str(info.value)
    assert re.search(key, msg) and re.search(rule, msg), msg
