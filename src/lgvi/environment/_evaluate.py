"""Run one component kind over many points from Python: the vectorised functions and the tests.

:func:`evaluate` lays the kind's ``reads + writes`` out on a bus of its own, fills the read signals
from the arrays given (broadcast over the points), runs the kind's compiled step on every row in
one compiled loop (``environment_many`` / ``disturbance_many``) and returns what it wrote.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._kernels.environment_components import disturbance_many, environment_many
from ..components import COMPONENT_KINDS, SIGNALS, STATUS


def _size(kind: Any, name: str) -> int:
    for sig in kind.own:
        if sig.name == name:
            return sig.size
    return SIGNALS[name].size


def layout(kind: Any) -> tuple[list[int], np.ndarray]:
    """Sizes and bus offsets (int64) of ``kind.reads + kind.writes``, laid out one after another."""
    sizes = [_size(kind, n) for n in kind.reads + kind.writes]
    return sizes, np.concatenate([[0], np.cumsum(sizes)])[:-1].astype(np.int64)


def evaluate(component: Any, t: Any = 0.0, *, member: int = 0, **signals: Any) -> dict[str, np.ndarray]:
    """The signals ``component`` writes, at times ``t`` (seconds, scalar or (n,)) and read signals
    given by name (``R`` as (..., 3, 3), vectors as (..., 3), scalars as (...)), broadcast together.

    Returns ``{name: (n, size)}`` for each written signal (``(n,)`` for size 1). A nonzero status
    raises ValueError naming the component, the status and the first point."""
    kind = COMPONENT_KINDS[component.kind]
    sizes, offsets = layout(kind)
    missing = [n for n in kind.reads if n not in signals]
    if missing:
        raise TypeError(f"{kind.name}: the signals {missing} must be given (it reads {list(kind.reads)})")
    arrays = {}
    for name, size in zip(kind.reads, sizes):
        a = np.asarray(signals[name], dtype=np.float64)
        if size == 1:
            a = a[..., None]
        a = a.reshape(a.shape[:-2] + (9,)) if size == 9 and a.shape[-2:] == (3, 3) else a
        if a.shape[-1] != size:
            raise ValueError(f"{kind.name}: signal {name!r} must have {size} entries per point, got shape "
                             f"{np.shape(signals[name])}")
        arrays[name] = a.reshape(-1, size)
    t = np.atleast_1d(np.asarray(t, dtype=np.float64)).ravel()
    n = max([len(t)] + [len(a) for a in arrays.values()])
    buses = np.zeros((n, int(sum(sizes))))
    for name, off, size in zip(kind.reads, offsets, sizes):
        buses[:, off:off + size] = np.broadcast_to(arrays[name], (n, size))
    p = np.asarray(component.params(), dtype=np.float64)
    p = np.ascontiguousarray(p[member] if p.ndim == 2 else p)       # one row per member: member's
    s = np.ascontiguousarray(component.state0(), dtype=np.float64)
    run = environment_many if kind.family == "environment" else disturbance_many
    status = run(kind.code, np.broadcast_to(t, (n,)).copy(), buses, p, s, offsets)
    bad = np.flatnonzero(status)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{kind.name}: status {status[i]} ({STATUS.get(int(status[i]), 'unknown')}) at point {i} "
                         f"(t = {t[min(i, len(t) - 1)]:g} s)")
    out = {}
    for name, off, size in zip(kind.writes, offsets[len(kind.reads):], sizes[len(kind.reads):]):
        out[name] = buses[:, off] if size == 1 else buses[:, off:off + size]
    return out
