"""Components of the compiled control loop: the contract every component kind keeps.

A spacecraft (:mod:`lgvi.spacecraft`: actuators, sensors, disturbance models) and its flight
software (:mod:`lgvi.fsw`: estimation, guidance, control, mode rules) are made of *components*.
Every component runs inside one compiled loop as data, as the built-in torque models do: a kind
(an integer code the loop dispatches on), a parameter row (one per member in an ensemble), a state
slot (carried by resume and streams) and a rate (a whole number of dynamics steps). Components
talk through one float64 *bus* per member: named signals at offsets fixed for the run
(:data:`SIGNALS` lists the standard ones, their sizes, units and frames). The contract, in full,
is in ``docs/components.md``.

The compiled form of a component kind is a ``numba.njit`` function

    step(t, bus, p, s, w) -> int          # 0: ok; anything else stops the run (see STATUS)

* ``t`` float: the time of the step the component runs at (seconds since the run's epoch);
* ``bus`` (nbus,) float64: the member's signals; the component reads and writes slices of it;
* ``p`` (P,) float64: its parameter row (read only);
* ``s`` (S,) float64: its own state (random-stream counters, filter state, integrals, held values);
* ``w`` (W,) int64: the bus offsets of the signals it reads, then of those it writes, in the order
  of its kind's ``reads + writes``.

A kind is registered once in :data:`COMPONENT_KINDS` (the one source of truth the scenario files,
the docs and the tests read) with :func:`register_kind`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

__all__ = ["Signal", "SIGNALS", "ComponentKind", "COMPONENT_KINDS", "FAMILIES", "register_kind", "STATUS"]

#: The families, in the order the loop runs the components due at a step.
FAMILIES: tuple[str, ...] = ("environment", "disturbance", "sensor", "estimator", "guidance", "mode", "control",
                             "actuator")

#: Status a component returns; the loop stops at the first nonzero status, keeps the part computed,
#: and names the component and the time.
STATUS: dict[int, str] = {0: "ok", 1: "wrote a value that is not finite", 2: "diverged (a covariance or state is not finite)",
                          3: "left its valid range (for example a date outside a table)",
                          4: "raised an exception (a user's compiled component)"}


@dataclass(frozen=True)
class Signal:
    """A named slice of the bus: ``size`` (``0``: set by the spacecraft, e.g. one entry a wheel)."""

    name: str
    size: int
    unit: str
    frame: str
    doc: str


def _signals(*rows: tuple[str, int, str, str, str]) -> dict[str, Signal]:
    return {r[0]: Signal(*r) for r in rows}


#: The standard signals. ``R`` and every ``R_*`` are 3x3 row-major, mapping the body (or reference)
#: frame to the inertial frame N (lgvi's ``R``; Basilisk's ``dcm_BN`` is its transpose). Quaternions
#: are scalar-last and of the same rotation (``traj.quaternion``). SI units throughout.
SIGNALS: dict[str, Signal] = _signals(
    # truth, written by the loop before the components run
    ("R", 9, "1", "B->N", "true attitude"),
    ("omega", 3, "rad/s", "B", "true angular velocity of the hub"),
    ("wheel_speed", 0, "rad/s", "wheel", "wheel speeds relative to the body"),
    ("wheel_momentum", 0, "N m s", "wheel", "absolute axial wheel momenta Js (a . omega + wheel_speed)"),
    # environment
    ("r_N", 3, "m", "N", "spacecraft position"),
    ("v_N", 3, "m/s", "N", "spacecraft velocity"),
    ("B_N", 3, "T", "N", "geomagnetic field at the spacecraft"),
    ("sun_N", 3, "1", "N", "unit vector from the spacecraft to the sun"),
    ("sun_distance", 1, "m", "-", "distance from the spacecraft to the sun"),
    ("shadow", 1, "1", "-", "fraction of the solar disc visible (1 sunlit, 0 umbra)"),
    ("density", 1, "kg/m^3", "-", "atmospheric density"),
    ("v_rel_N", 3, "m/s", "N", "velocity relative to the co-rotating atmosphere"),
    # disturbances (each model also writes its own tau_<name>_B, recorded by name)
    ("tau_dist_B", 3, "N m", "B", "sum of the disturbance torques, held over the step"),
    ("tau_gravity_gradient_B", 3, "N m", "B", "the gravity gradient's moment at the step's start (in the "
     "variational step, not in tau_dist_B), written by the loop"),
    # sensors
    ("gyro_B", 3, "rad/s", "B", "gyro measurement"),
    ("st_q", 4, "1", "B->N", "star tracker quaternion (scalar-last)"),
    ("st_valid", 1, "1", "-", "1 when the star tracker measured at this step"),
    ("mag_B", 3, "T", "B", "magnetometer measurement"),
    ("css", 0, "1", "-", "coarse sun sensor outputs"),
    ("sun_B", 3, "1", "B", "sun direction measured in the body frame (fine sun sensor)"),
    ("sun_valid", 1, "1", "-", "1 when the sun direction was measured at this step"),
    # estimator (the controllers read these when an estimator is present, the truth otherwise)
    ("R_est", 9, "1", "B->N", "estimated attitude"),
    ("omega_est", 3, "rad/s", "B", "estimated angular velocity"),
    ("bias_est", 3, "rad/s", "B", "estimated gyro bias"),
    ("P_diag", 6, "mixed", "-", "diagonal of the estimator's covariance (attitude rad^2, bias (rad/s)^2)"),
    # guidance
    ("R_ref", 9, "1", "R->N", "reference attitude"),
    ("omega_ref_N", 3, "rad/s", "N", "reference angular velocity"),
    ("domega_ref_N", 3, "rad/s^2", "N", "reference angular acceleration"),
    ("mode", 1, "1", "-", "active mode (an index into the mode list)"),
    # control
    ("sigma_BR", 3, "1", "B", "attitude error (MRP of the body relative to the reference)"),
    ("omega_BR_B", 3, "rad/s", "B", "rate error"),
    ("torque_request_B", 3, "N m", "B", "requested body torque"),
    ("dipole_request_B", 3, "A m^2", "B", "requested magnetic dipole"),
    # actuators
    ("wheel_command", 0, "N m", "wheel", "wheel motor torque commands"),
    ("dipole_B", 3, "A m^2", "B", "applied magnetic dipole"),
    ("tau_control_B", 3, "N m", "B", "body torque of the actuators other than the wheels"),
    ("tau_command_B", 3, "N m", "B", "body torque of a Python controller (its Command.torque and magnetorquer torque)"),
)


@dataclass(frozen=True)
class ComponentKind:
    """A registered kind of component.

    ``code`` is the integer the compiled loop dispatches on (built-in kinds) or ``0`` for a user's
    kind compiled into the loop as a function argument; ``step`` is the ``numba.njit`` function of
    the contract; ``reads`` and ``writes`` name bus signals (standard ones from :data:`SIGNALS`, or
    a kind's own, which it then declares in ``own`` as ``Signal`` rows); ``cls`` is the Python
    class users build it with (its constructor validates, its ``params()``, ``state0()`` give the
    rows).
    """

    name: str
    family: str
    code: int
    step: Callable[..., int] | None
    reads: tuple[str, ...]
    writes: tuple[str, ...]
    cls: Any = None
    own: tuple[Signal, ...] = ()
    doc: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


#: Every component kind by name (scenario ``type`` keys).
COMPONENT_KINDS: dict[str, ComponentKind] = {}


def register_kind(kind: ComponentKind) -> ComponentKind:
    """Register ``kind``; a second kind of the same name or code is refused."""
    if kind.family not in FAMILIES:
        raise ValueError(f"component kind {kind.name!r}: family must be one of {FAMILIES}, got {kind.family!r}")
    if kind.name in COMPONENT_KINDS and COMPONENT_KINDS[kind.name] is not kind:
        raise ValueError(f"component kind {kind.name!r} is registered already")
    if kind.code and any(k.code == kind.code and k.name != kind.name for k in COMPONENT_KINDS.values()):
        raise ValueError(f"component kind {kind.name!r}: code {kind.code} is taken")
    for name in kind.reads + kind.writes:
        if name not in SIGNALS and name not in {s.name for s in kind.own}:
            raise ValueError(f"component kind {kind.name!r}: signal {name!r} is neither standard nor declared in own")
    COMPONENT_KINDS[kind.name] = kind
    return kind


# ------------------------------------------------------------------------------------------------
# the Python side of a component (added by the loop issue): a base class and the run's context
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LoopContext:
    """What a component may need to build its parameter row, handed to ``Component.setup`` once per
    run: the spacecraft (``lgvi.spacecraft.Spacecraft``: body, wheels, magnetorquers, orbit, field,
    epoch), the step ``h``, the start ``t0`` and end ``t1`` of the run (seconds since its epoch)
    and whether an estimator runs (``navigation``: the controllers then read ``R_est``,
    ``omega_est``); ``member`` is the index of the ensemble member the run is (``None``: a lone
    run), by which a component given one parameter row per member picks its own."""

    spacecraft: Any
    h: float
    t0: float
    t1: float
    navigation: bool = False
    member: int | None = None


class Component:
    """Base of the components (``docs/components.md``, "The Python side").

    ``kind`` names the registered :class:`ComponentKind`; ``rate`` is the period in seconds (a
    whole multiple of the step ``h``; ``None``: every step); ``modes`` the indices of the modes it
    runs in (``None``: all). Subclasses validate their arguments in ``__init__``, may read the run
    in ``setup(ctx)`` (a :class:`LoopContext`), and give ``params()`` (1-D float64 row),
    ``state0()`` (1-D float64) and ``sizes()`` (the sizes of size-0 signals they write)."""

    kind: str = ""
    rate: Any = None
    modes: Any = None

    def __init__(self, *, rate: Any = None, modes: Any = None) -> None:
        import math

        if rate is not None:
            try:
                rate = float(rate)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"rate must be a number of seconds or None, got {rate!r}") from exc
            if not (math.isfinite(rate) and rate > 0.0):
                raise ValueError(f"rate must be a finite number of seconds > 0 (a multiple of h) or None, got {rate!r}")
        self.rate = rate
        if modes is not None:
            if isinstance(modes, (int, float)) and not isinstance(modes, bool):
                modes = (modes,)
            try:
                modes = tuple(int(m) for m in modes)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"modes must be None or a sequence of mode indices (int), got {modes!r}") from exc
            if not modes or any(m < 0 or m > 62 for m in modes):
                raise ValueError(f"modes must be a non-empty sequence of mode indices in 0..62, got {modes!r}")
        self.modes = modes

    def setup(self, ctx: LoopContext) -> None:
        """Read what the run gives (default: nothing)."""

    def params(self) -> Any:
        import numpy as np

        return np.zeros(0)

    def state0(self) -> Any:
        import numpy as np

        return np.zeros(0)

    def sizes(self) -> dict[str, int]:
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}(rate={self.rate!r})"


def kind_of(component: Any) -> ComponentKind | None:
    """The :class:`ComponentKind` of a component object: its registered kind, or for a user's
    component (``kind == "user"``, :class:`lgvi.fsw.UserComponent`) one built from its own family,
    signals and function (code 0); ``None`` if it has none."""
    name = getattr(component, "kind", None)
    if name == "user":
        return ComponentKind(getattr(component, "name", "user"), component.family, 0, component.step,
                             tuple(component.reads), tuple(component.writes), type(component),
                             own=tuple(component.own))
    return COMPONENT_KINDS.get(name) if isinstance(name, str) else None


__all__ += ["Component", "LoopContext", "kind_of"]


# ------------------------------------------------------------------------------------------------
# coefficients that differ per member of an ensemble (one parameter row per member)
# ------------------------------------------------------------------------------------------------
def member_coefficient(value: Any, name: str, *, positive: bool = False, infinite: bool = False) -> Any:
    """A component's coefficient: a number (``float``) or one per member of an ensemble (a 1-D
    array of ``B`` values, returned as a read-only float64 array); every value finite (``+inf``
    too with ``infinite``) and, with ``positive``, ``> 0``. The error names ``name``, the value
    and, for an array, the member."""
    import math

    import numpy as np

    from ._validation import as_float, as_float_array

    if np.ndim(value) == 0:
        if infinite and isinstance(value, (int, float)) and value == math.inf:
            return math.inf
        return as_float(value, name, positive=positive)
    if infinite:                        # +inf is a value here: as_float_array would refuse it
        try:
            a = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a number or one number per member, got {value!r}") from None
    else:
        a = as_float_array(value, name)
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"{name} must be a number or one value per member (a 1-D array of B >= 1 values), got "
                         f"shape {a.shape}")
    ok = np.isfinite(a) | (a == math.inf) if infinite else np.ones(a.shape, bool)
    if positive:
        ok &= a > 0.0
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        rule = "positive and finite" if positive else "finite" + (" or +inf" if infinite else "")
        raise ValueError(f"{name} must be {rule}, got {a[i]} for member {i}")
    a = a.copy()
    a.flags.writeable = False
    return a


def member_rows(*columns: Any, what: str = "coefficients given per member") -> Any:
    """A component's parameter row from its coefficients (numbers, (B,) arrays of one per member,
    or 2-D (1, K) / (B, K) blocks), in order: ``(P,)`` when none is given per member, else
    ``(B, P)`` (a number repeated in every row). Members of different counts are refused (the error
    begins with ``what``)."""
    import numpy as np

    blocks = [np.asarray(c, dtype=np.float64) for c in columns]
    blocks = [b.reshape(1, 1) if b.ndim == 0 else (b[:, None] if b.ndim == 1 else b) for b in blocks]
    counts = sorted({b.shape[0] for b in blocks} - {1})
    if len(counts) > 1:
        raise ValueError(f"{what}: give one value per member of the same ensemble, got {counts} members")
    B = counts[0] if counts else 1
    rows = np.concatenate([np.broadcast_to(b, (B, b.shape[1])) for b in blocks], axis=1)
    return rows if counts else rows[0]


__all__ += ["member_coefficient", "member_rows"]
