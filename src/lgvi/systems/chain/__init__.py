"""Chains of spherical pendulums on ``(S^2)^n`` (``docs/two_spheres.md``): :func:`simulate_chain`."""

from .model import chain_equations, chain_parameters, momenta, velocities
from .run import ChainRun, ChainTrajectory, simulate_chain
from .system import CHAIN

__all__ = ["CHAIN", "ChainRun", "ChainTrajectory", "chain_equations", "chain_parameters", "momenta",
           "simulate_chain", "velocities"]
