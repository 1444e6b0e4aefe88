"""A user's compiled moment (``lgvi.torques.Compiled``) that is wrong is reported, never run blind
(issue 29, part 3): its Python form is tried at the first sample, so an index past ``params``
(which Numba would read from memory past the array), a division by zero or a wrong return shape
is a ``TorqueError`` naming the model before the run; an exception inside the compiled loop
stops the run at its step with the part computed kept."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import lgvi
from lgvi.torques import Compiled

BODY = lgvi.RigidBody([1.0, 2.0, 3.0])
W0 = [0.3, 0.5, 0.9]


@numba.njit
def reads_past(t, R, Pi, p):
    return (p[100000], 0.0, 0.0)


@numba.njit
def divides(t, R, Pi, p):
    return (1.0 / (t - p[0]), 0.0, 0.0)


@numba.njit
def two_late(t, R, Pi, p):
    if Pi[0] > 0.1:
        return np.zeros(2)              # passes the construction's trial at Pi = 0
    return np.zeros(3)


@numba.njit
def fails_late(t, R, Pi, p):
    # a spring about e3, and from t = p[0] on a division by zero (0 < p[0]: never at the first sample)
    c = 0.0 if t < p[0] else 1.0 / (t - t)
    return (-0.1 * R[2, 1] + c, 0.1 * R[2, 0], 0.0)


@numba.njit
def spring(t, R, Pi, p):
    return (-0.1 * R[2, 1], 0.1 * R[2, 0], 0.0)


def test_an_index_past_params_is_refused_before_the_run():
    model = Compiled(reads_past, params=[1.0])     # compiled, the trial at R = I reads garbage and passes
    for call in (lambda: lgvi.simulate(BODY, np.eye(3), omega0=W0, h=0.01, steps=10, torque=model),
                 lambda: lgvi.simulate_ensemble(BODY, np.stack([np.eye(3)] * 2), omega0=np.ones((2, 3)), h=0.01,
                                                steps=10, torque=model)):
        with pytest.raises(lgvi.TorqueError, match=r"Compiled\(reads_past, params shape \(1,\)\): moment reads_past"
                                                   r".*indexes past the end of an array \(params has size 1\).*"
                                                   r"IndexError.*first sample") as info:
            call()
        assert isinstance(info.value.__cause__, IndexError) and info.value.trajectory is None


def test_a_division_by_zero_or_a_wrong_shape_at_the_first_sample_is_refused():
    with pytest.raises(lgvi.TorqueError, match=r"divides.*(ZeroDivisionError|FloatingPointError: divide by zero).*at the first sample "
                                               r"\(t = 2\)"):
        lgvi.simulate(BODY, np.eye(3), omega0=W0, h=0.01, steps=10, t0=2.0, torque=Compiled(divides, params=[2.0]))
    # one row per body: body 1's row divides by zero at its first sample, and the message names it
    rows = np.array([[5.0], [2.0]])
    with pytest.raises(lgvi.TorqueError, match=r"\(body 1\).*first sample of body 1"):
        lgvi.simulate_ensemble(BODY, np.stack([np.eye(3)] * 2), omega0=np.ones((2, 3)), h=0.01, steps=10, t0=2.0,
                               torque=Compiled(divides, params=rows))
    with pytest.raises(lgvi.TorqueError, match=r"two_late must return 3 finite numbers, got array\(\[0., 0.\]\)"):
        lgvi.simulate(BODY, np.eye(3), omega0=W0, h=0.01, steps=10, torque=Compiled(two_late))


def _stops_at_its_step(func, pattern, **kw):
    """Run the model ``func`` failing from t = 1.5 (``params=[1.5]``): its TorqueError (matching
    ``pattern``), whose part is the clean run's (``params=[1e9]``) up to the failed step."""
    kw = dict(h=0.01, steps=300, save_every=3, **kw)
    with pytest.raises(lgvi.TorqueError, match=pattern) as info:
        lgvi.simulate(BODY, np.eye(3), omega0=W0, torque=Compiled(func, params=[1.5]), **kw)
    err = info.value
    part = err.trajectory
    clean = lgvi.simulate(BODY, np.eye(3), omega0=W0, torque=Compiled(func, params=[1e9]), **kw)
    n = err.step // 3 + 1
    assert err.time == pytest.approx(0.01 * err.step) and part.meta["partial"]
    assert len(part.t) == n and np.array_equal(part.R, clean.R[:n]) and np.array_equal(part.Pi, clean.Pi[:n])
    return err


def test_an_exception_in_the_compiled_loop_stops_at_its_step_and_keeps_the_part():
    # the step from t = 1.49 evaluates the moment at 1.5: it fails there, the part up to it is the clean run's
    err = _stops_at_its_step(fails_late, r"Compiled\(fails_late.*raised an exception inside the compiled loop "
                                         r"at step 149 \(t = 1.49\).*ZeroDivisionError")
    assert err.step == 149 and len(err.trajectory.t) == 50


# the first step with a kick at t >= 1.5: the compositions place their kicks differently in a step
# (axes-kl8 kicks at the step's end, so the step to t = 1.5 fails; aba84 not, so the step from it)
@pytest.mark.parametrize("order, composition, step", [(4, "aba84", 150), (8, "axes-kl8", 149)])
def test_an_exception_in_the_splittings_loop_stops_at_its_step_and_keeps_the_part(order, composition, step):
    """The splitting's loops (the exact flows', the axis splitting's) take the guarded function too:
    the step whose kick raised is undone, the part before it kept, and the error names the exception."""
    err = _stops_at_its_step(fails_late, r"Compiled\(fails_late.*raised an exception inside the compiled loop "
                                         rf"at step {step} .*ZeroDivisionError", scheme="splitting", order=order,
                             composition=composition)
    assert err.step == step


@numba.njit
def shrinks_late(t, R, Pi, p):
    return np.zeros(3 if t < p[0] else 2)       # 3 numbers at the trial and at the first sample


def test_a_moment_of_another_length_inside_the_compiled_loop_stops_at_its_step():
    """Never read past the user's array: a moment that is not 3 numbers fails its step as a raise does."""
    err = _stops_at_its_step(shrinks_late, r"Compiled\(shrinks_late.*inside the compiled loop at step 149 "
                                           r"\(t = 1.49\).*returns array\(\[0., 0.\]\), not 3 numbers")
    assert err.step == 149


def test_an_exception_in_one_body_of_an_ensemble_names_it_and_spares_the_others():
    rows = np.array([[1e9], [1.5], [1e9], [0.7]])       # bodies 1 and 3 fail, 3 first
    R0 = np.stack([np.eye(3)] * 4)
    w0 = np.tile(W0, (4, 1))
    with pytest.raises(lgvi.TorqueError, match="body 3") as info:
        lgvi.simulate_ensemble(BODY, R0, omega0=w0, h=0.01, steps=200, threads=1,
                               torque=Compiled(fails_late, params=rows))
    err = info.value
    assert err.body == 3 and err.step == 69
    part = err.trajectory
    clean = lgvi.simulate(BODY, np.eye(3), omega0=W0, h=0.01, steps=200, torque=Compiled(fails_late, params=[1e9]))
    # body 2 follows body 1 in the same thread: its part is the clean run's
    assert part.R.shape[1] == err.step + 1 and np.array_equal(part.R[2], clean.R[:err.step + 1])


@numba.njit
def inverse(t, R, Pi, p):
    return (1.0 / p[0], 0.0, 0.0)


def test_a_failing_row_past_the_tried_ones_stops_its_own_body_in_the_compiled_loop():
    """A Compiled model is tried in its Python form on at most 64 rows (the first and last 32 of more:
    ``torques.tried_rows``); a row between them whose values fail (a zero divisor in row 50 of 100) is
    not tried before the run, and the compiled loop stops that body at its first step, naming it."""
    assert list(lgvi.torques.tried_rows(5)) == [0, 1, 2, 3, 4]
    assert lgvi.torques.tried_rows(100) == [*range(32), *range(68, 100)]
    rows = np.ones((100, 1))
    rows[50, 0] = 0.0
    model = Compiled(inverse, params=rows)                     # row 50 is not tried here
    with pytest.raises(lgvi.TorqueError, match="body 50") as info:
        lgvi.simulate_ensemble(BODY, np.stack([np.eye(3)] * 100), omega0=np.tile(W0, (100, 1)), h=0.01, steps=10,
                               threads=1, torque=model)
    assert info.value.body == 50 and info.value.step == 0
    with pytest.raises(TypeError, match="ZeroDivisionError"):  # among the tried rows it is refused at once
        Compiled(inverse, params=rows[30:])


@numba.njit
def refuses_nan(t, R, Pi, p):
    if R[0, 0] != R[0, 0]:
        raise ValueError("a NaN attitude")
    return (-0.1 * R[2, 1], 0.1 * R[2, 0], 0.0)


def test_a_raise_at_a_sample_whose_own_attitude_is_nan_reaches_python():
    """The series' compiled loop marks a raise with a NaN in its scratch attitude; a sample whose own
    attitude holds that NaN must not hide the raise (it is evaluated again in Python, which raises)."""
    model = Compiled(refuses_nan)
    model.series_compile = 16           # the compiled series for these 40 samples
    R = np.tile(np.eye(3), (40, 1, 1))
    clean = model.moment(np.zeros(40), R, np.zeros((40, 3)), BODY)
    np.testing.assert_array_equal(clean, np.zeros((40, 3)))
    R[7, 0, 0] = np.nan
    with pytest.raises(ValueError, match="a NaN attitude"):
        model.moment(np.zeros(40), R, np.zeros((40, 3)), BODY)
