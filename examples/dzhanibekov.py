"""The Dzhanibekov effect: a free body spun near its intermediate axis flips over and over
=======================================================================================

J = diag(1, 2, 3) kg m^2, omega0 = (1e-3, 1, 1e-3) rad/s, R0 = I, h = 0.01 s. The LGVI keeps
the kinetic energy, ``|Pi|`` and the spatial momentum ``R Pi`` to round-off; the flips are the run of
the body momentum along the separatrix of the polhode figure.

Usage::

    python examples/dzhanibekov.py                  # 10000 steps, figures in output/dzhanibekov
    python examples/dzhanibekov.py --quick          # 1000 steps
    python examples/dzhanibekov.py --steps 100000 --out figs --animate
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import lgvi

J = (1.0, 2.0, 3.0)          # principal moments [kg m^2]
OMEGA0 = (1e-3, 1.0, 1e-3)   # [rad/s], almost along the intermediate axis
H = 0.01                     # [s]


def run(steps: int) -> lgvi.Trajectory:
    return lgvi.simulate(lgvi.RigidBody(J), np.eye(3), omega0=OMEGA0, h=H, steps=steps)


def summary(traj: lgvi.Trajectory) -> dict[str, float]:
    E, L = traj.energy, traj.spatial_momentum
    nPi = np.linalg.norm(traj.Pi, axis=1)
    flips = int(np.count_nonzero(np.diff(np.sign(traj.omega[:, 1])) != 0))
    return {
        "flips": flips,
        "energy": float(np.max(np.abs(E - E[0])) / E[0]),
        "casimir": float(np.max(np.abs(nPi - nPi[0])) / nPi[0]),
        "momentum": float(np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0])),
        "orthogonality": float(np.max(traj.orthogonality_error)),
        "iterations": float(traj.iterations.mean()),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--steps", type=int, default=10_000, help="number of steps (default 10000)")
    parser.add_argument("--quick", action="store_true", help="short run (2000 steps)")
    parser.add_argument("--out", default="output/dzhanibekov", help="folder for the figures")
    parser.add_argument("--no-plots", action="store_true", help="skip the figures")
    parser.add_argument("--animate", action="store_true", help="also write animation.gif (slow: ~0.2 s a frame)")
    args = parser.parse_args(argv)
    steps = 2000 if args.quick else args.steps

    t0 = time.perf_counter()
    traj = run(steps)
    wall = time.perf_counter() - t0
    s = summary(traj)
    print(f"Dzhanibekov effect: J = diag{J} kg m^2, omega0 = {OMEGA0} rad/s, h = {H} s, {steps} steps "
          f"({wall:.2f} s wall, including any compilation)")
    print(f"  flips of the intermediate axis (sign changes of omega_2): {s['flips']}")
    print(f"  max relative error: energy {s['energy']:.1e}, |Pi| {s['casimir']:.1e}, "
          f"R Pi {s['momentum']:.1e}; max |R^T R - I| {s['orthogonality']:.1e}")
    print(f"  mean solver updates per step: {s['iterations']:.2f}")
    if not args.no_plots:
        from lgvi import plot

        out = Path(args.out)
        files = plot.save_figures(traj, out)
        if args.animate:
            files.append(plot.animate(traj, out / "animation.gif", max_frames=150, fps=15))
        print("  figures: " + ", ".join(str(f) for f in files))
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
