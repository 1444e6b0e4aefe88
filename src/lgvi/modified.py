r"""Modified-inertia (preprocessed) discrete Moser-Veselov method for the free rigid body.

The free-body LGVI step

.. math::

    \widehat{h\Pi_k} = F_k J_d - J_d F_k^T, \qquad R_{k+1} = R_k F_k, \qquad \Pi_{k+1} = F_k^T \Pi_k

is the discrete Moser-Veselov (DMV) algorithm: symmetric, second order, and it conserves
``|Pi|``, the spatial momentum ``R Pi`` and the energy of the inertia it is run with. Run it with
*modified* principal moments ``J~(h; E, C)`` instead of the true ``J`` and it becomes a method of
order ``p`` for the momentum **and** the attitude, still at the cost of one implicit solve per step
(McLachlan and Zanna, Found. Comput. Math. 5 (2005) 87-123; Hairer and Vilmart, J. Phys. A 39
(2006) 13225-13235). No pre- or post-processing of the attitude is needed (see below).

The modification
----------------
With ``w_i = 1/J_i`` (inverse principal moments), their elementary symmetric polynomials

    e1 = w1 + w2 + w3,   e2 = w1 w2 + w1 w3 + w2 w3,   e3 = w1 w2 w3,

and the invariants of the initial momentum ``C = |Pi0|^2`` and ``2E = Pi0 . J^-1 Pi0``,

    1/J~_i = alpha + beta w_i,
    alpha = sum_{j>=1} h^(2j) sum_{m=0..j} A_jm(e1, e2, e3) C^m (2E)^(j-m),
    beta  = 1 + sum_{j>=1} h^(2j) sum_{m=0..j} B_jm(e1, e2, e3) C^m (2E)^(j-m),

summed up to ``j = order/2 - 1``. ``A_jm`` and ``B_jm`` are the homogeneous polynomials (degrees
``j+m+1`` and ``j+m``) in :data:`_COEFFICIENTS`. To order 4:

    alpha = h^2 (e2 (2E)/12 - e3 C/6),      beta = 1 + h^2 (e2 C/12 - e1 (2E)/6).

Why this form, and why the attitude needs nothing else
------------------------------------------------------
``1/J~`` lies in the pencil ``alpha + beta J^-1``, so the modified energy is
``E~ = alpha C/2 + beta E``: the level sets of (``C``, ``E~``) and of (``C``, ``E``) are the same
curves on the momentum sphere, and a rigid body with inertia ``J~`` moves on them as the true body
does, with time scaled by ``beta`` and an extra precession about the spatial momentum at rate
``alpha |L|`` (``R' = R hat(J~^-1 Pi) = R hat(beta Omega) + alpha hat(L) R``). The DMV map with
``J~`` is integrable and symplectic and preserves these invariant tori, so it is a translation in
their angle variables; so is the exact time-``h`` flow. Two angles (the phase of ``Pi`` along its
curve and the precession angle about ``L``) and two free functions (``alpha``, ``beta``) of the
conserved ``E``, ``C``: matching both translations to ``O(h^(p+1))`` makes the *whole* step
``F_k`` (hence ``Pi`` and ``R``) accurate to order ``p``. Because ``E`` and ``C`` are conserved
exactly by the modified scheme, ``J~`` is computed once from ``Pi0``, and the scheme stays
symmetric (only even powers of ``h`` appear).

Derivation (done once with sympy; the test suite checks the result)
--------------------------------------------------------------------
Both sides are written as Taylor series in ``h`` of the Cayley vector ``f`` of the step
(``F = (I + hat f)(I - hat f)^-1``), with symbolic ``Pi`` and ``w``:

* exact: ``Pi' = Pi x W Pi``, ``Omega = W Pi`` and ``f' = (Omega + f x Omega + (f . Omega) f)/2``
  (the Cayley vector ``f = q_v / q_0`` of ``Phi(t) = R(0)^T R(t)``), ``f(0) = 0``;
* DMV with inverse moments ``alpha + beta w_i`` in Lee's Cayley form
  ``2 J~ f = h Pi + h Pi x f + (h Pi . f) f``, solved by recursion on the powers of ``h``.

At order ``h^(2j+1)`` the unknowns of ``h^(2j)`` enter linearly as ``(a_j + b_j w_i) Pi_i / 2``;
the residual ``r_i`` turned out to be divisible by ``Pi_i`` with ``-2 r_i / Pi_i = a_j + b_j w_i``
for one pair ``(a_j, b_j)`` of polynomials in ``C`` and ``E`` (an exact identity in the polynomial
ring, checked for ``i = 3`` and by re-expanding), and the next even order ``h^(2j+2)`` then matched
by itself (symmetry). This was carried out for ``j = 1..5`` (order 12) in exact rational
arithmetic; the coefficients were then rewritten in ``e1, e2, e3``. They agree to round-off with
the order 4-10 coefficients of Hairer and Vilmart's Fortran code DMV10 (written there in the
``J_i``); order 12 is an extension. The tests re-derive every term with sympy when it is
installed (an optional test dependency), check the sphere against the closed form
``J/J~ = sin(x)/x`` with ``x = h |Pi| / J``, and measure the orders.

Range of validity and caveats
-----------------------------
* The series is in the step angle. With ``w_min``, ``w_max`` the extreme inverse moments, the
  largest angular speed on the orbit is ``|Omega|_max = sqrt((w_min + w_max) 2E - w_min w_max C)``
  (the orbit crosses the plane of the extreme axes) and ``theta = h |Omega|_max`` bounds the
  rotation of one step. Measured for several bodies: the order-10 error grows smoothly with
  ``theta`` up to 1.4 rad and breaks down near ``pi/2`` (for a sphere the DMV step angle is
  ``asin(h |Pi|/J~)``, which cannot exceed ``pi/2``). :func:`simulate_modified` therefore refuses
  ``theta > 1.4`` (:data:`MAX_STEP_ANGLE`) for ``order >= 4``; accurate runs use far less
  (1e-7 rad over 1000 s on J = diag(1, 2, 3) needs ``theta`` of 0.3 at order 8).
* Flat bodies (``J3 = J1 + J2`` with ``J3`` the largest moment, where ``Jd`` is singular) are
  fine: to leading order ``J~_i = J_i - h^2 (b_1 J_i + a_1 J_i^2)``, so
  ``J~1 + J~2 - J~3 = (J1 + J2 - J3)(1 - h^2 (b_1 + a_1 tr J)) + 2 J1 J2 h^2 a_1`` with
  ``a_1 = (e2 2E - 2 e3 C)/12 >= (2E) e3 (J1 + J2 - J3)/12 >= 0`` (as ``C <= J3 2E`` and
  ``e2 = e3 tr J``): the modification moves a boundary body into the triangle, never out of it.
  The modified moments are still checked by :class:`lgvi.RigidBody`.
* The modification is polynomial in ``E`` and ``C``: nothing is singular at the separatrix
  ``C = 2 E J_mid`` (unlike elliptic-function solutions), but the error constants of every method
  grow near it, as the motion itself is sensitive there.
* Only the free body: with a torque ``E`` and ``C`` are no longer conserved and a fixed ``J~``
  is only second order.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._validation import as_float, as_float_array, as_int, as_rotation
from .body import RigidBody
from .errors import ConvergenceError, SimulationInterrupted
from .integrator import simulate
from .trajectory import Trajectory

__all__ = ["MAX_STEP_ANGLE", "ORDERS", "max_step_angle", "modified_inertia", "pencil_coefficients",
           "simulate_modified"]

#: Orders available: 2 (the plain LGVI/DMV step) and the modified-inertia methods.
ORDERS = (2, 4, 6, 8, 10, 12)

#: Largest ``h |Omega|_max`` (rad) accepted by :func:`simulate_modified` for ``order >= 4``.
MAX_STEP_ANGLE = 1.4

#: ``_COEFFICIENTS[j] = (A_j, B_j)``: the ``h^(2j)`` terms of ``alpha`` and ``beta``. ``A_j[m]``
#: (``m = 0..j``) multiplies ``C^m (2E)^(j-m)`` and is ``(den, terms)`` with
#: ``A_jm = sum(k e1^a e2^b e3^c for (a, b, c, k) in terms) / den``; likewise ``B_j``.
#: Derived in exact rational arithmetic (see the module docstring); do not edit by hand.
_COEFFICIENTS: dict[int, tuple[tuple[tuple[int, tuple[tuple[int, int, int, int], ...]], ...], ...]] = {
    1: (  # h^2
        (  # alpha_1: m = 0..1
            (12, ((0, 1, 0, 1),)),
            (6, ((0, 0, 1, -1),)),
        ),
        (  # beta_1: m = 0..1
            (6, ((1, 0, 0, -1),)),
            (12, ((0, 1, 0, 1),)),
        ),
    ),
    2: (  # h^4
        (  # alpha_2: m = 0..2
            (240, ((1, 1, 0, -1), (0, 0, 1, -6),)),
            (240, ((1, 0, 1, 8), (0, 2, 0, -1),)),
            (240, ((0, 1, 1, -1),)),
        ),
        (  # beta_2: m = 0..2
            (240, ((2, 0, 0, 2), (0, 1, 0, -1),)),
            (120, ((1, 1, 0, -1), (0, 0, 1, 4),)),
            (120, ((1, 0, 1, -3), (0, 2, 0, 1),)),
        ),
    ),
    3: (  # h^6
        (  # alpha_3: m = 0..3
            (10080, ((2, 1, 0, 1), (1, 0, 1, 30), (0, 2, 0, -13),)),
            (20160, ((2, 0, 1, -64), (1, 2, 0, 13), (0, 1, 1, 110),)),
            (10080, ((1, 1, 1, -1), (0, 3, 0, 1), (0, 0, 2, -88),)),
            (20160, ((1, 0, 2, 72), (0, 2, 1, -19),)),
        ),
        (  # beta_3: m = 0..3
            (5040, ((3, 0, 0, -1), (1, 1, 0, 1), (0, 0, 1, 18),)),
            (20160, ((2, 1, 0, 6), (1, 0, 1, -212), (0, 2, 0, 41),)),
            (3360, ((2, 0, 1, 22), (1, 2, 0, -6), (0, 1, 1, -5),)),
            (20160, ((1, 1, 1, -66), (0, 3, 0, 17), (0, 0, 2, 100),)),
        ),
    ),
    4: (  # h^8
        (  # alpha_4: m = 0..4
            (725760, ((3, 1, 0, -1), (2, 0, 1, -126), (1, 2, 0, -6), (0, 1, 1, 459),)),
            (362880, ((3, 0, 1, 64), (2, 2, 0, -15), (1, 1, 1, -276), (0, 3, 0, 97), (0, 0, 2, -648),)),
            (120960, ((2, 1, 1, 19), (1, 3, 0, -5), (1, 0, 2, 356), (0, 2, 1, -133),)),
            (725760, ((2, 0, 2, -864), (1, 2, 1, 222), (0, 4, 0, -1), (0, 1, 2, 684),)),
            (725760, ((1, 1, 2, 243), (0, 3, 1, -61), (0, 0, 3, -610),)),
        ),
        (  # beta_4: m = 0..4
            (725760, ((4, 0, 0, 2), (2, 1, 0, -3), (1, 0, 1, -486), (0, 2, 0, 153),)),
            (181440, ((3, 1, 0, -1), (2, 0, 1, 276), (1, 2, 0, -66), (0, 1, 1, -207),)),
            (120960, ((3, 0, 1, -102), (2, 2, 0, 26), (1, 1, 1, 30), (0, 3, 0, 3), (0, 0, 2, 318),)),
            (362880, ((2, 1, 1, 306), (1, 3, 0, -77), (1, 0, 2, -1128), (0, 2, 1, 141),)),
            (725760, ((2, 0, 2, 378), (1, 2, 1, -342), (0, 4, 0, 62), (0, 1, 2, 291),)),
        ),
    ),
    5: (  # h^10
        (  # alpha_5: m = 0..5
            (79833600, (
                (4, 1, 0, 1), (3, 0, 1, 510), (2, 2, 0, -555), (1, 1, 1, -2133), (0, 3, 0, 2169),
                (0, 0, 2, -8424),
            )),
            (159667200, (
                (4, 0, 1, -1024), (3, 2, 0, 251), (2, 1, 1, 12198), (1, 3, 0, -774), (1, 0, 2, 63288),
                (0, 2, 1, -48285),
            )),
            (39916800, (
                (3, 1, 1, -871), (2, 3, 0, 219), (2, 0, 2, -20496), (1, 2, 1, 7782), (0, 4, 0, -1095),
                (0, 1, 2, 26793),
            )),
            (159667200, (
                (3, 0, 2, 31104), (2, 2, 1, -8790), (1, 4, 0, 251), (1, 1, 2, -45960), (0, 3, 1, 12444),
                (0, 0, 3, -110664),
            )),
            (79833600, ((2, 1, 2, -7263), (1, 3, 1, 1813), (1, 0, 3, 47298), (0, 5, 0, 1), (0, 2, 2, -10365),)),
            (159667200, ((2, 0, 3, -12096), (1, 2, 2, 8559), (0, 4, 1, -1384), (0, 1, 3, -3270),)),
        ),
        (  # beta_5: m = 0..5
            (79833600, ((5, 0, 0, -2), (3, 1, 0, 4), (2, 0, 1, 5022), (1, 2, 0, -819), (0, 1, 1, -7641),)),
            (159667200, (
                (4, 1, 0, 10), (3, 0, 1, -21124), (2, 2, 0, 5241), (1, 1, 1, 31338), (0, 3, 0, -7339),
                (0, 0, 2, 59508),
            )),
            (39916800, (
                (4, 0, 1, 2766), (3, 2, 0, -694), (2, 1, 1, -963), (1, 3, 0, -90), (1, 0, 2, -41814),
                (0, 2, 1, 11481),
            )),
            (159667200, (
                (3, 1, 1, -16596), (2, 3, 0, 4154), (2, 0, 2, 145320), (1, 2, 1, -39228), (0, 4, 0, 2759),
                (0, 1, 2, -45948),
            )),
            (79833600, (
                (3, 0, 2, -16578), (2, 2, 1, 12438), (1, 4, 0, -2074), (1, 1, 2, -15186), (0, 3, 1, 1747),
                (0, 0, 3, 34000),
            )),
            (159667200, (
                (2, 1, 2, 16578), (1, 3, 1, -9672), (1, 0, 3, -33300), (0, 5, 0, 1382), (0, 2, 2, 11067),
            )),
        ),
    ),
}


def _check_moments(moments: Any) -> np.ndarray:
    J = as_float_array(moments, "moments", (3,))
    if not np.all(np.isfinite(J)) or not np.all(J > 0.0):
        raise ValueError(f"moments must be three positive principal moments of inertia, got {J}")
    return J


def _check_order(order: Any) -> int:
    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)) or int(order) not in ORDERS:
        raise ValueError(f"order must be one of {', '.join(str(o) for o in ORDERS)}; got {order!r}")
    return int(order)


def pencil_coefficients(moments: Any, Pi0: Any, h: float, order: int) -> tuple[float, float]:
    """``(alpha, beta)`` of the modified inverse moments ``1/J~_i = alpha + beta / J_i``.

    Parameters
    ----------
    moments : (3,) array_like
        Principal moments ``J_i > 0`` (any order).
    Pi0 : (3,) array_like
        Body angular momentum in the principal frame (only ``|Pi0|^2`` and ``Pi0 . J^-1 Pi0``
        are used, and both are conserved).
    h : float
        Step size (only ``h^2`` enters).
    order : {2, 4, 6, 8, 10, 12}
        Order of the modified method; ``order=2`` gives ``(0, 1)``.

    Returns
    -------
    alpha, beta : float
        See the module docstring.
    """
    J = _check_moments(moments)
    Pi = as_float_array(Pi0, "Pi0", (3,))
    h = as_float(h, "h")
    order = _check_order(order)
    # dimensionless form: w = s w^ with s = e1/3, so A_jm(e) = s^(j+m+1) A_jm(e^), B_jm(e) = s^(j+m) B_jm(e^)
    w = 1.0 / J
    s = float(w.sum()) / 3.0
    wh = w / s
    e = (float(wh.sum()), float(wh[0] * wh[1] + wh[0] * wh[2] + wh[1] * wh[2]), float(wh[0] * wh[1] * wh[2]))
    X = h * h * s * s * float(Pi @ Pi)          # (h |Pi| s)^2
    Y = h * h * s * float(Pi @ (w * Pi))         # h^2 s 2E
    alpha = 0.0
    beta = 1.0
    for j in range(1, order // 2):
        A, B = _COEFFICIENTS[j]
        for m in range(j + 1):
            mono = X**m * Y ** (j - m)
            alpha += _poly(A[m], e) * mono
            beta += _poly(B[m], e) * mono
    return alpha * s, beta


def _poly(entry: tuple[int, tuple[tuple[int, int, int, int], ...]], e: tuple[float, float, float]) -> float:
    den, terms = entry
    return sum(k * e[0] ** a * e[1] ** b * e[2] ** c for a, b, c, k in terms) / den


def max_step_angle(moments: Any, Pi0: Any, h: float) -> float:
    """Largest rotation angle ``|h| max_t |Omega(t)|`` of a step along the free-body orbit of ``Pi0``.

    ``|Omega|^2 = sum w_i^2 Pi_i^2`` on the orbit ``|Pi|^2 = C``, ``Pi . W Pi = 2E`` is largest
    where the orbit crosses the plane of the axes with the extreme inverse moments ``w_min``,
    ``w_max``: ``|Omega|_max^2 = (w_min + w_max) 2E - w_min w_max C`` (an upper bound for every
    point of the orbit, since ``(w_i - w_min)(w_i - w_max) <= 0``, and attained).
    """
    J = _check_moments(moments)
    Pi = as_float_array(Pi0, "Pi0", (3,))
    w = 1.0 / J
    lo, hi = float(w.min()), float(w.max())
    sq = (lo + hi) * float(Pi @ (w * Pi)) - lo * hi * float(Pi @ Pi)
    sq = max(sq, float(np.max(w * w * Pi * Pi)))   # round-off guard (and exact for |Pi| on one axis)
    return abs(float(h)) * float(np.sqrt(sq))


def modified_inertia(moments: Any, Pi0: Any, h: float, order: int) -> np.ndarray:
    """Modified principal moments ``J~`` of the order-``order`` DMV method, shape (3,).

    ``1/J~_i = alpha + beta / J_i`` with :func:`pencil_coefficients`; ``order=2`` returns the
    moments unchanged. The LGVI free-body step run with ``J~`` (and ``h``, ``Pi0`` the same) is a
    method of order ``order`` for both the momentum and the attitude of the body with moments
    ``J``. See the module docstring for the formulas and their range of validity.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.modified import modified_inertia
    >>> Jt = modified_inertia([1.0, 2.0, 3.0], [0.3, 2.0, 0.6], 0.1, 4)
    >>> bool(np.all(np.abs(Jt / [1.0, 2.0, 3.0] - 1.0) < 1e-2))
    True
    """
    J = _check_moments(moments)
    alpha, beta = pencil_coefficients(J, Pi0, h, order)
    if order == 2:
        return J.copy()
    inv = alpha + beta / J
    if not np.all(inv > 0.0):
        raise ValueError(f"the step h={h:g} is too large for the order-{order} modified inertia: "
                         f"1/J~ = {inv} is not positive (the modification series is meant for "
                         "h |Pi|/J_min up to about 1); reduce |h|")
    return 1.0 / inv


def _principal_frame(inertia: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """True inertia (3,3), principal moments in the frame used, and the rotation Q (or None).

    A diagonal inertia keeps its body frame (the moments in their given order); a full matrix
    ``J = Q diag(m) Q^T`` is integrated in the principal frame (``R Q``, ``Q^T Pi``).
    """
    body = inertia if isinstance(inertia, RigidBody) else RigidBody(inertia)
    J = np.array(body.J)
    if np.count_nonzero(J - np.diag(np.diag(J))) == 0:
        return J, np.diag(J).copy(), None
    return J, np.array(body.principal_moments), np.array(body.principal_axes)


def _to_true(traj: Trajectory, J: np.ndarray, Q: np.ndarray | None, meta: dict[str, Any]) -> Trajectory:
    R, Pi = traj.R, traj.Pi
    if Q is not None:
        R = R @ Q.T                       # R_body = R_principal Q^T
        Pi = Pi @ Q.T                     # Pi_body = Q Pi_principal (rows)
    return Trajectory(t=traj.t, R=np.array(R), Pi=np.array(Pi), inertia=J.copy(), iterations=traj.iterations,
                      residual=traj.residual, h=traj.h, potential=None, meta=dict(traj.meta, **meta))


def simulate_modified(body_moments: Any, R0: Any, Pi0: Any = None, *, h: float, steps: int, order: int,
                      save_every: int = 1, method: str = "cayley", omega0: Any = None, tol: float = 1e-14,
                      max_iter: int = 50, t0: float = 0.0) -> Trajectory:
    """Free rigid body with the modified-inertia DMV method of order ``order``, one solve per step.

    Builds the body with the modified moments :func:`modified_inertia` and runs the compiled
    free-body kernels of :func:`lgvi.simulate` with it; the attitude needs no processing.

    Parameters
    ----------
    body_moments : (3,) array_like, (3, 3) array_like or RigidBody
        The true body: principal moments, or an inertia matrix. A non-diagonal matrix
        ``J = Q diag(m) Q^T`` (``Q`` = :attr:`RigidBody.principal_axes`) is integrated in its
        principal frame, starting from ``R0 Q`` and ``Q^T Pi0``, and the results are rotated back
        (``R Q^T``, ``Q Pi``), vectorised after the run.
    R0 : (3, 3) array_like or scipy Rotation
        Initial attitude (body to inertial).
    Pi0 : (3,) array_like, optional
        Initial body angular momentum (or give ``omega0``).
    h : float
        Step size, non-zero (negative integrates backwards).
    steps : int
        Number of steps.
    order : {2, 4, 6, 8, 10, 12}
        Order of the method (2 is the unmodified LGVI).
    save_every : int
        Keep every ``save_every``-th state (must divide ``steps``).
    method, tol, max_iter
        Solver of the implicit equation, as in :func:`lgvi.simulate` (default the Cayley Newton
        solver, the fastest for the free body).
    omega0 : (3,) array_like, optional
        Initial body angular velocity, ``Pi0 = J omega0`` with the true ``J``.
    t0 : float
        Initial time.

    Returns
    -------
    Trajectory
        With the true inertia in ``.inertia`` and the true body momentum in ``.Pi`` (so
        ``.energy``, ``.omega`` are those of the true body); ``.residual`` is that of the
        modified implicit equation. ``meta`` adds ``scheme="modified-inertia"``, ``order``,
        ``modified_moments``, ``pencil`` (``[alpha, beta]``) and ``principal_axes`` (or None).

    Raises
    ------
    ValueError
        Invalid input, or a step too large for the modification (see :func:`modified_inertia`).
    ConvergenceError, SimulationInterrupted
        As in :func:`lgvi.simulate`; ``.trajectory`` is converted to the true body as above.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.modified import simulate_modified
    >>> traj = simulate_modified([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.1,
    ...                          steps=100, order=6)
    >>> traj.meta["scheme"], traj.meta["order"], traj.Pi.shape
    ('modified-inertia', 6, (101, 3))
    """
    J, moments, Q = _principal_frame(body_moments)
    order = _check_order(order)
    h = as_float(h, "h", nonzero=True)
    as_int(steps, "steps", minimum=0)
    R = as_rotation(R0, "R0")
    if (Pi0 is None) == (omega0 is None):
        raise ValueError("give either the initial body angular momentum Pi0 (3,) or the angular velocity "
                         "omega0 (3,), not both and not neither")
    Pi = as_float_array(Pi0, "Pi0", (3,)) if Pi0 is not None else J @ as_float_array(omega0, "omega0", (3,))
    if Q is not None:
        R = R @ Q
        Pi = Q.T @ Pi
    if order >= 4:
        theta = max_step_angle(moments, Pi, h)
        if theta > MAX_STEP_ANGLE:
            raise ValueError(f"the step h={h:g} rotates the body by up to h |Omega|_max = {theta:.3g} rad per step; "
                             f"the order-{order} modified inertia needs at most {MAX_STEP_ANGLE} rad (it breaks down "
                             f"near pi/2): use |h| <= {abs(h) * MAX_STEP_ANGLE / theta:.4g}")
    alpha, beta = pencil_coefficients(moments, Pi, h, order)
    Jt = modified_inertia(moments, Pi, h, order)
    try:
        mod_body = RigidBody(Jt)
    except ValueError as exc:
        raise ValueError(f"the order-{order} modified moments {Jt} for h={h:g} are not a physical inertia "
                         f"({exc}); this happens for (nearly) flat bodies J3 ~ J1 + J2 or too large steps") from exc
    meta = {"scheme": "modified-inertia", "order": order, "modified_moments": [float(x) for x in Jt],
            "pencil": [float(alpha), float(beta)],
            "principal_axes": None if Q is None else Q.tolist()}
    try:
        traj = simulate(mod_body, R, Pi, h=h, steps=steps, method=method, tol=tol, max_iter=max_iter,
                        save_every=save_every, t0=t0)
    except (ConvergenceError, SimulationInterrupted) as exc:
        if getattr(exc, "trajectory", None) is not None:
            exc.trajectory = _to_true(exc.trajectory, J, Q, meta)
        raise
    return _to_true(traj, J, Q, meta)
