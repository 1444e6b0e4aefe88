"""A spacecraft attitude slew with the geometric PD controller of lgvi.torques.AttitudePD
======================================================================================

J = diag(100, 120, 80) kg m^2, from rest at the identity to the attitude with ZYX Euler angles
(60, 30, -20) deg; e_R = vee(R_d^T R - R^T R_d) / 2, u = -kp e_R - kd Omega with kp = 20 N m,
kd = 80 N m s; h = 0.05 s, symmetric forcing (second order). Prints the settling time and the
final pointing error; the figure shows the angle to the target and the control torque.

Usage::

    python examples/slew_pd.py [--steps 3000] [--quick] [--out DIR] [--no-plots]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.torques import AttitudePD

J = (100.0, 120.0, 80.0)                                                  # [kg m^2]
TARGET = Rotation.from_euler("ZYX", [60.0, 30.0, -20.0], degrees=True)   # R_d
CONTROLLER = AttitudePD(kp=20.0, kd=80.0, R_target=TARGET)
H = 0.05                                                                  # [s]


def angle_to_target(traj: lgvi.Trajectory) -> np.ndarray:
    """Rotation angle of ``R_d^T R`` (deg) at every sample."""
    return np.degrees((TARGET.inv() * traj.rotation).magnitude())


def slew_figure(traj: lgvi.Trajectory, body: lgvi.RigidBody):
    from matplotlib.figure import Figure

    u = CONTROLLER.moment(traj.t, traj.R, traj.Pi, body)
    fig = Figure(figsize=(8, 5), dpi=100, layout="constrained")
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.semilogy(traj.t, np.maximum(angle_to_target(traj), 1e-12), color="tab:purple")
    ax1.axhline(1.0, color="0.5", ls=":", lw=1, label="1 deg")
    ax1.set_ylabel("angle to target (deg)")
    ax1.set_title("PD slew to ZYX (60, 30, -20) deg: pointing error and control torque")
    ax1.legend(loc="upper right")
    for i, c in enumerate(("tab:red", "tab:green", "tab:blue")):
        ax2.plot(traj.t, u[:, i], color=c, label=f"$u_{i + 1}$")
    ax2.set_ylabel("body torque $u$ (N m)")
    ax2.set_xlabel("time $t$ (s)")
    ax2.legend(loc="upper right", ncols=3)
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--steps", type=int, default=3000, help="number of steps (default 3000, 150 s)")
    parser.add_argument("--quick", action="store_true", help="short run (600 steps, 30 s)")
    parser.add_argument("--out", default="output/slew_pd", help="folder for the figures")
    parser.add_argument("--no-plots", action="store_true", help="skip the figures")
    args = parser.parse_args(argv)
    steps = 600 if args.quick else args.steps

    body = lgvi.RigidBody(J)
    traj = lgvi.simulate(body, np.eye(3), omega0=[0.0, 0.0, 0.0], h=H, steps=steps, torque=CONTROLLER,
                         forcing="symmetric")
    err = angle_to_target(traj)
    above = np.nonzero(err > 1.0)[0]
    settled = traj.t[above[-1] + 1] if len(above) and above[-1] + 1 < len(err) else None
    u = CONTROLLER.moment(traj.t, traj.R, traj.Pi, body)
    print(f"PD slew: J = diag{J} kg m^2, {CONTROLLER!r}, h = {H} s, {steps} steps ({steps * H:g} s)")
    print(f"  initial angle to target {err[0]:.2f} deg, final {err[-1]:.2e} deg")
    print("  within 1 deg from t = " + (f"{settled:.1f} s" if settled is not None else "(not reached)"))
    print(f"  peak torque {np.max(np.linalg.norm(u, axis=1)):.2f} N m; "
          f"final rate {np.linalg.norm(traj.omega[-1]):.2e} rad/s")
    if not args.no_plots:
        from lgvi import plot

        out = Path(args.out)
        files = plot.save_figures(traj, out, prefix="slew_pd_")
        plot.conservation(traj, invariants=()).savefig(out / "slew_pd_conservation.png")  # all dissipated
        files.append(out / "slew_pd_error.png")
        slew_figure(traj, body).savefig(files[-1], dpi=100)
        print("  figures: " + ", ".join(str(f) for f in files))
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
