"""The Basilisk wiring the Basilisk benchmark scripts share (run with the ``bench`` extra).

``basilisk_loop_scenario.py`` (a tumbling 6U under every disturbance), ``loop_hill_pointing.py``
(Hill pointing with wheels and the gravity gradient) and ``basilisk_mission.py`` (the CubeSat
mission's nadir phase) build their simulations from these pieces, so the three agree on how each
Basilisk module is configured. Basilisk is imported inside the functions: importing this module
needs only NumPy.
"""

from __future__ import annotations

import math

import numpy as np


def hub(tag: str, mass: float, inertia: np.ndarray, r0, v0, sigma0, omega0):
    """A ``spacecraft.Spacecraft`` with its centre of mass at B, the orbit and attitude initialised."""
    from Basilisk.simulation import spacecraft

    sc = spacecraft.Spacecraft()
    sc.ModelTag = tag
    sc.hub.mHub = mass
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = np.asarray(inertia, dtype=float).tolist()
    sc.hub.r_CN_NInit = np.asarray(r0, dtype=float).tolist()
    sc.hub.v_CN_NInit = np.asarray(v0, dtype=float).tolist()
    sc.hub.sigma_BNInit = [[float(s)] for s in sigma0]
    sc.hub.omega_BN_BInit = [[float(w)] for w in omega0]
    return sc


def earth(sc, mu: float | None = None):
    """Basilisk's Earth as the central point mass of ``sc`` (``mu`` overrides its default)."""
    from Basilisk.utilities import simIncludeGravBody

    grav = simIncludeGravBody.gravBodyFactory()
    body = grav.createEarth()
    body.isCentralBody = True
    if mu is not None:
        body.mu = mu
    grav.addBodiesTo(sc)
    return body


def gravity_gradient(sc, planet, tag: str | None = None):
    """``GravityGradientEffector`` of ``planet`` on ``sc``."""
    from Basilisk.simulation import GravityGradientEffector

    gg = GravityGradientEffector.GravityGradientEffector()
    if tag is not None:
        gg.ModelTag = tag
    gg.addPlanetName(planet.planetName)
    sc.addDynamicEffector(gg)
    return gg


def wheels(sc, axes, spin_inertia: float, speed0, max_torque: float):
    """Balanced wheels (``rwFactory``, ``speed0`` in rad/s) on ``sc``: ``(effector, factory)``."""
    from Basilisk.architecture import messaging
    from Basilisk.simulation import reactionWheelStateEffector
    from Basilisk.utilities import simIncludeRW

    rwf = simIncludeRW.rwFactory()
    for a, w in zip(axes, speed0):
        rwf.create("custom", list(map(float, a)), Js=spin_inertia, Omega=float(w) * 60.0 / (2.0 * np.pi),
                   u_max=max_torque, RWModel=messaging.BalancedWheels)
    rwe = reactionWheelStateEffector.ReactionWheelStateEffector()
    rwf.addToSpacecraft("rw", rwe, sc)
    return rwe, rwf


def hill_pointing_fsw(sim, dyn: str, fsw: str, sc, rwe, rwf, inertia, K: float, P: float) -> dict:
    """Perfect navigation (``simpleNav``, no noise, priority 0 in ``dyn``), then in ``fsw``:
    ``hillPoint`` -> ``attTrackingError`` -> ``mrpFeedback`` (no integral term) -> ``rwMotorTorque``
    (body axes) -> the wheels. Returns the modules by name (the messages must outlive the run)."""
    from Basilisk.fswAlgorithms import attTrackingError, hillPoint, mrpFeedback, rwMotorTorque
    from Basilisk.simulation import simpleNav

    nav = simpleNav.SimpleNav()
    sim.AddModelToTask(dyn, nav, 0)
    hp = hillPoint.hillPoint()
    sim.AddModelToTask(fsw, hp, 10)
    err = attTrackingError.attTrackingError()
    sim.AddModelToTask(fsw, err, 9)
    ctrl = mrpFeedback.mrpFeedback()
    sim.AddModelToTask(fsw, ctrl, 8)
    ctrl.K, ctrl.Ki, ctrl.P = K, -1.0, P
    mt = rwMotorTorque.rwMotorTorque()
    sim.AddModelToTask(fsw, mt, 7)
    mt.controlAxes_B = [1, 0, 0, 0, 1, 0, 0, 0, 1]
    hp.transNavInMsg.subscribeTo(nav.transOutMsg)
    vc, rw_params = connect_mrp_chain(sc, rwe, rwf, inertia, nav, hp.attRefOutMsg, err, ctrl, mt)
    return dict(nav=nav, hp=hp, err=err, ctrl=ctrl, mt=mt, vc=vc, rw_params=rw_params)


def connect_mrp_chain(sc, rwe, rwf, inertia, nav, ref_msg, err, ctrl, mt):
    """Subscribes ``nav`` (``simpleNav``) to ``sc``, ``err`` (``attTrackingError``) to the
    navigation and the reference message ``ref_msg``, ``ctrl`` (``mrpFeedback``) to ``err``, the
    vehicle (``inertia``) and the wheels, ``mt`` (``rwMotorTorque``) to ``ctrl`` and the wheels
    ``rwe`` to ``mt``. Returns the vehicle and wheel configuration messages (keep them alive)."""
    from Basilisk.architecture import messaging

    vc = messaging.VehicleConfigMsg().write(messaging.VehicleConfigMsgPayload(
        ISCPntB_B=np.asarray(inertia, dtype=float).ravel().tolist()))
    rw_params = rwf.getConfigMessage()
    nav.scStateInMsg.subscribeTo(sc.scStateOutMsg)
    err.attNavInMsg.subscribeTo(nav.attOutMsg)
    err.attRefInMsg.subscribeTo(ref_msg)
    ctrl.guidInMsg.subscribeTo(err.attGuidOutMsg)
    ctrl.vehConfigInMsg.subscribeTo(vc)
    ctrl.rwParamsInMsg.subscribeTo(rw_params)
    ctrl.rwSpeedsInMsg.subscribeTo(rwe.rwSpeedOutMsg)
    mt.rwParamsInMsg.subscribeTo(rw_params)
    mt.vehControlInMsg.subscribeTo(ctrl.cmdTorqueOutMsg)
    rwe.rwMotorCmdInMsg.subscribeTo(mt.rwMotorTorqueOutMsg)
    return vc, rw_params


def ephemeris_module(t_nodes, sun_nodes, gmst_nodes, node: float):
    """A Python module writing the sun (lgvi's nodes every ``node`` s from ``-node``, interpolated
    linearly) and the Earth (at the origin, ``J20002Pfix = R3(GMST)``) at each of its calls."""
    from Basilisk.architecture import messaging, sysModel

    sun_n, gmst_n = np.asarray(sun_nodes), np.asarray(gmst_nodes)

    class Ephemeris(sysModel.SysModel):
        def __init__(self):
            super().__init__()
            self.sunOutMsg = messaging.SpicePlanetStateMsg()
            self.earthOutMsg = messaging.SpicePlanetStateMsg()

        def UpdateState(self, CurrentSimNanos):
            t = CurrentSimNanos * 1e-9
            k = int(math.floor(t / node)) + 1                  # node k is at (k - 1) * node
            q = t / node - math.floor(t / node)
            sun = sun_n[k] + q * (sun_n[k + 1] - sun_n[k])
            theta = gmst_n[k] + q * (gmst_n[k + 1] - gmst_n[k])
            c, s = math.cos(theta), math.sin(theta)
            sp = messaging.SpicePlanetStateMsgPayload()
            sp.PositionVector = list(sun)
            sp.PlanetName = "sun"
            self.sunOutMsg.write(sp, CurrentSimNanos, self.moduleID)
            ep = messaging.SpicePlanetStateMsgPayload()
            ep.PositionVector = [0.0, 0.0, 0.0]
            ep.PlanetName = "earth"
            ep.J20002Pfix = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]
            w = (gmst_n[k + 1] - gmst_n[k]) / node
            ep.J20002Pfix_dot = [[-s * w, c * w, 0.0], [-c * w, -s * w, 0.0], [0.0, 0.0, 0.0]]
            self.earthOutMsg.write(ep, CurrentSimNanos, self.moduleID)

    mod = Ephemeris()
    mod.ModelTag = "ephemeris"
    return mod


def disturbances(sc, eph, fac, *, rho0: float, H: float, planet_radius: float, omega_earth: float,
                 g10_g11_h11, dipole) -> dict:
    """The environment and the disturbance effectors of ``sc``, fed by ``eph``
    (:func:`ephemeris_module`): ``eclipse`` (conical), ``exponentialAtmosphere`` with a co-rotating
    ``zeroWindModel``, facet drag and facet SRP with the facets ``fac_*`` (see
    ``basilisk_environment.py``), and a residual ``dipole`` (A m^2, body) held by an ``MtbEffector``
    in ``magneticFieldCenteredDipole`` (``g10_g11_h11`` nT). Returns the modules by name; the caller
    adds them to its task (environment before the effectors)."""
    from Basilisk.architecture import messaging
    from Basilisk.simulation import MtbEffector, eclipse, exponentialAtmosphere, magneticFieldCenteredDipole, \
        zeroWindModel

    from basilisk_environment import drag_effector, srp_effector

    ecl = eclipse.Eclipse()
    ecl.sunInMsg.subscribeTo(eph.sunOutMsg)
    ecl.addPlanetToModel(eph.earthOutMsg)
    ecl.addSpacecraftToModel(sc.scStateOutMsg)

    atm = exponentialAtmosphere.ExponentialAtmosphere()
    atm.baseDensity, atm.scaleHeight, atm.planetRadius = rho0, H, planet_radius
    atm.addSpacecraftToModel(sc.scStateOutMsg)
    wind = zeroWindModel.ZeroWindModel()
    wind.setPlanetOmega_N([0.0, 0.0, omega_earth])
    wind.setUseSpiceOmegaFlag(False)
    wind.planetPosInMsg.subscribeTo(eph.earthOutMsg)
    wind.addSpacecraftToModel(sc.scStateOutMsg)

    drag = drag_effector(fac)
    drag.atmoDensInMsg.subscribeTo(atm.envOutMsgs[0])
    drag.windVelInMsg.subscribeTo(wind.envOutMsgs[0])
    sc.addDynamicEffector(drag)

    srp = srp_effector(fac)
    srp.sunInMsg.subscribeTo(eph.sunOutMsg)
    srp.sunEclipseInMsg.subscribeTo(ecl.eclipseOutMsgs[0])
    sc.addDynamicEffector(srp)

    mag = magneticFieldCenteredDipole.MagneticFieldCenteredDipole()
    mag.g10, mag.g11, mag.h11 = (np.asarray(g10_g11_h11, dtype=float) * 1e-9).tolist()
    mag.planetRadius = 6371.2e3
    mag.planetPosInMsg.subscribeTo(eph.earthOutMsg)
    mag.addSpacecraftToModel(sc.scStateOutMsg)
    mtb = MtbEffector.MtbEffector()
    cmd = messaging.MTBCmdMsg().write(messaging.MTBCmdMsgPayload(mtbDipoleCmds=np.asarray(dipole, float).tolist()))
    pmsg = messaging.MTBArrayConfigMsg().write(messaging.MTBArrayConfigMsgPayload(
        numMTB=3, GtMatrix_B=list(np.eye(3).ravel()), maxMtbDipoles=[10.0, 10.0, 10.0]))
    mtb.mtbCmdInMsg.subscribeTo(cmd)
    mtb.magInMsg.subscribeTo(mag.envOutMsgs[0])
    mtb.mtbParamsInMsg.subscribeTo(pmsg)
    sc.addDynamicEffector(mtb)
    return dict(ecl=ecl, atm=atm, wind=wind, mag=mag, drag=drag, srp=srp, mtb=mtb, cmd=cmd, pmsg=pmsg)


def add_environment(sim, task: str, sc, env: dict, gg) -> None:
    """Adds ``sc`` and the modules of :func:`disturbances` to ``task`` in the order the scripts
    rely on: at each t_k the spacecraft integrates to t_k first, then the environment runs on the
    state at t_k, then the effectors read it (held over [t_k, t_k+1])."""
    for prio, model in ((110, sc), (90, env["ecl"]), (89, env["atm"]), (88, env["wind"]), (87, env["mag"]),
                        (40, env["drag"]), (40, env["srp"]), (40, env["mtb"]), (40, gg)):
        sim.AddModelToTask(task, model, prio)


def shadow_of(recorder) -> np.ndarray:
    """The visible fraction from an ``eclipse`` recorder (``illuminationFactor``, or ``shadowFactor``)."""
    return np.asarray(recorder.illuminationFactor if hasattr(recorder, "illuminationFactor")
                      else recorder.shadowFactor)


def run_child(script: str, python: str | None, *args: str) -> dict:
    """Runs ``script --basilisk-only OUT *args`` with ``python`` (an interpreter with Basilisk;
    ``None``: this one) and returns the arrays it saved in ``OUT``, ``cpu`` as a float."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    out = Path(os.environ.get("TMPDIR", "/tmp")) / f"lgvi_bsk_{Path(script).stem}_{os.getpid()}.npz"
    subprocess.run([python or sys.executable, str(script), "--basilisk-only", str(out), *args], check=True)
    with np.load(out) as z:
        d = {k: z[k] for k in z.files}
    out.unlink()
    d["cpu"] = float(d["cpu"])
    return d


def record_and_run(sim, task: str, sc, rwe, every: float, stop: float) -> dict:
    """Records the hub's state and the wheel speeds (four wheels) every ``every`` s in ``task``,
    runs to ``stop`` s; the records, ``cpu`` (CPU seconds of ``ExecuteSimulation()``) and ``bsk``
    (Basilisk's version)."""
    import time

    from Basilisk import __version__ as bsk_version
    from Basilisk.utilities import macros

    state_log = sc.scStateOutMsg.recorder(macros.sec2nano(every))
    speed_log = rwe.rwSpeedOutMsg.recorder(macros.sec2nano(every))
    for log in (state_log, speed_log):
        sim.AddModelToTask(task, log)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(stop))
    c0 = time.process_time()
    sim.ExecuteSimulation()
    cpu = time.process_time() - c0
    return {"t": state_log.times() * 1e-9, "sigma": np.array(state_log.sigma_BN),
            "omega": np.array(state_log.omega_BN_B), "wheel_speed": np.array(speed_log.wheelSpeeds)[:, :4],
            "r": np.array(state_log.r_BN_N), "cpu": cpu, "bsk": str(bsk_version)}
