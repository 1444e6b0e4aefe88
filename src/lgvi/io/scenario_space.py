"""Scenario sections of the spacecraft's environment (issue 12): ``[orbit]``, ``[field]``,
``[[magnetorquer]]`` and the ``"bdot"`` controller, read by :mod:`lgvi.scenario`.

::

    [orbit]                              # what drives the environment (lgvi.environment)
    type = "circular"                    # "circular" (radius), "kepler" or "j2" (a, e, arg_perigee,
    radius = 6871e3                      # mean_anomaly), "sgp4" (line1, line2); angles in degrees
    inclination = 97.4                   # optional, default 0 (also raan; arg_latitude for circular)
    epoch = 2026-03-20T00:00:00Z         # UTC of t = 0 (TOML date-time); default an SGP4 TLE's epoch

    [field]                              # needs [orbit]
    model = "igrf"                       # "igrf" (IGRF-14), "wmm" (WMM2025) or "dipole"
    degree = 13                          # optional truncation

    [[magnetorquer]]                     # one table per rod; needs a controller returning a dipole
    axis = [1.0, 0.0, 0.0]
    max_dipole = 0.2                     # [A m^2]

    [controller]
    type = "bdot"                        # B-dot: gain [A m^2 s / T], derivative "difference" or "rate"
    gain = 5e4
    period = 1.0
"""

from __future__ import annotations

import datetime as _dt
import math
from typing import Any

import numpy as np

ORBIT_KEYS = {"circular": ("radius", "inclination", "raan", "arg_latitude"),
              "kepler": ("a", "e", "inclination", "raan", "arg_perigee", "mean_anomaly"),
              "j2": ("a", "e", "inclination", "raan", "arg_perigee", "mean_anomaly"),
              "sgp4": ("line1", "line2")}
FIELD_MODELS = ("igrf", "wmm", "dipole")
BDOT_KEYS = ("gain", "derivative")
_ANGLES = ("inclination", "raan", "arg_latitude", "arg_perigee", "mean_anomaly")


def environment(c: Any, d: dict[str, Any]) -> Any:
    """``[orbit]`` and ``[field]``: an :class:`lgvi.environment.OrbitEnvironment`, or ``None``."""
    from .. import environment as env

    if "field" in d and "orbit" not in d:
        raise c.error("field", "a field is evaluated along an orbit: add an [orbit] table")
    if "orbit" not in d:
        return None
    tbl = d["orbit"]
    if not isinstance(tbl, dict) or "type" not in tbl:
        raise c.expected("orbit.type", "one of " + ", ".join(f'"{t}"' for t in ORBIT_KEYS))
    kind = c.string(tbl["type"], "orbit.type", tuple(ORBIT_KEYS))
    c.table(tbl, "orbit", ("type", "epoch") + ORBIT_KEYS[kind])
    try:
        if kind == "sgp4":
            for k in ("line1", "line2"):
                if k not in tbl:
                    raise c.expected(f"orbit.{k}", "a string (a TLE line)")
            orbit = env.SGP4Orbit(c.string(tbl["line1"], "orbit.line1"), c.string(tbl["line2"], "orbit.line2"))
        else:
            first = "radius" if kind == "circular" else "a"
            if first not in tbl:
                raise c.expected(f"orbit.{first}", "a positive number (m)")
            kw = {k: c.number(tbl[k], f"orbit.{k}") for k in ORBIT_KEYS[kind] if k in tbl}
            kw = {k: math.radians(v) if k in _ANGLES else v for k, v in kw.items()}
            orbit = {"circular": env.CircularOrbit, "kepler": env.KeplerOrbit, "j2": env.J2Orbit}[kind](**kw)
    except (ValueError, TypeError) as exc:
        if type(exc).__name__ == "ScenarioError":
            raise
        raise c.error("orbit", f"invalid {kind} orbit: {exc}") from None
    epoch = None
    if "epoch" in tbl:
        epoch = tbl["epoch"]
        if isinstance(epoch, str):
            try:
                epoch = _dt.datetime.fromisoformat(epoch)
            except ValueError:
                raise c.expected("orbit.epoch", "a date-time (UTC), e.g. 2026-03-20T00:00:00Z", tbl["epoch"]) from None
        if not isinstance(epoch, _dt.datetime):
            raise c.expected("orbit.epoch", "a date-time (UTC), e.g. 2026-03-20T00:00:00Z", epoch)
    field = None
    if "field" in d:
        ftbl = c.table(d["field"], "field", ("model", "degree"))
        if "model" not in ftbl:
            raise c.expected("field.model", "one of " + ", ".join(f'"{m}"' for m in FIELD_MODELS))
        model = c.string(ftbl["model"], "field.model", FIELD_MODELS)
        kw = {"degree": c.integer(ftbl["degree"], "field.degree", minimum=1)} if "degree" in ftbl else {}
        try:
            if model == "dipole":
                if kw:
                    raise c.error("field.degree", "the dipole has degree 1; remove degree")
                field = env.CentredDipole()
            else:
                field = (env.IGRF if model == "igrf" else env.WMM)(**kw)
        except (ValueError, ModuleNotFoundError, FileNotFoundError) as exc:
            if type(exc).__name__ == "ScenarioError":
                raise
            raise c.error("field", f"invalid {model} field: {exc}") from None
        if epoch is None and getattr(orbit, "epoch", None) is None:
            raise c.expected("orbit.epoch", "a date-time (UTC) of t = 0: the field needs a date")
    try:
        return env.OrbitEnvironment(orbit, field, epoch=epoch)
    except (ValueError, TypeError) as exc:
        raise c.error("orbit.epoch", str(exc)) from None


def magnetorquers(c: Any, entries: Any) -> Any:
    """``[[magnetorquer]]``: one :class:`lgvi.Magnetorquers` of all the rods."""
    from ..environment import Magnetorquers

    if isinstance(entries, dict):
        raise c.error("magnetorquer", "expected an array of tables: write [[magnetorquer]] (double brackets) "
                      "for each rod")
    if not isinstance(entries, list) or not entries:
        raise c.expected("magnetorquer", "an array of tables ([[magnetorquer]] sections)", entries)
    axes, limits = [], []
    for i, entry in enumerate(entries):
        key = f"magnetorquer[{i}]"
        c.table(entry, key, ("axis", "max_dipole"))
        for k in ("axis", "max_dipole"):
            if k not in entry:
                raise c.expected(f"{key}.{k}", "an array of 3 numbers" if k == "axis" else "a positive number")
        axes.append(c.vector(entry["axis"], f"{key}.axis"))
        limits.append(c.number(entry["max_dipole"], f"{key}.max_dipole", positive=True))
    try:
        return Magnetorquers(np.array(axes), np.array(limits))
    except ValueError as exc:
        raise c.error("magnetorquer", f"invalid magnetorquers: {exc}") from None


def bdot(c: Any, tbl: dict[str, Any]) -> Any:
    """The ``"bdot"`` controller of ``[controller]`` (its ``gain`` and ``derivative``)."""
    from ..environment import BDot

    if "gain" not in tbl:
        raise c.expected("controller.gain", "a positive number (A m^2 s / T)")
    return BDot(c.number(tbl["gain"], "controller.gain", positive=True),
                derivative=c.string(tbl.get("derivative", "difference"), "controller.derivative",
                                    ("difference", "rate")))
