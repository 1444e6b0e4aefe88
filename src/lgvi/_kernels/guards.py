"""A user's compiled function as a value of one function type, guarded: the one factory.

The compiled loops take a user's ``numba.njit`` function (a :class:`lgvi.torques.Compiled` moment,
:mod:`.user_kernels`; a user's loop component, :mod:`.loop_kernels`) as a first-class function
value of one signature, not as a function they are specialised for: one loop, cached on disk,
serves every user's function, and a new function costs only its own compilation and that of the
small ``cfunc`` around it. :func:`guarded_function` makes that ``cfunc`` (in memory, once per
function, signature and process):

* the **signature** the loop calls (``MOMENT_SIGNATURE``, ``COMPONENT_SIGNATURE``);
* the **call adapter** ``result(value)``: what the user's function returns, as the signature's
  return value (the moment's three floats from a tuple or a (3,) array; the component's status);
* the **failure marking** ``failed(*args)``: what the loop sees when the user's function raises,
  given the call's arguments (a ``cfunc`` cannot raise into its caller): the moment marks its
  scratch ``R[0, 0]`` with NaN and returns NaN, so the step fails with ``USER_RAISED``; the
  component returns the loop's ``USER_RAISED`` status.

A function that does not fit the signature raises Numba's typing error from
:func:`guarded_function`. With ``NUMBA_DISABLE_JIT=1`` (the kernels as Python) the guard itself is
returned, the same Python code.
"""

from __future__ import annotations

from numba import cfunc, config

_GUARDS: dict = {}


def _guard(func, result, failed, nargs):
    """``guard(a0, .., a{n-1})``: ``result(func(..))``, or ``failed(..)`` when ``func`` raises. A
    ``cfunc`` takes no ``*args`` (and Numba cannot compile ``func(*args)`` inside a ``try``), so there
    is one closure for each arity the loops' signatures have (3, 4 and 5 arguments)."""
    if nargs == 3:
        def guard3(a0, a1, a2):
            try:
                return result(func(a0, a1, a2))
            except Exception:
                return failed(a0, a1, a2)
        return guard3
    if nargs == 4:
        def guard4(a0, a1, a2, a3):
            try:
                return result(func(a0, a1, a2, a3))
            except Exception:
                return failed(a0, a1, a2, a3)
        return guard4
    if nargs == 5:
        def guard5(a0, a1, a2, a3, a4):
            try:
                return result(func(a0, a1, a2, a3, a4))
            except Exception:
                return failed(a0, a1, a2, a3, a4)
        return guard5
    raise ValueError(f"a guarded function takes 3, 4 or 5 arguments (the loops' signatures), not {nargs}")


def guarded_function(func, signature, result, failed):
    """The user's ``func`` as a value of ``signature`` (a Numba ``cfunc``, compiled in memory once
    per ``func``, ``signature`` and process): ``result(func(*args))``, or ``failed(*args)`` when
    ``func`` raises (see the module notes). ``result`` and ``failed`` are kernels (``lgvi._jit.jit``)."""
    key = (func, signature, result, failed)
    value = _GUARDS.get(key)
    if value is None:
        guard = _guard(func, result, failed, len(signature.args))
        value = guard if config.DISABLE_JIT else cfunc(signature, error_model="numpy")(guard)
        _GUARDS[key] = value
    return value


def made(func) -> bool:
    """Whether a guard of ``func`` was made in this process (for any signature): a loop that takes it
    then costs no compilation."""
    return any(key[0] is func for key in _GUARDS)
