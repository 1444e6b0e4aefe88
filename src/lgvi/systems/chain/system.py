"""The declaration of the chain of spherical pendulums on ``(S^2)^n`` (:data:`CHAIN`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...invariants import BOUNDED, EXACT
from .. import Field, System, register


def chain_invariants(config: Any) -> dict[str, dict[str, Any]]:
    """The declaration of a run (``config``: a dict with ``gravity``, the (3,) acceleration): the
    angular momentum about the pivot (all of it without gravity, its ``e3`` component with gravity
    along ``e3``) exact, the energy bounded. (The unit length of every link is exact too: the
    steps are rotations.)"""
    g = np.asarray((config or {}).get("gravity", (0.0, 0.0, -1.0)), dtype=np.float64)
    out: dict[str, dict[str, Any]] = {}
    if not g.any():
        out["angular_momentum"] = {"kind": EXACT}
    elif not g[0] and not g[1]:
        out["angular_momentum_e3"] = {"kind": EXACT}
    out["energy"] = {"kind": BOUNDED}
    return out


def _kernels() -> dict[str, Any]:
    from ..._kernels import chain_kernels

    return {"run_chain": chain_kernels.run_chain, "chain_substep": chain_kernels.chain_substep}


CHAIN = register(System(
    name="chain",
    doc="a chain of n spherical pendulums from a fixed pivot: link directions q (n, 3), momenta pi (n, 3)",
    state=(Field("q", ("n", 3), doc="link directions, unit vectors"),
           Field("pi", ("n", 3), doc="discrete angular momenta of the links")),
    records=(Field("iterations", (), np.int32, "largest Newton iterations per saved interval"),
             Field("residual", (), np.float64, "largest final Newton residual per saved interval")),
    kernels=_kernels,
    results=("t", "q", "pi", "iterations", "residual", "h", "meta"),
    scenario_section="chain",
    run_factory=None,
    invariants=chain_invariants,
    from_stream=lambda meta, arrays, state: _from_stream(meta, arrays, state),
    from_scenario=lambda table: chain_scenario(table),
    describe=lambda traj: chain_description(traj),
    saved_as=("lgvi.chain/1", lambda path: _load(path)),
    view=lambda traj: _scene(traj),
))

#: The keys of a scenario's ``[chain]`` section: required, then optional.
SCENARIO_KEYS = ("lengths", "masses", "q0", "qdot0", "link_masses", "gravity", "order", "composition")
_REQUIRED = ("lengths", "masses", "q0")


def chain_scenario(table: Any) -> tuple[tuple[Any, ...], dict[str, Any]]:
    """``(args, kwargs)`` of :func:`lgvi.simulate_chain` from a scenario's ``[chain]`` section::

        [chain]
        lengths = [1.0, 0.5, 0.5]            # [m], one per link
        masses = [1.0, 1.0, 1.0]             # point masses at the outer ends [kg]
        q0 = [[1, 0, 0], [0, 1, 0], [0, 0, -1]]     # unit directions
        qdot0 = [[0, 1, 0], [0, 0, 2], [1, 0, 0]]   # optional, tangent [1/s]; default rest
        link_masses = [0.0, 0.2, 0.0]        # optional: uniform rods [kg]
        gravity = [0.0, 0.0, -9.80665]       # optional [m/s^2]
        order = 4                            # optional: 2, 4 or 6; composition = "suzuki4"

    The values are checked by the run itself; a wrong key or type raises ``ValueError`` or
    ``TypeError`` naming ``chain.<key>``."""
    if not isinstance(table, dict):
        raise TypeError(f"chain: expected a table ([chain] with {', '.join(_REQUIRED)}), got {type(table).__name__}")
    unknown = [k for k in table if k not in SCENARIO_KEYS]
    if unknown:
        raise ValueError(f"chain.{unknown[0]}: unknown key; expected one of {', '.join(SCENARIO_KEYS)}")
    for key in _REQUIRED:
        if key not in table:
            raise ValueError(f"chain.{key}: missing (the chain needs {', '.join(_REQUIRED)})")
    for key, kind, what in (("order", int, "an integer (2, 4 or 6)"), ("composition", str, "a string")):
        if key in table and (not isinstance(table[key], kind) or isinstance(table[key], bool)):
            raise TypeError(f"chain.{key}: expected {what}, got {table[key]!r}")
    for key in ("lengths", "masses", "q0", "qdot0", "link_masses", "gravity"):
        if key in table and not isinstance(table[key], list):
            raise TypeError(f"chain.{key}: expected an array, got {table[key]!r}")
    args = tuple(table[k] for k in _REQUIRED)
    kwargs = {k: table[k] for k in SCENARIO_KEYS[3:] if k in table}
    return args, kwargs


def chain_description(traj: Any) -> list[str]:
    """What was simulated (summary lines)."""
    n = traj.n_links
    rods = f", rods {np.round(traj.link_masses, 6).tolist()} kg" if np.any(traj.link_masses) else ""
    top = traj.positions[:, :, 2].max() if len(traj.t) else float("nan")
    return [f"system:        a chain of {n} spherical pendulums (lgvi.simulate_chain): lengths "
            f"{np.round(traj.lengths, 6).tolist()} m, masses {np.round(traj.masses, 6).tolist()} kg{rods}, "
            f"gravity {np.round(traj.gravity, 6).tolist()} m/s^2, order {traj.meta.get('order')}",
            f"chain:         highest joint at z = {top:.6g} m; largest ||q_i| - 1| = "
            f"{float(np.max(traj.orthogonality_error)) if len(traj.t) else 0.0:.2g}"]


def _scene(traj: Any) -> Any:
    from .scene import chain_scene

    return chain_scene(traj)


def _load(path: Any) -> Any:
    from .run import ChainTrajectory

    return ChainTrajectory.load(path)


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> Any:
    from .run import chain_from_stream

    return chain_from_stream(meta, arrays, state)
