"""A short run of the compiled loop for the page's tests (tests/test_view.py, tests/test_view_browser.py):
a 6U on a 500 km polar orbit from the March equinox (an eclipse in its 6000 s), the sun and the
conical shadow recorded, four wheels, and two named modes: "coast" (no control) for 1500 s, then
"nadir" (Hill pointing with MRP feedback on the wheels)."""

from __future__ import annotations

import datetime as dt

import numpy as np

import lgvi


def orbit_run():
    from lgvi.environment import CircularOrbit, Shadow, Sun
    from lgvi.fsw import FlightSoftware, HillPointing, ModeRules, MRPControl, RWMotorTorque
    from lgvi.spacecraft import Spacecraft

    axes = np.array([[1, 1, 1], [-1, 1, 1], [1, -1, 1], [-1, -1, 1]]) / np.sqrt(3.0)
    sat = Spacecraft([0.15, 0.12, 0.05], wheels=lgvi.ReactionWheels(axes, 2e-5, max_torque=2e-3),
                     orbit=CircularOrbit(6878137.0, np.radians(97.4)), epoch=dt.datetime(2026, 3, 20),
                     environment=[Sun(), Shadow("conical")])
    fsw = FlightSoftware(guidance=HillPointing(modes=[1]), control=MRPControl(K=0.004, P=0.04, modes=[1]),
                         actuators=RWMotorTorque(modes=[1]),
                         modes=ModeRules([(0, 1, "time_after", 1500.0)], names=["coast", "nadir"]), rate=1.0)
    return lgvi.simulate(sat, np.eye(3), omega0=[0.0, 0.01, 0.0], h=0.5, steps=12000, fsw=fsw, save_every=20)
