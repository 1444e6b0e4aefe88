"""The compiled attitude control loop: the gyrostat step with components on a bus (``docs/loop.md``).

At step ``k`` (time ``t = t0 + k h``) the loop

1. writes the truth on the bus (``io``: the offsets of ``R``, ``omega``, ``wheel_speed``,
   ``wheel_momentum``; ``-1`` for a signal the run does not carry);
2. sets ``tau_dist_B`` to the sum of the held torques of the disturbances not due at ``k``
   (``io[IO_NDIST]`` of them, indices after it), then runs every component due at ``k``
   (``k % spc[c] == 0``, kept as each component's next due step ``nxt[c]``: :func:`due_start`; the
   loop visits the components only at the earliest of these, :func:`earliest_due`) and
   active in the current mode (bit ``mode`` of ``mask[c]``), in the order given (the Python side sorts them by family):
   ``<family>_dispatch(code, t, bus, p, s, w)`` on the component's slices of ``P`` (parameters),
   ``S`` (state) and ``W`` (bus offsets of the signals it reads, then writes); a user's component
   (code 0) is the function ``user``, a first-class function value (:func:`user_component`). A
   nonzero status, or a written value that is not finite, stops the loop: ``fail = [component,
   status]``, the state is that of the step's start;
3. takes the held wheel commands ``wheel_command`` and the body torque ``tau_dist_B +
   tau_control_B + tau_command_B`` (a Python controller's torque) and makes the gyrostat step (:func:`.gyrostat_kernels.gyro_advance`), with the
   gravity gradient along the tabulated orbit in the variational form when ``gg`` (``ggp`` the
   member's row: its own inertia);
4. records: the solver's and the wheels' records as the gyrostat does, and the bus entries
   ``sig_idx`` at each record entry's first step into ``sig_out``; a signal whose writer runs off
   the record grid (faster than it, or at a period that is not a multiple of it) has a row
   ``(period, bus offset, size, column, slots, next, slot, end)`` of ``sig_fast`` (``next`` and
   ``slot`` the kernel's counters, kept per group of rows of one period, ``end`` the group's end):
   at each of its writer's steps
   the loop writes it into slot ``j`` of its columns of the entry's row (the ``j``-th writer step
   of the entry, NaN for a slot the entry has no step for), so ``sig_out`` holds every value it
   wrote (:func:`record_fast`); the gravity gradient's moment at the step's start (``gg``) is on the bus at
   ``io``'s slot after the lookahead count (:func:`gravity_gradient_slot`), recorded like the rest.

A family absent from a run has no component in the list and costs nothing; adding a family is
one import and one ``elif`` in :func:`run_one` (and in :func:`run_early` when its kinds run in the
lookahead).

A user's component reaches the loop as a value of one function type, :data:`COMPONENT_SIGNATURE`
(a Numba ``cfunc`` of the user's function, guarded, made once per function by
:func:`user_component`; :func:`no_user_component` when the run has none), not as a function the
loop is specialised for: one compiled loop, cached on disk, serves every run, with or without a
user's component, and a user's function costs only its own compilation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import cfunc, config, types

from .._jit import CACHE, jit
from .codes import NOT_FINITE, OK
from .environment_components import disturbance_dispatch, environment_dispatch
from .estimation_components import estimator_dispatch
from .fsw_components import actuator_dispatch, control_dispatch, guidance_dispatch, mode_dispatch, orbit_field_dispatch
from .guards import guarded_function
from .gyrostat_kernels import after_step, body_rate, gyro_advance, wheel_torque
from .orbit_table_kernels import orbit_gravity_gradient_moment
from .sensor_components import sensor_dispatch

#: Unsigned 1 and 2 (offsets added to an unsigned index stay unsigned: :func:`record_fast`).
_U1 = np.uint64(1)
_U2 = np.uint64(2)
#: The status the loop returns when a component stopped it (``fail`` says which and why).
COMPONENT_FAILED = 100
#: ``io`` entries: bus offsets of the loop's own signals (``-1``: absent).
IO_R, IO_OMEGA, IO_SPEED, IO_RHO, IO_CMD, IO_DIST, IO_CTRL, IO_MODE, IO_PY = 0, 1, 2, 3, 4, 5, 6, 7, 8
#: ``io[IO_NDIST]``: the number of disturbance components that add into ``tau_dist_B``; their
#: component indices follow it (each writes its own torque first, ``tau_<name>_B``).
IO_NDIST = 9
#: The status of a user's component that raised an exception (:func:`user_component`).
USER_RAISED = 4
#: The status the loop gets from the user slot of a run with no user's component (never called:
#: no component has code 0 then).
NO_USER = 3
#: ``step(t, bus, p, s, w) -> int`` of a component (``docs/components.md``), as the loop calls a
#: user's: the slices of the loop's contiguous arrays.
COMPONENT_SIGNATURE = types.int64(types.float64, types.float64[::1], types.float64[::1], types.float64[::1],
                                  types.int64[::1])
_NO_USER: list = []


@jit(inline="always")
def component_result(status):
    """The call adapter of :func:`user_component`: the status the user's function returns."""
    return status


@jit(inline="always")
def component_failed(t, bus, p, s, w):
    """The failure marking of :func:`user_component`: the status :data:`USER_RAISED`."""
    return USER_RAISED


def user_component(step):
    """The user's ``numba.njit`` function ``step(t, bus, p, s, w) -> int`` as the loop's ``user``
    argument: a ``cfunc`` of :data:`COMPONENT_SIGNATURE` (compiled in memory, once per function and
    process, by :func:`.guards.guarded_function`) that calls it and returns :data:`USER_RAISED` when
    it raises (a ``cfunc`` cannot raise into its caller). A function that does not fit the signature
    raises Numba's typing error here. With ``NUMBA_DISABLE_JIT=1`` (the kernels as Python) the guard
    itself."""
    return guarded_function(step, COMPONENT_SIGNATURE, component_result, component_failed)


def _no_user(t, bus, p, s, w):
    return NO_USER


def no_user_component():
    """The loop's ``user`` argument for a run without a user's component (cached on disk)."""
    if not _NO_USER:
        _NO_USER.append(_no_user if config.DISABLE_JIT else
                        cfunc(COMPONENT_SIGNATURE, cache=CACHE, error_model="numpy")(_no_user))
    return _NO_USER[0]


@jit(inline="always")
def sum_held_disturbances(k, bus, io, nxt, nr, W, wo):
    """Zero ``tau_dist_B`` and add the held torques of the disturbances not due at step ``k``
    (``nxt[c] != k``, :func:`due_start`; those due add theirs when they run), so it is the sum of
    every disturbance's latest torque."""
    od = io[IO_DIST]
    if od < 0 or io.shape[0] <= IO_NDIST:
        return
    bus[od] = 0.0
    bus[od + 1] = 0.0
    bus[od + 2] = 0.0
    for j in range(io[IO_NDIST]):
        c = io[IO_NDIST + 1 + j]
        if nxt[c] != k:
            o = W[wo[c] + nr[c]]
            bus[od] += bus[o]
            bus[od + 1] += bus[o + 1]
            bus[od + 2] += bus[o + 2]


@jit(inline="always")
def due_start(k0, spc, nxt):
    """Before step ``k0``: each component's next due step ``nxt[c]``, the first multiple of its period
    ``spc[c]`` from ``k0`` on. A component is due at step ``k`` when ``nxt[c] == k``
    (``k % spc[c] == 0``: one integer division a component per chunk, not per step);
    :func:`due_advance` moves the counters on. Returns the earliest of them (-1 with no component):
    the loop visits the components only at that step (:func:`earliest_due`)."""
    for c in range(spc.shape[0]):
        p = spc[c]
        nxt[c] = ((k0 + p - 1) // p) * p
    return earliest_due(nxt)


@jit(inline="always")
def earliest_due(nxt):
    """The earliest next due step of the components (-1 with none): at every step before it no
    component is due, so the loop skips :func:`run_components` and :func:`due_advance` there (a
    component at 1 Hz with h = 0.1 s is visited at one step in ten, not at each)."""
    m = -1
    for c in range(nxt.shape[0]):
        if m < 0 or nxt[c] < m:
            m = nxt[c]
    return m


@jit(inline="always")
def due_advance(k, spc, nxt):
    """After step ``k`` (before the step's end runs step ``k + 1``'s lookahead), when a component was
    due at ``k``: the counters of those due move on by their period. Returns the new earliest."""
    for c in range(spc.shape[0]):
        if nxt[c] == k:
            nxt[c] = k + spc[c]
    return earliest_due(nxt)


@jit(inline="always")
def lookahead_count(io):
    """``L``: the leading components that are functions of the time, the attitude and the orbit only
    (built-in environment and disturbance kinds, active in every mode); the loop runs them at the
    step's end to force the step symmetrically (0: every disturbance held over the step). Stored in
    ``io`` after the disturbances' indices."""
    if io.shape[0] <= IO_NDIST:
        return 0
    i = IO_NDIST + 1 + io[IO_NDIST]
    return io[i] if io.shape[0] > i else 0


@jit(inline="always")
def gravity_gradient_slot(io):
    """The bus offset of ``tau_gravity_gradient_B`` (the variational moment at the step's start),
    stored in ``io`` after the lookahead count; -1 when the run does not record it."""
    if io.shape[0] <= IO_NDIST:
        return -1
    i = IO_NDIST + 2 + io[IO_NDIST]
    return io[i] if io.shape[0] > i else -1


@jit(inline="always")
def record_fast_start(k0, c_rec, sig_fast):
    """Before step ``k0`` (its place ``c_rec`` in its record entry): each row's next writer step
    ``sig_fast[f, 5]`` (the first multiple of its period ``p`` from ``k0`` on) and its slot in the
    entry ``sig_fast[f, 6]`` (the writer steps of the entry before it). Rows of one period have the
    same counters (they depend on ``p``, ``k0`` and ``c_rec`` only): :func:`record_fast` keeps them
    on the period group's first row."""
    ke = k0 - c_rec
    for f in range(sig_fast.shape[0]):
        p = sig_fast[f, 0]
        nxt = ((k0 + p - 1) // p) * p
        sig_fast[f, 5] = nxt
        sig_fast[f, 6] = (nxt - ((ke + p - 1) // p) * p) // p


@jit(inline="always")
def record_fast(k, c_rec, e, per, bus, sig_fast, sig_out):
    """Step 4's records off the grid at step ``k`` (``c_rec`` its place in entry ``e`` of ``per``
    steps). The rows ``(p, offset, size, column, slots, next, slot, end)`` of ``sig_fast`` come
    in groups of one period ``p`` (rows ``f .. end - 1``, ``end`` in each row of the group; the
    Python side sorts them, :func:`lgvi.systems.spacecraft._fast_layout`), whose counters are the
    group's first row's: when ``k == next``, each row of the group goes into slot ``slot`` of its
    columns, then ``next += p``, ``slot += 1``, once for the group. At the entry's first step the
    slots restart at 0, and a row whose period does not divide ``per`` has them set to NaN first (a
    slot with no writer step in the entry stays NaN). No division a step: the counters start at
    :func:`record_fast_start`. Returns the earliest ``next`` of the groups, so the loop calls it
    again only at that step or at an entry's first step.

    A group not due costs two loads and a comparison; a due row's ``size`` values (at least one: a
    signal has a size) are copied from the bus in one contiguous run into the entry's row
    ``sig_out[e]`` (a 1-D view)."""
    nf = sig_fast.shape[0]
    if c_rec == 0:
        for f in range(nf):
            sig_fast[f, 6] = 0
            if per % sig_fast[f, 0] != 0:
                for i in range(sig_fast[f, 2] * sig_fast[f, 4]):
                    sig_out[e, sig_fast[f, 3] + i] = math.nan
    out = sig_out[e]
    m = -1
    f = 0
    while f < nf:
        end = sig_fast[f, 7]
        nx = sig_fast[f, 5]
        if k == nx:
            slot = sig_fast[f, 6]
            for r in range(f, end):
                size = sig_fast[r, 2]
                # the offsets as unsigned integers (they are never negative): an index of a signed type
                # is wrapped around (a negative one counts from the end), three more instructions at each
                # load and each store
                d = np.uint64(sig_fast[r, 3] + slot * size)
                o = np.uint64(sig_fast[r, 1])
                # the first three values by branches, the rest (a quaternion's fourth, a matrix) by a
                # loop: a signal has 1 to 9 values, and a loop over so few, vectorised with its checks,
                # cost a fifth more (docs/performance.md, round 9)
                out[d] = bus[o]
                if size > 1:
                    out[d + _U1] = bus[o + _U1]
                    if size > 2:
                        out[d + _U2] = bus[o + _U2]
                        for i in range(3, size):
                            u = np.uint64(i)
                            out[d + u] = bus[o + u]
            nx = k + sig_fast[f, 0]
            sig_fast[f, 5] = nx
            sig_fast[f, 6] = slot + 1
        if m < 0 or nx < m:
            m = nx
        f = end
    return m


@jit(inline="always")
def fast_next(sig_fast):
    """The earliest next writer step ``sig_fast[f, 5]`` of the period groups (``-1`` with no row)."""
    m = -1
    f = 0
    while f < sig_fast.shape[0]:
        if m < 0 or sig_fast[f, 5] < m:
            m = sig_fast[f, 5]
        f = sig_fast[f, 7]
    return m


@jit(_nrt=False)
def environment_call(code, t, bus, p, s, w):
    """An environment kind (family 1: the sun, the shadow, the atmospheres, then the orbit and the
    field from code 190): a small function of its own, compiled once, which :func:`run_one` calls.

    Not part of :func:`dispatch`: a large function pays, at each call, the zeroing at its entry of
    the return slots of every call inside it (Numba stores them there whichever branch runs: 20 in
    ``dispatch`` when it held these kinds), where a function of one family has a short entry
    (``docs/performance.md``, round 9)."""
    if code < 190:
        return environment_dispatch(code, t, bus, p, s, w)
    return orbit_field_dispatch(code, t, bus, p, s, w)


@jit(_nrt=False)
def disturbance_call(code, t, bus, p, s, w):
    """A disturbance kind (family 2: facet drag, facet SRP, residual dipole), a small function of its
    own as :func:`environment_call`. Each kind tests every value it writes (its torque, the force,
    ``tau_dist_B`` after its addition) and returns 1 when one is not finite, so :func:`run_one` needs
    no :func:`writes_finite` after it."""
    return disturbance_dispatch(code, t, bus, p, s, w)


@jit(_nrt=False)
def dispatch(user, code, t, bus, p, s, w):
    """A user's component (code 0) or a mode rule (family 6, ``code // 100``); status 3 for any
    other code (:func:`run_one` calls every other family's function itself).

    A function of its own (compiled once, cached), not inlined: the loop inlines :func:`run_one`
    (the components due) and :func:`run_early` (the step's end). It holds only these two families: a
    function pays, at each call, the zeroing at its entry of the return slots of every call inside
    it, whichever branch runs (``docs/performance.md``, round 9). Compiled without Numba's reference
    counting, as the loop is, so the call passes its four arrays as they are (no reference counts:
    the 70 ns a call that ``environment_dispatch``'s inlining avoided)."""
    if code == 0:
        return user(t, bus, p, s, w)
    if code // 100 == 6:
        return mode_dispatch(code, t, bus, p, s, w)
    return 3


@jit(inline="always")
def writes_finite(bus, W, WS, a, b):
    """Whether the signals ``W[a:b]`` (sizes ``WS``) hold finite values: the sum of ``x * 0`` over
    them is 0 when every ``x`` is finite and NaN when one is NaN or infinite (no branch a value,
    no false alarm: a sum of finite values that overflows does not count). Two sums, of the even
    and the odd values of each signal, so the additions do not wait for each other."""
    z0 = 0.0
    z1 = 0.0
    for j in range(a, b):
        o = W[j]
        if o < 0:
            continue
        n = WS[j]
        i = 0
        while i + 1 < n:
            z0 += bus[o + i] * 0.0
            z1 += bus[o + i + 1] * 0.0
            i += 2
        if i < n:
            z0 += bus[o + i] * 0.0
    return z0 + z1 == 0.0


@jit(inline="always")
def tests_own_writes(fam):
    """Whether the kinds of family ``fam`` test their own writes (:mod:`.finite`: the disturbances,
    2, the sensors, 3, the estimators, 4): the loop runs :func:`writes_finite` after the others."""
    return 2 <= fam <= 4


@jit(inline="always")
def clear_writes(bus, W, WS, a, b):
    for j in range(a, b):
        o = W[j]
        if o < 0:
            continue
        for i in range(WS[j]):
            bus[o + i] = 0.0


@jit(inline="always")
def component_rows(c, P, po, S, so, W, wo):
    """Component ``c``'s parameter row, state and bus offsets: its slices of ``P``, ``S``, ``W``."""
    return P[po[c]:po[c + 1]], S[so[c]:so[c + 1]], W[wo[c]:wo[c + 1]]


@jit(inline="always")
def marked(c, st, fail):
    """``st``, with ``fail = [c, st]`` set when it is not 0 (the component that stopped the loop)."""
    if st != OK:
        fail[0] = c
        fail[1] = st
    return st


@jit(inline="always")
def run_one(user, c, t, bus, codes, nr, P, po, S, so, W, wo, WS, fail):
    """Component ``c`` at ``t``; its status (1 when it wrote a value that is not finite), and
    ``fail`` set when it is not 0."""
    code = codes[c]
    p, s, w = component_rows(c, P, po, S, so, W, wo)
    # every family but the user's and the mode rules' straight to its function (one call, not two: the
    # arguments, four arrays, are passed once)
    fam = code // 100
    if fam == 2:
        st = disturbance_call(code, t, bus, p, s, w)
    elif fam == 1:
        st = environment_call(code, t, bus, p, s, w)
    elif fam == 3:
        st = sensor_dispatch(code, t, bus, p, s, w)
    elif fam == 4:
        st = estimator_dispatch(code, t, bus, p, s, w)
    elif fam == 5:
        st = guidance_dispatch(code, t, bus, p, s, w)
    elif fam == 7:
        st = control_dispatch(code, t, bus, p, s, w)
    elif fam == 8:
        st = actuator_dispatch(code, t, bus, p, s, w)
    else:
        st = dispatch(user, code, t, bus, p, s, w)
    # the disturbance (2), sensor (3) and estimator (4) kinds test their own writes (:mod:`.finite`); the
    # others' writes are tested here
    if st == OK and not tests_own_writes(fam) and not writes_finite(bus, W, WS, wo[c] + nr[c], wo[c + 1]):
        st = 1
    return marked(c, st, fail)


@jit(_nrt=False)
def run_one_call(user, c, t, bus, codes, nr, P, po, S, so, W, wo, WS, fail):
    """:func:`run_one` as a function of its own, for the rare road of a mode switch (the new mode's
    components before the switching one, :func:`run_components`): one copy of :func:`run_one`
    fewer inlined in the loop, which shortens the loop's cold compilation."""
    return run_one(user, c, t, bus, codes, nr, P, po, S, so, W, wo, WS, fail)


@jit(inline="always")
def run_early(user, c, t, bus, codes, nr, P, po, S, so, W, wo, WS, fail):
    """:func:`run_one` for component ``c`` of the lookahead (:func:`run_lookahead`: built-in
    environment and disturbance kinds), with the disturbance kinds inlined: this is the one place
    of the loop where they are (the lookahead runs every disturbance at each step's end), so the
    torques that run every step pay no call, no arguments on the stack and no slice passed whole;
    everywhere else they go through :func:`disturbance_call`. Each disturbance kind tests its own
    writes; the others are tested by :func:`writes_finite` as in :func:`run_one`."""
    code = codes[c]
    p, s, w = component_rows(c, P, po, S, so, W, wo)
    fam = code // 100
    if fam == 2:
        st = disturbance_dispatch(code, t, bus, p, s, w)
    else:
        if fam == 1:
            st = environment_call(code, t, bus, p, s, w)
        else:
            st = dispatch(user, code, t, bus, p, s, w)
        if st == OK and not writes_finite(bus, W, WS, wo[c] + nr[c], wo[c + 1]):
            st = 1
    return marked(c, st, fail)


@jit(inline="always")
def run_components(user, t, k, bus, io, codes, nxt, mask, nr, P, po, S, so, W, wo, WS, fail, first):
    """Step 2 of the loop at step ``k`` from component ``first`` on (those before it ran at the end
    of the previous step: :func:`run_lookahead`); returns the status. Component ``c`` is due when
    ``nxt[c] == k`` (:func:`due_start`).

    When a mode component changes the mode, the components active in the old mode and not in the
    new one have their outputs cleared (nothing they wrote stays held), and those of the new mode
    that come before it in the order (guidance) and are due run at once, so that the new mode's
    control reads its own reference at this very step."""
    mode = 0
    if io[IO_MODE] >= 0:
        mode = int(bus[io[IO_MODE]])
    for c in range(first, codes.shape[0]):
        if nxt[c] != k or ((mask[c] >> mode) & 1) == 0:
            continue
        if run_one(user, c, t, bus, codes, nr, P, po, S, so, W, wo, WS, fail) != OK:
            return COMPONENT_FAILED
        if io[IO_MODE] >= 0:
            new = int(bus[io[IO_MODE]])
            if new != mode:
                for d in range(codes.shape[0]):
                    if ((mask[d] >> mode) & 1) == 1 and ((mask[d] >> new) & 1) == 0:
                        clear_writes(bus, W, WS, wo[d] + nr[d], wo[d + 1])
                for d in range(c):
                    if nxt[d] == k and ((mask[d] >> mode) & 1) == 0 and ((mask[d] >> new) & 1) == 1:
                        if run_one_call(user, d, t, bus, codes, nr, P, po, S, so, W, wo, WS, fail) != OK:
                            return COMPONENT_FAILED
                mode = new
    return OK


@jit(inline="always")
def run_lookahead(user, t, k, L, R, bus, io, codes, nxt, mask, nr, P, po, S, so, W, wo, WS, fail):
    """The components ``0 .. L - 1`` due at step ``k`` (time ``t``) on the attitude ``R`` written on
    the bus, after ``tau_dist_B`` is set to the held disturbances' sum (:func:`sum_held_disturbances`):
    the environment and the disturbance torque at the end of step ``k - 1``, which step ``k`` then
    starts from. Returns the status (``fail`` set as :func:`run_one` does)."""
    oR = io[IO_R]
    if oR >= 0:
        for a in range(3):
            for b in range(3):
                bus[oR + 3 * a + b] = R[a, b]
    sum_held_disturbances(k, bus, io, nxt, nr, W, wo)
    for c in range(L):
        if nxt[c] == k:
            if run_early(user, c, t, bus, codes, nr, P, po, S, so, W, wo, WS, fail) != OK:
                return COMPONENT_FAILED
    return OK


@jit(_nrt=False)
def advance_free(ggp, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now, ta0, ta1, ta2, m0, m1, m2, tol, max_iter):
    """The gyrostat step without the gravity gradient (a function of its own: compiled once)."""
    return gyro_advance(None, ggp, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now, ta0, ta1, ta2, m0, m1, m2, tol,
                        max_iter)


@jit(_nrt=False)
def advance_gg(ggp, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now, ta0, ta1, ta2, m0, m1, m2, tol, max_iter):
    """The gyrostat step with the gravity gradient along the tabulated orbit ``ggp`` (variational)."""
    return gyro_advance(orbit_gravity_gradient_moment, ggp, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now, ta0,
                        ta1, ta2, m0, m1, m2, tol, max_iter)


def loop_steps(user, gg, ggp, Rs, JdB, JBi, h, gam, t0, R, Pi, rho, G, axes, wp, cmd, u_now, bus, io, codes, spc,
               mask, nr, P, po, S, so, W, wo, WS, sig_idx, sig_fast, k0, n, kb, tol, max_iter, save_every, per, R_out, Pi_out,
               rho_out, u_out, it_out, res_out, sig_out, counts, fail, nxt):
    """Steps ``k0 .. k0 + n - 1`` of the loop (see the module's text) in place on ``R``, ``Pi``,
    ``rho``, ``G``, ``bus``, ``S``; buffers as :func:`.gyrostat_kernels.gyro_steps` plus ``sig_out``
    (entries, len(sig_idx) + the columns of ``sig_fast``) and ``nxt`` (one int64 a component: the
    next due steps, set here from ``k0``, :func:`due_start`). Returns ``(status, k, iterations_total, residual_max, its, residual)``."""
    N = rho.shape[0]
    it_sum = 0
    rmax = 0.0
    its = 0
    rn = 0.0
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    if gg:
        m0, m1, m2 = orbit_gravity_gradient_moment(t0 + k0 * h, R, Pi, ggp)
        if not (math.isfinite(m0) and math.isfinite(m1) and math.isfinite(m2)):
            fail[0] = -1
            fail[1] = 3
            return COMPONENT_FAILED, k0, 0, 0.0, 0, 0.0
    e = (k0 - kb) // per
    c_rec = (k0 - kb) % per
    c_save = (k0 + 1 - kb) % save_every
    j = (k0 - kb) // save_every - 1
    oR = io[IO_R]
    ow = io[IO_OMEGA]
    osp = io[IO_SPEED]
    orh = io[IO_RHO]
    ocmd = io[IO_CMD]
    odist = io[IO_DIST]
    octl = io[IO_CTRL]
    opy = io[IO_PY]
    nsig = sig_idx.shape[0]
    L = lookahead_count(io)
    ogg = gravity_gradient_slot(io)
    nfast = sig_fast.shape[0]
    kfast = -1
    if nfast > 0:
        record_fast_start(k0, c_rec, sig_fast)
        kfast = fast_next(sig_fast)
    kdue = due_start(k0, spc, nxt)
    hh = 0.5 * h
    for k in range(k0, k0 + n):
        t = t0 + k * h
        w0, w1, w2 = body_rate(JBi, Pi, axes, rho)
        # 1. the truth (R already on the bus when the previous step's end ran the lookahead)
        if oR >= 0 and (L == 0 or k == k0):
            for a in range(3):
                for b in range(3):
                    bus[oR + 3 * a + b] = R[a, b]
        if ow >= 0:
            bus[ow] = w0
            bus[ow + 1] = w1
            bus[ow + 2] = w2
        for i in range(N):
            if orh >= 0:
                bus[orh + i] = rho[i]
            if osp >= 0:
                bus[osp + i] = rho[i] / wp[i, 0] - (axes[i, 0] * w0 + axes[i, 1] * w1 + axes[i, 2] * w2)
        if ogg >= 0:
            bus[ogg] = m0
            bus[ogg + 1] = m1
            bus[ogg + 2] = m2
        # 2. the components due (the disturbances' sum first set to the held ones); the first L ran
        # at the end of the previous step, except at a chunk's first step (and all run here when L = 0)
        first = L
        if k == k0 or L == 0:
            sum_held_disturbances(k, bus, io, nxt, nr, W, wo)
            first = 0
        if k == kdue:                   # a component is due at k (none is before kdue)
            st = run_components(user, t, k, bus, io, codes, nxt, mask, nr, P, po, S, so, W, wo, WS, fail, first)
            if st != OK:
                return st, k, it_sum, rmax, 0, 0.0
        # 3. the step, with what the bus holds
        if ocmd >= 0:
            for i in range(N):
                cmd[i] = bus[ocmd + i]
        for i in range(N):
            wheel_torque(i, cmd, rho, axes, wp, w0, w1, w2, u_now, N)
        ta0 = 0.0
        ta1 = 0.0
        ta2 = 0.0
        d0 = 0.0
        d1 = 0.0
        d2 = 0.0
        if odist >= 0:
            d0 = bus[odist]
            d1 = bus[odist + 1]
            d2 = bus[odist + 2]
            ta0 += d0
            ta1 += d1
            ta2 += d2
        if octl >= 0:
            ta0 += bus[octl]
            ta1 += bus[octl + 1]
            ta2 += bus[octl + 2]
        if opy >= 0:
            ta0 += bus[opy]
            ta1 += bus[opy + 1]
            ta2 += bus[opy + 2]
        if gg:
            st, its, rn, it_add, m0, m1, m2 = advance_gg(ggp, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now, ta0,
                                                        ta1, ta2, m0, m1, m2, tol, max_iter)
        else:
            st, its, rn, it_add, m0, m1, m2 = advance_free(ggp, Rs, JdB, h, gam, t0, k, R, Pi, rho, G, axes, u_now,
                                                          ta0, ta1, ta2, m0, m1, m2, tol, max_iter)
        it_sum += it_add
        if st != OK:
            if st == NOT_FINITE and gg and not (math.isfinite(m0) and math.isfinite(m1) and math.isfinite(m2)):
                fail[0] = -1
                fail[1] = 3
                return COMPONENT_FAILED, k, it_sum, rmax, its, rn
            return st, k, it_sum, rmax, its, rn
        # 4. records: the bus at the entry's first step, then the gyrostat's
        if c_rec == 0:
            for q in range(nsig):
                sig_out[e, q] = bus[sig_idx[q]]
        if nfast > 0 and (k == kfast or c_rec == 0):
            kfast = record_fast(k, c_rec, e, per, bus, sig_fast, sig_out)
        if k == kdue:
            kdue = due_advance(k, spc, nxt)
        # 5. the symmetric forcing: the disturbances at the step's end (t_k+1, R_k+1), and
        # Pi_k+1 += h/2 (tau_dist_k+1 - tau_dist_k) (the step held tau_dist_k at both ends)
        if L > 0:
            st = run_lookahead(user, t0 + (k + 1) * h, k + 1, L, R, bus, io, codes, nxt, mask, nr, P, po, S, so, W, wo, WS,
                               fail)
            if st == OK and odist >= 0:
                Pi[0] += hh * (bus[odist] - d0)
                Pi[1] += hh * (bus[odist + 1] - d1)
                Pi[2] += hh * (bus[odist + 2] - d2)
        rmax, c_rec, e, c_save, j = after_step(its, rn, rmax, counts, c_rec, e, per, it_out, res_out, u_out, u_now,
                                               c_save, j, save_every, R, Pi, rho, R_out, Pi_out, rho_out)
        if st != OK:
            # a component failed at the next step's start: step k is done (its end held at tau_dist_k)
            return COMPONENT_FAILED, k + 1, it_sum, rmax, 0, 0.0
    return OK, k0 + n, it_sum, rmax, its, rn


#: :func:`loop_steps` compiled once (cached on disk) for every run: ``user`` is
#: :func:`user_component` of the run's user component, or :func:`no_user_component`.
run_loop = jit(_nrt=False)(loop_steps)
