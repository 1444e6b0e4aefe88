"""Geomagnetic field kernels: a Schmidt semi-normalised spherical-harmonic synthesis.

The internal field of degree ``N`` has the potential (geocentric spherical coordinates
``r``, colatitude ``theta``, east longitude ``phi``, reference radius ``a``)

``V = a sum_{n=1..N} (a/r)^(n+1) sum_{m=0..n} (g_nm cos(m phi) + h_nm sin(m phi)) P_n^m(cos theta)``

with ``P_n^m`` the Schmidt semi-normalised associated Legendre functions, and ``B = -grad V``:

``B_r = sum (n+1) (a/r)^(n+2) sum (g cos + h sin) P``,
``B_theta = -sum (a/r)^(n+2) sum (g cos + h sin) dP/dtheta``,
``B_phi = sum (a/r)^(n+2) sum m (g sin - h cos) P / sin(theta)``.

The functions follow the recursions (``c = cos theta``, ``s = sin theta``)
``P_0^0 = 1``, ``P_1^1 = s``, ``P_n^n = sqrt((2n-1)/(2n)) s P_{n-1}^{n-1}`` (n >= 2) and, for
``n > m``, ``P_n^m = ((2n-1) c P_{n-1}^m - sqrt((n-1)^2 - m^2) P_{n-2}^m) / sqrt(n^2 - m^2)``.
``P_n^m / s`` (m >= 1) obeys the same recursions from ``P_1^1 / s = 1``, so ``B_phi`` is
evaluated without a division by ``sin theta`` and is finite on the poles.

Coefficients ``g``, ``h`` are (N+1, N+1) arrays indexed ``[n, m]`` (flat, row-major, in
:func:`sh_field_flat`); the scratch arrays ``P``, ``dP``, ``Q`` have the same shape, so the kernels
allocate nothing. The recursions' factors ``sqrt((2n-1)/(2n))``, ``(2n-1)/sqrt(n^2 - m^2)`` and
``sqrt((n-1)^2 - m^2)/sqrt(n^2 - m^2)`` are constants of the degree: :func:`sh_recursion_constants`
computes them once (the same operations, so the same values), and an evaluation reads them (about
180 square roots and divisions an evaluation fewer at degree 13).
"""

from __future__ import annotations

import math

from .._jit import jit


def recursion_constants_size(n1):
    """The length of :func:`sh_recursion_constants`' array for (n1, n1) coefficients: ``2 n1^2 + n1``."""
    return 2 * n1 * n1 + n1


@jit(_nrt=False)
def sh_recursion_constants(n1, C):
    """The recursions' factors for (n1, n1) coefficients into ``C`` (:func:`recursion_constants_size`):
    ``e[n, m] = (2n-1) / sqrt(n^2 - m^2)`` at ``n n1 + m``, ``f[n, m] = sqrt((n-1)^2 - m^2) /
    sqrt(n^2 - m^2)`` at ``n1^2 + n n1 + m`` (``n - 2 >= m``; 0 elsewhere) and ``k[n] =
    sqrt((2n-1)/(2n))`` at ``2 n1^2 + n`` (``n >= 2``), for ``1 <= n < n1``, ``0 <= m < n``."""
    q = n1 * n1
    for i in range(2 * q + n1):
        C[i] = 0.0
    for n in range(1, n1):
        if n >= 2:
            C[2 * q + n] = math.sqrt((2.0 * n - 1.0) / (2.0 * n))
        for m in range(0, n):
            i = n * n1 + m
            d = math.sqrt(float(n * n - m * m))
            C[i] = (2.0 * n - 1.0) / d
            if n - 2 >= m:
                C[q + i] = math.sqrt(float((n - 1) * (n - 1) - m * m)) / d


@jit(inline="always")
def sh_field_flat(x, y, z, G, og, H, oh, n1, nmax, a, P, oP, dP, odP, Q, oQ, C, oC):
    """Field of the expansion ``(g, h)`` at the Earth-fixed point ``(x, y, z)`` (same unit as ``a``).

    The (N+1, N+1) arrays are indexed flat, row-major with ``n1`` columns: ``g[n, m]`` is
    ``G[og + n n1 + m]``, ``h``, ``P``, ``dP``, ``Q`` likewise from ``H[oh]``, ``P[oP]``, ``dP[odP]``,
    ``Q[oQ]`` (one state array with offsets in the loop's field component: reshaped views of its
    slices cost a call each); ``C[oC:]`` the recursions' factors, :func:`sh_recursion_constants` of
    ``n1``. Returns ``(bx, by, bz)`` in Earth-fixed Cartesian components, in the
    unit of ``g`` and ``h``.
    """
    rho2 = x * x + y * y
    r = math.sqrt(rho2 + z * z)
    rho = math.sqrt(rho2)
    c = z / r
    s = rho / r
    if rho > 0.0:
        cp = x / rho
        sp = y / rho
    else:
        cp = 1.0
        sp = 0.0
    # Legendre functions, their theta derivatives and P/sin(theta); [n, m] at n * n1 + m
    P[oP] = 1.0
    dP[odP] = 0.0
    Q[oQ] = 0.0
    for n in range(1, nmax + 1):
        nn = n * n1 + n                 # [n, n]
        pp = nn - n1 - 1                # [n - 1, n - 1]
        if n == 1:
            P[oP + nn] = s
            dP[odP + nn] = c
            Q[oQ + nn] = 1.0
        else:
            k = C[oC + 2 * n1 * n1 + n]
            P[oP + nn] = k * s * P[oP + pp]
            dP[odP + nn] = k * (c * P[oP + pp] + s * dP[odP + pp])
            Q[oQ + nn] = k * s * Q[oQ + pp]
        for m in range(0, n):
            i = n * n1 + m              # [n, m]
            i1 = i - n1                 # [n - 1, m]
            i2 = i1 - n1                # [n - 2, m]
            e = C[oC + i]
            if n - 2 >= m:
                f = C[oC + n1 * n1 + i]
                P[oP + i] = e * c * P[oP + i1] - f * P[oP + i2]
                dP[odP + i] = e * (c * dP[odP + i1] - s * P[oP + i1]) - f * dP[odP + i2]
                Q[oQ + i] = e * c * Q[oQ + i1] - f * Q[oQ + i2]
            else:
                P[oP + i] = e * c * P[oP + i1]
                dP[odP + i] = e * (c * dP[odP + i1] - s * P[oP + i1])
                Q[oQ + i] = e * c * Q[oQ + i1]
    br = 0.0
    bt = 0.0
    bp = 0.0
    ar = a / r
    arn = ar * ar            # (a/r)^(n+2) at n = 0
    for n in range(1, nmax + 1):
        arn *= ar
        sr = 0.0
        st = 0.0
        sph = 0.0
        cm = 1.0             # cos(m phi), sin(m phi) by the angle-sum recursion
        sm = 0.0
        for m in range(0, n + 1):
            i = n * n1 + m
            gnm = G[og + i]
            hnm = H[oh + i]
            gc = gnm * cm + hnm * sm
            sr += gc * P[oP + i]
            st += gc * dP[odP + i]
            sph += m * (gnm * sm - hnm * cm) * Q[oQ + i]
            cm, sm = cm * cp - sm * sp, sm * cp + cm * sp
        br += (n + 1.0) * arn * sr
        bt -= arn * st
        bp += arn * sph
    # spherical (r, theta, phi) unit vectors to Earth-fixed Cartesian
    bx = (br * s + bt * c) * cp - bp * sp
    by = (br * s + bt * c) * sp + bp * cp
    bz = br * c - bt * s
    return bx, by, bz


@jit(inline="always")
def sh_field_ecef(x, y, z, g, h, nmax, a, P, dP, Q, C):
    """:func:`sh_field_flat` on (N+1, N+1) C-contiguous arrays ``g``, ``h``, scratch ``P``, ``dP``,
    ``Q`` and the recursions' factors ``C`` (:func:`sh_recursion_constants`)."""
    return sh_field_flat(x, y, z, g.reshape(-1), 0, h.reshape(-1), 0, g.shape[1], nmax, a, P.reshape(-1), 0,
                         dP.reshape(-1), 0, Q.reshape(-1), 0, C, 0)


@jit(_nrt=False)
def sh_field_many(xyz, g, h, nmax, a, P, dP, Q, C, out):
    """``out[i] = field(xyz[i])`` for (K, 3) Earth-fixed points (see :func:`sh_field_ecef`)."""
    for i in range(xyz.shape[0]):
        bx, by, bz = sh_field_ecef(xyz[i, 0], xyz[i, 1], xyz[i, 2], g, h, nmax, a, P, dP, Q, C)
        out[i, 0] = bx
        out[i, 1] = by
        out[i, 2] = bz


@jit(_nrt=False)
def sh_field_one(x, y, z, g, h, nmax, a, P, dP, Q, C):
    """One point (a Python-callable wrapper of :func:`sh_field_ecef`)."""
    return sh_field_ecef(x, y, z, g, h, nmax, a, P, dP, Q, C)


@jit(_nrt=False)
def sh_coefficients_at(times, G, H, year, g, h):
    """Coefficients at ``year`` linearly interpolated between the epochs ``times`` (T,).

    ``G``, ``H`` are (T, N+1, N+1); before the first or after the last epoch the first or last
    interval's line is extended. Writes ``g``, ``h`` (N+1, N+1) in place.
    """
    T = times.shape[0]
    j = 0
    while j < T - 2 and year >= times[j + 1]:
        j += 1
    w = (year - times[j]) / (times[j + 1] - times[j])
    for n in range(G.shape[1]):
        for m in range(G.shape[2]):
            g[n, m] = G[j, n, m] + w * (G[j + 1, n, m] - G[j, n, m])
            h[n, m] = H[j, n, m] + w * (H[j + 1, n, m] - H[j, n, m])


@jit(inline="always")
def dipole_field_turned(x, y, z, g10, g11, h11, a, c, s):
    """The centred dipole's field (nT) at ``(x, y, z)`` of a frame turned by the angle whose cosine and
    sine are ``c``, ``s`` about z from the Earth-fixed one (the inertial frame and the GMST, in the
    loop): the degree-1 synthesis in Cartesian form, ``B = a^3 / r^5 (3 (m . r) r - r^2 m)`` with
    ``m = Rz m_E``, ``m_E = (g11, h11, g10)`` (``V = a^3 m_E . r_E / r^3``, ``B = -grad V``). One
    square root and one division; no spherical coordinates, no turning of ``r`` and ``B``. Equals
    :func:`sh_field_flat` at degree 1 to round-off (``docs/environment.md``, the field)."""
    mx = c * g11 - s * h11
    my = s * g11 + c * h11
    mz = g10
    r2 = x * x + y * y + z * z
    k = (a * a * a) / (r2 * r2 * math.sqrt(r2))
    d = 3.0 * (mx * x + my * y + mz * z)
    return k * (d * x - r2 * mx), k * (d * y - r2 * my), k * (d * z - r2 * mz)


@jit(_nrt=False)
def dipole_field_many(xyz, g10, g11, h11, a, c, s, out):
    """``out[i]`` = :func:`dipole_field_turned` at ``xyz[i]`` (K, 3) (the tests compare it with the
    spherical synthesis)."""
    for i in range(xyz.shape[0]):
        bx, by, bz = dipole_field_turned(xyz[i, 0], xyz[i, 1], xyz[i, 2], g10, g11, h11, a, c, s)
        out[i, 0] = bx
        out[i, 1] = by
        out[i, 2] = bz
