"""Pointing knowledge and control error budgets of a 6U flying on its gyro, star tracker and magnetometer
======================================================================================================

The spacecraft and its flight software are those of ``examples/estimation_budget.toml`` (the 6U
of ``nadir_pointing.toml`` with a MEMS gyro, a star tracker looking at zenith and a magnetometer
read by the MEKF at 2 Hz, the MRP feedback pointing the estimate at the Hill frame). A Monte Carlo
over members that differ in what a real unit would: each member has its own sensor noise (its own
seeds), its own true gyro bias (drawn from the filter's prior, 3e-4 rad/s one sigma per axis) and
its own initial knowledge error (drawn from the prior, 1 deg one sigma per axis). The members run
together in the compiled loop (``lgvi.simulate_ensemble``).

After the slew (from ``--from`` seconds on) it pools the members' records into three budgets:

* **knowledge**: the angle of the estimation error ``est_error`` (``R = R_est Exp(est_error)``),
  and its RMS per body axis (the star tracker's boresight is body x: 83 arcsec about it against 10
  across, so x dominates);
* **control**: the error the control law sees, estimate against reference, ``4 atan |sigma_BR|``;
* **pointing**: the truth against the reference, the one a payload sees.

Knowledge and control errors add (the truth is the estimate times the knowledge error), so the
pointing error's mean square is close to the sum of the two others' (printed, with the fraction
of axis values inside the filter's 3-sigma bounds). ``--out DIR`` draws the three errors against
time (median and 95th percentile over the members) and their distributions
(``estimation_budget.png``).

Usage::

    python examples/estimation_budget.py [--members 100] [--from 400] [--out DIR] [--quick]
"""

from __future__ import annotations

import argparse
import copy
import time
import tomllib
from pathlib import Path

import numpy as np

import lgvi
from lgvi.io.scenario import Scenario

# next to this script (the docs' gallery runs it in examples/ without __file__)
SCENARIO = Path(globals().get("__file__", "estimation_budget.py")).resolve().parent / "estimation_budget.toml"
ARCSEC = np.degrees(1.0) * 3600.0


def members(base: dict, count: int, seed: int) -> tuple[list, list, np.ndarray]:
    """One spacecraft and flight software per member, from the scenario with the member's seeds,
    true gyro bias and initial estimate (the truth starts where the file says)."""
    rng = np.random.default_rng(seed)
    est = base["fsw"]["estimator"][0]
    att_sd, bias_sd = np.sqrt(est["P0"][0]), np.sqrt(est["P0"][3])
    sats, fsws = [], []
    for b in range(count):
        d = copy.deepcopy(base)
        for sensor in d["spacecraft"]["sensor"]:
            sensor["seed"] = 1000 + b
            if sensor["type"] == "gyro":
                sensor["bias"] = rng.normal(scale=bias_sd, size=3).tolist()
        d["fsw"]["estimator"][0]["R0"] = {"rotvec": (-rng.normal(scale=att_sd, size=3)).tolist()}   # R = R_est Exp(e0)
        sc = Scenario.from_dict(d, source=f"{SCENARIO.name} (member {b})")
        sats.append(sc.spacecraft)
        fsws.append(sc.fsw)
    return sats, fsws, sc


def errors(run, t_from: float) -> dict[str, np.ndarray]:
    """The three errors of one member from t_from on: knowledge (per axis, rad), control and pointing (rad)."""
    sig, t = run.signals, run.signal_t
    keep = t >= t_from
    R = run.R[:len(t)][keep]                                   # the truth at the records
    R_ref = sig["R_ref"][keep].reshape(-1, 3, 3)
    sigma = sig["sigma_BR"][keep]
    return {"t": t[keep], "knowledge": sig["est_error"][keep], "P": sig["P_diag"][keep, :3],
            "control": 4.0 * np.arctan(np.linalg.norm(sigma, axis=1)),
            "pointing": np.linalg.norm(lgvi.so3.log(np.swapaxes(R_ref, 1, 2) @ R), axis=1)}


def row(name: str, a: np.ndarray) -> str:
    a = a * ARCSEC
    return (f"  {name:<22} RMS {np.sqrt(np.mean(a ** 2)):8.2f}  p95 {np.percentile(a, 95):8.2f}  "
            f"p99.7 {np.percentile(a, 99.7):8.2f}  max {a.max():8.2f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    ap.add_argument("--members", type=int, default=100)
    ap.add_argument("--from", dest="t_from", type=float, default=400.0, help="start of the budget window [s]")
    ap.add_argument("--seed", type=int, default=27)
    ap.add_argument("--out", type=Path, default=None, help="folder for estimation_budget.png")
    ap.add_argument("--quick", action="store_true", help="20 members, 600 s, budget from 300 s")
    args = ap.parse_args(argv)
    base = tomllib.loads(SCENARIO.read_text())
    if args.quick:
        args.members, args.t_from = min(args.members, 20), 300.0
        base["integrator"]["duration"] = 600.0
    sats, fsws, sc = members(base, args.members, args.seed)
    R0 = np.broadcast_to(sc.R0, (args.members, 3, 3)).copy()
    omega0 = np.broadcast_to(sc.omega0, (args.members, 3)).copy()
    t0 = time.perf_counter()
    ens = lgvi.simulate_ensemble(sats, R0, omega0=omega0, h=sc.h, steps=sc.steps, fsw=fsws,
                                 save_every=sc.save_every)
    wall = time.perf_counter() - t0
    per = [errors(m, args.t_from) for m in ens.members]
    know = np.concatenate([e["knowledge"] for e in per])
    P = np.concatenate([e["P"] for e in per])
    ctrl = np.concatenate([e["control"] for e in per])
    point = np.concatenate([e["pointing"] for e in per])
    know_angle = np.linalg.norm(know, axis=1)
    print(f"{args.members} members of {sc.steps} steps (h = {sc.h:g} s, {sc.steps * sc.h:g} s) in {wall:.1f} s; "
          f"budget from t = {args.t_from:g} s on, {len(ctrl)} records pooled (arcsec)")
    print(row("knowledge |est_error|", know_angle))
    for i in range(3):
        print(row(f"knowledge about {'xyz'[i]}", np.abs(know[:, i])))
    print(row("control (est. vs ref)", ctrl))
    print(row("pointing (true vs ref)", point))
    rms = {k: float(np.sqrt(np.mean(v ** 2))) * ARCSEC for k, v in
           (("knowledge", know_angle), ("control", ctrl), ("pointing", point))}
    print(f"RSS of knowledge and control RMS {np.hypot(rms['knowledge'], rms['control']):.2f} arcsec; "
          f"pointing RMS {rms['pointing']:.2f} arcsec")
    inside = np.abs(know) <= 3.0 * np.sqrt(P)
    print(f"knowledge inside the filter's 3-sigma bounds: {inside.mean():.2%} of axis values "
          f"(x {inside[:, 0].mean():.2%}, y {inside[:, 1].mean():.2%}, z {inside[:, 2].mean():.2%})")
    if args.out is not None:
        import matplotlib.pyplot as plt

        args.out.mkdir(parents=True, exist_ok=True)
        t_all = ens.members[0].signal_t
        fig, axs = plt.subplots(1, 2, figsize=(12, 4.4), gridspec_kw={"width_ratios": [1.6, 1]})
        curves = (("knowledge", "tab:blue"), ("control", "tab:orange"), ("pointing", "k"))
        full = [errors(m, 0.0) for m in ens.members]
        for name, colour in curves:
            series = np.stack([np.linalg.norm(e[name], axis=1) if name == "knowledge" else e[name] for e in full])
            series = np.maximum(series * ARCSEC, 1e-3)
            axs[0].semilogy(t_all, np.median(series, axis=0), color=colour, lw=1.0, label=f"{name}: median")
            axs[0].semilogy(t_all, np.percentile(series, 95, axis=0), color=colour, lw=0.6, ls="--",
                            label=f"{name}: 95th percentile")
        axs[0].axvline(args.t_from, color="0.5", ls=":", lw=1.0, label="budget window starts")
        axs[0].set_xlabel("time $t$ (s)")
        axs[0].set_ylabel("error angle (arcsec)")
        axs[0].set_title(f"Over {args.members} members: median and 95th percentile")
        axs[0].legend(fontsize="small", ncols=2, loc="upper right")
        axs[0].grid(True, which="both", alpha=0.3)
        bins = np.linspace(0.0, np.percentile(point * ARCSEC, 99.9), 60)
        for (name, colour), data in zip(curves, (know_angle, ctrl, point)):
            axs[1].hist(data * ARCSEC, bins=bins, histtype="step", color=colour, lw=1.2, density=True,
                        label=f"{name} (RMS {rms[name]:.1f})")
        axs[1].set_xlabel("error angle (arcsec)")
        axs[1].set_ylabel("density")
        axs[1].set_title(f"Budget window (t >= {args.t_from:g} s), pooled")
        axs[1].legend(fontsize="small")
        axs[1].grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(args.out / "estimation_budget.png", dpi=120)
        print(f"figure: {args.out / 'estimation_budget.png'}")
    return 0


if __name__ == "__main__":
    main()   # exits 0, or raises
