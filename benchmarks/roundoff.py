"""Round-off floor of the high-order free-body methods, their round-off drift, and their speed.

Usage::

    python benchmarks/roundoff.py                    # full size
    python benchmarks/roundoff.py --quick            # reduced size, for CI (no assertions)
    python benchmarks/roundoff.py --before 9a10d4f   # also an earlier commit, interleaved
    python benchmarks/roundoff.py --before 9a10d4f --speed-only --repeat 21   # the speed table only

The problem is Hairer, Lubich and Wanner's free body: principal moments ``I = (0.5, 0.85, 1)``,
``Pi0 = (0.2, 1.0, 0.4)``, ``R0 = I``, step ``h = 0.05``, run with :func:`lgvi.simulate_modified`
(Cayley solver, default ``tol = 1e-14``). What is printed, all measured in this run:

1. The reference: :mod:`lgvi.exact` at ``T = 100`` against SciPy's DOP853 at ``rtol = atol =
   1e-14`` (SciPy raises ``rtol`` to ``2.2e-14``: it agrees to about 4e-13 rad only) and (full
   size, when mpmath is installed) against mpmath's Taylor integrator at 24 digits. The attitude
   error of a method is only meaningful well above this agreement.
2. The floor: the final attitude error (rad) at ``T = 100`` against :mod:`lgvi.exact` for orders
   8, 10 and 12 (at orders 10 and 12 the truncation error is far below 1e-13, so this is
   round-off; order 8 may carry about 1e-13 of truncation), for the
   problem as stated and, because one trajectory's round-off is one draw, the root mean square
   and maximum over starts ``Pi0 (1 + 1e-7 j)`` (24 of them; 8 with ``--quick``).
3. The drift over 1e5 steps (2e4 with ``--quick``) of order 10: the largest relative deviation of
   the energy, of ``|Pi|`` and of the spatial momentum ``R Pi``, invariants of the scheme, so all
   of it is round-off.
4. Speed: steps per second of the compiled free-body loop (``run_chunk``/``run_chunk_cayley``,
   1e6 steps every one saved, as ``benchmarks/run.py``) on that script's body (``J = (1, 2, 3)``,
   ``h = 0.01``) and on the problem above, and of ``simulate_modified`` (order 10), median of
   ``--repeat`` runs.

With ``--before REV`` the package's sources at git revision ``REV`` are extracted into a
temporary folder and imported under another name, and every figure is printed for both, the
timings interleaved (before, after, before, ...) so the machine's noise affects both alike; the
speed ratio is ``after / before``.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
HLW_I = (0.5, 0.85, 1.0)
HLW_PI0 = (0.2, 1.0, 0.4)
HLW_H = 0.05
T_END = 100.0
ORDERS = (8, 10, 12)


def load_before(rev: str, tmp: str):
    """The package at git revision ``rev``, imported as ``lgvi_before`` from a copy in ``tmp``."""
    archive = os.path.join(tmp, "src.tar")
    subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", "-o", archive, rev, "src/lgvi"], check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(tmp, filter="data")
    os.rename(os.path.join(tmp, "src", "lgvi"), os.path.join(tmp, "src", "lgvi_before"))
    sys.path.insert(0, os.path.join(tmp, "src"))
    pkg = importlib.import_module("lgvi_before")
    for sub in ("modified", "exact", "_kernels.stepping"):
        importlib.import_module(f"lgvi_before.{sub}")
    return pkg


def rotation_angle(A: np.ndarray, B: np.ndarray) -> float:
    """Angle (rad) of ``A^T B``, accurate for small angles."""
    M = A.T @ B
    s = 0.5 * math.hypot(M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1])
    return math.atan2(s, 0.5 * (np.trace(M) - 1.0))


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _rhs(Iv, y, ops):
    """Euler's equations and ``q' = q (0, Omega) / 2`` (``R' = R hat(Omega)``), ``y = (Pi, q)``."""
    P, (w, x, yy, z) = y[0:3], y[3:7]
    a, b, c = (P[i] / Iv[i] for i in range(3))
    return ops([P[1] * c - P[2] * b, P[2] * a - P[0] * c, P[0] * b - P[1] * a,
                0.5 * (-x * a - yy * b - z * c), 0.5 * (w * a + yy * c - z * b), 0.5 * (w * b + z * a - x * c),
                0.5 * (w * c + x * b - yy * a)])


def reference_check(exact, full: bool) -> list[str]:
    from scipy.integrate import solve_ivp

    R_ex, Pi_ex = exact.free_body(HLW_I, np.eye(3), HLW_PI0, np.array([T_END]))
    lines = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)         # SciPy raises rtol to 100 eps = 2.2e-14
        sol = solve_ivp(lambda t, y: _rhs(HLW_I, y, np.array), (0.0, T_END), [*HLW_PI0, 1.0, 0.0, 0.0, 0.0],
                        method="DOP853", rtol=1e-14, atol=1e-14)
    y = sol.y[:, -1]
    eR = rotation_angle(R_ex[0], _quat_matrix(y[3:]))
    lines.append(f"  lgvi.exact vs DOP853 rtol=atol=1e-14 (SciPy: rtol 2.2e-14): attitude {eR:.2e} rad, "
                 f"|dPi| {np.linalg.norm(Pi_ex[0] - y[:3]):.2e}")
    try:
        import mpmath
    except ImportError:
        mpmath = None
    if not full or mpmath is None:
        lines.append("  lgvi.exact vs mpmath Taylor, 24 digits: skipped" + (" (--quick)" if not full else
                                                                            " (mpmath not installed)"))
        return lines
    mpmath.mp.dps = 24
    Iv = [mpmath.mpf(str(v)) for v in HLW_I]
    sol = mpmath.odefun(lambda t, y: _rhs(Iv, y, list), 0, [mpmath.mpf(str(v)) for v in HLW_PI0] + [1, 0, 0, 0])
    y = np.array([float(v) for v in sol(T_END)])
    eR = rotation_angle(R_ex[0], _quat_matrix(y[3:]))
    lines.append(f"  lgvi.exact vs mpmath Taylor, 24 digits: attitude {eR:.2e} rad, "
                 f"|dPi| {np.linalg.norm(Pi_ex[0] - y[:3]):.2e}")
    return lines


def floor_errors(pkg, order: int, starts: int) -> tuple[float, float, float]:
    """Final attitude error at T_END: the stated problem, rms and max over perturbed starts."""
    steps = int(round(T_END / HLW_H))
    errs = []
    for j in range(starts):
        Pi0 = np.array(HLW_PI0) * (1.0 + 1e-7 * j)
        R_ex, _ = pkg.exact.free_body(HLW_I, np.eye(3), Pi0, np.array([T_END]))
        tr = pkg.modified.simulate_modified(HLW_I, np.eye(3), Pi0, h=HLW_H, steps=steps, order=order,
                                            save_every=steps)
        errs.append(rotation_angle(tr.R[-1], R_ex[0]))
    e = np.array(errs)
    return e[0], float(np.sqrt(np.mean(e * e))), float(e.max())


def drift(pkg, steps: int) -> tuple[float, float, float]:
    """Largest relative deviation of energy, |Pi| and R Pi over ``steps`` steps of order 10."""
    save = 100
    tr = pkg.modified.simulate_modified(HLW_I, np.eye(3), np.array(HLW_PI0), h=HLW_H, steps=steps, order=10,
                                        save_every=save)
    Iv = np.array(HLW_I)
    E = 0.5 * np.sum(tr.Pi ** 2 / Iv, axis=1)
    C = np.linalg.norm(tr.Pi, axis=1)
    L = np.einsum("kij,kj->ki", tr.R, tr.Pi)
    return (float(np.max(np.abs(E / E[0] - 1.0))), float(np.max(np.abs(C / C[0] - 1.0))),
            float(np.max(np.linalg.norm(L - L[0], axis=1)) / C[0]))


def _kernel_runner(pkg, J, Pi0, h, code, steps):
    st = importlib.import_module(pkg.__name__ + "._kernels.stepping")
    body = pkg.RigidBody(J)
    Pi0 = np.asarray(Pi0, dtype=float)
    out = (np.ones((steps, 3, 3)), np.ones((steps, 3)), np.ones(steps, np.int32), np.ones(steps))
    kernel = st.run_chunk_cayley if code == 2 else st.run_chunk
    # revisions after the per-interval solver record (issue 17) take the iteration histogram too
    params = kernel.py_func.__code__.co_varnames[:kernel.py_func.__code__.co_argcount]
    extra = (np.zeros(64, np.int64),) if "counts" in params else ()

    def run():
        G = np.zeros((5, 3))              # rows 0-3 the solver history, row 4 (newer) Pi's low part
        G[0] = np.linalg.solve(body.J, h * Pi0) * (0.5 if code == 2 else 1.0)
        G[3, 0] = 1.0
        status = kernel(code, body.Jd, h, np.eye(3), Pi0.copy(), G, np.zeros((0, 3)), 0, steps, 1e-14, 50, 1.0,
                        1, *out, np.zeros(0), *extra)[0]
        assert status == 0
        return float(out[2].mean())

    return run


def speed_cases(pkg, steps: int):
    """``(name, callable returning the mean solver updates per step or None)`` of the timed cases."""
    J = np.array([1.0, 2.0, 3.0])
    P = J * np.array([0.3, 1.0, 0.2])
    Jt = pkg.modified.modified_inertia(HLW_I, HLW_PI0, HLW_H, 10)

    def modified():
        pkg.modified.simulate_modified(HLW_I, np.eye(3), np.array(HLW_PI0), h=HLW_H, steps=steps, order=10)

    return [("loop newton, J=(1,2,3) h=0.01", _kernel_runner(pkg, J, P, 0.01, 1, steps)),
            ("loop cayley, J=(1,2,3) h=0.01", _kernel_runner(pkg, J, P, 0.01, 2, steps)),
            ("loop cayley, HLW order 10", _kernel_runner(pkg, pkg.RigidBody(Jt).J, HLW_PI0, HLW_H, 2, steps)),
            ("simulate_modified, HLW order 10", modified)]


def accuracy(versions, quick: bool, starts: int, drift_steps: int) -> None:
    """Print the reference check, the floor table and the drift table."""
    import lgvi.exact

    print("reference at T = 100:")
    for line in reference_check(lgvi.exact, not quick):
        print(line)
    print(f"\nfloor: final attitude error (rad) at T = {T_END:g} against lgvi.exact; rms and max over "
          f"{starts} starts Pi0 (1 + 1e-7 j)")
    print(f"  {'version':22s} {'order':>5s} {'HLW':>9s} {'rms':>9s} {'max':>9s}")
    for name, pkg in versions:
        for order in ORDERS:
            e0, rms, emax = floor_errors(pkg, order, starts)
            print(f"  {name:22s} {order:5d} {e0:9.2e} {rms:9.2e} {emax:9.2e}")
    print(f"\ndrift over {drift_steps:.0e} steps (order 10, h = {HLW_H}): largest relative deviation")
    print(f"  {'version':22s} {'energy':>9s} {'|Pi|':>9s} {'R Pi':>9s}")
    for name, pkg in versions:
        dE, dC, dL = drift(pkg, drift_steps)
        print(f"  {name:22s} {dE:9.2e} {dC:9.2e} {dL:9.2e}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced size for CI")
    parser.add_argument("--repeat", type=int, default=None, help="timed runs per entry (median)")
    parser.add_argument("--before", metavar="REV", help="also measure the sources at this git revision")
    parser.add_argument("--speed-only", action="store_true", help="only the speed table")
    args = parser.parse_args(argv)
    starts = 8 if args.quick else 24
    drift_steps = 20_000 if args.quick else 100_000
    speed_steps = 20_000 if args.quick else 1_000_000
    repeat = args.repeat or (3 if args.quick else 11)

    import lgvi
    import lgvi._kernels.stepping
    import lgvi.exact
    import lgvi.modified

    with tempfile.TemporaryDirectory() as tmp:
        versions = [("after", lgvi)]
        if args.before:
            versions.insert(0, (f"before ({args.before})", load_before(args.before, tmp)))
        print(f"HLW free body: I = {HLW_I}, Pi0 = {HLW_PI0}, h = {HLW_H}, simulate_modified (cayley, tol = 1e-14)")
        if not args.speed_only:
            accuracy(versions, args.quick, starts, drift_steps)
        print(f"\nspeed: steps/s, {speed_steps:.0e} steps, median of {repeat}"
              + (", versions interleaved" if len(versions) > 1 else ""))
        cases = [speed_cases(pkg, speed_steps) for _, pkg in versions]
        times = [[[] for _ in cases[0]] for _ in versions]
        updates = [[None for _ in cases[0]] for _ in versions]
        for rep in range(repeat + 1):                       # the first round warms up (compiles)
            for c in range(len(cases[0])):
                for v in range(len(versions)):
                    t0 = time.perf_counter()
                    u = cases[v][c][1]()
                    if rep:
                        times[v][c].append(time.perf_counter() - t0)
                    updates[v][c] = u
        header = f"  {'case':32s}" + "".join(f" {name:>22s}" for name, _ in versions)
        print(header + ("   after/before" if len(versions) > 1 else ""))
        for c, (cname, _) in enumerate(cases[0]):
            sps = [speed_steps / statistics.median(times[v][c]) for v in range(len(versions))]
            cells = "".join(f" {s:13.3e}" + (f" ({updates[v][c]:.3f} upd)" if updates[v][c] is not None else " " * 11)
                            for v, s in enumerate(sps))
            ratio = ""
            if len(versions) > 1:
                pairs = [b / a for a, b in zip(times[1][c], times[0][c])]   # per round: t_before / t_after
                ratio = f"   {sps[1] / sps[0]:.3f} (median of rounds {statistics.median(pairs):.3f})"
            print(f"  {cname:32s}{cells}{ratio}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
