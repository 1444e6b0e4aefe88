"""Figures of what the compiled loop recorded (``traj.signals``, ``docs/loop.md``): the attitude
error and rate error (:func:`pointing`), the requested and applied magnetic dipoles
(:func:`dipoles`) and the active mode (:func:`modes`); :func:`save_loop_figures` writes those the
run has. The wheel speeds and motor torques are :func:`lgvi.plot.wheels`, the body rates
:func:`lgvi.plot.rates`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

__all__ = ["pointing", "dipoles", "modes", "save_loop_figures"]


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
    ``sigma_BR`` (middle) and of the rate error ``omega_BR_B`` (deg/s, bottom), against time."""
    from . import MAX_POINTS, _UNITS, _axes_list, _thin_minmax

    sig, t = _signals(traj, "pointing", ("sigma_BR",))
    n = max_points or MAX_POINTS
    has_rate = "omega_BR_B" in sig
    fig, axs = _axes_list(axes, 3 if has_rate else 2, "pointing")
    s = sig["sigma_BR"]
    err = np.degrees(4.0 * np.arctan(np.linalg.norm(s, axis=1)))
    tt, yy = _thin_minmax(t, np.maximum(err, 1e-12), n)
    from ..io.scenario_loop import SETTLE_DEG

    axs[0].semilogy(tt, yy, lw=1.2, color="k")
    axs[0].axhline(SETTLE_DEG, ls=":", lw=1.0, color="tab:orange", label=f"settled below {SETTLE_DEG:g} deg (summary)")
    axs[0].legend(loc="upper right", fontsize="small", framealpha=0.85)
    axs[0].set_ylabel("error angle (deg)")
    axs[0].set_title("Attitude error relative to the guidance reference")
    panels = [(axs[1], s, r"$\sigma_{BR}$ (MRP)")]
    if has_rate:
        panels.append((axs[2], np.degrees(sig["omega_BR_B"]), r"$\omega_{BR}$ (deg/s, body)"))
    for ax, data, label in panels:
        for i, c in enumerate(("tab:red", "tab:green", "tab:blue")):
            tt, yy = _thin_minmax(t, data[:, i], n)
            ax.plot(tt, yy, lw=1.0, color=c, label="xyz"[i])
        ax.set_ylabel(label)
        ax.legend(loc="upper right", fontsize="small", ncols=3, framealpha=0.85)
    for ax in axs:
        ax.grid(True, alpha=0.3)
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
    """The active mode (``mode``) against time, a step plot."""
    from . import _UNITS, _axes

    sig, t = _signals(traj, "modes", ("mode",))
    fig, ax = _axes(ax, (8.0, 2.6))
    m = np.asarray(sig["mode"]).reshape(len(t), -1)[:, 0]
    ax.step(t, m, where="post", lw=1.5, color="tab:purple")
    vals = np.unique(m)
    ax.set_yticks(vals)
    ax.set_yticklabels([str(int(v)) for v in vals])
    ax.set_ylim(vals.min() - 0.5, vals.max() + 0.5)
    ax.set_ylabel("mode")
    ax.set_xlabel(_UNITS["t"])
    ax.set_title("Active mode (ModeRules)")
    ax.grid(True, alpha=0.3)
    return fig


def save_loop_figures(traj: Any, outdir: str | os.PathLike[str], *, prefix: str = "") -> list[Path]:
    """Write ``pointing.png``, ``dipoles.png`` and ``modes.png``, each where the run recorded what it
    draws (``sigma_BR``; ``dipole_B`` or ``dipole_request_B``; ``mode``). Returns the files."""
    from . import _save

    sig = getattr(traj, "signals", None) or {}
    if len(np.asarray(getattr(traj, "signal_t", ()))) == 0:
        return []
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, fn, need in (("pointing", pointing, ("sigma_BR",)), ("dipoles", dipoles, ("dipole_B", "dipole_request_B")),
                           ("modes", modes, ("mode",))):
        if any(n in sig for n in need):
            written.append(_save(fn(traj), out / f"{prefix}{name}.png"))
    return written
