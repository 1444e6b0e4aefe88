"""Magnetic control laws: B-dot detumbling and magnetic momentum dumping (:class:`lgvi.control.Controller`s).

Both read the field in the body frame from the environment (``env["B_body"]``, tesla, or
``R.T @ env["B_inertial"]``) and return a dipole request (``Command.dipole``, A m^2, body frame)
that :class:`lgvi.Magnetorquers` maps to its rods.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_float, as_float_array, choice
from ..control import Command, Controller

__all__ = ["BDot", "MomentumDumping", "field_in_body"]


def field_in_body(R: np.ndarray, env: dict[str, Any]) -> np.ndarray:
    """``env["B_body"]``, else ``R.T @ env["B_inertial"]`` (3,), tesla; KeyError naming both if neither."""
    if "B_body" in env:
        return as_float_array(env["B_body"], "env['B_body']", (3,))
    if "B_inertial" in env:
        return np.asarray(R).T @ as_float_array(env["B_inertial"], "env['B_inertial']", (3,))
    raise KeyError("this controller needs the magnetic field: give simulate(..., environment=...) an environment "
                   "whose sample(t) holds 'B_inertial' (e.g. lgvi.environment.OrbitEnvironment(orbit, field=IGRF()))")


class BDot(Controller):
    r"""B-dot detumbling: the dipole ``m = -k dB/dt`` (body frame).

    Parameters
    ----------
    gain : float
        ``k`` > 0, A m^2 s / T.
    derivative : {"difference", "rate"}
        ``"difference"`` (default): ``dB/dt`` by the backward difference of the body-frame field
        between two controller calls (the first call commands nothing); ``"rate"``:
        ``dB/dt = -omega x B`` from the measured rate (the field's own change along the orbit
        neglected), so ``m = k omega x B``.

    Notes
    -----
    With ``m = k omega x B`` the magnetic torque ``m x B = -k (omega_perp |B|^2)`` removes the
    rate across the field: the rotational energy ``omega . J omega / 2`` never increases.
    """

    def __init__(self, gain: float, *, derivative: str = "difference"):
        self.gain: float = as_float(gain, "gain", positive=True)
        self.derivative: str = choice(derivative, "derivative", ("difference", "rate"))
        self.reset()

    def reset(self) -> None:
        self._last: tuple[float, np.ndarray] | None = None

    def command(self, t: float, R: np.ndarray, omega: np.ndarray, wheel_speed: np.ndarray,
                env: dict[str, Any]) -> Command:
        B = field_in_body(R, env)
        if self.derivative == "rate":
            return Command(dipole=self.gain * np.cross(np.asarray(omega, dtype=np.float64), B))
        last, self._last = self._last, (float(t), B)
        if last is None or t == last[0]:
            return Command(dipole=np.zeros(3))
        return Command(dipole=-self.gain * (B - last[1]) / (t - last[0]))

    def __repr__(self) -> str:
        return f"BDot(gain={self.gain:g}, derivative={self.derivative!r})"


class MomentumDumping(Controller):
    r"""Magnetic momentum dumping beside an attitude controller.

    Parameters
    ----------
    gain : float
        ``k`` > 0, 1/s.
    controller : Controller, optional
        The attitude controller whose ``torque`` and ``wheel_torque`` are passed on (e.g.
        :class:`lgvi.control.MRPFeedback`); without it only the dipole is commanded.
    wheels : lgvi.ReactionWheels, optional
        Default: the wheels of the run (``setup``). Needs ``axes`` (N, 3) and ``spin_inertia`` (N,).

    Notes
    -----
    With ``h`` the wheels' angular momentum in the body frame (``Js_i (a_i . omega + Omega_i)
    a_i`` summed), the dipole ``m = -k (B x h) / |B|^2 = k (h x B) / |B|^2`` gives the torque
    ``m x B = -k h_perp`` (``h_perp`` the part of ``h`` across the field): an external torque that
    the attitude controller passes to the wheels, so ``h_perp`` decays at the rate ``k``. The
    part of ``h`` along ``B`` cannot be dumped at that instant.
    """

    def __init__(self, gain: float, *, controller: Controller | None = None, wheels: Any = None):
        self.gain: float = as_float(gain, "gain", positive=True)
        if controller is not None and not isinstance(controller, Controller):
            raise TypeError(f"controller must be an lgvi.control.Controller, got {type(controller).__name__}")
        self.controller = controller
        self._wheels = wheels

    def setup(self, body: Any, wheels: Any) -> None:
        super().setup(body, wheels)
        if self.controller is not None:
            self.controller.setup(body, wheels)

    def reset(self) -> None:
        if self.controller is not None:
            self.controller.reset()

    def wheel_momentum(self, omega: Any, wheel_speed: Any) -> np.ndarray:
        """The wheels' angular momentum (3,), body frame, N m s."""
        wheels = self._wheels if self._wheels is not None else self.wheels
        if wheels is None:
            raise ValueError("MomentumDumping needs wheels: run it with simulate(..., wheels=...) or pass wheels=")
        axes = np.asarray(wheels.axes, dtype=np.float64)
        Js = np.asarray(wheels.spin_inertia, dtype=np.float64)
        rho = Js * (axes @ np.asarray(omega, dtype=np.float64) + np.asarray(wheel_speed, dtype=np.float64))
        return axes.T @ rho

    def command(self, t: float, R: np.ndarray, omega: np.ndarray, wheel_speed: np.ndarray,
                env: dict[str, Any]) -> Command:
        B = field_in_body(R, env)
        hw = self.wheel_momentum(omega, wheel_speed)
        b2 = float(B @ B)
        dipole = np.zeros(3) if b2 == 0.0 else -self.gain * np.cross(B, hw) / b2
        inner = Command() if self.controller is None else self.controller.command(t, R, omega, wheel_speed, env)
        return Command(torque=inner.torque, wheel_torque=inner.wheel_torque, dipole=dipole)

    def __repr__(self) -> str:
        return f"MomentumDumping(gain={self.gain:g}, controller={self.controller!r})"
