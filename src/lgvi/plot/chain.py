"""The figure of a chain of spherical pendulums (:func:`lgvi.simulate_chain`): :func:`chain`."""

from __future__ import annotations

from typing import Any

import numpy as np


def chain(traj: Any) -> Any:
    """A :class:`lgvi.ChainTrajectory` at a glance: the chain's outer ends seen from above (the
    path of the last one, the chain at the start and at the end), the height of every joint, the
    unit length of the links (round-off) and the invariants' changes (log scale)."""
    from . import ATTITUDE_PANELS_FIGSIZE, ERROR_FLOOR, _UNITS, _figure, _invariant_errors, _style_log

    if len(traj.t) == 0:
        raise ValueError("chain: the trajectory is empty (no samples to plot)")
    x = np.asarray(traj.positions)
    n = x.shape[1]
    fig = _figure(ATTITUDE_PANELS_FIGSIZE)
    (a, b), (c, d) = fig.subplots(2, 2)
    a.plot(x[:, -1, 0], x[:, -1, 1], lw=0.6, color="0.5", label="last joint's path")
    for k, colour, label in ((0, "tab:blue", "start"), (-1, "tab:red", "end")):
        pts = np.vstack([np.zeros(3), x[k]])
        a.plot(pts[:, 0], pts[:, 1], "o-", color=colour, ms=3, lw=1.2, label=f"chain at the {label}")
    a.set_aspect("equal", adjustable="datalim")
    a.set_xlabel("x (m)")
    a.set_ylabel("y (m)")
    a.set_title("seen from above (pivot at the origin)", fontsize=9)
    a.legend(fontsize=7, loc="upper right")
    for i in range(n):
        b.plot(traj.t, x[:, i, 2], lw=0.8, label=f"joint {i + 1}" if n <= 8 else None)
    b.set_xlabel(_UNITS["t"])
    b.set_ylabel("height z (m)")
    b.set_title("height of the outer end of every link", fontsize=9)
    if n <= 8:
        b.legend(fontsize=7, loc="best")
    worst = np.maximum.accumulate(np.asarray(traj.orthogonality_error))     # a step line, not round-off noise
    c.plot(traj.t, np.maximum(worst, ERROR_FLOOR), lw=1.2, color="0.3")
    _style_log(c)
    c.set_xlabel(_UNITS["t"])
    c.set_ylabel(r"largest $||q_i| - 1|$ so far")
    c.set_title("unit length of the links", fontsize=9)
    keys = [k for k in ("angular_momentum", "angular_momentum_e3", "energy") if k in traj.meta.get("invariants", {})]
    _invariant_errors(d, traj, keys or ["energy"])
    d.set_title("invariants", fontsize=9)
    fig.suptitle(f"chain of {n} spherical pendulums (order {traj.meta.get('order', 2)}, h = {traj.h:g} s)",
                 fontsize=10)
    return fig


__all__ = ["chain"]
