"""lgvi: Lie group variational integrator for rigid-body attitude dynamics on SO(3).

Public names (everything else is private):

- :class:`RigidBody`, :func:`inertia_to_jd`, :func:`jd_to_inertia`
- :func:`simulate`, :func:`step`, :class:`Trajectory`, :func:`load`
- :func:`solve_implicit`, :class:`ImplicitSolution`
- :class:`ConvergenceError`, :class:`CollisionError`, :class:`TorqueError`, :class:`SimulationInterrupted`, :class:`AccuracyWarning`,
  :class:`AttitudeWarning`
- modules :mod:`lgvi.optimal` (optimal control and adjoint gradients), :mod:`lgvi.so3`, :mod:`lgvi.torques`, :mod:`lgvi.reference`, :mod:`lgvi.baselines`, :mod:`lgvi.exact`,
  :mod:`lgvi.accuracy` (the error estimate of ``simulate(..., error_estimate=True)``)

Layout: the core at the top level (with :mod:`lgvi.systems` and the compiled :mod:`lgvi._kernels`),
input/output in :mod:`lgvi.io`, :mod:`lgvi.cli`, :mod:`lgvi.plot`, and :mod:`lgvi.verification`
(``reference``, ``exact``, ``baselines``). The old names of the modules that moved
(``lgvi.streaming``, ``lgvi.exact``, ...) are the same module objects (:mod:`lgvi._aliases`).

Importing lgvi compiles nothing: kernels are compiled (or loaded from Numba's cache) on first use.
Numba itself is imported here (about 0.3 s) so that the first simulation does not pay for it.
"""

import sys as _sys

from . import _aliases  # noqa: F401  (installs the old names of moved modules: lgvi.exact, ...)
from . import _jit  # noqa: F401  (imports Numba now; compiles nothing)
from . import control as control
from . import optimal as optimal
from . import so3 as so3
from . import torques as torques
from ._version import __version__ as __version__
from .body import RigidBody as RigidBody
from .body import inertia_to_jd as inertia_to_jd
from .body import jd_to_inertia as jd_to_inertia
from .ensemble import EnsembleTrajectory as EnsembleTrajectory
from .ensemble import load_ensemble as load_ensemble
from .ensemble import simulate_ensemble as simulate_ensemble
from . import gpu as gpu  # provides simulate_ensemble(device="cuda"); imports no numba.cuda
from . import environment as environment
from .environment import Magnetorquers as Magnetorquers
from .errors import AccuracyWarning as AccuracyWarning
from .errors import AttitudeWarning as AttitudeWarning
from .errors import CollisionError as CollisionError
from .errors import ComponentError as ComponentError
from .errors import ConvergenceError as ConvergenceError
from .errors import SimulationInterrupted as SimulationInterrupted
from .errors import TorqueError as TorqueError
from .implicit import ImplicitSolution as ImplicitSolution
from .implicit import solve_implicit as solve_implicit
from .integrator import StepResult as StepResult
from .integrator import simulate as simulate
from .integrator import step as step
from .modified import simulate_modified as simulate_modified
from . import splitting as splitting  # provides the run of scheme="splitting" (lgvi.systems.provide_run)
from .system_ensembles import SystemEnsemble as SystemEnsemble
from .system_ensembles import simulate_members as simulate_members
from .io import streaming as streaming  # the old name lgvi.streaming (imported here anyway)
from .io.streaming import simulate_stream as simulate_stream
from . import fsw as fsw
from . import spacecraft as spacecraft
from .fsw import FlightSoftware as FlightSoftware
from .spacecraft import Spacecraft as Spacecraft
from .systems import spacecraft as _spacecraft_system  # noqa: F401  (registers the system "spacecraft")
from .systems.orbit import OrbitTrajectory as OrbitTrajectory
from .systems.orbit import simulate_orbit as simulate_orbit
from .systems.two_body import Ellipsoid as Ellipsoid
from .systems.two_body import PointMasses as PointMasses
from .systems.two_body import Polyhedron as Polyhedron
from .systems.two_body import TwoBodyTrajectory as TwoBodyTrajectory
from .systems.two_body import simulate_two_body as simulate_two_body
from .systems.chain import ChainTrajectory as ChainTrajectory
from .systems.chain import simulate_chain as simulate_chain
from .systems.slosh import SloshTrajectory as SloshTrajectory
from .systems.slosh import simulate_slosh as simulate_slosh
from .systems.gyrostat import ReactionWheels as ReactionWheels
from .trajectory import Trajectory as Trajectory
from .trajectory import load as load
from . import view as _view  # noqa: F401  (Jupyter's display of a Trajectory; plotly imported when used)

_sys.modules.setdefault("lgvi.streaming", streaming)

__all__ = [
    "AccuracyWarning",
    "AttitudeWarning",
    "ChainTrajectory",
    "SloshTrajectory",
    "CollisionError",
    "ComponentError",
    "ConvergenceError",
    "Ellipsoid",
    "EnsembleTrajectory",
    "FlightSoftware",
    "ImplicitSolution",
    "Magnetorquers",
    "OrbitTrajectory",
    "PointMasses",
    "Polyhedron",
    "ReactionWheels",
    "RigidBody",
    "SimulationInterrupted",
    "Spacecraft",
    "StepResult",
    "SystemEnsemble",
    "TorqueError",
    "Trajectory",
    "TwoBodyTrajectory",
    "__version__",
    "control",
    "environment",
    "gpu",
    "fsw",
    "inertia_to_jd",
    "jd_to_inertia",
    "load",
    "load_ensemble",
    "optimal",
    "simulate",
    "simulate_chain",
    "simulate_slosh",
    "simulate_ensemble",
    "simulate_members",
    "simulate_modified",
    "simulate_orbit",
    "simulate_stream",
    "simulate_two_body",
    "so3",
    "spacecraft",
    "solve_implicit",
    "step",
    "torques",
]
