"""Step-doubling (Richardson) estimate of the global error of a run.

``simulate(..., error_estimate=True)`` runs the same problem a second time at ``h/2`` (the
*shadow* run: :func:`lgvi.simulate` itself, compiled, twice the steps) and compares the two at
every saved sample. For a scheme of order ``p`` the global error at a fixed time is
``e_h = C h^p + O(h^(p+1))``, so ``e_h - e_(h/2) = C h^p (1 - 2^-p)`` and

.. math::

    \\|e_h\\| \\approx \\frac{2^p}{2^p - 1}\\, d\\bigl(R_h, R_{h/2}\\bigr),
    \\qquad d(A, B) = \\bigl|\\log(A^T B)\\bigr| \\in [0, \\pi],

the geodesic distance on SO(3) (the angle of the rotation between the two attitudes), and the same
for the body momentum. ``p`` is 2 for the symmetric step (free body, potentials, ``forcing=
"symmetric"``), 1 for the paper's forcing of a non-conservative moment, 4 or 6 for the
compositions. The estimate holds in the asymptotic regime, where the error is small enough to
scale as ``h^p`` (below a few tenths of a radian); beyond that it only says that the error is large.

Why a shadow run rather than an embedded (per-step) estimate: a per-step estimate gives the
local error, but what a user looks at is the global error at the end, which accumulates (linearly
in time for the free body, faster for tumbling under a moment) and is not the sum of local errors.
The shadow run measures the global error directly, for every scheme and torque path, and costs
twice the steps of the run (about 3x its wall time in total).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from ._validation import as_float
from .errors import AccuracyWarning, ConvergenceError, SimulationInterrupted, TorqueError

#: Values of ``error_estimate`` that ask for the estimate.
ESTIMATES = ("richardson",)
#: Default ``error_warn``: warn above this estimated final attitude error [rad] (about 0.57 deg).
DEFAULT_WARN = 0.01
#: Above this difference [rad] between the runs the estimate is outside its asymptotic regime.
ASYMPTOTIC_LIMIT = 0.3


@dataclass(frozen=True)
class ErrorEstimate:
    """Richardson estimate of the global error of a run, from a shadow run at ``h/2``.

    Attributes
    ----------
    attitude : float
        Estimated attitude error at the final time [rad]: ``2^p / (2^p - 1)`` times the angle of
        the rotation between the final attitudes of the runs at ``h`` and ``h/2``.
    attitude_max : float
        The same estimate, largest over the saved samples [rad].
    t_attitude_max : float
        Time of that sample.
    momentum : float
        Estimated error of the final body momentum, ``2^p / (2^p - 1) |Pi_h - Pi_(h/2)|``
        [kg m^2/s].
    momentum_rel : float or None
        ``momentum`` divided by the largest ``|Pi|`` of the run (``None`` if the body never moves).
    order : int
        Order ``p`` of the scheme used in the factor.
    h : float
        Step of the run; the shadow run used ``h / 2``.
    wall_time_s : float
        Wall time of the shadow run [s].
    warn : float or None
        Threshold on ``attitude`` [rad] (and on ``position_rel``) above which
        :class:`lgvi.AccuracyWarning` is emitted (``None``: never).
    method : str
        ``"richardson"``.
    position : float or None
        For runs with an orbit (:func:`lgvi.simulate_orbit`: the position ``x``;
        :func:`lgvi.simulate_two_body`: the relative position ``x2 - x1``): the estimated error of
        the final position, ``2^p / (2^p - 1) |x_h - x_(h/2)|`` (length units); ``None`` otherwise.
        With two bodies ``attitude`` is the larger of the two bodies' estimates.
    position_rel : float or None
        ``position`` divided by the largest distance from the centre over the run.
    """

    attitude: float
    attitude_max: float
    t_attitude_max: float
    momentum: float
    momentum_rel: float | None
    order: int
    h: float
    wall_time_s: float
    warn: float | None = DEFAULT_WARN
    method: str = "richardson"
    position: float | None = None
    position_rel: float | None = None

    @property
    def factor(self) -> float:
        """Richardson factor ``2^p / (2^p - 1)``."""
        return 2.0 ** self.order / (2.0 ** self.order - 1.0)

    @property
    def asymptotic(self) -> bool:
        """Whether the two runs are close enough (``< ASYMPTOTIC_LIMIT`` rad apart everywhere)
        for the ``h^p`` error model, and so the estimate, to be trusted."""
        return self.attitude_max / self.factor < ASYMPTOTIC_LIMIT

    @property
    def worst(self) -> float:
        """The larger of ``attitude`` [rad] and ``position_rel`` (when there is a position)."""
        return max(self.attitude, self.position_rel or 0.0)

    @property
    def exceeds(self) -> bool:
        """``attitude > warn`` or ``position_rel > warn`` (``False`` when ``warn`` is ``None``)."""
        return self.warn is not None and self.worst > self.warn

    def step_for(self, target: float) -> float:
        """Step of the same scheme that would bring the final attitude error to about ``target``
        [rad], from the ``h^p`` scaling (meaningful only when :attr:`asymptotic`)."""
        target = as_float(target, "target", positive=True)
        if self.worst == 0.0:
            return self.h
        return self.h * (target / self.worst) ** (1.0 / self.order)

    def describe(self) -> str:
        """One sentence: the estimate, in rad and degrees."""
        regime = "" if self.asymptotic else (
            "; the runs at h and h/2 differ by more than 0.3 rad, so the error is too large for the "
            "h^p model and this figure is only an order of magnitude")
        rel = "" if self.momentum_rel is None else f" ({self.momentum_rel:.2g} relative)"
        where = "" if self.position is None else (
            f"; position error {self.position:.3g} ({(self.position_rel or 0.0):.2g} of the largest distance)")
        return (f"estimated final attitude error {self.attitude:.3g} rad ({math.degrees(self.attitude):.3g} deg), "
                f"largest {self.attitude_max:.3g} rad at t = {self.t_attitude_max:g}; momentum error "
                f"{self.momentum:.3g} kg m^2/s{rel}{where} (Richardson, order {self.order}, shadow run at h/2 = "
                f"{self.h / 2:g})" + regime)

    def advice(self, toml: bool = False) -> str:
        """What to change for accuracy: a higher order, or the step the ``h^p`` scaling asks for
        (``toml=True``: as keys of a scenario's ``[integrator]`` table, else as arguments)."""
        target = self.warn if self.warn is not None else DEFAULT_WARN
        eq, q, where = (" = ", '"', " in [integrator]") if toml else ("=", "'", "")
        tip = {1: f"forcing{eq}{q}symmetric{q} (order 2; also with order{eq}4 or 6){where}",
               2: f"order{eq}4 or order{eq}6{where}"}.get(self.order, f"a smaller h{where}")
        if self.position is not None:       # the orbit and two-body runs have one scheme: a smaller step
            tip = f"a smaller h{where}"
        if self.asymptotic and self.worst > 0.0:
            tip += f", or h{eq}{self.step_for(target):.3g} (order {self.order}) for about {target:g} rad"
        return f"for accuracy use {tip}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable form, as stored in ``Trajectory.meta["error_estimate"]``."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Any) -> "ErrorEstimate":
        """Inverse of :meth:`to_dict` (ValueError naming the field on malformed input)."""
        if not isinstance(d, dict):
            raise ValueError(f"meta['error_estimate'] must be a JSON object, got {type(d).__name__}")
        names = [f for f in cls.__dataclass_fields__]
        missing = [k for k in names if k not in d and k not in ("warn", "method", "position", "position_rel")]
        if missing:
            raise ValueError(f"meta['error_estimate'] lacks field(s) {', '.join(missing)}")
        unknown = [k for k in d if k not in names]
        if unknown:
            raise ValueError(f"meta['error_estimate'] has unknown field(s) {', '.join(map(str, unknown))}")
        kw = dict(d)
        for k in ("attitude", "attitude_max", "t_attitude_max", "momentum", "h", "wall_time_s"):
            kw[k] = as_float(kw[k], f"meta['error_estimate'][{k!r}]")
        for k in ("momentum_rel", "warn", "position", "position_rel"):
            if kw.get(k) is not None:
                kw[k] = as_float(kw[k], f"meta['error_estimate'][{k!r}]")
        if kw["order"] not in (1, 2, 4, 6) or isinstance(kw["order"], bool):
            raise ValueError(f"meta['error_estimate']['order'] must be 1, 2, 4 or 6, got {kw['order']!r}")
        return cls(**kw)


def check_options(error_estimate: Any, error_warn: Any, torque: Any) -> tuple[bool, float | None]:
    """Validated ``(enabled, warn)`` of :func:`lgvi.simulate`'s ``error_estimate`` and ``error_warn``."""
    from .torques import TorqueModel

    if error_estimate is None or isinstance(error_estimate, (bool, np.bool_)):
        enabled = bool(error_estimate)
    elif isinstance(error_estimate, str):
        if error_estimate not in ESTIMATES:
            raise ValueError(f"error_estimate must be False, True or 'richardson', got {error_estimate!r}")
        enabled = True
    else:
        raise TypeError(f"error_estimate must be False, True or 'richardson', got {error_estimate!r} of type "
                        f"{type(error_estimate).__name__}")
    warn = None if error_warn is None else as_float(error_warn, "error_warn", positive=True)
    if enabled and torque is not None and not isinstance(torque, TorqueModel) and not callable(torque):
        raise ValueError("error_estimate needs the moment between the grid times (the shadow run steps at "
                         "h/2), but a torque array holds it at the grid times only; pass a callable "
                         "torque(t, R, Pi) or a torque model, or error_estimate=False")
    return enabled, warn


def scheme_order(torque: Any, forcing: str, order: int) -> int:
    """Order ``p`` of the scheme :func:`lgvi.simulate` uses for these (validated) arguments."""
    from .torques import TorqueModel

    if order != 2 or torque is None or forcing == "symmetric":
        return int(order)
    if isinstance(torque, TorqueModel) and all(m.conservative for m in torque.terms):
        return 2  # potentials always use the symmetric step
    return 1      # the paper's update Pi_(k+1) = F^T Pi_k + h u_k is first order in u


def geodesic_distance(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``|log(A^T B)|`` for stacks of rotations ``(..., 3, 3)``: the angle in ``[0, pi]``, accurate
    for small angles too (``atan2`` of the sine and cosine parts, not ``arccos`` of the trace)."""
    M = np.einsum("...ki,...kj->...ij", A, B)
    c = 0.5 * (M[..., 0, 0] + M[..., 1, 1] + M[..., 2, 2] - 1.0)
    s = 0.5 * np.sqrt((M[..., 2, 1] - M[..., 1, 2]) ** 2 + (M[..., 0, 2] - M[..., 2, 0]) ** 2
                      + (M[..., 1, 0] - M[..., 0, 1]) ** 2)
    return np.arctan2(s, c)


def richardson(traj: Any, shadow: Any, order: int, *, wall_time_s: float = 0.0,
               warn: float | None = DEFAULT_WARN, position: Any = None) -> ErrorEstimate:
    """The estimate from a run ``traj`` at ``h`` and a ``shadow`` run at ``h/2`` saved at the same times.

    Parameters
    ----------
    traj, shadow : Trajectory
        ``M`` samples each, at the same times.
    order : int
        Order ``p`` of the scheme.
    wall_time_s : float
        Wall time of the shadow run, recorded in the result.
    warn : float or None
        Threshold recorded in the result.
    position : callable, optional
        ``position(run)`` -> (M, 3): the position whose error is estimated too (an orbit's ``x``,
        two bodies' ``x2 - x1``).

    Returns
    -------
    ErrorEstimate
    """
    if shadow.R.shape != traj.R.shape or not np.allclose(shadow.t, traj.t, rtol=1e-12, atol=0.0):
        raise ValueError("the shadow run must be saved at the times of the run")
    factor = 2.0 ** order / (2.0 ** order - 1.0)
    ang = factor * geodesic_distance(traj.R, shadow.R)
    ang = ang.reshape(len(ang), -1).max(axis=1)           # the largest over the bodies of a run with two
    j = int(np.argmax(ang))
    dPi = factor * float(np.linalg.norm(traj.Pi[-1] - shadow.Pi[-1]))
    scale = float(np.max(np.linalg.norm(traj.Pi.reshape(len(traj.Pi), -1), axis=1)))
    pos = rel = None
    if position is not None:
        x, xs = position(traj), position(shadow)
        pos = factor * float(np.linalg.norm(x[-1] - xs[-1]))
        far = float(np.max(np.linalg.norm(x, axis=1)))
        rel = pos / far if far > 0.0 else None
    return ErrorEstimate(attitude=float(ang[-1]), attitude_max=float(ang[j]), t_attitude_max=float(traj.t[j]),
                         momentum=dPi, momentum_rel=dPi / scale if scale > 0.0 else None, order=int(order),
                         h=float(traj.h), wall_time_s=float(wall_time_s), warn=warn, position=pos, position_rel=rel)


#: The function a shadow run calls, :func:`lgvi.simulate`: :mod:`lgvi.systems.rigid_body_run` provides it on
#: import (:func:`provide_simulate`), so that this module stays below the integrator (no import cycle).
SHADOW_RUNNER: dict[str, Any] = {}


def provide_simulate(simulate: Any) -> None:
    """Set the function the shadow run of :func:`with_estimate` calls (:func:`lgvi.simulate`)."""
    SHADOW_RUNNER["simulate"] = simulate


def with_estimate(traj: Any, args: dict[str, Any], *, warn: float | None = DEFAULT_WARN,
                  stacklevel: int = 2, order: int | None = None, runner: Any = None, position: Any = None) -> Any:
    """``traj`` with ``meta["error_estimate"]`` from a shadow run of :func:`lgvi.simulate` at ``h/2``.

    Parameters
    ----------
    traj : Trajectory
        The run (complete).
    args : dict
        The keyword arguments of :func:`lgvi.simulate` that produced it (``body``, ``R0``, ``Pi0``
        or ``omega0``, ``h``, ``steps``, ``torque``, ``save_every``, ...). The shadow run uses them
        with ``h/2``, twice the steps and twice ``save_every``, so it is saved at the same times.
    warn : float or None
        Emit :class:`lgvi.AccuracyWarning` when the estimated final attitude error exceeds it.
    stacklevel : int
        Passed to :func:`warnings.warn` (counted from the caller of this function).
    order : int, optional
        The scheme's order ``p`` when the arguments do not tell it (the gyrostat's: 1 with wheel
        friction); default from ``order``, ``torque`` and ``forcing``.
    runner : callable, optional
        The function the shadow run calls instead of :func:`lgvi.simulate`, with ``args`` (e.g.
        :func:`lgvi.simulate_orbit`; then give ``order``).
    position : callable, optional
        As in :func:`richardson`.

    Raises
    ------
    SimulationInterrupted, ConvergenceError, TorqueError
        From the shadow run, with ``.trajectory`` the (complete) run ``traj``.
    """
    simulate = SHADOW_RUNNER["simulate"] if runner is None else runner   # lgvi.simulate (lgvi.integrator provides it)
    kw = dict(args)
    kw.update(h=float(kw["h"]) / 2.0, steps=2 * int(kw["steps"]), save_every=2 * int(kw.get("save_every", 1)))
    if kw.get("progress") is not True:
        kw["progress"] = False
    p = int(kw.get("order", 2))
    if kw.get("scheme") in (None, "lgvi"):          # the splitting's order is order= for every moment
        p = scheme_order(kw.get("torque"), kw.get("forcing", "paper"), p)
    order = p if order is None else int(order)
    t0 = time.perf_counter()
    try:
        shadow = simulate(**kw)
    except SimulationInterrupted as exc:
        raise SimulationInterrupted(f"interrupted during the error estimate (the shadow run at h/2): {exc}; the "
                                    "run itself is complete in .trajectory", trajectory=traj) from None
    except (ConvergenceError, TorqueError) as exc:
        exc.args = (f"the error estimate's shadow run at h/2 failed: {exc} (the run itself is complete in "
                    ".trajectory; pass error_estimate=False to skip the estimate)",)
        exc.trajectory = traj
        raise
    est = richardson(traj, shadow, order, wall_time_s=time.perf_counter() - t0, warn=warn, position=position)
    if est.exceeds:
        warnings.warn(f"{est.describe()}: above error_warn = {est.warn:g} rad; {est.advice()}",
                      AccuracyWarning, stacklevel=stacklevel + 1)
    return replace(traj, meta=dict(traj.meta, error_estimate=est.to_dict()))


__all__ = ["ASYMPTOTIC_LIMIT", "DEFAULT_WARN", "ErrorEstimate", "SHADOW_RUNNER", "check_options", "geodesic_distance",
           "provide_simulate", "richardson", "scheme_order", "with_estimate"]
