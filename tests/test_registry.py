"""The registries are the one source of truth: the scenario files and the command line read them."""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi import registry, torques
from lgvi.io import scenario
from lgvi._kernels import codes as kcodes
from lgvi.implicit import METHODS


def test_solver_methods_derive_the_method_names():
    assert METHODS == {name: m.code for name, m in registry.SOLVER_METHODS.items()}
    assert set(scenario.METHODS) == set(registry.SOLVER_METHODS)
    assert scenario.METHODS[0] == registry.DEFAULT_METHOD
    assert {m.code for m in registry.SOLVER_METHODS.values()} == {kcodes.METHOD_PAPER, kcodes.METHOD_NEWTON,
                                                                  kcodes.METHOD_CAYLEY}
    assert all(m.coordinates in ("exp", "cayley") for m in registry.SOLVER_METHODS.values())


def test_orders_and_forcings_come_from_the_registry():
    assert scenario.FORCINGS is registry.FORCINGS
    assert scenario.ORDERS == registry.ORDERS == (2, 4, 6)
    assert set(registry.DEFAULT_COMPOSITION) == set(registry.ORDERS) - {2}
    assert lgvi.integrator.COMPOSITIONS is registry.COMPOSITIONS


def test_torque_models_register_themselves_with_a_kernel_code():
    from lgvi._kernels import torque_kernels as tk

    assert registry.TORQUE_MODELS is torques.TORQUE_MODELS
    assert list(registry.TORQUE_MODELS) == list(scenario._torque_params())
    for key, cls in registry.TORQUE_MODELS.items():
        assert cls.key == key
        assert cls.code in torques.PARAM_COUNT
        # the class's code is the kernel's branch of the same name
        name = {torques.GRAVITY: "GRAVITY", torques.GRAVITY_GRADIENT: "GRAVITY_GRADIENT",
                torques.CONSTANT: "CONSTANT", torques.DAMPING: "DAMPING", torques.ATTITUDE_PD: "ATTITUDE_PD"}[cls.code]
        assert getattr(tk, name) == cls.code
        assert cls.scenario_params and cls.summary()


def test_torque_kind_is_the_one_classification():
    assert registry.torque_kind(None) == "none"
    assert registry.torque_kind(torques.Constant([0.0, 0.0, 1.0])) == "model"
    assert registry.torque_kind(lambda t, R, Pi: np.zeros(3)) == "callable"
    assert registry.torque_kind(np.zeros((3, 3))) == "array"


def test_a_new_model_is_a_scenario_type_without_touching_scenario(monkeypatch):
    """A model registered by its class alone is accepted by the scenario files."""
    monkeypatch.setattr(torques, "TORQUE_MODELS", dict(torques.TORQUE_MODELS))
    monkeypatch.setattr(scenario, "TORQUE_MODELS", torques.TORQUE_MODELS)

    class Spin(torques.Constant):
        """A constant moment about the body's third axis."""

        key = "spin"
        scenario_params = {"size": ("number", True)}

        @classmethod
        def from_scenario(cls, spec):
            return cls([0.0, 0.0, spec["size"]])

    assert torques.TORQUE_MODELS["spin"] is Spin
    d = {"body": {"inertia": [1.0, 2.0, 3.0]}, "initial": {"omega": [0.1, 1.0, 0.2]},
         "integrator": {"h": 0.01, "steps": 10}, "torque": [{"type": "spin", "size": 0.5}]}
    sc = scenario.Scenario.from_dict(d)
    assert np.array_equal(sc.torque.u, [0.0, 0.0, 0.5])
    with pytest.raises(ValueError, match="size"):
        scenario.Scenario.from_dict(dict(d, torque=[{"type": "spin"}]))


def test_a_scenario_chooses_a_composition():
    d = {"body": {"inertia": [1.0, 2.0, 3.0]}, "initial": {"omega": [0.1, 1.0, 0.2]},
         "integrator": {"h": 0.01, "steps": 10, "composition": "yoshida4"}}
    sc = scenario.Scenario.from_dict(d)
    assert sc.order == 4 and sc.composition == "yoshida4"
    traj = sc.run()
    ref = lgvi.simulate(sc.body, sc.R0, sc.Pi0, h=0.01, steps=10, order=4, composition="yoshida4")
    assert np.array_equal(traj.R, ref.R) and traj.meta["composition"] == "yoshida4"
    with pytest.raises(ValueError, match="composition"):
        scenario.Scenario.from_dict({**d, "integrator": {"h": 0.01, "steps": 10, "order": 6,
                                                         "composition": "yoshida4"}})
    with pytest.raises(ValueError, match="composition"):
        scenario.Scenario.from_dict({**d, "integrator": {"h": 0.01, "steps": 10, "composition": "rk4"}})



def test_the_driver_runs_a_registered_system_as_simulate_does():
    """The seam: a system's run, driven into a memory sink sized by its layout, is lgvi.simulate."""
    from lgvi.driver import MemorySink, drive
    from lgvi.systems import SYSTEMS

    system = SYSTEMS["rigid_body"]
    assert [f.name for f in system.state] == ["R", "Pi"] and system.scenario_section == "body"
    assert set(system.kernels()) >= {"run_chunk", "run_chunk_forced"}
    kw = dict(omega0=None, h=0.01, steps=60, torque=torques.UniformGravity(1.0, [0.0, 0.0, 0.3]), method="cayley",
              tol=1e-14, max_iter=50, alpha=1.0, save_every=3, t0=0.0, forcing="paper", order=4, composition=None)
    run = system.run([1.0, 2.0, 3.0], np.eye(3), [0.1, 1.0, 0.2], **kw, solver_record="full")
    traj = drive(run, MemorySink(run))
    ref = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), [0.1, 1.0, 0.2], solver_record="full",
                        **{k: v for k, v in kw.items() if k != "omega0"})
    for name in ("t", "R", "Pi", "iterations", "residual", "potential"):
        assert np.array_equal(getattr(traj, name), getattr(ref, name)), name
    assert system.invariants(kw["torque"]) == ref.meta["invariants"]
    assert system.invariants(None)["casimir"]["kind"] == "exact"


def test_the_literal_option_types_name_the_registry_entries():
    """Each ``Literal`` option type lists exactly the names its table accepts (type checkers read the
    one, the validation the other), and the public entry points use them."""
    import typing

    from lgvi.environment import sun
    from lgvi.optimal import transfers
    from lgvi.systems import orbit, two_body

    pairs = [(registry.MethodName, registry.SOLVER_METHODS), (registry.ForcingName, registry.FORCINGS),
             (registry.DeviceName, registry.DEVICES), (orbit.OrbitPotential, orbit.POTENTIALS),
             (two_body.TwoBodyPotential, two_body.POTENTIALS), (sun.ShadowModel, sun.SHADOW_MODELS),
             (transfers.CostName, transfers.COSTS), (transfers.TransferMethod, transfers.METHODS)]
    for alias, table in pairs:
        assert typing.get_origin(alias) is typing.Literal
        assert sorted(typing.get_args(alias)) == sorted(table), alias
    uses = {lgvi.simulate: {"method": "MethodName", "forcing": "ForcingName"},
            lgvi.simulate_ensemble: {"method": "MethodName", "forcing": "ForcingName", "device": "DeviceName"},
            lgvi.solve_implicit: {"method": "MethodName"},
            lgvi.simulate_orbit: {"potential": "OrbitPotential"},
            lgvi.simulate_two_body: {"potential": "TwoBodyPotential"},
            lgvi.optimal.transfer: {"cost": "CostName", "forcing": "ForcingName",
                                    "method": "TransferMethod | None"}}
    for func, expected in uses.items():
        annotations = func.__annotations__     # strings: the modules use postponed evaluation
        for name, alias in expected.items():
            assert annotations[name] == alias, (func.__name__, name, annotations[name])
