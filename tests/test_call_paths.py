"""The cheaper Python paths of a ``simulate`` call (issue 13): each gives what the path it
shortcuts gives, bit for bit, and the same errors."""

from __future__ import annotations

import gc
import warnings

import numpy as np
import pytest

import lgvi
from lgvi import integrator, splitting
from lgvi._kernels.solvers import initial_guess
from lgvi._validation import as_float_array, as_rotation
from lgvi.registry import COMPOSITIONS, SPLITTINGS
from lgvi.trajectory import summary_dict

GUESS = getattr(initial_guess, "py_func", initial_guess)


def _bodies(rng, n):
    for trial in range(n):
        m = np.sort(rng.uniform(0.1, 10.0, 3))
        m[2] = min(m[2], m[0] + m[1])
        Q = lgvi.so3.exp(rng.normal(size=3))
        J = Q @ np.diag(m) @ Q.T if trial % 2 else np.diag(m)
        yield lgvi.RigidBody(0.5 * (J + J.T) * 10.0 ** float(rng.integers(-6, 6)))


def test_cold_start_is_the_kernels_bit_for_bit():
    rng = np.random.default_rng(13)
    for body in _bodies(rng, 300):
        Pi = rng.normal(size=3) * 10.0 ** float(rng.integers(-8, 8))
        h = float(rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-4, 1))
        hs = np.array([0.3, -0.1, 0.8]) * h
        for code in (0, 1, 2):
            want = np.zeros(3)
            GUESS(code, body.J, h * Pi, want)
            assert integrator._solver_state(code, body, h, Pi)[0].tobytes() == want.tobytes()
            G = integrator._solver_states(code, body, hs, Pi)
            for i, hi in enumerate(hs):
                want = np.zeros(3)
                GUESS(code, body.J, hi * Pi, want)
                assert G[i, 0].tobytes() == want.tobytes()


def test_cold_start_of_an_extreme_body_is_the_kernels_with_its_warning():
    body = lgvi.RigidBody([1e-120, 1.5e-120, 2e-120])       # det(J) underflows to 0
    Pi = np.array([1.0, 2.0, 3.0])
    assert integrator._cold_start_factors(1, body.J) is None
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        G = integrator._solver_state(1, body, 0.1, Pi)
    want = np.zeros(3)
    with warnings.catch_warnings(record=True) as expected:
        warnings.simplefilter("always")
        GUESS(1, body.J, 0.1 * Pi, want)
    assert G[0].tobytes() == want.tobytes()
    assert [str(w.message) for w in got] == [str(w.message) for w in expected] != []


def test_principal_data_once_per_body_new_arrays_each_call():
    full = lgvi.RigidBody([[2.0, 0.1, 0.05], [0.1, 3.0, 0.2], [0.05, 0.2, 4.0]])
    for body in (full, lgvi.RigidBody([0.13, 0.28, 0.17]), lgvi.RigidBody([1.0, 1.0, 1.5])):
        want = splitting._principal_data(body)
        first = splitting.principal_data(body)
        first[0][:] = -1.0                         # a caller's copy: the cache is not touched
        first[1][:] = 7
        first[3][:] = 0.0
        again = splitting.principal_data(body)
        for a, b in zip(again, want):
            if isinstance(a, np.ndarray):
                assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
            else:
                assert a == b and type(a) is type(b)
    n = len(splitting._PRINCIPAL)
    splitting.principal_data(lgvi.RigidBody([1.0, 2.0, 2.5]))   # dies at once: forgotten
    gc.collect()
    assert len(splitting._PRINCIPAL) == n


def test_registry_arrays_computed_once_returned_as_new_arrays():
    for sp in SPLITTINGS.values():
        drift, weight, node = sp.arrays()
        node_want = np.array(sp.nodes, dtype=np.float64)
        assert drift.tobytes() == np.diff(np.concatenate([[0.0], node_want, [1.0]])).tobytes()
        assert weight.tobytes() == np.array(sp.weights, dtype=np.float64).tobytes()
        assert node.tobytes() == node_want.tobytes()
        drift[:] = weight[:] = node[:] = np.nan
        assert np.all(np.isfinite(np.concatenate(sp.arrays())))
    for comp in COMPOSITIONS.values():
        gam, cum = comp.arrays()
        want = np.concatenate([[0.0], np.cumsum(np.array(comp.coefficients))])
        want[-1] = 1.0
        assert gam.tobytes() == np.array(comp.coefficients).tobytes() and cum.tobytes() == want.tobytes()
        gam[:] = cum[:] = np.nan
        assert np.all(np.isfinite(np.concatenate(comp.arrays())))


def test_summary_dict_as_before():
    rng = np.random.default_rng(5)
    for counts in (np.zeros(64, np.int64), rng.integers(0, 9, 64) * (rng.random(64) < 0.2), [0, 3, 0, 1, 0],
                   np.array([7])):
        c = np.asarray(counts, dtype=np.int64)
        nz = np.flatnonzero(c)
        top = int(nz[-1]) if len(nz) else 0
        got = summary_dict(counts, 12, 1e-15)
        assert got == {"steps": int(c.sum()), "iterations_total": 12, "iterations_max": top,
                       "residual_max": 1e-15, "histogram": [int(x) for x in c]}
        assert all(type(x) is int for x in got["histogram"]) and type(got["steps"]) is int
        assert summary_dict(counts, 0, 0.0, iterations_max=99)["iterations_max"] == max(99, top)


def test_small_array_checks_keep_their_errors():
    big = as_float_array([1e308, 1e308, -0.0], "v", (3,))   # a finite vector whose sum overflows
    assert big.tolist() == [1e308, 1e308, -0.0]
    for bad, where in (([1.0, np.nan, 2.0], 1), ([np.inf, 1.0, 2.0], 0), ([1.0, 2.0, -np.inf], 2)):
        with pytest.raises(ValueError, match=rf"v must be finite \(no NaN or inf\), found .* at index \({where},\)"):
            as_float_array(bad, "v", (3,))
    with pytest.raises(ValueError, match=r"v must have shape \(3,\), got shape \(4,\)"):
        as_float_array([1.0, 2.0, 3.0, 4.0], "v", (3,))
    assert as_float_array(np.ones((5, 3)), "v", (None, 3)).shape == (5, 3)


def test_rotation_check_keeps_its_answers():
    R = lgvi.so3.exp(np.array([0.1, -0.2, 0.3]))
    assert as_rotation(R) is R                       # a rotation is used as given, not copied
    with pytest.raises(ValueError, match="R0 must be finite"):
        as_rotation(np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="determinant -1"):
        as_rotation(-np.eye(3))
    near = R + 1e-8                                  # off by ~3e-8: repaired, with a warning
    with pytest.warns(lgvi.AttitudeWarning):
        fixed = as_rotation(near)
    assert fixed is not near and np.allclose(fixed, R, atol=1e-7)
    for bad in (np.eye(3, dtype=np.float32), np.eye(3).astype(">f8"), np.asfortranarray(R)):
        assert np.array_equal(as_rotation(bad), bad)


def test_gravity_gradient_nadir_as_stacked():
    from lgvi.torques import GravityGradient

    gg = GravityGradient(3.986004418e14, 6878.137e3)
    rng = np.random.default_rng(2)
    for shape in ((), (11,), (4, 5)):
        t = rng.uniform(-1e5, 1e5, shape)
        R = lgvi.so3.exp(rng.normal(size=shape + (3,)))
        for tt in (t, 3.0):
            nt = gg.mean_motion * np.asarray(tt, dtype=np.float64)
            r_hat = np.stack(np.broadcast_arrays(np.cos(nt), np.sin(nt), np.zeros_like(nt)), axis=-1)
            want = -np.einsum("...ji,...j->...i", R, r_hat)
            got = gg.nadir(tt, R)
            assert got.shape == want.shape and got.tobytes() == want.tobytes()
