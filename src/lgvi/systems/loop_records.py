"""The compiled loop's records at each component's own rate (``traj.records``, ``docs/loop.md``).

The loop records the bus on one grid, every ``save_every`` steps (every step with
``solver_record="full"``): ``traj.signals[name]``, at ``traj.signal_t``. A signal written by a
component that runs every ``p`` steps changes only at those steps, so its own record is the rows
of the grid at the writer's steps: :class:`Record` (``t``, ``values``, ``period``). When the
writer runs at a multiple of the grid's period the record holds every value it wrote
(``complete``); when it runs faster than the grid (or off it), the grid holds the latest value at
each entry and the record is that (``complete`` is ``False``: record more often to see every write).

A run writes the writers' periods in ``meta["signal_periods"]`` (steps, by signal name), so the
records follow the trajectory into files, streams and ensembles with nothing else stored; a result
saved before this version has no periods and each record is the grid.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Record", "records_of", "signal_periods"]


@dataclass(frozen=True, eq=False)
class Record:
    """One signal at its writer's rate.

    Attributes
    ----------
    name : str
        The signal (``sigma_BR``, ``wheel_command``, ``gyro_B``, ...).
    t : (n,) ndarray
        The times at which its writer ran (and the loop recorded it), seconds.
    values : (n, size) ndarray, or (n,) for ``mode``
        What it wrote then.
    period : float
        Seconds between two rows: the writer's period, or the record grid's when the writer runs
        faster than the grid.
    complete : bool
        Whether every value the writer wrote is here (its period a multiple of the grid's).
    """

    name: str
    t: np.ndarray
    values: np.ndarray
    period: float
    complete: bool

    def __repr__(self) -> str:
        return (f"Record({self.name!r}, {len(self.t)} rows every {self.period:g} s"
                + ("" if self.complete else ", the record grid's (the writer runs faster)") + ")")


def signal_periods(record_layout: list[tuple[str, int, int]], writers: dict[str, list[int]]) -> dict[str, int]:
    """``{name: steps}``: for each recorded signal the shortest period (steps) of the components
    that write it (``writers[name]``: their periods); 1 for the loop's own signals (the truth)."""
    return {name: int(min(writers.get(name) or [1])) for name, _, _ in record_layout}


def records_of(traj: Any) -> dict[str, Record]:
    """``{name: Record}`` of a :class:`lgvi.systems.spacecraft.SpacecraftTrajectory` (see the module)."""
    meta = traj.meta or {}
    per = 1 if meta.get("solver_record") == "full" else int(meta.get("save_every", 1))
    periods = meta.get("signal_periods") or {}
    t, h = traj.signal_t, float(traj.h)
    out = {}
    for name, values in traj.signals.items():
        p = int(periods.get(name, 0))
        if p >= per and p % per == 0:
            rows = slice(None, None, p // per)
            out[name] = Record(name, t[rows], values[rows], abs(h) * p, True)
        else:                    # faster than the grid, off it, or a result without the periods
            out[name] = Record(name, t, values, abs(h) * per, False)
    return out
