"""Registries: the one source of truth for the names a run can choose.

Scenario files, the command line, the docs and the tests read these dictionaries; nothing else
re-declares them (see ``docs/architecture.md``):

* :data:`SOLVER_METHODS`: solvers of the implicit equation (name, kernel code, coordinates, cold
  start); :data:`lgvi.implicit.METHODS` is derived from it;
* :data:`FORCINGS`: treatments of the non-conservative moment;
* :data:`COMPOSITIONS` and :data:`DEFAULT_COMPOSITION`: symmetric compositions of the symmetric
  step (:data:`ORDERS` follows from them);
* :data:`TORQUE_MODELS`: the torque models by scenario key, each class registered by
  :class:`lgvi.torques.TorqueModel` itself when it is defined (``key = "..."``);
* :data:`lgvi.systems.SYSTEMS`: the dynamical systems the driver runs.

Importing this module loads no Numba.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

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
        end of each substep (``cum[0] = 0``, ``cum[s] = 1`` exactly), as the kernels take them."""
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


def torque_kind(torque: Any) -> str:
    """Classify ``torque=``, the one classification every entry point uses.

    Returns ``"none"`` (``None``), ``"model"`` (a :class:`lgvi.torques.TorqueModel`),
    ``"callable"`` (any other callable) or ``"array"`` (anything else: validated as moments by
    the entry points that take them). Each entry point then rejects the kinds it cannot run with
    its own message.
    """
    from .torques import TorqueModel

    if torque is None:
        return "none"
    if isinstance(torque, TorqueModel):
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


__all__ = ["COMPOSITIONS", "Composition", "DEFAULT_COMPOSITION", "DEFAULT_METHOD", "FORCINGS", "FORCING_DOCS",
           "ORDERS", "SECOND_ORDER", "SOLVER_METHODS", "SolverMethod", "TORQUE_KINDS", "TORQUE_MODELS",
           "check_composable", "composition_for", "method_names", "torque_kind"]
