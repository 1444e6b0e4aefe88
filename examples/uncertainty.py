"""Uncertainty propagation: 10^4 bodies with uncertain initial attitude and rate, side by side
===========================================================================================

The nominal motion is the tumbling free body J = diag(1, 2, 3) kg m^2, omega0 = (0.3, 1, 0.2)
rad/s, R0 = I: its ``|Pi|^2 / 2T = 2.01`` lies just above the intermediate moment J2 = 2, close to
the separatrix of the polhode, so small errors in the initial state grow quickly. Each body
starts from the nominal attitude turned by a random small rotation (2 degrees rms per axis) and
the nominal rate scaled by 1 % rms per component; :func:`lgvi.simulate_ensemble` propagates
all of them at once (h = 0.01 s, Cayley solver, compiled and parallel over cores). The figure
shows where the body x-axis R e1 points at a few times (on the unit sphere) and the angular
spread about the nominal axis over time.

Usage::

    python examples/uncertainty.py                   # 10000 bodies, 60 s, figure in output/uncertainty
    python examples/uncertainty.py --quick           # 1000 bodies, 10 s
    python examples/uncertainty.py --bodies 100000 --duration 120 --out figs
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np

import lgvi

J = (1.0, 2.0, 3.0)              # principal moments [kg m^2]
OMEGA0 = (0.3, 1.0, 0.2)         # nominal body rate [rad/s]
ATTITUDE_SIGMA_DEG = 2.0         # rms initial attitude error per axis [deg]
RATE_SIGMA = 0.01                # rms relative error of each rate component
H = 0.01                         # [s]


def initial_states(bodies: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Random initial attitudes (B, 3, 3) and rates (B, 3) about the nominal state (body 0 is nominal)."""
    rng = np.random.default_rng(seed)
    dtheta = np.deg2rad(ATTITUDE_SIGMA_DEG) * rng.normal(size=(bodies, 3))
    scale = 1.0 + RATE_SIGMA * rng.normal(size=(bodies, 3))
    dtheta[0] = 0.0
    scale[0] = 1.0
    R0 = lgvi.so3.exp(dtheta)                       # nominal R0 = I turned in the body frame
    omega0 = np.asarray(OMEGA0) * scale
    return R0, omega0


def axis_spread(axes: np.ndarray, nominal: np.ndarray) -> np.ndarray:
    """Angles [rad] between each body's axis (B, M, 3) and the nominal one (M, 3), shape (B, M)."""
    cos = np.einsum("bmi,mi->bm", axes, nominal)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def local_coordinates(axes: np.ndarray, nominal_axis: np.ndarray, along: np.ndarray) -> np.ndarray:
    """Azimuthal equidistant coordinates [deg] of unit vectors ``axes`` (B, 3) about ``nominal_axis``:
    (along-track, cross-track), with ``along`` the direction the nominal axis moves in."""
    n = nominal_axis / np.linalg.norm(nominal_axis)
    u = along - (along @ n) * n
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    theta = np.rad2deg(np.arccos(np.clip(axes @ n, -1.0, 1.0)))
    phi = np.arctan2(axes @ v, axes @ u)
    return np.stack([theta * np.cos(phi), theta * np.sin(phi)], axis=-1)


def figure(t: np.ndarray, axes: np.ndarray, angles: np.ndarray, nominal: lgvi.Trajectory, path_line: np.ndarray,
           path: Path, shown: int = 2000) -> Path:
    """The body x-axis on the sphere at four times, close-ups about the nominal axis, and the
    spread over time; written to ``path``."""
    from matplotlib.figure import Figure   # no pyplot: works with any (or no) display

    fig = Figure(figsize=(16, 5.6), layout="constrained")
    grid = fig.add_gridspec(1, 3, width_ratios=[1.1, 1.0, 1.1])
    pick = np.linspace(0, len(t) - 1, 4).round().astype(int)
    colors = ["tab:blue", "tab:green", "tab:orange", "tab:red"]
    sub = axes[:shown]
    n_axis = nominal.R[:, :, 0]

    ax3 = fig.add_subplot(grid[0], projection="3d")
    u, v = np.mgrid[0:2 * np.pi:40j, 0:np.pi:20j]
    ax3.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.88", linewidth=0.4)
    ax3.plot(*path_line.T, color="k", linewidth=0.5, alpha=0.7, label="nominal path")
    for j, c in zip(pick, colors):
        ax3.scatter(*sub[:, j].T, s=1.5, color=c, alpha=0.4, depthshade=False, label=f"t = {t[j]:.0f} s")
    centre = sub[:, pick].reshape(-1, 3).mean(axis=0)
    elev = float(np.rad2deg(np.arcsin(np.clip(centre[2] / np.linalg.norm(centre), -1, 1))))
    ax3.view_init(elev=elev, azim=float(np.rad2deg(np.arctan2(centre[1], centre[0]))))   # facing the clouds
    ax3.set_box_aspect((1, 1, 1))
    ax3.set_axis_off()
    ax3.set_title(f"body x-axis R e1 ({min(shown, len(axes))} of {len(axes)} bodies)")
    ax3.legend(loc="upper left", fontsize=8, markerscale=5)

    inner = grid[1].subgridspec(2, 2)
    for q, (j, c) in enumerate(zip(pick, colors)):
        ax = fig.add_subplot(inner[q // 2, q % 2])
        Rn = nominal.R[j]
        along = Rn @ np.cross(nominal.omega[j], [1.0, 0.0, 0.0])    # d/dt R e1 = R (Omega x e1)
        xy = local_coordinates(sub[:, j], n_axis[j], along)
        ax.scatter(xy[:, 0], xy[:, 1], s=1.5, color=c, alpha=0.4)
        ax.plot([0], [0], "k+", markersize=10)
        lim = 1.05 * np.abs(xy).max()
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_title(f"t = {t[j]:.0f} s", fontsize=9)
        ax.tick_params(labelsize=7)
        if q // 2 == 1:
            ax.set_xlabel("along-track [deg]", fontsize=8)
        if q % 2 == 0:
            ax.set_ylabel("cross-track [deg]", fontsize=8)

    ax = fig.add_subplot(grid[2])
    deg = np.rad2deg(angles)
    lo, med, hi = np.percentile(deg, [5, 50, 95], axis=0)
    rms = np.sqrt(np.mean(deg ** 2, axis=0))
    ax.fill_between(t, lo, hi, color="tab:blue", alpha=0.25, label="5-95 % of bodies")
    ax.plot(t, med, color="tab:blue", label="median")
    ax.plot(t, rms, color="k", linestyle="--", label="rms")
    ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("angle of R e1 from the nominal [deg]")
    ax.set_title("spread of the body x-axis")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--bodies", type=int, default=10_000, help="number of bodies (default 10000)")
    parser.add_argument("--duration", type=float, default=60.0, help="simulated time [s] (default 60)")
    parser.add_argument("--samples", type=int, default=120, help="saved samples after t = 0 (default 120)")
    parser.add_argument("--quick", action="store_true", help="short run: 1000 bodies, 10 s")
    parser.add_argument("--threads", type=int, default=None, help="threads (default: all cores)")
    parser.add_argument("--out", default="output/uncertainty", help="folder for the figure")
    parser.add_argument("--no-plots", action="store_true", help="skip the figure")
    args = parser.parse_args(argv)
    bodies, duration, samples = (1000, 10.0, 40) if args.quick else (args.bodies, args.duration, args.samples)
    steps = int(round(duration / H))
    save_every = max(1, steps // samples)
    steps = save_every * max(1, steps // save_every)   # save_every divides steps

    R0, omega0 = initial_states(bodies)
    body = lgvi.RigidBody(J)
    t0 = time.perf_counter()
    ens = lgvi.simulate_ensemble(body, R0, omega0=omega0, h=H, steps=steps, save_every=save_every,
                                 method="cayley", threads=args.threads)
    wall = time.perf_counter() - t0
    nominal = lgvi.simulate(body, np.eye(3), omega0=OMEGA0, h=H, steps=steps, save_every=save_every,
                            method="cayley")
    assert np.array_equal(ens.R[0], nominal.R)       # body 0 is the nominal state, bit for bit

    dense = lgvi.simulate(body, np.eye(3), omega0=OMEGA0, h=H, steps=steps, save_every=math.gcd(steps, 10),
                          method="cayley")                      # the nominal path, for the figure
    axes = ens.R[:, :, :, 0]                          # body x-axis in the inertial frame, (B, M, 3)
    angles = axis_spread(axes, nominal.R[:, :, 0])
    deg = np.rad2deg(angles)
    E = ens.energy
    drift = float(np.max(np.abs(E - E[:, :1]) / E[:, :1]))
    print(f"uncertainty propagation: {bodies} bodies, J = diag{J} kg m^2, omega0 = {OMEGA0} rad/s "
          f"(1 sigma: {ATTITUDE_SIGMA_DEG} deg attitude, {100 * RATE_SIGMA:g} % rate), h = {H} s, {steps} steps")
    print(f"  {bodies * steps:.3g} body-steps in {wall:.2f} s wall ({bodies * steps / wall:.3g} body-steps/s, "
          f"including any compilation; load average {os.getloadavg()[0]:.2f})")
    print("  spread of the body x-axis about the nominal one (angle, deg):")
    print(f"  {'t [s]':>8} {'median':>8} {'95 %':>8} {'max':>8}")
    for j in np.linspace(0, len(ens.t) - 1, 6).round().astype(int):
        p50, p95 = np.percentile(deg[:, j], [50, 95])
        print(f"  {ens.t[j]:8.1f} {p50:8.3f} {p95:8.3f} {deg[:, j].max():8.3f}")
    print(f"  max relative energy drift of any body: {drift:.1e}; solver updates per step: "
          f"{ens.iterations.sum() / (bodies * steps):.3f}")
    if not args.no_plots:
        path = figure(ens.t, axes, angles, nominal, dense.R[:, :, 0],
                      Path(args.out) / "axis_spread.png")
        print(f"  figure: {path}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
