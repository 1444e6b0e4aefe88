"""Figures of what the compiled loop recorded (``traj.signals``, ``docs/loop.md``): the attitude
error and rate error (:func:`pointing`), the requested and applied magnetic dipoles
(:func:`dipoles`), the active mode (:func:`modes`), the estimator's error with its 3-sigma bounds
(:func:`estimation`), the disturbance torques (:func:`disturbances`) and a mission's overview
(:func:`mission`: rate, modes, control and knowledge errors, wheel momentum);
:func:`save_loop_figures` writes those the run has. The wheel speeds and motor torques are
:func:`lgvi.plot.wheels`, the body rates :func:`lgvi.plot.rates`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

__all__ = ["pointing", "dipoles", "modes", "estimation", "disturbances", "mission", "save_loop_figures"]

#: Colours of the modes in :func:`mission` (mode index modulo the length).
MODE_COLOURS = ("#f4cccc", "#fff2cc", "#d9ead3", "#cfe2f3", "#d9d2e9")


def _signals(traj: Any, name: str, need: Sequence[str]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    sig = getattr(traj, "signals", None)
    if not isinstance(sig, dict):
        raise TypeError(f"{name}: expected a run of the compiled loop (lgvi.simulate with an lgvi.Spacecraft), got "
                        f"{type(traj).__name__}")
    if not any(n in sig for n in need):
        raise ValueError(f"{name}: the run recorded none of {', '.join(need)} (recorded: {', '.join(sorted(sig))})")
    t = np.asarray(traj.signal_t)
    if len(t) == 0:
        raise ValueError(f"{name}: the run recorded no entries")
    return sig, t


def pointing(traj: Any, axes: Sequence[Any] | None = None, *, max_points: int | None = None) -> Any:
    """Attitude error angle ``4 atan |sigma_BR|`` (degrees, log scale, top), the components of
    ``sigma_BR`` (middle) and of the rate error ``omega_BR_B`` (deg/s, bottom), against time; the
    records in a mode with no control law (:func:`lgvi.io.scenario_loop.pointing_records`) are
    gaps, not a zero error."""
    from . import MAX_POINTS, _UNITS, _axes_list, _thin_minmax

    from ..io.scenario_loop import SETTLE_DEG, pointing_records

    sig, t = _signals(traj, "pointing", ("sigma_BR",))
    n = max_points or MAX_POINTS
    has_rate = "omega_BR_B" in sig
    fig, axs = _axes_list(axes, 3 if has_rate else 2, "pointing")
    live = pointing_records(traj, sig, len(t))[:, None]         # in a mode with no law sigma_BR is cleared: a gap
    s = np.where(live, sig["sigma_BR"], np.nan)
    err = np.degrees(4.0 * np.arctan(np.linalg.norm(s, axis=1)))
    tt, yy = _thin_minmax(t, np.where(err > 0.0, err, np.nan), n)

    axs[0].semilogy(tt, yy, lw=1.2, color="k")
    axs[0].axhline(SETTLE_DEG, ls=":", lw=1.0, color="tab:orange", label=f"settled below {SETTLE_DEG:g} deg (summary)")
    axs[0].legend(loc="upper right", fontsize="small", framealpha=0.85)
    axs[0].set_ylabel("error angle (deg)")
    axs[0].set_title("Attitude error relative to the guidance reference")
    panels = [(axs[1], s, r"$\sigma_{BR}$ (MRP)")]
    if has_rate:
        panels.append((axs[2], np.degrees(np.where(live, sig["omega_BR_B"], np.nan)), r"$\omega_{BR}$ (deg/s, body)"))
    for ax, data, label in panels:
        for i, c in enumerate(("tab:red", "tab:green", "tab:blue")):
            tt, yy = _thin_minmax(t, data[:, i], n)
            ax.plot(tt, yy, lw=1.0, color=c, label="xyz"[i])
        ax.set_ylabel(label)
        ax.legend(loc="upper right", fontsize="small", ncols=3, framealpha=0.85)
    for ax in axs:
        ax.grid(True, alpha=0.3)
        if len(t) > 1:
            ax.set_xlim(t[0], t[-1])          # the whole run: the modes with no law are the gap before
    axs[-1].set_xlabel(_UNITS["t"])
    return fig


def dipoles(traj: Any, axes: Sequence[Any] | None = None, *, max_points: int | None = None) -> Any:
    """The magnetic dipole requested by the control laws (``dipole_request_B``, dashed) and applied
    by the rods (``dipole_B``), body components in A m^2, against time."""
    from . import MAX_POINTS, _UNITS, _axes, _thin_minmax

    sig, t = _signals(traj, "dipoles", ("dipole_B", "dipole_request_B"))
    n = max_points or MAX_POINTS
    fig, ax = _axes(axes[0] if axes else None)
    for name, style in (("dipole_request_B", "--"), ("dipole_B", "-")):
        if name not in sig:
            continue
        for i, c in enumerate(("tab:red", "tab:green", "tab:blue")):
            tt, yy = _thin_minmax(t, sig[name][:, i], n)
            ax.plot(tt, yy, style, lw=1.0, color=c,
                    label=f"{'requested' if name == 'dipole_request_B' else 'applied'} {'xyz'[i]}")
    ax.set_ylabel("dipole (A m$^2$, body)")
    ax.set_xlabel(_UNITS["t"])
    ax.set_title("Magnetic dipole: requested (dashed) and applied by the rods")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize="small", ncols=2, framealpha=0.85)
    return fig


def modes(traj: Any, ax: Any = None) -> Any:
    """The active mode (``mode``) against time, a step plot; the modes by the names the run's
    :class:`lgvi.fsw.ModeRules` gave them (``meta["mode_names"]``), else by index."""
    from ..fsw import mode_label
    from . import _UNITS, _axes

    sig, t = _signals(traj, "modes", ("mode",))
    fig, ax = _axes(ax, (8.0, 2.6))
    m = np.asarray(sig["mode"]).reshape(len(t), -1)[:, 0]
    ax.step(t, m, where="post", lw=1.5, color="tab:purple")
    vals = np.unique(m)
    ax.set_yticks(vals)
    named = "mode_names" in (getattr(traj, "meta", None) or {})
    ax.set_yticklabels([f"{mode_label(traj, v)} ({int(v)})" if named else str(int(v)) for v in vals])
    ax.set_ylim(vals.min() - 0.5, vals.max() + 0.5)
    ax.set_ylabel("mode")
    ax.set_xlabel(_UNITS["t"])
    ax.set_title("Active mode (ModeRules)")
    ax.grid(True, alpha=0.3)
    return fig


def _torques(traj: Any, sig: dict[str, np.ndarray], t: np.ndarray, inertia: Any, mu: float) -> dict[str, np.ndarray]:
    out = {name[4:-2]: np.asarray(sig[name]) for name in sorted(sig) if name.startswith("tau_")
           and name.endswith("_B") and name not in ("tau_dist_B", "tau_control_B", "tau_command_B")}
    if "gravity_gradient" not in out and inertia is not None and "r_N" in sig:   # a run before it was recorded
        J = np.asarray(inertia, dtype=np.float64).reshape(3, 3)
        r = np.asarray(sig["r_N"])
        b = np.einsum("nji,nj->ni", np.asarray(traj.R)[np.searchsorted(np.asarray(traj.t), t)], r)
        out["gravity_gradient"] = 3.0 * mu / np.linalg.norm(r, axis=1)[:, None] ** 5 * np.cross(b, b @ J.T)
    return out


def _shade_shadow(ax: Any, sig: dict[str, np.ndarray], t: np.ndarray) -> None:
    if "shadow" not in sig:
        return
    dark = np.asarray(sig["shadow"]).reshape(len(t), -1)[:, 0] < 0.5
    edges = np.flatnonzero(np.diff(np.concatenate([[0], dark.astype(np.int8), [0]])))
    for k, (a, b) in enumerate(zip(edges[::2], edges[1::2])):
        ax.axvspan(t[a], t[min(b, len(t) - 1)], color="0.88", zorder=0, label="eclipse" if k == 0 else None)


def disturbances(traj: Any, ax: Any = None, *, mu: float = 3.986004418e14, max_points: int | None = None) -> Any:
    """The norm of each disturbance torque recorded (``tau_<kind>_B``, the gravity gradient's
    ``tau_gravity_gradient_B`` too; for a run saved before the loop recorded it, with ``r_N``
    recorded, ``3 mu / |r|^5 b x J b`` with the run's ``inertia``), N m, log scale, eclipses shaded."""
    from . import MAX_POINTS, _UNITS, _axes, _thin_minmax

    sig, t = _signals(traj, "disturbances", tuple(n for n in getattr(traj, "signals", {}) or {}
                                                  if n.startswith("tau_") and n not in ("tau_dist_B", "tau_control_B",
                                                                                       "tau_command_B")) or ("tau_",))
    n = max_points or MAX_POINTS
    fig, ax = _axes(ax, (9.0, 3.8))
    for name, tau in _torques(traj, sig, t, getattr(traj, "inertia", None), mu).items():
        norm = np.linalg.norm(tau, axis=1)
        tt, yy = _thin_minmax(t, np.where(norm > 0.0, norm, np.nan), n)         # none in the shadow: a gap
        ax.semilogy(tt, yy, lw=1.0, label=name.replace("_", " "))
    _shade_shadow(ax, sig, t)
    ax.set_ylabel("|torque| (N m)")
    ax.set_xlabel(_UNITS["t"])
    ax.set_title("Disturbance torques")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower right", fontsize="small", ncols=3, framealpha=0.85)
    return fig


def mission(traj: Any, axes: Sequence[Any] | None = None, *, max_points: int | None = None) -> Any:
    """A mission at a glance: the body rate ``|omega|`` (deg/s, log), the true pointing error (the
    angle of ``R_ref^T R``) and the knowledge error ``|est_error|`` (deg, log), and, for a run with
    wheels, their total momentum in the body frame (N m s); the modes shaded and named (the names
    the run's :class:`lgvi.fsw.ModeRules` gave them, else ``mode <index>``)."""
    from ..fsw import mode_label
    from . import MAX_POINTS, _UNITS, _axes_list, _thin_minmax

    sig, t = _signals(traj, "mission", ("mode",))
    n = max_points or MAX_POINTS
    hw = getattr(traj, "wheel_momentum", None)
    wheels = hw is not None and np.size(hw) > 0
    fig, axs = _axes_list(axes, 3 if wheels else 2, "mission")
    at = np.searchsorted(np.asarray(traj.t), t)
    omega = np.asarray(traj.omega)[at]
    tt, yy = _thin_minmax(t, np.degrees(np.linalg.norm(omega, axis=1)), n)
    axs[0].semilogy(tt, yy, color="k", lw=1.0)
    axs[0].set_ylabel(r"$|\omega|$ (deg/s)")
    axs[0].set_title("Mission: body rate, pointing and knowledge errors" + (", wheel momentum" if wheels else "") + "; modes shaded")
    if "R_ref" in sig:
        R_ref = np.asarray(sig["R_ref"]).reshape(-1, 3, 3)
        live = np.abs(R_ref).sum(axis=(1, 2)) > 0.0                      # a reference is set (its mode runs)
        cos = np.clip((np.einsum("nij,nij->n", R_ref, np.asarray(traj.R)[at]) - 1.0) / 2.0, -1.0, 1.0)
        err = np.where(live, np.degrees(np.arccos(cos)), np.nan)
        tt, yy = _thin_minmax(t, np.maximum(err, 1e-9), n)
        axs[1].semilogy(tt, yy, color="tab:blue", lw=0.8, label="control error (truth vs reference)")
    if "est_error" in sig:
        tt, yy = _thin_minmax(t, np.maximum(np.degrees(np.linalg.norm(np.asarray(sig["est_error"]), axis=1)), 1e-9), n)
        axs[1].semilogy(tt, yy, color="tab:orange", lw=0.8, label="knowledge error (estimate vs truth)")
    axs[1].set_ylabel("error (deg)")
    axs[1].legend(loc="upper right", fontsize="small", framealpha=0.85)
    if wheels:
        tt, yy = _thin_minmax(t, np.linalg.norm(np.asarray(hw)[at] @ np.asarray(traj.wheel_axes), axis=1), n)
        axs[2].plot(tt, yy, color="tab:purple", lw=1.0)
        axs[2].set_ylabel("wheel momentum (N m s)")
    m = np.asarray(sig["mode"]).reshape(len(t), -1)[:, 0]
    start = np.concatenate([[0], np.flatnonzero(np.diff(m)) + 1, [len(t) - 1]])
    seen: set[int] = set()
    for a, b in zip(start[:-1], start[1:]):
        mode = int(m[a])
        for ax in axs:
            ax.axvspan(t[a], t[b], color=MODE_COLOURS[mode % len(MODE_COLOURS)], zorder=0, lw=0,
                       label=mode_label(traj, mode) if ax is axs[0] and mode not in seen else None)
        seen.add(mode)
    axs[0].legend(loc="upper right", fontsize="small", ncols=len(seen), framealpha=0.85)
    for ax in axs:
        ax.grid(True, which="both", alpha=0.3)
    axs[-1].set_xlabel(_UNITS["t"])
    return fig


ARCSEC = 180.0 / np.pi * 3600.0          # arcseconds per radian
DEG_H = 180.0 / np.pi * 3600.0           # deg/h per rad/s


def _band_limits(err: np.ndarray, sig3: np.ndarray) -> tuple[float, float]:
    """Half-height of a panel: 1.3 x the largest of |error| and 3 sigma after the first tenth of the
    records (the filter's transient), and the peak over all records (drawn off the axis if larger)."""
    tail = slice(len(err) // 10, None)
    lim = 1.3 * float(max(np.nanmax(np.abs(err[tail])), np.nanmax(sig3[tail])))
    peak = float(max(np.nanmax(np.abs(err)), np.nanmax(sig3)))
    return (lim if lim > 0.0 else 1.0), peak


def estimation(traj: Any, axes: Sequence[Any] | None = None, *, max_points: int | None = None) -> Any:
    """The estimator's attitude error ``est_error`` (``R = R_est Exp(est_error)``, arcsec, one panel
    per body axis) inside its 3-sigma bounds ``3 sqrt(P_diag[:3])`` (shaded), and, where the gyro's
    true bias ``gyro_bias`` and the estimate ``bias_est`` were recorded, the bias error (deg/h)
    inside ``3 sqrt(P_diag[3:])``, against time.

    Each panel's height is set by the run after its first tenth (the filter's transient); a larger
    early error is drawn off the axis and its peak written in the panel."""
    from . import MAX_POINTS, _UNITS, _axes_list, _figure, _thin_minmax

    sig, t = _signals(traj, "estimation", ("est_error",))
    if "P_diag" not in sig:
        raise ValueError("estimation: the run recorded est_error but not P_diag (the MEKF's covariance diagonal); "
                         "record both")
    n = max_points or MAX_POINTS
    P = np.asarray(sig["P_diag"])
    panels = [(np.asarray(sig["est_error"]) * ARCSEC, np.sqrt(np.maximum(P[:, :3], 0.0)) * 3 * ARCSEC,
               "attitude", "arcsec")]
    if "gyro_bias" in sig and "bias_est" in sig:
        panels.append(((np.asarray(sig["gyro_bias"]) - np.asarray(sig["bias_est"])) * DEG_H,
                       np.sqrt(np.maximum(P[:, 3:6], 0.0)) * 3 * DEG_H, "bias", "deg/h"))
    if axes is None:
        fig = _figure((9.0, 1.7 * 3 * len(panels) + 0.6))
        axs = list(fig.subplots(3 * len(panels), 1, sharex=True))
    else:
        fig, axs = _axes_list(axes, 3 * len(panels), "estimation")
    colours = ("tab:red", "tab:green", "tab:blue")
    for j, (err, sig3, what, unit) in enumerate(panels):
        for i in range(3):
            ax = axs[3 * j + i]
            tt, hi = _thin_minmax(t, sig3[:, i], n)
            ax.fill_between(tt, -hi, hi, color=colours[i], alpha=0.15, lw=0,
                            label=r"$\pm 3\sigma$ (covariance)")
            ax.plot(tt, hi, lw=0.6, color=colours[i], alpha=0.6)
            ax.plot(tt, -hi, lw=0.6, color=colours[i], alpha=0.6)
            tt, yy = _thin_minmax(t, err[:, i], n)
            ax.plot(tt, yy, lw=0.9, color="k", label="error")
            lim, peak = _band_limits(err[:, i], sig3[:, i])
            ax.set_ylim(-lim, lim)
            if peak > lim:
                ax.text(0.01, 0.95, f"early transient off the axis (peak {peak:.3g} {unit})", transform=ax.transAxes,
                        va="top", fontsize="x-small", color="0.3")
            inside = np.mean(np.abs(err[:, i]) <= sig3[:, i])
            ax.set_ylabel(f"{what} {'xyz'[i]}\n({unit})")
            ax.text(0.99, 0.05, f"inside 3$\\sigma$: {inside:.1%}", transform=ax.transAxes, ha="right",
                    va="bottom", fontsize="x-small")
            ax.grid(True, alpha=0.3)
    axs[0].legend(loc="upper right", fontsize="small", ncols=2, framealpha=0.85)
    axs[0].set_title("Estimation error (truth vs estimate, body frame) and the filter's 3-sigma bounds")
    axs[-1].set_xlabel(_UNITS["t"])
    return fig


def save_loop_figures(traj: Any, outdir: str | os.PathLike[str], *, prefix: str = "") -> list[Path]:
    """Write ``pointing.png``, ``dipoles.png``, ``modes.png``, ``estimation.png``,
    ``disturbances.png`` and ``mission.png``, each where the run recorded what it draws
    (``sigma_BR`` in a pointing mode; ``dipole_B`` or ``dipole_request_B``; ``mode``; ``est_error`` and ``P_diag``;
    a disturbance torque; ``mode``). Returns the files."""
    from . import _save

    sig = getattr(traj, "signals", None) or {}
    if len(np.asarray(getattr(traj, "signal_t", ()))) == 0:
        return []
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    torques = tuple(n for n in sig if n.startswith("tau_") and n not in ("tau_dist_B", "tau_control_B", "tau_command_B"))
    from ..io.scenario_loop import pointing_records

    if "sigma_BR" in sig and not pointing_records(traj, sig, len(traj.signal_t)).any():
        sig = {k: v for k, v in sig.items() if k != "sigma_BR"}   # never in a pointing mode: no pointing.png
    figures = (("pointing", pointing, ("sigma_BR",)), ("dipoles", dipoles, ("dipole_B", "dipole_request_B")),
               ("modes", modes, ("mode",)), ("estimation", estimation, ("est_error", "P_diag")),
               ("disturbances", disturbances, torques), ("mission", mission, ("mode",)))
    for name, fn, need in figures:
        if all(n in sig for n in need) if name == "estimation" else any(n in sig for n in need):
            written.append(_save(fn(traj), out / f"{prefix}{name}.png"))
    return written
