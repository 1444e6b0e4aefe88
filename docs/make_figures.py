"""Regenerate the figures of docs/validation.md (small palette PNGs in docs/figures/).

Usage::

    python docs/make_figures.py                 # full size, into docs/figures/ (about a minute)
    python docs/make_figures.py --quick --out /tmp/figs   # short runs (what the tests do)
    python docs/make_figures.py --gallery       # the kept figures of the slow examples (minutes)

The runs are those of the example scripts (imported from examples/), so the figures show exactly
what the examples compute. Each PNG is reduced to a 256-colour palette, which keeps it well under
150 KB without visible loss (the figures are line art).
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "examples"))

import lgvi  # noqa: E402
from lgvi import plot  # noqa: E402
from lgvi.verification.baselines import solve_ivp_baseline  # noqa: E402
from lgvi.verification.exact import free_body  # noqa: E402


def save_small(fig, path: Path) -> Path:
    """Render with Agg and write a 256-colour PNG."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=plot.DPI)
    buf.seek(0)
    with Image.open(buf) as im:
        im.convert("RGB").quantize(colors=256).save(path, optimize=True)
    return path


def dzhanibekov(out: Path, quick: bool) -> list[Path]:
    import dzhanibekov as ex

    steps = 2000 if quick else 10_000
    traj = ex.run(steps)
    rk = solve_ivp_baseline(ex.J, np.eye(3), omega0=ex.OMEGA0, t_final=steps * ex.H, samples=steps + 1,
                            method="RK45", rtol=1e-6, atol=1e-9)
    return [save_small(plot.comparison({"lgvi (newton, h = 0.01 s)": traj, "scipy RK45 (rtol 1e-6)": rk}),
                       out / "dzhanibekov_comparison.png"),
            save_small(plot.polhode(traj), out / "dzhanibekov_polhode.png")]


def convergence(out: Path, quick: bool) -> list[Path]:
    """Final momentum error against h for orders 2, 4, 6, against the exact free body."""
    from matplotlib.figure import Figure

    moments = (1.0, 2.0, 3.0)
    body = lgvi.RigidBody(moments)
    Pi0, T = body.J @ np.array([0.3, 1.0, 0.2]), 10.0
    R_exact, Pi_exact = free_body(moments, np.eye(3), Pi0, T)
    hs = np.array([0.2, 0.1, 0.05, 0.025] if quick else [0.2, 0.1, 0.05, 0.025, 0.0125, 0.00625])
    fig = Figure(figsize=plot.FIGSIZE, dpi=plot.DPI, layout="constrained")
    ax = fig.add_subplot()
    for order, color in ((2, "tab:blue"), (4, "tab:orange"), (6, "tab:green")):
        err = []
        for h in hs:
            tr = lgvi.simulate(body, np.eye(3), Pi0, h=float(h), steps=round(T / h), order=order)
            err.append(np.linalg.norm(lgvi.so3.log(R_exact.T @ tr.R[-1])))
        err = np.array(err)
        slope = np.polyfit(np.log(hs[err > 1e-12]), np.log(err[err > 1e-12]), 1)[0]
        ax.loglog(hs, err, "o-", color=color, label=f"order {order}: fitted slope {slope:.2f}")
        ax.loglog(hs, err[0] * (hs / hs[0]) ** order, ":", color=color, lw=1)
    ax.set_xlabel("step size $h$ (s)")
    ax.set_ylabel(r"attitude error $|\log(R_{exact}^T R_N)|$ at $T$ = 10 s (rad)")
    ax.set_title("Convergence against the exact free body (dotted: slopes 2, 4, 6)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return [save_small(fig, out / "convergence.png")]


def solvers(out: Path, quick: bool) -> list[Path]:
    """Residual per iteration of the three solvers on one implicit equation."""
    from matplotlib.figure import Figure

    body = lgvi.RigidBody([1.0, 2.0, 3.0])
    fig = Figure(figsize=plot.FIGSIZE, dpi=plot.DPI, layout="constrained")
    ax = fig.add_subplot()
    for method, color in (("paper", "tab:red"), ("newton", "tab:blue"), ("cayley", "tab:green")):
        for scale, ls in ((0.1, "-"), (0.5, "--")):
            hPi = scale * np.array([0.3, 2.0, 0.6])
            sol = lgvi.solve_implicit(body.Jd, hPi, method=method, tol=1e-15)
            hist = np.maximum(sol.history / np.linalg.norm(hPi), 1e-18)
            ax.semilogy(np.arange(len(hist)), hist, ls, marker="o", ms=3, color=color,
                        label=f"{method}, |h Pi| = {np.linalg.norm(hPi):.2g} kg m$^2$")
    ax.set_xlabel("iteration (1)")
    ax.set_ylabel(r"relative residual $|f(w)| / |h\Pi|$ (1)")
    ax.set_title("Implicit solve, J = diag(1, 2, 3): the paper's update is linear, Newton quadratic")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", ncols=2)
    return [save_small(fig, out / "solvers.png")]


def pendulum(out: Path, quick: bool) -> list[Path]:
    import pendulum3d as ex

    steps = 500 if quick else 3000
    body = lgvi.RigidBody(ex.J)
    lg = lgvi.simulate(body, np.eye(3), omega0=ex.OMEGA0, h=ex.H, steps=steps, torque=ex.GRAVITY)
    rk = solve_ivp_baseline(body, np.eye(3), omega0=ex.OMEGA0, t_final=steps * ex.H, samples=steps + 1,
                            method="RK45", rtol=1e-6, atol=1e-9, torque=ex.GRAVITY)
    fig = plot.comparison({"lgvi (symmetric, h = 0.01 s)": lg, "scipy RK45 (rtol 1e-6)": rk})  # E, e3 . R Pi
    return [save_small(fig, out / "pendulum3d_comparison.png")]


def heavy_top(out: Path, quick: bool) -> list[Path]:
    import heavy_top as ex

    traj = ex.run(4000 if quick else 20_000)
    return [save_small(ex.axis_figure(traj), out / "heavy_top_axis.png")]


def gravity_gradient(out: Path, quick: bool) -> list[Path]:
    import gravity_gradient as ex

    traj = ex.run(1000 if quick else 2000)
    return [save_small(ex.pitch_figure(traj), out / "gravity_gradient_pitch.png")]


def slew(out: Path, quick: bool) -> list[Path]:
    import slew_pd as ex

    body = lgvi.RigidBody(ex.J)
    traj = lgvi.simulate(body, np.eye(3), omega0=[0.0, 0.0, 0.0], h=ex.H, steps=600 if quick else 3000,
                         torque=ex.CONTROLLER, forcing="symmetric")
    return [save_small(ex.slew_figure(traj, body), out / "slew_pd_error.png")]


def optimal_slew(out: Path, quick: bool) -> list[Path]:
    import optimal_slew as ex

    N = 20 if quick else 40
    eig, u_eig = ex.eigenaxis_bang_bang(N)
    opt = lgvi.optimal.transfer(ex.SPHERE, np.eye(3), ex.TARGET, 3.6, N, cost="time", max_torque=1.0)
    return [save_small(ex.slew_figure(eig, u_eig, opt), out / "optimal_slew.png")]


#: examples whose short run is too slow for the docs' build: their first figure is kept here
#: (``--gallery``), and the gallery's page of an example not run shows it (docs/_gallery.py)
GALLERY_KEPT = ("orbit_attitude", "binary_asteroid", "uncertainty", "wheel_slew", "bdot_detumble", "nadir_dumping",
                "momentum_budget", "momentum_day", "estimation_budget")


def gallery(out: Path, names: tuple[str, ...] = GALLERY_KEPT) -> list[Path]:
    """The first figure of each example's short run (``--quick``), as ``gallery_NAME.png``."""
    import importlib
    import tempfile

    from PIL import Image

    made = []
    for name in names:
        ex = importlib.import_module(name)
        with tempfile.TemporaryDirectory() as tmp:
            ex.main(["--quick", "--out", tmp])
            first = sorted(Path(tmp).rglob("*.png"))[0]
            with Image.open(first) as im:
                path = out / f"gallery_{name}.png"
                im.convert("RGB").quantize(colors=256).save(path, optimize=True)
        made.append(path)
    return made


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(HERE / "figures"), help="folder (default docs/figures)")
    parser.add_argument("--quick", action="store_true", help="short runs")
    parser.add_argument("--gallery", action="store_true",
                        help="only the kept figures of the slow examples (gallery_NAME.png; minutes)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.gallery:
        for path in gallery(out):
            print(f"{path}  {path.stat().st_size / 1024:6.1f} KB")
        return 0
    for make in (dzhanibekov, convergence, solvers, pendulum, heavy_top, gravity_gradient, slew, optimal_slew):
        t0 = time.perf_counter()
        for path in make(out, args.quick):
            print(f"{path}  {path.stat().st_size / 1024:6.1f} KB  ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
