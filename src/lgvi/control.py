"""Attitude controllers run at their own rate: ``lgvi.simulate(..., controller=, control_period=)``.

A controller is called every ``control_period`` (a multiple of the step ``h``) with the state at
that time and its output is held until the next call (zero-order hold). Between calls the step
loop stays compiled; :class:`MRPFeedback` is evaluated inside the compiled loop too.

The interface (a contract other modules build on):

* :class:`Controller`: ``command(t, R, omega, wheel_speed, env) -> Command`` and ``reset()``;
  ``setup(body, wheels)`` is called once before a run (the base class keeps both).
* :class:`Command`: ``torque`` (3,) a body torque applied directly (an ideal torquer), N m;
  ``wheel_torque`` (N,) wheel motor torques, N m (saturated as the wheels say); ``dipole`` (3,)
  a magnetic dipole request, A m^2, applied only with ``simulate(..., magnetorquers=...)``.
  Each may be ``None`` (nothing).
* ``env``: a dict with whatever ``simulate(..., environment=)`` gives at that time (its
  ``sample(t)``), plus ``"B_body"`` (3,) tesla when the sample holds ``"B_inertial"`` (3,), the
  field rotated into the body frame. Known keys: ``"B_body"``, ``"B_inertial"``, ``"r"`` (3,) m and
  ``"v"`` (3,) m/s inertial, ``"sigma_ref"`` (3,) the MRP of the reference frame relative to the
  inertial one (Basilisk's ``sigma_RN``), ``"omega_ref"`` (3,) and ``"domega_ref"`` (3,) its
  angular velocity and acceleration, inertial components, rad/s and rad/s^2.

Conventions: ``R`` maps body vectors to inertial ones (lgvi's), so Basilisk's DCM ``[BN]`` is
``R.T`` and its ``sigma_BN`` is :func:`mrp_from_matrix` of ``R`` (:func:`matrix_from_mrp` back).
"""

from __future__ import annotations

import math
from typing import Any, Callable, NamedTuple

import numpy as np

from ._validation import as_float, as_float_array, as_rotation
from .so3 import matrix_from_mrp, mrp_from_matrix  # noqa: F401  (lgvi.control's names of lgvi.so3's MRPs)

#: How far a wheel axis given to :func:`map_to_wheels` may be from unit length (as ``lgvi.ReactionWheels``).
AXIS_TOL = 1e-6


class Command(NamedTuple):
    """A controller's output, held until its next call.

    Attributes
    ----------
    torque : (3,) array_like or None
        Body torque applied directly, N m (body frame).
    wheel_torque : (N,) array_like or None
        Wheel motor torques, N m (positive spins the wheel up about its axis; the body gets the
        reaction). Saturated by :class:`lgvi.ReactionWheels` (torque, deadband, power, speed).
    dipole : (3,) array_like or None
        Magnetic dipole request, A m^2 (body frame), for ``simulate(..., magnetorquers=...)``.
    """

    torque: Any = None
    wheel_torque: Any = None
    dipole: Any = None


class Controller:
    """Base class of controllers (subclass it and write :meth:`command`).

    ``setup(body, wheels)`` is called by :func:`lgvi.simulate` before a run (it keeps both as
    ``self.body``, ``self.wheels``, ``wheels`` may be ``None``) and then :meth:`reset`.
    """

    body: Any = None
    wheels: Any = None

    def setup(self, body: Any, wheels: Any) -> None:
        """Called once before a run with the :class:`lgvi.RigidBody` and the wheels (or ``None``)."""
        self.body = body
        self.wheels = wheels

    def reset(self) -> None:
        """Forget any internal state (integrators, the last call's time). Called before a run."""

    def command(self, t: float, R: np.ndarray, omega: np.ndarray, wheel_speed: np.ndarray,
                env: dict[str, Any]) -> Command:
        """The command to hold from time ``t``.

        Parameters
        ----------
        t : float
            Time.
        R : (3, 3) ndarray
            Attitude (body to inertial).
        omega : (3,) ndarray
            Body angular velocity, rad/s (body frame).
        wheel_speed : (N,) ndarray
            Wheel speeds relative to the body, rad/s (empty without wheels).
        env : dict
            The environment at ``t`` (see the module docstring).

        Returns
        -------
        Command
        """
        raise NotImplementedError


# ------------------------------------------------------------------------------------------------
# modified Rodrigues parameters (Basilisk's attitude coordinates)
# ------------------------------------------------------------------------------------------------
def _mrp3(C: np.ndarray) -> np.ndarray:
    """:func:`mrp_from_matrix` of one (3, 3) matrix in scalar code (the controllers' hot path)."""
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = C.tolist()
    tr = c00 + c11 + c22
    if tr >= c00 and tr >= c11 and tr >= c22:
        s = math.sqrt(1.0 + tr) * 2.0
        w, x, y, z = 0.25 * s, (c21 - c12) / s, (c02 - c20) / s, (c10 - c01) / s
    elif c00 >= c11 and c00 >= c22:
        s = math.sqrt(1.0 + c00 - c11 - c22) * 2.0
        w, x, y, z = (c21 - c12) / s, 0.25 * s, (c01 + c10) / s, (c02 + c20) / s
    elif c11 >= c22:
        s = math.sqrt(1.0 + c11 - c00 - c22) * 2.0
        w, x, y, z = (c02 - c20) / s, (c01 + c10) / s, 0.25 * s, (c12 + c21) / s
    else:
        s = math.sqrt(1.0 + c22 - c00 - c11) * 2.0
        w, x, y, z = (c10 - c01) / s, (c02 + c20) / s, (c12 + c21) / s, 0.25 * s
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    return np.array([x, y, z]) / (1.0 + w)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def map_to_wheels(torque_request: Any, axes: Any) -> np.ndarray:
    """Wheel motor torques ``u`` (N,) whose reaction on the body is ``torque_request`` (3,).

    As Basilisk's ``rwMotorTorque`` with the body axes as control axes: the body receives
    ``-G u`` (``G`` = ``axes.T``, (3, N)), so ``u = -G^T (G G^T)^-1 L`` for three or more wheels
    spanning space; otherwise the least-squares minimum-norm ``u = -pinv(G) L``.
    """
    L = as_float_array(torque_request, "torque_request", (3,))
    a = as_float_array(axes, "axes")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"axes must have shape (N, 3) (one unit vector per wheel), got shape {a.shape}")
    norms = np.linalg.norm(a, axis=1)
    if np.any(np.abs(norms - 1.0) > AXIS_TOL):   # a zero axis would silently give no torque
        i = int(np.argmax(np.abs(norms - 1.0) > AXIS_TOL))
        raise ValueError(f"axes must be unit vectors (to {AXIS_TOL:g}), as lgvi.ReactionWheels takes them; axis {i} "
                         f"{a[i].tolist()} has norm {norms[i]:.9g}")
    G = a.T
    if G.shape[1] >= 3:
        M = G @ G.T
        if np.linalg.cond(M) < 1e12:
            return -(G.T @ np.linalg.solve(M, L))
    return -(np.linalg.pinv(G) @ L)


_WHEEL_MAPS: dict[bytes, np.ndarray] = {}


def _wheel_map(axes: np.ndarray) -> np.ndarray:
    """``map_to_wheels`` of the three body axes as columns (N, 3), the same numbers, ``cond`` once;
    remembered for the last few sets of axes (a new copy each call)."""
    a = np.ascontiguousarray(axes, dtype=np.float64)
    key = a.shape[0].to_bytes(4, "little") + a.tobytes()
    hit = _WHEEL_MAPS.get(key)
    if hit is None:
        hit = _wheel_map_of(a)
        if len(_WHEEL_MAPS) >= 8:
            _WHEEL_MAPS.pop(next(iter(_WHEEL_MAPS)))
        _WHEEL_MAPS[key] = hit
    return hit.copy()


def wheel_map(axes: Any) -> np.ndarray:
    """(N, 3) the map from a body torque request to wheel motor torques, one column per body axis:
    :func:`map_to_wheels` of the three body axes (the numbers :class:`MRPFeedback` uses)."""
    return _wheel_map(np.asarray(axes, dtype=np.float64))


def _wheel_map_of(axes: np.ndarray) -> np.ndarray:
    G = np.asarray(axes, dtype=np.float64).T
    if G.shape[1] >= 3:
        M = G @ G.T
        if np.linalg.cond(M) < 1e12:
            return np.stack([-(G.T @ np.linalg.solve(M, e)) for e in np.eye(3)], axis=1)
    return np.stack([map_to_wheels(e, axes) for e in np.eye(3)], axis=1)


def _reference_callable(target: Callable[[float], Any], t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    out = target(t)
    if isinstance(out, tuple):
        parts = list(out) + [None] * (3 - len(out))
        R_ref, w, dw = parts[:3]
    else:
        R_ref, w, dw = out, None, None
    R_ref = as_rotation(R_ref, "target(t)[0]")
    w = np.zeros(3) if w is None else as_float_array(w, "target(t)[1] (omega_ref)", (3,))
    dw = np.zeros(3) if dw is None else as_float_array(dw, "target(t)[2] (domega_ref)", (3,))
    return R_ref, w, dw


def _inertia_matrix(inertia: Any) -> np.ndarray:
    """The (3, 3) inertia a control law uses: symmetric positive definite, as a body's."""
    J = as_float_array(inertia, "inertia", (3, 3))
    if not np.allclose(J, J.T, rtol=1e-12, atol=1e-12 * float(np.abs(J).max())):
        raise ValueError(f"inertia must be a symmetric (3, 3) matrix, got {J.tolist()}")
    eig = np.linalg.eigvalsh(J)
    if not eig[0] > 0.0:
        raise ValueError(f"inertia must be positive definite (an inertia matrix); got eigenvalues {eig.tolist()}")
    return J


class MRPFeedback(Controller):
    """MRP feedback with the semantics of Basilisk's ``mrpFeedback`` (and ``rwMotorTorque``).

    With the tracking errors ``sigma = sigma_BR`` (MRP of ``R_ref^T R``), ``dw = omega - omega_r``
    (``omega_r`` the reference rate in the body frame), ``J`` the body's (locked) inertia and
    ``h_s`` the wheels' absolute axial momenta, the requested body torque is

        L = -(K sigma + P dw + P Ki z - (omega_r + Ki z) x (J omega + G h_s)
              + J (omega x omega_r - domega_r))

    with the integral term ``z = int_sigma + J dw``, ``int_sigma`` the sum of ``K sigma dt`` over
    the calls (``dt`` the time since the last call, 0 at the first and, as in Basilisk, at the call
    after one at ``t = 0``: Basilisk's prior call time 0 means "no prior call"), each component
    clipped to ``integral_limit``; ``z = 0`` without ``Ki``. With wheels the request is mapped to wheel motor
    torques by :func:`map_to_wheels` (``rwMotorTorque``) and the wheels' saturation applies;
    without wheels it is applied as a body torque.

    Parameters
    ----------
    K : float
        Attitude gain, N m (> 0).
    P : float
        Rate gain, N m s (> 0).
    Ki : float, optional
        Integral gain, 1/s (> 0); ``None`` (default) turns the integral term off (Basilisk: ``Ki < 0``).
    integral_limit : float, optional
        Bound of each component of ``int_sigma`` (> 0); ``None``: unbounded.
    target : None, (3, 3) array_like, scipy Rotation or callable
        The reference attitude ``R_ref`` (reference frame to inertial): ``None`` the identity, or
        the environment's ``"sigma_ref"`` (and ``"omega_ref"``, ``"domega_ref"``) when it gives
        one; a fixed rotation; or a profile ``target(t)`` returning ``R_ref`` or ``(R_ref,
        omega_ref)`` or ``(R_ref, omega_ref, domega_ref)``, rates in inertial components.
    inertia : (3, 3) array_like, optional
        The inertia the law uses (Basilisk's ``ISCPntB_B``); default the body's.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> ctrl = lgvi.control.MRPFeedback(K=3.5, P=30.0)
    >>> ctrl.setup(lgvi.RigidBody([900.0, 800.0, 600.0]), None)
    >>> cmd = ctrl.command(0.0, np.eye(3), np.array([0.0, 0.0, 0.01]), np.zeros(0), {})
    >>> np.allclose(cmd.torque, [0.0, 0.0, -0.3])
    True
    """

    def __init__(self, K: float, P: float, *, Ki: float | None = None, integral_limit: float | None = None,
                 target: Any = None, inertia: Any = None) -> None:
        self.K = as_float(K, "K", positive=True)
        self.P = as_float(P, "P", positive=True)
        self.Ki: float | None = None if Ki is None else as_float(Ki, "Ki", positive=True)
        self.integral_limit: float = (np.inf if integral_limit is None
                               else as_float(integral_limit, "integral_limit", positive=True))
        if integral_limit is not None and Ki is None:
            raise ValueError("integral_limit bounds the integral term: give Ki too (or leave integral_limit=None)")
        self.target = target
        self.R_ref: np.ndarray | None = None
        if target is not None and not callable(target):
            self.R_ref = as_rotation(target, "target")
        self._inertia = None if inertia is None else _inertia_matrix(inertia)
        self.J = self._inertia if self._inertia is not None else np.zeros((3, 3))
        self.axes: np.ndarray = np.zeros((0, 3))
        self.spin_inertia: np.ndarray = np.zeros(0)
        self.wheel_map: np.ndarray = np.zeros((0, 3))
        self.reset()

    # -------------------------------------------------------------- run set-up
    def setup(self, body: Any, wheels: Any) -> None:
        super().setup(body, wheels)
        self.J = self._inertia if self._inertia is not None else np.array(body.J, dtype=np.float64)
        if wheels is None:
            self.axes, self.spin_inertia = np.zeros((0, 3)), np.zeros(0)
        else:
            self.axes, self.spin_inertia = wheels.axes.copy(), wheels.spin_inertia.copy()
        # (N, 3): torque request -> wheel motor torques (rwMotorTorque), one column per body axis
        self.wheel_map = _wheel_map(self.axes)

    def reset(self) -> None:
        self.int_sigma: np.ndarray = np.zeros(3)
        self.prior_time: float | None = None

    @property
    def compiled(self) -> bool:
        """Whether the compiled loop evaluates this law (a fixed or absent reference: yes)."""
        return type(self) is MRPFeedback and not callable(self.target)

    # -------------------------------------------------------------- the law
    def reference(self, t: float, env: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R_ref (3, 3), omega_ref (3,), domega_ref (3,))`` at ``t``, rates in inertial components."""
        if callable(self.target):
            return _reference_callable(self.target, t)
        zero = np.zeros(3)
        if self.R_ref is not None:
            return self.R_ref, zero, zero
        if "sigma_ref" in env:
            R_ref = matrix_from_mrp(as_float_array(env["sigma_ref"], "env['sigma_ref']", (3,)))
            w = env.get("omega_ref")
            dw = env.get("domega_ref")
            return (R_ref, zero if w is None else as_float_array(w, "env['omega_ref']", (3,)),
                    zero if dw is None else as_float_array(dw, "env['domega_ref']", (3,)))
        return np.eye(3), zero, zero

    def torque_request(self, t: float, R: np.ndarray, omega: np.ndarray, wheel_speed: np.ndarray,
                       env: dict[str, Any]) -> np.ndarray:
        """The body torque ``L`` (3,) the law asks for (Basilisk's ``torqueRequestBody``)."""
        R_ref, w_ref_N, dw_ref_N = self.reference(t, env)
        sigma = _mrp3(R_ref.T @ R)
        BN = R.T
        w_r = BN @ w_ref_N
        dw_r = BN @ dw_ref_N
        dw = omega - w_r
        # Basilisk's mrpFeedback takes a prior call time of 0 for "no prior call": dt = 0 then too
        dt = 0.0 if self.prior_time is None or self.prior_time == 0.0 else t - self.prior_time
        self.prior_time = t
        J = self.J
        z = np.zeros(3)
        Ki = 0.0 if self.Ki is None else self.Ki
        if self.Ki is not None:
            self.int_sigma = np.clip(self.int_sigma + self.K * dt * sigma, -self.integral_limit, self.integral_limit)
            z = self.int_sigma + J @ dw
        L = self.K * sigma + self.P * dw + self.P * Ki * z
        H = J @ omega
        if len(self.spin_inertia):
            H = H + self.axes.T @ (self.spin_inertia * (self.axes @ omega + wheel_speed))
        L = L - _cross(w_r + Ki * z, H)
        L = L + J @ (_cross(omega, w_r) - dw_r)
        return -L

    def command(self, t: float, R: np.ndarray, omega: np.ndarray, wheel_speed: np.ndarray,
                env: dict[str, Any]) -> Command:
        L = self.torque_request(t, R, omega, wheel_speed, env)
        if len(self.spin_inertia):
            return Command(wheel_torque=self.wheel_map @ L)
        return Command(torque=L)

    def __repr__(self) -> str:
        return (f"MRPFeedback(K={self.K:g}, P={self.P:g}, Ki={self.Ki!r}, "
                f"integral_limit={self.integral_limit:g})")


class RotationPD(Controller):
    """A proportional-derivative law on the rotation error (Python, called at the control rate).

    ``L = -kp e - kd (omega - R^T omega_ref)`` with ``e`` the attitude error of ``R_ref^T R``: its
    rotation vector (``error="rotation"``, the log map) or twice the vector part of its quaternion
    with non-negative scalar part (``error="quaternion"``). With wheels ``L`` is mapped to wheel
    motor torques as :class:`MRPFeedback` does; without, applied as a body torque.

    Parameters
    ----------
    kp, kd : float
        Gains, N m / rad and N m s / rad (> 0).
    target : None, (3, 3) array_like, scipy Rotation or callable
        As :class:`MRPFeedback` (``None``: the identity or the environment's ``"sigma_ref"``).
    error : {"rotation", "quaternion"}
    """

    def __init__(self, kp: float, kd: float, *, target: Any = None, error: str = "rotation") -> None:
        self.kp: float = as_float(kp, "kp", positive=True)
        self.kd: float = as_float(kd, "kd", positive=True)
        if error not in ("rotation", "quaternion"):
            raise ValueError(f"error must be 'rotation' or 'quaternion', got {error!r}")
        self.error = error
        self._law = MRPFeedback(1.0, 1.0, target=target)

    def setup(self, body: Any, wheels: Any) -> None:
        super().setup(body, wheels)
        self._law.setup(body, wheels)

    def command(self, t: float, R: np.ndarray, omega: np.ndarray, wheel_speed: np.ndarray,
                env: dict[str, Any]) -> Command:
        from .so3 import log

        R_ref, w_ref, _ = self._law.reference(t, env)
        C = R_ref.T @ R
        if self.error == "rotation":
            e = log(C)
        else:
            s = _mrp3(C)                        # sigma = q / (1 + q4): q = 2 sigma / (1 + |sigma|^2)
            e = 4.0 * s / (1.0 + s @ s)
        L = -self.kp * e - self.kd * (omega - R.T @ w_ref)
        if len(self._law.spin_inertia):
            return Command(wheel_torque=self._law.wheel_map @ L)
        return Command(torque=L)

    def __repr__(self) -> str:
        return f"RotationPD(kp={self.kp:g}, kd={self.kd:g}, error={self.error!r})"


__all__ = ["Command", "Controller", "MRPFeedback", "RotationPD", "map_to_wheels", "matrix_from_mrp", "mrp_from_matrix", "wheel_map"]
