"""Steps per second of lgvi against its peers, every ratio measured in the same run.

Usage::

    python benchmarks/peers.py            # full size
    python benchmarks/peers.py --quick    # reduced size, for CI (no timing assertions)

Rows (median of ``--repeat`` timed runs after an untimed warm-up, so compilation and imports are
excluded):

* free body ``J = diag(1, 2, 3)``, ``omega0 = (0.3, 1, 0.2)``, ``R0 = I``, ``h = 0.01``, every
  state saved: lgvi with each solver (``newton``, ``cayley``, ``paper``) at order 2, the order-4
  and order-6 compositions (a "step" is one composed step of size ``h``), a constant body torque
  with ``forcing="paper"`` and ``"symmetric"``; the compiled RK4 baseline
  (:func:`lgvi.baselines.rk4`); SciPy ``solve_ivp`` RK45 and DOP853 at ``rtol = atol = 1e-9``
  (steps = accepted steps; the right-hand side is lgvi's compiled one, so this is SciPy's own
  per-step cost); the pure-NumPy reference (:func:`lgvi.reference.simulate`, the paper's
  iteration); Basilisk RK4 and RKF78 with a task step of 0.01 s (one integrator step per task
  step; RKF78 at a loose 1e-8 never subdivides it) when ``bsk`` is installed;
* 3D pendulum, inverted start (``lgvi.torques.UniformGravity``, Lee's body and rates but the
  centre of mass 0.3 m above the pivot, ``com = +0.3 e3``, ``E0 = 7.91 J``; Lee's own start
  hangs, ``com = -0.3 e3`` here), ``h = 0.001``: lgvi orders
  2, 4, 6, the compiled RK4 baseline and Basilisk RK4 (gravity moment through the
  ``MtbEffector``, see ``basilisk_peer.py``).

The last column is how many times more steps per second lgvi's default (``newton``, order 2)
takes than the row, within the same section. Steps per second is not time to accuracy: see
``time_to_accuracy.py`` for that.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from typing import Any, Callable

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import basilisk_peer  # noqa: E402

import lgvi  # noqa: E402
from lgvi.verification import reference  # noqa: E402

J = np.array([1.0, 2.0, 3.0])
OMEGA0 = np.array([0.3, 1.0, 0.2])
H = 0.01
J_PEND = np.array([0.13, 0.28, 0.17])
OMEGA_PEND = 4.14 * np.ones(3)
COM = np.array([0.0, 0.0, 0.3])     # inverted start (lgvi e3 up); Lee's hanging start is -0.3 e3
H_PEND = 0.001


def median_time(fn: Callable[[], Any], repeat: int) -> float:
    times = []
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


class Table:
    def __init__(self, title: str):
        self.title = title
        self.rows: list[tuple[str, int | None, float | None, str]] = []

    def add(self, name: str, steps: int | None, seconds: float | None, note: str = "") -> None:
        self.rows.append((name, steps, None if seconds is None else steps / seconds, note))

    def skip(self, name: str, note: str) -> None:
        self.rows.append((name, None, None, note))

    def print(self, base: str) -> None:
        base_rate = next((r for n, _, r, _ in self.rows if n == base and r), None)
        print(f"\n{self.title}")
        print(f"{'case':<56} {'steps':>9} {'steps/s':>10} {'us/step':>9} {'lgvi newton o2 / this':>22}")
        for name, steps, rate, note in self.rows:
            if rate is None:
                print(f"{name:<56} {'':>9} {'n/a':>10} {'':>9} {'':>22}  {note}")
                continue
            ratio = f"{base_rate / rate:.3g}" if base_rate else ""
            print(f"{name:<56} {steps:>9d} {rate:>10.3e} {1e6 / rate:>9.3g} {ratio:>22}  {note}")


def _try(table: Table, name: str, steps: int, run: Callable[[int], Any], repeat: int, note: str = "",
         warm: int = 10) -> None:
    """Warm up with ``run(warm)``, then time ``run(steps)``; an unavailable option becomes n/a."""
    try:
        run(warm)
        table.add(name, steps, median_time(lambda: run(steps), repeat), note)
    except (TypeError, ValueError, NotImplementedError, ImportError, AttributeError,
            basilisk_peer.BasiliskUnavailable) as exc:
        table.skip(name, f"n/a ({type(exc).__name__}: {exc})")


def free_body(quick: bool, repeat: int) -> Table:
    from lgvi.verification.baselines import rk4, solve_ivp_baseline

    n = 20_000 if quick else 1_000_000
    n_comp = 4_000 if quick else 200_000
    n_ref = 30 if quick else 300
    t_scipy = 50.0 if quick else 2000.0
    n_bsk = 2_000 if quick else 100_000
    body = lgvi.RigidBody(J)
    Pi0 = J * OMEGA0
    tab = Table(f"free body, J = diag(1, 2, 3), omega0 = (0.3, 1, 0.2), h = {H:g}, every step saved; "
                f"median of {repeat}")

    def sim(k: int, **kw: Any) -> Any:
        return lgvi.simulate(body, np.eye(3), Pi0, h=H, steps=k, **kw)

    for method in ("newton", "cayley", "paper"):
        its = sim(1000, method=method).iterations.mean()
        _try(tab, f"lgvi {method}, order 2", n, lambda k, m=method: sim(k, method=m), repeat,
             f"{its:.2f} solver iterations/step")
    for order in (4, 6):
        for method in ("newton", "cayley"):
            _try(tab, f"lgvi {method}, order {order}", n_comp,
                 lambda k, m=method, o=order: sim(k, method=m, order=o), repeat)
    try:
        from lgvi.torques import Constant

        const: Any = Constant([0.0, 0.0, 0.01])
    except ImportError as exc:
        const = None
        for forcing in ("paper", "symmetric"):
            tab.skip(f"lgvi newton, constant torque model, forcing={forcing}", f"n/a ({exc})")
    if const is not None:
        for forcing in ("paper", "symmetric"):
            _try(tab, f"lgvi newton, constant torque model, forcing={forcing}", n,
                 lambda k, f=forcing: sim(k, torque=const, forcing=f), repeat)
    _try(tab, "lgvi.baselines.rk4 (compiled)", n,
         lambda k: rk4(body, np.eye(3), Pi0, h=H, steps=k), repeat)
    for method in ("RK45", "DOP853"):
        def run(t_final: float, m: str = method) -> Any:
            return solve_ivp_baseline(body, np.eye(3), Pi0, t_final=t_final, samples=None, method=m,
                                      rtol=1e-9, atol=1e-9)

        try:
            run(1.0)
            accepted = len(run(t_scipy).t) - 1
            tab.add(f"scipy solve_ivp {method} (rtol=atol=1e-9)", accepted,
                    median_time(lambda: run(t_scipy), repeat), f"accepted steps over T = {t_scipy:g} s")
        except (TypeError, ValueError, ImportError) as exc:
            tab.skip(f"scipy solve_ivp {method}", f"n/a ({exc})")
    _try(tab, "pure-NumPy reference (paper's iteration)", n_ref,
         lambda k: reference.simulate(J * np.eye(3), np.eye(3), Pi0, H, k), max(1, repeat // 2), warm=2)
    if basilisk_peer.status() is None:
        for integ, tol in (("rk4", None), ("rkf78", 1e-8)):
            name = f"Basilisk {integ.upper()} (task step {H:g} s)"
            try:
                walls = [basilisk_peer.run(J, np.eye(3), OMEGA0, T=n_bsk * H, dt=H, integrator=integ, tol=tol).wall
                         for _ in range(max(1, repeat))]
                tab.add(name, n_bsk, statistics.median(walls), "ExecuteSimulation() only")
            except (ValueError, basilisk_peer.BasiliskUnavailable) as exc:
                tab.skip(name, f"n/a ({exc})")
    else:
        tab.skip("Basilisk RK4 / RKF78", basilisk_peer.status() or "")
    return tab


def pendulum(quick: bool, repeat: int) -> Table:
    from lgvi.verification.baselines import rk4

    n = 20_000 if quick else 500_000
    n_comp = 4_000 if quick else 100_000
    n_bsk = 2_000 if quick else 50_000
    body = lgvi.RigidBody(J_PEND)
    tab = Table(f"3D pendulum, inverted start (UniformGravity, m = 1, com = +0.3 e3, g = 9.81), h = {H_PEND:g}, final state saved; "
                f"median of {repeat}")
    try:
        from lgvi.torques import UniformGravity

        grav: Any = UniformGravity(1.0, COM, g=9.81)
    except ImportError as exc:
        tab.skip("lgvi.torques.UniformGravity", f"n/a ({exc})")
        return tab
    for order in (2, 4, 6):
        _try(tab, f"lgvi newton, order {order}", n if order == 2 else n_comp,
             lambda k, o=order: lgvi.simulate(body, np.eye(3), omega0=OMEGA_PEND, h=H_PEND, steps=k, order=o,
                                              torque=grav, save_every=k), repeat)
    _try(tab, "lgvi.baselines.rk4 (compiled)", n,
         lambda k: rk4(body, np.eye(3), omega0=OMEGA_PEND, h=H_PEND, steps=k, torque=grav, save_every=k), repeat)
    if basilisk_peer.status() is None:
        walls = [basilisk_peer.run(J_PEND, np.eye(3), OMEGA_PEND, T=n_bsk * H_PEND, dt=H_PEND, integrator="rk4",
                                   gravity=(1.0, COM, 9.81)).wall for _ in range(max(1, repeat))]
        tab.add(f"Basilisk RK4 (task step {H_PEND:g} s, MtbEffector moment)", n_bsk, statistics.median(walls),
                "ExecuteSimulation() only")
    else:
        tab.skip("Basilisk RK4", basilisk_peer.status() or "")
    return tab


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="reduced size for CI")
    parser.add_argument("--repeat", type=int, default=None, help="timed runs per entry (median; default 3)")
    args = parser.parse_args(argv)
    repeat = args.repeat or (1 if args.quick else 3)
    start = time.perf_counter()
    print(f"lgvi {lgvi.__version__} steps per second against peers{' (--quick)' if args.quick else ''}; "
          f"{basilisk_peer.version()}", flush=True)
    free = free_body(args.quick, repeat)
    free.print("lgvi newton, order 2")
    pend = pendulum(args.quick, repeat)
    pend.print("lgvi newton, order 2")
    print(f"\ntotal benchmark time {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
