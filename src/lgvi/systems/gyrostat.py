"""The gyrostat: a rigid body with balanced reaction wheels, ``(R, Pi, rho)`` (``docs/gyrostat.md``).

``lgvi.simulate(body, R0, omega0=..., h=..., steps=..., wheels=lgvi.ReactionWheels(...),
controller=..., control_period=...)`` runs this system. ``body`` is the whole spacecraft with the
wheels locked (Basilisk's convention for balanced wheels); ``Pi`` is the total body angular
momentum (hub plus wheels) and ``rho_i`` the absolute axial momentum of wheel ``i``. The step is
the LGVI of the discrete Routhian of the cyclic wheel angles: the implicit equation keeps its form
with the shifted, non-symmetric matrix ``Jd_B + h/2 hat(G rho_bar)`` (compiled kernel:
:mod:`lgvi._kernels.gyrostat_kernels`).
"""

from __future__ import annotations

import dataclasses
import math
import operator
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from .._validation import as_float, as_float_array, as_int, as_rotation, choice
from .._version import __version__
from ..accuracy import check_options, with_estimate
from .._kernels.codes import USER_RAISED
from ..body import RigidBody
from ..control import Command, Controller
from ..driver import MemorySink, check_memory, drive, run_solver_options, sample_times, time_grid
from ..errors import ConvergenceError, TorqueError
from ..invariants import BOUNDED, EXACT
from ..registry import Composition, composition_for
from ..trajectory import HIST_BINS, RESULT_TYPES, Trajectory, freeze_arrays, summary_dict
from . import Field, System, register

#: Steps per compiled call when no Python controller needs the loop back sooner.
CHUNK_STEPS = 1 << 16
#: Default speed (rad/s) below which wheel friction is linear through zero (Basilisk's omegaLimitCycle).
OMEGA_LIMIT_CYCLE = 1e-4
#: Tolerance on the norm of a wheel axis.
AXIS_TOL = 1e-6
#: The arrays of :class:`ReactionWheels` (what its derived values are computed from; the hub
#: inertia from the first two).
_WHEEL_ARRAYS = ("axes", "spin_inertia", "speed0", "max_torque", "min_torque", "max_power", "max_speed", "coulomb",
                 "viscous", "omega_limit_cycle")
#: ``(J_B, J_B^-1, Jd_B)`` by the numbers they are computed from (the body's inertia, the wheels'
#: axes and spin inertias, with shapes): shared by wheels with the same numbers; the last 16.
_HUBS: dict[tuple[Any, ...], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _per_wheel(value: Any, name: str, n: int, *, minimum: float | None = None, strict: bool = False,
               none: float | None = None) -> np.ndarray:
    """A scalar or (N,) array of finite floats, checked against ``minimum`` (``strict``: above)."""
    if value is None:
        return np.array([np.nan if none is None else none] * n, dtype=np.float64)     # np.full, cheaper
    if isinstance(value, float) and math.isfinite(value):   # the common case (np.float64 too), no array round trip
        if minimum is not None and (value <= minimum if strict else value < minimum):
            rule = f"> {minimum:g}" if strict else f">= {minimum:g}"
            raise ValueError(f"{name} must be {rule} for every wheel; wheel 0 has {value:g}")
        return np.array([value] * n, dtype=np.float64)
    arr = as_float_array(value, name)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    elif arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have shape ({n},) (one per wheel), got shape {arr.shape}")
    if minimum is not None:
        bad = arr <= minimum if strict else arr < minimum
        if np.any(bad):
            i = int(np.argmax(bad))
            rule = f"> {minimum:g}" if strict else f">= {minimum:g}"
            raise ValueError(f"{name} must be {rule} for every wheel; wheel {i} has {arr[i]:g}")
    return arr.copy()


class ReactionWheels:
    """Balanced reaction wheels in the body, for ``lgvi.simulate(..., wheels=...)``.

    Parameters
    ----------
    axes : (N, 3) array_like
        Spin axes in the body frame, unit vectors (to 1e-6; stored normalised).
    spin_inertia : float or (N,) array_like
        Axial moments of inertia ``Js``, kg m^2 (> 0).
    speed0 : float or (N,) array_like
        Initial wheel speeds relative to the body, rad/s.
    max_torque : float or (N,) array_like, optional
        Motor torque limit, N m (> 0); ``None``: none.
    min_torque : float or (N,) array_like
        Deadband: requests below this magnitude give no torque, N m (>= 0).
    max_power : float or (N,) array_like, optional
        Motor power limit ``|u Omega|``, W (> 0); ``None``: none.
    max_speed : float or (N,) array_like, optional
        Speed limit, rad/s (> 0): a torque that would spin a wheel at or beyond it is refused.
    friction : dict, optional
        ``{"coulomb": N m, "viscous": N m s, "omega_limit_cycle": rad/s}`` (each a scalar or (N,),
        all >= 0; the last > 0, default 1e-4): friction ``-(coulomb sign(Omega) + viscous Omega)``,
        linear through zero below ``omega_limit_cycle`` (Basilisk's model without Stribeck).

    Notes
    -----
    The saturation follows Basilisk's ``reactionWheelStateEffector``, in its order: torque limit,
    deadband, power limit (``|u| = max_power / |Omega|``), speed limit (no torque with
    ``Omega u >= 0`` once ``|Omega| >= max_speed``). lgvi applies it at every step with the speed
    at the step's start (Basilisk: at each of its task updates).
    """

    def __init__(self, axes: Any, spin_inertia: Any, *, speed0: Any = 0.0, max_torque: Any = None,
                 min_torque: Any = 0.0, max_power: Any = None, max_speed: Any = None, friction: Any = None) -> None:
        a = as_float_array(axes, "axes")
        if a.ndim == 1 and a.shape == (3,):
            a = a[None, :]
        if a.ndim != 2 or a.shape[1] != 3:
            raise ValueError(f"axes must have shape (N, 3) (one unit vector per wheel), got shape {a.shape}")
        n = a.shape[0]
        norms = [math.sqrt((x * x + y * y) + z * z) for x, y, z in a.tolist()]   # np.linalg.norm(a, axis=1)
        for i, norm in enumerate(norms):
            if abs(norm - 1.0) > AXIS_TOL:
                raise ValueError(f"axes must be unit vectors (to {AXIS_TOL:g}); axis {i} {a[i].tolist()} has norm "
                                 f"{norm:.9g}: divide it by its norm")
        self.axes: np.ndarray = a / np.array(norms)[:, None] if n else a.reshape(0, 3)
        self.spin_inertia: np.ndarray = _per_wheel(spin_inertia, "spin_inertia", n, minimum=0.0, strict=True)
        self.speed0: np.ndarray = _per_wheel(speed0, "speed0", n)
        self.max_torque: np.ndarray = _per_wheel(max_torque, "max_torque", n, minimum=0.0, strict=True, none=0.0)
        self.min_torque: np.ndarray = _per_wheel(min_torque, "min_torque", n, minimum=0.0)
        self.max_power: np.ndarray = _per_wheel(max_power, "max_power", n, minimum=0.0, strict=True, none=0.0)
        self.max_speed: np.ndarray = _per_wheel(max_speed, "max_speed", n, minimum=0.0, strict=True, none=0.0)
        above = (self.max_torque > 0.0) & (self.min_torque > self.max_torque)   # max_torque 0: no limit
        if np.any(above):   # the deadband would swallow every torque the motor can give
            i = int(np.argmax(above))
            raise ValueError(f"min_torque (the deadband) must not exceed max_torque; wheel {i} has min_torque = "
                             f"{self.min_torque[i]:g} N m > max_torque = {self.max_torque[i]:g} N m")
        if friction is None:
            friction = {}
        if not isinstance(friction, dict):
            raise TypeError(f"friction must be a dict with keys 'coulomb', 'viscous', 'omega_limit_cycle' or None, "
                            f"got {type(friction).__name__}")
        unknown = set(friction) - {"coulomb", "viscous", "omega_limit_cycle"}
        if unknown:
            raise ValueError(f"friction has unknown keys {sorted(unknown)}; known: 'coulomb', 'viscous', "
                             "'omega_limit_cycle'")
        self.coulomb: np.ndarray = _per_wheel(friction.get("coulomb", 0.0), "friction['coulomb']", n, minimum=0.0)
        self.viscous: np.ndarray = _per_wheel(friction.get("viscous", 0.0), "friction['viscous']", n, minimum=0.0)
        self.omega_limit_cycle: np.ndarray = _per_wheel(friction.get("omega_limit_cycle", OMEGA_LIMIT_CYCLE),
                                            "friction['omega_limit_cycle']", n, minimum=0.0, strict=True)

    def __len__(self) -> int:
        return int(self.axes.shape[0])

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("_kept", None)          # a copy or a pickle recomputes what it needs
        return state

    def _derived(self) -> dict[str, Any]:
        """The values derived from the wheels' numbers, kept for the next run with the same numbers.

        They are kept with the arrays they were computed from and those arrays' bytes: an array
        replaced (another object) or changed in place (other bytes) makes them computed afresh, so
        a stale value is never returned. Callers copy what they hand out.
        """
        arrays = tuple(map(self.__dict__.get, _WHEEL_ARRAYS))
        kept = self.__dict__.get("_kept")
        if (kept is not None and all(map(operator.is_, arrays, kept["arrays"]))
                and kept["bytes"] == tuple(a.tobytes() for a in arrays)):
            return kept
        kept = {"arrays": arrays, "bytes": None, "hub": {}}
        if all(type(a) is np.ndarray and a.dtype == np.float64 for a in arrays):
            kept["bytes"] = tuple(a.tobytes() for a in arrays)
            self.__dict__["_kept"] = kept
        return kept

    def _hub(self, body: Any, kept: dict[str, Any] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(J_B, J_B^-1, Jd_B)`` (3, 3) of the wheels in ``body`` (:meth:`hub_inertia`, its inverse and
        ``tr(J_B)/2 I - J_B``), computed once per body inertia and set of wheel numbers; the arrays
        kept, not copies (do not write into them)."""
        kept = kept or self._derived()
        hub = kept["hub"]
        J = np.asarray(body.J, dtype=np.float64)
        key = J.tobytes()
        out = hub.get(key)
        if out is None:
            # other wheels with the same numbers (a caller building its objects for each run) share them
            shared = None if kept["bytes"] is None else (J.shape, self.axes.shape, self.spin_inertia.shape, key,
                                                         *kept["bytes"][:2])
            out = _HUBS.get(shared) if shared is not None else None
            if out is None:
                JB = self._hub_inertia(J)
                rows = JB.tolist()                           # np.trace(JB) / 2.0 * np.eye(3) - JB, in floats
                half = ((rows[0][0] + rows[1][1]) + rows[2][2]) / 2.0
                JdB = np.array([[(half if r == c else half * 0.0) - x for c, x in enumerate(row)]
                                for r, row in enumerate(rows)])
                out = (JB, np.linalg.inv(JB), JdB)
                if shared is not None:
                    if len(_HUBS) >= 16:
                        _HUBS.clear()
                    _HUBS[shared] = out
            if len(hub) >= 4:
                hub.clear()
            hub[key] = out
        return out

    def _for_run(self, body: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
        """``(J_B, J_B^-1, Jd_B, params, has_friction)`` for a run in ``body``, the wheels' numbers
        checked once (:meth:`_derived`); the arrays kept, not copies (do not write into them)."""
        kept = self._derived()
        return (*self._hub(body, kept), self._params(kept), self._friction(kept))

    def _friction(self, kept: dict[str, Any]) -> bool:
        if "has_friction" not in kept:
            kept["has_friction"] = any(np.ravel(self.coulomb).tolist()) or any(np.ravel(self.viscous).tolist())
        return kept["has_friction"]

    def _params(self, kept: dict[str, Any]) -> np.ndarray:
        if "params" not in kept:
            rows = np.empty((len(self), 8))           # np.stack(..., axis=1), C order
            for j, column in enumerate((self.spin_inertia, self.max_torque, self.min_torque, self.max_power,
                                        self.max_speed, self.coulomb, self.viscous, self.omega_limit_cycle)):
                rows[:, j] = column
            kept["params"] = rows
        return kept["params"]

    @property
    def G(self) -> np.ndarray:
        """(3, N) the axes as columns."""
        return self.axes.T.copy()

    @property
    def has_friction(self) -> bool:
        return self._friction(self._derived())

    def params(self) -> np.ndarray:
        """(N, 8) rows for the kernel (:mod:`lgvi._kernels.gyrostat_kernels`), a new array."""
        return self._params(self._derived()).copy()

    def hub_inertia(self, body: Any) -> np.ndarray:
        """``J_B = J - G diag(Js) G^T`` (3, 3): the body's inertia without the wheels' axial part.

        Raises ``ValueError`` when the wheels do not fit the body: the locked inertia along an
        axis not above that wheel's spin inertia, or ``J_B`` not positive definite.
        """
        return self._hub(body)[0].copy()

    def _hub_inertia(self, J: np.ndarray) -> np.ndarray:
        """:meth:`hub_inertia` of the inertia ``J`` (3, 3), computed."""
        for i in range(len(self)):
            along = float(self.axes[i] @ J @ self.axes[i])
            if not along > self.spin_inertia[i]:
                raise ValueError(f"wheels inconsistent with the body: the body's (locked) inertia along wheel {i}'s "
                                 f"axis is {along:.6g} kg m^2, not above the wheel's spin inertia "
                                 f"{self.spin_inertia[i]:.6g}; the body's inertia must include the wheels")
        if len(self) == 0:
            JB = J.copy()
        else:
            JB = J - (self.axes.T * self.spin_inertia) @ self.axes
            JB = 0.5 * (JB + JB.T)
        lam = np.linalg.eigvalsh(JB)
        if not lam[0] > 1e-12 * lam[-1]:
            raise ValueError(f"wheels inconsistent with the body: J - G diag(spin_inertia) G^T is not positive "
                             f"definite (eigenvalues {lam.tolist()}); the body's inertia must include the wheels")
        return JB

    def describe(self) -> dict[str, Any]:
        """JSON-serialisable parameters (kept in ``meta["wheels"]``)."""
        out = {"axes": self.axes.tolist(), "spin_inertia": self.spin_inertia.tolist(),
               "speed0": self.speed0.tolist()}
        for name in ("max_torque", "min_torque", "max_power", "max_speed", "coulomb", "viscous", "omega_limit_cycle"):
            out[name] = getattr(self, name).tolist()
        return out

    def __repr__(self) -> str:
        return f"ReactionWheels(N={len(self)}, spin_inertia={self.spin_inertia.tolist()})"


# ------------------------------------------------------------------------------------------------
# the system declaration
# ------------------------------------------------------------------------------------------------
def _invariants(spec: Any = None) -> dict[str, dict[str, Any]]:
    """The gyrostat's invariants: total momentum and ``|Pi|`` exact without external torque, under any
    wheel torques; the energy bounded with the motors off and no friction (``spec``: the run; an
    explicit run, ``spec.symplectic`` false, declares no energy bound)."""
    if spec is not None and getattr(spec, "external", False):
        return {}
    out = {"spatial_momentum": {"kind": EXACT}, "spatial_momentum_e3": {"kind": EXACT}, "casimir": {"kind": EXACT}}
    if (spec is None or getattr(spec, "motors_off", True)) and getattr(spec, "symplectic", True):
        out["energy"] = {"kind": BOUNDED}
    return out


def _kernels() -> dict[str, Any]:
    from .._kernels import gyrostat_kernels

    return {"run_gyro": gyrostat_kernels.run_gyro}


GYROSTAT = register(System(
    name="gyrostat",
    doc="a rigid body with balanced reaction wheels: R (3, 3), total body momentum Pi (3,), wheel momenta rho (N,)",
    state=(Field("R", (3, 3), doc="attitude, body to inertial"),
           Field("Pi", (3,), doc="total body angular momentum (hub plus wheels)"),
           Field("wheel_momentum", (0,), doc="absolute axial wheel momenta rho (N,)")),
    records=(Field("iterations", (), np.int32, "solver iterations per step"),
             Field("residual", (), np.float64, "final solver residual per step"),
             Field("wheel_torque", (0,), np.float64, "motor torque held from the entry's first step (N,)")),
    kernels=_kernels,
    results=("t", "R", "Pi", "wheel_momentum", "wheel_speed", "wheel_torque", "inertia", "iterations", "residual",
             "h", "meta"),
    scenario_section="wheel",
    run_factory=None,
    invariants=_invariants,
    from_stream=lambda meta, arrays, state: _from_stream(meta, arrays, state),
))


@dataclass(frozen=True, eq=False)
class GyrostatTrajectory(Trajectory):
    """A :class:`lgvi.Trajectory` of a body with reaction wheels.

    Extra attributes
    ----------------
    wheel_momentum : (M, N) ndarray
        Absolute axial wheel momenta ``rho_i = Js_i (a_i . omega + wheel_speed_i)``.
    wheel_torque : (M, N) ndarray
        Motor torque applied from each sample on (after saturation; the last sample repeats the
        last step's), N m.
    wheel_axes : (N, 3) ndarray, spin_inertia : (N,) ndarray
        The wheels.

    ``Pi`` is the total body momentum (hub plus wheels), so ``spatial_momentum = R Pi`` includes
    the wheels; ``inertia`` is the locked inertia ``J``; ``omega = J_B^-1 (Pi - G rho)``;
    ``wheel_speed`` (M, N) relative to the body; ``energy`` the kinetic energy of hub and wheels.
    """

    wheel_momentum: np.ndarray | None = None
    wheel_torque: np.ndarray | None = None
    wheel_axes: np.ndarray | None = None
    spin_inertia: np.ndarray | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        freeze_arrays(self, ("wheel_momentum", "wheel_torque", "wheel_axes", "spin_inertia"))

    @cached_property
    def hub_inertia(self) -> np.ndarray:
        """(3, 3) ``J_B = J - G diag(Js) G^T``."""
        return self.inertia - (self.wheel_axes.T * self.spin_inertia) @ self.wheel_axes

    @cached_property
    def omega(self) -> np.ndarray:
        """(M, 3) body angular velocity ``J_B^-1 (Pi - G rho)``."""
        return np.linalg.solve(self.hub_inertia, (self.Pi - self.wheel_momentum @ self.wheel_axes).T).T

    @cached_property
    def wheel_speed(self) -> np.ndarray:
        """(M, N) wheel speeds relative to the body, rad/s."""
        return self.wheel_momentum / self.spin_inertia - self.omega @ self.wheel_axes.T

    @cached_property
    def kinetic_energy(self) -> np.ndarray:
        """(M,) ``1/2 omega . J_B omega + sum rho^2 / (2 Js)``."""
        w = self.omega
        return (0.5 * np.einsum("ij,jk,ik->i", w, self.hub_inertia, w)
                + 0.5 * np.sum(self.wheel_momentum ** 2 / self.spin_inertia, axis=1))

    def __repr__(self) -> str:
        return "Gyrostat" + super().__repr__() + f" with {self.wheel_axes.shape[0]} wheels"

    def _extra_arrays(self) -> dict[str, np.ndarray]:
        return {"wheel_momentum": self.wheel_momentum, "wheel_torque": self.wheel_torque,
                "wheel_axes": self.wheel_axes, "spin_inertia": self.spin_inertia}


def _from_file(**fields: Any) -> GyrostatTrajectory:
    """A :class:`GyrostatTrajectory` read by :func:`lgvi.load` (shapes checked)."""
    M = len(fields["t"])
    n = fields["spin_inertia"].shape[0] if fields["spin_inertia"].ndim == 1 else -1
    want = {"wheel_momentum": (M, n), "wheel_torque": (M, n), "wheel_axes": (n, 3), "spin_inertia": (n,)}
    for name, shape in want.items():
        if fields[name].shape != shape:
            raise ValueError(f"field {name!r} must have shape {shape} (M = {M} samples, N = {n} wheels), got shape "
                             f"{fields[name].shape}")
    return GyrostatTrajectory(**fields)


RESULT_TYPES["gyrostat"] = (("wheel_momentum", "wheel_torque", "wheel_axes", "spin_inertia"), _from_file)
#: Public name of the file reader (systems built on the gyrostat's result extend it).
gyrostat_from_file = _from_file


# ------------------------------------------------------------------------------------------------
# the run
# ------------------------------------------------------------------------------------------------
_NO_WHEELS = None
_INITIAL_GUESS = None
#: The gyrostat's System with the wheel fields shaped for N wheels, by N (each built once).
_LAYOUTS: dict[int, System] = {}


def _layout(n: int) -> System:
    """:data:`GYROSTAT` with ``wheel_momentum`` and ``wheel_torque`` of shape ``(n,)`` (frozen, shared by runs)."""
    system = _LAYOUTS.get(n)
    if system is None:
        system = dataclasses.replace(
            GYROSTAT,
            state=(GYROSTAT.state[0], GYROSTAT.state[1], Field("wheel_momentum", (n,), doc=GYROSTAT.state[2].doc)),
            records=(GYROSTAT.records[0], GYROSTAT.records[1],
                     Field("wheel_torque", (n,), np.float64, GYROSTAT.records[2].doc)))
        if len(_LAYOUTS) < 64:
            _LAYOUTS[n] = system
    return system


def _cold_start() -> Any:
    """The Python source of the solvers' cold start from the linearisation (as the rigid body), imported
    on the first run (the kernels load lazily)."""
    global _INITIAL_GUESS
    if _INITIAL_GUESS is None:
        from .._kernels.solvers import initial_guess

        _INITIAL_GUESS = getattr(initial_guess, "py_func", initial_guess)
    return _INITIAL_GUESS


def controller_period_steps(controller: Any, control_period: Any, h: float) -> int:
    """Steps per control period (``control_period`` a positive multiple of ``|h|``)."""
    if control_period is None:
        if controller is None:
            return 1
        raise ValueError("give control_period (seconds, a multiple of h) with a controller")
    if controller is None:
        raise ValueError("control_period is given without a controller")
    cp = as_float(control_period, "control_period", positive=True)
    ratio = cp / abs(h)
    m = int(round(ratio))
    if m < 1 or abs(ratio - m) > 1e-9 * max(1.0, ratio):
        raise ValueError(f"control_period must be a positive multiple of |h|; got control_period={cp:g}, "
                         f"h={h:g} (ratio {ratio:.12g})")
    return m


class GyrostatRun:
    """One validated run of the gyrostat, driven by :func:`lgvi.driver.drive`."""
    Pi: np.ndarray
    tol: float
    t0: float
    steps: int
    save_every: int
    rho0: np.ndarray
    max_iter: int
    h: float
    code: int
    body: RigidBody
    alpha: float
    Pi0: np.ndarray

    label = "simulation"

    def __init__(self, body: Any, R0: Any, Pi0: Any, *, omega0: Any, h: Any, steps: Any, wheels: Any,
                 controller: Any = None, control_period: Any = None, environment: Any = None,
                 magnetorquers: Any = None, method: str = "newton", tol: Any = 1e-14, max_iter: Any = 50,
                 alpha: Any = 1.0, save_every: Any = 1, t0: Any = 0.0, solver_record: str = "interval",
                 order: Any = 2, composition: Any = None, torque: Any = None) -> None:
        self.body = body = body if isinstance(body, RigidBody) else RigidBody(body)
        if wheels is None:
            wheels = ReactionWheels(np.zeros((0, 3)), np.zeros(0))
        if not isinstance(wheels, ReactionWheels):
            raise TypeError(f"wheels must be an lgvi.ReactionWheels, got {type(wheels).__name__}")
        self.wheels = wheels
        if method != "newton":
            choice(method, "method", ("newton",))
        self.code, self.tol, self.max_iter, self.alpha = run_solver_options(method, tol, max_iter, alpha)
        if self.alpha != 1.0:
            raise ValueError(f"alpha must be 1.0 with wheels or a controller (exact Newton), got {self.alpha:g}")
        self.R = as_rotation(R0, "R0").copy()
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        choice(solver_record, "solver_record", ("interval", "full"))
        self.full: bool = solver_record == "full"
        check_memory(self.steps, self.save_every, self.full)
        n = len(wheels)
        self.N = n
        JB, JB_inv, JdB, wp, friction = wheels._for_run(body)     # kept by the wheels: this run's own copies
        self.JB = JB = JB.copy()
        self.JB_inv: np.ndarray = JB_inv.copy()
        self.JdB: np.ndarray = body.Jd.copy() if n == 0 else JdB.copy()
        a, Js = wheels.axes, wheels.spin_inertia
        # initial state: Pi = J_B omega + G rho, rho = Js (a . omega + speed0)
        if Pi0 is None and omega0 is None:
            raise ValueError("give the initial body angular momentum Pi0 (3,) or the angular velocity omega0 (3,)")
        if Pi0 is not None and omega0 is not None:
            raise ValueError("give either Pi0 or omega0, not both")
        if omega0 is not None:
            w = as_float_array(omega0, "omega0", (3,))
        else:
            Pi = as_float_array(Pi0, "Pi0", (3,))
            w = np.linalg.solve(body.J, Pi - a.T @ (Js * wheels.speed0))
        self.wheel_momentum: np.ndarray = Js * (a @ w + wheels.speed0)
        self.Pi = JB @ w + a.T @ self.wheel_momentum if omega0 is not None else as_float_array(Pi0, "Pi0", (3,)).copy()
        self.R0, self.Pi0, self.rho0 = self.R.copy(), self.Pi.copy(), self.wheel_momentum.copy()
        # controller, environment, magnetorquers
        if controller is not None and not isinstance(controller, Controller):
            raise TypeError(f"controller must be an lgvi.control.Controller, got {type(controller).__name__}")
        self.spc: int = controller_period_steps(controller, control_period, self.h)
        self.controller = controller
        if environment is not None and not callable(getattr(environment, "sample", None)):
            raise TypeError(f"environment must have a method sample(t) -> dict, got {type(environment).__name__}")
        if magnetorquers is not None and not callable(getattr(magnetorquers, "torque", None)):
            raise TypeError("magnetorquers must have a method torque(dipole, B_body) -> (3,), got "
                            f"{type(magnetorquers).__name__}")
        if environment is not None and controller is None:
            raise ValueError("environment is sampled for a controller (at its control rate): give a controller")
        if magnetorquers is not None and controller is None:
            raise ValueError("magnetorquers are driven by a controller's dipole: give a controller")
        self.environment = environment
        self.magnetorquers = magnetorquers
        self.model: Any = _torque_model(torque)
        if self.model is not None:
            self.model.check_sample(self.t0, self.R, self.Pi)      # its Python form, before the run
        self.Rs: np.ndarray = np.zeros((3, 3))
        self.cp: np.ndarray = np.zeros(0)
        self.cs: np.ndarray = np.zeros(5)
        self.ctrl: int = 0
        if controller is not None:
            controller.setup(body, wheels if n else None)
            controller.reset()
            if getattr(controller, "compiled", False) and environment is None and magnetorquers is None:
                self.ctrl = 1
                self.cp = mrp_params(controller, wheels)
        self.python_controller: bool = controller is not None and self.ctrl == 0
        self.cmd: np.ndarray = np.zeros(n)
        self.tau: np.ndarray = np.zeros(3)
        self.u_now: np.ndarray = np.zeros(2 * n)
        self.comp: Composition = composition_for(order, composition)
        self.gam: np.ndarray = np.array(self.comp.coefficients)     # comp.arrays()[0], without the cumulative sums
        self.G = np.zeros((len(self.gam), 11, 3))    # rows 5-10: the solver's guess (gyrostat_kernels.gyro_steps)
        guess, q, first = _cold_start(), self.Pi - a.T @ self.wheel_momentum, {}
        # the kernel's Python source on plain floats (J_B as a memoryview, lists): the same IEEE operations
        JB_view, q, h = memoryview(JB), q.tolist(), self.h
        for i, g in enumerate(self.comp.coefficients):           # once per distinct substep
            if g in first:
                self.G[i, 0] = self.G[first[g], 0]
            else:
                gh, out = g * h, [0.0, 0.0, 0.0]
                guess(self.code, JB_view, [gh * x for x in q], out)      # g * h * q
                self.G[i, 0] = out
                first[g] = i
        # a body torque acted (the declaration of invariants is that of the run so far)
        self.external: bool = (self.ctrl == 1 and n == 0) or self.model is not None
        self.motors_off: bool = controller is None and not friction
        self.k: int = 0
        self.counts: np.ndarray = np.zeros(HIST_BINS, dtype=np.int64)
        self.it_total: int = 0
        self.res_max: float = 0.0
        self.last_its: int = 0
        self.last_res: float = 0.0
        se = self.save_every
        base = CHUNK_STEPS if not self.python_controller else max(CHUNK_STEPS, self.spc)
        self.chunk: int = max(1, base // se) * se
        self.wp: np.ndarray = wp.copy()
        self.system: System = _layout(n)
        ctrl_repr = repr(controller) if controller is not None else None
        self.meta: dict[str, Any] = {"system": "gyrostat", "method": "newton", "tol": self.tol,
                                     "max_iter": self.max_iter, "alpha": 1.0, "save_every": se,
                                     "torque": ("none" if controller is None else "controller") if self.model is None
                                     else repr(self.model),
                                     "forcing": "symmetric", "lgvi_version": __version__, "t0": self.t0, "order": self.comp.order,
                                     "solver_record": solver_record, "wheels": wheels.describe(),
                                     "controller": ctrl_repr,
                                     "control_period": None if controller is None else self.spc * abs(self.h),
                                     "invariants": _invariants(self)}
        if self.comp.order != 2:
            self.meta["composition"] = self.comp.name
        self.meta["torque_model"] = (f"the gyrostat ({n} reaction wheels"
                                     + (f", {ctrl_repr} every {self.spc * abs(self.h):g} s)" if controller is not None
                                        else ")"))

    # -------------------------------------------------------------- results
    def times(self, j0: int, j1: int) -> np.ndarray:
        return sample_times(self.t0, self.h * self.save_every, j0, j1)

    def summary(self) -> dict[str, Any]:
        return summary_dict(self.counts, self.it_total, self.res_max)

    def trajectory(self, t, R_out, Pi_out, rho_out, it_out, res_out, u_out, partial: bool = False) -> GyrostatTrajectory:
        meta = dict(self.meta, partial=True) if partial else dict(self.meta)
        meta["solver_summary"] = self.summary()
        meta["invariants"] = _invariants(self)
        wt = _wheel_torque_samples(len(t), u_out, self.full, self.save_every, self.u_now[:self.N])
        return GyrostatTrajectory(t=t, R=R_out, Pi=Pi_out, inertia=self.body.J.copy(), iterations=it_out,
                                  residual=res_out, h=self.h, potential=None, meta=meta, wheel_momentum=rho_out,
                                  wheel_torque=wt, wheel_axes=self.wheels.axes.copy(),
                                  spin_inertia=self.wheels.spin_inertia.copy())

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = "") -> ConvergenceError:
        from ..implicit import failure_message

        k = self.k
        t_fail = self.t0 + k * self.h
        if status == USER_RAISED and self.model is not None:     # the Compiled model's function raised
            return self.model.raised_error(k, t_fail, self.h, self.R, self.Pi, None, trajectory, where)
        hnorm = abs(self.h) * float(np.linalg.norm(self.Pi))
        msg = (f"step {k} (t = {t_fail:g}) failed: "
               + failure_message(status, residual, iterations, hnorm, self.tol, self.code, 1.0)
               + f" The run up to step {k} is in .trajectory." + where)
        return ConvergenceError(msg, residual=residual, iterations=iterations, step=k, time=t_fail,
                                trajectory=trajectory)

    def state(self) -> dict[str, Any]:
        """Everything the next step needs: the state, the solver history ``G``, the held command
        (``cmd``, ``tau``: the zero-order hold, whose phase is ``k % spc``), the compiled MRP
        feedback's integral and last time (``cs``), the solver's totals, whether a body torque
        acted (``external``) and a Python controller's own state (``controller``: ``None`` when
        it cannot be saved, see :func:`controller_state`)."""
        st: dict[str, Any] = {"k": self.k, "R": self.R.copy(), "Pi": self.Pi.copy(),
                              "wheel_momentum": self.wheel_momentum.copy(), "G": self.G.copy(), "cmd": self.cmd.copy(),
                              "tau": self.tau.copy(), "cs": self.cs.copy(), "counts": self.counts.copy(),
                              "it_total": self.it_total, "res_max": self.res_max, "external": bool(self.external)}
        if self.python_controller:
            st["controller"] = controller_state(self.controller)
        return st

    def load_state(self, st: dict[str, Any]) -> None:
        """Continue from ``st`` (:meth:`state`); a Python controller whose state was not saved is refused."""
        if self.python_controller:
            saved = st.get("controller")
            if saved is None:
                raise ValueError(f"resume: the run's Python controller {self.controller!r} keeps state that lgvi "
                                 "cannot save (give its class state() -> dict and load_state(dict) methods), so it "
                                 "cannot be continued bit for bit; run it again from the start")
            load_controller_state(self.controller, saved)
        self.k = int(st["k"])
        G = np.asarray(st["G"], dtype=np.float64)
        if G.ndim == 3 and G.shape[1] == 5 and G.shape[0] == self.G.shape[0]:
            # a state saved before the solver's guess kept the forcing and the right sides (G rows 5-10):
            # none valid, the guess starts again from the extrapolation alone (the solution within the
            # tolerance)
            G = np.concatenate([G, np.zeros((G.shape[0], 6, 3))], axis=1)
            G[:, 3, 1:] = 0.0
        self.G[...] = G
        for name in ("R", "Pi", "wheel_momentum", "cmd", "tau", "cs"):
            getattr(self, name)[...] = np.asarray(st[name], dtype=np.float64)
        if "counts" in st:
            self.counts[...] = np.asarray(st["counts"], dtype=np.int64)
            self.it_total = int(st["it_total"])
            self.res_max = float(st["res_max"])
            self.external = bool(st["external"])

    def stream_meta(self) -> dict[str, Any]:
        """JSON-serialisable metadata of a stream of this run: what :func:`_from_stream` needs and
        what identifies the run (compared on resume; a controller without its own ``__repr__`` by its
        class, not by its address)."""
        meta = dict(self.meta)
        c = self.controller
        if c is not None and type(c).__repr__ is object.__repr__:
            name = f"{type(c).__module__}.{type(c).__qualname__}"
            meta["controller"] = name
            meta["torque_model"] = meta["torque_model"].replace(repr(c), name)
        return dict(meta, h=self.h, steps=self.steps, inertia=self.body.J.tolist(),
                    motors_off=bool(self.motors_off), initial={"R": self.R0.tolist(), "Pi": self.Pi0.tolist(),
                                                               "wheel_momentum": self.rho0.tolist()})

    # -------------------------------------------------------------- stepping
    def _kernel(self, k0: int, n: int, kb: int, R_out, Pi_out, rho_out, it_out, res_out, u_out) -> int:
        from .._kernels.gyrostat_kernels import run_gyro, run_gyro_model
        from .._kernels.user_kernels import guarded

        per = 1 if self.full else self.save_every
        kernel, moment, up = run_gyro, None, self.cp
        if self.model is not None:      # one cached loop for every user's model: the function as a value
            kernel, moment, up = run_gyro_model, guarded(self.model.moment_func), self.model.row()
        status, k, it_sum, rmax, its, rn = kernel(
            moment, up, self.Rs, self.JdB, self.JB_inv, self.h, self.gam, self.t0, self.R, self.Pi, self.wheel_momentum, self.G, self.wheels.axes,
            self.wp, self.cmd, self.tau, self.u_now, self.ctrl, self.cp, self.cs, self.spc, k0, n, kb, self.tol,
            self.max_iter, self.save_every, per, R_out, Pi_out, rho_out, u_out, it_out, res_out, self.counts)
        self.k = int(k)
        self.it_total += int(it_sum) - (int(its) if status != 0 else 0)
        self.res_max = max(self.res_max, float(rmax))
        self.last_its, self.last_res = int(its), float(rn)
        return int(status)

    def advance(self, n: int, R_out, Pi_out, rho_out, it_out, res_out, u_out, partial) -> int:
        kb = self.k
        end = kb + n
        if not self.python_controller:
            return self._kernel(kb, n, kb, R_out, Pi_out, rho_out, it_out, res_out, u_out)
        while self.k < end:
            k = self.k
            if k % self.spc == 0:
                self._call_controller(k, partial)
            m = min(end, (k // self.spc + 1) * self.spc) - k
            status = self._kernel(k, m, kb, R_out, Pi_out, rho_out, it_out, res_out, u_out)
            if status != 0:
                return status
        return 0

    def _call_controller(self, k: int, partial) -> None:
        t = self.t0 + k * self.h
        R = self.R.copy()
        rho = self.wheel_momentum
        a, Js = self.wheels.axes, self.wheels.spin_inertia
        w = self.JB_inv @ (self.Pi - a.T @ rho)
        speed = rho / Js - a @ w
        try:
            env: dict[str, Any] = {}
            if self.environment is not None:
                env = dict(self.environment.sample(t))
                if "B_inertial" in env and "B_body" not in env:
                    env["B_body"] = R.T @ np.asarray(env["B_inertial"], dtype=np.float64)
            cmd = self.controller.command(t, R, w, speed, env)
            tau, wheel, dipole = _check_command(cmd, self.N, k, t)
            if dipole is not None:
                if self.magnetorquers is None:
                    raise TorqueError("the controller returned a dipole but simulate(..., magnetorquers=) was not given")
                if "B_body" not in env:
                    raise TorqueError("the controller returned a dipole but the environment gives no magnetic field "
                                      "('B_body' or 'B_inertial')")
                m_tau = np.asarray(self.magnetorquers.torque(dipole, np.asarray(env["B_body"], dtype=np.float64)),
                                   dtype=np.float64)
                if m_tau.shape != (3,) or not np.all(np.isfinite(m_tau)):
                    raise TorqueError(f"magnetorquers.torque returned {m_tau!r}, not 3 finite numbers")
                tau = m_tau if tau is None else tau + m_tau
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            err = exc if isinstance(exc, TorqueError) else None
            msg = str(err) if err is not None else f"the controller raised {type(exc).__name__}: {exc}"
            raise TorqueError(f"at step {k} (t = {t:g}): {msg}. The run up to step {k} is in .trajectory.",
                              step=k, time=t, trajectory=partial(k)) from exc
        self.tau[:] = 0.0 if tau is None else tau
        if np.any(self.tau):
            self.external = True
        self.cmd[:] = 0.0 if wheel is None else wheel


def controller_state(controller: Any) -> dict[str, Any] | None:
    """The internal state of a Python controller between calls, JSON-serialisable, or ``None`` when
    lgvi cannot save it: the controller's own ``state()`` if its class has ``state`` and
    ``load_state``; :class:`lgvi.control.MRPFeedback` (its integral and last call's time) and
    :class:`lgvi.control.RotationPD` (none) are known; another class is not."""
    from ..control import MRPFeedback, RotationPD

    if callable(getattr(controller, "state", None)) and callable(getattr(controller, "load_state", None)):
        return dict(controller.state())
    if type(controller) is MRPFeedback:
        return {"int_sigma": np.asarray(controller.int_sigma, dtype=np.float64).tolist(),
                "prior_time": controller.prior_time}
    if type(controller) is RotationPD:
        return {}
    return None


def load_controller_state(controller: Any, saved: dict[str, Any]) -> None:
    """Restore what :func:`controller_state` saved."""
    from ..control import MRPFeedback

    if callable(getattr(controller, "state", None)) and callable(getattr(controller, "load_state", None)):
        controller.load_state(saved)
    elif type(controller) is MRPFeedback:
        controller.int_sigma = np.asarray(saved["int_sigma"], dtype=np.float64).copy()
        prior = saved["prior_time"]
        controller.prior_time = None if prior is None else float(prior)


def _wheel_torque_samples(M: int, u_out: np.ndarray, full: bool, se: int, last: np.ndarray) -> np.ndarray:
    """(M, N) motor torques per sample from the records ``u_out`` (per step with ``full`` and
    ``se > 1``, else per saved interval); the last sample repeats the last entry (``last``: none)."""
    rec = u_out if not full or se == 1 else u_out[::se]
    wt = np.empty((M, len(last)))
    m = min(len(rec), M - 1)
    wt[:m] = rec[:m]
    if M > m:
        wt[m:] = rec[m - 1] if m > 0 else last
    return wt


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> GyrostatTrajectory:
    """The :class:`GyrostatTrajectory` of a stream folder (``System.from_stream``)."""
    from types import SimpleNamespace

    wheels = meta["wheels"]
    axes = np.asarray(wheels["axes"], dtype=np.float64).reshape(-1, 3)
    n = len(axes)
    Js = np.asarray(wheels["spin_inertia"], dtype=np.float64).reshape(n)
    M = len(arrays["t"])
    for name, shape in (("R", (M, 3, 3)), ("Pi", (M, 3)), ("wheel_momentum", (M, n))):
        if arrays[name].shape != shape:
            raise ValueError(f"field {name!r} must have shape {shape} (M = {M} samples, N = {n} wheels), got "
                             f"{arrays[name].shape}")
    u = arrays["wheel_torque"]
    if u.ndim != 2 or u.shape[1] != n:
        raise ValueError(f"field 'wheel_torque' must have shape (entries, {n}) (N = {n} wheels), got {u.shape}")
    full, se = meta.get("solver_record") == "full", int(meta["save_every"])
    out = dict(meta)
    out["solver_summary"] = summary_dict(np.asarray(state["counts"], dtype=np.int64), int(state["it_total"]),
                                         float(state["res_max"]))
    out["invariants"] = _invariants(SimpleNamespace(external=bool(state["external"]),
                                                    motors_off=bool(meta["motors_off"]),
                                                    symplectic=meta.get("scheme") != "rkmk4"))
    return GyrostatTrajectory(t=arrays["t"], R=arrays["R"], Pi=arrays["Pi"],
                              inertia=np.asarray(meta["inertia"], dtype=np.float64), iterations=arrays["iterations"],
                              residual=arrays["residual"], h=float(meta["h"]), potential=None, meta=out,
                              wheel_momentum=arrays["wheel_momentum"],
                              wheel_torque=_wheel_torque_samples(M, u, full, se, np.zeros(n)), wheel_axes=axes,
                              spin_inertia=Js)


#: Public name of the stream reader (systems built on the gyrostat's result extend it).
gyrostat_from_stream = _from_stream


def _check_command(cmd: Any, n: int, k: int, t: float) -> tuple[Any, Any, Any]:
    if not isinstance(cmd, Command):
        raise TorqueError(f"controller.command must return an lgvi.control.Command, got {type(cmd).__name__}")
    out = []
    for name, shape in (("torque", (3,)), ("wheel_torque", (n,)), ("dipole", (3,))):
        v = getattr(cmd, name)
        if v is None:
            out.append(None)
            continue
        arr = np.asarray(v, dtype=np.float64)
        if arr.shape != shape:
            raise TorqueError(f"Command.{name} must have shape {shape}, got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise TorqueError(f"the controller returned a non-finite Command.{name} {arr.tolist()}")
        if name == "wheel_torque" and n == 0:
            raise TorqueError("the controller returned wheel torques but the run has no wheels")
        out.append(arr.copy())
    return out[0], out[1], out[2]


def mrp_params(ctrl: Any, wheels: ReactionWheels) -> np.ndarray:
    """The ``cp`` vector of the compiled MRP feedback (:data:`lgvi._kernels.gyrostat_kernels.CP_MAP`)."""
    n = len(wheels)
    cp = np.zeros(28 + 3 * n)              # filled in place: the same numbers, fewer small-array calls
    cp[0], cp[1], cp[2] = ctrl.K, ctrl.P, 0.0 if ctrl.Ki is None else ctrl.Ki
    cp[3] = ctrl.integral_limit if math.isfinite(ctrl.integral_limit) else 1e300
    if ctrl.R_ref is None:
        cp[4:13:4] = 1.0                    # the identity
    else:
        cp[4:13] = ctrl.R_ref.ravel()
    cp[19:28] = np.asarray(ctrl.J, dtype=np.float64).ravel()
    wm = getattr(ctrl, "wheel_map", None)      # set by MRPFeedback.setup from these axes: the same numbers
    axes = ctrl.axes
    if (n and isinstance(wm, np.ndarray) and wm.shape == (n, 3) and isinstance(axes, np.ndarray)
            and axes.shape == wheels.axes.shape and axes.tolist() == wheels.axes.tolist()):   # np.array_equal
        cp[28:] = wm.ravel()
    elif n:
        from ..control import map_to_wheels

        M = np.zeros((n, 3))
        for j in range(3):
            M[:, j] = map_to_wheels(np.eye(3)[j], wheels.axes)
        cp[28:] = M.ravel()
    return cp


def _torque_model(torque: Any) -> Any:
    """``torque=`` beside wheels or a controller: one :class:`lgvi.torques.Compiled` model (or ``None``)."""
    if torque is None:
        return None
    if getattr(torque, "moment_func", None) is None:
        raise ValueError("torque= with wheels= or controller= takes one lgvi.torques.Compiled model (e.g. "
                         "lgvi.environment.OrbitGravityGradient), run inside the gyrostat's compiled loop; got "
                         f"{type(torque).__name__}. Give other body torques through the controller (Command.torque)")
    if torque.depends_on_momentum:
        raise ValueError(f"torque= with wheels= or controller= must not depend on Pi (momentum_dependent=True): "
                         f"got {torque!r}")
    torque.row()                      # params (P,) for one body
    return torque


def gyrostat_options(*, torque: Any, forcing: Any, order: Any, composition: Any, error_estimate: Any) -> None:
    """Refuse the options of :func:`lgvi.simulate` that a run with wheels or a controller does not take."""
    _torque_model(torque)
    if forcing not in ("paper", "symmetric"):
        choice(forcing, "forcing", ("paper", "symmetric"))
    check_options(error_estimate, 0.01, None)      # True or "richardson": the shadow run of simulate_gyrostat


def simulate_gyrostat(body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: Any, steps: Any,
                      wheels: Any = None, controller: Any = None, control_period: Any = None, environment: Any = None,
                      magnetorquers: Any = None, progress: Any = False, error_estimate: Any = False,
                      error_warn: Any = 0.01, scheme: Any = None, **options: Any) -> GyrostatTrajectory:
    """:func:`lgvi.simulate` with wheels or a controller (see there); returns a :class:`GyrostatTrajectory`.

    With ``error_estimate``, the same run again at ``h/2`` (:func:`lgvi.accuracy.with_estimate`):
    the controller, environment, magnetorquers and torque of that shadow run are copies of the
    ones given, taken before the run changes them, and ``control_period`` must be a multiple of
    ``h/2`` (it is whenever it is one of ``h``); the order is the composition's, 1 with wheel
    friction (first order in the friction torque).
    """
    import copy

    estimate, warn = check_options(error_estimate, error_warn, None)
    if estimate:
        if control_period is not None:
            cp, half = as_float(control_period, "control_period", positive=True), abs(as_float(h, "h")) / 2.0
            ratio = cp / half if half > 0 else float("inf")
            if not np.isfinite(ratio) or abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio) or round(ratio) < 1:
                raise ValueError(f"error_estimate: control_period must be a multiple of h/2 (the shadow run steps at "
                                 f"h/2); got control_period={cp:g}, h={float(h):g}")
        shadow_inputs = copy.deepcopy((wheels, controller, environment, magnetorquers, options.get("torque")))
    run_class = scheme_run_class(scheme)
    run = run_class(body, R0, Pi0, omega0=omega0, h=h, steps=steps, wheels=wheels, controller=controller,
                    control_period=control_period, environment=environment, magnetorquers=magnetorquers, **options)
    traj = drive(run, MemorySink(run), progress)
    if not estimate:
        return traj
    wl, ctrl, env, mtq, torque = shadow_inputs
    kw = {k: v for k, v in options.items() if k not in ("save_every", "t0", "solver_record", "torque")}
    kw.update(body=run.body, R0=R0, Pi0=Pi0, omega0=omega0, h=run.h, steps=run.steps, wheels=wl, controller=ctrl,
              control_period=control_period, environment=env, magnetorquers=mtq, torque=torque,
              save_every=run.save_every, t0=run.t0, progress=progress, scheme="lgvi", forcing="symmetric")
    if run_class is not GyrostatRun:
        kw.update(scheme=scheme, order=4, composition=run.tableau)
    order = 4 if run_class is not GyrostatRun else run.comp.order
    return with_estimate(traj, kw, warn=warn, stacklevel=3, order=1 if run.wheels.has_friction else order)


def scheme_run_class(scheme: Any) -> Any:
    """The run class of ``scheme``: ``None``/``"lgvi"`` :class:`GyrostatRun`, ``"rkmk4"`` the explicit
    RKMK scheme (:mod:`lgvi.systems.gyrostat_rkmk`)."""
    if scheme is None or scheme == "lgvi":
        return GyrostatRun
    if scheme == "rkmk4":
        from .gyrostat_rkmk import GyrostatRKMKRun

        return GyrostatRKMKRun
    raise ValueError(f"scheme must be None or 'lgvi' (the LGVI) or 'rkmk4' (the explicit RKMK scheme) for the "
                     f"gyrostat, got {scheme!r}")


def gyrostat_run(body: Any, R0: Any, Pi0: Any = None, *, omega0: Any = None, h: Any, steps: Any, wheels: Any = None,
                 controller: Any = None, control_period: Any = None, environment: Any = None, magnetorquers: Any = None,
                 torque: Any = None, method: str = "newton", tol: Any = 1e-14, max_iter: Any = 50, alpha: Any = 1.0,
                 save_every: Any = 1, t0: Any = 0.0, forcing: Any = "paper", order: Any = 2, composition: Any = None,
                 solver_record: str = "interval", scheme: Any = None, error_estimate: Any = False,
                 error_warn: Any = 0.01) -> GyrostatRun:
    """The run factory of the gyrostat (``SYSTEMS["gyrostat"].run``, :func:`lgvi.simulate_members`):
    the validated :class:`GyrostatRun` of ``lgvi.simulate(body, R0, Pi0, ..., wheels=..., controller=...)``
    with the same arguments (``progress`` aside), so that driving it gives that result bit for bit.

    The run uses its own copies (``copy.deepcopy``) of ``controller``, ``environment`` and
    ``magnetorquers``: a controller is stateful (its integral, a Python controller's memory), so one
    object given to several members would otherwise be shared and changed by all of them; the
    objects given are left as they are (not set up, not run). An object that cannot be copied is
    refused (``TypeError``). ``error_estimate`` (a second run at ``h/2``) is not available here:
    call :func:`lgvi.simulate` for it.
    """
    import copy

    if error_estimate is not False and error_estimate is not None:
        raise ValueError(f"error_estimate must be False in a run of the gyrostat built by its run factory "
                         f"(lgvi.simulate_members), got {error_estimate!r}: the estimate is a second run at h/2 "
                         "that lgvi.simulate(..., error_estimate=True) makes")
    run_class = scheme_run_class(scheme)
    if run_class is GyrostatRun:
        gyrostat_options(torque=torque, forcing=forcing, order=order, composition=composition, error_estimate=False)
    owned = {}
    for name, obj in (("controller", controller), ("environment", environment), ("magnetorquers", magnetorquers)):
        try:
            owned[name] = copy.deepcopy(obj)
        except Exception as exc:
            raise TypeError(f"{name}: each run of the gyrostat's run factory (lgvi.simulate_members) uses its own "
                            f"copy of its {name} (copy.deepcopy), and this {type(obj).__name__} cannot be copied "
                            f"({type(exc).__name__}: {exc}); give each member its own object") from exc
    return run_class(body, R0, Pi0, omega0=omega0, h=h, steps=steps, wheels=wheels, control_period=control_period,
                     method=method, tol=tol, max_iter=max_iter, alpha=alpha, save_every=save_every, t0=t0,
                     solver_record=solver_record, order=order, composition=composition, torque=torque, **owned)


def _provide() -> None:
    from . import provide_run

    provide_run(GYROSTAT, gyrostat_run)


_provide()

__all__ = ["GYROSTAT", "GyrostatRun", "GyrostatTrajectory", "ReactionWheels", "controller_state", "gyrostat_from_file",
           "gyrostat_from_stream", "gyrostat_options",
           "gyrostat_run", "load_controller_state", "controller_period_steps", "mrp_params", "scheme_run_class",
           "simulate_gyrostat"]
