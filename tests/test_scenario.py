"""Scenario files: every schema form resolves to the right state, every bad file gets a keyed error."""

from __future__ import annotations

import tomllib
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.io.scenario import Scenario, ScenarioError, load_scenario, to_toml

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

BASE = """\
name = "base"
description = "a free body"

[body]
inertia = [1.0, 2.0, 3.0]

[initial]
omega = [0.1, 1.0, 0.2]

[integrator]
h = 0.01
steps = 40
save_every = 4
"""


def base_dict() -> dict:
    return tomllib.loads(BASE)


def write(tmp_path: Path, text: str, name: str = "scen.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def has_torques() -> bool:
    try:
        from lgvi import torques  # noqa: F401
    except ImportError:
        return False
    return True


needs_torques = pytest.mark.skipif(not has_torques(), reason="lgvi.torques is not available yet")


# ------------------------------------------------------------------------------------ valid files
def test_base_scenario_resolves(tmp_path):
    sc = load_scenario(write(tmp_path, BASE))
    assert sc.name == "base" and sc.description == "a free body"
    assert np.array_equal(sc.body.J, np.diag([1.0, 2.0, 3.0]))
    assert np.array_equal(sc.R0, np.eye(3))
    assert np.array_equal(sc.Pi0, [0.1, 2.0, 0.6000000000000001])
    assert (sc.h, sc.steps, sc.save_every, sc.samples) == (0.01, 40, 4, 11)
    assert (sc.method, sc.tol, sc.max_iter, sc.alpha) == ("newton", 1e-14, 50, 1.0)
    assert sc.forcing is None and sc.order is None and sc.torque is None
    assert sc.formats == ("npz",) and sc.plots is True
    assert sc.text == BASE and sc.source == str(tmp_path / "scen.toml")


def test_name_defaults_to_file_stem(tmp_path):
    d = base_dict()
    del d["name"]
    sc = Scenario.from_dict(d, source=str(tmp_path / "my_run.toml"))
    assert sc.name == "my_run"


def test_run_matches_simulate_bit_for_bit_and_carries_the_scenario(tmp_path):
    sc = load_scenario(write(tmp_path, BASE))
    traj = sc.run()
    ref = lgvi.simulate(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), omega0=[0.1, 1.0, 0.2], h=0.01, steps=40,
                        save_every=4)
    assert np.array_equal(traj.R, ref.R) and np.array_equal(traj.Pi, ref.Pi)
    assert np.array_equal(traj.iterations, ref.iterations)
    assert traj.meta["scenario"] == BASE
    assert traj.meta["scenario_name"] == "base"
    assert traj.meta["lgvi_version"] == lgvi.__version__


@pytest.mark.parametrize("body, expected", [
    ({"inertia": [1.0, 2.0, 2.5]}, np.diag([1.0, 2.0, 2.5])),
    ({"matrix": [[2.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 3.0]]},
     np.array([[2.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 3.0]])),
    ({"shape": "box", "mass": 12.0, "dimensions": [1.0, 2.0, 3.0]}, np.diag([13.0, 10.0, 5.0])),
    ({"shape": "cylinder", "mass": 12.0, "radius": 1.0, "height": 2.0, "axis": "y"}, np.diag([7.0, 6.0, 7.0])),
])
def test_body_forms(body, expected):
    d = base_dict()
    d["body"] = body
    sc = Scenario.from_dict(d)
    np.testing.assert_allclose(sc.body.J, expected, rtol=1e-15)


R_EXPECTED = Rotation.from_euler("ZYX", [30.0, 20.0, -10.0], degrees=True)


@pytest.mark.parametrize("initial", [
    {"matrix": R_EXPECTED.as_matrix().tolist()},
    {"quat_xyzw": R_EXPECTED.as_quat().tolist()},
    {"quat_wxyz": R_EXPECTED.as_quat()[[3, 0, 1, 2]].tolist()},
    {"euler": {"sequence": "ZYX", "angles": [30.0, 20.0, -10.0], "unit": "deg"}},
    {"euler": {"sequence": "ZYX", "angles": np.radians([30.0, 20.0, -10.0]).tolist(), "unit": "rad"}},
    {"euler": {"sequence": "xyz", "angles": [-10.0, 20.0, 30.0], "unit": "deg"}},  # extrinsic = reversed
    {"rotvec": R_EXPECTED.as_rotvec().tolist()},
])
def test_attitude_forms_agree(initial):
    d = base_dict()
    d["initial"] = dict(initial, omega=[0.0, 1.0, 0.0])
    sc = Scenario.from_dict(d)
    np.testing.assert_allclose(sc.R0, R_EXPECTED.as_matrix(), atol=1e-14)


def test_rounded_quaternion_is_normalised():
    d = base_dict()
    d["initial"]["quat_xyzw"] = [0.0, 0.0, 0.7071, 0.7071]
    sc = Scenario.from_dict(d)
    np.testing.assert_allclose(sc.R0, Rotation.from_euler("z", 90, degrees=True).as_matrix(), atol=1e-14)


def test_pi_instead_of_omega():
    d = base_dict()
    d["initial"] = {"Pi": [0.5, 0.25, 1.0]}
    assert np.array_equal(Scenario.from_dict(d).Pi0, [0.5, 0.25, 1.0])


def test_omega_takes_a_unit_like_the_euler_angles():
    """``omega = { values = [...], unit = "deg/s" }`` (or "rad/s"); a bare array stays rad/s."""
    d = base_dict()
    plain = Scenario.from_dict(d)
    d["initial"]["omega"] = {"values": [0.1, 1.0, 0.2], "unit": "rad/s"}
    assert np.array_equal(Scenario.from_dict(d).Pi0, plain.Pi0)
    d["initial"]["omega"] = {"values": np.degrees([0.1, 1.0, 0.2]).tolist(), "unit": "deg/s"}
    np.testing.assert_allclose(Scenario.from_dict(d).Pi0, plain.Pi0, rtol=1e-15)
    d["initial"]["omega"] = {"values": [0.0, 90.0, 0.0], "unit": "deg/s"}
    np.testing.assert_allclose(Scenario.from_dict(d).Pi0, [0.0, 2.0 * np.pi / 4.0 * 2.0, 0.0], rtol=1e-15)
    # the documented spelling runs from a file, and survives the round trip through to_toml
    text = edit(BASE, "omega = [0.1, 1.0, 0.2]", 'omega = { values = [0.0, 90.0, 0.0], unit = "deg/s" }')
    assert np.array_equal(Scenario.from_dict(tomllib.loads(to_toml(tomllib.loads(text)))).Pi0,
                          Scenario.from_dict(d).Pi0)


def test_matrix_slightly_off_so3_is_replaced_by_the_nearest_rotation_with_a_warning(tmp_path):
    """A rotation written with 7 digits (||R^T R - I||_F ~ 1e-7) is accepted: R0 is its nearest
    rotation, and a warning names the file and the key. A rotation to round-off stays as written."""
    R = Rotation.from_euler("ZYX", [30.0, 20.0, -10.0], degrees=True).as_matrix()
    rounded = np.round(R, 7)
    assert 1e-9 < lgvi.so3.orthogonality_error(rounded) < 1e-6
    path = write(tmp_path, edit(BASE, "omega =", f"matrix = {rounded.tolist()}\nomega ="), "seven.toml")
    with pytest.warns(lgvi.errors.AttitudeWarning, match=rf"{path}: initial\.matrix is [0-9.e-]+ away from a "
                      r"rotation.*using the nearest rotation"):
        sc = load_scenario(path)
    assert np.array_equal(sc.R0, lgvi.so3.project(rounded))
    # a rotation to a few ulps (1.2e-15 with NumPy 1.24's LAPACK, the floor)
    assert lgvi.so3.orthogonality_error(sc.R0) < 1e-14 and np.max(np.abs(sc.R0 - R)) < 1e-7
    d = base_dict()
    d["initial"]["matrix"] = R.tolist()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.array_equal(Scenario.from_dict(d).R0, R)        # as written, bit for bit


def test_matrix_errors_say_what_to_write_in_the_file(tmp_path):
    """A scenario error speaks TOML: what to write in the file, never a Python call."""
    path = write(tmp_path, edit(BASE, "omega =", "matrix = [[1, 0, 0], [0, 1, 0.001], [0, 0, 1]]\nomega ="))
    with pytest.raises(ScenarioError, match=r"initial\.matrix: expected a rotation matrix: .*orthogonal to 1e-06.*"
                       r"Write initial\.matrix with orthonormal rows and determinant \+1 .* or give the attitude "
                       r"as rotvec, quat_xyzw, quat_wxyz or euler instead\.") as info:
        load_scenario(path)
    assert "lgvi." not in str(info.value) and "(" not in str(info.value).split("Write", 1)[1]


@pytest.mark.parametrize("h, duration, steps", [(0.01, 1.0, 100), (0.1, 0.3, 3), (-0.01, -0.5, 50),
                                                (0.001, 20.0, 20000), (0.01, 0.0, 0)])
def test_duration_gives_steps(h, duration, steps):
    d = base_dict()
    d["integrator"] = {"h": h, "duration": duration}
    assert Scenario.from_dict(d).steps == steps


def test_all_integrator_options_and_outputs():
    d = base_dict()
    d["integrator"].update(method="paper", tol=1e-12, max_iter=80, alpha=0.5, forcing="symmetric", order=4)
    d["output"] = {"formats": ["csv", "npz", "csv"], "plots": False}
    sc = Scenario.from_dict(d)
    assert (sc.method, sc.tol, sc.max_iter, sc.alpha, sc.forcing, sc.order) == ("paper", 1e-12, 80, 0.5,
                                                                               "symmetric", 4)
    assert sc.formats == ("csv", "npz") and sc.plots is False
    kw = sc.simulate_kwargs()
    assert kw["forcing"] == "symmetric" and kw["order"] == 4


def test_to_toml_round_trip():
    d = base_dict()
    d["initial"]["euler"] = {"sequence": "ZYX", "angles": [1.5, 0, -2], "unit": "deg"}
    d["torque"] = [{"type": "constant", "u": [0.0, 0.0, 1e-3]}]
    d["description"] = 'quote " and backslash \\ and\nnewline'
    assert tomllib.loads(to_toml(d)) == d
    sc = Scenario.from_dict({k: v for k, v in d.items() if k != "torque"})
    assert tomllib.loads(sc.text)["integrator"]["steps"] == 40


# ------------------------------------------------------------------------------------ torques
@needs_torques
def test_torque_tables_build_a_summed_model():
    from lgvi import torques

    d = base_dict()
    d["torque"] = [{"type": "uniform_gravity", "mass": 1.0, "com": [0.0, 0.0, 0.3]},
                   {"type": "damping", "c": [0.1, 0.2, 0.3]},
                   {"type": "pd", "kp": 2.0, "kd": 1.0, "target": {"rotvec": [0.0, 0.0, 0.5]}},
                   {"type": "constant", "u": [0.0, 0.01, 0.0]},
                   {"type": "gravity_gradient", "mu": 3.986e14, "radius": 7.0e6}]
    sc = Scenario.from_dict(d)
    expected = (torques.UniformGravity(1.0, [0.0, 0.0, 0.3]) + torques.LinearDamping([0.1, 0.2, 0.3])
                + torques.AttitudePD(2.0, 1.0, Rotation.from_rotvec([0.0, 0.0, 0.5]).as_matrix())
                + torques.Constant([0.0, 0.01, 0.0]) + torques.GravityGradient(3.986e14, 7.0e6))
    assert sc.torque == expected
    assert [s["type"] for s in sc.torque_spec] == ["uniform_gravity", "damping", "pd", "constant",
                                                   "gravity_gradient"]
    traj = sc.run()
    assert np.all(np.isfinite(traj.R))


# ------------------------------------------------------------------------------------ examples
EXAMPLE_FILES = sorted(EXAMPLES.glob("*.toml"))


def test_examples_exist():
    names = {p.stem for p in EXAMPLE_FILES}
    assert {"dzhanibekov", "heavy_top", "pendulum3d", "slew_pd", "gravity_gradient"} <= names


@pytest.mark.parametrize("path", EXAMPLE_FILES, ids=lambda p: p.stem)
def test_example_loads_and_runs_short(path):
    d = tomllib.loads(path.read_text())
    if "torque" in d and not has_torques():
        pytest.skip("lgvi.torques is not available yet")
    sc = load_scenario(path)
    assert sc.name == path.stem and sc.description
    n = 20 * sc.save_every
    traj = replace(sc, steps=min(sc.steps, n)).run()
    assert len(traj.t) == min(sc.steps, n) // sc.save_every + 1
    assert np.all(np.isfinite(traj.R)) and np.all(np.isfinite(traj.Pi))
    if path.stem in ("pendulum3d", "heavy_top"):  # uniform gravity: e3 . R Pi to round-off
        L3 = traj.spatial_momentum[:, 2]
        assert np.max(np.abs(L3 - L3[0])) <= 1e-12 * np.linalg.norm(traj.spatial_momentum[0])
    if path.stem == "dzhanibekov":
        E = traj.energy
        assert np.max(np.abs(E - E[0])) <= 1e-13 * E[0]


@needs_torques
def test_pendulum3d_example_is_lees_pendulum():
    """Lee, Leok and McClamroch's start hangs: their e3 points along gravity and rho = 0.3 e3, so
    here (e3 up) com = -0.3 e3, the centre of mass is below the pivot and E0 = 2.03 J (the inverted
    start, com = +0.3 e3, has 7.91 J)."""
    sc = load_scenario(EXAMPLES / "pendulum3d.toml")
    assert np.array_equal(sc.body.J, np.diag([0.13, 0.28, 0.17]))
    np.testing.assert_allclose(sc.body.J_inv @ sc.Pi0, [4.14, 4.14, 4.14], rtol=1e-15)
    assert sc.h == 0.01 and np.array_equal(sc.R0, np.eye(3))
    term = sc.torque.terms[0]
    assert term.mass == 1.0 and term.g == 9.81 and np.array_equal(term.com, [0.0, 0.0, -0.3])
    gravity = np.array([0.0, 0.0, -1.0])                          # lgvi: gravity acts along -e3
    assert (sc.R0 @ term.com) @ gravity == pytest.approx(0.3)     # 0.3 m below the pivot, along gravity
    E0 = 0.5 * sc.Pi0 @ sc.body.J_inv @ sc.Pi0 + float(sc.torque.potential(0.0, sc.R0, sc.body))
    assert round(E0, 2) == 2.03                                   # Lee's figure, to the digits given
    # Lee's moment m g hat(rho) R^T e3_Lee (e3_Lee = down = -e3 here, rho = 0.3 e3) is ours, number for number
    R = lgvi.so3.exp([0.4, -0.7, 1.1])
    lee = 9.81 * lgvi.so3.hat([0.0, 0.0, 0.3]) @ R.T @ np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(sc.torque.moment(0.0, R, sc.Pi0, sc.body), lee, rtol=1e-15, atol=1e-15)


@needs_torques
def test_slew_example_reaches_its_target():
    sc = load_scenario(EXAMPLES / "slew_pd.toml")
    traj = sc.run()
    Rd = Rotation.from_euler("ZYX", [60.0, 30.0, -20.0], degrees=True)
    err = (Rd.inv() * traj.rotation[-1]).magnitude()
    assert err < 1e-6
    assert (Rd.inv() * traj.rotation[0]).magnitude() > 1.0


# ------------------------------------------------------------------------------------ errors
def edit(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


BAD = {
    "unknown top-level key": (edit(BASE, 'name = "base"', 'name = "base"\nnmae = "x"'), "nmae", "unknown key"),
    "unknown nested key": (edit(BASE, "steps = 40", "stpes = 40"), "integrator.stpes", "did you mean 'steps'"),
    "unknown table": (BASE + "\n[outputs]\nplots = false\n", "outputs", "did you mean 'output'"),
    "h is a string": (edit(BASE, "h = 0.01", 'h = "0.01"'), "integrator.h", "expected a number"),
    "steps is a float": (edit(BASE, "steps = 40", "steps = 40.0"), "integrator.steps", "expected an integer"),
    "bool is no number": (edit(BASE, "h = 0.01", "h = true"), "integrator.h", "expected a number"),
    "h zero": (edit(BASE, "h = 0.01", "h = 0.0"), "integrator.h", "non-zero"),
    "both omega and Pi": (edit(BASE, "omega = [0.1, 1.0, 0.2]", "omega = [0.1, 1.0, 0.2]\nPi = [1.0, 2.0, 3.0]"),
                          "initial", "exactly one of initial.omega"),
    "neither omega nor Pi": (edit(BASE, "omega = [0.1, 1.0, 0.2]", ""), "initial", "exactly one of initial.omega"),
    "omega too short": (edit(BASE, "omega = [0.1, 1.0, 0.2]", "omega = [0.1, 1.0]"), "initial.omega",
                        "array of 3 numbers"),
    "omega unit unknown": (edit(BASE, "omega = [0.1, 1.0, 0.2]", 'omega = { values = [0.1, 1.0, 0.2], unit = "rpm" }'),
                           "initial.omega.unit", "'rad/s', 'deg/s'"),
    "omega table without unit": (edit(BASE, "omega = [0.1, 1.0, 0.2]", "omega = { values = [0.1, 1.0, 0.2] }"),
                                 "initial.omega.unit", "missing"),
    "omega table unknown key": (edit(BASE, "omega = [0.1, 1.0, 0.2]", 'omega = { value = [0.1, 1.0, 0.2], '
                                     'unit = "deg/s" }'), "initial.omega.value", "did you mean 'values'"),
    "omega entry not a number": (edit(BASE, "omega = [0.1, 1.0, 0.2]", 'omega = [0.1, "x", 0.2]'),
                                 "initial.omega[1]", "expected a number"),
    "duration not a multiple of h": (edit(BASE, "steps = 40\nsave_every = 4", "duration = 1.005"),
                                     "integrator.duration", "whole number of steps"),
    "steps and duration": (edit(BASE, "steps = 40", "steps = 40\nduration = 0.4"), "integrator",
                           "exactly one of integrator.steps or integrator.duration"),
    "save_every not dividing": (edit(BASE, "save_every = 4", "save_every = 7"), "integrator.save_every",
                                "divisor"),
    "bad method": (edit(BASE, "steps = 40", 'steps = 40\nmethod = "newtn"'), "integrator.method", "'newton'"),
    "bad order": (edit(BASE, "steps = 40", "steps = 40\norder = 3"), "integrator.order", "one of 2, 4, 6"),
    "alpha out of range": (edit(BASE, "steps = 40", "steps = 40\nalpha = 1.5"), "integrator.alpha", "(0, 1]"),
    "bad euler unit": (edit(BASE, "omega =", 'euler = { sequence = "ZYX", angles = [1, 2, 3], unit = "degrees" }'
                                             "\nomega ="), "initial.euler.unit", "'deg', 'rad'"),
    "missing euler unit": (edit(BASE, "omega =", 'euler = { sequence = "ZYX", angles = [1, 2, 3] }\nomega ='),
                           "initial.euler.unit", "missing"),
    "bad euler sequence": (edit(BASE, "omega =", 'euler = { sequence = "ZZX", angles = [1, 2, 3], unit = "rad" }'
                                                 "\nomega ="), "initial.euler.sequence", "3 axes"),
    "mixed-case euler sequence": (edit(BASE, "omega =", 'euler = { sequence = "Zyx", angles = [1, 2, 3], '
                                                        'unit = "rad" }\nomega ='), "initial.euler.sequence",
                                  "uppercase"),
    "two attitude forms": (edit(BASE, "omega =", "rotvec = [0, 0, 1]\nquat_xyzw = [0, 0, 0, 1]\nomega ="),
                           "initial", "one form only"),
    "not a rotation": (edit(BASE, "omega =", "matrix = [[1, 0, 0], [0, 1, 0], [0, 0, -1]]\nomega ="),
                       "initial.matrix", "rotation matrix"),
    "matrix wrong shape": (edit(BASE, "omega =", "matrix = [[1, 0, 0], [0, 1, 0]]\nomega ="), "initial.matrix",
                           "3x3 matrix"),
    "not a unit quaternion": (edit(BASE, "omega =", "quat_wxyz = [2, 0, 0, 0]\nomega ="), "initial.quat_wxyz",
                              "unit quaternion"),
    "no body form": (edit(BASE, "inertia = [1.0, 2.0, 3.0]", "mass = 1.0"), "body", "exactly one of"),
    "unphysical inertia": (edit(BASE, "inertia = [1.0, 2.0, 3.0]", "inertia = [1.0, 1.0, 5.0]"), "body.inertia",
                           "triangle inequality"),
    "box without dimensions": (edit(BASE, "inertia = [1.0, 2.0, 3.0]", 'shape = "box"\nmass = 1.0'),
                               "body.dimensions", "missing"),
    "cylinder bad axis": (edit(BASE, "inertia = [1.0, 2.0, 3.0]", 'shape = "cylinder"\nmass = 1.0\nradius = 0.1\n'
                                                                  'height = 1.0\naxis = "w"'), "body.axis", "'x'"),
    "mass without shape": (edit(BASE, "inertia = [1.0, 2.0, 3.0]", "inertia = [1.0, 2.0, 3.0]\nmass = 2.0"),
                           "body.mass", "only used with body.shape"),
    "missing integrator": (BASE.split("[integrator]")[0], "integrator", "missing"),
    "missing h": (edit(BASE, "h = 0.01\n", ""), "integrator.h", "missing"),
    "torque as a table": (BASE + '\n[torque]\ntype = "constant"\nu = [0, 0, 1]\n', "torque", "[[torque]]"),
    "unknown torque type": (BASE + '\n[[torque]]\ntype = "drag"\n', "torque[0].type", "'uniform_gravity'"),
    "torque without type": (BASE + "\n[[torque]]\nu = [0, 0, 1]\n", "torque[0].type", "missing"),
    "torque missing parameter": (BASE + '\n[[torque]]\ntype = "constant"\nu = [0, 0, 1]\n\n[[torque]]\ntype = "uniform_gravity"'
                                        "\nmass = 1.0\n", "torque[1].com", "missing"),
    "torque unknown parameter": (BASE + '\n[[torque]]\ntype = "damping"\nc = 0.1\nk = 2\n', "torque[0].k",
                                 "unknown key"),
    "negative gain": (BASE + '\n[[torque]]\ntype = "damping"\nc = -0.1\n', "torque[0].c", ">= 0"),
    "bad output format": (BASE + '\n[output]\nformats = ["npz", "hdf5"]\n', "output.formats[1]", "'netcdf'"),
    "plots not a bool": (BASE + '\n[output]\nplots = "yes"\n', "output.plots", "true or false"),
}


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_bad_scenarios_name_file_and_key(tmp_path, case):
    text, key, expected = BAD[case]
    path = write(tmp_path, text, name="bad_case.toml")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    err = info.value
    msg = str(err)
    assert isinstance(err, ValueError)
    assert msg.startswith(f"{path}: {key}: "), msg
    assert err.key == key and err.source == str(path)
    assert expected in msg, msg
    assert "\n" not in msg


def test_toml_syntax_error_names_file_and_line(tmp_path):
    text = BASE.replace("h = 0.01", "h = 0.01 0.02")
    line = text.splitlines().index("h = 0.01 0.02") + 1
    path = write(tmp_path, text, name="syntax.toml")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: line {line}, column ") and "TOML syntax error" in msg
    assert info.value.line == line


def test_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read the scenario file"):
        load_scenario(tmp_path / "nope.toml")


def test_from_dict_errors_name_the_source():
    d = base_dict()
    d["integrator"]["h"] = "fast"
    with pytest.raises(ScenarioError, match=r"^<dict>: integrator\.h: expected a number"):
        Scenario.from_dict(d)
    with pytest.raises(ScenarioError, match=r"^mine: integrator\.h"):
        Scenario.from_dict(d, source="mine")
