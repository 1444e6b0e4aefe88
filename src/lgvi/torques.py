r"""Torque and potential models: moments described as data, evaluated inside compiled kernels.

A model is passed as ``simulate(..., torque=model)``. The integrator never calls back into Python
for it: :meth:`TorqueModel.encode` turns the model into two flat arrays (integer codes and float
parameters) that :mod:`lgvi._kernels.torque_kernels` evaluates in every step. Each model also
has a plain NumPy evaluator, :meth:`TorqueModel.moment`, vectorised over leading axes, for
baselines, plots and tests.

Models add up: ``UniformGravity(1.0, [0, 0, 0.3]) + LinearDamping(0.01)`` is a
:class:`TorqueSum`, itself a model.

Each model declares the quantities its runs conserve, :meth:`TorqueModel.invariants` (the kinds
and the rules are in :mod:`lgvi.invariants`): uniform gravity the total energy (bounded) and
``e3 . R Pi`` (exact), the gravity gradient the Jacobi integral ``E - n e3 . R Pi`` (bounded), the
others nothing; a sum keeps what all its members conserve.

================================  ============  ===================  ===============
model                             conservative  depends on momentum  time-dependent
================================  ============  ===================  ===============
:class:`UniformGravity`           yes           no                   no
:class:`GravityGradient`          yes           no                   yes (the orbit)
:class:`Constant`                 no            no                   no
:class:`LinearDamping`            no            yes                  no
:class:`AttitudePD`               no            yes                  no
================================  ============  ===================  ===============

Conventions
-----------
All moments are in the body frame. ``R`` maps body vectors to inertial ones, ``Pi = J Omega``.
A conservative model has a potential ``U(t, R)`` and its moment is ``M = -dU`` in the sense of
the LGVI: for every ``eta`` in R^3,

.. math::

    \frac{d}{d\epsilon} U(t, R \exp(\epsilon \hat\eta)) \Big|_{\epsilon=0} = -M \cdot \eta .

The integrator treats conservative moments with the variational (symmetric) LGVI of Lee, Leok and
McClamroch and reports ``U`` in :attr:`lgvi.Trajectory.potential`.

Kernel encoding
---------------
``encode()`` returns ``codes`` (n, 2) int64, one row ``(kind, offset)`` per term, and ``params``
float64 in which term ``i`` owns ``params[offset : offset + PARAM_COUNT[kind]]``:

* ``GRAVITY`` (1): ``mass * g * com`` (3)
* ``GRAVITY_GRADIENT`` (2): ``3 mu / r^3``, ``n = sqrt(mu / r^3)`` (2)
* ``CONSTANT`` (3): ``u`` (3)
* ``DAMPING`` (4): ``c`` (3, per body axis)
* ``ATTITUDE_PD`` (5): ``kp`` (3), ``kd`` (3), ``R_target`` row-major (9)

Every momentum dependence of the built-in models is ``-D Omega`` with a diagonal ``D`` (the
damping ``c`` and the derivative gain ``kd``), which lets the symmetric scheme solve for
``Pi_{k+1}`` exactly with one 3x3 linear solve.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._validation import as_float, as_float_array, as_rotation
from .invariants import combine, declares_invariants

__all__ = [
    "AttitudePD",
    "Compiled",
    "Constant",
    "GravityGradient",
    "LinearDamping",
    "TORQUE_MODELS",
    "TorqueModel",
    "TorqueSum",
    "UniformGravity",
]

# kernel codes (shared with lgvi._kernels.torque_kernels)
GRAVITY = 1
GRAVITY_GRADIENT = 2
CONSTANT = 3
DAMPING = 4
ATTITUDE_PD = 5
PARAM_COUNT = {GRAVITY: 3, GRAVITY_GRADIENT: 2, CONSTANT: 3, DAMPING: 3, ATTITUDE_PD: 15}

#: The registry of torque models: scenario key -> class (filled by each class that sets ``key``).
TORQUE_MODELS: dict[str, type["TorqueModel"]] = {}

E3 = np.array([0.0, 0.0, 1.0])


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a


def _num(x: float) -> str:
    return f"{x:.10g}"


def _vec_text(v: np.ndarray) -> str:
    return "[" + ", ".join(map(_num, np.asarray(v, dtype=np.float64).tolist())) + "]"


def _gain(value: Any, name: str) -> np.ndarray:
    """A non-negative gain: a scalar (the same on every body axis) or (3,) per body axis."""
    arr = as_float_array(value, name)
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    elif arr.shape != (3,):
        raise ValueError(f"{name} must be a scalar or have shape (3,), got shape {arr.shape}")
    if np.any(arr < 0.0):
        raise ValueError(f"{name} must be >= 0 (a gain, per body axis), got {arr}")
    return arr


def _gain_text(v: np.ndarray) -> str:
    return _num(float(v[0])) if v[0] == v[1] == v[2] else _vec_text(v)


def _body_arrays(body: Any) -> tuple[np.ndarray, np.ndarray]:
    from .body import RigidBody

    b = body if isinstance(body, RigidBody) else RigidBody(body)
    return b.J, b.J_inv


def _state(R: Any, Pi: Any | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    R = np.asarray(R, dtype=np.float64)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise ValueError(f"R must have shape (..., 3, 3), got shape {R.shape}")
    if Pi is not None:
        Pi = np.asarray(Pi, dtype=np.float64)
        if Pi.ndim < 1 or Pi.shape[-1] != 3:
            raise ValueError(f"Pi must have shape (..., 3), got shape {Pi.shape}")
    return R, Pi


def _time(t: Any) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64)
    return t


@declares_invariants  # lgvi.invariants.declaration_of reads a model's own declaration
class TorqueModel:
    """Base class of the torque models (a moment given as data; see the module notes).

    Subclasses set the class attributes and implement ``_terms`` (kernel encoding), ``moment``
    and, when conservative, ``potential``.
    """

    #: The moment derives from a potential ``U(t, R)`` (``M = -dU``, see the module notes).
    conservative: bool = False
    #: The moment depends on the angular momentum (``Pi``, through ``Omega = J^-1 Pi``).
    depends_on_momentum: bool = False
    #: The moment depends explicitly on time.
    time_dependent: bool = False

    # -- registration (lgvi.registry): a model with a ``key`` is registered when it is defined ----
    #: Scenario key (``[[torque]] type = key``) and registry name; ``None``: not registered.
    key: str | None = None
    #: Kernel kind code of its term (a branch of :mod:`lgvi._kernels.torque_kernels`).
    code: int | None = None
    #: Scenario parameters: name -> ``(kind, required)``; kinds ``"number"``, ``"positive"``,
    #: ``"vector"`` (3 numbers), ``"gain"`` (a number or 3), ``"attitude"`` (a rotation).
    scenario_params: dict[str, tuple[str, bool]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        key = cls.__dict__.get("key")
        if key is not None:
            if key in TORQUE_MODELS and TORQUE_MODELS[key].__qualname__ != cls.__qualname__:
                raise ValueError(f"torque model key {key!r} is taken by {TORQUE_MODELS[key].__name__}")
            TORQUE_MODELS[key] = cls

    @classmethod
    def from_scenario(cls, spec: dict[str, Any]) -> "TorqueModel":
        """The model of a checked ``[[torque]]`` table (``spec`` holds its parameters by name)."""
        return cls(**{k: v for k, v in spec.items() if k != "type"})

    @classmethod
    def summary(cls) -> str:
        """First line of the class docstring (help texts and docs)."""
        return (cls.__doc__ or "").strip().splitlines()[0] if cls.__doc__ else cls.__name__

    def parameters(self) -> dict[str, np.ndarray]:
        """The model's parameters by scenario name, as float64 arrays (a copy).

        ``type(model).from_scenario(model.parameters())`` rebuilds the model; ensembles with
        per-body models record these (:attr:`lgvi.EnsembleTrajectory.model_params`).
        """
        return {name: np.array(getattr(self, name), dtype=np.float64) for name in self.scenario_params}

    def invariants(self) -> dict[str, dict[str, Any]]:
        """The quantities the LGVI conserves under this moment (see :mod:`lgvi.invariants`).

        Returns
        -------
        dict
            Quantity key (of :data:`lgvi.invariants.QUANTITIES`) -> ``{"kind": "exact" or
            "bounded", **parameters}``; quantities not listed are not invariants. Empty here:
            a model conserves nothing unless it says so.
        """
        return {}

    # -- kernel encoding ------------------------------------------------------------------
    def _terms(self) -> list[tuple[int, np.ndarray]]:
        raise NotImplementedError(
            f"{type(self).__name__} subclasses TorqueModel but does not implement _terms(), its kernel "
            "encoding (a list of (kind code, parameters) with a branch in lgvi._kernels.torque_kernels; "
            "see docs/architecture.md), nor moment(t, R, Pi, body). For a moment written in Python "
            "compiled with numba.njit, use lgvi.torques.Compiled(moment, potential=..., params=...) instead")

    @property
    def terms(self) -> tuple["TorqueModel", ...]:
        """The elementary models this one is made of (itself for a single model)."""
        return (self,)

    def encode(self) -> tuple[np.ndarray, np.ndarray]:
        """Kernel form: ``codes`` (n, 2) int64 rows ``(kind, offset)`` and ``params`` float64.

        See the module notes for the layout of each kind.
        """
        rows = []
        chunks = []
        offset = 0
        for kind, p in self._terms():
            rows.append((kind, offset))
            chunks.append(np.asarray(p, dtype=np.float64).ravel())
            offset += PARAM_COUNT[kind]
        codes = np.array(rows, dtype=np.int64).reshape(len(rows), 2)
        params = np.concatenate(chunks) if chunks else np.zeros(0)
        return codes, np.ascontiguousarray(params, dtype=np.float64)

    # -- NumPy evaluation --------------------------------------------------------------------
    def moment(self, t: Any, R: Any, Pi: Any, body: Any) -> np.ndarray:
        """Body-frame moment at time ``t`` and state ``(R, Pi)``.

        Parameters
        ----------
        t : float or array_like
            Time (broadcast against the leading axes of ``R``).
        R : (..., 3, 3) array_like
            Attitudes.
        Pi : (..., 3) array_like
            Body angular momenta (ignored by models that do not depend on them).
        body : RigidBody or array_like
            The body (or its inertia).

        Returns
        -------
        (..., 3) ndarray
        """
        raise NotImplementedError(
            f"{type(self).__name__} subclasses TorqueModel but does not implement moment(t, R, Pi, body), "
            "the NumPy evaluation of its moment (and _terms(), its kernel encoding; see "
            "docs/architecture.md). For a moment compiled with numba.njit, use lgvi.torques.Compiled")

    def potential(self, t: Any, R: Any, body: Any) -> np.ndarray | None:
        """Potential energy ``U(t, R)`` (shape ``R.shape[:-2]``), or ``None`` if not conservative."""
        return None

    # -- algebra -----------------------------------------------------------------------------
    def __add__(self, other: Any) -> "TorqueSum":
        if not isinstance(other, TorqueModel):
            return NotImplemented
        return TorqueSum(*self.terms, *other.terms)

    def __radd__(self, other: Any) -> "TorqueModel":
        if isinstance(other, (int, float)) and not isinstance(other, bool) and other == 0:
            return self  # so that sum(models) works
        return NotImplemented

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TorqueModel):
            return NotImplemented
        a_codes, a_params = self.encode()
        b_codes, b_params = other.encode()
        return bool(np.array_equal(a_codes, b_codes) and np.array_equal(a_params, b_params))

    def __hash__(self) -> int:
        codes, params = self.encode()
        return hash((codes.tobytes(), (params + 0.0).tobytes()))


class UniformGravity(TorqueModel):
    r"""Uniform gravity on a body pivoting about a fixed point (heavy top, 3D pendulum).

    Inertial ``e3`` points up and gravity acts along ``-e3``; ``com`` is the centre of mass in the
    body frame, measured from the pivot (the origin of the body frame, about which ``J`` is taken).

    Parameters
    ----------
    mass : float
        Mass, > 0.
    com : (3,) array_like
        Centre of mass in the body frame, from the pivot.
    g : float
        Gravitational acceleration, >= 0 (default 9.81).

    Notes
    -----
    ``U(R) = mass g e3 . (R com)`` and ``M = mass g (R^T e3) x com``. About the vertical the
    moment has no component (``e3 . R M = 0``), so the LGVI conserves ``e3 . R Pi`` to round-off.

    Lee, Leok and McClamroch take ``e3`` along gravity (down): their ``rho`` is ``-com`` here,
    and their 3D pendulum (``rho = 0.3 e3``, hanging at ``R = I``) is ``com = [0, 0, -0.3]``.

    Examples
    --------
    >>> import numpy as np
    >>> from lgvi.torques import UniformGravity
    >>> m = UniformGravity(1.0, [0.0, 0.0, 0.3])
    >>> m
    UniformGravity(mass=1, com=[0, 0, 0.3], g=9.81)
    >>> float(m.potential(0.0, np.eye(3), [1.0, 1.0, 1.0]))
    2.943
    """
    scenario_params: dict[str, tuple[str, bool]]
    key = "uniform_gravity"
    code = GRAVITY
    scenario_params = {"mass": ("positive", True), "com": ("vector", True), "g": ("positive", False)}

    conservative = True

    def __init__(self, mass: float, com: Any, g: float = 9.81):
        self.mass: float = as_float(mass, "mass", positive=True)
        self.com: np.ndarray = _readonly(as_float_array(com, "com", (3,)))
        self.g: float = as_float(g, "g")
        if self.g < 0.0:
            raise ValueError(f"g must be >= 0 (gravity acts along -e3), got {self.g}")
        with np.errstate(over="ignore", invalid="ignore"):
            moment = self.mass * self.g * self.com
        if not np.all(np.isfinite(moment)):
            raise ValueError(f"mass * g * com must be finite (the kernels use it), got {moment} "
                             f"(mass={self.mass}, g={self.g}, com={self.com})")

    def __repr__(self) -> str:
        return f"UniformGravity(mass={_num(self.mass)}, com={_vec_text(self.com)}, g={_num(self.g)})"

    def _terms(self):
        return [(GRAVITY, self.mass * self.g * self.com)]

    def invariants(self) -> dict[str, dict[str, Any]]:
        """Total energy (bounded) and ``e3 . R Pi``, the momentum about the gravity axis (exact)."""
        return {"spatial_momentum_e3": {"kind": "exact"}, "energy": {"kind": "bounded"}}

    def moment(self, t: Any, R: Any, Pi: Any, body: Any) -> np.ndarray:
        R, _ = _state(R)
        s = R[..., 2, :]                                   # R^T e3
        return np.cross(s, self.mass * self.g * self.com)

    def potential(self, t: Any, R: Any, body: Any) -> np.ndarray | None:
        R, _ = _state(R)
        return self.mass * self.g * (R[..., 2, :] @ self.com)


class GravityGradient(TorqueModel):
    r"""Gravity-gradient moment on a body on a circular orbit.

    The orbit lies in the inertial ``e1``-``e2`` plane (orbit normal ``e3``), with radius ``r``
    and rate ``n = sqrt(mu / r^3)``; the position direction is
    ``r_hat(t) = (cos n t, sin n t, 0)`` (on ``e1`` at ``t = 0``).

    Parameters
    ----------
    mu : float
        Gravitational parameter, > 0.
    radius : float
        Orbit radius ``r``, > 0.

    Notes
    -----
    The energy changes (the orbit does work on the attitude); the Jacobi integral
    ``C = E - n e3 . R Pi`` is conserved (see :mod:`lgvi.invariants`).

    With ``c = -R^T r_hat(t)`` the nadir direction in the body frame,

    ``M = 3 mu / r^3  c x (J c)``,   ``U = 3/2 mu / r^3  c . J c``.

    ``U`` is the gravity-gradient part of the potential; the dropped terms
    ``-mu m / r - mu tr(J) / (2 r^3)`` are constant on a circular orbit. The body is at rest
    in the orbiting frame when its axis of least inertia points to nadir.

    Axis naming (used by the libration tests): the local-vertical local-horizontal frame has
    roll axis ``x`` along the orbital velocity, pitch axis ``y`` along the negative orbit normal
    and yaw axis ``z`` to nadir; with the body's principal axes on them (body axis 1 along the
    velocity, 2 against the orbit normal, 3 to nadir) and ``J = diag(J1, J2, J3)``, small pitch
    librations have frequency ``sqrt(3 n^2 (J1 - J3) / J2)``. That attitude is
    ``R(t) = [v_hat(t), -e3, -r_hat(t)]`` (columns), ``v_hat = (-sin n t, cos n t, 0)``, and its
    body rate is ``Omega = (0, -n, 0)``.

    Examples
    --------
    >>> from lgvi.torques import GravityGradient
    >>> GravityGradient(mu=3.986e14, radius=7.0e6)
    GravityGradient(mu=3.986e+14, radius=7000000)
    """
    scenario_params: dict[str, tuple[str, bool]]
    key = "gravity_gradient"
    code = GRAVITY_GRADIENT
    scenario_params = {"mu": ("positive", True), "radius": ("positive", True)}

    conservative = True
    time_dependent = True

    def __init__(self, mu: float, radius: float):
        self.mu: float = as_float(mu, "mu", positive=True)
        self.radius: float = as_float(radius, "radius", positive=True)
        with np.errstate(over="ignore", divide="ignore", under="ignore"):
            k = float(np.float64(self.mu) / np.float64(self.radius) ** 3)
        if not (np.isfinite(k) and k > 0.0):
            raise ValueError(f"mu / radius^3 must be a positive finite number, got {k} "
                             f"(mu={self.mu}, radius={self.radius})")

    @property
    def mean_motion(self) -> float:
        """Orbital rate ``n = sqrt(mu / r^3)``."""
        return float(np.sqrt(self.mu / self.radius ** 3))

    def __repr__(self) -> str:
        return f"GravityGradient(mu={_num(self.mu)}, radius={_num(self.radius)})"

    def _terms(self):
        k = self.mu / self.radius ** 3
        return [(GRAVITY_GRADIENT, np.array([3.0 * k, np.sqrt(k)]))]

    def invariants(self) -> dict[str, dict[str, Any]]:
        """The Jacobi integral ``E - n e3 . R Pi`` (bounded), the energy in the frame that turns
        with the orbit; neither the energy nor any momentum is conserved."""
        return {"jacobi": {"kind": "bounded", "n": self.mean_motion}}

    def nadir(self, t: Any, R: Any) -> np.ndarray:
        """Nadir direction ``c = -R^T r_hat(t)`` in the body frame, shape ``(..., 3)``."""
        R, _ = _state(R)
        nt = self.mean_motion * _time(t)
        r_hat = np.zeros(nt.shape + (3,))           # (cos nt, sin nt, 0), without stacking three arrays
        r_hat[..., 0] = np.cos(nt)
        r_hat[..., 1] = np.sin(nt)
        return -np.einsum("...ji,...j->...i", R, r_hat)

    def moment(self, t: Any, R: Any, Pi: Any, body: Any) -> np.ndarray:
        J, _ = _body_arrays(body)
        c = self.nadir(t, R)
        return 3.0 * self.mu / self.radius ** 3 * np.cross(c, c @ J.T)

    def potential(self, t: Any, R: Any, body: Any) -> np.ndarray | None:
        J, _ = _body_arrays(body)
        c = self.nadir(t, R)
        return 1.5 * self.mu / self.radius ** 3 * np.einsum("...i,...i->...", c, c @ J.T)


class Constant(TorqueModel):
    """A constant body-frame moment ``u`` (for example a thruster fixed on the body).

    Parameters
    ----------
    u : (3,) array_like
        The moment, in the body frame.

    Examples
    --------
    >>> from lgvi.torques import Constant
    >>> Constant([0.0, 0.0, 1e-3])
    Constant(u=[0, 0, 0.001])
    """
    scenario_params: dict[str, tuple[str, bool]]
    key = "constant"
    code = CONSTANT
    scenario_params = {"u": ("vector", True)}

    def __init__(self, u: Any):
        self.u: np.ndarray = _readonly(as_float_array(u, "u", (3,)))

    def __repr__(self) -> str:
        return f"Constant(u={_vec_text(self.u)})"

    def _terms(self):
        return [(CONSTANT, self.u)]

    def moment(self, t: Any, R: Any, Pi: Any, body: Any) -> np.ndarray:
        R, Pi = _state(R, Pi)
        shape = np.broadcast_shapes(R.shape[:-2], Pi.shape[:-1]) if Pi is not None else R.shape[:-2]
        return np.broadcast_to(self.u, shape + (3,)).copy()


class LinearDamping(TorqueModel):
    """Linear viscous damping ``u = -c Omega`` (``Omega = J^-1 Pi``).

    Parameters
    ----------
    c : float or (3,) array_like
        Damping coefficient, >= 0: one for all body axes or one per body axis
        (``u_i = -c_i Omega_i``).

    Examples
    --------
    >>> from lgvi.torques import LinearDamping
    >>> LinearDamping(0.1), LinearDamping([0.1, 0.2, 0.3])
    (LinearDamping(c=0.1), LinearDamping(c=[0.1, 0.2, 0.3]))
    """
    scenario_params: dict[str, tuple[str, bool]]
    key = "damping"
    code = DAMPING
    scenario_params = {"c": ("gain", True)}

    depends_on_momentum = True

    def __init__(self, c: Any):
        self.c: np.ndarray = _readonly(_gain(c, "c"))

    def __repr__(self) -> str:
        return f"LinearDamping(c={_gain_text(self.c)})"

    def _terms(self):
        return [(DAMPING, self.c)]

    def moment(self, t: Any, R: Any, Pi: Any, body: Any) -> np.ndarray:
        _, J_inv = _body_arrays(body)
        Pi = np.asarray(Pi, dtype=np.float64)
        return -self.c * (Pi @ J_inv.T)


class AttitudePD(TorqueModel):
    r"""Geometric attitude controller (proportional-derivative on SO(3)) towards ``R_target``.

    ``e_R = vee(R_d^T R - R^T R_d) / 2``, ``u = -kp e_R - kd Omega``.

    Parameters
    ----------
    kp, kd : float or (3,) array_like
        Proportional and derivative gains, >= 0 (one for all body axes, or per body axis).
    R_target : (3, 3) array_like or scipy Rotation, optional
        Desired attitude ``R_d`` (default the identity).

    Notes
    -----
    With scalar ``kp`` the proportional part is the moment of the potential
    ``kp / 2 tr(I - R_d^T R)`` = ``kp (1 - cos angle)``, and with ``kd > 0`` the closed loop
    converges to ``R_d`` from any attitude rotated less than pi away from it (almost global
    convergence). The model is not conservative as a whole (``kd`` dissipates).

    Examples
    --------
    >>> from lgvi.torques import AttitudePD
    >>> AttitudePD(kp=2.0, kd=1.5)
    AttitudePD(kp=2, kd=1.5)
    """
    scenario_params: dict[str, tuple[str, bool]]
    key = "pd"
    code = ATTITUDE_PD
    scenario_params = {"kp": ("gain", True), "kd": ("gain", True), "target": ("attitude", False)}

    @classmethod
    def from_scenario(cls, spec: dict[str, Any]) -> "TorqueModel":
        return cls(spec["kp"], spec["kd"], spec.get("target", np.eye(3)))

    depends_on_momentum = True

    def __init__(self, kp: Any, kd: Any, R_target: Any = None):
        self.kp: np.ndarray = _readonly(_gain(kp, "kp"))
        self.kd: np.ndarray = _readonly(_gain(kd, "kd"))
        Rd = np.eye(3) if R_target is None else as_rotation(R_target, "R_target")
        self.R_target: np.ndarray = _readonly(Rd)

    def parameters(self) -> dict[str, np.ndarray]:
        return {"kp": self.kp.copy(), "kd": self.kd.copy(), "target": self.R_target.copy()}

    def __repr__(self) -> str:
        text = f"AttitudePD(kp={_gain_text(self.kp)}, kd={_gain_text(self.kd)}"
        if not np.array_equal(self.R_target, np.eye(3)):
            text += ", R_target=[" + ", ".join(_vec_text(row) for row in self.R_target) + "]"
        return text + ")"

    def _terms(self):
        return [(ATTITUDE_PD, np.concatenate([self.kp, self.kd, self.R_target.ravel()]))]

    def attitude_error(self, R: Any) -> np.ndarray:
        """``e_R = vee(R_d^T R - R^T R_d) / 2``, shape ``(..., 3)``."""
        R, _ = _state(R)
        A = np.einsum("ji,...jk->...ik", self.R_target, R)   # R_d^T R
        return 0.5 * np.stack([A[..., 2, 1] - A[..., 1, 2], A[..., 0, 2] - A[..., 2, 0],
                               A[..., 1, 0] - A[..., 0, 1]], axis=-1)

    def moment(self, t: Any, R: Any, Pi: Any, body: Any) -> np.ndarray:
        _, J_inv = _body_arrays(body)
        Pi = np.asarray(Pi, dtype=np.float64)
        return -self.kp * self.attitude_error(R) - self.kd * (Pi @ J_inv.T)


class TorqueSum(TorqueModel):
    """A sum of torque models (what ``model_a + model_b`` returns); nested sums are flattened.

    Conservative when every term is; depends on momentum or time when any term does. Its
    ``potential`` is the sum of the potentials of its conservative terms (``None`` if there are
    none), so a damped heavy top reports the gravity energy.

    Examples
    --------
    >>> from lgvi.torques import UniformGravity, LinearDamping
    >>> UniformGravity(1.0, [0, 0, 0.3]) + LinearDamping(0.01)
    TorqueSum(UniformGravity(mass=1, com=[0, 0, 0.3], g=9.81), LinearDamping(c=0.01))
    """

    def __init__(self, *models: TorqueModel):
        flat: list[TorqueModel] = []
        for i, m in enumerate(models):
            if not isinstance(m, TorqueModel):
                raise TypeError(f"TorqueSum terms must be torque models (lgvi.torques), got "
                                f"{type(m).__name__} as term {i}")
            flat.extend(m.terms)
        if not flat:
            raise ValueError("TorqueSum needs at least one model")
        self._models = tuple(flat)

    @property
    def terms(self) -> tuple[TorqueModel, ...]:
        return self._models

    @property
    def conservative(self) -> bool:  # type: ignore[override]
        return all(m.conservative for m in self._models)

    @property
    def depends_on_momentum(self) -> bool:  # type: ignore[override]
        return any(m.depends_on_momentum for m in self._models)

    @property
    def time_dependent(self) -> bool:  # type: ignore[override]
        return any(m.time_dependent for m in self._models)

    def invariants(self) -> dict[str, dict[str, Any]]:
        """What every term conserves, with the weaker kind (:func:`lgvi.invariants.combine`)."""
        return combine([m.invariants() for m in self._models])

    def __repr__(self) -> str:
        return "TorqueSum(" + ", ".join(repr(m) for m in self._models) + ")"

    def _terms(self):
        out = []
        for m in self._models:
            out.extend(m._terms())
        return out

    def moment(self, t: Any, R: Any, Pi: Any, body: Any) -> np.ndarray:
        total = None
        for m in self._models:
            v = m.moment(t, R, Pi, body)
            total = v if total is None else total + v
        return total

    def potential(self, t: Any, R: Any, body: Any) -> np.ndarray | None:
        total = None
        for m in self._models:
            if m.conservative:
                v = m.potential(t, R, body)
                total = v if total is None else total + v
        return total


def _is_dispatcher(f: Any) -> bool:
    try:
        from numba.core.registry import CPUDispatcher
    except Exception:  # pragma: no cover
        return False
    return isinstance(f, CPUDispatcher)


def tried_rows(n: int) -> range | list[int]:
    """The rows (bodies) a :class:`Compiled` model's functions are tried at in their Python form, at
    its construction and before an ensemble: all of them up to 64, else the first and the last 32. A
    trial costs tens of microseconds (a minute for a million bodies); what it catches for one row (an
    index past ``params``, a wrong shape) is the same for every row, and a row whose values fail (a
    division by zero) stops its body in the compiled loop, which names the body."""
    return range(n) if n <= 64 else [*range(32), *range(n - 32, n)]


class Compiled(TorqueModel):
    r"""A moment the user writes and compiles with ``numba.njit``; it runs inside the compiled loops.

    Parameters
    ----------
    moment : numba.njit function
        ``moment(t, R, Pi, params)`` -> the body-frame moment, a tuple of 3 floats or a (3,)
        array; ``t`` float, ``R`` (3, 3), ``Pi`` (3,), ``params`` (P,) float64 arrays.
    potential : numba.njit function, optional
        ``potential(t, R, params)`` -> float, with ``moment = -dU`` (see the module notes). With
        it the model is conservative: the variational (symmetric) LGVI is used for it and
        :attr:`lgvi.Trajectory.energy` includes it. ``moment`` must then not depend on ``Pi``.
    params : array_like, optional
        (P,) parameters passed to the functions (default empty); for
        :func:`lgvi.simulate_ensemble` also (B, P), one row per body.
    momentum_dependent : bool
        ``moment`` depends on ``Pi`` (with ``forcing="symmetric"`` its momentum equation is then
        solved by fixed-point iteration to ``tol``).

    Notes
    -----
    The compiled loops take the user's moment as a value of one function type (a Numba ``cfunc``
    made once per function and process: the user's function's own compilation), so one loop,
    compiled once and cached on disk, serves every model. A trial call at ``R = I``, ``Pi = 0``,
    ``t = 0`` checks that the functions compile and return finite values of the right shape.
    Before each run the functions are tried once more in their Python form (``.py_func``) at
    the run's first sample (:meth:`check_sample`; each body's in an ensemble): an index past
    ``params`` (which compiled code, without bounds checks, reads from memory past the array),
    a division by zero or a wrong return shape is a :class:`lgvi.TorqueError` naming the model.
    No invariants are declared. A non-finite moment during a run stops it with
    :class:`lgvi.ConvergenceError` holding the partial trajectory; an exception the moment raises
    inside the compiled loop stops it with :class:`lgvi.TorqueError`, the part computed before
    that step in ``.trajectory``.

    Examples
    --------
    >>> import numba, numpy as np
    >>> from lgvi.torques import Compiled
    >>> @numba.njit
    ... def spring(t, R, Pi, p):
    ...     return (-p[0] * R[2, 1], p[0] * R[2, 0], 0.0)
    >>> Compiled(spring, params=[2.0]).moment(0.0, np.eye(3), np.zeros(3), None)
    array([-0.,  0.,  0.])
    """

    def __init__(self, moment: Any, *, potential: Any = None, params: Any = None,
                 momentum_dependent: bool = False):
        for name, f in (("moment", moment), ("potential", potential)):
            if f is not None and not _is_dispatcher(f):
                raise TypeError(f"Compiled: {name} must be a function compiled with @numba.njit "
                                f"(decorate it: @numba.njit def {name}(...)), got {type(f).__name__} {f!r}")
        if not isinstance(momentum_dependent, (bool, np.bool_)):
            raise TypeError(f"momentum_dependent must be True or False, got {momentum_dependent!r}")
        if potential is not None and momentum_dependent:
            raise ValueError("Compiled: a model with a potential is conservative, its moment cannot depend on Pi "
                             "(momentum_dependent=True); write the Pi-dependent part as a second model")
        p = np.zeros(0) if params is None else np.array(params, dtype=np.float64)
        if p.ndim not in (1, 2):
            raise ValueError(f"Compiled: params must have shape (P,) or (B, P) (one row per body of an "
                             f"ensemble), got shape {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError(f"Compiled: params must be finite, got {p}")
        self.moment_func = moment
        self.potential_func = potential
        self.params: np.ndarray = _readonly(p)
        self.depends_on_momentum: bool = bool(momentum_dependent)
        self.conservative: bool = potential is not None
        self.time_dependent = True          # the user's functions receive t: assume they use it
        rows = self.params if p.ndim == 2 else self.params[None]
        for r in tried_rows(len(rows)):
            self._trial(np.ascontiguousarray(rows[r]))

    def _trial(self, row: np.ndarray) -> None:
        name = getattr(self.moment_func, "__name__", "moment")
        if isinstance(self._python_call(self.moment_func, (0.0, np.eye(3), np.zeros(3), row.copy()))[1], IndexError):
            return      # compiled, this call would read memory past params (anything): check_sample refuses it at the run
        try:
            m = np.asarray(self.moment_func(0.0, np.eye(3), np.zeros(3), row), dtype=np.float64)
        except Exception as exc:
            raise TypeError(f"Compiled: the trial call {name}(0.0, R=I, Pi=zeros(3), params) failed: "
                            f"{type(exc).__name__}: {exc}") from exc
        if m.shape != (3,) or not np.all(np.isfinite(m)):
            raise ValueError(f"Compiled: {name}(t, R, Pi, params) must return 3 finite numbers (a tuple or a (3,) "
                             f"array), got {m!r} (shape {m.shape}) at t=0, R=I, Pi=0")
        if self.potential_func is not None:
            pname = getattr(self.potential_func, "__name__", "potential")
            try:
                u = np.asarray(self.potential_func(0.0, np.eye(3), row), dtype=np.float64)
            except Exception as exc:
                raise TypeError(f"Compiled: the trial call {pname}(0.0, R=I, params) failed: "
                                f"{type(exc).__name__}: {exc}") from exc
            if u.shape != () or not np.isfinite(u):
                raise ValueError(f"Compiled: {pname}(t, R, params) must return a finite float, got {u!r}")

    def _python_call(self, func: Any, args: tuple) -> tuple[Any, BaseException | None]:
        """``func``'s Python form (``.py_func``) on ``args``, with a float division by zero raising as
        it does compiled: ``(value, None)`` or ``(None, the exception)``."""
        py = getattr(func, "py_func", func)
        try:
            with np.errstate(divide="raise"):
                return py(*args), None
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            return None, exc

    def check_sample(self, t: float, R: Any, Pi: Any, b: int | None = None, where: str = "the first sample") -> None:
        """Try the user's functions once outside Numba, in their Python form (``.py_func``), at
        ``(t, R, Pi)`` with the parameters (of body ``b``), before a run: an index past ``params``
        (which the compiled loop, without bounds checks, would read from memory past the array),
        a division by zero or a return of the wrong shape is a :class:`lgvi.TorqueError` naming
        the model and the sample. A function whose Python form cannot run at all (it uses what
        only Numba provides) is tried compiled instead."""
        from .errors import TorqueError

        row = self.row(b)
        who = f"{self!r}{'' if b is None else f' (body {b})'}"
        for kind, func, args in (("moment", self.moment_func, (float(t), np.array(R, dtype=np.float64),
                                                                 np.array(Pi, dtype=np.float64), row.copy())),
                                 ("potential", self.potential_func, (float(t), np.array(R, dtype=np.float64),
                                                                     row.copy()))):
            if func is None:
                continue
            name = getattr(func, "__name__", kind)
            value, exc = self._python_call(func, args)
            if exc is not None and not isinstance(exc, (ArithmeticError, IndexError, KeyError, ValueError)):
                try:            # not a fault of the values: a Python form that cannot run; the compiled call decides
                    value, exc = func(*args), None
                except Exception as compiled:
                    exc = compiled
            if exc is not None:
                past = isinstance(exc, IndexError)
                what = f"indexes past the end of an array (params has size {row.size}): " if past else ""
                then = "read memory past the array" if past else "stop the run"
                raise TorqueError(f"{who}: {kind} {name}(t, R, {'Pi, ' if kind == 'moment' else ''}params) {what}"
                                  f"raised {type(exc).__name__}: {exc} in its Python form ({name}.py_func) at {where} "
                                  f"(t = {float(t):g}); compiled, this would {then}; fix the function or its params",
                                  step=0, time=float(t)) from exc
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
                arr = np.asarray([np.nan])
            want = (3,) if kind == "moment" else ()
            if arr.shape != want or not np.all(np.isfinite(arr)):
                raise TorqueError(f"{who}: {kind} {name} must return {'3 finite numbers' if kind == 'moment' else 'a finite float'}"
                                  f", got {value!r} at {where} (t = {float(t):g}) in its Python form",
                                  step=0, time=float(t))

    def raised_error(self, step: int, t: float, h: float, R: Any, Pi: Any, b: int | None, trajectory: Any,
                     where: str = "") -> Exception:
        """The :class:`lgvi.TorqueError` of a run whose compiled loop caught an exception of the user's
        moment at ``step`` (``USER_RAISED``, time ``t``, step ``h``); ``R``, ``Pi`` the state at the
        start of that step. Its Python form is tried there (at ``t`` and ``t + h``) to name the
        exception."""
        from .errors import TorqueError

        name = getattr(self.moment_func, "__name__", "moment")
        said = ""
        for when, tt in (("at the start of the step", t), ("at its end time with that state", t + h)):
            value, exc = self._python_call(self.moment_func, (float(tt), np.array(R, dtype=np.float64),
                                                              np.array(Pi, dtype=np.float64), self.row(b).copy()))
            if exc is not None:
                said = f" ({name}.py_func {when}, t = {tt:g}, raises {type(exc).__name__}: {exc})"
                break
            if np.shape(value) != (3,):     # the guard refuses a moment of another length as a raise
                said = f" ({name}.py_func {when}, t = {tt:g}, returns {value!r}, not 3 numbers)"
                break
        who = f"{self!r}{'' if b is None else f' of body {b}'}"
        return TorqueError(f"the moment of {who} raised an exception inside the compiled loop at step {step} "
                           f"(t = {t:g}){said}. The run up to step {step} is in .trajectory.{where}", step=step,
                           time=t, trajectory=trajectory)

    def __repr__(self) -> str:
        text = f"Compiled({getattr(self.moment_func, '__name__', '?')}"
        if self.potential_func is not None:
            text += f", potential={getattr(self.potential_func, '__name__', '?')}"
        if self.params.size:
            text += f", params shape {self.params.shape}"
        if self.depends_on_momentum:
            text += ", momentum_dependent=True"
        return text + ")"

    def __add__(self, other: Any) -> Any:
        raise TypeError("a Compiled torque model cannot be added to other models: write the sum in the "
                        "compiled moment (and potential)")

    __radd__ = __add__  # type: ignore[assignment]

    def __eq__(self, other: object) -> bool:
        return self is other

    def __hash__(self) -> int:
        return id(self)

    def _terms(self):
        return []

    def encode(self) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0)

    def row(self, b: int | None = None) -> np.ndarray:
        """The (P,) parameters (of body ``b`` when ``params`` is (B, P))."""
        if self.params.ndim == 1:
            return np.ascontiguousarray(self.params)
        if b is None:
            if self.params.shape[0] == 1:
                return np.ascontiguousarray(self.params[0])
            raise ValueError(f"Compiled: params of shape {self.params.shape} (one row per body) are for "
                             "simulate_ensemble; simulate takes params of shape (P,)")
        return np.ascontiguousarray(self.params[b])

    # moment / potential evaluate n samples in one compiled loop (user_kernels.user_moment_series /
    # user_potential_series, cached on disk, taking the user's function guarded) when n >= series_min
    # and the guard of the user's function is already made in this process (a run made the moment's),
    # or n >= series_compile (making it compiles the function and its cfunc, ~0.15 s; the per-sample
    # Python calls cost ~1-3 us); otherwise with one call per sample from Python. See
    # benchmarks/bench_compiled_energy.py
    series_min = 16
    series_compile = 100_000

    def _series(self, func, n):
        """The compiled series loop is worth using for ``n`` samples of ``func``."""
        if n < self.series_min:
            return False
        if n >= self.series_compile:
            return True
        from ._kernels.guards import made

        return made(func)

    @staticmethod
    def _guard(make, func):
        """``make(func)`` (the guarded ``cfunc``), or None for a return type the loops cannot convert."""
        from numba.core.errors import TypingError

        try:
            return make(func)
        except TypingError:
            return None

    def potential_of_bodies(self, t: Any, R: Any, first: int = 0) -> np.ndarray | None:
        """The potential of an ensemble's saved samples: ``R`` (B, M, 3, 3) at times ``t`` (M,), body
        ``b`` with its row ``first + b`` of ``params`` (B', P) or the one row of (P,), in one compiled
        loop (a call per body cost tens of microseconds: half a minute for a million bodies)."""
        if self.potential_func is None:
            return None
        R = np.ascontiguousarray(R, dtype=np.float64)
        B, M = R.shape[:2]
        table = self.params[first:first + B] if self.params.ndim == 2 else self.params.reshape(1, -1)
        from ._kernels.user_kernels import guarded_potential, user_potential_bodies

        out = np.empty((B, M))
        call = self._guard(guarded_potential, self.potential_func)
        if call is not None and user_potential_bodies(
                call, np.ascontiguousarray(_time(t), dtype=np.float64).reshape(M), R, table, np.empty((3, 3)), out) < 0:
            return out
        # a return type the loop cannot convert, or the function raised: body by body (which raises)
        for b in range(B):
            out[b] = self.potential(t, R[b], None, b=first + b if self.params.ndim == 2 else None)
        return out

    def moment(self, t: Any, R: Any, Pi: Any, body: Any, b: int | None = None) -> np.ndarray:
        R, Pi = _state(R, Pi)
        p = self.row(b)
        lead = R.shape[:-2]
        t = np.broadcast_to(_time(t), lead)
        Pi = np.broadcast_to(Pi, lead + (3,))
        n = int(np.prod(lead, dtype=np.int64))
        from ._kernels.user_kernels import guarded, user_moment_series
        call = self._guard(guarded, self.moment_func) if self._series(self.moment_func, n) else None
        if call is not None:            # None: few samples, or a return type the loop cannot convert
            out = np.empty((n, 3))
            bad = user_moment_series(call, np.ascontiguousarray(t, dtype=np.float64).reshape(n),
                                     np.ascontiguousarray(R, dtype=np.float64).reshape(n, 3, 3),
                                     np.ascontiguousarray(Pi, dtype=np.float64).reshape(n, 3), p, np.empty((3, 3)),
                                     np.empty(3), out)
            if bad < 0:                 # else the function raised or returned other than 3 numbers: per sample
                return out.reshape(lead + (3,))
        out = np.empty(lead + (3,))
        for i in np.ndindex(*lead):
            out[i] = np.asarray(self.moment_func(float(t[i]), np.array(R[i]), np.array(Pi[i]), p),
                                dtype=np.float64)     # copies: the user's function cannot change the samples
        return out

    def potential(self, t: Any, R: Any, body: Any, b: int | None = None) -> np.ndarray | None:
        if self.potential_func is None:
            return None
        R, _ = _state(R)
        p = self.row(b)
        lead = R.shape[:-2]
        t = np.broadcast_to(_time(t), lead)
        n = int(np.prod(lead, dtype=np.int64))
        from ._kernels.user_kernels import guarded_potential, user_potential_series
        call = self._guard(guarded_potential, self.potential_func) if self._series(self.potential_func, n) else None
        if call is not None:            # None: few samples, or a return type the loop cannot convert
            out = np.empty(n)
            if user_potential_series(call, np.ascontiguousarray(t, dtype=np.float64).reshape(n),
                                     np.ascontiguousarray(R, dtype=np.float64).reshape(n, 3, 3), p, np.empty((3, 3)),
                                     out) < 0:
                return out.reshape(lead)    # else the function raised: per sample below (which raises)
        out = np.empty(lead)
        for i in np.ndindex(*lead):
            out[i] = float(self.potential_func(float(t[i]), np.array(R[i]), p))
        return out
