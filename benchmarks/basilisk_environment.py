"""Basilisk's environment and disturbance modules at given states: the fixture of lgvi's checks.

Writes ``basilisk_environment.npz`` beside this file (tests/test_environment_components.py reads it;
the tests never import Basilisk). Run with the ``bench`` extra (Basilisk) installed:

    python benchmarks/basilisk_environment.py

Contents (SI units; Basilisk's ``dcm_BN`` is lgvi's ``R.T``, its MRP ``sigma_BN`` is given):
* ``ecl_*``: the ``eclipse`` module, the Earth at the origin, the sun at ``ecl_sun`` (m), the
  spacecraft at ``ecl_r`` (n, 3) on arcs at 6600, 7000 and 42000 km through the umbra, densely
  through the penumbra, and out into the sunlight: ``ecl_factor`` (n,);
  Basilisk's radii ``ecl_R_earth`` (REQ_EARTH) and ``ecl_R_sun`` (REQ_SUN, 695000 km).
* ``atm_*``: ``exponentialAtmosphere`` (``atm_base``, ``atm_H``, ``atm_R``) at ``atm_r``:
  ``atm_density``.
* ``drag_*``: ``facetDragDynamicEffector`` with the facets ``fac_area``, ``fac_normal``,
  ``fac_centre``, ``fac_cd`` at attitudes ``drag_sigma`` (n, 3), hub velocities ``drag_v`` and
  densities ``drag_rho``: ``drag_torque`` (n, 3, body, about B), ``drag_force`` (n, 3, body).
* ``srp_*``: ``facetSRPDynamicEffector`` with the same facets and ``fac_specular``,
  ``fac_diffuse`` at ``srp_sigma``, hub positions ``srp_r``, the sun at ``srp_sun`` (n, 3) and
  illumination factors ``srp_shadow``: ``srp_torque``, ``srp_force`` (body).
* ``mtb_*``: ``MtbEffector`` (identity rod axes, a held command ``mtb_dipole``) at ``mtb_sigma``
  in the inertial field ``mtb_B`` (n, 3): ``mtb_torque`` (body).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from Basilisk.architecture import messaging
from Basilisk.simulation import (MtbEffector, eclipse, exponentialAtmosphere, facetDragDynamicEffector,
                                 facetSRPDynamicEffector, spacecraft)
from Basilisk.utilities import SimulationBaseClass, macros

OUT = Path(__file__).with_name("basilisk_environment.npz")
RNG = np.random.default_rng(26)

# a 6U (10 x 22.6 x 36.6 cm) with two deployed panels (front and back as two facets), centres of
# pressure from the centre of mass (offset from the geometric centre)
COM = np.array([0.004, -0.006, 0.012])
SIZE = np.array([0.1, 0.226, 0.366])


def six_u() -> dict[str, np.ndarray]:
    area, normal, centre = [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            area.append(np.prod(np.delete(SIZE, axis)))
            normal.append(n)
            centre.append(n * SIZE[axis] / 2 - COM)
    for sign in (1.0, -1.0):                    # panels 0.3 x 0.2 m along +-y, normal +x, both faces
        for face in (1.0, -1.0):
            area.append(0.3 * 0.2)
            normal.append([face, 0.0, 0.0])
            centre.append(np.array([0.0, sign * (SIZE[1] / 2 + 0.15), 0.0]) - COM)
    k = len(area)
    return dict(fac_area=np.array(area), fac_normal=np.array(normal, dtype=float), fac_centre=np.array(centre),
                fac_cd=np.linspace(2.0, 2.4, k), fac_specular=np.linspace(0.1, 0.5, k),
                fac_diffuse=np.linspace(0.3, 0.1, k))


def random_mrp(n: int) -> np.ndarray:
    q = RNG.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[q[:, 3] < 0] *= -1
    return q[:, :3] / (1.0 + q[:, 3:])


def _factor(payload) -> float:
    """The illuminated fraction (``illuminationFactor``; ``shadowFactor`` in older Basilisk)."""
    return payload.illuminationFactor if hasattr(payload, "illuminationFactor") else payload.shadowFactor


def _eclipse_payload(value: float):
    payload = messaging.EclipseMsgPayload()
    for name in ("illuminationFactor", "shadowFactor"):
        if hasattr(payload, name):
            setattr(payload, name, value)
    return payload


def _run_at(module, rs) -> list:
    """Give ``module`` one spacecraft state message per position of ``rs`` and run it once; the
    messages are returned (they must live while the outputs are read)."""
    keep = []
    for r in rs:
        m = messaging.SCStatesMsg().write(messaging.SCStatesMsgPayload(r_BN_N=list(r)))
        keep.append(m)
        module.addSpacecraftToModel(m)
    module.Reset(0)
    module.UpdateState(0)
    return keep


def drag_effector(fac):
    """Basilisk's facet drag with the facets ``fac_*``."""
    drag = facetDragDynamicEffector.FacetDragDynamicEffector()
    for k in range(len(fac["fac_area"])):
        drag.addFacet(fac["fac_area"][k], fac["fac_cd"][k], list(fac["fac_normal"][k]), list(fac["fac_centre"][k]))
    return drag


def srp_effector(fac):
    """Basilisk's facet SRP with the facets ``fac_*`` (fixed, normals in the body frame)."""
    srp = facetSRPDynamicEffector.FacetSRPDynamicEffector()
    srp.setNumFacets(len(fac["fac_area"]))
    srp.setNumArticulatedFacets(0)
    for k in range(len(fac["fac_area"])):
        srp.addFacet(fac["fac_area"][k], np.eye(3).tolist(), list(fac["fac_normal"][k]), [0.0, 0.0, 1.0],
                     list(fac["fac_centre"][k]), fac["fac_diffuse"][k], fac["fac_specular"][k])
    return srp


def eclipse_case() -> dict[str, np.ndarray]:
    sun = np.array([1.2e11, -8.0e10, 3.1e10])
    u = sun / np.linalg.norm(sun)
    e1 = np.cross(u, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    rs = []
    for radius in (6.6e6, 7.0e6, 4.2e7):        # arcs behind the Earth, in planes containing u
        edge = np.arcsin(6378.1366e3 / radius)  # the angle from the anti-sun line of the shadow's edge
        for th in np.concatenate([np.linspace(0.0, 0.98 * edge, 15), edge + np.linspace(-0.01, 0.01, 81) * (
                7e6 / radius), np.linspace(1.02 * edge, 1.5 * edge, 10)]):
            for side in (e1, 0.6 * e1 + 0.8 * e2):
                rs.append(radius * (-np.cos(th) * u + np.sin(th) * side))
    rs = np.array(rs)
    ecl = eclipse.Eclipse()
    sun_msg = messaging.SpicePlanetStateMsg().write(messaging.SpicePlanetStateMsgPayload(
        PositionVector=list(sun), PlanetName="sun"))
    earth_msg = messaging.SpicePlanetStateMsg().write(messaging.SpicePlanetStateMsgPayload(
        PositionVector=[0.0, 0.0, 0.0], PlanetName="earth"))
    ecl.sunInMsg.subscribeTo(sun_msg)
    ecl.addPlanetToModel(earth_msg)
    keep = _run_at(ecl, rs)
    factor = np.array([_factor(ecl.eclipseOutMsgs[i].read()) for i in range(len(rs))])
    return dict(ecl_sun=sun, ecl_r=rs, ecl_factor=factor, ecl_R_earth=6378.1366e3, ecl_R_sun=695000e3)


def atmosphere_case() -> dict[str, np.ndarray]:
    atm = exponentialAtmosphere.ExponentialAtmosphere()
    atm.baseDensity, atm.scaleHeight, atm.planetRadius = 1.217, 8500.0, 6378136.6
    rs = RNG.normal(size=(40, 3))
    rs *= (6378136.6 + np.linspace(100e3, 400e3, 40))[:, None] / np.linalg.norm(rs, axis=1, keepdims=True)
    keep = _run_at(atm, rs)
    dens = np.array([atm.envOutMsgs[i].read().neutralDensity for i in range(len(rs))])
    del keep
    return dict(atm_base=1.217, atm_H=8500.0, atm_R=6378136.6, atm_r=rs, atm_density=dens)


def _spacecraft_with(effector, msgs) -> tuple:
    sim = SimulationBaseClass.SimBaseClass()
    sim.CreateNewProcess("p").addTask(sim.CreateNewTask("t", macros.sec2nano(1.0)))
    sc = spacecraft.Spacecraft()
    sc.hub.r_CN_NInit = [7.0e6, 0.0, 0.0]
    sc.hub.v_CN_NInit = [0.0, 7.5e3, 0.0]
    sc.addDynamicEffector(effector)
    sim.AddModelToTask("t", sc)
    sim.AddModelToTask("t", effector)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(0)
    sim.ExecuteSimulation()
    return sim, sc


def drag_case(fac: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    n = 40
    sig = random_mrp(n)
    v = RNG.normal(size=(n, 3)) * 3000.0 + [0.0, 7500.0, 0.0]
    rho = 10.0 ** RNG.uniform(-13.0, -11.0, n)
    tq, fo = [], []
    for i in range(n):
        drag = drag_effector(fac)
        atm = messaging.AtmoPropsMsg().write(messaging.AtmoPropsMsgPayload(neutralDensity=rho[i]))
        drag.atmoDensInMsg.subscribeTo(atm)
        sim, sc = _spacecraft_with(drag, [atm])
        sc.dynManager.getStateObject(drag.getStateNameOfSigma()).setState(sig[i][:, None].tolist())
        sc.dynManager.getStateObject(drag.getStateNameOfVelocity()).setState(v[i][:, None].tolist())
        drag.computeForceTorque(0.0, 0.0)
        tq.append(np.ravel(drag.torqueExternalPntB_B))
        fo.append(np.ravel(drag.forceExternal_B))
    return dict(drag_sigma=sig, drag_v=v, drag_rho=rho, drag_torque=np.array(tq), drag_force=np.array(fo))


def srp_case(fac: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    n = 40
    sig = random_mrp(n)
    r = RNG.normal(size=(n, 3)) * 4.0e6
    sun = RNG.normal(size=(n, 3))
    sun *= (1.47e11 + RNG.uniform(0.0, 5e9, n))[:, None] / np.linalg.norm(sun, axis=1, keepdims=True)
    shadow = np.where(np.arange(n) % 4 == 0, RNG.uniform(0.0, 1.0, n), 1.0)
    tq, fo = [], []
    for i in range(n):
        srp = srp_effector(fac)
        sun_msg = messaging.SpicePlanetStateMsg().write(messaging.SpicePlanetStateMsgPayload(
            PositionVector=list(sun[i]), PlanetName="sun"))
        ecl = messaging.EclipseMsg().write(_eclipse_payload(shadow[i]))
        srp.sunInMsg.subscribeTo(sun_msg)
        srp.sunEclipseInMsg.subscribeTo(ecl)
        sim, sc = _spacecraft_with(srp, [sun_msg, ecl])
        sc.dynManager.getStateObject(srp.getStateNameOfSigma()).setState(sig[i][:, None].tolist())
        sc.dynManager.getStateObject(srp.getStateNameOfPosition()).setState(r[i][:, None].tolist())
        srp.computeForceTorque(0.0, 0.0)
        tq.append(np.ravel(srp.torqueExternalPntB_B))
        fo.append(np.ravel(srp.forceExternal_B))
    return dict(srp_sigma=sig, srp_r=r, srp_sun=sun, srp_shadow=shadow, srp_torque=np.array(tq),
                srp_force=np.array(fo), srp_flux=1368.0, srp_au=149597870700.0)


def mtb_case() -> dict[str, np.ndarray]:
    n = 20
    sig = random_mrp(n)
    B = RNG.normal(size=(n, 3)) * 3e-5
    dipole = np.array([0.012, -0.004, 0.007])
    tq = []
    for i in range(n):
        mtb = MtbEffector.MtbEffector()
        cmd = messaging.MTBCmdMsg().write(messaging.MTBCmdMsgPayload(mtbDipoleCmds=list(dipole)))
        field = messaging.MagneticFieldMsg().write(messaging.MagneticFieldMsgPayload(magField_N=list(B[i])))
        params = messaging.MTBArrayConfigMsgPayload(numMTB=3, GtMatrix_B=list(np.eye(3).ravel()),
                                                    maxMtbDipoles=[1.0, 1.0, 1.0])
        pmsg = messaging.MTBArrayConfigMsg().write(params)
        mtb.mtbCmdInMsg.subscribeTo(cmd)
        mtb.magInMsg.subscribeTo(field)
        mtb.mtbParamsInMsg.subscribeTo(pmsg)
        sim, sc = _spacecraft_with(mtb, [cmd, field, pmsg])
        sc.dynManager.getStateObject(sc.hub.nameOfHubSigma).setState(sig[i][:, None].tolist())
        mtb.computeForceTorque(0.0, 0.0)
        tq.append(np.ravel(mtb.torqueExternalPntB_B))
    return dict(mtb_sigma=sig, mtb_B=B, mtb_dipole=dipole, mtb_torque=np.array(tq))


def main() -> None:
    fac = six_u()
    data = {**fac, **eclipse_case(), **atmosphere_case(), **drag_case(fac), **srp_case(fac), **mtb_case()}
    np.savez_compressed(OUT, **data)
    print(f"wrote {OUT} ({OUT.stat().st_size / 1024:.0f} kB)")


if __name__ == "__main__":
    main()
