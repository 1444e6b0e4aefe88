"""The benchmark scripts run end to end at reduced size (``--quick``) and print their tables.

No timing assertions and no time limit (timings on shared CI machines are noise, and a cold Numba
cache on a busy machine takes minutes); what is checked is that each script exits 0 and prints its
table, so a broken benchmark cannot fail silently. Basilisk rows are exercised when ``bsk`` is installed and skipped cleanly otherwise.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"


def _run(script: str, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("NUMBA_DISABLE_JIT", None)   # benchmarks time the compiled kernels, even in an interpreted test run
    return subprocess.run([sys.executable, str(BENCHMARKS / script), *args], capture_output=True, text=True,
                          env=env, cwd=BENCHMARKS.parent)


def _check(proc: subprocess.CompletedProcess, *needles: str) -> None:
    assert proc.returncode == 0, f"exit code {proc.returncode}\nstdout:\n{proc.stdout}\nstderr:\n{proc.stderr}"
    for needle in needles:
        assert needle in proc.stdout, f"{needle!r} not printed\nstdout:\n{proc.stdout}\nstderr:\n{proc.stderr}"


@pytest.mark.slow
def test_time_to_accuracy_quick():
    proc = _run("time_to_accuracy.py", "--quick")
    _check(proc, "problem", "target", "solver", "h or tol", "error rad", "wall s", "ext. peer/this",
           "lgvi newton order 2", "scipy DOP853", "free body", "3D pendulum", "reference free body")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_call_overhead_quick():
    proc = _run("call_overhead.py", "--quick", "--compare", "src", "src")
    _check(proc, "case", "old us", "new us", "new/old", "free body", "UniformGravity", "splitting order 4")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_bench_compiled_energy_quick():
    proc = _run("bench_compiled_energy.py", "--quick")
    _check(proc, "potential", "moment", "1000")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_peers_quick():
    proc = _run("peers.py", "--quick")
    _check(proc, "case", "steps/s", "us/step", "lgvi newton, order 2", "scipy solve_ivp RK45",
           "lgvi.baselines.rk4", "pure-NumPy reference", "3D pendulum")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_basilisk_peer_quick():
    """The convention check passes when Basilisk is installed; otherwise the script says so and exits 0."""
    proc = _run("basilisk_peer.py", "--quick")
    _check(proc)
    assert ("convention check" in proc.stdout) or ("Basilisk not installed" in proc.stdout)


@pytest.mark.slow
def test_floor_quick():
    """The floor script counts a step's operations from the kernel's own source and prints its table."""
    proc = _run("floor.py", "--quick")
    _check(proc, "latency: add", "throughput: add/mul mix", "lat.floor", "thr.floor", "kern/floor", "newton ",
           "cayley ")
    assert "Traceback" not in proc.stderr
    rows = {line.split()[0]: line.split() for line in proc.stdout.splitlines() if line.startswith(("newton ", "cayley "))}
    # one solver update per step with the warm start, and the Cayley step needs no more operations than Newton's
    assert rows["cayley"][1] == rows["newton"][1] == "1"
    assert 0 < int(rows["cayley"][3]) <= int(rows["newton"][3])


@pytest.mark.slow
def test_roundoff_quick():
    """The round-off script prints the reference check, the floor of orders 8-12, the drift, the speed."""
    proc = _run("roundoff.py", "--quick")
    _check(proc, "lgvi.exact vs DOP853", "floor: final attitude error", "drift over", "energy", "|Pi|", "R Pi",
           "steps/s", "loop cayley, HLW order 10", "simulate_modified, HLW order 10")
    assert "Traceback" not in proc.stderr
    rows = [line.split() for line in proc.stdout.splitlines() if line.strip().startswith("after ")]
    assert [int(r[1]) for r in rows[:3]] == [8, 10, 12]
    assert all(float(x) < 1e-11 for r in rows[:3] for x in r[2:5])   # round-off, not truncation


@pytest.mark.slow
def test_memory_quick():
    """lgvi run, each size in a fresh process: the script prints its peak-memory table and the verdict line."""
    proc = _run("memory.py", "--quick")
    _check(proc, "peak resident memory", "peak MB", "lgvi run (interval record)", "lgvi info", "goal <= 300 MB")
    assert "Traceback" not in proc.stderr
    rows = [line.split() for line in proc.stdout.splitlines() if line.startswith("lgvi run (interval")]
    assert [int(r[4]) for r in rows] == [100_000, 1_000_000] and all(float(r[6]) > 0 for r in rows)


@pytest.mark.slow
def test_bench_adjoint_quick():
    proc = _run("bench_adjoint.py", "--quick")
    _check(proc, "discrete adjoint", "/ simulate", "gradient", "7 seeds")


@pytest.mark.slow
def test_bench_transfer_quick():
    proc = _run("bench_transfer.py", "--quick")
    _check(proc, "transfer: asymmetric slew", "time/ipopt", "SLSQP")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_bench_bodies_quick():
    """The two-body benchmark prints its cost table and its time-to-accuracy table against DOP853."""
    proc = _run("bench_bodies.py", "--quick")
    _check(proc, "Table 1", "steps/s", "order2", "order4", "Table 2", "lgvi order2", "scipy DOP853", "DOP853/lgvi")


@pytest.mark.slow
def test_bench_members_quick():
    """The Monte Carlo benchmark (lgvi.simulate_members) prints its table; members checked bit for bit."""
    proc = _run("bench_members.py", "--quick")
    _check(proc, "orbit members", "members/s", "loop/this", "threads=2")


def test_bench_gyrostat_quick():
    proc = _run("bench_gyrostat.py", "--quick")
    _check(proc, "gyrostat step vs free body", "ns/step", "ratio", "free body", "4 wheels, motors off",
           "MRPFeedback compiled", "Python controller")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_basilisk_rw_scenario_quick():
    """Against the stored Basilisk fixture (no Basilisk needed)."""
    proc = _run("basilisk_rw_scenario.py", "--quick")
    _check(proc, "scenarioAttitudeFeedbackRW", "max |d sigma|", "Basilisk/lgvi", "Basilisk ExecuteSimulation")


def test_bench_gyrostat_ensemble_quick():
    proc = _run("bench_gyrostat_ensemble.py", "--quick")
    _check(proc, "simulate_ensemble with wheels", "MRPFeedback compiled", "RotationPD, Python", "vs threads=1")


@pytest.mark.slow
def test_bench_gyrostat_call_quick():
    proc = _run("bench_gyrostat_call.py", "--quick", "--compare", "src", "src")
    _check(proc, "case", "old wall", "new CPU", "new/old", "objects", "simulate 10", "simulate 6000")
    assert "Traceback" not in proc.stderr


def test_bench_field_quick():
    proc = _run("bench_field.py", "--quick")
    _check(proc, "us/point", "IGRF-14 n=13, compiled, batch", "centred dipole n=1, compiled, batch")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_splitting_flow_cost_quick():
    proc = _run("splitting_flow_cost.py", "--quick", "--compare", "src", "src")
    _check(proc, "old us/step", "new ns/flow", "new/old", "saba4 h=24 s, gravity gradient", "no torque")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_bench_environment_quick():
    """Issue 26: per-evaluation cost of the environment and disturbance components, all of them vs a gyrostat step."""
    proc = _run("bench_environment.py", "--quick")
    _check(proc, "ns/eval", "sun (series every call)", "shadow (conical)", "facet SRP (10 facets)", "gyrostat step",
           "all together / gyrostat step")
    assert "Traceback" not in proc.stderr


def test_bench_estimation_quick():
    proc = _run("bench_estimation.py", "--quick", "--repeat", "1")
    _check(proc, "called ns", "gyro (ARW, RRW, bias, misalignment, scale)",
           "MEKF propagation + star tracker update", "star tracker update alone")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_bench_loop_sensors_member_quick():
    """``--member``: the two members with and without records, and their two ratios (a merge once
    dropped this branch of the script's output and it crashed on the full table's cases)."""
    proc = _run("bench_loop_sensors.py", "--member", "--quick")
    _check(proc, "sensors + MEKF", "true-state feedback", "sensors + MEKF, no records", "true-state, no records",
           "sensors + MEKF / true-state feedback", "sensors + MEKF, no records / true-state, no records")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_bench_loop_setup_quick():
    """The member's set-up against the true-state member's: the totals, the table by function, and
    ``--compare`` of a tree with itself (the same counts twice)."""
    proc = _run("bench_loop_setup.py", "--quick")
    _check(proc, "one LoopRun build, sensors + MEKF / true-state feedback: opcodes", "_wire")
    proc = _run("bench_loop_setup.py", "--quick", "--compare", "src", "src")
    _check(proc, "src: the member's extra, median over the processes")
    counts = re.findall(r"opcodes (\d+) / (\d+)", proc.stdout)
    assert len(counts) == 2 and counts[0] == counts[1], proc.stdout
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_member_iterations_quick():
    """The member's Newton iterations at six tolerances and its guess's miss: the tables are printed whole
    (a row a tolerance, two members a row; the misses at the steps asked for)."""
    proc = _run("member_iterations.py", "--steps", "400")
    _check(proc, "Newton iterations a step, 400 steps", "the guess's miss")
    rows = re.findall(r"^\s+1e-(\d\d)\s+(\d\.\d{4})\s+(\d\.\d{4})$", proc.stdout, re.M)
    assert [r[0] for r in rows] == ["14", "13", "12", "11", "10", "09"], proc.stdout
    misses = re.findall(r"^\s+(\d+)\s+(\d\.\de-\d\d)\s+(\d\.\de-\d\d)$", proc.stdout, re.M)
    assert [int(m[0]) for m in misses] == [20, 100, 200, 300, 390], proc.stdout
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_loop_hill_pointing_quick():
    proc = _run("loop_hill_pointing.py", "--quick")
    _check(proc, "max attitude difference lgvi - Basilisk", "final pointing error")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_bench_chain_quick():
    """The chain benchmark prints its step-cost table and its time-to-accuracy table against DOP853."""
    proc = _run("bench_chain.py", "--quick")
    _check(proc, "Table 1", "ns/step", "/rigid body", "chain, 3 links, order 2", "Table 2", "lgvi order 2",
           "scipy DOP853", "DOP853/lgvi")


@pytest.mark.slow
def test_bench_slosh_quick():
    """The slosh benchmark prints its step-cost table and its time-to-accuracy table against DOP853."""
    proc = _run("bench_slosh.py", "--quick")
    _check(proc, "Table 1", "ns/step", "/rigid body", "2 pendulums, order 2", "2 pendulums, damped", "Table 2",
           "lgvi order 4", "scipy DOP853", "DOP853/lgvi")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_bench_slosh_wheels_quick():
    """The slosh-with-wheels benchmark prints its step-cost table with both ratios (issue 30, part 2)."""
    proc = _run("bench_slosh_wheels.py", "--quick")
    _check(proc, "ns/step", "/no wheels", "/gyrostat", "slosh + wheels, MRP every step", "gyrostat + wheels + MRP")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_mission_monte_carlo_quick():
    """Issue 28: the mission's Monte Carlo (8 members, one orbit) prints its wall time, its failures and its table."""
    proc = _run("mission_monte_carlo.py", "--quick")
    _check(proc, "members x 1 orbits", "1000 members x 3 orbits at this rate", "reached nadir pointing",
           "mean [95 % CI]", "95th percentile [95 % CI]", "control error p95 (deg)")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_model_step_quick():
    proc = _run("model_step.py", "--quick", "--compare", "src", "src")
    _check(proc, "case", "old ns", "new ns", "new/old", "simulate gravity", "simulate Compiled", "gravity + damping",
           "ensemble gravity", "ensemble Compiled", "Compiled / built-in")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_first_call_compiles_compare_quick():
    """One fresh process a tree with an empty Numba cache (two cold compiles of the free body's loop)."""
    proc = _run("first_call_compiles.py", "--compare", "src", "src", "--rounds", "1", "simulate-free")
    _check(proc, "first call, CPU s", "old runs", "new runs", "new/old", "simulate-free", "load average")
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_first_call_compiles_quick():
    """The smallest case (the free body, whose kernels the suite has usually cached already): the
    call's line, the table's header and one row of numbers per kernel it compiled."""
    proc = _run("first_call_compiles.py", "simulate-free")
    _check(proc, "kernel", "compiler s", "llvm s", "inline_inlinables", "nopython_type_infe", "native_lowering")
    lines = proc.stdout.splitlines()
    first = re.fullmatch(r"simulate-free: first call ([0-9.]+) s CPU, ([0-9.]+) s wall; (\d+) kernels compiled .*",
                         lines[0])
    assert first, proc.stdout
    rows = lines[lines.index(next(line for line in lines if set(line) == {"-"})) + 1:]
    assert (len(rows) >= 1) == (int(first[3]) >= 1), proc.stdout     # a kernel compiled has its row
    for row in rows:
        name, *numbers = row.split()
        assert len(numbers) == 6 and all(float(x) >= 0.0 for x in numbers), row
    assert "Traceback" not in proc.stderr
