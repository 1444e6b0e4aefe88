"""Disturbance torques (and forces) as components of the compiled loop (``docs/environment.md``).

Each kind writes its own torque ``tau_<kind>_B`` (body frame, N m, recorded by name) and adds it
into ``tau_dist_B`` (which the loop zeroes before the disturbances run); the facet models also
write their force in the inertial frame, ``F_<kind>_N`` (N), for a loop that integrates the orbit.

* :class:`FacetDrag` (``"facet_drag"``, code 200): Basilisk's ``facetDragDynamicEffector``;
* :class:`FacetSRP` (``"facet_srp"``, code 201): Basilisk's ``facetSRPDynamicEffector``
  (absorbed, specular and diffuse fractions; the shadow's visible fraction scales it);
* :class:`ResidualDipole` (``"residual_dipole"``, code 202): ``m x B`` (Basilisk's ``MtbEffector``
  with a held dipole).

Every coefficient is an entry of the parameter row; give an array with a leading member axis
(``(B, N)`` areas, ``(B, N, 3)`` normals, ``(B, 3)`` dipoles, ...) for one row per member of an
ensemble: :meth:`params` then returns ``(B, P)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._kernels.environment_components import (FACET_DRAG, FACET_SRP, RESIDUAL_DIPOLE, facet_drag_step,
                                               facet_srp_step, residual_dipole_step)
from .._validation import as_float, as_float_array
from ..components import Component, ComponentKind, Signal, register_kind
from ..environment._evaluate import evaluate

__all__ = ["FacetDrag", "FacetSRP", "ResidualDipole", "SOLAR_FLUX", "SPEED_OF_LIGHT", "AU"]

#: Total solar irradiance at 1 AU (W/m^2, IAU 2015 nominal; Basilisk's facet SRP uses 1368).
SOLAR_FLUX = 1361.0
SPEED_OF_LIGHT = 299792458.0
AU = 149597870700.0
UNIT_TOL = 1e-9


def _members(arr: np.ndarray, base: int, name: str) -> np.ndarray:
    """``arr`` with a member axis in front: ``base`` is its dimension without one."""
    if arr.ndim == base:
        return arr[None]
    if arr.ndim == base + 1:
        return arr
    raise ValueError(f"{name} must have {base} dimensions (one value set) or {base + 1} (one row per member), "
                     f"got shape {arr.shape}")


def _facets(area: Any, normal: Any, centre: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validated (B, N) areas, (B, N, 3) unit normals, (B, N, 3) centres of pressure."""
    A = _members(as_float_array(area, "area"), 1, "area")
    n = _members(as_float_array(normal, "normal"), 2, "normal")
    c = _members(as_float_array(centre, "centre"), 2, "centre")
    if n.shape[-1] != 3 or c.shape[-1] != 3:
        raise ValueError(f"normal and centre must be (N, 3) arrays, got shapes {n.shape} and {c.shape}")
    if A.shape[-1] == 0:
        raise ValueError("area must hold at least one facet, got none")
    try:
        B = np.broadcast_shapes(A.shape[:1], n.shape[:1], c.shape[:1])[0]
        A = np.broadcast_to(A, (B, A.shape[-1]))
        n = np.broadcast_to(n, (B,) + n.shape[1:])
        c = np.broadcast_to(c, (B,) + c.shape[1:])
        if not A.shape[1] == n.shape[1] == c.shape[1]:
            raise ValueError
    except ValueError:
        raise ValueError(f"area (N,), normal (N, 3) and centre (N, 3) must describe the same facets, got shapes "
                         f"{A.shape}, {n.shape}, {c.shape}") from None
    bad = np.argwhere(~(A > 0.0))
    if bad.size:
        raise ValueError(f"area must be positive (m^2) for every facet, got {A[tuple(bad[0])]} at index "
                         f"{tuple(int(i) for i in bad[0])}")
    norm = np.linalg.norm(n, axis=-1)
    bad = np.argwhere(np.abs(norm - 1.0) > UNIT_TOL)
    if bad.size:
        i = tuple(int(k) for k in bad[0])
        raise ValueError(f"normal must be unit vectors (|n| = 1 within {UNIT_TOL:g}), got |n| = {norm[i]:.12g} at "
                         f"index {i}")
    return A, n, c


def _per_facet(value: Any, name: str, shape: tuple[int, int]) -> np.ndarray:
    """A number, one value per facet (N,) or per member and facet (B, N), broadcast to ``shape``
    (``(B, N)``, or ``(1, N)`` for facets given once: then a coefficient per member sets ``B``)."""
    x = as_float_array(value, name)
    x = x[None] if x.ndim == 1 else x
    try:
        B = np.broadcast_shapes(x.shape[:1] if x.ndim == 2 else (1,), shape[:1])[0]
        return np.broadcast_to(x, (B, shape[1]))
    except ValueError:
        raise ValueError(f"{name} must be a number or one value per facet (shape ({shape[1]},)) or per member and "
                         f"facet (shape (B, {shape[1]}), B = {shape[0]} where the facets are given per member), got "
                         f"shape {np.shape(value)}") from None


def _to_members(B: int, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """Each (1 or B, ...) array broadcast to B members."""
    return tuple(np.broadcast_to(a, (B,) + a.shape[1:]) for a in arrays)


def _fraction(value: Any, name: str, shape: tuple[int, int]) -> np.ndarray:
    x = _per_facet(value, name, shape)
    bad = np.argwhere(~((x >= 0.0) & (x <= 1.0)))
    if bad.size:
        raise ValueError(f"{name} must lie in [0, 1], got {x[tuple(bad[0])]} at index "
                         f"{tuple(int(i) for i in bad[0])}")
    return x


class _Disturbance(Component):
    rate: float | None = None

    def state0(self) -> np.ndarray:
        return np.zeros(0)

    def sizes(self) -> dict[str, int]:
        return {}

    def _row(self, rows: np.ndarray) -> np.ndarray:
        return rows[0] if self.members is None else rows

    def member(self, i: int) -> np.ndarray:
        """The parameter row of member ``i`` (0 without a member axis)."""
        rows = np.atleast_2d(self.params())
        return rows[i]


class FacetDrag(_Disturbance):
    r"""Drag on flat plates (Basilisk's ``facetDragDynamicEffector``).

    Parameters
    ----------
    area : (N,) array
        Facet areas (m^2), positive.
    normal : (N, 3) array
        Outward unit normals in the body frame.
    centre : (N, 3) array
        Centres of pressure in the body frame (m, from the centre of mass: lgvi's body frame is
        centred there; Basilisk's ``B_location`` is from its point B).
    drag_coefficient : float or (N,) array, or (B, N) one row per member
        ``Cd`` of each facet (positive; 2.2 is usual). Any argument may have a leading member axis
        (the others are then shared by the members).

    Notes
    -----
    With ``v`` the velocity relative to the atmosphere in the body frame and ``u = v / |v|``, a
    facet with ``n . u > 0`` feels ``F_i = -1/2 rho |v|^2 Cd_i A_i (n_i . u) u`` at ``c_i``;
    the torque is ``sum c_i x F_i``. Facets facing away feel nothing (no shadowing between facets).
    """
    normal: np.ndarray
    drag_coefficient: np.ndarray
    centre: np.ndarray
    area: np.ndarray

    kind = "facet_drag"

    def __init__(self, area: Any, normal: Any, centre: Any, drag_coefficient: Any = 2.2, *,
                 rate: float | None = None):
        A, n, c = _facets(area, normal, centre)
        Cd = _per_facet(drag_coefficient, "drag_coefficient", A.shape)
        A, n, c = _to_members(Cd.shape[0], A, n, c)        # a coefficient per member, the facets once
        bad = np.argwhere(~(Cd > 0.0))
        if bad.size:
            raise ValueError(f"drag_coefficient must be positive, got {Cd[tuple(bad[0])]}")
        self.members: Any | None = None if max(np.ndim(area) - 1, np.ndim(normal) - 2, np.ndim(centre) - 2,
                                   np.ndim(drag_coefficient) - 1) <= 0 else A.shape[0]
        self.area, self.normal, self.centre, self.drag_coefficient = A, n, c, Cd
        self.rate: float | None = None if rate is None else as_float(rate, "rate", positive=True)

    def __repr__(self) -> str:
        return f"FacetDrag({self.area.shape[1]} facets)"

    def params(self) -> np.ndarray:
        # per facet [Cd A, n, c]: the kernel's constants, computed once (_kernels.environment_components)
        B, N = self.area.shape
        per = np.concatenate([(self.drag_coefficient * self.area)[..., None], self.normal, self.centre],
                             axis=-1).reshape(B, 7 * N)
        return self._row(np.concatenate([np.full((B, 1), N), per], axis=1))

    def evaluate(self, R: Any, density: Any, v_rel_N: Any) -> dict[str, np.ndarray]:
        """Torque ``tau_facet_drag_B`` (n, 3) and force ``F_facet_drag_N`` (n, 3) (first member)."""
        return _first(self, R=R, density=density, v_rel_N=v_rel_N)


class FacetSRP(_Disturbance):
    r"""Solar radiation pressure on flat plates (Basilisk's ``facetSRPDynamicEffector``).

    Parameters
    ----------
    area, normal, centre : arrays
        As :class:`FacetDrag`.
    absorbed, specular, diffuse : float or (N,) array
        Fractions of the incoming light absorbed, reflected specularly and diffusely, each in
        [0, 1], summing to one per facet.
    solar_flux : float
        W/m^2 at 1 AU (1361; Basilisk's module uses 1368).

    Notes
    -----
    With ``s`` the unit vector to the sun and ``cos(th) = n . s > 0``:
    ``F = -P A cos(th) [(1 - specular) s + 2 (diffuse / 3 + specular cos(th)) n]``,
    ``P = shadow * solar_flux / c * (AU / d)^2``; the torque is ``sum c_i x F_i``.
    """
    members: Any | None
    specular: np.ndarray
    normal: np.ndarray
    diffuse: np.ndarray
    centre: np.ndarray
    area: np.ndarray
    absorbed: np.ndarray

    kind = "facet_srp"

    def __init__(self, area: Any, normal: Any, centre: Any, *, absorbed: Any, specular: Any, diffuse: Any,
                 solar_flux: float = SOLAR_FLUX, speed_of_light: float = SPEED_OF_LIGHT, au: float = AU,
                 rate: float | None = None):
        A, n, c = _facets(area, normal, centre)
        a = _fraction(absorbed, "absorbed", A.shape)
        s = _fraction(specular, "specular", A.shape)
        d = _fraction(diffuse, "diffuse", A.shape)
        B = max(x.shape[0] for x in (a, s, d))
        try:
            A, n, c, a, s, d = _to_members(B, A, n, c, a, s, d)
        except ValueError:
            raise ValueError(f"absorbed, specular and diffuse given per member must have the same members, got "
                             f"shapes {np.shape(absorbed)}, {np.shape(specular)}, {np.shape(diffuse)}") from None
        total = a + s + d
        bad = np.argwhere(np.abs(total - 1.0) > 1e-9)
        if bad.size:
            i = tuple(int(k) for k in bad[0])
            raise ValueError(f"absorbed + specular + diffuse must sum to one for every facet (within 1e-9), got "
                             f"{total[i]:.12g} at index {i}")
        self.members = None if max(np.ndim(area) - 1, np.ndim(normal) - 2, np.ndim(centre) - 2, np.ndim(absorbed) - 1,
                                   np.ndim(specular) - 1, np.ndim(diffuse) - 1) <= 0 else A.shape[0]
        self.area, self.normal, self.centre = A, n, c
        self.absorbed, self.specular, self.diffuse = a, s, d
        self.solar_flux: float = as_float(solar_flux, "solar_flux", positive=True)
        self.speed_of_light: float = as_float(speed_of_light, "speed_of_light", positive=True)
        self.au: float = as_float(au, "au", positive=True)
        self.rate: float | None = None if rate is None else as_float(rate, "rate", positive=True)

    def __repr__(self) -> str:
        return f"FacetSRP({self.area.shape[1]} facets)"

    def params(self) -> np.ndarray:
        # per facet [A (1 - specular), 2 A diffuse / 3, 2 A specular, n, c, c x n]: the kernel's
        # constants, computed once (_kernels.environment_components); the head's pressure at 1 AU
        # times AU^2, so that P = p[1] shadow / d^2
        B, N = self.area.shape
        A, spec, diff = self.area, self.specular, self.diffuse
        per = np.concatenate([(A * (1.0 - spec))[..., None], (2.0 * A * diff / 3.0)[..., None],
                              (2.0 * A * spec)[..., None], self.normal, self.centre,
                              np.cross(self.centre, self.normal)], axis=-1).reshape(B, 12 * N)
        head = np.tile([N, self.solar_flux / self.speed_of_light * self.au * self.au], (B, 1))
        return self._row(np.concatenate([head, per], axis=1))

    def evaluate(self, R: Any, sun_N: Any, sun_distance: Any, shadow: Any = 1.0) -> dict[str, np.ndarray]:
        """Torque ``tau_facet_srp_B`` (n, 3) and force ``F_facet_srp_N`` (n, 3) (first member).

        ``sun_N`` (3,) or (n, 3) is the direction to the sun in the inertial frame, of any nonzero
        length (it is normalised here: the compiled kernel takes the unit vector the loop's sun writes).
        """
        u = as_float_array(sun_N, "sun_N")
        if u.shape[-1:] != (3,):
            raise ValueError(f"sun_N must be a (3,) vector or (n, 3), got shape {u.shape}")
        norm = np.linalg.norm(u, axis=-1, keepdims=True)
        if not np.all(norm > 0.0):
            raise ValueError("sun_N must be a nonzero direction to the sun (every row), got a zero vector")
        return _first(self, R=R, sun_N=u / norm, sun_distance=sun_distance, shadow=shadow)


class ResidualDipole(_Disturbance):
    """A residual magnetic dipole ``m`` (A m^2, body frame): ``tau = m x R^T B_N``.

    Parameters
    ----------
    dipole : (3,) or (B, 3) array
    """

    kind = "residual_dipole"

    def __init__(self, dipole: Any, *, rate: float | None = None):
        m = _members(as_float_array(dipole, "dipole"), 1, "dipole")
        if m.shape[-1] != 3:
            raise ValueError(f"dipole must be a (3,) vector (A m^2) or (B, 3), got shape {np.shape(dipole)}")
        self.members: Any | None = None if np.ndim(dipole) == 1 else m.shape[0]
        self.dipole = m
        self.rate: float | None = None if rate is None else as_float(rate, "rate", positive=True)

    def __repr__(self) -> str:
        return f"ResidualDipole({self.dipole[0].tolist()})"

    def params(self) -> np.ndarray:
        return self._row(self.dipole.copy())

    def evaluate(self, R: Any, B_N: Any) -> dict[str, np.ndarray]:
        """Torque ``tau_residual_dipole_B`` (n, 3) (first member)."""
        return _first(self, R=R, B_N=B_N)


class _Row:
    """One member's row of a disturbance (what :func:`evaluate` runs)."""

    def __init__(self, model: _Disturbance, i: int):
        self.kind, self._p, self._s = model.kind, model.member(i), model.state0()

    def params(self) -> np.ndarray:
        return self._p

    def state0(self) -> np.ndarray:
        return self._s


def _first(model: _Disturbance, **signals: Any) -> dict[str, np.ndarray]:
    out = evaluate(_Row(model, 0), 0.0, **signals)
    out.pop("tau_dist_B")
    return out


def _own(name: str, force: bool) -> tuple[Signal, ...]:
    rows = [Signal(f"tau_{name}_B", 3, "N m", "B", f"torque of {name}")]
    if force:
        rows.append(Signal(f"F_{name}_N", 3, "N", "N", f"force of {name} (for an integrated orbit)"))
    return tuple(rows)


register_kind(ComponentKind("facet_drag", "disturbance", FACET_DRAG, facet_drag_step,
                            reads=("R", "density", "v_rel_N"),
                            writes=("tau_facet_drag_B", "tau_dist_B", "F_facet_drag_N"), cls=FacetDrag,
                            own=_own("facet_drag", True), doc="aerodynamic drag on flat plates"))
register_kind(ComponentKind("facet_srp", "disturbance", FACET_SRP, facet_srp_step,
                            reads=("R", "sun_N", "sun_distance", "shadow"),
                            writes=("tau_facet_srp_B", "tau_dist_B", "F_facet_srp_N"), cls=FacetSRP,
                            own=_own("facet_srp", True), doc="solar radiation pressure on flat plates"))
register_kind(ComponentKind("residual_dipole", "disturbance", RESIDUAL_DIPOLE, residual_dipole_step,
                            reads=("R", "B_N"), writes=("tau_residual_dipole_B", "tau_dist_B"), cls=ResidualDipole,
                            own=_own("residual_dipole", False), doc="residual magnetic dipole, m x B"))
