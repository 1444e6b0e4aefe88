"""``lgvi run`` of a scenario with an estimator (issue 27, part 5): the estimation error drawn inside
the MEKF's 3-sigma bounds, and knowledge statistics in the summary equal to those recomputed from the
saved records; the MEKF takes the spacecraft's star tracker from a scenario file."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi.fsw import MEKF
from lgvi.io.scenario import ScenarioError, to_toml
from lgvi.io.scenario_loop import loop_summary
from lgvi.scenario import Scenario
from lgvi.spacecraft import StarTracker

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "estimation_budget.toml"
ARCSEC = np.degrees(1.0) * 3600.0


def _short(duration: float = 300.0) -> dict:
    d = tomllib.loads(EXAMPLE.read_text())
    d["integrator"]["duration"] = duration
    return d


def test_lgvi_run_draws_the_estimation_error_and_summarises_knowledge(capsys, tmp_path):
    pytest.importorskip("matplotlib")
    from lgvi import cli

    path = tmp_path / "budget.toml"
    path.write_text(to_toml(_short()))
    code = cli.main(["run", str(path), "-o", str(tmp_path / "out")])
    out, err = capsys.readouterr()
    assert code == 0, err
    o = tmp_path / "out"
    assert {"estimation.png", "pointing.png", "summary.json", "summary.txt"} <= {p.name for p in o.iterdir()}
    assert (o / "estimation.png").stat().st_size > 20_000          # six panels drawn, not an empty canvas
    k = json.loads((o / "summary.json").read_text())["pointing"]["knowledge"]
    sig = lgvi.load(o / "trajectory.npz").signals
    e = sig["est_error"] * ARCSEC
    ang = np.linalg.norm(e, axis=1)
    half = len(ang) // 2
    assert k["error_arcsec"]["max"] == ang.max() and k["error_arcsec"]["final"] == ang[-1]
    assert k["error_arcsec"]["mean"] == pytest.approx(ang.mean(), rel=1e-12)
    assert k["error_arcsec"]["steady"]["p95"] == pytest.approx(np.percentile(ang[half:], 95), rel=1e-12)
    np.testing.assert_allclose(k["rms_axis_arcsec"], np.sqrt((e[half:] ** 2).mean(axis=0)), rtol=1e-12)
    s3 = 3 * np.sqrt(sig["P_diag"][:, :3]) * ARCSEC
    np.testing.assert_allclose(k["sigma3_final_arcsec"], s3[-1], rtol=1e-12)
    assert k["inside_3sigma"]["all"] == np.mean(np.abs(e) <= s3)
    # a consistent filter: its bounds cover the error (3 sigma: 99.7 % of Gaussian axis values), and
    # the star tracker (10 arcsec across, 83 about the boresight = body x) sets the steady error
    assert k["inside_3sigma"]["steady"] > 0.98
    assert k["rms_axis_arcsec"][0] > 2 * max(k["rms_axis_arcsec"][1:])
    assert "knowledge:" in (o / "summary.txt").read_text()


def test_true_pointing_error_composes_the_control_and_knowledge_errors():
    """The summary's true pointing error is R_ref vs R_est Exp(est_error); the control law's
    sigma_BR is that of the estimate, R_ref^T R_est: checked on the records, and the truth's error
    against the saved true attitude."""
    d = _short(300.0)
    traj = Scenario.from_dict(d).run()
    sig, ts = traj.signals, traj.signal_t
    np.testing.assert_array_equal(ts, traj.t[:-1])       # records at the saved states but the last
    R_est = sig["R_est"].reshape(-1, 3, 3)
    R_ref = sig["R_ref"].reshape(-1, 3, 3)
    R = traj.R[:-1]
    np.testing.assert_allclose(R_est @ lgvi.so3.exp(sig["est_error"]), R, atol=1e-12)
    s = loop_summary(traj, settle_deg=0.5)
    assert s["settle_time_s"] is not None
    k = int(np.searchsorted(ts, s["settle_time_s"]))
    true = np.degrees(np.linalg.norm(lgvi.so3.log(np.swapaxes(R_ref, 1, 2) @ R)[k:], axis=1))
    assert s["true_error_deg"]["max"] == pytest.approx(true.max(), rel=1e-9)
    assert s["true_error_deg"]["mean"] == pytest.approx(true.mean(), rel=1e-9)
    seen = lgvi.so3.mrp_from_matrix(np.swapaxes(R_ref, 1, 2) @ R_est)
    on = np.flatnonzero(ts % 1.0 == 0.0)               # the control law runs at 1 Hz, the records at 2 Hz
    np.testing.assert_allclose(sig["sigma_BR"][on], seen[on], atol=1e-12)


def test_mekf_star_tracker_true_takes_the_spacecraft_s():
    with pytest.raises(TypeError, match="star_tracker must be a StarTracker, True"):
        MEKF(arw=1e-4, rrw=1e-5, star_tracker="yes", P0=[1e-4] * 6)
    est = MEKF(arw=1e-4, rrw=1e-5, star_tracker=True, P0=[1e-4] * 6)
    with pytest.raises(ValueError, match="known once the run is built"):
        est.params()
    d = _short(10.0)
    d["spacecraft"]["sensor"] = [t for t in d["spacecraft"]["sensor"] if t["type"] != "star_tracker"]
    with pytest.raises(ScenarioError, match="StarTracker"):
        Scenario.from_dict(d)
    d = _short(10.0)
    st = [t for t in d["spacecraft"]["sensor"] if t["type"] == "star_tracker"][0]
    d["spacecraft"]["sensor"].append(dict(st, seed=2))
    with pytest.raises(ScenarioError, match=r"star_tracker: true names the spacecraft's one StarTracker, and "
                                            r"\[\[spacecraft.sensor\]\] holds 2 \(at \[1, 3\]\): give the index"):
        Scenario.from_dict(d)
    sc = Scenario.from_dict(_short(10.0))
    tracker = [c for c in sc.spacecraft.components() if isinstance(c, StarTracker)]
    assert len(tracker) == 1
    assert sc.fsw.estimator[0].star_tracker is tracker[0]   # a file's `true` names the spacecraft's one tracker
