"""The system seam: what the driver runs (see ``docs/architecture.md``).

A *system* is a subpackage of :mod:`lgvi.systems` that registers one :class:`System`: its state
layout (the fields saved per sample), its per-step records, its compiled step kernels, its
invariants (read from :mod:`lgvi.invariants`), its result fields and its scenario section. The
driver (:mod:`lgvi.driver`) allocates the result buffers from the layout and runs the system's
run object in compiled chunks, so progress, Ctrl-C, partial results, failures and streaming are
the same for every system.

The systems: the rigid body (:mod:`lgvi.systems.rigid_body`), the gyrostat, a body with reaction
wheels (:mod:`lgvi.systems.gyrostat`), a rigid body in a central field (:mod:`lgvi.systems.orbit`)
two rigid bodies in mutual gravity (:mod:`lgvi.systems.two_body`) and chains of spherical
pendulums on ``(S^2)^n`` (:mod:`lgvi.systems.chain`); another is a new module plus a
:func:`register` call.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..errors import CollisionError, ConvergenceError


@dataclass(frozen=True)
class Field:
    """One array of a system's state or record: ``shape`` per sample (or per step) and dtype.

    ``filled``: a record whose every value of each complete entry the kernel writes (the loop's
    ``signals``): the sinks allocate it uninitialised (:meth:`record`), sparing the zeroing of a
    buffer that is written over anyway."""

    name: str
    shape: tuple[int, ...]
    dtype: Any = np.float64
    doc: str = ""
    filled: bool = False

    def empty(self, n: int) -> np.ndarray:
        """``(n, *shape)`` uninitialised (state) buffer."""
        return np.empty((n,) + self.shape, dtype=self.dtype)

    def zeros(self, n: int) -> np.ndarray:
        """``(n, *shape)`` zeroed (record) buffer."""
        return np.zeros((n,) + self.shape, dtype=self.dtype)

    def record(self, n: int) -> np.ndarray:
        """``(n, *shape)`` record buffer: uninitialised when the kernel fills it (``filled``), else zeroed."""
        return self.empty(n) if self.filled else self.zeros(n)


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
        A shape may name a dimension the run fixes (``("n", 3)``); the run then gives its
        concrete fields with ``layout()`` (:func:`lgvi.driver.layout`).
    records : tuple of Field
        The per-step records of the solver (after the state buffers in ``advance``).
    kernels : callable
        ``kernels() -> dict``: its compiled step kernels by name (imports them on first call).
    results : tuple of str
        The fields of its result object (e.g. :class:`lgvi.Trajectory`).
    scenario_section : str
        The scenario table that describes the system (``[body]`` for a rigid body).
    run_factory : callable or None
        Builds the validated run object the driver runs; ``None`` when the module that defines it
        provides it on import (:func:`provide_run`), so that the system does not import its
        runner (the rigid body's is :class:`lgvi.systems.rigid_body_run.Run`). The run object has ``k``,
        ``steps``, ``save_every``, ``chunk``, ``advance(n, *state_buffers, *record_buffers, partial)``,
        ``failure(...)``, ``state()``, ``load_state()``, ``trajectory(...)``, ``times(j0, j1)``.
    invariants : callable
        ``invariants(torque) -> dict``: the declaration (:mod:`lgvi.invariants`) of a run of this
        system under ``torque``.
    from_stream : callable or None
        ``from_stream(meta, arrays, state) -> result``: the result object of a stream folder
        (:mod:`lgvi.io.streaming`) from its metadata (the run's ``stream_meta()``), the
        concatenated chunk arrays by field name (``t``, the ``state`` and ``records`` fields) and
        the resume state after the last complete chunk; ``None``: the system is not streamed
        (the rigid body's stream format predates the seam and is read by the stream module).
        A streamable run also has ``stream_meta()`` (JSON-serialisable: everything the result
        needs and everything that identifies the run, compared on resume) and its ``state()``
        carries everything the next step needs, JSON-serialisable.
    from_scenario : callable or None
        ``from_scenario(table) -> (args, kwargs)``: the arguments of its run factory from the plain
        values of its scenario section (``[<scenario_section>]`` of a TOML file), raising
        ``ValueError`` or ``TypeError`` whose message starts with the key it names
        (``"chain.lengths: ..."``). With it, a scenario file with that section runs the system
        (``lgvi.io.scenario``, ``lgvi run``, streams and ``--resume``) and nothing in ``io`` or
        ``cli`` names it; ``[integrator]`` gives ``h``, ``steps`` or ``duration``,
        ``save_every``, ``tol`` and ``max_iter``.
    describe : callable or None
        ``describe(result) -> list of str``: lines saying what was simulated, for summaries
        (``lgvi run``'s ``summary.txt``); ``None``: the ``doc`` line.
    saved_as : tuple or None
        ``(format, load)``: the format tag in the header of the ``.npz`` its result's ``save``
        writes, and the function that reads it back (``lgvi.io.outputs.read_trajectory``, ``lgvi
        info``, ``lgvi plot`` find it by the tag).
    view : callable or None
        ``view(result) -> Scene``: what the interactive page (:mod:`lgvi.view`, ``lgvi view``,
        ``lgvi run``'s ``report.html``) draws of a result: its parts in 3D at every sample, its
        own plots against time, the names of its invariants (:class:`Scene`). ``None``: no page
        (the rigid body's page, which predates the seam, is drawn by :mod:`lgvi.view` itself).
    """

    name: str
    doc: str
    state: tuple[Field, ...]
    records: tuple[Field, ...]
    kernels: Callable[[], dict[str, Any]]
    results: tuple[str, ...]
    scenario_section: str
    run_factory: Callable[..., Any] | None
    invariants: Callable[[Any], dict[str, dict[str, Any]]]
    from_stream: Callable[[dict[str, Any], dict[str, np.ndarray], dict[str, Any]], Any] | None = None
    from_scenario: Callable[[dict[str, Any]], tuple[tuple[Any, ...], dict[str, Any]]] | None = None
    describe: Callable[[Any], list[str]] | None = None
    saved_as: tuple[str, Callable[[Any], Any]] | None = None
    view: Callable[[Any], "Scene"] | None = None

    def run(self, *args: Any, **kwargs: Any) -> Any:
        """A validated run of this system (see ``run_factory``)."""
        return self.runner()(*args, **kwargs)

    def runner(self, scheme: str | None = None) -> Callable[..., Any]:
        """The run factory of this system, or of another of its schemes (``scheme``, e.g. the rigid
        body's ``"splitting"``) as provided with :func:`provide_run`."""
        key = self.name if scheme is None else f"{self.name}:{scheme}"
        factory = (self.run_factory if scheme is None else None) or RUNS.get(key)
        if factory is None:
            raise LookupError(f"no run is provided for {key!r}: import the module that "
                              "defines it (import lgvi does for the built-in systems)")
        return factory


@dataclass(frozen=True)
class SceneLine:
    """A polyline of a :class:`Scene`: ``points`` (M, P, 3) inertial, one row per sample (a row
    of NaN breaks the line), or (P, 3) for a line that does not move (a path over the run)."""

    name: str
    points: np.ndarray
    color: str = "#1f77b4"
    width: float = 5.0
    markers: bool = False


@dataclass(frozen=True)
class SceneMesh:
    """A closed surface of a :class:`Scene`: ``vertices`` (M, V, 3) inertial at every sample and
    ``triangles`` (T, 3) indices into them."""

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    color: str = "lightsteelblue"


@dataclass(frozen=True)
class Scene:
    """What the interactive page draws of one result of a system (:attr:`System.view`).

    Attributes
    ----------
    title : str
        What it shows, in a few words (the 3D scene's legend title).
    meshes, lines : tuple
        :class:`SceneMesh` and :class:`SceneLine` drawn at every sample (the page animates them).
    paths : tuple of SceneLine
        Lines that do not move (``points`` (P, 3)), e.g. the path of a point over the run.
    extent : float
        Half the side of the cube the scene is drawn in (m), centred on the origin.
    panels : tuple
        ``(title, ((label, values (M,)), ...))``: plots against time beside the scene.
    names : dict
        Quantity key of :mod:`lgvi.invariants` -> what it is for this system (the page's key).
    summary : tuple
        ``(label, value)`` rows the system adds to the run's summary.
    """

    title: str
    lines: tuple[SceneLine, ...]
    extent: float
    meshes: tuple[SceneMesh, ...] = ()
    paths: tuple[SceneLine, ...] = ()
    panels: tuple[tuple[str, tuple[tuple[str, np.ndarray], ...]], ...] = ()
    names: dict[str, str] = field(default_factory=dict)
    summary: tuple[tuple[str, str], ...] = ()


#: The registry of systems by name.
SYSTEMS: dict[str, System] = {}
#: Run factories provided on import by the modules that define them (:func:`provide_run`).
RUNS: dict[str, Callable[..., Any]] = {}


def register(system: System) -> System:
    """Add ``system`` to :data:`SYSTEMS` (its name must be new)."""
    if system.name in SYSTEMS and SYSTEMS[system.name] is not system:
        raise ValueError(f"a system named {system.name!r} is registered already")
    SYSTEMS[system.name] = system
    return system


def provide_run(system: System, factory: Callable[..., Any], scheme: str | None = None) -> None:
    """Attach the run factory of ``system`` (called by the module that defines the run object);
    ``scheme`` names another scheme of the same system (:meth:`System.runner`), so that the module
    that picks a scheme never imports the module that runs it."""
    RUNS[system.name if scheme is None else f"{system.name}:{scheme}"] = factory


class CarriedState:
    """Base of a run whose state between chunks is the step count ``k`` and the float arrays
    named in :attr:`CARRIED`: its ``state()`` copies them and ``load_state()`` writes them back in
    place (so a run continued from a saved state is bit for bit the uninterrupted run), and
    ``step_failure`` words the :class:`lgvi.ConvergenceError` of a failed step. With ``last``
    (the kernel's iterations and residual of the last step), ``t0``, ``h`` and ``save_every``, it
    gives ``last_its``, ``last_res`` and ``times`` too."""

    #: Names of the arrays the compiled kernel carries from step to step.
    CARRIED: tuple[str, ...] = ()
    # set by each run's __init__: the time grid and what the properties below read
    k: int
    t0: float
    h: float
    steps: int
    save_every: int
    last: np.ndarray

    def state(self) -> dict[str, Any]:
        return {"k": self.k, **{key: getattr(self, key).copy() for key in self.CARRIED}}

    def load_state(self, st: dict[str, Any]) -> None:
        self.k: int = int(st["k"])
        for key in self.CARRIED:
            getattr(self, key)[...] = np.asarray(st[key], dtype=np.float64)

    @property
    def last_its(self) -> int:
        """Solver iterations of the last step (``self.last[0]``, written by the kernel)."""
        return int(self.last[0])

    @property
    def last_res(self) -> float:
        """Final solver residual of the last step (``self.last[1]``)."""
        return float(self.last[1])

    def times(self, j0: int, j1: int) -> np.ndarray:
        """Times of samples ``j0 .. j1 - 1`` (``t0 + j h save_every``)."""
        from ..driver import sample_times

        return sample_times(self.t0, self.h * self.save_every, j0, j1)

    def step_failure(self, what: str, residual: float, iterations: int, trajectory: Any, where: str) -> Exception:
        t = self.t0 + self.k * self.h
        return ConvergenceError(f"{self.system.name.replace('_', '-')} step {self.k} (t = {t:g}) failed: {what}; "
                                f"try a smaller step h{where}", residual=float(residual),
                                iterations=int(iterations), step=self.k, time=t, trajectory=trajectory)

    def collision(self, contact: np.ndarray, trajectory: Any, where: str, core: str, shapes: str = "") -> Exception:
        """The :class:`lgvi.CollisionError` of a step that failed with ``COLLISION``: ``contact``
        (3,) = ``(kind, d_min, L)`` from :mod:`lgvi._kernels.contact_kernels` (kind 1: the path met
        ``core``, 2: it passed the centre closer than its length, 3: the shapes ``shapes`` overlap at
        the new state, ``d_min`` the distance between the centres of mass there)."""
        t = self.t0 + self.k * self.h
        kind, d, L = int(contact[0]), float(contact[1]), float(contact[2])
        if kind == 1:
            what = f"its path came within {d:.6g} of the centre, inside {core}"
        elif kind == 2:
            what = (f"its path passed {d:.6g} from the centre in one step of length {L:.6g}: a fall through the "
                    "centre, or a step far too large for this close approach (it swept more than 53 degrees "
                    "about the centre)")
        else:
            what = f"the bodies overlap at its end ({shapes}), {d:.6g} apart (centres of mass)"
        return CollisionError(f"{self.system.name.replace('_', '-')} step {self.k} (t = {t:g}): collision, {what}. "
                              f"The run up to step {self.k} is in .trajectory{where}", step=self.k, time=t,
                              trajectory=trajectory, distance=d)


from . import rigid_body as rigid_body  # noqa: E402  (registers the rigid body)
from . import orbit as orbit  # noqa: E402  (a body in a central field)
from . import two_body as two_body  # noqa: E402  (two bodies in mutual gravity)
from . import gyrostat as gyrostat  # noqa: E402  (registers the gyrostat: reaction wheels)
from . import chain as chain  # noqa: E402  (chains of spherical pendulums on (S^2)^n)
from . import slosh as slosh  # noqa: E402  (a hub with slosh pendulums on SO(3) x (S^2)^n)

__all__ = ["CarriedState", "Field", "RUNS", "SYSTEMS", "Scene", "SceneLine", "SceneMesh", "System", "provide_run",
           "register"]
