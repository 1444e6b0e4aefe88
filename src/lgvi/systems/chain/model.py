r"""A chain of ``n`` spherical pendulums from a fixed pivot: its parameters, energy, Legendre map
and continuous equations (NumPy; the compiled step is :mod:`lgvi._kernels.chain_kernels`).

Link ``i`` (``i = 0`` at the pivot) has length ``l_i``, direction ``q_i`` in ``S^2`` (from its inner
joint to its outer end), a point mass ``m_i`` at its outer end and, optionally, its own mass
``rho_i`` spread uniformly along it (a thin rigid rod, free to turn about its own axis at no cost).
The outer end of link ``i`` is at ``x_i = sum_{k <= i} l_k q_k``. Then

    T = 1/2 sum_ij M_ij qdot_i . qdot_j,          U = -sum_i w_i g . q_i

with, for ``i <= j``, ``M_ij = l_i l_j (sum_{a >= j} m_a + sum_{a > j} rho_a + c_ij rho_j)``,
``c_ii = 1/3``, ``c_ij = 1/2`` (``i < j``), and ``w_i = l_i (sum_{a >= i} m_a + rho_i / 2 +
sum_{a > i} rho_a)``; derivation in ``docs/two_spheres.md``.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ..._validation import REPAIR_TOL, ROTATION_TOL, as_float_array

#: Standard gravity, m/s^2 (the default ``g = (0, 0, -G0)``: ``e3`` up).
G0 = 9.80665


def chain_parameters(lengths: Any, masses: Any, link_masses: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Validated ``(M, w)``: the mass matrix ``M`` (n, n) and the gravity weights ``w`` (n,) (see the
    module notes) of links of ``lengths`` (n,) > 0 with point masses ``masses`` (n,) > 0 at their
    outer ends and, optionally, rod masses ``link_masses`` (n,) >= 0."""
    l = as_float_array(lengths, "lengths", (None,))
    n = l.shape[0]
    if n < 1:
        raise ValueError("lengths must hold one length per link (at least one link), got an empty array")
    m = as_float_array(masses, "masses", (n,))
    rho = np.zeros(n) if link_masses is None else as_float_array(link_masses, "link_masses", (n,))
    for name, a, what in (("lengths", l, "length"), ("masses", m, "point mass")):
        bad = np.flatnonzero(~(a > 0.0))
        if bad.size:
            raise ValueError(f"{name} must be positive (each link's {what}, > 0), got {name}[{bad[0]}] = "
                             f"{float(a[bad[0]])!r} in {a.tolist()}")
    bad = np.flatnonzero(~(rho >= 0.0))
    if bad.size:
        raise ValueError(f"link_masses must be >= 0 (a rod's mass), got link_masses[{bad[0]}] = {float(rho[bad[0]])!r}")
    tail_m = np.cumsum(m[::-1])[::-1]                      # sum_{a >= i} m_a
    tail_r = np.concatenate([np.cumsum(rho[::-1])[::-1][1:], [0.0]])   # sum_{a > i} rho_a
    M = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            b = max(i, j)
            M[i, j] = l[i] * l[j] * (tail_m[b] + tail_r[b] + rho[b] * (1.0 / 3.0 if i == j else 0.5))
    w = l * (tail_m + tail_r + 0.5 * rho)
    return M, w


def unit_directions(q0: Any, n: int, name: str = "q0") -> np.ndarray:
    """Validated link directions (n, 3): unit to :data:`lgvi._validation.ROTATION_TOL` (normalised),
    within :data:`REPAIR_TOL` normalised with an :class:`lgvi.errors.AttitudeWarning`, else refused."""
    q = as_float_array(q0, name, (n, 3)).copy()
    norm = np.linalg.norm(q, axis=1)
    err = np.abs(norm - 1.0)
    i = int(np.argmax(err))
    if err[i] > REPAIR_TOL:
        raise ValueError(f"{name} must hold unit vectors (| |q_i| - 1 | <= {REPAIR_TOL:g}), got |{name}[{i}]| = "
                         f"{float(norm[i])!r} ({q[i].tolist()})")
    if err[i] > ROTATION_TOL:
        from ...errors import AttitudeWarning

        warnings.warn(f"{name}[{i}] has length {float(norm[i])!r}, {err[i]:.2g} from 1 (used as is up to "
                      f"{ROTATION_TOL:g}, "
                      f"accepted up to {REPAIR_TOL:g}); dividing each direction by its length", AttitudeWarning,
                      stacklevel=4)
    return q / norm[:, None]


def tangent_velocities(qdot0: Any, q: np.ndarray, name: str = "qdot0") -> np.ndarray:
    """Validated ``qdot0`` (n, 3): tangent to the spheres (``|q_i . qdot_i| <= 1e-9 |qdot_i|``; the
    normal part within that is removed), else refused."""
    n = q.shape[0]
    if qdot0 is None:
        return np.zeros((n, 3))
    v = as_float_array(qdot0, name, (n, 3)).copy()
    normal = np.einsum("ij,ij->i", q, v)
    speed = np.linalg.norm(v, axis=1)
    bad = np.flatnonzero(np.abs(normal) > ROTATION_TOL * np.maximum(speed, 1e-300))
    bad = bad[np.abs(normal[bad]) > 0.0]
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name} must be tangent to the sphere of each link (q_i . qdot_i = 0 to "
                         f"{ROTATION_TOL:g} |qdot_i|), got q[{i}] . {name}[{i}] = {normal[i]:.3g} with "
                         f"|{name}[{i}]| = {speed[i]:.3g}; remove the component along q[{i}]")
    return v - normal[:, None] * q


def momenta(M: np.ndarray, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """Angular momenta ``pi_i = q_i x sum_j M_ij qdot_j`` (..., n, 3) of velocities ``qdot``."""
    return np.cross(q, np.einsum("ij,...jk->...ik", M, qdot))


def velocities(M: np.ndarray, q: np.ndarray, pi: np.ndarray) -> np.ndarray:
    """The tangent velocities ``qdot`` (..., n, 3) of momenta ``pi`` (the inverse Legendre map).

    ``q_i x sum_j M_ij qdot_j = pi_i`` means ``sum_j M_ij qdot_j = pi_i x q_i + c_i q_i``; with
    ``q_i . qdot_i = 0`` that is one linear system of ``4n`` unknowns ``(qdot, c)``."""
    q = np.asarray(q, dtype=np.float64)
    pi = np.asarray(pi, dtype=np.float64)
    lead = q.shape[:-2]
    n = q.shape[-2]
    A = np.zeros(lead + (4 * n, 4 * n))
    rhs = np.zeros(lead + (4 * n,))
    eye = np.eye(3)
    for i in range(n):
        for j in range(n):
            A[..., 3 * i:3 * i + 3, 3 * j:3 * j + 3] = M[i, j] * eye
        A[..., 3 * i:3 * i + 3, 3 * n + i] = -q[..., i, :]
        A[..., 3 * n + i, 3 * i:3 * i + 3] = q[..., i, :]
        rhs[..., 3 * i:3 * i + 3] = np.cross(pi[..., i, :], q[..., i, :])
    sol = np.linalg.solve(A, rhs[..., None])[..., 0]
    return sol[..., :3 * n].reshape(lead + (n, 3))


def kinetic_energy(M: np.ndarray, qdot: np.ndarray) -> np.ndarray:
    """``1/2 sum_ij M_ij qdot_i . qdot_j`` (...)."""
    return 0.5 * np.einsum("ij,...ik,...jk->...", M, qdot, qdot)


def potential_energy(w: np.ndarray, g: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``-sum_i w_i g . q_i`` (...)."""
    return -np.einsum("i,...ik,k->...", w, q, g)


def chain_equations(M: np.ndarray, w: np.ndarray, g: Any):
    """The continuous equations ``f(t, y)``, ``y = (q, qdot)`` (6n,) row-major, for a reference
    solution with :func:`scipy.integrate.solve_ivp`: ``sum_j M_ij qddot_j = w_i g + lam_i q_i``
    with ``q_i . qddot_i = -|qdot_i|^2`` (the constraint twice differentiated)."""
    M = np.asarray(M, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    g = np.asarray(g, dtype=np.float64)
    n = len(w)
    A = np.zeros((4 * n, 4 * n))
    for i in range(n):
        for j in range(n):
            A[3 * i:3 * i + 3, 3 * j:3 * j + 3] = M[i, j] * np.eye(3)
    force = (w[:, None] * g[None, :]).ravel()

    def f(t: float, y: np.ndarray) -> np.ndarray:
        q = y[:3 * n].reshape(n, 3)
        v = y[3 * n:].reshape(n, 3)
        for i in range(n):
            A[3 * i:3 * i + 3, 3 * n + i] = -q[i]
            A[3 * n + i, 3 * i:3 * i + 3] = q[i]
        rhs = np.concatenate([force, -np.einsum("ij,ij->i", v, v)])
        acc = np.linalg.solve(A, rhs)[:3 * n]
        return np.concatenate([y[3 * n:], acc])

    return f


__all__ = ["G0", "chain_equations", "chain_parameters", "kinetic_energy", "momenta", "potential_energy",
           "tangent_velocities", "unit_directions", "velocities"]
