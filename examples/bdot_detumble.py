"""B-dot detumbling of a small satellite in a polar orbit, in the IGRF-14 field
============================================================================

A 3U-class body, J = diag(0.02, 0.025, 0.03) kg m^2, tumbling at (10, -8, 6) deg/s, on a 500 km
circular sun-synchronous orbit (i = 97.4 deg) from 2026-03-20 00:00 UTC. Three magnetorquer rods on
the body axes (0.2 A m^2 each) driven by B-dot, ``m = -k dB/dt`` (k = 5e4 A m^2 s / T) with ``dB/dt``
the difference of the body-frame field between two controller calls (as a magnetometer sees it:
the body's rotation and the field's change along the orbit), the field from IGRF-14 at degree 13
along the orbit, the command held for 1 s (``control_period``), h = 0.1 s. B-dot leaves the body
turning at about twice the orbit rate (the field turns twice per orbit in a polar orbit). Prints the rate at each orbit's quarter and the time to
fall below 0.5 deg/s; the figure shows the body rate and the rods' dipole.

Usage::

    python examples/bdot_detumble.py [--orbits 2] [--quick] [--out DIR] [--no-plots]
"""

from __future__ import annotations

import argparse
import datetime as dt
from pathlib import Path

import numpy as np

import lgvi
from lgvi.environment import IGRF, BDot, CircularOrbit, OrbitEnvironment

J = (0.02, 0.025, 0.03)                                  # [kg m^2]
OMEGA0 = np.radians([10.0, -8.0, 6.0])                    # [rad/s], body frame
ORBIT = CircularOrbit(6371e3 + 500e3, np.radians(97.4))   # 500 km, sun-synchronous inclination
EPOCH = dt.datetime(2026, 3, 20)
GAIN = 5e4                                                # [A m^2 s / T]
RODS = lgvi.Magnetorquers(np.eye(3), max_dipole=0.2)      # [A m^2]
H = 0.1                                                   # [s]
CONTROL = 1.0                                             # [s]


def detumble(orbits: float):
    env = OrbitEnvironment(ORBIT, IGRF(), epoch=EPOCH)
    every = int(round(10.0 / H))                           # save every 10 s
    steps = every * int(round(orbits * ORBIT.period / (every * H)))
    sat = lgvi.Spacecraft(J, magnetorquers=RODS, orbit=ORBIT, field=IGRF(), epoch=EPOCH, environment_rate=CONTROL)
    fsw = lgvi.FlightSoftware(controller=BDot(GAIN), control_period=CONTROL)   # B-dot, called from Python
    traj = lgvi.simulate(sat, np.eye(3), omega0=OMEGA0, h=H, steps=steps, fsw=fsw, save_every=every)
    return traj, env


def dipoles(traj, env) -> np.ndarray:
    """The rods' dipole (A m^2, body frame) at the saved samples (the command of the call there)."""
    t = np.stack([traj.t - CONTROL, traj.t], axis=1)
    B = env.sample(t)["B_inertial"]
    B_now = np.einsum("kji,kj->ki", traj.R, B[:, 1])
    # the body-frame field one control period earlier, from the rate at the sample (for the figure)
    R_before = traj.R @ lgvi.so3.exp(-CONTROL * traj.omega)
    B_before = np.einsum("kji,kj->ki", R_before, B[:, 0])
    return np.array([RODS.dipole(-GAIN * (b1 - b0) / CONTROL) for b0, b1 in zip(B_before, B_now)])


def figure(traj, env):
    from matplotlib.figure import Figure

    t = traj.t / ORBIT.period
    fig = Figure(figsize=(8, 5.5), dpi=100, layout="constrained")
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.semilogy(t, np.degrees(np.linalg.norm(traj.omega, axis=1)), "k", lw=1.2, label="$|\\omega|$")
    ax1.axhline(2 * np.degrees(ORBIT.mean_motion), color="C3", ls="--", lw=1, label="twice the orbit rate")
    ax1.set_ylabel("body rate [deg/s]")
    ax1.legend(fontsize=8)
    ax1.set_title("B-dot detumble, 500 km polar orbit, IGRF-14, rods 0.2 A m$^2$")
    m = dipoles(traj, env)
    for i, c in enumerate("xyz"):
        ax2.plot(t, m[:, i], lw=0.8, label=f"$m_{c}$")
    ax2.set_ylabel("rod dipole [A m$^2$]")
    ax2.set_xlabel("time [orbits]")
    ax2.legend(ncol=3, fontsize=8)
    return fig


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    ap.add_argument("--orbits", type=float, default=2.0)
    ap.add_argument("--quick", action="store_true", help="half an orbit")
    ap.add_argument("--out", type=Path, default=Path("figures") / "bdot_detumble")
    ap.add_argument("--no-plots", action="store_true")
    args = ap.parse_args(argv)
    orbits = 0.5 if args.quick else args.orbits
    traj, env = detumble(orbits)
    rate = np.degrees(np.linalg.norm(traj.omega, axis=1))
    print(f"orbit period {ORBIT.period:.1f} s, {len(traj.t) - 1} saved intervals of 10 s")
    for q in np.arange(0.0, orbits + 1e-9, 0.25):
        k = int(np.argmin(np.abs(traj.t - q * ORBIT.period)))
        print(f"  t = {q:4.2f} orbits: |omega| = {rate[k]:.3f} deg/s")
    below = np.flatnonzero(rate < 0.5)
    print(f"orbit rate {np.degrees(ORBIT.mean_motion):.4f} deg/s")
    print(f"initial |omega| {rate[0]:.3f} deg/s, final {rate[-1]:.3f} deg/s; below 0.5 deg/s after "
          + (f"{traj.t[below[0]]:.0f} s" if below.size else "never"))
    if not args.no_plots:
        args.out.mkdir(parents=True, exist_ok=True)
        path = args.out / "detumble.png"
        figure(traj, env).savefig(path)
        print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
