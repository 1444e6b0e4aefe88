"""What is bolted on the spacecraft: actuators, sensors and disturbance models, as components of
the compiled loop (:mod:`lgvi.components`)."""

from .disturbances import FacetDrag, FacetSRP, ResidualDipole
from .sensors import CoarseSunSensors, FineSunSensor, Gyro, Magnetometer, StarTracker

__all__ = ["FacetDrag", "FacetSRP", "ResidualDipole", "Gyro", "StarTracker", "Magnetometer", "CoarseSunSensors",
           "FineSunSensor"]
