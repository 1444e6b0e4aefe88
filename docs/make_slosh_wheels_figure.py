"""The figure of docs/slosh.md, "Reaction wheels and the control loop": a hub with two slosh pendulums
and three reaction wheels slewed 40 degrees by the compiled MRP feedback, with the pendulums damped
and undamped.

Usage::

    python docs/make_slosh_wheels_figure.py               # writes docs/figures/slosh_wheels_slew.png
    python docs/make_slosh_wheels_figure.py --out /tmp/f  # elsewhere

Top left: the angle from the target attitude; top right: the largest pendulum rate relative to
the hub (the slosh); bottom left: the wheels' absolute axial momenta and, dashed, the total angular
momentum in the hub frame ``R^T L`` (at rest the wheels hold all of it); bottom right: the relative
error of the total angular momentum (hub, pendulums, wheels).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import lgvi

HERE = Path(__file__).resolve().parent
TARGET = lgvi.so3.exp(np.array([0.3, -0.5, 0.4]))


def slew(damping, steps=3000):
    """The slew of ``tests/test_slosh_wheels.py``: h = 0.1 s, MRP feedback K = 20, P = 150 every 0.5 s."""
    rw = lgvi.ReactionWheels(np.eye(3), 0.08, speed0=[10.0, -20.0, 30.0], max_torque=2.0, max_speed=600.0)
    return lgvi.simulate_slosh([900.0, 800.0, 600.0], 1500.0, [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]], [0.3, 0.4],
                               [40.0, 60.0], np.eye(3), [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]],
                               [[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]], omega0=[0.01, -0.02, 0.015], damping=damping,
                               h=0.1, steps=steps, save_every=10, wheels=rw,
                               controller=lgvi.control.MRPFeedback(K=20.0, P=150.0, target=TARGET), control_period=0.5)


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "figures"))
    args = ap.parse_args()
    fig, ((a, b), (c, d)) = plt.subplots(2, 2, figsize=(11, 7.5))
    floor = 1e-18
    for damping, style, label in (([30.0, 50.0], "-", "damped (30, 50 N s/m)"), (None, "--", "undamped")):
        tr = slew(damping)
        err = np.degrees(np.arccos(np.clip((np.einsum("tab,ab->t", tr.R, TARGET) - 1.0) / 2.0, -1.0, 1.0)))
        a.semilogy(tr.t, np.maximum(err, floor), style, color="k", lw=1.0, label=label)
        rate = np.linalg.norm(tr.qdot_body, axis=2).max(axis=1)
        b.semilogy(tr.t, np.maximum(rate, floor), style, color="k", lw=1.0, label=label)
        L = tr.angular_momentum
        dL = np.linalg.norm(L - L[0], axis=1) / np.linalg.norm(L[0])
        d.semilogy(tr.t[1:], np.maximum(dL[1:], floor), style, color="k", lw=1.0, label=label)
        if damping is not None:
            Lb = np.einsum("tba,b->ta", tr.R, L[0])
            for i, colour in enumerate(("tab:blue", "tab:orange", "tab:green")):
                c.plot(tr.t, tr.wheel_momentum[:, i], color=colour, lw=1.2, label=f"wheel {i + 1}: rho_{i + 1}")
                c.plot(tr.t, Lb[:, i], "--", color=colour, lw=0.8, label=f"(R^T L)_{i + 1}")
            print(f"damped: angle to target at {tr.t[-1]:g} s {err[-1]:.2e} deg, slosh rate {rate[-1]:.2e} 1/s, "
                  f"max |L - L0| / |L0| {dL.max():.2e}, wheels vs R^T L0 at the end "
                  f"{np.abs(tr.wheel_momentum[-1] - Lb[-1]).max():.2e} N m s")
        else:
            print(f"undamped: angle to target at {tr.t[-1]:g} s {err[-1]:.2e} deg, slosh rate {rate[-1]:.2e} 1/s, "
                  f"max |L - L0| / |L0| {dL.max():.2e}")
    a.set_ylabel("angle to the target (deg)")
    a.set_title("slew by the compiled MRP feedback (wheels, 2 N m)", fontsize=10)
    b.set_ylabel("largest pendulum rate relative to the hub (1/s)")
    b.set_title("the slosh", fontsize=10)
    c.set_ylabel("N m s")
    c.set_title("wheel momenta (damped run) and the total momentum in the hub frame", fontsize=10)
    c.legend(fontsize=7, ncol=3)
    d.set_ylabel("|L - L(0)| / |L(0)|")
    d.set_title("total angular momentum (hub, pendulums, wheels)", fontsize=10)
    for ax in (a, b, c, d):
        ax.set_xlabel("time t (s)")
        if ax is not c:
            ax.legend(fontsize=8)
    fig.suptitle("hub with two slosh pendulums and three reaction wheels, h = 0.1 s, order 2", fontsize=11)
    fig.tight_layout()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "slosh_wheels_slew.png", dpi=110)
    print(f"wrote {out / 'slosh_wheels_slew.png'}")


if __name__ == "__main__":
    main()
