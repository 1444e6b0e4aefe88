"""A 90 degree slew with four reaction wheels in a pyramid, torque-limited, under MRP feedback
===========================================================================================

The spacecraft (wheels locked: J = diag(900, 800, 600) kg m^2) starts at rest at the identity
with four wheels (Js = 0.08 kg m^2, 0.2 N m, 6000 rpm, Coulomb and viscous friction) spinning at
1000 rpm; its flight software (``lgvi.FlightSoftware``: an inertial target, ``MRPControl`` with
K = 20 N m, P = 200 N m s, Basilisk's mrpFeedback law, and ``RWMotorTorque``, Basilisk's
rwMotorTorque) every 0.1 s slews it 90 degrees about (1, 1, 0)/sqrt(2).
The wheels saturate at 0.2 N m for the first tens of seconds. Prints the time to settle within
0.01 degree, the largest wheel torque and the drift of the total angular momentum (hub plus
wheels: exact, the wheels only exchange momentum with the hub); the figure shows the pointing
error, the wheel speeds and the wheel torques.

Usage::

    python examples/wheel_slew.py [--quick] [--out DIR] [--no-plots]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import lgvi
from lgvi.fsw import FlightSoftware, InertialPointing, MRPControl, RWMotorTorque

J = np.diag([900.0, 800.0, 600.0])                  # [kg m^2], wheels locked
RPM = 2.0 * np.pi / 60.0
_b = 1.0 / np.sqrt(3.0)
AXES = np.array([[_b, _b, _b], [-_b, _b, _b], [-_b, -_b, _b], [_b, -_b, _b]])
WHEELS = lgvi.ReactionWheels(AXES, 0.08, speed0=1000.0 * RPM, max_torque=0.2, max_speed=6000.0 * RPM,
                             friction={"coulomb": 1e-4, "viscous": 1e-6})
TARGET = lgvi.so3.exp(np.radians(90.0) * np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0))
H = 0.1                                             # [s], also the control period


def pointing_error_deg(traj) -> np.ndarray:
    """Angle of ``R_target^T R`` at every sample, degrees."""
    return np.degrees(np.linalg.norm(lgvi.so3.log(TARGET.T @ traj.R), axis=-1))


def figure(traj):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 7), dpi=100, layout="constrained")
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
    ax1.semilogy(traj.t, np.maximum(pointing_error_deg(traj), 1e-8), color="tab:purple")
    ax1.axhline(0.01, color="0.5", ls=":", lw=1, label="0.01 deg")
    ax1.set_ylabel("pointing error (deg)")
    ax1.set_title("90 deg slew with 4 wheels (0.2 N m): error, wheel speeds, wheel torques")
    ax1.legend(loc="upper right")
    for i in range(len(AXES)):
        ax2.plot(traj.t, traj.wheel_speed[:, i] / RPM, label=f"wheel {i + 1}")
        ax3.plot(traj.t, traj.wheel_torque[:, i], label=f"wheel {i + 1}")
    ax2.set_ylabel("wheel speed (rpm)")
    ax3.set_ylabel("motor torque (N m)")
    ax3.set_xlabel("time $t$ (s)")
    ax2.legend(loc="upper right", ncols=4, fontsize="small")
    for ax in (ax1, ax2, ax3):
        ax.grid(True, alpha=0.3)
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--quick", action="store_true", help="accepted for uniformity (the run takes milliseconds)")
    parser.add_argument("--out", default="output/wheel_slew", help="folder for the figure")
    parser.add_argument("--no-plots", action="store_true")
    args = parser.parse_args(argv)
    T = 600.0
    fsw = FlightSoftware(guidance=InertialPointing(TARGET), control=MRPControl(K=20.0, P=200.0),
                         actuators=RWMotorTorque(), rate=H)
    traj = lgvi.simulate(lgvi.Spacecraft(J, wheels=WHEELS), np.eye(3), omega0=np.zeros(3), h=H,
                         steps=int(round(T / H)), fsw=fsw)
    err = pointing_error_deg(traj)
    outside = np.flatnonzero(err > 0.01)
    settle = traj.t[outside[-1] + 1] if len(outside) and outside[-1] + 1 < len(err) else float("nan")
    L = traj.spatial_momentum
    print(f"settled within 0.01 deg at t = {settle:.1f} s; final error {err[-1]:.2e} deg")
    print(f"largest wheel torque {np.abs(traj.wheel_torque).max():.3f} N m (limit 0.2); "
          f"wheel speeds {np.round(traj.wheel_speed[-1] / RPM, 1).tolist()} rpm")
    print(f"total angular momentum drift {np.abs(L - L[0]).max() / np.linalg.norm(L[0]):.1e} (relative)")
    if not args.no_plots:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        figure(traj).savefig(out / "wheel_slew.png")
        print(f"figure: {out / 'wheel_slew.png'}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
