"""The memo of Numba's function typing (``lgvi._jit._install_typing_memo``) changes no typing.

Numba types each call of a built-in function or operator by trying its templates; lgvi remembers the
answer for plain argument types (a fifth of a cold first call's compilation). Here one kernel of the
project and a function using integers, floats, literals, tuples, slices and arrays are compiled in
two fresh processes, with and without the memo: every variable's type, every call's signature and
the results must be the same; the memo must have served the project's kernel and not the user's
function (its scope is the compilation of lgvi's own kernels).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = str(Path(__file__).resolve().parents[1] / "src")

CHILD = r"""
import json
import re
import numba
import numpy as np
import lgvi
from lgvi import _jit
from lgvi._kernels import torque_kernels as tk
from numba.core.types.functions import BaseFunction

calls = [0]
memo_in_place = getattr(BaseFunction.get_call_type, "_lgvi_memo", False)


@numba.njit(cache=False)
def mixed(a, i, x):
    s = 0.0
    for k in range(a.shape[0]):
        s += a[k] * x + i // 2 - (k % 3) * 1.5
        if k == 2 and s > x:
            s -= 1
    t = (a[0], i, True)
    b = a[1:4] * 2.0
    b[0] = t[1] + (1 if t[2] else 0)
    return s, t[1] + 1, b, a[::2].sum(), abs(i - 9), max(x, 0.25), np.sqrt(x)


sizes = [len(_jit._TYPING_MEMO)]
moment = numba.njit(cache=False)(tk.moment_kernel.py_func)
codes = np.array([[tk.GRAVITY, 0], [tk.DAMPING, 3], [tk.ATTITUDE_PD, 6]], dtype=np.int64)
params = np.arange(1.0, 22.0) / 10.0
J = np.diag([0.13, 0.28, 0.17])
R = lgvi.so3.exp(np.array([0.3, -0.2, 0.5]))
out = np.zeros(3)
moment(codes, params, J, np.linalg.inv(J), 0.7, R, np.array([0.1, -0.4, 0.2]), out)
sizes.append(len(_jit._TYPING_MEMO))
res = mixed(np.arange(6.0), 7, 0.5)
sizes.append(len(_jit._TYPING_MEMO))


def name(t):
    return re.sub(r" at 0x[0-9a-f]+", "", str(t))       # a function's address differs between processes


def typing_of(disp):
    cres = disp.overloads[disp.signatures[0]]
    ann = cres.type_annotation
    return {"typemap": {k: name(v) for k, v in sorted(ann.typemap.items())},
            "calltypes": sorted(name(v) for v in ann.calltypes.values()),
            "signature": str(cres.signature)}


print(json.dumps({"memo": memo_in_place, "on": _jit.TYPING_MEMO, "sizes": sizes, "mixed": typing_of(mixed),
                  "moment": typing_of(moment), "out": out.tolist(),
                  "res": [float(res[0]), int(res[1]), res[2].tolist(), float(res[3]), int(res[4]), float(res[5]),
                          float(res[6])]}))
"""


def _child(memo: str) -> dict:
    env = dict(os.environ, LGVI_TYPING_MEMO=memo, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_the_typing_memo_changes_no_type_and_no_result():
    off, on = _child("0"), _child("1")
    assert (off["memo"], off["on"]) == (False, False)
    assert (on["memo"], on["on"]) == (True, True)
    for name in ("mixed", "moment"):
        assert on[name] == off[name], name
        assert len(on[name]["calltypes"]) > 20          # the functions do type many calls
    assert on["out"] == off["out"] and on["res"] == off["res"]
    # the memo serves lgvi's kernel (a function of an lgvi module) and not the user's own function
    assert off["sizes"] == [0, 0, 0]
    s0, s1, s2 = on["sizes"]
    assert s1 - s0 > 20 and s2 == s1


def test_the_memo_keeps_plain_calls_only():
    """In this process (the memo is on unless LGVI_TYPING_MEMO=0): outside a compilation of lgvi's
    kernels nothing is remembered; inside one a typing of ``int * float`` is remembered, with Numba's
    answer; a call with another kind of argument (a string), or one that Numba cannot type, is not
    (Numba raises as before)."""
    import operator

    import lgvi._jit as _jit
    from numba.core import types
    from numba.core.errors import TypingError
    from numba.core.registry import cpu_target
    from numba.core.types.functions import BaseFunction

    if not _jit.TYPING_MEMO:
        pytest.skip("LGVI_TYPING_MEMO=0 in this process")
    ctx = cpu_target.typing_context
    ctx.refresh()
    fnty = ctx.resolve_value_type(operator.mul)
    assert getattr(BaseFunction.get_call_type, "_lgvi_memo", False)
    before = len(_jit._TYPING_MEMO)
    sig = fnty.get_call_type(ctx, (types.int32, types.float32), {})     # outside lgvi's compilations
    assert sig is not None and len(_jit._TYPING_MEMO) == before
    _jit._COMPILING.lgvi = True          # as the compile listener sets it while an lgvi kernel compiles
    try:
        _inside_an_lgvi_compilation(fnty, ctx)
    finally:
        _jit._COMPILING.lgvi = False


def _inside_an_lgvi_compilation(fnty, ctx):
    import lgvi._jit as _jit
    from numba.core import types
    from numba.core.errors import TypingError

    sig = fnty.get_call_type(ctx, (types.int64, types.float64), {})
    assert sig.return_type == types.float64 and sig.args == (types.float64, types.float64)
    remembered = [k for k in _jit._TYPING_MEMO if k[0] == fnty and k[3] == (types.int64, types.float64)]
    assert len(remembered) == 1 and _jit._TYPING_MEMO[remembered[0]][0] is sig
    # a hit puts back the implementation Numba recorded for the signature's arguments
    impl = fnty._impl_keys[sig.args]
    fnty._impl_keys[sig.args] = "another template's"
    assert fnty.get_call_type(ctx, (types.int64, types.float64), {}) is sig
    assert fnty._impl_keys[sig.args] == impl
    before = len(_jit._TYPING_MEMO)
    for args in ((types.unicode_type, types.float64), (types.float64, types.none)):   # not plain; no match
        with pytest.raises(TypingError):
            fnty.get_call_type(ctx, args, {})
    assert len(_jit._TYPING_MEMO) == before
