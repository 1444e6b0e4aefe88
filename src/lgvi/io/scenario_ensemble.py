"""The ``[ensemble]`` section of a spacecraft scenario: a Monte Carlo of the file's mission.

::

    [ensemble]
    members = 100                        # B >= 1
    seed = 2026                          # member b draws from numpy.random.default_rng((seed, b))
    threads = 2                          # optional (default: one per core)

    [[ensemble.dispersion]]              # applied in order, each to one key of the file
    key = "initial"                      # the initial attitude: turned by a rotation of
    rotation = 5.0                       #   5 deg rms per axis (or random = true: uniform on SO(3))
    [[ensemble.dispersion]]
    key = "initial.omega"                # a number or an array of numbers:
    normal = 0.001                       #   nominal + N(0, sigma), each entry drawn
    [[ensemble.dispersion]]
    key = "spacecraft.body.inertia"
    scale = [0.95, 1.05]                 #   nominal x U(lo, hi), each entry drawn
    [[ensemble.dispersion]]
    key = "spacecraft.disturbance[0].drag_coefficient"
    uniform = [2.0, 2.4]                 #   U(lo, hi) (the nominal may be absent: a number)
    [[ensemble.dispersion]]
    key = "spacecraft.wheel[0].axis"     # a 3-vector or a 3x3 matrix:
    rotation = 0.5                       #   turned by a rotation of sigma deg rms per axis
    [[ensemble.dispersion]]              # the principal moments' axes (after their scale):
    key = "spacecraft.body.inertia"      #   body.matrix = Q diag(inertia) Q^T
    rotation = 1.0
    [[ensemble.dispersion]]
    key = "spacecraft.sensor[0].seed"    # an integer:
    sequence = 1000                      #   1000 + b

Member ``b`` is the file with its drawn values put in place, read again by the same reader (so a
drawn value is checked as a written one would be, and an error names the member, the key and the
rule), and every member's run is built before any step runs (what the loop refuses is named
then). A member's draws depend on ``seed`` and ``b`` only: member ``b`` is the same whatever
``members`` is. ``lgvi run`` runs the members in the compiled loop in threads
(:func:`lgvi.simulate_ensemble` with one spacecraft and flight software per member), saves the
ensemble (``ensemble.npz``, read by :func:`lgvi.io.outputs.read_trajectory`) and summarises each member
(:func:`lgvi.io.scenario_loop.loop_summary`) and the ensemble (:func:`ensemble_summary`).
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Dispersion", "EnsembleSpec", "LAWS", "read_ensemble", "member_tables", "ensemble_summary",
           "ensemble_lines"]

#: The laws of a dispersion: the key of its table -> what it draws.
LAWS: dict[str, str] = {
    "uniform": "[lo, hi]: U(lo, hi) for each entry of the value (a number where the file has none)",
    "scale": "[lo, hi]: the nominal value times U(lo, hi), each entry drawn",
    "normal": "sigma >= 0: the nominal value plus N(0, sigma), each entry drawn",
    "rotation": "sigma >= 0 degrees: a 3-vector, a 3x3 matrix (Q M Q^T), the principal moments body.inertia "
                "(their axes: the body.matrix Q diag(J) Q^T) or the initial attitude turned by exp(N(0, sigma) per "
                "axis)",
    "random": "true: the initial attitude uniform on SO(3)",
    "sequence": "an integer n0 >= 0: n0 + b for member b (noise seeds)",
}
_ENSEMBLE = ("members", "seed", "threads", "dispersion")
_PART = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


@dataclass(frozen=True)
class Dispersion:
    """One ``[[ensemble.dispersion]]``: the file key, its law (a key of :data:`LAWS`) and the law's value."""

    key: str
    law: str
    value: Any
    path: tuple[tuple[str, int | None], ...]


@dataclass(frozen=True)
class EnsembleSpec:
    """The checked ``[ensemble]`` section."""

    members: int
    seed: int
    threads: int | None
    dispersions: tuple[Dispersion, ...]


def _path(c: Any, key: str, where: str) -> tuple[tuple[str, int | None], ...]:
    parts = []
    for part in key.split("."):
        m = _PART.match(part)
        if m is None:
            raise c.error(where, f"expected a dotted key of the file such as 'fsw.control[0].K' or "
                          f"'spacecraft.disturbance[1].dipole'; got {key!r}")
        parts.append((m.group(1), None if m.group(2) is None else int(m.group(2))))
    return tuple(parts)


def _locate(c: Any, d: dict[str, Any], disp: Dispersion, where: str) -> tuple[dict[str, Any], str]:
    """The table holding the dispersed key, and the key (its value need not be there for
    ``uniform`` and ``sequence``); refuses a path that is not in the file."""
    *head, (last, last_index) = disp.path
    if last_index is not None:             # "spacecraft.wheel[0]" and the like: a table, not a key
        raise c.error(where, f"{disp.key!r}: a dispersion names a key of a table (an array as a whole), not an "
                      "entry of an array")
    node: Any = d
    walked: list[str] = []
    for name, index in head:
        walked.append(name if index is None else f"{name}[{index}]")
        if not isinstance(node, dict) or name not in node:
            raise c.error(where, f"{disp.key!r}: the file has no {'.'.join(walked)!r}; a dispersion changes a key "
                          "of a table the file has")
        node = node[name]
        if index is not None:
            if not isinstance(node, list) or index >= len(node):
                raise c.error(where, f"{disp.key!r}: {'.'.join(walked)!r} is not in the file (it has "
                              f"{len(node) if isinstance(node, list) else 'no'} such tables)")
            node = node[index]
    if not isinstance(node, dict):
        raise c.error(where, f"{disp.key!r}: {'.'.join(walked) or 'the file'!r} is not a table")
    if disp.law in ("scale", "normal", "rotation") and last not in node and disp.key != "initial":
        raise c.error(where, f"{disp.key!r}: the law {disp.law!r} changes the file's value, and the file gives none; "
                      "give the nominal value in the file (or draw it with uniform = [lo, hi])")
    return node, last


def read_ensemble(c: Any, tbl: Any, d: dict[str, Any]) -> EnsembleSpec:
    """Check the ``[ensemble]`` table of the scenario ``d`` (errors name the file and the key)."""
    tbl = c.table(tbl, "ensemble", _ENSEMBLE)
    if "members" not in tbl:
        raise c.error("ensemble.members", "missing; expected the number of members (an integer >= 1)")
    members = c.integer(tbl["members"], "ensemble.members", minimum=1)
    seed = c.integer(tbl.get("seed", 0), "ensemble.seed", minimum=0)
    threads = c.integer(tbl["threads"], "ensemble.threads", minimum=1) if "threads" in tbl else None
    raw = tbl.get("dispersion", [])
    if not isinstance(raw, list):
        raise c.expected("ensemble.dispersion", "an array of tables [[ensemble.dispersion]]", raw)
    out = []
    for i, item in enumerate(raw):
        where = f"ensemble.dispersion[{i}]"
        item = c.table(item, where, ("key",) + tuple(LAWS))
        if "key" not in item:
            raise c.error(f"{where}.key", "missing; expected the dotted key of the file it disperses")
        key = c.string(item["key"], f"{where}.key")
        laws = [k for k in item if k in LAWS]
        if len(laws) != 1:
            raise c.error(where, f"expected exactly one law of {', '.join(LAWS)}; got "
                          f"{', '.join(laws) if laws else 'none'}")
        law = laws[0]
        value = _law_value(c, law, item[law], f"{where}.{law}")
        path = _path(c, key, f"{where}.key")
        if (law in ("random",) or (law == "rotation" and key == "initial")) and key != "initial":
            raise c.error(f"{where}.{law}", f"random = true draws the initial attitude: key = \"initial\"; got {key!r}")
        if key == "initial" and law not in ("rotation", "random"):
            raise c.error(f"{where}.{law}", "the initial attitude takes rotation = sigma (degrees) or random = true")
        disp = Dispersion(key, law, value, path)
        if key != "initial":
            _locate(c, d, disp, f"{where}.key")
        turned = [j for j, o in enumerate(out) if o.key == key and o.law == "rotation" and path[-1][0] == "inertia"]
        if turned:
            raise c.error(where, f"{key!r} is turned by ensemble.dispersion[{turned[0]}] (its axes: it becomes "
                          "body.matrix); give the dispersions of the principal moments before the rotation")
        out.append(disp)
    return EnsembleSpec(members, seed, threads, tuple(out))


def _law_value(c: Any, law: str, value: Any, where: str) -> Any:
    if law in ("uniform", "scale"):
        if not (isinstance(value, list) and len(value) == 2):
            raise c.expected(where, "[lo, hi], two numbers with lo <= hi", value)
        lo, hi = (c.number(v, f"{where}[{j}]") for j, v in enumerate(value))
        if not lo <= hi:
            raise c.error(where, f"expected lo <= hi; got [{lo:g}, {hi:g}]")
        return lo, hi
    if law in ("normal", "rotation"):
        return c.number(value, where, nonnegative=True)
    if law == "random":
        if value is not True:
            raise c.expected(where, "true (the attitude uniform on SO(3))", value)
        return True
    return c.integer(value, where, minimum=0)


def _draw(disp: Dispersion, nominal: Any, rng: np.random.Generator, b: int, c: Any, where: str) -> Any:
    """The member's value of the key (a TOML-able number or nested list)."""
    from ..so3 import exp

    if disp.law == "sequence":
        return int(disp.value) + b
    if disp.law == "uniform":
        lo, hi = disp.value
        shape = np.shape(nominal) if nominal is not None else ()
        return np.asarray(rng.uniform(lo, hi, shape)).tolist()
    try:
        x = np.asarray(nominal, dtype=np.float64)
    except (TypeError, ValueError):
        raise c.error(where, f"{disp.key!r}: the law {disp.law!r} draws numbers, and the file's value is "
                      f"{nominal!r}") from None
    if disp.law == "scale":
        lo, hi = disp.value
        return (x * rng.uniform(lo, hi, x.shape)).tolist()
    if disp.law == "normal":
        return (x + rng.normal(0.0, disp.value, x.shape)).tolist()
    Q = exp(rng.normal(0.0, math.radians(disp.value), 3))          # rotation
    if x.shape == (3,) and disp.path[-1][0] == "inertia":           # principal moments: their axes turn
        return (Q @ np.diag(x) @ Q.T).tolist()
    if x.shape == (3,):
        return (Q @ x).tolist()
    if x.shape == (3, 3):
        return (Q @ x @ Q.T).tolist()
    raise c.error(where, f"{disp.key!r}: rotation turns a 3-vector or a 3x3 matrix; the file's value has shape "
                  f"{x.shape}")


def member_tables(c: Any, d: dict[str, Any], spec: EnsembleSpec, b: int) -> tuple[dict[str, Any], Any]:
    """Member ``b``'s scenario tables (a deep copy of ``d`` without ``[ensemble]``, its drawn values
    in place) and ``attitude(R0) -> R0_b``: its initial attitude from the one its tables give
    (turned, or drawn uniformly, where ``key = "initial"`` is dispersed)."""
    from scipy.spatial.transform import Rotation

    from ..so3 import exp

    rng = np.random.default_rng((spec.seed, b))
    out = copy.deepcopy({k: v for k, v in d.items() if k != "ensemble"})
    ops: list[tuple[str, np.ndarray]] = []
    for i, disp in enumerate(spec.dispersions):
        where = f"ensemble.dispersion[{i}]"
        if disp.key == "initial":
            if disp.law == "random":
                ops.append(("set", Rotation.random(random_state=rng).as_matrix()))
            else:
                ops.append(("turn", exp(rng.normal(0.0, math.radians(disp.value), 3))))
            continue
        node, last = _locate(c, out, disp, f"{where}.key")
        value = _draw(disp, node.get(last), rng, b, c, where)
        if disp.law == "rotation" and last == "inertia" and np.shape(node[last]) == (3,):
            # the principal moments (body.inertia) with their axes turned: the matrix Q diag(J) Q^T
            del node[last]
            node["matrix"] = value
        else:
            node[last] = value

    def attitude(R0: np.ndarray) -> np.ndarray:
        R = np.array(R0, dtype=np.float64)
        for op, M in ops:
            R = M if op == "set" else R @ M
        return R

    return out, attitude


def _finite(values: list[Any]) -> np.ndarray:
    return np.array([np.nan if v is None else float(v) for v in values])


def ensemble_summary(summaries: list[dict[str, Any]]) -> dict[str, Any]:
    """Statistics over the members of :func:`lgvi.io.scenario_loop.loop_summary`'s results:
    ``members``, ``settled`` (how many settled: reached a pointing mode and stayed within the
    threshold), ``not_settled`` (how many did not, by why: ``{"never left detumble": 3, ...}``,
    the members' ``not_settled``), and for the settle time, the pointing error after
    it (each member's mean, p95 and max), the final error and the final rate: ``mean``, ``std``,
    ``min``, ``p95``, ``max`` over the members that have it, with ``n`` their count."""
    def stats(x: np.ndarray) -> dict[str, Any] | None:
        x = x[np.isfinite(x)]
        if not x.size:
            return None
        return {"n": int(x.size), "mean": float(x.mean()), "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
                "min": float(x.min()), "p95": float(np.percentile(x, 95.0)), "max": float(x.max())}

    out: dict[str, Any] = {"members": len(summaries),
                           "settled": sum(s["settle_time_s"] is not None for s in summaries)}
    why = [s.get("not_settled") or "not settled" for s in summaries if s["settle_time_s"] is None]
    out["not_settled"] = {w: why.count(w) for w in dict.fromkeys(why)}
    out["settle_time_s"] = stats(_finite([s["settle_time_s"] for s in summaries]))
    for part in ("mean", "p95", "max"):
        out[f"error_{part}_deg"] = stats(_finite([None if s["error_deg"] is None else s["error_deg"][part]
                                                  for s in summaries]))
    out["error_final_deg"] = stats(_finite([s["error_final_deg"] for s in summaries]))
    out["rate_final_deg_s"] = stats(_finite([s["rate_final_deg_s"] for s in summaries]))
    if all("wheel_momentum_peak_Nms" in s for s in summaries):
        out["wheel_momentum_peak_Nms"] = stats(_finite([s["wheel_momentum_peak_Nms"] for s in summaries]))
    return out


def ensemble_lines(s: dict[str, Any]) -> list[str]:
    """The lines of an ensemble's ``summary.txt`` for :func:`ensemble_summary`'s ``s``."""
    lines = [f"members:       {s['members']}, settled {s['settled']}"
             + "".join(f"; {why} {n}" for why, n in (s.get("not_settled") or {}).items())]
    names = (("settle_time_s", "settle time", "s"), ("error_mean_deg", "error after settling, mean", "deg"),
             ("error_p95_deg", "error after settling, p95", "deg"), ("error_max_deg", "error after settling, max",
                                                                     "deg"),
             ("error_final_deg", "final error", "deg"), ("rate_final_deg_s", "final rate", "deg/s"),
             ("wheel_momentum_peak_Nms", "wheel momentum peak", "N m s"))
    for key, what, unit in names:
        x = s.get(key)
        if x is not None:
            lines.append(f"  {what} [{unit}] over {x['n']}: mean {x['mean']:.4g}, std {x['std']:.3g}, min "
                         f"{x['min']:.4g}, 95th percentile {x['p95']:.4g}, max {x['max']:.4g}")
    return lines
