"""Exceptions raised by lgvi."""

from __future__ import annotations

from typing import Any


class ConvergenceError(RuntimeError):
    """The implicit equation ``hat(h Pi) = F Jd - Jd F^T`` was not solved to tolerance.

    Raised instead of returning an unconverged ``F``. Attributes carry what is known:

    Attributes
    ----------
    residual : float
        ``|vee(F Jd - Jd F^T) - h Pi|`` reached by the last iterate.
    iterations : int
        Updates applied before giving up.
    step : int or None
        Index ``k`` of the step that failed (``None`` for a single :func:`lgvi.solve_implicit`).
    time : float or None
        Time ``t_k`` of that step.
    trajectory : lgvi.Trajectory or None
        The part of the run computed before the failed step (states ``0 .. k``).
    """

    def __init__(self, message: str, *, residual: float = float("nan"), iterations: int = 0,
                 step: int | None = None, time: float | None = None, trajectory: Any = None):
        super().__init__(message)
        self.residual = residual
        self.iterations = iterations
        self.step = step
        self.time = time
        self.trajectory = trajectory


class CollisionError(ConvergenceError):
    """Impossible physics: the bodies of a run touched, or a body passed through a centre of
    attraction (:func:`lgvi.simulate_orbit`, :func:`lgvi.simulate_two_body`).

    Raised at the step where it happens, never returned as a result. A subclass of
    :class:`ConvergenceError`, so code that keeps a failed run's partial result keeps this one too.

    Attributes
    ----------
    step, time, trajectory
        As in :class:`ConvergenceError`: the failed step ``k``, its time ``t_k``, and the run up
        to that step (``None`` when the initial state is already in contact).
    distance : float
        The distance between the centres (of mass, or of the central body) where the contact was
        found: the closest approach of the step's path, or the distance at the new state for
        overlapping shapes.
    """

    def __init__(self, message: str, *, step: int | None = None, time: float | None = None,
                 trajectory: Any = None, distance: float = float("nan")):
        super().__init__(message, step=step, time=time, trajectory=trajectory)
        self.distance = distance


class InitialContactError(CollisionError, ValueError):
    """The initial state of a run already has its bodies in contact (bad input: also a
    ``ValueError``); ``step`` 0, ``trajectory`` None."""


class SimulationInterrupted(KeyboardInterrupt):
    """A run was interrupted (Ctrl-C); ``trajectory`` holds the part computed so far."""

    def __init__(self, message: str, trajectory: Any = None):
        super().__init__(message)
        self.trajectory = trajectory


class TorqueError(RuntimeError):
    """A user torque callable raised or returned an invalid value; ``trajectory`` holds the
    part of the run computed before that step."""

    def __init__(self, message: str, *, step: int | None = None, time: float | None = None,
                 trajectory: Any = None):
        super().__init__(message)
        self.step = step
        self.time = time
        self.trajectory = trajectory


class ComponentError(TorqueError):
    """A component of the compiled loop (``docs/components.md``) stopped the run: it returned a
    nonzero status or wrote a value that is not finite. ``component`` names it, ``status`` is its
    code (``lgvi.components.STATUS``); ``step``, ``time`` and ``trajectory`` (the part computed
    before that step) as for :class:`TorqueError`."""

    def __init__(self, message: str, *, component: str = "", status: int = 0, step: int | None = None,
                 time: float | None = None, trajectory: Any = None):
        super().__init__(message, step=step, time=time, trajectory=trajectory)
        self.component = component
        self.status = status


class AccuracyWarning(UserWarning):
    """The estimated error of a run (``simulate(..., error_estimate=True)``) exceeds its threshold
    ``error_warn``; the message gives the estimate and what to change."""


class AttitudeWarning(UserWarning):
    """An attitude matrix slightly off SO(3) (``1e-9 < ||R^T R - I||_F <= 1e-6``, e.g. a rotation
    written with 7 significant digits) was replaced by its nearest rotation."""


__all__ = ["AccuracyWarning", "AttitudeWarning", "CollisionError", "ConvergenceError", "InitialContactError", "SimulationInterrupted", "TorqueError"]
