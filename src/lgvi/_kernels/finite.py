"""The test a built-in component kind runs on the values it writes to the bus.

The loop stops a run when a component writes a value that is not finite (status 1,
:data:`lgvi.components.STATUS`). For a user's component and the flight software's laws the loop
tests the bus slots afterwards (:func:`.loop_kernels.writes_finite`: the slots' offsets and sizes
read from the wiring, a loop over each signal). A built-in kind that has its values in registers
tests them itself for less: ``x * 0`` is 0 for a finite ``x`` and NaN for NaN or an infinity, so a
sum of such terms is 0 exactly when every value is finite (no branch a value, and no false alarm: a
sum of finite values that overflows does not count). The sensor and estimator kinds do this
(``sensor_components``, ``estimation_components``, ``navigation_components``) and so do the
disturbance kinds (``environment_components``).
"""

from __future__ import annotations

from .._jit import jit


@jit(inline="always")
def written(x, y, z):
    """``0.0`` when ``x``, ``y`` and ``z`` are finite, NaN otherwise: a kind adds these up over the
    values it wrote and returns :func:`finite_status` of the sum."""
    return x * 0.0 + y * 0.0 + z * 0.0


@jit(inline="always")
def written_at(bus, o, n):
    """:func:`written` over the ``n`` values ``bus[o:o + n]`` (a matrix a kind wrote in place)."""
    z = 0.0
    for i in range(n):
        z += bus[o + i] * 0.0
    return z


@jit(inline="always")
def finite_status(z):
    """0 when ``z`` (a sum of :func:`written` terms) is 0, else 1: "wrote a value that is not finite"."""
    return 0 if z == 0.0 else 1
