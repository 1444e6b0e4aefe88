"""Magnetorquer rods: a body dipole request mapped to the rods, saturated per rod, torque ``m x B``."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_float_array

__all__ = ["Magnetorquers"]


class Magnetorquers:
    r"""Magnetorquer rods fixed in the body, each with a dipole limit.

    Parameters
    ----------
    axes : array_like
        (N, 3) rod axes in the body frame, unit vectors (to 1e-6; used normalised), N >= 1.
    max_dipole : float or array_like
        Dipole limit of each rod, A m^2, > 0: a scalar for all rods or (N,).

    Notes
    -----
    A body-frame dipole request ``m_cmd`` (3,) goes to the rods by least squares,
    ``d = pinv(G) m_cmd`` with ``G = axes.T`` (3, N) (for three orthogonal rods, the components
    along them), each rod clipped to ``[-max_dipole, max_dipole]`` (as Basilisk's ``MtbEffector``
    does), and the body receives the torque ``(G d) x B_body``.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> rods = lgvi.Magnetorquers(np.eye(3), max_dipole=0.2)
    >>> rods.torque([1.0, 0.0, 0.0], [0.0, 3e-5, 0.0])      # the x rod saturates at 0.2 A m^2
    array([0.e+00, 0.e+00, 6.e-06])
    """

    def __init__(self, axes: Any, max_dipole: Any):
        axes = as_float_array(axes, "axes")
        if axes.ndim != 2 or axes.shape[1] != 3 or axes.shape[0] < 1:
            raise ValueError(f"axes must have shape (N, 3) with N >= 1 rods, got shape {axes.shape}")
        norms = np.linalg.norm(axes, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
        if bad.size:
            raise ValueError(f"axes must be unit vectors (|axis| = 1 to 1e-6); row {int(bad[0])} has norm "
                             f"{norms[bad[0]]:.9g}")
        m = as_float_array(max_dipole, "max_dipole")
        if m.ndim == 0:
            m = np.full(axes.shape[0], float(m))
        if m.shape != (axes.shape[0],):
            raise ValueError(f"max_dipole must be a scalar or have shape ({axes.shape[0]},) (one per rod), "
                             f"got shape {m.shape}")
        if np.any(m <= 0.0):
            raise ValueError(f"max_dipole must be > 0 A m^2 for every rod, got {m}")
        self.axes: Any = axes / norms[:, None]
        self.max_dipole = m
        self._pinv = np.linalg.pinv(self.axes.T)          # (N, 3)
        for a in (self.axes, self.max_dipole, self._pinv):
            a.setflags(write=False)

    def __repr__(self) -> str:
        return f"Magnetorquers({self.axes.shape[0]} rods, max_dipole={self.max_dipole.tolist()})"

    @property
    def count(self) -> int:
        """Number of rods N."""
        return int(self.axes.shape[0])

    def rod_dipoles(self, dipole_cmd: Any) -> np.ndarray:
        """Rod dipoles (N,), A m^2, for the body dipole request ``dipole_cmd`` (3,), saturated."""
        m = as_float_array(dipole_cmd, "dipole_cmd", (3,))
        return np.clip(self._pinv @ m, -self.max_dipole, self.max_dipole)

    def dipole(self, dipole_cmd: Any) -> np.ndarray:
        """The body dipole (3,) the rods produce for the request ``dipole_cmd`` (3,)."""
        return self.axes.T @ self.rod_dipoles(dipole_cmd)

    def torque(self, dipole_cmd: Any, B_body: Any) -> np.ndarray:
        """Body torque (3,), N m: ``dipole(dipole_cmd) x B_body`` with ``B_body`` (3,) in tesla."""
        B = as_float_array(B_body, "B_body", (3,))
        m = self.dipole(dipole_cmd)
        return np.array([m[1] * B[2] - m[2] * B[1], m[2] * B[0] - m[0] * B[2], m[0] * B[1] - m[1] * B[0]])
