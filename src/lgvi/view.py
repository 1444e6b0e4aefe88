"""An interactive page of a :class:`~lgvi.Trajectory`: the body turning in 3D, linked plots, summary.

:func:`write_html` writes one self-contained HTML file that works offline: the JavaScript is the
plotly.js bundled inside the installed ``plotly`` Python package, embedded in the page (about
4.8 MB), never fetched from a network. ``lgvi view TRAJ.npz`` and ``lgvi run`` (its
``report.html``) call it. The page shows

* the body turning in 3D: the uniform box with the body's principal moments, its principal axes
  (red, green, blue), the spatial angular momentum ``R Pi`` (black, scaled to the largest
  ``|R Pi|`` of the run), the path of the tip of the intermediate axis and, for a trajectory with
  a ``wheel_speed`` field, the reaction wheels (a disc per wheel with a spoke turning at the
  wheel's speed relative to the body); play, pause and a time scrubber;
* linked plots against time, each with a cursor at the frame shown: the body rates ``omega``; the
  relative error of every invariant the run declares (:mod:`lgvi.invariants`; none drawn, and a
  note, for a system without invariants); the wheel speeds and a ``control_error`` field when the
  trajectory has them;
* for a run of the compiled loop (``lgvi.simulate`` with an ``lgvi.Spacecraft``) that recorded
  them: the sun's direction (``sun_N``, gold) beside the body; the orbit around the Earth (``r_N``,
  Earth radii) in a second 3D view, the track coloured by mode, the spacecraft's position and the
  sun's direction moving with the frames; and the modes (``mode``, by the names the run's
  ``ModeRules`` gave them) with the eclipses (``shadow``) on a time strip;
* the run's summary: samples, steps, method, the solver's totals, the largest change of each
  declared invariant with its kind, ``|R^T R - I|``, the error estimate, the modes, the scenario.

Long runs are decimated for display, with a note on the page saying so: the animation shows at
most ``max_frames`` evenly spread samples, each curve at most ``max_points`` points (wheel speeds:
the minimum and maximum of every bin; errors: the maximum of every bin, so no excursion is hidden).
The body rates of a run with many samples (more than twice :data:`RATE_BINS`) are drawn per bin: a
transparent band from the bin's minimum to its maximum, in the component's colour, with the middle
of the bin's range as a line on top, so a fast tumble reads as its envelope and its trend, not a
solid block.

**In Jupyter** a trajectory displays this view inline (``Trajectory._repr_mimebundle_`` calls
:func:`mimebundle`). To keep notebooks light, plotly.js (4.8 MB) is embedded only in the *first*
trajectory displayed by a Python process; later displays reuse the copy the page has already
loaded, and each costs only its data (a few hundred KB at the inline defaults,
:data:`INLINE_FRAMES` frames and :data:`INLINE_POINTS` points per curve). A notebook saved with its
outputs keeps that first output and so renders offline. Where the first output was cleared, a
display says so; ``IPython.display.HTML(lgvi.view.html(traj, full_html=False))`` embeds the
library again. ``lgvi.view.display("summary")`` makes every later display the run's summary table
only (a few kB), for light notebooks.

Requires plotly (``pip install 'lgvi[plot]'``); imported only when a page is made.
"""

from __future__ import annotations

import html as _html
import json
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from . import trajectory as _trajectory
from .invariants import KIND_TEXT, QUANTITIES, declared, drifts, error_series

__all__ = ["MAX_FRAMES", "MAX_POINTS", "INLINE_FRAMES", "INLINE_POINTS", "figure", "html", "write_html",
           "mimebundle", "display", "shows", "traced_axis"]

#: Most animation frames of a page (the run is sampled evenly, first and last sample included).
MAX_FRAMES: int = 200
#: Most points per curve of a page.
MAX_POINTS: int = 4000
#: The same for the inline view in Jupyter.
INLINE_FRAMES: int = 100
INLINE_POINTS: int = 1500
#: Most bins of a body rate's band (a panel is about 600 pixels wide: 3 or more a bin). A rate with
#: more than twice as many samples is drawn per bin (at most ``max_points // 3`` bins): a transparent
#: band from the bin's minimum to its maximum, and on top the line through the middle of each bin's
#: range (:func:`_band`). A line through every sample of a detumble, or through each bin's minimum
#: and maximum, fills the panel in solid colour where a rate turns faster than a few pixels, and the
#: components that share a range hide one another; the band shows each one's envelope, the line its
#: trend (the centre of an oscillation a bin spans; a bin's mean would alias an oscillation of about
#: a bin's length into a slower one that is not there).
RATE_BINS: int = 200
#: The opacity of a band's fill.
BAND_OPACITY: float = 0.25
#: Errors below this are drawn at this value on the logarithmic axis (an exact zero has no log).
ERROR_FLOOR: float = 1e-17

_AXIS_COLORS = ("#d62728", "#2ca02c", "#1f77b4")
_ERROR_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd")
_WHEEL_COLORS = ("#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")
#: Colours of the modes (index modulo the length): the orbit's track and the time strip.
MODE_COLORS = ("#d62728", "#e6a700", "#2ca02c", "#1f77b4", "#9467bd", "#8c564b")
_SUN_COLOR = "#e6a700"
#: The Earth's equatorial radius (m): the orbit view's unit.
EARTH_RADIUS = 6378137.0
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
# the 12 triangles of the box (two per face), as indices into _CORNERS
_TRI = np.array([(0, 1, 3), (0, 3, 2), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
                 (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 3, 7), (1, 7, 5)])
_DIV_ID = "lgvi-view"
_inline_library_sent = False
#: What a trajectory shows in Jupyter: ``"view"`` (the interactive view) or ``"summary"`` (the
#: run's summary table only, a few kB); set with :func:`display`.
INLINE: str = "view"


def _plotly():
    try:
        import plotly.graph_objects as go
        from plotly.subplots import make_subplots
    except ImportError as exc:  # pragma: no cover - exercised where plotly is missing
        raise ImportError(f"the interactive view needs plotly ({exc}): pip install 'lgvi[plot]'") from None
    return go, make_subplots


def _system_of(traj: Any) -> Any:
    """The registered system whose page draws ``traj`` (its :attr:`lgvi.systems.System.view`), or
    ``None`` (a rigid body's :class:`~lgvi.Trajectory`, drawn by this module itself)."""
    if isinstance(traj, _trajectory.Trajectory):
        return None
    from .systems import SYSTEMS

    meta = getattr(traj, "meta", None)
    system = SYSTEMS.get(str(meta.get("system"))) if isinstance(meta, Mapping) else None
    return system if system is not None and system.view is not None else None


def shows(traj: Any) -> bool:
    """Whether the page draws ``traj``: an :class:`lgvi.Trajectory`, or a result of a system that
    declares its :class:`lgvi.systems.Scene` (``System.view``)."""
    return isinstance(traj, _trajectory.Trajectory) or _system_of(traj) is not None


def _check(traj: Any, name: str, max_frames: int, max_points: int) -> None:
    if not shows(traj):
        from .systems import SYSTEMS

        shown = ", ".join(k for k, s in SYSTEMS.items() if s.view is not None)
        raise TypeError(f"{name}: traj must be an lgvi.Trajectory or the result of a system with a page "
                        f"({shown}), got {type(traj).__name__}")
    if len(traj.t) == 0:
        raise ValueError(f"{name}: traj has no samples (len(traj.t) == 0): nothing to show")
    for key, val, low in (("max_frames", max_frames, 2), ("max_points", max_points, 10)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < low:
            raise ValueError(f"{name}: {key} must be an integer >= {low}, got {val!r}")


# ------------------------------------------------------------------------------------ geometry
def _principal(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Principal moments, axes (columns, body frame) and names; a diagonal inertia keeps body axes."""
    J = np.asarray(inertia, dtype=np.float64)
    if np.count_nonzero(J - np.diag(np.diag(J))) == 0:
        return np.diag(J).copy(), np.eye(3), ["body x", "body y", "body z"]
    moments, V = np.linalg.eigh(0.5 * (J + J.T))
    return moments, V, ["principal axis 1", "principal axis 2", "principal axis 3"]


#: A rate component whose own range is below this fraction of the range of all three is drawn on an
#: axis of its own (on a shared one it would be a flat line: a fast spin about one axis).
RATES_APART = 0.05


def _rates_apart(omega: np.ndarray) -> bool:
    """Whether a shared axis would flatten a rate component that varies (see :data:`RATES_APART`)."""
    if len(omega) < 2 or not np.all(np.isfinite(omega)):
        return False
    spans = np.ptp(omega, axis=0)
    whole = float(np.max(omega) - np.min(omega))
    return bool(whole > 0 and np.any((spans > 0) & (spans < RATES_APART * whole)))


def traced_axis(moments: Any, rtol: float = 1e-6) -> int:
    """The body axis whose tip the view traces: the symmetry axis of a symmetric body (the moment
    that differs from the two equal ones: a top's nutation and precession), else the axis of the
    intermediate moment (the Dzhanibekov flips). Index into the principal moments given.

    >>> traced_axis([0.13, 0.13, 0.28]), traced_axis([0.2, 0.1, 0.1]), traced_axis([1.0, 3.0, 2.0])
    (2, 0, 2)
    """
    mo = np.asarray(moments, dtype=np.float64)
    order = np.argsort(mo, kind="stable")
    lo, mid, hi = mo[order]
    close = lambda a, b: abs(a - b) <= rtol * max(abs(a), abs(b))   # noqa: E731
    if close(lo, mid) and not close(mid, hi):
        return int(order[2])
    if close(mid, hi) and not close(lo, mid):
        return int(order[0])
    return int(order[1])


def _box_half_sides(moments: np.ndarray) -> np.ndarray:
    """Half sides of the uniform box with these principal moments, the longest scaled to 1/2."""
    I1, I2, I3 = moments
    sides = np.sqrt(np.clip(6.0 * np.array([I2 + I3 - I1, I1 + I3 - I2, I1 + I2 - I3]), 0.0, None))
    sides = sides / sides.max() if sides.max() > 0 else np.ones(3)
    return 0.5 * np.maximum(sides, 0.04)  # a flat body keeps a visible thickness


def _wheel_axes(traj: Any, n: int) -> np.ndarray | None:
    """(n, 3) unit wheel axes (body frame) from ``traj.wheel_axes`` or the metadata, else None."""
    meta = getattr(traj, "meta", None) or {}
    wheels = meta.get("wheels") if isinstance(meta.get("wheels"), Mapping) else {}
    for cand in (getattr(traj, "wheel_axes", None), wheels.get("axes"), meta.get("wheel_axes")):
        if cand is None:
            continue
        try:
            a = np.asarray(cand, dtype=np.float64)
        except (TypeError, ValueError):
            continue
        if a.shape == (n, 3) and np.all(np.isfinite(a)) and np.all(np.linalg.norm(a, axis=1) > 0):
            return a / np.linalg.norm(a, axis=1)[:, None]
    return None


def _optional_series(traj: Any, name: str, m: int) -> np.ndarray | None:
    """A per-sample field the trajectory may have (``wheel_speed``, ``control_error``), as (M, k)."""
    val = getattr(traj, name, None)
    if val is None:
        return None
    a = np.asarray(val, dtype=np.float64)
    if a.size == 0 or a.shape[0] != m:
        return None
    return a.reshape(m, -1)


def _loop_signals(traj: Any) -> dict[str, Any]:
    """What a run of the compiled loop recorded for the page: ``t`` (E,) the record times and,
    where recorded, ``r`` (E, 3) the position (m), ``sun`` (E, 3) the sun's unit direction,
    ``mode`` (E,) and ``shadow`` (E,); empty for other trajectories."""
    sig = getattr(traj, "signals", None)
    if not isinstance(sig, Mapping) or not sig:
        return {}
    t = np.asarray(getattr(traj, "signal_t", ()), dtype=np.float64)
    e = len(t)
    if e == 0:
        return {}
    out: dict[str, Any] = {"t": t}
    for key, name, width in (("r", "r_N", 3), ("sun", "sun_N", 3), ("mode", "mode", 1), ("shadow", "shadow", 1)):
        if name not in sig:
            continue
        a = np.asarray(sig[name], dtype=np.float64).reshape(e, -1)
        if a.shape[1] != width:
            continue
        if key == "r":
            a = np.where(np.all(np.isfinite(a), axis=1, keepdims=True) & (np.linalg.norm(a, axis=1, keepdims=True) > 0),
                         a, np.nan)
            if not np.any(np.isfinite(a[:, 0])):
                continue
        if key == "sun":
            n = np.linalg.norm(a, axis=1, keepdims=True)
            a = np.where(n > 0, a / np.where(n > 0, n, 1.0), np.nan)      # before the sun model ran: none
        out[key] = a[:, 0] if width == 1 else a
    return out


def _orbit_period(loop: Mapping[str, Any]) -> float | None:
    """A loop run's orbital period from its records: ``2 pi`` times the time the recorded position
    ``r`` took over the angle it swept; ``None`` when no position was recorded or it swept at most
    one orbit (the period is then not needed: the run's whole path is drawn)."""
    r = loop.get("r")
    if r is None:
        return None
    ok = np.all(np.isfinite(r), axis=1)
    u, t = r[ok] / np.linalg.norm(r[ok], axis=1, keepdims=True), np.asarray(loop["t"])[ok]
    if len(t) < 3:
        return None
    swept = float(np.sum(np.arccos(np.clip(np.einsum("ij,ij->i", u[1:], u[:-1]), -1.0, 1.0))))
    return 2.0 * np.pi * (t[-1] - t[0]) / swept if swept > 2.0 * np.pi else None


def _at(times: np.ndarray, t: float) -> int:
    """The record in force at ``t``: the last at or before it (the first before any)."""
    return int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1))


def _segments(values: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` index ranges of the runs of equal values."""
    edges = np.concatenate([[0], np.flatnonzero(np.diff(values)) + 1, [len(values)]])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


# ------------------------------------------------------------------------------------ decimation
def _frames(m: int, max_frames: int) -> np.ndarray:
    return np.unique(np.linspace(0, m - 1, min(m, max_frames)).round().astype(np.int64))


def _bins(n: int, max_points: int) -> np.ndarray:
    """Edges of at most ``max_points // 2`` bins covering ``range(n)``."""
    return np.unique(np.linspace(0, n, max(1, max_points // 2) + 1).round().astype(np.int64))


def _f32(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Curves are drawn in single precision (half the page's bytes; far below a pixel)."""
    return t.astype(np.float32), y.astype(np.float32)


def _envelope(t: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """At most ``max_points`` points: the minimum and maximum of each bin, in time order."""
    if len(t) <= max_points:
        return _f32(t, y)
    edges = _bins(len(t), max_points)
    idx = []
    for a, b in zip(edges[:-1], edges[1:]):
        seg = y[a:b]
        i, j = a + int(np.argmin(seg)), a + int(np.argmax(seg))
        idx += sorted({i, j})
    idx = np.asarray(idx)
    return _f32(t[idx], y[idx])


def _bin_max(t: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """At most ``max_points`` points: the maximum of each bin."""
    if len(t) <= max_points:
        return _f32(t, y)
    edges = np.unique(np.linspace(0, len(t), max_points + 1).round().astype(np.int64))
    idx = np.array([a + int(np.argmax(y[a:b])) for a, b in zip(edges[:-1], edges[1:])])
    return _f32(t[idx], y[idx])


def _rate_bins(m: int, max_points: int) -> int:
    """The number of bins of a body rate's band (:data:`RATE_BINS`; band and mean line together at
    most ``max_points`` points), or 0 when its ``m`` samples are drawn as they are."""
    nb = min(RATE_BINS, max_points // 3)
    return nb if m > 2 * nb else 0


def _band(t: np.ndarray, y: np.ndarray, nb: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``nb`` bins of consecutive samples: each bin's mean time, and the minimum, maximum and middle of
    the range of ``y`` in it."""
    edges = np.unique(np.linspace(0, len(t), nb + 1).round().astype(np.int64))[:-1]
    count = np.diff(np.append(edges, len(t)))
    lo, hi = np.minimum.reduceat(y, edges), np.maximum.reduceat(y, edges)
    return np.add.reduceat(t, edges) / count, lo, hi, 0.5 * (lo + hi)


def _rgba(color: str, alpha: float) -> str:
    """``#rrggbb`` as a CSS ``rgba()`` with opacity ``alpha``."""
    r, g, b = (int(color[i:i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r}, {g}, {b}, {alpha})"


def _rate_traces(go: Any, t: np.ndarray, y: np.ndarray, label: str, color: str, max_points: int) -> list[Any]:
    """The traces of one body-rate component ``label`` (``ωx``): the line through its samples, or,
    for many samples, its band (minimum to maximum of each bin, filled, no hover) and the line
    through the middle of each bin's range."""
    nb = _rate_bins(len(t), max_points)
    if not nb:
        tt, yy = _f32(t, y)
        return [go.Scatter(x=tt, y=yy, mode="lines", line=dict(color=color, width=1.3), name=label,
                           legendgroup="rates", showlegend=False,
                           hovertemplate=f"{label} = %{{y:.4g}} rad/s<br>t = %{{x:.4g}} s<extra></extra>")]
    tc, lo, hi, mid = _band(t, y, nb)
    bx, by = _f32(np.concatenate([tc, tc[::-1]]), np.concatenate([hi, lo[::-1]]))
    tt, yy = _f32(tc, mid)
    return [go.Scatter(x=bx, y=by, mode="lines", fill="toself", fillcolor=_rgba(color, BAND_OPACITY),
                       line=dict(width=0, color=color), name=f"{label} range", legendgroup="rates", showlegend=False,
                       hoverinfo="skip"),
            go.Scatter(x=tt, y=yy, mode="lines", line=dict(color=color, width=1.3), name=label, legendgroup="rates",
                       showlegend=False, hovertemplate=f"{label} = %{{y:.4g}} rad/s (middle of the bin's range)<br>"
                                                       "t = %{x:.4g} s<extra></extra>")]


def decimation_note(traj: Any, max_frames: int = MAX_FRAMES, max_points: int = MAX_POINTS) -> str | None:
    """The note a page shows when it decimates the run for display, else ``None``."""
    m = len(traj.t)
    nb = _rate_bins(m, max_points) if _system_of(traj) is None else 0      # a scene has no body rates
    if m <= max_frames and m <= max_points and not nb:
        return None
    nf = len(_frames(m, max_frames))
    parts = [f"Decimated for display: the run has {m:,} saved samples"]
    if m > max_frames:
        parts.append(f"the animation shows {nf} of them (about every {max(1, round((m - 1) / (nf - 1))):,}th)")
    if nb:
        parts.append(f"the body rates in {nb} bins of about {m / nb:.3g} samples (a band from each bin's minimum "
                     "to its maximum, the line through its middle)")
    if m > max_points:
        parts.append(f"each other curve at most {max_points:,} points (wheel speeds: the minimum and maximum of "
                     "every bin; errors: the maximum of every bin)")
    return "; ".join(parts) + ". The trajectory file holds every sample."


# ------------------------------------------------------------------------------------ figure
def figure(traj: Any, *, max_frames: int = MAX_FRAMES, max_points: int = MAX_POINTS):
    """The view as a plotly figure: the 3D body with frames and a scrubber, and the linked plots.

    Parameters
    ----------
    traj : Trajectory, or the result of a system with a page
        A trajectory with ``M >= 1`` samples, or a result whose system declares its
        :class:`lgvi.systems.Scene` (``System.view``: the chain, the slosh hub), drawn from it with
        the same controls, linked plots and invariants. Optional fields, used when present: ``wheel_speed``
        (M, N) rad/s relative to the body, with the wheel axes (N, 3) from ``wheel_axes`` or
        ``meta["wheels"]["axes"]``; ``control_error`` (M,) or (M, k) (the norm is drawn).
    max_frames : int
        Most animation frames (>= 2).
    max_points : int
        Most points per curve (>= 10).

    Returns
    -------
    plotly.graph_objects.Figure

    Raises
    ------
    TypeError
        ``traj`` is not a Trajectory.
    ValueError
        An empty trajectory, or ``max_frames``/``max_points`` out of range.
    ImportError
        plotly is not installed.
    """
    _check(traj, "figure", max_frames, max_points)
    system = _system_of(traj)
    if system is not None:
        return _scene_figure(traj, system.view(traj), max_frames, max_points)
    go, make_subplots = _plotly()
    t = np.asarray(traj.t, dtype=np.float64)
    R = np.asarray(traj.R, dtype=np.float64)
    m = len(t)
    frames = _frames(m, max_frames)
    decl = declared(traj)
    wheel_speed = _optional_series(traj, "wheel_speed", m)
    control = _optional_series(traj, "control_error", m)
    omega = np.asarray(traj.omega, dtype=np.float64)
    loop = _loop_signals(traj)
    rate_rows = ["rates"] * 3 if not _rates_apart(omega) else ["rate x", "rate y", "rate z"]
    panels = list(dict.fromkeys(rate_rows)) + ["invariants"] + (["wheels"] if wheel_speed is not None else []) \
        + (["control"] if control is not None else []) + (["modes"] if "mode" in loop else [])
    titles = {"rates": "body rates ω (rad/s)", "invariants": "relative error of the invariants",
              "wheels": "wheel speeds relative to the body (rad/s)", "control": "control error",
              "rate x": "body rate ωx (rad/s)", "rate y": "body rate ωy (rad/s)", "rate z": "body rate ωz (rad/s)",
              "modes": "modes" + (" and eclipses" if "shadow" in loop else "")}
    n = len(panels)
    # the left column: the body, and below it the orbit around the Earth for a loop run that recorded r_N
    top = (n + 1) // 2 if "r" in loop else n
    specs = [[{"type": "scene", "rowspan": top}, {"type": "xy"}]] + [[None, {"type": "xy"}] for _ in range(top - 1)]
    if top < n:
        specs += [[{"type": "scene", "rowspan": n - top}, {"type": "xy"}]] + [[None, {"type": "xy"}]
                                                                               for _ in range(n - top - 1)]
    names_grid = ["", titles[panels[0]]] + [titles[p] for p in panels[1:top]]
    if top < n:
        names_grid += ["the orbit around the Earth (inertial, Earth radii)", titles[panels[top]]] \
            + [titles[p] for p in panels[top + 1:]]
    fig = make_subplots(rows=n, cols=2, specs=specs, column_widths=[0.52, 0.48], horizontal_spacing=0.07,
                        vertical_spacing=0.09, subplot_titles=names_grid)

    # ---- the 3D body: traces 0.. are redrawn by every frame
    moments, V, names = _principal(traj.inertia)
    half = _box_half_sides(moments)
    verts = (_CORNERS * half) @ V.T                       # box corners, body frame
    axes = (V * 1.6 * half.max() * 1.35).T                # rows: principal axes, body frame
    L = np.asarray(traj.spatial_momentum, dtype=np.float64)     # a system may add to R Pi (wheels)
    Lmax = float(np.max(np.linalg.norm(L, axis=1))) or 1.0
    wheel_axes = _wheel_axes(traj, wheel_speed.shape[1]) if wheel_speed is not None else None
    wheel_geom = []
    if wheel_axes is not None:
        angle = np.concatenate([np.zeros((1, wheel_speed.shape[1])),
                                np.cumsum(0.5 * (wheel_speed[1:] + wheel_speed[:-1]) * np.diff(t)[:, None], axis=0)])
        phi = np.linspace(0.0, 2.0 * np.pi, 25)
        for i, a in enumerate(wheel_axes):
            u = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
            u /= np.linalg.norm(u)
            v = np.cross(a, u)
            reach = float(np.sum(np.abs(a @ V) * half))   # the box's extent along the axis
            c = a * (reach + 0.12)
            wheel_geom.append((c, u, v, angle[:, i], 0.16))

    def body_traces(k: int) -> list[dict[str, Any]]:
        Rk = R[k]
        p = verts @ Rk.T
        out = [dict(x=p[:, 0], y=p[:, 1], z=p[:, 2])]
        for i in range(3):
            a = Rk @ axes[i]
            out.append(dict(x=[0.0, a[0]], y=[0.0, a[1]], z=[0.0, a[2]]))
        s = L[k] / Lmax * 1.15
        out.append(dict(x=[0.0, s[0]], y=[0.0, s[1]], z=[0.0, s[2]]))
        for c, u, v, ang, r in wheel_geom:
            ring = c + r * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
            tip = c + r * (np.cos(ang[k]) * u + np.sin(ang[k]) * v)
            pts = np.vstack([ring, c, tip]) @ Rk.T
            out.append(dict(x=pts[:, 0], y=pts[:, 1], z=pts[:, 2]))
        if "sun" in loop:                  # the sun's direction (inertial), from the body's centre
            d = 1.2 * np.nan_to_num(loop["sun"][_at(loop["t"], t[k])])
            out.append(dict(x=[0.0, d[0]], y=[0.0, d[1]], z=[0.0, d[2]]))
        for d in out:
            for key in ("x", "y", "z"):
                d[key] = np.round(np.asarray(d[key], dtype=np.float64), 5)
        return out

    first = body_traces(int(frames[0]))
    fig.add_trace(go.Mesh3d(**first[0], i=_TRI[:, 0], j=_TRI[:, 1], k=_TRI[:, 2], color="lightsteelblue",
                            opacity=0.6, flatshading=True, name="body (uniform box, same principal moments)",
                            showlegend=True, hoverinfo="skip"), row=1, col=1)
    for i in range(3):
        fig.add_trace(go.Scatter3d(**first[1 + i], mode="lines", line=dict(color=_AXIS_COLORS[i], width=7),
                                   name=f"{names[i]}, J = {moments[i]:.3g} kg m²", hoverinfo="skip"), row=1, col=1)
    fig.add_trace(go.Scatter3d(**first[4], mode="lines+markers", line=dict(color="black", width=8),
                               marker=dict(size=[0, 6], color="black", symbol="diamond"),
                               name="angular momentum R Π (scaled)", hoverinfo="skip"), row=1, col=1)
    for i in range(len(wheel_geom)):
        fig.add_trace(go.Scatter3d(**first[5 + i], mode="lines", line=dict(color=_WHEEL_COLORS[i % 6], width=5),
                                   name=f"wheel {i + 1}", hoverinfo="skip"), row=1, col=1)
    if "sun" in loop:
        fig.add_trace(go.Scatter3d(**first[-1], mode="lines+markers", line=dict(color=_SUN_COLOR, width=6, dash="dash"),
                                   marker=dict(size=[0, 7], color=_SUN_COLOR, symbol="circle"),
                                   name="direction of the sun", hoverinfo="skip"), row=1, col=1)
    n_body = len(first)
    # the path of the tip of one body axis (static), chosen by the body's symmetry: over the whole run,
    # or over the last orbit of a loop run that recorded more than one (three orbits of tumbling, then
    # pointing, draw a tangle that hides the body)
    period = _orbit_period(loop)
    since = None if period is None or t[-1] - t[0] <= period else t[-1] - period
    k0 = 0 if since is None else int(np.searchsorted(t, since))
    fine = np.unique(np.linspace(k0, m - 1, min(m - k0, max_points)).round().astype(np.int64))
    traced = traced_axis(moments)
    tip = np.einsum("mij,j->mi", R[fine], axes[traced])
    fig.add_trace(go.Scatter3d(x=np.round(tip[:, 0], 5), y=np.round(tip[:, 1], 5), z=np.round(tip[:, 2], 5),
                               mode="lines", line=dict(color=_AXIS_COLORS[traced], width=2), opacity=0.45,
                               name=f"path of the {names[traced]} tip" + (
                                   "" if since is None else f", the last orbit (from t = {t[k0]:.6g} s)"),
                               hoverinfo="skip"), row=1, col=1)

    # ---- the orbit around the Earth (a loop run that recorded r_N): track by mode, spacecraft, sun
    orbit_traces = _orbit(fig, go, traj, loop, top + 1, max_points) if top < n else None

    # ---- linked plots (the rates on one axis, or on one each when a shared axis would flatten some)
    for i, lab in enumerate("xyz"):
        for trace in _rate_traces(go, t, omega[:, i], f"ω{lab}", _AXIS_COLORS[i], max_points):
            fig.add_trace(trace, row=1 + panels.index(rate_rows[i]), col=2)
    row = 1 + panels.index("invariants")
    keys = _invariant_traces(fig, go, traj, decl, t, row, max_points, {})
    if wheel_speed is not None:
        for i in range(wheel_speed.shape[1]):
            tt, yy = _envelope(t, wheel_speed[:, i], max_points)
            fig.add_trace(go.Scatter(x=tt, y=yy, mode="lines", line=dict(color=_WHEEL_COLORS[i % 6], width=1.3),
                                     name=f"wheel {i + 1}", showlegend=False,
                                     hovertemplate=f"wheel {i + 1}: %{{y:.4g}} rad/s<extra></extra>"),
                          row=1 + panels.index("wheels"), col=2)
    if control is not None:
        ce = np.linalg.norm(control, axis=1) if control.shape[1] > 1 else control[:, 0]
        tt, yy = _envelope(t, ce, max_points)
        fig.add_trace(go.Scatter(x=tt, y=yy, mode="lines", line=dict(color="black", width=1.3), showlegend=False,
                                 name="control error", hovertemplate="%{y:.4g}<extra></extra>"),
                      row=1 + panels.index("control"), col=2)
    mode_keys = _mode_strip(fig, go, traj, loop, 1 + panels.index("modes")) if "modes" in panels else []
    first_x = fig.get_subplot(1, 2).xaxis.plotly_name.replace("axis", "")
    for r in range(1, n + 1):
        fig.update_xaxes(showticklabels=(r == n), row=r, col=2, **({"matches": first_x} if r > 1 else {}))
    fig.update_xaxes(title_text="time t (s)", row=n, col=2)

    # each panel's key (coloured names); the invariants' kinds, or why none is drawn
    def key(r: int, items: list[tuple[str, str]]) -> None:
        _panel_key(fig, r, items)

    if "rates" in panels:
        key(1 + panels.index("rates"), [(f"ω{lab}", _AXIS_COLORS[i]) for i, lab in enumerate("xyz")])
    key(row, [(f"{QUANTITIES[k].name.split(' (')[0]}: {decl.kind(k)}"
               + (" (running max)" if decl.kind(k) == "exact" else ""), _ERROR_COLORS[j % len(_ERROR_COLORS)])
              for j, k in enumerate(keys)] or [(decl.note(short=True), "#222")])    # in full: the summary
    if wheel_speed is not None:
        key(1 + panels.index("wheels"), [(f"wheel {i + 1}", _WHEEL_COLORS[i % 6])
                                         for i in range(wheel_speed.shape[1])])
    if mode_keys:
        key(1 + panels.index("modes"), mode_keys)

    # the time cursor of every linked plot: a vertical line that each frame moves
    cursors = _cursors(fig, n)
    body_idx = list(range(n_body))
    moving = body_idx + ([] if orbit_traces is None else orbit_traces[0])

    def frame_traces(k: int) -> list[Any]:
        out = [go.Mesh3d(**d) if i == 0 else go.Scatter3d(**d) for i, d in enumerate(body_traces(k))]
        return out + ([] if orbit_traces is None else [go.Scatter3d(**d) for d in orbit_traces[1](float(t[k]))])

    fig.frames = [go.Frame(name=str(j), data=frame_traces(int(k)), traces=moving,
                           layout=dict(shapes=cursors(float(t[k])))) for j, k in enumerate(frames)]
    _controls(fig, t, frames, cursors, n, 1.25)
    if orbit_traces is not None:
        reach = orbit_traces[2]
        fig.update_layout(scene2=dict(xaxis=dict(range=[-reach, reach], title="x (R⊕)"),
                                      yaxis=dict(range=[-reach, reach], title="y (R⊕)"),
                                      zaxis=dict(range=[-reach, reach], title="z (R⊕)"), aspectmode="cube",
                                      camera=dict(eye=dict(x=1.3, y=1.3, z=0.8))))
    return fig


def _controls(fig: Any, t: np.ndarray, frames: np.ndarray, cursors: Any, n: int, lim: float) -> None:
    """The scene's cube, the layout, play and pause, and the time scrubber of a view."""
    fig.update_layout(shapes=cursors(float(t[frames[0]])))
    fig.update_scenes(xaxis=dict(range=[-lim, lim], title="inertial x"), yaxis=dict(range=[-lim, lim], title="inertial y"),
                      zaxis=dict(range=[-lim, lim], title="inertial z"), aspectmode="cube",
                      camera=dict(eye=dict(x=1.45, y=1.45, z=0.9)))
    step_args = dict(mode="immediate", frame=dict(duration=0, redraw=True), transition=dict(duration=0))
    fig.update_layout(
        height=max(620, 230 * n + 160), margin=dict(l=10, r=20, t=40, b=10), uirevision="lgvi",
        legend=dict(x=0.0, y=1.0, xanchor="left", yanchor="top", font=dict(size=10), bgcolor="rgba(255,255,255,0.7)"),
        updatemenus=[dict(type="buttons", direction="left", x=0.0, y=-0.02, xanchor="left", yanchor="top",
                          pad=dict(t=0, r=8), showactive=False,
                          buttons=[dict(label="▶ play", method="animate",
                                        args=[None, dict(mode="immediate", fromcurrent=True,
                                                         frame=dict(duration=60, redraw=True),
                                                         transition=dict(duration=0))]),
                                   dict(label="❚❚ pause", method="animate",
                                        args=[[None], dict(mode="immediate", frame=dict(duration=0, redraw=False),
                                                           transition=dict(duration=0))])])],
        sliders=[dict(active=0, x=0.14, len=0.36, y=-0.01, xanchor="left", yanchor="top", pad=dict(t=0),
                      currentvalue=dict(prefix="t = ", suffix=" s", font=dict(size=12, color="#222")),
                      font=dict(color="rgba(0,0,0,0)"), ticklen=3, minorticklen=0,  # no label per frame
                      steps=[dict(label=f"{t[k]:.4g}", method="animate", args=[[str(j)], step_args])
                             for j, k in enumerate(frames)])])


def _invariant_traces(fig: Any, go: Any, traj: Any, decl: Any, t: np.ndarray, row: int, max_points: int,
                      names: Mapping[str, str]) -> list[str]:
    """The relative error of every declared invariant in the linked plot of ``row`` (log scale; an
    exact one as its running maximum), named by ``names`` or :data:`QUANTITIES`; returns the keys."""
    keys = decl.quantities()
    for j, key in enumerate(keys):
        err, relative = error_series(traj, key, {k: v for k, v in decl.entries[key].items() if k != "kind"})
        if decl.kind(key) == "exact":     # round-off: its running maximum (a comb of zeros and ulps otherwise)
            err = np.fmax.accumulate(np.asarray(err, dtype=np.float64))
        tt, yy = _bin_max(t[1:], np.maximum(err[1:], ERROR_FLOOR), max_points) if len(t) > 1 else (t, err)
        name = names.get(key, QUANTITIES[key].name)
        fig.add_trace(go.Scatter(x=tt, y=yy, mode="lines", showlegend=False,
                                 line=dict(width=1.3, color=_ERROR_COLORS[j % len(_ERROR_COLORS)]),
                                 name=f"{name} ({decl.kind(key)})",
                                 hovertemplate=f"{_html.escape(name)}: %{{y:.3g}}"
                                 f"{'' if relative else ' (absolute)'}<br>t = %{{x:.4g}} s<extra></extra>"),
                      row=row, col=2)
    if keys:
        fig.update_yaxes(type="log", exponentformat="power", row=row, col=2)
    else:  # nothing to draw: the panel keeps only its note
        fig.update_yaxes(visible=False, row=row, col=2)
    return keys


def _cursors(fig: Any, n: int) -> Any:
    """``cursors(t) -> shapes``: the dotted time cursor of each of the ``n`` linked plots."""
    refs = []
    for r in range(1, n + 1):
        sp = fig.get_subplot(r, 2)
        refs.append((sp.xaxis.plotly_name.replace("axis", ""), sp.yaxis.plotly_name.replace("axis", "")))

    def cursors(tk: float) -> list[dict[str, Any]]:
        return [dict(type="line", xref=xr, yref=f"{yr} domain", x0=tk, x1=tk, y0=0, y1=1,
                     line=dict(color="rgba(0,0,0,0.55)", width=1.5, dash="dot")) for xr, yr in refs]

    return cursors


def _panel_key(fig: Any, r: int, items: list[tuple[str, str]]) -> None:
    """A linked plot's key: coloured names in its top left corner."""
    sp = fig.get_subplot(r, 2)
    xr, yr = sp.xaxis.plotly_name.replace("axis", ""), sp.yaxis.plotly_name.replace("axis", "")
    text = "  ".join(f"<span style='color:{c}'>{_html.escape(label)}</span>" for label, c in items)
    fig.add_annotation(text=text, xref=f"{xr} domain", yref=f"{yr} domain", x=0.01, y=0.99, showarrow=False,
                       xanchor="left", yanchor="top", font=dict(size=11), bgcolor="rgba(255,255,255,0.8)")


def _scene_figure(traj: Any, scene: Any, max_frames: int, max_points: int):
    """The view of a system's :class:`lgvi.systems.Scene`: its meshes and lines in 3D at every
    frame, its paths, its panels and the relative error of the invariants its run declares, with the
    same cursors, play, pause and scrubber as the rigid body's view."""
    go, make_subplots = _plotly()
    t = np.asarray(traj.t, dtype=np.float64)
    m = len(t)
    frames = _frames(m, max_frames)
    decl = declared(traj)
    titles = [p[0] for p in scene.panels] + ["relative error of the invariants"]
    n = len(titles)
    specs = [[{"type": "scene", "rowspan": n}, {"type": "xy"}]] + [[None, {"type": "xy"}] for _ in range(n - 1)]
    fig = make_subplots(rows=n, cols=2, specs=specs, column_widths=[0.52, 0.48], horizontal_spacing=0.07,
                        vertical_spacing=0.09, subplot_titles=[""] + titles)

    def moving(k: int) -> list[dict[str, Any]]:
        out = [dict(x=v[k, :, 0], y=v[k, :, 1], z=v[k, :, 2]) for v in (np.asarray(s.vertices) for s in scene.meshes)]
        out += [dict(x=p[k, :, 0], y=p[k, :, 1], z=p[k, :, 2]) for p in (np.asarray(s.points) for s in scene.lines)]
        for d in out:
            for key in ("x", "y", "z"):
                d[key] = np.round(np.asarray(d[key], dtype=np.float64), 5)
        return out

    first = moving(int(frames[0]))
    for s, d in zip(scene.meshes, first):
        tri = np.asarray(s.triangles)
        fig.add_trace(go.Mesh3d(**d, i=tri[:, 0], j=tri[:, 1], k=tri[:, 2], color=s.color, opacity=0.45,
                                flatshading=True, name=s.name, showlegend=True, hoverinfo="skip"), row=1, col=1)
    for s, d in zip(scene.lines, first[len(scene.meshes):]):
        fig.add_trace(go.Scatter3d(**d, mode="lines+markers" if s.markers else "lines",
                                   line=dict(color=s.color, width=s.width),
                                   marker=dict(size=4, color=s.color), name=s.name, hoverinfo="skip"), row=1, col=1)
    n_moving = len(first)
    for s in scene.paths:
        p = np.asarray(s.points, dtype=np.float64)
        fine = np.unique(np.linspace(0, len(p) - 1, min(len(p), max_points)).round().astype(np.int64))
        fig.add_trace(go.Scatter3d(x=np.round(p[fine, 0], 5), y=np.round(p[fine, 1], 5), z=np.round(p[fine, 2], 5),
                                   mode="lines", line=dict(color=s.color, width=s.width), opacity=0.45, name=s.name,
                                   hoverinfo="skip"), row=1, col=1)

    for r, (_, series) in enumerate(scene.panels, start=1):
        for j, (label, y) in enumerate(series):
            tt, yy = _envelope(t, np.asarray(y, dtype=np.float64), max_points)
            fig.add_trace(go.Scatter(x=tt, y=yy, mode="lines", showlegend=False, name=label,
                                     line=dict(color=_ERROR_COLORS[j % len(_ERROR_COLORS)], width=1.3),
                                     hovertemplate=f"{_html.escape(label)} = %{{y:.4g}}<br>t = %{{x:.4g}} s"
                                     "<extra></extra>"), row=r, col=2)
        _panel_key(fig, r, [(label, _ERROR_COLORS[j % len(_ERROR_COLORS)]) for j, (label, _) in enumerate(series)])
    keys = _invariant_traces(fig, go, traj, decl, t, n, max_points, scene.names)
    _panel_key(fig, n, [(f"{scene.names.get(k, QUANTITIES[k].name)}: {decl.kind(k)}"
                         + (" (running max)" if decl.kind(k) == "exact" else ""),
                         _ERROR_COLORS[j % len(_ERROR_COLORS)]) for j, k in enumerate(keys)]
               or [(f"the {scene.title} has no invariants here", "#222")])
    first_x = fig.get_subplot(1, 2).xaxis.plotly_name.replace("axis", "")
    for r in range(1, n + 1):
        fig.update_xaxes(showticklabels=(r == n), row=r, col=2, **({"matches": first_x} if r > 1 else {}))
    fig.update_xaxes(title_text="time t (s)", row=n, col=2)

    cursors = _cursors(fig, n)
    kinds = [go.Mesh3d] * len(scene.meshes) + [go.Scatter3d] * len(scene.lines)
    fig.frames = [go.Frame(name=str(j), data=[kind(**d) for kind, d in zip(kinds, moving(int(k)))],
                           traces=list(range(n_moving)), layout=dict(shapes=cursors(float(t[k]))))
                  for j, k in enumerate(frames)]
    fig.update_layout(legend_title_text=scene.title)
    _controls(fig, t, frames, cursors, n, float(scene.extent))
    return fig


def _orbit(fig: Any, go: Any, traj: Any, loop: dict[str, Any], row: int, max_points: int):
    """The orbit's 3D view at ``row`` of the left column: the Earth, the track (coloured by mode),
    and the traces the frames move (the spacecraft, the sun's direction from the Earth's centre).
    Returns ``(indices of the moving traces, their data at a time t, the axes' half range)``."""
    from .fsw import mode_label

    ts, r = loop["t"], loop["r"] / EARTH_RADIUS
    finite = np.isfinite(r[:, 0])
    reach = float(max(1.7, 1.15 * np.nanmax(np.linalg.norm(r, axis=1))))
    u, v = np.meshgrid(np.linspace(0.0, 2.0 * np.pi, 49), np.linspace(0.0, np.pi, 25))
    ex, ey, ez = np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)
    # the day side lit by the sun of the first record (it turns about 1 deg a day): night dark
    sun0 = next((d for d in loop.get("sun", ()) if np.all(np.isfinite(d))), None)
    lit = np.ones_like(ex) if sun0 is None else np.clip(ex * sun0[0] + ey * sun0[1] + ez * sun0[2], -0.2, 0.2)
    fig.add_trace(go.Surface(x=ex, y=ey, z=ez, surfacecolor=lit, cmin=-0.2, cmax=0.2,
                             colorscale=[[0.0, "#1d3557"], [0.5, "#1d3557"], [1.0, "#9ecae1"]], showscale=False,
                             opacity=0.9, name="the Earth", hoverinfo="skip", showlegend=False,
                             lighting=dict(ambient=0.9, diffuse=0.2, specular=0.0)), row=row, col=1)
    keep = np.unique(np.linspace(0, len(ts) - 1, min(len(ts), max_points)).round().astype(np.int64))
    mode = loop.get("mode")
    groups: dict[int, list[int]] = {}
    for a, b in _segments(mode if mode is not None else np.zeros(len(ts))):
        idx = [int(i) for i in keep[(keep >= a) & (keep < b)]] + ([b] if b < len(ts) else [])   # joined to the next
        groups.setdefault(int(mode[a]) if mode is not None else -1, []).extend(idx + [-1])
    for m, idx in groups.items():
        pts = [None if i < 0 or not finite[i] else r[i] for i in idx]
        xyz = [[None if p is None else round(float(p[c]), 5) for p in pts] for c in range(3)]
        label = "orbit" if m < 0 else f"orbit in {mode_label(traj, m)}"
        fig.add_trace(go.Scatter3d(x=xyz[0], y=xyz[1], z=xyz[2], mode="lines", name=label, hoverinfo="skip",
                                   line=dict(color="#444" if m < 0 else MODE_COLORS[m % len(MODE_COLORS)], width=4)),
                      row=row, col=1)

    def moving(t: float) -> list[dict[str, Any]]:
        j = _at(ts, t)
        p = np.round(np.nan_to_num(r[j]), 5)
        out = [dict(x=[p[0]], y=[p[1]], z=[p[2]])]
        if "sun" in loop:                  # from the Earth's surface out, towards the sun
            d = np.nan_to_num(loop["sun"][j])
            a, b = np.round(1.0 * d, 5), np.round(0.95 * reach * d, 5)
            out.append(dict(x=[a[0], b[0]], y=[a[1], b[1]], z=[a[2], b[2]]))
        return out

    now = moving(float(ts[0]))
    first = len(fig.data)
    fig.add_trace(go.Scatter3d(**now[0], mode="markers", marker=dict(size=6, color="black", symbol="diamond"),
                               name="the spacecraft", hoverinfo="skip"), row=row, col=1)
    if "sun" in loop:
        fig.add_trace(go.Scatter3d(**now[1], mode="lines+markers+text", text=["", "sun"], textposition="top center",
                                   textfont=dict(color="#8a6500", size=12), line=dict(color=_SUN_COLOR, width=7),
                                   marker=dict(size=[0, 8], color=_SUN_COLOR), name="direction of the sun",
                                   showlegend=False, hoverinfo="skip"), row=row, col=1)
    return list(range(first, len(fig.data))), moving, reach


def _mode_strip(fig: Any, go: Any, traj: Any, loop: dict[str, Any], row: int) -> list[tuple[str, str]]:
    """The modes (upper band, named) and the eclipses (lower band, where ``shadow`` < 1/2) against
    time at ``row`` of the right column; returns the panel's key (name, colour)."""
    from .fsw import mode_label

    ts, mode = loop["t"], loop["mode"]
    end = float(ts[-1]) if len(ts) < 2 else float(ts[-1] + (ts[-1] - ts[-2]))
    shadow = loop.get("shadow")
    low = 0.55 if shadow is not None else 0.0
    seen: dict[int, list[tuple[float, float]]] = {}
    for a, b in _segments(mode):
        seen.setdefault(int(mode[a]), []).append((float(ts[a]), float(ts[b]) if b < len(ts) else end))
    span = max(end - float(ts[0]), 1e-300)
    sp = fig.get_subplot(row, 2)
    xr, yr = sp.xaxis.plotly_name.replace("axis", ""), sp.yaxis.plotly_name.replace("axis", "")
    keys = []
    for m, spans in seen.items():
        label, colour = mode_label(traj, m), MODE_COLORS[m % len(MODE_COLORS)]
        x, y = [], []
        for a, b in spans:
            x += [a, b, b, a, a, None]
            y += [low, low, 1.0, 1.0, low, None]
            if (b - a) / span > 0.08:
                fig.add_annotation(text=_html.escape(label), x=0.5 * (a + b), y=0.5 * (low + 1.0), xref=xr, yref=yr,
                                   showarrow=False, font=dict(size=11, color="#222"))
        fig.add_trace(go.Scatter(x=x, y=y, mode="lines", fill="toself", fillcolor=colour, opacity=0.55,
                                 line=dict(color=colour, width=0.5), name=label, showlegend=False,
                                 hovertemplate=f"{_html.escape(label)} (mode {m})<extra></extra>"), row=row, col=2)
        keys.append((f"{label} ({m})", colour))
    if shadow is not None:
        x, y = [], []
        for a, b in _segments((shadow < 0.5).astype(np.int8)):
            if shadow[a] < 0.5:
                ta, tb = float(ts[a]), float(ts[b]) if b < len(ts) else end
                x += [ta, tb, tb, ta, ta, None]
                y += [0.0, 0.0, 0.45, 0.45, 0.0, None]
        if x:
            fig.add_trace(go.Scatter(x=x, y=y, mode="lines", fill="toself", fillcolor="#555", opacity=0.6,
                                     line=dict(color="#555", width=0.5), name="eclipse", showlegend=False,
                                     hovertemplate="eclipse<extra></extra>"), row=row, col=2)
        keys.append(("eclipse", "#555"))
    fig.update_yaxes(range=[0.0, 1.0], tickvals=[0.225, 0.775] if shadow is not None else [0.5],
                     ticktext=["eclipse", "mode"] if shadow is not None else ["mode"], showgrid=False, zeroline=False,
                     fixedrange=True, row=row, col=2)
    return keys


# ------------------------------------------------------------------------------------ summary
def _fmt(x: Any) -> str:
    if x is None:
        return "n/a"
    if isinstance(x, (float, np.floating)):
        return f"{float(x):.4g}"
    return str(x)


def summary_rows(traj: Any, extra: Mapping[str, Any] | None = None) -> list[tuple[str, str]]:
    """``(label, value)`` rows of the run's summary (plain text; the page escapes them)."""
    system = _system_of(traj)
    if system is not None:
        return _scene_summary_rows(traj, system, extra)
    meta = dict(getattr(traj, "meta", None) or {})
    t = np.asarray(traj.t)
    rows: list[tuple[str, str]] = [(str(k), _fmt(v)) for k, v in (extra or {}).items()]
    rows += [("samples", f"{len(t):,}"), ("steps", f"{traj.steps:,}, h = {traj.h:g} s"),
             ("time", f"{t[0]:g} .. {t[-1]:g} s")]
    for key in ("method", "forcing", "order", "torque", "torque_model", "lgvi_version"):
        if key in meta:
            rows.append((key.replace("_", " "), _fmt(meta[key])))
    solver = traj.solver_summary
    if solver["steps"]:
        rows.append(("solver", f"mean {solver['iterations_mean']:.3f} updates per step, max "
                               f"{solver['iterations_max']}, largest residual {solver['residual_max']:.3e}"))
    decl = declared(traj)
    rows.append(("invariants", decl.note()))
    d = drifts(traj, decl)
    for key in decl.quantities():
        q = QUANTITIES[key]
        rel = d[q.rel_key]
        rows.append((f"  {q.name}", f"largest relative change {_fmt(rel)} ({KIND_TEXT[decl.kind(key)]})"))
    if decl.not_invariants():
        rows.append(("not invariants here", ", ".join(QUANTITIES[k].name for k in decl.not_invariants())))
    rows.append(("|RᵀR − I|", f"largest {float(np.max(traj.orthogonality_error)):.3e}"))
    loop = _loop_signals(traj)
    if "mode" in loop:
        from .fsw import mode_label

        rows.append(("modes", ", ".join(f"{mode_label(traj, loop['mode'][a])} ({int(loop['mode'][a])}) from "
                                        f"{loop['t'][a]:g} s" for a, _ in _segments(loop["mode"]))))
    est = traj.error_estimate if "error_estimate" in meta else None
    if est is not None:
        rows.append(("accuracy", est.describe()))
    return rows


def _scene_summary_rows(traj: Any, system: Any, extra: Mapping[str, Any] | None) -> list[tuple[str, str]]:
    """The summary of a system's result drawn from its :class:`lgvi.systems.Scene`."""
    meta = dict(getattr(traj, "meta", None) or {})
    t = np.asarray(traj.t)
    scene = system.view(traj)
    rows: list[tuple[str, str]] = [(str(k), _fmt(v)) for k, v in (extra or {}).items()]
    steps = (len(t) - 1) * int(meta.get("save_every", 1))
    rows += [("system", f"{system.name}: {scene.title}"), ("samples", f"{len(t):,}"),
             ("steps", f"{steps:,}, h = {traj.h:g} s"), ("time", f"{t[0]:g} .. {t[-1]:g} s")]
    for key in ("method", "order", "composition", "partial", "lgvi_version"):
        if key in meta:
            rows.append((key.replace("_", " "), _fmt(meta[key])))
    its, res = np.asarray(getattr(traj, "iterations", [])), np.asarray(getattr(traj, "residual", []))
    if its.size:
        rows.append(("solver", f"at most {int(its.max())} updates per step, largest residual {float(res.max()):.3e}"))
    rows += list(scene.summary)
    decl = declared(traj)
    rows.append(("invariants", f"of the {scene.title}" if decl.entries else f"the {scene.title} has none here"))
    d = drifts(traj, decl)
    for key in decl.quantities():
        rel = d[QUANTITIES[key].rel_key]
        rows.append((f"  {scene.names.get(key, QUANTITIES[key].name)}",
                     f"largest relative change {_fmt(rel)} ({KIND_TEXT[decl.kind(key)]})"))
    return rows


# every rule under .lgvi-view: the inline view in a notebook must not restyle the notebook
_CSS = """
.lgvi-view { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; color: #222; }
.lgvi-view h1 { font-size: 1.35em; margin: 0 0 0.3em 0; }
.lgvi-view h2 { font-size: 1.1em; margin: 1.2em 0 0.4em 0; }
.lgvi-view .lgvi-note { color: #444; background: #f3f6fa; border-left: 3px solid #7a9cc6; padding: 0.3em 0.6em;
                        display: inline-block; margin: 0.3em 0; font-size: 0.9em; }
.lgvi-view table.lgvi-summary { border-collapse: collapse; font-size: 0.9em; margin: 0; }
.lgvi-view table.lgvi-summary td { padding: 0.15em 0.9em 0.15em 0; vertical-align: top; text-align: left;
                                   background: none; border: none; }
.lgvi-view table.lgvi-summary td:first-child { color: #555; white-space: pre; }
.lgvi-view pre { background: #f5f5f5; padding: 0.6em; font-size: 0.85em; overflow-x: auto; text-align: left; }
"""


def _script_safe(text: str) -> str:
    """JSON text safe inside a ``<script>`` element (no ``</``, no ``<!--``)."""
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


def _body(traj: Any, *, title: str | None, summary: Mapping[str, Any] | None, max_frames: int,
          max_points: int, library: str, div_id: str) -> str:
    """The view's HTML fragment: heading, note, figure (with ``library``, a script or ""), summary."""
    fig = figure(traj, max_frames=max_frames, max_points=max_points)
    spec = _script_safe(fig.to_json())
    note = decimation_note(traj, max_frames, max_points)
    head = f"<h1>{_html.escape(title)}</h1>\n" if title else ""
    rows = "\n".join(f"<tr><td>{_html.escape(a)}</td><td>{_html.escape(b)}</td></tr>"
                     for a, b in summary_rows(traj, summary))
    scenario = (getattr(traj, "meta", None) or {}).get("scenario")
    scen = (f"<details><summary>scenario</summary><pre>{_html.escape(str(scenario))}</pre></details>\n"
            if scenario else "")
    did = json.dumps(div_id)
    return (f"{head}" + (f'<p class="lgvi-note">{_html.escape(note)}</p>\n' if note else "")
            + f"{library}<div id=\"{div_id}\" class=\"lgvi-plot\"></div>\n"
            "<script type=\"text/javascript\">\n(function () {\n"
            f"  var el = document.getElementById({did});\n"
            "  if (typeof window.Plotly === 'undefined') {\n"
            "    el.textContent = 'plotly.js is not loaded on this page: display the trajectory with "
            "IPython.display.HTML(lgvi.view.html(traj, full_html=False)) to embed it.';\n    return;\n  }\n"
            f"  var fig = {spec};\n"
            "  Plotly.newPlot(el, {data: fig.data, layout: fig.layout, frames: fig.frames,\n"
            "                      config: {responsive: true, displaylogo: false}});\n"
            "})();\n</script>\n"
            f"<h2>Run summary</h2>\n<table class=\"lgvi-summary\">\n{rows}\n</table>\n{scen}")


def _library() -> str:
    """plotly.js from the installed plotly package, as a script element (AMD loaders kept out)."""
    from plotly.offline import get_plotlyjs

    js = get_plotlyjs()
    if "</script" in js.lower():  # pragma: no cover - the bundle never contains it
        raise RuntimeError("plotly.js contains '</script' and cannot be embedded")
    # in a page with require.js (the classic notebook) the bundle would register as an AMD module
    # instead of defining window.Plotly: hide `define` while it runs
    return ("<script type=\"text/javascript\">window.__lgviDefine = window.define; window.define = undefined;"
            "</script>\n<script type=\"text/javascript\">" + js + "</script>\n"
            "<script type=\"text/javascript\">window.define = window.__lgviDefine;</script>\n")


def html(traj: Any, *, title: str | None = None, summary: Mapping[str, Any] | None = None,
         include_plotlyjs: bool = True, full_html: bool = True, max_frames: int = MAX_FRAMES,
         max_points: int = MAX_POINTS, div_id: str = _DIV_ID) -> str:
    """The view as HTML text.

    Parameters
    ----------
    traj : Trajectory
    title : str, optional
        Heading of the page (default: a description of the run).
    summary : mapping, optional
        Extra ``label: value`` rows placed first in the summary (``lgvi run``: scenario, wall time).
    include_plotlyjs : bool
        Embed plotly.js (from the installed plotly package; about 4.8 MB). Without it the page
        needs ``window.Plotly`` from elsewhere (the inline Jupyter view's later displays).
    full_html : bool
        A whole document (``<!DOCTYPE html>`` ...) or a fragment to place in a page.
    max_frames, max_points : int
        Decimation for display (see the module notes).
    div_id : str
        ``id`` of the plot's element.

    Returns
    -------
    str
    """
    if not isinstance(div_id, str) or not div_id.replace("-", "").replace("_", "").isalnum():
        raise ValueError(f"html: div_id must be letters, digits, '-' and '_', got {div_id!r}")
    if title is None:
        meta = getattr(traj, "meta", None) or {}
        system = _system_of(traj)
        title = (f"lgvi {system.name}: {len(traj.t):,} samples" if system is not None
                 else f"lgvi trajectory: {len(traj.t):,} samples, method {meta.get('method', '?')}")
    body = _body(traj, title=title, summary=summary, max_frames=max_frames, max_points=max_points,
                 library=_library() if include_plotlyjs else "", div_id=div_id)
    if not full_html:
        return f"<div class=\"lgvi-view\"><style>{_CSS}</style>\n{body}</div>\n"
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<title>{_html.escape(title)}</title>\n<style>body {{ margin: 1.2em 2em; }}{_CSS}</style>\n</head>\n"
            f"<body>\n<div class=\"lgvi-view\">\n{body}</div>\n</body>\n</html>\n")


def write_html(traj: Any, path: str | os.PathLike[str], **kwargs: Any) -> Path:
    """Write the self-contained page of ``traj`` to ``path`` (atomically); keywords as :func:`html`.

    Returns
    -------
    pathlib.Path
        The written file.
    """
    text = html(traj, **kwargs)
    path = Path(path)
    from ._files import write_text

    path.parent.mkdir(parents=True, exist_ok=True)
    return write_text(path, text, "page")   # an unpredictable temporary name; a link is refused


def mimebundle(traj: Any, include: Any = None, exclude: Any = None) -> dict[str, str]:
    """Jupyter's rich display of a trajectory (``Trajectory._repr_mimebundle_``).

    ``text/html``: the view at :data:`INLINE_FRAMES` frames and :data:`INLINE_POINTS` points per
    curve, with plotly.js embedded only in the first display of the process (see the module
    notes); ``text/plain``: the trajectory's ``repr``. Without plotly, or for an empty
    trajectory, the plain text only.
    """
    global _inline_library_sent
    plain = repr(traj)
    try:
        import plotly  # noqa: F401
    except ImportError:
        return {"text/plain": plain + "\n(pip install 'lgvi[plot]' for the interactive view)"}
    if len(traj.t) == 0:
        return {"text/plain": plain}
    if INLINE == "summary":
        rows = "\n".join(f"<tr><td>{_html.escape(a)}</td><td>{_html.escape(b)}</td></tr>"
                         for a, b in summary_rows(traj))
        return {"text/plain": plain, "text/html": f"<style>{_CSS}</style><div class=\"lgvi-view\"><table "
                f"class=\"lgvi-summary\">\n{rows}\n</table></div>"}
    div_id = f"lgvi-view-{os.urandom(6).hex()}"
    text = html(traj, full_html=False, include_plotlyjs=not _inline_library_sent, max_frames=INLINE_FRAMES,
                max_points=INLINE_POINTS, div_id=div_id)
    _inline_library_sent = True
    return {"text/plain": plain, "text/html": text}


def display(mode: str) -> None:
    """Choose what a trajectory shows in Jupyter: ``"view"`` (default: the interactive view; the
    first display of a session embeds plotly.js, about 5 MB) or ``"summary"`` (the run's summary
    table, a few kB: light notebooks). ``lgvi.view.write_html`` and ``lgvi view`` are unchanged.

    >>> import lgvi.view
    >>> lgvi.view.display("summary"); lgvi.view.display("view")
    """
    global INLINE
    if mode not in ("view", "summary"):
        raise ValueError(f"display: mode must be 'view' or 'summary', got {mode!r}")
    INLINE = mode


_trajectory.rich_display = mimebundle
