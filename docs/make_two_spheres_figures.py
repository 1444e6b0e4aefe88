"""The figures of docs/two_spheres.md: a chain of five spherical pendulums over a long time, the
Lie group variational integrator on (S^2)^5 against an explicit Runge-Kutta method.

Usage::

    python docs/make_two_spheres_figures.py                       # full size, into docs/figures/
    python docs/make_two_spheres_figures.py --quick --out /tmp/f  # a short smoke run (20 s)

Case (in the spirit of the chain example of Lee, Leok and McClamroch, IJNME 79 (2009) 1147; its
own parameters were not available to this work): five links of 1 m with 1 kg at each joint,
hanging from a fixed pivot under standard gravity, started stretched horizontally along e1 with
``qdot_i = (0, 0.5, +-0.3)`` (alternating signs), simulated for 200 s. lgvi: ``simulate_chain``
at h = 1e-3 s. Runge-Kutta: SciPy's RK45 with its default tolerances (rtol 1e-3, atol 1e-6, as
MATLAB's ode45) and at rtol = atol = 1e-8, both on the same mechanics in R^3 with the unit
lengths as constraints (``lgvi.systems.chain.chain_equations``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import lgvi  # noqa: E402
from lgvi.systems.chain import chain_equations, chain_parameters  # noqa: E402
from lgvi.systems.chain.model import G0, kinetic_energy, potential_energy  # noqa: E402
from make_figures import save_small  # noqa: E402

N = 5
LENGTHS = np.ones(N)
MASSES = np.ones(N)
GRAVITY = np.array([0.0, 0.0, -G0])


def initial():
    q0 = np.tile([1.0, 0.0, 0.0], (N, 1))
    qd0 = np.stack([[0.0, 0.5, 0.3 * (-1) ** i] for i in range(N)])
    return q0, qd0


def runs(T, h):
    q0, qd0 = initial()
    t = time.process_time()
    chain = lgvi.simulate_chain(LENGTHS, MASSES, q0, qd0, h=h, steps=int(round(T / h)),
                                save_every=max(1, int(round(0.05 / h))))
    cpu = {"lgvi": time.process_time() - t}
    M, w = chain_parameters(LENGTHS, MASSES)
    f = chain_equations(M, w, GRAVITY)
    y0 = np.concatenate([q0.ravel(), qd0.ravel()])
    rk = {}
    for label, tol in (("RK45, rtol 1e-3 (ode45 defaults)", (1e-3, 1e-6)), ("RK45, rtol 1e-8", (1e-8, 1e-8))):
        t = time.process_time()
        sol = solve_ivp(f, (0.0, T), y0, method="RK45", rtol=tol[0], atol=tol[1], t_eval=chain.t)
        cpu[label] = time.process_time() - t
        q = sol.y[:3 * N].T.reshape(-1, N, 3)
        v = sol.y[3 * N:].T.reshape(-1, N, 3)
        rk[label] = dict(t=sol.t, q=q, E=kinetic_energy(M, v) + potential_energy(w, GRAVITY, q),
                         Lz=np.cross(q, np.einsum("ij,kjl->kil", M, v)).sum(axis=1)[:, 2], nfev=sol.nfev)
    return chain, rk, cpu


def figures(out: Path, quick: bool) -> list[Path]:
    from matplotlib.figure import Figure

    T, h = (20.0, 1e-3) if quick else (200.0, 1e-3)
    chain, rk, cpu = runs(T, h)
    E0, Lz0 = chain.energy[0], chain.vertical_momentum[0]
    colours = {"lgvi": "C0", "RK45, rtol 1e-3 (ode45 defaults)": "C3", "RK45, rtol 1e-8": "C1"}
    lgvi_label = f"lgvi on (S$^2$)$^5$, h = {h:g} s"
    tiny = 1e-17

    fig = Figure(figsize=(7.0, 5.0))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.semilogy(chain.t, np.abs(chain.energy - E0) + tiny, color=colours["lgvi"], lw=0.8, label=lgvi_label)
    for label, r in rk.items():
        ax1.semilogy(r["t"], np.abs(r["E"] - E0) + tiny, color=colours[label], lw=0.8, label=label)
    ax1.set_ylabel(r"$|E(t) - E(0)|$ (J)")
    ax1.set_title(f"Chain of {N} spherical pendulums: energy and vertical momentum errors", fontsize=10)
    ax1.legend(fontsize=7, loc="lower right")
    ax2.semilogy(chain.t, np.abs(chain.vertical_momentum - Lz0) + tiny, color=colours["lgvi"], lw=0.8,
                 label=lgvi_label)
    for label, r in rk.items():
        ax2.semilogy(r["t"], np.abs(r["Lz"] - Lz0) + tiny, color=colours[label], lw=0.8, label=label)
    ax2.set_ylabel(r"$|e_3\cdot(L(t) - L(0))|$ (kg m$^2$/s)")
    ax2.set_xlabel("t (s)")
    fig.tight_layout()
    paths = [save_small(fig, out / "chain_energy_momentum.png")]

    fig = Figure(figsize=(7.0, 5.0))
    ax1, ax2 = fig.subplots(2, 1)
    def worst(q):     # the largest unit-length error so far
        return np.maximum.accumulate(np.abs(np.linalg.norm(q, axis=2) - 1.0).max(axis=1)) + tiny

    ax1.semilogy(chain.t, worst(chain.q), color=colours["lgvi"], lw=1.2, label=lgvi_label)
    for label, r in rk.items():
        ax1.semilogy(r["t"], worst(r["q"]), color=colours[label], lw=0.8, label=label)
    ax1.set_ylabel(r"largest $||q_i| - 1|$ so far")
    ax1.set_xlabel("t (s)")
    ax1.set_title("Unit length of the links; the tip's path (first 10 s, from above)", fontsize=10)
    ax1.legend(fontsize=7, loc="center right")
    x = chain.positions[:, -1]
    k = chain.t <= 10.0
    ax2.plot(x[k, 0], x[k, 1], color=colours["lgvi"], lw=0.6)
    ax2.set_aspect("equal")
    ax2.set_xlabel("x (m)")
    ax2.set_ylabel("y (m)")
    fig.tight_layout()
    paths.append(save_small(fig, out / "chain_unit_length.png"))

    print(f"T = {T:g} s, {len(chain.t) - 1} samples; CPU s: " + ", ".join(f"{k}: {v:.2f}" for k, v in cpu.items()))
    print(f"lgvi: max |E - E0| = {np.abs(chain.energy - E0).max():.2e} J, max |dLz| = "
          f"{np.abs(chain.vertical_momentum - Lz0).max():.2e}, max ||q| - 1| = "
          f"{np.abs(np.linalg.norm(chain.q, axis=2) - 1).max():.1e}")
    for label, r in rk.items():
        print(f"{label}: final |E - E0| = {abs(r['E'][-1] - E0):.2e} J, max |dLz| = {np.abs(r['Lz'] - Lz0).max():.2e}, "
              f"max ||q| - 1| = {np.abs(np.linalg.norm(r['q'], axis=2) - 1).max():.1e}, nfev = {r['nfev']}")
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(HERE / "figures"), help="folder (default docs/figures)")
    parser.add_argument("--quick", action="store_true", help="short runs")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for p in figures(out, args.quick):
        print(p, p.stat().st_size // 1024, "kB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
