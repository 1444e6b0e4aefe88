"""The environment and disturbance components of the compiled loop (``docs/components.md``).

Every kind is a ``step(t, bus, p, s, w) -> int`` (0: ok; 1: a value that is not finite; 3: out of
the model's range); ``w`` holds the bus offsets of the kind's ``reads`` then ``writes``, in the
order the Python class registers them (``lgvi.environment.sun``, ``lgvi.environment.shadow``,
``lgvi.environment.atmosphere``, ``lgvi.spacecraft.disturbances``). The equations, frames and
parameter rows are derived in ``docs/environment.md``. Units SI; the inertial frame is the one of
the orbit (TEME for SGP4): the sun is given in TEME (true equator, mean equinox of date).

Codes: environment 100-189 (:func:`environment_dispatch`), disturbance 200-299
(:func:`disturbance_dispatch`). :func:`environment_many` and :func:`disturbance_many` run one kind
over many rows (the vectorised Python functions and the tests use them).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .finite import finite_status, written

SUN = 100
SHADOW = 101
EXPONENTIAL_ATMOSPHERE = 110
TABULATED_ATMOSPHERE = 111
FACET_DRAG = 200
FACET_SRP = 201
RESIDUAL_DIPOLE = 202

OK = 0
NOT_FINITE = 1
OUT_OF_RANGE = 3

_DEG = math.pi / 180.0
_ARCSEC = _DEG / 3600.0
AU = 149597870700.0                      # m (IAU 2012)

# Corrections of the sun's series (see sun_teme), fitted to astropy's ephemeris at 4000 dates of
# 1950-2050 by benchmarks/fit_sun_series.py: longitude (arcsec) = L[0] + L[1] T + sum L[2+i] sin(a_i),
# distance (relative) = Q[0] + sum Q[1+i] cos(a_i), a = (D, LV-LE, 2(LV-LE), 3(LV-LE), LE-LJ,
# 2(LE-LJ), 2(LE-LM)).
_LON = (-8.007, -5.033, 6.579, 4.713, -5.545, -0.755, -7.195, 2.698, -1.934)
_DIST = (-7.3858e-07, 3.0692e-05, -5.5647e-06, 1.5787e-05, 2.6971e-06, 1.6404e-05, -9.2269e-06,
         4.5790e-06)


@jit(inline="always")
def sun_teme(days, corrected):
    """The sun's geocentric position (m, TEME of date) at ``days`` TT days after J2000.0.

    Meeus' low-precision solar series (equation of the centre to third order, aberration, the
    main nutation term) in the ecliptic of date, turned to the true equator by the true obliquity
    and to the mean equinox by the equation of the equinoxes; then ``corrected`` (1.0 or 0.0)
    times a fitted series of the lunar and planetary perturbations (the constants above).
    """
    T = days / 36525.0
    L0 = 280.46646 + 36000.76983 * T + 0.0003032 * T * T
    M = (357.52911 + 35999.05029 * T - 0.0001537 * T * T) * _DEG
    sM = math.sin(M)
    cM = math.cos(M)
    s2M = 2.0 * sM * cM
    c2M = cM * cM - sM * sM
    s3M = s2M * cM + c2M * sM
    C = ((1.914602 - 0.004817 * T - 0.000014 * T * T) * sM + (0.019993 - 0.000101 * T) * s2M
         + 0.000289 * s3M)
    Om = (125.04 - 1934.136 * T) * _DEG
    dpsi = -0.00478 * math.sin(Om)                                   # deg
    eps = (23.439291 - 0.0130042 * T + 0.00256 * math.cos(Om)) * _DEG
    e = 0.016708634 - 0.000042037 * T
    nu = M + C * _DEG
    dist = 1.000001018 * (1.0 - e * e) / (1.0 + e * math.cos(nu))
    lon = (L0 + C - 0.00569 + dpsi) * _DEG
    if corrected != 0.0:
        D = (297.85036 + 445267.111480 * T) * _DEG
        VE = (181.979801 - 100.466457 + (58517.8156760 - 35999.3728565) * T) * _DEG
        EJ = (100.466457 - 34.351519 + (35999.3728565 - 3034.9056606) * T) * _DEG
        EM = (100.466457 - 355.433 + (35999.3728565 - 19140.2993) * T) * _DEG
        sD, cD = math.sin(D), math.cos(D)
        s1, c1 = math.sin(VE), math.cos(VE)
        s2, c2 = 2.0 * s1 * c1, c1 * c1 - s1 * s1
        s3, c3 = s2 * c1 + c2 * s1, c2 * c1 - s2 * s1
        sj, cj = math.sin(EJ), math.cos(EJ)
        sj2, cj2 = 2.0 * sj * cj, cj * cj - sj * sj
        sm = math.sin(2.0 * EM)
        cm = math.cos(2.0 * EM)
        lon += (_LON[0] + _LON[1] * T + _LON[2] * sD + _LON[3] * s1 + _LON[4] * s2 + _LON[5] * s3
                + _LON[6] * sj + _LON[7] * sj2 + _LON[8] * sm) * _ARCSEC
        dist *= 1.0 + (_DIST[0] + _DIST[1] * cD + _DIST[2] * c1 + _DIST[3] * c2 + _DIST[4] * c3
                       + _DIST[5] * cj + _DIST[6] * cj2 + _DIST[7] * cm)
    dist *= AU
    sl = math.sin(lon)
    x = dist * math.cos(lon)                       # true equator and equinox of date
    y = dist * math.cos(eps) * sl
    z = dist * math.sin(eps) * sl
    ee = dpsi * _DEG * math.cos(eps)               # equation of the equinoxes: to the mean equinox
    ce = math.cos(ee)
    se = math.sin(ee)
    return ce * x + se * y, ce * y - se * x, z


@jit
def sun_many(days, corrected):
    """``sun_teme`` at each of ``days`` (n,) -> (n, 3) metres."""
    out = np.empty((days.shape[0], 3))
    for i in range(days.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = sun_teme(days[i], corrected)
    return out


@jit(inline="always")
def sun_cached(t, p, s):
    """The sun at ``t`` (m, TEME): ``sun_teme`` itself when ``p[1] == 0``; else the straight line
    between its values at the grid times ``k p[1]`` around ``t`` (the chord of 1 AU over 60 s
    departs from the arc by 3 m, 2e-11 rad), the two nodes kept in ``s`` = [k, x_k, y_k, z_k,
    x_k+1, y_k+1, z_k+1], so one series evaluation serves ``p[1]`` seconds. A pure function of ``t``
    whatever the order of the calls."""
    step = p[1]
    if step == 0.0:
        return sun_teme(p[0] + t / 86400.0, 1.0)
    u = t / step
    k = math.floor(u)
    if s[0] != k:
        if s[0] == k - 1.0:
            s[1] = s[4]
            s[2] = s[5]
            s[3] = s[6]
        else:
            s[1], s[2], s[3] = sun_teme(p[0] + k * step / 86400.0, 1.0)
        s[4], s[5], s[6] = sun_teme(p[0] + (k + 1.0) * step / 86400.0, 1.0)
        s[0] = k
    q = u - k
    return s[1] + q * (s[4] - s[1]), s[2] + q * (s[5] - s[2]), s[3] + q * (s[6] - s[3])


@jit(inline="always")
def sun_step(t, bus, p, s, w):
    """Sun (code 100). p = [TT days of the epoch after J2000.0, interpolation step (s, 0: none)],
    s (7,) the interpolation nodes (``sun_cached``); reads r_N; writes sun_N, sun_distance."""
    x, y, z = sun_cached(t, p, s)
    r = w[0]
    dx = x - bus[r]
    dy = y - bus[r + 1]
    dz = z - bus[r + 2]
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    inv = 1.0 / d
    o = w[1]
    bus[o] = dx * inv
    bus[o + 1] = dy * inv
    bus[o + 2] = dz * inv
    bus[w[2]] = d
    return OK if (math.isfinite(d) and d > 0.0) else NOT_FINITE


@jit(inline="always")
def _asin(x):
    return math.asin(min(1.0, max(-1.0, x)))


@jit(inline="always")
def _acos(x):
    return math.acos(min(1.0, max(-1.0, x)))


@jit(inline="always")
def shadow_fraction(rx, ry, rz, ux, uy, uz, d, model, R_p, R_s):
    """Fraction of the solar disc visible from ``r`` (planet-centred, m), the sun at ``d`` (m)
    along the unit vector ``u`` from the spacecraft. ``model`` 0: none; 1: cylindrical; 2: conical
    (Montenbruck and Gill 3.4: overlapping discs of apparent radii ``a`` (sun), ``b`` (planet)
    at separation ``c``)."""
    if not math.isfinite(rx + ry + rz + ux + uy + uz + d):
        return math.nan                                 # (the clamps of asin and acos would hide it)
    if model == 0.0:
        return 1.0
    r2 = rx * rx + ry * ry + rz * rz
    ru = rx * ux + ry * uy + rz * uz
    if model == 1.0:
        hx = rx + d * ux                                # sun from the planet
        hy = ry + d * uy
        hz = rz + d * uz
        dh = math.sqrt(hx * hx + hy * hy + hz * hz)
        sr = (rx * hx + ry * hy + rz * hz) / dh         # r along the sun direction
        if sr >= 0.0:
            return 1.0
        perp2 = r2 - sr * sr
        return 0.0 if perp2 < R_p * R_p else 1.0
    if r2 + 2.0 * d * ru > 0.0:                         # nearer the sun than the planet's centre:
        return 1.0                                      # d < |r + d u|, squared
    rn = math.sqrt(r2)
    inv = 1.0 / rn
    sa = R_s / d                                        # sin a, sin b, cos c: the cases without trigonometry
    sb = R_p * inv
    ca = math.sqrt(max(1.0 - sa * sa, 0.0))
    cb = math.sqrt(max(1.0 - sb * sb, 0.0))
    cc = -ru * inv
    if cc <= ca * cb - sa * sb:                         # c >= a + b: sunlit
        return 1.0
    if sb > sa and cc > ca * cb + sa * sb:              # c < b - a: umbra
        return 0.0
    a = _asin(sa)
    b = _asin(sb)
    c = _acos(cc)
    if c >= a + b:
        return 1.0
    if c < b - a:
        return 0.0
    if c < a - b:                                       # annular: the planet inside the disc
        return 1.0 - (b * b) / (a * a)
    # partial: the lens of the two discs, a^2 (al - sin al cos al) + b^2 (be - sin be cos be), with
    # x the distance from the sun's centre to the chord and y its half length; y^2 factored and the
    # half-angles by atan2, so that no acos near 1 loses digits (the textbook acos form loses ~1e-9)
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = math.sqrt(max((a + b - c) * (b - a + c) * (c + a - b) * (c + a + b), 0.0)) / (2.0 * c)
    area = a * a * math.atan2(y, x) + b * b * math.atan2(y, c - x) - c * y
    return 1.0 - area / (math.pi * a * a)


@jit(inline="always")
def shadow_step(t, bus, p, s, w):
    """Shadow (code 101). p = [model, planet radius, sun radius]; reads r_N, sun_N, sun_distance;
    writes shadow."""
    r = w[0]
    u = w[1]
    f = shadow_fraction(bus[r], bus[r + 1], bus[r + 2], bus[u], bus[u + 1], bus[u + 2], bus[w[2]],
                        p[0], p[1], p[2])
    bus[w[3]] = f
    return OK if math.isfinite(f) else NOT_FINITE


@jit(inline="always")
def _relative_velocity(bus, w, omega):
    """``v - omega e_z x r`` written at ``w[3]`` (the atmosphere turns with the Earth about z)."""
    r = w[0]
    v = w[1]
    o = w[3]
    bus[o] = bus[v] + omega * bus[r + 1]
    bus[o + 1] = bus[v + 1] - omega * bus[r]
    bus[o + 2] = bus[v + 2]


@jit(inline="always")
def exponential_atmosphere_step(t, bus, p, s, w):
    """Exponential atmosphere (code 110). p = [rho0, scale height, planet radius, omega, min
    altitude, max altitude]; reads r_N, v_N; writes density, v_rel_N. Below the minimum altitude
    the run stops (status 3); above the maximum the density is zero (Basilisk's envMaxReach)."""
    r = w[0]
    alt = math.sqrt(bus[r] ** 2 + bus[r + 1] ** 2 + bus[r + 2] ** 2) - p[2]
    _relative_velocity(bus, w, p[3])
    if not alt >= p[4]:
        bus[w[2]] = math.nan
        return OUT_OF_RANGE
    bus[w[2]] = p[0] * math.exp(-alt / p[1]) if alt <= p[5] else 0.0
    return OK


@jit(inline="always")
def table_log_density(t, p):
    """Cubic Hermite interpolation of ``log rho`` in the table ``p[1:]`` = [t0, dt, K, values
    (K), slopes (K)] (the slopes of a cubic spline: the interpolant is that spline); NaN outside."""
    t0 = p[1]
    dt = p[2]
    K = int(p[3])
    u = (t - t0) / dt
    if not (u >= 0.0 and u <= K - 1.0):
        return math.nan
    k = int(math.floor(u))
    if k >= K - 1:
        k = K - 2
    q = u - k
    q2 = q * q
    q3 = q2 * q
    y0 = p[4 + k]
    y1 = p[5 + k]
    m0 = p[4 + K + k] * dt
    m1 = p[5 + K + k] * dt
    return ((2.0 * q3 - 3.0 * q2 + 1.0) * y0 + (q3 - 2.0 * q2 + q) * m0 + (-2.0 * q3 + 3.0 * q2) * y1
            + (q3 - q2) * m1)


@jit(inline="always")
def tabulated_atmosphere_step(t, bus, p, s, w):
    """Density tabulated along the orbit (code 111; NRLMSIS through pymsis). p = [omega, t0, dt,
    K, log rho (K), d log rho / dt (K)]; reads r_N, v_N; writes density, v_rel_N. Outside the
    table the run stops (status 3)."""
    _relative_velocity(bus, w, p[0])
    lr = table_log_density(t, p)
    if not math.isfinite(lr):
        bus[w[2]] = math.nan
        return OUT_OF_RANGE
    bus[w[2]] = math.exp(lr)
    return OK


@jit(inline="always")
def environment_dispatch(code, t, bus, p, s, w):
    """Run the environment kind ``code`` (100-189); -1 for a code that is not one.

    Inlined where it is called (``inline="always"``): a call that is not inlined costs about 70 ns
    (the reference counts of the four arrays), more than most kinds themselves
    (``benchmarks/bench_environment.py``)."""
    if code == SUN:
        return sun_step(t, bus, p, s, w)
    if code == SHADOW:
        return shadow_step(t, bus, p, s, w)
    if code == EXPONENTIAL_ATMOSPHERE:
        return exponential_atmosphere_step(t, bus, p, s, w)
    if code == TABULATED_ATMOSPHERE:
        return tabulated_atmosphere_step(t, bus, p, s, w)
    return -1


@jit(inline="always")
def _add_torque(bus, o, d, tx, ty, tz):
    """Write the torque at ``o`` (the kind's own signal) and add it into ``d`` (tau_dist_B); the
    status: 1 when the torque or the sum is not finite (the loop runs no other test of a
    disturbance's writes, :func:`lgvi._kernels.loop_kernels.run_one`)."""
    bus[o] = tx
    bus[o + 1] = ty
    bus[o + 2] = tz
    s0 = bus[d] + tx
    s1 = bus[d + 1] + ty
    s2 = bus[d + 2] + tz
    bus[d] = s0
    bus[d + 1] = s1
    bus[d + 2] = s2
    return finite_status(written(tx, ty, tz) + written(s0, s1, s2))


@jit(inline="always")
def _facet_finish(bus, Ro, ot, od, of, fx, fy, fz, tx, ty, tz):
    """``F_N = R F_B`` written at ``of``; the torque written at ``ot`` and added into ``tau_dist_B``
    at ``od``; the status (1 when the force, the torque or the sum is not finite)."""
    g0 = bus[Ro] * fx + bus[Ro + 1] * fy + bus[Ro + 2] * fz
    g1 = bus[Ro + 3] * fx + bus[Ro + 4] * fy + bus[Ro + 5] * fz
    g2 = bus[Ro + 6] * fx + bus[Ro + 7] * fy + bus[Ro + 8] * fz
    bus[of] = g0
    bus[of + 1] = g1
    bus[of + 2] = g2
    st = _add_torque(bus, ot, od, tx, ty, tz)
    return st if written(g0, g1, g2) == 0.0 else NOT_FINITE


@jit(inline="always")
def _to_body(bus, Ro, v):
    """``R^T x`` for the 3-vector at ``v``."""
    x = bus[Ro] * bus[v] + bus[Ro + 3] * bus[v + 1] + bus[Ro + 6] * bus[v + 2]
    y = bus[Ro + 1] * bus[v] + bus[Ro + 4] * bus[v + 1] + bus[Ro + 7] * bus[v + 2]
    z = bus[Ro + 2] * bus[v] + bus[Ro + 5] * bus[v + 1] + bus[Ro + 8] * bus[v + 2]
    return x, y, z


#: Per-facet values in the parameter rows: facet drag ``[Cd A, n (3), c (3)]``, facet SRP
#: ``[A (1 - specular), 2 A diffuse / 3, 2 A specular, n (3), c (3), c x n (3)]`` (computed once by the
#: Python classes, ``lgvi.spacecraft.disturbances``).
DRAG_FACET = 7
SRP_FACET = 12


@jit(inline="always")
def facet_drag_step(t, bus, p, s, w):
    """Facet drag (code 200; Basilisk's facetDragDynamicEffector). p = [N, then per facet: Cd A,
    normal (3, body), centre of pressure (3, body, from the centre of mass)]; reads R, density,
    v_rel_N; writes tau_facet_drag_B, tau_dist_B (adds), F_facet_drag_N.

    Each facet's force ``-1/2 rho |v|^2 Cd A (n . u) u`` (``u = v / |v|``) is
    ``-1/2 rho Cd A (n . v) v``: every force lies along ``v``, so the sums are
    ``F = -rho/2 S v`` and ``tau = -rho/2 C x v`` with ``S = sum a_i``, ``C = sum a_i c_i``,
    ``a_i = Cd_i A_i max(n_i . v, 0)``: no square root, no division, one cross product."""
    Ro = w[0]
    rho = bus[w[1]]
    vx, vy, vz = _to_body(bus, Ro, w[2])
    S = cx = cy = cz = 0.0
    if vx * vx + vy * vy + vz * vz > 1e-24:
        for i in range(int(p[0])):
            j = 1 + DRAG_FACET * i
            a = p[j] * (p[j + 1] * vx + p[j + 2] * vy + p[j + 3] * vz)
            if a > 0.0:
                S += a
                cx += a * p[j + 4]
                cy += a * p[j + 5]
                cz += a * p[j + 6]
    k = -0.5 * rho
    f = k * S
    return _facet_finish(bus, Ro, w[3], w[4], w[5], f * vx, f * vy, f * vz, k * (cy * vz - cz * vy),
                         k * (cz * vx - cx * vz), k * (cx * vy - cy * vx))


@jit(inline="always")
def facet_srp_step(t, bus, p, s, w):
    """Facet radiation pressure (code 201; Basilisk's facetSRPDynamicEffector). p = [N, solar flux
    at 1 AU / c AU^2 (N m^2), then per facet: A (1 - specular), 2 A diffuse / 3, 2 A specular,
    normal (3), centre of pressure (3), centre x normal (3)]; reads R, sun_N (a unit vector),
    sun_distance, shadow; writes tau_facet_srp_B, tau_dist_B (adds), F_facet_srp_N.

    ``F = -P A cos(th) [(1 - specular) s + 2 (diffuse / 3 + specular cos(th)) n]`` on each lit
    facet (``cos(th) = n . s > 0``), ``P = flux / c (AU / d)^2`` times the visible fraction; summed
    as ``F = -P (S s + N)``, ``tau = -P (C x s + M)`` with ``a_i = A_i (1 - spec_i) cos(th_i)``,
    ``b_i = cos(th_i) (2 A_i diff_i / 3 + 2 A_i spec_i cos(th_i))``, ``S = sum a_i``,
    ``C = sum a_i c_i``, ``N = sum b_i n_i``, ``M = sum b_i c_i x n_i``. In the shadow
    (``P = 0``) the facets are not visited."""
    Ro = w[0]
    sx, sy, sz = _to_body(bus, Ro, w[1])
    d = bus[w[2]]
    P = p[1] * bus[w[3]] / (d * d)
    S = cx = cy = cz = nx = ny = nz = mx = my = mz = 0.0
    if P != 0.0:
        for i in range(int(p[0])):
            j = 2 + SRP_FACET * i
            cth = p[j + 3] * sx + p[j + 4] * sy + p[j + 5] * sz
            if cth > 0.0:
                a = p[j] * cth
                b = cth * (p[j + 1] + p[j + 2] * cth)
                S += a
                cx += a * p[j + 6]
                cy += a * p[j + 7]
                cz += a * p[j + 8]
                nx += b * p[j + 3]
                ny += b * p[j + 4]
                nz += b * p[j + 5]
                mx += b * p[j + 9]
                my += b * p[j + 10]
                mz += b * p[j + 11]
    k = -P
    return _facet_finish(bus, Ro, w[4], w[5], w[6], k * (S * sx + nx), k * (S * sy + ny), k * (S * sz + nz),
                         k * (cy * sz - cz * sy + mx), k * (cz * sx - cx * sz + my), k * (cx * sy - cy * sx + mz))


@jit(inline="always")
def residual_dipole_step(t, bus, p, s, w):
    """Residual dipole (code 202). p = [m (3, A m^2, body)]; reads R, B_N; writes
    tau_residual_dipole_B, tau_dist_B (adds): ``m x R^T B_N``."""
    bx, by, bz = _to_body(bus, w[0], w[1])
    return _add_torque(bus, w[2], w[3], p[1] * bz - p[2] * by, p[2] * bx - p[0] * bz, p[0] * by - p[1] * bx)


@jit(inline="always")
def disturbance_dispatch(code, t, bus, p, s, w):
    """Run the disturbance kind ``code`` (200-299); -1 for a code that is not one (inlined, as
    :func:`environment_dispatch`)."""
    if code == FACET_DRAG:
        return facet_drag_step(t, bus, p, s, w)
    if code == FACET_SRP:
        return facet_srp_step(t, bus, p, s, w)
    if code == RESIDUAL_DIPOLE:
        return residual_dipole_step(t, bus, p, s, w)
    return -1


@jit
def environment_many(code, t, buses, p, s, w):
    """``environment_dispatch`` on each row of ``buses`` (n, nbus) at ``t`` (n,); statuses (n,)."""
    out = np.empty(t.shape[0], dtype=np.int64)
    for i in range(t.shape[0]):
        out[i] = environment_dispatch(code, t[i], buses[i], p, s, w)
    return out


@jit
def disturbance_many(code, t, buses, p, s, w):
    """``disturbance_dispatch`` on each row of ``buses`` (n, nbus) at ``t`` (n,); statuses (n,)."""
    out = np.empty(t.shape[0], dtype=np.int64)
    for i in range(t.shape[0]):
        out[i] = disturbance_dispatch(code, t[i], buses[i], p, s, w)
    return out
