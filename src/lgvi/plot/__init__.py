"""Figures and animations of a :class:`~lgvi.Trajectory` (matplotlib, imported lazily).

Every plotting function takes an existing ``ax`` (or ``axes``) to draw into, or creates a new
figure when it is ``None``, and returns the :class:`matplotlib.figure.Figure`. New figures are
plain ``Figure`` objects, not registered with ``pyplot``: nothing is shown, nothing leaks, and
any backend (including the headless Agg) works. In a notebook a returned figure displays itself;
in a script save it with ``fig.savefig(...)``, or pass ``ax=`` from your own ``plt.subplots()``.

========================  =======================================================================
:func:`attitude`          Euler angles (unwrapped) or quaternion components against time
:func:`rates`             body angular velocity ``omega`` and body momentum ``Pi`` against time
:func:`conservation`      relative errors of energy, ``|Pi|``, spatial momentum; ``|R^T R - I|``
:func:`iterations`        solver updates per step and final residual of each step
:func:`polhode`           body momentum path on the momentum sphere, with analytic polhodes
:func:`animate`           the body as a box with its principal axes and the momentum (GIF/MP4)
:func:`save_figures`      all of the above (but the animation) as PNG files
:func:`save_comparison`   conservation diagnostics of several trajectories overlaid
========================  =======================================================================

Long runs are thinned before drawing (at most ``max_points`` points per curve): time series keep
the minimum and maximum of every bin, error curves the maximum, so no excursion is hidden.

Requires matplotlib (``pip install lgvi[plot]``).
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from .._files import write_atomic

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..trajectory import Trajectory

#: Size of the figures made by this module, in inches, and the resolution of saved PNGs.
FIGSIZE: tuple[float, float] = (8.0, 5.0)
POLHODE_FIGSIZE: tuple[float, float] = (8.0, 7.0)
ATTITUDE_PANELS_FIGSIZE: tuple[float, float] = (8.0, 6.5)
COMPARISON_FIGSIZE: tuple[float, float] = (10.0, 7.0)
DPI: int = 100

#: Pixel size ``(width, height)`` of each PNG written by :func:`save_figures` and
#: :func:`save_comparison` (figure size in inches times :data:`DPI`).
FIGURE_PIXELS: dict[str, tuple[int, int]] = {
    "attitude": (800, 650),
    "rates": (800, 500),
    "conservation": (800, 500),
    "iterations": (800, 500),
    "polhode": (800, 700),
    "comparison": (1000, 700),
    "wheels": (800, 500),
    "orbit": (800, 650),
    "two_body": (800, 650),
}

#: Errors below this are drawn at this value on the logarithmic axes (an exact zero has no log).
ERROR_FLOOR: float = 1e-17

#: Default number of points per drawn curve (longer series are thinned, see the module notes).
MAX_POINTS: int = 10_000

#: Vertices per piece in which Agg draws a long line when a figure is saved (``agg.path.chunksize``).
AGG_CHUNK: int = 1000

#: Names of the PNG files written by :func:`save_figures` (before the prefix).
FIGURE_NAMES: tuple[str, ...] = ("attitude", "rates", "conservation", "iterations", "polhode")

_COMPONENT_COLORS = ("tab:red", "tab:green", "tab:blue", "tab:gray")
_UNITS = {"t": "time $t$ (s)", "omega": "rad/s", "Pi": "kg m$^2$/s", "angle": "rad"}


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------
def _mpl():
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - exercised only without the extra
        raise ImportError("lgvi.plot needs matplotlib: pip install 'lgvi[plot]' (or pip install matplotlib)") from exc
    return matplotlib


def _figure(figsize: tuple[float, float] = FIGSIZE) -> Figure:
    """A new stand-alone figure (not managed by pyplot) with constrained layout."""
    _mpl()
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, dpi=DPI, layout="constrained")


def _axes(ax: Axes | None, figsize: tuple[float, float] = FIGSIZE) -> tuple[Figure, Axes]:
    if ax is None:
        fig = _figure(figsize)
        return fig, fig.add_subplot()
    return ax.get_figure(), ax


def _axes_list(axes: Sequence[Axes] | None, n: int, name: str) -> tuple[Figure, list[Axes]]:
    if axes is None:
        fig = _figure()
        axs = list(np.atleast_1d(fig.subplots(n, 1, sharex=True)))
        return fig, axs
    axs = list(np.ravel(np.asarray(axes, dtype=object)))
    if len(axs) != n:
        raise ValueError(f"{name}: axes must be a sequence of {n} Axes, got {len(axs)}")
    return axs[0].get_figure(), axs


def _check_traj(traj: Any, name: str) -> None:
    for attr in ("t", "R", "Pi", "inertia"):
        if not hasattr(traj, attr):
            raise TypeError(f"{name}: expected an lgvi.Trajectory, got {type(traj).__name__} (no .{attr})")
    if len(traj.t) == 0:
        raise ValueError(f"{name}: the trajectory is empty (no samples to plot)")


def _label(traj: Trajectory) -> str:
    meta = getattr(traj, "meta", {}) or {}
    method = str(meta.get("method", "lgvi"))
    if method.startswith("solve_ivp:"):
        return f"{method.split(':', 1)[1]} (rtol={meta.get('rtol', '?'):g})" if "rtol" in meta else method
    h = getattr(traj, "h", float("nan"))
    return f"lgvi {method}, h={h:g} s" if np.isfinite(h) else f"lgvi {method}"


def has_solver_record(traj: Trajectory) -> bool:
    """Whether ``traj`` carries the per-step record of LGVI solves that :func:`iterations` draws.

    True for runs of :func:`lgvi.simulate` (and their ``.npz``/netCDF copies); False for the
    baselines of :mod:`lgvi.baselines` (no implicit solves) and trajectories read from CSV.
    """
    from ..implicit import METHODS

    its = getattr(traj, "iterations", ())
    res = getattr(traj, "residual", ())
    method = str((getattr(traj, "meta", {}) or {}).get("method", ""))
    return len(res) > 0 and len(res) == len(its) and method in METHODS


def _bins(n: int, max_points: int) -> int:
    return 0 if n <= max_points else max(1, max_points // 2)


def _thin_minmax(t: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Keep the minimum and the maximum of each bin (in time order) of a 1-D series."""
    n = len(t)
    nb = _bins(n, max_points)
    if nb == 0:
        return t, y
    edges = np.linspace(0, n, nb + 1).astype(np.int64)
    lo = np.minimum.reduceat(y, edges[:-1])
    hi = np.maximum.reduceat(y, edges[:-1])
    # positions of min and max within each bin, to keep time order within the bin
    idx = np.arange(n)
    bin_of = np.repeat(np.arange(nb), np.diff(edges))
    i_lo = np.full(nb, n, dtype=np.int64)
    i_hi = np.full(nb, n, dtype=np.int64)
    np.minimum.at(i_lo, bin_of, np.where(y == lo[bin_of], idx, n))
    np.minimum.at(i_hi, bin_of, np.where(y == hi[bin_of], idx, n))
    i_lo = np.minimum(i_lo, n - 1)
    i_hi = np.minimum(i_hi, n - 1)
    first = np.minimum(i_lo, i_hi)
    second = np.maximum(i_lo, i_hi)
    keep = np.unique(np.concatenate([first, second, [0, n - 1]]))
    return t[keep], y[keep]


def _thin_max(t: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-bin maximum of an error series (drawn at the bin's start time); the last point kept."""
    n = len(t)
    nb = _bins(n, max_points)
    if nb == 0:
        return t, y
    edges = np.linspace(0, n, nb + 1).astype(np.int64)[:-1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        peaks = np.fmax.reduceat(y, edges)  # NaN (a gap) only where a whole bin is NaN
    return np.append(t[edges], t[-1]), np.append(peaks, y[-1])


def _running_max(err: Any) -> np.ndarray:
    """The largest error so far at each sample (NaN, a missing sample, does not reset it)."""
    err = np.asarray(err, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.fmax.accumulate(err) if err.size else err


def _legend_below(ax: Axes, ncol: int = 1) -> None:
    """The legend under the axes, outside the data (constrained layout makes room for it)."""
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=ncol, fontsize="small", frameon=False)


def _legend_right(ax: Axes, **kw: Any) -> None:
    """The legend right of the axes, outside the data (constrained layout makes room for it)."""
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize="small", **kw)


def _floor(err: np.ndarray) -> np.ndarray:
    err = np.asarray(err, dtype=np.float64)
    return np.where(np.isfinite(err), np.maximum(err, ERROR_FLOOR), np.nan)


#: Error series drawn by :func:`conservation` and :func:`comparison`, in this order (the first three
#: always in :func:`conservation`, marked when they are not invariants; the others when declared).
_SERIES_ORDER = ("energy", "casimir", "spatial_momentum", "spatial_momentum_e3", "jacobi")
_SERIES_COLORS = {"energy": "tab:red", "casimir": "tab:green", "spatial_momentum": "tab:blue",
                  "spatial_momentum_e3": "tab:purple", "jacobi": "tab:orange", "orthogonality": "tab:gray"}
_SERIES_LABELS = {
    "energy": ("energy", "$|E - E_0|/|E_0|$", "$|E - E_0|$ (J)"),
    "casimir": ("", r"$\,||\Pi| - |\Pi_0||/|\Pi_0|$", r"$||\Pi| - |\Pi_0||$ (kg m$^2$/s)"),
    "spatial_momentum": ("spatial momentum", r"$|R\Pi - R_0\Pi_0|/|R_0\Pi_0|$",
                         r"$|R\Pi - R_0\Pi_0|$ (kg m$^2$/s)"),
    "spatial_momentum_e3": ("vertical momentum", r"$|e_3\cdot(R\Pi - R_0\Pi_0)|/|R_0\Pi_0|$",
                            r"$|e_3\cdot(R\Pi - R_0\Pi_0)|$ (kg m$^2$/s)"),
    "jacobi": ("Jacobi integral", r"$|C - C_0|/|C_0|$, $C = E - n\,e_3\cdot R\Pi$",
               r"$|C - C_0|$ (J), $C = E - n\,e_3\cdot R\Pi$"),
}
_CONSERVATION_TITLES = {
    "energy": "energy error (relative)",
    "casimir": r"$|\Pi|$ error (relative)",
    "spatial_momentum": "spatial momentum error (relative)",
    "spatial_momentum_e3": r"vertical momentum $e_3\cdot R\Pi$ error (relative to $|R_0\Pi_0|$)",
    "jacobi": r"Jacobi integral $C = E - n\,e_3\cdot R\Pi$ error (relative)",
    "orthogonality": r"distance from SO(3): $\|R^T R - I\|_F$",
}
_LEGACY_NAMES = {"momentum": "spatial_momentum"}


def _declaration(trajs: Sequence[Trajectory]):
    """The invariants of the problem: those of the first trajectory that records (or implies) them."""
    from ..invariants import declared

    decls = [declared(tr) for tr in trajs]
    return next((d for d in decls if d.recorded), decls[0])


def _shown(keys: Sequence[str]) -> list[str]:
    """Declared quantities worth a curve of their own: ``e3 . R Pi`` only without ``R Pi``."""
    return [k for k in _SERIES_ORDER if k in keys and not (k == "spatial_momentum_e3" and "spatial_momentum" in keys)]


def _error(traj: Trajectory, key: str, decl: Any) -> tuple[np.ndarray, str]:
    """Error series of one quantity (``"orthogonality"`` too) and its legend label."""
    from ..invariants import error_series

    if key == "orthogonality":
        return np.asarray(traj.orthogonality_error, dtype=np.float64), r"orthogonality $\|R^T R - I\|_F$"
    entry = decl.entries.get(key, {})
    err, rel = error_series(traj, key, {k: v for k, v in entry.items() if k != "kind"})
    name, rel_text, abs_text = _SERIES_LABELS[key]
    if key == "energy":
        name = "total energy" if getattr(traj, "potential", None) is not None else "kinetic energy"
    return err, (f"{name} " if name else "") + (rel_text if rel else abs_text)


def _style_log(ax: Axes) -> None:
    ax.set_yscale("log")
    ax.set_ylim(bottom=ERROR_FLOOR / 2)
    ax.grid(True, which="major", alpha=0.3)


# ------------------------------------------------------------------------------------------------
# time series
# ------------------------------------------------------------------------------------------------
#: Sign changes of the quaternion shown at most (about this many oscillations) before the
#: quaternion view zooms in on the start of the run.
QUAT_CYCLES = 40

#: Largest rotation between consecutive samples (rad) that the attitude curves resolve: beyond a
#: quarter turn they alias, and :func:`attitude` says so on the figure.
SPARSE_TURN = np.pi / 2

#: Half-width of the band around an Euler singularity (gimbal lock) that is shaded and not
#: unwrapped across (rad).
GIMBAL_BAND = np.radians(5.0)


def _unwrap_euler(raw: np.ndarray, near: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Euler angles with whole turns of angles 1 and 3 removed, never across a singularity.

    A step between consecutive samples is a *break* when either sample lies in the band ``near``
    the singularity, or when angle 1 or 3 changes by more than a quarter turn beyond whole turns
    (a jump of the representation, or samples too sparse to follow the motion). Each run of
    samples between breaks starts from the principal value and is unwrapped within itself, so
    the angles stay bounded by the turns of one run (an unwrap across the jumps of a spin through
    gimbal lock climbs a staircase, one half turn per passage). Angle 2 is never unwrapped.

    Returns ``(angles (M, 3), breaks (M-1,) bool)``.
    """
    ang = np.array(raw, dtype=np.float64)
    if len(ang) < 2:
        return ang, np.zeros(0, dtype=bool)
    d = np.diff(ang[:, [0, 2]], axis=0)
    turns = np.round(d / (2.0 * np.pi))
    jump = np.abs(d - 2.0 * np.pi * turns).max(axis=1) > np.pi / 2
    breaks = jump | near[:-1] | near[1:]
    turns[breaks] = 0.0
    # whole turns counted from the start of each run between breaks: every run starts from the
    # principal value, so turns that only make up for the jumps at the breaks never add up
    count = np.vstack([np.zeros((1, 2)), np.cumsum(turns, axis=0)])
    run = np.concatenate([[0], np.cumsum(breaks)])
    first = np.flatnonzero(np.diff(run, prepend=-1))
    ang[:, [0, 2]] -= 2.0 * np.pi * (count - count[first][run])
    return ang, breaks


def _thin_segments(t: np.ndarray, y: np.ndarray, breaks: np.ndarray, skip: np.ndarray,
                   max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_thin_minmax` of each run of samples between breaks, joined by NaN gaps (so no line
    is drawn across a break); runs whose samples are all in ``skip`` are left out."""
    n = len(t)
    cut = np.flatnonzero(breaks) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [n]])
    parts_t, parts_y = [], []
    for a, b in zip(starts, ends):
        if skip[a:b].all():
            continue
        tt, yy = _thin_minmax(t[a:b], y[a:b], max(4, int(max_points * (b - a) / n)))
        parts_t += [tt, tt[-1:]]
        parts_y += [yy, [np.nan]]
    if not parts_t:
        return t[:0], y[:0]
    return np.concatenate(parts_t[:-1]), np.concatenate(parts_y[:-1])


def _oscillation_window(y: np.ndarray) -> slice:
    """The samples shown of components that oscillate: all, or (when they change sign more often
    than about :data:`QUAT_CYCLES` oscillations, a solid band at any width) the first ones."""
    crossings = np.flatnonzero(np.diff(np.signbit(y), axis=0).any(axis=1))
    if len(crossings) > 4 * QUAT_CYCLES:
        return slice(0, int(crossings[2 * QUAT_CYCLES]) + 1)
    return slice(None)


def sampling_note(traj: Trajectory) -> str | None:
    """A warning when the saved samples are too sparse for the motion, else ``None``.

    Sparse means: somewhere the body turns by more than a quarter turn (:data:`SPARSE_TURN`)
    between consecutive samples (``|omega| dt``, with the larger rate of the two samples); then
    every attitude curve (Euler angles and quaternion alike) aliases.
    """
    t = np.asarray(traj.t, dtype=np.float64)
    if len(t) < 2:
        return None
    w = np.linalg.norm(np.asarray(traj.omega, dtype=np.float64), axis=1)
    turn = np.maximum(w[:-1], w[1:]) * np.abs(np.diff(t))
    worst = float(np.max(turn))
    if not worst > SPARSE_TURN:
        return None
    return (f"samples too sparse for the motion: up to {np.degrees(worst):.0f} deg of rotation between saved\n"
            f"samples (over a quarter turn), so these curves alias; save more often (smaller save_every)")


def _note(ax: Axes, text: str | None) -> None:
    if text:
        ax.text(0.5, 0.97, text, transform=ax.transAxes, ha="center", va="top", fontsize="x-small",
                color="darkred", bbox=dict(boxstyle="round", facecolor="white", edgecolor="darkred", alpha=0.9),
                zorder=10)


def attitude(traj: Trajectory, kind: str = "euler", sequence: str = "ZYX", ax: Axes | None = None, *,
             degrees: bool = False, scalar_first: bool = False, max_points: int = MAX_POINTS) -> Figure:
    """Attitude against time: MRPs, quaternion components or Euler angles (unwrapped).

    Parameters
    ----------
    traj : Trajectory
    kind : {"euler", "quaternion", "mrp"}
        Euler angles of ``R`` (body to inertial) in ``sequence``, unwrapped over time so that
        full turns show as ramps instead of jumps (but never across a singularity, see the
        notes); or the sign-continuous unit quaternion; or the modified Rodrigues parameters
        (:func:`lgvi.so3.mrp_from_matrix`, Basilisk's ``sigma_BN``: ``|sigma| <= 1``, no
        singularity, a jump to the other side only where the body passes a half turn).
    sequence : str
        Euler sequence as in :meth:`scipy.spatial.transform.Rotation.as_euler`: upper case is
        intrinsic (``"ZYX"``: yaw, pitch, roll), lower case extrinsic.
    ax : matplotlib Axes, optional
        Axes to draw into; a new figure otherwise.
    degrees : bool
        Euler angles in degrees instead of radians.
    scalar_first : bool
        Quaternion order ``(w, x, y, z)`` instead of scipy's ``(x, y, z, w)`` (labels follow).
    max_points : int
        Most points per curve (longer runs keep each bin's minimum and maximum).

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    Euler angles are singular where the middle angle reaches +-90 deg (``"ZYX"``, ``"XYZ"``, ...)
    or 0/180 deg (``"ZXZ"``, ...): there the first and third angles jump however they are
    unwrapped. Samples within 5 deg of it are shaded and left out, and the curves of angles 1 and
    3 are broken (not unwrapped) there and wherever they jump by more than a quarter turn, so
    they stay bounded. The quaternion view has no such singularity. When the samples are further
    apart than a quarter turn of the body, both views say so on the figure
    (:func:`sampling_note`).
    """
    _check_traj(traj, "attitude")
    if kind not in ("euler", "quaternion", "mrp"):
        raise ValueError(f"attitude: kind must be 'euler', 'quaternion' or 'mrp', got {kind!r}")
    fig, ax = _axes(ax)
    t = np.asarray(traj.t)
    if kind == "euler":
        if not isinstance(sequence, str) or len(sequence) != 3:
            raise ValueError(f"attitude: sequence must be 3 axis letters such as 'ZYX' or 'zxz', got {sequence!r}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # scipy's "Gimbal lock detected"
            raw = traj.rotation.as_euler(sequence)
        unit = "deg" if degrees else "rad"
        intrinsic = sequence.isupper()
        primes = ("", "'", "''") if intrinsic else ("", "", "")
        # shade where the middle angle is within 5 deg of the singularity (gimbal lock)
        mid = raw[:, 1]
        if sequence[0].lower() == sequence[2].lower():  # proper Euler: singular at 0 and pi
            dist = np.minimum(np.abs(mid), np.abs(np.pi - np.abs(mid)))
        else:  # Tait-Bryan: singular at +-pi/2
            dist = np.abs(np.pi / 2 - np.abs(mid))
        near = dist < GIMBAL_BAND
        ang, breaks = _unwrap_euler(raw, near)
        if degrees:
            ang = np.degrees(ang)
        if near.any():
            ax.fill_between(t, 0, 1, where=near, transform=ax.get_xaxis_transform(), color="0.85",
                            step="mid", label="near gimbal lock (angles 1, 3 ill-defined)")
        for i in range(3):
            if i == 1:
                tt, yy = _thin_minmax(t, ang[:, i], max_points)
            else:  # broken at the singularity and at jumps, never unwrapped across them
                tt, yy = _thin_segments(t, ang[:, i], breaks, near, max_points)
            ax.plot(tt, yy, color=_COMPONENT_COLORS[i], lw=1.2,
                    label=f"angle {i + 1}: about {sequence[i].upper()}{primes[i]}")
        ax.set_ylabel(f"Euler angle ({unit})")
        ax.set_title(f"Attitude: {'intrinsic' if intrinsic else 'extrinsic'} {sequence} Euler angles "
                     "(unwrapped), body to inertial")
    elif kind == "mrp":
        from ..so3 import mrp_from_matrix, orthogonality_error, project

        R = np.asarray(traj.R)
        if not np.all(orthogonality_error(R) <= 1e-9):   # a baseline (RK45, RK4) drifts off SO(3):
            R = project(R)                                 # the attitude drawn is the nearest rotation's
        sigma = mrp_from_matrix(R)
        window = _oscillation_window(sigma)
        tw, sw = t[window], sigma[window]
        # the switch to the other side at a half turn is a jump (|d sigma| ~ 2): the curves break there
        breaks = np.linalg.norm(np.diff(sw, axis=0), axis=1) > 1.0 if len(sw) > 1 else np.zeros(0, dtype=bool)
        for i in range(3):
            tt, yy = _thin_segments(tw, sw[:, i], breaks, np.zeros(len(tw), dtype=bool), max_points)
            ax.plot(tt, yy, color=_COMPONENT_COLORS[i], lw=1.2, label=rf"$\sigma_{i + 1}$")
        ax.set_ylabel("MRP component (1)")
        ax.set_ylim(-1.08, 1.08)
        shown = "" if window == slice(None) else f"; first {tw[-1] - t[0]:.4g} s of {t[-1] - t[0]:.4g} s"
        ax.set_title(f"Attitude: modified Rodrigues parameters (body to inertial), |sigma| <= 1{shown}")
    else:
        q = traj.quaternions(scalar_first=scalar_first)
        names = ("w", "x", "y", "z") if scalar_first else ("x", "y", "z", "w")
        colors = (_COMPONENT_COLORS[3],) + _COMPONENT_COLORS[:3] if scalar_first else _COMPONENT_COLORS
        # a long run of a fast rotation oscillates more often than there are pixels (a solid band):
        # show the first ~QUAT_CYCLES oscillations only, and say so
        window = _oscillation_window(q)
        for i in range(4):
            tt, yy = _thin_minmax(t[window], q[window, i], max_points)
            ax.plot(tt, yy, color=colors[i], lw=1.2, label=f"$q_{names[i]}$")
        ax.set_ylabel("quaternion component (1)")
        ax.set_ylim(-1.08, 1.08)
        order = "scalar-first (w, x, y, z)" if scalar_first else "scalar-last (x, y, z, w)"
        shown = "" if window == slice(None) else f"; first {t[window][-1] - t[0]:.4g} s of {t[-1] - t[0]:.4g} s"
        ax.set_title(f"Attitude: unit quaternion, {order}, sign-continuous{shown}")
    _note(ax, sampling_note(traj))
    ax.set_xlabel(_UNITS["t"])
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize="small", framealpha=0.85)
    return fig


#: A component whose values lie apart from the others' goes on a second y axis when the others then
#: vary over less than this fraction of the shared axis (a top spun at 40 rad/s about its axis would
#: flatten a nutation of 1 rad/s to a line).
RATES_APART = 0.2

#: A component with more turning points than this oscillates faster than the figure's ~560 pixels
#: of axis can draw (under three pixels a period): a line, even thinned to each bin's minimum and
#: maximum, fills its range as a solid band that hides the other components. It is drawn as its
#: envelope instead, each of :data:`ENVELOPE_BINS` bins' range shaded between its edges.
FAST_TURNS = 400
ENVELOPE_BINS = 400


def _turns(t: np.ndarray, y: np.ndarray) -> tuple[int, float | None]:
    """How many times ``y`` turns (local extrema of the samples; flat runs ignored), and its period
    when the turns are regular (every period, two turns, within 10 % of their mean), else ``None``."""
    d = np.sign(np.diff(y))
    keep = np.flatnonzero(d != 0)
    turn = keep[1:][d[keep][1:] != d[keep][:-1]]          # the sample after which the slope changes sign
    if len(turn) < 3:
        return len(turn), None
    periods = np.diff(t[turn])[:-1] + np.diff(t[turn])[1:]
    regular = periods.std() <= 0.1 * periods.mean()
    return len(turn), (float(periods.mean()) if regular else None)


def _envelope(t: np.ndarray, y: np.ndarray, bins: int = ENVELOPE_BINS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, low, high)``: each of ``bins`` equal runs of samples' minimum and maximum, at the
    run's first time, then the last sample's time (the last run's values repeated), for a step
    drawing that covers every sample."""
    edges = np.linspace(0, len(y), min(bins, len(y)) + 1).astype(np.int64)[:-1]
    lo, hi = np.minimum.reduceat(y, edges), np.maximum.reduceat(y, edges)
    return np.append(t[edges], t[-1]), np.append(lo, lo[-1]), np.append(hi, hi[-1])


def _apart(data: np.ndarray) -> int | None:
    """The component of ``data`` (M, 3) to draw on a second y axis, or None (one shared axis shows all)."""
    if len(data) < 2 or not np.all(np.isfinite(data)):
        return None
    lo, hi = data.min(axis=0), data.max(axis=0)
    whole = float(hi.max() - lo.min())
    if whole <= 0:
        return None
    centre = (lo + hi) / 2
    k = int(np.argmax(np.abs(centre - np.median(centre))))
    rest = [i for i in range(data.shape[1]) if i != k]
    return k if float(hi[rest].max() - lo[rest].min()) < RATES_APART * whole else None


def _second_axis(ax: Axes, y: np.ndarray, color: str, label: str) -> Axes:
    """A twin y axis on the right for one component, its limits padded so that a component constant
    up to round-off is a flat line (not its last digits magnified)."""
    tw = ax.twinx()
    lo, hi = float(np.min(y)), float(np.max(y))
    pad = max(0.1 * (hi - lo), 0.02 * max(abs(lo), abs(hi)), 1e-300)
    tw.set_ylim(lo - pad, hi + pad)
    tw.set_ylabel(label, color=color)
    tw.tick_params(axis="y", colors=color)
    return tw


def rates(traj: Trajectory, axes: Sequence[Axes] | None = None, *, max_points: int = MAX_POINTS) -> Figure:
    """Body angular velocity ``omega`` (top) and body angular momentum ``Pi`` (bottom) against time.

    Where one component lies far from the other two (a top spun fast about its axis), it is drawn on
    a second y axis on the right, so that the others are not flattened to a line
    (:data:`RATES_APART`); the legend says which component is on it. A component that oscillates
    faster than the axis can draw (more than :data:`FAST_TURNS` turning points: a long fast
    rotation) is drawn as its envelope, the range of each of :data:`ENVELOPE_BINS` bins shaded
    between two thin edges, and its legend gives its period where the turning points are regular,
    so that the components stay apart instead of one solid band.

    Parameters
    ----------
    traj : Trajectory
    axes : two matplotlib Axes, optional
        Axes for ``omega`` and ``Pi``; a new two-panel figure otherwise.
    max_points : int
        Most points per curve.

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check_traj(traj, "rates")
    fig, (ax_w, ax_p) = _axes_list(axes, 2, "rates")
    t = np.asarray(traj.t)
    for ax, data, sym, unit in ((ax_w, traj.omega, r"\omega", _UNITS["omega"]),
                                (ax_p, traj.Pi, r"\Pi", _UNITS["Pi"])):
        data = np.asarray(data, dtype=float)
        k = _apart(data)
        tw = None if k is None else _second_axis(ax, data[:, k], _COMPONENT_COLORS[k], f"${sym}_{k + 1}$ ({unit})")
        for i in range(3):
            where, c = (tw if i == k else ax), _COMPONENT_COLORS[i]
            label = f"${sym}_{i + 1}$" + (" (right axis)" if i == k else "")
            turns, period = _turns(t, data[:, i])
            if turns > FAST_TURNS and len(t) > 2 * ENVELOPE_BINS:      # its range per bin, not a band of zigzags
                tt, lo, hi = _envelope(t, data[:, i])
                where.fill_between(tt, lo, hi, step="post", color=c, alpha=0.2, lw=0)
                what = "range per bin" if period is None else f"range, period {period:.2g} s"
                where.step(tt, hi, where="post", color=c, lw=0.9, label=f"{label}: {what}")
                where.step(tt, lo, where="post", color=c, lw=0.9)
                continue
            tt, yy = _thin_minmax(t, data[:, i], max_points)
            where.plot(tt, yy, color=c, lw=1.2, label=label)
        ax.set_ylabel(f"${sym}$ ({unit})" if k is None else f"${sym}$ ({unit}), left axis")
        ax.grid(True, alpha=0.3)
        if tw is None:
            _legend_right(ax)
        else:   # one legend for both axes, right of the second axis's labels
            handles = ax.get_legend_handles_labels()[0] + tw.get_legend_handles_labels()[0]
            handles.sort(key=lambda h: str(h.get_label()))
            tw.legend(handles=handles, loc="center left", bbox_to_anchor=(1.16, 0.5), fontsize="small")
    ax_w.set_title(r"Body angular velocity $\omega = J^{-1}\Pi$ and body angular momentum $\Pi$")
    ax_p.set_xlabel(_UNITS["t"])
    return fig


def wheels(traj: Any, axes: Sequence[Axes] | None = None, *, max_points: int = MAX_POINTS) -> Figure:
    """Reaction wheel speeds relative to the body (top) and applied motor torques (bottom).

    Parameters
    ----------
    traj : lgvi.systems.gyrostat.GyrostatTrajectory
        A run with ``wheels=`` (``wheel_speed`` and ``wheel_torque``, (M, N)).
    axes : two matplotlib Axes, optional
    max_points : int
        Most points per curve.

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check_traj(traj, "wheels")
    if getattr(traj, "wheel_speed", None) is None:
        raise TypeError(f"wheels: expected a trajectory with reaction wheels (simulate(..., wheels=...)), got "
                        f"{type(traj).__name__}")
    fig, (ax_s, ax_u) = _axes_list(axes, 2, "wheels")
    t = np.asarray(traj.t)
    n = np.asarray(traj.wheel_speed).shape[1]
    for ax, data, label in ((ax_s, traj.wheel_speed, "wheel speed (rad/s)"),
                            (ax_u, traj.wheel_torque, "motor torque (N m)")):
        for i in range(n):
            tt, yy = _thin_minmax(t, np.asarray(data)[:, i], max_points)
            ax.plot(tt, yy, lw=1.2, label=f"wheel {i + 1}")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        if n:
            _legend_right(ax, ncols=1 + (n - 1) // 8)
    ax_s.set_title("Reaction wheels: speed relative to the body and applied motor torque")
    ax_u.set_xlabel(_UNITS["t"])
    return fig


def conservation(traj: Trajectory, ax: Axes | None = None, *, extra: Mapping[str, Any] | None = None,
                 invariants: Sequence[str] | None = None, max_points: int = MAX_POINTS) -> Figure:
    """Conservation diagnostics on a logarithmic axis against time.

    Draws the relative error of the energy (kinetic plus potential, if the run has one), of the
    Casimir ``|Pi|`` and of the spatial momentum ``R Pi``, of every other invariant the run's
    system declares (``e3 . R Pi`` under uniform gravity, the Jacobi integral under the gravity
    gradient; see :mod:`lgvi.invariants`), and the distance ``|R^T R - I|_F`` of the attitude from
    SO(3). Zeros are drawn at :data:`ERROR_FLOOR`; long runs show each bin's maximum. Each
    invariant's legend says how the LGVI keeps it (exact or bounded); quantities that are not
    invariants of the run are drawn dashed and say so (a spacecraft under external torques, whose
    control and disturbances change them by design, draws only the distance from SO(3), and its
    title names the torques' sources: the torques themselves are in ``disturbances.png``).
    The invariants and the distance from SO(3) are drawn as their running maximum: a round-off
    error flickers between zero and a few ulps from one sample to the next, and a bounded error
    (the energy of a heavy top) passes through zero twice an oscillation, which would fill the plot
    as a comb of spikes; the running maximum shows what matters, how large the error has grown (a
    bounded error levels off, a drift climbs). The legend sits below the axes, clear of the curves.

    Parameters
    ----------
    traj : Trajectory
    ax : matplotlib Axes, optional
    extra : mapping of label -> (M,) array_like, optional
        More error series to draw (one value per sample), e.g. the vertical momentum error
        ``|e3 . (R Pi - R_0 Pi_0)| / |e3 . R_0 Pi_0|`` of a heavy top.
    invariants : sequence of {"energy", "casimir", "momentum", ...}, optional
        Which quantities to draw as invariants (keys of :data:`lgvi.invariants.QUANTITIES`;
        ``"momentum"`` is ``"spatial_momentum"``). Default: the run's declaration
        (``meta["invariants"]``, see :func:`lgvi.invariants.declared`).
    max_points : int
        Most points per curve.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np, lgvi, lgvi.plot
    >>> traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=200)
    >>> fig = lgvi.plot.conservation(traj)
    >>> fig.axes[0].get_yscale()
    'log'
    """
    _check_traj(traj, "conservation")
    fig, ax = _axes(ax)
    t = np.asarray(traj.t)
    from ..invariants import BOUNDED, EXACT, KIND_TEXT, QUANTITIES

    decl = _declaration([traj])
    if invariants is None:
        solid = decl.quantities()
    else:
        solid = [_LEGACY_NAMES.get(k, k) for k in invariants]
        unknown = sorted(k for k in solid if k not in QUANTITIES or (k == "jacobi" and k not in decl.entries))
        if unknown:
            raise ValueError(f"conservation: invariants must be among 'energy', 'casimir', 'momentum', "
                             f"'spatial_momentum_e3' (and 'jacobi' when the run declares it); got {unknown}")
    keys = ["energy", "casimir", "spatial_momentum"] + [k for k in _shown(solid) if k in _SERIES_ORDER[3:]]
    note = decl.note(short=True)
    if invariants is None and not decl.entries and (getattr(traj, "meta", None) or {}).get("system") == "spacecraft":
        # the control and the disturbances change the energy and the momenta by design: no error to
        # draw but the attitude's distance from SO(3) (the torques: disturbances.png, the summary)
        keys, note = [], note.replace(" has no invariants", ": no invariant") + "; drawn: |R^T R - I|"
    for key in keys + ["orthogonality"]:
        err, label = _error(traj, key, decl)
        dashed = key != "orthogonality" and key not in solid
        kind = decl.kind(key)
        if dashed:
            label += " (not an invariant here)"
        elif kind is not None and invariants is None:
            label += f": {KIND_TEXT[kind]}"
        if not dashed and (key == "orthogonality" or kind in (EXACT, BOUNDED)):
            err = _running_max(err)
            label += ", running max"
        tt, yy = _thin_max(t, _floor(err), max_points)
        ax.plot(tt, yy, color=_SERIES_COLORS[key], lw=1.2, ls="--" if dashed else "-", label=label)
    for j, (label, err) in enumerate((extra or {}).items()):
        err = np.asarray(err, dtype=np.float64)
        if err.shape != t.shape:
            raise ValueError(f"conservation: extra[{label!r}] must have shape {t.shape} (one value per sample), "
                             f"got {err.shape}")
        tt, yy = _thin_max(t, _floor(err), max_points)
        ax.plot(tt, yy, color=f"C{4 + j}", lw=1.2, label=str(label))
    _style_log(ax)
    ax.set_xlabel(_UNITS["t"])
    ax.set_ylabel("error (relative, 1)")
    ax.set_title(f"Conservation: {_label(traj)}\n({note})", fontsize="medium")
    _legend_below(ax)
    return fig


def iterations(traj: Trajectory, axes: Sequence[Axes] | None = None, *, max_points: int = MAX_POINTS) -> Figure:
    """Solver updates per step (top) and the final residual of each step's solve (bottom).

    Step ``k`` (from ``t_k`` to ``t_k + h``) is drawn at ``t_k``. A record per saved interval
    (``solver_record="interval"`` with ``save_every > 1``) draws the largest of each interval
    from sample ``t_i`` to ``t_{i+1}``, and the title gives the mean over every step. Long
    records are binned: the top panel then shows the mean per bin with the bin's range shaded,
    the bottom the bin's maximum.

    Parameters
    ----------
    traj : Trajectory
        A run of :func:`lgvi.simulate` (baselines have no per-step record: ``ValueError``).
    axes : two matplotlib Axes, optional
    max_points : int
        Most points per curve.

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check_traj(traj, "iterations")
    its = np.asarray(traj.iterations, dtype=np.float64)
    res = np.asarray(traj.residual, dtype=np.float64)
    if not has_solver_record(traj):
        raise ValueError("iterations: this trajectory has no per-step solver record "
                         f"(method {traj.meta.get('method', '?')!r}); only lgvi.simulate runs have one")
    fig, (ax_i, ax_r) = _axes_list(axes, 2, "iterations")
    h = float(traj.h)
    n = len(its)
    meta = traj.meta or {}
    # a record per saved interval of more than one step: entry i spans samples i .. i+1
    per_interval = meta.get("solver_record") == "interval" and n == len(traj.t) - 1 and traj.steps != n
    tk = np.asarray(traj.t[:-1], dtype=np.float64) if per_interval else float(traj.t[0]) + h * np.arange(n)
    what = "largest per saved interval" if per_interval else "updates in step $k$"
    nb = _bins(n, max_points)
    if nb == 0:
        ax_i.step(tk, its, where="post", color="tab:blue", lw=1.2, label=what)
    else:
        edges = np.linspace(0, n, nb + 1).astype(np.int64)
        start = edges[:-1]
        mean = np.add.reduceat(its, start) / np.diff(edges)
        lo = np.minimum.reduceat(its, start)
        hi = np.maximum.reduceat(its, start)
        unit = "intervals" if per_interval else "steps"
        ax_i.fill_between(tk[start], lo, hi, step="post", color="tab:blue", alpha=0.25,
                          label=f"range over bins of {n // nb} {unit}")
        ax_i.step(tk[start], mean, where="post", color="tab:blue", lw=1.2,
                  label="mean per bin" + (" of the interval maxima" if per_interval else ""))
    top = max(1.0, float(its.max()) if n else 1.0)
    ax_i.set_ylim(-0.05 * top, top * 1.15 + 0.5)
    ax_i.yaxis.get_major_locator().set_params(integer=True)
    ax_i.set_ylabel("solver updates (1)")
    ax_i.grid(True, alpha=0.3)
    mean_all = traj.solver_summary["iterations_mean"] if per_interval else (its.mean() if n else 0)
    ax_i.set_title(f"Implicit solves: method {meta.get('method', '?')!r}, tol {meta.get('tol', '?')}, "
                   f"mean {mean_all or 0:.2f} updates/step")
    ax_i.legend(loc="upper right", fontsize="small", framealpha=0.85)
    # residuals are absolute (units of h Pi), often far below 1e-17, and often exactly zero:
    # exact zeros are left out (gaps) and counted in the legend
    positive = np.isfinite(res) & (res > 0)
    rfloor = float(res[positive].min()) if positive.any() else ERROR_FLOOR
    tt, rr = _thin_max(tk, np.where(positive, res, np.nan), max_points)
    label = r"$|\mathrm{vee}(F J_d - J_d F^T) - h\Pi_k|$" + (", largest per interval" if per_interval else "")
    zeros = int(np.count_nonzero(res == 0))
    if zeros:
        label += f"; {zeros / len(res):.0%} of {'intervals' if per_interval else 'steps'} exactly 0 (gaps)"
    ax_r.plot(tt, rr, color="tab:purple", lw=0.8, label=label)
    ax_r.set_yscale("log")
    ax_r.grid(True, which="major", alpha=0.3)
    top = float(np.nanmax(rr)) if np.isfinite(rr).any() else rfloor
    tol = meta.get("tol")
    if isinstance(tol, (int, float)) and tol > 0 and len(traj.Pi):
        level = float(tol) * abs(h) * float(np.linalg.norm(traj.Pi[0]))
        ax_r.axhline(level, color="0.4", ls=":", lw=1.0, label=r"tolerance tol $|h\,\Pi_0|$")
        top = max(top, level)
    ax_r.set_ylim(rfloor / 3, top * 1e3)
    ax_r.set_ylabel(r"residual (kg m$^2$)")
    ax_r.set_xlabel(r"time $t_i$ of the interval's start (s)" if per_interval else r"time $t_k$ of the step (s)")
    ax_r.legend(loc="upper right", fontsize="small", framealpha=0.85)
    return fig


# ------------------------------------------------------------------------------------------------
# polhode
# ------------------------------------------------------------------------------------------------
def polhode_curves(moments: Sequence[float], radius: float, energies: Sequence[float], *,
                   points: int = 241) -> list[np.ndarray]:
    """Analytic polhodes: where the momentum sphere meets energy ellipsoids, in principal axes.

    Parameters
    ----------
    moments : (3,) array_like
        Principal moments ``I1 <= I2 <= I3`` (ascending, positive).
    radius : float
        ``|Pi|``, the radius of the momentum sphere.
    energies : sequence of float
        Kinetic energies ``E``, each in ``[|Pi|^2 / (2 I3), |Pi|^2 / (2 I1)]``.
    points : int
        Points per closed curve.

    Returns
    -------
    list of (points, 3) ndarray
        Closed curves ``{Pi : |Pi| = radius, Pi . diag(1/I) Pi = 2E}``: two per energy (around
        the ``+`` and ``-`` end of the axis they circle), or, on the separatrix
        ``E = |Pi|^2 / (2 I2)``, the two great circles through the middle axis.
    """
    I1, I2, I3 = (float(m) for m in moments)
    if not 0 < I1 <= I2 <= I3:
        raise ValueError(f"polhode_curves: moments must be positive and ascending, got {tuple(moments)}")
    L2 = float(radius) ** 2
    phi = np.linspace(0.0, 2.0 * np.pi, points)
    c, s = np.cos(phi), np.sin(phi)
    curves: list[np.ndarray] = []
    for E in energies:
        two_e = 2.0 * float(E)
        if I1 == I3:
            continue  # a sphere: every momentum is steady
        sep = L2 / I2
        if np.isclose(two_e, sep, rtol=1e-12, atol=0.0) and I1 < I2 < I3:
            k = np.sqrt((1 / I2 - 1 / I3) / (1 / I1 - 1 / I2))
            u2 = np.array([0.0, 1.0, 0.0])
            for sign in (1.0, -1.0):
                u1 = np.array([sign * k, 0.0, 1.0]) / np.hypot(k, 1.0)
                curves.append(np.sqrt(L2) * (np.outer(c, u2) + np.outer(s, u1)))
            continue
        if two_e < sep:  # circles the major axis 3
            a1, a2 = 1 / I1 - 1 / I3, 1 / I2 - 1 / I3
            cc = max(two_e - L2 / I3, 0.0)
            if a2 <= 0:
                continue
            x = np.sqrt(cc / a1) * c
            y = np.sqrt(cc / a2) * s
            z = np.sqrt(np.clip(L2 - x * x - y * y, 0.0, None))
            curves += [np.column_stack([x, y, z]), np.column_stack([x, y, -z])]
        else:  # circles the minor axis 1
            b2, b3 = 1 / I1 - 1 / I2, 1 / I1 - 1 / I3
            d = max(L2 / I1 - two_e, 0.0)
            if b2 <= 0:
                continue
            y = np.sqrt(d / b2) * c
            z = np.sqrt(d / b3) * s
            x = np.sqrt(np.clip(L2 - y * y - z * z, 0.0, None))
            curves += [np.column_stack([x, y, z]), np.column_stack([-x, y, z])]
    return curves


def _principal_axes(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str], list[str]]:
    """Principal moments (ascending), axes (columns, det +1), names and colours.

    An axis that lies on a body axis is named and coloured after it ("body axis 2", green, as
    ``omega_2`` elsewhere); otherwise "principal axis" with the colour of its rank.
    """
    J = np.asarray(inertia, dtype=np.float64)
    moments, V = np.linalg.eigh(0.5 * (J + J.T))
    if np.linalg.det(V) < 0:
        V[:, 0] = -V[:, 0]
    names, colors = [], []
    for i in range(3):
        j = int(np.argmax(np.abs(V[:, i])))
        if abs(abs(V[j, i]) - 1.0) < 1e-12:
            names.append(f"body axis {j + 1}")
            colors.append(_COMPONENT_COLORS[j])
        else:
            names.append(f"principal axis {i + 1}")
            colors.append(_COMPONENT_COLORS[i])
    return moments, V, names, colors


def _polhodes_apply(traj: Trajectory) -> bool:
    """Free-body polhodes describe the run: its system conserves ``|Pi|`` and the energy."""
    decl = _declaration([traj])
    return decl.kind("casimir") is not None and decl.kind("energy") is not None


def _visited_branch(moments: np.ndarray, radius: float, energy: float, p0: np.ndarray) -> list[np.ndarray]:
    """The branch of the polhode of ``energy`` through ``p0`` (principal coordinates): one curve.

    Below the separatrix the branches circle the major axis 3 on either side (the sign of
    ``p0[2]`` chooses); above it they circle the minor axis 1 (the sign of ``p0[0]``); on it, the
    great circle whose plane ``p0`` is nearer.
    """
    curves = polhode_curves(moments, radius, [energy])
    if len(curves) < 2:
        return curves
    I1, I2, I3 = (float(m) for m in moments)
    two_e, sep = 2.0 * float(energy), float(radius) ** 2 / I2
    if np.isclose(two_e, sep, rtol=1e-12, atol=0.0) and I1 < I2 < I3:
        normals = [np.cross(c[0], c[len(c) // 4]) for c in curves[:2]]  # planes of the great circles
        off = [abs(float(nv @ p0)) / float(np.linalg.norm(nv)) for nv in normals]
        return [curves[int(np.argmin(off))]]
    side = p0[2] if two_e < sep else p0[0]
    return [curves[0] if side >= 0 else curves[1]]


def polhode(traj: Trajectory, ax: Axes | None = None, *, levels: int = 4, max_points: int = MAX_POINTS) -> Figure:
    """The body angular momentum path on the momentum sphere, with analytic polhodes.

    Draws (in body axes, kg m^2/s): a wireframe of the sphere ``|Pi| = |Pi_0|``; ``levels``
    analytic polhodes (intersections of the sphere with energy ellipsoids
    ``Pi . J^-1 Pi = 2E``) on each side of the separatrix, the path ``Pi_k`` of the run, its
    start, and the principal axes; over the path the separatrix and, dashed, the branch of the
    polhode of the run's initial energy that the run follows (the other branch of that energy is
    not drawn). For the free body the path lies on its dashed polhode. For a forced run (a
    system that does not conserve ``|Pi|`` and the energy, see :mod:`lgvi.invariants`) no
    polhode is drawn: free-body polhodes do not apply.

    Parameters
    ----------
    traj : Trajectory
    ax : matplotlib 3D Axes, optional
        Made with ``projection="3d"``; a new figure otherwise.
    levels : int
        Reference polhodes per side of the separatrix.
    max_points : int
        Most points of the path (evenly strided).

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check_traj(traj, "polhode")
    if ax is None:
        fig = _figure(POLHODE_FIGSIZE)
        ax = fig.add_subplot(projection="3d")
    else:
        if getattr(ax, "name", "") != "3d":
            raise ValueError("polhode: ax must be a 3D Axes (add_subplot(projection='3d'))")
        fig = ax.get_figure()
    ax.computed_zorder = False  # draw in the order below, not by depth (keeps the curves on top)
    J = np.asarray(traj.inertia, dtype=np.float64)
    moments, V, names, colors = _principal_axes(J)
    Pi = np.asarray(traj.Pi, dtype=np.float64)
    L = float(np.linalg.norm(Pi[0]))
    scale = max(L, float(np.max(np.linalg.norm(Pi, axis=1))))  # a forced run may leave the sphere
    scale = scale if scale > 0 else 1.0

    if L > 0:  # sphere wireframe
        uu, vv = np.meshgrid(np.linspace(0, 2 * np.pi, 37), np.linspace(0, np.pi, 19))
        ax.plot_wireframe(L * np.cos(uu) * np.sin(vv), L * np.sin(uu) * np.sin(vv), L * np.cos(vv),
                          color="0.75", lw=0.4, alpha=0.6)
    # principal axes
    for i in range(3):
        a = V[:, i] * 1.25 * scale
        ax.plot(*np.column_stack([-a, a]), color=colors[i], lw=1.2, alpha=0.9,
                label=f"{names[i]}, J = {moments[i]:.3g} kg m$^2$")
    # reference polhodes: free-body curves, drawn only for a free body
    free = _polhodes_apply(traj)
    separatrix: list[np.ndarray] = []
    own: list[np.ndarray] = []
    if free and L > 0 and moments[0] < moments[2]:
        I1, I2, I3 = moments
        e_min, e_mid, e_max = L * L / (2 * I3), L * L / (2 * I2), L * L / (2 * I1)
        fr = (np.arange(1, levels + 1) / (levels + 1)) ** 1.5
        energies = [e_min + f * (e_mid - e_min) for f in fr if e_mid > e_min]
        energies += [e_max - f * (e_max - e_mid) for f in fr if e_max > e_mid]
        first = True
        for curve in polhode_curves(moments, L, energies):
            ax.plot(*(curve @ V.T).T, color="tab:olive", lw=0.8, alpha=0.8,
                    label="polhodes (other energies)" if first else None)
            first = False
        if I1 < I2 < I3:
            separatrix = polhode_curves(moments, L, [e_mid])
        E0 = 0.5 * float(Pi[0] @ np.linalg.solve(J, Pi[0]))
        E0 = min(max(E0, e_min), e_max)
        own = _visited_branch(moments, L, E0, V.T @ Pi[0])
    step = max(1, int(np.ceil(len(Pi) / max_points)))
    path = np.vstack([Pi[::step], Pi[-1:]])
    chords = np.linalg.norm(np.diff(path, axis=0), axis=1)
    if len(chords) and float(chords.max()) > 0.15 * max(scale, 1e-300):
        # samples too far apart along the path (sparse saving, or thinning of a long run): joining
        # them would draw chords across the sphere, so show the points themselves
        ax.scatter(*path.T, color="tab:purple", s=3, depthshade=False, label=r"samples $\Pi_k$ of the run")
    else:
        ax.plot(*path.T, color="tab:purple", lw=3.5, alpha=0.55, label=r"path $\Pi_k$ of the run")
    # on top of the path (drawing order, see computed_zorder above): the separatrix, then the run's
    # own analytic branch, dashed, so that both stay visible where they run along the path
    for j, curve in enumerate(separatrix):
        ax.plot(*(curve @ V.T).T, color="tab:orange", lw=1.5, alpha=0.95,
                label="separatrix $E = |\\Pi|^2/(2J_2)$" if j == 0 else None)
    for curve in own:
        ax.plot(*(curve @ V.T).T, color="black", lw=1.0, ls="--",
                label=f"analytic polhode of the run ($E_0$ = {E0:.4g} J)")
    ax.scatter(*Pi[0], color="tab:purple", edgecolor="black", s=40, depthshade=False, label=r"start $\Pi_0$")
    lim = 1.3 * scale
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim, lim)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel(r"$\Pi_1$ (kg m$^2$/s)")
    ax.set_ylabel(r"$\Pi_2$ (kg m$^2$/s)")
    ax.set_zlabel(r"$\Pi_3$ (kg m$^2$/s)")
    if L > 0:
        title = f"Polhode: body momentum on the sphere $|\\Pi|$ = $|\\Pi_0|$ = {L:.4g} kg m$^2$/s"
        if not free:
            title += ("\n(forced run: free-body polhodes do not apply and are not drawn; the path may "
                      "leave the sphere)")
        ax.set_title(title)
    else:
        ax.set_title("Body momentum path (no momentum sphere: $\\Pi_0$ = 0)")
    ax.legend(loc="upper left", fontsize="small", framealpha=0.85)
    return fig


# ------------------------------------------------------------------------------------------------
# animation
# ------------------------------------------------------------------------------------------------
def _box_half_sides(moments: np.ndarray) -> np.ndarray:
    """Half side lengths of the uniform box with these principal moments (unit mass, scaled to 1)."""
    I1, I2, I3 = moments
    sq = 6.0 * np.array([I2 + I3 - I1, I1 + I3 - I2, I1 + I2 - I3])  # side^2 for unit mass
    sides = np.sqrt(np.clip(sq, 0.0, None))
    sides = sides / sides.max()
    return 0.5 * np.maximum(sides, 0.04)  # a flat body still gets a visible thickness


_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
_FACES = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]


def animate(traj: Trajectory, path: str | os.PathLike[str], *, fps: int = 30, max_frames: int = 300,
            dpi: int = DPI) -> Path:
    """Animate the body: a box shaped by the principal moments, its axes and the momentum vector.

    The box is the uniform box with the body's principal moments (flat bodies get a thin slab),
    turned by ``R_k``; its principal axes are drawn in red, green and blue (body axes 1, 2, 3
    when the principal axes are body axes), the spatial angular momentum ``R Pi`` as a black
    arrow (scaled to the largest ``|R Pi|`` of the run), and the trace of the tip of the axis of
    intermediate moment. Frames are evenly spread over the run.

    Parameters
    ----------
    traj : Trajectory
    path : str or os.PathLike
        Output file: ``.gif`` (Pillow, always available) or ``.mp4`` (needs ``ffmpeg`` on PATH).
    fps : int
        Frames per second of the file.
    max_frames : int
        Most frames (the run is sampled evenly, first and last sample included).
    dpi : int
        Resolution (the frame is 6 x 6 inches).

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        Unsupported suffix, ``fps < 1`` or ``max_frames < 1``.
    RuntimeError
        ``.mp4`` requested but ffmpeg is not available.
    """
    _check_traj(traj, "animate")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ValueError(f"animate: path must end in .gif or .mp4, got {str(path)!r}")
    if int(fps) < 1 or int(max_frames) < 1:
        raise ValueError(f"animate: fps and max_frames must be >= 1, got fps={fps}, max_frames={max_frames}")
    _mpl()
    from matplotlib import animation
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    if suffix == ".mp4":
        if not animation.writers.is_available("ffmpeg"):
            raise RuntimeError(f"animate: writing {path.name} needs ffmpeg, which is not on PATH; install ffmpeg "
                               "or save a .gif instead (Pillow, always available)")
        writer = animation.FFMpegWriter(fps=int(fps))
    else:
        writer = animation.PillowWriter(fps=int(fps))

    moments, V, names, colors = _principal_axes(traj.inertia)
    half = _box_half_sides(moments)
    verts_body = (_CORNERS * half) @ V.T            # box corners in body axes
    axes_body = (V * 1.35 * half.max() * 1.6).T     # rows: principal axes (body frame), length ~1.1
    R = np.asarray(traj.R, dtype=np.float64)
    Lsp = np.asarray(traj.spatial_momentum, dtype=np.float64)
    Lmax = float(np.max(np.linalg.norm(Lsp, axis=1))) or 1.0
    n = len(R)
    frames = np.unique(np.linspace(0, n - 1, min(n, int(max_frames))).round().astype(np.int64))
    # trace of the tip of axis 2, sampled finer than the frames (at most ~20 points per frame)
    stride = max(1, int(np.ceil(n / (20 * len(frames)))))
    fine = np.unique(np.concatenate([np.arange(0, n, stride), frames]))
    tip = np.einsum("mij,j->mi", R[fine], axes_body[1])
    upto = np.searchsorted(fine, frames, side="right")  # trace points shown at each frame

    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 6.0), dpi=dpi)  # fixed layout: a layout engine would cost a pass per frame
    ax = fig.add_subplot(projection="3d")
    fig.subplots_adjust(left=0.02, right=0.95, bottom=0.04, top=0.95)
    ax.grid(False)
    lim = 1.2
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim, lim)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("inertial x")
    ax.set_ylabel("inertial y")
    ax.set_zlabel("inertial z")
    box = Poly3DCollection([], facecolor="lightsteelblue", edgecolor="0.3", linewidths=0.6, alpha=0.55)
    ax.add_collection3d(box)
    axis_lines = [ax.plot([], [], [], color=colors[i], lw=2.2, label=f"{names[i]}, J = {moments[i]:.3g} kg m²")[0]
                  for i in range(3)]
    mom_line = ax.plot([], [], [], color="black", lw=2.5, label="spatial momentum R Π (scaled)")[0]
    mom_head = ax.plot([], [], [], "k^", ms=7)[0]
    trace = ax.plot([], [], [], color=colors[1], lw=0.8, alpha=0.6)[0]  # tip of the intermediate axis
    title = ax.set_title("")
    ax.legend(loc="upper left", fontsize="x-small", framealpha=0.85)

    def draw(j: int):
        k = frames[j]
        Rk = R[k]
        v = verts_body @ Rk.T
        box.set_verts([v[list(f)] for f in _FACES])
        for i, line in enumerate(axis_lines):
            a = Rk @ axes_body[i]
            line.set_data_3d([0.0, a[0]], [0.0, a[1]], [0.0, a[2]])
        m = Lsp[k] / Lmax * 1.1
        mom_line.set_data_3d([0.0, m[0]], [0.0, m[1]], [0.0, m[2]])
        mom_head.set_data_3d([m[0]], [m[1]], [m[2]])
        tr = tip[: upto[j]]
        trace.set_data_3d(tr[:, 0], tr[:, 1], tr[:, 2])
        title.set_text(f"t = {traj.t[k]:8.3f} s")
        return [box, *axis_lines, mom_line, mom_head, trace, title]

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), blit=False)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda tmp: anim.save(os.fspath(tmp), writer=writer, dpi=dpi), by_path=True,
                 what="animation")
    return path


# ------------------------------------------------------------------------------------------------
# files
# ------------------------------------------------------------------------------------------------
def _save(fig: Figure, path: Path) -> Path:
    _mpl()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    import matplotlib

    FigureCanvasAgg(fig)  # render with Agg whatever the session's backend
    # A dense curve of MAX_POINTS points rasterised by Agg in one piece holds tens of MB of coverage
    # cells at once (measured); in pieces of AGG_CHUNK vertices a few. Matplotlib's own chunking
    # (agg.path.chunksize) drops the vertex at each cut, leaving a gap of two segments in the
    # curve, so the long lines are cut here, into pieces that share their end vertices.
    undo = _cut_long_lines(fig, AGG_CHUNK)
    try:
        with matplotlib.rc_context({"agg.path.chunksize": 0}):   # atomically, never through a link
            write_atomic(path, lambda fh: fig.savefig(fh, dpi=DPI, format="png"), what="figure")
    finally:
        undo()
    return path


def _cut_long_lines(fig: Figure, piece: int) -> Callable[[], None]:
    """Draw every plain line (no markers) of more than ``piece`` vertices as consecutive pieces of
    at most ``piece`` vertices that share their end vertices (the first piece is the line itself,
    so legends still point to it). Returns the function that puts the figure back."""
    from matplotlib.lines import Line2D

    changed: list[tuple[Any, Any, Any]] = []
    added: list[Any] = []
    for ax in fig.axes:
        for line in list(ax.get_lines()):
            x, y = line.get_xdata(orig=True), line.get_ydata(orig=True)
            n = len(x)
            if n <= piece or line.get_marker() not in (None, "None", "", " ") or line.get_drawstyle() != "default":
                continue
            changed.append((line, x, y))
            step = piece - 1
            line.set_data(x[:piece], y[:piece])
            for i0 in range(step, n - 1, step):
                part = Line2D(x[i0:i0 + piece], y[i0:i0 + piece])
                part.update_from(line)
                part.set_label("_nolegend_")
                part.set_zorder(line.get_zorder())
                ax.add_line(part)
                added.append(part)

    def undo() -> None:
        for part in added:
            part.remove()
        for line, x, y in changed:
            line.set_data(x, y)

    return undo


def _attitude_panels(traj: Trajectory) -> Figure:
    """MRPs (top) and quaternion (bottom), both free of gimbal lock: the figure ``attitude.png``
    of :func:`save_figures` (Euler angles: :func:`attitude` with ``kind="euler"``)."""
    fig = _figure(ATTITUDE_PANELS_FIGSIZE)
    ax_e, ax_q = fig.subplots(2, 1)  # not shared: either panel may show only the start
    attitude(traj, "mrp", ax=ax_e)
    attitude(traj, "quaternion", ax=ax_q)
    zoom = ax_e.get_title().partition("; ")[2]
    ax_e.set_title("Attitude (body to inertial): modified Rodrigues parameters" + (f"; {zoom}" if zoom else ""),
                   fontsize="medium")
    zoom = ax_q.get_title().partition("; ")[2]
    ax_q.set_title("unit quaternion, scalar-last (x, y, z, w), sign-continuous" + (f"; {zoom}" if zoom else ""),
                   fontsize="medium")
    for ax in (ax_e, ax_q):
        _legend_right(ax)
    return fig


def save_figures(traj: Trajectory, outdir: str | os.PathLike[str], *, prefix: str = "") -> list[Path]:
    """Write the figures of one trajectory as PNG files (pixel sizes in :data:`FIGURE_PIXELS`).

    Files ``{prefix}attitude.png``, ``rates.png``, ``conservation.png``, ``iterations.png``
    (only for runs with a per-step solver record, see :func:`has_solver_record`) and
    ``polhode.png`` (only where the polhodes mean something: runs that keep ``|Pi|`` and the
    energy, the free body) in ``outdir`` (created if needed), and ``wheels.png`` for a run with
    reaction wheels.

    Parameters
    ----------
    traj : Trajectory
    outdir : str or os.PathLike
    prefix : str
        Prepended to every file name.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order above.

    A result of :func:`lgvi.simulate_orbit` gets ``{prefix}orbit.png`` (:func:`orbit`), one of
    :func:`lgvi.simulate_two_body` ``{prefix}two_body.png`` (:func:`two_body`), one of
    :func:`lgvi.simulate_chain` ``{prefix}chain.png`` (:func:`lgvi.plot.chain.chain`).
    """
    from ..trajectory import Trajectory

    system = (getattr(traj, "meta", None) or {}).get("system")
    if system in _SYSTEM_FIGURES and not isinstance(traj, Trajectory):   # orbit, two bodies, chain
        out = Path(outdir)
        out.mkdir(parents=True, exist_ok=True)
        return [_save(_SYSTEM_FIGURES[system](traj), out / f"{prefix}{system}.png")]
    _check_traj(traj, "save_figures")
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    makers = {"attitude": attitude, "rates": rates, "conservation": conservation, "iterations": iterations,
              "polhode": polhode}
    has_record = has_solver_record(traj)
    written = []
    for name in FIGURE_NAMES:
        if (name == "iterations" and not has_record) or (name == "polhode" and not _polhodes_apply(traj)):
            continue          # a polhode means something only where |Pi| and the energy are kept
        fig = _attitude_panels(traj) if name == "attitude" else makers[name](traj)
        written.append(_save(fig, out / f"{prefix}{name}.png"))
    if getattr(traj, "wheel_speed", None) is not None:     # a run with reaction wheels
        written.append(_save(wheels(traj), out / f"{prefix}wheels.png"))
    if isinstance(getattr(traj, "signals", None), dict):   # the compiled loop's records (lgvi.plot.loop)
        from .loop import save_loop_figures

        written += save_loop_figures(traj, out, prefix=prefix)
    return written


def comparison(trajs: Mapping[str, Trajectory], axes: Sequence[Axes] | None = None, *,
               extra: Mapping[str, Callable[[Trajectory], Any]] | None = None,
               max_points: int = MAX_POINTS) -> Figure:
    """Conservation diagnostics of several trajectories overlaid: one panel per quantity.

    Parameters
    ----------
    trajs : mapping of label -> Trajectory
        E.g. ``{"lgvi": traj, "RK45": rk}``; the labels go into the legend.
    axes : sequence of matplotlib Axes, optional
        Panels for the energy, ``|Pi|``, spatial momentum and orthogonality errors, then one per
        ``extra`` entry; a new figure otherwise (2 x 2 panels, 2 x 3 with extras).
    extra : mapping of title -> callable, optional
        More panels: ``extra[title](traj)`` returns the ``(M,)`` error series of a trajectory,
        e.g. the vertical momentum error of a heavy top.
    max_points : int
        Most points per curve.

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    The panels are the invariants of the problem (the declaration of the first trajectory that
    records one, see :func:`lgvi.invariants.declared`): for the free body the energy, ``|Pi|``
    and ``R Pi``; under uniform gravity the energy and ``e3 . R Pi``; under the gravity gradient
    the Jacobi integral; then ``|R^T R - I|``. The quantities that are not invariants are left
    out, and the figure's title says which.
    """
    if not isinstance(trajs, Mapping) or not trajs:
        raise ValueError("comparison: trajs must be a non-empty mapping of label -> Trajectory")
    for label, tr in trajs.items():
        _check_traj(tr, f"comparison[{label!r}]")
    extra = dict(extra or {})
    from ..invariants import EXACT, KIND_TEXT, QUANTITIES

    decl = _declaration(list(trajs.values()))
    keys = _shown(decl.quantities()) + ["orthogonality"]
    # round-off quantities as their running maximum (a comb between zero and a few ulps otherwise)
    envelope = {k for k in keys if k == "orthogonality" or decl.kind(k) == EXACT}
    n_panels = len(keys) + len(extra)
    if axes is None:
        ncols = 2 if n_panels <= 4 else 3
        nrows = -(-n_panels // ncols)
        fig = _figure(COMPARISON_FIGSIZE if ncols == 2 else (13.0, 3.5 * nrows))
        grid = fig.subplots(nrows, ncols, sharex=True)
        axs = list(np.ravel(grid))
        for ax in axs[n_panels:]:
            ax.set_visible(False)
        axs = axs[:n_panels]
    else:
        axs = list(np.ravel(np.asarray(axes, dtype=object)))
        if len(axs) != n_panels:
            raise ValueError(f"comparison: axes must be {n_panels} Axes ({len(keys)} for the invariants of "
                             f"{decl.system} and |R^T R - I|, + one per extra), got {len(axs)}")
        fig = axs[0].get_figure()
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    titles = {k: _CONSERVATION_TITLES[k] + (f"\n{KIND_TEXT[decl.kind(k)]} for the LGVI" if decl.kind(k) else "")
              + (", running max" if k in envelope else "") for k in keys}
    for j, (label, tr) in enumerate(trajs.items()):
        series = {key: _error(tr, key, decl)[0] for key in keys}
        for name, fn in extra.items():
            series[name] = np.asarray(fn(tr), dtype=np.float64)
        for ax, key in zip(axs, list(titles) + list(extra)):
            err = _running_max(series[key]) if key in envelope else series[key]
            tt, yy = _thin_max(np.asarray(tr.t), _floor(err), max_points)
            ax.plot(tt, yy, color=cmap(j % 10), lw=1.2, label=str(label))
    for ax, title in zip(axs, list(titles.values()) + list(extra)):
        _style_log(ax)
        ax.set_title(title, fontsize="medium")
        ax.set_ylabel("error (1)")
        ax.set_xlabel(_UNITS["t"])
        ax.tick_params(labelbottom=True)
    handles, labels = axs[0].get_legend_handles_labels()
    if axes is None:   # below the panels, clear of the data
        fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 4), fontsize="small",
                   frameon=False)
    else:
        axs[0].legend(loc="best", fontsize="small", framealpha=0.85)
    missing = [QUANTITIES[k].name for k in decl.not_invariants()]
    fig.suptitle(f"Conservation compared ({decl.note(short=True)}; zeros drawn at 1e-17)"
                 + (f"\nnot invariants here, not shown: {', '.join(missing)}" if missing else ""), fontsize="medium")
    return fig


def save_comparison(trajs: Mapping[str, Trajectory], outdir: str | os.PathLike[str], *,
                    extra: Mapping[str, Callable[[Trajectory], Any]] | None = None) -> list[Path]:
    """Write :func:`comparison` of several trajectories as ``comparison.png`` (1000 x 700 pixels).

    Parameters
    ----------
    trajs : mapping of label -> Trajectory
    outdir : str or os.PathLike
        Folder (created if needed).
    extra : mapping of title -> callable, optional
        More panels, as in :func:`comparison` (the figure is then 1300 pixels wide).

    Returns
    -------
    list of pathlib.Path
        ``[outdir / "comparison.png"]``.
    """
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    return [_save(comparison(trajs, extra=extra), out / "comparison.png")]


# ------------------------------------------------------------------------------------------------
# bodies in orbit and two bodies (lgvi.simulate_orbit, lgvi.simulate_two_body)
# ------------------------------------------------------------------------------------------------
def _invariant_errors(ax: Axes, traj: Any, keys: Sequence[str]) -> None:
    from ..invariants import QUANTITIES, error_series

    decl = traj.meta.get("invariants", {})
    for key in keys:
        q = QUANTITIES[key]
        err, rel = error_series(traj, key)
        kind = decl.get(key, {}).get("kind", "not an invariant")
        ax.plot(traj.t, np.maximum(err, ERROR_FLOOR), lw=1.0,
                label=f"{q.tex} ({kind}){'' if rel else ', absolute'}")
    _style_log(ax)
    ax.set_xlabel(_UNITS["t"])
    ax.set_ylabel("relative change")
    ax.legend(fontsize=7, loc="best")         # not over a curve at the floor (an exact zero)


def orbit(traj: Any) -> Figure:
    """Orbit and attitude of a :class:`lgvi.OrbitTrajectory` together: the orbit in the inertial
    x-y plane with the body's long axis (smallest moment of inertia) drawn along it, the angle
    between that axis and the local vertical, the body rates, and the invariants' changes (log
    scale)."""
    x = np.asarray(traj.x)
    if len(traj.t) == 0:
        raise ValueError("orbit: the trajectory is empty (no samples to plot)")
    fig = _figure(ATTITUDE_PANELS_FIGSIZE)
    (a, b), (c, d) = fig.subplots(2, 2)
    a.plot(x[:, 0], x[:, 1], lw=0.8, color="0.4")
    a.plot([0.0], [0.0], "o", color="tab:orange", ms=8, label="central body")
    k = int(np.argmin(np.diag(np.asarray(traj.inertia))))      # the long axis: smallest moment
    every = max(1, len(x) // 30)
    scale = 0.12 * float(np.abs(x[:, :2]).max())
    axis = np.asarray(traj.R)[::every, :, k]
    a.quiver(x[::every, 0], x[::every, 1], axis[:, 0], axis[:, 1], color="tab:red", angles="xy",
             scale_units="xy", scale=1.0 / scale, width=0.005, label=f"long axis (body {k + 1})")
    a.set_aspect("equal", adjustable="datalim")
    a.set_xlabel("$x_1$")
    a.set_ylabel("$x_2$")
    a.set_title("orbit (inertial x-y) and the body's long axis", fontsize=9)
    a.legend(fontsize=7, loc="upper right")
    radial = x / np.linalg.norm(x, axis=1, keepdims=True)
    cosang = np.clip(np.einsum("ki,ki->k", np.asarray(traj.R)[:, :, k], radial), -1.0, 1.0)
    b.plot(traj.t, np.degrees(np.arccos(cosang)), lw=0.8, color="tab:red")
    b.set_xlabel(_UNITS["t"])
    b.set_ylabel("deg")
    b.set_title(f"long axis (body {k + 1}) from the local vertical", fontsize=9)
    w = traj.omega
    for i in range(3):
        c.plot(traj.t, w[:, i], lw=0.8, color=_COMPONENT_COLORS[i], label=f"$\\omega_{i + 1}$")
    c.set_xlabel(_UNITS["t"])
    c.set_ylabel(f"body rate ({_UNITS['omega']})")
    c.legend(fontsize=7)
    keys = [k for k in ("angular_momentum", "angular_momentum_e3", "energy") if k in traj.meta.get("invariants", {})]
    _invariant_errors(d, traj, keys or ["angular_momentum", "energy"])
    d.set_title("invariants", fontsize=9)
    fig.suptitle(f"body in a central field ({traj.meta.get('potential', '')} potential"
                 + (f", J2 = {traj.meta['J2']:g})" if traj.meta.get("J2") else ")"), fontsize=10)
    return fig


def two_body(traj: Any) -> Figure:
    """Mutual orbit and spins of a :class:`lgvi.TwoBodyTrajectory`: the relative position
    ``x2 - x1`` in the inertial x-y plane, the distance, both bodies' body rates, and the
    invariants' changes (log scale)."""
    if len(traj.t) == 0:
        raise ValueError("two_body: the trajectory is empty (no samples to plot)")
    d_ = np.asarray(traj.relative_position)
    fig = _figure(ATTITUDE_PANELS_FIGSIZE)
    (a, b), (c, d) = fig.subplots(2, 2)
    a.plot(d_[:, 0], d_[:, 1], lw=0.8, color="0.4")
    a.plot([0.0], [0.0], "o", color="tab:orange", ms=8, label="body 1")
    a.plot(d_[:1, 0], d_[:1, 1], "o", color="tab:blue", ms=4, label="body 2 at t0")
    a.set_aspect("equal", adjustable="datalim")
    a.set_xlabel("$(x_2 - x_1)_1$")
    a.set_ylabel("$(x_2 - x_1)_2$")
    a.set_title("mutual orbit", fontsize=9)
    a.legend(fontsize=7, loc="upper right")
    b.plot(traj.t, traj.distance, lw=0.8, color="0.3")
    b.set_xlabel(_UNITS["t"])
    b.set_ylabel("$|x_2 - x_1|$")
    b.set_title("distance", fontsize=9)
    w = traj.omega
    for body, style in ((0, "-"), (1, "--")):
        for i in range(3):
            c.plot(traj.t, w[:, body, i], style, lw=0.8, color=_COMPONENT_COLORS[i],
                   label=f"body {body + 1} $\\omega_{i + 1}$")
    c.set_xlabel(_UNITS["t"])
    c.set_ylabel(f"body rate ({_UNITS['omega']})")
    c.set_title("spins (body 1 solid, body 2 dashed)", fontsize=9)
    c.legend(fontsize=6, ncol=2)
    _invariant_errors(d, traj, ["linear_momentum", "angular_momentum", "energy"])
    d.set_title("invariants", fontsize=9)
    fig.suptitle(f"two bodies ({traj.meta.get('potential', '')} mutual potential)", fontsize=10)
    return fig


#: The figure of each other system's result, by ``meta["system"]`` (:func:`save_figures`).
_SYSTEM_FIGURES: dict[str, Callable[[Any], Any]] = {"orbit": orbit, "two_body": two_body}
from .chain import chain as chain  # noqa: E402  (a chain of spherical pendulums: lgvi.plot.chain)

_SYSTEM_FIGURES["chain"] = chain
from .slosh import slosh as slosh  # noqa: E402  (a hub with slosh pendulums: lgvi.plot.slosh)

_SYSTEM_FIGURES["slosh"] = slosh


__all__ = [
    "DPI",
    "ERROR_FLOOR",
    "FIGSIZE",
    "FIGURE_NAMES",
    "FIGURE_PIXELS",
    "animate",
    "attitude",
    "chain",
    "comparison",
    "conservation",
    "has_solver_record",
    "iterations",
    "orbit",
    "polhode",
    "polhode_curves",
    "rates",
    "sampling_note",
    "save_comparison",
    "save_figures",
    "slosh",
    "two_body",
    "wheels",
]
