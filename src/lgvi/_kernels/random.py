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
or 1, so ``log(u)`` is finite. Normals come by the Box-Muller transform (exact, not an
approximation): the pair of uniforms of counters ``2c`` and ``2c + 1`` gives two independent
standard normals ``sqrt(-2 log u1) (cos 2 pi u2, sin 2 pi u2)``, :func:`normal_pair` (counter ``c``).

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
_TWO_PI = 2.0 * math.pi
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


@jit(inline="always")
def normal_pair(key, counter):
    """Two independent standard normals, number ``counter`` of the stream ``key`` (Box-Muller on the
    uniforms ``2 counter`` and ``2 counter + 1``)."""
    c = np.uint64(counter) * _TWO
    u1 = uniform_at(key, c)
    u2 = uniform_at(key, c + _ONE)
    r = math.sqrt(-2.0 * math.log(u1))
    a = _TWO_PI * u2
    return r * math.cos(a), r * math.sin(a)


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
    """``2 n`` standard normals of ``(seed, stream)``: the pairs ``counter0 .. counter0 + n - 1``,
    in order (for tests and tables)."""
    key = stream_key(seed, stream)
    out = np.empty(2 * n)
    for i in range(n):
        a, b = normal_pair(key, counter0 + i)
        out[2 * i] = a
        out[2 * i + 1] = b
    return out


__all__ = ["mix64", "stream_key", "bits_at", "uniform_at", "normal_pair", "uniforms", "normals"]
