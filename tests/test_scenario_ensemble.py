"""The ``[ensemble]`` section of a spacecraft scenario (issue 25, part 5): a Monte Carlo of the
file's mission, every member drawn from ``default_rng((seed, b))`` and checked before any step;
``lgvi run`` runs it and summarises it (lgvi.io.scenario_ensemble)."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

import lgvi
from lgvi.io.outputs import read_trajectory
from lgvi.io.scenario import ScenarioError, to_toml
from lgvi.io.scenario_loop import LoopScenario, loop_summary
from lgvi.scenario import Scenario

from test_loop_scenario import AXES, _cli, _dict

DISPERSIONS = [
    {"key": "initial", "rotation": 5.0},
    {"key": "initial.omega", "normal": 0.005},
    {"key": "spacecraft.body.inertia", "scale": [0.95, 1.05]},
    {"key": "fsw.control[1].K", "scale": [0.9, 1.1]},
    {"key": "spacecraft.wheel[0].axis", "rotation": 0.5},
    {"key": "spacecraft.wheel[2].max_torque", "uniform": [0.003, 0.005]},
    {"key": "spacecraft.body.inertia", "rotation": 1.0},
]


def _ensemble(members=3, seed=5, dispersions=DISPERSIONS):
    d = _dict()
    d["ensemble"] = {"members": members, "seed": seed, "threads": 1, "dispersion": copy.deepcopy(dispersions)}
    return d


def test_members_hold_their_draws_and_run_as_their_lone_runs():
    """Member b's description holds the values drawn, in the file's order, from default_rng((seed, b))
    (redrawn here); its run in the ensemble is the lone run of its description, bit for bit; member b
    is the same whatever the number of members."""
    from lgvi.so3 import exp

    scen = Scenario.from_dict(_ensemble(), source="mc.toml")
    assert isinstance(scen, LoopScenario) and len(scen.members) == 3
    for b, (sc, fsw, R0, omega0, Pi0) in enumerate(scen.members):
        rng = np.random.default_rng((5, b))
        Q = exp(rng.normal(0.0, math.radians(5.0), 3))
        w = np.array([0.03, -0.02, 0.01]) + rng.normal(0.0, 0.005, 3)
        J = np.array([0.18, 0.14, 0.06]) * rng.uniform(0.95, 1.05, 3)
        K = 0.004 * rng.uniform(0.9, 1.1)
        axis = exp(rng.normal(0.0, math.radians(0.5), 3)) @ np.array(AXES[0])
        top = rng.uniform(0.003, 0.005)
        Q_J = exp(rng.normal(0.0, math.radians(1.0), 3))             # the principal axes turned
        np.testing.assert_array_equal(R0, Q)
        np.testing.assert_array_equal(omega0, w)
        np.testing.assert_allclose(sc.body.J, Q_J @ np.diag(J) @ Q_J.T, rtol=0, atol=1e-16)
        np.testing.assert_allclose(np.linalg.eigvalsh(sc.body.J), np.sort(J), rtol=1e-14)
        assert fsw.control[1].K == K and Pi0 is None
        np.testing.assert_allclose(sc.wheels.axes[0], axis / np.linalg.norm(axis), rtol=0, atol=1e-15)
        assert sc.wheels.max_torque[2] == top and sc.wheels.max_torque[1] == 0.004
    ens = scen.run_ensemble()
    assert ens.meta["scenario_name"] == "mc" and ens.meta["ensemble_seed"] == 5
    kw = dict(h=scen.h, steps=scen.steps, save_every=scen.save_every)
    for b, (sc, fsw, R0, omega0, _) in enumerate(scen.members):
        one = lgvi.simulate(sc, R0, omega0=omega0, fsw=fsw, **kw)
        np.testing.assert_array_equal(ens[b].R, one.R)
        np.testing.assert_array_equal(ens[b].signal_data, one.signal_data)
    assert not np.array_equal(ens[0].R, ens[1].R)
    two = Scenario.from_dict(_ensemble(members=2), source="mc.toml")
    for b in range(2):
        for x, y in zip(two.members[b][2:4], scen.members[b][2:4]):
            np.testing.assert_array_equal(x, y)
        assert two.members[b][1].control[1].K == scen.members[b][1].control[1].K


@pytest.mark.parametrize("edit, key, words", [
    (lambda e: e.update(members=0), "ensemble.members", ">= 1"),
    (lambda e: e.pop("members"), "ensemble.members", "missing"),
    (lambda e: e.update(size=3), "ensemble.size", "unknown key"),
    (lambda e: e["dispersion"].append({"key": "fsw.control[5].K", "scale": [0.9, 1.1]}),
     "ensemble.dispersion[7].key", "'fsw.control[5]' is not in the file"),
    (lambda e: e["dispersion"].append({"key": "spacecraft.body.mass", "normal": 0.1}),
     "ensemble.dispersion[7].key", "the file gives none"),
    (lambda e: e["dispersion"].append({"key": "fsw.rate"}), "ensemble.dispersion[7]", "exactly one law"),
    (lambda e: e["dispersion"].append({"key": "fsw.rate", "scale": [1.1, 0.9]}), "ensemble.dispersion[7].scale",
     "lo <= hi"),
    (lambda e: e["dispersion"].append({"key": "initial", "normal": 0.1}), "ensemble.dispersion[7].normal",
     "rotation = sigma"),
    (lambda e: e["dispersion"].append({"key": "fsw.rate", "random": True}), "ensemble.dispersion[7].random",
     'key = "initial"'),
    (lambda e: e["dispersion"].append({"key": "spacecraft.wheel[0]", "normal": 0.1}), "ensemble.dispersion[7].key",
     "not an entry"),
    (lambda e: e["dispersion"].append({"key": "spacecraft.body.inertia", "normal": 0.01}), "ensemble.dispersion[7]",
     "before the rotation"),
])
def test_errors_name_the_file_and_key(edit, key, words):
    d = _ensemble()
    edit(d["ensemble"])
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(d, source="mc.toml")
    assert info.value.key == key, str(info.value)
    assert str(info.value).startswith(f"mc.toml: {key}: ") and words in str(info.value), str(info.value)


def test_a_drawn_value_the_reader_refuses_names_the_member_and_key():
    d = _ensemble(dispersions=[{"key": "spacecraft.wheel[1].max_torque", "uniform": [-0.002, 0.002]}])
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(d, source="mc.toml")
    assert str(info.value).startswith("mc.toml (ensemble member ") and info.value.key == "spacecraft.wheel[1].max_torque"
    # the loop's own refusals too, before any step: a rate that is not a multiple of h
    d = _ensemble(dispersions=[{"key": "fsw.rate", "uniform": [0.7, 0.8]}])
    with pytest.raises(ScenarioError, match=r"mc\.toml \(ensemble member 0\): fsw\.rate: .*multiple"):
        Scenario.from_dict(d, source="mc.toml")


def test_lgvi_run_runs_and_summarises_the_ensemble(capsys, tmp_path):
    d = _ensemble(members=2)
    path = tmp_path / "mc.toml"
    path.write_text(to_toml(d))
    code, out, err = _cli(capsys, "run", path, "-o", tmp_path / "out")
    assert code == 0, err
    o = tmp_path / "out"
    assert {"ensemble.npz", "summary.json", "summary.txt", "scenario.toml"} <= {p.name for p in o.iterdir()}
    ens = read_trajectory(o / "ensemble.npz")
    js = json.loads((o / "summary.json").read_text())
    assert js["members"] == 2 and js["seed"] == 5
    for b in range(2):
        assert js["member_summaries"][b]["settle_time_s"] == loop_summary(ens[b])["settle_time_s"]
    rates = [loop_summary(ens[b])["rate_final_deg_s"] for b in range(2)]
    assert js["ensemble"]["rate_final_deg_s"]["max"] == max(rates)
    assert js["ensemble"]["rate_final_deg_s"]["mean"] == pytest.approx(np.mean(rates), rel=1e-15)
    txt = (o / "summary.txt").read_text()
    assert "2 members (seed 5)" in txt and "final rate [deg/s] over 2" in txt
