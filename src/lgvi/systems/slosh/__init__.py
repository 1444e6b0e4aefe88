"""A rigid hub with spherical slosh pendulums on ``SO(3) x (S^2)^n`` (``docs/slosh.md``): :func:`simulate_slosh`."""

from .model import kinetic_energy, momenta, newton_euler, newton_euler_split, newton_euler_state, slosh_parameters, velocities
from .run import SloshRun, SloshTrajectory, simulate_slosh
from .system import SLOSH

__all__ = ["SLOSH", "SloshRun", "SloshTrajectory", "kinetic_energy", "momenta", "newton_euler", "newton_euler_split",
           "newton_euler_state", "simulate_slosh", "slosh_parameters", "velocities"]
