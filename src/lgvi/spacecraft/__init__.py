"""What is bolted on the spacecraft: actuators, sensors and disturbance models, as components of
the compiled loop (:mod:`lgvi.components`)."""

from .sensors import CoarseSunSensors, FineSunSensor, Gyro, Magnetometer, StarTracker

__all__ = ["Gyro", "StarTracker", "Magnetometer", "CoarseSunSensors", "FineSunSensor"]
