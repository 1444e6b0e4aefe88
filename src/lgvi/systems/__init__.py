"""The system seam: what the driver runs (see ``docs/architecture.md``).

A *system* is a subpackage of :mod:`lgvi.systems` that registers one :class:`System`: its state
layout (the fields saved per sample), its per-step records, its compiled step kernels, its
invariants (read from :mod:`lgvi.invariants`), its result fields and its scenario section. The
driver (:mod:`lgvi.driver`) allocates the result buffers from the layout and runs the system's
run object in compiled chunks, so progress, Ctrl-C, partial results, failures and streaming are
the same for every system.

Today's system is the rigid body (:mod:`lgvi.systems.rigid_body`); a gyrostat, a body in orbit or
two bodies are each a new subpackage plus a :func:`register` call.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np


@dataclass(frozen=True)
class Field:
    """One array of a system's state or record: ``shape`` per sample (or per step) and dtype."""

    name: str
    shape: tuple[int, ...]
    dtype: Any = np.float64
    doc: str = ""

    def empty(self, n: int) -> np.ndarray:
        """``(n, *shape)`` uninitialised (state) buffer."""
        return np.empty((n,) + self.shape, dtype=self.dtype)

    def zeros(self, n: int) -> np.ndarray:
        """``(n, *shape)`` zeroed (record) buffer."""
        return np.zeros((n,) + self.shape, dtype=self.dtype)


@dataclass(frozen=True)
class System:
    """A dynamical system the driver can run.

    Attributes
    ----------
    name : str
        Registry key (``SYSTEMS[name]``); also ``meta["system"]`` of its results.
    doc : str
        One line for help texts and docs.
    state : tuple of Field
        The state saved at every sample, in the order the run's ``advance`` takes its buffers.
    records : tuple of Field
        The per-step records of the solver (after the state buffers in ``advance``).
    kernels : callable
        ``kernels() -> dict``: its compiled step kernels by name (imports them on first call).
    results : tuple of str
        The fields of its result object (e.g. :class:`lgvi.Trajectory`).
    scenario_section : str
        The scenario table that describes the system (``[body]`` for a rigid body).
    run_factory : callable
        Builds the validated run object the driver runs (imported lazily): it has ``k``,
        ``steps``, ``save_every``, ``chunk``, ``advance(n, *state_buffers, *record_buffers, partial)``,
        ``failure(...)``, ``state()``, ``load_state()``, ``trajectory(...)``, ``times(j0, j1)``.
    invariants : callable
        ``invariants(torque) -> dict``: the declaration (:mod:`lgvi.invariants`) of a run of this
        system under ``torque``.
    """

    name: str
    doc: str
    state: tuple[Field, ...]
    records: tuple[Field, ...]
    kernels: Callable[[], dict[str, Any]]
    results: tuple[str, ...]
    scenario_section: str
    run_factory: Callable[..., Any]
    invariants: Callable[[Any], dict[str, dict[str, Any]]]

    def run(self, *args: Any, **kwargs: Any) -> Any:
        """A validated run of this system (see ``run_factory``)."""
        return self.run_factory(*args, **kwargs)


#: The registry of systems by name.
SYSTEMS: dict[str, System] = {}


def register(system: System) -> System:
    """Add ``system`` to :data:`SYSTEMS` (its name must be new)."""
    if system.name in SYSTEMS and SYSTEMS[system.name] is not system:
        raise ValueError(f"a system named {system.name!r} is registered already")
    SYSTEMS[system.name] = system
    return system


from . import rigid_body as rigid_body  # noqa: E402  (registers the rigid body)

__all__ = ["Field", "SYSTEMS", "System", "register"]
