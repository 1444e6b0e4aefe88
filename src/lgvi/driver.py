"""One driver for every run: validation shared by the entry points, chunks, progress, Ctrl-C,
partial results and failures, in one place (see ``docs/architecture.md``).

:func:`drive` runs any system's run object (:mod:`lgvi.systems`) in compiled chunks into a *sink*:
:class:`MemorySink` keeps the whole result in memory (:func:`lgvi.simulate`);
:class:`lgvi.streaming.StreamSink` writes each chunk to a crash-safe stream folder
(:func:`lgvi.simulate_stream`). The core never imports the stream file format: the sink is handed
in from above. :func:`lgvi.simulate_ensemble` uses the same validation, progress and interrupt
handling for its chunks over bodies.

A run object has ``k`` (steps done), ``steps``, ``save_every``, ``chunk`` (steps per compiled
call), ``system`` (its :class:`lgvi.systems.System`), ``advance(n, *state_buffers,
*record_buffers, partial)`` returning a status code, ``failure(status, residual, iterations,
trajectory, where="")`` returning the exception to raise, ``trajectory(t, *state, *records,
partial=False)``, ``times(j0, j1)``, ``state()`` and ``load_state()``.
"""

from __future__ import annotations

import _signal  # signal.signal without its enum conversions: the same C call, ~4 us less a run
import functools
import math
import os
import signal
import sys
import threading
from typing import Any, Protocol

import numpy as np

from ._kernels.codes import OK
from ._validation import as_float, as_float_array, as_int
from .errors import SimulationInterrupted
from .implicit import solver_options


def run_solver_options(method: str, tol: Any, max_iter: Any, alpha: Any) -> tuple[int, float, int, float]:
    """Validated ``(code, tol, max_iter, alpha)`` of a run's solver (at least one iteration a step)."""
    return solver_options(method, tol, max_iter, alpha, min_iter=1)


def initial_momentum(body: Any, Pi0: Any, omega0: Any) -> np.ndarray:
    """Validated initial body momentum ``Pi0`` (3,), given as ``Pi0`` or as ``omega0`` (``J omega0``)."""
    if Pi0 is None and omega0 is None:
        raise ValueError("give the initial body angular momentum Pi0 (3,) or the angular velocity omega0 (3,)")
    if Pi0 is not None and omega0 is not None:
        raise ValueError("give either Pi0 or omega0, not both")
    if Pi0 is not None:
        return as_float_array(Pi0, "Pi0", (3,)).copy()
    return body.J @ as_float_array(omega0, "omega0", (3,))


#: Largest ``steps`` and ``save_every`` a run takes (the kernels count steps in int64).
MAX_STEPS = 2**62


def time_grid(h: Any, t0: Any, steps: Any, save_every: Any) -> tuple[float, float, int, int]:
    """Validated ``(h, t0, steps, save_every)`` of a run: ``h != 0``, ``steps >= 0``,
    ``save_every >= 1`` dividing ``steps`` (so that the final state is saved)."""
    h = as_float(h, "h", nonzero=True)
    t0 = as_float(t0, "t0")
    steps = as_int(steps, "steps", minimum=0)
    save_every = as_int(save_every, "save_every", minimum=1)
    if steps > MAX_STEPS or save_every > MAX_STEPS:   # the compiled loop counts in int64: refused here, not by Numba
        name, n = ("steps", steps) if steps > MAX_STEPS else ("save_every", save_every)
        raise ValueError(f"{name} must be at most 2**62 = {MAX_STEPS} (the compiled loop counts steps in "
                         f"64-bit integers), got {n}")
    if steps % save_every != 0:
        raise ValueError(f"save_every must divide steps so that the final state is saved; got "
                         f"steps={steps}, save_every={save_every} (steps % save_every = {steps % save_every})")
    t_end = t0 + steps * h
    if not math.isfinite(t_end):
        raise ValueError(f"the final time t0 + steps*h must be finite; got t0 = {t0!r}, h = {h!r}, steps = {steps} "
                         f"(t = {t_end}): shift t0 or shorten the run")
    if steps and t0 + h == t0:
        raise ValueError(f"h = {h!r} is below the resolution of the time t0 = {t0!r} (t0 + h == t0): every sample "
                         "would carry the same time; measure t from a nearer origin (a smaller t0)")
    return h, t0, steps, save_every


def steps_from(h: Any, steps: Any, duration: Any) -> Any:
    """The number of steps of a run given as ``steps=`` or as ``duration=`` (the time span
    ``steps * h``, signed like ``h``): exactly one of the two, and a duration that is a whole
    number of steps (to 1e-9 relative)."""
    if (steps is None) == (duration is None):
        raise TypeError("give exactly one of steps= (an integer number of steps) and duration= (the time span, "
                        f"steps * h); got steps={steps!r}, duration={duration!r}")
    if duration is None:
        return steps
    h = as_float(h, "h", nonzero=True)
    duration = as_float(duration, "duration")
    n = duration / h
    k = round(n)
    if k < 0 or abs(n - k) > 1e-9 * max(1.0, abs(n)):
        raise ValueError(f"duration={duration!r} must be a whole, non-negative number of steps h={h!r} "
                         f"(duration / h = {n:.12g}): choose an h that divides it, or give steps=")
    return int(k)


def sample_times(t0: float, dt: float, j0: int, j1: int) -> np.ndarray:
    """``t0 + dt * j`` for ``j = j0 .. j1-1``, in place in one array (no temporaries to fault in)."""
    t = np.arange(j0, j1, dtype=np.float64)
    t *= dt
    t += t0
    return t


@functools.lru_cache(maxsize=None)
def _physical_memory() -> int:
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 1 << 62


def physical_memory() -> int:
    """Bytes of physical memory (asked of the system once per process: it does not change)."""
    return _physical_memory()


def check_memory(steps: int, save_every: int, full: bool = True) -> None:
    """Refuse a run whose in-memory result cannot fit: 96 bytes a sample, 12 bytes a record entry
    (a step, or with ``full=False`` a saved interval)."""
    need = 96 * (steps // save_every + 1) + 12 * (steps if full else steps // save_every)
    have = physical_memory()
    if need > have:
        raise ValueError(f"steps={steps} with save_every={save_every} needs {need / 2**30:.3g} GiB for the "
                         f"result, more than this machine's {have / 2**30:.3g} GiB: save sparsely (a larger "
                         "save_every) or run it to disk with lgvi.simulate_stream")


class Interrupts:
    """Turn Ctrl-C during a run into a request honoured between chunks (a second Ctrl-C aborts at once).

    Outside the main thread signals cannot be caught; a ``KeyboardInterrupt`` there still ends the
    run the usual way.
    """

    def __init__(self) -> None:
        self.requested: bool = False
        self._old: Any = None

    def _handler(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __enter__(self) -> "Interrupts":
        if threading.current_thread() is threading.main_thread():
            try:
                self._old = _signal.signal(signal.SIGINT, self._handler)
            except (ValueError, OSError):  # pragma: no cover - embedded interpreters
                self._old = None
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._old is not None:
            _signal.signal(signal.SIGINT, self._old)


def interactive() -> bool:
    """Whether a person watches this process: stderr is a terminal, or a Jupyter kernel runs it."""
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return True
    except (AttributeError, ValueError):  # a closed or replaced stream
        pass
    shell = getattr(sys.modules.get("IPython"), "get_ipython", lambda: None)()
    return type(shell).__name__ == "ZMQInteractiveShell"


class Progress:
    """A progress report between chunks: ``progress=True`` draws a ``tqdm`` bar where a person
    watches (``tqdm.auto``: a widget in Jupyter, text on a terminal's stderr; nothing when stderr
    goes to a file or a CI log), a callable is called as ``progress(steps_done, steps)``, ``False``
    is silent. Updated between compiled chunks only."""

    def __init__(self, progress: Any, steps: int, start: int = 0, unit: str = "step") -> None:
        if not (isinstance(progress, bool) or callable(progress)):
            raise TypeError(f"progress must be True, False or a callable progress(done, total), got {progress!r}")
        self.progress = progress
        self.steps = steps
        self.bar: Any = None
        if progress is True and steps and interactive():
            from tqdm.auto import tqdm

            self.bar = tqdm(total=steps, initial=start, unit=unit, unit_scale=steps >= 100_000, dynamic_ncols=True)

    def __enter__(self) -> "Progress":
        return self

    def update(self, k: int, final: bool = False) -> None:
        if self.progress is False:
            return
        if callable(self.progress) and not isinstance(self.progress, bool):
            self.progress(k, self.steps)
        elif self.bar is not None:
            self.bar.update(k - self.bar.n)

    def __exit__(self, *exc: Any) -> None:
        if self.bar is not None:
            self.bar.close()


# ------------------------------------------------------------------------------------------------
# sinks and the chunk driver
# ------------------------------------------------------------------------------------------------
class Sink(Protocol):
    """Where a driven run's chunks go (see :class:`MemorySink`, :class:`lgvi.streaming.StreamSink`)."""

    #: Appended to failure messages (e.g. where the complete chunks are).
    where: str
    #: The end of the message of :class:`lgvi.SimulationInterrupted`.
    interrupted: str

    def buffers(self, k0: int, n: int) -> list[np.ndarray]:
        """State buffers (one per field of ``run.system.state``, ``n // save_every`` samples) and
        record buffers (one per field of ``run.system.records``, ``n // record_every(run)``
        entries) for steps ``k0 ..``."""

    def partial(self, k_done: int | None = None) -> Any:
        """The result up to step ``k_done`` (``None``: what is kept), marked partial."""

    def failed(self, k0: int, k: int) -> tuple[float, int]:
        """The run failed at step ``k`` of the chunk from ``k0``: ``(residual, iterations)`` of that step."""

    def commit(self, k0: int, n: int) -> None:
        """Steps ``k0 .. k0 + n - 1`` are done and in the buffers."""

    def interrupt(self, k: int) -> Any:
        """Ctrl-C after step ``k``: the partial result to hand to the exception."""

    def finish(self) -> Any:
        """The run is complete: its result."""


def layout(run: Any) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """``(state, records)``: the fields (:class:`lgvi.systems.Field`) of ``run``'s buffers with their
    concrete shapes. A system whose field shapes depend on the run (the chain's ``q`` is ``(n, 3)``
    for ``n`` links; its declaration writes ``("n", 3)``) gives them with a ``run.layout()``
    method; for the others the system's declared fields are the layout. The sinks allocate from it."""
    own = getattr(run, "layout", None)
    return own() if own is not None else (run.system.state, run.system.records)


def record_every(run: Any) -> int:
    """Steps per entry of a run's per-step records: 1 (every step) or ``save_every`` (the largest
    over each saved interval, ``solver_record="interval"``)."""
    return 1 if getattr(run, "full", True) else run.save_every


class MemorySink:
    """The whole result in memory, allocated from the system's state layout (:func:`lgvi.simulate`)."""
    se: Any
    per: int

    where = ""
    interrupted = "the computed part is in .trajectory"

    def __init__(self, run: Any) -> None:
        self.run = run
        self.se = se = run.save_every
        M = run.steps // se + 1
        self.M = M
        state, records = layout(run)
        self.state: list[Any] = [f.empty(M) for f in state]
        for buf, f in zip(self.state, state):
            buf[0] = getattr(run, f.name)
        self.per = per = record_every(run)
        self.records: list[Any] = [f.record(run.steps // per) for f in records]

    def buffers(self, k0: int, n: int) -> list[np.ndarray]:
        j0 = k0 // self.se + 1
        m = n // self.se
        per = self.per
        return [b[j0:j0 + m] for b in self.state] + [r[k0 // per:(k0 + n) // per] for r in self.records]

    def partial(self, k_done: int | None = None) -> Any:
        m = k_done // self.se + 1
        r = k_done // self.per
        return self.run.trajectory(self.run.times(0, m), *(b[:m].copy() for b in self.state),
                                   *(a[:r].copy() for a in self.records), partial=True)

    def failed(self, k0: int, k: int) -> tuple[float, int]:
        return self.run.last_res, self.run.last_its

    def commit(self, k0: int, n: int) -> None:
        pass

    def interrupt(self, k: int) -> Any:
        return self.partial(k)

    def finish(self) -> Any:
        return self.run.trajectory(self.run.times(0, self.M), *self.state, *self.records)


def _keep_partial(exc: BaseException, sink: Sink, k: int) -> None:
    """Attach the run up to step ``k`` (the chunks completed before the failing one) to ``exc`` as
    ``.trajectory``, unless it carries one already (a TorqueError of a Python callable does), with
    a note saying so: an error escaping the compiled loop never loses the computed part."""
    if getattr(exc, "trajectory", None) is not None:
        return
    try:
        part = sink.partial(k)
        exc.trajectory = part           # type: ignore[attr-defined]
    except Exception:                   # noqa: BLE001 - the original error matters more
        return
    exc.add_note(f"lgvi: the run up to step {k} (the chunks completed before the failing one) is in the "
                 "exception's .trajectory")


def drive(run: Any, sink: Sink, progress: Any = False) -> Any:
    """Run ``run`` from step ``run.k`` to its end in chunks of ``run.chunk`` steps into ``sink``.

    Between chunks: progress is reported (``progress`` as in :func:`lgvi.simulate`) and a Ctrl-C
    is honoured (:class:`lgvi.SimulationInterrupted` with the partial result in ``.trajectory``);
    a failed step raises the run's error (``run.failure``) with the run up to that step; any other
    exception escaping a chunk (a user's compiled model raising inside the loop) is raised with
    the chunks completed before it in ``.trajectory``. A run may name itself in the messages
    (``run.label``, default ``"simulation"``).

    Returns
    -------
    Whatever ``sink.finish()`` returns (the result).
    """
    steps = run.steps
    with Interrupts() as stop, Progress(progress, steps, start=run.k) as bar:
        while run.k < steps:
            k0 = run.k
            n = min(run.chunk, steps - k0)
            try:
                status = run.advance(n, *sink.buffers(k0, n), sink.partial)
            except Exception as exc:    # raised inside the compiled loop (a user's njit model): keep the part done
                _keep_partial(exc, sink, run.k)
                raise
            if status != OK:
                residual, iterations = sink.failed(k0, run.k)
                raise run.failure(status, residual, iterations, sink.partial(run.k), where=sink.where)
            sink.commit(k0, n)
            bar.update(run.k)
            if stop.requested:
                raise SimulationInterrupted(f"{getattr(run, 'label', 'simulation')} interrupted after {run.k} of "
                                            f"{steps} steps; "
                                            f"{sink.interrupted}", trajectory=sink.interrupt(run.k))
    return sink.finish()


__all__ = ["Interrupts", "MemorySink", "Progress", "Sink", "check_memory", "drive", "initial_momentum", "layout",
           "physical_memory", "record_every", "run_solver_options", "sample_times", "time_grid"]
