"""The spacecraft's environment: geomagnetic field models, orbits and the environment they drive.

* :mod:`lgvi.environment.field`: centred dipole, IGRF-14, WMM (compiled spherical harmonics);
* :mod:`lgvi.environment.orbits`: circular, Kepler, J2-secular and SGP4 orbits, LVLH helpers,
  :class:`OrbitEnvironment` (what a controller reads: position, velocity, inertial field);
* :mod:`lgvi.environment.gravity`: the gravity-gradient moment along any of these orbits,
  compiled (:class:`OrbitGravityGradient`);
* :mod:`lgvi.environment.actuators`: magnetorquer rods (:class:`lgvi.Magnetorquers`);
* :mod:`lgvi.environment.bdot`: B-dot detumbling and magnetic momentum dumping;
* :mod:`lgvi.environment.clock`: one clock (UTC epoch, TT, decimal years, GMST) for all of them;
* :mod:`lgvi.environment.sun`: the sun and the Earth's shadow, components of the compiled loop;
* :mod:`lgvi.environment.atmosphere`: exponential and tabulated (NRLMSIS) atmospheres, components.
"""

from __future__ import annotations

from .actuators import Magnetorquers
from .bdot import BDot, MomentumDumping
from .field import (CentredDipole, IGRF, WMM, SphericalHarmonicField, decimal_year, geodetic_to_ecef,
                    ned_frame)
from .gravity import OrbitGravityGradient
from .atmosphere import ExponentialAtmosphere, TabulatedAtmosphere, ecef_to_geodetic
from .clock import Clock
from .orbits import (CircularOrbit, J2Orbit, KeplerOrbit, Orbit, OrbitEnvironment, SGP4Orbit, gmst, lvlh_frame,
                     nadir_reference, solve_kepler)
from .sun import Shadow, Sun, shadow_fraction, sun_position

__all__ = ["CentredDipole", "IGRF", "WMM", "SphericalHarmonicField", "decimal_year", "geodetic_to_ecef",
           "ned_frame", "CircularOrbit", "J2Orbit", "KeplerOrbit", "Orbit", "OrbitEnvironment", "SGP4Orbit",
           "gmst", "lvlh_frame", "nadir_reference", "solve_kepler", "OrbitGravityGradient", "Magnetorquers",
           "BDot", "MomentumDumping", "Clock", "Sun", "Shadow", "sun_position", "shadow_fraction",
           "ExponentialAtmosphere", "TabulatedAtmosphere", "ecef_to_geodetic"]
