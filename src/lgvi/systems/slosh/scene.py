"""What the interactive page (``lgvi view``) draws of a hub with slosh pendulums."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import Scene, SceneLine, SceneMesh

_AXIS_COLORS = ("#d62728", "#2ca02c", "#1f77b4")
_COLORS = ("#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
# the 12 triangles of the box (two per face), as indices into _CORNERS
_TRIANGLES = np.array([(0, 1, 3), (0, 3, 2), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
                       (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 3, 7), (1, 7, 5)])


def hub_box(inertia: Any, mass: float) -> tuple[np.ndarray, np.ndarray]:
    """Half sides (3,) and axes (columns, body frame) of the uniform box with the hub's mass and
    principal moments: ``a_i^2 = 3 (J_j + J_k - J_i) / (2 m)`` (a side is kept at 5 % of the
    largest where the moments allow no box)."""
    J = np.asarray(inertia, dtype=np.float64)
    moments, V = np.linalg.eigh(0.5 * (J + J.T))
    sq = 1.5 / mass * (moments.sum() - 2.0 * moments)
    half = np.sqrt(np.maximum(sq, 0.0))
    return np.maximum(half, 0.05 * half.max()), V


def slosh_scene(traj: Any) -> Scene:
    """The hub (its box and principal axes), every pendulum from its pivot to its mass and the
    total angular momentum (scaled; fixed in space to round-off), seen from the hub's centre of
    mass; the hub's rates and each pendulum's angle in the hub from its start against time."""
    R = np.asarray(traj.R, dtype=np.float64)
    q = np.asarray(traj.q, dtype=np.float64)
    m, n = q.shape[:2]
    half, V = hub_box(traj.inertia, traj.hub_mass)
    pivots = np.einsum("tab,ib->tia", R, np.asarray(traj.pivots, dtype=np.float64))     # inertial (M, n, 3)
    ends = pivots + np.asarray(traj.lengths)[None, :, None] * q
    extent = 1.15 * max(float(np.linalg.norm(half)),
                        float(np.max(np.linalg.norm(traj.pivots, axis=1) + traj.lengths)))
    box = np.einsum("tab,vb->tva", R, (_CORNERS * half) @ V.T)
    axes = tuple(SceneLine(f"hub axis {i + 1}", np.stack([np.zeros((m, 3)), R @ (V[:, i] * 1.3 * half.max())], 1),
                           _AXIS_COLORS[i], 6.0) for i in range(3))
    pend = tuple(SceneLine(f"pendulum {i + 1}: {traj.masses[i]:g} kg, {traj.lengths[i]:g} m",
                           np.stack([pivots[:, i], ends[:, i]], axis=1), _COLORS[i % len(_COLORS)], 6.0, True)
                 for i in range(n))
    L = np.asarray(traj.angular_momentum, dtype=np.float64)
    Lmax = float(np.max(np.linalg.norm(L, axis=1))) or 1.0
    momentum = SceneLine("total angular momentum (scaled)", np.stack([np.zeros((m, 3)), L / Lmax * 0.9 * extent], 1),
                         "#000000", 7.0)
    omega = np.asarray(traj.omega, dtype=np.float64)
    qb = np.asarray(traj.q_body, dtype=np.float64)
    cosang = np.clip(np.einsum("tia,ia->ti", qb, qb[0]), -1.0, 1.0)
    angles = tuple((f"pendulum {i + 1}", np.degrees(np.arccos(cosang[:, i]))) for i in range(n))
    return Scene(
        title=f"hub with {n} slosh pendulums",
        meshes=(SceneMesh("hub (uniform box, its mass and principal moments)", box, _TRIANGLES),),
        lines=axes + pend + (momentum,),
        extent=extent,
        panels=(("hub rates ω (rad/s)", tuple((f"ω{c}", omega[:, i]) for i, c in enumerate("xyz"))),
                ("pendulum angle in the hub from its start (deg)", angles)),
        names={"angular_momentum": "total angular momentum R Π + Σ π_i", "energy": "kinetic energy"},
        summary=(("hub", f"{traj.hub_mass:g} kg, principal moments "
                         f"{np.round(np.linalg.eigvalsh(traj.inertia), 6).tolist()} kg m²"),
                 ("pendulums", f"{n}: lengths {np.round(traj.lengths, 6).tolist()} m, masses "
                               f"{np.round(traj.masses, 6).tolist()} kg, damping "
                               f"{np.round(traj.damping, 6).tolist()} N s/m"),
                 ("on the manifolds", f"largest |RᵀR − I| {float(np.max(traj.orthogonality_error)):.2e}, "
                                      f"largest ||q_i| − 1| {float(np.max(traj.unit_error)):.2e}")),
    )


__all__ = ["hub_box", "slosh_scene"]
