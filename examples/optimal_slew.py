"""Optimal slews on the discrete LGVI: the eigenaxis manoeuvre against the optimal ones
====================================================================================

A spherical body (``J = I``) turns by 180 deg about its body axis ``e1``, from rest to rest, with
independent torque bounds ``|u_i| <= 1`` (units: time in ``sqrt(J / u_max)``):

* the eigenaxis bang-bang manoeuvre uses ``u1 = +-1`` only and takes ``2 sqrt(pi) = 3.545``;
* the time-optimal one (Bilimoria and Wie, 1993) uses all three axes, bang-bang with five
  switches, and is faster (about 3.24): :func:`lgvi.optimal.transfer` with ``cost="time"``.

It also prints the minimum-energy transfer in the same time (eigenaxis, cubic angle profile) and
its discrete cost against ``12 theta^2 / T^3``. The figure compares the torques, the angle to the
target and the rates of the eigenaxis and time-optimal manoeuvres.

Usage::

    python examples/optimal_slew.py [--steps 40] [--quick] [--out DIR] [--no-plots]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import lgvi
from lgvi import so3
from lgvi.optimal import transfer

SPHERE = lgvi.RigidBody([1.0, 1.0, 1.0])
TARGET = so3.exp([np.pi, 0.0, 0.0])        # 180 deg about e1


def eigenaxis_bang_bang(N: int) -> lgvi.Trajectory:
    """``u = (+1, 0, 0)`` for the first half of ``T = 2 sqrt(pi)``, ``(-1, 0, 0)`` after."""
    T = 2.0 * np.sqrt(np.pi)
    u = np.zeros((N, 3))
    u[: N // 2, 0] = 1.0
    u[N // 2:, 0] = -1.0
    return lgvi.simulate(SPHERE, np.eye(3), omega0=[0.0, 0.0, 0.0], h=T / N, steps=N, torque=u), u


def angle_to_target(traj: lgvi.Trajectory) -> np.ndarray:
    return np.linalg.norm(so3.log(np.swapaxes(TARGET, -1, -2) @ traj.R), axis=-1)


def switches(u: np.ndarray) -> list[int]:
    """Number of sign changes of each torque component."""
    s = np.sign(np.where(np.abs(u) < 1e-9, 0.0, u))
    return [int(np.sum(s[1:, i] * s[:-1, i] < 0)) for i in range(3)]


def slew_figure(eig, u_eig, opt):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 7), dpi=100, layout="constrained")
    axes = fig.subplots(3, 2, sharex="col", sharey="row")
    colors = ("tab:red", "tab:green", "tab:blue")
    for col, (traj, u, title) in enumerate(((eig, u_eig, f"eigenaxis bang-bang, T = {eig.t[-1]:.3f}"),
                                            (opt.trajectory, opt.u, f"time-optimal, T = {opt.T:.3f}"))):
        t = traj.t
        ax = axes[0, col]
        for i, c in enumerate(colors):
            ax.step(t[:-1], u[:, i], where="post", color=c, lw=1.6, label=f"$u_{i + 1}$")
        ax.set_title(title)
        ax.set_ylim(-1.15, 1.15)
        axes[1, col].plot(t, np.degrees(angle_to_target(traj)), color="tab:purple")
        for i, c in enumerate(colors):
            axes[2, col].plot(t, traj.omega[:, i], color=c, label=rf"$\omega_{i + 1}$")
        axes[2, col].set_xlabel(r"time $t$ (units of $\sqrt{J / u_{max}}$)")
        for ax in axes[:, col]:
            ax.grid(True, alpha=0.3)
    axes[0, 0].set_ylabel("torque $u$ ($u_{max}$)")
    axes[1, 0].set_ylabel("angle to target (deg)")
    axes[2, 0].set_ylabel(r"body rate $\omega$")
    axes[0, 0].legend(loc="lower left", ncols=3, fontsize=8)       # same colours in both columns
    axes[2, 0].legend(loc="lower right", ncols=3, fontsize=8)
    fig.suptitle(r"180 deg rest-to-rest slew of a sphere, $|u_i| \leq u_{max}$: eigenaxis vs time-optimal")
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--steps", type=int, default=40, help="steps of the transfers (default 40)")
    parser.add_argument("--quick", action="store_true", help="coarse grid (20 steps)")
    parser.add_argument("--out", default="output/optimal_slew", help="folder for the figure")
    parser.add_argument("--no-plots", action="store_true", help="skip the figure")
    args = parser.parse_args(argv)
    N = 20 if args.quick else args.steps

    eig, u_eig = eigenaxis_bang_bang(N)
    print(f"eigenaxis bang-bang: T = 2 sqrt(pi) = {eig.t[-1]:.4f}, final angle to target "
          f"{angle_to_target(eig)[-1]:.1e} rad (discrete, {N} steps), switches {switches(u_eig)}")
    opt = transfer(SPHERE, np.eye(3), TARGET, 3.6, N, cost="time", max_torque=1.0)
    saturated = np.mean(np.abs(np.abs(opt.u) - 1.0) < 1e-6)
    print(f"time-optimal ({N} steps): T = {opt.T:.4f} ({100 * (1 - opt.T / eig.t[-1]):.1f}% faster), "
          f"switches per axis {switches(opt.u)}, {100 * saturated:.0f}% of the torques on a bound, "
          f"violation {max(opt.violation.values()):.1e}, {opt.stats['iterations']} SLSQP iterations")
    h = opt.T / N
    for i in range(3):
        s = np.sign(opt.u[:, i])
        at = [f"{h * (k + 1):.2f}" for k in np.nonzero(s[1:] * s[:-1] < 0)[0]]
        print(f"  u{i + 1}: starts at {opt.u[0, i]:+.0f}, switches near t = {', '.join(at)}")
    theta = 2.0
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    energy = transfer(SPHERE, np.eye(3), so3.exp(theta * axis), 1.0, N)
    off = np.abs(energy.u - np.outer(energy.u @ axis, axis)).max()
    print(f"minimum energy, 2 rad about (1, 2, 2)/3 in T = 1: cost {energy.cost:.6f} "
          f"(continuous 12 theta^2 / T^3 = {12 * theta ** 2:.0f}), torque off the eigenaxis {off:.1e}")
    if not args.no_plots:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        path = out / "optimal_slew.png"
        slew_figure(eig, u_eig, opt).savefig(path, dpi=100)
        print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
