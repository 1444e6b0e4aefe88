r"""A rigid hub with ``n`` spherical pendulums (propellant slosh): parameters, Legendre map, energy
and an independent continuous formulation (NumPy; the compiled step is
:mod:`lgvi._kernels.slosh_kernels`, the derivation ``docs/slosh.md``).

The hub (mass ``m0``, inertia ``J0`` about its centre of mass) carries pendulum ``i``: a pivot at
``b_i`` (body frame, from the hub's centre of mass), a massless rod of length ``l_i`` and a point
mass ``m_i`` at its end, in the direction ``q_i`` (inertial unit vector). With the centre of mass
of the whole spacecraft at rest (no external force: its motion separates), the relative positions
``z_i = R b_i + l_i q_i`` give

    T = 1/2 Omega . J0 Omega + 1/2 sum_ij mu_ij zdot_i . zdot_j,    mu = diag(m) - m m^T / m_total
      = 1/2 Omega . J' Omega + sum_j (Omega x c_j) . vb_j + 1/2 sum_ij M_ij vb_i . vb_j

with ``vb_j = R^T qdot_j``, ``J' = J0 + sum_ij mu_ij ((b_i . b_j) I - b_i b_j^T)``,
``c_j = l_j sum_i mu_ij b_i`` and ``M_ij = mu_ij l_i l_j``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._validation import as_float, as_float_array


def slosh_parameters(inertia: np.ndarray, hub_mass: Any, pivots: Any, lengths: Any, masses: Any) -> dict[str, Any]:
    """The constants of the reduced system (module notes), validated: ``J`` (3, 3) the hub's
    ``J0`` (SPD), ``hub_mass > 0``, ``pivots`` (n, 3), ``lengths`` (n,) > 0, ``masses`` (n,) > 0.
    Returns a dict with ``Jp`` (``J'``), ``Jd`` (``tr(J')/2 I - J'``), ``c``, ``M``, ``Minv``,
    ``Ct`` (``Ct_i = sum_j Minv_ji c_j``), ``mu``, ``m_total`` and the validated inputs."""
    J0 = np.asarray(inertia, dtype=np.float64)
    m0 = as_float(hub_mass, "hub_mass")
    if not m0 > 0.0:
        raise ValueError(f"hub_mass must be positive (the hub's mass, kg), got {hub_mass!r}")
    l = as_float_array(lengths, "lengths", (None,))
    n = l.shape[0]
    if n < 1:
        raise ValueError("lengths must hold one length per pendulum (at least one), got an empty array")
    b = as_float_array(pivots, "pivots", (n, 3))
    m = as_float_array(masses, "masses", (n,))
    for name, a, what in (("lengths", l, "rod length"), ("masses", m, "pendulum mass")):
        bad = np.flatnonzero(~(a > 0.0))
        if bad.size:
            raise ValueError(f"{name} must be positive (each pendulum's {what}, > 0), got {name}[{bad[0]}] = "
                             f"{float(a[bad[0]])!r} in {a.tolist()}")
    m_total = m0 + m.sum()
    mu = np.diag(m) - np.outer(m, m) / m_total
    Jp = J0 + np.einsum("ij,ij->", mu, b @ b.T) * np.eye(3) - np.einsum("ij,ia,jb->ab", mu, b, b)
    Jp = 0.5 * (Jp + Jp.T)
    Jd = 0.5 * np.trace(Jp) * np.eye(3) - Jp
    c = l[:, None] * (mu @ b)                     # c_j = l_j sum_i mu_ij b_i (mu symmetric)
    M = mu * np.outer(l, l)
    Minv = np.linalg.inv(M)
    Ct = Minv.T @ c
    return {"J0": J0, "hub_mass": m0, "pivots": b.copy(), "lengths": l.copy(), "masses": m.copy(), "mu": mu,
            "m_total": m_total, "Jp": Jp, "Jd": Jd, "c": c, "M": M, "Minv": Minv, "Ct": Ct}


def momenta(P: dict[str, Any], R: np.ndarray, Omega: np.ndarray, qb: np.ndarray, vb: np.ndarray):
    """``(Pi, pi)`` of hub rate ``Omega`` (3,) and pendulum velocities ``vb`` (n, 3) (inertial velocity
    ``qdot_i`` in body axes) at directions ``qb`` (n, 3) (body axes): ``Pi = J' Omega + sum_j c_j x
    vb_j`` (body), ``pi_i = R (qb_i x (Omega x c_i + sum_j M_ij vb_j))`` (inertial)."""
    Pi = P["Jp"] @ Omega + np.cross(P["c"], vb).sum(axis=0)
    g = np.cross(Omega[None, :], P["c"]) + P["M"] @ vb
    return Pi, np.cross(qb, g) @ R.T


def velocities(P: dict[str, Any], R: np.ndarray, Pi: np.ndarray, q: np.ndarray, pi: np.ndarray):
    """``(Omega, vb)`` of the momenta (the inverse Legendre map) at ``R`` (..., 3, 3), ``q``, ``pi``
    (..., n, 3) inertial: one linear system a sample in ``(Omega, vb, lambda)``:
    ``Omega x c_i + sum_j M_ij vb_j = pib_i x qb_i + lambda_i qb_i``, ``qb_i . vb_i = 0``."""
    R = np.asarray(R, dtype=np.float64)
    lead = R.shape[:-2]
    n = P["M"].shape[0]
    qb = np.einsum("...ba,...ib->...ia", R, q)
    pib = np.einsum("...ba,...ib->...ia", R, pi)
    N = 3 + 4 * n
    A = np.zeros(lead + (N, N))
    rhs = np.zeros(lead + (N,))
    A[..., :3, :3] = P["Jp"]
    rhs[..., :3] = Pi
    hat = lambda v: np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])  # noqa: E731
    for j in range(n):
        A[..., :3, 3 + 3 * j:6 + 3 * j] = hat(P["c"][j])               # c_j x vb_j
        A[..., 3 + 3 * j:6 + 3 * j, :3] = -hat(P["c"][j])              # Omega x c_j = -c_j x Omega
        for i in range(n):
            A[..., 3 + 3 * j:6 + 3 * j, 3 + 3 * i:6 + 3 * i] = P["M"][j, i] * np.eye(3)
        A[..., 3 + 3 * j:6 + 3 * j, 3 + 3 * n + j] = -qb[..., j, :]
        A[..., 3 + 3 * n + j, 3 + 3 * j:6 + 3 * j] = qb[..., j, :]
        rhs[..., 3 + 3 * j:6 + 3 * j] = np.cross(pib[..., j, :], qb[..., j, :])
    x = np.linalg.solve(A, rhs[..., None])[..., 0]
    return x[..., :3], x[..., 3:3 + 3 * n].reshape(lead + (n, 3))


def kinetic_energy(P: dict[str, Any], Omega: np.ndarray, vb: np.ndarray) -> np.ndarray:
    """``T`` (...) of the velocities (module notes)."""
    t = 0.5 * np.einsum("...a,ab,...b->...", Omega, P["Jp"], Omega)
    t = t + np.einsum("...ja,...ja->...", np.cross(Omega[..., None, :], P["c"]), vb)
    return t + 0.5 * np.einsum("ij,...ia,...ja->...", P["M"], vb, vb)


def newton_euler(P: dict[str, Any], damping: Any = None, wheels: Any = None):
    """The continuous equations in maximal coordinates, for a reference with SciPy (independent of
    the reduced Lagrangian the integrator is built on): ``y = (x, xdot, R (9), Omega, s (3n), sdot
    (3n))``, the hub's centre of mass ``x``, the pendulum masses at ``s_i``; rods of fixed length by
    tensions ``Lambda_i`` (``d_i = s_i - x - R b_i``, ``d_i . ddot_i + |ddot_i|^2 = 0``), Newton's
    law for every mass, Euler's for the hub, and the damping force ``-d_i`` times the mass's
    velocity relative to the hub, reacted on the hub at the pivot together with its couple.

    ``wheels = (axes (Nw, 3), spin_inertia (Nw,), motor_torque (Nw,))``: balanced reaction wheels in
    the hub (``J0`` then the hub with the wheels locked) with constant motor torques; ``y`` ends
    with their absolute axial momenta ``rho`` (``rho' = u``) and Euler's law of the hub is that of
    a gyrostat, ``J_B Wdot + G u + W x (J_B W + G rho) = torque``, ``J_B = J0 - G diag(Js) G^T``."""
    J0, m0, b, l, m = P["J0"], P["hub_mass"], P["pivots"], P["lengths"], P["masses"]
    n = len(l)
    dmp = np.zeros(n) if damping is None else np.asarray(damping, dtype=np.float64)
    N = 3 * n + 6 + n
    Nw = 0
    JB = J0
    if wheels is not None:
        ax, Js, uw = (np.asarray(v, dtype=np.float64) for v in wheels)
        Nw = len(Js)
        JB = J0 - (ax.T * Js) @ ax
        Gu = ax.T @ uw

    def f(t: float, y: np.ndarray) -> np.ndarray:
        xd = y[3:6]
        R = y[6:15].reshape(3, 3)
        W = y[15:18]
        s = y[18:18 + 3 * n].reshape(n, 3)
        sd = y[18 + 3 * n:18 + 6 * n].reshape(n, 3)
        w = R @ W                                   # inertial rate
        Rb = b @ R.T                                # (n, 3) pivots, inertial
        d = s - y[0:3][None, :] - Rb
        dd = sd - xd[None, :] - np.cross(w[None, :], Rb)
        frc = -dmp[:, None] * (dd - np.cross(w[None, :], d))      # relative to the hub frame
        # unknowns: sdd (3n), xdd (3), Wdot (3, body), Lambda (n)
        A = np.zeros((N, N))
        rhs = np.zeros(N)
        if Nw:
            gyro = -np.cross(W, JB @ W + ax.T @ y[18 + 6 * n:]) - Gu
        else:
            gyro = -np.cross(W, J0 @ W)
        tq = np.zeros(3)
        for i in range(n):
            r = slice(3 * i, 3 * i + 3)
            A[r, r] = m[i] * np.eye(3)
            A[r, 3 * n + 6 + i] = d[i]                           # m sdd + Lambda d = frc
            rhs[r] = frc[i]
            tq -= np.cross(Rb[i] + d[i], frc[i])
        # hub: m0 xdd - sum Lambda_i d_i = -sum frc_i
        A[3 * n:3 * n + 3, 3 * n:3 * n + 3] = m0 * np.eye(3)
        for i in range(n):
            A[3 * n:3 * n + 3, 3 * n + 6 + i] = -d[i]
        rhs[3 * n:3 * n + 3] = -frc.sum(axis=0)
        # Euler (inertial torque about the hub's centre of mass, in body axes):
        # J0 Wdot - R^T sum_i Lambda_i (R b_i) x d_i = -W x J0 W + R^T tq
        A[3 * n + 3:3 * n + 6, 3 * n + 3:3 * n + 6] = JB
        for i in range(n):
            A[3 * n + 3:3 * n + 6, 3 * n + 6 + i] = -(R.T @ np.cross(Rb[i], d[i]))
        rhs[3 * n + 3:3 * n + 6] = gyro + R.T @ tq
        # constraints: d_i . (sdd_i - xdd - R (Wdot x b_i) - w x (w x R b_i)) = -|dd_i|^2
        for i in range(n):
            row = 3 * n + 6 + i
            A[row, 3 * i:3 * i + 3] = d[i]
            A[row, 3 * n:3 * n + 3] = -d[i]
            # -d . R (Wdot x b) = -(R^T d) . (Wdot x b) = -Wdot . (b x R^T d)
            A[row, 3 * n + 3:3 * n + 6] = -np.cross(b[i], R.T @ d[i])
            rhs[row] = -dd[i] @ dd[i] + d[i] @ np.cross(w, np.cross(w, Rb[i]))
        sol = np.linalg.solve(A, rhs)
        Rd = R @ np.array([[0.0, -W[2], W[1]], [W[2], 0.0, -W[0]], [-W[1], W[0], 0.0]])
        out = np.concatenate([xd, sol[3 * n:3 * n + 3], Rd.ravel(), sol[3 * n + 3:3 * n + 6], sd.ravel(),
                              sol[:3 * n]])
        return np.concatenate([out, uw]) if Nw else out

    return f


def newton_euler_state(P: dict[str, Any], R: np.ndarray, Omega: np.ndarray, qb: np.ndarray, qb_rate: np.ndarray,
                       wheel_momentum: Any = None):
    """The initial ``y`` of :func:`newton_euler` (centre of mass at rest at the origin) of hub
    attitude ``R``, rate ``Omega`` (body), directions ``qb`` and their rates relative to the hub
    ``qb_rate`` (body axes), and the wheels' absolute axial momenta (with ``wheels``)."""
    b, l, m, m0 = P["pivots"], P["lengths"], P["masses"], P["hub_mass"]
    z = (b + l[:, None] * qb) @ R.T                                    # relative to the hub CM
    zd = (np.cross(Omega[None, :], b + l[:, None] * qb) + l[:, None] * qb_rate) @ R.T
    mt = m0 + m.sum()
    x = -(m[:, None] * z).sum(axis=0) / mt
    xd = -(m[:, None] * zd).sum(axis=0) / mt
    s = x[None, :] + z
    sd = xd[None, :] + zd
    y = np.concatenate([x, xd, R.ravel(), Omega, s.ravel(), sd.ravel()])
    return y if wheel_momentum is None else np.concatenate([y, np.asarray(wheel_momentum, dtype=np.float64)])


def newton_euler_split(P: dict[str, Any], y: np.ndarray):
    """``(R, q)`` (..., 3, 3), (..., n, 3) of states ``y`` (..., 18 + 6n) of :func:`newton_euler`."""
    n = len(P["lengths"])
    y = np.asarray(y)
    R = y[..., 6:15].reshape(y.shape[:-1] + (3, 3))
    s = y[..., 18:18 + 3 * n].reshape(y.shape[:-1] + (n, 3))
    Rb = np.einsum("...ab,ib->...ia", R, P["pivots"])
    d = s - y[..., None, 0:3] - Rb
    return R, d / P["lengths"][:, None]


__all__ = ["kinetic_energy", "momenta", "newton_euler", "newton_euler_split", "newton_euler_state",
           "slosh_parameters", "velocities"]
