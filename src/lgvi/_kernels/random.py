"""Counter-based random numbers: a sample is a pure function of ``(seed, stream, counter)``.

Every random draw of a component (sensor noise, random walks) comes from here, so a member's draws
are the same whatever the thread count, the Dask layout, the order members run in or a resume: the
component keeps the counter in its state and the seed and stream in its parameter row
(``docs/components.md``, "Random streams").

The hash is the SplitMix64 finaliser (Steele, Lea and Flood 2014; the output function of
``java.util.SplittableRandom``, a bijection of 64-bit words with full avalanche), applied three
times to chain the three keys:

``key = mix(mix(seed + G) ^ (stream * C))``,  ``u64(seed, stream, counter) = mix(key + (counter + 1) G)``

with ``G = 0x9E3779B97F4A7C15`` (the golden-ratio increment of SplitMix64) and ``C`` an odd
constant. For a fixed key the words over ``counter`` are SplitMix64's own output sequence (period
``2^64``); different keys start the sequence at unrelated points.

Uniforms take the top 53 bits: ``u = (floor(u64 / 2^11) + 1/2) 2^-53`` lies in ``(0, 1)``, never 0
or 1, so ``log(u)`` is finite. Normal number ``c`` comes by the ziggurat method (Marsaglia and
Tsang 2000, 128 layers, in the form of Doornik 2005), an exact rejection method, not an
approximation: the word ``c`` gives the layer (its low 7 bits) and a uniform in ``(-1, 1)`` (its top
53 bits); 98.8% of the draws are accepted at once, the rest (the wedges and the tail beyond
``r = 3.44262``, by Marsaglia's exponential method) draw further words from a second key,
at indices ``c 2^20 + m``, so a normal is still a pure function of ``(seed, stream, c)``. The layer
table is computed at import from ``r`` (the root, to 1e-40, of the 128-layer closure equation) and
the common area ``v = r f(r) + sqrt(pi/2) erfc(r/sqrt(2))``, ``f(x) = exp(-x^2/2)``.

Seeds and streams are integers in ``[0, 2^53)`` (they travel in float64 rows), counters too.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import jit

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_STREAM = np.uint64(0xD1B54A32D192ED03)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_ONE = np.uint64(1)
_TWO = np.uint64(2)
_INV_2_53 = 1.0 / 9007199254740992.0


@jit(inline="always")
def mix64(z):
    """The SplitMix64 finaliser of the 64-bit word ``z`` (a bijection with full avalanche)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@jit(inline="always")
def stream_key(seed, stream):
    """The 64-bit key of ``(seed, stream)`` (both whole numbers in ``[0, 2^53)``, int or float)."""
    return mix64(mix64(np.uint64(seed) + _GOLDEN) ^ (np.uint64(stream) * _STREAM))


@jit(inline="always")
def bits_at(key, counter):
    """The 64-bit word number ``counter`` of the stream ``key``."""
    return mix64(key + (np.uint64(counter) + _ONE) * _GOLDEN)


@jit(inline="always")
def uniform_at(key, counter):
    """The uniform number ``counter`` of the stream ``key``, in the open interval ``(0, 1)``."""
    return ((bits_at(key, counter) >> _S11) + 0.5) * _INV_2_53


def _ziggurat_table(r: float, n: int) -> np.ndarray:
    """``x[0..n]``: ``x[0] = v / f(r)`` (the base strip's width), ``x[1] = r``,
    ``f(x[i+1]) = f(x[i]) + v / x[i]``, ``x[n] = 0``."""
    f = lambda x: math.exp(-0.5 * x * x)  # noqa: E731
    v = r * f(r) + math.sqrt(math.pi / 2) * math.erfc(r / math.sqrt(2.0))
    x = np.empty(n + 1)
    x[0] = v / f(r)
    x[1] = r
    for i in range(1, n - 1):
        x[i + 1] = math.sqrt(-2.0 * math.log(f(x[i]) + v / x[i]))
    x[n] = 0.0
    return x


_ZIG_R = 3.4426198558966523
_ZX = _ziggurat_table(_ZIG_R, 128)
_ZRATIO = np.array([_ZX[i + 1] / _ZX[i] for i in range(128)])
_SLOW = np.uint64(0x5851F42D4C957F2D)
_SHIFT20 = np.uint64(20)
_LOW7 = np.uint64(127)


@jit(inline="always")
def _signed_uniform(b):
    """A uniform in (-1, 1) from the top 53 bits of the word ``b``."""
    return ((b >> _S11) + 0.5) * (2.0 * _INV_2_53) - 1.0


@jit(inline="never")
def _normal_slow(key, counter, u, i):
    """The rejection part of the ziggurat for a first draw ``(u, i)`` that was not accepted at once."""
    key2 = mix64(key + _SLOW)
    m = np.uint64(counter) << _SHIFT20
    while True:
        if i == 0:          # the tail beyond r (Marsaglia 1964), with the sign of u
            while True:
                a = -math.log(uniform_at(key2, m)) / _ZIG_R
                b = -math.log(uniform_at(key2, m + _ONE))
                m += _TWO
                if 2.0 * b > a * a:
                    return _ZIG_R + a if u > 0.0 else -_ZIG_R - a
        x = u * _ZX[i]
        f0 = math.exp(-0.5 * (_ZX[i] * _ZX[i] - x * x))
        f1 = math.exp(-0.5 * (_ZX[i + 1] * _ZX[i + 1] - x * x))
        if f1 + uniform_at(key2, m) * (f0 - f1) < 1.0:
            return x
        w = bits_at(key2, m + _ONE)
        m += _TWO
        u = _signed_uniform(w)
        i = np.int64(w & _LOW7)
        if abs(u) < _ZRATIO[i]:
            return u * _ZX[i]


@jit(inline="always")
def normal_at(key, counter):
    """The standard normal number ``counter`` of the stream ``key`` (ziggurat, exact)."""
    w = bits_at(key, counter)
    u = _signed_uniform(w)
    i = np.int64(w & _LOW7)
    if abs(u) < _ZRATIO[i]:
        return u * _ZX[i]
    return _normal_slow(key, counter, u, i)


@jit(inline="always")
def normals3_at(key, counter):
    """The normals ``counter``, ``counter + 1``, ``counter + 2`` of the stream ``key`` (:func:`normal_at`),
    drawn in a loop: one call site of the ziggurat's slow path (:func:`_normal_slow`, not inlined) for the
    three. A compiled function zeroes at its entry the return slot of every call inside it, whichever
    branch runs: with fifteen sites, each call of the sensors' dispatcher began with 30 such stores
    (seven sites, 14 stores, with this; ``docs/performance.md``, round 10)."""
    n0 = 0.0
    n1 = 0.0
    n2 = 0.0
    for i in range(3):
        x = normal_at(key, counter + i)
        if i == 0:
            n0 = x
        elif i == 1:
            n1 = x
        else:
            n2 = x
    return n0, n1, n2


@jit
def uniforms(seed, stream, counter0, n):
    """``n`` uniforms of ``(seed, stream)`` from counter ``counter0`` (for tests and tables)."""
    key = stream_key(seed, stream)
    out = np.empty(n)
    for i in range(n):
        out[i] = uniform_at(key, counter0 + i)
    return out


@jit
def normals(seed, stream, counter0, n):
    """``n`` standard normals of ``(seed, stream)`` from counter ``counter0`` (for tests and tables)."""
    key = stream_key(seed, stream)
    out = np.empty(n)
    for i in range(n):
        out[i] = normal_at(key, counter0 + i)
    return out


__all__ = ["mix64", "stream_key", "bits_at", "uniform_at", "normal_at", "normals3_at", "uniforms", "normals"]
