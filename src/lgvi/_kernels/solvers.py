"""Newton-type solvers for the implicit equation ``hat(hPi) = F Jd - Jd F^T`` (paper, section 4).

Each solver works on a coordinate vector ``g`` of the unknown ``F`` (updated in place, so the
caller can warm start the next solve from it) and leaves ``E = F - I`` in a caller array.
Keeping ``F - I`` rather than ``F`` lets the residual be evaluated without cancellation, so the
relative stopping rule works for ``|h Pi|`` from 1e-8 to 1e3.

Methods (integer codes, shared with :mod:`lgvi.implicit`):

``METHOD_PAPER``  (0)  ``g = w``, ``F = exp(hat w)``; the paper's additive update
                       ``w <- w - alpha Df(w)^-1 f(w)`` with the paper's ``Df``, whose columns
                       are ``vee(e^w E_i Jd + Jd E_i e^-w)`` = ``(tr(A) I - A) F`` with
                       ``A = F Jd``. That ``Df`` is exact for ``F <- F exp(hat d)``, not for the
                       additive update, so the iteration converges linearly.
``METHOD_NEWTON`` (1)  ``g = w``; exact Newton: the true derivative of ``f(w)`` is
                       ``(tr(A) I - A) Jl(w)`` (``Jl`` the left Jacobian of ``exp``), because a
                       left update ``F <- exp(hat d) F`` changes ``f`` by ``(tr(A) I - A) d``.
``METHOD_CAYLEY`` (2)  ``g = f``, ``F = (I + hat f)(I - hat f)^-1``; Newton on Lee's equivalent
                       form ``G(f) = hPi + hPi x f + (hPi . f) f - 2 J f = 0`` with
                       ``DG = hat(hPi) + (hPi . f) I + f hPi^T - 2 J``. No trigonometry.
                       ``G`` is quadratic, ``G(f + s) = G(f) + DG s + (hPi . s) s`` exactly, so
                       each update also removes the quadratic term with the same ``DG``:
                       ``s <- s - (hPi . s) DG^-1 s`` (Chebyshev's method, third order). From
                       the stepping loops' warm start one update lands at round-off.

Stopping rule (all methods): with ``r = vee(E Jd - Jd E^T) - hPi`` the residual of the paper's
``f``, stop when ``|r| <= tol |hPi| + 8 eps (|Jd| |E| + |hPi|)``: ``tol`` is relative to the
size of the right-hand side, and the second term is the round-off floor of evaluating ``r``.
Cayley only: an iterate within ``tol`` but above that floor gets one more update (at most one),
so the accepted solution is at round-off whatever ``tol`` (a solve stopped at ``1e-14`` relative
leaves an error that accumulates over long runs into the phase; see docs/performance.md).

Status codes: ``OK`` (0), ``NOT_CONVERGED`` (1, ``max_iter`` updates did not reach the
tolerance), ``NOT_FINITE`` (2, the iterate or the residual became NaN/inf), ``SINGULAR`` (3, the
Newton matrix was singular).
"""

from __future__ import annotations

import math

from .._jit import jit, jit_copy
from .codes import METHOD_CAYLEY, METHOD_NEWTON, METHOD_PAPER, NOT_CONVERGED, NOT_FINITE, OK, SINGULAR

__all__ = ["METHOD_CAYLEY", "METHOD_NEWTON", "METHOD_PAPER", "NOT_CONVERGED", "NOT_FINITE", "OK", "SINGULAR",
           "initial_guess", "solve_implicit_kernel", "solve_scalar"]

EPS = 2.220446049250313e-16
#: Below this angle (rad) the Rodrigues coefficients use their Taylor series through t^8, exact to
#: rounding there: the first dropped terms are below 3e-18 relative at t = 0.1.
SERIES_ANGLE = 0.1
# Horner coefficients (multiplications only: a division by a constant is not turned into one)
#: Cayley updates ``s`` with ``|s|^2`` at most this skip the quadratic correction (see solve_scalar).
CHEBYSHEV_MIN = 2.0 ** -56
_A1, _A2, _A3, _A4 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0          # sin t / t
_B1, _B2, _B3, _B4 = -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0, 1.0 / 3628800.0       # (1 - cos t) / t^2
_E0, _E1, _E2, _E3 = 1.0 / 12.0, 1.0 / 720.0, 1.0 / 30240.0, 1.0 / 1209600.0       # (1 - t/2 cot t/2) / t^2


@jit(inline="always")
def expm1_entries(x, y, z, a, b):
    """Entries of E = a hat(w) + b hat(w)^2 (row-major), w = (x, y, z)."""
    xx = x * x
    yy = y * y
    zz = z * z
    bxy = b * x * y
    bxz = b * x * z
    byz = b * y * z
    return (-b * (yy + zz), -a * z + bxy, a * y + bxz,
            a * z + bxy, -b * (xx + zz), -a * x + byz,
            -a * y + bxz, a * x + byz, -b * (xx + yy))


@jit(inline="always")
def cofactors3(m00, m01, m02, m10, m11, m12, m20, m21, m22):
    """The cofactors of a 3x3 ``m`` (``c[i][j]``, so that ``m^-1 = c^T / det``) and its determinant
    along the first row: ``(c00, c01, c02, c10, c11, c12, c20, c21, c22, det)``. Cramer's rule of
    :func:`cramer3`, of the solvers' Newton steps and of the lockstep Cayley step (which reuse the
    cofactors for Chebyshev's correction)."""
    c00 = m11 * m22 - m12 * m21
    c01 = m12 * m20 - m10 * m22
    c02 = m10 * m21 - m11 * m20
    c10 = m02 * m21 - m01 * m22
    c11 = m00 * m22 - m02 * m20
    c12 = m01 * m20 - m00 * m21
    c20 = m01 * m12 - m02 * m11
    c21 = m02 * m10 - m00 * m12
    c22 = m00 * m11 - m01 * m10
    return c00, c01, c02, c10, c11, c12, c20, c21, c22, m00 * c00 + m01 * c01 + m02 * c02


@jit(inline="always")
def cramer3(m00, m01, m02, m10, m11, m12, m20, m21, m22, q0, q1, q2):
    """``x = m^-1 q`` for a 3x3 ``m`` by Cramer's rule (cofactors, one division): ``(x0, x1, x2, ok)``,
    ``ok`` False (and ``x`` zero) when the determinant is zero or not finite."""
    c00, c01, c02, c10, c11, c12, c20, c21, c22, det = cofactors3(m00, m01, m02, m10, m11, m12, m20, m21, m22)
    if det == 0.0 or not math.isfinite(det):
        return 0.0, 0.0, 0.0, False
    inv = 1.0 / det
    return ((c00 * q0 + c10 * q1 + c20 * q2) * inv, (c01 * q0 + c11 * q1 + c21 * q2) * inv,
            (c02 * q0 + c12 * q1 + c22 * q2) * inv, True)


@jit(inline="always")
def solve_scalar(method, d00, d01, d02, d11, d12, d22, p0, p1, p2, g0, g1, g2, tol, max_iter, alpha, hist,
                 eager=False):
    """Scalar core of every solver (no arrays touched but ``hist``): see the module docstring.

    ``d..`` are the entries of the symmetric ``Jd``, ``p`` = ``h Pi``, ``g`` the initial
    coordinates. Returns ``(g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, its, rn,
    status)`` with ``E = F - I`` of the returned coordinates.

    ``eager=True`` (Cayley only; used by the stepping loops, whose extrapolated guess is never
    within 1e-14) applies the first Newton update before the first residual check: Lee's ``G``
    needs no ``F``, so this saves one evaluation of ``F - I`` and of the residual per step. The
    result still satisfies the same stopping rule; only ``iterations`` is at least 1.
    """
    tr = d00 + d11 + d22
    # J = tr(Jd) I - Jd, needed by the Cayley form
    j00 = tr - d00
    j11 = tr - d11
    j22 = tr - d22
    hn2 = p0 * p0 + p1 * p1 + p2 * p2
    hn = math.sqrt(hn2)
    jdn = math.sqrt(d00 * d00 + d11 * d11 + d22 * d22 + 2.0 * (d01 * d01 + d02 * d02 + d12 * d12))
    nhist = hist.shape[0]
    it = 0
    a = 0.0
    b = 0.0
    t2 = 0.0
    skip_check = eager and method == METHOD_CAYLEY and max_iter > 0
    x01 = x02 = x10 = x12 = x20 = x21 = 0.0
    E00 = E01 = E02 = E10 = E11 = E12 = E20 = E21 = E22 = 0.0
    r0 = r1 = r2 = 0.0
    rn2 = math.inf  # no residual evaluated yet (eager first update)
    polish = False
    while True:
        if skip_check:
            skip_check = False
        else:
            t2 = g0 * g0 + g1 * g1 + g2 * g2
            if not math.isfinite(t2):   # a diverged iterate (checked before any trigonometry)
                return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), NOT_FINITE
            if method == METHOD_CAYLEY:
                a = 2.0 / (1.0 + t2)
                b = a
            else:
                if t2 < SERIES_ANGLE * SERIES_ANGLE:
                    # sin t / t and (1 - cos t) / t^2 through t^8: no trigonometry for the usual
                    # steps (|h Omega| < 0.1); the first dropped terms, t^10/11! and t^10/12!, are
                    # below 3e-18 relative at t = 0.1 (checked against 50-digit values: 0.5 ulp)
                    a = 1.0 + t2 * (_A1 + t2 * (_A2 + t2 * (_A3 + t2 * _A4)))
                    b = 0.5 + t2 * (_B1 + t2 * (_B2 + t2 * (_B3 + t2 * _B4)))
                else:
                    t = math.sqrt(t2)
                    sh = math.sin(0.5 * t)
                    ch = math.cos(0.5 * t)
                    a = 2.0 * sh * ch / t             # sin t / t
                    b = 2.0 * sh * sh / t2            # (1 - cos t) / t^2, no cancellation
            # |F - I|_F^2 = 4 (1 - cos angle) = 4 b |g|^2 for both maps (b = a for Cayley): at most 8
            enorm = 2.0 * math.sqrt(b * t2)
            E00, E01, E02, E10, E11, E12, E20, E21, E22 = expm1_entries(g0, g1, g2, a, b)
            # X = E Jd (Jd symmetric); r = vee(X - X^T) - hPi needs the off-diagonal entries only
            x01 = E00 * d01 + E01 * d11 + E02 * d12
            x02 = E00 * d02 + E01 * d12 + E02 * d22
            x10 = E10 * d00 + E11 * d01 + E12 * d02
            x12 = E10 * d02 + E11 * d12 + E12 * d22
            x20 = E20 * d00 + E21 * d01 + E22 * d02
            x21 = E20 * d01 + E21 * d11 + E22 * d12
            r0 = (x21 - x12) - p0
            r1 = (x02 - x20) - p1
            r2 = (x10 - x01) - p2
            rn2 = r0 * r0 + r1 * r1 + r2 * r2
            if it < nhist:
                hist[it] = math.sqrt(rn2)
            floor = 8.0 * EPS * (jdn * enorm + hn)
            thr = tol * hn + floor
            if not math.isfinite(rn2) or not math.isfinite(thr):
                # also |hPi| beyond ~1e154, where the squares overflow: no meaningful solve exists
                return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), NOT_FINITE
            if rn2 <= thr * thr:
                # Cayley: within tol but above the round-off floor, one more (third-order) update
                # takes the iterate to round-off; it is rare (the warm-started update lands there)
                if method != METHOD_CAYLEY or rn2 <= floor * floor or polish or it >= max_iter:
                    return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), OK
                polish = True
            if it >= max_iter:
                return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), NOT_CONVERGED
        if method == METHOD_CAYLEY:
            # Lee's G(f) = hPi + hPi x f + (hPi . f) f - 2 J f and DG = hat(hPi) + (hPi . f) I + f hPi^T - 2 J
            pf = p0 * g0 + p1 * g1 + p2 * g2
            q0 = -(p0 + (p1 * g2 - p2 * g1) + pf * g0 - 2.0 * (j00 * g0 - d01 * g1 - d02 * g2))
            q1 = -(p1 + (p2 * g0 - p0 * g2) + pf * g1 - 2.0 * (-d01 * g0 + j11 * g1 - d12 * g2))
            q2 = -(p2 + (p0 * g1 - p1 * g0) + pf * g2 - 2.0 * (-d02 * g0 - d12 * g1 + j22 * g2))
            m00 = pf + g0 * p0 - 2.0 * j00
            m01 = -p2 + g0 * p1 + 2.0 * d01
            m02 = p1 + g0 * p2 + 2.0 * d02
            m10 = p2 + g1 * p0 + 2.0 * d01
            m11 = pf + g1 * p1 - 2.0 * j11
            m12 = -p0 + g1 * p2 + 2.0 * d12
            m20 = -p1 + g2 * p0 + 2.0 * d02
            m21 = p0 + g2 * p1 + 2.0 * d12
            m22 = pf + g2 * p2 - 2.0 * j22
        else:
            # A = F Jd = Jd + X; M = tr(A) I - A
            x00 = E00 * d00 + E01 * d01 + E02 * d02
            x11 = E10 * d01 + E11 * d11 + E12 * d12
            x22 = E20 * d02 + E21 * d12 + E22 * d22
            ta = tr + x00 + x11 + x22
            m00 = ta - d00 - x00
            m01 = -d01 - x01
            m02 = -d02 - x02
            m10 = -d01 - x10
            m11 = ta - d11 - x11
            m12 = -d12 - x12
            m20 = -d02 - x20
            m21 = -d12 - x21
            m22 = ta - d22 - x22
            if method == METHOD_PAPER:
                # the paper's Df = M F = M (I + E)
                n00 = m00 + m00 * E00 + m01 * E10 + m02 * E20
                n01 = m01 + m00 * E01 + m01 * E11 + m02 * E21
                n02 = m02 + m00 * E02 + m01 * E12 + m02 * E22
                n10 = m10 + m10 * E00 + m11 * E10 + m12 * E20
                n11 = m11 + m10 * E01 + m11 * E11 + m12 * E21
                n12 = m12 + m10 * E02 + m11 * E12 + m12 * E22
                n20 = m20 + m20 * E00 + m21 * E10 + m22 * E20
                n21 = m21 + m20 * E01 + m21 * E11 + m22 * E21
                n22 = m22 + m20 * E02 + m21 * E12 + m22 * E22
                m00, m01, m02, m10, m11, m12, m20, m21, m22 = n00, n01, n02, n10, n11, n12, n20, n21, n22
            q0 = -r0
            q1 = -r1
            q2 = -r2
        # Cramer's rule for m x = q
        c00, c01, c02, c10, c11, c12, c20, c21, c22, det = cofactors3(m00, m01, m02, m10, m11, m12, m20, m21, m22)
        if det == 0.0 or not math.isfinite(det):
            return g0, g1, g2, E00, E01, E02, E10, E11, E12, E20, E21, E22, it, math.sqrt(rn2), SINGULAR
        inv = 1.0 / det
        s0 = (c00 * q0 + c10 * q1 + c20 * q2) * inv
        s1 = (c01 * q0 + c11 * q1 + c21 * q2) * inv
        s2 = (c02 * q0 + c12 * q1 + c22 * q2) * inv
        if method == METHOD_CAYLEY and s0 * s0 + s1 * s1 + s2 * s2 > CHEBYSHEV_MIN:
            # G is quadratic: G(f + s) = G(f) + DG s + (hPi . s) s exactly. Removing the last term
            # with the same DG (Chebyshev's method) makes the update third order; skipped when that
            # term is below a sixteenth of an ulp of hPi (|s|^2 <= 2^-56), as for small steps
            ps = (p0 * s0 + p1 * s1 + p2 * s2) * inv
            s0, s1, s2 = (s0 - ps * (c00 * s0 + c10 * s1 + c20 * s2), s1 - ps * (c01 * s0 + c11 * s1 + c21 * s2),
                          s2 - ps * (c02 * s0 + c12 * s1 + c22 * s2))
        if method == METHOD_NEWTON:
            # left update d = s  ->  coordinates move by Jl(w)^-1 d = d - w x d / 2 + e w x (w x d)
            if t2 < SERIES_ANGLE * SERIES_ANGLE:
                # (1 - (t/2) cot(t/2)) / t^2 through t^6 (2.6e-15 relative at t = 0.1; it only
                # scales a second-order correction of the update)
                e = _E0 + t2 * (_E1 + t2 * (_E2 + t2 * _E3))
            else:
                e = (1.0 - 0.5 * a / b) / t2
            u0 = g1 * s2 - g2 * s1
            u1 = g2 * s0 - g0 * s2
            u2 = g0 * s1 - g1 * s0
            v0 = g1 * u2 - g2 * u1
            v1 = g2 * u0 - g0 * u2
            v2 = g0 * u1 - g1 * u0
            s0 = s0 - 0.5 * u0 + e * v0
            s1 = s1 - 0.5 * u1 + e * v1
            s2 = s2 - 0.5 * u2 + e * v2
        g0 += alpha * s0
        g1 += alpha * s1
        g2 += alpha * s2
        it += 1


#: :func:`solve_scalar` as a function of its own (not inlined at Numba's level; LLVM decides), with
#: the same arguments (``eager`` given). The forced loops call the solver through this: an
#: ``inline="always"`` helper is copied into every caller at Numba's IR level, and the copy costs
#: time that grows with the size of the caller (most of the first call's compilation). Compiled
#: from :func:`solve_scalar`'s source itself (:func:`.._jit.jit_copy`), not as a wrapper that
#: inlines it, so the solver's IR is built once and never copied. The arithmetic is the same, bit
#: for bit.
solve_call = jit_copy(solve_scalar, "solve_call", "solve_scalar compiled as a function of its own (see the "
                      "module's solve_call).", _nrt=False)


@jit
def solve_implicit_kernel(method, Jd, hPi, g, tol, max_iter, alpha, E, hist):
    """Array wrapper of :func:`solve_scalar`: ``g`` (3,) in/out, ``E`` (3,3) out, ``hist`` (n,) out.

    Returns ``(iterations, residual, status)``.
    """
    res = solve_scalar(method, Jd[0, 0], Jd[0, 1], Jd[0, 2], Jd[1, 1], Jd[1, 2], Jd[2, 2],
                       hPi[0], hPi[1], hPi[2], g[0], g[1], g[2], tol, max_iter, alpha, hist)
    g[0] = res[0]
    g[1] = res[1]
    g[2] = res[2]
    E[0, 0] = res[3]
    E[0, 1] = res[4]
    E[0, 2] = res[5]
    E[1, 0] = res[6]
    E[1, 1] = res[7]
    E[1, 2] = res[8]
    E[2, 0] = res[9]
    E[2, 1] = res[10]
    E[2, 2] = res[11]
    return res[12], res[13], res[14]


@jit
def initial_guess(method, J, hPi, g):
    """Cold start from the linearisation ``hPi = J w`` (``w = 2 f`` for Cayley), ``g`` out."""
    c00 = J[1, 1] * J[2, 2] - J[1, 2] * J[2, 1]
    c01 = J[1, 2] * J[2, 0] - J[1, 0] * J[2, 2]
    c02 = J[1, 0] * J[2, 1] - J[1, 1] * J[2, 0]
    c10 = J[0, 2] * J[2, 1] - J[0, 1] * J[2, 2]
    c11 = J[0, 0] * J[2, 2] - J[0, 2] * J[2, 0]
    c12 = J[0, 1] * J[2, 0] - J[0, 0] * J[2, 1]
    c20 = J[0, 1] * J[1, 2] - J[0, 2] * J[1, 1]
    c21 = J[0, 2] * J[1, 0] - J[0, 0] * J[1, 2]
    c22 = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
    scale = 1.0 / (J[0, 0] * c00 + J[0, 1] * c01 + J[0, 2] * c02)
    if method == METHOD_CAYLEY:
        scale *= 0.5
    g[0] = (c00 * hPi[0] + c10 * hPi[1] + c20 * hPi[2]) * scale
    g[1] = (c01 * hPi[0] + c11 * hPi[1] + c21 * hPi[2]) * scale
    g[2] = (c02 * hPi[0] + c12 * hPi[1] + c22 * hPi[2]) * scale
