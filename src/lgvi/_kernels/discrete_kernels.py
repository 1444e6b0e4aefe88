"""Compiled Stormer-Verlet for a particle in the Kepler potential (``lgvi.discrete``).

The trapezoidal discrete Lagrangian of ``L = 1/2 qdot^T M qdot - V(q)`` with constant ``M``,

    L_d(q0, q1) = h [1/2 ((q1 - q0)/h)^T M ((q1 - q0)/h) - (V(q0) + V(q1))/2],

gives the discrete Euler-Lagrange step in position-momentum form in closed form:

    p_k     = -D1 L_d(q_k, q_{k+1}) = M (q_{k+1} - q_k)/h + h/2 grad V(q_k)
    p_{k+1} =  D2 L_d(q_k, q_{k+1}) = M (q_{k+1} - q_k)/h - h/2 grad V(q_{k+1})

that is, with the half-step momentum ``p_half = M (q_{k+1} - q_k)/h``:

    p_half  = p_k - h/2 grad V(q_k)
    q_{k+1} = q_k + h M^-1 p_half
    p_{k+1} = p_half - h/2 grad V(q_{k+1})

(Stormer-Verlet, "kick-drift-kick"). Here ``V(q) = -mu/|q|`` and ``grad V(q) = mu q/|q|^3``.

The momentum update uses ``p_half`` rather than re-forming ``M (q_{k+1} - q_k)/h``: both are the
same number in exact arithmetic, but the difference quotient loses ``log10(|q|/|h p|)`` digits
per step, which would show as a random walk in the angular momentum.

Only float64 arrays and scalars cross this boundary (no Python callables), so the kernel is
cached by Numba.
"""

from __future__ import annotations

import numpy as np

from .._jit import jit


@jit
def kepler_gradient(mu, q, out):
    """out = grad V(q) = mu q / |q|^3 for V = -mu/|q|; returns False if |q| is 0 or not finite."""
    n = q.shape[0]
    r2 = 0.0
    for i in range(n):
        r2 += q[i] * q[i]
    if not (r2 > 0.0 and r2 < np.inf):
        return False
    c = mu / (r2 * np.sqrt(r2))
    for i in range(n):
        out[i] = c * q[i]
    return True


@jit
def kepler_verlet_run(q, p, M, Minv, h, mu, steps, q_out, p_out, res_out):
    """Advance ``steps`` Stormer-Verlet steps from ``(q, p)`` (updated in place).

    Parameters
    ----------
    q, p : (n,) float64
        State at step 0; on return the last state reached.
    M, Minv : (n, n) float64
        Constant mass matrix and its inverse.
    h, mu : float
        Step size and gravitational parameter.
    steps : int
    q_out, p_out : (steps + 1, n) float64
        Filled with the states ``0 .. steps``.
    res_out : (steps,) float64
        ``max_i |p_k + D1 L_d(q_k, q_{k+1})|_i``: the round-off left in the discrete
        Legendre transform ``F- L_d`` that the closed form solves.

    Returns
    -------
    int
        ``steps`` on success; otherwise the index ``k`` of the step that met ``|q| = 0`` or a
        non-finite value (states ``0 .. k`` are filled).
    """
    n = q.shape[0]
    g = np.empty(n)
    ph = np.empty(n)
    q1 = np.empty(n)
    half_h = 0.5 * h
    for i in range(n):
        q_out[0, i] = q[i]
        p_out[0, i] = p[i]
    if not kepler_gradient(mu, q, g):
        return 0
    for k in range(steps):
        # kick: p_half = p_k - h/2 grad V(q_k)
        for i in range(n):
            ph[i] = p[i] - half_h * g[i]
        # drift: q_{k+1} = q_k + h M^-1 p_half
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += Minv[i, j] * ph[j]
            q1[i] = q[i] + h * s
        # residual of p_k = -D1 L_d(q_k, q_{k+1}) = M (q_{k+1} - q_k)/h + h/2 grad V(q_k)
        res = 0.0
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += M[i, j] * (q1[j] - q[j])
            r = abs(p[i] - s / h - half_h * g[i])
            if not r <= res:
                res = r
        res_out[k] = res
        if not kepler_gradient(mu, q1, g):
            return k
        # kick: p_{k+1} = p_half - h/2 grad V(q_{k+1})
        for i in range(n):
            q[i] = q1[i]
            p[i] = ph[i] - half_h * g[i]
            q_out[k + 1, i] = q[i]
            p_out[k + 1, i] = p[i]
    return steps
