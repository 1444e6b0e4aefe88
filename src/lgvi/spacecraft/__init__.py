"""What is bolted on the spacecraft: actuators, sensors and disturbance models, as components of
the compiled loop (:mod:`lgvi.components`), and :class:`Spacecraft`, the description that holds them
with the body, the wheels and the orbit it flies (``docs/loop.md``)."""

from __future__ import annotations

import datetime as _dt
import math
from typing import Any, Sequence

import numpy as np

from .._validation import as_float
from ..body import RigidBody
from ..components import COMPONENT_KINDS, Component, ComponentKind, LoopContext, kind_of, register_kind

__all__ = ["Spacecraft", "OrbitTable", "FieldModel", "GravityGradient", "MagnetorquerRods", "ORBIT_TABLE_DT", "components_of"]

#: Default spacing (s) of the tabulated orbit (cubic Hermite; relative position error about
#: ``(n dt)^4 / 384``, 4e-11 in LEO).
ORBIT_TABLE_DT = 10.0


def _orbit_table(orbit: Any, t0: float, t1: float, dt: float, mu: float, J: Any) -> np.ndarray:
    """The row ``[mu, J (9), t0, dt, K, r_0, v_0, ...]`` of :mod:`lgvi._kernels.orbit_table_kernels`
    for ``[t0, t1]`` (seconds since the run's epoch, which is the orbit's time)."""
    span = max(t1 - t0, 0.0)
    K = max(2, int(math.ceil(span / dt)) + 1)
    if K > 10_000_000:
        raise ValueError(f"the run's span / dt = {span / dt:.3g} orbit table nodes is too many (> 1e7): raise "
                         "orbit_dt")
    r, v = orbit.position_velocity(t0 + np.arange(K) * dt)
    table = np.concatenate([np.asarray(r, dtype=np.float64), np.asarray(v, dtype=np.float64)], axis=1).reshape(-1)
    row = np.concatenate([[mu], np.asarray(J, dtype=np.float64).reshape(-1), [t0, dt, float(K)], table])
    if not np.all(np.isfinite(row)):
        raise ValueError(f"the orbit {orbit!r} gave non-finite positions or velocities on [{t0:g}, {t1:g}] s")
    return row


class OrbitTable(Component):
    """Environment: ``r_N``, ``v_N`` from the spacecraft's orbit, tabulated for the run (added by
    :class:`Spacecraft` when it has an ``orbit``; cubic Hermite between nodes ``dt`` apart)."""

    kind = "orbit"

    def __init__(self, *, dt: float = ORBIT_TABLE_DT, rate: Any = None) -> None:
        super().__init__(rate=rate)
        self.dt: float = as_float(dt, "orbit_dt", positive=True)
        self._row = np.zeros(0)

    def setup(self, ctx: LoopContext) -> None:
        sc = ctx.spacecraft
        lo, hi = min(ctx.t0, ctx.t1), max(ctx.t0, ctx.t1)
        self._row = _orbit_table(sc.orbit, lo, hi, self.dt, float(getattr(sc.orbit, "mu", 0.0) or 0.0), np.zeros(9))

    def params(self) -> np.ndarray:
        return self._row


class FieldModel(Component):
    """Environment: ``B_N`` (tesla) at ``r_N`` from the spacecraft's field model (IGRF, WMM, centred
    dipole), compiled: the spherical-harmonic kernel of :mod:`lgvi._kernels.field_kernels` in the
    Earth-fixed frame turned by GMST from the spacecraft's ``epoch``, the Gauss coefficients linear
    in time over the run (as the model's own interpolation within one of its epochs' intervals)."""

    kind = "field"

    def __init__(self, *, rate: Any = None) -> None:
        super().__init__(rate=rate)
        self._row = np.zeros(0)
        self._n1 = 0

    def setup(self, ctx: LoopContext) -> None:
        from ..environment.field import decimal_year
        from .._kernels.field_kernels import recursion_constants_size, sh_recursion_constants

        sc = ctx.spacecraft
        model, epoch = sc.field, sc.epoch
        t0, t1 = min(ctx.t0, ctx.t1), max(ctx.t0, ctx.t1)
        y0 = decimal_year(epoch + _dt.timedelta(seconds=t0))
        y1 = decimal_year(epoch + _dt.timedelta(seconds=t1))
        lo, hi = model.valid
        if not (lo <= y0 <= hi and lo <= y1 <= hi):
            raise ValueError(f"the run ({epoch} + [{t0:g}, {t1:g}] s) must lie in {model.name}'s validity "
                             f"{lo:g}..{hi:g} (decimal years {y0:.6f}..{y1:.6f})")
        ye = decimal_year(epoch)
        g0, h0 = model.coefficients(ye)
        # the rate per second of the coefficients over the run (they are linear in the year)
        span = t1 - t0
        if span > 0.0:
            ga, ha = model.coefficients(y0)
            gb, hb = model.coefficients(y1)
            gd, hd = (gb - ga) / span, (hb - ha) / span
        else:
            gd, hd = np.zeros_like(g0), np.zeros_like(h0)
        jd0 = (epoch - _dt.datetime(2000, 1, 1, 12)).total_seconds() / 86400.0
        n1 = g0.shape[0]
        self._n1 = n1
        constants = np.zeros(recursion_constants_size(n1))     # the recursions' factors: once, not per evaluation
        sh_recursion_constants(n1, constants)
        self._row = np.concatenate([[float(model.degree), float(model.radius), jd0, float(n1)], g0.ravel(),
                                    h0.ravel(), gd.ravel(), hd.ravel(), constants])

    def params(self) -> np.ndarray:
        return self._row

    def state0(self) -> np.ndarray:
        return np.zeros(5 * self._n1 * self._n1)


class GravityGradient(Component):
    """Disturbance: the gravity-gradient moment along the spacecraft's orbit, in the loop's
    variational step (the moment of a time-dependent potential, as
    :class:`lgvi.environment.OrbitGravityGradient`; each member with its own inertia)."""

    kind = "orbit_gravity_gradient"

    def __init__(self, *, dt: float = ORBIT_TABLE_DT, mu: float | None = None) -> None:
        super().__init__(rate=None)
        self.dt: float = as_float(dt, "dt", positive=True)
        self.mu: float | None = None if mu is None else as_float(mu, "mu", positive=True)
        self._row = np.zeros(0)

    def setup(self, ctx: LoopContext) -> None:
        sc = ctx.spacecraft
        if sc.orbit is None:
            raise ValueError("GravityGradient needs the spacecraft's orbit: Spacecraft(..., orbit=...)")
        mu = self.mu if self.mu is not None else as_float(getattr(sc.orbit, "mu", None), "orbit.mu", positive=True)
        lo, hi = min(ctx.t0, ctx.t1), max(ctx.t0, ctx.t1)
        # one node beyond the end: the moment is evaluated at the last step's end
        self._row = _orbit_table(sc.orbit, lo, hi + self.dt, self.dt, mu, sc.body.J)

    def params(self) -> np.ndarray:
        return self._row

    def __repr__(self) -> str:
        return f"GravityGradient(dt={self.dt:g})"


class MagnetorquerRods(Component):
    """Actuator: magnetorquer rods (an :class:`lgvi.Magnetorquers`): the dipole request to the rods
    by least squares, each clipped to its limit, ``dipole_B`` and the torque ``tau_control_B =
    dipole_B x R^T B_N`` held until the next call (added by :class:`Spacecraft` for its
    ``magnetorquers``)."""

    kind = "magnetorquers"

    def __init__(self, rods: Any, *, rate: Any = None, modes: Any = None) -> None:
        super().__init__(rate=rate, modes=modes)
        self.rods = rods

    def params(self) -> np.ndarray:
        r = self.rods
        return np.concatenate([[float(r.count)], r.axes.ravel(), r.max_dipole.ravel(), r._pinv.ravel()])


class Spacecraft:
    """The spacecraft: its body, what is bolted on it and where it flies (``docs/loop.md``).

    Parameters
    ----------
    body : lgvi.RigidBody or array_like
        The whole spacecraft with the wheels locked (its inertia, kg m^2).
    wheels : lgvi.ReactionWheels, optional
        Balanced reaction wheels (``docs/gyrostat.md``).
    magnetorquers : lgvi.Magnetorquers, optional
        Magnetorquer rods; they act on the dipole request of the flight software
        (``dipole_request_B``) at ``magnetorquer_rate`` (default: every step).
    orbit : an orbit of :mod:`lgvi.environment`, optional
        The orbit (time 0 is the run's epoch): tabulated for the run and put on the bus as ``r_N``,
        ``v_N`` (every step, or at ``environment_rate``).
    field : lgvi.environment field model, optional
        ``B_N`` along the orbit, compiled (needs ``orbit`` and ``epoch``).
    epoch : datetime.datetime, optional
        UTC of ``t = 0`` (the Earth's rotation angle and the field's date); default the orbit's.
    disturbances : sequence of components, optional
        Disturbance models, e.g. :class:`GravityGradient` (the gravity gradient along the orbit).
    sensors : sequence of components, optional
        Sensor models (components of the ``"sensor"`` family).
    environment : sequence of components, optional
        Further environment models (:class:`lgvi.environment.Sun`, ``Shadow``,
        ``ExponentialAtmosphere``, ``TabulatedAtmosphere``: components of the ``"environment"``
        family), run after the orbit and the field, in the order of their codes (the sun before the
        shadow); they read the spacecraft's ``epoch`` (one clock).
    orbit_dt : float
        Spacing of the orbit table, s (default 10).
    environment_rate, magnetorquer_rate : float, optional
        Periods (s) of the orbit and field, and of the magnetorquers; ``None``: every step.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> from lgvi.environment import CircularOrbit
    >>> wheels = lgvi.ReactionWheels(np.eye(3), 1e-4)
    >>> sc = lgvi.Spacecraft([0.18, 0.14, 0.06], wheels=wheels,
    ...                      orbit=CircularOrbit(6878137.0, np.radians(97.4)),
    ...                      disturbances=[lgvi.spacecraft.GravityGradient()])
    >>> [c.kind for c in sc.components()]
    ['orbit', 'orbit_gravity_gradient']
    """

    def __init__(self, body: Any, *, wheels: Any = None, magnetorquers: Any = None, orbit: Any = None,
                 field: Any = None, epoch: Any = None, disturbances: Sequence[Any] = (), sensors: Sequence[Any] = (),
                 environment: Sequence[Any] = (), orbit_dt: float = ORBIT_TABLE_DT, environment_rate: Any = None,
                 magnetorquer_rate: Any = None) -> None:
        self.body: RigidBody = body if isinstance(body, RigidBody) else RigidBody(body)
        if wheels is not None and not (hasattr(wheels, "axes") and hasattr(wheels, "spin_inertia")
                                       and callable(getattr(wheels, "_for_run", None))):
            raise TypeError(f"wheels must be an lgvi.ReactionWheels or None, got {type(wheels).__name__}")
        self.wheels = wheels
        if magnetorquers is not None and not (hasattr(magnetorquers, "axes") and hasattr(magnetorquers, "max_dipole")):
            raise TypeError(f"magnetorquers must be an lgvi.Magnetorquers or None, got {type(magnetorquers).__name__}")
        self.magnetorquers = magnetorquers
        if orbit is not None and not callable(getattr(orbit, "position_velocity", None)):
            raise TypeError(f"orbit must have a position_velocity(t) method (an lgvi.environment orbit), got "
                            f"{type(orbit).__name__}")
        self.orbit = orbit
        from ..environment.field import SphericalHarmonicField

        if field is not None and not isinstance(field, SphericalHarmonicField):
            raise TypeError(f"field must be an lgvi.environment field model (IGRF, WMM, CentredDipole) or None, "
                            f"got {type(field).__name__}")
        if field is not None and orbit is None:
            raise ValueError("field needs an orbit (the field is evaluated at the spacecraft's position): give orbit=")
        self.field = field
        if epoch is None:
            epoch = getattr(orbit, "epoch", None)
        if epoch is not None:
            from ..environment.orbits import utc_epoch

            epoch = utc_epoch(epoch)
        elif field is not None:
            raise ValueError("field needs epoch= (UTC of t = 0: the Earth's rotation angle and the field's date), "
                             "e.g. epoch=datetime.datetime(2026, 1, 1)")
        self.epoch = epoch
        self.orbit_dt: float = as_float(orbit_dt, "orbit_dt", positive=True)
        self.environment_rate = environment_rate
        self.magnetorquer_rate = magnetorquer_rate
        self.disturbances: list[Any] = components_of(disturbances, "disturbances", ("disturbance",))
        self.sensors: list[Any] = components_of(sensors, "sensors", ("sensor",))
        self.environment: list[Any] = components_of(environment, "environment", ("environment",))
        for d in self.disturbances:
            if d.kind == "orbit_gravity_gradient" and orbit is None:
                raise ValueError("disturbances: GravityGradient needs the spacecraft's orbit: give orbit=")
        self._built = self._build()

    def _build(self) -> list[Any]:
        out: list[Any] = []
        if self.orbit is not None:
            out.append(OrbitTable(dt=self.orbit_dt, rate=self.environment_rate))
        if self.field is not None:
            out.append(FieldModel(rate=self.environment_rate))
        # the environment by code (sun, shadow, atmospheres: each reads what the ones before write), a
        # user's own last
        env = sorted(self.environment, key=lambda c: kind_of(c).code or 10 ** 6)
        out += env + self.disturbances + self.sensors
        if self.magnetorquers is not None:
            out.append(MagnetorquerRods(self.magnetorquers, rate=self.magnetorquer_rate))
        return out

    def components(self) -> list[Any]:
        """The spacecraft's components (the orbit, the field, the user's environment models, the
        disturbances, the sensors and the magnetorquers), in the order the loop runs them."""
        return list(self._built)

    def __repr__(self) -> str:
        parts = [f"J=diag{tuple(np.round(np.diag(self.body.J), 6).tolist())}"]
        if self.wheels is not None:
            parts.append(f"{len(self.wheels)} wheels")
        if self.magnetorquers is not None:
            parts.append(f"{self.magnetorquers.count} rods")
        if self.orbit is not None:
            parts.append(f"orbit={self.orbit!r}")
        if self.field is not None:
            parts.append(f"field={self.field!r}")
        parts += [repr(c) for c in self.disturbances + self.sensors + self.environment]
        return "Spacecraft(" + ", ".join(parts) + ")"


def components_of(items: Any, name: str, families: tuple[str, ...]) -> list[Any]:
    """A list of components of ``families`` (each an object with ``kind`` registered in one of them)."""
    if isinstance(items, Component) or items is None:
        items = () if items is None else (items,)
    try:
        items = list(items)
    except TypeError as exc:
        raise TypeError(f"{name} must be a sequence of components, got {type(items).__name__}") from exc
    for i, c in enumerate(items):
        kind = kind_of(c)
        if kind is None or not callable(getattr(c, "params", None)):
            raise TypeError(f"{name}[{i}] must be a component (an object with a registered kind and params()), got "
                            f"{type(c).__name__}")
        if kind.family not in families:
            raise ValueError(f"{name}[{i}] is a {kind.family} component ({kind.name!r}); {name} takes "
                             f"{' or '.join(families)} components")
    return items


def _register() -> None:
    rows = (
        ComponentKind("orbit", "environment", 190, None, (), ("r_N", "v_N"), OrbitTable,
                      doc="the spacecraft's orbit, tabulated for the run (cubic Hermite)"),
        ComponentKind("field", "environment", 191, None, ("r_N",), ("B_N",), FieldModel,
                      doc="geomagnetic field (IGRF, WMM, dipole) at r_N, compiled"),
        ComponentKind("orbit_gravity_gradient", "disturbance", 290, None, (), (), GravityGradient,
                      doc="gravity gradient along the orbit, in the variational step (per-member inertia)",
                      extra={"variational": True}),
        ComponentKind("magnetorquers", "actuator", 801, None, ("dipole_request_B", "B_N", "R"),
                      ("dipole_B", "tau_control_B"), MagnetorquerRods,
                      doc="magnetorquer rods: least squares, clipped per rod, torque m x B"),
    )
    for kind in rows:
        if kind.name not in COMPONENT_KINDS:
            register_kind(kind)


_register()


from .disturbances import FacetDrag, FacetSRP, ResidualDipole  # noqa: E402  (issue 26's kinds)
from .sensors import CoarseSunSensors, FineSunSensor, Gyro, Magnetometer, StarTracker  # noqa: E402  (issue 27's)

__all__ += ["FacetDrag", "FacetSRP", "ResidualDipole", "Gyro", "StarTracker", "Magnetometer", "CoarseSunSensors",
            "FineSunSensor"]
