"""Scenario files of the compiled spacecraft loop (issue 25, part 5): ``[spacecraft]`` and ``[fsw]``
build the same run as the Python descriptions (bit for bit), and every mistake names the file and
its key before any step runs."""

from __future__ import annotations

import copy
import json
import datetime as dt
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi.environment import CentredDipole, CircularOrbit
from lgvi.fsw import (BDotControl, FlightSoftware, HillPointing, InertialPointing, ModeRules, MRPControl,
                      RWMotorTorque)
from lgvi.io.scenario import ScenarioError, load_scenario
from lgvi.io.scenario_loop import LoopScenario
from lgvi.scenario import Scenario
from lgvi.spacecraft import GravityGradient, Spacecraft

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "nadir_pointing.toml"
S = 1 / np.sqrt(3)
AXES = [[S, S, S], [-S, S, S], [S, -S, S], [-S, -S, S]]


def _sixu_python():
    wheels = lgvi.ReactionWheels(AXES, 1e-4, max_torque=0.004)
    sat = Spacecraft([0.18, 0.14, 0.06], wheels=wheels, orbit=CircularOrbit(6878137.0, np.radians(97.4)),
                     disturbances=[GravityGradient()])
    fsw = FlightSoftware(guidance=HillPointing(), control=MRPControl(K=0.0035, P=0.035), actuators=RWMotorTorque(),
                         rate=1.0)
    return sat, fsw


def _dict():
    """A short B-dot then inertial-pointing scenario, as a dict (modified by the error tests)."""
    return {
        "initial": {"omega": [0.03, -0.02, 0.01]},
        "integrator": {"h": 0.5, "duration": 100.0, "save_every": 2},
        "spacecraft": {"body": {"inertia": [0.18, 0.14, 0.06]}, "epoch": dt.datetime(2026, 1, 1),
                       "magnetorquer_rate": 1.0,
                       "wheel": [{"axis": a, "spin_inertia": 1e-4, "max_torque": 0.004} for a in AXES],
                       "magnetorquer": [{"axis": list(a), "max_dipole": 1.0} for a in np.eye(3)],
                       "orbit": {"type": "circular", "radius": 6878137.0, "inclination": 97.4},
                       "field": {"model": "dipole"}},
        "fsw": {"rate": 1.0,
                "guidance": [{"type": "inertial", "modes": [1],
                              "R_ref": {"rotvec": [0.0, 0.0, 0.3]}}],
                "control": [{"type": "bdot", "gain": 2e4, "derivative": "rate", "modes": [0]},
                            {"type": "mrp_feedback", "K": 0.004, "P": 0.04, "modes": [1]}],
                "actuator": [{"type": "rw_motor_torque", "modes": [1]}],
                "modes": {"rules": [[0, 1, "rate_below", 0.0372]]}},
    }


def test_example_is_the_python_run():
    """examples/nadir_pointing.toml (the 6U of issue 25, one orbit) is lgvi.simulate with the
    descriptions built in Python, bit for bit, and it points: under 1e-3 deg after the slew."""
    sc = load_scenario(EXAMPLE)
    assert isinstance(sc, LoopScenario) and sc.steps == 56770 and sc.save_every == 10
    traj = sc.run()
    sat, fsw = _sixu_python()
    ref = lgvi.simulate(sat, np.eye(3), omega0=[0.0, 0.0, 0.0011], h=0.1, steps=56770, fsw=fsw, save_every=10)
    np.testing.assert_array_equal(traj.R, ref.R)
    np.testing.assert_array_equal(traj.wheel_speed, ref.wheel_speed)
    assert sorted(traj.signals) == sorted(ref.signals)
    for name in ref.signals:
        np.testing.assert_array_equal(traj.signals[name], ref.signals[name])
    err = np.degrees(4 * np.arctan(np.linalg.norm(traj.signals["sigma_BR"], axis=1)))
    assert err[0] > 90.0 and err[traj.signal_t > 1000.0].max() < 1e-3
    assert traj.meta["scenario_name"] == "nadir_pointing"


def test_modes_bdot_and_magnetorquers_are_the_python_run():
    sc = Scenario.from_dict(copy.deepcopy(_dict()))
    traj = sc.run()
    wheels = lgvi.ReactionWheels(AXES, 1e-4, max_torque=0.004)
    sat = Spacecraft([0.18, 0.14, 0.06], wheels=wheels, magnetorquers=lgvi.Magnetorquers(np.eye(3), 1.0),
                     orbit=CircularOrbit(6878137.0, np.radians(97.4)), field=CentredDipole(),
                     epoch=dt.datetime(2026, 1, 1), magnetorquer_rate=1.0)
    from scipy.spatial.transform import Rotation

    fsw = FlightSoftware(guidance=InertialPointing(Rotation.from_rotvec([0, 0, 0.3]).as_matrix(), modes=[1]),
                         control=[BDotControl(2e4, derivative="rate", modes=[0]),
                                  MRPControl(K=0.004, P=0.04, modes=[1])],
                         actuators=RWMotorTorque(modes=[1]), modes=ModeRules([(0, 1, "rate_below", 0.0372)]), rate=1.0)
    ref = lgvi.simulate(sat, np.eye(3), omega0=[0.03, -0.02, 0.01], h=0.5, steps=200, fsw=fsw, save_every=2)
    np.testing.assert_array_equal(traj.R, ref.R)
    for name in ("mode", "dipole_B", "sigma_BR"):
        np.testing.assert_array_equal(traj.signals[name], ref.signals[name])
    assert set(np.unique(traj.signals["mode"])) == {0.0, 1.0}      # it switched


@pytest.mark.parametrize("edit, key, words", [
    (lambda d: d["fsw"]["control"][1].pop("K"), "fsw.control[1].K", "missing"),
    (lambda d: d["fsw"]["control"][1].update(K=-1.0), "fsw.control[1].K", "K"),
    (lambda d: d["fsw"]["control"][1].update(Kp=1.0), "fsw.control[1].Kp", "unknown key"),
    (lambda d: d["fsw"]["guidance"][0].update(type="hil"), "fsw.guidance[0].type", "did you mean 'hill'"),
    (lambda d: d["fsw"]["guidance"][0].update(type="mrp_feedback"), "fsw.guidance[0].type", "expected one of"),
    (lambda d: d["fsw"].update(rate=0.7), "fsw.rate", "multiple"),
    (lambda d: d["fsw"]["control"][1].update(rate=0.75), "fsw.control[1].rate", "multiple"),
    (lambda d: d["spacecraft"].update(magnetorquer_rate=0.3), "spacecraft.magnetorquer_rate", "multiple"),
    (lambda d: d["fsw"]["modes"].update(rules=[[0, 1, "rate_under", 0.03]]), "fsw.modes.rules[0]", "condition"),
    (lambda d: d["fsw"].update(record=["sigma_XY"]), "fsw.record[0]", "not a signal"),
    (lambda d: d["fsw"].update(record_rate="every"), "fsw.record_rate", "expected one of 'writer', 'grid'"),
    (lambda d: d["spacecraft"].pop("wheel"), "fsw.actuator[0]", "wheels"),
    (lambda d: d["spacecraft"]["body"].update(inertia=[1.0, 2.0]), "spacecraft.body.inertia", "3 numbers"),
    (lambda d: d["spacecraft"]["wheel"][0].pop("spin_inertia"), "spacecraft.wheel[0].spin_inertia", "missing"),
    (lambda d: d["spacecraft"]["orbit"].update(type="halo"), "spacecraft.orbit.type", "expected one of"),
    (lambda d: d["spacecraft"].update(disturbance=[{"type": "gravity_gradient", "mu": "big"}]),
     "spacecraft.disturbance[0].mu", "mu"),
    (lambda d: d["spacecraft"].update(colour="red"), "spacecraft.colour", "unknown key"),
    (lambda d: d["integrator"].update(save_every=3), "integrator.save_every", "divisor"),
])
def test_errors_name_the_file_and_key(edit, key, words):
    d = _dict()
    edit(d)
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(d, source="mission.toml")
    assert info.value.key == key, str(info.value)
    assert str(info.value).startswith(f"mission.toml: {key}: ") and words in str(info.value)


def test_record_rate_in_a_file():
    """The default records the B-dot law, run every step (0.5 s), in its own slots on the 1 s record
    grid (save_every = 2); fsw.record_rate = "grid" keeps the grid's columns only, the same run."""
    d = _dict()
    d["fsw"]["control"][0]["rate"] = 0.5
    full = Scenario.from_dict(copy.deepcopy(d)).run()
    d["fsw"]["record_rate"] = "grid"
    grid = Scenario.from_dict(d).run()
    np.testing.assert_array_equal(full.R, grid.R)
    assert grid.meta["signal_fast"] == [] and "dipole_request_B" in {r[0] for r in full.meta["signal_fast"]}
    assert full.records["dipole_request_B"].complete and not grid.records["dipole_request_B"].complete


def test_guidance_without_orbit_is_refused_before_a_step():
    d = _dict()
    for k in ("orbit", "field", "magnetorquer", "magnetorquer_rate"):
        d["spacecraft"].pop(k)
    d["fsw"] = {"guidance": {"type": "hill"}}
    with pytest.raises(ScenarioError, match=r"<dict>: fsw.guidance: .*r_N"):
        Scenario.from_dict(d)


def test_every_guidance_alias_names_a_registered_kind():
    from lgvi.components import COMPONENT_KINDS
    from lgvi.io.scenario_loop import ALIASES

    for family, table in ALIASES.items():
        for alias, name in table.items():
            assert COMPONENT_KINDS[name].family == family, alias


def _cli(capsys, *argv):
    from lgvi import cli

    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_lgvi_run_draws_and_summarises_the_records(capsys, tmp_path):
    """``lgvi run`` of a detumble-then-point scenario: the figures of what it recorded, and a summary
    whose numbers are those of the saved records (recomputed here from trajectory.npz)."""
    pytest.importorskip("matplotlib")
    from lgvi.io.scenario import to_toml

    d = _dict()
    d["integrator"]["duration"] = 400.0
    path = tmp_path / "detumble.toml"
    path.write_text(to_toml(d))
    code, out, err = _cli(capsys, "run", path, "-o", tmp_path / "out")
    assert code == 0, err
    o = tmp_path / "out"
    names = {p.name for p in o.iterdir()}
    assert {"trajectory.npz", "summary.json", "summary.txt", "pointing.png", "dipoles.png", "modes.png",
            "wheels.png", "rates.png"} <= names
    s = json.loads((o / "summary.json").read_text())["pointing"]
    traj = lgvi.load(o / "trajectory.npz")
    t, sig = traj.signal_t, traj.signals
    err_deg = np.degrees(4 * np.arctan(np.linalg.norm(sig["sigma_BR"], axis=1)))
    k = np.searchsorted(t, s["settle_time_s"])
    assert t[k] == s["settle_time_s"] and err_deg[k:].max() < s["settle_deg"] <= err_deg[k - 1]
    assert s["error_deg"]["max"] == err_deg[k:].max() and s["error_deg"]["mean"] == pytest.approx(err_deg[k:].mean())
    assert s["error_deg"]["p95"] == pytest.approx(np.percentile(err_deg[k:], 95))
    assert s["rate_final_deg_s"] == pytest.approx(np.degrees(np.linalg.norm(traj.omega[-1])), rel=1e-12)
    hw = 1e-4 * (traj.omega @ np.array(AXES).T + traj.wheel_speed)
    assert s["wheel_momentum_peak_Nms"] == pytest.approx(np.abs(hw).max(), rel=1e-12)
    switch = t[np.argmax(np.ravel(sig["mode"]) == 1)]
    assert s["modes"] == [{"mode": 0, "name": "mode 0", "from_s": 0.0}, {"mode": 1, "name": "mode 1", "from_s": switch}]
    np.testing.assert_array_equal(traj.R, Scenario.from_dict(d).run().R)      # the stream is the run
    txt = (o / "summary.txt").read_text()
    assert f"settled below 0.1 deg at t = {s['settle_time_s']:g} s" in txt and f"1 from {switch:g} s" in txt


def test_loop_summary_of_a_run_that_never_settles():
    from lgvi.io.scenario_loop import loop_summary

    sat, fsw = _sixu_python()
    traj = lgvi.simulate(sat, np.eye(3), omega0=[0.0, 0.0, 0.0011], h=0.1, steps=100, fsw=fsw, save_every=10)
    s = loop_summary(traj)
    assert s["settle_time_s"] is None and s["error_deg"] is None and s["error_final_deg"] > 10.0
    given = loop_summary(traj, wheels=sat.wheels)                      # no wheels given: the run's own
    assert s["wheel_momentum_peak_Nms"] == given["wheel_momentum_peak_Nms"] > 0.0
    with pytest.raises(ValueError, match="settle_deg must be a positive number"):
        loop_summary(traj, settle_deg=0.0)


def test_tle_orbit_and_field_take_the_tle_epoch():
    """[spacecraft.orbit] type = "sgp4" (a TLE): the spacecraft's epoch is the TLE's, the field's date too."""
    pytest.importorskip("sgp4")
    d = _dict()
    d["spacecraft"].pop("epoch")
    d["spacecraft"]["orbit"] = {
        "type": "sgp4", "line1": "1 25544U 98067A   26079.50000000  .00016717  00000-0  10270-3 0  9006",
        "line2": "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815361  2048"}
    sc = Scenario.from_dict(d)
    assert type(sc.spacecraft.orbit).__name__ == "SGP4Orbit"
    assert sc.spacecraft.epoch.replace(tzinfo=None) == dt.datetime(2026, 3, 20, 12)
    d["spacecraft"]["orbit"] = {"type": "circular", "radius": 6878137.0}      # no epoch anywhere: the field
    with pytest.raises(ScenarioError, match=r"spacecraft\.orbit\.epoch.*needs a date"):
        Scenario.from_dict(d)


def test_environment_models_take_the_spacecraft_epoch():
    """[[spacecraft.environment]] type = "sun": the class's required epoch is the spacecraft's."""
    from lgvi.io.scenario import Checker
    from lgvi.io.scenario_loop import spacecraft

    tbl = _dict()["spacecraft"]
    tbl["environment"] = [{"type": "sun"}, {"type": "shadow"}]
    sc = spacecraft(Checker("m.toml"), tbl)
    assert [type(e).__name__ for e in sc.environment] == ["Sun", "Shadow"]
    assert sc.environment[0].clock.epoch.replace(tzinfo=None) == dt.datetime(2026, 1, 1)
    tbl.pop("epoch")
    tbl["orbit"] = {"type": "circular", "radius": 6878137.0}
    tbl.pop("field")
    sc = spacecraft(Checker("m.toml"), tbl)          # the sun's date comes from the run's spacecraft
    assert sc.environment[0].clock is None
    from lgvi.components import LoopContext

    with pytest.raises(ValueError, match=r"Sun needs a date"):     # and none is there: refused before a step
        sc.environment[0].setup(LoopContext(sc, 0.1, 0.0, 1.0))
