"""lgvi.plot: every function returns a labelled Figure; files are real images of the promised size."""

from __future__ import annotations

import struct
import sys

import numpy as np
import pytest

import lgvi

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

from lgvi import plot  # noqa: E402


@pytest.fixture(scope="module")
def traj() -> lgvi.Trajectory:
    # the Dzhanibekov demo, short: one flip happens near t = 14 s
    return lgvi.simulate(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), omega0=[1e-3, 1.0, 1e-3], h=0.01, steps=2000)


@pytest.fixture(scope="module")
def rk(traj) -> lgvi.Trajectory:
    from lgvi.verification.baselines import solve_ivp_baseline

    return solve_ivp_baseline([1.0, 2.0, 3.0], np.eye(3), omega0=[1e-3, 1.0, 1e-3], t_final=20.0, samples=201)


def png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    assert data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def labelled(ax) -> bool:
    return bool(ax.get_xlabel()) and bool(ax.get_ylabel())


def test_import_does_not_load_matplotlib():
    import subprocess

    code = "import lgvi, lgvi.plot, sys; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("kind", ["euler", "quaternion"])
def test_attitude(traj, kind):
    fig = plot.attitude(traj, kind=kind)
    assert isinstance(fig, Figure)
    (ax,) = fig.axes
    assert labelled(ax) and "(s)" in ax.get_xlabel()
    assert ("rad" in ax.get_ylabel()) if kind == "euler" else ("quaternion" in ax.get_ylabel())
    assert ax.get_title() and ax.get_legend() is not None
    n_lines = 3 if kind == "euler" else 4
    assert len(ax.get_lines()) == n_lines


def test_attitude_unwraps(traj):
    fig = plot.attitude(traj, kind="euler")
    for line in fig.axes[0].get_lines():
        y = line.get_ydata()
        assert np.nanmax(np.abs(np.diff(y))) < np.pi  # no 2 pi jumps left (NaN: breaks at gimbal lock)


def test_attitude_rejects_bad_kind(traj):
    with pytest.raises(ValueError, match="kind"):
        plot.attitude(traj, kind="dcm")
    with pytest.raises(ValueError, match="sequence"):
        plot.attitude(traj, sequence="ZY")


def test_attitude_into_given_axes(traj):
    fig = Figure()
    ax = fig.add_subplot()
    assert plot.attitude(traj, ax=ax) is fig


def test_rates(traj):
    fig = plot.rates(traj)
    ax_w, ax_p = fig.axes
    assert "rad/s" in ax_w.get_ylabel() and "kg m" in ax_p.get_ylabel()
    assert "(s)" in ax_p.get_xlabel()
    assert len(ax_w.get_lines()) == 3 and len(ax_p.get_lines()) == 3
    np.testing.assert_allclose(ax_p.get_lines()[1].get_ydata(), traj.Pi[:, 1])


def test_conservation(traj):
    fig = plot.conservation(traj)
    (ax,) = fig.axes
    assert ax.get_yscale() == "log" and labelled(ax)
    lines = ax.get_lines()
    assert len(lines) == 4
    for line in lines:  # zeros are floored, so every value can be drawn on the log axis
        y = np.asarray(line.get_ydata())
        assert np.all(y >= plot.ERROR_FLOOR) and np.all(y < 1e-12)


def test_conservation_extra_and_invariants(traj):
    extra = {"something": np.zeros(len(traj))}
    fig = plot.conservation(traj, extra=extra, invariants=("energy",))
    lines = fig.axes[0].get_lines()
    assert len(lines) == 5
    assert [line.get_linestyle() for line in lines[:3]] == ["-", "--", "--"]
    with pytest.raises(ValueError, match="shape"):
        plot.conservation(traj, extra={"bad": np.zeros(3)})
    with pytest.raises(ValueError, match="invariants"):
        plot.conservation(traj, invariants=("angular",))


def test_iterations(traj):
    fig = plot.iterations(traj)
    ax_i, ax_r = fig.axes
    assert ax_i.get_ylabel() and labelled(ax_r) and ax_r.get_yscale() == "log"  # shared time axis
    np.testing.assert_array_equal(ax_i.get_lines()[0].get_ydata(), traj.iterations)


def test_iterations_binned_for_long_runs(traj):
    fig = plot.iterations(traj, max_points=100)
    mean_line = fig.axes[0].get_lines()[0]
    assert len(mean_line.get_ydata()) <= 100


def test_iterations_needs_a_solver_record(rk):
    with pytest.raises(ValueError, match="solver record"):
        plot.iterations(rk)


def test_polhode(traj):
    fig = plot.polhode(traj)
    (ax,) = fig.axes
    assert ax.name == "3d"
    assert "kg m" in ax.get_xlabel() and "kg m" in ax.get_ylabel() and "kg m" in ax.get_zlabel()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("path" in s for s in labels) and any("polhode" in s for s in labels)


def test_polhode_curves_lie_on_sphere_and_ellipsoid():
    moments = np.array([1.0, 2.0, 3.0])
    L = 2.0
    energies = [0.7, 0.9, 1.0, 1.2, 1.8]  # between L^2/6 and L^2/2, separatrix at 1.0
    curves = plot.polhode_curves(moments, L, energies)
    assert len(curves) == 2 * len(energies)
    for k, curve in enumerate(curves):
        E = energies[k // 2]
        np.testing.assert_allclose(np.linalg.norm(curve, axis=1), L, rtol=1e-12)
        np.testing.assert_allclose(0.5 * np.sum(curve**2 / moments, axis=1), E, rtol=1e-12)


def test_polhode_rejects_2d_axes(traj):
    fig = Figure()
    with pytest.raises(ValueError, match="3D"):
        plot.polhode(traj, ax=fig.add_subplot())


def test_comparison(traj, rk):
    fig = plot.comparison({"lgvi": traj, "RK45": rk})
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 4
    for ax in axes:
        assert ax.get_yscale() == "log" and labelled(ax) and len(ax.get_lines()) == 2
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["lgvi", "RK45"]   # below the panels
    fig = plot.comparison({"lgvi": traj}, extra={"zero": lambda tr: np.zeros(len(tr))})
    assert len([ax for ax in fig.axes if ax.get_visible()]) == 5


def test_wrong_input():
    with pytest.raises(TypeError, match="Trajectory"):
        plot.rates(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="non-empty"):
        plot.comparison({})


def test_save_figures(traj, tmp_path):
    files = plot.save_figures(traj, tmp_path / "figs", prefix="demo_")
    assert [f.name for f in files] == [f"demo_{n}.png" for n in plot.FIGURE_NAMES]
    for f in files:
        name = f.stem.removeprefix("demo_")
        assert png_size(f) == plot.FIGURE_PIXELS[name], f.name
        image = matplotlib.image.imread(f)
        assert image.std() > 0.05  # not blank


def test_save_figures_of_a_baseline_skips_iterations(rk, tmp_path):
    files = plot.save_figures(rk, tmp_path)
    assert "iterations.png" not in {f.name for f in files} and len(files) == len(plot.FIGURE_NAMES) - 1


def test_rk4_baseline_has_no_solver_record(tmp_path):
    from lgvi.verification.baselines import rk4

    tr = rk4([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=100)
    assert not plot.has_solver_record(tr)
    with pytest.raises(ValueError, match="solver record"):
        plot.iterations(tr)
    assert "iterations.png" not in {f.name for f in plot.save_figures(tr, tmp_path)}


def test_save_comparison(traj, rk, tmp_path):
    (f,) = plot.save_comparison({"lgvi": traj, "RK45": rk}, tmp_path)
    assert f.name == "comparison.png" and png_size(f) == plot.FIGURE_PIXELS["comparison"]


def test_forced_run_figures(tmp_path):
    torques = pytest.importorskip("lgvi.torques", reason="lgvi.torques not available")
    body = lgvi.RigidBody([0.13, 0.28, 0.17])
    tr = lgvi.simulate(body, np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=200,
                       torque=torques.UniformGravity(1.0, [0.0, 0.0, 0.3]))
    fig = plot.conservation(tr)
    styles = [line.get_linestyle() for line in fig.axes[0].get_lines()]
    # energy, |Pi| and R Pi (not invariants under gravity), e3 . R Pi (exact), |R^T R - I|
    assert styles == ["-", "--", "--", "-", "-"]
    # a forced run has no polhode figure (the free-body polhodes do not describe it)
    assert [p.stem for p in plot.save_figures(tr, tmp_path)] == [n for n in plot.FIGURE_NAMES if n != "polhode"]


def test_animate_gif(traj, tmp_path):
    from PIL import Image

    path = plot.animate(traj, tmp_path / "spin.gif", fps=10, max_frames=4)
    assert path == tmp_path / "spin.gif" and path.exists()
    with Image.open(path) as im:
        assert im.format == "GIF" and im.n_frames == 4


def test_animate_errors(traj, tmp_path):
    with pytest.raises(ValueError, match=r"\.gif or \.mp4"):
        plot.animate(traj, tmp_path / "spin.avi")
    with pytest.raises(ValueError, match="max_frames"):
        plot.animate(traj, tmp_path / "spin.gif", max_frames=0)
    from matplotlib import animation

    if not animation.writers.is_available("ffmpeg"):
        with pytest.raises(RuntimeError, match="ffmpeg"):
            plot.animate(traj, tmp_path / "spin.mp4", max_frames=2)


def test_thinning_keeps_extremes():
    t = np.linspace(0.0, 1.0, 100_001)
    y = np.sin(2 * np.pi * 500 * t)
    y[12_345] = 7.0
    tt, yy = plot._thin_minmax(t, y, 1000)
    assert len(tt) <= 1002 and yy.max() == 7.0 and yy.min() == pytest.approx(-1.0, abs=1e-3)
    assert np.all(np.diff(tt) > 0)
    tt, yy = plot._thin_max(t, np.abs(y), 1000)
    assert yy.max() == 7.0 and tt[-1] == t[-1]


# ------------------------------------------------------------------------------------ misleading figures
def y_spin(save_every: int) -> lgvi.Trajectory:
    """The demo: a spin about body y (the intermediate axis, slightly off, so it flips now and
    then), 1000 s at 1 rad/s: ZYX Euler angles pass near gimbal lock twice per turn."""
    return lgvi.simulate(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), omega0=[1e-3, 1.0, 1e-3], h=0.01,
                         steps=100_000, save_every=save_every)


def test_euler_angles_are_not_unwrapped_across_gimbal_lock():
    """Unwrapping across the jumps at gimbal lock made the angle about Z climb in a staircase to
    about 190 rad over 160 turns. Broken there instead, it stays within one turn; angle 3 still
    winds between two passages near the lock (a genuine turn about X'', up to 16 rad measured),
    but never over the whole run."""
    fig = plot.attitude(y_spin(10), kind="euler")
    peaks = [np.nanmax(np.abs(np.asarray(line.get_ydata(), dtype=float))) for line in fig.axes[0].get_lines()]
    assert peaks[0] <= 2 * np.pi and max(peaks) < 6 * np.pi, peaks
    text = " ".join(t.get_text() for t in fig.axes[0].texts)
    assert "too sparse" not in text  # 0.1 rad between samples is fine


def test_sparse_samples_are_said_on_both_attitude_panels(tmp_path):
    """200 steps of 0.01 s between samples turn the body by 2 rad (over a quarter turn)."""
    sparse = y_spin(200)
    assert "too sparse" in (plot.sampling_note(sparse) or "")
    fig = plot._attitude_panels(sparse)
    for ax in fig.axes[:2]:
        assert any("too sparse" in t.get_text() for t in ax.texts), ax.get_title()


def test_polhode_draws_the_branch_the_run_follows(traj):
    """One dashed analytic curve, the one along the run's path (the other branch of the same
    energy is the mirror image, far from it); the separatrix is drawn after (above) the path."""
    fig = plot.polhode(traj)
    (ax,) = fig.axes
    dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    assert len(dashed) == 1
    curve = np.column_stack(dashed[0].get_data_3d())
    Pi = np.asarray(traj.Pi)[::10]
    gap = np.linalg.norm(Pi[:, None, :] - curve[None, :, :], axis=2).min(axis=1)
    assert gap.max() < 0.06 * np.linalg.norm(Pi[0])
    lines = ax.get_lines()
    path = next(i for i, ln in enumerate(lines) if "path" in ln.get_label())
    sep = next(i for i, ln in enumerate(lines) if "separatrix" in ln.get_label())
    assert ax.computed_zorder is False and sep > path


def test_forced_run_has_no_free_body_polhodes():
    torques = pytest.importorskip("lgvi.torques", reason="lgvi.torques not available")
    tr = lgvi.simulate(lgvi.RigidBody([0.13, 0.28, 0.17]), np.eye(3), omega0=[4.14, 4.14, 4.14], h=0.01, steps=200,
                       torque=torques.UniformGravity(1.0, [0.0, 0.0, 0.3]))
    (ax,) = plot.polhode(tr).axes
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert not any("polhode" in s or "separatrix" in s for s in labels), labels
    assert not [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    assert "not drawn" in ax.get_title()


def test_gravity_gradient_figures_show_the_jacobi_integral(monkeypatch):
    import matplotlib.figure

    for cls in matplotlib.figure.Figure.__mro__:          # as on matplotlib 3.7, which has no get_suptitle
        if "get_suptitle" in vars(cls):
            monkeypatch.delattr(cls, "get_suptitle")
    torques = pytest.importorskip("lgvi.torques", reason="lgvi.torques not available")
    from lgvi.verification.baselines import rk4

    gg = torques.GravityGradient(mu=1.0, radius=1.0)
    kw = dict(omega0=[0.4, 1.3, -0.6], h=0.02, steps=2000, torque=gg, save_every=10)
    tr = lgvi.simulate(lgvi.RigidBody([2.0, 3.0, 1.5]), np.eye(3), **kw)
    (ax,) = plot.conservation(tr).axes
    labels = {ln.get_label(): ln.get_linestyle() for ln in ax.get_lines()}
    (jacobi,) = [k for k in labels if k.startswith("Jacobi integral")]
    assert "bounded" in jacobi and labels[jacobi] == "-"
    (energy,) = [k for k in labels if "energy" in k]
    assert "not an invariant" in energy and labels[energy] == "--"
    rk = rk4(lgvi.RigidBody([2.0, 3.0, 1.5]), np.eye(3), **kw)
    fig = plot.comparison({"lgvi": tr, "RK4": rk})
    titles = [ax.get_title() for ax in fig.axes if ax.get_visible()]
    assert len(titles) == 2 and "Jacobi" in titles[0] and "SO(3)" in titles[1]
    # the suptitle through fig.texts: Figure.get_suptitle is absent from matplotlib 3.7, the floor
    # (the monkeypatch above removes it, as 3.7 has it)
    suptitle = " ".join(t.get_text() for t in fig.texts)
    assert "not shown" in suptitle and "energy" in suptitle


def test_long_lines_are_drawn_without_gaps(tmp_path):
    # Figures are saved with long lines cut into pieces of plot.AGG_CHUNK vertices (to bound
    # Agg's memory); matplotlib's own cutting (agg.path.chunksize) drops the vertex at each cut
    # and leaves a visible gap. A zigzag of 3 * AGG_CHUNK vertices, looked at around the first
    # cut: every pixel column of the axes must hold some of the line.
    import matplotlib.image

    n = 3 * plot.AGG_CHUNK
    fig = Figure(figsize=(4, 3))
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    x = np.arange(n, dtype=float)
    y = x % 2
    x[-1], y[-1] = 0.0, 10.0   # not sorted in x, so Line2D hands Agg the whole path, not the visible part
    line, = ax.plot(x, y, color="k", lw=1, label="zigzag")
    ax.set_xlim(plot.AGG_CHUNK - 11, plot.AGG_CHUNK + 9)
    ax.set_ylim(-0.1, 1.1)
    png = plot._save(fig, tmp_path / "zigzag.png")
    img = matplotlib.image.imread(png)[..., :3].mean(axis=2)
    dark = (img < 0.5).any(axis=0)
    assert dark[2:-2].all(), f"{int((~dark[2:-2]).sum())} empty pixel columns"
    assert len(line.get_xdata()) == n and ax.get_lines() == [line]    # the figure is put back
