"""The CubeSat ADCS mission of issue 28 (``examples/cubesat_mission.toml``): the loop fixes it
showed, a short run of the file, its summary and figures, and the Monte Carlo's member equal to
its lone run."""

from __future__ import annotations

import json
import sys
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.io import examples
from lgvi.io.scenario_loop import loop_summary
from lgvi.environment import CircularOrbit
from lgvi.fsw import MEKF, FlightSoftware
from lgvi.spacecraft import Gyro, Spacecraft, StarTracker


def test_star_tracker_excluded_at_its_first_sample_with_an_mekf():
    """A star tracker whose boresight is inside the Earth's limb at t = 0 measures nothing then; with
    an MEKF in the run the loop used to start its time st_time at the MEKF's NaN ("nothing yet"), so
    the tracker 'wrote' a value that is not finite and the run stopped at step 0. It must run, take
    no measurement while excluded, and the filter must use the first one once the Earth leaves the
    field of view (the body turns at 0.05 rad/s: ~26 s to clear the limb plus 0.1 rad)."""
    orbit = CircularOrbit(6878137.0, np.radians(97.4))
    r0 = np.asarray(orbit.position_velocity(np.array([0.0]))[0]).reshape(3)
    z = -r0 / np.linalg.norm(r0)                                  # boresight (body z) at nadir
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    R0 = np.column_stack([x, np.cross(z, x), z])
    st = StarTracker(rate=0.5, sigma_cross=1e-5, sigma_about=1e-4, earth_exclusion=0.1, seed=1)
    sat = Spacecraft([0.18, 0.14, 0.06], orbit=orbit, sensors=[Gyro(rate=0.5, arw=1e-5, seed=1), st])
    est = MEKF(rate=0.5, arw=1e-5, rrw=0.0, star_tracker=True, R0=lgvi.so3.exp([2e-3, -1e-3, 1e-3]) @ R0,
               P0=[1e-5] * 3 + [1e-10] * 3)
    tr = lgvi.simulate(sat, R0, omega0=[0.05, 0.0, 0.0], h=0.1, steps=600, fsw=FlightSoftware(estimator=est),
                       save_every=5)
    valid = tr.signals["st_valid"].ravel()
    assert valid[0] == 0.0 and valid[-1] == 1.0
    first = int(np.argmax(valid == 1.0))
    assert 20.0 < tr.signal_t[first] < 40.0
    assert np.all(np.isfinite(tr.signals["st_time"]))
    err = np.linalg.norm(tr.signals["est_error"], axis=1)
    assert err[first - 1] > 1e-3                      # the 2.4e-3 rad first estimate, not corrected yet
    assert err[-1] < 2e-4                             # corrected by the star tracker (1e-5 rad across)


ROOT = Path(__file__).resolve().parents[1]
QUICK = 70000                       # 7000 s: the detumble, the sun-safe mode and the start of nadir pointing


def _scenario(steps: int = QUICK):
    from lgvi.io.scenario import Scenario

    sc = Scenario.from_dict(tomllib.loads(examples.text("cubesat_mission")), "cubesat_mission.toml")
    return replace(sc, steps=steps)


@pytest.fixture(scope="module")
def flown():
    sc = _scenario()
    return sc, sc.run()


def test_mission_file_flies_the_three_modes(flown):
    """The shipped file (7000 s of it): B-dot brings 10 deg/s below 0.8 deg/s within one orbit,
    sun-safe holds 15 minutes, then the Hill frame is held to better than 0.1 deg (the truth
    against the reference, whatever the filter says) with the MEKF's error ten times smaller."""
    sc, traj = flown
    s = loop_summary(traj)
    assert [m["mode"] for m in s["modes"]] == [0, 1, 2]
    assert [m["name"] for m in s["modes"]] == traj.meta["mode_names"] == ["detumble", "sun-safe", "nadir"]
    assert np.degrees(np.linalg.norm(traj.omega[0])) == pytest.approx(10.0, abs=1e-3)
    assert 2000.0 < s["detumble_time_s"] < 5677.0
    assert s["modes"][2]["from_s"] - s["modes"][1]["from_s"] == pytest.approx(900.0, abs=1.0)
    assert s["settle_time_s"] is not None and s["settle_time_s"] < s["modes"][2]["from_s"] + 600.0
    assert s["control_error_deg"]["p95"] < 0.1
    assert s["knowledge_error_deg"]["p95"] < 0.02
    # the control error recomputed from the saved states and the reference
    k = np.searchsorted(traj.signal_t, s["settle_time_s"])
    R_ref = traj.signals["R_ref"][k:].reshape(-1, 3, 3)
    R = traj.R[np.searchsorted(traj.t, traj.signal_t[k:])]
    angle = np.degrees(Rotation.from_matrix(np.swapaxes(R_ref, 1, 2) @ R).magnitude())
    assert s["control_error_deg"]["max"] == pytest.approx(angle.max(), rel=1e-6)
    # the budget: the residual dipole is the largest torque of this 6U, radiation pressure the least
    d = s["disturbances"]
    assert set(d) == {"facet_drag", "facet_srp", "residual_dipole", "gravity_gradient"}
    assert max(d, key=lambda k: d[k]["rms_Nm"]) == "residual_dipole"
    assert min(d, key=lambda k: d[k]["rms_Nm"]) == "facet_srp"
    # the gravity gradient of the budget is 3 mu / r^5 b x J b at one record, done by hand
    j = len(traj.signal_t) // 2
    r = traj.signals["r_N"][j]
    b = traj.R[np.searchsorted(traj.t, traj.signal_t[j])].T @ r
    tau = 3 * 3.986004418e14 / np.linalg.norm(r) ** 5 * np.cross(b, sc.spacecraft.body.J @ b)
    assert d["gravity_gradient"]["max_Nm"] >= np.linalg.norm(tau) > 1e-9


def test_python_example_is_the_file_bit_for_bit(flown):
    """examples/cubesat_mission.py builds the same mission from the classes: the same run, bit for bit."""
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import cubesat_mission as cm
    finally:
        sys.path.pop(0)
    sc, traj = flown
    sat, fsw, R0, omega0 = cm.mission()
    mine = lgvi.simulate(sat, R0, omega0=omega0, h=0.1, steps=QUICK, fsw=fsw, save_every=50)
    np.testing.assert_array_equal(mine.R, traj.R)
    np.testing.assert_array_equal(mine.wheel_speed, traj.wheel_speed)
    assert sorted(mine.signals) == sorted(traj.signals)
    for name in traj.signals:
        np.testing.assert_array_equal(mine.signals[name], traj.signals[name], err_msg=name)


def test_mission_figures(flown, tmp_path):
    pytest.importorskip("matplotlib")
    from lgvi.plot.loop import save_loop_figures

    files = {p.name for p in save_loop_figures(flown[1], tmp_path)}
    assert {"mission.png", "estimation.png", "disturbances.png", "pointing.png", "modes.png", "dipoles.png"} <= files
    # pointing.png: the detumble (no control law: sigma_BR cleared) is a gap, not an error of zero
    from lgvi.plot.loop import pointing

    traj = flown[1]
    sigma = pointing(traj).axes[1].get_lines()[0]
    x, y = np.asarray(sigma.get_xdata()), np.asarray(sigma.get_ydata(), float)
    detumble = x < loop_summary(traj)["modes"][1]["from_s"]
    assert detumble.any() and np.isnan(y[detumble]).all() and np.isfinite(y[~detumble]).all()


def test_lgvi_run_of_the_example_summarises_the_mission(capsys, tmp_path):
    """``lgvi example cubesat_mission`` then ``lgvi run`` of its first 700 s (still in detumble): the
    summary's lines (not settled: it never left detumble, whose cleared sigma_BR is no error), the
    page report.html beside the figures as for the other scenarios, with the recorded orbit, and
    what the conservation figure, the summary and the page say of a spacecraft under torques."""
    import base64
    import re

    from lgvi import cli
    from lgvi.io.scenario import to_toml

    d = tomllib.loads(examples.text("cubesat_mission"))
    d["integrator"]["duration"] = 700.0
    d["output"] = {"formats": ["npz"]}
    path = tmp_path / "mission.toml"
    path.write_text(to_toml(d))
    assert cli.main(["run", str(path), "-o", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    out = tmp_path / "out"
    s = json.loads((out / "summary.json").read_text())["pointing"]
    assert s["detumble_time_s"] is None and s["modes"] == [{"mode": 0, "name": "detumble", "from_s": 0.0}]
    assert s["settle_time_s"] is None and s["error_deg"] is None and s["not_settled"] == "never left detumble"
    assert s["error_final_deg"] is None and s["rate_error_final_deg_s"] is None
    assert not (out / "pointing.png").exists() and (out / "mission.png").exists()    # no law ran: no pointing
    assert set(s["disturbances"]) == {"facet_drag", "facet_srp", "residual_dipole", "gravity_gradient"}
    txt = (out / "summary.txt").read_text()
    assert "disturbances:" in txt and "pointing:      not settled: never left detumble" in txt
    torques = ("a spacecraft under external torques (facet drag, facet srp, residual dipole, magnetorquers, "
               "gravity gradient)")
    assert f"{torques} has no invariants" in txt
    # the page, as lgvi view writes it, with the orbit's track: the recorded positions in Earth radii
    traj = lgvi.load(out / "trajectory.npz")
    assert traj.meta["pointing_modes"] == [1, 2]
    page = (out / "report.html").read_text()
    fig = json.loads(re.search(r"var fig = (\{.*?\});\n  Plotly\.newPlot", page, re.S).group(1).replace("<\\/", "</"))
    track = [t for t in fig["data"] if t.get("name") == "orbit in detumble"]
    assert len(track) == 1

    def decode(a):
        return (np.frombuffer(base64.b64decode(a["bdata"]), dtype=a["dtype"]) if isinstance(a, dict)
                else np.array([np.nan if v is None else v for v in a], dtype=float))

    pts = np.column_stack([decode(track[0][c]) for c in "xyz"])
    pts = pts[np.isfinite(pts).all(axis=1)]
    r = traj.signals["r_N"] / 6378137.0
    assert len(pts) > 10 and np.allclose(pts[0], r[0], atol=1e-5)
    assert np.abs(pts[:, None, :] - r[None, :, :]).max(axis=2).min(axis=1).max() < 1e-5      # every point recorded
    assert f"{torques} has no invariants" in page and "the spacecraft has no invariants" not in page
    # the conservation figure: no error to draw but |R^T R - I|, and says why
    pytest.importorskip("matplotlib")
    from lgvi import plot

    f = plot.conservation(traj)
    assert f.axes[0].get_title().endswith("(a spacecraft under external torques: no invariant; drawn: |R^T R - I|)")
    labels = [ln.get_label() for ln in f.axes[0].get_lines()]
    assert len(labels) == 1 and labels[0].startswith("orthogonality"), labels


def _modes_run(modes, sigma, meta):
    """A stand-in for a loop result with records ``mode`` and ``sigma_BR`` (what loop_summary reads)."""
    from types import SimpleNamespace

    n = len(modes)
    return SimpleNamespace(signals={"mode": np.asarray(modes, float), "sigma_BR": np.asarray(sigma, float)},
                           signal_t=5.0 * np.arange(n), t=5.0 * np.arange(n), omega=np.zeros((n, 3)),
                           R=np.tile(np.eye(3), (n, 1, 1)), meta=meta)


@pytest.mark.parametrize("meta", [{"mode_names": ["detumble", "nadir"], "pointing_modes": [1]},
                                  {"mode_names": ["detumble", "nadir"]}])      # saved before pointing_modes
def test_a_member_that_never_left_detumble_is_not_settled(meta):
    """In a mode with no control law (B-dot detumble) sigma_BR is cleared to zero: that is no error,
    and a run that never left it has not settled (it used to read as settled at t = 0 with error 0).
    A run is settled from the first record after which every record is in a pointing mode and
    below the threshold; the summary, the ensemble's count and its lines say why not, by mode name."""
    from lgvi.io.scenario_ensemble import ensemble_lines, ensemble_summary
    from lgvi.io.scenario_loop import summary_lines

    small = [1e-4, 0.0, 0.0]                                    # 0.0229 deg
    still = loop_summary(_modes_run([0] * 6, np.zeros((6, 3)), meta))
    assert still["settle_time_s"] is None and still["error_deg"] is None and still["error_final_deg"] is None
    assert still["not_settled"] == "never left detumble"
    assert "pointing:      not settled: never left detumble" in summary_lines(still)
    flown = loop_summary(_modes_run([0, 0, 1, 1, 1, 1], [[0.0] * 3] * 2 + [[0.1, 0, 0]] + [small] * 3, meta))
    assert flown["settle_time_s"] == 15.0 and flown["not_settled"] is None
    assert flown["error_deg"]["max"] == pytest.approx(np.degrees(4 * np.arctan(1e-4)))
    back = loop_summary(_modes_run([0, 1, 1, 0, 0, 0], [[0.0] * 3] + [small] * 2 + [[0.0] * 3] * 3, meta))
    assert back["settle_time_s"] is None and back["not_settled"] == "ended in detumble, a mode with no control law"
    e = ensemble_summary([still, flown, still, back])
    assert e["settled"] == 1 and e["settle_time_s"]["n"] == 1
    assert e["not_settled"] == {"never left detumble": 2, "ended in detumble, a mode with no control law": 1}
    assert ensemble_lines(e)[0] == ("members:       4, settled 1; never left detumble 2; ended in detumble, a mode "
                                    "with no control law 1")
    mc = _monte_carlo()                                         # the benchmark's verdict: did not detumble
    assert mc.verdict(dict(still, detumble_time_s=None, modes=[{"mode": 0, "name": "detumble", "from_s": 0.0}]),
                      None, 628.3).startswith("did not detumble (never left detumble")


def test_mode_names_in_the_file_are_checked():
    """``[fsw.modes] names``: one string per mode the rules use; a mistake names the key."""
    from lgvi.io.scenario import Scenario, ScenarioError

    d = tomllib.loads(examples.text("cubesat_mission"))
    for names, match in ((["detumble", "sun-safe"], r"fsw\.modes\.names.*every mode.*0\.\.2"),
                         ("detumble", r"fsw\.modes\.names.*array of strings"),
                         (["detumble", 1, "nadir"], r"fsw\.modes\.names\[1\].*string")):
        d["fsw"]["modes"]["names"] = names
        with pytest.raises(ScenarioError, match=match):
            Scenario.from_dict(d, "mission.toml")


def _monte_carlo():
    import importlib.util

    spec = importlib.util.spec_from_file_location("mission_monte_carlo", ROOT / "benchmarks" / "mission_monte_carlo.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_sgp4_orbit_copies_and_pickles():
    """An ensemble deep-copies each member's spacecraft (and Dask pickles it): an SGP4 orbit used to
    refuse ("cannot pickle 'Satrec' object"); it is rebuilt from its TLE, the same positions."""
    import copy
    import pickle

    from lgvi.environment import SGP4Orbit

    d = tomllib.loads(examples.text("cubesat_mission"))["spacecraft"]["orbit"]
    orbit = SGP4Orbit(d["line1"], d["line2"])
    t = np.array([0.0, 1234.5, 17040.0])
    for other in (copy.deepcopy(orbit), pickle.loads(pickle.dumps(orbit))):
        assert other.epoch == orbit.epoch
        for a, b in zip(other.position_velocity(t), orbit.position_velocity(t)):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("threads", [1, 2])
def test_monte_carlo_member_is_its_lone_run(threads):
    """benchmarks/mission_monte_carlo.py: member b of a dispersed ensemble (its own inertia, axes,
    sensors, seeds, coefficients, gains) equals its lone run bit for bit, on one and two threads;
    its draws depend on b alone (the same member built twice is the same)."""
    mc = _monte_carlo()
    base = mc.nominal()
    built = [mc.member(b, base=base) for b in (0, 1, 2)]
    again = mc.member(1, base=base)
    np.testing.assert_array_equal(again[0].body.J, built[1][0].body.J)
    assert not np.array_equal(built[0][0].body.J, built[1][0].body.J)
    kw = dict(h=base.h, steps=2000, save_every=base.save_every)
    ens = lgvi.simulate_ensemble([m[0] for m in built], np.stack([m[2] for m in built]),
                                 omega0=np.stack([m[3] for m in built]), fsw=[m[1] for m in built], threads=threads,
                                 **kw)
    for b in (1, 2):
        lone = lgvi.simulate(built[b][0], built[b][2], omega0=built[b][3], fsw=built[b][1], **kw)
        np.testing.assert_array_equal(ens.members[b].R, lone.R)
        np.testing.assert_array_equal(ens.members[b].wheel_speed, lone.wheel_speed)
        for name in lone.signals:
            np.testing.assert_array_equal(ens.members[b].signals[name], lone.signals[name], err_msg=name)
    assert not np.array_equal(ens.members[1].signals["est_error"], ens.members[2].signals["est_error"])


def test_monte_carlo_member_is_its_lone_run_on_dask():
    """Member b of the Monte Carlo flown as a Dask task (lgvi.simulate_members on a client: the
    spacecraft system's runs, one task a member) equals its lone run bit for bit, records included."""
    distributed = pytest.importorskip("dask.distributed")
    from lgvi.system_ensembles import simulate_members

    mc = _monte_carlo()
    base = mc.nominal()
    built = [mc.member(b, base=base) for b in (0, 1, 2)]
    kw = dict(h=base.h, steps=1000, save_every=base.save_every)
    members = [((m[0], m[2]), dict(kw, omega0=m[3], fsw=m[1])) for m in built]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=":0") as cluster, distributed.Client(cluster) as client:
        ens = simulate_members("spacecraft", members, client=client)
    for b in (0, 2):
        lone = lgvi.simulate(built[b][0], built[b][2], omega0=built[b][3], fsw=built[b][1], **kw)
        np.testing.assert_array_equal(ens[b].R, lone.R)
        np.testing.assert_array_equal(ens[b].wheel_speed, lone.wheel_speed)
        assert sorted(ens[b].signals) == sorted(lone.signals)
        for name in lone.signals:
            np.testing.assert_array_equal(ens[b].signals[name], lone.signals[name], err_msg=name)
    assert not np.array_equal(ens[0].R, ens[2].R)


def test_bad_inputs_of_the_mission_parts():
    """MEKF(star_tracker=True) needs exactly one StarTracker on the spacecraft; loop_summary's
    inertia is a 3x3 matrix; each refusal names the argument and the rule."""
    orbit = CircularOrbit(6878137.0, np.radians(97.4))
    sat = Spacecraft([0.18, 0.14, 0.06], orbit=orbit, sensors=[Gyro(rate=0.5, arw=1e-5, seed=1)])
    fsw = FlightSoftware(estimator=MEKF(rate=0.5, arw=1e-5, rrw=0.0, star_tracker=True, P0=[1e-4] * 3 + [1e-8] * 3))
    with pytest.raises(ValueError, match=r"MEKF: the spacecraft needs a StarTracker"):
        lgvi.simulate(sat, np.eye(3), omega0=np.zeros(3), h=0.1, steps=10, fsw=fsw)
    with pytest.raises(TypeError, match="star_tracker must be a StarTracker, True"):
        MEKF(rate=0.5, arw=1e-5, rrw=0.0, star_tracker="yes", P0=[1e-4] * 6)
    st = StarTracker(rate=0.5, sigma_cross=1e-5, sigma_about=1e-4, seed=1)
    sat = Spacecraft([0.18, 0.14, 0.06], orbit=orbit, sensors=[Gyro(rate=0.5, arw=1e-5, seed=1), st])
    traj = lgvi.simulate(sat, np.eye(3), omega0=np.zeros(3), h=0.1, steps=10, fsw=fsw)
    with pytest.raises(ValueError, match="inertia"):
        loop_summary(traj, inertia=[1.0, 2.0])


def test_nadir_phase_agrees_with_basilisk_over_one_orbit():
    """The mission's nadir phase (benchmarks/basilisk_mission.py: the mission's 6U, wheels, facets and
    dipole; hillPoint, mrpFeedback, rwMotorTorque; gravity gradient, facet drag, facet SRP with the
    shadow, residual dipole; FSW at 2 Hz, perfect navigation, no dumping) against Basilisk 2.12.1's
    RK4 over one orbit. Basilisk's own error is first order too (its environment is held over each
    step): its runs at h and h/2 differ by 3.7e-8 rad, so its run at h is about 7.4e-8 from its limit.
    lgvi agrees with it to 7.1e-8 (h = 0.1 s) and 7.4e-8 (h/2, h/4: lgvi converged, the difference is
    Basilisk's own step error), far below the issue's 1e-5 rad. lgvi's own step error is second order
    (the disturbances forced symmetrically, docs/environment.md): its differences between h and h/2,
    h/2 and h/4 measure 1.38e-8 and 3.46e-9 (ratio 4.00; 4.00 again one step further)."""
    bench = Path(__file__).resolve().parents[1] / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        import basilisk_mission as m
    finally:
        sys.path.remove(str(bench))
    fx = dict(np.load(bench / "basilisk_mission.npz"))
    assert np.allclose(fx["t"], np.arange(0.0, m.DURATION + 1.0, m.SAVE), rtol=0, atol=1e-9)
    floor = m.attitude_difference(m.matrix_of(fx["sigma"]), fx["sigma_half"]).max()
    assert floor < 1e-7, floor                                  # Basilisk at h against h/2
    runs = {h: m.lgvi_run(h) for h in (m.H, m.H / 2, m.H / 4)}
    for h in (m.H, m.H / 2):
        err = m.attitude_difference(runs[h].R, fx["sigma"])
        assert len(err) == len(fx["t"])
        assert err.max() < 1e-7, (h, err.max())                # 2.7 x the floor at most; measured 7.1e-8, 7.4e-8
    step = [(Rotation.from_matrix(runs[a].R).inv() * Rotation.from_matrix(runs[b].R)).magnitude().max()
            for a, b in ((m.H, m.H / 2), (m.H / 2, m.H / 4))]
    assert 3.6 < step[0] / step[1] < 4.4, step                  # second order in h
    assert step[0] < 5e-8, step


def test_noisy_nadir_phase_agrees_with_basilisk_over_50_members():
    """With noise on (benchmarks/basilisk_mission.py, "With noise on"): the nadir phase over one orbit,
    50 members a side, the navigation of Basilisk's simpleNav on both (lgvi.fsw.SimpleNav: a bounded
    random walk of the MRP attitude error and of the rate error every dynamics step, the flight
    software reading it at 2 Hz), each member its own noise stream. Per member, from 1000 s on: the
    mean and 95th percentile of the true pointing error, the mean navigation error. lgvi's 50 against
    Basilisk's 50 (the fixture), the issue's criterion: for each figure the two means' 95 % intervals
    (Student t) overlap, and the 95 % Welch interval of the difference of the means holds 0 (measured:
    Welch p 0.15, 0.18, 0.19). Not asserted, reported (docs/mission.md): the two-sample
    Kolmogorov-Smirnov test rejects equal distributions of the per-member mean pointing error at 1 %
    (p 0.006; 0.40 and 0.18 for the other two), and Basilisk's 95th percentiles spread wider (std
    0.0038 against 0.0026 deg, Levene p 0.006). The comparison can fail: a navigation whose walk is
    bounded 10 % wider is told apart on the navigation error and on the pointing error."""
    bench = Path(__file__).resolve().parents[1] / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        import basilisk_mission as m
    finally:
        sys.path.remove(str(bench))
    with np.load(m.NOISY_FIXTURE) as z:
        fx = {k: z[k] for k in z.files}
    np.testing.assert_array_equal(fx["nav"], [m.NAV_ATTITUDE, m.NAV_ATTITUDE_BOUND, m.NAV_RATE, m.NAV_RATE_BOUND,
                                              m.SETTLE, m.EVERY, m.H, m.DURATION])
    assert len(fx["pointing_mean"]) == 50 and np.all(fx["samples"] == fx["samples"][0])
    mine = m.lgvi_noisy(50)
    # Basilisk's recorder also holds the state at the stop time; lgvi's records end one record before
    # its last state: 4670 samples against 4671, the same times otherwise
    assert np.all(mine["samples"] == fx["samples"] - 1)
    from scipy import stats

    for key in ("pointing_mean", "pointing_p95", "nav_mean"):
        (lo_a, hi_a), (lo_b, hi_b) = (stats.t.interval(0.95, len(x) - 1, x.mean(), stats.sem(x))
                                      for x in (mine[key], fx[key]))
        assert lo_a < hi_b and lo_b < hi_a, (key, (lo_a, hi_a), (lo_b, hi_b))
        d, half, _, _ = m.compare(mine[key], fx[key])
        assert abs(d) < half, (key, d, half)
    wider = m.lgvi_noisy(50, attitude_bound=1.1 * m.NAV_ATTITUDE_BOUND)
    for key in ("nav_mean", "pointing_mean"):
        d, half, _, _ = m.compare(wider[key], fx[key])
        assert d > half, (key, d, half)
