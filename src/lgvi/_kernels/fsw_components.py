"""Built-in components of the compiled loop: orbit and field (codes 190-199), guidance (500-599),
mode rules (600-699), control laws (700-799) and actuator maps (800-899).

Every kind keeps the contract of ``docs/components.md``: ``step(t, bus, p, s, w) -> int`` with
``w`` the bus offsets of the signals it reads, then of those it writes, in the order of its kind's
``reads + writes`` (``lgvi.fsw``, ``lgvi.spacecraft`` register them); an optional signal that no
component writes has offset ``-1``. Each family has one dispatcher ``<family>_dispatch(code, t,
bus, p, s, w)`` that the loop (:mod:`.loop_kernels`) calls. Attitudes on the bus are row-major
3x3 ``R`` (body or reference frame to inertial).
"""

from __future__ import annotations

import math

from .._jit import jit
from .gyrostat_kernels import mrp_error_at, mrp_request, reference_rates_at
from .field_kernels import dipole_field_turned, sh_field_flat
from .orbit_table_kernels import hermite_interval, hermite_position_in

OK = 0
NOT_FINITE = 1
OUT_OF_RANGE = 3

# ------------------------------------------------------------------------------------------------
# codes (lgvi.components registers the kinds with these)
# ------------------------------------------------------------------------------------------------
ORBIT = 190
FIELD = 191
GUIDE_INERTIAL = 500
GUIDE_HILL = 501
GUIDE_LVLH = 502
GUIDE_VELOCITY = 503
GUIDE_SUN = 504
GUIDE_TARGET = 505
MODE_RULES = 600
CTRL_MRP = 700
CTRL_BDOT = 701
CTRL_DUMP = 702
ACT_RW = 800
ACT_MTB = 801

# mode rule conditions
COND_TIME = 0            # t >= x
COND_RATE_BELOW = 1      # |omega| <= x
COND_RATE_ABOVE = 2      # |omega| >= x
COND_ERROR_BELOW = 3     # attitude error angle 4 atan |sigma_BR| <= x
COND_ERROR_ABOVE = 4
COND_ECLIPSE = 5         # shadow <= x
COND_SUNLIT = 6          # shadow >= x
COND_DWELL = 7           # time in the current mode >= x


@jit(inline="always")
def _finite3(a, b, c):
    return math.isfinite(a) and math.isfinite(b) and math.isfinite(c)


@jit(inline="always")
def put_frame(bus, o, x0, x1, x2, y0, y1, y2, z0, z1, z2):
    """``R_ref`` with columns ``x``, ``y``, ``z`` (reference axes in inertial components) at ``bus[o:o + 9]``."""
    bus[o] = x0
    bus[o + 1] = y0
    bus[o + 2] = z0
    bus[o + 3] = x1
    bus[o + 4] = y1
    bus[o + 5] = z1
    bus[o + 6] = x2
    bus[o + 7] = y2
    bus[o + 8] = z2


@jit(inline="always")
def put3(bus, o, a, b, c):
    bus[o] = a
    bus[o + 1] = b
    bus[o + 2] = c


@jit(inline="always")
def body_of(bus, oR, v0, v1, v2):
    """``R^T v`` with ``R`` row-major at ``bus[oR:oR + 9]``."""
    return (bus[oR] * v0 + bus[oR + 3] * v1 + bus[oR + 6] * v2,
            bus[oR + 1] * v0 + bus[oR + 4] * v1 + bus[oR + 7] * v2,
            bus[oR + 2] * v0 + bus[oR + 5] * v1 + bus[oR + 8] * v2)


# ------------------------------------------------------------------------------------------------
# orbit and field (190-199)
# ------------------------------------------------------------------------------------------------
@jit(inline="always")
def hermite_velocity(t, p):
    """Inertial velocity at ``t``: the derivative of :func:`.orbit_table_kernels.hermite_position`'s
    cubic (NaN outside the table)."""
    i, s, dt = hermite_interval(t, p)
    if i < 0:
        return math.nan, math.nan, math.nan
    return hermite_velocity_in(i, s, dt, p)


@jit(inline="always")
def hermite_velocity_in(i, s, dt, p):
    """:func:`hermite_velocity` in the interval ``(i, s, dt)`` of :func:`.orbit_table_kernels.hermite_interval`."""
    s2 = s * s
    d00 = (6.0 * s2 - 6.0 * s) / dt
    d10 = 3.0 * s2 - 4.0 * s + 1.0
    d11 = 3.0 * s2 - 2.0 * s
    # d01 = (-6 s^2 + 6 s) / dt is -d00 exactly (IEEE: b - a = -(a - b)): one division, the same values
    x = d00 * p[i] + d10 * p[i + 3] - d00 * p[i + 6] + d11 * p[i + 9]
    y = d00 * p[i + 1] + d10 * p[i + 4] - d00 * p[i + 7] + d11 * p[i + 10]
    z = d00 * p[i + 2] + d10 * p[i + 5] - d00 * p[i + 8] + d11 * p[i + 11]
    return x, y, z


@jit(inline="always")
def orbit_step(t, bus, p, s, w):
    """``r_N``, ``v_N`` from the tabulated orbit (``p``: the layout of
    :mod:`.orbit_table_kernels`, J unused); outside the table: status 3."""
    i, q, dt = hermite_interval(t, p)          # one interval for both
    if i < 0:
        return OUT_OF_RANGE
    x, y, z = hermite_position_in(i, q, dt, p)
    vx, vy, vz = hermite_velocity_in(i, q, dt, p)
    if not (_finite3(x, y, z) and _finite3(vx, vy, vz)):
        return OUT_OF_RANGE
    put3(bus, w[0], x, y, z)
    put3(bus, w[1], vx, vy, vz)
    return OK


#: ``p`` of the field: degree, radius (m), Julian days from J2000.0 to the epoch, (N+1), then
#: g, h at the epoch and their rates per second (each (N+1)^2, nT), then the recursions' factors
#: (:func:`.field_kernels.sh_recursion_constants`, 2 (N+1)^2 + N+1); ``s``: g, h, P, dP, Q scratch.
F_NMAX, F_RADIUS, F_JD0, F_N1, F_COEF = 0, 1, 2, 3, 4


@jit(inline="always")
def gmst_angle(jd0, t):
    """Greenwich mean sidereal time (rad, IAU 1982) ``t`` s after the epoch ``jd0`` days from J2000.0."""
    T = (jd0 + t / 86400.0) / 36525.0
    sec = 67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * T + 0.093104 * T * T - 6.2e-6 * T ** 3
    return (sec * (2.0 * math.pi / 86400.0)) % (2.0 * math.pi)


#: Seconds between the grid times at which the field kind of degree 1 evaluates the Earth angle's
#: cosine and sine (:func:`earth_angle_cs`).
EARTH_ANGLE_GRID = 60.0
_I6, _I20, _I42, _I2, _I12, _I30, _I56 = 1.0 / 6.0, 1.0 / 20.0, 1.0 / 42.0, 0.5, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0


@jit(inline="always")
def gmst_rate(jd0, tb):
    """``d theta / dt`` (rad/s) of :func:`gmst_angle`'s polynomial at ``tb`` s after the epoch."""
    Tb = (jd0 + tb / 86400.0) / 36525.0
    dsec = (876600.0 * 3600.0 + 8640184.812866) + 2.0 * 0.093104 * Tb - 3.0 * 6.2e-6 * Tb * Tb
    return dsec * (2.0 * math.pi / 86400.0) / (86400.0 * 36525.0)


@jit(inline="always")
def earth_angle_cs(jd0, t, s):
    """``cos``, ``sin`` of the GMST at ``t``: at the grid time ``tb = k EARTH_ANGLE_GRID`` at or before ``t``
    by :func:`gmst_angle` (kept in ``s = [k, cos, sin, k + 1/2, rate]``, recomputed when ``k`` changes),
    then turned on by ``d = (t - tb) rate`` (:func:`gmst_rate` at ``tb``; the polynomial's curvature
    adds 2e-21 rad over a minute) with ``sin d``, ``cos d`` from their series to ``d^7``, ``d^8``
    (``|d| <= 4.4e-3`` rad: the rest below 1e-20). No ``fmod``, ``cos`` or ``sin`` and one division
    a call between grid times; a pure function of ``t`` (the grid is fixed), so chunks and resumes
    give the same numbers. Equal to ``cos``, ``sin`` of :func:`gmst_angle` at the grid times; between
    them it differs by that function's own rounding of its large unreduced argument (up to about
    3e-11 rad; ``docs/environment.md``)."""
    k = math.floor(t / EARTH_ANGLE_GRID)
    tb = k * EARTH_ANGLE_GRID
    if not (s[0] == k and s[3] == k + 0.5):
        th = gmst_angle(jd0, tb)
        s[0] = k
        s[1] = math.cos(th)
        s[2] = math.sin(th)
        s[3] = k + 0.5
        s[4] = gmst_rate(jd0, tb)
    d = (t - tb) * s[4]
    d2 = d * d
    sd = d * (1.0 - d2 * _I6 * (1.0 - d2 * _I20 * (1.0 - d2 * _I42)))
    cd = 1.0 - d2 * _I2 * (1.0 - d2 * _I12 * (1.0 - d2 * _I30 * (1.0 - d2 * _I56)))
    return s[1] * cd - s[2] * sd, s[2] * cd + s[1] * sd


@jit(_nrt=False)
def earth_angle_many(jd0, t, s, out):
    """:func:`earth_angle_cs` at each of ``t`` (n,) in turn (state ``s`` (5,)): ``out`` (n, 2) cos, sin."""
    for i in range(t.shape[0]):
        out[i, 0], out[i, 1] = earth_angle_cs(jd0, t[i], s)


@jit(inline="always")
def field_step(t, bus, p, s, w):
    """``B_N`` (tesla) at ``r_N``: the spherical-harmonic kernel in the Earth-fixed frame turned by
    GMST, coefficients linear in time from the epoch; at degree 1 the dipole's Cartesian form
    (:func:`.field_kernels.dipole_field_turned`)."""
    nmax = int(p[F_NMAX])
    n1 = int(p[F_N1])
    q = n1 * n1
    o = F_COEF
    r = w[0]
    x = bus[r]
    y = bus[r + 1]
    z = bus[r + 2]
    if not (_finite3(x, y, z) and x * x + y * y + z * z > 0.0):
        return NOT_FINITE
    if nmax == 1:
        # the centred dipole in Cartesian form, its moment turned by GMST (field_kernels): the same
        # field to round-off, without the spherical coordinates and the two frame turns; the Earth
        # angle's cosine and sine from the grid kept in s[0:5] (the synthesis' scratch, unused here)
        c, sn = earth_angle_cs(p[F_JD0], t, s)
        g10 = p[o + n1] + t * p[o + 2 * q + n1]
        g11 = p[o + n1 + 1] + t * p[o + 2 * q + n1 + 1]
        h11 = p[o + q + n1 + 1] + t * p[o + 3 * q + n1 + 1]
        bx, by, bz = dipole_field_turned(x, y, z, g10, g11, h11, p[F_RADIUS], c, sn)
        put3(bus, w[1], bx * 1e-9, by * 1e-9, bz * 1e-9)
        return OK
    theta = gmst_angle(p[F_JD0], t)
    c = math.cos(theta)
    sn = math.sin(theta)
    for i in range(q):
        s[i] = p[o + i] + t * p[o + 2 * q + i]
        s[q + i] = p[o + q + i] + t * p[o + 3 * q + i]
    # g, h, P, dP, Q: (n1, n1) blocks of s, indexed flat
    bx, by, bz = sh_field_flat(c * x + sn * y, -sn * x + c * y, z, s, 0, s, q, n1, nmax, p[F_RADIUS], s, 2 * q,
                               s, 3 * q, s, 4 * q, p, o + 4 * q)
    put3(bus, w[1], (c * bx - sn * by) * 1e-9, (sn * bx + c * by) * 1e-9, bz * 1e-9)
    return OK


@jit(inline="always")
def orbit_field_dispatch(code, t, bus, p, s, w):
    """The orbit and field kinds (codes 190-199); inlined where it is called (the loop's
    ``dispatch``, a function of its own), as :func:`.environment_components.environment_dispatch`:
    one call a component instead of two."""
    if code == ORBIT:
        return orbit_step(t, bus, p, s, w)
    if code == FIELD:
        return field_step(t, bus, p, s, w)
    return OUT_OF_RANGE


# ------------------------------------------------------------------------------------------------
# guidance (500-599): R_ref, omega_ref_N, domega_ref_N
# ------------------------------------------------------------------------------------------------
@jit(inline="always")
def orbit_rates(bus, w):
    """``r``, ``v``, ``h = r x v``, ``|r|^2``, ``r . v`` from ``r_N`` (``w[0]``), ``v_N`` (``w[1]``)."""
    o = w[0]
    q = w[1]
    r0 = bus[o]
    r1 = bus[o + 1]
    r2 = bus[o + 2]
    v0 = bus[q]
    v1 = bus[q + 1]
    v2 = bus[q + 2]
    h0 = r1 * v2 - r2 * v1
    h1 = r2 * v0 - r0 * v2
    h2 = r0 * v1 - r1 * v0
    return r0, r1, r2, v0, v1, v2, h0, h1, h2, r0 * r0 + r1 * r1 + r2 * r2, r0 * v0 + r1 * v1 + r2 * v2


@jit(inline="always")
def orbital_frame(t, bus, p, s, w, lvlh):
    """Basilisk's Hill frame (``hillPoint``: x radial out, y along-track, z orbit normal) or lgvi's
    LVLH (x = y x z, y against the orbit normal, z nadir), each turning at ``omega = (r x v) / |r|^2``
    with ``domega = -2 (r . v) (r x v) / |r|^4`` (exact on a Kepler orbit)."""
    r0, r1, r2, v0, v1, v2, h0, h1, h2, rr, rv = orbit_rates(bus, w)
    rn = math.sqrt(rr)
    hn = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
    if not (rn > 0.0 and hn > 0.0 and math.isfinite(rn) and math.isfinite(hn)):
        return NOT_FINITE
    ir0 = r0 / rn
    ir1 = r1 / rn
    ir2 = r2 / rn
    ih0 = h0 / hn
    ih1 = h1 / hn
    ih2 = h2 / hn
    if lvlh:
        # z = -r/|r|, y = -h/|h|, x = y x z = h x r / (|h| |r|)
        x0 = ih1 * ir2 - ih2 * ir1
        x1 = ih2 * ir0 - ih0 * ir2
        x2 = ih0 * ir1 - ih1 * ir0
        put_frame(bus, w[2], x0, x1, x2, -ih0, -ih1, -ih2, -ir0, -ir1, -ir2)
    else:
        # x = r/|r|, z = h/|h|, y = z x x
        y0 = ih1 * ir2 - ih2 * ir1
        y1 = ih2 * ir0 - ih0 * ir2
        y2 = ih0 * ir1 - ih1 * ir0
        put_frame(bus, w[2], ir0, ir1, ir2, y0, y1, y2, ih0, ih1, ih2)
    put3(bus, w[3], h0 / rr, h1 / rr, h2 / rr)
    k = -2.0 * rv / (rr * rr)
    put3(bus, w[4], k * h0, k * h1, k * h2)
    return OK


@jit(inline="always")
def velocity_frame(t, bus, p, s, w):
    """Velocity pointing: x along the inertial velocity, z along the orbit normal, y = z x x,
    turning about the normal at ``mu |h| / (|r|^3 |v|^2)`` (``p[0] = mu``; its derivative along
    the Kepler orbit)."""
    r0, r1, r2, v0, v1, v2, h0, h1, h2, rr, rv = orbit_rates(bus, w)
    vv = v0 * v0 + v1 * v1 + v2 * v2
    vn = math.sqrt(vv)
    hn = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
    if not (vn > 0.0 and hn > 0.0 and math.isfinite(vn) and math.isfinite(hn)):
        return NOT_FINITE
    ix0 = v0 / vn
    ix1 = v1 / vn
    ix2 = v2 / vn
    iz0 = h0 / hn
    iz1 = h1 / hn
    iz2 = h2 / hn
    put_frame(bus, w[2], ix0, ix1, ix2, iz1 * ix2 - iz2 * ix1, iz2 * ix0 - iz0 * ix2, iz0 * ix1 - iz1 * ix0,
              iz0, iz1, iz2)
    mu = p[0]
    rn = math.sqrt(rr)
    r3 = rr * rn
    rate = mu * hn / (r3 * vv)
    # d/dt: r' = (r . v)/|r|, (v . v)' = -2 mu (r . v)/|r|^3
    drate = rate * (-3.0 * rv / rr + 2.0 * mu * rv / (r3 * vv))
    put3(bus, w[3], rate * iz0, rate * iz1, rate * iz2)
    put3(bus, w[4], drate * iz0, drate * iz1, drate * iz2)
    return OK


@jit(inline="always")
def aligned_frame(bus, o, a0, a1, a2, c0, c1, c2, b0, b1, b2, d0, d1, d2):
    """``R_ref`` taking the body axis ``b`` onto the inertial direction ``a`` and the body axis ``d``
    as close as it can go to the inertial direction ``c`` (TRIAD; ``b``, ``d`` unit and not parallel,
    ``a``, ``c`` not parallel). Returns ``False`` when a direction is degenerate."""
    an = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    # inertial triad: t1 = a, t2 = a x c, t3 = t1 x t2
    e0 = a1 * c2 - a2 * c1
    e1 = a2 * c0 - a0 * c2
    e2 = a0 * c1 - a1 * c0
    en = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    f0 = b1 * d2 - b2 * d1
    f1 = b2 * d0 - b0 * d2
    f2 = b0 * d1 - b1 * d0
    fn = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    if not (an > 0.0 and en > 1e-12 * an and fn > 1e-12 and math.isfinite(en)):
        return False
    a0 /= an
    a1 /= an
    a2 /= an
    e0 /= en
    e1 /= en
    e2 /= en
    f0 /= fn
    f1 /= fn
    f2 /= fn
    g0 = a1 * e2 - a2 * e1
    g1 = a2 * e0 - a0 * e2
    g2 = a0 * e1 - a1 * e0
    k0 = b1 * f2 - b2 * f1
    k1 = b2 * f0 - b0 * f2
    k2 = b0 * f1 - b1 * f0
    # R_ref = [a e g] [b f k]^T
    bus[o] = a0 * b0 + e0 * f0 + g0 * k0
    bus[o + 1] = a0 * b1 + e0 * f1 + g0 * k1
    bus[o + 2] = a0 * b2 + e0 * f2 + g0 * k2
    bus[o + 3] = a1 * b0 + e1 * f0 + g1 * k0
    bus[o + 4] = a1 * b1 + e1 * f1 + g1 * k1
    bus[o + 5] = a1 * b2 + e1 * f2 + g1 * k2
    bus[o + 6] = a2 * b0 + e2 * f0 + g2 * k0
    bus[o + 7] = a2 * b1 + e2 * f1 + g2 * k1
    bus[o + 8] = a2 * b2 + e2 * f2 + g2 * k2
    return True


@jit(inline="always")
def sun_frame(t, bus, p, s, w):
    """Sun pointing: the body axis ``p[0:3]`` onto ``sun_N`` (``w[0]``), the body axis ``p[3:6]`` as
    close as it can go to the orbit normal ``r_N x v_N`` (``w[1]``, ``w[2]``); rates zero (the sun
    direction turns at about 2e-7 rad/s)."""
    o = w[0]
    r0, r1, r2, v0, v1, v2, h0, h1, h2, rr, rv = orbit_rates(bus, w[1:])
    if not aligned_frame(bus, w[3], bus[o], bus[o + 1], bus[o + 2], h0, h1, h2, p[0], p[1], p[2], p[3], p[4], p[5]):
        return NOT_FINITE
    put3(bus, w[4], 0.0, 0.0, 0.0)
    put3(bus, w[5], 0.0, 0.0, 0.0)
    return OK


@jit(inline="always")
def target_frame(t, bus, p, s, w):
    """Target (ground station) pointing: the body axis ``p[0:3]`` towards the Earth-fixed point
    ``p[6:9]`` (m, turned into the inertial frame by GMST, epoch ``p[9]`` Julian days from J2000.0),
    the body axis ``p[3:6]`` as close as it can go to the orbit normal. The reference rate is the
    line of sight's turn ``omega = (l x l') / |l|^2`` (its rate about the line and the normal's turn
    neglected), its derivative ``(l x l'') / |l|^2 - 2 (l . l') omega / |l|^2`` with
    ``l'' = g'' - a``: the target's centripetal acceleration ``-omega_E^2 (g_x, g_y, 0)`` and the
    two-body acceleration ``a = -mu r / |r|^3`` (``mu`` ``p[10]``; exact on a Kepler orbit)."""
    r0, r1, r2, v0, v1, v2, h0, h1, h2, rr, rv = orbit_rates(bus, w)
    theta = gmst_angle(p[9], t)
    c = math.cos(theta)
    sn = math.sin(theta)
    x = p[6]
    y = p[7]
    z = p[8]
    g0 = c * x - sn * y                 # R3(theta)^T r_ecef
    g1 = sn * x + c * y
    g2 = z
    we = 7.292115146706979e-5           # the target's inertial velocity: omega_E e3 x g
    gv0 = -we * g1
    gv1 = we * g0
    l0 = g0 - r0
    l1 = g1 - r1
    l2 = g2 - r2
    dl0 = gv0 - v0
    dl1 = gv1 - v1
    dl2 = -v2
    ll = l0 * l0 + l1 * l1 + l2 * l2
    if not aligned_frame(bus, w[2], l0, l1, l2, h0, h1, h2, p[0], p[1], p[2], p[3], p[4], p[5]):
        return NOT_FINITE
    o0 = (l1 * dl2 - l2 * dl1) / ll
    o1 = (l2 * dl0 - l0 * dl2) / ll
    o2 = (l0 * dl1 - l1 * dl0) / ll
    put3(bus, w[3], o0, o1, o2)
    k = p[10] / (rr * math.sqrt(rr))    # l'' = g'' - a = -omega_E^2 (g0, g1, 0) + mu r / |r|^3
    a0 = -we * we * g0 + k * r0
    a1 = -we * we * g1 + k * r1
    a2 = k * r2
    c = 2.0 * (l0 * dl0 + l1 * dl1 + l2 * dl2) / ll
    put3(bus, w[4], (l1 * a2 - l2 * a1) / ll - c * o0, (l2 * a0 - l0 * a2) / ll - c * o1,
         (l0 * a1 - l1 * a0) / ll - c * o2)
    return OK


@jit(_nrt=False)
def guidance_dispatch(code, t, bus, p, s, w):
    """The guidance kinds (codes 500-599)."""
    if code == GUIDE_HILL:
        return orbital_frame(t, bus, p, s, w, False)
    if code == GUIDE_LVLH:
        return orbital_frame(t, bus, p, s, w, True)
    if code == GUIDE_INERTIAL:
        for i in range(9):
            bus[w[0] + i] = p[i]
        put3(bus, w[1], p[9], p[10], p[11])
        put3(bus, w[2], p[12], p[13], p[14])
        return OK
    if code == GUIDE_VELOCITY:
        return velocity_frame(t, bus, p, s, w)
    if code == GUIDE_SUN:
        return sun_frame(t, bus, p, s, w)
    if code == GUIDE_TARGET:
        return target_frame(t, bus, p, s, w)
    return OUT_OF_RANGE


# ------------------------------------------------------------------------------------------------
# mode rules (600-699): the mode as a float on the bus
# ------------------------------------------------------------------------------------------------
@jit(inline="always")
def mode_rules(t, bus, p, s, w):
    """Rules ``(from, to, condition, threshold)`` (``p[1:]``, ``p[0]`` of them; ``from < 0``: any mode),
    the first that holds moves ``mode`` (``w[3]``) to ``to``; reads ``omega`` (``w[0]``), ``sigma_BR``
    (``w[1]``) and ``shadow`` (``w[2]``, optional: a rule on it never holds without it). ``s``: the
    time the current mode began."""
    mo = w[3]
    mode = bus[mo]
    nr = int(p[0])
    for i in range(nr):
        q = 1 + 4 * i
        frm = p[q]
        if frm >= 0.0 and frm != mode:
            continue
        cond = int(p[q + 2])
        x = p[q + 3]
        ok = False
        if cond == COND_TIME:
            ok = t >= x
        elif cond == COND_DWELL:
            ok = t - s[0] >= x
        elif cond == COND_RATE_BELOW or cond == COND_RATE_ABOVE:
            o = w[0]
            wn = math.sqrt(bus[o] * bus[o] + bus[o + 1] * bus[o + 1] + bus[o + 2] * bus[o + 2])
            ok = wn <= x if cond == COND_RATE_BELOW else wn >= x
        elif cond == COND_ERROR_BELOW or cond == COND_ERROR_ABOVE:
            o = w[1]
            sn = math.sqrt(bus[o] * bus[o] + bus[o + 1] * bus[o + 1] + bus[o + 2] * bus[o + 2])
            ang = 4.0 * math.atan(sn)
            ok = ang <= x if cond == COND_ERROR_BELOW else ang >= x
        elif w[2] >= 0:
            sh = bus[w[2]]
            ok = sh <= x if cond == COND_ECLIPSE else sh >= x
        if ok:
            if p[q + 1] != mode:
                bus[mo] = p[q + 1]
                s[0] = t
            return OK
    return OK


@jit(_nrt=False)
def mode_dispatch(code, t, bus, p, s, w):
    """The mode kinds (codes 600-699)."""
    if code == MODE_RULES:
        return mode_rules(t, bus, p, s, w)
    return OUT_OF_RANGE


# ------------------------------------------------------------------------------------------------
# control (700-799)
# ------------------------------------------------------------------------------------------------
@jit(inline="always")
def add_wheels(p, o, bus, orho, H0, H1, H2):
    """``H + sum_i rho_i a_i``: ``p[o]`` wheels with axes ``p[o + 1:]`` (N x 3), momenta ``bus[orho:]``."""
    n = int(p[o])
    for i in range(n):
        a = o + 1 + 3 * i
        rho = bus[orho + i]
        H0 += p[a] * rho
        H1 += p[a + 1] * rho
        H2 += p[a + 2] * rho
    return H0, H1, H2


@jit(inline="always")
def mrp_control(t, bus, p, s, w):
    """Basilisk's ``mrpFeedback`` (:func:`.gyrostat_kernels.mrp_request`): reads the attitude
    (``w[0]``: ``R`` or ``R_est``), the rate (``w[1]``), the wheel momenta (``w[2]``, ``p[13]`` wheels,
    axes ``p[14:]``), ``R_ref``, ``omega_ref_N``, ``domega_ref_N``; writes ``sigma_BR``,
    ``omega_BR_B``, ``torque_request_B``. ``p``: K, P, Ki, integral limit, J (9), N, axes (3N);
    ``s``: int_sigma (3), prior time, has prior."""
    oR = w[0]
    ow = w[1]
    R = bus[oR:oR + 9].reshape((3, 3))
    s0, s1, s2 = mrp_error_at(bus, w[3], R)
    r0, r1, r2, e0, e1, e2 = reference_rates_at(bus, w[4], w[5], R)
    w0 = bus[ow]
    w1 = bus[ow + 1]
    w2 = bus[ow + 2]
    H0, H1, H2 = add_wheels(p, 13, bus, w[2], p[4] * w0 + p[5] * w1 + p[6] * w2, p[7] * w0 + p[8] * w1 + p[9] * w2,
                            p[10] * w0 + p[11] * w1 + p[12] * w2)
    L0, L1, L2 = mrp_request(p, 4, s, t, s0, s1, s2, r0, r1, r2, e0, e1, e2, w0, w1, w2, H0, H1, H2)
    put3(bus, w[6], s0, s1, s2)
    put3(bus, w[7], w0 - r0, w1 - r1, w2 - r2)
    put3(bus, w[8], L0, L1, L2)
    return OK


@jit(inline="always")
def bdot_control(t, bus, p, s, w):
    """B-dot: ``m = -k dB/dt`` in the body frame, ``p = [k, derivative]`` (0: the backward difference
    of the body-frame field between calls, nothing at the first; 1: ``dB/dt = -omega x B``). Reads
    ``B_N``, the attitude, the rate; writes ``dipole_request_B``. ``s``: last B (3), last t, has."""
    b0, b1, b2 = body_of(bus, w[1], bus[w[0]], bus[w[0] + 1], bus[w[0] + 2])
    k = p[0]
    o = w[3]
    if p[1] == 1.0:
        ow = w[2]
        w0 = bus[ow]
        w1 = bus[ow + 1]
        w2 = bus[ow + 2]
        put3(bus, o, k * (w1 * b2 - w2 * b1), k * (w2 * b0 - w0 * b2), k * (w0 * b1 - w1 * b0))
        return OK
    if s[4] > 0.0 and t != s[3]:
        dt = t - s[3]
        put3(bus, o, -k * (b0 - s[0]) / dt, -k * (b1 - s[1]) / dt, -k * (b2 - s[2]) / dt)
    else:
        put3(bus, o, 0.0, 0.0, 0.0)
    s[0] = b0
    s[1] = b1
    s[2] = b2
    s[3] = t
    s[4] = 1.0
    return OK


@jit(inline="always")
def dumping_control(t, bus, p, s, w):
    """Magnetic momentum dumping: ``m = k (h x B) / |B|^2`` with ``h`` the wheels' momentum in the
    body (``p = [k, N, axes (3N)]``); reads ``B_N``, the attitude, ``wheel_momentum``; writes
    ``dipole_request_B``."""
    b0, b1, b2 = body_of(bus, w[1], bus[w[0]], bus[w[0] + 1], bus[w[0] + 2])
    h0, h1, h2 = add_wheels(p, 1, bus, w[2], 0.0, 0.0, 0.0)
    bb = b0 * b0 + b1 * b1 + b2 * b2
    o = w[3]
    if bb == 0.0:
        put3(bus, o, 0.0, 0.0, 0.0)
        return OK
    k = p[0] / bb
    put3(bus, o, k * (h1 * b2 - h2 * b1), k * (h2 * b0 - h0 * b2), k * (h0 * b1 - h1 * b0))
    return OK


@jit(_nrt=False)
def control_dispatch(code, t, bus, p, s, w):
    """The control kinds (codes 700-799)."""
    if code == CTRL_MRP:
        return mrp_control(t, bus, p, s, w)
    if code == CTRL_BDOT:
        return bdot_control(t, bus, p, s, w)
    if code == CTRL_DUMP:
        return dumping_control(t, bus, p, s, w)
    return OUT_OF_RANGE


# ------------------------------------------------------------------------------------------------
# actuators (800-899)
# ------------------------------------------------------------------------------------------------
@jit(inline="always")
def rw_map(t, bus, p, s, w):
    """Basilisk's ``rwMotorTorque``: ``wheel_command = M torque_request_B`` with the (N, 3) map
    ``p[1:]`` (``p[0] = N``), the minimum-norm motor torques whose reaction on the body is the
    request along the control axes."""
    o = w[0]
    L0 = bus[o]
    L1 = bus[o + 1]
    L2 = bus[o + 2]
    n = int(p[0])
    c = w[1]
    for i in range(n):
        m = 1 + 3 * i
        bus[c + i] = p[m] * L0 + p[m + 1] * L1 + p[m + 2] * L2
    return OK


@jit(inline="always")
def magnetorquers(t, bus, p, s, w):
    """Magnetorquer rods (``p = [K, axes (3K), max dipole (K), pinv (K x 3)]``): the dipole request
    (``w[0]``) to the rods by least squares, each clipped, ``dipole_B = G d`` and
    ``tau_control_B = dipole_B x R^T B_N`` (the true attitude ``w[2]``, the field ``w[1]``)."""
    K = int(p[0])
    o = w[0]
    m0 = bus[o]
    m1 = bus[o + 1]
    m2 = bus[o + 2]
    d0 = 0.0
    d1 = 0.0
    d2 = 0.0
    ax = 1
    mx = 1 + 3 * K
    pv = 1 + 4 * K
    for i in range(K):
        q = pv + 3 * i
        d = p[q] * m0 + p[q + 1] * m1 + p[q + 2] * m2
        lim = p[mx + i]
        if d > lim:
            d = lim
        elif d < -lim:
            d = -lim
        a = ax + 3 * i
        d0 += p[a] * d
        d1 += p[a + 1] * d
        d2 += p[a + 2] * d
    b0, b1, b2 = body_of(bus, w[2], bus[w[1]], bus[w[1] + 1], bus[w[1] + 2])
    put3(bus, w[3], d0, d1, d2)
    put3(bus, w[4], d1 * b2 - d2 * b1, d2 * b0 - d0 * b2, d0 * b1 - d1 * b0)
    return OK


@jit(_nrt=False)
def actuator_dispatch(code, t, bus, p, s, w):
    """The actuator kinds (codes 800-899)."""
    if code == ACT_RW:
        return rw_map(t, bus, p, s, w)
    if code == ACT_MTB:
        return magnetorquers(t, bus, p, s, w)
    return OUT_OF_RANGE
