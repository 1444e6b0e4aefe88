"""A minimal compiled driver of sensor and estimator components on a given truth, for the
statistics tests and the benchmarks of issue 27 (not the loop: no dynamics, no other families).

At row ``k`` of ``truth`` (time ``t0 + k h``) the columns of ``truth`` are written into the bus at
``truth_off``, every component due at ``k`` (``k % period == 0``) runs in the order given (sensors,
codes 300-399, then estimators, 400-499, as the loop orders the families), and the bus entries at
``rec_off`` are copied into ``out[k]``, and the state entries ``S[rec_comp[j], rec_s[j]]`` into
``out_s[k, j]`` (e.g. an estimator's full covariance, which the bus does not carry).
"""

from __future__ import annotations

from .._jit import jit
from .estimation_components import estimator_dispatch
from .sensor_components import sensor_dispatch


@jit
def run_components(truth, truth_off, t0, h, codes, periods, P, S, W, bus, rec_off, out, rec_comp, rec_s, out_s):
    """Returns ``(k, status)``: the rows run and 0, or the row and the status of the first failure."""
    n = truth.shape[0]
    for k in range(n):
        t = t0 + k * h
        for j in range(truth_off.size):
            bus[truth_off[j]] = truth[k, j]
        for c in range(codes.size):
            if k % periods[c] == 0:
                code = codes[c]
                if code < 400:
                    st = sensor_dispatch(code, t, bus, P[c], S[c], W[c])
                else:
                    st = estimator_dispatch(code, t, bus, P[c], S[c], W[c])
                if st != 0:
                    record(k, bus, rec_off, out, S, rec_comp, rec_s, out_s)
                    return k, st
        record(k, bus, rec_off, out, S, rec_comp, rec_s, out_s)
    return n, 0


@jit(inline="always")
def record(k, bus, rec_off, out, S, rec_comp, rec_s, out_s):
    for j in range(rec_off.size):
        out[k, j] = bus[rec_off[j]]
    for j in range(rec_s.size):
        out_s[k, j] = S[rec_comp[j], rec_s[j]]
