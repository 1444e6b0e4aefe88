"""What is bolted on the spacecraft: actuators, sensors and disturbance models, as components of
the compiled loop (:mod:`lgvi.components`)."""
