"""Wall time of :func:`lgvi.optimal.transfer` against the number of steps: SciPy's SLSQP and
trust-constr against IPOPT (CasADi, ``method="ipopt"``).

Usage::

    python benchmarks/bench_transfer.py                  # N = 200, 1000, 4000; 3 rounds; SLSQP, IPOPT
    python benchmarks/bench_transfer.py --steps 20 40 --solvers SLSQP trust-constr ipopt
    python benchmarks/bench_transfer.py --quick          # reduced size, for CI (no timing assertions)

The problem is the asymmetric slew of the tests (``J = diag(1, 2, 2.5)``, from rest-ish
``omega0 = (0.1, 0, -0.1)`` to ``omegaf = (0, 0.05, 0)`` and the attitude ``exp(0.8, -0.5, 1.2)``
in ``T = 3``, minimum energy), with the torque box ``|u_i| <= 1.5`` (active) and without it. The
same start (the eigenaxis cubic) and tolerances for every solver (``tol = 1e-10``,
``constraint_tol = 1e-8``). Per round the solvers run one after another (interleaved, so the load of
a shared machine affects them alike); the table gives the median wall time over the rounds, the
iterations, the constraint evaluations (one rollout and one reverse pass each), the final cost and
the ratio of each solver's median time to IPOPT's (``> 1``: IPOPT is faster).

SLSQP's quasi-Newton matrix is dense (``3N x 3N``) and its QP subproblem treats the ``6N`` bounds as
inequalities; trust-constr keeps dense quasi-Newton matrices too and, with the box, runs its
interior-point method for hundreds of iterations (474 s at N = 20 in one run with the machine
loaded, 2900x IPOPT): it is not in the default set. Their time grows at least
quadratically in ``N``, so a SciPy solver whose time at the previous ``N``, scaled by ``(N/N_prev)^2``,
exceeds ``--budget`` seconds is not run at the larger ``N`` (the row says so, with that estimate).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import lgvi  # noqa: E402
from lgvi import so3  # noqa: E402
from lgvi.optimal import TransferError, transfer  # noqa: E402

BODY = lgvi.RigidBody([1.0, 2.0, 2.5])
RF = so3.exp([0.8, -0.5, 1.2])
SLEW = dict(omega0=[0.1, 0.0, -0.1], omegaf=[0.0, 0.05, 0.0])
SOLVERS = ("SLSQP", "trust-constr", "ipopt")
DEFAULT = ("SLSQP", "ipopt")       # trust-constr: opt in (--solvers); 474 s at N = 20 with the box


def solve(method: str, N: int, box: bool) -> dict:
    t = time.perf_counter()
    try:
        res = transfer(BODY, np.eye(3), RF, 3.0, N, method=method, max_torque=1.5 if box else None, **SLEW)
        out = {"cost": res.cost, "iterations": res.stats["iterations"], "evaluations": res.stats["function_evaluations"],
               "ok": "yes"}
    except TransferError as exc:
        out = {"cost": exc.best.cost, "iterations": -1, "evaluations": -1, "ok": "FAILED"}
    out["wall"] = time.perf_counter() - t
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="reduced size (CI)")
    ap.add_argument("--steps", type=int, nargs="+", default=[200, 1000, 4000])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--budget", type=float, default=300.0,
                    help="skip a SciPy solver at an N where its estimated time exceeds this (s)")
    ap.add_argument("--solvers", nargs="+", default=list(DEFAULT), choices=SOLVERS,
                    help="default: SLSQP and ipopt (trust-constr's interior point is far slower with the box)")
    args = ap.parse_args()
    steps, rounds = ([10, 20], 1) if args.quick else (sorted(args.steps), args.rounds)
    try:
        import casadi
        have_ipopt = True
        version = f"casadi {casadi.__version__}"
    except ImportError:
        have_ipopt, version = False, "casadi not installed: no IPOPT rows (pip install lgvi[ipopt])"
    solvers = [s for s in args.solvers if s != "ipopt" or have_ipopt]
    print(f"transfer: asymmetric slew, T = 3, minimum energy; {rounds} round(s), medians; {version}; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    for s in solvers:                                    # compile the kernels, load IPOPT
        solve(s, 10, True)

    header = (f"{'box':>5} {'N':>6} {'solver':>13} {'wall s':>10} {'iters':>6} {'evals':>6} {'cost':>16} "
              f"{'ok':>6} {'time/ipopt':>11}")
    for box in (True, False):
        print()
        print(header)
        print("-" * len(header))
        last: dict[str, tuple[int, float]] = {}
        for N in steps:
            runs: dict[str, list[dict]] = {s: [] for s in solvers}
            skipped: dict[str, float] = {}
            for s in solvers:
                if s != "ipopt" and s in last:
                    estimate = last[s][1] * (N / last[s][0]) ** 2
                    if estimate > args.budget:
                        skipped[s] = estimate
            for _ in range(rounds):
                for s in solvers:
                    if s not in skipped:
                        runs[s].append(solve(s, N, box))
            med = {s: statistics.median(r["wall"] for r in runs[s]) for s in solvers if runs[s]}
            for s in solvers:
                if s in skipped:
                    print(f"{'yes' if box else 'no':>5} {N:>6} {s:>13}   not run: estimated {skipped[s]:.0f} s "
                          f"> --budget {args.budget:.0f} s")
                    continue
                last[s] = (N, med[s])
                r = runs[s][-1]
                ratio = f"{med[s] / med['ipopt']:.2f}" if "ipopt" in med else "-"
                print(f"{'yes' if box else 'no':>5} {N:>6} {s:>13} {med[s]:>10.3f} {r['iterations']:>6} "
                      f"{r['evaluations']:>6} {r['cost']:>16.10f} {r['ok']:>6} {ratio:>11}", flush=True)


if __name__ == "__main__":
    main()
