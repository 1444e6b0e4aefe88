"""Conventions a SciPy or xarray user expects: ``duration=`` beside ``steps``, slicing of results,
``traj.at(t)`` (slerp for the attitude), ``to_xarray()`` and ``to_dataframe()``, the library speaking
through a logger; the figures' conventions of issue 31 (running maxima, no gimbal lock).

Elsewhere: progress only where a person watches (``tests/test_libraries.py``: ``interactive()`` is a
terminal or Jupyter, nothing drawn otherwise), the compile line on stderr (``tests/test_package.py``),
the "coming from Basilisk" page (``docs/basilisk.md``, its blocks run in ``tests/test_docs.py``;
``R = dcm_BN^T`` against Basilisk's own output in ``tests/test_environment_components.py``)."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi import so3

BODY = lgvi.RigidBody([1.0, 2.0, 3.0])
KW = dict(omega0=[0.3, 1.0, 0.2], h=0.01)


@pytest.fixture(scope="module")
def traj():
    return lgvi.simulate(BODY, np.eye(3), steps=200, **KW)


# ------------------------------------------------------------------------------ duration=
def test_duration_is_steps_times_h():
    a = lgvi.simulate(BODY, np.eye(3), duration=0.5, **KW)
    b = lgvi.simulate(BODY, np.eye(3), steps=50, **KW)
    assert np.array_equal(a.R, b.R) and np.array_equal(a.t, b.t) and a.steps == 50
    back = lgvi.simulate(BODY, np.eye(3), omega0=KW["omega0"], h=-0.01, duration=-0.5)
    assert back.steps == 50 and back.t[-1] == pytest.approx(-0.5)
    assert lgvi.simulate(BODY, np.eye(3), duration=0.0, **KW).steps == 0


@pytest.mark.parametrize("kw, exc, match", [
    (dict(), TypeError, "exactly one of steps= .*integer.* and duration="),
    (dict(steps=10, duration=0.1), TypeError, "exactly one of steps="),
    (dict(duration=0.333), ValueError, r"duration=0.333 must be a whole, non-negative number of steps h=0.01"),
    (dict(duration=-1.0), ValueError, "non-negative"),
    (dict(duration="1"), TypeError, "duration"),
    (dict(duration=float("nan")), ValueError, "duration"),
])
def test_duration_refusals_name_the_rule(kw, exc, match):
    with pytest.raises(exc, match=match):
        lgvi.simulate(BODY, np.eye(3), **KW, **kw)


# ------------------------------------------------------------------------------ slicing
def test_slice_keeps_every_kth_sample_and_reduces_the_record(traj):
    s = traj[::10]
    assert type(s) is type(traj) and len(s) == 21
    for name in ("t", "R", "Pi"):
        assert np.array_equal(getattr(s, name), getattr(traj, name)[::10])
    # the record of each new interval is the largest of the ten it covers
    assert np.array_equal(s.iterations, traj.iterations.reshape(20, 10).max(axis=1))
    assert np.array_equal(s.residual, traj.residual.reshape(20, 10).max(axis=1))
    assert s.steps == traj.steps == 200 and s.solver_summary["iterations_total"] == traj.solver_summary[
        "iterations_total"]
    assert np.array_equal(s.energy, traj.energy[::10])
    part = traj[50:101:25]
    assert np.array_equal(part.t, traj.t[50:101:25])
    assert np.array_equal(part.iterations, [traj.iterations[50:75].max(), traj.iterations[75:100].max()])


def test_slice_of_a_sparse_run_is_its_own_sparse_run():
    full = lgvi.simulate(BODY, np.eye(3), steps=200, **KW)
    sparse = lgvi.simulate(BODY, np.eye(3), steps=200, save_every=10, **KW)
    assert np.array_equal(full[::10].R, sparse.R)
    assert np.array_equal(full[::10].iterations, sparse.iterations)


def test_slice_refusals(traj):
    with pytest.raises(TypeError, match=r"traj.R\[k\]"):
        traj[3]
    with pytest.raises(ValueError, match="step forward"):
        traj[::-1]


def test_slice_of_a_gyrostat_run_slices_the_wheels_not_their_axes():
    wheels = lgvi.ReactionWheels(np.eye(3), [0.01, 0.01, 0.01], speed0=[10.0, 0.0, -5.0])
    run = lgvi.simulate(BODY, np.eye(3), omega0=[0.1, 0.0, 0.0], h=0.1, steps=30, wheels=wheels)
    s = run[::3]
    assert np.array_equal(s.wheel_momentum, run.wheel_momentum[::3])
    assert np.array_equal(s.wheel_axes, run.wheel_axes)
    assert np.array_equal(s.omega, run.omega[::3])


# ------------------------------------------------------------------------------ at(t)
def test_at_the_sample_times_gives_the_samples_bit_for_bit(traj):
    got = traj.at(traj.t[::7])
    assert np.array_equal(got.R, traj.R[::7]) and np.array_equal(got.Pi, traj.Pi[::7])
    assert got.steps == traj.steps and len(got.iterations) == 0


def test_at_interpolates_along_the_geodesic(traj):
    coarse = traj[::4]                       # samples 0.04 s apart
    mid = coarse.at(traj.t[2:-2:4])          # halfway between them, where traj has samples
    R = mid.R
    # on SO(3) to round-off, and equidistant from both neighbours (the geodesic's midpoint)
    assert np.abs(np.einsum("mki,mkj->mij", R, R) - np.eye(3)).max() < 1e-14
    d_left = np.linalg.norm(so3.log(np.einsum("mji,mjk->mik", coarse.R[:-1], R)), axis=1)
    d_right = np.linalg.norm(so3.log(np.einsum("mji,mjk->mik", R, coarse.R[1:])), axis=1)
    assert np.allclose(d_left, d_right, rtol=1e-10, atol=1e-15)
    # and close to the true motion: slerp's error is second order in the gap (0.04 s at ~1 rad/s)
    err = np.linalg.norm(so3.log(np.einsum("mji,mjk->mik", R, traj.R[2:-2:4])), axis=1)
    assert 0 < err.max() < 1e-3
    assert np.allclose(mid.Pi, 0.5 * (coarse.Pi[:-1] + coarse.Pi[1:]), rtol=0, atol=1e-15)


def test_at_near_a_half_turn():
    """Samples a bit less than pi apart about a fixed axis: the midpoint is the half-angle rotation."""
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    angles = np.array([0.0, 3.1, 6.2])
    spin = lgvi.Trajectory(t=np.array([0.0, 1.0, 2.0]), R=so3.exp(np.outer(angles, axis)), Pi=np.outer(angles, axis),
                           inertia=np.eye(3), iterations=np.ones(2, dtype=np.int32), residual=np.zeros(2), h=1.0)
    mid = spin.at([0.5, 1.5])
    assert np.allclose(mid.R, so3.exp(np.outer([1.55, 4.65], axis)), atol=1e-12)


def test_at_refuses_times_outside_the_run(traj):
    with pytest.raises(ValueError, match=r"t must lie inside the run, \[0, 2"):
        traj.at(2.5)
    with pytest.raises(ValueError, match="inside the run"):
        traj.at([0.1, np.nan])


# ------------------------------------------------------------------------------ xarray, pandas
def test_to_xarray_and_to_dataframe(traj):
    xr = pytest.importorskip("xarray")
    ds = traj.to_xarray()
    assert isinstance(ds, xr.Dataset)
    assert np.array_equal(ds["R"].values, traj.R) and np.array_equal(ds["time"].values, traj.t)
    assert np.array_equal(ds["omega"].values, traj.omega) and ds["omega"].attrs["units"] == "rad s-1"
    assert ds["iterations"].dims == ("interval",)
    df = traj.to_dataframe()
    assert df.index.name == "t" and len(df) == len(traj)
    assert np.array_equal(df[["qx", "qy", "qz", "qw"]].to_numpy(), traj.quaternion)
    assert np.array_equal(df["R23"].to_numpy(), traj.R[:, 1, 2])


# ------------------------------------------------------------------------------ MRP in lgvi.so3
@pytest.mark.parametrize("angle", [0.0, 1e-7, 0.3, 2.0, np.pi - 1e-9, np.pi])
def test_mrp_round_trip_near_the_identity_and_a_half_turn(angle):
    axis = np.array([2.0, -1.0, 2.0]) / 3.0
    R = so3.exp(angle * axis)
    sigma = so3.mrp_from_matrix(R)
    assert np.linalg.norm(sigma) <= 1.0 + 1e-15                              # never the shadow set
    assert np.allclose(sigma, np.tan(angle / 4.0) * axis, rtol=1e-12, atol=1e-16)
    assert np.abs(so3.matrix_from_mrp(sigma) - R).max() < 4e-16 * max(1.0, angle)
    stack = so3.mrp_from_matrix(np.stack([R, R.T]))                            # vectorised over leading axes
    assert stack.shape == (2, 3) and np.array_equal(stack[0], sigma)
    assert np.array_equal(stack[1], so3.mrp_from_matrix(R.T))


def test_control_keeps_the_mrp_names():
    import lgvi.control

    assert lgvi.control.mrp_from_matrix is so3.mrp_from_matrix
    assert lgvi.control.matrix_from_mrp is so3.matrix_from_mrp


# ------------------------------------------------------------------------------ the view page
def test_view_traces_the_axis_the_symmetry_picks():
    from lgvi.view import traced_axis

    assert traced_axis([0.13, 0.13, 0.28]) == 2          # a symmetric top: its symmetry axis
    assert traced_axis([0.28, 0.13, 0.13]) == 0
    assert traced_axis([1.0, 2.0, 3.0]) == 1             # asymmetric: the intermediate axis
    assert traced_axis([3.0, 1.0, 2.0]) == 2
    assert traced_axis([1.0, 1.0 + 1e-12, 2.0]) == 2     # equal to round-off is equal


def test_light_jupyter_display_on_request():
    pytest.importorskip("plotly")
    import lgvi.view

    tr = lgvi.simulate(BODY, np.eye(3), steps=20, **KW)
    try:
        lgvi.view.display("summary")
        bundle = tr._repr_mimebundle_()
        assert len(bundle["text/html"]) < 20_000 and "lgvi-summary" in bundle["text/html"]
        assert "Plotly" not in bundle["text/html"]
    finally:
        lgvi.view.display("view")
    with pytest.raises(ValueError, match="'view' or 'summary'"):
        lgvi.view.display("tiny")


def test_decimation_note_is_not_styled_as_an_error():
    import lgvi.view

    note_rule = next(line for line in lgvi.view._CSS.splitlines() if ".lgvi-note" in line)
    assert "#8b0000" not in note_rule and "red" not in note_rule


# ------------------------------------------------------------------------------ figures
def test_round_off_quantities_are_drawn_as_their_running_maximum(traj):
    pytest.importorskip("matplotlib")
    from lgvi import plot

    fig = plot.conservation(traj)
    ax = fig.axes[0]
    lines = {line.get_label(): np.asarray(line.get_ydata(), dtype=float) for line in ax.get_lines()}
    envelopes = [label for label in lines if label.endswith("running max")]
    assert len(envelopes) == 4          # energy, |Pi|, R Pi (exact for the free body) and |R^T R - I|
    for label in envelopes:
        assert np.all(np.diff(lines[label]) >= 0), label
    # the legend is below the axes, outside the data
    legend = ax.get_legend()
    assert legend is not None and legend.get_bbox_to_anchor().y0 < ax.get_window_extent().y0


def test_legends_of_the_time_series_sit_outside_the_data(traj):
    pytest.importorskip("matplotlib")
    from lgvi import plot

    for fig in (plot.rates(traj), plot._attitude_panels(traj)):
        fig.draw_without_rendering()
        for ax in fig.axes:
            legend = ax.get_legend()
            assert legend is not None
            assert legend.get_window_extent().x0 >= ax.get_window_extent().x1, ax.get_ylabel()


def test_a_bounded_energy_is_drawn_as_its_running_maximum():
    """The heavy top of examples/heavy_top.py (2 s): its energy error, bounded by the variational
    LGVI, passes through zero twice a nutation and was drawn as a comb of spikes down to 1e-12; it
    is its running maximum now, as the exact invariants are (a bounded error levels off at the
    largest relative change, 4.7e-7 here; a drift would climb)."""
    pytest.importorskip("matplotlib")
    from lgvi import plot
    from lgvi.torques import UniformGravity

    R0 = lgvi.so3.exp([np.radians(30.0), 0.0, 0.0])
    top = lgvi.simulate([0.05, 0.05, 0.02], R0, omega0=[0.0, 0.0, 40.0], h=1e-3, steps=2000,
                        torque=UniformGravity(1.0, [0.0, 0.0, 0.1], 9.81), save_every=10)
    lines = {ln.get_label(): np.asarray(ln.get_ydata(), float) for ln in plot.conservation(top).axes[0].get_lines()}
    energy = next(v for k, v in lines.items() if k.startswith("total energy"))
    label = next(k for k in lines if k.startswith("total energy"))
    assert label.endswith("bounded (no drift), running max")
    E = top.energy
    rel = np.abs(E - E[0]) / abs(E[0])
    assert np.all(np.diff(energy) >= 0) and energy[-1] == rel.max() and 1e-7 < rel.max() < 1e-6
    assert rel[rel.argmax():].min() < 1e-3 * rel.max()            # the series itself does dip: a comb drawn raw


def test_rates_figure_shows_every_component_of_a_fast_top(traj):
    """A top spun at 40 rad/s about its axis: that component goes on a second y axis, and the left
    axis spans the nutation of the two others (not 40 rad/s); a body whose components are comparable
    keeps one axis a panel."""
    pytest.importorskip("matplotlib")
    from lgvi import plot

    top = lgvi.simulate([0.2, 0.2, 0.3], np.eye(3), omega0=[0.5, 0.0, 40.0], h=0.001, steps=400)
    fig = plot.rates(top)
    assert len(fig.axes) == 4                                   # omega and Pi, each with a second axis
    ax_w = fig.axes[0]
    twin = next(a for a in fig.axes[2:] if a.get_shared_x_axes().joined(a, ax_w))
    assert [line.get_label() for line in twin.get_lines()] == [r"$\omega_3$ (right axis)"]
    lo, hi = ax_w.get_ylim()
    nutation = float(np.ptp(top.omega[:, :2]))
    assert nutation > 0 and hi - lo < 2 * nutation            # omega_1, omega_2 fill their axis
    tlo, thi = twin.get_ylim()
    assert tlo < 40.0 < thi and thi - tlo > 1.0                 # constant omega_3: a flat line, not its round-off
    assert len(plot.rates(traj).axes) == 2                      # comparable components: one axis a panel


def test_rates_of_a_long_fast_rotation_are_envelopes_not_a_solid_band(traj):
    """The same kind of top for 100 s (omega_1, omega_2 turn about 760 times at 3.8 Hz in the body):
    drawn as lines, even thinned to each bin's minimum and maximum, they filled their range as one
    solid band that hid each other. A component that turns more than FAST_TURNS times is drawn as its
    envelope: each bin's range shaded, its two edges the bins' true extrema, its period in the legend;
    a slow component (omega_3 here, every component of a slow run) stays a line."""
    pytest.importorskip("matplotlib")
    from lgvi import plot

    top = lgvi.simulate([0.05, 0.05, 0.02], np.eye(3), omega0=[0.5, 0.3, 40.0], h=1e-3, steps=100_000,
                        save_every=2)
    fig = plot.rates(top)
    ax_w = fig.axes[0]
    twin = next(a for a in fig.axes[2:] if a.get_shared_x_axes().joined(a, ax_w))
    labels = [line.get_label() for line in ax_w.get_lines()]
    period = 2 * np.pi / (40.0 * 0.03 / 0.05)                   # (J3 - J1) / J1 omega_3: 0.26 s
    assert labels[0] == r"$\omega_1$: range, period 0.26 s" and labels[2] == r"$\omega_2$: range, period 0.26 s"
    assert len(ax_w.collections) == 2                            # two shaded ranges
    hi, lo = ax_w.get_lines()[0].get_ydata(), ax_w.get_lines()[1].get_ydata()
    edges = np.linspace(0, len(top.t), plot.ENVELOPE_BINS + 1).astype(int)
    w1 = top.omega[:, 0]
    np.testing.assert_array_equal(hi[:-1], np.maximum.reduceat(w1, edges[:-1]))
    np.testing.assert_array_equal(lo[:-1], np.minimum.reduceat(w1, edges[:-1]))
    assert len(hi) <= plot.ENVELOPE_BINS + 1 and abs(float(np.ptp(w1)) - (hi.max() - lo.min())) == 0.0
    assert period == pytest.approx(0.26, abs=0.005)
    assert [line.get_label() for line in twin.get_lines()] == [r"$\omega_3$ (right axis)"]
    assert not plot.rates(traj).axes[0].collections              # a slow run: lines


def test_attitude_figure_is_free_of_gimbal_lock(traj, tmp_path):
    pytest.importorskip("matplotlib")
    from lgvi import plot

    fig = plot._attitude_panels(traj)
    titles = [ax.get_title() for ax in fig.axes]
    assert "modified Rodrigues" in titles[0] and "quaternion" in titles[1]
    assert not any("Euler" in t for t in titles)
    sigma = plot.attitude(traj, "mrp").axes[0].get_lines()
    assert all(np.nanmax(np.abs(line.get_ydata())) <= 1.0 for line in sigma)
    with pytest.raises(ValueError, match="'euler', 'quaternion' or 'mrp'"):
        plot.attitude(traj, "rpy")


def test_view_rates_on_their_own_axes_when_one_would_flatten_the_others():
    pytest.importorskip("plotly")
    import lgvi.view

    top = lgvi.simulate([0.2, 0.2, 0.3], np.eye(3), omega0=[0.5, 0.0, 40.0], h=0.001, steps=400)
    fig = lgvi.view.figure(top)
    titles = [a.text for a in fig.layout.annotations if a.text and "rate" in a.text]
    assert titles == ["body rate ωx (rad/s)", "body rate ωy (rad/s)", "body rate ωz (rad/s)"]
    rates = {d.name: d for d in fig.data if d.name in ("ωx", "ωy", "ωz")}
    assert len({rates[n].yaxis for n in rates}) == 3          # three y axes: every component visible
    plain = lgvi.view.figure(lgvi.simulate(BODY, np.eye(3), steps=3000, **KW))      # comparable ranges
    assert [a.text for a in plain.layout.annotations if a.text and a.text.startswith("body rate")] == [
        "body rates ω (rad/s)"]


def test_literal_options_are_the_registries():
    """simulate's string options are typed as Literal (an editor completes them); the Literals are
    exactly the registries' names, so the two cannot drift."""
    import typing

    from lgvi.registry import FORCINGS, SCHEMES, SOLVER_METHODS

    hints = typing.get_type_hints(lgvi.simulate)
    assert set(typing.get_args(hints["method"])) == set(SOLVER_METHODS)
    assert set(typing.get_args(hints["forcing"])) == set(FORCINGS)
    assert set(typing.get_args(hints["solver_record"])) == {"interval", "full"}
    (scheme,) = [a for a in typing.get_args(hints["scheme"]) if a is not type(None)]
    assert set(typing.get_args(scheme)) == set(SCHEMES)


# ------------------------------------------------------------------------------ a logger, not prints
def test_the_library_speaks_through_the_lgvi_logger_not_print():
    """Outside the command line (``lgvi.cli``, ``python -m lgvi``) no module prints or writes to
    stdout/stderr itself: what the library says goes through ``logging.getLogger("lgvi")`` (the
    compile line of ``lgvi._jit``) or ``warnings`` (a user configures or silences both); the one
    reading of ``sys.stderr`` left, ``lgvi.driver.interactive``, asks whether it is a terminal."""
    import ast
    import logging
    from pathlib import Path

    import lgvi._jit

    src = Path(lgvi.__file__).resolve().parent
    found = []
    for path in sorted(src.rglob("*.py")):
        rel = path.relative_to(src)
        if rel.parts[0] == "cli" or rel.name == "__main__.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print":
                found.append(f"{rel}:{node.lineno}: print(")
            if (isinstance(node, ast.Attribute) and node.attr in ("stdout", "stderr")
                    and isinstance(node.value, ast.Name) and node.value.id == "sys"):
                if not (rel.as_posix() == "driver.py" and node.attr == "stderr"):
                    found.append(f"{rel}:{node.lineno}: sys.{node.attr}")
    assert not found, "the library writes to the streams itself (use logging or warnings):\n" + "\n".join(found)
    assert lgvi._jit._log is logging.getLogger("lgvi")
