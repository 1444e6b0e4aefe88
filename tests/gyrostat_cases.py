"""The gyrostat test cases shared by several test modules (imported as a plain module: pytest puts
``tests/`` on the path): a tumbling body with four wheels (three on the axes, one skewed), its start
and reference, a seeded random wheel command, and Basilisk's scenario from ``benchmarks/``."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import lgvi
from lgvi.control import Command, Controller

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
BODY = lgvi.RigidBody([1.0, 2.0, 3.0])
AXES = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]) / np.array(
    [[1.0], [1.0], [1.0], [np.sqrt(3.0)]])
JS = np.array([0.02, 0.03, 0.04, 0.05])
R0 = lgvi.so3.exp([0.3, -0.2, 0.5])
W0 = np.array([0.3, 1.0, 0.2])
R_REF = lgvi.so3.exp([0.0, 0.5, 0.0])


def wheels(**kw):
    """The four wheels (``speed0`` (10, -5, 3, 7) rad/s unless given)."""
    kw.setdefault("speed0", [10.0, -5.0, 3.0, 7.0])
    return lgvi.ReactionWheels(AXES, JS, **kw)


class Random(Controller):
    """Random wheel motor torques (seeded), held over each control period."""

    def __init__(self, scale, seed=0):
        self.scale, self.seed = scale, seed

    def reset(self):
        self.rng = np.random.default_rng(self.seed)

    def command(self, t, R, omega, wheel_speed, env):
        return Command(wheel_torque=self.scale * self.rng.standard_normal(len(wheel_speed)))


def basilisk_scenario():
    """``benchmarks/basilisk_rw_scenario.py`` as a module: Basilisk's scenario, its fixtures and ``run_lgvi``."""
    sys.path.insert(0, str(BENCH))
    try:
        import basilisk_rw_scenario
    finally:
        sys.path.remove(str(BENCH))
    return basilisk_rw_scenario
