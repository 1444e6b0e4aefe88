"""What runs on board: estimation, guidance, control and mode rules, as components of the compiled
loop (:mod:`lgvi.components`), and :class:`FlightSoftware`, the description that holds them
(``docs/loop.md``)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from .._validation import as_float, as_float_array, as_rotation, choice
from ..components import COMPONENT_KINDS, SIGNALS, Component, ComponentKind, LoopContext, Signal, register_kind

if TYPE_CHECKING:  # annotations only: imported where used at run time
    from ..control import Controller

__all__ = ["FlightSoftware", "InertialPointing", "HillPointing", "NadirPointing", "VelocityPointing", "SunPointing",
           "TargetPointing", "MRPControl", "BDotControl", "MomentumDumpingControl", "RWMotorTorque", "ModeRules",
           "UserComponent", "MODE_CONDITIONS", "mode_label"]


def _unit(v: Any, name: str) -> np.ndarray:
    a = as_float_array(v, name, (3,))
    n = float(np.linalg.norm(a))
    if not n > 0.0:
        raise ValueError(f"{name} must be a non-zero vector (a body axis), got {a.tolist()}")
    return a / n


# ------------------------------------------------------------------------------------------------
# guidance
# ------------------------------------------------------------------------------------------------
class InertialPointing(Component):
    """Guidance: a fixed reference ``R_ref`` (reference frame to inertial; default the identity), with
    optional constant ``omega_ref`` / ``domega_ref`` (inertial components)."""
    domega_ref: np.ndarray

    kind = "inertial_pointing"

    def __init__(self, R_ref: Any = None, *, omega_ref: Any = None, domega_ref: Any = None, rate: Any = None,
                 modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.R_ref: np.ndarray = np.eye(3) if R_ref is None else as_rotation(R_ref, "R_ref")
        self.omega_ref: np.ndarray = np.zeros(3) if omega_ref is None else as_float_array(omega_ref, "omega_ref", (3,))
        self.domega_ref = np.zeros(3) if domega_ref is None else as_float_array(domega_ref, "domega_ref", (3,))

    def params(self) -> np.ndarray:
        return np.concatenate([self.R_ref.ravel(), self.omega_ref, self.domega_ref])


class HillPointing(Component):
    """Guidance: Basilisk's Hill frame (``hillPoint``): x radial (away from the Earth), z along the
    orbit normal ``r x v``, y = z x x (along-track on a circular orbit); the reference rate
    ``(r x v)/|r|^2`` and its derivative ``-2 (r . v)(r x v)/|r|^4``. Body axes on these axes: the
    body's -x points at nadir."""

    kind = "hill_pointing"

    def __init__(self, *, rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)


class NadirPointing(Component):
    """Guidance: lgvi's LVLH frame (:func:`lgvi.environment.lvlh_frame`: z to nadir, y against the
    orbit normal, x = y x z along-track), the rates of :class:`HillPointing`. Body axes on these
    axes: the body's +z points at nadir. Not Basilisk's Hill frame (x radial): see :class:`HillPointing`."""

    kind = "nadir_pointing"

    def __init__(self, *, rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)


class VelocityPointing(Component):
    """Guidance: x along the inertial velocity, z along the orbit normal, y = z x x; the frame turns
    about the normal at ``mu |r x v| / (|r|^3 |v|^2)`` (exact on a Kepler orbit)."""

    kind = "velocity_pointing"

    def __init__(self, *, mu: float | None = None, rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.mu: float | None = None if mu is None else as_float(mu, "mu", positive=True)
        self._mu = self.mu

    def setup(self, ctx: LoopContext) -> None:
        if self.mu is None:
            self._mu = as_float(getattr(ctx.spacecraft.orbit, "mu", None), "orbit.mu", positive=True)

    def params(self) -> np.ndarray:
        return np.array([self._mu])


class SunPointing(Component):
    """Guidance: the body axis ``axis`` at the sun (``sun_N``, from an environment model), the body
    axis ``secondary`` as close as it can go to the orbit normal; reference rates zero."""

    kind = "sun_pointing"

    def __init__(self, axis: Any = (0.0, 0.0, 1.0), secondary: Any = (1.0, 0.0, 0.0), *, rate: Any = None,
                 modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.axis: np.ndarray = _unit(axis, "axis")
        self.secondary: np.ndarray = _unit(secondary, "secondary")
        if np.linalg.norm(np.cross(self.axis, self.secondary)) < 1e-6:
            raise ValueError(f"secondary must not be parallel to axis, got axis={self.axis.tolist()}, "
                             f"secondary={self.secondary.tolist()}")

    def params(self) -> np.ndarray:
        return np.concatenate([self.axis, self.secondary])


class TargetPointing(SunPointing):
    """Guidance: the body axis ``axis`` at an Earth-fixed target (``target_ecef``, m; a ground
    station), the body axis ``secondary`` as close as it can go to the orbit normal; the reference
    rate of the line of sight about itself neglected, its turn ``(l x l')/|l|^2`` given, and the
    derivative of that rate (``domega_ref_N``, with the two-body acceleration of gravitational
    parameter ``mu``, default the orbit's ``mu``: exact on a Kepler orbit). Needs the spacecraft's
    ``epoch`` (the Earth's rotation angle)."""

    kind = "target_pointing"

    def __init__(self, target_ecef: Any, axis: Any = (0.0, 0.0, 1.0), secondary: Any = (1.0, 0.0, 0.0), *,
                 mu: float | None = None, rate: Any = None, modes: Any = None) -> None:
        super().__init__(axis, secondary, rate=rate, modes=modes)
        self.target_ecef: np.ndarray = as_float_array(target_ecef, "target_ecef", (3,))
        self.mu = None if mu is None else as_float(mu, "mu", positive=True)
        self._mu = self.mu
        self._jd0 = math.nan

    def setup(self, ctx: LoopContext) -> None:
        import datetime as _dt

        epoch = ctx.spacecraft.epoch
        if epoch is None:
            raise ValueError("TargetPointing needs the spacecraft's epoch (the Earth's rotation angle): "
                             "Spacecraft(..., epoch=datetime.datetime(...))")
        self._jd0 = (epoch - _dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0
        if self.mu is None:
            self._mu = as_float(getattr(ctx.spacecraft.orbit, "mu", None), "orbit.mu (TargetPointing's mu)",
                                positive=True)

    def params(self) -> np.ndarray:
        return np.concatenate([self.axis, self.secondary, self.target_ecef, [self._jd0, self._mu]])


# ------------------------------------------------------------------------------------------------
# modes
# ------------------------------------------------------------------------------------------------
#: Conditions of a mode rule (name -> code of :mod:`lgvi._kernels.fsw_components`).
MODE_CONDITIONS = {"time_after": 0, "rate_below": 1, "rate_above": 2, "error_below": 3, "error_above": 4,
                   "eclipse": 5, "sunlit": 6, "dwell": 7}


class ModeRules(Component):
    """The mode manager: writes ``mode`` (an index) by rules ``(from, to, condition, threshold)``,
    the first that holds wins; ``from`` ``None`` for any mode. Conditions: ``"time_after"`` (t >=
    x s), ``"dwell"`` (x s in the current mode), ``"rate_below"``/``"rate_above"`` (|omega| in
    rad/s, the estimate when an estimator runs), ``"error_below"``/``"error_above"`` (the attitude
    error angle ``4 atan |sigma_BR|``, rad), ``"eclipse"`` (``shadow <= x``), ``"sunlit"``
    (``shadow >= x``; both need a model writing ``shadow``). Components with ``modes=`` run only in
    those modes; what a component wrote is cleared when it leaves its modes.

    ``names`` (optional) names the modes, ``names[i]`` mode ``i`` (one for every mode the rules and
    ``initial`` use): the run keeps them in ``meta["mode_names"]``, and the summary, the figures and
    the page of ``lgvi view`` show them (:func:`mode_label`).

    Example: detumble (0) with B-dot, then nadir (1) once slow:
    ``ModeRules([(0, 1, "rate_below", 0.01)], initial=0, names=["detumble", "nadir"])``.
    """

    kind = "mode_rules"

    def __init__(self, rules: Sequence[Any], *, initial: int = 0, names: Sequence[str] | None = None,
                 rate: Any = None) -> None:
        super().__init__(rate=rate)
        out = []
        for i, rule in enumerate(rules):
            try:
                frm, to, cond, x = rule
            except (TypeError, ValueError) as exc:
                raise TypeError(f"rules[{i}] must be (from, to, condition, threshold), got {rule!r}") from exc
            cond = choice(cond, f"rules[{i}] condition", tuple(MODE_CONDITIONS))
            for name, m in (("from", frm), ("to", to)):
                if (m is not None or name == "to") and not (isinstance(m, (int, np.integer)) and 0 <= m <= 62):
                    raise ValueError(f"rules[{i}] {name} must be a mode index in 0..62" +
                                     (" or None (any)" if name == "from" else "") + f", got {m!r}")
            out.append((-1.0 if frm is None else float(frm), float(to), float(MODE_CONDITIONS[cond]),
                        as_float(x, f"rules[{i}] threshold")))
        if not out:
            raise ValueError("rules must hold at least one (from, to, condition, threshold)")
        if not (isinstance(initial, (int, np.integer)) and 0 <= initial <= 62):
            raise ValueError(f"initial must be a mode index in 0..62, got {initial!r}")
        self.rules = out
        self.initial: int = int(initial)
        self.names: tuple[str, ...] | None = None if names is None else _mode_names(names, out, self.initial)

    def params(self) -> np.ndarray:
        return np.concatenate([[float(len(self.rules))], np.ravel(self.rules)])

    def __repr__(self) -> str:
        if self.names is None:                   # as before names existed (a stream's metadata compares it)
            return super().__repr__()
        return f"ModeRules(names={list(self.names)!r}, rate={self.rate!r})"


def _mode_names(names: Any, rules: list[tuple[float, float, float, float]], initial: int) -> tuple[str, ...]:
    """``names`` checked: distinct non-empty strings, one for every mode ``rules`` and ``initial`` use."""
    if isinstance(names, str) or not isinstance(names, Sequence):
        raise TypeError(f"names must be a sequence of strings (names[i] names mode i), got {names!r}")
    out = []
    for i, n in enumerate(names):
        if not isinstance(n, str) or not n.strip():
            raise ValueError(f"names[{i}] must be a non-empty string, got {n!r}")
        out.append(n.strip())
    if len(set(out)) != len(out):
        raise ValueError(f"names must be distinct, got {out!r}")
    used = max([initial] + [int(r[1]) for r in rules] + [int(r[0]) for r in rules])
    if len(out) <= used:
        raise ValueError(f"names must name every mode the rules and initial use (0..{used}): got {len(out)} "
                         f"name(s), {out!r}")
    return tuple(out)


def mode_label(meta: Any, mode: Any) -> str:
    """The name of ``mode`` in a run whose :class:`ModeRules` named its modes (``meta["mode_names"]``,
    the run's metadata or the run itself), else ``"mode <index>"``.

    >>> mode_label({"mode_names": ["detumble", "nadir"]}, 1), mode_label({}, 2)
    ('nadir', 'mode 2')
    """
    meta = getattr(meta, "meta", meta) or {}
    names = meta.get("mode_names") if isinstance(meta, Mapping) else None
    m = int(mode)
    if isinstance(names, (list, tuple)) and 0 <= m < len(names) and isinstance(names[m], str):
        return names[m]
    return f"mode {m}"

    def state0(self) -> np.ndarray:
        return np.zeros(1)


# ------------------------------------------------------------------------------------------------
# control
# ------------------------------------------------------------------------------------------------
class MRPControl(Component):
    """Control: Basilisk's ``mrpFeedback`` (the law of :class:`lgvi.control.MRPFeedback`, with the
    reference rates of the guidance): writes ``sigma_BR``, ``omega_BR_B`` and ``torque_request_B``.
    ``inertia`` default the spacecraft's (locked) inertia; the wheels' momenta enter ``H``."""

    kind = "mrp_feedback"

    def __init__(self, K: float, P: float, *, Ki: float | None = None, integral_limit: float | None = None,
                 inertia: Any = None, rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.K = as_float(K, "K", positive=True)
        self.P = as_float(P, "P", positive=True)
        self.Ki: float | None = None if Ki is None else as_float(Ki, "Ki", positive=True)
        if integral_limit is not None and Ki is None:
            raise ValueError("integral_limit bounds the integral term: give Ki too (or leave integral_limit=None)")
        self.integral_limit: float = math.inf if integral_limit is None else as_float(integral_limit, "integral_limit",
                                                                                 positive=True)
        self.inertia: np.ndarray | None = None if inertia is None else as_float_array(inertia, "inertia", (3, 3))
        self._J = np.zeros((3, 3))
        self._axes = np.zeros((0, 3))

    def setup(self, ctx: LoopContext) -> None:
        sc = ctx.spacecraft
        self._J = self.inertia if self.inertia is not None else np.asarray(sc.body.J, dtype=np.float64)
        self._axes = np.zeros((0, 3)) if sc.wheels is None else np.asarray(sc.wheels.axes, dtype=np.float64)

    def params(self) -> np.ndarray:
        lim = self.integral_limit if math.isfinite(self.integral_limit) else 1e300
        return np.concatenate([[self.K, self.P, 0.0 if self.Ki is None else self.Ki, lim], self._J.ravel(),
                               [float(len(self._axes))], self._axes.ravel()])

    def state0(self) -> np.ndarray:
        return np.zeros(5)

    def __repr__(self) -> str:
        return f"MRPControl(K={self.K:g}, P={self.P:g}, Ki={self.Ki!r}, rate={self.rate!r})"


class BDotControl(Component):
    """Control: B-dot detumbling, ``m = -k dB/dt`` (body frame) into ``dipole_request_B``;
    ``derivative="difference"`` (the backward difference between calls, nothing at the first) or
    ``"rate"`` (``m = k omega x B``), as :class:`lgvi.environment.BDot`."""

    kind = "bdot"

    def __init__(self, gain: float, *, derivative: str = "difference", rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.gain: float = as_float(gain, "gain", positive=True)
        self.derivative: str = choice(derivative, "derivative", ("difference", "rate"))

    def params(self) -> np.ndarray:
        return np.array([self.gain, 1.0 if self.derivative == "rate" else 0.0])

    def state0(self) -> np.ndarray:
        return np.zeros(5)


class MomentumDumpingControl(Component):
    """Control: magnetic momentum dumping, ``m = k (h x B)/|B|^2`` into ``dipole_request_B`` (``h``
    the wheels' momentum in the body), as :class:`lgvi.environment.MomentumDumping`."""

    kind = "momentum_dumping"

    def __init__(self, gain: float, *, rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.gain: float = as_float(gain, "gain", positive=True)
        self._axes = np.zeros((0, 3))

    def setup(self, ctx: LoopContext) -> None:
        if ctx.spacecraft.wheels is None:
            raise ValueError("MomentumDumpingControl needs wheels: Spacecraft(..., wheels=lgvi.ReactionWheels(...))")
        self._axes = np.asarray(ctx.spacecraft.wheels.axes, dtype=np.float64)

    def params(self) -> np.ndarray:
        return np.concatenate([[self.gain, float(len(self._axes))], self._axes.ravel()])


# ------------------------------------------------------------------------------------------------
# actuator maps
# ------------------------------------------------------------------------------------------------
class RWMotorTorque(Component):
    """Actuator map: Basilisk's ``rwMotorTorque``, the torque request to wheel motor torques
    ``wheel_command`` (minimum norm, the reaction ``-G u`` equal to the request along
    ``control_axes``, default the three body axes: :func:`lgvi.control.map_to_wheels`)."""
    control_axes: np.ndarray | None

    kind = "rw_motor_torque"

    def __init__(self, *, control_axes: Any = None, rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.control_axes = None if control_axes is None else as_float_array(control_axes, "control_axes", (None, 3))
        self._map = np.zeros((0, 3))

    def setup(self, ctx: LoopContext) -> None:
        from ..control import wheel_map

        wheels = ctx.spacecraft.wheels
        if wheels is None or len(wheels) == 0:
            raise ValueError("RWMotorTorque needs wheels: Spacecraft(..., wheels=lgvi.ReactionWheels(...))")
        if self.control_axes is None:
            self._map = wheel_map(wheels.axes)
        else:
            C = self.control_axes                                   # (m, 3)
            CG = C @ wheels.axes.T                                  # (m, N)
            self._map = -(CG.T @ np.linalg.solve(CG @ CG.T, C))     # u = -CG^T (CG CG^T)^-1 C L

    def params(self) -> np.ndarray:
        return np.concatenate([[float(len(self._map))], self._map.ravel()])

    def sizes(self) -> dict[str, int]:
        return {"wheel_command": len(self._map)}


# ------------------------------------------------------------------------------------------------
# a user's component
# ------------------------------------------------------------------------------------------------
class UserComponent(Component):
    """A component written by the user: ``step(t, bus, p, s, w) -> int``, a ``numba.njit`` function
    of the contract (``docs/components.md``), in ``family``, reading and writing the named signals
    (standard ones, or its own declared as ``own=[lgvi.components.Signal(...)]``), with its
    parameter row ``params`` and initial state ``state``. The loop calls it through a function
    pointer: the function alone is compiled (in memory, once per process and function), the loop is
    the one cached on disk; an exception it raises stops the run (status 4). One user function per
    run (several components may share it with their own rows)."""

    kind = "user"

    def __init__(self, step: Any, *, family: str, reads: Sequence[str] = (), writes: Sequence[str] = (),
                 params: Any = (), state: Any = (), own: Sequence[Signal] = (), name: str = "user",
                 rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        from ..components import FAMILIES

        if not (callable(step) and hasattr(step, "py_func")):
            raise TypeError(f"step must be a numba.njit function step(t, bus, p, s, w) -> int, got {step!r}")
        if family not in FAMILIES:
            raise ValueError(f"family must be one of {FAMILIES}, got {family!r}")
        self.step = step
        self.family = family
        self.own: tuple[Signal, ...] = tuple(own)
        for o in self.own:
            if not isinstance(o, Signal):
                raise TypeError(f"own must hold lgvi.components.Signal rows, got {type(o).__name__}")
            if o.size < 1:
                raise ValueError(f"own signal {o.name!r} must have a size >= 1, got {o.size}")
        names = set(SIGNALS) | {o.name for o in self.own}
        for what, lst in (("reads", reads), ("writes", writes)):
            for s in lst:
                if s not in names:
                    raise ValueError(f"{what} names {s!r}, neither a standard signal (lgvi.components.SIGNALS) nor "
                                     "declared in own")
        self.reads: tuple[str, ...] = tuple(reads)
        self.writes: tuple[str, ...] = tuple(writes)
        self._params = as_float_array(params, "params").reshape(-1)
        self._state = as_float_array(state, "state").reshape(-1)
        self.name: str = str(name)

    def params(self) -> np.ndarray:
        return self._params

    def state0(self) -> np.ndarray:
        return self._state.copy()

    def __repr__(self) -> str:
        return f"UserComponent({self.name!r}, family={self.family!r}, rate={self.rate!r})"


# ------------------------------------------------------------------------------------------------
# the description
# ------------------------------------------------------------------------------------------------
class FlightSoftware:
    """The flight software: what runs on board, each part at its own rate (``docs/loop.md``).

    Parameters
    ----------
    guidance : component or sequence, optional
        :class:`HillPointing`, :class:`NadirPointing`, :class:`InertialPointing`,
        :class:`VelocityPointing`, :class:`SunPointing`, :class:`TargetPointing` (several with
        ``modes=``).
    control : component or sequence, optional
        :class:`MRPControl`, :class:`BDotControl`, :class:`MomentumDumpingControl`.
    actuators : component or sequence, optional
        Actuator maps: :class:`RWMotorTorque`.
    modes : ModeRules, optional
        The mode manager.
    estimator : component or sequence, optional
        Estimators (the ``"estimator"`` family); the controllers then read ``R_est``/``omega_est``.
    components : sequence, optional
        Further components of any family (a :class:`UserComponent`).
    rate : float, optional
        The default period (s) of every part given without its own ``rate``.
    record : sequence of str, optional
        The signals recorded (default: every signal written by a component).
    record_rate : {"writer", "grid"}, optional
        ``"writer"`` (the default): ``traj.records[name]`` holds every value the signal's writer
        wrote, at its own rate, also when it runs faster than the record grid (``save_every``);
        ``"grid"``: the record grid's entries only (memory of one row per entry, whatever the
        writers' rates).
    controller : lgvi.control.Controller, optional
        A controller called from Python every ``control_period`` seconds (as in
        ``lgvi.simulate(..., controller=)``): it reads the truth and the environment of the
        spacecraft's orbit and field (an :class:`lgvi.environment.OrbitEnvironment`); its
        ``Command`` goes on the bus, held: the wheel torques as ``wheel_command``, the body torque
        and the magnetorquers' torque of its dipole as ``tau_command_B``. The compiled components
        run beside it (no actuator may then write ``wheel_command``).
    control_period : float, optional
        Seconds between the controller's calls, a multiple of ``h``.

    Examples
    --------
    >>> import lgvi
    >>> from lgvi.fsw import FlightSoftware, HillPointing, MRPControl, RWMotorTorque
    >>> fsw = FlightSoftware(guidance=HillPointing(), control=MRPControl(K=0.0035, P=0.035),
    ...                      actuators=RWMotorTorque(), rate=1.0)
    >>> [c.kind for c in fsw.components()]
    ['hill_pointing', 'mrp_feedback', 'rw_motor_torque']
    """
    controller: Controller | None
    control_period: Any

    def __init__(self, *, guidance: Any = None, control: Any = None, actuators: Any = None, modes: Any = None,
                 estimator: Any = None, components: Sequence[Any] = (), rate: Any = None,
                 record: Sequence[str] | None = None, record_rate: str = "writer", controller: Any = None,
                 control_period: Any = None) -> None:
        from ..control import Controller

        if controller is not None and not isinstance(controller, Controller):
            raise TypeError(f"controller must be an lgvi.control.Controller (called from Python), got "
                            f"{type(controller).__name__}")
        if (controller is None) != (control_period is None):
            raise ValueError("give controller and control_period (seconds, a multiple of h) together")
        self.controller, self.control_period = controller, control_period
        from ..spacecraft import components_of

        self.guidance: list[Any] = components_of(guidance, "guidance", ("guidance",))
        self.control: list[Any] = components_of(control, "control", ("control",))
        self.actuators: list[Any] = components_of(actuators, "actuators", ("actuator",))
        self.modes: list[Any] = components_of(modes, "modes", ("mode",))
        if len(self.modes) > 1:
            raise ValueError("modes takes one ModeRules (one mode manager)")
        self.estimator: list[Any] = components_of(estimator, "estimator", ("estimator",))
        from ..components import FAMILIES

        self.extra: list[Any] = components_of(components, "components", FAMILIES)
        if rate is not None:
            Component(rate=rate)               # validates it
        self.rate = rate
        self.record: tuple[str, ...] | None = None if record is None else tuple(str(r) for r in record)
        if record_rate not in ("writer", "grid"):
            raise ValueError(f"record_rate must be 'writer' (every value at its writer's rate) or 'grid' (the record "
                             f"grid's entries only), got {record_rate!r}")
        self.record_rate = record_rate

    def components(self) -> list[Any]:
        return self.estimator + self.guidance + self.modes + self.control + self.actuators + self.extra

    def __repr__(self) -> str:
        return "FlightSoftware(" + ", ".join(repr(c) for c in self.components()) + f", rate={self.rate!r})"


def _register() -> None:
    nav = {"navigation": True}
    rows = (
        ComponentKind("inertial_pointing", "guidance", 500, None, (), ("R_ref", "omega_ref_N", "domega_ref_N"),
                      InertialPointing, doc="a fixed reference attitude"),
        ComponentKind("hill_pointing", "guidance", 501, None, ("r_N", "v_N"), ("R_ref", "omega_ref_N", "domega_ref_N"),
                      HillPointing, doc="Basilisk's Hill frame (hillPoint): x radial, z orbit normal"),
        ComponentKind("nadir_pointing", "guidance", 502, None, ("r_N", "v_N"),
                      ("R_ref", "omega_ref_N", "domega_ref_N"), NadirPointing,
                      doc="lgvi's LVLH frame: z nadir, y against the orbit normal"),
        ComponentKind("velocity_pointing", "guidance", 503, None, ("r_N", "v_N"),
                      ("R_ref", "omega_ref_N", "domega_ref_N"), VelocityPointing,
                      doc="x along the velocity, z orbit normal"),
        ComponentKind("sun_pointing", "guidance", 504, None, ("sun_N", "r_N", "v_N"),
                      ("R_ref", "omega_ref_N", "domega_ref_N"), SunPointing,
                      doc="a body axis at the sun, a second one towards the orbit normal"),
        ComponentKind("target_pointing", "guidance", 505, None, ("r_N", "v_N"),
                      ("R_ref", "omega_ref_N", "domega_ref_N"), TargetPointing,
                      doc="a body axis at an Earth-fixed target"),
        ComponentKind("mode_rules", "mode", 600, None, ("omega", "sigma_BR", "shadow"), ("mode",), ModeRules,
                      doc="mode switching on time, rate, attitude error and eclipse",
                      extra={"navigation": True, "optional": ("sigma_BR", "shadow")}),
        ComponentKind("mrp_feedback", "control", 700, None,
                      ("R", "omega", "wheel_momentum", "R_ref", "omega_ref_N", "domega_ref_N"),
                      ("sigma_BR", "omega_BR_B", "torque_request_B"), MRPControl,
                      doc="Basilisk's mrpFeedback", extra=nav),
        ComponentKind("bdot", "control", 701, None, ("B_N", "R", "omega"), ("dipole_request_B",), BDotControl,
                      doc="B-dot detumbling", extra=nav),
        ComponentKind("momentum_dumping", "control", 702, None, ("B_N", "R", "wheel_momentum"), ("dipole_request_B",),
                      MomentumDumpingControl, doc="magnetic momentum dumping", extra=nav),
        ComponentKind("rw_motor_torque", "actuator", 800, None, ("torque_request_B",), ("wheel_command",),
                      RWMotorTorque, doc="Basilisk's rwMotorTorque"),
    )
    for kind in rows:
        if kind.name not in COMPONENT_KINDS:
            register_kind(kind)


_register()


from .estimation import MEKF, davenport, triad  # noqa: E402  (issue 27's estimator and static solvers)

__all__ += ["MEKF", "davenport", "triad"]

from .navigation import SimpleNav  # noqa: E402  (Basilisk's simpleNav: the truth with a bounded walk)

__all__ += ["SimpleNav"]
