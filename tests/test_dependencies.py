"""The declared dependency ranges are true (issue 19).

* ``requirements/floors.txt`` pins exactly the lowest versions that ``pyproject.toml`` declares
  (``make test`` runs the floors part of the suite against it), so the two cannot drift apart.
* The core (``import lgvi``, a simulation, a trajectory's quaternions) imports none of the optional
  extras: matplotlib, xarray, netCDF4, dask/distributed, pandas, sympy, hypothesis.
* SciPy < 1.12 rejects read-only arrays in ``Rotation.from_matrix`` (``ValueError: buffer source
  array is read-only``) and a ``Trajectory``'s arrays are read-only: lgvi must hand SciPy writable
  arrays. Checked here on any SciPy through a stand-in ``Rotation`` as strict as SciPy 1.11's, and
  for real by the floors run.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from packaging.version import Version
import scipy.spatial.transform
from scipy.spatial.transform import Rotation

import lgvi

ROOT = Path(__file__).resolve().parent.parent
FLOORS = ROOT / "requirements" / "floors.txt"
OPTIONAL = ("matplotlib", "xarray", "netCDF4", "dask", "distributed", "pandas", "sympy", "hypothesis", "plotly",
            "selenium", "sphinx")


def _canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _declared_floors() -> dict[str, Version]:
    """``{package: lowest version}`` of every ``>=`` requirement in pyproject.toml (core and extras)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    requirements = list(project["dependencies"])
    for extra in project["optional-dependencies"].values():
        requirements += extra
    floors: dict[str, Version] = {}
    for req in requirements:
        m = re.fullmatch(r"\s*([A-Za-z0-9_.-]+)(\[[^\]]*\])?\s*>=\s*([0-9][0-9A-Za-z.]*)\s*", req)
        if m is None:
            assert re.fullmatch(r"[A-Za-z0-9_.-]+", req), f"pyproject requirement {req!r}: give a floor 'name>=X'"
            continue  # unversioned (the bench extra's bsk): no promise to keep
        name, version = _canonical(m.group(1)), Version(m.group(3))
        assert floors.get(name, version) == version, f"{name}: two different floors in pyproject.toml"
        floors[name] = version
    return floors


def _pinned_floors() -> dict[str, Version]:
    pins: dict[str, Version] = {}
    for line in FLOORS.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            m = re.fullmatch(r"([A-Za-z0-9_.-]+)==([0-9][0-9A-Za-z.]*)", line)
            assert m is not None, f"{FLOORS.name}: {line!r} is not 'name==version'"
            pins[_canonical(m.group(1))] = Version(m.group(2))
    return pins


def test_floors_file_pins_exactly_the_declared_floors():
    assert _pinned_floors() == _declared_floors()


def test_floors_run_uses_the_floors():
    """In the floors environment (``make test`` sets LGVI_FLOORS=1), the installed versions are the pins."""
    import os
    from importlib.metadata import version

    if os.environ.get("LGVI_FLOORS") != "1":
        pytest.skip("not the floors environment")
    pins = {name: v for name, v in _pinned_floors().items() if name not in _validation_only()}
    installed = {name: Version(version(name)) for name in pins}
    assert installed == pins


def _validation_only() -> set[str]:
    """Packages of the ``validation`` extra alone: they need NumPy >= 2, so the floors environment
    (NumPy 1.24) does not install them (the Makefile's floors stage installs ``test`` and ``plot``)."""
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    name = lambda req: _canonical(re.split(r"[<>=\[ ]", req, maxsplit=1)[0])  # noqa: E731
    others = {name(r) for extra, reqs in extras.items() if extra not in ("validation", "atmosphere") for r in reqs}
    return {name(r) for r in extras["validation"]} - others


def test_validation_extra_is_not_in_the_floors_environment():
    """The floors stage cannot install astropy and pymsis (NumPy >= 2): they stay out of ``test``."""
    assert _validation_only() == {"astropy", "pymsis"}


def test_core_imports_no_optional_extra():
    code = (
        "import sys, numpy as np, lgvi\n"
        "traj = lgvi.simulate(lgvi.RigidBody([1.0, 2.0, 3.0]), np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=10)\n"
        "traj.quaternion, traj.energy, traj.spatial_momentum\n"
        f"print(sorted(m for m in {OPTIONAL!r} if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


class _StrictRotation:
    """``Rotation`` whose ``from_matrix`` rejects a read-only array as SciPy 1.11's does."""

    @staticmethod
    def from_matrix(matrix, *args, **kwargs):
        if isinstance(matrix, np.ndarray) and not matrix.flags.writeable:
            raise ValueError("buffer source array is read-only")
        return Rotation.from_matrix(matrix, *args, **kwargs)


@pytest.fixture
def strict_scipy(monkeypatch):
    monkeypatch.setattr(scipy.spatial.transform, "Rotation", _StrictRotation)


def test_trajectory_hands_scipy_writable_arrays(strict_scipy):
    traj = lgvi.simulate([1.0, 2.0, 3.0], np.eye(3), omega0=[0.3, 1.0, 0.2], h=0.01, steps=20)
    assert not traj.R.flags.writeable
    assert np.allclose(traj.rotation.as_matrix(), traj.R, rtol=0, atol=1e-12)
    q = traj.quaternion
    assert np.allclose(lgvi.so3.quat_to_matrix(q), traj.R, rtol=0, atol=1e-12)
    assert np.array_equal(traj.quaternions(scalar_first=True), q[:, [3, 0, 1, 2]])
    assert not traj.R.flags.writeable  # still read-only afterwards


def test_baselines_hand_scipy_writable_arrays(strict_scipy):
    from lgvi.verification import baselines

    R = lgvi.so3.exp(np.array([[0.1, 0.2, 0.3], [0.4, -0.1, 0.2]]))
    R.flags.writeable = False
    assert np.allclose(lgvi.so3.quat_to_matrix(baselines._quat_of(R)), R, rtol=0, atol=1e-12)


def test_kernel_cache_key_is_installed_on_this_numba():
    """lgvi keys its kernels' Numba cache by a hash of all kernel sources (see lgvi._jit) through
    Numba's locator classes, whose names differ between versions (underscored up to 0.61): if they
    were not found, the fallback (Numba's per-file stamp) would silently keep stale inlined code."""
    from lgvi import _jit
    from lgvi._kernels import stepping

    if not _jit.CACHE:
        pytest.skip("LGVI_NUMBA_CACHE=0: no cache, no key")
    locator = stepping.run_chunk._cache._impl.locator
    assert type(locator).__name__.startswith("Lgvi"), type(locator)
    assert locator.get_source_stamp() == ("lgvi-kernels", _jit._kernel_sources_hash())
