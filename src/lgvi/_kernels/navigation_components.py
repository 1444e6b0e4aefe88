"""Navigation with errors (estimator family, code 402): Basilisk's ``simpleNav`` attitude channels.

``simple_nav`` (code 402) reads the truth ``R``, ``omega`` and writes the navigation the flight
software reads, ``R_est``, ``omega_est``, and ``est_error`` (``R = R_est Exp(est_error)``, for
records). Its errors are Basilisk's Gauss-Markov walk (``GaussMarkov::computeNextState`` with the
propagation matrix of ``simpleNav`` without ``crossAtt``: the identity), one step per run:

``e_i <- clamp(e_i + sigma_i n_i, -b_i, b_i)`` (``n_i`` standard normal; no clamp where
``b_i = 0``), ``e = (a, d)``: ``a`` an MRP error, ``d`` a rate error (rad/s, body);

applied as ``simpleNav`` applies them: ``sigma_BN_est = addMRP(sigma_BN, a)``, the DCM ``[E][BN]``
with ``E = C(a)``, which is ``R_est = R Exp(phi)`` with ``phi = 4 atan(|a|) a / |a|`` in lgvi's
body-to-inertial ``R``; ``omega_est = omega + d``. ``docs/components.md`` ("simple_nav").

p: 0 seed, 1 stream, 2..4 attitude noise (MRP a run), 5..7 rate noise (rad/s a run), 8..10 attitude
   bounds (MRP; 0: none), 11..13 rate bounds (rad/s; 0: none)
s: 0 counter (normals), 1..3 attitude error a (MRP), 4..6 rate error d (rad/s)
"""

from __future__ import annotations

import math

from .._jit import jit
from .attitude_kernels import quat_from_matrix, quat_from_rotvec, quat_mul, quat_to_matrix
from .finite import finite_status, written, written_at
from .random import normal_at, stream_key

SIMPLE_NAV = 402


@jit(inline="always")
def simple_nav_step(t, bus, p, s, w):
    key = stream_key(p[0], p[1])
    c = s[0]
    for i in range(6):
        e = s[1 + i] + p[2 + i] * normal_at(key, c + i)
        b = p[8 + i]
        if b > 0.0 and abs(e) > b:
            e = math.copysign(b, e)
        s[1 + i] = e
    s[0] = c + 6
    # the MRP error as a rotation vector: 4 atan|a| a / |a| (4 a to round-off below |a| = 1e-8)
    a = math.sqrt(s[1] * s[1] + s[2] * s[2] + s[3] * s[3])
    f = 4.0 if a < 1e-8 else 4.0 * math.atan(a) / a
    x, y, z = f * s[1], f * s[2], f * s[3]
    r0, r1, r2, r3 = quat_from_matrix(bus, w[0])
    e0, e1, e2, e3 = quat_from_rotvec(x, y, z)
    q0, q1, q2, q3 = quat_mul(r0, r1, r2, r3, e0, e1, e2, e3)
    quat_to_matrix(q0, q1, q2, q3, bus, w[2])
    o = w[1]
    d = w[3]
    v0 = bus[o] + s[4]
    v1 = bus[o + 1] + s[5]
    v2 = bus[o + 2] + s[6]
    bus[d] = v0
    bus[d + 1] = v1
    bus[d + 2] = v2
    g = w[4]
    bus[g] = -x
    bus[g + 1] = -y
    bus[g + 2] = -z
    # every value written tested here (the loop tests nothing after an estimator, :mod:`.finite`)
    return finite_status(written_at(bus, w[2], 9) + written(v0, v1, v2) + written(x, y, z))
