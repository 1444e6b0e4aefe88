"""The declaration of a rigid hub with spherical slosh pendulums on ``SO(3) x (S^2)^n`` (:data:`SLOSH`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...invariants import BOUNDED, EXACT
from .. import Field, System, register


def slosh_invariants(config: Any) -> dict[str, dict[str, Any]]:
    """The declaration of a run (``config``: a dict with ``damping``, (n,), and ``motors``, whether
    wheel motors or friction act): the total angular momentum (hub, pendulums and wheels) exact;
    the energy bounded without damping and without motors (with damping it decreases, motors
    change it: no declaration). ``R`` on SO(3) and every ``|q_i| = 1`` hold to round-off too."""
    d = np.asarray((config or {}).get("damping", 0.0), dtype=np.float64)
    out: dict[str, dict[str, Any]] = {"angular_momentum": {"kind": EXACT}}
    if not d.any() and not (config or {}).get("motors", False):
        out["energy"] = {"kind": BOUNDED}
    return out


def _kernels() -> dict[str, Any]:
    from ..._kernels import slosh_kernels

    return {"run_slosh": slosh_kernels.run_slosh, "slosh_substep": slosh_kernels.slosh_substep,
            "kick_build": slosh_kernels.kick_build, "kick_apply": slosh_kernels.kick_apply}


def _scene(traj: Any) -> Any:
    from .scene import slosh_scene

    return slosh_scene(traj)


def _load(path: Any) -> Any:
    from .run import SloshTrajectory

    return SloshTrajectory.load(path)


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> Any:
    from .run import slosh_from_stream

    return slosh_from_stream(meta, arrays, state)


def slosh_description(traj: Any) -> list[str]:
    """What was simulated (summary lines)."""
    lines = [f"system:        a rigid hub ({traj.hub_mass:g} kg) with {traj.n_pendulums} spherical slosh pendulums "
             f"(lgvi.simulate_slosh): lengths {np.round(traj.lengths, 6).tolist()} m, masses "
             f"{np.round(traj.masses, 6).tolist()} kg, damping {np.round(traj.damping, 6).tolist()} N s/m, "
             f"order {traj.meta.get('order')}"]
    if traj.n_wheels:
        ctrl = traj.meta.get("controller")
        lines.append(f"wheels:        {traj.n_wheels} reaction wheels, spin inertias "
                     f"{np.round(traj.spin_inertia, 6).tolist()} kg m^2; "
                     + (f"MRP feedback K = {ctrl['K']:g}, P = {ctrl['P']:g} every {traj.meta['control_period']:g} s"
                        if ctrl else "motor commands given" if traj.meta.get("wheel_torque") else "motors off"))
    return lines


SLOSH = register(System(
    name="slosh",
    doc="a rigid hub with n spherical slosh pendulums and N reaction wheels: attitude R (3, 3), Pi (3,), directions "
        "q (n, 3), pi (n, 3), wheel momenta (N,)",
    state=(Field("R", (3, 3), doc="hub attitude"),
           Field("Pi", (3,), doc="hub momentum, body frame"),
           Field("q", ("n", 3), doc="pendulum directions, inertial unit vectors"),
           Field("pi", ("n", 3), doc="pendulum angular momenta, inertial"),
           Field("wheel_momentum", ("N",), doc="reaction wheels' absolute axial momenta (N = 0: no wheels)")),
    records=(Field("iterations", (), np.int32, "largest Newton iterations per saved interval"),
             Field("residual", (), np.float64, "largest final Newton residual per saved interval"),
             Field("wheel_torque", ("N",), np.float64, "wheel motor torques of each saved interval's first step")),
    kernels=_kernels,
    results=("t", "R", "Pi", "q", "pi", "wheel_momentum", "iterations", "residual", "wheel_torque", "h", "meta"),
    scenario_section="slosh",
    run_factory=None,
    invariants=slosh_invariants,
    from_stream=_from_stream,
    from_scenario=lambda table: slosh_scenario(table),
    describe=slosh_description,
    saved_as=("lgvi.slosh/1", _load),
    view=lambda traj: _scene(traj),
))


#: The keys of a scenario's ``[slosh]`` section: required, then optional.
SCENARIO_KEYS = ("inertia", "hub_mass", "pivots", "lengths", "masses", "q0", "R0", "qdot0", "omega0", "damping",
                 "order", "composition", "wheels", "controller", "control_period", "wheel_torque")
#: The keys of ``slosh.wheels`` (:class:`lgvi.ReactionWheels`) and ``slosh.controller``
#: (:class:`lgvi.control.MRPFeedback`, compiled: a fixed target).
WHEEL_KEYS = ("axes", "spin_inertia", "speed0", "max_torque", "min_torque", "max_power", "max_speed", "friction")
CONTROLLER_KEYS = ("K", "P", "Ki", "integral_limit", "target")
_REQUIRED = SCENARIO_KEYS[:6]


def slosh_scenario(table: Any) -> tuple[tuple[Any, ...], dict[str, Any]]:
    """``(args, kwargs)`` of :func:`lgvi.simulate_slosh` from a scenario's ``[slosh]`` section::

        [slosh]
        inertia = [900.0, 800.0, 600.0]           # hub, about its centre of mass [kg m^2]: (3,) or (3, 3)
        hub_mass = 1500.0                         # [kg]
        pivots = [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]]   # body frame, from the hub's centre of mass [m]
        lengths = [0.3, 0.4]                      # [m]
        masses = [40.0, 60.0]                     # [kg]
        q0 = [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]] # directions, body frame
        R0 = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]    # optional: hub attitude (default identity)
        qdot0 = [[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]]   # optional: rates relative to the hub [1/s]
        omega0 = [0.3, -0.2, 0.5]                 # optional: hub rate, body [rad/s]
        damping = [30.0, 50.0]                    # optional [N s/m]
        order = 4                                 # optional: 2, 4 or 6
        # optional: reaction wheels (lgvi.ReactionWheels' arguments) and the compiled MRP feedback
        wheels = {axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]], spin_inertia = 0.08, max_torque = 0.2}
        controller = {K = 3.5, P = 30.0, target = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}
        control_period = 0.5                      # [s], a multiple of h
        # or, instead of a controller, held motor commands [N m]: wheel_torque = [0.1, 0.0, -0.1]

    The values are checked by the run; a wrong key or type raises ``ValueError`` or ``TypeError``
    naming ``slosh.<key>``."""
    if not isinstance(table, dict):
        raise TypeError(f"slosh: expected a table ([slosh] with {', '.join(_REQUIRED)}), got {type(table).__name__}")
    unknown = [k for k in table if k not in SCENARIO_KEYS]
    if unknown:
        raise ValueError(f"slosh.{unknown[0]}: unknown key; expected one of {', '.join(SCENARIO_KEYS)}")
    for key in _REQUIRED:
        if key not in table:
            raise ValueError(f"slosh.{key}: missing (the slosh system needs {', '.join(_REQUIRED)})")
    for key, kind, what in (("order", int, "an integer (2, 4 or 6)"), ("composition", str, "a string")):
        if key in table and (not isinstance(table[key], kind) or isinstance(table[key], bool)):
            raise TypeError(f"slosh.{key}: expected {what}, got {table[key]!r}")
    if not isinstance(table["hub_mass"], (int, float)) or isinstance(table["hub_mass"], bool):
        raise TypeError(f"slosh.hub_mass: expected a number (kg), got {table['hub_mass']!r}")
    for key in ("inertia", "pivots", "lengths", "masses", "q0", "R0", "qdot0", "omega0"):
        if key in table and not isinstance(table[key], list):
            raise TypeError(f"slosh.{key}: expected an array, got {table[key]!r}")
    if "damping" in table and not isinstance(table["damping"], (list, int, float)):
        raise TypeError(f"slosh.damping: expected a number or an array (N s/m), got {table['damping']!r}")
    args = (table["inertia"], table["hub_mass"], table["pivots"], table["lengths"], table["masses"],
            table.get("R0", np.eye(3).tolist()), table["q0"])
    kwargs = {k: table[k] for k in SCENARIO_KEYS[7:12] if k in table}
    for key in ("wheel_torque",):
        if key in table and not isinstance(table[key], list):
            raise TypeError(f"slosh.{key}: expected an array (one motor torque per wheel, N m), got {table[key]!r}")
    if "control_period" in table and (not isinstance(table["control_period"], (int, float))
                                      or isinstance(table["control_period"], bool)):
        raise TypeError(f"slosh.control_period: expected a number (seconds), got {table['control_period']!r}")
    kwargs.update({k: table[k] for k in ("control_period", "wheel_torque") if k in table})
    if "wheels" in table:
        kwargs["wheels"] = _scenario_object(table["wheels"], "wheels", WHEEL_KEYS, ("axes", "spin_inertia"))
    if "controller" in table:
        kwargs["controller"] = _scenario_object(table["controller"], "controller", CONTROLLER_KEYS, ("K", "P"))
    return args, kwargs


def _scenario_object(tbl: Any, key: str, keys: tuple[str, ...], required: tuple[str, ...]) -> Any:
    """An :class:`lgvi.ReactionWheels` (``key = "wheels"``) or :class:`lgvi.control.MRPFeedback` from
    its scenario table; errors name ``slosh.<key>``."""
    from ...control import MRPFeedback
    from ..gyrostat import ReactionWheels

    if not isinstance(tbl, dict):
        raise TypeError(f"slosh.{key}: expected a table ({{{', '.join(required)}, ...}}), got {tbl!r}")
    unknown = [k for k in tbl if k not in keys]
    if unknown:
        raise ValueError(f"slosh.{key}: unknown key {unknown[0]!r}; expected some of {', '.join(keys)}")
    missing = [k for k in required if k not in tbl]
    if missing:
        raise ValueError(f"slosh.{key}: missing {missing[0]!r} (needs {', '.join(required)})")
    try:
        if key == "wheels":
            return ReactionWheels(tbl["axes"], tbl["spin_inertia"], **{k: v for k, v in tbl.items() if k not in required})
        return MRPFeedback(**tbl)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"slosh.{key}: {exc}") from None
