"""Scenario files of the loop: an estimator's ``star_tracker`` names a sensor of the spacecraft."""

from __future__ import annotations

import copy

import pytest

from lgvi.io.scenario import ScenarioError
from lgvi.io.scenario_loop import LoopScenario
from lgvi.spacecraft import Gyro, StarTracker


def _dict(star_tracker=True):
    return {
        "integrator": {"h": 0.5, "duration": 10.0},
        "spacecraft": {"body": {"inertia": [0.18, 0.14, 0.06]},
                       "sensor": [{"type": "gyro", "rate": 0.5, "arw": 1e-4, "rrw": 1e-5, "seed": 1},
                                  {"type": "star_tracker", "rate": 0.5, "sigma_cross": 5e-5, "sigma_about": 4e-4,
                                   "seed": 2}]},
        "fsw": {"estimator": [{"type": "mekf", "rate": 0.5, "arw": 1e-4, "rrw": 1e-5, "star_tracker": star_tracker,
                               "P0": [1e-3, 1e-3, 1e-3, 1e-7, 1e-7, 1e-7]}]},
    }


@pytest.mark.parametrize("ref", [True, 1])
def test_the_mekf_takes_the_spacecrafts_star_tracker(ref):
    scen = LoopScenario.from_dict(_dict(ref), "st.toml")
    gyro, st = scen.spacecraft.sensors
    assert isinstance(gyro, Gyro) and isinstance(st, StarTracker)
    assert scen.fsw.estimator[0].star_tracker is st        # the same sensor object: its samples, its noise


def test_no_star_tracker_update():
    d = _dict(False)
    assert LoopScenario.from_dict(d, "st.toml").fsw.estimator[0].star_tracker is None


@pytest.mark.parametrize("ref, words", [
    (0, "index of a StarTracker"),              # the gyro
    (5, "index of a StarTracker"),
    ("star", "true (the spacecraft's StarTracker)"),
])
def test_a_bad_reference_names_the_file_and_key(ref, words):
    with pytest.raises(ScenarioError, match=r"st\.toml.*fsw\.estimator\[0\]\.star_tracker") as err:
        LoopScenario.from_dict(_dict(ref), "st.toml")
    assert words in str(err.value)


def test_true_needs_exactly_one_star_tracker():
    d = _dict(True)
    d["spacecraft"]["sensor"] = [d["spacecraft"]["sensor"][0]]
    with pytest.raises(ScenarioError, match=r"fsw\.estimator\[0\]\.star_tracker.*holds 0"):
        LoopScenario.from_dict(d, "st.toml")
    d = _dict(True)
    d["spacecraft"]["sensor"].append(copy.deepcopy(d["spacecraft"]["sensor"][1]))
    with pytest.raises(ScenarioError, match=r"holds 2 \(at \[1, 2\]\)"):
        LoopScenario.from_dict(d, "st.toml")
