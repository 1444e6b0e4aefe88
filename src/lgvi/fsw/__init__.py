"""What runs on board: estimation, guidance, control and mode rules, as components of the compiled
loop (:mod:`lgvi.components`)."""

from .estimation import MEKF, davenport, triad

__all__ = ["MEKF", "davenport", "triad"]
