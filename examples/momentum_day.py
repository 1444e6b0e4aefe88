"""A day of the 6U of ``momentum_budget.py`` in the compiled loop: wheel momentum and its dumping
==============================================================================================

The disturbances build wheel momentum; magnetic momentum dumping keeps it bounded.

The 6U of ``momentum_budget.py`` (its facets, optics, residual dipole and inertia; 500 km
sun-synchronous orbit, noon-midnight at the March equinox, from 2026-03-20 00:00 UTC) carries three
reaction wheels on its body axes (spin inertia 2e-5 kg m^2, 2 mN m, 10000 rpm: a 0.02 N m s CubeSat
wheel) and three 0.2 A m^2 magnetorquer rods. The flight software at 1 Hz: nadir pointing
(``NadirPointing``), ``MRPControl`` (K = 0.001 N m, P = 0.02 N m s) through ``RWMotorTorque``, and,
in the second run, ``MomentumDumpingControl`` (``m = k (h x B) / |B|^2``, k = 5e-3 1/s) on the rods.
Every disturbance acts in the loop: facet drag in NRLMSIS 2.1 (an exponential atmosphere if pymsis
is not installed), facet radiation pressure with the conical shadow, the residual dipole in the
IGRF-14 field (a centred dipole without ppigrf), and the gravity gradient; the step is the
gyrostat's LGVI with the disturbances forced symmetrically (``docs/environment.md``), h = 0.5 s.

Prints the momentum each disturbance adds over the day (the integral of its recorded torque in the
body frame, what the wheels must absorb while the body turns with the LVLH frame), and the wheel
momentum without and with dumping (largest and at the end), and the pointing error. ``--out DIR``
draws the wheel momentum of both runs and the disturbance torques (``momentum_day.png``).

Usage::

    python examples/momentum_day.py [--hours 24] [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import numpy as np

import lgvi
from lgvi.environment import (IGRF, CentredDipole, ExponentialAtmosphere, Shadow, Sun, TabulatedAtmosphere,
                              lvlh_frame)
from lgvi.fsw import FlightSoftware, MomentumDumpingControl, MRPControl, NadirPointing, RWMotorTorque
from lgvi.spacecraft import FacetDrag, FacetSRP, GravityGradient, ResidualDipole, Spacecraft
sys.path.insert(0, str(Path(globals().get("__file__", "momentum_day.py")).resolve().parent))   # the docs' gallery: no __file__
from momentum_budget import DIPOLE, EPOCH, MU, ORBIT, J, six_u  # noqa: E402  (the 6U of the one-orbit budget)

H = 0.5
SAVE = 60.0
K_DUMP = 5e-3                                             # 1/s
RPM = 2.0 * np.pi / 60.0
SOURCES = {"tau_facet_drag_B": "aerodynamic drag", "tau_facet_srp_B": "solar radiation pressure",
           "tau_residual_dipole_B": "residual dipole", "tau_gravity_gradient_B": "gravity gradient"}


def spacecraft(duration: float, rods: bool):
    area, normal, centre, absorbed, specular, diffuse = six_u()
    field = IGRF() if importlib.util.find_spec("ppigrf") else CentredDipole()
    if importlib.util.find_spec("pymsis"):
        air = TabulatedAtmosphere.from_msis(ORBIT, EPOCH, duration + 60.0, dt=20.0)
        where = "NRLMSIS 2.1 (pymsis), F10.7 = 150, Ap = 4"
    else:
        air = ExponentialAtmosphere.from_reference(500e3, 6.967e-13, 63822.0)
        where = "exponential through 6.967e-13 kg/m^3 at 500 km (pymsis not installed)"
    wheels = lgvi.ReactionWheels(np.eye(3), 2e-5, speed0=np.zeros(3), max_torque=2e-3, max_speed=10000.0 * RPM)
    sc = Spacecraft(J, wheels=wheels, magnetorquers=lgvi.Magnetorquers(np.eye(3), 0.2) if rods else None, orbit=ORBIT,
                    field=field,
                    epoch=EPOCH, magnetorquer_rate=1.0,
                    environment=[Sun(), Shadow("conical"), air],
                    disturbances=[FacetDrag(area, normal, centre, 2.2),
                                  FacetSRP(area, normal, centre, absorbed=absorbed, specular=specular,
                                           diffuse=diffuse),
                                  ResidualDipole(DIPOLE), GravityGradient(mu=MU)])
    return sc, f"density: {where}; field: {field.name}"


def fsw(dumping: bool) -> FlightSoftware:
    control = [MRPControl(K=0.001, P=0.02)] + ([MomentumDumpingControl(K_DUMP)] if dumping else [])
    return FlightSoftware(guidance=NadirPointing(), control=control, actuators=RWMotorTorque(), rate=1.0,
                          record_rate="grid")      # the tables and the figure read the record grid (every 60 s)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--quick", action="store_true", help="three hours")
    ap.add_argument("--out", type=Path, default=None, help="folder for momentum_day.png")
    args = ap.parse_args(argv)
    hours = 3.0 if args.quick else args.hours
    steps = int(round(hours * 3600.0 / H))
    every = int(round(SAVE / H))
    ships = {dumping: spacecraft(steps * H, rods=dumping) for dumping in (False, True)}
    what = ships[True][1]
    r0, v0 = (np.asarray(x, dtype=float).reshape(3) for x in ORBIT.position_velocity(np.array([0.0])))
    R0 = lvlh_frame(r0[None], v0[None])[0]                    # on the LVLH frame, turning with it
    omega0 = R0.T @ (np.cross(r0, v0) / np.dot(r0, r0))
    runs = {dumping: lgvi.simulate(ships[dumping][0], R0, omega0=omega0, h=H, steps=steps, fsw=fsw(dumping), save_every=every)
            for dumping in (False, True)}
    t = runs[True].t[:-1]
    print(f"6U, nadir pointing, {hours:g} h from {EPOCH:%Y-%m-%d %H:%M} UTC, h = {H} s; {what}")
    print(f"{'source':<26}{'rms |tau| N m':>15}{'momentum N m s':>16}")
    sig = runs[True].signals
    for name, label in SOURCES.items():
        tau = sig[name]
        added = np.linalg.norm(np.trapezoid(tau, t, axis=0))
        print(f"{label:<26}{np.sqrt(np.mean(np.sum(tau ** 2, axis=1))):>15.3e}{added:>16.3e}")
    print(f"{'wheel momentum N m s':<26}{'largest':>12}{'end':>12}{'pointing deg (after 10 min)':>30}")
    for dumping, tr in runs.items():
        hw = np.linalg.norm(tr.wheel_momentum, axis=1)
        s = tr.signals["sigma_BR"]
        err = np.degrees(4.0 * np.arctan(np.linalg.norm(s, axis=1)))[t >= 600.0]
        label = "with dumping" if dumping else "without dumping"
        print(f"{label:<26}{hw.max():>12.3e}{hw[-1]:>12.3e}{err.max():>30.3f}")
    if args.out is not None:
        import matplotlib.pyplot as plt

        args.out.mkdir(parents=True, exist_ok=True)
        fig, (a0, a1) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True)
        for dumping, tr in runs.items():
            a0.plot(tr.t / 3600.0, np.linalg.norm(tr.wheel_momentum, axis=1) * 1e3,
                    label="with magnetic dumping" if dumping else "without dumping")
        a0.set_ylabel("|wheel momentum| [mN m s]")
        a0.legend(loc="upper left")
        a0.grid(True, alpha=0.3)
        for name, label in SOURCES.items():
            a1.semilogy(t / 3600.0, np.linalg.norm(sig[name], axis=1), label=label, lw=0.8)
        a1.set_xlabel("time since epoch [h]")
        a1.set_ylabel("|torque| [N m]")
        a1.legend(loc="lower right", fontsize=8)
        a1.grid(True, which="both", alpha=0.3)
        a0.set_title(f"6U in a 500 km sun-synchronous orbit, nadir pointing: wheel momentum over {hours:g} h")
        fig.tight_layout()
        fig.savefig(args.out / "momentum_day.png", dpi=120)
        print(f"figure: {args.out / 'momentum_day.png'}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
