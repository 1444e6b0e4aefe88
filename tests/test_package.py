"""The package as a user installs it: licence, citation, version, the example scenarios shipped in
the wheel (``lgvi example``), Numba's cache in the user's cache folder, the compile notice."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

import lgvi
from lgvi import _jit
from lgvi.cli import main
from lgvi.io import examples

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def test_licence_file_and_expression_agree():
    assert PYPROJECT["project"]["license"] == "MIT"
    assert PYPROJECT["project"]["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "WITHOUT WARRANTY OF ANY KIND" in text


def test_citation_names_the_paper_and_the_software():
    text = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert text.startswith("cff-version: 1.2.0")
    assert "A Computational Approach for Variational Integration of Attitude Dynamics on SO(3)" in text
    assert 'family-names: "Potu Surya Prakash"' in text and "University of California, Berkeley" in text
    assert "type: software" in text and "license: MIT" in text


def test_version_comes_from_the_tags():
    assert PYPROJECT["tool"]["hatch"]["version"]["source"] == "vcs"
    assert PYPROJECT["tool"]["hatch"]["version"]["fallback-version"]       # a tree without git builds too
    assert isinstance(lgvi.__version__, str) and lgvi.__version__


def test_every_example_scenario_ships_in_the_wheel():
    shipped = PYPROJECT["tool"]["hatch"]["build"]["targets"]["wheel"]["force-include"]
    on_disk = {f"examples/{p.name}": f"lgvi/_examples/{p.name}" for p in (ROOT / "examples").glob("*.toml")}
    assert shipped == on_disk
    assert examples.names() == sorted(p.stem for p in (ROOT / "examples").glob("*.toml"))


def test_lgvi_example_lists_and_writes(tmp_path, capsys, monkeypatch):
    assert main(["example"]) == 0
    listing = capsys.readouterr().out
    assert all(name in listing for name in examples.names())
    monkeypatch.chdir(tmp_path)
    assert main(["example", "heavy_top"]) == 0
    written = tmp_path / "heavy_top.toml"
    assert written.read_text(encoding="utf-8") == (ROOT / "examples" / "heavy_top.toml").read_text(encoding="utf-8")
    assert "lgvi run heavy_top.toml" in capsys.readouterr().out
    # an existing file is kept unless --force; an unknown name lists the known ones
    written.write_text("mine")
    assert main(["example", "heavy_top"]) == 2
    assert "exists" in capsys.readouterr().err and written.read_text() == "mine"
    assert main(["example", "heavy_top.toml", "--force"]) == 0
    assert written.read_text(encoding="utf-8").startswith("#")
    (tmp_path / "sub").mkdir()
    assert main(["example", "dzhanibekov", "-o", "sub"]) == 0 and (tmp_path / "sub" / "dzhanibekov.toml").is_file()
    assert main(["example", "nope"]) == 2
    err = capsys.readouterr().err
    assert "name='nope'" in err and "dzhanibekov" in err


def test_example_bad_name_type():
    with pytest.raises(TypeError, match="name must be a string"):
        examples.text(3)  # type: ignore[arg-type]


def test_user_cache_dir_follows_the_platform_convention(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert _jit.user_cache_dir() == str(tmp_path / "lgvi" / "numba")
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert _jit.user_cache_dir() == str(tmp_path / "home" / ".cache" / "lgvi" / "numba")
    monkeypatch.setattr(sys, "platform", "darwin")
    assert _jit.user_cache_dir() == str(tmp_path / "home" / "Library" / "Caches" / "lgvi" / "numba")


# A small kernel compiled in a fresh process: where its cache goes, and the notice (its threshold
# set to 0 s, so the notice is certain: said by the timer or, at the latest, at the compile's end).
PROBE = textwrap.dedent("""\
    import numpy as np
    from lgvi import _jit
    _jit.COMPILE_NOTICE_AFTER = 0.0
    from lgvi._kernels.orbit_table_kernels import orbit_gravity_gradient_potential
    orbit_gravity_gradient_potential(0.0, np.eye(3), np.zeros(16))
    print("OK")
    """)


def _probe(env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess:
    src = str(Path(lgvi.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([src] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
    return subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=env, cwd=cwd)


def test_numba_cache_goes_to_the_user_cache_folder_and_compiling_is_said(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "LGVI_"))}
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    run = _probe(env, tmp_path)
    assert run.returncode == 0 and "OK" in run.stdout, run.stderr
    assert list((tmp_path / "xdg" / "lgvi" / "numba").rglob("*.nbi")), "no cache index in the user cache folder"
    assert run.stderr.count("lgvi: compiling the kernel orbit_gravity_gradient_potential") == 1, run.stderr
    # the second process loads it from the cache: no compilation, nothing said
    again = _probe(env, tmp_path)
    assert again.returncode == 0 and "compiling" not in again.stderr, again.stderr


def test_numba_cache_dir_wins_when_set(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "LGVI_"))}
    env |= {"XDG_CACHE_HOME": str(tmp_path / "xdg"), "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    run = _probe(env, tmp_path)
    assert run.returncode == 0, run.stderr
    assert list((tmp_path / "numba").rglob("*.nbi")) and not (tmp_path / "xdg" / "lgvi").exists()
