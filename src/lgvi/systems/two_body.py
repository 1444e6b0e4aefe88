r"""Two rigid bodies in mutual gravity (the full two-body problem): :func:`simulate_two_body`.

The Lie group variational integrator of Lee, Leok and McClamroch (Comput. Methods Appl. Mech.
Engrg. 196, 2007) in inertial coordinates: each body's orbit by the explicit variational
(Verlet) update, its attitude by the LGVI, one evaluation of the mutual potential per step
(:mod:`lgvi._kernels.two_body_kernels`; derivation in ``docs/orbit.md``). The mutual potential is

* ``"order2"``: truncated at second order in the bodies' size over their distance (MacCullagh:
  the point-mass term and each body's second moments in the other's point-mass field);
* ``"order4"``: through fourth order (third and fourth moments of each body and the cross term of
  the two second moments); bodies given as :class:`Ellipsoid`, :class:`Polyhedron` or
  :class:`PointMasses`;
* ``"points"``: exact for bodies made of point masses (:class:`PointMasses`), the pairwise sum.

Invariants: total linear momentum ``p1 + p2`` and total angular momentum
``x1 x p1 + x2 x p2 + R1 Pi1 + R2 Pi2`` to round-off (the discrete Lagrangian is invariant under
translations and rotations of the inertial frame); the energy bounded.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from .._kernels.codes import COLLISION, NOT_FINITE, OVERFLOW
from .._validation import as_float_array, as_rotation, choice
from ..accuracy import check_options, with_estimate
from .._version import __version__
from ..body import RigidBody
from ..errors import InitialContactError
from ..driver import MemorySink, Progress, check_memory, drive, initial_momentum, time_grid
from ..invariants import BOUNDED, EXACT
from . import CarriedState, Field, System, register
from .orbit import estimate_of, load_result_npz, positive_number, save_result_npz

#: The body arrays a result keeps (``TwoBodyTrajectory.moments``).
MOMENT_KEYS = ("S", "T3", "T4", "Q1", "w1", "Q2", "w2")

CHUNK_STEPS = 1 << 18
#: Mutual potentials by name (kernel codes).
POTENTIALS = {"order2": 0, "order4": 1, "points": 2}
#: ``potential=`` of :func:`simulate_two_body` as a type (the keys of ``POTENTIALS``).
TwoBodyPotential = Literal["order2", "order4", "points"]
FORMAT = "lgvi.two_body/1"


def _invariants(config: Any) -> dict[str, dict[str, Any]]:
    return {"angular_momentum": {"kind": EXACT}, "linear_momentum": {"kind": EXACT}, "energy": {"kind": BOUNDED}}


def _kernels() -> dict[str, Any]:
    from .._kernels import two_body_kernels

    return {"run_two_body": two_body_kernels.run_two_body, "mutual_force": two_body_kernels.mutual_force}


TWO_BODY = register(System(
    name="two_body",
    doc="two rigid bodies in mutual gravity: positions x (2, 3), momenta p (2, 3), attitudes R (2, 3, 3), "
        "body momenta Pi (2, 3)",
    state=(Field("x", (2, 3), doc="centres of mass, inertial"),
           Field("p", (2, 3), doc="linear momenta, inertial"),
           Field("R", (2, 3, 3), doc="attitudes, body to inertial"),
           Field("Pi", (2, 3), doc="body angular momenta")),
    records=(Field("iterations", (), np.int32, "largest solver iterations (both bodies) per saved interval"),
             Field("residual", (), np.float64, "largest final solver residual per saved interval")),
    kernels=_kernels,
    results=("t", "x", "p", "R", "Pi", "iterations", "residual", "h", "meta"),
    scenario_section="two_body",
    run_factory=None,
    invariants=_invariants,
    from_stream=lambda meta, arrays, state: _from_stream(meta, arrays, state),
))


# ------------------------------------------------------------------------------------------------
# bodies: shapes that carry their higher moments
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Ellipsoid:
    """A solid homogeneous ellipsoid with semi-axes ``a, b, c`` along its body axes (the mass is
    given to :func:`simulate_two_body`). Its second and fourth moments are exact; its odd
    moments vanish."""

    a: float
    b: float
    c: float

    def __post_init__(self) -> None:
        for name in ("a", "b", "c"):
            object.__setattr__(self, name, positive_number(getattr(self, name), f"Ellipsoid {name}"))

    def moments(self, mass: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(S (3,3), T3 (3,3,3), T4 (3,3,3,3))``: ``int r r^T dm`` and the third, fourth moments."""
        ax = np.array([self.a, self.b, self.c])
        S = np.diag(mass * ax ** 2 / 5.0)
        T4 = np.zeros((3, 3, 3, 3))
        for i in range(3):
            T4[i, i, i, i] = 3.0 * mass * ax[i] ** 4 / 35.0
            for j in range(3):
                if i != j:
                    v = mass * ax[i] ** 2 * ax[j] ** 2 / 35.0
                    T4[i, i, j, j] = T4[i, j, i, j] = T4[i, j, j, i] = v
        return S, np.zeros((3, 3, 3)), T4


def _simplex_weights(n: int) -> np.ndarray:
    """``W[i1..in] = E[l_i1 ... l_in]`` (3,)*n for barycentric coordinates ``l`` uniform on a
    tetrahedron (``E[prod l^k] = 3! prod k! / (n + 3)!``), over the three vertices other than the apex."""
    from math import factorial

    W = np.zeros((3,) * n)
    for idx in np.ndindex(*W.shape):
        counts = np.bincount(np.array(idx, dtype=np.int64), minlength=3)
        W[idx] = 6.0 * np.prod([factorial(int(k)) for k in counts]) / factorial(n + 3)
    return W


def _cone_moments(P: np.ndarray, vol: np.ndarray, n: int) -> np.ndarray:
    """``sum_t int_{tet(0, P_t)} x^(n) dV`` (3,)*n: the tetrahedra from the origin to the faces ``P`` (m, 3, 3)
    with signed volumes ``vol`` (m,), exactly (the monomials' means over a tetrahedron)."""
    from itertools import permutations

    verts, coords = "abcd"[:n], "ijkl"[:n]
    Y = vol.reshape((-1,) + (1,) * n) * _simplex_weights(n)          # (m, 3, ..., 3)
    for k in range(n - 1, -1, -1):                                    # one vertex index at a time
        sub = verts[:k + 1] + coords[k + 1:]
        Y = np.einsum(f"t{sub},t{verts[k]}{coords[k]}->t{sub[:k]}{coords[k]}{coords[k + 1:]}", Y, P)
    M = Y.sum(axis=0)
    perms = list(permutations(range(n)))
    M = sum(np.transpose(M, p) for p in perms) / len(perms)
    for idx in np.ndindex(*M.shape):             # symmetric to the last bit
        M[idx] = M[tuple(sorted(idx))]
    return M


class Polyhedron:
    """A solid homogeneous polyhedron: a closed triangle mesh, its faces oriented outward.

    Its volume, centre of mass, inertia and its mass moments through fourth order are exact (the
    monomials integrated over the tetrahedra from the centre of mass to the faces, see
    ``docs/orbit.md``). The body frame is the mesh's frame moved to the centre of mass (the axes are
    not turned to the principal axes).

    Parameters
    ----------
    vertices : (n, 3) array_like
        Vertex positions (any origin: the centre of mass is found); vertices used by no face are ignored.
    faces : (m, 3) array_like of int
        Triangles as vertex indices, counter-clockwise seen from outside. The surface must be closed and
        consistently oriented (every edge used by exactly two faces, once in each direction), with no
        zero-area face, enclosing a positive volume. Self-intersection is not checked.
    mass, density : float, optional
        At most one, ``> 0``: the mass, or the density (then ``mass = density * volume``). With neither,
        the mass is given to :func:`simulate_two_body` (``m1``/``m2``), as for :class:`Ellipsoid`.

    Attributes
    ----------
    vertices : (n, 3) ndarray
        As given (float64).
    faces : (m, 3) ndarray of int64
        As given.
    volume : float
        The enclosed volume.
    center_of_mass : (3,) ndarray
        In the frame of ``vertices``.
    mass : float or None
        From ``mass`` or ``density`` (``None`` with neither).

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> tet = lgvi.Polyhedron(np.eye(4, 3, -1), [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], density=6.0)
    >>> round(tet.volume, 12), tet.center_of_mass.tolist()
    (0.166666666667, [0.25, 0.25, 0.25])
    """

    def __init__(self, vertices: Any, faces: Any, *, mass: Any = None, density: Any = None) -> None:
        V = as_float_array(vertices, "vertices", (None, 3))
        F = np.asarray(faces)
        if F.dtype == object or not (np.issubdtype(F.dtype, np.integer) and F.dtype != np.bool_):
            raise TypeError(f"faces must be an array of integer vertex indices, got dtype {F.dtype}")
        if F.ndim != 2 or F.shape[1] != 3 or len(F) < 4:
            raise ValueError(f"faces must have shape (m, 3) with m >= 4 triangles (a closed surface), got shape "
                             f"{F.shape}")
        F = F.astype(np.int64)
        n = len(V)
        if F.min() < 0 or F.max() >= n:
            bad = int(F[(F < 0) | (F >= n)][0])
            raise ValueError(f"faces must index the {n} vertices (0 <= index < {n}), got index {bad}")
        same = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 2] == F[:, 0])
        if same.any():
            k = int(np.argmax(same))
            raise ValueError(f"faces must be triangles of three distinct vertices, face {k} is {F[k].tolist()}")
        # closed and consistently oriented: every directed edge once, and its reverse once
        e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        key = e[:, 0] * n + e[:, 1]
        uniq, counts = np.unique(key, return_counts=True)
        if (counts > 1).any():
            i, j = divmod(int(uniq[np.argmax(counts > 1)]), n)
            fs = np.nonzero(key == i * n + j)[0] % len(F)
            raise ValueError(f"faces must be consistently oriented (every edge used once in each direction): "
                             f"edge ({i}, {j}) is used in the same direction by faces {sorted(fs.tolist())} "
                             "(a flipped face, or more than two faces on an edge)")
        missing = ~np.isin(e[:, 1] * n + e[:, 0], uniq)
        if missing.any():
            a = int(np.argmax(missing))
            raise ValueError(f"faces must form a closed surface (every edge used once in each direction): edge "
                             f"({int(e[a, 0])}, {int(e[a, 1])}) of face {a % len(F)} has no face using "
                             f"({int(e[a, 1])}, {int(e[a, 0])}) (a hole, or a flipped neighbour)")
        used = np.unique(F)
        ref = V[used].mean(axis=0)
        size = float(np.linalg.norm(V[used].max(axis=0) - V[used].min(axis=0)))
        P = V[F] - ref
        area = 0.5 * np.linalg.norm(np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
        if not area.min() > 1e-12 * size ** 2:
            k = int(np.argmin(area))
            raise ValueError(f"faces must not be degenerate: face {k} (vertices {F[k].tolist()}) has area "
                             f"{area[k]:.3g} (its vertices are collinear or coincide)")
        vol = np.linalg.det(P) / 6.0
        volume = float(vol.sum())
        if volume < 0.0 and abs(volume) > 1e-12 * size ** 3:
            raise ValueError(f"faces must be oriented outward (counter-clockwise seen from outside): the enclosed "
                             f"signed volume is {volume:.6g} < 0 (reverse every face's vertex order)")
        if not volume > 1e-12 * size ** 3:
            raise ValueError(f"vertices and faces must enclose a positive volume, got {volume:.3g} (a flat mesh)")
        com = ref + _cone_moments(P, vol, 1) / volume
        if mass is not None and density is not None:
            raise ValueError(f"give mass or density of the Polyhedron, not both (got mass={mass!r}, "
                             f"density={density!r})")
        if mass is not None:
            m = positive_number(mass, "mass")
        elif density is not None:
            m = positive_number(density, "density") * volume
        else:
            m = None
        P = V[F] - com                 # the tetrahedra from the centre of mass
        vol = np.linalg.det(P) / 6.0
        # the ball about the centre of mass inside the body: when the centre sees every face from inside
        # (each tetrahedron to it positive), the nearest face plane bounds it (distance 3 vol / area)
        self.inner_radius: float = float(np.min(3.0 * vol / area)) if np.all(vol > 0.0) else 0.0
        self.vertices = V
        self.faces = F
        self.volume: float = float(vol.sum())
        self.center_of_mass = com
        self.mass = m
        self._unit = tuple(_cone_moments(P, vol, k) / self.volume for k in (2, 3, 4))

    def _mass(self, mass: Any) -> float:
        if mass is None:
            if self.mass is None:
                raise ValueError("mass must be given: this Polyhedron was made without mass or density")
            return self.mass
        return positive_number(mass, "mass")

    def moments(self, mass: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(S (3,3), T3 (3,3,3), T4 (3,3,3,3))`` about the centre of mass (``int r r^T dm`` and the third,
        fourth moments) for ``mass`` (default: the Polyhedron's own)."""
        m = self._mass(mass)
        return tuple(m * t for t in self._unit)  # type: ignore[return-value]

    def inertia(self, mass: float | None = None) -> np.ndarray:
        """The inertia (3, 3) about the centre of mass, ``tr(S) I - S``."""
        S = self.moments(mass)[0]
        return np.trace(S) * np.eye(3) - S

    def __repr__(self) -> str:
        mass = "" if self.mass is None else f", mass={self.mass:.6g}"
        return f"Polyhedron({len(self.faces)} faces, volume={self.volume:.6g}{mass})"


@dataclass(frozen=True, eq=False)
class PointMasses:
    """A rigid body made of point masses ``masses`` (n,) at ``positions`` (n, 3) in its body frame,
    or of homogeneous spheres of ``radii`` (n,) there (a point is a sphere of radius 0).

    The positions are taken relative to their centre of mass (which the run's position follows).
    Its moments of every order follow from the points and spheres (a sphere adds ``m rho^2 / 5`` to
    its second moments and ``m rho^4 / 35`` times the isotropic tensor to its fourth,
    :func:`lgvi.body.sphere_moments`); a sphere attracts as the point at its centre, so
    ``potential="points"`` is exact for spheres too (the pairwise sum, ``n1 n2`` pairs a step) as
    long as no two spheres overlap, which :func:`simulate_two_body` checks every step. Two spheres
    on a rod (the dumbbell of Lee, Leok and McClamroch) are a rigid body: their own inertia gives
    the moment about the rod."""

    masses: Any
    positions: Any
    radii: Any = None

    def __post_init__(self) -> None:
        from ..body import sphere_moments

        w, q, rho, S, _, _ = sphere_moments(self.masses, self.positions, self.radii, "PointMasses", order=2)
        object.__setattr__(self, "masses", w)
        object.__setattr__(self, "positions", q)
        object.__setattr__(self, "radii", rho)

    @property
    def mass(self) -> float:
        return float(self.masses.sum())

    def moments(self, mass: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(S (3,3), T3 (3,3,3), T4 (3,3,3,3))`` about the centre of mass, spheres included."""
        from ..body import sphere_moments

        return sphere_moments(self.masses, self.positions, self.radii, "PointMasses")[3:]


class Moments:
    """What the kernels need of one body: mass, inertia, moments (and points)."""
    shape: str
    core: float
    bound: float

    def __init__(self, body: Any, mass: Any, potential: str, name: str, mname: str) -> None:
        self.points: PointMasses | None = None
        if isinstance(body, PointMasses):
            self.mass: float = body.mass if mass is None else positive_number(mass, mname)
            if abs(self.mass - body.mass) > 1e-12 * body.mass:
                raise ValueError(f"{mname} must be the sum of {name}'s point masses ({body.mass!r}) or None, got {mass!r}")
            S, T3, T4 = body.moments()
            self.points = body
        elif isinstance(body, Polyhedron) and body.mass is not None:
            self.mass = body.mass if mass is None else positive_number(mass, mname)
            if abs(self.mass - body.mass) > 1e-12 * body.mass:
                raise ValueError(f"{mname} must be {name}'s mass ({body.mass!r}, from its mass or density) or None, "
                                 f"got {mass!r}")
            S, T3, T4 = body.moments()
        else:
            self.mass = positive_number(mass, mname)
            if isinstance(body, (Ellipsoid, Polyhedron)):
                S, T3, T4 = body.moments(self.mass)
            else:
                if potential == "points":
                    raise ValueError(f"potential='points' needs {name} as lgvi.PointMasses (the exact pairwise sum), "
                                     f"got {type(body).__name__}")
                if potential == "order4":
                    raise ValueError(f"potential='order4' needs the third and fourth moments of {name}: give it as "
                                     f"lgvi.Ellipsoid, lgvi.Polyhedron or lgvi.PointMasses, got {type(body).__name__}")
                J = RigidBody(body).J
                S = np.trace(J) / 2.0 * np.eye(3) - J
                T3 = np.zeros((3, 3, 3))
                T4 = np.zeros((3, 3, 3, 3))
        if potential == "points" and self.points is None:
            raise ValueError(f"potential='points' needs {name} as lgvi.PointMasses, got {type(body).__name__}")
        self.body: RigidBody = RigidBody(np.trace(S) * np.eye(3) - S)
        self.S = np.array(self.body.Jd)
        self.T3 = T3
        self.T4 = T4
        self.t3: Any = np.einsum("kki->i", T3)
        self.Q4 = np.einsum("kkij->ij", T4)
        self.q4: float = float(np.einsum("iijj->", T4))
        self.E, self.A, self.core, self.bound, self.shape = contact_shape(body)


def contact_shape(body: Any) -> tuple[np.ndarray, np.ndarray, float, float, str]:
    """What the contact check of :func:`simulate_two_body` knows of a body's shape
    (:mod:`lgvi._kernels.contact_kernels`): ellipsoids (centres ``E`` (n, 3) in the body frame from
    the centre of mass, semi-axes ``A`` (n, 3) along the body axes), the radius ``core`` of a
    ball about the centre of mass inside the body, the radius ``bound`` of a ball about it that
    holds the ellipsoids, and a short description. An :class:`Ellipsoid` is one ellipsoid; a
    :class:`PointMasses` body one sphere per point (radius 0 for a point); a :class:`Polyhedron`
    only its inscribed ball about the centre of mass (when that centre sees every face from
    inside: a grazing contact of two polyhedra is not detected); a body given by its inertia has
    no shape (only a passage through its centre is detected)."""
    none = np.zeros((0, 3))
    if isinstance(body, Ellipsoid):
        ax = np.array([[body.a, body.b, body.c]])
        return np.zeros((1, 3)), ax, float(ax.min()), float(ax.max()), f"ellipsoid {body.a:g} x {body.b:g} x {body.c:g}"
    if isinstance(body, PointMasses):
        rho = body.radii
        dist = np.linalg.norm(body.positions, axis=1)
        core = float(max(0.0, np.max(rho - dist)))
        what = f"{len(rho)} sphere{'s' if len(rho) > 1 else ''}" if rho.any() else f"{len(rho)} points"
        return (np.ascontiguousarray(body.positions), np.repeat(rho[:, None], 3, axis=1), core,
                float(np.max(dist + rho)), what)
    if isinstance(body, Polyhedron):
        return none, none, body.inner_radius, 0.0, f"polyhedron of {len(body.faces)} faces"
    return none, none, 0.0, 0.0, "no shape"


def mutual_potential(potential: str, G: float, d: np.ndarray, R1: np.ndarray, R2: np.ndarray, b1: Moments,
                     b2: Moments) -> np.ndarray:
    """The mutual potential (M,) at ``d = x2 - x1`` (M, 3) and attitudes ``R1``, ``R2`` (M, 3, 3)."""
    d = np.asarray(d, dtype=np.float64)
    if potential == "points":
        y = np.einsum("kij,aj->kai", R1, b1.points.positions)
        z = np.einsum("kij,bj->kbi", R2, b2.points.positions)
        e = d[:, None, None, :] + z[:, None, :, :] - y[:, :, None, :]
        w = b1.points.masses[:, None] * b2.points.masses[None, :]
        return -G * np.sum(w / np.linalg.norm(e, axis=-1), axis=(1, 2))
    r = np.linalg.norm(d, axis=-1)
    U = -G * b1.mass * b2.mass / r
    order4 = potential == "order4"
    for Ri, bi, mj, s in ((R1, b1, b2.mass, 1.0), (R2, b2, b1.mass, -1.0)):
        u = np.einsum("kji,kj->ki", Ri, d)
        c = G * mj
        U = U - c * (3.0 * np.einsum("ki,ij,kj->k", u, bi.S, u) / r ** 2 - np.trace(bi.S)) / (2.0 * r ** 3)
        if order4:
            A3 = np.einsum("ijk,ni,nj,nk->n", bi.T3, u, u, u)
            U = U - s * c * (5.0 * A3 / r ** 7 - 3.0 * (u @ bi.t3) / r ** 5) / 2.0
            A4 = np.einsum("ijkl,ni,nj,nk,nl->n", bi.T4, u, u, u, u)
            B4 = np.einsum("ni,ij,nj->n", u, bi.Q4, u)
            U = U - c * (35.0 * A4 / r ** 9 - 30.0 * B4 / r ** 7 + 3.0 * bi.q4 / r ** 5) / 8.0
    if order4:
        A = np.einsum("kij,jl,kml->kim", R1, b1.S, R1)
        B = np.einsum("kij,jl,kml->kim", R2, b2.S, R2)
        al = np.einsum("ki,kij,kj->k", d, A, d)
        be = np.einsum("ki,kij,kj->k", d, B, d)
        ga = np.einsum("ki,kij,kjl,kl->k", d, A, B, d)
        trA = np.trace(A, axis1=1, axis2=2)
        trB = np.trace(B, axis1=1, axis2=2)
        trAB = np.einsum("kij,kji->k", A, B)
        U = U - G / 4.0 * (105.0 * al * be / r ** 9 - 15.0 / r ** 7 * (trA * be + trB * al + 4.0 * ga)
                           + 3.0 / r ** 5 * (trA * trB + 2.0 * trAB))
    return U


def _arrays(b1: Moments, b2: Moments) -> dict[str, np.ndarray]:
    """The kernels' body arrays (the point arrays are (1, 3) placeholders without points)."""
    out = {"S": np.stack([b1.S, b2.S]), "T3": np.stack([b1.T3, b2.T3]), "t3": np.stack([b1.t3, b2.t3]),
           "T4": np.stack([b1.T4, b2.T4]), "Q4": np.stack([b1.Q4, b2.Q4]), "q4": np.array([b1.q4, b2.q4])}
    for i, b in ((1, b1), (2, b2)):
        if b.points is not None:
            out[f"Q{i}"] = np.ascontiguousarray(b.points.positions)
            out[f"w{i}"] = np.ascontiguousarray(b.points.masses)
        else:
            out[f"Q{i}"] = np.zeros((1, 3))
            out[f"w{i}"] = np.zeros(1)
    return out


def mutual_force(potential: str, G: float, d: Any, R1: Any, R2: Any, b1: Moments, b2: Moments) -> np.ndarray:
    """``(g = dU/dd, M1, M2)`` (9,) from the compiled kernel (one state)."""
    from .._kernels.two_body_kernels import mutual_force as kernel

    a = _arrays(b1, b2)
    out = np.zeros(10)
    kernel(POTENTIALS[potential], G, b1.mass, b2.mass, a["S"], a["T3"], a["t3"], a["T4"], a["Q4"], a["q4"], a["Q1"],
           a["w1"], a["Q2"], a["w2"], np.asarray(d, dtype=np.float64), np.stack([R1, R2]).astype(np.float64), out)
    return out[:9]


def two_body_equations(potential: str, G: float, b1: Moments, b2: Moments):
    """The continuous equations ``f(t, y)``, ``y = (x1, x2, p1, p2, R1, R2 (row-major), Pi1, Pi2)``
    (42,), with the same mutual force as the integrator (for a DOP853 reference)."""
    Jinv = [np.linalg.inv(b1.body.J), np.linalg.inv(b2.body.J)]
    m = (b1.mass, b2.mass)

    def f(t: float, y: np.ndarray) -> np.ndarray:
        x1, x2, p1, p2 = y[0:3], y[3:6], y[6:9], y[9:12]
        R = [y[12:21].reshape(3, 3), y[21:30].reshape(3, 3)]
        Pi = [y[30:33], y[33:36]]
        out = mutual_force(potential, G, x2 - x1, R[0], R[1], b1, b2)
        g, M = out[0:3], (out[3:6], out[6:9])
        dR, dPi = [], []
        for i in range(2):
            w = Jinv[i] @ Pi[i]
            dR.append((R[i] @ np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])).ravel())
            dPi.append(np.cross(Pi[i], w) + M[i])
        return np.concatenate([p1 / m[0], p2 / m[1], g, -g, dR[0], dR[1], dPi[0], dPi[1]])

    return f


# ------------------------------------------------------------------------------------------------
# results
# ------------------------------------------------------------------------------------------------
@dataclass
class TwoBodyTrajectory:
    """The result of :func:`simulate_two_body`, ``M`` samples; axis 1 is the body (0, 1).

    Attributes
    ----------
    t : (M,) ndarray
    x, p : (M, 2, 3) ndarray
        Centres of mass and linear momenta (inertial).
    R : (M, 2, 3, 3) ndarray
        Attitudes, body to inertial.
    Pi : (M, 2, 3) ndarray
        Body angular momenta.
    iterations, residual : (M - 1,) ndarray
        Largest solver iterations (both bodies summed) and residual per saved interval.
    h, G : float
    masses : (2,) ndarray
    moments : dict
        ``S`` (2,3,3) second moments (``= Jd``), ``T3``, ``T4``; ``Q1, w1, Q2, w2`` the points.
    meta : dict
    """

    t: np.ndarray
    x: np.ndarray
    p: np.ndarray
    R: np.ndarray
    Pi: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    h: float
    G: float
    masses: np.ndarray
    moments: dict[str, np.ndarray]
    meta: dict[str, Any] = field(default_factory=dict)

    ARRAYS = ("t", "x", "p", "R", "Pi", "iterations", "residual", "masses")

    @property
    def inertia(self) -> np.ndarray:
        """Inertias (2, 3, 3) about the centres of mass."""
        S = self.moments["S"]
        return np.trace(S, axis1=1, axis2=2)[:, None, None] * np.eye(3) - S

    @property
    def error_estimate(self) -> Any:
        """The run's :class:`lgvi.accuracy.ErrorEstimate` (``simulate_two_body(..., error_estimate=True)``)
        or ``None``."""
        return estimate_of(self.meta)

    @property
    def relative_position(self) -> np.ndarray:
        """``x2 - x1`` (M, 3)."""
        return self.x[:, 1] - self.x[:, 0]

    @property
    def distance(self) -> np.ndarray:
        return np.linalg.norm(self.relative_position, axis=1)

    @property
    def v(self) -> np.ndarray:
        return self.p / self.masses[None, :, None]

    @property
    def omega(self) -> np.ndarray:
        """Body angular velocities (M, 2, 3)."""
        return np.einsum("bij,kbj->kbi", np.linalg.inv(self.inertia), self.Pi)

    @property
    def spatial_momentum(self) -> np.ndarray:
        """Spin momenta ``R_i Pi_i`` (M, 2, 3)."""
        return np.einsum("kbij,kbj->kbi", self.R, self.Pi)

    @property
    def linear_momentum(self) -> np.ndarray:
        """Total linear momentum ``p1 + p2`` (M, 3)."""
        return self.p.sum(axis=1)

    @property
    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum ``sum_i x_i x p_i + R_i Pi_i`` (M, 3) about the origin."""
        return np.cross(self.x, self.p).sum(axis=1) + self.spatial_momentum.sum(axis=1)

    def _bodies(self) -> tuple[Moments, Moments]:
        out = []
        for i in range(2):
            b = Moments.__new__(Moments)
            b.mass = float(self.masses[i])
            b.S, b.T3, b.T4 = (self.moments[k][i] for k in ("S", "T3", "T4"))
            b.t3 = np.einsum("kki->i", b.T3)
            b.Q4 = np.einsum("kkij->ij", b.T4)
            b.q4 = float(np.einsum("iijj->", b.T4))
            w = self.moments[f"w{i + 1}"]
            b.points = PointMasses(w, self.moments[f"Q{i + 1}"]) if w.any() else None
            out.append(b)
        return out[0], out[1]

    @property
    def potential_energy(self) -> np.ndarray:
        b1, b2 = self._bodies()
        return mutual_potential(self.meta.get("potential", "order2"), self.G, self.relative_position, self.R[:, 0],
                                self.R[:, 1], b1, b2)

    @property
    def kinetic_energy(self) -> np.ndarray:
        return (0.5 * np.einsum("kbi,kbi,b->k", self.p, self.p, 1.0 / self.masses)
                + 0.5 * np.einsum("kbi,kbi->k", self.Pi, self.omega))

    @property
    def energy(self) -> np.ndarray:
        """Total energy (M,): kinetic (both bodies, orbit and spin) plus the mutual potential."""
        return self.kinetic_energy + self.potential_energy

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write to ``path`` (``.npz``, atomically); :meth:`load` reads it back exactly."""
        arrays = {k: np.asarray(getattr(self, k)) for k in self.ARRAYS}
        arrays.update({f"moment_{k}": v for k, v in self.moments.items()})
        arrays["scalars"] = np.array([self.h, self.G])
        save_result_npz(path, FORMAT, arrays, self.meta)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "TwoBodyTrajectory":
        """Read a result written by :meth:`save` (ValueError naming the file if it is not one)."""
        keys = ("S", "T3", "T4", "Q1", "w1", "Q2", "w2")
        arrays, meta = load_result_npz(path, FORMAT, cls.ARRAYS + ("scalars",) + tuple(f"moment_{k}" for k in keys))
        h, G = (float(v) for v in arrays.pop("scalars"))
        moments = {k: arrays.pop(f"moment_{k}") for k in keys}
        return cls(h=h, G=G, moments=moments, meta=meta, **arrays)


# ------------------------------------------------------------------------------------------------
# the run
# ------------------------------------------------------------------------------------------------
def _pair(value: Any, name: str, m1: float, m2: float) -> np.ndarray:
    """``(2, 3)`` from a relative vector (3,) (the centre of mass at the origin, at rest) or (2, 3)."""
    arr = np.asarray(value) if not isinstance(value, (str, bytes)) else None
    if arr is not None and arr.shape == (3,):
        rel = as_float_array(value, name, (3,))
        M = m1 + m2
        return np.stack([-m2 / M * rel, m1 / M * rel])
    if arr is None or arr.shape != (2, 3):
        raise ValueError(f"{name} must be the relative vector body 2 - body 1 (3,) or both bodies' (2, 3), got "
                         f"{'shape ' + str(arr.shape) if arr is not None else repr(value)}")
    return as_float_array(value, name, (2, 3)).copy()


class TwoBodyRun(CarriedState):
    """One validated run of :func:`simulate_two_body` (driven by :func:`lgvi.driver.drive`)."""
    meta: dict[str, Any]
    scratch: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    tol: float
    max_iter: int

    system = TWO_BODY
    CARRIED = ('x', 'p', 'R', 'Pi', 'Gh', 'C')
    full = False
    label = "two-body simulation"

    def __init__(self, body1: Any, body2: Any, m1: Any, m2: Any, x0: Any, v0: Any, R1_0: Any, R2_0: Any, *,
                 Pi1_0: Any = None, Pi2_0: Any = None, omega1_0: Any = None, omega2_0: Any = None, h: Any,
                 steps: Any, G: Any = 1.0, potential: Any = "order2", tol: Any = 1e-14, max_iter: Any = 50,
                 save_every: Any = 1, t0: Any = 0.0) -> None:
        from ..driver import run_solver_options

        self.potential: str = choice(potential, "potential", tuple(POTENTIALS))
        self.code: int = POTENTIALS[self.potential]
        self.G = positive_number(G, "G")
        self.b1: Moments = Moments(body1, m1, self.potential, "body1", "m1")
        self.b2: Moments = Moments(body2, m2, self.potential, "body2", "m2")
        m1, m2 = self.b1.mass, self.b2.mass
        self.arrays: dict[str, np.ndarray] = _arrays(self.b1, self.b2)
        self.x: np.ndarray = _pair(x0, "x0", m1, m2)
        if not np.linalg.norm(self.x[1] - self.x[0]) > 0.0:
            raise ValueError("x0 must separate the bodies (|x2 - x1| > 0), got coincident centres")
        self.p: np.ndarray = _pair(v0, "v0", m1, m2) * np.array([[m1], [m2]])
        self.R = np.stack([as_rotation(R1_0, "R1_0"), as_rotation(R2_0, "R2_0")])
        try:
            Pi1 = initial_momentum(self.b1.body, Pi1_0, omega1_0)
        except ValueError as exc:
            raise ValueError(str(exc).replace("Pi0", "Pi1_0").replace("omega0", "omega1_0")) from None
        try:
            Pi2 = initial_momentum(self.b2.body, Pi2_0, omega2_0)
        except ValueError as exc:
            raise ValueError(str(exc).replace("Pi0", "Pi2_0").replace("omega0", "omega2_0")) from None
        self.Pi: np.ndarray = np.stack([Pi1, Pi2])
        self.h, self.t0, self.steps, self.save_every = time_grid(h, t0, steps, save_every)
        _, self.tol, self.max_iter, _ = run_solver_options("cayley", tol, max_iter, 1.0)
        check_memory(self.steps, self.save_every, False)
        self.chunk: int = max(self.save_every, (CHUNK_STEPS // self.save_every) * self.save_every)
        self.k: int = 0
        self.Gh: np.ndarray = np.zeros((2, 5, 3))
        for i, b in enumerate((self.b1, self.b2)):
            self.Gh[i, 0] = 0.5 * self.h * (b.body.J_inv @ self.Pi[i])
            self.Gh[i, 3, 0] = 1.0
        self.C = np.zeros(10)
        self.N = np.zeros(10)
        self.scratch = (np.zeros_like(self.arrays["Q1"]), np.zeros_like(self.arrays["Q2"]), np.zeros((3, 3)),
                        np.zeros((3, 3)))
        self.last = np.zeros(2)
        self.hist: np.ndarray = np.zeros(0)
        b1, b2 = self.b1, self.b2
        self.core: float = b1.core + b2.core
        self.bound: float = b1.bound + b2.bound if len(b1.E) and len(b2.E) else 0.0
        self.contact: np.ndarray = np.zeros(3)
        self.contact_scratch: tuple[np.ndarray, np.ndarray] = (np.zeros((2, 3)), np.zeros((2, 3, 3)))
        self._check_start()
        self.meta = {"system": TWO_BODY.name, "potential": self.potential, "invariants": _invariants(None),
                     "t0": self.t0, "save_every": self.save_every, "method": "cayley", "tol": self.tol,
                     "lgvi_version": __version__}
        self.initial: dict[str, Any] = {key: getattr(self, key).tolist() for key in ("x", "p", "R", "Pi")}

    def _check_start(self) -> None:
        """Refuse an initial state whose bodies are in contact (:class:`lgvi.errors.InitialContactError`)."""
        from .._kernels.contact_kernels import shapes_overlap

        d = float(np.linalg.norm(self.x[1] - self.x[0]))
        touch = d <= self.core
        if not touch and d < self.bound:
            touch = shapes_overlap(self.x, self.R, self.b1.E, self.b1.A, self.b2.E, self.b2.A) >= 0
        if touch:
            raise InitialContactError(f"x0 puts the bodies in contact at the start: the centres of mass are {d:.6g} "
                                      f"apart and the bodies ({self.b1.shape}; {self.b2.shape}) overlap at the "
                                      "attitudes R1_0, R2_0; start them farther apart", step=0, time=float(self.t0),
                                      distance=d)

    def stream_meta(self) -> dict[str, Any]:
        """JSON-serialisable metadata of a stream of this run (:mod:`lgvi.io.streaming`): what
        :func:`_from_stream` needs (the bodies' moment arrays with their shapes) and what identifies
        the run (compared on resume)."""
        a = self.arrays
        return dict(self.meta, h=self.h, steps=self.steps, G=self.G, masses=[self.b1.mass, self.b2.mass],
                    max_iter=self.max_iter, initial=self.initial,
                    moments={k: {"shape": list(a[k].shape), "values": a[k].ravel().tolist()} for k in MOMENT_KEYS})

    def advance(self, n: int, x_out, p_out, R_out, Pi_out, it_out, res_out, partial) -> int:
        from .._kernels.two_body_kernels import run_two_body

        a = self.arrays
        Y, Z, A, B = self.scratch
        status, self.k = run_two_body(self.code, self.G, self.b1.mass, self.b2.mass, a["S"], a["T3"], a["t3"], a["T4"],
                                      a["Q4"], a["q4"], a["Q1"], a["w1"], a["Q2"], a["w2"], Y, Z, A, B, self.h, self.x,
                                      self.p, self.R, self.Pi, self.Gh, self.C, self.N, self.k, n, self.tol,
                                      self.max_iter, self.save_every, x_out, p_out, R_out, Pi_out, it_out, res_out,
                                      self.hist, self.last, self.b1.E, self.b1.A, self.b2.E, self.b2.A, self.bound,
                                      self.core, *self.contact_scratch, self.contact)
        return int(status)

    def failure(self, status: int, residual: float, iterations: int, trajectory: Any, where: str = "") -> Exception:
        if status == COLLISION:
            core = f"the bodies (balls of radius {self.b1.core:g} and {self.b2.core:g} about their centres of mass)"
            return self.collision(self.contact, trajectory, where, core, f"{self.b1.shape}; {self.b2.shape}")
        what = {OVERFLOW: "the state after the step is not finite (the bodies collided, or the step is far too large)",
                NOT_FINITE: "the positions became non-finite",
                }.get(status, f"an attitude equation was not solved (status {status}, residual {residual:.3e}, "
                              f"{iterations} iterations)")
        return self.step_failure(what, residual, iterations, trajectory, where)

    def trajectory(self, t, x, p, R, Pi, it, res, partial: bool = False) -> TwoBodyTrajectory:
        meta = dict(self.meta, partial=True) if partial else dict(self.meta)
        a = self.arrays
        moments = {k: a[k].copy() for k in MOMENT_KEYS}
        return TwoBodyTrajectory(t=t, x=x, p=p, R=R, Pi=Pi, iterations=it, residual=res, h=self.h, G=self.G,
                                 masses=np.array([self.b1.mass, self.b2.mass]), moments=moments, meta=meta)


def _from_stream(meta: dict[str, Any], arrays: dict[str, np.ndarray], state: dict[str, Any]) -> TwoBodyTrajectory:
    """The :class:`TwoBodyTrajectory` of a stream folder (``System.from_stream``)."""
    M = len(arrays["t"])
    for name, shape in (("x", (M, 2, 3)), ("p", (M, 2, 3)), ("R", (M, 2, 3, 3)), ("Pi", (M, 2, 3)),
                        ("iterations", (M - 1,)), ("residual", (M - 1,))):
        if arrays[name].shape != shape:
            raise ValueError(f"field {name!r} must have shape {shape} (M = {M} samples), got {arrays[name].shape}")
    moments = {k: np.asarray(meta["moments"][k]["values"], dtype=np.float64).reshape(meta["moments"][k]["shape"])
               for k in MOMENT_KEYS}
    return TwoBodyTrajectory(t=arrays["t"], x=arrays["x"], p=arrays["p"], R=arrays["R"], Pi=arrays["Pi"],
                             iterations=arrays["iterations"], residual=arrays["residual"], h=float(meta["h"]),
                             G=float(meta["G"]), masses=np.asarray(meta["masses"], dtype=np.float64).reshape(2),
                             moments=moments, meta=dict(meta))


def simulate_two_body(body1: Any, body2: Any, m1: float | None, m2: float | None, x0: Any, v0: Any, R1_0: Any,
                      R2_0: Any, *, Pi1_0: Any = None, Pi2_0: Any = None, omega1_0: Any = None, omega2_0: Any = None,
                      h: float, steps: int, G: float = 1.0, potential: TwoBodyPotential = "order2", save_every: int = 1,
                      t0: float = 0.0, tol: float = 1e-14, max_iter: int = 50, progress: Any = False,
                      error_estimate: Any = False, error_warn: float | None = 0.01) -> TwoBodyTrajectory:
    r"""Simulate two rigid bodies in mutual gravity (the full two-body problem).

    Each step: both attitudes by the LGVI, both orbits by the explicit variational (Verlet)
    update, one evaluation of the mutual potential's force and moments (``docs/orbit.md``).
    Second order; total linear and angular momentum conserved to round-off, energy bounded.

    Parameters
    ----------
    body1, body2 : RigidBody, array_like, Ellipsoid, Polyhedron or PointMasses
        The bodies: an inertia (``(3,)`` or ``(3, 3)``, about the centre of mass), an
        :class:`Ellipsoid` or :class:`Polyhedron` (homogeneous; its moments scale with the mass) or
        :class:`PointMasses`.
    m1, m2 : float or None
        Masses, ``> 0`` (``None`` for :class:`PointMasses`: the sum of the points; for a
        :class:`Polyhedron` made with ``mass`` or ``density``: that mass).
    x0 : (3,) or (2, 3) array_like
        The relative position ``x2 - x1`` (then the centre of mass is at the origin) or both
        centres of mass.
    v0 : (3,) or (2, 3) array_like
        The relative velocity ``v2 - v1`` (the centre of mass at rest) or both velocities.
    R1_0, R2_0 : (3, 3) array_like
        Initial attitudes, body to inertial.
    Pi1_0, Pi2_0, omega1_0, omega2_0 : (3,) array_like
        Initial body angular momenta, or body angular velocities (one of each pair).
    h : float
        Step, non-zero.
    steps : int
        Number of steps, ``>= 0``.
    G : float
        Gravitational constant in the units of the run, ``> 0`` (default 1).
    potential : {"order2", "order4", "points"}
        The mutual potential (see the module notes).
    save_every, t0, tol, max_iter, progress
        As in :func:`lgvi.simulate_orbit`.
    error_estimate, error_warn
        As in :func:`lgvi.simulate_orbit`: the shadow run at ``h/2`` estimates the error of both
        attitudes (the larger is ``attitude``), of the body momenta and of the relative position
        ``x2 - x1`` (``position``, ``position_rel``).

    Raises
    ------
    lgvi.CollisionError
        At the step where the bodies touch (for shapes the check knows: :func:`contact_shape`) or
        where their centres pass each other closer than the step's own length, with the run up to
        that step in ``.trajectory``; bodies in contact at the start raise it (as a
        ``ValueError`` too) before any step.

    Returns
    -------
    TwoBodyTrajectory
        ``x``, ``p`` (M, 2, 3), ``R`` (M, 2, 3, 3), ``Pi`` (M, 2, 3); ``energy``,
        ``linear_momentum``, ``angular_momentum`` (M, 3), ``save``/``load``.

    Examples
    --------
    >>> import numpy as np, lgvi
    >>> traj = lgvi.simulate_two_body(lgvi.Ellipsoid(1.0, 0.7, 0.5), lgvi.Ellipsoid(0.3, 0.25, 0.2), 1.0, 0.1,
    ...                               [3.0, 0, 0], [0, 0.6, 0], np.eye(3), np.eye(3), omega1_0=[0, 0, 1.0],
    ...                               omega2_0=[0, 0, 0.2], h=0.05, steps=200, potential="order4")
    >>> bool(np.abs(traj.linear_momentum).max() < 1e-14)
    True
    """
    estimate, warn = check_options(error_estimate, error_warn, None)
    run = TwoBodyRun(body1, body2, m1, m2, x0, v0, R1_0, R2_0, Pi1_0=Pi1_0, Pi2_0=Pi2_0, omega1_0=omega1_0,
                     omega2_0=omega2_0, h=h, steps=steps, G=G, potential=potential, tol=tol, max_iter=max_iter,
                     save_every=save_every, t0=t0)
    Progress(progress, 0)
    traj = drive(run, MemorySink(run), progress=progress)
    if not estimate:
        return traj
    args = dict(body1=body1, body2=body2, m1=m1, m2=m2, x0=x0, v0=v0, R1_0=R1_0, R2_0=R2_0, Pi1_0=Pi1_0, Pi2_0=Pi2_0,
                omega1_0=omega1_0, omega2_0=omega2_0, h=run.h, steps=run.steps, G=G, potential=potential,
                save_every=run.save_every, t0=t0, tol=tol, max_iter=max_iter, progress=progress)
    return with_estimate(traj, args, warn=warn, stacklevel=2, order=2, runner=simulate_two_body,
                         position=lambda tr: tr.relative_position)


def _provide() -> None:
    from . import provide_run

    provide_run(TWO_BODY, TwoBodyRun)


_provide()

__all__ = ["Ellipsoid", "Moments", "PointMasses", "Polyhedron", "TWO_BODY", "TwoBodyRun", "TwoBodyTrajectory",
           "mutual_force", "mutual_potential", "simulate_two_body", "two_body_equations"]
