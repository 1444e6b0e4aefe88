"""Basilisk (``bsk`` on PyPI) as a peer: the free rigid body and the 3D pendulum, RK4 and RKF78.

Usage::

    python benchmarks/basilisk_peer.py            # convention check against lgvi.exact, then a few runs
    python benchmarks/basilisk_peer.py --quick    # the check only, at a short horizon

Install the peer with ``pip install "lgvi[bench]"`` (or ``pip install bsk``). Without it every
function here raises :class:`BasiliskUnavailable` ("Basilisk not installed") and the benchmarks
that import this module skip the Basilisk rows cleanly.

How the problems are posed in Basilisk
--------------------------------------
* A ``spacecraft.Spacecraft`` hub with ``IHubPntBc_B = J``, its centre of mass at the body point
  ``B`` (``r_BcB_B = 0``), no gravity body: the attitude obeys Euler's equations
  ``J Omega' = J Omega x Omega + L`` and the translational states stay at rest. Basilisk also
  integrates those (zero) translational states; that is part of its cost.
* Attitude: Basilisk stores the MRP ``sigma_BN`` of the DCM ``[BN]`` (body from inertial), the
  transpose of lgvi's ``R`` (body to inertial). In: ``sigma_BN = C2MRP(R0^T)``; out:
  ``R = MRP2C(sigma_BN)^T``. :func:`check_conventions` proves it against :mod:`lgvi.exact`.
* The 3D pendulum (rigid body on a fixed frictionless pivot, ``J`` about the pivot) has the same
  rotational equations with the gravity moment ``L = m g (R^T e3) x c`` (``c`` the centre of mass
  from the pivot, body frame). Basilisk has no "uniform gravity about a fixed pivot" effector, and
  a torque written by a module (``extForceTorque`` or a Python ``SysModel``) is only updated once
  per task step, i.e. held constant across the integrator's stages (first order). What *is*
  evaluated at every integrator stage from the current attitude is the magnetic torque-rod
  effector ``MtbEffector``: ``L = mu x (R^T B_N)``. With the inertial field ``B_N = e3`` and the
  body dipole ``mu = -m g c`` (three orthogonal rods, no saturation) that is exactly the pendulum
  moment, computed in compiled code at every stage. (A repurposed effector, but the mathematics is
  identical; the check in :func:`check_conventions` compares it with lgvi's order-6 run.)
* Time is integer nanoseconds in Basilisk: a fixed step ``T / N`` must divide ``T`` exactly in
  ns (see :func:`step_ok`).
* RKF78 (``svIntegratorRKF78``): adaptive *inside* each task step; every task step starts with a
  trial step equal to the task step, so the task step ``dt`` is the largest step. ``relTol`` and
  ``absTol`` are set to the same ``tol``. The task step must keep the rotation per step well below
  pi (the MRP set switches only between steps; at ``dt = 10`` s the free body returns NaN).

Wall time is that of ``ExecuteSimulation()`` only (building the simulation is not counted).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from typing import Any

import numpy as np

NOT_INSTALLED = "Basilisk not installed"

try:  # pragma: no cover - depends on the optional extra
    from Basilisk.architecture import messaging as _messaging
    from Basilisk.simulation import MtbEffector as _MtbEffector
    from Basilisk.simulation import spacecraft as _spacecraft
    from Basilisk.simulation import svIntegrators as _svIntegrators
    from Basilisk.utilities import RigidBodyKinematics as _rbk
    from Basilisk.utilities import SimulationBaseClass as _SimulationBaseClass

    _IMPORT_ERROR: str | None = None
except ImportError as exc:  # pragma: no cover
    _IMPORT_ERROR = f"{NOT_INSTALLED} ({exc})"

INTEGRATORS = ("rk4", "rkf78")


class BasiliskUnavailable(RuntimeError):
    """Raised by every run when Basilisk cannot be imported."""


def status() -> str | None:
    """``None`` when Basilisk is importable, else the reason (starts with "Basilisk not installed")."""
    return _IMPORT_ERROR


def version() -> str:
    if _IMPORT_ERROR is not None:
        return NOT_INSTALLED
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as _version

    try:
        return f"Basilisk {_version('bsk')}"
    except PackageNotFoundError:  # pragma: no cover - built from source
        return "Basilisk (version unknown)"


def _require() -> None:
    if _IMPORT_ERROR is not None:
        raise BasiliskUnavailable(_IMPORT_ERROR)


def nanoseconds(seconds: float) -> int:
    return int(round(float(seconds) * 1e9))


def step_ok(T: float, steps: int) -> bool:
    """True when ``T / steps`` is a whole number of nanoseconds (Basilisk's clock)."""
    return steps >= 1 and nanoseconds(T) % int(steps) == 0


@dataclasses.dataclass(frozen=True)
class BasiliskRun:
    """Final state and cost of one Basilisk run."""

    R: np.ndarray          # (3, 3) final attitude, body to inertial (lgvi's convention)
    omega: np.ndarray      # (3,) final body rate
    wall: float            # seconds in ExecuteSimulation()
    task_steps: int        # number of task steps (= integrator calls)
    integrator: str


def run(inertia: Any, R0: Any, omega0: Any, *, T: float, dt: float, integrator: str = "rk4",
        tol: float | None = None, gravity: tuple[float, Any, float] | None = None) -> BasiliskRun:
    """Propagate the free body (``gravity=None``) or the 3D pendulum in Basilisk.

    Parameters
    ----------
    inertia : (3,) or (3, 3) array_like
        ``J`` (about the centre of mass for the free body, about the pivot for the pendulum).
    R0 : (3, 3) array_like
        Initial attitude, body to inertial.
    omega0 : (3,) array_like
        Initial body angular velocity.
    T, dt : float
        Final time and task (integrator) step, seconds; ``dt`` must divide ``T`` in nanoseconds.
    integrator : {"rk4", "rkf78"}
    tol : float, optional
        ``relTol = absTol`` of RKF78 (required for it).
    gravity : (mass, com (3,), g), optional
        The 3D pendulum's gravity moment ``m g (R^T e3) x com`` (see the module notes).
    """
    _require()
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
    J = np.asarray(inertia, dtype=np.float64)
    J = np.diag(J) if J.shape == (3,) else J
    R0 = np.asarray(R0, dtype=np.float64)
    omega0 = np.asarray(omega0, dtype=np.float64).reshape(3)
    T_ns, dt_ns = nanoseconds(T), nanoseconds(dt)
    if dt_ns <= 0 or T_ns % dt_ns != 0:
        raise ValueError(f"dt must divide T in whole nanoseconds (Basilisk's clock); got T={T!r}, dt={dt!r}")

    sim = _SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("lgviPeerProcess")
    proc.addTask(sim.CreateNewTask("lgviPeerTask", dt_ns))
    sc = _spacecraft.Spacecraft()
    sc.ModelTag = "rigidBody"
    sc.hub.mHub = 1.0
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = J.tolist()
    sc.hub.sigma_BNInit = [[float(s)] for s in _rbk.C2MRP(R0.T)]
    sc.hub.omega_BN_BInit = [[float(w)] for w in omega0]
    keep: list[Any] = []                       # SWIG objects that must outlive the run
    mtb = None
    if gravity is not None:
        mass, com, g = gravity
        com = np.asarray(com, dtype=np.float64).reshape(3)
        mtb = _MtbEffector.MtbEffector()
        mtb.ModelTag = "pendulumGravityMoment"
        params = _messaging.MTBArrayConfigMsgPayload()
        params.numMTB = 3
        gt = [0.0] * len(params.GtMatrix_B)    # row-major 3 x numMTB: the identity
        gt[0] = gt[4] = gt[8] = 1.0
        params.GtMatrix_B = gt
        params.maxMtbDipoles = [1e300] * len(params.maxMtbDipoles)
        cmd = _messaging.MTBCmdMsgPayload()
        cmd.mtbDipoleCmds = [float(-mass * g * c) for c in com] + [0.0] * (len(cmd.mtbDipoleCmds) - 3)
        field = _messaging.MagneticFieldMsgPayload()
        field.magField_N = [0.0, 0.0, 1.0]
        msgs = (_messaging.MTBArrayConfigMsg().write(params), _messaging.MTBCmdMsg().write(cmd),
                _messaging.MagneticFieldMsg().write(field))
        mtb.mtbParamsInMsg.subscribeTo(msgs[0])
        mtb.mtbCmdInMsg.subscribeTo(msgs[1])
        mtb.magInMsg.subscribeTo(msgs[2])
        sc.addDynamicEffector(mtb)
        keep += [mtb, *msgs]
    if integrator == "rk4":
        integ = _svIntegrators.svIntegratorRK4(sc)
    else:
        if tol is None:
            raise ValueError("integrator='rkf78' needs tol (relTol = absTol)")
        integ = _svIntegrators.svIntegratorRKF78(sc)
        integ.relTol = float(tol)
        integ.absTol = float(tol)
    sc.setIntegrator(integ)
    keep.append(integ)
    sim.AddModelToTask("lgviPeerTask", sc)
    if mtb is not None:
        sim.AddModelToTask("lgviPeerTask", mtb)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(T_ns)
    start = time.perf_counter()
    sim.ExecuteSimulation()
    wall = time.perf_counter() - start
    state = sc.scStateOutMsg.read()
    R = np.asarray(_rbk.MRP2C(np.asarray(state.sigma_BN, dtype=np.float64))).T.copy()
    omega = np.asarray(state.omega_BN_B, dtype=np.float64).copy()
    del keep, mtb, sim
    return BasiliskRun(R=R, omega=omega, wall=wall, task_steps=T_ns // dt_ns, integrator=integrator)


def attitude_error(R_ref: np.ndarray, R: np.ndarray) -> float:
    """``|log(R_ref^T R)|`` in rad (``R`` rescaled first if it is a multiple of a rotation)."""
    from lgvi import so3

    R = np.asarray(R, dtype=np.float64)
    R = R / np.sqrt(np.trace(R.T @ R) / 3.0)
    return float(np.linalg.norm(so3.log(np.asarray(R_ref).T @ R)))


def check_conventions(T: float = 10.0, verbose: bool = True) -> dict[str, float]:
    """Prove the attitude conventions before any timing; raise if they are wrong.

    Free body ``J = diag(1, 2, 3)``, ``omega0 = (0.3, 1, 0.2)`` from a non-trivial ``R0``: Basilisk
    RK4 at ``dt = 1 ms`` against :func:`lgvi.exact.free_body_attitude`, and the 3D pendulum
    (inverted start, ``com = +0.3 e3`` with ``e3`` up, as in ``peers.py`` and
    ``time_to_accuracy.py``) against lgvi order 6 at ``h = 1e-4``. Both must agree to 1e-9 rad; the transposed reading of
    the DCM is printed to show that the check can fail.
    """
    _require()
    import lgvi
    from lgvi.verification.exact import free_body_attitude
    from lgvi.torques import UniformGravity

    out: dict[str, float] = {}
    R0 = lgvi.so3.exp(np.array([0.3, -0.5, 0.8]))
    J = np.array([1.0, 2.0, 3.0])
    w0 = np.array([0.3, 1.0, 0.2])
    bsk = run(J, R0, w0, T=T, dt=1e-3, integrator="rk4")
    R_ex = free_body_attitude(J, R0, J * w0, float(T))
    out["free body vs lgvi.exact"] = attitude_error(R_ex, bsk.R)
    out["free body, DCM read untransposed (wrong)"] = attitude_error(R_ex, bsk.R.T)

    Jp = np.array([0.13, 0.28, 0.17])
    wp = 4.14 * np.ones(3)
    com = np.array([0.0, 0.0, 0.3])
    Tp = min(T, 10.0)
    bsk = run(Jp, np.eye(3), wp, T=Tp, dt=1e-4, integrator="rk4", gravity=(1.0, com, 9.81))
    n = nanoseconds(Tp) // 100_000
    ref = lgvi.simulate(lgvi.RigidBody(Jp), np.eye(3), omega0=wp, h=Tp / n, steps=n, order=6,
                        torque=UniformGravity(1.0, com, 9.81), save_every=n)
    out["3D pendulum (inverted) vs lgvi order 6"] = attitude_error(ref.R[-1], bsk.R)
    if verbose:
        print(f"{version()}: convention check (T = {T:g} s free body, {Tp:g} s pendulum)")
        for k, v in out.items():
            print(f"  {k:<44} {v:.2e} rad")
    bad = {k: v for k, v in out.items() if "wrong" not in k and not v < 1e-9}
    if bad or not out["free body, DCM read untransposed (wrong)"] > 1e-3:
        raise AssertionError(f"Basilisk conventions check failed: {out}")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="convention check at a short horizon only")
    args = parser.parse_args(argv)
    if status() is not None:
        print(f"{status()}: skipping the Basilisk peer (pip install bsk, or lgvi[bench])")
        return 0
    check_conventions(T=2.0 if args.quick else 10.0)
    if args.quick:
        return 0
    from lgvi.verification.exact import free_body_attitude

    J = np.array([1.0, 2.0, 3.0])
    w0 = np.array([0.3, 1.0, 0.2])
    T = 100.0
    R_ex = free_body_attitude(J, np.eye(3), J * w0, T)
    print(f"\nfree body J = diag(1, 2, 3), omega0 = (0.3, 1, 0.2), T = {T:g} s")
    print(f"{'integrator':<10} {'dt s':>8} {'tol':>8} {'task steps':>11} {'error rad':>10} {'wall s':>8}")
    for integ, dt, tol in (("rk4", 0.01, None), ("rk4", 0.001, None), ("rkf78", 1.0, 1e-10), ("rkf78", 1.0, 1e-12)):
        r = run(J, np.eye(3), w0, T=T, dt=dt, integrator=integ, tol=tol)
        print(f"{integ:<10} {dt:>8g} {tol or float('nan'):>8.0e} {r.task_steps:>11d} "
              f"{attitude_error(R_ex, r.R):>10.2e} {r.wall:>8.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
