"""The rigid body, ``(R, Pi)`` on ``T*SO(3)``: today's system (:func:`lgvi.simulate`).

Its run object is :class:`lgvi.integrator.Run` (validation once, the kernel choice, the state
carried across chunks); its kernels live in :mod:`lgvi._kernels.stepping`; its invariants are the
free body's or the torque model's (:func:`lgvi.invariants.declaration_of`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..invariants import FREE_BODY, declaration_of
from . import Field, System, register


def _invariants(torque: Any) -> dict[str, dict[str, Any]]:
    return {k: dict(v) for k, v in FREE_BODY.items()} if torque is None else declaration_of(torque)


RIGID_BODY = register(System(
    name="rigid_body",
    doc="one rigid body: attitude R (3, 3) and body angular momentum Pi (3,)",
    state=(Field("R", (3, 3), doc="attitude, body to inertial"),
           Field("Pi", (3,), doc="body angular momentum")),
    records=(Field("iterations", (), np.int32, "solver iterations per step (summed over substeps)"),
             Field("residual", (), np.float64, "final solver residual per step (largest over substeps)")),
    kernels=("stepping:run_chunk", "stepping:run_chunk_cayley", "stepping:run_chunk_forced",
             "stepping:lgvi_step", "stepping:shifted_step", "ensemble_kernels:run_free_parallel",
             "ensemble_kernels:run_forced_parallel"),
    results=("t", "R", "Pi", "inertia", "iterations", "residual", "h", "potential", "meta"),
    scenario_section="body",
    run_factory="lgvi.integrator:Run",
    invariants=_invariants,
))

__all__ = ["RIGID_BODY"]
