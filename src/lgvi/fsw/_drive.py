"""Run sensor and estimator components on a given truth (issue 27's own small driver, for the
statistics tests and the benchmarks; the compiled loop of issue 25 replaces it in simulations).

:func:`run_components` lays out a bus for the components' signals (standard sizes from
:data:`lgvi.components.SIGNALS`, the kinds' own signals, the size-0 ones from ``sizes()``), writes
the truth rows into it, runs the compiled :func:`lgvi._kernels.component_bench.run_components`
and returns the recorded signals by name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..components import COMPONENT_KINDS, SIGNALS
from .._kernels.component_bench import run_components as _run
from ..spacecraft.sensors import period_steps


@dataclass(frozen=True)
class ComponentRun:
    """Records by signal name (``(n, size)`` each), the rows run, the status, and the final states."""

    records: dict[str, np.ndarray]
    rows: int
    status: int
    states: list[np.ndarray]


def bus_layout(components: list[Any]) -> dict[str, tuple[int, int]]:
    """Offsets and sizes of every signal the components read or write, in first-use order."""
    layout: dict[str, tuple[int, int]] = {}
    n = 0
    for comp in components:
        kind = COMPONENT_KINDS[comp.kind]
        own = {s.name: s for s in kind.own}
        for name in kind.reads + kind.writes:
            if name in layout:
                continue
            sig = own.get(name) or SIGNALS[name]
            size = sig.size or comp.sizes()[name]
            layout[name] = (n, size)
            n += size
    return layout


def run_components(components: list[Any], truth: dict[str, Any], h: float, *, record: list[str],
                   t0: float = 0.0, constants: dict[str, Any] | None = None,
                   record_state: dict[str, tuple[int, Any]] | None = None) -> ComponentRun:
    """Run ``components`` (sensors then estimators, in the order given) on the truth rows.

    ``truth``: signal name -> ``(n, size)`` array, one row a dynamics step of ``h`` seconds (``R`` as
    ``(n, 3, 3)`` is accepted); ``constants``: signal name -> value held on the bus throughout;
    ``record``: the signals copied out after every row; ``record_state``: name -> (component index,
    indices into its state), copied out after every row too (in ``records`` under that name).
    """
    layout = bus_layout(components)
    nbus = sum(size for _, size in layout.values())
    bus = np.zeros(nbus)
    for name, (o, size) in layout.items():
        if name.endswith("_time"):
            bus[o] = np.nan                 # nothing measured yet
    for name, value in (constants or {}).items():
        o, size = layout[name]
        bus[o:o + size] = np.ravel(value)
    cols, offs = [], []
    for name, value in truth.items():
        if name not in layout:          # a truth signal no component reads
            continue
        arr = np.asarray(value, dtype=float)
        arr = arr.reshape(arr.shape[0], -1)
        o, size = layout[name]
        if arr.shape[1] != size:
            raise ValueError(f"truth[{name!r}] must have {size} entries a row, got {arr.shape[1]}")
        cols.append(arr)
        offs.extend(range(o, o + size))
    table = np.ascontiguousarray(np.concatenate(cols, axis=1))
    n = table.shape[0]
    codes = np.array([COMPONENT_KINDS[c.kind].code for c in components], dtype=np.int64)
    periods = np.array([1 if c.rate is None else period_steps(c.rate, h, f"{type(c).__name__}.rate")
                        for c in components], dtype=np.int64)
    rows = [np.asarray(c.params(), dtype=float) for c in components]
    states = [np.asarray(c.state0(), dtype=float) for c in components]
    P = np.zeros((len(components), max(r.size for r in rows)))
    S = np.zeros((len(components), max(s.size for s in states)))
    wl = []
    for c in components:
        kind = COMPONENT_KINDS[c.kind]
        wl.append([layout[name][0] for name in kind.reads + kind.writes])
    W = np.zeros((len(components), max(len(x) for x in wl)), dtype=np.int64)
    for i in range(len(components)):
        P[i, :rows[i].size] = rows[i]
        S[i, :states[i].size] = states[i]
        W[i, :len(wl[i])] = wl[i]
    rec_off, rec_names = [], []
    for name in record:
        o, size = layout[name]
        rec_off.extend(range(o, o + size))
        rec_names.append((name, size))
    rec_comp, rec_s, s_names = [], [], []
    for name, (c, idx) in (record_state or {}).items():
        idx = np.atleast_1d(np.asarray(idx, dtype=np.int64))
        rec_comp.extend([c] * idx.size)
        rec_s.extend(idx.tolist())
        s_names.append((name, idx.size))
    out = np.full((n, len(rec_off)), np.nan)
    out_s = np.full((n, len(rec_s)), np.nan)
    k, status = _run(table, np.array(offs, dtype=np.int64), float(t0), float(h), codes, periods, P, S, W, bus,
                     np.array(rec_off, dtype=np.int64), out, np.array(rec_comp, dtype=np.int64),
                     np.array(rec_s, dtype=np.int64), out_s)
    records, j = {}, 0
    for name, size in rec_names:
        records[name] = out[:, j:j + size]
        j += size
    j = 0
    for name, size in s_names:
        records[name] = out_s[:, j:j + size]
        j += size
    return ComponentRun(records, int(k), int(status), [S[i, :states[i].size].copy() for i in range(len(components))])
