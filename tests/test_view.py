"""The interactive page (lgvi.view, ``lgvi view``, ``lgvi run``'s report.html) without a browser.

What a browser does with the page is tests/test_view_browser.py; here: the page is self-contained
(plotly.js embedded from the installed package, nothing fetched), its frames turn the body as
the trajectory does, long runs are decimated with a note, the declared invariants and the
optional wheel fields are drawn, text read from a file cannot inject markup, and Jupyter's
display embeds plotly.js once per process.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass

import numpy as np
import pytest

import lgvi
from lgvi.cli import main

pytest.importorskip("plotly")
from lgvi import view  # noqa: E402


@pytest.fixture(scope="module")
def traj():
    return lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[1e-3, 1.0, 1e-3], h=0.01, steps=3000)


def _figure_json(page: str, div_id: str = "lgvi-view") -> dict:
    m = re.search(r"var fig = (\{.*?\});\n  Plotly\.newPlot", page, re.S)
    assert m is not None, "no figure in the page"
    return json.loads(m.group(1).replace("<\\/", "</"))


def _decode(a) -> np.ndarray:
    """A plotly JSON array: a list, or ``{"dtype", "bdata"}`` (base64 typed array, plotly >= 6)."""
    if isinstance(a, dict):
        import base64

        return np.frombuffer(base64.b64decode(a["bdata"]), dtype=a["dtype"])
    return np.asarray(a, dtype=np.float64)


def test_page_is_self_contained(traj, tmp_path):
    from plotly.offline import get_plotlyjs

    path = view.write_html(traj, tmp_path / "page.html")
    page = path.read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>")
    js = get_plotlyjs()
    assert js in page                                          # the installed package's bundle, inline
    rest = page.replace(js, "")
    assert not re.search(r"<script[^>]+src=", rest)            # no script fetched from anywhere
    assert "<link" not in rest and "http://" not in rest and "https://" not in rest


def test_frames_turn_the_body_as_the_trajectory(traj):
    fig = view.figure(traj, max_frames=50)
    frames = fig.frames
    assert len(frames) == 50 and len(fig.layout.sliders[0].steps) == 50
    k = np.unique(np.linspace(0, len(traj.t) - 1, 50).round().astype(int))
    # the body x axis drawn in frame j is R_k e1 (scaled): its direction equals the trajectory's
    for j in (0, 17, 49):
        line = frames[j].data[1]
        tip = np.array([line.x[1], line.y[1], line.z[1]])
        assert np.allclose(tip / np.linalg.norm(tip), traj.R[k[j]][:, 0], atol=1e-4)
    # the momentum arrow is R Pi (scaled): constant for the free body
    arrows = np.array([[f.data[4].x[1], f.data[4].y[1], f.data[4].z[1]] for f in frames])
    assert np.ptp(arrows, axis=0).max() < 1e-4
    # the slider shows the frame times; the cursor of the linked plots moves with them
    assert [s.args[0][0] for s in fig.layout.sliders[0].steps] == [f.name for f in frames]
    assert frames[17].layout.shapes[0].x0 == pytest.approx(traj.t[k[17]])


def test_long_run_is_decimated_with_a_note(traj):
    short = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[1e-3, 1.0, 1e-3], h=0.01, steps=2 * view.RATE_BINS - 1)
    assert view.decimation_note(short, max_frames=5000, max_points=5000) is None
    # 3001 samples, more than twice RATE_BINS: only the rates are binned, and the note says so
    note = view.decimation_note(traj, max_frames=5000, max_points=5000)
    assert f"the body rates in {view.RATE_BINS} bins" in note and "animation" not in note
    note = view.decimation_note(traj, max_frames=100, max_points=500)
    assert "3,001 saved samples" in note and "100" in note and "the body rates in 166 bins" in note
    page = view.html(traj, include_plotlyjs=False, max_frames=100, max_points=500)
    assert note in page.replace("&#x27;", "'")
    fig = _figure_json(page)
    band = [d for d in fig["data"] if d.get("name") == "ωy range"][0]
    mid = _decode([d for d in fig["data"] if d.get("name") == "ωy"][0]["y"])
    y = _decode(band["y"])
    assert band["fill"] == "toself" and len(y) + len(mid) <= 500 and len(y) == 2 * len(mid) == 2 * 166
    # the band keeps the extremes, and the line is the middle of each bin's range
    assert y.min() == pytest.approx(traj.omega[:, 1].min(), abs=1e-6)
    assert y.max() == pytest.approx(traj.omega[:, 1].max(), abs=1e-6)
    hi, lo = y[:len(mid)], y[len(mid):][::-1]
    assert np.allclose(mid, 0.5 * (lo + hi), rtol=0, atol=1e-6) and np.any(lo < hi)


def test_declared_invariants_are_drawn():
    free = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=50)
    names = [d.name for d in view.figure(free).data if d.type == "scatter"]
    drawn = [n for n in names if n.endswith("(exact)") or n.endswith("(bounded)")]
    assert len(drawn) == len(lgvi.invariants.declared(free).quantities()) >= 3
    damped = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=50,
                           torque=lgvi.torques.LinearDamping(0.1))
    fig = view.figure(damped)
    assert not any("exact" in (d.name or "") or "bounded" in (d.name or "") for d in fig.data)
    assert any("has no invariants" in a.text for a in fig.layout.annotations)


@dataclass(frozen=True, eq=False)
class _WheelTrajectory(lgvi.Trajectory):
    """A trajectory with the fields of a gyrostat's result (lgvi's wheels add them)."""

    wheel_speed: np.ndarray | None = None
    wheel_axes: np.ndarray | None = None
    control_error: np.ndarray | None = None


def test_wheels_and_control_error_by_attribute(traj):
    m = len(traj.t)
    speed = np.column_stack([np.linspace(0, 50, m), np.linspace(0, -20, m), np.full(m, 10.0)])
    wt = _WheelTrajectory(t=traj.t, R=traj.R, Pi=traj.Pi, inertia=traj.inertia, iterations=traj.iterations,
                          residual=traj.residual, h=traj.h, meta=traj.meta, wheel_speed=speed,
                          wheel_axes=np.eye(3), control_error=np.linspace(1, 0, m))
    fig = view.figure(wt, max_frames=20)
    names = [d.name for d in fig.data]
    assert [n for n in names if n and n.startswith("wheel")] == ["wheel 1", "wheel 2", "wheel 3"] * 2
    assert "control error" in names
    # the spoke of wheel 3 (10 rad/s relative to the body) turns between frames, in the body frame
    w3 = [5 + 2]
    k = np.unique(np.linspace(0, m - 1, 20).round().astype(int))
    spoke = []
    for j in (3, 4):
        d = fig.frames[j].data[w3[0]]
        tip = np.array([d.x[-1], d.y[-1], d.z[-1]])
        spoke.append(traj.R[k[j]].T @ tip)
    assert np.linalg.norm(spoke[0] - spoke[1]) > 0.01
    # without wheels the panels are only rates and invariants
    plain = view.figure(traj, max_frames=20)
    assert not any((d.name or "").startswith("wheel") for d in plain.data)


def test_text_from_the_file_cannot_inject_markup(traj, tmp_path):
    hostile = "</script><script>alert(1)</script><img src=x onerror=alert(2)>"
    bad = lgvi.Trajectory(t=traj.t[:20], R=traj.R[:20], Pi=traj.Pi[:20], inertia=traj.inertia,
                          iterations=traj.iterations[:19], residual=traj.residual[:19], h=traj.h,
                          meta={"method": hostile, "scenario": hostile, "torque": "none"})
    page = view.html(bad, include_plotlyjs=False, title=hostile)
    assert "<script>alert" not in page and "<img" not in page
    assert page.count("<script") == page.count("</script>") == 1


def test_bad_arguments(traj):
    with pytest.raises(TypeError, match="traj must be an lgvi.Trajectory"):
        view.figure(np.zeros(3))
    with pytest.raises(ValueError, match="max_frames must be an integer >= 2, got 1"):
        view.figure(traj, max_frames=1)
    with pytest.raises(ValueError, match="div_id"):
        view.html(traj, div_id="a b")


def test_jupyter_display_embeds_the_library_once(traj, monkeypatch):
    monkeypatch.setattr(view, "_inline_library_sent", False)
    first = traj._repr_mimebundle_()
    second = traj._repr_mimebundle_()
    assert first["text/plain"] == repr(traj)
    assert len(first["text/html"]) > 4_000_000                  # plotly.js, once
    assert len(second["text/html"]) < 600_000                   # data only, reusing window.Plotly
    assert "window.Plotly" in second["text/html"]
    ids = [re.search(r'id="(lgvi-view-[0-9a-f]+)"', b["text/html"]).group(1) for b in (first, second)]
    assert ids[0] != ids[1]                                      # two views on one page do not collide


def test_cli_view_and_run_report(traj, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("lgvi.cli._save_figures", lambda traj, outdir: [])   # the PNGs are test_cli's
    traj.save(tmp_path / "run.npz")
    assert main(["view", str(tmp_path / "run.npz")]) == 0
    assert (tmp_path / "run.html").stat().st_size > 4_000_000
    assert main(["view", str(tmp_path / "run.npz"), "-o", str(tmp_path / "v" / "p.html"), "--max-frames", "30"]) == 0
    fig = _figure_json((tmp_path / "v" / "p.html").read_text(encoding="utf-8"))
    assert len(fig["frames"]) == 30
    assert main(["view", str(tmp_path / "missing.npz")]) == 2
    assert main(["view", str(tmp_path / "run.npz"), "--max-frames", "1"]) == 2
    scenario = tmp_path / "s.toml"
    scenario.write_text('name = "tiny"\n[body]\ninertia = [1.0, 2.0, 3.0]\n[initial]\nomega = [0.3, 1.0, 0.2]\n'
                        '[integrator]\nh = 0.01\nsteps = 100\n')
    assert main(["run", str(scenario), "-o", str(tmp_path / "out")]) == 0
    report = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert "tiny" in report and "Run summary" in report
    assert "report.html" in json.loads((tmp_path / "out" / "summary.json").read_text())["files"]


# ------------------------------------------------------------------ systems that declare their page


def _chain():
    return lgvi.simulate_chain([1.0, 0.5, 0.5], [1.0, 1.0, 1.0], [[1, 0, 0], [0, 1, 0], [0, 0, -1]],
                               [[0, 1, 0], [0, 0, 2], [1, 0, 0]], h=1e-3, steps=2000, save_every=10)


def _slosh():
    return lgvi.simulate_slosh([900.0, 800.0, 600.0], 1500.0, [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]], [0.3, 0.4],
                               [40.0, 60.0], np.eye(3), [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]],
                               [[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]], omega0=[0.3, -0.2, 0.5], h=0.01, steps=600,
                               save_every=5)


def test_chain_page_draws_the_links_at_every_frame():
    chain = _chain()
    fig = view.figure(chain, max_frames=40)
    k = np.unique(np.linspace(0, len(chain.t) - 1, 40).round().astype(int))
    assert len(fig.frames) == 40 and len(fig.layout.sliders[0].steps) == 40
    x = chain.positions
    for j in (0, 13, 39):
        line = fig.frames[j].data[0]                        # the chain: the pivot, then every joint
        pts = np.stack([_decode(line.x), _decode(line.y), _decode(line.z)], axis=1)
        assert np.allclose(pts[0], 0.0) and np.allclose(pts[1:], x[k[j]], atol=1e-5)
        assert fig.frames[j].layout.shapes[0].x0 == pytest.approx(chain.t[k[j]])
    names = [tr.name for tr in fig.data]
    assert "path of the last joint" in names
    # the declared invariants, named for the chain, with the relative errors of the run
    errs = {tr.name: np.asarray(tr.y) for tr in fig.data if tr.name and tr.name.endswith(("(exact)", "(bounded)"))}
    assert set(errs) == {"energy (bounded)", "vertical angular momentum about the pivot (exact)"}
    assert errs["vertical angular momentum about the pivot (exact)"].max() < 1e-13
    rows = dict(view.summary_rows(chain))
    assert rows["steps"] == "2,000, h = 0.001 s" and "largest ||q_i| − 1|" in rows["unit length"]
    assert "exact" in rows["  vertical angular momentum about the pivot"]


def test_slosh_page_draws_the_hub_and_the_pendulums():
    sl = _slosh()
    fig = view.figure(sl, max_frames=30)
    k = np.unique(np.linspace(0, len(sl.t) - 1, 30).round().astype(int))
    names = [tr.name for tr in fig.data]
    first = names.index("pendulum 1: 40 kg, 0.3 m")
    for j in (0, 29):
        R = sl.R[k[j]]
        for i in range(2):
            seg = fig.frames[j].data[first + i]
            pts = np.stack([_decode(seg.x), _decode(seg.y), _decode(seg.z)], axis=1)
            pivot = R @ sl.pivots[i]
            assert np.allclose(pts, [pivot, pivot + sl.lengths[i] * sl.q[k[j], i]], atol=1e-5)
        box = fig.frames[j].data[0]                         # the hub's box turns with R
        corners = np.stack([_decode(box.x), _decode(box.y), _decode(box.z)], axis=1)
        assert np.allclose(corners.mean(axis=0), 0.0, atol=1e-5)
        assert np.allclose(np.linalg.norm(corners, axis=1), np.linalg.norm(corners[0]), atol=1e-4)
    # the total angular momentum arrow is fixed in space (exact to round-off)
    arrow = names.index("total angular momentum (scaled)")
    tips = np.array([[_decode(f.data[arrow].x)[1], _decode(f.data[arrow].y)[1], _decode(f.data[arrow].z)[1]]
                     for f in fig.frames])
    assert np.ptp(tips, axis=0).max() < 1e-4
    rows = dict(view.summary_rows(sl))
    assert "exact" in rows["  total angular momentum R Π + Σ π_i"] and "bounded" in rows["  kinetic energy"]


def test_cli_view_of_a_chain_and_what_has_no_page(tmp_path, capsys):
    _chain().save(tmp_path / "chain.npz")
    assert main(["view", str(tmp_path / "chain.npz"), "--max-frames", "20"]) == 0
    fig = _figure_json((tmp_path / "chain.html").read_text(encoding="utf-8"))
    assert len(fig["frames"]) == 20
    orbit = lgvi.simulate_orbit([1.0, 2.0, 3.0], 10.0, [7000.0, 0.0, 0.0], [0.0, 7.546, 0.0], np.eye(3),
                                omega0=[0.0, 0.0, 1e-3], h=10.0, steps=20, mu=398600.4418)
    orbit.save(tmp_path / "orbit.npz")
    capsys.readouterr()
    assert main(["view", str(tmp_path / "orbit.npz")]) == 2
    assert "a result of chain, slosh" in capsys.readouterr().err
    with pytest.raises(TypeError, match=r"traj must be an lgvi.Trajectory or the result of a system with a page "
                                        r"\(chain, slosh\), got OrbitTrajectory"):
        view.figure(orbit)

@pytest.fixture(scope="module")
def orbit_run():
    from view_cases import orbit_run

    return orbit_run()


def test_loop_run_shows_the_orbit_the_sun_and_the_named_modes(orbit_run):
    """A run of the compiled loop that recorded r_N, sun_N, mode and shadow: a second 3D view with
    the Earth and the orbit's track (one trace per mode, by the names the ModeRules gave), the
    spacecraft and the sun's direction moved by every frame to the record in force at its time,
    the sun's direction beside the body too, and a time strip of the named modes and the eclipses."""
    tr = orbit_run
    sig, ts = tr.signals, tr.signal_t
    fig = view.figure(tr, max_frames=40)
    assert fig.layout.scene2.domain.y[1] < fig.layout.scene.domain.y[0]          # the orbit below the body
    names = [d.name for d in fig.data]
    assert {"orbit in coast", "orbit in nadir", "the spacecraft", "the Earth"} <= set(names)
    # the track of each mode: points of the orbit (Earth radii), the first at the mode's first record
    r = sig["r_N"] / view.EARTH_RADIUS
    first_nadir = int(np.argmax(sig["mode"] == 1))
    track = fig.data[names.index("orbit in nadir")]
    pts = np.array([[a, b, c] for a, b, c in zip(track.x, track.y, track.z) if a is not None])
    assert np.allclose(np.linalg.norm(pts, axis=1), 6878137.0 / 6378137.0, atol=1e-4)
    assert np.allclose(pts[0], r[first_nadir], atol=1e-5)
    # each frame moves the spacecraft to r_N and both sun arrows along sun_N at its time
    k = np.unique(np.linspace(0, len(tr.t) - 1, 40).round().astype(int))
    craft = names.index("the spacecraft")
    suns = [i for i, n in enumerate(names) if n == "direction of the sun"]
    assert len(suns) == 2 and suns[0] < craft < suns[1]
    for j in (0, 17, 39):
        frame = fig.frames[j]
        data = dict(zip(frame.traces, frame.data))
        at = int(np.searchsorted(ts, tr.t[k[j]], side="right") - 1)
        assert np.allclose([data[craft].x[0], data[craft].y[0], data[craft].z[0]], r[at], atol=1e-5)
        for i in suns:
            tip = np.array([data[i].x[-1], data[i].y[-1], data[i].z[-1]])
            assert np.allclose(tip / np.linalg.norm(tip), sig["sun_N"][at] / np.linalg.norm(sig["sun_N"][at]),
                               atol=1e-4)
    # the strip: a band per mode, named, and the eclipses where the shadow hides the sun
    texts = [a.text for a in fig.layout.annotations]
    assert "coast" in texts and "nadir" in texts
    assert any("coast (0)" in t and "nadir (1)" in t and "eclipse" in t for t in texts)
    band = fig.data[[i for i, d in enumerate(fig.data) if d.name == "nadir" and d.type == "scatter"][0]]
    assert band.x[0] == pytest.approx(ts[first_nadir]) and band.x[1] == pytest.approx(ts[-1] + ts[1] - ts[0])
    dark = fig.data[names.index("eclipse")]
    starts = [x for x, y, y0 in zip(dark.x[:-1:6], dark.y[:-1:6], dark.y[2::6]) if x is not None]
    shadow = sig["shadow"].ravel() < 0.5
    assert shadow.any() and not shadow.all()
    assert starts[0] == pytest.approx(ts[int(np.argmax(shadow))])
    # the summary names the modes with their times
    rows = dict(view.summary_rows(tr))
    assert rows["modes"] == f"coast (0) from 0 s, nadir (1) from {ts[first_nadir]:g} s"


def test_the_body_axis_path_of_a_run_longer_than_an_orbit_is_its_last_orbit(orbit_run, traj):
    """The path of the traced axis's tip over three orbits of tumbling then pointing was a tangle
    that hid the body: a loop run whose records span more than one orbit draws it over the last
    orbit (its period from the angle the recorded position swept), and says so; a run of less than
    an orbit, or with no orbit, keeps the whole path."""
    tr = orbit_run
    period = 2 * np.pi * np.sqrt(6878137.0 ** 3 / 3.986004418e14)           # the circular orbit's
    assert tr.t[-1] > period
    k0 = int(np.searchsorted(tr.t, tr.t[-1] - period))
    fig = view.figure(tr, max_frames=20)
    path = [d for d in fig.data if d.name.startswith("path of the")]
    assert len(path) == 1 and path[0].name.endswith(f", the last orbit (from t = {tr.t[k0]:.6g} s)")
    moments, V, _ = view._principal(tr.inertia)
    axis = V[:, view.traced_axis(moments)]
    first = np.array([path[0].x[0], path[0].y[0], path[0].z[0]])
    assert np.allclose(first / np.linalg.norm(first), tr.R[k0] @ axis, atol=1e-4)
    assert len(path[0].x) == len(tr.t) - k0
    short = tr[: len(tr.t) // 2]                                             # half an orbit: all of it
    whole = [d for d in view.figure(short, max_frames=5).data if d.name.startswith("path of the")]
    assert whole[0].name == path[0].name.split(",")[0] and len(whole[0].x) == len(short.t)
    assert [d.name for d in view.figure(traj, max_frames=5).data if d.name.startswith("path of the")] == \
        ["path of the body y tip"]


def test_loop_run_without_an_orbit_keeps_one_scene():
    """A loop run that recorded no orbit: the body alone on the left, the modes (unnamed) on the strip."""
    from lgvi.fsw import FlightSoftware, InertialPointing, ModeRules, MRPControl, RWMotorTorque
    from lgvi.spacecraft import Spacecraft

    axes = np.eye(3)
    sat = Spacecraft([0.15, 0.12, 0.05], wheels=lgvi.ReactionWheels(axes, 2e-5, max_torque=2e-3))
    fsw = FlightSoftware(guidance=InertialPointing(modes=[1]), control=MRPControl(K=0.004, P=0.04, modes=[1]),
                         actuators=RWMotorTorque(modes=[1]), modes=ModeRules([(0, 1, "time_after", 20.0)]), rate=1.0)
    tr = lgvi.simulate(sat, np.eye(3), omega0=[0.0, 0.01, 0.0], h=0.5, steps=200, fsw=fsw, save_every=4)
    fig = view.figure(tr, max_frames=10)
    assert "scene2" not in fig.layout.to_plotly_json() and "the spacecraft" not in [d.name for d in fig.data]
    assert fig.layout.scene.domain.y == (0.0, 1.0)
    key = [a.text for a in fig.layout.annotations if "mode 0 (0)" in a.text]
    assert len(key) == 1 and "mode 1 (1)" in key[0] and "eclipse" not in key[0]
