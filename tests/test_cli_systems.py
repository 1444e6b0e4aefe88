"""The command line, the figures and ensembles for every system on the seam (issue 11, part 2).

``lgvi run`` of ``[orbiting_body]`` and ``[two_body]`` scenarios: the summary reads the system's
declared invariants (checked against the run's own numbers), ``lgvi info`` and ``lgvi plot`` read
the trajectory it writes, bad keys name the key. A gyrostat ensemble saves and loads bit for bit.
``error_estimate=True`` with reaction wheels tracks the true error.
"""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi import cli
from lgvi.invariants import KIND_TEXT, QUANTITIES
from lgvi.io.outputs import read_trajectory
from lgvi.io.scenario import ScenarioError, load_scenario
from lgvi.systems import SYSTEMS

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

ORBIT = """\
name = "boom_orbit"
description = "boom on an eccentric LEO with J2, two hours"

[orbiting_body]
inertia = [4000.0, 4000.0, 100.0]
mass = 500.0
mu = 3.986004418e14
J2 = 1.08263e-3
radius = 6378137.0
position = [7.0e6, 0.0, 0.0]
velocity = [0.0, 4915.991779731, 6202.437996826]

[initial]
matrix = [[0.0, 0.0, 1.0], [0.6211477802783103, -0.7836934573258398, 0.0], [0.7836934573258398, 0.6211477802783103, 0.0]]
omega = [0.0, 0.0011306218, 0.0]

[integrator]
h = 10.0
duration = 7200.0
save_every = 4
"""

POINT_ORBIT = ORBIT.replace('J2 = 1.08263e-3\nradius = 6378137.0\n', 'potential = "point"\n').replace(
    'name = "boom_orbit"', 'name = "point_orbit"')

TWO = """\
name = "pair"

[two_body]
G = 1.0
potential = "order2"
position = [4.0, 0.0, 0.0]
velocity = [0.0, 0.55, 0.0]

[two_body.body1]
ellipsoid = [0.6, 0.5, 0.4]
mass = 1.0
omega = [0.0, 0.1, 0.5]

[two_body.body2]
inertia = [0.02, 0.03, 0.04]
mass = 0.2
omega = [0.3, 0.0, 0.2]

[integrator]
h = 0.05
steps = 2000
save_every = 5
"""


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def write(tmp_path: Path, text: str, name: str = "scenario.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def summary_rows(text: str) -> dict[str, tuple[float | None, float, str]]:
    """The conservation block of summary.txt: quantity name -> (abs, rel, kind text)."""
    rows = {}
    block = text.split("conservation (", 1)[1].split("files:", 1)[0]
    for line in block.splitlines()[1:]:
        m = re.match(r"\s+(.+?)\s{2,}(?:abs (\S+)\s+)?rel (\S+)\s+(.+)$", line)
        if m:
            rows[m.group(1)] = (None if m.group(2) is None else float(m.group(2)), float(m.group(3)), m.group(4))
    return rows


def own_drift(values: np.ndarray, scale: float) -> float:
    """Largest change of a quantity over the run, relative to ``scale`` (computed here, not by lgvi)."""
    d = values - values[0]
    d = np.abs(d) if d.ndim == 1 else np.linalg.norm(d, axis=1)
    return float(d.max()) / scale


@pytest.mark.parametrize("text,declared", [
    (ORBIT, {"angular_momentum_e3": "exact", "energy": "bounded"}),
    (POINT_ORBIT, {"angular_momentum": "exact", "energy": "bounded"}),
    (TWO, {"angular_momentum": "exact", "linear_momentum": "exact", "energy": "bounded"}),
])
def test_run_writes_a_summary_of_the_declared_invariants(capsys, tmp_path, text, declared):
    path = write(tmp_path, text)
    out_dir = tmp_path / "out"
    code, out, err = run(capsys, "run", path, "-o", out_dir)
    assert code == 0, err
    traj = read_trajectory(out_dir / "trajectory.npz")
    sc = load_scenario(path)
    direct = sc.run()
    for name in ("t", "x", "p", "R", "Pi", "iterations", "residual"):   # the file holds the run, bit for bit
        assert np.array_equal(getattr(traj, name), getattr(direct, name)), name
    system = "orbit" if sc.kind == "orbit" else "two_body"
    assert traj.meta["system"] == system and traj.meta["scenario"] == text
    # the declaration is the system's (lgvi.invariants via the seam), and the summary shows exactly it
    decl = SYSTEMS[system].invariants({"J2": "J2 =" in text, "torque": False})
    assert {k: v["kind"] for k, v in decl.items()} == declared
    summary = (out_dir / "summary.txt").read_text()
    rows = summary_rows(summary)
    assert set(rows) == {QUANTITIES[k].name for k in declared}, rows
    # the body's own spin momentum is exchanged with the orbit: listed, marked as not conserved
    assert re.search(r"spatial momentum R Pi\s+not an invariant here", summary)
    E = traj.energy
    L = np.cross(traj.x, traj.p)
    L = (L.sum(axis=1) if L.ndim == 3 else L) + np.einsum("k...ij,k...j->k...i", traj.R, traj.Pi).reshape(
        len(traj.t), -1, 3).sum(axis=1)
    mine = {"energy": (float(np.abs(E - E[0]).max()), own_drift(E, abs(E[0]))),
            "angular_momentum": (None, own_drift(L, np.linalg.norm(L[0]))),
            "angular_momentum_e3": (None, own_drift(L[:, 2], np.linalg.norm(L[0])))}
    if system == "two_body":
        P = traj.p.sum(axis=1)
        mine["linear_momentum"] = (None, own_drift(P, float(np.abs(traj.p[0]).max())))
    for key, kind in declared.items():
        ab, rel, kind_text = rows[QUANTITIES[key].name]
        assert kind_text == KIND_TEXT[kind]
        want_abs, want_rel = mine[key]
        assert rel == pytest.approx(want_rel, rel=1e-3, abs=1e-300)       # printed to 4 digits
        if want_abs is not None:
            assert ab == pytest.approx(want_abs, rel=1e-3)
        # and what the kinds promise holds on the run: exact to round-off, bounded small
        assert rel < (1e-12 if kind == "exact" else 1e-3), (key, rel)
    js = json.loads((out_dir / "summary.json").read_text())
    assert js["system"] == system and js["status"] == "complete" and js["steps"] == sc.steps
    assert js["invariants"] == {k: declared.get(k, "not an invariant") for k in js["invariants"]}
    assert js["drifts"][QUANTITIES["energy"].rel_key] == pytest.approx(mine["energy"][1], rel=1e-12)
    files = {p.name for p in out_dir.iterdir()}
    assert {"trajectory.npz", "scenario.toml", "summary.txt", "summary.json", f"{system}.png"} <= files

    # lgvi info reads it and shows the same invariants
    code, out, err = run(capsys, "info", out_dir / "trajectory.npz")
    assert code == 0, err
    for key, kind in declared.items():
        assert re.search(re.escape(QUANTITIES[key].name) + r" .*rel \S+ \(" + re.escape(KIND_TEXT[kind]), out), out
    assert "scenario_name" in out and f"system           {system}" in out

    # lgvi plot draws the system's figure from it
    code, out, err = run(capsys, "plot", out_dir / "trajectory.npz", "-o", tmp_path / "figs", "--prefix", "x_")
    assert code == 0, err
    png = tmp_path / "figs" / f"x_{system}.png"
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert (width, height) == (800, 650)
    code, _, err = run(capsys, "plot", out_dir / "trajectory.npz", "--animate")
    assert code == 2 and "--animate" in err
    code, _, err = run(capsys, "view", out_dir / "trajectory.npz", "-o", tmp_path / "page.html")
    assert code == 2 and "lgvi view" in err and system in err and not (tmp_path / "page.html").exists()


@pytest.mark.parametrize("example", ["orbit_attitude.toml", "binary_asteroid.toml"])
def test_the_examples_run_from_the_command_line(capsys, tmp_path, example):
    code, out, err = run(capsys, "run", EXAMPLES / example, "-o", tmp_path / "out", "--no-plots")
    assert code == 0, err
    assert not list((tmp_path / "out").glob("*.png"))
    assert "status:        complete" in (tmp_path / "out" / "summary.txt").read_text()


@pytest.mark.parametrize("text,old,new,key", [
    (ORBIT, "mass = 500.0", "mas = 500.0", "orbiting_body.mas"),
    (ORBIT, "mu = 3.986004418e14", "mu = -1.0", "orbiting_body.mu"),
    (ORBIT, "h = 10.0", "h = 10.0\nsteps_per = 3", "integrator.steps_per"),
    (ORBIT, "[integrator]", '[output]\nformats = ["csv"]\n\n[integrator]', "output.formats[0]"),
    (ORBIT, "[integrator]", '[output]\nplots = "yes"\n\n[integrator]', "output.plots"),
    (TWO, "mass = 0.2", "mass = 0.2\ncolour = 1", "two_body.body2.colour"),
    (TWO, 'potential = "order2"', 'potential = "order3"', "two_body.potential"),
])
def test_bad_scenario_keys_are_named(capsys, tmp_path, text, old, new, key):
    assert old in text
    path = write(tmp_path, text.replace(old, new, 1))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.key == key, str(info.value)
    code, _, err = run(capsys, "run", path, "-o", tmp_path / "out")
    assert code == 2 and key in err
    assert not (tmp_path / "out").exists()


def test_run_options_these_systems_do_not_take(capsys, tmp_path):
    path = write(tmp_path, ORBIT)
    code, _, err = run(capsys, "run", path, "-o", tmp_path / "a", "--format", "csv")
    assert code == 2 and "--format" in err and "npz" in err
    code, _, err = run(capsys, "run", path, "-o", tmp_path / "b", "--resume")
    assert code == 2 and "--resume" in err and "no interrupted run" in err
    plots_off = write(tmp_path, ORBIT.replace("[integrator]", "[output]\nplots = false\n\n[integrator]"), "quiet.toml")
    code, _, err = run(capsys, "run", plots_off, "-o", tmp_path / "c")
    assert code == 0, err
    assert not list((tmp_path / "c").glob("*.png")) and (tmp_path / "c" / "trajectory.npz").exists()


def test_a_failed_run_writes_the_part_computed(capsys, tmp_path, monkeypatch):
    # a step that fails (as the driver reports it: ConvergenceError with the run up to it)
    from dataclasses import replace

    from lgvi.io.scenario import BodiesScenario

    path = write(tmp_path, ORBIT)
    whole = load_scenario(path).run()
    part = replace(whole, t=whole.t[:11], x=whole.x[:11], p=whole.p[:11], R=whole.R[:11], Pi=whole.Pi[:11],
                   iterations=whole.iterations[:10], residual=whole.residual[:10])

    def fail(self, folder, *, resume=False, progress=False, chunk_steps=None):
        raise lgvi.ConvergenceError("orbit step 41 (t = 410) failed: test", residual=1.0, iterations=50, step=41,
                                    time=410.0, trajectory=part)

    monkeypatch.setattr(BodiesScenario, "run_stream", fail)
    code, _, err = run(capsys, "run", path, "-o", tmp_path / "out")
    assert code == 1 and "ConvergenceError" in err and "step 41" in err and str(tmp_path / "out") in err
    js = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert js["status"] == "failed" and js["steps"] == 40 and js["samples"] == 11
    back = read_trajectory(tmp_path / "out" / "trajectory.npz")
    assert np.array_equal(back.x, part.x) and not list((tmp_path / "out").glob("*.png"))


@pytest.mark.parametrize("text", [ORBIT, TWO], ids=["orbit", "two_body"])
def test_an_interrupted_run_resumes_bit_for_bit(capsys, tmp_path, text):
    # lgvi run streams these systems as it does rigid bodies: a run stopped by Ctrl-C after two
    # chunks is finished by `lgvi run --resume`, and the result is the uninterrupted run
    path = write(tmp_path, text)
    sc = load_scenario(path)
    whole = sc.run()
    stop = sc.steps // 2

    def ctrl_c(k, n):
        if k >= stop:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sc.run_stream(tmp_path / "out" / "stream", chunk_steps=stop // 2, progress=ctrl_c)
    code, _, err = run(capsys, "run", path, "-o", tmp_path / "out", "--resume")
    assert code == 0, err
    back = read_trajectory(tmp_path / "out" / "trajectory.npz")
    for name in ("t", "x", "p", "R", "Pi", "iterations", "residual"):
        assert np.array_equal(getattr(back, name), getattr(whole, name)), name
    assert not (tmp_path / "out" / "stream").exists()      # removed unless --keep-stream


# ------------------------------------------------------------------------------------------------
# a gyrostat ensemble: save / load / lgvi info
# ------------------------------------------------------------------------------------------------
B = 3
RPM = 2 * np.pi / 60
RNG = np.random.default_rng(11)
J0 = np.diag([900.0, 800.0, 600.0])


def gyrostat_ensemble(save_every: int = 5):
    inertia = np.array([J0 * (1 + 0.05 * RNG.normal(size=3)) for _ in range(B)])
    wheels = [lgvi.ReactionWheels(np.eye(3), 0.08, speed0=(np.array([100.0, 200.0, 300.0]) + 20 * RNG.normal(size=3))
                                  * RPM, max_torque=0.2) for _ in range(B)]
    R0 = lgvi.so3.exp(0.2 * RNG.normal(size=(B, 3)))
    W0 = np.array([0.001, -0.01, 0.03]) + 1e-3 * RNG.normal(size=(B, 3))
    ctrl = [lgvi.control.MRPFeedback(K=3.5 * (1 + 0.1 * RNG.normal()), P=30.0) for _ in range(B)]
    from lgvi.systems.loop_keywords import as_given

    with as_given():    # the gyrostat ensemble's files (the keywords now run the loop: tests/test_loop_keywords.py)
        return lgvi.simulate_ensemble(inertia, R0, omega0=W0, h=0.1, steps=200, wheels=wheels, controller=ctrl,
                                      control_period=0.1, save_every=save_every)


def test_gyrostat_ensemble_round_trips_bit_for_bit(tmp_path, capsys):
    from lgvi.systems.gyrostat_ensemble import GyrostatEnsemble

    ens = gyrostat_ensemble()
    path = tmp_path / "ensemble.npz"
    ens.save(path)
    back = GyrostatEnsemble.load(path)
    assert isinstance(back, GyrostatEnsemble) and len(back) == B
    assert json.loads(json.dumps(ens.meta)) == back.meta
    assert sorted(back.params) == sorted(ens.params) and sorted(back.dispersions) == sorted(ens.dispersions)
    for k in ens.params:
        assert np.array_equal(back.params[k], ens.params[k]) and back.params[k].dtype == ens.params[k].dtype, k
    for b in range(B):
        one, two = ens[b], back[b]
        assert type(two) is type(one) and two.h == one.h
        for name in ("t", "R", "Pi", "inertia", "iterations", "residual", "wheel_momentum", "wheel_torque",
                     "wheel_axes", "spin_inertia"):
            a, c = np.asarray(getattr(one, name)), np.asarray(getattr(two, name))
            assert a.dtype == c.dtype and a.shape == c.shape and a.tobytes() == c.tobytes(), (b, name)
        assert json.loads(json.dumps(one.meta)) == two.meta
        assert np.array_equal(one.wheel_speed, two.wheel_speed)
    # saved again, the file is the same bytes
    back.save(tmp_path / "again.npz")
    assert (tmp_path / "again.npz").read_bytes() == path.read_bytes()
    assert type(read_trajectory(path)) is GyrostatEnsemble
    code = cli.main(["info", str(path)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert f"members     {B}" in out and "controller.K" in out and "dispersed" in out
    code = cli.main(["plot", str(path)])
    assert code == 2 and "ensemble" in capsys.readouterr().err


def test_gyrostat_ensemble_load_refuses_damaged_and_hostile_files(tmp_path):
    from lgvi.systems.gyrostat_ensemble import GyrostatEnsemble

    ens = gyrostat_ensemble(save_every=50)
    path = tmp_path / "ens.npz"
    ens.save(path)
    data = path.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="cut.npz"):
        GyrostatEnsemble.load(tmp_path / "cut.npz")
    # another result is not an ensemble
    ens[0].save(tmp_path / "one.npz")
    with pytest.raises(ValueError, match=r"one\.npz.*format"):
        GyrostatEnsemble.load(tmp_path / "one.npz")
    # a pickled object array is refused before numpy reads it
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["R"] = np.array([object()] * 2, dtype=object)
    np.savez(tmp_path / "evil.npz", **arrays)
    with pytest.raises(ValueError, match=r"evil\.npz.*object"):
        GyrostatEnsemble.load(tmp_path / "evil.npz")
    # wrong shapes are named
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["wheel_momentum"] = arrays["wheel_momentum"][:, :, :2]
    np.savez(tmp_path / "shape.npz", **arrays)
    with pytest.raises(ValueError, match=r"shape\.npz.*wheel_momentum"):
        GyrostatEnsemble.load(tmp_path / "shape.npz")


# ------------------------------------------------------------------------------------------------
# error_estimate with reaction wheels
# ------------------------------------------------------------------------------------------------
def _wheel_case(h: float, **kw):
    J = np.diag([900.0, 800.0, 600.0])
    R0 = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))
    wheels = lgvi.ReactionWheels(np.eye(3), 0.08, speed0=np.array([100.0, 200.0, 300.0]) * RPM, max_torque=0.2)
    return lgvi.simulate(J, R0, omega0=[0.01, -0.02, 0.03], h=h, wheels=wheels,
                         controller=lgvi.control.MRPFeedback(K=3.5, P=30.0), control_period=0.4, **kw)


@pytest.mark.parametrize("h", [0.4, 0.2])
def test_error_estimate_with_wheels_tracks_the_true_error(h):
    from lgvi.accuracy import geodesic_distance

    steps = int(round(120.0 / h))
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no AccuracyWarning: the error is small
        traj = _wheel_case(h, steps=steps, error_estimate=True)
    est = traj.error_estimate
    assert est is not None and est.order == 2 and est.h == h
    ref = _wheel_case(h / 64, steps=64 * steps, save_every=64)        # the same zero-order hold, 64x finer
    true = float(geodesic_distance(traj.R[-1], ref.R[-1]))
    assert true > 1e-6                                                 # a real error to track
    assert est.attitude == pytest.approx(true, rel=0.02)
    # the estimate does not change the run itself
    plain = _wheel_case(h, steps=steps)
    assert np.array_equal(plain.R, traj.R) and np.array_equal(plain.wheel_momentum, traj.wheel_momentum)


class _Pulse(lgvi.control.Controller):
    """A wheel torque pulse over the first 20 calls: a controller with its own state."""

    def __init__(self) -> None:
        self.calls = 0

    def command(self, t, R, omega, wheel_speed, env):
        self.calls += 1
        return lgvi.control.Command(wheel_torque=[0.05, -0.02, 0.0] if self.calls <= 20 else [0.0, 0.0, 0.0])


def test_error_estimate_with_wheels_runs_the_shadow_with_a_copy_of_the_controller():
    # a controller shared by the run and the shadow run would start the shadow with the run's
    # state (here: the pulse over), and the estimate would measure that, not the step's error
    J = np.diag([900.0, 800.0, 600.0])
    kw = dict(omega0=[0.01, -0.02, 0.03], h=0.2, steps=300, control_period=0.2)
    wheels = lgvi.ReactionWheels(np.eye(3), 0.08)
    a = lgvi.simulate(J, np.eye(3), wheels=wheels, controller=_Pulse(), error_estimate=True, **kw)
    b = lgvi.simulate(J, np.eye(3), wheels=wheels, controller=_Pulse(), **kw)
    assert np.array_equal(a.R, b.R)
    half = lgvi.simulate(J, np.eye(3), wheels=wheels, controller=_Pulse(), **dict(kw, h=0.1, steps=600,
                                                                                    control_period=0.2))
    from lgvi.accuracy import geodesic_distance

    assert a.error_estimate.attitude == pytest.approx(4.0 / 3.0 * float(geodesic_distance(a.R[-1], half.R[-1])),
                                                      rel=1e-12)
    assert a.error_estimate.attitude < 1e-4


# ------------------------------------------------------------------------------------------------
# a wheel scenario with scheme = "rkmk4" from the command line
# ------------------------------------------------------------------------------------------------
COAST = """\
name = "wheels_coast"

[body]
inertia = [900.0, 800.0, 600.0]

[initial]
omega = [0.01, -0.02, 0.03]

[integrator]
h = 0.1
steps = 400
save_every = 4
scheme = "rkmk4"
composition = "ralston4"

[[wheel]]
axis = [1.0, 0.0, 0.0]
spin_inertia = 0.08
speed0 = 100.0

[[wheel]]
axis = [0.0, 1.0, 0.0]
spin_inertia = 0.08
speed0 = -50.0
"""


def test_run_a_wheel_scenario_with_scheme_rkmk4(capsys, tmp_path):
    """``lgvi run`` of [[wheel]] with scheme = "rkmk4": the run of lgvi.simulate bit for bit, the
    scheme and tableau in the summary, the wheel figures, and no energy bound claimed (the LGVI's
    run of the same file, motors off, claims one)."""
    lgvi_text = COAST.replace('scheme = "rkmk4"\ncomposition = "ralston4"\n', "")
    assert lgvi_text != COAST
    sums = {}
    for name, text in (("rkmk4", COAST), ("lgvi", lgvi_text)):
        out_dir = tmp_path / name
        code, out, err = run(capsys, "run", write(tmp_path, text, f"{name}.toml"), "-o", out_dir)
        assert code == 0, err
        sums[name] = ((out_dir / "summary.txt").read_text(), json.loads((out_dir / "summary.json").read_text()))
        files = {p.name for p in out_dir.iterdir()}
        assert {"trajectory.npz", "summary.txt", "wheels.png", "conservation.png"} <= files
    traj = read_trajectory(tmp_path / "rkmk4" / "trajectory.npz")
    wheels = lgvi.ReactionWheels(np.eye(3)[:2], 0.08, speed0=[100.0, -50.0])
    ref = lgvi.simulate(np.diag([900.0, 800.0, 600.0]), np.eye(3), omega0=[0.01, -0.02, 0.03], h=0.1, steps=400,
                        save_every=4, wheels=wheels, scheme="rkmk4", composition="ralston4")
    for name in ("t", "R", "Pi", "wheel_momentum"):
        assert np.array_equal(getattr(traj, name), getattr(ref, name)), name
    assert traj.meta["scheme"] == "rkmk4" and traj.meta["composition"] == "ralston4"
    text, js = sums["rkmk4"]
    assert "integrator:    rkmk4 ralston4 (explicit Runge-Kutta-Munthe-Kaas), order 4" in text
    assert (js["scheme"], js["method"], js["composition"], js["order"]) == ("rkmk4", "rkmk4", "ralston4", 4)
    assert re.search(r"energy \(total\)\s+not an invariant here", text), text
    assert js["invariants"]["energy"] == "not an invariant"
    assert all(rel < 1e-12 for _, rel, _ in summary_rows(text).values())   # the momenta it declares exact
    text, js = sums["lgvi"]
    assert js["invariants"]["energy"] == "bounded" and "bounded" in summary_rows(text)["energy (total)"][2]


@pytest.mark.parametrize("old,new,key,allowed", [
    ('composition = "ralston4"', 'composition = "suzuki4"', "integrator.composition", "'rk4', 'rk38', 'ralston4'"),
    ("h = 0.1", "h = 0.1\norder = 6", "integrator.order", "one of 4"),
    ("[[wheel]]", '[[torque]]\ntype = "damping"\nc = 0.1\n\n[[wheel]]', "torque", 'integrator.scheme = "lgvi"'),
])
def test_run_names_the_key_scheme_rkmk4_refuses(capsys, tmp_path, old, new, key, allowed):
    assert old in COAST
    path = write(tmp_path, COAST.replace(old, new, 1))
    code, _, err = run(capsys, "run", path, "-o", tmp_path / "out")
    assert code == 2 and key in err and allowed in err, err
    assert not (tmp_path / "out").exists()
