"""Registries: the one source of truth for the names a run can choose.

Scenario files, the command line, the docs and the tests read these dictionaries; nothing else
re-declares them (see ``docs/architecture.md``):

* :data:`SOLVER_METHODS`: solvers of the implicit equation (name, kernel code, coordinates, cold
  start); :data:`lgvi.implicit.METHODS` is derived from it;
* :data:`FORCINGS`: treatments of the non-conservative moment;
* :data:`COMPOSITIONS` and :data:`DEFAULT_COMPOSITION`: symmetric compositions of the symmetric
  step (:data:`ORDERS` follows from them);
* :data:`SPLITTINGS` and :data:`DEFAULT_SPLITTING`: splitting methods (exact free-body flows, or
  rotations about the principal axes, and kicks) of ``scheme="splitting"``;
* :data:`TORQUE_MODELS`: the torque models by scenario key, each class registered by
  :class:`lgvi.torques.TorqueModel` itself when it is defined (``key = "..."``);
* :data:`lgvi.systems.SYSTEMS`: the dynamical systems the driver runs.

Importing this module loads no Numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Literal

import numpy as np

from ._kernels.codes import METHOD_CAYLEY, METHOD_NEWTON, METHOD_PAPER


# ------------------------------------------------------------------------------------ solvers
@dataclass(frozen=True)
class SolverMethod:
    """A solver of the implicit equation ``hat(h Pi) = F Jd - Jd F^T`` (one kernel branch).

    Attributes
    ----------
    name : str
        The ``method=`` string.
    code : int
        The kernel's integer code (:mod:`lgvi._kernels.codes`).
    coordinates : {"exp", "cayley"}
        How the solver's unknown ``w`` (3,) parametrises ``F``: ``F = exp(hat(w))`` or the Cayley map.
    cold_start : str
        The first guess of a run's first step (later steps start from the previous solution).
    doc : str
        One line for help texts.
    """

    name: str
    code: int
    coordinates: str
    cold_start: str
    doc: str


#: Solver methods by name, in kernel-code order (``method=`` of :func:`lgvi.simulate`).
SOLVER_METHODS: dict[str, SolverMethod] = {m.name: m for m in (
    SolverMethod("paper", METHOD_PAPER, "exp", "linearisation hPi = J w",
                 "the paper's iteration as written (exp map, additive update, step alpha)"),
    SolverMethod("newton", METHOD_NEWTON, "exp", "linearisation hPi = J w",
                 "exact Newton on the group (quadratic convergence), the default"),
    SolverMethod("cayley", METHOD_CAYLEY, "cayley", "linearisation hPi = J w (w = 2 f)",
                 "Newton in Cayley coordinates (Lee et al.)"),
)}
#: The default ``method=``.
DEFAULT_METHOD = "newton"
#: ``method=`` as a type (the names of :data:`SOLVER_METHODS`; ``tests/test_registry.py`` keeps them equal).
MethodName = Literal["paper", "newton", "cayley"]


def method_names() -> tuple[str, ...]:
    """Solver method names, the default first (the order help texts and scenario errors list them)."""
    return (DEFAULT_METHOD,) + tuple(n for n in SOLVER_METHODS if n != DEFAULT_METHOD)


# ------------------------------------------------------------------------------------ forcings
#: Treatments of moments that do not come from a potential (``forcing=``), with their update.
FORCING_DOCS: dict[str, str] = {
    "paper": "the paper's first-order update Pi_(k+1) = F^T Pi_k + h u_k",
    "symmetric": "the second-order symmetric update Pi_(k+1) = F^T Pi_k + h/2 F^T u_k + h/2 u_(k+1)",
}
FORCINGS: tuple[str, ...] = tuple(FORCING_DOCS)
#: ``forcing=`` as a type (the names of :data:`FORCINGS`).
ForcingName = Literal["paper", "symmetric"]

#: Where ``simulate_ensemble(device=...)`` runs the bodies (``lgvi.gpu`` provides ``"cuda"``).
DEVICE_DOCS: dict[str, str] = {
    "cpu": "the machine's cores (Numba threads; Dask tasks with client=)",
    "cuda": "one NVIDIA GPU, one body a thread, the CPU kernels compiled by Numba's CUDA target (lgvi.gpu)",
}
DEVICES: tuple[str, ...] = tuple(DEVICE_DOCS)
#: ``device=`` as a type (the names of :data:`DEVICES`).
DeviceName = Literal["cpu", "cuda"]


# ------------------------------------------------------------------------------------ compositions
@dataclass(frozen=True)
class Composition:
    """A symmetric composition ``Phi_{g_s h} o ... o Phi_{g_1 h}`` of the symmetric step.

    Composing a symmetric method of order 2 with coefficients ``g`` that are symmetric
    (``g_i = g_{s+1-i}``), sum to 1 and satisfy the order conditions gives a symmetric method of
    the stated order (Hairer, Lubich and Wanner, *Geometric Numerical Integration*, 2nd ed.,
    Section V.3).
    """

    name: str
    order: int
    coefficients: tuple[float, ...]
    source: str

    @property
    def stages(self) -> int:
        return len(self.coefficients)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``gam`` (s,), the substep fractions, and ``cum`` (s+1,), the fraction of the step at the
        end of each substep (``cum[0] = 0``, ``cum[s] = 1`` exactly), as the kernels take them
        (new arrays each call, computed once)."""
        gam, cum = self._arrays
        return gam.copy(), cum.copy()

    @cached_property
    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        gam = np.array(self.coefficients)
        cum = np.concatenate([[0.0], np.cumsum(gam)])
        cum[-1] = 1.0
        return gam, cum


def _symmetric(half: list[float]) -> tuple[float, ...]:
    """``half + [middle] + reversed(half)`` with the middle fixing the sum to 1."""
    middle = 1.0 - 2.0 * sum(half)
    return tuple(half) + (middle,) + tuple(reversed(half))


def _triple_jump(base: tuple[float, ...], p: int) -> tuple[float, ...]:
    """Yoshida's triple jump raising a symmetric method of order ``p`` to ``p + 2``."""
    g1 = 1.0 / (2.0 - 2.0 ** (1.0 / (p + 1)))
    g0 = 1.0 - 2.0 * g1                         # = -2^(1/(p+1)) / (2 - 2^(1/(p+1)))
    return tuple(g1 * c for c in base) + tuple(g0 * c for c in base) + tuple(g1 * c for c in base)


_SUZUKI = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))

#: Registry of compositions by name (``simulate(..., composition=name)``).
COMPOSITIONS: dict[str, Composition] = {
    c.name: c for c in (
        Composition("yoshida4", 4, _triple_jump((1.0,), 2),
                    "Yoshida (1990), Phys. Lett. A 150, 262: triple jump, "
                    "g1 = g3 = 1/(2 - 2^(1/3)), g2 = 1 - 2 g1"),
        Composition("suzuki4", 4, _symmetric([_SUZUKI, _SUZUKI]),
                    "Suzuki (1990), Phys. Lett. A 146, 319: fractal 5-stage, "
                    "g1 = g2 = g4 = g5 = 1/(4 - 4^(1/3)), g3 = 1 - 4 g1"),
        Composition("yoshida6", 6, _triple_jump(_triple_jump((1.0,), 2), 4),
                    "Yoshida (1990): triple jump of the triple jump, 9 stages"),
        Composition("kahan-li6", 6, _symmetric([0.39216144400731413927925056, 0.33259913678935943859974864,
                                                 -0.70624617255763935980996482, 0.08221359629355080023149045]),
                    "Kahan and Li (1997), Math. Comp. 66, 1089, scheme s9odr6a, as printed in "
                    "Hairer, Lubich and Wanner, Geometric Numerical Integration, Sect. V.3.2"),
    )
}

#: Composition used by ``order=4`` and ``order=6`` unless ``composition=`` names another.
DEFAULT_COMPOSITION = {4: "suzuki4", 6: "kahan-li6"}


#: The order-2 "composition": the symmetric step itself.
SECOND_ORDER = Composition("none", 2, (1.0,), "the symmetric LGVI step itself")

#: Orders a run can ask for (``order=``): 2 and the orders of the registered compositions.
ORDERS: tuple[int, ...] = (2,) + tuple(sorted({c.order for c in COMPOSITIONS.values()}))


def composition_for(order: Any, composition: Any) -> Composition:
    """The validated composition of ``order=`` and ``composition=`` (``None``: the default one)."""
    from ._validation import choice

    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)) or order not in ORDERS:
        raise ValueError(f"order must be {', '.join(str(o) for o in ORDERS[:-1])} or {ORDERS[-1]}, got {order!r}")
    order = int(order)
    if composition is None:
        if order == 2:
            return SECOND_ORDER
        return COMPOSITIONS[DEFAULT_COMPOSITION[order]]
    choice(composition, "composition", tuple(COMPOSITIONS))
    comp = COMPOSITIONS[composition]
    if comp.order != order:
        raise ValueError(f"composition {composition!r} is of order {comp.order}, but order={order}; "
                         f"pass order={comp.order} with it")
    return comp


# ------------------------------------------------------------------------------------ splittings
@dataclass(frozen=True)
class Splitting:
    """A symmetric splitting method for ``H = T(Pi) + eps U(t, R)`` (``scheme="splitting"``).

    One step of size ``h`` alternates exact free-body flows (drifts) and kicks
    ``Pi += weights[i] h M(t_k + nodes[i] h, R)``: the kick ``i`` happens at the fraction
    ``nodes[i]`` of the step, and the drifts are the differences of consecutive nodes (with 0 and
    1 at the ends). ``order`` is the classical order; ``eps_orders = (s1, s2)`` says the error is
    ``O(eps h^s1 + eps^2 h^s2)`` (``docs/splitting.md`` derives the coefficients and the conditions).

    ``base="axes"``: the free body is not flowed exactly but split further into the three
    rotations about the principal axes (one sine and cosine each); stage ``i`` is the symmetric
    Strang step ``U T_a T_b T_c T_b T_a U`` of the length ``weights[i] h``, ending at the fraction
    ``nodes[i]`` of the step (its half kicks at its two ends), and ``eps_orders = (order, order)``:
    the error has no factor ``eps``.
    """

    name: str
    order: int
    eps_orders: tuple[int, int]
    nodes: tuple[float, ...]
    weights: tuple[float, ...]
    source: str
    base: str = "exact"

    @property
    def kicks(self) -> int:
        return len(self.weights)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``drift`` (s+1,), ``weight`` (s,), ``node`` (s,) as the kernels take them (fractions of ``h``;
        new arrays each call, computed once)."""
        drift, weight, node = self._arrays
        return drift.copy(), weight.copy(), node.copy()

    @cached_property
    def _arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        node = np.array(self.nodes, dtype=np.float64)
        drift = np.diff(np.concatenate([[0.0], node, [1.0]]))
        return drift, np.array(self.weights, dtype=np.float64), node


def _gauss(n: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Gauss-Legendre nodes on [0, 1] and weights (closed forms) for ``n = 1 .. 4``."""
    if n == 1:
        x, w = [0.0], [1.0]
    elif n == 2:
        r = math.sqrt(3.0) / 6.0
        x, w = [-r, r], [0.5, 0.5]
    elif n == 3:
        r = math.sqrt(15.0) / 10.0
        x, w = [-r, 0.0, r], [5.0 / 18.0, 4.0 / 9.0, 5.0 / 18.0]
    else:
        r1 = 0.5 * math.sqrt(3.0 / 7.0 + 2.0 / 7.0 * math.sqrt(6.0 / 5.0))
        r2 = 0.5 * math.sqrt(3.0 / 7.0 - 2.0 / 7.0 * math.sqrt(6.0 / 5.0))
        w1 = (18.0 - math.sqrt(30.0)) / 72.0
        w2 = (18.0 + math.sqrt(30.0)) / 72.0
        x, w = [-r1, -r2, r2, r1], [w1, w2, w2, w1]
    return tuple(0.5 + xi for xi in x), tuple(w)


def _splitting_triple_jump(base: "Splitting", name: str) -> "Splitting":
    """Yoshida's triple jump of a symmetric splitting of order 4: order 6, same ``s1``."""
    g1 = 1.0 / (2.0 - 2.0 ** (1.0 / 5.0))
    g0 = 1.0 - 2.0 * g1
    nodes: list[float] = []
    weights: list[float] = []
    start = 0.0
    for g in (g1, g0, g1):
        nodes += [start + g * c for c in base.nodes]
        weights += [g * b for b in base.weights]
        start += g
    return Splitting(name, 6, (base.eps_orders[0], 6), tuple(nodes), tuple(weights),
                     f"Yoshida's triple jump of {base.name} (g1 = 1/(2 - 2^(1/5)), g0 = 1 - 2 g1)")


# ABA with 5 kicks, order (8, 4): nodes 1/2 -+ x1, 1/2 -+ x2, 1/2 solving the quadrature conditions
# of order 8 and the eps^2 h^3 condition (docs/splitting.md); BAB with 5 kicks, order (6, 4).
_ABA84_NODES = (0.0753469602698928884165278, 0.5932638149581496707173018, 0.5, 0.4067361850418503292826982,
                0.9246530397301071115834722)
_ABA84_WEIGHTS = (0.1902259393736766192452308, 0.8465240704435262570550805, -1.073500019634405752600623,
                  0.8465240704435262570550805, 0.1902259393736766192452308)
_BAB64_NODES = (0.0, -0.0437514219173741137407351, 0.5, 1.043751421917374113740735, 1.0)
_BAB64_WEIGHTS = (0.5316386245813511790852625, -0.3086019704406066393237719, 0.5539266917185109204770189,
                  -0.3086019704406066393237719, 0.5316386245813511790852625)

_ABA84 = Splitting("aba84", 4, (8, 4), _ABA84_NODES, _ABA84_WEIGHTS,
                   "symmetric ABA, 5 kicks: Gauss-type quadrature of order 8 plus the eps^2 h^3 condition "
                   "(after McLachlan 1995, BIT 35, 258; derived in docs/splitting.md)")

def _axes(name: str, order: int, gammas: tuple[float, ...], source: str) -> "Splitting":
    """A symmetric composition ``S(g_1 h) ... S(g_s h)`` of the axis splitting's Strang step ``S``
    (``base="axes"``); ``nodes``: where each stage ends (its last half kick)."""
    nodes = tuple(float(c) for c in np.cumsum(gammas))
    return Splitting(name, order, (order, order), nodes, tuple(float(g) for g in gammas), source, base="axes")


# symmetric compositions of a symmetric method of order 2 (docs/splitting.md checks their orders):
# Suzuki's 5 stages (order 4), Kahan and Li's s9odr6a and s15odr8 (1997, Math. Comp. 66, 1089)
_SUZUKI5 = (1.0 / (4.0 - 4.0 ** (1.0 / 3.0)),) * 2
_SUZUKI5 = _SUZUKI5 + (1.0 - 4.0 * _SUZUKI5[0],) + _SUZUKI5
_KL9 = (0.39216144400731413927925056, 0.33259913678935943859974864, -0.70624617255763935980996482,
        0.08221359629355080023149045, 0.79854399093482996339895035)
_KL9 = _KL9 + _KL9[3::-1]
_KL15 = (0.74167036435061295344822780, -0.40910082580003159399730010, 0.19075471029623837995387626,
         -0.57386247111608226665638773, 0.29906418130365592384446354, 0.33462491824529818378495798,
         0.31529309239676659663205666, -0.79688793935291635401978884)
_KL15 = _KL15 + _KL15[6::-1]

#: Splitting methods by name (``simulate(..., scheme="splitting", composition=name)``).
SPLITTINGS: dict[str, Splitting] = {
    s.name: s for s in (
        Splitting("strang", 2, (2, 2), *_gauss(1), "Strang's ABA (leapfrog): drift h/2, kick h, drift h/2"),
        Splitting("saba2", 2, (4, 2), *_gauss(2),
                  "Laskar and Robutel (2001), Celest. Mech. Dyn. Astron. 80, 39: SABA_2, kicks at Gauss nodes"),
        Splitting("saba3", 2, (6, 2), *_gauss(3), "Laskar and Robutel (2001): SABA_3"),
        Splitting("saba4", 2, (8, 2), *_gauss(4), "Laskar and Robutel (2001): SABA_4"),
        Splitting("bab64", 4, (6, 4), _BAB64_NODES, _BAB64_WEIGHTS,
                  "symmetric BAB, 5 kicks (first and last at the step's ends): quadrature of order 6 plus "
                  "the eps^2 h^3 condition (after McLachlan 1995; derived in docs/splitting.md)"),
        _ABA84,
        _splitting_triple_jump(_ABA84, "aba84-tj6"),
        _axes("axes-strang", 2, (1.0,), "rotations about the principal axes and the kick: Strang's "
              "U T_a T_b T_c T_b T_a U (McLachlan 1993; Touma and Wisdom 1994)"),
        _axes("axes-suzuki4", 4, _SUZUKI5, "Suzuki's 5-stage composition (1990) of axes-strang"),
        _axes("axes-kl6", 6, _KL9, "Kahan and Li's s9odr6a (1997, Math. Comp. 66, 1089) of axes-strang"),
        _axes("axes-kl8", 8, _KL15, "Kahan and Li's s15odr8 (1997) of axes-strang"),
    )
}

#: Splitting used by ``scheme="splitting", order=p`` unless ``composition=`` names another.
DEFAULT_SPLITTING = {2: "saba3", 4: "aba84", 6: "aba84-tj6", 8: "axes-kl8"}


def splitting_for(order: Any, composition: Any) -> Splitting:
    """The validated splitting method of ``order=`` and ``composition=`` (``None``: the default one)."""
    sp = SPLITTINGS.get(composition) if type(composition) is str else None
    if sp is not None and type(order) is int and order == sp.order and order in DEFAULT_SPLITTING:
        return sp          # a registered name of that order: every check below passes
    from ._validation import choice

    orders = tuple(sorted(DEFAULT_SPLITTING))
    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)) or order not in orders:
        raise ValueError(f"order must be {', '.join(str(o) for o in orders[:-1])} or {orders[-1]} with "
                         f"scheme='splitting', got {order!r}")
    if composition is None:
        return SPLITTINGS[DEFAULT_SPLITTING[int(order)]]
    choice(composition, "composition", tuple(SPLITTINGS))
    sp = SPLITTINGS[composition]
    if sp.order != order:
        raise ValueError(f"composition {composition!r} is a splitting of order {sp.order}, but order={order}; "
                         f"pass order={sp.order} with it")
    return sp


#: ``scheme=`` of :func:`lgvi.simulate`: ``None`` (or ``"lgvi"``) the LGVI and its compositions;
#: ``"rkmk4"`` the gyrostat's explicit Runge-Kutta-Munthe-Kaas scheme (:mod:`lgvi.systems.gyrostat_rkmk`).
SCHEMES = ("lgvi", "splitting", "rkmk4")


def check_composable(comp: Composition, kind: str, forcing: str, model: Any) -> None:
    """Reject compositions whose base step is not symmetric (they would not raise the order)."""
    if comp.order == 2:
        return
    why = (f"order={comp.order} composes the symmetric step, and composition raises the order only of "
           f"a symmetric method")
    if kind == "array":
        raise ValueError(f"{why}; a torque array holds moments at the grid times only, but the substeps of "
                         f"order={comp.order} need them at intermediate times (some substeps even step "
                         "backwards). Pass a callable torque(t, R, Pi) or a torque model instead.")
    if forcing == "paper":
        if kind == "callable":
            raise ValueError(f"{why}; the paper's update Pi_(k+1) = F^T Pi_k + h u_k is first order and "
                             "not symmetric. Pass forcing='symmetric' to compose the callable torque.")
        if model is not None and not all(m.conservative for m in model.terms):
            bad = ", ".join(repr(m) for m in model.terms if not m.conservative)
            raise ValueError(f"{why}; the non-conservative part of the torque model ({bad}) uses the "
                             "paper's first-order update Pi_(k+1) = F^T Pi_k + h u_k, which is not symmetric. "
                             "Pass forcing='symmetric'.")


# ------------------------------------------------------------------------------------ torques
#: The kinds of ``torque=`` a run can be given.
TORQUE_KINDS = ("none", "model", "callable", "array")


_TorqueModel: Any = None    # lgvi.torques.TorqueModel, imported on first use (it is a layer above)


def torque_kind(torque: Any) -> str:
    """Classify ``torque=``, the one classification every entry point uses.

    Returns ``"none"`` (``None``), ``"model"`` (a :class:`lgvi.torques.TorqueModel`),
    ``"callable"`` (any other callable) or ``"array"`` (anything else: validated as moments by
    the entry points that take them). Each entry point then rejects the kinds it cannot run with
    its own message.
    """
    if torque is None:
        return "none"
    global _TorqueModel
    if _TorqueModel is None:
        from .torques import TorqueModel

        _TorqueModel = TorqueModel
    if isinstance(torque, _TorqueModel):
        return "model"
    if callable(torque):
        return "callable"
    return "array"


def __getattr__(name: str) -> Any:
    # the torque models register themselves on their class (lgvi.torques); read them lazily so
    # that this module stays importable below lgvi.torques
    if name == "TORQUE_MODELS":
        from .torques import TORQUE_MODELS

        return TORQUE_MODELS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["COMPOSITIONS", "Composition", "DEFAULT_COMPOSITION", "DEFAULT_METHOD", "DEFAULT_SPLITTING", "DEVICES",
           "DEVICE_DOCS", "FORCINGS",
           "FORCING_DOCS", "ORDERS", "SCHEMES", "SECOND_ORDER", "SOLVER_METHODS", "SPLITTINGS", "SolverMethod",
           "Splitting", "TORQUE_KINDS", "TORQUE_MODELS", "check_composable", "composition_for", "method_names",
           "splitting_for", "torque_kind"]
