"""A whole CubeSat ADCS mission from Python: the 6U of ``examples/cubesat_mission.toml``, three orbits
===================================================================================================

The same spacecraft and flight software as the scenario file (``lgvi example cubesat_mission``,
``lgvi run cubesat_mission.toml``), built from the classes, so each line says what it is:

* a 10 kg 6U (a 0.1 x 0.226 x 0.366 m box, centre of mass 5, -10, 10 mm off its centre, products
  of inertia of 0.4 to 1.2 g m^2), four pyramid wheels, three 0.4 A m^2 rods;
* a 500 km sun-synchronous orbit from a TLE (SGP4), noon-midnight at the March equinox (36 minutes
  of eclipse an orbit), IGRF-14, the Sun and the conical shadow, an exponential atmosphere;
* disturbances: the gravity gradient (variational), drag and radiation pressure on the six faces,
  a residual dipole of 0.02 A m^2;
* sensors: a gyro (ARW 5e-5 rad/s^0.5, RRW 5e-6 rad/s^1.5, a constant bias), a star tracker (6 and
  50 arcsec, sun and Earth-limb exclusions), a magnetometer, six coarse sun sensors;
* flight software at 2 Hz: an MEKF (gyro, star tracker, magnetometer); modes B-dot detumble (0),
  sun-safe (1: the +x face at the sun), Hill-frame nadir pointing with magnetic momentum dumping (2).

It prints the summary of ``lgvi run`` (detumble and settle times, control and knowledge errors,
wheel momentum, disturbance budget) and with ``--out DIR`` draws ``mission.png``,
``estimation.png``, ``disturbances.png`` and ``pointing.png``. ``--quick``: the first 7000 s (the
detumble, the sun-safe mode and the start of nadir pointing).

Usage::

    python examples/cubesat_mission.py [--out DIR] [--quick]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import lgvi
from lgvi.environment import IGRF, ExponentialAtmosphere, SGP4Orbit, Shadow, Sun
from lgvi.fsw import (MEKF, BDotControl, FlightSoftware, HillPointing, ModeRules, MomentumDumpingControl, MRPControl,
                      RWMotorTorque, SunPointing)
from lgvi.io.scenario_loop import loop_summary, summary_lines
from lgvi.spacecraft import (CoarseSunSensors, FacetDrag, FacetSRP, GravityGradient, Gyro, Magnetometer,
                             ResidualDipole, Spacecraft, StarTracker)

TLE = ("1 99999U 26001A   26079.00000000  .00000000  00000-0  00000-0 0  9998",
       "2 99999  97.4000   0.0000 0001000  90.0000 270.0000 15.21936487    13")
MASS, SIZE, COM = 10.0, np.array([0.1, 0.226, 0.366]), np.array([0.005, -0.01, 0.01])
H, RATE, DURATION = 0.1, 0.5, 17040.0                                  # [s]; three orbits of 5677 s


def inertia() -> np.ndarray:
    """The uniform box, rounded as the scenario file writes it, plus the products of inertia."""
    box = np.round(MASS / 12.0 * (SIZE @ SIZE - SIZE ** 2), 8)          # (b^2 + c^2, ...) m / 12
    return np.diag(box) + np.array([[0.0, 4e-4, -1.2e-3], [4e-4, 0.0, 8e-4], [-1.2e-3, 8e-4, 0.0]])


def faces() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Areas, normals and centres (from the centre of mass) of the six faces +x, -x, +y, -y, +z, -z."""
    normal = np.vstack([s * np.eye(3)[i] for i in range(3) for s in (1.0, -1.0)])
    area = np.round([np.prod(np.delete(SIZE, i)) for i in range(3) for _ in (1.0, -1.0)], 6)
    centre = np.round(normal * SIZE / 2.0 - COM, 6)
    return area, normal, centre


def mission() -> tuple[Spacecraft, FlightSoftware, np.ndarray, np.ndarray]:
    """The spacecraft, its flight software, the initial attitude and rate."""
    s = 1.0 / np.sqrt(3.0)
    wheels = lgvi.ReactionWheels([[s, s, s], [-s, s, s], [s, -s, s], [-s, -s, s]], 2e-5, max_torque=0.002)
    area, normal, centre = faces()
    st = StarTracker(rate=RATE, sigma_cross=3e-5, sigma_about=2.4e-4, sun_exclusion=0.52, earth_exclusion=0.35,
                     seed=1)
    sat = Spacecraft(
        inertia(), wheels=wheels, magnetorquers=lgvi.Magnetorquers(np.eye(3), 0.4), orbit=SGP4Orbit(*TLE),
        field=IGRF(), environment_rate=RATE, magnetorquer_rate=RATE,
        environment=[Sun(rate=RATE), Shadow(rate=RATE),
                     ExponentialAtmosphere.from_reference(500e3, 6.967e-13, 63822.0, rate=RATE)],
        disturbances=[GravityGradient(), FacetDrag(area, normal, centre, 2.2, rate=RATE),
                      FacetSRP(area, normal, centre, absorbed=0.6, specular=0.2, diffuse=0.2, rate=RATE),
                      ResidualDipole([0.015, -0.01, 0.008], rate=RATE)],
        sensors=[Gyro(rate=RATE, arw=5e-5, rrw=5e-6, bias=[2e-4, -1e-4, 5e-5], seed=1), st,
                 Magnetometer(rate=RATE, sigma=5e-8, seed=1),
                 CoarseSunSensors(normal, rate=RATE, sigma=0.01, seed=1)])
    R0 = _matrix([0.2, -0.5, 0.6, 0.5916079783099616])
    fsw = FlightSoftware(
        estimator=MEKF(rate=RATE, arw=5e-5, rrw=5e-6, star_tracker=True, mag_sigma=5e-8,
                       R0=_matrix([0.210613, -0.49143, 0.60175, 0.593326]), P0=[1e-3] * 3 + [1e-7] * 3),
        modes=ModeRules([(0, 1, "rate_below", 0.014), (1, 2, "dwell", 900.0)], initial=0,
                        names=["detumble", "sun-safe", "nadir"]),
        guidance=[SunPointing(axis=[1.0, 0.0, 0.0], secondary=[0.0, 0.0, 1.0], modes=[1]), HillPointing(modes=[2])],
        control=[BDotControl(1e5, derivative="rate", modes=[0]), MRPControl(K=0.004, P=0.04, modes=[1, 2]),
                 MomentumDumpingControl(5e-4, modes=[2])],
        actuators=RWMotorTorque(modes=[1, 2]), rate=RATE)
    return sat, fsw, R0, np.array([0.10076, -0.10076, 0.10076])          # |omega| = 10 deg/s


def _matrix(q_xyzw: list[float]) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q_xyzw).as_matrix()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    ap.add_argument("--out", type=Path, default=None, help="folder for the figures")
    ap.add_argument("--quick", action="store_true", help="the first 7000 s")
    args = ap.parse_args(argv)
    sat, fsw, R0, omega0 = mission()
    steps = int(round((7000.0 if args.quick else DURATION) / H))
    start = time.process_time()
    traj = lgvi.simulate(sat, R0, omega0=omega0, h=H, steps=steps, fsw=fsw, save_every=50)
    cpu = time.process_time() - start
    print(f"6U ADCS mission, {steps} steps of {H:g} s ({steps * H / 60:.0f} minutes) in {cpu:.2f} s of CPU "
          "(a first run in a process includes loading the compiled loop)")
    print("\n".join(summary_lines(loop_summary(traj))))
    if args.out is not None:
        from lgvi.plot import loop

        args.out.mkdir(parents=True, exist_ok=True)
        for name, fig in (("mission", loop.mission(traj)), ("estimation", loop.estimation(traj)),
                          ("disturbances", loop.disturbances(traj)), ("pointing", loop.pointing(traj))):
            fig.savefig(args.out / f"{name}.png", dpi=110)
            print(f"figure: {args.out / (name + '.png')}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
