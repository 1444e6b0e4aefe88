"""The fused block of the loop (issue 26 part 5, ``docs/loop.md``): the leading built-in environment
and disturbance components run in one compiled call give the trajectories and records of the
components run one by one, bit for bit, and a member that fails stops the run as it did.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import lgvi
from lgvi.fsw import FlightSoftware
from lgvi.spacecraft import FacetDrag, ResidualDipole, Spacecraft
from lgvi.systems import spacecraft as loop_system
from test_loop_integration import _basilisk_6u

ENVIRONMENT = ("orbit", "field", "sun", "shadow", "exponential_atmosphere")


def _run(fused, sc, R0, monkeypatch, **kw):
    monkeypatch.setattr(loop_system, "FUSE_BLOCK", fused)
    return lgvi.simulate(sc, R0, **kw)


def _gnc_6u():
    """The tumbling 6U with a GNC engineer's rates: the orbit, field, shadow and atmosphere at 1 s,
    the sun at 60 s, every torque every step (``benchmarks/bench_loop_sensors.py``'s ``GNC``)."""
    sc, d = _basilisk_6u()
    for c in sc.environment:
        c.rate = 60.0 if c.kind == "sun" else 1.0
    out = Spacecraft(sc.body, orbit=sc.orbit, field=sc.field, epoch=sc.epoch, environment=sc.environment,
                     disturbances=sc.disturbances, environment_rate=1.0)
    return out, d


def _same(a, b):
    assert np.array_equal(a.R, b.R) and np.array_equal(a.Pi, b.Pi)
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.signal_data, b.signal_data, equal_nan=True)
    assert a.signals.keys() == b.signals.keys()


@pytest.mark.parametrize("rates", ["every step", "GNC", "held"])
@pytest.mark.parametrize("record_rate", [None, "grid"])
def test_the_block_fused_is_the_components_one_by_one_bit_for_bit(rates, record_rate, monkeypatch):
    """The tumbling 6U under every disturbance (orbit, field, sun, shadow, atmosphere, facet drag and
    SRP, residual dipole, gravity gradient): the fused block and the components one by one give the
    same attitude, momentum and records (by name, at the writers' rates and on the grid), bit for bit;
    at the GNC rates the block's members are due at different steps (sun every 600th, the
    environment every 10th, the torques every step) and over 130 s the sun moves twice; ``held``: the
    residual dipole restricted to mode 0 (no lookahead: the block runs at each step's start, each
    member's mode checked in it)."""
    sc, d = _gnc_6u() if rates == "GNC" else _basilisk_6u()
    if rates == "held":
        for c in sc.disturbances:
            if c.kind == "residual_dipole":
                c.modes = (0,)
    R0 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    fsw = None if record_rate is None else FlightSoftware(components=[], record_rate=record_rate)
    kw = dict(omega0=d["omega0"], h=0.1, steps=1300, save_every=50, fsw=fsw)
    fused = _run(True, sc, R0, monkeypatch, **kw)
    one = _run(False, sc, R0, monkeypatch, **kw)
    _same(fused, one)
    assert set(fused.records) >= {"tau_facet_drag_B", "tau_facet_srp_B", "tau_residual_dipole_B", "tau_dist_B"}
    assert np.abs(fused.signals["tau_dist_B"]).max() > 0.0


def test_the_fused_block_is_chosen_when_it_qualifies(monkeypatch):
    """The block is the leading built-in environment and disturbance components: all eight of the 6U,
    also when one runs in one mode only (then no lookahead: the held, first-order forcing); none
    when fusing is switched off."""
    from lgvi.systems.spacecraft import LoopRun

    sc, d = _basilisk_6u()
    R0 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    built = []
    real = LoopRun._wire

    def spy(self, comps, ctx):
        real(self, comps, ctx)
        built.append((self.fused, list(self.names), int(self.io[-3])))

    monkeypatch.setattr(LoopRun, "_wire", spy)
    lgvi.simulate(sc, R0, omega0=d["omega0"], h=0.1, steps=2)
    fused, names, L = built[-1]
    assert fused == 8 and L == 8
    assert set(names[:8]) == set(ENVIRONMENT) | {"facet_drag", "facet_srp", "residual_dipole"}
    for c in sc.disturbances:
        if c.kind == "residual_dipole":
            c.modes = (0,)
    lgvi.simulate(sc, R0, omega0=d["omega0"], h=0.1, steps=2)
    assert built[-1][0] == 8 and built[-1][2] == 0
    monkeypatch.setattr(loop_system, "FUSE_BLOCK", False)
    lgvi.simulate(_basilisk_6u()[0], R0, omega0=d["omega0"], h=0.1, steps=2)
    assert built[-1][0] == 0


def test_an_ensemble_with_coefficients_per_member_fused_bit_for_bit(monkeypatch):
    """Each member's own drag coefficients, dipole and atmosphere (per-member parameter rows): the
    ensemble fused equals the ensemble one by one, bit for bit, and the members differ."""
    base, d = _basilisk_6u()
    facets = (d["fac_area"], d["fac_normal"], d["fac_centre"])
    cd = np.stack([d["fac_cd"], 1.1 * d["fac_cd"]])
    dipole = np.stack([d["dipole"], [0.0, 0.02, -0.01]])
    drag = FacetDrag(*facets, cd)
    dist = [drag if c.kind == "facet_drag" else ResidualDipole(dipole) if c.kind == "residual_dipole" else c
            for c in base.disturbances]
    sc = Spacecraft(base.body, orbit=base.orbit, field=base.field, epoch=base.epoch, environment=base.environment,
                    disturbances=dist)
    R0 = np.stack([Rotation.from_mrp(d["sigma0"]).as_matrix(), lgvi.so3.exp([0.2, -0.1, 0.3])])
    w0 = np.stack([d["omega0"], [0.0, 0.01, -0.01]])
    kw = dict(omega0=w0, h=0.1, steps=400, save_every=20, threads=1)
    monkeypatch.setattr(loop_system, "FUSE_BLOCK", True)
    fused = lgvi.simulate_ensemble(sc, R0, **kw)
    monkeypatch.setattr(loop_system, "FUSE_BLOCK", False)
    one = lgvi.simulate_ensemble(sc, R0, **kw)
    for b in range(2):
        _same(fused[b], one[b])
    assert not np.array_equal(fused[0].signals["tau_facet_drag_B"], fused[1].signals["tau_facet_drag_B"])


def _failing_6u(kind):
    """The 6U whose ``kind`` writes a value that is not finite from its first step: an infinite drag
    area of one facet (the drag and every disturbance after it, which add into ``tau_dist_B``, then
    write infinities or NaN) or an infinite residual dipole (the block's last member)."""
    sc, d = _basilisk_6u()
    comp = next(c for c in sc.disturbances if c.kind == kind)
    row = np.array(comp.params(), dtype=float)
    row[1] = np.inf                       # facet 0's Cd A, or the dipole's y component
    comp.params = lambda: row
    return sc, d


@pytest.mark.parametrize("kind", ["facet_drag", "residual_dipole"])
def test_a_member_of_the_block_writing_nan_stops_the_run_naming_it(kind, monkeypatch):
    """A member of the block that writes a value that is not finite stops the run at the same step,
    naming the same component, with the same part computed, as the components one by one: the
    first writer of a non-finite value, not a member after it that read it."""
    sc, d = _failing_6u(kind)
    R0 = Rotation.from_mrp(d["sigma0"]).as_matrix()
    kw = dict(omega0=d["omega0"], h=0.1, steps=200, save_every=10)
    errors = []
    for fused in (True, False):
        with pytest.raises(lgvi.ComponentError, match=rf"{kind} \(component \d\) stopped the run at step \d+ "
                                                      r"\(t = [\d.]+ s\): status 1") as err:
            _run(fused, sc, R0, monkeypatch, **kw)
        errors.append(err.value)
    assert str(errors[0]) == str(errors[1])
    assert errors[0].component == kind and errors[0].status == 1
    assert errors[0].step == errors[1].step
    _same(errors[0].trajectory, errors[1].trajectory)


def test_a_member_of_an_ensemble_block_failing_is_named_with_its_member(monkeypatch):
    """In an ensemble, member 1's infinite dipole stops member 1 and the message names the component,
    the member and the time, fused or not."""
    base, d = _basilisk_6u()
    dip = ResidualDipole(np.stack([d["dipole"], [1.0, 0.0, 0.0]]))
    rows = dip.params()
    rows[1, 0] = np.inf                   # (the class refuses it: the row a faulty member would give)
    dip.params = lambda: rows
    dist = [dip if c.kind == "residual_dipole" else c for c in base.disturbances]
    sc = Spacecraft(base.body, orbit=base.orbit, field=base.field, epoch=base.epoch, environment=base.environment,
                    disturbances=dist)
    R0 = np.stack([Rotation.from_mrp(d["sigma0"]).as_matrix()] * 2)
    kw = dict(omega0=np.stack([d["omega0"]] * 2), h=0.1, steps=50, save_every=10, threads=1)
    messages = []
    for fused in (True, False):
        monkeypatch.setattr(loop_system, "FUSE_BLOCK", fused)
        with pytest.raises(Exception, match=r"residual_dipole") as err:
            lgvi.simulate_ensemble(sc, R0, **kw)
        messages.append(str(err.value))
    assert messages[0] == messages[1]
    assert "member 1" in messages[0] and "t = 0 s" in messages[0]
