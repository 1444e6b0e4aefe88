"""Which disturbance dominates for a 6U CubeSat, and how much wheel momentum it builds in one orbit
================================================================================================

A 6U (10 x 22.6 x 36.6 cm, 8 kg, products of inertia of about 1e-3 kg m^2, two deployed 30 x 20 cm solar panels, centre of mass 1.5 cm from
the geometric centre, residual dipole 0.02 A m^2) points at nadir on a 500 km sun-synchronous
orbit (i = 97.4 deg, RAAN 0: noon-midnight at the March equinox, 36 minutes of eclipse) from
2026-03-20 00:00 UTC. Along one orbit, every 10 s, the compiled components of issue 26 give each
torque in the body frame from the attitude tabulated along the orbit (the LVLH frame; the compiled
loop that would fly it is another issue's):

* aerodynamic drag on the 10 facets (``FacetDrag``, Cd 2.2), the density from NRLMSIS 2.1 along
  the orbit (``TabulatedAtmosphere.from_msis``, F10.7 = 150, Ap = 4; an exponential atmosphere
  through 500 km if pymsis is not installed), the air co-rotating with the Earth;
* solar radiation pressure (``FacetSRP``; body: 60 % absorbed, 20 % specular, 20 % diffuse;
  panels' cells 80/10/10, backs 50/20/30) with the conical shadow (``Sun``, ``Shadow``);
* the residual dipole in the IGRF-14 field (``ResidualDipole``; a centred dipole without ppigrf);
* the gravity gradient, ``3 mu / r^5 b x J b``.

Prints, for each source, the largest and the RMS torque and the momentum it adds over the orbit in
the body frame (``|integral of tau dt|``: what the wheels must absorb, since the body turns with the
LVLH frame), and which dominates. ``--out DIR`` draws the torques along the orbit
(``momentum_budget.png``).

Usage::

    python examples/momentum_budget.py [--out DIR] [--quick]
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib.util
from pathlib import Path

import numpy as np

from lgvi.environment import (IGRF, CentredDipole, CircularOrbit, ExponentialAtmosphere, OrbitEnvironment, Shadow,
                              Sun, TabulatedAtmosphere, lvlh_frame)
from lgvi.spacecraft import FacetDrag, FacetSRP, ResidualDipole

EPOCH = dt.datetime(2026, 3, 20)
ORBIT = CircularOrbit(6378136.6 + 500e3, np.radians(97.4))
MU = 3.986004418e14
MASS = 8.0
SIZE = np.array([0.1, 0.226, 0.366])                       # x: along-track, z: nadir (the long axis)
COM = np.array([0.005, -0.01, 0.01])                       # from the geometric centre [m]
DIPOLE = np.array([0.015, -0.01, 0.008])                   # [A m^2]
J = MASS / 12.0 * np.diag([SIZE[1] ** 2 + SIZE[2] ** 2, SIZE[0] ** 2 + SIZE[2] ** 2, SIZE[0] ** 2 + SIZE[1] ** 2])
J += np.array([[0.0, 4e-4, -1.2e-3], [4e-4, 0.0, 8e-4], [-1.2e-3, 8e-4, 0.0]])   # products of inertia [kg m^2]


def six_u():
    """Facets: the six faces, then the two panels (along +-y, normals +-x), front and back."""
    area, normal, centre, optics = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            area.append(np.prod(np.delete(SIZE, axis)))
            normal.append(n)
            centre.append(n * SIZE[axis] / 2 - COM)
            optics.append((0.6, 0.2, 0.2))
    for side in (1.0, -1.0):
        for face, op in ((1.0, (0.8, 0.1, 0.1)), (-1.0, (0.5, 0.2, 0.3))):
            area.append(0.3 * 0.2)
            normal.append([face, 0.0, 0.0])
            centre.append(np.array([0.0, side * (SIZE[1] / 2 + 0.15), 0.0]) - COM)
            optics.append(op)
    a, s, d = np.array(optics).T
    return np.array(area), np.array(normal), np.array(centre), a, s, d


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    ap.add_argument("--out", type=Path, default=None, help="folder for momentum_budget.png")
    ap.add_argument("--quick", action="store_true", help="a quarter of the orbit")
    args = ap.parse_args(argv)
    period = ORBIT.period
    t = np.arange(0.0, (0.25 if args.quick else 1.0) * period, 10.0)
    area, normal, centre, absorbed, specular, diffuse = six_u()

    field = IGRF() if importlib.util.find_spec("ppigrf") else CentredDipole()
    env = OrbitEnvironment(ORBIT, field, epoch=EPOCH).sample(t)
    r, v, B_N = env["r"], env["v"], env["B_inertial"]
    R = lvlh_frame(r, v)                                    # nadir pointing: body axes on LVLH
    if importlib.util.find_spec("pymsis"):
        atmosphere = TabulatedAtmosphere.from_msis(ORBIT, EPOCH, t[-1] + 10.0, dt=10.0)
        where = "NRLMSIS 2.1 (pymsis), F10.7 = 150, Ap = 4"
    else:
        atmosphere = ExponentialAtmosphere.from_reference(500e3, 6.967e-13, 63822.0)
        where = "exponential through 6.967e-13 kg/m^3 at 500 km (pymsis not installed)"
    air = atmosphere.evaluate(t, r, v) if isinstance(atmosphere, TabulatedAtmosphere) else atmosphere.evaluate(r, v)
    sun = Sun(EPOCH).evaluate(t, r)
    lit = Shadow("conical").evaluate(r, sun["sun_N"], sun["sun_distance"])

    drag = FacetDrag(area, normal, centre, 2.2).evaluate(R, air["density"], air["v_rel_N"])["tau_facet_drag_B"]
    srp = FacetSRP(area, normal, centre, absorbed=absorbed, specular=specular, diffuse=diffuse).evaluate(
        R, sun["sun_N"], sun["sun_distance"], lit)["tau_facet_srp_B"]
    mag = ResidualDipole(DIPOLE).evaluate(R, B_N)["tau_residual_dipole_B"]
    b = np.einsum("nji,nj->ni", R, r)                        # position in the body frame
    rn = np.linalg.norm(r, axis=1)
    gg = 3.0 * MU / rn[:, None] ** 5 * np.cross(b, b @ J.T)
    torques = {"aerodynamic drag": drag, "solar radiation pressure": srp, "residual dipole": mag,
               "gravity gradient": gg}

    print(f"6U, nadir pointing, 500 km SSO from {EPOCH:%Y-%m-%d %H:%M} UTC, {t[-1] / 60:.0f} minutes "
          f"({np.mean(lit < 1.0) * 100:.0f} % in shadow); density: {where}; field: {field.name}")
    print(f"{'source':<26}{'max |tau| N m':>15}{'rms |tau| N m':>15}{'momentum N m s':>16}")
    added = {}
    for name, tau in torques.items():
        mag_t = np.linalg.norm(tau, axis=1)
        h = np.linalg.norm(np.trapezoid(tau, t, axis=0))
        added[name] = h
        print(f"{name:<26}{mag_t.max():>15.3e}{np.sqrt(np.mean(mag_t ** 2)):>15.3e}{h:>16.3e}")
    total = np.linalg.norm(np.trapezoid(sum(torques.values()), t, axis=0))
    rms = {name: np.sqrt(np.mean(np.sum(tau ** 2, axis=1))) for name, tau in torques.items()}
    print(f"{'all together':<26}{'':>15}{'':>15}{total:>16.3e}")
    print(f"dominant torque: {max(rms, key=rms.get)}; largest momentum added: {max(added, key=added.get)}")

    if args.out is not None:
        import matplotlib.pyplot as plt

        args.out.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(10, 4.2))
        for name, tau in torques.items():
            ax.semilogy(t / 60.0, np.linalg.norm(tau, axis=1), label=name)
        dark = lit < 1.0
        if dark.any():
            ax.axvspan(t[dark][0] / 60.0, t[dark][-1] / 60.0, color="0.85", zorder=0, label="shadow")
        ax.set_xlabel("time since epoch [min]")
        ax.set_ylabel("|torque| [N m]")
        ax.set_title("6U in a 500 km sun-synchronous orbit, nadir pointing: disturbance torques")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        fig.tight_layout()
        fig.savefig(args.out / "momentum_budget.png", dpi=120)
        print(f"figure: {args.out / 'momentum_budget.png'}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
