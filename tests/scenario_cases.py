"""Checks shared by the scenario tests of the systems that read their own section (the chain, the
slosh hub): a bad value names its key, and ``lgvi run --resume`` continues a stream cut by Ctrl-C."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

#: The slosh hub of the scenario tests (tests/test_slosh.py, tests/test_slosh_wheels.py): its
#: ``[slosh]`` lines before each test's own (``omega0``, ``damping``, wheels, order).
SLOSH_HUB = """\
inertia = [900.0, 800.0, 600.0]
hub_mass = 1500.0
pivots = [[0.5, 0.1, 0.2], [-0.3, 0.4, -0.1]]
lengths = [0.3, 0.4]
masses = [40.0, 60.0]
q0 = [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8]]
qdot0 = [[0.5, 0.2, 0.0], [0.0, 1.0, 0.0]]
"""


def assert_scenario_error(tmp_path: Path, scenario: str, old: str, new: str, key: str, rule: str) -> None:
    """``scenario`` with ``old`` replaced by ``new`` is refused by ``load_scenario`` with a
    ScenarioError naming ``key`` and matching ``rule``."""
    from lgvi.io.scenario import ScenarioError, load_scenario

    path = tmp_path / "bad.toml"
    assert old in scenario
    path.write_text(scenario.replace(old, new))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.key == key and re.search(rule, str(info.value)), str(info.value)


def cut_and_resume(scenario: Any, path: Path, out: Path, capsys: Any, cut_at: int, chunk_steps: int) -> Any:
    """Stream the loaded ``scenario`` into ``out/stream``, stopped by a Ctrl-C after step ``cut_at``,
    then ``lgvi run path -o out --resume``: the result read back from ``out/trajectory.npz``."""
    from lgvi import cli
    from lgvi.io.outputs import read_trajectory

    def ctrl_c(k: int, n: int) -> None:
        if k >= cut_at:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        scenario.run_stream(out / "stream", chunk_steps=chunk_steps, progress=ctrl_c)
    code = cli.main(["run", str(path), "-o", str(out), "--resume"])
    _, err = capsys.readouterr()
    assert code == 0, err
    return read_trajectory(out / "trajectory.npz")
