"""Shared fixtures of the core test suite: a few rigid bodies and the hypothesis profile.

Bodies
------
``diag_body``      J = diag(1, 2, 3): the paper-style example (a flat body: J3 = J1 + J2, Jd singular).
``full_body``      a full, non-diagonal SPD inertia: moments (1.0, 1.7, 2.4) turned by a fixed random
                   rotation Q (seeded), J = Q diag(m) Q^T, symmetrised exactly.
``near_flat_body`` moments (1, 2, 2.999) turned by another fixed rotation: Jd has one eigenvalue 5e-4,
                   the hard case for the Newton matrices.
``body``           parametrised over the three.

Hypothesis
----------
Profile ``"lgvi"`` (deadline off: the first call of a kernel may load or compile it; modest
``max_examples`` to keep the suite fast; ``derandomize``: the same examples on every run, so the
default suite, which CI runs, passes or fails reproducibly) is registered and loaded here, as
``"lgvi-active"``. Test modules pass ``settings.get_profile("lgvi-active")`` explicitly to
``@settings`` so another module's ``load_profile`` cannot change them.
``LGVI_HYPOTHESIS_PROFILE=lgvi-thorough`` selects a heavier random profile (400 fresh examples per
test) for exploring: run it when changing numerical code (with ``LGVI_EDGE_EXAMPLES=4000`` for
tests/test_edges.py), and turn what it finds into fixed cases or better bounds.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from scipy.spatial.transform import Rotation

import lgvi

def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C reaches the tests as it reaches a user: SIGINT raises KeyboardInterrupt in the main thread.

    A process started in the background by a shell without job control (``cmd &`` in a script,
    some CI runners and ``nohup`` wrappers) inherits SIGINT *ignored*, and Python then installs no
    handler: the tests that press Ctrl-C with ``os.kill(pid, SIGINT)`` would see nothing (a test
    whose member waits for the stop request would wait for ever). Python's own handler is put back
    here, in the main thread of the controller and of each xdist worker; processes the tests start
    inherit the default disposition and install it themselves. (tests/test_signals.py)
    """
    import signal
    import threading

    if (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.SIG_IGN):
        signal.signal(signal.SIGINT, signal.default_int_handler)


settings.register_profile(
    "lgvi", deadline=None, max_examples=25, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "lgvi-thorough", deadline=None, max_examples=400, suppress_health_check=[HealthCheck.too_slow]
)
#: The profile in force for this suite ("lgvi" unless LGVI_HYPOTHESIS_PROFILE names another).
settings.register_profile(
    "lgvi-active", parent=settings.get_profile(os.environ.get("LGVI_HYPOTHESIS_PROFILE", "lgvi"))
)
settings.load_profile("lgvi-active")


def rotated_inertia(moments, seed: int) -> np.ndarray:
    """``Q diag(moments) Q^T`` for a seeded random rotation ``Q``, exactly symmetric."""
    Q = Rotation.random(random_state=seed).as_matrix()
    J = Q @ np.diag(np.asarray(moments, dtype=float)) @ Q.T
    return 0.5 * (J + J.T)


@pytest.fixture(scope="session")
def diag_body() -> lgvi.RigidBody:
    return lgvi.RigidBody([1.0, 2.0, 3.0])


@pytest.fixture(scope="session")
def full_body() -> lgvi.RigidBody:
    b = lgvi.RigidBody(rotated_inertia([1.0, 1.7, 2.4], seed=7))
    assert not b.is_diagonal
    return b


@pytest.fixture(scope="session")
def near_flat_body() -> lgvi.RigidBody:
    b = lgvi.RigidBody(rotated_inertia([1.0, 2.0, 2.999], seed=11))
    assert np.linalg.eigvalsh(b.Jd)[0] == pytest.approx(5e-4, rel=1e-9)
    return b


@pytest.fixture(scope="session", params=["diag", "full", "near_flat"])
def body(request, diag_body, full_body, near_flat_body) -> lgvi.RigidBody:
    return {"diag": diag_body, "full": full_body, "near_flat": near_flat_body}[request.param]


@pytest.fixture(scope="session")
def R0() -> np.ndarray:
    """A generic initial attitude (not the identity, so R and R^T mix-ups show)."""
    return Rotation.from_rotvec([0.1, -0.2, 0.3]).as_matrix()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240611)
