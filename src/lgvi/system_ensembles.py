"""Monte Carlo runs of any registered system: one run per member, on threads or on Dask.

:func:`simulate_members` takes a system of :data:`lgvi.systems.SYSTEMS` (``"orbit"``,
``"two_body"``, ``"gyrostat"``, ...) and a sequence of members, each the arguments of one run of
that system (those of :func:`lgvi.simulate_orbit`, :func:`lgvi.simulate_two_body`, or of
:func:`lgvi.simulate` with ``wheels=``/``controller=``, without ``progress``).
Every member is built and validated first (a bad member raises before any work, naming its index);
then each is driven by :func:`lgvi.driver.drive` into its own :class:`lgvi.driver.MemorySink`, on a
pool of threads (the compiled kernels release the GIL) or as one task per member on a
``dask.distributed`` client. Member ``b`` of the result is bit for bit the single run with its
arguments: the members share nothing.

The rigid body's many-body ensembles (one compiled call over all bodies, ``out_dir`` blocks,
resume) are :func:`lgvi.simulate_ensemble`; this module is the generic, simpler path.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait
from typing import Any

import numpy as np

from .driver import MemorySink, Progress, drive
from .errors import SimulationInterrupted
from .systems import RUNS, SYSTEMS, System


class SystemEnsemble:
    """The results of :func:`simulate_members`, in the order of the members.

    Attributes
    ----------
    system : str
        The system's name (``SYSTEMS[system]``).
    members : list
        One result per member (an :class:`lgvi.OrbitTrajectory`, :class:`lgvi.TwoBodyTrajectory`, ...).

    ``len(ens)``, ``ens[b]`` and iteration give the members; ``ens.stack(name)`` (or ``ens.<name>``
    for ``t`` and each field of the system's state layout, e.g. ``x``, ``p``, ``R``, ``Pi``) stacks
    that array over the members, shape ``(B, M, *field shape)``, when all members have the same
    number of samples ``M``.
    """

    def __init__(self, system: str, members: Sequence[Any]) -> None:
        self.system = system
        self.members: list[Any] = list(members)

    def __len__(self) -> int:
        return len(self.members)

    def __getitem__(self, b: int) -> Any:
        return self.members[b]

    def __iter__(self):
        return iter(self.members)

    def __repr__(self) -> str:
        return f"SystemEnsemble(system={self.system!r}, members={len(self.members)})"

    def fields(self) -> tuple[str, ...]:
        """Names :meth:`stack` takes: ``t`` and the system's state fields."""
        return ("t",) + tuple(f.name for f in SYSTEMS[self.system].state)

    def stack(self, name: str) -> np.ndarray:
        """``name`` (``t`` or a state field) of every member, stacked: ``(B, M, ...)``.

        Raises
        ------
        ValueError
            ``name`` is not a field, or the members have different numbers of samples.
        """
        if name not in self.fields():
            raise ValueError(f"name must be one of {self.fields()} (the {self.system} state layout), got {name!r}")
        arrays = [np.asarray(getattr(m, name)) for m in self.members]
        shapes = {a.shape for a in arrays}
        if len(shapes) > 1:
            raise ValueError(f"the members' {name} have different shapes {sorted(shapes)}: they cannot be "
                             "stacked; use ens[b] or ens.members")
        if not arrays:
            raise ValueError("the ensemble has no members")
        return np.stack(arrays)

    def __getattr__(self, name: str) -> np.ndarray:
        if name.startswith("_") or name in ("system", "members"):
            raise AttributeError(name)
        if name in self.fields():
            return self.stack(name)
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")


class _Stopped(Exception):
    """Raised between chunks in a worker thread when the ensemble stops (Ctrl-C or a failure elsewhere)."""


def _system(system: Any) -> System:
    if not isinstance(system, System):
        if not isinstance(system, str) or system not in SYSTEMS:
            raise ValueError(f"system must be one of {sorted(SYSTEMS)} (lgvi.systems.SYSTEMS), got {system!r}")
        system = SYSTEMS[system]
    if system.run_factory is None and system.name not in RUNS:
        raise ValueError(f"the system {system.name!r} provides no run factory (SYSTEMS[{system.name!r}].run), so "
                         "simulate_members cannot build its members")
    return system


def _split(member: Any, b: int) -> tuple[tuple[Any, ...], dict[str, Any]]:
    """A member as ``(args, kwargs)``: a mapping of keyword arguments or an ``(args, kwargs)`` pair."""
    if isinstance(member, Mapping):
        args, kwargs = (), dict(member)
    elif (isinstance(member, (tuple, list)) and len(member) == 2 and isinstance(member[0], (tuple, list))
          and isinstance(member[1], Mapping)):
        args, kwargs = tuple(member[0]), dict(member[1])
    else:
        raise TypeError(f"members[{b}] must be a dict of the run's keyword arguments or an (args, kwargs) pair, "
                        f"got {type(member).__name__}")
    if "progress" in kwargs:
        raise TypeError(f"members[{b}] has progress=: give progress to simulate_members (one for the ensemble)")
    return args, kwargs


def _tag(exc: BaseException, b: int, done: dict[int, Any]) -> BaseException:
    """Name member ``b`` in ``exc``'s message; attach ``member`` and the finished ``members``."""
    if exc.args and isinstance(exc.args[0], str):
        exc.args = (f"member {b}: {exc.args[0]}",) + exc.args[1:]
    else:
        exc.args = (f"member {b} failed",) + exc.args
    exc.member = b
    exc.members = dict(sorted(done.items()))
    return exc


def _build(sys_: System, members: Sequence[Any]) -> list[tuple[tuple[Any, ...], dict[str, Any], Any]]:
    out = []
    for b, member in enumerate(members):
        args, kwargs = _split(member, b)
        try:
            run = sys_.run(*args, **kwargs)
        except (TypeError, ValueError) as exc:
            raise _tag(exc, b, {}) from None
        out.append((args, kwargs, run))
    return out


def _member_task(name: str, args: tuple[Any, ...], kwargs: dict[str, Any]) -> Any:
    """One member on a Dask worker: build its run and drive it into memory."""
    run = SYSTEMS[name].run(*args, **kwargs)
    return drive(run, MemorySink(run))


def _interrupted(done: dict[int, Any], total: int, how: str) -> SimulationInterrupted:
    exc = SimulationInterrupted(f"ensemble interrupted: {len(done)} of {total} members finished ({how}); they are "
                                "in .members (member index -> result)", trajectory=dict(sorted(done.items())))
    exc.members = dict(sorted(done.items()))
    return exc


def _run_serial(runs: list, bar: Progress) -> list[Any]:
    done: dict[int, Any] = {}
    for b, (_, _, run) in enumerate(runs):
        try:
            done[b] = drive(run, MemorySink(run))
        except SimulationInterrupted as exc:
            exc.members = dict(done)
            exc.args = (f"ensemble interrupted in member {b}: {len(done)} of {len(runs)} members finished "
                        f"(in .members); member {b}'s partial run is in .trajectory",)
            raise
        except Exception as exc:
            raise _tag(exc, b, done)
        bar.update(len(done))
    return [done[b] for b in range(len(runs))]


def _run_threads(runs: list, threads: int, bar: Progress) -> list[Any]:
    stop = threading.Event()

    def check(k: int, steps: int) -> None:   # between chunks; a member whose last chunk is done is kept
        if stop.is_set() and k < steps:
            raise _Stopped

    def one(run: Any) -> Any:
        if stop.is_set():
            raise _Stopped
        return drive(run, MemorySink(run), progress=check)

    done: dict[int, Any] = {}
    with ThreadPoolExecutor(max_workers=threads, thread_name_prefix="lgvi-member") as pool:
        futures: list[Any] = []
        index: dict[Any, int] = {}
        pending: set[Any] = set()
        interrupted = False
        try:
            for b, (_, _, run) in enumerate(runs):      # Ctrl-C may come while submitting too
                futures.append(pool.submit(one, run))
                index[futures[-1]] = b
                pending.add(futures[-1])
            while pending:
                finished, pending = wait(pending, timeout=0.2, return_when=FIRST_EXCEPTION)
                failed = False
                for f in finished:
                    if f.exception() is None:
                        done[index[f]] = f.result()
                    else:
                        failed = True
                if finished:
                    bar.update(len(done))
                if failed:
                    break
        except KeyboardInterrupt:
            interrupted = True
            stop.set()
        if pending:
            stop.set()
            for f in pending:
                f.cancel()
            wait(pending)
    errors = {}
    for f in futures:
        if f.cancelled():
            continue
        exc = f.exception()
        if exc is None:
            done[index[f]] = f.result()
        elif not isinstance(exc, _Stopped):
            errors[index[f]] = exc
    if errors:
        b = min(errors)
        raise _tag(errors[b], b, done)
    if interrupted:
        raise _interrupted(done, len(runs), "the running members stopped between chunks")
    return [done[b] for b in range(len(runs))]


def _run_dask(sys_: System, runs: list, client: Any, bar: Progress) -> list[Any]:
    futures = [client.submit(_member_task, sys_.name, args, kwargs, pure=False) for args, kwargs, _ in runs]
    done: dict[int, Any] = {}

    def finished() -> None:
        for j, g in enumerate(futures):
            if j not in done and g.status == "finished":
                done[j] = g.result()

    try:
        for b, f in enumerate(futures):
            try:
                done[b] = f.result()
            except Exception as exc:
                client.cancel([g for g in futures if g.status == "pending"])
                finished()
                raise _tag(exc, b, done) from None
            bar.update(len(done))
    except KeyboardInterrupt as exc:
        if isinstance(exc, SimulationInterrupted):
            raise
        client.cancel([g for g in futures if g.status == "pending"])
        finished()
        raise _interrupted(done, len(runs), "the Dask tasks of the others were cancelled") from None
    return [done[b] for b in range(len(runs))]


def simulate_members(system: Any, members: Sequence[Any], *, threads: int | None = None, client: Any = None,
                     progress: Any = False) -> SystemEnsemble:
    """Run many members of one system (Monte Carlo), on threads or on a Dask client.

    Parameters
    ----------
    system : str or lgvi.systems.System
        A registered system with a run factory (``SYSTEMS[name].run``): ``"orbit"``, ``"two_body"``,
        ``"gyrostat"`` (the arguments of :func:`lgvi.simulate` with ``wheels=``, ``controller=``;
        each member runs its own copy of its controller, environment and magnetorquers, so one
        object may serve several members and is left untouched:
        :func:`lgvi.systems.gyrostat.gyrostat_run`); also ``"rigid_body"``, whose run is the
        low-level :class:`lgvi.systems.rigid_body_run.Run` (every option by name; :func:`lgvi.simulate_ensemble`
        is its better path).
    members : sequence
        One entry per run: a dict of the keyword arguments of the system's run (those of
        :func:`lgvi.simulate_orbit` / :func:`lgvi.simulate_two_body`, which take every argument by
        name), or an ``(args, kwargs)`` pair. ``progress`` is not a member's argument.
    threads : int, optional
        Worker threads in this process (default: ``min(len(members), os.cpu_count())``);
        ``threads=1`` runs the members one after the other in this thread. Not with ``client``.
    client : dask.distributed.Client, optional
        Run one task per member on this client and gather the results in order.
    progress : bool or callable
        ``True``: a bar over members; a callable: ``progress(members_done, members)``.

    Returns
    -------
    SystemEnsemble
        ``ens[b]`` is bit for bit the single run of ``members[b]``; ``ens.stack(name)`` (B, M, ...).

    Raises
    ------
    ValueError, TypeError
        A bad member, before any run: the message starts ``member b:`` and the exception has
        ``.member = b``.
    lgvi.ConvergenceError (or the member's error)
        A member failed: its message starts ``member b:``; ``.member`` is ``b`` and ``.members``
        holds the finished members (index -> result). The other running members are stopped.
    lgvi.SimulationInterrupted
        Ctrl-C: ``.members`` holds the finished members (index -> result).
    """
    import os

    sys_ = _system(system)
    if isinstance(members, (str, bytes, Mapping)) or not isinstance(members, Sequence):
        raise TypeError(f"members must be a sequence (list) of dicts or (args, kwargs) pairs, got "
                        f"{type(members).__name__}")
    if threads is not None:
        if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
            raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
        if client is not None:
            raise ValueError("give threads= or client=, not both (a Dask worker chooses its own threads)")
    Progress(progress, 0)  # validates progress before any work
    runs = _build(sys_, members)
    with Progress(progress, len(runs), unit="member") as bar:
        if not runs:
            results: list[Any] = []
        elif client is not None:
            results = _run_dask(sys_, runs, client, bar)
        else:
            n = int(threads) if threads is not None else min(len(runs), os.cpu_count() or 1)
            n = min(n, len(runs))
            results = _run_serial(runs, bar) if n == 1 else _run_threads(runs, n, bar)
    return SystemEnsemble(sys_.name, results)


__all__ = ["SystemEnsemble", "simulate_members"]
