"""The figure of docs/slosh.md: lgvi's hub with two slosh pendulums against Basilisk's
``sphericalPendulum`` effector (the fixture ``benchmarks/basilisk_slosh.npz`` of
``benchmarks/basilisk_slosh.py``).

Usage::

    python docs/make_slosh_figures.py                   # writes docs/figures/slosh_basilisk.png
    python docs/make_slosh_figures.py --out /tmp/f      # elsewhere

Left: the largest error over the pendulum directions (body frame) against Basilisk's RK4 at
0.625 ms, over time, for lgvi at order 2 and 4 and several steps, and for Basilisk's own RK4 at
10 ms and 5 ms (against the same reference). Right: the largest error over the run against the step
(log-log), with slopes 2 and 4 for reference.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import lgvi

HERE = Path(__file__).resolve().parent
FIXTURE = HERE.parent / "benchmarks" / "basilisk_slosh.npz"


def run(S, h, order):
    P = S["pendulums"]
    q0 = [p["pHat"][0] for p in P]
    qd0 = [p["phiDot"] * np.array(p["pHat"][1]) - p["thetaDot"] * np.array(p["pHat"][2]) for p in P]
    n = int(round(S["T"] / h))
    return lgvi.simulate_slosh(S["hub"]["inertia"], S["hub"]["mass"], [p["d"] for p in P], [p["length"] for p in P],
                               [p["mass"] for p in P], np.eye(3), q0, qd0, omega0=S["hub"]["omega0"],
                               damping=[p["damping"] for p in P], h=h, steps=n, save_every=int(round(S["sample"] / h)),
                               order=order)


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "figures"))
    args = ap.parse_args()
    z = np.load(FIXTURE)
    S = json.loads(str(z["setup"]))
    t, ref = z["t"], z["q_body_0.000625"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    floor = 1e-16
    rows = []
    for order, hs, colour in ((2, (0.02, 0.01, 0.005), "tab:blue"), (4, (0.02, 0.01, 0.005), "tab:red")):
        worst = []
        for k, h in enumerate(hs):
            e = np.linalg.norm(run(S, h, order).q_body - ref, axis=2).max(axis=1)
            worst.append(e.max())
            a.semilogy(t, np.maximum(e, floor), color=colour, alpha=1.0 - 0.3 * k, lw=1.0,
                       label=f"lgvi order {order}, h = {1e3 * h:g} ms")
            rows.append(f"lgvi order {order} h = {h:g}: max error {e.max():.2e} rad")
        b.loglog(hs, worst, "o-", color=colour, label=f"lgvi order {order}")
    for dt, style in ((0.01, "k--"), (0.005, "k:")):
        e = np.linalg.norm(z[f"q_body_{dt:g}"] - ref, axis=2).max(axis=1)
        a.semilogy(t, np.maximum(e, floor), style, lw=1.0, label=f"Basilisk RK4, {1e3 * dt:g} ms")
        rows.append(f"Basilisk RK4 dt = {dt:g}: max error {e.max():.2e} rad")
    a.axhline(1e-6, color="0.6", lw=0.8)
    a.text(t[-1], 1.3e-6, "1e-6 rad (the goal)", ha="right", fontsize=8, color="0.4")
    a.set_xlabel("time t (s)")
    a.set_ylabel("largest pendulum direction error (rad)")
    a.set_title("against Basilisk's RK4 at 0.625 ms", fontsize=10)
    a.legend(fontsize=7, ncol=2, loc="lower right")
    hh = np.array([0.005, 0.02])
    b.loglog(hh, 1e-4 * (hh / 0.01) ** 2, color="0.6", lw=0.8, ls="--", label="slope 2")
    b.loglog(hh, 1e-9 * (hh / 0.01) ** 4, color="0.6", lw=0.8, ls=":", label="slope 4")
    b.set_xlabel("step h (s)")
    b.set_ylabel("largest error over 10 s (rad)")
    b.set_title("convergence to Basilisk with the step", fontsize=10)
    b.legend(fontsize=8)
    fig.suptitle("hub (1500 kg) with two slosh pendulums (one damped), spinning: lgvi.simulate_slosh "
                 "against Basilisk sphericalPendulum", fontsize=10)
    fig.tight_layout()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "slosh_basilisk.png", dpi=110)
    print("\n".join(rows))
    print("wrote", out / "slosh_basilisk.png")


if __name__ == "__main__":
    main()
