"""Splitting kernels: the exact flow of the free rigid body and the kick-drift loop of
:mod:`lgvi.splitting` (``scheme="splitting"``).

The free body ``(R, Pi)`` with principal moments ``I`` (3,) (body frame = principal frame) is
advanced over a time ``tau`` exactly, to round-off (:func:`free_flow`):

* the body momentum by Jacobi elliptic functions ``Pi = S^T (A1 cn u, B2 sn u, B3 dn u)``,
  ``u = u0 + lam tau``: ``u0 = F(phi0 | m)`` (Carlson's ``R_F``), ``am(u | m)`` by the
  arithmetic-geometric mean (descending Landen transformation);
* the attitude ``R(tau) = R V(Pi0)^T Rz(psi) V(Pi(tau))``, ``V`` the Euler frame whose third
  axis is ``Pi/|Pi|`` and ``psi`` the precession angle about the (fixed) spatial momentum,
  ``psi = |L| tau / I_e + |L| (2E - |L|^2/I_e) / (c0 lam) [Pi(n; am u) - Pi(n; am u0)]``, an
  elliptic integral of the third kind (Carlson's ``R_F`` and ``R_J``);
* bodies with two (or three) equal moments in closed form with rotations.

The formulas and their derivation are in ``docs/splitting.md``. Everything here is scalar
arithmetic on the arrays passed in: no allocation (``ws`` is a scratch buffer of 64 floats).
"""

from __future__ import annotations

import math

from .._jit import jit, jit_copy
from .codes import OK, OVERFLOW, USER_RAISED
from .torque_kernels import model_moments_s

# convergence of Carlson's duplication: relative spread of the arguments below which the
# 7th-order Taylor series of R_F and R_J (DLMF 19.36.1-2) is exact to round-off (next term ~ spread^8)
_SPREAD = 0.01


@jit(inline="always")
def rc1(e):
    """Carlson's ``R_C(1, 1 + e)`` for ``e > -1``."""
    if abs(e) < 1e-3:
        return 1.0 - e * (1.0 / 3.0 - e * (0.2 - e * (1.0 / 7.0 - e * (1.0 / 9.0 - e * (1.0 / 11.0)))))
    if e > 0.0:
        s = math.sqrt(e)
        return math.atan(s) / s
    s = math.sqrt(-e)
    return math.atanh(s) / s


@jit(inline="always")
def rf_series(e2, e3):
    """Taylor series of ``R_F`` in the elementary symmetric functions of the deviations (DLMF 19.36.1)."""
    return (1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0 - 5.0 * e2 * e2 * e2 / 208.0
            + 3.0 * e3 * e3 / 104.0 + e2 * e2 * e3 / 16.0)


@jit(inline="always")
def rj_series(e2, e3, e4, e5):
    """Taylor series of ``R_J`` (DLMF 19.36.2)."""
    return (1.0 - 3.0 * e2 / 14.0 + e3 / 6.0 + 9.0 * e2 * e2 / 88.0 - 3.0 * e4 / 22.0 - 9.0 * e2 * e3 / 52.0
            + 3.0 * e5 / 26.0 - e2 * e2 * e2 / 16.0 + 3.0 * e3 * e3 / 40.0 + 3.0 * e2 * e4 / 20.0
            + 45.0 * e2 * e2 * e3 / 272.0 - 9.0 * (e3 * e4 + e2 * e5) / 68.0)


@jit
def carlson_rf(x, y, z):
    """Carlson's symmetric elliptic integral ``R_F(x, y, z)`` (``x, y, z >= 0``, at most one zero)."""
    mu = (x + y + z) / 3.0
    dx = (mu - x) / mu
    dy = (mu - y) / mu
    for _ in range(64):
        mu = (x + y + z) / 3.0
        dx = (mu - x) / mu
        dy = (mu - y) / mu
        dz = (mu - z) / mu
        if max(abs(dx), abs(dy), abs(dz)) < _SPREAD:
            break
        sx = math.sqrt(x)
        sy = math.sqrt(y)
        sz = math.sqrt(z)
        lam = sx * (sy + sz) + sy * sz
        x = 0.25 * (x + lam)
        y = 0.25 * (y + lam)
        z = 0.25 * (z + lam)
    dz = -(dx + dy)
    e2 = dx * dy - dz * dz
    e3 = dx * dy * dz
    return rf_series(e2, e3) / math.sqrt(mu)


@jit
def carlson_rj(x, y, z, p):
    """Carlson's symmetric elliptic integral ``R_J(x, y, z, p)`` (``x, y, z >= 0``, ``p > 0``)."""
    a = (x + y + z + 2.0 * p) / 5.0
    delta = (p - x) * (p - y) * (p - z)
    total = 0.0
    fac = 1.0
    dx = dy = dz = 0.0
    for _ in range(64):
        dx = (a - x) / a
        dy = (a - y) / a
        dz = (a - z) / a
        dp = (a - p) / a
        if max(abs(dx), abs(dy), abs(dz), abs(dp)) < _SPREAD:
            break
        sx = math.sqrt(x)
        sy = math.sqrt(y)
        sz = math.sqrt(z)
        sp = math.sqrt(p)
        lam = sx * (sy + sz) + sy * sz
        d = (sp + sx) * (sp + sy) * (sp + sz)
        total += fac * rc1(delta * fac * fac * fac / (d * d)) / d
        a = 0.25 * (a + lam)
        x = 0.25 * (x + lam)
        y = 0.25 * (y + lam)
        z = 0.25 * (z + lam)
        p = 0.25 * (p + lam)
        fac *= 0.25
    pp = -0.5 * (dx + dy + dz)
    xyz = dx * dy * dz
    e2 = dx * dy + dx * dz + dy * dz - 3.0 * pp * pp
    e3 = xyz + 2.0 * e2 * pp + 4.0 * pp * pp * pp
    e4 = (2.0 * xyz + e2 * pp + 3.0 * pp * pp * pp) * pp
    e5 = xyz * pp * pp
    series = rj_series(e2, e3, e4, e5)
    return fac * series / (a * math.sqrt(a)) + 6.0 * total


@jit(inline="always")
def carlson_rf_rj(x, y, z, p):
    """``(R_F(x, y, z), R_J(x, y, z, p))`` with one duplication sequence (the same ``x, y, z``)."""
    a = (x + y + z + 2.0 * p) / 5.0
    delta = (p - x) * (p - y) * (p - z)
    total = 0.0
    fac = 1.0
    dx = dy = dz = 0.0
    mu = 1.0
    for _ in range(64):
        mu = (x + y + z) / 3.0
        dx = (a - x) / a
        dy = (a - y) / a
        dz = (a - z) / a
        dp = (a - p) / a
        if max(abs(dx), abs(dy), abs(dz), abs(dp)) < _SPREAD and \
                max(abs(mu - x), abs(mu - y), abs(mu - z)) < _SPREAD * mu:
            break
        sx = math.sqrt(x)
        sy = math.sqrt(y)
        sz = math.sqrt(z)
        sp = math.sqrt(p)
        lam = sx * (sy + sz) + sy * sz
        d = (sp + sx) * (sp + sy) * (sp + sz)
        total += fac * rc1(delta * fac * fac * fac / (d * d)) / d
        a = 0.25 * (a + lam)
        x = 0.25 * (x + lam)
        y = 0.25 * (y + lam)
        z = 0.25 * (z + lam)
        p = 0.25 * (p + lam)
        fac *= 0.25
    fx = (mu - x) / mu
    fy = (mu - y) / mu
    fz = -(fx + fy)
    f2 = fx * fy - fz * fz
    f3 = fx * fy * fz
    rf = rf_series(f2, f3) / math.sqrt(mu)
    pp = -0.5 * (dx + dy + dz)
    xyz = dx * dy * dz
    e2 = dx * dy + dx * dz + dy * dz - 3.0 * pp * pp
    e3 = xyz + 2.0 * e2 * pp + 4.0 * pp * pp * pp
    e4 = (2.0 * xyz + e2 * pp + 3.0 * pp * pp * pp) * pp
    e5 = xyz * pp * pp
    series = rj_series(e2, e3, e4, e5)
    return rf, fac * series / (a * math.sqrt(a)) + 6.0 * total


#: :func:`carlson_rf_rj` compiled from its source as a function of its own (:func:`.._jit.jit_copy`),
#: called by :func:`free_flow`: the largest helper of the flow, built once and not copied (bit for bit).
rf_rj_call = jit_copy(carlson_rf_rj, "carlson_rf_rj_call", "carlson_rf_rj compiled as a function of its own (see "
                      "splitting_kernels.rf_rj_call).")


@jit(inline="always")
def jacobi_am(u, m, m1, ws):
    """Jacobi amplitude ``am(u | m)`` (continuous, increasing in ``u``) by the AGM; ``ws`` (>= 32,) scratch."""
    if m1 <= 0.0:                        # m = 1: the separatrix, am = gd(u)
        return math.atan(math.sinh(u))
    a = 1.0
    b = math.sqrt(m1)
    c = math.sqrt(m)
    n = 0
    while c > 2.2e-16 * a and n < 30:
        a1 = 0.5 * (a + b)
        c = 0.5 * (a - b)
        b = math.sqrt(a * b)
        a = a1
        n += 1
        ws[n] = c / a
    phi = a * u * (2.0 ** n)
    for i in range(n, 0, -1):
        phi = 0.5 * (phi + math.asin(ws[i] * math.sin(phi)))
    return phi


@jit(inline="always")
def jacobi_sncn(u, m, m1, ws):
    """``(sn(u | m), cn(u | m), j)`` for ``0 <= m < 1`` by the descending Landen transformation, and the
    integer ``j`` with ``am(u | m) = r + j pi``, ``r`` in ``[-pi/2, pi/2]``; ``ws`` (>= 31,) scratch.

    With ``k = sqrt(m)``, ``k1 = (1 - k')/(1 + k') = k^2/(1 + k')^2`` and ``z1 = u/(1 + k1)`` (DLMF 22.7.1-3),
    ``sn(u, k) = (1 + k1) s / (1 + k1 s^2)``, ``cn(u, k) = c d / (1 + k1 s^2)``,
    ``dn(u, k) = (c^2 + (1 - k1) s^2) / (1 + k1 s^2)`` with ``(s, c, d)`` the functions of ``(z1, k1)``;
    repeated until ``k_N <= 1e-8``, where ``sn = sin z_N`` to ``k_N^2 z_N / 4``. One sine and cosine and a
    division a level, where the amplitude by the AGM (:func:`jacobi_am`) takes an arcsine and a sine a level.
    The signs of ``sn`` and ``cn`` are those of ``sin z_N``, ``cos z_N`` (``d > 0``) and ``z_N = pi u / (2 K)``,
    so ``j = round(z_N / pi)``.
    """
    k = math.sqrt(m)
    kp = math.sqrt(m1)
    z = u
    n = 0
    while k > 1e-8 and n < 14:
        d = 1.0 + kp
        k = k * k / (d * d)
        n += 1
        ws[n] = k
        ws[16 + n] = 2.0 * kp / d                       # 1 - k_n, without cancellation
        kp = 2.0 * math.sqrt(kp) / d
        z = z / (1.0 + k)
    j = round(z / math.pi)
    s = math.sin(z)
    c = math.cos(z)
    dd = 1.0 - 0.5 * k * k * s * s
    for i in range(n, 0, -1):
        kk = ws[i]
        s2 = s * s
        inv = 1.0 / (1.0 + kk * s2)
        dn = (c * c + ws[16 + i] * s2) * inv
        c = c * dd * inv
        s = (1.0 + kk) * s * inv
        dd = dn
    # s^2 + c^2 = 1 to round-off, but the recursion's round-off is biased: it would make |Pi| and the
    # energy drift linearly over many flows (the phase quadratically). One Newton step for
    # 1/sqrt(s^2 + c^2), applied as a correction (multiplying by 1.5 - (s^2 + c^2)/2 would round it to
    # the spacing of the floats near 1 and bias it again); docs/splitting.md has the drift measured
    d = 0.5 * ((s * s - 1.0) + c * c)
    return s - d * s, c - d * c, j


@jit(inline="always")
def euler_frame(p0, p1, p2, e, ws, o):
    """The rotation ``V`` (into ``ws[o:o+9]``, row-major) with ``V Pi = |Pi| e3``, from the angles of
    the Euler sequence about body axis ``e``."""
    a = (e + 1) % 3
    b = (e + 2) % 3
    q = (p0, p1, p2)
    x1 = q[a]
    x2 = q[b]
    x3 = q[e]
    rho2 = x1 * x1 + x2 * x2
    rho = math.sqrt(rho2)
    inrm = 1.0 / math.sqrt(rho2 + x3 * x3)
    irho = 1.0 / rho
    sth = rho * inrm
    cth = x3 * inrm
    sph = x1 * irho
    cph = x2 * irho
    # Q rows in the coordinates (a, b, e); V[:, a] = Q[:, 0], V[:, b] = Q[:, 1], V[:, e] = Q[:, 2]
    ws[o + a] = cph
    ws[o + b] = -sph
    ws[o + e] = 0.0
    ws[o + 3 + a] = cth * sph
    ws[o + 3 + b] = cth * cph
    ws[o + 3 + e] = -sth
    ws[o + 6 + a] = sth * sph
    ws[o + 6 + b] = sth * cph
    ws[o + 6 + e] = cth


@jit(inline="always")
def rotate_right(R, F, o):
    """``R <- R F`` with ``F`` row-major in ``F[o:o+9]``."""
    for i in range(3):
        r0 = R[i, 0]
        r1 = R[i, 1]
        r2 = R[i, 2]
        R[i, 0] = r0 * F[o] + r1 * F[o + 3] + r2 * F[o + 6]
        R[i, 1] = r0 * F[o + 1] + r1 * F[o + 4] + r2 * F[o + 7]
        R[i, 2] = r0 * F[o + 2] + r1 * F[o + 5] + r2 * F[o + 8]


@jit(inline="always")
def axis_rotation(x, y, z, angle, F, o):
    """Rotation by ``angle`` about the unit vector ``(x, y, z)`` into ``F[o:o+9]`` (row-major)."""
    s = math.sin(angle)
    c = math.cos(angle)
    v = 1.0 - c
    F[o] = c + v * x * x
    F[o + 1] = v * x * y - s * z
    F[o + 2] = v * x * z + s * y
    F[o + 3] = v * x * y + s * z
    F[o + 4] = c + v * y * y
    F[o + 5] = v * y * z - s * x
    F[o + 6] = v * x * z - s * y
    F[o + 7] = v * y * z + s * x
    F[o + 8] = c + v * z * z


@jit
def rotate_by(R, x, y, z, angle, ws):
    """``R <- R Rot((x, y, z), angle)``, the rotation left in ``ws[50:59]`` (row-major): a called
    function, not inlined, so that the rare paths of :func:`free_flow` share one compiled copy."""
    axis_rotation(x, y, z, angle, ws, 50)
    rotate_right(R, ws, 50)


#: below this ``m1 = 1 - m`` :func:`free_flow` takes ``sn``, ``cn`` from the AGM amplitude (:func:`jacobi_am`),
#: not the Landen transformation (docs/splitting.md, round-off over many flows)
AGM_M1 = 0.05


@jit(inline="always")
def orbit_constants(I1, I2, I3):
    """``(I1 (I3 - I2), I3 (I2 - I1), I2 (I3 - I1), sqrt((I3 - I2)(I3 - I1)/(I1 I2))/I3)`` for the axes
    ``(a1, a2, a3)`` of :func:`free_flow` with moments ``(I1, I2, I3)`` (increasing or decreasing): the
    products of the amplitudes' ratios (``A1^2 = q1^2 + q2^2 pa/pc``, ...) and ``lam/A3``."""
    return I1 * (I3 - I2), I3 * (I2 - I1), I2 * (I3 - I1), math.sqrt((I3 - I2) * (I3 - I1) / (I1 * I2)) / I3


@jit(inline="always")
def flow_constants(I, ax):
    """The body's constants of :func:`free_flow` (11 floats): ``1/I_i`` (3), then :func:`orbit_constants`
    for ``(I1, I2, I3) = (I_min, I_mid, I_max)`` (4) and for ``(I_max, I_mid, I_min)`` (4). Infinite or
    NaN for equal moments, where :func:`free_flow` does not read them.

    The amplitudes' ratios are kept as products, not quotients: each flow divides by them. A quotient
    rounded once per run would multiply the same (nearly conserved) ``q2^2`` by the same rounding error
    every flow, a bias of ``|Pi|^2`` and the energy a flow that adds up (tests/test_splitting_flow.py)."""
    lo = I[ax[0]]
    mid = I[ax[1]]
    hi = I[ax[2]]
    return (1.0 / I[0], 1.0 / I[1], 1.0 / I[2]) + orbit_constants(lo, mid, hi) + orbit_constants(hi, mid, lo)


@jit
def free_flow(I, ax, symax, R, Pi, tau, ws, fc):
    """Advance the free rigid body ``(R, Pi)`` by the time ``tau`` exactly, in place.

    Parameters
    ----------
    I : (3,) float64
        Principal moments, one per body axis (the body frame is the principal frame).
    ax : (3,) int64
        Body axes of the smallest, middle and largest moment.
    symax : int
        ``-1`` three distinct moments; ``0, 1, 2`` the symmetry axis of a body with two equal
        moments; ``3`` all three equal.
    R : (3, 3) float64
        Attitude (body to inertial), updated.
    Pi : (3,) float64
        Body angular momentum, updated.
    tau : float
        Time (any sign).
    ws : (64,) float64
        Scratch.
    fc : tuple of 11 floats
        :func:`flow_constants` of ``I`` and ``ax`` (the body's constants, computed once per run).
    """
    p0 = Pi[0]
    p1 = Pi[1]
    p2 = Pi[2]
    L2 = p0 * p0 + p1 * p1 + p2 * p2
    if L2 == 0.0 or tau == 0.0:
        return
    L = math.sqrt(L2)
    if symax == 3:                      # spherical: a steady rotation
        w = L / I[0]
        rotate_by(R, p0 / L, p1 / L, p2 / L, w * tau, ws)
        return
    if symax >= 0:                      # axisymmetric: Pi turns about e_s, R precesses about L
        s = symax
        Iperp = I[(s + 1) % 3]
        mu = (1.0 / I[s] - 1.0 / Iperp) * Pi[s]
        ex = 1.0 if s == 0 else 0.0
        ey = 1.0 if s == 1 else 0.0
        ez = 1.0 if s == 2 else 0.0
        rotate_by(R, p0 / L, p1 / L, p2 / L, L * tau / Iperp, ws)
        rotate_by(R, ex, ey, ez, mu * tau, ws)
        # Pi(tau) = Rot(e_s, -mu tau) Pi = Rot(e_s, mu tau)^T Pi
        q0 = ws[50] * p0 + ws[53] * p1 + ws[56] * p2
        q1 = ws[51] * p0 + ws[54] * p1 + ws[57] * p2
        q2 = ws[52] * p0 + ws[55] * p1 + ws[58] * p2
        Pi[0] = q0
        Pi[1] = q1
        Pi[2] = q2
        return
    imin = ax[0]
    imid = ax[1]
    imax = ax[2]
    Jmid = I[imid]
    # D = m1 A3^2 pa of the orbit about the largest moment's axis (m1 >= 0 there), else about the smallest's
    D = Pi[imax] * Pi[imax] * fc[3] - Pi[imin] * Pi[imin] * fc[4]
    if D == 0.0 and Pi[imin] == 0.0 and Pi[imax] == 0.0:   # steady spin about the middle axis
        ex = 1.0 if imid == 0 else 0.0
        ey = 1.0 if imid == 1 else 0.0
        ez = 1.0 if imid == 2 else 0.0
        rotate_by(R, ex, ey, ez, Pi[imid] / Jmid * tau, ws)
        return
    if D >= 0.0:
        a1 = imin
        a3 = imax
        pa, pb, pc, clam = fc[3], fc[4], fc[5], fc[6]
    else:
        a1 = imax
        a3 = imin
        pa, pb, pc, clam = fc[7], fc[8], fc[9], fc[10]
    a2 = imid
    sg = 1.0 if (a2 - a1) % 3 == 1 else -1.0      # S = rows e_a1, sg e_a2, e_a3 has det +1
    I2 = I[a2]
    I3 = I[a3]
    q1 = Pi[a1]
    q2 = sg * Pi[a2]
    q3 = Pi[a3]
    # The amplitudes and m are nearly conserved: a rounding error that is the same every flow adds up
    # (|Pi|^2, the energy and, through m1, the frequency drift). So the ratios are divided per flow
    # (rounded anew each time; flow_constants) and m1 A3^2 pa = q3^2 pa - q1^2 pb comes from the
    # momentum itself, not as the difference of the two rounded A3^2 pa and A1^2 pb, whose cancellation
    # near the separatrix (m1 -> 0) multiplied their rounding by 1/m1 (docs/splitting.md)
    s1 = q1 * q1
    t2 = q2 * q2 / pc
    s3q = q3 * q3
    A1 = math.sqrt(s1 + t2 * pa)
    A2 = math.sqrt(q2 * q2 + s1 * pc / pa)
    A3 = math.sqrt(s3q + t2 * pb)
    inv = 1.0 / (A3 * A3 * pa)
    m = A1 * A1 * pb * inv
    m1 = (s3q * pa - s1 * pb) * inv
    if m >= 1.0 or m1 <= 0.0:
        m = 1.0
        m1 = 0.0
    lam = A3 * clam
    s3 = 1.0 if q3 > 0.0 else -1.0
    s23 = 1.0 if I3 > I2 else -1.0
    B2 = s3 * s23 * A2
    B3 = s3 * A3
    # the Euler axis: the body axis whose momentum amplitude is smallest; L^2 - Pi_e^2 = c0 (1 - nn sn^2)
    if A1 <= A2 and A1 <= A3:
        e = a1
        c0 = A3 * A3
        nn = -A1 * A1 / c0
    elif A2 <= A3:
        e = a2
        c0 = A1 * A1 + A3 * A3
        nn = A2 * A2 / c0
    else:
        e = a3
        c0 = A1 * A1
        nn = -m * A3 * A3 / c0
    # phase: am(u0) = phi0; reduced to r0 = phi0 - j0 pi in [-pi/2, pi/2] (am(u + 2K) = am(u) + pi, and the
    # integrals below are differences, unchanged by the shift): (sin r0, cos r0) = +-(y, x) / |(x, y)|
    xph = q1 * A2
    yph = q2 * A1 * s3 * s23
    if m1 <= 0.0:                     # the separatrix (m = 1): am(u | 1) = gd(u) in (-pi/2, pi/2)
        phi0 = max(-0.5 * math.pi, min(0.5 * math.pi, math.atan2(yph, xph)))
        sr0 = math.sin(phi0)
        cr0 = math.cos(phi0)
        flip = 1.0
    else:
        rho = math.sqrt(xph * xph + yph * yph)
        flip = 1.0 if xph >= 0.0 else -1.0
        sr0 = flip * yph / rho if rho > 0.0 else 0.0
        cr0 = flip * xph / rho if rho > 0.0 else 1.0
    y0 = cr0 * cr0 + m1 * sr0 * sr0
    rf0, rj0 = rf_rj_call(cr0 * cr0, y0, 1.0, 1.0 - nn * sr0 * sr0)
    u0 = sr0 * rf0
    # sn, cn of u1 = u0 + lam tau and j1 with am(u1) = r1 + j1 pi, r1 in [-pi/2, pi/2]: by the descending
    # Landen transformation, or near the separatrix (m1 < AGM_M1) by the AGM amplitude, whose angle is
    # more accurate there (the next flow reads the phase back with the error divided by dn ~ sqrt(m1))
    if m1 < AGM_M1:
        phi1 = jacobi_am(u0 + lam * tau, m, m1, ws)
        j1 = round(phi1 / math.pi)
        sn = math.sin(phi1)
        cn = math.cos(phi1)
    else:
        sn, cn, j1 = jacobi_sncn(u0 + lam * tau, m, m1, ws)
    sr1 = -sn if j1 % 2 != 0 else sn
    cr1 = -cn if j1 % 2 != 0 else cn
    sn = flip * sn
    cn = flip * cn
    dn = math.sqrt(cn * cn + m1 * sn * sn)
    iIe = fc[e]
    twoE_minus = p0 * p0 * (fc[0] - iIe) + p1 * p1 * (fc[1] - iIe) + p2 * p2 * (fc[2] - iIe)
    # int dt / (L^2 - Pi_e^2) = [Pi(nn; am u | m)] / (c0 lam), and Pi(nn; phi) = F(phi) + nn/3 G(phi) with
    # F(am u) = u, so the difference is lam tau + nn/3 (G(phi1) - G(phi0))
    # G(phi1) = sin^3 r1 R_J(cos^2 r1, ...) + 2 j1 R_J(0, m1, 1, 1 - nn), from sin and cos of r1
    dG = sr1 * sr1 * sr1 * carlson_rj(cr1 * cr1, cr1 * cr1 + m1 * sr1 * sr1, 1.0, 1.0 - nn * sr1 * sr1) \
        - sr0 * sr0 * sr0 * rj0
    if j1 != 0:
        dG += 2.0 * j1 * carlson_rj(0.0, m1, 1.0, 1.0 - nn)
    psi = L * tau * iIe + L * twoE_minus / c0 * (tau + nn / (3.0 * lam) * dG)
    euler_frame(p0, p1, p2, e, ws, 32)            # V0
    n1 = A1 * cn
    n2 = B2 * sn
    n3 = B3 * dn
    Pi[a1] = n1
    Pi[a2] = sg * n2
    Pi[a3] = n3
    euler_frame(Pi[0], Pi[1], Pi[2], e, ws, 41)   # V1
    # F = V0^T Rz(psi) V1 into ws[50:59]
    c = math.cos(psi)
    s = math.sin(psi)
    for j in range(3):
        w0 = c * ws[41 + j] - s * ws[44 + j]
        w1 = s * ws[41 + j] + c * ws[44 + j]
        w2 = ws[47 + j]
        for i in range(3):
            ws[50 + 3 * i + j] = ws[32 + i] * w0 + ws[35 + i] * w1 + ws[38 + i] * w2
    rotate_right(R, ws, 50)


@jit
def _to_frame(R, Pi, Pax, forward, ws):
    """Between the body frame and the principal frame ``(R Pax, Pax^T Pi)`` (``forward``) or back.

    Called, not inlined (it runs at the ends of a chunk and at saved samples only); the callers pass
    ``forward`` as a runtime bool (``not diag`` / ``diag`` under ``if not diag``), not a literal, so
    that one compiled copy serves both directions."""
    for i in range(3):
        for j in range(3):
            ws[59 + j] = R[i, j]
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += ws[59 + k] * (Pax[k, j] if forward else Pax[j, k])
            R[i, j] = acc
    for j in range(3):
        ws[59 + j] = Pi[j]
    for i in range(3):
        acc = 0.0
        for k in range(3):
            acc += (Pax[k, i] if forward else Pax[i, k]) * ws[59 + k]
        Pi[i] = acc


@jit(inline="always")
def kick(moment, up, user, diag, Pax, J, codes, params, t, hb, R, Pi, Rs, Ps):
    """``Pi += hb M(t, R)`` with the moment in the principal frame (the models see the body frame).

    Returns whether the user's function (``user``; ``moment`` guarded, :func:`.user_kernels.guarded`)
    raised: the guard then marks its scratch ``Rs[0, 0]`` with NaN, and its moment is NaN (so the
    step ends non-finite and is undone); a rotation given to it that was finite tells the two apart."""
    if diag:
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2],
                                                       R[2, 0], R[2, 1], R[2, 2])
    else:   # R_body = R Pax^T
        r00 = R[0, 0] * Pax[0, 0] + R[0, 1] * Pax[0, 1] + R[0, 2] * Pax[0, 2]
        r01 = R[0, 0] * Pax[1, 0] + R[0, 1] * Pax[1, 1] + R[0, 2] * Pax[1, 2]
        r02 = R[0, 0] * Pax[2, 0] + R[0, 1] * Pax[2, 1] + R[0, 2] * Pax[2, 2]
        r10 = R[1, 0] * Pax[0, 0] + R[1, 1] * Pax[0, 1] + R[1, 2] * Pax[0, 2]
        r11 = R[1, 0] * Pax[1, 0] + R[1, 1] * Pax[1, 1] + R[1, 2] * Pax[1, 2]
        r12 = R[1, 0] * Pax[2, 0] + R[1, 1] * Pax[2, 1] + R[1, 2] * Pax[2, 2]
        r20 = R[2, 0] * Pax[0, 0] + R[2, 1] * Pax[0, 1] + R[2, 2] * Pax[0, 2]
        r21 = R[2, 0] * Pax[1, 0] + R[2, 1] * Pax[1, 1] + R[2, 2] * Pax[1, 2]
        r22 = R[2, 0] * Pax[2, 0] + R[2, 1] * Pax[2, 1] + R[2, 2] * Pax[2, 2]
    P0, P1, P2, Q0, Q1, Q2 = model_moments_s(codes, params, J, t, r00, r01, r02, r10, r11, r12, r20, r21, r22)
    m0 = P0 + Q0
    m1 = P1 + Q1
    m2 = P2 + Q2
    if user:
        Rs[0, 0], Rs[0, 1], Rs[0, 2], Rs[1, 0], Rs[1, 1], Rs[1, 2], Rs[2, 0], Rs[2, 1], Rs[2, 2] = (
            r00, r01, r02, r10, r11, r12, r20, r21, r22)
        if diag:
            Ps[0] = Pi[0]
            Ps[1] = Pi[1]
            Ps[2] = Pi[2]
        else:
            Ps[0] = Pax[0, 0] * Pi[0] + Pax[0, 1] * Pi[1] + Pax[0, 2] * Pi[2]
            Ps[1] = Pax[1, 0] * Pi[0] + Pax[1, 1] * Pi[1] + Pax[1, 2] * Pi[2]
            Ps[2] = Pax[2, 0] * Pi[0] + Pax[2, 1] * Pi[1] + Pax[2, 2] * Pi[2]
        u = moment(t, Rs, Ps, up)
        raised = Rs[0, 0] != Rs[0, 0] and r00 == r00
        m0 += float(u[0])
        m1 += float(u[1])
        m2 += float(u[2])
    else:
        raised = False
    if diag:
        Pi[0] += hb * m0
        Pi[1] += hb * m1
        Pi[2] += hb * m2
    else:   # Pax^T M
        Pi[0] += hb * (Pax[0, 0] * m0 + Pax[1, 0] * m1 + Pax[2, 0] * m2)
        Pi[1] += hb * (Pax[0, 1] * m0 + Pax[1, 1] * m1 + Pax[2, 1] * m2)
        Pi[2] += hb * (Pax[0, 2] * m0 + Pax[1, 2] * m1 + Pax[2, 2] * m2)
    return raised


@jit(inline="always")
def step_end(R, Pi, Rb, Pb, countdown, save_every, jout, R_out, Pi_out, Pax, diag, ws):
    """A step's end in :func:`split_steps` and :func:`axes_steps`: if ``R`` or ``Pi`` is not finite,
    restore them from ``Rb``, ``Pb`` (the step's start) and return ``ok = False``; else, when
    ``countdown`` is 0, store sample ``jout`` (in the body frame) and restart the countdown.
    Returns ``(ok, countdown, jout)``."""
    ok = math.isfinite(Pi[0]) and math.isfinite(Pi[1]) and math.isfinite(Pi[2])
    for i in range(3):
        for j in range(3):
            ok = ok and math.isfinite(R[i, j])
    if not ok:
        for i in range(3):
            Pi[i] = Pb[i]
            for j in range(3):
                R[i, j] = Rb[i, j]
        return False, countdown, jout
    if countdown == 0:
        countdown = save_every
        for i in range(3):
            Pi_out[jout, i] = Pi[i]
            for j in range(3):
                R_out[jout, i, j] = R[i, j]
        if not diag:
            # saved in the body frame
            _to_frame(R_out[jout], Pi_out[jout], Pax, diag, ws)
        jout += 1
    return True, countdown, jout


@jit(inline="always")
def split_steps(moment, up, user, I, ax, symax, Pax, diag, J, drift, weight, node, h, t0, R, Pi, codes, params,
                k0, n, save_every, R_out, Pi_out, ws, Rb, Pb, Rs, Ps):
    """Steps ``k0 .. k0+n-1`` of the splitting: per step, drifts (exact free flows) of
    ``drift[i] h`` and kicks ``Pi += weight[i] h M(t0 + (k + node[i]) h, R)``; the last drift of a
    step and the first of the next are one flow, except at saved samples. Returns ``(status, k)``:
    ``OVERFLOW`` for a step that made the state non-finite, ``USER_RAISED`` when the user's function
    raised in it (the state is then the step's start)."""
    s = weight.shape[0]
    fc = flow_constants(I, ax)
    if not diag:
        _to_frame(R, Pi, Pax, not diag, ws)    # forward (a runtime bool: one compiled _to_frame for both ways)
    countdown = save_every
    jout = 0
    pend = 0.0
    status = OK
    kend = k0 + n
    for k in range(k0, k0 + n):
        for i in range(3):
            Pb[i] = Pi[i]
            for j in range(3):
                Rb[i, j] = R[i, j]
        pend_b = pend
        pend += drift[0] * h
        raised = False
        for i in range(s):
            free_flow(I, ax, symax, R, Pi, pend, ws, fc)
            if kick(moment, up, user, diag, Pax, J, codes, params, t0 + (k + node[i]) * h, weight[i] * h, R, Pi, Rs,
                    Ps):
                raised = True
            pend = drift[i + 1] * h
        countdown -= 1
        if countdown == 0:
            free_flow(I, ax, symax, R, Pi, pend, ws, fc)
            pend = 0.0
        ok, countdown, jout = step_end(R, Pi, Rb, Pb, countdown, save_every, jout, R_out, Pi_out, Pax, diag, ws)
        if not ok:
            free_flow(I, ax, symax, R, Pi, pend_b, ws, fc)
            status = USER_RAISED if raised else OVERFLOW
            kend = k
            break
    if not diag:
        _to_frame(R, Pi, Pax, diag, ws)
    return status, kend


@jit(inline="always")
def axis_flow(I, i, R, Pi, tau):
    """Exact flow of ``T_i = Pi_i^2 / (2 I_i)`` over ``tau``, in place: ``R <- R exp(th e_i^)``,
    ``Pi <- exp(-th e_i^) Pi`` with ``th = Pi_i tau / I_i`` (``Pi_i`` is constant)."""
    th = Pi[i] / I[i] * tau
    c = math.cos(th)
    s = math.sin(th)
    a = (i + 1) % 3
    b = (i + 2) % 3
    for r in range(3):
        x = R[r, a]
        y = R[r, b]
        R[r, a] = c * x + s * y
        R[r, b] = c * y - s * x
    x = Pi[a]
    y = Pi[b]
    Pi[a] = c * x + s * y
    Pi[b] = c * y - s * x


@jit(inline="always")
def axes_steps(moment, up, user, I, ax, Pax, diag, J, weight, node, h, t0, R, Pi, codes, params, k0, n, save_every,
               R_out, Pi_out, ws, Rb, Pb, Rs, Ps):
    """Steps ``k0 .. k0+n-1`` of an axis splitting (``base="axes"``): per step, the stages
    ``U(g/2) T_a(g/2) T_b(g/2) T_c(g) T_b(g/2) T_a(g/2) U(g/2)`` with ``g = weight[i] h``, ``(a, b, c) = ax``
    (smallest, middle, largest moment; ``T_i`` the rotation about principal axis ``i``) and the kicks
    at the stage's ends (``t0 + k h`` and ``t0 + (k + node[i]) h``); the kicks between two stages of a
    step are one. Returns ``(status, k)`` (as :func:`split_steps`)."""
    s = weight.shape[0]
    oa = ax[0]
    ob = ax[1]
    oc = ax[2]
    if not diag:
        _to_frame(R, Pi, Pax, not diag, ws)    # forward (a runtime bool: one compiled _to_frame for both ways)
    countdown = save_every
    jout = 0
    status = OK
    kend = k0 + n
    for k in range(k0, k0 + n):
        for i in range(3):
            Pb[i] = Pi[i]
            for j in range(3):
                Rb[i, j] = R[i, j]
        raised = kick(moment, up, user, diag, Pax, J, codes, params, t0 + k * h, 0.5 * weight[0] * h, R, Pi, Rs, Ps)
        for i in range(s):
            g = weight[i] * h
            axis_flow(I, oa, R, Pi, 0.5 * g)
            axis_flow(I, ob, R, Pi, 0.5 * g)
            axis_flow(I, oc, R, Pi, g)
            axis_flow(I, ob, R, Pi, 0.5 * g)
            axis_flow(I, oa, R, Pi, 0.5 * g)
            hb = 0.5 * (weight[i] + weight[i + 1]) * h if i + 1 < s else 0.5 * g
            if kick(moment, up, user, diag, Pax, J, codes, params, t0 + (k + node[i]) * h, hb, R, Pi, Rs, Ps):
                raised = True
        countdown -= 1
        ok, countdown, jout = step_end(R, Pi, Rb, Pb, countdown, save_every, jout, R_out, Pi_out, Pax, diag, ws)
        if not ok:
            status = USER_RAISED if raised else OVERFLOW
            kend = k
            break
    if not diag:
        _to_frame(R, Pi, Pax, diag, ws)
    return status, kend


@jit(inline="always")
def no_moment(t, R, Pi, p):
    return (0.0, 0.0, 0.0)


@jit(_nrt=False)
def run_split(I, ax, symax, Pax, diag, J, drift, weight, node, h, t0, R, Pi, codes, params, k0, n, save_every,
              R_out, Pi_out, ws, Rb, Pb, Rs, Ps):
    """:func:`split_steps` with the built-in torque models only (``codes``, ``params``)."""
    return split_steps(no_moment, params, False, I, ax, symax, Pax, diag, J, drift, weight, node, h, t0, R, Pi,
                       codes, params, k0, n, save_every, R_out, Pi_out, ws, Rb, Pb, Rs, Ps)


@jit(_nrt=False)
def run_split_user(moment, up, I, ax, symax, Pax, diag, J, drift, weight, node, h, t0, R, Pi, codes, params, k0,
                   n, save_every, R_out, Pi_out, ws, Rb, Pb, Rs, Ps):
    """:func:`split_steps` with the user's compiled ``moment(t, R, Pi, up)`` added to the models, as a
    value of :data:`.user_kernels.MOMENT_SIGNATURE` (:func:`.user_kernels.guarded`): one loop, cached on
    disk, for every user's model, as :func:`.user_kernels.run_chunk_user`. A step whose function raised
    fails with ``USER_RAISED``."""
    return split_steps(moment, up, True, I, ax, symax, Pax, diag, J, drift, weight, node, h, t0, R, Pi,
                       codes, params, k0, n, save_every, R_out, Pi_out, ws, Rb, Pb, Rs, Ps)


@jit(_nrt=False)
def run_axes(I, ax, symax, Pax, diag, J, drift, weight, node, h, t0, R, Pi, codes, params, k0, n, save_every,
             R_out, Pi_out, ws, Rb, Pb, Rs, Ps):
    """:func:`axes_steps` with the built-in torque models only (the arguments of :func:`run_split`;
    ``symax`` and ``drift`` are unused)."""
    return axes_steps(no_moment, params, False, I, ax, Pax, diag, J, weight, node, h, t0, R, Pi, codes, params, k0,
                      n, save_every, R_out, Pi_out, ws, Rb, Pb, Rs, Ps)


@jit(_nrt=False)
def run_axes_user(moment, up, I, ax, symax, Pax, diag, J, drift, weight, node, h, t0, R, Pi, codes, params, k0,
                  n, save_every, R_out, Pi_out, ws, Rb, Pb, Rs, Ps):
    """:func:`axes_steps` with the user's compiled ``moment(t, R, Pi, up)`` (see :func:`run_split_user`)."""
    return axes_steps(moment, up, True, I, ax, Pax, diag, J, weight, node, h, t0, R, Pi, codes, params, k0, n,
                      save_every, R_out, Pi_out, ws, Rb, Pb, Rs, Ps)


@jit
def flow_once(I, ax, symax, R, Pi, tau, ws):
    """One exact free flow (tests and the Python layer): :func:`free_flow`."""
    free_flow(I, ax, symax, R, Pi, tau, ws, flow_constants(I, ax))


__all__ = ["axis_flow", "carlson_rf", "carlson_rj", "flow_once", "free_flow", "run_axes", "run_axes_user", "run_split",
           "run_split_user"]
