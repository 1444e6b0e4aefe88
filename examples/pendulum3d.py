"""Lee, Leok and McClamroch's 3D pendulum: a rigid body on a frictionless pivot under gravity
==========================================================================================

J = diag(0.13, 0.28, 0.17) kg m^2 about the pivot, mass 1 kg, centre of mass 0.3 m from the pivot
along body axis 3, R0 = I, Omega0 = 4.14 (1, 1, 1) rad/s: chaotic tumbling from the *hanging*
position, total energy E0 = 2.03 J. Lee et al. take inertial e3 along gravity (their moment is
m g hat(rho) R^T e3 with rho = 0.3 e3); lgvi's UniformGravity takes e3 up, so their rho is
com = -0.3 e3 here (the same R, Pi and moments, number for number). The variational LGVI
(h = 0.01 s) keeps the total energy bounded with no drift and the vertical angular momentum
e3 . R Pi to round-off; SciPy's RK45 (rtol 1e-6) lets both drift and leaves SO(3).

Usage::

    python examples/pendulum3d.py [--steps 3000] [--quick] [--out DIR] [--no-plots]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import lgvi
from lgvi.verification.baselines import solve_ivp_baseline
from lgvi.torques import UniformGravity

J = (0.13, 0.28, 0.17)           # about the pivot [kg m^2]
GRAVITY = UniformGravity(mass=1.0, com=[0.0, 0.0, -0.3], g=9.81)   # Lee's rho = 0.3 e3, their e3 down
OMEGA0 = (4.14, 4.14, 4.14)      # [rad/s]
H = 0.01                         # [s]


def vertical_momentum_error(traj: lgvi.Trajectory) -> np.ndarray:
    """``|e3 . (R Pi - R0 Pi0)| / |e3 . R0 Pi0|`` per sample (conserved: gravity has no moment about e3)."""
    Lz = traj.spatial_momentum[:, 2]
    return np.abs(Lz - Lz[0]) / abs(Lz[0])


def errors(traj: lgvi.Trajectory) -> tuple[float, float, float]:
    """Max relative errors of the total energy and of e3 . R Pi, and max |R^T R - I|."""
    E = traj.energy
    return (float(np.max(np.abs(E - E[0])) / abs(E[0])), float(np.max(vertical_momentum_error(traj))),
            float(np.max(traj.orthogonality_error)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--steps", type=int, default=3000, help="number of steps (default 3000, 30 s)")
    parser.add_argument("--quick", action="store_true", help="short run (500 steps)")
    parser.add_argument("--out", default="output/pendulum3d", help="folder for the figures")
    parser.add_argument("--no-plots", action="store_true", help="skip the figures")
    args = parser.parse_args(argv)
    steps = 500 if args.quick else args.steps

    body = lgvi.RigidBody(J)
    lg = lgvi.simulate(body, np.eye(3), omega0=OMEGA0, h=H, steps=steps, torque=GRAVITY)
    rk = solve_ivp_baseline(body, np.eye(3), omega0=OMEGA0, t_final=steps * H, samples=steps + 1,
                            method="RK45", rtol=1e-6, atol=1e-9, torque=GRAVITY)
    print(f"3D pendulum: J = diag{J} kg m^2, {GRAVITY!r}, Omega0 = {OMEGA0} rad/s, "
          f"T = {steps * H:g} s, E0 = {lg.energy[0]:.4g} J (hanging start)")
    print(f"{'integrator':<28} {'dE/E':>9} {'d(e3.R Pi)':>11} {'|RtR-I|':>9}")
    for name, traj in ((f"lgvi (symmetric), h={H:g} s", lg), ("scipy RK45, rtol=1e-6", rk)):
        dE, dLz, orth = errors(traj)
        print(f"{name:<28} {dE:>9.1e} {dLz:>11.1e} {orth:>9.1e}")
    if not args.no_plots:
        from lgvi import plot

        out = Path(args.out)
        files = plot.save_figures(lg, out, prefix="pendulum3d_")
        files += plot.save_comparison({"lgvi": lg, "RK45": rk}, out)  # panels: the invariants, E and e3 . R Pi
        print("  figures: " + ", ".join(str(f) for f in files))
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
