"""What the interactive page (``lgvi view``) draws of a chain of spherical pendulums."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import Scene, SceneLine

_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf")


def chain_scene(traj: Any) -> Scene:
    """The chain in 3D (pivot at the origin, a marker at every joint), the path of its last joint,
    the height of every joint and the kinetic and potential energy against time."""
    x = np.asarray(traj.positions, dtype=np.float64)                       # (M, n, 3)
    m, n = x.shape[:2]
    pts = np.concatenate([np.zeros((m, 1, 3)), x], axis=1)
    heights = tuple((f"joint {i + 1}", x[:, i, 2]) for i in range(n))
    energies = (("kinetic", np.asarray(traj.kinetic_energy)), ("potential", np.asarray(traj.potential_energy)),
                ("total", np.asarray(traj.energy)))
    unit = float(np.max(traj.orthogonality_error))
    return Scene(
        title=f"chain of {n} spherical pendulums",
        lines=(SceneLine("the chain (pivot at the origin)", pts, "#333333", 6.0, True),),
        paths=(SceneLine("path of the last joint", x[:, -1], _COLORS[0], 2.0),),
        extent=1.05 * float(np.sum(traj.lengths)),
        panels=(("height of every joint z (m)", heights), ("energy (J)", energies)),
        names={"angular_momentum_e3": "vertical angular momentum about the pivot",
               "angular_momentum": "angular momentum about the pivot", "energy": "energy"},
        summary=(("links", f"{n}: lengths {np.round(traj.lengths, 6).tolist()} m, masses "
                           f"{np.round(traj.masses, 6).tolist()} kg"),
                 ("gravity", f"{np.round(traj.gravity, 6).tolist()} m/s²"),
                 ("unit length", f"largest ||q_i| − 1| {unit:.2e}")),
    )


__all__ = ["chain_scene"]
