"""The Kepler problem of the paper's introduction: a variational integrator against Runge-Kutta
============================================================================================

Stormer-Verlet is the variational integrator of the trapezoidal discrete Lagrangian
``L_d = h [|q1 - q0|^2 / (2 h^2) - (V(q0) + V(q1))/2]`` with ``V = -mu/|q|`` (lgvi.discrete,
compiled). It keeps the angular momentum ``q x p`` to round-off and its energy error bounded;
classical RK4 at the same step, and SciPy's adaptive RK45, let both drift.

Usage::

    python examples/kepler.py [--steps 20000] [--quick] [--h 0.05] [--eccentricity 0.5] [--out DIR] [--no-plots]

The figure of the errors goes to ``DIR/kepler_errors.png`` (default ``output/kepler``);
``--plot FILE.png`` names the file instead.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from lgvi import discrete


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--steps", type=int, default=20_000, help="number of steps (default 20000)")
    parser.add_argument("--quick", action="store_true", help="short run (2000 steps)")
    parser.add_argument("--h", type=float, default=0.05, help="step size (default 0.05)")
    parser.add_argument("--eccentricity", type=float, default=0.5, help="orbit eccentricity (default 0.5)")
    parser.add_argument("--out", default="output/kepler", help="folder for the figure")
    parser.add_argument("--no-plots", action="store_true", help="skip the figure")
    parser.add_argument("--plot", metavar="PNG", help="file for the figure (instead of OUT/kepler_errors.png)")
    args = parser.parse_args(argv)
    if args.quick:
        args.steps = 2000

    mu = 1.0
    q0, p0 = discrete.kepler_initial_state(args.eccentricity, mu)
    h, steps = args.h, args.steps
    t = h * np.arange(steps + 1)
    runs: dict[str, tuple[np.ndarray, np.ndarray, float]] = {}

    Ld = discrete.kepler(mu).discrete_lagrangian(h)                # trapezoidal rule: Stormer-Verlet
    discrete.simulate_discrete(Ld, q0, p0, steps=1)                # compile (or load from cache)
    start = time.perf_counter()
    traj = discrete.simulate_discrete(Ld, q0, p0, steps=steps)
    runs["Stormer-Verlet (lgvi)"] = (traj.q, traj.p, time.perf_counter() - start)

    start = time.perf_counter()
    Q, P = discrete.kepler_rk4(q0, p0, h, steps, mu)
    runs[f"RK4, h = {h:g}"] = (Q, P, time.perf_counter() - start)

    start = time.perf_counter()
    sol = solve_ivp(lambda _, y: np.r_[y[2:], -mu * y[:2] / np.linalg.norm(y[:2]) ** 3], (0.0, t[-1]),
                    np.r_[q0, p0], method="RK45", t_eval=t, rtol=1e-6, atol=1e-9)
    runs[f"scipy RK45 (rtol 1e-6, {sol.nfev} f-evals)"] = (sol.y[:2].T, sol.y[2:].T, time.perf_counter() - start)

    E0 = discrete.kepler_energy(q0, p0, mu)
    L0 = discrete.kepler_angular_momentum(q0, p0)
    print(f"Kepler orbit, e = {args.eccentricity:g}, h = {h:g}, {steps} steps "
          f"(t = {t[-1]:g}, {t[-1] / (2 * np.pi / np.sqrt(mu)):.0f} orbits)")
    # energy drift: change of the mean energy error from the first to the last tenth of the run
    # (a bounded, oscillating error has none; a secular one shows here)
    header = f"{'method':40s} {'max |dL|/|L0|':>14s} {'max |dE|':>10s} {'E drift':>10s} {'time [s]':>9s}"
    print(header)
    print("-" * len(header))
    table = {}
    for name, (q, p, seconds) in runs.items():
        dL = np.abs(discrete.kepler_angular_momentum(q, p) - L0) / abs(L0)
        dE = discrete.kepler_energy(q, p, mu) - E0
        m = max(len(dE) // 10, 1)
        drift = abs(dE[-m:].mean() - dE[:m].mean())
        table[name] = {"L_drift": float(dL.max()), "E_error": float(np.abs(dE).max()), "E_drift": float(drift),
                       "seconds": seconds}
        print(f"{name:40s} {dL.max():14.2e} {np.abs(dE).max():10.2e} {drift:10.2e} {seconds:9.3f}")

    if not args.no_plots:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("matplotlib is not installed: no plot")
            return table
        fig, axes = plt.subplots(1, 3, figsize=(14, 4.4), layout="constrained")
        for name, (q, p, _) in runs.items():
            # the errors as their running maximum: the largest error so far (a bounded error stays flat, a
            # drift climbs), not a comb of zero crossings; round-off of 1e-16 drawn at 1e-17 (log axis)
            dE = np.maximum.accumulate(np.abs(discrete.kepler_energy(q, p, mu) - E0))
            dL = np.maximum.accumulate(np.abs(discrete.kepler_angular_momentum(q, p) - L0) / abs(L0))
            axes[0].plot(q[-2000:, 0], q[-2000:, 1], lw=0.6, label=name)
            axes[1].semilogy(t, np.maximum(dE, 1e-17), lw=1.2)
            axes[2].semilogy(t, np.maximum(dL, 1e-17), lw=1.2)
        axes[0].set(aspect="equal", title="last 2000 samples of the orbit", xlabel="q1", ylabel="q2")
        axes[1].set(title="energy error |E - E0| (running max)", xlabel="t")
        axes[2].set(title="momentum error |L - L0| / |L0| (running max)", xlabel="t")
        for ax in axes[1:]:
            ax.grid(True, which="major", alpha=0.3)
        fig.legend(loc="outside lower center", ncols=len(runs), fontsize=9, frameon=False)
        path = Path(args.plot) if args.plot else Path(args.out) / "kepler_errors.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=120)
        plt.close(fig)
        print(f"  figures: {path}")
    return table


if __name__ == "__main__":
    main()
