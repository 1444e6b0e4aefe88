"""Orbits that drive the environment (issue 12, part 4): known answers.

* Kepler: the period returns the state, the energy is ``-mu / 2a``, vis-viva, the angular
  momentum ``sqrt(mu a (1 - e^2))``; Kepler's equation solved for ``e`` from 0 to 1 - 1e-9.
* J2 secular rates: the textbook formula's sun-synchronous orbit (RAAN drift 360 deg per
  365.2422 days) and the drift seen in the positions' orbit plane.
* SGP4: Vallado's verification case 00005 (the TLE and the expected TEME states of
  ``SGP4-VER.TLE`` / ``tcppver.out`` that the ``sgp4`` package ships with its tests), to 1e-2 m.
* LVLH: a rotation; on an equatorial circle, the frame of :class:`lgvi.torques.GravityGradient`;
  the nadir reference's rate is the frame's rate (``dR/dt = hat(omega) R``, finite differences).
* The environment: a field aligned with the Earth's axis is the same in inertial components
  whatever the Earth's rotation; the tabulated gravity gradient equals the circular-orbit model.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest

import lgvi
from lgvi.environment import (CentredDipole, CircularOrbit, IGRF, J2Orbit, KeplerOrbit, OrbitEnvironment,
                              OrbitGravityGradient, SGP4Orbit, lvlh_frame, nadir_reference, solve_kepler)
from lgvi.environment.orbits import MU_EARTH
from lgvi.so3 import hat
from lgvi.torques import GravityGradient

ELEMENTS = dict(inclination=1.1, raan=0.4, arg_perigee=2.0, mean_anomaly=0.3)


@pytest.mark.parametrize("e", [0.0, 1e-12, 0.1, 0.7, 0.99, 0.999999])
def test_solve_kepler(e):
    M = np.concatenate([np.linspace(-20.0, 20.0, 2001), [0.0, 1e-12, -1e-12, np.pi, -np.pi, 2 * np.pi]])
    E = solve_kepler(M, e)
    assert np.max(np.abs(E - e * np.sin(E) - M)) <= 4e-15 * (1 + np.abs(M)).max()
    assert np.all(np.diff(E[:2001]) > 0)                    # monotonic in M


@pytest.mark.parametrize("e", [0.0, 0.1, 0.7, 0.995])
def test_kepler_known_answers(e):
    orbit = KeplerOrbit(7.5e6 / (1 - e) if e > 0.5 else 7.5e6, e, **ELEMENTS)
    a, mu = orbit.a, orbit.mu
    assert np.isclose(orbit.period, 2 * np.pi * np.sqrt(a ** 3 / mu), rtol=1e-15)
    t = np.linspace(0.0, orbit.period, 301)
    r, v = orbit.position_velocity(t)
    rn, vn = np.linalg.norm(r, axis=-1), np.linalg.norm(v, axis=-1)
    assert np.allclose(0.5 * vn ** 2 - mu / rn, -mu / (2 * a), rtol=1e-12, atol=0)     # energy
    assert np.allclose(vn ** 2, mu * (2 / rn - 1 / a), rtol=1e-11, atol=0)              # vis-viva
    h = np.cross(r, v)
    assert np.allclose(np.linalg.norm(h, axis=-1), np.sqrt(mu * a * (1 - e * e)), rtol=1e-12, atol=0)
    assert np.allclose(h / np.linalg.norm(h, axis=-1, keepdims=True), h[0] / np.linalg.norm(h[0]), atol=1e-13)
    assert np.allclose(r[-1], r[0], rtol=0, atol=1e-7 * a) and np.allclose(v[-1], v[0], rtol=0, atol=1e-7 * vn[0])
    tp = -orbit.mean_anomaly / orbit.mean_motion                         # perigee, then apogee
    rp, _ = orbit.position_velocity([tp, tp + orbit.period / 2])
    assert np.allclose(np.linalg.norm(rp, axis=-1), [a * (1 - e), a * (1 + e)], rtol=1e-13, atol=0)
    # the velocity is the derivative of the position
    dt_ = orbit.period * 1e-6
    rp, _ = orbit.position_velocity(t[:5] + dt_)
    rm, _ = orbit.position_velocity(t[:5] - dt_)
    assert np.allclose((rp - rm) / (2 * dt_), v[:5], rtol=0, atol=1e-6 * vn.max())


def test_circular_orbit_plane():
    i, raan = np.radians(51.6), np.radians(120.0)
    orbit = CircularOrbit(6.8e6, i, raan, arg_latitude=0.5)
    r, v = orbit.position_velocity(np.linspace(0, 6000.0, 50))
    assert np.allclose(np.linalg.norm(r, axis=-1), 6.8e6, rtol=1e-14)
    normal = np.cross(r, v) / np.linalg.norm(np.cross(r, v), axis=-1, keepdims=True)
    assert np.allclose(normal, [np.sin(i) * np.sin(raan), -np.sin(i) * np.cos(raan), np.cos(i)], atol=1e-14)
    r0, _ = orbit.position_velocity(-0.5 / orbit.mean_motion)            # the ascending node
    assert np.allclose(r0 / 6.8e6, [np.cos(raan), np.sin(raan), 0.0], atol=1e-13)


def test_j2_sun_synchronous_rate():
    """The textbook formula: a 700 km circular orbit at i = 98.19 deg precesses 360 deg a year."""
    orbit = J2Orbit(6378137.0 + 700e3, 0.0, np.radians(98.19))
    dO, dw, dM = orbit.rates
    year = 365.2422 * 86400.0
    assert abs(dO * year - 2 * np.pi) < 0.003 * 2 * np.pi
    # critical inclination: no apsidal drift; polar orbit: no nodal drift
    assert abs(J2Orbit(7e6, 0.01, np.arccos(np.sqrt(1 / 5))).rates[1]) < 1e-20
    assert abs(J2Orbit(7e6, 0.01, np.pi / 2).rates[0]) < 1e-20


def test_j2_drift_in_the_positions():
    orbit = J2Orbit(7.0e6, 0.05, 0.9, 0.2, 1.0, 0.0)
    dO, dw, dM = orbit.rates
    n = orbit.mean_motion
    p = 7.0e6 * (1 - 0.05 ** 2)
    k = n * orbit.J2 * (orbit.radius / p) ** 2
    assert np.isclose(dO, -1.5 * k * np.cos(0.9)) and np.isclose(dw, 0.75 * k * (5 * np.cos(0.9) ** 2 - 1))
    t = np.array([0.0, 30 * 86400.0])
    r, v = orbit.position_velocity(t)
    h = np.cross(r, v)
    node = np.arctan2(h[:, 0], -h[:, 1])
    assert np.isclose(node[1] - node[0], dO * t[1], rtol=1e-10)
    assert np.allclose(np.arccos(h[:, 2] / np.linalg.norm(h, axis=1)), 0.9, atol=1e-13)


# Vallado's SGP4 verification case 00005 (sgp4/SGP4-VER.TLE) and its TEME states, km and km/s,
# at 0, 360 and 720 minutes (sgp4/tcppver.out)
TLE = ("1 00005U 58002B   00179.78495062  .00000023  00000-0  28098-4 0  4753",
       "2 00005  34.2682 348.7242 1859667 331.7664  19.3264 10.82419157413667")
TCPPVER = [
    (0.0, 7022.46529266, -1400.08296755, 0.03995155, 1.893841015, 6.405893759, 4.534807250),
    (360.0, -7154.03120202, -3783.17682504, -3536.19412294, 4.741887409, -4.151817765, -2.093935425),
    (720.0, -7134.59340119, 6531.68641334, 3260.27186483, -4.113793027, -2.911922039, -2.557327851),
]


def test_sgp4_verification_case():
    pytest.importorskip("sgp4")
    orbit = SGP4Orbit(*TLE)
    ref = np.array(TCPPVER)
    r, v = orbit.position_velocity(ref[:, 0] * 60.0)
    assert np.allclose(r, ref[:, 1:4] * 1e3, rtol=0, atol=1e-2)
    assert np.allclose(v, ref[:, 4:7] * 1e3, rtol=0, atol=1e-5)
    assert orbit.epoch.strftime("%Y-%m-%d %H:%M:%S") == "2000-06-27 18:50:19"
    env = OrbitEnvironment(orbit, epoch=orbit.epoch + dt.timedelta(minutes=360))
    assert np.allclose(env.sample(0.0)["r"], r[1], rtol=1e-15, atol=1e-9)


def test_lvlh_frame_and_nadir_reference():
    orbit = CircularOrbit(7e6)
    t = np.linspace(0, 3000.0, 7)
    r, v = orbit.position_velocity(t)
    R = lvlh_frame(r, v)
    n = orbit.mean_motion
    expected = np.stack([np.stack([-np.sin(n * t), np.cos(n * t), 0 * t], -1), np.tile([0, 0, -1.0], (7, 1)),
                         -np.stack([np.cos(n * t), np.sin(n * t), 0 * t], -1)], axis=-1)
    assert np.allclose(R, expected, atol=1e-14)
    # an eccentric inclined orbit: the reference rate is the LVLH frame's rate
    orbit = KeplerOrbit(8e6, 0.3, **ELEMENTS)
    for tk in (0.0, 1234.0, 4000.0):
        r, v = orbit.position_velocity(tk)
        R, w, dw = nadir_reference(r, v)
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-15) and np.isclose(np.linalg.det(R), 1.0)
        d = 1e-2
        Rp, wp, _ = nadir_reference(*orbit.position_velocity(tk + d))
        Rm, wm, _ = nadir_reference(*orbit.position_velocity(tk - d))
        assert np.allclose((Rp - Rm) / (2 * d), hat(w) @ R, atol=1e-9 * np.linalg.norm(w))
        assert np.allclose((wp - wm) / (2 * d), dw, atol=1e-6 * np.linalg.norm(dw))


def test_environment_field_is_rotated_into_the_inertial_frame():
    axial = CentredDipole(-29000.0, 0.0, 0.0)             # symmetric about the Earth's axis
    orbit = KeplerOrbit(7e6, 0.01, **ELEMENTS)
    env = OrbitEnvironment(orbit, axial, epoch=dt.datetime(2026, 3, 1, 6, 30))
    t = np.linspace(0.0, 5000.0, 11)
    s = env.sample(t)
    m = axial.moment
    r = s["r"]
    n = np.linalg.norm(r, axis=-1, keepdims=True)
    exact = 1e-7 * (3.0 * (r @ m)[:, None] * r / n ** 5 - m / n ** 3)
    assert np.allclose(s["B_inertial"], exact, rtol=1e-12, atol=0)
    # a tilted field does turn with the Earth: the inertial field differs over a sidereal day's half
    env = OrbitEnvironment(orbit, IGRF(), epoch=dt.datetime(2026, 3, 1))
    b = env.sample(0.0)["B_inertial"]
    assert b.shape == (3,) and 1e-5 < np.linalg.norm(b) < 6e-5
    assert np.allclose(env.sample(t)["B_inertial"][3], env.sample(t[3])["B_inertial"], rtol=1e-14, atol=0)


def test_environment_nadir_reference_keys():
    env = OrbitEnvironment(CircularOrbit(7e6, 1.0), reference="nadir")
    s = env.sample(100.0)
    R = lgvi.control.matrix_from_mrp(s["sigma_ref"])
    assert np.allclose(R, lvlh_frame(s["r"], s["v"]), atol=1e-14)
    assert set(s) == {"r", "v", "sigma_ref", "omega_ref", "domega_ref"}


def test_orbit_gravity_gradient_is_the_circular_model():
    body = lgvi.RigidBody([10.0, 12.0, 8.0])
    model = OrbitGravityGradient(CircularOrbit(7e6), body, duration=3000.0)
    ref = GravityGradient(mu=MU_EARTH, radius=7e6)
    rng = np.random.default_rng(5)
    for t in (0.0, 13.7, 1234.5, 3000.0):
        R = lgvi.so3.exp(rng.normal(size=3))
        assert np.allclose(model.moment(t, R, np.zeros(3), body), ref.moment(t, R, np.zeros(3), body),
                           rtol=1e-9, atol=0)
        assert np.isclose(model.potential(t, R, body), ref.potential(t, R, body), rtol=1e-9)
    assert np.all(np.isnan(model.moment(3000.1, np.eye(3), np.zeros(3), body)))       # past the table


def test_orbit_gravity_gradient_moment_is_minus_the_potentials_derivative():
    body = lgvi.RigidBody([10.0, 12.0, 8.0])
    model = OrbitGravityGradient(KeplerOrbit(8e6, 0.2, **ELEMENTS), body, duration=2000.0)
    R = lgvi.so3.exp(np.array([0.4, -1.0, 0.3]))
    M = model.moment(700.0, R, np.zeros(3), body)
    d = 1e-6
    grad = [(model.potential(700.0, R @ lgvi.so3.exp(d * e), body)
             - model.potential(700.0, R @ lgvi.so3.exp(-d * e), body)) / (2 * d) for e in np.eye(3)]
    assert np.allclose(M, -np.array(grad), rtol=1e-6, atol=0)
