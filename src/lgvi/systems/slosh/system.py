"""The declaration of a rigid hub with spherical slosh pendulums on ``SO(3) x (S^2)^n`` (:data:`SLOSH`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...invariants import BOUNDED, EXACT
from .. import Field, System, register


def slosh_invariants(config: Any) -> dict[str, dict[str, Any]]:
    """The declaration of a run (``config``: a dict with ``damping``, (n,)): the total angular
    momentum exact; the energy bounded without damping (with damping it decreases: no
    declaration). ``R`` on SO(3) and every ``|q_i| = 1`` hold to round-off too."""
    d = np.asarray((config or {}).get("damping", 0.0), dtype=np.float64)
    out: dict[str, dict[str, Any]] = {"angular_momentum": {"kind": EXACT}}
    if not d.any():
        out["energy"] = {"kind": BOUNDED}
    return out


def _kernels() -> dict[str, Any]:
    from ..._kernels import slosh_kernels

    return {"run_slosh": slosh_kernels.run_slosh, "slosh_substep": slosh_kernels.slosh_substep,
            "kick_build": slosh_kernels.kick_build, "kick_apply": slosh_kernels.kick_apply}


def _load(path: Any) -> Any:
    from .run import SloshTrajectory

    return SloshTrajectory.load(path)


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> Any:
    from .run import slosh_from_stream

    return slosh_from_stream(meta, arrays, state)


def slosh_description(traj: Any) -> list[str]:
    """What was simulated (summary lines)."""
    return [f"system:        a rigid hub ({traj.hub_mass:g} kg) with {traj.n_pendulums} spherical slosh pendulums "
            f"(lgvi.simulate_slosh): lengths {np.round(traj.lengths, 6).tolist()} m, masses "
            f"{np.round(traj.masses, 6).tolist()} kg, damping {np.round(traj.damping, 6).tolist()} N s/m, "
            f"order {traj.meta.get('order')}"]


SLOSH = register(System(
    name="slosh",
    doc="a rigid hub with n spherical slosh pendulums: attitude R (3, 3), Pi (3,), directions q (n, 3), pi (n, 3)",
    state=(Field("R", (3, 3), doc="hub attitude"),
           Field("Pi", (3,), doc="hub momentum, body frame"),
           Field("q", ("n", 3), doc="pendulum directions, inertial unit vectors"),
           Field("pi", ("n", 3), doc="pendulum angular momenta, inertial")),
    records=(Field("iterations", (), np.int32, "largest Newton iterations per saved interval"),
             Field("residual", (), np.float64, "largest final Newton residual per saved interval")),
    kernels=_kernels,
    results=("t", "R", "Pi", "q", "pi", "iterations", "residual", "h", "meta"),
    scenario_section="slosh",
    run_factory=None,
    invariants=slosh_invariants,
    from_stream=_from_stream,
    describe=slosh_description,
    saved_as=("lgvi.slosh/1", _load),
))
