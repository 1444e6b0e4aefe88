"""The spacecraft with its flight software in the compiled loop (``docs/loop.md``).

``lgvi.simulate(spacecraft, R0, omega0=..., h=..., steps=..., fsw=...)`` runs this system: the
gyrostat (:mod:`lgvi.systems.gyrostat`) stepped by the compiled loop
(:mod:`lgvi._kernels.loop_kernels`), with the spacecraft's and the flight software's components
(:mod:`lgvi.components`) on a bus, each at its rate, and their signals recorded by name.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from functools import cached_property
from itertools import accumulate, chain
from operator import itemgetter
from typing import TYPE_CHECKING, Any

import numpy as np

from ..components import FAMILIES, SIGNALS, LoopContext, kind_of
from ..driver import MemorySink, drive
from ..errors import ComponentError
from ..trajectory import RESULT_TYPES
from . import Field, System, register
from .._validation import as_float_array
from .gyrostat import GYROSTAT, GyrostatRun, GyrostatTrajectory, gyrostat_from_file, gyrostat_from_stream
from .gyrostat_ensemble import ENSEMBLE_TYPES, GyrostatEnsemble, drive_members, per_member, thread_count
from .loop_records import signal_periods

if TYPE_CHECKING:  # annotations only: imported where used at run time
    from ..fsw import FlightSoftware
    from ..spacecraft import Spacecraft

__all__ = ["SPACECRAFT", "LoopRun", "SpacecraftEnsemble", "SpacecraftTrajectory", "simulate_spacecraft",
           "simulate_spacecraft_ensemble"]

#: Loop inputs and truth: the bus signals the loop itself reads or writes (``io`` of the kernel).
_IO = ("R", "omega", "wheel_speed", "wheel_momentum", "wheel_command", "tau_dist_B", "tau_control_B", "mode",
       "tau_command_B")
_TRUTH = ("R", "omega", "wheel_speed", "wheel_momentum")
#: What a component of a kind marked ``navigation`` reads in place of the truth when an estimator runs.
_NAV = {"R": "R_est", "omega": "omega_est"}


def _compile_user(step: Any, name: str) -> Any:
    """The loop's value of the user's component function ``step`` (compiled once per function and
    process: :func:`lgvi._kernels.loop_kernels.user_component`); a TypeError naming the component
    when the function does not compile for the loop's arguments."""
    from numba.core.errors import NumbaError

    from .._kernels.loop_kernels import user_component

    try:
        return user_component(step)
    except NumbaError as exc:
        first = next((line for line in str(exc).splitlines() if line.strip()), "")
        raise TypeError(f"{name}: its step function must compile as step(t: float, bus, p, s: float64 arrays, "
                        f"w: int64 array) -> int (a status, 0: ok); Numba says: {first}") from exc


def _invariants(spec: Any = None) -> dict[str, dict[str, Any]]:
    return {}


def _loop_kernel() -> Any:
    """The compiled loop (imported when asked for: importing the system compiles nothing)."""
    from .._kernels.loop_kernels import run_loop

    return run_loop


SPACECRAFT = register(System(
    name="spacecraft",
    doc="a spacecraft with its flight software in the compiled loop: the gyrostat's state and the bus signals",
    state=GYROSTAT.state,
    records=GYROSTAT.records + (Field("signals", (0,), np.float64, "the recorded bus signals at each entry's first "
                                                                    "step", filled=True),),
    kernels=lambda: {"run_loop": _loop_kernel()},
    results=GYROSTAT.results + ("signals",),
    scenario_section="spacecraft",
    run_factory=None,
    invariants=_invariants,
    from_stream=lambda meta, arrays, state: _from_stream(meta, arrays, state),
))


@dataclass(frozen=True, eq=False)
class SpacecraftTrajectory(GyrostatTrajectory):
    """A :class:`lgvi.systems.gyrostat.GyrostatTrajectory` with the flight software's records.

    Extra attributes
    ----------------
    signal_data : (E, S) ndarray
        The recorded bus signals, one row per record entry (the bus after the components ran at
        the entry's first step: every ``save_every`` steps, or every step with
        ``solver_record="full"``); ``meta["signals"]`` gives each name's columns.

    ``signals`` is a dict name -> (E, size) array (``sigma_BR``, ``omega_BR_B``,
    ``torque_request_B``, ``wheel_command``, ``dipole_request_B``, ``dipole_B``, ``B_N``, ``mode``,
    ...), ``signal_t`` (E,) their times.
    """

    signal_data: np.ndarray | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.signal_data is not None:
            self.signal_data.flags.writeable = False

    @cached_property
    def signals(self) -> dict[str, np.ndarray]:
        out = {}
        for name, start, size in self.meta.get("signals", []):
            a = self.signal_data[:, start:start + size]
            out[name] = a[:, 0] if name == "mode" else a
        return out

    @cached_property
    def records(self) -> dict[str, Any]:
        """``{name: lgvi.systems.loop_records.Record}``: each signal at its writer's rate (``t``,
        ``values``, ``period``, ``complete``), from the rows of ``signals`` where the writer ran."""
        from .loop_records import records_of

        return records_of(self)

    @cached_property
    def signal_t(self) -> np.ndarray:
        per = 1 if self.meta.get("solver_record") == "full" else int(self.meta.get("save_every", 1))
        return float(self.meta.get("t0", 0.0)) + self.h * per * np.arange(len(self.signal_data))

    def __repr__(self) -> str:
        return super().__repr__().replace("GyrostatTrajectory", "SpacecraftTrajectory", 1) + \
            f", signals {sorted(self.signals)}"

    def _extra_arrays(self) -> dict[str, np.ndarray]:
        return dict(super()._extra_arrays(), signal_data=self.signal_data)


def _from_file(**fields: Any) -> SpacecraftTrajectory:
    data = fields.pop("signal_data")
    base = gyrostat_from_file(**fields)
    width = signal_width(base.meta)
    if data.ndim != 2 or data.shape[1] != width:
        raise ValueError(f"field 'signal_data' must have shape (entries, {width}), got {data.shape}")
    return SpacecraftTrajectory(**{f.name: getattr(base, f.name) for f in dataclasses.fields(GyrostatTrajectory)},
                                signal_data=data)


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> SpacecraftTrajectory:
    """The :class:`SpacecraftTrajectory` of a stream folder (``System.from_stream``)."""
    base = gyrostat_from_stream(meta, arrays, state)
    width = signal_width(meta)
    data = arrays["signals"].reshape(len(arrays["signals"]), -1) if arrays["signals"].size else \
        np.zeros((len(arrays["signals"]), width))
    if data.shape[1] != width:
        raise ValueError(f"field 'signals' must have shape (entries, {width}), got {arrays['signals'].shape}")
    return SpacecraftTrajectory(**{f.name: getattr(base, f.name) for f in dataclasses.fields(GyrostatTrajectory)},
                                signal_data=data)


RESULT_TYPES["spacecraft"] = (RESULT_TYPES["gyrostat"][0] + ("signal_data",), _from_file)


def _period(rate: Any, h: float, what: str) -> int:
    if rate is None:
        return 1
    ratio = float(rate) / abs(h)
    m = round(ratio)                            # an int
    if m < 1 or abs(ratio - m) > 1e-9 * (ratio if ratio > 1.0 else 1.0):
        raise ValueError(f"{what}: rate must be a positive multiple of |h|; got rate={float(rate):g}, h={h:g} "
                         f"(ratio {ratio:.12g})")
    return m


def _fast_layout(run: Any) -> tuple[np.ndarray, list[list[Any]], int]:
    """The kernel's ``sig_fast`` rows ``(period, bus offset, size, column, slots, 0, 0, end)`` (the
    sixth and seventh: the kernel's counters, the next writer step and the slot, set at each call)
    and ``meta["signal_fast"]`` (``[name, column, size, period, slots]``): the recorded signals whose
    writer runs off the record grid (a period that is not a multiple of the grid's), each with
    ``ceil(grid / period)`` slots a record entry after the grid's columns
    (:mod:`lgvi.systems.loop_records`); none with ``FlightSoftware(record_rate="grid")``. The
    kernel's rows are grouped by period (a stable sort: the columns stay those of ``meta``), ``end``
    the row after the last of its group, so a due step visits only the groups' first rows and the
    rows due (:func:`lgvi._kernels.loop_kernels.record_fast`); a signal of size 0 (nothing to copy) has
    no row. The third value: the columns of ``signal_data`` (:func:`signal_width` of the meta)."""
    per = 1 if run.full else run.save_every
    meta: list[list[Any]] = []
    col = len(run.sig_idx)
    periods, offsets = run.meta["signal_periods"], run.offsets
    if run.fsw.record_rate == "writer":
        for name, _, size in run.record_layout:
            p = periods[name]
            if p % per == 0:
                continue                         # the grid holds every value it writes
            slots = -(-per // p)
            meta.append([name, col, size, p, slots])
            col += size * slots
    # a signal of size 0 has no row (the kernel copies at least one value a row)
    rows = sorted(((p, offsets[name], size, c, slots) for name, c, size, p, slots in meta if size > 0),
                  key=itemgetter(0))
    out = np.zeros((len(rows), 8), np.int64)
    if rows:                                 # one flat run of integers: NumPy reads it faster than nested rows
        out[:, :5] = np.fromiter(chain.from_iterable(rows), np.int64, 5 * len(rows)).reshape(len(rows), 5)
        out[:, 7] = np.searchsorted(out[:, 0], out[:, 0], side="right")     # the row after its period group's last
    return out, meta, col


def signal_width(meta: dict[str, Any]) -> int:
    """Columns of a spacecraft run's ``signal_data``: the grid's (``meta["signals"]``) and the
    off-grid records' slots (``meta["signal_fast"]``)."""
    return sum(int(s) for _, _, s in meta.get("signals", [])) + sum(
        int(size) * int(slots) for _, _, size, _, slots in meta.get("signal_fast", []))


#: Widths a component's state had in earlier lgvi versions (a stream saved with one is refused on
#: resume, and the message names the component): the gyro kept 14 values before its noise scales
#: moved into its parameter row.
FORMER_STATE_WIDTHS: dict[str, tuple[int, ...]] = {"gyro": (14,)}


class LoopRun(GyrostatRun):
    """One validated run of a spacecraft and its flight software, driven by :func:`lgvi.driver.drive`."""
    wo: np.ndarray
    spc_c: np.ndarray
    so: np.ndarray
    po: np.ndarray
    nr: np.ndarray
    mask: np.ndarray
    codes: np.ndarray
    spacecraft: Spacecraft
    sizes: dict[str, int]
    python_controller: bool
    offsets: dict[str, int]
    last_res: float
    last_its: int
    fsw: FlightSoftware
    ctrl: int
    #: metadata keys that follow from the compared ones (``fsw``): a stream begun without them resumes
    derived_meta: tuple[str, ...] = ("pointing_modes", "external_torques")

    def __init__(self, spacecraft: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: Any, steps: Any,
                 fsw: Any = None, method: str = "newton", tol: Any = 1e-14, max_iter: Any = 50, alpha: Any = 1.0,
                 save_every: Any = 1, t0: Any = 0.0, solver_record: str = "interval", order: Any = 2,
                 composition: Any = None, member: tuple[int, int] | None = None) -> None:
        from ..fsw import FlightSoftware
        from ..spacecraft import Spacecraft

        if not isinstance(spacecraft, Spacecraft):
            raise TypeError(f"spacecraft must be an lgvi.Spacecraft, got {type(spacecraft).__name__}")
        if fsw is None:
            fsw = FlightSoftware()
        if not isinstance(fsw, FlightSoftware):
            raise TypeError(f"fsw must be an lgvi.FlightSoftware or None, got {type(fsw).__name__}")
        py = fsw.controller
        env = None
        if py is not None and spacecraft.orbit is not None:
            from ..environment.orbits import OrbitEnvironment

            env = OrbitEnvironment(spacecraft.orbit, spacecraft.field, epoch=spacecraft.epoch)
        super().__init__(spacecraft.body, R0, Pi0, omega0=omega0, h=h, steps=steps, wheels=spacecraft.wheels,
                         controller=py, control_period=fsw.control_period, environment=env,
                         magnetorquers=spacecraft.magnetorquers if py is not None else None,
                         method=method, tol=tol, max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0,
                         solver_record=solver_record, order=order, composition=composition)
        # a Python controller runs from Python at its period, its commands held on the bus
        self.ctrl, self.python_controller = 0, py is not None
        self.spacecraft, self.fsw = spacecraft, fsw
        # member: (b, B) for member b of an ensemble of B (rows given per member are picked by b)
        self._members = None if member is None else int(member[1])
        ctx = LoopContext(spacecraft, self.h, self.t0, self.t0 + self.steps * self.h, navigation=bool(fsw.estimator),
                          member=None if member is None else int(member[0]))
        own_fsw = {id(c) for c in fsw.components()}
        items = []
        for c in spacecraft.components() + fsw.components():
            kind = kind_of(c)
            if py is not None and kind.name == "magnetorquers":
                continue                        # the Python controller's dipole goes to the rods in Python
            in_fsw = id(c) in own_fsw
            c = copy.copy(c)                   # its setup is this run's (a shared description stays as given)
            c.setup(ctx)
            rate = c.rate if c.rate is not None or not in_fsw else fsw.rate
            items.append((FAMILIES.index(kind.family), len(items), c, kind, rate))
        items.sort(key=itemgetter(0))           # by family; a stable sort keeps the order given within one
        self.gg: int = 0
        self.ggp: np.ndarray = np.zeros(13 + 12)
        comps = []
        for _, _, c, kind, rate in items:
            if kind.extra.get("variational"):
                if self.gg:
                    raise ValueError("disturbances: give one GravityGradient")
                self.gg, self.ggp = 1, np.ascontiguousarray(c.params(), dtype=np.float64)
                continue
            comps.append((c, kind, rate))
        periods = self._wire(comps, ctx)
        self.label = "simulation"
        self.meta["system"] = "spacecraft"
        self.meta["spacecraft"] = repr(spacecraft)
        self.meta["fsw"] = repr(fsw)
        if fsw.modes and getattr(fsw.modes[0], "names", None):
            self.meta["mode_names"] = list(fsw.modes[0].names)       # figures, summary and page name the modes
        # the control laws (they write sigma_BR), the kinds whose torque acts from outside (on tau_dist_B or
        # tau_control_B) and whether a component commands the wheels, in one pass over the components
        laws, pushing, commanded = [], [], False
        for c, kind, _ in comps:
            writes = kind.writes
            if "sigma_BR" in writes:
                laws.append(c)
            if "tau_dist_B" in writes or "tau_control_B" in writes:
                pushing.append(kind.name)
            if "wheel_command" in writes:
                commanded = True
        if laws:       # the modes with a control law (pointing); None: every mode (loop_summary reads it)
            self.meta["pointing_modes"] = (None if any(getattr(c, "modes", None) is None for c in laws)
                                           else sorted({int(m) for c in laws for m in c.modes}))
        self.meta["signals"] = list(map(list, self.record_layout))
        # traj.records: each at its writer's rate
        self.meta["signal_periods"] = signal_periods(self.record_layout, periods)
        self.sig_fast, self.meta["signal_fast"], width = _fast_layout(self)
        self.meta["components"] = [f"{kind.name} every {spc * abs(self.h):g} s" for (c, kind, _), spc in
                                   zip(comps, self.spc_c.tolist())]
        self.meta["torque_model"] = "the spacecraft loop (" + ", ".join(self.meta["components"]) + ")" + (
            " with the gravity gradient along the orbit" if self.gg else "")
        # a body torque can act (no invariant declared): the gravity gradient, a disturbance or the
        # rods on the bus; a Python controller's body torque sets it when it acts (GyrostatRun)
        self.external = bool(self.gg) or self.external or bool(pushing)
        # what acts from outside, by kind (the conservation figure, the summary and the page name them)
        self.meta["external_torques"] = pushing + (["gravity_gradient"] if self.gg else []) + (
            ["python_controller"] if self.python_controller and self.external else [])
        self.motors_off = self.motors_off and not commanded
        self.meta["invariants"] = GYROSTAT.invariants(self)
        self.system: System = dataclasses.replace(
            SPACECRAFT, state=self.system.state,
            # filled: the loop writes each complete entry's every column (the grid's at its first step, each
            # off-grid slot at its writer's step or NaN first: record_fast), so it is allocated uninitialised
            records=self.system.records + (Field("signals", (width,), np.float64,
                                                 SPACECRAFT.records[-1].doc, filled=True),))

    # -------------------------------------------------------------- the bus
    def _size(self, name: str, comp: Any, own: dict[str, Any]) -> int:
        if name in own:
            return int(own[name].size)
        size = SIGNALS[name].size
        if size:
            return size
        if name.startswith("wheel_"):
            return self.N
        got = comp.sizes().get(name) if comp is not None else None
        if got is None:
            raise ValueError(f"signal {name!r} has a size set by the spacecraft, and no component gives it (sizes())")
        return int(got)

    def _wire(self, comps: list[Any], ctx: LoopContext) -> dict[str, list[int]]:
        """Place the signals on the bus and build the kernel's rows of the components (``comps``:
        ``(component, kind, rate)`` in the loop's order) and the record layout; returns the periods
        (steps) of each signal's writers (:func:`lgvi.systems.loop_records.signal_periods`)."""
        offsets: dict[str, int] = {}
        sizes: dict[str, int] = {}
        nbus = 0
        own: dict[str, Any] = {sig.name: sig for _, kind, _ in comps for sig in kind.own}

        def place(name: str, comp: Any) -> None:
            nonlocal nbus
            if name not in offsets:
                size = self._size(name, comp, own)
                sizes[name] = size
                offsets[name] = nbus
                nbus += size

        for name in ("R", "omega") + (("wheel_speed", "wheel_momentum") if self.N else ()):
            place(name, None)
        # the signals something writes: the loop (the truth; the gravity gradient's variational moment,
        # recorded by name for the momentum budget), the Python controller, the components; each is on the bus
        written = set(offsets)
        if self.gg:
            place("tau_gravity_gradient_B", None)
            written.add("tau_gravity_gradient_B")
        if self.python_controller:
            for name in ("tau_command_B",) + (("wheel_command",) if self.N else ()):
                place(name, None)
                written.add(name)
        wired = []
        py = self.python_controller
        for c, kind, rate in comps:
            # the controllers read the estimate where an estimator runs
            reads = (tuple(map(_NAV.get, kind.reads, kind.reads)) if ctx.navigation
                     and kind.extra.get("navigation", False) else tuple(kind.reads))
            for name in kind.writes:
                if py and name == "wheel_command":
                    raise ValueError(f"{kind.name} writes wheel_command, which the Python controller "
                                     f"{self.controller!r} commands: give one of the two")
                if name not in offsets:
                    place(name, c)
            written.update(kind.writes)
            wired.append((c, kind, rate, reads))
        W: list[int] = []
        WS: list[int] = []
        codes, spc, mask, nr, po, so, wo = [], [], [], [], [0], [0], [0]
        P, S = [], []
        users = []
        initial: dict[str, float] = {}
        for c, kind, rate, reads in wired:
            if "initial" in kind.extra:
                initial.update(kind.extra["initial"])
            zeros = kind.extra.get("zeros")
            if zeros:
                for name in reads:
                    if name not in written and name in zeros:
                        place(name, c)          # nothing writes it: a slot held at its initial value
        periods: dict[str, list[int]] = {}      # the periods (steps) of each signal's writers
        offset_of, size_of = offsets.__getitem__, sizes.__getitem__
        for c, kind, rate, reads in wired:
            for name in reads:                  # every signal written is on the bus
                if name not in offsets:         # one nothing writes: an optional read (-1, size 0), or refused
                    if name in kind.extra.get("optional", ()):
                        W.append(-1)
                        WS.append(0)
                        continue
                    if name.startswith("wheel_") and self.N == 0:
                        raise ValueError(f"{kind.name}: reads {name!r}, and the spacecraft has no wheels: give "
                                         "Spacecraft(..., wheels=lgvi.ReactionWheels(...))")
                    raise ValueError(f"{kind.name}: reads the signal {name!r}, which no component of the "
                                     "spacecraft or the flight software writes (a family missing: an orbit for "
                                     "r_N, v_N, a field for B_N, a guidance law for R_ref, an estimator for R_est)")
                W.append(offsets[name])
                WS.append(sizes[name])
            k = _period(rate, self.h, kind.name)
            W += map(offset_of, kind.writes)
            WS += map(size_of, kind.writes)
            for name in kind.writes:
                periods.setdefault(name, []).append(k)
            codes.append(kind.code)
            spc.append(k)
            modes = getattr(c, "modes", None)
            mask.append(-1 if modes is None else sum(1 << m for m in modes))
            nr.append(len(reads))
            p = self._member_row(c.params(), kind.name, "params()", ctx.member, self._members)
            s = self._member_row(c.state0(), kind.name, "state0()", ctx.member, self._members)
            P.append(p)
            S.append(s)
            po.append(po[-1] + len(p))
            so.append(so[-1] + len(s))
            wo.append(len(W))
            if kind.code == 0:
                users.append((kind.step, kind.name))
        if len({id(u) for u, _ in users}) > 1:
            raise ValueError("the loop takes one user component function per run (several components may share it "
                             f"with their own params); got {len({id(u) for u, _ in users})}")
        self.user: Any | None = users[0][0] if users else None
        if users:
            _compile_user(*users[0])
        self.names: list[Any] = [kind.name for _, kind, _, _ in wired]
        i64 = np.int64
        self.codes, self.spc_c, self.mask = np.array(codes, i64), np.array(spc, i64), np.array(mask, i64)
        self.nr, self.po, self.so, self.wo = (np.array(nr, i64), np.array(po, i64), np.array(so, i64),
                                              np.array(wo, i64))
        self.P = np.concatenate(P) if P else np.zeros(0)
        if np.isnan(self.P).any():              # inf is a value some rows hold (no saturation, no ceiling)
            bad = next(i for i, p in enumerate(P) if np.isnan(p).any())
            raise ValueError(f"{self.names[bad]}: params() holds NaN")
        self.S = np.concatenate(S) if S else np.zeros(0)
        self.W, self.WS = np.array(W, i64), np.array(WS, i64)
        self.bus: np.ndarray = np.zeros(max(nbus, 1))
        for name, value in initial.items():
            # a reader's initial value (the MEKF's NaN time: "nothing measured yet") is for a slot nothing
            # writes; a slot a component writes starts at zero, as its writer's state does, since the loop
            # refuses a writer leaving a value that is not finite (a star tracker excluded at its first sample)
            if name in offsets and name not in written:
                self.bus[offsets[name]:offsets[name] + sizes[name]] = value
        # the disturbances that add into tau_dist_B (their own torque first): the loop sums the held ones
        dist = [i for i, (c, kind, _, _) in enumerate(wired) if kind.family == "disturbance"
                and "tau_dist_B" in kind.writes and kind.writes[0] != "tau_dist_B"
                and SIGNALS.get(kind.writes[0]) is None and sizes.get(kind.writes[0]) == 3]
        self.io: np.ndarray = np.array([offsets.get(name, -1) for name in _IO] + [len(dist)] + dist
                                       + [self._lookahead(wired, dist), offsets.get("tau_gravity_gradient_B", -1)],
                                       i64)
        modes = [c for c, kind, _, _ in wired if kind.family == "mode"]
        if modes:
            self.bus[offsets["mode"]] = float(getattr(modes[0], "initial", 0))
        record = self.fsw.record
        if record is None:                      # what is written, in the bus's order, but the truth
            record = list(filter(written.difference(_TRUTH).__contains__, offsets))
        start = list(map(offsets.get, record))
        if None in start:
            name = record[start.index(None)]
            raise ValueError(f"record names {name!r}, which is not on this run's bus; on it: {sorted(offsets)}")
        width = list(map(size_of, record))
        cols = list(accumulate(width, initial=0))
        self.record_layout = list(zip(record, cols, width))     # (name, its first column, size)
        # the bus slot of each column: a signal's columns hold its slots from its offset on
        self.sig_idx: np.ndarray = np.arange(cols[-1], dtype=i64) + np.repeat(
            np.array(start, i64) - np.array(cols[:-1], i64), width)
        periods["tau_dist_B"] = [1]             # the loop sums the held disturbance torques at every step
        periods["tau_gravity_gradient_B"] = [1]  # the loop writes the variational moment at every step
        if self.python_controller:
            periods["tau_command_B"] = periods["wheel_command"] = [int(self.spc)]
        self.offsets, self.sizes = offsets, sizes
        self.fail: np.ndarray = np.zeros(2, i64)
        self.nxt: np.ndarray = np.zeros(len(codes), i64)     # the loop's next due step of each component
        return periods

    @staticmethod
    def _lookahead(wired: list[Any], dist: list[int]) -> int:
        """How many leading components the loop runs again at each step's end, for the symmetric
        forcing of the disturbances (``docs/environment.md``): the built-in environment and
        disturbance kinds active in every mode whose inputs are the attitude or what the leading ones
        write (a function of the time and the attitude, not of the rates); 0 (every disturbance held
        over the step, first order) unless each disturbance that adds into ``tau_dist_B`` is one."""
        L = 0
        written = {"R"}
        for c, kind, _, reads in wired:
            modes = getattr(c, "modes", None)
            if (kind.code == 0 or kind.family not in ("environment", "disturbance") or modes is not None
                    or not set(reads) <= written):
                break
            written.update(kind.writes)
            L += 1
        return L if all(i < L for i in dist) else 0

    @staticmethod
    def _member_row(rows: Any, name: str, what: str, member: int | None, members: int | None) -> np.ndarray:
        """A component's row for this run: ``rows`` itself (1-D), or row ``member`` of a (B, n) array
        (one row per member of an ensemble; a lone run takes it only when B is 1)."""
        if type(rows) is np.ndarray and rows.ndim == 1 and rows.dtype == np.float64 and rows.flags.c_contiguous:
            return rows                          # what the checks below return for it, without them
        a = np.asarray(rows, dtype=np.float64)
        if a.ndim == 2:
            if member is None:
                if a.shape[0] != 1:
                    raise ValueError(f"{name}: {what} gives {a.shape[0]} rows (one per member of an ensemble); a lone "
                                     "run takes one: give one value set, or run it with lgvi.simulate_ensemble")
                a = a[0]
            else:
                if a.shape[0] != members:
                    raise ValueError(f"{name}: {what} gives {a.shape[0]} rows (one per member), and the ensemble has "
                                     f"{members} members: give one row per member")
                a = a[member]
        elif a.ndim != 1:
            raise ValueError(f"{name}: {what} must be one row (1-D) or one row per member (2-D), got shape {a.shape}")
        return np.ascontiguousarray(a)

    # -------------------------------------------------------------- stepping
    def _kernel(self, k0: int, n: int, kb: int, R_out, Pi_out, rho_out, it_out, res_out, u_out, sig_out) -> int:
        from .._kernels.loop_kernels import no_user_component, run_loop, user_component

        per = 1 if self.full else self.save_every
        user = no_user_component() if self.user is None else user_component(self.user)
        status, k, it_sum, rmax, its, rn = run_loop(
            user, self.gg, self.ggp, self.Rs, self.JdB, self.JB_inv, self.h, self.gam, self.t0, self.R, self.Pi,
            self.wheel_momentum, self.G, self.wheels.axes, self.wp, self.cmd, self.u_now, self.bus, self.io, self.codes,
            self.spc_c, self.mask, self.nr, self.P, self.po, self.S, self.so, self.W, self.wo, self.WS, self.sig_idx,
            self.sig_fast, k0, n, kb, self.tol, self.max_iter, self.save_every, per, R_out, Pi_out, rho_out, u_out, it_out, res_out,
            sig_out, self.counts, self.fail, self.nxt)
        self.k: int = int(k)
        self.it_total += int(it_sum) - (int(its) if status != 0 else 0)
        self.res_max: float = max(self.res_max, float(rmax))
        self.last_its, self.last_res = int(its), float(rn)
        return int(status)

    def advance(self, n: int, R_out, Pi_out, rho_out, it_out, res_out, u_out, sig_out, partial) -> int:
        kb = self.k
        end = kb + n
        if not self.python_controller:
            return self._kernel(kb, n, kb, R_out, Pi_out, rho_out, it_out, res_out, u_out, sig_out)
        oc, ot = self.offsets.get("wheel_command"), self.offsets["tau_command_B"]
        while self.k < end:
            k = self.k
            if k % self.spc == 0:
                self._call_controller(k, partial)         # GyrostatRun's: self.cmd, self.tau
                if oc is not None:
                    self.bus[oc:oc + self.N] = self.cmd
                self.bus[ot:ot + 3] = self.tau
            m = min(end, (k // self.spc + 1) * self.spc) - k
            status = self._kernel(k, m, kb, R_out, Pi_out, rho_out, it_out, res_out, u_out, sig_out)
            if status != 0:
                return status
        return 0

    def trajectory(self, t, R_out, Pi_out, rho_out, it_out, res_out, u_out, sig_out,
                   partial: bool = False) -> SpacecraftTrajectory:
        base = super().trajectory(t, R_out, Pi_out, rho_out, it_out, res_out, u_out, partial=partial)
        return SpacecraftTrajectory(**{f.name: getattr(base, f.name) for f in dataclasses.fields(GyrostatTrajectory)},
                                    signal_data=sig_out)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = "") -> Exception:
        from .._kernels.loop_kernels import COMPONENT_FAILED
        from ..components import STATUS

        if status != COMPONENT_FAILED:
            return super().failure(status, residual, iterations, trajectory, where)
        c, st = int(self.fail[0]), int(self.fail[1])
        name = "orbit_gravity_gradient (the orbit table ended)" if c < 0 else f"{self.names[c]} (component {c})"
        k = self.k
        t = self.t0 + k * self.h
        return ComponentError(f"{name} stopped the run at step {k} (t = {t:g} s): status {st}, "
                              f"{STATUS.get(st, 'unknown status')}. The run up to step {k} is in .trajectory." + where,
                              component=name.split(" ")[0], status=st, step=k, time=t, trajectory=trajectory)

    def state(self) -> dict[str, Any]:
        st = super().state()
        st.update(S=self.S.copy(), bus=self.bus.copy(), S_widths=self._state_widths())
        return st

    def _state_widths(self) -> list[list[Any]]:
        """``[[kind name, width of its state], ...]`` of the wired components, in the loop's order."""
        return [[str(name), int(self.so[i + 1] - self.so[i])] for i, name in enumerate(self.names)]

    def _check_state_layout(self, st: dict[str, Any]) -> None:
        """Refuse a saved state whose components' state widths differ from this run's (a stream saved
        by an lgvi whose component kept another layout), naming the component and the rule."""
        rule = ("a stream resumes only with the components' state layout it was saved with (it was saved by "
                "another lgvi version); run it again from the start")
        mine = self._state_widths()
        saved = st.get("S_widths")
        size = int(np.size(st["S"]))
        if saved is not None:
            for i in range(max(len(mine), len(saved))):
                a = mine[i] if i < len(mine) else None
                b = list(saved[i]) if i < len(saved) else None
                if a != b:
                    raise ValueError(
                        "resume: " + (f"the stream's saved state of component {i} ({b[0]}) holds {b[1]} values"
                                      if b is not None else f"the stream's saved state has no component {i}")
                        + ", " + (f"this run's ({a[0]}) holds {a[1]}" if a is not None else "this run has none")
                        + f"; {rule}")
        if size != self.S.size:
            diff = size - self.S.size
            named = [f"the {name}'s state held {w + diff} values in the lgvi that saved it, {w} in this one"
                     for name, w in mine if w + diff in FORMER_STATE_WIDTHS.get(name, ())]
            raise ValueError(f"resume: the stream's saved component state holds {size} values, this run's components "
                             f"hold {self.S.size} (" + ", ".join(f"{n} {w}" for n, w in mine) + ")"
                             + (f": {named[0]}" if named else "") + f"; {rule}")
        if np.size(st["bus"]) != self.bus.size:
            raise ValueError(f"resume: the stream's saved signal bus holds {np.size(st['bus'])} values, this run's "
                             f"{self.bus.size}; {rule}")

    def load_state(self, st: dict[str, Any]) -> None:
        self._check_state_layout(st)
        super().load_state(st)
        self.S[...] = np.asarray(st["S"], dtype=np.float64)
        self.bus[...] = np.asarray(st["bus"], dtype=np.float64)


def simulate_spacecraft(spacecraft: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: Any, steps: Any,
                        fsw: Any = None, progress: Any = False, **options: Any) -> SpacecraftTrajectory:
    """:func:`lgvi.simulate` with a :class:`lgvi.Spacecraft` (see there and ``docs/loop.md``)."""
    run = LoopRun(spacecraft, R0, Pi0, omega0=omega0, h=h, steps=steps, fsw=fsw, **options)
    return drive(run, MemorySink(run), progress)


class SpacecraftEnsemble(GyrostatEnsemble):
    """A :class:`lgvi.systems.gyrostat_ensemble.GyrostatEnsemble` of spacecraft runs (members are
    :class:`SpacecraftTrajectory`); ``signals`` stacks the records by name, (B, E, size);
    ``params["component.<kind>"]`` holds each component's parameter row per member (B, P).
    Saved with :meth:`save` (and read by ``load``, :func:`lgvi.load`) it keeps the records too."""

    @cached_property
    def signals(self) -> dict[str, np.ndarray]:
        return {name: np.stack([m.signals[name] for m in self.members]) for name in self.members[0].signals}


ENSEMBLE_TYPES["spacecraft"] = SpacecraftEnsemble      # its save and load keep the records (signal_data)


def simulate_spacecraft_ensemble(spacecraft: Any, R: np.ndarray, Pi0: Any = None, *, omega0: Any = None, h: Any,
                                 steps: Any, fsw: Any = None, threads: Any = None,
                                 **options: Any) -> SpacecraftEnsemble:
    """:func:`lgvi.simulate_ensemble` with a :class:`lgvi.Spacecraft` (see there): ``spacecraft`` and
    ``fsw`` one for all members or one per member (their inertias, wheels, gains, rates disperse);
    member ``b`` equals ``lgvi.simulate(spacecraft[b], R[b], ..., fsw=fsw[b])`` bit for bit, and
    its gravity gradient uses its own inertia. ``R`` (B, 3, 3) rotations validated by the caller."""
    from ..fsw import FlightSoftware
    from ..spacecraft import Spacecraft

    B = len(R)
    if (Pi0 is None) == (omega0 is None):
        raise ValueError("give the initial body angular momenta Pi0 (B, 3) or the angular velocities omega0 (B, 3), "
                         "one of the two")
    init = as_float_array(Pi0 if omega0 is None else omega0, "Pi0" if omega0 is None else "omega0", (B, 3))
    scs = per_member(spacecraft, "spacecraft", B, Spacecraft)
    fl = per_member(FlightSoftware() if fsw is None else fsw, "fsw", B, FlightSoftware)
    runs = []
    for b in range(B):
        kw = {"Pi0": init[b], "omega0": None} if omega0 is None else {"Pi0": None, "omega0": init[b]}
        try:
            runs.append(LoopRun(scs[b], R[b], kw["Pi0"], omega0=kw["omega0"], h=h, steps=steps, fsw=fl[b], member=(b, B),
                                **options))
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"member {b}: {exc}") from exc
    params: dict[str, np.ndarray] = {"inertia": np.stack([r.body.J for r in runs]), "R0": R.copy(),
                                     "Pi0": np.stack([r.Pi for r in runs])}
    first = runs[0]
    if all(r.names == first.names and r.po.tolist() == first.po.tolist() for r in runs):
        for c, name in enumerate(first.names):
            params[f"component.{c}.{name}"] = np.stack([r.P[r.po[c]:r.po[c + 1]] for r in runs])
    if first.gg:
        params["gravity_gradient.inertia"] = np.stack([r.ggp[1:10] for r in runs])
    members = drive_members(runs, threads)
    meta = dict(members[0].meta, members=B, threads=min(thread_count(threads, B), B))
    for key in ("wheels", "solver_summary", "invariants"):
        meta.pop(key, None)
    return SpacecraftEnsemble(members=tuple(members), params=params, meta=meta)


def _provide() -> None:
    from . import provide_run

    provide_run(SPACECRAFT, LoopRun)


_provide()
