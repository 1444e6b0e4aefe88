"""The compiled loop's records at each component's own rate (``traj.records``, ``docs/loop.md``).

The loop records the bus on one grid, every ``save_every`` steps (every step with
``solver_record="full"``): ``traj.signals[name]``, at ``traj.signal_t``. A signal written by a
component that runs every ``p`` steps changes only at those steps. When ``p`` is a multiple of
the grid's period its record is the grid's rows at the writer's steps; otherwise (the writer runs
faster than the grid, or off it) the loop also writes it at each of its writer's steps into
``ceil(grid / p)`` slots of its own columns of the entry's row (``meta["signal_fast"]``; a slot
the entry has no writer step for is NaN). Either way :class:`Record` (``t``, ``values``,
``period``) holds every value the writer wrote (``complete``). The memory this costs is what the
writes are: ``size * ceil(grid / p)`` floats a record entry for such a signal, one chunk of them in
memory when the run streams; ``FlightSoftware(record_rate="grid")`` keeps the grid's columns only,
and its records of the faster writers are the grid's rows (``complete`` is ``False``).

A run writes the writers' periods in ``meta["signal_periods"]`` (steps, by signal name: the
greatest common divisor of its writers' periods), so the records follow the trajectory into files,
streams and ensembles with nothing else stored; a result saved before this version has no periods
and each record is the grid.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
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
    """``{name: steps}``: for each recorded signal the period (steps) at which one of the components
    that write it (``writers[name]``: their periods) may run, the greatest common divisor of
    theirs; 1 for the loop's own signals (the truth)."""
    gcd = math.gcd                                          # an int, whatever integers it is given
    return {name: gcd(*(writers.get(name) or [1])) for name, _, _ in record_layout}


def records_of(traj: Any) -> dict[str, Record]:
    """``{name: Record}`` of a :class:`lgvi.systems.spacecraft.SpacecraftTrajectory` (see the module)."""
    meta = traj.meta or {}
    per = 1 if meta.get("solver_record") == "full" else int(meta.get("save_every", 1))
    periods = meta.get("signal_periods") or {}
    fast = {row[0]: row[1:] for row in meta.get("signal_fast") or []}
    t, h = traj.signal_t, float(traj.h)
    t0 = float(meta.get("t0", 0.0))
    out = {}
    for name, values in traj.signals.items():
        p = int(periods.get(name, 0))
        if name in fast:
            col, size, p, slots = (int(x) for x in fast[name])
            E = len(t)
            ke = per * np.arange(E)[:, None]                     # each entry's first step
            k = -(-ke // p) * p + p * np.arange(slots)[None, :]  # its writer's steps, slot by slot
            keep = (k < ke + per).ravel()
            block = traj.signal_data[:, col:col + size * slots].reshape(E * slots, size)[keep]
            out[name] = Record(name, t0 + h * k.ravel()[keep], block[:, 0] if name == "mode" else block,
                               abs(h) * p, True)
        elif p >= per and p % per == 0:
            rows = slice(None, None, p // per)
            out[name] = Record(name, t[rows], values[rows], abs(h) * p, True)
        else:                    # record_rate="grid" with a faster writer, or a result without the periods
            out[name] = Record(name, t, values, abs(h) * per, False)
    return out
