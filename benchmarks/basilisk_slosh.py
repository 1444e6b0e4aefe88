"""Basilisk's ``sphericalPendulum`` state effector on a scenario of two slosh pendulums: the fixture
``basilisk_slosh.npz`` that ``tests/test_slosh.py`` compares ``lgvi.simulate_slosh`` with.

Run with the ``bench`` extra (Basilisk 2.12.1)::

    PY benchmarks/basilisk_slosh.py     # PY: a Python with the bench extra; writes benchmarks/basilisk_slosh.npz

The scenario (free space: no gravity body, no external force or torque): Basilisk's own unit-test
hub (1500 kg, inertia diag(900, 800, 600) kg m^2), here with its centre of mass at the body point
B (``r_BcB_B = 0``), spinning at (0.3, -0.2, 0.5) rad/s, and two pendulums (0.3 m, 20 kg, undamped;
0.4 m, 40 kg, damping ``D = 20 I`` N s/m) pivoted at ``d`` (body frame). Basilisk starts every
pendulum at ``phi = theta = 0`` (its initial angles are private), i.e. along ``pHat_01``, so each
pendulum's ``P0`` frame is chosen to point ``pHat_01`` along the wanted initial direction; the
initial rates ``phiDot``, ``thetaDot`` then move it along ``pHat_02`` and ``-pHat_03``.

Basilisk integrates it with its RK4 at the steps ``STEPS``; at every sample the script reads the
hub's MRP ``sigma_BN`` and each pendulum's ``phi``, ``theta`` and current ``P0`` frame (Basilisk
changes the frame when ``theta`` passes 45 degrees) and stores the hub attitude ``R`` (body to
inertial), the pendulum directions in the body frame ``l_B / l`` and Basilisk's total rotational
angular momentum about the centre of mass ``totRotAngMomPntC_N``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from Basilisk.simulation import spacecraft, sphericalPendulum
from Basilisk.utilities import SimulationBaseClass, macros

HERE = Path(__file__).resolve().parent
T = 10.0
SAMPLE = 0.1
STEPS = (0.01, 0.005, 0.0025, 0.00125, 0.000625)

HUB = {"mass": 1500.0, "inertia": [900.0, 800.0, 600.0], "omega0": [0.3, -0.2, 0.5]}
PENDULUMS = [
    {"d": [0.5, 0.1, 0.2], "length": 0.3, "mass": 20.0, "damping": 0.0,
     "pHat": [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]], "phiDot": 0.5, "thetaDot": 0.2},
    {"d": [-0.3, 0.4, -0.1], "length": 0.4, "mass": 40.0, "damping": 20.0,
     "pHat": [[0.6, 0.0, -0.8], [0.0, 1.0, 0.0], [0.8, 0.0, 0.6]], "phiDot": 0.0, "thetaDot": -1.0},
]


def mrp_to_dcm_NB(s: np.ndarray) -> np.ndarray:
    """Body-to-inertial rotation of the MRP ``sigma_BN`` (Schaub and Junkins)."""
    s = np.asarray(s, dtype=np.float64)
    s2 = s @ s
    S = np.array([[0.0, -s[2], s[1]], [s[2], 0.0, -s[0]], [-s[1], s[0], 0.0]])
    dcm_BN = np.eye(3) + (8.0 * S @ S - 4.0 * (1.0 - s2) * S) / (1.0 + s2) ** 2
    return dcm_BN.T


def run(dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("proc")
    proc.addTask(sim.CreateNewTask("task", macros.sec2nano(dt)))
    sc = spacecraft.Spacecraft()
    sc.ModelTag = "hub"
    sim.AddModelToTask("task", sc)
    pends = []
    for k, p in enumerate(PENDULUMS, start=1):
        e = sphericalPendulum.SphericalPendulum()
        e.pendulumRadius = p["length"]
        e.d = [[x] for x in p["d"]]
        e.D = (p["damping"] * np.eye(3)).tolist()
        for name in ("Phi", "PhiDot", "Theta", "ThetaDot", "Mass"):
            setattr(e, f"nameOf{name}State", f"sphericalPendulum{name}{k}")
        e.phiDotInit = p["phiDot"]
        e.thetaDotInit = p["thetaDot"]
        e.massInit = p["mass"]
        e.pHat_01, e.pHat_02, e.pHat_03 = ([[x] for x in v] for v in p["pHat"])
        sc.addStateEffector(e)
        pends.append(e)
    sc.hub.mHub = HUB["mass"]
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = np.diag(HUB["inertia"]).tolist()
    sc.hub.sigma_BNInit = [[0.0], [0.0], [0.0]]
    sc.hub.omega_BN_BInit = [[x] for x in HUB["omega0"]]
    sc.hub.r_CN_NInit = [[0.0], [0.0], [0.0]]
    sc.hub.v_CN_NInit = [[0.0], [0.0], [0.0]]
    sim.InitializeSimulation()
    n_samples = int(round(T / SAMPLE)) + 1
    R = np.empty((n_samples, 3, 3))
    qb = np.empty((n_samples, len(PENDULUMS), 3))
    H = np.empty((n_samples, 3))
    for j in range(n_samples):
        if j:
            sim.ConfigureStopTime(macros.sec2nano(j * SAMPLE))
            sim.ExecuteSimulation()
        sigma = np.asarray(sc.dynManager.getStateObject(sc.hub.nameOfHubSigma).getState()).ravel()
        R[j] = mrp_to_dcm_NB(sigma)
        for i, e in enumerate(pends):
            k = i + 1
            phi = float(np.asarray(sc.dynManager.getStateObject(f"sphericalPendulumPhi{k}").getState()).ravel()[0])
            th = float(np.asarray(sc.dynManager.getStateObject(f"sphericalPendulumTheta{k}").getState()).ravel()[0])
            P0 = np.column_stack([np.asarray(e.pHat_01).ravel(), np.asarray(e.pHat_02).ravel(),
                                  np.asarray(e.pHat_03).ravel()])
            qb[j, i] = P0 @ np.array([np.cos(phi) * np.cos(th), np.sin(phi) * np.cos(th), -np.sin(th)])
        # Basilisk's total rotational angular momentum about the centre of mass, inertial (it is
        # computed during a step: none before the first)
        H[j] = np.asarray(sc.totRotAngMomPntC_N).ravel() if j else np.nan
    return R, qb, H


def main() -> None:
    out: dict[str, np.ndarray] = {}
    for dt in STEPS:
        R, qb, H = run(dt)
        key = f"{dt:g}"
        out[f"R_{key}"] = R
        out[f"q_body_{key}"] = qb
        out[f"H_{key}"] = H
        print(f"Basilisk RK4 dt = {dt:g} s: max ||q_body| - 1| {np.abs(np.linalg.norm(qb, axis=2) - 1).max():.1e}, "
              f"momentum drift {np.abs(H[1:] - H[1]).max():.1e} of {np.abs(H[1]).max():.4g} N m s")
    keys = [f"{dt:g}" for dt in STEPS]
    for a, b in zip(keys[:-1], keys[1:]):
        dR = np.abs(out[f"R_{a}"] - out[f"R_{b}"]).max()
        dq = np.abs(out[f"q_body_{a}"] - out[f"q_body_{b}"]).max()
        print(f"dt {a} vs {b}: max |dR| {dR:.3e}, max |dq| {dq:.3e}")
    from importlib.metadata import version

    setup = {"T": T, "sample": SAMPLE, "steps": list(STEPS), "hub": HUB, "pendulums": PENDULUMS,
             "basilisk": version("bsk")}
    out["t"] = np.arange(int(round(T / SAMPLE)) + 1) * SAMPLE
    out["setup"] = np.array(json.dumps(setup))
    np.savez_compressed(HERE / "basilisk_slosh.npz", **out)
    print("wrote", HERE / "basilisk_slosh.npz", (HERE / "basilisk_slosh.npz").stat().st_size, "bytes")


if __name__ == "__main__":
    main()
