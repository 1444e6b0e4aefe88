"""A built-in disturbance that writes a value that is not finite stops the loop, naming it, the step
and the time (issue 26 part 5, round 9: the disturbance kinds test their own writes, the force
included, and the loop runs no other test after them: ``loop_kernels.run_one`` at a run's first
step, ``loop_kernels.run_early`` at each step's end)."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest

import lgvi
from lgvi.environment import CentredDipole, ExponentialAtmosphere, KeplerOrbit
from lgvi.spacecraft import FacetDrag, ResidualDipole, Spacecraft

MU = 3.986004418e14


def _spacecraft(base_density: float, normal_angle: float) -> Spacecraft:
    """A polar 500 km orbit, an exponential atmosphere of scale height 1e15 m (the density is the base
    density all along it), one facet of normal ``(cos a, sin a, 0)`` whose centre of pressure is the
    centre of mass (its drag torque is exactly zero) and a residual dipole."""
    orbit = KeplerOrbit(6878137.0, 0.0, np.radians(97.4), 0.0, 0.0, 0.0, mu=MU)
    drag = FacetDrag([0.03], [[np.cos(normal_angle), np.sin(normal_angle), 0.0]], [[0.0, 0.0, 0.0]], 2.2)
    return Spacecraft(np.diag([0.18, 0.14, 0.06]), orbit=orbit, field=CentredDipole(-29404.8e-9, -1450.9e-9, 4652.5e-9),
                      epoch=dt.datetime(2024, 3, 1),
                      environment=[ExponentialAtmosphere(base_density, 1e15, planet_radius=6378137.0)],
                      disturbances=[drag, ResidualDipole([0.01, 0.0, 0.0])])


KW = dict(omega0=[0.0, 0.0, -0.1], h=0.1, steps=60, save_every=1)


def test_the_facet_and_its_zero_torque_in_a_sane_atmosphere():
    """The control of the tests below: with a sane density the run goes through, the facet's torque is
    zero at every step and its force turns from zero (the facet facing away from the flow) to a
    drag once the spin about z turns it into the flow (between 0.5 and 0.6 s)."""
    tr = lgvi.simulate(_spacecraft(1e-12, 0.05), np.eye(3), **KW)
    force = tr.records["F_facet_drag_N"].values
    assert np.all(tr.records["tau_facet_drag_B"].values == 0.0)
    assert np.all(force[:6] == 0.0) and np.all(np.abs(force[6:]).max(axis=1) > 0.0)


@pytest.mark.parametrize(("angle", "step"), [(-0.05, 0), (0.05, 6)])
def test_a_drag_force_that_overflows_stops_the_run_naming_facet_drag(angle, step):
    """Where the facet faces the flow, its force -rho/2 Cd A (n . v) v overflows to infinity with a
    density of 1e308 while its torque stays exactly zero: only the kind's own test of its force can
    stop the run. Facing the flow at once, the run stops at step 0 (the components of the first
    step); turned into the flow by the spin, at step 6 (t = 0.6 s: the lookahead at the end of step
    5), with the steps before it kept and equal to the sane run's."""
    with pytest.raises(lgvi.ComponentError, match=r"facet_drag.*not finite") as err:
        lgvi.simulate(_spacecraft(1e308, angle), np.eye(3), **KW)
    e = err.value
    assert e.component == "facet_drag" and e.step == step and e.time == pytest.approx(0.1 * step)
    if step:
        sane = lgvi.simulate(_spacecraft(1e-12, angle), np.eye(3), **KW)
        part = e.trajectory
        assert part.meta.get("partial") and len(part.t) == step + 1
        assert np.array_equal(part.R, sane.R[:step + 1])
