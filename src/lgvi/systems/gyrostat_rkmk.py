"""The gyrostat by an explicit, momentum-exact Runge-Kutta-Munthe-Kaas method (``scheme="rkmk4"``).

``lgvi.simulate(body, R0, omega0=..., h=..., steps=..., wheels=..., controller=...,
control_period=..., scheme="rkmk4")``: the same :class:`lgvi.systems.gyrostat.GyrostatTrajectory`
as the LGVI, stepped by a 4-stage, 4th-order Runge-Kutta method in Cayley coordinates of the
rotation over one step (derivation and measurements: ``docs/gyrostat_rkmk.md``; compiled kernel:
:mod:`lgvi._kernels.gyrostat_rk_kernels`). Explicit: no equation is solved, the records of solver
iterations and residuals are zero. ``R`` stays on SO(3) and, without a body torque, ``|Pi|`` and
the inertial momentum ``R Pi`` are kept to round-off under any wheel torques, friction and
saturation; a body torque (a controller without wheels, ``Command.torque``, magnetorquers) changes
``R Pi`` by exactly the integrated impulse. Not symplectic: with the motors off the energy drifts
(slowly, as ``h^4``) instead of staying bounded.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .gyrostat import GyrostatRun

_R5 = math.sqrt(5.0)
#: Explicit 4-stage tableaux of order 4: ``a21, a31, a32, a41, a42, a43, b1..b4, c2, c3, c4``.
TABLEAUS: dict[str, tuple[float, ...]] = {
    "rk4": (0.5, 0.0, 0.5, 0.0, 0.0, 1.0, 1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0, 0.5, 0.5, 1.0),
    "rk38": (1.0 / 3.0, -1.0 / 3.0, 1.0, 1.0, -1.0, 1.0, 0.125, 0.375, 0.375, 0.125, 1.0 / 3.0, 2.0 / 3.0, 1.0),
    # Ralston (1962), Math. Comp. 16, 431: the smallest bound on the leading error terms
    "ralston4": (0.4, (-2889.0 + 1428.0 * _R5) / 1024.0, (3785.0 - 1620.0 * _R5) / 1024.0,
                 (-3365.0 + 2094.0 * _R5) / 6040.0, (-975.0 - 3046.0 * _R5) / 2552.0,
                 (467040.0 + 203968.0 * _R5) / 240845.0, (263.0 + 24.0 * _R5) / 1812.0,
                 (125.0 - 1000.0 * _R5) / 3828.0, (3426304.0 + 1661952.0 * _R5) / 5924787.0,
                 (30.0 - 4.0 * _R5) / 123.0, 0.4, (14.0 - 3.0 * _R5) / 16.0, 1.0),
}
#: The tableau of ``scheme="rkmk4"`` unless ``composition=`` names another (``docs/gyrostat_rkmk.md``).
DEFAULT_TABLEAU = "rk4"
#: Largest ``|theta|`` of one step (Cayley coordinates; a rotation by ``2 atan(|theta| / 2)``, 90 degrees).
THETA_MAX = 2.0
#: Name of the scheme in ``lgvi.simulate(..., scheme=)``.
SCHEME = "rkmk4"


def quaternion_of(R: np.ndarray) -> np.ndarray:
    """The unit quaternion ``(w, x, y, z)`` (``w >= 0``) of a rotation matrix (Shepperd's method)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(R, dtype=np.float64).tolist()
    tr = r00 + r11 + r22
    if tr >= r00 and tr >= r11 and tr >= r22:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [0.25 * s, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s]
    elif r00 >= r11 and r00 >= r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        q = [(r21 - r12) / s, 0.25 * s, (r01 + r10) / s, (r02 + r20) / s]
    elif r11 >= r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        q = [(r02 - r20) / s, (r01 + r10) / s, 0.25 * s, (r12 + r21) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        q = [(r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, 0.25 * s]
    if q[0] < 0.0:
        q = [-x for x in q]
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return np.array([x / n for x in q])


def check_rkmk_options(*, torque: Any, order: Any, composition: Any) -> str:
    """The tableau name of ``scheme="rkmk4"``; refuses the options it does not take."""
    if torque is not None:
        raise ValueError(f"torque= is not available with scheme={SCHEME!r} (got {torque!r}): a compiled torque "
                         "model runs in the LGVI's loop only; give body torques through the controller "
                         "(Command.torque) or use scheme=None")
    if order not in (2, 4) or isinstance(order, bool):
        raise ValueError(f"order must be 4 (or left at its default) with scheme={SCHEME!r}: the scheme is a "
                         f"4th-order Runge-Kutta method; got {order!r}")
    name = DEFAULT_TABLEAU if composition is None else composition
    if not isinstance(name, str) or name not in TABLEAUS:
        raise ValueError(f"composition must be None or one of {sorted(TABLEAUS)} with scheme={SCHEME!r} (the "
                         f"Runge-Kutta tableau), got {composition!r}")
    return name


class GyrostatRKMKRun(GyrostatRun):
    """One validated run of the gyrostat by RKMK in Cayley coordinates (``scheme="rkmk4"``).

    The arguments are :class:`GyrostatRun`'s; ``order`` must be 4 (or the default 2, meaning
    "the scheme's order"), ``composition`` names the tableau (:data:`TABLEAUS`, default
    :data:`DEFAULT_TABLEAU`), ``torque`` must be ``None``; ``method``, ``tol``, ``max_iter`` are
    unused. The attitude is kept as a unit quaternion ``q`` between steps.
    """
    last_res: float
    last_its: int

    #: Not symplectic: no energy bound is declared with the motors off (its energy drifts).
    symplectic = False

    def __init__(self, body: Any, R0: Any, Pi0: Any, *, order: Any = 2, composition: Any = None, torque: Any = None,
                 **kwargs: Any) -> None:
        name = check_rkmk_options(torque=torque, order=order, composition=composition)
        super().__init__(body, R0, Pi0, **kwargs)
        self.tableau = name
        self.tab: np.ndarray = np.array(TABLEAUS[name], dtype=np.float64)
        self.q: np.ndarray = quaternion_of(self.R)
        self.qr: np.ndarray = np.zeros(5)             # the reference's quaternion, and whether its rates are not zero
        if self.ctrl == 1:
            from .._kernels.gyrostat_kernels import CP_J, CP_RREF, CP_WREF

            self.qr[:4] = quaternion_of(self.cp[CP_RREF:CP_RREF + 9].reshape(3, 3))
            self.qr[4] = float(np.any(self.cp[CP_WREF:CP_J] != 0.0))
        self.theta: float = 0.0
        self.meta.update(scheme=SCHEME, method=SCHEME, order=4, composition=name, tol=0.0, max_iter=0)

    def state(self) -> dict[str, Any]:
        """:meth:`GyrostatRun.state` with the attitude quaternion ``q``."""
        st = super().state()
        st["q"] = self.q.copy()
        return st

    def load_state(self, st: dict[str, Any]) -> None:
        super().load_state(st)
        self.q[...] = np.asarray(st["q"], dtype=np.float64) if "q" in st else quaternion_of(self.R)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = ""):
        from .._kernels.gyrostat_rk_kernels import CHART
        from ..errors import ConvergenceError

        if status != CHART:
            return super().failure(status, residual, iterations, trajectory, where)
        k = self.k
        t_fail = self.t0 + k * self.h
        msg = (f"step {k} (t = {t_fail:g}) failed: scheme={SCHEME!r} would rotate the body by "
               f"{math.degrees(2.0 * math.atan(self.theta / 2.0)):.4g} degrees in one step (Cayley coordinate "
               f"|theta| = {self.theta:.4g} > {THETA_MAX:g}, i.e. more than 90 degrees per step, where the chart "
               f"and the method's accuracy break down); reduce h. The run up to step {k} is in .trajectory." + where)
        return ConvergenceError(msg, residual=0.0, iterations=0, step=k, time=t_fail, trajectory=trajectory)

    def _kernel(self, k0: int, n: int, kb: int, R_out, Pi_out, rho_out, it_out, res_out, u_out) -> int:
        from .._kernels.gyrostat_rk_kernels import run_rkmk

        per = 1 if self.full else self.save_every
        status, k, theta = run_rkmk(self.tab, self.JB_inv, self.h, self.t0, self.q, self.R, self.Pi,
                                    self.wheel_momentum, self.wheels.axes, self.wp, self.cmd, self.tau, self.u_now,
                                    self.ctrl, self.cp, self.cs, self.qr, self.spc, k0, n, kb, self.save_every, per,
                                    THETA_MAX, R_out, Pi_out, rho_out, u_out, it_out, res_out, self.counts)
        self.k: int = int(k)
        self.theta = float(theta)
        self.last_its, self.last_res = 0, 0.0
        return int(status)


__all__ = ["DEFAULT_TABLEAU", "GyrostatRKMKRun", "SCHEME", "TABLEAUS", "THETA_MAX", "check_rkmk_options",
           "quaternion_of"]
