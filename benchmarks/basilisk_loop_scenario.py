"""A tumbling 6U over one orbit under every disturbance of issue 26 together, in Basilisk: the
fixture for the compiled loop's end-to-end check (the test is added with the loop, issue 25).

Two steps, because the sun must be lgvi's own (the comparison is of the dynamics and the
disturbance models, not of two ephemerides):

    PYTHONPATH=src python benchmarks/basilisk_loop_scenario.py --ephemeris     # lgvi: sun and GMST nodes
    python benchmarks/basilisk_loop_scenario.py      # in an environment with Basilisk (the bench extra)

The first writes ``basilisk_loop_scenario_ephemeris.json`` (lgvi's sun position, TEME metres, and
the Greenwich mean sidereal time at every minute from -60 s to the end), the second reads it and
writes ``basilisk_loop_scenario.npz``. Everything below is what the lgvi side must configure to
match (the values are also saved in the npz, under the names in brackets):

* epoch 2026-03-20 00:00 UTC [epoch]; Earth point mass ``mu`` = Basilisk's 3.98600436e14 [mu],
  no J2; the orbit integrated by Basilisk's RK4 with the attitude, from a circular orbit of radius
  6878136.6 m (500 km), inclination 97.4 deg, RAAN 0, argument of latitude 0 (a noon-midnight
  orbit at the equinox: about 35 minutes of eclipse) [r0, v0];
* hub: mass 8 kg, inertia diag(0.1234, 0.0960, 0.0407) kg m^2 about the centre of mass, which is
  the body frame's origin [J]; sigma_BN(0) [sigma0], omega_BN_B(0) = (3, -2, 1.5) deg/s [omega0];
* sun: the straight line between lgvi's series at whole minutes (``lgvi.environment.Sun(epoch)``,
  its default ``interpolation=60``), written for Basilisk each step by a Python module;
* shadow: Basilisk's ``eclipse`` (conical; its REQ_SUN 695000 km, REQ_EARTH 6378.1366 km):
  ``Shadow("conical", planet_radius=6378136.6, sun_radius=695e6)`` [R_sun];
* atmosphere: ``exponentialAtmosphere`` [rho0, H, planet_radius] = ``ExponentialAtmosphere(rho0, H)``,
  co-rotating through ``zeroWindModel`` with omega = (0, 0, 7.292115e-5) rad/s [omega_earth];
* facet drag: ``facetDragDynamicEffector`` with the 6U's 10 facets of
  ``basilisk_environment.py`` (``fac_*``, also in this npz) = ``FacetDrag(area, normal, centre, cd)``;
* facet SRP: ``facetSRPDynamicEffector`` (solar flux 1368 W/m^2, AU 149597870700 m) with the same
  facets, ``FacetSRP(..., absorbed=1 - specular - diffuse, specular, diffuse, solar_flux=1368)``;
* residual dipole: ``MtbEffector`` holding the dipole [dipole] (A m^2, body) in
  ``magneticFieldCenteredDipole`` (g10, g11, h11 [g10_g11_h11] nT, radius 6371.2 km): the field
  of ``lgvi.environment.CentredDipole(g10, g11, h11)`` turned by the GMST (the Earth's
  ``J20002Pfix`` = R3(GMST) at each step, the same GMST as ``lgvi.environment.gmst``);
* gravity gradient: ``GravityGradientEffector`` (Earth, the same ``mu``);
* Basilisk integrates with RK4 at h = 0.1 s; the environment (sun, shadow, density, wind, field)
  is computed from the state at the start of each step and held over it, as the lgvi loop does
  (task priorities: the spacecraft integrates to t_k first, then the ephemeris and environment
  modules run on the state at t_k); the effectors' torques are evaluated at each RK4 stage with
  the stage's attitude (and position). The held environment makes Basilisk's run first order in
  its step: ``--kepler``, ``--kepler-half`` and ``--kepler-quarter`` fly the same scenario with the
  hub 1e9 times heavier (the forces no longer move the orbit: Kepler's, as lgvi's) at h = 0.1,
  0.05 and 0.025 s, for the test's extrapolation to h = 0 (docs/environment.md).

Saved every 10 s over one orbit [t]: sigma_BN [sigma], omega_BN_B [omega] (rad/s), r_BN_N [r],
v_BN_N [v], the shadow's visible fraction [shadow], the density [density], the field [B_N] (T).
"""

from __future__ import annotations

import datetime as dt
import json
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
EPHEMERIS = HERE / "basilisk_loop_scenario_ephemeris.json"
OUT = HERE / "basilisk_loop_scenario.npz"
KEPLER = HERE / "basilisk_loop_scenario_kepler.npz"
KEPLER_HALF = HERE / "basilisk_loop_scenario_kepler_half.npz"
KEPLER_QUARTER = HERE / "basilisk_loop_scenario_kepler_quarter.npz"
EPOCH = dt.datetime(2026, 3, 20)
MU = 3.98600436e14
RADIUS = 6378136.6 + 500e3
INC = math.radians(97.4)
PERIOD = 2.0 * math.pi * math.sqrt(RADIUS ** 3 / MU)
H = 0.1
SAVE = 10.0
DURATION = SAVE * math.ceil(PERIOD / SAVE)
NODE = 60.0
J = np.diag([0.1234, 0.0960, 0.0407])
MASS = 8.0
SIGMA0 = np.array([0.1, -0.2, 0.3])
OMEGA0 = np.radians([3.0, -2.0, 1.5])
DIPOLE = np.array([0.02, -0.01, 0.015])
G10_G11_H11 = np.array([-29350.0, -1410.3, 4545.5])
OMEGA_EARTH = 7.292115e-5
RHO0_H = (6.967e-13 * math.exp(500e3 / 63822.0), 63822.0)


def ephemeris() -> None:
    """lgvi's sun and GMST at the minutes -60 s .. DURATION + 60 s (run with lgvi importable)."""
    from lgvi.environment import gmst, sun_position

    t = NODE * np.arange(-1, int(DURATION // NODE) + 3)
    EPHEMERIS.write_text(json.dumps({"epoch": EPOCH.isoformat(), "t": t.tolist(),
                                     "sun": sun_position(EPOCH, t).tolist(), "gmst": np.unwrap(gmst(EPOCH, t)).tolist()}))
    print(f"wrote {EPHEMERIS}")


def basilisk(h: float = H, mass: float = MASS, path: Path = OUT) -> None:
    from Basilisk.utilities import SimulationBaseClass, macros

    sys.path.insert(0, str(HERE))
    import _basilisk as bsk

    eph = json.loads(EPHEMERIS.read_text())
    assert eph["epoch"] == EPOCH.isoformat()
    fac = np.load(HERE / "basilisk_environment.npz")

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("p")
    proc.addTask(sim.CreateNewTask("dyn", macros.sec2nano(h)))
    eph_mod = bsk.ephemeris_module(eph["t"], eph["sun"], eph["gmst"], NODE)
    sim.AddModelToTask("dyn", eph_mod, 100)

    u, i = 0.0, INC
    r0 = RADIUS * np.array([math.cos(u), math.cos(i) * math.sin(u), math.sin(i) * math.sin(u)])
    vmag = math.sqrt(MU / RADIUS)
    v0 = vmag * np.array([-math.sin(u), math.cos(i) * math.cos(u), math.sin(i) * math.cos(u)])
    sc = bsk.hub("sixU", mass, J, r0, v0, SIGMA0, OMEGA0)
    earth = bsk.earth(sc, MU)
    ggEff = bsk.gravity_gradient(sc, earth)
    env = bsk.disturbances(sc, eph_mod, fac, rho0=RHO0_H[0], H=RHO0_H[1], planet_radius=6378136.6,
                           omega_earth=OMEGA_EARTH, g10_g11_h11=G10_G11_H11, dipole=DIPOLE)
    ecl, atm, mag = env["ecl"], env["atm"], env["mag"]
    bsk.add_environment(sim, "dyn", sc, env, ggEff)
    every = macros.sec2nano(SAVE)
    rec = {"sc": sc.scStateOutMsg.recorder(every), "ecl": ecl.eclipseOutMsgs[0].recorder(every),
           "atm": atm.envOutMsgs[0].recorder(every), "mag": mag.envOutMsgs[0].recorder(every)}
    for r in rec.values():
        sim.AddModelToTask("dyn", r)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(DURATION))
    sim.ExecuteSimulation()
    shadow = bsk.shadow_of(rec["ecl"])
    out = dict(t=rec["sc"].times() * 1e-9, sigma=np.asarray(rec["sc"].sigma_BN), omega=np.asarray(rec["sc"].omega_BN_B),
               r=np.asarray(rec["sc"].r_BN_N), v=np.asarray(rec["sc"].v_BN_N), shadow=shadow,
               density=np.asarray(rec["atm"].neutralDensity), B_N=np.asarray(rec["mag"].magField_N), epoch=EPOCH.isoformat(), mu=MU, r0=r0, v0=v0, J=J,
               mass=mass, sigma0=SIGMA0, omega0=OMEGA0, dipole=DIPOLE, g10_g11_h11=G10_G11_H11, R_sun=695e6,
               rho0=RHO0_H[0], H=RHO0_H[1], planet_radius=6378136.6, omega_earth=OMEGA_EARTH, h=h,
               **{k: fac[k] for k in fac.files if k.startswith("fac_")})
    np.savez_compressed(path, **out)
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB): {len(out['t'])} samples to t = {out['t'][-1]:g} s, "
          f"eclipse {np.sum(shadow < 1) * SAVE / 60:.0f} min")


if __name__ == "__main__":
    if "--ephemeris" in sys.argv[1:]:
        ephemeris()
    elif "--kepler" in sys.argv[1:]:
        # the same run with the hub's mass 1e9 times larger: the forces no longer move the orbit
        # (Kepler's, as lgvi's), the torques and the attitude dynamics unchanged
        basilisk(mass=MASS * 1e9, path=KEPLER)
    elif "--kepler-half" in sys.argv[1:]:
        basilisk(h=H / 2, mass=MASS * 1e9, path=KEPLER_HALF)      # Basilisk's own step error, h = 0.05
    elif "--kepler-quarter" in sys.argv[1:]:
        basilisk(h=H / 4, mass=MASS * 1e9, path=KEPLER_QUARTER)   # and h = 0.025
    else:
        basilisk()
