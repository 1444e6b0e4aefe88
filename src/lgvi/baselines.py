"""Classical baselines on the same problems: Euler's equations with quaternion kinematics.

State ``y = (q, Pi)`` with ``q`` a scalar-last unit quaternion (body to inertial) and ``Pi`` the
body angular momentum:

    dq/dt  = 1/2 q (x) (Omega, 0),      Omega = J^-1 Pi
    dPi/dt = Pi x Omega + u(t, R, Pi)

The quaternion is integrated as a vector in R^4 and *not* renormalised, so the attitude that
comes back, ``R = R(q)`` from the homogeneous formula (``|q|^2`` times a rotation), shows the
drift off SO(3) that a Runge-Kutta method accumulates; that is the honest comparison with the
LGVI, which stays on SO(3) by construction.
"""

from __future__ import annotations

import numpy as np

from ._validation import as_float, as_float_array, as_int, as_rotation
from ._version import __version__
from .trajectory import Trajectory


def quat_rhs(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """dq/dt for scalar-last ``q`` and body rate ``omega`` (vectorised over a leading axis)."""
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    a, b, c = omega[..., 0], omega[..., 1], omega[..., 2]
    return 0.5 * np.stack([w * a + y * c - z * b,
                           w * b + z * a - x * c,
                           w * c + x * b - y * a,
                           -(x * a + y * b + z * c)], axis=-1)


def homogeneous_matrix(q: np.ndarray) -> np.ndarray:
    """``R(q) = (w^2 - v.v) I + 2 v v^T + 2 w hat(v)``: ``|q|^2`` times the rotation of ``q``."""
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = w * w + x * x - y * y - z * z
    R[..., 1, 1] = w * w - x * x + y * y - z * z
    R[..., 2, 2] = w * w - x * x - y * y + z * z
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 1] = 2 * (y * z + w * x)
    return R


def solve_ivp_baseline(body, R0, Pi0=None, *, omega0=None, t_final: float, samples: int | None = 1001,
                       method: str = "RK45", rtol: float = 1e-6, atol: float = 1e-9,
                       torque=None) -> Trajectory:
    """Integrate the same problem with ``scipy.integrate.solve_ivp``.

    Parameters
    ----------
    body : RigidBody or array_like
    R0 : (3, 3) array_like
    Pi0, omega0 : (3,) array_like
        Initial body momentum or angular velocity (one of them).
    t_final : float
        Final time (> 0).
    samples : int or None
        Number of output times, evenly spaced on ``[0, t_final]``; ``None`` keeps every
        accepted step of the integrator.
    method : str
        Any ``solve_ivp`` method (``"RK45"``, ``"DOP853"``, ...).
    rtol, atol : float
        Tolerances passed to ``solve_ivp``.
    torque : callable, optional
        ``torque(t, R, Pi) -> (3,)`` body-frame moment.

    Returns
    -------
    Trajectory
        ``iterations`` holds the number of right-hand-side evaluations (one entry), ``residual``
        is empty; ``R`` is built from the unnormalised quaternion (see the module notes).
    """
    from scipy.integrate import solve_ivp
    from scipy.spatial.transform import Rotation

    from .integrator import _initial_momentum, as_body

    body = as_body(body)
    R0 = as_rotation(R0, "R0")
    Pi0 = _initial_momentum(body, Pi0, omega0)
    t_final = as_float(t_final, "t_final", positive=True)
    if samples is not None:
        samples = as_int(samples, "samples", minimum=2)
    J_inv = body.J_inv

    def rhs(t, y):
        q, Pi = y[:4], y[4:]
        omega = J_inv @ Pi
        dPi = np.cross(Pi, omega)
        if torque is not None:
            dPi = dPi + np.asarray(torque(t, homogeneous_matrix(q) / (q @ q), Pi), dtype=float)
        return np.concatenate([quat_rhs(q, omega), dPi])

    y0 = np.concatenate([Rotation.from_matrix(R0).as_quat(), Pi0])
    t_eval = None if samples is None else np.linspace(0.0, t_final, samples)
    sol = solve_ivp(rhs, (0.0, t_final), y0, method=method, t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"solve_ivp({method}) failed: {sol.message}")
    q = sol.y[:4].T
    return Trajectory(t=sol.t, R=homogeneous_matrix(q), Pi=as_float_array(sol.y[4:].T, "Pi"),
                      inertia=body.J.copy(), iterations=np.array([sol.nfev], dtype=np.int32),
                      residual=np.zeros(0), h=float("nan"),
                      meta={"method": f"solve_ivp:{method}", "rtol": rtol, "atol": atol,
                            "lgvi_version": __version__})


__all__ = ["homogeneous_matrix", "quat_rhs", "solve_ivp_baseline"]
