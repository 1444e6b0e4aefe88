"""The command line end to end, in a temporary folder: files written, their contents, exit codes."""

from __future__ import annotations

import csv
import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import lgvi
from lgvi import cli
from lgvi.io.scenario import load_scenario

SCENARIO = """\
name = "spin"
description = "free body for the CLI tests"

[body]
inertia = [1.0, 2.0, 3.0]

[initial]
euler = { sequence = "ZYX", angles = [10.0, 0.0, 0.0], unit = "deg" }
omega = [0.01, 1.0, 0.01]

[integrator]
h = 0.01
duration = 2.0
save_every = 5
"""
STEPS, SAVE_EVERY = 200, 5
M = STEPS // SAVE_EVERY + 1


def has_plot() -> bool:
    try:
        import lgvi.plot  # noqa: F401
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def has_xarray() -> bool:
    try:
        import xarray  # noqa: F401
    except ImportError:
        return False
    return True


needs_plot = pytest.mark.skipif(not has_plot(), reason="lgvi.plot (or matplotlib) is not available")


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()[:24]
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    return struct.unpack(">II", data[16:24])


@pytest.fixture
def scenario_file(tmp_path) -> Path:
    p = tmp_path / "spin.toml"
    p.write_text(SCENARIO)
    return p


def run(capsys, *argv) -> tuple[int, str, str]:
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------------------------ help
def test_python_m_lgvi_help():
    res = subprocess.run([sys.executable, "-m", "lgvi", "--help"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    for command in ("demo", "run", "compare", "plot", "info", "warmup"):
        assert command in res.stdout


@pytest.mark.parametrize("command", ["demo", "run", "compare", "plot", "info", "warmup"])
def test_every_command_has_help(capsys, command):
    code, out, _ = run(capsys, command, "--help")
    assert code == 0
    assert out.startswith(f"usage: lgvi {command}")


def test_no_command_runs_the_demo(capsys, monkeypatch):
    calls = []
    monkeypatch.setattr(cli, "run_demo", lambda **kw: calls.append(kw) or 0)
    assert cli.main([]) == 0
    assert calls == [{"out": None, "steps": cli.DEMO_STEPS, "plots": True}]


def test_usage_errors_exit_2(capsys):
    assert run(capsys, "frobnicate")[0] == 2
    assert run(capsys, "run")[0] == 2  # missing the scenario argument


# ------------------------------------------------------------------------------------ run
def test_run_writes_everything(capsys, tmp_path, scenario_file):
    out_dir = tmp_path / "out"
    formats = "npz,csv,netcdf" if has_xarray() else "npz,csv"
    code, out, err = run(capsys, "run", scenario_file, "-o", out_dir, "--format", formats)
    assert code == 0, err
    assert "spin" in out and str(out_dir) in out

    # the trajectory reloads and is bit-for-bit the library's run of the same scenario
    traj = lgvi.load(out_dir / "trajectory.npz")
    ref = load_scenario(scenario_file).run()
    assert np.array_equal(traj.R, ref.R) and np.array_equal(traj.Pi, ref.Pi) and len(traj.t) == M
    assert traj.meta["scenario"] == SCENARIO and traj.meta["lgvi_version"] == lgvi.__version__

    # CSV: named columns, one row per saved state
    with open(out_dir / "trajectory.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0][:4] == ["t", "R11", "R12", "R13"] and rows[0][10:14] == ["qx", "qy", "qz", "qw"]
    assert rows[0][-1] == "energy" and len(rows) == M + 1
    assert float(rows[-1][0]) == pytest.approx(2.0)
    side = json.loads((out_dir / "trajectory.meta.json").read_text())
    assert side["meta"]["scenario"] == SCENARIO
    if has_xarray():
        from lgvi.io.outputs import read_netcdf

        assert np.array_equal(read_netcdf(out_dir / "trajectory.nc").R, traj.R)

    # summaries
    summary = json.loads((out_dir / "summary.json").read_text())
    assert summary["status"] == "complete"
    assert summary["steps"] == STEPS and summary["samples"] == M and summary["h"] == 0.01
    assert summary["lgvi_version"] == lgvi.__version__ and summary["scenario"] == SCENARIO
    assert summary["wall_time_s"] > 0 and summary["steps_per_s"] > 0
    d = summary["drifts"]
    assert d["energy_rel"] < 1e-13 and d["casimir_rel"] < 1e-13 and d["spatial_momentum_rel"] < 1e-13
    assert "trajectory.npz" in summary["files"]
    text = (out_dir / "summary.txt").read_text()
    assert "spin" in text and "energy" in text and "steps/s" in text and 'name = "spin"' in text
    assert (out_dir / "scenario.toml").read_text() == SCENARIO

    if has_plot():
        for name in ("attitude", "rates", "conservation", "iterations", "polhode"):
            w, h = png_size(out_dir / f"{name}.png")
            assert w >= 400 and h >= 300


def test_run_no_plots_and_scenario_formats(capsys, tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(SCENARIO + '\n[output]\nformats = ["csv"]\nplots = true\n')
    code, _, err = run(capsys, "run", p, "-o", tmp_path / "o", "--no-plots")
    assert code == 0, err
    names = {f.name for f in (tmp_path / "o").iterdir()}
    assert names == {"trajectory.csv", "trajectory.meta.json", "scenario.toml", "summary.txt", "summary.json"}


def test_run_summary_names_the_splitting(capsys, tmp_path):
    """A splitting run has no implicit solve and no forcing: its summary says which splitting ran."""
    p = tmp_path / "s.toml"
    p.write_text(SCENARIO.replace("save_every = 5", 'save_every = 5\nscheme = "splitting"\norder = 4')
                 + "\n[output]\nplots = false\n")
    code, out, err = run(capsys, "run", p, "-o", tmp_path / "o")
    assert code == 0, err
    summary = (tmp_path / "o" / "summary.txt").read_text()
    assert "integrator:    splitting aba84, order 4" in summary and "forcing" not in summary
    data = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert data["scheme"] == "splitting" and data["composition"] == "aba84"


def test_run_scenario_without_plots(capsys, tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(SCENARIO + "\n[output]\nplots = false\n")
    assert run(capsys, "run", p, "-o", tmp_path / "o")[0] == 0
    assert not list((tmp_path / "o").glob("*.png"))


def test_run_default_output_folder(capsys, tmp_path, scenario_file, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run(capsys, "run", scenario_file, "--no-plots")[0] == 0
    assert (tmp_path / "spin_output" / "trajectory.npz").exists()


@pytest.mark.parametrize("edit, key", [
    (("steps", "stpes"), "integrator.stpes"),                       # unknown key (duration -> no steps key)
    (('unit = "deg"', 'unit = "grad"'), "initial.euler.unit"),
    (("h = 0.01", 'h = "0.01"'), "integrator.h"),
    (("duration = 2.0", "duration = 2.005"), "integrator.duration"),
    (("omega = [0.01, 1.0, 0.01]", "omega = [0.01, 1.0, 0.01]\nPi = [1, 2, 3]"), "initial"),
])
def test_run_bad_scenario_exits_2_with_one_line(capsys, tmp_path, edit, key):
    old, new = edit
    text = SCENARIO.replace("duration = 2.0", "duration = 2.0\nstpes = 3") if old == "steps" else \
        SCENARIO.replace(old, new)
    p = tmp_path / "bad.toml"
    p.write_text(text)
    code, out, err = run(capsys, "run", p, "-o", tmp_path / "o")
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert str(p) in err and f": {key}: " in err
    assert not (tmp_path / "o").exists()


def test_run_toml_syntax_error(capsys, tmp_path):
    p = tmp_path / "broken.toml"
    p.write_text(SCENARIO.replace("h = 0.01", "h = = 0.01"))
    code, _, err = run(capsys, "run", p)
    line = SCENARIO.splitlines().index("h = 0.01") + 1
    assert code == 2 and str(p) in err and f"line {line}" in err and err.count("\n") == 1


def test_run_missing_file_and_bad_format(capsys, tmp_path, scenario_file):
    code, _, err = run(capsys, "run", tmp_path / "nope.toml")
    assert code == 2 and "nope.toml" in err and "cannot read" in err
    code, _, err = run(capsys, "run", scenario_file, "--format", "npz,xlsx")
    assert code == 2 and "--format" in err and err.count("\n") == 1


def test_run_convergence_failure_exits_1_and_keeps_the_part_computed(capsys, tmp_path):
    p = tmp_path / "hard.toml"
    p.write_text('[body]\ninertia = [1, 2, 3]\n[initial]\nomega = [0.1, 1, 0.2]\n'
                 '[integrator]\nh = 0.5\nsteps = 100\nmethod = "paper"\nmax_iter = 1\ntol = 0.0\n')
    code, _, err = run(capsys, "run", p, "-o", tmp_path / "o")
    assert code == 1
    assert "ConvergenceError" in err and "step 0" in err and "Traceback" not in err
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["status"] == "failed" and summary["steps"] == 0
    assert len(lgvi.load(tmp_path / "o" / "trajectory.npz").t) == 1


def test_run_interrupted_writes_the_part_computed(capsys, tmp_path, scenario_file, monkeypatch):
    from lgvi.errors import SimulationInterrupted
    from lgvi.io.scenario import Scenario

    sc = load_scenario(scenario_file)
    full = sc.run()
    part = lgvi.Trajectory(t=full.t[:5], R=full.R[:5], Pi=full.Pi[:5], inertia=full.inertia,
                           iterations=full.iterations[:20], residual=full.residual[:20], h=full.h, meta=full.meta)

    def interrupted(self, folder, *, resume=False, progress=False, chunk_steps=None, solver_record="interval"):
        raise SimulationInterrupted("simulation interrupted after 20 of 200 steps", trajectory=part)

    monkeypatch.setattr(Scenario, "run_stream", interrupted)
    code, _, err = run(capsys, "run", scenario_file, "-o", tmp_path / "o")
    assert code == 130 and "interrupted" in err and "20 steps" in err
    assert len(lgvi.load(tmp_path / "o" / "trajectory.npz").t) == 5
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["status"] == "interrupted"


# ------------------------------------------------------------------------------------ demo
def test_demo_writes_trajectory_and_figures(capsys, tmp_path):
    code, out, err = run(capsys, "demo", "--steps", 300, "-o", tmp_path / "d")
    assert code == 0, err
    assert "Dzhanibekov" in out and "lgvi newton" in out and "scipy RK45" in out
    traj = lgvi.load(tmp_path / "d" / "trajectory.npz")
    assert len(traj.t) == 301
    if has_plot():
        assert png_size(tmp_path / "d" / "conservation.png")[0] > 0
        assert (tmp_path / "d" / "comparison.png").exists()


def test_demo_bad_steps(capsys):
    code, _, err = run(capsys, "demo", "--steps", 0)
    assert code == 2 and "--steps" in err


# ------------------------------------------------------------------------------------ compare
def test_compare_table_files_and_figure(capsys, tmp_path, scenario_file):
    code, out, err = run(capsys, "compare", scenario_file, "--with", "rk4,rk45,dop853", "-o", tmp_path / "c")
    assert code == 0, err
    lines = out.splitlines()
    for label in ("lgvi newton h=0.01", "RK4 h=0.01", "RK45 rtol=1e-06", "DOP853 rtol=1e-06"):
        row = [ln for ln in lines if ln.startswith(label)]
        assert len(row) == 1, out
        assert len(row[0].split()) >= 8
    report = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert [r["name"] for r in report["runs"]] == ["lgvi", "rk4", "rk45", "dop853"]
    assert all(r["status"] == "ok" and r["wall_time_s"] > 0 for r in report["runs"])
    lg = report["runs"][0]["drifts"]
    rk45 = report["runs"][2]["drifts"]
    assert lg["energy_rel"] < 1e-13 < rk45["energy_rel"]          # the point of the comparison
    for name in ("lgvi", "rk4", "rk45", "dop853"):
        assert len(lgvi.load(tmp_path / "c" / f"{name}.npz").t) == M
    if has_plot():
        assert png_size(tmp_path / "c" / "comparison.png")[0] > 0


def test_compare_bad_with(capsys, scenario_file):
    code, _, err = run(capsys, "compare", scenario_file, "--with", "rk4,euler")
    assert code == 2 and "--with" in err and "euler" in err


# ------------------------------------------------------------------------------------ plot / info
@pytest.fixture
def saved(tmp_path, scenario_file) -> Path:
    traj = load_scenario(scenario_file).run()
    p = tmp_path / "saved" / "run.npz"
    p.parent.mkdir()
    traj.save(p)
    return p


@needs_plot
def test_plot_command(capsys, tmp_path, saved):
    code, out, err = run(capsys, "plot", saved, "-o", tmp_path / "figs", "--prefix", "x_")
    assert code == 0, err
    for name in ("attitude", "rates", "conservation", "iterations", "polhode"):
        assert png_size(tmp_path / "figs" / f"x_{name}.png")[0] > 0
    code, _, err = run(capsys, "plot", saved)  # default: next to the trajectory
    assert code == 0, err
    assert (saved.parent / "attitude.png").exists()


@needs_plot
def test_plot_command_reads_csv(capsys, tmp_path, saved):
    from lgvi.io.outputs import write_csv

    p = write_csv(lgvi.load(saved), tmp_path / "run.csv")
    code, _, err = run(capsys, "plot", p, "-o", tmp_path / "f")
    assert code == 0, err
    assert (tmp_path / "f" / "polhode.png").exists() and not (tmp_path / "f" / "iterations.png").exists()


def test_plot_errors(capsys, tmp_path):
    code, _, err = run(capsys, "plot", tmp_path / "missing.npz")
    assert code == 2 and "no such file" in err
    bad = tmp_path / "bad.npz"
    bad.write_text("not a zip")
    code, _, err = run(capsys, "plot", bad)
    assert code == 2 and "bad.npz" in err and "Traceback" not in err


def test_plot_without_matplotlib_fails_clearly(capsys, saved, monkeypatch):
    monkeypatch.setitem(sys.modules, "lgvi.plot", None)
    code, _, err = run(capsys, "plot", saved)
    assert code == 1 and "lgvi[plot]" in err


def test_run_without_plot_module_still_writes_results(capsys, tmp_path, scenario_file, monkeypatch):
    monkeypatch.setitem(sys.modules, "lgvi.plot", None)
    code, _, err = run(capsys, "run", scenario_file, "-o", tmp_path / "o")
    assert code == 0 and "figures skipped" in err
    assert (tmp_path / "o" / "trajectory.npz").exists() and not list((tmp_path / "o").glob("*.png"))


def test_info_command(capsys, saved):
    code, out, err = run(capsys, "info", saved)
    assert code == 0, err
    assert f"samples     {M}" in out and "method      newton" in out
    assert f"steps       {STEPS}, h = 0.01" in out and "time        0 .. 2 s" in out
    assert "scenario_name    spin" in out and 'name = "spin"' in out
    assert "energy abs" in out and "|R^T R - I| max" in out


def test_info_of_csv_reports_steps_from_sidecar(capsys, tmp_path, saved):
    from lgvi.io.outputs import write_csv

    p = write_csv(lgvi.load(saved), tmp_path / "run.csv")
    code, out, _ = run(capsys, "info", p)
    assert code == 0 and f"steps       {STEPS}," in out


def test_info_bad_file(capsys, tmp_path):
    bad = tmp_path / "x.txt"
    bad.write_text("hello")
    code, _, err = run(capsys, "info", bad)
    assert code == 2 and "unknown trajectory file type" in err


# ------------------------------------------------------------------------------------ warmup
def test_warmup(capsys):
    code, out, err = run(capsys, "warmup")
    assert code == 0, err
    for method in ("newton", "paper", "cayley"):
        assert f"simulate method={method}" in out
    assert "kernels ready in" in out


# ------------------------------------------------------------------------------------ invariants
GRAVITY_GRADIENT = """\
name = "gg"

[body]
inertia = [100.0, 120.0, 80.0]

[initial]
euler = { sequence = "ZYX", angles = [85.0, 0.0, -90.0], unit = "deg" }
omega = [0.002, -0.001, 0.001]

[integrator]
h = 10.0
duration = 2000.0

[[torque]]
type = "gravity_gradient"
mu = 3.986004418e14
radius = 6778.0e3
"""


@pytest.fixture
def gg_file(tmp_path) -> Path:
    p = tmp_path / "gg.toml"
    p.write_text(GRAVITY_GRADIENT)
    return p


def test_summary_shows_the_invariants_of_the_problem(capsys, tmp_path, gg_file):
    """Under the gravity gradient the summary reports the Jacobi integral (bounded) and labels
    the energy and the momenta as not invariants; the free body's lists its four as exact."""
    code, _, err = run(capsys, "run", gg_file, "-o", tmp_path / "o", "--no-plots")
    assert code == 0, err
    text = (tmp_path / "o" / "summary.txt").read_text()
    assert "Jacobi integral" in text and "bounded" in text
    for name in ("energy (total)", "|Pi| (Casimir)", "spatial momentum R Pi", "vertical e3 . R Pi"):
        (line,) = [ln for ln in text.splitlines() if ln.strip().startswith(name)]
        assert "not an invariant" in line, line
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["forcing"] == "symmetric"             # potentials always take the symmetric step
    assert summary["invariants"]["jacobi"] == "bounded"
    assert summary["invariants"]["energy"] == "not an invariant"
    d = summary["drifts"]
    assert set(d) == {"jacobi_abs", "jacobi_rel", "orthogonality_max"} and d["jacobi_rel"] < 1e-4


def test_summary_of_a_free_body_lists_its_exact_invariants(capsys, tmp_path, scenario_file):
    code, _, err = run(capsys, "run", scenario_file, "-o", tmp_path / "o", "--no-plots")
    assert code == 0, err
    text = (tmp_path / "o" / "summary.txt").read_text()
    assert "not an invariant" not in text and "Jacobi" not in text
    (line,) = [ln for ln in text.splitlines() if ln.strip().startswith("energy (total)")]
    assert "exact" in line


def test_compare_and_info_show_the_invariants_of_the_problem(capsys, tmp_path, gg_file):
    code, out, err = run(capsys, "compare", gg_file, "--with", "rk4", "-o", tmp_path / "c", "--no-plots")
    assert code == 0, err
    header = next(ln for ln in out.splitlines() if ln.startswith("integrator"))
    assert "dC/C" in header and "dE/E" not in header and "d|Pi|/|Pi|" not in header
    assert "Jacobi integral" in out and "Not invariants of GravityGradient" in out
    report = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert report["invariants"]["jacobi"] == "bounded" and report["invariants"]["energy"] == "not an invariant"
    for r in report["runs"]:
        assert set(r["drifts"]) == {"jacobi_abs", "jacobi_rel", "orthogonality_max"}, r["name"]
    assert lgvi.load(tmp_path / "c" / "rk4.npz").meta["invariants"]["jacobi"]["kind"] == "bounded"
    code, out, err = run(capsys, "info", tmp_path / "c" / "lgvi.npz")
    assert code == 0, err
    assert "forcing          symmetric" in out and "Jacobi integral" in out
    assert "not invariants here: spatial momentum R Pi, vertical e3 . R Pi, |Pi| (Casimir), energy (total)" in out
