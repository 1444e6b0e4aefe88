"""Attitude estimation: TRIAD and Davenport's q-method (plain functions) and the multiplicative
extended Kalman filter (a component of the compiled loop, :class:`MEKF`).

Conventions as everywhere in lgvi: ``R`` maps body components to inertial ones, so a body-frame
measurement ``b`` of the inertial vector ``r`` obeys ``r = R b``. The static solvers take the
measured body vectors and the reference (inertial) vectors and return ``R``; SciPy's
``Rotation.align_vectors(r, b, weights)`` solves the same weighted problem (Wahba's) and returns the
same rotation. The MEKF's equations are derived in ``docs/estimation.md``; its compiled step is
:func:`lgvi._kernels.estimation_components.mekf_step` (code 401).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validation import as_float, as_float_array, as_rotation
from ..components import Component, ComponentKind, LoopContext, Signal, register_kind
from .._kernels import estimation_components as _k
from ..spacecraft.sensors import MAG_TIME, ST_TIME, SUN_TIME, StarTracker, describe

__all__ = ["triad", "davenport", "MEKF", "EST_ERROR"]

#: The MEKF's own record: the attitude error ``dtheta`` with ``R = R_est Exp(dtheta)`` (body frame).
EST_ERROR = Signal("est_error", 3, "rad", "B", "attitude estimation error: R = R_est Exp(est_error)")

_PARALLEL = 1e-10       # |b1 x b2| / (|b1| |b2|) below this: parallel for TRIAD

#: The MEKF's initial state after its quaternion, bias and covariance (entries 43 on): no measurement
#: time yet (NaN), 0, the last sample times -inf, the kernel's work space 0 (``MEKF.state0``).
_STATE_TAIL = np.zeros(_k.STATE_SIZE - 43)
_STATE_TAIL[0] = math.nan
_STATE_TAIL[4:7] = -math.inf
_STATE_TAIL.flags.writeable = False


def _unit_rows(v: Any, name: str, n: int | None = None) -> np.ndarray:
    arr = as_float_array(v, name, (n, 3))
    norms = np.linalg.norm(arr, axis=1)
    if (norms == 0.0).any():
        raise ValueError(f"{name} must hold non-zero vectors, got {describe(arr)}")
    return arr / norms[:, None]


def _triad_frame(a: np.ndarray, b: np.ndarray, name: str) -> np.ndarray:
    c = np.cross(a, b)
    s = np.linalg.norm(c)
    if s < _PARALLEL:
        raise ValueError(f"{name} must hold two vectors that are not parallel, got {describe(np.stack([a, b]))} "
                         f"(|v1 x v2| = {s:.3g} for unit vectors; TRIAD needs two directions)")
    c /= s
    return np.column_stack([a, c, np.cross(a, c)])


def triad(body: Any, reference: Any) -> np.ndarray:
    """TRIAD: the rotation ``R`` (body -> inertial) that maps the first body vector exactly onto the
    first reference vector and the second as closely as possible.

    Parameters
    ----------
    body : (2, 3) the measured vectors in the body frame (any length; directions are used).
    reference : (2, 3) the same vectors in the inertial frame.

    Returns
    -------
    (3, 3) ndarray, ``R`` with ``R b1 || r1`` and ``R b2`` in the plane of ``r1, r2``. It equals
    ``Rotation.align_vectors(reference, body, weights=[inf, 1])``. Parallel vectors are refused.
    """
    b = _unit_rows(body, "body", 2)
    r = _unit_rows(reference, "reference", 2)
    Mb = _triad_frame(b[0], b[1], "body")
    Mr = _triad_frame(r[0], r[1], "reference")
    return Mr @ Mb.T


def davenport(body: Any, reference: Any, weights: Any = None) -> np.ndarray:
    """Wahba's problem by Davenport's q-method: the rotation ``R`` minimising
    ``sum_i w_i |r_i - R b_i|^2`` (the vectors as given, not normalised, as SciPy's
    ``Rotation.align_vectors(reference, body, weights)``).

    The optimal quaternion is the eigenvector of the largest eigenvalue of Davenport's symmetric
    4x4 matrix ``K`` built from ``B = sum_i w_i r_i b_i^T``. An attitude that the vectors leave
    undetermined (fewer than two independent directions: two equal largest eigenvalues) is refused.

    Parameters
    ----------
    body, reference : (N, 3), N >= 2.  weights : (N,) nonnegative, default ones.

    Returns
    -------
    (3, 3) ndarray, the rotation ``R``.
    """
    b = as_float_array(body, "body", (None, 3))
    r = as_float_array(reference, "reference", (b.shape[0], 3))
    if b.shape[0] < 2:
        raise ValueError(f"body must hold at least two vectors, got {b.shape[0]}")
    w = np.ones(b.shape[0]) if weights is None else as_float_array(weights, "weights", (b.shape[0],))
    if (w < 0.0).any():
        raise ValueError(f"weights must be nonnegative, got {describe(w)}")
    B = (w[:, None] * r).T @ b
    S = B + B.T
    z = np.array([B[1, 2] - B[2, 1], B[2, 0] - B[0, 2], B[0, 1] - B[1, 0]])
    K = np.empty((4, 4))             # scalar-last: [[S - tr(B) I, z], [z^T, tr(B)]]
    K[:3, :3] = S - np.trace(B) * np.eye(3)
    K[:3, 3] = z
    K[3, :3] = z
    K[3, 3] = np.trace(B)
    vals, vecs = np.linalg.eigh(K)
    if vals[3] - vals[2] <= 1e-12 * max(abs(vals[3]), 1e-300):
        raise ValueError("body and reference leave the attitude undetermined (parallel or too few vectors): "
                         f"the two largest eigenvalues of Davenport's matrix are {vals[3]:.6g} and {vals[2]:.6g}")
    x, y, zq, s = vecs[:, 3]
    # the eigenvector q is of the rotation taking reference to body components (A = R^T); R = A(q)^T
    return np.array([
        [s * s + x * x - y * y - zq * zq, 2 * (x * y - zq * s), 2 * (x * zq + y * s)],
        [2 * (x * y + zq * s), s * s - x * x + y * y - zq * zq, 2 * (y * zq - x * s)],
        [2 * (x * zq - y * s), 2 * (y * zq + x * s), s * s - x * x - y * y + zq * zq],
    ]).T


def _spd(value: Any, name: str, n: int) -> np.ndarray:
    arr = as_float_array(value, name)
    if arr.shape == (n,):
        arr = np.diag(arr)
    if arr.shape != (n, n):
        raise ValueError(f"{name} must have shape ({n},) (a diagonal) or ({n}, {n}), got shape {arr.shape}")
    if not np.allclose(arr, arr.T, rtol=1e-12, atol=0.0):
        raise ValueError(f"{name} must be symmetric positive definite: it is not symmetric, got {describe(arr)}")
    try:
        np.linalg.cholesky(arr)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name} must be symmetric positive definite, got eigenvalues "
                         f"{describe(np.linalg.eigvalsh(arr))}") from None
    return 0.5 * (arr + arr.T)


def _star_tracker_noise(c: list[float], sx: float, sz: float) -> list[float]:
    """The star tracker's noise covariance in the body frame, ``R_m = C diag(sx^2, sx^2, sz^2) C^T``
    (row-major), the kernel's row entries 20..28, from ``c``, the case matrix ``C`` row-major as nine
    floats: the same IEEE operations, in the same order, as the kernel computed it at each update
    before it moved here (so the same numbers)."""
    vx = sx * sx
    vz = sz * sz
    rows = (c[0:3], c[3:6], c[6:9])
    return [vx * (a0 * b0 + a1 * b1) + vz * a2 * b2 for a0, a1, a2 in rows for b0, b1, b2 in rows]


class MEKF(Component):
    """The multiplicative extended Kalman filter (Lefferts, Markley and Shuster 1982) as a component.

    Propagates the attitude with the gyro (``gyro_B``, bias-corrected, trapezoidal between the last
    sample and this one) and the error covariance of ``x = (dtheta, db)`` (error angles in the body
    frame, ``R = R_est Exp(dtheta)``; bias error); updates, each once per new measurement, with the
    star tracker quaternion (``st_q``), the magnetometer (``mag_B`` against ``B_N``) and the fine sun
    sensor (``sun_B`` against ``sun_N``). Writes ``R_est``, ``omega_est``, ``bias_est``, ``P_diag``
    and ``est_error`` (the true error, from ``R``, for records). Equations: ``docs/estimation.md``.

    Parameters
    ----------
    rate : float or None
        Period of the filter in seconds (None: every step); run it at the gyro's rate.
    arw, rrw : float
        The gyro's angle random walk (rad/s^0.5) and rate random walk (rad/s^1.5) the filter assumes.
    star_tracker : StarTracker, True or None
        Its ``sigma_cross``, ``sigma_about`` and ``case`` set the update's noise; ``True``: those of
        the spacecraft's one star tracker, found when the run is built (what a scenario file's
        ``star_tracker = true`` says); None: no update.
    mag_sigma : float or None
        The magnetometer's noise (T); None: no magnetometer update.
    sun_sigma : float or None
        The sun sensor's noise (rad); None: no sun update.
    R0 : (3, 3) rotation, or a scipy Rotation: the initial estimate; (B, 3, 3) (or a stack of
        rotations): one per member of an ensemble, and ``state0()`` gives one row per member.
    bias0 : (3,) rad/s, or (B, 3): one per member.
    P0 : (6,) diagonal or (6, 6) symmetric positive definite initial covariance (rad^2, (rad/s)^2).
    max_variance : float
        A covariance diagonal entry above this (or not finite) stops the run with status 2.
    gyro_output : ``"rate"`` or ``"mean"``, as the gyro's ``output``: rates at the samples are
        propagated by the trapezoid (with its commutator term), mean rates as constant over the
        interval (exact for the truth).
    """

    kind = "mekf"

    def __init__(self, *, rate: float | None = None, arw: float, rrw: float, star_tracker: StarTracker | None = None,
                 mag_sigma: float | None = None, sun_sigma: float | None = None, R0: Any = None,
                 bias0: Any = (0.0, 0.0, 0.0), P0: Any, max_variance: float = 1e6, gyro_output: str = "rate") -> None:
        self.rate: Any = None if rate is None else as_float(rate, "rate", positive=True)
        self.arw: float = as_float(arw, "arw")
        self.rrw: float = as_float(rrw, "rrw")
        for name, v in (("arw", self.arw), ("rrw", self.rrw)):
            if v < 0.0:
                raise ValueError(f"{name} must be a nonnegative noise density, got {v}")
        if star_tracker is not None and star_tracker is not True and not isinstance(star_tracker, StarTracker):
            raise TypeError("star_tracker must be a StarTracker, True (the spacecraft's) or None, got "
                            f"{star_tracker!r}")
        self.star_tracker = star_tracker
        self.mag_sigma: float | None = None if mag_sigma is None else as_float(mag_sigma, "mag_sigma", positive=True)
        self.sun_sigma: float | None = None if sun_sigma is None else as_float(sun_sigma, "sun_sigma", positive=True)
        if isinstance(star_tracker, StarTracker):
            self._check_star_tracker(star_tracker)
        if R0 is not None and hasattr(R0, "as_matrix") and not R0.single:
            R0 = R0.as_matrix()
        if R0 is not None and np.ndim(R0) == 3:
            self.R0 = np.stack([as_rotation(R, f"R0[{i}]") for i, R in enumerate(np.asarray(R0, dtype=float))])
        else:
            self.R0 = np.eye(3) if R0 is None else as_rotation(R0, "R0")
        self.bias0: np.ndarray = as_float_array(bias0, "bias0", (3,) if np.ndim(bias0) < 2 else (None, 3))
        members = {a.shape[0] for a, d in ((self.R0, 3), (self.bias0, 2)) if a.ndim == d}
        if len(members) > 1:
            raise ValueError(f"R0 and bias0 must give the same number of members, got {sorted(members)}")
        self.P0 = _spd(P0, "P0", 6)
        self.max_variance: float = as_float(max_variance, "max_variance", positive=True)
        if gyro_output not in ("rate", "mean"):
            raise ValueError(f"gyro_output must be 'rate' or 'mean' (the gyro's output), got {gyro_output!r}")
        self.gyro_output = gyro_output
        self._quaternion0()                  # kept with the filter, so each run's copy of it has it

    @staticmethod
    def _check_star_tracker(st: StarTracker) -> None:
        if min(st.sigma_cross, st.sigma_about) <= 0.0:
            raise ValueError("star_tracker must have positive sigma_cross and sigma_about for the filter's update, "
                             f"got {st.sigma_cross} and {st.sigma_about}")

    def params(self) -> np.ndarray:
        st = self.star_tracker
        if st is True:
            raise ValueError("MEKF(star_tracker=True): the star tracker is the spacecraft's, known once the run is "
                             "built (Component.setup); params() needs it")
        case = np.eye(3) if st is None else st.case
        sx = 0.0 if st is None else float(st.sigma_cross)
        sz = 0.0 if st is None else float(st.sigma_about)
        c = np.asarray(case, dtype=np.float64).ravel().tolist()
        # one list of Python floats, one array (the values of a concatenation, at a third of its cost)
        return np.array([self.arw, self.rrw, sx, sz, *c, self.mag_sigma or 0.0, self.sun_sigma or 0.0,
                         float(st is not None), float(self.mag_sigma is not None), float(self.sun_sigma is not None),
                         self.max_variance, float(self.gyro_output == "mean"), *_star_tracker_noise(c, sx, sz)],
                        dtype=np.float64)

    def state0(self) -> np.ndarray:
        """The initial state: one row, or one row per member when ``R0`` or ``bias0`` has one per member."""
        q = self._quaternion0()
        if q.ndim == 1 and self.bias0.ndim == 1:      # one row: that of the rows below, built at once
            return np.concatenate((q, self.bias0, self.P0.ravel(), _STATE_TAIL))
        B = max(q.shape[0] if q.ndim == 2 else 1, self.bias0.shape[0] if self.bias0.ndim == 2 else 1)
        rows = np.zeros((B, _k.STATE_SIZE))          # entries 44-46 and the kernel's work space (50 on): 0
        rows[:, 0:4] = q
        rows[:, 4:7] = self.bias0
        rows[:, 7:43] = self.P0.ravel()
        rows[:, 43] = math.nan
        rows[:, 47:50] = -math.inf
        return rows

    def _quaternion0(self) -> np.ndarray:
        """``R0``'s quaternion (scalar last, ``w >= 0``), by SciPy's ``Rotation.from_matrix``, kept
        with the bytes of the ``R0`` it came from (computed at construction, so the copy of the filter
        each run makes has it): SciPy's conversion costs some 0.2 ms a call, which a run of 20 000
        steps would pay again at every ``lgvi.simulate`` with the same filter (0.01 us a step); a new
        ``R0`` (the attribute reassigned or changed in place) is converted again."""
        R0 = np.ascontiguousarray(self.R0, dtype=np.float64)
        key = (R0.shape, R0.tobytes())
        kept = getattr(self, "_q0", None)
        if kept is None or kept[0] != key:
            from scipy.spatial.transform import Rotation
            q = Rotation.from_matrix(R0).as_quat()
            q = np.where(q[..., 3:] < 0.0, -q, q)
            q.flags.writeable = False
            self._q0 = kept = (key, q)
        return kept[1]

    def sizes(self) -> dict[str, int]:
        return {}

    def setup(self, ctx: LoopContext) -> None:
        """Each update the filter makes needs its sensor (and the reference vector) on the spacecraft."""
        sc = ctx.spacecraft
        have = {getattr(c, "kind", "") for c in sc.components()}
        need = [("gyro", True, "a Gyro (the filter propagates with gyro_B)"),
                ("star_tracker", self.star_tracker is not None, "a StarTracker (star_tracker= is given)"),
                ("magnetometer", self.mag_sigma is not None, "a Magnetometer (mag_sigma= is given)"),
                ("field", self.mag_sigma is not None, "a field model for B_N (mag_sigma= is given): field="),
                ("fine_sun_sensor", self.sun_sigma is not None, "a FineSunSensor (sun_sigma= is given)"),
                ("sun", self.sun_sigma is not None, "a Sun in environment= for sun_N (sun_sigma= is given)")]
        for kind, wanted, what in need:
            if wanted and kind not in have:
                raise ValueError(f"MEKF: the spacecraft needs {what}; its components are {sorted(have)}")
        if self.star_tracker is True:             # this run's copy takes the spacecraft's star tracker
            found = [c for c in sc.components() if isinstance(c, StarTracker)]
            if len(found) != 1:
                raise ValueError(f"MEKF(star_tracker=True) takes the spacecraft's star tracker and needs exactly one; "
                                 f"the spacecraft has {len(found)}: give the StarTracker itself")
            self._check_star_tracker(found[0])
            self.star_tracker = found[0]

    def __repr__(self) -> str:
        return (f"MEKF(rate={self.rate}, star_tracker={self.star_tracker is not None}, "
                f"mag={self.mag_sigma is not None}, sun={self.sun_sigma is not None})")


register_kind(ComponentKind(
    "mekf", "estimator", _k.MEKF, _k.mekf_step,
    ("gyro_B", "st_q", "st_valid", "st_time", "mag_B", "mag_time", "B_N", "sun_B", "sun_valid", "sun_time",
     "sun_N", "R"),
    ("R_est", "omega_est", "bias_est", "P_diag", "est_error"),
    cls=MEKF, own=(ST_TIME, MAG_TIME, SUN_TIME, EST_ERROR), doc=MEKF.__doc__.splitlines()[0],
    extra={"zeros": ("st_q", "st_valid", "st_time", "mag_B", "mag_time", "B_N", "sun_B", "sun_valid", "sun_time",
                     "sun_N"),
           "initial": {"st_time": math.nan, "mag_time": math.nan, "sun_time": math.nan}}))
