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
))


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> Any:
    from .run import chain_from_stream

    return chain_from_stream(meta, arrays, state)
