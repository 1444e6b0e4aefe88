"""Command line: ``lgvi`` / ``python -m lgvi``.

=================================================  ==============================================================
command                                            what it does
=================================================  ==============================================================
``lgvi`` or ``lgvi demo [-o DIR]``                 the default scenario (Dzhanibekov effect), LGVI against RK45;
                                                   with ``-o`` also the trajectory and figures
``lgvi run SCENARIO.toml [-o DIR]``                runs a scenario file (:mod:`lgvi.scenario`); writes the
``[--no-plots] [--format npz,csv,netcdf]``         trajectory, ``summary.txt``/``summary.json``, the scenario,
                                                   the figures and ``report.html``; an ``[orbiting_body]`` or
                                                   ``[two_body]`` scenario: the npz, summaries (the system's
                                                   declared invariants) and its figure
``lgvi compare SCENARIO.toml --with rk4,rk45``     the same problem through the baselines (``rk4``, ``rk45``,
``[-o DIR]``                                       ``dop853``): a table of conservation errors and wall times,
                                                   and with ``-o`` overlaid figures
``lgvi plot TRAJECTORY [-o DIR] [--animate]``      figures (PNG) of a saved trajectory (``.npz``, ``.csv``, ``.nc``)
``lgvi info TRAJECTORY``                           shape, times, method, metadata and conservation drifts
``lgvi view TRAJECTORY [-o PAGE.html]``            an interactive page (plotly, offline): the body turning in
                                                   3D (a chain's links, a slosh hub's pendulums), linked
                                                   plots, the summary
``lgvi warmup``                                    compiles (or loads from Numba's cache) the kernels
``lgvi example [NAME] [-o PATH] [--force]``        lists the example scenarios shipped with lgvi; with a
                                                   name, writes ``NAME.toml`` (to give to ``lgvi run``)
=================================================  ==============================================================

Exit codes: 0 success; 2 a usage or input error (bad arguments, an invalid scenario or trajectory
file), with a one-line message on stderr; 1 a failure while running (a step's solver did not
converge, a missing optional package), with its message; 130 interrupted by Ctrl-C (what was
computed is written first).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import os
import platform
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from .._files import write_text

DEMO_INERTIA = (1.0, 2.0, 3.0)
DEMO_OMEGA0 = (1e-3, 1.0, 1e-3)
DEMO_H = 0.01
DEMO_STEPS = 100_000
BASELINES = ("rk4", "rk45", "dop853")
#: Runs of at least this many steps print their start and end on stderr.
ANNOUNCE_STEPS = 10_000


class UsageError(Exception):
    """Bad input from the user: exit code 2 with a one-line message."""


class RunFailure(Exception):
    """A failure while running: exit code 1 with a one-line message."""


def _err(msg: str) -> None:
    """One line on stderr (messages that span lines are joined)."""
    print("lgvi: " + " ".join(str(msg).split("\n")), file=sys.stderr)


def drift_table_row(name: str, traj, steps: int, wall: float, invariants=None) -> str:
    """One row of the table: the relative drift of each quantity the system conserves.

    ``invariants`` (an :class:`lgvi.invariants.Declaration`) chooses the columns, as in
    :func:`table_header`; default the trajectory's own declaration.
    """
    from ..invariants import QUANTITIES, declared
    from ..io.outputs import conservation_drifts

    decl = invariants if invariants is not None else declared(traj)
    d = conservation_drifts(traj, decl)

    def f(x: float | None) -> str:
        return f"{x:>10.2e}" if x is not None else f"{'-':>10}"

    rate = f"{steps / wall:>11.3e}" if wall > 0 else f"{'-':>11}"
    cols = " ".join(f(d[QUANTITIES[k].rel_key]) for k in decl.quantities())
    return f"{name:<24} {steps:>9d} {wall:>9.3f} {rate} {cols + ' ' if cols else ''}{f(d['orthogonality_max'])}"


def table_header(invariants=None) -> str:
    """Header of the conservation table: one column per declared invariant (default: the free body's)."""
    from ..invariants import FREE_BODY, QUANTITIES, Declaration

    decl = invariants if invariants is not None else Declaration(FREE_BODY, "the free body")
    cols = "".join(f" {QUANTITIES[k].column:>10}" for k in decl.quantities())
    return f"{'integrator':<24} {'steps':>9} {'wall [s]':>9} {'steps/s':>11}{cols} {'|RtR-I|':>10}"


_LEGEND = {"spatial_momentum": ("dL", "spatial angular momentum R Pi"),
           "spatial_momentum_e3": ("dL3", "vertical spatial momentum e3 . R Pi"),
           "casimir": ("|Pi|", "Casimir"), "energy": ("E", "total energy"),
           "jacobi": ("C", "Jacobi integral E - n e3 . R Pi (the energy in the frame turning with the orbit)")}


def table_legend(invariants=None) -> str:
    """What the columns of :func:`table_header` are, how the LGVI conserves each, what is left out."""
    from ..invariants import FREE_BODY, KIND_TEXT, QUANTITIES, Declaration

    decl = invariants if invariants is not None else Declaration(FREE_BODY, "the free body")
    keys = decl.quantities()
    import textwrap

    lines = textwrap.wrap("; ".join(f"{_LEGEND[k][0]}: {_LEGEND[k][1]}" for k in keys) + ("; " if keys else "")
                          + "|RtR-I|: distance from SO(3). All are the largest changes over the run.",
                          width=110, initial_indent="  ", subsequent_indent="  ")
    kinds = [f"{', '.join(_LEGEND[k][0] for k in keys if decl.kind(k) == kind)} {KIND_TEXT[kind]}"
             for kind in KIND_TEXT if any(decl.kind(k) == kind for k in keys)]
    if kinds:
        lines.append(f"  Invariants of {decl.system}; the LGVI keeps " + " and ".join(kinds) + ".")
    if decl.not_invariants():
        lines += textwrap.wrap(f"Not invariants of {decl.system}, so not shown: "
                               + ", ".join(QUANTITIES[k].name for k in decl.not_invariants()) + ".",
                               width=110, initial_indent="  ", subsequent_indent="  ")
    return "\n".join(lines)


TABLE_HEADER = table_header()
TABLE_LEGEND = table_legend()


def _plot_module():
    """``lgvi.plot`` or ``None`` (with a note on stderr) when it or matplotlib is missing."""
    try:
        plot = importlib.import_module("lgvi.plot")
    except ImportError as exc:
        _err(f"figures skipped: lgvi.plot is not available ({exc}); install matplotlib: pip install 'lgvi[plot]'")
        return None
    return plot


def _save_figures(traj, outdir: Path) -> list[Path]:
    plot = _plot_module()
    if plot is None:
        return []
    try:
        return list(plot.save_figures(traj, outdir))
    except ImportError as exc:
        _err(f"figures skipped: {exc}")
        return []


# ------------------------------------------------------------------------------------ demo
def run_demo(out: str | None = None, steps: int = DEMO_STEPS, h: float = DEMO_H, rtol: float = 1e-6,
             plots: bool = True) -> int:
    """Run the default scenario and print the comparison table; with ``out``, write files too."""
    import lgvi
    from ..verification.baselines import solve_ivp_baseline

    body = lgvi.RigidBody(DEMO_INERTIA)
    R0 = np.eye(3)
    T = steps * h
    print("lgvi demo: the Dzhanibekov effect (a body spun near its intermediate axis flips over and over)")
    print(f"  J = diag{DEMO_INERTIA}, omega0 = {DEMO_OMEGA0} rad/s, R0 = I, T = {T:g} s")
    t_c = time.perf_counter()
    lgvi.simulate(body, R0, omega0=DEMO_OMEGA0, h=h, steps=10)  # compile or load the kernels
    t_c = time.perf_counter() - t_c
    t_0 = time.perf_counter()
    traj = lgvi.simulate(body, R0, omega0=DEMO_OMEGA0, h=h, steps=steps)
    wall = time.perf_counter() - t_0
    t_0 = time.perf_counter()
    rk = solve_ivp_baseline(body, R0, omega0=DEMO_OMEGA0, t_final=T, samples=None, method="RK45", rtol=rtol,
                            atol=rtol * 1e-3)
    wall_rk = time.perf_counter() - t_0
    print()
    print(TABLE_HEADER)
    print(drift_table_row(f"lgvi newton h={h:g}", traj, steps, wall))
    print(drift_table_row(f"scipy RK45 rtol={rtol:g}", rk, len(rk.t) - 1, wall_rk))
    flips = int(np.sum(np.diff(np.sign(traj.omega[:, 1])) != 0))
    print()
    print(f"  intermediate-axis flips seen by lgvi: {flips}; mean solver iterations per step: "
          f"{traj.iterations.mean():.2f}; kernel load/compile time: {t_c:.2f} s")
    print(TABLE_LEGEND)
    print("  RK45 integrates a quaternion and does not renormalise it, so its attitude leaves SO(3).")
    if out is not None:
        path = Path(out)
        path.mkdir(parents=True, exist_ok=True)
        traj.save(path / "trajectory.npz")
        print(f"  trajectory written to {path / 'trajectory.npz'}")
        if plots:
            figs = _save_figures(traj, path)
            plot = _plot_module() if figs else None
            if plot is not None:
                figs += list(plot.save_comparison({f"lgvi h={h:g}": traj, f"RK45 rtol={rtol:g}": rk}, path))
            if figs:
                print(f"  figures written to {path}: {', '.join(p.name for p in figs)}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    if args.steps < 1:
        raise UsageError(f"--steps must be a positive integer, got {args.steps}")
    return run_demo(out=args.output, steps=args.steps, plots=not args.no_plots)


# ------------------------------------------------------------------------------------ run
def _load(path: str, *, systems: bool = False):
    """The checked scenario of ``path``; ``systems``: also ``[orbiting_body]`` and ``[two_body]``
    scenarios (``lgvi run``; ``lgvi compare``'s baselines integrate a single body only)."""
    from ..io.scenario import BodiesScenario, ScenarioError, load_scenario

    from ..io.scenario_loop import LoopScenario

    sc = load_scenario(path)
    if isinstance(sc, LoopScenario) and not systems:
        raise ScenarioError(path, "spacecraft", "lgvi compare runs the baselines of a single rigid body; a "
                            "[spacecraft] scenario runs with lgvi run")
    if isinstance(sc, BodiesScenario) and not systems:
        raise ScenarioError(path, sc.kind, "lgvi compare runs the baselines of a single rigid body; an "
                            "[orbiting_body] or [two_body] scenario runs with lgvi run")
    return sc


def _parse_formats(text: str | None, default: tuple[str, ...]) -> tuple[str, ...]:
    from ..io.scenario import FORMATS

    if text is None:
        return default
    items = [f.strip().lower() for f in text.split(",") if f.strip()]
    bad = [f for f in items if f not in FORMATS]
    if bad or not items:
        raise UsageError(f"--format: expected a comma-separated list of {', '.join(FORMATS)}; got {text!r}")
    return tuple(dict.fromkeys(items))


def _fmt_drift(x: float | None) -> str:
    return "n/a (zero scale)" if x is None else f"{x:.3e}"


def _conservation_lines(decl, drifts: dict[str, Any], width: int = 34) -> list[str]:
    """The conservation block of ``summary.txt``: each invariant ``decl`` declares with its kind and
    largest change, then the usual quantities this system does not conserve, marked so."""
    from ..invariants import KIND_TEXT, QUANTITIES

    lines = [f"conservation (largest change over the run; {decl.note()}):"]
    for k in decl.quantities():
        q = QUANTITIES[k]
        change = (f"abs {drifts[q.abs_key]:.3e}   " if q.abs_key else "") + f"rel {_fmt_drift(drifts[q.rel_key])}"
        lines.append(f"  {q.name:<{width}} {change}   {KIND_TEXT[decl.kind(k)]}")
    lines += [f"  {QUANTITIES[k].name:<{width}} not an invariant here" for k in decl.not_invariants()]
    lines.append(f"  {'|R^T R - I|':<{width}} max {drifts['orthogonality_max']:.3e}")
    return lines


def write_summary(outdir: Path, traj, scenario, wall: float, files: list[Path], *, status: str = "complete",
                  message: str = "", kernel_load: float | None = None) -> tuple[Path, Path]:
    """``summary.json`` and ``summary.txt``: drifts, wall time, rate, scenario text, versions.

    ``wall`` is the time of the simulation itself; ``kernel_load`` the time of the short warm-up
    run before it (loading or compiling the kernels), reported separately.
    """
    import lgvi

    from ..invariants import declared
    from ..io.outputs import conservation_drifts

    drifts = conservation_drifts(traj)
    steps_done = int(traj.steps)
    solver = traj.solver_summary  # totals over every step, whatever the record's resolution
    data: dict[str, Any] = {
        "status": status,
        "message": message,
        "scenario_name": scenario.name,
        "description": scenario.description,
        "scenario_source": scenario.source,
        "lgvi_version": lgvi.__version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "steps_requested": scenario.steps,
        "steps": steps_done,
        "samples": len(traj.t),
        "h": scenario.h,
        "t_start": float(traj.t[0]),
        "t_end": float(traj.t[-1]),
        "method": "rkmk4" if traj.meta.get("scheme") == "rkmk4" else scenario.method,
        "scheme": traj.meta.get("scheme"),            # "splitting": no implicit solve, no forcing
        "composition": traj.meta.get("composition"),
        "forcing": traj.meta.get("forcing", scenario.forcing),
        "order": traj.meta.get("order", scenario.order),
        "torque": [s["type"] for s in scenario.torque_spec],
        "wall_time_s": wall,
        "steps_per_s": steps_done / wall if wall > 0 else None,
        "kernel_load_s": kernel_load,
        "iterations_mean": solver["iterations_mean"] if solver["steps"] else None,
        "iterations_max": solver["iterations_max"] if solver["steps"] else None,
        "residual_max": solver["residual_max"] if solver["steps"] else None,
        "drifts": drifts,
        "invariants": declared(traj).labels(),
        "files": [p.name for p in files],
        "scenario": scenario.text,
    }
    data["error_estimate"] = traj.meta.get("error_estimate")  # lgvi.accuracy, when the scenario asks for it
    js = outdir / "summary.json"
    write_text(js, json.dumps(data, indent=2) + "\n", "summary")
    rate = "n/a" if data["steps_per_s"] is None else f"{data['steps_per_s']:.4g}"
    lines = [
        f"lgvi {lgvi.__version__} run of scenario {scenario.name!r} ({scenario.source})",
        *( [f"  {scenario.description}"] if scenario.description else []),
        f"status:        {status}{': ' + message if message else ''}",
        f"steps:         {steps_done} of {scenario.steps}, h = {scenario.h:g} s, t = {data['t_start']:g} .. "
        f"{data['t_end']:g} s, {data['samples']} saved states (every {scenario.save_every})",
        (f"integrator:    splitting {data['composition']}, order {data['order']}, "
         if data["scheme"] == "splitting" else
         f"integrator:    rkmk4 {data['composition']} (explicit Runge-Kutta-Munthe-Kaas), order {data['order']}, "
         if data["scheme"] == "rkmk4" else
         f"integrator:    method {scenario.method}, forcing {data['forcing']}, order {data['order']}, ")
        + f"torque {' + '.join(data['torque']) or 'none'}",
        f"wall time:     {wall:.4g} s ({rate} steps/s)"
        + ("" if kernel_load is None else f"; kernel load/compile before it {kernel_load:.3g} s"),
        f"solver:        mean {data['iterations_mean'] if data['iterations_mean'] is None else round(data['iterations_mean'], 3)}"
        f" iterations/step, max {data['iterations_max']}, max residual {data['residual_max']}",
        *_conservation_lines(declared(traj), drifts),
        f"files:         {', '.join(data['files'])}",
        "",
        "scenario:",
        *("  " + line for line in scenario.text.rstrip("\n").splitlines()),
        "",
    ]
    at = next((i for i, line in enumerate(lines) if line.startswith("files:")), len(lines))
    lines[at:at] = _accuracy_lines(traj)
    txt = outdir / "summary.txt"
    write_text(txt, "\n".join(lines), "summary")
    return txt, js


def _accuracy_lines(traj) -> list[str]:
    """The summary's lines on the estimated error of the run (:mod:`lgvi.accuracy`)."""
    est = traj.error_estimate
    if est is None:
        return ["accuracy:      not estimated (error_estimate = true under [integrator] estimates the final "
                "attitude error from a second run at h/2)"]
    lines = [f"accuracy:      {est.describe()}; the run at h/2 took {est.wall_time_s:.3g} s more"]
    if est.exceeds:
        lines.append(f"WARNING:       the estimated final attitude error exceeds error_warn = {est.warn:g} rad: "
                     f"{est.advice(toml=True)}")
    return lines


def _default_outdir(scenario) -> Path:
    """``./SLUG_output``: the scenario name made a safe file name, so no name read from a file
    (``../x``, ``/abs``, control characters) puts the results outside the current folder."""
    from .._untrusted import safe_name

    return Path.cwd() / f"{safe_name(scenario.name)}_output"


def _outdir(args: argparse.Namespace, scenario) -> Path:
    """The output folder: ``-o DIR`` as given, or the default ``./SLUG_output``, which is refused
    when it is a symbolic link (a link planted under the default name never redirects the results,
    nor the removal of the stream folder, elsewhere)."""
    if args.output:
        return Path(args.output)
    outdir = _default_outdir(scenario)
    if outdir.is_symlink():
        raise UsageError(f"the default output folder {outdir} is a symbolic link (to {os.readlink(outdir)}); lgvi "
                         "does not follow it: remove it, or name the folder with -o")
    return outdir


def _remove_stream(stream: Path) -> None:
    """Remove what the run wrote in ``stream`` (its manifest, chunks and lock), and the folder
    itself only if nothing else is left in it: a folder holding the user's own files is kept."""
    from ..io.streaming import remove_stream

    left = remove_stream(stream)
    if left:
        _err(f"note: {stream} is kept: it holds {len(left)} file(s) lgvi did not write "
             f"({', '.join(sorted(left)[:5])}{', ...' if len(left) > 5 else ''})")


def _check_outdir(outdir: Path) -> None:
    """Refuse an output folder holding a symbolic link that points outside it (a folder from
    elsewhere must not redirect where the results are written)."""
    from .._untrusted import inside

    for folder in (outdir, outdir / "stream"):
        if not folder.is_dir():
            continue
        for p in [folder, *folder.iterdir()]:
            if p.is_symlink() and p != outdir and not inside(outdir, p):
                raise UsageError(f"{p} is a symbolic link to {os.path.realpath(p)}, outside the output folder "
                                 f"{outdir}; remove it or choose another folder with -o")


def _write_results(traj, scenario, outdir: Path, formats: tuple[str, ...], plots: bool, wall: float, *,
                   status: str = "complete", message: str = "", kernel_load: float | None = None) -> list[Path]:
    from ..io.outputs import write_trajectory

    outdir.mkdir(parents=True, exist_ok=True)   # -o DIR as named (a default folder that is a link is refused)
    files = write_trajectory(traj, outdir, formats)
    write_text(outdir / "scenario.toml", scenario.text, "scenario copy")
    files.append(outdir / "scenario.toml")
    if plots:
        files += _save_figures(traj, outdir)
        files += _save_report(traj, outdir, {"scenario": scenario.name, "wall time": f"{wall:.4g} s"})
    txt, js = write_summary(outdir, traj, scenario, wall, files, status=status, message=message,
                            kernel_load=kernel_load)
    return files + [txt, js]


def _warm(scenario, baselines: tuple[str, ...] = ()) -> float:
    """Load (or compile) the kernels the scenario uses with a short run, so timings exclude it."""
    from dataclasses import replace

    t0 = time.perf_counter()
    if scenario.steps:
        short = replace(scenario, steps=scenario.save_every, error_estimate=False)
        try:
            short.run()
            if "rk4" in baselines:
                _baseline("rk4", short, 1e-6)
        except Exception:  # noqa: BLE001 - the real run reports any problem
            pass
    return time.perf_counter() - t0


def cmd_run(args: argparse.Namespace) -> int:
    from ..errors import AccuracyWarning, ConvergenceError, SimulationInterrupted, TorqueError
    from ..io.scenario import BodiesScenario

    from ..io.scenario_loop import LoopScenario

    scenario = _load(args.scenario, systems=True)
    if isinstance(scenario, (BodiesScenario, LoopScenario)):    # a body in orbit, two bodies, the spacecraft loop
        return _run_system(args, scenario)
    formats = _parse_formats(args.format, scenario.formats)
    plots = scenario.plots and not args.no_plots
    outdir = _outdir(args, scenario)
    _check_outdir(outdir)
    if "netcdf" in formats:  # fail before a long run, not after it
        try:
            import xarray  # noqa: F401
        except ImportError as exc:
            raise RunFailure(f"netCDF output needs the optional packages xarray and netCDF4: "
                             f"pip install 'lgvi[io]' ({exc})") from None
    t_load = _warm(scenario)
    loud = scenario.steps >= ANNOUNCE_STEPS
    if loud:
        print(f"lgvi run: {scenario.name}: {scenario.steps} steps of h = {scenario.h:g} s "
              f"({scenario.method})" + (f", then {2 * scenario.steps} steps of h/2 for the error estimate"
                                        if scenario.error_estimate else "") + " ...", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    stream = outdir / "stream"
    if args.resume and not (stream / "manifest.json").exists():
        raise UsageError(f"--resume: no interrupted run to resume in {stream}")
    try:
        with warnings.catch_warnings():  # reported as one line below and in summary.txt
            warnings.simplefilter("ignore", AccuracyWarning)
            traj = scenario.run_stream(stream, resume=args.resume, progress=True,
                                       solver_record=args.solver_record)
    except SimulationInterrupted as exc:
        wall = time.perf_counter() - t0
        part = exc.trajectory
        if part is not None:
            files = _write_results(part, scenario, outdir, formats, False, wall, status="interrupted",
                                   message=str(exc))
            _err(f"interrupted: {exc}; the {part.steps} steps computed are written to {outdir} "
                 f"({', '.join(p.name for p in files)}); `lgvi run {args.scenario} -o {outdir} --resume` "
                 "continues the run")
        else:
            _err(f"interrupted: {exc}")
        return 130
    except (ConvergenceError, TorqueError) as exc:
        wall = time.perf_counter() - t0
        part = getattr(exc, "trajectory", None)
        msg = f"{type(exc).__name__}: {exc}"
        if part is not None and len(part.t):
            _write_results(part, scenario, outdir, formats, False, wall, status="failed", message=str(exc))
            msg += f" (the part computed is written to {outdir})"
        raise RunFailure(msg) from None
    wall = time.perf_counter() - t0
    if traj.error_estimate is not None:  # the run's own time; the estimate's is reported with it
        wall -= traj.error_estimate.wall_time_s
    if loud:
        rate = traj.steps / wall if wall > 0 else float("inf")
        print(f"lgvi run: {scenario.name}: done in {wall:.3g} s ({rate:.3g} steps/s)", file=sys.stderr, flush=True)
    files = _write_results(traj, scenario, outdir, formats, plots, wall, kernel_load=t_load)
    if not args.keep_stream:
        _remove_stream(stream)
    print(f"{scenario.name}: {traj.steps} steps in {wall:.3g} s; wrote {len(files)} files to {outdir}")
    for p in files:
        print(f"  {p.name}")
    est = traj.error_estimate
    if est is not None:
        print(f"  {est.describe()}")
        if est.exceeds:
            _err(f"warning: the estimated final attitude error {est.attitude:.3g} rad exceeds error_warn = "
                 f"{est.warn:g} rad; {est.advice(toml=True)} (see summary.txt)")
    return 0


# ------------------------------------------------------------------------------------ run: other systems
_SYSTEM_NAMES = {"orbit": "a rigid body in a central field (lgvi.simulate_orbit)",
                 "two_body": "two rigid bodies in mutual gravity (lgvi.simulate_two_body)"}


def _system_declaration(traj):
    """The declared invariants of an orbit or two-body result (:func:`lgvi.invariants.declared`),
    named after its system."""
    from ..invariants import Declaration, declared

    meta = traj.meta
    if meta.get("system") == "orbit":
        what = f"a body in a central field ({meta.get('potential', '?')} potential" + (", J2)" if meta.get("J2") else ")")
        if meta.get("torque") not in (None, "none"):
            what += f" under an extra torque ({meta['torque']})"
    elif meta.get("system") == "two_body":
        what = f"two bodies in mutual gravity ({meta.get('potential', '?')} potential)"
    elif meta.get("system") == "spacecraft":           # under external torques: named by their kinds
        what = declared(traj).system
    else:                                   # another registered system: its one-line doc
        from ..systems import SYSTEMS

        what = SYSTEMS[meta["system"]].doc.split(":")[0]
    decl = declared(traj)
    return Declaration(decl.entries, what, decl.recorded)


def _system_lines(traj) -> list[str]:
    """What was simulated: the orbit's or the pair's parameters and range."""
    meta = traj.meta
    if meta.get("system") == "orbit":
        r = np.linalg.norm(np.asarray(traj.x), axis=1)
        J2 = f", J2 = {meta['J2']:g} (radius {meta['radius']:g} m)" if meta.get("J2") else ""
        return [f"system:        {_SYSTEM_NAMES['orbit']}: mass {traj.mass:g} kg, mu = {traj.mu:g} m^3/s^2, "
                f"{meta.get('potential')} potential{J2}",
                f"orbit:         |x| from {r.min():.6g} to {r.max():.6g} m"]
    if meta.get("system") != "two_body":    # another registered system describes itself
        from ..systems import SYSTEMS

        system = SYSTEMS[meta["system"]]
        return system.describe(traj) if system.describe is not None else [f"system:        {system.doc}"]
    d = np.asarray(traj.distance)
    return [f"system:        {_SYSTEM_NAMES['two_body']}: masses {traj.masses[0]:g} and {traj.masses[1]:g} kg, "
            f"G = {traj.G:g}, {meta.get('potential')} mutual potential",
            f"distance:      |x2 - x1| from {d.min():.6g} to {d.max():.6g} m"]


def write_system_summary(outdir: Path, traj, scenario, wall: float, files: list[Path], *, status: str = "complete",
                         message: str = "", kernel_load: float | None = None) -> tuple[Path, Path]:
    """``summary.json`` and ``summary.txt`` of an ``[orbiting_body]`` or ``[two_body]`` run: the
    system, the declared invariants (:mod:`lgvi.invariants`) with their kinds and largest changes,
    wall time, solver record, scenario text, versions."""
    import lgvi

    from ..invariants import drifts as invariant_drifts
    from ..io.outputs import orthogonality_max

    decl = _system_declaration(traj)
    drifts = invariant_drifts(traj, decl) if len(traj.t) else {}
    drifts["orthogonality_max"] = orthogonality_max(traj)
    steps_done = (len(traj.t) - 1) * scenario.save_every if len(traj.t) else 0
    its, res = np.asarray(traj.iterations), np.asarray(traj.residual)
    data: dict[str, Any] = {
        "status": status, "message": message, "system": traj.meta.get("system"),
        "scenario_name": scenario.name, "description": scenario.description, "scenario_source": scenario.source,
        "lgvi_version": lgvi.__version__, "python": platform.python_version(), "numpy": np.__version__,
        "steps_requested": scenario.steps, "steps": steps_done, "samples": len(traj.t), "h": scenario.h,
        "t_start": float(traj.t[0]) if len(traj.t) else None, "t_end": float(traj.t[-1]) if len(traj.t) else None,
        "method": traj.meta.get("method"), "potential": traj.meta.get("potential"),
        "wall_time_s": wall, "steps_per_s": steps_done / wall if wall > 0 else None, "kernel_load_s": kernel_load,
        "iterations_max": int(its.max()) if its.size else None,
        "iterations_interval_mean": float(its.mean()) if its.size else None,
        "residual_max": float(res.max()) if res.size else None,
        "drifts": drifts, "invariants": decl.labels(), "files": [p.name for p in files], "scenario": scenario.text,
    }
    loop_lines: list[str] = []
    if traj.meta.get("system") == "spacecraft" and len(traj.t):   # the compiled loop: what it achieved
        from ..io.scenario_loop import loop_summary, summary_lines

        data["pointing"] = loop_summary(traj, wheels=getattr(getattr(scenario, "spacecraft", None), "wheels", None))
        loop_lines = summary_lines(data["pointing"])
    js = outdir / "summary.json"
    write_text(js, json.dumps(data, indent=2) + "\n", "summary")
    rate = "n/a" if data["steps_per_s"] is None else f"{data['steps_per_s']:.4g}"
    times = (f", t = {data['t_start']:g} .. {data['t_end']:g} s" if len(traj.t) else "")
    lines = [
        f"lgvi {lgvi.__version__} run of scenario {scenario.name!r} ({scenario.source})",
        *([f"  {scenario.description}"] if scenario.description else []),
        f"status:        {status}{': ' + message if message else ''}",
        *_system_lines(traj),
        f"steps:         {steps_done} of {scenario.steps}, h = {scenario.h:g} s{times}, {data['samples']} saved "
        f"states (every {scenario.save_every})",
        f"integrator:    {traj.meta.get('method')} coordinates, tol {traj.meta.get('tol')}",
        f"wall time:     {wall:.4g} s ({rate} steps/s)"
        + ("" if kernel_load is None else f"; kernel load/compile before it {kernel_load:.3g} s"),
        ("solver:        largest iterations per saved interval: mean "
         f"{data['iterations_interval_mean']:.3f}, max {data['iterations_max']}; max final residual (absolute) "
         f"{data['residual_max']:.3e}"
         if its.size else "solver:        no steps recorded"),
        *(_conservation_lines(decl, drifts, width=50) if len(traj.t) else []),
        *loop_lines,
        f"files:         {', '.join(data['files'])}",
        "",
        "scenario:",
        *("  " + line for line in scenario.text.rstrip("\n").splitlines()),
        "",
    ]
    txt = outdir / "summary.txt"
    write_text(txt, "\n".join(lines), "summary")
    return txt, js


def _write_system_results(traj, scenario, outdir: Path, plots: bool, wall: float, *, status: str = "complete",
                          message: str = "", kernel_load: float | None = None) -> list[Path]:
    outdir.mkdir(parents=True, exist_ok=True)   # -o DIR as named (a default folder that is a link is refused)
    traj.save(outdir / "trajectory.npz")
    files = [outdir / "trajectory.npz"]
    write_text(outdir / "scenario.toml", scenario.text, "scenario copy")
    files.append(outdir / "scenario.toml")
    if plots:
        from .. import view

        files += _save_figures(traj, outdir)
        if view.shows(traj):      # a system that declares its page (System.view)
            files += _save_report(traj, outdir, {"scenario": scenario.name, "wall time": f"{wall:.4g} s"})
    txt, js = write_system_summary(outdir, traj, scenario, wall, files, status=status, message=message,
                                   kernel_load=kernel_load)
    return files + [txt, js]


def _run_system(args: argparse.Namespace, scenario) -> int:
    """``lgvi run`` of an ``[orbiting_body]`` or ``[two_body]`` scenario, streamed to
    ``outdir/stream`` as the rigid body's runs are (so ``--resume`` continues it)."""
    from dataclasses import replace

    from ..errors import ConvergenceError, SimulationInterrupted, TorqueError

    if getattr(scenario, "ensemble", None) is not None:       # a spacecraft scenario's [ensemble]
        return _run_loop_ensemble(args, scenario)
    formats = _parse_formats(args.format, scenario.formats)
    if formats != ("npz",):
        raise UsageError(f"--format: the results of an [orbiting_body] or [two_body] scenario are saved as npz "
                         f"only; got {args.format!r}")
    plots = scenario.plots and not args.no_plots
    outdir = _outdir(args, scenario)
    _check_outdir(outdir)
    t_load = time.perf_counter()
    if scenario.steps:   # load (or compile) the kernels, so that the timing excludes it
        try:
            replace(scenario, steps=scenario.save_every).run()
        except Exception:  # noqa: BLE001 - the real run reports any problem
            pass
    t_load = time.perf_counter() - t_load
    loud = scenario.steps >= ANNOUNCE_STEPS
    if loud:
        print(f"lgvi run: {scenario.name}: {scenario.steps} steps of h = {scenario.h:g} s ({scenario.kind}) ...",
              file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    stream = outdir / "stream"
    if args.resume and not (stream / "manifest.json").exists():
        raise UsageError(f"--resume: no interrupted run to resume in {stream}")
    try:
        traj = scenario.run_stream(stream, resume=args.resume, progress=True)
    except SimulationInterrupted as exc:
        part = exc.trajectory
        if part is not None and len(part.t):
            files = _write_system_results(part, scenario, outdir, False, time.perf_counter() - t0,
                                          status="interrupted", message=str(exc))
            _err(f"interrupted: {exc}; the {(len(part.t) - 1) * scenario.save_every} steps computed are written to "
                 f"{outdir} ({', '.join(p.name for p in files)}); `lgvi run {args.scenario} -o {outdir} --resume` "
                 "continues the run")
        else:
            _err(f"interrupted: {exc}")
        return 130
    except (ConvergenceError, TorqueError) as exc:
        part = getattr(exc, "trajectory", None)
        msg = f"{type(exc).__name__}: {exc}"
        if part is not None and len(part.t):
            _write_system_results(part, scenario, outdir, False, time.perf_counter() - t0, status="failed",
                                  message=str(exc))
            msg += f" (the part computed is written to {outdir})"
        raise RunFailure(msg) from None
    wall = time.perf_counter() - t0
    if loud:
        rate = scenario.steps / wall if wall > 0 else float("inf")
        print(f"lgvi run: {scenario.name}: done in {wall:.3g} s ({rate:.3g} steps/s)", file=sys.stderr, flush=True)
    files = _write_system_results(traj, scenario, outdir, plots, wall, kernel_load=t_load)
    if not args.keep_stream:
        _remove_stream(stream)
    print(f"{scenario.name}: {scenario.steps} steps in {wall:.3g} s; wrote {len(files)} files to {outdir}")
    for p in files:
        print(f"  {p.name}")
    return 0


def _run_loop_ensemble(args: argparse.Namespace, scenario) -> int:
    """``lgvi run`` of a spacecraft scenario with ``[ensemble]``: its members in the compiled loop in
    threads (in memory: no stream, no ``--resume``), saved as ``ensemble.npz`` with
    ``summary.txt``/``summary.json``: each member's :func:`lgvi.io.scenario_loop.loop_summary`
    and the ensemble's statistics (:func:`lgvi.io.scenario_ensemble.ensemble_summary`)."""
    import lgvi

    from ..errors import ConvergenceError, SimulationInterrupted, TorqueError
    from ..io.scenario_ensemble import ensemble_lines, ensemble_summary
    from ..io.scenario_loop import loop_summary, mode_text

    if args.resume:
        raise UsageError("--resume: an [ensemble] scenario runs in memory (no stream to resume); run it again")
    formats = _parse_formats(args.format, scenario.formats)
    if formats != ("npz",):
        raise UsageError(f"--format: the results of an [ensemble] scenario are saved as npz only; got {args.format!r}")
    outdir = _outdir(args, scenario)
    _check_outdir(outdir)
    B = len(scenario.members)
    print(f"lgvi run: {scenario.name}: {B} members of {scenario.steps} steps of h = {scenario.h:g} s ...",
          file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    try:
        ens = scenario.run_ensemble()
    except SimulationInterrupted as exc:
        _err(f"interrupted: {exc}")
        return 130
    except (ConvergenceError, TorqueError) as exc:      # a component's failure too (ComponentError), naming the member
        raise RunFailure(f"{type(exc).__name__}: {exc}") from None
    wall = time.perf_counter() - t0
    outdir.mkdir(parents=True, exist_ok=True)
    ens.save(outdir / "ensemble.npz")
    write_text(outdir / "scenario.toml", scenario.text, "scenario copy")
    per_member = [loop_summary(ens[b]) for b in range(B)]
    stats = ensemble_summary(per_member)
    data = {"status": "complete", "system": "spacecraft", "scenario_name": scenario.name,
            "scenario_source": scenario.source, "lgvi_version": lgvi.__version__, "members": B,
            "seed": scenario.ensemble.seed, "steps": scenario.steps, "h": scenario.h, "wall_time_s": wall,
            "ensemble": stats, "member_summaries": per_member,
            "files": ["ensemble.npz", "scenario.toml", "summary.txt", "summary.json"], "scenario": scenario.text}
    write_text(outdir / "summary.json", json.dumps(data, indent=2) + "\n", "summary")
    lines = [f"lgvi {lgvi.__version__} run of scenario {scenario.name!r} ({scenario.source}): an ensemble",
             *([f"  {scenario.description}"] if scenario.description else []),
             f"status:        complete, {B} members (seed {scenario.ensemble.seed}) of {scenario.steps} steps, "
             f"h = {scenario.h:g} s, in {wall:.4g} s",
             *ensemble_lines(stats), "",
             "members (settle time [s], error after settling mean / max [deg], or why not settled; final rate "
             "[deg/s], final mode):",
             *(f"  {b:4d}  " + (f"not settled: {s.get('not_settled')}" if s["settle_time_s"] is None else
                                f"{s['settle_time_s']:g}  {s['error_deg']['mean']:.3g} / {s['error_deg']['max']:.3g}")
               + f"  {s['rate_final_deg_s']:.3g}" + (f"  {mode_text(s['modes'][-1])}" if s.get("modes") else "")
               for b, s in enumerate(per_member)),
             "", f"files:         {', '.join(data['files'])}", "", "scenario:",
             *("  " + line for line in scenario.text.rstrip("\n").splitlines()), ""]
    write_text(outdir / "summary.txt", "\n".join(lines), "summary")
    print(f"{scenario.name}: {B} members of {scenario.steps} steps in {wall:.3g} s; wrote {len(data['files'])} files "
          f"to {outdir}")
    for name in data["files"]:
        print(f"  {name}")
    return 0


# ------------------------------------------------------------------------------------ compare
def _parse_with(text: str) -> tuple[str, ...]:
    items = [w.strip().lower() for w in text.split(",") if w.strip()]
    bad = [w for w in items if w not in BASELINES]
    if bad or not items:
        raise UsageError(f"--with: expected a comma-separated list of {', '.join(BASELINES)}; got {text!r}")
    return tuple(dict.fromkeys(items))


def _baseline(name: str, scenario, rtol: float):
    from ..verification import baselines

    if name == "rk4":
        if not hasattr(baselines, "rk4"):
            raise RunFailure("the rk4 baseline is not available in this version of lgvi.baselines")
        traj = baselines.rk4(scenario.body, scenario.R0, scenario.Pi0, h=scenario.h, steps=scenario.steps,
                             torque=scenario.torque, save_every=scenario.save_every)
        return traj, f"RK4 h={scenario.h:g}", scenario.steps
    method = {"rk45": "RK45", "dop853": "DOP853"}[name]
    traj = baselines.solve_ivp_baseline(scenario.body, scenario.R0, scenario.Pi0, t_final=scenario.duration,
                                        samples=scenario.samples, method=method, rtol=rtol, atol=rtol * 1e-3,
                                        torque=scenario.torque)
    nfev = int(traj.iterations[0]) if len(traj.iterations) else 0
    return traj, f"{method} rtol={rtol:g}", nfev


def cmd_compare(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from ..invariants import Declaration, declaration_of
    from ..io.outputs import conservation_drifts

    scenario = _load(args.scenario)
    which = _parse_with(args.with_)
    if not args.rtol > 0:
        raise UsageError(f"--rtol must be positive, got {args.rtol}")
    if scenario.steps == 0:
        raise UsageError(f"{scenario.source}: nothing to compare: the scenario has 0 steps")
    _warm(scenario, which)
    print(f"lgvi compare: {scenario.name}: T = {scenario.duration:g} s, h = {scenario.h:g} s, "
          f"{scenario.steps} steps, torque {' + '.join(s['type'] for s in scenario.torque_spec) or 'none'}")
    print("  steps column: steps taken (fixed-step methods) or right-hand-side evaluations (solve_ivp)")
    print()
    # the problem's invariants, for every run (the baselines' trajectories carry no declaration)
    decl = Declaration(declaration_of(scenario.torque),
                       "the free body" if scenario.torque is None else repr(scenario.torque))
    print(table_header(decl))
    done: list[tuple[str, str, Any]] = []  # (key, label, trajectory)
    rows: list[dict[str, Any]] = []
    failed = []
    runs = [("lgvi", None)] + [(w, w) for w in which]
    for key, base in runs:
        t0 = time.perf_counter()
        try:
            if base is None:  # without the error estimate's second run, so that wall times compare
                traj = replace(scenario, error_estimate=False).run()
                label, count = f"lgvi {scenario.method} h={scenario.h:g}", scenario.steps
            else:
                traj, label, count = _baseline(base, scenario, args.rtol)
        except Exception as exc:  # a failing baseline is reported in its row, the others still run
            failed.append(key)
            print(f"{key:<24} failed: {type(exc).__name__}: {exc}")
            rows.append({"name": key, "status": "failed", "message": f"{type(exc).__name__}: {exc}"})
            continue
        wall = time.perf_counter() - t0
        if "invariants" not in traj.meta:
            traj = replace(traj, meta=dict(traj.meta, invariants=decl.entries))
        print(drift_table_row(label, traj, count, wall, decl))
        done.append((key, label, traj))
        rows.append({"name": key, "label": label, "status": "ok", "steps_or_nfev": count, "wall_time_s": wall,
                     "drifts": conservation_drifts(traj, decl)})
    print()
    print(table_legend(decl))
    if args.output:
        out = Path(args.output)
        out.mkdir(parents=True, exist_ok=True)
        written = []
        for key, _, traj in done:
            traj.save(out / f"{key}.npz")
            written.append(out / f"{key}.npz")
        write_text(out / "compare.json", json.dumps({"scenario_name": scenario.name, "rtol": args.rtol,
                                                    "invariants": decl.labels(), "runs": rows,
                                                    "scenario": scenario.text}, indent=2) + "\n", "comparison")
        written.append(out / "compare.json")
        if not args.no_plots and done:
            plot = _plot_module()
            if plot is not None:
                written += list(plot.save_comparison({label: traj for _, label, traj in done}, out))
        print(f"  wrote to {out}: {', '.join(p.name for p in written)}")
    if failed:
        raise RunFailure(f"{len(failed)} of {len(runs)} runs failed: {', '.join(failed)}")
    return 0


# ------------------------------------------------------------------------------------ plot / info
def _read(path: str):
    from ..io.outputs import read_trajectory

    if not Path(path).exists():
        raise UsageError(f"{path}: no such file")
    try:
        return read_trajectory(path)
    except ValueError as exc:
        msg = str(exc)
        raise UsageError(msg if str(path) in msg else f"{path}: {msg}") from None


def cmd_plot(args: argparse.Namespace) -> int:
    traj = _read(args.trajectory)
    if hasattr(traj, "members"):
        raise UsageError(f"{args.trajectory} holds an ensemble of {len(traj)} runs; lgvi plot draws one run "
                         "(lgvi info describes the ensemble)")
    if args.animate and hasattr(traj, "x"):
        raise UsageError(f"--animate: {args.trajectory} is a {traj.meta.get('system')} result; the animation "
                         "shows one rigid body")
    outdir = Path(args.output) if args.output else Path(args.trajectory).resolve().parent
    try:
        plot = importlib.import_module("lgvi.plot")
    except ImportError as exc:
        raise RunFailure(f"figures need lgvi.plot and matplotlib ({exc}): pip install 'lgvi[plot]'") from None
    files = list(plot.save_figures(traj, outdir, prefix=args.prefix))
    if args.animate:
        files.append(Path(plot.animate(traj, outdir / f"{args.prefix}animation.gif")))
    print(f"wrote {len(files)} files to {outdir}")
    for p in files:
        print(f"  {Path(p).name}")
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    from ..invariants import KIND_TEXT, QUANTITIES, declared
    from ..io.outputs import conservation_drifts

    traj = _read(args.trajectory)
    if hasattr(traj, "members"):                    # a gyrostat ensemble
        return _info_ensemble(args.trajectory, traj)
    if hasattr(traj, "x") or not hasattr(traj, "R") or not hasattr(traj, "steps"):   # an orbit, two bodies, another system
        return _info_system(args.trajectory, traj)
    meta = dict(traj.meta)
    scenario_text = meta.pop("scenario", None)
    meta.pop("solver_summary", None)  # printed on the solver lines
    print(f"{args.trajectory}: {traj!r}")
    print(f"  samples     {len(traj.t)}  (R {tuple(traj.R.shape)}, Pi {tuple(traj.Pi.shape)})")
    steps = traj.steps if len(traj.iterations) or "steps" not in meta else meta["steps"]
    print(f"  steps       {steps}, h = {traj.h:g}")
    if len(traj.t):
        print(f"  time        {traj.t[0]:g} .. {traj.t[-1]:g} s")
    print(f"  method      {meta.get('method', '?')}")
    J = np.asarray(traj.inertia)
    print(f"  inertia     {np.array2string(np.diag(J) if np.count_nonzero(J - np.diag(np.diag(J))) == 0 else J, precision=6)}")
    if len(traj.iterations) and len(traj.residual):
        solver = traj.solver_summary
        print(f"  solver      mean {solver['iterations_mean'] or 0.0:.3f} iterations/step, "
              f"max {solver['iterations_max']}, max residual {solver['residual_max']:.3e} "
              f"(record: {solver['record']})")
        hist = solver["histogram"]
        print("  histogram   steps by solver updates: " + ", ".join(
            f"{i}{'+' if i == len(hist) - 1 else ''}: {int(c)}" for i, c in enumerate(hist) if c))
    if traj.potential is not None:
        print("  potential   yes (energy = kinetic + potential)")
    print("  metadata")
    for k in sorted(meta):
        print(f"    {k:<16} {meta[k]}")
    if len(traj.t):
        decl = declared(traj)
        d = conservation_drifts(traj, decl)
        _print_conservation(decl, d, d["orthogonality_max"], short_names=True)
    if scenario_text:
        print("  scenario")
        for line in scenario_text.rstrip("\n").splitlines():
            print(f"    {line}")
    return 0


def _print_meta(meta: dict[str, Any]) -> None:
    scenario_text = meta.pop("scenario", None)
    print("  metadata")
    for k in sorted(meta):
        print(f"    {k:<16} {meta[k]}")
    if scenario_text:
        print("  scenario")
        for line in str(scenario_text).rstrip("\n").splitlines():
            print(f"    {line}")


def _info_system(path: str, traj) -> int:
    """``lgvi info`` of a result of :func:`lgvi.simulate_orbit` or :func:`lgvi.simulate_two_body`."""
    from ..invariants import KIND_TEXT, QUANTITIES, drifts as invariant_drifts
    from ..io.outputs import orthogonality_max

    meta = dict(traj.meta)
    system = meta.get("system")
    from ..systems import SYSTEMS

    print(f"{path}: {_SYSTEM_NAMES.get(system, system)}")
    shapes = ", ".join(f"{f.name} {tuple(np.shape(getattr(traj, f.name)))}" for f in SYSTEMS[system].state)
    print(f"  samples     {len(traj.t)}  ({shapes})")
    print(f"  steps       {max(len(traj.t) - 1, 0) * int(meta.get('save_every', 1))}, h = {traj.h:g}")
    if len(traj.t):
        print(f"  time        {traj.t[0]:g} .. {traj.t[-1]:g} s")
    for line in _system_lines(traj) if len(traj.t) else []:
        name, _, rest = line.partition(":")
        print(f"  {name:<11} {rest.strip()}")
    its, res = np.asarray(traj.iterations), np.asarray(traj.residual)
    if its.size:
        print(f"  solver      largest iterations per saved interval: mean {its.mean():.3f}, max {int(its.max())}; "
              f"max final residual (absolute) {float(res.max()):.3e}")
    if len(traj.t):
        decl = _system_declaration(traj)
        _print_conservation(decl, invariant_drifts(traj, decl), orthogonality_max(traj))
    meta.pop("invariants", None)        # printed above
    _print_meta(meta)
    return 0


def _print_conservation(decl: Any, d: dict[str, float], orthogonality: float, short_names: bool = False) -> None:
    """``lgvi info``'s conservation lines: each declared quantity's largest change ``d`` and kind."""
    from ..invariants import KIND_TEXT, QUANTITIES

    print(f"  conservation (largest change over the run; {decl.note()})")
    for k in decl.quantities():
        q = QUANTITIES[k]
        name = q.name.split(" (")[0] if short_names else q.name
        print(f"    {name} " + (f"abs {d[q.abs_key]:.3e}, " if q.abs_key else "")
              + f"rel {_fmt_drift(d[q.rel_key])} ({KIND_TEXT[decl.kind(k)]})")
    print(f"    |R^T R - I| max {orthogonality:.3e}")
    if decl.not_invariants():
        print(f"    not invariants here: {', '.join(QUANTITIES[k].name for k in decl.not_invariants())}")


def _info_ensemble(path: str, ens) -> int:
    """``lgvi info`` of a gyrostat ensemble (:meth:`lgvi.systems.gyrostat_ensemble.GyrostatEnsemble.save`)."""
    from ..invariants import KIND_TEXT, QUANTITIES, Declaration, declared, drifts as invariant_drifts

    B, M = len(ens), len(ens.t)
    print(f"{path}: {ens!r}")
    print(f"  members     {B}, {M} samples each (R {tuple(ens.R.shape)}, wheel_momentum "
          f"{tuple(ens.wheel_momentum.shape)})")
    if M:
        print(f"  time        {ens.t[0]:g} .. {ens.t[-1]:g} s, h = {ens.members[0].h:g}")
    print(f"  params      {', '.join(sorted(ens.params))}")
    disp = ens.dispersions
    print(f"  dispersed   {', '.join(sorted(disp)) if disp else 'nothing (every member has the same inputs)'}")
    if M:
        first = declared(ens.members[0])          # the members' controllers may differ: not named here
        n = ens.wheel_momentum.shape[-1]
        decl = Declaration(first.entries, f"each member (a gyrostat with {n} reaction wheels"
                           + (", its controller)" if ens.meta.get("torque") == "controller" else ")"), first.recorded)
        print(f"  conservation (largest change over the run, worst member; {decl.note()})")
        per = [invariant_drifts(m, declared(m)) for m in ens.members]
        for k in decl.quantities():
            q = QUANTITIES[k]
            vals = [p[q.rel_key] for p in per if p.get(q.rel_key) is not None]
            worst = max(vals) if vals else None
            print(f"    {q.name} rel {_fmt_drift(worst)} ({KIND_TEXT[decl.kind(k)]})")
        print(f"    |R^T R - I| max {max(float(np.max(m.orthogonality_error)) for m in ens.members):.3e}")
        if decl.not_invariants():
            print(f"    not invariants here: {', '.join(QUANTITIES[k].name for k in decl.not_invariants())}")
    _print_meta(dict(ens.meta))
    return 0


def _save_report(traj, outdir: Path, summary: dict[str, Any]) -> list[Path]:
    """``report.html`` (:mod:`lgvi.view`), or nothing (with a note on stderr) without plotly."""
    from .. import view

    try:
        return [view.write_html(traj, outdir / "report.html", summary=summary)]
    except ImportError as exc:
        _err(f"report.html skipped: {exc}")
        return []


def cmd_view(args: argparse.Namespace) -> int:
    from .. import view
    from ..systems import SYSTEMS

    traj = _read(args.trajectory)
    if not view.shows(traj):
        shown = ", ".join(k for k, s in SYSTEMS.items() if s.view is not None)
        raise UsageError(f"{args.trajectory}: lgvi view shows one rigid body's run or a result of {shown}; this "
                         f"file holds "
                         f"{'an ensemble' if hasattr(traj, 'members') else 'a ' + str(traj.meta.get('system')) + ' result'} "
                         "(lgvi info describes it, lgvi plot draws its figure)")
    out = Path(args.output) if args.output else Path(args.trajectory).with_suffix(".html")
    if args.max_frames < 2:
        raise UsageError(f"--max-frames must be an integer >= 2, got {args.max_frames}")
    if not len(traj.t):
        raise UsageError(f"{args.trajectory}: the trajectory has no samples, nothing to show")
    try:
        path = view.write_html(traj, out, title=f"lgvi: {Path(args.trajectory).name}",
                               max_frames=args.max_frames)
    except ImportError as exc:
        raise RunFailure(str(exc)) from None
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB, self-contained: open it in a browser, offline)")
    return 0


# ------------------------------------------------------------------------------------ example
def cmd_example(args: argparse.Namespace) -> int:
    from ..io import examples

    if args.name is None:
        print("example scenarios (lgvi example NAME writes NAME.toml; then lgvi run NAME.toml):")
        for name in examples.names():
            print(f"  {name:<18} {examples.summary(name)}")
        return 0
    try:
        path = examples.write(args.name, args.output, overwrite=args.force)
    except FileExistsError as exc:
        raise UsageError(str(exc)) from None
    print(f"wrote {path}; run it with: lgvi run {path}")
    return 0


# ------------------------------------------------------------------------------------ warmup
def cmd_warmup(args: argparse.Namespace) -> int:
    import inspect

    import lgvi
    from lgvi.registry import ORDERS, SOLVER_METHODS

    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    omega0 = [0.1, 1.0, 0.2]
    total = time.perf_counter()
    jobs: list[tuple[str, Any]] = [(f"simulate method={m}", dict(method=m)) for m in SOLVER_METHODS]
    try:
        from .. import torques
    except ImportError:
        torques = None
    params = inspect.signature(lgvi.simulate).parameters
    if torques is not None:
        model = torques.UniformGravity(1.0, [0.0, 0.0, 0.3]) + torques.LinearDamping(0.01)
        jobs.append(("simulate torque model", dict(torque=model)))
        if "forcing" in params:
            jobs.append(("simulate torque, symmetric", dict(torque=torques.Constant([0.0, 0.0, 0.01]),
                                                             forcing="symmetric")))
    if "order" in params:
        jobs += [(f"simulate order={o}", dict(order=o)) for o in ORDERS if o != 2]
    if "wheels" in params:   # the gyrostat's kernel (reaction wheels, compiled MRP feedback)
        jobs.append(("simulate wheels + MRPFeedback", dict(wheels=lgvi.ReactionWheels(np.eye(3), 0.01),
                                                            controller=lgvi.control.MRPFeedback(1.0, 1.0),
                                                            control_period=0.01)))
    for name, kw in jobs:
        t0 = time.perf_counter()
        with contextlib.ExitStack() as stack:
            if "wheels" in kw:     # the gyrostat's kernel, as scenario files with [[wheel]] run it (no warning)
                from ..systems.loop_keywords import as_given

                stack.enter_context(as_given())
            lgvi.simulate(body, np.eye(3), omega0=omega0, h=0.01, steps=20, **kw)
        print(f"  {name:<32} {time.perf_counter() - t0:8.2f} s")
    from ..verification import baselines

    if hasattr(baselines, "rk4"):
        t0 = time.perf_counter()
        baselines.rk4(body, np.eye(3), omega0=omega0, h=0.01, steps=20)
        print(f"  {'baseline rk4':<32} {time.perf_counter() - t0:8.2f} s")
    print(f"kernels ready in {time.perf_counter() - total:.2f} s (compiled now or loaded from Numba's cache)")
    return 0


# ------------------------------------------------------------------------------------ parser
def build_parser() -> argparse.ArgumentParser:
    from .._version import __version__

    parser = argparse.ArgumentParser(
        prog="lgvi", description="Lie group variational integrator for rigid-body attitude dynamics on SO(3). "
        "Without a command, runs the demo.",
        epilog="Exit codes: 0 ok, 1 run failure, 2 usage or input error, 130 interrupted.")
    parser.add_argument("--version", action="version", version=f"lgvi {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    demo = sub.add_parser("demo", help="run the default scenario (Dzhanibekov effect) and compare with RK45",
                          description="Run the default scenario and print a conservation table against RK45; "
                          "with -o also write the trajectory and figures.")
    demo.add_argument("-o", "--output", default=None, metavar="DIR", help="folder for the trajectory and figures")
    demo.add_argument("--steps", type=int, default=DEMO_STEPS, help=f"number of steps (default {DEMO_STEPS})")
    demo.add_argument("--no-plots", action="store_true", help="do not write figures")
    demo.set_defaults(func=cmd_demo)

    run = sub.add_parser("run", help="run a scenario file (TOML)",
                         description="Run a scenario file and write the trajectory, summary.txt, summary.json, "
                         "scenario.toml, figures and report.html (the interactive page). The file format is documented in lgvi.scenario "
                         "(python -c 'import lgvi.scenario; help(lgvi.scenario)').")
    run.add_argument("scenario", metavar="SCENARIO.toml", help="scenario file")
    run.add_argument("-o", "--output", default=None, metavar="DIR",
                     help="output folder (default ./NAME_output, NAME the scenario name as a safe file name)")
    run.add_argument("--no-plots", action="store_true", help="do not write figures")
    run.add_argument("--resume", action="store_true",
                     help="continue an interrupted or killed run from its last complete chunk in DIR/stream "
                          "(the result equals an uninterrupted run bit for bit)")
    run.add_argument("--keep-stream", action="store_true",
                     help="keep the chunk files of DIR/stream after a successful run (without it, only the "
                          "files the run wrote there are removed; anything else in DIR/stream is kept)")
    run.add_argument("--solver-record", default="interval", choices=("interval", "full"),
                     help="resolution of the solver's iterations/residual record: the largest per saved "
                     "interval (default; outputs sized by the saved states) or every step")
    run.add_argument("--format", default=None, metavar="FORMATS",
                     help="comma-separated output formats among npz, csv, netcdf (default: the scenario's "
                     "[output] formats, else npz)")
    run.set_defaults(func=cmd_run)

    cmp_ = sub.add_parser("compare", help="the same scenario through classical baselines",
                          description="Run a scenario with the LGVI and with baselines (fixed-step RK4 at the "
                          "same h; SciPy RK45/DOP853 at a tolerance) and print conservation errors and wall "
                          "times; with -o also write each trajectory, compare.json and overlaid figures.")
    cmp_.add_argument("scenario", metavar="SCENARIO.toml", help="scenario file")
    cmp_.add_argument("--with", dest="with_", default="rk4,rk45", metavar="LIST",
                      help=f"comma-separated baselines among {', '.join(BASELINES)} (default rk4,rk45)")
    cmp_.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance of rk45/dop853 (default 1e-6; "
                      "atol = rtol * 1e-3)")
    cmp_.add_argument("-o", "--output", default=None, metavar="DIR", help="folder for trajectories and figures")
    cmp_.add_argument("--no-plots", action="store_true", help="do not write figures")
    cmp_.set_defaults(func=cmd_compare)

    plot = sub.add_parser("plot", help="figures of a saved trajectory",
                          description="Write PNG figures (attitude, rates, conservation, iterations, polhode) of "
                          "a trajectory file (.npz, .csv with its .meta.json, or .nc).")
    plot.add_argument("trajectory", metavar="TRAJECTORY", help="trajectory file (.npz, .csv, .nc)")
    plot.add_argument("-o", "--output", default=None, metavar="DIR",
                      help="folder for the figures (default: the trajectory's folder)")
    plot.add_argument("--prefix", default="", help="prefix of the figure file names")
    plot.add_argument("--animate", action="store_true", help="also write animation.gif of the body")
    plot.set_defaults(func=cmd_plot)

    info = sub.add_parser("info", help="describe a saved trajectory",
                          description="Print the shape, times, method, metadata (with the scenario) and "
                          "conservation drifts of a trajectory file (.npz, .csv, .nc).")
    info.add_argument("trajectory", metavar="TRAJECTORY", help="trajectory file (.npz, .csv, .nc)")
    info.set_defaults(func=cmd_info)

    view = sub.add_parser("view", help="an interactive page of a saved trajectory (HTML)",
                          description="Write a self-contained HTML page (plotly, works offline) of a trajectory "
                          "file: the body turning in 3D with play, pause and a time scrubber, linked plots of "
                          "the rates, the declared invariants (and wheels, control error when present), and "
                          "the run's summary.")
    view.add_argument("trajectory", metavar="TRAJECTORY", help="trajectory file (.npz, .csv, .nc)")
    view.add_argument("-o", "--output", default=None, metavar="PAGE.html",
                      help="the page to write (default: the trajectory's name with .html)")
    view.add_argument("--max-frames", type=int, default=200, help="most animation frames (default 200)")
    view.set_defaults(func=cmd_view)

    warm = sub.add_parser("warmup", help="compile and cache the kernels",
                          description="Compile (or load from Numba's cache) every kernel by running each solver "
                          "method, torque path and baseline on a tiny problem; prints the time taken.")
    warm.set_defaults(func=cmd_warmup)

    example = sub.add_parser("example", help="list the example scenarios, or write one out",
                             description="Without a name, list the example scenarios shipped with lgvi; with one, "
                             "write it to NAME.toml (or -o PATH) for `lgvi run`.")
    example.add_argument("name", nargs="?", default=None, metavar="NAME", help="the example's name")
    example.add_argument("-o", "--output", default=None, metavar="PATH",
                         help="file or folder to write (default: NAME.toml here)")
    example.add_argument("--force", action="store_true", help="overwrite an existing file")
    example.set_defaults(func=cmd_example)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``lgvi`` and ``python -m lgvi``; returns the exit code."""
    from ..io.scenario import ScenarioError

    parser = build_parser()
    try:
        args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    except SystemExit as exc:  # --help (0) or a usage error (2, argparse printed it)
        return int(exc.code) if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    if args.command is None:
        args = parser.parse_args(["demo"])
    try:
        return int(args.func(args))
    except (ScenarioError, UsageError) as exc:
        _err(f"error: {exc}")
        return 2
    except ValueError as exc:  # input the library rejected (after the scenario's own checks)
        _err(f"error: {exc}")
        return 2
    except RunFailure as exc:
        _err(f"failed: {exc}")
        return 1
    except KeyboardInterrupt:
        _err("interrupted")
        return 130
    except OSError as exc:  # a full disk, another run writing the same stream: the message names the folder
        _err(f"failed: {exc}")
        return 1
    except RuntimeError as exc:  # ConvergenceError, TorqueError and other run failures
        _err(f"failed: {type(exc).__name__}: {exc}")
        return 1


__all__ = ["main", "run_demo", "write_summary"]
