"""Optimal attitude control and gradients through the discrete LGVI flow.

- :func:`gradient` (and :func:`rollout`, :func:`cost_gradient`): the discrete adjoint of an LGVI
  run, the gradient of a cost (:class:`Effort`, :class:`AttitudeError`, :class:`RateError`,
  :class:`Terminal`) with respect to the controls, the initial state, the inertia and the step;
- :func:`transfer`: a state-to-state transfer (minimum energy or minimum time) on the discrete
  LGVI by a direct method with adjoint gradients;
- :func:`identify_inertia`: least-squares fit of the inertia (and the initial state) to a noisy
  attitude and/or rate series.

The equations are in ``docs/optimal.md``.
"""

from .adjoint import (AttitudeError, Effort, Gradient, RateError, Rollout, Terminal, cost_gradient, gradient,
                      rollout)

__all__ = ["AttitudeError", "Effort", "Gradient", "RateError", "Rollout", "Terminal", "cost_gradient", "gradient",
           "rollout"]
from .transfers import InfeasibleTransferError, TransferError, TransferResult, reachable_angle, transfer

__all__ += ["InfeasibleTransferError", "TransferError", "TransferResult", "reachable_angle", "transfer"]
from .identify import InertiaFit, identify_inertia

__all__ += ["InertiaFit", "identify_inertia"]
