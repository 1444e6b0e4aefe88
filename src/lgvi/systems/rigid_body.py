"""The rigid body, ``(R, Pi)`` on ``T*SO(3)``: today's system (:func:`lgvi.simulate`).

Its run object is :class:`lgvi.systems.rigid_body_run.Run` (validation once, the kernel choice, the state
carried across chunks; the integrator provides it with :func:`lgvi.systems.provide_run`); its kernels live in :mod:`lgvi._kernels.stepping`; its invariants are the
free body's or the torque model's (:func:`lgvi.invariants.declaration_of`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..invariants import FREE_BODY, declaration_of
from . import Field, System, register


def _invariants(torque: Any) -> dict[str, dict[str, Any]]:
    return {k: dict(v) for k, v in FREE_BODY.items()} if torque is None else declaration_of(torque)


def momentum_matrices(body: Any, codes: np.ndarray, params: np.ndarray, hs: np.ndarray,
                       sym: bool) -> np.ndarray:
    """``(I + hs/2 D J^-1)^-1`` per substep: the symmetric momentum equation of damped models."""
    from .._kernels.torque_kernels import momentum_diag

    # the kernel's Python source (the same sums in the same order, so the same bits): no compiled
    # function loaded, or compiled cold, for three numbers on a run's first call
    D = np.array(getattr(momentum_diag, "py_func", momentum_diag)(codes, params), dtype=np.float64)
    A = np.tile(np.eye(3), (len(hs), 1, 1))
    if not sym or not np.any(D):
        return A
    for i, hi in enumerate(hs):
        Mi = np.eye(3) + 0.5 * hi * (D[:, None] * body.J_inv)
        # D J^-1 has real eigenvalues >= 0; a backward (sub)step can make Mi singular
        lam = np.linalg.eigvals(Mi).real.min()
        if not lam > 1e-6:
            raise ValueError(f"the step h={hi:g} (substep {i}) is too large a backward step for "
                             f"the damping of the torque model: I + h/2 D J^-1 is (nearly) singular "
                             f"(smallest eigenvalue {lam:.3g}) in the symmetric momentum equation; "
                             "reduce |h|")
        A[i] = np.linalg.inv(Mi)
    return A


def _kernels() -> dict[str, Any]:
    from .._kernels import ensemble_kernels, stepping

    return {"run_chunk": stepping.run_chunk, "run_chunk_cayley": stepping.run_chunk_cayley,
            "run_chunk_newton": stepping.run_chunk_newton,
            "run_chunk_forced": stepping.run_chunk_forced, "lgvi_step": stepping.lgvi_step,
            "shifted_step": stepping.shifted_step, "run_free_parallel": ensemble_kernels.run_free_parallel,
            "advance_forced": ensemble_kernels.advance_forced}


RIGID_BODY = register(System(
    name="rigid_body",
    doc="one rigid body: attitude R (3, 3) and body angular momentum Pi (3,)",
    state=(Field("R", (3, 3), doc="attitude, body to inertial"),
           Field("Pi", (3,), doc="body angular momentum")),
    records=(Field("iterations", (), np.int32, "solver iterations per step (summed over substeps)"),
             Field("residual", (), np.float64, "final solver residual per step (largest over substeps)")),
    kernels=_kernels,
    results=("t", "R", "Pi", "inertia", "iterations", "residual", "h", "potential", "meta"),
    scenario_section="body",
    run_factory=None,  # lgvi.systems.rigid_body_run provides Run (provide_run)
    invariants=_invariants,
))

__all__ = ["RIGID_BODY", "momentum_matrices"]
