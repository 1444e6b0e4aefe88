"""Today's keywords of :func:`lgvi.simulate` mapped onto the descriptions of the compiled loop.

``lgvi.simulate(body, R0, ..., wheels=, controller=, control_period=, environment=,
magnetorquers=)`` ran the gyrostat (:mod:`lgvi.systems.gyrostat`). Where the same run has an exact
equivalent as an :class:`lgvi.Spacecraft` and an :class:`lgvi.FlightSoftware` (the same steps, bit
for bit), :func:`describe` builds the two and :func:`lgvi.simulate` runs them, with a
:class:`KeywordsDeprecationWarning` (a ``DeprecationWarning``) that names the replacement:

- ``wheels=`` alone: ``Spacecraft(body, wheels=wheels)`` with no flight software;
- ``controller=MRPFeedback(K, P, Ki=, integral_limit=, target=R)`` with a fixed (or no) target,
  with wheels, no environment and no magnetorquers (the gyrostat's compiled MRP feedback):
  ``FlightSoftware(guidance=InertialPointing(R), control=MRPControl(K, P, Ki=, integral_limit=),
  actuators=RWMotorTorque(), rate=control_period)``;
- any other :class:`lgvi.control.Controller` (called from Python): ``FlightSoftware(controller=,
  control_period=)``, with the wheels and the :class:`lgvi.Magnetorquers` on the spacecraft and
  an ``OrbitEnvironment(orbit, field, epoch=)`` as its ``orbit``, ``field`` and ``epoch`` (the
  loop's own orbit and field, recorded as ``r_N``, ``v_N``, ``B_N``, every ``control_period``:
  ``environment_rate``; the controller samples the ``OrbitEnvironment`` as before).

Everything else keeps the gyrostat's path, with no warning, because the loop has no exact
equivalent (:func:`describe` returns ``None``): a ``torque=`` model, ``scheme="rkmk4"``,
``error_estimate``, an ``environment`` that is not an ``OrbitEnvironment`` (or one with a
``reference``), magnetorquers that are not an :class:`lgvi.Magnetorquers`, a controller that is
not an :class:`lgvi.control.Controller`, and the compiled ``MRPFeedback`` without wheels (its body
torque) or with an ``inertia`` of its own and a profile target (those run in Python: the
controller path above).

:func:`lgvi.simulate_ensemble` maps the same keywords member by member (:func:`describe_members`:
``wheels`` and ``controller`` one for all, copied per member, or one per member; the ensemble runs
where every member maps) and keeps the gyrostat ensemble's ``params`` (``wheels.*``,
``controller.*``) beside the components' rows; :func:`lgvi.simulate_stream` maps them as
:func:`lgvi.simulate` does, except when it resumes a stream the gyrostat wrote.
"""

from __future__ import annotations

import contextlib
import contextvars
from typing import Any, Iterator

__all__ = ["KeywordsDeprecationWarning", "as_given", "describe", "describe_members", "replacement"]

#: Set (by :func:`as_given`) where the caller asks for the gyrostat's path as given (scenario files).
_AS_GIVEN: contextvars.ContextVar[bool] = contextvars.ContextVar("lgvi_keywords_as_given", default=False)


class KeywordsDeprecationWarning(DeprecationWarning):
    """``lgvi.simulate(..., wheels=, controller=, ...)`` ran as an ``lgvi.Spacecraft`` with an
    ``lgvi.FlightSoftware``: give those instead (the message names them)."""


@contextlib.contextmanager
def as_given() -> Iterator[None]:
    """Inside, :func:`describe` maps nothing: the old keywords run the gyrostat as given, silently
    (the scenario files' ``[[wheel]]``/``[controller]`` runs, whose outputs stay as they were)."""
    token = _AS_GIVEN.set(True)
    try:
        yield
    finally:
        _AS_GIVEN.reset(token)


def describe(body: Any, *, wheels: Any, controller: Any, control_period: Any, environment: Any,
             magnetorquers: Any, torque: Any, scheme: Any, error_estimate: Any) -> tuple[Any, Any] | None:
    """``(Spacecraft, FlightSoftware or None)`` equivalent to the gyrostat run of these keywords, or
    ``None`` where the loop has no exact equivalent (see the module's notes). Invalid inputs map to
    ``None`` too: the gyrostat's own validation then names them as before."""
    if _AS_GIVEN.get() or torque is not None or scheme not in (None, "lgvi") or error_estimate:
        return None
    if wheels is None and controller is None and control_period is None and environment is None \
            and magnetorquers is None:
        return None
    from ..control import Controller, MRPFeedback
    from ..environment.orbits import OrbitEnvironment
    from ..fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque
    from ..spacecraft import Spacecraft
    from .gyrostat import ReactionWheels

    if wheels is not None and not isinstance(wheels, ReactionWheels):
        return None
    if controller is None:
        if control_period is not None or environment is not None or magnetorquers is not None:
            return None                                       # the gyrostat refuses these: let it say so
        return Spacecraft(body, wheels=wheels), None
    if control_period is None or not isinstance(controller, Controller):
        return None
    if getattr(controller, "compiled", False) and environment is None and magnetorquers is None:
        # the gyrostat's compiled MRP feedback (lgvi.systems.gyrostat: ctrl == 1)
        if type(controller) is not MRPFeedback or wheels is None or len(wheels) == 0:
            return None
        lim = controller.integral_limit
        control = MRPControl(controller.K, controller.P, Ki=controller.Ki,
                             integral_limit=None if controller.Ki is None or lim == float("inf") else lim,
                             inertia=getattr(controller, "_inertia", None))
        guidance = InertialPointing(controller.R_ref)
        return Spacecraft(body, wheels=wheels), FlightSoftware(guidance=guidance, control=control,
                                                               actuators=RWMotorTorque(), rate=control_period)
    orbit = field = epoch = None
    if environment is not None:
        if type(environment) is not OrbitEnvironment or environment.reference is not None:
            return None
        orbit, field, epoch = environment.orbit, environment.field, environment.epoch
    if magnetorquers is not None and type(magnetorquers).__name__ != "Magnetorquers":
        return None
    # the loop's own orbit and field (records r_N, v_N, B_N) at the control period, not every step
    spacecraft = Spacecraft(body, wheels=wheels, magnetorquers=magnetorquers, orbit=orbit, field=field, epoch=epoch,
                            environment_rate=None if orbit is None else control_period)
    return spacecraft, FlightSoftware(controller=controller, control_period=control_period)


def describe_members(bodies: Any, B: int, *, wheels: Any, controller: Any, control_period: Any, environment: Any,
                     magnetorquers: Any, torque: Any) -> tuple[list[Any], list[Any] | None, dict[str, Any]] | None:
    """``(spacecraft, fsw or None, params)`` per member for :func:`lgvi.simulate_ensemble`'s keywords
    (``bodies``: B :class:`lgvi.RigidBody`; ``wheels``, ``controller``: one for all, copied per
    member, or B of them), where every member has an exact equivalent (:func:`describe`), else
    ``None``; ``params`` are the gyrostat ensemble's ``wheels.*`` and ``controller.*`` rows."""
    if _AS_GIVEN.get() or torque is not None:
        return None
    from ..control import Controller
    from .gyrostat import ReactionWheels
    from .gyrostat_ensemble import controller_params, per_member, wheel_params

    try:
        wl = per_member(wheels, "wheels", B, ReactionWheels) if wheels is not None else [None] * B
        cl = per_member(controller, "controller", B, Controller) if controller is not None else [None] * B
    except (TypeError, ValueError):
        return None                              # the gyrostat ensemble names it
    if wheels is not None and len({len(w) for w in wl}) > 1:
        return None
    params: dict[str, Any] = {}
    if wheels is not None:
        params.update(wheel_params(wl))
    if controller is not None:
        params.update(controller_params(cl))     # before any setup, as the gyrostat ensemble's
    pairs = [describe(bodies[b], wheels=wl[b], controller=cl[b], control_period=control_period,
                      environment=environment, magnetorquers=magnetorquers, torque=None, scheme=None,
                      error_estimate=None) for b in range(B)]
    if any(p is None for p in pairs):
        return None
    fsw = [p[1] for p in pairs]
    return [p[0] for p in pairs], None if fsw[0] is None else fsw, params


def replacement(spacecraft: Any, fsw: Any, call: str = "lgvi.simulate") -> str:
    """The warning's text: what was given, and the call that replaces it (``call``: the entry point
    given the old keywords, ``lgvi.simulate``, ``lgvi.simulate_ensemble`` or ``lgvi.simulate_stream``)."""
    return _replacement(spacecraft, fsw).replace("lgvi.simulate(", f"{call}(")


def _replacement(spacecraft: Any, fsw: Any) -> str:
    parts = ["wheels=wheels"] if spacecraft.wheels is not None else []
    if spacecraft.magnetorquers is not None:
        parts.append("magnetorquers=magnetorquers")
    if spacecraft.orbit is not None:
        parts.append("orbit=environment.orbit, field=environment.field, epoch=environment.epoch, "
                     "environment_rate=control_period")
    sc = f"lgvi.Spacecraft(body, {', '.join(parts)})"
    if fsw is None:
        return (f"lgvi.simulate(body, ..., wheels=...) is deprecated: give the spacecraft, "
                f"lgvi.simulate({sc}, R0, ...); the result is the same run, bit for bit (docs/loop.md)")
    if fsw.controller is not None:
        new = "lgvi.FlightSoftware(controller=controller, control_period=control_period)"
    else:
        new = ("lgvi.FlightSoftware(guidance=lgvi.fsw.InertialPointing(target), control=lgvi.fsw.MRPControl(K, P, "
               "Ki=, integral_limit=), actuators=lgvi.fsw.RWMotorTorque(), rate=control_period)")
    return (f"lgvi.simulate(body, ..., wheels=, controller=, control_period=, environment=, magnetorquers=) is "
            f"deprecated: give the spacecraft and its flight software, lgvi.simulate({sc}, R0, ..., fsw={new}); "
            "the result is the same run, bit for bit (docs/loop.md)")
