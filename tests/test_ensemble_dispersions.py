"""Ensembles with one torque model per body (issue 11 part 6): Monte Carlo dispersions.

``simulate_ensemble(..., torque=[model_0, ..., model_{B-1}])``: every built-in model kind may
have its parameters (gains, targets, disturbance torques, centres of mass, orbits) differ per
body. Body ``b`` must equal ``lgvi.simulate(..., torque=model_b)`` bit for bit on the serial and
the parallel kernel and through block files, and the parameters used are recorded with the
result (``model_params``, ``dispersions``, ``torque_model(b)``) and survive save and load.
"""

from __future__ import annotations

import numpy as np
import pytest

import lgvi
from lgvi import so3
from lgvi.torques import AttitudePD, Constant, GravityGradient, LinearDamping, UniformGravity

B = 7
BODIES = [lgvi.RigidBody([0.9, 1.3, 1.7]), lgvi.RigidBody([1.0, 2.0, 2.5])]


def initial(n: int = B, seed: int = 11) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return so3.exp(0.5 * rng.normal(size=(n, 3))), np.array([0.6, -0.9, 1.2]) + 0.3 * rng.normal(size=(n, 3))


def dispersed(kind: str, n: int = B) -> list:
    """``n`` models of one kind with parameters drawn per body (the last two bodies share one)."""
    rng = np.random.default_rng(7)
    out = []
    for b in range(n):
        r = rng.random(3)
        if kind == "uniform_gravity":
            m = UniformGravity(1.0 + r[0], [0.05 * r[1], -0.02, 0.3 * r[2]])
        elif kind == "gravity_gradient":
            m = GravityGradient(3.0, 1.0 + r[0])
        elif kind == "constant":
            m = Constant(0.1 * (r - 0.5))
        elif kind == "damping":
            m = LinearDamping(0.05 + 0.1 * r)
        elif kind == "pd":
            m = AttitudePD(kp=1.0 + r, kd=0.5 + r[0], R_target=so3.exp(0.4 * (r - 0.5)))
        else:  # a sum, with a key that repeats
            m = UniformGravity(1.0, [0.0, 0.0, 0.2 + 0.1 * r[0]]) + LinearDamping(0.02 * r[1]) + LinearDamping(
                [0.01, 0.02, 0.03 * r[2]])
        out.append(m)
    out[-1] = out[-2]
    return out


KINDS = {"uniform_gravity": dict(order=4, method="cayley"), "gravity_gradient": dict(t0=0.5),
         "constant": dict(), "damping": dict(forcing="symmetric"), "pd": dict(forcing="symmetric"),
         "sum": dict(forcing="symmetric", order=4)}


def check_members(ens, models, R0, Pi0, ib, **opts) -> None:
    for b in range(len(models)):
        one = lgvi.simulate(BODIES[ib[b]], R0[b], Pi0[b], torque=models[b], **opts)
        np.testing.assert_array_equal(ens.R[b], one.R, err_msg=f"body {b}")
        np.testing.assert_array_equal(ens.Pi[b], one.Pi, err_msg=f"body {b}")
        assert ens.iterations[b] == one.solver_summary["iterations_total"], b
        assert ens.residual[b] == one.solver_summary["residual_max"], b
        if one.potential is None:
            assert ens.potential is None
        else:
            np.testing.assert_array_equal(ens.potential[b], one.potential, err_msg=f"body {b}")
        rebuilt = ens.torque_model(b)
        assert rebuilt == models[b] and repr(rebuilt) == repr(models[b])
        member = ens[b]
        assert member.meta["torque_model"] == one.meta["torque_model"]
        assert member.meta["invariants"] == one.meta["invariants"]


@pytest.mark.parametrize("kind", list(KINDS))
def test_member_equals_simulate_with_its_model(kind):
    R0, Pi0 = initial()
    models = dispersed(kind)
    ib = [b % 2 for b in range(B)]
    opts = dict(h=0.02, steps=40, save_every=4, **KINDS[kind])
    serial = lgvi.simulate_ensemble([BODIES[q] for q in ib], R0, Pi0, torque=models, threads=1, **opts)
    check_members(serial, models, R0, Pi0, ib, **opts)
    parallel = lgvi.simulate_ensemble([BODIES[q] for q in ib], R0, Pi0, torque=models, threads=2, **opts)
    for name in ("R", "Pi", "iterations", "residual", "potential"):
        np.testing.assert_array_equal(getattr(parallel, name), getattr(serial, name), err_msg=name)
    # what was dispersed is recorded, one row per body
    assert serial.dispersions and all(v.shape[0] == B for v in serial.model_params.values())
    for name, values in serial.dispersions.items():
        assert not np.all(values == values[:1]), name
    assert set(serial.dispersions) <= set(serial.model_params)


def test_recorded_names_and_values():
    models = dispersed("sum")
    ens = lgvi.simulate_ensemble(BODIES[0], *initial(), h=0.02, steps=4, torque=models, forcing="symmetric")
    assert sorted(ens.model_params) == ["damping[1].c", "damping[2].c", "uniform_gravity.com",
                                        "uniform_gravity.g", "uniform_gravity.mass"]
    assert sorted(ens.dispersions) == ["damping[1].c", "damping[2].c", "uniform_gravity.com"]
    np.testing.assert_array_equal(ens.model_params["uniform_gravity.com"],
                                  np.stack([m.terms[0].com for m in models]))
    assert ens.meta["torque_terms"] == ["uniform_gravity", "damping", "damping"]
    assert ens[3].meta["model_params"]["damping[2].c"] == models[3].terms[2].c.tolist()
    # gravity gradient on dispersed orbits: the ensemble keeps no common Jacobi rate, each body its own
    gg = dispersed("gravity_gradient")
    ens = lgvi.simulate_ensemble(BODIES[0], *initial(), h=0.02, steps=4, torque=gg)
    assert "jacobi" not in ens.meta["invariants"]
    assert ens[2].meta["invariants"]["jacobi"]["n"] == gg[2].mean_motion
    # one model for all: nothing per body recorded
    one = lgvi.simulate_ensemble(BODIES[0], *initial(), h=0.02, steps=4, torque=models[0], forcing="symmetric")
    assert one.model_params is None and one.dispersions == {}
    with pytest.raises(ValueError, match="one torque model for all bodies"):
        one.torque_model(0)
    assert lgvi.simulate_ensemble(BODIES[0], *initial(), h=0.02, steps=4).torque_model(0) is None


def test_blocks_on_disk_and_save_load_keep_the_dispersions(tmp_path):
    R0, Pi0 = initial(10)
    models = dispersed("pd", 10)
    opts = dict(h=0.02, steps=30, save_every=5, forcing="symmetric", torque=models)
    whole = lgvi.simulate_ensemble(BODIES[1], R0, Pi0, **opts)
    lgvi.simulate_ensemble(BODIES[1], R0, Pi0, out_dir=tmp_path / "run", block_size=3, **opts)
    whole.save(tmp_path / "one.npz")
    for loaded in (lgvi.load_ensemble(tmp_path / "run"), lgvi.load_ensemble(tmp_path / "one.npz")):
        for name in ("R", "Pi", "iterations", "residual"):
            np.testing.assert_array_equal(getattr(loaded, name), getattr(whole, name), err_msg=name)
        assert sorted(loaded.model_params) == sorted(whole.model_params)
        for name, values in whole.model_params.items():
            np.testing.assert_array_equal(loaded.model_params[name], values, err_msg=name)
        assert sorted(loaded.dispersions) == ["pd.kd", "pd.kp", "pd.target"]
        assert loaded.torque_model(8) == models[8]
    check_members(lgvi.load_ensemble(tmp_path / "run"), models, R0, Pi0, [1] * 10, **{
        k: v for k, v in opts.items() if k != "torque"})


def test_validation():
    R0, Pi0 = initial(3)
    run = lambda torque, **kw: lgvi.simulate_ensemble(BODIES[0], R0, Pi0, h=0.01, steps=2, torque=torque, **kw)
    with pytest.raises(ValueError, match=r"must hold 3 models .* got 2"):
        run([Constant([0, 0, 1.0])] * 2)
    with pytest.raises(ValueError, match=r"torque\[2\] = LinearDamping.* not of the same kind as torque\[0\] = "
                                         r"Constant.*same terms in the same order \(Constant\)"):
        run([Constant([0, 0, 1.0]), Constant([0, 1.0, 0]), LinearDamping(0.1)])
    g, d = UniformGravity(1.0, [0, 0, 0.3]), LinearDamping(0.1)
    with pytest.raises(ValueError, match=r"torque\[1\].*UniformGravity \+ LinearDamping"):
        run([g + d, d + g, g + d])
    with pytest.raises(TypeError, match=r"torque\[1\] must be a torque model.*got float"):
        run([g, 1.0, g])
    import numba
    from lgvi.torques import Compiled

    @numba.njit
    def zero(t, R, Pi, p):
        return (0.0, 0.0, 0.0)

    with pytest.raises(TypeError, match=r"torque\[0\] is a Compiled model.*params of shape \(B, P\)"):
        run([Compiled(zero)] * 3)
    # the run's options are checked on the models' kind
    with pytest.raises(ValueError, match="forcing='symmetric'"):
        run([d] * 3, order=4)
