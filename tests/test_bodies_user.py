"""The user side of bodies in orbit and two bodies (issue 16, part 4): scenario sections, figures."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi.scenario import BodiesScenario, Scenario, ScenarioError

ORBIT = {"orbiting_body": {"inertia": [0.04, 0.06, 0.075], "mass": 1.0, "mu": 1.0, "position": [1.0, 0.0, 0.1],
                   "velocity": [0.0, 1.15, 0.05]},
         "initial": {"rotvec": [0.4, -0.3, 0.8], "omega": [0.3, -0.4, 1.3]},
         "integrator": {"h": 0.02, "steps": 100, "save_every": 5}}
TWO = {"two_body": {"potential": "order4", "position": [3.0, 0.0, 0.3], "velocity": [0.0, 0.6, 0.1],
                    "body1": {"ellipsoid": [1.0, 0.7, 0.5], "mass": 1.0, "omega": [0.1, 0.2, 1.0]},
                    "body2": {"points": {"masses": [0.05, 0.05, 0.01, 0.01],
                                         "positions": [[0.3, 0, 0], [-0.3, 0, 0], [0, 0.1, 0], [0, -0.1, 0]]},
                              "rotvec": [0.0, 0.0, 0.5], "omega": [0.3, 0.0, 0.2]}},
       "integrator": {"h": 0.02, "duration": 2.0}}


def test_orbit_section_runs_the_same_as_the_call():
    sc = Scenario.from_dict(ORBIT)
    assert isinstance(sc, BodiesScenario) and sc.kind == "orbit" and sc.steps == 100
    traj = sc.run()
    from scipy.spatial.transform import Rotation

    direct = lgvi.simulate_orbit([0.04, 0.06, 0.075], 1.0, [1.0, 0.0, 0.1], [0.0, 1.15, 0.05],
                                 Rotation.from_rotvec([0.4, -0.3, 0.8]).as_matrix(), omega0=[0.3, -0.4, 1.3], h=0.02,
                                 steps=100, mu=1.0, save_every=5)
    assert np.array_equal(traj.x, direct.x) and np.array_equal(traj.R, direct.R)
    assert traj.meta["scenario_name"] == "scenario" and "[orbiting_body]" in traj.meta["scenario"]


def test_two_body_section_runs():
    sc = Scenario.from_dict(TWO)
    traj = sc.run()
    assert sc.kind == "two_body" and traj.x.shape == (101, 2, 3)
    assert traj.masses[1] == pytest.approx(0.12)       # the points' sum
    L = traj.angular_momentum
    assert np.abs(L - L[0]).max() < 1e-13 * np.abs(L[0]).max()


@pytest.mark.parametrize("path,value,key,rule", [
    (("orbiting_body", "mass"), -1.0, r"orbiting_body\.mass", "positive"),
    (("orbiting_body", "potential"), "order4", r"orbiting_body\.potential", "one of"),
    (("orbiting_body", "radius"), 2.0, r"orbiting_body\.radius", "only used with orbiting_body.J2"),
    (("orbiting_body", "J2"), 1e-3, r"orbiting_body\.radius", "equatorial radius"),
    (("orbiting_body", "mas"), 1.0, r"orbiting_body\.mas", "did you mean 'mass'"),
    (("orbiting_body", "position"), [0.0, 0.0, 0.0], r"\borbiting_body\b", r"\|x0\| > 0"),
    (("initial", "omega"), None, r"initial", "exactly one of initial.omega or initial.Pi"),
    (("integrator", "save_every"), 3, r"integrator\.save_every", "divisor"),
])
def test_orbit_section_errors_name_the_key(path, value, key, rule):
    import copy

    d = copy.deepcopy(ORBIT)
    if value is None:
        del d[path[0]][path[1]]
    else:
        d[path[0]][path[1]] = value
    with pytest.raises(ScenarioError, match=key) as info:
        Scenario.from_dict(d, "s.toml")
    assert rule in str(info.value) or __import__("re").search(rule, str(info.value))


@pytest.mark.parametrize("edit,key,rule", [
    (lambda d: d["two_body"]["body1"].pop("mass"), r"two_body\.body1\.mass", "positive number"),
    (lambda d: d["two_body"]["body1"].update(inertia=[1.0, 1.0, 1.0]), r"two_body\.body1",
     "exactly one of two_body.body1.inertia"),
    (lambda d: d["two_body"].update(potential="points"), r"\btwo_body\b", "PointMasses"),
    (lambda d: d["two_body"]["body2"]["points"].update(masses=[1.0]), r"two_body\.body2\.points",
     "as many masses as positions"),
    (lambda d: d.update(initial={"omega": [0, 0, 1]}), r"\binitial\b", r"\[two_body\.body1\]"),
    (lambda d: d.update(orbiting_body=ORBIT["orbiting_body"]), None, "describes one system"),
])
def test_two_body_section_errors_name_the_key(edit, key, rule):
    import copy

    d = copy.deepcopy(TWO)
    edit(d)
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(d, "s.toml")
    msg = str(info.value)
    assert key is None or __import__("re").search(key, msg), msg
    assert rule in msg or __import__("re").search(rule, msg), msg


def test_figures_have_their_panels(tmp_path):
    pytest.importorskip("matplotlib")
    from lgvi import plot

    fig = plot.orbit(Scenario.from_dict(ORBIT).run())
    titles = [ax.get_title() for ax in fig.axes]
    assert any("long axis" in t for t in titles) and "invariants" in titles
    legend = [t.get_text() for t in fig.axes[3].get_legend().get_texts()]
    assert any("(exact)" in t for t in legend) and any("(bounded)" in t for t in legend)
    fig.savefig(tmp_path / "orbit.png")
    fig = plot.two_body(Scenario.from_dict(TWO).run())
    titles = [ax.get_title() for ax in fig.axes]
    assert titles == ["mutual orbit", "distance", "spins (body 1 solid, body 2 dashed)", "invariants"]
    assert len(fig.axes[2].get_lines()) == 6
    fig.savefig(tmp_path / "two_body.png")
    assert (tmp_path / "two_body.png").read_bytes()[:4] == b"\x89PNG"


def test_compare_refuses_them_clearly(tmp_path, capsys):
    # lgvi run runs them (tests/test_cli_systems.py); the baselines of lgvi compare are single bodies
    from pathlib import Path

    from lgvi import cli

    path = Path(__file__).resolve().parents[1] / "examples" / "binary_asteroid.toml"
    assert cli.main(["compare", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "two_body" in err and "lgvi run" in err
