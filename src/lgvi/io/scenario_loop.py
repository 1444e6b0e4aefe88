"""Scenario sections of the compiled spacecraft loop (issue 25): ``[spacecraft]`` and ``[fsw]``,
read by :mod:`lgvi.io.scenario` into an :class:`lgvi.Spacecraft` and an :class:`lgvi.FlightSoftware`
(``docs/loop.md``), run by ``lgvi run`` (:class:`LoopScenario`).

Every component table names a registered kind with ``type`` (``lgvi.components.COMPONENT_KINDS``,
the one source of truth: a kind's class and the keyword arguments of its constructor are the keys
the table takes; a few short aliases: guidance ``"inertial"``, ``"nadir"`` (lgvi's LVLH),
``"hill"`` (Basilisk's ``hillPoint``), ``"velocity"``, ``"sun"``, ``"target"``; disturbance
``"gravity_gradient"``)::

    name = "nadir_pointing"
    [initial]                            # attitude (any form of the rigid body's [initial])
    omega = [0.0, 0.0, 0.0011]           # and omega [rad/s] or Pi

    [integrator]
    h = 0.1                              # [s]
    duration = 5677.0                    # or steps; save_every; method, tol, max_iter
    save_every = 10

    [spacecraft]
    orbit_dt = 10.0                      # optional: spacing of the orbit table [s]
    magnetorquer_rate = 1.0              # optional [s]; environment_rate too
    epoch = 2026-03-20T00:00:00Z         # optional: UTC of t = 0 (else [spacecraft.orbit]'s epoch)
    [spacecraft.body]                    # as the rigid body's [body]: inertia, matrix or shape
    inertia = [0.18, 0.14, 0.06]
    [[spacecraft.wheel]]                 # as the rigid body's [[wheel]]
    axis = [0.577, 0.577, 0.577]
    spin_inertia = 1e-4
    [[spacecraft.magnetorquer]]          # as [[magnetorquer]]: axis, max_dipole
    [spacecraft.orbit]                   # as [orbit]: "circular", "kepler", "j2", "sgp4" (TLE lines)
    type = "circular"
    radius = 6878137.0
    inclination = 97.4                   # [deg]
    [spacecraft.field]                   # as [field]: model = "igrf", "wmm" or "dipole"
    [[spacecraft.disturbance]]           # any disturbance kind; also [[spacecraft.sensor]] and
    type = "gravity_gradient"            # [[spacecraft.environment]] of their families

    [fsw]
    rate = 1.0                           # default period of every part [s]
    record = ["sigma_BR", "mode"]        # optional: the signals recorded (default all written)
    record_rate = "writer"               # optional: every write at its writer's rate (default), or
                                         # "grid": the record grid's entries only
    [[fsw.guidance]]                     # one table, or several with modes = [...]
    type = "hill"
    [[fsw.control]]
    type = "mrp_feedback"
    K = 0.0035
    P = 0.035
    [[fsw.actuator]]
    type = "rw_motor_torque"
    [fsw.modes]                          # the mode manager: rules [from, to, condition, threshold];
    rules = [["any", 1, "rate_below", 0.01]]   # from "any" for any mode
    initial = 0
    [[fsw.estimator]]                    # the estimator family, e.g. the MEKF:
    type = "mekf"
    arw = 1e-4
    rrw = 1e-5
    P0 = [1e-3, 1e-3, 1e-3, 1e-7, 1e-7, 1e-7]
    star_tracker = true                  # the spacecraft's one StarTracker (or its index in
                                         # [[spacecraft.sensor]]; false: no star tracker update)

Attitude-valued keys (``R_ref`` of the inertial guidance) take any form of ``[initial]``
(``R_ref = { euler = { sequence = "ZYX", angles = [30.0, 0.0, 0.0], unit = "deg" } }``).
Errors are :class:`lgvi.io.scenario.ScenarioError` naming the file and the dotted key
(``fsw.control[0].K``); the run is then built once (without a step) so that what the loop refuses
(a rate that is not a multiple of ``h``, a controller without wheels, a guidance without an orbit)
is named before any step runs.
"""

from __future__ import annotations

import datetime as _dt
import inspect
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["LoopScenario", "ALIASES", "SPACECRAFT_KEYS", "FSW_KEYS", "SPACECRAFT_LISTS", "FSW_LISTS"]

#: Short names of component kinds in a file (``type = "hill"``) -> the registered kind.
ALIASES: dict[str, dict[str, str]] = {
    "guidance": {"inertial": "inertial_pointing", "nadir": "nadir_pointing", "hill": "hill_pointing",
                 "velocity": "velocity_pointing", "sun": "sun_pointing", "target": "target_pointing"},
    "disturbance": {"gravity_gradient": "orbit_gravity_gradient"},
}
#: [spacecraft] component lists: file key -> family.
SPACECRAFT_LISTS = {"disturbance": "disturbance", "sensor": "sensor", "environment": "environment"}
#: [fsw] component lists: file key -> family.
FSW_LISTS = {"estimator": "estimator", "guidance": "guidance", "control": "control", "actuator": "actuator"}
SPACECRAFT_KEYS = ("body", "wheel", "magnetorquer", "orbit", "field", "epoch", "orbit_dt", "environment_rate",
                   "magnetorquer_rate") + tuple(k for k in SPACECRAFT_LISTS if k != "environment")
FSW_KEYS = ("rate", "record", "record_rate", "modes") + tuple(FSW_LISTS)
_TOP = ("name", "description", "initial", "integrator", "output", "spacecraft", "fsw", "ensemble")
_INTEGRATOR = ("h", "steps", "duration", "save_every", "method", "tol", "max_iter")
#: kinds the spacecraft adds itself from its own keys (orbit, field, magnetorquers): not in a list
_BUILT_IN = ("orbit", "field", "magnetorquers")


def _prefixed(c: Any, prefix: str) -> Any:
    """A checker of :mod:`lgvi.io.scenario` whose keys are under ``prefix`` (``spacecraft.``)."""
    base = type(c)

    class Prefixed(base):  # type: ignore[valid-type, misc]
        def error(self, key: str | None, message: str):
            return base.error(self, prefix.rstrip(".") if not key else prefix + key, message)

    return Prefixed(c.source)


def _kinds(family: str) -> dict[str, Any]:
    """Registered kinds of ``family`` a file may name, with a class to build them."""
    from .. import fsw as _fsw  # noqa: F401  (registers the flight software's kinds)
    from .. import spacecraft as _sc  # noqa: F401
    from ..components import COMPONENT_KINDS

    return {name: k for name, k in COMPONENT_KINDS.items()
            if k.family == family and k.cls is not None and name not in _BUILT_IN}


def _value(c: Any, v: Any, key: str) -> Any:
    """A TOML value as a component's constructor takes it (an attitude table -> a rotation matrix)."""
    from .scenario import ATTITUDE_KEYS, read_attitude

    if isinstance(v, dict):
        if v and all(k in ATTITUDE_KEYS for k in v):
            return read_attitude(c, v, key)
        raise c.expected(key, "a number, a string, an array or an attitude table (as [initial])", v)
    return v


def component(c: Any, tbl: Any, key: str, family: str, defaults: dict[str, Any] | None = None,
              refs: dict[str, Any] | None = None) -> Any:
    """One component of ``family`` from its table: ``type`` (a registered kind or alias) and the
    keyword arguments of the kind's class (``lgvi.components.COMPONENT_KINDS[type].cls``);
    ``defaults`` fill arguments the class takes and the table leaves out (the spacecraft's
    ``epoch`` for a sun model); ``refs`` turn a key's value into the object it names
    (``refs[k](value, dotted_key)``: the MEKF's ``star_tracker``, a sensor of the spacecraft)."""
    kinds = _kinds(family)
    aliases = ALIASES.get(family, {})
    names = tuple(aliases) + tuple(kinds)
    if not isinstance(tbl, dict):
        raise c.expected(key, "a table", tbl)
    if "type" not in tbl:
        raise c.expected(f"{key}.type", "one of " + ", ".join(f'"{n}"' for n in names))
    name = c.string(tbl["type"], f"{key}.type", names)
    kind = kinds[aliases.get(name, name)]
    sig = inspect.signature(kind.cls.__init__)
    params = {p.name: p for p in list(sig.parameters.values())[1:]
              if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    c.table(tbl, key, ("type",) + tuple(params))
    for k, v in (defaults or {}).items():
        if k in params and k not in tbl and v is not None:
            tbl = {**tbl, k: v}
    for p in params.values():
        if p.default is p.empty and p.name not in tbl:
            raise c.expected(f"{key}.{p.name}", f"a value (a required argument of {kind.cls.__name__})")
    kw = {k: _value(c, v, f"{key}.{k}") for k, v in tbl.items() if k != "type" and k not in (refs or {})}
    kw.update({k: ref(tbl[k], f"{key}.{k}") for k, ref in (refs or {}).items() if k in tbl and k in params})
    try:
        obj = kind.cls(**kw)
    except (ValueError, TypeError) as exc:
        first = str(exc).split(" ", 1)[0].rstrip(":")
        where = f"{key}.{first}" if first in kw else key
        raise c.error(where, f"invalid {name} ({kind.cls.__name__}): {exc}") from None
    obj.scenario_key = key           # where the run's own refusals (LoopScenario.check) point
    return obj


def components(c: Any, value: Any, key: str, family: str, defaults: dict[str, Any] | None = None,
               refs: dict[str, Any] | None = None) -> list[Any]:
    """``[[key]]`` (an array of tables) or ``[key]`` (one table) of components of ``family``."""
    tables = [value] if isinstance(value, dict) else value
    if not isinstance(tables, list):
        raise c.expected(key, f"a table or an array of tables ([[{key}]])", value)
    return [component(c, t, f"{key}[{i}]" if isinstance(value, list) else key, family, defaults, refs)
            for i, t in enumerate(tables)]


def _sensor_ref(c: Any, sensors: Any, cls_name: str) -> Any:
    """A ``refs`` entry (:func:`component`) naming one of the spacecraft's sensors of class
    ``cls_name``: ``true`` (the one there is), an index into ``[[spacecraft.sensor]]``, or ``false``
    (none)."""
    sensors = list(sensors or ())

    def ref(v: Any, key: str) -> Any:
        if v is False:
            return None
        found = [i for i, s in enumerate(sensors) if type(s).__name__ == cls_name]
        if v is True:
            if len(found) != 1:
                raise c.error(key, f"true names the spacecraft's one {cls_name}, and [[spacecraft.sensor]] holds "
                              f"{len(found)} (at {found}): give the index of the one to use")
            return sensors[found[0]]
        if isinstance(v, int) and not isinstance(v, bool):
            if v not in found:
                raise c.error(key, f"{v} must be the index of a {cls_name} in [[spacecraft.sensor]]; the "
                              f"{cls_name}s there: {found}")
            return sensors[v]
        raise c.expected(key, f"true (the spacecraft's {cls_name}), the index of one in [[spacecraft.sensor]], or "
                         "false", v)

    return ref


def _modes(c: Any, tbl: Any) -> Any:
    from ..fsw import ModeRules

    tbl = c.table(tbl, "fsw.modes", ("rules", "initial", "names", "rate"))
    if "rules" not in tbl:
        raise c.expected("fsw.modes.rules", 'an array of [from, to, condition, threshold] ("any" as from: any mode)')
    rules = tbl["rules"]
    if not isinstance(rules, list):
        raise c.expected("fsw.modes.rules", "an array of [from, to, condition, threshold]", rules)
    out = []
    for i, r in enumerate(rules):
        if not isinstance(r, list) or len(r) != 4:
            raise c.expected(f"fsw.modes.rules[{i}]", "[from, to, condition, threshold]", r)
        out.append((None if r[0] == "any" else r[0], *r[1:]))
    kw = {k: tbl[k] for k in ("initial", "rate") if k in tbl}
    if "names" in tbl:
        if not isinstance(tbl["names"], list):
            raise c.expected("fsw.modes.names", 'an array of strings (names[i] names mode i), e.g. ["detumble", "nadir"]',
                             tbl["names"])
        kw["names"] = [c.string(n, f"fsw.modes.names[{i}]") for i, n in enumerate(tbl["names"])]
    try:
        return ModeRules(out, **kw)
    except (ValueError, TypeError) as exc:
        msg = str(exc)
        where = "fsw.modes." + msg.split(" ", 2)[0] if msg.startswith(("rules[", "initial", "names", "rate")) \
            else "fsw.modes"
        raise c.error(where.split(" ")[0] if msg.startswith("rules[") else where, msg) from None


def spacecraft(c: Any, tbl: Any) -> Any:
    """``[spacecraft]``: an :class:`lgvi.Spacecraft`."""
    from ..spacecraft import Spacecraft
    from . import scenario_space
    from .scenario import read_body, read_wheels

    tbl = c.table(tbl, "spacecraft", SPACECRAFT_KEYS + ("environment",))
    if "body" not in tbl:
        raise c.error("spacecraft.body", "missing; expected a [spacecraft.body] table (inertia, matrix or shape)")
    p = _prefixed(c, "spacecraft.")
    body = read_body(p, tbl["body"])
    kw: dict[str, Any] = {}
    if "wheel" in tbl:
        kw["wheels"] = read_wheels(p, tbl["wheel"], body)
    if "magnetorquer" in tbl:
        kw["magnetorquers"] = scenario_space.magnetorquers(p, tbl["magnetorquer"])
    epoch = tbl.get("epoch")
    if epoch is not None and not isinstance(epoch, _dt.datetime):
        raise c.expected("spacecraft.epoch", "a date-time (UTC), e.g. 2026-03-20T00:00:00Z", epoch)
    sub = {k: tbl[k] for k in ("orbit", "field") if k in tbl}
    if "field" in sub and "orbit" in sub and epoch is not None and isinstance(sub["orbit"], dict) \
            and "epoch" not in sub["orbit"]:
        sub["orbit"] = {**sub["orbit"], "epoch": epoch}       # the field's date from spacecraft.epoch
    env = scenario_space.environment(p, sub)
    if env is not None:
        kw.update(orbit=env.orbit, field=env.field)
        epoch = epoch if epoch is not None else getattr(env, "epoch", None)
    if epoch is not None:
        kw["epoch"] = epoch
    for k in ("orbit_dt", "environment_rate", "magnetorquer_rate"):
        if k in tbl:
            kw[k] = c.number(tbl[k], f"spacecraft.{k}", positive=True)
    for k, fam in SPACECRAFT_LISTS.items():
        if k in tbl:
            kw[{"disturbance": "disturbances", "sensor": "sensors"}.get(k, k)] = \
                components(c, tbl[k], f"spacecraft.{k}", fam, {"epoch": epoch})
    try:
        return Spacecraft(body, **kw)
    except (ValueError, TypeError) as exc:
        raise c.error("spacecraft", str(exc)) from None


def flight_software(c: Any, tbl: Any, spacecraft: Any = None) -> Any:
    """``[fsw]``: an :class:`lgvi.FlightSoftware` (``spacecraft``: the one it flies, whose sensors
    an estimator's ``star_tracker`` names)."""
    from ..components import SIGNALS
    from ..fsw import FlightSoftware

    tbl = c.table(tbl, "fsw", FSW_KEYS)
    kw: dict[str, Any] = {}
    if "rate" in tbl:
        kw["rate"] = c.number(tbl["rate"], "fsw.rate", positive=True)
    if "record" in tbl:
        rec = tbl["record"]
        if not isinstance(rec, list):
            raise c.expected("fsw.record", "an array of signal names", rec)
        kw["record"] = [c.string(r, f"fsw.record[{i}]") for i, r in enumerate(rec)]
        for i, r in enumerate(kw["record"]):
            if r not in SIGNALS and not r.startswith("tau_"):
                raise c.error(f"fsw.record[{i}]", f"not a signal: {r!r}; expected one of lgvi.components.SIGNALS")
    if "record_rate" in tbl:
        kw["record_rate"] = c.string(tbl["record_rate"], "fsw.record_rate", ("writer", "grid"))
    if "modes" in tbl:
        kw["modes"] = _modes(c, tbl["modes"])
    refs = {"estimator": {"star_tracker": _sensor_ref(c, getattr(spacecraft, "sensors", ()), "StarTracker")}}
    for k, fam in FSW_LISTS.items():
        if k in tbl:
            kw[{"actuator": "actuators"}.get(k, k)] = components(c, tbl[k], f"fsw.{k}", fam, refs=refs.get(k))
    return FlightSoftware(**kw)


@dataclass(frozen=True, eq=False)
class LoopScenario:
    """A checked scenario of a spacecraft and its flight software in the compiled loop."""

    name: str
    description: str
    spacecraft: Any
    fsw: Any
    R0: np.ndarray
    h: float
    steps: int
    omega0: np.ndarray | None = None
    Pi0: np.ndarray | None = None
    save_every: int = 1
    options: dict[str, Any] = field(default_factory=dict)
    formats: tuple[str, ...] = ("npz",)
    plots: bool = True
    source: str = "<dict>"
    text: str = field(default="", repr=False)
    kind: str = "spacecraft"
    #: The ``[ensemble]`` section (:mod:`lgvi.io.scenario_ensemble`), or ``None``.
    ensemble: Any = None
    #: Per member ``(spacecraft, fsw, R0, omega0, Pi0)``, drawn and checked (empty without ``[ensemble]``).
    members: tuple[Any, ...] = ()

    def __repr__(self) -> str:
        more = f", members={len(self.members)}" if self.ensemble is not None else ""
        return f"LoopScenario(name={self.name!r}, steps={self.steps}, h={self.h:g}{more}, source={self.source!r})"

    @property
    def samples(self) -> int:
        return self.steps // self.save_every + 1

    def simulate_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`lgvi.simulate` after the spacecraft, ``R0`` and ``Pi0``."""
        return dict(omega0=self.omega0, h=self.h, steps=self.steps, fsw=self.fsw,
                    save_every=self.save_every, **self.options)

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "<dict>", *, text: str | None = None) -> "LoopScenario":
        from .._untrusted import name_problem
        from .scenario import FORMATS, METHODS, Checker, read_steps, to_toml

        c = Checker(source)
        d = c.table(d, "", _TOP)
        for req in ("spacecraft", "integrator"):
            if req not in d:
                raise c.error(req, f"missing; expected a [{req}] table")
        name = c.string(d.get("name", Path(source).stem if not source.startswith("<") else "scenario"), "name")
        if "name" in d and (problem := name_problem(name)):
            raise c.error("name", problem)
        description = c.string(d.get("description", ""), "description")
        integ = c.table(d["integrator"], "integrator", _INTEGRATOR)
        h, steps = read_steps(c, integ)
        save_every = c.integer(integ.get("save_every", 1), "integrator.save_every", minimum=1)
        if steps % save_every:
            raise c.error("integrator.save_every", f"expected a divisor of the number of steps ({steps}) so the "
                          f"final state is saved; got {save_every}")
        options: dict[str, Any] = {}
        if "method" in integ:
            options["method"] = c.string(integ["method"], "integrator.method", METHODS)
        if "tol" in integ:
            options["tol"] = c.number(integ["tol"], "integrator.tol", nonnegative=True)
        if "max_iter" in integ:
            options["max_iter"] = c.integer(integ["max_iter"], "integrator.max_iter", minimum=1)
        R0, omega0, Pi0, sc, fsw = _described(c, d)
        ensemble, members = None, ()
        if "ensemble" in d:                   # a Monte Carlo of the mission: every member drawn and read now
            from .scenario_ensemble import member_tables, read_ensemble

            ensemble = read_ensemble(c, d["ensemble"], d)
            built = []
            for b in range(ensemble.members):
                cb = Checker(f"{source} (ensemble member {b})")
                tables, attitude = member_tables(cb, d, ensemble, b)
                R_b, omega_b, Pi_b, sc_b, fsw_b = _described(cb, tables)
                built.append((sc_b, fsw_b, attitude(R_b), omega_b, Pi_b))
            members = tuple(built)
        out = c.table(d.get("output", {}), "output", ("formats", "plots"))
        formats: tuple[str, ...] = ("npz",)
        if "formats" in out:
            raw = out["formats"]
            if not isinstance(raw, list) or not raw:
                raise c.expected("output.formats", 'a non-empty array holding "npz"', raw)
            for i, f in enumerate(raw):
                if c.string(f, f"output.formats[{i}]", FORMATS) != "npz":
                    raise c.error(f"output.formats[{i}]", f"the result of a [spacecraft] scenario is saved as npz "
                                  f"only; got {f!r}")
        plots = c.boolean(out.get("plots", True), "output.plots")
        scen = cls(name=name, description=description, spacecraft=sc, fsw=fsw, R0=R0, h=h, steps=steps,
                   omega0=omega0, Pi0=Pi0, save_every=save_every, options=options, formats=formats, plots=plots,
                   source=source, text=to_toml(d) if text is None else text, ensemble=ensemble, members=members)
        scen.check(c)
        return scen

    def check(self, c: Any) -> None:
        """Build the run once, without a step: what the loop refuses is named before any step (each
        member's run too, the error naming the member)."""
        from ..systems.spacecraft import LoopRun
        from .scenario import Checker

        try:
            LoopRun(self.spacecraft, self.R0, self.Pi0, **self.simulate_kwargs())
        except (ValueError, TypeError) as exc:
            raise c.error(self._key_of(str(exc)), str(exc)) from None
        B = len(self.members)
        for b, (sc, fsw, R0, omega0, Pi0) in enumerate(self.members):
            member = replace(self, spacecraft=sc, fsw=fsw, R0=R0, omega0=omega0, Pi0=Pi0, ensemble=None, members=())
            try:
                LoopRun(sc, R0, Pi0, member=(b, B), **member.simulate_kwargs())
            except (ValueError, TypeError) as exc:
                raise Checker(f"{self.source} (ensemble member {b})").error(member._key_of(str(exc)),
                                                                            str(exc)) from None

    def _key_of(self, msg: str) -> str:
        """The file key of a refusal of the run: the component it names first (its kind or class),
        its ``rate`` for a rate; else ``fsw`` or ``spacecraft``."""
        rate = " rate " in f" {msg} "
        head = msg.split(":", 1)[0].split(" ", 1)[0]
        built = {"orbit": "spacecraft.orbit", "field": "spacecraft.field", "magnetorquers": "spacecraft.magnetorquer"}
        if head in built:
            return ("spacecraft.magnetorquer_rate" if head == "magnetorquers" else "spacecraft.environment_rate") \
                if rate else built[head]
        own = [c for c in self.fsw.components() + self.spacecraft.components()
               if head in (getattr(c, "kind", None), type(c).__name__) and hasattr(c, "scenario_key")]
        if len(own) != 1:
            return "fsw" if self.fsw.components() and not rate else ("fsw.rate" if rate else "spacecraft")
        c = own[0]
        if not rate:
            return c.scenario_key
        if c.rate is not None or not c.scenario_key.startswith("fsw."):
            return f"{c.scenario_key}.rate"
        return "fsw.rate"

    def run_ensemble(self, threads: Any = None):
        """The ``[ensemble]``'s members in the compiled loop (:func:`lgvi.simulate_ensemble` with one
        spacecraft and flight software per member): a :class:`lgvi.systems.spacecraft.SpacecraftEnsemble`
        whose ``meta`` holds the scenario's text, name and source."""
        from ..systems.spacecraft import simulate_spacecraft_ensemble

        if self.ensemble is None:
            raise ValueError(f"{self.source}: the scenario has no [ensemble] section; run it with run()")
        scs, fsws, R0, omega0, Pi0 = zip(*self.members)
        init = {"omega0": np.stack(omega0)} if omega0[0] is not None else {"Pi0": np.stack(Pi0)}
        ens = simulate_spacecraft_ensemble(list(scs), np.stack(R0), h=self.h, steps=self.steps, fsw=list(fsws),
                                           threads=self.ensemble.threads if threads is None else threads,
                                           save_every=self.save_every, **init, **self.options)
        ens.meta.update(scenario=self.text, scenario_name=self.name, scenario_source=self.source,
                        ensemble_seed=self.ensemble.seed)
        return ens

    def run(self, progress: Any = False):
        """Simulate (:func:`lgvi.simulate` with the spacecraft and ``fsw=``); the result's ``meta``
        holds the scenario text, name and source."""
        from ..systems.spacecraft import simulate_spacecraft

        return self._attached(lambda: simulate_spacecraft(self.spacecraft, self.R0, self.Pi0, progress=progress,
                                                          **self.simulate_kwargs()))

    def run_stream(self, folder: Any, *, resume: bool = False, progress: Any = False,
                   chunk_steps: int | None = None):
        """Simulate into a crash-safe stream folder (``resume=True`` continues it bit for bit)."""
        from .streaming import read_stream, stream_system

        def go():
            stream_system(folder, "spacecraft", self.spacecraft, self.R0, self.Pi0, progress=progress,
                          resume=resume, chunk_steps=chunk_steps, meta={"scenario_name": self.name},
                          **self.simulate_kwargs())
            return read_stream(folder)

        return self._attached(go)

    def short(self) -> "LoopScenario":
        """The same scenario for one saved interval (to load or compile the kernels first)."""
        return replace(self, steps=min(self.steps, self.save_every))

    def _attached(self, go: Any):
        from .scenario import BodiesScenario

        return BodiesScenario._attached(self, go)    # the scenario's text, name and source in meta

    def attach(self, traj):
        from .scenario import BodiesScenario

        return BodiesScenario.attach(self, traj)


#: Pointing error (degrees) under which a run counts as settled, by default.
SETTLE_DEG = 0.1


def _described(c: Any, d: dict[str, Any]) -> tuple[Any, Any, Any, Any, Any]:
    """``(R0, omega0, Pi0, spacecraft, fsw)`` of a spacecraft scenario's tables (or a member's)."""
    from .scenario import ATTITUDE_KEYS, read_attitude, read_omega

    init = c.table(d.get("initial", {}), "initial", ATTITUDE_KEYS + ("omega", "Pi"))
    R0 = read_attitude(c, init, "initial")
    if "omega" in init and "Pi" in init:
        raise c.error("initial", "expected at most one of initial.omega [rad/s] or initial.Pi [kg m^2/s]; got both")
    omega0 = read_omega(c, init["omega"], "initial.omega") if "omega" in init else None
    Pi0 = c.vector(init["Pi"], "initial.Pi") if "Pi" in init else None
    if omega0 is None and Pi0 is None:
        omega0 = np.zeros(3)
    sc = spacecraft(c, d["spacecraft"])
    return R0, omega0, Pi0, sc, flight_software(c, d.get("fsw", {}), sc)


def loop_summary(traj: Any, *, wheels: Any = None, settle_deg: float = SETTLE_DEG, inertia: Any = None,
                 mu: float = 3.986004418e14) -> dict[str, Any]:
    """What a run of the compiled loop achieved, from its records (``traj.signals``).

    Parameters
    ----------
    traj : lgvi.systems.spacecraft.SpacecraftTrajectory
    wheels : lgvi.ReactionWheels, optional
        The spacecraft's wheels (their spin inertias and axes give the wheel momenta); default the
        run's own (``traj.wheel_axes``, ``traj.spin_inertia``).
    settle_deg : float
        The pointing error, degrees, under which the run counts as settled.
    inertia : (3, 3) array_like, optional
        The spacecraft's inertia (kg m^2; default the run's ``traj.inertia``): a run that did not
        record ``tau_gravity_gradient_B`` (the loop records it, by name, since issue 26's part 4;
        a result saved before), with the position ``r_N`` recorded, has the gravity gradient
        ``3 mu / |r|^5 b x J b`` (``b = R^T r_N``) computed from it in the disturbance budget as
        ``gravity_gradient``.
    mu : float
        The Earth's gravitational parameter for it (m^3/s^2).

    Returns
    -------
    dict
        ``settle_deg``; ``settle_time_s``: the first record time from which the attitude error
        ``4 atan |sigma_BR|`` stays below ``settle_deg`` to the end, every record from it on
        taken in a pointing mode (one whose control law writes ``sigma_BR``:
        ``meta["pointing_modes"]``; a mode with no law, a detumble, clears ``sigma_BR`` to zero,
        which is no error); ``None`` if it never does; ``not_settled``: why not (``None`` when
        settled): ``"never left <mode>"`` (the initial mode, by name, has no control law),
        ``"ended in <mode>, a mode with no control law"``, ``"above <settle_deg> deg at the
        end"``, ``"no control law wrote sigma_BR"``; ``error_deg``: ``mean``, ``p95`` (95th
        percentile), ``max`` of the error over the records from the settle time on (``None``
        when not settled); ``error_final_deg``: the error at the last record (``None`` when it
        was taken in a mode with no control law); ``rate_final_deg_s``: ``|omega|`` at the last
        saved state; ``rate_error_final_deg_s``: ``|omega_BR_B|`` at the last record (``None``
        when it was taken in a mode with no control law);
        ``wheel_momentum_peak_Nms``: the largest ``|Js_i (a_i . omega + Omega_i)|`` of any wheel
        over the saved states, ``wheel_momentum_total_peak_Nms``: the largest norm of their sum
        ``sum_i a_i h_i`` (body frame), ``wheel_momentum_final_Nms`` that norm at the end;
        ``modes``: the modes visited, in order, with the time each was entered and its name
        (``name``: the ``ModeRules``' names, else ``"mode <index>"``);
        ``detumble_time_s``: the time the mode manager first left its initial mode (the detumble
        of a mission that starts in it; ``None`` without modes or if it never left);
        ``control_error_deg``: the true pointing error, the angle of ``R_ref^T R`` (the truth
        against the guidance's reference, whatever the controller reads), and
        ``knowledge_error_deg``: the estimator's true error ``|est_error|``, each ``mean``,
        ``p95``, ``max`` over the records from the settle time on (``None`` when not settled
        or not recorded); ``disturbances``: for each disturbance torque recorded
        (``tau_<kind>_B``), its largest and RMS norm (N m) and the momentum it adds in the body
        frame, ``|integral tau dt|`` (N m s, trapezoid over the records); ``knowledge`` (where an
        estimator recorded ``est_error``, see
        :func:`knowledge_summary`); with an estimator the control law points the estimate, so
        ``error_deg`` is the error it sees and ``true_error_deg`` (``mean``, ``p95``, ``max`` from
        the settle time on; ``R_ref``, ``R_est`` and ``est_error`` recorded) that of the truth.
    """
    import math

    if not (isinstance(settle_deg, (int, float)) and math.isfinite(settle_deg) and settle_deg > 0):
        raise ValueError(f"settle_deg must be a positive number of degrees, got {settle_deg!r}")
    sig, ts = traj.signals, np.asarray(traj.signal_t)
    out: dict[str, Any] = {"settle_deg": float(settle_deg), "settle_time_s": None, "error_deg": None,
                           "error_final_deg": None, "rate_error_final_deg_s": None, "records": int(len(ts))}
    omega = np.asarray(traj.omega)
    out["rate_final_deg_s"] = float(np.degrees(np.linalg.norm(omega[-1]))) if len(omega) else None
    out["not_settled"] = None
    if "sigma_BR" in sig and len(ts):
        err = np.degrees(4.0 * np.arctan(np.linalg.norm(sig["sigma_BR"], axis=1)))
        pointing = pointing_records(traj, sig, len(ts))
        out["error_final_deg"] = float(err[-1]) if pointing[-1] else None
        above = np.flatnonzero(~(err < settle_deg) | ~pointing)   # a mode with no law is not settled
        first = 0 if not above.size else int(above[-1]) + 1
        if first < len(err):
            tail = err[first:]
            out["settle_time_s"] = float(ts[first])
            out["error_deg"] = {"mean": float(tail.mean()), "p95": float(np.percentile(tail, 95.0)),
                                "max": float(tail.max())}
        elif pointing[-1]:
            out["not_settled"] = f"above {settle_deg:g} deg at the end"
        else:
            from ..fsw import mode_label

            m = np.asarray(sig["mode"]).reshape(len(ts), -1)[:, 0]
            out["not_settled"] = (f"never left {mode_label(traj, m[0])}" if np.all(m == m[0]) else
                                  f"ended in {mode_label(traj, m[-1])}, a mode with no control law")
    else:
        out["not_settled"] = "no control law wrote sigma_BR"
    if "omega_BR_B" in sig and len(ts) and ("sigma_BR" not in sig or out["error_final_deg"] is not None):
        out["rate_error_final_deg_s"] = float(np.degrees(np.linalg.norm(sig["omega_BR_B"][-1])))
    speed = getattr(traj, "wheel_speed", None)
    if wheels is None and np.size(getattr(traj, "wheel_axes", ())):
        wheels = _Wheels(np.asarray(traj.wheel_axes), np.asarray(traj.spin_inertia))   # the run's own wheels
    if wheels is not None and speed is not None and len(omega):
        axes = np.asarray(wheels.axes)
        hw = np.asarray(wheels.spin_inertia) * (omega @ axes.T + np.asarray(speed))      # (M, N)
        out["wheel_momentum_peak_Nms"] = float(np.abs(hw).max())
        out["wheel_momentum_total_peak_Nms"] = float(np.linalg.norm(hw @ axes, axis=1).max())
        out["wheel_momentum_final_Nms"] = float(np.linalg.norm(hw[-1] @ axes))
    out["detumble_time_s"] = None

    if "est_error" in sig and len(ts):
        out["knowledge"] = knowledge_summary(sig)
        if out["settle_time_s"] is not None and "R_ref" in sig and "R_est" in sig:
            from ..so3 import exp, log

            # the controller points the estimate (sigma_BR); the truth is R = R_est Exp(est_error)
            k = int(np.searchsorted(ts, out["settle_time_s"]))
            R_ref = np.asarray(sig["R_ref"])[k:].reshape(-1, 3, 3)
            R_est = np.asarray(sig["R_est"])[k:].reshape(-1, 3, 3)
            # records where a guidance law wrote a reference and the filter an estimate (a mode without
            # guidance, a detumble, leaves R_ref zero)
            live = (np.linalg.det(R_ref) > 0.5) & (np.linalg.det(R_est) > 0.5)
            if live.any():
                R = R_est[live] @ exp(np.asarray(sig["est_error"])[k:][live])
                true = np.degrees(np.linalg.norm(log(np.swapaxes(R_ref[live], 1, 2) @ R), axis=1))
                out["true_error_deg"] = {"mean": float(true.mean()), "p95": float(np.percentile(true, 95.0)),
                                         "max": float(true.max())}
    if "mode" in sig and len(ts):
        m = np.asarray(sig["mode"]).reshape(len(ts), -1)[:, 0]
        start = np.concatenate([[0], np.flatnonzero(np.diff(m)) + 1])
        from ..fsw import mode_label

        out["modes"] = [{"mode": int(m[i]), "name": mode_label(traj, m[i]), "from_s": float(ts[i])} for i in start]
        if len(start) > 1:
            out["detumble_time_s"] = float(ts[start[1]])
    window = slice(None) if out["settle_time_s"] is None else slice(int(np.searchsorted(ts, out["settle_time_s"])),
                                                                      None)
    out["control_error_deg"] = out["knowledge_error_deg"] = None
    R = np.asarray(getattr(traj, "R", np.zeros((0, 3, 3))))
    if out["settle_time_s"] is not None and "R_ref" in sig and len(R):
        at = np.searchsorted(np.asarray(traj.t), ts[window])           # the saved states at the records
        R_ref = np.asarray(sig["R_ref"])[window].reshape(-1, 3, 3)
        cos = np.clip((np.einsum("nij,nij->n", R_ref, R[at]) - 1.0) / 2.0, -1.0, 1.0)     # tr(R_ref^T R)
        out["control_error_deg"] = _stats(np.degrees(np.arccos(cos)))
    if out["settle_time_s"] is not None and "est_error" in sig:
        out["knowledge_error_deg"] = _stats(np.degrees(np.linalg.norm(np.asarray(sig["est_error"])[window], axis=1)))
    out["disturbances"] = {}
    torques = {name[4:-2]: np.asarray(sig[name]) for name in sorted(sig) if name.startswith("tau_")
               and name.endswith("_B") and name not in ("tau_dist_B", "tau_control_B", "tau_command_B")}
    if inertia is not None:
        from .._validation import as_float_array

        inertia = as_float_array(inertia, "inertia", (3, 3))
    inertia = getattr(traj, "inertia", None) if inertia is None else inertia
    if "gravity_gradient" not in torques and inertia is not None and "r_N" in sig and len(R):
        J = np.asarray(inertia, dtype=np.float64)
        r = np.asarray(sig["r_N"])
        b = np.einsum("nji,nj->ni", R[np.searchsorted(np.asarray(traj.t), ts)], r)      # R^T r_N
        torques["gravity_gradient"] = 3.0 * mu / np.linalg.norm(r, axis=1)[:, None] ** 5 * np.cross(b, b @ J.T)
    for name, tau in torques.items():
        if len(ts) > 1:
            norm = np.linalg.norm(tau, axis=1)
            out["disturbances"][name] = {
                "max_Nm": float(norm.max()), "rms_Nm": float(np.sqrt(np.mean(norm ** 2))),
                "momentum_Nms": float(np.linalg.norm(0.5 * (np.diff(ts)[:, None] * (tau[1:] + tau[:-1])).sum(axis=0)))}
    return out


def pointing_records(traj: Any, sig: dict[str, np.ndarray], n: int) -> np.ndarray:
    """(n,) bool: the records taken in a pointing mode, one in which a control law writes
    ``sigma_BR`` (``meta["pointing_modes"]``; every record without modes recorded). In a mode with
    no law ``sigma_BR`` is cleared to zero, which is no error. A run saved before lgvi wrote
    ``pointing_modes``: the modes in which ``sigma_BR`` was ever non-zero."""
    if "mode" not in sig:
        return np.ones(n, dtype=bool)
    m = np.asarray(sig["mode"]).reshape(n, -1)[:, 0]
    meta = getattr(traj, "meta", None) or {}
    if "pointing_modes" in meta:
        modes = meta["pointing_modes"]
        return np.ones(n, dtype=bool) if modes is None else np.isin(m, np.asarray(modes, dtype=float))
    live = np.any(np.asarray(sig["sigma_BR"]) != 0.0, axis=1)
    return np.isin(m, np.unique(m[live]))


@dataclass(frozen=True)
class _Wheels:
    axes: np.ndarray
    spin_inertia: np.ndarray


def _stats(x: np.ndarray) -> dict[str, float] | None:
    if not len(x):
        return None
    return {"mean": float(x.mean()), "p95": float(np.percentile(x, 95.0)), "max": float(x.max())}

ARCSEC = 180.0 / np.pi * 3600.0       # arcseconds per radian


def knowledge_summary(sig: dict[str, np.ndarray]) -> dict[str, Any]:
    """Attitude knowledge statistics from an estimator's records (``est_error``, ``R = R_est
    Exp(est_error)``; ``P_diag``, its covariance diagonal, when recorded).

    Returns
    -------
    dict
        ``error_arcsec``: ``mean``, ``p95``, ``max`` and ``final`` of the angle ``|est_error|``
        over all records, and ``steady``: the same over the second half of the records (after the
        filter's transient); ``rms_axis_arcsec``: the RMS of each body-axis component over the
        second half; where ``P_diag`` was recorded, ``sigma3_final_arcsec``: ``3 sqrt(P_diag[:3])``
        at the last record and ``inside_3sigma``: the fraction of axis components within their
        3-sigma bound, over all records and over the second half.
    """
    e = np.asarray(sig["est_error"], dtype=float) * ARCSEC
    ang = np.linalg.norm(e, axis=1)
    half = len(ang) // 2

    def stats(a: np.ndarray) -> dict[str, float]:
        return {"mean": float(a.mean()), "p95": float(np.percentile(a, 95.0)), "max": float(a.max()),
                "final": float(a[-1])}

    out: dict[str, Any] = {"error_arcsec": {**stats(ang), "steady": stats(ang[half:])},
                           "rms_axis_arcsec": np.sqrt(np.mean(e[half:] ** 2, axis=0)).tolist()}
    if "P_diag" in sig:
        s3 = 3.0 * np.sqrt(np.maximum(np.asarray(sig["P_diag"], dtype=float)[:, :3], 0.0)) * ARCSEC
        inside = np.abs(e) <= s3
        out["sigma3_final_arcsec"] = s3[-1].tolist()
        out["inside_3sigma"] = {"all": float(inside.mean()), "steady": float(inside[half:].mean())}
    return out


def mode_text(m: dict[str, Any]) -> str:
    """A mode of the summary: its name and index (``sun-safe (1)``), or ``mode 1`` when unnamed."""
    name = m.get("name")
    return f"{name} ({m['mode']})" if name and name != f"mode {m['mode']}" else f"mode {m['mode']}"


def summary_lines(s: dict[str, Any]) -> list[str]:
    """The lines of ``summary.txt`` for :func:`loop_summary`'s ``s``."""
    lines = []
    why = s.get("not_settled")
    if s["settle_time_s"] is None and s["error_final_deg"] is None:
        lines.append(f"pointing:      not settled: {why or 'no control law wrote sigma_BR'}")
    elif s["settle_time_s"] is None:
        lines.append(f"pointing:      not settled below {s['settle_deg']:g} deg (final error "
                     f"{s['error_final_deg']:.3g} deg)")
    else:
        e = s["error_deg"]
        lines.append(f"pointing:      settled below {s['settle_deg']:g} deg at t = {s['settle_time_s']:g} s; error "
                     f"after it mean {e['mean']:.3g}, 95th percentile {e['p95']:.3g}, max {e['max']:.3g} deg")
    if s.get("true_error_deg") is not None:
        e = s["true_error_deg"]
        lines.append(f"               (the estimate's; the truth's after it: mean {e['mean']:.3g}, 95th percentile "
                     f"{e['p95']:.3g}, max {e['max']:.3g} deg)")
    rate = f"final rate:    |omega| {s['rate_final_deg_s']:.4g} deg/s"
    if s["rate_error_final_deg_s"] is not None:
        rate += f", |omega_BR| {s['rate_error_final_deg_s']:.3g} deg/s"
    lines.append(rate)
    if "wheel_momentum_peak_Nms" in s:
        lines.append(f"wheels:        momentum peak {s['wheel_momentum_peak_Nms']:.4g} N m s (one wheel), "
                     f"{s['wheel_momentum_total_peak_Nms']:.4g} N m s (all, body frame)")
    k = s.get("knowledge")
    if k is not None:
        e, st = k["error_arcsec"], k["error_arcsec"]["steady"]
        lines.append(f"knowledge:     |est_error| mean {e['mean']:.3g}, 95th percentile {e['p95']:.3g}, max "
                     f"{e['max']:.3g}, final {e['final']:.3g} arcsec; second half mean {st['mean']:.3g}, 95th "
                     f"percentile {st['p95']:.3g} arcsec, RMS per axis "
                     + ", ".join(f"{v:.3g}" for v in k["rms_axis_arcsec"]) + " arcsec")
        if "inside_3sigma" in k:
            lines.append(f"               inside 3 sigma {k['inside_3sigma']['all']:.1%} of axis values "
                         f"({k['inside_3sigma']['steady']:.1%} in the second half); final 3 sigma "
                         + ", ".join(f"{v:.3g}" for v in k["sigma3_final_arcsec"]) + " arcsec")
    if s.get("modes"):
        lines.append("modes:         " + ", ".join(f"{mode_text(m)} from {m['from_s']:g} s" for m in s["modes"]))
    if s.get("detumble_time_s") is not None:
        lines.append(f"detumble:      left {mode_text(s['modes'][0])} at t = {s['detumble_time_s']:g} s")
    for key, what in (("control_error_deg", "control error (truth vs reference)"),
                      ("knowledge_error_deg", "knowledge error (estimate vs truth)")):
        if s.get(key) is not None:
            e = s[key]
            lines.append(f"{what}: mean {e['mean']:.3g}, 95th percentile {e['p95']:.3g}, max {e['max']:.3g} deg "
                         "after settling")
    if s.get("wheel_momentum_final_Nms") is not None:
        lines.append(f"wheels:        momentum at the end {s['wheel_momentum_final_Nms']:.4g} N m s (all, body frame)")
    if s.get("disturbances"):
        lines.append("disturbances:  " + "; ".join(
            f"{k} max {d['max_Nm']:.2e} N m, rms {d['rms_Nm']:.2e} N m, momentum {d['momentum_Nms']:.2e} N m s"
            for k, d in s["disturbances"].items()))
    return lines


__all__ += ["loop_summary", "knowledge_summary", "summary_lines", "pointing_records", "mode_text", "SETTLE_DEG"]
