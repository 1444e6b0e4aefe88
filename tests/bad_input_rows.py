"""Rows of the bad-input table (``tests/test_bad_inputs.py``) from issue 29: the helpers that
checked nothing, the untyped errors, and one row per numeric argument of the public functions
and each way it can be wrong, generated from a declaration of the arguments.

The generated rows are honest in the way a hand-written row is: each calls the public function
with every argument sound but one, and asserts the exception type and that the message names
that argument. A value of the wrong kind (a string, a complex number, a bool for an integer) is a
TypeError; a value of the right kind that breaks the rule (NaN, an infinity, a sign, a shape) is a
ValueError. Nothing here may return a result: a non-finite result would fail the row.
"""

from __future__ import annotations

import datetime as dt
from typing import Any, Callable

import numpy as np

import lgvi
from lgvi import control, so3, torques
from lgvi import environment as env
from lgvi import optimal

NAN, INF = float("nan"), float("inf")
BODY = [1.0, 2.0, 3.0]
_TLE1 = "1 00005U 58002B   00179.78495062  .00000023  00000-0  28098-4 0  4753"
_TLE2 = "2 00005  34.2682 348.7242 1859667 331.7664  19.3264 10.82419157413667"

Row = tuple[str, Callable[[], Any], type[BaseException], tuple[str, ...]]


def _tle_checksum(line: str) -> str:
    """``line`` (69 columns) with its checksum recomputed: a row then breaks only one rule."""
    total = sum(int(c) if c.isdigit() else (c == "-") for c in line[:68]) % 10
    return line[:68] + str(total)


def _interpreted() -> bool:
    import numba

    return bool(numba.config.DISABLE_JIT)


def _zero_division_moment() -> Any:
    import numba

    @numba.njit
    def moment(t, R, Pi, p):  # pragma: no cover - compiled
        out = np.zeros(3)
        if t > 0.05:
            out[0] = 1.0 // (p[0] - 1.0)     # a user's bug: divides by zero from step 6
        return out

    return moment


def _compiled_zero_division() -> Any:
    """``simulate`` with a compiled moment dividing by zero inside the compiled loop (not at the
    first sample, where its Python form is tried): a ``TorqueError`` naming the model, the step and
    the exception, the part computed up to that step in ``.trajectory``."""
    model = torques.Compiled(_zero_division_moment(), params=np.array([1.0]))
    try:
        lgvi.simulate(BODY, np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=40, torque=model)
    except lgvi.TorqueError as exc:
        part = getattr(exc, "trajectory", None)
        assert part is not None and len(part.t) >= 1 and np.all(np.isfinite(part.R))
        raise
    return None


# ------------------------------------------------------------------------------------ hand-written rows
HELPERS: list[Row] = [
    # 4. helpers that checked nothing
    ("mrp-from-matrix-zeros", lambda: control.mrp_from_matrix(np.zeros((3, 3))), ValueError,
     (r"\bR\b", r"\|R\^T R - I\| = 1\.73", r"rotation matrices")),
    ("mrp-from-matrix-stack-one-bad", lambda: control.mrp_from_matrix(np.stack([np.eye(3), 2 * np.eye(3)])),
     ValueError, (r"R\[1\]", r"\|R\^T R - I\| = 5\.2", r"determinant \+1")),
    ("mrp-from-matrix-reflection", lambda: control.mrp_from_matrix(-np.eye(3)), ValueError,
     (r"\bR\b", r"det = -1", r"determinant \+1")),
    ("map-to-wheels-zero-axes", lambda: control.map_to_wheels([0.1, 0.0, 0.0], np.zeros((3, 3))), ValueError,
     (r"\baxes\b", r"axis 0 \[0\.0, 0\.0, 0\.0\] has norm 0", r"unit vectors")),
    ("map-to-wheels-axes-shape", lambda: control.map_to_wheels([0.1, 0.0, 0.0], np.ones((3, 2))), ValueError,
     (r"\baxes\b", r"\(3, 2\)", r"shape \(N, 3\)")),
    ("map-to-wheels-request-nan", lambda: control.map_to_wheels([NAN, 0.0, 0.0], np.eye(3)), ValueError,
     (r"\btorque_request\b", r"nan", r"finite")),
    ("mrp-feedback-inertia-negative", lambda: control.MRPFeedback(1.0, 1.0, inertia=-np.eye(3)), ValueError,
     (r"\binertia\b", r"-1\.0", r"positive definite")),
    ("mrp-feedback-inertia-unsymmetric", lambda: control.MRPFeedback(1.0, 1.0, inertia=[[1, 0.5, 0], [0, 1, 0],
                                                                                          [0, 0, 1]]),
     ValueError, (r"\binertia\b", r"0\.5", r"symmetric")),
    ("ned-frame-lat-100", lambda: env.ned_frame(100.0, 0.0), ValueError, (r"\blat\b", r"100", r"\[-90, 90\]")),
    ("reachable-angle-negative-inertia", lambda: optimal.reachable_angle(-1.0, 0.0, 0.0, 1.0, 1.0), ValueError,
     (r"\binertia_min\b", r"-1", r"positive")),
    ("reachable-angle-negative-time", lambda: optimal.reachable_angle(1.0, 0.0, 0.0, 1.0, -2.0), ValueError,
     (r"\bT\b", r"-2", r">= 0")),
    ("reachable-angle-negative-p0", lambda: optimal.reachable_angle(1.0, -0.5, 0.0, 1.0, 2.0), ValueError,
     (r"\bp0\b", r"-0\.5", r">= 0")),
    ("so3-exp-nan", lambda: so3.exp([NAN, 0.0, 0.0]), ValueError, (r"\bw\b", r"nan", r"finite")),
    ("so3-exp-inf-stack", lambda: so3.exp([[0.0, 0.0, 0.0], [0.0, INF, 0.0]]), ValueError,
     (r"\bw\b", r"inf at index \(1, 1\)", r"finite")),
    ("so3-exp-complex", lambda: so3.exp(np.array([1j, 0.0, 0.0])), TypeError, (r"\bw\b", r"complex", r"real")),
    ("so3-quat-nan", lambda: so3.quat_to_matrix([0.0, 0.0, NAN, 1.0]), ValueError, (r"\bq\b", r"nan", r"finite")),
    ("wheels-deadband-above-limit", lambda: lgvi.ReactionWheels(np.eye(3), 0.01, max_torque=0.1, min_torque=0.2),
     ValueError, (r"\bmin_torque\b", r"0\.2 N m > max_torque = 0\.1", r"must not exceed max_torque")),
    ("simulate-R0-complex", lambda: lgvi.simulate(BODY, np.eye(3) + 0j, omega0=[0, 1, 0], h=0.01, steps=5),
     TypeError, (r"\bR0\b", r"complex", r"real numbers")),
    ("simulate-Pi0-complex", lambda: lgvi.simulate(BODY, np.eye(3), np.array([1j, 0, 0]), h=0.01, steps=5),
     TypeError, (r"\bPi0\b", r"complex", r"real numbers")),
    ("simulate-stream-empty-folder", lambda: lgvi.simulate_stream("", BODY, np.eye(3), omega0=[0, 1, 0], h=0.01,
                                                                   steps=5),
     ValueError, (r"\bfolder\b", r"''", r"current folder")),
    ("simulate-stream-folder-type", lambda: lgvi.simulate_stream(None, BODY, np.eye(3), omega0=[0, 1, 0], h=0.01,
                                                                  steps=5),
     TypeError, (r"\bfolder\b", r"NoneType", r"a path")),
    ("sgp4-checksum", lambda: env.SGP4Orbit(_TLE1[:68] + "0", _TLE2), ValueError,
     (r"\bline1\b", r"column 69 is '0'", r"modulo 10 is 3")),
    ("sgp4-day-400", lambda: env.SGP4Orbit(_tle_checksum(_TLE1.replace("00179.78495062", "00400.78495062")), _TLE2),
     ValueError, (r"line1's epoch day", r"'400\.78495062'", r"from 1 to 366")),
    ("sgp4-day-0", lambda: env.SGP4Orbit(_tle_checksum(_TLE1.replace("00179.78495062", "00000.50000000")), _TLE2),
     ValueError, (r"line1's epoch day", r"'000\.50000000'", r"from 1 to 366")),
    ("sgp4-day-366-not-leap", lambda: env.SGP4Orbit(_tle_checksum(_TLE1.replace("00179.78495062", "01366.5000000"
                                                                               "0")), _TLE2),
     ValueError, (r"line1's epoch day", r"366\.5", r"from 1 to 365\.99999999 in 2001")),
    ("sgp4-unicode-digit", lambda: env.SGP4Orbit(_TLE1.replace("00179.78", "00179.\u0667\u0668"), _TLE2), ValueError,
     (r"\bline1\b", r"'\u0667'|'\\u0667'", r"ASCII characters only")),
    ("sgp4-other-satellite", lambda: env.SGP4Orbit(_TLE1, _tle_checksum(_TLE2.replace("2 00005", "2 00006"))),
     ValueError, (r"line1 and line2", r"'00005' and '00006'", r"one satellite")),
    ("sgp4-short-line", lambda: env.SGP4Orbit(_TLE1[:60], _TLE2), ValueError,
     (r"\bline1\b", r"got 60", r"69 columns")),
    # 3. untyped errors
    ("steps-save-every-1e20", lambda: lgvi.simulate(BODY, np.eye(3), omega0=[0, 1, 0], h=0.01, steps=10**20,
                                                    save_every=10**20), ValueError,
     (r"\bsteps\b", r"100000000000000000000", r"at most 2\*\*62")),
    ("time-not-finite", lambda: lgvi.simulate(BODY, np.eye(3), omega0=[0, 1, 0], h=1e306, t0=1.79e308, steps=10),
     ValueError, (r"t0 \+ steps\*h", r"1\.79e\+308", r"must be finite")),
    ("time-below-resolution", lambda: lgvi.simulate(BODY, np.eye(3), omega0=[0, 1, 0], h=1e-3, t0=1e20, steps=10),
     ValueError, (r"\bh = 0\.001", r"t0 = 1e\+20", r"resolution")),
    ("orbit-time-not-finite", lambda: lgvi.simulate_orbit(BODY, 1.0, [1.0, 0, 0], [0, 1.0, 0], np.eye(3),
                                                          omega0=[0, 0, 0.1], h=1e306, t0=1.79e308, steps=10, mu=1.0),
     ValueError, (r"t0 \+ steps\*h", r"inf", r"must be finite")),
    ("circular-orbit-1e-120", lambda: env.CircularOrbit(1e-120), ValueError,
     (r"\ba = 1e-120", r"mean motion", r"finite")),
    ("kepler-orbit-1e200", lambda: env.KeplerOrbit(1e200), ValueError, (r"\ba = 1e\+200", r"mean motion", r"finite")),
    ("transfer-N-1e12", lambda: optimal.transfer(BODY, np.eye(3), so3.exp([0, 0, 1.0]), 10.0, 10**12), ValueError,
     (r"\bN = 1000000000000", r"GiB", r"fewer steps")),
]
if not _interpreted():   # lgvi.torques.Compiled needs numba.njit functions, which NUMBA_DISABLE_JIT=1 does not make
    HELPERS.append(("compiled-zero-division-keeps-part", _compiled_zero_division, lgvi.TorqueError,
                    (r"Compiled\(moment", r"inside the compiled loop at step \d+", r"divide by zero",
                     r"\.trajectory")))


def _igrf_text_file() -> Any:
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "notes.txt")
        with open(path, "w") as fh:
            fh.write("these are my notes\nnot a coefficient file\n\nat all\n")
        return env.IGRF(path=path)


def _wmm_binary_file() -> Any:
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "WMM.COF")
        with open(path, "wb") as fh:
            fh.write(bytes(range(256)))
        return env.WMM(path=path)


HELPERS += [
    ("igrf-text-file", _igrf_text_file, ValueError, (r"notes\.txt", r"'these'|'are'", r"IGRF \.shc coefficient")),
    ("wmm-binary-file", _wmm_binary_file, ValueError, (r"WMM\.COF", r"0x80", r"ASCII text")),
]


# ------------------------------------------------------------------------------------ generated rows
class Arg:
    """An argument of a public function and the ways to get it wrong.

    ``kind``: ``"real"`` (a finite float), ``"vec"`` (a finite array of ``shape``), ``"int"`` (an
    integer, ``minimum`` the least value); ``sign``: ``"positive"`` (> 0), ``"nonnegative"``
    (>= 0) or ``None``. ``name`` is what the message must name (the argument, or its path in the
    message, e.g. ``"friction\\['coulomb'\\]"``).
    """

    def __init__(self, kind: str, *, shape: tuple[int, ...] = (), sign: str | None = None, minimum: int = 0,
                 name: str | None = None, skip: tuple[str, ...] = (), errors: dict[str, type] | None = None):
        self.kind, self.shape, self.sign, self.minimum, self.name, self.skip = kind, shape, sign, minimum, name, skip
        self.errors = errors or {}      # the exception of a way of being wrong, where it is not the rule above

    def bad(self) -> list[tuple[str, Any, type[BaseException]]]:
        return [(what, value, self.errors.get(what, exc)) for what, value, exc in self._bad() if what not in self.skip]

    def _bad(self) -> list[tuple[str, Any, type[BaseException]]]:
        if self.kind == "int":
            out = [("float", 2.5, TypeError), ("str", "3", TypeError), ("bool", True, TypeError),
                   ("none", None, TypeError)]
            out.append(("below-minimum", self.minimum - 1, ValueError))
            return out
        if self.kind == "real":
            out = [("nan", NAN, ValueError), ("inf", INF, ValueError), ("-inf", -INF, ValueError),
                   ("str", "1.0", TypeError), ("complex", 1j, TypeError), ("list", [1.0, 2.0], TypeError)]
        else:
            good = np.ones(self.shape)
            nan, inf = good.copy(), good.copy()
            nan.flat[-1], inf.flat[0] = NAN, INF
            wrong = np.ones(self.shape[:-1] + (self.shape[-1] + 1,)) if self.shape else np.ones(2)
            out = [("nan", nan, ValueError), ("inf", inf, ValueError), ("shape", wrong, ValueError),
                   ("complex", good * (1 + 1j), TypeError), ("str", "abc", TypeError)]
        if self.sign == "positive":
            out += [("zero", 0.0 if self.kind == "real" else np.zeros(self.shape), ValueError),
                    ("negative", -1.0 if self.kind == "real" else -np.ones(self.shape), ValueError)]
        elif self.sign == "nonnegative":
            out.append(("negative", -1.0 if self.kind == "real" else -np.ones(self.shape), ValueError))
        return out


def _simulate(**kw: Any) -> Any:
    return lgvi.simulate(kw.pop("body"), kw.pop("R0"), **kw)


def _orbit(**kw: Any) -> Any:
    return lgvi.simulate_orbit(kw.pop("body"), kw.pop("mass"), kw.pop("x0"), kw.pop("v0"), kw.pop("R0"), **kw)


def _wheels(**kw: Any) -> Any:
    return lgvi.ReactionWheels(kw.pop("axes"), kw.pop("spin_inertia"), **kw)


def _friction(**kw: Any) -> Any:
    return lgvi.ReactionWheels(np.eye(3), 0.01, friction=kw)


def _positional(f: Callable[..., Any], names: tuple[str, ...]) -> Callable[..., Any]:
    """``f`` taking ``names`` positionally from keywords (for functions without keyword names)."""
    def call(**kw: Any) -> Any:
        args = [kw.pop(n) for n in names]
        return f(*args, **kw)
    return call


R = Arg("vec", shape=(3, 3))
#: A scalar or one value per wheel (rod): a list of the wrong length is a wrong shape (ValueError).
PER: dict[str, Any] = {"errors": {"list": ValueError}}
V3 = Arg("vec", shape=(3,))
#: (label, function taking keywords, sound keywords, {argument: Arg})
TARGETS: list[tuple[str, Callable[..., Any], dict[str, Any], dict[str, Arg]]] = [
    ("simulate", _simulate, dict(body=BODY, R0=np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=10),
     {"R0": Arg("vec", shape=(3, 3), skip=("shape",)), "omega0": V3, "h": Arg("real", skip=("zero",)),
      "t0": Arg("real"), "tol": Arg("real", sign="nonnegative"), "steps": Arg("int"),
      "save_every": Arg("int", minimum=1), "max_iter": Arg("int", minimum=1)}),
    ("simulate-Pi0", _simulate, dict(body=BODY, R0=np.eye(3), Pi0=[0.3, 2.0, 0.6], h=0.01, steps=10),
     {"Pi0": V3}),
    ("step", _positional(lgvi.step, ("body", "R", "Pi")), dict(body=BODY, R=np.eye(3), Pi=[0.3, 2.0, 0.6], h=0.01),
     {"Pi": V3, "h": Arg("real")}),
    ("rigid-body", _positional(lgvi.RigidBody, ("inertia",)), dict(inertia=BODY),      # its own message: ValueError
     {"inertia": Arg("vec", shape=(3,), sign="positive", skip=("shape",), errors={"complex": ValueError,
                                                                               "str": ValueError})}),
    ("orbit", _orbit, dict(body=BODY, mass=1.0, x0=[1.0, 0.0, 0.0], v0=[0.0, 1.0, 0.0], R0=np.eye(3),
                           omega0=[0.0, 0.0, 0.1], h=0.01, steps=10, mu=1.0),
     {"mass": Arg("real", sign="positive"), "x0": V3, "v0": V3, "omega0": V3, "h": Arg("real"),
      "mu": Arg("real", sign="positive"), "t0": Arg("real"), "steps": Arg("int"), "save_every": Arg("int", minimum=1)}),
    ("wheels", _wheels, dict(axes=np.eye(3), spin_inertia=0.01),
     {"spin_inertia": Arg("real", sign="positive", **PER), "speed0": Arg("real", **PER),
      "max_torque": Arg("real", sign="positive", **PER), "min_torque": Arg("real", sign="nonnegative", **PER),
      "max_power": Arg("real", sign="positive", **PER), "max_speed": Arg("real", sign="positive", **PER)}),
    ("wheels-per-wheel", _wheels, dict(axes=np.eye(3), spin_inertia=0.01),
     {"speed0": Arg("vec", shape=(3,), skip=("str",)), "spin_inertia": Arg("vec", shape=(3,), sign="positive",
                                                                          skip=("str",))}),
    ("wheels-friction", _friction, dict(),
     {"coulomb": Arg("real", sign="nonnegative", name=r"friction\['coulomb'\]", **PER),
      "viscous": Arg("real", sign="nonnegative", name=r"friction\['viscous'\]", **PER),
      "omega_limit_cycle": Arg("real", sign="positive", name=r"friction\['omega_limit_cycle'\]", **PER)}),
    ("mrp-feedback", control.MRPFeedback, dict(K=1.0, P=1.0),
     {"K": Arg("real", sign="positive"), "P": Arg("real", sign="positive"), "Ki": Arg("real", sign="positive"),
      "inertia": Arg("vec", shape=(3, 3))}),
    ("mrp-from-matrix", control.mrp_from_matrix, dict(R=np.eye(3)), {"R": R}),
    ("matrix-from-mrp", _positional(control.matrix_from_mrp, ("sigma",)), dict(sigma=[0.1, 0.0, 0.0]),
     {"sigma": Arg("vec", shape=(3,), skip=("shape",))}),
    ("map-to-wheels", control.map_to_wheels, dict(torque_request=[0.1, 0.0, 0.0], axes=np.eye(3)),
     {"torque_request": V3, "axes": Arg("vec", shape=(3, 3), skip=("shape",))}),
    *[(f"so3-{f.__name__}", _positional(f, ("w",)), dict(w=[0.1, 0.2, 0.3]),
       {"w": Arg("vec", shape=(3,), name=r"\b(w|f)\b")})
      for f in (so3.hat, so3.exp, so3.exp_minus_identity, so3.left_jacobian, so3.right_jacobian,
                so3.left_jacobian_inv, so3.right_jacobian_inv, so3.cayley)],
    ("so3-quat-to-matrix", _positional(so3.quat_to_matrix, ("q",)), dict(q=[0.0, 0.0, 0.0, 1.0]),
     {"q": Arg("vec", shape=(4,))}),
    ("kepler", env.KeplerOrbit, dict(a=7e6),
     {"a": Arg("real", sign="positive"), "e": Arg("real", skip=("str", "complex", "list")),
      "raan": Arg("real"), "arg_perigee": Arg("real"), "mean_anomaly": Arg("real"),
      "mu": Arg("real", sign="positive")}),
    ("circular", env.CircularOrbit, dict(radius=7e6),
     {"radius": Arg("real", sign="positive"), "arg_latitude": Arg("real")}),
    ("j2", env.J2Orbit, dict(a=7e6), {"J2": Arg("real"), "radius": Arg("real", sign="positive")}),
    ("geodetic", env.geodetic_to_ecef, dict(lat=10.0, lon=20.0, height=0.0),
     {"lat": Arg("real", skip=("str", "complex", "list")), "lon": Arg("real", skip=("str", "complex", "list")),
      "height": Arg("real", skip=("str", "complex", "list"))}),
    ("ned", env.ned_frame, dict(lat=10.0, lon=20.0),
     {"lat": Arg("real", skip=("str", "complex", "list")), "lon": Arg("real", skip=("str", "complex", "list"))}),
    ("lvlh", env.lvlh_frame, dict(r=[7e6, 0.0, 0.0], v=[0.0, 7.5e3, 0.0]), {"r": V3, "v": V3}),
    ("dipole", env.CentredDipole, dict(), {"g10": Arg("real"), "g11": Arg("real"), "h11": Arg("real"),
                                           "radius": Arg("real", sign="positive")}),
    ("constant-torque", _positional(torques.Constant, ("u",)), dict(u=[0.1, 0.0, 0.0]), {"u": V3}),
    ("transfer", _positional(optimal.transfer, ("body", "R0", "Rf", "T", "N")),
     dict(body=BODY, R0=np.eye(3), Rf=so3.exp([0.0, 0.0, 0.5]), T=5.0, N=20, maxiter=1),
     {"T": Arg("real", sign="positive"), "N": Arg("int", minimum=2), "tol": Arg("real", sign="positive"),
      "Rf": Arg("vec", shape=(3, 3), skip=("shape",))}),
    ("reachable", optimal.reachable_angle, dict(inertia_min=1.0, p0=0.0, pf=0.0, a=1.0, T=2.0),
     {"inertia_min": Arg("real", sign="positive"), "p0": Arg("real", sign="nonnegative"),
      "pf": Arg("real", sign="nonnegative"), "a": Arg("real", sign="nonnegative"),
      "T": Arg("real", sign="nonnegative")}),
    ("magnetorquers", _positional(lgvi.Magnetorquers, ("axes", "max_dipole")), dict(axes=np.eye(3), max_dipole=1.0),
     {"max_dipole": Arg("real", sign="positive", **PER)}),
    ("bdot", _positional(env.BDot, ("gain",)), dict(gain=1.0), {"gain": Arg("real", sign="positive")}),
]


def generated() -> list[Row]:
    rows: list[Row] = []
    for label, f, good, args in TARGETS:
        for arg, spec in args.items():
            pattern = spec.name or rf"\b{arg}\b"
            for what, value, exc in spec.bad():
                def call(f=f, good=good, arg=arg, value=value) -> Any:
                    return f(**dict(good, **{arg: value}))
                rows.append((f"gen-{label}-{arg}-{what}", call, exc, (pattern,)))
    return rows


ROWS: list[Row] = HELPERS + generated()
