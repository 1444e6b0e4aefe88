r"""What a run conserves: one declaration that summaries, tables, figures and tests read.

Every system declares its invariants: each torque model (:meth:`lgvi.torques.TorqueModel.invariants`,
sums combine their members' declarations with :func:`combine`), the free body (:data:`FREE_BODY`),
and, for torques given as arrays or callables, nothing. :func:`lgvi.simulate` stores the declaration
of a forced run in ``meta["invariants"]`` (a free body's follows from ``meta["torque"]`` being
``"none"``); :func:`declared` reads it back from any trajectory, and
:func:`lgvi.outputs.conservation_drifts`, ``lgvi run``'s summary, ``lgvi compare``, ``lgvi info``
and :mod:`lgvi.plot` show the declared quantities and mark the others as not invariants.

A declaration maps a quantity of :data:`QUANTITIES` to ``{"kind": KIND, **parameters}``:

=========== =============================================================================
kind        meaning (for the LGVI, at any order)
=========== =============================================================================
``exact``   conserved to round-off (the error grows only as accumulated rounding)
``bounded`` no secular drift: an ``O(h^p)`` oscillation that stays bounded over long times
=========== =============================================================================

A quantity absent from the declaration is not an invariant of the problem.

==========================================  ======================================================
system                                      invariants
==========================================  ======================================================
free body (no torque)                       energy, ``|Pi|``, ``R Pi`` (so ``e3 . R Pi``): exact
:class:`~lgvi.torques.UniformGravity`       total energy: bounded; ``e3 . R Pi`` (about the
                                            gravity axis): exact
:class:`~lgvi.torques.GravityGradient`      Jacobi integral ``E - n e3 . R Pi``: bounded
damping, PD control, constant moments,      none
torque arrays, callables
==========================================  ======================================================

The Jacobi integral. :class:`~lgvi.torques.GravityGradient`'s potential ``U(t, R)`` depends on
time only through the orbit: ``U(t + s, Rz(n s) R) = U(t, R)`` for every ``s``, ``Rz`` the rotation
about the orbit normal ``e3``. Then ``dE/dt = dU/dt (at fixed R) = n e3 . R M = n d(e3 . R Pi)/dt``
(``R M`` is the inertial moment, the rate of ``R Pi``), so ``C = E - n e3 . R Pi`` is conserved:
the energy in the frame turning with the orbit. The LGVI step commutes with that symmetry, so in
the rotating frame it is an autonomous symplectic map and ``C`` has no drift. A potential that is
symmetric under time shifts and under ``Rz`` (uniform gravity) conserves ``C`` for every ``n``,
which :func:`combine` uses for sums of the two.

Adding a quantity: a :class:`Quantity` in :data:`QUANTITIES` (its values from a trajectory and its
parameters); a system declares it by key.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np

__all__ = [
    "BOUNDED",
    "EXACT",
    "FREE_BODY",
    "NOT_INVARIANT",
    "QUANTITIES",
    "Declaration",
    "Quantity",
    "MODEL_TYPES",
    "combine",
    "declared",
    "declaration_of",
    "declares_invariants",
    "drifts",
    "error_series",
]

EXACT = "exact"
BOUNDED = "bounded"
KINDS = (EXACT, BOUNDED)
NOT_INVARIANT = "not an invariant"
#: Short descriptions of the kinds (for summaries and legends).
KIND_TEXT = {EXACT: "exact (to round-off)", BOUNDED: "bounded (no drift)"}


@dataclass(frozen=True)
class Quantity:
    """A quantity a system may conserve.

    Attributes
    ----------
    key : str
        Name in declarations and in ``meta["invariants"]``.
    name : str
        Plain-text name (summaries, ``lgvi info``).
    column : str
        Short column header of ``lgvi compare`` (the error's symbol).
    tex : str
        Legend and panel label (matplotlib mathtext).
    values : callable
        ``values(traj, params) -> (M,) or (M, 3) ndarray``.
    abs_key, rel_key : str or None
        Keys of the absolute and relative drift in :func:`lgvi.outputs.conservation_drifts`.
    scale : callable, optional
        ``scale(traj, values) -> float``, the reference of the relative error (default
        ``|values[0]|``).
    """

    key: str
    name: str
    column: str
    tex: str
    values: Callable[[Any, Mapping[str, Any]], np.ndarray]
    abs_key: str | None
    rel_key: str
    scale: Callable[[Any, np.ndarray], float] | None = None


def _energy(traj, p):
    return np.asarray(traj.energy, dtype=np.float64)


def _casimir(traj, p):
    return np.linalg.norm(np.asarray(traj.Pi, dtype=np.float64), axis=1)


def _momentum(traj, p):
    return np.asarray(traj.spatial_momentum, dtype=np.float64)


def _momentum_e3(traj, p):
    return np.asarray(traj.spatial_momentum, dtype=np.float64)[:, 2]


def _momentum_scale(traj, v):
    # relative to |R0 Pi0|, as the whole vector (a zero vertical component is common)
    return float(np.linalg.norm(np.asarray(traj.spatial_momentum)[0]))


def _total_momentum(traj, p):
    return np.asarray(traj.angular_momentum, dtype=np.float64)


def _total_momentum_e3(traj, p):
    return np.asarray(traj.angular_momentum, dtype=np.float64)[:, 2]


def _total_momentum_scale(traj, v):
    return float(np.linalg.norm(np.asarray(traj.angular_momentum)[0]))


def _linear_momentum(traj, p):
    return np.asarray(traj.linear_momentum, dtype=np.float64)


def _linear_momentum_scale(traj, v):
    # relative to the largest body momentum (the total is often zero)
    return float(np.abs(np.asarray(traj.p)[0]).max())


def _jacobi(traj, p):
    return _energy(traj, p) - float(p["n"]) * _momentum_e3(traj, p)


#: The quantities, in the order every table and figure shows them.
QUANTITIES: dict[str, Quantity] = {q.key: q for q in (
    Quantity("spatial_momentum", "spatial momentum R Pi", "max dL/L", r"spatial momentum $R\Pi$", _momentum,
             None, "spatial_momentum_rel", _momentum_scale),
    Quantity("spatial_momentum_e3", "vertical e3 . R Pi", "dL3/L", r"vertical momentum $e_3\cdot R\Pi$",
             _momentum_e3, None, "spatial_momentum_e3_rel", _momentum_scale),
    Quantity("casimir", "|Pi| (Casimir)", "d|Pi|/|Pi|", r"$|\Pi|$ (Casimir)", _casimir, None, "casimir_rel"),
    Quantity("energy", "energy (total)", "dE/E", "energy $E$", _energy, "energy_abs", "energy_rel"),
    Quantity("jacobi", "Jacobi integral E - n e3 . R Pi", "dC/C",
             r"Jacobi integral $C = E - n\,e_3\cdot R\Pi$", _jacobi, "jacobi_abs", "jacobi_rel"),
    # bodies in orbit, two bodies (lgvi.systems.orbit, lgvi.systems.two_body)
    Quantity("angular_momentum", "total angular momentum x x p + R Pi", "dL/L",
             r"total angular momentum $x\times p + R\Pi$", _total_momentum, None, "angular_momentum_rel",
             _total_momentum_scale),
    Quantity("angular_momentum_e3", "polar total angular momentum e3 . (x x p + R Pi)", "dLz/L",
             r"polar momentum $e_3\cdot(x\times p + R\Pi)$", _total_momentum_e3, None, "angular_momentum_e3_rel",
             _total_momentum_scale),
    Quantity("linear_momentum", "total linear momentum p1 + p2", "dP/p", r"linear momentum $p_1 + p_2$",
             _linear_momentum, None, "linear_momentum_rel", _linear_momentum_scale),
)}

#: Quantities a summary lists even when the system does not conserve them (then marked so).
USUAL = ("spatial_momentum", "spatial_momentum_e3", "casimir", "energy")

#: The free rigid body: the LGVI (the discrete Moser-Veselov flow) conserves all four to round-off.
FREE_BODY: dict[str, dict[str, Any]] = {"spatial_momentum": {"kind": EXACT}, "spatial_momentum_e3": {"kind": EXACT},
                                        "casimir": {"kind": EXACT}, "energy": {"kind": EXACT}}


def _check(decl: Mapping[str, Any], where: str) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    if not (isinstance(decl, dict) or isinstance(decl, Mapping)):  # dict first: typing's check costs ~1 us
        raise TypeError(f"{where}: a declaration of invariants must be a mapping, got {type(decl).__name__}")
    for key, entry in decl.items():
        if key not in QUANTITIES:
            raise ValueError(f"{where}: unknown quantity {key!r}; known: {', '.join(QUANTITIES)}")
        if not (isinstance(entry, dict) or isinstance(entry, Mapping)) or entry.get("kind") not in KINDS:
            raise ValueError(f"{where}: {key} must be declared as {{'kind': 'exact' or 'bounded', ...}}, got {entry!r}")
        out[key] = dict(entry)
    return out


def _weaker(a: str, b: str) -> str:
    return BOUNDED if BOUNDED in (a, b) else EXACT


def _implied(decl: Mapping[str, Mapping[str, Any]], key: str, params: Mapping[str, Any]) -> str | None:
    """The kind with which ``decl`` conserves ``key`` with ``params`` (``None``: it does not)."""
    entry = decl.get(key)
    if entry is not None and _params(entry) == dict(params):
        return entry["kind"]
    if key == "spatial_momentum_e3" and "spatial_momentum" in decl:
        return decl["spatial_momentum"]["kind"]
    if key == "jacobi":  # E - n L3 for every n when E and L3 are both conserved
        e = decl.get("energy", {}).get("kind")
        l3 = _implied(decl, "spatial_momentum_e3", {})
        if e is not None and l3 is not None:
            return _weaker(e, l3)
    return None


def combine(decls: list[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """The invariants of a sum of systems: what every member conserves, with the weaker kind.

    A member conserves a quantity it declares, ``e3 . R Pi`` when it declares ``R Pi``, and the
    Jacobi integral for any rate ``n`` when it conserves both the energy and ``e3 . R Pi`` (as
    uniform gravity does), so ``UniformGravity + GravityGradient`` keeps the Jacobi integral.
    """
    checked = [_check(d, "combine") for d in decls]
    if not checked:
        return {}
    out: dict[str, dict[str, Any]] = {}
    for d in checked:
        for key, entry in d.items():
            params = _params(entry)
            kinds = [_implied(other, key, params) for other in checked]
            if all(k is not None for k in kinds) and key not in out:
                kind = EXACT
                for k in kinds:
                    kind = _weaker(kind, k)
                out[key] = {"kind": kind, **params}
    return {k: out[k] for k in QUANTITIES if k in out}


#: The classes whose instances declare their own invariants (``invariants()``): the torque models'
#: base class, :class:`lgvi.torques.TorqueModel`, which :mod:`lgvi.torques` adds on import with
#: :func:`declares_invariants`, so that this module stays below the torque models.
MODEL_TYPES: list[type] = []


def declares_invariants(cls: type) -> type:
    """Class decorator: instances of ``cls`` declare their invariants (:func:`declaration_of` calls
    their ``invariants()``)."""
    if cls not in MODEL_TYPES:
        MODEL_TYPES.append(cls)
    return cls


def declaration_of(torque: Any) -> dict[str, dict[str, Any]]:
    """The declaration of a run's torque: ``None`` (free body), a torque model, or anything else
    (arrays, callables: no invariants declared)."""
    if torque is None:
        return {k: dict(v) for k, v in FREE_BODY.items()}
    if isinstance(torque, tuple(MODEL_TYPES)):
        decl = torque.invariants()
        try:
            return _check(decl, "")
        except (TypeError, ValueError):  # again, naming the model (its repr only when needed: ~2 us a run)
            return _check(decl, repr(torque))
    return {}


@dataclass(frozen=True)
class Declaration:
    """The invariants of one trajectory's system (see :func:`declared`).

    Attributes
    ----------
    entries : dict
        Quantity key -> ``{"kind": "exact" | "bounded", **parameters}``, in display order.
    system : str
        What the run simulated ("the free body", the torque model, "torque array", ...).
    recorded : bool
        False when the trajectory carries no declaration and none could be inferred (a forced
        run saved by an older lgvi, or a baseline of a forced problem): nothing is declared.
    """

    entries: dict[str, dict[str, Any]] = field(default_factory=dict)
    system: str = ""
    recorded: bool = True

    def kind(self, key: str) -> str | None:
        """``"exact"``, ``"bounded"`` or ``None`` (not an invariant)."""
        e = self.entries.get(key)
        return None if e is None else e["kind"]

    def quantities(self) -> list[str]:
        """The declared quantities, in the order of :data:`QUANTITIES`."""
        return [k for k in QUANTITIES if k in self.entries]

    def not_invariants(self) -> list[str]:
        """The usual quantities (:data:`USUAL`) this system does not conserve."""
        return [k for k in USUAL if k not in self.entries]

    def label(self, key: str) -> str:
        """``"exact"``, ``"bounded"`` or ``"not an invariant"``."""
        return self.kind(key) or NOT_INVARIANT

    def labels(self) -> dict[str, str]:
        """Quantity key -> ``"exact"``, ``"bounded"`` or ``"not an invariant"``, for the declared
        quantities and the usual ones (JSON summaries)."""
        return {k: self.label(k) for k in QUANTITIES if k in self.entries or k in USUAL}

    def note(self, short: bool = False) -> str:
        """Whose invariants these are, in a few words (summaries; ``short`` for figure titles:
        model names without their parameters)."""
        system = self.system
        if short:
            names = [m for m in re.findall(r"([A-Za-z_]\w*)\(", system) if m != "TorqueSum"]
            system = " + ".join(names) if names else system
            if system.startswith("a spacecraft under"):          # its torques' kinds: in the long note
                system = system.split(" (")[0]
        if not self.recorded:
            return f"invariants not recorded for this run ({system}): none shown"
        if not self.entries:
            return f"{system} has no invariants"
        return f"invariants of {system}"


def _system(meta: Mapping[str, Any]) -> str:
    system = meta.get("system")
    torque = meta.get("torque", "none")
    if system == "spacecraft" and meta.get("invariants") == {}:     # control, disturbances, gravity gradient
        ext = [str(k).replace("_", " ") for k in meta.get("external_torques") or ()]
        return "a spacecraft under external torques" + (f" ({', '.join(ext)})" if ext else "")
    if isinstance(system, str) and system not in ("", "rigid_body"):
        # another system's result (a chain, a slosh hub, a spacecraft...): named by its registry key,
        # not "the free body"
        name = f"the {system.replace('_', ' ')}"
        if torque in (None, "none", ""):
            return name
        return f"{name} with {meta['torque_model']}" if "torque_model" in meta else f"{name} with torque {torque}"
    if torque in (None, "none", ""):
        return "the free body"
    if "torque_model" in meta:
        return str(meta["torque_model"])
    return f"torque {torque}"


def declared(traj: Any, default: Declaration | None = None) -> Declaration:
    """The declaration of invariants of a trajectory's system.

    Read from ``meta["invariants"]`` (written by :func:`lgvi.simulate`); a trajectory without one
    is a free body when its ``meta["torque"]`` is missing or ``"none"`` and it has no potential;
    otherwise ``default`` when given, else an empty declaration with ``recorded=False``.
    """
    meta = getattr(traj, "meta", None) or {}
    system = _system(meta)
    if "invariants" in meta:
        return Declaration(_check(meta["invariants"], "meta['invariants']"), system)
    if meta.get("torque", "none") in (None, "none", "") and getattr(traj, "potential", None) is None:
        return Declaration({k: dict(v) for k, v in FREE_BODY.items()}, "the free body")
    if default is not None:
        return default
    return Declaration({}, system, recorded=False)


def _change(traj: Any, key: str, params: Mapping[str, Any]) -> tuple[np.ndarray, float]:
    """``|q_k - q_0|`` (vectors: the norm) at each sample, and the scale of the relative error."""
    q = QUANTITIES[key]
    v = q.values(traj, params)
    if v.ndim == 1:
        return np.abs(v - v[0]), (q.scale(traj, v) if q.scale is not None else abs(float(v[0])))
    return np.linalg.norm(v - v[0], axis=1), (q.scale(traj, v) if q.scale is not None
                                              else float(np.linalg.norm(v[0])))


def _params(entry: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in entry.items() if k != "kind"}


def error_series(traj: Any, key: str, params: Mapping[str, Any] | None = None) -> tuple[np.ndarray, bool]:
    """The error of a quantity at each sample: ``|q_k - q_0| / scale`` (vectors: the norm).

    Returns ``(error (M,), relative)``: ``relative`` is False when the scale is zero (the error is
    then absolute). The scale is ``|q_0|``, for ``e3 . R Pi`` the whole ``|R_0 Pi_0|``.
    """
    d, scale = _change(traj, key, params or {})
    if scale > 0 and np.isfinite(scale):
        return d / scale, True
    return d, False


def drifts(traj: Any, decl: Declaration) -> dict[str, float | None]:
    """Largest change over the run of each declared quantity, under the keys ``Quantity.abs_key``
    (absolute, when it has one) and ``Quantity.rel_key`` (relative; ``None`` at a zero scale)."""
    out: dict[str, float | None] = {}
    for key in decl.quantities():
        q = QUANTITIES[key]
        d, scale = _change(traj, key, _params(decl.entries[key]))
        big = float(np.max(d))
        if q.abs_key is not None:
            out[q.abs_key] = big
        out[q.rel_key] = big / scale if scale > 0 and np.isfinite(big / scale) else None
    return out


def forcing_used(kind: str, forcing: str, model: Any = None) -> str:
    """The forcing scheme a run actually uses, for ``meta["forcing"]``.

    Potentials always take the symmetric (variational) step, whatever ``forcing`` says; the other
    moments take ``forcing``. Returns ``forcing`` for the free body and for arrays and callables,
    ``"symmetric"`` for a model whose terms are all conservative (or with ``forcing="symmetric"``),
    and ``"symmetric (potential), paper (other moments)"`` for a mixed model with
    ``forcing="paper"``.
    """
    if kind != "model" or model is None or forcing == "symmetric":
        return forcing
    conservative = [m.conservative for m in model.terms]
    if all(conservative):
        return "symmetric"
    if any(conservative):
        return "symmetric (potential), paper (other moments)"
    return forcing
