"""Gravity-gradient libration of a satellite on a circular orbit (pitch oscillation)
=================================================================================

J = diag(100, 120, 80) kg m^2 on a circular orbit of radius 6778 km (n = sqrt(mu / r^3),
period 5553 s), axes as in lgvi.torques.GravityGradient: body 1 along the orbital velocity,
2 against the orbit normal, 3 to nadir. Started 5 deg off in pitch and turning with the orbit,
the body librates about the local vertical with the small-angle frequency
sqrt(3 n^2 (J1 - J3) / J2); h = 10 s, symmetric (variational) scheme. Prints the measured and
predicted libration periods and the energy error (the potential turns with the orbit, so the
conserved quantity is the Jacobi integral, not E; the script reports both).

Usage::

    python examples/gravity_gradient.py [--steps 2000] [--quick] [--out DIR] [--no-plots]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.torques import GravityGradient

J = (100.0, 120.0, 80.0)                          # [kg m^2]
MODEL = GravityGradient(mu=3.986004418e14, radius=6778.0e3)
N = MODEL.mean_motion                             # orbital rate [rad/s]
PITCH0_DEG = 5.0
H = 10.0                                          # [s]


def lvlh(t: np.ndarray) -> np.ndarray:
    """Orbit-pointing attitude ``[v_hat, -e3, -r_hat]`` (columns) at times ``t``, shape (M, 3, 3)."""
    nt = N * np.asarray(t)
    v = np.stack([-np.sin(nt), np.cos(nt), 0 * nt], axis=-1)
    r = np.stack([np.cos(nt), np.sin(nt), 0 * nt], axis=-1)
    minus_e3 = np.broadcast_to([0.0, 0.0, -1.0], v.shape)
    return np.stack([v, minus_e3, -r], axis=-1)


def pitch(traj: lgvi.Trajectory) -> np.ndarray:
    """Libration angle about body axis 2 relative to the orbit-pointing attitude (rad)."""
    rel = np.einsum("mji,mjk->mik", lvlh(traj.t), traj.R)   # R_lvlh^T R
    return Rotation.from_matrix(rel).as_rotvec()[:, 1]


def jacobi_integral(traj: lgvi.Trajectory) -> np.ndarray:
    """``E - n e3 . R Pi``: conserved for a potential turning at rate n about e3."""
    return traj.energy - N * traj.spatial_momentum[:, 2]


def run(steps: int) -> lgvi.Trajectory:
    """Start 5 deg off in pitch, turning with the orbit, and integrate ``steps`` steps."""
    R0 = lvlh(np.zeros(1))[0] @ Rotation.from_rotvec([0.0, np.radians(PITCH0_DEG), 0.0]).as_matrix()
    return lgvi.simulate(lgvi.RigidBody(J), R0, omega0=[0.0, -N, 0.0], h=H, steps=steps, torque=MODEL,
                         forcing="symmetric")


def predicted_period() -> float:
    """Small-angle pitch libration period ``2 pi / (n sqrt(3 (J1 - J3) / J2))`` (s)."""
    return 2 * np.pi / (N * np.sqrt(3 * (J[0] - J[2]) / J[1]))


def pitch_figure(traj: lgvi.Trajectory):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 5), dpi=100, layout="constrained")
    ax = fig.add_subplot()
    ax.plot(traj.t, np.degrees(pitch(traj)), label="lgvi")
    ax.plot(traj.t, PITCH0_DEG * np.cos(2 * np.pi * traj.t / predicted_period()), "--", lw=1,
            label="small-angle theory")
    ax.set_xlabel("time $t$ (s)")
    ax.set_ylabel("pitch relative to the local vertical (deg)")
    ax.set_title("Gravity-gradient pitch libration")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncols=2, frameon=False)   # below, off the curves
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--steps", type=int, default=2000, help="number of steps (default 2000, 3.6 orbits)")
    parser.add_argument("--quick", action="store_true", help="short run (1000 steps)")
    parser.add_argument("--out", default="output/gravity_gradient", help="folder for the figures")
    parser.add_argument("--no-plots", action="store_true", help="skip the figures")
    args = parser.parse_args(argv)
    steps = 1000 if args.quick else args.steps

    traj = run(steps)
    theta = pitch(traj)
    up = np.nonzero((theta[:-1] < 0) & (theta[1:] >= 0))[0]       # upward zero crossings
    t_up = traj.t[up] - theta[up] * H / (theta[up + 1] - theta[up])  # linear interpolation
    predicted = predicted_period()
    E, C = traj.energy, jacobi_integral(traj)
    print(f"Gravity gradient: J = diag{J} kg m^2, {MODEL!r}, orbit period {2 * np.pi / N:.0f} s, "
          f"h = {H:g} s, {steps} steps ({steps * H:g} s)")
    print(f"  pitch libration amplitude {np.degrees(np.max(np.abs(theta))):.3f} deg")
    measured = f"{np.mean(np.diff(t_up)):.0f} s" if len(t_up) >= 2 else "(run too short to measure)"
    print(f"  libration period: measured {measured}, small-angle prediction {predicted:.0f} s")
    print(f"  max relative change: energy E {np.max(np.abs(E - E[0])) / abs(E[0]):.1e} (not an invariant: "
          f"the field turns), Jacobi integral E - n e3.R Pi {np.max(np.abs(C - C[0])) / abs(C[0]):.1e}")
    if not args.no_plots:
        from lgvi import plot

        out = Path(args.out)
        # the conservation figure shows this problem's invariant, the Jacobi integral (lgvi.invariants)
        files = plot.save_figures(traj, out, prefix="gravity_gradient_")
        files.append(out / "gravity_gradient_pitch.png")
        pitch_figure(traj).savefig(files[-1], dpi=100)
        print("  figures: " + ", ".join(str(f) for f in files))
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
