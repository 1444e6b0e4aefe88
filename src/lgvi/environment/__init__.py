"""The spacecraft's environment: geomagnetic field models, orbits and the environment they drive.

* :mod:`lgvi.environment.field`: centred dipole, IGRF-14, WMM (compiled spherical harmonics);
* :mod:`lgvi.environment.orbits`: circular, Kepler, J2-secular and SGP4 orbits, LVLH helpers,
  :class:`OrbitEnvironment` (what a controller reads: position, velocity, inertial field);
* :mod:`lgvi.environment.actuators`: magnetorquer rods;
* :mod:`lgvi.environment.bdot`: B-dot detumbling and magnetic momentum dumping.
"""

from __future__ import annotations

from .field import (CentredDipole, IGRF, WMM, SphericalHarmonicField, decimal_year, geodetic_to_ecef,
                    ned_frame)

__all__ = ["CentredDipole", "IGRF", "WMM", "SphericalHarmonicField", "decimal_year", "geodetic_to_ecef",
           "ned_frame"]
