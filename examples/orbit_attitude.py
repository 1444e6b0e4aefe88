"""A long spacecraft on an eccentric, inclined low Earth orbit: orbit and attitude together
========================================================================================

A boom-like body (J = diag(4000, 4000, 100) kg m^2, 500 kg, its axis 3 along the boom) on an
orbit of perigee 7000 km, eccentricity 0.1, inclination 51.6 deg, in Earth's field with J2
(mu = 3.986004418e14 m^3/s^2, J2 = 1.08263e-3, Re = 6378137 m). It starts with the boom along the
local vertical, turning at the perigee's orbital rate; gravity gradient makes it librate and the
eccentric orbit pumps the libration. lgvi.simulate_orbit moves orbit and attitude together
(second-order potential of the body's inertia); with J2 the polar component of the total angular
momentum x x p + R Pi is exact, the energy bounded.

Usage::

    python examples/orbit_attitude.py [--steps 6000] [--quick] [--out DIR] [--no-plots]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import lgvi

MU, J2, RE = 3.986004418e14, 1.08263e-3, 6378137.0
J = (4000.0, 4000.0, 100.0)                      # [kg m^2]
MASS = 500.0                                     # [kg]
H = 10.0                                         # [s]


def initial_state():
    """Perigee state of the orbit (rp = 7000 km, e = 0.1, i = 51.6 deg) and a boom along the vertical."""
    rp, e, inc = 7000e3, 0.1, np.radians(51.6)
    a = rp / (1 - e)
    vp = np.sqrt(MU * (2 / rp - 1 / a))
    x0 = np.array([rp, 0.0, 0.0])
    v0 = vp * np.array([0.0, np.cos(inc), np.sin(inc)])
    up = x0 / rp
    normal = np.cross(x0, v0) / np.linalg.norm(np.cross(x0, v0))
    R0 = np.column_stack([np.cross(normal, up), normal, up])     # body 3 (the boom) along the vertical
    omega0 = np.array([0.0, vp / rp, 0.0])                        # turning with the orbit (about the normal)
    return x0, v0, R0, omega0, 2 * np.pi * np.sqrt(a ** 3 / MU)


def run(steps: int) -> lgvi.OrbitTrajectory:
    x0, v0, R0, omega0, _ = initial_state()
    return lgvi.simulate_orbit(J, MASS, x0, v0, R0, omega0=omega0, h=H, steps=steps, mu=MU, J2=J2, radius=RE,
                               save_every=5)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--steps", type=int, default=6000, help="number of steps (default 6000, about 9 orbits)")
    parser.add_argument("--quick", action="store_true", help="short run (1500 steps)")
    parser.add_argument("--out", default="output/orbit_attitude", help="folder for the figures")
    parser.add_argument("--no-plots", action="store_true", help="skip the figures")
    args = parser.parse_args(argv)
    steps = 1500 if args.quick else args.steps
    period = initial_state()[-1]

    traj = run(steps)
    L, E = traj.angular_momentum, traj.energy
    boom = np.degrees(np.arccos(np.clip(np.einsum("ki,ki->k", traj.R[:, :, 2],
                                                  traj.x / np.linalg.norm(traj.x, axis=1)[:, None]), -1, 1)))
    print(f"Boom on an eccentric orbit: J = diag{J} kg m^2, {MASS:g} kg, orbit period {period:.0f} s, "
          f"h = {H:g} s, {steps} steps ({steps * H / period:.1f} orbits), J2 on")
    print(f"  boom angle from the local vertical: up to {boom.max():.2f} deg")
    print(f"  polar total angular momentum e3.(x x p + R Pi): max relative change "
          f"{np.abs(L[:, 2] - L[0, 2]).max() / np.linalg.norm(L[0]):.1e}")
    print(f"  energy: max relative change {np.abs(E - E[0]).max() / abs(E[0]):.1e} (bounded)")
    if not args.no_plots:
        from lgvi import plot

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        path = out / "orbit_attitude.png"
        plot.orbit(traj).savefig(path, dpi=100)
        print(f"  figure: {path}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
