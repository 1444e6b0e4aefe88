"""The figure of a hub with slosh pendulums (:func:`lgvi.simulate_slosh`): :func:`slosh`."""

from __future__ import annotations

from typing import Any

import numpy as np


def slosh(traj: Any) -> Any:
    """A :class:`lgvi.SloshTrajectory` at a glance: the hub's body rates, each pendulum's angle from
    its initial direction in the hub frame, the distance of the state from its groups (round-off)
    and the changes of the total angular momentum and of the energy (log scale)."""
    from . import ATTITUDE_PANELS_FIGSIZE, ERROR_FLOOR, _UNITS, _figure, _invariant_errors, _style_log

    if len(traj.t) == 0:
        raise ValueError("slosh: the trajectory is empty (no samples to plot)")
    W = np.asarray(traj.omega)
    qb = np.asarray(traj.q_body)
    n = qb.shape[1]
    fig = _figure(ATTITUDE_PANELS_FIGSIZE)
    (a, b), (c, d) = fig.subplots(2, 2)
    for k, name in enumerate(("x", "y", "z")):
        a.plot(traj.t, W[:, k], lw=0.9, label=rf"$\Omega_{name}$")
    a.set_xlabel(_UNITS["t"])
    a.set_ylabel("hub rate (rad/s, body)")
    a.set_title("hub angular velocity", fontsize=9)
    a.legend(fontsize=7, loc="best")
    cosang = np.clip(np.einsum("tia,ia->ti", qb, qb[0]), -1.0, 1.0)
    for i in range(n):
        b.plot(traj.t, np.degrees(np.arccos(cosang[:, i])), lw=0.8, label=f"pendulum {i + 1}" if n <= 8 else None)
    b.set_xlabel(_UNITS["t"])
    b.set_ylabel("angle from its initial direction (deg)")
    b.set_title("slosh: pendulum directions in the hub frame", fontsize=9)
    if n <= 8:
        b.legend(fontsize=7, loc="best")
    for err, label in ((traj.unit_error, r"largest $||q_i| - 1|$"), (traj.orthogonality_error, r"$\|R^TR - I\|$")):
        worst = np.maximum.accumulate(np.asarray(err))           # a step line, not round-off noise
        c.plot(traj.t, np.maximum(worst, ERROR_FLOOR), lw=1.2, label=label + " so far")
    _style_log(c)
    c.set_xlabel(_UNITS["t"])
    c.set_ylabel("distance from the groups")
    c.set_title(r"$R$ on SO(3), $q_i$ on $S^2$", fontsize=9)
    c.legend(fontsize=7, loc="best")
    _invariant_errors(d, traj, ["angular_momentum", "energy"])
    wheels = getattr(traj, "n_wheels", 0)
    motors = wheels and (traj.meta.get("controller") or traj.meta.get("wheel_torque"))
    d.set_title("invariants" + (" (the motors change the energy)" if motors else " (damped: the energy falls)"
                                if np.any(traj.damping) else ""), fontsize=9)
    fig.suptitle(f"hub with {n} slosh pendulum{'s' if n > 1 else ''}"
                 + (f" and {wheels} reaction wheel{'s' if wheels > 1 else ''}" if wheels else "")
                 + f" (order {traj.meta.get('order', 2)}, h = {traj.h:g} s)", fontsize=10)
    return fig


__all__ = ["slosh"]
